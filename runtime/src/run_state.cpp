#include "runtime/run_state.hpp"

#include <stdexcept>

#include "common/byte_codec.hpp"
#include "storage/history_reader.hpp"
#include "storage/model_json.hpp"

namespace alc::runtime {

namespace {

using common::ByteReader;
using common::ByteWriter;

void encode_controller(ByteWriter& e, const ControllerState& c) {
  e.i32(static_cast<std::int32_t>(c.phase));
  e.f64(c.phase_start_s);
  e.f64(c.start_time_s);
  e.boolean(c.started);
  e.f64(c.now_s);
  e.f64(c.cp_end_s);
  e.f64(c.next_probe_due_s);
  e.f64(c.current_interval_s);
  e.f64(c.last_update_s);
  for (int v : {c.probe_cycles, c.ng_probes, c.ng_phases, c.updates, c.rejected_fits, c.probes_at_last_attempt})
    e.i32(v);
  e.f64(c.structure_span_s);
  e.i32(c.breach_probe);
  e.vector(c.breach_residual);
  e.strings(c.history.input_names);
  e.i64(c.history_first_index);
  e.i64(c.samples);
  e.u64(c.probes.size());
  for (const auto& p : c.probes) {
    e.f64(p.time_s);
    e.u64(p.sample_index);
    e.vector(p.errors);
    e.f64(p.weight);
  }
  e.boolean(c.has_model);
  e.string(c.has_model ? storage::thermal_model_to_json(c.predictor.model()) : std::string());
  e.vector(c.has_model ? c.predictor.state() : Eigen::VectorXd());
  e.vector(c.prediction);
  // Version 4: the evidence of the adaptive schedule and the guard.
  e.f64(c.last_probe_s);
  e.vector(c.drift_rate);
  e.vector(c.noise_var);
  // Version 5: the guard's gain evidence and the range of the measured errors.
  e.vector(c.guard_cross);
  e.vector(c.guard_power);
  e.vector(c.guard_error);
  e.i32(c.guard_probes);
  e.vector(c.guard_gain);
  e.vector(c.error_low);
  e.vector(c.error_high);
  e.vector(c.guard_off_range);
  // Version 6: the adaptive schedule's evidence of the prediction's change since the last decision.
  e.vector(c.kappa);
  e.f64(c.schedule_since_s);
  e.vector(c.schedule_prediction);
  e.matrix(c.schedule_sums);
  // Version 7: which outputs the guard's drift bound holds back.
  e.vector(c.guard_held);
  // Version 8: the guard's first check judging the model (a check due, the errors it holds, NaN: none).
  e.boolean(c.first_check_due);
  e.vector(c.guard_check_hold);
  // Version 9: the guard's level (its decaying sums and the level last told).
  e.vector(c.guard_level_sum);
  e.vector(c.guard_level_weight);
  e.vector(c.guard_level_told);
}

ControllerState decode_controller(ByteReader& d, std::uint32_t version) {
  ControllerState c;
  const std::int32_t phase = d.i32("phase");
  if (phase < 0 || phase > 2) throw std::runtime_error("run state: unknown phase " + std::to_string(phase));
  c.phase = static_cast<Phase>(phase);
  c.phase_start_s = d.f64("phase_start_s");
  c.start_time_s = d.f64("start_time_s");
  c.started = d.boolean("started");
  c.now_s = d.f64("now_s");
  c.cp_end_s = d.f64("cp_end_s");
  c.next_probe_due_s = d.f64("next_probe_due_s");
  c.current_interval_s = d.f64("current_interval_s");
  c.last_update_s = d.f64("last_update_s");
  for (int* v : {&c.probe_cycles, &c.ng_probes, &c.ng_phases, &c.updates, &c.rejected_fits, &c.probes_at_last_attempt})
    *v = d.i32("counter");
  c.structure_span_s = d.f64("structure_span_s");
  c.breach_probe = d.i32("breach_probe");
  c.breach_residual = d.vector("breach_residual");
  c.history.input_names = d.strings("input_names");
  c.history.inputs.resize(0, static_cast<Eigen::Index>(c.history.input_names.size()));
  c.history_first_index = d.i64("history_first_index");
  c.samples = d.i64("samples");
  if (c.history_first_index < 0 || c.samples < c.history_first_index)
    throw std::runtime_error("run state: history rows " + std::to_string(c.history_first_index) + ".." +
                             std::to_string(c.samples) + " are not a range");
  const std::uint64_t probes = d.u64("probe count");
  if (probes > d.remaining()) throw std::runtime_error("run state: corrupt probe count");
  c.probes.resize(static_cast<std::size_t>(probes));
  for (auto& p : c.probes) {
    p.time_s = d.f64("probe time_s");
    p.sample_index = static_cast<std::size_t>(d.u64("probe sample_index"));
    p.errors = d.vector("probe errors");
    p.weight = d.f64("probe weight");
  }
  c.has_model = d.boolean("has_model");
  const std::string model = d.string("model");
  const Eigen::VectorXd predictor_state = d.vector("predictor state");
  if (c.has_model) {
    c.predictor = ModelPredictor(storage::thermal_model_from_json(model));
    c.predictor.set_state(predictor_state);
  }
  c.prediction = d.vector("prediction");
  if (version >= 4) {
    c.last_probe_s = d.f64("last_probe_s");
    c.drift_rate = d.vector("drift_rate");
    c.noise_var = d.vector("noise_var");
  }  // version 3: the controller starts the evidence afresh (init_evidence)
  if (version == 4) {
    // Version 4's guard (residual and error energies, an on/off gain) is not this guard's evidence:
    // read past it; the guard starts afresh, its range from the probes kept in the state.
    d.vector("guard_residual");
    d.vector("guard_error");
    d.i32("guard_probes");
    d.vector("guard_gain");
    c.error_low = c.error_high = Eigen::VectorXd();
  } else if (version >= 5) {
    c.guard_cross = d.vector("guard_cross");
    c.guard_power = d.vector("guard_power");
    c.guard_error = d.vector("guard_error");
    c.guard_probes = d.i32("guard_probes");
    c.guard_gain = d.vector("guard_gain");
    c.error_low = d.vector("error_low");
    c.error_high = d.vector("error_high");
    c.guard_off_range = d.vector("guard_off_range");
  }
  if (version >= 6) {
    c.kappa = d.vector("kappa");
    c.schedule_since_s = d.f64("schedule_since_s");
    c.schedule_prediction = d.vector("schedule_prediction");
    c.schedule_sums = d.matrix("schedule_sums");
  }  // before: the controller starts them (init_evidence): kappa 0, the change from the last probe on
  if (version >= 7) c.guard_held = d.vector("guard_held");  // before: none held (init_evidence)
  if (version >= 8) {  // before: no check due, none held (init_evidence)
    c.first_check_due = d.boolean("first_check_due");
    c.guard_check_hold = d.vector("guard_check_hold");
  }
  if (version >= 9) {  // before: no level (init_evidence), learnt from the next Post-CP probe on
    c.guard_level_sum = d.vector("guard_level_sum");
    c.guard_level_weight = d.vector("guard_level_weight");
    c.guard_level_told = d.vector("guard_level_told");
  }
  return c;
}

}  // namespace

std::string encode_run_state(const RunState& s) {
  ByteWriter e;
  e.write_header(kRunStateFormat, kRunStateVersion);
  e.i64(s.next_index);
  encode_controller(e, s.controller);
  e.boolean(s.baseline_fitted);
  e.strings(s.baseline.input_names);
  e.strings(s.baseline.output_names);
  e.vector(s.baseline.intercept);
  e.matrix(s.baseline.coefficients);
  e.f64(s.identification_s);
  e.f64(s.total_s);
  const std::uint64_t sum = common::checksum64(e.bytes());
  e.u64(sum);
  return e.take();
}

RunState decode_run_state(const std::string& payload) {
  if (payload.size() < 8) throw std::runtime_error("run state: payload is truncated");
  const std::string_view body(payload.data(), payload.size() - 8);
  ByteReader tail(std::string_view(payload).substr(payload.size() - 8), "run state checksum");
  if (tail.u64("checksum") != common::checksum64(body))
    throw std::runtime_error("run state: checksum mismatch (the snapshot is damaged)");
  ByteReader d(body, "run state");
  const std::uint32_t version = d.read_header(kRunStateFormat);
  if (version != kRunStateVersion && (version < 3 || version > kRunStateVersion))
    throw std::runtime_error("run state: version " + std::to_string(version) + ", this program reads 3 to " +
                             std::to_string(kRunStateVersion));
  RunState s;
  s.next_index = d.i64("next_index");
  s.controller = decode_controller(d, version);
  s.baseline_fitted = d.boolean("baseline_fitted");
  s.baseline.input_names = d.strings("baseline inputs");
  s.baseline.output_names = d.strings("baseline outputs");
  s.baseline.intercept = d.vector("baseline intercept");
  s.baseline.coefficients = d.matrix("baseline coefficients");
  s.identification_s = d.f64("identification_s");
  s.total_s = d.f64("total_s");
  d.expect_done();
  return s;
}

std::string run_state_problem(const storage::ControllerSnapshot& snapshot) {
  if (snapshot.format != kRunStateFormat)
    return "format '" + snapshot.format + "', this program resumes " + kRunStateFormat;
  try {
    decode_run_state(snapshot.payload);
  } catch (const std::exception& e) {
    return e.what();
  }
  return {};
}

std::int64_t history_rows(const ControllerState& state) { return state.samples - state.history_first_index; }

void restore_history(ControllerState& state, std::vector<double> time_s, InputMatrix inputs) {
  const auto need = history_rows(state);
  if (static_cast<std::int64_t>(time_s.size()) != need || inputs.rows() != need ||
      inputs.cols() != static_cast<Eigen::Index>(state.history.input_names.size()))
    throw std::runtime_error("run state: " + std::to_string(time_s.size()) + " stored samples of " +
                             std::to_string(inputs.cols()) + " inputs to restore, the state needs " +
                             std::to_string(need) + " of " + std::to_string(state.history.input_names.size()));
  state.history.time_s = std::move(time_s);
  state.history.inputs = std::move(inputs);
}

RunState load_run_state(const std::filesystem::path& db, storage::RunId run, const storage::ControllerSnapshot& snapshot,
                        std::size_t inputs) {
  RunState s = decode_run_state(snapshot.payload);
  // The snapshot's sample index (the payload's next_index is the source's: an inbox entry for the
  // supervisor).
  const std::int64_t next = snapshot.next_sample_index;
  const storage::HistoryReader reader(db);
  const auto samples = reader.input_samples(run);
  // The learning history is the last `count - first` samples the run accepted before its snapshot,
  // each stored (oldest first by index). Where every sample was accepted (the supervisor, a replay
  // without a sample set aside) a sample's index is its place among the accepted ones, and each must be
  // where it is; those before `first` may have been deleted (the supervisor's keep_days prunes them at
  // snapshots, never one the learning holds). A replay that set samples aside keeps its recording's
  // row numbers, with gaps; it deletes nothing, so every accepted sample is there.
  const std::int64_t first = s.controller.history_first_index;
  const std::int64_t count = s.controller.samples;
  const std::int64_t need = count - first;
  const bool by_place = next == count;
  const auto cols = static_cast<Eigen::Index>(inputs);
  std::vector<const storage::InputSampleRecord*> before;
  for (const auto& rec : samples)
    if (rec.sample_index < next) before.push_back(&rec);
  const auto stored = static_cast<std::int64_t>(before.size());
  const std::string range = "(samples " + std::to_string(first) + " to " + std::to_string(count - 1) + " of the " +
                            std::to_string(count) + " accepted before its snapshot)";
  if (stored < need || stored > count || (!by_place && stored != count))
    throw std::runtime_error(db.string() + ": run " + std::to_string(run) + " stores " + std::to_string(stored) +
                             " samples before its snapshot (row " + std::to_string(next) +
                             "), where its learning history " + range + " needs " +
                             (by_place ? "the last " + std::to_string(need) : "all " + std::to_string(count)));
  std::vector<double> time_s;
  InputMatrix matrix(std::max<Eigen::Index>(0, static_cast<Eigen::Index>(need)), cols);
  for (std::int64_t k = 0; k < need; ++k) {
    const storage::InputSampleRecord& rec = *before[static_cast<std::size_t>(stored - need + k)];
    if (by_place && rec.sample_index != first + k)
      throw std::runtime_error(db.string() + ": run " + std::to_string(run) + " stores sample " +
                               std::to_string(rec.sample_index) + " where its learning history " + range +
                               " needs sample " + std::to_string(first + k));
    if (static_cast<Eigen::Index>(rec.values.size()) != cols)
      throw std::runtime_error(db.string() + ": stored sample " + std::to_string(rec.sample_index) + " has " +
                               std::to_string(rec.values.size()) + " inputs");
    time_s.push_back(rec.time_s);
    for (Eigen::Index c = 0; c < cols; ++c) matrix(static_cast<Eigen::Index>(k), c) = rec.values[static_cast<std::size_t>(c)];
  }
  restore_history(s.controller, std::move(time_s), std::move(matrix));
  return s;
}

}  // namespace alc::runtime
