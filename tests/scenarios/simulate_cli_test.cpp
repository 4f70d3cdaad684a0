// `alc simulate` end to end: runs the built binary (ALC_CLI_PATH) and reads what it wrote.
#include <catch2/catch.hpp>

#include "../cli_support.hpp"
#include <unistd.h>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <sys/wait.h>

#include "scenarios/load_cases.hpp"
#include "scenarios/scenario_csv.hpp"

namespace sc = alc::scenarios;
namespace fs = std::filesystem;

namespace {

using CliResult = alc_test::CliRun;
using alc_test::slurp;

fs::path work_dir() { return alc_test::work_dir("simulate_cli_test"); }

CliResult run_alc(const std::string& args) { return alc_test::run_alc(args, "simulate_cli_test"); }

}  // namespace

TEST_CASE("alc simulate: --case C --out writes a file that the reader loads, equal to the library's case") {
  const fs::path file = work_dir() / "c.csv";
  const CliResult r = run_alc("simulate --case C --out \"" + file.string() + "\"");
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  const sc::Scenario read = sc::read_scenario_csv(file);
  const sc::Scenario expected = sc::simulate_case("C").scenario;
  CHECK(read.input_names == expected.input_names);
  CHECK(read.output_names == expected.output_names);
  CHECK(read.time_s == expected.time_s);
  CHECK(read.inputs == expected.inputs);
  CHECK(read.outputs.rows() == expected.outputs.rows());
}

TEST_CASE("alc simulate: the largest seed, 2^64 - 1, is taken as given") {
  const fs::path file = work_dir() / "s16_max_seed.csv";
  const CliResult r = run_alc("simulate --case S16 --seed 18446744073709551615 --out \"" + file.string() + "\"");
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  const sc::Scenario read = sc::read_scenario_csv(file);
  const sc::Scenario expected = sc::simulate_case("S16", 18446744073709551615ULL).scenario;
  CHECK(read.time_s == expected.time_s);
  CHECK(read.inputs == expected.inputs);
}

TEST_CASE("alc simulate: --seed changes the file, the same seed reproduces it byte for byte") {
  const fs::path a = work_dir() / "a1.csv", b = work_dir() / "a2.csv", c = work_dir() / "a3.csv";
  REQUIRE(run_alc("simulate --case A --seed 5 --out \"" + a.string() + "\"").exit_code == 0);
  REQUIRE(run_alc("simulate --case A --seed 5 --out \"" + b.string() + "\"").exit_code == 0);
  REQUIRE(run_alc("simulate --case A --seed 6 --out \"" + c.string() + "\"").exit_code == 0);
  CHECK(slurp(a) == slurp(b));
  CHECK(slurp(a) != slurp(c));
}

TEST_CASE("alc simulate: --truth writes the noiseless truth with an error at every sample") {
  const fs::path file = work_dir() / "s16_truth.csv";
  REQUIRE(run_alc("simulate --case S16 --truth \"" + file.string() + "\"").exit_code == 0);
  const sc::Scenario truth = sc::read_scenario_csv(file);
  CHECK(truth.output_names.size() == 5);
  CHECK(truth.input_index("node_front_bearing") >= 0);
  CHECK_FALSE(truth.outputs.hasNaN());
}

TEST_CASE("alc simulate: --list prints one line per case") {
  const CliResult r = run_alc("simulate --list");
  REQUIRE(r.exit_code == 0);
  for (const std::string name : {"A  192 h", "B  192 h", "C  192 h", "D  192 h", "S16  46 h"})
    CHECK_THAT(r.out, Catch::Matchers::Contains(name));
}

TEST_CASE("alc simulate: --case all --summary prints the figures of A-D") {
  const CliResult r = run_alc("simulate --case all --summary");
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  CHECK_THAT(r.out, Catch::Matchers::Contains("E_X0C peak / P99 [µm]"));
  CHECK_THAT(r.out, Catch::Matchers::Contains("E_C0C peak / P99 [µm/m]"));
  for (const std::string row : {"| A | 101 | 192.0 |", "| B |", "| C |", "| D |"})
    CHECK_THAT(r.out, Catch::Matchers::Contains(row));
  CHECK_THAT(r.out, !Catch::Matchers::Contains("| S16 |"));
}

TEST_CASE("alc simulate: --case heldout --summary prints the figures of H1-H5 and --list names them") {
  const CliResult r = run_alc("simulate --case heldout --summary");
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  for (const std::string row : {"| H1 | 201 | 144.0 |", "| H2 | 202 | 192.0 |", "| H3 | 203 | 48.0 |", "| H4 |", "| H5 |"})
    CHECK_THAT(r.out, Catch::Matchers::Contains(row));
  CHECK_THAT(r.out, !Catch::Matchers::Contains("| A |"));
  const CliResult list = run_alc("simulate --list");
  for (const std::string name : {"H1  144 h  every 60 s", "H2  192 h  every 300 s", "H3  48 h  every 10 s"})
    CHECK_THAT(list.out, Catch::Matchers::Contains(name));
  CHECK(run_alc("simulate --case heldout --out x.csv").exit_code == 2);
  // H6 and H7, built later, are listed apart and are not in the heldout group (H1-H5's figures stay as they were).
  CHECK_THAT(list.out, Catch::Matchers::Contains("built after the adaptive policy was settled (by name only):\nH6  168 h  every 120 s"));
  CHECK_THAT(r.out, !Catch::Matchers::Contains("| H6 |"));
  CHECK_THAT(list.out, Catch::Matchers::Contains("\nH7  120 h  every 60 s"));
  CHECK_THAT(r.out, !Catch::Matchers::Contains("| H7 |"));
}

TEST_CASE("alc simulate: usage errors go to stderr with exit code 2") {
  SECTION("unknown case") {
    const CliResult r = run_alc("simulate --case E --out x.csv");
    CHECK(r.exit_code == 2);
    CHECK_THAT(r.err, Catch::Matchers::Contains("unknown --case 'E'"));
    CHECK(r.out.empty());
  }
  SECTION("no case") {
    const CliResult r = run_alc("simulate --summary");
    CHECK(r.exit_code == 2);
    CHECK_THAT(r.err, Catch::Matchers::Contains("give --case"));
  }
  SECTION("nothing to do") {
    const CliResult r = run_alc("simulate --case A");
    CHECK(r.exit_code == 2);
    CHECK_THAT(r.err, Catch::Matchers::Contains("nothing to do"));
  }
  SECTION("--out with all cases") {
    const CliResult r = run_alc("simulate --case all --out x.csv");
    CHECK(r.exit_code == 2);
    CHECK_THAT(r.err, Catch::Matchers::Contains("--case all"));
  }
  SECTION("a bad seed") {
    const CliResult r = run_alc("simulate --case A --seed many --out x.csv");
    CHECK(r.exit_code == 2);
    CHECK_THAT(r.err, Catch::Matchers::Contains("--seed"));
    CHECK_THAT(r.err, Catch::Matchers::Contains("got 'many'"));
  }
  SECTION("a negative seed is not wrapped to 2^64 - 1") {
    for (const std::string seed : {"--seed -1", "--seed=-1", "--seed -0", "--seed ' 5'", "--seed 1.5", "--seed +5"}) {
      INFO(seed);
      const CliResult r = run_alc("simulate --case A " + seed + " --out x.csv");
      CHECK(r.exit_code == 2);
      CHECK_THAT(r.err, Catch::Matchers::Contains("--seed must be a whole number from 0 to 18446744073709551615"));
      CHECK(r.out.empty());
    }
    CHECK_THAT(run_alc("simulate --case A --seed -1 --out x.csv").err, Catch::Matchers::Contains("got '-1'"));
  }
  SECTION("a seed beyond 2^64 - 1 is not clamped") {
    const CliResult r = run_alc("simulate --case A --seed 18446744073709551616 --out x.csv");
    CHECK(r.exit_code == 2);
    CHECK_THAT(r.err, Catch::Matchers::Contains("got '18446744073709551616'"));
  }
  SECTION("--list with --case") {
    const CliResult r = run_alc("simulate --list --case A");
    CHECK(r.exit_code == 2);
    CHECK_THAT(r.err, Catch::Matchers::Contains("--case excludes --list"));
  }
  SECTION("an unknown option") {
    const CliResult r = run_alc("simulate --case A --bogus");
    CHECK(r.exit_code == 2);
    CHECK_THAT(r.err, Catch::Matchers::Contains("bogus"));
    CHECK(r.out.empty());
  }
  SECTION("'-' is not stdout here") {
    const CliResult r = run_alc("simulate --case A --out -");  // before: a file named '-', exit 0
    CHECK(r.exit_code == 2);
    CHECK_THAT(r.err, Catch::Matchers::Contains("--out writes a file; '-' (stdout) is not offered"));
    CHECK_FALSE(fs::exists("-"));  // the command runs in the test's working directory
  }
  SECTION("an option without its value") {
    const CliResult r = run_alc("simulate --out x.csv --case");
    CHECK(r.exit_code == 2);
    CHECK_THAT(r.err, Catch::Matchers::Contains("--case"));
  }
  CHECK_FALSE(fs::exists("x.csv"));
}

TEST_CASE("alc simulate: --truth onto --out, a target it may not write: refused before anything is written") {
  const fs::path dir = work_dir() / "targets";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string out = (dir / "x.csv").string();
  // Before: exit 0, and x.csv held the truth alone (the scenario written first, then replaced).
  CliResult r = run_alc("simulate --case A --out " + out + " --truth " + (dir / "." / "x.csv").string());
  CHECK(r.exit_code == 2);
  CHECK_THAT(r.err, Catch::Matchers::Contains("is the --out file"));
  CHECK_FALSE(fs::exists(out));
  // Before: a.csv written, then exit 1 on the --truth symlink: half the output left behind.
  fs::create_symlink(dir / "nowhere", dir / "link.csv");
  r = run_alc("simulate --case A --out " + (dir / "a.csv").string() + " --truth " + (dir / "link.csv").string());
  CHECK(r.exit_code == 1);
  CHECK_THAT(r.err, Catch::Matchers::Contains("--truth: cannot write '" + (dir / "link.csv").string() + "': it is a symbolic link"));
  CHECK_FALSE(fs::exists(dir / "a.csv"));
  // A recording made read-only is not replaced (before: replaced, mode 0644, exit 0).
  REQUIRE(run_alc("simulate --case B --out " + out).exit_code == 0);
  const std::string recorded = slurp(out);
  fs::permissions(out, fs::perms::owner_read | fs::perms::group_read | fs::perms::others_read);
  r = run_alc("simulate --case A --out " + out);
  CHECK(r.exit_code == 1);
  CHECK_THAT(r.err, Catch::Matchers::Contains("read-only file (mode 0444)"));
  CHECK(slurp(out) == recorded);
  fs::permissions(out, fs::perms::owner_all);
  fs::remove_all(dir);
}

TEST_CASE("alc simulate --help describes every option") {
  const CliResult r = run_alc("simulate --help");
  REQUIRE(r.exit_code == 0);
  for (const std::string option : {"--case", "--out", "--truth", "--seed", "--list", "--summary"})
    CHECK_THAT(r.out, Catch::Matchers::Contains(option));
}
