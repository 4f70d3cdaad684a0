// A reader opened beside this process's writer must not drop the writer's locks. POSIX advisory
// locks belong to the process: closing any descriptor of the file drops them all, and then another
// process's connection, closing as if it were the last one, checkpoints and deletes the WAL that the
// writer here still appends to (its later commits go into a deleted file: lost after a kill -9).
#include <catch2/catch.hpp>
#include <cstdlib>
#include <filesystem>
#include <sstream>

#include "storage/history_reader.hpp"
#include "storage/history_tools.hpp"
#include "storage/history_writer.hpp"
#include "storage/study_store.hpp"
#include "storage_test_support.hpp"

using namespace alc::storage;

TEST_CASE("history locks: a reader opened beside the writer in one process keeps the writer's WAL from others") {
  const test::ScratchDir dir;
  const auto file = dir / "h.sqlite";
  std::filesystem::path wal = file;
  wal += "-wal";
  HistoryWriter writer(file);
  const RunId id = writer.begin_run(test::small_run());
  for (int k = 0; k < 50; ++k) writer.add(test::sample_at(id, k));
  writer.commit();
  REQUIRE(std::filesystem::exists(wal));
  // Readers in this process: a history reader and the study store's look (as the supervisor and a
  // resume open them while their writer runs).
  CHECK(HistoryReader(file).runs().size() == 1);
  CHECK_FALSE(StudyStore::header_of(file));
  // Another process opens the file read-write and closes it: it must see a connection still there.
  const std::string cmd = "sqlite3 '" + file.string() + "' 'SELECT count(*) FROM input_samples' >/dev/null 2>&1";
  REQUIRE(std::system(cmd.c_str()) == 0);
  CHECK(std::filesystem::exists(wal));
  // What the writer commits after that is in the file that others read.
  for (int k = 50; k < 80; ++k) writer.add(test::sample_at(id, k));
  writer.commit();
  CHECK(HistoryReader(file).input_samples(id).size() == 80);
  const std::string count = "sqlite3 '" + file.string() + "' 'SELECT count(*) FROM input_samples' > '" +
                            (dir / "count").string() + "'";
  REQUIRE(std::system(count.c_str()) == 0);
  CHECK(test::read_bytes(dir / "count") == "80\n");
}

// SQLite deletes FILE-wal and FILE-shm when the last connection closes, unless that connection is
// read-only; a reader of a file no writer has open opens it read-write with query_only, so it leaves
// nothing behind (alc report, alc db, alc study merge and report read files this way).
TEST_CASE("history locks: a reader of a history no writer has open leaves the file as it was, with no -wal or -shm") {
  const test::ScratchDir dir;
  const auto file = dir / "h.sqlite";
  {
    HistoryWriter writer(file);
    const RunId id = writer.begin_run(test::small_run());
    for (int k = 0; k < 20; ++k) writer.add(test::sample_at(id, k));
    writer.commit();
  }
  const auto no_side_files = [&] {
    CHECK_FALSE(std::filesystem::exists(file.string() + "-wal"));
    CHECK_FALSE(std::filesystem::exists(file.string() + "-shm"));
  };
  no_side_files();
  const std::string before = test::read_bytes(file);
  {
    const HistoryReader reader(file);
    CHECK(reader.input_samples(1).size() == 20);
  }
  no_side_files();
  CHECK(check_history(file).ok());
  no_side_files();
  std::ostringstream csv;
  export_table_csv(file, "input_samples", csv);
  CHECK(csv.str().find('\n') != std::string::npos);
  no_side_files();
  CHECK_FALSE(StudyStore::header_of(file));
  no_side_files();
  CHECK(test::read_bytes(file) == before);
  // With the writer open the reader stays read-only, and the writer's WAL stays where it is.
  HistoryWriter writer(file);
  writer.add(test::sample_at(1, 20));
  writer.commit();
  REQUIRE(std::filesystem::exists(file.string() + "-wal"));
  CHECK(HistoryReader(file).input_samples(1).size() == 21);
  CHECK(std::filesystem::exists(file.string() + "-wal"));
}
