// alc study from the command line: files, resume, refusals, merge, report, a clean stop on SIGINT.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <catch2/catch.hpp>

#include <algorithm>
#include <fstream>
#include <map>
#include <chrono>
#include <nlohmann/json.hpp>
#include <sstream>
#include <set>
#include <thread>

#include "../cli_support.hpp"

using alc_test::run_alc;
using alc_test::slurp;
using alc_test::occurrences;
namespace fs = std::filesystem;

namespace {

fs::path dir() { return alc_test::work_dir("study_cli"); }

// Case A and B cut to 48 h as scenario CSV files (made once per test process).
const fs::path& short_case(char name) {
  static std::map<char, fs::path> made;
  auto it = made.find(name);
  if (it != made.end()) return it->second;
  const fs::path full = dir() / (std::string("full_") + name + ".csv");
  const fs::path cut = dir() / (std::string(1, static_cast<char>(std::tolower(name))) + ".csv");
  REQUIRE(run_alc("simulate --case " + std::string(1, name) + " --out " + full.string(), "study_cli").exit_code == 0);
  // Header + 48 h at 1 min.
  REQUIRE(std::system(("head -n 2881 " + full.string() + " > " + cut.string()).c_str()) == 0);
  return made.emplace(name, cut).first->second;
}

fs::path write(const std::string& name, const std::string& text) {
  const fs::path p = dir() / name;
  std::ofstream(p) << text;
  return p;
}

const char* kGrid = "cp = [0.05, 6.5]\ninterval = [2, 6, \"inf\"]\nng-meas = [6, 12]\n";

std::string sql(const fs::path& db, const std::string& query) {
  const fs::path out = dir() / "sql.out";
  const std::string cmd = "sqlite3 " + db.string() + " \"" + query + "\" > " + out.string();
  REQUIRE(std::system(cmd.c_str()) == 0);
  std::string s = slurp(out);
  while (!s.empty() && s.back() == '\n') s.pop_back();
  return s;
}

std::string files() { return short_case('A').string() + " " + short_case('B').string(); }

}  // namespace

TEST_CASE("study writes rows to CSV and SQLite, and report gives the same rows and the analysis") {
  const fs::path grid = write("g.toml", kGrid);
  const fs::path db = dir() / "whole.sqlite", csv = dir() / "whole.csv", csv2 = dir() / "report.csv";
  fs::remove(db);
  const auto r = run_alc("study --grid " + grid.string() + " " + files() + " --jobs 2 --db " + db.string() + " --csv " +
                             csv.string() + " --json",
                         "study_cli");
  REQUIRE(r.exit_code == 0);
  const auto j = nlohmann::json::parse(r.out);
  CHECK(j["rows"] == 20);  // 10 sets (interval = inf: one set per CP) x 2 cases
  CHECK(j["expected_rows"] == 20);
  CHECK(j["per_case"].contains(short_case('A').string()));
  CHECK(j["paper_set"].is_null() == false);  // cp 6.5, interval 2, ng-meas 12 with default ng-interval 10
  const std::string text = slurp(csv);
  std::istringstream lines(text);
  std::string header;
  std::getline(lines, header);
  CHECK(header.rfind("set,case,cp,interval,ng-meas,status,error,Pd,M,ng_phases,updates,rejected_fits,rejected_samples,cp_end_h,"
                     "duration_h,P99_linear,P99_angular",
                     0) == 0);
  std::size_t rows = 0, errors = 0;
  for (std::string line; std::getline(lines, line);) {
    ++rows;
    if (line.find(",error,") != std::string::npos) {
      ++errors;
      CHECK(line.find("cp_interval_s") != std::string::npos);  // the failed set says why
    }
  }
  CHECK(rows == 20);
  CHECK(errors == 10);  // cp = 0.05 h: its 5 sets x 2 cases
  CHECK(sql(db, "SELECT count(*) FROM study_rows") == "20");
  REQUIRE(run_alc("study report " + db.string() + " --csv " + csv2.string(), "study_cli").exit_code == 0);
  CHECK(slurp(csv2) == text);
  // The study's tables are tables of the file for db info and db export too (before: not listed, refused).
  const auto info = run_alc("db info " + db.string(), "study_cli");
  CHECK_THAT(info.out, Catch::Matchers::Contains("study_rows") && Catch::Matchers::Contains("studies"));
  const auto rows_csv = run_alc("db export " + db.string() + " --table study_rows --out -", "study_cli");
  REQUIRE(rows_csv.exit_code == 0);
  CHECK(rows_csv.out.rfind("study_id,set_index,case_index,status,error,pd,p99_linear,p99_angular,report_json\n", 0) == 0);
  CHECK(std::count(rows_csv.out.begin(), rows_csv.out.end(), '\n') >= 21);  // header + 20 rows (JSON may hold more)

  SECTION("--resume reuses the rows it has and computes the rest: the same rows") {
    const fs::path partial = dir() / "partial.sqlite", csv3 = dir() / "resumed.csv";
    fs::remove(partial);
    fs::copy_file(db, partial);
    sql(partial, "DELETE FROM study_rows WHERE set_index % 2 = 1");
    const std::string left = sql(partial, "SELECT count(*) FROM study_rows");
    const auto res = run_alc("study --grid " + grid.string() + " " + files() + " --db " + partial.string() +
                                 " --resume --csv " + csv3.string(),
                             "study_cli");
    REQUIRE(res.exit_code == 0);
    CHECK_THAT(res.err, Catch::Contains(left + " rows reused, " + std::to_string(20 - std::stoi(left)) + " computed"));
    // Not a terminal: a progress line at once, before any run, with the rows to come (then every 5 s).
    CHECK(res.err.rfind("study: " + left + "/20 runs, 0 runs/s, ETA -, 0 s in\n", 0) == 0);
    CHECK(slurp(csv3) == text);
  }
  SECTION("the same recordings reached by other paths resume the study under the stored names") {
    // Before: "the cases differ: stored file a.csv (content hash X), now file ./a.csv (content hash X)", so a
    // SLURM task resubmitted with the paths as typed could not resume.
    const fs::path partial = dir() / "moved.sqlite", csv3 = dir() / "moved.csv", elsewhere = dir() / "elsewhere";
    fs::remove(partial);
    fs::copy_file(db, partial);
    sql(partial, "DELETE FROM study_rows WHERE set_index % 2 = 1");
    fs::create_directories(elsewhere);
    for (const char c : {'A', 'B'})
      fs::copy_file(short_case(c), elsewhere / short_case(c).filename(), fs::copy_options::overwrite_existing);
    const auto res = run_alc("study --grid " + grid.string() + " " + (elsewhere / "a.csv").string() + " " +
                                 (elsewhere / "b.csv").string() + " --db " + partial.string() + " --resume --csv " +
                                 csv3.string(),
                             "study_cli");
    INFO(res.err);
    REQUIRE(res.exit_code == 0);
    CHECK_THAT(res.err, Catch::Contains("the same recording (content) as the study's case, continued under its stored "
                                        "name (file " + (elsewhere / "a.csv").string() + " -> file " +
                                        short_case('A').string() + ")"));
    CHECK(slurp(csv3) == text);  // the stored names, the same rows
    // Another content under a stored name is still another case.
    REQUIRE(std::system(("sed -i '100s/,\\([0-9]\\)/,9\\1/' " + (elsewhere / "b.csv").string()).c_str()) == 0);
    const auto other = run_alc("study --grid " + grid.string() + " " + (elsewhere / "a.csv").string() + " " +
                                   (elsewhere / "b.csv").string() + " --db " + partial.string() + " --resume",
                               "study_cli");
    CHECK(other.exit_code == 2);
    CHECK_THAT(other.err, Catch::Contains("the cases differ: stored file " + short_case('B').string()));
  }
  SECTION("--csv - writes the rows to stdout and the analysis to stderr; with --json it is refused") {
    // Before: a file named '-'.
    const auto res = run_alc("study report " + db.string() + " --csv -", "study_cli");
    REQUIRE(res.exit_code == 0);
    CHECK(res.out == text);
    CHECK_THAT(res.err, Catch::Contains("Eq. 8"));
    const auto both = run_alc("study report " + db.string() + " --csv - --json", "study_cli");
    CHECK(both.exit_code == 2);
    CHECK_THAT(both.err, Catch::Contains("--csv - and --json both write to stdout"));
    CHECK_FALSE(fs::exists("-"));
  }
  SECTION("a row of a set the grid does not have: study report and report name it, db check lists it") {
    // Before: both reports crashed (SIGSEGV, exit 139) indexing the grid's sets by 999; db check said ok.
    const fs::path damaged = dir() / "damaged.sqlite";
    fs::remove(damaged);
    fs::copy_file(db, damaged);
    sql(damaged, "UPDATE study_rows SET set_index = 999 WHERE set_index = 2 AND case_index = 0");
    const std::string why = "study_rows: set 999, case 0: set_index 999 is not one of the study's 10 parameter sets";
    for (const std::string& command : {"study report " + damaged.string(), "report " + damaged.string() + " --out " +
                                                                                (dir() / "damaged.html").string(),
                                       "db check " + damaged.string()}) {
      INFO(command);
      const auto res = run_alc(command, "study_cli");
      CHECK(res.exit_code == 1);
      CHECK_THAT(res.err + res.out, Catch::Contains(damaged.string()) && Catch::Contains(why));
    }
    CHECK_FALSE(fs::exists(dir() / "damaged.html"));
  }
  SECTION("--csv where it cannot be written is refused before any row is computed") {
    const auto res = run_alc("study --grid " + grid.string() + " " + files() + " --csv " +
                                 (dir() / "no_such_dir" / "rows.csv").string(),
                             "study_cli");
    CHECK(res.exit_code == 1);  // as replay --residuals and simulate --out (README: refused, exit 1)
    CHECK_THAT(res.err, Catch::Contains("--csv: cannot write '") && Catch::Contains("no_such_dir") &&
                            Catch::Contains("No such file or directory"));
    CHECK(res.err.find("computed") == std::string::npos);  // the progress line never came
  }
  SECTION("the empty file a run killed before its first row leaves: --resume begins the study there") {
    const fs::path empty = dir() / "killed_early.sqlite", csv4 = dir() / "from_empty.csv";
    fs::remove(empty);
    std::ofstream(empty).flush();  // 0 bytes (SQLite's header alone is judged alike: storage tests)
    const auto res = run_alc("study --grid " + grid.string() + " " + files() + " --db " + empty.string() +
                                 " --resume --csv " + csv4.string(),
                             "study_cli");
    INFO(res.err);
    REQUIRE(res.exit_code == 0);
    CHECK_THAT(res.err, Catch::Contains("0 rows reused, 20 computed"));
    CHECK(slurp(csv4) == text);
    // A file that is missing is still no study to resume.
    const auto missing = run_alc("study --grid " + grid.string() + " " + files() + " --db " +
                                     (dir() / "missing.sqlite").string() + " --resume",
                                 "study_cli");
    CHECK(missing.exit_code == 2);
    CHECK_THAT(missing.err, Catch::Contains("holds no study to resume"));
  }
  SECTION("a study file is not overwritten, and resumes only the same study") {
    auto again = run_alc("study --grid " + grid.string() + " " + files() + " --db " + db.string(), "study_cli");
    CHECK(again.exit_code == 2);
    CHECK_THAT(again.err, Catch::Contains("holds a study already"));
    const fs::path other = write("other.toml", "cp = [6.5]\ninterval = [2, 6]\n");
    again = run_alc("study --grid " + other.string() + " " + files() + " --db " + db.string() + " --resume", "study_cli");
    CHECK(again.exit_code == 2);
    CHECK_THAT(again.err, Catch::Contains("cannot resume") && Catch::Contains("the grid differs"));
    // Another recording under the same file name.
    const fs::path b_copy = dir() / "b_saved.csv";
    fs::copy_file(short_case('B'), b_copy, fs::copy_options::overwrite_existing);
    REQUIRE(std::system(("sed -i '100s/,\\([0-9]\\)/,9\\1/' " + short_case('B').string()).c_str()) == 0);
    again = run_alc("study --grid " + grid.string() + " " + files() + " --db " + db.string() + " --resume", "study_cli");
    fs::copy_file(b_copy, short_case('B'), fs::copy_options::overwrite_existing);
    CHECK(again.exit_code == 2);
    CHECK_THAT(again.err, Catch::Contains("the cases differ") && Catch::Contains("content hash"));
  }
  SECTION("shards merge into the whole study; overlaps, gaps and foreign shards are refused") {
    std::string shard_files;
    for (int i = 1; i <= 3; ++i) {
      const fs::path s = dir() / ("shard" + std::to_string(i) + ".sqlite");
      fs::remove(s);
      REQUIRE(run_alc("study --grid " + grid.string() + " " + files() + " --shard " + std::to_string(i) + "/3 --db " +
                          s.string() + " --quiet",
                      "study_cli")
                  .exit_code == 0);
      shard_files += " " + s.string();
    }
    const fs::path merged = dir() / "merged.sqlite", merged_csv = dir() / "merged.csv";
    fs::remove(merged);
    const auto merge = run_alc("study merge --out " + merged.string() + shard_files, "study_cli");
    REQUIRE(merge.exit_code == 0);
    CHECK_THAT(merge.err, Catch::Contains("merged 3 shards into " + merged.string() + ": "));
    REQUIRE(run_alc("study report " + merged.string() + " --csv " + merged_csv.string(), "study_cli").exit_code == 0);
    CHECK(slurp(merged_csv) == text);
    // Reading the shards and the merged file leaves no -wal or -shm beside them (one pair per shard
    // of a cluster's study otherwise).
    for (const fs::path& f : {dir() / "shard1.sqlite", dir() / "shard2.sqlite", dir() / "shard3.sqlite", merged})
      for (const char* side : {"-wal", "-shm"}) {
        INFO(f.string() + side);
        CHECK_FALSE(fs::exists(f.string() + side));
      }
    const fs::path bad = dir() / "bad.sqlite";
    fs::remove(bad);
    auto m = run_alc("study merge --out " + bad.string() + " " + (dir() / "shard1.sqlite").string() + " " +
                         (dir() / "shard2.sqlite").string(),
                     "study_cli");
    CHECK(m.exit_code == 2);
    CHECK_THAT(m.err, Catch::Contains("gap: no shard holds the row"));
    m = run_alc("study merge --out " + bad.string() + shard_files + " " + db.string(), "study_cli");
    CHECK(m.exit_code == 2);
    CHECK_THAT(m.err, Catch::Contains("shard all is of another split than shard 1/3"));
    // Shards of two splits (1/2 with 2/3): said so, not found as an overlap.
    const fs::path half = dir() / "half.sqlite";
    fs::remove(half);
    REQUIRE(run_alc("study --grid " + grid.string() + " " + files() + " --shard 1/2 --quiet --db " + half.string(),
                    "study_cli")
                .exit_code == 0);
    m = run_alc("study merge --out " + bad.string() + " " + half.string() + " " + (dir() / "shard2.sqlite").string(),
                "study_cli");
    CHECK(m.exit_code == 2);
    CHECK_THAT(m.err, Catch::Contains("is of another split") && Catch::Contains("the same N"));
    const fs::path other = write("other.toml", "cp = [6.5]\ninterval = [2, 6]\n");
    const fs::path foreign = dir() / "foreign.sqlite";
    fs::remove(foreign);
    REQUIRE(run_alc("study --grid " + other.string() + " " + files() + " --shard 1/3 --db " + foreign.string() +
                        " --quiet",
                    "study_cli")
                .exit_code == 0);
    m = run_alc("study merge --out " + bad.string() + " " + foreign.string() + " " +
                    (dir() / "shard2.sqlite").string(),
                "study_cli");
    CHECK(m.exit_code == 2);
    CHECK_THAT(m.err, Catch::Contains("is not a shard of the study") && Catch::Contains("the grid differs"));
    CHECK_FALSE(fs::exists(bad));
    // A shard that is not there is named so (before: "holds no study", as for a file of another kind).
    m = run_alc("study merge --out " + bad.string() + " " + (dir() / "shard1.sqlite").string() + " " +
                    (dir() / "no_such_shard.sqlite").string(),
                "study_cli");
    CHECK(m.exit_code == 2);
    CHECK_THAT(m.err, Catch::Contains("no_such_shard.sqlite: no such file"));
    CHECK_FALSE(fs::exists(dir() / "no_such_shard.sqlite"));
  }
}

TEST_CASE("a study tells a sparsely measured recording once per case and each repeated warning of its runs once") {
  // Case A cut to 48 h, every second minute kept: measured every 10 min in CP where the CP interval is 5.
  const fs::path sparse = dir() / "a_2min.csv";
  REQUIRE(std::system(("awk 'NR == 1 || NR % 2 == 0' " + short_case('A').string() + " > " + sparse.string()).c_str()) == 0);
  // Two sets of CP 6.5 h (the CP interval 5 min) and one invalid (CP 0.05 h); a plausible limit of 5 um
  // sets the same readings aside in every set.
  const fs::path grid = write("sparse.toml", "cp = [0.05, 6.5]\ninterval = [2, 6]\n[fixed]\nplausible-lin = 5\n");
  const auto r = run_alc("study --grid " + grid.string() + " " + sparse.string() + " --quiet", "study_cli");
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  const auto count = [&](const std::string& what) { return occurrences(r.err, what); };
  CHECK(count("is measured more sparsely than the schedule asks") == 1);
  CHECK_THAT(r.err, Catch::Contains("file " + sparse.string() + " is measured more sparsely") &&
                        Catch::Contains("in CP every 10 min (median) where the CP interval is 5 min") &&
                        Catch::Contains("; 2 of the 4 sets are concerned"));
  // Each text once (before: the same lines once per set), and the repeats counted.
  const std::string beyond = "is beyond the plausible";
  REQUIRE(count(beyond) > 0);
  std::set<std::string> lines;
  std::istringstream in(r.err);
  for (std::string line; std::getline(in, line);)
    if (line.find(beyond) != std::string::npos) CHECK(lines.insert(line.substr(line.find("] [") + 1)).second);
  CHECK_THAT(r.err, Catch::Contains(" log line(s) of the runs repeated an earlier one and were not shown"));
}

TEST_CASE("bad study arguments are usage errors naming the value") {
  const fs::path grid = write("bad.toml", "cp = [6.5]\nng-meas = [6, -2]\n");
  auto r = run_alc("study --grid " + grid.string() + " --case A", "study_cli");
  CHECK(r.exit_code == 2);
  CHECK_THAT(r.err, Catch::Contains(grid.string() + ":2:") && Catch::Contains("key 'ng-meas', value '-2'"));
  r = run_alc("study --grid paper --case A --shard 4/3", "study_cli");
  CHECK(r.exit_code == 2);
  CHECK_THAT(r.err, Catch::Contains("--shard: '4/3'"));
  r = run_alc("study --grid paper --case A --resume", "study_cli");
  CHECK(r.exit_code == 2);
  CHECK_THAT(r.err, Catch::Contains("--resume needs --db"));
  r = run_alc("study --grid nothere.toml --case A", "study_cli");
  CHECK(r.exit_code == 2);
  CHECK_THAT(r.err, Catch::Contains("nothere.toml"));
  r = run_alc("study --grid paper " + dir().string(), "study_cli");
  CHECK(r.exit_code == 2);
  CHECK_THAT(r.err, Catch::Contains("is a directory"));
  // The same file twice would be two cases of one name.
  const fs::path a = short_case('A');
  r = run_alc("study --grid paper " + a.string() + " " + a.string(), "study_cli");
  CHECK(r.exit_code == 2);
  CHECK_THAT(r.err, Catch::Contains(a.string() + ": given twice"));
  // Reached by a link or copied, it is still one recording (before: two cases, each row counted twice).
  const fs::path link = dir() / "a-link.csv", copy = dir() / "a-copy.csv";
  fs::remove(link);
  fs::create_symlink(a, link);
  fs::copy_file(a, copy, fs::copy_options::overwrite_existing);
  for (const fs::path& other : {link, copy}) {
    r = run_alc("study --grid paper " + a.string() + " " + other.string(), "study_cli");
    CHECK(r.exit_code == 2);
    CHECK_THAT(r.err, Catch::Contains(other.string() + ": the same recording as " + a.string() + " (content hash "));
  }
  // The benchmark's options without --bench were ignored without a word.
  r = run_alc("study --grid paper --case A --bench-seed 3", "study_cli");
  CHECK(r.exit_code == 2);
  CHECK_THAT(r.err, Catch::Contains("--bench-seed requires --bench"));
}

TEST_CASE("the study benchmark compares only the rows that ran, and counts the work saved on them") {
  // A CP longer than the recording is an error row; the benchmark replayed it anyway (a CP without end)
  // and failed 'shared rows differ', and counted its samples as work saved (50 % here, 0 without it).
  const fs::path with = write("bench-cp.toml", "cp = [6.5, 300]\ninterval = [2, 4]\n");
  const fs::path without = write("bench.toml", "cp = [6.5]\ninterval = [2, 4]\n");
  const auto saved = [](const std::string& out) {
    const auto at = out.find("work saved by sharing:");
    REQUIRE(at != std::string::npos);
    return out.substr(at, out.find('\n', at) - at);
  };
  auto r = run_alc("study --grid " + with.string() + " " + short_case('A').string() + " --bench --bench-sample 4 --jobs 1",
                   "study_cli");
  CHECK(r.exit_code == 0);
  CHECK_THAT(r.out, Catch::Contains("identical to the study's rows: 2 of 2"));
  const auto b = run_alc("study --grid " + without.string() + " " + short_case('A').string() +
                             " --bench --bench-sample 4 --jobs 1",
                         "study_cli");
  REQUIRE(b.exit_code == 0);
  CHECK(saved(r.out) == saved(b.out));
}

TEST_CASE("SIGINT stops a study cleanly: finished rows stay, --resume completes it") {
  const fs::path grid = write("long.toml", "cp = [6.5, 12]\ninterval = [1, 2, 3, 4, 6]\nng-meas = [6, 12]\n");
  const fs::path db = dir() / "stopped.sqlite";
  fs::remove(db);
  short_case('A');  // also simulates the whole of case A (8 days): long enough to interrupt
  const fs::path full = dir() / "full_A.csv";
  const std::string args = "study --grid " + grid.string() + " " + full.string() + " --jobs 1 --db " + db.string();
  // Built before fork: dir() names itself after the process id.
  const std::string cmd = std::string("exec \"") + ALC_CLI_PATH + "\" " + args + " >/dev/null 2>" +
                          (dir() / "stopped.err").string();
  const pid_t pid = fork();
  REQUIRE(pid >= 0);
  if (pid == 0) {
    execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  // Wait for the first finished unit in the file, then interrupt.
  const auto until = std::chrono::steady_clock::now() + std::chrono::minutes(5);
  while (std::chrono::steady_clock::now() < until) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    if (fs::exists(db) && std::system(("sqlite3 " + db.string() +
                                       " 'SELECT count(*) FROM study_rows' 2>/dev/null | grep -qv '^0$'")
                                          .c_str()) == 0)
      break;
  }
  kill(pid, SIGINT);
  int status = 0;
  REQUIRE(waitpid(pid, &status, 0) == pid);
  REQUIRE(WIFEXITED(status));
  const int code = WEXITSTATUS(status);
  const std::string err = slurp(dir() / "stopped.err");
  INFO("exit " << code << ": " << err);
  if (code == 0) {
    WARN("the study finished before SIGINT arrived; nothing to resume");
    return;
  }
  CHECK(code == 130);
  CHECK_THAT(err, Catch::Contains("study stopped by signal 2") && Catch::Contains("continue with --resume"));
  const int kept = std::stoi(sql(db, "SELECT count(*) FROM study_rows"));
  CHECK(kept > 0);
  CHECK(kept < 20);
  const fs::path resumed = dir() / "stopped.csv", whole = dir() / "unstopped.csv";
  const auto r = run_alc(args + " --resume --csv " + resumed.string(), "study_cli");
  REQUIRE(r.exit_code == 0);
  CHECK_THAT(r.err, Catch::Contains(std::to_string(kept) + " rows reused"));
  REQUIRE(run_alc("study --grid " + grid.string() + " " + full.string() + " --jobs 2 --quiet --csv " +
                      whole.string(),
                  "study_cli")
              .exit_code == 0);
  CHECK(slurp(resumed) == slurp(whole));
}

TEST_CASE("the study's CSV counts each row's input samples set aside, as alc replay does on the same file and value, and holds the fixed options") {
  // Case A's first 48 h: temperatures up to 23.9 degC, so a plausible limit of 23.5 sets some aside.
  const fs::path grid = write("plausible.toml", "plausible-temp = [1000, 23.5]\n[fixed]\nng-meas = 12\nacl-lin = 5\n");
  const fs::path csv = dir() / "plausible.csv";
  const auto r = run_alc("study --grid " + grid.string() + " " + short_case('A').string() + " --quiet --csv " + csv.string(),
                         "study_cli");
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  std::istringstream lines(slurp(csv));
  const auto cells = [](const std::string& line) {
    std::vector<std::string> out;
    std::istringstream f(line);
    for (std::string c; std::getline(f, c, ',');) out.push_back(c);
    return out;
  };
  std::string line;
  std::getline(lines, line);
  const auto header = cells(line);
  const auto col = [&](const std::string& name) {
    const auto it = std::find(header.begin(), header.end(), name);
    REQUIRE(it != header.end());
    return static_cast<std::size_t>(it - header.begin());
  };
  const std::size_t limit = col("plausible-temp"), rejected = col("rejected_samples"), status = col("status");
  // The fixed options after the axes, in name order (the grid keeps them so: a TOML table has no order).
  REQUIRE(header.size() > status);
  CHECK(std::vector<std::string>(header.begin() + 2, header.begin() + static_cast<std::ptrdiff_t>(status)) ==
        std::vector<std::string>{"plausible-temp", "acl-lin", "ng-meas"});
  std::map<std::string, std::string> per_limit;
  while (std::getline(lines, line)) {
    const auto c = cells(line);
    REQUIRE(c.size() > rejected);
    CHECK(c[status] == "ok");
    CHECK(c[col("ng-meas")] == "12");
    CHECK(c[col("acl-lin")] == "5");
    per_limit[c[limit]] = c[rejected];
  }
  REQUIRE(per_limit.size() == 2);
  CHECK(per_limit["1000"] == "0");
  const auto replay = run_alc("replay " + short_case('A').string() + " --plausible-temp 23.5 --json", "study_cli");
  REQUIRE(replay.exit_code == 0);
  const auto set_aside = nlohmann::json::parse(replay.out).at("rejected_samples").get<std::int64_t>();
  CHECK(set_aside > 0);
  CHECK(per_limit["23.5"] == std::to_string(set_aside));
}
