// alc: adaptive learning control of thermal errors of a 5-axis machine's rotary axis.
#include <cstddef>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <iostream>
#include <streambuf>
#include <string>

#include "alc_version.hpp"
#include "commands.hpp"
#include "common/log.hpp"
#include "scenarios/scenario_csv.hpp"
#include "storage/storage_error.hpp"

namespace {

// A history database the command was given that it cannot take: the user's input is wrong (exit 2),
// not the run (a locked, full, read-only or damaged file: exit 1).
bool wrong_input(alc::storage::StorageErrorKind kind) {
  using K = alc::storage::StorageErrorKind;
  return kind == K::NotFound || kind == K::NotADatabase || kind == K::Empty || kind == K::ForeignDatabase ||
         kind == K::NewerSchema;
}

// std::cout's buffer: it passes everything to the buffer cout had and keeps the errno of the first write
// that failed, which errno itself does not keep until exit (a study whose --csv - fails goes on to its
// analysis, and errno read at exit said "Success").
class ErrnoKeepingBuffer : public std::streambuf {
 public:
  explicit ErrnoKeepingBuffer(std::streambuf* to) : to_(to) {}
  int first_errno() const { return first_errno_; }
  std::streambuf* target() const { return to_; }

 protected:
  int_type overflow(int_type c) override {
    if (traits_type::eq_int_type(c, traits_type::eof())) return traits_type::not_eof(c);
    const int_type r = to_->sputc(traits_type::to_char_type(c));
    if (traits_type::eq_int_type(r, traits_type::eof())) keep();
    return r;
  }
  std::streamsize xsputn(const char* s, std::streamsize n) override {
    const std::streamsize written = to_->sputn(s, n);
    if (written != n) keep();
    return written;
  }
  int sync() override {
    const int r = to_->pubsync();
    if (r != 0) keep();
    return r;
  }

 private:
  void keep() {
    if (first_errno_ == 0) first_errno_ = errno;
  }
  std::streambuf* to_;
  int first_errno_ = 0;
};

// A result that did not reach its reader is a failure: stdout is flushed and checked once, at exit
// (a full disk, /dev/full, a closed pipe), and the reason is the first write's that failed. `code`
// stays if it already says failure.
int checked_stdout(int code, const ErrnoKeepingBuffer& buffer) {
  std::cout.flush();
  const bool failed = !std::cout || std::fflush(stdout) != 0 || std::ferror(stdout);
  if (!failed) return code;
  const int reason = buffer.first_errno() != 0 ? buffer.first_errno() : errno;
  std::cerr << "alc: error: writing to stdout failed"
            << (reason != 0 ? std::string(": ") + std::strerror(reason) : std::string()) << "\n";
  return code == 0 ? 1 : code;
}

// No option of any command takes an empty value: `--db ""` (a script's unset $DB) read as "not given",
// and the replay silently recorded no history; `--nc-out ""`, `--residuals ""` and an empty FILE alike.
void refuse_empty_values(CLI::App& app) {
  for (CLI::Option* o : app.get_options())
    if (o->get_type_size() > 0)
      o->check(CLI::Validator(
          [](std::string& value) { return value.empty() ? std::string("the value is empty: give one, or leave the option out") : std::string(); },
          "", "non-empty"));
  // A database or a directory is never stdout: `--db -` made a history named '-' in the working directory.
  for (const char* name : {"--db", "--spool-dir"})
    if (CLI::Option* o = app.get_option_no_throw(name))
      o->check(CLI::Validator(
          [](std::string& value) {
            return value == "-" ? std::string("'-' (stdout) is not offered: this option names a file or directory")
                                : std::string();
          },
          "", "not-stdout"));
  for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) refuse_empty_values(*sub);
}

// The log is appended to: a --log-file that is a file the command reads or writes (the recording
// replayed, the history or its -wal, a grid, a config) would get log lines in the middle of its data.
// Every value given to the command is checked, as a path, whether or not that file exists yet (the
// history a replay creates); a log named as another value (--case A, --log-file A) is refused too.
void refuse_log_over_input(const CLI::App& app, const std::string& log_file, std::size_t max_files,
                           const std::string& command = "alc") {
  for (const CLI::App* sub : app.get_subcommands()) {
    const std::string path = command + " " + sub->get_name();
    for (const CLI::Option* o : sub->get_options()) {
      if (o->get_type_size() <= 0) continue;
      for (const std::string& value : o->results()) {
        const std::string name = o->get_name().empty() ? o->get_name(true, false) : o->get_name();
        alc::cli::refuse_log_over("--log-file", log_file, max_files, value, path + "'s " + name);
      }
    }
    refuse_log_over_input(*sub, log_file, max_files, path);
  }
}

int run(int argc, char** argv) {
  CLI::App app{"alc: adaptive learning control of thermal errors of a 5-axis machine tool's rotary axis.\n"
               "Predicts the thermal location errors of the C axis from temperatures and machine states "
               "(ARX), schedules touch-probe measurements, and turns predictions into NC axis offsets."};
  app.set_version_flag("--version", std::string("alc ") + ALC_VERSION);
  app.require_subcommand(1);

  // Logging, for every command: given before the command (alc --log-level info replay ...).
  std::string log_level = "warn";
  alc::log::Options log_options;
  app.add_option("--log-level", log_level,
                 "Log level: trace, debug, info, warn, error, critical or off (default: warn)");
  app.add_option("--log-file", log_options.file,
                 "Also log to FILE (rotating: FILE, FILE.1, ...); its directory must exist")
      ->option_text("FILE");
  alc::cli::add_whole_option(&app, "--log-max-bytes", log_options.max_file_bytes,
                             "Size at which the log file rotates (default: 10 MiB)", 1, std::uint64_t{1} << 50);
  alc::cli::add_whole_option(&app, "--log-max-files", log_options.max_files,
                             "Rotated log files kept besides FILE (default: 5)", 0, 200000);
  // Runs once the options are parsed and before the command's callback.
  app.parse_complete_callback([&] {
    const auto level = alc::log::parse_level(log_level);
    if (!level)
      throw alc::cli::UsageError("--log-level: '" + log_level +
                                 "' is not a level (trace, debug, info, warn, error, critical, off)");
    log_options.level = *level;
    if (!log_options.file.empty()) {
      refuse_log_over_input(app, log_options.file, log_options.max_files);
      alc::cli::refuse_log_over_supervised_files(app, log_options.file, log_options.max_files);
    }
    alc::log::configure(log_options);
  });
  // Commands register here, one line each.
  alc::cli::add_simulate_command(app);
  alc::cli::add_replay_command(app);
  alc::cli::add_bench_command(app);
  alc::cli::add_study_command(app);
  alc::cli::add_db_command(app);
  alc::cli::add_nc_command(app);
  alc::cli::add_supervise_command(app);
  alc::cli::add_report_command(app);
  refuse_empty_values(app);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // CLI11 prints --help / --version (code 0) to stdout and its message to stderr. Any other
    // parse error (unknown option, bad number, missing or excluded option...) is a usage error:
    // exit 2 as the README says, not CLI11's own codes (104, 106, ...).
    if (e.get_exit_code() == 0) return app.exit(e);
    // Said as every other error is ("alc: error: ..."), not as CLI11's bare message.
    std::cerr << "alc: error: " << e.what() << "\nRun with --help for more information.\n";
    return dynamic_cast<const CLI::RuntimeError*>(&e) != nullptr ? 1 : 2;
  } catch (const alc::cli::ExitStatus& e) {
    std::cerr << "alc: " << e.what() << "\n";
    return e.code;
  } catch (const alc::cli::UsageError& e) {
    std::cerr << "alc: error: " << e.what() << "\n";
    return 2;
  } catch (const alc::scenarios::ScenarioCsvError& e) {
    // A scenario CSV that is missing or breaks the contract: input, like a bad config or grid; a
    // read that fails midway is a failure while running.
    std::cerr << "alc: error: " << e.what() << "\n";
    return e.reason == "read error" ? 1 : 2;
  } catch (const alc::storage::StorageError& e) {
    std::cerr << "alc: error: " << e.what() << "\n";
    return wrong_input(e.kind) ? 2 : 1;
  } catch (const std::exception& e) {
    std::cerr << "alc: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  ErrnoKeepingBuffer buffer(std::cout.rdbuf());
  std::cout.rdbuf(&buffer);
  const int code = checked_stdout(run(argc, argv), buffer);
  std::cout.rdbuf(buffer.target());
  return code;
}
