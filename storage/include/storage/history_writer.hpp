#pragma once
// Appends records to a history database in batched transactions.
//
// Use from a replay or supervisor loop:
//   HistoryWriter writer(path, {});                // opens or creates; migrates; validates
//   RunId run = writer.begin_run(run_record);      // committed at once
//   writer.add(sample); writer.add(prediction); …  // buffered in the open transaction
//   writer.commit();                               // before acting on what was accepted
//   writer.record_delivery(run, sink, ok, message); // after handing NC commands to the sink
//   writer.save_snapshot(snapshot);                // stored and committed at once
//   writer.end_run(run, RunStatus::Finished);      // committed at once
// Records are committed every `batch_size` records, on commit(), save_snapshot(), end_run(),
// record_delivery() and on destruction. A process killed between commits loses only the
// uncommitted batch; the file stays consistent (WAL journal).
//
// Resume: `ResumePoint p = writer.resume_run(run)` returns the latest snapshot and deletes every
// record of the run written after it (time_s > snapshot.time_s, sample_index >= next_sample_index),
// so the continued run rewrites them exactly once, and the run's stored indicators (run_indicators),
// which the resumed run stores again when it ends.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "storage/records.hpp"

namespace alc::storage {

// Durability of a commit. Process: survives a crashed or killed process (WAL, synchronous=NORMAL).
// Power: also survives power loss (synchronous=FULL, an fsync per commit) — for a real machine.
enum class Durability { Process, Power };

struct WriterOptions {
  std::size_t batch_size = 1000;        // records per transaction; 1 = a transaction per record
  int busy_timeout_ms = 5000;           // [ms] wait for another writer's lock before failing
  Durability durability = Durability::Process;
  bool create_directories = false;      // create missing parent directories of the file
  std::int64_t max_page_count = 0;      // cap on the file size in pages (0 = none); SQLITE_FULL above
  // Open an existing history only (to resume a run in it): a missing or empty file, or a symbolic
  // link to nothing, is StorageError(NotFound) and nothing is created or initialised.
  bool must_exist = false;

  // Empty if valid, else which field is wrong and its value.
  std::string validate() const;
};

struct ResumePoint {
  RunRecord run;                        // the run being resumed (status back to Running)
  ControllerSnapshot snapshot;          // restore the controller from this
  std::vector<std::string> skipped;     // later snapshots the check refused: "snapshot ID at time_s T: why"
};

// Empty if the caller can restore from `snapshot`, else why not (its payload is damaged, say). The
// storage layer does not know the payload's format; the runtime does (runtime::run_state_problem).
using SnapshotCheck = std::function<std::string(const ControllerSnapshot&)>;

class HistoryWriter {
 public:
  // Opens `path`, creating an empty ALC database if the file does not exist (or is empty).
  // Refuses, with StorageError naming the file and cause, and without modifying the file: a file
  // that is not SQLite, an SQLite file of another program, a newer schema, a truncated file, an
  // ALC file that lacks the tables of its schema version, a file with damaged pages (PRAGMA
  // quick_check, run on every existing non-empty file before anything is written: Corrupt).
  // An older ALC schema is migrated forward in one transaction.
  explicit HistoryWriter(const std::filesystem::path& path, WriterOptions options = {});
  ~HistoryWriter();  // commits what is pending; errors are swallowed (call close() to see them)
  HistoryWriter(HistoryWriter&&) noexcept;
  HistoryWriter& operator=(HistoryWriter&&) noexcept;
  HistoryWriter(const HistoryWriter&) = delete;
  HistoryWriter& operator=(const HistoryWriter&) = delete;

  // Inserts the run with its channel names and commits. Returns the new run_id.
  RunId begin_run(const RunRecord& run);
  // Sets end time (now) and status, commits.
  void end_run(RunId run, RunStatus status);

  // Buffered in the current transaction; vectors must match the run's channel counts.
  void add(const InputSampleRecord& record);
  void add(const ProbeMeasurementRecord& record);
  void add(const PredictionRecord& record);
  void add(const ModelParameterSetRecord& record);
  void add(const PhaseChangeRecord& record);
  void add(const ProbeIntervalChangeRecord& record);
  void add(const NcCommandRecord& record);  // delivered must be empty when accepted is false

  // Records whether `sink` took the NC commands of `run`: sets delivered and delivery_message on the
  // run's accepted nc_commands rows of that sink whose delivered is still NULL (refused rows and
  // rows already settled are left alone). Commits the pending batch first, so the commands added so
  // far are covered, and the update at once. Returns the number of rows set.
  std::size_t record_delivery(RunId run, const std::string& sink, bool delivered, const std::string& message);

  // Stores (or replaces) the run's indicators, buffered like add() (end_run commits them). Refuses
  // text that is not JSON.
  void store_indicators(const RunIndicatorsRecord& record);

  // Stores the snapshot and commits everything pending with it.
  void save_snapshot(const ControllerSnapshot& snapshot);

  // Retention for a run that goes on for months: deletes the run's input samples with sample_index <
  // before_index and time_s < before_time_s, and its predictions with time_s < before_time_s, then
  // commits; probes, models, phase changes, NC commands and snapshots stay. The caller keeps what a
  // resume reads (the samples from the latest snapshot's history_first_index on). SQLite reuses the
  // freed pages, so the file stops growing. Returns the rows deleted.
  std::int64_t prune_samples(RunId run, std::int64_t before_index, double before_time_s);

  // Commits the open transaction (no-op when nothing is pending).
  void commit();

  // See the file comment. With `usable`, the latest snapshot that passes it: later ones that do not
  // are listed in ResumePoint::skipped (and deleted with the records after the one used). Throws
  // StorageError(NotFound) if the run or its snapshot is missing, StorageError(Corrupt) naming every
  // snapshot and why if none passes; nothing is changed then. With `restorable`, what the resume
  // reads back besides the snapshot (the stored samples of its learning history) is judged on the
  // snapshot chosen before anything is deleted: StorageError(Corrupt) naming why, nothing changed.
  ResumePoint resume_run(RunId run, const SnapshotCheck& usable = {}, const SnapshotCheck& restorable = {});

  // Commits and closes; further calls throw. Safe to call twice.
  void close();

  const std::filesystem::path& path() const;
  std::size_t pending() const;                 // records added since the last commit
  std::uint64_t transactions_committed() const;

 private:
  struct Impl;
  Impl& live() const;  // the open writer, or std::logic_error after close() or a move
  std::unique_ptr<Impl> impl_;
};

}  // namespace alc::storage
