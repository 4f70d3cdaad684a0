#pragma once
// Replay of a recorded or simulated scenario through the driver: the controller, a RecordedSource,
// the indicators (Evaluation), and, as asked, the history (begin or resume a run, snapshots,
// end) and the NC output (commands through the safety gate, files, delivery records).
// `alc replay` and `alc bench` run this; a study runs many.
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "alc/controller.hpp"
#include "nc_interface/dialects.hpp"
#include "nc_interface/machine_config.hpp"
#include "nc_interface/recorder.hpp"
#include "runtime/driver.hpp"
#include "runtime/evaluation.hpp"
#include "runtime/nc_emitter.hpp"
#include "runtime/recorded_source.hpp"
#include "runtime/run.hpp"
#include "scenarios/scenario.hpp"

namespace alc::runtime {

// Where the NC output of a replay goes: DIR/commands.jsonl, DIR/program.<ext>, DIR/safety.jsonl.
struct NcOutputSetup {
  std::filesystem::path dir;
  nc::Dialect dialect = nc::Dialect::LinuxCNC;
};

struct ReplayOptions {
  AlcParameters parameters;
  Controller::SchedulePtr schedule;        // nullptr: seed 004's schedule of `parameters`
  std::string source;                      // what is replayed: "case A", "file a.csv" (the run's source)
  nlohmann::json identity = nlohmann::json::object();  // more of the run's identity (seed, machine, ...)
  std::filesystem::path db;                // history database; empty: none
  bool resume = false;                     // continue the latest unfinished run of `source` in `db`
  double stop_time_s = kInf;               // [s] replay the rows before this scenario time
  // Probes asked for (Driver::set_requests): [s] of scenario time, ascending, and the reason each names.
  std::vector<std::pair<double, std::string>> probe_requests;
  double snapshot_every_s = 24 * 3600.0;   // [s] of scenario time
  nc::MachineConfig machine;               // chain of the offsets (history, NC), NC options, limits
  std::optional<NcOutputSetup> nc;         // NC output; none: no commands
  std::vector<Observer*> observers;        // more observers (after the built-in ones)
  std::vector<BaselineKind> baselines;     // the seeds' static models to evaluate beside ALC (not with resume)
  std::string software_version;            // stored with a new run
};

// Why a replay with `resume` cannot take `baselines` (empty if it can): Replay refuses it, and a
// caller that runs several replays asks first, before any of them changes a history.
std::string resume_problem(bool resume, const std::vector<BaselineKind>& baselines);

// Why `parameters` cannot be replayed on `scenario` (empty if they can): a CP longer than the recording,
// a --since after its end or before its first sample, a recording without a single measurement (CP
// would not end, or learning would change nothing: a table of dashes). `what` names the recording
// ("case A", "a.csv"); `texts` name the two options as the caller's user writes them ("--cp", or a
// grid's "cp ="), with the value as written ("1e6"), or empty for the parameter's value in hours (a
// study: formatted only when there is a problem). alc replay refuses such a run, a study makes it an
// error row.
struct ScenarioOptionTexts {
  std::string cp_option, cp, since_option, since;
};
std::string scenario_problem(const scenarios::Scenario& scenario, const AlcParameters& parameters,
                             const std::string& what, const ScenarioOptionTexts& texts);

// A warning (empty if none) when the recording measures more sparsely than the CP or NG probe
// interval asks: a probe takes the next recorded measurement, so CP gets fewer probes than its
// schedule and an NG burst is stretched (a recording measured every 2 h with the default 5-min CP
// interval ran a CP of 10 h and two rejected fits without a word). Judged by the median spacing of
// the measured rows in the first `cp_duration_s` (against the CP interval) and after it (against the
// NG interval, unless there is no NG burst).
std::string sparse_measurements(const scenarios::Scenario& scenario, const AlcParameters& parameters,
                                const std::string& what);

// The identity a replay with `options` stores (runs.config_json) and a resume must match: the
// canonical parameters under the schedule's name, and options.identity.
std::string replay_identity(const ReplayOptions& options);

class Replay {
 public:
  // Opens the history and begins or resumes the run when `options.db` is set. Throws
  // ResumeRefused, std::invalid_argument (parameters) or a storage error.
  Replay(const scenarios::Scenario& scenario, ReplayOptions options);
  ~Replay();
  Replay(const Replay&) = delete;
  Replay& operator=(const Replay&) = delete;

  // Replays up to options.stop_time_s (again: up to `stop_time_s`), then: the final snapshot and the
  // run's end (Finished, or Stopped), and the NC files with their delivery record. When the NC files
  // cannot be written their delivery is recorded as failed and the error is rethrown.
  void run();
  void run_until(double stop_time_s);
  // Drives the rows before `stop_time_s` without ending anything (a benchmark's checkpoints); run()
  // or run_until() ends the run later.
  void advance(double stop_time_s);

  bool finished() const { return source_.finished(); }
  std::size_t position() const { return source_.position(); }  // the next row of the scenario to replay
  ReplayReport report() const;
  scenarios::Scenario residuals() const { return evaluation_.residuals(); }
  const Controller& controller() const { return controller_; }
  const Evaluation& evaluation() const { return evaluation_; }
  Driver& driver() { return driver_; }
  std::optional<storage::RunId> run_id() const;
  const NcCommandObserver* nc() const { return nc_ ? &*nc_ : nullptr; }
  const std::optional<nc::NcOutputSummary>& nc_summary() const { return nc_summary_; }
  // The run's state as a snapshot would store it (bounded: no input samples).
  std::string encode_state() const;
  // The run record a new run of this replay stores (identity = canonical parameters + options.identity).
  storage::RunRecord run_record() const;
  static std::string nc_sink_name(const std::filesystem::path& dir) { return "file:" + dir.string(); }

  // A resumed run that recorded NC commands before its snapshot, resumed without NC output (--nc-out
  // cannot be combined with --resume): the rest of the run has none.
  struct NcOutputEnded {
    std::vector<std::string> sinks;   // where its earlier commands went ("file:DIR"), each once
    double from_s = 0.0;              // [s] scenario time of the snapshot resumed from (kSnapshotBeforeStart_s: the start)
    std::size_t not_delivered = 0;    // accepted commands before it whose sink failed (delivered 0)
    std::size_t not_settled = 0;      // accepted commands before it never settled (delivered NULL: a kill)
  };
  const std::optional<NcOutputEnded>& nc_output_ended() const { return nc_output_ended_; }

 private:
  void restore(const storage::ControllerSnapshot& snapshot);
  const scenarios::Scenario& scenario_;
  ReplayOptions options_;
  Controller controller_;                  // restore() assigns the resumed state; driver_ refers to it
  RecordedSource source_;
  Evaluation evaluation_;
  Driver driver_;
  std::unique_ptr<storage::HistoryWriter> writer_;
  std::unique_ptr<RunLifecycle> lifecycle_;
  std::unique_ptr<Observer> recorder_;
  std::optional<NcCommandObserver> nc_;
  std::optional<nc::NcOutputSummary> nc_summary_;
  std::optional<NcOutputEnded> nc_output_ended_;
  double total_s_ = 0.0;
  bool ended_ = false;
};

// Replays the whole scenario in memory (no history, no NC output).
ReplayReport replay(const scenarios::Scenario& scenario, const AlcParameters& parameters);

}  // namespace alc::runtime
