#pragma once
// Kinematics of a 5-axis machine with a two-axis rotary table (trunnion): from the seven thermal
// location errors of the C axis to axis offsets that cancel them (seed 000, Zhang et al.,
// "thermal error compensation model"; HTMs of the kinematic chain).
//
// The chain, workpiece side (all vectors in the machine frame with both rotary axes at zero):
//   p = pivot_tilt + R_tilt(tilt)·( pivot_table + E·( R_table(table)·(w_r − pivot_table) ) − pivot_tilt )
// where E is the error HTM located at the table (C) axis pivot, in the cradle frame:
//   rotation by (E_A0C, E_B0C, E_C0C) about the cradle x, y, z axes, translation (E_X0C, E_Y0C, 0).
// Its first-order form is the small-angle HTM [I + [ε]×, δ]; the code uses the exact rotation of
// the same rotation vector so that the forward chain is a rigid motion (difference O(ε²) ≈ 1e-8).
// w_r is the workpiece point moved radially away from the table axis by E_R0T (table growth).
// Tool side: the tool tip sits at the commanded (X, Y, Z) plus E_Z0T along machine z (spindle growth).
//
// The deviation is tool minus workpiece: position at the workpiece point [µm] and the rotation of
// the tool relative to the workpiece [µrad] (machine frame). Offsets (ΔX, ΔY, ΔZ, Δtilt, Δtable)
// cancel it: the linear axes cancel all of the position at the workpiece point, the two rotary axes
// cancel the part of the rotation that lies in the plane spanned by their directions. The rest of
// the rotation (for an A–C table: a tilt of the C axis about the cradle's y axis, i.e. E_B0C) has
// no axis to act on; compensate() reports it instead of dropping it.
//
// Pure math: no files, no I/O. Reading a machine config lives in nc_interface/.
#include <Eigen/Core>
#include <string>
#include <vector>

namespace alc::kinematics {

// A rotary axis: its name letter, unit direction and a point on it (machine frame, axes at zero).
struct RotaryAxis {
  char name = 'A';
  Eigen::Vector3d direction = Eigen::Vector3d::UnitX();  // [-] unit vector, right-hand rotation
  Eigen::Vector3d pivot_mm = Eigen::Vector3d::Zero();    // [mm] a point on the axis
};

// The configurable chain of a table-table machine: a tilting cradle carrying a rotary table.
struct MachineChain {
  RotaryAxis tilt{'A', Eigen::Vector3d::UnitX(), Eigen::Vector3d::Zero()};   // cradle (A or B)
  RotaryAxis table{'C', Eigen::Vector3d::UnitZ(), Eigen::Vector3d::Zero()};  // table on the cradle
  Eigen::Vector3d workpiece_point_mm{100.0, 0.0, 50.0};  // [mm] reference point on the table (axes at zero)

  static MachineChain ac_trunnion();  // A about +x, C about +z, both through the origin
  static MachineChain bc_trunnion();  // B about +y, C about +z, both through the origin
};

// Empty if the chain is usable, else which constraint is broken (names the field and the value).
std::string validate(const MachineChain& chain);

// The seven thermal location errors of the C axis (ISO 230-7 names; docs/design.md, "The seven errors").
struct LocationErrors {
  double x0c_um = 0.0;       // E_X0C [µm] axis position in x
  double y0c_um = 0.0;       // E_Y0C [µm] axis position in y
  double z0t_um = 0.0;       // E_Z0T [µm] tool side, along machine z
  double r0t_um = 0.0;       // E_R0T [µm] radial, away from the table axis at the workpiece point
  double a0c_um_per_m = 0.0; // E_A0C [µm/m] tilt about the cradle x axis
  double b0c_um_per_m = 0.0; // E_B0C [µm/m] tilt about the cradle y axis
  double c0c_um_per_m = 0.0; // E_C0C [µm/m] zero position about the cradle z axis
};

// Positions of the rotary axes (the NC's commanded values).
struct AxisPositions {
  double tilt_deg = 0.0;   // [°] A (or B)
  double table_deg = 0.0;  // [°] C
};

// Offsets added to the commanded axis positions.
struct AxisOffsetValues {
  double x_um = 0.0;         // [µm]
  double y_um = 0.0;         // [µm]
  double z_um = 0.0;         // [µm]
  double tilt_urad = 0.0;    // [µrad] A (or B)
  double table_urad = 0.0;   // [µrad] C
};

// Tool against workpiece, machine frame.
struct Deviation {
  Eigen::Vector3d position_um = Eigen::Vector3d::Zero();    // [µm] tool minus workpiece point
  Eigen::Vector3d rotation_urad = Eigen::Vector3d::Zero();  // [µrad] rotation vector, tool vs workpiece
};

// Deviation left at `positions` with `errors` when `offsets` are applied (the exact forward chain).
Deviation deviation(const MachineChain& chain, const AxisPositions& positions, const LocationErrors& errors,
                    const AxisOffsetValues& offsets = {});

struct Compensation {
  AxisOffsetValues offsets;                    // what to add to the axes
  Deviation before;                            // deviation without offsets
  Deviation after;                             // deviation with `offsets` (the non-compensable rest)
  Eigen::Vector3d non_compensable_rotation_urad = Eigen::Vector3d::Zero();  // [µrad] = after.rotation
  double non_compensable_um_per_m = 0.0;       // [µm/m] its magnitude: µm of error per m from the point
  double residual_position_um = 0.0;           // [µm] |after.position|, < 1e-6 when converged
  int iterations = 0;                          // Gauss-Newton iterations used
  bool converged = false;                      // false: offsets are the last iterate, do not send
  std::string message;                         // why not converged, empty otherwise
};

// Offsets of X, Y, Z, tilt and table that cancel the deviation at the workpiece point: position
// completely, rotation in the least-squares sense; the rotation left over is reported.
// Solved by Gauss-Newton on the exact forward chain (the problem is 6 equations, 5 unknowns).
Compensation compensate(const MachineChain& chain, const AxisPositions& positions, const LocationErrors& errors);

// Which LocationErrors field an error output name is: 0..6 for E_X0C, E_Y0C, E_Z0T, E_R0T, E_A0C,
// E_B0C, E_C0C (the order of the struct), -1 for any other name.
int location_error_field(const std::string& output_name);
// Sets field 0..6 (as location_error_field) to `value`; other fields are ignored.
void set_location_error(LocationErrors& errors, int field, double value);
// Whether some name is one of the seven location errors (then offsets can be derived from outputs).
bool maps_any_location_error(const std::vector<std::string>& names);
// The location errors of a vector of outputs named `names` (fields without an output, and
// non-finite values, stay zero).
LocationErrors location_errors_of(const std::vector<std::string>& names, const Eigen::VectorXd& values);

}  // namespace alc::kinematics
