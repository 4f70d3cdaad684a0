// The replay's NC output: load cases A–D through NcCommandObserver, the linuxcnc program checked by
// LinuxCNC's standalone interpreter rs274, and `alc replay --nc-out` end to end.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <vector>

#include "../nc_interface/nc_test_support.hpp"
#include "alc/kinematics.hpp"
#include "nc_interface/dialects.hpp"
#include "nc_interface/jsonl.hpp"
#include "nc_interface/nc_number.hpp"
#include "nc_interface/recorder.hpp"
#include "scenarios/load_cases.hpp"
#include "scenarios/replay.hpp"
#include "scenarios/replay_nc.hpp"

namespace fs = std::filesystem;
namespace sc = alc::scenarios;
namespace nc = alc::nc;
namespace kinematics = alc::kinematics;
using alc::nc::test::read_text;
using alc::nc::test::write_text;

namespace {

struct Rs274Run {
  int exit_code = -1;
  std::string canon;
  std::string var;
};

// As in tests/nc_interface/linuxcnc_test.cpp: two interpreters at once crash with SIGBUS (shared
// memory of a fixed name), so every run takes /tmp/alc_rs274.lock. The simulator shares those names
// too, and ctest's RESOURCE_LOCK linuxcnc covers only the nc_interface tests, so this run also waits
// for the simulator tests' lock (same order as there: simulator lock first, then the rs274 lock).
Rs274Run run_rs274(const fs::path& dir) {
  if (std::system("command -v rs274 > /dev/null 2>&1") != 0)
    FAIL("rs274 not found: install the Debian package linuxcnc-uspace (scripts/test.sh does this)");
  write_text(dir / "tool.tbl", "T1 P1 Z0 D0 ;\n");
  write_text(dir / "params.var", "3001 0.0\n");
  fs::remove(dir / "canon.txt");
  const std::string cmd = "cd '" + dir.string() +
                          "' && flock /tmp/alc_linuxcnc_sim.flock flock /tmp/alc_rs274.lock timeout 60 "
                          "rs274 -g -t tool.tbl -v params.var program.ngc canon.txt > rs274.log 2>&1";
  const int status = std::system(cmd.c_str());
  Rs274Run r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.canon = read_text(dir / "canon.txt");
  r.var = read_text(dir / "params.var");
  return r;
}

// SET_G5X_OFFSET lines that follow a G10's USE_LENGTH_UNITS after the program's opening comment (not
// the interpreter's own at start-up and at M2).
std::vector<std::string> g10_offsets(const std::string& canon) {
  std::vector<std::string> out;
  std::istringstream in(canon);
  std::string line;
  bool in_program = false;
  bool after_units = false;
  while (std::getline(in, line)) {
    if (line.find("COMMENT(\"ALC thermal compensation") != std::string::npos) in_program = true;
    const auto at = line.find("SET_G5X_OFFSET(");
    if (in_program && at != std::string::npos && after_units) out.push_back(line.substr(at));
    after_units = line.find("USE_LENGTH_UNITS(CANON_UNITS_MM)") != std::string::npos;
  }
  return out;
}

std::string expected_g5x(const nc::AxisOffsets& o) {
  return "SET_G5X_OFFSET(1, " + nc::format_nc_number(o.x_mm) + ", " + nc::format_nc_number(o.y_mm) + ", " +
         nc::format_nc_number(o.z_mm) + ", " + nc::format_nc_number(o.a_deg.value_or(0.0)) + ", " +
         nc::format_nc_number(o.b_deg.value_or(0.0)) + ", " + nc::format_nc_number(o.c_deg) + ")";
}

double var_value(const std::string& var, int parameter) {
  std::istringstream in(var);
  int p = 0;
  double v = 0.0;
  while (in >> p >> v)
    if (p == parameter) return v;
  FAIL("parameter " << parameter << " not in the var file");
  return 0.0;
}

// Forwards every callback to the NC observer and keeps, for each axis_offsets command it emits,
// the prediction of the controller cycle that emitted it.
class PredictionTap : public sc::ReplayObserver {
 public:
  explicit PredictionTap(sc::NcCommandObserver& nc) : nc_(nc) {}
  void on_row_done(const sc::ReplaySession& session) override { nc_.on_row_done(session); }
  void on_sample(std::size_t row, double time_s, const Eigen::VectorXd& inputs, const alc::ControllerOutput& out) override {
    const std::size_t before = nc_.commands().size();
    nc_.on_sample(row, time_s, inputs, out);
    keep(before, out);
  }
  void on_probe(std::size_t row, const alc::ProbeMeasurement& probe, const alc::ControllerOutput& out) override {
    const std::size_t before = nc_.commands().size();
    nc_.on_probe(row, probe, out);
    keep(before, out);
  }
  std::vector<std::pair<nc::AxisOffsets, Eigen::VectorXd>> emitted;

 private:
  void keep(std::size_t before, const alc::ControllerOutput& out) {
    for (std::size_t i = before; i < nc_.commands().size(); ++i)
      if (const auto* o = std::get_if<nc::AxisOffsets>(&nc_.commands()[i])) emitted.emplace_back(*o, out.prediction);
  }
  sc::NcCommandObserver& nc_;
};

}  // namespace

TEST_CASE("replay NC output: each offset command records the non-compensable part of its prediction",
          "[replay][nc]") {
  const sc::Scenario scenario = sc::simulate_case("A").scenario;
  const sc::NcObserverOptions options;  // A-C table: what no axis cancels is the tilt E_B0C
  sc::NcCommandObserver observer(scenario.output_names, options);
  PredictionTap tap(observer);
  sc::replay(scenario, alc::AlcParameters{}, &tap);
  REQUIRE(tap.emitted.size() > 10);
  double largest = 0.0;
  for (const auto& [command, prediction] : tap.emitted) {
    INFO("command at t = " << command.time_s.value_or(-1.0) << " s");
    REQUIRE(command.non_compensable_um_per_m.has_value());
    const auto errors = kinematics::location_errors_of(scenario.output_names, prediction);
    const kinematics::Compensation c = kinematics::compensate(options.chain, options.pose, errors);
    REQUIRE(c.converged);
    CHECK(*command.non_compensable_um_per_m == c.non_compensable_um_per_m);
    // For an A-C table it is |E_B0C| up to the O(eps^2) of the exact chain (eps ~ 1e-5 rad here).
    CHECK(std::abs(*command.non_compensable_um_per_m - std::abs(errors.b0c_um_per_m)) < 1e-3);
    largest = std::max(largest, *command.non_compensable_um_per_m);
  }
  CHECK(largest > 0.1);  // the case does predict a tilt that the offsets leave
  CHECK(observer.max_non_compensable_um_per_m() >= largest);

  // It is in DIR/commands.jsonl (and reads back), and the summary has its maximum.
  const fs::path dir = alc::nc::test::fresh_dir("replay_non_compensable");
  const nc::NcOutputSummary s = nc::write_replay_nc_output(dir, nc::Dialect::LinuxCNC, observer.commands());
  CHECK(s.max_non_compensable_um_per_m == largest);
  std::istringstream jsonl(read_text(s.commands_file));
  const std::vector<nc::NcCommand> written = nc::read_commands_jsonl(jsonl, s.commands_file.string());
  std::size_t with_value = 0;
  for (const nc::NcCommand& c : written)
    if (const auto* o = std::get_if<nc::AxisOffsets>(&c); o && o->non_compensable_um_per_m) ++with_value;
  CHECK(with_value == tap.emitted.size());
  CHECK(written == observer.recorder().to_send());  // round trip, field included
  fs::remove_all(dir);
}

TEST_CASE("replay NC output: every load case's linuxcnc program passes rs274 with the intended offsets",
          "[replay][nc][rs274]") {
  const nc::SafetyLimits limits;
  for (const char* name : {"A", "B", "C", "D"}) {
    INFO("load case " << name);
    const sc::Scenario scenario = sc::simulate_case(name).scenario;
    sc::NcCommandObserver observer(scenario.output_names, sc::NcObserverOptions{});
    REQUIRE(observer.maps_any_error());
    sc::replay(scenario, alc::AlcParameters{}, &observer);

    std::size_t offsets = 0, intervals = 0;
    for (const nc::NcCommand& c : observer.commands())
      (std::holds_alternative<nc::AxisOffsets>(c) ? offsets : intervals)++;
    const fs::path dir = alc::nc::test::fresh_dir(std::string("replay_") + name);
    const nc::NcOutputSummary s = nc::write_replay_nc_output(dir, nc::Dialect::LinuxCNC, observer.commands());
    WARN("case " << name << ": " << offsets << " axis_offsets + " << intervals << " probe_interval commands, "
                 << s.refused << " refused, " << s.sent << " written");
    // The emission rule keeps the number far below one per sample (11,520 samples in 8 days).
    CHECK(offsets > 10);
    CHECK(offsets < 1500);
    CHECK(intervals >= 2);  // CP interval at the start, Post-CP interval at the end of CP
    CHECK(s.refused == observer.refused());  // the file writer's gate decides as the observer's did
    REQUIRE(s.sent > 0);

    // The observer steps within max_step, so with the default limits nothing is refused; and nothing
    // beyond the limits reaches the program.
    CHECK(s.refused == 0);
    std::vector<nc::AxisOffsets> sent;
    std::optional<double> last_interval;
    for (const nc::NcCommand& c : observer.recorder().to_send()) {
      if (const auto* o = std::get_if<nc::AxisOffsets>(&c)) {
        sent.push_back(*o);
        CHECK(std::abs(o->x_mm) <= limits.max_offset.x_mm);
        CHECK(std::abs(o->y_mm) <= limits.max_offset.y_mm);
        CHECK(std::abs(o->z_mm) <= limits.max_offset.z_mm);
        CHECK(std::abs(o->a_deg.value_or(0.0)) <= limits.max_offset.a_deg);
        CHECK(std::abs(o->c_deg) <= limits.max_offset.c_deg);
      } else {
        last_interval = std::get<nc::ProbeInterval>(c).minutes.value_or(0.0);
      }
    }
    for (std::size_t i = 1; i < sent.size(); ++i) {
      CHECK(std::abs(sent[i].x_mm - sent[i - 1].x_mm) <= limits.max_step.x_mm + 1e-12);
      CHECK(std::abs(sent[i].y_mm - sent[i - 1].y_mm) <= limits.max_step.y_mm + 1e-12);
      CHECK(std::abs(sent[i].z_mm - sent[i - 1].z_mm) <= limits.max_step.z_mm + 1e-12);
      CHECK(std::abs(*sent[i].a_deg - *sent[i - 1].a_deg) <= limits.max_step.a_deg + 1e-12);
      CHECK(std::abs(sent[i].c_deg - sent[i - 1].c_deg) <= limits.max_step.c_deg + 1e-12);
    }

    const Rs274Run r = run_rs274(dir);
    INFO("rs274 log:\n" << read_text(dir / "rs274.log"));
    REQUIRE(r.exit_code == 0);
    const std::vector<std::string> got = g10_offsets(r.canon);
    REQUIRE(got.size() == sent.size());
    for (std::size_t i = 0; i < got.size(); ++i) {
      INFO("G10 number " << i + 1);
      REQUIRE(got[i] == expected_g5x(sent[i]));
    }
    REQUIRE(last_interval);
    CHECK(std::abs(var_value(r.var, 3001) - std::stod(nc::format_nc_number(*last_interval))) < 1e-9);
  }
}

TEST_CASE("replay NC output: alc replay --case A --nc-out writes commands.jsonl and program.ngc", "[replay][nc][cli]") {
  const fs::path dir = alc::nc::test::fresh_dir("replay_cli");
  const std::string cmd = std::string("\"") + ALC_CLI_PATH + "\" replay --case A --nc-out \"" + (dir / "out").string() +
                          "\" > \"" + (dir / "stdout").string() + "\" 2> \"" + (dir / "stderr").string() + "\"";
  const int status = std::system(cmd.c_str());
  const std::string err = read_text(dir / "stderr");
  INFO(err);
  REQUIRE(WIFEXITED(status));
  REQUIRE(WEXITSTATUS(status) == 0);
  REQUIRE(fs::exists(dir / "out" / "commands.jsonl"));
  REQUIRE(fs::exists(dir / "out" / "program.ngc"));
  REQUIRE(fs::exists(dir / "out" / "safety.jsonl"));
  const std::string jsonl = read_text(dir / "out" / "commands.jsonl");
  CHECK(jsonl.find("\"type\":\"axis_offsets\"") != std::string::npos);
  CHECK(jsonl.find("\"type\":\"probe_interval\"") != std::string::npos);
  CHECK(jsonl.find("\"non_compensable_um_per_m\":") != std::string::npos);
  CHECK(read_text(dir / "out" / "program.ngc").find("G10 L2 P1") != std::string::npos);
  CHECK(err.find("commands") != std::string::npos);
  CHECK(err.find("refused") != std::string::npos);
  // What no axis can cancel is said, not dropped: the largest value of the run (A: E_B0C is tens of µm/m).
  const auto at = err.find("largest non-compensable tilt ");
  REQUIRE(at != std::string::npos);
  CHECK(std::stod(err.substr(at + std::string("largest non-compensable tilt ").size())) > 1.0);

  // A bad dialect is a usage error.
  const std::string bad = std::string("\"") + ALC_CLI_PATH + "\" replay --case A --nc-out \"" + (dir / "bad").string() +
                          "\" --dialect haas > /dev/null 2>&1";
  const int bad_status = std::system(bad.c_str());
  CHECK(WIFEXITED(bad_status));
  CHECK(WEXITSTATUS(bad_status) == 2);
}
