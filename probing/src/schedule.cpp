#include "probing/schedule.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace alc {

std::string_view to_string(Phase phase) {
  switch (phase) {
    case Phase::Calibration: return "CP";
    case Phase::PostCalibration: return "Post-CP";
    case Phase::NoGood: return "NG";
  }
  return "?";
}

}  // namespace alc

namespace alc::probing {

bool SchedulePolicy::confirmed(const Eigen::VectorXd& breach, const Eigen::VectorXd& residual,
                               const Eigen::VectorXd& acl) const {
  for (Eigen::Index i = 0; i < breach.size() && i < residual.size() && i < acl.size(); ++i) {
    const double before = breach(i);
    if (std::isnan(before) || std::isnan(residual(i))) continue;
    if (before * residual(i) > 0.0 && std::abs(residual(i)) > 0.5 * acl(i)) return true;
  }
  return false;
}

double PaperSchedule::interval(Phase phase) const {
  switch (phase) {
    case Phase::Calibration: return options_.cp_interval_s;
    case Phase::PostCalibration: return options_.post_cp_interval_s;
    case Phase::NoGood: return options_.ng_interval_s;
  }
  return kNever;
}

bool PaperSchedule::ng_burst() const {
  return std::isfinite(options_.ng_interval_s) && options_.ng_measurements != 0.0;
}

NgStep PaperSchedule::after_ng_probe(const ScheduleContext& ctx, bool breaching) const {
  if (std::isfinite(options_.ng_measurements))
    return ctx.ng_probes < options_.ng_measurements ? NgStep::Continue : NgStep::UpdateAndLeave;
  return breaching ? NgStep::UpdateAndContinue : NgStep::Leave;
}

namespace {

double entry(const Eigen::VectorXd& v, Eigen::Index i) { return i < v.size() && std::isfinite(v(i)) ? v(i) : 0.0; }
double since(const ScheduleContext& ctx) { return std::isfinite(ctx.since_s) ? ctx.since_s : ctx.now_s; }

}  // namespace

std::pair<double, int> AdaptiveSchedule::post_cp_interval(const ScheduleContext& ctx) const {
  const double paper = interval(Phase::PostCalibration);
  if (!std::isfinite(paper)) return {paper, -1};  // no probes after CP: none, adaptive or not
  double best = kNever;
  int which = -1;
  bool evidence = false;
  for (Eigen::Index i = 0; i < ctx.drift_rate.size() && i < ctx.acl.size(); ++i) {
    const double rate = ctx.drift_rate(i);
    if (!(rate >= 0.0) || !std::isfinite(rate)) continue;
    evidence = true;
    // What is left of the budget (fraction x ACL)² after the fit's noise and the prediction's change.
    const double dy = entry(ctx.prediction_change, i);
    const double left = std::pow(adaptive_.fraction * ctx.acl(i), 2) - entry(ctx.noise_var, i) -
                        entry(ctx.kappa, i) * dy * dy;
    const double dt = left <= 0.0 ? 0.0 : rate > 0.0 ? left / rate : kNever;
    if (dt < best || which < 0) {
      best = dt;
      which = static_cast<int>(i);
    }
  }
  if (!evidence) return {paper, -1};
  const double dt = std::clamp(best, adaptive_.min_interval_s, adaptive_.max_interval_s);
  // The guard's first check of a model fitted on a burst: half the interval, not below the minimum.
  return {ctx.first_check ? std::max(adaptive_.min_interval_s, kFirstCheckFraction * dt) : dt, which};
}

double AdaptiveSchedule::next_due(const ScheduleContext& ctx) const {
  if (ctx.phase != Phase::PostCalibration) return PaperSchedule::next_due(ctx);
  return since(ctx) + post_cp_interval(ctx).first;
}

std::string AdaptiveSchedule::explain(const ScheduleContext& ctx) const {
  if (ctx.phase != Phase::PostCalibration) return {};
  const auto [dt, which] = post_cp_interval(ctx);
  const double from = since(ctx);
  const double elapsed = ctx.now_s - from;
  const bool now = elapsed > 0.0;  // asked at a sample after the decision: the probe is due now
  char text[512];
  if (which < 0) {
    std::snprintf(text, sizeof text, "adaptive: next probe in %.2f h (no drift evidence yet: the Post-CP interval)",
                  dt / 3600.0);
    return text;
  }
  const auto i = static_cast<Eigen::Index>(which);
  const std::string name = ctx.output_names && static_cast<std::size_t>(which) < ctx.output_names->size()
                               ? (*ctx.output_names)[static_cast<std::size_t>(which)]
                               : "output " + std::to_string(which);
  const double noise = entry(ctx.noise_var, i);
  const double dy = entry(ctx.prediction_change, i);
  const double moved = entry(ctx.kappa, i) * dy * dy;
  const char* bound = ctx.first_check ? " (the guard's first check of the model after a burst of probes: half the "
                                       "interval, at least the minimum)"
                      : dt <= adaptive_.min_interval_s ? " (the minimum interval)"
                      : dt >= adaptive_.max_interval_s ? " (the maximum interval)" : "";
  if (now) {
    std::snprintf(text, sizeof text,
                  "adaptive: probe due now, %.2f h after the last: the predicted sigma of %s reaches %.2f x its ACL "
                  "%.3g: the prediction moved by %.3g since (kappa %.3g: %.3g), drift %.3g per h, fit noise %.3g "
                  "(squared units)",
                  elapsed / 3600.0, name.c_str(),
                  adaptive_.fraction, ctx.acl(i), dy, entry(ctx.kappa, i), moved, ctx.drift_rate(i) * 3600.0, noise);
    return text;
  }
  if (!std::isfinite(dt)) {
    std::snprintf(text, sizeof text,
                  "adaptive: no probe due: the predicted sigma of %s stays below %.2f x its ACL %.3g without a drift "
                  "(kappa %.3g, fit noise %.3g, squared units), unless the prediction moves",
                  name.c_str(), adaptive_.fraction, ctx.acl(i), entry(ctx.kappa, i), noise);
    return text;
  }
  std::snprintf(text, sizeof text,
                "adaptive: next probe in %.2f h%s: the predicted sigma of %s reaches %.2f x its ACL %.3g "
                "(drift %.3g per h, kappa %.3g, fit noise %.3g, squared units), earlier if the prediction moves",
                dt / 3600.0, bound, name.c_str(), adaptive_.fraction, ctx.acl(i), ctx.drift_rate(i) * 3600.0,
                entry(ctx.kappa, i), noise);
  return text;
}

double productivity_percent(double probe_cycles, double duration_s, double cycle_time_s) {
  if (!(duration_s > 0.0)) return std::nan("");
  return (1.0 - probe_cycles * cycle_time_s / duration_s) * 100.0;
}

}  // namespace alc::probing
