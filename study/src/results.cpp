#include "study/results.hpp"

#include <cmath>
#include <set>

#include "common/number_text.hpp"
#include "runtime/report_json.hpp"

namespace alc::study {

namespace {

std::string csv_cell(const std::string& text) {
  if (text.find_first_of(",\"\n\r") == std::string::npos) return text;
  std::string q = "\"";
  for (const char c : text) {
    if (c == '"') q += '"';
    q += c;
  }
  return q + "\"";
}

std::string number_cell(const nlohmann::json& v) {
  if (v.is_null()) return {};
  if (v.is_number_integer()) return std::to_string(v.get<long long>());
  const double d = v.get<double>();
  return std::isnan(d) ? std::string() : common::shortest_text(d);
}

std::string number_cell(double d) { return std::isnan(d) ? std::string() : common::shortest_text(d); }

nlohmann::json cases_json(const std::vector<CaseInfo>& cases) {
  nlohmann::json j = nlohmann::json::array();
  for (const CaseInfo& c : cases) j.push_back({{"name", c.name}, {"source", c.source}, {"content_hash", c.content_hash}});
  return j;
}

}  // namespace

storage::StudyHeader StudyInfo::header() const {
  storage::StudyHeader h;
  h.grid_json = grid.canonical().dump();
  h.cases_json = cases_json(cases).dump();
  h.software_version = software_version;
  h.shard = shard;
  h.set_count = static_cast<std::int64_t>(sets.size());
  return h;
}

std::vector<CaseInfo> cases_of(const std::string& cases_json) {
  std::vector<CaseInfo> cases;
  for (const auto& c : nlohmann::json::parse(cases_json))
    cases.push_back({c.at("name").get<std::string>(), c.at("source").get<std::string>(),
                     c.at("content_hash").get<std::string>()});
  return cases;
}

StudyInfo StudyInfo::of(const storage::StudyHeader& h, const std::string& file) {
  StudyInfo info;
  try {
    info.grid = Grid::from_canonical(nlohmann::json::parse(h.grid_json), "stored grid");
    info.sets = info.grid.sets();
    info.cases = cases_of(h.cases_json);
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(file + ": the study's stored grid or cases cannot be read (" + e.what() + ")");
  }
  // The rows are indexed by set: a grid that does not give the study's sets would misname every row.
  if (static_cast<std::int64_t>(info.sets.size()) != h.set_count)
    throw std::runtime_error(file + ": the study's stored grid gives " + std::to_string(info.sets.size()) +
                             " parameter sets, its set_count says " + std::to_string(h.set_count));
  info.software_version = h.software_version;
  info.shard = h.shard;
  return info;
}

std::vector<CaseInfo> case_infos(const std::vector<StudyCase>& cases) {
  std::vector<CaseInfo> infos;
  for (const StudyCase& c : cases) infos.push_back({c.name, c.source, c.content_hash});
  return infos;
}

namespace {

// Two stored cases are one: equal, or both files of one content (the path is how it was reached).
bool same_case(const nlohmann::json& a, const nlohmann::json& b) {
  if (a == b) return true;
  const auto file = [](const nlohmann::json& c) { return c.at("source").get<std::string>().rfind("file ", 0) == 0; };
  return file(a) && file(b) && a.at("content_hash") == b.at("content_hash");
}

}  // namespace

std::vector<std::string> renamed_cases(const storage::StudyHeader& stored, const storage::StudyHeader& now) {
  std::vector<std::string> renamed;
  const auto a = nlohmann::json::parse(stored.cases_json);
  const auto b = nlohmann::json::parse(now.cases_json);
  for (std::size_t i = 0; i < std::min(a.size(), b.size()); ++i)
    if (a[i] != b[i] && same_case(a[i], b[i]))
      renamed.push_back(b[i].at("source").get<std::string>() + " -> " + a[i].at("source").get<std::string>());
  return renamed;
}

std::string difference(const storage::StudyHeader& stored, const storage::StudyHeader& now) {
  if (stored.software_version != now.software_version)
    return "the program version differs: stored '" + stored.software_version + "', now '" + now.software_version + "'";
  if (stored.grid_json != now.grid_json)
    return "the grid differs: stored " + stored.grid_json + ", now " + now.grid_json;
  if (stored.cases_json != now.cases_json) {
    const auto a = nlohmann::json::parse(stored.cases_json);
    const auto b = nlohmann::json::parse(now.cases_json);
    for (std::size_t i = 0; i < std::max(a.size(), b.size()); ++i) {
      const auto describe = [](const nlohmann::json& c) {
        return c.at("source").get<std::string>() + " (content hash " + c.at("content_hash").get<std::string>() + ")";
      };
      if (i >= a.size()) return "the cases differ: now also " + describe(b[i]);
      if (i >= b.size()) return "the cases differ: stored also " + describe(a[i]);
      if (!same_case(a[i], b[i])) return "the cases differ: stored " + describe(a[i]) + ", now " + describe(b[i]);
    }
  }
  if (stored.shard != now.shard) return "the shard differs: stored " + stored.shard + ", now " + now.shard;
  return {};
}

storage::StudyRowRecord record_of(const StudyRow& row) {
  storage::StudyRowRecord r;
  r.set_index = static_cast<std::int64_t>(row.set);
  r.case_index = static_cast<std::int64_t>(row.case_index);
  r.ok = row.report.has_value();
  r.error = row.error;
  if (!row.report) return r;
  const nlohmann::json j = runtime::report_json(*row.report);
  r.report_json = j.dump();
  // The query columns from the stored JSON, as every reader of the row sees them.
  const runtime::ReplayReport back = runtime::report_from_json(j);
  const auto optional = [](double v) { return std::isnan(v) ? std::nullopt : std::optional<double>(v); };
  r.pd = optional(back.Pd);
  r.p99_linear = optional(back.mean_p99(ErrorKind::Linear));
  r.p99_angular = optional(back.mean_p99(ErrorKind::Angular));
  return r;
}

void write_rows_csv(std::ostream& os, const StudyInfo& info, const std::vector<storage::StudyRowRecord>& rows) {
  // Outputs: the union over the rows, in order of first appearance (JSON objects are sorted by name).
  std::vector<std::string> outputs;
  std::vector<nlohmann::json> reports(rows.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    if (!rows[i].ok || rows[i].report_json.empty()) continue;
    reports[i] = nlohmann::json::parse(rows[i].report_json);
    for (const auto& [name, _] : reports[i].at("outputs").items())
      if (std::find(outputs.begin(), outputs.end(), name) == outputs.end()) outputs.push_back(name);
  }
  static const char* kPerOutput[] = {"PV", "RMSE", "P99", "SMAPE", "P99_uncompensated", "measurements"};
  // rejected_samples: the input samples the controller set aside (a row stored before it was in the
  // report leaves the cell empty).
  static const char* kRun[] = {"Pd", "M", "ng_phases", "updates", "rejected_fits", "rejected_samples", "cp_end_h",
                               "duration_h"};
  os << "set,case";
  // The grid's axes, then its [fixed] options (the same value on every row: a CSV read apart from its
  // grid still says what its sets held).
  for (const auto& [axis, _] : info.grid.axes) os << "," << csv_cell(axis);
  for (const auto& [option, _] : info.grid.fixed) os << "," << csv_cell(option);
  os << ",status,error";
  for (const char* f : kRun) os << "," << f;
  os << ",P99_linear,P99_angular,baseline_P99_linear,baseline_P99_angular,uncompensated_P99_linear,"
        "uncompensated_P99_angular";
  for (const std::string& o : outputs)
    for (const char* f : kPerOutput) os << "," << csv_cell(o + "_" + f);
  os << "\n";
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const storage::StudyRowRecord& r = rows[i];
    const auto set = static_cast<std::size_t>(r.set_index);
    const auto c = static_cast<std::size_t>(r.case_index);
    os << r.set_index << "," << csv_cell(c < info.cases.size() ? info.cases[c].name : std::to_string(c));
    for (const auto& [axis, _] : info.grid.axes) os << "," << csv_cell(set < info.sets.size() ? info.sets[set].value(axis) : "");
    for (const auto& [_, value] : info.grid.fixed) os << "," << csv_cell(value);
    os << "," << (r.ok ? "ok" : "error") << "," << csv_cell(r.error);
    const nlohmann::json& j = reports[i];
    if (j.is_null()) {
      for (std::size_t k = 0; k < std::size(kRun) + 6 + outputs.size() * std::size(kPerOutput); ++k) os << ",";
      os << "\n";
      continue;
    }
    for (const char* f : kRun) os << "," << (j.contains(f) ? number_cell(j.at(f)) : std::string());
    const runtime::ReplayReport back = runtime::report_from_json(j);
    os << "," << number_cell(back.mean_p99(ErrorKind::Linear)) << "," << number_cell(back.mean_p99(ErrorKind::Angular))
       << "," << number_cell(back.mean_p99(ErrorKind::Linear, true)) << ","
       << number_cell(back.mean_p99(ErrorKind::Angular, true)) << ","
       << number_cell(back.mean_p99_uncompensated(ErrorKind::Linear)) << ","
       << number_cell(back.mean_p99_uncompensated(ErrorKind::Angular));
    const auto& outs = j.at("outputs");
    for (const std::string& o : outputs)
      for (const char* f : kPerOutput) os << "," << (outs.contains(o) ? number_cell(outs.at(o).at(f)) : std::string());
    os << "\n";
  }
}

}  // namespace alc::study
