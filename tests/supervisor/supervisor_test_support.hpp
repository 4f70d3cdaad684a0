#pragma once
// Shared by the supervisor's tests: processes (spawn, wait, free ports), a mosquitto of the test's own
// (anonymous, password file and ACL, persistence, TLS), a test's MQTT client, the twin gateway that
// plays a load case through the broker and answers probe requests in closed loop, and configs.
#include <arpa/inet.h>
#include <fcntl.h>
#include <mosquitto.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <catch2/catch.hpp>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "../cli_support.hpp"
#include "scenarios/load_cases.hpp"
#include "supervisor/supervisor.hpp"

namespace alc::supervisor_test {

using Json = nlohmann::json;
namespace fs = std::filesystem;

// <tmp>/alc-supervisor-<name>-<pid>, fresh, removed with its files when the test process exits.
inline fs::path temp_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("alc-supervisor-" + name + "-" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  alc_test::remove_at_exit(d);
  return d;
}

inline void write(const fs::path& p, const std::string& text) { std::ofstream(p) << text; }

// ---- processes -------------------------------------------------------------------------------

inline int free_port() {
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

inline bool port_open(int port) {
  const int s = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  const bool ok = ::connect(s, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  ::close(s);
  return ok;
}

inline pid_t spawn(const std::vector<std::string>& argv, const fs::path& log) {
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
inline int wait_exit(pid_t pid) {
  int status = 0;
  ::waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

// Stops (SIGKILL) and reaps a child still running when the guard goes: what a failed REQUIRE leaves.
struct ChildGuard {
  const pid_t& pid;
  ~ChildGuard() {
    if (pid > 0 && ::waitpid(pid, nullptr, WNOHANG) == 0) {
      ::kill(pid, SIGCONT);
      ::kill(pid, SIGKILL);
      ::waitpid(pid, nullptr, 0);
    }
  }
};

inline void sleep_ms(int ms) { std::this_thread::sleep_for(std::chrono::milliseconds(ms)); }

// A mosquitto of the test's own on a free port of 127.0.0.1: anonymous, or with a password file and
// an ACL; with persistence (its database in `dir`, so that a restart keeps the persistent sessions and
// their queued QoS 1 messages); with a TLS listener (server certificate and key in PEM).
struct BrokerOptions {
  bool auth = false;
  bool persistence = false;
  std::optional<std::array<fs::path, 3>> tls;  // CA, server certificate, server key
  // Mosquitto's dynamic-security plugin denying every subscription (answered 0x80 in the SUBACK;
  // an acl_file never refuses a subscription, it only withholds the messages).
  bool refuse_subscriptions = false;
  // The same plugin refusing only the subscription to this topic (literal), granting the others.
  std::string refuse_topic{};
};

struct Broker {
  fs::path dir;
  int port = 0;
  pid_t pid = -1;
  Broker(const fs::path& d, bool auth) : Broker(d, BrokerOptions{auth, false, std::nullopt}) {}
  Broker(const fs::path& d, const BrokerOptions& o) : dir(d), port(free_port()) {
    std::string conf = "per_listener_settings false\nlistener " + std::to_string(port) + " 127.0.0.1\n" +
                       (o.persistence ? "persistence true\npersistence_location " + dir.string() + "/\n"
                                      : std::string("persistence false\n")) +
                       "log_dest file " + (dir / "mosquitto.log").string() + "\nuser root\n";
    if (o.tls)
      conf += "cafile " + (*o.tls)[0].string() + "\ncertfile " + (*o.tls)[1].string() + "\nkeyfile " +
              (*o.tls)[2].string() + "\n";
    if (o.auth) {
      REQUIRE(std::system(("mosquitto_passwd -c -b " + (dir / "passwd").string() + " alc alcpw && mosquitto_passwd -b " +
                           (dir / "passwd").string() + " twin twinpw")
                              .c_str()) == 0);
      write(dir / "acl", "user alc\ntopic readwrite alc/dmu-1/#\nuser twin\ntopic readwrite alc/dmu-1/#\n");
      conf += "allow_anonymous false\npassword_file " + (dir / "passwd").string() + "\nacl_file " +
              (dir / "acl").string() + "\n";
    } else {
      conf += "allow_anonymous true\n";
    }
    if (o.refuse_subscriptions || !o.refuse_topic.empty()) {
      Json dynsec = {{"defaultACLAccess",
                      {{"publishClientSend", true}, {"publishClientReceive", true},
                       {"subscribe", !o.refuse_subscriptions}, {"unsubscribe", true}}},
                     {"clients", Json::array()}, {"groups", Json::array()}, {"roles", Json::array()}};
      if (!o.refuse_topic.empty()) {  // anonymous clients are in the group "anon", whose role denies the one topic
        dynsec["groups"].push_back({{"groupname", "anon"}, {"roles", {{{"rolename", "deny"}}}}});
        dynsec["roles"].push_back(
            {{"rolename", "deny"},
             {"acls", {{{"acltype", "subscribeLiteral"}, {"topic", o.refuse_topic}, {"priority", 0}, {"allow", false}}}}});
        dynsec["anonymousGroup"] = "anon";
      }
      write(dir / "dynsec.json", dynsec.dump() + "\n");
      conf += "plugin /usr/lib/x86_64-linux-gnu/mosquitto_dynamic_security.so\nplugin_opt_config_file " +
              (dir / "dynsec.json").string() + "\n";
    }
    write(dir / "mosquitto.conf", conf);
    start();
  }
  void start() {
    pid = spawn({"mosquitto", "-c", (dir / "mosquitto.conf").string()}, dir / "mosquitto.stderr");
    for (int i = 0; i < 200 && !port_open(port); ++i) sleep_ms(25);
    REQUIRE(port_open(port));
  }
  // SIGTERM to its PID (mosquitto saves its persistence database on the way out).
  void stop() {
    if (pid <= 0) return;
    ::kill(pid, SIGTERM);
    wait_exit(pid);
    pid = -1;
  }
  ~Broker() { stop(); }
};

// A test's own MQTT client (the gateway and an observer of every topic). With `persistent`, its
// session survives a disconnection (clean session off) and loop() reconnects when the connection is
// gone, so QoS 1 messages published meanwhile are delivered later.
struct ClientOptions {
  std::string user, password;
  std::optional<fs::path> tls_ca;
  bool persistent = false;
};

struct Client {
  mosquitto* m = nullptr;
  std::vector<std::pair<std::string, std::string>> received;
  std::map<std::string, std::string> retained_last;
  std::set<int> in_flight;  // message ids of QoS 1 publishes the broker has not acknowledged yet
  bool persistent = false;
  bool connected = false;  // the broker accepted the connection and has not been lost since
  std::vector<std::pair<std::string, std::string>> pending;  // published while not connected
  Client(int port, const std::string& id, const std::string& user = "", const std::string& pw = "")
      : Client(port, id, ClientOptions{user, pw, std::nullopt, false}) {}
  Client(int port, const std::string& id, const ClientOptions& o) : persistent(o.persistent) {
    m = mosquitto_new(id.c_str(), !o.persistent, this);
    if (!o.user.empty()) mosquitto_username_pw_set(m, o.user.c_str(), o.password.c_str());
    if (o.tls_ca) REQUIRE(mosquitto_tls_set(m, o.tls_ca->c_str(), nullptr, nullptr, nullptr, nullptr) == MOSQ_ERR_SUCCESS);
    mosquitto_message_callback_set(m, [](mosquitto*, void* self, const mosquitto_message* msg) {
      auto* c = static_cast<Client*>(self);
      c->received.emplace_back(msg->topic, std::string(static_cast<const char*>(msg->payload),
                                                       static_cast<std::size_t>(msg->payloadlen)));
      c->retained_last[msg->topic] = c->received.back().second;
    });
    mosquitto_publish_callback_set(m, [](mosquitto*, void* self, int mid) { static_cast<Client*>(self)->in_flight.erase(mid); });
    mosquitto_connect_callback_set(m, [](mosquitto*, void* self, int rc) { static_cast<Client*>(self)->connected = rc == 0; });
    mosquitto_disconnect_callback_set(m, [](mosquitto*, void* self, int) { static_cast<Client*>(self)->connected = false; });
    REQUIRE(mosquitto_connect(m, "127.0.0.1", port, 30) == MOSQ_ERR_SUCCESS);
    REQUIRE(mosquitto_subscribe(m, nullptr, "alc/dmu-1/#", 1) == MOSQ_ERR_SUCCESS);
    for (int i = 0; i < 10; ++i) mosquitto_loop(m, 10, 1);
  }
  ~Client() {
    mosquitto_disconnect(m);
    mosquitto_destroy(m);
  }
  // QoS 1. A persistent client keeps what it publishes without a connection and sends it after the
  // reconnection (a gateway queuing samples while the broker is away).
  void publish(const std::string& topic, const std::string& payload) {
    if (persistent && !connected) {
      pending.emplace_back(topic, payload);
      return;
    }
    int mid = 0;
    const int rc = mosquitto_publish(m, &mid, ("alc/dmu-1/" + topic).c_str(), static_cast<int>(payload.size()),
                                     payload.data(), 1, false);
    if (persistent && rc != MOSQ_ERR_SUCCESS) pending.emplace_back(topic, payload);  // the loss not seen yet
    else REQUIRE(rc == MOSQ_ERR_SUCCESS);
    if (rc == MOSQ_ERR_SUCCESS) in_flight.insert(mid);
  }
  void loop(int ms = 20) {
    const int rc = mosquitto_loop(m, ms, 1);
    if (rc != MOSQ_ERR_SUCCESS && persistent) {
      connected = false;
      sleep_ms(ms);
      mosquitto_reconnect(m);  // fails while the broker is down: tried again next time
    }
    if (connected && !pending.empty()) {
      auto queued = std::move(pending);
      pending.clear();
      for (const auto& [t, p] : queued) publish(t, p);
    }
  }
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
inline std::string case_config(const scenarios::Scenario& s, int port, const std::string& mqtt_extra = "",
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

inline std::string sample_json(const scenarios::Scenario& s, std::size_t row) {
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
  bool forget = false;  // drop the client's received messages once handled (long runs: bounded memory)
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
    if (forget) {
      c.received.clear();
      seen = 0;
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

// A bus in the test's process: what an in-process Supervisor publishes, in order.
struct RecordingBus : supervisor::Bus {
  std::vector<std::pair<std::string, std::string>> out;
  void publish(const std::string& topic, const std::string& payload, bool) override { out.emplace_back(topic, payload); }
  std::size_t count(const std::string& event_type) const {
    std::size_t n = 0;
    for (const auto& [t, p] : out) n += t == "event" && Json::parse(p).value("type", "") == event_type;
    return n;
  }
  Json last(const std::string& topic) const {
    for (auto it = out.rbegin(); it != out.rend(); ++it)
      if (it->first == topic) return Json::parse(it->second);
    return Json();
  }
  // The latest event of `type` (null if none).
  Json last_event(const std::string& type) const {
    for (auto it = out.rbegin(); it != out.rend(); ++it)
      if (it->first == "event" && Json::parse(it->second).value("type", "") == type) return Json::parse(it->second);
    return Json();
  }
};

// Load case A cut to its first `hours`.
inline scenarios::Scenario case_a(double hours) {
  scenarios::Scenario s = scenarios::simulate_case("A").scenario;
  std::size_t rows = 0;
  while (rows < s.samples() && s.time_s[rows] < s.time_s[0] + hours * 3600.0) ++rows;
  s.time_s.resize(rows);
  s.inputs.conservativeResize(static_cast<Eigen::Index>(rows), Eigen::NoChange);
  s.outputs.conservativeResize(static_cast<Eigen::Index>(rows), Eigen::NoChange);
  return s;
}

inline pid_t start_supervisor(const fs::path& dir) {
  return spawn({ALC_CLI_PATH, "--log-level", "info", "supervise", "--config", (dir / "s.toml").string()},
               dir / "supervisor.log");
}

inline std::string small_config(int port, const std::string& mqtt_extra = "") {
  return "machine_id = \"dmu-1\"\n[mqtt]\nport = " + std::to_string(port) + "\n" + mqtt_extra +
         "[signals]\ninputs = [\"T_ENV\", \"T_WS\"]\noutputs = [\"E_X0C\", \"E_Y0C\"]\nstale_after_s = 1\n"
         "probe_timeout_s = 600\n[history]\ndb = \"h.sqlite\"\n[controller]\ncp = 6.5\n";
}

inline std::string sample_at(double t) {
  return Json{{"time_s", t}, {"inputs", {{"T_ENV", 20.0 + t * 1e-4}, {"T_WS", 21.0}}}}.dump();
}

// Waits until the supervisor is online (its retained state) and has received its first sample, t = 0.
inline void first_sample(Client& c, double seconds = 120.0) {
  REQUIRE(c.until([&] { return c.state().value("online", false); }, seconds));
  c.publish("sample", sample_at(0.0));
  REQUIRE(c.until([&] { return c.state().value("received", 0) == 1; }, seconds));
}

// `alc supervise` with small_config on an anonymous broker of the test's own, watched by the client
// "observer": started, online, and its first sample received (first_sample). A supervisor still
// running when the test ends (a failed REQUIRE) is killed.
struct SmallSupervisor {
  MosquittoLib lib;
  fs::path dir;
  Broker broker;
  Client c;
  pid_t pid = -1;
  ChildGuard guard{pid};
  explicit SmallSupervisor(const std::string& name)
      : dir(temp_dir(name)), broker(dir, false), c(broker.port, "observer") {
    write(dir / "s.toml", small_config(broker.port));
    pid = start_supervisor(dir);
    first_sample(c);
  }
  SmallSupervisor(const SmallSupervisor&) = delete;
  SmallSupervisor& operator=(const SmallSupervisor&) = delete;
};

inline std::string read_text(const fs::path& p) {
  std::ifstream in(p);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}


}  // namespace alc::supervisor_test
