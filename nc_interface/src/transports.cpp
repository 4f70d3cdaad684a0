#include "nc_interface/transports.hpp"

#include <arpa/inet.h>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <netdb.h>
#include <netinet/in.h>
#include <ostream>
#include <poll.h>
#include <random>
#include <sstream>
#include <sys/socket.h>
#include <thread>
#include <unistd.h>

#include "common/atomic_file.hpp"
#include "common/log.hpp"
#include "nc_interface/nc_number.hpp"
#include "nc_interface/recorder.hpp"

namespace alc::nc {
namespace {

constexpr long kSpoolLast = 999999;

bool is_loopback(const std::string& host) { return host == "127.0.0.1" || host == "localhost" || host == "::1"; }

// Text that goes into the linuxcncrsh protocol must be one word without control characters.
void check_word(const std::string& what, const std::string& text) {
  if (text.empty()) throw SinkError("linuxcncrsh: " + what + " is empty");
  for (unsigned char ch : text)
    if (ch <= ' ' || ch >= 0x7f) throw SinkError("linuxcncrsh: " + what + " must be one printable word");
}

std::string upper(std::string s) {
  for (char& c : s) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return s;
}

}  // namespace

std::string delivery_error(const Sink& sink, const std::exception& error) {
  const std::string what = error.what(), name = sink.name();
  return what.rfind(name, 0) == 0 ? what : name + ": " + what;
}

StreamSink::StreamSink(std::ostream& out, Dialect dialect, DialectOptions options)
    : out_(out), dialect_(dialect), options_(std::move(options)) {}

void StreamSink::deliver(const NcCommand& command) {
  const std::string program = write_program(dialect_, {command}, options_);
  out_ << program;
  out_.flush();
  if (!out_) throw SinkError("stream: write failed");
}

SpoolSink::SpoolSink(std::filesystem::path dir, Dialect dialect, DialectOptions options)
    : dir_(std::move(dir)), dialect_(dialect), options_(std::move(options)) {}

void SpoolSink::deliver(const NcCommand& command) {
  const std::string program = write_program(dialect_, {command}, options_);
  std::error_code ec;
  if (!std::filesystem::is_directory(dir_, ec)) throw SinkError("spool " + dir_.string() + ": not a directory");
  // The next number after the highest already there (a name alc_<digits><ext>, any number of digits),
  // claimed without replacing anything: another writer that took it first makes this one try the next.
  long next = 1;
  for (const auto& entry : std::filesystem::directory_iterator(dir_, ec)) {
    const std::string name = entry.path().stem().string();
    if (name.rfind("alc_", 0) != 0 || name.size() < 5 || name.size() > 14) continue;
    if (name.find_first_not_of("0123456789", 4) != std::string::npos) continue;
    next = std::max(next, std::stol(name.substr(4)) + 1);
  }
  if (ec) throw SinkError("spool " + dir_.string() + ": " + ec.message());
  std::filesystem::path path;
  for (;; ++next) {
    // Six digits keep the names in order when sorted by name; the millionth file would not be.
    if (next > kSpoolLast)
      throw SinkError("spool " + dir_.string() + ": full, alc_" + std::to_string(kSpoolLast) +
                      " is taken (names past it would sort before it); empty the spool");
    char name[32];
    std::snprintf(name, sizeof name, "alc_%06ld", next);
    path = dir_ / (name + std::string(program_extension(dialect_)));
    try {
      if (io::write_new_file_atomically(path, program)) break;
    } catch (const std::exception& e) {
      throw SinkError("spool: " + std::string(e.what()));
    }
  }
  last_ = path;
}

LinuxcncrshClient::LinuxcncrshClient(LinuxcncrshOptions options) : options_(std::move(options)) {
  std::random_device random;
  char nonce[16];
  std::snprintf(nonce, sizeof nonce, "%08X", static_cast<unsigned>(random()));
  readback_nonce_ = nonce;
}

LinuxcncrshClient::~LinuxcncrshClient() { close(); }

void LinuxcncrshClient::close() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  buffer_.clear();
  mm_per_unit_ = 0.0;
}

void LinuxcncrshClient::connect() {
  close();
  if (!is_loopback(options_.host))
    throw SinkError("linuxcncrsh: host '" + options_.host + "' refused: only localhost is allowed");
  if (options_.port < 1 || options_.port > 65535)
    throw SinkError("linuxcncrsh: port must be 1…65535, got " + std::to_string(options_.port));
  check_word("connect password", options_.connect_password);
  check_word("enable password", options_.enable_password);
  addrinfo hints{};
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* found = nullptr;
  const std::string port = std::to_string(options_.port);
  if (::getaddrinfo(options_.host == "localhost" ? "127.0.0.1" : options_.host.c_str(), port.c_str(), &hints, &found) != 0)
    throw SinkError("linuxcncrsh: cannot resolve " + options_.host);
  const int fd = ::socket(found->ai_family, SOCK_STREAM, 0);
  const int rc = fd < 0 ? -1 : ::connect(fd, found->ai_addr, found->ai_addrlen);
  const int err = errno;
  ::freeaddrinfo(found);
  if (rc != 0) {
    if (fd >= 0) ::close(fd);
    throw SinkError("linuxcncrsh: cannot connect to " + options_.host + ":" + port + ": " + std::strerror(err));
  }
  fd_ = fd;
  const std::string hello = request("hello " + options_.connect_password + " alc 1.0");
  if (hello.rfind("HELLO ACK", 0) != 0) {
    close();
    throw SinkError("linuxcncrsh: hello refused: '" + hello + "'");
  }
  request("set echo off");  // answered by the echo of this very line
  set("verbose on");
  set("enable " + options_.enable_password);
  alc::log::get("nc")->info("linuxcncrsh: connected to {}:{}", options_.host, options_.port);
}

std::string LinuxcncrshClient::read_line() {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(options_.timeout_s);
  for (;;) {
    const auto nl = buffer_.find('\n');
    if (nl != std::string::npos) {
      std::string line = buffer_.substr(0, nl);
      buffer_.erase(0, nl + 1);
      std::erase(line, '\r');  // replies end in "\r\n" or "\n\r"
      if (!line.empty()) return line;
      continue;
    }
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) throw SinkError("linuxcncrsh: no reply within " + std::to_string(options_.timeout_s) + " s");
    pollfd p{fd_, POLLIN, 0};
    const int ready = ::poll(&p, 1, static_cast<int>(left.count()));
    if (ready < 0 && errno == EINTR) continue;
    if (ready <= 0) continue;
    char chunk[1024];
    const ssize_t got = ::recv(fd_, chunk, sizeof chunk, 0);
    if (got <= 0) {
      close();
      throw SinkError("linuxcncrsh: connection closed");
    }
    buffer_.append(chunk, static_cast<std::size_t>(got));
  }
}

std::string LinuxcncrshClient::request(const std::string& line) {
  if (fd_ < 0) throw SinkError("linuxcncrsh: not connected");
  if (line.find_first_of("\r\n") != std::string::npos) throw SinkError("linuxcncrsh: request contains a line break");
  const std::string wire = line + "\r\n";
  std::size_t sent = 0;
  while (sent < wire.size()) {
    const ssize_t n = ::send(fd_, wire.data() + sent, wire.size() - sent, MSG_NOSIGNAL);
    if (n <= 0) {
      close();
      throw SinkError("linuxcncrsh: send failed");
    }
    sent += static_cast<std::size_t>(n);
  }
  return read_line();
}

void LinuxcncrshClient::set(const std::string& what) {
  const std::string reply = request("set " + what);
  const std::string command = upper(what.substr(0, what.find(' ')));
  if (reply == "SET " + command + " ACK") return;
  std::string detail;
  if (reply == "SET " + command + " NAK") {
    try {
      detail = request("get error");
    } catch (const SinkError&) {
    }
  }
  throw SinkError("linuxcncrsh: 'set " + what + "' answered '" + reply + "'" + (detail.empty() ? "" : " (" + detail + ")"));
}

void LinuxcncrshClient::mdi(const std::vector<std::string>& lines) {
  set("mode mdi");
  set("set_wait done");
  for (const std::string& line : lines) set("mdi " + line);
}

std::array<double, 6> LinuxcncrshClient::position_offsets() {
  const std::string reply = request("get pos_offset");
  std::istringstream in(reply);
  std::string tag;
  std::array<double, 6> out{};
  in >> tag;
  for (double& v : out) in >> v;
  if (tag != "POS_OFFSET" || in.fail()) throw SinkError("linuxcncrsh: unexpected reply to 'get pos_offset': '" + reply + "'");
  return out;
}

double LinuxcncrshClient::machine_mm_per_unit() {
  if (mm_per_unit_ > 0.0) return mm_per_unit_;
  const std::string reply = request("get user_linear_units");
  if (reply == "USER_LINEAR_UNITS MM") mm_per_unit_ = 1.0;
  else if (reply == "USER_LINEAR_UNITS INCH") mm_per_unit_ = 25.4;
  else if (reply == "USER_LINEAR_UNITS CM") mm_per_unit_ = 10.0;
  else throw SinkError("linuxcncrsh: machine length unit not mm, inch or cm ('get user_linear_units' answered '" +
                       reply + "'), so work offsets cannot be read back");
  return mm_per_unit_;
}

std::vector<double> LinuxcncrshClient::parameters(const std::vector<int>& numbers, const std::string& what) {
  if (numbers.empty()) return {};
  const std::string tag = "ALC-READBACK-" + readback_nonce_ + "-" + std::to_string(++readback_count_);
  std::string line = "(DEBUG," + tag;
  for (int n : numbers) line += " #" + std::to_string(n);
  line += ")";
  set("mode mdi");
  set("set_wait done");
  set("mdi " + line);
  // The message goes to the operator display; `get operator_display` returns it once, then "OK".
  const std::string prefix = "OPERATOR_DISPLAY " + tag + " ";
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(options_.timeout_s);
  for (;;) {
    const std::string reply = request("get operator_display");
    if (reply.rfind(prefix, 0) == 0) {
      std::istringstream in(reply.substr(prefix.size()));
      std::vector<double> out(numbers.size());
      for (double& v : out) in >> v;
      if (in.fail()) throw SinkError("linuxcncrsh: unexpected read-back of " + what + ": '" + reply + "'");
      return out;
    }
    if (std::chrono::steady_clock::now() > deadline)
      throw SinkError("linuxcncrsh: the read-back of " + what + " did not reach the operator display within " +
                      std::to_string(options_.timeout_s) + " s (last reply '" + reply + "')");
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

std::array<double, 6> LinuxcncrshClient::work_offset_values(int work_offset) {
  const std::string name = work_offset_name(work_offset);  // throws for anything but 1…6
  const double mm = machine_mm_per_unit();
  const int first = 5201 + 20 * work_offset;  // G54: 5221 (X) … 5226 (C)
  const std::vector<double> got = parameters({first, first + 1, first + 2, first + 3, first + 4, first + 5}, name);
  std::array<double, 6> out{};
  for (std::size_t k = 0; k < 6; ++k) out[k] = got[k] * (k < 3 ? mm : 1.0);  // lengths: machine units -> mm
  return out;
}

LinuxcncrshSink::LinuxcncrshSink(LinuxcncrshOptions options, DialectOptions nc)
    : options_(std::move(options)), nc_(std::move(nc)), client_(options_) {}

std::string LinuxcncrshSink::name() const {
  return "linuxcncrsh " + options_.host + ":" + std::to_string(options_.port);
}

void LinuxcncrshSink::deliver(const NcCommand& command) {
  const std::vector<std::string> lines = linuxcnc_mdi_lines(command, nc_);
  const auto* o = std::get_if<AxisOffsets>(&command);
  if (!client_.connected()) client_.connect();
  std::array<double, 6> got{};
  try {
    // Before anything is sent: the read-back must be possible (a machine length unit we can convert).
    if (o) client_.machine_mm_per_unit();
    client_.mdi(lines);
    if (!o) return;
    // The stored value of the target work offset, not pos_offset (active work offset + G92).
    got = client_.work_offset_values(o->work_offset);
  } catch (const SinkError& e) {
    alc::log::get("nc")->info("linuxcncrsh {}:{}: closing the session after an error: {}", options_.host,
                              options_.port, e.what());
    client_.close();  // a fresh session next time
    throw;
  }
  const BaseOffset& b = nc_.base[static_cast<std::size_t>(o->work_offset - 1)];
  const std::array<double, 6> want{with_base(b.x_mm, o->x_mm), with_base(b.y_mm, o->y_mm),
                                   with_base(b.z_mm, o->z_mm), with_base(b.a_deg, o->a_deg.value_or(0.0)),
                                   with_base(b.b_deg, o->b_deg.value_or(0.0)), with_base(b.c_deg, o->c_deg)};
  static constexpr char kAxes[] = "XYZABC";
  for (std::size_t i = 0; i < 6; ++i) {
    if (i == 3 && !o->a_deg) continue;
    if (i == 4 && !o->b_deg) continue;
    // Compare with the text that was sent (4 decimals); LinuxCNC prints 6.
    const std::string sent = format_nc_number(want[i]);
    if (std::abs(got[i] - std::stod(sent)) > 0.5e-4)
      throw SinkError("linuxcncrsh: read back " + work_offset_name(o->work_offset) + " " + std::string(1, kAxes[i]) +
                      " offset " + std::to_string(got[i]) + " (parameter #" +
                      std::to_string(5201 + 20 * o->work_offset + static_cast<int>(i)) + "), sent " + sent);
  }
}

DeliveryReport CommandQueue::flush(Sink& sink) {
  DeliveryReport report;
  while (!pending_.empty()) {
    try {
      sink.deliver(pending_.front());
    } catch (const std::exception& e) {
      report.error = delivery_error(sink, e);
      alc::log::get("nc")->warn("delivery failed, {} command(s) kept pending: {}", pending_.size(), report.error);
      break;
    }
    pending_.pop_front();
    ++report.delivered;
  }
  report.pending = pending_.size();
  return report;
}

}  // namespace alc::nc
