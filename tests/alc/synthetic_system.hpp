#pragma once
// Synthetic thermal systems for the identification tests: seeded input histories (ambient cycle,
// C-axis speed profile, fluid on/off, extra sensors), a known model run forward by ModelPredictor,
// and probe schedules (5 min calibration, then hours).
#include <Eigen/Core>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "alc/thermal_model.hpp"

namespace alc::test {

// Inputs: T_ENV [°C] daily cycle with drift, n_C [rpm] random speed steps, FLUID [0/1] switching,
// then `extra` temperatures that mix T_ENV with their own slow random walk.
inline InputHistory make_history(std::mt19937_64& rng, double duration_s, double step_s, int extra = 0) {
  InputHistory h;
  h.input_names = {"T_ENV", "n_C", "FLUID"};
  for (int e = 0; e < extra; ++e) h.input_names.push_back("T_" + std::to_string(e + 1));
  const auto n = static_cast<Eigen::Index>(std::floor(duration_s / step_s)) + 1;
  h.inputs.resize(n, static_cast<Eigen::Index>(h.input_names.size()));
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  double speed = 0.0;
  double fluid = 0.0;
  double next_speed_change = 0.0;
  double next_fluid_change = 0.0;
  std::vector<double> walk(static_cast<std::size_t>(extra), 0.0);
  std::vector<double> mix(static_cast<std::size_t>(extra));
  for (double& m : mix) m = 0.2 + 0.8 * unit(rng);
  for (Eigen::Index k = 0; k < n; ++k) {
    const double t = static_cast<double>(k) * step_s;
    h.time_s.push_back(t);
    if (t >= next_speed_change) {
      speed = unit(rng) < 0.3 ? 0.0 : std::round(500.0 + 2500.0 * unit(rng));
      next_speed_change = t + 1800.0 + 5.0 * 3600.0 * unit(rng);
    }
    if (t >= next_fluid_change) {
      fluid = unit(rng) < 0.5 ? 0.0 : 1.0;
      next_fluid_change = t + 3600.0 + 8.0 * 3600.0 * unit(rng);
    }
    const double env = 20.0 + 2.0 * std::sin(2.0 * M_PI * (t / 86400.0 - 0.3)) + 0.3 * std::sin(2.0 * M_PI * t / 7200.0);
    h.inputs(k, 0) = env;
    h.inputs(k, 1) = speed;
    h.inputs(k, 2) = fluid;
    for (int e = 0; e < extra; ++e) {
      walk[static_cast<std::size_t>(e)] += 0.02 * gauss(rng) * std::sqrt(step_s / 60.0);
      h.inputs(k, 3 + e) = 20.0 + mix[static_cast<std::size_t>(e)] * (env - 20.0) + walk[static_cast<std::size_t>(e)];
    }
  }
  return h;
}

// One output with the given inputs, time constants [s] and parameters [b0, gains input-major].
inline OutputModel output_model(std::string name, std::vector<int> inputs, const std::vector<double>& tau_s,
                                std::vector<double> parameters, double base_step_s = 60.0) {
  OutputModel o;
  o.name = std::move(name);
  o.inputs = std::move(inputs);
  o.order = static_cast<int>(tau_s.size());
  o.poles.resize(static_cast<Eigen::Index>(tau_s.size()));
  for (std::size_t k = 0; k < tau_s.size(); ++k) o.poles(static_cast<Eigen::Index>(k)) = pole_of_time_constant(tau_s[k], base_step_s);
  o.parameters = Eigen::Map<Eigen::VectorXd>(parameters.data(), static_cast<Eigen::Index>(parameters.size()));
  return o;
}

inline ThermalModel truth_model(const InputHistory& h, std::vector<OutputModel> outputs) {
  ThermalModel m;
  m.input_names = h.input_names;
  m.input_reference = h.inputs.row(0).transpose();
  m.outputs = std::move(outputs);
  return m;
}

// The model's prediction at every sample (samples x outputs).
inline Eigen::MatrixXd simulate(const ThermalModel& model, const InputHistory& h) {
  ModelPredictor p(model);
  Eigen::MatrixXd y(h.inputs.rows(), static_cast<Eigen::Index>(model.outputs.size()));
  for (Eigen::Index k = 0; k < h.inputs.rows(); ++k) y.row(k) = p.step(h.time_s[static_cast<std::size_t>(k)], h.inputs.row(k).transpose()).transpose();
  return y;
}

// Probe sample indices: every cp_interval for cp_duration, then every post_interval.
inline std::vector<Eigen::Index> probe_samples(const InputHistory& h, double cp_duration_s, double cp_interval_s,
                                               double post_interval_s) {
  std::vector<Eigen::Index> s;
  double next = cp_interval_s;
  for (Eigen::Index k = 0; k < h.inputs.rows(); ++k) {
    const double t = h.time_s[static_cast<std::size_t>(k)];
    if (t + 1e-9 < next) continue;
    s.push_back(k);
    next = t + (t < cp_duration_s ? cp_interval_s : post_interval_s);
  }
  return s;
}

// Probe records at the given samples from the outputs y (samples x outputs), plus Gaussian noise.
inline std::vector<ProbeRecord> probes_at(const InputHistory& h, const Eigen::MatrixXd& y, const std::vector<Eigen::Index>& samples,
                                          std::mt19937_64* rng = nullptr, double noise_sd = 0.0) {
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::vector<ProbeRecord> probes;
  for (const Eigen::Index k : samples) {
    ProbeRecord p;
    p.time_s = h.time_s[static_cast<std::size_t>(k)];
    p.sample_index = static_cast<std::size_t>(k);
    p.errors = y.row(k).transpose();
    if (rng) for (Eigen::Index o = 0; o < p.errors.size(); ++o) p.errors(o) += noise_sd * gauss(*rng);
    probes.push_back(p);
  }
  return probes;
}

}  // namespace alc::test
