#include "alc/static_regression.hpp"

#include <algorithm>
#include <cmath>

#include "least_squares.hpp"

namespace alc {

Eigen::VectorXd StaticRegression::predict(const Eigen::VectorXd& inputs) const {
  Eigen::VectorXd u = Eigen::VectorXd::Zero(coefficients.cols());
  for (Eigen::Index i = 0; i < u.size() && i < inputs.size(); ++i) u(i) = std::isfinite(inputs(i)) ? inputs(i) : 0.0;
  return intercept + coefficients * u;
}

ProbeRows probe_rows(const InputHistory& history, const std::vector<ProbeRecord>& probes, Eigen::Index output,
                     Eigen::Index outputs) {
  ProbeRows r;
  if (history.time_s.empty()) return r;
  for (const ProbeRecord& p : probes) {
    if (p.errors.size() != outputs || !std::isfinite(p.errors(output)) || p.time_s < history.time_s.front()) continue;
    const auto it = std::upper_bound(history.time_s.begin(), history.time_s.end(), p.time_s);
    const Eigen::Index s = static_cast<Eigen::Index>(it - history.time_s.begin()) - 1;
    if (!history.inputs.row(s).allFinite()) continue;
    r.rows.push_back(s);
    r.values.push_back(p.errors(output));
    r.time_s.push_back(p.time_s);
  }
  return r;
}

std::vector<Eigen::Index> varying_inputs(const InputHistory& history, const std::vector<Eigen::Index>& rows) {
  std::vector<Eigen::Index> varying;
  if (rows.empty()) return varying;
  for (Eigen::Index i = 0; i < history.inputs.cols(); ++i) {
    double lo = history.inputs(rows[0], i);
    double hi = lo;
    for (const Eigen::Index s : rows) {
      lo = std::min(lo, history.inputs(s, i));
      hi = std::max(hi, history.inputs(s, i));
    }
    if (hi - lo > 0.0 && hi - lo > 1e-9 * std::max(std::abs(hi), std::abs(lo))) varying.push_back(i);  // any unit
  }
  return varying;
}

StaticRegressionFit fit_static_regression(const InputHistory& history, const std::vector<std::string>& output_names,
                                          const std::vector<ProbeRecord>& probes, double ridge) {
  StaticRegressionFit fit;
  const auto n_in = static_cast<Eigen::Index>(history.input_names.size());
  const auto n_out = static_cast<Eigen::Index>(output_names.size());
  fit.model.input_names = history.input_names;
  fit.model.output_names = output_names;
  fit.model.intercept = Eigen::VectorXd::Zero(n_out);
  fit.model.coefficients = Eigen::MatrixXd::Zero(n_out, n_in);
  fit.usable = n_out > 0;
  if (history.time_s.empty() || history.inputs.rows() != static_cast<Eigen::Index>(history.time_s.size()) ||
      history.inputs.cols() != n_in || !(ridge >= 0.0)) {
    fit.usable = false;
    fit.message = "no usable input history";
    fit.measurements.assign(output_names.size(), 0);
    return fit;
  }
  for (Eigen::Index o = 0; o < n_out; ++o) {
    const ProbeRows pr = probe_rows(history, probes, o, n_out);
    const std::vector<Eigen::Index>& rows = pr.rows;
    const std::vector<double>& ys = pr.values;
    const auto m = static_cast<Eigen::Index>(ys.size());
    fit.measurements.push_back(static_cast<int>(m));
    if (m < 2) {
      fit.usable = false;
      fit.message += (fit.message.empty() ? "" : "; ") + output_names[static_cast<std::size_t>(o)] + ": only " +
                     std::to_string(m) + " measurements";
      continue;
    }
    const std::vector<Eigen::Index> varying = varying_inputs(history, rows);
    Eigen::MatrixXd phi(m, 1 + static_cast<Eigen::Index>(varying.size()));
    phi.col(0).setOnes();
    for (Eigen::Index r = 0; r < m; ++r)
      for (std::size_t c = 0; c < varying.size(); ++c) phi(r, static_cast<Eigen::Index>(c) + 1) = history.inputs(rows[static_cast<std::size_t>(r)], varying[c]);
    const Eigen::VectorXd y = Eigen::Map<const Eigen::VectorXd>(ys.data(), m);
    // Centre the inputs so that the unpenalised b0 is the mean and the ridge acts on the slopes only.
    Eigen::VectorXd mean = Eigen::VectorXd::Zero(phi.cols());
    for (Eigen::Index c = 1; c < phi.cols(); ++c) {
      mean(c) = phi.col(c).mean();
      phi.col(c).array() -= mean(c);
    }
    const detail::LinearFit lf = detail::solve_weighted_ridge(phi, y, Eigen::VectorXd::Ones(m), ridge, 1);
    if (!lf.ok) {
      fit.usable = false;
      fit.message += (fit.message.empty() ? "" : "; ") + output_names[static_cast<std::size_t>(o)] + ": no finite solution";
      continue;
    }
    double b0 = lf.theta(0);
    for (std::size_t c = 0; c < varying.size(); ++c) {
      const double b = lf.theta(static_cast<Eigen::Index>(c) + 1);
      fit.model.coefficients(o, varying[c]) = b;
      b0 -= b * mean(static_cast<Eigen::Index>(c) + 1);
    }
    fit.model.intercept(o) = b0;
  }
  return fit;
}

}  // namespace alc
