#include "nc_interface/safety.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "nc_interface/nc_number.hpp"

namespace alc::nc {
namespace {

struct AxisValue {
  char axis;
  double value;      // [mm] or [°]
  double max_offset; // [mm] or [°]
  double max_step;   // [mm] or [°]
  const char* unit;
};

std::vector<AxisValue> axes(const SafetyLimits& l, const AxisOffsets& o) {
  std::vector<AxisValue> v{{'X', o.x_mm, l.max_offset.x_mm, l.max_step.x_mm, "mm"},
                           {'Y', o.y_mm, l.max_offset.y_mm, l.max_step.y_mm, "mm"},
                           {'Z', o.z_mm, l.max_offset.z_mm, l.max_step.z_mm, "mm"},
                           {'A', o.a_deg.value_or(0.0), l.max_offset.a_deg, l.max_step.a_deg, "deg"},
                           {'B', o.b_deg.value_or(0.0), l.max_offset.b_deg, l.max_step.b_deg, "deg"},
                           {'C', o.c_deg, l.max_offset.c_deg, l.max_step.c_deg, "deg"}};
  return v;
}

std::optional<double> blend(const std::optional<double>& from, const std::optional<double>& to, double f) {
  if (!to) return std::nullopt;
  return from.value_or(0.0) + (*to - from.value_or(0.0)) * f;
}

std::string show(double v) {
  return std::isfinite(v) && std::abs(v) <= kMaxNcMagnitude ? format_nc_number(v) : std::to_string(v);
}

// "G55", or "work offset N" for a number outside G54…G59 (the gate itself does not validate).
std::string name_of(int work_offset) {
  if (work_offset >= kMinWorkOffset && work_offset <= kMaxWorkOffset) return work_offset_name(work_offset);
  return "work offset " + std::to_string(work_offset);
}

}  // namespace

std::string validate(const SafetyLimits& limits) {
  const AxisOffsets zero;
  for (const AxisValue& a : axes(limits, zero)) {
    if (!(a.max_offset > 0.0) || !std::isfinite(a.max_offset))
      return std::string("max_offset of axis ") + a.axis + " must be > 0 and finite, got " + std::to_string(a.max_offset);
    if (!(a.max_step > 0.0) || !std::isfinite(a.max_step))
      return std::string("max_step of axis ") + a.axis + " must be > 0 and finite, got " + std::to_string(a.max_step);
  }
  if (limits.max_split_steps < 1 || limits.max_split_steps > 1000)
    return "max_split_steps must be 1…1000, got " + std::to_string(limits.max_split_steps);
  return {};
}

std::string_view verdict_name(SafetyVerdict verdict) {
  switch (verdict) {
    case SafetyVerdict::Accepted: return "accepted";
    case SafetyVerdict::Split: return "split";
    case SafetyVerdict::Refused: return "refused";
  }
  return "?";
}

SafetyDecision check_offsets(const SafetyLimits& limits, const AxisOffsets& current, const AxisOffsets& requested) {
  SafetyDecision d;
  d.requested = requested;
  const auto want = axes(limits, requested);
  const auto now = axes(limits, current);
  bool offset_broken = false;
  double worst_ratio = 0.0;  // largest |change| / max_step
  for (std::size_t i = 0; i < want.size(); ++i) {
    const AxisValue& a = want[i];
    if (std::abs(a.value) > a.max_offset) {
      d.violations.push_back({a.axis, "max_offset", a.value, a.max_offset});
      offset_broken = true;
    }
    const double change = a.value - now[i].value;
    if (std::abs(change) > a.max_step) d.violations.push_back({a.axis, "max_step", change, a.max_step});
    worst_ratio = std::max(worst_ratio, std::abs(change) / a.max_step);
  }
  // Steps of exactly max_step count as within the limit; 1e-9 absorbs the division's rounding.
  const int steps = std::max(1, static_cast<int>(std::ceil(worst_ratio - 1e-9)));
  if (d.violations.empty()) {
    d.verdict = SafetyVerdict::Accepted;
    d.to_send = {requested};
  } else if (!offset_broken && limits.on_step_violation == StepAction::Split && steps <= limits.max_split_steps) {
    d.verdict = SafetyVerdict::Split;
    for (int k = 1; k <= steps; ++k) {
      const double f = static_cast<double>(k) / steps;
      AxisOffsets s = requested;
      s.x_mm = current.x_mm + (requested.x_mm - current.x_mm) * f;
      s.y_mm = current.y_mm + (requested.y_mm - current.y_mm) * f;
      s.z_mm = current.z_mm + (requested.z_mm - current.z_mm) * f;
      s.a_deg = blend(current.a_deg, requested.a_deg, f);
      s.b_deg = blend(current.b_deg, requested.b_deg, f);
      s.c_deg = current.c_deg + (requested.c_deg - current.c_deg) * f;
      d.to_send.push_back(k == steps ? requested : s);
    }
  } else {
    d.verdict = SafetyVerdict::Refused;
  }
  d.message = std::string(verdict_name(d.verdict));
  if (d.verdict == SafetyVerdict::Split) d.message += " into " + std::to_string(d.to_send.size()) + " steps";
  if (d.verdict == SafetyVerdict::Refused && !offset_broken && limits.on_step_violation == StepAction::Split)
    d.message += " (would need " + std::to_string(steps) + " steps, max_split_steps " +
                 std::to_string(limits.max_split_steps) + ")";
  for (const LimitViolation& v : d.violations) {
    const char* unit = (v.axis == 'X' || v.axis == 'Y' || v.axis == 'Z') ? " mm" : " deg";
    d.message += std::string("; axis ") + v.axis + (v.limit == "max_offset" ? " offset " : " change ") +
                 show(v.value) + unit + " exceeds " + v.limit + " " + show(v.limit_value) + unit;
  }
  return d;
}

SafetyGate::SafetyGate(SafetyLimits limits, OffsetRegisters registers) : limits_(limits), registers_(registers) {}

int SafetyGate::register_of(int work_offset) const {
  return registers_ == OffsetRegisters::Single ? 0 : work_offset;
}

AxisOffsets SafetyGate::current(int work_offset) const {
  const auto it = current_.find(register_of(work_offset));
  if (it != current_.end()) return it->second;
  AxisOffsets zero;
  zero.work_offset = work_offset;
  return zero;
}

void SafetyGate::set_in_force(const AxisOffsets& offsets) {
  if (registers_ == OffsetRegisters::Single) {
    if (in_force_work_offset_ && *in_force_work_offset_ != offsets.work_offset)
      throw std::invalid_argument("the NC has one offset register for every work offset, so the offsets in force "
                                  "are one set: given for " + name_of(*in_force_work_offset_) + " and " +
                                  name_of(offsets.work_offset));
    in_force_work_offset_ = offsets.work_offset;
  }
  current_[register_of(offsets.work_offset)] = offsets;
}

SafetyDecision SafetyGate::submit(const AxisOffsets& requested) {
  const AxisOffsets from = current(requested.work_offset);
  SafetyDecision d = check_offsets(limits_, from, requested);
  if (d.verdict != SafetyVerdict::Accepted && from.work_offset != requested.work_offset)
    d.message += "; judged against the offsets of " + name_of(from.work_offset) +
                 " (one offset register for every work offset)";
  if (d.verdict != SafetyVerdict::Refused) current_[register_of(requested.work_offset)] = requested;
  return d;
}

}  // namespace alc::nc
