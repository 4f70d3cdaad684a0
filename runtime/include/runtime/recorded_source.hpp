#pragma once
// A recording (scenario CSV rows, or a simulated load case) as a driver Source.
//
// Probing semantics (docs/design.md): a probe due at time t takes the first recorded measurement
// (a row with any output measured) at or after t; what it reads is that row's outputs, NaN where an
// output was not measured. The recording's errors are open-loop (no compensation was in force).
#include <cstddef>

#include "probing/recorded_probes.hpp"
#include "runtime/driver.hpp"
#include "scenarios/scenario.hpp"

namespace alc::runtime {

class RecordedSource : public Source {
 public:
  // Starts at row `first_row` (a resumed run continues where it stopped).
  explicit RecordedSource(const scenarios::Scenario& scenario, std::size_t first_row = 0);
  std::optional<Sample> next(double before_s) override;
  std::optional<ProbeMeasurement> probe(double due_s, const Sample& sample) override;
  std::size_t position() const { return row_; }          // next row
  void seek(std::size_t row);                            // continue at `row` (throws beyond the end)
  bool finished() const { return row_ >= scenario_.samples(); }
  const scenarios::Scenario& scenario() const { return scenario_; }
  const probing::RecordedProbes& recorded() const { return recorded_; }

 private:
  const scenarios::Scenario& scenario_;
  probing::RecordedProbes recorded_;
  std::size_t row_ = 0;
};

}  // namespace alc::runtime
