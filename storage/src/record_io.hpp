#pragma once
// Private to storage/: reading runs and snapshots, shared by the reader and by the writer's resume.
#include <optional>
#include <vector>

#include "sqlite_db.hpp"
#include "storage/records.hpp"

namespace alc::storage::detail {

// Every run (or only `only`), with channel names, in run_id order.
std::vector<RunRecord> query_runs(Database& db, std::optional<RunId> only = std::nullopt);
// Snapshots of a run in (time_s, snapshot_id) order; only the last one if `latest_only`.
std::vector<ControllerSnapshot> query_snapshots(Database& db, RunId run, bool latest_only);
// The columns every snapshot query selects, in this order (read_snapshot reads a row of them).
inline constexpr const char* kSnapshotColumns = "run_id, time_s, next_sample_index, format, is_json, payload, snapshot_id";
ControllerSnapshot read_snapshot(Statement& st);

}  // namespace alc::storage::detail
