// `alc --help`, `alc <command> --help` and the exit codes of usage errors (README, "Command line":
// 0 for help and version, 2 for a usage error). Runs the built program (ALC_CLI_PATH).
#include <catch2/catch.hpp>

#include "../cli_support.hpp"
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

using Run = alc_test::CliRun;

Run alc(const std::string& args) { return alc_test::run_alc(args, "help_cli_test"); }

// `alc ARGS` prints help on stdout, nothing on stderr, exits 0, and lists every one of `options`.
void check_help(const std::string& args, const std::vector<std::string>& options) {
  INFO("alc " << args);
  const Run r = alc(args);
  INFO(r.err);
  CHECK(r.exit_code == 0);
  CHECK(r.err.empty());
  CHECK_THAT(r.out, Catch::Matchers::Contains("Usage:"));
  for (const std::string& option : options) {
    INFO("option " << option);
    // As the help prints an option: two spaces before it, a space or a line end after it.
    CHECK_THAT(r.out, Catch::Matchers::Contains("  " + option + " ") || Catch::Matchers::Contains("  " + option + "\n"));
  }
}

// `alc ARGS` is a usage error: exit 2, nothing on stdout, a message on stderr containing `says`.
void check_usage_error(const std::string& args, const std::string& says) {
  INFO("alc " << args);
  const Run r = alc(args);
  INFO(r.err);
  CHECK(r.exit_code == 2);
  CHECK(r.out.empty());
  CHECK_THAT(r.err, Catch::Matchers::Contains(says));
  CHECK_THAT(r.err, Catch::Matchers::StartsWith("alc: error: "));  // before: CLI11's bare "--table is required"
}

}  // namespace

TEST_CASE("alc --help lists every command and exits 0") {
  check_help("--help", {"--version", "simulate", "replay", "bench", "db", "nc", "--log-level", "--log-file",
                        "--log-max-bytes", "--log-max-files"});
  check_help("-h", {"simulate", "replay", "bench", "db", "nc"});
}

TEST_CASE("alc --version prints the version and exits 0") {
  const Run r = alc("--version");
  CHECK(r.exit_code == 0);
  CHECK(r.err.empty());
  CHECK(r.out.rfind("alc ", 0) == 0);
}

TEST_CASE("alc replay --help describes its options") {
  check_help("replay --help",
             {"file", "--case", "--seed", "--cp", "--cp-interval", "--interval", "--ng-interval", "--ng-meas",
              "--update", "--acl-lin", "--acl-ang", "--window", "--since", "--half-life", "--method", "--max-order",
              "--structure-refresh", "--no-refit", "--no-confirm", "--kill-at", "--db", "--stop-at", "--resume", "--json", "--residuals", "--nc-out", "--dialect",
              "--machine"});
}

TEST_CASE("alc simulate --help describes its options") {
  check_help("simulate --help", {"--case", "--out", "--truth", "--seed", "--list", "--summary"});
}

TEST_CASE("alc bench --help describes its options") { check_help("bench --help", {"--case", "--repeat", "--long"}); }

TEST_CASE("alc db --help lists its subcommands, and each subcommand its options") {
  check_help("db --help", {"info", "check", "export", "finish", "bench", "path"});
  check_help("db finish --help", {"FILE", "--run"});
  check_help("db info --help", {"FILE"});
  check_help("db check --help", {"FILE"});
  check_help("db export --help", {"FILE", "--table", "--out"});
  check_help("db bench --help", {"--samples", "--inputs", "--batch", "--dir"});
  check_help("db path --help", {});
}

TEST_CASE("alc nc --help describes its options") {
  check_help("nc --help", {"--dialect", "--machine", "--in", "--in-force", "--sink", "--spool-dir", "--port"});
}

TEST_CASE("alc: a usage error found while parsing exits 2 with CLI11's message on stderr, as alc: error:") {
  // CLI11's own exit codes would be 106 (required), 109 (extras), 104 (conversion), 105
  // (validation), 107 (argument mismatch) and 108 (excludes).
  check_usage_error("", "A subcommand is required");
  // CLI11 checks the required subcommand first, so an unknown command or option says that.
  check_usage_error("frobnicate", "A subcommand is required");
  check_usage_error("--bogus", "A subcommand is required");
  check_usage_error("replay --case C --bogus", "--bogus");
  check_usage_error("replay --case C --acl-lin five", "--acl-lin");
  check_usage_error("replay --case C --max-order 1.5", "--max-order");
  check_usage_error("replay --case C --seed many", "--seed");
  check_usage_error("replay --case C --cp", "--cp");
  check_usage_error("replay --case C --since inf", "--since: 'inf' is not a number >= 0");
  check_usage_error("replay --case C --since -2", "--since");
  // A recording stamped in Unix time: --since counts from time 0, so "26 h in" changes nothing.
  const std::string epoch = (std::filesystem::temp_directory_path() / "alc_help_cli_epoch.csv").string();
  {
    std::ofstream f(epoch);
    f << "time_s,T,E_X0C\n";
    for (int k = 0; k < 200; ++k) f << 1700000000 + 300 * k << ",20," << (k % 3 == 0 ? "1" : "") << "\n";
  }
  check_usage_error("replay " + epoch + " --since 26",
                    "--since 26 h is before the first sample of " + epoch + " (at 472222.22222222225 h of scenario time)");
  // A CP longer than the recording: no model, a table of dashes (before: exit 0).
  check_usage_error("replay " + epoch + " --cp 1e6", "--cp 1e6 h is longer than " + epoch + " (16.583333333333332 h)");
  // --seed belongs to the simulated cases; with a file it was ignored, yet stored in the identity.
  check_usage_error("replay " + epoch + " --seed 7", "--seed applies to --case (a simulated load case), not to a FILE");
  std::filesystem::remove(epoch);
  // After the end of the recording: nothing would be learned (before: a table of dashes, exit 0).
  check_usage_error("replay --case A --since 200",
                    "--since 200 h is after the end of case A (its last sample is at 192 h of scenario time)");
  check_usage_error("bench --repeat x", "--repeat");
  check_usage_error("db", "A subcommand is required");
  check_usage_error("db info", "FILE is required");
  check_usage_error("db export x.sqlite --out -", "--table is required");
  check_usage_error("db bench --samples 0", "--samples");
  check_usage_error("nc", "--dialect is required");
  check_usage_error("nc --dialect linuxcnc --port 0", "--port");
  check_usage_error("nc --dialect linuxcnc --sink carrier-pigeon", "--sink");
  check_usage_error("simulate --list --case A", "excludes");
  // The hint CLI11 appends to its message stays.
  CHECK_THAT(alc("--bogus").err, Catch::Matchers::Contains("Run with --help for more information."));
}
