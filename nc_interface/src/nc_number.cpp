#include "nc_interface/nc_number.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>

namespace alc::nc {

std::string format_nc_number(double value, SignStyle sign) {
  if (!std::isfinite(value) || std::abs(value) > kMaxNcMagnitude) {
    char text[64];
    std::snprintf(text, sizeof text, "%g", value);
    throw std::domain_error(std::string("NC number out of range: ") + text + " (allowed: finite, |value| <= 1e6)");
  }
  const long long ticks = std::llround(value * 1e4);  // [0.0001 mm] or [0.0001°]
  const long long magnitude = std::llabs(ticks);
  std::string out;
  if (ticks < 0) out = "-";
  else if (sign == SignStyle::Always) out = "+";
  char digits[48];
  std::snprintf(digits, sizeof digits, "%lld.%04lld", magnitude / 10000, magnitude % 10000);
  return out + digits;
}

}  // namespace alc::nc
