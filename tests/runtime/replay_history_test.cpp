// The history of a replay: the offsets stored with each prediction are the ones that cancel it;
// each probe is stored with the phase it was taken in; NC commands with the safety gate's verdict.
#include <catch2/catch.hpp>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <limits>
#include <map>
#include <optional>
#include <random>

#include "nc_interface/jsonl.hpp"
#include "runtime/history_recorder.hpp"
#include "runtime/replay.hpp"
#include "runtime/run.hpp"
#include "scenarios/load_cases.hpp"
#include "storage/history_reader.hpp"

using namespace alc;
using namespace alc::runtime;
using alc::scenarios::Scenario;
using alc::scenarios::simulate_case;

namespace {

// A fresh directory under the system temp dir, removed with its contents at scope exit.
struct TempDir {
  std::filesystem::path path = std::filesystem::temp_directory_path() /
                               ("alc_replay_history_test_" + std::to_string(::getpid()) + "_" +
                                std::to_string(std::random_device{}()));
  TempDir() { std::filesystem::create_directories(path); }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
};

// A replay recorded in `file` as `alc replay --db` records it.
ReplayOptions recorded(const std::filesystem::path& file, AlcParameters p = {}) {
  ReplayOptions o;
  o.parameters = std::move(p);
  o.source = "test";
  o.db = file;
  return o;
}

}  // namespace

TEST_CASE("replay history: every prediction is stored with the axis offsets that cancel it") {
  const TempDir dir;
  const auto file = dir.path / "offsets.sqlite";
  const auto simulated = simulate_case("A");
  const Scenario& sc = simulated.scenario;
  const auto chain = kinematics::MachineChain::bc_trunnion();  // not the default: the names follow the chain
  storage::RunId run = 0;
  {
    ReplayOptions o = recorded(file);
    o.machine.chain = chain;
    o.stop_time_s = 12 * 3600.0;
    Replay replay(sc, o);
    replay.run();
    run = *replay.run_id();
  }
  const storage::HistoryReader reader(file);
  CHECK(reader.runs().at(0).offset_names == std::vector<std::string>{"X_um", "Y_um", "Z_um", "B_urad", "C_urad"});
  const auto predictions = reader.predictions(run);
  REQUIRE(predictions.size() > 700);  // 12 h at 1 min
  int nonzero = 0;
  for (std::size_t k = 0; k < predictions.size(); k += 37) {
    const auto& p = predictions[k];
    REQUIRE(p.offsets.size() == 5);
    const Eigen::VectorXd predicted = Eigen::Map<const Eigen::VectorXd>(p.predicted.data(), static_cast<Eigen::Index>(p.predicted.size()));
    const auto c = kinematics::compensate(chain, {}, kinematics::location_errors_of(sc.output_names, predicted));
    REQUIRE(c.converged);
    CHECK(p.offsets[0] == c.offsets.x_um);
    CHECK(p.offsets[1] == c.offsets.y_um);
    CHECK(p.offsets[2] == c.offsets.z_um);
    CHECK(p.offsets[3] == c.offsets.tilt_urad);
    CHECK(p.offsets[4] == c.offsets.table_urad);
    nonzero += std::abs(p.offsets[0]) > 1.0 ? 1 : 0;
  }
  CHECK(nonzero > 5);  // after CP (6.5 h) the model compensates micrometres
}

TEST_CASE("replay history: a run's offset channels exist exactly when some output is a C-axis error") {
  const auto chain = kinematics::MachineChain::ac_trunnion();
  CHECK(HistoryRecorder::offset_names(chain, {"T_X", "E_Z0T"}) == HistoryRecorder::offset_names(chain));
  CHECK(HistoryRecorder::offset_names(chain, {"E_X1", "E_Z2"}).empty());  // S16: no offsets to derive
  // A spindle recording is recorded with no offset channels and empty offsets (the writer checks the
  // count of every vector against the run's channels).
  const Scenario s16 = simulate_case("S16").scenario;
  const TempDir dir;
  ReplayOptions o = recorded(dir.path / "s16.sqlite");
  o.stop_time_s = s16.time_s.front() + 600.0;
  Replay replay(s16, o);
  replay.run();
  const storage::RunId run = *replay.run_id();
  const auto predictions = storage::HistoryReader(dir.path / "s16.sqlite").predictions(run);
  REQUIRE_FALSE(predictions.empty());
  CHECK(predictions.front().offsets.empty());
}

namespace {

// Notes, for every probe, the controller's phase when the probe was taken: the phase after the
// row's sample, before the controller handles the probe.
struct PhaseAtProbe : Observer {
  Phase before_probe = Phase::Calibration;
  std::vector<Phase> phases;
  void on_cycle(const Cycle& cycle) override {
    if (cycle.kind() == Cycle::Kind::Sample) before_probe = cycle.controller().phase();
    else if (cycle.kind() == Cycle::Kind::Probe) phases.push_back(before_probe);
  }
};

}  // namespace

TEST_CASE("replay history: a probe is stored with the phase it was taken in, also when it changes the phase") {
  // Case A with a step of 20 µm in E_X0C from 12 h on: the model cannot know it, so the first
  // Post-CP probe after it breaches the ACL (Post-CP -> NG) and the NG burst ends with NG -> Post-CP.
  Scenario sc = simulate_case("A").scenario;
  const auto x = static_cast<Eigen::Index>(sc.output_index("E_X0C"));
  for (std::size_t k = 0; k < sc.samples(); ++k)
    if (sc.time_s[k] >= sc.time_s.front() + 12 * 3600.0) sc.outputs(static_cast<Eigen::Index>(k), x) += 20.0;
  const TempDir dir;
  const auto file = dir.path / "phases.sqlite";
  storage::RunId run = 0;
  std::vector<Phase> expected;
  {
    PhaseAtProbe tap;
    ReplayOptions o = recorded(file);
    o.stop_time_s = sc.time_s.front() + 24 * 3600.0;
    o.observers.push_back(&tap);
    Replay replay(sc, o);
    replay.run();
    run = *replay.run_id();
    expected = tap.phases;
  }
  const storage::HistoryReader reader(file);
  const auto probes = reader.probe_measurements(run);
  REQUIRE(probes.size() == expected.size());
  std::map<double, std::string> phase_of;  // probe time -> stored phase
  for (std::size_t i = 0; i < probes.size(); ++i) {
    INFO("probe " << i << " at t = " << probes[i].time_s << " s");
    CHECK(probes[i].phase == to_string(expected[i]));
    phase_of[probes[i].time_s] = probes[i].phase;
  }
  int breaches = 0, ng_ends = 0;
  for (const auto& change : reader.phase_changes(run)) {
    INFO("phase change at t = " << change.time_s << " s: " << change.from_phase << " -> " << change.to_phase);
    if (change.from_phase == "Post-CP" && change.to_phase == "NG") {
      ++breaches;
      REQUIRE(phase_of.count(change.time_s) == 1);
      CHECK(phase_of[change.time_s] == "Post-CP");  // the breaching probe, not "NG"
    }
    if (change.from_phase == "NG" && change.to_phase == "Post-CP") {
      ++ng_ends;
      REQUIRE(phase_of.count(change.time_s) == 1);
      CHECK(phase_of[change.time_s] == "NG");  // the last NG probe, not "Post-CP"
    }
  }
  CHECK(breaches >= 1);
  CHECK(ng_ends >= 1);
}

TEST_CASE("replay history: NC commands are stored with the safety gate's verdict before they reach the sink") {
  // Limits so tight that the first model's offsets are refused: accepted = 0 with the gate's reason.
  const Scenario sc = simulate_case("A").scenario;
  const TempDir dir;
  const auto file = dir.path / "nc.sqlite";
  ReplayOptions o = recorded(file);
  o.machine.limits.max_offset.x_mm = 0.002;
  o.nc = NcOutputSetup{dir.path / "out", nc::Dialect::LinuxCNC};
  o.stop_time_s = sc.time_s.front() + 12 * 3600.0;
  Replay replay(sc, o);
  replay.run();
  const storage::RunId run = *replay.run_id();
  const NcCommandObserver& nc_observer = *replay.nc();
  const auto rows = storage::HistoryReader(file).nc_commands(run);
  const auto& decisions = nc_observer.recorder().decisions();
  REQUIRE(rows.size() == decisions.size());
  REQUIRE(rows.size() == nc_observer.commands().size());
  std::size_t refused = 0;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    INFO("command " << i << " at t = " << rows[i].time_s << " s: " << rows[i].text);
    const bool passed = decisions[i].verdict != nc::SafetyVerdict::Refused;
    CHECK(rows[i].accepted == passed);
    CHECK(rows[i].sink == "file:" + (dir.path / "out").string());
    if (passed) {
      CHECK(rows[i].message == (decisions[i].verdict == nc::SafetyVerdict::Split ? decisions[i].message : ""));
    } else {
      ++refused;
      CHECK(rows[i].message == decisions[i].message);                     // the gate's reason
      CHECK(rows[i].text == nc::to_json_line(nc_observer.commands()[i]));  // the request, nothing sent
    }
  }
  CHECK(refused == nc_observer.refused());
  CHECK(refused >= 1);
  CHECK(refused < rows.size());  // probe-interval commands pass
}

TEST_CASE("kinematics: output names map to the seven location errors, others are ignored") {
  const std::vector<std::string> names{"E_C0C", "T_X", "E_X0C", "E_Z1", "E_R0T", "E_B0C"};
  Eigen::VectorXd v(6);
  v << 30.0, 99.0, 1.5, 77.0, std::numeric_limits<double>::quiet_NaN(), -4.0;
  const auto e = kinematics::location_errors_of(names, v);
  CHECK(e.c0c_um_per_m == 30.0);
  CHECK(e.x0c_um == 1.5);
  CHECK(e.r0t_um == 0.0);  // NaN: not measured, stays zero
  CHECK(e.b0c_um_per_m == -4.0);
  CHECK(e.y0c_um == 0.0);
  CHECK(e.z0t_um == 0.0);
  CHECK(e.a0c_um_per_m == 0.0);
  CHECK(kinematics::location_error_field("E_Z0T") == 2);
  CHECK(kinematics::location_error_field("E_Z1") == -1);
}

TEST_CASE("replay history: snapshots every period from the run's first sample, and a resumed run restarts the count") {
  Scenario sc = simulate_case("A").scenario;
  // A recording whose time does not start at 0, also one in negative times: there the snapshot before the
  // first sample (sentinel time -1 s) was taken for the latest, and the resume deleted every sample.
  const double t0 = GENERATE(1.0e6, -2.0e5);
  INFO("t0 = " << t0);
  for (double& t : sc.time_s) t += t0;
  const double h = 3600.0;
  const TempDir dir;
  // As `alc replay --db [--stop-at] [--resume]` runs, with a 2 h period.
  auto record = [&](const std::filesystem::path& file, double stop_s, bool resume) {
    ReplayOptions o = recorded(file);
    o.snapshot_every_s = 2 * h;
    o.stop_time_s = stop_s;
    o.resume = resume;
    Replay replay(sc, o);
    replay.run();
  };
  const auto whole = dir.path / "whole.sqlite", resumed = dir.path / "resumed.sqlite";
  record(whole, t0 + 9 * h, false);
  record(resumed, t0 + 5 * h, false);
  record(resumed, t0 + 9 * h, true);
  auto snapshot_times = [](const std::filesystem::path& file) {
    std::vector<double> times;
    for (const auto& s : storage::HistoryReader(file).snapshots(1)) times.push_back(s.time_s);
    return times;
  };
  const double before = storage::kSnapshotBeforeStart_s, minute = 60.0;
  CHECK(snapshot_times(whole) == std::vector<double>{before, t0 + 2 * h, t0 + 4 * h, t0 + 6 * h, t0 + 8 * h,
                                                     t0 + 9 * h - minute});
  // The stop (last row before 5 h), then the first row replayed after the resume, then 2 h later.
  CHECK(snapshot_times(resumed) == std::vector<double>{before, t0 + 2 * h, t0 + 4 * h, t0 + 5 * h - minute, t0 + 5 * h,
                                                       t0 + 7 * h, t0 + 9 * h - minute});
  // Everything but the snapshots is the same as uninterrupted.
  const storage::HistoryReader a(whole), b(resumed);
  CHECK(a.input_samples(1).size() == b.input_samples(1).size());
  const auto pa = a.predictions(1), pb = b.predictions(1);
  REQUIRE(pa.size() == pb.size());
  for (std::size_t i = 0; i < pa.size(); ++i) {
    INFO("prediction " << i);
    CHECK(pa[i].time_s == pb[i].time_s);
    CHECK(pa[i].predicted == pb[i].predicted);
    CHECK(pa[i].offsets == pb[i].offsets);
  }
  const auto qa = a.probe_measurements(1), qb = b.probe_measurements(1);
  REQUIRE(qa.size() == qb.size());
  for (std::size_t i = 0; i < qa.size(); ++i) {
    CHECK(qa[i].time_s == qb[i].time_s);
    CHECK(qa[i].phase == qb[i].phase);
  }
  CHECK(a.phase_changes(1).size() == b.phase_changes(1).size());
  CHECK(a.model_parameter_sets(1).size() == b.model_parameter_sets(1).size());
}

TEST_CASE("replay history: a model parameter set stores the first probe time its fit could learn from") {
  const TempDir dir;
  const auto simulated = simulate_case("B");
  const Scenario& sc = simulated.scenario;
  const auto windows_of = [&](const AlcParameters& p, const std::string& name) {
    const auto file = dir.path / name;
    storage::RunId run = 0;
    {
      ReplayOptions o = recorded(file, p);
      o.stop_time_s = 30 * 3600.0;
      Replay replay(sc, o);
      replay.run();
      run = *replay.run_id();
    }
    return storage::HistoryReader(file).model_parameter_sets(run);
  };
  AlcParameters p;
  const auto all = windows_of(p, "all.sqlite");
  REQUIRE(all.size() > 3);
  for (const auto& m : all) CHECK(m.window_start_s == sc.time_s.front());  // all data since the start
  p.learning_since_s = 10 * 3600.0;
  p.learning_window_s = 16 * 3600.0;
  const auto limited = windows_of(p, "limited.sqlite");
  REQUIRE(limited.size() > 3);
  for (const auto& m : limited) {
    INFO("fit at " << m.time_s << " s");
    CHECK(m.window_start_s == std::max({sc.time_s.front(), 10 * 3600.0, m.time_s - 16 * 3600.0}));
    CHECK(m.window_end_s == m.time_s);
  }
  CHECK(limited.back().window_start_s == limited.back().time_s - 16 * 3600.0);  // the window took over
}

TEST_CASE("run lifecycle: a resume with other channels is refused naming them, stored and given") {
  // The supervisor's case: the same parameters, but [signals] inputs changed between two starts.
  const TempDir dir;
  const auto file = dir.path / "h.sqlite";
  storage::RunRecord record;
  record.source = "supervisor dmu-1";
  record.config_json = R"({"parameters":{"cp_duration_s":23400.0}})";
  record.input_names = {"T_ENV", "T_WS"};
  record.output_names = {"E_X0C"};
  {
    storage::HistoryWriter writer(file);
    const RunLifecycle begun(writer, record, 3600.0);
    REQUIRE(begun.run() == 1);
  }
  storage::HistoryWriter writer(file);
  record.input_names = {"T_ENV", "T_WS", "T_SP"};
  CHECK_THROWS_WITH(RunLifecycle(writer, file, record, 3600.0, RunLifecycle::Resume{}),
                    file.string() + ": run 1 of 'supervisor dmu-1' was recorded with other inputs: stored [T_ENV, "
                                    "T_WS], given [T_ENV, T_WS, T_SP]");
  record.input_names = {"T_ENV", "T_WS"};
  record.output_names = {"E_Y0C"};
  CHECK_THROWS_WITH(RunLifecycle(writer, file, record, 3600.0, RunLifecycle::Resume{}),
                    Catch::Contains("other outputs: stored [E_X0C], given [E_Y0C]"));
  CHECK(storage::HistoryReader(file).runs().size() == 1);
}

TEST_CASE("run lifecycle: the run a resume continues is found by identity, the scenario's content included, not by path") {
  const auto run = [](storage::RunId id, const std::string& source, const std::string& config,
                      storage::RunStatus status = storage::RunStatus::Stopped) {
    storage::RunRecord r;
    r.run_id = id;
    r.source = source;
    r.config_json = config;
    r.status = status;
    return r;
  };
  const std::string mix = R"({"parameters":{"cp":1},"scenario_hash":"aaaa"})";
  const std::string other = R"({"parameters":{"cp":1},"scenario_hash":"bbbb"})";
  const std::string supervisor = R"({"parameters":{"cp":1}})";
  const std::vector<storage::RunRecord> runs = {
      run(1, "file mix.csv", mix),
      run(2, "file old.csv", mix, storage::RunStatus::Finished),  // finished: never resumed
      run(3, "file b.csv", other),
      run(4, "supervisor dmu-1", supervisor)};
  const auto id = [&](const std::vector<storage::RunRecord>& in, const std::string& source, const std::string& config) {
    const auto found = run_to_resume(in, source, config);
    return found ? found->run_id : storage::RunId{0};
  };
  CHECK(id(runs, "file /data/mix.csv", mix) == 1);   // another path to the same data (or a copy)
  // The same path with other data: the run of that data if there is one, else the path's run, which the
  // lifecycle refuses as recorded from other data.
  CHECK(id(runs, "file mix.csv", other) == 3);
  CHECK(id(runs, "file mix.csv", R"({"parameters":{"cp":1},"scenario_hash":"cccc"})") == 1);
  CHECK(id(runs, "file /data/b-copy.csv", other) == 3);
  // The same path and identity first, else the latest run of that identity.
  std::vector<storage::RunRecord> more = runs;
  more.push_back(run(5, "file /data/mix.csv", mix));
  CHECK(id(more, "file mix.csv", mix) == 1);
  CHECK(id(more, "file elsewhere.csv", mix) == 5);
  // Other parameters under another path: none (the caller lists the unfinished runs).
  CHECK(id(runs, "file /data/mix.csv", R"({"parameters":{"cp":2},"scenario_hash":"aaaa"})") == 0);
  // Without a scenario hash (a supervisor) only the same source is a match, as before.
  CHECK(id(runs, "supervisor dmu-2", supervisor) == 0);
  CHECK(id(runs, "supervisor dmu-1", supervisor) == 4);
  CHECK(id(runs, "supervisor dmu-1", R"({"parameters":{"cp":3}})") == 4);  // refused by the lifecycle
}

TEST_CASE("run lifecycle: a resume that finds no run names the unfinished runs of the file") {
  const TempDir dir;
  const auto file = dir.path / "h.sqlite";
  storage::RunRecord record;
  record.source = "file mix.csv";
  record.config_json = R"({"parameters":{"cp_duration_s":23400.0},"scenario_hash":"aaaa"})";
  record.input_names = {"T_ENV"};
  record.output_names = {"E_X0C"};
  {
    storage::HistoryWriter writer(file);
    const RunLifecycle begun(writer, record, 3600.0);
    writer.add(storage::InputSampleRecord{begun.run(), 0, 3600.0, {20.0}});
    writer.save_snapshot({begun.run(), 3600.0 + 20 * 3600.0, 1, "test/1", false, "x"});
    writer.end_run(begun.run(), storage::RunStatus::Stopped);
  }
  storage::HistoryWriter writer(file);
  storage::RunRecord edited = record;
  edited.source = "file edited.csv";
  edited.config_json = R"({"parameters":{"cp_duration_s":23400.0},"scenario_hash":"bbbb"})";
  CHECK_THROWS_WITH(RunLifecycle(writer, file, edited, 3600.0, RunLifecycle::Resume{}),
                    file.string() + ": no unfinished run of 'file edited.csv' (content hash bbbb) with this identity "
                                    "to resume; its unfinished runs: run 1 of 'file mix.csv' (stopped, its latest "
                                    "snapshot at 20 h from its first sample, content hash aaaa)");
}
