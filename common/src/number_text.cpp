#include "common/number_text.hpp"

#include <charconv>
#include <cmath>

namespace alc::common {

std::string shortest_text(double value) {
  if (std::isnan(value)) return "nan";  // to_chars would print "-nan" for a negative NaN
  char text[32];  // the longest shortest form, "-2.2250738585072014e-308", has 24 characters
  const auto result = std::to_chars(text, text + sizeof text, value);
  return std::string(text, result.ptr);
}

}  // namespace alc::common
