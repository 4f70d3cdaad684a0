// alc replay --db --nc-out: the history records whether the NC files took each command (schema
// version 3, nc_commands.delivered). Runs the built program.
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

#include "../cli_support.hpp"
#include "storage/history_reader.hpp"

namespace fs = std::filesystem;

namespace {

using Run = alc_test::CliRun;

fs::path work_dir() { return alc_test::work_dir("replay_delivery_cli_test"); }

Run run_alc(const std::string& args) { return alc_test::run_alc(args, "replay_delivery_cli_test"); }

// A machine config whose X limit (2 µm) makes the gate refuse the first model's offsets of case A,
// so a replay has accepted and refused NC commands.
std::string tight_machine() {
  const fs::path file = work_dir() / "tight.toml";
  std::ofstream(file) << "[limits.max_offset]\nx_mm = 0.002\n[nc.base.G54]\nx_mm = 0\ny_mm = 0\nz_mm = 0\na_deg = 0\nc_deg = 0\n";
  return " --machine \"" + file.string() + "\"";
}

// The NC commands of the only run in `db`.
std::vector<alc::storage::NcCommandRecord> nc_rows_of(const fs::path& db) {
  const alc::storage::HistoryReader reader(db);
  const auto runs = reader.runs();
  REQUIRE(runs.size() == 1);
  return reader.nc_commands(runs.front().run_id);
}

}  // namespace

TEST_CASE("alc replay --db --nc-out records each accepted NC command as delivered, refused ones as not handed over") {
  const fs::path db = work_dir() / "delivered.sqlite", out = work_dir() / "delivered_nc";
  fs::remove(db);
  fs::remove_all(out);
  const Run r = run_alc("replay --case A --db \"" + db.string() + "\" --nc-out \"" + out.string() + "\"" + tight_machine());
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  CHECK_THAT(r.err, Catch::Matchers::Contains("case A: NC output in " + out.string()));
  REQUIRE(fs::exists(out / "program.ngc"));
  const auto rows = nc_rows_of(db);
  std::size_t accepted = 0, refused = 0;
  for (const auto& row : rows) {
    INFO("command at " << row.time_s << " s: " << row.text);
    CHECK(row.sink == "file:" + out.string());
    if (row.accepted) {
      ++accepted;
      CHECK(row.delivered == std::optional<bool>(true));
      CHECK(row.delivery_message == "written to " + (out / "program.ngc").string());
    } else {
      ++refused;
      CHECK_FALSE(row.delivered.has_value());
      CHECK(row.delivery_message.empty());
    }
  }
  CHECK(accepted >= 1);
  CHECK(refused >= 1);
  CHECK(run_alc("db check \"" + db.string() + "\"").exit_code == 0);

  // --stop-at writes the files of what was emitted so far, and records their delivery.
  fs::remove(db);
  fs::remove_all(out);
  const Run stopped = run_alc("replay --case A --db \"" + db.string() + "\" --nc-out \"" + out.string() + "\" --stop-at 30");
  INFO(stopped.err);
  REQUIRE(stopped.exit_code == 0);
  CHECK_THAT(stopped.err, Catch::Matchers::Contains("stopped at 30 h"));
  CHECK(fs::exists(out / "program.ngc"));
  const auto partial = nc_rows_of(db);
  REQUIRE_FALSE(partial.empty());
  for (const auto& row : partial)
    CHECK(row.delivered == (row.accepted ? std::optional<bool>(true) : std::nullopt));
}

TEST_CASE("alc replay --db --nc-out that cannot write its files records the commands as not delivered and exits 1") {
  // DIR/commands.jsonl is a directory: no process, root included, can write the file. (An --nc-out that
  // cannot be a directory at all is refused before the run begins: replay_cli_test.)
  const fs::path db = work_dir() / "undelivered.sqlite", out = work_dir() / "undelivered_nc";
  fs::remove(db);
  fs::remove_all(out);
  fs::create_directories(out / "commands.jsonl");
  const Run r = run_alc("replay --case A --db \"" + db.string() + "\" --nc-out \"" + out.string() + "\"" + tight_machine());
  INFO(r.err);
  CHECK(r.exit_code == 1);
  CHECK_FALSE(fs::exists(out / "program.ngc"));
  const auto error_at = r.err.find("alc: error: ");
  REQUIRE(error_at != std::string::npos);
  std::string error = r.err.substr(error_at + std::string("alc: error: ").size());
  if (!error.empty() && error.back() == '\n') error.pop_back();
  CHECK_THAT(error, Catch::Matchers::Contains(out.string()));
  const auto rows = nc_rows_of(db);
  std::size_t accepted = 0, refused = 0;
  for (const auto& row : rows) {
    INFO("command at " << row.time_s << " s: " << row.text);
    if (row.accepted) {
      ++accepted;
      CHECK(row.delivered == std::optional<bool>(false));
      CHECK(row.delivery_message == error);  // the error the program reported
    } else {
      ++refused;
      CHECK_FALSE(row.delivered.has_value());
    }
  }
  CHECK(accepted >= 1);
  CHECK(refused >= 1);
  CHECK(run_alc("db check \"" + db.string() + "\"").exit_code == 0);
}

TEST_CASE("a history whose NC files could not be written: the report says no passed command was delivered, db check names it") {
  // The review's case: `touch afile; alc replay ... --nc-out afile` exited 1 after the run and every
  // accepted row read delivered 0; the report said "passed to the NC (813)" and nothing else. (A plain
  // file as --nc-out is now refused before the run; a commands.jsonl that is a directory still fails
  // the delivery at the end.)
  const fs::path db = work_dir() / "afile.sqlite", out = work_dir() / "afile_nc", page = work_dir() / "afile.html";
  fs::remove(db);
  fs::remove_all(out);
  fs::create_directories(out / "commands.jsonl");
  const Run r = run_alc("replay --case A --db \"" + db.string() + "\" --nc-out \"" + out.string() + "\"");
  INFO(r.err);
  REQUIRE(r.exit_code == 1);
  std::size_t passed = 0;
  for (const auto& row : nc_rows_of(db))
    if (row.accepted && row.kind == "offsets") {
      ++passed;
      CHECK(row.delivered == std::optional<bool>(false));
    }
  REQUIRE(passed > 0);
  const Run report = run_alc("report \"" + db.string() + "\" --out \"" + page.string() + "\"");
  INFO(report.err);
  REQUIRE(report.exit_code == 0);
  const std::string html = alc_test::slurp(page);
  CHECK_THAT(html, Catch::Matchers::Contains("<strong>None of the " + std::to_string(passed) +
                                             " offset commands the safety gate passed is recorded as delivered to the NC</strong>: " +
                                             std::to_string(passed) + " not delivered (delivered 0: the sink failed: "));
  CHECK_THAT(html, Catch::Matchers::Contains((out / "commands.jsonl").string()));
  const Run check = run_alc("db check \"" + db.string() + "\"");
  INFO(check.out << check.err);
  CHECK(check.exit_code == 0);  // a true record of a failed delivery, not damage (docs/storage.md)
  CHECK_THAT(check.out, Catch::Matchers::Contains("finding: nc_commands: run 1 (finished): of its ") &&
                            Catch::Matchers::Contains(" not delivered (delivered 0: the sink failed)") &&
                            Catch::Matchers::Contains("ok (no problem; 1 finding(s) above"));
}

TEST_CASE("a run with NC output killed and resumed without --nc-out: the resume warns from when, db check and the report name the unsettled commands") {
  const fs::path db = work_dir() / "killed_nc.sqlite", out = work_dir() / "killed_nc", page = work_dir() / "killed.html";
  fs::remove(db);
  fs::remove_all(out);
  const Run killed = run_alc("replay --case A --db \"" + db.string() + "\" --nc-out \"" + out.string() + "\" --kill-at 100");
  REQUIRE(killed.signal == 9);
  std::size_t unsettled_before = 0;
  for (const auto& row : nc_rows_of(db)) unsettled_before += row.accepted && !row.delivered;
  REQUIRE(unsettled_before > 0);
  // --resume with --nc-out stays refused (documented); without it, the rest of the run reaches no NC.
  CHECK(run_alc("replay --case A --db \"" + db.string() + "\" --resume --nc-out \"" + out.string() + "\"").exit_code == 2);
  const Run resumed = run_alc("replay --case A --db \"" + db.string() + "\" --resume");
  INFO(resumed.err);
  REQUIRE(resumed.exit_code == 0);
  CHECK_THAT(resumed.err, Catch::Matchers::Contains("case A: run 1 had NC output (file:" + out.string() +
                                                    "); this resume has none (--nc-out cannot be combined with "
                                                    "--resume): from 96 h of scenario time (its snapshot) on, no NC "
                                                    "command of the run is written or recorded"));
  // Only the rows up to the snapshot are left (the resume deleted the later ones): those are counted.
  std::size_t unsettled = 0, unsettled_offsets = 0;  // the report draws the offset commands
  for (const auto& row : nc_rows_of(db)) {
    unsettled += row.accepted && !row.delivered;
    unsettled_offsets += row.accepted && !row.delivered && row.kind == "offsets";
  }
  REQUIRE(unsettled > 0);
  CHECK_THAT(resumed.err, Catch::Matchers::Contains("; " + std::to_string(unsettled) +
                                                    " accepted command(s) before it are not recorded as delivered"));
  const Run check = run_alc("db check \"" + db.string() + "\"");
  INFO(check.out << check.err);
  CHECK(check.exit_code == 0);
  CHECK_THAT(check.out, Catch::Matchers::Contains("finding: nc_commands: run 1 (finished): of its " +
                                                  std::to_string(unsettled) + " command(s) the safety gate passed to file:" +
                                                  out.string() + ", " + std::to_string(unsettled) + " not settled"));
  REQUIRE(run_alc("report \"" + db.string() + "\" --out \"" + page.string() + "\"").exit_code == 0);
  const std::string html = alc_test::slurp(page);
  CHECK_THAT(html, Catch::Matchers::Contains("data-not-settled=\"" + std::to_string(unsettled_offsets) + "\""));
  CHECK_THAT(html, Catch::Matchers::Contains("class=\"marker marker-unsettled"));

  // Stopped with --nc-out (its files written, delivered 1) and resumed: the warning, and nothing undelivered.
  fs::remove(db);
  fs::remove_all(out);
  REQUIRE(run_alc("replay --case A --db \"" + db.string() + "\" --nc-out \"" + out.string() + "\" --stop-at 30").exit_code == 0);
  const Run after_stop = run_alc("replay --case A --db \"" + db.string() + "\" --resume");
  INFO(after_stop.err);
  REQUIRE(after_stop.exit_code == 0);
  CHECK_THAT(after_stop.err, Catch::Matchers::Contains("case A: run 1 had NC output") &&
                                 Catch::Matchers::Contains("h of scenario time (its snapshot) on"));
  CHECK(after_stop.err.find("never delivered") == std::string::npos);
  const Run clean = run_alc("db check \"" + db.string() + "\"");
  CHECK(clean.exit_code == 0);
  CHECK(clean.out.find("finding") == std::string::npos);
  // A run without NC output resumes without the warning.
  fs::remove(db);
  REQUIRE(run_alc("replay --case A --db \"" + db.string() + "\" --stop-at 10").exit_code == 0);
  const Run plain = run_alc("replay --case A --db \"" + db.string() + "\" --resume");
  REQUIRE(plain.exit_code == 0);
  CHECK(plain.err.find("NC output") == std::string::npos);
}
