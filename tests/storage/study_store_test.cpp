// The study file's store: a study begun by another process after our look is judged under the write
// lock, and the empty file of a study killed before its first commit holds nothing.
#include <catch2/catch.hpp>

#include <tuple>

#include "storage/history_tools.hpp"
#include "storage/storage_error.hpp"
#include "storage/study_store.hpp"
#include "storage_test_support.hpp"

using namespace alc::storage;

namespace {
StudyHeader header(const std::string& grid, const std::string& shard = "all") {
  StudyHeader h;
  h.grid_json = grid;
  h.cases_json = R"([{"name":"A","source":"built-in A","content_hash":"0"}])";
  h.software_version = "alc test";
  h.shard = shard;
  h.set_count = 2;
  return h;
}
}  // namespace

TEST_CASE("study store: a study another process began after our look is refused, not mixed with ours") {
  const test::ScratchDir dir;
  const auto file = dir / "study.sqlite";
  // Both looked (header_of: none), then the other one began first.
  REQUIRE_FALSE(StudyStore::header_of(file));
  { const StudyStore other(file, header(R"({"acl-ang":[16]})", "2/2"), StudyStore::Existing::Refuse); }
  CHECK_THROWS_WITH(StudyStore(file, header(R"({"acl-ang":[15]})", "1/2"), StudyStore::Existing::Refuse),
                    Catch::Contains("another process began a study in this file meanwhile"));
  // Continuing needs the very same study.
  CHECK_THROWS_WITH(StudyStore(file, header(R"({"acl-ang":[15]})", "2/2"), StudyStore::Existing::Continue),
                    Catch::Contains("holds another study"));
  const StudyStore same(file, header(R"({"acl-ang":[16]})", "2/2"), StudyStore::Existing::Continue);
  CHECK(StudyStore::header_of(file)->grid_json == R"({"acl-ang":[16]})");
}

TEST_CASE("study store: two processes continuing one study at once: the second to write a row is told so") {
  const test::ScratchDir dir;
  const auto file = dir / "study.sqlite";
  { const StudyStore begun(file, header(R"({"cp":[6.5]})"), StudyStore::Existing::Refuse); }
  // Both continue and find no row done; the first writes row (0, 0), then the second tries it too.
  StudyStore first(file, header(R"({"cp":[6.5]})"), StudyStore::Existing::Continue);
  StudyStore second(file, header(R"({"cp":[6.5]})"), StudyStore::Existing::Continue);
  REQUIRE(first.done().empty());
  REQUIRE(second.done().empty());
  StudyRowRecord row;
  row.set_index = 0;
  row.case_index = 0;
  row.ok = false;
  row.error = "x";
  first.add({row});
  // Before: "running 'INSERT INTO study_rows (...': record rejected (UNIQUE constraint failed ...)".
  try {
    second.add({row});
    FAIL("the second write of the row was taken");
  } catch (const StorageError& e) {
    CHECK(e.kind == StorageErrorKind::Locked);
    CHECK_THAT(e.what(), Catch::Contains("the row of set 0, case 0 was written by another process meanwhile") &&
                             Catch::Contains("two studies write this file at once"));
  }
  CHECK(first.done().size() == 1);
}

TEST_CASE("study store: the empty file of a study killed before its first commit holds nothing, a study begins there") {
  const test::ScratchDir dir;
  const auto zero = dir / "zero.sqlite", bare = dir / "bare.sqlite", other = dir / "other.sqlite";
  test::write_bytes(zero, "");
  {
    test::RawDb raw(bare);  // SQLite's header, no table: what a kill between open and schema leaves
    REQUIRE(raw.exec("CREATE TABLE t (x); DROP TABLE t;") == SQLITE_OK);
  }
  {
    test::RawDb raw(other);  // another program's database is not "nothing"
    REQUIRE(raw.exec("CREATE TABLE t (x);") == SQLITE_OK);
  }
  for (const auto& f : {zero, bare}) {
    INFO(f);
    CHECK(StudyStore::holds_nothing(f));
    CHECK_FALSE(StudyStore::header_of(f));
    CHECK(StudyStore::rows_of(f).empty());
    const StudyStore store(f, header("{}"), StudyStore::Existing::Refuse);
    CHECK(StudyStore::header_of(f));
  }
  CHECK_FALSE(StudyStore::holds_nothing(other));
  CHECK_THROWS_AS(StudyStore::header_of(other), StorageError);
  CHECK_FALSE(StudyStore::holds_nothing(dir / "missing.sqlite"));
}

TEST_CASE("study store: a damaged row or header is named with its place, and db check lists it") {
  const test::ScratchDir dir;
  const auto file = dir / "study.sqlite";
  {
    StudyStore store(file, header(R"({"cp":[6.5,12]})"), StudyStore::Existing::Refuse);
    StudyRowRecord ok;
    ok.set_index = 0;
    ok.case_index = 0;
    ok.ok = true;
    ok.report_json = R"({"outputs":{},"M":3})";
    StudyRowRecord damaged = ok;
    damaged.set_index = 1;
    damaged.report_json = R"({"outputs":5})";  // what an editor left: before, "key 'M' not found" from nlohmann
    store.add({ok, damaged});
  }
  CHECK_THROWS_WITH(StudyStore::rows_of(file), Catch::Contains("study_rows: set 1, case 0: report_json has no \"outputs\" object") &&
                                                   Catch::Contains(file.string()));
  CheckReport report = check_history(file);
  REQUIRE(report.problems.size() == 1);
  CHECK(report.problems[0] == "study_rows: set 1, case 0: report_json has no \"outputs\" object");
  test::RawDb(file).exec("UPDATE studies SET grid_json = '{'");
  CHECK_THROWS_WITH(StudyStore::header_of(file), Catch::Contains("studies: grid_json does not parse as JSON"));
  report = check_history(file);
  CHECK(report.problems.size() == 2);
  CHECK(report_json_problem(R"({"outputs":{},"M":3})").empty());
  CHECK(report_json_problem("garbage") == "does not parse as JSON");
  CHECK(report_json_problem(R"({"outputs":{}})") == "has no whole number \"M\"");
}

TEST_CASE("study store: a row whose set or case the study does not have is named, not indexed past the grid") {
  // Before: 'alc report' and 'alc study report' crashed (SIGSEGV) on a row of set 999 of a 10-set study,
  // threw std::bad_alloc on set -1, and 'alc db check' said ok.
  const test::ScratchDir dir;
  const auto file = dir / "study.sqlite";
  {
    StudyStore store(file, header(R"({"cp":[6.5,12]})"), StudyStore::Existing::Refuse);
    StudyRowRecord row;
    row.ok = false;
    row.error = "x";
    store.add({row});
  }
  REQUIRE(StudyStore::rows_of(file).size() == 1);
  REQUIRE(check_history(file).ok());
  for (const auto& [update, row, why] :
       {std::tuple{"set_index = 999", "set 999, case 0", "set_index 999 is not one of the study's 2 parameter sets (0 to 1)"},
        std::tuple{"set_index = -1", "set -1, case 0", "set_index -1 is not one of the study's 2 parameter sets (0 to 1)"},
        std::tuple{"case_index = 5", "set 0, case 5", "case_index 5 is not one of the study's 1 cases (0 to 0)"}}) {
    INFO(update);
    const auto copy = dir / "damaged.sqlite";
    std::filesystem::copy_file(file, copy, std::filesystem::copy_options::overwrite_existing);
    REQUIRE(test::RawDb(copy).exec(std::string("UPDATE study_rows SET ") + update) == SQLITE_OK);
    CHECK_THROWS_WITH(StudyStore::rows_of(copy), Catch::Contains(copy.string()) &&
                                                     Catch::Contains(std::string("study_rows: ") + row + ": " + why));
    const CheckReport report = check_history(copy);
    REQUIRE(report.problems.size() == 1);
    CHECK(report.problems[0] == std::string("study_rows: ") + row + ": " + why);
  }
  // The header's cases and set count bound the rows: they are judged too.
  REQUIRE(test::RawDb(file).exec("UPDATE studies SET cases_json = '[]'") == SQLITE_OK);
  CHECK_THROWS_WITH(StudyStore::header_of(file), Catch::Contains("studies: cases_json is not a non-empty JSON array"));
  CHECK(check_history(file).problems == std::vector<std::string>{"studies: study 1: cases_json is not a non-empty JSON array"});
  REQUIRE(test::RawDb(file).exec(R"(UPDATE studies SET cases_json = '[{"name":"A"}]', set_count = 0)") == SQLITE_OK);
  CHECK_THROWS_WITH(StudyStore::header_of(file), Catch::Contains("studies: cases_json case 0 has no string \"source\""));
  const CheckReport report = check_history(file);
  CHECK(report.problems == std::vector<std::string>{"studies: study 1: cases_json case 0 has no string \"source\"",
                                                    "studies: study 1: set_count 0 is below 1"});
  CHECK(study_row_problem(1, 0, 2, 1).empty());
}
