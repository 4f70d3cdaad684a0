#include "scenarios/thermal_twin.hpp"

#include <cmath>
#include <stdexcept>

namespace alc::scenarios {

namespace {

// Inputs u of the network: boundary temperature and heat flows.
enum TwinInput : int { kAmbientInput = 0, kFrictionInput, kPumpInput, kTwinInputs };

std::vector<double> capacities(const ThermalTwinParams& p) {
  std::vector<double> c(kTwinNodes);
  c[kBearing] = p.c_bearing;
  c[kTable] = p.c_table;
  c[kCradle] = p.c_cradle;
  c[kBed] = p.c_bed;
  c[kColumn] = p.c_column;
  c[kWorkspace] = p.c_workspace;
  c[kCoolant] = p.c_coolant;
  c[kChiller] = p.c_chiller;
  c[kFluidTank] = p.c_fluid_tank;
  return c;
}

ThermalNetwork build_network(const ThermalTwinParams& p, bool fluid_on) {
  ThermalNetwork net(ThermalTwin::node_names(), capacities(p), kTwinInputs);
  net.conduct(kBearing, kCoolant, p.g_bearing_coolant);
  net.conduct(kBearing, kTable, p.g_bearing_table);
  net.conduct(kBearing, kCradle, p.g_bearing_cradle);
  net.conduct(kTable, kCradle, p.g_table_cradle);
  net.conduct(kTable, kWorkspace, p.g_table_workspace);
  net.conduct(kCradle, kWorkspace, p.g_cradle_workspace);
  net.conduct(kCradle, kBed, p.g_cradle_bed);
  net.conduct(kBed, kColumn, p.g_bed_column);
  net.conduct_to_input(kBed, kAmbientInput, p.g_bed_ambient);
  net.conduct_to_input(kColumn, kAmbientInput, p.g_column_ambient);
  net.conduct_to_input(kWorkspace, kAmbientInput, p.g_workspace_ambient);
  // The chiller removes whatever the circuit brings and holds its reservoir near the hall air:
  // the circuit is pulled towards the reservoir, the reservoir does not feel the circuit.
  net.drive(kCoolant, kChiller, p.g_coolant_chiller);
  net.conduct_to_input(kChiller, kAmbientInput, p.g_chiller_ambient);
  net.conduct_to_input(kFluidTank, kAmbientInput, p.g_fluid_tank_ambient);
  net.heat_from_input(kBearing, kFrictionInput);
  net.heat_from_input(kFluidTank, kPumpInput);
  if (fluid_on) {
    net.conduct(kTable, kFluidTank, p.g_table_fluid);
    net.conduct(kWorkspace, kFluidTank, p.g_workspace_fluid);
  }
  return net;
}

ThermalTwinParams checked(ThermalTwinParams p) {
  if (const std::string why = p.validate(); !why.empty()) throw std::invalid_argument("ThermalTwinParams: " + why);
  return p;
}

}  // namespace

std::string ThermalTwinParams::validate() const {
  const std::vector<std::pair<const char*, double>> positive = {
      {"c_bearing", c_bearing}, {"c_table", c_table}, {"c_cradle", c_cradle}, {"c_bed", c_bed},
      {"c_column", c_column}, {"c_workspace", c_workspace}, {"c_coolant", c_coolant},
      {"c_chiller", c_chiller}, {"c_fluid_tank", c_fluid_tank},
      {"g_bed_ambient", g_bed_ambient}, {"g_column_ambient", g_column_ambient},
      {"g_workspace_ambient", g_workspace_ambient}, {"g_coolant_chiller", g_coolant_chiller},
      {"g_chiller_ambient", g_chiller_ambient}, {"g_fluid_tank_ambient", g_fluid_tank_ambient},
      {"friction_speed_ref_rpm", friction_speed_ref_rpm}, {"friction_exponent", friction_exponent}};
  for (const auto& [name, value] : positive)
    if (!(value > 0.0) || !std::isfinite(value))
      return std::string(name) + " must be finite and > 0, got " + std::to_string(value);
  const std::vector<std::pair<const char*, double>> non_negative = {
      {"g_bearing_coolant", g_bearing_coolant}, {"g_bearing_table", g_bearing_table},
      {"g_bearing_cradle", g_bearing_cradle}, {"g_table_cradle", g_table_cradle},
      {"g_table_workspace", g_table_workspace}, {"g_cradle_workspace", g_cradle_workspace},
      {"g_cradle_bed", g_cradle_bed}, {"g_bed_column", g_bed_column}, {"g_table_fluid", g_table_fluid},
      {"g_workspace_fluid", g_workspace_fluid}, {"fluid_pump_power_W", fluid_pump_power_W},
      {"friction_power_W", friction_power_W}};
  for (const auto& [name, value] : non_negative)
    if (!(value >= 0.0) || !std::isfinite(value))
      return std::string(name) + " must be finite and >= 0, got " + std::to_string(value);
  if (!std::isfinite(reference_temperature_C))
    return "reference_temperature_C must be finite, got " + std::to_string(reference_temperature_C);
  return {};
}

ThermalTwin::ThermalTwin(ThermalTwinParams params, double step_s)
    : params_(checked(std::move(params))),
      step_s_(step_s),
      network_off_(build_network(params_, false)),
      network_on_(build_network(params_, true)),
      discrete_off_(discretise(network_off_, step_s)),
      discrete_on_(discretise(network_on_, step_s)) {
}

const std::vector<std::string>& ThermalTwin::node_names() {
  static const std::vector<std::string> names = {"bearing", "table",   "cradle",  "bed",       "column",
                                                 "workspace", "coolant", "chiller", "fluid_tank"};
  return names;
}

const std::vector<std::string>& ThermalTwin::error_names() {
  static const std::vector<std::string> names = {"E_X0C", "E_Y0C", "E_Z0T", "E_R0T", "E_A0C", "E_B0C", "E_C0C"};
  return names;
}

double ThermalTwin::friction_heat_W(double speed_rpm) const {
  return params_.friction_power_W *
         std::pow(std::abs(speed_rpm) / params_.friction_speed_ref_rpm, params_.friction_exponent);
}

Eigen::VectorXd ThermalTwin::input_vector(const ThermalLoad& load) const {
  Eigen::VectorXd u(kTwinInputs);
  u(kAmbientInput) = load.ambient_C;
  u(kFrictionInput) = friction_heat_W(load.speed_rpm);
  u(kPumpInput) = load.fluid_on ? params_.fluid_pump_power_W : 0.0;
  return u;
}

Eigen::VectorXd ThermalTwin::steady_state(const ThermalLoad& load) const {
  return network(load.fluid_on).steady_state(input_vector(load));
}

Eigen::VectorXd ThermalTwin::step(const Eigen::VectorXd& nodes, const ThermalLoad& load) const {
  return (load.fluid_on ? discrete_on_ : discrete_off_).next(nodes, input_vector(load));
}

ErrorVector ThermalTwin::errors(const Eigen::VectorXd& nodes, const ErrorVector& drift) const {
  ErrorVector e = drift;
  const double gradient = nodes(kCradle) - nodes(kBed);  // [K]
  for (int k = 0; k < kTwinErrors; ++k) {
    const auto& g = params_.gains[static_cast<std::size_t>(k)];
    for (int i = 0; i < kTwinNodes; ++i) e(k) += g[static_cast<std::size_t>(i)] * (nodes(i) - params_.reference_temperature_C);
    e(k) += params_.quadratic[static_cast<std::size_t>(k)] * gradient * gradient;
  }
  return e;
}

TwinTruth ThermalTwin::simulate(const Eigen::VectorXd& initial_nodes, const std::vector<ThermalLoad>& loads,
                                const Eigen::MatrixXd& drift) const {
  const auto n = static_cast<Eigen::Index>(loads.size());
  if (initial_nodes.size() != kTwinNodes)
    throw std::invalid_argument("ThermalTwin::simulate: initial_nodes has " + std::to_string(initial_nodes.size()) +
                                " values, the twin has " + std::to_string(kTwinNodes) + " nodes");
  if (drift.size() != 0 && (drift.rows() != n || drift.cols() != kTwinErrors))
    throw std::invalid_argument("ThermalTwin::simulate: drift must be " + std::to_string(n) + " x 7, got " +
                                std::to_string(drift.rows()) + " x " + std::to_string(drift.cols()));
  TwinTruth truth{node_names(), error_names(), Eigen::MatrixXd(n, kTwinNodes), Eigen::MatrixXd(n, kTwinErrors)};
  Eigen::VectorXd x = initial_nodes;
  for (Eigen::Index k = 0; k < n; ++k) {
    truth.nodes.row(k) = x.transpose();
    const ErrorVector d = drift.size() != 0 ? ErrorVector(drift.row(k).transpose()) : ErrorVector::Zero();
    truth.errors.row(k) = errors(x, d).transpose();
    x = step(x, loads[static_cast<std::size_t>(k)]);
  }
  return truth;
}

}  // namespace alc::scenarios
