#include "least_squares.hpp"

#include <Eigen/Cholesky>
#include <Eigen/QR>
#include <Eigen/Eigenvalues>
#include <cmath>
#include <limits>

namespace alc::detail {
namespace {

// Weighted RMS of each column; 1 for columns that vanish, so that they stay zero after scaling.
Eigen::VectorXd column_scales(const Eigen::MatrixXd& phi, const Eigen::VectorXd& w) {
  const double wsum = w.sum();
  Eigen::VectorXd s(phi.cols());
  for (Eigen::Index j = 0; j < phi.cols(); ++j) {
    const double ms = wsum > 0.0 ? (w.array() * phi.col(j).array().square()).sum() / wsum : 0.0;
    s(j) = (ms > 0.0 && std::isfinite(ms)) ? std::sqrt(ms) : 1.0;
  }
  return s;
}

}  // namespace

LinearFit solve_weighted_ridge(const Eigen::MatrixXd& phi, const Eigen::VectorXd& y, const Eigen::VectorXd& w,
                               double ridge, Eigen::Index unpenalised_columns) {
  LinearFit fit;
  const Eigen::Index m = phi.rows();
  const Eigen::Index p = phi.cols();
  fit.weight_sum = w.sum();
  fit.theta = Eigen::VectorXd::Zero(p);
  if (!phi.allFinite() || !y.allFinite() || !w.allFinite() || !(fit.weight_sum > 0.0)) return fit;
  const Eigen::VectorXd s = column_scales(phi, w);
  const Eigen::VectorXd sw = w.array().sqrt();
  const Eigen::Index penalised = ridge > 0.0 ? p - unpenalised_columns : 0;
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(m + penalised, p);
  Eigen::VectorXd b = Eigen::VectorXd::Zero(m + penalised);
  a.topRows(m) = sw.asDiagonal() * phi * s.cwiseInverse().asDiagonal();
  b.head(m) = sw.cwiseProduct(y);
  const double lambda = std::sqrt(ridge * fit.weight_sum);
  for (Eigen::Index j = 0; j < penalised; ++j) a(m + j, unpenalised_columns + j) = lambda;
  // With ridge rows every penalised column is independent, so plain Householder QR is safe (and
  // faster in the structure search); without them column pivoting handles rank deficiency.
  const Eigen::VectorXd theta_scaled = penalised == p - unpenalised_columns && penalised > 0
                                           ? Eigen::VectorXd(Eigen::HouseholderQR<Eigen::MatrixXd>(a).solve(b))
                                           : Eigen::VectorXd(Eigen::ColPivHouseholderQR<Eigen::MatrixXd>(a).solve(b));
  fit.theta = theta_scaled.cwiseQuotient(s);
  const Eigen::VectorXd r = y - phi * fit.theta;
  fit.weighted_rss = (w.array() * r.array().square()).sum();
  fit.ok = fit.theta.allFinite() && std::isfinite(fit.weighted_rss);
  if (!fit.ok) fit.theta.setZero();
  return fit;
}

SubsetLeastSquares::SubsetLeastSquares(const Eigen::MatrixXd& z, const Eigen::VectorXd& y, const Eigen::VectorXd& w,
                                       double ridge)
    : z_(z), y_(y), w_(w), ridge_(ridge), weight_sum_(w.sum()) {
  finite_ = z.allFinite() && y.allFinite() && w.allFinite() && weight_sum_ > 0.0;
  if (!finite_) return;
  scale_ = column_scales(z, w);
  const Eigen::VectorXd sw = w.array().sqrt();
  const Eigen::MatrixXd a = sw.asDiagonal() * z * scale_.cwiseInverse().asDiagonal();
  gram_ = Eigen::MatrixXd::Zero(z.cols(), z.cols());
  gram_.selfadjointView<Eigen::Lower>().rankUpdate(a.transpose());
  rhs_ = a.transpose() * sw.cwiseProduct(y);
}

LinearFit SubsetLeastSquares::fit(const std::vector<Eigen::Index>& cols, Eigen::Index unpenalised,
                                  Eigen::VectorXd* residual) const {
  const auto p = static_cast<Eigen::Index>(cols.size());
  const auto residual_of = [&](const LinearFit& f) {
    Eigen::VectorXd r = y_;
    for (Eigen::Index j = 0; j < p; ++j) r -= f.theta(j) * z_.col(cols[static_cast<std::size_t>(j)]);
    return r;
  };
  const auto fallback = [&] {
    Eigen::MatrixXd phi(z_.rows(), p);
    for (Eigen::Index j = 0; j < p; ++j) phi.col(j) = z_.col(cols[static_cast<std::size_t>(j)]);
    const LinearFit f = solve_weighted_ridge(phi, y_, w_, ridge_, unpenalised);
    if (residual) *residual = residual_of(f);
    return f;
  };
  if (!finite_ || (!(ridge_ > 0.0) && p > unpenalised)) return fallback();
  Eigen::MatrixXd h(p, p);
  Eigen::VectorXd b(p);
  const double lambda2 = ridge_ * weight_sum_;
  for (Eigen::Index j = 0; j < p; ++j) {
    const Eigen::Index cj = cols[static_cast<std::size_t>(j)];
    for (Eigen::Index k = j; k < p; ++k) {
      const Eigen::Index ck = cols[static_cast<std::size_t>(k)];
      h(k, j) = ck >= cj ? gram_(ck, cj) : gram_(cj, ck);  // lower triangle of the stored lower triangle
    }
    if (j >= unpenalised) h(j, j) += lambda2;
    b(j) = rhs_(cj);
  }
  const Eigen::LLT<Eigen::MatrixXd, Eigen::Lower> llt(h);
  if (llt.info() != Eigen::Success) return fallback();
  LinearFit f;
  f.weight_sum = weight_sum_;
  f.theta = llt.solve(b);
  for (Eigen::Index j = 0; j < p; ++j) f.theta(j) /= scale_(cols[static_cast<std::size_t>(j)]);
  const Eigen::VectorXd r = residual_of(f);
  f.weighted_rss = (w_.array() * r.array().square()).sum();
  f.ok = f.theta.allFinite() && std::isfinite(f.weighted_rss);
  if (!f.ok) f.theta.setZero();
  if (residual) *residual = f.ok ? r : y_;  // theta = 0 when not ok, as solve_weighted_ridge
  return f;
}

Conditioning conditioning(const Eigen::MatrixXd& phi, const Eigen::VectorXd& w, double weighted_rss) {
  Conditioning c;
  const Eigen::Index m = phi.rows();
  const Eigen::Index p = phi.cols();
  c.parameter_std = Eigen::VectorXd::Constant(p, std::numeric_limits<double>::infinity());
  c.condition = std::numeric_limits<double>::infinity();
  if (m < p || p == 0 || !phi.allFinite()) return c;  // fewer singular values than columns: singular
  const Eigen::VectorXd s = column_scales(phi, w);
  const Eigen::MatrixXd a = w.array().sqrt().matrix().asDiagonal() * phi * s.cwiseInverse().asDiagonal();
  // a = Q R: the singular values of the p x p R are those of a. The largest is the square root of
  // the largest eigenvalue of R^T R, the smallest the inverse of the largest singular value of
  // R^-1 (largest eigenvalues are accurate to rounding, the smallest of R^T R would not be).
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(a);
  const Eigen::MatrixXd r = qr.matrixQR().topRows(p).triangularView<Eigen::Upper>();
  if ((r.diagonal().array() == 0.0).any()) return c;
  Eigen::MatrixXd r_inv = Eigen::MatrixXd::Identity(p, p);
  r.triangularView<Eigen::Upper>().solveInPlace(r_inv);
  if (!r_inv.allFinite()) return c;
  const auto largest_eigenvalue = [](const Eigen::MatrixXd& gram) {
    return Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(gram, Eigen::EigenvaluesOnly).eigenvalues().maxCoeff();
  };
  const double smax = std::sqrt(largest_eigenvalue(r.transpose() * r));
  const double inv_smin = std::sqrt(largest_eigenvalue(r_inv * r_inv.transpose()));
  if (!(inv_smin > 0.0) || !std::isfinite(smax * inv_smin)) return c;
  c.condition = smax * inv_smin;
  if (m > p) {
    // Var(e_i) = sigma2 / w_i; sigma2 estimated from the weighted residuals.
    const double sigma2 = weighted_rss / static_cast<double>(m - p);
    // cov(theta_scaled) = sigma2 (a^T a)^-1 = sigma2 R^-1 R^-T, theta = theta_scaled / s
    for (Eigen::Index j = 0; j < p; ++j) c.parameter_std(j) = std::sqrt(sigma2 * r_inv.row(j).squaredNorm()) / s(j);
  }
  return c;
}

}  // namespace alc::detail
