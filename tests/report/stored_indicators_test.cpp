// The indicators table of the report is the one `alc replay` prints: a replay with --db stores the
// document `alc replay --json` prints (history schema version 5, run_indicators) and the page shows
// it; a resumed run ends with the same; a run without stored indicators shows the probe-based ones,
// labelled as such.
#include <catch2/catch.hpp>

#include <nlohmann/json.hpp>
#include <sqlite3.h>
#include <string>
#include <vector>

#include "../cli_support.hpp"
#include "report/run_data.hpp"
#include "report_test_support.hpp"
#include "storage/history_reader.hpp"
#include "storage/history_writer.hpp"

using namespace alc;
using namespace alc::report;

namespace {

// Each text between `open` and the next `close` in `text`, in order (plain search: GCC 12's <regex> warns
// under the sanitizer build).
std::vector<std::string> between(const std::string& text, const std::string& open, const std::string& close) {
  std::vector<std::string> out;
  for (auto at = text.find(open); at != std::string::npos; at = text.find(open, at)) {
    const auto from = at + open.size();
    const auto to = text.find(close, from);
    if (to == std::string::npos) break;
    out.push_back(text.substr(from, to - from));
    at = to + close.size();
  }
  return out;
}

// The indicators of the first run of a page, read back from its table and summary line (each number's
// exact value is its cell's data-value): {"source": "replay"|"probes", "summary": {key: value},
// "outputs": {name: {key: value}}, "order": [the rows' outputs]}.
nlohmann::json page_indicators(const std::string& html) {
  nlohmann::json j = {{"summary", nlohmann::json::object()}, {"outputs", nlohmann::json::object()}};
  // data-key="KEY" data-value="VALUE": KEY" data-value="VALUE between data-key=" and the next quote after it.
  const auto pairs = [&](const std::string& text, nlohmann::json& into) {
    const std::string separator = "\" data-value=\"";
    for (const std::string& cell : between(text, "data-key=\"", "\">")) {
      const auto at = cell.find(separator);
      REQUIRE(at != std::string::npos);
      into[cell.substr(0, at)] = nlohmann::json::parse(cell.substr(at + separator.size()));
    }
  };
  const auto summary_at = html.find("<p class=\"summary\" data-indicators=\"");
  REQUIRE(summary_at != std::string::npos);
  const auto source_at = summary_at + std::string("<p class=\"summary\" data-indicators=\"").size();
  j["source"] = html.substr(source_at, html.find('"', source_at) - source_at);
  pairs(html.substr(summary_at, html.find("</p>", summary_at) - summary_at), j["summary"]);
  const auto table_at = html.find("<table class=\"indicators\"");
  REQUIRE(table_at != std::string::npos);
  const std::string table = html.substr(table_at, html.find("</table>", table_at) - table_at);
  for (const std::string& row : between(table, "<tr data-output=\"", "</tr>")) {
    const auto name_end = row.find("\">");
    REQUIRE(name_end != std::string::npos);
    const std::string name = row.substr(0, name_end);
    pairs(row.substr(name_end + 2), j["outputs"][name]);
    j["order"].push_back(name);
  }
  return j;
}

// Every number of `replay` (alc replay --json of one case) equals the page's.
void check_same(const nlohmann::json& page, const nlohmann::json& replay) {
  CHECK(page.at("source") == "replay");
  for (const char* key : {"duration_h", "cp_end_h", "M", "Pd", "ng_phases", "updates", "rejected_fits"}) {
    INFO(key);
    CHECK(page.at("summary").at(key) == replay.at(key));
  }
  REQUIRE(page.at("outputs").size() == replay.at("outputs").size());
  for (const auto& [name, o] : replay.at("outputs").items()) {
    INFO(name);
    const auto& p = page.at("outputs").at(name);
    for (const char* key : {"PV", "RMSE", "P99", "SMAPE", "P99_uncompensated", "measurements"}) {
      INFO(key);
      CHECK(p.at(key) == o.at(key));
    }
    CHECK(p.at("baseline.P99") == replay.at("baseline").at("outputs").at(name).at("P99"));
  }
}

}  // namespace

TEST_CASE("replay --case A --db then report: the page's indicators are alc replay --json's - a resumed run ends with "
          "the same",
          "[report][html][cli]") {
  const test::Scratch scratch("stored");
  const auto& dir = scratch.dir;
  const auto db = dir / "a.sqlite";
  auto r = alc_test::run_alc("replay --case A --json --db \"" + db.string() + "\"", "report_stored");
  REQUIRE(r.exit_code == 0);
  const auto replay = nlohmann::json::parse(r.out);
  const auto page = dir / "a.html";
  r = alc_test::run_alc("report \"" + db.string() + "\" --out \"" + page.string() + "\"", "report_stored");
  REQUIRE(r.exit_code == 0);
  const std::string html = alc_test::slurp(page);
  const nlohmann::json shown = page_indicators(html);
  check_same(shown, replay);
  // Not the probe-based evaluation: that one scores about 100 probes after CP, the replay every
  // recorded measurement (thousands).
  CHECK(shown.at("outputs").at("E_A0C").at("measurements").get<int>() > 1000);
  CHECK(html.find("(from the probes of this history)") == std::string::npos);
  {
    const storage::HistoryReader reader(db);
    CHECK(reader.schema_version() == 5);
    // The rows in the run's output order, as alc replay prints its table.
    CHECK(shown.at("order").get<std::vector<std::string>>() == reader.run(1)->output_names);
    const auto stored = reader.indicators(1);
    REQUIRE(stored);
    CHECK(nlohmann::json::parse(stored->report_json) == replay);
  }

  // Stopped at 50 h (indicators of the part replayed), then resumed to the end: the run ends with the
  // indicators of the uninterrupted replay, and a resume removed the stopped run's ones meanwhile.
  const auto db2 = dir / "resumed.sqlite";
  r = alc_test::run_alc("replay --case A --stop-at 50 --db \"" + db2.string() + "\"", "report_stored");
  REQUIRE(r.exit_code == 0);
  {
    const storage::HistoryReader reader(db2);
    REQUIRE(reader.run(1)->status == storage::RunStatus::Stopped);
    const auto stopped = reader.indicators(1);
    REQUIRE(stopped);
    CHECK(nlohmann::json::parse(stopped->report_json).at("duration_h").get<double>() < 50.0);
  }
  r = alc_test::run_alc("replay --case A --resume --json --db \"" + db2.string() + "\"", "report_stored");
  REQUIRE(r.exit_code == 0);
  CHECK(nlohmann::json::parse(r.out) == replay);
  const storage::HistoryReader reader(db2);
  CHECK(reader.run(1)->status == storage::RunStatus::Finished);
  const auto resumed = reader.indicators(1);
  REQUIRE(resumed);
  CHECK(nlohmann::json::parse(resumed->report_json) == replay);
  check_same(page_indicators(html_report(db2, {})), replay);
}

TEST_CASE("a run without stored indicators: the report shows the probe-based ones, labelled", "[report][html]") {
  const test::Scratch scratch("unstored");
  const auto& dir = scratch.dir;
  const auto h = test::short_history(dir);
  CHECK(page_indicators(html_report(h.db, {})).at("source") == "replay");
  {
    // Resuming removes what the run ended with (as a supervisor run or an unended one: nothing stored).
    storage::HistoryWriter writer(h.db);
    (void)writer.resume_run(h.run);
  }
  REQUIRE_FALSE(storage::HistoryReader(h.db).indicators(h.run));
  const std::string html = html_report(h.db, {});
  const nlohmann::json shown = page_indicators(html);
  CHECK(shown.at("source") == "probes");
  CHECK(html.find("<h3>Indicators (from the probes of this history)</h3>") != std::string::npos);
  CHECK(html.find(">probes evaluated</th>") != std::string::npos);
  // The numbers are history_indicators' (every probe from the end of CP on).
  const storage::HistoryReader reader(h.db);
  const runtime::ReplayReport probes = history_indicators(load_run(reader, h.run));
  CHECK(shown.at("summary").at("M") == probes.M);
  CHECK(shown.at("summary").at("Pd") == probes.Pd);
  for (const auto& o : probes.outputs) {
    INFO(o.name);
    CHECK(shown.at("outputs").at(o.name).at("P99") == o.P99);
    CHECK(shown.at("outputs").at(o.name).at("measurements") == o.measurements);
    CHECK(o.measurements < h.replay.outputs.front().measurements);
  }
}

TEST_CASE("stored indicators that cannot be read: the page says so, not that none are stored, and shows the "
          "probe-based ones",
          "[report][html]") {
  const test::Scratch scratch("unreadable");
  const auto& dir = scratch.dir;
  const auto h = test::short_history(dir);
  const auto page_says = [&](const std::string& why) {
    const std::string html = html_report(h.db, {});
    INFO(why);
    CHECK(page_indicators(html).at("source") == "probes");
    CHECK(html.find("<h3>Indicators (from the probes of this history)</h3>") != std::string::npos);
    // Before: "This history stores no indicators of the run (a supervisor run, … or a file written
    // before schema version 5)", which was false.
    CHECK(html.find("stores no indicators") == std::string::npos);
    CHECK(html.find("The indicators stored for this run cannot be read (" + why + "), so those shown are computed "
                    "from its probes") != std::string::npos);
  };
  {
    // JSON, but not the document alc replay --json prints (the writer takes any JSON).
    storage::HistoryWriter writer(h.db);
    (void)writer.resume_run(h.run);
    writer.store_indicators({h.run, R"({"Pd": 98.5})", 0.0});
    writer.end_run(h.run, storage::RunStatus::Finished);
  }
  page_says("run_indicators.report_json is not a JSON object with &quot;outputs&quot;");
  // Not JSON at all (a damaged row; alc db check reports it).
  sqlite3* db = nullptr;
  REQUIRE(sqlite3_open(h.db.c_str(), &db) == SQLITE_OK);
  CHECK(sqlite3_exec(db, "UPDATE run_indicators SET report_json = '{\"outputs\": {'", nullptr, nullptr, nullptr) ==
        SQLITE_OK);
  sqlite3_close(db);
  page_says("run_indicators.report_json is not JSON");
}
