// Scenario CSV contract: round trip, any number of columns, and every rejected input class.
#include <catch2/catch.hpp>
#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <set>
#include <sstream>
#include <thread>

#include "scenarios/scenario_csv.hpp"

using alc::scenarios::parse_scenario_csv;
using alc::scenarios::Scenario;
using alc::scenarios::ScenarioCsvError;

namespace {

Scenario parse(const std::string& text) {
  std::istringstream in(text);
  return parse_scenario_csv(in, "case.csv");
}

// Parses text that must be rejected and returns the error.
ScenarioCsvError rejected(const std::string& text) {
  try {
    parse(text);
  } catch (const ScenarioCsvError& e) {
    return e;
  }
  FAIL("the text was accepted: " << text);
  throw std::logic_error("unreachable");
}

// The full message of a rejected text.
std::string message_of(const std::string& text) { return rejected(text).what(); }

// A directory of this test process: the release and the sanitizer runs may run at the same time.
std::filesystem::path own_temp_dir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / (name + "_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir;
}

std::string file_text(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// The names in `dir`: what a write left behind.
std::set<std::string> entries_of(const std::filesystem::path& dir) {
  std::set<std::string> names;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) names.insert(entry.path().filename().string());
  return names;
}

// A small scenario that the writer accepts: 3 rows, inputs T and n, outputs E_X and E_A.
Scenario writable() {
  Scenario s;
  s.input_names = {"T", "n"};
  s.output_names = {"E_X", "E_A"};
  s.time_s = {0.0, 60.0, 120.0};
  s.inputs.resize(3, 2);
  s.inputs << 20.0, 0.0, 20.5, 100.0, 21.0, 0.0;
  s.outputs.resize(3, 2);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  s.outputs << 1.5, nan, nan, -2.0, 3.0, 4.0;
  return s;
}

// What write_scenario_csv(stream) says about `s`; it must throw before writing anything.
std::string write_refused(const Scenario& s) {
  std::ostringstream out;
  try {
    alc::scenarios::write_scenario_csv(out, s);
  } catch (const std::invalid_argument& e) {
    CHECK(out.str().empty());
    return e.what();
  }
  FAIL("the scenario was written:\n" << out.str());
  throw std::logic_error("unreachable");
}

}  // namespace

TEST_CASE("scenario CSV: columns are split into time, inputs and E_ outputs") {
  const Scenario s = parse("time_s,T_ENV,E_X0C,n_C,E_A0C\n0,20.5,1.5,0,\n60,20.6,,100,-3\n");
  CHECK(s.input_names == std::vector<std::string>{"T_ENV", "n_C"});
  CHECK(s.output_names == std::vector<std::string>{"E_X0C", "E_A0C"});
  REQUIRE(s.samples() == 2);
  CHECK(s.time_s[1] == 60.0);
  CHECK(s.inputs(1, 1) == 100.0);
  CHECK(s.outputs(0, 0) == 1.5);
  CHECK(std::isnan(s.outputs(1, 0)));
  CHECK(std::isnan(s.outputs(0, 1)));
  CHECK(s.outputs(1, 1) == -3.0);
  CHECK(s.output_index("E_A0C") == 1);
  CHECK(s.input_index("missing") == -1);
}

TEST_CASE("scenario CSV: CRLF line ends, a BOM and trailing blank lines are accepted") {
  const Scenario s = parse("\xEF\xBB\xBFtime_s,T,E_Z0T\r\n0,1,2\r\n15,1.5,\r\n\r\n");
  CHECK(s.input_names == std::vector<std::string>{"T"});
  CHECK(s.samples() == 2);
  CHECK(s.inputs(1, 0) == 1.5);
}

TEST_CASE("scenario CSV: lines ending in CR alone are named as such, not read as one long header") {
  // Before: "case.csv:1:4: duplicate column name in header, first at column 2 (column '0')".
  CHECK(message_of("time_s,T,E_X0C\r0,1,2\r60,1,2\r") ==
        "case.csv:1: a carriage return inside the line (byte 15): the lines end in CR alone (classic Mac OS); "
        "convert them to LF or CRLF");
}

TEST_CASE("scenario CSV: a 16-sensor, 5-output recording at 15 s sampling loads") {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, 1.0);
  Scenario s;
  for (int i = 0; i < 16; ++i) s.input_names.push_back(std::string("T").append(std::to_string(i + 1)));
  s.input_names.push_back("S_spindle");
  for (const char* e : {"E_X", "E_Y", "E_Z", "E_X2", "E_Y2"}) s.output_names.push_back(e);
  const int n = 46 * 240;  // 46 h at 15 s
  s.time_s.resize(n);
  s.inputs.resize(n, 17);
  s.outputs.setConstant(n, 5, std::numeric_limits<double>::quiet_NaN());
  for (int r = 0; r < n; ++r) {
    s.time_s[static_cast<std::size_t>(r)] = 15.0 * r;
    for (int c = 0; c < 17; ++c) s.inputs(r, c) = 20.0 + noise(rng);
    if (r % 20 == 0)
      for (int c = 0; c < 5; ++c) s.outputs(r, c) = noise(rng) * 10.0;
  }
  std::stringstream buf;
  alc::scenarios::write_scenario_csv(buf, s);
  const Scenario back = parse_scenario_csv(buf, "rec.csv");
  CHECK(back.input_names == s.input_names);
  CHECK(back.output_names == s.output_names);
  CHECK(back.time_s == s.time_s);
  CHECK(back.inputs == s.inputs);
  // NaN != NaN, so compare the pattern of measured cells and their values separately.
  REQUIRE(back.outputs.rows() == s.outputs.rows());
  CHECK((back.outputs.array().isNaN() == s.outputs.array().isNaN()).all());
  const Eigen::MatrixXd measured_back = back.outputs.array().isNaN().select(0.0, back.outputs);
  const Eigen::MatrixXd measured = s.outputs.array().isNaN().select(0.0, s.outputs);
  CHECK(measured_back == measured);
}

TEST_CASE("scenario CSV: write then read gives the same numbers, also through a file") {
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> u(-1e3, 1e3);
  Scenario s;
  s.input_names = {"T_ENV", "n_C"};
  s.output_names = {"E_X0C"};
  const int n = 500;
  s.time_s.resize(n);
  s.inputs.resize(n, 2);
  s.outputs.resize(n, 1);
  for (int r = 0; r < n; ++r) {
    s.time_s[static_cast<std::size_t>(r)] = r * 0.1 + 1e-9 * r;  // values with no short decimal form
    s.inputs(r, 0) = u(rng);
    s.inputs(r, 1) = std::ldexp(u(rng), -40);  // tiny values need exponent form to round-trip
    s.outputs(r, 0) = (r % 3 == 0) ? u(rng) : std::numeric_limits<double>::quiet_NaN();
  }
  const auto dir = own_temp_dir("alc_roundtrip_test");
  const auto path = dir / "roundtrip.csv";
  alc::scenarios::write_scenario_csv(path, s);
  const Scenario back = alc::scenarios::read_scenario_csv(path);
  CHECK(entries_of(dir) == std::set<std::string>{"roundtrip.csv"});  // no temporary file left
  std::filesystem::remove_all(dir);
  CHECK(back.time_s == s.time_s);
  CHECK(back.inputs == s.inputs);
  for (int r = 0; r < n; ++r) {
    if (std::isnan(s.outputs(r, 0)))
      CHECK(std::isnan(back.outputs(r, 0)));
    else
      CHECK(back.outputs(r, 0) == s.outputs(r, 0));
  }
}

TEST_CASE("scenario CSV: format_number never prints -0 and reads back exactly") {
  using alc::scenarios::format_number;
  CHECK(format_number(-0.0) == "0");
  CHECK(format_number(0.1) == "0.1");
  CHECK(format_number(-12.5) == "-12.5");
  CHECK(std::stod(format_number(1.0 / 3.0)) == 1.0 / 3.0);
}

TEST_CASE("scenario CSV: an empty file is rejected") {
  const auto e = rejected("");
  CHECK(std::string(e.what()) == "case.csv: the file is empty (no header line)");
  CHECK(rejected("\n\n  \n").reason == "the file is empty (no header line)");
  CHECK(message_of("\r\n\n") == "case.csv: the file is empty (no header line)");
}

TEST_CASE("scenario CSV: a header without data rows is rejected") {
  const auto e = rejected("time_s,T,E_X0C\n");
  CHECK(e.line == 1);
  CHECK(e.reason == "no data rows after the header");
  CHECK(std::string(e.what()) == "case.csv:1: no data rows after the header");
}

TEST_CASE("scenario CSV: a missing time_s column is rejected with the header line") {
  const auto e = rejected("t,T_ENV,E_X0C\n0,1,2\n");
  CHECK(e.line == 1);
  CHECK(std::string(e.what()) ==
        "case.csv:1: missing required column 'time_s' in header: value 't,T_ENV,E_X0C'");
  // A long header is cut to 60 bytes, never inside a UTF-8 character ("°" is 2 bytes, at 59-60).
  const std::string long_header = "t," + std::string(57, 'a') + "\xC2\xB0" + "C,E_X0C";
  const auto cut = rejected(long_header + "\n0,1,2\n");
  CHECK(cut.value == "t," + std::string(57, 'a') + "…");
  CHECK(std::string(cut.what()) ==
        "case.csv:1: missing required column 'time_s' in header: value 't," + std::string(57, 'a') + "…'");
}

TEST_CASE("scenario CSV: a file with no E_ column or no input column is rejected") {
  const auto no_output = rejected("time_s,T_ENV\n0,1\n");
  CHECK(no_output.line == 1);
  CHECK(no_output.reason == "no measured-error column (a name starting with 'E_') in header");
  const auto no_input = rejected("time_s,E_X0C\n0,1\n");
  CHECK(no_input.reason == "no input column (any column other than time_s and E_…) in header");
  CHECK(std::string(no_output.what()) ==
        "case.csv:1: no measured-error column (a name starting with 'E_') in header: value 'time_s,T_ENV'");
  CHECK(std::string(no_input.what()) ==
        "case.csv:1: no input column (any column other than time_s and E_…) in header: value 'time_s,E_X0C'");
  // "E_" alone names no error, and no input either (before: an input, and then "no measured-error column (a
  // name starting with 'E_')", which it seemed to be).
  CHECK(message_of("time_s,E_\n0,1\n") ==
        "case.csv:1:2: column name 'E_' names no error (an error column is E_ followed by its name, e.g. E_X0C) "
        "(column 'E_'): value 'time_s,E_'");
}

TEST_CASE("scenario CSV: duplicate and empty column names are rejected") {
  const auto dup = rejected("time_s,T,T,E_X0C\n0,1,2,3\n");
  CHECK(dup.line == 1);
  CHECK(dup.column == 3);
  CHECK(dup.column_name == "T");
  const auto empty = rejected("time_s,,E_X0C\n0,1,2\n");
  CHECK(empty.column == 2);
  CHECK(empty.reason == "empty column name in header");
  CHECK(dup.value == "time_s,T,T,E_X0C");
  CHECK(std::string(dup.what()) ==
        "case.csv:1:3: duplicate column name in header, first at column 2 (column 'T'): value 'time_s,T,T,E_X0C'");
  CHECK(std::string(empty.what()) == "case.csv:1:2: empty column name in header: value 'time_s,,E_X0C'");
  // Quotes around a name are dropped, so "T" and T are the same name; the BOM is not part of a name.
  CHECK(message_of("\xEF\xBB\xBFtime_s,\"T\",T,E_X0C\n0,1,2,3\n") ==
        "case.csv:1:3: duplicate column name in header, first at column 2 (column 'T'): value 'time_s,\"T\",T,E_X0C'");
  CHECK(message_of("time_s,T,E_X0C,time_s\n0,1,2,3\n") ==
        "case.csv:1:4: duplicate column name in header, first at column 1 (column 'time_s'): "
        "value 'time_s,T,E_X0C,time_s'");
  CHECK(message_of("time_s,T,E_X0C,\n0,1,2,3\n") == "case.csv:1:4: empty column name in header: value 'time_s,T,E_X0C,'");
  // "E_" alone names no error (before: taken for an input, its empty cells "only measured-error (E_) columns
  // may be empty").
  CHECK(message_of("time_s,T,E_X0C,E_\n0,1,2,\n") ==
        "case.csv:1:4: column name 'E_' names no error (an error column is E_ followed by its name, e.g. E_X0C) "
        "(column 'E_'): value 'time_s,T,E_X0C,E_'");
  // A quote inside a name (a spreadsheet's "T_""a"""): kept before, so that --residuals could not write it.
  CHECK(message_of("time_s,\"T_\"\"a\"\"\",E_X0C\n0,1,2\n") ==
        "case.csv:1:2: column name contains a quote: value 'T_\"\"a\"\"'");
}

TEST_CASE("scenario CSV: a column name that is not UTF-8 is rejected at read time (issue 13 item 4)") {
  const auto bad = rejected("time_s,T\xFF" "1,E_X0C\n0,1,2\n60,1,2\n");
  CHECK(bad.line == 1);
  CHECK(bad.column == 2);
  CHECK(std::string(bad.what()) == "case.csv:1:2: column name is not UTF-8 (byte 2): value 'T\\xFF1'");
  // Overlong, surrogate and truncated sequences too; well-formed UTF-8 ("°C") is a name like any other.
  CHECK(rejected("time_s,\xC0\xB0,E_X0C\n0,1,2\n").column == 2);
  CHECK(rejected("time_s,\xED\xA0\x80,E_X0C\n0,1,2\n").column == 2);
  CHECK(rejected("time_s,T,E_X0C\xE2\x82\n0,1,2\n").column == 3);
  CHECK(parse("time_s,T_\xC2\xB0" "C,E_X0C\n0,1,2\n60,1,2\n").input_names[0] == "T_\xC2\xB0" "C");
}

TEST_CASE("scenario CSV: quoted cells, as a spreadsheet writes them, read as their contents") {
  const Scenario q = parse("\"time_s\",\"T\",\"E_X0C\"\n\"0\",\"20.5\",\"1.25\"\n\"60\",\"21\",\"\"\n");
  REQUIRE(q.time_s == std::vector<double>{0.0, 60.0});
  CHECK(q.inputs(0, 0) == 20.5);
  CHECK(q.outputs(0, 0) == 1.25);
  CHECK(std::isnan(q.outputs(1, 0)));  // "" is no measurement, as an empty cell
  // Inside the quotes the number must still be whole: no blanks, no text.
  CHECK(rejected("time_s,T,E_X0C\n0,\"20.5x\",1\n").column == 2);
  CHECK(std::string(rejected("time_s,T,E_X0C\n0,\"\",1\n").what()) ==
        "case.csv:2:2: empty cell: only measured-error (E_) columns may be empty (column 'T'): value ''");
}

TEST_CASE("scenario CSV: a bad cell is quoted whole on one line, control characters and bytes not UTF-8 escaped") {
  // A NUL cut the message at the cell before, a stray CR moved the cursor back over it.
  CHECK(std::string(rejected(std::string("time_s,T,E_X0C\n0,20\0" "5,1\n", 22)).what()) ==
        "case.csv:2:2: not a number (column 'T'): value '20\\x005'");
  CHECK(std::string(rejected("time_s,T,E_X0C\n0,20.5\r7,1\n").what()) ==
        "case.csv:2:2: not a number (column 'T'): value '20.5\\x0D7'");
  CHECK(std::string(rejected("time_s,T,E_X0C\n0,2\xFF,1\n").what()) ==
        "case.csv:2:2: not a number (column 'T'): value '2\\xFF'");
}

TEST_CASE("scenario CSV: time not strictly increasing is rejected at its line and column") {
  const auto equal = rejected("T,time_s,E_X0C\n1,0,2\n1,60,\n1,60,\n");
  CHECK(equal.line == 4);
  CHECK(equal.column == 2);
  CHECK(equal.column_name == "time_s");
  CHECK(equal.value == "60");
  CHECK(std::string(equal.what()) ==
        "case.csv:4:2: time_s is not strictly increasing (previous row has 60) (column 'time_s'): value '60'");
  const auto back = rejected("time_s,T,E_X0C\n0,1,2\n60,1,\n30,1,\n");
  CHECK(back.line == 4);
  CHECK(back.value == "30");
}

TEST_CASE("scenario CSV: a non-numeric cell is rejected naming line, column and value") {
  const auto e = rejected("time_s,T_ENV,E_X0C\n0,20.1,1\n60,20.x,\n");
  CHECK(e.line == 3);
  CHECK(e.column == 2);
  CHECK(e.column_name == "T_ENV");
  CHECK(e.value == "20.x");
  CHECK(e.reason == "not a number");
  CHECK(std::string(e.what()) == "case.csv:3:2: not a number (column 'T_ENV'): value '20.x'");
  CHECK(rejected("time_s,T,E_X0C\n0,1,abc\n").column_name == "E_X0C");
  CHECK(message_of("time_s,T,E_X0C\n0,1,2\n1,2,3 4\n") == "case.csv:3:3: not a number (column 'E_X0C'): value '3 4'");
  CHECK(message_of("time_s,T,E_X0C\n0x10,1,2\n") == "case.csv:2:1: not a number (column 'time_s'): value '0x10'");
}

TEST_CASE("scenario CSV: one leading '+' is accepted, '+-5', '++5' and '+' are not numbers") {
  for (const std::string bad : {"+-5", "++5", "+", "-+5", "--5", "+-0", "+ 5"}) {
    INFO(bad);
    const auto e = rejected("time_s,T,E_X0C\n0," + bad + ",1\n");
    CHECK(e.reason == "not a number");
    CHECK(std::string(e.what()) == "case.csv:2:2: not a number (column 'T'): value '" + bad + "'");
  }
  const Scenario s = parse("time_s,T,E_X0C\n+0,+5,-5\n+1e-3,-5,1e-3\n2,+.5,+2.5E+1\n");
  CHECK(s.time_s == std::vector<double>{0.0, 1e-3, 2.0});
  CHECK(s.inputs(0, 0) == 5.0);
  CHECK(s.inputs(1, 0) == -5.0);
  CHECK(s.inputs(2, 0) == 0.5);
  CHECK(s.outputs(0, 0) == -5.0);
  CHECK(s.outputs(1, 0) == 1e-3);
  CHECK(s.outputs(2, 0) == 25.0);
}

TEST_CASE("scenario CSV: non-finite cells are rejected") {
  for (const std::string bad : {"nan", "inf", "-inf", "NaN", "1e999"}) {
    const auto e = rejected("time_s,T,E_X0C\n0,1,2\n60," + bad + ",3\n");
    CHECK(e.line == 3);
    CHECK(e.column == 2);
    CHECK(e.value == bad);
    CHECK((e.reason == "not a finite number" || e.reason == "number out of range"));
    CHECK(std::string(e.what()) == "case.csv:3:2: " + e.reason + " (column 'T'): value '" + bad + "'");
  }
  CHECK(rejected("time_s,T,E_X0C\n0,1,2\n60,inf,3\n").reason == "not a finite number");
  CHECK(rejected("time_s,T,E_X0C\n0,1,2\n60,1e999,3\n").reason == "number out of range");
  CHECK(message_of("time_s,T,E_X0C\n0,1,+inf\n") == "case.csv:2:3: not a finite number (column 'E_X0C'): value '+inf'");
}

TEST_CASE("scenario CSV: a wrong number of cells is rejected") {
  const auto few = rejected("time_s,T,E_X0C\n0,1,2\n60,1\n");
  CHECK(few.line == 3);
  CHECK(few.reason == "wrong number of cells: 2 where the header has 3, the row ends before this column");
  CHECK(few.value == "60,1");
  const auto many = rejected("time_s,T,E_X0C\n0,1,2,4\n");
  CHECK(many.line == 2);
  CHECK(many.reason ==
        "wrong number of cells: 4 where the header has 3, this cell is beyond the last column 'E_X0C'");
  // The first missing column by number and header name; the first extra cell by number.
  CHECK(few.column == 3);
  CHECK(few.column_name == "E_X0C");
  CHECK(std::string(few.what()) == "case.csv:3:3: wrong number of cells: 2 where the header has 3, the row ends "
                                   "before this column (column 'E_X0C'): value '60,1'");
  CHECK(many.column == 4);
  CHECK(many.column_name.empty());
  CHECK(many.value == "0,1,2,4");
  CHECK(std::string(many.what()) == "case.csv:2:4: wrong number of cells: 4 where the header has 3, this cell is "
                                    "beyond the last column 'E_X0C': value '0,1,2,4'");
  CHECK(message_of("time_s,T,E_X0C,E_Y0C\n0\n") == "case.csv:2:2: wrong number of cells: 1 where the header has 4, "
                                                    "the row ends before this column (column 'T'): value '0'");
  CHECK(message_of("time_s,T,E_X0C\r\n0,1,2,\r\n") == "case.csv:2:4: wrong number of cells: 4 where the header has "
                                                       "3, this cell is beyond the last column 'E_X0C': value '0,1,2,'");
}

TEST_CASE("scenario CSV: empty cells are allowed only in E_ columns") {
  const auto e = rejected("time_s,T,E_X0C\n0,,2\n");
  CHECK(e.line == 2);
  CHECK(e.column == 2);
  CHECK(e.reason == "empty cell: only measured-error (E_) columns may be empty");
  CHECK(rejected("time_s,T,E_X0C\n,1,2\n").column_name == "time_s");
  CHECK(std::string(e.what()) ==
        "case.csv:2:2: empty cell: only measured-error (E_) columns may be empty (column 'T'): value ''");
  CHECK(message_of("time_s,T,E_X0C\n0,1,2\n\n60, ,\n") ==
        "case.csv:4:2: empty cell: only measured-error (E_) columns may be empty (column 'T'): value ''");
}

TEST_CASE("scenario CSV: a missing file names the path") {
  try {
    alc::scenarios::read_scenario_csv("/nonexistent/dir/x.csv");
    FAIL("no error");
  } catch (const ScenarioCsvError& e) {
    CHECK(std::string(e.what()) == "/nonexistent/dir/x.csv: cannot open file for reading");
  }
}

TEST_CASE("scenario CSV: a directory or another non-regular file is not reported as empty") {
  const auto dir = own_temp_dir("alc_csv_dir_test");
  try {
    alc::scenarios::read_scenario_csv(dir);
    FAIL("a directory was read");
  } catch (const ScenarioCsvError& e) {
    CHECK(std::string(e.what()) == dir.string() + ": not a regular file (a directory)");
    CHECK(e.line == 0);
  }
  try {
    alc::scenarios::read_scenario_csv("/dev/null");
    FAIL("/dev/null was read");
  } catch (const ScenarioCsvError& e) {
    CHECK(std::string(e.what()) ==
          "/dev/null: not a regular file (a character device) and nothing could be read from it");
  }
  // A pipe is read like a file (a shell's <(...)), and an empty pipe says what it is.
  const auto fifo = dir / "pipe.csv";
  REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
  for (const std::string& text : {std::string("time_s,T,E_X0C\n0,1,2\n"), std::string()}) {
    std::thread writer([&] { std::ofstream(fifo, std::ios::binary) << text; });
    try {
      const Scenario s = alc::scenarios::read_scenario_csv(fifo);
      CHECK_FALSE(text.empty());
      CHECK(s.samples() == 1);
    } catch (const ScenarioCsvError& e) {
      CHECK(text.empty());
      CHECK(std::string(e.what()) == fifo.string() + ": not a regular file (a pipe) and nothing could be read from it");
    }
    writer.join();
  }
  // An empty regular file is just empty.
  { std::ofstream(dir / "empty.csv"); }
  try {
    alc::scenarios::read_scenario_csv(dir / "empty.csv");
    FAIL("an empty file was read");
  } catch (const ScenarioCsvError& e) {
    CHECK(std::string(e.what()) == (dir / "empty.csv").string() + ": the file is empty (no header line)");
  }
  std::filesystem::remove_all(dir);
}

TEST_CASE("scenario CSV: a failed write leaves an existing file untouched") {
  const auto dir = own_temp_dir("alc_csv_ro_test");
  const auto path = dir / "keep.csv";
  { std::ofstream(path) << "original\n"; }
  Scenario bad;  // sizes do not match: writing must throw before the original is replaced
  bad.input_names = {"T"};
  bad.output_names = {"E_X"};
  bad.time_s = {0.0};
  CHECK_THROWS_AS(alc::scenarios::write_scenario_csv(path, bad), std::invalid_argument);
  std::ifstream in(path);
  std::string text;
  std::getline(in, text);
  CHECK(text == "original");
  CHECK(entries_of(dir) == std::set<std::string>{"keep.csv"});  // no temporary file made
  std::filesystem::remove_all(dir);
}

TEST_CASE("scenario CSV: the writer refuses what its reader would reject, naming the field, row and value") {
  {
    std::stringstream text;
    alc::scenarios::write_scenario_csv(text, writable());
    CHECK(text.str() == "time_s,T,n,E_X,E_A\n0,20,0,1.5,\n60,20.5,100,,-2\n120,21,0,3,4\n");
    CHECK(parse_scenario_csv(text, "w.csv").samples() == 3);
  }
  const auto with = [](auto change) {
    Scenario s = writable();
    change(s);
    return write_refused(s);
  };
  const double inf = std::numeric_limits<double>::infinity();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  // Names.
  CHECK(with([](Scenario& s) { s.input_names[0] = "T,1"; }) ==
        "write_scenario_csv: input name 1 'T,1' contains a comma, a quote or a line break");
  CHECK(with([](Scenario& s) { s.output_names[1] = "E_\"A\""; }) ==
        "write_scenario_csv: output name 2 'E_\"A\"' contains a comma, a quote or a line break");
  CHECK(with([](Scenario& s) { s.input_names[1] = "n\r"; }) ==
        "write_scenario_csv: input name 2 'n\r' contains a comma, a quote or a line break");
  CHECK(with([](Scenario& s) { s.input_names[1] = "a\nb"; }) ==
        "write_scenario_csv: input name 2 'a\nb' contains a comma, a quote or a line break");
  CHECK(with([](Scenario& s) { s.input_names[1].clear(); }) == "write_scenario_csv: input name 2 is empty");
  CHECK(with([](Scenario& s) { s.output_names[0].clear(); }) == "write_scenario_csv: output name 1 is empty");
  CHECK(with([](Scenario& s) { s.input_names[1] = "T"; }) == "write_scenario_csv: input name 2 'T' is a duplicate");
  CHECK(with([](Scenario& s) { s.output_names[1] = "E_X"; }) == "write_scenario_csv: output name 2 'E_X' is a duplicate");
  CHECK(with([](Scenario& s) { s.input_names[0] = "time_s"; }) ==
        "write_scenario_csv: input name 1 'time_s': time_s is written as the first column");
  CHECK(with([](Scenario& s) { s.output_names[0] = "time_s"; }) ==
        "write_scenario_csv: output name 1 'time_s': time_s is written as the first column");
  CHECK(with([](Scenario& s) { s.input_names[0] = " T"; }) ==
        "write_scenario_csv: input name 1 ' T' starts or ends with a space or tab");
  CHECK(with([](Scenario& s) { s.output_names[0] = "E_X\t"; }) ==
        "write_scenario_csv: output name 1 'E_X\t' starts or ends with a space or tab");
  CHECK(with([](Scenario& s) { s.input_names[1] = "E_n"; }) ==
        "write_scenario_csv: input name 2 'E_n' starts with 'E_', which marks a measured error");
  CHECK(with([](Scenario& s) { s.output_names[1] = "A"; }) ==
        "write_scenario_csv: output name 2 'A' is not a measured-error name ('E_' and at least one more character)");
  CHECK(with([](Scenario& s) { s.output_names[1] = "E_"; }) ==
        "write_scenario_csv: output name 2 'E_' is not a measured-error name ('E_' and at least one more character)");
  // Values.
  CHECK(with([&](Scenario& s) { s.inputs(1, 0) = inf; }) ==
        "write_scenario_csv: input 'T' at row 2 (line 3): value 'inf' is not finite");
  CHECK(with([&](Scenario& s) { s.inputs(2, 1) = nan; }) ==
        "write_scenario_csv: input 'n' at row 3 (line 4): value 'nan' is not finite");
  CHECK(with([&](Scenario& s) { s.outputs(2, 1) = -inf; }) ==
        "write_scenario_csv: output 'E_A' at row 3 (line 4): value '-inf' is infinite");
  CHECK(with([](Scenario& s) { s.time_s[2] = 60.0; }) ==
        "write_scenario_csv: time_s at row 3 (line 4): value '60' is not greater than the previous row's '60'");
  CHECK(with([](Scenario& s) { s.time_s[1] = -1.5; }) ==
        "write_scenario_csv: time_s at row 2 (line 3): value '-1.5' is not greater than the previous row's '0'");
  CHECK(with([&](Scenario& s) { s.time_s[0] = nan; }) ==
        "write_scenario_csv: time_s at row 1 (line 2): value 'nan' is not finite");
  CHECK(with([&](Scenario& s) { s.time_s[2] = inf; }) ==
        "write_scenario_csv: time_s at row 3 (line 4): value 'inf' is not finite");
  // Shape.
  CHECK(with([](Scenario& s) { s.time_s.pop_back(); }) ==
        "write_scenario_csv: matrix sizes do not match the names and time_s");
  CHECK(with([](Scenario& s) {
          s.output_names.clear();
          s.outputs.resize(3, 0);
        }) == "write_scenario_csv: no measured-error (E_) column");
}

TEST_CASE("scenario CSV: the writer writes result files without inputs or rows (alc replay --residuals)") {
  Scenario s = writable();
  s.input_names.clear();
  s.inputs.resize(3, 0);
  s.output_names = {"E_X", "E_X_pred"};
  std::ostringstream text;
  alc::scenarios::write_scenario_csv(text, s);
  CHECK(text.str() == "time_s,E_X,E_X_pred\n0,1.5,\n60,,-2\n120,3,4\n");
  s.time_s.clear();
  s.inputs.resize(0, 0);
  s.outputs.resize(0, 2);
  std::ostringstream header_only;
  alc::scenarios::write_scenario_csv(header_only, s);
  CHECK(header_only.str() == "time_s,E_X,E_X_pred\n");
}

TEST_CASE("scenario CSV: a refused or failed file write leaves no temporary file and the target as it was") {
  const auto dir = own_temp_dir("alc_csv_refused_test");
  const auto path = dir / "keep.csv";
  const auto tmp = dir / "keep.csv.tmp";
  { std::ofstream(path, std::ios::binary) << "original\n"; }
  Scenario bad = writable();
  bad.time_s[1] = 0.0;
  try {
    alc::scenarios::write_scenario_csv(path, bad);
    FAIL("the scenario was written");
  } catch (const std::invalid_argument& e) {
    CHECK(std::string(e.what()) ==
          "write_scenario_csv: time_s at row 2 (line 3): value '0' is not greater than the previous row's '0'");
  }
  CHECK(file_text(path) == "original\n");
  CHECK_FALSE(std::filesystem::exists(tmp));
  // A stale temporary file of an earlier crash (or of another writer) is not taken for ours: neither
  // a refused write nor a good one touches it; each write uses a temporary file of its own.
  { std::ofstream(tmp, std::ios::binary) << "stale\n"; }
  CHECK_THROWS_AS(alc::scenarios::write_scenario_csv(path, bad), std::invalid_argument);
  CHECK(file_text(tmp) == "stale\n");
  // A good write replaces the target and leaves nothing of its own beside it.
  alc::scenarios::write_scenario_csv(path, writable());
  CHECK(file_text(path) == "time_s,T,n,E_X,E_A\n0,20,0,1.5,\n60,20.5,100,,-2\n120,21,0,3,4\n");
  CHECK(file_text(tmp) == "stale\n");
  CHECK(entries_of(dir) == std::set<std::string>{"keep.csv", "keep.csv.tmp"});
  // The rename fails (the target is a directory that is not empty): the temporary file goes, the
  // directory stays.
  const auto target_dir = dir / "taken.csv";
  std::filesystem::create_directories(target_dir);
  { std::ofstream(target_dir / "inside", std::ios::binary) << "x"; }
  CHECK_THROWS_WITH(alc::scenarios::write_scenario_csv(target_dir, writable()),
                    Catch::Matchers::Contains(target_dir.string()));
  CHECK(entries_of(dir) == std::set<std::string>{"keep.csv", "keep.csv.tmp", "taken.csv"});
  CHECK(file_text(target_dir / "inside") == "x");
  std::filesystem::remove_all(dir);
}
