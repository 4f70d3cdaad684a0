// The status page: its model (bounded by the window), `alc supervise` with [status] serving it on
// 127.0.0.1 (GET only, bounded, nothing outside its two paths), the page in a real browser (Debian's
// chromium, headless: it loads without console errors and its charts hold the points it was given),
// and without [status] no listening socket at all.
#include <catch2/catch.hpp>

#include <sstream>

#include "../report/report_test_support.hpp"
#include "report/svg_chart.hpp"
#include "supervisor/config.hpp"
#include "supervisor/status_page.hpp"
#include "supervisor_test_support.hpp"

using namespace alc;
using namespace alc::supervisor_test;

namespace {

// The TCP ports process `pid` listens on (its socket inodes found in /proc/net/tcp and tcp6 in state
// LISTEN), each with its local address in /proc's hex form.
std::vector<std::pair<std::string, int>> listening(pid_t pid) {
  std::set<std::string> inodes;
  const fs::path fds = "/proc/" + std::to_string(pid) + "/fd";
  for (const auto& e : fs::directory_iterator(fds)) {
    std::error_code ec;
    const std::string target = fs::read_symlink(e.path(), ec).string();
    if (!ec && target.rfind("socket:[", 0) == 0) inodes.insert(target.substr(8, target.size() - 9));
  }
  std::vector<std::pair<std::string, int>> out;
  for (const char* table : {"/proc/net/tcp", "/proc/net/tcp6"}) {
    std::ifstream in(table);
    std::string line;
    std::getline(in, line);  // header
    while (std::getline(in, line)) {
      std::istringstream f(line);
      std::string sl, local, remote, st, queues, timer, retr, uid, timeout, inode;
      f >> sl >> local >> remote >> st >> queues >> timer >> retr >> uid >> timeout >> inode;
      if (st == "0A" && inodes.count(inode)) {
        const auto colon = local.rfind(':');
        out.emplace_back(local.substr(0, colon), std::stoi(local.substr(colon + 1), nullptr, 16));
      }
    }
  }
  return out;
}

// One raw HTTP exchange with 127.0.0.1:port (::1 with ipv6): the response's status line ("" when the
// server closed).
std::string http_status(int port, const std::string& request, bool ipv6 = false) {
  const int s = ::socket(ipv6 ? AF_INET6 : AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  sockaddr_in6 a6{};
  a6.sin6_family = AF_INET6;
  a6.sin6_addr = in6addr_loopback;
  a6.sin6_port = a.sin_port;
  if (ipv6)
    REQUIRE(::connect(s, reinterpret_cast<sockaddr*>(&a6), sizeof a6) == 0);
  else
    REQUIRE(::connect(s, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0);
  timeval tv{10, 0};
  ::setsockopt(s, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  ::send(s, request.data(), request.size(), MSG_NOSIGNAL);
  std::string response;
  char buf[4096];
  for (ssize_t n; (n = ::recv(s, buf, sizeof buf, 0)) > 0;) {
    response.append(buf, static_cast<std::size_t>(n));
    if (response.find("\r\n") != std::string::npos) break;
  }
  ::close(s);
  return response.substr(0, response.find("\r\n"));
}

std::string offsets_at(double t) {
  return Json{{"time_s", t},
              {"prediction", {{"E_X0C", 1.0}, {"E_Y0C", 2.0}}},
              {"compensation", {{"E_X0C", 1.0}, {"E_Y0C", 2.0}}},
              {"axis", {{"x_mm", -0.001}, {"y_mm", -0.002}}},
              {"work_offset", "G54"}}
      .dump();
}

}  // namespace

TEST_CASE("the status page model keeps only the window of machine time and escapes what it shows") {
  supervisor::StatusModel m("dmu-<1>", {"E_X0C", "E_Y0C"}, 86400.0);
  for (int k = 0; k < 3 * 96; ++k) m.published("offsets", offsets_at(900.0 * k));  // 3 days every 15 min
  // The last day: t from 2 days + 15 min to 3 days - 15 min, prediction and axis rows.
  CHECK(m.points() == 2 * 97);
  m.probe_result("{\"id\": 1, \"time_s\": 200000, \"errors\": {\"E_X0C\": 1.5}}");
  m.published("event", "{\"type\": \"MessageRejected\", \"reason\": \"<script>\"}");
  m.published("state", "{\"online\": true}");
  CHECK(m.points() == 2 * 97 + 1);
  const std::string h = m.html();
  CHECK(h.find("dmu-&lt;1&gt;") != std::string::npos);
  CHECK(h.find("&lt;script&gt;") != std::string::npos);
  CHECK(h.find("<script>\"") == std::string::npos);
  CHECK(m.state_json() == "{\"online\": true}");
  m.published("offsets", "not JSON");  // ignored
  CHECK(m.points() == 2 * 97 + 1);
}

TEST_CASE("the status page on 127.0.0.1 in a real browser: loads without console errors, its charts hold the points given, GET only", "[browser]") {
  MosquittoLib lib;
  const fs::path dir = temp_dir("status");
  Broker broker(dir, false);
  const int port = free_port();
  write(dir / "s.toml", small_config(broker.port) + "[status]\nlisten = \"" + std::to_string(port) + "\"\n");
  Client c(broker.port, "gateway");
  const pid_t pid = start_supervisor(dir);
  const ChildGuard guard{pid};
  REQUIRE(c.until([&] { return c.state().value("online", false); }));
  // Six hours of samples every minute; each probe request answered at once with known errors.
  std::set<std::int64_t> answered;
  std::size_t seen = 0;
  int results = 0;
  for (int k = 0; k < 360; ++k) {
    const double t = 60.0 * k;
    c.publish("sample", sample_at(t));
    REQUIRE(c.until([&] { return c.state().value("received", 0) == k + 1; }));
    for (; seen < c.received.size(); ++seen) {
      if (c.received[seen].first != "alc/dmu-1/probe/request") continue;
      const auto id = Json::parse(c.received[seen].second)["id"].get<std::int64_t>();
      if (!answered.insert(id).second) continue;
      c.publish("probe/result",
                Json{{"id", id}, {"time_s", t}, {"errors", {{"E_X0C", 0.1 * id}, {"E_Y0C", nullptr}}}}.dump());
      ++results;
    }
  }
  REQUIRE(c.until([&] { return c.state().value("probes", 0) == results && c.state().value("held", 1) == 0; }));
  REQUIRE(results >= 3);
  const auto offsets = std::count_if(c.received.begin(), c.received.end(),
                                     [](const auto& m) { return m.first == "alc/dmu-1/offsets"; });
  REQUIRE(offsets >= 3);

  // Only the page's port, on 127.0.0.1 (0100007F); GET only; nothing outside its two paths.
  const auto ports = listening(pid);
  REQUIRE(ports.size() == 1);
  CHECK(ports[0].first == "0100007F");
  CHECK(ports[0].second == port);
  CHECK(http_status(port, "GET / HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n") == "HTTP/1.1 200 OK");
  CHECK(http_status(port, "GET /state.json HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n") == "HTTP/1.1 200 OK");
  CHECK(http_status(port, "GET /../../etc/passwd HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n").find(" 200 ") ==
        std::string::npos);
  CHECK(http_status(port, "GET /h.sqlite HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n") == "HTTP/1.1 404 Not Found");
  CHECK(http_status(port, "POST / HTTP/1.1\r\nHost: x\r\nContent-Length: 2\r\nConnection: close\r\n\r\n{}") ==
        "HTTP/1.1 405 Method Not Allowed");
  const std::string huge = "GET /" + std::string(20000, 'a') + " HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n";
  CHECK(http_status(port, huge).find(" 200 ") == std::string::npos);

  const fs::path bdir = dir / "browser";
  fs::create_directories(bdir);
  const auto b = report::test::chromium_url(bdir, "--virtual-time-budget=5000 --dump-dom",
                                            "http://127.0.0.1:" + std::to_string(port) + "/");
  REQUIRE(b.exit_code == 0);
  INFO(b.err);
  CHECK(b.err.find(":CONSOLE") == std::string::npos);  // no console message at all, errors included
  const std::string text = report::test::dom_check(b.out);
  REQUIRE_FALSE(text.empty());
  const Json j = Json::parse(text);
  CHECK(j.at("errors").empty());
  std::map<std::string, std::map<std::string, std::size_t>> points;  // chart id -> series -> points
  for (const auto& chart : j.at("charts"))
    for (const auto& s : chart.at("series"))
      points[chart.at("id").get<std::string>()][s.at("name").get<std::string>()] = s.at("points").get<std::size_t>();
  INFO(j.dump());
  CHECK(points["measured"]["E_X0C"] == static_cast<std::size_t>(results));
  CHECK(points["predicted"]["E_X0C"] == static_cast<std::size_t>(offsets));
  CHECK(points["offsets"].count("x_mm") == 1);
  // The probe requests as markers on the time axis: one line each with its id as tooltip, or one path
  // with a line per request beyond report::kMarkersAsLines.
  if (answered.size() <= report::kMarkersAsLines)
    CHECK(report::test::count(b.out, "<title>probe request ") == answered.size());
  else
    CHECK(b.out.find("<path class=\"marker marker-sent\" data-markers=\"" + std::to_string(answered.size()) + "\"") !=
          std::string::npos);

  ::kill(pid, SIGTERM);
  CHECK(wait_exit(pid) == 0);
  CHECK_FALSE(port_open(port));
}

TEST_CASE("the status page listens on an IPv6 address given in brackets: ::1 answers GET, 127.0.0.1 does not") {
  const supervisor::StatusModel model("m", {"E_X0C"}, 86400.0);
  supervisor::StatusConfig config;
  config.host = "::1";
  config.port = free_port();
  const supervisor::StatusServer server(config, model);
  CHECK(http_status(config.port, "GET /state.json HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n", true) ==
        "HTTP/1.1 200 OK");
  CHECK_FALSE(port_open(config.port));  // 127.0.0.1: nothing listens there
  // A second server on the same address names it as written in the config.
  CHECK_THROWS_WITH(supervisor::StatusServer(config, model),
                    Catch::Contains("status page: cannot listen on [::1]:" + std::to_string(config.port) +
                                    " (key status.listen)"));
}

TEST_CASE("a status port already in use is an error naming it, not a second listener beside the first") {
  // Before: cpp-httplib's SO_REUSEPORT let a second supervisor bind the same port, and the kernel
  // spread the requests over both (another machine's state, at random).
  const supervisor::StatusModel model("m", {"E_X0C"}, 86400.0);
  supervisor::StatusConfig config;
  config.port = free_port();
  const supervisor::StatusServer first(config, model);
  CHECK_THROWS_WITH(supervisor::StatusServer(config, model),
                    Catch::Contains("status page: cannot listen on 127.0.0.1:" + std::to_string(config.port)));
  // A server stopped as soon as it is made (a supervisor the broker refuses at once) stops: before, a stop
  // before its thread listened did nothing, and the join waited for ever (this test hung in the suite).
  for (int i = 0; i < 50; ++i) {
    supervisor::StatusConfig other;
    other.port = free_port();
    const supervisor::StatusServer brief(other, model);
  }
}

TEST_CASE("without a status section in its config the supervisor listens on no port") {
  const SmallSupervisor sup("no-status");
  CHECK(listening(sup.pid).empty());
  ::kill(sup.pid, SIGTERM);
  CHECK(wait_exit(sup.pid) == 0);
}

TEST_CASE("the status section of the config: 127.0.0.1 unless another host is written, bad addresses name the key and value") {
  const std::string base = small_config(1883);
  auto parse = [&](const std::string& status) { return supervisor::parse_supervisor_config(base + status, "/tmp/s.toml"); };
  CHECK_FALSE(parse("").status.has_value());
  const auto c = parse("[status]\nlisten = \"8080\"\n");
  REQUIRE(c.status.has_value());
  CHECK(c.status->host == "127.0.0.1");
  CHECK(c.status->port == 8080);
  CHECK(c.status->window_s == 86400.0);
  const auto d = parse("[status]\nlisten = \"0.0.0.0:9000\"\nwindow_h = 6\n");
  CHECK(d.status->host == "0.0.0.0");
  CHECK(d.status->window_s == 6 * 3600.0);
  // IPv6 in brackets, as in a URL; without them "::1:8080" would read as host "::1", port 8080 or as
  // host "::1:8080" and no port: refused with the form to write.
  const auto v6 = parse("[status]\nlisten = \"[::1]:8081\"\n");
  CHECK(v6.status->host == "::1");
  CHECK(v6.status->port == 8081);
  CHECK(parse("[status]\nlisten = \"[fe80::1]:80\"\n").status->host == "fe80::1");
  for (const std::string bad : {"\"\"", "\"abc\"", "\"127.0.0.1:0\"", "\"127.0.0.1:99999\"", "\"127.0.0.1:\"", "8080",
                                "\"::1:8080\"", "\"[::1]\"", "\"[::1]8080\"", "\"[]:8080\"", "\"[::1:8080\"", "\"[::1]:\"",
                                "\"[::1]:0\"", "\"[a b]:80\"", "\"[::1]:80:80\""}) {
    INFO(bad);
    try {
      parse("[status]\nlisten = " + bad + "\n");
      FAIL("accepted");
    } catch (const supervisor::ConfigError& e) {
      CHECK(std::string(e.what()).find("/tmp/s.toml: key 'status.listen', value " + bad) != std::string::npos);
    }
  }
  CHECK_THROWS_WITH(parse("[status]\nlisten = \"::1:8080\"\n"), Catch::Contains("written in brackets before the port"));
  CHECK_THROWS_WITH(parse("[status]\nlisten = \"8080\"\nport = 1\n"), Catch::Contains("key 'status.port', value 1: unknown key"));
}
