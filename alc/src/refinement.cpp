#include "refinement.hpp"

#include <ceres/ceres.h>

#include <cmath>
#include <memory>

#include "lag_filter.hpp"

namespace alc::detail {
namespace {

std::unique_ptr<ceres::LossFunction> make_loss(const RobustSettings& s) {
  switch (s.loss) {
    case RobustLoss::Huber: return std::make_unique<ceres::HuberLoss>(s.scale);
    case RobustLoss::Cauchy: return std::make_unique<ceres::CauchyLoss>(s.scale);
    case RobustLoss::None: break;
  }
  return nullptr;
}

ceres::Problem::Options problem_options() {
  ceres::Problem::Options o;
  o.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;  // one loss shared by all blocks
  return o;
}

ceres::Solver::Options solver_options(int max_iterations) {
  ceres::Solver::Options o;
  o.linear_solver_type = ceres::DENSE_QR;
  o.max_num_iterations = max_iterations;
  o.logging_type = ceres::SILENT;
  o.minimizer_progress_to_stdout = false;
  o.num_threads = 1;
  return o;
}

// Weighted RMS of each lag column: the scale of the ridge term (as in solve_weighted_ridge).
Eigen::VectorXd ridge_weights(const Eigen::MatrixXd& phi, const Eigen::VectorXd& w, double ridge) {
  const double wsum = w.sum();
  Eigen::VectorXd r(phi.cols() - 1);
  for (Eigen::Index j = 1; j < phi.cols(); ++j) {
    const double ms = (w.array() * phi.col(j).array().square()).sum() / wsum;
    r(j - 1) = std::sqrt(ridge * wsum * (ms > 0.0 ? ms : 1.0));
  }
  return r;
}

// One measurement on fixed regressors: r = sqrt(w) (phi theta - y).
class LinearResidual final : public ceres::CostFunction {
 public:
  LinearResidual(Eigen::VectorXd phi, double y) : phi_(std::move(phi)), y_(y) {
    set_num_residuals(1);
    mutable_parameter_block_sizes()->push_back(static_cast<int>(phi_.size()));
  }
  bool Evaluate(double const* const* p, double* r, double** j) const override {
    const Eigen::Map<const Eigen::VectorXd> theta(p[0], phi_.size());
    r[0] = phi_.dot(theta) - y_;
    if (j && j[0]) Eigen::Map<Eigen::VectorXd>(j[0], phi_.size()) = phi_;
    return true;
  }

 private:
  Eigen::VectorXd phi_;  // sqrt(w) * regressor row
  double y_;             // sqrt(w) * measurement
};

// Ridge on the gains: r_j = c_j theta_j for j >= 1 (the offset is not penalised).
class RidgeResidual final : public ceres::CostFunction {
 public:
  explicit RidgeResidual(Eigen::VectorXd c) : c_(std::move(c)) {
    set_num_residuals(static_cast<int>(c_.size()));
    mutable_parameter_block_sizes()->push_back(static_cast<int>(c_.size() + 1));
  }
  bool Evaluate(double const* const* p, double* r, double** j) const override {
    const auto n = c_.size();
    for (Eigen::Index i = 0; i < n; ++i) r[i] = c_(i) * p[0][i + 1];
    if (j && j[0]) {
      Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> jac(j[0], n, n + 1);
      jac.setZero();
      for (Eigen::Index i = 0; i < n; ++i) jac(i, i + 1) = c_(i);
    }
    return true;
  }

 private:
  Eigen::VectorXd c_;
};

bool finite_summary(const ceres::Solver::Summary& s) {
  return s.IsSolutionUsable() && std::isfinite(s.initial_cost) && std::isfinite(s.final_cost);
}

// Simulates the lags of the chosen inputs for the current log time constants, with their
// derivatives, at the measurement samples. Ceres calls it before every evaluation.
class LagSimulation final : public ceres::EvaluationCallback {
 public:
  LagSimulation(const OutputErrorData& data, const double* log_tau, Eigen::Index poles)
      : data_(data), log_tau_(log_tau), poles_(poles) {
    const auto lags = static_cast<Eigen::Index>(data.inputs.size()) * poles;
    x_.resize(static_cast<Eigen::Index>(data.samples.size()), lags);
    dx_.resize(x_.rows(), lags);
  }
  void PrepareForEvaluation(bool /*evaluate_jacobians*/, bool new_point) override {
    if (new_point) simulate();
  }
  const Eigen::MatrixXd& x() const { return x_; }
  const Eigen::MatrixXd& dx() const { return dx_; }  // d x / d log tau of the lag's own pole
  Eigen::Index poles() const { return poles_; }

 private:
  void simulate() {
    const InputHistory& h = *data_.history;
    const auto n = static_cast<Eigen::Index>(h.time_s.size());
    Eigen::Index col = 0;
    for (const int i : data_.inputs) {
      const double ref = data_.reference(i);
      for (Eigen::Index k = 0; k < poles_; ++k, ++col) {
        const double tau = std::exp(log_tau_[k]);
        const double u0 = h.inputs(0, i);
        double held = std::isfinite(u0) ? u0 : ref;
        double x = held - ref;
        double d = 0.0;
        double last_t = h.time_s[0];
        double last_dt = -1.0;
        double a = 0.0;
        std::size_t next = 0;
        for (Eigen::Index s = 0; s < n && next < data_.samples.size(); ++s) {
          if (s > 0) {
            const double dt = h.time_s[static_cast<std::size_t>(s)] - last_t;
            if (dt > 0.0) {
              if (dt != last_dt) {
                a = lag_factor(dt, tau);
                last_dt = dt;
              }
              const double v = held - ref;
              d = a * d + a * dt / tau * (x - v);
              x = lag_step(x, a, v);
              last_t = h.time_s[static_cast<std::size_t>(s)];
            }
            const double u = h.inputs(s, i);
            if (std::isfinite(u)) held = u;
          }
          while (next < data_.samples.size() && data_.samples[next] == s) {
            x_(static_cast<Eigen::Index>(next), col) = x;
            dx_(static_cast<Eigen::Index>(next), col) = d;
            ++next;
          }
        }
      }
    }
  }

  const OutputErrorData& data_;
  const double* log_tau_;
  Eigen::Index poles_;
  Eigen::MatrixXd x_;
  Eigen::MatrixXd dx_;
};

class OutputErrorResidual final : public ceres::CostFunction {
 public:
  OutputErrorResidual(const LagSimulation& sim, Eigen::Index row, double sqrt_w, double y)
      : sim_(sim), row_(row), sqrt_w_(sqrt_w), y_(y) {
    set_num_residuals(1);
    mutable_parameter_block_sizes()->push_back(static_cast<int>(sim.x().cols() + 1));
    mutable_parameter_block_sizes()->push_back(static_cast<int>(sim.poles()));
  }
  bool Evaluate(double const* const* p, double* r, double** j) const override {
    const Eigen::Index lags = sim_.x().cols();
    const Eigen::Index poles = sim_.poles();
    const Eigen::Map<const Eigen::VectorXd> theta(p[0], lags + 1);
    r[0] = sqrt_w_ * (theta(0) + sim_.x().row(row_).dot(theta.tail(lags)) - y_);
    if (!j) return std::isfinite(r[0]);
    if (j[0]) {
      j[0][0] = sqrt_w_;
      for (Eigen::Index c = 0; c < lags; ++c) j[0][c + 1] = sqrt_w_ * sim_.x()(row_, c);
    }
    if (j[1]) {
      for (Eigen::Index k = 0; k < poles; ++k) j[1][k] = 0.0;
      for (Eigen::Index c = 0; c < lags; ++c) j[1][c % poles] += sqrt_w_ * theta(c + 1) * sim_.dx()(row_, c);
    }
    return std::isfinite(r[0]);
  }

 private:
  const LagSimulation& sim_;
  Eigen::Index row_;
  double sqrt_w_;
  double y_;
};

}  // namespace

Refinement refine_gains(const Eigen::MatrixXd& phi, const Eigen::VectorXd& y, const Eigen::VectorXd& w,
                        const Eigen::VectorXd& theta0, const RobustSettings& settings) {
  Refinement out;
  out.theta = theta0;
  const std::unique_ptr<ceres::LossFunction> loss = make_loss(settings);
  ceres::Problem problem(problem_options());
  Eigen::VectorXd theta = theta0;
  for (Eigen::Index i = 0; i < phi.rows(); ++i) {
    if (!(w(i) > 0.0)) continue;
    const double sw = std::sqrt(w(i));
    problem.AddResidualBlock(new LinearResidual(sw * phi.row(i).transpose(), sw * y(i)), loss.get(), theta.data());
  }
  if (settings.ridge > 0.0 && phi.cols() > 1)
    problem.AddResidualBlock(new RidgeResidual(ridge_weights(phi, w, settings.ridge)), nullptr, theta.data());
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options(settings.max_iterations), &problem, &summary);
  out.cost_before = summary.initial_cost;
  out.cost_after = summary.final_cost;
  if (!finite_summary(summary) || !theta.allFinite()) {
    out.message = "robust refinement failed (" + summary.message + "), least-squares gains kept";
    return out;
  }
  out.theta = theta;
  out.ok = true;
  return out;
}

Refinement refine_output_error(const OutputErrorData& data, const std::vector<double>& tau0_s,
                               const Eigen::VectorXd& theta0, const RobustSettings& settings) {
  Refinement out;
  out.theta = theta0;
  out.tau_s = tau0_s;
  const auto poles = static_cast<Eigen::Index>(tau0_s.size());
  if (poles == 0 || data.inputs.empty()) {
    out.message = "output error: no lag to refine";
    return out;
  }
  Eigen::VectorXd theta = theta0;
  Eigen::VectorXd log_tau(poles);
  for (Eigen::Index k = 0; k < poles; ++k) log_tau(k) = std::log(tau0_s[static_cast<std::size_t>(k)]);
  LagSimulation sim(data, log_tau.data(), poles);
  const std::unique_ptr<ceres::LossFunction> loss = make_loss(settings);
  ceres::Problem::Options po = problem_options();
  po.evaluation_callback = &sim;
  ceres::Problem problem(po);
  for (std::size_t i = 0; i < data.samples.size(); ++i) {
    if (!(data.w(static_cast<Eigen::Index>(i)) > 0.0)) continue;
    const double sw = std::sqrt(data.w(static_cast<Eigen::Index>(i)));
    problem.AddResidualBlock(new OutputErrorResidual(sim, static_cast<Eigen::Index>(i), sw, data.y(static_cast<Eigen::Index>(i))),
                             loss.get(), theta.data(), log_tau.data());
  }
  if (problem.NumResidualBlocks() == 0) {
    out.message = "output error: no weighted measurement";
    return out;
  }
  for (Eigen::Index k = 0; k < poles; ++k) {
    problem.SetParameterLowerBound(log_tau.data(), static_cast<int>(k), std::log(data.tau_lower_s));
    problem.SetParameterUpperBound(log_tau.data(), static_cast<int>(k), std::log(data.tau_upper_s));
  }
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options(settings.max_iterations), &problem, &summary);
  out.cost_before = summary.initial_cost;
  out.cost_after = summary.final_cost;
  if (!finite_summary(summary) || !theta.allFinite() || !log_tau.allFinite()) {
    out.message = "output-error refinement failed (" + summary.message + "), fixed-pole fit kept";
    return out;
  }
  out.theta = theta;
  for (Eigen::Index k = 0; k < poles; ++k) out.tau_s[static_cast<std::size_t>(k)] = std::exp(log_tau(k));
  out.ok = true;
  return out;
}

}  // namespace alc::detail
