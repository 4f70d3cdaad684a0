// NC numbers, dialect writers against reviewed reference text, JSON lines, safety limits,
// machine config, the replay entry point, transports and the `alc nc` command.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <sys/wait.h>
#include <sstream>

#include "nc_interface/dialects.hpp"
#include "nc_interface/jsonl.hpp"
#include "nc_interface/machine_config.hpp"
#include "nc_interface/nc_number.hpp"
#include "nc_interface/recorder.hpp"
#include "nc_interface/safety.hpp"
#include "nc_interface/transports.hpp"
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
  e = fails(R"({"type":"probe_interval","minutes":-5})");
  CHECK(e.field == "minutes");
  CHECK(e.value == "-5");
  e = fails(R"({"type":"probe_interval","minutes":1e400})");
  CHECK(e.line == 1);
  e = fails(R"({"type":"spindle","rpm":5})");
  CHECK(e.field == "type");
  e = fails("not json");
  CHECK_THAT(e.reason, StartsWith("not JSON"));
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
    CHECK_THAT(d.to_send[0].x_mm, WithinAbs(0.00875, 1e-15));
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
  SECTION("steps count from the offsets in force, per work offset") {
    SafetyGate gate(limits);
    CHECK(gate.submit(offsets(0.01, 0, 0, 0, 0)).verdict == SafetyVerdict::Accepted);
    CHECK(gate.submit(offsets(0.02, 0, 0, 0, 0)).verdict == SafetyVerdict::Accepted);
    CHECK(gate.submit(offsets(0.02, 0, 0, 0, 0, 2)).verdict == SafetyVerdict::Refused);  // G55 starts at 0
  }
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
  CHECK(error("[limits]\non_step_violation = \"clamp\"") ==
        "m.toml: key 'limits.on_step_violation': must be \"refuse\" or \"split\": value '\"clamp\"'");
  CHECK(error("[nc]\nwork_offset = \"G54.1\"") == "m.toml: key 'nc.work_offset': must be one of G54 … G59: value '\"G54.1\"'");
  CHECK_THAT(error("[nc]\nfanuc_interval_variable = 33"), StartsWith("m.toml: key 'nc.fanuc_interval_variable'") && Contains("33"));
  CHECK_THAT(error("[kinematics]\ntilt_direction = [1, 0]"), StartsWith("m.toml: key 'kinematics.tilt_direction'"));
  CHECK_THAT(error("[kinematics]\ntilt_direction = [0, 0, 1]"), Contains("parallel"));
  CHECK_THAT(error("[kinematics]\nchian = \"A-C\""), StartsWith("m.toml: key 'kinematics.chian': unknown key"));
  CHECK_THAT(error("[nc.base.G60]\nx_mm = 1"), StartsWith("m.toml: key 'nc.base.G60'"));
  CHECK_THAT(error("[nc\n"), StartsWith("m.toml: key '': ") && Contains("line 1"));
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
  alc::nc::test::write_text(dir / "wide.toml", "[limits.max_offset]\nx_mm = 1\ny_mm = 1\nz_mm = 1\nb_deg = 1\nc_deg = 1\n"
                                                "[limits.max_step]\nx_mm = 1\ny_mm = 1\nz_mm = 1\nb_deg = 1\nc_deg = 1\n");
  CHECK(run("--dialect heidenhain --machine " + (dir / "wide.toml").string() + " < " + (dir / "in.jsonl").string()) == 0);
  CHECK(alc::nc::test::read_text(dir / "out") == write_program(Dialect::Heidenhain, reference_commands()));
  CHECK(run("--dialect klartext < " + (dir / "in.jsonl").string()) == 2);
  CHECK_THAT(alc::nc::test::read_text(dir / "err"), Contains("--dialect must be"));
  alc::nc::test::write_text(dir / "bad.jsonl", "{\"type\":\"probe_interval\",\"minutes\":\"x\"}\n");
  CHECK(run("--dialect fanuc --in " + (dir / "bad.jsonl").string()) == 2);
  CHECK_THAT(alc::nc::test::read_text(dir / "err"), Contains("bad.jsonl:1: not a number (field 'minutes')"));
  alc::nc::test::write_text(dir / "big.jsonl", to_json_line(offsets(0.2, 0, 0, 0, 0)) + "\n");
  CHECK(run("--dialect fanuc --in " + (dir / "big.jsonl").string()) == 1);
  CHECK_THAT(alc::nc::test::read_text(dir / "err"), Contains("axis X offset 0.2000 mm exceeds max_offset 0.1000 mm"));
  CHECK(alc::nc::test::read_text(dir / "out").empty());
  alc::nc::test::write_text(dir / "m.toml", "[limits.max_offset]\nx_mm = 0.5\n");
  CHECK(run("--dialect fanuc --machine " + (dir / "m.toml").string() + " --in " + (dir / "big.jsonl").string()) == 1);
  CHECK_THAT(alc::nc::test::read_text(dir / "err"), Contains("axis X change 0.2000 mm exceeds max_step 0.0100 mm"));
  alc::nc::test::write_text(dir / "m.toml", "[limits]\non_step_violation = \"split\"\n[limits.max_offset]\nx_mm = 0.5\n");
  CHECK(run("--dialect fanuc --machine " + (dir / "m.toml").string() + " --in " + (dir / "big.jsonl").string()) == 0);
  CHECK_THAT(alc::nc::test::read_text(dir / "err"), Contains("split into 20 steps"));
  std::filesystem::remove_all(dir);
}

TEST_CASE("alc nc: --in-force makes max_step count from the offsets in force", "[nc][cli]") {
  const auto dir = alc::nc::test::fresh_dir("cli_in_force");
  const std::string alc = ALC_CLI_PATH;
  const auto run = [&](const std::string& args) {
    const std::string cmd = alc + " nc " + args + " > " + (dir / "out").string() + " 2> " + (dir / "err").string();
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
  alc::nc::test::write_text(dir / "twice.jsonl", to_json_line(offsets(0, 0, 0, 0, 0, 2)) + "\n" +
                                                     to_json_line(offsets(0.001, 0, 0, 0, 0, 2)) + "\n");
  CHECK(run("--dialect linuxcnc --in-force " + (dir / "twice.jsonl").string() + " --in " + near) == 2);
  CHECK_THAT(alc::nc::test::read_text(dir / "err"), Contains("twice.jsonl") && Contains("G55 is given twice"));
  alc::nc::test::write_text(dir / "interval.jsonl", "{\"type\":\"probe_interval\",\"minutes\":5}\n");
  CHECK(run("--dialect linuxcnc --in-force " + (dir / "interval.jsonl").string() + " --in " + near) == 2);
  CHECK_THAT(alc::nc::test::read_text(dir / "err"), Contains("not an axis_offsets line"));
  CHECK(run("--dialect linuxcnc --in-force " + (dir / "missing.jsonl").string() + " --in " + near) == 2);
  CHECK_THAT(alc::nc::test::read_text(dir / "err"), Contains("cannot open"));
  // The help says what happens without it.
  CHECK(run("--help") == 0);
  CHECK_THAT(alc::nc::test::read_text(dir / "out"), Contains("--in-force") && Contains("judged against zero offsets"));
  std::filesystem::remove_all(dir);
}

TEST_CASE("machine config: the shipped example reads and equals the defaults", "[nc][config]") {
  const MachineConfig c = read_machine_config(std::filesystem::path(ALC_SOURCE_DIR) / "nc_interface/machine.example.toml");
  const MachineConfig d;
  CHECK(c.chain.workpiece_point_mm == d.chain.workpiece_point_mm);
  CHECK(c.limits.max_step.c_deg == d.limits.max_step.c_deg);
  CHECK(c.limits.max_offset.x_mm == d.limits.max_offset.x_mm);
  CHECK(c.nc.linuxcnc_interval_parameter == d.nc.linuxcnc_interval_parameter);
  CHECK_THROWS_WITH(read_machine_config("/nonexistent/m.toml"), Contains("/nonexistent/m.toml") && Contains("cannot open"));
}
