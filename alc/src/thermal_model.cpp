// ModelPredictor, option validation and pole conversions of the thermal model.
#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "alc/thermal_model.hpp"
#include "lag_filter.hpp"

namespace alc {
namespace {

std::string violation(const char* field, double value, const char* constraint) {
  std::ostringstream os;
  os << "IdentificationOptions." << field << " = " << value << ": " << constraint;
  return os.str();
}

// Fixed offsets into the predictor state (see the layout in the header).
constexpr Eigen::Index kStarted = 0;
constexpr Eigen::Index kLastTime = 1;
constexpr Eigen::Index kHeld = 2;

}  // namespace

std::string IdentificationOptions::validate() const {
  if (!(base_step_s > 0.0) || !std::isfinite(base_step_s)) return violation("base_step_s", base_step_s, "must be finite and > 0");
  if (max_order < 1 || max_order > 6) return violation("max_order", max_order, "must be in 1..6");
  if (!(tau_min_s > 0.0) || !std::isfinite(tau_min_s)) return violation("tau_min_s", tau_min_s, "must be finite and > 0");
  if (!(tau_max_s >= tau_min_s) || !std::isfinite(tau_max_s))
    return violation("tau_max_s", tau_max_s, "must be finite and >= tau_min_s");
  if (pole_grid_size < 1 || pole_grid_size > 16) return violation("pole_grid_size", pole_grid_size, "must be in 1..16");
  if (pole_grid_size < max_order) return violation("pole_grid_size", pole_grid_size, "must be >= max_order");
  if (max_inputs < 1) return violation("max_inputs", max_inputs, "must be >= 1");
  if (!(ridge >= 0.0) || !std::isfinite(ridge)) return violation("ridge", ridge, "must be finite and >= 0");
  if (!(robust_scale_lin > 0.0) || !std::isfinite(robust_scale_lin))
    return violation("robust_scale_lin", robust_scale_lin, "must be finite and > 0");
  if (!(robust_scale_ang > 0.0) || !std::isfinite(robust_scale_ang))
    return violation("robust_scale_ang", robust_scale_ang, "must be finite and > 0");
  if (std::isnan(window_start_s) || window_start_s == kInf)
    return violation("window_start_s", window_start_s, "must be a time or -inf");
  if (!(forgetting_half_life_s > 0.0)) return violation("forgetting_half_life_s", forgetting_half_life_s, "must be > 0 (inf: none)");
  if (min_measurements < 2) return violation("min_measurements", min_measurements, "must be >= 2");
  if (!(output_limit_factor >= 1.0)) return violation("output_limit_factor", output_limit_factor, "must be >= 1 (inf: no bound)");
  if (max_iterations < 0) return violation("max_iterations", max_iterations, "must be >= 0");
  return {};
}

double time_constant_of_pole(double pole, double base_step_s) { return -base_step_s / std::log(pole); }
double pole_of_time_constant(double tau_s, double base_step_s) { return std::exp(-base_step_s / tau_s); }

ModelPredictor::ModelPredictor(ThermalModel model) : model_(std::move(model)) {
  Eigen::Index lags = 0;
  for (const OutputModel& out : model_.outputs) {
    std::vector<double> taus;
    for (Eigen::Index k = 0; k < out.poles.size(); ++k) taus.push_back(time_constant_of_pole(out.poles(k), model_.base_step_s));
    factor_.emplace_back(taus.size(), 0.0);
    tau_s_.push_back(std::move(taus));
    lags += static_cast<Eigen::Index>(out.inputs.size()) * out.poles.size();
  }
  const auto n_in = static_cast<Eigen::Index>(model_.input_names.size());
  state_ = Eigen::VectorXd::Zero(kHeld + n_in + lags);
  state_(kLastTime) = -kInf;
}

Eigen::VectorXd ModelPredictor::step(double time_s, const Eigen::VectorXd& inputs) {
  const auto n_in = static_cast<Eigen::Index>(model_.input_names.size());
  if (model_.outputs.empty()) return {};
  const bool started = state_(kStarted) != 0.0;
  const double dt = started ? time_s - state_(kLastTime) : 0.0;
  if (dt > 0.0 && dt != factor_dt_s_) {
    for (std::size_t o = 0; o < tau_s_.size(); ++o)
      for (std::size_t k = 0; k < tau_s_[o].size(); ++k) factor_[o][k] = detail::lag_factor(dt, tau_s_[o][k]);
    factor_dt_s_ = dt;
  }
  Eigen::Index at = kHeld + n_in;
  for (std::size_t o = 0; o < model_.outputs.size(); ++o) {
    const OutputModel& out = model_.outputs[o];
    for (const int i : out.inputs) {
      const double u_new = i < inputs.size() && std::isfinite(inputs(i)) ? inputs(i) : model_.input_reference(i);
      for (std::size_t k = 0; k < tau_s_[o].size(); ++k, ++at) {
        if (!started) {
          state_(at) = u_new - model_.input_reference(i);  // steady state
        } else if (dt > 0.0) {
          state_(at) = detail::lag_step(state_(at), factor_[o][k], state_(kHeld + i) - model_.input_reference(i));
        }
      }
    }
  }
  for (Eigen::Index i = 0; i < n_in; ++i) {
    if (i < inputs.size() && std::isfinite(inputs(i))) {
      state_(kHeld + i) = inputs(i);
    } else if (!started) {
      state_(kHeld + i) = model_.input_reference(i);
    }
  }
  if (!started || dt > 0.0) state_(kLastTime) = time_s;
  state_(kStarted) = 1.0;
  return prediction();
}

Eigen::VectorXd ModelPredictor::prediction() const {
  const auto n_in = static_cast<Eigen::Index>(model_.input_names.size());
  Eigen::VectorXd y(static_cast<Eigen::Index>(model_.outputs.size()));
  Eigen::Index at = kHeld + n_in;
  for (std::size_t o = 0; o < model_.outputs.size(); ++o) {
    const OutputModel& out = model_.outputs[o];
    const Eigen::Index lags = static_cast<Eigen::Index>(out.inputs.size()) * out.poles.size();
    double v = out.parameters.size() > 0 ? out.parameters(0) : 0.0;
    if (out.parameters.size() == 1 + lags) v += out.parameters.tail(lags).dot(state_.segment(at, lags));
    at += lags;
    if (!std::isfinite(v)) v = 0.0;
    y(static_cast<Eigen::Index>(o)) = std::clamp(v, -out.output_limit, out.output_limit);
  }
  return y;
}

Eigen::VectorXd ModelPredictor::state() const { return state_; }

void ModelPredictor::set_state(const Eigen::VectorXd& state) {
  if (state.size() != state_.size()) {
    throw std::invalid_argument("ModelPredictor::set_state: state has " + std::to_string(state.size()) +
                                " values, the model needs " + std::to_string(state_.size()));
  }
  state_ = state;
}

}  // namespace alc
