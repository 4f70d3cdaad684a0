#include "report/svg_chart.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string_view>

#include "common/utf8.hpp"

namespace alc::report {

namespace {

std::string num(double v, int decimals = 1) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

// Tick label: as few decimals as the step needs.
std::string tick_text(double v, double step) {
  int decimals = 0;
  while (decimals < 6 && std::fabs(step * std::pow(10.0, decimals) - std::round(step * std::pow(10.0, decimals))) > 1e-6)
    ++decimals;
  if (std::fabs(v) < step * 1e-9) v = 0.0;  // no "-0"
  return num(v, decimals);
}

const char* dash_class(Series::Dash d) {
  switch (d) {
    case Series::Dash::Dashed: return " dashed";
    case Series::Dash::Dotted: return " dotted";
    default: return "";
  }
}

// A legend key: the colour, with the line's pattern as gaps (the same dash and gap lengths).
std::string key_background(const Series& s) {
  const std::string c = escape_xml(s.color);
  switch (s.dash) {
    case Series::Dash::Dashed: return "repeating-linear-gradient(90deg," + c + " 0 6px,transparent 6px 10px)";
    case Series::Dash::Dotted: return "repeating-linear-gradient(90deg," + c + " 0 2px,transparent 2px 5px)";
    default: return c;
  }
}

const char* style_name(Series::Style s) {
  switch (s) {
    case Series::Style::Points: return "points";
    case Series::Style::Step: return "step";
    default: return "line";
  }
}

std::pair<double, double> x_domain(const Chart& c) {
  if (c.x_range) return *c.x_range;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const auto& s : c.series)
    for (double x : s.x)
      if (std::isfinite(x)) {
        lo = std::min(lo, x);
        hi = std::max(hi, x);
      }
  if (!(lo <= hi)) return {0.0, 1.0};
  if (lo == hi) return {lo - 0.5, hi + 0.5};
  return {lo, hi};
}

}  // namespace

std::string escape_xml(const std::string& text) {
  // The page says it is UTF-8: bytes that are not (a channel name, a message or a file name from
  // outside) are shown as \xNN, never copied raw into it.
  const std::string valid =
      common::invalid_utf8_at(text) == std::string_view::npos ? std::string() : common::valid_utf8(text);
  const std::string& from = valid.empty() ? text : valid;
  std::string out;
  out.reserve(from.size());
  for (char ch : from) {
    switch (ch) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default: out += ch;
    }
  }
  return out;
}

std::vector<std::size_t> minmax_downsample(const std::vector<double>& x, const std::vector<double>& y, double x0,
                                           double x1, std::size_t buckets) {
  const std::size_t n = std::min(x.size(), y.size());
  std::vector<std::size_t> keep;
  if (n <= 2 * buckets || buckets == 0 || !(x1 > x0)) {
    keep.resize(n);
    for (std::size_t i = 0; i < n; ++i) keep[i] = i;
    return keep;
  }
  const double width = (x1 - x0) / static_cast<double>(buckets);
  std::size_t i = 0;
  while (i < n) {
    const double b = std::clamp(std::floor((x[i] - x0) / width), 0.0, static_cast<double>(buckets - 1));
    std::size_t lo = n, hi = n, nan = n;
    std::size_t j = i;
    for (; j < n; ++j) {
      const double bj = std::clamp(std::floor((x[j] - x0) / width), 0.0, static_cast<double>(buckets - 1));
      if (bj != b) break;
      if (std::isnan(y[j])) {
        if (nan == n) nan = j;
        continue;
      }
      if (lo == n || y[j] < y[lo]) lo = j;
      if (hi == n || y[j] > y[hi]) hi = j;
    }
    if (lo == n) {
      keep.push_back(nan);
    } else {
      keep.push_back(std::min(lo, hi));
      if (hi != lo) keep.push_back(std::max(lo, hi));
    }
    i = j;
  }
  return keep;
}

std::size_t drawn_points(const Chart& chart, const Series& s) {
  const auto [x0, x1] = x_domain(chart);
  const auto pw = static_cast<std::size_t>(std::max(1, chart.width - kMarginLeft - kMarginRight));
  std::size_t count = 0;
  for (std::size_t i : minmax_downsample(s.x, s.y, x0, x1, pw))
    if (std::isfinite(s.x[i]) && std::isfinite(s.y[i])) ++count;
  return count;
}

std::vector<double> nice_ticks(double lo, double hi, int target, bool hours) {
  std::vector<double> ticks;
  if (!(hi > lo) || !std::isfinite(hi - lo) || target < 1) return ticks;
  const double raw = (hi - lo) / target;
  double step;
  if (hours && raw >= 4.0) {
    step = 6.0;
    for (double s : {6.0, 12.0, 24.0, 48.0, 72.0, 168.0, 336.0, 720.0, 1440.0, 2160.0})
      if (s <= raw * 1.5) step = s;
  } else {
    const double mag = std::pow(10.0, std::floor(std::log10(raw)));
    step = mag;
    for (double m : {1.0, 2.0, 2.5, 5.0, 10.0})
      if (m * mag <= raw * 1.5) step = m * mag;
  }
  // At most a few times the target: near the largest double, t + step can round to t or overflow.
  const double end = hi + step * 1e-9;
  for (double t = std::ceil(lo / step - 1e-9) * step; std::isfinite(t) && t <= end; t += step) {
    ticks.push_back(t);
    if (ticks.size() > static_cast<std::size_t>(4 * target + 2)) return {};
  }
  return ticks;
}

std::string render_svg(const Chart& c) {
  const int W = c.width, H = c.height;
  const double pl = kMarginLeft, pr = W - kMarginRight, pt = kMarginTop, pb = H - kMarginBottom;
  const std::pair<double, double> domain = x_domain(c);
  const double x0 = domain.first, x1 = domain.second;  // plain names: lambdas below capture them (clang 14)
  // y domain: finite values of every series and band, 5 % padding.
  double ylo = std::numeric_limits<double>::infinity(), yhi = -ylo;
  for (const auto& s : c.series)
    for (std::size_t i = 0; i < std::min(s.x.size(), s.y.size()); ++i)
      if (std::isfinite(s.y[i]) && s.x[i] >= x0 && s.x[i] <= x1) {
        ylo = std::min(ylo, s.y[i]);
        yhi = std::max(yhi, s.y[i]);
      }
  for (const auto& b : c.hbands)
    for (double v : {b.y0, b.y1})
      if (std::isfinite(v)) {
        ylo = std::min(ylo, v);
        yhi = std::max(yhi, v);
      }
  if (!(ylo <= yhi)) ylo = -1.0, yhi = 1.0;
  // In halves: values near ±1.8e308 (an input with its plausibility limit off) would make the span
  // yhi - ylo infinite, and every point NaN in the drawing. A flat series is widened relative to its
  // size (±1 is lost in rounding beyond 2^53).
  const double big = std::numeric_limits<double>::max();
  if (const double size = std::max(std::abs(ylo), std::abs(yhi)); yhi / 2 - ylo / 2 < 0.5e-12 * std::max(1.0, size)) {
    const double widen = std::max(1.0, 1e-6 * size);
    ylo = std::max(-big, ylo - widen);
    yhi = std::min(big, yhi + widen);
  }
  const double pad = 0.1 * (yhi / 2 - ylo / 2);
  ylo = std::max(-big, ylo - pad);
  yhi = std::min(big, yhi + pad);
  auto X = [&](double x) { return pl + (x - x0) / (x1 - x0) * (pr - pl); };
  auto Y = [&](double y) { return pb - (y / 2 - ylo / 2) / (yhi / 2 - ylo / 2) * (pb - pt); };
  const std::string clip = c.id + "-clip";

  std::string o;
  o.reserve(4096);
  o += "<figure class=\"chart\" id=\"" + escape_xml(c.id) + "\">\n";
  o += "<svg class=\"alc-chart\" xmlns=\"http://www.w3.org/2000/svg\" data-series=\"" +
       std::to_string(c.series.size()) + "\" viewBox=\"0 0 " + std::to_string(W) + " " + std::to_string(H) +
       "\" width=\"" + std::to_string(W) + "\" height=\"" + std::to_string(H) + "\" role=\"img\" aria-label=\"" +
       escape_xml(c.title) + "\">\n";
  o += "<title>" + escape_xml(c.title) + "</title>\n";
  o += "<defs><clipPath id=\"" + escape_xml(clip) + "\"><rect x=\"" + num(pl) + "\" y=\"" + num(pt) +
       "\" width=\"" + num(pr - pl) + "\" height=\"" + num(pb - pt) + "\"/></clipPath></defs>\n";
  o += "<text class=\"chart-title\" x=\"" + num(pl) + "\" y=\"16\">" + escape_xml(c.title) + "</text>\n";
  o += "<g clip-path=\"url(#" + escape_xml(clip) + ")\">\n";
  for (const auto& s : c.spans) {
    const double a = std::max(X(s.x0), pl), b = std::min(X(s.x1), pr);
    if (!(b > a)) continue;
    o += "<rect class=\"span span-" + escape_xml(s.label) + "\" x=\"" + num(a) + "\" y=\"" + num(pt) + "\" width=\"" +
         num(b - a) + "\" height=\"" + num(pb - pt) + "\"><title>" + escape_xml(s.label) + "</title></rect>\n";
  }
  for (const auto& b : c.hbands) {
    const double a = Y(std::max(b.y0, b.y1)), d = Y(std::min(b.y0, b.y1));
    o += "<rect class=\"hband\" x=\"" + num(pl) + "\" y=\"" + num(a) + "\" width=\"" + num(pr - pl) + "\" height=\"" +
         num(d - a) + "\"><title>" + escape_xml(b.label) + "</title></rect>\n";
  }
  o += "</g>\n<g class=\"axes\">\n";
  const std::vector<double> yt = nice_ticks(ylo, yhi, std::max(2, (H - 60) / 40));
  const double ystep = yt.size() > 1 ? yt[1] - yt[0] : 1.0;
  for (double t : yt) {
    const double y = Y(t);
    o += "<line class=\"grid\" x1=\"" + num(pl) + "\" x2=\"" + num(pr) + "\" y1=\"" + num(y) + "\" y2=\"" + num(y) +
         "\"/><text class=\"tick\" x=\"" + num(pl - 5) + "\" y=\"" + num(y + 4) + "\" text-anchor=\"end\">" +
         tick_text(t, ystep) + "</text>\n";
  }
  const std::vector<double> xt = nice_ticks(x0, x1, std::max(2, W / 100), c.x_label.find("[h]") != std::string::npos);
  const double xstep = xt.size() > 1 ? xt[1] - xt[0] : 1.0;
  for (double t : xt) {
    const double x = X(t);
    o += "<line class=\"grid\" x1=\"" + num(x) + "\" x2=\"" + num(x) + "\" y1=\"" + num(pt) + "\" y2=\"" + num(pb) +
         "\"/><text class=\"tick\" x=\"" + num(x) + "\" y=\"" + num(pb + 14) + "\" text-anchor=\"middle\">" +
         tick_text(t, xstep) + "</text>\n";
  }
  o += "<rect class=\"frame\" x=\"" + num(pl) + "\" y=\"" + num(pt) + "\" width=\"" + num(pr - pl) + "\" height=\"" +
       num(pb - pt) + "\"/>\n";
  o += "<text class=\"axis-label\" x=\"" + num((pl + pr) / 2) + "\" y=\"" + num(H - 6.0) +
       "\" text-anchor=\"middle\">" + escape_xml(c.x_label) + "</text>\n";
  o += "<text class=\"axis-label\" transform=\"rotate(-90)\" x=\"" + num(-(pt + pb) / 2) +
       "\" y=\"14\" text-anchor=\"middle\">" + escape_xml(c.y_label) + "</text>\n";
  o += "</g>\n<g clip-path=\"url(#" + escape_xml(clip) + ")\">\n";
  std::vector<std::string> kinds;  // in order of first appearance
  for (const auto& m : c.markers)
    if (std::find(kinds.begin(), kinds.end(), m.kind) == kinds.end()) kinds.push_back(m.kind);
  for (const std::string& kind : kinds) {
    std::vector<const Marker*> in_range;
    for (const auto& m : c.markers)
      if (m.kind == kind && m.x >= x0 && m.x <= x1) in_range.push_back(&m);
    // A command the gate passed (delivered or not): a tick on the time axis.
    const bool bottom = kind == "sent" || kind == "undelivered" || kind == "unsettled";
    // Not delivered, not settled: twice the height of a delivered one, so they stand out.
    const double scale = bottom && kind != "sent" ? 2.0 : 1.0;
    const double top = bottom ? pb - 8.0 * scale : pt;
    if (static_cast<double>(in_range.size()) * kMarkerMinSpacingPx > pr - pl) {
      // Too dense for lines: a tick per pixel column that holds any (at its centre, crisp).
      std::vector<double> columns;
      for (const Marker* m : in_range) columns.push_back(std::floor(X(m->x)) + 0.5);
      std::sort(columns.begin(), columns.end());
      columns.erase(std::unique(columns.begin(), columns.end()), columns.end());
      const double y0 = bottom ? pb - kMarkerTickPx * scale : pt, y1 = bottom ? pb : pt + kMarkerTickPx;
      std::string d;
      for (double x : columns) d.append("M").append(num(x)).append(" ").append(num(y0)).append("V").append(num(y1));
      o += "<path class=\"marker marker-" + escape_xml(kind) + " marker-ticks\" data-markers=\"" +
           std::to_string(in_range.size()) + "\" data-columns=\"" + std::to_string(columns.size()) + "\" d=\"" + d +
           "\"><title>" + std::to_string(in_range.size()) + " x " + escape_xml(kind) + " (too dense for lines: a tick " +
           "per pixel column at the " + (bottom ? "bottom" : "top") + " edge)</title></path>\n";
      continue;
    }
    if (in_range.size() <= kMarkersAsLines) {
      for (const Marker* m : in_range)
        o += "<line class=\"marker marker-" + escape_xml(kind) + "\" x1=\"" + num(X(m->x)) + "\" x2=\"" +
             num(X(m->x)) + "\" y1=\"" + num(top) + "\" y2=\"" + num(pb) + "\"><title>" + escape_xml(m->label) +
             "</title></line>\n";
      continue;
    }
    std::string d;
    for (const Marker* m : in_range) d.append("M").append(num(X(m->x))).append(" ").append(num(top)).append("V").append(num(pb));
    o += "<path class=\"marker marker-" + escape_xml(kind) + "\" data-markers=\"" + std::to_string(in_range.size()) +
         "\" d=\"" + d + "\"><title>" + std::to_string(in_range.size()) + " x " + escape_xml(kind) +
         "</title></path>\n";
  }
  const auto buckets = static_cast<std::size_t>(std::max(1.0, pr - pl));
  std::size_t drawn_total = 0;  // points of every series
  for (const auto& s : c.series) {
    std::string d;
    std::size_t points = 0;
    bool pen = false;  // a point was drawn and the next one connects to it
    for (std::size_t i : minmax_downsample(s.x, s.y, x0, x1, buckets)) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) {
        // A step's value holds until the next point, so a NaN point (a probe interval of inf: no more
        // probing) ends the run before it at its x, not at the last finite point.
        if (s.style == Series::Style::Step && pen && std::isfinite(s.x[i])) d.append("H").append(num(X(s.x[i])));
        pen = false;
        continue;
      }
      const std::string px = num(X(s.x[i])), py = num(Y(s.y[i]));
      ++points;
      // Appended piece by piece: "literal" + std::string&& trips GCC 12's -Wrestrict.
      switch (s.style) {
        case Series::Style::Points: d.append("M").append(px).append(" ").append(py).append("h0"); break;
        case Series::Style::Step:
          if (pen) d.append("H").append(px).append("V").append(py);
          else d.append("M").append(px).append(" ").append(py);
          break;
        default: d.append(pen ? "L" : "M").append(px).append(" ").append(py);
      }
      pen = true;
    }
    drawn_total += points;
    if (s.style == Series::Style::Step && pen) d.append("H").append(num(pr));  // the last value holds to the end
    o += "<path class=\"series series-" + std::string(style_name(s.style)) + dash_class(s.dash) +
         "\" data-name=\"" + escape_xml(s.name) + "\" data-style=\"" + style_name(s.style) + "\" data-points=\"" +
         std::to_string(points) + "\" data-source-points=\"" + std::to_string(std::min(s.x.size(), s.y.size())) +
         "\" stroke=\"" + escape_xml(s.color) + "\" d=\"" + d + "\"><title>" + escape_xml(s.name) + "</title></path>\n";
  }
  // A chart with nothing to draw says so: an empty frame reads like a drawing that failed.
  if (drawn_total == 0)
    o += "<text class=\"no-data\" x=\"" + num((pl + pr) / 2) + "\" y=\"" + num((pt + pb) / 2) +
         "\" text-anchor=\"middle\">no data</text>\n";
  o += "</g>\n</svg>\n<figcaption class=\"legend\">";
  for (const auto& s : c.series)
    o += "<span class=\"key key-" + std::string(style_name(s.style)) + "\"><i style=\"background:" +
         key_background(s) + "\"></i>" + escape_xml(s.name) + "</span>";
  for (const auto& b : c.hbands) o += "<span class=\"key\"><i class=\"hband-key\"></i>" + escape_xml(b.label) + "</span>";
  for (const auto& [kind, text] : c.marker_keys)
    o += "<span class=\"key key-marker\"><i class=\"marker-key marker-key-" + escape_xml(kind) + "\"></i>" +
         escape_xml(text) + "</span>";
  o += "</figcaption>\n</figure>\n";
  return o;
}

}  // namespace alc::report
