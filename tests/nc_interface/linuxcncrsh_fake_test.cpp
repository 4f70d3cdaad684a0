// LinuxcncrshSink against a fake linuxcncrsh on localhost: what the read-back reads and when it
// refuses, without starting the simulator (linuxcnc_test.cpp does that). The fake keeps the numbered
// parameters of the six work offsets (machine units), an active work offset, a G92 offset, and the
// operator display, as LinuxCNC does; it answers the requests LinuxcncrshClient sends.
#include <cctype>
#include <catch2/catch.hpp>

#include <arpa/inet.h>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <map>
#include <mutex>
#include <netinet/in.h>
#include <poll.h>
#include <sstream>
#include <sys/socket.h>
#include <thread>
#include <unistd.h>

#include "../cli_support.hpp"
#include "nc_interface/dialects.hpp"
#include "nc_interface/jsonl.hpp"
#include "nc_interface/transports.hpp"
#include "nc_test_support.hpp"

using namespace alc::nc;
using Catch::Matchers::Contains;
using Catch::Matchers::WithinAbs;

namespace {

using alc::nc::test::offsets;

class FakeLinuxcncrsh {
 public:
  std::string units = "MM";        // reply to get user_linear_units: MM, INCH or anything else
  bool apply_g10 = true;           // false: a G10 is acknowledged but not stored
  bool answer_debug = true;        // false: (DEBUG,…) never reaches the operator display
  int active = 1;                  // active work offset (1 = G54)
  std::array<double, 6> g92{};     // [mm] / [°]
  std::map<int, double> params;    // numbered parameters, lengths in machine units
  std::deque<std::string> display; // operator display messages, oldest first

  FakeLinuxcncrsh() {
    listen_fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = 0;  // any free port
    socklen_t len = sizeof a;
    if (listen_fd_ < 0 || ::bind(listen_fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 ||
        ::listen(listen_fd_, 4) != 0 || ::getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&a), &len) != 0)
      throw std::runtime_error("fake linuxcncrsh: cannot listen on localhost");
    port_ = ntohs(a.sin_port);
    thread_ = std::thread([this] { serve(); });
  }
  ~FakeLinuxcncrsh() {
    stop_ = true;
    thread_.join();
    ::close(listen_fd_);
  }
  int port() const { return port_; }
  std::vector<std::string> received() {
    const std::lock_guard<std::mutex> lock(mutex_);
    return received_;
  }
  double param(int p) {
    const std::lock_guard<std::mutex> lock(mutex_);
    return params[p];
  }
  std::mutex& mutex() { return mutex_; }

 private:
  double mm_per_unit() const { return units == "INCH" ? 25.4 : 1.0; }

  static std::string f(double v) {
    char b[64];
    std::snprintf(b, sizeof b, "%f", v);
    return b;
  }

  std::string answer(const std::string& line) {
    const std::lock_guard<std::mutex> lock(mutex_);
    received_.push_back(line);
    if (line.rfind("hello ", 0) == 0) return "HELLO ACK EMCNETSVR 1.1";
    if (line == "set echo off") return line;
    if (line.rfind("set mdi ", 0) == 0) {
      mdi(line.substr(8));
      return "SET MDI ACK";
    }
    if (line.rfind("set ", 0) == 0) {
      std::string word = line.substr(4, line.find(' ', 4) - 4);
      for (char& ch : word) ch = static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
      return "SET " + word + " ACK";
    }
    if (line == "get user_linear_units") return "USER_LINEAR_UNITS " + units;
    if (line == "get error") return "ERROR OK";
    if (line == "get operator_display") {
      if (display.empty()) return "OPERATOR_DISPLAY OK";
      const std::string m = display.front();
      display.pop_front();
      return "OPERATOR_DISPLAY " + m;
    }
    if (line == "get pos_offset") {  // active G5x + G92, as linuxcncrsh reports it
      std::string r = "POS_OFFSET";
      for (int k = 0; k < 6; ++k)
        r += " " + f(params[5201 + 20 * active + k] * (k < 3 ? mm_per_unit() : 1.0) + g92[static_cast<std::size_t>(k)]);
      return r;
    }
    return "GET NAK";
  }

  void mdi(const std::string& text) {
    if (text.rfind("(DEBUG,", 0) == 0) {
      if (!answer_debug) return;
      // Replaces every #NNNN by the parameter's value, as LinuxCNC's DEBUG comment does.
      const std::string body = text.substr(7, text.size() - 8);
      std::string out;
      for (std::size_t at = 0; at < body.size();) {
        std::size_t end = at + 1;
        while (body[at] == '#' && end < body.size() && std::isdigit(static_cast<unsigned char>(body[end]))) ++end;
        if (body[at] == '#' && end > at + 1) {
          out += f(params[std::stoi(body.substr(at + 1, end - at - 1))]);
          at = end;
        } else {
          out += body[at++];
        }
      }
      display.push_back(out);
      return;
    }
    std::istringstream in(text);
    std::vector<std::string> words;
    for (std::string w; in >> w;) words.push_back(w);
    if (words.size() < 4 || words[0] != "G21" || words[1] != "G10" || words[2] != "L2" || words[3][0] != 'P') return;
    const int p = std::stoi(words[3].substr(1));
    if (!apply_g10) return;
    const std::string axes = "XYZABC";
    for (std::size_t i = 4; i < words.size(); ++i) {
      const auto k = static_cast<int>(axes.find(words[i][0]));
      const double v = std::stod(words[i].substr(1));  // G21: mm
      params[5201 + 20 * p + k] = k < 3 ? v / mm_per_unit() : v;
    }
  }

  void serve() {
    while (!stop_) {
      pollfd p{listen_fd_, POLLIN, 0};
      if (::poll(&p, 1, 50) <= 0) continue;
      const int fd = ::accept(listen_fd_, nullptr, nullptr);
      if (fd < 0) continue;
      std::string buffer;
      while (!stop_) {
        pollfd c{fd, POLLIN, 0};
        if (::poll(&c, 1, 50) <= 0) continue;
        char chunk[512];
        const ssize_t got = ::recv(fd, chunk, sizeof chunk, 0);
        if (got <= 0) break;
        buffer.append(chunk, static_cast<std::size_t>(got));
        for (auto nl = buffer.find('\n'); nl != std::string::npos; nl = buffer.find('\n')) {
          std::string line = buffer.substr(0, nl);
          buffer.erase(0, nl + 1);
          if (!line.empty() && line.back() == '\r') line.pop_back();
          const std::string reply = answer(line) + "\r\n";
          if (::send(fd, reply.data(), reply.size(), MSG_NOSIGNAL) < 0) break;
        }
      }
      ::close(fd);
    }
  }

  int listen_fd_ = -1;
  int port_ = 0;
  std::atomic<bool> stop_{false};
  std::mutex mutex_;
  std::vector<std::string> received_;
  std::thread thread_;
};

// Changes the fake's state while its thread may be answering.
template <class F>
void set(FakeLinuxcncrsh& fake, F change) {
  const std::lock_guard<std::mutex> lock(fake.mutex());
  change(fake);
}

LinuxcncrshOptions options_for(const FakeLinuxcncrsh& fake, double timeout_s = 5.0) {
  LinuxcncrshOptions o;
  o.port = fake.port();
  o.timeout_s = timeout_s;
  return o;
}

bool any_line_contains(const std::vector<std::string>& lines, const std::string& text) {
  for (const std::string& l : lines)
    if (l.find(text) != std::string::npos) return true;
  return false;
}

}  // namespace

TEST_CASE("linuxcncrsh sink: reads back the target work offset, not the active one plus G92", "[nc][transport]") {
  FakeLinuxcncrsh fake;
  set(fake, [](FakeLinuxcncrsh& f) {
    f.active = 1;                              // G54 is active …
    f.params[5221] = 5.0;                      // … with its own offset
    f.g92 = {1.5, -2.0, 0.25, 0.0, 0.0, 0.0};  // and a G92 offset in force
    f.display.push_back("ALC-READBACK-00000000-1 9 9 9 9 9 9");  // a stale message: must be ignored
  });
  DialectOptions nc;
  nc.base[1] = {100.0, -50.0, 20.0, 0.0, 0.0, 90.0};
  LinuxcncrshSink sink(options_for(fake), nc);
  CommandQueue queue;
  queue.push(offsets(0.0123, -0.004, 0.01, 0.001, -0.002, 2));  // G55: base + compensation
  queue.push(offsets(-0.0071, 0.0032, 0.0, -0.0004, 0.0005, 1));  // G54 under G92
  const DeliveryReport r = queue.flush(sink);
  INFO(r.error);
  REQUIRE(r.ok());
  CHECK(r.delivered == 2);
  CHECK_THAT(fake.param(5241), WithinAbs(100.0123, 1e-12));
  CHECK_THAT(fake.param(5246), WithinAbs(89.998, 1e-12));
  CHECK_THAT(fake.param(5221), WithinAbs(-0.0071, 1e-12));
  const auto lines = fake.received();
  CHECK(any_line_contains(lines, " #5241 #5242 #5243 #5244 #5245 #5246)"));
  CHECK(any_line_contains(lines, " #5221 #5222 #5223 #5224 #5225 #5226)"));
  CHECK_FALSE(any_line_contains(lines, "get pos_offset"));  // G5x + G92 of the active offset: not used
}

TEST_CASE("linuxcncrsh sink: a G10 that did not take is an error naming offset, axis and parameter", "[nc][transport]") {
  FakeLinuxcncrsh fake;
  set(fake, [](FakeLinuxcncrsh& f) { f.apply_g10 = false; });
  LinuxcncrshSink sink(options_for(fake));
  CommandQueue queue;
  queue.push(offsets(0.0123, 0, 0, 0, 0, 3));
  const DeliveryReport r = queue.flush(sink);
  CHECK(r.pending == 1);  // nothing lost
  CHECK_THAT(r.error, Contains("read back G56 X offset 0.000000 (parameter #5261), sent 0.0123"));
}

TEST_CASE("linuxcncrsh sink: an inch machine is read back in inches, an unknown unit is refused before sending",
          "[nc][transport]") {
  SECTION("inch") {
    FakeLinuxcncrsh fake;
    set(fake, [](FakeLinuxcncrsh& f) { f.units = "INCH"; });  // parameters in inches, printed with 6 decimals
    LinuxcncrshSink sink(options_for(fake));
    CommandQueue queue;
    queue.push(offsets(0.0123, -0.0987, 0.05, 0.001, -0.002, 1));
    const DeliveryReport r = queue.flush(sink);
    INFO(r.error);
    CHECK(r.ok());
    CHECK_THAT(fake.param(5221), WithinAbs(0.0123 / 25.4, 1e-15));
  }
  SECTION("unknown unit") {
    FakeLinuxcncrsh fake;
    set(fake, [](FakeLinuxcncrsh& f) { f.units = "CUSTOM"; });
    LinuxcncrshSink sink(options_for(fake));
    CommandQueue queue;
    queue.push(offsets(0.0123, 0, 0, 0, 0, 1));
    const DeliveryReport r = queue.flush(sink);
    CHECK(r.pending == 1);
    CHECK_THAT(r.error, Contains("not mm, inch or cm") && Contains("CUSTOM"));
    CHECK_FALSE(any_line_contains(fake.received(), "G10"));  // refused before anything was sent
  }
}

TEST_CASE("linuxcncrsh sink: a read-back that never arrives is an error within the timeout", "[nc][transport]") {
  FakeLinuxcncrsh fake;
  set(fake, [](FakeLinuxcncrsh& f) { f.answer_debug = false; });
  LinuxcncrshSink sink(options_for(fake, 0.5));
  CommandQueue queue;
  queue.push(offsets(0.001, 0, 0, 0, 0, 6));
  const auto start = std::chrono::steady_clock::now();
  const DeliveryReport r = queue.flush(sink);
  CHECK(std::chrono::steady_clock::now() - start < std::chrono::seconds(5));
  CHECK(r.pending == 1);
  CHECK_THAT(r.error, Contains("read-back of G59 did not reach the operator display"));
  // A probe interval needs no read-back.
  set(fake, [](FakeLinuxcncrsh& f) { f.answer_debug = true; });
  CommandQueue intervals;
  intervals.push(ProbeInterval{5.0, {}});
  CHECK(intervals.flush(sink).ok());
}

TEST_CASE("alc nc --sink linuxcncrsh: delivers and reads back, what did not take goes to stderr with exit 1",
          "[nc][transport][cli]") {
  const auto dir = alc::nc::test::fresh_dir("cli_linuxcncrsh");
  alc::nc::test::write_text(dir / "m.toml", std::string(alc::nc::test::kZeroBaseG54) +
                                                "[nc.base.G55]\nx_mm = 100.0\ny_mm = 0.0\nz_mm = 0.0\na_deg = 0.0\nc_deg = 90.0\n");
  const std::string machine = " --machine " + (dir / "m.toml").string();
  const auto write_in = [&](const std::vector<NcCommand>& commands) {
    std::ostringstream jsonl;
    write_commands_jsonl(jsonl, commands);
    alc::nc::test::write_text(dir / "in.jsonl", jsonl.str());
    return " --in " + (dir / "in.jsonl").string();
  };
  FakeLinuxcncrsh fake;
  const std::string sink = " --sink linuxcncrsh --port " + std::to_string(fake.port());

  const AxisOffsets g55 = offsets(0.0093, -0.004, 0.01, 0.0009, -0.0008, 2);  // within max_step of zero
  const AxisOffsets g54 = offsets(-0.0071, 0.0032, 0.0, -0.0004, 0.0005, 1);
  auto r = alc_test::run_alc("nc --dialect linuxcnc" + machine + sink + write_in({g55, ProbeInterval{30.0, {}}, g54}),
                             "cli_linuxcncrsh");
  INFO(r.err);
  CHECK(r.exit_code == 0);
  CHECK_THAT(r.err, Contains("3 command(s) delivered to linuxcncrsh 127.0.0.1:" + std::to_string(fake.port())));
  CHECK_THAT(fake.param(5241), WithinAbs(100.0093, 1e-12));  // G55: base + compensation
  CHECK_THAT(fake.param(5246), WithinAbs(89.9992, 1e-12));
  CHECK_THAT(fake.param(5221), WithinAbs(-0.0071, 1e-12));   // G54
  CHECK(any_line_contains(fake.received(), "set mdi #3001 = 30.0000"));

  // A G10 that does not take: the interval before it is delivered, the offsets are not and are printed.
  set(fake, [](FakeLinuxcncrsh& f) { f.apply_g10 = false; });
  const AxisOffsets g55_next = offsets(0.0063, -0.004, 0.01, 0.0009, -0.0008, 2);
  r = alc_test::run_alc("nc --dialect linuxcnc" + machine + sink + write_in({ProbeInterval{20.0, {}}, g55_next, g54}),
                        "cli_linuxcncrsh");
  CHECK(r.exit_code == 1);
  CHECK_THAT(r.err, Contains("1 delivered, 2 not delivered:") &&
                        Contains("read back G55 X offset 100.009300 (parameter #5241), sent 100.0063"));
  CHECK(alc::nc::test::undelivered_commands(r.err) == std::vector<NcCommand>{g55_next, g54});
  CHECK_THAT(fake.param(5241), WithinAbs(100.0093, 1e-12));  // unchanged
  std::filesystem::remove_all(dir);
}
