#pragma once
// A scenario: time series of model inputs and (sparse) measured thermal errors.
// This is the in-memory form of the scenario CSV contract (docs/design.md, "Scenario CSV").
#include <Eigen/Core>
#include <string>
#include <vector>

namespace alc::scenarios {

struct Scenario {
  std::vector<std::string> input_names;   // model inputs: temperatures [°C], speeds [rpm], 0/1 states
  std::vector<std::string> output_names;  // measured errors, names start with "E_"
  std::vector<double> time_s;             // sample times [s], strictly increasing
  Eigen::MatrixXd inputs;                 // samples x inputs
  Eigen::MatrixXd outputs;                // samples x outputs [µm] or [µm/m]; NaN where not measured

  std::size_t samples() const { return time_s.size(); }
  // Index of a named input or output column, or -1.
  int input_index(const std::string& name) const;
  int output_index(const std::string& name) const;
};

// The content hash of a scenario: checksum64 (common/byte_codec.hpp) of its names, times and values
// as 16 hex digits. Another recording under the same file name has another hash.
std::string content_hash(const Scenario& scenario);

}  // namespace alc::scenarios
