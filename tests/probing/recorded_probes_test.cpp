// Replay probing: a scheduled probe at t takes the first recorded measurement at or after t.
#include <catch2/catch.hpp>
#include <limits>

#include "probing/recorded_probes.hpp"

TEST_CASE("recorded probes: first measurement at or after the due time") {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<double> t{0, 60, 120, 180, 240, 300};
  Eigen::MatrixXd e(6, 2);
  e << 1, nan,   //
      nan, nan,  //
      nan, 2,    // one output measured is a measurement
      nan, nan,  //
      nan, nan,  //
      3, 4;
  alc::probing::RecordedProbes probes(t, e);
  CHECK(probes.measured_rows() == std::vector<std::size_t>{0, 2, 5});
  CHECK(probes.first_at_or_after(0.0) == std::optional<std::size_t>(0));
  CHECK(probes.first_at_or_after(0.5) == std::optional<std::size_t>(2));
  CHECK(probes.first_at_or_after(120.0) == std::optional<std::size_t>(2));
  CHECK(probes.first_at_or_after(121.0) == std::optional<std::size_t>(5));
  CHECK_FALSE(probes.first_at_or_after(301.0).has_value());
  // Within 1 ms before a measurement counts as at it (a due time summed in doubles); more does not.
  CHECK(probes.first_at_or_after(120.0 + 1e-9) == std::optional<std::size_t>(2));
  CHECK(probes.first_at_or_after(120.0009) == std::optional<std::size_t>(2));
  CHECK(probes.first_at_or_after(120.002) == std::optional<std::size_t>(5));
  CHECK(probes.is_measured(2));
  CHECK_FALSE(probes.is_measured(3));
  CHECK_FALSE(probes.is_measured(99));
}

TEST_CASE("recorded probes: mismatched sizes are refused") {
  CHECK_THROWS_AS(alc::probing::RecordedProbes({0.0, 1.0}, Eigen::MatrixXd::Zero(3, 1)), std::invalid_argument);
}
