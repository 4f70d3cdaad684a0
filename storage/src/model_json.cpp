// Thermal model <-> JSON (every field of the model, the clamp of its predictions included), exact for every double: finite values as shortest round-trip numbers
// (nlohmann prints them so), non-finite ones as the strings "nan", "inf", "-inf".
#include "storage/model_json.hpp"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "storage/storage_error.hpp"

namespace alc::storage {
using nlohmann::json;

namespace {

json number(double v) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  return v;
}

double number_from(const json& j) {
  if (j.is_number()) return j.get<double>();
  const std::string s = j.get<std::string>();
  if (s == "nan") return std::numeric_limits<double>::quiet_NaN();
  if (s == "inf") return std::numeric_limits<double>::infinity();
  if (s == "-inf") return -std::numeric_limits<double>::infinity();
  throw StorageError(StorageErrorKind::InvalidArgument, {}, "model JSON: '" + s + "' is not a number");
}

json vector(const Eigen::VectorXd& v) {
  json a = json::array();
  for (Eigen::Index i = 0; i < v.size(); ++i) a.push_back(number(v[i]));
  return a;
}

Eigen::VectorXd vector_from(const json& a) {
  Eigen::VectorXd v(static_cast<Eigen::Index>(a.size()));
  for (std::size_t i = 0; i < a.size(); ++i) v[static_cast<Eigen::Index>(i)] = number_from(a[i]);
  return v;
}

}  // namespace

std::string thermal_model_to_json(const alc::ThermalModel& model) {
  json j;
  j["format"] = "alc.thermal_model/1";
  j["input_names"] = model.input_names;
  j["input_reference"] = vector(model.input_reference);
  j["base_step_s"] = number(model.base_step_s);
  j["outputs"] = json::array();
  for (const auto& o : model.outputs)
    j["outputs"].push_back({{"name", o.name}, {"order", o.order}, {"inputs", o.inputs},
                            {"parameters", vector(o.parameters)}, {"poles", vector(o.poles)},
                            {"output_limit", number(o.output_limit)}});
  return j.dump();
}

alc::ThermalModel thermal_model_from_json(const std::string& text) {
  try {
    const json j = json::parse(text);
    alc::ThermalModel model;
    model.input_names = j.at("input_names").get<std::vector<std::string>>();
    model.input_reference = vector_from(j.at("input_reference"));
    model.base_step_s = number_from(j.at("base_step_s"));
    for (const auto& o : j.at("outputs")) {
      alc::OutputModel out;
      out.name = o.at("name").get<std::string>();
      out.order = o.at("order").get<int>();
      out.inputs = o.at("inputs").get<std::vector<int>>();
      out.parameters = vector_from(o.at("parameters"));
      out.poles = vector_from(o.at("poles"));
      // The clamp of the predictions is part of the model: without it a resumed run predicted unclamped
      // where the uninterrupted one clamped. Files written before it was stored have none (no bound).
      if (o.contains("output_limit")) out.output_limit = number_from(o.at("output_limit"));
      model.outputs.push_back(std::move(out));
    }
    return model;
  } catch (const json::exception& e) {
    throw StorageError(StorageErrorKind::InvalidArgument, {}, std::string("model JSON: ") + e.what());
  }
}

std::string fit_summary_to_json(const alc::FitResult& fit) {
  json j;
  j["usable"] = fit.usable;
  j["message"] = fit.message;
  j["outputs"] = json::array();
  for (const auto& o : fit.outputs) {
    json p_values = json::array();
    for (const double p : o.input_p_values) p_values.push_back(number(p));
    j["outputs"].push_back({{"name", o.name}, {"usable", o.usable}, {"message", o.message}, {"order", o.order},
                            {"inputs_chosen", o.inputs_chosen}, {"input_p_values", p_values},
                            {"measurements", o.measurements},
                            {"residual_rms", number(o.residual_rms)}, {"residual_max", number(o.residual_max)},
                            {"condition", number(o.condition)}, {"cost_before", number(o.cost_before)},
                            {"cost_after", number(o.cost_after)}});
  }
  return j.dump();
}

ModelParameterSetRecord make_model_parameter_set(RunId run, double time_s, std::string reason, double window_start_s,
                                                 double window_end_s, const alc::FitResult& fit, bool adopted) {
  ModelParameterSetRecord r;
  r.run_id = run;
  r.time_s = time_s;
  r.reason = std::move(reason);
  r.window_start_s = window_start_s;
  r.window_end_s = window_end_s;
  r.usable = fit.usable;
  r.adopted = adopted;
  for (const auto& o : fit.outputs) {
    r.order = std::max(r.order, o.order);
    for (const auto& name : o.inputs_chosen)
      if (std::find(r.inputs_chosen.begin(), r.inputs_chosen.end(), name) == r.inputs_chosen.end())
        r.inputs_chosen.push_back(name);
  }
  r.fit_summary_json = fit_summary_to_json(fit);
  r.model_json = thermal_model_to_json(fit.model);
  return r;
}

}  // namespace alc::storage
