#include "record_io.hpp"

namespace alc::storage::detail {

std::vector<RunRecord> query_runs(Database& db, std::optional<RunId> only) {
  Statement st(db,
               "SELECT run_id, source, config_json, software_version, started_unix_s, ended_unix_s, status "
               "FROM runs WHERE ?1 IS NULL OR run_id = ?1 ORDER BY run_id");
  if (only) st.bind(1, *only);
  std::vector<RunRecord> runs;
  while (st.step()) {
    RunRecord r;
    r.run_id = st.column_int(0);
    r.source = st.column_text(1);
    r.config_json = st.column_text(2);
    r.software_version = st.column_text(3);
    r.started_unix_s = st.column_double(4);
    if (!st.is_null(5)) r.ended_unix_s = st.column_double(5);
    r.status = run_status_from_string(st.column_text(6)).value_or(RunStatus::Running);
    runs.push_back(std::move(r));
  }
  Statement channels(db,
                     "SELECT kind, name FROM run_channels WHERE run_id = ?1 ORDER BY kind, channel_index");
  for (RunRecord& r : runs) {
    channels.bind(1, r.run_id);
    while (channels.step()) {
      const std::string kind = channels.column_text(0);
      auto& names = kind == "input" ? r.input_names : kind == "output" ? r.output_names : r.offset_names;
      names.push_back(channels.column_text(1));
    }
    channels.reset();
  }
  return runs;
}

ControllerSnapshot read_snapshot(Statement& st) {
  ControllerSnapshot s;
  s.run_id = st.column_int(0);
  s.time_s = st.column_double(1);
  s.next_sample_index = st.column_int(2);
  s.format = st.column_text(3);
  s.is_json = st.column_int(4) != 0;
  s.payload = st.column_blob(5);
  s.snapshot_id = st.column_int(6);
  return s;
}

// In the order they were written (snapshot_id), which is the run's order: the snapshot before the first
// sample carries the sentinel time kSnapshotBeforeStart_s (-1 s), which is later than every sample of a
// recording with negative times; ordered by time it was taken for the latest and a resume lost the run.
std::vector<ControllerSnapshot> query_snapshots(Database& db, RunId run, bool latest_only) {
  Statement st(db, std::string("SELECT ") + kSnapshotColumns + " FROM controller_snapshots WHERE run_id = ?1 ORDER BY " +
                       (latest_only ? "snapshot_id DESC LIMIT 1" : "snapshot_id"));
  st.bind(1, run);
  std::vector<ControllerSnapshot> snapshots;
  while (st.step()) snapshots.push_back(read_snapshot(st));
  return snapshots;
}

}  // namespace alc::storage::detail
