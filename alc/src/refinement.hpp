#pragma once
// Refinements of a fixed-pole fit: robust gains (route a, Newton / IRLS in Eigen) and output error
// with free time constants (route b, Ceres). Internal to identification.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "alc/thermal_model.hpp"

namespace alc::detail {

struct Refinement {
  Eigen::VectorXd theta;          // [b0, gains input-major pole-minor]
  std::vector<double> tau_s;      // [s] time constants (unchanged for the gains-only refinement)
  double cost_before = 0.0;       // cost at the start (Ceres' definition: ½ Σ rho(r²) + ½ ridge terms)
  double cost_after = 0.0;        // cost at the end
  bool ok = false;                // false: keep the starting point (message says why)
  std::string message;
};

struct RobustSettings {
  RobustLoss loss = RobustLoss::Huber;
  double scale = 1.0;             // [µm] or [µm/m]
  double ridge = 0.0;             // [-] relative, as in solve_weighted_ridge
  int max_iterations = 50;
};

// Robust gains on fixed regressors phi (rows x (1 + lags)), residual sqrt(w) (phi theta - y), ridge
// on the gains as in solve_weighted_ridge: Newton (Huber) or IRLS (Cauchy) steps with a line search
// from theta0 (docs/identification.md, step 6).
Refinement refine_gains(const Eigen::MatrixXd& phi, const Eigen::VectorXd& y, const Eigen::VectorXd& w,
                        const Eigen::VectorXd& theta0, const RobustSettings& settings);

// Output error: gains and time constants (shared by the inputs) on the lags simulated over the
// history, compared at `samples` (ascending history rows, one per measurement).
struct OutputErrorData {
  const InputHistory* history = nullptr;
  Eigen::VectorXd reference;          // input reference
  std::vector<int> inputs;            // history columns used
  std::vector<Eigen::Index> samples;  // history row of each measurement, ascending
  Eigen::VectorXd y;                  // measured error at each sample
  Eigen::VectorXd w;                  // weight of each measurement
  double tau_lower_s = 0.0;           // [s] bounds of the time constants
  double tau_upper_s = 0.0;
};
Refinement refine_output_error(const OutputErrorData& data, const std::vector<double>& tau0_s,
                               const Eigen::VectorXd& theta0, const RobustSettings& settings);

}  // namespace alc::detail
