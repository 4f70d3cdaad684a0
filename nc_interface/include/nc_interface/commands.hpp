#pragma once
// NC commands as values: what the controller decided, before any dialect turns it into text
// (the idea of LinuxCNC's canonical machining commands, docs/design.md "Module map").
#include <optional>
#include <string>
#include <variant>

#include "alc/kinematics.hpp"

namespace alc::nc {

// Work offsets the commands may target: 1 = G54 … 6 = G59 (every dialect has these six; on a
// Sinumerik they are the settable frames $P_UIFR[1…6], selected by G54…G57, G505, G506).
inline constexpr int kMinWorkOffset = 1;
inline constexpr int kMaxWorkOffset = 6;

// "G54" for 1 … "G59" for 6; throws std::invalid_argument for anything else.
std::string work_offset_name(int work_offset);
// 1 for "G54" … 6 for "G59" (exact text); std::nullopt for anything else.
std::optional<int> parse_work_offset(const std::string& text);

// Thermal compensation offsets: added to the base of the work offset `work_offset`.
// Values are totals (what the offset should be now), not increments. An A–C machine leaves
// b_deg empty, a B–C machine leaves a_deg empty; an empty axis is not written to the NC.
struct AxisOffsets {
  double x_mm = 0.0;                 // [mm]
  double y_mm = 0.0;                 // [mm]
  double z_mm = 0.0;                 // [mm]
  std::optional<double> a_deg = 0.0; // [°]
  std::optional<double> b_deg;       // [°]
  double c_deg = 0.0;                // [°]
  int work_offset = 1;               // 1 = G54 … 6 = G59
  std::optional<double> time_s;      // [s] when it was decided (for the record; never written to NC)
  // [µm/m] the part of the error these offsets cannot cancel (kinematics::Compensation::
  // non_compensable_um_per_m of the compensation they were computed from), >= 0. For the record,
  // never written to NC; empty when unknown (e.g. a command written by hand).
  std::optional<double> non_compensable_um_per_m;
  bool operator==(const AxisOffsets&) const = default;
};

// Change of the probing interval that the part program's probing macro reads.
struct ProbeInterval {
  std::optional<double> minutes;     // [min] > 0; empty = never probe again (written as 0)
  std::optional<double> time_s;      // [s] when it was decided (for the record; never written to NC)
  bool operator==(const ProbeInterval&) const = default;
};

using NcCommand = std::variant<AxisOffsets, ProbeInterval>;

// Axis offsets that realise a kinematic compensation (µm → mm, µrad → °), with the compensation's
// non-compensable part in non_compensable_um_per_m.
AxisOffsets to_axis_offsets(const kinematics::Compensation& compensation, const kinematics::MachineChain& chain,
                            int work_offset = 1);

}  // namespace alc::nc
