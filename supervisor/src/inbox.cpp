#include "supervisor/inbox.hpp"

#include <sqlite3.h>

#include <stdexcept>

namespace alc::supervisor {

namespace {

// A prepared statement, finalized on scope exit.
class Statement {
 public:
  Statement(sqlite3* db, const std::string& sql, const std::filesystem::path& path) : db_(db), path_(path) {
    if (sqlite3_prepare_v2(db, sql.c_str(), -1, &s_, nullptr) != SQLITE_OK) fail("prepare");
  }
  ~Statement() { sqlite3_finalize(s_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;
  void bind(int i, std::int64_t v) { sqlite3_bind_int64(s_, i, v); }
  void bind(int i, const std::string& v) {
    sqlite3_bind_blob(s_, i, v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT);
  }
  bool step() {
    const int rc = sqlite3_step(s_);
    if (rc == SQLITE_ROW) return true;
    if (rc != SQLITE_DONE) fail("step");
    return false;
  }
  std::int64_t integer(int c) const { return sqlite3_column_int64(s_, c); }
  std::string text(int c) const {
    const auto* p = static_cast<const char*>(sqlite3_column_blob(s_, c));
    return p ? std::string(p, static_cast<std::size_t>(sqlite3_column_bytes(s_, c))) : std::string();
  }

 private:
  [[noreturn]] void fail(const char* what) const {
    throw std::runtime_error(path_.string() + ": inbox " + what + ": " + sqlite3_errmsg(db_));
  }
  sqlite3* db_;
  const std::filesystem::path& path_;
  sqlite3_stmt* s_ = nullptr;
};

}  // namespace

Inbox::Inbox(const std::filesystem::path& path, storage::Durability durability) : path_(path) {
  if (sqlite3_open_v2(path.c_str(), &db_, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, nullptr) != SQLITE_OK) {
    const std::string e = db_ ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    throw std::runtime_error(path.string() + ": cannot open the inbox: " + e);
  }
  sqlite3_busy_timeout(db_, 5000);
  // WAL with synchronous=NORMAL: a committed entry survives a killed process; FULL: a power loss too.
  exec(std::string("PRAGMA journal_mode=WAL; PRAGMA synchronous=") +
       (durability == storage::Durability::Power ? "FULL;" : "NORMAL;") +
       "CREATE TABLE IF NOT EXISTS alc_inbox(seq INTEGER PRIMARY KEY, kind TEXT NOT NULL, payload BLOB NOT NULL);"
       "CREATE TABLE IF NOT EXISTS alc_inbox_state(seq INTEGER PRIMARY KEY, state BLOB NOT NULL);"
       "CREATE TABLE IF NOT EXISTS alc_inbox_next(id INTEGER PRIMARY KEY CHECK(id = 1), seq INTEGER NOT NULL);"
       "INSERT OR IGNORE INTO alc_inbox_next(id, seq) VALUES(1, 0);");
}

Inbox::~Inbox() { sqlite3_close(db_); }

void Inbox::exec(const std::string& sql) const {
  char* error = nullptr;
  if (sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &error) != SQLITE_OK) {
    const std::string e = error ? error : "unknown error";
    sqlite3_free(error);
    throw std::runtime_error(path_.string() + ": inbox: " + e);
  }
}

int Inbox::synchronous() const {
  Statement s(db_, "PRAGMA synchronous", path_);
  return s.step() ? static_cast<int>(s.integer(0)) : -1;
}

std::int64_t Inbox::next_seq() const {
  Statement s(db_, "SELECT seq FROM alc_inbox_next WHERE id = 1", path_);
  return s.step() ? s.integer(0) : 0;
}

std::int64_t Inbox::append(const std::string& kind, const std::string& payload) {
  exec("BEGIN IMMEDIATE");
  try {
    const std::int64_t seq = next_seq();
    Statement s(db_, "INSERT INTO alc_inbox(seq, kind, payload) VALUES(?, ?, ?)", path_);
    s.bind(1, seq);
    s.bind(2, kind);
    s.bind(3, payload);
    s.step();
    Statement n(db_, "UPDATE alc_inbox_next SET seq = seq + 1 WHERE id = 1", path_);
    n.step();
    exec("COMMIT");
    return seq;
  } catch (...) {
    sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
    throw;
  }
}

std::vector<InboxEntry> Inbox::from(std::int64_t first) const {
  Statement s(db_, "SELECT seq, kind, payload FROM alc_inbox WHERE seq >= ? ORDER BY seq", path_);
  s.bind(1, first);
  std::vector<InboxEntry> out;
  while (s.step()) out.push_back({s.integer(0), s.text(1), s.text(2)});
  return out;
}

void Inbox::save_state(std::int64_t seq, const std::string& state) {
  Statement s(db_, "INSERT OR REPLACE INTO alc_inbox_state(seq, state) VALUES(?, ?)", path_);
  s.bind(1, seq);
  s.bind(2, state);
  s.step();
}

void Inbox::prune(std::int64_t before) {
  exec("BEGIN IMMEDIATE");
  try {
    Statement d(db_, "DELETE FROM alc_inbox WHERE seq < ?", path_);
    d.bind(1, before);
    d.step();
    Statement e(db_, "DELETE FROM alc_inbox_state WHERE seq < ?", path_);
    e.bind(1, before);
    e.step();
    exec("COMMIT");
  } catch (...) {
    sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
    throw;
  }
}

std::optional<std::string> Inbox::state_at(std::int64_t seq) const {
  Statement s(db_, "SELECT state FROM alc_inbox_state WHERE seq = ?", path_);
  s.bind(1, seq);
  if (!s.step()) return std::nullopt;
  return s.text(0);
}

void Inbox::clear() { exec("DELETE FROM alc_inbox; DELETE FROM alc_inbox_state;"); }

}  // namespace alc::supervisor
