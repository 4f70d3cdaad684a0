#pragma once
// Thermal error model (ARX family) and its identification from irregular probe measurements.
//
// Contract used by the controller (alc/controller.hpp), the replay, the study and the supervisor:
// - A ThermalModel is a value: structure + parameters for every output. It can be copied, compared,
//   and saved/restored exactly (all fields are plain numbers/strings).
// - A ModelPredictor runs a model forward over input samples in time order and returns the
//   predicted errors at every sample. Its state is a value too (save/restore bit for bit).
// - identify() fits a model from the input history and the probe measurements. It never throws
//   for bad data: it returns FitResult with usable == false and a reason, and the caller keeps the
//   previous model.
//
// The model of one output (docs/identification.md) is a bank of first-order lags per input,
//   x_{i,k}(t) = lag with time constant tau_k of (u_i(t) - input_reference_i), unit static gain,
//   y(t)       = b0 + sum_i sum_k theta_{i,k} * x_{i,k}(t),
// i.e. the partial-fraction form of an ARX/OE model with real poles a_k = exp(-base_step_s/tau_k):
// each lag is x[n+1] = a_k x[n] + (1 - a_k) u[n]. The lags are discretised exactly for any sample
// spacing (zero-order hold of the previous sample), so inputs at 15 s, 60 s or with gaps all work.
#include <Eigen/Core>
#include <algorithm>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace alc {

inline constexpr double kInf = std::numeric_limits<double>::infinity();

// One probe cycle: the measured errors at `time_s`, NaN for an output not measured.
struct ProbeRecord {
  double time_s = 0.0;             // [s]
  std::size_t sample_index = 0;    // index of the input sample at or before time_s in the history
  Eigen::VectorXd errors;          // [µm] or [µm/m], one per output
  double weight = 1.0;             // [-] extra weight of this measurement (e.g. 0 to ignore)
};

// Samples x inputs, row-major so that appending a sample extends the storage at its end.
using InputMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// The input samples of a history: an InputMatrix that keeps room to grow, so that appending one
// sample per call costs amortised O(1) (its storage doubles when full) instead of a reallocation
// and a copy of the whole history each time. The rows in use are the top rows of the storage;
// every accessor sees those only.
class SampleRows {
 public:
  using Index = Eigen::Index;
  SampleRows() = default;
  SampleRows(Index rows, Index cols) : data_(rows, cols), rows_(rows) {}
  SampleRows(InputMatrix m) : data_(std::move(m)), rows_(data_.rows()) {}  // NOLINT: implicit on purpose
  SampleRows(const SampleRows& o) : data_(o.data_.topRows(o.rows_)), rows_(o.rows_) {}   // copies the rows in use only
  SampleRows(SampleRows&& o) noexcept : data_(std::move(o.data_)), rows_(std::exchange(o.rows_, 0)) {}
  SampleRows& operator=(const SampleRows& o) {
    if (this != &o) {
      data_ = o.data_.topRows(o.rows_);
      rows_ = o.rows_;
    }
    return *this;
  }
  SampleRows& operator=(SampleRows&& o) noexcept {
    data_ = std::move(o.data_);
    rows_ = std::exchange(o.rows_, 0);
    o.data_.resize(0, 0);
    return *this;
  }

  Index rows() const { return rows_; }
  Index cols() const { return data_.cols(); }
  auto matrix() { return data_.topRows(rows_); }
  auto matrix() const { return data_.topRows(rows_); }
  double& operator()(Index r, Index c) { return data_(r, c); }
  double operator()(Index r, Index c) const { return data_(r, c); }
  auto row(Index r) { return data_.row(r); }
  auto row(Index r) const { return data_.row(r); }
  auto col(Index c) { return matrix().col(c); }
  auto col(Index c) const { return matrix().col(c); }
  auto topRows(Index n) const { return matrix().topRows(n); }
  auto bottomRows(Index n) const { return matrix().bottomRows(n); }
  // Sets the shape; the values are unset (as Eigen's resize).
  void resize(Index rows, Index cols) {
    data_.resize(rows, cols);
    rows_ = rows;
  }
  // Appends one sample (its size is the number of columns; the first sets it).
  void append(const Eigen::Ref<const Eigen::VectorXd>& sample) {
    if (rows_ == 0 && data_.rows() == 0) data_.resize(0, sample.size());
    eigen_assert(sample.size() == data_.cols());
    if (rows_ == data_.rows()) data_.conservativeResize(std::max<Index>(64, 2 * rows_), Eigen::NoChange);
    data_.row(rows_++) = sample.transpose();
  }
  // Drops the oldest `n` rows; the storage keeps its size for the rows still to come.
  void drop_front(Index n) {
    eigen_assert(n >= 0 && n <= rows_);
    if (n == 0) return;
    std::copy(data_.data() + n * data_.cols(), data_.data() + rows_ * data_.cols(), data_.data());
    rows_ -= n;
  }

 private:
  InputMatrix data_;
  Index rows_ = 0;
};

// Input history given to identification: uniform or not, in time order.
struct InputHistory {
  std::vector<std::string> input_names;
  std::vector<double> time_s;      // [s]
  SampleRows inputs;               // samples x inputs (rows align with time_s)
};

enum class RobustLoss { None, Huber, Cauchy };
enum class StructureCriterion { BIC, AIC, HoldOut };
// FixedPoles: route (a), poles from a grid of time constants, gains by weighted least squares
//   (QR), structure by the criterion, then a robust (Huber/Cauchy) refinement of the gains.
// OutputError: route (b), starts from FixedPoles and refines gains and time constants together on
//   the simulated output at the probe times (Ceres, robust loss).
enum class IdentificationMethod { FixedPoles, OutputError };

struct IdentificationOptions {
  IdentificationMethod method = IdentificationMethod::FixedPoles;
  double base_step_s = 60.0;                 // [s] step at which `poles` are expressed
  int max_order = 3;                         // highest ARX order (number of poles per input) tried
  double tau_min_s = 120.0;                  // [s] shortest time constant of the pole grid (fast sensors:
                                             //     an almost static term; docs/identification.md)
  double tau_max_s = 72000.0;                // [s] longest time constant of the pole grid
  int pole_grid_size = 7;                    // [-] log-spaced time constants tau_min_s..tau_max_s
  StructureCriterion criterion = StructureCriterion::BIC;
  bool select_inputs = true;                 // drop inputs that do not help (p-values / Lasso)
  int max_inputs = 8;                        // upper bound of inputs kept after selection
  double ridge = 1e-5;                       // [-] relative Tikhonov regularisation of the final fit
  RobustLoss robust_loss = RobustLoss::Huber;
  double robust_scale_lin = 1.0;             // [µm] Huber/Cauchy scale for linear errors
  double robust_scale_ang = 3.0;             // [µm/m] for angular errors
  double window_start_s = -kInf;             // [s] use data since this time only
  double forgetting_half_life_s = kInf;      // [s] weight halves per this age; inf = no forgetting
  int min_measurements = 6;                  // fewer probes -> not usable
  double output_limit_factor = 4.0;          // [-] predictions are bounded by this times the largest
                                             //     measured |error| (at least 20 robust scales)
  int max_iterations = 50;                   // [-] iterations of the robust (Newton / IRLS) and the
                                             //     output-error (Ceres) fit
  bool fit_statistics = true;                // condition number and standard errors in the fit summary; no
                                             // decision reads them (a study turns them off; not part of a
                                             // run's identity)

  // Empty if valid, else which constraint is violated, naming the field and value.
  std::string validate() const;
};

// Structure and parameters of the model for one output.
struct OutputModel {
  std::string name;                          // "E_X0C"
  int order = 0;                             // chosen order
  std::vector<int> inputs;                   // indices into ThermalModel::input_names used
  // [b0, theta_{i1,1..K}, theta_{i2,1..K}, ...]: offset [µm] then the gain of each lag, input-major,
  // pole-minor, in [µm] (or [µm/m]) per input unit (°C, rpm, 0/1). Static gain of input i: sum_k.
  Eigen::VectorXd parameters;
  Eigen::VectorXd poles;                     // [-] discrete poles a_k = exp(-base_step_s / tau_k), size order
  double output_limit = kInf;                // [µm] or [µm/m] predictions are clamped to +-this
};

struct ThermalModel {
  std::vector<std::string> input_names;
  Eigen::VectorXd input_reference;           // reference values the inputs are taken against
  double base_step_s = 60.0;                 // [s]
  std::vector<OutputModel> outputs;
  bool empty() const { return outputs.empty(); }
};

struct OutputFitSummary {
  std::string name;
  bool usable = false;
  std::string message;                       // why not usable, or notes
  int order = 0;
  std::vector<std::string> inputs_chosen;
  int measurements = 0;                      // probes used
  double residual_rms = 0.0;                 // [µm] or [µm/m] after the fit, on used probes
  double residual_max = 0.0;
  double condition = 0.0;                    // condition number of the (weighted) regressor
  double cost_before = 0.0;                  // robust refinement cost before/after
  double cost_after = 0.0;
  std::vector<double> time_constants_s;      // [s] of the chosen poles
  Eigen::VectorXd parameter_std;             // standard errors of `parameters` (weighted LS, same units)
  std::vector<double> input_p_values;        // [-] per chosen input, the p-value of the partial F test of
                                             //     dropping its lags (seed 000's significance); NaN when
                                             //     undefined; empty when the structure was kept (refit())
};

struct FitResult {
  bool usable = false;                       // true when every output with min_measurements got a usable fit
                                             // and at least one did; an output with fewer gets no model
                                             // (predicts 0) and its summary says why
  std::string message;                       // summary; reason when not usable
  ThermalModel model;                        // valid only when usable
  std::vector<OutputFitSummary> outputs;
  // State of a ModelPredictor(model) that has been stepped over the whole history (set_state() it
  // to continue from the last sample without replaying); empty when not usable.
  Eigen::VectorXd predictor_state;
};

// The lags of every input at the time constants of the pole grid after every sample of an input
// history: what identify() and refit() compute first, O(samples x inputs x grid) each time. A caller
// that identifies again and again on a history that only grows (the controller) keeps one LagCache
// and passes it in; each call then extends it by the samples added since the last one. Derived data,
// not state: it is rebuilt when it does not match the history (another first sample, reference, grid
// or a history that is not an extension of the cached one), and an empty cache gives the same fits
// bit for bit. Fields are read and written by identify()/refit() only.
struct LagCache {
  std::vector<double> taus;                  // [s] time constants of the columns
  std::vector<int> inputs;                   // history columns computed (columns of others stay zero)
  Eigen::VectorXd reference;                 // the inputs' reference values (the lags of u - reference)
  Eigen::MatrixXd x;                         // capacity x (inputs * taus): column input * taus + k; rows
                                             // [0, samples) are valid
  Eigen::Index samples = 0;                  // history samples covered
  double first_time_s = 0.0;                 // [s] time of sample 0
  double last_time_s = 0.0;                  // [s] time of the last sample that advanced the lags
  double last_dt_s = -1.0;                   // [s] spacing that `factor` was computed for
  Eigen::VectorXd held;                      // input held after the last sample (reference at the start)
  Eigen::VectorXd factor;                    // exp(-last_dt_s / tau) per time constant
  Eigen::RowVectorXd last_row;               // inputs of the last sample covered (to recognise the history)
  Eigen::MatrixXd block_min;                 // per block of 64 samples (row s / 64) and column: the least
  Eigen::MatrixXd block_max;                 // and the largest x of the block's covered samples (the
                                             // bound check between the probes skips safe blocks)
};

// Time constant [s] of a discrete pole at `base_step_s` and back.
double time_constant_of_pole(double pole, double base_step_s);
double pole_of_time_constant(double tau_s, double base_step_s);

// `cache` (optional) keeps the grid lags between calls on a growing history (see LagCache).
FitResult identify(const InputHistory& history, const std::vector<std::string>& output_names,
                   const std::vector<ProbeRecord>& probes, const IdentificationOptions& options,
                   LagCache* cache = nullptr);

// identify() without the structure search for the outputs that `structure` has (same name, same
// input names and base step): their inputs and poles are kept and only the parameters are fitted
// again (weighted least squares and the robust refinement; no output-error step). Outputs that
// `structure` lacks get the full search. Same usability rules and summary as identify().
FitResult refit(const InputHistory& history, const std::vector<std::string>& output_names,
                const std::vector<ProbeRecord>& probes, const IdentificationOptions& options,
                const ThermalModel& structure, LagCache* cache = nullptr);

// Runs a model forward over samples. Feed every input sample in time order.
class ModelPredictor {
 public:
  ModelPredictor() = default;
  explicit ModelPredictor(ThermalModel model);
  // Returns the predicted errors after this sample (size = number of outputs). The first sample
  // starts every lag in steady state; later samples advance the lags over the elapsed time with the
  // previous sample held. A non-finite input keeps its previous value (the reference at the first
  // sample); a time not after the previous one only replaces the held input.
  Eigen::VectorXd step(double time_s, const Eigen::VectorXd& inputs);
  // The prediction for the current state (what the last step() returned; b0 before any step).
  Eigen::VectorXd prediction() const;
  const ThermalModel& model() const { return model_; }
  // Exact state for save/restore; set_state() throws std::invalid_argument on a size mismatch.
  Eigen::VectorXd state() const;
  void set_state(const Eigen::VectorXd& state);

 private:
  ThermalModel model_;
  // Layout: [started 0/1, last time [s], held inputs (n_inputs), lag states per output, per used
  // input, per pole]. Everything the predictor needs to continue; the rest is derived from model_.
  Eigen::VectorXd state_;
  std::vector<std::vector<double>> tau_s_;   // [s] per output, per pole (derived from model_)
  // Lag factors exp(-dt/tau) of the last step spacing: a cache (same values as recomputing them).
  double factor_dt_s_ = -1.0;
  std::vector<std::vector<double>> factor_;
};

}  // namespace alc
