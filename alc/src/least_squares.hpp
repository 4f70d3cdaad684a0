#pragma once
// Weighted, ridge-regularised linear least squares by column-pivoting Householder QR on the
// column-scaled, augmented system (never the normal equations). Shared by the ARX identification
// and the static regression baseline.
#include <Eigen/Core>

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

struct Conditioning {
  double condition = 0.0;            // of the column-scaled, weighted regressor (inf if singular)
  Eigen::VectorXd parameter_std;     // standard errors of theta from the residual variance
};

// Conditioning of the problem solved by solve_weighted_ridge (SVD; for reporting, not in loops).
Conditioning conditioning(const Eigen::MatrixXd& phi, const Eigen::VectorXd& w, double weighted_rss);

}  // namespace alc::detail
