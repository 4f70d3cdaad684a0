#include "scenarios/replay.hpp"

#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "alc/indicators.hpp"

namespace alc::scenarios {

namespace {

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

OutputIndicators evaluate(const std::string& name, const std::vector<double>& measured,
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

double ReplayReport::mean_p99(ErrorKind kind, bool of_baseline) const {
  return mean_of(of_baseline ? baseline : outputs, kind, &OutputIndicators::P99);
}

double ReplayReport::mean_p99_uncompensated(ErrorKind kind) const {
  return mean_of(outputs, kind, &OutputIndicators::P99_uncompensated);
}

ReplaySession::ReplaySession(const Scenario& scenario, AlcParameters parameters)
    : scenario_(scenario),
      recorded_(scenario.time_s, scenario.outputs),
      controller_(scenario.input_names, scenario.output_names, std::move(parameters)) {}

ReplaySession::ReplaySession(const Scenario& scenario, AlcParameters parameters, ReplayState state)
    : scenario_(scenario),
      recorded_(scenario.time_s, scenario.outputs),
      controller_(scenario.input_names, scenario.output_names, std::move(parameters), state.controller),
      state_(std::move(state)) {
  if (state_.next_row > scenario_.samples())
    throw std::invalid_argument("replay: saved state is beyond the end of the scenario");
  state_.controller = ControllerState{};  // the controller holds the live copy
}

ReplayState ReplaySession::state() const {
  ReplayState s = state_;
  s.controller = controller_.state();
  return s;
}

void ReplaySession::run(double stop_time_s, ReplayObserver* observer) {
  const auto wall_start = std::chrono::steady_clock::now();
  const auto n_out = static_cast<Eigen::Index>(scenario_.output_names.size());
  for (; state_.next_row < scenario_.samples(); ++state_.next_row) {
    const std::size_t row = state_.next_row;
    const auto r = static_cast<Eigen::Index>(row);
    const double t = scenario_.time_s[row];
    if (!(t < stop_time_s)) break;
    const Eigen::VectorXd inputs = scenario_.inputs.row(r).transpose();

    auto cycle_start = std::chrono::steady_clock::now();
    ControllerOutput out = controller_.on_sample(t, inputs);
    if (out.fit) state_.identification_s += seconds_since(cycle_start);
    if (observer) observer->on_sample(row, t, inputs, out);
    const Eigen::VectorXd predicted = out.prediction;  // active before this row's probe is learned

    const ControllerState& cs = controller_.state();
    if (!state_.baseline_fitted && std::isfinite(cs.cp_end_s)) {
      // Static baseline: MLR on the CP measurements, fitted once and never updated.
      state_.baseline = fit_static_regression(cs.history, scenario_.output_names, cs.probes).model;
      state_.baseline_fitted = true;
    }

    const Eigen::VectorXd measured = scenario_.outputs.row(r).transpose();
    const bool is_measured = recorded_.is_measured(row);
    // The probe due at t takes the first recorded measurement at or after t: this row, if it is that one.
    if (is_measured && recorded_.first_at_or_after(controller_.state().next_probe_due_s) == row) {
      ProbeMeasurement probe;
      probe.time_s = t;
      probe.measured = measured;
      cycle_start = std::chrono::steady_clock::now();
      ControllerOutput probe_out = controller_.on_probe(probe);
      if (probe_out.fit) state_.identification_s += seconds_since(cycle_start);
      if (observer) observer->on_probe(row, probe, probe_out);
    }
    if (is_measured && t >= controller_.state().cp_end_s) {
      state_.eval_time_s.push_back(t);
      state_.eval_measured.push_back(measured);
      state_.eval_predicted.push_back(predicted);
      state_.eval_baseline.push_back(state_.baseline_fitted ? state_.baseline.predict(inputs)
                                                            : Eigen::VectorXd::Zero(n_out));
    }
    if (observer) {
      ++state_.next_row;  // the row is done: the state seen by the observer continues after it
      observer->on_row_done(*this);
      --state_.next_row;
    }
  }
  state_.total_s += seconds_since(wall_start);
}

ReplayReport ReplaySession::report() const {
  ReplayReport rep;
  const ControllerState& cs = controller_.state();
  rep.M = cs.probe_cycles;
  rep.ng_phases = cs.ng_phases;
  rep.updates = cs.updates;
  rep.rejected_fits = cs.rejected_fits;
  rep.cp_end_s = cs.cp_end_s;
  rep.identification_s = state_.identification_s;
  rep.total_s = state_.total_s;
  const std::size_t last = std::min(state_.next_row, scenario_.samples());
  rep.duration_s = last > 0 ? scenario_.time_s[last - 1] - scenario_.time_s.front() : 0.0;
  rep.Pd = rep.duration_s > 0 ? productivity_percent(rep.M, rep.duration_s)
                              : std::numeric_limits<double>::quiet_NaN();
  for (std::size_t k = 0; k < scenario_.output_names.size(); ++k) {
    std::vector<double> measured, predicted, baseline;
    const auto c = static_cast<Eigen::Index>(k);
    for (std::size_t i = 0; i < state_.eval_time_s.size(); ++i) {
      const double m = state_.eval_measured[i][c];
      if (std::isnan(m)) continue;
      measured.push_back(m);
      predicted.push_back(state_.eval_predicted[i][c]);
      baseline.push_back(state_.eval_baseline[i][c]);
    }
    rep.outputs.push_back(evaluate(scenario_.output_names[k], measured, predicted));
    rep.baseline.push_back(evaluate(scenario_.output_names[k], measured, baseline));
  }
  return rep;
}

Scenario ReplaySession::residuals() const {
  Scenario r;
  const auto n = static_cast<Eigen::Index>(state_.eval_time_s.size());
  const auto n_out = static_cast<Eigen::Index>(scenario_.output_names.size());
  r.time_s = state_.eval_time_s;
  r.inputs.resize(n, 0);
  r.outputs.resize(n, 2 * n_out);
  for (Eigen::Index k = 0; k < n_out; ++k) {
    r.output_names.push_back(scenario_.output_names[static_cast<std::size_t>(k)]);
    r.output_names.push_back(scenario_.output_names[static_cast<std::size_t>(k)] + "_pred");
  }
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index k = 0; k < n_out; ++k) {
      r.outputs(i, 2 * k) = state_.eval_measured[static_cast<std::size_t>(i)][k];
      r.outputs(i, 2 * k + 1) = state_.eval_predicted[static_cast<std::size_t>(i)][k];
    }
  return r;
}

ReplayReport replay(const Scenario& scenario, const AlcParameters& parameters, ReplayObserver* observer) {
  ReplaySession session(scenario, parameters);
  session.run(kInf, observer);
  return session.report();
}

}  // namespace alc::scenarios
