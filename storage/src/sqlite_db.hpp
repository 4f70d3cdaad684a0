#pragma once
// Private to storage/: RAII handles over the SQLite C API, the error mapping, and the one open
// path that validates a file before SQLite may touch it.
#include <sqlite3.h>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <utility>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "storage/history_writer.hpp"
#include "storage/storage_error.hpp"

namespace alc::storage::detail {

class Database;

// A prepared statement; values are always bound parameters.
class Statement {
 public:
  Statement(Database& db, std::string_view sql);
  ~Statement();
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;
  Statement(Statement&& other) noexcept;
  Statement& operator=(Statement&&) = delete;

  Statement& bind(int index, double value);
  Statement& bind(int index, std::int64_t value);
  Statement& bind(int index, int value) { return bind(index, static_cast<std::int64_t>(value)); }
  Statement& bind(int index, bool value) { return bind(index, static_cast<std::int64_t>(value ? 1 : 0)); }
  Statement& bind_text(int index, std::string_view text);
  Statement& bind_blob(int index, std::string_view bytes);
  Statement& bind_null(int index);
  // Steps once: true if a row is available, false when done. Throws StorageError otherwise.
  bool step();
  // Steps to completion (for INSERT/UPDATE/DELETE), then resets for reuse.
  void run();
  void reset();

  int column_count() const;
  bool is_null(int column) const;
  double column_double(int column) const;
  std::int64_t column_int(int column) const;
  std::string column_text(int column) const;
  std::string column_blob(int column) const;

 private:
  Database* db_;
  sqlite3_stmt* stmt_ = nullptr;
};

class Database {
 public:
  Database(sqlite3* handle, std::filesystem::path file, int busy_timeout_ms);
  ~Database();
  Database(const Database&) = delete;
  Database& operator=(const Database&) = delete;

  sqlite3* handle() { return db_; }
  const std::filesystem::path& file() const { return file_; }
  int busy_timeout_ms() const { return busy_timeout_ms_; }
  void exec(std::string_view sql);
  std::int64_t query_int(std::string_view sql);
  std::string query_text(std::string_view sql);
  bool table_exists(std::string_view table);
  bool column_exists(std::string_view table, std::string_view column);
  // query_text(sql) for a statement that SQLite answers with SQLITE_BUSY at once, without its busy
  // handler, while another connection holds a lock (PRAGMA journal_mode = WAL on a file another writer
  // is creating): retried until the busy timeout, then the Locked error.
  std::string query_text_when_free(std::string_view sql);
  // Throws a StorageError for result code `rc` of an operation described by `what`.
  [[noreturn]] void fail(int rc, const std::string& what);

 private:
  sqlite3* db_;
  std::filesystem::path file_;
  int busy_timeout_ms_;
  std::optional<std::pair<std::uint64_t, std::uint64_t>> identity_;  // (device, inode) while open here
};

// Whether this process has `file` open through a Database now. POSIX advisory locks belong to the
// process: closing any descriptor of a file drops every lock the process holds on it, SQLite's
// included, and another process could then take the file from under a writer here (checkpoint and
// delete the WAL it still writes to). Code that would open the file with a descriptor of its own
// (inspect_header) must not do so while this is true.
bool open_in_this_process(const std::filesystem::path& file);

enum class OpenMode { Read, Write };

struct OpenOptions {
  OpenMode mode = OpenMode::Read;
  int busy_timeout_ms = 5000;
  bool create_directories = false;
};

// What the 100-byte SQLite header of an existing file says.
struct HeaderFacts {
  bool exists = false;
  bool empty = false;             // a zero-byte file (SQLite treats it as an empty database)
  std::int32_t application_id = 0;
  std::int32_t user_version = 0;
};

// Reads and judges the header without SQLite: throws NotADatabase, Corrupt (truncated),
// ForeignDatabase, NewerSchema as the file deserves. Never writes.
HeaderFacts inspect_header(const std::filesystem::path& file);

// Opens after inspect_header; then checks application_id, user_version and tables through SQLite.
// Returns the connection and the schema version found (0 = an empty database, Write mode only).
std::unique_ptr<Database> open_database(const std::filesystem::path& file, const OpenOptions& options,
                                        int& version_found);

// open_database() for writing, then WAL, synchronous per options.durability, foreign keys, the page
// cap, and the migrations to kSchemaVersion under the write lock (defined in history_writer.cpp).
std::unique_ptr<Database> open_for_writing(const std::filesystem::path& file, const WriterOptions& options);

// Vectors of doubles as little-endian IEEE-754 bytes (8 per value), exact.
std::string encode_f64(const std::vector<double>& values);

// A count for decode_f64 that judges only whole values (the row's run has no channels on record).
inline constexpr std::size_t kAnyCount = static_cast<std::size_t>(-1);

// The error for a blob of `bytes` bytes where `count` values of the run's `channels` belong:
// Corrupt, naming the file, `where` (table, row, column) and the length.
StorageError f64_length_error(const std::filesystem::path& file, const std::string& where, std::size_t bytes,
                              std::size_t count, const std::string& channels);

// The values of a blob of whole values (its length a multiple of 8).
std::vector<double> decode_whole_f64(std::string_view bytes);

// The `count` values of a vector blob of `file`. A blob of another length (not 8 x count; with
// kAnyCount, not a whole number of values) is a damaged row and refused: read as fewer values it was
// used as zero inputs, or missing channels, without a word (a sample's 2-byte blob moved the P99 of
// the report's baseline from 7.53 to 32.41 µm). where() names the row, built only for the error.
template <class Where>
std::vector<double> decode_f64(std::string_view bytes, std::size_t count, const std::string& channels,
                               const std::filesystem::path& file, Where&& where) {
  if (bytes.size() % 8 != 0 || (count != kAnyCount && bytes.size() != 8 * count))
    throw f64_length_error(file, where(), bytes.size(), count, channels);
  return decode_whole_f64(bytes);
}

// Shortest text that reads back to the same double; "inf", "-inf"; "" for NaN.
std::string format_double(double value);

}  // namespace alc::storage::detail
