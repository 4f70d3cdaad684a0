// The supervisor: its config and messages (no broker), and `alc supervise` on a real mosquitto
// started by the test on a free port of 127.0.0.1 (stopped by its PID), with a twin gateway that plays
// load case A through the broker and answers probe requests in closed loop.
#include <arpa/inet.h>
#include <fcntl.h>
#include <mosquitto.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <nlohmann/json.hpp>
#include <thread>

#include "runtime/replay.hpp"
#include "scenarios/load_cases.hpp"
#include "storage/history_reader.hpp"
#include "supervisor/config.hpp"
#include "supervisor/messages.hpp"

using namespace alc;
using Json = nlohmann::json;
namespace fs = std::filesystem;

namespace {

fs::path temp_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("alc-supervisor-" + name + "-" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

void write(const fs::path& p, const std::string& text) { std::ofstream(p) << text; }

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

// ---- processes -------------------------------------------------------------------------------

int free_port() {
  const int s = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ::bind(s, reinterpret_cast<sockaddr*>(&a), sizeof a);
  socklen_t n = sizeof a;
  ::getsockname(s, reinterpret_cast<sockaddr*>(&a), &n);
  ::close(s);
  return ntohs(a.sin_port);
}

bool port_open(int port) {
  const int s = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  const bool ok = ::connect(s, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  ::close(s);
  return ok;
}

pid_t spawn(const std::vector<std::string>& argv, const fs::path& log) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::setpgid(0, 0);
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    ::dup2(fd, 1);
    ::dup2(fd, 2);
    std::vector<char*> args;
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    ::execvp(args[0], args.data());
    ::_exit(127);
  }
  return pid;
}

// Waits for the process; its exit status, or 128 + signal.
int wait_exit(pid_t pid) {
  int status = 0;
  ::waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

void sleep_ms(int ms) { std::this_thread::sleep_for(std::chrono::milliseconds(ms)); }

// A mosquitto of the test's own on a free port: anonymous, or with a password file and an ACL.
struct Broker {
  fs::path dir;
  int port = 0;
  pid_t pid = -1;
  Broker(const fs::path& d, bool auth) : dir(d), port(free_port()) {
    std::string conf = "per_listener_settings false\nlistener " + std::to_string(port) +
                       " 127.0.0.1\npersistence false\nlog_dest file " + (dir / "mosquitto.log").string() +
                       "\nuser root\n";
    if (auth) {
      REQUIRE(std::system(("mosquitto_passwd -c -b " + (dir / "passwd").string() + " alc alcpw && mosquitto_passwd -b " +
                           (dir / "passwd").string() + " twin twinpw")
                              .c_str()) == 0);
      write(dir / "acl", "user alc\ntopic readwrite alc/dmu-1/#\nuser twin\ntopic readwrite alc/dmu-1/#\n");
      conf += "allow_anonymous false\npassword_file " + (dir / "passwd").string() + "\nacl_file " +
              (dir / "acl").string() + "\n";
    } else {
      conf += "allow_anonymous true\n";
    }
    write(dir / "mosquitto.conf", conf);
    start();
  }
  void start() {
    pid = spawn({"mosquitto", "-c", (dir / "mosquitto.conf").string()}, dir / "mosquitto.stderr");
    for (int i = 0; i < 200 && !port_open(port); ++i) sleep_ms(25);
    REQUIRE(port_open(port));
  }
  ~Broker() {
    if (pid > 0) {
      ::kill(pid, SIGTERM);
      wait_exit(pid);
    }
  }
};

// A test's own MQTT client (the gateway and an observer of every topic).
struct Client {
  mosquitto* m = nullptr;
  std::vector<std::pair<std::string, std::string>> received;
  std::map<std::string, std::string> retained_last;
  Client(int port, const std::string& id, const std::string& user = "", const std::string& pw = "") {
    m = mosquitto_new(id.c_str(), true, this);
    if (!user.empty()) mosquitto_username_pw_set(m, user.c_str(), pw.c_str());
    mosquitto_message_callback_set(m, [](mosquitto*, void* self, const mosquitto_message* msg) {
      auto* c = static_cast<Client*>(self);
      c->received.emplace_back(msg->topic, std::string(static_cast<const char*>(msg->payload),
                                                       static_cast<std::size_t>(msg->payloadlen)));
      c->retained_last[msg->topic] = c->received.back().second;
    });
    REQUIRE(mosquitto_connect(m, "127.0.0.1", port, 30) == MOSQ_ERR_SUCCESS);
    REQUIRE(mosquitto_subscribe(m, nullptr, "alc/dmu-1/#", 1) == MOSQ_ERR_SUCCESS);
    for (int i = 0; i < 10; ++i) mosquitto_loop(m, 10, 1);
  }
  ~Client() {
    mosquitto_disconnect(m);
    mosquitto_destroy(m);
  }
  void publish(const std::string& topic, const std::string& payload) {
    REQUIRE(mosquitto_publish(m, nullptr, ("alc/dmu-1/" + topic).c_str(), static_cast<int>(payload.size()),
                              payload.data(), 1, false) == MOSQ_ERR_SUCCESS);
  }
  void loop(int ms = 20) { mosquitto_loop(m, ms, 1); }
  // Loops until `done()` or about `seconds` passed (a safety net against a hang, not a timed assertion).
  template <class F>
  bool until(F done, double seconds = 120.0) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    while (!done()) {
      if (std::chrono::steady_clock::now() > end) return false;
      loop();
    }
    return true;
  }
  Json state() const {
    const auto it = retained_last.find("alc/dmu-1/state");
    return it == retained_last.end() ? Json::object() : Json::parse(it->second);
  }
  std::vector<Json> events() const {
    std::vector<Json> out;
    for (const auto& [t, p] : received)
      if (t == "alc/dmu-1/event") out.push_back(Json::parse(p));
    return out;
  }
};

struct MosquittoLib {
  MosquittoLib() { mosquitto_lib_init(); }
  ~MosquittoLib() { mosquitto_lib_cleanup(); }
};

// The supervisor's config for case A on `port` (all of its inputs and outputs).
std::string case_config(const scenarios::Scenario& s, int port, const std::string& mqtt_extra = "",
                        const std::string& signals_extra = "") {
  auto list = [](const std::vector<std::string>& names) {
    std::string t = "[";
    for (std::size_t i = 0; i < names.size(); ++i) t += (i ? ", \"" : "\"") + names[i] + "\"";
    return t + "]";
  };
  return "machine_id = \"dmu-1\"\n[mqtt]\nport = " + std::to_string(port) + "\nprefix = \"alc/dmu-1\"\n" + mqtt_extra +
         "[signals]\ninputs = " + list(s.input_names) + "\noutputs = " + list(s.output_names) +
         "\nprobe_timeout_s = 86400\n" + signals_extra +
         "[history]\ndb = \"h.sqlite\"\nsnapshot_every_h = 2\n[controller]\ncp = 6.5\ninterval = 2\n";
}

std::string sample_json(const scenarios::Scenario& s, std::size_t row) {
  Json in = Json::object();
  for (std::size_t c = 0; c < s.input_names.size(); ++c)
    in[s.input_names[c]] = s.inputs(static_cast<Eigen::Index>(row), static_cast<Eigen::Index>(c));
  return Json{{"time_s", s.time_s[row]}, {"inputs", in}}.dump();
}

// The twin gateway: publishes the case's samples (at most `window` ahead of what the supervisor has
// processed) and answers each probe request once, in closed loop: the recorded reading of the first
// probed row at or after the due time minus the compensation of the latest offsets message.
struct Gateway {
  const scenarios::Scenario& s;
  Client& c;
  std::size_t next_row = 0;
  std::set<std::int64_t> answered;
  std::size_t seen = 0;
  Json compensation = Json::object();
  Gateway(const scenarios::Scenario& sc, Client& cl) : s(sc), c(cl) {}

  void handle_new() {
    for (; seen < c.received.size(); ++seen) {
      const auto& [topic, payload] = c.received[seen];
      if (topic == "alc/dmu-1/offsets") compensation = Json::parse(payload)["compensation"];
      if (topic != "alc/dmu-1/probe/request") continue;
      const Json r = Json::parse(payload);
      const auto id = r["id"].get<std::int64_t>();
      if (!answered.insert(id).second) continue;
      const double due = r["due_s"].get<double>();
      for (std::size_t row = 0; row < s.samples(); ++row) {
        if (s.time_s[row] < due || !std::isfinite(s.outputs(static_cast<Eigen::Index>(row), 0))) continue;
        Json errors = Json::object();
        for (std::size_t j = 0; j < s.output_names.size(); ++j) {
          const double reading = s.outputs(static_cast<Eigen::Index>(row), static_cast<Eigen::Index>(j));
          const Json& comp = compensation[s.output_names[j]];
          errors[s.output_names[j]] = reading - (comp.is_number() ? comp.get<double>() : 0.0);
        }
        c.publish("probe/result", Json{{"id", id}, {"time_s", s.time_s[row]}, {"errors", errors}}.dump());
        break;
      }
    }
  }
  std::int64_t processed() const {
    const Json st = c.state();
    return st.contains("samples") ? st["samples"].get<std::int64_t>() : 0;
  }
  // Plays rows until `rows` are processed and nothing is held; stops early (returns) when `stop_at`
  // rows are processed.
  void play(std::size_t rows, std::size_t stop_at = SIZE_MAX, std::size_t window = 10) {
    c.until([&] {
      handle_new();
      const Json st = c.state();
      if (!st.value("online", false)) return false;  // not subscribed yet: a sample would be lost
      const auto done = static_cast<std::size_t>(processed());
      if (done >= stop_at) return true;
      const bool quiet = st.value("held", 1) == 0 && st.contains("outstanding_probe") && st["outstanding_probe"].is_null();
      if (done >= rows && quiet) return done == next_row;
      if (next_row < s.samples() && next_row < done + window) c.publish("sample", sample_json(s, next_row++));
      return false;
    });
  }
};

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

// Load case A cut to its first `hours`.
scenarios::Scenario case_a(double hours) {
  scenarios::Scenario s = scenarios::simulate_case("A").scenario;
  std::size_t rows = 0;
  while (rows < s.samples() && s.time_s[rows] < s.time_s[0] + hours * 3600.0) ++rows;
  s.time_s.resize(rows);
  s.inputs.conservativeResize(static_cast<Eigen::Index>(rows), Eigen::NoChange);
  s.outputs.conservativeResize(static_cast<Eigen::Index>(rows), Eigen::NoChange);
  return s;
}

pid_t start_supervisor(const fs::path& dir) {
  return spawn({ALC_CLI_PATH, "--log-level", "info", "supervise", "--config", (dir / "s.toml").string()},
               dir / "supervisor.log");
}

}  // namespace

TEST_CASE("config errors name the file and the key and the value") {
  CHECK(error_of(config_text()).empty());
  CHECK(error_of("[mqtt]\n").find("/tmp/s.toml: key 'machine_id': missing") != std::string::npos);
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
  // The same names and units as alc replay: interval in hours.
  const auto c = supervisor::parse_supervisor_config(config_text(), "/tmp/s.toml");
  CHECK(c.parameters.post_cp_interval_s == 7200.0);
  CHECK(c.history.db == fs::path("/tmp/h.sqlite"));
  CHECK(c.mqtt.prefix == "alc/dmu-1");
}

TEST_CASE("messages are refused with the reason named") {
  const std::vector<std::string> in = {"T_ENV", "T_WS"};
  auto reason = [&](const std::string& p) {
    auto r = supervisor::parse_sample(p, in);
    return std::holds_alternative<supervisor::Refusal>(r) ? std::get<supervisor::Refusal>(r).reason : "";
  };
  CHECK(reason("{\"time_s\": 1, \"inputs\": {\"T_ENV\": 1, \"T_WS\": 2}}").empty());
  CHECK(reason("{\"time_s\": 1, \"inputs\": {") == "invalid JSON");
  CHECK(reason("{\"time_s\": 1, \"inputs\": {\"T_ENV\": 1}}") == "input T_WS is missing");
  CHECK(reason("{\"time_s\": 1, \"inputs\": {\"T_ENV\": 1, \"T_WS\": \"2\"}}") == "input T_WS is not a number: \"2\"");
  // JSON has no NaN or infinity: a non-finite input can only come as invalid JSON.
  CHECK(reason("{\"time_s\": 1, \"inputs\": {\"T_ENV\": 1, \"T_WS\": 1e999}}") == "invalid JSON");
  CHECK(reason("{\"time_s\": 1, \"inputs\": {\"T_ENV\": 1, \"T_WS\": NaN}}") == "invalid JSON");
  CHECK(reason("{\"inputs\": {}}") == "time_s is missing");
  auto probe = supervisor::parse_probe_result("{\"id\": 3, \"time_s\": 5, \"errors\": {\"E_X0C\": null, \"E_Y0C\": 2}}",
                                              {"E_X0C", "E_Y0C"});
  REQUIRE(std::holds_alternative<supervisor::ProbeResultMessage>(probe));
  CHECK(std::isnan(std::get<supervisor::ProbeResultMessage>(probe).measured(0)));
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

namespace {

std::string small_config(int port, const std::string& mqtt_extra = "") {
  return "machine_id = \"dmu-1\"\n[mqtt]\nport = " + std::to_string(port) + "\n" + mqtt_extra +
         "[signals]\ninputs = [\"T_ENV\", \"T_WS\"]\noutputs = [\"E_X0C\", \"E_Y0C\"]\nstale_after_s = 1\n"
         "probe_timeout_s = 600\n[history]\ndb = \"h.sqlite\"\n[controller]\ncp = 6.5\n";
}

std::string sample_at(double t) {
  return Json{{"time_s", t}, {"inputs", {{"T_ENV", 20.0 + t * 1e-4}, {"T_WS", 21.0}}}}.dump();
}

std::string read_text(const fs::path& p) {
  std::ifstream in(p);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

}  // namespace

TEST_CASE("bad messages are rejected with the reason and stale sensors hold the offsets and a missing probe times out and SIGTERM stops cleanly") {
  MosquittoLib lib;
  const fs::path dir = temp_dir("faults");
  Broker broker(dir, false);
  write(dir / "s.toml", small_config(broker.port));
  Client c(broker.port, "observer");
  const pid_t pid = start_supervisor(dir);
  REQUIRE(c.until([&] { return c.state().value("online", false); }));
  c.publish("sample", sample_at(0.0));
  REQUIRE(c.until([&] { return c.state().value("received", 0) == 1; }));
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
  };
  const std::vector<std::string> reasons = {"invalid JSON", "input T_WS is missing", "input T_WS is not a number",
                                            "invalid JSON", "time goes backwards", "duplicate sample",
                                            "payload of 10485760 bytes", "unknown probe id 99"};
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
  // The held samples go to the controller; the first (t = 60 s) is past the due time again, so it asks
  // again (a new id) and the rest are held for that request.
  CHECK(c.state()["samples"] == 2);
  CHECK(c.state()["held"] == 10);
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
  const storage::HistoryReader r(dir / "h.sqlite");
  const auto run = r.runs().back();
  CHECK(run.status == storage::RunStatus::Stopped);
  // t = 720 s timed probe 2 out: t = 120 s was processed and asked for probe 3; the others wait in the
  // inbox (processed after a restart).
  CHECK(c.state()["probe_timeouts"] == 2);
  CHECK(r.input_samples(run.run_id).size() == 3);
}

TEST_CASE("username and password file on a broker with an ACL and wrong credentials are a clear error") {
  MosquittoLib lib;
  const fs::path dir = temp_dir("auth");
  Broker broker(dir, true);
  write(dir / "pw", "alcpw\n");
  write(dir / "s.toml", small_config(broker.port, "username = \"alc\"\npassword_file = \"pw\"\n"));
  Client c(broker.port, "observer", "twin", "twinpw");
  pid_t pid = start_supervisor(dir);
  REQUIRE(c.until([&] { return c.state().value("online", false); }));
  c.publish("sample", sample_at(0.0));
  REQUIRE(c.until([&] { return c.state().value("received", 0) == 1; }));
  ::kill(pid, SIGTERM);
  CHECK(wait_exit(pid) == 0);

  write(dir / "pw", "wrong\n");
  pid = start_supervisor(dir);
  CHECK(wait_exit(pid) == 1);
  CHECK(read_text(dir / "supervisor.log").find("refused the connection") != std::string::npos);
  CHECK(read_text(dir / "supervisor.log").find("(user 'alc')") != std::string::npos);
}
