#include "runtime/nc_emitter.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "nc_interface/jsonl.hpp"
#include "nc_interface/nc_number.hpp"

namespace alc::runtime {

namespace {

// A value as the NC would hold it (nc::as_printed); one the NC cannot be given (not finite, beyond
// ±1e6) as it is, for the safety gate to refuse.
double shown(double v) { return std::isfinite(v) && std::abs(v) <= nc::kMaxNcMagnitude ? nc::as_printed(v) : v; }

// Whether some axis of `a` and `b` differs by at least `resolution`: in the values as computed
// (`as_printed` false), or as the NC receives them (true: nc::as_printed, rounded to 0.0001). An axis
// one leaves out and the other has differs.
bool differs(const nc::AxisOffsets& a, const nc::AxisOffsets& b, double resolution, bool as_printed) {
  const double limit = resolution * (1.0 - 1e-9);
  auto d = [&](double x, double y) {
    return as_printed ? !(std::abs(shown(x) - shown(y)) < limit) : std::abs(x - y) >= limit;
  };
  auto opt = [&](const std::optional<double>& x, const std::optional<double>& y) {
    return x.has_value() != y.has_value() || (x && d(*x, *y));
  };
  return d(a.x_mm, b.x_mm) || d(a.y_mm, b.y_mm) || d(a.z_mm, b.z_mm) || opt(a.a_deg, b.a_deg) ||
         opt(a.b_deg, b.b_deg) || d(a.c_deg, b.c_deg);
}

// The offsets as the NC holds them after `o` is written: every value as printed.
nc::AxisOffsets printed(nc::AxisOffsets o) {
  o.x_mm = shown(o.x_mm);
  o.y_mm = shown(o.y_mm);
  o.z_mm = shown(o.z_mm);
  if (o.a_deg) o.a_deg = shown(*o.a_deg);
  if (o.b_deg) o.b_deg = shown(*o.b_deg);
  o.c_deg = shown(o.c_deg);
  return o;
}

// The largest number of NC ticks (0.0001) within `limit`, as the safety gate counts a change: t ticks
// are within it when t / 1e4 <= limit.
long long ticks_within(double limit) {
  if (!(limit > 0.0)) return 0;
  auto t = static_cast<long long>(std::floor(limit * nc::kNcTicksPerUnit + 1e-6));
  while (t > 0 && static_cast<double>(t) / nc::kNcTicksPerUnit > limit) --t;
  return t;
}

// One step from `from` (as the NC holds it, printed) toward `to`, judged and taken in printed values:
// per axis the printed change is a whole number of NC ticks, at most the budget's (its rounding
// error of 1e-10 forgiven) and at most max_step's as the gate counts them, so the gate never
// refuses a step this chose. An axis whose printed target is within reach gets the target itself
// (it prints as the target does); else the printed value in force plus the ticks it may move.
nc::AxisOffsets step_toward(const nc::AxisOffsets& from, const nc::AxisOffsets& to, const nc::AxisLimits& budget,
                            const nc::AxisLimits& max_step) {
  const auto printable = [](double v) { return std::isfinite(v) && std::abs(v) <= nc::kMaxNcMagnitude; };
  auto move = [&](double x, double y, double allowed, double limit) {
    if (!printable(x) || std::isnan(y)) return y;  // nothing to step from or toward: the gate refuses it
    const long long k = std::min(ticks_within(allowed * (1.0 + 1e-9)), ticks_within(limit));
    const long long a = nc::nc_ticks(x);
    if (printable(y)) {
      const long long d = nc::nc_ticks(y) - a;
      if ((d < 0 ? -d : d) <= k) return y;
      return static_cast<double>(a + (d < 0 ? -k : k)) / nc::kNcTicksPerUnit;
    }
    return static_cast<double>(a + (y < x ? -k : k)) / nc::kNcTicksPerUnit;  // toward a target beyond ±1e6
  };
  nc::AxisOffsets s = to;
  s.x_mm = move(from.x_mm, to.x_mm, budget.x_mm, max_step.x_mm);
  s.y_mm = move(from.y_mm, to.y_mm, budget.y_mm, max_step.y_mm);
  s.z_mm = move(from.z_mm, to.z_mm, budget.z_mm, max_step.z_mm);
  if (to.a_deg) s.a_deg = move(from.a_deg.value_or(0.0), *to.a_deg, budget.a_deg, max_step.a_deg);
  if (to.b_deg) s.b_deg = move(from.b_deg.value_or(0.0), *to.b_deg, budget.b_deg, max_step.b_deg);
  s.c_deg = move(from.c_deg, to.c_deg, budget.c_deg, max_step.c_deg);
  return s;
}

// The members of nc::AxisLimits, for the budget's per-axis arithmetic.
constexpr double nc::AxisLimits::* kAxes[] = {&nc::AxisLimits::x_mm,  &nc::AxisLimits::y_mm,  &nc::AxisLimits::z_mm,
                                             &nc::AxisLimits::a_deg, &nc::AxisLimits::b_deg, &nc::AxisLimits::c_deg};

// |to - from| per axis as printed (an axis either leaves out counts as not moving).
nc::AxisLimits moved(const nc::AxisOffsets& from, const nc::AxisOffsets& to) {
  const auto one = [](double a, double b) { return std::abs(shown(b) - shown(a)); };
  auto opt = [&](const std::optional<double>& a, const std::optional<double>& b) { return a && b ? one(*a, *b) : 0.0; };
  return {one(from.x_mm, to.x_mm), one(from.y_mm, to.y_mm), one(from.z_mm, to.z_mm),
          opt(from.a_deg, to.a_deg), opt(from.b_deg, to.b_deg), one(from.c_deg, to.c_deg)};
}

}  // namespace

NcObserverOptions nc_observer_options(const nc::MachineConfig& config) {
  NcObserverOptions o;
  o.chain = config.chain;
  o.work_offset = config.work_offset;
  o.limits = config.limits;
  return o;
}

NcCommandObserver::NcCommandObserver(const std::vector<std::string>& output_names, NcObserverOptions options)
    : options_(std::move(options)), recorder_(nc::recorder_for(options_.dialect, options_.limits)) {
  if (const std::string e = kinematics::validate(options_.chain); !e.empty())
    throw std::invalid_argument("NC observer: machine chain: " + e);
  if (!(options_.period_s > 0.0)) throw std::invalid_argument("NC observer: period_s must be > 0");
  if (!(options_.resolution > 0.0) || !std::isfinite(options_.resolution))
    throw std::invalid_argument("NC observer: resolution must be finite and > 0");
  // The starting point of the comparison: zero offsets on the axes of this chain.
  last_ = nc::to_axis_offsets(kinematics::Compensation{}, options_.chain, options_.work_offset);
  in_force_ = last_;
  budget_ = options_.limits.max_step;
  maps_any_ = kinematics::maps_any_location_error(output_names);
}

void NcCommandObserver::on_cycle(const Cycle& cycle) { handle(cycle); }

void NcCommandObserver::restore(const State& state) {
  recorder_.set_in_force(state.in_force);
  last_ = state.last;
  // As the NC holds them, printed: a caller may give a command as sent (the supervisor rolls back to
  // the last delivered one, in the values as computed).
  in_force_ = printed(state.in_force);
  behind_ = state.behind;
  next_periodic_s_ = state.next_periodic_s;
  budget_ = state.budget;
  budget_s_ = state.budget_s;
}

void NcCommandObserver::forget_commands() {
  commands_.clear();
  recorder_.clear_log();
}

void NcCommandObserver::handle(const Cycle& cycle) {
  const ControllerOutput& out = cycle.out();
  const double time_s = cycle.time_s();
  const bool probe_cycle = cycle.kind() == Cycle::Kind::Probe;
  bool updated = false;
  for (const ControllerEvent& e : out.events) {
    if (e.type == ControllerEvent::Type::ModelUpdate) updated = true;
    if (e.type != ControllerEvent::Type::ProbeIntervalChange) continue;
    nc::ProbeInterval p;
    if (std::isfinite(e.interval_s)) p.minutes = e.interval_s / 60.0;
    p.time_s = e.time_s;
    emit(p, e.time_s);
  }
  const bool periodic = time_s >= next_periodic_s_;
  if (!(probe_cycle || updated || periodic || behind_) || !maps_any_) return;
  if (probe_cycle || updated || periodic) next_periodic_s_ = time_s + options_.period_s;

  const kinematics::Compensation* computed = cycle.compensation();
  if (computed == nullptr) throw std::logic_error("NC observer: the driver has no machine to compensate with");
  const kinematics::Compensation& c = *computed;
  if (!c.converged) {
    ++not_converged_;
    return;
  }
  // What no axis can cancel (for an A-C table E_B0C): recorded on the command, never dropped.
  max_non_compensable_um_per_m_ = std::max(max_non_compensable_um_per_m_, c.non_compensable_um_per_m);
  // The target carries c.non_compensable_um_per_m, and so does every step toward it.
  const nc::AxisOffsets target = nc::to_axis_offsets(c, options_.chain, options_.work_offset);
  // Approach the target in steps drawn from the budget, one per controller cycle while behind: the
  // budget refills at max_step per step_period_s of scenario time, up to max_step, so samples 1 ms
  // apart move the offsets no faster than samples a minute apart. A step too small for the NC waits.
  refill(time_s);
  nc::AxisOffsets request = step_toward(in_force_, target, budget_, options_.limits.max_step);
  // Stepping goes on until the request prints as the target does. A request is emitted when it
  // differs from the last one by the resolution as computed, or, while stepping (this step falls short
  // of the target, or the one before did), when it prints differently: a step is a whole number of
  // NC ticks from the printed value in force, which can be less than one tick from the last request
  // as computed, and the last step must not stop a tick short of the target.
  const bool was_behind = behind_;
  behind_ = differs(request, target, options_.resolution, true);
  if (!differs(request, last_, options_.resolution, false) &&
      !((behind_ || was_behind) && differs(request, last_, options_.resolution, true)))
    return;
  request.time_s = time_s;
  last_ = request;
  const nc::SafetyDecision d = emit(request, time_s);
  if (d.verdict == nc::SafetyVerdict::Refused) {
    behind_ = false;  // wait for the next regular moment instead of repeating a refusal each cycle
  } else {
    const nc::AxisLimits used = moved(in_force_, d.to_send.back());
    for (const auto axis : kAxes) budget_.*axis = std::max(0.0, budget_.*axis - used.*axis);
    in_force_ = nc::held_after(in_force_, d.to_send.back());  // what the NC holds: the values as printed
  }
}

void NcCommandObserver::refill(double time_s) {
  const double since_s = time_s - budget_s_;
  budget_s_ = std::max(budget_s_, time_s);
  if (!(since_s > 0.0)) return;
  const double share = since_s / options_.limits.step_period_s;  // +inf before the first refill
  for (const auto axis : kAxes)
    budget_.*axis = std::min(options_.limits.max_step.*axis, budget_.*axis + share * options_.limits.max_step.*axis);
}

nc::SafetyDecision NcCommandObserver::emit(const nc::NcCommand& command, double time_s) {
  const nc::SafetyDecision d = recorder_.record(command);
  commands_.push_back(command);
  const bool accepted = d.verdict != nc::SafetyVerdict::Refused;
  if (!accepted) ++refused_;
  if (!history_ || history_->writer == nullptr) return d;
  storage::NcCommandRecord r;
  r.run_id = history_->run;
  r.time_s = time_s;
  r.kind = std::holds_alternative<nc::AxisOffsets>(command) ? "offsets" : "probe_interval";
  r.sink = history_->sink;
  r.accepted = accepted;
  if (accepted) {
    // What the NC receives: the program of the command's steps (one, or several when split).
    if (std::holds_alternative<nc::AxisOffsets>(command)) {
      r.text = nc::write_program(history_->dialect,
                                 std::vector<nc::NcCommand>(d.to_send.begin(), d.to_send.end()), history_->options);
    } else {
      r.text = nc::write_program(history_->dialect, {command}, history_->options);
    }
    if (d.verdict == nc::SafetyVerdict::Split) r.message = d.message;
  } else {
    // Nothing was sent: keep the request as a JSON line and why the gate refused it.
    r.text = nc::to_json_line(command);
    r.message = d.message;
  }
  history_->writer->add(r);
  return d;
}

}  // namespace alc::runtime
