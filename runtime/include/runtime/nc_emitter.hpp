#pragma once
// What the NC receives: the controller's predictions turned into axis offsets (the cycle's
// compensation at the driver's machine, Cycle::compensation(), + nc::to_axis_offsets) and its
// probe-interval changes, each passed through the safety gate (nc::CommandRecorder). A driver
// observer: replay, study and supervisor alike.
//
// Emission rule (docs/nc.md, "The replay's NC output"):
// - Offsets are computed at the driver's reference pose (Driver::set_machine: tilt (A or B) = 0°,
//   table (C) = 0°, for the workpiece reference point `[kinematics] workpiece_point_mm` of the machine
//   config); the driver must have a machine with the same chain as these options.
// - They are considered at three kinds of moments: after every probe cycle, after every cycle with a
//   model update (ModelUpdate event), and when `period_s` of scenario time has passed since the last
//   of these. One controller cycle gives at most one moment.
// - At such a moment the request is the target, approached from the offsets in force by at most the
//   budget of each axis: it holds at most `limits.max_step`, every step draws from it, and it refills
//   at max_step per `limits.step_period_s` of scenario time (a rate limit: over any span T an axis
//   moves by at most max_step × (1 + T / step_period_s), whatever the sampling); while the request
//   falls short of the target, every following controller cycle is a moment too (one step per cycle
//   until the target is reached). Steps are judged and taken in printed values (what the NC
//   receives): from the offsets in force as printed, whole NC ticks (0.0001), at most the budget and
//   at most max_step as the gate counts a change, so the gate never refuses a step chosen here. An
//   axis_offsets command is emitted when some axis of the request differs from the last emitted
//   command (zero at the start) by at least `resolution` (0.0001 mm / 0.0001°, the NC resolution), or,
//   while stepping, when it prints differently. A refused request (beyond max_offset) stops the
//   stepping until the next regular moment.
// - Every ProbeIntervalChange event gives a probe_interval command (an infinite interval: "never").
// - What the offsets cannot cancel is kept, not dropped: every axis_offsets command carries the
//   non_compensable_um_per_m of the compensation of the prediction it moves toward (also in
//   DIR/commands.jsonl), and max_non_compensable_um_per_m() is its maximum over all moments.
// The output names E_X0C, E_Y0C, E_Z0T, E_R0T, E_A0C, E_B0C, E_C0C map to the seven location errors;
// other outputs are ignored, and without any of the seven no axis offsets are emitted.
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "alc/kinematics.hpp"
#include "nc_interface/dialects.hpp"
#include "nc_interface/machine_config.hpp"
#include "nc_interface/recorder.hpp"
#include "runtime/driver.hpp"
#include "storage/history_writer.hpp"

namespace alc::runtime {

struct NcObserverOptions {
  kinematics::MachineChain chain = kinematics::MachineChain::ac_trunnion();
  nc::Dialect dialect = nc::Dialect::LinuxCNC;  // the gate's offset registers (nc::recorder_for)
  int work_offset = 1;               // 1 = G54 … 6 = G59
  nc::SafetyLimits limits;
  double period_s = 900.0;           // [s] scenario time between periodic moments (15 min)
  double resolution = 1e-4;          // [mm] / [°] smallest change worth a command
};

// The options of a machine config (chain, work offset, limits); period and resolution default.
NcObserverOptions nc_observer_options(const nc::MachineConfig& config);

// Where the observer also records each command in the history (NcCommandRecord rows).
struct NcHistoryTarget {
  storage::HistoryWriter* writer = nullptr;
  storage::RunId run = 0;
  std::string sink;                  // e.g. "file:DIR"
  nc::Dialect dialect = nc::Dialect::LinuxCNC;
  nc::DialectOptions options;        // for the NC text of the record
};

class NcCommandObserver : public Observer {
 public:
  // Throws std::invalid_argument for an unusable chain, limits, period or resolution.
  NcCommandObserver(const std::vector<std::string>& output_names, NcObserverOptions options);

  // Also record every command (accepted = the safety gate passed it) in a history database.
  void set_history(NcHistoryTarget target) { history_ = std::move(target); }

  void on_cycle(const Cycle& cycle) override;

  // The commands as emitted (before the gate), in order: the input of nc::write_replay_nc_output.
  const std::vector<nc::NcCommand>& commands() const { return commands_; }
  // The gate's decisions, one per command, and the commands it lets through (split steps expanded).
  const nc::CommandRecorder& recorder() const { return recorder_; }
  std::size_t refused() const { return refused_; }
  std::size_t not_converged() const { return not_converged_; }  // moments skipped: compensate() failed
  // [µm/m] largest Compensation::non_compensable_um_per_m over every moment with a converged
  // compensation (also those that emitted no command); 0 before the first.
  double max_non_compensable_um_per_m() const { return max_non_compensable_um_per_m_; }
  bool maps_any_error() const { return maps_any_; }

  // What the emission rule remembers between cycles, for a run that continues after a restart (the
  // supervisor): the last emitted request, the offsets in force, stepping, the next periodic moment.
  struct State {
    nc::AxisOffsets last;
    nc::AxisOffsets in_force;
    bool behind = false;
    double next_periodic_s = -kInf;
    nc::AxisLimits budget;        // [mm] / [°] what each axis may still move now (see the rule above)
    double budget_s = -kInf;      // [s] when the budget was last refilled
  };
  State state() const { return {last_, in_force_, behind_, next_periodic_s_, budget_, budget_s_}; }
  // Continues from `state` (the gate takes state.in_force as the offsets in force; state() gives them
  // back as printed, whatever the values given).
  void restore(const State& state);
  // Drops the commands and decisions kept so far (commands(), recorder()): a long-running user keeps
  // memory bounded; counts and the state stay.
  void forget_commands();

 private:
  void handle(const Cycle& cycle);
  void refill(double time_s);  // the budget grows by max_step per step_period_s since budget_s_
  nc::SafetyDecision emit(const nc::NcCommand& command, double time_s);

  NcObserverOptions options_;
  bool maps_any_ = false;
  nc::CommandRecorder recorder_;
  std::vector<nc::NcCommand> commands_;
  nc::AxisOffsets last_;               // last emitted offsets (zero at the start)
  nc::AxisOffsets in_force_;           // what the gate let through last, as printed (zero at the start)
  bool behind_ = false;                // in_force_ has not reached the latest target yet
  double next_periodic_s_ = -kInf;     // [s]
  nc::AxisLimits budget_;              // the rate limit's budget per axis (max_step at the start)
  double budget_s_ = -kInf;            // [s] its last refill
  std::size_t refused_ = 0;
  std::size_t not_converged_ = 0;
  double max_non_compensable_um_per_m_ = 0.0;  // [µm/m]
  std::optional<NcHistoryTarget> history_;
};

}  // namespace alc::runtime
