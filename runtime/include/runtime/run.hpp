#pragma once
// The lifecycle of a run recorded in a history: begin (or resume the latest unfinished run of the
// same identity: the same data, by content, and parameters), the snapshot schedule, delivery records of NC output, end.
// Used by replay and bench alike (and the supervisor next).
//
// Snapshot schedule: after the first sample at or past the run's first sample + every_s, then
// after the first sample at or past the previous snapshot + every_s. A resumed run counts from the
// run's first sample too, so past that point it saves a snapshot after its first sample.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "alc/controller.hpp"
#include "runtime/driver.hpp"
#include "storage/history_reader.hpp"
#include "storage/history_writer.hpp"

namespace alc::runtime {

// The run's identity: the canonical parameters (parsed values, never the text they came from),
// as JSON with every number exact; "inf" / "-inf" where the value is infinite. Two runs with the
// same identity make the same decisions on the same data.
nlohmann::json canonical_parameters(const AlcParameters& parameters, std::string_view schedule = "paper");

// A run that may still be resumed: running (killed, or still running) or stopped.
bool unfinished(const storage::RunRecord& run);

// The latest run of `source` running or stopped (none if there is none).
std::optional<storage::RunRecord> latest_unfinished_run(const std::vector<storage::RunRecord>& runs,
                                                        const std::string& source);

// The "scenario_hash" of a run's config_json (a replay's: the content hash of its data), "" if none.
std::string scenario_hash_of(const std::string& config_json);

// The run a resume continues: the latest unfinished run of `source` with this identity (config_json);
// else, when the identity holds a scenario hash (a replay), the latest unfinished run of this identity
// under another source (the same data by another path, from another directory, a copy); else the
// latest unfinished run of `source` (which the caller refuses naming what differs); else none.
std::optional<storage::RunRecord> run_to_resume(const std::vector<storage::RunRecord>& runs, const std::string& source,
                                                const std::string& config_json);

// "its unfinished runs: run 3 of 'file mix.csv' (stopped, its latest snapshot at 20 h from its first
// sample, content hash …)" for every unfinished run of `runs`, or "there is no unfinished run in it".
std::string unfinished_runs_text(const storage::HistoryReader& history, const std::vector<storage::RunRecord>& runs);

// What differs between two run configurations (JSON), leaf by leaf: "/parameters/cp_duration_s: stored
// 23400, given 43200; ..." (at most 5, then how many more); both texts whole if either is not JSON.
std::string config_difference(const std::string& stored_text, const std::string& given_text);

// A resume that cannot be done (no unfinished run, another identity): the history is unchanged.
// `run`: the unfinished run that was found but cannot be continued (0 when there is none).
class ResumeRefused : public std::runtime_error {
 public:
  explicit ResumeRefused(const std::string& what, std::int64_t run_id = 0) : std::runtime_error(what), run(run_id) {}
  std::int64_t run;
};

class RunLifecycle : public Observer {
 public:
  // Encodes the state to save at a consistent point: the payload of the snapshot.
  using Encoder = std::function<std::string(std::int64_t next_index)>;

  // Begins a new run (committed at once).
  RunLifecycle(storage::HistoryWriter& writer, const storage::RunRecord& record, double snapshot_every_s);
  // Resumes the unfinished run of `record` in `db` (the file `writer` has open; run_to_resume: by
  // identity, the scenario's content included, so another path to the same data is the same run):
  // refuses (ResumeRefused) when there is none (naming the unfinished runs there are) or the run found
  // has another config_json or other channels (naming what differs). Records
  // after its latest snapshot are deleted; that snapshot is resumed_from().
  struct Resume {};
  RunLifecycle(storage::HistoryWriter& writer, const std::filesystem::path& db, const storage::RunRecord& record,
               double snapshot_every_s, Resume);

  void set_encoder(Encoder encoder) { encoder_ = std::move(encoder); }
  storage::RunId run() const { return run_; }
  const std::optional<storage::ControllerSnapshot>& resumed_from() const { return resumed_from_; }

  // Saves a snapshot when one is due.
  void on_sample_done(const Sample& sample, const Controller& controller, std::int64_t next_index) override;
  // Stores the state as a snapshot now (commits everything before it).
  void save_snapshot(const Controller& controller, std::int64_t next_index);
  // Records the delivery of the run's accepted NC commands of `sink` (delivered or not, why).
  void record_delivery(const std::string& sink, bool delivered, const std::string& message);
  // Ends the run: Finished, or Stopped (resumable). `indicators`: the run's evaluation as
  // report_json() gives it (what `alc replay --json` prints), stored with the end (run_indicators);
  // none for a run without truth to evaluate against (a supervisor).
  void end(bool finished, const std::optional<nlohmann::json>& indicators = std::nullopt);

 private:
  storage::HistoryWriter& writer_;
  storage::RunId run_ = 0;
  double snapshot_every_s_;
  double next_snapshot_s_ = -kInf;
  Encoder encoder_;
  std::optional<storage::ControllerSnapshot> resumed_from_;
};

}  // namespace alc::runtime
