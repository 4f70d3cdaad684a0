#include "storage/study_store.hpp"

#include <chrono>
#include <sqlite3.h>

#include "sqlite_db.hpp"
#include "storage/history_tools.hpp"
#include "storage/schema.hpp"
#include <nlohmann/json.hpp>

namespace alc::storage {

namespace {

namespace fs = std::filesystem;

std::unique_ptr<detail::Database> open_read(const fs::path& file) {
  int version = 0;
  return detail::open_database(file, {detail::OpenMode::Read, 5000, false}, version);
}

std::optional<StudyHeader> read_header(detail::Database& db) {
  if (!db.table_exists("studies")) return std::nullopt;
  detail::Statement st(db,
                       "SELECT grid_json, cases_json, software_version, shard, set_count FROM studies "
                       "ORDER BY study_id LIMIT 1");
  if (!st.step()) return std::nullopt;
  StudyHeader h;
  h.grid_json = st.column_text(0);
  h.cases_json = st.column_text(1);
  h.software_version = st.column_text(2);
  h.shard = st.column_text(3);
  h.set_count = st.column_int(4);
  for (const auto& [field, text] : {std::pair<const char*, const std::string*>{"grid_json", &h.grid_json},
                                    {"cases_json", &h.cases_json}})
    if (!nlohmann::json::accept(*text))
      throw StorageError(StorageErrorKind::Corrupt, db.file(), std::string("studies: ") + field + " does not parse as JSON");
  if (const std::string why = study_cases_problem(h.cases_json); !why.empty())
    throw StorageError(StorageErrorKind::Corrupt, db.file(), "studies: cases_json " + why);
  if (h.set_count < 1)
    throw StorageError(StorageErrorKind::Corrupt, db.file(),
                       "studies: set_count " + std::to_string(h.set_count) + " is below 1");
  return h;
}

std::optional<double> optional_double(const detail::Statement& st, int column) {
  if (st.is_null(column)) return std::nullopt;
  return st.column_double(column);
}

}  // namespace

struct StudyStore::Impl {
  std::unique_ptr<detail::Database> db;
  std::optional<detail::Statement> insert;
};

// No bytes, or SQLite's header with no table and no application_id (what a study killed before its
// first commit leaves): open_database's StorageErrorKind::Empty.
bool StudyStore::holds_nothing(const fs::path& file) {
  std::error_code ec;
  if (!fs::exists(file, ec)) return false;
  try {
    open_read(file);
  } catch (const StorageError& e) {
    if (e.kind == StorageErrorKind::Empty) return true;
  }
  return false;
}

std::optional<StudyHeader> StudyStore::header_of(const fs::path& file) {
  std::error_code ec;
  if (!fs::exists(file, ec)) return std::nullopt;
  try {
    auto db = open_read(file);
    return read_header(*db);
  } catch (const StorageError& e) {
    if (e.kind == StorageErrorKind::Empty) return std::nullopt;
    throw;
  }
}

std::vector<StudyRowRecord> StudyStore::rows_of(const fs::path& file) {
  std::unique_ptr<detail::Database> db;
  try {
    db = open_read(file);
  } catch (const StorageError& e) {
    if (e.kind == StorageErrorKind::Empty) return {};
    throw;
  }
  std::vector<StudyRowRecord> rows;
  if (!db->table_exists("study_rows")) return rows;
  // The rows' indices name a set of the grid and a case: the analysis indexes both by them.
  const std::optional<StudyHeader> header = read_header(*db);
  const std::int64_t cases =
      header ? static_cast<std::int64_t>(nlohmann::json::parse(header->cases_json).size()) : 0;
  detail::Statement st(*db,
                       "SELECT set_index, case_index, status, error, pd, p99_linear, p99_angular, report_json "
                       "FROM study_rows ORDER BY set_index, case_index");
  while (st.step()) {
    StudyRowRecord r;
    r.set_index = st.column_int(0);
    r.case_index = st.column_int(1);
    r.ok = st.column_text(2) == "ok";
    r.error = st.column_text(3);
    r.pd = optional_double(st, 4);
    r.p99_linear = optional_double(st, 5);
    r.p99_angular = optional_double(st, 6);
    r.report_json = st.is_null(7) ? std::string() : st.column_text(7);
    if (const std::string why = study_row_problem(r.set_index, r.case_index, header ? header->set_count : 0, cases);
        !why.empty())
      throw StorageError(StorageErrorKind::Corrupt, file,
                         "study_rows: set " + std::to_string(r.set_index) + ", case " + std::to_string(r.case_index) +
                             ": " + why + "; 'alc db check' lists every such row");
    // The analysis and the CSV read every finished row's document: a damaged one is named here.
    if (r.ok)
      if (const std::string why = report_json_problem(r.report_json); !why.empty())
        throw StorageError(StorageErrorKind::Corrupt, file,
                           "study_rows: set " + std::to_string(r.set_index) + ", case " + std::to_string(r.case_index) +
                               ": report_json " + why + "; 'alc db check' lists every such row");
    rows.push_back(std::move(r));
  }
  return rows;
}

StudyStore::StudyStore(const fs::path& file, const StudyHeader& header, Existing existing)
    : impl_(std::make_unique<Impl>()) {
  WriterOptions options;
  options.create_directories = true;
  impl_->db = detail::open_for_writing(file, options);
  auto& db = *impl_->db;
  db.exec("BEGIN IMMEDIATE");
  try {
    // Judged again under the write lock: another process may have begun a study in the file since the
    // caller read header_of() (two shards given one --db, say); its rows must not mix with ours.
    if (const auto stored = read_header(db)) {
      if (existing == Existing::Refuse)
        throw StorageError(StorageErrorKind::InvalidArgument, file,
                           "another process began a study in this file meanwhile; give each run its own --db");
      if (stored->grid_json != header.grid_json || stored->cases_json != header.cases_json ||
          stored->software_version != header.software_version || stored->shard != header.shard ||
          stored->set_count != header.set_count)
        throw StorageError(StorageErrorKind::InvalidArgument, file,
                           "holds another study (grid, cases, shard or version differ) than the one to continue");
    } else {
      const double now = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
      detail::Statement st(db,
                           "INSERT INTO studies (study_id, grid_json, cases_json, software_version, shard, set_count, "
                           "created_unix_s) VALUES (1, ?1, ?2, ?3, ?4, ?5, ?6)");
      st.bind_text(1, header.grid_json).bind_text(2, header.cases_json).bind_text(3, header.software_version);
      st.bind_text(4, header.shard).bind(5, header.set_count).bind(6, now);
      st.run();
    }
    db.exec("COMMIT");
  } catch (...) {
    sqlite3_exec(db.handle(), "ROLLBACK", nullptr, nullptr, nullptr);
    throw;
  }
  impl_->insert.emplace(db,
                        "INSERT INTO study_rows (study_id, set_index, case_index, status, error, pd, p99_linear, "
                        "p99_angular, report_json) VALUES (1, ?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8)");
}

StudyStore::~StudyStore() = default;

std::set<std::pair<std::int64_t, std::int64_t>> StudyStore::done() const {
  std::set<std::pair<std::int64_t, std::int64_t>> d;
  detail::Statement st(*impl_->db, "SELECT set_index, case_index FROM study_rows");
  while (st.step()) d.emplace(st.column_int(0), st.column_int(1));
  return d;
}

void StudyStore::add(const std::vector<StudyRowRecord>& rows) {
  auto& db = *impl_->db;
  auto& st = *impl_->insert;
  const auto bind_optional = [&st](int index, const std::optional<double>& v) {
    if (v) st.bind(index, *v);
    else st.bind_null(index);
  };
  db.exec("BEGIN IMMEDIATE");
  try {
    for (const StudyRowRecord& r : rows) {
      st.bind(1, r.set_index).bind(2, r.case_index).bind_text(3, r.ok ? "ok" : "error").bind_text(4, r.error);
      bind_optional(5, r.pd);
      bind_optional(6, r.p99_linear);
      bind_optional(7, r.p99_angular);
      if (r.ok) st.bind_text(8, r.report_json);
      else st.bind_null(8);
      try {
        st.run();
      } catch (const StorageError& e) {
        // This process found the row missing when it began: another one wrote it since (a SLURM task
        // requeued while the old one still runs, two --resume at once). Said so, not as SQL.
        if (std::string(e.reason).find("UNIQUE") == std::string::npos) throw;
        throw StorageError(StorageErrorKind::Locked, db.file(),
                           "the row of set " + std::to_string(r.set_index) + ", case " + std::to_string(r.case_index) +
                               " was written by another process meanwhile: two studies write this file at once "
                               "(e.g. two --resume); this one stops, the file keeps the other's rows");
      }
    }
    db.exec("COMMIT");
  } catch (...) {
    st.reset();
    sqlite3_exec(db.handle(), "ROLLBACK", nullptr, nullptr, nullptr);
    throw;
  }
}

}  // namespace alc::storage
