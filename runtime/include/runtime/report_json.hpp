#pragma once
// The indicators of a replay as JSON: what `alc replay --json` prints per case and what a study
// stores per row (so a study row and a replay can be compared byte for byte).
#include <nlohmann/json.hpp>

#include "runtime/evaluation.hpp"

namespace alc::runtime {

// Per output PV, RMSE, P99, SMAPE, P99_uncompensated, measurements; Pd, M, NG phases, updates,
// rejected fits, CP end, duration and the baseline's outputs; with baselines asked for (--baselines)
// also "baselines": {"<name>": {"outputs": ..., "selected": {"<output>": [inputs]}}} ("selected" for
// lasso and ols), a key that is absent otherwise. Non-finite numbers are null.
nlohmann::json report_json(const ReplayReport& report);

}  // namespace alc::runtime

namespace alc::runtime {

// The report back from report_json() (what a study file stores); null numbers come back as NaN, the
// baselines in the order of their names.
// The wall times (identification_s, total_s) are not stored and come back 0. Throws
// nlohmann::json::exception on a document of another shape. The document is keyed by output name
// (sorted); with `output_order` (the run's output channels) the outputs come back in that order, as a
// replay prints them; names it does not list follow in the document's order.
ReplayReport report_from_json(const nlohmann::json& j, const std::vector<std::string>& output_order = {});

}  // namespace alc::runtime
