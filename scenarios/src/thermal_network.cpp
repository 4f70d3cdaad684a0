#include "scenarios/thermal_network.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <stdexcept>
#include <unsupported/Eigen/MatrixFunctions>

namespace alc::scenarios {

ThermalNetwork::ThermalNetwork(std::vector<std::string> node_names, std::vector<double> capacity_J_per_K,
                               int input_count)
    : node_names_(std::move(node_names)), capacity_(std::move(capacity_J_per_K)) {
  if (node_names_.size() != capacity_.size())
    throw std::invalid_argument("ThermalNetwork: " + std::to_string(node_names_.size()) + " node names but " +
                                std::to_string(capacity_.size()) + " capacities");
  for (std::size_t i = 0; i < capacity_.size(); ++i)
    if (!(capacity_[i] > 0.0))
      throw std::invalid_argument("ThermalNetwork: capacity of node '" + node_names_[i] +
                                  "' must be > 0 J/K, got " + std::to_string(capacity_[i]));
  const auto n = static_cast<Eigen::Index>(capacity_.size());
  a_ = Eigen::MatrixXd::Zero(n, n);
  b_ = Eigen::MatrixXd::Zero(n, input_count);
}

void ThermalNetwork::conduct(int i, int j, double g) {
  drive(i, j, g);
  drive(j, i, g);
}

void ThermalNetwork::drive(int to, int from, double g) {
  const double c = capacity_.at(static_cast<std::size_t>(to));
  a_(to, to) -= g / c;
  a_(to, from) += g / c;
}

void ThermalNetwork::conduct_to_input(int i, int k, double g) {
  const double c = capacity_.at(static_cast<std::size_t>(i));
  a_(i, i) -= g / c;
  b_(i, k) += g / c;
}

void ThermalNetwork::heat_from_input(int i, int k, double share) {
  b_(i, k) += share / capacity_.at(static_cast<std::size_t>(i));
}

Eigen::VectorXd ThermalNetwork::steady_state(const Eigen::VectorXd& u) const {
  return a_.partialPivLu().solve(-(b_ * u));
}

Eigen::VectorXd ThermalNetwork::time_constants_s() const {
  const Eigen::VectorXcd lambda = a_.eigenvalues();
  Eigen::VectorXd tau(lambda.size());
  for (Eigen::Index i = 0; i < lambda.size(); ++i) tau(i) = -1.0 / lambda(i).real();
  std::sort(tau.data(), tau.data() + tau.size());
  return tau;
}

DiscreteNetwork discretise(const ThermalNetwork& network, double step_s) {
  if (!(step_s > 0.0)) throw std::invalid_argument("discretise: step must be > 0 s, got " + std::to_string(step_s));
  const Eigen::Index n = network.nodes();
  const Eigen::Index m = network.inputs();
  Eigen::MatrixXd augmented = Eigen::MatrixXd::Zero(n + m, n + m);
  augmented.topLeftCorner(n, n) = network.a() * step_s;
  augmented.topRightCorner(n, m) = network.b() * step_s;
  const Eigen::MatrixXd e = augmented.exp();
  return DiscreteNetwork{e.topLeftCorner(n, n), e.topRightCorner(n, m), step_s};
}

}  // namespace alc::scenarios
