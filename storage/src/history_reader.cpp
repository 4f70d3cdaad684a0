#include "storage/history_reader.hpp"

#include <algorithm>
#include <nlohmann/json.hpp>
#include <string_view>

#include "common/log.hpp"
#include "record_io.hpp"
#include "sqlite_db.hpp"
#include "storage/storage_error.hpp"

namespace alc::storage {
using detail::Database;
using detail::Statement;

struct HistoryReader::Impl {
  std::filesystem::path file;
  std::unique_ptr<Database> db;
  int version = 0;

  // The number of the run's channels of each kind, which every vector of its rows holds
  // (detail::kAnyCount for a run not on record).
  struct Counts {
    std::size_t inputs = detail::kAnyCount, outputs = detail::kAnyCount, offsets = detail::kAnyCount;
  };
  Counts counts(RunId run) const {
    const auto runs = detail::query_runs(*db, run);
    if (runs.empty()) return {};
    const RunRecord& r = runs.front();
    return {r.input_names.size(), r.output_names.size(), r.offset_names.size()};
  }

  // Runs `sql` with ?1 = run and calls `row` for every result row.
  template <class Row>
  void each(const char* sql, RunId run, Row&& row) const {
    Statement st(*db, sql);
    st.bind(1, run);
    while (st.step()) row(st);
  }
};

HistoryReader::HistoryReader(const std::filesystem::path& path) : impl_(std::make_unique<Impl>()) {
  impl_->file = path;
  impl_->db = detail::open_database(path, {detail::OpenMode::Read, 5000, false}, impl_->version);
  alc::log::get("storage")->info("opened history {} for reading (schema version {})", path.string(), impl_->version);
}

HistoryReader::~HistoryReader() = default;
HistoryReader::HistoryReader(HistoryReader&&) noexcept = default;
HistoryReader& HistoryReader::operator=(HistoryReader&&) noexcept = default;

const std::filesystem::path& HistoryReader::path() const { return impl_->file; }
int HistoryReader::schema_version() const { return impl_->version; }

std::vector<RunRecord> HistoryReader::runs() const { return detail::query_runs(*impl_->db); }

std::optional<RunRecord> HistoryReader::run(RunId id) const {
  auto runs = detail::query_runs(*impl_->db, id);
  if (runs.empty()) return std::nullopt;
  return std::move(runs.front());
}

std::optional<RunRecord> HistoryReader::latest_unfinished_run() const {
  Statement st(*impl_->db,
               "SELECT run_id FROM runs WHERE status IN ('running', 'stopped') ORDER BY run_id DESC LIMIT 1");
  if (!st.step()) return std::nullopt;
  return run(st.column_int(0));
}

std::vector<InputSampleRecord> HistoryReader::input_samples(RunId run) const {
  std::vector<InputSampleRecord> out;
  const auto n = impl_->counts(run);
  impl_->each("SELECT sample_index, time_s, values_f64 FROM input_samples WHERE run_id = ?1 ORDER BY sample_index",
              run, [&](Statement& st) {
                const std::int64_t index = st.column_int(0);
                const double time_s = st.column_double(1);
                const auto where = [&] {
                  return "input_samples: run " + std::to_string(run) + ", sample " + std::to_string(index) +
                         " (time_s " + detail::format_double(time_s) + "): values_f64";
                };
                out.push_back({run, index, time_s,
                               detail::decode_f64(st.column_blob(2), n.inputs, "inputs", impl_->file, where)});
              });
  return out;
}

std::vector<ProbeMeasurementRecord> HistoryReader::probe_measurements(RunId run) const {
  std::vector<ProbeMeasurementRecord> out;
  const auto n = impl_->counts(run);
  impl_->each("SELECT time_s, phase, measured_f64, compensation_f64, weight, probe_id FROM probe_measurements "
              "WHERE run_id = ?1 ORDER BY probe_id",
              run, [&](Statement& st) {
                const double time_s = st.column_double(0);
                const auto where = [&](const char* column) {
                  return [&st, run, time_s, column] {
                    return "probe_measurements: run " + std::to_string(run) + ", probe_id " + st.column_text(5) +
                           " (time_s " + detail::format_double(time_s) + "): " + column;
                  };
                };
                out.push_back({run, time_s, st.column_text(1),
                               detail::decode_f64(st.column_blob(2), n.outputs, "outputs", impl_->file,
                                                  where("measured_f64")),
                               detail::decode_f64(st.column_blob(3), n.outputs, "outputs", impl_->file,
                                                  where("compensation_f64")),
                               st.column_double(4)});
              });
  return out;
}

std::vector<PredictionRecord> HistoryReader::predictions(RunId run) const {
  std::vector<PredictionRecord> out;
  const auto n = impl_->counts(run);
  impl_->each("SELECT time_s, predicted_f64, offsets_f64, prediction_id FROM predictions WHERE run_id = ?1 "
              "ORDER BY prediction_id",
              run, [&](Statement& st) {
                const double time_s = st.column_double(0);
                const auto where = [&](const char* column) {
                  return [&st, run, time_s, column] {
                    return "predictions: run " + std::to_string(run) + ", prediction_id " + st.column_text(3) +
                           " (time_s " + detail::format_double(time_s) + "): " + column;
                  };
                };
                out.push_back({run, time_s,
                               detail::decode_f64(st.column_blob(1), n.outputs, "outputs", impl_->file,
                                                  where("predicted_f64")),
                               detail::decode_f64(st.column_blob(2), n.offsets, "offsets", impl_->file,
                                                  where("offsets_f64"))});
              });
  return out;
}

std::vector<ModelParameterSetRecord> HistoryReader::model_parameter_sets(RunId run) const {
  std::vector<ModelParameterSetRecord> out;
  impl_->each("SELECT time_s, reason, window_start_s, window_end_s, model_order, inputs_chosen_json, usable, adopted, "
              "fit_summary_json, model_json FROM model_parameter_sets WHERE run_id = ?1 ORDER BY model_id",
              run, [&](Statement& st) {
                ModelParameterSetRecord r;
                r.run_id = run;
                r.time_s = st.column_double(0);
                r.reason = st.column_text(1);
                r.window_start_s = st.is_null(2) ? std::numeric_limits<double>::quiet_NaN() : st.column_double(2);
                r.window_end_s = st.is_null(3) ? std::numeric_limits<double>::quiet_NaN() : st.column_double(3);
                r.order = static_cast<int>(st.column_int(4));
                const auto inputs = nlohmann::json::parse(st.column_text(5), nullptr, false);
                if (inputs.is_array())
                  for (const auto& name : inputs)
                    if (name.is_string()) r.inputs_chosen.push_back(name.get<std::string>());
                r.usable = st.column_int(6) != 0;
                r.adopted = st.column_int(7) != 0;
                r.fit_summary_json = st.column_text(8);
                r.model_json = st.column_text(9);
                out.push_back(std::move(r));
              });
  return out;
}

std::vector<PhaseChangeRecord> HistoryReader::phase_changes(RunId run) const {
  std::vector<PhaseChangeRecord> out;
  impl_->each("SELECT time_s, from_phase, to_phase, reason FROM phase_changes WHERE run_id = ?1 ORDER BY phase_change_id",
              run, [&](Statement& st) {
                out.push_back({run, st.column_double(0), st.column_text(1), st.column_text(2), st.column_text(3)});
              });
  return out;
}

std::vector<ProbeIntervalChangeRecord> HistoryReader::probe_interval_changes(RunId run) const {
  std::vector<ProbeIntervalChangeRecord> out;
  impl_->each("SELECT time_s, interval_s, reason FROM probe_interval_changes WHERE run_id = ?1 "
              "ORDER BY interval_change_id",
              run, [&](Statement& st) {
                out.push_back({run, st.column_double(0), st.column_double(1), st.column_text(2)});
              });
  return out;
}

std::vector<NcCommandRecord> HistoryReader::nc_commands(RunId run) const {
  std::vector<NcCommandRecord> out;
  if (impl_->version < 2) return out;  // the table arrived with schema version 2
  // delivered and delivery_message arrived with version 3: an older file reads as not delivered.
  impl_->each(impl_->version < 3
                  ? "SELECT time_s, kind, text, sink, accepted, message, NULL, '' FROM nc_commands "
                    "WHERE run_id = ?1 ORDER BY nc_command_id"
                  : "SELECT time_s, kind, text, sink, accepted, message, delivered, delivery_message FROM nc_commands "
                    "WHERE run_id = ?1 ORDER BY nc_command_id",
              run, [&](Statement& st) {
                out.push_back({run, st.column_double(0), st.column_text(1), st.column_text(2), st.column_text(3),
                               st.column_int(4) != 0, st.column_text(5),
                               st.is_null(6) ? std::nullopt : std::optional<bool>(st.column_int(6) != 0),
                               st.column_text(7)});
              });
  return out;
}

std::vector<ControllerSnapshot> HistoryReader::snapshots(RunId run) const {
  return detail::query_snapshots(*impl_->db, run, false);
}

std::optional<ControllerSnapshot> HistoryReader::latest_snapshot(RunId run) const {
  auto all = detail::query_snapshots(*impl_->db, run, true);
  if (all.empty()) return std::nullopt;
  return std::move(all.front());
}

std::optional<RunIndicatorsRecord> HistoryReader::indicators(RunId run) const {
  if (impl_->version < 5) return std::nullopt;  // the table arrived with schema version 5
  std::optional<RunIndicatorsRecord> out;
  impl_->each("SELECT stored_unix_s, report_json FROM run_indicators WHERE run_id = ?1", run,
              [&](Statement& st) { out = RunIndicatorsRecord{run, st.column_text(1), st.column_double(0)}; });
  return out;
}

namespace {
// Every table of the current schema; those of later versions are skipped when absent.
constexpr const char* kTables[] = {"runs", "run_channels", "input_samples", "probe_measurements", "predictions",
                                   "model_parameter_sets", "phase_changes", "probe_interval_changes",
                                   "nc_commands", "controller_snapshots", "run_indicators", "studies", "study_rows"};
constexpr const char* kTimedTables[] = {"input_samples", "probe_measurements", "predictions", "model_parameter_sets",
                                        "phase_changes", "probe_interval_changes", "nc_commands",
                                        "controller_snapshots"};
}  // namespace

std::vector<TableCount> HistoryReader::table_counts() const {
  std::vector<TableCount> out;
  for (const char* table : kTables) {
    if (!impl_->db->table_exists(table)) continue;
    out.push_back({table, impl_->db->query_int(std::string("SELECT COUNT(*) FROM ") + table)});
  }
  return out;
}

TimeSpan HistoryReader::time_span(RunId run) const {
  TimeSpan span;
  for (const char* table : kTimedTables) {
    if (!impl_->db->table_exists(table)) continue;
    // The snapshot taken before the first sample carries a sentinel time, not a time of the run.
    const bool snapshots = std::string_view(table) == "controller_snapshots";
    Statement st(*impl_->db, std::string("SELECT MIN(time_s), MAX(time_s) FROM ") + table + " WHERE run_id = ?1" +
                                 (snapshots ? " AND time_s != ?2" : ""));
    st.bind(1, run);
    if (snapshots) st.bind(2, kSnapshotBeforeStart_s);
    if (st.step() && !st.is_null(0)) {
      span.first_s = span.empty ? st.column_double(0) : std::min(span.first_s, st.column_double(0));
      span.last_s = span.empty ? st.column_double(1) : std::max(span.last_s, st.column_double(1));
      span.empty = false;
    }
  }
  return span;
}

}  // namespace alc::storage
