#include "common/number_text.hpp"

#include <charconv>
#include <cctype>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace alc::common {

std::string shortest_text(double value) {
  if (std::isnan(value)) return "nan";  // to_chars would print "-nan" for a negative NaN
  char text[32];  // the longest shortest form, "-2.2250738585072014e-308", has 24 characters
  const auto result = std::to_chars(text, text + sizeof text, value);
  return std::string(text, result.ptr);
}

}  // namespace alc::common

namespace alc::common {

double parse_number(std::string_view what, std::string_view text, bool allow_inf) {
  const auto refuse = [&] {
    throw std::invalid_argument(std::string(what) + ": '" + std::string(text) + "' is not a number >= 0" +
                                (allow_inf ? " or inf" : ""));
  };
  if (text == "inf" || text == "Inf") {
    if (!allow_inf) refuse();
    return std::numeric_limits<double>::infinity();
  }
  // from_chars alone would take "nan", "inf", "infinity" and, after a sign, negatives: digits first.
  if (text.empty() || !(std::isdigit(static_cast<unsigned char>(text.front())) || text.front() == '.')) refuse();
  double v = 0.0;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, v, std::chars_format::general);
  if (ec == std::errc::result_out_of_range && ptr == end)  // 1e999, 1e-400: a number, but not a double's
    throw std::invalid_argument(std::string(what) + ": '" + std::string(text) +
                                "' is out of the range of a double (about 2.2e-308 to 1.8e308)");
  if (ec != std::errc() || ptr != end || !std::isfinite(v)) refuse();
  return v;
}

std::uint64_t parse_whole_number(std::string_view what, std::string_view text, std::uint64_t lo, std::uint64_t hi) {
  std::uint64_t v = 0;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, v);
  if (text.empty() || !std::isdigit(static_cast<unsigned char>(text.front())) || ec != std::errc() || ptr != end ||
      v < lo || v > hi)
    throw std::invalid_argument(std::string(what) + ": '" + std::string(text) + "' is not a whole number from " +
                                std::to_string(lo) + " to " + std::to_string(hi));
  return v;
}

}  // namespace alc::common
