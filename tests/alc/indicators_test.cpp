// Indicators of seed 004 Eq. 1-7 against values worked out by hand.
#include <catch2/catch.hpp>
#include <cmath>
#include <vector>

#include "alc/indicators.hpp"

using namespace alc;
using Catch::Matchers::WithinAbs;

namespace {
constexpr double kTol = 1e-12;
// y and yhat: residuals yhat - y = {0.5, 1, -1, 0}, |residuals| sorted {0, 0.5, 1, 1}.
const std::vector<double> kMeasured{1.0, -2.0, 3.0, 4.0};
const std::vector<double> kPredicted{1.5, -1.0, 2.0, 4.0};
}  // namespace

TEST_CASE("indicators: PV, RMSE and SMAPE by hand") {
  // PV = max|res| / max|y| * 100 = 1 / 4 * 100
  REQUIRE_THAT(peak_value_percent(kMeasured, kPredicted), WithinAbs(25.0, kTol));
  // RMSE = sqrt((0.25 + 1 + 1 + 0) / 4) = 0.75
  REQUIRE_THAT(rmse(kMeasured, kPredicted), WithinAbs(0.75, kTol));
  // SMAPE = 100/4 * (0.5/2.5 + 1/3 + 1/5 + 0/8) = 25 * 11/15
  REQUIRE_THAT(smape_percent(kMeasured, kPredicted), WithinAbs(100.0 / 4.0 * (0.2 + 1.0 / 3.0 + 0.2), kTol));
}

TEST_CASE("indicators: SMAPE is bounded to 0..100 % and 0/0 counts as 0") {
  const std::vector<double> zero{0.0, 0.0};
  REQUIRE_THAT(smape_percent(zero, zero), WithinAbs(0.0, kTol));
  // prediction 0 for a non-zero error, and a sign flip: each term is 1, the upper bound
  REQUIRE_THAT(smape_percent(std::vector<double>{2.0, -1.0}, std::vector<double>{0.0, 1.0}), WithinAbs(100.0, kTol));
  // y = 0, yhat = 0 next to a perfect non-zero term: (0 + 0) / 2
  REQUIRE_THAT(smape_percent(std::vector<double>{0.0, 3.0}, std::vector<double>{0.0, 3.0}), WithinAbs(0.0, kTol));
}

TEST_CASE("indicators: percentile with the midpoint-rank interpolation of Eq. 3-5") {
  const std::vector<double> v{1.0, 0.0, 0.5, 1.0};  // sorted 0, 0.5, 1, 1; p_1 = 0.125, p_4 = 0.875
  REQUIRE_THAT(percentile(v, 0.5), WithinAbs(0.75, kTol));    // x = 2.5: 0.5 + 0.5 (1 - 0.5)
  REQUIRE_THAT(percentile(v, 0.3), WithinAbs(0.35, kTol));    // x = 1.7: 0 + 0.7 (0.5 - 0)
  REQUIRE_THAT(percentile(v, 0.375), WithinAbs(0.5, kTol));   // P = p_2: x = 2 exactly
  REQUIRE_THAT(percentile(v, 0.1), WithinAbs(0.0, kTol));     // P < p_1: x = 1
  REQUIRE_THAT(percentile(v, 0.0), WithinAbs(0.0, kTol));
  REQUIRE_THAT(percentile(v, 0.9), WithinAbs(1.0, kTol));     // P > p_n: x = n
  REQUIRE_THAT(percentile(v, 1.0), WithinAbs(1.0, kTol));
  const std::vector<double> ten{10, 9, 8, 7, 6, 5, 4, 3, 2, 1};
  REQUIRE_THAT(percentile(ten, 0.9), WithinAbs(9.5, kTol));   // x = 9.5
  REQUIRE_THAT(percentile(ten, 0.99), WithinAbs(10.0, kTol)); // 0.99 > p_10 = 0.95
  REQUIRE_THAT(percentile(ten, 0.12), WithinAbs(1.7, kTol));  // x = 1.7
  // n = 1: every P gives the single value
  for (const double p : {0.0, 0.3, 0.5, 0.99, 1.0}) REQUIRE_THAT(percentile(std::vector<double>{4.2}, p), WithinAbs(4.2, kTol));
  CHECK(std::isnan(percentile(std::vector<double>{}, 0.5)));
  CHECK(std::isnan(percentile(v, 1.5)));
}

TEST_CASE("indicators: P99 of absolute residuals, and with 200 values it interpolates") {
  REQUIRE_THAT(p99_abs_residual(kMeasured, kPredicted), WithinAbs(1.0, kTol));
  std::vector<double> y(200, 0.0);
  std::vector<double> yhat(200);
  for (int i = 0; i < 200; ++i) yhat[static_cast<std::size_t>(i)] = (i % 2 ? -1.0 : 1.0) * (i + 1);  // |res| = 1..200
  // x = 200 * 0.99 + 0.5 = 198.5: 198 + 0.5 (199 - 198)
  REQUIRE_THAT(p99_abs_residual(y, yhat), WithinAbs(198.5, kTol));
}

TEST_CASE("indicators: undefined indicators are NaN") {
  CHECK(std::isnan(rmse(std::vector<double>{}, std::vector<double>{})));
  CHECK(std::isnan(peak_value_percent(std::vector<double>{0.0}, std::vector<double>{1.0})));
}
