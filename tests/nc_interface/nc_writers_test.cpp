// NC numbers, dialect writers against reviewed reference text, JSON lines, safety limits,
// machine config, the replay entry point, transports and the `alc nc` command.
#include <catch2/catch.hpp>

#include "common/utf8.hpp"

#include <set>
#include <thread>

#include <algorithm>
#include <arpa/inet.h>
#include <array>
#include <cmath>
#include <cstdlib>
#include <netinet/in.h>
#include <random>
#include <sys/socket.h>
#include <sys/wait.h>
#include <sstream>
#include <unistd.h>

#include "nc_interface/dialects.hpp"
#include "nc_interface/jsonl.hpp"
#include "nc_interface/machine_config.hpp"
#include "nc_interface/nc_number.hpp"
#include "nc_interface/recorder.hpp"
#include "nc_interface/safety.hpp"
#include "nc_interface/transports.hpp"
#include "../cli_support.hpp"
#include "nc_test_support.hpp"

using namespace alc::nc;
using alc::nc::test::reference_commands;
using Catch::Matchers::Contains;
using Catch::Matchers::StartsWith;
using Catch::Matchers::WithinAbs;

namespace {
constexpr double kExact = 0.0;  // [mm] values that must round-trip bit for bit
const std::filesystem::path kReferenceDir = std::filesystem::path(ALC_SOURCE_DIR) / "tests/nc_interface/reference";

using alc::nc::test::offsets;

}  // namespace

TEST_CASE("nc number: fixed point, four decimals, no exponent, no negative zero", "[nc][number]") {
  CHECK(format_nc_number(0.0) == "0.0000");
  CHECK(format_nc_number(-0.0) == "0.0000");
  CHECK(format_nc_number(-0.00004) == "0.0000");
  CHECK(format_nc_number(0.00004) == "0.0000");
  CHECK(format_nc_number(0.00005) == "0.0001");    // half away from zero
  CHECK(format_nc_number(-0.00005) == "-0.0001");
  CHECK(format_nc_number(0.00015) == "0.0002");
  CHECK(format_nc_number(1e-12) == "0.0000");
  CHECK(format_nc_number(-1e-12) == "0.0000");
  CHECK(format_nc_number(0.0123) == "0.0123");
  CHECK(format_nc_number(-12.34567) == "-12.3457");
  CHECK(format_nc_number(1e6) == "1000000.0000");
  CHECK(format_nc_number(123456.78904) == "123456.7890");
  CHECK(format_nc_number(0.0, SignStyle::Always) == "+0.0000");
  CHECK(format_nc_number(-0.00004, SignStyle::Always) == "+0.0000");
  CHECK(format_nc_number(0.5, SignStyle::Always) == "+0.5000");
  CHECK(format_nc_number(-0.5, SignStyle::Always) == "-0.5000");
  CHECK_THROWS_AS(format_nc_number(std::nan("")), std::domain_error);
  CHECK_THROWS_AS(format_nc_number(HUGE_VAL), std::domain_error);
  CHECK_THROWS_WITH(format_nc_number(2e6), Contains("out of range"));
  // No value in a sweep prints an exponent or "-0.0000".
  for (double v = -2.0; v <= 2.0; v += 0.0000731) {
    const std::string s = format_nc_number(v);
    REQUIRE(s.find_first_of("eE") == std::string::npos);
    REQUIRE(s != "-0.0000");
    REQUIRE_THAT(std::stod(s), WithinAbs(v, 0.00005 + 1e-12));
  }
}

TEST_CASE("dialects: output for the fixed command set equals the reviewed reference text", "[nc][dialect]") {
  const bool update = std::getenv("ALC_UPDATE_REFERENCE") != nullptr;
  for (Dialect d : {Dialect::LinuxCNC, Dialect::Fanuc, Dialect::Sinumerik, Dialect::Heidenhain}) {
    const std::string text = write_program(d, reference_commands());
    const auto path = kReferenceDir / (std::string(dialect_name(d)) + ".txt");
    if (update) alc::nc::test::write_text(path, text);
    INFO("dialect " << dialect_name(d) << ", reference " << path);
    REQUIRE(text == alc::nc::test::read_text(path));
  }
}

TEST_CASE("dialects: names, options and bad commands", "[nc][dialect]") {
  CHECK(parse_dialect("fanuc") == Dialect::Fanuc);
  CHECK_FALSE(parse_dialect("Fanuc").has_value());
  CHECK_FALSE(parse_dialect("linuxcnc; rm").has_value());
  DialectOptions o;
  o.fanuc_interval_variable = 100;  // volatile local variable: refused
  CHECK_THAT(validate(o), Contains("fanuc_interval_variable") && Contains("100"));
  o = {};
  o.heidenhain_program_name = "A B";
  CHECK_THAT(validate(o), Contains("heidenhain_program_name"));
  o = {};
  o.linuxcnc_interval_parameter = 5221;  // would overwrite the G54 X offset
  CHECK_THAT(validate(o), Contains("5221"));
  CHECK_THROWS_WITH(write_program(Dialect::LinuxCNC, {}, o), Contains("linuxcnc_interval_parameter"));
  AxisOffsets bad = offsets(0, 0, 0, 0, 0);
  bad.x_mm = std::nan("");
  CHECK_THROWS_WITH(write_program(Dialect::Fanuc, {ProbeInterval{1.0, {}}, bad}), Contains("command 2") && Contains("x_mm"));
  bad = offsets(0, 0, 0, 0, 0, 7);
  CHECK_THROWS_WITH(write_program(Dialect::Sinumerik, {bad}), Contains("work_offset"));
  CHECK_THROWS_WITH(write_program(Dialect::Heidenhain, {ProbeInterval{0.0, {}}}), Contains("minutes"));
  CHECK_THROWS_WITH(write_program(Dialect::Heidenhain, {ProbeInterval{0.00001, {}}}), Contains("0.0001"));
}

TEST_CASE("dialects: LinuxCNC and Fanuc write base + compensation, Sinumerik and Heidenhain compensation only",
          "[nc][dialect]") {
  DialectOptions o;
  o.base[0] = {100.0, -50.0, 20.0, 0.0, 0.0, 90.0};
  const std::vector<NcCommand> c{offsets(0.01, 0.02, -0.03, 0.0, 0.001)};
  CHECK_THAT(write_program(Dialect::LinuxCNC, c, o), Contains("G10 L2 P1 X100.0100 Y-49.9800 Z19.9700 A0.0000 C90.0010"));
  CHECK_THAT(write_program(Dialect::Fanuc, c, o), Contains("G90 G10 L2 P1 X100.0100 Y-49.9800 Z19.9700 A0.0000 C90.0010"));
  CHECK_THAT(write_program(Dialect::Sinumerik, c, o), Contains("$P_UIFR[1,X,FI]=0.0100"));
  CHECK_THAT(write_program(Dialect::Heidenhain, c, o), Contains("CYCL DEF 7.1 X+0.0100"));
  // A program written for the twin (alc replay without --machine) says so below its header, where a
  // base is written; no note, no line.
  CHECK(write_program(Dialect::LinuxCNC, c, o).find("\n(") == std::string::npos);
  o.base_note = "for the built-in twin, whose work offsets are 0";
  CHECK_THAT(write_program(Dialect::LinuxCNC, c, o), Contains("[min])\n(for the built-in twin, whose work offsets are 0)\nG21"));
  CHECK_THAT(write_program(Dialect::Fanuc, c, o),
             Contains("(ALC THERMAL COMPENSATION)\n(FOR THE BUILT-IN TWIN, WHOSE WORK OFFSETS ARE 0)\nG21\n"));
  CHECK(write_program(Dialect::Sinumerik, c, o).find("twin") == std::string::npos);  // adds to the work offset
}

TEST_CASE("dialects: Sinumerik selects settable frames 5 and 6 with G505 and G506, never G58 or G59", "[nc][dialect]") {
  // G58/G59 are Sinumerik's programmable axial offsets; settable frames $P_UIFR[5…99] are G505…G599.
  const char* const selection[] = {"G54", "G55", "G56", "G57", "G505", "G506"};
  for (int wo = 1; wo <= 6; ++wo) {
    INFO("work offset " << wo);
    const std::string text = write_program(Dialect::Sinumerik, {offsets(0.001, 0, 0, 0, 0, wo)});
    std::istringstream in(text);
    std::vector<std::string> lines;
    for (std::string l; std::getline(in, l);) lines.push_back(l);
    REQUIRE(lines.size() == 8);  // comment, X Y Z A C, selection, M30
    CHECK(lines[1] == "$P_UIFR[" + std::to_string(wo) + ",X,FI]=0.0010");
    CHECK(lines[6] == selection[wo - 1]);
    CHECK(text.find("G58") == std::string::npos);
    CHECK(text.find("G59") == std::string::npos);
  }
}

TEST_CASE("dialects: Fanuc selects metric input in a block of its own before the first G10", "[nc][dialect]") {
  const std::string text = write_program(Dialect::Fanuc, {ProbeInterval{1.0, {}}, offsets(0.01, 0, 0, 0, 0)});
  std::istringstream in(text);
  std::vector<std::string> lines;
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  REQUIRE(lines.size() >= 5);
  CHECK(lines[0] == "%");
  CHECK(lines[2] == "G21");  // right after the program number, before any coordinate system is set
  CHECK(std::count(lines.begin(), lines.end(), "G21") == 1);
  CHECK(lines[4] == "G90 G10 L2 P1 X0.0100 Y0.0000 Z0.0000 A0.0000 C0.0000");
  // Each spooled single-command program carries it too.
  CHECK_THAT(write_program(Dialect::Fanuc, {offsets(0.01, 0, 0, 0, 0)}), Contains("\nG21\nG90 G10 L2 P1"));
}

TEST_CASE("jsonl: write then read gives the same commands", "[nc][jsonl]") {
  std::ostringstream out;
  write_commands_jsonl(out, reference_commands());
  std::istringstream in(out.str());
  REQUIRE(read_commands_jsonl(in, "mem") == reference_commands());
  CHECK(to_json_line(offsets(0.1, 0.2, 0.3, 0.4, 0.5, 3)) ==
        R"({"type":"axis_offsets","x_mm":0.1,"y_mm":0.2,"z_mm":0.3,"a_deg":0.4,"c_deg":0.5,"work_offset":"G56"})");
  CHECK(to_json_line(ProbeInterval{std::nullopt, 60.0}) == R"({"type":"probe_interval","minutes":null,"time_s":60.0})");
}

TEST_CASE("jsonl: the non-compensable part rides along, reads back, and never reaches the NC", "[nc][jsonl]") {
  AxisOffsets o = offsets(0.01, -0.002, 0.003, 0.0004, -0.0005, 2);
  o.non_compensable_um_per_m = 7.25;
  o.time_s = 120.0;
  CHECK(to_json_line(o) == R"({"type":"axis_offsets","x_mm":0.01,"y_mm":-0.002,"z_mm":0.003,"a_deg":0.0004,)"
                           R"("c_deg":-0.0005,"work_offset":"G55","non_compensable_um_per_m":7.25,"time_s":120.0})");
  std::istringstream in(to_json_line(o) + "\n");
  const auto back = read_commands_jsonl(in, "mem");
  REQUIRE(back.size() == 1);
  CHECK(std::get<AxisOffsets>(back[0]) == o);
  AxisOffsets plain = o;
  plain.non_compensable_um_per_m.reset();
  for (Dialect d : {Dialect::LinuxCNC, Dialect::Fanuc, Dialect::Sinumerik, Dialect::Heidenhain})
    CHECK(write_program(d, {o}) == write_program(d, {plain}));
  std::istringstream bad(R"({"type":"axis_offsets","x_mm":0,"y_mm":0,"z_mm":0,"a_deg":0,"c_deg":0,"non_compensable_um_per_m":-1})");
  try {
    read_commands_jsonl(bad, "bad.jsonl");
    FAIL("a negative non_compensable_um_per_m was accepted");
  } catch (const JsonlError& e) {
    CHECK(e.field == "non_compensable_um_per_m");
    CHECK(e.value == "-1");
  }
}

TEST_CASE("jsonl: bad input names line, field and value", "[nc][jsonl]") {
  const auto fails = [](const std::string& text) -> JsonlError {
    std::istringstream in(text);
    try {
      read_commands_jsonl(in, "cmds.jsonl");
    } catch (const JsonlError& e) {
      return e;
    }
    FAIL("no error for: " << text);
    return JsonlError("", 0, "", "", "");
  };
  const std::string ok = R"({"type":"probe_interval","minutes":5})";
  auto e = fails(ok + "\n\n" + R"({"type":"axis_offsets","x_mm":"0.1","y_mm":0,"z_mm":0,"a_deg":0,"c_deg":0})");
  CHECK(e.line == 3);
  CHECK(e.field == "x_mm");
  CHECK(e.value == "\"0.1\"");
  CHECK_THAT(std::string(e.what()), StartsWith("cmds.jsonl:3: not a number (field 'x_mm'): value '\"0.1\"'"));
  e = fails(R"({"type":"axis_offsets","x_mm":0,"y_mm":0,"z_mm":0,"a_deg":0,"c_deg":0,"work_offset":"G54; M30"})");
  CHECK(e.field == "work_offset");
  CHECK(e.value == "\"G54; M30\"");
  e = fails(R"({"type":"axis_offsets","x_mm":0,"y_mm":0,"z_mm":0,"a_deg":0,"c_deg":0,"xmm":1})");
  CHECK(e.field == "xmm");
  CHECK(e.reason == "unknown field");
  e = fails(R"({"type":"axis_offsets","x_mm":0,"y_mm":0,"z_mm":0,"c_deg":0})");
  CHECK(e.field == "a_deg");
  e = fails(R"({"type":"axis_offsets","x_mm":0,"y_mm":0,"z_mm":0,"a_deg":0,"b_deg":0,"c_deg":0})");
  CHECK(e.field == "b_deg");
  e = fails(R"({"type":"axis_offsets","y_mm":0,"z_mm":0,"a_deg":0,"c_deg":0})");
  CHECK(e.field == "x_mm");
  CHECK(e.reason == "missing field");
  // No value, so no "value ''" (before: "missing field (field 'x_mm'): value ''").
  CHECK(std::string(e.what()) == "cmds.jsonl:1: missing field (field 'x_mm')");
  e = fails(R"({"type":"probe_interval","minutes":-5})");
  CHECK(e.field == "minutes");
  CHECK(e.value == "-5");
  CHECK_THAT(e.what(), Catch::Contains("got -5 (field 'minutes')"));  // not -5.000000
  e = fails(R"({"type":"probe_interval","minutes":1e400})");
  CHECK(e.line == 1);
  // A long value is cut between two UTF-8 characters, its control characters shown as \xNN (before: cut
  // at byte 77, inside a two-byte character, and a message quoting outside text could end mid-character).
  e = fails(R"({"type":"axis_offsets","x_mm":0,"y_mm":0,"z_mm":0,"a_deg":0,"c_deg":0,"work_offset":")" +
            std::string(75, 'x') + "\u00e9\u00e9" + std::string(10, 'y') + "\"}");
  CHECK(e.field == "work_offset");
  CHECK(e.value.size() <= 80 + std::string("…").size());
  CHECK(e.value.rfind("…") == e.value.size() - std::string("…").size());
  CHECK(alc::common::invalid_utf8_at(e.value) == std::string::npos);
  e = fails(R"({"type":"spindle","rpm":5})");
  CHECK(e.field == "type");
  e = fails("not json");
  CHECK_THAT(e.reason, StartsWith("not JSON: at column 2: "));  // "n" could start null, "o" cannot
  CHECK(e.reason.find("json.exception") == std::string::npos);
  e = fails(R"({"type":"probe_interval","minutes":1e400})");
  CHECK(e.reason == "not JSON: number overflow parsing '1e400'");
  // A field given twice is refused, not read as the last of them.
  e = fails(R"({"type":"axis_offsets","x_mm":0.001,"y_mm":0,"z_mm":0,"a_deg":0,"c_deg":0,"x_mm":0.002})");
  CHECK(e.field == "x_mm");
  CHECK(e.reason == "duplicate field");
  CHECK(std::string(e.what()) == "cmds.jsonl:1: duplicate field (field 'x_mm')");  // before: …: value ''
  e = fails("[1,2]");
  CHECK(e.reason == "not a JSON object");
  e = fails(R"({"type":"axis_offsets","x_mm":2e6,"y_mm":0,"z_mm":0,"a_deg":0,"c_deg":0})");
  CHECK(e.field == "x_mm");
}

TEST_CASE("safety: within limits is accepted unchanged", "[nc][safety]") {
  SafetyGate gate;
  const auto d = gate.submit(offsets(0.005, -0.005, 0.0, 0.0005, -0.0005));
  CHECK(d.verdict == SafetyVerdict::Accepted);
  REQUIRE(d.to_send.size() == 1);
  CHECK(d.to_send[0] == d.requested);
  // Exactly at the step limit is allowed.
  const auto at = gate.submit(offsets(0.015, -0.005, 0.0, 0.0005, -0.0005));
  CHECK(at.verdict == SafetyVerdict::Accepted);
}

TEST_CASE("safety: max_offset is refused, naming axis, value and limit", "[nc][safety]") {
  SafetyLimits limits;
  limits.on_step_violation = StepAction::Split;  // even when splitting: an offset limit is final
  SafetyGate gate(limits);
  const auto d = gate.submit(offsets(0.0, 0.0, 0.0, 0.0, 0.0125));
  CHECK(d.verdict == SafetyVerdict::Refused);
  CHECK(d.to_send.empty());
  REQUIRE(d.violations.size() == 2);
  CHECK(d.violations[0].axis == 'C');
  CHECK(d.violations[0].limit == "max_offset");
  CHECK_THAT(d.message, Contains("axis C offset 0.0125 deg exceeds max_offset 0.0100 deg"));
  // A refused command does not move the gate's state: after an accepted command, a refused one
  // (max_offset, then max_step) leaves exactly the accepted offsets in force.
  const AxisOffsets accepted = offsets(0.004, -0.003, 0.002, 0.0006, 0.0007);
  REQUIRE(gate.submit(accepted).verdict == SafetyVerdict::Accepted);
  REQUIRE(gate.current(1) == accepted);
  CHECK(gate.submit(offsets(0.004, -0.003, 0.002, 0.0006, 0.0125)).verdict == SafetyVerdict::Refused);
  CHECK(gate.current(1) == accepted);
  SafetyLimits refuse_steps;
  SafetyGate strict(refuse_steps);
  REQUIRE(strict.submit(accepted).verdict == SafetyVerdict::Accepted);
  CHECK(strict.submit(offsets(0.05, -0.003, 0.002, 0.0006, 0.0007)).verdict == SafetyVerdict::Refused);
  CHECK(strict.current(1) == accepted);
  CHECK(strict.current(2) == offsets(0, 0, 0, 0, 0, 2));  // other work offsets untouched
}

TEST_CASE("safety: the gate can start from the offsets in force", "[nc][safety]") {
  SafetyGate gate;
  const AxisOffsets in_force = offsets(0.095, 0, 0, 0, 0.0095, 3);
  gate.set_in_force(in_force);
  CHECK(gate.current(3) == in_force);
  CHECK(gate.current(1) == offsets(0, 0, 0, 0, 0, 1));
  // 0.1 mm is one step of 0.005 mm from what is in force, but ten max_steps from zero.
  CHECK(gate.submit(offsets(0.1, 0, 0, 0, 0.01, 3)).verdict == SafetyVerdict::Accepted);
  CHECK(gate.submit(offsets(0.1, 0, 0, 0, 0.01, 1)).verdict == SafetyVerdict::Refused);
  // And back to zero at once is a step too large.
  SafetyGate back;
  back.set_in_force(in_force);
  const auto d = back.submit(offsets(0, 0, 0, 0, 0, 3));
  CHECK(d.verdict == SafetyVerdict::Refused);
  CHECK_THAT(d.message, Contains("axis X change -0.0950 mm exceeds max_step 0.0100 mm"));
  CommandRecorder recorder;
  AxisOffsets bad = in_force;
  bad.x_mm = std::nan("");
  CHECK_THROWS_WITH(recorder.set_in_force(bad), Contains("offsets in force") && Contains("x_mm"));
  recorder.set_in_force(in_force);
  CHECK(recorder.current(3) == in_force);
}

TEST_CASE("safety: max_step refuses or splits, by configuration", "[nc][safety]") {
  SafetyLimits limits;
  const AxisOffsets big = offsets(0.035, -0.01, 0.0, 0.0, 0.0);
  SECTION("refuse") {
    const auto d = check_offsets(limits, offsets(0, 0, 0, 0, 0), big);
    CHECK(d.verdict == SafetyVerdict::Refused);
    CHECK_THAT(d.message, Contains("axis X change 0.0350 mm exceeds max_step 0.0100 mm"));
  }
  SECTION("split into equal steps within the limit, ending exactly at the request") {
    limits.on_step_violation = StepAction::Split;
    SafetyGate gate(limits);
    const auto d = gate.submit(big);
    CHECK(d.verdict == SafetyVerdict::Split);
    REQUIRE(d.to_send.size() == 4);
    double previous = 0.0;
    for (const AxisOffsets& s : d.to_send) {
      CHECK(std::abs(s.x_mm - previous) <= limits.max_step.x_mm + 1e-12);
      previous = s.x_mm;
    }
    CHECK(d.to_send[0].x_mm == 0.0087);  // steps are multiples of the NC resolution, as printed
    CHECK(d.to_send.back() == big);
    CHECK(gate.current(1) == big);
    CHECK_THAT(d.message, StartsWith("split into 4 steps"));
  }
  SECTION("split needing too many steps is refused") {
    limits.on_step_violation = StepAction::Split;
    limits.max_split_steps = 3;
    const auto d = check_offsets(limits, offsets(0, 0, 0, 0, 0), big);
    CHECK(d.verdict == SafetyVerdict::Refused);
    CHECK_THAT(d.message, Contains("would need 4 steps"));
  }
  SECTION("no split starts from offsets in force beyond max_offset: its steps would be beyond it too") {
    limits.on_step_violation = StepAction::Split;
    limits.max_split_steps = 1000;
    // In force 0.15 mm (beyond 0.1), asked 0.09: before, 0.14, 0.13, 0.12, 0.11 mm were sent first.
    const auto d = check_offsets(limits, offsets(0.15, 0, 0, 0, 0), offsets(0.09, 0, 0, 0, 0));
    CHECK(d.verdict == SafetyVerdict::Refused);
    CHECK(d.to_send.empty());
    CHECK_THAT(d.message, Contains("the offset in force on axis X, 0.1500, is beyond max_offset 0.1000"));
    // Within max_offset it splits as before.
    CHECK(check_offsets(limits, offsets(0.1, 0, 0, 0, 0), offsets(0.05, 0, 0, 0, 0)).verdict == SafetyVerdict::Split);
  }
  SECTION("steps count from the offsets in force, per work offset") {
    SafetyGate gate(limits);
    CHECK(gate.submit(offsets(0.01, 0, 0, 0, 0)).verdict == SafetyVerdict::Accepted);
    CHECK(gate.submit(offsets(0.02, 0, 0, 0, 0)).verdict == SafetyVerdict::Accepted);
    CHECK(gate.submit(offsets(0.02, 0, 0, 0, 0, 2)).verdict == SafetyVerdict::Refused);  // G55 starts at 0
  }
}

TEST_CASE("safety: a rotary axis left out of a line keeps its value on the control (issue 13 item 1)",
          "[nc][safety]") {
  // a_deg -0.001, then a line with b_deg and no a_deg (no A word is written: the control keeps
  // -0.001), then a_deg +0.001: a step of 0.002 deg on A against max_step 0.001.
  AxisOffsets b_only = offsets(0, 0, 0, 0, 0);
  b_only.a_deg.reset();
  b_only.b_deg = 0.0005;
  const std::vector<NcCommand> stream{offsets(0, 0, 0, -0.001, 0), b_only, offsets(0, 0, 0, 0.001, 0)};
  for (const Dialect dialect : {Dialect::LinuxCNC, Dialect::Fanuc, Dialect::Sinumerik, Dialect::Heidenhain}) {
    INFO(dialect_name(dialect));
    CommandRecorder recorder = recorder_for(dialect);
    CHECK(recorder.record(stream[0]).verdict == SafetyVerdict::Accepted);
    CHECK(recorder.record(stream[1]).verdict == SafetyVerdict::Accepted);
    CHECK(recorder.current(1).a_deg == -0.001);  // held, not 0
    const SafetyDecision d = recorder.record(stream[2]);
    CHECK(d.verdict == SafetyVerdict::Refused);
    CHECK_THAT(d.message, Contains("axis A change 0.0020 deg exceeds max_step 0.0010 deg"));
  }
  // Split: the steps start from the held value, and a left-out axis stays left out.
  SafetyLimits split;
  split.on_step_violation = StepAction::Split;
  SafetyGate gate(split);
  REQUIRE(gate.submit(std::get<AxisOffsets>(stream[0])).verdict == SafetyVerdict::Accepted);
  REQUIRE(gate.submit(b_only).verdict == SafetyVerdict::Accepted);
  const SafetyDecision s = gate.submit(std::get<AxisOffsets>(stream[2]));
  REQUIRE(s.verdict == SafetyVerdict::Split);
  REQUIRE(s.to_send.size() == 2);
  CHECK(s.to_send[0].a_deg == 0.0);
  CHECK(!s.to_send[0].b_deg);
}

TEST_CASE("held_after: what the NC holds after a line is each value as printed, a left-out axis as it was",
          "[nc][safety]") {
  // The supervisor keeps what the NC holds with it after each delivery (docs/supervisor.md, "The NC").
  const AxisOffsets first = held_after(offsets(0, 0, 0, 0, 0), offsets(0.00015, -0.01827677, 0.00004, -0.001, 0.123456));
  CHECK(first.x_mm == 0.0002);
  CHECK(first.y_mm == -0.0183);
  CHECK(first.z_mm == 0.0);
  CHECK(first.a_deg == -0.001);
  CHECK(first.c_deg == 0.1235);
  AxisOffsets b_only = offsets(0, 0, 0, 0, 0);
  b_only.a_deg.reset();
  b_only.b_deg = 0.00049;
  const AxisOffsets second = held_after(first, b_only);
  CHECK(second.a_deg == -0.001);  // no A word: the control keeps it
  CHECK(second.b_deg == 0.0005);
  CHECK(second.x_mm == 0.0);
}

TEST_CASE("safety: the value is judged as printed at the NC resolution (issue 13 item 2)", "[nc][safety]") {
  SafetyLimits limits;
  limits.max_offset.x_mm = 0.00015;  // not a multiple of the resolution
  SafetyGate gate(limits);
  const SafetyDecision d = gate.submit(offsets(0.00015, 0, 0, 0, 0));  // written X0.0002
  CHECK(d.verdict == SafetyVerdict::Refused);
  CHECK_THAT(d.message, Contains("axis X offset 0.0002 mm exceeds max_offset 0.00015 mm"));
  CHECK(gate.submit(offsets(0.00014, 0, 0, 0, 0)).verdict == SafetyVerdict::Accepted);  // written X0.0001
  // A step that reads within max_step but prints beyond it: 0.00014 -> 0.00029 is 0.00015, printed
  // 0.0001 -> 0.0003 = 0.0002 against max_step 0.00015.
  SafetyLimits steps;
  steps.max_step.y_mm = 0.00015;
  SafetyGate step_gate(steps);
  REQUIRE(step_gate.submit(offsets(0, 0.00014, 0, 0, 0)).verdict == SafetyVerdict::Accepted);
  CHECK(step_gate.submit(offsets(0, 0.00029, 0, 0, 0)).verdict == SafetyVerdict::Refused);
  // Split steps are printed values each within max_step (0.00015 allows 1 tick per step).
  steps.on_step_violation = StepAction::Split;
  const SafetyDecision split = check_offsets(steps, offsets(0, 0, 0, 0, 0), offsets(0, 0.0003, 0, 0, 0));
  REQUIRE(split.verdict == SafetyVerdict::Split);
  REQUIRE(split.to_send.size() == 3);
  CHECK(split.to_send[0].y_mm == 0.0001);
  CHECK(split.to_send[1].y_mm == 0.0002);
  CHECK(split.to_send[2].y_mm == 0.0003);
  // A max_step below the resolution cannot be split into anything.
  steps.max_step.y_mm = 0.00005;
  CHECK_THAT(check_offsets(steps, offsets(0, 0, 0, 0, 0), offsets(0, 0.0001, 0, 0, 0)).message,
             Contains("below the NC resolution"));
  // With a base offset (G10 L2 writes base + compensation), the compensation is written as judged.
  DialectOptions options;
  options.base[0].x_mm = 10.00005;
  const std::string program = write_program(Dialect::LinuxCNC, {offsets(0.00015, 0, 0, 0, 0)}, options);
  CHECK_THAT(program, Contains("X10.0003 "));  // 10.0001 (base as printed) + 0.0002
}

TEST_CASE("safety: one offset register (heidenhain) judges every work offset against the last command",
          "[nc][safety]") {
  CHECK(offset_registers(Dialect::Heidenhain) == OffsetRegisters::Single);
  CHECK(offset_registers(Dialect::LinuxCNC) == OffsetRegisters::PerWorkOffset);
  CHECK(offset_registers(Dialect::Fanuc) == OffsetRegisters::PerWorkOffset);
  CHECK(offset_registers(Dialect::Sinumerik) == OffsetRegisters::PerWorkOffset);
  // Alternating G54 / G55, each work offset constant: per work offset every step is small, but on
  // one register (Heidenhain's datum shift) X would jump by 0.018 mm each time.
  const std::vector<AxisOffsets> alternating{offsets(0.009, 0, 0, 0, 0, 1), offsets(-0.009, 0, 0, 0, 0, 2),
                                             offsets(0.009, 0, 0, 0, 0, 1), offsets(-0.009, 0, 0, 0, 0, 2)};
  SafetyGate per_offset;
  for (const AxisOffsets& o : alternating) CHECK(per_offset.submit(o).verdict == SafetyVerdict::Accepted);
  SafetyGate single({}, OffsetRegisters::Single);
  CHECK(single.submit(alternating[0]).verdict == SafetyVerdict::Accepted);
  const SafetyDecision d = single.submit(alternating[1]);
  CHECK(d.verdict == SafetyVerdict::Refused);
  CHECK_THAT(d.message, Contains("axis X change -0.0180 mm exceeds max_step 0.0100 mm") &&
                            Contains("judged against the offsets of G54 (one offset register for every work offset)"));
  CHECK(single.current(2) == alternating[0]);  // the one register, whichever work offset is asked
  CHECK(single.current(1) == alternating[0]);
  // A change within max_step from the other work offset's command is fine …
  CHECK(single.submit(offsets(0.0, 0, 0, 0, 0, 2)).verdict == SafetyVerdict::Accepted);
  CHECK(single.current(1) == offsets(0.0, 0, 0, 0, 0, 2));
  // … and splitting steps from it, whatever the work offset of the request.
  SafetyLimits split;
  split.on_step_violation = StepAction::Split;
  SafetyGate split_gate(split, OffsetRegisters::Single);
  REQUIRE(split_gate.submit(alternating[0]).verdict == SafetyVerdict::Accepted);
  const SafetyDecision s = split_gate.submit(alternating[1]);
  REQUIRE(s.verdict == SafetyVerdict::Split);
  REQUIRE(s.to_send.size() == 2);
  CHECK_THAT(s.to_send[0].x_mm, WithinAbs(0.0, 1e-15));
  CHECK(s.to_send[0].work_offset == 2);
  CHECK(s.to_send[1] == alternating[1]);
  // One register holds one set of offsets: in force for two work offsets is a contradiction.
  SafetyGate in_force({}, OffsetRegisters::Single);
  in_force.set_in_force(offsets(0.05, 0, 0, 0, 0, 1));
  in_force.set_in_force(offsets(0.06, 0, 0, 0, 0, 1));  // the same work offset again: replaces it
  CHECK_THROWS_WITH(in_force.set_in_force(offsets(0.05, 0, 0, 0, 0, 3)), Contains("given for G54 and G56"));
  CHECK(in_force.submit(offsets(0.0, 0, 0, 0, 0, 3)).verdict == SafetyVerdict::Refused);  // 0.06 -> 0 on G56
  CHECK(in_force.submit(offsets(0.055, 0, 0, 0, 0, 3)).verdict == SafetyVerdict::Accepted);
}

TEST_CASE("recorder_for: the recorder's gate keeps the registers of the dialect", "[nc][safety]") {
  // The same alternating G54 / G55 commands: refused on heidenhain's one register, accepted on the
  // per-work-offset registers of the other dialects.
  const std::vector<NcCommand> alternating{offsets(0.009, 0, 0, 0, 0, 1), offsets(-0.009, 0, 0, 0, 0, 2)};
  for (const Dialect dialect : {Dialect::LinuxCNC, Dialect::Fanuc, Dialect::Sinumerik, Dialect::Heidenhain}) {
    INFO(dialect_name(dialect));
    CommandRecorder recorder = recorder_for(dialect);
    CHECK(recorder.record(alternating[0]).verdict == SafetyVerdict::Accepted);
    const SafetyDecision d = recorder.record(alternating[1]);
    CHECK(d.verdict == (dialect == Dialect::Heidenhain ? SafetyVerdict::Refused : SafetyVerdict::Accepted));
  }
  SafetyLimits split;
  split.on_step_violation = StepAction::Split;
  CommandRecorder recorder = recorder_for(Dialect::Heidenhain, split);
  recorder.record(alternating[0]);
  CHECK(recorder.record(alternating[1]).verdict == SafetyVerdict::Split);  // the limits are the given ones
  SafetyLimits bad;
  bad.max_step.x_mm = -1.0;
  CHECK_THROWS_AS(recorder_for(Dialect::Fanuc, bad), std::invalid_argument);
}

TEST_CASE("safety: the heidenhain datum shift never moves by more than max_step, whatever the work offsets",
          "[nc][safety]") {
  // A seeded random walk over all six work offsets, each command within max_step of the last command
  // of its own work offset (what a per-work-offset gate lets through): every cycle 7 the Heidenhain
  // program ends up with is within max_step of the one before.
  std::mt19937_64 rng(20240605);
  std::uniform_int_distribution<int> pick(1, 6);
  std::uniform_real_distribution<double> change(-0.0095, 0.0095);
  std::array<double, 7> x{};  // per work offset [mm]
  std::vector<NcCommand> commands;
  for (int i = 0; i < 300; ++i) {
    const int w = pick(rng);
    const auto k = static_cast<std::size_t>(w);
    x[k] = std::clamp(x[k] + change(rng), -0.095, 0.095);
    commands.push_back(offsets(x[k], 0, 0, 0, 0, w));
  }
  const auto dir = alc::nc::test::fresh_dir("heidenhain_walk");
  const NcOutputSummary linuxcnc = write_replay_nc_output(dir / "linuxcnc", Dialect::LinuxCNC, commands);
  CHECK(linuxcnc.refused == 0);  // per work offset, nothing to refuse
  const NcOutputSummary heidenhain = write_replay_nc_output(dir / "heidenhain", Dialect::Heidenhain, commands);
  CHECK(heidenhain.refused > 50);  // jumps between work offsets: refused
  CHECK(heidenhain.sent == commands.size() - heidenhain.refused);
  // Read the X of every cycle 7 back from the program text.
  std::istringstream program(alc::nc::test::read_text(heidenhain.program_file));
  std::vector<double> shifts;
  for (std::string line; std::getline(program, line);)
    if (const auto at = line.find("CYCL DEF 7.1 X"); at != std::string::npos) shifts.push_back(std::stod(line.substr(at + 14)));
  REQUIRE(shifts.size() == heidenhain.sent);
  double previous = 0.0, largest_jump = 0.0;
  for (const double shift : shifts) {
    largest_jump = std::max(largest_jump, std::abs(shift - previous));
    previous = shift;
  }
  CHECK(largest_jump <= 0.01 + 1e-4);  // max_step, plus the rounding of the written text
  CHECK(largest_jump > 0.009);         // (the walk does use the step)
  std::filesystem::remove_all(dir);
}

TEST_CASE("machine config: defaults, a full file, and errors naming file, key and value", "[nc][config]") {
  const MachineConfig d = parse_machine_config("", "empty.toml");
  CHECK(d.chain.tilt.name == 'A');
  CHECK(d.work_offset == 1);
  const MachineConfig c = parse_machine_config(R"(
[kinematics]
chain = "B-C"
table_pivot_mm = [0.0, 0.0, -120.5]
workpiece_point_mm = [50, 25, 10]
[nc]
work_offset = "G55"
fanuc_interval_variable = 600
[nc.base.G55]
x_mm = 250.0
[limits]
on_step_violation = "split"
max_split_steps = 5
[limits.max_offset]
x_mm = 0.2
[limits.max_step]
c_deg = 0.002
)",
                                               "m.toml");
  CHECK(c.chain.tilt.name == 'B');
  CHECK(c.chain.table.pivot_mm.z() == -120.5);
  CHECK(c.chain.workpiece_point_mm.y() == 25.0);
  CHECK(c.work_offset == 2);
  CHECK(c.nc.fanuc_interval_variable == 600);
  CHECK(c.nc.base[1].x_mm == 250.0);
  CHECK(c.limits.on_step_violation == StepAction::Split);
  CHECK(c.limits.max_split_steps == 5);
  CHECK(c.limits.max_offset.x_mm == 0.2);
  CHECK(c.limits.max_step.c_deg == 0.002);
  const auto error = [](const std::string& text) -> std::string {
    try {
      parse_machine_config(text, "m.toml");
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "no error";
  };
  CHECK(error("[limits.max_step]\nx_mm = -1") == "m.toml: key 'limits.max_step.x_mm': must be > 0: value '-1'");
  // A step below one tick of the NC: every step would be refused, the axis stuck at zero. Refused at load.
  CHECK_THAT(error("[limits.max_step]\nc_deg = 0.00005"),
             StartsWith("m.toml: key 'limits.max_step'") && Contains("axis C must be at least the NC resolution 0.0001"));
  // A value as typed, not toml++'s 17 digits (-0.10000000000000001).
  CHECK(error("[limits.max_offset]\nx_mm = -0.1") == "m.toml: key 'limits.max_offset.x_mm': must be > 0: value '-0.1'");
  // The rate limit's period: seconds of machine time per max_step.
  CHECK(parse_machine_config("[limits]\nstep_period_s = 600", "m.toml").limits.step_period_s == 600.0);
  CHECK(parse_machine_config("", "m.toml").limits.step_period_s == 60.0);
  CHECK(error("[limits]\nstep_period_s = 0") ==
        "m.toml: key 'limits.step_period_s': must be > 0 (seconds of machine time per max_step): value '0'");
  CHECK(error("[limits]\nstep_period_s = inf") == "m.toml: key 'limits.step_period_s': not a finite number: value 'inf'");
  CHECK(error("[limits]\non_step_violation = \"clamp\"") ==
        "m.toml: key 'limits.on_step_violation': must be \"refuse\" or \"split\": value '\"clamp\"'");
  CHECK(error("[nc]\nwork_offset = \"G54.1\"") == "m.toml: key 'nc.work_offset': must be one of G54 … G59: value '\"G54.1\"'");
  CHECK_THAT(error("[nc]\nfanuc_interval_variable = 33"), StartsWith("m.toml: key 'nc.fanuc_interval_variable'") && Contains("33"));
  CHECK_THAT(error("[kinematics]\ntilt_direction = [1, 0]"), StartsWith("m.toml: key 'kinematics.tilt_direction'"));
  // A key not in the file (table_direction is the default here) has no value to show: no "value ''".
  CHECK(error("[kinematics]\ntilt_direction = [0, 0, 1]") ==
        "m.toml: key 'kinematics.table_direction': tilt and table axis directions are parallel: [0, 0, 1] and [0, 0, 1]");
  // validate()'s finding named by the key it is about, with that key's value.
  CHECK_THAT(error("[kinematics]\ntilt_direction = [0, 0, 0]"),
             StartsWith("m.toml: key 'kinematics.tilt_direction'") && Contains("finite unit vector") && Contains("[0, 0, 0]"));
  CHECK_THAT(error("[kinematics]\ntable_pivot_mm = [0, 0, nan]"), StartsWith("m.toml: key 'kinematics.table_pivot_mm'"));
  CHECK_THAT(error("[kinematics]\nchian = \"A-C\""), StartsWith("m.toml: key 'kinematics.chian': unknown key"));
  // A TOML syntax error as the grid and the supervisor's config give it: file:line:column (before:
  // "m.toml: <description> (line 3, column 8)").
  CHECK_THAT(error("[limits]\nstep_period_s = 60\nx_mm = = 1\n"), StartsWith("m.toml:3:8: "));
  CHECK_THAT(error("[nc.base.G60]\nx_mm = 1"), StartsWith("m.toml: key 'nc.base.G60'"));
  // Bounded so that base + compensation always prints (before: 999999.999 + 0.005 failed at formatting,
  // after the gate, with a spool half written; max_offset 1e300 was taken).
  // Named by its key, line and value (before: key 'nc.base' and the whole [nc.base] table as the value).
  CHECK(error("[nc.base.G54]\nx_mm = 999999.999") ==
        "m.toml: key 'nc.base.G54.x_mm' (line 2): a base offset must be finite and within ±1e5 (with the "
        "compensation it must print within ±1e6): value '999999.999'");
  CHECK_THAT(error("[nc.base.G54]\nx_mm = 1.0\n[nc.base.G55]\nz_mm = -4200000.0\n"),
             StartsWith("m.toml: key 'nc.base.G55.z_mm' (line 4): ") && Contains("value '-4200000'") &&
                 !Contains("[G54]"));
  CHECK_THAT(error("[limits.max_offset]\nx_mm = 1e300"), Contains("max_offset of axis X must be at most 1000"));
  CHECK_THAT(error("[limits.max_step]\nx_mm = 1e300"), Contains("max_step of axis X must be at most 1000"));
  CHECK_NOTHROW(parse_machine_config("[nc.base.G54]\nx_mm = -99999.9999\n[limits.max_offset]\nx_mm = 1000\n", "m.toml"));
  CHECK(error("[nc\n") == "m.toml:1:4: Error while parsing table header: expected ']', saw '\\n'");  // toml++'s words
  CHECK_THAT(error("[nc]\nwork_offset = 54"), Contains("not a string") && Contains("'54'"));
}

TEST_CASE("replay entry point: commands.jsonl, program and safety record", "[nc][recorder]") {
  const auto dir = alc::nc::test::fresh_dir("recorder");
  SafetyLimits limits;
  limits.on_step_violation = StepAction::Split;
  AxisOffsets first = offsets(0.02, 0, 0, 0, 0);
  first.non_compensable_um_per_m = 3.5;
  AxisOffsets refused = offsets(0.5, 0, 0, 0, 0);  // second offset: refused
  refused.non_compensable_um_per_m = 4.25;
  const std::vector<NcCommand> commands{first, ProbeInterval{10.0, {}}, refused};
  const NcOutputSummary s = write_replay_nc_output(dir / "nc", Dialect::LinuxCNC, commands, {}, limits);
  CHECK(s.requested == 3);
  CHECK(s.max_non_compensable_um_per_m == 4.25);  // of every command given, refused ones included
  CHECK(s.sent == 3);  // 2 steps + the interval
  CHECK(s.split == 1);
  CHECK(s.refused == 1);
  std::istringstream jsonl(alc::nc::test::read_text(s.commands_file));
  const auto sent = read_commands_jsonl(jsonl, s.commands_file.string());
  REQUIRE(sent.size() == 3);
  CHECK(std::get<AxisOffsets>(sent[1]).x_mm == 0.02);
  // Each split step keeps the non-compensable part of the request it belongs to.
  CHECK(std::get<AxisOffsets>(sent[0]).non_compensable_um_per_m == 3.5);
  CHECK(std::get<AxisOffsets>(sent[1]).non_compensable_um_per_m == 3.5);
  CHECK(s.program_file.filename() == "program.ngc");
  CHECK_THAT(alc::nc::test::read_text(s.program_file), Contains("G21 G10 L2 P1 X0.0100") && Contains("#3001 = 10.0000"));
  const std::string safety = alc::nc::test::read_text(s.safety_file);
  CHECK_THAT(safety, Contains("\"verdict\":\"split\"") && Contains("\"verdict\":\"refused\"") &&
                         Contains("axis X offset 0.5000 mm exceeds max_offset 0.1000 mm") &&
                         Contains("\"non_compensable_um_per_m\":4.25"));
  std::filesystem::remove_all(dir);
}

TEST_CASE("replay entry point: the program another dialect left in DIR is removed, nothing else", "[nc][recorder]") {
  // Review: --nc-out into a directory with case A's program.ngc (linuxcnc), then case B with fanuc:
  // DIR had B's commands.jsonl and program.nc beside A's program.ngc, and nothing said so.
  const auto dir = alc::nc::test::fresh_dir("recorder_stale");
  const std::vector<NcCommand> commands{offsets(0.002, 0, 0, 0, 0), ProbeInterval{10.0, {}}};
  const NcOutputSummary first = write_replay_nc_output(dir, Dialect::LinuxCNC, commands);
  CHECK(first.removed.empty());
  REQUIRE(std::filesystem::exists(dir / "program.ngc"));
  // Files that only look like ours, and a directory by a program's name, are not ALC's to remove.
  for (const char* name : {"program.ngc.bak", "program.txt", "program2.nc", "notes.mpf", "PROGRAM.H"})
    alc::nc::test::write_text(dir / name, "operator's\n");
  std::filesystem::create_directories(dir / "program.mpf");
  alc::nc::test::write_text(dir / "program.h", "0 BEGIN PGM OLD MM\n");
  const NcOutputSummary second = write_replay_nc_output(dir, Dialect::Fanuc, commands);
  CHECK(second.removed == std::vector<std::filesystem::path>{dir / "program.ngc", dir / "program.h"});
  CHECK_FALSE(std::filesystem::exists(dir / "program.ngc"));
  CHECK_FALSE(std::filesystem::exists(dir / "program.h"));
  CHECK(std::filesystem::exists(dir / "program.nc"));
  CHECK(std::filesystem::is_directory(dir / "program.mpf"));
  for (const char* name : {"program.ngc.bak", "program.txt", "program2.nc", "notes.mpf", "PROGRAM.H"})
    CHECK(alc::nc::test::read_text(dir / name) == "operator's\n");
  // The same dialect again: its own program is replaced, nothing removed.
  CHECK(write_replay_nc_output(dir, Dialect::Fanuc, commands).removed.empty());
  std::filesystem::remove_all(dir);
}

namespace {
// A sink that fails on demand: the queue must keep what it could not deliver.
class FlakySink : public Sink {
 public:
  int fail_from = 1000;  // delivery index from which it fails
  std::vector<NcCommand> got;
  std::string name() const override { return "flaky"; }
  void deliver(const NcCommand& c) override {
    if (static_cast<int>(got.size()) >= fail_from) throw SinkError("cable pulled");
    got.push_back(c);
  }
};
}  // namespace

TEST_CASE("transports: a failing sink keeps the commands queued and reports it", "[nc][transport]") {
  CommandQueue queue;
  for (const NcCommand& c : reference_commands()) queue.push(c);
  FlakySink sink;
  sink.fail_from = 2;
  DeliveryReport r = queue.flush(sink);
  CHECK_FALSE(r.ok());
  CHECK(r.delivered == 2);
  CHECK(r.pending == 4);
  CHECK_THAT(r.error, Contains("flaky") && Contains("cable pulled"));
  sink.fail_from = 1000;
  r = queue.flush(sink);
  CHECK(r.ok());
  CHECK(r.delivered == 4);
  CHECK(sink.got == reference_commands());  // in order, none lost, none twice
}

TEST_CASE("transports: spool writes whole numbered files, stream writes programs", "[nc][transport]") {
  const auto dir = alc::nc::test::fresh_dir("spool");
  SpoolSink spool(dir, Dialect::Fanuc);
  CommandQueue queue;
  for (const NcCommand& c : reference_commands()) queue.push(c);
  CHECK(queue.flush(spool).ok());
  std::vector<std::string> names;
  for (const auto& e : std::filesystem::directory_iterator(dir)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  REQUIRE(names.size() == 6);
  CHECK(names.front() == "alc_000001.nc");
  CHECK(names.back() == "alc_000006.nc");
  CHECK_THAT(alc::nc::test::read_text(dir / "alc_000002.nc"), Contains("#500=30.0000"));
  SpoolSink missing(dir / "nope", Dialect::Fanuc);
  queue.push(ProbeInterval{1.0, {}});
  const auto r = queue.flush(missing);
  CHECK_THAT(r.error, Contains("not a directory"));
  CHECK(r.pending == 1);
  std::ostringstream out;
  StreamSink stream(out, Dialect::Sinumerik);
  CHECK(queue.flush(stream).ok());
  CHECK(out.str() == write_program(Dialect::Sinumerik, {ProbeInterval{1.0, {}}}));
  std::filesystem::remove_all(dir);
}

TEST_CASE("transports: two spool writers on one directory never replace each other's files", "[nc][transport]") {
  const auto dir = alc::nc::test::fresh_dir("spool_two");
  // Each writer numbers after the highest file it sees; both see the same one often. Before, the
  // second rename replaced the first writer's file and both reported every command delivered.
  constexpr int kEach = 200;
  const auto writer = [&](double first) {
    SpoolSink spool(dir, Dialect::LinuxCNC);
    for (int i = 0; i < kEach; ++i) spool.deliver(ProbeInterval{first + i, {}});
  };
  std::thread a(writer, 1.0), b(writer, 1001.0);
  a.join();
  b.join();
  std::set<std::string> intervals;
  std::size_t files = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    ++files;
    const std::string text = alc::nc::test::read_text(e.path());
    const auto at = text.find("#3001 = ");
    REQUIRE(at != std::string::npos);
    intervals.insert(text.substr(at, text.find('\n', at) - at));
  }
  CHECK(files == 2 * kEach);
  CHECK(intervals.size() == 2 * kEach);  // every command in a file of its own
  std::filesystem::remove_all(dir);
}

TEST_CASE("transports: a spool past alc_999999 is full, not out of order", "[nc][transport]") {
  const auto dir = alc::nc::test::fresh_dir("spool_full");
  alc::nc::test::write_text(dir / "alc_999998.ngc", "%\n");
  SpoolSink spool(dir, Dialect::LinuxCNC);
  spool.deliver(ProbeInterval{1.0, {}});
  CHECK(spool.last_file().filename() == "alc_999999.ngc");
  // alc_1000000 would sort before alc_999999 by name.
  CHECK_THROWS_WITH(spool.deliver(ProbeInterval{2.0, {}}), Contains("full, alc_999999 is taken"));
  // A seven-digit name someone else wrote counts as the highest too.
  std::filesystem::remove(dir / "alc_999999.ngc");
  alc::nc::test::write_text(dir / "alc_1000000.ngc", "%\n");
  CHECK_THROWS_WITH(spool.deliver(ProbeInterval{2.0, {}}), Contains("full"));
  std::filesystem::remove_all(dir);
}

TEST_CASE("transports: linuxcncrsh refuses other hosts and reports a closed port", "[nc][transport]") {
  LinuxcncrshOptions o;
  o.host = "192.168.1.10";
  LinuxcncrshSink remote(o);
  CHECK_THROWS_WITH(remote.deliver(ProbeInterval{1.0, {}}), Contains("only localhost"));
  o = {};
  o.port = 1;  // nothing listens on port 1
  o.timeout_s = 1.0;
  LinuxcncrshSink closed(o);
  CommandQueue queue;
  queue.push(ProbeInterval{1.0, {}});
  const auto r = queue.flush(closed);
  CHECK(r.pending == 1);
  CHECK_THAT(r.error, Contains("cannot connect"));
}

TEST_CASE("alc nc: stdin to program, refusals and usage errors", "[nc][cli]") {
  const auto dir = alc::nc::test::fresh_dir("cli");
  std::ostringstream jsonl;
  write_commands_jsonl(jsonl, reference_commands());
  alc::nc::test::write_text(dir / "in.jsonl", jsonl.str());
  const std::string alc = ALC_CLI_PATH;
  const auto run = [&](const std::string& args) {
    const std::string cmd = alc + " nc " + args + " > " + (dir / "out").string() + " 2> " + (dir / "err").string();
    const int status = std::system(cmd.c_str());
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  };
  // Heidenhain writes every work offset to its one datum shift, so the gate judges the reference set's
  // G54 -> G55 -> G59 changes against each other (A: 0.001 -> -0.00005 deg is above the default max_step).
  alc::nc::test::write_text(dir / "wide.toml",
                            "[limits.max_offset]\nx_mm = 1\ny_mm = 1\nz_mm = 1\na_deg = 1\nb_deg = 1\nc_deg = 1\n"
                            "[limits.max_step]\nx_mm = 1\ny_mm = 1\nz_mm = 1\na_deg = 1\nb_deg = 1\nc_deg = 1\n");
  CHECK(run("--dialect heidenhain --machine " + (dir / "wide.toml").string() + " < " + (dir / "in.jsonl").string()) == 0);
  CHECK(alc::nc::test::read_text(dir / "out") == write_program(Dialect::Heidenhain, reference_commands()));
  CHECK(run("--dialect klartext < " + (dir / "in.jsonl").string()) == 2);
  CHECK_THAT(alc::nc::test::read_text(dir / "err"), Contains("--dialect must be"));
  alc::nc::test::write_text(dir / "bad.jsonl", "{\"type\":\"probe_interval\",\"minutes\":\"x\"}\n");
  CHECK(run("--dialect fanuc --in " + (dir / "bad.jsonl").string()) == 2);
  CHECK_THAT(alc::nc::test::read_text(dir / "err"), Contains("bad.jsonl:1: not a number (field 'minutes')"));
  alc::nc::test::write_text(dir / "big.jsonl", to_json_line(offsets(0.2, 0, 0, 0, 0)) + "\n");
  CHECK(run("--dialect fanuc --in " + (dir / "big.jsonl").string()) == 2);  // no base for G54 (G10 L2)
  CHECK_THAT(alc::nc::test::read_text(dir / "err"), Contains("fanuc writes G10 L2") && Contains("[nc.base.G54]"));
  CHECK(alc::nc::test::read_text(dir / "out").empty());
  alc::nc::test::write_text(dir / "bases.toml", alc::nc::test::kAllBases);
  CHECK(run("--dialect fanuc --machine " + (dir / "bases.toml").string() + " --in " + (dir / "big.jsonl").string()) == 1);
  CHECK_THAT(alc::nc::test::read_text(dir / "err"), Contains("axis X offset 0.2000 mm exceeds max_offset 0.1000 mm"));
  CHECK(alc::nc::test::read_text(dir / "out").empty());
  alc::nc::test::write_text(dir / "m.toml", std::string("[limits.max_offset]\nx_mm = 0.5\n") + alc::nc::test::kAllBases);
  CHECK(run("--dialect fanuc --machine " + (dir / "m.toml").string() + " --in " + (dir / "big.jsonl").string()) == 1);
  CHECK_THAT(alc::nc::test::read_text(dir / "err"), Contains("axis X change 0.2000 mm exceeds max_step 0.0100 mm"));
  alc::nc::test::write_text(dir / "m.toml", std::string("[limits]\non_step_violation = \"split\"\n[limits.max_offset]\nx_mm = 0.5\n") +
                                                alc::nc::test::kAllBases);
  CHECK(run("--dialect fanuc --machine " + (dir / "m.toml").string() + " --in " + (dir / "big.jsonl").string()) == 0);
  CHECK_THAT(alc::nc::test::read_text(dir / "err"), Contains("split into 20 steps"));
  // Paths that are directories (issue 13 item 9): not the defaults, not an empty program.
  CHECK(run("--dialect fanuc --machine " + dir.string() + " --in " + (dir / "in.jsonl").string()) == 2);
  CHECK_THAT(alc::nc::test::read_text(dir / "err"), Contains(dir.string() + ": not a regular file (a directory)"));
  CHECK(run("--dialect fanuc --in " + dir.string()) == 2);
  CHECK_THAT(alc::nc::test::read_text(dir / "err"), Contains("--in " + dir.string() + ": not a regular file (a directory)"));
  CHECK(alc::nc::test::read_text(dir / "out").empty());
  // (big.jsonl: in.jsonl has a B-C command, whose b_deg the A-C bases.toml does not give.)
  CHECK(run("--dialect fanuc --machine " + (dir / "bases.toml").string() + " --in-force " + dir.string() + " --in " +
            (dir / "big.jsonl").string()) == 2);
  CHECK_THAT(alc::nc::test::read_text(dir / "err"), Contains("not a regular file (a directory)"));
  std::filesystem::remove_all(dir);
}

TEST_CASE("alc nc: a command without a work offset goes to the machine file's [nc] work_offset", "[nc][cli]") {
  const auto dir = alc::nc::test::fresh_dir("cli_work_offset");
  const std::string alc = ALC_CLI_PATH;
  alc::nc::test::write_text(dir / "in.jsonl",
                            "{\"type\":\"axis_offsets\",\"x_mm\":0.005,\"y_mm\":0,\"z_mm\":0,\"a_deg\":0,\"c_deg\":0}\n"
                            "{\"type\":\"axis_offsets\",\"x_mm\":0.006,\"y_mm\":0,\"z_mm\":0,\"a_deg\":0,\"c_deg\":0,"
                            "\"work_offset\":\"G57\"}\n");
  alc::nc::test::write_text(dir / "m.toml", std::string("[nc]\nwork_offset = \"G55\"\n") + alc::nc::test::kAllBases);
  const std::string cmd = alc + " nc --dialect linuxcnc --machine " + (dir / "m.toml").string() + " --in " +
                          (dir / "in.jsonl").string() + " > " + (dir / "out").string();
  REQUIRE(std::system(cmd.c_str()) == 0);
  const std::string out = alc::nc::test::read_text(dir / "out");
  // Before: G54 (P1), the key silently ignored. A work offset given in the line stays its own.
  CHECK_THAT(out, Contains("G10 L2 P2 X0.0050"));
  CHECK_THAT(out, Contains("G10 L2 P4 X0.0060"));
  CHECK_THAT(out, !Contains(" P1 "));
  std::filesystem::remove_all(dir);
}

TEST_CASE("alc nc: --in-force makes max_step count from the offsets in force", "[nc][cli]") {
  const auto dir = alc::nc::test::fresh_dir("cli_in_force");
  const std::string alc = ALC_CLI_PATH;
  alc::nc::test::write_text(dir / "bases.toml", alc::nc::test::kAllBases);
  const auto run = [&](const std::string& args) {
    const std::string cmd = alc + " nc --machine " + (dir / "bases.toml").string() + " " + args + " > " +
                            (dir / "out").string() + " 2> " + (dir / "err").string();
    const int status = std::system(cmd.c_str());
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  };
  const std::string near = (dir / "near.jsonl").string();  // 0.1 mm on G55: one small step from 0.095 mm
  alc::nc::test::write_text(near, to_json_line(offsets(0.1, 0, 0, 0, 0, 2)) + "\n");
  const std::string zero = (dir / "zero.jsonl").string();  // back to zero on G55
  alc::nc::test::write_text(zero, to_json_line(offsets(0, 0, 0, 0, 0, 2)) + "\n");
  const std::string state = (dir / "state.jsonl").string();
  alc::nc::test::write_text(state, to_json_line(offsets(0.095, 0, 0, 0, 0, 2)) + "\n" +
                                       to_json_line(offsets(-0.05, 0, 0, 0, 0, 1)) + "\n");
  // Without a state the first command is judged against zero offsets …
  CHECK(run("--dialect linuxcnc --in " + near) == 1);
  CHECK_THAT(alc::nc::test::read_text(dir / "err"), Contains("axis X change 0.1000 mm exceeds max_step 0.0100 mm"));
  CHECK(run("--dialect linuxcnc --in " + zero) == 0);
  // … with it, against the offsets in force.
  CHECK(run("--dialect linuxcnc --in-force " + state + " --in " + near) == 0);
  CHECK_THAT(alc::nc::test::read_text(dir / "out"), Contains("G21 G10 L2 P2 X0.1000"));
  CHECK(run("--dialect linuxcnc --in-force " + state + " --in " + zero) == 1);
  CHECK_THAT(alc::nc::test::read_text(dir / "err"), Contains("axis X change -0.0950 mm exceeds max_step 0.0100 mm"));
  CHECK(alc::nc::test::read_text(dir / "out").empty());
  // A bad state file is a usage error naming the file.
  // Named by the file's line, blank lines counted (before: "entry 1", and the repeat without a line).
  alc::nc::test::write_text(dir / "twice.jsonl", to_json_line(offsets(0, 0, 0, 0, 0, 2)) + "\n\n" +
                                                     to_json_line(offsets(0.001, 0, 0, 0, 0, 2)) + "\n");
  CHECK(run("--dialect linuxcnc --in-force " + (dir / "twice.jsonl").string() + " --in " + near) == 2);
  CHECK_THAT(alc::nc::test::read_text(dir / "err"),
             Contains("--in-force " + (dir / "twice.jsonl").string() + ":3: G55 is given twice (first on line 1)"));
  alc::nc::test::write_text(dir / "interval.jsonl", "\n\n{\"type\":\"probe_interval\",\"minutes\":5}\n");
  CHECK(run("--dialect linuxcnc --in-force " + (dir / "interval.jsonl").string() + " --in " + near) == 2);
  CHECK_THAT(alc::nc::test::read_text(dir / "err"),
             Contains("--in-force " + (dir / "interval.jsonl").string() + ":3: not an axis_offsets line"));
  CHECK(run("--dialect linuxcnc --in-force " + (dir / "missing.jsonl").string() + " --in " + near) == 2);
  CHECK_THAT(alc::nc::test::read_text(dir / "err"), Contains("cannot open"));
  // The help says what happens without it.
  CHECK(run("--help") == 0);
  CHECK_THAT(alc::nc::test::read_text(dir / "out"), Contains("--in-force") && Contains("judged against zero offsets"));
  std::filesystem::remove_all(dir);
}

TEST_CASE("alc nc: heidenhain judges alternating work offsets against its one datum shift", "[nc][cli][safety]") {
  const auto dir = alc::nc::test::fresh_dir("cli_heidenhain");
  const std::string in = (dir / "alternating.jsonl").string();
  alc::nc::test::write_text(in, to_json_line(offsets(0.009, 0, 0, 0, 0, 1)) + "\n" +
                                    to_json_line(offsets(-0.009, 0, 0, 0, 0, 2)) + "\n" +
                                    to_json_line(offsets(0.009, 0, 0, 0, 0, 1)) + "\n");
  // G10 L2 keeps G54 and G55 apart: accepted.
  alc::nc::test::write_text(dir / "bases.toml", alc::nc::test::kAllBases);
  auto r = alc_test::run_alc("nc --dialect linuxcnc --machine " + (dir / "bases.toml").string() + " --in " + in,
                             "cli_heidenhain");
  CHECK(r.exit_code == 0);
  CHECK_THAT(r.out, Contains("G21 G10 L2 P2 X-0.0090"));
  // Heidenhain writes all three to the one cycle 7 shift: X would jump by 0.018 mm. Refused, nothing written.
  r = alc_test::run_alc("nc --dialect heidenhain --in " + in, "cli_heidenhain");
  CHECK(r.exit_code == 1);
  CHECK(r.out.empty());
  CHECK_THAT(r.err, Contains("command 2: refused; axis X change -0.0180 mm exceeds max_step 0.0100 mm") &&
                        Contains("judged against the offsets of G54") && Contains("nothing written"));
  // The same with splitting: the shift walks there in steps.
  alc::nc::test::write_text(dir / "split.toml", "[limits]\non_step_violation = \"split\"\n");
  r = alc_test::run_alc("nc --dialect heidenhain --machine " + (dir / "split.toml").string() + " --in " + in,
                        "cli_heidenhain");
  CHECK(r.exit_code == 0);
  CHECK_THAT(r.out, Contains("7.1 X+0.0090") && Contains("7.1 X+0.0000") && Contains("7.1 X-0.0090"));
  // One shift, one set of offsets in force.
  const std::string state = (dir / "state.jsonl").string();
  alc::nc::test::write_text(state, to_json_line(offsets(0.009, 0, 0, 0, 0, 1)) + "\n" +
                                       to_json_line(offsets(-0.009, 0, 0, 0, 0, 2)) + "\n");
  r = alc_test::run_alc("nc --dialect heidenhain --in-force " + state + " --in " + in, "cli_heidenhain");
  CHECK(r.exit_code == 2);
  CHECK_THAT(r.err, Contains("state.jsonl") && Contains("given for G54 and G55"));
  std::filesystem::remove_all(dir);
}

TEST_CASE("alc nc --sink spool: one whole program file per command as sent", "[nc][cli][transport]") {
  const auto dir = alc::nc::test::fresh_dir("cli_spool");
  const auto spool = dir / "spool";
  std::filesystem::create_directories(spool);
  // Split steps are spooled one by one, each written with the machine's options (base of G55).
  alc::nc::test::write_text(dir / "m.toml", "[limits]\non_step_violation = \"split\"\n"
                                            "[nc]\nlinuxcnc_interval_parameter = 3010\n"
                                            "[nc.base.G55]\nx_mm = 100.0\ny_mm = 0.0\nz_mm = 0.0\na_deg = 0.0\nc_deg = 0.0\n");
  const std::vector<NcCommand> commands{offsets(0.025, 0.001, 0, 0, 0, 2), ProbeInterval{30.0, {}}};
  std::ostringstream jsonl;
  write_commands_jsonl(jsonl, commands);
  alc::nc::test::write_text(dir / "in.jsonl", jsonl.str());
  const auto r = alc_test::run_alc("nc --dialect linuxcnc --machine " + (dir / "m.toml").string() +
                                       " --sink spool --spool-dir " + spool.string() + " --in " + (dir / "in.jsonl").string(),
                                   "cli_spool");
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  CHECK(r.out.empty());
  CHECK_THAT(r.err, Contains("4 command(s) delivered"));
  std::vector<std::string> names;
  for (const auto& e : std::filesystem::directory_iterator(spool)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  CHECK(names == std::vector<std::string>{"alc_000001.ngc", "alc_000002.ngc", "alc_000003.ngc", "alc_000004.ngc"});
  // Each file is the whole program of one command: the steps toward 0.025 mm on G55 (base 100 mm), then #3010.
  const MachineConfig config = read_machine_config(dir / "m.toml");
  CommandRecorder recorder(config.limits);
  for (const NcCommand& c : commands) recorder.record(c);
  REQUIRE(recorder.to_send().size() == 4);
  for (std::size_t i = 0; i < 4; ++i)
    CHECK(alc::nc::test::read_text(spool / names[i]) == write_program(Dialect::LinuxCNC, {recorder.to_send()[i]}, config.nc));
  CHECK_THAT(alc::nc::test::read_text(spool / "alc_000001.ngc"), Contains("G21 G10 L2 P2 X100.0083 Y0.0003"));
  CHECK_THAT(alc::nc::test::read_text(spool / "alc_000003.ngc"), Contains("G21 G10 L2 P2 X100.0250 Y0.0010"));
  CHECK_THAT(alc::nc::test::read_text(spool / "alc_000004.ngc"), Contains("#3010 = 30.0000"));
  std::filesystem::remove_all(dir);
}

TEST_CASE("alc nc: an option of another sink is refused, not ignored (--spool-dir without --sink spool, --port without linuxcncrsh)",
          "[nc][cli][transport]") {
  const auto dir = alc::nc::test::fresh_dir("cli_sink_options");
  const auto spool = dir / "spool";
  std::filesystem::create_directories(spool);
  std::ostringstream jsonl;
  write_commands_jsonl(jsonl, {ProbeInterval{30.0, {}}});
  alc::nc::test::write_text(dir / "in.jsonl", jsonl.str());
  const std::string in = " --in " + (dir / "in.jsonl").string();
  // --spool-dir alone: the program went to stdout and the spool stayed empty, exit 0.
  auto r = alc_test::run_alc("nc --dialect linuxcnc --spool-dir " + spool.string() + in, "cli_sink_options");
  CHECK(r.exit_code == 2);
  CHECK(r.out.empty());
  CHECK_THAT(r.err, Contains("--spool-dir is for --sink spool") && Contains("--sink stdout"));
  r = alc_test::run_alc("nc --dialect linuxcnc --sink linuxcncrsh --spool-dir " + spool.string() + in, "cli_sink_options");
  CHECK(r.exit_code == 2);
  CHECK_THAT(r.err, Contains("--spool-dir is for --sink spool") && Contains("--sink linuxcncrsh"));
  r = alc_test::run_alc("nc --dialect linuxcnc --port 5007" + in, "cli_sink_options");
  CHECK(r.exit_code == 2);
  CHECK(r.out.empty());
  CHECK_THAT(r.err, Contains("--port is for --sink linuxcncrsh") && Contains("--sink stdout"));
  r = alc_test::run_alc("nc --dialect linuxcnc --sink spool --spool-dir " + spool.string() + " --port 5007" + in,
                        "cli_sink_options");
  CHECK(r.exit_code == 2);
  CHECK_THAT(r.err, Contains("--port is for --sink linuxcncrsh") && Contains("--sink spool"));
  CHECK(std::filesystem::is_empty(spool));
  // Each with its own sink works.
  r = alc_test::run_alc("nc --dialect linuxcnc --sink spool --spool-dir " + spool.string() + in, "cli_sink_options");
  CHECK(r.exit_code == 0);
  CHECK_FALSE(std::filesystem::is_empty(spool));
  std::filesystem::remove_all(dir);
}

TEST_CASE("alc nc: a failing sink prints the undelivered commands as JSON lines and exits 1", "[nc][cli][transport]") {
  const auto dir = alc::nc::test::fresh_dir("cli_failing_sink");
  alc::nc::test::write_text(dir / "split.toml", std::string("[limits]\non_step_violation = \"split\"\n") +
                                                    alc::nc::test::kAllBases);
  const std::vector<NcCommand> commands{offsets(0.015, -0.002, 0.001, 0.0004, -0.0003, 3), ProbeInterval{5.5, {}},
                                        ProbeInterval{std::nullopt, {}}};
  std::ostringstream jsonl;
  write_commands_jsonl(jsonl, commands);
  const std::string in = (dir / "in.jsonl").string();
  alc::nc::test::write_text(in, jsonl.str());
  CommandRecorder recorder(read_machine_config(dir / "split.toml").limits);
  for (const NcCommand& c : commands) recorder.record(c);
  const std::vector<NcCommand> to_send = recorder.to_send();  // the offsets in 2 steps, then the intervals
  REQUIRE(to_send.size() == 4);
  const std::string machine = " --machine " + (dir / "split.toml").string();

  SECTION("spool directory missing") {
    const auto missing = dir / "no_such_dir";
    const auto r = alc_test::run_alc("nc --dialect fanuc" + machine + " --sink spool --spool-dir " + missing.string() +
                                         " --in " + in,
                                     "cli_failing_sink");
    CHECK(r.exit_code == 1);
    CHECK(r.out.empty());
    CHECK_THAT(r.err, Contains("0 delivered, 4 not delivered:") && Contains("not a directory"));
    CHECK(alc::nc::test::undelivered_commands(r.err) == to_send);  // all of them, in order
    CHECK_FALSE(std::filesystem::exists(missing));                 // nothing created in its place
    // They are ready to resend: the same lines into an existing spool directory.
    alc::nc::test::write_text(dir / "resend.jsonl", [&] {
      std::ostringstream s;
      write_commands_jsonl(s, alc::nc::test::undelivered_commands(r.err));
      return s.str();
    }());
    std::filesystem::create_directories(missing);
    const auto again = alc_test::run_alc("nc --dialect fanuc" + machine + " --sink spool --spool-dir " + missing.string() + " --in " +
                                             (dir / "resend.jsonl").string(),
                                         "cli_failing_sink");
    INFO(again.err);
    CHECK(again.exit_code == 0);
    CHECK(std::distance(std::filesystem::directory_iterator(missing), std::filesystem::directory_iterator()) == 4);
    CHECK_THAT(alc::nc::test::read_text(missing / "alc_000004.nc"), Contains("#500=0.0000"));
  }
  SECTION("linuxcncrsh on a closed localhost port") {
    // A port that was free a moment ago: bind it, read its number, close it again.
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    REQUIRE(fd >= 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof a;
    REQUIRE(::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0);
    REQUIRE(::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) == 0);
    const int port = ntohs(a.sin_port);
    ::close(fd);
    const auto r = alc_test::run_alc("nc --dialect linuxcnc" + machine + " --sink linuxcncrsh --port " +
                                         std::to_string(port) + " --in " + in,
                                     "cli_failing_sink");
    CHECK(r.exit_code == 1);
    CHECK(r.out.empty());
    CHECK_THAT(r.err, Contains("0 delivered, 4 not delivered:") && Contains("cannot connect") &&
                          Contains("127.0.0.1:" + std::to_string(port)));
    CHECK(alc::nc::test::undelivered_commands(r.err) == to_send);
  }
  std::filesystem::remove_all(dir);
}

TEST_CASE("machine config: the shipped example reads and equals the defaults", "[nc][config]") {
  const MachineConfig c = read_machine_config(std::filesystem::path(ALC_SOURCE_DIR) / "nc_interface/machine.example.toml");
  const MachineConfig d;
  CHECK(c.chain.workpiece_point_mm == d.chain.workpiece_point_mm);
  CHECK(c.limits.max_step.c_deg == d.limits.max_step.c_deg);
  CHECK(c.limits.max_offset.x_mm == d.limits.max_offset.x_mm);
  CHECK(c.limits.step_period_s == d.limits.step_period_s);
  CHECK(c.nc.linuxcnc_interval_parameter == d.nc.linuxcnc_interval_parameter);
  CHECK_THROWS_WITH(read_machine_config("/nonexistent/m.toml"), Contains("/nonexistent/m.toml") && Contains("cannot open"));
}

TEST_CASE("machine config: a base table must give every axis G10 L2 writes, and no tilt axis the chain lacks",
          "[nc][config]") {
  // Before, a key left out of [nc.base.G54] was 0: a base of X-350 alone wrote
  // G10 L2 P1 X-349.9900 Y0.0100 Z-0.0100 A-0.0010 C-0.0010, the operator's Z becoming -0.0100; and
  // b_deg in an A-C file (a_deg in a B-C one) was read and never written, A written from 0.
  const MachineConfig partial = parse_machine_config("[nc]\nwork_offset = \"G54\"\n[nc.base.G54]\nx_mm = -350.0\n", "p.toml");
  CHECK(missing_base(Dialect::LinuxCNC, partial.nc, 1, 'A') ==
        "[nc.base.G54] (line 3) lacks key 'nc.base.G54.y_mm', 'nc.base.G54.z_mm', 'nc.base.G54.a_deg', "
        "'nc.base.G54.c_deg': linuxcnc writes G10 L2, which replaces the whole G54 with base + compensation, so "
        "G54 Y, Z, A, C would become the compensation alone, not the operator's value. Give every axis the program "
        "writes (x_mm, y_mm, z_mm, a_deg, c_deg; 0 only where G54 really is 0)");
  CHECK_THAT(missing_base(Dialect::Fanuc, partial.nc, 1, 'B'), StartsWith("[nc.base.G54] (line 3) lacks key") &&
                                                                   Contains("'nc.base.G54.b_deg'") && Contains("fanuc"));
  CHECK_THAT(missing_base(Dialect::LinuxCNC, partial.nc, 1, '\0'), !Contains("a_deg") && Contains("'nc.base.G54.c_deg'"));
  // Sinumerik and Heidenhain write no base: nothing is missing.
  CHECK(missing_base(Dialect::Sinumerik, partial.nc, 1, 'A').empty());
  CHECK(missing_base(Dialect::Heidenhain, partial.nc, 1, 'A').empty());
  // An empty table gives no axis either (before, it stood for all zeros).
  CHECK_THAT(missing_base(Dialect::LinuxCNC, parse_machine_config("[nc.base.G54]\n", "e.toml").nc, 1, 'A'),
             Contains("[nc.base.G54] (line 1) lacks key 'nc.base.G54.x_mm', 'nc.base.G54.y_mm'"));
  // The complete table of each chain is accepted; so is a work offset that gives its tilt axis only
  // where a command has one.
  const MachineConfig ac = parse_machine_config(
      "[nc.base.G54]\nx_mm = -350.0\ny_mm = 0.0\nz_mm = -420.0\na_deg = 0.0\nc_deg = 0.0\n", "ac.toml");
  CHECK(missing_base(Dialect::LinuxCNC, ac.nc, 1, 'A').empty());
  CHECK(missing_base(Dialect::Fanuc, ac.nc, 1, '\0').empty());
  CHECK_THAT(missing_base(Dialect::LinuxCNC, ac.nc, 1, 'B'), Contains("lacks key 'nc.base.G54.b_deg'"));
  const MachineConfig bc = parse_machine_config(
      "[kinematics]\nchain = \"B-C\"\n[nc.base.G54]\nx_mm = 1\ny_mm = 2\nz_mm = 3\nb_deg = 4\nc_deg = 5\n", "bc.toml");
  CHECK(missing_base(Dialect::LinuxCNC, bc.nc, 1, 'B').empty());
  CHECK(bc.nc.base[0].b_deg == 4.0);
  // The tilt axis the chain does not have: refused when the file is read, naming the key and its line.
  const auto error = [](const std::string& text) -> std::string {
    try {
      parse_machine_config(text, "m.toml");
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "";
  };
  CHECK(error("[nc.base.G54]\nx_mm = 0.0\ny_mm = 0.0\nz_mm = 0.0\nb_deg = 5.0\nc_deg = 0.0\n") ==
        "m.toml: key 'nc.base.G54.b_deg' (line 5): the machine's chain (kinematics.chain) is A-C, which has no B axis: "
        "give the tilt axis's base as a_deg, or set the chain (kinematics.chain = \"B-C\"): value '5'");
  CHECK_THAT(error("[kinematics]\nchain = \"B-C\"\n[nc.base.G55]\nx_mm = 0.0\na_deg = 5.0\n"),
             StartsWith("m.toml: key 'nc.base.G55.a_deg' (line 5): the machine's chain (kinematics.chain) is B-C, "
                        "which has no A axis") && Contains("value '5'"));
  // Both tilt axes (as the six keys of max_step): the one the chain lacks is named.
  CHECK_THAT(error("[nc.base.G54]\nx_mm = 0\ny_mm = 0\nz_mm = 0\na_deg = 0\nb_deg = 0\nc_deg = 0\n"),
             StartsWith("m.toml: key 'nc.base.G54.b_deg' (line 6)"));
}

TEST_CASE("alc nc: a partial base, or a tilt axis the chain lacks, is refused with the file, table, key and line",
          "[nc][cli]") {
  const auto dir = alc::nc::test::fresh_dir("cli_partial_base");
  const std::string in = (dir / "in.jsonl").string();
  alc::nc::test::write_text(in, to_json_line(offsets(0.001, 0.001, -0.001, -0.0001, -0.0001)) + "\n");
  const auto run = [&](const std::string& machine_text, const std::string& dialect) {
    alc::nc::test::write_text(dir / "m.toml", machine_text);
    return alc_test::run_alc("nc --dialect " + dialect + " --machine " + (dir / "m.toml").string() + " --in " + in,
                             "cli_partial_base");
  };
  for (const char* dialect : {"linuxcnc", "fanuc"}) {
    INFO(dialect);
    const auto partial = run("[nc.base.G54]\nx_mm = -350.0\n", dialect);
    CHECK(partial.exit_code == 2);
    CHECK(partial.out.empty());
    CHECK_THAT(partial.err, Contains("command 1: [nc.base.G54] (line 1) lacks key 'nc.base.G54.y_mm'") &&
                                Contains("'nc.base.G54.z_mm'") && Contains("in " + (dir / "m.toml").string()));
    const auto wrong_tilt = run("[nc.base.G54]\nx_mm = -350.0\ny_mm = 0\nz_mm = -420\nb_deg = 5.0\nc_deg = 0\n", dialect);
    CHECK(wrong_tilt.exit_code == 2);
    CHECK(wrong_tilt.out.empty());
    CHECK_THAT(wrong_tilt.err, Contains((dir / "m.toml").string() + ": key 'nc.base.G54.b_deg' (line 5)"));
    const auto complete = run("[nc.base.G54]\nx_mm = -350.0\ny_mm = 0\nz_mm = -420\na_deg = 0\nc_deg = 0\n", dialect);
    INFO(complete.err);
    CHECK(complete.exit_code == 0);
    CHECK_THAT(complete.out, Contains("G10 L2 P1 X-349.9990 Y0.0010 Z-420.0010 A-0.0001 C-0.0001"));
  }
  // Sinumerik adds to the operator's frame: a partial base is not in the way.
  CHECK(run("[nc.base.G54]\nx_mm = -350.0\n", "sinumerik").exit_code == 0);
  std::filesystem::remove_all(dir);
}

TEST_CASE("README: the alc nc example gives the program the README shows", "[nc][cli]") {
  // The README's "NC output" section: the JSON lines after "One command per line:", then the
  // linuxcnc program it says they give. A change of either (or of the limits) must keep them true.
  const std::string readme = alc_test::slurp(std::filesystem::path(ALC_SOURCE_DIR) / "README.md");
  const auto block_after = [&](const std::string& marker) {
    const auto at = readme.find(marker);
    REQUIRE(at != std::string::npos);
    const auto open = readme.find("```\n", at);
    REQUIRE(open != std::string::npos);
    const auto close = readme.find("```\n", open + 4);
    REQUIRE(close != std::string::npos);
    return readme.substr(open + 4, close - open - 4);
  };
  const std::string machine = block_after("with `machine.toml`:");
  const std::string commands = block_after("One command per line:");
  const std::string program = block_after("gives with `--dialect linuxcnc`");
  REQUIRE(commands.find("axis_offsets") != std::string::npos);
  const auto dir = alc::nc::test::fresh_dir("readme_example");
  const auto in = (dir / "commands.jsonl").string();
  std::ofstream(in) << commands;
  std::ofstream(dir / "machine.toml") << machine;
  const auto r = alc_test::run_alc("nc --dialect linuxcnc --machine " + (dir / "machine.toml").string() + " --in " + in,
                                   "readme_example");
  INFO(r.err);
  CHECK(r.exit_code == 0);
  CHECK(r.out == program);
  // Without the base, G10 L2 would set G54 to the compensation alone: refused, nothing written.
  const auto without = alc_test::run_alc("nc --dialect linuxcnc --in " + in, "readme_example");
  CHECK(without.exit_code == 2);
  CHECK(without.out.empty());
  CHECK_THAT(without.err, Contains("command 1: linuxcnc writes G10 L2, which replaces the whole G54") &&
                              Contains("[nc.base.G54]") && Contains("give --machine FILE"));
}
