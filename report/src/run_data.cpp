#include "report/run_data.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>

#include "alc/static_regression.hpp"
#include "probing/schedule.hpp"

namespace alc::report {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// A canonical parameter: a number, or "inf" / "-inf" / "nan" (runtime::canonical_parameters).
double parameter(const nlohmann::json& p, const char* key) {
  if (!p.is_object() || !p.contains(key)) return kNaN;
  const auto& v = p.at(key);
  if (v.is_number()) return v.get<double>();
  if (v.is_string()) {
    const auto s = v.get<std::string>();
    if (s == "inf") return std::numeric_limits<double>::infinity();
    if (s == "-inf") return -std::numeric_limits<double>::infinity();
  }
  return kNaN;
}

// Index of the input sample at or before time_s (0 before the first).
std::size_t sample_at(const std::vector<storage::InputSampleRecord>& samples, double time_s) {
  const auto it = std::upper_bound(samples.begin(), samples.end(), time_s,
                                   [](double t, const storage::InputSampleRecord& s) { return t < s.time_s; });
  return it == samples.begin() ? 0 : static_cast<std::size_t>(it - samples.begin()) - 1;
}

}  // namespace

RunData load_run(const storage::HistoryReader& reader, storage::RunId run) {
  RunData d;
  d.run = *reader.run(run);
  d.samples = reader.input_samples(run);
  d.predictions = reader.predictions(run);
  d.probes = reader.probe_measurements(run);
  d.models = reader.model_parameter_sets(run);
  d.phases = reader.phase_changes(run);
  d.intervals = reader.probe_interval_changes(run);
  d.nc_commands = reader.nc_commands(run);
  d.indicators = reader.indicators(run);
  return d;
}

double probe_error(const storage::ProbeMeasurementRecord& probe, std::size_t k) {
  const double m = k < probe.measured.size() ? probe.measured[k] : kNaN;
  const double c = k < probe.compensation.size() && std::isfinite(probe.compensation[k]) ? probe.compensation[k] : 0.0;
  return m + c;
}

const storage::PredictionRecord* prediction_at(const RunData& data, double time_s) {
  const auto& p = data.predictions;
  const auto it = std::upper_bound(p.begin(), p.end(), time_s,
                                   [](double t, const storage::PredictionRecord& r) { return t < r.time_s; });
  return it == p.begin() ? nullptr : &*(it - 1);
}

Acl acl_of(const storage::RunRecord& run) {
  const auto j = nlohmann::json::parse(run.config_json, nullptr, false);
  const nlohmann::json p = j.is_object() && j.contains("parameters") ? j.at("parameters") : nlohmann::json();
  return {parameter(p, "acl_linear_um"), parameter(p, "acl_angular_um_per_m")};
}

runtime::ReplayReport history_indicators(const RunData& d) {
  runtime::ReplayReport rep;
  rep.M = static_cast<int>(d.probes.size());
  for (const auto& c : d.phases) {
    if (c.from_phase == "CP" && !std::isfinite(rep.cp_end_s)) rep.cp_end_s = c.time_s;
    if (c.to_phase == "NG") ++rep.ng_phases;
  }
  for (const auto& m : d.models) (m.adopted ? rep.updates : rep.rejected_fits)++;
  rep.duration_s = d.samples.size() > 1 ? d.samples.back().time_s - d.samples.front().time_s : 0.0;
  rep.Pd = rep.duration_s > 0 ? probing::productivity_percent(rep.M, rep.duration_s) : kNaN;

  const auto& names = d.run.output_names;
  const std::size_t n = names.size();
  // The static baseline: fitted once on the CP probes (the probes the controller held when CP ended).
  StaticRegression baseline;
  bool baseline_fitted = false;
  if (std::isfinite(rep.cp_end_s) && !d.samples.empty()) {
    InputHistory history;
    history.input_names = d.run.input_names;
    const auto cols = static_cast<Eigen::Index>(d.run.input_names.size());
    const std::size_t last = sample_at(d.samples, rep.cp_end_s);
    history.inputs.resize(static_cast<Eigen::Index>(last + 1), cols);
    for (std::size_t i = 0; i <= last; ++i) {
      history.time_s.push_back(d.samples[i].time_s);
      for (Eigen::Index c = 0; c < cols; ++c)
        history.inputs(static_cast<Eigen::Index>(i), c) =
            static_cast<std::size_t>(c) < d.samples[i].values.size() ? d.samples[i].values[static_cast<std::size_t>(c)] : kNaN;
    }
    std::vector<ProbeRecord> cp_probes;
    for (const auto& p : d.probes) {
      if (p.time_s > rep.cp_end_s) break;
      ProbeRecord r;
      r.time_s = p.time_s;
      r.sample_index = sample_at(d.samples, p.time_s);
      r.errors.resize(static_cast<Eigen::Index>(n));
      for (std::size_t k = 0; k < n; ++k) r.errors[static_cast<Eigen::Index>(k)] = probe_error(p, k);
      r.weight = p.weight;
      cp_probes.push_back(std::move(r));
    }
    baseline = fit_static_regression(history, names, cp_probes).model;
    baseline_fitted = true;
  }
  std::vector<std::vector<double>> measured(n), predicted(n), base(n);
  for (const auto& p : d.probes) {
    if (!(p.time_s >= rep.cp_end_s)) continue;
    const storage::PredictionRecord* pred = prediction_at(d, p.time_s);
    Eigen::VectorXd b = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(n));
    if (baseline_fitted) {
      const auto& values = d.samples[sample_at(d.samples, p.time_s)].values;
      b = baseline.predict(Eigen::Map<const Eigen::VectorXd>(values.data(), static_cast<Eigen::Index>(values.size())));
    }
    for (std::size_t k = 0; k < n; ++k) {
      const double e = probe_error(p, k);
      if (std::isnan(e)) continue;
      measured[k].push_back(e);
      predicted[k].push_back(pred && k < pred->predicted.size() ? pred->predicted[k] : 0.0);
      base[k].push_back(b[static_cast<Eigen::Index>(k)]);
    }
  }
  for (std::size_t k = 0; k < n; ++k) {
    rep.outputs.push_back(runtime::evaluate_output(names[k], measured[k], predicted[k]));
    rep.baseline.push_back(runtime::evaluate_output(names[k], measured[k], base[k]));
  }
  return rep;
}

}  // namespace alc::report
