#pragma once
// The entry point for the replay (and anything else that wants to keep what the NC would receive):
// commands pass the safety gate, and the result is written as commands.jsonl plus the NC program.
//
// Intended CLI behaviour (wired by the replay): `alc replay … --nc-out DIR --dialect D
// [--machine FILE]` collects the replay's commands in order and calls write_replay_nc_output(DIR,
// D, commands, config.nc, config.limits) once at the end. DIR is created if missing.
#include <filesystem>
#include <string>
#include <vector>

#include "nc_interface/commands.hpp"
#include "nc_interface/dialects.hpp"
#include "nc_interface/safety.hpp"

namespace alc::nc {

// Collects commands in order, passing axis offsets through a SafetyGate. `registers`: where the
// NC keeps the offsets, offset_registers(dialect) of the dialect they will be written in.
class CommandRecorder {
 public:
  explicit CommandRecorder(SafetyLimits limits = {}, OffsetRegisters registers = OffsetRegisters::PerWorkOffset);
  // Returns the decision (probe intervals are always accepted once valid; an invalid command of
  // either kind is refused with the reason in the message).
  SafetyDecision record(const NcCommand& command);
  // The offsets in force on `offsets.work_offset` before the first command (SafetyGate::set_in_force).
  // Throws std::invalid_argument for an invalid value (validate(NcCommand)) and, with one offset
  // register, for a second work offset.
  void set_in_force(const AxisOffsets& offsets);
  AxisOffsets current(int work_offset) const { return gate_.current(work_offset); }
  const std::vector<NcCommand>& to_send() const { return to_send_; }            // split steps expanded
  const std::vector<SafetyDecision>& decisions() const { return decisions_; }   // one per record()
  // Forgets to_send() and decisions() (the offsets in force stay): bounded memory for a long run.
  void clear_log() {
    to_send_.clear();
    decisions_.clear();
  }

 private:
  SafetyGate gate_;
  std::vector<NcCommand> to_send_;
  std::vector<SafetyDecision> decisions_;
};

// The recorder for commands that will be written in `dialect`: its gate keeps the offset registers
// of the dialect (offset_registers(dialect): heidenhain's one datum shift, one register per work
// offset elsewhere), so max_step is judged against what that NC holds. Zero offsets in force until
// set_in_force. Throws std::invalid_argument for invalid limits.
CommandRecorder recorder_for(Dialect dialect, const SafetyLimits& limits = {});

struct NcOutputSummary {
  std::filesystem::path commands_file;   // DIR/commands.jsonl: the commands as sent, one JSON per line
  std::filesystem::path program_file;    // DIR/program.<ext>: all of them as one NC program
  std::filesystem::path safety_file;     // DIR/safety.jsonl: every decision that was not a plain accept
  std::size_t requested = 0;             // commands given
  std::size_t sent = 0;                  // commands written (after splitting)
  std::size_t refused = 0;
  std::size_t split = 0;
  // [µm/m] largest non_compensable_um_per_m of the axis-offset commands given (0 if none has one).
  double max_non_compensable_um_per_m = 0.0;
  // The programs of the other dialects that an earlier run left in DIR (program.ngc, program.nc,
  // program.mpf, program.h: only these names), removed so that DIR holds one run's output.
  std::vector<std::filesystem::path> removed;
};

// Writes DIR/commands.jsonl, DIR/program.<ext> and DIR/safety.jsonl, each atomically
// (io::write_file_atomically), then removes the program another dialect would have written there
// (DIR/program.<ext of another dialect>, a file or a symbolic link; nothing else), which an earlier
// run into DIR left beside the new commands (summary.removed). The gate is recorder_for(dialect, limits). Throws
// std::invalid_argument for bad options, std::runtime_error when a file cannot be written (the message names the path).
NcOutputSummary write_replay_nc_output(const std::filesystem::path& dir, Dialect dialect,
                                       const std::vector<NcCommand>& commands, const DialectOptions& options = {},
                                       const SafetyLimits& limits = {});

// One line of JSON describing a decision: {"verdict":…,"message":…,"requested":{…}}.
std::string decision_json_line(const SafetyDecision& decision);

}  // namespace alc::nc
