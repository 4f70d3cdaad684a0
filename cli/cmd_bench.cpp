// alc bench: replay speed per load case, the share spent in identification, and the cost of
// recording the history (replay with --db against replay without, in the same invocation).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <tuple>
#include <unistd.h>

#include "commands.hpp"
#include "nc_interface/machine_config.hpp"
#include "runtime/replay.hpp"
#include "scenarios/load_cases.hpp"

namespace alc::cli {

namespace {

struct BenchArgs {
  std::string case_name = "all";
  int repeat = 3;
};

double now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
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
  const auto dir = std::filesystem::temp_directory_path() / ("alc-bench-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
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
  std::filesystem::remove_all(dir);
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
  cmd->add_option("--case", args->case_name, "A, B, C, D, S16 or all")->capture_default_str();
  cmd->add_option("--repeat", args->repeat, "Runs per measurement; the best is reported")->capture_default_str();
  cmd->callback([args] { run_bench(*args); });
}

}  // namespace alc::cli
