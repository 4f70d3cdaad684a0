// Replay: probing against a recording, evaluation span, Pd, stop and resume, residual output.
#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include <filesystem>
#include <unistd.h>

#include "runtime/replay.hpp"
#include "runtime_test_support.hpp"

using namespace alc;
using namespace alc::runtime;
using namespace alc::runtime::test;
using alc::scenarios::Scenario;

namespace {

constexpr double kMinute = 60.0;
constexpr double kHour = 3600.0;

// The third time constant of the default identification grid (about 17 min): a plant with this lag
// is exactly representable by a first-order model.
double grid_tau_2() {
  const IdentificationOptions o;
  return o.tau_min_s * std::pow(o.tau_max_s / o.tau_min_s, 2.0 / (o.pole_grid_size - 1));
}

// 24 h at 1 min; one temperature; E_X0C = 2 * lag(T - 20) (time constant grid_tau_2()) recorded every
// `every` minutes, plus a step of `step_um` from `step_at_h` on (something the model has to re-learn).
Scenario synthetic(int every_min, double step_um = 0.0, double step_at_h = 1e9) {
  Scenario s;
  s.input_names = {"T_ENV"};
  s.output_names = {"E_X0C"};
  const int n = 24 * 60;
  s.time_s.resize(n);
  s.inputs.resize(n, 1);
  s.outputs.setConstant(n, 1, std::numeric_limits<double>::quiet_NaN());
  double lag = 0.0, prev_u = 0.0;
  for (int k = 0; k < n; ++k) {
    const double t = k * kMinute;
    const double u = 3.0 * std::sin(2 * M_PI * t / (7 * kHour)) + 1.0 * std::sin(2 * M_PI * t / (2.3 * kHour));
    if (k > 0) lag += (1.0 - std::exp(-kMinute / grid_tau_2())) * (prev_u - lag);
    prev_u = u;
    s.time_s[static_cast<std::size_t>(k)] = t;
    s.inputs(k, 0) = 20.0 + u;
    if (k % every_min == 0) s.outputs(k, 0) = 2.0 * lag + (t >= step_at_h * kHour ? step_um : 0.0);
  }
  return s;
}

AlcParameters parameters() {
  AlcParameters p;
  p.cp_duration_s = 3 * kHour;
  p.cp_interval_s = 5 * kMinute;
  p.post_cp_interval_s = 2 * kHour;
  p.ng_interval_s = 10 * kMinute;
  p.ng_measurements = 4;
  p.identification.max_order = 1;
  return p;
}

// Records the times at which the controller probed.
struct ProbeTimes : Observer {
  std::vector<double> times;
  void on_cycle(const Cycle& cycle) override {
    if (cycle.kind() == Cycle::Kind::Probe) times.push_back(cycle.probe()->time_s);
  }
};

}  // namespace

TEST_CASE("replay: a probe takes the first recorded measurement at or after its due time") {
  // Measurements only every 7 min: CP probes due every 5 min land on the next 7-min row.
  const Scenario s = synthetic(7);
  ProbeTimes probes;
  Replay session(s, in_memory(parameters(), &probes));
  session.run();
  REQUIRE(probes.times.size() > 3);
  CHECK(probes.times[0] == 0.0);
  CHECK(probes.times[1] == 7 * kMinute);   // due at 5 min
  CHECK(probes.times[2] == 14 * kMinute);  // due at 12 min
  CHECK(probes.times[3] == 21 * kMinute);  // due at 19 min
  for (double t : probes.times) CHECK(std::fmod(t, 7 * kMinute) == 0.0);
}

TEST_CASE("replay: time stamps with fractions of a second probe at the same rows as whole seconds") {
  // A due time is a sum of doubles: 124200.123 + 7200 is 131400.12300000002, 1 ulp after the recorded
  // 131400.123, and that probe used to wait for the next measured row (5 min later), which moved the
  // schedule for the rest of the run (M and the NG phases differed from the same recording shifted by
  // 0.5 s). The end of CP likewise: 124200.123 + 3 h is 1 ulp after the recorded 135000.123, and CP
  // ended a sample later (an extra CP probe). Every probe row of the shifted recordings is that of the
  // unshifted one. A probe asked for at 3.25 h too (alc replay --probe-at 3.25: 124200.123 + 3.25 h is
  // 1 ulp after the recorded row, and was taken a sample later, at the next measured row 5 min on).
  Scenario s = synthetic(5);
  ProbeTimes reference;
  ReplayOptions clean_options = in_memory(parameters(), &reference);
  clean_options.probe_requests = {{3.25 * kHour, "asked"}};
  Replay clean(s, clean_options);
  clean.run();
  REQUIRE(reference.times.size() > 20);
  REQUIRE(std::find(reference.times.begin(), reference.times.end(), 3.25 * kHour) != reference.times.end());
  // The times as a CSV gives them: the double nearest to the decimal text ("131400.123").
  for (const std::string fraction : {".123", ".5"}) {
    const double shift = 124200.0 + std::stod("0" + fraction);
    Scenario shifted = s;
    for (double& t : shifted.time_s) t = std::stod(std::to_string(static_cast<long long>(t) + 124200) + fraction);
    ProbeTimes probes;
    ReplayOptions options = in_memory(parameters(), &probes);
    options.probe_requests = {{shifted.time_s.front() + 3.25 * kHour, "asked"}};
    Replay session(shifted, options);
    session.run();
    CAPTURE(shift);
    REQUIRE(probes.times.size() == reference.times.size());
    for (std::size_t i = 0; i < probes.times.size(); ++i) {
      CAPTURE(i, reference.times[i]);
      CHECK(std::abs(probes.times[i] - shift - reference.times[i]) < 1e-3);
    }
  }
}

TEST_CASE("replay: a recording measured more sparsely than the CP or NG interval is told, a slightly coarser one is not") {
  AlcParameters p = parameters();  // CP interval 5 min, NG interval 10 min
  p.cp_duration_s = 6 * kHour;
  CHECK(sparse_measurements(synthetic(5), p, "a.csv").empty());
  CHECK(sparse_measurements(synthetic(7), p, "a.csv").empty());  // the next measurement is 2 min late
  const std::string sparse = sparse_measurements(synthetic(120), p, "a.csv");
  CHECK_THAT(sparse, Catch::Contains("a.csv is measured more sparsely than the schedule asks (a probe takes the next "
                                     "recorded measurement): in CP every 120 min (median) where the CP interval is 5 min, "
                                     "so CP gets fewer probes than its schedule; after CP every 120 min (median) where "
                                     "the NG interval is 10 min, so an NG burst is stretched"));
  // Measured every 5 min in CP and every 30 min after: CP is as asked, an NG burst is not.
  Scenario mixed = synthetic(5);
  for (Eigen::Index r = 0; r < mixed.outputs.rows(); ++r)
    if (mixed.time_s[static_cast<std::size_t>(r)] > 6 * kHour && static_cast<int>(mixed.time_s[static_cast<std::size_t>(r)]) % 1800 != 0)
      mixed.outputs(r, 0) = std::numeric_limits<double>::quiet_NaN();
  const std::string after_cp = sparse_measurements(mixed, p, "b.csv");
  CHECK_THAT(after_cp, Catch::Contains("): after CP every 30 min (median) where the NG interval is 10 min, so an NG "
                                       "burst is stretched"));
  CHECK_THAT(after_cp, !Catch::Contains("in CP"));
  p.ng_interval_s = std::numeric_limits<double>::infinity();  // no NG burst: nothing to stretch
  CHECK(sparse_measurements(mixed, p, "b.csv").empty());
}

TEST_CASE("replay: a probe due on a sample the controller sets aside is taken at the next measurement") {
  // Measurements every 5 min. An implausible temperature on a row where a probe is due sets that sample
  // aside; the probe is taken at the next measured row instead, and probing goes on to the end (it used
  // to stop for the rest of the run, without a word).
  Scenario s = synthetic(5);
  ProbeTimes reference;
  Replay clean(s, in_memory(parameters(), &reference));
  clean.run();
  REQUIRE(reference.times.size() > 20);
  for (const double at : {20 * kMinute, 0.0 /* the first post-CP probe, below */}) {
    double bad = at;
    if (at == 0.0)
      for (double t : reference.times)
        if (t > 3 * kHour) {
          bad = t;
          break;
        }
    REQUIRE(bad > 0.0);
    Scenario faulty = s;
    const auto row = static_cast<Eigen::Index>(bad / kMinute);
    REQUIRE(faulty.time_s[static_cast<std::size_t>(row)] == bad);
    faulty.inputs(row, 0) = 999.0;  // beyond the plausible +-200 degC
    ProbeTimes probes;
    Replay session(faulty, in_memory(parameters(), &probes));
    session.run();
    CAPTURE(bad);
    CHECK(std::find(probes.times.begin(), probes.times.end(), bad) == probes.times.end());
    CHECK(std::find(probes.times.begin(), probes.times.end(), bad + 5 * kMinute) != probes.times.end());
    REQUIRE_FALSE(probes.times.empty());
    // Probing continues to the end of the day as in the clean run.
    CHECK(probes.times.back() > reference.times.back() - 2 * kHour - 10 * kMinute);
    CHECK(probes.times.size() + 2 >= reference.times.size());
  }
}

TEST_CASE("replay: evaluation uses every recorded measurement after CP, and Pd follows Eq. 7") {
  const Scenario s = synthetic(5);
  Replay session(s, in_memory(parameters()));
  session.run();
  const ReplayReport r = session.report();
  REQUIRE(r.cp_end_s == 3 * kHour);
  // Recorded every 5 min from 3 h to 23 h 55 min inclusive.
  const int expected = static_cast<int>((s.time_s.back() - 3 * kHour) / (5 * kMinute)) + 1;
  REQUIRE(r.outputs.size() == 1);
  CHECK(r.outputs[0].measurements == expected);
  CHECK(r.baseline[0].measurements == expected);
  CHECK(r.duration_s == s.time_s.back());
  ProbeTimes probes;
  Replay again(s, in_memory(parameters(), &probes));
  again.run();
  CHECK(static_cast<int>(probes.times.size()) == r.M);  // M counts every probe cycle the controller took
  CHECK_THAT(r.Pd, Catch::Matchers::WithinAbs((1.0 - r.M * 95.0 / r.duration_s) * 100.0, 1e-12));
  // The model can represent this plant: the compensated P99 is far below the uncompensated one.
  CHECK(r.outputs[0].P99 < 0.1 * r.outputs[0].P99_uncompensated);
  const Scenario res = session.residuals();
  CHECK(res.output_names == std::vector<std::string>{"E_X0C", "E_X0C_pred"});
  CHECK(static_cast<int>(res.samples()) == expected);
  CHECK(res.time_s.front() == 3 * kHour);
}

TEST_CASE("replay: a step the model cannot know triggers NG and an update, and the ALC beats the static baseline") {
  const Scenario s = synthetic(5, 8.0, 10.0);
  const ReplayReport r = replay(s, parameters());
  CHECK(r.ng_phases >= 1);
  CHECK(r.updates >= 2);
  CHECK(r.outputs[0].P99 < r.baseline[0].P99);
}

TEST_CASE("replay: stopping and resuming from the saved state gives the same result bit for bit") {
  const Scenario s = synthetic(5, 8.0, 10.0);
  const ReplayReport whole = replay(s, parameters());
  for (double stop_h : {0.5, 3.0, 10.05, 11.0, 20.0}) {
    const auto db = temp_db("stop");
    ReplayOptions o = in_memory(parameters());
    o.source = "synthetic";
    o.db = db;
    o.stop_time_s = stop_h * kHour;
    {
      Replay first(s, o);
      first.run();
      CHECK_FALSE(first.finished());
    }
    o.resume = true;
    o.stop_time_s = kInf;
    Replay second(s, o);
    second.run();
    CHECK(second.finished());
    const ReplayReport resumed = second.report();
    CHECK(resumed.M == whole.M);
    CHECK(resumed.updates == whole.updates);
    CHECK(resumed.ng_phases == whole.ng_phases);
    CHECK(resumed.outputs[0].P99 == whole.outputs[0].P99);
    CHECK(resumed.outputs[0].RMSE == whole.outputs[0].RMSE);
    CHECK(resumed.baseline[0].P99 == whole.baseline[0].P99);
    CHECK(resumed.Pd == whole.Pd);
  }
}

TEST_CASE("replay: the static baseline is fitted once on the CP measurements and never updated") {
  // A step at 12 h that ALC re-learns; the baseline must not (it would if it were refitted).
  const Scenario s = synthetic(5, 8.0, 12.0);
  Replay session(s, in_memory(parameters()));
  session.run();
  const ControllerState& st = session.controller().state();
  const Evaluation& ev = session.evaluation();
  REQUIRE(ev.baseline_fitted());
  REQUIRE(st.updates >= 2);
  const double cp_end = st.cp_end_s;
  REQUIRE(cp_end == 3 * kHour);
  std::vector<ProbeRecord> cp_probes;
  for (const ProbeRecord& p : st.probes)
    if (p.time_s <= cp_end) cp_probes.push_back(p);
  REQUIRE(cp_probes.size() == 36);  // 0, 5, ..., 175 min
  // What a fit on the CP probes alone predicts, at every evaluated measurement.
  const StaticRegression expected = fit_static_regression(st.history, s.output_names, cp_probes).model;
  REQUIRE(ev.evaluated() > 0);
  for (std::size_t i = 0; i < ev.evaluated(); ++i) {
    const auto row = static_cast<Eigen::Index>(std::lround(ev.time_at(i) / kMinute));
    REQUIRE(s.time_s[static_cast<std::size_t>(row)] == ev.time_at(i));
    INFO("t = " << ev.time_at(i) << " s");
    CHECK(ev.baseline_at(i) == expected.predict(s.inputs.row(row).transpose()));
  }
  // After the step, the baseline keeps its error while ALC learns it.
  const ReplayReport r = session.report();
  CHECK(r.baseline[0].P99 > 4.0);
  CHECK(r.outputs[0].P99 < r.baseline[0].P99);
}
