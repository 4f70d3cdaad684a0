// What a run's charts say, read back from the page in the data's units (the axes' tick labels give
// the scale): the probe interval up to the end of probing, Pd so far between probes, the end of CP
// on the page's time axis for a recording that does not start at 0, the phase of a run that never
// left calibration.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "../cli_support.hpp"
#include "probing/schedule.hpp"
#include "report/run_data.hpp"
#include "report_test_support.hpp"
#include "storage/history_reader.hpp"

using namespace alc;
using namespace alc::report;

namespace {

struct Point {
  double x, y;
};

// The <figure> of chart `id` in a page.
std::string figure(const std::string& html, const std::string& id) {
  const std::string open = "<figure class=\"chart\" id=\"" + id + "\">";
  const auto at = html.find(open);
  REQUIRE(at != std::string::npos);
  return html.substr(at, html.find("</figure>", at) - at);
}

// The value of attribute `name` in the element starting at `at`.
std::string attribute(const std::string& text, std::size_t at, const std::string& name) {
  const std::string key = " " + name + "=\"";
  const auto from = text.find(key, at) + key.size();
  return text.substr(from, text.find('"', from) - from);
}

// Pixel to data for both axes of a chart, from its grid lines and their tick labels.
struct Scale {
  double x_px0 = 0, x_v0 = 0, x_px1 = 1, x_v1 = 1, y_px0 = 0, y_v0 = 0, y_px1 = 1, y_v1 = 1;
  double x(double px) const { return x_v0 + (px - x_px0) * (x_v1 - x_v0) / (x_px1 - x_px0); }
  double y(double px) const { return y_v0 + (px - y_px0) * (y_v1 - y_v0) / (y_px1 - y_px0); }
};

Scale scale_of(const std::string& fig) {
  std::vector<std::pair<double, double>> xs, ys;  // (px, value)
  const std::string grid = "<line class=\"grid\"";
  for (auto at = fig.find(grid); at != std::string::npos; at = fig.find(grid, at + 1)) {
    const double x1 = std::stod(attribute(fig, at, "x1")), x2 = std::stod(attribute(fig, at, "x2"));
    const double y1 = std::stod(attribute(fig, at, "y1"));
    const auto text = fig.find('>', fig.find("<text class=\"tick\"", at)) + 1;
    const double value = std::stod(fig.substr(text, fig.find('<', text) - text));
    (x1 == x2 ? xs : ys).push_back({x1 == x2 ? x1 : y1, value});
  }
  REQUIRE(xs.size() >= 2);
  REQUIRE(ys.size() >= 2);
  return {xs.front().first, xs.front().second, xs.back().first, xs.back().second,
          ys.front().first, ys.front().second, ys.back().first, ys.back().second};
}

// The vertices of the path of series `name` in chart `id`, in data units (M, L, H, V commands).
std::vector<Point> curve(const std::string& html, const std::string& id, const std::string& name) {
  const std::string fig = figure(html, id);
  const Scale s = scale_of(fig);
  const auto at = fig.find("data-name=\"" + name + "\"");
  REQUIRE(at != std::string::npos);
  std::istringstream d(attribute(fig, at, "d"));
  std::vector<Point> out;
  double px = 0, py = 0;
  char command = 0;
  while (d >> command) {
    if (command == 'M' || command == 'L') d >> px >> py;
    else if (command == 'H') d >> px;
    else if (command == 'V') d >> py;
    else FAIL("unexpected path command " << command);
    out.push_back({s.x(px), s.y(py)});
  }
  return out;
}

// The curve's value at x (linear between its vertices); NaN outside it.
double at_x(const std::vector<Point>& c, double x) {
  for (std::size_t i = 1; i < c.size(); ++i)
    if (c[i - 1].x <= x && x <= c[i].x && c[i].x > c[i - 1].x)
      return c[i - 1].y + (x - c[i - 1].x) / (c[i].x - c[i - 1].x) * (c[i].y - c[i - 1].y);
  return std::nan("");
}

// The end of the first shaded span of `label` in chart `id`, in hours.
double span_end(const std::string& html, const std::string& id, const std::string& label) {
  const std::string fig = figure(html, id);
  const auto at = fig.find("<rect class=\"span span-" + label + "\"");
  REQUIRE(at != std::string::npos);
  return scale_of(fig).x(std::stod(attribute(fig, at, "x")) + std::stod(attribute(fig, at, "width")));
}

std::string run(const std::string& args, const std::string& tag) {
  const auto r = alc_test::run_alc(args, tag);
  INFO(args << ": " << r.err);
  REQUIRE(r.exit_code == 0);
  return r.out;
}

// `alc replay SOURCE --db D` (D = scratch/NAME.sqlite), then `alc report D`: the page's text.
std::string replayed_page(const test::Scratch& scratch, const std::string& name, const std::string& replay_args) {
  const auto db = scratch.dir / (name + ".sqlite"), page = scratch.dir / (name + ".html");
  run("replay " + replay_args + " --db \"" + db.string() + "\"", "report_charts");
  run("report \"" + db.string() + "\" --out \"" + page.string() + "\"", "report_charts");
  return alc_test::slurp(page);
}

}  // namespace

TEST_CASE("probing stopped (--interval inf): the interval is drawn up to the end of CP",
          "[report][html][cli]") {
  const test::Scratch scratch("interval-inf");
  const std::string html = replayed_page(scratch, "inf", "--case A --interval inf");
  const auto db = scratch.dir / "inf.sqlite";
  const storage::HistoryReader reader(db);
  const RunData d = load_run(reader, 1);
  REQUIRE(d.intervals.size() == 2);  // 5 min from the start, inf from the end of CP
  const double cp_end_h = d.intervals[1].time_s / 3600.0;
  CHECK(cp_end_h == Approx(6.5));

  // Before, the path was "M72.0 108.0": one point, no line.
  const auto interval = curve(html, "run1-interval", "probe interval");
  INFO("probe interval vertices " << interval.size());
  REQUIRE(interval.size() == 2);
  CHECK(interval[0].x == Approx(0.0).margin(0.05));
  CHECK(interval[0].y == Approx(5.0).margin(0.05));
  CHECK(interval[1].x == Approx(cp_end_h).margin(0.05));  // one pixel column is 0.22 h
  CHECK(interval[1].y == Approx(5.0).margin(0.05));
}

TEST_CASE("probing stopped (--interval inf): Pd so far is Eq. 7 between the probes too", "[report][html][cli]") {
  const test::Scratch scratch("pd-inf");
  const std::string html = replayed_page(scratch, "inf", "--case A --interval inf");
  const auto db = scratch.dir / "inf.sqlite";
  const storage::HistoryReader reader(db);
  const RunData d = load_run(reader, 1);
  // Pd so far at 24 h and 100 h: Eq. 7 with the probes up to then (all of them in CP). Before, a
  // straight line from the last probe (6.5 h) to the end (192 h): about 71 % at 24 h against 91.4 %.
  const auto pd = curve(html, "run1-pd", "Pd");
  for (const double t_h : {24.0, 100.0}) {
    int m = 0;
    for (const auto& p : d.probes) m += p.time_s <= t_h * 3600.0;
    const double expected = probing::productivity_percent(m, t_h * 3600.0);
    INFO("at " << t_h << " h: " << m << " probes, Pd " << expected << " %");
    CHECK(at_x(pd, t_h) == Approx(expected).margin(0.3));
  }
  CHECK(at_x(pd, 24.0) == Approx(91.4).margin(0.3));
}

TEST_CASE("a recording that does not start at 0: CP ends on the page's time axis, where its shading ends",
          "[report][html][cli]") {
  const test::Scratch scratch("shifted");
  const auto csv = scratch.dir / "a.csv", shifted = scratch.dir / "a_shift.csv";
  const auto db = scratch.dir / "shift.sqlite", page = scratch.dir / "shift.html";
  run("simulate --case A --out \"" + csv.string() + "\"", "report_charts");
  {
    // Every time 10 h later (the first field of each row).
    std::ifstream in(csv);
    std::ofstream out(shifted);
    out.precision(17);
    std::string line;
    std::getline(in, line);
    out << line << "\n";
    while (std::getline(in, line)) {
      const auto comma = line.find(',');
      out << std::stod(line.substr(0, comma)) + 36000.0 << line.substr(comma) << "\n";
    }
  }
  run("replay \"" + shifted.string() + "\" --db \"" + db.string() + "\"", "report_charts");
  run("report \"" + db.string() + "\" --out \"" + page.string() + "\"", "report_charts");
  const std::string html = alc_test::slurp(page);
  CHECK(html.find("(time_s 36000 s)") != std::string::npos);
  // Before: "CP ended at 16.50 h" (the scenario's time) beside CP shaded to 6.5 h.
  const std::string shown = "CP ended at <span data-key=\"cp_end_h\" data-value=\"6.5\">6.50</span> h";
  CHECK(html.find(shown) != std::string::npos);
  CHECK(span_end(html, "run1-E_X0C", "CP") == Approx(6.5).margin(0.05));
}

TEST_CASE("a run that never left calibration: CP shaded over the whole run - the summary says CP did not end",
          "[report][html][cli]") {
  const test::Scratch scratch("stop3");
  const std::string html = replayed_page(scratch, "stop3", "--case A --stop-at 3");
  const auto db = scratch.dir / "stop3.sqlite";
  REQUIRE(storage::HistoryReader(db).phase_changes(1).empty());
  // Before: no span at all (no phase_changes rows), and "CP ended at never".
  CHECK(test::count(html, "class=\"span span-") == test::count(html, "class=\"span span-CP\""));
  const std::size_t outputs = storage::HistoryReader(db).run(1)->output_names.size();
  CHECK(test::count(html, "class=\"span span-CP\"") >= 2 * outputs);
  const auto fig = figure(html, "run1-E_X0C");
  const auto x_end = scale_of(fig).x(944.0);  // the plot's right edge
  CHECK(span_end(html, "run1-E_X0C", "CP") == Approx(x_end).margin(0.01));
  CHECK(html.find("never") == std::string::npos);
  CHECK(html.find("CP <span data-key=\"cp_end_h\" data-value=\"null\">not ended</span> (the run was in calibration "
                  "up to its last sample)") != std::string::npos);
}

TEST_CASE("a chart of more lines than the palette has colours (case S16: 16 temperatures): no two look alike",
          "[report][html][cli]") {
  const test::Scratch scratch("s16");
  const std::string html = replayed_page(scratch, "s16", "--case S16 --stop-at 10");
  const std::string fig = figure(html, "run1-inputs-0");
  REQUIRE(fig.find(">temperatures [°C]</text>") != std::string::npos);
  // Each line's look: its colour and its pattern (the class after "series-line"), and its legend key.
  std::vector<std::string> looks, keys;
  const std::string open = "<path class=\"series series-line";
  for (auto at = fig.find(open); at != std::string::npos; at = fig.find(open, at + 1)) {
    const auto pattern = fig.substr(at + open.size(), fig.find('"', at + open.size()) - at - open.size());
    looks.push_back(attribute(fig, at, "stroke") + pattern);
  }
  const std::string key = "<span class=\"key key-line\"><i style=\"";
  for (auto at = fig.find(key); at != std::string::npos; at = fig.find(key, at + 1))
    keys.push_back(fig.substr(at + key.size(), fig.find('"', at + key.size()) - at - key.size()));
  REQUIRE(looks.size() == 16);
  REQUIRE(keys.size() == 16);
  for (auto* v : {&looks, &keys}) {
    std::sort(v->begin(), v->end());
    CHECK(std::adjacent_find(v->begin(), v->end()) == v->end());  // before: colours 11-16 repeated 1-6
  }
  CHECK(test::count(fig, "series-line dashed") == 6);
}

TEST_CASE("a run without samples, probes or predictions: a note instead of twenty empty charts", "[report][html][cli]") {
  const test::Scratch scratch("no-samples");
  const auto db = scratch.dir / "empty.sqlite";
  run("replay --case A --db \"" + db.string() + "\" --stop-at 0", "report_charts");
  REQUIRE(storage::HistoryReader(db).input_samples(1).empty());
  ReportStats stats;
  const std::string html = html_report(db, {}, &stats);
  CHECK(stats.runs == 1);
  CHECK(stats.charts == 0);  // before: 20 frames, each empty, no word why
  CHECK(html.find("This run holds no input samples, probes or predictions") != std::string::npos);
  CHECK(html.find("<table class=\"indicators\"") != std::string::npos);  // the rest of the run's section stays
  CHECK(html.find("<h3>Parameters</h3>") != std::string::npos);
}
