#include "runtime/recorded_source.hpp"

#include <stdexcept>

namespace alc::runtime {

RecordedSource::RecordedSource(const scenarios::Scenario& scenario, std::size_t first_row)
    : scenario_(scenario), recorded_(scenario.time_s, scenario.outputs) {
  seek(first_row);
}

void RecordedSource::seek(std::size_t row) {
  if (row > scenario_.samples())
    throw std::invalid_argument("recorded source: row " + std::to_string(row) + " is beyond the " +
                                std::to_string(scenario_.samples()) + " rows of the scenario");
  row_ = row;
}

std::optional<Sample> RecordedSource::next(double before_s) {
  if (row_ >= scenario_.samples() || !(scenario_.time_s[row_] < before_s)) return std::nullopt;
  Sample s;
  s.index = static_cast<std::int64_t>(row_);
  s.time_s = scenario_.time_s[row_];
  s.inputs = scenario_.inputs.row(static_cast<Eigen::Index>(row_)).transpose();
  ++row_;
  return s;
}

std::optional<ProbeMeasurement> RecordedSource::probe(double due_s, const Sample& sample) {
  const auto row = static_cast<std::size_t>(sample.index);
  // The first measured row at or after the due time that reaches the controller: one it set aside (an
  // implausible input) passes the probe on to the next measured row, not past it for the rest of the run.
  const auto first = recorded_.first_at_or_after(due_s);
  if (!recorded_.is_measured(row) || !first || *first > row) return std::nullopt;
  ProbeMeasurement p;
  p.time_s = sample.time_s;
  p.measured = scenario_.outputs.row(static_cast<Eigen::Index>(row)).transpose();
  return p;
}

}  // namespace alc::runtime
