#pragma once
// Rounding to a sensor's or a writer's resolution.
#include <cmath>

namespace alc::common {

// Rounds to a multiple of `resolution` (a sensor's quantisation, or rounding before writing).
// Below 1, divides by the integer scale (100 for 0.01) so that the result is the double nearest
// the decimal value and the shortest-text writer prints 21.37, not 21.370000000000001.
inline double quantise(double value, double resolution) {
  if (resolution >= 1.0) return std::round(value / resolution) * resolution;
  const double scale = std::round(1.0 / resolution);
  return std::round(value * scale) / scale;
}

}  // namespace alc::common
