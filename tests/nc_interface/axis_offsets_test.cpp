// nc::to_axis_offsets: a kinematic compensation turned into an axis offset command (units, axes).
#include <catch2/catch.hpp>

#include <numbers>

#include "alc/kinematics.hpp"
#include "nc_interface/commands.hpp"

using namespace alc::kinematics;
using Catch::Matchers::WithinAbs;

namespace {
constexpr double kDegPerRad = 180.0 / std::numbers::pi;
}  // namespace

TEST_CASE("kinematics: compensation to axis offset command (um -> mm, urad -> deg)", "[kinematics]") {
  constexpr double kTolDeg = 1e-12;  // [°]
  LocationErrors err;
  err.c0c_um_per_m = 30.0;
  err.x0c_um = 12.0;
  const Compensation ac = compensate(MachineChain::ac_trunnion(), {0.0, 0.0}, err);
  const alc::nc::AxisOffsets o = alc::nc::to_axis_offsets(ac, MachineChain::ac_trunnion(), 2);
  REQUIRE_THAT(o.c_deg, WithinAbs(-30e-6 * kDegPerRad, kTolDeg));
  REQUIRE_THAT(o.x_mm, WithinAbs(ac.offsets.x_um / 1000.0, 1e-15));
  REQUIRE(o.a_deg.has_value());
  REQUIRE_FALSE(o.b_deg.has_value());
  REQUIRE(o.work_offset == 2);
  const Compensation bc = compensate(MachineChain::bc_trunnion(), {10.0, 0.0}, err);
  const alc::nc::AxisOffsets ob = alc::nc::to_axis_offsets(bc, MachineChain::bc_trunnion());
  REQUIRE_FALSE(ob.a_deg.has_value());
  REQUIRE(ob.b_deg.has_value());
}
