#pragma once
// The JSON-lines form of NC commands: what the replay writes (commands.jsonl) and `alc nc` reads.
//   {"type":"axis_offsets","x_mm":0.0123,"y_mm":-0.004,"z_mm":0.01,"a_deg":0.001,"c_deg":-0.002,"work_offset":"G54"}
//   {"type":"probe_interval","minutes":30}          ("minutes":null = never probe again)
// Optional in both: "time_s" (number). Axis offsets: x_mm, y_mm, z_mm, c_deg required; exactly one of
// a_deg, b_deg; work_offset "G54"…"G59" (default: `default_work_offset`, G54 unless the caller gives
// the machine config's [nc] work_offset); optional "non_compensable_um_per_m" (>= 0,
// what the offsets cannot cancel; never written to NC). Unknown fields are errors, so a typo
// never silently becomes a zero offset. Empty lines are skipped.
#include <iosfwd>
#include <stdexcept>
#include <string>
#include <vector>

#include "nc_interface/commands.hpp"

namespace alc::nc {

// A line that is not a valid command. The message reads `SOURCE:LINE: reason (field 'F'): value 'V'`
// (without `: value 'V'` where there is no value: a field missing or given twice).
class JsonlError : public std::runtime_error {
 public:
  JsonlError(std::string source, std::size_t line, std::string field, std::string value, const std::string& reason);
  std::string source;
  std::size_t line = 0;  // 1-based
  std::string field;     // empty when the whole line is at fault
  std::string value;     // offending JSON text (shortened to 80 characters)
  std::string reason;
};

NcCommand parse_command_json(const std::string& line_text, const std::string& source = "<input>", std::size_t line = 1,
                             int default_work_offset = 1);
// `lines`, when given, gets each command's 1-based line in the input (empty lines are skipped).
std::vector<NcCommand> read_commands_jsonl(std::istream& in, const std::string& source, int default_work_offset = 1,
                                           std::vector<std::size_t>* lines = nullptr);

// One line of JSON without the newline; numbers print so that they read back exactly.
std::string to_json_line(const NcCommand& command);
void write_commands_jsonl(std::ostream& out, const std::vector<NcCommand>& commands);

}  // namespace alc::nc
