// libFuzzer target: NC command JSON lines (nc_interface/jsonl.hpp), and what follows them in
// `alc nc`: the safety gate and the four dialect writers. Bad input is JsonlError; accepted
// commands always write, and what the gate let through reads back from commands.jsonl text.
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

#include "nc_interface/dialects.hpp"
#include "nc_interface/jsonl.hpp"
#include "nc_interface/recorder.hpp"

using namespace alc::nc;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  std::vector<NcCommand> commands;
  try {
    commands = read_commands_jsonl(in, "fuzz.jsonl");
  } catch (const JsonlError&) {
    return 0;
  }
  for (const Dialect d : {Dialect::LinuxCNC, Dialect::Fanuc, Dialect::Sinumerik, Dialect::Heidenhain}) {
    SafetyLimits split;
    split.on_step_violation = StepAction::Split;
    CommandRecorder recorder = recorder_for(d, split);
    for (const NcCommand& c : commands) recorder.record(c);
    write_program(d, recorder.to_send());  // never throws for commands the recorder let through
    std::ostringstream jsonl;
    write_commands_jsonl(jsonl, recorder.to_send());
    std::istringstream back(jsonl.str());
    if (read_commands_jsonl(back, "written.jsonl").size() != recorder.to_send().size()) __builtin_trap();
  }
  return 0;
}
