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
#include <Eigen/Core>
#include <limits>
#include <optional>
#include <string>
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

// Input history given to identification: uniform or not, in time order.
struct InputHistory {
  std::vector<std::string> input_names;
  std::vector<double> time_s;      // [s]
  Eigen::MatrixXd inputs;          // samples x inputs (rows align with time_s)
};

enum class RobustLoss { None, Huber, Cauchy };
enum class StructureCriterion { BIC, AIC, HoldOut };

struct IdentificationOptions {
  double base_step_s = 60.0;                 // [s] uniform step the ARX model runs on
  int max_order = 3;                         // highest ARX order (number of poles per input) tried
  StructureCriterion criterion = StructureCriterion::BIC;
  bool select_inputs = true;                 // drop inputs that do not help (p-values / Lasso)
  int max_inputs = 8;                        // upper bound of inputs kept after selection
  double ridge = 1e-6;                       // [-] relative Tikhonov regularisation
  RobustLoss robust_loss = RobustLoss::Huber;
  double robust_scale_lin = 1.0;             // [µm] Huber/Cauchy scale for linear errors
  double robust_scale_ang = 3.0;             // [µm/m] for angular errors
  double window_start_s = -kInf;             // [s] use data since this time only
  double forgetting_half_life_s = kInf;      // [s] weight halves per this age; inf = no forgetting
  int min_measurements = 6;                  // fewer probes -> not usable

  // Empty if valid, else which constraint is violated, naming the field and value.
  std::string validate() const;
};

// Structure and parameters of the model for one output.
struct OutputModel {
  std::string name;                          // "E_X0C"
  int order = 0;                             // chosen order
  std::vector<int> inputs;                   // indices into ThermalModel::input_names used
  Eigen::VectorXd parameters;                // meaning fixed by the implementation (documented there)
  Eigen::VectorXd poles;                     // discrete poles / time constants used, if any
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
};

struct FitResult {
  bool usable = false;                       // true when every output got a usable fit
  std::string message;                       // summary; reason when not usable
  ThermalModel model;                        // valid only when usable
  std::vector<OutputFitSummary> outputs;
};

FitResult identify(const InputHistory& history, const std::vector<std::string>& output_names,
                   const std::vector<ProbeRecord>& probes, const IdentificationOptions& options);

// Runs a model forward over samples. Feed every input sample in time order.
class ModelPredictor {
 public:
  ModelPredictor() = default;
  explicit ModelPredictor(ThermalModel model);
  // Returns the predicted errors after this sample (size = number of outputs).
  Eigen::VectorXd step(double time_s, const Eigen::VectorXd& inputs);
  const ThermalModel& model() const { return model_; }
  // Exact state for save/restore.
  Eigen::VectorXd state() const;
  void set_state(const Eigen::VectorXd& state);

 private:
  ThermalModel model_;
  Eigen::VectorXd state_;
  double last_time_s_ = -kInf;
};

}  // namespace alc
