#include "scenarios/scenario_figures.hpp"

#include <algorithm>
#include <cmath>

#include "alc/error_kind.hpp"
#include "alc/indicators.hpp"

namespace alc::scenarios {

ScenarioFigures scenario_figures(const Scenario& scenario) {
  ScenarioFigures f;
  f.samples = scenario.samples();
  if (f.samples >= 2) {
    f.duration_h = (scenario.time_s.back() - scenario.time_s.front()) / 3600.0;
    f.step_s = scenario.time_s[1] - scenario.time_s[0];
  }
  for (std::size_t c = 0; c < scenario.output_names.size(); ++c) {
    ErrorFigures e;
    e.name = scenario.output_names[c];
    e.angular = alc::error_kind(e.name) == alc::ErrorKind::Angular;
    std::vector<double> magnitudes;
    for (Eigen::Index r = 0; r < scenario.outputs.rows(); ++r) {
      const double v = scenario.outputs(r, static_cast<Eigen::Index>(c));
      if (!std::isnan(v)) magnitudes.push_back(std::abs(v));
    }
    e.measurements = static_cast<int>(magnitudes.size());
    e.peak = magnitudes.empty() ? std::nan("") : *std::max_element(magnitudes.begin(), magnitudes.end());
    e.p99 = alc::percentile(magnitudes, 0.99);
    f.errors.push_back(e);
  }
  return f;
}

}  // namespace alc::scenarios
