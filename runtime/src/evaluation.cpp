#include "runtime/evaluation.hpp"

#include <cmath>
#include <limits>

#include "alc/indicators.hpp"
#include "common/number_text.hpp"
#include "probing/schedule.hpp"

namespace alc::runtime {

namespace {

double mean_of(const std::vector<OutputIndicators>& outs, ErrorKind kind, double OutputIndicators::*field) {
  double sum = 0.0;
  int n = 0;
  for (const auto& o : outs)
    if (o.kind == kind && !std::isnan(o.*field)) {
      sum += o.*field;
      ++n;
    }
  return n ? sum / n : std::numeric_limits<double>::quiet_NaN();
}

}  // namespace

OutputIndicators evaluate_output(const std::string& name, const std::vector<double>& measured,
                                 const std::vector<double>& predicted) {
  OutputIndicators r;
  r.name = name;
  r.kind = error_kind(name);
  r.measurements = static_cast<int>(measured.size());
  if (measured.empty()) {
    r.PV = r.RMSE = r.P99 = r.SMAPE = r.P99_uncompensated = std::numeric_limits<double>::quiet_NaN();
    return r;
  }
  r.PV = peak_value_percent(measured, predicted);
  r.RMSE = rmse(measured, predicted);
  r.P99 = p99_abs_residual(measured, predicted);
  r.SMAPE = smape_percent(measured, predicted);
  const std::vector<double> zero(measured.size(), 0.0);
  r.P99_uncompensated = p99_abs_residual(measured, zero);
  return r;
}

double ReplayReport::mean_p99(ErrorKind kind, bool of_baseline) const {
  return mean_of(of_baseline ? baseline : outputs, kind, &OutputIndicators::P99);
}

double BaselineReport::mean_p99(ErrorKind kind) const { return mean_of(outputs, kind, &OutputIndicators::P99); }

double ReplayReport::mean_p99_uncompensated(ErrorKind kind) const {
  return mean_of(outputs, kind, &OutputIndicators::P99_uncompensated);
}

Evaluation::Evaluation(const scenarios::Scenario& scenario, std::vector<BaselineKind> baselines)
    : scenario_(scenario), baseline_kinds_(std::move(baselines)) {}

void Evaluation::on_cycle(const Cycle& cycle) {
  if (cycle.kind() == Cycle::Kind::Sample) predicted_ = cycle.out().prediction;
  const ControllerState& cs = cycle.controller().state();
  // Fitted in the cycle that ends CP, whatever its kind: a CP prolonged by a rejected fit ends on a
  // probe, and the row of that probe is evaluated (on_sample_done) with the baseline, as a resumed
  // run's rebuild evaluates it.
  if (!baseline_fitted_ && std::isfinite(cs.cp_end_s)) {
    // Static baseline: MLR on the CP measurements, fitted once and never updated.
    baseline_ = fit_static_regression(cs.history, scenario_.output_names, cs.probes).model;
    baseline_fitted_ = true;
    for (const BaselineKind kind : baseline_kinds_)
      baseline_models_.push_back(fit_baseline(kind, cs.history, scenario_.output_names, cs.probes));
  }
}

void Evaluation::on_sample_done(const Sample& sample, const Controller& controller, std::int64_t) {
  rebuild(static_cast<std::size_t>(sample.index), predicted_, controller.state().cp_end_s);
}

void Evaluation::rebuild(std::size_t row, const Eigen::VectorXd& predicted, double cp_end_s) {
  if (row >= scenario_.samples()) return;
  const auto r = static_cast<Eigen::Index>(row);
  if (scenario_.outputs.row(r).array().isNaN().all() || !(scenario_.time_s[row] >= cp_end_s)) return;
  add(row, predicted);
}

void Evaluation::add(std::size_t row, const Eigen::VectorXd& predicted) {
  const auto r = static_cast<Eigen::Index>(row);
  const auto n = static_cast<Eigen::Index>(scenario_.output_names.size());
  time_s_.push_back(scenario_.time_s[row]);
  rows_.push_back(row);
  const Eigen::VectorXd inputs = scenario_.inputs.row(r).transpose();
  const Eigen::VectorXd base = baseline_fitted_ ? baseline_.predict(inputs) : Eigen::VectorXd::Zero(n);
  for (Eigen::Index k = 0; k < n; ++k) {
    measured_.push_back(scenario_.outputs(r, k));
    predicted_rows_.push_back(predicted[k]);
    baseline_rows_.push_back(base[k]);
  }
}

Eigen::VectorXd Evaluation::baseline_at(std::size_t i) const {
  const auto n = static_cast<Eigen::Index>(scenario_.output_names.size());
  return Eigen::Map<const Eigen::VectorXd>(baseline_rows_.data() + i * static_cast<std::size_t>(n), n);
}

void Evaluation::restore_baseline(bool fitted, StaticRegression baseline) {
  baseline_fitted_ = fitted;
  baseline_ = std::move(baseline);
}

ReplayReport Evaluation::report(const Controller& controller, std::size_t rows) const {
  ReplayReport rep;
  const ControllerState& cs = controller.state();
  rep.M = cs.probe_cycles;
  rep.ng_phases = cs.ng_phases;
  rep.updates = cs.updates;
  rep.rejected_fits = cs.rejected_fits;
  rep.cp_end_s = cs.cp_end_s;
  const std::size_t last = std::min(rows, scenario_.samples());
  // Every row replayed was either accepted (counted in the controller's state, so across a resume) or
  // set aside.
  rep.rejected_samples = std::max<std::int64_t>(0, static_cast<std::int64_t>(last) - cs.samples);
  rep.duration_s = last > 0 ? scenario_.time_s[last - 1] - scenario_.time_s.front() : 0.0;
  // No Pd of a run that took no sample (every one set aside): it did not run the machine's time.
  rep.Pd = rep.duration_s > 0 && cs.samples > 0 ? probing::productivity_percent(rep.M, rep.duration_s)
                                                : std::numeric_limits<double>::quiet_NaN();
  const std::size_t n = scenario_.output_names.size();
  // The indicators of each output over the evaluated rows where it was measured plausibly (a reading
  // the controller set aside as a sensor fault is no error to judge it by); the readings beyond the
  // plausible limit are counted and the first is named.
  std::vector<char> judged(measured_.size(), 0);
  for (std::size_t i = 0; i < time_s_.size(); ++i)
    for (std::size_t k = 0; k < n; ++k) {
      const double m = measured_[i * n + k];
      if (std::isnan(m)) continue;  // not measured
      if (std::abs(m) <= controller.parameters().plausible_limit(error_kind(scenario_.output_names[k]))) {
        judged[i * n + k] = 1;
      } else if (rep.implausible_measurements++ == 0) {
        rep.first_implausible =
            scenario_.output_names[k] + " at time_s " + common::shortest_text(time_s_[i]) + ": " + common::shortest_text(m);
      }
    }
  // The indicators for predictions prediction(i, k) at evaluated row i.
  const auto indicators = [&](const auto& prediction) {
    std::vector<OutputIndicators> outs;
    for (std::size_t k = 0; k < n; ++k) {
      std::vector<double> measured, predicted;
      for (std::size_t i = 0; i < time_s_.size(); ++i) {
        if (!judged[i * n + k]) continue;
        measured.push_back(measured_[i * n + k]);
        predicted.push_back(prediction(i, k));
      }
      outs.push_back(evaluate_output(scenario_.output_names[k], measured, predicted));
    }
    return outs;
  };
  rep.outputs = indicators([&](std::size_t i, std::size_t k) { return predicted_rows_[i * n + k]; });
  rep.baseline = indicators([&](std::size_t i, std::size_t k) { return baseline_rows_[i * n + k]; });
  for (std::size_t j = 0; j < baseline_kinds_.size(); ++j) {
    // Before the end of CP a model is not fitted yet and predicts 0, as the static baseline does.
    BaselineModel model;
    if (j < baseline_models_.size()) model = baseline_models_[j];
    model.kind = baseline_kinds_[j];
    const Eigen::MatrixXd p = j < baseline_models_.size()
                                  ? model.predict(scenario_.time_s, scenario_.inputs, rows_)
                                  : Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(rows_.size()),
                                                          static_cast<Eigen::Index>(n));
    BaselineReport b;
    b.name = std::string(baseline_name(model.kind));
    b.outputs = indicators([&](std::size_t i, std::size_t k) {
      return p(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(k));
    });
    b.parameters = static_cast<int>(scenario_.input_names.size()) + 1;
    for (std::size_t k = 0; k < n; ++k)
      b.fitted_on.emplace_back(scenario_.output_names[k], k < model.measurements.size() ? model.measurements[k] : 0);
    if (model.kind == BaselineKind::Lasso || model.kind == BaselineKind::Ols) {
      const auto selected = model.selected_inputs();
      for (std::size_t k = 0; k < n && k < selected.size(); ++k)
        b.selected.emplace_back(scenario_.output_names[k], selected[k]);
    }
    rep.baselines.push_back(std::move(b));
  }
  return rep;
}

scenarios::Scenario Evaluation::residuals() const {
  scenarios::Scenario r;
  const auto rows = static_cast<Eigen::Index>(time_s_.size());
  const auto n = static_cast<Eigen::Index>(scenario_.output_names.size());
  r.time_s = time_s_;
  r.inputs.resize(rows, 0);
  r.outputs.resize(rows, 2 * n);
  for (Eigen::Index k = 0; k < n; ++k) {
    r.output_names.push_back(scenario_.output_names[static_cast<std::size_t>(k)]);
    r.output_names.push_back(scenario_.output_names[static_cast<std::size_t>(k)] + "_pred");
  }
  for (Eigen::Index i = 0; i < rows; ++i)
    for (Eigen::Index k = 0; k < n; ++k) {
      r.outputs(i, 2 * k) = measured_[static_cast<std::size_t>(i * n + k)];
      r.outputs(i, 2 * k + 1) = predicted_rows_[static_cast<std::size_t>(i * n + k)];
    }
  return r;
}

}  // namespace alc::runtime
