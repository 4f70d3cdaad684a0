#include "nc_interface/nc_number.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string_view>

namespace alc::nc {

long long nc_ticks(double value) {
  if (!std::isfinite(value) || std::abs(value) > kMaxNcMagnitude) {
    char text[64];
    std::snprintf(text, sizeof text, "%g", value);
    throw std::domain_error(std::string("NC number out of range: ") + text + " (allowed: finite, |value| <= 1e6)");
  }
  // Round the shortest decimal text of the value (what a person reads in the JSON), not its binary
  // expansion: 0.00015 is 1.4999…e-4 in binary but prints and rounds as 0.0002.
  char shortest[400];
  const auto [end, ec] = std::to_chars(shortest, shortest + sizeof shortest, std::abs(value), std::chars_format::fixed);
  if (ec != std::errc()) throw std::domain_error("NC number cannot be formatted");
  const std::string_view text(shortest, static_cast<std::size_t>(end - shortest));
  const std::size_t point = text.find('.');
  const std::string_view whole = text.substr(0, point);
  const std::string_view fraction = point == std::string_view::npos ? std::string_view() : text.substr(point + 1);
  long long magnitude = 0;  // [0.0001 mm] or [0.0001°]
  for (char ch : whole) magnitude = magnitude * 10 + (ch - '0');
  for (std::size_t i = 0; i < 4; ++i) magnitude = magnitude * 10 + (i < fraction.size() ? fraction[i] - '0' : 0);
  if (fraction.size() > 4 && fraction[4] >= '5') ++magnitude;  // half away from zero
  return value < 0.0 ? -magnitude : magnitude;
}

double as_printed(double value) { return static_cast<double>(nc_ticks(value)) / kNcTicksPerUnit; }

double with_base(double base, double offset) {
  return static_cast<double>(nc_ticks(base) + nc_ticks(offset)) / kNcTicksPerUnit;
}

std::string format_nc_number(double value, SignStyle sign) {
  const long long ticks = nc_ticks(value);
  const long long magnitude = ticks < 0 ? -ticks : ticks;
  std::string out;
  if (ticks < 0) out = "-";
  else if (sign == SignStyle::Always) out = "+";
  char digits[48];
  std::snprintf(digits, sizeof digits, "%lld.%04lld", magnitude / 10000, magnitude % 10000);
  return out + digits;
}

}  // namespace alc::nc
