#pragma once
// One run of a history as the report draws it, and its indicators recomputed from what the history
// stores (docs/report.md, "Indicators").
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "runtime/evaluation.hpp"
#include "storage/history_reader.hpp"

namespace alc::report {

struct RunData {
  storage::RunRecord run;
  std::vector<storage::InputSampleRecord> samples;
  std::vector<storage::PredictionRecord> predictions;
  std::vector<storage::ProbeMeasurementRecord> probes;
  std::vector<storage::ModelParameterSetRecord> models;
  std::vector<storage::PhaseChangeRecord> phases;
  std::vector<storage::ProbeIntervalChangeRecord> intervals;
  std::vector<storage::NcCommandRecord> nc_commands;
  std::optional<storage::RunIndicatorsRecord> indicators;  // what the run ended with (schema 5), if stored
};

RunData load_run(const storage::HistoryReader& reader, storage::RunId run);

// The thermal error a probe saw: measured + compensation in force (closed loop; 0 in a replay).
double probe_error(const storage::ProbeMeasurementRecord& probe, std::size_t output);

// The stored prediction active at time_s (the latest at or before it); nullptr before the first.
const storage::PredictionRecord* prediction_at(const RunData& data, double time_s);

// The run's action control limits from its config_json (parameters.acl_linear_um,
// parameters.acl_angular_um_per_m); NaN where the run does not say.
struct Acl {
  double linear_um;
  double angular_um_per_m;
};
Acl acl_of(const storage::RunRecord& run);

// The indicators of seed 004 (Eq. 1-7) computed the way runtime::Evaluation does, on what the
// history holds: every probe at or after the end of CP against the stored prediction active at its
// time; the static baseline fitted on the CP probes with the stored inputs; M, NG phases, updates,
// rejected fits and CP end from the probes, phase changes and model parameter sets; the duration
// from the first to the last input sample. The wall times are not stored (0).
runtime::ReplayReport history_indicators(const RunData& data);

}  // namespace alc::report
