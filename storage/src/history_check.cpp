// `alc db check`: SQLite's own checks, then the project's consistency rules (docs/storage.md).
#include <map>
#include <nlohmann/json.hpp>
#include <string>

#include "common/number_text.hpp"
#include "record_io.hpp"
#include "sqlite_db.hpp"
#include "storage/history_tools.hpp"
#include "storage/storage_error.hpp"

namespace alc::storage {
using detail::Database;
using detail::Statement;

namespace {

constexpr int kMaxReported = 20;  // per check, so a broken file does not flood the terminal

// Adds one problem per row of `sql`; the row's columns are joined into `label: c0 c1 …`.
void report_rows(Database& db, std::string_view sql, const std::string& label, CheckReport& report) {
  Statement st(db, sql);
  int n = 0;
  while (st.step()) {
    if (++n > kMaxReported) {
      report.problems.push_back(label + ": more rows not shown");
      break;
    }
    std::string line = label + ":";
    for (int c = 0; c < st.column_count(); ++c) line.append(" ").append(st.column_text(c));
    report.problems.push_back(line);
  }
}

}  // namespace

std::string report_json_problem(const std::string& text) {
  const auto j = nlohmann::json::parse(text, nullptr, false);
  if (j.is_discarded()) return "does not parse as JSON";
  if (!j.is_object()) return "is not a JSON object";
  if (!j.contains("outputs") || !j["outputs"].is_object()) return "has no \"outputs\" object";
  if (!j.contains("M") || !j["M"].is_number_integer()) return "has no whole number \"M\"";
  return {};
}

std::string study_cases_problem(const std::string& cases_json) {
  const auto j = nlohmann::json::parse(cases_json, nullptr, false);
  if (j.is_discarded()) return "does not parse as JSON";
  if (!j.is_array() || j.empty()) return "is not a non-empty JSON array";
  for (std::size_t i = 0; i < j.size(); ++i)
    for (const char* key : {"name", "source", "content_hash"})
      if (!j[i].is_object() || !j[i].contains(key) || !j[i][key].is_string())
        return "case " + std::to_string(i) + " has no string \"" + key + "\"";
  return {};
}

std::string study_row_problem(std::int64_t set_index, std::int64_t case_index, std::int64_t set_count,
                              std::int64_t case_count) {
  if (set_index < 0 || set_index >= set_count)
    return "set_index " + std::to_string(set_index) + " is not one of the study's " + std::to_string(set_count) +
           " parameter sets (0 to " + std::to_string(set_count - 1) + ")";
  if (case_index < 0 || case_index >= case_count)
    return "case_index " + std::to_string(case_index) + " is not one of the study's " + std::to_string(case_count) +
           " cases (0 to " + std::to_string(case_count - 1) + ")";
  return {};
}

CheckReport check_history(const std::filesystem::path& path, const SnapshotCheck& snapshot_check) {
  CheckReport report;
  int version = 0;
  auto db = detail::open_database(path, {detail::OpenMode::Read, 5000, false}, version);

  // SQLite's own checks first. On a damaged file a later check can stop on an unreadable page
  // (SQLITE_CORRUPT): what was found so far is kept and the failure is reported as a problem.
  try {
    Statement st(*db, "PRAGMA integrity_check(50)");
    while (st.step()) {
      const std::string row = st.column_text(0);
      if (row != "ok") report.problems.push_back("integrity_check: " + row);
    }
  } catch (const StorageError& e) {
    if (e.kind != StorageErrorKind::Corrupt && e.kind != StorageErrorKind::NotADatabase) throw;
    report.problems.push_back("integrity_check stopped: " + e.reason);
  }
  // Damaged pages: the foreign-key and project checks would read the same pages and stop on them.
  if (!report.ok()) {
    report.problems.push_back("damaged pages: foreign-key and consistency checks skipped");
    return report;
  }
  try {
    Statement st(*db, "PRAGMA foreign_key_check");
    int n = 0;
    while (st.step() && ++n <= kMaxReported)
      report.problems.push_back("foreign key: table " + st.column_text(0) + " row " + st.column_text(1) +
                                " refers to a missing row of " + st.column_text(2));
  } catch (const StorageError& e) {
    if (e.kind != StorageErrorKind::Corrupt && e.kind != StorageErrorKind::NotADatabase) throw;
    report.problems.push_back("foreign_key_check stopped: " + e.reason);
  }
  if (!report.ok()) return report;

  {
    Statement st(*db, "SELECT run_id, config_json, status, ended_unix_s IS NULL FROM runs ORDER BY run_id");
    while (st.step()) {
      const std::string run = "run " + st.column_text(0);
      if (!nlohmann::json::accept(st.column_text(1))) report.problems.push_back(run + ": configuration is not valid JSON");
      if (st.column_text(2) == "finished" && st.column_int(3) != 0)
        report.problems.push_back(run + ": finished but has no end time");
    }
  }
  report_rows(*db, "SELECT run_id, started_unix_s, ended_unix_s FROM runs WHERE ended_unix_s < started_unix_s",
              "runs: ended before it started (run, started, ended)", report);
  // Every accepted sample is stored with its prediction (one cycle), and a resume pairs them up to its
  // snapshot: a sample or a prediction missing there makes it refuse. Not a gap in the indices: a sample
  // the controller rejected (an input beyond its plausible limit) has an index and no row. Rows after
  // the latest snapshot are not judged: a kill may part a sample from its prediction there, and the
  // resume redoes them. A run that stores no prediction at all (written through the writer's API by
  // another program) has nothing to pair.
  report_rows(*db,
              "SELECT run_id, t, samples, predictions FROM ("
              " SELECT c.run_id, c.time_s AS t,"
              "  (SELECT COUNT(*) FROM input_samples s WHERE s.run_id = c.run_id AND s.time_s <= c.time_s) AS samples,"
              "  (SELECT COUNT(*) FROM predictions p WHERE p.run_id = c.run_id AND p.time_s <= c.time_s) AS predictions"
              " FROM controller_snapshots c WHERE c.next_sample_index > 0 AND c.snapshot_id ="
              "  (SELECT MAX(snapshot_id) FROM controller_snapshots d WHERE d.run_id = c.run_id)"
              ") x WHERE samples != predictions AND EXISTS (SELECT 1 FROM predictions q WHERE q.run_id = x.run_id)",
              "input_samples: samples and predictions up to the latest snapshot differ in number (run, snapshot "
              "time_s, samples, predictions)",
              report);
  report_rows(*db,
              "SELECT run_id, probe_id, phase, weight FROM probe_measurements "
              "WHERE phase NOT IN ('CP', 'Post-CP', 'NG') OR NOT (weight >= 0)",
              "probe_measurements: a phase other than CP, Post-CP, NG or a weight below 0 (run, probe_id, phase, "
              "weight)",
              report);
  // Channel indices of every run and kind are 0..n-1.
  report_rows(*db,
              "SELECT run_id, kind FROM run_channels GROUP BY run_id, kind "
              "HAVING COUNT(*) != MAX(channel_index) + 1 OR MIN(channel_index) != 0",
              "run_channels: channel indices not 0..n-1", report);
  // Vector lengths match the run's channel counts.
  const std::string counts =
      "WITH c AS (SELECT r.run_id, "
      "(SELECT COUNT(*) FROM run_channels k WHERE k.run_id = r.run_id AND k.kind = 'input') AS n_in, "
      "(SELECT COUNT(*) FROM run_channels k WHERE k.run_id = r.run_id AND k.kind = 'output') AS n_out, "
      "(SELECT COUNT(*) FROM run_channels k WHERE k.run_id = r.run_id AND k.kind = 'offset') AS n_off FROM runs r) ";
  report_rows(*db, counts + "SELECT s.run_id, s.sample_index FROM input_samples s JOIN c USING (run_id) "
                            "WHERE length(s.values_f64) != 8 * c.n_in",
              "input_samples: value count differs from the run's inputs (run, sample)", report);
  report_rows(*db, counts + "SELECT p.run_id, p.probe_id FROM probe_measurements p JOIN c USING (run_id) "
                            "WHERE length(p.measured_f64) != 8 * c.n_out OR length(p.compensation_f64) != 8 * c.n_out",
              "probe_measurements: error count differs from the run's outputs (run, probe_id)", report);
  report_rows(*db, counts + "SELECT p.run_id, p.prediction_id FROM predictions p JOIN c USING (run_id) "
                            "WHERE length(p.predicted_f64) != 8 * c.n_out OR length(p.offsets_f64) != 8 * c.n_off",
              "predictions: vector length differs from the run's channels (run, prediction_id)", report);
  // Time order: strictly increasing samples, never decreasing records, per run.
  report_rows(*db,
              "SELECT run_id, sample_index, time_s FROM (SELECT run_id, sample_index, time_s, "
              "LAG(time_s) OVER (PARTITION BY run_id ORDER BY sample_index) AS previous FROM input_samples) "
              "WHERE previous >= time_s",
              "input_samples: time_s not strictly increasing (run, sample, time_s)", report);
  struct Timed {
    const char* table;
    const char* id;
  };
  for (const Timed t : {Timed{"probe_measurements", "probe_id"}, Timed{"predictions", "prediction_id"},
                        Timed{"model_parameter_sets", "model_id"}, Timed{"phase_changes", "phase_change_id"},
                        Timed{"probe_interval_changes", "interval_change_id"}, Timed{"nc_commands", "nc_command_id"}}) {
    if (!db->table_exists(t.table)) continue;
    const std::string table = t.table, id = t.id;
    report_rows(*db,
                "SELECT run_id, " + id + ", time_s FROM (SELECT run_id, " + id + ", time_s, LAG(time_s) OVER "
                "(PARTITION BY run_id ORDER BY " + id + ") AS previous FROM " + table + ") WHERE previous > time_s",
                table + ": time_s decreases (run, id, time_s)", report);
  }
  // A command the safety gate refused is never handed to a sink, so it cannot have been delivered.
  if (version >= 3)
    report_rows(*db, "SELECT run_id, nc_command_id FROM nc_commands WHERE accepted = 0 AND delivered IS NOT NULL",
                "nc_commands: delivered set on a command the safety gate refused (run, nc_command_id)", report);
  // Findings, not problems: a finished run whose accepted commands did not all reach their sink.
  if (version >= 3) {
    Statement st(*db,
                 "SELECT n.run_id, n.sink, COUNT(*), SUM(n.delivered = 0), SUM(n.delivered IS NULL), "
                 "MIN(CASE WHEN n.delivered IS NOT 1 THEN n.time_s END), MAX(CASE WHEN n.delivered IS NOT 1 THEN n.time_s END), "
                 "(SELECT m.delivery_message FROM nc_commands m WHERE m.run_id = n.run_id AND m.sink = n.sink AND "
                 "m.accepted = 1 AND m.delivered = 0 ORDER BY m.nc_command_id LIMIT 1) "
                 "FROM nc_commands n JOIN runs r ON r.run_id = n.run_id WHERE r.status = 'finished' AND n.accepted = 1 "
                 "GROUP BY n.run_id, n.sink HAVING SUM(n.delivered IS NOT 1) > 0 ORDER BY n.run_id, n.sink");
    while (st.step()) {
      const std::int64_t failed = st.column_int(3), unsettled = st.column_int(4);
      std::string line = "nc_commands: run " + st.column_text(0) + " (finished): of its " + st.column_text(2) +
                         " command(s) the safety gate passed to " + st.column_text(1) + ", ";
      if (failed) line += std::to_string(failed) + " not delivered (delivered 0: the sink failed)";
      if (failed && unsettled) line += " and ";
      if (unsettled)
        line += std::to_string(unsettled) + " not settled (delivered NULL: the run stopped before their delivery was "
                "recorded, e.g. killed and resumed without NC output)";
      line += ", time_s " + common::shortest_text(st.column_double(5)) + " to " + common::shortest_text(st.column_double(6));
      if (failed && !st.column_text(7).empty()) line += "; the sink's error: " + st.column_text(7);
      report.findings.push_back(line);
    }
  }
  // The indicators a run ended with (version 5) are the JSON object alc replay --json printed.
  if (version >= 5) {
    // (Its reader, the report, shows a document it cannot read as such; an object with "outputs" is
    // what it needs to show one.)
    Statement st(*db, "SELECT run_id, report_json FROM run_indicators ORDER BY run_id");
    while (st.step()) {
      const auto j = nlohmann::json::parse(st.column_text(1), nullptr, false);
      if (!j.is_object() || !j.contains("outputs"))
        report.problems.push_back("run_indicators: run " + st.column_text(0) +
                                  ": report_json is not a JSON object with \"outputs\"");
    }
  }
  // A study's file (version 4): its header's JSON and each finished row's indicators.
  if (version >= 4) {
    // Per study its number of sets and of cases (-1: cases_json unusable), which bound its rows' indices.
    std::map<std::int64_t, std::pair<std::int64_t, std::int64_t>> sizes;
    Statement studies(*db, "SELECT study_id, grid_json, cases_json, set_count FROM studies ORDER BY study_id");
    while (studies.step()) {
      const std::string id = studies.column_text(0);
      if (!nlohmann::json::accept(studies.column_text(1)))
        report.problems.push_back("studies: study " + id + ": grid_json does not parse");
      const std::string cases = studies.column_text(2);
      const std::string why = study_cases_problem(cases);
      if (!why.empty()) report.problems.push_back("studies: study " + id + ": cases_json " + why);
      const std::int64_t set_count = studies.column_int(3);
      if (set_count < 1)
        report.problems.push_back("studies: study " + id + ": set_count " + std::to_string(set_count) + " is below 1");
      sizes[studies.column_int(0)] = {set_count,
                                      why.empty() ? static_cast<std::int64_t>(nlohmann::json::parse(cases).size()) : -1};
    }
    Statement rows(*db, "SELECT study_id, set_index, case_index, status, report_json FROM study_rows "
                        "ORDER BY study_id, set_index, case_index");
    int shown = 0;
    while (rows.step() && shown < kMaxReported) {
      const std::string row = "study_rows: set " + rows.column_text(1) + ", case " + rows.column_text(2);
      const auto size = sizes.find(rows.column_int(0));
      if (size == sizes.end()) {
        report.problems.push_back(row + ": study_id " + rows.column_text(0) + " names no study");
        ++shown;
        continue;
      }
      std::string why;
      if (size->second.second >= 0)
        why = study_row_problem(rows.column_int(1), rows.column_int(2), size->second.first, size->second.second);
      if (why.empty() && rows.column_text(3) == "ok")
        if (why = report_json_problem(rows.column_text(4)); !why.empty()) why = "report_json " + why;
      if (!why.empty()) {
        report.problems.push_back(row + ": " + why);
        ++shown;
      }
    }
  }
  {
    Statement st(*db, std::string("SELECT ") + detail::kSnapshotColumns + " FROM controller_snapshots");
    while (st.step()) {
      const ControllerSnapshot s = detail::read_snapshot(st);
      const std::string which =
          "controller_snapshots: snapshot " + std::to_string(s.snapshot_id) + " of run " + std::to_string(s.run_id);
      if (s.format.empty()) report.problems.push_back(which + " has no format");
      if (s.is_json && !nlohmann::json::accept(s.payload)) report.problems.push_back(which + ": JSON payload does not parse");
      if (s.next_sample_index < 0) report.problems.push_back(which + ": negative next_sample_index");
      if (snapshot_check)
        if (const std::string why = snapshot_check(s); !why.empty()) report.problems.push_back(which + ": " + why);
    }
  }
  return report;
}

}  // namespace alc::storage
