#pragma once
// The one reader and the one writer of the scenario CSV contract (docs/design.md, "Scenario CSV"):
// UTF-8, comma-separated, one header line, required `time_s` [s] strictly increasing,
// `E_…` columns are measured errors (empty cell = no measurement), every other column an input.
#include <filesystem>
#include <iosfwd>
#include <stdexcept>
#include <string>

#include "scenarios/scenario.hpp"

namespace alc::scenarios {

// Thrown for a file that breaks the contract. The message names the file, the line, the column
// (1-based index and header name) and the offending value; the fields carry the same facts.
class ScenarioCsvError : public std::runtime_error {
 public:
  ScenarioCsvError(std::string file, std::size_t line, std::size_t column, std::string column_name,
                   std::string value, const std::string& what);
  std::string file;
  std::size_t line = 0;      // 1-based, 0 when the whole file is at fault
  std::size_t column = 0;    // 1-based, 0 when no single column is at fault
  std::string column_name;   // header name of `column`, empty if none
  std::string value;         // the offending cell or header text
  std::string reason;        // the bare reason, without the location prefix
};

// Parse a scenario from text; `source_name` is used in error messages (a path or "<stdin>").
Scenario parse_scenario_csv(std::istream& in, const std::string& source_name);
// A directory (or socket, block device) is rejected as "not a regular file (...)"; a pipe or a
// character device is read like a file.
Scenario read_scenario_csv(const std::filesystem::path& path);

// Write columns time_s, inputs..., outputs... Numbers use the shortest text that reads back to
// the same double, so write -> read is exact. Missing outputs (NaN) are written as empty cells.
// Throws std::invalid_argument before writing anything, naming the field, row and value, for what
// the reader would reject or read back differently: mismatched sizes, no output column, an empty,
// duplicate or padded name or one with a comma, quote or line break, an input named time_s or E_…,
// an output not named E_…, a non-finite time or input, an infinite output, or time_s not strictly
// increasing. No input column and no rows are allowed (a result file such as `alc replay
// --residuals` writes, which the reader would not take as a scenario).
void write_scenario_csv(std::ostream& out, const Scenario& scenario);
// Writes atomically (io::write_file_atomically: a temporary file of its own beside `path`, then a
// rename), so a reader never sees half a file. On any failure the temporary file is removed and an
// existing `path` is left untouched (std::runtime_error naming `path`).
void write_scenario_csv(const std::filesystem::path& path, const Scenario& scenario);

// Shortest round-trip text of a finite double ("0.1", "-12.5", "1e-07"; common::shortest_text),
// except that -0 is written as "0".
std::string format_number(double value);

}  // namespace alc::scenarios
