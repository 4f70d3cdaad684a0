#pragma once
// Reads a history database back (read-only connection; never migrates or writes).
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "storage/records.hpp"

namespace alc::storage {

struct TableCount {
  std::string table;
  std::int64_t rows = 0;
};

struct TimeSpan {
  double first_s = 0.0;   // [s] earliest time_s over every table of the run (not kSnapshotBeforeStart_s)
  double last_s = 0.0;    // [s] latest
  bool empty = true;      // no timed record at all
};

class HistoryReader {
 public:
  // Same refusals as HistoryWriter (not SQLite, foreign, newer, truncated, tables missing); older
  // ALC schema versions are read as they are (tables added later read as empty). In a directory it
  // cannot write to and with no FILE-wal beside the file, the file is opened immutable (read-only,
  // no locks, no -shm), so a history on read-only media or in another user's directory reads. Every
  // reader sets query_only; one that finds no FILE-wal or FILE-journal and may write the file and its directory
  // opens it read-write, so that closing it removes the -wal and -shm it made (docs/storage.md).
  explicit HistoryReader(const std::filesystem::path& path);
  ~HistoryReader();
  HistoryReader(HistoryReader&&) noexcept;
  HistoryReader& operator=(HistoryReader&&) noexcept;

  const std::filesystem::path& path() const;
  int schema_version() const;

  std::vector<RunRecord> runs() const;
  std::optional<RunRecord> run(RunId run) const;
  // The run with the highest id whose status is Running or Stopped (the one to resume).
  std::optional<RunRecord> latest_unfinished_run() const;

  // All in insertion (= time) order.
  std::vector<InputSampleRecord> input_samples(RunId run) const;
  std::vector<ProbeMeasurementRecord> probe_measurements(RunId run) const;
  std::vector<PredictionRecord> predictions(RunId run) const;
  std::vector<ModelParameterSetRecord> model_parameter_sets(RunId run) const;
  std::vector<PhaseChangeRecord> phase_changes(RunId run) const;
  std::vector<ProbeIntervalChangeRecord> probe_interval_changes(RunId run) const;
  std::vector<NcCommandRecord> nc_commands(RunId run) const;
  std::vector<ControllerSnapshot> snapshots(RunId run) const;
  std::optional<ControllerSnapshot> latest_snapshot(RunId run) const;
  // The indicators the run ended with; none for a run that has not ended, one that stores none (a
  // supervisor run) or a file older than schema version 5.
  std::optional<RunIndicatorsRecord> indicators(RunId run) const;

  std::vector<TableCount> table_counts() const;   // every table of the schema version
  TimeSpan time_span(RunId run) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace alc::storage
