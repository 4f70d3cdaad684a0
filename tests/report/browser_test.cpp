// The report in a real browser (Debian's chromium, headless; scripts/test.sh installs it): the page
// loads without a console message or script error, and the charts the browser holds carry the
// series and points the report drew (counted in the page from the DOM's path data); a screenshot is
// kept in the build tree. One browser launch per test.
#include <catch2/catch.hpp>

#include <nlohmann/json.hpp>
#include <string>

#include "report/run_data.hpp"
#include "report_test_support.hpp"
#include "storage/history_reader.hpp"

using namespace alc;
using namespace alc::report;


TEST_CASE("browser: the report loads without console errors and its charts hold the expected series and points",
          "[report][browser]") {
  const test::Scratch scratch("browser-dom");
  const auto& dir = scratch.dir;
  const auto h = test::short_history(dir);
  ReportStats stats;
  const auto page = dir / "report.html";
  test::io_write(page, html_report(h.db, {}, &stats));
  const test::Browser b = test::chromium(dir, "--virtual-time-budget=10000 --dump-dom", page);
  REQUIRE(b.exit_code == 0);
  INFO(b.err);
  CHECK(b.err.find(":CONSOLE") == std::string::npos);  // no console message at all, errors included
  const std::string text = test::dom_check(b.out);
  REQUIRE_FALSE(text.empty());
  const auto j = nlohmann::json::parse(text);
  CHECK(j.at("errors").empty());
  const auto& charts = j.at("charts");
  CHECK(charts.size() == stats.charts);
  std::size_t series = 0, points = 0;
  const storage::HistoryReader reader(h.db);
  const RunData d = load_run(reader, h.run);
  std::size_t measured_series = 0;
  for (const auto& c : charts)
    for (const auto& s : c.at("series")) {
      ++series;
      points += s.at("points").get<std::size_t>();
      if (s.at("name") == "measured (probes)") {
        ++measured_series;
        CHECK(s.at("points").get<std::size_t>() == d.probes.size());
      }
      if (s.at("name") == "predicted") {
        CHECK(s.at("points").get<std::size_t>() > 888);
        CHECK(s.at("points").get<std::size_t>() <= 2 * 888);
      }
    }
  CHECK(measured_series == d.run.output_names.size());
  CHECK(series == stats.series);
  CHECK(points == stats.points);
  CHECK(charts.at(0).at("id") == "run1-E_X0C");
  CHECK(charts.at(0).at("series").size() == 2);  // predicted, measured
}

TEST_CASE("browser: commands passed but not delivered or not settled are drawn on the offset charts in their own colours",
          "[report][browser]") {
  const test::Scratch scratch("browser-undelivered");
  const auto& dir = scratch.dir;
  const auto h = test::short_history(dir);
  test::mark_undelivered(h.db, 3, 2);
  std::size_t delivered = 0;
  for (const auto& c : load_run(storage::HistoryReader(h.db), h.run).nc_commands)
    delivered += c.kind == "offsets" && c.delivered == true;
  REQUIRE(delivered > 0);
  const auto page = dir / "report.html";
  test::io_write(page, html_report(h.db, {}));
  const test::Browser b = test::chromium(dir, "--virtual-time-budget=10000 --dump-dom", page);
  REQUIRE(b.exit_code == 0);
  INFO(b.err);
  CHECK(b.err.find(":CONSOLE") == std::string::npos);
  const std::string text = test::dom_check(b.out);
  REQUIRE_FALSE(text.empty());
  const auto j = nlohmann::json::parse(text);
  CHECK(j.at("errors").empty());
  // What the browser holds, per offset chart: every command as a marker of its kind, and the page's
  // style gives each kind its own colour (green delivered, orange not delivered, purple not settled).
  std::size_t offset_charts = 0;
  for (const auto& c : j.at("charts")) {
    if (c.at("id").get<std::string>().find("offsets-") == std::string::npos) continue;
    ++offset_charts;
    INFO(c.dump());
    const auto& m = c.at("markers");
    REQUIRE(m.contains("sent"));
    REQUIRE(m.contains("undelivered"));
    REQUIRE(m.contains("unsettled"));
    CHECK(m.at("sent").at("count") == delivered);
    CHECK(m.at("undelivered").at("count") == 3);
    CHECK(m.at("unsettled").at("count") == 2);
    CHECK(m.at("refused").at("count") == 1);
    CHECK(m.at("sent").at("stroke") == "rgb(44, 160, 44)");
    CHECK(m.at("undelivered").at("stroke") == "rgb(255, 127, 14)");
    CHECK(m.at("unsettled").at("stroke") == "rgb(148, 103, 189)");
  }
  CHECK(offset_charts == 2);
}

TEST_CASE("browser: a screenshot of the report is kept as a test artifact", "[report][browser]") {
  const test::Scratch scratch("browser-shot");
  const auto& dir = scratch.dir;
  const auto h = test::short_history(dir);
  const auto page = dir / "report.html";
  test::io_write(page, html_report(h.db, {}));
  const auto artifacts = std::filesystem::path(ALC_TEST_BINARY_DIR) / "report-artifacts";
  std::filesystem::create_directories(artifacts);
  const auto png = artifacts / "report.png";
  std::filesystem::remove(png);
  const test::Browser b = test::chromium(dir, "--window-size=1040,1800 --screenshot=\"" + png.string() + "\"", page);
  INFO(b.err);
  REQUIRE(b.exit_code == 0);
  const std::string bytes = alc_test::slurp(png);
  REQUIRE(bytes.size() > 20000);  // a page of charts, not a blank one
  CHECK(bytes.compare(0, 8, "\x89PNG\r\n\x1a\n") == 0);
}

TEST_CASE("browser: the report of a study file shows its Pareto figure and heat maps without console errors",
          "[report][browser]") {
  const test::Scratch scratch("browser-study");
  const auto& dir = scratch.dir;
  const auto db = test::small_study(dir, "report_browser_study");
  const auto page = dir / "study.html";
  test::io_write(page, html_report(db, {}));
  const test::Browser b = test::chromium(dir, "--virtual-time-budget=10000 --dump-dom", page);
  REQUIRE(b.exit_code == 0);
  INFO(b.err);
  CHECK(b.err.find(":CONSOLE") == std::string::npos);
  const std::string text = test::dom_check(b.out);
  REQUIRE_FALSE(text.empty());
  const auto j = nlohmann::json::parse(text);
  CHECK(j.at("errors").empty());
  const auto& figures = j.at("figures");
  REQUIRE(figures.size() == 3);
  CHECK(figures.at(0).at("id") == "study-pareto-A");
  CHECK(figures.at(0).at("rows") == 4);  // a point per parameter set
  for (std::size_t i = 1; i < 3; ++i) {
    CHECK(figures.at(i).at("id").get<std::string>().rfind("study-heatmap-", 0) == 0);
    CHECK(figures.at(i).at("cells") == 4);  // interval x ng-meas
  }
  for (const auto& f : figures) CHECK(f.at("svgs") == 1);
}
