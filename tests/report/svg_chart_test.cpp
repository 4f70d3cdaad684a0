// The SVG chart writer: display downsampling keeps every peak and bounds the points; the drawn
// points, series and escaping the page's checks rely on.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include "report/svg_chart.hpp"
#include "report_test_support.hpp"

using namespace alc::report;


TEST_CASE("min/max downsampling keeps every peak and at most two points per pixel column", "[report][svg]") {
  // 8 days at 1 min on 888 columns: a one-sample spike in every column must survive.
  const std::size_t n = 8 * 1440 + 1, buckets = 888;
  std::vector<double> x(n), y(n);
  for (std::size_t i = 0; i < n; ++i) {
    x[i] = static_cast<double>(i) / 60.0;
    y[i] = std::sin(static_cast<double>(i) / 300.0);
  }
  y[5000] = 50.0;
  y[9000] = -40.0;
  const auto keep = minmax_downsample(x, y, x.front(), x.back(), buckets);
  CHECK(keep.size() <= 2 * buckets);
  CHECK(keep.size() > buckets);
  CHECK(std::find(keep.begin(), keep.end(), std::size_t{5000}) != keep.end());
  CHECK(std::find(keep.begin(), keep.end(), std::size_t{9000}) != keep.end());
  CHECK(std::is_sorted(keep.begin(), keep.end()));
  CHECK(keep.front() == 0);
  // Few points: all kept.
  const std::vector<double> sx = {0, 1, 2}, sy = {1, 2, 3};
  CHECK(minmax_downsample(sx, sy, 0, 2, buckets).size() == 3);
}

TEST_CASE("a gap of NaN stays a gap after downsampling", "[report][svg]") {
  std::vector<double> x(4000), y(4000, 1.0);
  for (std::size_t i = 0; i < x.size(); ++i) x[i] = static_cast<double>(i);
  for (std::size_t i = 2000; i < 2400; ++i) y[i] = std::numeric_limits<double>::quiet_NaN();
  Chart c;
  c.id = "gap";
  c.series = {{"s", "#000", Series::Style::Line, x, y}};
  const std::string svg = render_svg(c);
  // Two pieces: the line is lifted over the gap (a second M), never drawn across it.
  const auto d = svg.substr(svg.find(" d=\"") + 4);
  CHECK(test::count(d.substr(0, d.find('"')), "M") == 2);
}

TEST_CASE("render_svg: one path per series with the points it draws - axis labels and escaped text", "[report][svg]") {
  Chart c;
  c.id = "t";
  c.title = "E_X0C <measured> & \"predicted\"";
  c.x_label = "time [h]";
  c.y_label = "E_X0C [µm]";
  c.series.push_back({"line", "#111", Series::Style::Line, {0, 1, 2, 3}, {1, 2, std::nan(""), 4}});
  c.series.push_back({"points", "#222", Series::Style::Points, {0.5, 1.5}, {3, 3}});
  c.series.push_back({"step", "#333", Series::Style::Step, {0, 2}, {5, 120}});
  c.spans = {{0, 1, "CP"}, {1, 3, "NG"}};
  c.hbands = {{-5, 5, "ACL ±5 µm"}};
  c.markers = {{1.0, "update", "model update"}, {2.0, "refused", "refused <X>"}};
  const std::string svg = render_svg(c);
  CHECK(svg.find("data-series=\"3\"") != std::string::npos);
  CHECK(test::count(svg, "<path class=\"series") == 3);
  CHECK(svg.find("data-name=\"line\" data-style=\"line\" data-points=\"3\" data-source-points=\"4\"") != std::string::npos);
  CHECK(drawn_points(c, c.series[0]) == 3);
  CHECK(svg.find("data-points=\"2\" data-source-points=\"2\"") != std::string::npos);
  CHECK(svg.find(">time [h]</text>") != std::string::npos);
  CHECK(svg.find(">E_X0C [µm]</text>") != std::string::npos);
  CHECK(svg.find("E_X0C &lt;measured&gt; &amp; &quot;predicted&quot;") != std::string::npos);
  CHECK(svg.find("refused &lt;X&gt;") != std::string::npos);
  CHECK(test::count(svg, "class=\"span span-") == 2);
  CHECK(test::count(svg, "class=\"hband\"") == 1);
  CHECK(test::count(svg, "class=\"marker marker-refused\"") == 1);
  CHECK(svg.find("<script") == std::string::npos);
}

TEST_CASE("render_svg: values near the largest double draw finite coordinates, never nan", "[report][svg]") {
  // An input with its plausibility limit off (--plausible-other inf) at 1.8e308 and 1e300: the span
  // of the y axis overflowed, and every point was written as -nan (found by review).
  Chart c;
  c.id = "big";
  const double top = std::numeric_limits<double>::max();
  c.series.push_back({"huge", "#111", Series::Style::Line, {0, 1, 2, 3}, {top, 1e300, -top, 0}});
  const std::string svg = render_svg(c);
  CHECK(svg.find("nan") == std::string::npos);
  CHECK(svg.find("inf") == std::string::npos);
  CHECK(svg.find("data-points=\"4\"") != std::string::npos);
  CHECK(nice_ticks(-top, top, 5).empty());  // no tick labels for a span beyond a double
  // A flat series far beyond 2^53 (a constant input of 1e20 or 1.7e308): +-1 was lost in rounding.
  for (const double flat : {1e20, top, -top}) {
    INFO("flat at " << flat);
    Chart f;
    f.id = "flat";
    f.series.push_back({"flat", "#111", Series::Style::Line, {0, 1, 2}, {flat, flat, flat}});
    const std::string drawn = render_svg(f);
    CHECK(drawn.find("nan") == std::string::npos);
    CHECK(drawn.find("inf") == std::string::npos);
  }
}

TEST_CASE("nice ticks: round steps - hours in multiples of 6 - 12 - 24 h", "[report][svg]") {
  CHECK(nice_ticks(0, 10, 5) == std::vector<double>{0, 2.5, 5, 7.5, 10});
  CHECK(nice_ticks(0, 100, 5) == std::vector<double>{0, 25, 50, 75, 100});
  const auto h = nice_ticks(0, 192, 9, true);
  REQUIRE(h.size() >= 2);
  CHECK(h[1] - h[0] == 24.0);
  CHECK(nice_ticks(1, 1, 5).empty());
}

TEST_CASE("markers: a line with its tooltip each up to the limit - beyond it one path per kind with a line per marker",
          "[report][svg]") {
  const auto chart_with = [](std::size_t updates) {
    Chart c;
    c.id = "m";
    c.x_range = std::make_pair(0.0, 100.0);
    c.series.push_back({"s", "#000", Series::Style::Line, {0.0, 100.0}, {0.0, 1.0}});
    for (std::size_t i = 0; i < updates; ++i)
      c.markers.push_back({static_cast<double>(i) * 0.5, "update", "update " + std::to_string(i)});
    c.markers.push_back({99.0, "refused", "refused: too large"});
    c.markers.push_back({200.0, "update", "outside the time range"});  // not drawn, not counted
    return render_svg(c);
  };
  const std::string few = chart_with(kMarkersAsLines);
  CHECK(test::count(few, "<line class=\"marker marker-update\"") == kMarkersAsLines);
  CHECK(few.find("<title>update 39</title>") != std::string::npos);
  CHECK(few.find("<path class=\"marker") == std::string::npos);
  const std::string many = chart_with(kMarkersAsLines + 1);
  CHECK(test::count(many, "<line class=\"marker marker-update\"") == 0);
  const std::string path = "<path class=\"marker marker-update\" data-markers=\"" + std::to_string(kMarkersAsLines + 1) + "\" d=\"";
  const auto at = many.find(path);
  REQUIRE(at != std::string::npos);
  const std::string d = many.substr(at + path.size(), many.find('"', at + path.size()) - at - path.size());
  CHECK(test::count(d, "M") == kMarkersAsLines + 1);
  CHECK(test::count(d, "V") == kMarkersAsLines + 1);
  // The other kind keeps its own line and tooltip.
  CHECK(test::count(many, "<line class=\"marker marker-refused\"") == 1);
  CHECK(many.find("refused: too large") != std::string::npos);
}

TEST_CASE("render_svg: a step series draws its value up to a NaN point (probe interval inf) - a gap after it",
          "[report][svg]") {
  // alc replay --interval inf: 5 min from 0 h, inf (NaN on the chart) at the end of CP, 6.5 h. Before,
  // the path was "M72.0 …" alone: the NaN point lifted the pen without drawing the run to it.
  Chart c;
  c.id = "interval";
  c.width = 960;
  c.x_range = std::make_pair(0.0, 192.0);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  c.series.push_back({"probe interval", "#2ca02c", Series::Style::Step, {0.0, 6.5}, {5.0, nan}});
  const auto path_of = [](const std::string& svg) {
    const std::string open = "data-name=\"probe interval\"";
    const auto at = svg.find(" d=\"", svg.find(open));
    return svg.substr(at + 4, svg.find('"', at + 4) - at - 4);
  };
  const double x65 = kMarginLeft + 6.5 / 192.0 * (960 - kMarginLeft - kMarginRight);
  char end[32];
  std::snprintf(end, sizeof end, "H%.1f", x65);
  std::string d = path_of(render_svg(c));
  INFO(d);
  CHECK(d.rfind("M72.0 ", 0) == 0);
  CHECK(d.substr(d.size() - std::string(end).size()) == end);  // drawn to 6.5 h, not on to the end
  CHECK(test::count(d, "M") == 1);
  // Probing again after a gap: a new piece from the next finite point, held to the end of the plot.
  c.series[0].x.push_back(100.0);
  c.series[0].y.push_back(120.0);
  d = path_of(render_svg(c));
  INFO(d);
  CHECK(d.find(std::string(end) + "M") != std::string::npos);
  CHECK(test::count(d, "M") == 2);
  CHECK(d.substr(d.size() - 6) == "H944.0");
}

TEST_CASE("markers too dense for lines (a 90-day run's model updates): a tick per pixel column at the top edge",
          "[report][svg]") {
  // 90 days, an update about every 2 h (1077 in the 90-day history of docs/report.md): as lines they
  // filled every pixel column of each error chart, which turned solid green.
  const auto chart_with = [](std::size_t updates, const std::string& kind) {
    Chart c;
    c.id = "dense";
    c.x_range = std::make_pair(0.0, 2160.0);
    c.series.push_back({"s", "#000", Series::Style::Line, {0.0, 2160.0}, {0.0, 1.0}});
    for (std::size_t i = 0; i < updates; ++i)
      c.markers.push_back({2160.0 * static_cast<double>(i) / static_cast<double>(updates), kind, "m"});
    return render_svg(c);
  };
  const double plot = 960 - kMarginLeft - kMarginRight, top = kMarginTop, bottom = 230 - kMarginBottom;
  const auto path_d = [](const std::string& svg, const std::string& open) {
    const auto at = svg.find(open);
    REQUIRE(at != std::string::npos);
    const auto d = svg.find(" d=\"", at) + 4;
    return svg.substr(d, svg.find('"', d) - d);
  };
  const std::string dense = chart_with(1077, "update");
  CHECK(test::count(dense, "class=\"marker marker-update") == 1);
  const std::string open = "<path class=\"marker marker-update marker-ticks\" data-markers=\"1077\" data-columns=\"";
  REQUIRE(dense.find(open) != std::string::npos);
  const auto columns = std::stoul(dense.substr(dense.find(open) + open.size()));
  CHECK(columns <= static_cast<std::size_t>(plot));
  CHECK(columns > 800);
  const std::string d = path_d(dense, open);
  CHECK(test::count(d, "M") == columns);
  // Each a tick of kMarkerTickPx from the top edge, none down to the bottom.
  char tick[48];
  std::snprintf(tick, sizeof tick, " %.1fV%.1f", top, top + kMarkerTickPx);
  CHECK(test::count(d, tick) == columns);
  CHECK(d.find("V" + std::to_string(static_cast<int>(bottom))) == std::string::npos);
  // Commands sent: ticks at the bottom edge, as they are drawn anyway.
  const std::string sent = chart_with(500, "sent");
  std::snprintf(tick, sizeof tick, " %.1fV%.1f", bottom - kMarkerTickPx, bottom);
  CHECK(test::count(path_d(sent, "<path class=\"marker marker-sent marker-ticks\""), tick) > 400);
  // Up to one marker per kMarkerMinSpacingPx on average they stay full-height lines.
  const auto lines = static_cast<std::size_t>(plot / kMarkerMinSpacingPx);
  CHECK(chart_with(lines, "update").find("marker-ticks") == std::string::npos);
  CHECK(chart_with(lines + 1, "update").find("marker-ticks") != std::string::npos);
}

TEST_CASE("render_svg: a chart with nothing to draw says 'no data'", "[report][svg]") {
  Chart c;
  c.id = "empty";
  c.x_range = std::make_pair(0.0, 1.0);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  c.series.push_back({"none", "#000", Series::Style::Line, {}, {}});
  c.series.push_back({"gap only", "#000", Series::Style::Step, {0.5}, {nan}});
  CHECK(test::count(render_svg(c), ">no data</text>") == 1);
  c.series.push_back({"one point", "#000", Series::Style::Points, {0.5}, {1.0}});
  CHECK(render_svg(c).find("no data") == std::string::npos);
}
