// Scenario CSV contract: round trip, any number of columns, and every rejected input class.
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

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

TEST_CASE("scenario CSV: a 16-sensor, 5-output recording at 15 s sampling loads") {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, 1.0);
  Scenario s;
  for (int i = 0; i < 16; ++i) s.input_names.push_back("T" + std::to_string(i + 1));
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
  const auto path = std::filesystem::temp_directory_path() / "alc_roundtrip_test.csv";
  alc::scenarios::write_scenario_csv(path, s);
  const Scenario back = alc::scenarios::read_scenario_csv(path);
  std::filesystem::remove(path);
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
}

TEST_CASE("scenario CSV: a header without data rows is rejected") {
  const auto e = rejected("time_s,T,E_X0C\n");
  CHECK(e.line == 1);
  CHECK(e.reason == "no data rows after the header");
}

TEST_CASE("scenario CSV: a missing time_s column is rejected with the header line") {
  const auto e = rejected("t,T_ENV,E_X0C\n0,1,2\n");
  CHECK(e.line == 1);
  CHECK(std::string(e.what()) ==
        "case.csv:1: missing required column 'time_s' in header: value 't,T_ENV,E_X0C'");
}

TEST_CASE("scenario CSV: a file with no E_ column or no input column is rejected") {
  const auto no_output = rejected("time_s,T_ENV\n0,1\n");
  CHECK(no_output.line == 1);
  CHECK(no_output.reason == "no measured-error column (a name starting with 'E_') in header");
  const auto no_input = rejected("time_s,E_X0C\n0,1\n");
  CHECK(no_input.reason == "no input column (any column other than time_s and E_…) in header");
}

TEST_CASE("scenario CSV: duplicate and empty column names are rejected") {
  const auto dup = rejected("time_s,T,T,E_X0C\n0,1,2,3\n");
  CHECK(dup.line == 1);
  CHECK(dup.column == 3);
  CHECK(dup.column_name == "T");
  const auto empty = rejected("time_s,,E_X0C\n0,1,2\n");
  CHECK(empty.column == 2);
  CHECK(empty.reason == "empty column name in header");
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
}

TEST_CASE("scenario CSV: non-finite cells are rejected") {
  for (const std::string bad : {"nan", "inf", "-inf", "NaN", "1e999"}) {
    const auto e = rejected("time_s,T,E_X0C\n0,1,2\n60," + bad + ",3\n");
    CHECK(e.line == 3);
    CHECK(e.column == 2);
    CHECK(e.value == bad);
    CHECK((e.reason == "not a finite number" || e.reason == "number out of range"));
  }
}

TEST_CASE("scenario CSV: a wrong number of cells is rejected") {
  const auto few = rejected("time_s,T,E_X0C\n0,1,2\n60,1\n");
  CHECK(few.line == 3);
  CHECK(few.reason == "wrong number of cells: 2 where the header has 3");
  CHECK(few.value == "60,1");
  const auto many = rejected("time_s,T,E_X0C\n0,1,2,4\n");
  CHECK(many.line == 2);
  CHECK(many.reason == "wrong number of cells: 4 where the header has 3");
}

TEST_CASE("scenario CSV: empty cells are allowed only in E_ columns") {
  const auto e = rejected("time_s,T,E_X0C\n0,,2\n");
  CHECK(e.line == 2);
  CHECK(e.column == 2);
  CHECK(e.reason == "empty cell: only measured-error (E_) columns may be empty");
  CHECK(rejected("time_s,T,E_X0C\n,1,2\n").column_name == "time_s");
}

TEST_CASE("scenario CSV: a missing file names the path") {
  try {
    alc::scenarios::read_scenario_csv("/nonexistent/dir/x.csv");
    FAIL("no error");
  } catch (const ScenarioCsvError& e) {
    CHECK(std::string(e.what()) == "/nonexistent/dir/x.csv: cannot open file for reading");
  }
}

TEST_CASE("scenario CSV: a failed write leaves an existing file untouched") {
  const auto dir = std::filesystem::temp_directory_path() / "alc_csv_ro_test";
  std::filesystem::create_directories(dir);
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
  std::filesystem::remove_all(dir);
}
