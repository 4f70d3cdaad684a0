// Comparison of the identification routes on synthetic irregular-probe data (docs/identification.md).
// Hidden from the default run; print the table with
//   build/ident/tests/test_alc "[.comparison]" -s        (or via ctest -L alc: not included)
// Speed is measured there (ms/fit column), never asserted: this is a benchmark, not a timed test.
#include <catch2/catch.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>

#include "alc/indicators.hpp"
#include "alc/static_regression.hpp"
#include "alc/thermal_model.hpp"
#include "synthetic_system.hpp"

using namespace alc;

namespace {

struct Case {
  InputHistory history;
  Eigen::MatrixXd truth;              // noiseless errors at every sample
  std::vector<ProbeRecord> probes;    // noisy, irregular
  double fit_end_s = 0.0;             // probes up to here are used for the fit
};

// 8 days at 60 s: CP probes every 5 min for 6.5 h, then every 1-4 h (random), noise sd 0.3 µm.
// Truth: 7 outputs, each a different mix of T_ENV, n_C and FLUID through two lags whose time
// constants are NOT on the identification grid.
Case make_case(std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  Case c;
  c.history = test::make_history(rng, 8 * 86400.0, 60.0);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<OutputModel> outs;
  const char* names[7] = {"E_X0C", "E_Y0C", "E_Z0T", "E_R0T", "E_A0C", "E_B0C", "E_C0C"};
  for (int o = 0; o < 7; ++o) {
    const double t1 = 1000.0 + 3000.0 * u(rng);
    const double t2 = 15000.0 + 40000.0 * u(rng);
    outs.push_back(test::output_model(names[o], {0, 1, 2}, {t1, t2},
                                      {0.5, 3.0 * (u(rng) - 0.3), 2.0 * (u(rng) - 0.5), 0.003 * u(rng), 0.002 * (u(rng) - 0.5),
                                       -2.0 * u(rng), 1.0 * (u(rng) - 0.5)}));
  }
  const ThermalModel truth = test::truth_model(c.history, outs);
  c.truth = test::simulate(truth, c.history);
  std::vector<Eigen::Index> samples;
  double t = 300.0;
  while (t < c.history.time_s.back()) {
    samples.push_back(static_cast<Eigen::Index>(t / 60.0));
    t += t < 6.5 * 3600.0 ? 300.0 : 3600.0 * (1.0 + 3.0 * u(rng));
  }
  c.probes = test::probes_at(c.history, c.truth, samples, &rng, 0.3);
  c.fit_end_s = 4 * 86400.0;
  return c;
}

struct Score {
  double rmse_in = 0.0;   // [µm] vs noiseless truth, every sample from the end of CP to fit_end
  double rmse_out = 0.0;  // [µm] every sample after fit_end (4 days of extrapolation)
  double p99_out = 0.0;   // [µm] P99 of |error| after fit_end
  double ms = 0.0;        // identify() wall time
  int usable = 0;
};

// Mean over the outputs of RMSE / P99 of prediction - truth.
void score_predictions(const Case& c, const Eigen::MatrixXd& pred, Score& s) {
  double in = 0.0;
  double out = 0.0;
  double p99 = 0.0;
  for (Eigen::Index o = 0; o < pred.cols(); ++o) {
    std::vector<double> yi, pi, yo, po;
    for (Eigen::Index k = 0; k < pred.rows(); ++k) {
      const double t = c.history.time_s[static_cast<std::size_t>(k)];
      if (t < 6.5 * 3600.0) continue;
      (t <= c.fit_end_s ? yi : yo).push_back(c.truth(k, o));
      (t <= c.fit_end_s ? pi : po).push_back(pred(k, o));
    }
    in += rmse(yi, pi);
    out += rmse(yo, po);
    p99 += p99_abs_residual(yo, po);
  }
  s.rmse_in += in / static_cast<double>(pred.cols());
  s.rmse_out += out / static_cast<double>(pred.cols());
  s.p99_out += p99 / static_cast<double>(pred.cols());
}

std::vector<ProbeRecord> until(const Case& c) {
  std::vector<ProbeRecord> p;
  for (const ProbeRecord& r : c.probes)
    if (r.time_s <= c.fit_end_s) p.push_back(r);
  return p;
}

const std::vector<std::string> kNames{"E_X0C", "E_Y0C", "E_Z0T", "E_R0T", "E_A0C", "E_B0C", "E_C0C"};

Score run_method(const std::vector<Case>& cases, const IdentificationOptions& o) {
  Score s;
  for (const Case& c : cases) {
    const auto probes = until(c);
    const auto t0 = std::chrono::steady_clock::now();
    const FitResult fit = identify(c.history, kNames, probes, o);
    s.ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    s.usable += fit.usable ? 1 : 0;
    score_predictions(c, test::simulate(fit.model, c.history), s);
  }
  const auto n = static_cast<double>(cases.size());
  s.rmse_in /= n;
  s.rmse_out /= n;
  s.p99_out /= n;
  s.ms /= n;
  return s;
}

Score run_static(const std::vector<Case>& cases) {
  Score s;
  for (const Case& c : cases) {
    std::vector<ProbeRecord> cp;
    for (const ProbeRecord& r : c.probes)
      if (r.time_s <= 6.5 * 3600.0) cp.push_back(r);
    const StaticRegressionFit fit = fit_static_regression(c.history, kNames, cp);
    s.usable += fit.usable ? 1 : 0;
    Eigen::MatrixXd pred(c.truth.rows(), c.truth.cols());
    for (Eigen::Index k = 0; k < pred.rows(); ++k) pred.row(k) = fit.model.predict(c.history.inputs.row(k).transpose()).transpose();
    score_predictions(c, pred, s);
  }
  const auto n = static_cast<double>(cases.size());
  s.rmse_in /= n;
  s.rmse_out /= n;
  s.p99_out /= n;
  return s;
}

}  // namespace

TEST_CASE("identification routes compared on synthetic irregular-probe data", "[.comparison]") {
  std::vector<Case> cases;
  for (std::uint64_t seed = 1; seed <= 10; ++seed) cases.push_back(make_case(seed));
  std::printf("10 synthetic 8-day cases, 7 outputs, 3 inputs, true time constants off the grid, noise 0.3 um\n");
  std::printf("fit on the probes of days 0-4 (%zu probes per case on average), scored against the noiseless truth\n",
              [&] { std::size_t n = 0; for (const Case& c : cases) n += until(c).size(); return n / cases.size(); }());
  std::printf("%-34s %8s %10s %10s %10s %10s\n", "method", "usable", "RMSE 0-4d", "RMSE 4-8d", "P99 4-8d", "ms/fit");
  const auto row = [](const char* name, const Score& s, int n) {
    std::printf("%-34s %5d/%-2d %10.3f %10.3f %10.3f %10.2f\n", name, s.usable, n, s.rmse_in, s.rmse_out, s.p99_out, s.ms);
  };
  const int n = static_cast<int>(cases.size());
  IdentificationOptions fp;
  row("(a) fixed poles, BIC, Huber", run_method(cases, fp), n);
  IdentificationOptions ho = fp;
  ho.criterion = StructureCriterion::HoldOut;
  row("(a) fixed poles, hold-out, Huber", run_method(cases, ho), n);
  IdentificationOptions ls = fp;
  ls.robust_loss = RobustLoss::None;
  row("(a) fixed poles, BIC, plain WLS", run_method(cases, ls), n);
  IdentificationOptions oe = fp;
  oe.method = IdentificationMethod::OutputError;
  row("(b) output error (from a), Huber", run_method(cases, oe), n);
  row("static MLR on CP probes", run_static(cases), n);
}

TEST_CASE("identify: an 8-day case with 7 outputs at 1-minute sampling gives a usable fit") {
  const Case c = make_case(99);
  CHECK(c.history.time_s.size() == 11521);
  const FitResult fit = identify(c.history, kNames, c.probes, {});
  INFO(c.probes.size() << " probes, " << c.history.time_s.size() << " samples");
  REQUIRE(fit.usable);
  REQUIRE(fit.model.outputs.size() == kNames.size());
}
