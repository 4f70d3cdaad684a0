#pragma once
// The static baseline: multiple linear regression of seed 003 Eq. 7, y = b0 + sum_i b_i T_i, on the
// inputs at the probe times, fitted once (e.g. on the CP measurements) and never updated.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "alc/thermal_model.hpp"

namespace alc {

struct StaticRegression {
  std::vector<std::string> input_names;
  std::vector<std::string> output_names;
  Eigen::VectorXd intercept;      // [µm] or [µm/m] b0 per output
  Eigen::MatrixXd coefficients;   // outputs x inputs: b_i [µm per input unit]
  // Predicted errors for one input sample (same order as input_names); NaN inputs count as 0 change.
  Eigen::VectorXd predict(const Eigen::VectorXd& inputs) const;
  bool empty() const { return output_names.empty(); }
};

struct StaticRegressionFit {
  bool usable = false;            // true when every output had at least 2 measurements
  std::string message;            // reason when not usable
  StaticRegression model;         // outputs without data predict 0
  std::vector<int> measurements;  // per output
};

// The measurements of output `output` that a static model learns from: per probe with a finite value
// of that output, the history row at or before its time (with finite inputs) and the value.
struct ProbeRows {
  std::vector<Eigen::Index> rows;  // into history.inputs
  std::vector<double> values;      // [µm] or [µm/m]
  std::vector<double> time_s;      // [s] probe times
};
ProbeRows probe_rows(const InputHistory& history, const std::vector<ProbeRecord>& probes, Eigen::Index output,
                     Eigen::Index outputs);

// The inputs that vary over `rows` of history.inputs (the others would only duplicate an intercept).
std::vector<Eigen::Index> varying_inputs(const InputHistory& history, const std::vector<Eigen::Index>& rows);

// Least squares (QR, relative ridge as in IdentificationOptions::ridge) on the input sample at or
// before each probe time. Inputs constant over the measurements get b_i = 0. Never throws for data.
StaticRegressionFit fit_static_regression(const InputHistory& history, const std::vector<std::string>& output_names,
                                          const std::vector<ProbeRecord>& probes, double ridge = 1e-6);

}  // namespace alc
