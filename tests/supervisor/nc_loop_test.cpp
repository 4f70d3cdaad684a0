// The supervisor's closed loop with a real NC: `alc supervise` with [nc] sink = "linuxcncrsh" on the
// headless LinuxCNC simulator (linuxcnc-uspace) and a real mosquitto, both started by the test.
// - the offsets the NC holds are those the supervisor published after the safety gate, refused ones
//   are not applied, and the compensation it learns with is what the NC holds (read back);
// - the NC going down is an event and a history row (delivered = 0), and the supervisor keeps going;
// - probe = "linuxcnc": the supervisor runs G38.2 itself against a HAL surface that the test moves
//   with the twin's error, and learns that error within the probe's resolution.
// Tagged [linuxcnc]: these tests hold the linuxcnc and mqtt CTest locks (tests/CMakeLists.txt).
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <memory>

#include "../linuxcnc_sim_support.hpp"
#include "mqtt_test_support.hpp"
#include "nc_interface/transports.hpp"
#include "storage/history_reader.hpp"

using namespace alc;
using namespace alc::supervisor::test;
using alc::nc::test::MachineLock;
using alc::nc::test::Simulator;

namespace {

int sim_port() { return 20000 + static_cast<int>((::getpid() + 7919) % 20000); }

// The supervisor's config: case A's signals, the NC on the simulator's linuxcncrsh.
std::string nc_config(const scenarios::Scenario& s, int broker_port, int sim_port, const std::string& nc_extra) {
  // A short calibration phase with fewer probes: a model, offsets and post-CP probes within hours.
  std::string text = case_config(s, broker_port);
  const std::string cp = "cp = 6.5\ninterval = 2\n";
  REQUIRE(text.find(cp) != std::string::npos);
  text.replace(text.find(cp), cp.size(), "cp = 2\ncp-interval = 15\ninterval = 1\n");
  return text + "[nc]\nmachine = \"machine.toml\"\nsink = \"linuxcncrsh\"\nport = " +
         std::to_string(sim_port) + "\ntimeout_s = 20\nretry_s = 1\n" + nc_extra;
}

nc::AxisOffsets axis_of(const Json& j) {
  nc::AxisOffsets o;
  o.x_mm = j.at("x_mm").get<double>();
  o.y_mm = j.at("y_mm").get<double>();
  o.z_mm = j.at("z_mm").get<double>();
  o.a_deg = j.at("a_deg").get<double>();
  o.c_deg = j.at("c_deg").get<double>();
  return o;
}

Json last_on(const Client& c, const std::string& topic) {
  Json last;
  for (const auto& [t, p] : c.received)
    if (t == "alc/dmu-1/" + topic) last = Json::parse(p);
  return last;
}

std::size_t events_of(const Client& c, const std::string& type) {
  std::size_t n = 0;
  for (const Json& e : c.events()) n += e.value("type", "") == type;
  return n;
}

// G54 as the NC holds it, read back by a session of the test's own (the supervisor is stopped).
std::array<double, 6> g54_of(int port) {
  nc::LinuxcncrshOptions o;
  o.port = port;
  o.timeout_s = 20.0;
  nc::LinuxcncrshClient client(o);
  client.connect();
  return client.work_offset_values(1);
}

// `alc supervise` of a test: stopped with SIGTERM by stop(), or killed if the test ends early.
struct Supervise {
  pid_t pid = -1;
  explicit Supervise(const fs::path& dir) : pid(start_supervisor(dir)) {}
  int stop() {
    ::kill(pid, SIGTERM);
    const int status = wait_exit(pid);
    pid = -1;
    return status;
  }
  ~Supervise() {
    if (pid <= 0) return;
    ::kill(pid, SIGKILL);
    wait_exit(pid);
  }
};

}  // namespace

TEST_CASE("nc loop: offsets reach the LinuxCNC simulator through the gate, are read back as the compensation in force and continue after a restart", "[linuxcnc]") {
  MosquittoLib lib;
  const MachineLock lock;
  const fs::path dir = temp_dir("nc-loop");
  const int port = sim_port();
  fs::create_directories(dir / "sim");
  Simulator sim(dir / "sim", port);
  sim.wait_ready([&] {
    nc::LinuxcncrshOptions o;
    o.port = port;
    o.timeout_s = 20.0;
    return o;
  }());
  Broker broker(dir, false);
  const scenarios::Scenario s = case_a(6.0);
  // Y steps of at most 2 µm up to a max_offset of 5 µm that the predicted Y offset (about 10 µm)
  // exceeds: two steps are taken, the third is refused by the gate.
  write(dir / "machine.toml", "[limits.max_offset]\ny_mm = 0.005\n[limits.max_step]\ny_mm = 0.002\n");
  write(dir / "s.toml", nc_config(s, broker.port, port, ""));
  Client c(broker.port, "twin-gateway");
  Gateway g(s, c);
  auto sup = std::make_unique<Supervise>(dir);
  const std::size_t rows = s.samples() * 2 / 3;
  g.play(rows);
  REQUIRE(sup->stop() == 0);

  // What the NC holds is what the supervisor published last, after the gate.
  const Json offsets = last_on(c, "offsets");
  REQUIRE(offsets.contains("axis"));
  const nc::AxisOffsets published = axis_of(offsets["axis"]);
  const auto g54 = g54_of(port);
  INFO("published " << offsets["axis"].dump() << ", G54 " << g54[0] << " " << g54[1] << " " << g54[2] << " " << g54[3]
                    << " " << g54[5]);
  CHECK_THAT(g54[0], Catch::Matchers::WithinAbs(published.x_mm, 0.5e-4));
  CHECK_THAT(g54[1], Catch::Matchers::WithinAbs(published.y_mm, 0.5e-4));
  CHECK_THAT(g54[2], Catch::Matchers::WithinAbs(published.z_mm, 0.5e-4));
  CHECK_THAT(g54[3], Catch::Matchers::WithinAbs(*published.a_deg, 0.5e-4));
  CHECK_THAT(g54[5], Catch::Matchers::WithinAbs(published.c_deg, 0.5e-4));
  CHECK(std::abs(g54[1]) <= 0.005 + 0.5e-4);  // never beyond max_offset
  CHECK(std::abs(g54[1]) >= 0.002 - 0.5e-4);  // but some of the way

  const storage::HistoryReader h(dir / "h.sqlite");
  const auto run = h.runs().back().run_id;
  std::size_t accepted = 0, refused = 0;
  for (const auto& r : h.nc_commands(run)) {
    INFO(r.kind << " at " << r.time_s << ": " << r.text << " " << r.message << " " << r.delivery_message);
    CHECK(r.sink == "linuxcncrsh 127.0.0.1:" + std::to_string(port));
    if (r.accepted) {
      ++accepted;
      CHECK(r.delivered == std::optional<bool>(true));
    } else {
      ++refused;
      CHECK_FALSE(r.delivered.has_value());
      CHECK(r.message.find("max_offset") != std::string::npos);
    }
  }
  CHECK(accepted >= 3);
  CHECK(refused >= 1);
  // The compensation it learns with is what the NC held (read back, in the error space): the twin
  // measured with the compensation it was last told, so measured + compensation is the recorded
  // reading to the NC resolution (0.0001 mm, 0.0001° = 1.7 µrad).
  const auto probes = h.probe_measurements(run);
  REQUIRE(probes.size() >= 3);
  std::size_t compared = 0;
  for (const auto& p : probes) {
    std::size_t row = 0;
    while (row < s.samples() && s.time_s[row] < p.time_s) ++row;
    REQUIRE(row < s.samples());
    for (std::size_t j = 0; j < s.output_names.size(); ++j) {
      const double reading = s.outputs(static_cast<Eigen::Index>(row), static_cast<Eigen::Index>(j));
      if (!std::isfinite(reading) || p.compensation.empty()) continue;
      INFO(s.output_names[j] << " at " << p.time_s << ": measured " << p.measured[j] << " + compensation "
                             << p.compensation[j] << " vs reading " << reading);
      CHECK_THAT(p.measured[j] + p.compensation[j], Catch::Matchers::WithinAbs(reading, 1.0));
      compared += p.compensation[j] != 0.0;
    }
  }
  CHECK(compared >= 3);

  // Restarted, it reads back what the NC holds and goes on delivering.
  sup = std::make_unique<Supervise>(dir);
  g.play(s.samples() - 40);
  CHECK(sup->stop() == 0);
  CHECK(events_of(c, "NcDeliveryFailed") == 0);
  CHECK(events_of(c, "NcResync") == 0);
  const storage::HistoryReader h2(dir / "h.sqlite");
  for (const auto& r : h2.nc_commands(run)) CHECK(r.delivered != std::optional<bool>(false));
  const auto g54_end = g54_of(port);
  const nc::AxisOffsets end = axis_of(last_on(c, "offsets")["axis"]);
  CHECK_THAT(g54_end[0], Catch::Matchers::WithinAbs(end.x_mm, 0.5e-4));
  CHECK_THAT(g54_end[2], Catch::Matchers::WithinAbs(end.z_mm, 0.5e-4));
}

TEST_CASE("nc loop: the NC going down is an event and a history row and the supervisor keeps running", "[linuxcnc]") {
  MosquittoLib lib;
  const MachineLock lock;
  const fs::path dir = temp_dir("nc-down");
  const int port = sim_port();
  fs::create_directories(dir / "sim");
  Simulator sim(dir / "sim", port);
  nc::LinuxcncrshOptions rsh;
  rsh.port = port;
  rsh.timeout_s = 20.0;
  sim.wait_ready(rsh);
  Broker broker(dir, false);
  const scenarios::Scenario s = case_a(3.0);
  write(dir / "machine.toml", "");
  write(dir / "s.toml", nc_config(s, broker.port, port, ""));
  Client c(broker.port, "twin-gateway");
  Gateway g(s, c);
  Supervise sup(dir);
  g.play(60);  // an hour of the calibration phase, the NC up
  CHECK(events_of(c, "NcDeliveryFailed") == 0);
  // The NC goes down before the end of the calibration phase (2 h), which sends a new probe interval
  // and the first offsets: they cannot be delivered.
  sim.stop(nullptr);
  REQUIRE_FALSE(sim.running());
  g.play(s.samples() - 20);
  CHECK(g.processed() >= static_cast<std::int64_t>(s.samples() - 20));
  CHECK(events_of(c, "NcDeliveryFailed") >= 1);
  CHECK(events_of(c, "NcReadBackFailed") >= 1);  // the probe requests' compensation: what it is known to hold
  CHECK(c.state().value("online", false));
  // Held safely: the offsets published are what the NC held when it went down (zero: none were sent).
  const nc::AxisOffsets held = axis_of(last_on(c, "offsets")["axis"]);
  CHECK(held.x_mm == 0.0);
  CHECK(held.z_mm == 0.0);
  CHECK(sup.stop() == 0);
  const storage::HistoryReader h(dir / "h.sqlite");
  const auto run = h.runs().back().run_id;
  std::size_t failed = 0, offsets = 0;
  for (const auto& r : h.nc_commands(run)) {
    if (r.delivered != std::optional<bool>(false)) continue;
    ++failed;
    offsets += r.kind == "offsets";
    INFO(r.delivery_message);
    CHECK(r.delivery_message.find("linuxcncrsh") != std::string::npos);
  }
  CHECK(failed >= 2);
  CHECK(offsets >= 1);
}

TEST_CASE("nc loop: probe = linuxcnc runs G38.2 on the simulator and learns the surface shift", "[linuxcnc]") {
  MosquittoLib lib;
  const MachineLock lock;
  const fs::path dir = temp_dir("nc-probe");
  const int port = sim_port();
  constexpr double kNominalZ = -5.0;  // [mm] the surface without error, work coordinates (G54 base 0)
  fs::create_directories(dir / "sim");
  Simulator sim(dir / "sim", port, true, kNominalZ);
  nc::LinuxcncrshOptions rsh;
  rsh.port = port;
  rsh.timeout_s = 20.0;
  sim.wait_ready(rsh);
  Broker broker(dir, false);
  // Case A to the first post-CP probe (CP 2 h, then every hour), and its twin's true E_Z0T.
  const scenarios::SimulatedCase twin_case = scenarios::simulate_case("A");
  const scenarios::Scenario s = case_a(3.1);
  const auto& names = twin_case.truth.error_names;
  const int truth_z = static_cast<int>(std::find(names.begin(), names.end(), "E_Z0T") - names.begin());
  REQUIRE(truth_z < static_cast<int>(names.size()));
  write(dir / "machine.toml", "");
  constexpr double kFeed = 30.0;  // [mm/min]
  // The NC probe cycle measures E_Z0T only: it is the one output (others would never be identified).
  std::string config = nc_config(s, broker.port, port,
                                 "probe = \"linuxcnc\"\n[nc.probe_cycle]\npoint_mm = [10.0, 20.0, " +
                                      std::to_string(kNominalZ) + "]\nfeed_mm_min = " + std::to_string(kFeed) +
                                      "\nclearance_mm = 1\napproach_mm = 0.2\nsearch_mm = 0.2\n");
  const std::size_t from = config.find("outputs = ");
  config.replace(from, config.find('\n', from) - from, "outputs = [\"E_Z0T\"]");
  write(dir / "s.toml", config);
  // The twin's tool error along Z [µm] at time t (the sample at t).
  const auto twin = [&](double t) {
    std::size_t row = 0;
    while (row + 1 < s.samples() && s.time_s[row] < t) ++row;
    return twin_case.truth.errors(static_cast<Eigen::Index>(row), truth_z);
  };
  Client c(broker.port, "twin-gateway");
  Supervise sup(dir);
  REQUIRE(c.until([&] { return c.state().value("online", false); }));
  // One sample at a time: the surface is where the twin's error puts it when the supervisor probes.
  const std::size_t rows = s.samples();
  for (std::size_t row = 0; row < rows; ++row) {
    REQUIRE(sim.set_surface(kNominalZ - twin(s.time_s[row]) / 1000.0));
    c.publish("sample", sample_json(s, row));
    REQUIRE(c.until([&] { return c.state().value("samples", 0) == static_cast<int>(row + 1) && c.state().value("held", 1) == 0; }, 60));
  }
  CHECK(sup.stop() == 0);
  CHECK(events_of(c, "NcProbeFailed") == 0);
  CHECK(events_of(c, "NcProbe") >= 3);
  for (const auto& [t, p] : c.received) CHECK(t != "alc/dmu-1/probe/request");  // no request to a gateway

  const storage::HistoryReader h(dir / "h.sqlite");
  const auto run = h.runs().back().run_id;
  const auto probes = h.probe_measurements(run);
  REQUIRE(probes.size() >= 3);
  const int z = 0;  // E_Z0T, the only output
  // The simulated probe trips in the first servo period (1 ms) below the surface and motion latches
  // the position one period later: the probed Z lies 1 to 2 periods of travel at the probing feed
  // beyond the surface. That is the resolution of this probe [µm].
  const double period_um = kFeed / 60.0 * 1e-3 * 1000.0;
  bool compensated = false;
  for (const auto& p : probes) {
    const double learned = p.measured[static_cast<std::size_t>(z)] + p.compensation[static_cast<std::size_t>(z)];
    INFO("probe at " << p.time_s << ": measured " << p.measured[static_cast<std::size_t>(z)] << " + compensation "
                     << p.compensation[static_cast<std::size_t>(z)] << " vs twin " << twin(p.time_s));
    CHECK(learned - twin(p.time_s) >= period_um - 1e-6);
    CHECK(learned - twin(p.time_s) <= 2.0 * period_um + 1e-6);
    compensated = compensated || std::abs(p.compensation[static_cast<std::size_t>(z)]) > 1.0;
    CHECK(p.measured.size() == 1);
  }
  CHECK(compensated);  // the offsets were in force while probing (closed loop)
}
