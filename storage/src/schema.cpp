// Schema DDL per version, the default location, and the small enum/text conversions.
#include "storage/schema.hpp"

#include <cstdlib>
#include <string>

#include "storage/records.hpp"
#include "storage/storage_error.hpp"

namespace alc::storage {

namespace {

// Version 1: the base tables. Never edit a released version: add a new one below.
// Vectors are BLOBs of little-endian float64 (8 bytes per value) aligned with run_channels.
constexpr std::string_view kSchemaV1 = R"sql(
CREATE TABLE runs (
  run_id            INTEGER PRIMARY KEY,
  source            TEXT NOT NULL,
  config_json       TEXT NOT NULL,
  software_version  TEXT NOT NULL,
  started_unix_s    REAL NOT NULL,
  ended_unix_s      REAL,
  status            TEXT NOT NULL CHECK (status IN ('running', 'stopped', 'finished', 'failed'))
);
CREATE TABLE run_channels (
  run_id         INTEGER NOT NULL REFERENCES runs (run_id),
  kind           TEXT NOT NULL CHECK (kind IN ('input', 'output', 'offset')),
  channel_index  INTEGER NOT NULL,
  name           TEXT NOT NULL,
  PRIMARY KEY (run_id, kind, channel_index)
) WITHOUT ROWID;
CREATE TABLE input_samples (
  run_id        INTEGER NOT NULL REFERENCES runs (run_id),
  sample_index  INTEGER NOT NULL,
  time_s        REAL NOT NULL,
  values_f64    BLOB NOT NULL,
  PRIMARY KEY (run_id, sample_index)
) WITHOUT ROWID;
CREATE TABLE probe_measurements (
  probe_id          INTEGER PRIMARY KEY,
  run_id            INTEGER NOT NULL REFERENCES runs (run_id),
  time_s            REAL NOT NULL,
  phase             TEXT NOT NULL,
  measured_f64      BLOB NOT NULL,
  compensation_f64  BLOB NOT NULL,
  weight            REAL NOT NULL
);
CREATE INDEX probe_measurements_by_run ON probe_measurements (run_id, time_s);
CREATE TABLE predictions (
  prediction_id  INTEGER PRIMARY KEY,
  run_id         INTEGER NOT NULL REFERENCES runs (run_id),
  time_s         REAL NOT NULL,
  predicted_f64  BLOB NOT NULL,
  offsets_f64    BLOB NOT NULL
);
CREATE INDEX predictions_by_run ON predictions (run_id, time_s);
CREATE TABLE model_parameter_sets (
  model_id            INTEGER PRIMARY KEY,
  run_id              INTEGER NOT NULL REFERENCES runs (run_id),
  time_s              REAL NOT NULL,
  reason              TEXT NOT NULL,
  window_start_s      REAL,
  window_end_s        REAL,
  model_order         INTEGER NOT NULL,
  inputs_chosen_json  TEXT NOT NULL,
  usable              INTEGER NOT NULL,
  adopted             INTEGER NOT NULL,
  fit_summary_json    TEXT NOT NULL,
  model_json          TEXT NOT NULL
);
CREATE INDEX model_parameter_sets_by_run ON model_parameter_sets (run_id, time_s);
CREATE TABLE phase_changes (
  phase_change_id  INTEGER PRIMARY KEY,
  run_id           INTEGER NOT NULL REFERENCES runs (run_id),
  time_s           REAL NOT NULL,
  from_phase       TEXT NOT NULL,
  to_phase         TEXT NOT NULL,
  reason           TEXT NOT NULL
);
CREATE INDEX phase_changes_by_run ON phase_changes (run_id, time_s);
CREATE TABLE probe_interval_changes (
  interval_change_id  INTEGER PRIMARY KEY,
  run_id              INTEGER NOT NULL REFERENCES runs (run_id),
  time_s              REAL NOT NULL,
  interval_s          REAL NOT NULL,
  reason              TEXT NOT NULL
);
CREATE INDEX probe_interval_changes_by_run ON probe_interval_changes (run_id, time_s);
CREATE TABLE controller_snapshots (
  snapshot_id        INTEGER PRIMARY KEY,
  run_id             INTEGER NOT NULL REFERENCES runs (run_id),
  time_s             REAL NOT NULL,
  next_sample_index  INTEGER NOT NULL,
  format             TEXT NOT NULL,
  is_json            INTEGER NOT NULL,
  payload            BLOB NOT NULL
);
CREATE INDEX controller_snapshots_by_run ON controller_snapshots (run_id, time_s);
)sql";

// Version 2: the NC commands emitted and the safety gate's verdict on each (accepted, message).
constexpr std::string_view kSchemaV2 = R"sql(
CREATE TABLE nc_commands (
  nc_command_id  INTEGER PRIMARY KEY,
  run_id         INTEGER NOT NULL REFERENCES runs (run_id),
  time_s         REAL NOT NULL,
  kind           TEXT NOT NULL,
  text           TEXT NOT NULL,
  sink           TEXT NOT NULL,
  accepted       INTEGER NOT NULL,
  message        TEXT NOT NULL
);
CREATE INDEX nc_commands_by_run ON nc_commands (run_id, time_s);
)sql";

// Version 3: whether the sink took each NC command. delivered: NULL = not handed to a sink (refused
// by the gate, or not yet delivered), 1 = the sink took it, 0 = the sink failed (delivery_message:
// the sink's error, or its note on a delivery).
constexpr std::string_view kSchemaV3 = R"sql(
ALTER TABLE nc_commands ADD COLUMN delivered INTEGER;
ALTER TABLE nc_commands ADD COLUMN delivery_message TEXT NOT NULL DEFAULT '';
)sql";

// Version 4: parameter studies (alc study): the study (grid, cases, program version, shard) and one
// row per (parameter set, case) with the indicators as alc replay --json gives them.
constexpr std::string_view kSchemaV4 = R"sql(
CREATE TABLE studies (
  study_id          INTEGER PRIMARY KEY,
  grid_json         TEXT NOT NULL,
  cases_json        TEXT NOT NULL,
  software_version  TEXT NOT NULL,
  shard             TEXT NOT NULL,
  set_count         INTEGER NOT NULL,
  created_unix_s    REAL NOT NULL
);
CREATE TABLE study_rows (
  study_id         INTEGER NOT NULL REFERENCES studies (study_id),
  set_index        INTEGER NOT NULL,
  case_index       INTEGER NOT NULL,
  status           TEXT NOT NULL CHECK (status IN ('ok', 'error')),
  error            TEXT NOT NULL,
  pd               REAL,
  p99_linear       REAL,
  p99_angular      REAL,
  report_json      TEXT,
  PRIMARY KEY (study_id, set_index, case_index)
) WITHOUT ROWID;
)sql";

// Version 5: the indicators a run ended with (the document `alc replay --json` prints for it), so a
// report shows the replay's own table. One row per run; written when the run ends, removed when it
// is resumed (the resumed run writes it again when it ends).
constexpr std::string_view kSchemaV5 = R"sql(
CREATE TABLE run_indicators (
  run_id          INTEGER PRIMARY KEY REFERENCES runs (run_id),
  stored_unix_s   REAL NOT NULL,
  report_json     TEXT NOT NULL
);
)sql";

}  // namespace

std::string_view migration_sql(int to_version) {
  switch (to_version) {
    case 1: return kSchemaV1;
    case 2: return kSchemaV2;
    case 3: return kSchemaV3;
    case 4: return kSchemaV4;
    case 5: return kSchemaV5;
    default: return {};
  }
}

std::filesystem::path default_history_path() {
  const char* xdg = std::getenv("XDG_DATA_HOME");
  if (xdg && *xdg == '/') return std::filesystem::path(xdg) / "alc" / "history.sqlite";
  const char* home = std::getenv("HOME");
  if (home && *home == '/') return std::filesystem::path(home) / ".local" / "share" / "alc" / "history.sqlite";
  return std::filesystem::path("alc-history.sqlite");
}

const char* to_string(RunStatus status) {
  switch (status) {
    case RunStatus::Running: return "running";
    case RunStatus::Stopped: return "stopped";
    case RunStatus::Finished: return "finished";
    case RunStatus::Failed: return "failed";
  }
  return "running";
}

std::optional<RunStatus> run_status_from_string(const std::string& text) {
  for (RunStatus s : {RunStatus::Running, RunStatus::Stopped, RunStatus::Finished, RunStatus::Failed})
    if (text == to_string(s)) return s;
  return std::nullopt;
}

const char* to_string(StorageErrorKind kind) {
  switch (kind) {
    case StorageErrorKind::NotADatabase: return "not a database";
    case StorageErrorKind::Empty: return "empty";
    case StorageErrorKind::ForeignDatabase: return "database of another program";
    case StorageErrorKind::NewerSchema: return "newer schema";
    case StorageErrorKind::Locked: return "locked";
    case StorageErrorKind::Corrupt: return "corrupt";
    case StorageErrorKind::ReadOnly: return "read-only";
    case StorageErrorKind::DiskFull: return "disk full";
    case StorageErrorKind::NotFound: return "not found";
    case StorageErrorKind::InvalidArgument: return "invalid argument";
    case StorageErrorKind::Io: return "I/O error";
  }
  return "error";
}

StorageError::StorageError(StorageErrorKind error_kind, std::filesystem::path error_file, std::string error_reason)
    : std::runtime_error("history database '" + error_file.string() + "': " + error_reason),
      kind(error_kind),
      file(std::move(error_file)),
      reason(std::move(error_reason)) {}

}  // namespace alc::storage
