#include "nc_interface/commands.hpp"

#include <numbers>
#include <stdexcept>

namespace alc::nc {

std::string work_offset_name(int work_offset) {
  if (work_offset < kMinWorkOffset || work_offset > kMaxWorkOffset)
    throw std::invalid_argument("work offset must be 1 (G54) … 6 (G59), got " + std::to_string(work_offset));
  std::string name = "G";  // (not "G" + …: GCC 12 -Wrestrict false positive)
  name += std::to_string(53 + work_offset);
  return name;
}

std::optional<int> parse_work_offset(const std::string& text) {
  for (int k = kMinWorkOffset; k <= kMaxWorkOffset; ++k)
    if (text == work_offset_name(k)) return k;
  return std::nullopt;
}

AxisOffsets to_axis_offsets(const kinematics::Compensation& compensation, const kinematics::MachineChain& chain,
                            int work_offset) {
  constexpr double kDegPerUrad = 180.0 / std::numbers::pi * 1e-6;
  AxisOffsets out;
  out.x_mm = compensation.offsets.x_um / 1000.0;
  out.y_mm = compensation.offsets.y_um / 1000.0;
  out.z_mm = compensation.offsets.z_um / 1000.0;
  const double tilt_deg = compensation.offsets.tilt_urad * kDegPerUrad;
  if (chain.tilt.name == 'B') {
    out.a_deg.reset();
    out.b_deg = tilt_deg;
  } else {
    out.a_deg = tilt_deg;
  }
  out.c_deg = compensation.offsets.table_urad * kDegPerUrad;
  out.work_offset = work_offset;
  out.non_compensable_um_per_m = compensation.non_compensable_um_per_m;
  return out;
}

}  // namespace alc::nc
