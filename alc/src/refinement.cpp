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

// One term of the robust cost of a residual r: ½ rho(r²) as Ceres' HuberLoss / CauchyLoss of scale
// a define rho, its derivative psi(r), and the curvature of the Newton step: Huber's own second
// derivative (1 inside the scale, 0 outside; the cost is convex), Cauchy's IRLS weight psi(r)/r
// (its second derivative is negative beyond the scale: the weight keeps the step a descent step,
// the majorise-minimise step of iteratively reweighted least squares).
struct RobustTerm {
  double cost;
  double psi;
  double curvature;
};

RobustTerm robust_term(RobustLoss loss, double a, double r) {
  const double s = r * r;
  switch (loss) {
    case RobustLoss::Huber:
      if (s <= a * a) return {0.5 * s, r, 1.0};
      return {a * std::abs(r) - 0.5 * a * a, std::copysign(a, r), 0.0};
    case RobustLoss::Cauchy: {
      const double q = 1.0 + s / (a * a);
      return {0.5 * a * a * std::log(q), r / q, 1.0 / q};
    }
    case RobustLoss::None: break;
  }
  return {0.5 * s, r, 1.0};
}

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
  using Eigen::Index;
  Refinement out;
  out.theta = theta0;
  const Index m = phi.rows();
  const Index p = phi.cols();
  // The column-scaled problem (as in solve_weighted_ridge): rows sqrt(w) phi / s, t = s theta, the
  // ridge ridge·Σw on every gain.
  const Eigen::VectorXd sw = w.unaryExpr([](double v) { return v > 0.0 ? std::sqrt(v) : 0.0; });
  const double wsum = sw.squaredNorm();
  Eigen::VectorXd s(p);
  for (Index j = 0; j < p; ++j) {
    const double ms = wsum > 0.0 ? sw.cwiseProduct(phi.col(j)).squaredNorm() / wsum : 0.0;
    s(j) = ms > 0.0 && std::isfinite(ms) ? std::sqrt(ms) : 1.0;
  }
  const Eigen::MatrixXd a = sw.asDiagonal() * phi * s.cwiseInverse().asDiagonal();
  const Eigen::VectorXd b = sw.cwiseProduct(y);
  const double lambda2 = settings.ridge > 0.0 ? settings.ridge * wsum : 0.0;
  const double scale = settings.scale;
  Eigen::VectorXd r(m);
  Eigen::VectorXd psi(m);
  Eigen::VectorXd curvature(m);
  // Cost ½ Σ rho(r_i²) + ½ lambda2 Σ_{j >= 1} t_j² (Ceres' definition); fills r, psi, curvature.
  const auto evaluate = [&](const Eigen::VectorXd& t) {
    r.noalias() = a * t - b;
    double cost = 0.5 * lambda2 * t.tail(p - 1).squaredNorm();
    for (Index i = 0; i < m; ++i) {
      const RobustTerm term = robust_term(settings.loss, scale, r(i));
      cost += term.cost;
      psi(i) = term.psi;
      curvature(i) = term.curvature;
    }
    return cost;
  };
  Eigen::VectorXd t = s.cwiseProduct(theta0);
  double cost = p > 0 && m > 0 && a.allFinite() && b.allFinite() && t.allFinite() ? evaluate(t) : kInf;
  out.cost_before = cost;
  out.cost_after = cost;
  if (!std::isfinite(cost)) {
    out.message = "robust refinement failed (non-finite cost at the start), least-squares gains kept";
    return out;
  }
  // Newton steps with a backtracking (Armijo) line search. Huber: the cost is convex and piecewise
  // quadratic, and a full step that keeps the set of residuals within the scale lands on the
  // minimum. Cauchy: IRLS steps, each lowers the cost, to the local minimum next to theta0.
  Eigen::MatrixXd h(p, p);
  Eigen::VectorXd g(p);
  Eigen::VectorXd step(p);
  Eigen::VectorXd trial(p);
  Eigen::LLT<Eigen::MatrixXd> llt(p);
  for (int iteration = 0; iteration < settings.max_iterations; ++iteration) {
    g.noalias() = a.transpose() * psi;
    g.tail(p - 1) += lambda2 * t.tail(p - 1);
    bool solved = false;
    for (int attempt = 0; attempt < 2 && !solved; ++attempt) {
      if (attempt == 1) {
        // Singular Newton matrix (e.g. every residual beyond the Huber scale): IRLS weights psi/r.
        for (Index i = 0; i < m; ++i) curvature(i) = r(i) != 0.0 ? psi(i) / r(i) : 1.0;
      }
      h.setZero();
      h.selfadjointView<Eigen::Lower>().rankUpdate(a.transpose() * curvature.cwiseSqrt().asDiagonal());
      h.diagonal().tail(p - 1).array() += lambda2;
      llt.compute(h);
      solved = llt.info() == Eigen::Success;
    }
    if (!solved) break;
    step = -llt.solve(g);
    const double slope = g.dot(step);  // the predicted decrease of a full step is -slope / 2
    if (!(slope < 0.0) || -0.5 * slope <= 1e-14 * cost) break;  // at the minimum (to rounding)
    double alpha = 1.0;
    double trial_cost = kInf;
    bool accepted = false;
    for (int halving = 0; halving < 40 && !accepted; ++halving) {
      if (halving > 0) alpha *= 0.5;
      trial = t + alpha * step;
      trial_cost = evaluate(trial);
      accepted = trial_cost <= cost + 1e-4 * alpha * slope;
    }
    if (!accepted) break;  // no decrease along the step: t is the minimum to rounding
    const bool negligible = cost - trial_cost <= 1e-12 * cost;
    t = trial;
    cost = trial_cost;
    if (negligible) break;
  }
  const Eigen::VectorXd theta = t.cwiseQuotient(s);
  out.cost_after = cost;
  if (!theta.allFinite() || !std::isfinite(cost)) {
    out.message = "robust refinement failed (non-finite solution), least-squares gains kept";
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
