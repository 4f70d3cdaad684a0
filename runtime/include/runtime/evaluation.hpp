#pragma once
// The paper's indicators of a replay (seed 004, Eq. 1–7) beside a static baseline (a multiple
// linear regression fitted once on the CP measurements), as a driver observer.
//
// Evaluation after CP uses every recorded measurement of the scenario, comparing it with the
// prediction that was active at that time (before the probe, if any, was learned from).
#include <Eigen/Core>
#include <string>
#include <vector>

#include "alc/baselines.hpp"
#include "alc/error_kind.hpp"
#include "alc/static_regression.hpp"
#include "runtime/driver.hpp"
#include "scenarios/scenario.hpp"

namespace alc::runtime {

// Indicators of one error output over the evaluation span (end of CP to end of run).
struct OutputIndicators {
  std::string name;
  ErrorKind kind = ErrorKind::Linear;
  int measurements = 0;               // recorded measurements evaluated
  double PV = 0.0;                    // [%] Eq. 1
  double RMSE = 0.0;                  // [µm] or [µm/m] Eq. 2
  double P99 = 0.0;                   // [µm] or [µm/m] Eq. 3–5 on |residual|
  double SMAPE = 0.0;                 // [%] Eq. 6
  double P99_uncompensated = 0.0;     // [µm] or [µm/m] P99 of |measured|
};

// One of the seeds' static models (alc/baselines.hpp), fitted once on the CP measurements.
struct BaselineReport {
  std::string name;                         // mlr, lasso, svr, gm, ols
  std::vector<OutputIndicators> outputs;
  // lasso and ols: per output, the inputs the model selected; empty for the others.
  std::vector<std::pair<std::string, std::vector<std::string>>> selected;
  // Per output, the CP measurements the model was fitted on (0 before the end of CP). Fewer than the
  // inputs + 1 (the linear models' and GM(1,N)'s parameters) is no fit: underdetermined.
  std::vector<std::pair<std::string, int>> fitted_on;
  int parameters = 0;                       // the inputs + 1
  double mean_p99(ErrorKind kind) const;    // NaN if there is no output of that kind
};

struct ReplayReport {
  std::vector<OutputIndicators> outputs;    // ALC
  std::vector<OutputIndicators> baseline;   // static MLR fitted on the CP measurements
  std::vector<BaselineReport> baselines;    // the seeds' models asked for (--baselines), in that order
  double Pd = 0.0;                          // [%] Eq. 7
  int M = 0;                                // probe cycles, all phases
  int ng_phases = 0;
  int updates = 0;                          // successful identifications, incl. the first
  int rejected_fits = 0;
  std::int64_t rejected_samples = 0;       // samples the controller set aside (an input beyond its limit, …)
  // Recorded measurements after CP beyond the plausible limit, left out of the indicators (a sensor
  // fault is no error to judge by), and the first of them ("E_X0C at time_s 108000: 5000").
  std::int64_t implausible_measurements = 0;
  std::string first_implausible;
  double cp_end_s = kInf;                   // [s] end of the calibration phase
  double duration_s = 0.0;                  // [s] T_total
  double identification_s = 0.0;            // [s] wall time spent in cycles that identified
  double total_s = 0.0;                     // [s] wall time of the replay
  // Mean P99 over the linear (resp. angular) outputs; NaN if there are none.
  double mean_p99(ErrorKind kind, bool of_baseline = false) const;
  double mean_p99_uncompensated(ErrorKind kind) const;
};

// The indicators of one output from its measured errors and the predictions at the same times
// (Eq. 1-6; P99_uncompensated against zero). NaN everywhere when there is no measurement.
OutputIndicators evaluate_output(const std::string& name, const std::vector<double>& measured,
                                 const std::vector<double>& predicted);

// Collects, per recorded measurement after CP, the measured errors, the ALC prediction and the
// baseline's. Memory: 3 doubles per output per recorded measurement after CP (the indicators need
// every residual); none per sample.
class Evaluation : public Observer {
 public:
  // `baselines`: the seeds' static models to fit at the end of CP and evaluate on the same rows
  // (not kept by a snapshot: a resumed run has none).
  explicit Evaluation(const scenarios::Scenario& scenario, std::vector<BaselineKind> baselines = {});
  void on_cycle(const Cycle& cycle) override;
  void on_sample_done(const Sample& sample, const Controller& controller, std::int64_t next_index) override;

  // The indicators after `rows` rows of the scenario were replayed.
  ReplayReport report(const Controller& controller, std::size_t rows) const;
  // Recorded measurements after CP with the ALC prediction: time_s, E_…, E_…_pred.
  scenarios::Scenario residuals() const;

  // What a snapshot keeps (bounded): the baseline. The evaluated rows are rebuilt on resume from
  // the stored predictions (rebuild()).
  bool baseline_fitted() const { return baseline_fitted_; }
  const StaticRegression& baseline() const { return baseline_; }
  void restore_baseline(bool fitted, StaticRegression baseline);
  // Adds the evaluation of row `row` with the prediction that was active there (resume: the stored
  // prediction of that sample), if the row is a recorded measurement at or after `cp_end_s`.
  void rebuild(std::size_t row, const Eigen::VectorXd& predicted, double cp_end_s);
  std::size_t evaluated() const { return time_s_.size(); }
  double time_at(std::size_t i) const { return time_s_[i]; }               // [s] of evaluated row i
  Eigen::VectorXd baseline_at(std::size_t i) const;                         // the baseline's prediction there

 private:
  void add(std::size_t row, const Eigen::VectorXd& predicted);
  const scenarios::Scenario& scenario_;
  std::vector<BaselineKind> baseline_kinds_;
  std::vector<BaselineModel> baseline_models_;  // fitted at the end of CP, in the order of baseline_kinds_
  bool baseline_fitted_ = false;
  StaticRegression baseline_;
  Eigen::VectorXd predicted_;                 // active before this row's probe
  std::vector<double> time_s_;                // [s] evaluated rows
  std::vector<std::size_t> rows_;             // scenario rows evaluated
  std::vector<double> measured_, predicted_rows_, baseline_rows_;  // outputs per evaluated row, row-major
};

}  // namespace alc::runtime
