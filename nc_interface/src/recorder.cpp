#include "nc_interface/recorder.hpp"

#include <algorithm>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

#include "common/atomic_file.hpp"
#include "nc_interface/jsonl.hpp"

namespace alc::nc {

CommandRecorder::CommandRecorder(SafetyLimits limits, OffsetRegisters registers) : gate_(limits, registers) {
  if (const std::string e = validate(limits); !e.empty()) throw std::invalid_argument("safety limits: " + e);
}

SafetyDecision CommandRecorder::record(const NcCommand& command) {
  SafetyDecision d;
  if (const std::string e = validate(command); !e.empty()) {
    d.verdict = SafetyVerdict::Refused;
    d.message = "refused; invalid command: " + e;
    if (const auto* o = std::get_if<AxisOffsets>(&command)) d.requested = *o;
  } else if (const auto* o = std::get_if<AxisOffsets>(&command)) {
    d = gate_.submit(*o);
    to_send_.insert(to_send_.end(), d.to_send.begin(), d.to_send.end());
  } else {
    d.verdict = SafetyVerdict::Accepted;
    d.message = "accepted";
    to_send_.push_back(command);
  }
  decisions_.push_back(d);
  return d;
}

void CommandRecorder::set_in_force(const AxisOffsets& offsets) {
  if (const std::string e = validate(NcCommand{offsets}); !e.empty())
    throw std::invalid_argument("offsets in force: " + e);
  gate_.set_in_force(offsets);
}

CommandRecorder recorder_for(Dialect dialect, const SafetyLimits& limits) {
  return CommandRecorder(limits, offset_registers(dialect));
}

std::string decision_json_line(const SafetyDecision& d) {
  nlohmann::ordered_json j;
  j["verdict"] = std::string(verdict_name(d.verdict));
  j["message"] = d.message;
  j["requested"] = nlohmann::ordered_json::parse(to_json_line(d.requested));
  j["steps"] = d.to_send.size();
  return j.dump();
}

NcOutputSummary write_replay_nc_output(const std::filesystem::path& dir, Dialect dialect,
                                       const std::vector<NcCommand>& commands, const DialectOptions& options,
                                       const SafetyLimits& limits) {
  if (const std::string e = validate(options); !e.empty()) throw std::invalid_argument("NC options: " + e);
  CommandRecorder recorder = recorder_for(dialect, limits);
  NcOutputSummary summary;
  std::ostringstream safety;
  for (const NcCommand& c : commands) {
    if (const auto* o = std::get_if<AxisOffsets>(&c); o && o->non_compensable_um_per_m)
      summary.max_non_compensable_um_per_m = std::max(summary.max_non_compensable_um_per_m, *o->non_compensable_um_per_m);
    const SafetyDecision d = recorder.record(c);
    if (d.verdict == SafetyVerdict::Refused) ++summary.refused;
    if (d.verdict == SafetyVerdict::Split) ++summary.split;
    if (d.verdict != SafetyVerdict::Accepted) safety << decision_json_line(d) << "\n";
  }
  summary.requested = commands.size();
  summary.sent = recorder.to_send().size();
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw std::runtime_error("cannot create " + dir.string() + ": " + ec.message());
  std::ostringstream jsonl;
  write_commands_jsonl(jsonl, recorder.to_send());
  summary.commands_file = dir / "commands.jsonl";
  summary.program_file = dir / ("program" + std::string(program_extension(dialect)));
  summary.safety_file = dir / "safety.jsonl";
  const std::string program = write_program(dialect, recorder.to_send(), options);
  io::write_file_atomically(summary.commands_file, jsonl.str());
  io::write_file_atomically(summary.program_file, program);
  io::write_file_atomically(summary.safety_file, safety.str());
  // An earlier run into DIR in another dialect left its program (review: program.ngc of case A with
  // G55 and base -350 beside case B's commands.jsonl and program.nc): one run's output only. Only the
  // names ALC itself gives a program, and only a file or a link (a directory of that name stays).
  for (const Dialect other : {Dialect::LinuxCNC, Dialect::Fanuc, Dialect::Sinumerik, Dialect::Heidenhain}) {
    if (other == dialect) continue;
    const std::filesystem::path old = dir / ("program" + std::string(program_extension(other)));
    const std::filesystem::file_status st = std::filesystem::symlink_status(old, ec);
    if (ec || !(std::filesystem::is_regular_file(st) || std::filesystem::is_symlink(st))) continue;
    if (!std::filesystem::remove(old, ec) || ec)
      throw std::runtime_error("cannot remove " + old.string() + ", the program of an earlier run in another dialect, " +
                               "beside the new output: " + (ec ? ec.message() : std::string("not removed")));
    summary.removed.push_back(old);
  }
  return summary;
}

}  // namespace alc::nc
