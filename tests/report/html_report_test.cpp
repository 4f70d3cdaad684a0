// The report page without a browser: its structure for a short history, the indicators recomputed
// from the history against the replay's, and the refusals (not a history, unknown --run).
#include <catch2/catch.hpp>

#include <cmath>
#include <fstream>
#include <regex>
#include <sqlite3.h>
#include <string>

#include "../cli_support.hpp"
#include "common/utf8.hpp"
#include "report/run_data.hpp"
#include "report/svg_chart.hpp"
#include "report_test_support.hpp"
#include "storage/history_reader.hpp"
#include "storage/storage_error.hpp"

using namespace alc;
using namespace alc::report;


TEST_CASE("report page of a short history: every chart - phases - updates - refused command - tables", "[report][html]") {
  const test::Scratch scratch("html");
  const auto& dir = scratch.dir;
  const auto h = test::short_history(dir);
  ReportStats stats;
  const std::string html = html_report(h.db, {}, &stats);
  const storage::HistoryReader reader(h.db);
  const RunData d = load_run(reader, h.run);
  const std::size_t outputs = d.run.output_names.size();
  REQUIRE(outputs == 7);
  // Per output an error and a residual chart; inputs in °C and rpm; probe interval and Pd; offsets in
  // µm and µrad.
  const std::size_t charts = 2 * outputs + 2 + 2 + 2;
  CHECK(stats.runs == 1);
  CHECK(stats.charts == charts);
  CHECK(test::count(html, "<svg class=\"alc-chart\"") == charts);
  CHECK(test::count(html, "<path class=\"series") == stats.series);
  // Each probe is a point of its output's measured series and of its residual series.
  CHECK(test::count(html, "data-name=\"measured (probes)\" data-style=\"points\" data-points=\"" +
                        std::to_string(d.probes.size()) + "\"") == outputs);
  // The prediction (one per minute) is reduced for display, never below one point per pixel column.
  CHECK(d.predictions.size() > 2 * 888);
  CHECK(test::count(html, "data-source-points=\"" + std::to_string(d.predictions.size()) + "\"") >= outputs);
  // Phases shaded (CP, NG, Post-CP) on every error chart; every fit marked.
  CHECK(test::count(html, "class=\"span span-CP\"") >= 2 * outputs);
  CHECK(test::count(html, "class=\"span span-NG\"") >= 2 * outputs);
  std::size_t adopted = 0;
  for (const auto& m : d.models) adopted += m.adopted;
  CHECK(adopted > 0);
  // Each fit on both charts of every output: as lines, or, beyond kMarkersAsLines per chart, as one path
  // that says how many it draws.
  std::size_t update_markers = test::count(html, "<line class=\"marker marker-update\"");
  const std::regex drawn("<path class=\"marker marker-update(?: marker-ticks)?\" data-markers=\"([0-9]+)\"");
  for (auto it = std::sregex_iterator(html.begin(), html.end(), drawn); it != std::sregex_iterator(); ++it)
    update_markers += std::stoul((*it)[1].str());
  CHECK(update_markers == 2 * outputs * adopted);
  CHECK(test::count(html, "class=\"hband\"") == outputs);  // the ACL band on each residual chart
  // Offsets: the refused command is a red line on both offset charts and a row with its reason.
  CHECK(test::count(html, "class=\"marker marker-refused\"") == 2);
  CHECK(html.find("exceeds the limit of 50 µm") != std::string::npos);
  CHECK(test::count(html, "class=\"marker marker-sent") > 0);
  // Units on every axis: each y label carries [unit], each x axis is time [h].
  CHECK(test::count(html, ">time [h]</text>") == charts);
  CHECK(html.find(">E_X0C [µm]</text>") != std::string::npos);
  CHECK(html.find(">E_A0C [µm/m]</text>") != std::string::npos);
  CHECK(html.find(">temperatures [°C]</text>") != std::string::npos);
  CHECK(html.find(">interval [min]</text>") != std::string::npos);
  CHECK(html.find(">Pd [%]</text>") != std::string::npos);
  // Tables: indicators (a row per output) and parameters.
  CHECK(test::count(html, "<tr data-output=\"E_") == outputs);
  CHECK(html.find("<td>parameters.acl_linear_um</td><td>2.5</td>") != std::string::npos);
  // Self-contained: nothing to fetch.
  CHECK(html.find("<link") == std::string::npos);
  CHECK(html.find(" src=") == std::string::npos);
  CHECK(html.find("url(http") == std::string::npos);
  CHECK(html.find("@import") == std::string::npos);
}

TEST_CASE("report page: commands the gate passed but not delivered or not settled are counted, said and marked apart",
          "[report][html]") {
  const test::Scratch scratch("undelivered");
  const auto& dir = scratch.dir;
  const auto h = test::short_history(dir);
  std::size_t passed = 0;
  for (const auto& c : load_run(storage::HistoryReader(h.db), h.run).nc_commands) passed += c.kind == "offsets" && c.accepted;
  REQUIRE(passed >= 6);
  test::mark_undelivered(h.db, 3, 2);
  const std::string html = html_report(h.db, {});
  const std::string delivered = std::to_string(passed - 5);
  // Counted (also as data for a reader of the page) and said in words, with the sink's error.
  CHECK(html.find("<p class=\"nc-undelivered\" data-passed=\"" + std::to_string(passed) + "\" data-delivered=\"" +
                  delivered + "\" data-not-delivered=\"3\" data-not-settled=\"2\"><strong>5 of the " +
                  std::to_string(passed) + " offset commands the safety gate passed are not recorded as delivered to the NC</strong>: 3 not "
                  "delivered (delivered 0: the sink failed: cannot create nc: Not a directory); 2 not settled") !=
        std::string::npos);
  CHECK(html.find("that were delivered to the NC (" + delivered + "); orange: passed but not delivered, the sink "
                  "failed (3); purple: passed but not settled, no delivery recorded (2); red lines: refused commands (1)") !=
        std::string::npos);
  // Marked on both offset charts (µm, µrad), one marker per command, each in its own kind, and keyed.
  CHECK(test::count(html, "<line class=\"marker marker-undelivered\"") == 2 * 3);
  CHECK(test::count(html, "<line class=\"marker marker-unsettled\"") == 2 * 2);
  CHECK(test::count(html, "NOT delivered: cannot create nc: Not a directory</title>") == 2 * 3);
  CHECK(test::count(html, "not settled (no delivery recorded)</title>") == 2 * 2);
  CHECK(test::count(html, "<i class=\"marker-key marker-key-undelivered\"></i>passed, NOT delivered (3)") == 2);
  CHECK(test::count(html, "<i class=\"marker-key marker-key-unsettled\"></i>passed, not settled (2)") == 2);
  CHECK(test::count(html, "<i class=\"marker-key marker-key-sent\"></i>passed, delivered (" + delivered + ")") == 2);
  // Delivered ones are no longer "passed to the NC" without a word on delivery.
  CHECK(html.find("passed to the NC") == std::string::npos);

  // None delivered (a --nc-out that could not be written): the page says none reached the NC.
  test::mark_undelivered(h.db, static_cast<int>(passed), 0);
  const std::string none = html_report(h.db, {});
  CHECK(none.find("<strong>None of the " + std::to_string(passed) +
                  " offset commands the safety gate passed is recorded as delivered to the NC</strong>: " + std::to_string(passed) +
                  " not delivered") != std::string::npos);
  CHECK(test::count(none, "class=\"marker marker-sent") == 0);
  CHECK(test::count(none, "<i class=\"marker-key marker-key-sent\"") == 0);
  // A history whose commands were all delivered has no such note.
  std::filesystem::create_directories(dir / "whole");
  const auto whole = test::short_history(dir / "whole");
  CHECK(html_report(whole.db, {}).find("<p class=\"nc-undelivered\"") == std::string::npos);
}

TEST_CASE("indicators from the history: M - Pd - CP end - NG phases - updates as the replay's - P99 over the probes",
          "[report][html]") {
  const test::Scratch scratch("indicators");
  const auto& dir = scratch.dir;
  const auto h = test::short_history(dir);
  const storage::HistoryReader reader(h.db);
  const RunData d = load_run(reader, h.run);
  const runtime::ReplayReport r = history_indicators(d);
  CHECK(r.M == h.replay.M);
  CHECK(r.Pd == h.replay.Pd);
  CHECK(r.cp_end_s == h.replay.cp_end_s);
  CHECK(r.ng_phases == h.replay.ng_phases);
  CHECK(r.updates == h.replay.updates);
  CHECK(r.rejected_fits == h.replay.rejected_fits);
  CHECK(r.duration_s == h.replay.duration_s);
  REQUIRE(r.outputs.size() == h.replay.outputs.size());
  // Evaluated on the probes from the end of CP on (the replay also counts unprobed measurements).
  int probes_after_cp = 0;
  for (const auto& p : d.probes) probes_after_cp += p.time_s >= r.cp_end_s;
  for (std::size_t k = 0; k < r.outputs.size(); ++k) {
    CHECK(r.outputs[k].measurements == probes_after_cp);
    CHECK(r.outputs[k].measurements < h.replay.outputs[k].measurements);
    CHECK(std::isfinite(r.outputs[k].P99));
    CHECK(std::isfinite(r.baseline[k].P99));
  }
  // One output by hand: P99 of |error - prediction in force| over those probes.
  std::vector<double> measured, predicted;
  for (const auto& p : d.probes)
    if (p.time_s >= r.cp_end_s) {
      measured.push_back(probe_error(p, 0));
      predicted.push_back(prediction_at(d, p.time_s)->predicted[0]);
    }
  CHECK(r.outputs[0].P99 == runtime::evaluate_output("E_X0C", measured, predicted).P99);
}

TEST_CASE("report refuses a file that is not a history and an unknown run - naming them", "[report][html]") {
  const test::Scratch scratch("refusals");
  const auto& dir = scratch.dir;
  const auto text = dir / "notes.txt";
  std::ofstream(text) << "not a database\n";
  CHECK_THROWS_AS(html_report(text, {}), storage::StorageError);
  const auto h = test::short_history(dir);
  ReportOptions o;
  o.runs = {1, 42};
  try {
    (void)html_report(h.db, o);
    FAIL("no error for run 42");
  } catch (const UnknownRun& e) {
    const std::string m = e.what();
    CHECK(m.find(h.db.string()) != std::string::npos);
    CHECK(m.find("no run 42") != std::string::npos);
    CHECK(m.find("its runs: 1") != std::string::npos);
  }
}

TEST_CASE("alc report: writes the page - not a history - a missing file or an unknown --run exit 2 naming it",
          "[report][cli]") {
  const test::Scratch scratch("cli");
  const auto& dir = scratch.dir;
  const auto h = test::short_history(dir);
  const auto out = dir / "page.html";
  auto r = alc_test::run_alc("report \"" + h.db.string() + "\" --run 1 --out \"" + out.string() + "\"", "report_cli");
  CHECK(r.exit_code == 0);
  CHECK(r.out.find(out.string()) != std::string::npos);
  CHECK(alc_test::slurp(out).find("<section class=\"run\" id=\"run-1\"") != std::string::npos);

  r = alc_test::run_alc("report \"" + h.db.string() + "\" --run 7 --out \"" + out.string() + "\"", "report_cli");
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("no run 7") != std::string::npos);
  CHECK(r.err.find(h.db.string()) != std::string::npos);

  const auto text = dir / "table.csv";
  std::ofstream(text) << "time_s,E_X0C\n0,1\n";
  r = alc_test::run_alc("report \"" + text.string() + "\" --out \"" + out.string() + "\"", "report_cli");
  CHECK(r.exit_code == 2);
  CHECK(r.err.find(text.string()) != std::string::npos);
  CHECK(r.err.find("not an SQLite database") != std::string::npos);

  r = alc_test::run_alc("report \"" + (dir / "missing.sqlite").string() + "\"", "report_cli");
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("missing.sqlite") != std::string::npos);

  // An empty --out (refused for every option, cli/main.cpp): before, "cannot rename '.tmp.NNN.0' into place".
  r = alc_test::run_alc("report \"" + h.db.string() + "\" --out ''", "report_cli");
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("--out: the value is empty") != std::string::npos);
  CHECK(r.err.find("rename") == std::string::npos);

  r = alc_test::run_alc("report \"" + h.db.string() + "\" --run x", "report_cli");
  CHECK(r.exit_code == 2);
  // The strict reader of whole numbers: not "0x10" as run 16, not a huge number clamped.
  for (const std::string bad : {"0x10", "1.5", "99999999999999999999", "0"}) {
    r = alc_test::run_alc("report \"" + h.db.string() + "\" --run " + bad, "report_cli");
    INFO(bad << ": " << r.err);
    CHECK(r.exit_code == 2);
    CHECK(r.err.find("--run: '" + bad + "' is not a whole number") != std::string::npos);
  }
}

TEST_CASE("report of a study file: the study's Pareto front of each case and its heat maps of P99 and Pd",
          "[report][html][cli]") {
  const test::Scratch scratch("study");
  const auto& dir = scratch.dir;
  const auto db = test::small_study(dir, "report_study");
  ReportStats stats;
  const std::string html = html_report(db, {}, &stats);
  CHECK(stats.study);
  CHECK(stats.runs == 0);
  CHECK(stats.figures == 3);  // the Pareto figure of case A, the heat maps of P99 and Pd
  CHECK(html.find("<section class=\"study\" id=\"study\">") != std::string::npos);
  CHECK(test::count(html, "<figure class=\"study-figure pareto\"") == 1);
  CHECK(test::count(html, "<figure class=\"study-figure heatmap\"") == 2);
  // Each heat map has a cell per (interval, ng-meas) of the grid: 2 x 2; the Pareto figure a point per set.
  CHECK(test::count(html, "<g class=\"cell\" ") + test::count(html, "<g class=\"cell nodata\" ") == 2 * 4);
  CHECK(test::count(html, "<circle class=\"row\"") == 4);
  CHECK(html.find("<?xml") == std::string::npos);  // inline SVG elements, not documents
  // The very figures `alc study report --svg` writes.
  const auto svg = dir / "svg";
  const auto r = alc_test::run_alc("study report \"" + db.string() + "\" --svg \"" + svg.string() + "\"", "report_study");
  REQUIRE(r.exit_code == 0);
  std::size_t files = 0;
  for (const auto& f : std::filesystem::directory_iterator(svg)) {
    ++files;
    const std::string text = alc_test::slurp(f.path());
    INFO(f.path());
    CHECK(html.find(text.substr(text.find("<svg"))) != std::string::npos);
  }
  CHECK(files == 3);
  CHECK(html.find("PARTIAL") == std::string::npos);
  // A file with rows missing (a shard, an unfinished run) says so, as alc study report does (before: only
  // "3 of 4 rows present", its optima unmarked).
  const auto partial = dir / "partial.sqlite";
  std::filesystem::copy_file(db, partial);
  sqlite3* handle = nullptr;
  REQUIRE(sqlite3_open(partial.c_str(), &handle) == SQLITE_OK);
  CHECK(sqlite3_exec(handle, "DELETE FROM study_rows WHERE set_index = 0", nullptr, nullptr, nullptr) == SQLITE_OK);
  sqlite3_close(handle);
  CHECK_THAT(html_report(partial, {}), Catch::Contains("<p class=\"study-partial\">PARTIAL: 1 rows are missing"));
}

TEST_CASE("bytes that are not UTF-8 in the database or the file name are escaped, never copied raw into the page",
          "[report][html]") {
  // The page is declared utf-8; a run's source, a channel name or the file's name with a stray byte
  // went into it as is.
  const test::Scratch scratch("utf8");
  const auto& dir = scratch.dir;
  const auto h = test::short_history(dir);
  const auto file = dir / "history-\xff.sqlite";
  std::filesystem::copy_file(h.db, file);
  sqlite3* db = nullptr;
  REQUIRE(sqlite3_open(file.c_str(), &db) == SQLITE_OK);
  CHECK(sqlite3_exec(db,
                     "UPDATE runs SET source = CAST(X'636173652041FE42' AS TEXT);"  // "case A\xFEB"
                     "UPDATE run_channels SET name = CAST(X'545F454E56FF' AS TEXT) "  // "T_ENV\xFF"
                     "WHERE kind = 'input' AND channel_index = 0;",
                     nullptr, nullptr, nullptr) == SQLITE_OK);
  sqlite3_close(db);
  const std::string html = html_report(file, {});
  CHECK(common::invalid_utf8_at(html) == std::string::npos);
  CHECK(html.find("case A\\xFEB") != std::string::npos);
  CHECK(html.find("data-name=\"T_ENV\\xFF\"") != std::string::npos);
  CHECK(html.find("<title>ALC report: history-\\xFF.sqlite</title>") != std::string::npos);
  CHECK(escape_xml("a\xc3\xa9 <\xc3>") == "a\xc3\xa9 &lt;\\xC3&gt;");  // é kept, a cut sequence escaped
}

TEST_CASE("report of a study whose grid has no heat map: the page does not describe heat maps", "[report][html][cli]") {
  const test::Scratch scratch("study-no-heatmap");
  const auto dir = scratch.dir / "no-heatmap";
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "grid.toml") << "cp = [6.5]\ninterval = [2, 8]\n";  // no ng-meas axis
  const auto db = dir / "study.sqlite";
  const auto r = alc_test::run_alc("study --grid \"" + (dir / "grid.toml").string() + "\" --case A --quiet --db \"" +
                                       db.string() + "\"",
                                   "report_study_no_heatmap");
  REQUIRE(r.exit_code == 0);
  ReportStats stats;
  const std::string html = html_report(db, {}, &stats);
  CHECK(stats.figures == 1);  // the Pareto figure of case A only
  CHECK(html.find("no heat map: the grid has no &#39;ng-meas&#39; axis") != std::string::npos);
  CHECK(html.find("The heat maps show") == std::string::npos);  // said so before
  // With heat maps the text is there (the study of the other test).
  const auto with = test::small_study(scratch.dir, "report_study_no_heatmap");
  CHECK(html_report(with, {}).find("The heat maps show the mean over the cases") != std::string::npos);
}
