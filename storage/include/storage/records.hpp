#pragma once
// Record types of the history database (docs/storage.md): plain values, one struct per table.
// Vectors of errors, compensations, offsets and input values are aligned with the run's channel
// names (RunRecord::input_names, output_names, offset_names) and stored exactly (bit for bit).
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace alc::storage {

using RunId = std::int64_t;

enum class RunStatus { Running, Stopped, Finished, Failed };
// "running", "stopped", "finished", "failed": the text stored in runs.status.
const char* to_string(RunStatus status);
// Inverse of to_string; std::nullopt for any other text.
std::optional<RunStatus> run_status_from_string(const std::string& text);

// One replay, supervisor session or study run. Channel names fix the meaning of every vector
// stored for the run.
struct RunRecord {
  RunId run_id = 0;                         // assigned by HistoryWriter::begin_run
  std::string source;                       // what was run: scenario file, "case A", "supervisor"
  std::string config_json = "{}";           // the full configuration as JSON text (required)
  std::string software_version;             // "alc 0.1.0"
  double started_unix_s = 0.0;              // [s] wall clock at start (0: set to now by begin_run)
  std::optional<double> ended_unix_s;       // [s] wall clock at end, empty while running
  RunStatus status = RunStatus::Running;
  std::vector<std::string> input_names;     // model inputs, order of InputSampleRecord::values
  std::vector<std::string> output_names;    // errors ("E_X0C"), order of every error vector
  std::vector<std::string> offset_names;    // NC offsets ("X_um"), order of PredictionRecord::offsets
};

// One input sample (temperatures [°C], speeds [rpm], 0/1 states).
struct InputSampleRecord {
  RunId run_id = 0;
  std::int64_t sample_index = 0;            // 0-based index of the sample in the run's input stream
  double time_s = 0.0;                      // [s] scenario or machine time
  std::vector<double> values;               // one per input name
};

// One probe cycle as measured (closed loop: the error left after compensation).
struct ProbeMeasurementRecord {
  RunId run_id = 0;
  double time_s = 0.0;                      // [s]
  std::string phase;                        // phase when probed, before the probe was handled:
                                            // "CP", "Post-CP", "NG" (alc::to_string(Phase))
  std::vector<double> measured;             // [µm] or [µm/m] per output; NaN = not measured
  std::vector<double> compensation;         // [µm] or [µm/m] per output, active at probe time
  double weight = 1.0;                      // [-] weight in identification (0 = screened out)
};

// A model prediction and the axis offsets derived from it.
struct PredictionRecord {
  RunId run_id = 0;
  double time_s = 0.0;                      // [s]
  std::vector<double> predicted;            // [µm] or [µm/m] per output
  std::vector<double> offsets;              // per offset name, unit in the name ("X_um", "C_mdeg")
};

// A model parameter set produced by identification (adopted or not).
struct ModelParameterSetRecord {
  RunId run_id = 0;
  double time_s = 0.0;                      // [s] when the fit was made
  std::string reason;                       // "end of CP", "NG re-identification", ...
  double window_start_s = 0.0;              // [s] first data used
  double window_end_s = 0.0;                // [s] last data used
  int order = 0;                            // highest ARX order over the outputs
  std::vector<std::string> inputs_chosen;   // input names the model uses
  bool usable = false;                      // FitResult::usable
  bool adopted = false;                     // true if the controller switched to this set
  std::string fit_summary_json = "{}";      // per-output fit summary (rms, condition, ...)
  std::string model_json = "{}";            // structure and parameters (see model_json.hpp)
};

// A change of the controller's phase.
struct PhaseChangeRecord {
  RunId run_id = 0;
  double time_s = 0.0;                      // [s]
  std::string from_phase;                   // "" at the start of a run
  std::string to_phase;                     // "CP", "Post-CP", "NG" (alc::to_string(Phase))
  std::string reason;                       // "residual 6.2 µm of E_X0C above ACL 5 µm", ...
};

// A change of the probe interval that the runtime tells the NC.
struct ProbeIntervalChangeRecord {
  RunId run_id = 0;
  double time_s = 0.0;                      // [s]
  double interval_s = 0.0;                  // [s] new interval; +inf = no more probing
  std::string reason;
};

// An NC command emitted for a sink, stored when the safety gate has judged it and before it is
// handed to the sink (schema version 2); whether the sink took it is set afterwards by
// HistoryWriter::record_delivery (schema version 3; docs/storage.md, nc_commands).
struct NcCommandRecord {
  RunId run_id = 0;
  double time_s = 0.0;                      // [s]
  std::string kind;                         // "offsets", "probe_interval", ...
  std::string text;                         // the NC code for the sink; a refused command: its JSON request
  std::string sink;                         // "file:/path", "stdout", "tcp:host:port"
  bool accepted = false;                    // the safety gate passed it (possibly split into steps), so it
                                            // is handed to the sink; false: refused, nothing sent
  std::string message;                      // the gate's reason for a refusal or its note on a split, else ""
  std::optional<bool> delivered = std::nullopt;  // true: the sink took it; false: the sink failed; empty:
                                                 // not handed to a sink (refused, or not yet delivered)
  std::string delivery_message = "";             // the sink's error, or its note on the delivery (file written)
};

// The indicators a run ended with (schema version 5): the JSON document `alc replay --json` prints for
// the run (runtime::report_json), stored when a replay ends and removed when the run is resumed.
// Storage only checks that it is JSON; its shape is the runtime's.
struct RunIndicatorsRecord {
  RunId run_id = 0;
  std::string report_json;                  // {"outputs": {...}, "Pd": ..., "M": ..., ...}
  double stored_unix_s = 0.0;               // [s] wall clock when stored (0: set to now by the writer)
};

// time_s of a snapshot taken before the controller saw its first sample (replay saves one at the
// start of a run). Not a time of the run: HistoryReader::time_span and `alc db info` ignore it.
inline constexpr double kSnapshotBeforeStart_s = -1.0;

// The controller's state, opaque to storage and stored bit for bit. A resumed run restores the
// latest snapshot and continues with sample `next_sample_index`.
struct ControllerSnapshot {
  RunId run_id = 0;
  double time_s = 0.0;                      // [s] every record with time_s <= this is before it
  std::int64_t next_sample_index = 0;       // first input sample not yet processed
  std::string format;                       // caller's format and version, "alc.controller/1"
  bool is_json = false;                     // payload is JSON text (checked by `alc db check`)
  std::string payload;                      // bytes (any, NUL included) or JSON text
  std::int64_t snapshot_id = 0;             // set when read back (0 for one not stored yet)
};

}  // namespace alc::storage
