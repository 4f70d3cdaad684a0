// Identification of the fixed-pole ARX form: parameter recovery, irregular probes, order and input
// selection, degenerate data, robust refinement, output-error route.
#include <catch2/catch.hpp>
#include <cmath>
#include <random>

#include "alc/thermal_model.hpp"
#include "synthetic_system.hpp"

using namespace alc;
using Catch::Matchers::WithinAbs;

namespace {

// The pole grid of identify() for the default options (same expression).
double grid_tau(int g, const IdentificationOptions& o = {}) {
  return o.tau_min_s * std::pow(o.tau_max_s / o.tau_min_s, double(g) / (o.pole_grid_size - 1));
}

std::vector<std::string> names_of(const ThermalModel& m) {
  std::vector<std::string> n;
  for (const OutputModel& o : m.outputs) n.push_back(o.name);
  return n;
}

}  // namespace

TEST_CASE("identify: recovers a known order-2 system from noiseless probes (CP 5 min, then 2 h)") {
  constexpr double kTol = 1e-6;  // [µm] per parameter; noiseless data, exact structure
  std::mt19937_64 rng(11);
  const InputHistory h = test::make_history(rng, 2 * 86400.0, 60.0);
  const ThermalModel truth = test::truth_model(
      h, {test::output_model("E_X0C", {0, 1}, {grid_tau(1), grid_tau(3)}, {1.5, 3.0, -1.2, 0.002, 0.001})});
  const Eigen::MatrixXd y = test::simulate(truth, h);
  const auto probes = test::probes_at(h, y, test::probe_samples(h, 6.5 * 3600.0, 300.0, 7200.0));
  IdentificationOptions o;
  o.robust_loss = RobustLoss::None;
  o.ridge = 0.0;  // the default relative ridge 1e-6 biases the gains by ~1e-5 µm
  const FitResult fit = identify(h, names_of(truth), probes, o);
  INFO(fit.message);
  REQUIRE(fit.usable);
  const OutputModel& m = fit.model.outputs.at(0);
  CHECK(m.order == 2);
  REQUIRE(m.inputs == std::vector<int>{0, 1});
  REQUIRE(m.parameters.size() == 5);
  for (Eigen::Index i = 0; i < 5; ++i) REQUIRE_THAT(m.parameters(i), WithinAbs(truth.outputs[0].parameters(i), kTol));
  CHECK_THAT(fit.outputs[0].residual_rms, WithinAbs(0.0, kTol));
  CHECK(fit.outputs[0].inputs_chosen == std::vector<std::string>{"T_ENV", "n_C"});

  constexpr double kRidgeTol = 1e-4;  // [µm] with the default ridge
  const FitResult with_ridge = identify(h, names_of(truth), probes, IdentificationOptions{});
  REQUIRE(with_ridge.usable);
  REQUIRE(with_ridge.model.outputs[0].parameters.size() == 5);
  for (Eigen::Index i = 0; i < 5; ++i)
    CHECK_THAT(with_ridge.model.outputs[0].parameters(i), WithinAbs(truth.outputs[0].parameters(i), kRidgeTol));
}

TEST_CASE("identify: classical ARX(1,1) difference equation is recovered as gain b/(1-a) and pole a") {
  constexpr double kTol = 1e-6;
  std::mt19937_64 rng(5);
  const InputHistory h = test::make_history(rng, 86400.0, 60.0);
  const double a = pole_of_time_constant(grid_tau(2), 60.0);
  const double b = 0.05;  // [µm/°C] per step
  // y[n+1] = a y[n] + b (u[n] - u[0]) with y[0] = 0; the probe at sample n reads y[n].
  Eigen::MatrixXd y = Eigen::MatrixXd::Zero(h.inputs.rows(), 1);
  for (Eigen::Index n = 1; n < h.inputs.rows(); ++n) y(n, 0) = a * y(n - 1, 0) + b * (h.inputs(n - 1, 0) - h.inputs(0, 0));
  const auto probes = test::probes_at(h, y, test::probe_samples(h, 6.5 * 3600.0, 300.0, 3600.0));
  IdentificationOptions o;
  o.robust_loss = RobustLoss::None;
  o.ridge = 0.0;
  const FitResult fit = identify(h, {"E_Y0C"}, probes, o);
  INFO(fit.message);
  REQUIRE(fit.usable);
  const OutputModel& m = fit.model.outputs.at(0);
  REQUIRE(m.order == 1);
  REQUIRE(m.inputs == std::vector<int>{0});
  REQUIRE_THAT(m.poles(0), WithinAbs(a, 1e-12));
  REQUIRE_THAT(m.parameters(0), WithinAbs(0.0, kTol));
  REQUIRE_THAT(m.parameters(1), WithinAbs(b / (1.0 - a), kTol));
}

TEST_CASE("identify: FitResult::predictor_state continues like a predictor stepped over the history") {
  std::mt19937_64 rng(3);
  const InputHistory h = test::make_history(rng, 86400.0, 60.0);
  const ThermalModel truth = test::truth_model(h, {test::output_model("E_X0C", {0}, {grid_tau(2)}, {0.5, 4.0})});
  const auto probes = test::probes_at(h, test::simulate(truth, h), test::probe_samples(h, 6.5 * 3600.0, 300.0, 7200.0));
  const FitResult fit = identify(h, {"E_X0C"}, probes, {});
  REQUIRE(fit.usable);
  ModelPredictor replayed(fit.model);
  for (Eigen::Index k = 0; k < h.inputs.rows(); ++k) replayed.step(h.time_s[static_cast<std::size_t>(k)], h.inputs.row(k).transpose());
  REQUIRE(replayed.state() == fit.predictor_state);
}
