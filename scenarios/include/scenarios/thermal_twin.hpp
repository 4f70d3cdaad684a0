#pragma once
// The thermal twin: a virtual 5-axis machine with a table-side C axis (rotary table in a tilting
// cradle), made of a lumped thermal network (scenarios/thermal_network.hpp) and an output map
// from node temperatures to the seven location errors of the C axis (docs/design.md, "The seven errors").
//
// Shape of GTSAM's Scenario / ScenarioRunner: the twin is the exact, noiseless physics
// (node temperatures and true errors at every sample); the load cases (load_cases.hpp) drive it
// and make what sensors and the touch probe would have given. docs/twin.md has the numbers.
#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "scenarios/thermal_network.hpp"

namespace alc::scenarios {

// Nodes of the C-axis twin, in state-vector order.
enum TwinNode : int {
  kBearing = 0,   // C-axis bearing and direct drive (friction heat enters here)
  kTable,         // rotary table (the workpiece side; cutting fluid flows over it)
  kCradle,        // tilting cradle (A axis) carrying the table
  kBed,           // machine bed
  kColumn,        // column with the spindle head (tool side)
  kWorkspace,     // air and sheet metal of the enclosed workspace
  kCoolant,       // C-axis coolant circuit (what the coolant sensor reads)
  kChiller,       // chiller reservoir; the chiller follows the hall air (room-tracking control)
  kFluidTank,     // cutting-fluid tank (what the fluid sensor reads in case D)
  kTwinNodes
};
// The seven errors, in output order: E_X0C, E_Y0C, E_Z0T, E_R0T [µm], E_A0C, E_B0C, E_C0C [µm/m].
inline constexpr int kTwinErrors = 7;
using ErrorGains = std::array<std::array<double, kTwinNodes>, kTwinErrors>;
using ErrorVector = Eigen::Matrix<double, kTwinErrors, 1>;

struct ThermalTwinParams {
  // Heat capacities [J/K] (steel and cast iron ≈ 460 J/(kg K), fluids ≈ 2–4 kJ/(kg K)).
  double c_bearing = 6.0e4;        // [J/K] ~130 kg around the C-axis bearing and motor
  double c_table = 2.3e5;          // [J/K] ~500 kg table
  double c_cradle = 7.0e5;         // [J/K] ~1.5 t cradle
  double c_bed = 3.7e6;            // [J/K] ~8 t bed
  double c_column = 1.4e6;         // [J/K] ~3 t column and head
  double c_workspace = 1.0e5;      // [J/K] enclosure air and sheet metal
  double c_coolant = 1.2e5;        // [J/K] ~60 l oil in the C-axis circuit
  double c_chiller = 2.0e5;        // [J/K] chiller reservoir
  double c_fluid_tank = 1.2e6;     // [J/K] ~300 l emulsion

  // Conductances [W/K].
  double g_bearing_coolant = 25.0;    // [W/K] cooling jacket of the C-axis drive
  double g_bearing_table = 15.0;      // [W/K]
  double g_bearing_cradle = 10.0;     // [W/K]
  double g_table_cradle = 8.0;        // [W/K]
  double g_table_workspace = 12.0;    // [W/K] convection, table surface
  double g_cradle_workspace = 10.0;   // [W/K]
  double g_cradle_bed = 20.0;         // [W/K] trunnion bearings and supports
  double g_bed_column = 15.0;         // [W/K]
  double g_bed_ambient = 45.0;        // [W/K] bed to hall air (and floor)
  double g_column_ambient = 40.0;     // [W/K]
  double g_workspace_ambient = 60.0;  // [W/K] enclosure walls and leakage
  double g_coolant_chiller = 60.0;    // [W/K] flow rate × heat capacity of the circuit
  double g_chiller_ambient = 55.0;    // [W/K] room-tracking control, as a one-way pull (τ ≈ 1 h)
  double g_fluid_tank_ambient = 35.0; // [W/K] tank walls
  // While the cutting fluid runs it floods the table and the workspace with tank fluid.
  double g_table_fluid = 60.0;        // [W/K] fluid on: table <-> fluid
  double g_workspace_fluid = 25.0;    // [W/K] fluid on: spray and chips <-> fluid
  double fluid_pump_power_W = 250.0;  // [W] pump heat into the fluid while it runs

  // C-axis friction heat: P = friction_power_W (n / friction_speed_ref_rpm)^friction_exponent.
  double friction_power_W = 130.0;        // [W] at the reference speed
  double friction_speed_ref_rpm = 1000.0; // [rpm]
  double friction_exponent = 1.6;         // [-] > 1: faster than linear (bearing drag, churning)

  // Output map: error_e = Σ_i gains[e][i] (T_i - reference_temperature_C)
  //                      + quadratic[e] (T_cradle - T_bed)² + drift_e.
  double reference_temperature_C = 20.0;  // [°C] temperature at which all errors are zero
  // [µm/K] for linear errors, [µm/(m K)] for angular ones; columns in TwinNode order.
  // Air, liquids and the chiller do not deform the structure: their columns are zero.
  ErrorGains gains = {{
      //  bearing table  cradle  bed    column  ws   cool chill fluid
      {{  1.0,   0.8,   1.4,   -1.6,   2.6,   0.0, 0.0, 0.0, 0.0}},  // E_X0C [µm/K]
      {{  1.8,   0.6,   3.0,   -1.0,   -1.8,  0.0, 0.0, 0.0, 0.0}},  // E_Y0C [µm/K]
      {{  1.6,   2.0,   1.6,   1.0,    -3.5,  0.0, 0.0, 0.0, 0.0}},  // E_Z0T [µm/K]
      {{  1.0,   2.9,   0.0,   -1.2,   0.0,   0.0, 0.0, 0.0, 0.0}},  // E_R0T [µm/K]
      {{  2.5,   2.0,   4.0,   -2.5,   -2.0,  0.0, 0.0, 0.0, 0.0}},  // E_A0C [µm/(m K)]
      {{  2.5,   -0.5,  1.0,   1.5,    4.5,   0.0, 0.0, 0.0, 0.0}},  // E_B0C [µm/(m K)]
      {{  5.0,   3.0,   -1.5,  -1.0,   0.0,   0.0, 0.0, 0.0, 0.0}},  // E_C0C [µm/(m K)]
  }};
  // Mild nonlinearity: bending of the cradle grows with the square of its vertical gradient.
  std::array<double, kTwinErrors> quadratic = {0.05, 0.12, 0.10, 0.0, 0.25, 0.15, 0.0};  // [µm/K²], [µm/(m K²)]

  // Empty if valid, else which constraint is violated (name and value).
  std::string validate() const;
};

// What acts on the machine during one sample interval (held constant over it).
struct ThermalLoad {
  double ambient_C = 20.0;  // [°C] hall air next to the machine
  double speed_rpm = 0.0;   // [rpm] C-axis speed (its magnitude heats)
  bool fluid_on = false;    // cutting-fluid supply switched on
};

// The noiseless truth of a simulation; row k is the state at sample k.
struct TwinTruth {
  std::vector<std::string> node_names;   // TwinNode order
  std::vector<std::string> error_names;  // E_X0C ... E_C0C
  Eigen::MatrixXd nodes;                 // samples x nodes [°C]
  Eigen::MatrixXd errors;                // samples x errors [µm] / [µm/m], drift included
};

class ThermalTwin {
 public:
  // Precomputes the exact discretisation for `step_s` with the fluid off and on.
  explicit ThermalTwin(ThermalTwinParams params = {}, double step_s = 60.0);

  static const std::vector<std::string>& node_names();   // "bearing", "table", ...
  static const std::vector<std::string>& error_names();  // "E_X0C", ...

  const ThermalTwinParams& params() const { return params_; }
  double step_s() const { return step_s_; }
  // The continuous network for a fluid state (for time constants and inspection).
  const ThermalNetwork& network(bool fluid_on) const { return fluid_on ? network_on_ : network_off_; }

  // C-axis friction heat [W] at a speed [rpm] (sign of the speed does not matter).
  double friction_heat_W(double speed_rpm) const;
  // Node temperatures [°C] reached under a load held forever.
  Eigen::VectorXd steady_state(const ThermalLoad& load) const;
  // Node temperatures one step later, the load held over the step.
  Eigen::VectorXd step(const Eigen::VectorXd& nodes, const ThermalLoad& load) const;
  // The seven true errors for node temperatures, plus a drift (no fixed model explains it).
  ErrorVector errors(const Eigen::VectorXd& nodes, const ErrorVector& drift = ErrorVector::Zero()) const;

  // Runs from `initial_nodes` through `loads`: one row per load, row k the state at sample k
  // (row 0 = initial_nodes), loads[k] acting from sample k to k + 1. `drift` is
  // loads.size() x 7, or empty for no drift.
  TwinTruth simulate(const Eigen::VectorXd& initial_nodes, const std::vector<ThermalLoad>& loads,
                     const Eigen::MatrixXd& drift = {}) const;

 private:
  Eigen::VectorXd input_vector(const ThermalLoad& load) const;

  ThermalTwinParams params_;
  double step_s_;
  ThermalNetwork network_off_;
  ThermalNetwork network_on_;
  DiscreteNetwork discrete_off_;
  DiscreteNetwork discrete_on_;
};

}  // namespace alc::scenarios
