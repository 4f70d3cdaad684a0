// Held-out cases H1-H7: determinism for their seeds, the physics each claims (against the same
// case and seed with that physics switched off), and a replay with the default set that finishes
// with finite indicators.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

#include "runtime/replay.hpp"
#include "scenarios/load_cases.hpp"
#include "scenarios/scenario_csv.hpp"
#include "scenarios/thermal_twin.hpp"

namespace sc = alc::scenarios;

namespace {

constexpr double kHour = 3600.0;  // [s]
constexpr double kRoundOff = 1e-9;  // [µm] difference of two sums that differ by one term

std::string csv_text(const sc::Scenario& s) {
  std::ostringstream out;
  sc::write_scenario_csv(out, s);
  return out.str();
}

// Row spacings [s] of a run.
std::vector<double> spacings(const sc::Scenario& s) {
  std::vector<double> d;
  for (std::size_t k = 1; k < s.time_s.size(); ++k) d.push_back(s.time_s[k] - s.time_s[k - 1]);
  return d;
}

double variance(const Eigen::VectorXd& v) { return (v.array() - v.mean()).square().mean(); }

// The row spacings [s] of a run other than its sampling step: one per gap in the data.
std::vector<double> gaps_of(const sc::Scenario& s, double step_s) {
  std::vector<double> gaps;
  for (const double d : spacings(s))
    if (d != step_s) gaps.push_back(d);
  return gaps;
}

// Creep in the truth (the run minus the same run without creep): monotone with the sign of its
// amplitude on every error, and at the end more than `min_share` of that amplitude.
void check_creep(const Eigen::MatrixXd& trend, const std::array<double, 7>& creep, double min_share) {
  for (Eigen::Index e = 0; e < trend.cols(); ++e) {
    INFO("error " << e);
    const double c = creep[static_cast<std::size_t>(e)];
    const double sign = c > 0 ? 1.0 : -1.0;
    for (Eigen::Index r = 1; r < trend.rows(); ++r) REQUIRE(sign * (trend(r, e) - trend(r - 1, e)) >= -kRoundOff);
    CHECK(sign * trend(trend.rows() - 1, e) > min_share * std::abs(c));
  }
}

}  // namespace

TEST_CASE("held-out cases: H1-H5 are listed apart from A-D with their sampling") {
  const auto& cases = sc::heldout_cases();
  REQUIRE(cases.size() == 5);
  const std::vector<std::string> names = {"H1", "H2", "H3", "H4", "H5"};
  const std::vector<double> steps = {60.0, 300.0, 10.0, 60.0, 60.0};
  for (std::size_t i = 0; i < cases.size(); ++i) {
    CHECK(cases[i].name == names[i]);
    CHECK(cases[i].step_s == steps[i]);
    CHECK(cases[i].duration_h <= 192.0);
    CHECK(!cases[i].description.empty());
    CHECK(sc::find_case(names[i]).has_value());
    CHECK(sc::load_case_spec(names[i]).info.name == names[i]);
  }
  // A-D stay the tuning set.
  CHECK(sc::load_cases().size() == 4);
  // A-D are not variants.
  CHECK(sc::load_case_spec("A").variant.sensors.empty());
}

TEST_CASE("held-out H6 and H7 are listed by name only, apart from H1-H5") {
  const auto& later = sc::later_heldout_cases();
  REQUIRE(later.size() == 2);
  const std::vector<std::string> names = {"H6", "H7"};
  const std::vector<double> steps = {120.0, 60.0};
  const std::vector<std::uint64_t> seeds = {206, 207};
  for (std::size_t i = 0; i < later.size(); ++i) {
    CHECK(later[i].name == names[i]);
    CHECK(later[i].step_s == steps[i]);
    CHECK(later[i].default_seed == seeds[i]);
    CHECK(sc::find_case(names[i]).has_value());
    CHECK(sc::load_case_spec(names[i]).info.name == names[i]);
    for (const auto& info : sc::heldout_cases()) CHECK(info.name != names[i]);
  }
}

// Every held-out case: H1-H5 and those built later.
std::vector<sc::LoadCaseInfo> every_heldout_case() {
  std::vector<sc::LoadCaseInfo> all = sc::heldout_cases();
  for (const auto& info : sc::later_heldout_cases()) all.push_back(info);
  return all;
}

TEST_CASE("held-out cases: the same seed gives the same CSV bytes and the probe reads again alike") {
  for (const auto& info : every_heldout_case()) {
    INFO("case " << info.name);
    const auto run = sc::simulate_case(info.name);
    CHECK(run.seed == info.default_seed);
    const std::string text = csv_text(run.scenario);
    CHECK(csv_text(sc::simulate_case(info.name, info.default_seed).scenario) == text);
    CHECK(csv_text(sc::simulate_case(info.name, info.default_seed + 1000).scenario) != text);
    CHECK(csv_text(sc::reprobe(run, run.probe_seed)) == text);
    // Truth, profile and scenario have the same rows.
    CHECK(run.truth.errors.rows() == static_cast<Eigen::Index>(run.scenario.samples()));
    CHECK(run.profile.time_s == run.scenario.time_s);
  }
}

TEST_CASE("held-out H1: another sensor set on other nodes and a faster machine") {
  const auto run = sc::simulate_case("H1");
  const sc::Scenario& s = run.scenario;
  CHECK(s.input_names == std::vector<std::string>{"T_ENV", "T_BED", "T_TBL", "T_COL", "n_C"});
  // T_BED is the bed node plus noise.
  const Eigen::VectorXd bed_error = s.inputs.col(1) - run.truth.nodes.col(sc::kBed);
  CHECK(std::sqrt(bed_error.squaredNorm() / static_cast<double>(bed_error.size())) < 0.03);
  // Other time constants: the slowest and the fastest mode are faster than A's machine's.
  const sc::ThermalTwin h1(sc::load_case_spec("H1").twin);
  const sc::ThermalTwin a(sc::load_case_spec("A").twin);
  const Eigen::VectorXd tau_h1 = h1.network(false).time_constants_s();
  const Eigen::VectorXd tau_a = a.network(false).time_constants_s();
  CHECK(tau_h1(0) < tau_a(0));
  CHECK(tau_h1(tau_h1.size() - 1) < 0.8 * tau_a(tau_a.size() - 1));
}

TEST_CASE("held-out H2: 300 s spacing with a drifting and a dead sensor") {
  const auto run = sc::simulate_case("H2");
  const sc::Scenario& s = run.scenario;
  for (const double d : spacings(s)) REQUIRE(d == 300.0);
  REQUIRE(s.input_names == std::vector<std::string>{"T_ENV", "T_WS", "T_COOL", "n_C"});
  // T_COOL dies at 60 h: constant from then on, alive before.
  const int cool = s.input_index("T_COOL");
  const auto dead_from = static_cast<Eigen::Index>(60.0 * kHour / 300.0);
  for (Eigen::Index r = dead_from; r < s.inputs.rows(); ++r) REQUIRE(s.inputs(r, cool) == s.inputs(dead_from - 1, cool));
  CHECK(s.inputs.col(cool).head(dead_from).maxCoeff() - s.inputs.col(cool).head(dead_from).minCoeff() > 0.5);
  // T_WS drifts 0.1 K/day: its offset from the workspace node grows by about 0.7 K over 7 days.
  const int ws = s.input_index("T_WS");
  const Eigen::VectorXd offset = s.inputs.col(ws) - run.truth.nodes.col(sc::kWorkspace);
  const Eigen::Index day = 288;  // samples
  const double growth = offset.tail(day).mean() - offset.head(day).mean();
  CHECK(growth > 0.65);
  CHECK(growth < 0.75);
}

TEST_CASE("held-out H3: 10 s spacing and a machine move at 26 h") {
  sc::LoadCaseSpec spec = sc::load_case_spec("H3");
  const auto moved = sc::simulate_load_case(spec, spec.info.default_seed);
  for (const double d : spacings(moved.scenario)) REQUIRE(d == 10.0);
  spec.variant.move_at_h = std::numeric_limits<double>::infinity();
  const auto still = sc::simulate_load_case(spec, spec.info.default_seed);
  const Eigen::MatrixXd change = moved.truth.errors - still.truth.errors;
  const auto at = static_cast<Eigen::Index>(26.0 * kHour / 10.0);
  CHECK(change.topRows(at).cwiseAbs().maxCoeff() == 0.0);
  // From the move on every error has jumped: at least 1.5 µm (µm/m) on average.
  for (Eigen::Index e = 0; e < change.cols(); ++e) {
    INFO("error " << e);
    CHECK(change.col(e).tail(change.rows() - at).cwiseAbs().mean() > 1.5);
  }
}

TEST_CASE("held-out H4: gaps in the data, a monotone creep in the truth and strong bending") {
  sc::LoadCaseSpec spec = sc::load_case_spec("H4");
  const auto run = sc::simulate_load_case(spec, spec.info.default_seed);
  // Three gaps (6 h, 0.5 h, 12 h) and no row inside one.
  CHECK(gaps_of(run.scenario, 60.0) == std::vector<double>{6.0 * kHour + 60.0, 0.5 * kHour + 60.0, 12.0 * kHour + 60.0});
  for (const double t : run.scenario.time_s)
    for (const auto& [from_h, to_h] : spec.variant.gaps_h) REQUIRE_FALSE((t >= from_h * kHour && t < to_h * kHour));
  // Creep: the truth minus the same run without creep is monotone, with the creep's sign, and
  // reaches most of its amplitude (1 - exp(-192/120) = 0.80).
  const auto creep = spec.variant.creep;
  spec.variant.creep = {};
  const auto no_creep = sc::simulate_load_case(spec, spec.info.default_seed);
  check_creep(run.truth.errors - no_creep.truth.errors, creep, 0.75);
  // The quadratic bending of the cradle reaches several µm/m on E_A0C (A's machine: a few tenths).
  const Eigen::VectorXd gradient = run.truth.nodes.col(sc::kCradle) - run.truth.nodes.col(sc::kBed);
  CHECK(spec.twin.quadratic[4] * gradient.squaredNorm() / static_cast<double>(gradient.size()) > 2.0);
  CHECK(spec.twin.quadratic[4] * gradient.cwiseAbs2().maxCoeff() > 8.0);
}

TEST_CASE("held-out H5: most of the error comes from the unmeasured source") {
  sc::LoadCaseSpec spec = sc::load_case_spec("H5");
  const auto run = sc::simulate_load_case(spec, spec.info.default_seed);
  spec.variant.hidden.enabled = false;
  const auto without = sc::simulate_load_case(spec, spec.info.default_seed);
  // The inputs do not change: the source is neither sensed nor logged.
  CHECK(run.scenario.inputs == without.scenario.inputs);
  double hidden = 0.0, rest = 0.0;
  for (Eigen::Index e = 0; e < 4; ++e) {  // the linear errors
    hidden += variance(run.truth.errors.col(e) - without.truth.errors.col(e));
    rest += variance(without.truth.errors.col(e));
  }
  INFO("variance from the hidden source " << hidden << " µm², from the rest " << rest << " µm²");
  CHECK(hidden > 1.5 * rest);
}

TEST_CASE("held-out H6: 120 s spacing with one 4-h gap, a drifting and a dead sensor, fluid, a small hidden source, "
          "a slower machine") {
  sc::LoadCaseSpec spec = sc::load_case_spec("H6");
  const auto run = sc::simulate_load_case(spec, spec.info.default_seed);
  const sc::Scenario& s = run.scenario;
  REQUIRE(s.input_names == std::vector<std::string>{"T_ENV", "T_WS", "T_COOL", "T_CRD", "n_C", "CF_on"});
  // Rows every 120 s but for the one gap of 70-74 h.
  CHECK(gaps_of(s, 120.0) == std::vector<double>{4.0 * kHour + 120.0});
  // T_CRD dies at 110 h (constant from then on; it followed the cradle before).
  const int crd = s.input_index("T_CRD");
  Eigen::Index dead_from = 0;
  while (s.time_s[static_cast<std::size_t>(dead_from)] < 110.0 * kHour) ++dead_from;
  for (Eigen::Index r = dead_from; r < s.inputs.rows(); ++r) REQUIRE(s.inputs(r, crd) == s.inputs(dead_from - 1, crd));
  const Eigen::VectorXd crd_error = s.inputs.col(crd).head(dead_from) - run.truth.nodes.col(sc::kCradle).head(dead_from);
  CHECK(crd_error.cwiseAbs().maxCoeff() < 0.1);
  // T_WS drifts -0.08 K/day against what it reads (0.7 workspace + 0.3 table): the mean offset of the
  // last day is 6 days after that of the first, -0.48 K.
  const int ws = s.input_index("T_WS");
  const Eigen::VectorXd offset =
      s.inputs.col(ws) - 0.7 * run.truth.nodes.col(sc::kWorkspace) - 0.3 * run.truth.nodes.col(sc::kTable);
  const Eigen::Index day = 720;  // samples
  const double growth = offset.tail(day).mean() - offset.head(day).mean();
  CHECK(growth < -0.45);
  CHECK(growth > -0.60);
  // The fluid runs part of the time.
  const double fluid_share = s.inputs.col(s.input_index("CF_on")).mean();
  CHECK(fluid_share > 0.1);
  CHECK(fluid_share < 0.9);
  // The hidden source adds a few per cent of the linear errors' variance (H5: more than the rest),
  // several µm at its peak.
  spec.variant.hidden.enabled = false;
  const auto without = sc::simulate_load_case(spec, spec.info.default_seed);
  CHECK(run.scenario.inputs == without.scenario.inputs);
  double hidden = 0.0, rest = 0.0, peak = 0.0;
  for (Eigen::Index e = 0; e < 4; ++e) {
    const Eigen::VectorXd added = run.truth.errors.col(e) - without.truth.errors.col(e);
    hidden += variance(added);
    rest += variance(without.truth.errors.col(e));
    peak = std::max(peak, added.cwiseAbs().maxCoeff());
  }
  INFO("variance from the hidden source " << hidden << " µm², from the rest " << rest << " µm², peak " << peak);
  CHECK(hidden > 0.02 * rest);
  CHECK(hidden < 0.2 * rest);
  CHECK(peak > 2.0);
  // A heavier machine: its slowest mode is slower than A's.
  const sc::ThermalTwin h6(sc::load_case_spec("H6").twin);
  const sc::ThermalTwin a(sc::load_case_spec("A").twin);
  const Eigen::VectorXd tau_h6 = h6.network(false).time_constants_s();
  const Eigen::VectorXd tau_a = a.network(false).time_constants_s();
  CHECK(tau_h6(tau_h6.size() - 1) > 1.2 * tau_a(tau_a.size() - 1));
}

TEST_CASE("held-out H7: re-levelled at 60 h with the bed's gains 0.6x, creep, a drifting column sensor, a 1-h gap, "
          "time constants spread wider than A's") {
  sc::LoadCaseSpec spec = sc::load_case_spec("H7");
  const auto run = sc::simulate_load_case(spec, spec.info.default_seed);
  const sc::Scenario& s = run.scenario;
  REQUIRE(s.input_names == std::vector<std::string>{"T_ENV", "T_WS", "T_COOL", "T_COL", "n_C"});
  // Rows every 60 s but for the gap of 90-91 h.
  CHECK(gaps_of(s, 60.0) == std::vector<double>{1.0 * kHour + 60.0});
  // T_COL drifts +0.12 K/day against the column: the mean offset of the last day is 4 days after
  // that of the first, +0.48 K.
  const Eigen::VectorXd offset = s.inputs.col(s.input_index("T_COL")) - run.truth.nodes.col(sc::kColumn);
  const Eigen::Index day = 1440;  // samples
  const double growth = offset.tail(day).mean() - offset.head(day).mean();
  CHECK(growth > 0.40);
  CHECK(growth < 0.56);
  // The repair: nothing changes before 60 h. From then on the errors jump by the move's offset (a run
  // with the jump alone differs from the unrepaired one by exactly that), and the bed deforms the axis
  // less on its new supports (the full repair differs from the jump alone wherever the bed's gain is).
  sc::LoadCaseSpec unrepaired = spec;
  unrepaired.variant.move_at_h = std::numeric_limits<double>::infinity();
  const auto still = sc::simulate_load_case(unrepaired, spec.info.default_seed);
  CHECK(still.scenario.inputs == s.inputs);
  sc::LoadCaseSpec jump_only = spec;
  jump_only.variant.move_bed_gain_factor = 1.0;
  const auto jumped = sc::simulate_load_case(jump_only, spec.info.default_seed);
  Eigen::Index at = 0;
  while (s.time_s[static_cast<std::size_t>(at)] < 60.0 * kHour) ++at;
  const Eigen::MatrixXd change = run.truth.errors - still.truth.errors;
  CHECK(change.topRows(at).cwiseAbs().maxCoeff() == 0.0);
  const Eigen::Index after = change.rows() - at;
  for (Eigen::Index e = 0; e < change.cols(); ++e) {
    INFO("error " << e);
    const Eigen::VectorXd jump = (jumped.truth.errors - still.truth.errors).col(e).tail(after);
    CHECK((jump.array() - spec.variant.move_offset[static_cast<std::size_t>(e)]).abs().maxCoeff() < kRoundOff);
    const Eigen::VectorXd gain_part = (run.truth.errors - jumped.truth.errors).col(e).tail(after);
    CHECK(gain_part.cwiseAbs().maxCoeff() > 0.1);
  }
  // Creep with the sign of its amplitude, monotone: 1 - exp(-120/200) = 0.45 of it at the end.
  sc::LoadCaseSpec no_creep = spec;
  no_creep.variant.creep = {};
  check_creep(run.truth.errors - sc::simulate_load_case(no_creep, spec.info.default_seed).truth.errors,
              spec.variant.creep, 0.40);
  // Time constants spread wider than A's: the fastest mode faster, the slowest slower.
  const Eigen::VectorXd tau_h7 = sc::ThermalTwin(spec.twin).network(false).time_constants_s();
  const Eigen::VectorXd tau_a = sc::ThermalTwin(sc::load_case_spec("A").twin).network(false).time_constants_s();
  CHECK(tau_h7(0) < tau_a(0));
  CHECK(tau_h7(tau_h7.size() - 1) > tau_a(tau_a.size() - 1));
}

TEST_CASE("held-out cases: a replay with the default set ends with finite indicators") {
  for (const auto& info : every_heldout_case()) {
    INFO("case " << info.name);
    const auto run = sc::simulate_case(info.name);
    const alc::runtime::ReplayReport r = alc::runtime::replay(run.scenario, alc::AlcParameters{});
    CHECK(r.M > 0);
    CHECK(r.updates > 0);
    CHECK(r.Pd >= 0.0);
    CHECK(r.Pd <= 100.0);
    REQUIRE(r.outputs.size() == 7);
    for (const auto& o : r.outputs) {
      INFO(o.name);
      CHECK(o.measurements > 0);
      CHECK(std::isfinite(o.P99));
      CHECK(std::isfinite(o.RMSE));
      CHECK(std::isfinite(o.P99_uncompensated));
      // The guard's promise (docs/adaptive.md): no output is made worse than uncompensated.
      CHECK(o.P99 <= o.P99_uncompensated);
    }
    CHECK(std::isfinite(r.mean_p99(alc::ErrorKind::Linear)));
  }
}

TEST_CASE("held-out H5: without the guard compensation makes errors worse than none, with it none is") {
  // H5's inputs barely explain its errors: the model mispredicts when the hidden source switches.
  // Its own seed and seeds 1-8, at which the guard brings every output back to or below uncompensated
  // (docs/adaptive.md, "What remains"). Seeds 6 and 7 were exceptions until the guard's drift bound,
  // seed 5 (E_Z0T) until its first check of a model fitted on a burst of probes, seed 8 (E_A0C, by
  // 0.38 µm/m) until that check judged the model (a compensation worse than none there holds the
  // probe's error until the next probe).
  const std::uint64_t seed = GENERATE(as<std::uint64_t>{}, 0, 1, 2, 3, 4, 5, 6, 7, 8);
  INFO("seed " << (seed == 0 ? "H5's own" : std::to_string(seed)));
  const auto run = seed == 0 ? sc::simulate_case("H5") : sc::simulate_case("H5", seed);
  alc::AlcParameters off;
  off.guard = false;
  const alc::runtime::ReplayReport without = alc::runtime::replay(run.scenario, off);
  const alc::runtime::ReplayReport with = alc::runtime::replay(run.scenario, alc::AlcParameters{});
  REQUIRE(without.outputs.size() == with.outputs.size());
  int worse_without = 0;
  for (std::size_t i = 0; i < with.outputs.size(); ++i) {
    INFO(with.outputs[i].name << ": " << without.outputs[i].P99 << " without the guard, " << with.outputs[i].P99
                              << " with it, " << with.outputs[i].P99_uncompensated << " uncompensated");
    if (without.outputs[i].P99 > without.outputs[i].P99_uncompensated) ++worse_without;
    CHECK(with.outputs[i].P99 <= with.outputs[i].P99_uncompensated);
  }
  CHECK(worse_without >= 1);
  CHECK(with.mean_p99(alc::ErrorKind::Linear) < without.mean_p99(alc::ErrorKind::Linear));
}

TEST_CASE("held-out cases and S16 at seeds 1-10: per run ALC's mean P99 stays below uncompensated", "[sweep]") {
  // The "no case is made worse than uncompensated" per recording: the mean P99 of its linear
  // and of its angular errors with ALC against without (README, held-out cases: at most 0.64 of it over the
  // own seeds and seeds 1-80; H6 at most 0.43 over its own seed and seeds 1-80, H7 at most 0.35 over its own
  // seed and seeds 1-80, docs/twin.md). Single outputs may still exceed theirs ("What remains" lists them).
  const std::uint64_t seed = GENERATE(range<std::uint64_t>(1, 11));
  for (const std::string name : {"H1", "H2", "H3", "H4", "H5", "H6", "H7", "S16"}) {
    INFO(name << " seed " << seed);
    const auto run = sc::simulate_case(name, seed);
    const alc::runtime::ReplayReport r = alc::runtime::replay(run.scenario, alc::AlcParameters{});
    for (const alc::ErrorKind kind : {alc::ErrorKind::Linear, alc::ErrorKind::Angular}) {
      const double with = r.mean_p99(kind);
      const double without = r.mean_p99_uncompensated(kind);
      if (std::isnan(with)) continue;  // S16 has no angular error
      INFO((kind == alc::ErrorKind::Linear ? "linear " : "angular ") << with << " with ALC, " << without
                                                                     << " uncompensated");
      CHECK(with < without);
    }
  }
}

TEST_CASE("held-out H6 at its own seed and seeds 1-10: the default set meets the issue's target, no output worse", "[sweep]") {
  // Mean linear P99 below 5 µm at Pd of at least 96 % on every run, and no output worse than
  // uncompensated (docs/twin.md, "H6": over seeds 1-80 at most 3.42 µm, Pd at least 96.84 %).
  const std::uint64_t seed = GENERATE(as<std::uint64_t>{}, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10);
  INFO("seed " << (seed == 0 ? "H6's own" : std::to_string(seed)));
  const auto run = seed == 0 ? sc::simulate_case("H6") : sc::simulate_case("H6", seed);
  const alc::runtime::ReplayReport r = alc::runtime::replay(run.scenario, alc::AlcParameters{});
  CHECK(r.mean_p99(alc::ErrorKind::Linear) < 5.0);
  CHECK(r.Pd >= 96.0);
  for (const auto& o : r.outputs) {
    INFO(o.name << ": " << o.P99 << " with ALC, " << o.P99_uncompensated << " uncompensated");
    CHECK(o.P99 <= o.P99_uncompensated);
  }
}

TEST_CASE("held-out H7 at seeds 60 and 72: off by the range, the latest probe's error fades instead of a step to 0", "[sweep]") {
  // The two of H7's 81 runs (its own seed and seeds 1-80) that were above 5 µm (6.84 and 6.16) while an
  // output off by the guard's range was compensated with 0: an NG burst from 8.3 h whose first model's
  // prediction ran past the errors its probes measured (docs/twin.md, "H7"). With the latest probe's
  // error fading within the drift bound they are 4.66 and 4.64 µm (Pd unchanged: 93.97 and 93.78 %).
  const std::uint64_t seed = GENERATE(as<std::uint64_t>{}, 60, 72);
  INFO("H7 seed " << seed);
  const alc::runtime::ReplayReport r = alc::runtime::replay(sc::simulate_case("H7", seed).scenario, alc::AlcParameters{});
  CHECK(r.mean_p99(alc::ErrorKind::Linear) < 5.0);
  for (const auto& o : r.outputs) {
    INFO(o.name << ": " << o.P99 << " with ALC, " << o.P99_uncompensated << " uncompensated");
    CHECK(o.P99 <= o.P99_uncompensated);
  }
}
