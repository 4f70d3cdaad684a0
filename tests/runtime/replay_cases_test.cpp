// What the core issue must show, on the built-in load cases with the paper's chosen set
// (CP 6.5 h, 5 min, 2 h, NG 10 min x 12, ACL 5 µm / 15 µm/m), default seeds.
#include <catch2/catch.hpp>

#include <fstream>
#include <memory>
#include <sstream>

#include "../cli_support.hpp"
#include "common/byte_codec.hpp"
#include "runtime/replay.hpp"
#include "runtime/run_state.hpp"
#include "runtime_test_support.hpp"
#include "scenarios/load_cases.hpp"
#include "storage/history_reader.hpp"

using namespace alc;
using namespace alc::runtime;
using namespace alc::runtime::test;
using alc::scenarios::load_cases;
using alc::scenarios::simulate_case;

TEST_CASE("load cases A-D: linear P99 below 5 µm, Pd at least 95.5 %, and the ALC beats the static baseline") {
  constexpr double kP99LimitUm = 5.0;       // [µm] Eq. 8 of seed 004
  constexpr double kPdMinPercent = 95.5;    // [%]
  for (const auto& info : load_cases()) {
    const auto simulated = simulate_case(info.name);
    const ReplayReport r = replay(simulated.scenario, AlcParameters{});
    INFO("case " << info.name << ": linear P99 " << r.mean_p99(ErrorKind::Linear) << " µm, baseline "
                 << r.mean_p99(ErrorKind::Linear, true) << " µm, Pd " << r.Pd << " %");
    CHECK(r.mean_p99(ErrorKind::Linear) < kP99LimitUm);
    CHECK(r.Pd >= kPdMinPercent);
    CHECK(r.mean_p99(ErrorKind::Linear) < r.mean_p99(ErrorKind::Linear, true));
    CHECK(r.mean_p99(ErrorKind::Angular) < r.mean_p99(ErrorKind::Angular, true));
    CHECK(r.mean_p99(ErrorKind::Linear) < r.mean_p99_uncompensated(ErrorKind::Linear));
  }
}

// Other seeds of the same cases (other weather, production, noise and chips on the sphere): one
// test per seed so that ctest runs them in parallel. Seeds 5 and 6 broke the limit (8 and 16 µm)
// until a breach had to be confirmed by the first NG probe (a chip at a Post-CP probe was learned).
static void check_seed(std::uint64_t seed) {
  for (const auto& info : load_cases()) {
    const auto simulated = simulate_case(info.name, seed);
    const ReplayReport r = replay(simulated.scenario, AlcParameters{});
    INFO("case " << info.name << " seed " << seed << ": linear P99 " << r.mean_p99(ErrorKind::Linear) << " µm");
    CHECK(r.mean_p99(ErrorKind::Linear) < 5.0);
    CHECK(r.Pd >= 95.5);
    CHECK(r.mean_p99(ErrorKind::Linear) < r.mean_p99(ErrorKind::Linear, true));
  }
}
TEST_CASE("load cases A-D with seed 1: linear P99 below 5 µm", "[sweep]") { check_seed(1); }
TEST_CASE("load cases A-D with seed 2: linear P99 below 5 µm", "[sweep]") { check_seed(2); }
TEST_CASE("load cases A-D with seed 3: linear P99 below 5 µm", "[sweep]") { check_seed(3); }
TEST_CASE("load cases A-D with seed 4: linear P99 below 5 µm", "[sweep]") { check_seed(4); }
TEST_CASE("load cases A-D with seed 5: linear P99 below 5 µm", "[sweep]") { check_seed(5); }
TEST_CASE("load cases A-D with seed 6: linear P99 below 5 µm", "[sweep]") { check_seed(6); }

TEST_CASE("S16: 16 temperatures, a spindle speed and 5 linear outputs at 15 s replay and compensation helps every output") {
  const auto simulated = simulate_case("S16");
  REQUIRE(simulated.scenario.input_names.size() == 17);
  REQUIRE(simulated.scenario.output_names.size() == 5);
  const ReplayReport r = replay(simulated.scenario, AlcParameters{});
  REQUIRE(r.outputs.size() == 5);
  REQUIRE(r.baseline.size() == 5);
  for (std::size_t k = 0; k < r.outputs.size(); ++k) {
    const auto& o = r.outputs[k];
    INFO(o.name << ": P99 " << o.P99 << " µm, baseline " << r.baseline[k].P99 << " µm, uncompensated "
                << o.P99_uncompensated << " µm");
    CHECK(o.measurements > 20);
    CHECK(o.P99 < o.P99_uncompensated);  // compensation never makes an output worse
    // Input selection among 16 sensors: the adaptive model beats the static regression on each output.
    CHECK(o.P99 < r.baseline[k].P99);
  }
  CHECK(r.mean_p99(ErrorKind::Linear) < r.mean_p99(ErrorKind::Linear, /*baseline=*/true));
}

// Equal element by element, NaN equal to NaN (a vector that marks "none" with NaN).
static bool same(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  return a.size() == b.size() && ((a.array() == b.array()) || (a.array().isNaN() && b.array().isNaN())).all();
}

// A scenario (case A, H5) run into a fresh history up to `stop_h`, then resumed from that history to its end:
// the resumed run (its source is named "case A" whatever the scenario: a label, the same in both runs).
static std::unique_ptr<Replay> stopped_and_resumed(const alc::scenarios::Scenario& scenario, const AlcParameters& p,
                                                   const std::string& db_name, double stop_h) {
  ReplayOptions o = in_memory(p);
  o.source = "case A";
  o.db = temp_db(db_name);
  o.stop_time_s = stop_h * 3600.0;
  {
    Replay first(scenario, o);
    first.run();
  }
  o.resume = true;
  o.stop_time_s = kInf;
  auto second = std::make_unique<Replay>(scenario, o);
  second->run();
  return second;
}

TEST_CASE("load case A: a run stopped at many points and resumed from its history continues bit for bit") {
  const auto simulated = simulate_case("A");
  Replay uninterrupted(simulated.scenario, in_memory(AlcParameters{}));
  uninterrupted.run();
  const ReplayReport whole = uninterrupted.report();
  const ControllerState& end = uninterrupted.controller().state();
  for (double stop_h : {0.0, 6.0, 6.5, 7.0, 30.0, 100.25, 191.0}) {
    const auto second = stopped_and_resumed(simulated.scenario, AlcParameters{}, "cases-A", stop_h);
    const ReplayReport r = second->report();
    INFO("stopped at " << stop_h << " h");
    CHECK(r.M == whole.M);
    CHECK(r.updates == whole.updates);
    CHECK(r.ng_phases == whole.ng_phases);
    // The decisions themselves, not only the indicators: every probe time, the model, its state.
    const ControllerState& c = second->controller().state();
    REQUIRE(c.probes.size() == end.probes.size());
    for (std::size_t k = 0; k < c.probes.size(); ++k) CHECK(c.probes[k].time_s == end.probes[k].time_s);
    CHECK(c.structure_span_s == end.structure_span_s);
    CHECK(c.predictor.state() == end.predictor.state());
    CHECK(c.next_probe_due_s == end.next_probe_due_s);
    // The guard's evidence and what it applies (docs/adaptive.md) continue alike.
    CHECK(c.guard_cross == end.guard_cross);
    CHECK(c.guard_power == end.guard_power);
    CHECK(c.guard_gain == end.guard_gain);
    CHECK(c.error_low == end.error_low);
    CHECK(c.error_high == end.error_high);
    CHECK(c.guard_off_range == end.guard_off_range);
    CHECK(c.guard_held == end.guard_held);
    CHECK(c.first_check_due == end.first_check_due);
    CHECK(same(c.guard_check_hold, end.guard_check_hold));
    CHECK(c.guard_level_sum == end.guard_level_sum);
    CHECK(c.guard_level_weight == end.guard_level_weight);
    CHECK(c.guard_level_told == end.guard_level_told);
    for (std::size_t k = 0; k < r.outputs.size(); ++k) {
      CHECK(r.outputs[k].P99 == whole.outputs[k].P99);
      CHECK(r.outputs[k].RMSE == whole.outputs[k].RMSE);
      CHECK(r.outputs[k].SMAPE == whole.outputs[k].SMAPE);
      CHECK(r.baseline[k].P99 == whole.baseline[k].P99);
    }
  }
}

TEST_CASE("held-out H5: a run stopped while the guard's first check holds an output resumes bit for bit") {
  // H5 at its own seed: the first check after CP (7.5 h) finds E_Z0T's compensation worse than none and
  // compensates the error its probe measured until the probe at 9.5 h; stopped within the hold and just
  // before the check, then resumed.
  const auto simulated = simulate_case("H5");
  Replay uninterrupted(simulated.scenario, in_memory(AlcParameters{}));
  uninterrupted.run();
  const ReplayReport whole = uninterrupted.report();
  const ControllerState& end = uninterrupted.controller().state();
  for (double stop_h : {7.4, 7.6, 8.0}) {
    const auto second = stopped_and_resumed(simulated.scenario, AlcParameters{}, "cases-H5", stop_h);
    const ReplayReport r = second->report();
    INFO("stopped at " << stop_h << " h");
    CHECK(r.M == whole.M);
    CHECK(r.updates == whole.updates);
    const ControllerState& c = second->controller().state();
    CHECK(same(c.guard_check_hold, end.guard_check_hold));
    CHECK(c.predictor.state() == end.predictor.state());
    for (std::size_t k = 0; k < r.outputs.size(); ++k) CHECK(r.outputs[k].P99 == whole.outputs[k].P99);
  }
}

TEST_CASE("load case A with a 10 h window: a resumed run clamps its predictions as the uninterrupted one") {
  // With a short window the model of E_Y0C runs into its output limit from 77.95 h on. The limit was not
  // part of the stored model: resumed at 77 h, the prediction ran on unclamped (46.8 ... 52.6 against
  // 45.788 µm) until the next fit, and RMSE and SMAPE differed.
  const auto simulated = simulate_case("A");
  AlcParameters p;
  p.learning_window_s = 10.0 * 3600.0;
  Replay uninterrupted(simulated.scenario, in_memory(p));
  uninterrupted.run();
  const ReplayReport whole = uninterrupted.report();
  const auto second = stopped_and_resumed(simulated.scenario, p, "cases-A-window", 77.0);
  const ReplayReport r = second->report();
  const auto& a = uninterrupted.controller().state().predictor.model().outputs;
  const auto& b = second->controller().state().predictor.model().outputs;
  REQUIRE(a.size() == b.size());
  for (std::size_t k = 0; k < a.size(); ++k) CHECK(b[k].output_limit == a[k].output_limit);
  for (std::size_t k = 0; k < r.outputs.size(); ++k) {
    INFO(r.outputs[k].name);
    CHECK(r.outputs[k].P99 == whole.outputs[k].P99);
    CHECK(r.outputs[k].RMSE == whole.outputs[k].RMSE);
    CHECK(r.outputs[k].SMAPE == whole.outputs[k].SMAPE);
  }
}

TEST_CASE("load case A with CP prolonged (learning since 10 h): the baseline of a resumed run is the uninterrupted one's") {
  // CP cannot end before probes from 10 h on allow a fit: it ends on a probe cycle, not at 6.5 h. The
  // baseline is fitted in that cycle; before, the uninterrupted run evaluated that probe's row with a
  // baseline of zero, and a resumed run (which rebuilds the rows with the fitted baseline) differed.
  const auto simulated = simulate_case("A");
  AlcParameters p;
  p.learning_since_s = 10.0 * 3600.0;
  Replay uninterrupted(simulated.scenario, in_memory(p));
  uninterrupted.run();
  const ReplayReport whole = uninterrupted.report();
  REQUIRE(whole.cp_end_s > 10.0 * 3600.0);
  const auto second = stopped_and_resumed(simulated.scenario, p, "cases-A-since", 25.0);
  const ReplayReport r = second->report();
  REQUIRE(r.baseline.size() == whole.baseline.size());
  for (std::size_t k = 0; k < r.baseline.size(); ++k) {
    INFO("output " << k);
    CHECK(r.baseline[k].P99 == whole.baseline[k].P99);
    CHECK(r.baseline[k].PV == whole.baseline[k].PV);
    CHECK(r.outputs[k].P99 == whole.outputs[k].P99);
  }
}

TEST_CASE("load case A with the adaptive schedule: a run stopped and resumed from its history continues bit for bit") {
  const auto simulated = simulate_case("A");
  AlcParameters p;
  p.schedule_kind = AlcParameters::Schedule::Adaptive;
  p.min_interval_s = 0.25 * 3600.0;
  // Also with a budget beyond the ACL and no maximum interval (the loosest policy of the study grid).
  const bool loose = GENERATE(false, true);
  if (loose) {
    p.uncertainty_fraction = 3.0;
    p.max_interval_s = kInf;
  }
  INFO((loose ? "fraction 3, no maximum interval" : "fraction 0.5, maximum 12 h"));
  Replay uninterrupted(simulated.scenario, in_memory(p));
  uninterrupted.run();
  const ReplayReport whole = uninterrupted.report();
  const ControllerState& end = uninterrupted.controller().state();
  REQUIRE((end.kappa.array() > 0.0).any());  // the prediction's change is part of the evidence on A
  for (double stop_h : {7.0, 40.5, 150.0}) {
    const auto second = stopped_and_resumed(simulated.scenario, p, loose ? "cases-A-loose" : "cases-A-adaptive", stop_h);
    const ReplayReport r = second->report();
    INFO("stopped at " << stop_h << " h");
    CHECK(r.M == whole.M);
    const ControllerState& c = second->controller().state();
    REQUIRE(c.probes.size() == end.probes.size());
    for (std::size_t k = 0; k < c.probes.size(); ++k) CHECK(c.probes[k].time_s == end.probes[k].time_s);
    CHECK(c.next_probe_due_s == end.next_probe_due_s);
    // The schedule's evidence (run state version 6) continues alike.
    CHECK(c.drift_rate == end.drift_rate);
    CHECK(c.kappa == end.kappa);
    CHECK(c.schedule_sums == end.schedule_sums);
    CHECK(c.schedule_since_s == end.schedule_since_s);
    CHECK(c.schedule_prediction == end.schedule_prediction);
    for (std::size_t k = 0; k < r.outputs.size(); ++k) CHECK(r.outputs[k].P99 == whole.outputs[k].P99);
  }
}

TEST_CASE("run state: a snapshot of version 8, from before the guard's level, is read and starts without a level") {
  // A supervisor that ran for months on the previous release restarts on this one from its latest snapshot.
  // Version 8 is version 9 without the level's three vectors at the end of the controller: built here from
  // a version 9 payload whose level vectors are empty (three zero lengths), cut out, with the older header.
  const auto simulated = simulate_case("A");
  Replay session(simulated.scenario, in_memory(AlcParameters{}));
  session.run_until(10 * 3600.0);  // CP ended at 6.5 h: the Post-CP probes have set a level
  const RunState v9 = decode_run_state(session.encode_state());
  REQUIRE((v9.controller.guard_level_weight.array() > 0.0).any());
  RunState without = v9;
  without.controller.guard_level_sum = without.controller.guard_level_weight =
      without.controller.guard_level_told = Eigen::VectorXd();
  const std::string full = encode_run_state(v9), empty = encode_run_state(without);
  // The first byte where they differ is the length of the first level vector (0 against the outputs).
  std::size_t at = 0;
  while (at < empty.size() && full[at] == empty[at]) ++at;
  REQUIRE(at + 24 <= empty.size() - 8);
  REQUIRE(empty.substr(at, 24) == std::string(24, '\0'));
  std::string body = empty.substr(0, at) + empty.substr(at + 24, empty.size() - 8 - at - 24);
  common::ByteWriter h9, h8, sum;
  h9.write_header(kRunStateFormat, 9);
  h8.write_header(kRunStateFormat, 8);
  REQUIRE(body.compare(0, h9.bytes().size(), h9.bytes()) == 0);
  body.replace(0, h9.bytes().size(), h8.bytes());
  sum.u64(common::checksum64(body));
  const RunState v8 = decode_run_state(body + sum.bytes());
  CHECK(v8.controller.guard_level_sum.size() == 0);
  CHECK(v8.controller.guard_gain == v9.controller.guard_gain);
  CHECK(v8.controller.guard_check_hold.size() == v9.controller.guard_check_hold.size());
  CHECK(v8.controller.probes.size() == v9.controller.probes.size());
  CHECK(v8.controller.samples == v9.controller.samples);
  CHECK(v8.total_s == v9.total_s);
  // The controller sizes what the older state lacks: no level, learnt again from the next Post-CP probe.
  ControllerState c = v8.controller;
  init_evidence(c, static_cast<std::size_t>(v9.controller.guard_gain.size()));
  CHECK(c.guard_level_sum.size() == v9.controller.guard_level_sum.size());
  CHECK(c.guard_level_sum.isZero());
  CHECK(c.guard_level_weight.isZero());
  CHECK(c.guard_level_told.isZero());
  // And a version this program does not know yet is refused by name.
  common::ByteWriter h10, sum10;
  h10.write_header(kRunStateFormat, 10);
  std::string future = full.substr(0, full.size() - 8);
  future.replace(0, h10.bytes().size(), h10.bytes());
  sum10.u64(common::checksum64(future));
  CHECK_THROWS_WITH(decode_run_state(future + sum10.bytes()), Catch::Matchers::Contains("version 10"));
}

TEST_CASE("run state: a truncated, damaged or foreign snapshot payload is refused") {
  const auto simulated = simulate_case("A");
  Replay session(simulated.scenario, in_memory(AlcParameters{}));
  session.run_until(10 * 3600.0);
  const std::string bytes = session.encode_state();
  const RunState decoded = decode_run_state(bytes);
  CHECK(decoded.controller.samples == 600);
  CHECK(decoded.controller.probes.size() == session.controller().state().probes.size());
  // The guard's state travels with the snapshot (run state version 5).
  const ControllerState& live = session.controller().state();
  CHECK(decoded.controller.guard_probes == live.guard_probes);
  CHECK(decoded.controller.guard_probes > 0);
  CHECK(decoded.controller.guard_cross == live.guard_cross);
  CHECK(decoded.controller.guard_power == live.guard_power);
  CHECK(decoded.controller.guard_error == live.guard_error);
  CHECK(decoded.controller.guard_gain == live.guard_gain);
  CHECK(decoded.controller.error_low == live.error_low);
  CHECK(decoded.controller.error_high == live.error_high);
  CHECK(decoded.controller.guard_off_range == live.guard_off_range);
  // And the schedule's evidence of the prediction's change (version 6).
  CHECK(decoded.controller.kappa == live.kappa);
  CHECK(decoded.controller.schedule_since_s == live.schedule_since_s);
  CHECK(decoded.controller.schedule_since_s >= 6.5 * 3600.0);  // CP ended at 6.5 h
  CHECK(decoded.controller.schedule_prediction == live.schedule_prediction);
  CHECK(decoded.controller.schedule_sums == live.schedule_sums);
  // And which outputs the drift bound holds back (version 7).
  CHECK(decoded.controller.guard_held == live.guard_held);
  // And the first check's judgement of the model (version 8): a check due (A at 7 h: CP ended at 6.5 h,
  // the check comes at 7.5 h), an output held (H5 at 7.6 h: the check found E_Z0T's compensation worse
  // than none).
  Replay due(simulated.scenario, in_memory(AlcParameters{}));
  due.run_until(7 * 3600.0);
  REQUIRE(due.controller().state().first_check_due);
  CHECK(decode_run_state(due.encode_state()).controller.first_check_due);
  const auto h5 = simulate_case("H5");
  Replay holding(h5.scenario, in_memory(AlcParameters{}));
  holding.run_until(7.6 * 3600.0);
  const ControllerState& held = holding.controller().state();
  REQUIRE_FALSE(held.guard_check_hold.array().isNaN().all());
  const RunState held_decoded = decode_run_state(holding.encode_state());
  CHECK(same(held_decoded.controller.guard_check_hold, held.guard_check_hold));
  CHECK_FALSE(held_decoded.controller.first_check_due);
  // And the guard's level (version 9): H5 at 7.6 h has learnt from the first check's probe.
  REQUIRE((held.guard_level_weight.array() > 0.0).any());
  REQUIRE_FALSE(held.guard_level_sum.isZero());
  CHECK(held_decoded.controller.guard_level_sum == held.guard_level_sum);
  CHECK(held_decoded.controller.guard_level_weight == held.guard_level_weight);
  CHECK(held_decoded.controller.guard_level_told == held.guard_level_told);
  CHECK_THROWS_WITH(decode_run_state(bytes.substr(0, bytes.size() / 2)), Catch::Matchers::Contains("checksum"));
  CHECK_THROWS_WITH(decode_run_state(bytes + "x"), Catch::Matchers::Contains("checksum"));
  std::string flipped = bytes;
  flipped[flipped.size() / 2] = static_cast<char>(flipped[flipped.size() / 2] ^ 0x10);
  CHECK_THROWS_WITH(decode_run_state(flipped), Catch::Matchers::Contains("damaged"));
  CHECK_THROWS_AS(decode_run_state(std::string(64, '\0')), std::runtime_error);
  CHECK_THROWS_AS(decode_run_state(""), std::runtime_error);
}

TEST_CASE("run state: a snapshot holds no input samples, so its size does not grow with the run") {
  const auto simulated = simulate_case("A");
  const auto db = temp_db("snapshot-size");
  ReplayOptions o = in_memory(AlcParameters{});
  o.source = "case A";
  o.db = db;
  Replay replay(simulated.scenario, o);
  replay.run();
  const auto snapshots = storage::HistoryReader(db).snapshots(*replay.run_id());
  REQUIRE(snapshots.size() >= 9);  // start, every 24 h of 192 h, end
  // From day 2 on the payload holds the Post-CP probes and the model: a few kB, not the 11521 x 5
  // inputs (460 kB) that a snapshot with the history would carry at the end.
  for (const auto& s : snapshots) {
    INFO("snapshot at " << s.time_s << " s: " << s.payload.size() << " bytes");
    CHECK(s.payload.size() < 40000);
  }
}

TEST_CASE("alc replay --case all --json is the same, byte for byte, as the reference output") {
  // tests/runtime/reference/replay_all.json was printed by the replay before the runtime driver was
  // introduced; a change of any decision or indicator of A-D shows here.
  std::ifstream in(std::string(ALC_SOURCE_DIR) + "/tests/runtime/reference/replay_all.json", std::ios::binary);
  REQUIRE(in);
  std::stringstream expected;
  expected << in.rdbuf();
  const alc_test::CliRun r = alc_test::run_alc("replay --case all --json", "replay_all_json");
  REQUIRE(r.exit_code == 0);
  CHECK(r.out == expected.str());
}
