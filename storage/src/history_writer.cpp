#include "storage/history_writer.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <thread>
#include <unordered_map>

#include "common/log.hpp"
#include "record_io.hpp"
#include "sqlite_db.hpp"
#include "storage/schema.hpp"
#include "storage/storage_error.hpp"

namespace alc::storage {
using detail::Database;
using detail::Statement;

namespace {

double now_unix_s() {
  using namespace std::chrono;
  return duration<double>(system_clock::now().time_since_epoch()).count();
}

struct ChannelCounts {
  std::size_t inputs = 0;
  std::size_t outputs = 0;
  std::size_t offsets = 0;
};

}  // namespace

std::string WriterOptions::validate() const {
  if (batch_size < 1) return "batch_size must be at least 1, got 0";
  if (busy_timeout_ms < 0) return "busy_timeout_ms must not be negative, got " + std::to_string(busy_timeout_ms);
  if (max_page_count < 0) return "max_page_count must not be negative, got " + std::to_string(max_page_count);
  return {};
}

namespace {

// A writer's claim on its file for its lifetime (flock; released by close() or by the process's end,
// kill -9 included). SQLite's write lock lasts one transaction, and a supervisor commits every sample,
// so a second writer (another alc supervise on the same history) would interleave its rows.
struct WriterClaim {
  int fd = -1;
  WriterClaim() = default;
  WriterClaim(const WriterClaim&) = delete;
  WriterClaim& operator=(const WriterClaim&) = delete;
  ~WriterClaim() { release(); }
  // Waits up to timeout_ms for another writer to close the file, as SQLite waits for its lock.
  void take(const std::filesystem::path& file, int timeout_ms) {
    fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0)
      throw StorageError(StorageErrorKind::Io, file, std::string("cannot open it to claim it: ") + std::strerror(errno));
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
    while (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      const int error = errno;
      if (error == EINTR) continue;
      if (error == EWOULDBLOCK && std::chrono::steady_clock::now() < deadline) {
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
        continue;
      }
      release();
      if (error == EWOULDBLOCK)
        throw StorageError(StorageErrorKind::Locked, file,
                           "another writer has this history open (one writer per file: a second alc supervise or "
                           "alc replay --db on it?); gave up after the busy timeout of " + std::to_string(timeout_ms) +
                               " ms");
      throw StorageError(StorageErrorKind::Io, file, std::string("cannot claim it: ") + std::strerror(error));
    }
  }
  void release() {
    if (fd >= 0) ::close(fd);
    fd = -1;
  }
};

}  // namespace

struct HistoryWriter::Impl {
  WriterOptions options;
  std::filesystem::path file;
  WriterClaim claim;             // declared before the database: released after it is closed
  std::unique_ptr<Database> db;  // declared first: outlives the statements
  std::optional<Statement> insert_sample, insert_probe, insert_prediction, insert_model, insert_phase,
      insert_interval, insert_nc, insert_snapshot, insert_run, insert_channel, insert_indicators;
  bool in_transaction = false;
  std::size_t pending = 0;
  std::uint64_t commits = 0;
  std::unordered_map<RunId, ChannelCounts> channels;

  [[noreturn]] void invalid(const std::string& reason) const {
    throw StorageError(StorageErrorKind::InvalidArgument, file, reason);
  }

  void begin() {
    if (in_transaction) return;
    db->exec("BEGIN IMMEDIATE");
    in_transaction = true;
  }

  // After a failed statement: SQLite may have rolled the transaction back (disk full, I/O);
  // a rejected record (constraint) leaves the transaction open and the rest of the batch intact.
  [[noreturn]] void failed(const StorageError& e) {
    if (e.kind != StorageErrorKind::InvalidArgument && in_transaction) {
      if (!sqlite3_get_autocommit(db->handle())) sqlite3_exec(db->handle(), "ROLLBACK", nullptr, nullptr, nullptr);
      in_transaction = false;
      const std::size_t lost = pending;
      pending = 0;
      throw StorageError(e.kind, e.file,
                         e.reason + "; the " + std::to_string(lost) +
                             " record(s) added since the last commit were not stored, earlier ones are intact");
    }
    throw e;
  }

  template <class BindAndRun>
  void insert(BindAndRun&& bind_and_run) {
    try {
      begin();
      bind_and_run();
    } catch (const StorageError& e) {
      failed(e);
    }
    ++pending;
    if (pending >= options.batch_size) commit();
  }

  void commit() {
    if (!in_transaction) return;
    try {
      db->exec("COMMIT");
    } catch (const StorageError& e) {
      failed(e);
    }
    in_transaction = false;
    pending = 0;
    ++commits;
  }

  const ChannelCounts& counts(RunId run) {
    auto it = channels.find(run);
    if (it != channels.end()) return it->second;
    Statement exists(*db, "SELECT 1 FROM runs WHERE run_id = ?1");
    exists.bind(1, run);
    if (!exists.step()) invalid("run " + std::to_string(run) + " does not exist (call begin_run first)");
    Statement st(*db, "SELECT kind, COUNT(*) FROM run_channels WHERE run_id = ?1 GROUP BY kind");
    st.bind(1, run);
    ChannelCounts c;
    while (st.step()) {
      const std::string kind = st.column_text(0);
      const auto n = static_cast<std::size_t>(st.column_int(1));
      (kind == "input" ? c.inputs : kind == "output" ? c.outputs : c.offsets) = n;
    }
    return channels.emplace(run, c).first->second;
  }

  void check_time(const char* what, double time_s) const {
    if (!std::isfinite(time_s)) invalid(std::string(what) + ": time_s must be finite, got " + std::to_string(time_s));
  }

  void check_size(const char* what, const char* field, std::size_t got, std::size_t want) const {
    if (got != want)
      invalid(std::string(what) + ": " + field + " has " + std::to_string(got) + " values, the run has " +
              std::to_string(want) + " channels");
  }

  void prepare() {
    insert_sample.emplace(*db, "INSERT INTO input_samples (run_id, sample_index, time_s, values_f64) VALUES (?1, ?2, ?3, ?4)");
    insert_probe.emplace(*db,
                         "INSERT INTO probe_measurements (run_id, time_s, phase, measured_f64, compensation_f64, weight) "
                         "VALUES (?1, ?2, ?3, ?4, ?5, ?6)");
    insert_prediction.emplace(*db, "INSERT INTO predictions (run_id, time_s, predicted_f64, offsets_f64) VALUES (?1, ?2, ?3, ?4)");
    insert_model.emplace(*db,
                         "INSERT INTO model_parameter_sets (run_id, time_s, reason, window_start_s, window_end_s, "
                         "model_order, inputs_chosen_json, usable, adopted, fit_summary_json, model_json) "
                         "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11)");
    insert_phase.emplace(*db, "INSERT INTO phase_changes (run_id, time_s, from_phase, to_phase, reason) VALUES (?1, ?2, ?3, ?4, ?5)");
    insert_interval.emplace(*db, "INSERT INTO probe_interval_changes (run_id, time_s, interval_s, reason) VALUES (?1, ?2, ?3, ?4)");
    insert_nc.emplace(*db,
                      "INSERT INTO nc_commands (run_id, time_s, kind, text, sink, accepted, message, delivered, "
                      "delivery_message) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9)");
    insert_snapshot.emplace(*db,
                            "INSERT INTO controller_snapshots (run_id, time_s, next_sample_index, format, is_json, payload) "
                            "VALUES (?1, ?2, ?3, ?4, ?5, ?6)");
    insert_run.emplace(*db,
                       "INSERT INTO runs (source, config_json, software_version, started_unix_s, ended_unix_s, status) "
                       "VALUES (?1, ?2, ?3, ?4, ?5, ?6)");
    insert_channel.emplace(*db, "INSERT INTO run_channels (run_id, kind, channel_index, name) VALUES (?1, ?2, ?3, ?4)");
    insert_indicators.emplace(*db,
                              "INSERT OR REPLACE INTO run_indicators (run_id, stored_unix_s, report_json) VALUES (?1, ?2, ?3)");
  }
};

namespace detail {

std::unique_ptr<Database> open_for_writing(const std::filesystem::path& file, const WriterOptions& options) {
  int version_found = 0;
  auto db = open_database(file, {OpenMode::Write, options.busy_timeout_ms, options.create_directories}, version_found);
  const std::string mode = db->query_text_when_free("PRAGMA journal_mode = WAL");  // a concurrent creator: wait
  if (mode != "wal")
    throw StorageError(StorageErrorKind::Io, file, "cannot switch to the WAL journal (journal_mode is '" + mode + "')");
  db->exec(options.durability == Durability::Power ? "PRAGMA synchronous = FULL" : "PRAGMA synchronous = NORMAL");
  db->exec("PRAGMA foreign_keys = ON");
  if (options.max_page_count > 0) db->exec("PRAGMA max_page_count = " + std::to_string(options.max_page_count));
  db->exec("BEGIN IMMEDIATE");
  try {
    // Read again under the write lock: another process may have created the schema meanwhile.
    const bool ours = db->query_int("PRAGMA application_id") == kApplicationId;
    const int version = ours ? static_cast<int>(db->query_int("PRAGMA user_version")) : 0;
    if (!ours && version_found != 0)
      throw StorageError(StorageErrorKind::ForeignDatabase, file, "application_id changed while opening");
    if (version > kSchemaVersion)
      throw StorageError(StorageErrorKind::NewerSchema, file,
                         "schema version " + std::to_string(version) + " is newer than this alc");
    for (int v = version + 1; v <= kSchemaVersion; ++v) db->exec(migration_sql(v));
    if (version < kSchemaVersion) {
      db->exec("PRAGMA application_id = " + std::to_string(kApplicationId));
      db->exec("PRAGMA user_version = " + std::to_string(kSchemaVersion));
    }
    db->exec("COMMIT");
    if (version == 0)
      alc::log::get("storage")->info("history {}: created schema version {}", file.string(), kSchemaVersion);
    else if (version < kSchemaVersion)
      alc::log::get("storage")->info("history {}: migrated schema version {} to {}", file.string(), version,
                                     kSchemaVersion);
  } catch (...) {
    sqlite3_exec(db->handle(), "ROLLBACK", nullptr, nullptr, nullptr);
    throw;
  }
  return db;
}

}  // namespace detail

HistoryWriter::HistoryWriter(const std::filesystem::path& path, WriterOptions options) : impl_(std::make_unique<Impl>()) {
  impl_->options = options;
  impl_->file = path;
  if (const std::string problem = options.validate(); !problem.empty())
    throw StorageError(StorageErrorKind::InvalidArgument, path, "writer options: " + problem);
  if (options.must_exist) {
    std::error_code ec;
    const auto status = std::filesystem::status(path, ec);  // follows a symbolic link
    if (!std::filesystem::exists(status))
      throw StorageError(StorageErrorKind::NotFound, path,
                         std::filesystem::is_symlink(std::filesystem::symlink_status(path, ec))
                             ? "no history to resume: a symbolic link to nothing"
                             : "no history to resume: the file does not exist");
    if (std::filesystem::is_regular_file(status) && std::filesystem::file_size(path, ec) == 0 && !ec)
      throw StorageError(StorageErrorKind::NotFound, path, "no history to resume: the file is empty");
  }
  // An existing file is claimed first: a writer that has it open (a supervisor) mostly holds a write
  // transaction, and SQLite's lock would answer first, "locked by another connection", where the claim
  // says what it is. Only a regular file (opening a FIFO to claim it would wait for a writer); one the
  // claim cannot open, or anything else, is left to open_for_writing, which names the cause.
  std::error_code regular_error;
  if (std::filesystem::is_regular_file(path, regular_error)) {
    try {
      impl_->claim.take(path, options.busy_timeout_ms);
    } catch (const StorageError& e) {
      if (e.kind == StorageErrorKind::Locked) throw;
    }
  }
  impl_->db = detail::open_for_writing(path, options);
  if (impl_->claim.fd < 0) impl_->claim.take(path, options.busy_timeout_ms);
  impl_->prepare();
  alc::log::get("storage")->info("opened history {} for writing", path.string());
}

HistoryWriter::~HistoryWriter() {
  try {
    close();
  } catch (...) {  // a destructor must not throw; close() reports the same failure to callers that ask
  }
}

HistoryWriter::HistoryWriter(HistoryWriter&&) noexcept = default;
HistoryWriter& HistoryWriter::operator=(HistoryWriter&&) noexcept = default;

HistoryWriter::Impl& HistoryWriter::live() const {
  if (!impl_ || !impl_->db) throw std::logic_error("HistoryWriter used after close() or move");
  return *impl_;
}

RunId HistoryWriter::begin_run(const RunRecord& run) {
  Impl& m = live();
  if (!nlohmann::json::accept(run.config_json))
    m.invalid("run configuration (config_json) is not valid JSON: '" + run.config_json.substr(0, 80) + "'");
  m.commit();
  RunId id = 0;
  m.insert([&] {
    m.insert_run->bind_text(1, run.source)
        .bind_text(2, run.config_json)
        .bind_text(3, run.software_version)
        .bind(4, run.started_unix_s != 0.0 ? run.started_unix_s : now_unix_s());
    if (run.ended_unix_s) m.insert_run->bind(5, *run.ended_unix_s);
    m.insert_run->bind_text(6, to_string(run.status)).run();
    id = sqlite3_last_insert_rowid(m.db->handle());
    const std::pair<const char*, const std::vector<std::string>*> kinds[] = {
        {"input", &run.input_names}, {"output", &run.output_names}, {"offset", &run.offset_names}};
    for (const auto& [kind, names] : kinds)
      for (std::size_t i = 0; i < names->size(); ++i)
        m.insert_channel->bind(1, id).bind_text(2, kind).bind(3, static_cast<std::int64_t>(i)).bind_text(4, (*names)[i]).run();
  });
  m.commit();
  m.channels[id] = ChannelCounts{run.input_names.size(), run.output_names.size(), run.offset_names.size()};
  return id;
}

void HistoryWriter::end_run(RunId run, RunStatus status) {
  Impl& m = live();
  m.commit();
  Statement st(*m.db, "UPDATE runs SET ended_unix_s = ?1, status = ?2 WHERE run_id = ?3");
  st.bind(1, now_unix_s()).bind_text(2, to_string(status)).bind(3, run).run();
  if (sqlite3_changes(m.db->handle()) != 1)
    throw StorageError(StorageErrorKind::NotFound, m.file, "run " + std::to_string(run) + " does not exist");
  ++m.commits;
}

void HistoryWriter::add(const InputSampleRecord& r) {
  Impl& m = live();
  m.check_time("input sample", r.time_s);
  m.check_size("input sample", "values", r.values.size(), m.counts(r.run_id).inputs);
  m.insert([&] {
    m.insert_sample->bind(1, r.run_id).bind(2, r.sample_index).bind(3, r.time_s).bind_blob(4, detail::encode_f64(r.values)).run();
  });
}

void HistoryWriter::add(const ProbeMeasurementRecord& r) {
  Impl& m = live();
  m.check_time("probe measurement", r.time_s);
  const auto& c = m.counts(r.run_id);
  m.check_size("probe measurement", "measured", r.measured.size(), c.outputs);
  m.check_size("probe measurement", "compensation", r.compensation.size(), c.outputs);
  if (!std::isfinite(r.weight)) m.invalid("probe measurement: weight must be finite");
  m.insert([&] {
    m.insert_probe->bind(1, r.run_id).bind(2, r.time_s).bind_text(3, r.phase)
        .bind_blob(4, detail::encode_f64(r.measured)).bind_blob(5, detail::encode_f64(r.compensation))
        .bind(6, r.weight).run();
  });
}

void HistoryWriter::add(const PredictionRecord& r) {
  Impl& m = live();
  m.check_time("prediction", r.time_s);
  const auto& c = m.counts(r.run_id);
  m.check_size("prediction", "predicted", r.predicted.size(), c.outputs);
  m.check_size("prediction", "offsets", r.offsets.size(), c.offsets);
  m.insert([&] {
    m.insert_prediction->bind(1, r.run_id).bind(2, r.time_s).bind_blob(3, detail::encode_f64(r.predicted))
        .bind_blob(4, detail::encode_f64(r.offsets)).run();
  });
}

void HistoryWriter::add(const ModelParameterSetRecord& r) {
  Impl& m = live();
  m.check_time("model parameter set", r.time_s);
  m.counts(r.run_id);
  if (!nlohmann::json::accept(r.fit_summary_json)) m.invalid("model parameter set: fit_summary_json is not valid JSON");
  if (!nlohmann::json::accept(r.model_json)) m.invalid("model parameter set: model_json is not valid JSON");
  const std::string inputs = nlohmann::json(r.inputs_chosen).dump();
  m.insert([&] {
    auto& st = *m.insert_model;
    st.bind(1, r.run_id).bind(2, r.time_s).bind_text(3, r.reason);
    // NaN would be stored as NULL anyway; ±inf (an unbounded window) is kept.
    if (!std::isnan(r.window_start_s)) st.bind(4, r.window_start_s);
    if (!std::isnan(r.window_end_s)) st.bind(5, r.window_end_s);
    st.bind(6, r.order).bind_text(7, inputs).bind(8, r.usable).bind(9, r.adopted)
        .bind_text(10, r.fit_summary_json).bind_text(11, r.model_json).run();
  });
}

void HistoryWriter::add(const PhaseChangeRecord& r) {
  Impl& m = live();
  m.check_time("phase change", r.time_s);
  m.counts(r.run_id);
  m.insert([&] {
    m.insert_phase->bind(1, r.run_id).bind(2, r.time_s).bind_text(3, r.from_phase).bind_text(4, r.to_phase)
        .bind_text(5, r.reason).run();
  });
}

void HistoryWriter::add(const ProbeIntervalChangeRecord& r) {
  Impl& m = live();
  m.check_time("probe interval change", r.time_s);
  if (std::isnan(r.interval_s) || r.interval_s <= 0)
    m.invalid("probe interval change: interval_s must be positive (or +inf), got " + std::to_string(r.interval_s));
  m.counts(r.run_id);
  m.insert([&] {
    m.insert_interval->bind(1, r.run_id).bind(2, r.time_s).bind(3, r.interval_s).bind_text(4, r.reason).run();
  });
}

void HistoryWriter::add(const NcCommandRecord& r) {
  Impl& m = live();
  m.check_time("NC command", r.time_s);
  if (r.delivered && !r.accepted)
    m.invalid("NC command: delivered is set, but the safety gate refused the command (nothing is handed to a sink)");
  m.counts(r.run_id);
  m.insert([&] {
    auto& st = *m.insert_nc;
    st.bind(1, r.run_id).bind(2, r.time_s).bind_text(3, r.kind).bind_text(4, r.text)
        .bind_text(5, r.sink).bind(6, r.accepted).bind_text(7, r.message);
    if (r.delivered) st.bind(8, *r.delivered);  // unbound: NULL, not handed to a sink (yet)
    st.bind_text(9, r.delivery_message).run();
  });
}

std::size_t HistoryWriter::record_delivery(RunId run, const std::string& sink, bool delivered,
                                           const std::string& message) {
  Impl& m = live();
  m.counts(run);
  m.commit();  // the rows of the pending batch must exist before they are updated
  Statement st(*m.db,
               "UPDATE nc_commands SET delivered = ?1, delivery_message = ?2 "
               "WHERE run_id = ?3 AND sink = ?4 AND accepted != 0 AND delivered IS NULL");
  st.bind(1, delivered).bind_text(2, message).bind(3, run).bind_text(4, sink).run();
  ++m.commits;
  return static_cast<std::size_t>(sqlite3_changes(m.db->handle()));
}

void HistoryWriter::store_indicators(const RunIndicatorsRecord& r) {
  Impl& m = live();
  m.counts(r.run_id);
  if (!nlohmann::json::accept(r.report_json))
    m.invalid("run indicators: report_json is not valid JSON: '" + r.report_json.substr(0, 80) + "'");
  m.insert([&] {
    m.insert_indicators->bind(1, r.run_id).bind(2, r.stored_unix_s != 0.0 ? r.stored_unix_s : now_unix_s())
        .bind_text(3, r.report_json).run();
  });
}

void HistoryWriter::save_snapshot(const ControllerSnapshot& s) {
  Impl& m = live();
  m.check_time("controller snapshot", s.time_s);
  m.counts(s.run_id);
  if (s.format.empty()) m.invalid("controller snapshot: format must name the payload's format and version");
  if (s.is_json && !nlohmann::json::accept(s.payload)) m.invalid("controller snapshot: payload is not valid JSON");
  if (s.next_sample_index < 0) m.invalid("controller snapshot: next_sample_index must not be negative");
  m.insert([&] {
    m.insert_snapshot->bind(1, s.run_id).bind(2, s.time_s).bind(3, s.next_sample_index).bind_text(4, s.format)
        .bind(5, s.is_json).bind_blob(6, s.payload).run();
  });
  m.commit();
}

std::int64_t HistoryWriter::prune_samples(RunId run, std::int64_t before_index, double before_time_s) {
  Impl& m = live();
  m.counts(run);
  m.commit();
  std::int64_t deleted = 0;
  m.db->exec("BEGIN IMMEDIATE");
  try {
    Statement samples(*m.db, "DELETE FROM input_samples WHERE run_id = ?1 AND sample_index < ?2 AND time_s < ?3");
    samples.bind(1, run).bind(2, before_index).bind(3, before_time_s).run();
    deleted += sqlite3_changes(m.db->handle());
    Statement predictions(*m.db, "DELETE FROM predictions WHERE run_id = ?1 AND time_s < ?2");
    predictions.bind(1, run).bind(2, before_time_s).run();
    deleted += sqlite3_changes(m.db->handle());
    m.db->exec("COMMIT");
  } catch (...) {
    sqlite3_exec(m.db->handle(), "ROLLBACK", nullptr, nullptr, nullptr);
    throw;
  }
  ++m.commits;
  return deleted;
}

void HistoryWriter::commit() { live().commit(); }

ResumePoint HistoryWriter::resume_run(RunId run, const SnapshotCheck& usable, const SnapshotCheck& restorable) {
  Impl& m = live();
  m.commit();
  auto runs = detail::query_runs(*m.db, run);
  if (runs.empty()) throw StorageError(StorageErrorKind::NotFound, m.file, "run " + std::to_string(run) + " does not exist");
  auto snapshots = detail::query_snapshots(*m.db, run, !usable);
  if (snapshots.empty())
    throw StorageError(StorageErrorKind::NotFound, m.file,
                       "run " + std::to_string(run) + " has no controller snapshot to resume from");
  // The latest snapshot the caller can use; the damaged ones after it are named.
  std::vector<std::string> skipped;
  auto chosen = snapshots.rend();
  for (auto it = snapshots.rbegin(); it != snapshots.rend(); ++it) {
    const std::string why = usable ? usable(*it) : std::string();
    if (why.empty()) {
      chosen = it;
      break;
    }
    skipped.push_back("snapshot " + std::to_string(it->snapshot_id) + " at time_s " + std::to_string(it->time_s) +
                      ": " + why);
  }
  if (chosen == snapshots.rend()) {
    std::string all;
    for (const std::string& s : skipped) all += (all.empty() ? "" : "; ") + s;
    throw StorageError(StorageErrorKind::Corrupt, m.file,
                       "run " + std::to_string(run) + " has no usable controller snapshot to resume from: " + all);
  }
  ResumePoint point{std::move(runs.front()), std::move(*chosen), std::move(skipped)};
  // The snapshot before the first sample (next_sample_index 0, sentinel time) keeps nothing of the run.
  const double t = point.snapshot.next_sample_index == 0 ? -std::numeric_limits<double>::infinity()
                                                         : point.snapshot.time_s;
  // What the resume keeps must pair every sample with its prediction (the replay rebuilds its evaluation
  // from them): judged before anything is deleted, so a resume that must fail changes nothing.
  {
    Statement kept(*m.db,
                   "SELECT (SELECT COUNT(*) FROM input_samples WHERE run_id = ?1 AND sample_index < ?2 AND time_s <= ?3),"
                   " (SELECT COUNT(*) FROM predictions WHERE run_id = ?1 AND time_s <= ?3),"
                   " EXISTS (SELECT 1 FROM predictions WHERE run_id = ?1)");
    kept.bind(1, run).bind(2, point.snapshot.next_sample_index).bind(3, t);
    if (kept.step() && kept.column_int(2) != 0 && kept.column_int(0) != kept.column_int(1))
      throw StorageError(StorageErrorKind::Corrupt, m.file,
                         "run " + std::to_string(run) + " stores " + std::to_string(kept.column_int(0)) +
                             " samples and " + std::to_string(kept.column_int(1)) +
                             " predictions up to its snapshot " + std::to_string(point.snapshot.snapshot_id) +
                             " (each sample is stored with its prediction): rows were deleted or damaged; nothing "
                             "was changed ('alc db check' names the run)");
  }
  if (restorable)
    if (const std::string why = restorable(point.snapshot); !why.empty())
      throw StorageError(StorageErrorKind::Corrupt, m.file,
                         "run " + std::to_string(run) + " cannot be resumed from its snapshot " +
                             std::to_string(point.snapshot.snapshot_id) + ": " + why + "; nothing was changed");
  m.insert([&] {
    // Everything after the snapshot is redone by the resumed run; table names are fixed text.
    for (const char* table : {"probe_measurements", "predictions", "model_parameter_sets", "phase_changes",
                              "probe_interval_changes", "nc_commands"}) {
      Statement del(*m.db, std::string("DELETE FROM ") + table + " WHERE run_id = ?1 AND time_s > ?2");
      del.bind(1, run).bind(2, t).run();
    }
    Statement samples(*m.db, "DELETE FROM input_samples WHERE run_id = ?1 AND (sample_index >= ?2 OR time_s > ?3)");
    samples.bind(1, run).bind(2, point.snapshot.next_sample_index).bind(3, t).run();
    Statement indicators(*m.db, "DELETE FROM run_indicators WHERE run_id = ?1");  // of the run's earlier end
    indicators.bind(1, run).run();
    // Snapshots in the order written (the snapshot before the first sample has a sentinel time).
    Statement later(*m.db, "DELETE FROM controller_snapshots WHERE run_id = ?1 AND snapshot_id > ?2");
    later.bind(1, run).bind(2, point.snapshot.snapshot_id).run();
    Statement status(*m.db, "UPDATE runs SET status = 'running', ended_unix_s = NULL WHERE run_id = ?1");
    status.bind(1, run).run();
  });
  m.commit();
  point.run.status = RunStatus::Running;
  point.run.ended_unix_s.reset();
  return point;
}

void HistoryWriter::close() {
  if (!impl_ || !impl_->db) return;
  impl_->commit();
  impl_->insert_sample.reset();
  impl_->insert_probe.reset();
  impl_->insert_prediction.reset();
  impl_->insert_model.reset();
  impl_->insert_phase.reset();
  impl_->insert_interval.reset();
  impl_->insert_nc.reset();
  impl_->insert_snapshot.reset();
  impl_->insert_run.reset();
  impl_->insert_channel.reset();
  impl_->insert_indicators.reset();
  impl_->db.reset();
  impl_->claim.release();
}

const std::filesystem::path& HistoryWriter::path() const { return impl_->file; }
std::size_t HistoryWriter::pending() const { return impl_ ? impl_->pending : 0; }
std::uint64_t HistoryWriter::transactions_committed() const { return impl_ ? impl_->commits : 0; }

}  // namespace alc::storage
