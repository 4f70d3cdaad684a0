#pragma once
// A second, smaller twin: a motor spindle in its headstock on a column, seen the way a
// laboratory recording sees it: sixteen temperature sensors on the structure, the spindle speed,
// and five linear errors of a test mandrel (E_X1, E_Y1, E_Z1 near the nose, E_X2, E_Z2 150 mm
// further out). It backs the recording-like built-in scenario S16 (load_cases.hpp).
#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "scenarios/thermal_network.hpp"
#include "scenarios/thermal_twin.hpp"

namespace alc::scenarios {

enum SpindleNode : int {
  kFrontBearing = 0,  // front spindle bearings
  kRearBearing,       // rear spindle bearings
  kMotor,             // motor stator and rotor
  kShaft,             // spindle shaft (carries the tool)
  kHousingFront,      // spindle housing, front half
  kHousingRear,       // spindle housing, rear half
  kHeadstock,         // headstock / ram
  kColumnTop,         // upper column
  kColumnBottom,      // lower column
  kSpindleCoolant,    // cooling jacket circuit
  kSpindleChiller,    // chiller reservoir, follows the hall air
  kSpindleNodes
};
inline constexpr int kSpindleErrors = 5;   // E_X1, E_Y1, E_Z1, E_X2, E_Z2 [µm]
inline constexpr int kSpindleSensors = 16;

struct SpindleTwinParams {
  std::array<double, kSpindleNodes> capacity_J_per_K = {
      2.0e4, 1.5e4, 6.0e4, 3.0e4, 1.5e5, 1.5e5, 8.0e5, 1.4e6, 2.0e6, 5.0e4, 2.0e5};  // [J/K]
  // Heat at reference speed, rising with (n / speed_ref_rpm)^exponent.
  double front_bearing_power_W = 110.0;  // [W]
  double rear_bearing_power_W = 50.0;     // [W]
  double motor_power_W = 180.0;          // [W] losses
  double speed_ref_rpm = 6000.0;         // [rpm]
  double bearing_exponent = 1.7;         // [-]
  double motor_exponent = 1.2;           // [-]
  double reference_temperature_C = 20.0; // [°C] all errors zero here
  // Output map [µm/K] per node (SpindleNode order); E_X2/E_Z2 see the headstock tilt at 150 mm more.
  std::array<std::array<double, kSpindleNodes>, kSpindleErrors> gains = {{
      //  fb     rb     motor  shaft  hsgF   hsgR   head   colT   colB   cool chill
      {{  0.2,   0.0,   0.0,   0.3,   0.6,   -0.4,  0.8,   -0.9,  0.6,   0.0, 0.0}},  // E_X1
      {{  0.4,   -0.2,  0.0,   0.3,   1.2,   -0.6,  1.6,   -2.2,  1.2,   0.0, 0.0}},  // E_Y1
      {{  -1.2,  0.0,   -0.3,  -2.0,  -1.2,  -0.5,  -1.2,  -1.5,  -0.6,  0.0, 0.0}},  // E_Z1
      {{  0.3,   0.0,   0.0,   0.5,   0.9,   -0.6,  1.2,   -1.2,  0.7,   0.0, 0.0}},  // E_X2
      {{  -1.3,  0.0,   -0.3,  -2.4,  -1.3,  -0.5,  -1.2,  -1.5,  -0.6,  0.0, 0.0}},  // E_Z2
  }};
  // Mild nonlinearity: bearing preload grows with the front bearing-to-housing difference.
  std::array<double, kSpindleErrors> quadratic = {0.0, 0.02, -0.08, 0.0, -0.09};  // [µm/K²]
};

class SpindleTwin {
 public:
  explicit SpindleTwin(SpindleTwinParams params = {}, double step_s = 15.0);

  static const std::vector<std::string>& node_names();
  static const std::vector<std::string>& error_names();   // E_X1, E_Y1, E_Z1, E_X2, E_Z2
  static const std::vector<std::string>& sensor_names();  // sixteen T_… columns

  const ThermalNetwork& network() const { return network_; }
  Eigen::VectorXd steady_state(const ThermalLoad& load) const;  // fluid_on is ignored
  // Noiseless sensor temperatures [°C]: each sensor sits on a node or between two, or in air.
  Eigen::VectorXd sensors(const Eigen::VectorXd& nodes, double ambient_C) const;
  // Same row convention as ThermalTwin::simulate; drift is loads.size() x 5 or empty.
  TwinTruth simulate(const Eigen::VectorXd& initial_nodes, const std::vector<ThermalLoad>& loads,
                     const Eigen::MatrixXd& drift = {}) const;

 private:
  Eigen::VectorXd input_vector(const ThermalLoad& load) const;

  SpindleTwinParams params_;
  ThermalNetwork network_;
  DiscreteNetwork discrete_;
};

}  // namespace alc::scenarios
