#include "scenarios/spindle_twin.hpp"

#include <cmath>
#include <stdexcept>

namespace alc::scenarios {

namespace {

enum SpindleInput : int { kHallInput = 0, kFrontHeat, kRearHeat, kMotorHeat, kSpindleInputs };

ThermalNetwork build_spindle_network(const SpindleTwinParams& p) {
  ThermalNetwork net(SpindleTwin::node_names(),
                     std::vector<double>(p.capacity_J_per_K.begin(), p.capacity_J_per_K.end()), kSpindleInputs);
  net.conduct(kFrontBearing, kShaft, 8.0);          // [W/K]
  net.conduct(kRearBearing, kShaft, 6.0);
  net.conduct(kMotor, kShaft, 10.0);
  net.conduct(kFrontBearing, kHousingFront, 12.0);
  net.conduct(kRearBearing, kHousingRear, 10.0);
  net.conduct(kMotor, kHousingRear, 15.0);
  net.conduct(kMotor, kSpindleCoolant, 30.0);
  net.conduct(kHousingFront, kSpindleCoolant, 20.0);
  net.conduct(kHousingFront, kHousingRear, 10.0);
  net.conduct(kHousingFront, kHeadstock, 15.0);
  net.conduct(kHousingRear, kHeadstock, 15.0);
  net.conduct(kHeadstock, kColumnTop, 20.0);
  net.conduct(kColumnTop, kColumnBottom, 25.0);
  net.conduct_to_input(kShaft, kHallInput, 2.0);
  net.conduct_to_input(kHousingFront, kHallInput, 5.0);
  net.conduct_to_input(kHeadstock, kHallInput, 30.0);
  net.conduct_to_input(kColumnTop, kHallInput, 30.0);
  net.conduct_to_input(kColumnBottom, kHallInput, 40.0);
  net.drive(kSpindleCoolant, kSpindleChiller, 80.0);  // regulated: the chiller takes the heat
  net.conduct_to_input(kSpindleChiller, kHallInput, 60.0);
  net.heat_from_input(kFrontBearing, kFrontHeat);
  net.heat_from_input(kRearBearing, kRearHeat);
  net.heat_from_input(kMotor, kMotorHeat);
  return net;
}

// Where the sixteen sensors sit: weights over nodes, and a share of the hall air (last column).
Eigen::Matrix<double, kSpindleSensors, kSpindleNodes + 1> sensor_map() {
  Eigen::Matrix<double, kSpindleSensors, kSpindleNodes + 1> m = decltype(m)::Zero();
  constexpr int air = kSpindleNodes;
  m(0, air) = 1.0;                                            // T_HALL
  m(1, kSpindleChiller) = 1.0;                                // T_COOL_IN
  m(2, kSpindleCoolant) = 1.0;                                // T_COOL_OUT
  m(3, kFrontBearing) = 0.8, m(3, kHousingFront) = 0.2;       // T_BRG_F
  m(4, kRearBearing) = 0.8, m(4, kHousingRear) = 0.2;         // T_BRG_R
  m(5, kMotor) = 0.7, m(5, kHousingRear) = 0.3;               // T_MOTOR
  m(6, kHousingFront) = 1.0;                                  // T_HSG_F1
  m(7, kHousingFront) = 0.7, m(7, kHeadstock) = 0.3;          // T_HSG_F2
  m(8, kHousingRear) = 1.0;                                   // T_HSG_R
  m(9, kHeadstock) = 1.0;                                     // T_HEAD_L
  m(10, kHeadstock) = 0.8, m(10, kHousingRear) = 0.2;         // T_HEAD_R
  m(11, kColumnTop) = 0.9, m(11, kHeadstock) = 0.1;           // T_COL_TF
  m(12, kColumnTop) = 0.8, m(12, air) = 0.2;                  // T_COL_TR
  m(13, kColumnTop) = 0.5, m(13, kColumnBottom) = 0.5;        // T_COL_M
  m(14, kColumnBottom) = 1.0;                                 // T_COL_B
  m(15, air) = 0.6, m(15, kHeadstock) = 0.4;                  // T_AIR_WS
  return m;
}

}  // namespace

SpindleTwin::SpindleTwin(SpindleTwinParams params, double step_s)
    : params_(std::move(params)), network_(build_spindle_network(params_)), discrete_(discretise(network_, step_s)) {}

const std::vector<std::string>& SpindleTwin::node_names() {
  static const std::vector<std::string> names = {"front_bearing", "rear_bearing", "motor",      "shaft",
                                                 "housing_front", "housing_rear", "headstock",  "column_top",
                                                 "column_bottom", "coolant",      "chiller"};
  return names;
}

const std::vector<std::string>& SpindleTwin::error_names() {
  static const std::vector<std::string> names = {"E_X1", "E_Y1", "E_Z1", "E_X2", "E_Z2"};
  return names;
}

const std::vector<std::string>& SpindleTwin::sensor_names() {
  static const std::vector<std::string> names = {
      "T_HALL",   "T_COOL_IN", "T_COOL_OUT", "T_BRG_F",  "T_BRG_R",  "T_MOTOR",  "T_HSG_F1", "T_HSG_F2",
      "T_HSG_R",  "T_HEAD_L",  "T_HEAD_R",   "T_COL_TF", "T_COL_TR", "T_COL_M",  "T_COL_B",  "T_AIR_WS"};
  return names;
}

Eigen::VectorXd SpindleTwin::input_vector(const ThermalLoad& load) const {
  const double r = std::abs(load.speed_rpm) / params_.speed_ref_rpm;
  Eigen::VectorXd u(kSpindleInputs);
  u(kHallInput) = load.ambient_C;
  u(kFrontHeat) = params_.front_bearing_power_W * std::pow(r, params_.bearing_exponent);
  u(kRearHeat) = params_.rear_bearing_power_W * std::pow(r, params_.bearing_exponent);
  u(kMotorHeat) = params_.motor_power_W * std::pow(r, params_.motor_exponent);
  return u;
}

Eigen::VectorXd SpindleTwin::steady_state(const ThermalLoad& load) const {
  return network_.steady_state(input_vector(load));
}

Eigen::VectorXd SpindleTwin::sensors(const Eigen::VectorXd& nodes, double ambient_C) const {
  static const auto map = sensor_map();
  Eigen::VectorXd x(kSpindleNodes + 1);
  x << nodes, ambient_C;
  return map * x;
}

TwinTruth SpindleTwin::simulate(const Eigen::VectorXd& initial_nodes, const std::vector<ThermalLoad>& loads,
                                const Eigen::MatrixXd& drift) const {
  const auto n = static_cast<Eigen::Index>(loads.size());
  if (initial_nodes.size() != kSpindleNodes)
    throw std::invalid_argument("SpindleTwin::simulate: initial_nodes has " + std::to_string(initial_nodes.size()) +
                                " values, the twin has " + std::to_string(kSpindleNodes) + " nodes");
  if (drift.size() != 0 && (drift.rows() != n || drift.cols() != kSpindleErrors))
    throw std::invalid_argument("SpindleTwin::simulate: drift must be " + std::to_string(n) + " x 5");
  TwinTruth truth{node_names(), error_names(), Eigen::MatrixXd(n, kSpindleNodes), Eigen::MatrixXd(n, kSpindleErrors)};
  Eigen::VectorXd x = initial_nodes;
  for (Eigen::Index k = 0; k < n; ++k) {
    truth.nodes.row(k) = x.transpose();
    const double preload = x(kFrontBearing) - x(kHousingFront);  // [K]
    for (int e = 0; e < kSpindleErrors; ++e) {
      const auto& g = params_.gains[static_cast<std::size_t>(e)];
      double value = drift.size() != 0 ? drift(k, e) : 0.0;
      for (int i = 0; i < kSpindleNodes; ++i) value += g[static_cast<std::size_t>(i)] * (x(i) - params_.reference_temperature_C);
      truth.errors(k, e) = value + params_.quadratic[static_cast<std::size_t>(e)] * preload * preload;
    }
    x = discrete_.next(x, input_vector(loads[static_cast<std::size_t>(k)]));
  }
  return truth;
}

}  // namespace alc::scenarios
