#pragma once
// The supervisor's configuration (TOML): machine, broker, signals, history, controller parameters
// (the same names and units as `alc replay`'s options), optional NC. docs/supervisor.md lists every key.
#include <array>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "alc/controller.hpp"
#include "nc_interface/machine_config.hpp"
#include "nc_interface/transports.hpp"
#include "runtime/parameter_options.hpp"
#include "storage/history_writer.hpp"

namespace alc::supervisor {

// A configuration that cannot be used: the file, the key (dotted) and its value, and why.
class ConfigError : public std::runtime_error {
 public:
  ConfigError(const std::string& file, const std::string& key, const std::string& value, const std::string& reason);
  explicit ConfigError(const std::string& message);  // a TOML syntax error: "file:line:column: ..."
};

struct MqttConfig {
  std::string host = "127.0.0.1";
  int port = 1883;
  std::string prefix;                 // default "alc/<machine_id>"
  std::string client_id;              // default "alc-<machine_id>"
  std::optional<std::string> username;
  std::optional<std::filesystem::path> password_file;  // first line is the password
  std::optional<std::filesystem::path> tls_ca_file;    // TLS to the broker when given
  int keepalive_s = 30;
  std::size_t max_payload_bytes = 65536;  // larger messages are rejected unread
};

struct SignalsConfig {
  std::vector<std::string> inputs;
  std::vector<std::string> outputs;
  double stale_after_s = 300.0;       // [s] wall clock without a sample: stale
  double probe_timeout_s = 1800.0;    // [s] machine time after the request: the probe is given up
  // [s] machine time: a sample further ahead of the latest one is held until the next sample confirms
  // the jump (a clock reset or a typo such as 1e15 would otherwise refuse every later sample as
  // "time goes backwards"); an unconfirmed one is set aside.
  double max_gap_s = 3600.0;
};

struct HistoryConfig {
  std::filesystem::path db;
  double snapshot_every_s = 3600.0;   // [s] machine time between controller snapshots
  storage::Durability durability = storage::Durability::Process;
  // [s] machine time: input samples and predictions older than this are deleted at each snapshot
  // (never those the controller's learning still holds); probes, models, phase changes and NC
  // commands stay. Must be > 0: a supervisor's storage stays bounded.
  double keep_s = 90.0 * 86400.0;
};

// The probe cycle the supervisor runs itself on LinuxCNC ([nc] probe = "linuxcnc"): G38.2 along -Z
// onto a surface at the nominal point, which measures E_Z0T (docs/supervisor.md, "Probe cycles on
// the NC").
struct NcProbeCycle {
  std::string output = "E_Z0T";                 // the error it measures (only E_Z0T so far)
  std::array<double, 3> point_mm{0.0, 0.0, 0.0}; // [mm] nominal contact point, work coordinates
  double clearance_mm = 5.0;                    // [mm] above the point for the moves in X and Y
  double approach_mm = 0.5;                     // [mm] G38.2 starts this far above the point ...
  double search_mm = 0.5;                       // [mm] ... and gives up this far below it
  double feed_mm_min = 60.0;                    // [mm/min] probing feed
};

struct NcConfig {
  std::optional<std::filesystem::path> machine;  // machine config (chain, work offset, safety limits)
  std::string sink = "none";                     // "none" (MQTT only), "spool" or "linuxcncrsh"
  std::string probe = "gateway";                 // "gateway" (PREFIX/probe/request) or "linuxcnc"
  nc::Dialect dialect = nc::Dialect::LinuxCNC;   // of the spool's programs (linuxcncrsh: LinuxCNC)
  std::optional<std::filesystem::path> spool_dir;  // sink = "spool": where the programs go
  nc::LinuxcncrshOptions linuxcncrsh;            // host (localhost only), port, timeout_s
  double retry_s = 5.0;                          // [s] wall clock after a failure before the NC is tried again
  NcProbeCycle probe_cycle;
  // Whether the supervisor talks to LinuxCNC over linuxcncrsh (for the offsets or the probe cycle).
  bool uses_linuxcncrsh() const { return sink == "linuxcncrsh" || probe == "linuxcnc"; }
};

// [status]: the read-only status page (docs/supervisor.md); off unless the section is there.
struct StatusConfig {
  std::string host = "127.0.0.1";     // another host only when written in `listen`
  int port = 0;
  double window_s = 86400.0;          // [s] machine time shown: the last day
};

struct LogConfig {
  std::optional<std::string> level;   // overrides --log-level
  std::optional<std::string> file;    // rotating log file
};

struct SupervisorConfig {
  std::filesystem::path file;         // where it was read from
  std::string machine_id;
  MqttConfig mqtt;
  SignalsConfig signals;
  HistoryConfig history;
  runtime::OptionTexts controller_options;  // as written, for the record
  AlcParameters parameters;
  NcConfig nc;
  nc::MachineConfig machine;          // of nc.machine, else the built-in defaults
  LogConfig log;
  std::optional<StatusConfig> status;  // no page (nothing listens) without [status]
};

// Reads and checks the whole file; relative paths are taken from the file's directory.
// Throws ConfigError.
SupervisorConfig read_supervisor_config(const std::filesystem::path& file);
SupervisorConfig parse_supervisor_config(const std::string& toml_text, const std::filesystem::path& file);

}  // namespace alc::supervisor
