// A real controller to test against: LinuxCNC (Debian package linuxcnc-uspace, installed by
// scripts/test.sh). The standalone interpreter rs274 checks every program the linuxcnc writer
// produces; the headless simulator, driven over linuxcncrsh, checks that sent offsets are applied.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <fcntl.h>
#include <random>
#include <sstream>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

#include "nc_interface/dialects.hpp"
#include "nc_interface/jsonl.hpp"
#include "nc_interface/nc_number.hpp"
#include "nc_interface/safety.hpp"
#include "nc_interface/transports.hpp"
#include "nc_test_support.hpp"
#include "../linuxcnc_sim_support.hpp"

using namespace alc::nc;
using alc::nc::test::g10_offsets;
using alc::nc::test::on_path;
using alc::nc::test::read_text;
using alc::nc::test::require_program;
using alc::nc::test::MachineLock;
using alc::nc::test::Rs274Run;
using alc::nc::test::Simulator;
using alc::nc::test::var_value;
using alc::nc::test::write_text;
using Catch::Matchers::WithinAbs;

namespace {
// `program` into DIR/program.ngc, then rs274 on it (the simulator tests hold the simulator lock).
Rs274Run run_rs274(const std::filesystem::path& dir, const std::string& program, const std::string& var_before) {
  write_text(dir / "program.ngc", program);
  return alc::nc::test::run_rs274(dir, var_before, false);
}
}  // namespace

namespace {

constexpr double kMmPerInch = 25.4;
// The standalone interpreter saves lengths in the var file in inches with 6 decimals.
constexpr double kVarFileTolMm = 0.5e-6 * kMmPerInch + 1e-9;  // [mm]
constexpr double kReadBackTol = 0.5e-4;                       // [mm] or [°] sim read-back vs 4-decimal text

// The shared offsets() with A and B as given (each may be absent).
AxisOffsets offsets(double x, double y, double z, std::optional<double> a, std::optional<double> b, double c,
                    int work_offset = 1) {
  AxisOffsets o = alc::nc::test::offsets(x, y, z, 0.0, c, work_offset);
  o.a_deg = a;
  o.b_deg = b;
  return o;
}

// Zero, tiny (rounds to zero / to one count), negative, and the default safety limits.
std::vector<NcCommand> edge_commands() {
  const SafetyLimits l;
  return {offsets(0, 0, 0, 0.0, {}, 0),
          ProbeInterval{5.0, {}},
          offsets(0.00004, -0.00004, 0.00005, -0.00005, {}, 0.00015),
          offsets(-0.0123, -0.004, -0.0001, -0.001, {}, -0.002),
          offsets(l.max_offset.x_mm, -l.max_offset.y_mm, l.max_offset.z_mm, -l.max_offset.a_deg, {}, l.max_offset.c_deg),
          offsets(-l.max_offset.x_mm, l.max_offset.y_mm, -l.max_offset.z_mm, {}, l.max_offset.b_deg, -l.max_offset.c_deg),
          ProbeInterval{std::nullopt, {}},
          ProbeInterval{0.0001, {}},
          ProbeInterval{1440.0, {}},
          offsets(1e-9, -1e-9, 0, 0.0, {}, -1e-9)};
}

// Runs the linuxcnc program of `commands` (written with `options`, so base + compensation) through
// rs274 and checks G54 in the canonical commands and G55…G59 in the var file, all six axes.
void check_program_in_rs274(const std::filesystem::path& dir, const std::vector<NcCommand>& commands,
                            const DialectOptions& options = {}) {
  const std::string program = write_program(Dialect::LinuxCNC, commands, options);
  const Rs274Run r = run_rs274(dir, program, "3001 0.0\n");
  INFO("program:\n" << program << "\nrs274 log:\n" << read_text(dir / "rs274.log"));
  REQUIRE(r.exit_code == 0);
  // What each work offset should hold: the numbers written (base + compensation, as 4-decimal text).
  // G10 L2 leaves an axis without a word unchanged (zero at the start).
  std::array<std::array<double, 6>, 6> held{};
  std::array<bool, 6> written{};
  std::vector<std::string> expected;
  std::optional<double> last_interval;
  for (const NcCommand& c : commands) {
    if (const auto* o = std::get_if<AxisOffsets>(&c)) {
      const BaseOffset& b = options.base[static_cast<std::size_t>(o->work_offset - 1)];
      auto& h = held[static_cast<std::size_t>(o->work_offset - 1)];
      written[static_cast<std::size_t>(o->work_offset - 1)] = true;
      const auto text = [](double v) { return std::stod(format_nc_number(v)); };
      h[0] = text(b.x_mm + o->x_mm);
      h[1] = text(b.y_mm + o->y_mm);
      h[2] = text(b.z_mm + o->z_mm);
      if (o->a_deg) h[3] = text(b.a_deg + *o->a_deg);
      if (o->b_deg) h[4] = text(b.b_deg + *o->b_deg);
      h[5] = text(b.c_deg + o->c_deg);
      if (o->work_offset != 1) continue;
      std::string line = "SET_G5X_OFFSET(1";
      for (double v : h) line += ", " + format_nc_number(v);
      expected.push_back(line + ")");
    } else {
      last_interval = std::get<ProbeInterval>(c).minutes.value_or(0.0);
    }
  }
  const std::vector<std::string> got = g10_offsets(r.canon);
  REQUIRE(got.size() == expected.size());
  for (std::size_t i = 0; i < got.size(); ++i) {
    INFO("G10 number " << i + 1);
    CHECK(got[i] == expected[i]);
  }
  // The interval parameter is listed in the var file, so the interpreter keeps it there.
  if (last_interval) CHECK_THAT(var_value(r.var, 3001), WithinAbs(std::stod(format_nc_number(*last_interval)), 1e-9));
  // Every other work offset that was written is in the var file (5221 + 20·(n−1) … +5): X Y Z in
  // inches (6 decimals), A B C in degrees.
  for (int wo = 2; wo <= 6; ++wo) {
    if (!written[static_cast<std::size_t>(wo - 1)]) continue;
    const auto& h = held[static_cast<std::size_t>(wo - 1)];
    const int base = 5221 + 20 * (wo - 1);
    INFO("work offset " << work_offset_name(wo));
    CHECK_THAT(var_value(r.var, base) * kMmPerInch, WithinAbs(h[0], kVarFileTolMm));
    CHECK_THAT(var_value(r.var, base + 1) * kMmPerInch, WithinAbs(h[1], kVarFileTolMm));
    CHECK_THAT(var_value(r.var, base + 2) * kMmPerInch, WithinAbs(h[2], kVarFileTolMm));
    CHECK_THAT(var_value(r.var, base + 3), WithinAbs(h[3], 1e-6));
    CHECK_THAT(var_value(r.var, base + 4), WithinAbs(h[4], 1e-6));
    CHECK_THAT(var_value(r.var, base + 5), WithinAbs(h[5], 1e-6));
  }
}

unsigned test_seed() {
  const char* s = std::getenv("ALC_TEST_SEED");
  return s ? static_cast<unsigned>(std::strtoul(s, nullptr, 10)) : 20261122u;
}

}  // namespace

TEST_CASE("linuxcnc rs274: edge values, as one program and one program per command", "[linuxcnc][rs274]") {
  const auto dir = alc::nc::test::fresh_dir("rs274_edges");
  check_program_in_rs274(dir, edge_commands());
  for (const NcCommand& c : edge_commands()) check_program_in_rs274(dir, {c});
  // Other work offsets land in the var file, all six axes: A–C commands on G55, G57, G59, B–C
  // commands on G56, G58, and a B–C command after an A–C one on G55 (A must stay as it was).
  std::vector<NcCommand> others;
  for (int wo = 2; wo <= 6; ++wo) {
    const double a = 0.001 * wo, b = -0.0007 * wo;
    others.push_back(wo % 2 == 0 ? offsets(0.01 * wo, -0.003 * wo, 0.0001 * wo, a, {}, -0.001 * wo, wo)
                                 : offsets(0.01 * wo, -0.003 * wo, 0.0001 * wo, {}, b, -0.001 * wo, wo));
  }
  others.push_back(offsets(-0.004, 0.005, -0.006, {}, 0.0031, 0.0042, 2));
  check_program_in_rs274(dir, others);
  std::filesystem::remove_all(dir);
}

TEST_CASE("linuxcnc rs274: non-zero base offsets are written as base + compensation", "[linuxcnc][rs274]") {
  const auto dir = alc::nc::test::fresh_dir("rs274_base");
  DialectOptions o;
  o.base[0] = {125.5, -310.25, 42.0, 0.0, 0.0, 90.0};    // G54: the operator's setting
  o.base[2] = {-20.125, 48.0, -7.5, 12.5, -30.0, 180.0};  // G56
  o.base[5] = {0.5, 0.25, -0.125, 0.0, 45.0, -45.0};      // G59
  const std::vector<NcCommand> commands{
      offsets(0.0123, -0.004, 0.01, 0.001, {}, -0.002), ProbeInterval{15.0, {}},
      offsets(0.00004, -0.00004, 0.00005, -0.00005, {}, 0.00015),  // rounds after the base is added
      offsets(-0.1, 0.1, -0.1, 0.01, {}, -0.01, 3), offsets(0.02, -0.03, 0.04, {}, 0.005, 0.006, 6),
      offsets(0, 0, 0, 0.0, {}, 0)};  // back to the operator's own offset
  check_program_in_rs274(dir, commands, o);
  // And by hand for one line, independent of the helper: G54 = base + compensation.
  const Rs274Run r = run_rs274(dir, write_program(Dialect::LinuxCNC, {commands[0]}, o), "3001 0.0\n");
  REQUIRE(r.exit_code == 0);
  REQUIRE(g10_offsets(r.canon).size() == 1);
  CHECK(g10_offsets(r.canon)[0] == "SET_G5X_OFFSET(1, 125.5123, -310.2540, 42.0100, 0.0010, 0.0000, 89.9980)");
  std::filesystem::remove_all(dir);
}

TEST_CASE("linuxcnc rs274: a bad line is rejected (the check can fail)", "[linuxcnc][rs274]") {
  const auto dir = alc::nc::test::fresh_dir("rs274_bad");
  const Rs274Run r = run_rs274(dir, "G10 L2 P1 X1e-5\nM2\n", "3001 0.0\n");
  CHECK(r.exit_code == 1);
  std::filesystem::remove_all(dir);
}

TEST_CASE("linuxcnc rs274: a long random seeded sequence through the safety gate", "[linuxcnc][rs274]") {
  std::mt19937 rng(test_seed());
  std::normal_distribution<double> walk(0.0, 0.004);
  std::uniform_int_distribution<int> pick(0, 9);
  SafetyLimits limits;
  limits.on_step_violation = StepAction::Split;
  SafetyGate gate(limits);
  std::vector<NcCommand> commands;
  AxisOffsets target = offsets(0, 0, 0, 0.0, {}, 0);
  for (int i = 0; i < 400; ++i) {
    if (pick(rng) == 0) {
      commands.push_back(ProbeInterval{std::max(0.0001, std::abs(walk(rng)) * 1e5), {}});
      continue;
    }
    const auto clamp = [](double v, double m) { return std::clamp(v, -m, m); };
    target.x_mm = clamp(target.x_mm + walk(rng), limits.max_offset.x_mm);
    target.y_mm = clamp(target.y_mm + walk(rng), limits.max_offset.y_mm);
    target.z_mm = clamp(target.z_mm + walk(rng), limits.max_offset.z_mm);
    target.a_deg = clamp(*target.a_deg + walk(rng) / 10, limits.max_offset.a_deg);
    target.c_deg = clamp(target.c_deg + walk(rng) / 10, limits.max_offset.c_deg);
    const SafetyDecision d = gate.submit(target);
    REQUIRE(d.verdict != SafetyVerdict::Refused);
    commands.insert(commands.end(), d.to_send.begin(), d.to_send.end());
  }
  INFO("seed " << test_seed() << ", " << commands.size() << " commands");
  const auto dir = alc::nc::test::fresh_dir("rs274_random");
  check_program_in_rs274(dir, commands);
  std::filesystem::remove_all(dir);
}

TEST_CASE("linuxcnc simulator: offsets sent over linuxcncrsh are applied and read back", "[linuxcnc][sim]") {
  require_program("linuxcnc");
  require_program("linuxcncrsh");
  if (std::filesystem::exists("/tmp/linuxcnc.lock"))
    WARN("/tmp/linuxcnc.lock exists: a LinuxCNC instance may be running; the linuxcnc script will clean it up");
  const MachineLock lock;
  const auto dir = alc::nc::test::fresh_dir("sim");
  const int port = 20000 + static_cast<int>(::getpid() % 20000);
  Simulator sim(dir, port);
  LinuxcncrshOptions options;
  options.port = port;
  options.timeout_s = 20.0;
  sim.wait_ready(options);
  try {
    LinuxcncrshSink sink(options);
    CommandQueue queue;
    const std::vector<NcCommand> commands{offsets(0.0123, -0.004, 0.01, 0.001, {}, -0.002), ProbeInterval{30.0, {}},
                                          offsets(0.00004, -0.00004, 0.00005, -0.00005, {}, 0.00015),
                                          offsets(-0.1, 0.1, -0.1, 0.01, {}, -0.01), offsets(0, 0, 0, 0.0, {}, 0)};
    for (const NcCommand& c : commands) {
      queue.push(c);
      // The sink reads the stored work-offset parameters back (a DEBUG line) and compares.
      const DeliveryReport r = queue.flush(sink);
      INFO("command " << to_json_line(c) << ": " << r.error);
      REQUIRE(r.ok());
      REQUIRE(r.delivered == 1);
    }
    // A target that is not the active work offset, with a G92 offset in force: the sink reads the
    // stored G55 back (not pos_offset = active G54 + G92), so delivery succeeds. (linuxcncrsh gives
    // control to one session at a time: each step below opens its own.)
    LinuxcncrshClient by_hand(options);
    by_hand.connect();
    by_hand.mdi({"G21 G54", "G92 X3 Y-2"});  // homed at 0: the G92 offset becomes (-3, 2)
    REQUIRE_THAT(by_hand.position_offsets()[0], WithinAbs(-3.0, 1e-6));  // pos_offset would not match G55
    by_hand.close();
    LinuxcncrshSink g55_sink(options);
    queue.push(offsets(0.0234, -0.0056, 0.0078, 0.0009, {}, -0.0011, 2));
    const DeliveryReport g55 = queue.flush(g55_sink);
    INFO("G55 under G54 + G92: " << g55.error);
    REQUIRE(g55.ok());
    // … and G55 does hold it: select it by hand, clear G92, and read pos_offset.
    by_hand.connect();
    by_hand.mdi({"G92.1", "G55"});
    const auto g55_in_force = by_hand.position_offsets();
    const double want_g55[6] = {0.0234, -0.0056, 0.0078, 0.0009, 0.0, -0.0011};
    for (int i = 0; i < 6; ++i) CHECK_THAT(g55_in_force[static_cast<std::size_t>(i)], WithinAbs(want_g55[i], kReadBackTol));
    by_hand.mdi({"G54"});
    by_hand.close();
    LinuxcncrshSink last_sink(options);
    // And once more by hand, independent of the sink's own check.
    queue.push(offsets(0.0421, -0.0077, 0.0009, -0.0042, {}, 0.0063));
    REQUIRE(queue.flush(last_sink).ok());
    LinuxcncrshClient check(options);
    check.connect();
    const auto got = check.position_offsets();
    const double want[6] = {0.0421, -0.0077, 0.0009, -0.0042, 0.0, 0.0063};
    for (int i = 0; i < 6; ++i) CHECK_THAT(got[static_cast<std::size_t>(i)], WithinAbs(want[i], kReadBackTol));
    sim.stop(&check);
  } catch (...) {
    sim.stop(nullptr);
    throw;
  }
  CHECK_FALSE(sim.running());
  std::filesystem::remove_all(dir);
}
