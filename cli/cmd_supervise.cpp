// alc supervise: the supervisor beside a machine on an MQTT broker (supervisor/, docs/supervisor.md).
#include <atomic>
#include <csignal>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "alc_version.hpp"
#include "commands.hpp"
#include "common/log.hpp"
#include "runtime/run.hpp"
#include "supervisor/config.hpp"
#include "supervisor/service.hpp"

namespace alc::cli {

namespace {

std::atomic<bool> g_stop{false};
extern "C" void on_stop_signal(int) { g_stop = true; }

// The configuration is read once per process: `alc --log-file` checks the files it names before the log
// opens, and the command then runs on the same reading (a FIFO, as `--config <(envsubst < s.toml)`
// gives, has nothing left for a second one; a file edited in between would be checked in one version
// and run in another).
struct ConfigReading {
  std::string file;
  supervisor::SupervisorConfig config;
  std::string error;  // the ConfigError's message, if reading it failed
};

const supervisor::SupervisorConfig& read_config(const std::string& file) {
  static std::optional<ConfigReading> reading;
  if (!reading || reading->file != file) {
    reading = ConfigReading{file, {}, {}};
    try {
      reading->config = supervisor::read_supervisor_config(file);
    } catch (const supervisor::ConfigError& e) {
      reading->error = e.what();
    }
  }
  if (!reading->error.empty()) throw UsageError(reading->error);
  return reading->config;
}

// The files a supervisor reads and writes, as (what, path), which no log may be.
std::vector<std::pair<std::string, std::string>> files_of(const supervisor::SupervisorConfig& config) {
  const auto text = [](const std::optional<std::filesystem::path>& p) { return p ? p->string() : std::string(); };
  return {{"the configuration", config.file.string()},
          {"[history] db", config.history.db.string()},
          {"[history] db's inbox", config.history.db.string() + ".inbox"},
          {"[mqtt] password_file", text(config.mqtt.password_file)},
          {"[mqtt] tls_ca_file", text(config.mqtt.tls_ca_file)},
          {"[nc] machine", text(config.nc.machine)}};
}

void run_supervise(const std::string& file) {
  const supervisor::SupervisorConfig& config = read_config(file);
  if (config.log.file)
    for (const auto& [what, path] : files_of(config))
      try {
        refuse_log_over("[log] file", *config.log.file, log::Options{}.max_files, path, what);
      } catch (const UsageError& e) {
        throw UsageError(file + ": key 'log.file': " + e.what());
      }
  const log::Options given = log::configured();  // alc --log-level/--log-file, before the command
  if (config.log.level || config.log.file) {
    // [log] takes the place of alc's --log-level and --log-file where it sets them; what it leaves out
    // stays as given (a [log] level alone keeps the --log-file).
    log::Options o = given;
    o.level = spdlog::level::info;
    if (config.log.level) {
      const auto level = log::parse_level(*config.log.level);
      if (!level) throw UsageError(file + ": key 'log.level', value \"" + *config.log.level + "\": not a level");
      o.level = *level;
    }
    if (config.log.file) {
      o.file = *config.log.file;
      o.max_file_bytes = log::Options{}.max_file_bytes;
      o.max_files = log::Options{}.max_files;
    }
    try {
      log::configure(o);
    } catch (const std::runtime_error& e) {  // a log file that cannot be opened: a configuration error
      throw UsageError(file + ": key 'log.file': " + e.what());
    }
  }
  std::signal(SIGTERM, on_stop_signal);
  std::signal(SIGINT, on_stop_signal);
  try {
    try {
      supervisor::run_service(config, g_stop, std::string("alc ") + ALC_VERSION);
    } catch (const supervisor::ConfigError& e) {
      throw UsageError(e.what());
    } catch (const runtime::ResumeRefused& e) {
      // The run found cannot be continued with this configuration: a new one begins once it is ended.
      // The path quoted as a shell takes it.
      throw UsageError(std::string(e.what()) + " (to begin a new run in this history, end that one: alc db finish '" +
                       config.history.db.string() + "' --run " +
                       (e.run > 0 ? std::to_string(e.run) : std::string("N (alc db info lists them)")) +
                       "; or give another [history] db)");
    }
  } catch (const std::exception& e) {
    // Why it stopped, also in the log file ([log] file or --log-file: a service's stderr may reach no
    // one); stderr gets it from main.
    if (!log::configured().file.empty()) log::get("supervisor")->critical("stopped: {}", e.what());
    throw;
  }
}

}  // namespace

void refuse_log_over_supervised_files(const CLI::App& app, const std::string& log_file, std::size_t max_files) {
  const CLI::App* cmd = app.get_subcommand("supervise");
  if (log_file.empty() || cmd->count() == 0 || cmd->get_option("--config")->results().empty()) return;
  const std::string file = cmd->get_option("--config")->results().front();
  const supervisor::SupervisorConfig* config = nullptr;
  try {
    config = &read_config(file);
  } catch (const UsageError&) {
    return;  // the command reports it
  }
  for (const auto& [what, path] : files_of(*config))
    refuse_log_over("--log-file", log_file, max_files, path, file + "'s " + what);
}

void add_supervise_command(CLI::App& app) {
  auto file = std::make_shared<std::string>();
  CLI::App* cmd = app.add_subcommand(
      "supervise", "Run the controller beside a machine: samples and probe results from an MQTT broker, probe "
                   "requests, offsets, state and events to it, everything recorded in the SQLite history; stops "
                   "cleanly on SIGTERM/SIGINT (see docs/supervisor.md)");
  cmd->add_option("--config", *file, "Supervisor configuration (TOML)")->required()->option_text("FILE.toml");
  cmd->callback([file] { run_supervise(*file); });
}

}  // namespace alc::cli
