#pragma once
// The ALC controller: calibration phase (CP) -> Post-CP <-> No-Good phase (NG), after seed 004.
//
// A cycle API without I/O. The caller feeds input samples, probe results and ticks in time order;
// each call returns what to do: the predicted errors (to turn into offsets), the time the next
// probe is due, and events (phase changes with reasons, probe-interval changes, model updates,
// ACL breaches). The replay, the parameter study and the supervisor all drive this class, through
// the driver of runtime/ (runtime/driver.hpp).
//
// When to probe is asked of a schedule policy (probing/schedule.hpp): by default seed 004's
// PaperSchedule built from the parameters below; another policy can be given to the constructor.
//
// Bad data never throws here: a sample or probe that cannot be used (wrong size, a non-finite or
// implausible input, a time that goes backwards) returns status Rejected with the reason and changes
// nothing. A probe's implausible error (beyond AlcParameters::plausible_*) is set aside for its output
// alone, with an Implausible event; the probe is rejected only when no plausible error is left.
//
// Memory is bounded by the learning window (docs/runtime.md): after CP the controller keeps the input
// samples of the last learning_window_s plus a warm-up of kWarmupTimeConstants x the longest time
// constant of the pole grid (so the lags start settled), and the probes since then.
#include <Eigen/Core>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "alc/error_kind.hpp"
#include "alc/thermal_model.hpp"
#include "probing/schedule.hpp"

namespace alc {

// Samples older than the learning window by this many times the longest time constant of the pole
// grid are dropped (the lags of a history that starts there have settled to within e^-5 = 0.7 %).
inline constexpr double kWarmupTimeConstants = 5.0;

// The parameters of Tab. 1 of seed 004 (all times in seconds; kInf where the paper has "Inf").
struct AlcParameters {
  double cp_duration_s = 6.5 * 3600.0;     // [s] calibration phase length
  double cp_interval_s = 300.0;            // [s] probe interval during CP
  double post_cp_interval_s = 2 * 3600.0;  // [s] probe interval after CP; inf: no probes after CP
  double ng_interval_s = 600.0;            // [s] probe interval in NG; inf: no NG burst, re-identify at the breach
  double ng_measurements = 12;             // [-] NG probes before the update; inf: update after each NG probe
                                           //     and leave NG at the first probe within the ACL
  double update_interval_s = kInf;         // [s] periodic re-identification in Post-CP; inf: none
  bool refit_on_probe = true;              // re-identify after every Post-CP probe within the ACL too, so
                                           // each measurement is learned from (docs/identification.md)
  bool confirm_breach = true;              // the first NG probe must confirm a breach (same sign, beyond half
                                           // the ACL) before it is learned from; unconfirmed, the breaching
                                           // probe is set aside as an outlier (weight 0) and NG ends
  double structure_refresh = 1.25;         // [-] a probe that confirms the model refits its parameters with
                                           //     the structure kept, unless the data span has grown by this
                                           //     factor since the last structure search (then a full search)
  double acl_linear_um = 5.0;              // [µm] action control limit of linear errors
  double acl_angular_um_per_m = 15.0;      // [µm/m] action control limit of angular errors
  double learning_window_s = 14 * 86400.0; // [s] re-identify on the data of this last span (bounds memory);
                                           //     inf: all data, memory grows with the run
  double learning_since_s = -kInf;         // [s] re-identify only on probes at or after this time (a point
                                           //     in time such as a repair or a new fixture); -inf: all data
  IdentificationOptions identification;    // window_start_s is set by the controller
  // When to probe after CP (docs/adaptive.md): seed 004's fixed interval, or when the model is unsure.
  enum class Schedule { Paper, Adaptive };
  Schedule schedule_kind = Schedule::Paper;
  double uncertainty_fraction = 0.5;       // [-] adaptive: probe when the predicted sigma reaches this x ACL
  double min_interval_s = 1800.0;          // [s] adaptive: bounds of the Post-CP interval
  double max_interval_s = 12 * 3600.0;     // [s]
  bool guard = true;                       // back compensation off where it does no good (docs/adaptive.md): per
                                           // output, scale the prediction by its least-squares gain in [0, 1]
                                           // against the errors of recent Post-CP probes and add the level
                                           // those probes measured (the guard's level), compensate nothing
                                           // of the model while the prediction leaves the range of the
                                           // measured errors (the latest probe's error fading within the
                                           // drift bound instead), and
                                           // keep compensation within the latest probe's error +- 2 x the
                                           // fastest drift measured x the time since (the drift bound)
  double move_fraction = 0.5;              // [-] the guard's move check: a Post-CP probe is due as soon as an
                                           //     output's compensation has moved this x its ACL since the last
                                           //     probe (or the end of CP or NG); inf: no move check
  // Plausibility (docs/runtime.md, "Plausibility"): a finite reading beyond these magnitudes is a sensor
  // fault, not a thermal error. A probe's error beyond its limit is set aside for that output (an
  // Implausible event; the other outputs of the probe are learned); an input beyond its limit rejects
  // the sample. inf: no limit.
  double plausible_linear_um = 1000.0;          // [µm] |measured| of a linear error (1 mm)
  double plausible_angular_um_per_m = 1000.0;   // [µm/m] |measured| of an angular error (0.057°)
  double plausible_temperature_C = 200.0;       // [°C] |value| of a temperature input (InputKind::Temperature)
  double plausible_speed_rpm = 100000.0;        // [rpm] |value| of a speed input (InputKind::Speed)
  double plausible_other = 1e6;                 // [-] |value| of any other input (machine states, …)

  // Empty if valid, else the first violated constraint naming the field and value.
  std::string validate() const;
  // Whether move_fraction is read: the move check belongs to the guard and needs the refits on probes
  // (the paper's literal loop keeps seed 004's schedule). Its `inf` is then read too: no move check.
  bool move_fraction_read() const { return guard && refit_on_probe; }
  // The largest plausible magnitude of an error of `kind` [µm] / [µm/m], of an input of `kind`.
  double plausible_limit(ErrorKind kind) const;
  double plausible_limit(InputKind kind) const;
  // The probe schedule of these parameters (seed 004's fixed intervals per phase).
  probing::PaperScheduleOptions schedule() const;
  // The policy of schedule_kind: PaperSchedule(schedule()) or AdaptiveSchedule.
  std::shared_ptr<const probing::SchedulePolicy> schedule_policy() const;
};

// What a probe cycle measured. In closed loop the probe sees the error left after compensation;
// the thermal error that the model learns is `measured + compensation` (docs/design.md, "Closed loop").
struct ProbeMeasurement {
  double time_s = 0.0;           // [s]
  Eigen::VectorXd measured;      // [µm] / [µm/m] per output; NaN where not measured
  Eigen::VectorXd compensation;  // [µm] / [µm/m] active at probe time; empty = none (open loop)
};

struct ControllerEvent {
  enum class Type { PhaseChange, ProbeIntervalChange, ModelUpdate, ModelRejected, AclBreach, OutlierRejected, Guard,
                    Implausible };
  Type type = Type::PhaseChange;
  double time_s = 0.0;           // [s]
  Phase from = Phase::Calibration;
  Phase to = Phase::Calibration;
  double interval_s = 0.0;       // [s] new probe interval (ProbeIntervalChange)
  std::string output;            // error name (AclBreach, Guard, Implausible)
  double value = 0.0;            // residual [µm] or [µm/m] (AclBreach); the new gain (Guard) or the prediction
                                 //     that left the range (Guard, range) or the prediction with its gain (Guard,
                                 //     drift bound; 0 off by the range) or the error the model's compensation left at its first
                                 //     check (Guard, first check; at the hold's end the probe's error without
                                 //     compensation); the reading set aside (Implausible)
  double limit = 0.0;            // ACL [µm] or [µm/m] (AclBreach); the gain before (Guard) or the range's bound
                                 //     or the drift bound's nearer edge or the error without compensation
                                 //     (Guard, first check); the plausibility limit (Implausible)
  std::string reason;            // human-readable why
};
std::string_view to_string(ControllerEvent::Type type);

struct ControllerOutput {
  bool accepted = true;                // false: the sample or probe was rejected (reason), nothing changed
  std::string reason;                  // why it was rejected
  Eigen::VectorXd prediction;          // [µm] / [µm/m] the errors to compensate: the model's prediction, zero
                                       //     while no model exists; where the guard's range switches the model
                                       //     off, the latest probe's error fading towards 0 within the drift
                                       //     bound (0 once the bound reaches 0)
  double next_probe_due_s = kInf;      // [s] inf: no probe scheduled
  std::vector<ControllerEvent> events;
  std::optional<FitResult> fit;        // the identification that ran in this cycle, if any
};

// Everything the controller knows: a plain value, so a saved copy restores it bit for bit.
struct ControllerState {
  Phase phase = Phase::Calibration;
  double phase_start_s = 0.0;          // [s] when the current phase began
  double start_time_s = 0.0;           // [s] time of the first sample
  bool started = false;
  double now_s = 0.0;                  // [s] time of the latest input
  double cp_end_s = kInf;              // [s] when CP ended (inf while in CP)
  double next_probe_due_s = 0.0;       // [s]
  double current_interval_s = 0.0;     // [s]
  double last_update_s = -kInf;        // [s] time of the last successful identification
  int probe_cycles = 0;                // M of Eq. 7, all phases
  int ng_probes = 0;                   // probes in the current NG phase
  int ng_phases = 0;                   // NG phases entered
  int updates = 0;                     // successful identifications (incl. the first at CP end)
  int rejected_fits = 0;               // identifications that kept the previous model
  int probes_at_last_attempt = -1;     // probes seen at the last end-of-CP fit attempt
  double structure_span_s = 0.0;       // [s] span of the data used by the last structure search
  int breach_probe = -1;               // index in `probes` of the probe that started NG, until confirmed
  Eigen::VectorXd breach_residual;     // its residuals [µm] / [µm/m] (NaN where within the ACL)
  InputHistory history;                // the input samples the learning needs (see kWarmupTimeConstants)
  std::int64_t history_first_index = 0;  // index of history row 0 among all samples of the run
  std::int64_t samples = 0;            // samples accepted in the run
  std::vector<ProbeRecord> probes;     // probe records since history row 0 (error = measured + compensation)
  bool has_model = false;
  ModelPredictor predictor;            // current model with its running state
  Eigen::VectorXd prediction;          // latest prediction of the model
  // Evidence from the probes after CP (docs/adaptive.md), per output:
  double last_probe_s = -kInf;         // [s] time of the latest probe
  Eigen::VectorXd drift_rate;          // [unit²/s] growth of the residual variance after a probe (NaN: unknown)
  Eigen::VectorXd noise_var;           // [unit²] residual variance of the latest usable fit
  Eigen::VectorXd kappa;               // [-] growth of that variance per squared change of the prediction
  double schedule_since_s = -kInf;     // [s] the latest Post-CP schedule decision (a probe, or CP end)
  Eigen::VectorXd schedule_prediction; // [unit] the model's prediction at that decision
  Eigen::MatrixXd schedule_sums;       // per output, decaying sums of the regression of the variance growth
                                       //     rate on the squared prediction change rate: w, x, x², y, x·y
  // The guard's evidence (docs/adaptive.md), per output, kept whether or not the guard is on:
  Eigen::VectorXd guard_cross;         // [unit²] decaying sum over Post-CP probes of error x prediction
  Eigen::VectorXd guard_power;         // [unit²] the same of prediction² (the gain is cross / power)
  Eigen::VectorXd guard_error;         // [unit²] the same of error² (the energy without compensation)
  int guard_probes = 0;                // Post-CP probes in the sums
  Eigen::VectorXd guard_gain;          // [-] applied gain in [0, 1] (1: the prediction as it is)
  Eigen::VectorXd error_low;           // [unit] smallest and largest settled thermal error (each the median of
                                       // three consecutive evidence probes, so a single chip is not one) (+-inf: none)
  Eigen::VectorXd error_high;
  Eigen::VectorXd guard_off_range;     // 1 while compensation is off because the prediction left the range
  Eigen::VectorXd guard_held;          // 1 while the drift bound holds compensation back by more than the ACL
                                       //     (from the model, or, off by the range, from 0)
  bool first_check_due = false;        // the next probe is the guard's first check of a model fitted on a burst
  Eigen::VectorXd guard_check_hold;    // [unit] where the model's compensation did worse than none at its first
                                       //     check, the error that probe measured, compensated until the next
                                       //     probe instead of the model's; NaN: none held
  // The guard's level (docs/adaptive.md, "The level"): per output, decaying sums over the Post-CP probes within
  // the ACL since the latest NG phase of the error the gain-scaled prediction left, and their weights.
  Eigen::VectorXd guard_level_sum;     // [unit]
  Eigen::VectorXd guard_level_weight;  // [-]
  Eigen::VectorXd guard_level_told;    // [unit] the level the latest guard event announced (0: none)
};

// Sizes the evidence of a state to `outputs` (NaN drift and noise, zero sums, gain 1, no range) where it is not.
void init_evidence(ControllerState& state, std::size_t outputs);

class Controller {
 public:
  using SchedulePtr = std::shared_ptr<const probing::SchedulePolicy>;
  // Throws std::invalid_argument if the parameters are invalid or there are no outputs. Without a
  // schedule, seed 004's PaperSchedule of params.schedule().
  Controller(std::vector<std::string> input_names, std::vector<std::string> output_names, AlcParameters params,
             SchedulePtr schedule = nullptr);
  // Restores a saved state (the parameters and names must be those of the saved controller).
  Controller(std::vector<std::string> input_names, std::vector<std::string> output_names, AlcParameters params,
             ControllerState state, SchedulePtr schedule = nullptr);

  // A new input sample (time strictly increasing, every input finite). Returns the prediction after
  // it; a sample that breaks this is rejected (accepted = false, reason) and changes nothing.
  ControllerOutput on_sample(double time_s, const Eigen::VectorXd& inputs);
  // Why on_sample would reject a sample for what it holds (the number of inputs, a time or an input
  // that is not finite, an input beyond its plausible limit), empty if nothing; the order of the times
  // is the caller's to judge. A caller that journals samples before they reach the controller (the
  // supervisor) asks this first, so that a sample refused here changes nothing there either.
  std::string sample_problem(double time_s, const Eigen::VectorXd& inputs) const;
  // A probe cycle finished at `probe.time_s` (not before the latest sample; NaN = not measured).
  // A probe that cannot be used is rejected (accepted = false, reason) and changes nothing; an error
  // beyond its plausibility limit is treated as not measured (an Implausible event names it).
  ControllerOutput on_probe(const ProbeMeasurement& probe);
  // Time passes without data: phase ends and periodic updates that are due happen here.
  ControllerOutput on_tick(double time_s);
  // Someone who knows what no input shows (the machine moved, relevelled, repaired, after a collision)
  // asks for a probe: it is due at `time_s` (finite, not before the latest sample: the latest sample's
  // time, as every caller gives it; a probe due by then already serves), in any phase, and
  // is that phase's ordinary probe (after CP a breach starts NG, a probe within the ACL is learned
  // from). One ProbeIntervalChange event "probe requested: <reason>", with the time since the latest
  // probe (or the phase start) as its interval; none where a probe is due already. The schedule's
  // interval counts again from that probe. Rejected before the first sample (nothing changes then).
  ControllerOutput request_probe(double time_s, const std::string& reason);

  // A copy of this controller (state and derived caches) that continues with other parameters: a
  // parameter study runs the sets that agree so far as one controller and forks it where their
  // parameters first matter (docs/study.md). The caller forks before any decision that the new
  // parameters would have taken otherwise. Throws std::invalid_argument if `params` are invalid.
  Controller fork(AlcParameters params, SchedulePtr schedule = nullptr) const&;
  Controller fork(AlcParameters params, SchedulePtr schedule = nullptr) &&;  // moves the state instead
  // Whether on_probe(probe) would find a residual beyond its ACL (the same arithmetic; no change).
  bool breaches_acl(const ProbeMeasurement& probe) const;

  const ControllerState& state() const { return state_; }
  const AlcParameters& parameters() const { return params_; }
  const probing::SchedulePolicy& schedule() const { return *schedule_; }
  const std::vector<std::string>& output_names() const { return output_names_; }
  Phase phase() const { return state_.phase; }
  double acl_of(std::size_t output) const;
  // [s] the first probe time that an identification at `time_s` learns from (learning_since_s and
  // learning_window_s together); -inf: all probes.
  double learning_window_start(double time_s) const;

 private:
  void advance(double time_s, ControllerOutput& out);
  void set_interval(double interval_s, double time_s, ControllerOutput& out, const std::string& reason);
  // next_probe_due_s after a decision at `time_s`, with an event when the policy explains it.
  void schedule_next(double time_s, ControllerOutput& out);
  // At a sample after CP, for a policy that checks each sample: the probe is due now if the evidence says so.
  void check_due(double time_s, ControllerOutput& out);
  // At a sample after CP, under the guard: the probe is due now where an output's compensation by the model
  // (its prediction with the guard's gain) has moved more than AlcParameters::move_fraction x its ACL since the last
  // decision (docs/adaptive.md, "The move check").
  void check_move(double time_s, ControllerOutput& out);
  // The probe is due now (one event saying why, its interval counted from `since_s`; the time no longer moves).
  void due_now(double time_s, double since_s, std::string reason, ControllerOutput& out);
  // A Post-CP probe's residuals (against the prediction when it ran): the drift and kappa evidence.
  void weigh_schedule(double time_s, const Eigen::VectorXd& residuals);
  // A probe after CP: the drift and guard evidence (errors: thermal errors, residuals: against the model).
  void weigh_probe(double time_s, const Eigen::VectorXd& errors, const Eigen::VectorXd& residuals, ControllerOutput& out);
  // The guard's first check judging the model (docs/adaptive.md): at the first probe after a fit on a burst,
  // an output whose compensation (the prediction with its gain and the level the probe ran with) left a
  // larger error than none compensates the error that probe measured until the next probe; any other probe
  // after CP ends such a hold.
  void judge_first_check(double time_s, const Eigen::VectorXd& errors, const Eigen::VectorXd& residuals,
                         const Eigen::VectorXd& level, ControllerOutput& out);
  // The prediction with the guard applied at `time_s` (what is compensated); with `out`, also the events
  // of an output whose prediction leaves or re-enters the range of the measured errors, or whose
  // compensation the drift bound starts or stops holding back.
  Eigen::VectorXd compensated(double time_s) const;
  Eigen::VectorXd compensated(double time_s, ControllerOutput& out);
  // Whether probe k is evidence of output i's thermal error: measured and not set aside as an outlier
  // (weight 0).
  bool evidence(std::size_t k, Eigen::Index i) const;
  // Widens the range of the measured thermal errors by what probe j settles: per output the median of
  // the latest three evidence probes up to j (a single probe its neighbours do not confirm, a chip on
  // the sphere, widens nothing; a change that lasts widens it one probe later).
  void settle_range(std::size_t j);
  // A Guard event at `time_s` for output i (value, limit as ControllerEvent documents them; the reason
  // `why`, which does not repeat the type).
  ControllerEvent guard_event(double time_s, Eigen::Index output, double value, double limit, const std::string& why) const;
  // [unit] the interval the guard lets compensation take for output i (the measured errors widened).
  std::pair<double, double> guard_range(Eigen::Index i) const;
  // The drift bound of output i at `time_s`: the latest probe's thermal error, the fastest rate of change
  // the probes have measured, and the interval compensation may take (+-inf: no evidence yet).
  struct DriftBound {
    double anchor = 0.0;  // [unit] the latest probe's thermal error
    double rate = 0.0;    // [unit/s] the fastest |change| between two probes at least kDriftSpan apart
    double low = -std::numeric_limits<double>::infinity();
    double high = std::numeric_limits<double>::infinity();
  };
  DriftBound drift_bound(Eigen::Index i, double time_s) const;
  // The guard's level of output i: the decaying mean of the errors its gain-scaled prediction left at the
  // recent Post-CP probes, shrunk towards 0 by one probe's weight (0 before the first such probe).
  double guard_level(Eigen::Index i) const;
  // What output i's model compensates with the guard's gain and level, before the range, a first check's
  // hold and the drift bound: the prediction x the gain + the level.
  double model_compensation(Eigen::Index i) const;
  // What output i compensates before the drift bound: 0 off by the range, else the error a first check's
  // probe measured while it holds, else model_compensation (the guard's order, read from its state).
  double unbounded_compensation(Eigen::Index i) const;
  void weigh_level(double time_s, const Eigen::VectorXd& errors, const Eigen::VectorXd& residuals,
                   ControllerOutput& out);
  void reset_level(double time_s, bool refitted, ControllerOutput& out);
  // A guard event where output i's level moved kLevelEventFraction x its ACL from the one last told.
  void tell_level(double time_s, Eigen::Index i, const char* why, ControllerOutput& out);
  void change_phase(Phase to, double time_s, ControllerOutput& out, const std::string& reason);
  // Enters `to` at `time_s`: the phase change, the next due probe and the interval of the new phase.
  // burst_model: a burst of probes just ended with an identification (CP end, NG end with an update;
  // after NG also when the fit was rejected and the previous model stays): the guard's first check
  // brings the next probe forward (docs/adaptive.md).
  void enter(Phase to, double time_s, ControllerOutput& out, const std::string& reason, const std::string& interval_reason,
             bool burst_model = false);
  probing::ScheduleContext schedule_context(double time_s) const;
  double next_due(double time_s) const;
  ControllerOutput rejected(std::string reason) const;
  // The thermal error a probe saw (measured + compensation in force) and its residuals against the
  // current prediction (NaN where not measured).
  Eigen::VectorXd thermal_errors(const ProbeMeasurement& probe) const;
  Eigen::VectorXd residuals(const Eigen::VectorXd& errors) const;
  // The probe with every error beyond its plausibility limit set aside (NaN), and an Implausible
  // event for each into `events` when given; `measured` counts the errors the probe measured.
  ProbeMeasurement plausible(const ProbeMeasurement& probe, std::vector<ControllerEvent>* events,
                             int* measured = nullptr) const;
  // Drops samples and probes that no identification can use any more (bounded memory).
  void trim();
  // keep_structure: refit the parameters of the current model's structure (refit()) instead of
  // the full identify(); used for the probes that confirm the model.
  bool reidentify(double time_s, ControllerOutput& out, const std::string& reason, bool keep_structure = false);

  std::vector<std::string> output_names_;
  std::vector<ErrorKind> kinds_;
  std::vector<InputKind> input_kinds_;
  AlcParameters params_;
  SchedulePtr schedule_;
  ControllerState state_;
  // The grid lags of state_.history, extended by each identification instead of recomputed: derived
  // from the state, not part of it (a restored controller rebuilds it and decides the same, bit for bit).
  LagCache lag_cache_;
  // The drift bound's evidence per output, derived from state_.probes alone and rebuilt when they
  // change (a probe added or dropped), not on every sample: not part of the state either.
  struct DriftEvidence {
    std::size_t probes = 0;
    int breach_probe = -1;
    double first_s = std::numeric_limits<double>::quiet_NaN();
    double last_s = std::numeric_limits<double>::quiet_NaN();
    Eigen::VectorXd anchor;    // [unit] the latest probe's thermal error (NaN: none measured)
    Eigen::VectorXd anchor_s;  // [s] its time
    Eigen::VectorXd rate;      // [unit/s] the fastest change (NaN: no two probes kDriftSpan apart yet)
  };
  mutable DriftEvidence drift_;  // written by const methods: a Controller is not for concurrent use
  const DriftEvidence& drift_evidence() const;
};

}  // namespace alc
