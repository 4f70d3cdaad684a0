#include "sqlite_db.hpp"

#include <sys/stat.h>

#include <unistd.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <mutex>
#include <set>
#include <thread>

#include "common/atomic_file.hpp"
#include "common/byte_codec.hpp"
#include "common/number_text.hpp"
#include "storage/schema.hpp"

namespace alc::storage::detail {
namespace fs = std::filesystem;

namespace {

std::uint32_t big_endian_u32(const unsigned char* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) |
         std::uint32_t{p[3]};
}

std::string hex32(std::int32_t value) {
  char text[16];
  std::snprintf(text, sizeof text, "0x%08X", static_cast<unsigned>(value));
  return text;
}

[[noreturn]] void refuse_foreign_id(const fs::path& file, std::int32_t application_id) {
  throw StorageError(StorageErrorKind::ForeignDatabase, file,
                     "an SQLite database of another program: application_id " + hex32(application_id) +
                         ", ALC's is " + hex32(kApplicationId) + "; left untouched");
}

[[noreturn]] void refuse_newer(const fs::path& file, int version) {
  throw StorageError(StorageErrorKind::NewerSchema, file,
                     "schema version " + std::to_string(version) + " is newer than this alc (" +
                         std::to_string(kSchemaVersion) + "); use a newer alc; left untouched");
}

StorageErrorKind kind_of_errno(int err, StorageErrorKind fallback) {
  switch (err) {
    case EACCES: case EPERM: case EROFS: return StorageErrorKind::ReadOnly;
    case ENOSPC: case EDQUOT: return StorageErrorKind::DiskFull;
    case ENOENT: return StorageErrorKind::NotFound;
    default: return fallback;
  }
}

fs::path parent_of(const fs::path& file) { return file.parent_path().empty() ? fs::path(".") : file.parent_path(); }

// A path as an SQLite URI ("file:" + the path, percent-encoded except unreserved characters and '/').
std::string file_uri(const fs::path& file, const char* query) {
  static constexpr char kHex[] = "0123456789ABCDEF";
  std::string uri = "file:";
  for (const char c : file.string()) {
    const auto u = static_cast<unsigned char>(c);
    if (std::isalnum(u) || c == '/' || c == '-' || c == '.' || c == '_' || c == '~') {
      uri += c;
    } else {
      uri += '%';
      uri += kHex[u >> 4];
      uri += kHex[u & 0xf];
    }
  }
  return uri + "?" + query;
}

// Calls `f(sql, at)` for every occurrence of `keyword` in migration_sql(1..version), `at` just
// after it: the released DDL is the one source of what a file of that version holds.
template <class F>
void each_in_migrations(int version, std::string_view keyword, F f) {
  for (int v = 1; v <= version; ++v) {
    const std::string_view sql = migration_sql(v);
    for (auto at = sql.find(keyword); at != std::string_view::npos; at = sql.find(keyword, at + 1))
      f(sql, at + keyword.size());
  }
}

// Tables that migration_sql(1..version) create.
std::vector<std::string> tables_of_version(int version) {
  std::vector<std::string> tables;
  each_in_migrations(version, "CREATE TABLE ", [&](std::string_view sql, std::size_t start) {
    tables.emplace_back(sql.substr(start, sql.find_first_of(" (\n", start) - start));
  });
  return tables;
}

// Columns that the ALTER TABLE … ADD COLUMN of migration_sql(1..version) add, as (table, column).
std::vector<std::pair<std::string, std::string>> added_columns_of_version(int version) {
  std::vector<std::pair<std::string, std::string>> columns;
  static constexpr std::string_view kAdd = " ADD COLUMN ";
  each_in_migrations(version, "ALTER TABLE ", [&](std::string_view sql, std::size_t table_start) {
    const auto add = sql.find(kAdd, table_start);
    if (add == std::string_view::npos) return;
    const auto column_start = add + kAdd.size();
    const auto column_end = sql.find_first_of(" ;\n", column_start);
    columns.emplace_back(sql.substr(table_start, add - table_start), sql.substr(column_start, column_end - column_start));
  });
  return columns;
}

// An ALC file must hold every table of its schema version as a real table (not a view), with the
// columns that migrations added, or it was not written by ALC and nothing may be done to it.
void require_tables(Database& db, const fs::path& file, int version) {
  std::string missing;
  for (const std::string& table : tables_of_version(version))
    if (!db.table_exists(table)) missing += (missing.empty() ? "" : ", ") + table;
  if (!missing.empty())
    throw StorageError(StorageErrorKind::Corrupt, file,
                       "ALC's application_id and schema version " + std::to_string(version) +
                           ", but the table(s) " + missing + " are missing; left untouched");
  for (const auto& [table, column] : added_columns_of_version(version))
    if (!db.column_exists(table, column)) missing += (missing.empty() ? "" : ", ") + table + "." + column;
  if (!missing.empty())
    throw StorageError(StorageErrorKind::Corrupt, file,
                       "ALC's application_id and schema version " + std::to_string(version) +
                           ", but the column(s) " + missing + " are missing; left untouched");
  // ALC's schema has no triggers and no views: one in the file would run its own SQL on our writes.
  Statement extra(db, "SELECT type, name FROM sqlite_schema WHERE type IN ('trigger', 'view') ORDER BY name LIMIT 5");
  std::string found;
  while (extra.step()) found += (found.empty() ? "" : ", ") + extra.column_text(0) + " '" + extra.column_text(1) + "'";
  if (!found.empty())
    throw StorageError(StorageErrorKind::ForeignDatabase, file,
                       "ALC's application_id, but the schema holds " + found +
                           " that ALC never creates (they would run on every write); left untouched");
}

// PRAGMA quick_check (page and B-tree structure, no index cross-check): a writer must not append to
// a damaged file, where the damage would spread and committed records could be lost.
void require_sound_pages(Database& db, const fs::path& file) {
  std::string problems;
  int shown = 0;
  try {
    Statement st(db, "PRAGMA quick_check(5)");
    while (st.step()) {
      const std::string row = st.column_text(0);
      if (row == "ok") continue;
      problems += (shown++ ? "; " : "") + row;
    }
  } catch (const StorageError& e) {
    if (e.kind != StorageErrorKind::Corrupt && e.kind != StorageErrorKind::NotADatabase) throw;
    problems += (shown++ ? "; " : "") + e.reason;
  }
  if (!problems.empty())
    throw StorageError(StorageErrorKind::Corrupt, file,
                       "the file is corrupted (PRAGMA quick_check: " + problems +
                           "); left untouched, not written to; 'alc db check' lists the damage");
}

// The checks of an opened file through SQLite: application_id, schema version, tables, and for a
// writer the pages. Sets version_found (0 = an empty database, Write mode only).
void check_schema(Database& db, const fs::path& file, bool write, const HeaderFacts& facts, int& version_found) {
  const auto application_id = static_cast<std::int32_t>(db.query_int("PRAGMA application_id"));
  const auto version = static_cast<int>(db.query_int("PRAGMA user_version"));
  if (application_id != 0 && application_id != kApplicationId) refuse_foreign_id(file, application_id);
  if (application_id == 0) {
    Statement tables(db, "SELECT name FROM sqlite_schema WHERE name NOT LIKE 'sqlite_%' ORDER BY name LIMIT 5");
    std::string names;
    while (tables.step()) names += (names.empty() ? "" : ", ") + tables.column_text(0);
    if (!names.empty())
      throw StorageError(StorageErrorKind::ForeignDatabase, file,
                         "an SQLite database of another program (no ALC application_id; holds " + names +
                             "); left untouched");
    if (!write) throw StorageError(StorageErrorKind::Empty, file, "an empty SQLite database, not an ALC history");
    if (facts.exists && !facts.empty) require_sound_pages(db, file);
    version_found = 0;
    return;
  }
  if (version > kSchemaVersion) refuse_newer(file, version);
  if (version < 1)
    throw StorageError(StorageErrorKind::Corrupt, file, "ALC's application_id but no schema version");
  require_tables(db, file, version);
  // A writer checks the pages before it changes anything (journal mode, migration, records).
  if (write) require_sound_pages(db, file);
  version_found = version;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
namespace {
std::mutex open_files_mutex;
std::multiset<std::pair<std::uint64_t, std::uint64_t>> open_files;  // (device, inode) of every open Database

std::optional<std::pair<std::uint64_t, std::uint64_t>> identity_of(const fs::path& file) {
  struct stat st {};
  if (::stat(file.c_str(), &st) != 0) return std::nullopt;
  return std::pair<std::uint64_t, std::uint64_t>{st.st_dev, st.st_ino};
}
}  // namespace

bool open_in_this_process(const fs::path& file) {
  const auto id = identity_of(file);
  const std::lock_guard<std::mutex> lock(open_files_mutex);
  return id && open_files.count(*id) > 0;
}

Database::Database(sqlite3* handle, fs::path file, int busy_timeout_ms)
    : db_(handle), file_(std::move(file)), busy_timeout_ms_(busy_timeout_ms), identity_(identity_of(file_)) {
  if (!identity_) return;
  const std::lock_guard<std::mutex> lock(open_files_mutex);
  open_files.insert(*identity_);
}

Database::~Database() {
  sqlite3_close_v2(db_);
  if (!identity_) return;
  const std::lock_guard<std::mutex> lock(open_files_mutex);
  if (const auto it = open_files.find(*identity_); it != open_files.end()) open_files.erase(it);
}

void Database::fail(int rc, const std::string& what) {
  const int primary = rc & 0xff;
  const int sys = sqlite3_system_errno(db_);
  std::string detail = sqlite3_errmsg(db_);
  if (sys != 0) detail += std::string(", ") + std::strerror(sys);
  StorageErrorKind kind = StorageErrorKind::Io;
  std::string cause;
  switch (primary) {
    case SQLITE_BUSY:
    case SQLITE_LOCKED:
      kind = StorageErrorKind::Locked;
      cause = "locked by another connection; gave up after the busy timeout of " +
              std::to_string(busy_timeout_ms_) + " ms";
      break;
    case SQLITE_READONLY:
      kind = StorageErrorKind::ReadOnly;
      cause = "the file or its directory is read-only";
      break;
    case SQLITE_FULL:
      kind = StorageErrorKind::DiskFull;
      cause = "disk full (or the max_page_count cap reached)";
      break;
    case SQLITE_CORRUPT:
      kind = StorageErrorKind::Corrupt;
      cause = "the file is corrupted";
      break;
    case SQLITE_NOTADB:
      kind = StorageErrorKind::NotADatabase;
      cause = "not an SQLite database";
      break;
    case SQLITE_CANTOPEN:
      kind = kind_of_errno(sys, StorageErrorKind::Io);
      cause = kind == StorageErrorKind::ReadOnly ? "cannot open: permission denied or read-only file system"
                                                 : "cannot open";
      break;
    case SQLITE_IOERR:
      kind = kind_of_errno(sys, StorageErrorKind::Io);
      cause = kind == StorageErrorKind::DiskFull ? "disk full" : "I/O error";
      break;
    case SQLITE_CONSTRAINT:
    case SQLITE_MISMATCH:
    case SQLITE_RANGE:
      kind = StorageErrorKind::InvalidArgument;
      cause = "record rejected";
      break;
    default:
      cause = "SQLite error";
      break;
  }
  throw StorageError(kind, file_, what + ": " + cause + " (" + detail + ")");
}

void Database::exec(std::string_view sql) {
  char* message = nullptr;
  const int rc = sqlite3_exec(db_, std::string(sql).c_str(), nullptr, nullptr, &message);
  sqlite3_free(message);
  if (rc != SQLITE_OK) fail(rc, "executing '" + std::string(sql.substr(0, 60)) + "'");
}

std::int64_t Database::query_int(std::string_view sql) {
  Statement st(*this, sql);
  return st.step() ? st.column_int(0) : 0;
}

std::string Database::query_text(std::string_view sql) {
  Statement st(*this, sql);
  return st.step() ? st.column_text(0) : std::string();
}

std::string Database::query_text_when_free(std::string_view sql) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(busy_timeout_ms_);
  for (int attempt = 1;; ++attempt) {
    try {
      return query_text(sql);
    } catch (const StorageError& e) {
      if (e.kind != StorageErrorKind::Locked || std::chrono::steady_clock::now() >= deadline) throw;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(std::min(attempt, 20)));
  }
}

bool Database::table_exists(std::string_view table) {
  Statement st(*this, "SELECT 1 FROM sqlite_schema WHERE type = 'table' AND name = ?1");
  st.bind_text(1, table);
  return st.step();
}

bool Database::column_exists(std::string_view table, std::string_view column) {
  Statement st(*this, "SELECT 1 FROM pragma_table_info(?1) WHERE name = ?2");
  st.bind_text(1, table).bind_text(2, column);
  return st.step();
}

// ---------------------------------------------------------------------------------------------
Statement::Statement(Database& db, std::string_view sql) : db_(&db) {
  const int rc = sqlite3_prepare_v3(db.handle(), sql.data(), static_cast<int>(sql.size()),
                                    SQLITE_PREPARE_PERSISTENT, &stmt_, nullptr);
  if (rc != SQLITE_OK) db.fail(rc, "preparing '" + std::string(sql.substr(0, 60)) + "'");
}

Statement::Statement(Statement&& other) noexcept : db_(other.db_), stmt_(other.stmt_) {
  other.stmt_ = nullptr;
}

Statement::~Statement() { sqlite3_finalize(stmt_); }

#define ALC_BIND(call)                                   \
  do {                                                   \
    const int rc_ = (call);                              \
    if (rc_ != SQLITE_OK) db_->fail(rc_, "binding a value"); \
  } while (0)

Statement& Statement::bind(int index, double value) {
  ALC_BIND(sqlite3_bind_double(stmt_, index, value));
  return *this;
}
Statement& Statement::bind(int index, std::int64_t value) {
  ALC_BIND(sqlite3_bind_int64(stmt_, index, value));
  return *this;
}
Statement& Statement::bind_text(int index, std::string_view text) {
  ALC_BIND(sqlite3_bind_text64(stmt_, index, text.data(), text.size(), SQLITE_TRANSIENT, SQLITE_UTF8));
  return *this;
}
Statement& Statement::bind_blob(int index, std::string_view bytes) {
  // A null pointer would bind NULL; an empty blob stays an empty blob.
  if (bytes.empty()) {
    ALC_BIND(sqlite3_bind_zeroblob(stmt_, index, 0));
  } else {
    ALC_BIND(sqlite3_bind_blob64(stmt_, index, bytes.data(), bytes.size(), SQLITE_TRANSIENT));
  }
  return *this;
}
Statement& Statement::bind_null(int index) {
  ALC_BIND(sqlite3_bind_null(stmt_, index));
  return *this;
}
#undef ALC_BIND

bool Statement::step() {
  const int rc = sqlite3_step(stmt_);
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  sqlite3_reset(stmt_);
  db_->fail(rc, "running '" + std::string(sqlite3_sql(stmt_)).substr(0, 60) + "'");
}

void Statement::run() {
  while (step()) {
  }
  reset();
}

void Statement::reset() {
  sqlite3_reset(stmt_);
  sqlite3_clear_bindings(stmt_);
}

int Statement::column_count() const { return sqlite3_column_count(stmt_); }
bool Statement::is_null(int column) const { return sqlite3_column_type(stmt_, column) == SQLITE_NULL; }
double Statement::column_double(int column) const { return sqlite3_column_double(stmt_, column); }
std::int64_t Statement::column_int(int column) const { return sqlite3_column_int64(stmt_, column); }
std::string Statement::column_text(int column) const {
  const auto* text = sqlite3_column_text(stmt_, column);
  const int size = sqlite3_column_bytes(stmt_, column);
  return text ? std::string(reinterpret_cast<const char*>(text), static_cast<std::size_t>(size)) : std::string();
}
std::string Statement::column_blob(int column) const {
  const void* blob = sqlite3_column_blob(stmt_, column);
  const int size = sqlite3_column_bytes(stmt_, column);
  return blob ? std::string(static_cast<const char*>(blob), static_cast<std::size_t>(size)) : std::string();
}

// ---------------------------------------------------------------------------------------------
HeaderFacts inspect_header(const fs::path& file) {
  HeaderFacts facts;
  std::error_code ec;
  const auto status = fs::status(file, ec);
  if (!fs::exists(status)) return facts;
  facts.exists = true;
  if (!fs::is_regular_file(status))
    throw StorageError(StorageErrorKind::NotADatabase, file, "not a regular file");
  const auto size = fs::file_size(file, ec);
  if (ec) throw StorageError(StorageErrorKind::Io, file, "cannot read its size: " + ec.message());
  if (size == 0) {
    facts.empty = true;
    return facts;
  }
  // Open here through SQLite already (a reader beside this process's writer): judged when it was
  // first opened, and a descriptor of our own would drop the writer's locks when it closes.
  if (open_in_this_process(file)) return facts;
  std::ifstream in(file, std::ios::binary);
  if (!in) throw StorageError(kind_of_errno(errno, StorageErrorKind::Io), file,
                              std::string("cannot open for reading: ") + std::strerror(errno));
  std::array<unsigned char, 100> header{};
  in.read(reinterpret_cast<char*>(header.data()), header.size());
  const auto got = static_cast<std::size_t>(in.gcount());
  static constexpr char kMagic[16] = {'S', 'Q', 'L', 'i', 't', 'e', ' ', 'f', 'o', 'r', 'm', 'a', 't', ' ', '3', '\0'};
  const std::size_t compare = std::min<std::size_t>(got, sizeof kMagic);
  if (std::memcmp(header.data(), kMagic, compare) != 0)
    throw StorageError(StorageErrorKind::NotADatabase, file,
                       "not an SQLite database (no 'SQLite format 3' header); left untouched");
  if (got < header.size())
    throw StorageError(StorageErrorKind::Corrupt, file,
                       "truncated: " + std::to_string(got) + " bytes, shorter than the 100-byte SQLite header");
  std::uint32_t page_size = (std::uint32_t{header[16]} << 8) | header[17];
  if (page_size == 1) page_size = 65536;
  if (page_size < 512 || page_size > 65536 || (page_size & (page_size - 1)) != 0)
    throw StorageError(StorageErrorKind::Corrupt, file, "corrupted header: page size " + std::to_string(page_size));
  if (size % page_size != 0)
    throw StorageError(StorageErrorKind::Corrupt, file,
                       "truncated: " + std::to_string(size) + " bytes is not a whole number of " +
                           std::to_string(page_size) + "-byte pages");
  // The in-header page count is valid when the change counter matches "version-valid-for"; a WAL
  // file beside it may still hold pages not yet copied back, so judge only without one.
  const std::uint32_t pages = big_endian_u32(&header[28]);
  const bool count_valid = pages != 0 && std::memcmp(&header[24], &header[92], 4) == 0;
  fs::path wal = file;
  wal += "-wal";
  const bool wal_has_frames = fs::exists(wal, ec) && fs::file_size(wal, ec) > 0;
  if (count_valid && !wal_has_frames && std::uint64_t{pages} * page_size > size)
    throw StorageError(StorageErrorKind::Corrupt, file,
                       "truncated: the header counts " + std::to_string(pages) + " pages of " +
                           std::to_string(page_size) + " bytes but the file has " + std::to_string(size) + " bytes");
  facts.user_version = static_cast<std::int32_t>(big_endian_u32(&header[60]));
  facts.application_id = static_cast<std::int32_t>(big_endian_u32(&header[68]));
  if (facts.application_id != 0 && facts.application_id != kApplicationId) refuse_foreign_id(file, facts.application_id);
  if (facts.application_id == kApplicationId && facts.user_version > kSchemaVersion) refuse_newer(file, facts.user_version);
  return facts;
}

std::unique_ptr<Database> open_database(const fs::path& file, const OpenOptions& options, int& version_found) {
  const HeaderFacts facts = inspect_header(file);
  const bool write = options.mode == OpenMode::Write;
  if (!facts.exists && !write)
    throw StorageError(StorageErrorKind::NotFound, file, "no such file");
  if (facts.empty && !write)
    throw StorageError(StorageErrorKind::Empty, file, "an empty file, not an ALC history");
  const fs::path parent = parent_of(file);
  // A reader in a directory it cannot write to: WAL needs FILE-shm beside the file, which cannot be
  // created, and SQLite would fail with "attempt to write a readonly database". With no FILE-wal
  // (no writer is running, and none can start there) the file alone is the whole database: open it
  // immutable (no locks, no -shm). With a FILE-wal present the normal open is tried and SQLite's
  // answer is reported (the WAL may hold committed records the file lacks).
  const bool parent_writable = ::access(parent.c_str(), W_OK) == 0;
  bool immutable = false, wal_in_readonly_dir = false;
  if (!write && !parent_writable) {
    std::error_code ec;
    immutable = !fs::exists(fs::path(file.string() + "-wal"), ec);
    wal_in_readonly_dir = !immutable;
  }
  if (!facts.exists) {
    std::error_code ec;
    if (!fs::exists(parent, ec)) {
      if (!options.create_directories)
        throw StorageError(StorageErrorKind::NotFound, file, "directory '" + parent.string() + "' does not exist");
      fs::create_directories(parent, ec);
      if (ec) throw StorageError(kind_of_errno(ec.value(), StorageErrorKind::Io), file,
                                 "cannot create directory '" + parent.string() + "': " + ec.message());
    }
    if (::access(parent.c_str(), W_OK) != 0)
      throw StorageError(StorageErrorKind::ReadOnly, file,
                         "cannot create the database: directory '" + parent.string() + "' is not writable");
  } else if (write) {
    // WAL needs FILE-wal and FILE-shm beside the file.
    if (!parent_writable)
      throw StorageError(StorageErrorKind::ReadOnly, file,
                         "directory '" + parent.string() + "' is not writable (the WAL journal lives beside the file)");
    if (io::read_only_file(file))
      throw StorageError(StorageErrorKind::ReadOnly, file,
                         "the file is read-only (no write permission for this user); left untouched");
  }

  // SQLite deletes FILE-wal and FILE-shm when the last connection closes, unless that connection is
  // read-only: a read-only reader of a file no writer has open would leave both behind (two per shard
  // after alc study merge, two beside every history after alc report). Where no FILE-wal lies beside
  // the file (no writer running, none killed) and this user may write the file and its directory, a
  // reader opens it read-write with query_only set below, which refuses every change through SQL.
  // With a FILE-wal present the reader stays read-only and leaves the writer's files alone; with a
  // FILE-journal present (a rollback journal: a file of another program, or one killed mid-write) too,
  // since a read-write connection would roll the journal back into the file. A writer that starts
  // after this check and closes before the reader leaves its frames for the reader's close to copy into
  // the file (SQLite's checkpoint: no record is changed or lost).
  bool read_write = write;
  if (!write && parent_writable) {
    std::error_code ec1, ec2;
    read_write = !fs::exists(fs::path(file.string() + "-wal"), ec1) && !ec1 &&
                 !fs::exists(fs::path(file.string() + "-journal"), ec2) && !ec2 && !io::read_only_file(file);
  }
  int flags = SQLITE_OPEN_NOMUTEX | SQLITE_OPEN_EXRESCODE;
  flags |= read_write ? SQLITE_OPEN_READWRITE : SQLITE_OPEN_READONLY;
  if (write && !facts.exists) flags |= SQLITE_OPEN_CREATE;  // never create over an existing file
  if (immutable) flags |= SQLITE_OPEN_URI;
  const std::string name = immutable ? file_uri(file, "mode=ro&immutable=1") : file.string();
  sqlite3* handle = nullptr;
  const int rc = sqlite3_open_v2(name.c_str(), &handle, flags, nullptr);
  auto db = std::make_unique<Database>(handle, file, options.busy_timeout_ms);
  if (rc != SQLITE_OK) db->fail(rc, "opening");
  sqlite3_extended_result_codes(handle, 1);
  sqlite3_busy_timeout(handle, options.busy_timeout_ms);
  if (!write) db->exec("PRAGMA query_only = ON");
  // The file may be hostile: SQL functions and virtual tables with side effects must not run from
  // its schema (triggers, views, CHECK constraints, DEFAULTs, indexes, generated columns).
  int trusted = 1;
  const int trc = sqlite3_db_config(handle, SQLITE_DBCONFIG_TRUSTED_SCHEMA, 0, &trusted);
  if (trc != SQLITE_OK || trusted != 0) db->fail(trc != SQLITE_OK ? trc : SQLITE_ERROR, "setting trusted_schema = OFF");

  if (wal_in_readonly_dir) {
    try {
      db->query_int("PRAGMA schema_version");  // the first read: opens the WAL and its -shm
    } catch (const StorageError& e) {
      if (e.kind != StorageErrorKind::ReadOnly && e.kind != StorageErrorKind::NotFound && e.kind != StorageErrorKind::Io)
        throw;  // corrupt, locked, …: SQLite's own answer
      throw StorageError(StorageErrorKind::ReadOnly, file,
                         "directory '" + parent.string() + "' is not writable and '" + file.filename().string() +
                             "-wal' lies beside the file (a writer is running or was killed): reading the WAL needs "
                             "a '-shm' file SQLite cannot create there; copy the file with its -wal to a writable "
                             "directory (" + e.reason + ")");
    }
  }
  // Authoritative checks through SQLite (the header may be stale while a WAL holds changes), all in
  // one read transaction: a writer creating the schema at this moment (in one transaction) is seen
  // either not at all or complete, never as tables without ALC's application_id.
  db->exec("BEGIN");
  try {
    check_schema(*db, file, write, facts, version_found);
  } catch (...) {
    sqlite3_exec(db->handle(), "ROLLBACK", nullptr, nullptr, nullptr);
    throw;
  }
  db->exec("COMMIT");
  return db;
}


// ---------------------------------------------------------------------------------------------
// Blobs of f64 values: the bytes of common::ByteWriter::f64, one after the other, no count.
std::string encode_f64(const std::vector<double>& values) {
  common::ByteWriter bytes;
  for (const double v : values) bytes.f64(v);
  return bytes.take();
}

std::vector<double> decode_whole_f64(std::string_view bytes) {
  common::ByteReader reader(bytes, "f64 blob");
  std::vector<double> values;
  values.reserve(bytes.size() / 8);
  while (!reader.done()) values.push_back(reader.f64());
  return values;
}

StorageError f64_length_error(const std::filesystem::path& file, const std::string& where, std::size_t bytes,
                              std::size_t count, const std::string& channels) {
  return StorageError(StorageErrorKind::Corrupt, file,
                      where + " holds " + std::to_string(bytes) + (bytes == 1 ? " byte" : " bytes") + ", not " +
                          (count == kAnyCount ? std::string("a whole number of 8-byte values")
                                              : std::to_string(8 * count) + " (the run's " + std::to_string(count) +
                                                    " " + channels + ", 8 bytes each)") +
                          ": a damaged row (alc db check lists such rows)");
}

// NaN is an empty cell (NULL-like), infinities are "inf" / "-inf", -0 stays "-0".
std::string format_double(double value) { return std::isnan(value) ? std::string() : common::shortest_text(value); }

}  // namespace alc::storage::detail
