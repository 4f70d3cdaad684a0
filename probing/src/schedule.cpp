#include "probing/schedule.hpp"

#include <cmath>

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

double productivity_percent(double probe_cycles, double duration_s, double cycle_time_s) {
  if (!(duration_s > 0.0)) return std::nan("");
  return (1.0 - probe_cycles * cycle_time_s / duration_s) * 100.0;
}

}  // namespace alc::probing
