#pragma once
// The figures of a scenario's measured errors that docs and `alc simulate --summary` report:
// duration, and per error the peak and the P99 of the absolute measured values.
#include <string>
#include <vector>

#include "scenarios/scenario.hpp"

namespace alc::scenarios {

struct ErrorFigures {
  std::string name;        // "E_X0C"
  bool angular = false;    // unit µm/m when true, µm otherwise
  int measurements = 0;    // non-empty cells
  double peak = 0.0;       // [µm] or [µm/m] max |measured|
  double p99 = 0.0;        // [µm] or [µm/m] 99th percentile of |measured| (alc::percentile, paper's Eq. 3–5)
};

struct ScenarioFigures {
  double duration_h = 0.0;  // [h] last minus first time
  double step_s = 0.0;      // [s] first sampling interval
  std::size_t samples = 0;
  std::vector<ErrorFigures> errors;
};

ScenarioFigures scenario_figures(const Scenario& scenario);

}  // namespace alc::scenarios
