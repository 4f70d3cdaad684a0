#pragma once
// The supervisor's inbox: every accepted message (a sample, a probe result, a probe asked for),
// committed before it is acted on, in the order it was accepted; and the supervisor's own state at
// each controller snapshot. A restart restores the latest snapshot of the history and processes the inbox entries
// after it again, so nothing accepted is lost and the decisions are those of an uninterrupted run.
// Entries before the latest snapshot are deleted (bounded storage). SQLite (WAL) in its own file.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "storage/history_writer.hpp"

struct sqlite3;

namespace alc::supervisor {

struct InboxEntry {
  std::int64_t seq = 0;
  std::string kind;     // "sample", "sample/jump", "probe/result", "probe/now", "nc/compensation", "nc/sending"
  std::string payload;  // as received
};

class Inbox {
 public:
  // Durability as the history's: Process commits survive a killed process (synchronous=NORMAL), Power
  // ones a power loss too (synchronous=FULL: an fsync before the broker is told the message is taken).
  explicit Inbox(const std::filesystem::path& path, storage::Durability durability = storage::Durability::Process);
  ~Inbox();
  Inbox(const Inbox&) = delete;
  Inbox& operator=(const Inbox&) = delete;

  // Appends and commits; returns its sequence number.
  std::int64_t append(const std::string& kind, const std::string& payload);
  // Entries with seq >= first, in order.
  std::vector<InboxEntry> from(std::int64_t first) const;
  // SQLite's synchronous level of the inbox's connection: 1 (NORMAL) or 2 (FULL).
  int synchronous() const;
  // The sequence number the next append gets.
  std::int64_t next_seq() const;
  // Stores the supervisor's state for the snapshot that continues at `seq` (before the snapshot is
  // saved), then prune(seq) once the snapshot is committed: entries and states before `seq` go.
  void save_state(std::int64_t seq, const std::string& state);
  void prune(std::int64_t before);
  std::optional<std::string> state_at(std::int64_t seq) const;
  // Empties the inbox (a new run).
  void clear();
  const std::filesystem::path& path() const { return path_; }

 private:
  void exec(const std::string& sql) const;
  std::filesystem::path path_;
  sqlite3* db_ = nullptr;
};

}  // namespace alc::supervisor
