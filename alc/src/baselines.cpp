#include "alc/baselines.hpp"

#include <svm.h>

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>
#include <stdexcept>

#include "alc/static_regression.hpp"
#include "alc/statistics.hpp"

namespace alc {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Columns of X that vary, their means and population standard deviations.
struct Standardisation {
  std::vector<Eigen::Index> cols;
  Eigen::VectorXd mean, sd;
  static Standardisation of(const Eigen::MatrixXd& X) {
    Standardisation s;
    s.mean = Eigen::VectorXd::Zero(X.cols());
    s.sd = Eigen::VectorXd::Ones(X.cols());
    if (X.rows() == 0) return s;
    for (Eigen::Index c = 0; c < X.cols(); ++c) {
      s.mean(c) = X.col(c).mean();
      const double sd = std::sqrt((X.col(c).array() - s.mean(c)).square().mean());
      // Relative to the column's own size, so that an input's unit does not decide (1e-20 x T is no
      // more constant than T); a column held at one value has sd 0 or rounding noise of its mean.
      if (sd > 0.0 && sd > 1e-12 * std::abs(s.mean(c))) {
        s.sd(c) = sd;
        s.cols.push_back(c);
      }
    }
    return s;
  }
  // The varying columns, standardised.
  Eigen::MatrixXd apply(const Eigen::MatrixXd& X) const {
    Eigen::MatrixXd Z(X.rows(), static_cast<Eigen::Index>(cols.size()));
    for (std::size_t j = 0; j < cols.size(); ++j)
      Z.col(static_cast<Eigen::Index>(j)) = (X.col(cols[j]).array() - mean(cols[j])) / sd(cols[j]);
    return Z;
  }
  Eigen::VectorXd apply_row(const Eigen::VectorXd& x) const {
    Eigen::VectorXd z(static_cast<Eigen::Index>(cols.size()));
    for (std::size_t j = 0; j < cols.size(); ++j) {
      const double v = cols[j] < x.size() ? x(cols[j]) : kNaN;
      z(static_cast<Eigen::Index>(j)) = std::isfinite(v) ? (v - mean(cols[j])) / sd(cols[j]) : 0.0;
    }
    return z;
  }
};

Eigen::MatrixXd rows_of(const Eigen::MatrixXd& X, const std::vector<Eigen::Index>& rows) {
  Eigen::MatrixXd r(static_cast<Eigen::Index>(rows.size()), X.cols());
  for (std::size_t i = 0; i < rows.size(); ++i) r.row(static_cast<Eigen::Index>(i)) = X.row(rows[i]);
  return r;
}

Eigen::VectorXd rows_of(const Eigen::VectorXd& y, const std::vector<Eigen::Index>& rows) {
  Eigen::VectorXd r(static_cast<Eigen::Index>(rows.size()));
  for (std::size_t i = 0; i < rows.size(); ++i) r(static_cast<Eigen::Index>(i)) = y(rows[i]);
  return r;
}

// Training and test rows of fold f.
std::pair<std::vector<Eigen::Index>, std::vector<Eigen::Index>> split(const std::vector<int>& fold_of, int f) {
  std::pair<std::vector<Eigen::Index>, std::vector<Eigen::Index>> s;
  for (std::size_t i = 0; i < fold_of.size(); ++i)
    (fold_of[i] == f ? s.second : s.first).push_back(static_cast<Eigen::Index>(i));
  return s;
}

double soft_threshold(double x, double t) { return x > t ? x - t : (x < -t ? x + t : 0.0); }

Eigen::VectorXd lasso_from(const Eigen::MatrixXd& X, const Eigen::VectorXd& y, double lambda, Eigen::VectorXd a,
                           double tol, int max_sweeps) {
  const double n = static_cast<double>(X.rows());
  const Eigen::VectorXd norm2 = X.colwise().squaredNorm().transpose() / n;
  Eigen::VectorXd r = y - X * a;
  for (int sweep = 0; sweep < max_sweeps; ++sweep) {
    double max_delta = 0.0, max_abs = 0.0;
    for (Eigen::Index j = 0; j < X.cols(); ++j) {
      if (!(norm2(j) > 0.0)) continue;
      const double rho = X.col(j).dot(r) / n + norm2(j) * a(j);
      const double next = soft_threshold(rho, lambda) / norm2(j);
      const double delta = next - a(j);
      if (delta != 0.0) {
        r.noalias() -= delta * X.col(j);
        a(j) = next;
      }
      max_delta = std::max(max_delta, std::abs(delta));
      max_abs = std::max(max_abs, std::abs(next));
    }
    if (max_delta <= tol * max_abs || max_delta == 0.0) break;
  }
  return a;
}

// The norm of each column of A (1 for a zero or non-finite one): A divided by it has unit columns, so
// that which columns a pivoted QR counts as dependent does not change when an input is given in other
// units (an input 1e20 times larger made every other column look dependent).
Eigen::VectorXd unit_scale(const Eigen::MatrixXd& A) {
  Eigen::VectorXd scale = A.colwise().norm().transpose();
  for (Eigen::Index k = 0; k < scale.size(); ++k)
    if (!(scale(k) > 0.0) || !std::isfinite(scale(k))) scale(k) = 1.0;
  return scale;
}

// The least-squares solution of A x = rhs by column-pivoting QR on A with unit columns (unit_scale).
Eigen::VectorXd solve_scaled(const Eigen::MatrixXd& A, const Eigen::VectorXd& rhs) {
  const Eigen::VectorXd scale = unit_scale(A);
  const Eigen::MatrixXd As = A * scale.cwiseInverse().asDiagonal();
  return As.colPivHouseholderQr().solve(rhs).cwiseQuotient(scale);
}

// OLS with intercept on the columns `cols` of X; coefficients (per column of X, 0 elsewhere) and
// p-values (NaN for columns not estimated).
LinearBaseline ols_on(const Eigen::MatrixXd& X, const Eigen::VectorXd& y, const std::vector<Eigen::Index>& cols) {
  LinearBaseline f;
  f.coefficients = Eigen::VectorXd::Zero(X.cols());
  f.p_values = Eigen::VectorXd::Constant(X.cols(), kNaN);
  f.selected.assign(static_cast<std::size_t>(X.cols()), false);
  const Eigen::Index m = X.rows();
  f.intercept = m ? y.mean() : 0.0;
  if (m < 2 || cols.empty()) return f;
  Eigen::MatrixXd Xc(m, static_cast<Eigen::Index>(cols.size()));
  Eigen::VectorXd mean(Xc.cols());
  for (std::size_t j = 0; j < cols.size(); ++j) {
    const auto c = static_cast<Eigen::Index>(j);
    mean(c) = X.col(cols[j]).mean();
    Xc.col(c) = X.col(cols[j]).array() - mean(c);
  }
  const Eigen::VectorXd yc = y.array() - f.intercept;
  // The linearly independent columns (pivoted QR of the columns scaled to unit norm, so that the
  // choice does not depend on the inputs' units), then a plain QR of those.
  const Eigen::MatrixXd Xs = Xc * unit_scale(Xc).cwiseInverse().asDiagonal();
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> piv(Xs);
  std::vector<Eigen::Index> independent;
  for (Eigen::Index k = 0; k < piv.rank(); ++k) independent.push_back(piv.colsPermutation().indices()(k));
  std::sort(independent.begin(), independent.end());
  const auto r = static_cast<Eigen::Index>(independent.size());
  if (r == 0) return f;
  Eigen::MatrixXd A(m, r);
  for (Eigen::Index k = 0; k < r; ++k) A.col(k) = Xc.col(independent[static_cast<std::size_t>(k)]);
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(A);
  const Eigen::VectorXd b = qr.solve(yc);
  if (!b.allFinite()) return f;
  const double dof = static_cast<double>(m - r - 1);
  const double s2 = dof > 0 ? (yc - A * b).squaredNorm() / dof : kNaN;
  const Eigen::MatrixXd R = qr.matrixQR().topRows(r).triangularView<Eigen::Upper>();
  const Eigen::MatrixXd Rinv = R.triangularView<Eigen::Upper>().solve(Eigen::MatrixXd::Identity(r, r));
  for (Eigen::Index k = 0; k < r; ++k) {
    const Eigen::Index c = cols[static_cast<std::size_t>(independent[static_cast<std::size_t>(k)])];
    f.coefficients(c) = b(k);
    f.intercept -= b(k) * mean(independent[static_cast<std::size_t>(k)]);
    const double var = s2 * Rinv.row(k).squaredNorm();
    f.p_values(c) = dof > 0 && var > 0 ? f_distribution_sf(b(k) * b(k) / var, 1.0, dof) : kNaN;
  }
  return f;
}

void quiet_libsvm() {
  static std::once_flag once;
  std::call_once(once, [] { svm_set_print_string_function([](const char*) {}); });
}

}  // namespace

// ---- names ----

std::string_view baseline_name(BaselineKind kind) {
  switch (kind) {
    case BaselineKind::Mlr: return "mlr";
    case BaselineKind::Lasso: return "lasso";
    case BaselineKind::Svr: return "svr";
    case BaselineKind::Gm: return "gm";
    case BaselineKind::Ols: return "ols";
  }
  return "?";
}

const std::vector<BaselineKind>& all_baselines() {
  static const std::vector<BaselineKind> all = {BaselineKind::Mlr, BaselineKind::Lasso, BaselineKind::Svr,
                                                BaselineKind::Gm, BaselineKind::Ols};
  return all;
}

std::optional<BaselineKind> parse_baseline(std::string_view name) {
  for (const BaselineKind k : all_baselines())
    if (baseline_name(k) == name) return k;
  return std::nullopt;
}

std::vector<BaselineKind> parse_baseline_list(std::string_view text) {
  if (text == "all") return all_baselines();
  std::vector<BaselineKind> kinds;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = std::min(text.find(',', start), text.size());
    const std::string_view name = text.substr(start, comma - start);
    if (name == "all")
      throw std::invalid_argument("'all' stands alone: it cannot be combined with other names ('" + std::string(text) +
                                  "')");
    const auto kind = parse_baseline(name);
    if (!kind) {
      std::string valid;
      for (const BaselineKind k : all_baselines()) valid += std::string(baseline_name(k)) + ", ";
      throw std::invalid_argument("'" + std::string(name) + "' is not one of " + valid + "or all");
    }
    // Refused like a value listed twice on a grid axis: a typo, not a wish for two rows.
    if (std::find(kinds.begin(), kinds.end(), *kind) != kinds.end())
      throw std::invalid_argument("'" + std::string(name) + "' is given twice ('" + std::string(text) + "')");
    kinds.push_back(*kind);
    start = comma + 1;
  }
  return kinds;
}

// ---- folds, Lasso, OLS ----

std::vector<int> contiguous_folds(Eigen::Index m, int k) {
  std::vector<int> fold_of;
  if (m <= 0 || k <= 0) return fold_of;
  for (int f = 0; f < k; ++f) {
    const Eigen::Index size = m / k + (f < m % k ? 1 : 0);
    fold_of.insert(fold_of.end(), static_cast<std::size_t>(size), f);
  }
  return fold_of;
}

Eigen::VectorXd lasso_coordinate_descent(const Eigen::MatrixXd& X, const Eigen::VectorXd& y, double lambda,
                                         double tol, int max_sweeps) {
  return lasso_from(X, y, lambda, Eigen::VectorXd::Zero(X.cols()), tol, max_sweeps);
}

LinearBaseline fit_lasso(const Eigen::MatrixXd& X, const Eigen::VectorXd& y, int folds, int n_lambda) {
  constexpr double kTol = 1e-10;
  constexpr int kSweeps = 20000;
  LinearBaseline f;
  const Eigen::Index m = X.rows();
  f.coefficients = Eigen::VectorXd::Zero(X.cols());
  f.selected.assign(static_cast<std::size_t>(X.cols()), false);
  f.intercept = m ? y.mean() : 0.0;
  const Standardisation s = Standardisation::of(X);
  if (m < 3 || s.cols.empty() || n_lambda < 1) return f;
  const Eigen::MatrixXd Z = s.apply(X);
  const Eigen::VectorXd yc = y.array() - f.intercept;
  const double lambda_max = (Z.transpose() * yc).cwiseAbs().maxCoeff() / static_cast<double>(m);
  if (!(lambda_max > 0.0)) return f;
  std::vector<double> grid;
  for (int k = 0; k < n_lambda; ++k)
    grid.push_back(lambda_max * std::pow(10.0, n_lambda > 1 ? -3.0 * k / (n_lambda - 1) : 0.0));
  const int k_folds = static_cast<int>(std::min<Eigen::Index>(folds, m));
  const std::vector<int> fold_of = contiguous_folds(m, k_folds);
  std::vector<double> mse(grid.size(), 0.0);
  for (int fold = 0; fold < k_folds; ++fold) {
    const auto [train, test] = split(fold_of, fold);
    Eigen::MatrixXd Zt = rows_of(Z, train);
    Eigen::VectorXd yt = rows_of(y, train);
    const Eigen::RowVectorXd z_mean = Zt.colwise().mean();
    const double y_mean = yt.mean();
    Zt.rowwise() -= z_mean;
    yt.array() -= y_mean;
    Eigen::VectorXd a = Eigen::VectorXd::Zero(Z.cols());
    for (std::size_t g = 0; g < grid.size(); ++g) {
      a = lasso_from(Zt, yt, grid[g], a, kTol, kSweeps);  // warm start along the path
      double sum = 0.0;
      for (const Eigen::Index i : test) {
        const double e = y(i) - (y_mean + (Z.row(i) - z_mean).dot(a));
        sum += e * e;
      }
      mse[g] += sum / static_cast<double>(test.size()) / k_folds;
    }
  }
  const auto best = static_cast<std::size_t>(std::min_element(mse.begin(), mse.end()) - mse.begin());
  f.lambda = grid[best];
  const Eigen::VectorXd a = lasso_coordinate_descent(Z, yc, f.lambda, kTol, kSweeps);
  for (std::size_t j = 0; j < s.cols.size(); ++j) {
    const Eigen::Index c = s.cols[j];
    const double w = a(static_cast<Eigen::Index>(j));
    f.coefficients(c) = w / s.sd(c);
    f.intercept -= f.coefficients(c) * s.mean(c);
    f.selected[static_cast<std::size_t>(c)] = w != 0.0;
  }
  return f;
}

LinearBaseline fit_ols(const Eigen::MatrixXd& X, const Eigen::VectorXd& y, double alpha) {
  const Standardisation s = Standardisation::of(X);
  LinearBaseline all = ols_on(X, y, s.cols);
  if (!(alpha > 0.0)) return all;
  std::vector<Eigen::Index> kept;
  for (Eigen::Index c = 0; c < X.cols(); ++c)
    if (all.p_values(c) < alpha) kept.push_back(c);
  LinearBaseline f = ols_on(X, y, kept);
  f.p_values = all.p_values;  // the p-values of the selection
  f.selected.assign(static_cast<std::size_t>(X.cols()), false);
  for (const Eigen::Index c : kept) f.selected[static_cast<std::size_t>(c)] = true;
  return f;
}

// ---- SVR ----

struct SvrBaseline::Impl {
  Standardisation scaling;
  double y_mean = 0.0, y_sd = 1.0;
  std::vector<double> ys;
  std::vector<svm_node> nodes;
  std::vector<svm_node*> rows;
  svm_problem problem{};
  svm_model* model = nullptr;
  Impl() = default;
  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;
  ~Impl() {
    if (model) svm_free_and_destroy_model(&model);
  }
  // Trains on standardised inputs Z and standardised outputs ys_scaled.
  void train(const Eigen::MatrixXd& Z, const Eigen::VectorXd& ys_scaled, const SvrParameters& p) {
    quiet_libsvm();
    const auto d = static_cast<std::size_t>(Z.cols());
    ys.assign(ys_scaled.data(), ys_scaled.data() + ys_scaled.size());
    nodes.assign(static_cast<std::size_t>(Z.rows()) * (d + 1), svm_node{-1, 0.0});
    rows.clear();
    for (Eigen::Index i = 0; i < Z.rows(); ++i) {
      svm_node* row = nodes.data() + static_cast<std::size_t>(i) * (d + 1);
      for (std::size_t j = 0; j < d; ++j) row[j] = svm_node{static_cast<int>(j) + 1, Z(i, static_cast<Eigen::Index>(j))};
      rows.push_back(row);
    }
    problem.l = static_cast<int>(Z.rows());
    problem.y = ys.data();
    problem.x = rows.data();
    svm_parameter param{};
    param.svm_type = EPSILON_SVR;
    param.kernel_type = RBF;
    param.gamma = p.gamma;
    param.C = p.C;
    param.p = p.epsilon;
    param.eps = p.tolerance;
    param.cache_size = 16;  // [MB]
    param.shrinking = 1;
    param.probability = 0;
    if (svm_check_parameter(&problem, &param) != nullptr) return;
    model = svm_train(&problem, &param);
  }
  double predict_scaled(const Eigen::VectorXd& z) const {
    if (!model) return 0.0;
    std::vector<svm_node> x(static_cast<std::size_t>(z.size()) + 1, svm_node{-1, 0.0});
    for (Eigen::Index j = 0; j < z.size(); ++j) x[static_cast<std::size_t>(j)] = svm_node{static_cast<int>(j) + 1, z(j)};
    return svm_predict(model, x.data());
  }
};

SvrBaseline SvrBaseline::fit(const Eigen::MatrixXd& X, const Eigen::VectorXd& y, const SvrParameters& parameters) {
  SvrBaseline b;
  b.parameters_ = parameters;
  if (X.rows() == 0) return b;
  const Standardisation s = Standardisation::of(X);
  const double y_mean = y.mean();
  const double y_sd = std::sqrt((y.array() - y_mean).square().mean());
  auto impl = std::make_shared<Impl>();
  impl->scaling = s;
  impl->y_mean = y_mean;
  impl->y_sd = y_sd > 0 ? y_sd : 1.0;
  if (y_sd > 0 && !s.cols.empty()) impl->train(s.apply(X), (y.array() - y_mean) / y_sd, parameters);
  b.impl_ = std::move(impl);
  return b;
}

SvrBaseline SvrBaseline::fit_by_cv(const Eigen::MatrixXd& X, const Eigen::VectorXd& y, double epsilon) {
  const Standardisation s = Standardisation::of(X);
  const double d = std::max<double>(1.0, static_cast<double>(s.cols.size()));
  SvrParameters best{10.0, 1.0 / d, epsilon, 1e-3};
  const Eigen::Index m = X.rows();
  if (m >= 10 && !s.cols.empty()) {
    const Eigen::MatrixXd Z = s.apply(X);
    const double y_mean = y.mean();
    const double y_sd = std::sqrt((y.array() - y_mean).square().mean());
    if (y_sd > 0) {
      const Eigen::VectorXd ys = (y.array() - y_mean) / y_sd;
      const std::vector<int> fold_of = contiguous_folds(m, 5);
      double best_mse = std::numeric_limits<double>::infinity();
      for (const double C : {1.0, 10.0, 100.0, 1000.0})
        for (const double g : {0.1, 1.0, 10.0}) {
          const SvrParameters p{C, g / d, epsilon, 1e-3};
          double mse = 0.0;
          for (int fold = 0; fold < 5; ++fold) {
            const auto [train, test] = split(fold_of, fold);
            Impl impl;
            impl.train(rows_of(Z, train), rows_of(ys, train), p);
            double sum = 0.0;
            for (const Eigen::Index i : test) {
              const double e = ys(i) - impl.predict_scaled(Z.row(i).transpose());
              sum += e * e;
            }
            mse += sum / static_cast<double>(test.size()) / 5.0;
          }
          if (mse < best_mse) {
            best_mse = mse;
            best = p;
          }
        }
    }
  }
  return fit(X, y, best);
}

double SvrBaseline::predict(const Eigen::VectorXd& x) const {
  if (!impl_) return 0.0;
  return impl_->y_mean + impl_->y_sd * impl_->predict_scaled(impl_->scaling.apply_row(x));
}

int SvrBaseline::support_vectors() const { return impl_ && impl_->model ? svm_get_nr_sv(impl_->model) : 0; }

// ---- GM(1,N) ----

namespace {
// Index of the last sample at or before t (-1 if none).
Eigen::Index sample_at(const std::vector<double>& time_s, double t) {
  return static_cast<Eigen::Index>(std::upper_bound(time_s.begin(), time_s.end(), t) - time_s.begin()) - 1;
}
}  // namespace

GreyBaseline fit_grey(const std::vector<double>& measured_at, const std::vector<double>& values,
                      const InputHistory& history) {
  GreyBaseline g;
  const auto n_in = history.inputs.cols();
  g.b = Eigen::VectorXd::Zero(n_in);
  g.u1 = Eigen::VectorXd::Zero(n_in);
  const std::size_t m = std::min(measured_at.size(), values.size());
  if (m == 0) return g;
  g.t1_s = measured_at.front();
  g.y1 = values.front();
  const Eigen::Index s0 = sample_at(history.time_s, g.t1_s);
  if (m < 3 || s0 < 0) return g;
  g.u1 = history.inputs.row(s0).transpose();
  // U_i at each measurement: the integral of du_i (held from sample to sample) from t1 [unit h].
  Eigen::MatrixXd U = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(m), n_in);
  Eigen::VectorXd acc = Eigen::VectorXd::Zero(n_in);  // integral up to time_s[s]
  Eigen::VectorXd du = Eigen::VectorXd::Zero(n_in);   // held since time_s[s]
  Eigen::Index s = s0;
  for (std::size_t j = 0; j < m; ++j) {
    const double t = measured_at[j];
    while (s + 1 < static_cast<Eigen::Index>(history.time_s.size()) && history.time_s[static_cast<std::size_t>(s + 1)] <= t) {
      acc += du * (history.time_s[static_cast<std::size_t>(s + 1)] - history.time_s[static_cast<std::size_t>(s)]) / 3600.0;
      ++s;
      for (Eigen::Index i = 0; i < n_in; ++i)
        if (std::isfinite(history.inputs(s, i))) du(i) = history.inputs(s, i) - g.u1(i);
    }
    U.row(static_cast<Eigen::Index>(j)) = (acc + du * (t - history.time_s[static_cast<std::size_t>(s)]) / 3600.0).transpose();
  }
  // Y1: the trapezoid integral of dy over the measurements (the background value of Eq. 4).
  std::vector<Eigen::Index> cols;
  for (Eigen::Index i = 0; i < n_in; ++i)
    if (U.col(i).cwiseAbs().maxCoeff() > 0.0) cols.push_back(i);
  Eigen::MatrixXd A(static_cast<Eigen::Index>(m) - 1, 1 + static_cast<Eigen::Index>(cols.size()));
  Eigen::VectorXd rhs(A.rows());
  double Y1 = 0.0;
  for (std::size_t j = 1; j < m; ++j) {
    const double dy = values[j] - g.y1;
    Y1 += 0.5 * ((values[j - 1] - g.y1) + dy) * (measured_at[j] - measured_at[j - 1]) / 3600.0;
    const auto r = static_cast<Eigen::Index>(j) - 1;
    A(r, 0) = -Y1;
    for (std::size_t c = 0; c < cols.size(); ++c) A(r, static_cast<Eigen::Index>(c) + 1) = U(static_cast<Eigen::Index>(j), cols[c]);
    rhs(r) = dy;
  }
  Eigen::VectorXd theta = solve_scaled(A, rhs);
  if (!theta.allFinite()) return g;
  // Stability: a time constant 1/a longer than the span of the measurements (or growth, a <= 0) is
  // not what the data can show, and the whitened equation would diverge after it. The problem is
  // a convex quadratic in (a, b), so the least squares with a >= a_min has a = a_min then.
  const double a_min = 3600.0 / (measured_at[m - 1] - measured_at[0]);
  g.a_constrained = !(theta(0) >= a_min);
  if (g.a_constrained) {
    theta(0) = a_min;
    if (A.cols() > 1) {
      const Eigen::VectorXd b = solve_scaled(A.rightCols(A.cols() - 1), rhs - a_min * A.col(0));
      if (!b.allFinite()) return g;
      theta.tail(b.size()) = b;
    }
  }
  g.a = theta(0);
  for (std::size_t c = 0; c < cols.size(); ++c) g.b(cols[c]) = theta(static_cast<Eigen::Index>(c) + 1);
  g.ok = true;
  return g;
}

Eigen::VectorXd GreyBaseline::predict_series(const std::vector<double>& time_s, const Eigen::MatrixXd& inputs) const {
  const auto n = static_cast<Eigen::Index>(time_s.size());
  Eigen::VectorXd out = Eigen::VectorXd::Constant(n, y1);
  const Eigen::Index s0 = sample_at(time_s, t1_s);
  if (!ok || s0 < 0 || inputs.cols() != b.size()) return out;
  Eigen::VectorXd du = Eigen::VectorXd::Zero(b.size());
  double dy = 0.0;
  for (Eigen::Index k = s0 + 1; k < n; ++k) {
    // Exact step of dy' = -a dy + f over (t_{k-1}, t_k] with f = b . du held.
    const double h = (time_s[static_cast<std::size_t>(k)] - time_s[static_cast<std::size_t>(k - 1)]) / 3600.0;
    const double f = b.dot(du);
    const double ah = a * h;
    dy = std::abs(ah) < 1e-8 ? dy + (f - a * dy) * h : dy * std::exp(-ah) + f * (-std::expm1(-ah)) / a;
    out(k) = y1 + dy;
    for (Eigen::Index i = 0; i < b.size(); ++i)
      if (std::isfinite(inputs(k, i))) du(i) = inputs(k, i) - u1(i);
  }
  return out;
}

// ---- one kind for all outputs ----

std::vector<std::vector<std::string>> BaselineModel::selected_inputs() const {
  std::vector<std::vector<std::string>> sel(output_names.size());
  if (kind != BaselineKind::Lasso && kind != BaselineKind::Ols) return sel;
  for (std::size_t o = 0; o < linear.size() && o < sel.size(); ++o)
    for (std::size_t i = 0; i < linear[o].selected.size() && i < input_names.size(); ++i)
      if (linear[o].selected[i]) sel[o].push_back(input_names[i]);
  return sel;
}

Eigen::MatrixXd BaselineModel::predict(const std::vector<double>& time_s, const Eigen::MatrixXd& inputs,
                                       const std::vector<std::size_t>& rows) const {
  const auto n_out = static_cast<Eigen::Index>(output_names.size());
  Eigen::MatrixXd p = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(rows.size()), n_out);
  for (Eigen::Index o = 0; o < n_out; ++o) {
    const auto uo = static_cast<std::size_t>(o);
    if (uo >= measurements.size() || measurements[uo] < 2) continue;
    if (kind == BaselineKind::Gm) {
      const Eigen::VectorXd series = grey[uo].predict_series(time_s, inputs);
      for (std::size_t r = 0; r < rows.size(); ++r) p(static_cast<Eigen::Index>(r), o) = series(static_cast<Eigen::Index>(rows[r]));
      continue;
    }
    for (std::size_t r = 0; r < rows.size(); ++r) {
      const Eigen::VectorXd x = inputs.row(static_cast<Eigen::Index>(rows[r])).transpose();
      double v = 0.0;
      if (kind == BaselineKind::Svr) {
        v = svr[uo].predict(x);
      } else if (kind == BaselineKind::Mlr) {
        v = mlr.predict(x)(o);
      } else {
        const LinearBaseline& l = linear[uo];
        v = l.intercept;
        for (Eigen::Index i = 0; i < l.coefficients.size() && i < x.size(); ++i)
          if (std::isfinite(x(i))) v += l.coefficients(i) * x(i);  // a missing input counts as 0, as in mlr
      }
      p(static_cast<Eigen::Index>(r), o) = v;
    }
  }
  return p;
}

BaselineModel fit_baseline(BaselineKind kind, const InputHistory& history, const std::vector<std::string>& output_names,
                           const std::vector<ProbeRecord>& probes) {
  BaselineModel b;
  b.kind = kind;
  b.input_names = history.input_names;
  b.output_names = output_names;
  const auto n_out = static_cast<Eigen::Index>(output_names.size());
  const auto n_in = history.inputs.cols();
  const bool history_ok = !history.time_s.empty() &&
                          history.inputs.rows() == static_cast<Eigen::Index>(history.time_s.size());
  if (kind == BaselineKind::Mlr) b.mlr = fit_static_regression(history, output_names, probes).model;
  const StaticRegression& mlr = b.mlr;
  for (Eigen::Index o = 0; o < n_out; ++o) {
    const ProbeRows pr = history_ok ? probe_rows(history, probes, o, n_out) : ProbeRows{};
    const auto m = static_cast<Eigen::Index>(pr.values.size());
    b.measurements.push_back(static_cast<int>(m));
    Eigen::MatrixXd X(m, n_in);
    for (Eigen::Index r = 0; r < m; ++r) X.row(r) = history.inputs.row(pr.rows[static_cast<std::size_t>(r)]);
    const Eigen::VectorXd y = Eigen::Map<const Eigen::VectorXd>(pr.values.data(), m);
    LinearBaseline lin;
    lin.coefficients = Eigen::VectorXd::Zero(n_in);
    switch (kind) {
      case BaselineKind::Mlr:
        if (mlr.intercept.size() == n_out) {
          lin.intercept = mlr.intercept(o);
          lin.coefficients = mlr.coefficients.row(o).transpose();
        }
        break;
      case BaselineKind::Lasso: lin = fit_lasso(X, y); break;
      case BaselineKind::Ols: lin = fit_ols(X, y); break;
      case BaselineKind::Svr: b.svr.push_back(m >= 2 ? SvrBaseline::fit_by_cv(X, y) : SvrBaseline{}); break;
      case BaselineKind::Gm: b.grey.push_back(fit_grey(pr.time_s, pr.values, history)); break;
    }
    b.linear.push_back(std::move(lin));
  }
  return b;
}

}  // namespace alc
