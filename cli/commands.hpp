#pragma once
// Each command of the `alc` program registers itself on the top-level app.
// A command's callback throws on error; main() prints the message to stderr and exits non-zero.
#include <CLI/CLI.hpp>
#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

namespace alc::cli {

// An error in what the user asked for (exit code 2), as opposed to a failure while running (1).
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// A command that ends with an exit status of its own (e.g. 130 after SIGINT), its message on stderr.
struct ExitStatus : std::runtime_error {
  ExitStatus(int status, const std::string& message) : std::runtime_error(message), code(status) {}
  int code;
};

// Throws UsageError if the output file `target` of `option` ("--out") is the input file `database`
// (`what`: "the history database", "the recording replayed") or one of its SQLite journals (-wal,
// -shm, -journal), under any spelling: the same path after resolving symlinks and `.`/`..`, or the
// same file (a hard link). Writing there would replace the input with the output. Nothing to check
// for an empty input or target, or "-". `consequence` says what writing there would do.
void refuse_output_over_input(const std::string& option, const std::filesystem::path& target,
                                 const std::string& database, const std::string& what,
                                 const std::string& consequence = "writing there would replace it");
// The log file `log` (rotating to FILE.1 ... FILE.`max_files`) against a file the command uses,
// `value` (`what`: "alc replay's --db"): UsageError when the log is that file or one of its SQLite
// journals (log lines would be written into it) or a name it rotates to (a rotation would replace
// it). `option` names where the log was given: "--log-file", "[log] file".
void refuse_log_over(const std::string& option, const std::string& log, std::size_t max_files,
                     const std::string& value, const std::string& what);
// `alc --log-file LOG supervise --config FILE`: refuse_log_over for every file FILE names (the history,
// its inbox, the password and CA files, the machine config, FILE itself), before the log is opened.
// Nothing when supervise is not the command or FILE cannot be read (the command says why).
void refuse_log_over_supervised_files(const CLI::App& app, const std::string& log_file, std::size_t max_files);
// Before long work whose result goes to `target`: std::runtime_error "OPTION: cannot write 'TARGET':
// why" when io::output_file_problem knows it cannot be written there; UsageError for "-" (an option
// that writes a file offers no stdout: "-" would be a file of that name). Nothing for an empty target.
void refuse_unwritable_output(const std::string& option, const std::string& target);

// [kB] a field of /proc/self/status ("VmRSS", "VmHWM"); 0 where it cannot be read.
double proc_status_kb(const std::string& field);

// alc study: parameter studies over a grid of controller parameters (cli/cmd_study.cpp).
void add_study_command(CLI::App& app);

// alc nc: NC commands (JSON lines) to NC code (cli/cmd_nc.cpp).
void add_nc_command(CLI::App& app);

// alc db: inspect, check, export and benchmark a history database (cli/cmd_db.cpp).
void add_db_command(CLI::App& app);

// alc simulate: built-in load cases of the thermal twin to scenario CSV (cli/cmd_simulate.cpp).
void add_simulate_command(CLI::App& app);

// alc replay: a scenario or built-in load case through the ALC controller (cli/cmd_replay.cpp).
void add_replay_command(CLI::App& app);

// Names of the built-in load cases for a --case value: "all" (A–D), "heldout" (H1–H5) or one name
// (cli/cases.cpp).
// Throws UsageError for an unknown name.
std::vector<std::string> load_case_names(const std::string& selector);

// A seed option's value (--seed, --bench-seed): decimal digits only, 0 ... 2^64 - 1 (CLI11 would wrap
// "-1"). Throws UsageError naming the option.
std::uint64_t parse_seed(const std::string& text, const std::string& option = "--seed");

// alc supervise: the supervisor on an MQTT broker (cli/cmd_supervise.cpp).
void add_supervise_command(CLI::App& app);
// alc report: a history (or study file) as one self-contained HTML page (cli/cmd_report.cpp).
void add_report_command(CLI::App& app);
// Numeric options, every one through the one strict reader of number text (common::parse_number,
// common::parse_whole_number; cli/cases.cpp): no sign, hex, nan, blank or trailing text; a value
// outside lo…hi or not a number is a UsageError (exit 2) naming the option and the value.
// `target` must outlive the parse (a member of the command's shared argument struct).
CLI::Option* add_number_option(CLI::App* cmd, const std::string& name, double& target, const std::string& help,
                               double lo, double hi, bool allow_inf = false);
// The value of a number option, lo…hi (common::parse_number; the reading add_number_option makes of
// each value); throws UsageError.
double number_option_value(const std::string& name, const std::string& text, double lo, double hi,
                           bool allow_inf = false);
// The value of a whole-number option, lo…hi (common::parse_whole_number); throws UsageError.
std::uint64_t whole_option_value(const std::string& name, const std::string& text, std::uint64_t lo, std::uint64_t hi);
template <class Int>
CLI::Option* add_whole_option(CLI::App* cmd, const std::string& name, Int& target, const std::string& help,
                              std::uint64_t lo, std::uint64_t hi) {
  return cmd
      ->add_option_function<std::string>(
          name, [&target, name, lo, hi](const std::string& text) {
            target = static_cast<Int>(whole_option_value(name, text, lo, hi));
          },
          help)
      ->default_str(std::to_string(target));
}

// alc bench: replay speed, identification share, cost of the history (cli/cmd_bench.cpp).
void add_bench_command(CLI::App& app);

}  // namespace alc::cli
