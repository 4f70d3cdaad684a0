// The seeds' static models beside ALC (alc/baselines.hpp) against reference values that do not come
// from this code: computed once with numpy, scipy and scikit-learn (Debian 12's python3-numpy,
// python3-scipy, python3-sklearn) by
//     /usr/bin/python3 tests/alc/reference/baselines_reference.py
// on the same formulas (data_x, data_y, the GM history below) and pasted here.
#include <catch2/catch.hpp>
#include <cmath>
#include <stdexcept>

#include "alc/baselines.hpp"

using namespace alc;
using Catch::Matchers::WithinAbs;
using Catch::Matchers::WithinRel;

namespace {

constexpr int kRows = 30;

Eigen::MatrixXd data_x() {
  Eigen::MatrixXd X(kRows, 3);
  for (int i = 0; i < kRows; ++i) {
    X(i, 0) = 20 + 0.5 * i + 0.8 * std::sin(0.7 * i);
    X(i, 1) = 22 + 3 * (1 - std::exp(-i / 8.0)) + 0.3 * std::cos(1.3 * i);
    X(i, 2) = 0.1 * i * i / 30 + 0.5 * std::sin(2.1 * i);
  }
  return X;
}

Eigen::VectorXd data_y(const Eigen::MatrixXd& X) {
  Eigen::VectorXd y(kRows);
  for (int i = 0; i < kRows; ++i) y(i) = 3 + 2.0 * (X(i, 0) - 20) - 1.5 * (X(i, 1) - 22) + 0.4 * std::sin(3.7 * i);
  return y;
}

}  // namespace

TEST_CASE("baselines: Lasso with lambda by contiguous 5-fold CV equals scikit-learn's LassoCV") {
  const Eigen::MatrixXd X = data_x();
  const LinearBaseline f = fit_lasso(X, data_y(X));
  CHECK_THAT(f.lambda, WithinRel(0.007573751455503809, 1e-9));
  CHECK_THAT(f.coefficients(0), WithinAbs(1.9896809437203886, 1e-7));
  CHECK_THAT(f.coefficients(1), WithinAbs(-1.4318209945877565, 1e-7));
  CHECK(f.coefficients(2) == 0.0);  // the input the output does not depend on is dropped
  CHECK_THAT(f.intercept, WithinAbs(-5.363944307347985, 1e-6));
  CHECK(f.selected == std::vector<bool>{true, true, false});
}

TEST_CASE("baselines: Lasso coordinate descent meets the optimality conditions of Eq. 13") {
  const Eigen::MatrixXd X = data_x();
  Eigen::MatrixXd Xc = X.rowwise() - X.colwise().mean();
  const Eigen::VectorXd y = data_y(X);
  const Eigen::VectorXd yc = y.array() - y.mean();
  const double lambda = 0.05;
  const Eigen::VectorXd a = lasso_coordinate_descent(Xc, yc, lambda);
  // Subgradient: X_j'(y - Xa)/N = lambda sign(a_j) where a_j != 0, |.| <= lambda where a_j = 0.
  const Eigen::VectorXd g = Xc.transpose() * (yc - Xc * a) / kRows;
  for (Eigen::Index j = 0; j < a.size(); ++j) {
    if (a(j) != 0.0) CHECK_THAT(g(j), WithinAbs(lambda * (a(j) > 0 ? 1.0 : -1.0), 1e-9));
    else CHECK(std::abs(g(j)) <= lambda + 1e-12);
  }
}

TEST_CASE("baselines: OLS p-values and the selection p < 0.05 equal scipy's t test") {
  const Eigen::MatrixXd X = data_x();
  const LinearBaseline f = fit_ols(X, data_y(X));
  CHECK_THAT(f.p_values(0), WithinRel(4.3638157840011894e-27, 1e-6));
  CHECK_THAT(f.p_values(1), WithinRel(3.3274081393418915e-11, 1e-6));
  CHECK_THAT(f.p_values(2), WithinRel(0.77349163455227, 1e-9));
  CHECK(f.selected == std::vector<bool>{true, true, false});
  CHECK_THAT(f.intercept, WithinAbs(-4.024441437440801, 1e-9));
  CHECK_THAT(f.coefficients(0), WithinAbs(2.0032963123823113, 1e-11));
  CHECK_THAT(f.coefficients(1), WithinAbs(-1.5025907117850594, 1e-11));
  CHECK(f.coefficients(2) == 0.0);
}

TEST_CASE("baselines: OLS with a constant and a collinear input stays finite") {
  Eigen::MatrixXd X = data_x();
  X.col(2).setConstant(1.0);
  Eigen::MatrixXd X4(kRows, 4);
  X4 << X, 2.0 * X.col(0);
  const LinearBaseline f = fit_ols(X4, data_y(X));
  CHECK(f.coefficients.allFinite());
  CHECK(std::isnan(f.p_values(2)));
  CHECK_FALSE(f.selected[2]);
  CHECK(f.selected[0] != f.selected[3]);  // one of the two collinear inputs, not both
}

TEST_CASE("baselines: OLS does not depend on the units of an input") {
  // An input given 1e20 times larger (or smaller) gets its coefficient scaled by 1e-20 (or 1e20);
  // the selection, the p-values and the other coefficients stay. Before, the pivoted QR judged rank
  // on the unscaled columns: the large one made the others look dependent, and they were dropped.
  const Eigen::MatrixXd X = data_x();
  const LinearBaseline base = fit_ols(X, data_y(X));
  for (const double unit : {1e20, 1e-20}) {
    INFO("input 0 times " << unit);
    Eigen::MatrixXd Xs = X;
    Xs.col(0) *= unit;
    const LinearBaseline f = fit_ols(Xs, data_y(X));
    CHECK(f.selected == base.selected);
    CHECK_THAT(f.coefficients(0) * unit, WithinRel(base.coefficients(0), 1e-9));
    CHECK_THAT(f.coefficients(1), WithinRel(base.coefficients(1), 1e-9));
    CHECK_THAT(f.p_values(1), WithinRel(base.p_values(1), 1e-6));
    CHECK_THAT(f.intercept, WithinAbs(base.intercept, 1e-9));
  }
}

TEST_CASE("baselines: epsilon-SVR with an RBF kernel equals scikit-learn's SVR") {
  const Eigen::MatrixXd X = data_x();
  const SvrBaseline s = SvrBaseline::fit(X, data_y(X), {10.0, 0.5, 0.05, 1e-8});
  CHECK_THAT(s.predict(Eigen::Vector3d(27.0, 24.0, 1.0)), WithinAbs(13.952310372504044, 1e-6));
  CHECK_THAT(s.predict(X.row(7).transpose()), WithinAbs(6.888272717448065, 1e-6));
  CHECK(s.support_vectors() == 17);
  // The grid of fit_by_cv picks what the same grid search with scikit-learn picks.
  const SvrBaseline cv = SvrBaseline::fit_by_cv(X, data_y(X));
  CHECK(cv.parameters().C == 100.0);
  CHECK_THAT(cv.parameters().gamma, WithinRel(0.03333333333333333, 1e-12));
}

TEST_CASE("baselines: GM(1 N) on unequal intervals equals the numpy computation") {
  // Inputs every 60 s for 6 h; measurements every 20 min, then every 40 min.
  InputHistory h;
  h.input_names = {"T_1", "T_2"};
  h.inputs.resize(361, 2);
  for (int k = 0; k <= 360; ++k) {
    const double t = 60.0 * k;
    h.time_s.push_back(t);
    h.inputs(k, 0) = 20 + 5 * (1 - std::exp(-t / 7200)) + 0.2 * std::sin(t / 900);
    h.inputs(k, 1) = 21 + 2 * std::sin(t / 5000);
  }
  // The error: dy' = -dy / 1.5 h + 1.2 du_1 - 0.5 du_2, exact for held inputs, + 0.05 sin(t / 1000).
  std::vector<double> sim = {0.0};
  for (int k = 1; k <= 360; ++k) {
    const double f = 1.2 * (h.inputs(k - 1, 0) - h.inputs(0, 0)) - 0.5 * (h.inputs(k - 1, 1) - h.inputs(0, 1));
    sim.push_back(sim.back() * std::exp(-1.0 / 60 / 1.5) + f * 1.5 * (1 - std::exp(-1.0 / 60 / 1.5)));
  }
  std::vector<double> at, values;
  for (double t = 0; t <= 6 * 3600; t += t < 3 * 3600 ? 1200 : 2400) {
    at.push_back(t);
    values.push_back(1 + sim[static_cast<std::size_t>(t / 60)] + 0.05 * std::sin(t / 1000));
  }
  const GreyBaseline g = fit_grey(at, values, h);
  REQUIRE(g.ok);
  CHECK_THAT(g.a, WithinAbs(0.7166317917918702, 1e-9));  // [1/h]; the simulated 1/1.5 up to the noise
  CHECK_THAT(g.b(0), WithinAbs(1.2666193629942364, 1e-9));
  CHECK_THAT(g.b(1), WithinAbs(-0.5556953419444912, 1e-9));
  const Eigen::VectorXd p = g.predict_series(h.time_s, Eigen::MatrixXd(h.inputs.matrix()));
  CHECK(p(0) == values.front());
  CHECK_THAT(p(120), WithinAbs(3.1197156890320685, 1e-8));
  CHECK_THAT(p(360), WithinAbs(9.020715432543133, 1e-8));
}

TEST_CASE("baselines: names and lists") {
  CHECK(parse_baseline_list("all").size() == 5);
  CHECK(parse_baseline_list("svr,mlr") == std::vector<BaselineKind>{BaselineKind::Svr, BaselineKind::Mlr});
  CHECK_THROWS_WITH(parse_baseline_list("svr,mlr,svr"), "'svr' is given twice ('svr,mlr,svr')");
  CHECK_THROWS_WITH(parse_baseline_list("all,mlr"), "'all' stands alone: it cannot be combined with other names ('all,mlr')");
  CHECK_THROWS_WITH(parse_baseline_list("mlr,all"), "'all' stands alone: it cannot be combined with other names ('mlr,all')");
  try {
    parse_baseline_list("mlr,knn");
    FAIL("no exception");
  } catch (const std::invalid_argument& e) {
    CHECK(std::string(e.what()) == "'knn' is not one of mlr, lasso, svr, gm, ols, or all");
  }
  CHECK_THROWS_AS(parse_baseline_list(""), std::invalid_argument);
  CHECK(contiguous_folds(7, 3) == std::vector<int>{0, 0, 0, 1, 1, 2, 2});
}

TEST_CASE("baselines: GM(1 N) keeps a stable time constant when least squares gives growth") {
  // An error that grows exponentially while the input is constant: the grey equation's least
  // squares gives a < 0; the fit takes a = 1 / (span of the measurements) = 1/6 per hour instead.
  InputHistory h;
  h.input_names = {"T_1"};
  h.inputs.resize(2 * 361, 1);
  for (int k = 0; k < 2 * 361; ++k) {
    h.time_s.push_back(60.0 * k);
    h.inputs(k, 0) = 20.0 + (k > 180 ? 0.5 : 0.0);
  }
  std::vector<double> at, values;
  for (double t = 0; t <= 6 * 3600; t += 600) {
    at.push_back(t);
    values.push_back(std::exp(t / 7200));
  }
  const GreyBaseline g = fit_grey(at, values, h);
  REQUIRE(g.ok);
  CHECK(g.a_constrained);
  CHECK_THAT(g.a, WithinRel(1.0 / 6.0, 1e-12));
  const Eigen::VectorXd p = g.predict_series(h.time_s, Eigen::MatrixXd(h.inputs.matrix()));
  CHECK(p.allFinite());
  CHECK(p.cwiseAbs().maxCoeff() < 1e3);
}
