#include "alc/controller.hpp"

#include "common/number_text.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace alc {

namespace {

std::string describe(const char* field, double value, const char* constraint) {
  std::ostringstream s;
  s << field << " = " << value << ": " << constraint;
  return s.str();
}

// A reading as printed in messages, 6 significant digits ("-1e+308", "1234.5").
std::string reading(double v) {
  std::ostringstream o;
  o.precision(6);
  o << v;
  return o.str();
}

std::string hours(double s) {
  std::ostringstream o;
  o << s / 3600.0 << " h";
  return o.str();
}

// The median of three values (a single one that the other two do not confirm drops out).
double median3(double a, double b, double c) { return std::max(std::min(a, b), std::min(std::max(a, b), c)); }

}  // namespace

std::string_view to_string(ControllerEvent::Type type) {
  switch (type) {
    case ControllerEvent::Type::PhaseChange: return "phase_change";
    case ControllerEvent::Type::ProbeIntervalChange: return "probe_interval";
    case ControllerEvent::Type::ModelUpdate: return "model_update";
    case ControllerEvent::Type::ModelRejected: return "model_rejected";
    case ControllerEvent::Type::AclBreach: return "acl_breach";
    case ControllerEvent::Type::OutlierRejected: return "outlier_rejected";
    case ControllerEvent::Type::Guard: return "guard";
    case ControllerEvent::Type::Implausible: return "implausible";
  }
  return "?";
}

void init_evidence(ControllerState& s, std::size_t outputs) {
  const auto n = static_cast<Eigen::Index>(outputs);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (s.drift_rate.size() != n) s.drift_rate = Eigen::VectorXd::Constant(n, nan);
  if (s.noise_var.size() != n) s.noise_var = Eigen::VectorXd::Constant(n, nan);
  if (s.kappa.size() != n) s.kappa = Eigen::VectorXd::Zero(n);
  if (s.schedule_sums.rows() != n || s.schedule_sums.cols() != 5) s.schedule_sums = Eigen::MatrixXd::Zero(n, 5);
  // A state saved before the change of the prediction counted: it counts from here, the time from the last probe.
  if (s.schedule_prediction.size() != n)
    s.schedule_prediction = s.prediction.size() == n ? s.prediction : Eigen::VectorXd::Zero(n);
  if (!std::isfinite(s.schedule_since_s) && s.phase != Phase::Calibration) s.schedule_since_s = s.last_probe_s;
  if (s.guard_cross.size() != n) s.guard_cross = Eigen::VectorXd::Zero(n);
  if (s.guard_power.size() != n) s.guard_power = Eigen::VectorXd::Zero(n);
  if (s.guard_error.size() != n) s.guard_error = Eigen::VectorXd::Zero(n);
  if (s.guard_gain.size() != n) s.guard_gain = Eigen::VectorXd::Ones(n);
  if (s.error_low.size() != n) s.error_low = Eigen::VectorXd::Constant(n, kInf);
  if (s.error_high.size() != n) s.error_high = Eigen::VectorXd::Constant(n, -kInf);
  if (s.guard_off_range.size() != n) s.guard_off_range = Eigen::VectorXd::Zero(n);
  if (s.guard_held.size() != n) s.guard_held = Eigen::VectorXd::Zero(n);
  if (s.guard_check_hold.size() != n) s.guard_check_hold = Eigen::VectorXd::Constant(n, nan);
  if (s.guard_level_sum.size() != n) s.guard_level_sum = Eigen::VectorXd::Zero(n);
  if (s.guard_level_weight.size() != n) s.guard_level_weight = Eigen::VectorXd::Zero(n);
  if (s.guard_level_told.size() != n) s.guard_level_told = Eigen::VectorXd::Zero(n);
}

std::string AlcParameters::validate() const {
  auto positive_finite = [](double v) { return std::isfinite(v) && v > 0.0; };
  auto positive_or_inf = [](double v) { return !std::isnan(v) && v > 0.0; };
  if (!positive_finite(cp_duration_s)) return describe("cp_duration_s", cp_duration_s, "must be positive and finite");
  if (!positive_finite(cp_interval_s)) return describe("cp_interval_s", cp_interval_s, "must be positive and finite");
  if (cp_interval_s > cp_duration_s)
    return describe("cp_interval_s", cp_interval_s, "must not exceed cp_duration_s");
  if (!positive_or_inf(post_cp_interval_s))
    return describe("post_cp_interval_s", post_cp_interval_s, "must be positive or inf");
  if (!positive_or_inf(ng_interval_s)) return describe("ng_interval_s", ng_interval_s, "must be positive or inf");
  if (std::isnan(ng_measurements) || ng_measurements < 0.0 ||
      (std::isfinite(ng_measurements) && ng_measurements != std::floor(ng_measurements)))
    return describe("ng_measurements", ng_measurements, "must be a whole number >= 0 or inf");
  if (!positive_or_inf(update_interval_s))
    return describe("update_interval_s", update_interval_s, "must be positive or inf");
  if (!(structure_refresh >= 1.0))
    return describe("structure_refresh", structure_refresh, "must be >= 1 (1: search the structure at every update, inf: never again after a search)");
  if (!positive_finite(acl_linear_um)) return describe("acl_linear_um", acl_linear_um, "must be positive and finite");
  if (!positive_finite(acl_angular_um_per_m))
    return describe("acl_angular_um_per_m", acl_angular_um_per_m, "must be positive and finite");
  if (!positive_or_inf(learning_window_s))
    return describe("learning_window_s", learning_window_s, "must be positive or inf");
  if (std::isnan(learning_since_s) || learning_since_s == kInf)
    return describe("learning_since_s", learning_since_s, "must be a time or -inf");
  if (const std::string why = identification.validate(); !why.empty()) return "identification: " + why;
  if (!positive_finite(uncertainty_fraction))
    return describe("uncertainty_fraction", uncertainty_fraction, "must be positive and finite");
  if (!positive_finite(min_interval_s)) return describe("min_interval_s", min_interval_s, "must be positive and finite");
  if (!(max_interval_s >= min_interval_s))
    return describe("max_interval_s", max_interval_s, "must not be below min_interval_s (inf: no bound)");
  if (!positive_or_inf(move_fraction))
    return describe("move_fraction", move_fraction, "must be positive or inf (inf: no move check)");
  const std::pair<const char*, double> limits[] = {{"plausible_linear_um", plausible_linear_um},
                                                   {"plausible_angular_um_per_m", plausible_angular_um_per_m},
                                                   {"plausible_temperature_C", plausible_temperature_C},
                                                   {"plausible_speed_rpm", plausible_speed_rpm},
                                                   {"plausible_other", plausible_other}};
  for (const auto& [field, value] : limits)
    if (!positive_or_inf(value)) return describe(field, value, "must be positive or inf (inf: no limit)");
  return {};
}

double AlcParameters::plausible_limit(ErrorKind kind) const {
  return kind == ErrorKind::Angular ? plausible_angular_um_per_m : plausible_linear_um;
}

double AlcParameters::plausible_limit(InputKind kind) const {
  switch (kind) {
    case InputKind::Temperature: return plausible_temperature_C;
    case InputKind::Speed: return plausible_speed_rpm;
    case InputKind::Other: return plausible_other;
  }
  return plausible_other;
}

probing::PaperScheduleOptions AlcParameters::schedule() const {
  probing::PaperScheduleOptions o;
  o.cp_interval_s = cp_interval_s;
  o.post_cp_interval_s = post_cp_interval_s;
  o.ng_interval_s = ng_interval_s;
  o.ng_measurements = ng_measurements;
  o.confirm_breach = confirm_breach;
  return o;
}

std::shared_ptr<const probing::SchedulePolicy> AlcParameters::schedule_policy() const {
  if (schedule_kind == Schedule::Paper) return std::make_shared<const probing::PaperSchedule>(schedule());
  probing::AdaptiveScheduleOptions o;
  o.paper = schedule();
  o.fraction = uncertainty_fraction;
  o.min_interval_s = min_interval_s;
  o.max_interval_s = max_interval_s;
  return std::make_shared<const probing::AdaptiveSchedule>(o);
}

Controller::Controller(std::vector<std::string> input_names, std::vector<std::string> output_names,
                       AlcParameters params, SchedulePtr schedule)
    : output_names_(std::move(output_names)), params_(std::move(params)), schedule_(std::move(schedule)) {
  if (const std::string why = params_.validate(); !why.empty()) throw std::invalid_argument(why);
  if (!schedule_) schedule_ = params_.schedule_policy();
  if (output_names_.empty()) throw std::invalid_argument("controller: no error outputs");
  for (const auto& name : output_names_) kinds_.push_back(error_kind(name));
  for (const auto& name : input_names) input_kinds_.push_back(input_kind(name));
  state_.history.input_names = std::move(input_names);
  state_.history.inputs.resize(0, static_cast<Eigen::Index>(state_.history.input_names.size()));
  state_.prediction = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(output_names_.size()));
  init_evidence(state_, output_names_.size());
}

Controller::Controller(std::vector<std::string> input_names, std::vector<std::string> output_names,
                       AlcParameters params, ControllerState state, SchedulePtr schedule)
    : Controller(std::move(input_names), std::move(output_names), std::move(params), std::move(schedule)) {
  if (state.history.input_names != state_.history.input_names)
    throw std::invalid_argument("controller: saved state has other input names");
  if (state.prediction.size() != static_cast<Eigen::Index>(output_names_.size()))
    throw std::invalid_argument("controller: saved state has another number of outputs");
  const bool no_range = state.error_low.size() != static_cast<Eigen::Index>(output_names_.size());
  state_ = std::move(state);
  init_evidence(state_, output_names_.size());  // a state saved before the evidence existed
  if (no_range)
    for (std::size_t j = 0; j < state_.probes.size(); ++j) settle_range(j);  // the guard's range from the probes kept
}

double Controller::learning_window_start(double time_s) const {
  const double trailing = std::isfinite(params_.learning_window_s) ? time_s - params_.learning_window_s : -kInf;
  return std::max(trailing, params_.learning_since_s);
}

double Controller::acl_of(std::size_t output) const {
  return kinds_[output] == ErrorKind::Angular ? params_.acl_angular_um_per_m : params_.acl_linear_um;
}

void Controller::set_interval(double interval_s, double time_s, ControllerOutput& out, const std::string& reason) {
  if (interval_s == state_.current_interval_s) return;
  state_.current_interval_s = interval_s;
  ControllerEvent e;
  e.type = ControllerEvent::Type::ProbeIntervalChange;
  e.time_s = time_s;
  e.from = e.to = state_.phase;
  e.interval_s = interval_s;
  e.reason = reason;
  out.events.push_back(std::move(e));
}

void Controller::change_phase(Phase to, double time_s, ControllerOutput& out, const std::string& reason) {
  ControllerEvent e;
  e.type = ControllerEvent::Type::PhaseChange;
  e.time_s = time_s;
  e.from = state_.phase;
  e.to = to;
  e.reason = reason;
  state_.phase = to;
  state_.phase_start_s = time_s;
  out.events.push_back(std::move(e));
}

probing::ScheduleContext Controller::schedule_context(double time_s) const {
  probing::ScheduleContext c;
  c.now_s = time_s;
  c.phase = state_.phase;
  c.phase_start_s = state_.phase_start_s;
  c.last_update_s = state_.last_update_s;
  c.ng_probes = state_.ng_probes;
  c.drift_rate = state_.drift_rate;
  c.kappa = state_.kappa;
  c.noise_var = state_.noise_var;
  c.since_s = state_.schedule_since_s;
  if (state_.has_model && state_.schedule_prediction.size() == state_.prediction.size())
    c.prediction_change = state_.prediction - state_.schedule_prediction;
  c.acl.resize(static_cast<Eigen::Index>(output_names_.size()));
  for (std::size_t i = 0; i < output_names_.size(); ++i) c.acl(static_cast<Eigen::Index>(i)) = acl_of(i);
  c.output_names = &output_names_;
  c.first_check = state_.first_check_due && state_.phase == Phase::PostCalibration;
  return c;
}

void Controller::schedule_next(double time_s, ControllerOutput& out) {
  // After the guard's first check (enter), its move check or a probe asked for (request_probe), a fixed
  // interval is the schedule's again.
  if (state_.phase == Phase::PostCalibration && !schedule_->checks_each_sample())
    set_interval(schedule_->interval(state_.phase), time_s, out,
                 "Post-CP interval after an early probe (the guard's first check or move check, or one asked for)");
  state_.schedule_since_s = time_s;
  state_.schedule_prediction = state_.prediction;
  const probing::ScheduleContext ctx = schedule_context(time_s);
  state_.next_probe_due_s = schedule_->next_due(ctx);
  std::string why = schedule_->explain(ctx);
  if (why.empty()) return;
  ControllerEvent e;
  e.type = ControllerEvent::Type::ProbeIntervalChange;
  e.time_s = time_s;
  e.from = e.to = state_.phase;
  e.interval_s = state_.next_probe_due_s - time_s;
  e.reason = std::move(why);
  state_.current_interval_s = e.interval_s;
  out.events.push_back(std::move(e));
}

void Controller::check_due(double time_s, ControllerOutput& out) {
  const probing::ScheduleContext ctx = schedule_context(time_s);
  if (schedule_->next_due(ctx) > time_s) return;
  due_now(time_s, state_.schedule_since_s, schedule_->explain(ctx), out);
}

void Controller::due_now(double time_s, double since_s, std::string reason, ControllerOutput& out) {
  // Due: the probe is taken at the first chance from here (one event, the time no longer moves).
  state_.next_probe_due_s = time_s;
  ControllerEvent e;
  e.type = ControllerEvent::Type::ProbeIntervalChange;
  e.time_s = time_s;
  e.from = e.to = state_.phase;
  e.interval_s = time_s - since_s;
  e.reason = std::move(reason);
  state_.current_interval_s = e.interval_s;
  out.events.push_back(std::move(e));
}

// The guard's move check (docs/adaptive.md): a model whose compensation moves by move_fraction of the ACL
// since the last probe is judged by a probe now, not at the end of the interval. Between probes nothing
// else tells a model that runs away to the wrong sign from one that follows the error.
void Controller::check_move(double time_s, ControllerOutput& out) {
  // It brings a planned probe forward; where the schedule plans none (a Post-CP interval of inf), none is added.
  if (!params_.move_fraction_read() || !std::isfinite(params_.move_fraction) || !state_.has_model ||
      state_.phase != Phase::PostCalibration || !std::isfinite(state_.next_probe_due_s) ||
      probing::reached(time_s, state_.next_probe_due_s) || state_.schedule_prediction.size() != state_.prediction.size())
    return;
  for (Eigen::Index i = 0; i < state_.prediction.size(); ++i) {
    // An output the guard switched off or holds compensates no prediction: its model's moves reach no axis.
    if (state_.guard_off_range(i) != 0.0 || !std::isnan(state_.guard_check_hold(i))) continue;
    const double moved = state_.guard_gain(i) * (state_.prediction(i) - state_.schedule_prediction(i));
    const double limit = params_.move_fraction * acl_of(static_cast<std::size_t>(i));
    if (!(std::abs(moved) > limit)) continue;
    std::ostringstream why;
    why << "the guard's move check: the compensation of " << output_names_[static_cast<std::size_t>(i)]
        << " moved " << moved << " since t = " << common::shortest_text(state_.schedule_since_s)
        << " s (the last probe, or the end of CP or NG), more than " << params_.move_fraction << " x its ACL (" << limit << "): probe now";
    due_now(time_s, state_.schedule_since_s, why.str(), out);
    return;
  }
}

// The schedule's evidence (docs/adaptive.md): per output, the growth rate of the residual variance after
// a decision, y = max(0, r² - noise) / dt, regressed on the squared prediction change rate x = dy² / dt
// as y = drift + kappa x (both >= 0), over the Post-CP probes with weights decaying by kScheduleDecay per
// probe. Seeded at CP end with one observation x = 0, y = the drift of the paper's interval.
constexpr double kScheduleDecay = 0.8;

void Controller::weigh_schedule(double time_s, const Eigen::VectorXd& residuals) {
  const double dt = time_s - state_.schedule_since_s;
  if (state_.phase != Phase::PostCalibration || !(dt > 0.0) || !std::isfinite(dt)) return;
  for (Eigen::Index i = 0; i < residuals.size(); ++i) {
    const double r = residuals(i);
    if (std::isnan(r)) continue;
    const double noise = std::isfinite(state_.noise_var(i)) ? state_.noise_var(i) : 0.0;
    const double dy = state_.prediction(i) - state_.schedule_prediction(i);
    const double x = dy * dy / dt;
    const double y = std::max(0.0, r * r - noise) / dt;
    auto sums = state_.schedule_sums.row(i);
    sums *= kScheduleDecay;
    sums += Eigen::RowVectorXd((Eigen::RowVectorXd(5) << 1.0, x, x * x, y, x * y).finished());
    const double w = sums(0), sx = sums(1), sxx = sums(2), sy = sums(3), sxy = sums(4);
    double drift = sy / w, kappa = 0.0;
    const double det = w * sxx - sx * sx;
    if (det > 1e-12 * w * sxx) {
      kappa = (w * sxy - sx * sy) / det;
      drift = (sy - kappa * sx) / w;
      if (kappa < 0.0) {
        kappa = 0.0;
        drift = sy / w;
      } else if (drift < 0.0) {
        drift = 0.0;
        kappa = sxy / sxx;
      }
    }
    state_.drift_rate(i) = drift;
    state_.kappa(i) = kappa;
  }
}

// The guard (docs/adaptive.md). Its sums decay by this factor per probe after CP (about the last 20
// probes weigh); the gain is applied once this many probes are in them, in steps of kGuardStep (each
// change an event). The range that compensation may take is the measured errors' (with 0) widened on
// both sides by kRangeMargin x its width, at least by the ACL; a measured error counts once the probes
// beside it confirm it (the median of three consecutive probes) or while it is the latest.
constexpr double kGuardDecay = 0.95;
constexpr int kGuardMinProbes = 12;
constexpr double kGuardStep = 0.1;
constexpr double kRangeMargin = 1.0;
// The drift bound: compensation stays within the latest probe's thermal error +- kDriftFactor x the
// fastest rate of change measured between two probes at least kDriftSpan apart x the time since it.
// Over a span s a sinusoidal error's change is sinc(pi s / period) of its fastest rate: with 2 x and
// 1 h the bound follows any error whose period is 1.66 h or longer at full speed (docs/adaptive.md).
constexpr double kDriftFactor = 2.0;
constexpr double kDriftSpan_s = 1.0 * 3600.0;
// The level: a probe's weight in the mean decays by kLevelDecay per Post-CP probe (the latest two weigh
// three quarters), and the mean is shrunk towards 0 by kLevelPrior probes' weight of no offset, so one probe
// sets half its error; a change of the level by kLevelEventFraction x the ACL is an event.
constexpr double kLevelDecay = 0.5;
constexpr double kLevelPrior = 1.0;
constexpr double kLevelEventFraction = 0.1;

double Controller::guard_level(Eigen::Index i) const {
  if (state_.guard_level_weight.size() <= i || !(state_.guard_level_weight(i) > 0.0)) return 0.0;
  return state_.guard_level_sum(i) / (state_.guard_level_weight(i) + kLevelPrior);
}

double Controller::model_compensation(Eigen::Index i) const {
  return state_.prediction(i) * state_.guard_gain(i) + guard_level(i);
}

double Controller::unbounded_compensation(Eigen::Index i) const {
  if (state_.guard_off_range(i) != 0.0) return 0.0;
  const double hold = state_.guard_check_hold(i);
  return std::isnan(hold) ? model_compensation(i) : hold;
}

// A Post-CP probe within the ACL tells what the compensated model's prediction left: a lasting offset of
// the model (a CP fit that the refits on sparse probes do not move, a step no input shows) that the gain,
// a scale, cannot take out. A breach is not learnt (NG judges it), nor an output the range switched off.
void Controller::weigh_level(double time_s, const Eigen::VectorXd& errors, const Eigen::VectorXd& residuals,
                             ControllerOutput& out) {
  if (state_.phase != Phase::PostCalibration) return;
  for (Eigen::Index i = 0; i < residuals.size(); ++i) {
    const double r = residuals(i), u = errors(i);
    if (std::isnan(r) || std::isnan(u) || !(std::abs(r) <= acl_of(static_cast<std::size_t>(i))) ||
        state_.guard_off_range(i) != 0.0)
      continue;
    const double p = u - r;  // the model's prediction when the probe ran
    state_.guard_level_sum(i) = kLevelDecay * state_.guard_level_sum(i) + (u - state_.guard_gain(i) * p);
    state_.guard_level_weight(i) = kLevelDecay * state_.guard_level_weight(i) + 1.0;
    tell_level(time_s, i, "the mean error the compensated model left at the recent Post-CP probes within the ACL",
               out);
  }
}

void Controller::reset_level(double time_s, bool refitted, ControllerOutput& out) {
  state_.guard_level_sum.setZero();
  state_.guard_level_weight.setZero();
  const char* why = refitted ? "the model refitted on the NG probes starts without one"
                             : "the NG update's fit was rejected, and the breach says the old level no longer holds";
  for (Eigen::Index i = 0; i < state_.guard_level_told.size(); ++i) tell_level(time_s, i, why, out);
}

void Controller::tell_level(double time_s, Eigen::Index i, const char* why, ControllerOutput& out) {
  const double level = guard_level(i), told = state_.guard_level_told(i);
  const double step = kLevelEventFraction * acl_of(static_cast<std::size_t>(i));
  if (!(std::abs(level - told) >= step) && !(level == 0.0 && told != 0.0)) return;
  state_.guard_level_told(i) = level;
  if (!params_.guard) return;
  std::ostringstream text;
  text << "compensation level " << told << " -> " << level << ": " << why;
  out.events.push_back(guard_event(time_s, i, level, told, text.str()));
}

std::pair<double, double> Controller::guard_range(Eigen::Index i) const {
  if (!(state_.error_low(i) <= state_.error_high(i))) return {-kInf, kInf};
  double lo = std::min(state_.error_low(i), 0.0);
  double hi = std::max(state_.error_high(i), 0.0);
  // The latest evidence probe counts at once (its successor has yet to settle it): a change that lasts
  // widens the range from the probe that first measures it.
  for (std::size_t k = state_.probes.size(); k-- > 0;)
    if (evidence(k, i)) {
      lo = std::min(lo, state_.probes[k].errors(i));
      hi = std::max(hi, state_.probes[k].errors(i));
      break;
    }
  const double margin = std::max(acl_of(static_cast<std::size_t>(i)), kRangeMargin * (hi - lo));
  return {lo - margin, hi + margin};
}

ControllerEvent Controller::guard_event(double time_s, Eigen::Index output, double value, double limit,
                                        const std::string& why) const {
  ControllerEvent e;
  e.type = ControllerEvent::Type::Guard;
  e.time_s = time_s;
  e.from = e.to = state_.phase;
  e.output = output_names_[static_cast<std::size_t>(output)];
  e.value = value;
  e.limit = limit;
  e.reason = why;  // the type names the guard: every consumer shows it beside the reason
  return e;
}

const Controller::DriftEvidence& Controller::drift_evidence() const {
  const std::vector<ProbeRecord>& probes = state_.probes;
  const auto n = static_cast<Eigen::Index>(output_names_.size());
  // The probes change by being added (at the back), dropped (at the front) or set aside as outliers
  // (weight 0, only when a pending breach is judged, which changes breach_probe): the key sees each.
  if (drift_.anchor.size() == n && drift_.probes == probes.size() && drift_.breach_probe == state_.breach_probe &&
      (probes.empty() || (drift_.first_s == probes.front().time_s && drift_.last_s == probes.back().time_s)))
    return drift_;
  constexpr double nan = std::numeric_limits<double>::quiet_NaN();
  drift_.probes = probes.size();
  drift_.breach_probe = state_.breach_probe;
  drift_.first_s = probes.empty() ? nan : probes.front().time_s;
  drift_.last_s = probes.empty() ? nan : probes.back().time_s;
  drift_.anchor = Eigen::VectorXd::Constant(n, nan);
  drift_.anchor_s = Eigen::VectorXd::Constant(n, nan);
  drift_.rate = Eigen::VectorXd::Constant(n, nan);
  std::vector<double> settled(probes.size());  // per probe the value its neighbours settle (NaN: no evidence)
  for (Eigen::Index i = 0; i < n; ++i) {
    // The latest probe that measured output i, and per probe j the change from the latest probe at
    // least kDriftSpan_s before it (shorter spans would measure the probe noise, not the drift). Only
    // evidence probes count, and not a breach the first NG probe has yet to confirm; each (but the
    // first and the latest) as the median of itself and its two neighbours: a chip on the sphere during
    // CP, which no breach judges, is no drift.
    const auto usable = [&](std::size_t k) {
      return evidence(k, i) && static_cast<long long>(k) != static_cast<long long>(state_.breach_probe);
    };
    std::fill(settled.begin(), settled.end(), nan);
    for (std::size_t k = 0, prev = probes.size(), last = probes.size(); k < probes.size(); ++k) {
      if (!usable(k)) continue;
      settled[k] = probes[k].errors(i);
      if (prev != probes.size() && last != probes.size())
        settled[prev] = median3(probes[last].errors(i), probes[prev].errors(i), probes[k].errors(i));
      last = prev;
      prev = k;
    }
    std::size_t before = 0;  // the last probe at least kDriftSpan_s before probe j
    for (std::size_t j = 0; j < probes.size(); ++j) {
      if (!usable(j)) continue;
      const double u = settled[j];
      drift_.anchor(i) = probes[j].errors(i);
      drift_.anchor_s(i) = probes[j].time_s;
      while (before + 1 < j && probes[j].time_s - probes[before + 1].time_s >= kDriftSpan_s) ++before;
      if (probes[j].time_s - probes[before].time_s < kDriftSpan_s) continue;
      for (std::size_t k = before + 1; k-- > 0;) {
        if (!usable(k)) continue;
        const double r = std::abs(u - settled[k]) / (probes[j].time_s - probes[k].time_s);
        drift_.rate(i) = std::isnan(drift_.rate(i)) ? r : std::max(drift_.rate(i), r);
        break;
      }
    }
  }
  return drift_;
}

Controller::DriftBound Controller::drift_bound(Eigen::Index i, double time_s) const {
  const DriftEvidence& e = drift_evidence();
  DriftBound b;
  if (std::isnan(e.rate(i))) return b;  // no evidence yet: no bound
  b.anchor = e.anchor(i);
  b.rate = e.rate(i);
  const double reach = kDriftFactor * b.rate * std::max(0.0, time_s - e.anchor_s(i));
  b.low = b.anchor - reach;
  b.high = b.anchor + reach;
  return b;
}

Eigen::VectorXd Controller::compensated(double time_s) const {
  Eigen::VectorXd c = state_.prediction;
  if (!params_.guard || !state_.has_model) return c;
  for (Eigen::Index i = 0; i < c.size(); ++i) {
    c(i) = unbounded_compensation(i);
    // Held by the first check (not off by the range): the error its probe measured, until the next probe.
    if (state_.guard_off_range(i) == 0.0 && !std::isnan(state_.guard_check_hold(i))) continue;
    // The model's compensation, nothing of it off by the range, within the drift bound: off by the range
    // that is the latest probe's error fading towards 0 at twice the fastest drift (0 once the bound
    // reaches 0, and with no bound yet), as where the gain is 0.
    const DriftBound b = drift_bound(i, time_s);
    c(i) = std::clamp(c(i), b.low, b.high);
  }
  return c;
}

Eigen::VectorXd Controller::compensated(double time_s, ControllerOutput& out) {
  if (params_.guard && state_.has_model)
    for (Eigen::Index i = 0; i < state_.prediction.size(); ++i) {
      const double p = state_.prediction(i);
      const auto [lo, hi] = guard_range(i);
      const bool off = !(p >= lo && p <= hi);
      const bool switched = off != (state_.guard_off_range(i) != 0.0);
      const DriftBound b = drift_bound(i, time_s);
      if (switched) {
        state_.guard_off_range(i) = off ? 1.0 : 0.0;
        std::ostringstream why;
        if (off) {
          why << "compensation off: the prediction " << p << " left the range of the measured errors widened to ["
              << lo << ", " << hi << "]";
          if (!(0.0 >= b.low && 0.0 <= b.high))
            why << "; the latest probe's error " << b.anchor << " fading towards 0 within [" << b.low << ", " << b.high
                << "] (" << kDriftFactor << " x the fastest drift the probes measured) instead";
        } else
          why << "compensation on again: the prediction " << p << " is back within [" << lo << ", " << hi << "]";
        out.events.push_back(guard_event(time_s, i, p, p > hi ? hi : lo, why.str()));
      }
      // The drift bound: an event when it starts or stops holding the compensation back by more than the
      // ACL (right after every probe it holds a little: compensation starts from the error measured).
      const double g = unbounded_compensation(i);  // the range's state is set above
      const double acl = acl_of(static_cast<std::size_t>(i));
      // Off by the range, what the bound holds back is 0 (nothing of the model).
      const bool held = !(g >= b.low - acl && g <= b.high + acl);
      // Told when it starts or stops, and again when the range switches while it holds: what it holds
      // back is then another (the model's prediction, or 0 off by the range).
      if (held == (state_.guard_held(i) != 0.0) && !(held && switched)) continue;
      state_.guard_held(i) = held ? 1.0 : 0.0;
      std::ostringstream why;
      if (held && off)
        why << "compensation held to [" << b.low << ", " << b.high << "]: off by the range, the latest probe's error "
            << b.anchor << " fades towards 0 no faster than " << kDriftFactor << " x the fastest drift the probes measured ("
            << b.rate * 3600.0 << " per h)";
      else if (held)
        why << "compensation held to [" << b.low << ", " << b.high << "]: the prediction " << g
            << " moves away from the latest probe's error " << b.anchor << " faster than " << kDriftFactor
            << " x the fastest drift the probes measured (" << b.rate * 3600.0 << " per h)";
      else if (off)
        why << "compensation held no more than the ACL: off by the range, the bound [" << b.low << ", " << b.high
            << "] reaches within the ACL of 0";
      else
        why << "compensation held no more than the ACL: the prediction " << g << ", the bound [" << b.low << ", "
            << b.high << "]";
      out.events.push_back(guard_event(time_s, i, g, g > b.high ? b.high : b.low, why.str()));
    }
  return compensated(time_s);
}

void Controller::weigh_probe(double time_s, const Eigen::VectorXd& errors, const Eigen::VectorXd& residuals,
                             ControllerOutput& out) {
  ++state_.guard_probes;
  const double weights = (1.0 - std::pow(kGuardDecay, state_.guard_probes)) / (1.0 - kGuardDecay);
  for (Eigen::Index i = 0; i < residuals.size(); ++i) {
    const double r = residuals(i);
    if (std::isnan(r) || std::isnan(errors(i))) continue;
    // The guard compares, on the recent probes, the error left with the prediction scaled by k with the
    // error without compensation: sum (u - k p)^2 is smallest in [0, 1] at k = sum(u p) / sum(p^2)
    // clamped, and never above sum u^2 (k = 0), so the gain never makes the recent probes worse.
    const double u = errors(i);
    const double p = u - r;  // the model's prediction when the probe ran
    state_.guard_cross(i) = kGuardDecay * state_.guard_cross(i) + u * p;
    state_.guard_power(i) = kGuardDecay * state_.guard_power(i) + p * p;
    state_.guard_error(i) = kGuardDecay * state_.guard_error(i) + u * u;
    if (!params_.guard || state_.guard_probes < kGuardMinProbes) continue;
    const double k = state_.guard_power(i) > 0.0 ? std::clamp(state_.guard_cross(i) / state_.guard_power(i), 0.0, 1.0) : 1.0;
    const double gain = std::round(k / kGuardStep) * kGuardStep;
    if (gain == state_.guard_gain(i)) continue;
    const auto rms = [&](double g) {
      const double energy = state_.guard_error(i) - 2.0 * g * state_.guard_cross(i) + g * g * state_.guard_power(i);
      return std::sqrt(std::max(0.0, energy) / weights);
    };
    std::ostringstream why;
    why << "compensation gain " << state_.guard_gain(i) << " -> " << gain << ": on the recent probes the error RMS is "
        << rms(0.0) << " uncompensated, " << rms(1.0) << " with the prediction, " << rms(gain) << " with gain " << gain;
    out.events.push_back(guard_event(time_s, i, gain, state_.guard_gain(i), why.str()));
    state_.guard_gain(i) = gain;
  }
}

void Controller::judge_first_check(double time_s, const Eigen::VectorXd& errors, const Eigen::VectorXd& residuals,
                                   const Eigen::VectorXd& level, ControllerOutput& out) {
  const bool judge = std::exchange(state_.first_check_due, false) && state_.phase == Phase::PostCalibration;
  for (Eigen::Index i = 0; i < errors.size(); ++i) {
    const bool was = !std::isnan(state_.guard_check_hold(i));
    bool hold = false;
    const double u = errors(i);
    double left = 0.0;
    if (judge && !std::isnan(u) && !std::isnan(residuals(i))) {
      // What the model compensated at this probe (its prediction with the gain and the level the probe ran
      // with, nothing where the range had switched it off), against no compensation: the model's first
      // judgement beyond the burst it learnt.
      const double p = u - residuals(i);
      left = u - (state_.guard_off_range(i) != 0.0 ? 0.0 : state_.guard_gain(i) * p + level(i));
      hold = std::abs(left) > std::abs(u);
    }
    if (hold == was) continue;
    state_.guard_check_hold(i) = hold ? u : std::numeric_limits<double>::quiet_NaN();
    std::ostringstream why;
    if (hold)
      why << "compensation holds the latest probe's error " << u << " until the next probe: at the first check of "
          << "the model it left " << left << ", more than the " << u << " without compensation";
    else
      why << "compensation by the model again after the probe that followed its first check";
    out.events.push_back(guard_event(time_s, i, hold ? left : u, u, why.str()));
  }
}

bool Controller::evidence(std::size_t k, Eigen::Index i) const {
  return !std::isnan(state_.probes[k].errors(i)) && state_.probes[k].weight > 0.0;
}

void Controller::settle_range(std::size_t j) {
  for (Eigen::Index i = 0; i < static_cast<Eigen::Index>(output_names_.size()); ++i) {
    std::array<double, 3> v{};
    std::size_t found = 0;
    for (std::size_t k = j + 1; k-- > 0 && found < v.size();)
      if (evidence(k, i)) v[found++] = state_.probes[k].errors(i);
    if (found < v.size()) continue;
    const double m = median3(v[0], v[1], v[2]);
    state_.error_low(i) = std::min(state_.error_low(i), m);
    state_.error_high(i) = std::max(state_.error_high(i), m);
  }
}

double Controller::next_due(double time_s) const { return schedule_->next_due(schedule_context(time_s)); }

void Controller::enter(Phase to, double time_s, ControllerOutput& out, const std::string& reason,
                       const std::string& interval_reason, bool burst_model) {
  change_phase(to, time_s, out, reason);
  // The guard's first check: a model fitted on a burst of probes (the CP's, an NG burst's) explains
  // every one of them in-sample, and how it predicts beyond the burst no probe has judged yet; under a
  // fixed interval the next probe comes at half of it (announced alone: the NC reads every interval), a
  // schedule that asks the model's uncertainty at every sample (adaptive) takes it at half the interval
  // it would choose (ScheduleContext::first_check). The paper's literal loop (no refit on a probe within
  // the ACL) keeps seed 004's schedule; no probes after CP (an interval of inf) stays none.
  const bool first_check = burst_model && params_.guard && params_.refit_on_probe && to == Phase::PostCalibration &&
                           std::isfinite(params_.post_cp_interval_s);
  const double first_s = probing::kFirstCheckFraction * params_.post_cp_interval_s;
  if (first_check && schedule_->checks_each_sample()) state_.first_check_due = true;
  if (first_check && !schedule_->checks_each_sample() && first_s < schedule_->interval(to)) {
    set_interval(first_s, time_s, out,
                 "the guard's first check of the model after the " +
                     std::string(reason.rfind("calibration", 0) == 0 ? "CP" : "NG") +
                     " probes: half the Post-CP interval");
    state_.schedule_since_s = time_s;
    state_.schedule_prediction = state_.prediction;
    state_.next_probe_due_s = time_s + first_s;
    state_.first_check_due = true;
    return;
  }
  set_interval(schedule_->interval(to), time_s, out, interval_reason);
  schedule_next(time_s, out);
}

Eigen::VectorXd Controller::thermal_errors(const ProbeMeasurement& probe) const {
  return probe.compensation.size() == probe.measured.size() && probe.compensation.size() != 0
             ? Eigen::VectorXd(probe.measured + probe.compensation)
             : probe.measured;
}

Eigen::VectorXd Controller::residuals(const Eigen::VectorXd& errors) const {
  return errors - state_.prediction;
}

ProbeMeasurement Controller::plausible(const ProbeMeasurement& probe, std::vector<ControllerEvent>* events,
                                       int* measured) const {
  ProbeMeasurement p = probe;
  if (measured) *measured = 0;
  for (Eigen::Index i = 0; i < p.measured.size() && i < static_cast<Eigen::Index>(kinds_.size()); ++i) {
    const double v = p.measured(i);
    if (std::isnan(v)) continue;
    if (measured) ++*measured;
    const auto k = static_cast<std::size_t>(i);
    const double limit = params_.plausible_limit(kinds_[k]);
    if (std::abs(v) <= limit) continue;
    p.measured(i) = std::numeric_limits<double>::quiet_NaN();
    if (!events) continue;
    ControllerEvent e;
    e.type = ControllerEvent::Type::Implausible;
    e.time_s = probe.time_s;
    e.from = e.to = state_.phase;
    e.output = output_names_[k];
    e.value = v;
    e.limit = limit;
    const std::string unit(unit_of(kinds_[k]));
    e.reason = "probe at t = " + reading(probe.time_s) + " s: " + output_names_[k] + " = " + reading(v) + " " + unit +
               " is beyond the plausible ±" + reading(limit) + " " + unit +
               " (a sensor fault?): set aside, the probe's other errors are learned";
    events->push_back(std::move(e));
  }
  return p;
}

bool Controller::breaches_acl(const ProbeMeasurement& measurement) const {
  const auto n = static_cast<Eigen::Index>(output_names_.size());
  if (measurement.measured.size() != n || state_.prediction.size() != n) return false;
  const ProbeMeasurement probe = plausible(measurement, nullptr);  // what on_probe would learn from
  const Eigen::VectorXd r = residuals(thermal_errors(probe));
  for (Eigen::Index i = 0; i < n; ++i)
    if (!std::isnan(r(i)) && std::abs(r(i)) > acl_of(static_cast<std::size_t>(i))) return true;
  return false;
}

Controller Controller::fork(AlcParameters params, SchedulePtr schedule) const& {
  return Controller(*this).fork(std::move(params), std::move(schedule));
}

Controller Controller::fork(AlcParameters params, SchedulePtr schedule) && {
  if (const std::string why = params.validate(); !why.empty()) throw std::invalid_argument(why);
  Controller c = std::move(*this);
  c.params_ = std::move(params);
  c.schedule_ = schedule ? std::move(schedule) : c.params_.schedule_policy();
  return c;
}

ControllerOutput Controller::rejected(std::string reason) const {
  ControllerOutput out;
  out.accepted = false;
  out.reason = std::move(reason);
  out.prediction = compensated(state_.now_s);
  out.next_probe_due_s = state_.next_probe_due_s;
  return out;
}

void Controller::trim() {
  if (state_.phase == Phase::Calibration || !std::isfinite(params_.learning_window_s)) return;
  auto& h = state_.history;
  if (h.time_s.empty()) return;
  // Keep the window and the warm-up of the slowest lag; trim in steps of a quarter window so the
  // copy is paid rarely (the samples kept stay below window x 1.25 + warm-up; their storage keeps its size).
  const double keep_from = learning_window_start(state_.now_s) -
                           kWarmupTimeConstants * params_.identification.tau_max_s;
  if (!(h.time_s.front() < keep_from - 0.25 * params_.learning_window_s)) return;
  const auto drop = static_cast<std::size_t>(std::lower_bound(h.time_s.begin(), h.time_s.end(), keep_from) -
                                             h.time_s.begin());
  if (drop == 0 || drop >= h.time_s.size()) return;
  h.time_s.erase(h.time_s.begin(), h.time_s.begin() + static_cast<std::ptrdiff_t>(drop));
  h.inputs.drop_front(static_cast<Eigen::Index>(drop));
  state_.history_first_index += static_cast<std::int64_t>(drop);
  // Probes whose sample is gone go too (they are older than the learning window).
  std::size_t gone = 0;
  while (gone < state_.probes.size() && state_.probes[gone].sample_index < drop) ++gone;
  state_.probes.erase(state_.probes.begin(), state_.probes.begin() + static_cast<std::ptrdiff_t>(gone));
  for (auto& p : state_.probes) p.sample_index -= drop;
  if (state_.breach_probe >= 0) state_.breach_probe -= static_cast<int>(gone);
}

bool Controller::reidentify(double time_s, ControllerOutput& out, const std::string& reason, bool keep_structure) {
  IdentificationOptions options = params_.identification;
  options.window_start_s = learning_window_start(time_s);
  // The structure is searched again when the data span has grown enough to tell more about the
  // slow dynamics; otherwise a confirming probe only refits the parameters (much cheaper).
  const double span_s = time_s - std::max(state_.start_time_s, options.window_start_s);
  const bool keep = keep_structure && state_.has_model && span_s < params_.structure_refresh * state_.structure_span_s;
  FitResult fit = keep ? refit(state_.history, output_names_, state_.probes, options, state_.predictor.model(), &lag_cache_)
                       : identify(state_.history, output_names_, state_.probes, options, &lag_cache_);
  if (fit.usable && !keep) state_.structure_span_s = span_s;
  ControllerEvent e;
  e.time_s = time_s;
  e.from = e.to = state_.phase;
  if (fit.usable) {
    // identify() hands over the predictor state after the whole input history: the new model
    // continues from the latest sample with its dynamic state current.
    ModelPredictor predictor(fit.model);
    predictor.set_state(fit.predictor_state);
    state_.prediction = predictor.prediction();
    state_.predictor = std::move(predictor);
    for (std::size_t i = 0; i < fit.outputs.size() && i < output_names_.size(); ++i)
      state_.noise_var(static_cast<Eigen::Index>(i)) = fit.outputs[i].residual_rms * fit.outputs[i].residual_rms;
    state_.has_model = true;
    state_.last_update_s = time_s;
    ++state_.updates;
    e.type = ControllerEvent::Type::ModelUpdate;
    e.reason = reason + (keep ? ", parameters refitted with the structure kept" : "") +
               (fit.message.empty() ? "" : ": " + fit.message);
  } else {
    ++state_.rejected_fits;
    e.type = ControllerEvent::Type::ModelRejected;
    e.reason = reason + ": fit not usable (" + fit.message + ")" +
               (state_.has_model ? ", previous model kept" : ", no model yet");
  }
  out.events.push_back(std::move(e));
  const bool usable = fit.usable;
  out.fit = std::move(fit);
  return usable;
}

void Controller::advance(double time_s, ControllerOutput& out) {
  if (state_.phase == Phase::Calibration) {
    // Within 1 ms, as a probe's due time (probing::reached): 124200.123 + 23400 lies 1 ulp after a
    // recorded 147600.123, and CP ended a sample later than on the same recording in whole seconds.
    if (!probing::reached(time_s, state_.start_time_s + params_.cp_duration_s)) return;
    // Try once per new probe: a failed first fit extends CP until the data suffice.
    if (static_cast<int>(state_.probes.size()) == state_.probes_at_last_attempt) return;
    state_.probes_at_last_attempt = static_cast<int>(state_.probes.size());
    if (!reidentify(time_s, out, "end of calibration phase after " + hours(time_s - state_.start_time_s))) return;
    state_.cp_end_s = time_s;
    // The drift evidence starts from the paper's Post-CP interval: the adaptive schedule's first
    // interval is that one, then the probes' residuals take over.
    if (std::isfinite(params_.post_cp_interval_s))
      for (Eigen::Index i = 0; i < state_.drift_rate.size(); ++i) {
        const double noise = std::isfinite(state_.noise_var(i)) ? state_.noise_var(i) : 0.0;
        const double budget = std::pow(params_.uncertainty_fraction * acl_of(static_cast<std::size_t>(i)), 2) - noise;
        if (budget > 0.0) state_.drift_rate(i) = budget / params_.post_cp_interval_s;
        state_.schedule_sums.row(i).setZero();
        if (budget > 0.0) state_.schedule_sums.row(i) << 1.0, 0.0, 0.0, state_.drift_rate(i), 0.0;
      }
    enter(Phase::PostCalibration, time_s, out, "calibration phase complete, first model identified",
          "Post-CP interval", true);
    return;
  }
  if (state_.phase == Phase::PostCalibration && std::isfinite(params_.update_interval_s) &&
      probing::reached(time_s, state_.last_update_s + params_.update_interval_s)) {
    // A failed periodic fit waits for the next interval too, so it is not retried every sample.
    const double due = state_.last_update_s + params_.update_interval_s;
    if (!reidentify(time_s, out, "periodic parameter update")) state_.last_update_s = due;
  }
}

std::string Controller::sample_problem(double time_s, const Eigen::VectorXd& inputs) const {
  const auto& h = state_.history;
  if (inputs.size() != static_cast<Eigen::Index>(h.input_names.size()))
    return "sample has " + std::to_string(inputs.size()) + " inputs, expected " + std::to_string(h.input_names.size());
  if (!std::isfinite(time_s)) return "sample time " + common::shortest_text(time_s) + " is not finite";
  for (Eigen::Index i = 0; i < inputs.size(); ++i)
    if (!std::isfinite(inputs[i]))
      return "sample at t = " + common::shortest_text(time_s) + " s: input '" + h.input_names[static_cast<std::size_t>(i)] +
             "' is " + common::shortest_text(inputs[i]);
  for (Eigen::Index i = 0; i < inputs.size(); ++i) {
    const InputKind kind = input_kinds_[static_cast<std::size_t>(i)];
    const double limit = params_.plausible_limit(kind);
    if (std::abs(inputs[i]) <= limit) continue;
    const std::string unit = kind == InputKind::Other ? "" : " " + std::string(unit_of(kind));
    return "sample at t = " + reading(time_s) + " s: input '" + h.input_names[static_cast<std::size_t>(i)] + "' = " +
           reading(inputs[i]) + unit + " is beyond the plausible ±" + reading(limit) + unit +
           " (a sensor fault?): sample set aside";
  }
  return {};
}

ControllerOutput Controller::on_sample(double time_s, const Eigen::VectorXd& inputs) {
  if (std::string why = sample_problem(time_s, inputs); !why.empty()) return rejected(std::move(why));
  auto& h = state_.history;
  if (state_.started && !(time_s > state_.now_s))
    return rejected("sample time " + common::shortest_text(time_s) + " s is not after the previous one (" +
                    common::shortest_text(state_.now_s) + " s)");
  ControllerOutput out;
  if (!state_.started) {
    state_.started = true;
    state_.start_time_s = time_s;
    state_.phase_start_s = time_s;
    state_.next_probe_due_s = time_s;
    set_interval(schedule_->interval(Phase::Calibration), time_s, out, "calibration phase starts");
  }
  state_.now_s = time_s;
  ++state_.samples;
  h.time_s.push_back(time_s);
  h.inputs.append(inputs);
  if (state_.has_model) state_.prediction = state_.predictor.step(time_s, inputs);
  advance(time_s, out);
  if (state_.phase == Phase::PostCalibration && schedule_->checks_each_sample() &&
      !probing::reached(time_s, state_.next_probe_due_s))
    check_due(time_s, out);
  check_move(time_s, out);
  trim();
  out.prediction = compensated(time_s, out);
  out.next_probe_due_s = state_.next_probe_due_s;
  return out;
}

ControllerOutput Controller::on_probe(const ProbeMeasurement& probe) {
  const auto n = static_cast<Eigen::Index>(output_names_.size());
  if (!state_.started) return rejected("probe before the first input sample");
  if (probe.measured.size() != n)
    return rejected("probe has " + std::to_string(probe.measured.size()) + " errors, expected " + std::to_string(n));
  if (probe.compensation.size() != 0 && probe.compensation.size() != n)
    return rejected("probe compensation has " + std::to_string(probe.compensation.size()) + " values, expected " +
                    std::to_string(n));
  if (!(probe.time_s >= state_.now_s) || !std::isfinite(probe.time_s))
    return rejected("probe at t = " + common::shortest_text(probe.time_s) + " s is before the latest sample (" +
                    common::shortest_text(state_.now_s) + " s)");
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto k = static_cast<std::size_t>(i);
    if (std::isinf(probe.measured[i]))
      return rejected("probe at t = " + common::shortest_text(probe.time_s) + " s: " + output_names_[k] + " is " +
                      common::shortest_text(probe.measured[i]));
    if (probe.compensation.size() == n && !std::isfinite(probe.compensation[i]))
      return rejected("probe at t = " + common::shortest_text(probe.time_s) + " s: compensation of " + output_names_[k] +
                      " is " + common::shortest_text(probe.compensation[i]));
  }
  // A sensor fault on one output must not spoil the others: its reading is set aside, the rest learned.
  ControllerOutput out;
  int measured = 0;
  const ProbeMeasurement usable = plausible(probe, &out.events, &measured);
  if (!out.events.empty() && static_cast<int>(out.events.size()) == measured) {
    std::string why;
    for (const ControllerEvent& e : out.events)
      why += (why.empty() ? "" : ", ") + e.output + " = " + reading(e.value) + " beyond ±" + reading(e.limit);
    return rejected("probe at t = " + reading(probe.time_s) + " s: no plausible error (" + why +
                    "; a sensor fault?): probe set aside");
  }
  const double t = probe.time_s;
  ProbeRecord record;
  record.time_s = t;
  record.sample_index = state_.history.time_s.size() - 1;
  record.errors = thermal_errors(usable);
  state_.probes.push_back(record);
  settle_range(state_.probes.size() - 1);
  ++state_.probe_cycles;

  // Residual against the prediction that was active when the probe ran.
  std::vector<std::size_t> breaches;
  const Eigen::VectorXd residuals = this->residuals(record.errors);
  // Every probe after CP is evidence for the guard, the NG probes too (a model that mispredicts breaches).
  if (state_.phase != Phase::Calibration && state_.has_model) {
    // The level the probe ran with: the first check judges the compensation in force, not one this probe moved.
    Eigen::VectorXd level(n);
    for (Eigen::Index i = 0; i < n; ++i) level(i) = guard_level(i);
    weigh_level(t, record.errors, residuals, out);
    weigh_probe(t, record.errors, residuals, out);
    if (params_.guard) judge_first_check(t, record.errors, residuals, level, out);
  }
  if (state_.has_model) weigh_schedule(t, residuals);
  state_.last_probe_s = t;
  for (Eigen::Index i = 0; i < n; ++i) {
    const double residual = residuals(i);
    if (std::isnan(residual)) continue;
    const auto k = static_cast<std::size_t>(i);
    if (std::abs(residual) > acl_of(k)) {
      breaches.push_back(k);
      if (state_.phase != Phase::Calibration) {
        ControllerEvent e;
        e.type = ControllerEvent::Type::AclBreach;
        e.time_s = t;
        e.from = e.to = state_.phase;
        e.output = output_names_[k];
        e.value = residual;
        e.limit = acl_of(k);
        e.reason = "residual beyond the action control limit";
        out.events.push_back(std::move(e));
      }
    }
  }

  switch (state_.phase) {
    case Phase::Calibration:
      state_.next_probe_due_s = next_due(t);
      advance(t, out);
      break;
    case Phase::PostCalibration:
      if (breaches.empty()) {
        if (params_.refit_on_probe) reidentify(t, out, "Post-CP probe within the ACL", true);
        schedule_next(t, out);
      } else if (!schedule_->ng_burst()) {
        // No NG burst configured: learn from what is there, right away.
        reidentify(t, out, "ACL breach (" + output_names_[breaches.front()] + "), update without NG burst");
        schedule_next(t, out);
      } else {
        ++state_.ng_phases;
        state_.ng_probes = 0;
        change_phase(Phase::NoGood, t, out, "ACL breach on " + output_names_[breaches.front()]);
        if (schedule_->confirms_breaches()) {
          // Wait for the first NG probe: a chip on the sphere breaches once, a thermal change stays.
          state_.breach_probe = static_cast<int>(state_.probes.size()) - 1;
          state_.breach_residual = Eigen::VectorXd::Constant(n, std::numeric_limits<double>::quiet_NaN());
          for (const std::size_t k : breaches)
            state_.breach_residual(static_cast<Eigen::Index>(k)) = residuals(static_cast<Eigen::Index>(k));
        } else if (params_.refit_on_probe) {
          // The model is known to be wrong now: learn from the breaching probe at once instead of
          // compensating with it for the whole NG burst; the NG update follows with more data.
          reidentify(t, out, "ACL breach, immediate update before the NG burst");
        }
        state_.next_probe_due_s = next_due(t);
        set_interval(schedule_->interval(Phase::NoGood), t, out, "NG interval");
      }
      break;
    case Phase::NoGood: {
      ++state_.ng_probes;
      if (state_.breach_probe >= 0) {
        // The first NG probe judges the breach: confirmed when some breached output is still off
        // the same way by more than half its ACL.
        Eigen::VectorXd acl(n);
        for (Eigen::Index i = 0; i < n; ++i) acl(i) = acl_of(static_cast<std::size_t>(i));
        const bool confirmed = schedule_->confirmed(state_.breach_residual, residuals, acl);
        const auto breach = static_cast<std::size_t>(state_.breach_probe);
        state_.breach_probe = -1;
        if (!confirmed) {
          state_.probes[breach].weight = 0.0;
          ControllerEvent e;
          e.type = ControllerEvent::Type::OutlierRejected;
          e.time_s = t;
          e.from = e.to = state_.phase;
          e.value = state_.probes[breach].time_s;
          e.reason = "the breach of the probe at t = " + common::shortest_text(state_.probes[breach].time_s) +
                     " s is not confirmed by the first NG probe: set aside as an outlier";
          out.events.push_back(std::move(e));
          if (!breaches.empty()) {
            // This probe breaches on its own: it becomes the breach that the next NG probe judges.
            state_.breach_probe = static_cast<int>(state_.probes.size()) - 1;
            state_.breach_residual = Eigen::VectorXd::Constant(n, std::numeric_limits<double>::quiet_NaN());
            for (const std::size_t k : breaches)
              state_.breach_residual(static_cast<Eigen::Index>(k)) = residuals(static_cast<Eigen::Index>(k));
            state_.ng_probes = 0;
            state_.next_probe_due_s = next_due(t);
            break;
          }
          if (params_.refit_on_probe) reidentify(t, out, "Post-CP probe within the ACL", true);
          enter(Phase::PostCalibration, t, out, "breach not confirmed (outlier probe)", "Post-CP interval");
          break;
        }
        // The model is known to be wrong: learn from both probes at once instead of compensating
        // with it for the whole NG burst; the NG update follows with more data.
        if (params_.refit_on_probe) reidentify(t, out, "ACL breach confirmed by the first NG probe, immediate update");
      }
      const probing::NgStep step = schedule_->after_ng_probe(schedule_context(t), !breaches.empty());
      if (step == probing::NgStep::Continue) {
        state_.next_probe_due_s = next_due(t);
        break;
      }
      if (step == probing::NgStep::UpdateAndContinue) {
        reidentify(t, out, "NG probe " + std::to_string(state_.ng_probes) + " still beyond the ACL");
        state_.next_probe_due_s = next_due(t);
        break;
      }
      const bool update = step == probing::NgStep::UpdateAndLeave;
      // The first check after an NG update whether its fit was accepted or not: a rejected fit leaves the
      // model that breached in force, which the early probe judges all the more.
      if (update) {
        const bool refitted =
            reidentify(t, out, "NG phase complete after " + std::to_string(state_.ng_probes) + " probes");
        // The level starts again also where the fit was rejected: the breach said the old one no longer holds.
        reset_level(t, refitted, out);
      }
      enter(Phase::PostCalibration, t, out, update ? "NG measurements complete" : "NG probe within the ACL",
            "Post-CP interval", update);
      break;
    }
  }
  // After a probe asked for in CP or NG (request_probe told the NC its own interval), the phase's again;
  // after CP, schedule_next says it. Without a request the interval of these phases never differs.
  if (state_.phase == Phase::Calibration || state_.phase == Phase::NoGood)
    set_interval(schedule_->interval(state_.phase), t, out, std::string(to_string(state_.phase)) +
                                                                " interval again after the probe asked for");
  out.prediction = compensated(t, out);
  out.next_probe_due_s = state_.next_probe_due_s;
  return out;
}

ControllerOutput Controller::request_probe(double time_s, const std::string& reason) {
  if (!state_.started) return rejected("probe requested before the first input sample");
  if (!std::isfinite(time_s) || time_s < state_.now_s)
    return rejected("probe requested at t = " + common::shortest_text(time_s) + " s, before the latest sample (" +
                    common::shortest_text(state_.now_s) + " s)");
  ControllerOutput out;
  // The interval the NC is told counts from the latest probe (or the phase start); the phase's own is
  // told again after the probe (on_probe, schedule_next).
  if (!probing::reached(time_s, state_.next_probe_due_s))
    due_now(time_s, std::max(state_.last_probe_s, state_.phase_start_s), "probe requested: " + reason, out);
  out.prediction = compensated(time_s);
  out.next_probe_due_s = state_.next_probe_due_s;
  return out;
}

ControllerOutput Controller::on_tick(double time_s) {
  ControllerOutput out;
  if (!state_.started) return out;
  advance(time_s, out);
  out.prediction = compensated(time_s, out);
  out.next_probe_due_s = state_.next_probe_due_s;
  return out;
}

}  // namespace alc
