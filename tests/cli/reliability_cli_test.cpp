// Issue 13 (reliability): what the CLI does with a history and data that changed under it.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <sys/stat.h>
#include <sys/wait.h>

#include "../cli_support.hpp"
#include "scenarios/scenario.hpp"
#include "scenarios/scenario_csv.hpp"
#include "storage/history_reader.hpp"
#include "storage/history_writer.hpp"

namespace fs = std::filesystem;
using alc_test::CliRun;
using namespace alc;

namespace {

CliRun run(const std::string& args) { return alc_test::run_alc(args, "reliability_cli_test"); }

// A fresh directory `name` of one test, removed at its end.
alc_test::Scratch scratch(const std::string& name) {
  return alc_test::Scratch(alc_test::work_dir("reliability_cli_test") / name);
}

// Case A simulated into `csv` (alc simulate) and read back.
scenarios::Scenario simulated_case_a(const fs::path& csv) {
  REQUIRE(run("simulate --case A --out \"" + csv.string() + "\"").exit_code == 0);
  return scenarios::read_scenario_csv(csv);
}

// The column of `name` in `names`, which must hold it.
Eigen::Index column(const std::vector<std::string>& names, const std::string& name) {
  const auto i = static_cast<Eigen::Index>(std::find(names.begin(), names.end(), name) - names.begin());
  REQUIRE(i < static_cast<Eigen::Index>(names.size()));
  return i;
}

}  // namespace

TEST_CASE("alc replay --resume refuses another recording under the same file name naming both hashes (issue 13 item 6)") {
  const alc_test::Scratch scratch_dir = scratch("same_name");
  const fs::path& dir = scratch_dir.dir;
  const fs::path csv = dir / "rec.csv", db = dir / "h.sqlite";
  const std::string first = scenarios::content_hash(simulated_case_a(csv));
  REQUIRE(run("replay \"" + csv.string() + "\" --db \"" + db.string() + "\" --stop-at 8").exit_code == 0);
  REQUIRE(run("simulate --case A --seed 7 --out \"" + csv.string() + "\"").exit_code == 0);
  const std::string second = scenarios::content_hash(scenarios::read_scenario_csv(csv));
  REQUIRE(first != second);
  const CliRun r = run("replay \"" + csv.string() + "\" --db \"" + db.string() + "\" --resume");
  CHECK(r.exit_code == 2);
  CHECK_THAT(r.err, Catch::Matchers::Contains("of 'file " + csv.string() + "' was recorded from other data: content hash " +
                                              first + " stored, " + second + " given"));
}

namespace {

// Runs `sqlite3 DB SQL` and returns its stdout without the final newline.
std::string sql(const fs::path& db, const std::string& statement) {
  const fs::path out = alc_test::work_dir("reliability_cli_test") / "sql_out";
  const std::string cmd = "sqlite3 \"" + db.string() + "\" \"" + statement + "\" >\"" + out.string() + "\"";
  REQUIRE(std::system(cmd.c_str()) == 0);
  std::string text = alc_test::slurp(out);
  while (!text.empty() && text.back() == '\n') text.pop_back();
  return text;
}

// Flips one byte in the middle of the payload of snapshot `id`.
void damage_snapshot(const fs::path& db, const std::string& id) {
  sql(db, "UPDATE controller_snapshots SET payload = substr(payload, 1, 999) || CASE WHEN substr(payload, 1000, 1) = "
          "X'00' THEN X'01' ELSE X'00' END || substr(payload, 1001) WHERE snapshot_id = " + id);
}

}  // namespace

TEST_CASE("a damaged snapshot is reported by db check and skipped by --resume, which says so (issue 13 item 5)") {
  const alc_test::Scratch scratch_dir = scratch("snapshot");
  const fs::path& dir = scratch_dir.dir;
  const fs::path db = dir / "h.sqlite";
  const CliRun whole = run("replay --case A --json");
  REQUIRE(whole.exit_code == 0);
  REQUIRE(run("replay --case A --db \"" + db.string() + "\" --stop-at 30").exit_code == 0);
  const std::string latest = sql(db, "SELECT max(snapshot_id) FROM controller_snapshots");
  const std::string before = sql(db, "SELECT max(snapshot_id) FROM controller_snapshots WHERE snapshot_id < " + latest);
  damage_snapshot(db, latest);
  const CliRun check = run("db check \"" + db.string() + "\"");
  CHECK(check.exit_code == 1);
  CHECK_THAT(check.err, Catch::Matchers::Contains("controller_snapshots: snapshot " + latest +
                                                  " of run 1: run state: checksum mismatch"));
  SECTION("resume falls back to the latest good snapshot, names both, and ends as an uninterrupted run") {
    const CliRun resumed = run("replay --case A --db \"" + db.string() + "\" --resume --json");
    CHECK(resumed.exit_code == 0);
    CHECK_THAT(resumed.err, Catch::Matchers::Contains("snapshot " + latest) &&
                                Catch::Matchers::Contains("resuming from the latest good one, snapshot " + before));
    CHECK(resumed.out == whole.out);
    CHECK(run("db check \"" + db.string() + "\"").exit_code == 0);  // the damaged one was redone
  }
  SECTION("no good snapshot left: refused with every snapshot named, the history unchanged") {
    for (const std::string& id : {before, std::string("1")}) damage_snapshot(db, id);
    const std::string rows = sql(db, "SELECT count(*) FROM input_samples") + " " + sql(db, "SELECT status FROM runs");
    const CliRun refused = run("replay --case A --db \"" + db.string() + "\" --resume --json");
    CHECK(refused.exit_code == 2);
    CHECK_THAT(refused.err, Catch::Matchers::Contains("no usable controller snapshot") &&
                                Catch::Matchers::Contains("snapshot " + latest + " at") &&
                                Catch::Matchers::Contains("snapshot 1 at"));
    CHECK(sql(db, "SELECT count(*) FROM input_samples") + " " + sql(db, "SELECT status FROM runs") == rows);
  }
}

TEST_CASE("resume on an empty file or a dangling symbolic link is refused and creates nothing (issue 13 item 12)") {
  const alc_test::Scratch scratch_dir = scratch("resume_nothing");
  const fs::path& dir = scratch_dir.dir;
  { std::ofstream(dir / "empty.sqlite"); }
  fs::create_symlink(dir / "nowhere.sqlite", dir / "dangling.sqlite");
  const std::pair<std::string, std::string> cases[] = {{"empty.sqlite", "the file is empty"},
                                                       {"dangling.sqlite", "a symbolic link to nothing"},
                                                       {"missing.sqlite", "the file does not exist"}};
  for (const auto& [name, why] : cases) {
    INFO(name);
    const CliRun r = run("replay --case A --db \"" + (dir / name).string() + "\" --resume");
    CHECK(r.exit_code == 2);
    CHECK_THAT(r.err, Catch::Matchers::Contains((dir / name).string()) &&
                          Catch::Matchers::Contains("no history to resume: " + why));
  }
  CHECK(fs::file_size(dir / "empty.sqlite") == 0);
  CHECK_FALSE(fs::exists(dir / "nowhere.sqlite"));
  CHECK_FALSE(fs::exists(dir / "missing.sqlite"));
  std::size_t entries = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++entries;
  CHECK(entries == 2);  // no -wal, -shm or journal files either
}

TEST_CASE("a --db that is a named pipe is refused at once, not waited on") {
  // The writer claims an existing history before SQLite opens it; opening a FIFO to claim it would wait
  // for a writer of the pipe for ever (the timeout below would end it with 124).
  const alc_test::Scratch scratch_dir = scratch("fifo_db");
  const fs::path fifo = scratch_dir.dir / "h.sqlite";
  REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
  const fs::path err = scratch_dir.dir / "err";
  const std::string cmd = std::string("timeout 60 \"") + ALC_CLI_PATH + "\" replay --case A --db \"" + fifo.string() +
                          "\" >/dev/null 2>\"" + err.string() + "\" </dev/null";
  const int status = std::system(cmd.c_str());
  REQUIRE(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 2);
  CHECK_THAT(alc_test::slurp(err), Catch::Matchers::Contains(fifo.string()) &&
                                       Catch::Matchers::Contains("not a regular file"));
}

TEST_CASE("an absurd but finite error column (-1e308: a sensor fault) is set aside for that output and the "
          "other outputs are learned as in the clean run (issue 13 item 3)") {
  const alc_test::Scratch scratch_dir = scratch("implausible");
  const fs::path& dir = scratch_dir.dir;
  const fs::path clean = dir / "clean.csv", faulty = dir / "faulty.csv";
  scenarios::Scenario s = simulated_case_a(clean);
  const auto names = s.output_names;
  const Eigen::Index x = column(names, "E_X0C");
  int replaced = 0;
  for (Eigen::Index r = 0; r < s.outputs.rows(); ++r)
    if (!std::isnan(s.outputs(r, x))) {
      s.outputs(r, x) = -1e308;
      ++replaced;
    }
  REQUIRE(replaced > 100);
  scenarios::write_scenario_csv(faulty, s);

  // Bit for bit where the probes' times cannot depend on E_X0C: without the guard, whose move check takes
  // a probe when any output's compensation has moved half its ACL (in the clean run E_X0C's does).
  const CliRun good = run("replay \"" + clean.string() + "\" --json --no-guard");
  const CliRun bad = run("replay \"" + faulty.string() + "\" --json --no-guard");
  REQUIRE(good.exit_code == 0);
  REQUIRE(bad.exit_code == 0);
  // With the guard (the default) the other outputs are learned and compensated as well: each one's P99
  // below a third of uncompensated, as in the clean run (where the angular ones are at about a fifth).
  const CliRun guarded = run("replay \"" + faulty.string() + "\" --json");
  const CliRun guarded_clean = run("replay \"" + clean.string() + "\" --json");
  REQUIRE(guarded.exit_code == 0);
  REQUIRE(guarded_clean.exit_code == 0);
  const auto g = nlohmann::json::parse(good.out), b = nlohmann::json::parse(bad.out);
  const auto gb = nlohmann::json::parse(guarded.out), gg = nlohmann::json::parse(guarded_clean.out);
  CHECK(b.at("updates").get<int>() > 0);
  CHECK(b.at("updates") == g.at("updates"));
  CHECK(gb.at("updates").get<int>() > 0);
  // Every other output: the indicators of the clean run, bit for bit; the faulty one has none.
  for (const std::string& name : names) {
    INFO(name);
    if (name == "E_X0C") {
      CHECK(b.at("outputs").at(name).at("measurements") == 0);
      CHECK(gb.at("outputs").at(name).at("measurements") == 0);
      continue;
    }
    CHECK(b.at("outputs").at(name) == g.at("outputs").at(name));
    CHECK(b.at("outputs").at(name).at("P99").is_number());
    for (const auto* r : {&gb, &gg})
      CHECK(r->at("outputs").at(name).at("P99").get<double>() <
            r->at("outputs").at(name).at("P99_uncompensated").get<double>() / 3.0);
  }
  // The event names the output, the value and the limit; once per output at warn.
  CHECK_THAT(bad.err, Catch::Matchers::Contains("E_X0C = -1e+308 µm is beyond the plausible ±1000 µm"));
  CHECK(bad.err.find("E_X0C = -1e+308", bad.err.find("E_X0C = -1e+308") + 1) == std::string::npos);
  // The readings after CP that the indicators leave out are counted at the end (before: without a word).
  const auto after_cp = [&] {
    int n = 0;
    for (Eigen::Index r = 0; r < s.outputs.rows(); ++r)
      n += !std::isnan(s.outputs(r, x)) && s.time_s[static_cast<std::size_t>(r)] >= g.at("cp_end_h").get<double>() * 3600.0;
    return n;
  }();
  REQUIRE(after_cp > 100);
  CHECK_THAT(bad.err, Catch::Matchers::Contains(std::to_string(after_cp) +
                                                " recorded measurement(s) after CP beyond the plausible limit "
                                                "(--plausible-lin, --plausible-ang) were left out of the indicators; "
                                                "the first: E_X0C at time_s "));
  CHECK_THAT(good.err, !Catch::Matchers::Contains("left out of the indicators"));
  // The table's mean of the linear errors is over the three left: it says so, where the clean run's
  // mean of four says nothing (the faulty recording would read as the better one).
  const CliRun bad_text = run("replay \"" + faulty.string() + "\"");
  const CliRun good_text = run("replay \"" + clean.string() + "\"");
  CHECK_THAT(bad_text.out, Catch::Matchers::Contains("µm (the mean of 3 of 4 outputs; E_X0C has no P99: no plausible "
                                                     "measurement after CP)\n"));
  CHECK_THAT(bad_text.out, !Catch::Matchers::Contains("µm/m (the mean of"));
  CHECK_THAT(good_text.out, !Catch::Matchers::Contains("(the mean of"));

  // A limit below the readings sets them aside too; a loose limit value is a usage error.
  const CliRun tight = run("replay \"" + clean.string() + "\" --json --plausible-ang 20");
  REQUIRE(tight.exit_code == 0);
  CHECK_THAT(tight.err, Catch::Matchers::Contains("is beyond the plausible ±20 µm/m"));
  for (const std::string bad_limit : {"-1", "nan", "0x10", "0"}) {
    const CliRun r = run("replay --case A --plausible-lin " + bad_limit);
    CHECK(r.exit_code == 2);
    CHECK_THAT(r.err, Catch::Matchers::Contains("plausible"));
  }
}

TEST_CASE("an absurd temperature reading (a sensor fault) sets the sample aside with its reason (issue 13 item 3)") {
  const alc_test::Scratch scratch_dir = scratch("implausible_input");
  const fs::path& dir = scratch_dir.dir;
  const fs::path clean = dir / "clean.csv", faulty = dir / "faulty.csv";
  scenarios::Scenario s = simulated_case_a(clean);
  const Eigen::Index t = column(s.input_names, "T_ENV");
  s.inputs(5000, t) = -1e308;  // one sample, after CP
  scenarios::write_scenario_csv(faulty, s);
  const CliRun r = run("replay \"" + faulty.string() + "\" --json");
  REQUIRE(r.exit_code == 0);
  CHECK_THAT(r.err, Catch::Matchers::Contains("input 'T_ENV' = -1e+308 °C is beyond the plausible ±200 °C"));
  CHECK_THAT(r.err, Catch::Matchers::Contains("faulty.csv: 1 of " + std::to_string(s.samples()) +
                                              " samples were set aside; the first: sample 5000: "));
  const auto j = nlohmann::json::parse(r.out);
  CHECK(j.at("rejected_samples") == 1);
  CHECK(j.at("updates").get<int>() > 0);
  for (const std::string& name : s.output_names) CHECK(j.at("outputs").at(name).at("P99").is_number());
}

TEST_CASE("alc db finish refuses a replay's run, an unknown run and a missing file, and waits for a writer holding the file") {
  // It ends a supervisor's run (tests/supervisor/supervisor_test.cpp: "a run that the configuration no
  // longer matches ..."); a replay's run stopped part-way holds the indicators of that part, which a
  // finished run would present as the whole run's.
  const auto scratch_dir = scratch("finish");
  const fs::path dir = scratch_dir.dir;
  const std::string db = (dir / "h.sqlite").string();
  REQUIRE(run("replay --case A --cp 1 --db \"" + db + "\" --stop-at 2").exit_code == 0);
  const auto status = [&] { return std::string(storage::to_string(storage::HistoryReader(db).runs().at(0).status)); };
  {
    // A supervisor or a replay that has the history open: refused (after the writer's busy timeout).
    storage::HistoryWriter holder(db);
    const CliRun locked = run("db finish \"" + db + "\" --run 1");
    CHECK(locked.exit_code == 1);
    CHECK_THAT(locked.err, Catch::Matchers::Contains(db) && Catch::Matchers::Contains("another writer has this history open"));
  }
  const std::pair<std::string, std::string> refused[] = {
      {"db finish \"" + db + "\" --run 1",
       "run 1 of 'case A' is not a supervisor's: a replay's run is continued with alc replay --resume or left as it "
       "is (a replay without --resume begins a new run); nothing changed"},
      {"db finish \"" + db + "\" --run 9", "there is no run 9; its unfinished runs: run 1 of 'case A'"},
  };
  for (const auto& [args, message] : refused) {
    INFO(args);
    const CliRun r = run(args);
    CHECK(r.exit_code == 1);
    CHECK_THAT(r.err, Catch::Matchers::Contains(db + ": " + message));
  }
  CHECK(status() == "stopped");
  // Still resumable, as it was.
  CHECK(run("replay --case A --cp 1 --db \"" + db + "\" --resume --stop-at 3").exit_code == 0);
  CHECK(run("db finish \"" + (dir / "none.sqlite").string() + "\" --run 1").exit_code == 2);
  CHECK_FALSE(fs::exists(dir / "none.sqlite"));
  CHECK(run("db finish \"" + db + "\" --run 0").exit_code == 2);
}
