#pragma once
// Where NC commands go: a spool directory, a stream (stdout), or a running LinuxCNC over
// linuxcncrsh. A CommandQueue keeps every command until a sink has taken it: a sink that fails
// leaves the command queued and the failure is reported, nothing is lost.
#include <array>
#include <deque>
#include <filesystem>
#include <iosfwd>
#include <stdexcept>
#include <string>
#include <vector>

#include "nc_interface/commands.hpp"
#include "nc_interface/dialects.hpp"

namespace alc::nc {

// Thrown by a sink that could not deliver; the message says which sink and why.
struct SinkError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

class Sink {
 public:
  virtual ~Sink() = default;
  virtual std::string name() const = 0;
  // Delivers one command completely or throws SinkError.
  virtual void deliver(const NcCommand& command) = 0;
};

// What a failed delivery of `sink` says: the sink's name and the error, the name once (a SinkError
// of the spool names its directory already).
std::string delivery_error(const Sink& sink, const std::exception& error);

// Writes each command as a program to `out` (e.g. std::cout).
class StreamSink : public Sink {
 public:
  StreamSink(std::ostream& out, Dialect dialect, DialectOptions options = {});
  std::string name() const override { return "stream"; }
  void deliver(const NcCommand& command) override;

 private:
  std::ostream& out_;
  Dialect dialect_;
  DialectOptions options_;
};

// Writes each command as one program file `alc_NNNNNN<ext>` in `dir` (temporary name, then linked to
// its name), numbered after the highest number already there, so a reader sees whole files in order.
// A name is never replaced: two writers on one spool each get names of their own. After alc_999999
// the spool is full (SinkError).
class SpoolSink : public Sink {
 public:
  SpoolSink(std::filesystem::path dir, Dialect dialect, DialectOptions options = {});
  std::string name() const override { return "spool " + dir_.string(); }
  void deliver(const NcCommand& command) override;
  std::filesystem::path last_file() const { return last_; }

 private:
  std::filesystem::path dir_;
  Dialect dialect_;
  DialectOptions options_;
  std::filesystem::path last_;
};

struct LinuxcncrshOptions {
  std::string host = "127.0.0.1";        // loopback only: "127.0.0.1", "localhost" or "::1"
  int port = 5007;                       // linuxcncrsh default
  std::string connect_password = "EMC";  // linuxcncrsh --connectpw default
  std::string enable_password = "EMCTOO";// linuxcncrsh --enablepw default
  double timeout_s = 10.0;               // [s] per request (an MDI line waits until done)
};

// A session with linuxcncrsh (telnet-style text protocol, see `man linuxcncrsh`): hello, echo off,
// verbose on (so every set is answered with ACK or NAK), enable.
class LinuxcncrshClient {
 public:
  explicit LinuxcncrshClient(LinuxcncrshOptions options = {});
  ~LinuxcncrshClient();
  LinuxcncrshClient(const LinuxcncrshClient&) = delete;
  LinuxcncrshClient& operator=(const LinuxcncrshClient&) = delete;

  void connect();                                   // throws SinkError
  bool connected() const { return fd_ >= 0; }
  void close();
  // Sends one line, returns the first non-empty reply line.
  std::string request(const std::string& line);
  // "set WHAT": throws SinkError on NAK (with `get error` text for an MDI line).
  void set(const std::string& what);
  // Sends each line as "set mdi LINE" after "set mode mdi" and "set set_wait done".
  void mdi(const std::vector<std::string>& lines);
  // Offsets in force of X Y Z A B C in the display units ("get pos_offset"): the ACTIVE work offset
  // plus G92, so not the stored value of any one work offset. Kept for checks by hand.
  std::array<double, 6> position_offsets();
  // mm per machine length unit ([TRAJ] LINEAR_UNITS, "get user_linear_units"): 1 (MM), 25.4 (INCH),
  // 10 (CM); SinkError for anything else. Asked once per session.
  double machine_mm_per_unit();
  // The stored value of work offset `work_offset` (1 = G54 … 6 = G59): X Y Z [mm], A B C [°], read
  // from its numbered parameters 5221 + 20·(n−1) … +5 (machine units) by the MDI line
  // "(DEBUG,ALC-READBACK-… #5221 …)" and `get operator_display`. Valid whichever work offset is
  // active and whatever G92 is. Switches to MDI mode; the message also shows on an operator GUI.
  std::array<double, 6> work_offset_values(int work_offset);
  // The values of numbered parameters (e.g. 5070 and 5061…5063 after a G38.2 probe move), as the
  // interpreter holds them in machine units, by one "(DEBUG,ALC-READBACK-… #N …)" MDI line and `get
  // operator_display`. Switches to MDI mode. `what` names them in an error.
  std::vector<double> parameters(const std::vector<int>& numbers, const std::string& what);

 private:
  std::string read_line();
  LinuxcncrshOptions options_;
  int fd_ = -1;
  std::string buffer_;
  double mm_per_unit_ = 0.0;        // 0 = not asked yet in this session
  std::string readback_nonce_;      // tells this client's read-back messages from stale ones
  unsigned long readback_count_ = 0;
};

// Sends each command as MDI lines to a running LinuxCNC. For axis offsets it first asks the machine's
// length unit (an unknown unit: SinkError, nothing sent), then reads the target work offset back
// from its parameters (work_offset_values): a mismatch with what was sent (> 0.00005 mm or °) is a
// SinkError.
class LinuxcncrshSink : public Sink {
 public:
  explicit LinuxcncrshSink(LinuxcncrshOptions options = {}, DialectOptions nc = {});
  std::string name() const override;
  void deliver(const NcCommand& command) override;
  // Its session, for what else a user does on the same machine (read-backs, probe cycles): one
  // session, since linuxcncrsh gives control to one at a time.
  LinuxcncrshClient& client() { return client_; }

 private:
  LinuxcncrshOptions options_;
  DialectOptions nc_;
  LinuxcncrshClient client_;
};

struct DeliveryReport {
  std::size_t delivered = 0;  // commands taken by the sink in this flush
  std::size_t pending = 0;    // commands still queued
  std::string error;          // the sink's failure, empty if none
  bool ok() const { return error.empty(); }
};

class CommandQueue {
 public:
  void push(const NcCommand& command) { pending_.push_back(command); }
  // Delivers in order; stops at the first failure, which stays at the head of the queue.
  DeliveryReport flush(Sink& sink);
  const std::deque<NcCommand>& pending() const { return pending_; }

 private:
  std::deque<NcCommand> pending_;
};

}  // namespace alc::nc
