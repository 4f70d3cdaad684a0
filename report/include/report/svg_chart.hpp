#pragma once
// A small SVG chart writer for the HTML report (docs/report.md): lines, points and steps over a
// numeric x axis, shaded x spans (phases), horizontal bands (the ACL), vertical markers (model
// updates, refused commands), nice ticks and a unit on each axis. No dependency, no script.
//
// Display only: a series with more points than twice the plot's pixel columns is reduced to the
// minimum and the maximum of each pixel column (peaks kept, in time order); the data behind the
// indicators is never touched.
#include <cstddef>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace alc::report {

struct Series {
  enum class Style { Line, Points, Step };
  enum class Dash { Solid, Dashed, Dotted };  // a line's pattern, also in its legend key
  std::string name;                 // legend text
  std::string color;                // CSS colour
  Style style = Style::Line;
  std::vector<double> x, y;         // same length; NaN in y breaks a line
  Dash dash = Dash::Solid;          // class "dashed" / "dotted" on the path
};

struct Span {                       // shaded x range (a phase)
  double x0 = 0.0, x1 = 0.0;
  std::string label;                // class and tooltip: "CP", "Post-CP", "NG"
};

struct HBand {                      // shaded y range across the plot (the ACL band)
  double y0 = 0.0, y1 = 0.0;
  std::string label;
};

struct Marker {                     // vertical line at x
  double x = 0.0;
  std::string kind;                 // CSS class: "update", "rejected", "refused", "sent" (passed and delivered),
                                    // "undelivered" (passed, delivered 0), "unsettled" (passed, delivered NULL)
  std::string label;                // tooltip
};

// Markers of one kind in a chart up to this many are one <line> each with its label as tooltip;
// more (a long run's model updates) are one <path class="marker marker-KIND" data-markers=N> with a
// line per marker and one tooltip, so a 90-day page does not carry thousands of elements per chart.
inline constexpr std::size_t kMarkersAsLines = 40;

// Lines are drawn while the markers of a kind are this far apart on average [px] (at most 109 in a plot
// of 872 px): denser (a 90-day run's ~1077 model updates) they covered the whole plot in their
// colour. Then each pixel column holding markers of the kind gets one short tick of kMarkerTickPx at
// the plot's edge (the top; the bottom for commands passed by the gate, drawn there anyway), a rug that shows where
// and how often without hiding the data: <path class="marker marker-KIND marker-ticks"
// data-markers=N data-columns=K>.
inline constexpr double kMarkerMinSpacingPx = 8.0;
inline constexpr double kMarkerTickPx = 6.0;

struct Chart {
  std::string id;                   // element id (unique in the page)
  std::string title;
  std::string x_label;              // with unit: "time [h]"
  std::string y_label;              // with unit: "E_X0C [µm]"
  std::vector<Series> series;
  std::vector<Span> spans;
  std::vector<HBand> hbands;
  std::vector<Marker> markers;
  // Legend keys of marker kinds (kind, text), drawn after the series' keys in the kind's colour.
  std::vector<std::pair<std::string, std::string>> marker_keys;
  std::optional<std::pair<double, double>> x_range;  // default: the data's
  int width = 960;                  // [px]
  int height = 230;                 // [px]
};

// Left, right, top, bottom margins of the plot area [px].
inline constexpr int kMarginLeft = 72, kMarginRight = 16, kMarginTop = 26, kMarginBottom = 40;

// Indices of the points to draw: all when n <= 2 * buckets, else per bucket of [x0, x1] the first
// index of the minimum and of the maximum of y (in index order; a bucket of only NaN keeps one NaN,
// so a gap stays a gap). x must be non-decreasing.
std::vector<std::size_t> minmax_downsample(const std::vector<double>& x, const std::vector<double>& y, double x0,
                                           double x1, std::size_t buckets);

// Number of points the chart draws for `series` (after downsampling), as data-points says.
std::size_t drawn_points(const Chart& chart, const Series& series);

// "Nice" tick values covering [lo, hi] with about `target` ticks (1, 2, 2.5, 5 x 10^k; for hours
// also 6, 12, 24, 48 ...).
std::vector<double> nice_ticks(double lo, double hi, int target, bool hours = false);

// The chart as an inline <svg> element with a legend. Each series is one
// <path class="series" data-name=… data-style=line|points|step data-points=K data-source-points=N>;
// the svg carries data-series (number of series).
std::string render_svg(const Chart& chart);

// Text escaped for HTML/SVG content and attributes (& < > " '); a byte that is not part of well-formed
// UTF-8 becomes the text \xNN (common::valid_utf8).
std::string escape_xml(const std::string& text);

}  // namespace alc::report
