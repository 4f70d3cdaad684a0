// The supervisor: its config and messages (no broker), and `alc supervise` on a real mosquitto
// started by the test on a free port of 127.0.0.1 (stopped by its PID), with a twin gateway that plays
// load case A through the broker and answers probe requests in closed loop.
#include <sqlite3.h>

#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <limits>
#include <nlohmann/json.hpp>

#include "runtime/replay.hpp"
#include "scenarios/load_cases.hpp"
#include "storage/history_reader.hpp"
#include "supervisor/config.hpp"
#include "supervisor/messages.hpp"
#include "supervisor_test_support.hpp"

using namespace alc;
using namespace alc::supervisor_test;

namespace {

std::string config_text(const std::string& extra_signals = "", const std::string& mqtt = "") {
  return "machine_id = \"dmu-1\"\n[mqtt]\nhost = \"127.0.0.1\"\nport = 1883\n" + mqtt +
         "[signals]\ninputs = [\"T_ENV\", \"T_WS\"]\noutputs = [\"E_X0C\", \"E_Y0C\"]\n" + extra_signals +
         "[history]\ndb = \"h.sqlite\"\n[controller]\ncp = 6.5\ninterval = 2\n";
}

std::string error_of(const std::string& text) {
  try {
    supervisor::parse_supervisor_config(text, "/tmp/s.toml");
  } catch (const supervisor::ConfigError& e) {
    return e.what();
  }
  return "";
}

// RMSE per output of (recorded measurement - stored prediction) at the probed rows after `from_s`.
std::vector<double> rmse_of(const fs::path& db, const scenarios::Scenario& s, double from_s, std::size_t rows) {
  const storage::HistoryReader r(db);
  const auto run = r.runs().back().run_id;
  const auto samples = r.input_samples(run);
  const auto predictions = r.predictions(run);
  REQUIRE(predictions.size() == samples.size());
  std::vector<double> sum(s.output_names.size(), 0.0);
  std::vector<int> n(s.output_names.size(), 0);
  for (std::size_t k = 0; k < samples.size() && k < rows; ++k) {
    REQUIRE(samples[k].time_s == s.time_s[k]);
    if (s.time_s[k] < from_s) continue;
    for (std::size_t j = 0; j < s.output_names.size(); ++j) {
      const double m = s.outputs(static_cast<Eigen::Index>(k), static_cast<Eigen::Index>(j));
      if (!std::isfinite(m)) continue;
      sum[j] += std::pow(m - predictions[k].predicted[j], 2);
      ++n[j];
    }
  }
  for (std::size_t j = 0; j < sum.size(); ++j) sum[j] = n[j] ? std::sqrt(sum[j] / n[j]) : 0.0;
  return sum;
}

}  // namespace

TEST_CASE("config errors name the file and the key and the value") {
  CHECK(error_of(config_text()).empty());
  CHECK(error_of("[mqtt]\n").find("/tmp/s.toml: key 'machine_id': missing") != std::string::npos);
  // A TOML syntax error: file:line:column (before: "key '(syntax)': ... at line 2", no column).
  CHECK_THAT(error_of("machine_id = \"dmu-1\"\n[mqtt\n"), Catch::StartsWith("/tmp/s.toml:2:6: "));
  const std::string bad_cp = config_text() + "cp2 = 1\n";
  CHECK(error_of(bad_cp).find("key 'controller.cp2', value 1: not an option of alc replay") != std::string::npos);
  std::string neg = config_text();
  neg.replace(neg.find("cp = 6.5"), 8, "cp = -1");
  CHECK(error_of(neg).find("key 'controller.cp', value -1") != std::string::npos);
  CHECK(error_of(config_text("stale_after_s = \"x\"\n")).find("key 'signals.stale_after_s', value \"x\"") !=
        std::string::npos);
  CHECK(error_of(config_text("", "keepalive_s = 1\n")).find("key 'mqtt.keepalive_s', value 1: not a whole number from 5") != std::string::npos);
  CHECK(error_of(config_text("colour = 1\n")).find("key 'signals.colour', value 1: unknown key") != std::string::npos);
  CHECK(error_of(config_text("", "password_file = \"pw\"\n")).find("needs mqtt.username") != std::string::npos);
  // [controller] takes its values as a study grid does (one conversion): no hex, a number in a string
  // is that number, and the value is named as written. Before, cp = 0x10 was taken as 16 h.
  std::string hex = config_text();
  hex.replace(hex.find("cp = 6.5"), 8, "cp = 0x10");
  CHECK_THAT(error_of(hex), Catch::Contains("key 'controller.cp', value 0x10: write it in decimal digits"));
  std::string quoted = config_text();
  quoted.replace(quoted.find("cp = 6.5"), 8, "cp = \"6.50\"");
  CHECK(error_of(quoted).empty());
  // The key at fault: machine_id where it makes the topic prefix, mqtt.prefix where that is given.
  std::string id = config_text();
  id.replace(id.find("dmu-1"), 5, "dmu/1#");
  CHECK(error_of(id).find("key 'machine_id', value \"dmu/1#\": must not contain # or +") != std::string::npos);
  CHECK(error_of(config_text("", "prefix = \"alc/#\"\n")).find("key 'mqtt.prefix'") != std::string::npos);
  // An input named like an error would be an output of every scenario CSV made of the run.
  std::string e_input = config_text();
  e_input.replace(e_input.find("\"T_WS\""), 6, "\"E_X0C\"");
  CHECK(error_of(e_input).find("key 'signals.inputs'") != std::string::npos);
  CHECK(error_of(e_input).find("'E_X0C' starts with E_") != std::string::npos);
  // A combination the controller refuses: named by the option and its value.
  std::string longer = config_text();
  longer.replace(longer.find("cp = 6.5"), 8, "cp = 1\ncp-interval = 90");
  CHECK(error_of(longer).find("invalid parameters: cp-interval = 90 (cp_interval_s = 5400): must not exceed cp = 1 h") !=
        std::string::npos);
  // The same names and units as alc replay: interval in hours.
  const auto c = supervisor::parse_supervisor_config(config_text(), "/tmp/s.toml");
  CHECK(c.parameters.post_cp_interval_s == 7200.0);
  CHECK(c.history.db == fs::path("/tmp/h.sqlite"));
  CHECK(c.mqtt.prefix == "alc/dmu-1");
}

TEST_CASE("a log file that cannot be opened is a configuration error: exit 2 naming log.file, not restarted by its unit") {
  const fs::path dir = temp_dir("log-file");
  write(dir / "s.toml", config_text() + "[log]\nfile = \"" + (dir / "no_such_dir" / "alc.log").string() + "\"\n");
  const pid_t pid = spawn({ALC_CLI_PATH, "supervise", "--config", (dir / "s.toml").string()}, dir / "out.log");
  CHECK(wait_exit(pid) == 2);
  std::ifstream in(dir / "out.log");
  const std::string out((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  CHECK_THAT(out, Catch::Contains("key 'log.file'") && Catch::Contains("no_such_dir"));
}

TEST_CASE("a history.db or spool_dir in a directory that is not there and a tls_ca_file that cannot be read are configuration errors") {
  const fs::path dir = temp_dir("config-paths");
  const auto run = [&](const std::string& text) {
    write(dir / "s.toml", text);
    const pid_t pid = spawn({ALC_CLI_PATH, "supervise", "--config", (dir / "s.toml").string()}, dir / "out.log");
    const int code = wait_exit(pid);
    std::ifstream in(dir / "out.log");
    return std::make_pair(code, std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>()));
  };
  // Before: the directories were created and a new history begun (a typo lost months of learning).
  std::string typo = config_text();
  typo.replace(typo.find("db = \"h.sqlite\""), 15, "db = \"histroy/h.sqlite\"");
  const auto [code, out] = run(typo);
  CHECK(code == 2);
  CHECK_THAT(out, Catch::Contains("key 'history.db'") && Catch::Contains("histroy") &&
                      Catch::Contains("does not exist (it is not created)"));
  CHECK_FALSE(fs::exists(dir / "histroy"));
  // Before: "mqtt: tls_set: Invalid function arguments provided.", exit 1 (restarted by its unit).
  const auto [ca_code, ca_out] = run(config_text("", "tls_ca_file = \"nope.pem\"\n"));
  CHECK(ca_code == 2);
  CHECK_THAT(ca_out, Catch::Contains("key 'mqtt.tls_ca_file'") && Catch::Contains("nope.pem") &&
                         Catch::Contains("cannot be read"));
  // A directory as the CA file (mosquitto's capath is a directory): before, it connected and retried.
  const auto [cadir_code, cadir_out] = run(config_text("", "tls_ca_file = \"" + dir.string() + "\"\n"));
  CHECK(cadir_code == 2);
  CHECK_THAT(cadir_out, Catch::Contains("key 'mqtt.tls_ca_file'") && Catch::Contains("cannot be read as a file"));
  // A spool directory that is not there: before, found at the first offsets (not delivered).
  write(dir / "machine.toml", "[nc.base.G54]\nx_mm = 0\ny_mm = 0\nz_mm = 0\na_deg = 0\nc_deg = 0\n");
  const auto [spool_code, spool_out] =
      run(config_text() + "[nc]\nmachine = \"machine.toml\"\nsink = \"spool\"\nspool_dir = \"nospool\"\n");
  CHECK(spool_code == 2);
  CHECK_THAT(spool_out, Catch::Contains("key 'nc.spool_dir'") && Catch::Contains("nospool") &&
                            Catch::Contains("is not a directory"));
  CHECK_FALSE(fs::exists(dir / "nospool"));
}

TEST_CASE("a run that the configuration no longer matches is refused naming alc db finish, after which a new run begins") {
  // Before, the refusal said "finish that run", and no command did.
  const fs::path dir = temp_dir("new-run");
  const fs::path db = dir / "h.sqlite";
  std::string text = config_text();
  text.replace(text.find("port = 1883"), 11, "port = " + std::to_string(free_port()));  // no broker: it retries
  write(dir / "s.toml", text);
  const auto runs = [&] {
    try {
      return storage::HistoryReader(db).runs();
    } catch (const std::exception&) {  // not created yet
      return std::vector<storage::RunRecord>{};
    }
  };
  // Starts the supervisor and stops it with SIGTERM once it has `count` runs; its exit status.
  const auto start_until = [&](std::size_t count) {
    pid_t pid = spawn({ALC_CLI_PATH, "supervise", "--config", (dir / "s.toml").string()}, dir / "out.log");
    ChildGuard guard{pid};
    for (int i = 0; i < 600 && runs().size() < count; ++i) sleep_ms(100);
    ::kill(pid, SIGTERM);
    const int code = wait_exit(pid);
    pid = 0;
    return code;
  };
  REQUIRE(start_until(1) == 0);
  REQUIRE(runs().size() == 1);
  CHECK(runs()[0].status == storage::RunStatus::Stopped);

  std::string other = text;
  other.replace(other.find("cp = 6.5"), 8, "cp = 8");
  write(dir / "s.toml", other);
  const pid_t refused = spawn({ALC_CLI_PATH, "supervise", "--config", (dir / "s.toml").string()}, dir / "refused.log");
  CHECK(wait_exit(refused) == 2);
  const std::string why = read_text(dir / "refused.log");
  CHECK_THAT(why, Catch::Contains("run 1 of 'supervisor dmu-1' was started with other parameters") &&
                      Catch::Contains("to begin a new run in this history, end that one: alc db finish ") &&
                      Catch::Contains("h.sqlite' --run 1"));
  CHECK(runs().size() == 1);

  const pid_t finish = spawn({ALC_CLI_PATH, "db", "finish", db.string(), "--run", "1"}, dir / "finish.log");
  CHECK(wait_exit(finish) == 0);
  CHECK_THAT(read_text(dir / "finish.log"), Catch::Contains("run 1 of 'supervisor dmu-1' is finished (it was stopped)"));
  const pid_t again = spawn({ALC_CLI_PATH, "db", "finish", db.string(), "--run", "1"}, dir / "again.log");
  CHECK(wait_exit(again) == 1);
  CHECK_THAT(read_text(dir / "again.log"), Catch::Contains("run 1 of 'supervisor dmu-1' is finished already; nothing changed"));
  REQUIRE(start_until(2) == 0);
  const auto after = runs();
  REQUIRE(after.size() == 2);
  CHECK(after[0].status == storage::RunStatus::Finished);
  CHECK(after[1].status == storage::RunStatus::Stopped);  // the new run, begun with cp = 8, stopped by SIGTERM
  CHECK(after[1].config_json.find("\"cp_duration_s\":28800") != std::string::npos);
  fs::remove_all(dir);
}

TEST_CASE("messages are refused with the reason named") {
  const std::vector<std::string> in = {"T_ENV", "T_WS"};
  auto reason = [&](const std::string& p) {
    auto r = supervisor::parse_sample(p, in);
    return std::holds_alternative<supervisor::Refusal>(r) ? std::get<supervisor::Refusal>(r).reason : "";
  };
  CHECK(reason("{\"time_s\": 1, \"inputs\": {\"T_ENV\": 1, \"T_WS\": 2}}").empty());
  CHECK_THAT(reason("{\"time_s\": 1, \"inputs\": {"), Catch::StartsWith("invalid JSON: at column 26: "));  // one past the end
  // A key given twice is refused, not read as the last of them.
  CHECK(reason("{\"time_s\": 1, \"inputs\": {\"T_ENV\": 1, \"T_WS\": 2, \"T_WS\": 3}}") ==
        "invalid JSON: duplicate key 'T_WS'");
  CHECK(reason("{\"time_s\": 1, \"inputs\": {\"T_ENV\": 1}}") == "input T_WS is missing");
  CHECK(reason("{\"time_s\": 1, \"inputs\": {\"T_ENV\": 1, \"T_WS\": \"2\"}}") == "input T_WS is not a number: \"2\"");
  // JSON has no NaN or infinity: a non-finite input can only come as invalid JSON.
  CHECK(reason("{\"time_s\": 1, \"inputs\": {\"T_ENV\": 1, \"T_WS\": 1e999}}") ==
        "invalid JSON: number overflow parsing '1e999'");
  CHECK_THAT(reason("{\"time_s\": 1, \"inputs\": {\"T_ENV\": 1, \"T_WS\": NaN}}"),
             Catch::StartsWith("invalid JSON: at column 46: "));  // the N
  CHECK(reason("{\"inputs\": {}}") == "time_s is missing");
  auto probe = supervisor::parse_probe_result("{\"id\": 3, \"time_s\": 5, \"errors\": {\"E_X0C\": null, \"E_Y0C\": 2}}",
                                              {"E_X0C", "E_Y0C"});
  REQUIRE(std::holds_alternative<supervisor::ProbeResultMessage>(probe));
  CHECK(std::isnan(std::get<supervisor::ProbeResultMessage>(probe).measured(0)));
  // An id beyond int64 is named as written (it was quoted as -1, wrapped), the largest int64 is read as is.
  const auto probe_reason = [](const std::string& id) {
    const auto r = supervisor::parse_probe_result("{\"id\": " + id + ", \"time_s\": 5, \"errors\": {\"E_X0C\": 1}}",
                                                  {"E_X0C"});
    return std::holds_alternative<supervisor::Refusal>(r) ? std::get<supervisor::Refusal>(r).reason : std::string();
  };
  CHECK(probe_reason("18446744073709551615") == "unknown probe id 18446744073709551615");
  CHECK(probe_reason("9223372036854775808") == "unknown probe id 9223372036854775808");
  const auto largest = supervisor::parse_probe_result(
      "{\"id\": 9223372036854775807, \"time_s\": 5, \"errors\": {\"E_X0C\": 1}}", {"E_X0C"});
  REQUIRE(std::holds_alternative<supervisor::ProbeResultMessage>(largest));
  CHECK(std::get<supervisor::ProbeResultMessage>(largest).id == std::numeric_limits<std::int64_t>::max());
  CHECK(probe_reason("-1") == "");  // a negative id is read; the supervisor refuses it as unknown (below 1)
  // probe/now: a reason of 1 to 200 bytes, nothing else.
  const auto now_reason = [](const std::string& p) {
    const auto r = supervisor::parse_probe_now(p);
    return std::holds_alternative<supervisor::Refusal>(r) ? std::get<supervisor::Refusal>(r).reason : std::string();
  };
  const auto now = supervisor::parse_probe_now("{\"reason\": \"relevelled\"}");
  REQUIRE(std::holds_alternative<supervisor::ProbeNowMessage>(now));
  CHECK(std::get<supervisor::ProbeNowMessage>(now).reason == "relevelled");
  CHECK(now_reason("{}") == "reason is missing or not a string");
  CHECK(now_reason("{\"reason\": 3}") == "reason is missing or not a string");
  CHECK(now_reason("{\"reason\": \"\"}") == "reason has 0 bytes, not 1 to 200");
  CHECK(now_reason("{\"reason\": \"" + std::string(201, 'x') + "\"}") == "reason has 201 bytes, not 1 to 200");
  CHECK(now_reason("{\"reason\": \"moved\", \"when\": 3}") == "unknown key 'when' (only \"reason\")");
  CHECK_THAT(now_reason("[\"moved\"]"), Catch::StartsWith("not a JSON object"));
}

TEST_CASE("case A through the broker equals the replay with every sample stored once and kill -9 plus restart losing nothing") {
  MosquittoLib lib;
  const fs::path dir = temp_dir("caseA");
  Broker broker(dir, false);
  const scenarios::Scenario s = case_a(30.0);
  write(dir / "s.toml", case_config(s, broker.port));
  Client c(broker.port, "twin-gateway");
  Gateway g(s, c);
  const std::size_t rows = s.samples() - 30;  // the rest answers the last probe request

  // The uninterrupted run.
  pid_t pid = start_supervisor(dir);
  g.play(rows);
  const std::size_t processed = static_cast<std::size_t>(g.processed());
  ::kill(pid, SIGTERM);
  CHECK(wait_exit(pid) == 0);
  CHECK(c.until([&] { return c.state().value("online", true) == false; }, 30));

  // The same with a kill -9 in the middle.
  const fs::path dir2 = dir / "killed";
  fs::create_directories(dir2);
  write(dir2 / "s.toml", case_config(s, broker.port));
  // The same machine again with another history (the first one is stopped; its session is taken over).
  Client c2(broker.port, "twin-gateway-2");
  Gateway g2(s, c2);
  pid = start_supervisor(dir2);
  g2.play(rows, rows / 2);
  ::kill(pid, SIGKILL);
  CHECK(wait_exit(pid) == 128 + SIGKILL);
  // Samples published while it is down wait in its persistent session.
  for (int i = 0; i < 5; ++i) c2.publish("sample", sample_json(s, g2.next_row++));
  pid = start_supervisor(dir2);
  g2.play(processed);
  ::kill(pid, SIGTERM);
  CHECK(wait_exit(pid) == 0);
  {
    std::ifstream log(dir2 / "supervisor.log");
    const std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
    CHECK(text.find("resumed from its snapshot") != std::string::npos);
  }

  // Reference: the replay of the same rows.
  scenarios::Scenario cut = s;
  cut.time_s.resize(processed);
  cut.inputs.conservativeResize(static_cast<Eigen::Index>(processed), Eigen::NoChange);
  cut.outputs.conservativeResize(static_cast<Eigen::Index>(processed), Eigen::NoChange);
  runtime::ReplayOptions o;
  o.db = dir / "replay.sqlite";
  o.parameters = supervisor::parse_supervisor_config(case_config(s, 1), dir / "x.toml").parameters;
  runtime::Replay replay(cut, o);
  replay.run();
  const double cp_end = replay.report().cp_end_s;
  REQUIRE(std::isfinite(cp_end));

  const auto ref = rmse_of(dir / "replay.sqlite", cut, cp_end, processed);
  const auto sup = rmse_of(dir / "h.sqlite", cut, cp_end, processed);
  const auto killed = rmse_of(dir2 / "h.sqlite", cut, cp_end, processed);
  for (std::size_t j = 0; j < ref.size(); ++j) {
    INFO(s.output_names[j] << ": replay " << ref[j] << ", supervisor " << sup[j] << ", killed " << killed[j]);
    CHECK(std::abs(sup[j] - ref[j]) <= 0.05 * ref[j] + 1e-9);
    CHECK(killed[j] == sup[j]);
  }
  // Every sample once, in order; the decisions of the killed run are the uninterrupted run's.
  for (const fs::path& db : {dir / "h.sqlite", dir2 / "h.sqlite"}) {
    const storage::HistoryReader r(db);
    const auto run = r.runs().back().run_id;
    const auto samples = r.input_samples(run);
    REQUIRE(samples.size() >= processed);
    for (std::size_t k = 0; k < samples.size(); ++k) {
      CHECK(samples[k].sample_index == static_cast<std::int64_t>(k));
      CHECK(samples[k].time_s == s.time_s[k]);
    }
  }
  const storage::HistoryReader a(dir / "h.sqlite"), b(dir2 / "h.sqlite");
  const auto pa = a.probe_measurements(a.runs().back().run_id), pb = b.probe_measurements(b.runs().back().run_id);
  const auto ca = a.phase_changes(a.runs().back().run_id), cb = b.phase_changes(b.runs().back().run_id);
  REQUIRE(pa.size() >= 10);
  for (std::size_t k = 0; k < std::min(pa.size(), pb.size()); ++k) {
    CHECK(pa[k].time_s == pb[k].time_s);
    CHECK(pa[k].measured == pb[k].measured);
  }
  REQUIRE(ca.size() == cb.size());
  for (std::size_t k = 0; k < ca.size(); ++k) CHECK(ca[k].time_s == cb[k].time_s);
}

// libmosquitto acknowledges a QoS 1 message (PUBACK) before it hands it over; the supervisor's client
// must not let that acknowledgement out before the message is in the inbox. Here the inbox commit is
// made to wait (the test holds the inbox's write lock) while the supervisor is killed: the sample was
// received but not committed, so the broker must send it again to the restarted supervisor. Before
// (the PUBACK written at once), it was acknowledged and lost: a CI run lost one of case A's samples
// to a kill -9 that way.
TEST_CASE("a sample is acknowledged to the broker only once it is in the inbox: kill -9 while its commit waits loses nothing") {
  SmallSupervisor sup("ack-after-commit");
  Client& c = sup.c;
  CHECK(c.state()["received"] == 1);
  sqlite3* lock = nullptr;
  REQUIRE(sqlite3_open((sup.dir / "h.sqlite.inbox").c_str(), &lock) == SQLITE_OK);
  sqlite3_busy_timeout(lock, 10000);
  REQUIRE(sqlite3_exec(lock, "BEGIN IMMEDIATE", nullptr, nullptr, nullptr) == SQLITE_OK);
  c.publish("sample", sample_at(60.0));
  // The supervisor receives it and waits for the lock (its busy timeout is 5 s): nothing accepted.
  c.until([] { return false; }, 1.5);
  CHECK(c.state()["received"] == 1);
  ::kill(sup.pid, SIGKILL);
  CHECK(wait_exit(sup.pid) == 128 + SIGKILL);
  REQUIRE(sqlite3_exec(lock, "ROLLBACK", nullptr, nullptr, nullptr) == SQLITE_OK);
  sqlite3_close(lock);
  REQUIRE(c.until([&] { return !c.state().value("online", true); }, 30));  // its will
  sup.pid = start_supervisor(sup.dir);
  // t = 0 s from the inbox, t = 60 s sent again by the broker (it was never acknowledged).
  CHECK(c.until([&] { return c.state().value("online", false) && c.state().value("received", 0) == 2; }, 60));
  ::kill(sup.pid, SIGTERM);
  CHECK(wait_exit(sup.pid) == 0);
  sup.pid = -1;
  CHECK(c.state().value("rejected", -1) == 0);
}

TEST_CASE("bad messages are rejected with the reason and stale sensors hold the offsets and a missing probe times out and SIGTERM stops cleanly") {
  SmallSupervisor sup("faults");
  Client& c = sup.c;
  const pid_t pid = sup.pid;
  // The first sample reaches the first due time (CP starts with a probe): request 1, left unanswered.
  CHECK(c.state()["outstanding_probe"] == 1);

  const std::vector<std::pair<std::string, std::string>> bad = {
      {"sample", "{\"time_s\": 60, \"inputs\": {"},
      {"sample", "{\"time_s\": 60, \"inputs\": {\"T_ENV\": 20}}"},
      {"sample", "{\"time_s\": 60, \"inputs\": {\"T_ENV\": 20, \"T_WS\": \"warm\"}}"},
      {"sample", "{\"time_s\": 60, \"inputs\": {\"T_ENV\": 20, \"T_WS\": NaN}}"},
      {"sample", sample_at(-60.0)},
      {"sample", sample_at(0.0)},
      {"sample", std::string(10 * 1024 * 1024, ' ')},
      {"probe/result", "{\"id\": 99, \"time_s\": 30, \"errors\": {\"E_X0C\": 1}}"},
      // Through the broker too: the supervisor reads probe/now (the refusal names the key).
      {"probe/now", "{\"why\": \"moved\"}"},
  };
  const std::vector<std::string> reasons = {"invalid JSON", "input T_WS is missing", "input T_WS is not a number",
                                            "invalid JSON", "time goes backwards", "duplicate sample",
                                            "payload of 10485760 bytes", "unknown probe id 99",
                                            "unknown key 'why'"};
  for (std::size_t k = 0; k < bad.size(); ++k) {
    c.publish(bad[k].first, bad[k].second);
    REQUIRE(c.until([&] { return c.state().value("rejected", 0) == static_cast<int>(k + 1); }));
    Json e;
    for (const Json& x : c.events())
      if (x.value("type", "") == "MessageRejected") e = x;  // the latest (Stale events come between)
    INFO(e.dump());
    CHECK(e.value("topic", "") == bad[k].first);
    CHECK(e.value("reason", "").find(reasons[k]) != std::string::npos);
    CHECK(c.state()["received"] == 1);
    CHECK(c.state()["samples"] == 1);
  }
  // No result for request 1: samples are held until one arrives more than probe_timeout_s later.
  for (int k = 1; k <= 11; ++k) c.publish("sample", sample_at(60.0 * k));
  REQUIRE(c.until([&] { return c.state().value("received", 0) == 12; }));
  bool timed_out = false;
  for (const Json& e : c.events()) timed_out = timed_out || (e.value("type", "") == "ProbeTimeout" && e.value("id", 0) == 1);
  CHECK(timed_out);
  CHECK(c.state()["probe_timeouts"] == 1);
  // The held samples go to the controller, all of them: the probe is past due again, and it is asked
  // for (a new id) at the latest sample, t = 660 s. Before, the first held sample (t = 60 s) asked and
  // the other 10 were held again, one sample released per timeout.
  CHECK(c.state()["samples"] == 12);
  CHECK(c.state()["held"] == 0);
  CHECK(c.state()["outstanding_probe"] == 2);

  // Sensors go quiet: stale, and no offsets while stale.
  REQUIRE(c.until([&] { return c.state().value("stale", false); }));
  const auto offsets_before = std::count_if(c.received.begin(), c.received.end(),
                                            [](const auto& m) { return m.first == "alc/dmu-1/offsets"; });
  for (int i = 0; i < 20; ++i) c.loop();
  CHECK(std::count_if(c.received.begin(), c.received.end(),
                      [](const auto& m) { return m.first == "alc/dmu-1/offsets"; }) == offsets_before);
  c.publish("sample", sample_at(60.0 * 12));
  REQUIRE(c.until([&] { return c.state().value("received", 0) == 13; }));
  CHECK_FALSE(c.state()["stale"].get<bool>());

  ::kill(pid, SIGTERM);
  CHECK(wait_exit(pid) == 0);
  REQUIRE(c.until([&] { return !c.state().value("online", true); }));
  const storage::HistoryReader r(sup.dir / "h.sqlite");
  const auto run = r.runs().back();
  CHECK(run.status == storage::RunStatus::Stopped);
  // t = 720 s does not time probe 2 out: it was asked when t = 660 s had arrived, so its timeout counts
  // from there (until t = 1260 s). The sample held for it (t = 720 s) waits in the inbox (processed
  // after a restart); the 12 before it are in the history.
  CHECK(c.state()["probe_timeouts"] == 1);
  CHECK(r.input_samples(run.run_id).size() == 12);
}

TEST_CASE("username and password file on a broker with an ACL and wrong credentials are a clear error") {
  MosquittoLib lib;
  const fs::path dir = temp_dir("auth");
  Broker broker(dir, true);
  write(dir / "pw", "alcpw\n");
  write(dir / "s.toml", small_config(broker.port, "username = \"alc\"\npassword_file = \"pw\"\n"));
  Client c(broker.port, "observer", "twin", "twinpw");
  pid_t pid = start_supervisor(dir);
  first_sample(c);
  ::kill(pid, SIGTERM);
  CHECK(wait_exit(pid) == 0);

  write(dir / "pw", "wrong\n");
  pid = start_supervisor(dir);
  CHECK(wait_exit(pid) == 1);
  CHECK(read_text(dir / "supervisor.log").find("refused the connection") != std::string::npos);
  CHECK(read_text(dir / "supervisor.log").find("(user 'alc')") != std::string::npos);
}

TEST_CASE("a subscription the broker's ACL refuses is a clear error, not a supervisor waiting for ever") {
  // A broker whose ACL (mosquitto's dynamic security) grants no subscription. Before: "connected", then
  // nothing (MQTT 3.1.1 answers a refused subscription with 0x80 in the SUBACK, which nobody read).
  MosquittoLib lib;
  const fs::path dir = temp_dir("acl");
  Broker broker(dir, BrokerOptions{false, false, std::nullopt, true});
  write(dir / "s.toml", small_config(broker.port) + "[log]\nfile = \"alc.log\"\n");
  pid_t pid = start_supervisor(dir);
  const ChildGuard guard{pid};
  // Bounded: before, it ran on (the guard kills it).
  int status = 0;
  for (int i = 0; i < 600 && ::waitpid(pid, &status, WNOHANG) == 0; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  REQUIRE(::kill(pid, 0) != 0);  // exited (and reaped)
  pid = -1;
  CHECK(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 1);
  const std::string log = read_text(dir / "supervisor.log");
  CHECK_THAT(log, Catch::Contains("refused the subscription to alc/dmu-1/") &&
                      Catch::Contains("not authorized: its ACL for anonymous clients"));
  // Why it stopped is in the log file too (before: on stderr only, which a service may send nowhere).
  CHECK_THAT(read_text(dir / "alc.log"), Catch::Contains("[critical] [supervisor] stopped: the broker") &&
                                             Catch::Contains("refused the subscription to alc/dmu-1/"));
}

TEST_CASE("a broker that refuses only the subscription to probe/now costs a warning, not the start") {
  // Asking for a probe by hand is optional (kInboundTopics): the supervisor runs on without it.
  MosquittoLib lib;
  const fs::path dir = temp_dir("acl-probe-now");
  BrokerOptions o;
  o.refuse_topic = "alc/dmu-1/probe/now";
  Broker broker(dir, o);
  write(dir / "s.toml", small_config(broker.port));
  Client c(broker.port, "observer");
  pid_t pid = start_supervisor(dir);
  const ChildGuard guard{pid};
  first_sample(c);
  // Not delivered to the supervisor: nothing waits and nothing is rejected; samples go on.
  c.publish("probe/now", R"({"reason": "relevelled"})");
  c.publish("sample", sample_at(60.0));
  REQUIRE(c.until([&] { return c.state().value("received", 0) == 2; }));
  CHECK(c.state()["probe_asked"].is_null());
  CHECK(c.state()["rejected"] == 0);
  CHECK_THAT(read_text(dir / "supervisor.log"),
             Catch::Contains("the broker refused the subscription to alc/dmu-1/probe/now: probes cannot be asked "
                             "for by hand"));
  ::kill(pid, SIGTERM);
  CHECK(wait_exit(pid) == 0);
  pid = -1;
}
