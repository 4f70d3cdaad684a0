// The static MLR baseline (seed 003 Eq. 7).
#include <catch2/catch.hpp>
#include <cmath>
#include <random>

#include "alc/static_regression.hpp"
#include "synthetic_system.hpp"

using namespace alc;
using Catch::Matchers::WithinAbs;

TEST_CASE("static regression: recovers y = b0 + sum b_i T_i from the inputs at the probe times") {
  constexpr double kTol = 1e-6;  // [µm] noiseless, relative ridge 1e-9
  std::mt19937_64 rng(8);
  const InputHistory h = test::make_history(rng, 86400.0, 60.0, 2);
  Eigen::MatrixXd y(h.inputs.rows(), 2);
  for (Eigen::Index k = 0; k < h.inputs.rows(); ++k) {
    y(k, 0) = 4.0 + 1.5 * h.inputs(k, 0) - 0.002 * h.inputs(k, 1);
    y(k, 1) = -1.0 + 3.0 * h.inputs(k, 3);
  }
  auto probes = test::probes_at(h, y, test::probe_samples(h, 6.5 * 3600.0, 300.0, 3600.0));
  probes[3].errors(1) = std::nan("");  // one output not measured in one cycle
  const StaticRegressionFit fit = fit_static_regression(h, {"E_X0C", "E_Y0C"}, probes, 1e-9);
  INFO(fit.message);
  REQUIRE(fit.usable);
  CHECK(fit.measurements == std::vector<int>{static_cast<int>(probes.size()), static_cast<int>(probes.size()) - 1});
  REQUIRE_THAT(fit.model.intercept(0), WithinAbs(4.0, 1e-4));
  REQUIRE_THAT(fit.model.coefficients(0, 0), WithinAbs(1.5, kTol));
  REQUIRE_THAT(fit.model.coefficients(0, 1), WithinAbs(-0.002, kTol));
  REQUIRE_THAT(fit.model.coefficients(1, 3), WithinAbs(3.0, kTol));
  const Eigen::VectorXd p = fit.model.predict(h.inputs.row(100).transpose());
  REQUIRE_THAT(p(0), WithinAbs(y(100, 0), 1e-4));
  REQUIRE_THAT(p(1), WithinAbs(y(100, 1), 1e-4));
}

TEST_CASE("static regression: constant inputs, collinear inputs and too few measurements stay finite") {
  std::mt19937_64 rng(9);
  InputHistory h = test::make_history(rng, 86400.0, 60.0, 1);
  h.inputs.col(2).setConstant(1.0);                          // FLUID always on
  h.inputs.col(3) = 2.0 * h.inputs.col(0).array() + 1.0;    // T_1 collinear with T_ENV
  Eigen::MatrixXd y(h.inputs.rows(), 1);
  y.col(0) = 2.0 * h.inputs.col(0).array() - 40.0;
  const auto probes = test::probes_at(h, y, test::probe_samples(h, 6.5 * 3600.0, 300.0, 3600.0));
  const StaticRegressionFit fit = fit_static_regression(h, {"E_X0C"}, probes);
  REQUIRE(fit.usable);
  CHECK(fit.model.coefficients(0, 2) == 0.0);
  REQUIRE(fit.model.coefficients.allFinite());
  REQUIRE_THAT(fit.model.predict(h.inputs.row(500).transpose())(0), WithinAbs(y(500, 0), 1e-3));
  const std::vector<ProbeRecord> two(probes.begin(), probes.begin() + 1);
  const StaticRegressionFit few = fit_static_regression(h, {"E_X0C"}, two);
  CHECK_FALSE(few.usable);
  CHECK(few.message.find("only 1 measurements") != std::string::npos);
  REQUIRE(few.model.predict(h.inputs.row(0).transpose()).allFinite());
}
