#pragma once
// When to probe: the phases of the ALC loop and the schedule policies that the controller consults.
//
// The controller (alc/controller.hpp) owns the phase logic: when a phase begins and ends, when the
// model is identified, what a breach is. A schedule policy owns the timing and counting inside it:
// the probe interval of each phase, when the next probe is due, whether a breach starts a No-Good
// (NG) burst, when the burst is complete and whether the first NG probe confirms a breach. The
// policy is a const value without I/O; whatever it needs to decide comes in a ScheduleContext, so
// the controller's state stays a plain value that saves and restores bit for bit.
//
// PaperSchedule is the schedule of seed 004 (Tab. 1, docs/design.md). Another policy (an adaptive
// one that probes when the model is unsure, say) derives from SchedulePolicy or PaperSchedule and
// overrides next_due(); the controller's phase logic stays as it is.
#include <Eigen/Core>
#include <limits>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace alc {

enum class Phase { Calibration, PostCalibration, NoGood };
std::string_view to_string(Phase phase);

}  // namespace alc

namespace alc::probing {

inline constexpr double kNever = std::numeric_limits<double>::infinity();

// [s] A measurement this little before a due time counts as at it. Due times are sums of time
// stamps and intervals in doubles, and 124200.123 + 7200 is 131400.12300000002, 1 ulp after the
// recorded 131400.123: without the tolerance that probe would wait for the next row, and a
// recording with fractional seconds would probe later than the same one shifted by whole seconds.
inline constexpr double kDueTolerance_s = 1e-3;
// Whether a sample or measurement at `time_s` is at or after `due_s` (within kDueTolerance_s).
inline bool reached(double time_s, double due_s) { return time_s >= due_s - kDueTolerance_s; }
// The guard's first check of a model fitted on a burst of probes (CP, NG): the first Post-CP probe after
// it comes after this fraction of the interval the schedule would give (docs/adaptive.md, "The first check").
inline constexpr double kFirstCheckFraction = 0.5;

// What a policy sees when it decides (all times in seconds, scenario or machine clock).
struct ScheduleContext {
  double now_s = 0.0;              // [s] time of the decision: a probe, or the start of a phase
  Phase phase = Phase::Calibration;  // the phase in force after the decision
  double phase_start_s = 0.0;      // [s] when that phase began
  double last_update_s = -kNever;  // [s] time of the last model update (-inf: none yet)
  int ng_probes = 0;               // probes taken in the current NG phase
  // The evidence an adaptive policy weighs (per output; empty before CP ends): how fast the variance
  // of the compensated error grows after a probe, in time and with the change of the prediction since,
  // the residual variance of the latest fit, the ACL.
  Eigen::VectorXd drift_rate;      // [unit²/s] NaN: not known
  Eigen::VectorXd kappa;           // [-] variance per squared change of the prediction (empty: 0)
  Eigen::VectorXd noise_var;       // [unit²]
  Eigen::VectorXd acl;             // [µm] or [µm/m]
  double since_s = -kNever;        // [s] the Post-CP decision (a probe) the uncertainty grows from (-inf: now_s)
  Eigen::VectorXd prediction_change;  // [unit] the model's prediction now minus at since_s (empty: 0)
  // The next probe is the guard's first check of a model fitted on a burst of probes (CP, NG): a policy
  // that decides its own intervals takes it at half the one it would choose (docs/adaptive.md).
  bool first_check = false;
  const std::vector<std::string>* output_names = nullptr;  // for reasons
};

// What the controller does after an NG probe.
enum class NgStep {
  Continue,           // keep probing at the NG interval
  UpdateAndLeave,     // identify on the data, then back to Post-CP
  UpdateAndContinue,  // identify now, and keep probing (an unbounded NG count while still breaching)
  Leave,              // back to Post-CP without an extra identification (unbounded count, within the ACL)
};

class SchedulePolicy {
 public:
  virtual ~SchedulePolicy() = default;
  virtual std::string_view name() const = 0;
  // [s] The probe interval announced for `phase` (a probe_interval event; inf: no probes).
  virtual double interval(Phase phase) const = 0;
  // [s] When the next probe is due after the decision at ctx.now_s; inf: none.
  virtual double next_due(const ScheduleContext& ctx) const { return ctx.now_s + interval(ctx.phase); }
  // Why next_due(ctx) is what it is, for a policy whose interval varies (an event per decision);
  // empty for a fixed interval (the interval events say it).
  virtual std::string explain(const ScheduleContext& /*ctx*/) const { return {}; }
  // Whether the controller asks next_due() again at every input sample after CP, with the evidence
  // of that moment (ctx.now_s the sample, ctx.since_s the decision): a due time at or before the
  // sample makes the probe due there (an event with explain(ctx)). A fixed interval does not.
  virtual bool checks_each_sample() const { return false; }
  // Whether a breach in Post-CP starts an NG burst (false: identify at the breach, stay in Post-CP).
  virtual bool ng_burst() const = 0;
  // After the NG probe number `ctx.ng_probes` (1 = the first), `breaching`: it broke the ACL.
  virtual NgStep after_ng_probe(const ScheduleContext& ctx, bool breaching) const = 0;
  // Whether a breach waits for the first NG probe to confirm it before it is learned from.
  virtual bool confirms_breaches() const = 0;
  // Whether the residuals of the first NG probe confirm a breach: some output that breached
  // (`breach` not NaN) is still off the same way by more than half its ACL. NaN entries are skipped.
  virtual bool confirmed(const Eigen::VectorXd& breach, const Eigen::VectorXd& residual,
                         const Eigen::VectorXd& acl) const;
};

// The probe schedule of seed 004: a fixed interval per phase, an NG burst of a fixed count.
struct PaperScheduleOptions {
  double cp_interval_s = 300.0;            // [s] interval during the calibration phase
  double post_cp_interval_s = 2 * 3600.0;  // [s] after CP; inf: no probes after CP
  double ng_interval_s = 600.0;            // [s] in NG; inf: no burst, identify at the breach
  double ng_measurements = 12;             // [-] NG probes before the update; 0: no burst; inf: identify
                                           //     after each breaching NG probe, leave at the first within
  bool confirm_breach = true;              // the first NG probe must confirm a breach
};

class PaperSchedule : public SchedulePolicy {
 public:
  explicit PaperSchedule(PaperScheduleOptions options) : options_(options) {}
  std::string_view name() const override { return "paper"; }
  double interval(Phase phase) const override;
  bool ng_burst() const override;
  NgStep after_ng_probe(const ScheduleContext& ctx, bool breaching) const override;
  bool confirms_breaches() const override { return options_.confirm_breach; }
  const PaperScheduleOptions& options() const { return options_; }

 private:
  PaperScheduleOptions options_;
};

// Probe when the model is unsure (docs/adaptive.md): after CP, the next probe is due when the predicted
// standard deviation of the compensated error of some output,
//   sqrt(noise_var + drift_rate * dt + kappa * dy^2),   dt = now - since, dy = prediction change since,
// reaches `fraction` x its ACL, within [min_interval_s, max_interval_s] after the decision (max inf: the
// evidence alone; without drift and without a move of the prediction no probe is due then). It is asked
// at every sample (checks_each_sample): a prediction that moves fast brings the probe forward. CP, the
// NG burst and the breach confirmation are seed 004's (PaperSchedule); without evidence yet, the
// Post-CP interval is the paper's.
struct AdaptiveScheduleOptions {
  PaperScheduleOptions paper;
  double fraction = 0.5;                   // [-] of the ACL (above 1: a budget beyond the ACL, for high Pd)
  double min_interval_s = 1800.0;          // [s]
  double max_interval_s = 12 * 3600.0;     // [s] inf: no bound
};

class AdaptiveSchedule : public PaperSchedule {
 public:
  explicit AdaptiveSchedule(AdaptiveScheduleOptions options) : PaperSchedule(options.paper), adaptive_(options) {}
  std::string_view name() const override { return "adaptive"; }
  double next_due(const ScheduleContext& ctx) const override;
  std::string explain(const ScheduleContext& ctx) const override;
  bool checks_each_sample() const override { return true; }
  const AdaptiveScheduleOptions& adaptive_options() const { return adaptive_; }

 private:
  // [s] the interval from ctx.since_s and the output that sets it (-1: none, the paper's interval or a bound).
  std::pair<double, int> post_cp_interval(const ScheduleContext& ctx) const;
  AdaptiveScheduleOptions adaptive_;
};

// Probe accounting of Eq. 7 of seed 004: M probe cycles of T_M each over a run of T_total.
inline constexpr double kProbeCycleTime_s = 95.0;  // [s] T_M, one probe cycle (seed 004)
// Eq. 7: Pd = (1 - M T_M / T_total) * 100 [%], M all probe cycles of the run (CP included); NaN
// when the duration is not positive.
double productivity_percent(double probe_cycles, double duration_s, double cycle_time_s = kProbeCycleTime_s);

}  // namespace alc::probing
