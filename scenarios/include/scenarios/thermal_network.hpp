#pragma once
// A lumped linear thermal network, the physics under both virtual machines (the C-axis twin and
// the spindle twin): node temperatures x [°C] obey C dx/dt = conduction + heat, i.e.
//   dx/dt = A x + B u,
// with u the boundary temperatures [°C] and heat flows [W] of the moment. DiscreteNetwork is its
// exact discretisation for inputs held constant over a step (zero-order hold), so a simulation
// costs one small matrix-vector product per step, whatever the step and the time constants.
#include <Eigen/Core>
#include <string>
#include <vector>

namespace alc::scenarios {

class ThermalNetwork {
 public:
  // `capacity_J_per_K[i]` is the heat capacity of node i [J/K]; `input_count` the size of u.
  ThermalNetwork(std::vector<std::string> node_names, std::vector<double> capacity_J_per_K,
                 int input_count);

  // Conduction or convection between nodes i and j: heat g (T_j - T_i) flows into i, and back.
  void conduct(int i, int j, double g_W_per_K);
  // Conduction between node i and a boundary temperature u[k] (ambient air, a supply).
  void conduct_to_input(int i, int k, double g_W_per_K);
  // One-way pull of node `to` towards node `from`, which does not feel it back: a regulated
  // circuit (a chiller that follows a reference) rather than passive conduction.
  void drive(int to, int from, double g_W_per_K);
  // A share of the heat flow u[k] [W] enters node i.
  void heat_from_input(int i, int k, double share = 1.0);

  int nodes() const { return static_cast<int>(node_names_.size()); }
  int inputs() const { return static_cast<int>(b_.cols()); }
  const std::vector<std::string>& node_names() const { return node_names_; }
  const Eigen::MatrixXd& a() const { return a_; }  // [1/s]
  const Eigen::MatrixXd& b() const { return b_; }  // [1/s] for temperatures, [K/J] for heat flows

  // Node temperatures once a constant input has acted long enough: -A⁻¹ B u [°C].
  Eigen::VectorXd steady_state(const Eigen::VectorXd& u) const;
  // Time constants of the network, -1/Re(λ) for the eigenvalues λ of A, ascending [s].
  Eigen::VectorXd time_constants_s() const;

 private:
  std::vector<std::string> node_names_;
  std::vector<double> capacity_;  // [J/K]
  Eigen::MatrixXd a_;
  Eigen::MatrixXd b_;
};

// x(t + step) = ad x(t) + bd u for u constant over the step: exact, from the matrix exponential
// of [[A, B], [0, 0]] step.
struct DiscreteNetwork {
  Eigen::MatrixXd ad;
  Eigen::MatrixXd bd;
  double step_s = 0.0;  // [s]

  Eigen::VectorXd next(const Eigen::VectorXd& x, const Eigen::VectorXd& u) const { return ad * x + bd * u; }
};

DiscreteNetwork discretise(const ThermalNetwork& network, double step_s);

}  // namespace alc::scenarios
