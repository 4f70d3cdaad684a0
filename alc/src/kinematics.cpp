#include "alc/kinematics.hpp"

#include <Eigen/Geometry>
#include <Eigen/QR>
#include <cmath>
#include <numbers>
#include <sstream>

namespace alc::kinematics {
namespace {

constexpr double kUmPerMm = 1000.0;
constexpr double kRadPerDeg = std::numbers::pi / 180.0;
constexpr double kUradPerRad = 1e6;

using Matrix65 = Eigen::Matrix<double, 6, 5>;
using Vector6 = Eigen::Matrix<double, 6, 1>;
using Vector5 = Eigen::Matrix<double, 5, 1>;

Eigen::Matrix3d rotation(const Eigen::Vector3d& axis, double angle_rad) {
  return Eigen::AngleAxisd(angle_rad, axis.normalized()).toRotationMatrix();
}

// Rotation matrix of a rotation vector [rad] (exact form of the small-angle I + [ε]×).
Eigen::Matrix3d rotation_of_vector(const Eigen::Vector3d& v) {
  const double angle = v.norm();
  if (angle == 0.0) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, v / angle).toRotationMatrix();
}

Eigen::Vector3d rotation_vector(const Eigen::Matrix3d& r) {
  const Eigen::AngleAxisd aa(r);
  return aa.axis() * aa.angle();
}

struct Pose {
  Eigen::Vector3d point_um;  // workpiece point, machine frame [µm]
  Eigen::Matrix3d orientation;
};

// Workpiece point and orientation in the machine frame; `with_errors` false gives the nominal chain.
Pose workpiece_pose(const MachineChain& chain, double tilt_rad, double table_rad, const LocationErrors* errors) {
  const Eigen::Vector3d pivot_tilt = chain.tilt.pivot_mm * kUmPerMm;
  const Eigen::Vector3d pivot_table = chain.table.pivot_mm * kUmPerMm;
  const Eigen::Vector3d table_dir = chain.table.direction.normalized();
  Eigen::Vector3d w = chain.workpiece_point_mm * kUmPerMm;
  Eigen::Matrix3d r_err = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t_err = Eigen::Vector3d::Zero();
  if (errors) {
    Eigen::Vector3d radial = w - pivot_table;
    radial -= table_dir * table_dir.dot(radial);
    // A point on the table axis has no radial direction: E_R0T moves it nowhere.
    if (radial.norm() > 1e-9) w += radial.normalized() * errors->r0t_um;
    r_err = rotation_of_vector(Eigen::Vector3d(errors->a0c_um_per_m, errors->b0c_um_per_m, errors->c0c_um_per_m) /
                               kUradPerRad);
    t_err = Eigen::Vector3d(errors->x0c_um, errors->y0c_um, 0.0);
  }
  const Eigen::Matrix3d r_table = rotation(table_dir, table_rad);
  const Eigen::Matrix3d r_tilt = rotation(chain.tilt.direction, tilt_rad);
  const Eigen::Vector3d on_table = r_table * (w - pivot_table);
  const Eigen::Vector3d in_cradle = pivot_table + r_err * on_table + t_err;
  return {pivot_tilt + r_tilt * (in_cradle - pivot_tilt), r_tilt * r_err * r_table};
}

Vector6 residual(const MachineChain& chain, const AxisPositions& positions, const LocationErrors& errors,
                 const AxisOffsetValues& offsets) {
  const double tilt = positions.tilt_deg * kRadPerDeg;
  const double table = positions.table_deg * kRadPerDeg;
  const Pose nominal = workpiece_pose(chain, tilt, table, nullptr);
  const Pose actual = workpiece_pose(chain, tilt + offsets.tilt_urad / kUradPerRad,
                                     table + offsets.table_urad / kUradPerRad, &errors);
  const Eigen::Vector3d tool = nominal.point_um + Eigen::Vector3d(offsets.x_um, offsets.y_um, offsets.z_um) +
                               Eigen::Vector3d(0.0, 0.0, errors.z0t_um);
  Vector6 r;
  r.head<3>() = tool - actual.point_um;
  r.tail<3>() = rotation_vector(nominal.orientation * actual.orientation.transpose()) * kUradPerRad;
  return r;
}

AxisOffsetValues from_vector(const Vector5& u) { return {u(0), u(1), u(2), u(3), u(4)}; }

Deviation to_deviation(const Vector6& r) { return {r.head<3>(), r.tail<3>()}; }

std::string vector_text(const Eigen::Vector3d& v) {
  std::ostringstream s;
  s << "[" << v.x() << ", " << v.y() << ", " << v.z() << "]";
  return s.str();
}

}  // namespace

MachineChain MachineChain::ac_trunnion() { return MachineChain{}; }

MachineChain MachineChain::bc_trunnion() {
  MachineChain chain;
  chain.tilt = {'B', Eigen::Vector3d::UnitY(), Eigen::Vector3d::Zero()};
  return chain;
}

std::string validate(const MachineChain& chain) {
  for (const RotaryAxis* axis : {&chain.tilt, &chain.table}) {
    const std::string which = axis == &chain.tilt ? "tilt" : "table";
    if (!axis->direction.allFinite() || std::abs(axis->direction.norm() - 1.0) > 1e-6)
      return which + " axis direction must be a finite unit vector, got " + vector_text(axis->direction);
    if (!axis->pivot_mm.allFinite()) return which + " axis pivot must be finite, got " + vector_text(axis->pivot_mm);
  }
  if (chain.tilt.name != 'A' && chain.tilt.name != 'B')
    return std::string("tilt axis name must be 'A' or 'B', got '") + chain.tilt.name + "'";
  if (chain.table.name != 'C') return std::string("table axis name must be 'C', got '") + chain.table.name + "'";
  if (chain.tilt.direction.cross(chain.table.direction).norm() < 1e-3)
    return "tilt and table axis directions are parallel: " + vector_text(chain.tilt.direction) + " and " +
           vector_text(chain.table.direction);
  if (!chain.workpiece_point_mm.allFinite())
    return "workpiece point must be finite, got " + vector_text(chain.workpiece_point_mm);
  return {};
}

Deviation deviation(const MachineChain& chain, const AxisPositions& positions, const LocationErrors& errors,
                    const AxisOffsetValues& offsets) {
  return to_deviation(residual(chain, positions, errors, offsets));
}

Compensation compensate(const MachineChain& chain, const AxisPositions& positions, const LocationErrors& errors) {
  constexpr int kMaxIterations = 20;
  constexpr double kStepTolerance = 1e-8;   // [µm] or [µrad]
  constexpr double kDifferenceStep = 1.0;   // [µm] or [µrad] for the numerical Jacobian
  Compensation out;
  Vector5 u = Vector5::Zero();
  Vector6 r = residual(chain, positions, errors, from_vector(u));
  out.before = to_deviation(r);
  for (out.iterations = 1; out.iterations <= kMaxIterations; ++out.iterations) {
    Matrix65 jacobian;
    for (int k = 0; k < 5; ++k) {
      Vector5 plus = u, minus = u;
      plus(k) += kDifferenceStep;
      minus(k) -= kDifferenceStep;
      jacobian.col(k) = (residual(chain, positions, errors, from_vector(plus)) -
                         residual(chain, positions, errors, from_vector(minus))) /
                        (2.0 * kDifferenceStep);
    }
    // Least squares: the linear axes zero the position rows; the rotary axes minimise the rotation.
    const Vector5 step = jacobian.completeOrthogonalDecomposition().solve(-r);
    u += step;
    r = residual(chain, positions, errors, from_vector(u));
    if (!r.allFinite()) break;
    if (step.norm() < kStepTolerance) {
      out.converged = true;
      break;
    }
  }
  out.iterations = std::min(out.iterations, kMaxIterations);
  out.offsets = from_vector(u);
  out.after = to_deviation(r);
  out.non_compensable_rotation_urad = out.after.rotation_urad;
  out.non_compensable_um_per_m = out.after.rotation_urad.norm();
  out.residual_position_um = out.after.position_um.norm();
  if (!out.converged) out.message = "Gauss-Newton did not converge in " + std::to_string(kMaxIterations) + " iterations";
  return out;
}

int location_error_field(const std::string& output_name) {
  static const char* const names[] = {"E_X0C", "E_Y0C", "E_Z0T", "E_R0T", "E_A0C", "E_B0C", "E_C0C"};
  for (int f = 0; f < 7; ++f)
    if (output_name == names[f]) return f;
  return -1;
}

void set_location_error(LocationErrors& e, int field, double value) {
  switch (field) {
    case 0: e.x0c_um = value; break;
    case 1: e.y0c_um = value; break;
    case 2: e.z0t_um = value; break;
    case 3: e.r0t_um = value; break;
    case 4: e.a0c_um_per_m = value; break;
    case 5: e.b0c_um_per_m = value; break;
    case 6: e.c0c_um_per_m = value; break;
    default: break;
  }
}

bool maps_any_location_error(const std::vector<std::string>& names) {
  for (const auto& name : names)
    if (location_error_field(name) >= 0) return true;
  return false;
}

LocationErrors location_errors_of(const std::vector<std::string>& names, const Eigen::VectorXd& values) {
  LocationErrors e;
  for (std::size_t k = 0; k < names.size() && static_cast<Eigen::Index>(k) < values.size(); ++k) {
    const double v = values(static_cast<Eigen::Index>(k));
    if (std::isfinite(v)) set_location_error(e, location_error_field(names[k]), v);
  }
  return e;
}

}  // namespace alc::kinematics
