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

std::pair<double, int> AdaptiveSchedule::post_cp_interval(const ScheduleContext& ctx) const {
  const double paper = interval(Phase::PostCalibration);
  if (!std::isfinite(paper)) return {paper, -1};  // no probes after CP: none, adaptive or not
  double best = kNever;
  int which = -1;
  for (Eigen::Index i = 0; i < ctx.drift_rate.size() && i < ctx.acl.size(); ++i) {
    const double rate = ctx.drift_rate(i);
    if (!(rate > 0.0) || !std::isfinite(rate)) continue;
    const double noise = i < ctx.noise_var.size() && std::isfinite(ctx.noise_var(i)) ? ctx.noise_var(i) : 0.0;
    const double budget = std::pow(adaptive_.fraction * ctx.acl(i), 2) - noise;
    const double dt = budget > 0.0 ? budget / rate : 0.0;
    if (dt < best) {
      best = dt;
      which = static_cast<int>(i);
    }
  }
  if (which < 0) return {paper, -1};
  return {std::clamp(best, adaptive_.min_interval_s, adaptive_.max_interval_s), which};
}

double AdaptiveSchedule::next_due(const ScheduleContext& ctx) const {
  if (ctx.phase != Phase::PostCalibration) return PaperSchedule::next_due(ctx);
  return ctx.now_s + post_cp_interval(ctx).first;
}

std::string AdaptiveSchedule::explain(const ScheduleContext& ctx) const {
  if (ctx.phase != Phase::PostCalibration) return {};
  const auto [dt, which] = post_cp_interval(ctx);
  char text[256];
  if (which < 0) {
    std::snprintf(text, sizeof text, "adaptive: next probe in %.2f h (no drift evidence yet: the Post-CP interval)",
                  dt / 3600.0);
    return text;
  }
  const auto i = static_cast<Eigen::Index>(which);
  const std::string name = ctx.output_names && static_cast<std::size_t>(which) < ctx.output_names->size()
                               ? (*ctx.output_names)[static_cast<std::size_t>(which)]
                               : "output " + std::to_string(which);
  const double noise = i < ctx.noise_var.size() && std::isfinite(ctx.noise_var(i)) ? ctx.noise_var(i) : 0.0;
  const char* bound = dt <= adaptive_.min_interval_s ? " (the minimum interval)"
                      : dt >= adaptive_.max_interval_s ? " (the maximum interval)" : "";
  std::snprintf(text, sizeof text,
                "adaptive: next probe in %.2f h%s: the predicted sigma of %s reaches %.2f x its ACL %.3g "
                "(drift %.3g per h, fit noise %.3g, squared units)",
                dt / 3600.0, bound, name.c_str(), adaptive_.fraction, ctx.acl(i), ctx.drift_rate(i) * 3600.0, noise);
  return text;
}

double productivity_percent(double probe_cycles, double duration_s, double cycle_time_s) {
  if (!(duration_s > 0.0)) return std::nan("");
  return (1.0 - probe_cycles * cycle_time_s / duration_s) * 100.0;
}

}  // namespace alc::probing
