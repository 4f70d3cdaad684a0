#include "runtime/report_json.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace alc::runtime {

namespace {

nlohmann::json number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

double number_of(const nlohmann::json& j) {
  return j.is_null() ? std::numeric_limits<double>::quiet_NaN() : j.get<double>();
}

nlohmann::json outputs_json(const std::vector<OutputIndicators>& outs) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& o : outs)
    j[o.name] = {{"PV", number(o.PV)}, {"RMSE", number(o.RMSE)}, {"P99", number(o.P99)}, {"SMAPE", number(o.SMAPE)},
                 {"P99_uncompensated", number(o.P99_uncompensated)}, {"measurements", o.measurements}};
  return j;
}

std::vector<OutputIndicators> outputs_of(const nlohmann::json& j, const std::vector<std::string>& order) {
  std::vector<OutputIndicators> outs;
  for (const auto& [name, o] : j.items()) {
    OutputIndicators r;
    r.name = name;
    r.kind = error_kind(name);
    r.PV = number_of(o.at("PV"));
    r.RMSE = number_of(o.at("RMSE"));
    r.P99 = number_of(o.at("P99"));
    r.SMAPE = number_of(o.at("SMAPE"));
    r.P99_uncompensated = number_of(o.at("P99_uncompensated"));
    r.measurements = o.at("measurements").get<int>();
    outs.push_back(std::move(r));
  }
  const auto rank = [&](const OutputIndicators& o) {
    return static_cast<std::size_t>(std::find(order.begin(), order.end(), o.name) - order.begin());
  };
  std::stable_sort(outs.begin(), outs.end(), [&](const auto& a, const auto& b) { return rank(a) < rank(b); });
  return outs;
}

}  // namespace

nlohmann::json report_json(const ReplayReport& r) {
  nlohmann::json j = {{"outputs", outputs_json(r.outputs)},
          {"Pd", r.Pd},
          {"M", r.M},
          {"ng_phases", r.ng_phases},
          {"updates", r.updates},
          {"rejected_fits", r.rejected_fits},
          {"rejected_samples", r.rejected_samples},
          {"cp_end_h", std::isfinite(r.cp_end_s) ? nlohmann::json(r.cp_end_s / 3600.0) : nlohmann::json(nullptr)},
          {"duration_h", r.duration_s / 3600.0},
          {"baseline", {{"outputs", outputs_json(r.baseline)}}}};
  if (r.baselines.empty()) return j;  // without --baselines the document is as it always was
  nlohmann::json& baselines = j["baselines"] = nlohmann::json::object();
  for (const BaselineReport& b : r.baselines) {
    nlohmann::json& e = baselines[b.name] = {{"outputs", outputs_json(b.outputs)}};
    if (!b.fitted_on.empty()) {
      nlohmann::json& fitted = e["fitted_on"] = nlohmann::json::object();
      for (const auto& [output, count] : b.fitted_on) fitted[output] = count;
      e["parameters"] = b.parameters;  // fitted_on below it: underdetermined (the text names those)
    }
    if (b.selected.empty()) continue;
    nlohmann::json& selected = e["selected"] = nlohmann::json::object();
    for (const auto& [output, inputs] : b.selected) selected[output] = inputs;
  }
  return j;
}

ReplayReport report_from_json(const nlohmann::json& j, const std::vector<std::string>& output_order) {
  ReplayReport r;
  r.outputs = outputs_of(j.at("outputs"), output_order);
  r.baseline = outputs_of(j.at("baseline").at("outputs"), output_order);
  if (j.contains("baselines"))
    for (const auto& [name, e] : j.at("baselines").items()) {
      BaselineReport b;
      b.name = name;
      b.outputs = outputs_of(e.at("outputs"), output_order);
      if (e.contains("fitted_on")) {  // since 2026-11-26
        for (const auto& [output, count] : e.at("fitted_on").items()) b.fitted_on.emplace_back(output, count.get<int>());
        b.parameters = e.at("parameters").get<int>();
      }
      if (e.contains("selected"))
        for (const auto& [output, inputs] : e.at("selected").items())
          b.selected.emplace_back(output, inputs.get<std::vector<std::string>>());
      r.baselines.push_back(std::move(b));
    }
  r.Pd = number_of(j.at("Pd"));
  r.M = j.at("M").get<int>();
  r.ng_phases = j.at("ng_phases").get<int>();
  r.updates = j.at("updates").get<int>();
  r.rejected_fits = j.at("rejected_fits").get<int>();
  // Stored before the count was kept: none known.
  r.rejected_samples = j.contains("rejected_samples") ? j.at("rejected_samples").get<std::int64_t>() : 0;
  r.cp_end_s = j.at("cp_end_h").is_null() ? kInf : j.at("cp_end_h").get<double>() * 3600.0;
  r.duration_s = j.at("duration_h").get<double>() * 3600.0;
  return r;
}

}  // namespace alc::runtime
