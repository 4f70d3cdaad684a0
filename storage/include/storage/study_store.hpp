#pragma once
// The rows of a parameter study (alc study) in an ALC database (schema version 4: tables studies and
// study_rows, docs/storage.md). One study per file. Rows are committed as they are given, so a
// killed study keeps every row it finished and --resume continues from them.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace alc::storage {

// What identifies a study: a resumed study or a merged shard must have the same grid, cases and
// program version.
struct StudyHeader {
  std::string grid_json;          // the grid (name, axes, fixed options) as canonical JSON
  std::string cases_json;         // [{"name", "source", "content_hash"}, ...]
  std::string software_version;   // "alc 0.1.0"
  std::string shard = "all";      // "I/N" for a shard, "all" for a whole study
  std::int64_t set_count = 0;     // parameter sets of the grid
};

struct StudyRowRecord {
  std::int64_t set_index = 0;
  std::int64_t case_index = 0;
  bool ok = true;
  std::string error;              // why the run failed (ok == false)
  std::optional<double> pd;       // [%] Eq. 7 (also columns for queries; the report has everything)
  std::optional<double> p99_linear;   // [µm] mean over the linear outputs
  std::optional<double> p99_angular;  // [µm/m]
  std::string report_json;        // alc replay --json of the run; empty when failed
};

class StudyStore {
 public:
  // The study a file holds; nullopt for a file without one (a new file, a history without a study, or
  // the empty file of a study killed before its first commit).
  // Throws StorageError for a file that is not an ALC database.
  static std::optional<StudyHeader> header_of(const std::filesystem::path& file);
  // Whether `file` is the empty file of a study killed before its first commit (no bytes, or an SQLite
  // header without tables): a study may begin there, also under --resume (with nothing to reuse).
  static bool holds_nothing(const std::filesystem::path& file);
  // Every row of the file's study, ordered by set then case.
  static std::vector<StudyRowRecord> rows_of(const std::filesystem::path& file);

  // Opens `file` for writing (created with its directories if missing) and creates the study if it
  // has none. A study already in the file (judged under the write lock, so also one that another
  // process began after the caller's header_of()) is refused with StorageError when `existing` is
  // Refuse, and must be this very one (the same header, field for field) when it is Continue.
  enum class Existing { Refuse, Continue };
  StudyStore(const std::filesystem::path& file, const StudyHeader& header, Existing existing);
  ~StudyStore();
  StudyStore(const StudyStore&) = delete;
  StudyStore& operator=(const StudyStore&) = delete;

  // (set, case) of the rows stored.
  std::set<std::pair<std::int64_t, std::int64_t>> done() const;
  // Adds rows in one transaction; a row already stored is an error (StorageError).
  void add(const std::vector<StudyRowRecord>& rows);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace alc::storage
