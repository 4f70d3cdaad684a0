#pragma once
// JSON text of the thermal model and its fit summary, exact for every double (shortest
// round-trip text), for ModelParameterSetRecord::model_json / fit_summary_json.
#include <string>

#include "alc/thermal_model.hpp"
#include "storage/records.hpp"

namespace alc::storage {

std::string thermal_model_to_json(const alc::ThermalModel& model);
// Inverse of thermal_model_to_json (bit-exact). Throws StorageError(InvalidArgument) on bad text.
alc::ThermalModel thermal_model_from_json(const std::string& json);

std::string fit_summary_to_json(const alc::FitResult& fit);

// A record for one identification: inputs_chosen is the union over outputs, order the highest.
ModelParameterSetRecord make_model_parameter_set(RunId run, double time_s, std::string reason,
                                                 double window_start_s, double window_end_s,
                                                 const alc::FitResult& fit, bool adopted);

}  // namespace alc::storage
