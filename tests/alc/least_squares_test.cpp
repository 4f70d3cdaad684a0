// The internal solvers of identify() against their references: the robust gains (Newton / IRLS)
// against Ceres on the same problem, the subset solver of the structure search against the QR of
// solve_weighted_ridge, the conditioning from R against an SVD of the full regressor.
#include <catch2/catch.hpp>
#include <ceres/ceres.h>

#include <Eigen/SVD>
#include <cmath>
#include <limits>
#include <memory>
#include <random>

#include "../../alc/src/least_squares.hpp"
#include "../../alc/src/refinement.hpp"

using namespace alc;
using namespace alc::detail;

namespace {

struct Problem {
  Eigen::MatrixXd phi;  // [1, lags]
  Eigen::VectorXd y;
  Eigen::VectorXd w;
};

// Offset and `lags` smooth, partly collinear columns; noise 0.05 and a few gross outliers.
Problem make_problem(std::mt19937_64& rng, Eigen::Index rows, Eigen::Index lags, int outliers) {
  std::normal_distribution<double> noise(0.0, 0.05);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  Problem p;
  p.phi.resize(rows, 1 + lags);
  p.phi.col(0).setOnes();
  for (Eigen::Index j = 1; j <= lags; ++j) {
    const double f = 0.3 * static_cast<double>(j);
    for (Eigen::Index r = 0; r < rows; ++r)
      p.phi(r, j) = 10.0 * std::sin(f * static_cast<double>(r) / 10.0) + 5.0 * static_cast<double>(r) / rows + noise(rng);
  }
  Eigen::VectorXd theta(1 + lags);
  for (Eigen::Index j = 0; j <= lags; ++j) theta(j) = unit(rng) - 0.5;
  p.y = p.phi * theta;
  for (Eigen::Index r = 0; r < rows; ++r) p.y(r) += noise(rng);
  for (int k = 0; k < outliers; ++k) p.y(static_cast<Eigen::Index>(unit(rng) * rows)) += 20.0 + 20.0 * unit(rng);
  p.w.resize(rows);
  for (Eigen::Index r = 0; r < rows; ++r) p.w(r) = 0.2 + unit(rng);
  return p;
}

// The Ceres problem that refine_gains solved before: one residual block sqrt(w) (phi theta - y) per
// row with the robust loss, one ridge block c_j theta_j (c_j = sqrt(ridge Σw ms_j)); here to tight
// tolerances.
class LinearRow final : public ceres::CostFunction {
 public:
  LinearRow(Eigen::VectorXd phi, double y) : phi_(std::move(phi)), y_(y) {
    set_num_residuals(1);
    mutable_parameter_block_sizes()->push_back(static_cast<int>(phi_.size()));
  }
  bool Evaluate(double const* const* p, double* r, double** j) const override {
    r[0] = phi_.dot(Eigen::Map<const Eigen::VectorXd>(p[0], phi_.size())) - y_;
    if (j && j[0]) Eigen::Map<Eigen::VectorXd>(j[0], phi_.size()) = phi_;
    return true;
  }

 private:
  Eigen::VectorXd phi_;
  double y_;
};

class Ridge final : public ceres::CostFunction {
 public:
  explicit Ridge(Eigen::VectorXd c) : c_(std::move(c)) {
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

Eigen::VectorXd ceres_gains(const Problem& p, const Eigen::VectorXd& theta0, const RobustSettings& s, double* final_cost) {
  Eigen::VectorXd theta = theta0;
  std::unique_ptr<ceres::LossFunction> loss;
  if (s.loss == RobustLoss::Huber) loss = std::make_unique<ceres::HuberLoss>(s.scale);
  if (s.loss == RobustLoss::Cauchy) loss = std::make_unique<ceres::CauchyLoss>(s.scale);
  ceres::Problem::Options po;
  po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  for (Eigen::Index i = 0; i < p.phi.rows(); ++i) {
    const double sw = std::sqrt(p.w(i));
    problem.AddResidualBlock(new LinearRow(sw * p.phi.row(i).transpose(), sw * p.y(i)), loss.get(), theta.data());
  }
  const double wsum = p.w.sum();
  Eigen::VectorXd c(p.phi.cols() - 1);
  for (Eigen::Index j = 1; j < p.phi.cols(); ++j)
    c(j - 1) = std::sqrt(s.ridge * wsum * (p.w.array() * p.phi.col(j).array().square()).sum() / wsum);
  problem.AddResidualBlock(new Ridge(c), nullptr, theta.data());
  ceres::Solver::Options o;
  o.linear_solver_type = ceres::DENSE_QR;
  o.max_num_iterations = 500;
  o.function_tolerance = 1e-15;
  o.gradient_tolerance = 1e-15;
  o.parameter_tolerance = 1e-15;
  o.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(o, &problem, &summary);
  *final_cost = summary.final_cost;
  return theta;
}

}  // namespace

TEST_CASE("refine_gains: Huber and Cauchy with ridge reach the Ceres optimum of the same problem") {
  std::mt19937_64 rng(7);
  for (const Eigen::Index lags : {1, 4, 12}) {
    const Problem p = make_problem(rng, 180, lags, 6);
    const Eigen::VectorXd theta0 = solve_weighted_ridge(p.phi, p.y, p.w, 1e-5, 1).theta;
    for (const RobustLoss loss : {RobustLoss::Huber, RobustLoss::Cauchy}) {
      const RobustSettings s{loss, 0.1, 1e-5, 50};
      const Refinement r = refine_gains(p.phi, p.y, p.w, theta0, s);
      double ceres_cost = 0.0;
      const Eigen::VectorXd reference = ceres_gains(p, theta0, s, &ceres_cost);
      INFO("lags " << lags << ", loss " << static_cast<int>(loss) << ": cost " << r.cost_before << " -> " << r.cost_after
                   << ", Ceres " << ceres_cost);
      REQUIRE(r.ok);
      CHECK(r.cost_after < r.cost_before);
      // The same cost function as Ceres' (its value at the Ceres optimum) and no worse an optimum.
      CHECK(r.cost_after <= ceres_cost * (1.0 + 1e-9));
      const Eigen::VectorXd d = (p.phi * (r.theta - reference)).cwiseAbs();
      CHECK(d.maxCoeff() < 1e-5 * (1.0 + p.y.cwiseAbs().maxCoeff()));
    }
  }
}

TEST_CASE("refine_gains: every residual beyond the Huber scale, no ridge, and a non-finite start") {
  std::mt19937_64 rng(8);
  const Problem p = make_problem(rng, 40, 2, 0);
  const Eigen::VectorXd theta0 = Eigen::VectorXd::Zero(3);
  const RobustSettings s{RobustLoss::Huber, 1e-6, 0.0, 50};  // all beyond the scale at the start
  const Refinement r = refine_gains(p.phi, p.y, p.w, theta0, s);
  REQUIRE(r.ok);
  CHECK(r.cost_after < r.cost_before);
  double ceres_cost = 0.0;
  ceres_gains(p, theta0, s, &ceres_cost);
  CHECK(r.cost_after <= ceres_cost * (1.0 + 1e-6));
  Eigen::VectorXd bad = theta0;
  bad(1) = std::numeric_limits<double>::quiet_NaN();
  const Refinement nan = refine_gains(p.phi, p.y, p.w, bad, s);
  CHECK_FALSE(nan.ok);
  CHECK(nan.message.find("robust refinement failed") != std::string::npos);
}

TEST_CASE("SubsetLeastSquares: subsets solve as solve_weighted_ridge on the chosen columns") {
  std::mt19937_64 rng(9);
  const Problem p = make_problem(rng, 120, 10, 0);
  for (const double ridge : {1e-6, 0.0}) {
    const SubsetLeastSquares subsets(p.phi, p.y, p.w, ridge);
    for (const std::vector<Eigen::Index>& cols :
         std::vector<std::vector<Eigen::Index>>{{0}, {0, 3}, {0, 1, 2, 3}, {0, 9, 2, 5, 7}, {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10}}) {
      Eigen::MatrixXd phi(p.phi.rows(), static_cast<Eigen::Index>(cols.size()));
      for (std::size_t j = 0; j < cols.size(); ++j) phi.col(static_cast<Eigen::Index>(j)) = p.phi.col(cols[j]);
      const LinearFit qr = solve_weighted_ridge(phi, p.y, p.w, ridge, 1);
      Eigen::VectorXd residual;
      const LinearFit fast = subsets.fit(cols, 1, &residual);
      INFO("ridge " << ridge << ", " << cols.size() << " columns");
      REQUIRE(fast.ok);
      CHECK(fast.weight_sum == qr.weight_sum);
      CHECK_THAT(fast.weighted_rss, Catch::Matchers::WithinRel(qr.weighted_rss, 1e-9));
      CHECK((phi * (fast.theta - qr.theta)).cwiseAbs().maxCoeff() < 1e-8 * p.y.cwiseAbs().maxCoeff());
      CHECK((residual - (p.y - phi * fast.theta)).cwiseAbs().maxCoeff() < 1e-12 * p.y.cwiseAbs().maxCoeff());
    }
  }
  SECTION("a nearly exact fit keeps its small residual (not lost to the Gram matrix)") {
    const Eigen::VectorXd y = p.phi.leftCols(4) * Eigen::Vector4d(1.0, -2.0, 0.5, 3.0);
    const SubsetLeastSquares subsets(p.phi, y, p.w, 1e-12);
    const LinearFit f = subsets.fit({0, 1, 2, 3}, 1);
    REQUIRE(f.ok);
    CHECK(f.weighted_rss < 1e-16 * (p.w.array() * y.array().square()).sum());
  }
}

TEST_CASE("conditioning: condition number and standard errors as from an SVD of the regressor") {
  std::mt19937_64 rng(10);
  Problem p = make_problem(rng, 150, 6, 0);
  for (const double collinear : {0.0, 1e-4}) {  // a column that is a noisy copy of another: condition ~1e5
    const double tol = collinear > 0.0 ? 1e-5 : 1e-9;
    std::normal_distribution<double> noise(0.0, collinear);
    if (collinear > 0.0)
      for (Eigen::Index r = 0; r < p.phi.rows(); ++r) p.phi(r, 6) = p.phi(r, 5) + noise(rng);
    const Conditioning c = conditioning(p.phi, p.w, 2.5);
    Eigen::VectorXd s(p.phi.cols());
    for (Eigen::Index j = 0; j < p.phi.cols(); ++j) s(j) = std::sqrt((p.w.array() * p.phi.col(j).array().square()).sum() / p.w.sum());
    const Eigen::MatrixXd a = p.w.array().sqrt().matrix().asDiagonal() * p.phi * s.cwiseInverse().asDiagonal();
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(a, Eigen::ComputeThinV);
    const Eigen::VectorXd& sv = svd.singularValues();
    INFO("collinear " << collinear << ": condition " << c.condition << ", SVD " << sv(0) / sv(sv.size() - 1));
    CHECK_THAT(c.condition, Catch::Matchers::WithinRel(sv(0) / sv(sv.size() - 1), tol));
    const Eigen::MatrixXd v = svd.matrixV() * sv.cwiseInverse().asDiagonal();
    const double sigma2 = 2.5 / static_cast<double>(p.phi.rows() - p.phi.cols());
    for (Eigen::Index j = 0; j < p.phi.cols(); ++j)
      CHECK_THAT(c.parameter_std(j), Catch::Matchers::WithinRel(std::sqrt(sigma2 * v.row(j).squaredNorm()) / s(j), tol));
  }
  CHECK(std::isinf(conditioning(Eigen::MatrixXd::Ones(3, 5), Eigen::VectorXd::Ones(3), 1.0).condition));
  Eigen::MatrixXd zero_column = Eigen::MatrixXd::Ones(10, 2);
  zero_column.col(1).setZero();
  CHECK(std::isinf(conditioning(zero_column, Eigen::VectorXd::Ones(10), 1.0).condition));
}
