// F-test p-values against printed tables of the F distribution's critical values.
#include <catch2/catch.hpp>
#include <cmath>

#include "alc/statistics.hpp"

using namespace alc;
using Catch::Matchers::WithinAbs;

TEST_CASE("statistics: F distribution upper tail at tabulated critical values") {
  // F_{0.05}(1, 10) = 4.965, F_{0.05}(5, 20) = 2.711, F_{0.01}(2, 30) = 5.390, F_{0.01}(3, 60) = 4.126.
  CHECK_THAT(f_distribution_sf(4.9646, 1, 10), WithinAbs(0.05, 2e-5));
  CHECK_THAT(f_distribution_sf(2.7109, 5, 20), WithinAbs(0.05, 2e-5));
  CHECK_THAT(f_distribution_sf(5.3903, 2, 30), WithinAbs(0.01, 2e-5));
  CHECK_THAT(f_distribution_sf(4.1259, 3, 60), WithinAbs(0.01, 2e-5));
  // d1 = 2: closed form P(F > f) = (1 + 2 f / d2)^(-d2 / 2).
  for (double f : {0.1, 1.0, 3.0, 12.0})
    CHECK_THAT(f_distribution_sf(f, 2, 17), WithinAbs(std::pow(1.0 + 2.0 * f / 17.0, -8.5), 1e-13));
  CHECK(f_distribution_sf(0.0, 3, 9) == 1.0);
  CHECK(f_distribution_sf(INFINITY, 3, 9) == 0.0);
  CHECK(std::isnan(f_distribution_sf(1.0, 0.0, 9)));
  CHECK(std::isnan(f_distribution_sf(NAN, 2, 9)));
}

TEST_CASE("statistics: regularised incomplete beta at its symmetries and edges") {
  CHECK_THAT(regularized_incomplete_beta(0.3, 1.0, 1.0), WithinAbs(0.3, 1e-15));              // uniform
  CHECK_THAT(regularized_incomplete_beta(0.5, 4.5, 4.5), WithinAbs(0.5, 1e-14));              // symmetric
  CHECK_THAT(regularized_incomplete_beta(0.2, 2.0, 3.0) + regularized_incomplete_beta(0.8, 3.0, 2.0),
             WithinAbs(1.0, 1e-14));                                                           // I_x(a,b) = 1 - I_{1-x}(b,a)
  CHECK_THAT(regularized_incomplete_beta(0.2, 2.0, 1.0), WithinAbs(0.04, 1e-15));             // x^a for b = 1
  CHECK(regularized_incomplete_beta(0.0, 2.0, 3.0) == 0.0);
  CHECK(regularized_incomplete_beta(1.0, 2.0, 3.0) == 1.0);
  CHECK(std::isnan(regularized_incomplete_beta(1.5, 2.0, 3.0)));
}
