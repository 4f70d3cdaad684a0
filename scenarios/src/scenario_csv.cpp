#include "scenarios/scenario_csv.hpp"

#include <charconv>
#include <cmath>
#include <fstream>
#include <istream>
#include <limits>
#include <ostream>
#include <sstream>
#include <system_error>
#include <unordered_set>

#include "alc/error_kind.hpp"
#include "common/atomic_file.hpp"
#include "common/utf8.hpp"
#include "common/input_file.hpp"
#include "common/number_text.hpp"

namespace alc::scenarios {

namespace {

std::string location_prefix(const std::string& file, std::size_t line, std::size_t column) {
  std::string s = file;
  if (line > 0) s.append(":").append(std::to_string(line));
  if (column > 0) s.append(":").append(std::to_string(column));
  return s;
}

// A long cell or line quoted in a message: its first 60 bytes.
std::string shorten(std::string_view text) { return common::shortened(text, 60); }

std::string compose(const std::string& file, std::size_t line, std::size_t column,
                    const std::string& column_name, const std::string& value, const std::string& reason) {
  std::string s = location_prefix(file, line, column) + ": " + reason;
  if (!column_name.empty()) s += " (column '" + column_name + "')";
  if (!value.empty() || column > 0) s += ": value '" + common::escaped_utf8(shorten(value), true) + "'";
  return s;
}

std::string trim(std::string_view s) {
  std::size_t b = 0, e = s.size();
  while (b < e && (s[b] == ' ' || s[b] == '\t')) ++b;
  while (e > b && (s[e - 1] == ' ' || s[e - 1] == '\t')) --e;
  return std::string(s.substr(b, e - b));
}

std::vector<std::string> split_cells(const std::string& line) {
  std::vector<std::string> cells;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    cells.push_back(trim(std::string_view(line).substr(start, comma == std::string::npos ? std::string::npos : comma - start)));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return cells;
}

std::string unquote(const std::string& s) {
  if (s.size() >= 2 && s.front() == '"' && s.back() == '"') return s.substr(1, s.size() - 2);
  return s;
}

// Parses a complete cell as a finite double; returns an empty string on success, else the reason.
std::string parse_double(const std::string& cell, double& out) {
  const char* begin = cell.data();
  const char* end = cell.data() + cell.size();
  if (begin != end && *begin == '+') {  // from_chars rejects a leading '+'; accept one before a digit or '.'
    ++begin;
    if (begin != end && (*begin == '+' || *begin == '-')) return "not a number";  // "+-5", "++5"
  }
  const auto [ptr, ec] = std::from_chars(begin, end, out);
  if (ec == std::errc::result_out_of_range) return "number out of range";
  if (ec != std::errc() || ptr != end || begin == end) return "not a number";
  if (!std::isfinite(out)) return "not a finite number";
  return {};
}

}  // namespace

ScenarioCsvError::ScenarioCsvError(std::string file_, std::size_t line_, std::size_t column_,
                                   std::string column_name_, std::string value_, const std::string& what)
    : std::runtime_error(compose(file_, line_, column_, column_name_, value_, what)),
      file(std::move(file_)), line(line_), column(column_), column_name(std::move(column_name_)),
      value(std::move(value_)), reason(what) {}

int Scenario::input_index(const std::string& name) const {
  for (std::size_t i = 0; i < input_names.size(); ++i)
    if (input_names[i] == name) return static_cast<int>(i);
  return -1;
}

int Scenario::output_index(const std::string& name) const {
  for (std::size_t i = 0; i < output_names.size(); ++i)
    if (output_names[i] == name) return static_cast<int>(i);
  return -1;
}

namespace {

// `empty_reason`: what to say when there is no header line at all.
Scenario parse_csv(std::istream& in, const std::string& source, const std::string& empty_reason) {
  std::string line;
  std::size_t line_no = 0;
  auto next_line = [&]() -> bool {
    if (!std::getline(in, line)) return false;
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line_no == 1 && line.rfind("\xEF\xBB\xBF", 0) == 0) line.erase(0, 3);  // UTF-8 BOM
    // A file whose lines end in CR alone (classic Mac OS, some old exports) reads as one long line:
    // say so, instead of what its cells would look like as one header. (A CR inside a later line is a
    // bad cell, named as such.)
    if (const auto cr = line.find('\r'); line_no == 1 && cr != std::string::npos)
      throw ScenarioCsvError(source, line_no, 0, "", "",
                             "a carriage return inside the line (byte " + std::to_string(cr + 1) +
                                 "): the lines end in CR alone (classic Mac OS); convert them to LF or CRLF");
    return true;
  };

  // Header: the first non-blank line.
  bool have_header = false;
  while (next_line()) {
    if (!trim(line).empty()) { have_header = true; break; }
  }
  if (!have_header) throw ScenarioCsvError(source, 0, 0, "", "", empty_reason);

  std::vector<std::string> header = split_cells(line);
  const std::size_t header_line = line_no;
  const std::string header_text = shorten(line);
  enum class Role { Time, Input, Output };
  std::vector<Role> roles(header.size());
  std::vector<int> slot(header.size(), -1);
  Scenario s;
  int time_col = -1;
  std::unordered_set<std::string> seen;
  for (std::size_t c = 0; c < header.size(); ++c) {
    header[c] = unquote(header[c]);
    const std::string& name = header[c];
    if (name.empty()) throw ScenarioCsvError(source, header_line, c + 1, "", header_text, "empty column name in header");
    // A quote in a name ("T_""a""" is not unescaped): no output of ours could write it back.
    if (name.find('"') != std::string::npos)
      throw ScenarioCsvError(source, header_line, c + 1, "", common::escaped_utf8(name, true), "column name contains a quote");
    // Names go into JSON (reports, the history's run record): refuse what is not UTF-8 here.
    if (const std::size_t at = common::invalid_utf8_at(name); at != std::string::npos)
      throw ScenarioCsvError(source, header_line, c + 1, "", common::escaped_utf8(name, true),
                             "column name is not UTF-8 (byte " + std::to_string(at + 1) + ")");
    if (!seen.insert(name).second) {
      std::size_t first = 0;
      while (header[first] != name) ++first;
      throw ScenarioCsvError(source, header_line, c + 1, name, header_text,
                             "duplicate column name in header, first at column " + std::to_string(first + 1));
    }
    // "E_" alone starts like an error and names none: taken for an input, its empty cells were refused
    // as "only measured-error (E_) columns may be empty".
    if (name == "E_")
      throw ScenarioCsvError(source, header_line, c + 1, name, header_text,
                             "column name 'E_' names no error (an error column is E_ followed by its name, e.g. E_X0C)");
    if (name == "time_s") {
      roles[c] = Role::Time;
      time_col = static_cast<int>(c);
    } else if (alc::is_error_name(name)) {
      roles[c] = Role::Output;
      slot[c] = static_cast<int>(s.output_names.size());
      s.output_names.push_back(name);
    } else {
      roles[c] = Role::Input;
      slot[c] = static_cast<int>(s.input_names.size());
      s.input_names.push_back(name);
    }
  }
  if (time_col < 0)
    throw ScenarioCsvError(source, header_line, 0, "", header_text, "missing required column 'time_s' in header");
  if (s.output_names.empty())
    throw ScenarioCsvError(source, header_line, 0, "", header_text,
                           "no measured-error column (a name starting with 'E_') in header");
  if (s.input_names.empty())
    throw ScenarioCsvError(source, header_line, 0, "", header_text,
                           "no input column (any column other than time_s and E_…) in header");

  std::vector<double> inputs, outputs;  // row-major while reading
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<std::string> cells;
  while (next_line()) {
    if (trim(line).empty()) continue;
    cells = split_cells(line);
    if (cells.size() != header.size()) {
      // Point at the first column that is missing (its header name) or the first cell beyond the header.
      const std::string counts =
          "wrong number of cells: " + std::to_string(cells.size()) + " where the header has " + std::to_string(header.size());
      if (cells.size() < header.size())
        throw ScenarioCsvError(source, line_no, cells.size() + 1, header[cells.size()], shorten(line),
                               counts + ", the row ends before this column");
      throw ScenarioCsvError(source, line_no, header.size() + 1, "", shorten(line),
                             counts + ", this cell is beyond the last column '" + header.back() + "'");
    }
    for (std::size_t c = 0; c < cells.size(); ++c) {
      const std::string cell = unquote(cells[c]);  // "20.5", as a spreadsheet writes it, is 20.5
      if (cell.empty()) {
        if (roles[c] == Role::Output) {
          outputs.push_back(nan);
          continue;
        }
        throw ScenarioCsvError(source, line_no, c + 1, header[c], cell,
                               "empty cell: only measured-error (E_) columns may be empty");
      }
      double v = 0.0;
      if (const std::string why = parse_double(cell, v); !why.empty())
        throw ScenarioCsvError(source, line_no, c + 1, header[c], cell, why);
      switch (roles[c]) {
        case Role::Time:
          if (!s.time_s.empty() && !(v > s.time_s.back()))
            throw ScenarioCsvError(source, line_no, c + 1, header[c], cell,
                                   "time_s is not strictly increasing (previous row has " +
                                       format_number(s.time_s.back()) + ")");
          s.time_s.push_back(v);
          break;
        case Role::Input: inputs.push_back(v); break;
        case Role::Output: outputs.push_back(v); break;
      }
    }
  }
  if (in.bad()) throw ScenarioCsvError(source, line_no, 0, "", "", "read error");
  if (s.time_s.empty()) throw ScenarioCsvError(source, header_line, 0, "", "", "no data rows after the header");

  const auto n = static_cast<Eigen::Index>(s.time_s.size());
  const auto ni = static_cast<Eigen::Index>(s.input_names.size());
  const auto no = static_cast<Eigen::Index>(s.output_names.size());
  s.inputs = Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(inputs.data(), n, ni);
  s.outputs = Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(outputs.data(), n, no);
  return s;
}

constexpr const char* kEmptyFile = "the file is empty (no header line)";

}  // namespace

Scenario parse_scenario_csv(std::istream& in, const std::string& source) { return parse_csv(in, source, kEmptyFile); }

Scenario read_scenario_csv(const std::filesystem::path& path) {
  // A directory opens as a stream that reads nothing: say what it is instead of "empty". A pipe or a
  // character device (/dev/stdin, a shell's <(...)) is read like a file.
  std::error_code ec;
  const auto type = std::filesystem::status(path, ec).type();
  const bool regular = type == std::filesystem::file_type::regular;
  if (const std::string problem = io::input_file_problem(path); !problem.empty())
    throw ScenarioCsvError(path.string(), 0, 0, "", "", problem);
  const std::string not_regular = std::string("not a regular file (") + io::file_type_name(type) + ")";
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ScenarioCsvError(path.string(), 0, 0, "", "", "cannot open file for reading");
  return parse_csv(in, path.string(), regular ? std::string(kEmptyFile) : not_regular + " and nothing could be read from it");
}

std::string format_number(double value) {
  return value == 0.0 ? "0" : common::shortest_text(value);  // -0 is written as 0
}

namespace {

[[noreturn]] void unwritable(const std::string& why) { throw std::invalid_argument("write_scenario_csv: " + why); }

// Quoted for a message: a name or a number as it would be written.
std::string quoted(const std::string& text) {
  std::string q(1, '\'');  // built by appending: GCC 12 warns (-Wrestrict) about "'" + std::string
  q.append(shorten(text)).push_back('\'');
  return q;
}

// "row 3 (line 4)": data rows count from 1, the header is line 1.
std::string row_at(Eigen::Index r) {
  return "row " + std::to_string(r + 1) + " (line " + std::to_string(r + 2) + ")";
}

// Everything the reader would reject (or read back differently) is refused before a byte is written.
void check_writable(const Scenario& s) {
  const auto n = static_cast<Eigen::Index>(s.time_s.size());
  if (s.inputs.rows() != n || s.outputs.rows() != n ||
      s.inputs.cols() != static_cast<Eigen::Index>(s.input_names.size()) ||
      s.outputs.cols() != static_cast<Eigen::Index>(s.output_names.size()))
    unwritable("matrix sizes do not match the names and time_s");
  // No input column and no rows are allowed: `alc replay --residuals` writes time_s and E_ columns
  // only, and may have no measurement after CP. Such a file is a result, not a scenario to replay.
  if (s.output_names.empty()) unwritable("no measured-error (E_) column");

  std::unordered_set<std::string> seen{"time_s"};  // time_s is always the first column
  const auto check_name = [&](const std::string& kind, std::size_t index, const std::string& name) {
    const std::string what = kind + " name " + std::to_string(index + 1) + " " + quoted(name);
    if (name.empty()) unwritable(kind + " name " + std::to_string(index + 1) + " is empty");
    if (name.find_first_of(",\"\r\n") != std::string::npos)
      unwritable(what + " contains a comma, a quote or a line break");
    if (name.front() == ' ' || name.front() == '\t' || name.back() == ' ' || name.back() == '\t')
      unwritable(what + " starts or ends with a space or tab");
    if (name == "time_s") unwritable(what + ": time_s is written as the first column");
    if (!seen.insert(name).second) unwritable(what + " is a duplicate");
  };
  for (std::size_t i = 0; i < s.input_names.size(); ++i) {
    check_name("input", i, s.input_names[i]);
    if (alc::is_error_name(s.input_names[i]))
      unwritable("input name " + std::to_string(i + 1) + " " + quoted(s.input_names[i]) +
                 " starts with 'E_', which marks a measured error");
  }
  for (std::size_t i = 0; i < s.output_names.size(); ++i) {
    check_name("output", i, s.output_names[i]);
    if (!alc::is_error_name(s.output_names[i]))
      unwritable("output name " + std::to_string(i + 1) + " " + quoted(s.output_names[i]) +
                 " is not a measured-error name ('E_' and at least one more character)");
  }

  for (Eigen::Index r = 0; r < n; ++r) {
    const double t = s.time_s[static_cast<std::size_t>(r)];
    if (!std::isfinite(t)) unwritable("time_s at " + row_at(r) + ": value " + quoted(format_number(t)) + " is not finite");
    if (r > 0 && !(t > s.time_s[static_cast<std::size_t>(r - 1)]))
      unwritable("time_s at " + row_at(r) + ": value " + quoted(format_number(t)) +
                 " is not greater than the previous row's " + quoted(format_number(s.time_s[static_cast<std::size_t>(r - 1)])));
    for (Eigen::Index c = 0; c < s.inputs.cols(); ++c)
      if (!std::isfinite(s.inputs(r, c)))
        unwritable("input " + quoted(s.input_names[static_cast<std::size_t>(c)]) + " at " + row_at(r) + ": value " +
                   quoted(format_number(s.inputs(r, c))) + " is not finite");
    for (Eigen::Index c = 0; c < s.outputs.cols(); ++c)
      if (std::isinf(s.outputs(r, c)))  // NaN is an empty cell (no measurement)
        unwritable("output " + quoted(s.output_names[static_cast<std::size_t>(c)]) + " at " + row_at(r) + ": value " +
                   quoted(format_number(s.outputs(r, c))) + " is infinite");
  }
}

void write_rows(std::ostream& out, const Scenario& s) {
  const auto n = static_cast<Eigen::Index>(s.time_s.size());
  std::string row = "time_s";
  for (const auto& name : s.input_names) row.append(",").append(name);
  for (const auto& name : s.output_names) row.append(",").append(name);
  out << row << '\n';
  for (Eigen::Index r = 0; r < n; ++r) {
    row = format_number(s.time_s[static_cast<std::size_t>(r)]);
    for (Eigen::Index c = 0; c < s.inputs.cols(); ++c) row.append(",").append(format_number(s.inputs(r, c)));
    for (Eigen::Index c = 0; c < s.outputs.cols(); ++c) {
      row += ',';
      if (!std::isnan(s.outputs(r, c))) row += format_number(s.outputs(r, c));
    }
    out << row << '\n';
  }
}

}  // namespace

void write_scenario_csv(std::ostream& out, const Scenario& s) {
  check_writable(s);
  write_rows(out, s);
}

void write_scenario_csv(const std::filesystem::path& path, const Scenario& s) {
  check_writable(s);  // before any file is touched
  io::write_file_atomically(path, [&s](std::ostream& out) { write_rows(out, s); });
}

}  // namespace alc::scenarios
