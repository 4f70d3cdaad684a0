#pragma once
// Replay of a scenario through the ALC controller, with the paper's indicators (seed 004, Eq. 1–7)
// and a static baseline (multiple linear regression fitted once on the CP measurements).
//
// Probing semantics (DESIGN.md): a scheduled probe at time t takes the first recorded measurement
// at or after t; evaluation after CP uses every recorded measurement, comparing it with the
// prediction that was active at that time (before the probe, if any, was learned from).
#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "alc/controller.hpp"
#include "alc/static_regression.hpp"
#include "probing/recorded_probes.hpp"
#include "scenarios/scenario.hpp"

namespace alc::scenarios {

class ReplaySession;

// Hooks for what the replay does, e.g. history recording or NC output. Default: nothing.
class ReplayObserver {
 public:
  virtual ~ReplayObserver() = default;
  // After a row is fully processed (a consistent point to save the session's state).
  virtual void on_row_done(const ReplaySession& /*session*/) {}
  virtual void on_sample(std::size_t /*row*/, double /*time_s*/, const Eigen::VectorXd& /*inputs*/,
                         const ControllerOutput& /*out*/) {}
  virtual void on_probe(std::size_t /*row*/, const ProbeMeasurement& /*probe*/, const ControllerOutput& /*out*/) {}
};

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

struct ReplayReport {
  std::vector<OutputIndicators> outputs;    // ALC
  std::vector<OutputIndicators> baseline;   // static MLR fitted on the CP measurements
  double Pd = 0.0;                          // [%] Eq. 7
  int M = 0;                                // probe cycles, all phases
  int ng_phases = 0;
  int updates = 0;                          // successful identifications, incl. the first
  int rejected_fits = 0;
  double cp_end_s = kInf;                   // [s] end of the calibration phase
  double duration_s = 0.0;                  // [s] T_total
  double identification_s = 0.0;            // [s] wall time spent in cycles that identified
  double total_s = 0.0;                     // [s] wall time of the replay
  // Mean P99 over the linear (resp. angular) outputs; NaN if there are none.
  double mean_p99(ErrorKind kind, bool of_baseline = false) const;
  double mean_p99_uncompensated(ErrorKind kind) const;
};

// A replay that can stop at a scenario time and resume from its saved state, bit for bit.
struct ReplayState {
  std::size_t next_row = 0;                 // first row not yet replayed
  ControllerState controller;
  bool baseline_fitted = false;
  StaticRegression baseline;
  std::vector<double> eval_time_s;          // [s] recorded measurements after CP
  std::vector<Eigen::VectorXd> eval_measured, eval_predicted, eval_baseline;
  double identification_s = 0.0;            // [s] wall time (not part of decisions)
  double total_s = 0.0;
};

class ReplaySession {
 public:
  ReplaySession(const Scenario& scenario, AlcParameters parameters);
  ReplaySession(const Scenario& scenario, AlcParameters parameters, ReplayState state);

  // Replays rows with time_s < stop_time_s (all rows by default).
  void run(double stop_time_s = kInf, ReplayObserver* observer = nullptr);
  bool finished() const { return state_.next_row >= scenario_.samples(); }
  ReplayState state() const;
  const Controller& controller() const { return controller_; }
  ReplayReport report() const;
  // Recorded measurements after CP with the ALC prediction: time_s, E_…, E_…_pred.
  Scenario residuals() const;

 private:
  const Scenario& scenario_;
  probing::RecordedProbes recorded_;
  Controller controller_;
  ReplayState state_;
};

// Replays the whole scenario.
ReplayReport replay(const Scenario& scenario, const AlcParameters& parameters, ReplayObserver* observer = nullptr);

}  // namespace alc::scenarios
