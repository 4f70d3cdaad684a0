#include "alc/indicators.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace alc {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

bool valid_pair(std::span<const double> measured, std::span<const double> predicted) {
  return !measured.empty() && measured.size() == predicted.size();
}

std::vector<double> abs_residuals(std::span<const double> measured, std::span<const double> predicted) {
  std::vector<double> r(measured.size());
  for (std::size_t t = 0; t < r.size(); ++t) r[t] = std::abs(predicted[t] - measured[t]);
  return r;
}

}  // namespace

double peak_value_percent(std::span<const double> measured, std::span<const double> predicted) {
  if (!valid_pair(measured, predicted)) return kNaN;
  double peak_residual = 0.0;
  double peak_error = 0.0;
  for (std::size_t t = 0; t < measured.size(); ++t) {
    peak_residual = std::max(peak_residual, std::abs(measured[t] - predicted[t]));
    peak_error = std::max(peak_error, std::abs(measured[t]));
  }
  return peak_error > 0.0 ? peak_residual / peak_error * 100.0 : kNaN;
}

double rmse(std::span<const double> measured, std::span<const double> predicted) {
  if (!valid_pair(measured, predicted)) return kNaN;
  double ss = 0.0;
  for (std::size_t t = 0; t < measured.size(); ++t) ss += (predicted[t] - measured[t]) * (predicted[t] - measured[t]);
  return std::sqrt(ss / static_cast<double>(measured.size()));
}

double percentile(std::span<const double> values, double p) {
  if (values.empty() || !(p >= 0.0 && p <= 1.0)) return kNaN;
  std::vector<double> v(values.begin(), values.end());
  const auto n = static_cast<double>(v.size());
  const double p1 = 0.5 / n;
  const double pn = (n - 0.5) / n;
  const double x = p <= p1 ? 1.0 : (p >= pn ? n : n * p + 0.5);  // Eq. 4, 1-based rank
  const double fl = std::floor(x);
  const auto i = std::min(static_cast<std::size_t>(fl) - 1, v.size() - 1);  // 0-based index of v_[x]
  const double frac = x - fl;                                                // x % 1
  // The order statistics i and i + 1 of the sorted values, without sorting them all (a study asks
  // for thousands of P99s): the same two values, so the same result.
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(i), v.end());
  const double vi = v[i];
  if (i + 1 >= v.size() || frac == 0.0) return vi;
  const double next = *std::min_element(v.begin() + static_cast<std::ptrdiff_t>(i) + 1, v.end());
  return vi + frac * (next - vi);
}

double p99_abs_residual(std::span<const double> measured, std::span<const double> predicted) {
  if (!valid_pair(measured, predicted)) return kNaN;
  return percentile(abs_residuals(measured, predicted), 0.99);
}

double smape_percent(std::span<const double> measured, std::span<const double> predicted) {
  if (!valid_pair(measured, predicted)) return kNaN;
  double sum = 0.0;
  for (std::size_t t = 0; t < measured.size(); ++t) {
    const double den = std::abs(predicted[t]) + std::abs(measured[t]);
    if (den > 0.0) sum += std::abs(predicted[t] - measured[t]) / den;
  }
  return 100.0 * sum / static_cast<double>(measured.size());
}

}  // namespace alc
