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
