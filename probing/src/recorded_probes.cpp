#include "probing/recorded_probes.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "probing/schedule.hpp"

namespace alc::probing {

RecordedProbes::RecordedProbes(const std::vector<double>& time_s, const Eigen::MatrixXd& errors)
    : measured_(time_s.size(), false) {
  if (errors.rows() != static_cast<Eigen::Index>(time_s.size()))
    throw std::invalid_argument("RecordedProbes: errors has " + std::to_string(errors.rows()) + " rows for " +
                                std::to_string(time_s.size()) + " times");
  for (std::size_t r = 0; r < time_s.size(); ++r) {
    const bool any = !errors.row(static_cast<Eigen::Index>(r)).array().isNaN().all();
    measured_[r] = any;
    if (any) {
      times_.push_back(time_s[r]);
      rows_.push_back(r);
    }
  }
}

std::optional<std::size_t> RecordedProbes::first_at_or_after(double due_s) const {
  const auto it = std::lower_bound(times_.begin(), times_.end(), due_s - kDueTolerance_s);
  if (it == times_.end()) return std::nullopt;
  return rows_[static_cast<std::size_t>(it - times_.begin())];
}

bool RecordedProbes::is_measured(std::size_t row) const { return row < measured_.size() && measured_[row]; }

}  // namespace alc::probing
