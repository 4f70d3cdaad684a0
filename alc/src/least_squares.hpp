#pragma once
// Weighted, ridge-regularised linear least squares by column-pivoting Householder QR on the
// column-scaled, augmented system (never the normal equations). Shared by the ARX identification
// and the static regression baseline.
#include <Eigen/Core>
#include <vector>

namespace alc::detail {

struct LinearFit {
  Eigen::VectorXd theta;        // parameters in the units of the original columns
  double weighted_rss = 0.0;    // sum_i w_i (y_i - phi_i theta)^2 (without the ridge term)
  double weight_sum = 0.0;      // sum_i w_i
  bool ok = false;              // false if the data or the solution is not finite
};

// Minimises sum_i w_i (y_i - phi_i theta)^2 + ridge * sum(w) * sum_{j >= unpenalised} (s_j theta_j)^2
// where s_j is the weighted RMS of column j: `ridge` is relative to the data. Columns that are zero
// on the weighted rows get theta_j = 0.
LinearFit solve_weighted_ridge(const Eigen::MatrixXd& phi, const Eigen::VectorXd& y, const Eigen::VectorXd& w,
                               double ridge, Eigen::Index unpenalised_columns);

// Weighted ridge fits of many column subsets of one design z on the same rows and weights (the
// structure search): the problem of solve_weighted_ridge(z(:, cols), y, w, ridge, unpenalised), and
// its solution up to rounding, but the Gram matrix of the weighted, column-scaled design is formed
// once and each subset is solved by Cholesky of its block plus the ridge diagonal (p x p, instead of
// a QR of the rows x p design per subset). The column scales do not depend on the subset, so the
// scaled problems are the same. The residual is computed from the columns, not from the Gram
// matrix, which would lose the small residual of a nearly exact fit. Without a ridge (rank
// deficiency is then possible) or if Cholesky fails, falls back to solve_weighted_ridge.
// Keeps a reference to z: z must outlive the object.
class SubsetLeastSquares {
 public:
  SubsetLeastSquares(const Eigen::MatrixXd& z, const Eigen::VectorXd& y, const Eigen::VectorXd& w, double ridge);

  // Columns `cols` of z, the first `unpenalised` of them without ridge. `residual`, if given, gets
  // y - z(:, cols) theta on every row (also those of weight 0).
  LinearFit fit(const std::vector<Eigen::Index>& cols, Eigen::Index unpenalised,
                Eigen::VectorXd* residual = nullptr) const;

 private:
  const Eigen::MatrixXd& z_;
  Eigen::VectorXd y_;
  Eigen::VectorXd w_;
  double ridge_ = 0.0;
  double weight_sum_ = 0.0;
  bool finite_ = false;       // data finite and weight_sum_ > 0
  Eigen::VectorXd scale_;     // weighted RMS of each column of z (1 if zero)
  Eigen::MatrixXd gram_;      // A^T A, A = diag(sqrt w) z diag(1 / scale_)
  Eigen::VectorXd rhs_;       // A^T diag(sqrt w) y
};

struct Conditioning {
  double condition = 0.0;            // of the column-scaled, weighted regressor (inf if singular)
  Eigen::VectorXd parameter_std;     // standard errors of theta from the residual variance
};

// Conditioning of the problem solved by solve_weighted_ridge (without its ridge rows): singular
// values of the R of a Householder QR of the weighted, column-scaled regressor (the same as the
// regressor's, at p x p cost after the QR) and the standard errors from R^-1.
Conditioning conditioning(const Eigen::MatrixXd& phi, const Eigen::VectorXd& w, double weighted_rss);

}  // namespace alc::detail
