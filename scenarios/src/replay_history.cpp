#include "scenarios/replay_history.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>

#include "storage/model_json.hpp"

namespace alc::scenarios {

namespace {

// Little-endian host assumed (x86-64, aarch64); the format tag carries the version.
class Encoder {
 public:
  template <typename T>
  void pod(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    out_.append(reinterpret_cast<const char*>(&v), sizeof v);
  }
  void size(std::size_t n) { pod(static_cast<std::uint64_t>(n)); }
  void text(const std::string& s) {
    size(s.size());
    out_.append(s);
  }
  void vec(const Eigen::VectorXd& v) {
    size(static_cast<std::size_t>(v.size()));
    out_.append(reinterpret_cast<const char*>(v.data()), sizeof(double) * static_cast<std::size_t>(v.size()));
  }
  void mat(const Eigen::MatrixXd& m) {
    size(static_cast<std::size_t>(m.rows()));
    size(static_cast<std::size_t>(m.cols()));
    out_.append(reinterpret_cast<const char*>(m.data()), sizeof(double) * static_cast<std::size_t>(m.size()));
  }
  void doubles(const std::vector<double>& v) {
    size(v.size());
    out_.append(reinterpret_cast<const char*>(v.data()), sizeof(double) * v.size());
  }
  void names(const std::vector<std::string>& v) {
    size(v.size());
    for (const auto& s : v) text(s);
  }
  std::string take() { return std::move(out_); }

 private:
  std::string out_;
};

class Decoder {
 public:
  explicit Decoder(const std::string& in) : in_(in) {}
  template <typename T>
  T pod() {
    T v;
    need(sizeof v);
    std::memcpy(&v, in_.data() + at_, sizeof v);
    at_ += sizeof v;
    return v;
  }
  std::size_t size() {
    const auto n = pod<std::uint64_t>();
    if (n > in_.size()) throw std::runtime_error("replay state: corrupt length field");
    return static_cast<std::size_t>(n);
  }
  std::string text() {
    const std::size_t n = size();
    need(n);
    std::string s = in_.substr(at_, n);
    at_ += n;
    return s;
  }
  Eigen::VectorXd vec() {
    const std::size_t n = size();
    need(n * sizeof(double));
    Eigen::VectorXd v(static_cast<Eigen::Index>(n));
    copy_out(v.data(), n * sizeof(double));
    return v;
  }
  Eigen::MatrixXd mat() {
    const std::size_t r = size(), c = size();
    if (c != 0 && r > in_.size() / c) throw std::runtime_error("replay state: corrupt matrix size");
    need(r * c * sizeof(double));
    Eigen::MatrixXd m(static_cast<Eigen::Index>(r), static_cast<Eigen::Index>(c));
    copy_out(m.data(), r * c * sizeof(double));
    return m;
  }
  std::vector<double> doubles() {
    const std::size_t n = size();
    need(n * sizeof(double));
    std::vector<double> v(n);
    copy_out(v.data(), n * sizeof(double));
    return v;
  }
  std::vector<std::string> names() {
    std::vector<std::string> v(size());
    for (auto& s : v) s = text();
    return v;
  }
  bool done() const { return at_ == in_.size(); }

 private:
  void need(std::size_t n) const {
    if (in_.size() - at_ < n) throw std::runtime_error("replay state: payload is truncated");
  }
  // Copies the next `bytes` bytes to dst; an empty field copies nothing (dst may be null then).
  void copy_out(void* dst, std::size_t bytes) {
    need(bytes);
    if (bytes != 0) std::memcpy(dst, in_.data() + at_, bytes);
    at_ += bytes;
  }
  const std::string& in_;
  std::size_t at_ = 0;
};

void encode_controller(Encoder& e, const ControllerState& c) {
  e.pod(static_cast<int>(c.phase));
  e.pod(c.start_time_s);
  e.pod(c.started);
  e.pod(c.now_s);
  e.pod(c.cp_end_s);
  e.pod(c.next_probe_due_s);
  e.pod(c.current_interval_s);
  e.pod(c.last_update_s);
  for (int v : {c.probe_cycles, c.ng_probes, c.ng_phases, c.updates, c.rejected_fits, c.probes_at_last_attempt})
    e.pod(v);
  e.pod(c.structure_span_s);
  e.pod(c.breach_probe);
  e.vec(c.breach_residual);
  e.names(c.history.input_names);
  e.doubles(c.history.time_s);
  e.mat(c.history.inputs);
  e.size(c.probes.size());
  for (const auto& p : c.probes) {
    e.pod(p.time_s);
    e.size(p.sample_index);
    e.vec(p.errors);
    e.pod(p.weight);
  }
  e.pod(c.has_model);
  e.text(c.has_model ? storage::thermal_model_to_json(c.predictor.model()) : std::string());
  e.vec(c.has_model ? c.predictor.state() : Eigen::VectorXd());
  e.vec(c.prediction);
}

ControllerState decode_controller(Decoder& d) {
  ControllerState c;
  const int phase = d.pod<int>();
  if (phase < 0 || phase > 2) throw std::runtime_error("replay state: unknown phase " + std::to_string(phase));
  c.phase = static_cast<Phase>(phase);
  c.start_time_s = d.pod<double>();
  c.started = d.pod<bool>();
  c.now_s = d.pod<double>();
  c.cp_end_s = d.pod<double>();
  c.next_probe_due_s = d.pod<double>();
  c.current_interval_s = d.pod<double>();
  c.last_update_s = d.pod<double>();
  for (int* v : {&c.probe_cycles, &c.ng_probes, &c.ng_phases, &c.updates, &c.rejected_fits, &c.probes_at_last_attempt})
    *v = d.pod<int>();
  c.structure_span_s = d.pod<double>();
  c.breach_probe = d.pod<int>();
  c.breach_residual = d.vec();
  c.history.input_names = d.names();
  c.history.time_s = d.doubles();
  c.history.inputs = d.mat();
  c.probes.resize(d.size());
  for (auto& p : c.probes) {
    p.time_s = d.pod<double>();
    p.sample_index = d.size();
    p.errors = d.vec();
    p.weight = d.pod<double>();
  }
  c.has_model = d.pod<bool>();
  const std::string model = d.text();
  const Eigen::VectorXd predictor_state = d.vec();
  if (c.has_model) {
    c.predictor = ModelPredictor(storage::thermal_model_from_json(model));
    c.predictor.set_state(predictor_state);
  }
  c.prediction = d.vec();
  return c;
}

std::vector<double> to_std(const Eigen::VectorXd& v) { return {v.data(), v.data() + v.size()}; }

// Whether some output is one of the seven C-axis location errors (then offsets can be derived).
bool maps_any_error(const std::vector<std::string>& output_names) {
  for (const auto& name : output_names)
    if (kinematics::location_error_field(name) >= 0) return true;
  return false;
}

// The phase a probe was taken in. The observer sees the probe after the controller handled it, when
// a phase change the probe caused (a breach: Post-CP -> NG; the last NG probe: NG -> Post-CP; the
// probe that ends CP) has already happened. Every phase change is a PhaseChange event of the cycle
// that made it (Controller::change_phase), so the first one's `from` is the phase at probe time.
Phase phase_at_probe(const ControllerOutput& out, Phase now) {
  for (const auto& e : out.events)
    if (e.type == ControllerEvent::Type::PhaseChange) return e.from;
  return now;
}

}  // namespace

std::string encode_replay_state(const ReplayState& s) {
  Encoder e;
  e.text(kReplayStateFormat);
  e.size(s.next_row);
  encode_controller(e, s.controller);
  e.pod(s.baseline_fitted);
  e.names(s.baseline.input_names);
  e.names(s.baseline.output_names);
  e.vec(s.baseline.intercept);
  e.mat(s.baseline.coefficients);
  e.doubles(s.eval_time_s);
  for (const auto* series : {&s.eval_measured, &s.eval_predicted, &s.eval_baseline}) {
    e.size(series->size());
    for (const auto& v : *series) e.vec(v);
  }
  e.pod(s.identification_s);
  e.pod(s.total_s);
  return e.take();
}

ReplayState decode_replay_state(const std::string& payload) {
  Decoder d(payload);
  if (d.text() != kReplayStateFormat) throw std::runtime_error(std::string("replay state: not an ") + kReplayStateFormat + " payload");
  ReplayState s;
  s.next_row = d.size();
  s.controller = decode_controller(d);
  s.baseline_fitted = d.pod<bool>();
  s.baseline.input_names = d.names();
  s.baseline.output_names = d.names();
  s.baseline.intercept = d.vec();
  s.baseline.coefficients = d.mat();
  s.eval_time_s = d.doubles();
  for (auto* series : {&s.eval_measured, &s.eval_predicted, &s.eval_baseline}) {
    series->resize(d.size());
    for (auto& v : *series) v = d.vec();
  }
  s.identification_s = d.pod<double>();
  s.total_s = d.pod<double>();
  if (!d.done()) throw std::runtime_error("replay state: trailing bytes after the payload");
  return s;
}

HistoryRecorder::HistoryRecorder(storage::HistoryWriter& writer, storage::RunId run, const Controller& controller,
                                 double snapshot_every_s)
    : writer_(writer), run_(run), controller_(controller), snapshot_every_s_(snapshot_every_s) {}

void HistoryRecorder::record_events(const ControllerOutput& out, double time_s) {
  for (const auto& e : out.events) {
    switch (e.type) {
      case ControllerEvent::Type::PhaseChange:
        writer_.add(storage::PhaseChangeRecord{run_, e.time_s, std::string(to_string(e.from)),
                                               std::string(to_string(e.to)), e.reason});
        break;
      case ControllerEvent::Type::ProbeIntervalChange:
        writer_.add(storage::ProbeIntervalChangeRecord{run_, e.time_s, e.interval_s, e.reason});
        break;
      default: break;  // breaches and model updates are recorded through their phase change / fit
    }
  }
  if (out.fit) {
    // The first probe time the fit could learn from (--window and --since), not before the run.
    const double window_start = std::max(controller_.learning_window_start(time_s), controller_.state().start_time_s);
    std::string reason;
    for (const auto& e : out.events)
      if (e.type == ControllerEvent::Type::ModelUpdate || e.type == ControllerEvent::Type::ModelRejected)
        reason = e.reason;
    writer_.add(storage::make_model_parameter_set(run_, time_s, reason, window_start, time_s, *out.fit,
                                                  out.fit->usable));
  }
}

void HistoryRecorder::on_sample(std::size_t row, double time_s, const Eigen::VectorXd& inputs,
                                const ControllerOutput& out) {
  writer_.add(storage::InputSampleRecord{run_, static_cast<std::int64_t>(row), time_s, to_std(inputs)});
  std::vector<double> offsets;
  if (chain_) {
    const auto errors = kinematics::location_errors_of(output_names_, out.prediction);
    const kinematics::Compensation c = kinematics::compensate(*chain_, {}, errors);
    const double nan = std::numeric_limits<double>::quiet_NaN();
    offsets = c.converged ? std::vector<double>{c.offsets.x_um, c.offsets.y_um, c.offsets.z_um, c.offsets.tilt_urad,
                                                c.offsets.table_urad}
                          : std::vector<double>(5, nan);  // no converged compensation: stated, not guessed
  }
  writer_.add(storage::PredictionRecord{run_, time_s, to_std(out.prediction), std::move(offsets)});
  record_events(out, time_s);
}

void HistoryRecorder::record_offsets(const kinematics::MachineChain& chain, std::vector<std::string> output_names) {
  if (!maps_any_error(output_names)) return;
  chain_ = chain;
  output_names_ = std::move(output_names);
}

std::vector<std::string> HistoryRecorder::offset_names(const kinematics::MachineChain& chain) {
  return {"X_um", "Y_um", "Z_um", std::string(1, chain.tilt.name) + "_urad", std::string(1, chain.table.name) + "_urad"};
}

std::vector<std::string> HistoryRecorder::offset_names(const kinematics::MachineChain& chain,
                                                       const std::vector<std::string>& output_names) {
  return maps_any_error(output_names) ? offset_names(chain) : std::vector<std::string>{};
}

void HistoryRecorder::on_probe(std::size_t, const ProbeMeasurement& probe, const ControllerOutput& out) {
  storage::ProbeMeasurementRecord r;
  r.run_id = run_;
  r.time_s = probe.time_s;
  r.phase = std::string(to_string(phase_at_probe(out, controller_.phase())));
  r.measured = to_std(probe.measured);
  r.compensation = probe.compensation.size() ? to_std(probe.compensation)
                                             : std::vector<double>(static_cast<std::size_t>(probe.measured.size()), 0.0);
  writer_.add(r);
  record_events(out, probe.time_s);
}

void HistoryRecorder::save_snapshot(const ReplaySession& session) {
  const ReplayState state = session.state();
  storage::ControllerSnapshot snap;
  snap.run_id = run_;
  snap.next_sample_index = static_cast<std::int64_t>(state.next_row);
  snap.time_s = state.controller.started ? state.controller.now_s : storage::kSnapshotBeforeStart_s;
  snap.format = kReplayStateFormat;
  snap.is_json = false;
  snap.payload = encode_replay_state(state);
  writer_.save_snapshot(snap);
  // Before the first sample the start time is not known yet: on_row_done() counts from it then.
  next_snapshot_s_ = state.controller.started ? state.controller.now_s + snapshot_every_s_ : -kInf;
}

void HistoryRecorder::on_row_done(const ReplaySession& session) {
  const ControllerState& c = session.controller().state();
  // The first snapshot of this recorder falls due `snapshot_every_s_` after the run's first sample;
  // a recorder of a resumed run past that point saves one after its first row.
  if (next_snapshot_s_ == -kInf) next_snapshot_s_ = c.start_time_s + snapshot_every_s_;
  if (c.now_s >= next_snapshot_s_) save_snapshot(session);
}

}  // namespace alc::scenarios
