// identify(): structure selection and weighted least squares of the fixed-pole ARX form (route a),
// optional output-error refinement (route b), robust refinement, bounds and the fit summary.
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numeric>
#include <sstream>

#include "alc/error_kind.hpp"
#include "alc/statistics.hpp"
#include "alc/thermal_model.hpp"
#include "lag_filter.hpp"
#include "least_squares.hpp"
#include "refinement.hpp"

namespace alc {
namespace {

using Index = Eigen::Index;

std::string format_number(double v) {
  std::ostringstream os;
  os.precision(4);
  os << v;
  return os.str();
}

// Lags of input columns at every history sample: column `input * taus + k` holds the lag of `input`
// with time constant taus[k] (columns of inputs not listed stay zero). A LagCache (thermal_model.hpp).
using LagTable = LagCache;

// Samples per block of LagCache::block_min / block_max.
constexpr Index kLagBlock = 64;

Index lag_column(const LagTable& t, int input, int k) {
  return static_cast<Index>(input) * static_cast<Index>(t.taus.size()) + k;
}

// Extends `t` to every sample of `h` (from scratch if it does not describe a prefix of `h` with
// these reference values, inputs and time constants). Per column, the same arithmetic as
// ModelPredictor::step, so a model whose poles give exactly these taus continues from the table bit
// for bit; extending sample by sample and computing at once give the same doubles.
void extend_lags(LagTable& t, const InputHistory& h, const Eigen::VectorXd& ref, const std::vector<int>& inputs,
                 const std::vector<double>& taus) {
  const auto n = static_cast<Index>(h.time_s.size());
  const auto n_in = static_cast<Index>(h.input_names.size());
  const auto n_tau = static_cast<Index>(taus.size());
  const bool prefix = t.samples > 0 && t.samples <= n && t.taus == taus && t.inputs == inputs &&
                      t.reference.size() == ref.size() && t.reference == ref && t.x.cols() == n_in * n_tau &&
                      t.first_time_s == h.time_s.front() &&
                      h.time_s[static_cast<std::size_t>(t.samples - 1)] == t.last_time_s &&
                      t.last_row.size() == n_in && h.inputs.row(t.samples - 1) == t.last_row;
  if (!prefix) {
    t = LagTable{};
    t.taus = taus;
    t.inputs = inputs;
    t.reference = ref;
    t.held = ref;
    t.factor = Eigen::VectorXd::Zero(n_tau);
  }
  if (n == t.samples) return;
  if (t.x.rows() < n) {
    // Grow geometrically: the controller appends a sample at a time.
    const Index capacity = std::max<Index>({n, 2 * t.x.rows(), 1024});
    Eigen::MatrixXd grown = Eigen::MatrixXd::Zero(capacity, n_in * n_tau);
    grown.topRows(t.samples) = t.x.topRows(t.samples);
    t.x.swap(grown);
    const Index blocks = (capacity + kLagBlock - 1) / kLagBlock;
    const Index kept_blocks = (t.samples + kLagBlock - 1) / kLagBlock;
    for (Eigen::MatrixXd* range : {&t.block_min, &t.block_max}) {
      Eigen::MatrixXd grown_range = Eigen::MatrixXd::Zero(blocks, n_in * n_tau);
      grown_range.topRows(kept_blocks) = range->topRows(kept_blocks);
      range->swap(grown_range);
    }
  }
  const Index first_new = t.samples;
  Index s = t.samples;
  if (s == 0) {
    t.first_time_s = t.last_time_s = h.time_s.front();
    for (const int i : inputs) {
      const double u0 = h.inputs(0, i);
      t.held(i) = std::isfinite(u0) ? u0 : ref(i);
      for (Index k = 0; k < n_tau; ++k) t.x(0, lag_column(t, i, static_cast<int>(k))) = t.held(i) - ref(i);
    }
    s = 1;
  }
  for (; s < n; ++s) {
    const double time = h.time_s[static_cast<std::size_t>(s)];
    const double dt = time - t.last_time_s;
    const bool advance = dt > 0.0;
    if (advance) {
      if (dt != t.last_dt_s) {
        for (Index k = 0; k < n_tau; ++k) t.factor(k) = detail::lag_factor(dt, taus[static_cast<std::size_t>(k)]);
        t.last_dt_s = dt;
      }
      t.last_time_s = time;
    }
    for (const int i : inputs) {
      const double u_held = t.held(i) - ref(i);
      for (Index k = 0; k < n_tau; ++k) {
        const Index c = lag_column(t, i, static_cast<int>(k));
        t.x(s, c) = advance ? detail::lag_step(t.x(s - 1, c), t.factor(k), u_held) : t.x(s - 1, c);
      }
      const double u = h.inputs(s, i);
      if (std::isfinite(u)) t.held(i) = u;
    }
  }
  for (Index c = 0; c < t.x.cols(); ++c) {
    for (Index r = first_new; r < n; ++r) {
      const Index b = r / kLagBlock;
      const double v = t.x(r, c);
      if (r % kLagBlock == 0) {
        t.block_min(b, c) = t.block_max(b, c) = v;
      } else {
        t.block_min(b, c) = std::min(t.block_min(b, c), v);
        t.block_max(b, c) = std::max(t.block_max(b, c), v);
      }
    }
  }
  t.samples = n;
  t.last_row = h.inputs.row(n - 1);
}

LagTable lag_table(const InputHistory& h, const Eigen::VectorXd& ref, const std::vector<int>& inputs,
                   const std::vector<double>& taus) {
  LagTable t;
  extend_lags(t, h, ref, inputs, taus);
  return t;
}

// Chosen structure of one output: history input columns and indices into the pole grid.
struct Structure {
  std::vector<int> inputs;
  std::vector<int> poles;
  Index parameters() const { return 1 + static_cast<Index>(inputs.size() * poles.size()); }
};

// The measurements of one output and the lag table their regressors come from.
class OutputData {
 public:
  OutputData(const LagTable& lags, std::vector<Index> row_sample, Eigen::VectorXd y, Eigen::VectorXd w,
             const IdentificationOptions& options)
      : lags_(lags), row_sample_(std::move(row_sample)), y_(std::move(y)), w_(std::move(w)), options_(options) {
    const double ms = (w_.array() * y_.array().square()).sum() / w_.sum();
    floor_ = 1e-12 * ms + 1e-300;  // relative RMS 1e-6: below this every fit counts as exact
  }
  OutputData(const OutputData&) = delete;
  OutputData& operator=(const OutputData&) = delete;

  Index rows() const { return y_.size(); }
  const Eigen::VectorXd& y() const { return y_; }
  const Eigen::VectorXd& w() const { return w_; }

  Eigen::MatrixXd design(const Structure& s) const {
    Eigen::MatrixXd phi(rows(), s.parameters());
    phi.col(0).setOnes();
    Index c = 1;
    for (const int i : s.inputs) {
      for (const int g : s.poles) {
        const auto lag = lags_.x.col(lag_column(lags_, i, g));
        for (Index r = 0; r < rows(); ++r) phi(r, c) = lag(row_sample_[static_cast<std::size_t>(r)]);
        ++c;
      }
    }
    return phi;
  }

  // The nearly unbiased weighted least squares fit of a structure (the search's solve).
  detail::LinearFit fit(const Structure& s) const { return search().all.fit(columns(s), 1); }

  // Lower is better. BIC/AIC on the weighted residual variance; hold-out on every 4th measurement.
  double criterion(const Structure& s) const {
    const Search& search = this->search();
    const std::vector<Index>& cols = columns(s);
    const auto m = static_cast<double>(rows());
    const auto p = static_cast<double>(s.parameters());
    if (!search.folds.empty()) {
      // 4-fold cross-validation: fold f holds out every 4th measurement from the f-th on; the
      // held-out errors of all folds together score the structure (one fold alone is too noisy
      // to choose among dozens of structures).
      double sse = 0.0;
      double w_sum = 0.0;
      for (Index f = 0; f < 4; ++f) {
        const detail::LinearFit fit = search.folds[static_cast<std::size_t>(f)].fit(cols, 1, &search.residual);
        if (!fit.ok) return kInf;
        const Eigen::VectorXd& w_val = search.held_out[static_cast<std::size_t>(f)];
        sse += (w_val.array() * search.residual.array().square()).sum();
        w_sum += w_val.sum();
      }
      if (!(w_sum > 0.0)) return kInf;
      return std::log(sse / w_sum + floor_) + 0.01 * p;  // 1 % per parameter breaks ties towards the simpler
    }
    const detail::LinearFit fit = search.all.fit(cols, 1);
    if (!fit.ok) return kInf;
    const double penalty = options_.criterion == StructureCriterion::AIC ? 2.0 : std::log(m);
    return m * std::log(fit.weighted_rss / fit.weight_sum + floor_) + penalty * p;
  }

 private:
  // The structure is chosen on nearly unbiased fits; the final fit shrinks with options.ridge. A
  // strong ridge in the search leaves structured residuals that more inputs and poles then chase.
  double selection_ridge() const { return std::min(options_.ridge, kSelectionRidge); }
  static constexpr double kSelectionRidge = 1e-6;

  // What the structure search solves on: every column it may choose (the offset, then each column
  // of the lag table) at the rows, with the Gram matrices of all of them formed once.
  struct Search {
    Eigen::MatrixXd z;                                 // rows x (1 + lag table columns)
    detail::SubsetLeastSquares all;                    // weights w
    std::vector<detail::SubsetLeastSquares> folds;     // hold-out: weights w without fold f's rows
    std::vector<Eigen::VectorXd> held_out;             // hold-out: weights of fold f's rows only
    mutable Eigen::VectorXd residual;                  // scratch
    Search(Eigen::MatrixXd z_, const Eigen::VectorXd& y, const Eigen::VectorXd& w, double ridge)
        : z(std::move(z_)), all(z, y, w, ridge) {}
  };
  const Search& search() const {
    if (!search_) {
      const Index lag_cols = lags_.x.cols();
      Eigen::MatrixXd z(rows(), 1 + lag_cols);
      z.col(0).setOnes();
      for (Index c = 0; c < lag_cols; ++c)
        for (Index r = 0; r < rows(); ++r) z(r, 1 + c) = lags_.x(row_sample_[static_cast<std::size_t>(r)], c);
      search_ = std::make_unique<Search>(std::move(z), y_, w_, selection_ridge());
      if (options_.criterion == StructureCriterion::HoldOut && rows() >= 8) {
        search_->folds.reserve(4);  // the solvers keep references: no reallocation after this
        for (Index f = 0; f < 4; ++f) {
          Eigen::VectorXd w_fit = w_;
          Eigen::VectorXd w_val = Eigen::VectorXd::Zero(rows());
          for (Index r = f; r < rows(); r += 4) std::swap(w_fit(r), w_val(r));
          search_->folds.emplace_back(search_->z, y_, w_fit, selection_ridge());
          search_->held_out.push_back(std::move(w_val));
        }
      }
    }
    return *search_;
  }
  // Columns of Search::z of a structure, in the order of design(s).
  const std::vector<Index>& columns(const Structure& s) const {
    columns_.assign(1, 0);
    for (const int i : s.inputs)
      for (const int g : s.poles) columns_.push_back(1 + lag_column(lags_, i, g));
    return columns_;
  }

  const LagTable& lags_;
  std::vector<Index> row_sample_;                            // history sample of each row
  Eigen::VectorXd y_;
  Eigen::VectorXd w_;
  const IdentificationOptions& options_;
  double floor_ = 0.0;
  mutable std::unique_ptr<Search> search_;                   // built by the first search call
  mutable std::vector<Index> columns_;                       // scratch of columns()
};

// Forward selection of inputs (each brings one lag per pole) while the criterion improves.
std::vector<int> select_inputs(const OutputData& d, const std::vector<int>& candidates, const std::vector<int>& poles,
                               const IdentificationOptions& o) {
  Structure s{{}, poles};
  double best = d.criterion(s);
  while (static_cast<int>(s.inputs.size()) < o.max_inputs) {
    int best_input = -1;
    double best_new = best;
    for (const int c : candidates) {
      if (std::find(s.inputs.begin(), s.inputs.end(), c) != s.inputs.end()) continue;
      Structure t = s;
      t.inputs.push_back(c);
      if (t.parameters() > d.rows() - 2) continue;
      const double v = d.criterion(t);
      if (v < best_new) {
        best_new = v;
        best_input = c;
      }
    }
    if (best_input < 0) break;
    s.inputs.push_back(best_input);
    best = best_new;
  }
  std::sort(s.inputs.begin(), s.inputs.end());
  return s.inputs;
}

// Every subset of the pole grid of size 1..max_order; the best criterion wins, the lower order on a tie.
std::vector<int> select_poles(const OutputData& d, const std::vector<int>& inputs, int grid_size,
                              const IdentificationOptions& o) {
  std::vector<int> best_poles{grid_size / 2};
  double best = kInf;
  for (int k = 1; k <= o.max_order; ++k) {
    if (1 + static_cast<Index>(inputs.size()) * k > std::max<Index>(d.rows() - 2, 2)) break;
    std::vector<int> subset(static_cast<std::size_t>(k));
    std::iota(subset.begin(), subset.end(), 0);
    while (true) {
      const double v = d.criterion(Structure{inputs, subset});
      if (v < best) {
        best = v;
        best_poles = subset;
      }
      // next combination in lexicographic order
      int i = k - 1;
      while (i >= 0 && subset[static_cast<std::size_t>(i)] == grid_size - k + i) --i;
      if (i < 0) break;
      ++subset[static_cast<std::size_t>(i)];
      for (int j = i + 1; j < k; ++j) subset[static_cast<std::size_t>(j)] = subset[static_cast<std::size_t>(j - 1)] + 1;
    }
  }
  return best_poles;
}

struct OutputSimulation {
  Eigen::VectorXd at_rows;   // prediction at each measurement sample
  bool beyond = false;       // |prediction| exceeds the limit somewhere from the first to the last
                             // measurement sample (or is not finite there)
  double peak = 0.0;         // if beyond: the largest |prediction| over that span
  bool finite = true;
  Eigen::VectorXd end_lags;  // lag states after the last sample (input-major, pole-minor)
};

// The unclamped prediction of an output model whose lags are columns `cols` of `table`, at the
// measurement samples, and whether it stays within `limit` between them. A block of the table
// whose column ranges bound the prediction within the limit is not simulated; the others are, and
// the whole span only when the limit is exceeded (for the peak in the message).
OutputSimulation simulate_output(const LagTable& table, const std::vector<Index>& cols, const Eigen::VectorXd& theta,
                                 const std::vector<Index>& row_sample, double limit) {
  OutputSimulation out;
  const auto lags = static_cast<Index>(cols.size());
  out.at_rows.resize(static_cast<Index>(row_sample.size()));
  out.end_lags.resize(lags);
  const Index last_row = table.samples - 1;
  for (Index c = 0; c < lags; ++c) out.end_lags(c) = table.x(last_row, cols[static_cast<std::size_t>(c)]);
  for (std::size_t r = 0; r < row_sample.size(); ++r) {
    double v = theta(0);
    for (Index c = 0; c < lags; ++c) v += theta(1 + c) * table.x(row_sample[r], cols[static_cast<std::size_t>(c)]);
    out.at_rows(static_cast<Index>(r)) = v;
  }
  if (row_sample.empty()) return out;
  const Index first = row_sample.front();
  const Index last = row_sample.back();
  // The prediction over [begin, end], its peak and finiteness.
  Eigen::Matrix<double, kLagBlock, 1> block;
  const auto simulate = [&](Index begin, Index end) {
    auto v = block.head(end + 1 - begin);
    v.setConstant(theta(0));
    for (Index c = 0; c < lags; ++c) v += theta(1 + c) * table.x.col(cols[static_cast<std::size_t>(c)]).segment(begin, v.size());
    out.finite = out.finite && v.allFinite();
    out.peak = std::max(out.peak, v.cwiseAbs().maxCoeff());
  };
  // Rounding: the bound's sums round like the prediction's, within a relative 1e-12.
  const double safe = limit * (1.0 - 1e-12);
  for (Index b = first / kLagBlock; b <= last / kLagBlock && !out.beyond; ++b) {
    double hi = theta(0);
    double lo = theta(0);
    for (Index c = 0; c < lags; ++c) {
      const double g = theta(1 + c);
      const double x_min = table.block_min(b, cols[static_cast<std::size_t>(c)]);
      const double x_max = table.block_max(b, cols[static_cast<std::size_t>(c)]);
      hi += g >= 0.0 ? g * x_max : g * x_min;
      lo += g >= 0.0 ? g * x_min : g * x_max;
    }
    if (std::max(std::abs(hi), std::abs(lo)) <= safe) continue;  // (false for NaN)
    simulate(std::max(first, b * kLagBlock), std::min(last, b * kLagBlock + kLagBlock - 1));
    out.beyond = !out.finite || out.peak > limit;
  }
  if (out.beyond) {
    out.peak = 0.0;
    for (Index b = first; b <= last; b += kLagBlock) simulate(b, std::min(last, b + kLagBlock - 1));
  }
  return out;
}

}  // namespace

FitResult identify(const InputHistory& history, const std::vector<std::string>& output_names,
                   const std::vector<ProbeRecord>& probes, const IdentificationOptions& options, LagCache* cache) {
  return refit(history, output_names, probes, options, ThermalModel{}, cache);
}

FitResult refit(const InputHistory& history, const std::vector<std::string>& output_names,
                const std::vector<ProbeRecord>& probes, const IdentificationOptions& options,
                const ThermalModel& structure, LagCache* cache) {
  FitResult result;
  const auto fail = [&result](std::string why) {
    result.usable = false;
    result.message = std::move(why);
    return result;
  };
  if (std::string why = options.validate(); !why.empty()) return fail(why);
  const auto n_samples = static_cast<Index>(history.time_s.size());
  const auto n_in = static_cast<Index>(history.input_names.size());
  if (n_samples == 0) return fail("empty input history");
  if (history.inputs.rows() != n_samples || history.inputs.cols() != n_in)
    return fail("input history is " + std::to_string(history.inputs.rows()) + " x " + std::to_string(history.inputs.cols()) +
                ", expected " + std::to_string(n_samples) + " samples x " + std::to_string(n_in) + " inputs");
  if (output_names.empty()) return fail("no output to identify");
  const auto n_out = static_cast<Index>(output_names.size());

  // Reference: the first sample, so that every lag starts at zero.
  Eigen::VectorXd reference(n_in);
  for (Index i = 0; i < n_in; ++i) reference(i) = std::isfinite(history.inputs(0, i)) ? history.inputs(0, i) : 0.0;

  // Measurements inside the window, in time order, with their history sample.
  std::vector<const ProbeRecord*> used;
  for (const ProbeRecord& p : probes) {
    if (p.time_s >= options.window_start_s && p.time_s >= history.time_s.front() && p.errors.size() == n_out &&
        std::isfinite(p.time_s) && p.weight > 0.0 && std::isfinite(p.weight))
      used.push_back(&p);
  }
  std::stable_sort(used.begin(), used.end(), [](const ProbeRecord* a, const ProbeRecord* b) { return a->time_s < b->time_s; });
  std::vector<Index> sample_of(used.size());
  for (std::size_t j = 0; j < used.size(); ++j) {
    const auto it = std::upper_bound(history.time_s.begin(), history.time_s.end(), used[j]->time_s);
    sample_of[j] = static_cast<Index>(it - history.time_s.begin()) - 1;
  }
  std::vector<Index> samples = sample_of;
  samples.erase(std::unique(samples.begin(), samples.end()), samples.end());
  const Index last_sample = samples.empty() ? 0 : samples.back();

  // Inputs that vary before the last measurement are candidates; the others cannot explain anything.
  std::vector<int> candidates;
  std::vector<std::string> constant;
  for (Index i = 0; i < n_in; ++i) {
    const auto col = history.inputs.col(i).head(last_sample + 1);
    double lo = kInf;
    double hi = -kInf;
    for (Index s = 0; s < col.size(); ++s) {
      if (!std::isfinite(col(s))) continue;
      lo = std::min(lo, col(s));
      hi = std::max(hi, col(s));
    }
    if (hi - lo > 1e-9 * std::max(1.0, std::abs(hi)))
      candidates.push_back(static_cast<int>(i));
    else
      constant.push_back(history.input_names[static_cast<std::size_t>(i)]);
  }

  // The pole grid, defined by its discrete poles: a model built from grid poles steps with exactly
  // the time constants of the table below, so its predictor continues from the table bit for bit.
  const int grid_size = options.pole_grid_size;
  std::vector<double> grid_pole(static_cast<std::size_t>(grid_size));
  std::vector<double> grid(static_cast<std::size_t>(grid_size));
  for (int g = 0; g < grid_size; ++g) {
    const double tau = grid_size == 1 ? options.tau_min_s
                                      : options.tau_min_s * std::pow(options.tau_max_s / options.tau_min_s, double(g) / (grid_size - 1));
    grid_pole[static_cast<std::size_t>(g)] = pole_of_time_constant(tau, options.base_step_s);
    grid[static_cast<std::size_t>(g)] = time_constant_of_pole(grid_pole[static_cast<std::size_t>(g)], options.base_step_s);
  }
  // Lags of every candidate input for every grid time constant at every sample, in one pass each:
  // the structure search, the final fit, the bound check and the predictor state all read it.
  // Every input, not only the candidates: a kept structure may use an input that is constant now.
  std::vector<int> all_inputs(static_cast<std::size_t>(n_in));
  std::iota(all_inputs.begin(), all_inputs.end(), 0);
  // A cache passed in is extended by the samples added since the last call instead of recomputed.
  LagTable local_lags;
  LagTable& grid_lags = cache ? *cache : local_lags;
  extend_lags(grid_lags, history, reference, all_inputs, grid);

  ThermalModel model;
  model.input_names = history.input_names;
  model.input_reference = reference;
  model.base_step_s = options.base_step_s;
  result.usable = true;
  std::string messages;
  std::vector<Eigen::VectorXd> end_lags;  // lag states of each usable output after the last sample
  int fitted = 0;                         // outputs with a fit (usable or not), not set aside for too few data
  std::string unmeasured;                 // the outputs set aside for too few measurements, with why

  for (Index o = 0; o < n_out; ++o) {
    const std::string& name = output_names[static_cast<std::size_t>(o)];
    OutputFitSummary sum;
    sum.name = name;
    OutputModel om;
    om.name = name;
    om.parameters = Eigen::VectorXd::Zero(1);
    const double scale = error_kind(name) == ErrorKind::Angular ? options.robust_scale_ang : options.robust_scale_lin;
    const std::string unit(unit_of(error_kind(name)));

    // Rows of this output.
    std::vector<Index> row_sample;
    std::vector<double> ys;
    std::vector<double> ts;
    std::vector<double> ws;
    for (std::size_t j = 0; j < used.size(); ++j) {
      const double y = used[j]->errors(o);
      if (!std::isfinite(y)) continue;
      row_sample.push_back(sample_of[j]);
      ys.push_back(y);
      ts.push_back(used[j]->time_s);
      ws.push_back(used[j]->weight);
    }
    const auto m = static_cast<Index>(ys.size());
    sum.measurements = static_cast<int>(m);
    const auto unusable = [&](std::string why) {
      sum.usable = false;
      sum.message = std::move(why);
      result.usable = false;
      messages += (messages.empty() ? "" : "; ") + name + ": " + sum.message;
      result.outputs.push_back(sum);
      model.outputs.push_back(om);
    };
    if (m < options.min_measurements) {
      // Too few measurements of this output alone (not measured, or its readings set aside as a sensor
      // fault): it gets no model (predicts 0, not compensated) and does not hold back the others; the
      // fit is usable when some other output's is.
      sum.message = "only " + std::to_string(m) + " measurements in the window (min_measurements = " +
                    std::to_string(options.min_measurements) + ")";
      unmeasured += (unmeasured.empty() ? "" : "; ") + name + ": " + sum.message;
      result.outputs.push_back(sum);
      model.outputs.push_back(om);
      end_lags.emplace_back();  // no inputs, no lags
      continue;
    }
    ++fitted;
    if (candidates.empty()) {
      std::string names;
      for (const std::string& c : constant) names += (names.empty() ? "" : ", ") + c;
      unusable("every input is constant over the data (" + names + ")");
      continue;
    }
    Eigen::VectorXd y = Eigen::Map<Eigen::VectorXd>(ys.data(), m);
    Eigen::VectorXd w = Eigen::Map<Eigen::VectorXd>(ws.data(), m);
    if (std::isfinite(options.forgetting_half_life_s)) {
      for (Index r = 0; r < m; ++r) w(r) *= std::exp2(-(ts.back() - ts[static_cast<std::size_t>(r)]) / options.forgetting_half_life_s);
    }
    // A structure to keep (refit): its inputs and poles. Grid poles read the grid table; other poles
    // (from the output-error route) get a table of their own.
    const OutputModel* kept = nullptr;
    if (structure.input_names == history.input_names && structure.base_step_s == options.base_step_s) {
      for (const OutputModel& prior : structure.outputs)
        // An output without inputs had too few measurements last time: its structure is searched anew.
        if (prior.name == name && !prior.inputs.empty() &&
            prior.parameters.size() == 1 + static_cast<Index>(prior.inputs.size()) * prior.poles.size())
          kept = &prior;
    }
    std::vector<int> kept_grid;  // grid index of each kept pole, empty if one is off the grid
    LagTable kept_lags;
    if (kept) {
      for (Index k = 0; k < kept->poles.size(); ++k) {
        const auto it = std::find(grid_pole.begin(), grid_pole.end(), kept->poles(k));
        if (it == grid_pole.end()) break;
        kept_grid.push_back(static_cast<int>(it - grid_pole.begin()));
      }
      if (static_cast<Index>(kept_grid.size()) != kept->poles.size()) {
        kept_grid.clear();
        std::vector<double> taus;
        for (Index k = 0; k < kept->poles.size(); ++k) taus.push_back(time_constant_of_pole(kept->poles(k), options.base_step_s));
        kept_lags = lag_table(history, reference, kept->inputs, taus);
      }
    }
    const bool own_table = kept && kept_grid.empty() && kept->poles.size() > 0;
    const LagTable& table = own_table ? kept_lags : grid_lags;
    const OutputData data(table, row_sample, y, w, options);

    // Structure: inputs with the middle pole, then the poles, then the inputs again with those poles.
    Structure s{{}, {grid_size / 2}};
    if (kept) {
      s.inputs = kept->inputs;
      s.poles = kept_grid;
      if (own_table) {
        s.poles.resize(static_cast<std::size_t>(kept->poles.size()));
        std::iota(s.poles.begin(), s.poles.end(), 0);
      }
    } else {
      s.inputs = options.select_inputs ? select_inputs(data, candidates, s.poles, options) : candidates;
    }
    if (kept) {
      // structure kept as it is
    } else if (!s.inputs.empty()) {
      s.poles = select_poles(data, s.inputs, grid_size, options);
      if (options.select_inputs) {
        std::vector<int> again = select_inputs(data, candidates, s.poles, options);
        if (!again.empty() && again != s.inputs) {
          s.inputs = again;
          s.poles = select_poles(data, s.inputs, grid_size, options);
        }
      }
    } else {
      s.poles.clear();
    }

    // Weighted least squares (QR) of the chosen structure.
    const Eigen::MatrixXd phi = data.design(s);
    const detail::LinearFit fit = detail::solve_weighted_ridge(phi, y, w, options.ridge, 1);
    if (!fit.ok) {
      unusable("weighted least squares gave no finite solution");
      continue;
    }
    detail::Conditioning cond;
    if (options.fit_statistics) cond = detail::conditioning(phi, w, fit.weighted_rss);
    else cond.condition = std::numeric_limits<double>::quiet_NaN();
    Eigen::VectorXd theta = fit.theta;
    std::vector<double> tau;
    for (const int g : s.poles) tau.push_back(table.taus[static_cast<std::size_t>(g)]);
    std::string notes;
    if (!constant.empty()) notes += "constant inputs ignored: " + std::to_string(constant.size()) + "; ";
    if (s.inputs.empty()) notes += "no input improves the criterion: offset only; ";
    if (s.parameters() >= m) notes += "more parameters than measurements, ridge decides; ";

    detail::RobustSettings rs{options.robust_loss, scale, options.ridge, options.max_iterations};
    if (kept) notes += "structure kept, parameters refitted; ";
    if (!kept && !s.inputs.empty() && options.method == IdentificationMethod::OutputError) {
      detail::OutputErrorData oe{&history, reference, s.inputs, row_sample, y, w, options.tau_min_s / 2.0,
                                 options.tau_max_s * 2.0};
      const detail::Refinement r = detail::refine_output_error(oe, tau, theta, rs);
      sum.cost_before = r.cost_before;
      sum.cost_after = r.cost_after;
      if (r.ok && r.cost_after <= r.cost_before) {
        theta = r.theta;
        tau = r.tau_s;
      } else {
        notes += r.message.empty() ? "output error did not improve, fixed-pole fit kept; " : r.message + "; ";
      }
    } else if (options.robust_loss != RobustLoss::None && m > s.parameters()) {
      const detail::Refinement r = detail::refine_gains(phi, y, w, theta, rs);
      sum.cost_before = r.cost_before;
      sum.cost_after = r.cost_after;
      if (r.ok) theta = r.theta; else notes += r.message + "; ";
    }

    om.order = static_cast<int>(tau.size());
    om.inputs = s.inputs;
    om.parameters = theta;
    om.poles.resize(static_cast<Index>(tau.size()));
    // Poles exactly as the table's (grid or kept), unless the output-error step moved them.
    const bool moved = tau.size() != s.poles.size() ||
                       !std::equal(tau.begin(), tau.end(), s.poles.begin(), [&](double t, int g) {
                         return t == table.taus[static_cast<std::size_t>(g)];
                       });
    for (std::size_t k = 0; k < tau.size(); ++k)
      om.poles(static_cast<Index>(k)) = moved ? pole_of_time_constant(tau[k], options.base_step_s)
                                              : (own_table ? kept->poles(static_cast<Index>(k))
                                                           : grid_pole[static_cast<std::size_t>(s.poles[k])]);

    // The prediction over the history: residuals at the probes, the bound between them, the state.
    LagTable moved_lags;
    std::vector<Index> cols;
    if (moved) {
      std::vector<double> taus;
      for (Index k = 0; k < om.poles.size(); ++k) taus.push_back(time_constant_of_pole(om.poles(k), options.base_step_s));
      moved_lags = lag_table(history, reference, s.inputs, taus);
      for (const int i : s.inputs)
        for (std::size_t k = 0; k < taus.size(); ++k) cols.push_back(lag_column(moved_lags, i, static_cast<int>(k)));
    } else {
      for (const int i : s.inputs)
        for (const int g : s.poles) cols.push_back(lag_column(table, i, g));
    }
    double y_max = 0.0;
    for (Index r = 0; r < m; ++r) y_max = std::max(y_max, std::abs(y(r)));
    om.output_limit = std::max(options.output_limit_factor * y_max, 20.0 * scale);
    const OutputSimulation sim = simulate_output(moved ? moved_lags : table, cols, theta, row_sample, om.output_limit);
    const bool finite = sim.finite && sim.at_rows.allFinite();
    const Eigen::VectorXd e = y - sim.at_rows;
    const double rss = e.squaredNorm();
    sum.residual_max = e.size() ? e.cwiseAbs().maxCoeff() : 0.0;
    end_lags.push_back(sim.end_lags);
    sum.residual_rms = std::sqrt(rss / static_cast<double>(m));
    sum.order = om.order;
    for (const int i : s.inputs) sum.inputs_chosen.push_back(history.input_names[static_cast<std::size_t>(i)]);
    sum.condition = cond.condition;
    if (!kept) {
      // Significance of each chosen input (seed 000's OLS p-values): the partial F test of dropping
      // its lags from the chosen structure, on the search's nearly unbiased fits.
      const detail::LinearFit with_all = data.fit(s);
      const double dof = static_cast<double>(m - s.parameters());
      const double k = static_cast<double>(s.poles.size());
      for (std::size_t j = 0; j < s.inputs.size(); ++j) {
        Structure reduced = s;
        reduced.inputs.erase(reduced.inputs.begin() + static_cast<std::ptrdiff_t>(j));
        const detail::LinearFit without = data.fit(reduced);
        double p_value = std::numeric_limits<double>::quiet_NaN();
        if (with_all.ok && without.ok && dof >= 1.0 && k > 0.0 && with_all.weighted_rss > 0.0) {
          const double f = ((without.weighted_rss - with_all.weighted_rss) / k) / (with_all.weighted_rss / dof);
          p_value = f_distribution_sf(std::max(f, 0.0), k, dof);
        }
        sum.input_p_values.push_back(p_value);
      }
    }
    sum.time_constants_s = tau;
    sum.parameter_std = cond.parameter_std;
    if (!finite || !theta.allFinite()) {
      unusable("the fitted model does not give finite predictions");
      continue;
    }
    if (sim.beyond) {
      unusable("prediction between the probes reaches " + format_number(sim.peak) + " " + unit + ", beyond the bound " +
               format_number(om.output_limit) + " " + unit + " (" + format_number(options.output_limit_factor) +
               " x the largest measured error)");
      continue;
    }
    sum.usable = true;
    if (!notes.empty()) notes.resize(notes.size() - 2);
    sum.message = notes;
    result.outputs.push_back(sum);
    model.outputs.push_back(om);
  }

  if (fitted == 0) {
    result.usable = false;
    messages = unmeasured + (messages.empty() ? "" : "; " + messages);
  }
  result.message = !result.usable      ? messages
                   : unmeasured.empty() ? "identified " + std::to_string(n_out) + " outputs"
                                        : "identified " + std::to_string(fitted) + " of " + std::to_string(n_out) +
                                              " outputs; not compensated (" + unmeasured + ")";
  result.model = std::move(model);
  if (result.usable) {
    // The state of ModelPredictor(model) after every sample (layout in thermal_model.hpp), built
    // from the simulations above instead of a second pass.
    Index lag_count = 0;
    for (const Eigen::VectorXd& l : end_lags) lag_count += l.size();
    Eigen::VectorXd state(2 + n_in + lag_count);
    state(0) = 1.0;
    // The grid table has stepped every input over every sample: its clock and held inputs are the
    // predictor's.
    state(1) = grid_lags.last_time_s;
    state.segment(2, n_in) = grid_lags.held;
    Index at = 2 + n_in;
    for (const Eigen::VectorXd& l : end_lags) {
      state.segment(at, l.size()) = l;
      at += l.size();
    }
    result.predictor_state = state;
  }
  return result;
}

}  // namespace alc
