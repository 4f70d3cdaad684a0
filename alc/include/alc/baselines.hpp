#pragma once
// The seeds' static models beside ALC (docs/baselines.md): fitted once on the CP measurements, as
// the static MLR baseline is, and never updated. Pure math (libsvm for the SVR), no I/O.
//   mlr    multiple linear regression, seed 003 Eq. 7 (the static baseline, fit_static_regression)
//   lasso  seed 003 Eq. 13 by coordinate descent on standardised inputs, lambda by 5-fold CV
//   svr    epsilon-SVR with an RBF kernel (seed 003 Eq. 8-12, seed 000), libsvm, C and gamma by CV
//   gm     grey model GM(1,N), seed 003 Eq. 1-6, on time-weighted accumulations (unequal intervals)
//   ols    OLS with p-values, inputs with p < 0.05 kept, OLS refitted on them (seed 000, Tab. 5)
#include <Eigen/Core>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "alc/static_regression.hpp"
#include "alc/thermal_model.hpp"

namespace alc {

enum class BaselineKind { Mlr, Lasso, Svr, Gm, Ols };

std::string_view baseline_name(BaselineKind kind);
std::optional<BaselineKind> parse_baseline(std::string_view name);
const std::vector<BaselineKind>& all_baselines();  // in the order above
// "mlr,svr" or "all" (a name twice counts once). Throws std::invalid_argument naming the bad value
// and the valid names.
std::vector<BaselineKind> parse_baseline_list(std::string_view text);

// ---- the fits on one output's data (X: measurements x inputs, y: measurements) ----

// Contiguous folds like scikit-learn's KFold(k) without shuffling: the first m % k folds have one
// more row. fold_of[i] is the fold of row i. No random draws.
std::vector<int> contiguous_folds(Eigen::Index m, int k);

// Minimises Eq. 13, 1/(2N) |y - X a|^2 + lambda |a|_1, by cyclic coordinate descent. X and y are
// used as given (centre them for a model with intercept). Stops when no coefficient moves by more
// than tol (relative to the largest) or after max_sweeps.
Eigen::VectorXd lasso_coordinate_descent(const Eigen::MatrixXd& X, const Eigen::VectorXd& y, double lambda,
                                         double tol = 1e-12, int max_sweeps = 100000);

struct LinearBaseline {
  double intercept = 0.0;          // [µm] or [µm/m]
  Eigen::VectorXd coefficients;    // per input, in the input's unit
  Eigen::VectorXd p_values;        // OLS: per input (NaN where not estimated); empty otherwise
  double lambda = 0.0;             // Lasso: the chosen lambda on standardised inputs
  std::vector<bool> selected;      // Lasso: non-zero coefficient; OLS: p < alpha
};

// Lasso on inputs standardised to mean 0 and standard deviation 1 (population) and y centred;
// lambda from a grid of `n_lambda` values log-spaced from lambda_max = max|X'y|/N down to
// 1e-3 lambda_max, the one with the least mean squared error over contiguous_folds(m, folds)
// (each training part centred on its own means). Coefficients back in the inputs' units.
LinearBaseline fit_lasso(const Eigen::MatrixXd& X, const Eigen::VectorXd& y, int folds = 5, int n_lambda = 50);

// OLS with intercept and the p-value of each coefficient (two-sided t test, as F(1, m - p)); then,
// if `alpha` > 0, OLS again on the inputs with p < alpha only. Constant or linearly dependent
// inputs get no coefficient (p NaN).
LinearBaseline fit_ols(const Eigen::MatrixXd& X, const Eigen::VectorXd& y, double alpha = 0.05);

struct SvrParameters {
  double C = 1.0;
  double gamma = 1.0;              // K(u, v) = exp(-gamma |u - v|^2) on the standardised inputs
  double epsilon = 0.05;           // tube half-width in units of the output's standard deviation
  double tolerance = 1e-3;         // libsvm's stopping tolerance
};

// epsilon-SVR (libsvm) on inputs standardised like fit_lasso's and y standardised. Holds the
// training data libsvm's model refers to; copies share it.
class SvrBaseline {
 public:
  SvrBaseline() = default;
  static SvrBaseline fit(const Eigen::MatrixXd& X, const Eigen::VectorXd& y, const SvrParameters& parameters);
  // C in {1, 10, 100, 1000} x gamma in {0.1, 1, 10} / inputs, the pair with the least mean squared
  // error over contiguous_folds(m, 5) (fewer than 10 rows: C = 10, gamma = 1 / inputs).
  static SvrBaseline fit_by_cv(const Eigen::MatrixXd& X, const Eigen::VectorXd& y, double epsilon = 0.05);
  double predict(const Eigen::VectorXd& x) const;  // NaN inputs count as their training mean
  const SvrParameters& parameters() const { return parameters_; }
  int support_vectors() const;

 private:
  struct Impl;
  std::shared_ptr<const Impl> impl_;
  SvrParameters parameters_;
};

// GM(1,N) of seed 003 on unequally spaced data, in hours: the output's and the inputs' increases
// since the first measurement, dy = y - y(t1) and du = u - u(t1); their accumulations (AGO) as time
// integrals from t1, Y1(t) of dy by the trapezoid rule over the measurements (Eq. 4's background
// value), U_i(t) of du_i over the input samples (held from sample to sample); the grey equation
// dy(t_k) + a Y1(t_k) = sum_i b_i U_i(t_k) for k = 2..m by least squares with a >= 1 / (t_m - t1)
// (a stable time constant no longer than the data's span: a = that bound if the unconstrained
// solution lies below it, b then refitted); the whitened equation
// (Eq. 5 with u = sum b_i U_i) solved exactly: dy' = -a dy + sum_i b_i du_i from dy(t1) = 0.
struct GreyBaseline {
  double a = 0.0;                  // [1/h] development coefficient
  Eigen::VectorXd b;               // [unit of y per input unit and hour] driving coefficients
  double t1_s = 0.0;               // [s] first measurement
  double y1 = 0.0;                 // measured output at t1
  Eigen::VectorXd u1;              // inputs at t1
  bool ok = false;                 // false: predicts y1 (too few measurements, no finite solution)
  bool a_constrained = false;      // least squares gave a < a_min = 1 / (span of the measurements)
  // The prediction at every sample of a series (time in s, inputs per sample), simulated from t1;
  // samples before t1 get y1. A NaN input holds its last finite value.
  Eigen::VectorXd predict_series(const std::vector<double>& time_s, const Eigen::MatrixXd& inputs) const;
};
// `measured_at`: probe times [s] (increasing) and values; `history`: the input samples.
GreyBaseline fit_grey(const std::vector<double>& measured_at, const std::vector<double>& values,
                      const InputHistory& history);

// ---- one kind for all outputs, fitted on the CP measurements ----

struct BaselineModel {
  BaselineKind kind = BaselineKind::Mlr;
  std::vector<std::string> input_names, output_names;
  StaticRegression mlr;                 // mlr: the static baseline (its predictions, bit for bit)
  std::vector<LinearBaseline> linear;   // mlr, lasso, ols: per output
  std::vector<SvrBaseline> svr;         // per output
  std::vector<GreyBaseline> grey;       // per output
  std::vector<int> measurements;        // per output
  // The inputs chosen per output (lasso: non-zero weight; ols: p < 0.05); empty for the others.
  std::vector<std::vector<std::string>> selected_inputs() const;
  // Predictions (rows.size() x outputs) at rows of a series; the GM simulates the series up to the
  // last row. Outputs with fewer than 2 measurements predict 0.
  Eigen::MatrixXd predict(const std::vector<double>& time_s, const Eigen::MatrixXd& inputs,
                          const std::vector<std::size_t>& rows) const;
};

// On the input sample at or before each probe time, as fit_static_regression. Never throws for data.
BaselineModel fit_baseline(BaselineKind kind, const InputHistory& history, const std::vector<std::string>& output_names,
                           const std::vector<ProbeRecord>& probes);

}  // namespace alc
