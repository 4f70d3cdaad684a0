// Faults of the supervisor's surroundings, each with a real mosquitto started by the test: the broker
// restarts mid-run (persistence on, so the persistent sessions and their queued QoS 1 messages survive
// it), and TLS to the broker (a CA and a server certificate made by the test with openssl), a wrong
// CA being a clear error.
#include <catch2/catch.hpp>

#include "storage/history_reader.hpp"
#include "supervisor_test_support.hpp"

using namespace alc;
using namespace alc::supervisor_test;

namespace {

// Every sample of the latest run once, in order: row k of the case at index k; their number.
std::size_t check_samples_once(const fs::path& db, const scenarios::Scenario& s) {
  const storage::HistoryReader r(db);
  const auto samples = r.input_samples(r.runs().back().run_id);
  for (std::size_t k = 0; k < samples.size(); ++k) {
    CHECK(samples[k].sample_index == static_cast<std::int64_t>(k));
    CHECK(samples[k].time_s == s.time_s[k]);
  }
  return samples.size();
}

std::size_t occurrences(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (auto p = text.find(what); p != std::string::npos; p = text.find(what, p + 1)) ++n;
  return n;
}

}  // namespace

TEST_CASE("the broker restarts mid-run: the supervisor reconnects, is online again, and every sample the broker kept is stored once") {
  MosquittoLib lib;
  const fs::path dir = temp_dir("broker-restart");
  Broker broker(dir, BrokerOptions{false, /*persistence=*/true, std::nullopt});
  const scenarios::Scenario s = case_a(10.0);
  write(dir / "s.toml", case_config(s, broker.port));
  Client c(broker.port, "twin-gateway", ClientOptions{"", "", std::nullopt, /*persistent=*/true});
  Gateway g(s, c);
  const std::size_t rows = s.samples() - 30;  // the rest answers the last probe request
  const pid_t pid = start_supervisor(dir);
  const ChildGuard guard{pid};
  g.play(rows, rows / 2);

  // Messages the broker holds for the supervisor's session when it goes down: the supervisor is
  // paused (SIGSTOP) while 5 samples are published and acknowledged by the broker.
  // Waited for by message id: play() runs up to its window ahead of the supervisor, so publishes before
  // these 5 may still wait for their PUBACK (before, a count of acknowledgements taken here never met
  // "+5" when one of those came late: a CI run under load).
  REQUIRE(::kill(pid, SIGSTOP) == 0);
  for (int i = 0; i < 5; ++i) c.publish("sample", sample_json(s, g.next_row++));
  REQUIRE(c.in_flight.size() >= 5);
  REQUIRE(c.until([&] { return c.in_flight.empty(); }, 30));
  broker.stop();
  REQUIRE(::kill(pid, SIGCONT) == 0);
  // The gateway keeps publishing while the broker is down (queued in its own client until it is back).
  for (int i = 0; i < 5; ++i) c.publish("sample", sample_json(s, g.next_row++));
  for (int i = 0; i < 30; ++i) c.loop(50);  // the supervisor retries with backoff meanwhile
  const std::size_t before = c.received.size();
  broker.start();
  // Online again: the retained state says so (the gateway's persistent subscription receives it).
  REQUIRE(c.until([&] {
    for (std::size_t k = before; k < c.received.size(); ++k)
      if (c.received[k].first == "alc/dmu-1/state" && Json::parse(c.received[k].second).value("online", false))
        return true;
    return false;
  }, 90));
  g.play(rows);
  const auto processed = static_cast<std::size_t>(g.processed());
  CHECK(processed == g.next_row);
  ::kill(pid, SIGTERM);
  CHECK(wait_exit(pid) == 0);

  const std::string log = read_text(dir / "supervisor.log");
  INFO(log);
  CHECK(log.find("disconnected; reconnecting") != std::string::npos);
  CHECK(occurrences(log, "mqtt: connected to") >= 2);
  // Nothing lost, nothing twice: every published row is in the history once, in order.
  CHECK(check_samples_once(dir / "h.sqlite", s) == processed);
  CHECK(processed >= rows);
}

namespace {

// A CA, a server certificate for 127.0.0.1 signed by it, and another CA that did not sign it (P-256).
struct Certificates {
  fs::path ca, cert, key, other_ca;
  explicit Certificates(const fs::path& dir)
      : ca(dir / "ca.pem"), cert(dir / "server.pem"), key(dir / "server.key"), other_ca(dir / "other-ca.pem") {
    const std::string d = dir.string();
    write(dir / "san.ext", "subjectAltName=IP:127.0.0.1\n");
    const std::string ec = " -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes ";
    const std::string cmd =
        "cd '" + d + "' && openssl req -x509" + ec + "-keyout ca.key -out ca.pem -days 2 -subj '/CN=alc test CA' && " +
        "openssl req" + ec + "-keyout server.key -out server.csr -subj '/CN=127.0.0.1' && " +
        "openssl x509 -req -in server.csr -CA ca.pem -CAkey ca.key -CAcreateserial -out server.pem -days 2 " +
        "-extfile san.ext && openssl req -x509" + ec +
        "-keyout other-ca.key -out other-ca.pem -days 2 -subj '/CN=another CA' && chmod 644 server.key";
    REQUIRE(std::system((cmd + " >openssl.log 2>&1").c_str()) == 0);
  }
};

}  // namespace

TEST_CASE("TLS to the broker with the CA of its certificate works, and a wrong CA is a clear error with a non-zero exit") {
  MosquittoLib lib;
  const fs::path dir = temp_dir("tls");
  const Certificates certs(dir);
  Broker broker(dir, BrokerOptions{false, false, std::array<fs::path, 3>{certs.ca, certs.cert, certs.key}});
  write(dir / "s.toml", small_config(broker.port, "tls_ca_file = \"ca.pem\"\n"));
  Client c(broker.port, "observer", ClientOptions{"", "", certs.ca, false});
  pid_t pid = start_supervisor(dir);
  const ChildGuard guard{pid};
  first_sample(c, 60);
  ::kill(pid, SIGTERM);
  CHECK(wait_exit(pid) == 0);

  // The CA that did not sign the broker's certificate: refused at the first connection, exit status 1.
  fs::remove(dir / "supervisor.log");
  write(dir / "s.toml", small_config(broker.port, "tls_ca_file = \"other-ca.pem\"\n"));
  pid = start_supervisor(dir);
  CHECK(wait_exit(pid) == 1);
  const std::string log = read_text(dir / "supervisor.log");
  INFO(log);
  CHECK(log.find("TLS to the broker 127.0.0.1:" + std::to_string(broker.port) + " failed") != std::string::npos);
  CHECK(log.find("certificate verify failed") != std::string::npos);
  CHECK(log.find("other-ca.pem") != std::string::npos);
}
