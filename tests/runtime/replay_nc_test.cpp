// The replay's NC output: load cases A–D through NcCommandObserver, the linuxcnc program checked by
// LinuxCNC's standalone interpreter rs274, `alc replay --nc-out` end to end (A–C and B–C machines),
// and `alc replay --db --machine` (the chain of the offsets stored with the predictions).
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <tuple>
#include <utility>
#include <vector>

#include "../cli_support.hpp"
#include "../nc_interface/nc_test_support.hpp"
#include "alc/kinematics.hpp"
#include "nc_interface/dialects.hpp"
#include "nc_interface/jsonl.hpp"
#include "nc_interface/nc_number.hpp"
#include "nc_interface/recorder.hpp"
#include "runtime/replay.hpp"
#include "scenarios/load_cases.hpp"
#include "storage/history_reader.hpp"

namespace fs = std::filesystem;
namespace sc = alc::scenarios;
namespace rt = alc::runtime;
namespace nc = alc::nc;
namespace kinematics = alc::kinematics;
using alc::nc::test::g10_offsets;
using alc::nc::test::read_text;
using alc::nc::test::Rs274Run;
using alc::nc::test::var_value;
using alc::nc::test::write_text;

namespace {

// rs274 on DIR/program.ngc (written by the replay), also waiting for the simulator tests' lock.
Rs274Run run_rs274(const fs::path& dir) { return alc::nc::test::run_rs274(dir, "3001 0.0\n", true); }

std::string expected_g5x(const nc::AxisOffsets& o) {
  return "SET_G5X_OFFSET(1, " + nc::format_nc_number(o.x_mm) + ", " + nc::format_nc_number(o.y_mm) + ", " +
         nc::format_nc_number(o.z_mm) + ", " + nc::format_nc_number(o.a_deg.value_or(0.0)) + ", " +
         nc::format_nc_number(o.b_deg.value_or(0.0)) + ", " + nc::format_nc_number(o.c_deg) + ")";
}

// Every axis_offsets command within max_offset, and each within max_step of the one before, as the
// safety gate judges them: in the values as printed (what the NC receives, nc::as_printed).
void check_within_limits(const std::vector<nc::AxisOffsets>& sent, const nc::SafetyLimits& limits) {
  const nc::AxisOffsets zero;
  const auto p = [](double v) { return nc::as_printed(v); };
  for (std::size_t i = 0; i < sent.size(); ++i) {
    INFO("offset command " << i + 1);
    const nc::AxisOffsets& o = sent[i];
    const nc::AxisOffsets& before = i == 0 ? zero : sent[i - 1];
    CHECK(std::abs(p(o.x_mm)) <= limits.max_offset.x_mm);
    CHECK(std::abs(p(o.y_mm)) <= limits.max_offset.y_mm);
    CHECK(std::abs(p(o.z_mm)) <= limits.max_offset.z_mm);
    CHECK(std::abs(p(o.a_deg.value_or(0.0))) <= limits.max_offset.a_deg);
    CHECK(std::abs(p(o.b_deg.value_or(0.0))) <= limits.max_offset.b_deg);
    CHECK(std::abs(p(o.c_deg)) <= limits.max_offset.c_deg);
    CHECK(std::abs(p(o.x_mm) - p(before.x_mm)) <= limits.max_step.x_mm + 1e-12);
    CHECK(std::abs(p(o.y_mm) - p(before.y_mm)) <= limits.max_step.y_mm + 1e-12);
    CHECK(std::abs(p(o.z_mm) - p(before.z_mm)) <= limits.max_step.z_mm + 1e-12);
    CHECK(std::abs(p(o.a_deg.value_or(0.0)) - p(before.a_deg.value_or(0.0))) <= limits.max_step.a_deg + 1e-12);
    CHECK(std::abs(p(o.b_deg.value_or(0.0)) - p(before.b_deg.value_or(0.0))) <= limits.max_step.b_deg + 1e-12);
    CHECK(std::abs(p(o.c_deg) - p(before.c_deg)) <= limits.max_step.c_deg + 1e-12);
  }
}


// Runs rs274 on DIR/program.ngc: it must pass, and its G10s must set exactly `sent`, in order.
Rs274Run check_rs274_applies(const fs::path& dir, const std::vector<nc::AxisOffsets>& sent) {
  const Rs274Run r = run_rs274(dir);
  INFO("rs274 log:\n" << read_text(dir / "rs274.log"));
  REQUIRE(r.exit_code == 0);
  const std::vector<std::string> got = g10_offsets(r.canon);
  REQUIRE(got.size() == sent.size());
  for (std::size_t i = 0; i < got.size(); ++i) {
    INFO("G10 number " << i + 1);
    REQUIRE(got[i] == expected_g5x(sent[i]));
  }
  return r;
}


// Runs after the NC observer in every cycle and keeps, for each axis_offsets command it emitted,
// the prediction of the controller cycle that emitted it.
class PredictionTap : public rt::Observer {
 public:
  const rt::NcCommandObserver* nc = nullptr;
  void on_cycle(const rt::Cycle& cycle) override {
    for (std::size_t i = seen_; i < nc->commands().size(); ++i)
      if (const auto* o = std::get_if<nc::AxisOffsets>(&nc->commands()[i]))
        emitted.emplace_back(*o, cycle.out().prediction);
    seen_ = nc->commands().size();
  }
  std::vector<std::pair<nc::AxisOffsets, Eigen::VectorXd>> emitted;

 private:
  std::size_t seen_ = 0;
};

// Replays `scenario` with NC output for `chain` (files into a fresh directory); `tap` sees every cycle.
std::unique_ptr<rt::Replay> replay_with_nc(const sc::Scenario& scenario, const kinematics::MachineChain& chain,
                                           PredictionTap* tap, const std::string& tag) {
  rt::ReplayOptions o;
  o.machine.chain = chain;
  o.nc = rt::NcOutputSetup{alc::nc::test::fresh_dir("replay_nc_" + tag), nc::Dialect::LinuxCNC};
  if (tap) o.observers.push_back(tap);
  auto replay = std::make_unique<rt::Replay>(scenario, o);
  if (tap) tap->nc = replay->nc();
  replay->run();
  return replay;
}

struct EmittedCheck {
  double largest = 0.0;           // [µm/m] largest non_compensable_um_per_m of the commands
  double largest_tilt_deg = 0.0;  // [°] largest |offset| of the tilt axis (A or B)
};

// Checks every axis_offsets command `tap` saw: it has the chain's tilt axis (a_deg for A-C, b_deg for
// B-C) and not the other; it carries the non-compensable part of compensate() for the prediction of
// the cycle that emitted it; and that is |`uncancelled`| (the error no axis of the chain cancels) up to
// the O(eps^2) of the exact chain (eps ~ 1e-5 rad here).
EmittedCheck check_emitted(const PredictionTap& tap, const sc::Scenario& scenario, const rt::NcObserverOptions& options,
                           double kinematics::LocationErrors::*uncancelled) {
  REQUIRE(tap.emitted.size() > 10);
  const bool a_tilt = options.chain.tilt.name == 'A';
  EmittedCheck r;
  for (const auto& [command, prediction] : tap.emitted) {
    INFO("command at t = " << command.time_s.value_or(-1.0) << " s");
    const std::optional<double>& tilt = a_tilt ? command.a_deg : command.b_deg;
    REQUIRE(tilt.has_value());
    CHECK_FALSE((a_tilt ? command.b_deg : command.a_deg).has_value());
    r.largest_tilt_deg = std::max(r.largest_tilt_deg, std::abs(*tilt));
    REQUIRE(command.non_compensable_um_per_m.has_value());
    const auto errors = kinematics::location_errors_of(scenario.output_names, prediction);
    const kinematics::Compensation c = kinematics::compensate(options.chain, {}, errors);
    REQUIRE(c.converged);
    CHECK(*command.non_compensable_um_per_m == c.non_compensable_um_per_m);
    CHECK(std::abs(*command.non_compensable_um_per_m - std::abs(errors.*uncancelled)) < 1e-3);
    r.largest = std::max(r.largest, *command.non_compensable_um_per_m);
  }
  return r;
}

}  // namespace

TEST_CASE("replay NC output: each offset command records the non-compensable part of its prediction",
          "[replay][nc]") {
  const sc::Scenario scenario = sc::simulate_case("A").scenario;
  const rt::NcObserverOptions options;  // A-C table: what no axis cancels is the tilt E_B0C
  PredictionTap tap;
  const auto replay = replay_with_nc(scenario, options.chain, &tap, "non_compensable");
  const rt::NcCommandObserver& observer = *replay->nc();
  // For an A-C table it is |E_B0C| up to the O(eps^2) of the exact chain (eps ~ 1e-5 rad here).
  const double largest = check_emitted(tap, scenario, options, &kinematics::LocationErrors::b0c_um_per_m).largest;
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
    const auto replay = replay_with_nc(scenario, rt::NcObserverOptions{}.chain, nullptr, name);
    const rt::NcCommandObserver& observer = *replay->nc();
    REQUIRE(observer.maps_any_error());

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
        REQUIRE(o->a_deg.has_value());
        sent.push_back(*o);
      } else {
        last_interval = std::get<nc::ProbeInterval>(c).minutes.value_or(0.0);
      }
    }
    check_within_limits(sent, limits);

    const Rs274Run r = check_rs274_applies(dir, sent);
    REQUIRE(last_interval);
    CHECK(std::abs(var_value(r.var, 3001) - std::stod(nc::format_nc_number(*last_interval))) < 1e-9);
  }
}

TEST_CASE("replay NC output: a max_step that is not a multiple of the NC resolution is stepped in printed values, "
          "nothing refused",
          "[replay][nc]") {
  // Before, the emitter stepped by max_step in computed values while the NC got them rounded to
  // 0.0001: with max_step 0.00015 a step printed 0.0001, the next request 0.0003 was a printed change
  // of 0.0002 > max_step, refused, and every axis stayed where it was for the rest of the run (case A:
  // 834 commands, 829 refused, 5 written); with 0.00019 not one offset was written.
  const sc::Scenario scenario = sc::simulate_case("A").scenario;
  const double end_s = scenario.time_s.back();
  const auto ticks = [](double v) { return nc::nc_ticks(v); };
  for (const double max_step : {0.00015, 0.00019, 0.00025}) {
    INFO("max_step " << max_step << " on every axis");
    rt::ReplayOptions o;
    o.machine.limits.max_step = {max_step, max_step, max_step, max_step, max_step, max_step};
    o.nc = rt::NcOutputSetup{alc::nc::test::fresh_dir("replay_nc_fine_step"), nc::Dialect::LinuxCNC};
    PredictionTap tap;
    o.observers.push_back(&tap);
    rt::Replay replay(scenario, o);
    tap.nc = replay.nc();
    replay.run();
    const rt::NcCommandObserver& observer = *replay.nc();
    REQUIRE(replay.nc_summary());
    const nc::NcOutputSummary& s = *replay.nc_summary();
    CHECK(observer.refused() == 0);
    CHECK(s.refused == 0);
    CHECK(s.split == 0);

    // What is written: every printed change within max_step (from zero at the start), and offsets
    // throughout the run, not a handful at its start.
    std::istringstream jsonl(read_text(s.commands_file));
    std::vector<nc::AxisOffsets> sent;
    for (const nc::NcCommand& c : nc::read_commands_jsonl(jsonl, s.commands_file.string()))
      if (const auto* a = std::get_if<nc::AxisOffsets>(&c)) sent.push_back(*a);
    REQUIRE(sent.size() > 1000);
    const long long per_step = static_cast<long long>(std::floor(max_step * 1e4 + 1e-9));  // whole ticks
    nc::AxisOffsets before;
    before.a_deg = 0.0;
    for (std::size_t i = 0; i < sent.size(); ++i) {
      INFO("offset command " << i + 1);
      const nc::AxisOffsets& a = sent[i];
      REQUIRE(a.a_deg.has_value());
      for (const auto& [now, then] : {std::pair{a.x_mm, before.x_mm}, std::pair{a.y_mm, before.y_mm},
                                      std::pair{a.z_mm, before.z_mm}, std::pair{*a.a_deg, *before.a_deg},
                                      std::pair{a.c_deg, before.c_deg}})
        CHECK(std::llabs(ticks(now) - ticks(then)) <= per_step);
      before = a;
    }
    CHECK(*sent.back().time_s > end_s - 86400.0);

    // The offsets approach the requests: each command moves every axis toward the target of its
    // moment (compensate() of that cycle's prediction), as printed, none away from it and at least one
    // closer; and the target is reached again and again, not only approached.
    REQUIRE(tap.emitted.size() == sent.size());
    nc::AxisOffsets held;  // printed offsets in force before the command (zero at the start)
    held.a_deg = 0.0;
    std::size_t reached = 0;
    double last_reached_s = 0.0;
    for (const auto& [command, prediction] : tap.emitted) {
      INFO("command at t = " << *command.time_s << " s");
      const auto errors = kinematics::location_errors_of(scenario.output_names, prediction);
      const nc::AxisOffsets target =
          nc::to_axis_offsets(kinematics::compensate(o.machine.chain, {}, errors), o.machine.chain);
      long long closer = 0, gap = 0;
      for (const auto& [now, then, want] :
           {std::tuple{command.x_mm, held.x_mm, target.x_mm}, std::tuple{command.y_mm, held.y_mm, target.y_mm},
            std::tuple{command.z_mm, held.z_mm, target.z_mm}, std::tuple{*command.a_deg, *held.a_deg, *target.a_deg},
            std::tuple{command.c_deg, held.c_deg, target.c_deg}}) {
        const long long after = std::llabs(ticks(now) - ticks(want)), prior = std::llabs(ticks(then) - ticks(want));
        CHECK(after <= prior);
        closer += prior - after;
        gap = std::max(gap, after);
      }
      CHECK(closer > 0);
      if (gap == 0) {
        ++reached;
        last_reached_s = *command.time_s;
      }
      held = command;
    }
    WARN("max_step " << max_step << ": " << sent.size() << " offset commands, " << reached
                     << " of them at the target as printed, the last at " << last_reached_s / 3600.0 << " h");
    CHECK(reached > 100);  // (most commands are steps toward a target that moved)
    CHECK(last_reached_s > end_s - 86400.0);
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
  // Its header names the command that wrote it (before: "written by alc nc").
  CHECK(read_text(dir / "out" / "program.ngc")
            .rfind("(ALC thermal compensation, written by alc replay: work offsets G10 L2, probe interval #3001 [min])\n"
                   "(for the built-in twin, whose work offsets are 0: not for a real machine, whose base alc replay "
                   "--machine FILE gives)\n",
                   0) == 0);
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


TEST_CASE("replay NC output: a B-C machine gets b_deg, within the limits, and its non-compensable E_A0C is reported",
          "[replay][nc]") {
  const sc::Scenario scenario = sc::simulate_case("A").scenario;
  rt::NcObserverOptions options;
  options.chain = kinematics::MachineChain::bc_trunnion();  // B about y: what no axis cancels is E_A0C
  PredictionTap tap;
  const auto replay = replay_with_nc(scenario, options.chain, &tap, "bc");
  const rt::NcCommandObserver& observer = *replay->nc();
  // b_deg, never a_deg; and what is left is |E_A0C| up to O(eps^2), not the A-C table's |E_B0C|.
  const EmittedCheck c = check_emitted(tap, scenario, options, &kinematics::LocationErrors::a0c_um_per_m);
  CHECK(c.largest > 0.1);
  CHECK(c.largest_tilt_deg >= 1e-4);  // B does move: E_B0C is cancelled by the tilt axis here
  CHECK(observer.max_non_compensable_um_per_m() >= c.largest);
}

TEST_CASE("replay NC output: alc replay --machine with a B-C chain writes B offsets that rs274 applies",
          "[replay][nc][cli][rs274]") {
  const fs::path dir = alc::nc::test::fresh_dir("replay_cli_bc");
  // A machine file without the base of its work offset: refused for linuxcnc's G10 L2, nothing written
  // (the program would set the machine's G54 to the compensation alone).
  write_text(dir / "bc.toml", "[kinematics]\nchain = \"B-C\"\n");
  const alc_test::CliRun refused = alc_test::run_alc(
      "replay --case A --nc-out \"" + (dir / "out").string() + "\" --machine \"" + (dir / "bc.toml").string() + "\"",
      "replay_cli_bc");
  CHECK(refused.exit_code == 2);
  CHECK_THAT(refused.err, Catch::Matchers::Contains("bc.toml: linuxcnc writes G10 L2, which replaces the whole G54"));
  CHECK_FALSE(fs::exists(dir / "out" / "program.ngc"));
  write_text(dir / "bc.toml",
             "[kinematics]\nchain = \"B-C\"\n[nc.base.G54]\nx_mm = 0\ny_mm = 0\nz_mm = 0\nb_deg = 0\nc_deg = 0\n");
  const alc_test::CliRun run = alc_test::run_alc(
      "replay --case A --nc-out \"" + (dir / "out").string() + "\" --machine \"" + (dir / "bc.toml").string() + "\"",
      "replay_cli_bc");
  const std::string& err = run.err;
  INFO(err);
  REQUIRE(run.exit_code == 0);
  CHECK(err.find(" 0 refused, 0 split") != std::string::npos);
  std::istringstream jsonl(read_text(dir / "out" / "commands.jsonl"));
  const std::vector<nc::NcCommand> commands = nc::read_commands_jsonl(jsonl, "commands.jsonl");
  std::vector<nc::AxisOffsets> sent;
  double largest = 0.0, largest_b = 0.0;
  for (const nc::NcCommand& c : commands) {
    const auto* o = std::get_if<nc::AxisOffsets>(&c);
    if (!o) continue;
    CHECK_FALSE(o->a_deg.has_value());
    REQUIRE(o->b_deg.has_value());
    REQUIRE(o->non_compensable_um_per_m.has_value());
    largest = std::max(largest, *o->non_compensable_um_per_m);
    largest_b = std::max(largest_b, std::abs(*o->b_deg));
    sent.push_back(*o);
  }
  REQUIRE(sent.size() > 10);
  CHECK(largest_b >= 1e-4);
  check_within_limits(sent, nc::SafetyLimits{});  // bc.toml keeps the default limits
  // The non-compensable part (E_A0C on this chain) is on stderr as the run's maximum.
  const std::string tag = "largest non-compensable tilt ";
  const auto at = err.find(tag);
  REQUIRE(at != std::string::npos);
  const double printed = std::stod(err.substr(at + tag.size()));
  CHECK(printed > 1.0);
  CHECK(printed >= largest * (1.0 - 1e-5));  // over every moment, printed to 6 digits

  // LinuxCNC applies them: G10 L2 P1 … B… C… gives SET_G5X_OFFSET(1, x, y, z, 0, b, c).
  const std::string program = read_text(dir / "out" / "program.ngc");
  CHECK(program.find(" A") == std::string::npos);
  CHECK(program.find(" B") != std::string::npos);
  CHECK(program.find("not for a real machine") == std::string::npos);  // the machine file gives its base
  check_rs274_applies(dir / "out", sent);
  fs::remove_all(dir);
}

TEST_CASE("replay NC output: a machine file whose base lacks an axis, or gives the tilt axis the chain lacks, is "
          "refused",
          "[replay][nc][cli]") {
  // Review: [nc.base.G54] with x_mm = -350.0 alone gave exit 0 and G10 L2 P1 X-349.9900 Y0.0100
  // Z-0.0100 A-0.0010 C-0.0010 (the operator's Z became -0.0100); an A-C chain with b_deg = 5.0 and no
  // a_deg wrote A-0.0010, a B-C chain with a_deg = 5.0 wrote B-0.0009.
  const fs::path dir = alc::nc::test::fresh_dir("replay_cli_partial_base");
  const auto replay = [&](const std::string& machine_text, const std::string& dialect) {
    write_text(dir / "m.toml", machine_text);
    return alc_test::run_alc("replay --case A --nc-out \"" + (dir / "out").string() + "\" --dialect " + dialect +
                                 " --machine \"" + (dir / "m.toml").string() + "\"",
                             "replay_cli_partial_base");
  };
  const std::string machine = (dir / "m.toml").string();
  for (const char* dialect : {"linuxcnc", "fanuc"}) {
    INFO(dialect);
    const alc_test::CliRun partial = replay("[nc.base.G54]\nx_mm = -350.0\n", dialect);
    CHECK(partial.exit_code == 2);
    CHECK_THAT(partial.err, Catch::Matchers::Contains("--machine " + machine + ": [nc.base.G54] (line 1) lacks key "
                                                      "'nc.base.G54.y_mm', 'nc.base.G54.z_mm', 'nc.base.G54.a_deg', "
                                                      "'nc.base.G54.c_deg'") &&
                                Catch::Matchers::Contains("G54 Y, Z, A, C would become the compensation alone"));
    CHECK_FALSE(fs::exists(dir / "out"));
    // The B-C chain needs b_deg, not a_deg.
    const alc_test::CliRun bc_partial =
        replay("[kinematics]\nchain = \"B-C\"\n[nc.base.G54]\nx_mm = 0\ny_mm = 0\nz_mm = 0\nc_deg = 0\n", dialect);
    CHECK(bc_partial.exit_code == 2);
    CHECK_THAT(bc_partial.err, Catch::Matchers::Contains("(line 3) lacks key 'nc.base.G54.b_deg':"));
    CHECK_FALSE(fs::exists(dir / "out"));
  }
  // A tilt axis the chain does not have: the machine file is refused, whatever the dialect.
  for (const char* dialect : {"linuxcnc", "sinumerik"}) {
    INFO(dialect);
    const alc_test::CliRun ac_b =
        replay("[nc.base.G54]\nx_mm = 0\ny_mm = 0\nz_mm = 0\nb_deg = 5.0\nc_deg = 0\n", dialect);
    CHECK(ac_b.exit_code == 2);
    CHECK_THAT(ac_b.err, Catch::Matchers::Contains(machine + ": key 'nc.base.G54.b_deg' (line 5): the machine's chain "
                                                   "(kinematics.chain) is A-C, which has no B axis") &&
                             Catch::Matchers::Contains("value '5'"));
    const alc_test::CliRun bc_a = replay(
        "[kinematics]\nchain = \"B-C\"\n[nc.base.G54]\nx_mm = 0\ny_mm = 0\nz_mm = 0\na_deg = 5.0\nc_deg = 0\n", dialect);
    CHECK(bc_a.exit_code == 2);
    CHECK_THAT(bc_a.err, Catch::Matchers::Contains(machine + ": key 'nc.base.G54.a_deg' (line 7): the machine's chain "
                                                   "(kinematics.chain) is B-C, which has no A axis"));
    CHECK_FALSE(fs::exists(dir / "out"));
  }
  // Sinumerik writes no base: a partial table is not in its way.
  CHECK(replay("[nc.base.G54]\nx_mm = -350.0\n", "sinumerik").exit_code == 0);
  fs::remove_all(dir / "out");
  // The complete base is accepted and written: base + compensation on every axis.
  const alc_test::CliRun complete =
      replay("[nc.base.G54]\nx_mm = -350.0\ny_mm = 10.0\nz_mm = -420.0\na_deg = 0.0\nc_deg = 90.0\n", "linuxcnc");
  INFO(complete.err);
  REQUIRE(complete.exit_code == 0);
  CHECK(complete.err.find(" 0 refused, 0 split") != std::string::npos);
  const std::string program = read_text(dir / "out" / "program.ngc");
  CHECK_THAT(program, Catch::Matchers::Contains("G21 G10 L2 P1 X-349.9900 Y10.0100 Z-420.0100 A-0.0010 C89.9990"));
  fs::remove_all(dir);
}

TEST_CASE("replay NC output: --nc-out into a directory with another dialect's program removes it and says so",
          "[replay][nc][cli]") {
  // Review: case A (linuxcnc, G55, base -350) into st/, then case B with --dialect fanuc into st/: st/
  // had B's commands.jsonl and program.nc beside A's program.ngc, and nothing warned.
  const fs::path dir = alc::nc::test::fresh_dir("replay_cli_stale");
  write_text(dir / "g55.toml", "[nc]\nwork_offset = \"G55\"\n[nc.base.G55]\nx_mm = -350.0\ny_mm = 0\nz_mm = 0\na_deg = 0\n"
                               "c_deg = 0\n");
  const std::string out = (dir / "st").string();
  const alc_test::CliRun a = alc_test::run_alc(
      "replay --case A --nc-out \"" + out + "\" --machine \"" + (dir / "g55.toml").string() + "\"", "replay_cli_stale");
  REQUIRE(a.exit_code == 0);
  CHECK(a.err.find("removed") == std::string::npos);
  REQUIRE(fs::exists(dir / "st" / "program.ngc"));
  write_text(dir / "st" / "notes.txt", "the operator's\n");
  const alc_test::CliRun b = alc_test::run_alc("replay --case B --nc-out \"" + out + "\" --dialect fanuc", "replay_cli_stale");
  INFO(b.err);
  REQUIRE(b.exit_code == 0);
  CHECK_THAT(b.err, Catch::Matchers::Contains("case B: removed " + (dir / "st" / "program.ngc").string() +
                                              ", the program of an earlier run in another dialect (this run's is " +
                                              (dir / "st" / "program.nc").string() + ")"));
  CHECK_FALSE(fs::exists(dir / "st" / "program.ngc"));
  const std::string program = read_text(dir / "st" / "program.nc");
  CHECK_THAT(program, Catch::Matchers::Contains("G90 G10 L2 P1") && !Catch::Matchers::Contains("P2"));
  CHECK(read_text(dir / "st" / "notes.txt") == "the operator's\n");  // not ALC's: left alone
  // Nothing but commands.jsonl, program.nc, safety.jsonl and the operator's file.
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir / "st")) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  CHECK(names == std::vector<std::string>{"commands.jsonl", "notes.txt", "program.nc", "safety.jsonl"});
  fs::remove_all(dir);
}

TEST_CASE("replay: --machine with --db alone gives the chain of the stored offsets, and --resume must repeat it",
          "[replay][cli]") {
  const fs::path dir = alc::nc::test::fresh_dir("replay_db_machine");
  write_text(dir / "bc.toml", "[kinematics]\nchain = \"B-C\"\n");
  const std::string machine = " --machine \"" + (dir / "bc.toml").string() + "\"";
  const std::string db = " --db \"" + (dir / "h.sqlite").string() + "\"";
  const auto run = [](const std::string& args) { return alc_test::run_alc(args, "replay_db_machine"); };
  // Without --nc-out or --db nothing would use it.
  alc_test::CliRun r = run("replay --case A" + machine);
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("--machine needs --nc-out or --db") != std::string::npos);
  r = run("replay --case A --dialect fanuc");
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("--dialect needs --nc-out") != std::string::npos);

  r = run("replay --case A --stop-at 60" + db + machine);
  REQUIRE(r.exit_code == 0);
  // A resume without the machine (or with another) would store the rest through another chain.
  r = run("replay --case A --resume" + db);
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("other parameters") != std::string::npos);
  // The machine is its content: the file edited is another machine (before, only the path text was
  // compared, so the edited geometry was taken and one run held offsets of two machines) ...
  write_text(dir / "bc.toml", "[kinematics]\nchain = \"A-C\"\n");
  r = run("replay --case A --resume" + db + machine);
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("/machine_hash: stored \"") != std::string::npos);
  write_text(dir / "bc.toml", "[kinematics]\nchain = \"B-C\"\n");
  // ... and the same file by another path is the same machine (before: refused, stored "…/bc.toml").
  r = run("replay --case A --resume" + db + " --machine \"" + (dir / "." / "bc.toml").string() + "\"");
  INFO(r.err);
  REQUIRE(r.exit_code == 0);

  const alc::storage::HistoryReader reader(dir / "h.sqlite");
  const auto runs = reader.runs();
  REQUIRE(runs.size() == 1);
  CHECK(runs[0].offset_names == std::vector<std::string>{"X_um", "Y_um", "Z_um", "B_urad", "C_urad"});
  const auto predictions = reader.predictions(runs[0].run_id);
  REQUIRE(predictions.size() > 1000);
  std::size_t tilted = 0;
  for (std::size_t i = 0; i < predictions.size(); i += 97) {  // before and after the stop
    const auto& p = predictions[i];
    INFO("prediction at t = " << p.time_s << " s");
    const Eigen::VectorXd predicted = Eigen::Map<const Eigen::VectorXd>(p.predicted.data(),
                                                                        static_cast<Eigen::Index>(p.predicted.size()));
    const auto errors = kinematics::location_errors_of(runs[0].output_names, predicted);
    const kinematics::Compensation bc = kinematics::compensate(kinematics::MachineChain::bc_trunnion(), {}, errors);
    REQUIRE(bc.converged);
    REQUIRE(p.offsets.size() == 5);
    CHECK(p.offsets[3] == bc.offsets.tilt_urad);  // the B-C chain's, bit for bit
    CHECK(p.offsets[4] == bc.offsets.table_urad);
    const kinematics::Compensation ac = kinematics::compensate(kinematics::MachineChain::ac_trunnion(), {}, errors);
    if (std::abs(ac.offsets.tilt_urad - bc.offsets.tilt_urad) > 1e-3) ++tilted;  // and not the A-C default's
  }
  CHECK(tilted > 10);
  CHECK(predictions.back().time_s > 60 * 3600.0);
  fs::remove_all(dir);
}
