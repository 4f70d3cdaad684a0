#include "nc_interface/safety.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "common/number_text.hpp"
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

// A value as the NC would print it; a limit that is not a multiple of the resolution in full.
std::string show(double v) {
  if (!std::isfinite(v) || std::abs(v) > kMaxNcMagnitude) return common::shortest_text(v);
  return as_printed(v) == v ? format_nc_number(v) : common::shortest_text(v);
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
      return std::string("max_offset of axis ") + a.axis + " must be > 0 and finite, got " + common::shortest_text(a.max_offset);
    if (!(a.max_step > 0.0) || !std::isfinite(a.max_step))
      return std::string("max_step of axis ") + a.axis + " must be > 0 and finite, got " + common::shortest_text(a.max_step);
    // Below one tick of the NC (0.0001) every step the NC can take is refused: that axis would stay at
    // zero for ever, without a word but the refusals.
    if (a.max_step < 1.0 / kNcTicksPerUnit)
      return std::string("max_step of axis ") + a.axis + " must be at least the NC resolution 0.0001, got " +
             common::shortest_text(a.max_step);
    if (a.max_offset < 1.0 / kNcTicksPerUnit)
      return std::string("max_offset of axis ") + a.axis + " must be at least the NC resolution 0.0001, got " +
             common::shortest_text(a.max_offset);
    // A thermal compensation of a metre is no limit; bounded, base (±1e5) + offset always prints.
    if (a.max_offset > kMaxCompensation)
      return std::string("max_offset of axis ") + a.axis + " must be at most 1000 (mm or deg), got " +
             common::shortest_text(a.max_offset);
    if (a.max_step > kMaxCompensation)
      return std::string("max_step of axis ") + a.axis + " must be at most 1000 (mm or deg), got " +
             common::shortest_text(a.max_step);
  }
  if (!(limits.step_period_s > 0.0) || !std::isfinite(limits.step_period_s))
    return "step_period_s must be > 0 and finite, got " + common::shortest_text(limits.step_period_s);
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

namespace {

bool printable(const AxisOffsets& o) {
  for (const std::optional<double>& v : {std::optional<double>(o.x_mm), std::optional<double>(o.y_mm),
                                         std::optional<double>(o.z_mm), o.a_deg, o.b_deg, std::optional<double>(o.c_deg)})
    if (v && (!std::isfinite(*v) || std::abs(*v) > kMaxNcMagnitude)) return false;
  return true;
}

// The largest number of NC ticks (0.0001) whose value is within `limit`.
long long ticks_within(double limit) {
  auto t = static_cast<long long>(std::floor(limit * kNcTicksPerUnit + 1e-6));
  while (t > 0 && static_cast<double>(t) / kNcTicksPerUnit > limit) --t;
  return t;
}

// from + (to - from) * k / n in ticks, truncated towards from: consecutive k differ by at most
// ceil(|to - from| / n) ticks.
double tick_between(double from, double to, int k, int n) {
  const long long a = nc_ticks(from), d = nc_ticks(to) - a;
  const long long part = (d < 0 ? -d : d) * k / n;
  return static_cast<double>(a + (d < 0 ? -part : part)) / kNcTicksPerUnit;
}

}  // namespace

AxisOffsets held_after(const AxisOffsets& current, const AxisOffsets& written) {
  AxisOffsets h = written;
  h.x_mm = as_printed(written.x_mm);
  h.y_mm = as_printed(written.y_mm);
  h.z_mm = as_printed(written.z_mm);
  h.a_deg = written.a_deg ? std::optional<double>(as_printed(*written.a_deg)) : current.a_deg;
  h.b_deg = written.b_deg ? std::optional<double>(as_printed(*written.b_deg)) : current.b_deg;
  h.c_deg = as_printed(written.c_deg);
  return h;
}

SafetyDecision check_offsets(const SafetyLimits& limits, const AxisOffsets& current, const AxisOffsets& requested) {
  SafetyDecision d;
  d.requested = requested;
  if (!printable(requested) || !printable(current)) {
    d.verdict = SafetyVerdict::Refused;
    d.message = "refused; an offset is not finite or beyond ±1e6, which the NC cannot be given";
    return d;
  }
  // Judged: what the NC holds now and after the command, per axis, as printed.
  const AxisOffsets now_held = held_after(current, current);
  const AxisOffsets then_held = held_after(now_held, requested);
  const auto want = axes(limits, then_held);
  const auto now = axes(limits, now_held);
  bool offset_broken = false;
  bool unsplittable = false;  // a change on an axis whose max_step is below the NC resolution
  // Offsets in force beyond max_offset (given so, e.g. by --in-force): the steps of a split would
  // start there, beyond max_offset too, so a split is refused (an operator sets them back by hand).
  std::string in_force_beyond;
  int steps = 1;
  for (std::size_t i = 0; i < want.size(); ++i) {
    const AxisValue& a = want[i];
    if (std::abs(now[i].value) > a.max_offset && in_force_beyond.empty())
      in_force_beyond = std::string(" (the offset in force on axis ") + a.axis + ", " + show(now[i].value) +
                        ", is beyond max_offset " + show(a.max_offset) + ": steps from it would be too)";
    if (std::abs(a.value) > a.max_offset) {
      d.violations.push_back({a.axis, "max_offset", a.value, a.max_offset});
      offset_broken = true;
    }
    const long long change_ticks = nc_ticks(a.value) - nc_ticks(now[i].value);
    const double change = static_cast<double>(change_ticks) / kNcTicksPerUnit;
    if (std::abs(change) > a.max_step) d.violations.push_back({a.axis, "max_step", change, a.max_step});
    if (change_ticks == 0) continue;
    const long long per_step = ticks_within(a.max_step);
    if (per_step == 0) {
      unsplittable = true;
      continue;
    }
    const long long magnitude = change_ticks < 0 ? -change_ticks : change_ticks;
    steps = static_cast<int>(std::min<long long>(std::max<long long>(steps, (magnitude + per_step - 1) / per_step), 1000000));
  }
  if (d.violations.empty()) {
    d.verdict = SafetyVerdict::Accepted;
    d.to_send = {requested};
  } else if (!offset_broken && !unsplittable && in_force_beyond.empty() &&
             limits.on_step_violation == StepAction::Split && steps <= limits.max_split_steps) {
    d.verdict = SafetyVerdict::Split;
    // Every step as printed, so that each printed change is within max_step; an axis the request
    // leaves out stays out (the NC keeps it).
    for (int k = 1; k <= steps; ++k) {
      AxisOffsets s = requested;
      s.x_mm = tick_between(now_held.x_mm, then_held.x_mm, k, steps);
      s.y_mm = tick_between(now_held.y_mm, then_held.y_mm, k, steps);
      s.z_mm = tick_between(now_held.z_mm, then_held.z_mm, k, steps);
      if (requested.a_deg) s.a_deg = tick_between(now_held.a_deg.value_or(0.0), *then_held.a_deg, k, steps);
      if (requested.b_deg) s.b_deg = tick_between(now_held.b_deg.value_or(0.0), *then_held.b_deg, k, steps);
      s.c_deg = tick_between(now_held.c_deg, then_held.c_deg, k, steps);
      d.to_send.push_back(s);
    }
  } else {
    d.verdict = SafetyVerdict::Refused;
  }
  d.message = std::string(verdict_name(d.verdict));
  if (d.verdict == SafetyVerdict::Split) d.message += " into " + std::to_string(d.to_send.size()) + " steps";
  if (d.verdict == SafetyVerdict::Refused && !offset_broken && limits.on_step_violation == StepAction::Split)
    d.message += unsplittable               ? std::string(" (max_step is below the NC resolution 0.0001)")
                 : !in_force_beyond.empty() ? in_force_beyond
                                            : " (would need " + std::to_string(steps) + " steps, max_split_steps " +
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
  // What the NC holds afterwards: the values as printed, an axis left out keeps its value.
  if (d.verdict != SafetyVerdict::Refused) current_[register_of(requested.work_offset)] = held_after(from, requested);
  return d;
}

}  // namespace alc::nc
