#include "runtime/history_recorder.hpp"

#include "storage/model_json.hpp"

#include <algorithm>
#include <limits>

namespace alc::runtime {

namespace {
std::vector<double> to_std(const Eigen::VectorXd& v) { return {v.data(), v.data() + v.size()}; }
}  // namespace

HistoryRecorder::HistoryRecorder(storage::HistoryWriter& writer, storage::RunId run, bool record_offsets)
    : writer_(writer), run_(run), record_offsets_(record_offsets) {}

std::vector<std::string> HistoryRecorder::offset_names(const kinematics::MachineChain& chain) {
  return {"X_um", "Y_um", "Z_um", std::string(1, chain.tilt.name) + "_urad", std::string(1, chain.table.name) + "_urad"};
}

std::vector<std::string> HistoryRecorder::offset_names(const kinematics::MachineChain& chain,
                                                       const std::vector<std::string>& output_names) {
  return kinematics::maps_any_location_error(output_names) ? offset_names(chain) : std::vector<std::string>{};
}

void HistoryRecorder::record_events(const Cycle& cycle) {
  const ControllerOutput& out = cycle.out();
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
    const Controller& c = cycle.controller();
    const double time_s = cycle.time_s();
    // The first probe time the fit could learn from (--window and --since), not before the run.
    const double window_start = std::max(c.learning_window_start(time_s), c.state().start_time_s);
    std::string reason;
    for (const auto& e : out.events)
      if (e.type == ControllerEvent::Type::ModelUpdate || e.type == ControllerEvent::Type::ModelRejected)
        reason = e.reason;
    writer_.add(storage::make_model_parameter_set(run_, time_s, reason, window_start, time_s, *out.fit,
                                                  out.fit->usable));
  }
}

void HistoryRecorder::on_cycle(const Cycle& cycle) {
  if (cycle.kind() == Cycle::Kind::Sample) {
    const Sample& s = cycle.sample();
    writer_.add(storage::InputSampleRecord{run_, s.index, s.time_s, to_std(s.inputs)});
    std::vector<double> offsets;
    if (record_offsets_) {
      const double nan = std::numeric_limits<double>::quiet_NaN();
      const kinematics::Compensation* c = cycle.compensation();
      offsets = c && c->converged ? std::vector<double>{c->offsets.x_um, c->offsets.y_um, c->offsets.z_um,
                                                        c->offsets.tilt_urad, c->offsets.table_urad}
                                  : std::vector<double>(5, nan);  // no converged compensation: stated, not guessed
    }
    writer_.add(storage::PredictionRecord{run_, s.time_s, to_std(cycle.out().prediction), std::move(offsets)});
  } else if (cycle.kind() == Cycle::Kind::Probe) {
    // The probe with the phase it was taken in, not the one its handling led to: a breaching Post-CP
    // probe is a Post-CP probe (its PhaseChange event to NG follows in phase_changes).
    const ProbeMeasurement& probe = *cycle.probe();
    storage::ProbeMeasurementRecord r;
    r.run_id = run_;
    r.time_s = probe.time_s;
    r.phase = std::string(to_string(cycle.phase_before()));
    r.measured = to_std(probe.measured);
    r.compensation = probe.compensation.size()
                         ? to_std(probe.compensation)
                         : std::vector<double>(static_cast<std::size_t>(probe.measured.size()), 0.0);
    writer_.add(r);
  }
  record_events(cycle);
}

}  // namespace alc::runtime
