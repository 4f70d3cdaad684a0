#pragma once
// Safety before anything is written: a maximum offset per axis and a maximum change per update
// (the controllers do the same: Fanuc alarms on large steps, Sinumerik limits the compensation
// per cycle). Every decision is returned as a value that the caller logs or stores.
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "nc_interface/commands.hpp"

namespace alc::nc {

// One limit per axis, > 0.
struct AxisLimits {
  double x_mm = 0.1;   // [mm]
  double y_mm = 0.1;   // [mm]
  double z_mm = 0.1;   // [mm]
  double a_deg = 0.01; // [°]
  double b_deg = 0.01; // [°]
  double c_deg = 0.01; // [°]
};

enum class StepAction {
  Refuse,  // a change above max_step refuses the whole command
  Split,   // … is sent as equal steps, each within max_step (at most max_split_steps of them)
};

struct SafetyLimits {
  AxisLimits max_offset{0.1, 0.1, 0.1, 0.01, 0.01, 0.01};       // |offset| allowed
  AxisLimits max_step{0.01, 0.01, 0.01, 0.001, 0.001, 0.001};   // |change| per update
  // [s] of machine time in which an axis may move by max_step: the controller's offsets
  // (runtime::NcCommandObserver) draw each change from a budget per axis that holds at most
  // max_step and refills at max_step per step_period_s, so samples arriving faster do not move the
  // offsets faster (over any span T at most max_step × (1 + T / step_period_s)). check_offsets and
  // the gate judge one command against max_step (a command carries no time to the NC).
  double step_period_s = 60.0;
  StepAction on_step_violation = StepAction::Refuse;
  int max_split_steps = 20;                                      // [-] more steps than this: refuse
};

// Empty if usable, else which limit is invalid (name and value).
std::string validate(const SafetyLimits& limits);

enum class SafetyVerdict { Accepted, Split, Refused };
std::string_view verdict_name(SafetyVerdict verdict);  // "accepted", "split", "refused"

struct LimitViolation {
  char axis = 'X';          // X Y Z A B C
  std::string limit;        // "max_offset" or "max_step"
  double value = 0.0;       // [mm] or [°] the offset or the change asked for
  double limit_value = 0.0; // [mm] or [°]
};

struct SafetyDecision {
  SafetyVerdict verdict = SafetyVerdict::Accepted;
  AxisOffsets requested;               // what was asked for
  std::vector<AxisOffsets> to_send;    // empty when refused; one element when accepted
  std::vector<LimitViolation> violations;
  std::string message;                 // one line: verdict, and each violation with axis, value, limit
};

// Check `requested` against the limits, starting from `current` (the offsets in force now). Judged
// is what the NC holds after the line as written: every value as printed (as_printed: 0.00015 is
// written 0.0002 and judged so), and a rotary axis that `requested` leaves out (a_deg or b_deg
// empty) keeps its value from `current` (no word is written for it). Split steps are multiples of
// the NC resolution, each printed change within max_step; an axis whose max_step is below the
// resolution cannot move by splitting. A max_offset violation is always refused (no number of
// steps makes it safe); a value that is not finite or beyond ±1e6 is refused.
SafetyDecision check_offsets(const SafetyLimits& limits, const AxisOffsets& current, const AxisOffsets& requested);

// The offsets the NC holds after `written` (a command the gate let through) is written on top of
// `current`: each value as printed (as_printed), and an optional axis that `written` leaves out keeps
// its value from `current` (no word is written for it).
AxisOffsets held_after(const AxisOffsets& current, const AxisOffsets& written);

// Where the NC keeps the offsets that the commands write, which decides what max_step is judged
// against.
enum class OffsetRegisters {
  PerWorkOffset,  // one register per work offset (G10 L2 of LinuxCNC and Fanuc, Sinumerik's settable frames)
  Single,         // one register that every command writes, whatever its work_offset (Heidenhain's
                  // cycle 7 datum shift of the active preset): each command is judged against the last
                  // one let through, of any work offset
};

// The stateful gate: remembers the offsets in force per register (zero at the start unless
// set_in_force() says otherwise) and decides each command. Probe-interval commands pass (their
// validity is checked by the writers).
class SafetyGate {
 public:
  explicit SafetyGate(SafetyLimits limits = {}, OffsetRegisters registers = OffsetRegisters::PerWorkOffset);
  SafetyDecision submit(const AxisOffsets& requested);
  // The offsets in force now on `offsets.work_offset` (e.g. read back from the machine): the next
  // command for that register is judged against them. Not checked against the limits: it is what
  // the machine has, not a request. With OffsetRegisters::Single the one register can be given for
  // one work offset only: a second work offset throws std::invalid_argument (which of them would
  // the machine hold?).
  void set_in_force(const AxisOffsets& offsets);
  // The offsets a command for `work_offset` is judged against: zero offsets on that work offset
  // before the first accepted command or set_in_force; after a command, what the NC holds (values as
  // printed, a rotary axis the command left out as it was). With OffsetRegisters::Single the one
  // register, whatever `work_offset` (its work_offset is that of the command that set it).
  AxisOffsets current(int work_offset) const;
  const SafetyLimits& limits() const { return limits_; }
  OffsetRegisters registers() const { return registers_; }

 private:
  int register_of(int work_offset) const;

  SafetyLimits limits_;
  OffsetRegisters registers_;
  std::map<int, AxisOffsets> current_;  // by register_of(work_offset)
  std::optional<int> in_force_work_offset_;  // Single: the work offset set_in_force was given for
};

}  // namespace alc::nc
