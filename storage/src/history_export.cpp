// `alc db export`: one table as CSV; vectors spread into one column per channel name.
#include <algorithm>
#include <map>
#include <set>
#include <ostream>

#include "sqlite_db.hpp"
#include "storage/history_tools.hpp"
#include "storage/storage_error.hpp"

namespace alc::storage {
using detail::Database;
using detail::Statement;

namespace {

enum class Cell { Int, Real, Text, Bool, Vector, Payload };

struct Column {
  const char* sql;      // column of the SELECT (fixed text)
  const char* header;   // CSV header; for a vector the prefix of each channel name
  Cell cell;
  const char* channel;  // for a vector: "input", "output" or "offset"
  int since_version = 1;  // schema version that added the column; an older file exports it empty
};

struct TableSpec {
  const char* table;
  const char* order;
  std::vector<Column> columns;
};

const std::vector<TableSpec>& specs() {
  static const std::vector<TableSpec> all = {
      {"runs", "run_id",
       {{"run_id", "run_id", Cell::Int, nullptr}, {"source", "source", Cell::Text, nullptr},
        {"software_version", "software_version", Cell::Text, nullptr},
        {"started_unix_s", "started_unix_s", Cell::Real, nullptr}, {"ended_unix_s", "ended_unix_s", Cell::Real, nullptr},
        {"status", "status", Cell::Text, nullptr}, {"config_json", "config_json", Cell::Text, nullptr}}},
      {"run_channels", "run_id, kind, channel_index",
       {{"run_id", "run_id", Cell::Int, nullptr}, {"kind", "kind", Cell::Text, nullptr},
        {"channel_index", "channel_index", Cell::Int, nullptr}, {"name", "name", Cell::Text, nullptr}}},
      {"input_samples", "run_id, sample_index",
       {{"run_id", "run_id", Cell::Int, nullptr}, {"sample_index", "sample_index", Cell::Int, nullptr},
        {"time_s", "time_s", Cell::Real, nullptr}, {"values_f64", "", Cell::Vector, "input"}}},
      {"probe_measurements", "run_id, probe_id",
       {{"run_id", "run_id", Cell::Int, nullptr}, {"probe_id", "probe_id", Cell::Int, nullptr},
        {"time_s", "time_s", Cell::Real, nullptr},
        {"phase", "phase", Cell::Text, nullptr}, {"weight", "weight", Cell::Real, nullptr},
        {"measured_f64", "measured_", Cell::Vector, "output"},
        {"compensation_f64", "compensation_", Cell::Vector, "output"}}},
      {"predictions", "run_id, prediction_id",
       {{"run_id", "run_id", Cell::Int, nullptr}, {"prediction_id", "prediction_id", Cell::Int, nullptr},
        {"time_s", "time_s", Cell::Real, nullptr},
        {"predicted_f64", "predicted_", Cell::Vector, "output"}, {"offsets_f64", "offset_", Cell::Vector, "offset"}}},
      {"model_parameter_sets", "run_id, model_id",
       {{"run_id", "run_id", Cell::Int, nullptr}, {"model_id", "model_id", Cell::Int, nullptr},
        {"time_s", "time_s", Cell::Real, nullptr}, {"reason", "reason", Cell::Text, nullptr},
        {"window_start_s", "window_start_s", Cell::Real, nullptr}, {"window_end_s", "window_end_s", Cell::Real, nullptr},
        {"model_order", "model_order", Cell::Int, nullptr}, {"inputs_chosen_json", "inputs_chosen_json", Cell::Text, nullptr},
        {"usable", "usable", Cell::Bool, nullptr}, {"adopted", "adopted", Cell::Bool, nullptr},
        {"fit_summary_json", "fit_summary_json", Cell::Text, nullptr}, {"model_json", "model_json", Cell::Text, nullptr}}},
      {"phase_changes", "run_id, phase_change_id",
       {{"run_id", "run_id", Cell::Int, nullptr}, {"phase_change_id", "phase_change_id", Cell::Int, nullptr},
        {"time_s", "time_s", Cell::Real, nullptr},
        {"from_phase", "from_phase", Cell::Text, nullptr}, {"to_phase", "to_phase", Cell::Text, nullptr},
        {"reason", "reason", Cell::Text, nullptr}}},
      {"probe_interval_changes", "run_id, interval_change_id",
       {{"run_id", "run_id", Cell::Int, nullptr}, {"interval_change_id", "interval_change_id", Cell::Int, nullptr},
        {"time_s", "time_s", Cell::Real, nullptr},
        {"interval_s", "interval_s", Cell::Real, nullptr}, {"reason", "reason", Cell::Text, nullptr}}},
      {"nc_commands", "run_id, nc_command_id",
       {{"run_id", "run_id", Cell::Int, nullptr}, {"nc_command_id", "nc_command_id", Cell::Int, nullptr},
        {"time_s", "time_s", Cell::Real, nullptr},
        {"kind", "kind", Cell::Text, nullptr}, {"text", "text", Cell::Text, nullptr},
        {"sink", "sink", Cell::Text, nullptr}, {"accepted", "accepted", Cell::Bool, nullptr},
        {"message", "message", Cell::Text, nullptr},
        {"delivered", "delivered", Cell::Int, nullptr, 3},  // empty (NULL): not handed to a sink
        {"delivery_message", "delivery_message", Cell::Text, nullptr, 3}}},
      {"controller_snapshots", "run_id, time_s, snapshot_id",
       {{"run_id", "run_id", Cell::Int, nullptr}, {"snapshot_id", "snapshot_id", Cell::Int, nullptr},
        {"time_s", "time_s", Cell::Real, nullptr}, {"next_sample_index", "next_sample_index", Cell::Int, nullptr},
        {"format", "format", Cell::Text, nullptr}, {"is_json", "is_json", Cell::Bool, nullptr},
        {"length(payload)", "payload_bytes", Cell::Int, nullptr},
        {"payload", "payload_json", Cell::Payload, nullptr}}},
      {"run_indicators", "run_id",  // schema version 5; an older file exports the header only
       {{"run_id", "run_id", Cell::Int, nullptr}, {"stored_unix_s", "stored_unix_s", Cell::Real, nullptr},
        {"report_json", "report_json", Cell::Text, nullptr}}},
      {"studies", "study_id",  // a study's file (schema version 4); a history exports the header only
       {{"study_id", "study_id", Cell::Int, nullptr}, {"grid_json", "grid_json", Cell::Text, nullptr},
        {"cases_json", "cases_json", Cell::Text, nullptr}, {"software_version", "software_version", Cell::Text, nullptr},
        {"shard", "shard", Cell::Text, nullptr}, {"set_count", "set_count", Cell::Int, nullptr},
        {"created_unix_s", "created_unix_s", Cell::Real, nullptr}}},
      {"study_rows", "study_id, set_index, case_index",
       {{"study_id", "study_id", Cell::Int, nullptr}, {"set_index", "set_index", Cell::Int, nullptr},
        {"case_index", "case_index", Cell::Int, nullptr}, {"status", "status", Cell::Text, nullptr},
        {"error", "error", Cell::Text, nullptr}, {"pd", "pd", Cell::Real, nullptr},
        {"p99_linear", "p99_linear", Cell::Real, nullptr}, {"p99_angular", "p99_angular", Cell::Real, nullptr},
        {"report_json", "report_json", Cell::Text, nullptr}}},
  };
  return all;
}

// RFC 4180: quote a field holding a comma, quote, CR or LF (or leading/trailing space); double quotes.
void write_field(std::ostream& out, std::string_view text) {
  const bool quote = text.find_first_of(",\"\r\n") != std::string_view::npos ||
                     (!text.empty() && (text.front() == ' ' || text.back() == ' '));
  if (!quote) {
    out << text;
    return;
  }
  out << '"';
  for (char c : text) {
    if (c == '"') out << '"';
    out << c;
  }
  out << '"';
}

// Names of every run's channels of one kind, and their union in order of first appearance.
struct ChannelMap {
  std::vector<std::string> names;                 // union
  std::map<std::int64_t, std::vector<int>> slot;  // run -> union position of each run channel
};

ChannelMap channel_map(Database& db, const char* kind) {
  ChannelMap map;
  Statement st(db, "SELECT run_id, name FROM run_channels WHERE kind = ?1 ORDER BY run_id, channel_index");
  st.bind_text(1, kind);
  while (st.step()) {
    const std::string name = st.column_text(1);
    auto it = std::find(map.names.begin(), map.names.end(), name);
    if (it == map.names.end()) it = map.names.insert(map.names.end(), name);
    map.slot[st.column_int(0)].push_back(static_cast<int>(it - map.names.begin()));
  }
  return map;
}

}  // namespace

const std::vector<std::string>& exportable_tables() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> v;
    for (const auto& s : specs()) v.emplace_back(s.table);
    return v;
  }();
  return names;
}

void export_table_csv(const std::filesystem::path& path, std::string_view table, std::ostream& out) {
  const auto& all = specs();
  const auto spec = std::find_if(all.begin(), all.end(), [&](const TableSpec& s) { return table == s.table; });
  if (spec == all.end()) {
    std::string known;
    for (const auto& name : exportable_tables()) known += (known.empty() ? "" : ", ") + name;
    throw StorageError(StorageErrorKind::InvalidArgument, path,
                       "no table '" + std::string(table) + "' to export; tables: " + known);
  }
  int version = 0;
  auto db = detail::open_database(path, {detail::OpenMode::Read, 5000, false}, version);

  std::map<std::string, ChannelMap> channels;
  for (const Column& c : spec->columns)
    if (c.cell == Cell::Vector && !channels.count(c.channel)) channels[c.channel] = channel_map(*db, c.channel);

  bool first = true;
  auto separator = [&] {
    if (!first) out << ',';
    first = false;
  };
  // A channel that bears a fixed column's name (an input called sample_index) is named by its kind
  // (input_sample_index): a header read by name must not hold a name twice.
  std::set<std::string> fixed;
  for (const Column& c : spec->columns)
    if (c.cell != Cell::Vector) fixed.insert(c.header);
  for (const Column& c : spec->columns) {
    if (c.cell == Cell::Vector) {
      for (const auto& name : channels[c.channel].names) {
        separator();
        const std::string header = c.header + name;
        write_field(out, fixed.count(header) ? std::string(c.channel) + "_" + header : header);
      }
    } else {
      separator();
      write_field(out, c.header);
    }
  }
  out << "\n";
  if (!db->table_exists(spec->table)) return;  // an older schema: header only

  // The run of each row (for its channels); a study's tables have no run.
  const bool per_run = std::any_of(spec->columns.begin(), spec->columns.end(),
                                   [](const Column& c) { return std::string_view(c.sql) == "run_id"; });
  std::string sql = per_run ? "SELECT run_id" : "SELECT 0";
  for (const Column& c : spec->columns) sql += std::string(", ") + (version < c.since_version ? "NULL" : c.sql);
  sql += std::string(" FROM ") + spec->table + " ORDER BY " + spec->order;
  Statement st(*db, sql);
  std::vector<std::string> cells;
  // The row's time, to name a damaged row (every table with vectors has one).
  const auto time_column = std::find_if(spec->columns.begin(), spec->columns.end(),
                                        [](const Column& c) { return std::string_view(c.sql) == "time_s"; });
  // The row's id, the column after run_id (sample_index, probe_id, prediction_id: every table with vectors
  // has one), to name a damaged row in the reader's words ("input_samples: run 1, sample 510 (time_s
  // 30600)"): the id its CSV row shows.
  const std::string id_name = spec->columns.size() < 2 ? std::string()
                              : std::string_view(spec->columns[1].sql) == "sample_index" ? std::string("sample")
                                                                                          : std::string(spec->columns[1].header);
  while (st.step()) {
    const std::int64_t run = st.column_int(0);
    first = true;
    for (std::size_t i = 0; i < spec->columns.size(); ++i) {
      const Column& c = spec->columns[i];
      const int col = static_cast<int>(i) + 1;
      switch (c.cell) {
        case Cell::Int:
          separator();
          if (!st.is_null(col)) out << st.column_int(col);
          break;
        case Cell::Bool:
          separator();
          out << (st.column_int(col) != 0 ? 1 : 0);
          break;
        case Cell::Real:
          separator();
          if (!st.is_null(col)) out << detail::format_double(st.column_double(col));
          break;
        case Cell::Text:
          separator();
          write_field(out, st.column_text(col));
          break;
        case Cell::Payload:  // JSON text as is; binary payloads are not text (see payload_bytes)
          separator();
          if (st.column_int(col - 2) != 0) write_field(out, st.column_blob(col));
          break;
        case Cell::Vector: {
          const ChannelMap& map = channels[c.channel];
          cells.assign(map.names.size(), std::string());
          const auto slots = map.slot.find(run);
          // A blob of another length than the run's channels is refused as the reader refuses it:
          // exported as the values it seemed to hold, a damaged row would look like data.
          const std::vector<double> values = detail::decode_f64(
              st.column_blob(col), slots == map.slot.end() ? detail::kAnyCount : slots->second.size(),
              std::string(c.channel) + "s", path, [&] {
                const std::string time =
                    time_column == spec->columns.end()
                        ? std::string()
                        : " (time_s " + detail::format_double(st.column_double(
                                            static_cast<int>(time_column - spec->columns.begin()) + 1)) + ")";
                return std::string(spec->table) + ": run " + std::to_string(run) + ", " + id_name + " " +
                       std::to_string(st.column_int(2)) + time + ": " + c.sql;
              });
          for (std::size_t k = 0; slots != map.slot.end() && k < values.size() && k < slots->second.size(); ++k)
            cells[static_cast<std::size_t>(slots->second[k])] = detail::format_double(values[k]);
          for (const auto& cell : cells) {
            separator();
            out << cell;
          }
          break;
        }
      }
    }
    out << "\n";
  }
  if (!out) throw StorageError(StorageErrorKind::Io, path, "writing the CSV failed");
}

}  // namespace alc::storage
