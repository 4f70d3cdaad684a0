// Hostile and damaged files: each refused with an error naming the file and the cause, and no
// existing file modified. Migration of version-1 and version-2 databases to the current schema.
#include <sys/mount.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <catch2/catch.hpp>

#include <memory>
#include <cstdio>
#include <sstream>

#include "storage/history_reader.hpp"
#include "storage/history_tools.hpp"
#include "storage/schema.hpp"
#include "storage/storage_error.hpp"
#include "storage_test_support.hpp"

using namespace alc::storage;
using alc::storage::test::RawDb;
using alc::storage::test::ScratchDir;

namespace {

// Runs `open` and returns the StorageError it throws (fails the test if it does not throw one).
template <class F>
StorageError error_of(F&& open) {
  try {
    open();
  } catch (const StorageError& e) {
    return e;
  }
  FAIL("no StorageError thrown");
  throw;
}

// The file must be byte for byte what it was, and no WAL/SHM created beside it.
void check_untouched(const std::filesystem::path& file, const std::string& before) {
  CHECK(test::read_bytes(file) == before);
  CHECK_FALSE(std::filesystem::exists(file.string() + "-wal"));
  CHECK_FALSE(std::filesystem::exists(file.string() + "-shm"));
}

void check_refused(const std::filesystem::path& file, StorageErrorKind kind, const std::string& cause) {
  const std::string before = test::read_bytes(file);
  for (int which = 0; which < 3; ++which) {
    const StorageError e = error_of([&] {
      if (which == 0) HistoryWriter writer(file);
      if (which == 1) HistoryReader reader(file);
      if (which == 2) (void)check_history(file);
    });
    INFO(e.what());
    CHECK(e.kind == kind);
    CHECK_THAT(e.what(), Catch::Contains(file.string()) && Catch::Contains(cause));
    check_untouched(file, before);
  }
}

std::filesystem::path filled_history(const ScratchDir& dir, const std::string& name, int samples) {
  const auto file = dir / name;
  HistoryWriter writer(file);
  const RunId id = writer.begin_run(test::small_run());
  for (int k = 0; k < samples; ++k) writer.add(test::sample_at(id, k));
  writer.end_run(id, RunStatus::Finished);
  return file;  // closed: WAL checkpointed into the file and removed
}

// Overwrites one leaf page of input_samples that is not on the path of an append (the leftmost
// child of the table's root page) with garbage; returns its page number. The header page and the
// schema stay intact, so the damage is found only by reading that page.
std::uint32_t damage_a_leaf_page(const std::filesystem::path& file) {
  long long root = 0;
  {
    RawDb raw(file);
    root = raw.scalar("SELECT rootpage FROM sqlite_schema WHERE name = 'input_samples'");
  }
  std::string bytes = test::read_bytes(file);
  const auto u8 = [&](std::size_t at) { return static_cast<unsigned char>(bytes.at(at)); };
  std::size_t page_size = (std::size_t{u8(16)} << 8) | u8(17);
  if (page_size == 1) page_size = 65536;
  REQUIRE(root > 1);
  const std::size_t page = static_cast<std::size_t>(root - 1) * page_size;
  REQUIRE((u8(page) == 0x02 || u8(page) == 0x05));  // an interior page: the table spans several leaves
  const std::size_t cell = (std::size_t{u8(page + 12)} << 8) | u8(page + 13);  // first cell pointer
  const std::uint32_t leaf = (std::uint32_t{u8(page + cell)} << 24) | (std::uint32_t{u8(page + cell + 1)} << 16) |
                             (std::uint32_t{u8(page + cell + 2)} << 8) | u8(page + cell + 3);
  REQUIRE(leaf > 1);
  REQUIRE(std::size_t{leaf} * page_size <= bytes.size());
  std::fill_n(bytes.begin() + static_cast<std::ptrdiff_t>((leaf - 1) * page_size), page_size, '\xA5');
  test::write_bytes(file, bytes);
  return leaf;
}

// Root ignores file permissions: runs `attempt` in a child process, as `nobody` when this process is
// root, and returns the child's exit code (`attempt`'s result: 0 when all it checked held, else bits
// naming what failed; 10: could not become nobody; 99: an unexpected exception).
template <class F>
int exit_code_as_nobody(F&& attempt) {
  const pid_t child = fork();
  REQUIRE(child >= 0);
  if (child == 0) {
    if (geteuid() == 0 && (setgid(65534) != 0 || setuid(65534) != 0)) _exit(10);
    int code = 99;
    try {
      code = attempt();
    } catch (const std::exception& e) {
      std::fprintf(stderr, "as nobody: %s\n", e.what());
    }
    _exit(code);
  }
  int status = 0;
  waitpid(child, &status, 0);
  REQUIRE(WIFEXITED(status));
  return WEXITSTATUS(status);
}

// Builds exactly what ALC of schema `version` created (migration_sql(1..version), its
// application_id and user_version), then runs `rows` (INSERTs in that version's form).
void old_history(const std::filesystem::path& file, int version, const std::string& rows) {
  RawDb raw(file);
  for (int v = 1; v <= version; ++v) REQUIRE(raw.exec(std::string(migration_sql(v))) == SQLITE_OK);
  REQUIRE(raw.exec("PRAGMA application_id = " + std::to_string(kApplicationId) +
                   "; PRAGMA user_version = " + std::to_string(version) + ";") == SQLITE_OK);
  REQUIRE(raw.exec(rows) == SQLITE_OK);
}

}  // namespace

TEST_CASE("a file that is not a database is refused and left untouched", "[storage]") {
  ScratchDir dir;
  const auto file = dir / "notes.txt";
  std::string text;
  for (int i = 0; i < 200; ++i) text += "time_s,T_ENV\n0,20\n";
  test::write_bytes(file, text);
  check_refused(file, StorageErrorKind::NotADatabase, "not an SQLite database");
}

TEST_CASE("a database of another program is refused and left untouched", "[storage]") {
  ScratchDir dir;
  SECTION("different application_id") {
    const auto file = dir / "other.db";
    {
      RawDb raw(file);
      raw.exec("PRAGMA application_id = 1234; CREATE TABLE runs (x); INSERT INTO runs VALUES (1);");
    }
    check_refused(file, StorageErrorKind::ForeignDatabase, "application_id 0x000004D2");
  }
  SECTION("no application_id but foreign tables") {
    const auto file = dir / "customers.db";
    {
      RawDb raw(file);
      raw.exec("CREATE TABLE customers (name TEXT); INSERT INTO customers VALUES ('x');");
    }
    check_refused(file, StorageErrorKind::ForeignDatabase, "holds customers");
  }
}

TEST_CASE("a newer schema version is refused", "[storage]") {
  ScratchDir dir;
  const auto file = filled_history(dir, "newer.sqlite", 5);
  {
    RawDb raw(file);
    raw.exec("PRAGMA journal_mode = DELETE; PRAGMA user_version = 99;");
  }
  check_refused(file, StorageErrorKind::NewerSchema, "schema version 99 is newer than this alc");
}

TEST_CASE("a truncated or corrupted file is refused or reported", "[storage]") {
  ScratchDir dir;
  const auto file = filled_history(dir, "truncated.sqlite", 3000);
  const std::string full = test::read_bytes(file);
  REQUIRE(full.size() > 16 * 4096);
  SECTION("cut at half its pages") {
    test::write_bytes(file, full.substr(0, full.size() / 2 / 4096 * 4096));
    check_refused(file, StorageErrorKind::Corrupt, "truncated");
  }
  SECTION("cut inside a page") {
    test::write_bytes(file, full.substr(0, full.size() - 1000));
    check_refused(file, StorageErrorKind::Corrupt, "not a whole number");
  }
  SECTION("cut inside the header") {
    test::write_bytes(file, full.substr(0, 50));
    check_refused(file, StorageErrorKind::Corrupt, "shorter than the 100-byte SQLite header");
  }
  SECTION("pages overwritten with garbage") {
    std::string damaged = full;
    for (std::size_t i = 4096; i < damaged.size(); i += 7) damaged[i] = static_cast<char>(i * 31);
    test::write_bytes(file, damaged);
    try {
      const CheckReport report = check_history(file);
      CHECK_FALSE(report.ok());
    } catch (const StorageError& e) {
      CHECK(e.kind == StorageErrorKind::Corrupt);
      CHECK_THAT(e.what(), Catch::Contains(file.string()));
    }
  }
}

TEST_CASE("db check finds rows edited behind the writer's back that a resume or the report would trip on", "[storage]") {
  ScratchDir dir;
  const auto file = dir / "edited.sqlite";
  {
    HistoryWriter writer(file);
    const RunId id = writer.begin_run(test::small_run());
    for (int k = 0; k < 40; ++k) {
      if (k == 20) continue;  // a sample the controller rejected: an index without a row, no damage
      const InputSampleRecord sample = test::sample_at(id, k);
      writer.add(sample);
      writer.add(PredictionRecord{id, sample.time_s, {0.0, 0.0}, {0.0, 0.0}});
    }
    writer.save_snapshot({id, test::sample_at(id, 35).time_s, 36, "test/1", true, "{}"});
    writer.add(ProbeMeasurementRecord{id, 600.0, "CP", {1.5, 0.5}, {0.0, 0.0}, 1.0});
    writer.add(ProbeMeasurementRecord{id, 900.0, "CP", {1.5, 0.5}, {0.0, 0.0}, 1.0});
    writer.end_run(id, RunStatus::Finished);
  }
  REQUIRE(check_history(file).ok());
  {
    RawDb raw(file);
    // Before, each of these was "ok" (the first makes --resume refuse: fewer samples than predictions).
    raw.exec("DELETE FROM input_samples WHERE sample_index BETWEEN 10 AND 12;"
             "UPDATE probe_measurements SET phase = 'XX' WHERE time_s = 600;"
             "UPDATE probe_measurements SET weight = -5 WHERE time_s = 900;"
             "UPDATE runs SET ended_unix_s = started_unix_s - 10;");
  }
  const CheckReport report = check_history(file);
  std::string all;
  for (const std::string& p : report.problems) all += p + "\n";
  INFO(all);
  CHECK_THAT(all, Catch::Contains("input_samples: samples and predictions up to the latest snapshot differ in number "
                                  "(run, snapshot time_s, samples, predictions): 1 2100.0 32 35"));
  CHECK_THAT(all, Catch::Contains("a phase other than CP, Post-CP, NG or a weight below 0") && Catch::Contains(" XX ") &&
                      Catch::Contains(" -5"));
  CHECK_THAT(all, Catch::Contains("runs: ended before it started"));
  // Samples pruned from the start (keep_days) go with their predictions; rows after the snapshot are not
  // judged (a kill may part them there).
  {
    RawDb raw(file);
    raw.exec("DELETE FROM predictions WHERE time_s BETWEEN 600 AND 720; DELETE FROM input_samples WHERE time_s < 300;"
             "DELETE FROM predictions WHERE time_s < 300; DELETE FROM predictions WHERE time_s > 2100;");
  }
  std::string after;
  for (const std::string& p : check_history(file).problems) after += p + "\n";
  CHECK_THAT(after, !Catch::Contains("samples and predictions"));
}

TEST_CASE("a vector blob of the wrong length is refused naming the table - the row - the length, not read as fewer "
          "values",
          "[storage]") {
  // sqlite3 h.db "update input_samples set values_f64=X'0102' where time_s=30600": the reader took the
  // 2 bytes as no values (trailing bytes ignored), the report used zero inputs for that sample and its
  // P99 baseline moved from 7.53 to 32.41 um, exit 0.
  ScratchDir dir;
  const auto file = dir / "blobs.sqlite";
  {
    HistoryWriter writer(file);
    const RunId id = writer.begin_run(test::small_run());  // 3 inputs, 2 outputs, 2 offsets
    for (int k = 0; k < 10; ++k) writer.add(test::sample_at(id, k));
    writer.add(ProbeMeasurementRecord{id, 300.0, "CP", {1.5, 0.5}, {0.0, 0.0}, 1.0});
    writer.add(PredictionRecord{id, 300.0, {1.0, 2.0}, {-1.0, -2.0}});
    writer.end_run(id, RunStatus::Finished);
  }
  {
    const HistoryReader reader(file);
    REQUIRE(reader.input_samples(1).size() == 10);
    REQUIRE(reader.probe_measurements(1).size() == 1);
    REQUIRE(reader.predictions(1).size() == 1);
  }
  struct Damage {
    std::string sql, read, restore;
    std::vector<std::string> message;
  };
  const std::vector<Damage> damages = {
      {"UPDATE input_samples SET values_f64 = X'0102' WHERE time_s = 300", "input_samples",
       "UPDATE input_samples SET values_f64 = (SELECT values_f64 FROM input_samples WHERE sample_index = 4) "
       "WHERE sample_index = 5",
       {"input_samples: run 1, sample 5 (time_s 300): values_f64 holds 2 bytes, not 24 (the run's 3 inputs"}},
      // Whole values, one short: as wrong.
      {"UPDATE input_samples SET values_f64 = substr(values_f64, 1, 16) WHERE sample_index = 7", "input_samples",
       "UPDATE input_samples SET values_f64 = (SELECT values_f64 FROM input_samples WHERE sample_index = 6) "
       "WHERE sample_index = 7",
       {"sample 7 (time_s 420): values_f64 holds 16 bytes, not 24"}},
      {"UPDATE probe_measurements SET measured_f64 = X'00' WHERE time_s = 300", "probe_measurements",
       "UPDATE probe_measurements SET measured_f64 = compensation_f64",
       {"probe_measurements: run 1, probe_id 1 (time_s 300): measured_f64 holds 1 byte, not 16 (the run's 2 outputs"}},
      {"UPDATE probe_measurements SET compensation_f64 = X''", "probe_measurements",
       "UPDATE probe_measurements SET compensation_f64 = measured_f64",
       {"compensation_f64 holds 0 bytes, not 16"}},
      {"UPDATE predictions SET predicted_f64 = zeroblob(26)", "predictions",
       "UPDATE predictions SET predicted_f64 = zeroblob(16)",
       {"predictions: run 1, prediction_id 1 (time_s 300): predicted_f64 holds 26 bytes, not 16"}},
      {"UPDATE predictions SET offsets_f64 = X'0000000000000000'", "predictions",
       "UPDATE predictions SET offsets_f64 = predicted_f64",
       {"offsets_f64 holds 8 bytes, not 16 (the run's 2 offsets, 8 bytes each)"}},
  };
  for (const Damage& damage : damages) {
    INFO(damage.sql);
    REQUIRE(RawDb(file).exec(damage.sql) == SQLITE_OK);
    const HistoryReader reader(file);
    const StorageError e = error_of([&] {
      if (damage.read == "input_samples") (void)reader.input_samples(1);
      else if (damage.read == "probe_measurements") (void)reader.probe_measurements(1);
      else (void)reader.predictions(1);
    });
    INFO(e.what());
    CHECK(e.kind == StorageErrorKind::Corrupt);
    CHECK_THAT(e.what(), Catch::Contains(file.string()));
    for (const std::string& part : damage.message) CHECK_THAT(e.what(), Catch::Contains(part));
    // alc db export refuses the row too, naming it.
    std::ostringstream csv;
    const StorageError exported = error_of([&] { export_table_csv(file, damage.read, csv); });
    INFO(exported.what());
    CHECK(exported.kind == StorageErrorKind::Corrupt);
    // In the reader's words, by the row's id that its CSV row shows (before: "input_samples: row 6 (run 1, …").
    for (const std::string& part : damage.message) CHECK_THAT(exported.what(), Catch::Contains(part));
    CHECK_FALSE(check_history(file).ok());  // db check lists it (it did before)
    REQUIRE(RawDb(file).exec(damage.restore) == SQLITE_OK);
    CHECK(check_history(file).ok());
  }
}

TEST_CASE("a writer refuses a file with a damaged page before it changes anything", "[storage]") {
  ScratchDir dir;
  const auto file = filled_history(dir, "damaged.sqlite", 3000);
  const std::uint32_t leaf = damage_a_leaf_page(file);
  INFO("damaged page " << leaf);
  const std::string before = test::read_bytes(file);
  const StorageError e = error_of([&] {
    HistoryWriter writer(file);
    const RunId id = writer.begin_run(test::small_run());
    writer.add(test::sample_at(id, 0));
    writer.commit();
  });
  INFO(e.what());
  CHECK(e.kind == StorageErrorKind::Corrupt);
  CHECK_THAT(e.what(), Catch::Contains(file.string()) && Catch::Contains("quick_check"));
  check_untouched(file, before);
}

TEST_CASE("alc db check reports the integrity problems of a damaged page", "[storage]") {
  ScratchDir dir;
  const auto file = filled_history(dir, "damaged.sqlite", 3000);
  damage_a_leaf_page(file);
  const std::string before = test::read_bytes(file);
  const CheckReport report = check_history(file);  // does not throw: the damage is the report
  CHECK_FALSE(report.ok());
  const auto integrity = std::count_if(report.problems.begin(), report.problems.end(), [](const std::string& p) {
    return p.rfind("integrity_check: ", 0) == 0;
  });
  CHECK(integrity > 0);
  CHECK(test::read_bytes(file) == before);  // a reader leaves SQLite's empty -wal/-shm of a WAL file
}

TEST_CASE("a file with ALC's application_id but without ALC's tables is refused untouched", "[storage]") {
  ScratchDir dir;
  SECTION("no tables") {
    const auto file = dir / "ids-only.sqlite";
    {
      RawDb raw(file);
      raw.exec("PRAGMA application_id = " + std::to_string(kApplicationId) + "; PRAGMA user_version = 2;");
    }
    check_refused(file, StorageErrorKind::Corrupt, "the table(s) runs, run_channels");
  }
  SECTION("a view where a table belongs, and a version-2 table missing") {
    const auto file = dir / "impostor.sqlite";
    {
      RawDb raw(file);
      REQUIRE(raw.exec(std::string(migration_sql(1))) == SQLITE_OK);
      REQUIRE(raw.exec("DROP TABLE runs; CREATE VIEW runs AS SELECT 1 AS run_id;"
                       "PRAGMA application_id = " + std::to_string(kApplicationId) + "; PRAGMA user_version = 2;") ==
              SQLITE_OK);
    }
    check_refused(file, StorageErrorKind::Corrupt, "the table(s) runs, nc_commands are missing");
  }
  SECTION("version 3 claimed, but the columns that migration 3 adds are missing") {
    const auto file = dir / "v3-without-columns.sqlite";
    {
      RawDb raw(file);
      REQUIRE(raw.exec(std::string(migration_sql(1)) + std::string(migration_sql(2)) +
                       "PRAGMA application_id = " + std::to_string(kApplicationId) + "; PRAGMA user_version = 3;") ==
              SQLITE_OK);
    }
    check_refused(file, StorageErrorKind::Corrupt,
                  "the column(s) nc_commands.delivered, nc_commands.delivery_message are missing");
  }
}

// As check_refused, for a file in WAL mode: SQLite's first read of it creates empty -wal/-shm files
// (docs/storage.md), so only the database's own bytes are compared.
void check_refused_wal(const std::filesystem::path& file, StorageErrorKind kind, const std::string& cause) {
  const std::string before = test::read_bytes(file);
  for (int which = 0; which < 3; ++which) {
    const StorageError e = error_of([&] {
      if (which == 0) HistoryWriter writer(file);
      if (which == 1) HistoryReader reader(file);
      if (which == 2) (void)check_history(file);
    });
    INFO(e.what());
    CHECK(e.kind == kind);
    CHECK_THAT(e.what(), Catch::Contains(file.string()) && Catch::Contains(cause));
    CHECK(test::read_bytes(file) == before);
  }
}

TEST_CASE("a history with triggers or views (hostile SQL on our writes) is refused untouched", "[storage]") {
  ScratchDir dir;
  SECTION("a trigger that deletes what we write (plain SQL: trusted_schema alone would not stop it)") {
    const auto file = filled_history(dir, "hostile_delete.sqlite", 5);
    REQUIRE(RawDb(file).exec("CREATE TRIGGER wipe AFTER INSERT ON input_samples BEGIN DELETE FROM input_samples; END;") ==
            SQLITE_OK);
    check_refused_wal(file, StorageErrorKind::ForeignDatabase, "trigger 'wipe'");
  }
  SECTION("a trigger that reads a virtual table") {
    const auto file = filled_history(dir, "hostile_spy.sqlite", 5);
    REQUIRE(RawDb(file).exec("CREATE TABLE spy (name TEXT); CREATE TRIGGER spy_on_runs AFTER INSERT ON runs "
                             "BEGIN INSERT INTO spy SELECT name FROM pragma_table_list; END;") == SQLITE_OK);
    check_refused_wal(file, StorageErrorKind::ForeignDatabase, "trigger 'spy_on_runs'");
    CHECK(RawDb(file).scalar("SELECT COUNT(*) FROM spy") == 0);
  }
  SECTION("a view") {
    const auto file = filled_history(dir, "hostile_view.sqlite", 5);
    REQUIRE(RawDb(file).exec("CREATE VIEW tables_seen AS SELECT name FROM pragma_table_list;") == SQLITE_OK);
    check_refused_wal(file, StorageErrorKind::ForeignDatabase, "view 'tables_seen'");
  }
}

TEST_CASE("a locked database gives a locked error after the busy timeout", "[storage]") {
  ScratchDir dir;
  const auto file = filled_history(dir, "locked.sqlite", 5);
  RawDb other(file);
  REQUIRE(other.exec("PRAGMA journal_mode = WAL; BEGIN IMMEDIATE; INSERT INTO runs (source, config_json, "
                     "software_version, started_unix_s, status) VALUES ('x', '{}', 'x', 0, 'running');") == SQLITE_OK);
  WriterOptions options;
  options.busy_timeout_ms = 100;
  const StorageError e = error_of([&] { HistoryWriter writer(file, options); });
  CHECK(e.kind == StorageErrorKind::Locked);
  CHECK_THAT(e.what(), Catch::Contains(file.string()) && Catch::Contains("busy timeout of 100 ms"));
  // A reader is not blocked by a writer (WAL).
  CHECK(HistoryReader(file).runs().size() == 1);
  other.exec("ROLLBACK");
  CHECK_NOTHROW(HistoryWriter(file, options));
}

TEST_CASE("a second writer on an open history waits for the first to close, then fails with Locked", "[storage]") {
  // SQLite's write lock lasts one transaction; a supervisor commits every sample, so before, a second
  // alc supervise on the same history opened it between two commits and both wrote (samples were lost).
  ScratchDir dir;
  const auto file = filled_history(dir, "claimed.sqlite", 5);
  WriterOptions options;
  options.busy_timeout_ms = 100;
  auto first = std::make_unique<HistoryWriter>(file, options);
  first->commit();  // no transaction open: SQLite's lock is free, the claim is not
  const StorageError e = error_of([&] { HistoryWriter second(file, options); });
  CHECK(e.kind == StorageErrorKind::Locked);
  CHECK_THAT(e.what(), Catch::Contains(file.string()) && Catch::Contains("another writer has this history open") &&
                           Catch::Contains("busy timeout of 100 ms"));
  CHECK(HistoryReader(file).runs().size() == 1);  // readers are not kept out
  // With a transaction open, as a supervisor mostly has (records added since its last commit): the same
  // words (before: SQLite's "locked by another connection", whose lock answered before the claim).
  first->add(test::sample_at(1, 100));
  REQUIRE(first->pending() > 0);
  const StorageError busy = error_of([&] { HistoryWriter second(file, options); });
  CHECK(busy.kind == StorageErrorKind::Locked);
  CHECK_THAT(busy.what(), Catch::Contains("another writer has this history open"));
  first->commit();
  first->close();                                 // released with the database
  CHECK_NOTHROW(HistoryWriter(file, options));
  first.reset();
  CHECK_NOTHROW(HistoryWriter(file, options));
}

TEST_CASE("a read-only directory gives a read-only error (to a writer, for a new or an existing file)", "[storage]") {
  ScratchDir dir;
  const auto locked_dir = dir.path / "ro";
  std::filesystem::create_directories(locked_dir);
  const auto existing = filled_history(dir, "ro/existing.sqlite", 5);
  std::filesystem::permissions(locked_dir, std::filesystem::perms::owner_read | std::filesystem::perms::owner_exec |
                                               std::filesystem::perms::group_read | std::filesystem::perms::group_exec |
                                               std::filesystem::perms::others_read | std::filesystem::perms::others_exec);
  const std::string before = test::read_bytes(existing);
  CHECK(exit_code_as_nobody([&] {
          int code = 0;
          try {
            HistoryWriter writer(locked_dir / "new.sqlite");
            code |= 1;
          } catch (const StorageError& e) {
            if (e.kind != StorageErrorKind::ReadOnly || std::string(e.what()).find("new.sqlite") == std::string::npos)
              code |= 2;
          }
          try {
            HistoryWriter writer(existing);
            code |= 4;
          } catch (const StorageError& e) {
            if (e.kind != StorageErrorKind::ReadOnly || std::string(e.what()).find("not writable") == std::string::npos)
              code |= 8;
          }
          return code;
        }) == 0);
  CHECK_FALSE(std::filesystem::exists(locked_dir / "new.sqlite"));
  CHECK(test::read_bytes(existing) == before);
}

TEST_CASE("a read-only file in a writable directory is refused by the writer naming the file, and left untouched", "[storage]") {
  ScratchDir dir;
  const auto open_dir = dir.path / "rw";
  std::filesystem::create_directories(open_dir);
  std::filesystem::permissions(open_dir, std::filesystem::perms::all);  // writable by anyone, `nobody` too
  const auto file = filled_history(dir, "rw/readonly.sqlite", 5);
  std::filesystem::permissions(file, std::filesystem::perms::owner_read | std::filesystem::perms::group_read |
                                         std::filesystem::perms::others_read);  // 0444
  const std::string before = test::read_bytes(file);
  CHECK(exit_code_as_nobody([&] {
          if (::access(file.c_str(), W_OK) == 0) return 11;      // the file must really be read-only here
          if (::access(open_dir.c_str(), W_OK) != 0) return 12;  // and its directory writable
          int code = 0;
          try {
            HistoryWriter writer(file);
            writer.begin_run(test::small_run());
            code |= 1;
          } catch (const StorageError& e) {
            if (e.kind != StorageErrorKind::ReadOnly) code |= 2;
            if (std::string(e.what()).find("'" + file.string() + "'") == std::string::npos) code |= 4;
            if (std::string(e.what()).find("the file is read-only") == std::string::npos) code |= 8;
            if (code != 0) std::fprintf(stderr, "writer: %s\n", e.what());
          }
          return code;
        }) == 0);
  check_untouched(file, before);  // bytes unchanged, no -wal/-shm left beside it
  // And for root (the tests' own user on CI), whom access() lets write: no write bit, no writer.
  // Before, root's replay grew a 0444 history.
  if (::geteuid() == 0) {
    const StorageError e = error_of([&] { HistoryWriter writer(file); });
    CHECK(e.kind == StorageErrorKind::ReadOnly);
    CHECK_THAT(e.what(), Catch::Contains("the file is read-only"));
    check_untouched(file, before);
  }
  // It is still a history that can be read (a reader needs no write permission on the file).
  CHECK(HistoryReader(file).input_samples(1).size() == 5);
}

TEST_CASE("a reader opens a history in a directory it cannot write to (immutable, no -shm)", "[storage]") {
  ScratchDir dir;
  const auto locked_dir = dir.path / "ro";
  std::filesystem::create_directories(locked_dir);
  const auto existing = filled_history(dir, "ro/existing.sqlite", 5);
  // A -wal beside the file (a writer running or killed): immutable would miss its records.
  const auto with_wal = filled_history(dir, "ro/with-wal.sqlite", 5);
  test::write_bytes(with_wal.string() + "-wal", "");
  std::filesystem::permissions(locked_dir, std::filesystem::perms::owner_read | std::filesystem::perms::owner_exec |
                                               std::filesystem::perms::group_read | std::filesystem::perms::group_exec |
                                               std::filesystem::perms::others_read | std::filesystem::perms::others_exec);
  const std::string before = test::read_bytes(existing);
  // Read as `nobody` (what info, check, export do).
  CHECK(exit_code_as_nobody([&] {
          if (::access(locked_dir.c_str(), W_OK) == 0) return 11;  // the directory must really be read-only here
          int code = 0;
          try {
            const HistoryReader reader(existing);
            if (reader.runs().size() != 1 || reader.input_samples(1).size() != 5) code |= 1;
          } catch (const StorageError& e) {
            std::fprintf(stderr, "reader: %s\n", e.what());
            code |= 2;
          }
          try {
            if (!check_history(existing).ok()) code |= 4;
          } catch (const StorageError& e) {
            std::fprintf(stderr, "check: %s\n", e.what());
            code |= 8;
          }
          try {
            std::ostringstream csv;
            export_table_csv(existing, "input_samples", csv);
            if (csv.str().rfind("run_id,sample_index,time_s,T_ENV,T_FLUID,n_C\n1,0,0,", 0) != 0) code |= 16;
          } catch (const StorageError& e) {
            std::fprintf(stderr, "export: %s\n", e.what());
            code |= 32;
          }
          try {
            const HistoryReader reader(with_wal);
            code |= 64;
          } catch (const StorageError& e) {
            if (e.kind != StorageErrorKind::ReadOnly || std::string(e.what()).find("-wal' lies beside") == std::string::npos) {
              std::fprintf(stderr, "with -wal: %s\n", e.what());
              code |= 128;
            }
          }
          return code;
        }) == 0);
  check_untouched(existing, before);
}

TEST_CASE("a full disk stops the writer with a disk-full error and keeps what was committed", "[storage]") {
  ScratchDir dir;
  auto fill = [](const std::filesystem::path& file, WriterOptions options) {
    options.batch_size = 50;
    std::int64_t committed = 0;
    std::int64_t k = 0;
    RunId id = 0;
    StorageError error = error_of([&] {
      HistoryWriter writer(file, options);
      id = writer.begin_run(test::small_run());
      for (;; ++k) {
        writer.add(test::sample_at(id, k));
        if (writer.pending() == 0) committed = k + 1;
      }
    });
    CHECK(error.kind == StorageErrorKind::DiskFull);
    CHECK_THAT(error.what(), Catch::Contains(file.string()) && Catch::Contains("disk full") &&
                                 Catch::Contains("were not stored"));
    INFO(error.what());
    CHECK(committed > 0);
    CHECK(check_history(file).ok());
    CHECK(static_cast<std::int64_t>(HistoryReader(file).input_samples(id).size()) >= committed);
  };
  SECTION("max_page_count cap (SQLITE_FULL)") {
    WriterOptions options;
    options.max_page_count = 40;
    fill(dir / "capped.sqlite", options);
  }
  SECTION("a real 256 KiB tmpfs (ENOSPC), when this process may mount") {
    const auto mount_point = dir.path / "tiny";
    std::filesystem::create_directories(mount_point);
    if (::mount("tmpfs", mount_point.c_str(), "tmpfs", 0, "size=256k") != 0) {
      WARN("cannot mount a tmpfs here (not root?): only the max_page_count case ran");
      return;
    }
    struct Unmount {
      std::filesystem::path path;
      ~Unmount() { ::umount(path.c_str()); }
    } unmount{mount_point};
    fill(mount_point / "full.sqlite", WriterOptions{});
  }
}

TEST_CASE("empty and missing files", "[storage]") {
  ScratchDir dir;
  CHECK(error_of([&] { HistoryReader reader(dir / "missing.sqlite"); }).kind == StorageErrorKind::NotFound);
  CHECK_THAT(error_of([&] { HistoryWriter writer(dir / "no/such/dir/h.sqlite"); }).what(),
             Catch::Contains("does not exist"));
  WriterOptions create;
  create.create_directories = true;
  CHECK_NOTHROW(HistoryWriter(dir / "made/for/you/h.sqlite", create));
  const auto empty = dir / "empty.sqlite";
  test::write_bytes(empty, "");
  CHECK(error_of([&] { HistoryReader reader(empty); }).kind == StorageErrorKind::Empty);
  CHECK_NOTHROW(HistoryWriter(empty));  // a zero-byte file holds nothing to lose: it becomes a history
  CHECK(HistoryReader(empty).schema_version() == kSchemaVersion);
}

TEST_CASE("a version-1 database is migrated to the current schema with its data", "[storage]") {
  ScratchDir dir;
  const auto file = dir / "v1.sqlite";
  // A run written in version-1 form.
  old_history(file, 1,
              "INSERT INTO runs VALUES (1, 'case B', '{\"cp_h\":12}', 'alc 0.0.9', 1.7e9, NULL, 'stopped');"
              "INSERT INTO run_channels VALUES (1, 'input', 0, 'T_ENV'), (1, 'output', 0, 'E_X0C');"
              "INSERT INTO input_samples VALUES (1, 0, 0.0, X'0000000000003440'), (1, 1, 60.0, X'0000000000803440');"
              "INSERT INTO controller_snapshots VALUES (1, 1, 60.0, 2, 'test/1', 1, '{\"k\":1}');");
  {
    const HistoryReader reader(file);  // read as it is, without migrating
    CHECK(reader.schema_version() == 1);
    CHECK(reader.nc_commands(1).empty());
    CHECK(reader.input_samples(1).size() == 2);
  }
  CHECK(RawDb(file).scalar("PRAGMA user_version") == 1);
  {
    HistoryWriter writer(file);
    writer.add(NcCommandRecord{1, 120.0, "offsets", "G10 L2 P1 X0.001", "stdout", true, ""});
  }
  const HistoryReader reader(file);
  CHECK(reader.schema_version() == kSchemaVersion);
  CHECK(RawDb(file).scalar("PRAGMA user_version") == kSchemaVersion);
  const auto samples = reader.input_samples(1);
  REQUIRE(samples.size() == 2);
  CHECK(samples[1].values == std::vector<double>{20.5});  // 0x4034800000000000
  CHECK(reader.run(1)->source == "case B");
  CHECK(reader.latest_snapshot(1)->payload == R"({"k":1})");
  const auto commands = reader.nc_commands(1);
  REQUIRE(commands.size() == 1);
  CHECK_FALSE(commands[0].delivered.has_value());  // version 2's table, with version 3's columns
  CHECK(RawDb(file).scalar("SELECT COUNT(*) FROM nc_commands WHERE delivered IS NULL AND delivery_message = ''") == 1);
  CHECK(check_history(file).ok());
}

TEST_CASE("a version-2 database is migrated to the current version: its NC commands kept, not delivered (NULL)", "[storage]") {
  ScratchDir dir;
  const auto file = dir / "v2.sqlite";
  // An accepted and a refused command in version-2 form.
  old_history(file, 2,
              "INSERT INTO runs VALUES (1, 'case A', '{}', 'alc 0.1.0', 1.7e9, 1.7e9, 'finished');"
              "INSERT INTO run_channels VALUES (1, 'output', 0, 'E_X0C');"
              "INSERT INTO nc_commands VALUES (1, 1, 60.0, 'offsets', 'G10 L2 P1 X0.001', 'file:/out', 1, ''),"
              " (2, 1, 120.0, 'offsets', '{\"x_mm\":9}', 'file:/out', 0, 'beyond max_offset');");
  const auto check_rows = [](const std::vector<NcCommandRecord>& rows) {
    REQUIRE(rows.size() == 2);
    CHECK(rows[0].text == "G10 L2 P1 X0.001");
    CHECK(rows[0].accepted);
    CHECK(rows[1].text == R"({"x_mm":9})");
    CHECK_FALSE(rows[1].accepted);
    CHECK(rows[1].message == "beyond max_offset");
    for (const auto& row : rows) {
      CHECK_FALSE(row.delivered.has_value());
      CHECK(row.delivery_message.empty());
    }
  };
  {
    // A reader takes the file as it is: the columns of version 3 read as not delivered.
    const HistoryReader reader(file);
    CHECK(reader.schema_version() == 2);
    check_rows(reader.nc_commands(1));
    std::ostringstream csv;
    export_table_csv(file, "nc_commands", csv);
    CHECK(csv.str() ==
          "run_id,nc_command_id,time_s,kind,text,sink,accepted,message,delivered,delivery_message\n"
          "1,1,60,offsets,G10 L2 P1 X0.001,file:/out,1,,,\n"
          "1,2,120,offsets,\"{\"\"x_mm\"\":9}\",file:/out,0,beyond max_offset,,\n");
    CHECK(check_history(file).ok());
  }
  CHECK(RawDb(file).scalar("PRAGMA user_version") == 2);
  { HistoryWriter writer(file); }  // migrates
  CHECK(RawDb(file).scalar("PRAGMA user_version") == kSchemaVersion);
  CHECK(RawDb(file).scalar("SELECT COUNT(*) FROM nc_commands WHERE delivered IS NULL AND delivery_message = ''") == 2);
  const HistoryReader reader(file);
  CHECK(reader.schema_version() == kSchemaVersion);
  check_rows(reader.nc_commands(1));
  CHECK(check_history(file).ok());
  {
    // The migrated rows take a delivery like new ones: the accepted one only.
    HistoryWriter writer(file);
    CHECK(writer.record_delivery(1, "file:/out", true, "written to /out/program.ngc") == 1);
  }
  const auto rows = HistoryReader(file).nc_commands(1);
  CHECK(rows[0].delivered == std::optional<bool>(true));
  CHECK_FALSE(rows[1].delivered.has_value());
}

TEST_CASE("a version-4 database is migrated to version 5: its runs kept, no indicators until a run ends", "[storage]") {
  ScratchDir dir;
  const auto file = dir / "v4.sqlite";
  // A finished replay and a study in version-4 form.
  old_history(file, 4,
              "INSERT INTO runs VALUES (1, 'case A', '{}', 'alc 0.1.0', 1.7e9, 1.7e9, 'finished');"
              "INSERT INTO run_channels VALUES (1, 'input', 0, 'T_ENV'), (1, 'output', 0, 'E_X0C');"
              "INSERT INTO input_samples VALUES (1, 0, 0.0, X'0000000000003440');"
              "INSERT INTO studies VALUES (1, '{}', '[{\"name\":\"A\",\"source\":\"A\",\"content_hash\":\"0\"}]', 'alc 0.1.0', '1/1', 2, 1.7e9);");
  {
    // A reader takes the file as it is: no indicators table, none stored, an export of the header only.
    const HistoryReader reader(file);
    CHECK(reader.schema_version() == 4);
    CHECK_FALSE(reader.indicators(1));
    const auto counts = reader.table_counts();
    CHECK(std::none_of(counts.begin(), counts.end(), [](const TableCount& c) { return c.table == "run_indicators"; }));
    std::ostringstream csv;
    export_table_csv(file, "run_indicators", csv);
    CHECK(csv.str() == "run_id,stored_unix_s,report_json\n");
    CHECK(check_history(file).ok());
  }
  CHECK(RawDb(file).scalar("PRAGMA user_version") == 4);
  RunId next = 0;
  {
    HistoryWriter writer(file);  // migrates
    next = writer.begin_run(RunRecord{0, "case B", "{}", "alc test", 0.0, std::nullopt, RunStatus::Running,
                                      {"T_ENV"}, {"E_X0C"}, {}});
    writer.store_indicators({next, R"({"outputs":{}})", 0.0});
    writer.end_run(next, RunStatus::Finished);
  }
  CHECK(RawDb(file).scalar("PRAGMA user_version") == kSchemaVersion);
  CHECK(kSchemaVersion == 5);
  CHECK(RawDb(file).scalar("SELECT COUNT(*) FROM studies") == 1);
  const HistoryReader reader(file);
  CHECK(reader.schema_version() == 5);
  CHECK(reader.run(1)->source == "case A");
  CHECK(reader.input_samples(1).size() == 1);
  CHECK_FALSE(reader.indicators(1));  // the old run ended without: a report computes them from its probes
  REQUIRE(reader.indicators(next));
  CHECK(reader.indicators(next)->report_json == R"({"outputs":{}})");
  CHECK(check_history(file).ok());
}

TEST_CASE("a reader leaves a hot rollback journal and the file it belongs to as they are", "[storage]") {
  // A file of another program, or one killed mid-write, in rollback-journal mode: a read-write
  // connection would roll the journal back into the file. The reader opens it read-only and refuses it.
  ScratchDir dir;
  const auto live = dir / "live.db", hot = dir / "hot.db";
  RawDb raw(live);
  REQUIRE(raw.exec("PRAGMA journal_mode = DELETE; CREATE TABLE customers (name TEXT); "
                   "INSERT INTO customers VALUES ('x');") == SQLITE_OK);
  REQUIRE(raw.exec("INSERT INTO customers SELECT hex(randomblob(500)) FROM "
                   "(WITH RECURSIVE n(i) AS (SELECT 1 UNION ALL SELECT i + 1 FROM n WHERE i < 400) SELECT i FROM n);") ==
          SQLITE_OK);
  // A transaction larger than the cache spills its pages into the file (the journal synced first); the
  // copies of the file and its journal while it is open: a hot journal (no lock on the copy).
  REQUIRE(raw.exec("PRAGMA cache_size = 2; BEGIN; UPDATE customers SET name = 'y' || name;") == SQLITE_OK);
  std::filesystem::copy_file(live, hot);
  REQUIRE(std::filesystem::exists(live.string() + "-journal"));
  std::filesystem::copy_file(live.string() + "-journal", hot.string() + "-journal");
  raw.exec("ROLLBACK");
  const std::string file_before = test::read_bytes(hot), journal_before = test::read_bytes(hot.string() + "-journal");
  CHECK_THROWS_AS(HistoryReader(hot), StorageError);
  CHECK(test::read_bytes(hot) == file_before);
  REQUIRE(std::filesystem::exists(hot.string() + "-journal"));
  CHECK(test::read_bytes(hot.string() + "-journal") == journal_before);
}
