#pragma once
// The one driver loop that replay, parameter study and supervisor share.
//
// A Source gives input samples in time order and takes the probe cycles that the controller asks
// for (a recording: the first recorded measurement at or after the due time; the twin: its truth
// seen through its probe; a live machine: the NC's probe cycle). Observers (indicators, history,
// NC emission, ...) plug in and see every cycle through a Cycle context. The driver is also a cycle
// API (sample(), probe(), sample_done()) for a caller that is driven by events instead of a loop:
// the supervisor pushes what arrives from its bus.
//
// No I/O here: the observers that write (history, NC files) are given their sinks by the caller.
#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "alc/controller.hpp"
#include "alc/kinematics.hpp"

namespace alc::runtime {

// One input sample of a source.
struct Sample {
  std::int64_t index = 0;        // position in the source (a recording's row)
  double time_s = 0.0;           // [s]
  Eigen::VectorXd inputs;        // one value per input name of the controller
};

class Source {
 public:
  virtual ~Source() = default;
  // The next sample if its time is before `before_s` (it is consumed), else nullopt (it stays).
  virtual std::optional<Sample> next(double before_s) = 0;
  // The probe cycle due at `due_s` if it is taken at `sample` (the latest sample the controller accepted),
  // else nullopt.
  virtual std::optional<ProbeMeasurement> probe(double due_s, const Sample& sample) = 0;
};

// Where the prediction is turned into axis offsets: the machine chain at the reference pose.
struct CompensationSetup {
  kinematics::MachineChain chain = kinematics::MachineChain::ac_trunnion();
  kinematics::AxisPositions pose{};          // reference pose: tilt 0°, table 0°
};

// What an observer sees of one controller cycle.
class Cycle {
 public:
  enum class Kind { Sample, Probe, Request };  // Request: a probe asked for (Controller::request_probe)
  Cycle(Kind kind, const Sample& sample, const ProbeMeasurement* probe, const ControllerOutput& out,
        const Controller& controller, Phase phase_before, const CompensationSetup* setup);
  Kind kind() const { return kind_; }
  const Sample& sample() const { return sample_; }            // the latest sample
  const ProbeMeasurement* probe() const { return probe_; }    // probe cycles only
  const ControllerOutput& out() const { return out_; }
  const Controller& controller() const { return controller_; }
  Phase phase_before() const { return phase_before_; }        // the phase when the cycle began
  double time_s() const { return probe_ ? probe_->time_s : sample_.time_s; }
  // The compensation of out().prediction at the reference pose of the driver's machine, computed at
  // most once per cycle, whoever asks first; nullptr without a machine or without an output named
  // as one of the seven C-axis location errors.
  const kinematics::Compensation* compensation() const;
  const CompensationSetup* machine() const { return setup_; }

 private:
  Kind kind_;
  const Sample& sample_;
  const ProbeMeasurement* probe_;
  const ControllerOutput& out_;
  const Controller& controller_;
  Phase phase_before_;
  const CompensationSetup* setup_;       // nullptr: no machine, or no output is a location error
  mutable bool computed_ = false;
  mutable std::optional<kinematics::Compensation> compensation_;
};

class Observer {
 public:
  virtual ~Observer() = default;
  // After each accepted controller cycle (a sample, a probe, or a probe asked for).
  virtual void on_cycle(const Cycle& /*cycle*/) {}
  // After a sample and the probe it led to: a consistent point (e.g. to save a snapshot).
  // `next_index` is the source index to continue from.
  virtual void on_sample_done(const Sample& /*sample*/, const Controller& /*controller*/,
                              std::int64_t /*next_index*/) {}
  // A sample (probe == nullptr) or probe the controller rejected; nothing changed.
  virtual void on_rejected(const Sample& /*sample*/, const ProbeMeasurement* /*probe*/,
                           const std::string& /*reason*/) {}
};

class Driver {
 public:
  explicit Driver(Controller& controller);
  void add(Observer& observer) { observers_.push_back(&observer); }
  // Offsets are derived from predictions at this machine's reference pose (Cycle::compensation()).
  void set_machine(CompensationSetup setup);
  bool has_machine() const { return setup_.has_value(); }
  const CompensationSetup* machine() const { return setup_ ? &*setup_ : nullptr; }

  // Cycle API. sample(), probe() and request() return the controller's output (also when rejected).
  ControllerOutput sample(const Sample& sample);
  ControllerOutput probe(const ProbeMeasurement& probe);
  // A probe asked for at `time_s` (Controller::request_probe), after an accepted sample; observers see
  // a Request cycle at the latest sample.
  ControllerOutput request(double time_s, const std::string& reason);
  void sample_done();

  // Probes asked for at these times [s] (ascending), each at the first accepted sample of run() at or
  // after it (within probing::kDueTolerance_s), before the source is asked for the probe; a time the
  // controller's latest sample reached counts as taken (a resumed run continues after them).
  void set_requests(std::vector<std::pair<double, std::string>> requests) { requests_ = std::move(requests); }

  // Pull loop: every sample of `source` before `stop_time_s`; a probe is asked of the source after
  // each sample. Returns the number of samples taken.
  std::size_t run(Source& source, double stop_time_s = kInf);

  const Controller& controller() const { return controller_; }
  // [s] wall time spent in cycles that identified (not part of any decision)
  double identification_s() const { return identification_s_; }
  void set_identification_s(double s) { identification_s_ = s; }
  const std::optional<Sample>& last_sample() const { return last_; }
  // The reason of the latest fit the controller rejected in this driver's cycles ("" if none): what a
  // run whose CP never ended tells its user.
  const std::string& last_rejected_fit() const { return last_rejected_fit_; }
  // The first sample this driver's controller set aside, with the reason ("" if none): the first
  // kSamplesToldAtWarn are logged at warn, later ones at debug.
  const std::string& first_rejected_sample() const { return first_rejected_sample_; }
  static constexpr std::int64_t kSamplesToldAtWarn = 10;
  // A driver of a forked controller continues after the sample its parent took last.
  void continue_after(const Sample& sample) { last_ = sample; }

 private:
  void notify(Cycle::Kind kind, const ProbeMeasurement* probe, const ControllerOutput& out, Phase before);
  // The log lines of a sample's or a probe's events: phase changes, rejected models and the guard at
  // info, a sensor's first implausible reading at warn, the rest at debug.
  void tell(const ControllerOutput& out);
  Controller& controller_;
  std::vector<Observer*> observers_;
  std::optional<CompensationSetup> setup_;
  bool maps_any_ = false;          // some output is one of the seven location errors
  std::optional<Sample> last_;
  double identification_s_ = 0.0;
  std::vector<std::string> implausible_logged_;  // outputs whose implausible reading was logged at warn
  std::string last_rejected_fit_;
  std::int64_t rejected_samples_ = 0;
  std::string first_rejected_sample_;
  std::vector<std::pair<double, std::string>> requests_;  // set_requests()
};

}  // namespace alc::runtime
