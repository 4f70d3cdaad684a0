#pragma once
// Probing against a recording: what a probe cycle would have read.
// docs/design.md ("Probing semantics on a recording"): a scheduled probe at time t takes the first recorded measurement at or after t.
#include <Eigen/Core>
#include <cstddef>
#include <optional>
#include <vector>

namespace alc::probing {

class RecordedProbes {
 public:
  // `time_s` [s] per row, `errors` rows x outputs with NaN where nothing was measured.
  RecordedProbes(const std::vector<double>& time_s, const Eigen::MatrixXd& errors);

  // Row of the first recorded measurement (any output measured) at or after `due_s`, if any.
  std::optional<std::size_t> first_at_or_after(double due_s) const;
  // True if row `row` holds a measurement of at least one output.
  bool is_measured(std::size_t row) const;
  // Rows that hold measurements, in time order.
  const std::vector<std::size_t>& measured_rows() const { return rows_; }

 private:
  std::vector<double> times_;       // [s] times of measured rows
  std::vector<std::size_t> rows_;   // their row indices
  std::vector<bool> measured_;      // per row
};

}  // namespace alc::probing
