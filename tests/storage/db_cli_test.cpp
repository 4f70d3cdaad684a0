// `alc db info|check|export` on real files: output, exit codes, errors on stderr.
#include <sys/wait.h>

#include <array>
#include <catch2/catch.hpp>
#include <cstdio>
#include <filesystem>

#include "storage/history_writer.hpp"
#include "storage/schema.hpp"
#include "storage_test_support.hpp"

using namespace alc::storage;
using alc::storage::test::RawDb;
using alc::storage::test::ScratchDir;

namespace {

struct Outcome {
  int exit_code = -1;
  std::string output;  // stdout and stderr together
};

Outcome run_alc(const std::string& arguments) {
  const std::string command = std::string(ALC_CLI_PATH) + " " + arguments + " 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  REQUIRE(pipe);
  Outcome outcome;
  std::array<char, 4096> buffer{};
  while (std::fgets(buffer.data(), static_cast<int>(buffer.size()), pipe)) outcome.output += buffer.data();
  const int status = pclose(pipe);
  outcome.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return outcome;
}

std::string quoted(const std::filesystem::path& path) { return std::string(1, '\'').append(path.string()).append(1, '\''); }

}  // namespace

TEST_CASE("alc db info gives the times of a run on a machine clock in full", "[storage][cli]") {
  // Unix times of a supervisor or a logger's recording: six significant digits ("1.76723e+09") told
  // the span and the snapshot to within about 3 h.
  ScratchDir dir;
  const auto file = dir / "history.sqlite";
  {
    HistoryWriter writer(file);
    const RunId id = writer.begin_run(test::small_run());
    for (std::int64_t k = 0; k < 3; ++k) {
      auto sample = test::sample_at(id, k);
      sample.time_s += 1767225600.25;
      writer.add(sample);
    }
    writer.save_snapshot({id, 1767225720.25, 3, "test/1", true, "{}"});
  }
  const Outcome info = run_alc("db info " + quoted(file));
  CHECK(info.exit_code == 0);
  CHECK_THAT(info.output, Catch::Contains("time_s 1767225600.25 .. 1767225720.25 (0.03333 h)") &&
                              Catch::Contains("latest snapshot at time_s 1767225720.25\n"));
}

TEST_CASE("alc db info, check and export on a sound history", "[storage][cli]") {
  ScratchDir dir;
  const auto file = dir / "history.sqlite";
  {
    HistoryWriter writer(file);
    const RunId id = writer.begin_run(test::small_run());
    for (std::int64_t k = 0; k < 61; ++k) writer.add(test::sample_at(id, k));
    writer.save_snapshot({id, 3600.0, 61, "test/1", true, "{}"});
    writer.store_indicators({id, R"({"outputs":{},"Pd":97.5})", 0.0});
  }
  const Outcome info = run_alc("db info " + quoted(file));
  CHECK_THAT(info.output, Catch::Contains("latest snapshot at time_s 3600, indicators stored\n") &&
                              Catch::Contains("run_indicators          1"));
  CHECK(info.exit_code == 0);
  CHECK_THAT(info.output, Catch::Contains("schema version: " + std::to_string(kSchemaVersion)) && Catch::Contains("runs: 1") &&
                              Catch::Contains("time_s 0 .. 3600 (1 h)") && Catch::Contains("input_samples           61"));
  const Outcome check = run_alc("db check " + quoted(file));
  CHECK(check.exit_code == 0);
  CHECK_THAT(check.output, Catch::EndsWith(": ok\n"));

  const Outcome indicators = run_alc("db export " + quoted(file) + " --table run_indicators --out -");
  CHECK(indicators.exit_code == 0);
  CHECK_THAT(indicators.output, Catch::StartsWith("run_id,stored_unix_s,report_json\n1,") &&
                                    Catch::EndsWith(",\"{\"\"outputs\"\":{},\"\"Pd\"\":97.5}\"\n"));

  const auto csv = dir / "samples.csv";
  const Outcome exported = run_alc("db export " + quoted(file) + " --table input_samples --out " + quoted(csv));
  CHECK(exported.exit_code == 0);
  const std::string text = test::read_bytes(csv);
  CHECK_THAT(text, Catch::StartsWith("run_id,sample_index,time_s,T_ENV,T_FLUID,n_C\n1,0,0,20,21.5,0\n1,1,60,20.001,21.5,500\n"));

  const Outcome bad_table = run_alc("db export " + quoted(file) + " --table 'runs; DROP TABLE runs' --out " + quoted(csv));
  CHECK(bad_table.exit_code == 2);
  CHECK_THAT(bad_table.output, Catch::Contains("is not a table of the history"));
  CHECK(test::read_bytes(csv) == text);  // the earlier export is not clobbered by a failed one
}

TEST_CASE("alc db check reports the project's consistency problems and exits 1", "[storage][cli]") {
  ScratchDir dir;
  const auto file = dir / "broken.sqlite";
  {
    HistoryWriter writer(file);
    const RunId id = writer.begin_run(test::small_run());
    for (std::int64_t k = 0; k < 5; ++k) writer.add(test::sample_at(id, k));
    writer.save_snapshot({id, 240.0, 5, "test/1", true, R"({"k":4})"});
  }
  {
    RawDb raw(file);
    raw.exec("UPDATE input_samples SET time_s = 1.0 WHERE sample_index = 3;"
             "UPDATE runs SET config_json = '{broken';"
             "UPDATE controller_snapshots SET payload = CAST('{\"k\":' AS BLOB);");
  }
  const Outcome check = run_alc("db check " + quoted(file));
  CHECK(check.exit_code == 1);
  CHECK_THAT(check.output, Catch::Contains("input_samples: time_s not strictly increasing (run, sample, time_s): 1 3 1") &&
                               Catch::Contains("run 1: configuration is not valid JSON") &&
                               Catch::Contains("JSON payload does not parse") && Catch::Contains("3 problem(s) found"));
}

TEST_CASE("alc db check reports an NC command marked delivered although the safety gate refused it", "[storage][cli]") {
  ScratchDir dir;
  const auto file = dir / "nc.sqlite";
  {
    HistoryWriter writer(file);
    const RunId id = writer.begin_run(test::small_run());
    writer.add(NcCommandRecord{id, 60.0, "offsets", "G10 L2 P1 X0.001", "file:/out", true, ""});
    writer.add(NcCommandRecord{id, 120.0, "offsets", R"({"type":"axis_offsets","x_mm":9})", "file:/out", false,
                               "x_mm 9 beyond max_offset 0.1"});
    REQUIRE(writer.record_delivery(id, "file:/out", true, "written to /out/program.ngc") == 1);
    writer.end_run(id, RunStatus::Finished);
  }
  const Outcome sound = run_alc("db check " + quoted(file));
  INFO(sound.output);
  CHECK(sound.exit_code == 0);  // delivered on the accepted row, NULL on the refused one
  RawDb(file).exec("UPDATE nc_commands SET delivered = 0 WHERE accepted = 0");
  const Outcome check = run_alc("db check " + quoted(file));
  INFO(check.output);
  CHECK(check.exit_code == 1);
  CHECK_THAT(check.output,
             Catch::Contains("nc_commands: delivered set on a command the safety gate refused (run, nc_command_id): 1 2") &&
                 Catch::Contains("1 problem(s) found"));
}

TEST_CASE("alc db check names a finished run whose passed NC commands were not delivered or not settled, exit 0",
          "[storage][cli]") {
  ScratchDir dir;
  const auto file = dir / "undelivered.sqlite";
  {
    HistoryWriter writer(file);
    // Run 1, finished: the sink failed (delivered 0), as `alc replay --nc-out` into a path under a file.
    const RunId failed = writer.begin_run(test::small_run());
    writer.add(NcCommandRecord{failed, 60.0, "offsets", "G10 L2 P1 X0.001", "file:afile", true, ""});
    writer.add(NcCommandRecord{failed, 120.0, "offsets", "G10 L2 P1 X0.002", "file:afile", true, ""});
    writer.add(NcCommandRecord{failed, 180.0, "offsets", R"({"x_mm":9})", "file:afile", false, "beyond max_offset"});
    REQUIRE(writer.record_delivery(failed, "file:afile", false, "cannot create afile: Not a directory") == 2);
    writer.end_run(failed, RunStatus::Finished);
    // Run 2, finished: killed before the delivery and resumed without NC output (delivered NULL), then a
    // row of a second sink that was delivered.
    const RunId killed = writer.begin_run(test::small_run());
    writer.add(NcCommandRecord{killed, 60.0, "offsets", "G10 L2 P1 X0.001", "file:ncK", true, ""});
    writer.add(NcCommandRecord{killed, 90.0, "offsets", "G10 L2 P1 X0.001", "file:ncK", true, ""});
    writer.add(NcCommandRecord{killed, 100.0, "offsets", "G10 L2 P1 X0.001", "file:other", true, ""});
    REQUIRE(writer.record_delivery(killed, "file:other", true, "written to other/program.ngc") == 1);
    writer.end_run(killed, RunStatus::Finished);
    // Run 3, stopped: its commands may still be settled by a resume, so it is no finding.
    const RunId stopped = writer.begin_run(test::small_run());
    writer.add(NcCommandRecord{stopped, 60.0, "offsets", "G10 L2 P1 X0.001", "file:ncS", true, ""});
    writer.end_run(stopped, RunStatus::Stopped);
    // Run 4, finished and delivered: no finding.
    const RunId sound = writer.begin_run(test::small_run());
    writer.add(NcCommandRecord{sound, 60.0, "offsets", "G10 L2 P1 X0.001", "file:ok", true, ""});
    REQUIRE(writer.record_delivery(sound, "file:ok", true, "written") == 1);
    writer.end_run(sound, RunStatus::Finished);
  }
  const Outcome check = run_alc("db check " + quoted(file));
  INFO(check.output);
  // Records of what happened, not damage (docs/storage.md: a problem is an inconsistency): exit 0.
  CHECK(check.exit_code == 0);
  CHECK_THAT(check.output,
             Catch::Contains("finding: nc_commands: run 1 (finished): of its 2 command(s) the safety gate passed to "
                             "file:afile, 2 not delivered (delivered 0: the sink failed), time_s 60 to 120; the sink's "
                             "error: cannot create afile: Not a directory") &&
                 Catch::Contains("finding: nc_commands: run 2 (finished): of its 2 command(s) the safety gate passed to "
                                 "file:ncK, 2 not settled (delivered NULL") &&
                 Catch::Contains("ok (no problem; 2 finding(s) above"));
  CHECK(check.output.find("run 3") == std::string::npos);
  CHECK(check.output.find("run 4") == std::string::npos);
  CHECK(check.output.find("file:other") == std::string::npos);
  // With a problem as well, the findings are still named and the exit is 1 for the problem.
  RawDb(file).exec("UPDATE nc_commands SET delivered = 0 WHERE accepted = 0");
  const Outcome both = run_alc("db check " + quoted(file));
  INFO(both.output);
  CHECK(both.exit_code == 1);
  CHECK_THAT(both.output, Catch::Contains("finding: nc_commands: run 1 (finished)") && Catch::Contains("1 problem(s) found"));
}

TEST_CASE("alc db commands name the file and the cause for a file that is not a history", "[storage][cli]") {
  ScratchDir dir;
  const auto file = dir / "notes.txt";
  test::write_bytes(file, std::string(4096, 'x'));
  for (const std::string command : {"info", "check"}) {
    const Outcome outcome = run_alc("db " + command + " " + quoted(file));
    CHECK(outcome.exit_code == 2);  // the input named is wrong (README: exit 2), as for report
    CHECK_THAT(outcome.output, Catch::Contains(file.string()) && Catch::Contains("not an SQLite database"));
  }
  CHECK(test::read_bytes(file) == std::string(4096, 'x'));
  const Outcome missing = run_alc("db info " + quoted(dir / "missing.sqlite"));
  CHECK(missing.exit_code == 2);
  CHECK_THAT(missing.output, Catch::Contains("no such file"));
  // An empty file: its own finding, also exit 2.
  const auto empty = dir / "empty.sqlite";
  test::write_bytes(empty, "");
  const Outcome nothing = run_alc("db info " + quoted(empty));
  CHECK(nothing.exit_code == 2);
  CHECK_THAT(nothing.output, Catch::Contains(empty.string()) && Catch::Contains("an empty file, not an ALC history"));
  // A damaged history is not a wrong input but a failure (exit 1; 'alc db check' lists the damage).
  const auto truncated = dir / "truncated.sqlite";
  test::write_bytes(truncated, std::string("SQLite format 3\0", 16) + std::string(40, '\0'));
  const Outcome damaged = run_alc("db info " + quoted(truncated));
  CHECK(damaged.exit_code == 1);
  CHECK_THAT(damaged.output, Catch::Contains("truncated"));
}

TEST_CASE("alc db export refuses to write its CSV over the database or its journal", "[storage][cli]") {
  ScratchDir dir;
  const auto file = dir / "history.sqlite";
  {
    HistoryWriter writer(file);
    const RunId id = writer.begin_run(test::small_run());
    writer.add(test::sample_at(id, 0));
  }
  const std::string before = test::read_bytes(file);
  std::filesystem::create_symlink(file, dir / "link.sqlite");
  for (const auto& out : {file, dir.path / "." / "history.sqlite", dir / "link.sqlite",
                          std::filesystem::path(file.string() + "-wal")}) {
    INFO(out.string());
    const Outcome outcome = run_alc("db export " + quoted(file) + " --table runs --out " + quoted(out));
    CHECK(outcome.exit_code == 2);
    CHECK_THAT(outcome.output, Catch::Contains("is the history database") && Catch::Contains("choose another --out"));
    CHECK(test::read_bytes(file) == before);
    CHECK_FALSE(std::filesystem::exists(file.string() + "-wal"));
  }
  CHECK(run_alc("db check " + quoted(file)).exit_code == 0);
}

TEST_CASE("alc db bench --dir never touches an existing file there", "[storage][cli]") {
  ScratchDir dir;
  // The name the bench used to delete and reuse.
  const auto precious = dir / "alc-bench-history.sqlite";
  test::write_bytes(precious, "someone's data");
  const Outcome bench = run_alc("db bench --samples 50 --inputs 2 --batch 10 --dir " + quoted(dir.path));
  INFO(bench.output);
  CHECK(bench.exit_code == 0);
  CHECK_THAT(bench.output, Catch::Contains("records per mode: 100") && Catch::Contains("scratch databases") &&
                               Catch::Contains("alc-bench-"));
  CHECK(test::read_bytes(precious) == "someone's data");
  std::size_t left = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir.path)) left += entry.path() != precious;
  CHECK(left == 0);  // its own scratch files are removed
}
