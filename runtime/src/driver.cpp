#include "runtime/driver.hpp"

#include <algorithm>
#include <chrono>

#include "common/log.hpp"
#include "probing/schedule.hpp"

namespace alc::runtime {

namespace {
double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// The events told at info level, of a sample or a probe alike: phase changes, rejected models, the
// guard's decisions.
bool told_at_info(const ControllerEvent& e) {
  return e.type == ControllerEvent::Type::PhaseChange || e.type == ControllerEvent::Type::ModelRejected ||
         e.type == ControllerEvent::Type::Guard;
}

// One of them, the phase change with its phases, the guard's decision with its output.
void log_event(const ControllerEvent& e) {
  std::string what = e.output.empty() ? "" : e.output + ": ";
  if (e.type == ControllerEvent::Type::PhaseChange)
    what = std::string(to_string(e.from)) + " -> " + std::string(to_string(e.to)) + ": ";
  log::get("runtime")->info("t = {} s: {}: {}{}", e.time_s, to_string(e.type), what, e.reason);
}
}  // namespace

Cycle::Cycle(Kind kind, const Sample& sample, const ProbeMeasurement* probe, const ControllerOutput& out,
             const Controller& controller, Phase phase_before, const CompensationSetup* setup)
    : kind_(kind), sample_(sample), probe_(probe), out_(out), controller_(controller), phase_before_(phase_before),
      setup_(setup) {}

const kinematics::Compensation* Cycle::compensation() const {
  if (!computed_) {
    computed_ = true;
    if (setup_)
      compensation_ = kinematics::compensate(
          setup_->chain, setup_->pose, kinematics::location_errors_of(controller_.output_names(), out_.prediction));
  }
  return compensation_ ? &*compensation_ : nullptr;
}

Driver::Driver(Controller& controller)
    : controller_(controller), maps_any_(kinematics::maps_any_location_error(controller.output_names())) {}

void Driver::set_machine(CompensationSetup setup) {
  if (const std::string e = kinematics::validate(setup.chain); !e.empty())
    throw std::invalid_argument("driver: machine chain: " + e);
  setup_ = std::move(setup);
}

void Driver::notify(Cycle::Kind kind, const ProbeMeasurement* probe, const ControllerOutput& out, Phase before) {
  const Cycle cycle(kind, *last_, probe, out, controller_, before, setup_ && maps_any_ ? &*setup_ : nullptr);
  for (Observer* o : observers_) o->on_cycle(cycle);
}

ControllerOutput Driver::sample(const Sample& sample) {
  const Phase before = controller_.phase();
  const auto start = std::chrono::steady_clock::now();
  ControllerOutput out = controller_.on_sample(sample.time_s, sample.inputs);
  if (out.fit) identification_s_ += seconds_since(start);
  if (!out.accepted) {
    // A dead sensor sets aside every sample for hours: the first ones are told at warn, the rest at
    // debug (the replay gives their count at its end; the supervisor counts and publishes each).
    if (rejected_samples_ == 0) first_rejected_sample_ = "sample " + std::to_string(sample.index) + ": " + out.reason;
    const bool loud = ++rejected_samples_ <= kSamplesToldAtWarn;
    log::get("runtime")->log(loud ? spdlog::level::warn : spdlog::level::debug, "sample {} rejected: {}{}", sample.index,
                             out.reason,
                             rejected_samples_ == kSamplesToldAtWarn ? " (later rejected samples at log level debug)" : "");
    for (Observer* o : observers_) o->on_rejected(sample, nullptr, out.reason);
    return out;
  }
  last_ = sample;
  tell(out);
  notify(Cycle::Kind::Sample, nullptr, out, before);
  return out;
}

ControllerOutput Driver::probe(const ProbeMeasurement& probe) {
  const Phase before = controller_.phase();
  const auto start = std::chrono::steady_clock::now();
  ControllerOutput out = controller_.on_probe(probe);
  if (out.fit) identification_s_ += seconds_since(start);
  if (!out.accepted || !last_) {
    log::get("runtime")->warn("probe at t = {} s rejected: {}", probe.time_s, out.reason);
    const Sample none{};
    for (Observer* o : observers_) o->on_rejected(last_ ? *last_ : none, &probe, out.reason);
    return out;
  }
  tell(out);
  notify(Cycle::Kind::Probe, &probe, out, before);
  return out;
}

ControllerOutput Driver::request(double time_s, const std::string& reason) {
  const Phase before = controller_.phase();
  ControllerOutput out;
  // Observers see a cycle at the latest sample: a caller asks after one (nothing changes here before).
  if (last_) {
    out = controller_.request_probe(time_s, reason);
  } else {
    out.accepted = false;
    out.reason = "probe requested before a sample reached this driver";
  }
  if (!out.accepted) {
    log::get("runtime")->warn("probe request at t = {} s rejected: {}", time_s, out.reason);
    return out;
  }
  // Someone asked: told at info whatever it changed.
  log::get("runtime")->info("t = {} s: probe requested: {}{}", time_s, reason,
                            out.events.empty() ? " (a probe is due already)" : "");
  notify(Cycle::Kind::Request, nullptr, out, before);
  return out;
}

void Driver::tell(const ControllerOutput& out) {
  for (const ControllerEvent& e : out.events) {
    if (e.type == ControllerEvent::Type::ModelRejected) last_rejected_fit_ = e.reason;
    // A sensor fault is told once per output at warn (it may last for every probe of the run).
    const bool first_fault = e.type == ControllerEvent::Type::Implausible &&
                             std::find(implausible_logged_.begin(), implausible_logged_.end(), e.output) ==
                                 implausible_logged_.end();
    if (first_fault) implausible_logged_.push_back(e.output);
    if (told_at_info(e)) {
      log_event(e);
      continue;
    }
    log::get("runtime")->log(first_fault ? spdlog::level::warn : spdlog::level::debug, "t = {} s: {}: {}{}", e.time_s,
                             to_string(e.type), e.reason,
                             first_fault ? " (later readings of " + e.output + " set aside: log level debug)" : "");
  }
}

void Driver::sample_done() {
  if (!last_) return;
  for (Observer* o : observers_) o->on_sample_done(*last_, controller_, last_->index + 1);
}

std::size_t Driver::run(Source& source, double stop_time_s) {
  std::size_t taken = 0;
  while (auto s = source.next(stop_time_s)) {
    ++taken;
    const double before_s = controller_.state().started ? controller_.state().now_s : -kInf;
    const ControllerOutput out = sample(*s);
    if (!out.accepted) continue;
    // Within the due tolerance, as the controller's own due times (a time computed from hours).
    for (const auto& [at_s, reason] : requests_)
      if (!probing::reached(before_s, at_s) && probing::reached(s->time_s, at_s)) request(s->time_s, reason);
    if (auto p = source.probe(controller_.state().next_probe_due_s, *s)) probe(*p);
    sample_done();
  }
  return taken;
}

}  // namespace alc::runtime
