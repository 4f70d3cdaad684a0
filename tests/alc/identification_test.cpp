// Identification of the fixed-pole ARX form: parameter recovery, irregular probes, order and input
// selection, degenerate data, robust refinement, output-error route.
#include <catch2/catch.hpp>
#include <algorithm>
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

// For noiseless data of an exactly representable system: plain least squares without ridge (the
// default relative ridge 1e-5 biases the gains by ~5e-4 µm).
IdentificationOptions exact_options() {
  IdentificationOptions o;
  o.robust_loss = RobustLoss::None;
  o.ridge = 0.0;
  return o;
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
      h, {test::output_model("E_X0C", {0, 1}, {grid_tau(2), grid_tau(4)}, {1.5, 3.0, -1.2, 0.002, 0.001})});
  const Eigen::MatrixXd y = test::simulate(truth, h);
  const auto probes = test::probes_at(h, y, test::probe_samples(h, 6.5 * 3600.0, 300.0, 7200.0));
  const FitResult fit = identify(h, names_of(truth), probes, exact_options());
  INFO(fit.message);
  REQUIRE(fit.usable);
  const OutputModel& m = fit.model.outputs.at(0);
  CHECK(m.order == 2);
  REQUIRE(m.inputs == std::vector<int>{0, 1});
  REQUIRE(m.parameters.size() == 5);
  for (Eigen::Index i = 0; i < 5; ++i) REQUIRE_THAT(m.parameters(i), WithinAbs(truth.outputs[0].parameters(i), kTol));
  CHECK_THAT(fit.outputs[0].residual_rms, WithinAbs(0.0, kTol));
  CHECK(fit.outputs[0].inputs_chosen == std::vector<std::string>{"T_ENV", "n_C"});

  constexpr double kRidgeTol = 1e-3;  // [µm] with the default relative ridge 1e-5 (bias ~5e-4)
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
  const FitResult fit = identify(h, {"E_Y0C"}, probes, exact_options());
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
  ModelPredictor resumed(fit.model);
  resumed.set_state(fit.predictor_state);
  REQUIRE((resumed.prediction().array() == replayed.prediction().array()).all());
}

TEST_CASE("identify: parameters lie within their confidence under seeded noise") {
  constexpr double kSigma = 0.2;       // [µm] probe noise
  constexpr double kCoverage = 4.0;    // [-] standard errors allowed per parameter
  for (const std::uint64_t seed : {21u, 22u, 23u}) {
    std::mt19937_64 rng(seed);
    const InputHistory h = test::make_history(rng, 2 * 86400.0, 60.0);
    const ThermalModel truth = test::truth_model(
        h, {test::output_model("E_X0C", {0, 1}, {grid_tau(2), grid_tau(4)}, {1.5, 3.0, -1.2, 0.002, 0.001})});
    const auto probes = test::probes_at(h, test::simulate(truth, h), test::probe_samples(h, 6.5 * 3600.0, 300.0, 3600.0), &rng, kSigma);
    IdentificationOptions o;
    o.robust_loss = RobustLoss::None;
    const FitResult fit = identify(h, {"E_X0C"}, probes, o);
    REQUIRE(fit.usable);
    const OutputModel& m = fit.model.outputs[0];
    REQUIRE(m.inputs == std::vector<int>{0, 1});
    REQUIRE(m.order == 2);
    const Eigen::VectorXd& sd = fit.outputs[0].parameter_std;
    for (Eigen::Index i = 0; i < 5; ++i) {
      INFO("seed " << seed << " parameter " << i << " sd " << sd(i));
      REQUIRE(std::isfinite(sd(i)));
      REQUIRE_THAT(m.parameters(i), WithinAbs(truth.outputs[0].parameters(i), kCoverage * sd(i)));
    }
    CHECK_THAT(fit.outputs[0].residual_rms, WithinAbs(kSigma, 0.5 * kSigma));
  }
}

TEST_CASE("identify: irregular probe times (5 min, then 1-6 h) between 15 s input samples") {
  constexpr double kTol = 1e-6;  // [µm] noiseless
  std::mt19937_64 rng(77);
  const InputHistory h = test::make_history(rng, 3 * 86400.0, 15.0);
  const ThermalModel truth = test::truth_model(
      h, {test::output_model("E_Z0T", {0, 2}, {grid_tau(2), grid_tau(4)}, {-0.7, 5.0, 2.0, -3.0, 1.0})});
  const Eigen::MatrixXd y = test::simulate(truth, h);
  std::vector<ProbeRecord> probes;
  std::uniform_real_distribution<double> hours(1.0, 6.0);
  for (double t = 300.0; t < h.time_s.back(); t += t < 6.5 * 3600.0 ? 300.0 : 3600.0 * hours(rng)) {
    ProbeRecord p;
    p.time_s = t + 7.0;  // between samples: identify uses the sample at or before
    const auto k = static_cast<Eigen::Index>(std::floor(p.time_s / 15.0));
    p.errors = y.row(k).transpose();
    probes.push_back(p);
  }
  const FitResult fit = identify(h, {"E_Z0T"}, probes, exact_options());
  INFO(fit.message);
  REQUIRE(fit.usable);
  const OutputModel& m = fit.model.outputs[0];
  REQUIRE(m.inputs == std::vector<int>{0, 2});
  REQUIRE(m.order == 2);
  for (Eigen::Index i = 0; i < 5; ++i) REQUIRE_THAT(m.parameters(i), WithinAbs(truth.outputs[0].parameters(i), kTol));
}

// AIC is left out: its penalty of 2 per parameter picks a higher order now and then (known overfit).
TEST_CASE("identify: order selection finds the true order (1, 2, 3) with BIC and hold-out") {
  constexpr double kSigma = 0.05;  // [µm]
  struct Case {
    std::vector<double> tau;
    std::vector<double> parameters;
  };
  const std::vector<Case> cases{
      {{grid_tau(3)}, {0.5, 4.0, 0.003}},
      {{grid_tau(1), grid_tau(4)}, {0.5, 4.0, -3.0, 0.002, 0.003}},
      {{grid_tau(1), grid_tau(3), grid_tau(5)}, {0.5, 4.0, -6.0, 3.0, 0.002, -0.004, 0.003}},
  };
  for (const StructureCriterion criterion : {StructureCriterion::BIC, StructureCriterion::HoldOut}) {
    for (std::size_t c = 0; c < cases.size(); ++c) {
      std::mt19937_64 rng(100 + c);
      const InputHistory h = test::make_history(rng, 3 * 86400.0, 60.0);
      const ThermalModel truth = test::truth_model(h, {test::output_model("E_X0C", {0, 1}, cases[c].tau, cases[c].parameters)});
      const auto probes = test::probes_at(h, test::simulate(truth, h), test::probe_samples(h, 12 * 3600.0, 300.0, 1800.0), &rng, kSigma);
      IdentificationOptions o;
      o.criterion = criterion;
      const FitResult fit = identify(h, {"E_X0C"}, probes, o);
      INFO("criterion " << static_cast<int>(criterion) << " true order " << c + 1 << ": " << fit.message);
      REQUIRE(fit.usable);
      CHECK(fit.model.outputs[0].order == static_cast<int>(c + 1));
      CHECK(fit.model.outputs[0].inputs == std::vector<int>{0, 1});
    }
  }
}

TEST_CASE("identify: 16 temperatures and 80 measurements do not overfit") {
  constexpr double kSigma = 0.3;  // [µm]
  std::mt19937_64 rng(2024);
  const InputHistory h = test::make_history(rng, 3 * 86400.0, 60.0, 13);  // T_ENV, n_C, FLUID + 13 = 16 inputs
  REQUIRE(h.input_names.size() == 16);
  const ThermalModel truth = test::truth_model(
      h, {test::output_model("E_X0C", {0, 1, 5}, {grid_tau(1), grid_tau(2)}, {1.0, 3.0, 1.0, 0.002, 0.001, 2.0, 1.0})});
  const Eigen::MatrixXd y = test::simulate(truth, h);
  // 40 calibration probes every 5 min, then 40 hourly ones
  auto samples = test::probe_samples(h, 40 * 300.0, 300.0, 3600.0);
  samples.resize(80);
  const auto probes = test::probes_at(h, y, samples, &rng, kSigma);
  REQUIRE(probes.size() == 80);
  // held out: every sample of the next day after the measurements
  const auto held_out_rmse = [&](const FitResult& fit) {
    ModelPredictor p(fit.model);
    double ss = 0.0;
    int n = 0;
    for (Eigen::Index k = 0; k < h.inputs.rows(); ++k) {
      const double v = p.step(h.time_s[static_cast<std::size_t>(k)], h.inputs.row(k).transpose())(0);
      if (h.time_s[static_cast<std::size_t>(k)] > probes.back().time_s && h.time_s[static_cast<std::size_t>(k)] < probes.back().time_s + 86400.0) {
        ss += (v - y(k, 0)) * (v - y(k, 0));
        ++n;
      }
    }
    return std::sqrt(ss / n);
  };
  double signal = 0.0;
  for (Eigen::Index k = 0; k < y.rows(); ++k) signal = std::max(signal, std::abs(y(k, 0)));
  const FitResult selected = identify(h, {"E_X0C"}, probes, {});
  INFO(selected.message);
  REQUIRE(selected.usable);
  CHECK(selected.model.outputs[0].inputs.size() <= 6);
  // The inputs the errors depend on are among the chosen (the extra sensors mix T_ENV, so one of them
  // may come along as a near-copy, but none of the 13 replaces a true input).
  const std::vector<int>& chosen = selected.model.outputs[0].inputs;
  for (const int true_input : truth.outputs[0].inputs) {
    INFO("true input " << h.input_names[static_cast<std::size_t>(true_input)]);
    CHECK(std::find(chosen.begin(), chosen.end(), true_input) != chosen.end());
  }
  const double rmse_selected = held_out_rmse(selected);
  INFO("held-out RMSE " << rmse_selected << " µm, signal peak " << signal << " µm, inputs "
                        << selected.model.outputs[0].inputs.size());
  REQUIRE(std::isfinite(rmse_selected));
  REQUIRE(rmse_selected < 0.1 * signal);
  REQUIRE(rmse_selected < 3.0 * kSigma);
  IdentificationOptions all;
  all.select_inputs = false;
  all.max_order = 1;
  const FitResult everything = identify(h, {"E_X0C"}, probes, all);
  REQUIRE(everything.model.outputs[0].inputs.size() == 16);
  if (everything.usable) CHECK(rmse_selected < held_out_rmse(everything));
}

TEST_CASE("identify: the p-value of each chosen input separates the inputs the errors depend on") {
  std::mt19937_64 rng(77);
  const InputHistory h = test::make_history(rng, 3 * 86400.0, 60.0);  // T_ENV, n_C, FLUID
  const ThermalModel truth =
      test::truth_model(h, {test::output_model("E_X0C", {0, 1}, {grid_tau(2), grid_tau(4)}, {0.5, 3.0, 1.0, 0.002, 0.001})});
  const auto probes = test::probes_at(h, test::simulate(truth, h), test::probe_samples(h, 6.5 * 3600.0, 300.0, 3600.0), &rng, 0.3);
  IdentificationOptions forced;
  forced.select_inputs = false;  // FLUID is kept although the errors do not depend on it
  const FitResult fit = identify(h, {"E_X0C"}, probes, forced);
  REQUIRE(fit.usable);
  REQUIRE(fit.outputs[0].inputs_chosen == std::vector<std::string>{"T_ENV", "n_C", "FLUID"});
  const auto& p = fit.outputs[0].input_p_values;
  REQUIRE(p.size() == 3);
  INFO("p-values " << p[0] << ", " << p[1] << ", " << p[2]);
  CHECK(p[0] < 1e-6);
  CHECK(p[1] < 1e-6);
  CHECK(p[2] > 0.01);
  // Forward selection by BIC keeps only inputs that are significant at least at the 5 % level.
  const FitResult selected = identify(h, {"E_X0C"}, probes, {});
  REQUIRE(selected.usable);
  REQUIRE(selected.outputs[0].input_p_values.size() == selected.outputs[0].inputs_chosen.size());
  for (const double v : selected.outputs[0].input_p_values) CHECK(v < 0.05);
  // A refit keeps the structure and does not test it again.
  CHECK(refit(h, {"E_X0C"}, probes, {}, selected.model).outputs[0].input_p_values.empty());
}

TEST_CASE("identify: degenerate data gives no NaN and says why it is not usable") {
  std::mt19937_64 rng(6);
  InputHistory h = test::make_history(rng, 86400.0, 60.0);
  const ThermalModel truth = test::truth_model(h, {test::output_model("E_X0C", {0}, {grid_tau(2)}, {0.5, 4.0})});
  const Eigen::MatrixXd y = test::simulate(truth, h);
  const auto samples = test::probe_samples(h, 6.5 * 3600.0, 300.0, 3600.0);
  const auto probes = test::probes_at(h, y, samples);

  SECTION("every input constant") {
    InputHistory flat = h;
    for (Eigen::Index i = 0; i < flat.inputs.cols(); ++i) flat.inputs.col(i).setConstant(flat.inputs(0, i));
    const FitResult fit = identify(flat, {"E_X0C"}, probes, {});
    CHECK_FALSE(fit.usable);
    CHECK_THAT(fit.message, Catch::Matchers::Contains("constant") && Catch::Matchers::Contains("T_ENV"));
    CHECK(fit.outputs.at(0).message.find("constant") != std::string::npos);
  }
  SECTION("two measurements") {
    const std::vector<ProbeRecord> two(probes.begin(), probes.begin() + 2);
    const FitResult fit = identify(h, {"E_X0C"}, two, {});
    CHECK_FALSE(fit.usable);
    CHECK_THAT(fit.message, Catch::Matchers::Contains("only 2 measurements"));
  }
  SECTION("collinear sensors: finite, usable, predicts like the truth") {
    InputHistory twin = h;
    twin.input_names.push_back("T_COPY");
    InputMatrix wide(h.inputs.rows(), 4);
    wide.leftCols(3) = h.inputs.matrix();
    wide.col(3) = 2.0 * h.inputs.col(0).array() + 3.0;  // a second sensor on the same spot
    twin.inputs = std::move(wide);
    IdentificationOptions o;
    o.select_inputs = false;
    const FitResult fit = identify(twin, {"E_X0C"}, probes, o);
    INFO(fit.message);
    REQUIRE(fit.usable);
    REQUIRE(fit.model.outputs[0].parameters.allFinite());
    const Eigen::MatrixXd pred = test::simulate(fit.model, twin);
    REQUIRE(pred.allFinite());
    CHECK((pred.col(0) - y.col(0)).cwiseAbs().maxCoeff() < 0.05);
    // The summary says how ill-conditioned the regressor is: the copy makes it singular.
    const FitResult plain = identify(h, {"E_X0C"}, probes, o);
    REQUIRE(plain.usable);
    INFO("condition " << fit.outputs[0].condition << " with the copy, " << plain.outputs[0].condition << " without");
    CHECK(std::isfinite(plain.outputs[0].condition));
    CHECK(fit.outputs[0].condition > 1e6 * plain.outputs[0].condition);
  }
  SECTION("a fit that would extrapolate wildly between the probes is rejected") {
    IdentificationOptions o;
    o.output_limit_factor = 1.0;  // the truth itself peaks between the probes above the largest probe
    o.robust_scale_lin = 0.01;    // and the floor of the bound (20 robust scales) stays below it
    std::vector<ProbeRecord> sparse;
    for (std::size_t j = 0; j < probes.size(); j += 12) sparse.push_back(probes[j]);
    const FitResult fit = identify(h, {"E_X0C"}, sparse, o);
    REQUIRE_FALSE(fit.usable);
    CHECK_THAT(fit.message, Catch::Matchers::Contains("beyond the bound"));
    for (const OutputModel& m : fit.model.outputs) CHECK(m.parameters.allFinite());
  }
  SECTION("no history, invalid options, wrong sizes") {
    CHECK_FALSE(identify({}, {"E_X0C"}, probes, {}).usable);
    IdentificationOptions bad;
    bad.max_order = -2;
    const FitResult fit = identify(h, {"E_X0C"}, probes, bad);
    CHECK_FALSE(fit.usable);
    CHECK_THAT(fit.message, Catch::Matchers::Contains("max_order = -2"));
    CHECK_FALSE(identify(h, {}, probes, {}).usable);
  }
}

TEST_CASE("identify: the robust (Huber/Cauchy) fit ignores an outlier probe, least squares does not") {
  constexpr double kTol = 0.05;  // [µm] on the gain of 4 µm/°C
  std::mt19937_64 rng(12);
  const InputHistory h = test::make_history(rng, 86400.0, 60.0);
  const ThermalModel truth = test::truth_model(h, {test::output_model("E_X0C", {0}, {grid_tau(2)}, {0.5, 4.0})});
  auto probes = test::probes_at(h, test::simulate(truth, h), test::probe_samples(h, 6.5 * 3600.0, 300.0, 3600.0), &rng, 0.05);
  probes[40].errors(0) += 40.0;  // a chip on the sphere
  IdentificationOptions o;
  o.select_inputs = false;
  o.max_order = 1;
  o.pole_grid_size = 1;
  o.tau_min_s = o.tau_max_s = grid_tau(2);
  o.robust_loss = RobustLoss::None;
  const FitResult ls = identify(h, {"E_X0C"}, probes, o);
  for (const RobustLoss loss : {RobustLoss::Huber, RobustLoss::Cauchy}) {
    o.robust_loss = loss;
    const FitResult robust = identify(h, {"E_X0C"}, probes, o);
    REQUIRE(robust.usable);
    const auto& s = robust.outputs[0];
    INFO("loss " << static_cast<int>(loss) << " cost " << s.cost_before << " -> " << s.cost_after);
    CHECK(s.cost_after < s.cost_before);
    REQUIRE_THAT(robust.model.outputs[0].parameters(1), WithinAbs(4.0, kTol));
    CHECK(std::abs(ls.model.outputs[0].parameters(0) - 0.5) > std::abs(robust.model.outputs[0].parameters(0) - 0.5));
  }
}

TEST_CASE("identify: window_start_s and forgetting follow a changed machine") {
  constexpr double kTol = 0.02;  // [µm/°C]
  std::mt19937_64 rng(31);
  const InputHistory h = test::make_history(rng, 2 * 86400.0, 60.0);
  const ThermalModel before = test::truth_model(h, {test::output_model("E_X0C", {0}, {grid_tau(2)}, {0.0, 4.0})});
  const ThermalModel after = test::truth_model(h, {test::output_model("E_X0C", {0}, {grid_tau(2)}, {0.0, 2.0})});
  const Eigen::MatrixXd y0 = test::simulate(before, h);
  const Eigen::MatrixXd y1 = test::simulate(after, h);
  const double change = 86400.0;
  Eigen::MatrixXd y = y0;
  for (Eigen::Index k = 0; k < y.rows(); ++k)
    if (h.time_s[static_cast<std::size_t>(k)] >= change) y(k, 0) = y1(k, 0);
  const auto probes = test::probes_at(h, y, test::probe_samples(h, 2 * 86400.0, 600.0, 600.0));
  IdentificationOptions o;
  o.select_inputs = false;
  o.max_order = 1;
  o.robust_loss = RobustLoss::None;
  o.window_start_s = change + 3600.0;
  const FitResult windowed = identify(h, {"E_X0C"}, probes, o);
  REQUIRE(windowed.usable);
  // the T_ENV gain of the new machine, whatever the offset after the jump
  REQUIRE_THAT(windowed.model.outputs[0].parameters(1), WithinAbs(2.0, kTol));
  REQUIRE(windowed.outputs[0].measurements < static_cast<int>(probes.size()) / 2);
  o.window_start_s = -kInf;
  const FitResult all = identify(h, {"E_X0C"}, probes, o);
  o.forgetting_half_life_s = 3600.0;
  const FitResult forgetting = identify(h, {"E_X0C"}, probes, o);
  REQUIRE(forgetting.usable);
  CHECK(std::abs(forgetting.model.outputs[0].parameters(1) - 2.0) < std::abs(all.model.outputs[0].parameters(1) - 2.0));
}

TEST_CASE("identify: the output-error route refines time constants that are not on the grid") {
  std::mt19937_64 rng(55);
  const InputHistory h = test::make_history(rng, 3 * 86400.0, 60.0);
  const ThermalModel truth = test::truth_model(h, {test::output_model("E_X0C", {0, 1}, {2500.0}, {0.3, 4.0, 0.003})});
  const Eigen::MatrixXd y = test::simulate(truth, h);
  const auto probes = test::probes_at(h, y, test::probe_samples(h, 6.5 * 3600.0, 300.0, 7200.0), &rng, 0.05);
  IdentificationOptions o;
  o.max_order = 1;
  const FitResult fixed = identify(h, {"E_X0C"}, probes, o);
  o.method = IdentificationMethod::OutputError;
  const FitResult oe = identify(h, {"E_X0C"}, probes, o);
  INFO(oe.message << " / " << (oe.outputs.empty() ? "" : oe.outputs[0].message));
  REQUIRE(oe.usable);
  REQUIRE(oe.outputs[0].time_constants_s.size() == 1);
  CHECK_THAT(oe.outputs[0].time_constants_s[0], WithinAbs(2500.0, 100.0));
  const auto err = [&](const FitResult& f) { return (test::simulate(f.model, h) - y).cwiseAbs().maxCoeff(); };
  CHECK(err(oe) < err(fixed));
}

TEST_CASE("identify: seeded random data never gives NaN, and an unusable fit always says why") {
  // Random histories with constant, collinear, NaN-free and gappy inputs; random probes with
  // outliers, NaN cells, zero weights and duplicates. Invariants only.
  for (std::uint64_t seed = 1; seed <= 30; ++seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    InputHistory h = test::make_history(rng, (0.3 + 2.0 * u(rng)) * 86400.0, u(rng) < 0.5 ? 15.0 : 60.0,
                                        static_cast<int>(4 * u(rng)));
    if (u(rng) < 0.3) h.inputs.col(1).setConstant(1000.0);
    if (h.inputs.cols() > 3 && u(rng) < 0.5) h.inputs.col(3) = h.inputs.col(0);
    if (u(rng) < 0.2) h.time_s.back() += 7200.0;  // a gap at the end
    const Eigen::Index n = h.inputs.rows();
    Eigen::MatrixXd y(n, 2);
    for (Eigen::Index k = 0; k < n; ++k) {
      y(k, 0) = 3.0 * (h.inputs(k, 0) - h.inputs(0, 0)) + 0.001 * h.inputs(k, 1);
      y(k, 1) = -10.0 * (h.inputs(k, 0) - h.inputs(0, 0));
    }
    std::vector<Eigen::Index> samples;
    const int count = static_cast<int>(2 + 150 * u(rng));
    for (int j = 0; j < count; ++j) samples.push_back(static_cast<Eigen::Index>(u(rng) * static_cast<double>(n - 1)));
    std::sort(samples.begin(), samples.end());
    auto probes = test::probes_at(h, y, samples, &rng, 0.5 * u(rng));
    for (ProbeRecord& p : probes) {
      if (u(rng) < 0.05) p.errors(0) += 100.0 * (u(rng) - 0.5);
      if (u(rng) < 0.1) p.errors(1) = std::nan("");
      if (u(rng) < 0.05) p.weight = 0.0;
    }
    IdentificationOptions o;
    o.method = u(rng) < 0.3 ? IdentificationMethod::OutputError : IdentificationMethod::FixedPoles;
    o.criterion = u(rng) < 0.3 ? StructureCriterion::HoldOut : StructureCriterion::BIC;
    o.robust_loss = u(rng) < 0.3 ? RobustLoss::Cauchy : RobustLoss::Huber;
    o.ridge = u(rng) < 0.2 ? 0.0 : 1e-6;
    const FitResult fit = identify(h, {"E_X0C", "E_A0C"}, probes, o);
    INFO("seed " << seed << ": " << fit.message);
    REQUIRE(fit.outputs.size() == 2);
    if (!fit.usable) REQUIRE_FALSE(fit.message.empty());
    for (const OutputFitSummary& s : fit.outputs) {
      if (!s.usable) REQUIRE_FALSE(s.message.empty());
      REQUIRE(std::isfinite(s.residual_rms));
    }
    if (fit.usable) {
      const Eigen::MatrixXd pred = test::simulate(fit.model, h);
      REQUIRE(pred.allFinite());
      for (std::size_t o2 = 0; o2 < 2; ++o2)
        REQUIRE(pred.col(static_cast<Eigen::Index>(o2)).cwiseAbs().maxCoeff() <= fit.model.outputs[o2].output_limit);
    }
  }
}

TEST_CASE("refit: keeps inputs and poles, refits the parameters, and continues like a stepped predictor") {
  std::mt19937_64 rng(21);
  const InputHistory h = test::make_history(rng, 3 * 86400.0, 60.0);
  const ThermalModel truth = test::truth_model(
      h, {test::output_model("E_X0C", {0, 1}, {grid_tau(2), grid_tau(4)}, {1.0, 3.0, -1.5, 0.002, 0.001}),
          test::output_model("E_Y0C", {0}, {grid_tau(3)}, {-0.5, 2.0})});
  const Eigen::MatrixXd y = test::simulate(truth, h);
  const auto all = test::probes_at(h, y, test::probe_samples(h, 6.5 * 3600.0, 300.0, 7200.0), &rng, 0.05);
  std::vector<ProbeRecord> early;
  for (const ProbeRecord& p : all)
    if (p.time_s < 8 * 3600.0) early.push_back(p);
  const FitResult first = identify(h, names_of(truth), early, {});
  REQUIRE(first.usable);

  const FitResult again = refit(h, names_of(truth), all, {}, first.model);
  INFO(again.message);
  REQUIRE(again.usable);
  for (std::size_t o = 0; o < 2; ++o) {
    const OutputModel& a = first.model.outputs[o];
    const OutputModel& b = again.model.outputs[o];
    CHECK(b.inputs == a.inputs);
    REQUIRE(b.poles.size() == a.poles.size());
    CHECK((b.poles.array() == a.poles.array()).all());  // exactly: no round trip through time constants
    CHECK(b.parameters != a.parameters);                // more data, other parameters
    CHECK_THAT(again.outputs[o].message, Catch::Matchers::Contains("structure kept"));
  }
  // Same predictor-state contract as identify().
  ModelPredictor replayed(again.model);
  for (Eigen::Index k = 0; k < h.inputs.rows(); ++k) replayed.step(h.time_s[static_cast<std::size_t>(k)], h.inputs.row(k).transpose());
  CHECK(replayed.state() == again.predictor_state);

  // With the same structure, the refit is as good as identify() with the true structure on all data.
  const auto err = [&](const FitResult& f) { return (test::simulate(f.model, h) - y).cwiseAbs().maxCoeff(); };
  CHECK(err(again) < err(first));

  // An output the structure lacks gets the full search; an empty structure is identify().
  ThermalModel only_x = first.model;
  only_x.outputs.pop_back();
  const FitResult mixed = refit(h, names_of(truth), all, {}, only_x);
  REQUIRE(mixed.usable);
  CHECK_THAT(mixed.outputs[0].message, Catch::Matchers::Contains("structure kept"));
  CHECK_THAT(mixed.outputs[1].message, !Catch::Matchers::Contains("structure kept"));
  const FitResult plain = identify(h, names_of(truth), all, {});
  const FitResult empty = refit(h, names_of(truth), all, {}, ThermalModel{});
  CHECK(empty.predictor_state == plain.predictor_state);
}

TEST_CASE("refit: time constants off the grid (output-error route) are kept exactly") {
  std::mt19937_64 rng(56);
  const InputHistory h = test::make_history(rng, 3 * 86400.0, 60.0);
  const ThermalModel truth = test::truth_model(h, {test::output_model("E_X0C", {0, 1}, {2500.0}, {0.3, 4.0, 0.003})});
  const auto probes = test::probes_at(h, test::simulate(truth, h), test::probe_samples(h, 6.5 * 3600.0, 300.0, 7200.0), &rng, 0.05);
  IdentificationOptions o;
  o.max_order = 1;
  o.method = IdentificationMethod::OutputError;
  const FitResult oe = identify(h, {"E_X0C"}, probes, o);
  REQUIRE(oe.usable);
  const FitResult again = refit(h, {"E_X0C"}, probes, o, oe.model);
  REQUIRE(again.usable);
  CHECK((again.model.outputs[0].poles.array() == oe.model.outputs[0].poles.array()).all());
  ModelPredictor replayed(again.model);
  for (Eigen::Index k = 0; k < h.inputs.rows(); ++k) replayed.step(h.time_s[static_cast<std::size_t>(k)], h.inputs.row(k).transpose());
  CHECK(replayed.state() == again.predictor_state);
}

namespace {

InputHistory head_of(const InputHistory& h, Eigen::Index n) {
  InputHistory p;
  p.input_names = h.input_names;
  p.time_s.assign(h.time_s.begin(), h.time_s.begin() + n);
  p.inputs = InputMatrix(h.inputs.topRows(n));
  return p;
}

// Bit-for-bit equality of two fits: every output's structure and parameters, and the predictor state.
void require_same_fit(const FitResult& a, const FitResult& b) {
  REQUIRE(a.usable == b.usable);
  REQUIRE(a.model.outputs.size() == b.model.outputs.size());
  for (std::size_t k = 0; k < a.model.outputs.size(); ++k) {
    CHECK(a.model.outputs[k].inputs == b.model.outputs[k].inputs);
    CHECK(a.model.outputs[k].poles == b.model.outputs[k].poles);
    CHECK(a.model.outputs[k].parameters == b.model.outputs[k].parameters);
  }
  CHECK(a.predictor_state == b.predictor_state);
}

}  // namespace

TEST_CASE("identify: a LagCache extended over a growing history gives the fits of a fresh computation, bit for bit") {
  std::mt19937_64 rng(2024);
  const InputHistory h = test::make_history(rng, 2 * 86400.0, 60.0, 2);
  const ThermalModel truth = test::truth_model(
      h, {test::output_model("E_X0C", {0, 1}, {grid_tau(2), grid_tau(5)}, {1.0, 3.0, -1.5, 0.002, 0.001}),
          test::output_model("E_A0C", {3}, {grid_tau(3)}, {-2.0, 6.0})});
  const Eigen::MatrixXd y = test::simulate(truth, h);
  const std::vector<ProbeRecord> all = test::probes_at(h, y, test::probe_samples(h, 6.5 * 3600.0, 300.0, 2 * 3600.0), &rng, 0.3);
  const std::vector<std::string> names{"E_X0C", "E_A0C"};
  const IdentificationOptions options;

  LagCache cache;
  ThermalModel structure;
  for (const Eigen::Index n : {Eigen::Index{400}, Eigen::Index{401}, Eigen::Index{1500}, Eigen::Index{2000}, h.inputs.rows()}) {
    INFO("samples " << n);
    const InputHistory part = head_of(h, n);
    std::vector<ProbeRecord> probes;
    for (const ProbeRecord& p : all)
      if (p.time_s <= part.time_s.back()) probes.push_back(p);
    const FitResult cached = identify(part, names, probes, options, &cache);
    CHECK(cache.samples == n);
    const FitResult fresh = identify(part, names, probes, options);
    REQUIRE(fresh.usable);
    require_same_fit(cached, fresh);
    if (!structure.empty()) require_same_fit(refit(part, names, probes, options, structure, &cache),
                                             refit(part, names, probes, options, structure));
    structure = fresh.model;
  }

  SECTION("a history that is not an extension of the cached one is computed afresh") {
    const InputHistory shorter = head_of(h, 1000);
    std::vector<ProbeRecord> probes;
    for (const ProbeRecord& p : all)
      if (p.time_s <= shorter.time_s.back()) probes.push_back(p);
    require_same_fit(identify(shorter, names, probes, options, &cache), identify(shorter, names, probes, options));
    CHECK(cache.samples == 1000);
    InputHistory other = h;
    other.inputs(other.inputs.rows() - 1, 0) += 0.5;  // another last sample
    require_same_fit(identify(other, names, all, options, &cache), identify(other, names, all, options));
    InputHistory later = h;
    for (double& t : later.time_s) t += 60.0;  // another first sample time
    std::vector<ProbeRecord> shifted = all;
    for (ProbeRecord& p : shifted) p.time_s += 60.0;
    require_same_fit(identify(later, names, shifted, options, &cache), identify(later, names, shifted, options));
    IdentificationOptions other_grid = options;
    other_grid.tau_max_s = 36000.0;  // other time constants
    require_same_fit(identify(h, names, all, other_grid, &cache), identify(h, names, all, other_grid));
  }
}
