#include "least_squares.hpp"

#include <Eigen/QR>
#include <Eigen/SVD>
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

Conditioning conditioning(const Eigen::MatrixXd& phi, const Eigen::VectorXd& w, double weighted_rss) {
  Conditioning c;
  const Eigen::Index m = phi.rows();
  const Eigen::Index p = phi.cols();
  c.parameter_std = Eigen::VectorXd::Constant(p, std::numeric_limits<double>::infinity());
  if (m == 0 || p == 0 || !phi.allFinite()) {
    c.condition = std::numeric_limits<double>::infinity();
    return c;
  }
  const Eigen::VectorXd s = column_scales(phi, w);
  const Eigen::MatrixXd a = w.array().sqrt().matrix().asDiagonal() * phi * s.cwiseInverse().asDiagonal();
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(a, Eigen::ComputeThinV);
  const Eigen::VectorXd& sv = svd.singularValues();
  const double smax = sv.size() ? sv(0) : 0.0;
  const double smin = sv.size() ? sv(sv.size() - 1) : 0.0;
  c.condition = (sv.size() < p || smin <= 0.0) ? std::numeric_limits<double>::infinity() : smax / smin;
  if (m > p && std::isfinite(c.condition)) {
    // Var(e_i) = sigma2 / w_i; sigma2 estimated from the weighted residuals.
    const double sigma2 = weighted_rss / static_cast<double>(m - p);
    const Eigen::MatrixXd v = svd.matrixV() * sv.cwiseInverse().asDiagonal();
    // cov(theta_scaled) = sigma2 V S^-2 V^T, theta = theta_scaled / s
    for (Eigen::Index j = 0; j < p; ++j) c.parameter_std(j) = std::sqrt(sigma2 * v.row(j).squaredNorm()) / s(j);
  }
  return c;
}

}  // namespace alc::detail
