// alc bench: replay speed per load case, the share spent in identification, and the cost of
// recording the history (replay with --db against replay without, in the same invocation).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <tuple>
#include <unistd.h>

#include "commands.hpp"
#include "common/number_text.hpp"
#include "nc_interface/machine_config.hpp"
#include "runtime/replay.hpp"
#include "scenarios/load_cases.hpp"

namespace alc::cli {

namespace {

struct BenchArgs {
  std::string case_name = "all";
  int repeat = 3;
  double long_days = 0.0;  // > 0: the long-run benchmark (memory and time over months)
};

double now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// A long simulated run (case A stretched to `days`) recorded into a fresh history, as a supervisor
// records one sample a minute: at each checkpoint the process's peak and current RSS, the time per
// sample over the day before it, the samples the controller keeps, the size of a snapshot and of the
// database. Once with the default learning window (14 d), then with --window inf as the baseline.
void run_long_bench(const BenchArgs& a, const std::filesystem::path& dir) {
  scenarios::LoadCaseSpec spec;
  try {
    spec = scenarios::load_case_spec(a.case_name == "all" ? "A" : a.case_name);
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--long: ") + e.what());
  }
  spec.info.duration_h = a.long_days * 24.0;
  const double s0 = now_s();
  const auto simulated = scenarios::simulate_load_case(spec, spec.info.default_seed);
  const auto& sc = simulated.scenario;
  std::printf("case %s stretched to %.0f days: %zu samples at %.0f s, simulated in %.1f s; RSS after simulation %.1f MB\n",
              spec.info.name.c_str(), a.long_days, sc.samples(), spec.info.step_s, now_s() - s0,
              proc_status_kb("VmRSS") / 1024.0);
  std::printf("%-10s %6s %14s %14s %13s %15s %15s %12s %8s\n", "window", "day", "peak RSS [MB]", "RSS [MB]",
              "µs/sample", "samples kept", "snapshot [kB]", "db [MB]", "P99[µm]");
  std::vector<double> checkpoints;
  for (double d : {10.0, 30.0, 60.0, 90.0, 180.0, 365.0})
    if (d < a.long_days) checkpoints.push_back(d);
  checkpoints.push_back(a.long_days);
  const std::string window_label = common::shortest_text(AlcParameters{}.learning_window_s / 86400.0) + " d";
  for (const bool bounded : {true, false}) {
    const auto db = dir / (bounded ? "long-window.sqlite" : "long-inf.sqlite");
    runtime::ReplayOptions o;
    o.source = "bench long";
    o.db = db;
    if (!bounded) o.parameters.learning_window_s = kInf;
    runtime::Replay replay(sc, std::move(o));
    const double t0 = sc.time_s.front();
    for (const double day : checkpoints) {
      const double end_s = t0 + day * 86400.0 + 1.0;
      replay.advance(end_s - 86400.0);
      const auto rows_before = static_cast<double>(replay.controller().state().samples);
      const double start = now_s();
      replay.advance(end_s);
      const double per_sample = (now_s() - start) / (static_cast<double>(replay.controller().state().samples) - rows_before);
      const std::string snapshot = replay.encode_state();
      const auto& c = replay.controller().state();
      // The database with its write-ahead log (records not yet checkpointed into the file live there).
      double db_mb = 0.0;
      for (const auto& f : {db, std::filesystem::path(db.string() + "-wal")}) {
        std::error_code ec;
        const auto bytes = std::filesystem::file_size(f, ec);
        if (!ec) db_mb += static_cast<double>(bytes) / 1e6;
      }
      const runtime::ReplayReport r = replay.report();
      std::printf("%-10s %6.0f %14.1f %14.1f %13.1f %15zu %15.1f %12.1f %8.2f\n", bounded ? window_label.c_str() : "inf", day,
                  proc_status_kb("VmHWM") / 1024.0, proc_status_kb("VmRSS") / 1024.0, per_sample * 1e6,
                  c.history.time_s.size(), static_cast<double>(snapshot.size()) / 1024.0, db_mb,
                  r.mean_p99(ErrorKind::Linear));
      std::fflush(stdout);
    }
    replay.run();
  }
  std::printf("µs/sample: wall time of the day before the checkpoint per sample (identifications included);\n"
              "peak RSS is the process's (the simulated scenario itself is held in memory); P99: mean linear P99\n"
              "so far; the inf baseline runs after the bounded one in the same process, so its peak includes the first.\n");
}

struct Timing {
  double replay_s = kInf;          // [s] best of the repeats, no history
  double identification_s = 0.0;   // [s] in that best run
  double with_history_s = kInf;    // [s] best of the repeats, recording into a fresh database
  double full_search_s = kInf;     // [s] best of the repeats, structure search at every update
};

// Best wall time of `repeat` replays with `params` and the identification time of that run.
std::pair<double, double> best_replay(const scenarios::Scenario& scenario, const AlcParameters& params, int repeat) {
  double best = kInf;
  double ident = 0.0;
  for (int i = 0; i < repeat; ++i) {
    const double start = now_s();
    runtime::ReplayOptions o;
    o.parameters = params;
    runtime::Replay replay(scenario, std::move(o));
    replay.run();
    const double elapsed = now_s() - start;
    if (elapsed < best) {
      best = elapsed;
      ident = replay.report().identification_s;
    }
  }
  return {best, ident};
}

Timing bench_case(const scenarios::Scenario& scenario, int repeat, const std::filesystem::path& dir) {
  Timing t;
  std::tie(t.replay_s, t.identification_s) = best_replay(scenario, AlcParameters{}, repeat);
  AlcParameters full;
  full.structure_refresh = 1.0;  // the baseline: the structure searched at every update
  t.full_search_s = best_replay(scenario, full, repeat).first;
  // What `alc replay --db` records without --machine (the same runtime::Replay): with every
  // prediction the axis offsets of the default machine chain, so db/plain is that of the real command.
  for (int i = 0; i < repeat; ++i) {
    const auto db = dir / ("bench-" + std::to_string(i) + ".sqlite");
    const double start = now_s();
    {
      runtime::ReplayOptions o;
      o.source = "bench";
      o.db = db;
      runtime::Replay replay(scenario, std::move(o));
      replay.run();
    }
    t.with_history_s = std::min(t.with_history_s, now_s() - start);
    std::filesystem::remove(db);
    std::filesystem::remove(db.string() + "-wal");
    std::filesystem::remove(db.string() + "-shm");
  }
  return t;
}

void run_bench(const BenchArgs& a) {
  if (a.repeat < 1) throw UsageError("--repeat: must be at least 1, got " + std::to_string(a.repeat));
  const std::vector<std::string> names = load_case_names(a.case_name);
  // The scratch directory goes with its files however the run ends (a refused --long case too).
  struct ScratchDir {
    std::filesystem::path path;
    ~ScratchDir() {
      std::error_code ec;
      std::filesystem::remove_all(path, ec);
    }
  } scratch{std::filesystem::temp_directory_path() / ("alc-bench-" + std::to_string(::getpid()))};
  const auto& dir = scratch.path;
  std::filesystem::create_directories(dir);
  if (a.long_days > 0.0) {
    run_long_bench(a, dir);
    return;
  }
  std::printf("%-5s %8s %10s %12s %14s %12s %16s %9s %18s %9s\n", "case", "samples", "sim [ms]", "replay [ms]",
              "ident. share", "µs/sample", "with --db [ms]", "db/plain", "full search [ms]", "speed-up");
  for (const auto& name : names) {
    const double s0 = now_s();
    const auto simulated = scenarios::simulate_case(name);
    const double sim_s = now_s() - s0;
    const Timing t = bench_case(simulated.scenario, a.repeat, dir);
    const double n = static_cast<double>(simulated.scenario.samples());
    std::printf("%-5s %8.0f %10.1f %12.1f %13.1f%% %12.2f %16.1f %9.2f %18.1f %9.2f\n", name.c_str(), n,
                sim_s * 1e3, t.replay_s * 1e3, 100.0 * t.identification_s / t.replay_s, t.replay_s / n * 1e6,
                t.with_history_s * 1e3, t.with_history_s / t.replay_s, t.full_search_s * 1e3,
                t.full_search_s / t.replay_s);
  }
  std::printf("best of %d runs each; default parameters (the paper's chosen set); full search: the same with\n"
              "--structure-refresh 1 (structure searched at every model update), speed-up = full search / replay\n",
              a.repeat);
}

}  // namespace

void add_bench_command(CLI::App& app) {
  auto args = std::make_shared<BenchArgs>();
  CLI::App* cmd = app.add_subcommand(
      "bench", "Benchmark: replay time per load case, the share spent in identification, and replay with "
               "the history database against replay without it (ratio), all in one invocation.");
  cmd->add_option("--case", args->case_name, "A, B, C, D, S16, H1-H7, all (A-D) or heldout (H1-H5)")->capture_default_str();
  add_whole_option(cmd, "--repeat", args->repeat, "Runs per measurement; the best is reported", 1, 1000000);
  add_number_option(cmd, "--long", args->long_days,
                  "Long-run benchmark instead: case A (or --case B|C|D) stretched to DAYS days, recorded into a "
                  "history; peak RSS, µs/sample, samples kept, snapshot and database size (with its WAL) at 10, 30, "
                  "60, 90 ... days, "
                  "with the default learning window and with --window inf", 1.0, 3650.0)
      ->type_name("DAYS");
  cmd->callback([args] { run_bench(*args); });
}

double proc_status_kb(const std::string& field) {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind(field + ":", 0) == 0) return std::atof(line.c_str() + field.size() + 1);
  return 0.0;
}

}  // namespace alc::cli
