// alc supervise: the supervisor beside a machine on an MQTT broker (supervisor/, docs/supervisor.md).
#include <atomic>
#include <csignal>

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

void run_supervise(const std::string& file) {
  supervisor::SupervisorConfig config;
  try {
    config = supervisor::read_supervisor_config(file);
  } catch (const supervisor::ConfigError& e) {
    throw UsageError(e.what());
  }
  if (config.log.level || config.log.file) {
    log::Options o;
    o.level = spdlog::level::info;
    if (config.log.level) {
      const auto level = log::parse_level(*config.log.level);
      if (!level) throw UsageError(file + ": key 'log.level', value \"" + *config.log.level + "\": not a level");
      o.level = *level;
    }
    if (config.log.file) o.file = *config.log.file;
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
    // Why it stopped, also in [log] file (a service's stderr may reach no one); stderr gets it from main.
    if (config.log.file) log::get("supervisor")->critical("stopped: {}", e.what());
    throw;
  }
}

}  // namespace

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
