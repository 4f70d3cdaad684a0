#include "study/figures.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <numbers>
#include <set>
#include <sstream>

#include "common/atomic_file.hpp"
#include "common/number_text.hpp"
#include "runtime/parameter_options.hpp"

namespace alc::study {

namespace {

namespace fs = std::filesystem;

constexpr const char* kFont = "font-family=\"DejaVu Sans, Helvetica, Arial, sans-serif\"";

std::string fmt(double v, int precision) {
  char b[64];
  std::snprintf(b, sizeof b, "%.*f", precision, v);
  return b;
}

// A coordinate (two decimals are far below a pixel).
std::string c(double v) { return fmt(v, 2); }

std::string esc(const std::string& s) { return xml_escape(s); }

// An option's unit for a label ("h", "min"; nothing for "-").
std::string unit_of(const std::string& option) {
  const auto* o = runtime::find_parameter_option(option);
  if (!o || o->unit == "-") return "";
  return std::string(o->unit);
}

std::string with_unit(const std::string& option, const std::string& value) {
  const std::string u = unit_of(option);
  return option + " = " + value + (u.empty() || value == "inf" ? "" : " " + u);
}

// A file name part: letters, digits, '.', '-', '_' kept, anything else '_'.
std::string file_part(const std::string& s) {
  std::string out;
  for (const char ch : s) {
    const bool keep = (ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') || (ch >= '0' && ch <= '9') || ch == '.' ||
                      ch == '-' || ch == '_';
    out += keep ? ch : '_';
  }
  if (out.empty() || out == "." || out == "..") out = "_" + out;
  return out;
}

// Tick step of about `target` intervals over `span`: 1, 2 or 5 times a power of ten.
double nice_step(double span, int target) {
  if (!(span > 0)) return 1.0;
  const double raw = span / target;
  const double p = std::pow(10.0, std::floor(std::log10(raw)));
  const double m = raw / p;
  return (m < 1.5 ? 1.0 : m < 3.5 ? 2.0 : m < 7.5 ? 5.0 : 10.0) * p;
}

int decimals_of(double step) {
  if (step >= 1.0) return 0;
  return static_cast<int>(std::ceil(-std::log10(step) - 1e-9));
}

struct Axis {
  double lo = 0, hi = 1, step = 1;
  double px0 = 0, px1 = 1;  // pixel positions of lo and hi
  double map(double v) const { return px0 + (v - lo) / (hi - lo) * (px1 - px0); }
  std::vector<double> ticks() const {
    std::vector<double> t;
    for (double v = lo; v <= hi + step * 1e-6; v += step) t.push_back(std::abs(v) < step * 1e-9 ? 0.0 : v);
    return t;
  }
};

// An axis over [lo, hi] widened to whole ticks.
Axis nice_axis(double lo, double hi, double px0, double px1) {
  if (!(hi > lo)) {
    const double pad = std::max(1.0, std::abs(lo) * 0.01);
    lo -= pad;
    hi += pad;
  }
  Axis a;
  a.step = nice_step(hi - lo, 6);
  a.lo = std::floor(lo / a.step + 1e-9) * a.step;
  a.hi = std::ceil(hi / a.step - 1e-9) * a.step;
  if (!(a.hi > a.lo)) a.hi = a.lo + a.step;
  a.px0 = px0;
  a.px1 = px1;
  return a;
}

// Viridis, sampled at nine points, interpolated linearly: t in [0, 1] to "#rrggbb" and its luminance.
struct Colour {
  std::string hex;
  double luminance;
};
Colour viridis(double t) {
  static constexpr std::array<std::array<double, 3>, 9> stops{{{68, 1, 84},
                                                              {71, 44, 122},
                                                              {59, 81, 139},
                                                              {44, 113, 142},
                                                              {33, 144, 141},
                                                              {39, 173, 129},
                                                              {92, 200, 99},
                                                              {170, 220, 50},
                                                              {253, 231, 37}}};
  t = std::clamp(std::isfinite(t) ? t : 0.0, 0.0, 1.0);
  const double x = t * static_cast<double>(stops.size() - 1);
  const auto i = std::min(static_cast<std::size_t>(x), stops.size() - 2);
  const double f = x - static_cast<double>(i);
  std::array<int, 3> rgb{};
  for (std::size_t k = 0; k < 3; ++k)
    rgb[k] = static_cast<int>(std::lround(stops[i][k] + f * (stops[i + 1][k] - stops[i][k])));
  char b[8];
  std::snprintf(b, sizeof b, "#%02x%02x%02x", rgb[0], rgb[1], rgb[2]);
  return {b, (0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]) / 255.0};
}

// Splits `text` at spaces into lines of at most about `width` characters.
std::vector<std::string> wrap(const std::string& text, std::size_t width) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  std::string word, line;
  while (in >> word) {
    if (!line.empty() && line.size() + 1 + word.size() > width) {
      lines.push_back(line);
      line.clear();
    }
    line += (line.empty() ? "" : " ") + word;
  }
  if (!line.empty()) lines.push_back(line);
  return lines;
}

class Svg {
 public:
  Svg(double width, double height, const std::string& title) {
    out_ << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
         << "<svg xmlns=\"http://www.w3.org/2000/svg\" version=\"1.1\" width=\"" << c(width) << "\" height=\""
         << c(height) << "\" viewBox=\"0 0 " << c(width) << " " << c(height) << "\" " << kFont << ">\n"
         << "<title>" << esc(title) << "</title>\n"
         << "<rect x=\"0\" y=\"0\" width=\"" << c(width) << "\" height=\"" << c(height) << "\" fill=\"#ffffff\"/>\n";
  }
  // Text at (x, y); anchor start, middle or end; `attrs` more attributes (already escaped).
  Svg& text(double x, double y, const std::string& s, double size, const std::string& anchor = "start",
            const std::string& attrs = "") {
    out_ << "<text x=\"" << c(x) << "\" y=\"" << c(y) << "\" font-size=\"" << fmt(size, 0) << "\" text-anchor=\""
         << anchor << "\"" << (attrs.empty() ? "" : " " + attrs) << ">" << esc(s) << "</text>\n";
    return *this;
  }
  Svg& line(double x1, double y1, double x2, double y2, const std::string& attrs) {
    out_ << "<line x1=\"" << c(x1) << "\" y1=\"" << c(y1) << "\" x2=\"" << c(x2) << "\" y2=\"" << c(y2) << "\" "
         << attrs << "/>\n";
    return *this;
  }
  Svg& raw(const std::string& s) {
    out_ << s;
    return *this;
  }
  std::string str() {
    out_ << "</svg>\n";
    return out_.str();
  }

 private:
  std::ostringstream out_;
};

// A five-pointed star centred at (x, y) with outer radius r, as path data.
std::string star_path(double x, double y, double r) {
  std::string d;
  for (int k = 0; k < 10; ++k) {
    const double a = -std::numbers::pi / 2 + k * std::numbers::pi / 5;
    const double rr = k % 2 == 0 ? r : r * 0.45;
    d += (k == 0 ? "M" : " L") + c(x + rr * std::cos(a)) + " " + c(y + rr * std::sin(a));
  }
  return d + " Z";
}

struct Value {
  double p99 = NAN, pd = NAN;
};

// The finite (P99, Pd) of each row by (set, case); rows without both are not in it.
std::map<std::pair<std::size_t, std::size_t>, Value> finite_values(const std::vector<storage::StudyRowRecord>& rows) {
  std::map<std::pair<std::size_t, std::size_t>, Value> v;
  for (const auto& r : rows)
    if (r.ok && r.p99_linear && r.pd && std::isfinite(*r.p99_linear) && std::isfinite(*r.pd) && r.set_index >= 0 &&
        r.case_index >= 0)
      v[{static_cast<std::size_t>(r.set_index), static_cast<std::size_t>(r.case_index)}] = {*r.p99_linear, *r.pd};
  return v;
}

std::string axes_text(const StudyInfo& info) {
  std::string s;
  for (const auto& [k, values] : info.grid.axes) s += (s.empty() ? "" : ", ") + k + " (" + std::to_string(values.size()) + ")";
  return s;
}

// ---- Pareto plot of one case ------------------------------------------------------------------

std::string pareto_svg(const StudyInfo& info, const std::vector<storage::StudyRowRecord>& rows, const Analysis& a,
                       std::size_t ci) {
  const CaseAnalysis& ca = a.cases[ci];
  const std::string case_name = info.cases[ci].name;
  struct P {
    std::size_t set;
    double pd, p99;
  };
  std::vector<P> pts;
  std::size_t failed = 0, not_finite = 0;
  std::optional<P> paper;
  for (const auto& r : rows) {
    if (r.case_index < 0 || static_cast<std::size_t>(r.case_index) != ci) continue;
    if (!r.ok || !r.p99_linear || !r.pd) {
      ++failed;
      continue;
    }
    if (!std::isfinite(*r.p99_linear) || !std::isfinite(*r.pd)) {
      ++not_finite;
      continue;
    }
    const P p{static_cast<std::size_t>(r.set_index), *r.pd, *r.p99_linear};
    pts.push_back(p);
    if (a.paper_set && p.set == *a.paper_set) paper = p;
  }
  std::vector<P> front;
  for (const Point& p : ca.pareto)
    if (std::isfinite(p.pd) && std::isfinite(p.p99_linear)) front.push_back({p.set, p.pd, p.p99_linear});
  std::optional<P> optimum;
  if (ca.optimum && std::isfinite(ca.optimum->pd) && std::isfinite(ca.optimum->p99_linear))
    optimum = P{ca.optimum->set, ca.optimum->pd, ca.optimum->p99_linear};

  const double W = 960;
  const double L = 80, R = 640, T = 78, B = 470;  // plot area
  // Caption and what was left out, wrapped to the width of the figure.
  std::vector<std::pair<std::string, std::string>> captions;  // line, attributes
  const auto caption = [&](const std::string& text, const std::string& attrs) {
    for (const std::string& line : wrap(text, 128)) captions.emplace_back(line, attrs);
  };
  caption("x: Pd (right: fewer probe cycles), y: mean linear P99 over the linear outputs (down: more accurate); "
          "better sets lie to the bottom right. One point per parameter set on case " + case_name +
              "; the Eq. 8 optimum is the highest Pd below the limit.",
          "class=\"caption\" fill=\"#333333\"");
  if (failed + not_finite > 0)
    caption("Left out: " + std::to_string(failed + not_finite) + " rows (" + std::to_string(failed) +
                " failed or without P99/Pd, " + std::to_string(not_finite) + " with a NaN or infinite value).",
            "class=\"note\" fill=\"#a04000\"");
  double cy = B + 70;
  const double H = cy + 16.0 * static_cast<double>(captions.size()) + 10;
  double xlo = INFINITY, xhi = -INFINITY, yhi = a.limit_um;
  for (const P& p : pts) {
    xlo = std::min(xlo, p.pd);
    xhi = std::max(xhi, p.pd);
    yhi = std::max(yhi, p.p99);
  }
  for (const P& p : front) {
    xlo = std::min(xlo, p.pd);
    xhi = std::max(xhi, p.pd);
    yhi = std::max(yhi, p.p99);
  }
  if (!std::isfinite(xlo)) xlo = 0, xhi = 100;
  const Axis ax = nice_axis(xlo, xhi, L, R);
  const Axis ay = nice_axis(0.0, yhi * 1.02, B, T);

  const std::string title = "Case " + case_name + ": mean linear P99 against Pd, " + std::to_string(pts.size()) +
                            " parameter sets";
  Svg svg(W, H, title);
  svg.text(L, 30, title, 17, "start", "font-weight=\"bold\" class=\"title\"");
  svg.text(L, 52, "Grid axes (values): " + axes_text(info) + "; limit " + fmt(a.limit_um, 1) +
                      " µm (Eq. 8)", 12, "start", "fill=\"#444444\"");
  // Plot frame, grid lines, ticks.
  std::ostringstream g;
  g << "<g class=\"axes\" font-size=\"12\" fill=\"#222222\">\n";
  for (const double v : ax.ticks()) {
    const double x = ax.map(v);
    g << "<line x1=\"" << c(x) << "\" y1=\"" << c(T) << "\" x2=\"" << c(x) << "\" y2=\"" << c(B)
      << "\" stroke=\"#e6e6e6\"/>\n<line x1=\"" << c(x) << "\" y1=\"" << c(B) << "\" x2=\"" << c(x) << "\" y2=\""
      << c(B + 5) << "\" stroke=\"#222222\"/>\n<text x=\"" << c(x) << "\" y=\"" << c(B + 19)
      << "\" text-anchor=\"middle\">" << fmt(v, decimals_of(ax.step)) << "</text>\n";
  }
  for (const double v : ay.ticks()) {
    const double y = ay.map(v);
    g << "<line x1=\"" << c(L) << "\" y1=\"" << c(y) << "\" x2=\"" << c(R) << "\" y2=\"" << c(y)
      << "\" stroke=\"#e6e6e6\"/>\n<line x1=\"" << c(L - 5) << "\" y1=\"" << c(y) << "\" x2=\"" << c(L) << "\" y2=\""
      << c(y) << "\" stroke=\"#222222\"/>\n<text x=\"" << c(L - 8) << "\" y=\"" << c(y + 4)
      << "\" text-anchor=\"end\">" << fmt(v, decimals_of(ay.step)) << "</text>\n";
  }
  g << "<rect x=\"" << c(L) << "\" y=\"" << c(T) << "\" width=\"" << c(R - L) << "\" height=\"" << c(B - T)
    << "\" fill=\"none\" stroke=\"#222222\"/>\n</g>\n";
  svg.raw(g.str());
  svg.text((L + R) / 2, B + 42, "Pd, productivity (Eq. 7) [%]", 13, "middle", "class=\"xlabel\"");
  svg.raw("<text x=\"" + c(L - 52) + "\" y=\"" + c((T + B) / 2) + "\" font-size=\"13\" text-anchor=\"middle\" "
          "class=\"ylabel\" transform=\"rotate(-90 " + c(L - 52) + " " + c((T + B) / 2) +
          ")\">mean linear P99 [µm]</text>\n");

  // The limit.
  const double ylim = ay.map(a.limit_um);
  svg.line(L, ylim, R, ylim, "class=\"limit\" stroke=\"#c0392b\" stroke-width=\"1.5\" stroke-dasharray=\"7 4\"");
  svg.text(R - 4, ylim - 5, "limit " + fmt(a.limit_um, 1) + " µm", 11, "end", "fill=\"#c0392b\"");

  // Every row.
  std::ostringstream rp;
  rp << "<g class=\"rows\" fill=\"#8c8c8c\" fill-opacity=\"0.55\">\n";
  for (const P& p : pts)
    rp << "<circle class=\"row\" cx=\"" << c(ax.map(p.pd)) << "\" cy=\"" << c(ay.map(p.p99)) << "\" r=\"2.4\"><title>"
       << esc(info.sets[p.set].key + ": P99 " + fmt(p.p99, 2) + " µm, Pd " + fmt(p.pd, 2) + " %") << "</title></circle>\n";
  rp << "</g>\n";
  svg.raw(rp.str());

  // The Pareto front.
  std::ostringstream fp;
  fp << "<g class=\"front\">\n<polyline class=\"pareto\" fill=\"none\" stroke=\"#1f77b4\" stroke-width=\"2\" points=\"";
  for (std::size_t i = 0; i < front.size(); ++i)
    fp << (i ? " " : "") << c(ax.map(front[i].pd)) << "," << c(ay.map(front[i].p99));
  fp << "\"/>\n";
  for (const P& p : front)
    fp << "<circle class=\"pareto-point\" cx=\"" << c(ax.map(p.pd)) << "\" cy=\"" << c(ay.map(p.p99))
       << "\" r=\"3.6\" fill=\"#1f77b4\" stroke=\"#ffffff\" stroke-width=\"0.8\"><title>"
       << esc("Pareto: " + info.sets[p.set].key + ": P99 " + fmt(p.p99, 2) + " µm, Pd " + fmt(p.pd, 2) + " %")
       << "</title></circle>\n";
  fp << "</g>\n";
  svg.raw(fp.str());

  // Seed 004's set (open square) and the Eq. 8 optimum (star) on top.
  if (paper) {
    const double x = ax.map(paper->pd), y = ay.map(paper->p99);
    svg.raw("<rect class=\"paper\" x=\"" + c(x - 7) + "\" y=\"" + c(y - 7) +
            "\" width=\"14\" height=\"14\" fill=\"none\" stroke=\"#2ca02c\" stroke-width=\"2.5\"><title>" +
            esc("seed 004's set: " + info.sets[paper->set].key + ": P99 " + fmt(paper->p99, 2) + " µm, Pd " +
                fmt(paper->pd, 2) + " %") +
            "</title></rect>\n");
  }
  if (optimum) {
    svg.raw("<path class=\"optimum\" d=\"" + star_path(ax.map(optimum->pd), ay.map(optimum->p99), 10) +
            "\" fill=\"#ffbf00\" stroke=\"#000000\" stroke-width=\"1\"><title>" +
            esc("Eq. 8 optimum: " + info.sets[optimum->set].key + ": P99 " + fmt(optimum->p99, 2) + " µm, Pd " +
                fmt(optimum->pd, 2) + " %") +
            "</title></path>\n");
  }

  // Legend.
  const double lx = 660;
  double ly = T + 4;
  std::ostringstream lg;
  lg << "<g class=\"legend\" font-size=\"12\">\n";
  lg << "<rect x=\"" << c(lx - 10) << "\" y=\"" << c(T - 12) << "\" width=\"" << c(W - lx) << "\" height=\"" << c(B - T + 12)
     << "\" fill=\"#fafafa\" stroke=\"#cccccc\"/>\n";
  const auto entry = [&](const std::string& symbol, const std::string& label, const std::vector<std::string>& more) {
    lg << symbol;
    lg << "<text x=\"" << c(lx + 26) << "\" y=\"" << c(ly + 4) << "\">" << esc(label) << "</text>\n";
    for (const std::string& m : more) {
      ly += 15;
      lg << "<text x=\"" << c(lx + 26) << "\" y=\"" << c(ly + 4) << "\" font-size=\"11\" fill=\"#444444\">" << esc(m)
         << "</text>\n";
    }
    ly += 26;
  };
  entry("<circle class=\"legend-row\" cx=\"" + c(lx + 10) + "\" cy=\"" + c(ly) +
            "\" r=\"2.4\" fill=\"#8c8c8c\" fill-opacity=\"0.55\"/>\n",
        "every row (" + std::to_string(pts.size()) + ")", {});
  entry("<line x1=\"" + c(lx) + "\" y1=\"" + c(ly) + "\" x2=\"" + c(lx + 20) + "\" y2=\"" + c(ly) +
            "\" stroke=\"#1f77b4\" stroke-width=\"2\"/><circle cx=\"" + c(lx + 10) + "\" cy=\"" + c(ly) +
            "\" r=\"3.6\" fill=\"#1f77b4\"/>\n",
        "Pareto front (" + std::to_string(front.size()) + " sets)", {"lower P99 and higher Pd", "than any other set"});
  entry("<line x1=\"" + c(lx) + "\" y1=\"" + c(ly) + "\" x2=\"" + c(lx + 20) + "\" y2=\"" + c(ly) +
            "\" stroke=\"#c0392b\" stroke-width=\"1.5\" stroke-dasharray=\"7 4\"/>\n",
        "limit " + fmt(a.limit_um, 1) + " µm", {});
  {
    std::vector<std::string> more;
    if (optimum) {
      more = wrap(info.sets[optimum->set].key, 34);
      more.push_back("P99 " + fmt(optimum->p99, 2) + " µm, Pd " + fmt(optimum->pd, 2) + " %");
    } else {
      more = {"none: no set below " + fmt(a.limit_um, 1) + " µm"};
    }
    entry("<path d=\"" + star_path(lx + 10, ly, 8) + "\" fill=\"#ffbf00\" stroke=\"#000000\" stroke-width=\"1\"/>\n",
          "Eq. 8 optimum", more);
  }
  {
    std::vector<std::string> more;
    if (paper) {
      more = wrap(info.sets[paper->set].key, 34);
      more.push_back("P99 " + fmt(paper->p99, 2) + " µm, Pd " + fmt(paper->pd, 2) + " %");
    } else if (a.paper_set) {
      more = {"no value on this case"};
    } else {
      more = {"not in this grid"};
    }
    entry("<rect x=\"" + c(lx + 4) + "\" y=\"" + c(ly - 6) +
              "\" width=\"12\" height=\"12\" fill=\"none\" stroke=\"#2ca02c\" stroke-width=\"2.5\"/>\n",
          "seed 004's set", more);
  }
  lg << "</g>\n";
  svg.raw(lg.str());

  for (const auto& [line, cls] : captions) {
    svg.text(L, cy, line, 11, "start", cls);
    cy += 16;
  }
  return svg.str();
}

// ---- Heat maps ----------------------------------------------------------------------------------

bool has_axis(const StudyInfo& info, const std::string& option) {
  return std::any_of(info.grid.axes.begin(), info.grid.axes.end(), [&](const auto& a) { return a.first == option; });
}

const std::vector<std::string>& axis_values(const StudyInfo& info, const std::string& option) {
  for (const auto& a : info.grid.axes)
    if (a.first == option) return a.second;
  static const std::vector<std::string> none;
  return none;
}

double number(const std::string& text) { return common::parse_number("cp", text, true); }

struct Cell {
  std::optional<std::size_t> set;  // nullopt: no such set in the grid
  double p99 = NAN, pd = NAN;      // means over the cases with a value
  std::size_t cases = 0;           // cases with a value
  bool spans_column = false;       // one set for every ng-meas row (NG options moot)
};

struct HeatMap {
  std::string cp;
  std::vector<std::pair<std::string, std::string>> fixed;  // other axes, value
  std::string fixed_from;                                  // where the fixed values come from
  std::vector<std::string> intervals, ng_meas;
  std::vector<std::vector<Cell>> cells;                    // [interval][ng-meas]
};

HeatMap heat_map(const StudyInfo& info, const std::vector<storage::StudyRowRecord>& rows, const Analysis& a,
                 const std::string& cp) {
  HeatMap h;
  h.cp = cp;
  h.intervals = axis_values(info, "interval");
  h.ng_meas = axis_values(info, "ng-meas");
  std::vector<std::pair<std::string, std::size_t>> refs;  // reference sets for the fixed axes
  if (!a.cases.empty() && a.cases.front().optimum)
    refs.emplace_back("the Eq. 8 optimum of case " + a.cases.front().name, a.cases.front().optimum->set);
  if (a.paper_set) refs.emplace_back("seed 004's set", *a.paper_set);
  std::set<std::string> sources;
  for (const auto& [option, values] : info.grid.axes) {
    if (option == "cp" || option == "interval" || option == "ng-meas") continue;
    std::string v, from = "the first value of the axis";
    for (const auto& [name, set] : refs)
      if (!(v = info.sets[set].value(option)).empty()) {
        from = name;
        break;
      }
    if (v.empty()) v = values.front();
    h.fixed.emplace_back(option, v);
    sources.insert(from);
  }
  for (const std::string& s : sources) h.fixed_from += (h.fixed_from.empty() ? "" : ", ") + s;

  const auto values = finite_values(rows);
  const auto find_set = [&](const std::string& interval, const std::string& ng_meas) -> std::optional<std::size_t> {
    std::map<std::string, std::string> want(h.fixed.begin(), h.fixed.end());
    want["interval"] = interval;
    want["ng-meas"] = ng_meas;
    if (has_axis(info, "cp")) want["cp"] = cp;
    for (const ParameterSet& s : info.sets) {
      bool match = true;
      for (const auto& [option, value] : want) {
        const std::string v = s.value(option);
        if (!v.empty() && v != value) {  // empty: moot for this set (e.g. ng-meas when interval = inf)
          match = false;
          break;
        }
      }
      if (match) return s.index;
    }
    return std::nullopt;
  };
  for (const std::string& iv : h.intervals) {
    std::vector<Cell> column;
    for (const std::string& nm : h.ng_meas) {
      Cell cell;
      cell.set = find_set(iv, nm);
      if (cell.set) {
        double p99 = 0, pd = 0;
        for (std::size_t ci = 0; ci < info.cases.size(); ++ci) {
          const auto it = values.find({*cell.set, ci});
          if (it == values.end()) continue;
          p99 += it->second.p99;
          pd += it->second.pd;
          ++cell.cases;
        }
        if (cell.cases) {
          cell.p99 = p99 / static_cast<double>(cell.cases);
          cell.pd = pd / static_cast<double>(cell.cases);
        }
      }
      column.push_back(cell);
    }
    const bool one_set = column.size() > 1 && column.front().set &&
                         std::all_of(column.begin(), column.end(), [&](const Cell& x) { return x.set == column.front().set; });
    if (one_set)
      for (Cell& x : column) x.spans_column = true;
    h.cells.push_back(std::move(column));
  }
  return h;
}

std::string heat_map_svg(const StudyInfo& info, const Analysis& a, const HeatMap& h, bool p99) {
  const auto value_of = [&](const Cell& x) { return p99 ? x.p99 : x.pd; };
  const int precision = 2;
  double vmin = INFINITY, vmax = -INFINITY;
  for (const auto& col : h.cells)
    for (const Cell& x : col)
      if (std::isfinite(value_of(x))) {
        vmin = std::min(vmin, value_of(x));
        vmax = std::max(vmax, value_of(x));
      }
  const bool any = std::isfinite(vmin);
  if (!any) vmin = 0, vmax = 1;
  const Axis scale = nice_axis(vmin, vmax, 0, 1);

  const double nx = static_cast<double>(h.intervals.size()), ny = static_cast<double>(h.ng_meas.size());
  // Cells of at least 58 x 40 px, larger for small grids (at least 420 x 220 px in all).
  const double cw = std::max(58.0, std::min(100.0, 420.0 / nx)), ch = std::max(40.0, std::min(110.0, 220.0 / ny));
  const double L = 110, T = 96;
  const double R = L + cw * nx, B = T + ch * ny;
  const double bar_x = R + 30, bar_w = 18;
  const double W = std::max(860.0, bar_x + bar_w + 120);

  const std::string what = p99 ? "mean linear P99 [µm]" : "Pd, productivity (Eq. 7) [%]";
  std::string cases;
  for (const CaseInfo& ci : info.cases) cases += (cases.empty() ? "" : ", ") + ci.name;
  const std::string title = std::string(p99 ? "Mean linear P99" : "Pd") +
                            (info.cases.size() == 1 ? " on case " : " over cases ") + cases + " at " +
                            with_unit("cp", h.cp);
  std::string fixed = "fixed: " + with_unit("cp", h.cp);
  for (const auto& [k, v] : h.fixed) fixed += ", " + with_unit(k, v);
  if (!h.fixed.empty()) fixed += " (from " + h.fixed_from + ")";

  // Caption, wrapped to the width of the figure.
  const std::string over = info.cases.size() == 1 ? "on case " + cases : "as the mean over the " +
                                                                             std::to_string(info.cases.size()) + " cases";
  std::vector<std::string> captions;
  for (const std::string& text :
       {"Cell: the set's " + what + " " + over + (any ? "" : " (no values)") +
            (info.cases.size() > 1 ? "; * fewer cases (failed rows)" : "") + "; n/a: no value; blank: no such set.",
        std::string("A column drawn as one cell is one set for every ng-meas (interval = inf: no probes after CP, so "
                    "no NG phase and ng-meas does not matter).")})
    for (const std::string& line : wrap(text, static_cast<std::size_t>((W - L - 20) / 6.3))) captions.push_back(line);
  const double Hgt = B + 68 + 16.0 * static_cast<double>(captions.size()) + 10;

  Svg svg(W, Hgt, title + "; " + fixed);
  svg.text(L, 30, title, 17, "start", "font-weight=\"bold\" class=\"title\"");
  svg.text(L, 52, fixed, 12, "start", "class=\"fixed\" fill=\"#333333\"");
  svg.text(L, 70, "Grid axes (values): " + axes_text(info), 12, "start", "fill=\"#555555\"");

  std::ostringstream g;
  g << "<g class=\"cells\" font-size=\"12\" text-anchor=\"middle\">\n";
  for (std::size_t i = 0; i < h.cells.size(); ++i) {
    const double x = L + cw * static_cast<double>(i);
    for (std::size_t j = 0; j < h.cells[i].size(); ++j) {
      const Cell& cell = h.cells[i][j];
      if (cell.spans_column && j > 0) continue;
      // The first ng-meas value at the bottom.
      const double y = cell.spans_column ? T : B - ch * static_cast<double>(j + 1);
      const double hh = cell.spans_column ? B - T : ch;
      if (!cell.set) {
        g << "<rect class=\"empty\" x=\"" << c(x + 1) << "\" y=\"" << c(y + 1) << "\" width=\"" << c(cw - 2)
          << "\" height=\"" << c(hh - 2) << "\" fill=\"#ffffff\" stroke=\"#dddddd\"><title>"
          << esc("no set with interval = " + h.intervals[i] + ", ng-meas = " + h.ng_meas[j] + " in the grid")
          << "</title></rect>\n";
        continue;
      }
      const double v = value_of(cell);
      const std::string key = info.sets[*cell.set].key;
      const std::string ng = cell.spans_column ? "all" : h.ng_meas[j];
      const std::string tip = key + ": " + (std::isfinite(v) ? fmt(v, precision) : std::string("no value")) + " (" +
                              std::to_string(cell.cases) + " of " + std::to_string(info.cases.size()) + " cases)";
      if (std::isfinite(v)) {
        const Colour col = viridis((v - scale.lo) / (scale.hi - scale.lo));
        g << "<g class=\"cell\" data-interval=\"" << esc(h.intervals[i]) << "\" data-ng-meas=\"" << esc(ng)
          << "\" data-set=\"" << *cell.set << "\" data-value=\"" << common::shortest_text(v) << "\">"
          << "<rect x=\"" << c(x + 1) << "\" y=\"" << c(y + 1) << "\" width=\"" << c(cw - 2) << "\" height=\""
          << c(hh - 2) << "\" fill=\"" << col.hex << "\"><title>" << esc(tip) << "</title></rect>"
          << "<text class=\"value\" x=\"" << c(x + cw / 2) << "\" y=\"" << c(y + hh / 2 + 4) << "\" fill=\""
          << (col.luminance > 0.5 ? "#000000" : "#ffffff") << "\">" << fmt(v, precision)
          << (cell.cases < info.cases.size() ? "*" : "") << "</text></g>\n";
      } else {
        g << "<g class=\"cell nodata\" data-interval=\"" << esc(h.intervals[i]) << "\" data-ng-meas=\"" << esc(ng)
          << "\" data-set=\"" << *cell.set << "\"><rect x=\"" << c(x + 1) << "\" y=\"" << c(y + 1) << "\" width=\""
          << c(cw - 2) << "\" height=\"" << c(hh - 2)
          << "\" fill=\"#f2f2f2\" stroke=\"#bbbbbb\" stroke-dasharray=\"3 2\"><title>" << esc(tip)
          << "</title></rect><text class=\"value\" x=\"" << c(x + cw / 2) << "\" y=\"" << c(y + hh / 2 + 4)
          << "\" fill=\"#777777\">n/a</text></g>\n";
      }
    }
  }
  g << "</g>\n";
  // Axes: labels of the columns (interval) and rows (ng-meas).
  g << "<g class=\"axes\" font-size=\"12\" fill=\"#222222\">\n";
  for (std::size_t i = 0; i < h.intervals.size(); ++i)
    g << "<text x=\"" << c(L + cw * (static_cast<double>(i) + 0.5)) << "\" y=\"" << c(B + 18)
      << "\" text-anchor=\"middle\">" << esc(h.intervals[i]) << "</text>\n";
  for (std::size_t j = 0; j < h.ng_meas.size(); ++j)
    g << "<text x=\"" << c(L - 8) << "\" y=\"" << c(B - ch * (static_cast<double>(j) + 0.5) + 4)
      << "\" text-anchor=\"end\">" << esc(h.ng_meas[j]) << "</text>\n";
  g << "</g>\n";
  svg.raw(g.str());
  svg.text((L + R) / 2, B + 40, "Post-CP probe interval, interval [" + unit_of("interval") + "]", 13, "middle",
           "class=\"xlabel\"");
  svg.raw("<text x=\"" + c(L - 48) + "\" y=\"" + c((T + B) / 2) +
          "\" font-size=\"13\" text-anchor=\"middle\" class=\"ylabel\" transform=\"rotate(-90 " + c(L - 48) + " " +
          c((T + B) / 2) + ")\">NG measurements, ng-meas [-]</text>\n");

  // Colour bar: the scale from the bottom (low) to the top (high), discrete steps.
  std::ostringstream cb;
  cb << "<g class=\"colourbar\" font-size=\"11\">\n";
  const int steps = 64;
  const double bar_h = B - T;
  for (int k = 0; k < steps; ++k) {
    const double t0 = static_cast<double>(k) / steps;
    cb << "<rect x=\"" << c(bar_x) << "\" y=\"" << c(B - bar_h * (t0 + 1.0 / steps)) << "\" width=\"" << c(bar_w)
       << "\" height=\"" << c(bar_h / steps + 0.5) << "\" fill=\"" << viridis(t0 + 0.5 / steps).hex << "\"/>\n";
  }
  cb << "<rect x=\"" << c(bar_x) << "\" y=\"" << c(T) << "\" width=\"" << c(bar_w) << "\" height=\"" << c(bar_h)
     << "\" fill=\"none\" stroke=\"#222222\"/>\n";
  const std::vector<double> ticks = scale.ticks();
  const std::size_t every = ticks.size() > 8 ? 2 : 1;
  for (std::size_t k = 0; k < ticks.size(); k += every) {
    const double y = B - bar_h * (ticks[k] - scale.lo) / (scale.hi - scale.lo);
    cb << "<line x1=\"" << c(bar_x + bar_w) << "\" y1=\"" << c(y) << "\" x2=\"" << c(bar_x + bar_w + 4) << "\" y2=\""
       << c(y) << "\" stroke=\"#222222\"/><text x=\"" << c(bar_x + bar_w + 7) << "\" y=\"" << c(y + 4) << "\">"
       << fmt(ticks[k], decimals_of(scale.step)) << "</text>\n";
  }
  if (p99 && a.limit_um > scale.lo && a.limit_um < scale.hi) {
    const double y = B - bar_h * (a.limit_um - scale.lo) / (scale.hi - scale.lo);
    cb << "<line class=\"limit\" x1=\"" << c(bar_x) << "\" y1=\"" << c(y) << "\" x2=\"" << c(bar_x + bar_w + 44)
       << "\" y2=\"" << c(y) << "\" stroke=\"#c0392b\" stroke-width=\"2\" stroke-dasharray=\"4 2\"/>"
       << "<text x=\"" << c(bar_x + bar_w + 48) << "\" y=\"" << c(y + 4) << "\" fill=\"#c0392b\">limit "
       << fmt(a.limit_um, 1) << " µm</text>\n";
  }
  cb << "<text x=\"" << c(bar_x) << "\" y=\"" << c(T - 10) << "\" font-size=\"12\">" << (p99 ? "P99 [µm]" : "Pd [%]")
     << "</text>\n</g>\n";
  svg.raw(cb.str());

  double cy = B + 68;
  for (const std::string& line : captions) {
    svg.text(L, cy, line, 11, "start", "class=\"caption\" fill=\"#333333\"");
    cy += 16;
  }
  return svg.str();
}

// Appends a UTF-8 sequence for code point `cp`.
void put_utf8(std::string& out, unsigned cp) {
  if (cp < 0x80) {
    out += static_cast<char>(cp);
  } else if (cp < 0x800) {
    out += static_cast<char>(0xC0 | (cp >> 6));
    out += static_cast<char>(0x80 | (cp & 0x3F));
  } else if (cp < 0x10000) {
    out += static_cast<char>(0xE0 | (cp >> 12));
    out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
    out += static_cast<char>(0x80 | (cp & 0x3F));
  } else {
    out += static_cast<char>(0xF0 | (cp >> 18));
    out += static_cast<char>(0x80 | ((cp >> 12) & 0x3F));
    out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
    out += static_cast<char>(0x80 | (cp & 0x3F));
  }
}

}  // namespace

std::string xml_escape(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  const auto* s = reinterpret_cast<const unsigned char*>(text.data());
  const std::size_t n = text.size();
  for (std::size_t i = 0; i < n;) {
    const unsigned char b = s[i];
    if (b < 0x80) {
      switch (b) {
        case '&': out += "&amp;"; break;
        case '<': out += "&lt;"; break;
        case '>': out += "&gt;"; break;
        case '"': out += "&quot;"; break;
        case '\'': out += "&apos;"; break;
        default:
          if (b < 0x20 && b != '\t' && b != '\n' && b != '\r') put_utf8(out, 0xFFFD);
          else out += static_cast<char>(b);
      }
      ++i;
      continue;
    }
    // A well-formed UTF-8 sequence of a character XML allows, else U+FFFD for the first byte.
    std::size_t len = b >= 0xF0 && b <= 0xF4 ? 4 : b >= 0xE0 ? 3 : b >= 0xC2 && b <= 0xDF ? 2 : 0;
    if (b > 0xF4) len = 0;
    unsigned cp = len == 2 ? (b & 0x1Fu) : len == 3 ? (b & 0x0Fu) : (b & 0x07u);
    bool ok = len > 0 && i + len <= n;
    for (std::size_t k = 1; ok && k < len; ++k) {
      if ((s[i + k] & 0xC0) != 0x80) ok = false;
      else cp = (cp << 6) | (s[i + k] & 0x3Fu);
    }
    if (ok) {
      const unsigned min = len == 2 ? 0x80 : len == 3 ? 0x800 : 0x10000;
      ok = cp >= min && cp <= 0x10FFFF && !(cp >= 0xD800 && cp <= 0xDFFF) && cp != 0xFFFE && cp != 0xFFFF;
    }
    if (ok) {
      out.append(text, i, len);
      i += len;
    } else {
      put_utf8(out, 0xFFFD);
      ++i;
    }
  }
  return out;
}

std::vector<std::string> cp_values(const StudyInfo& info) {
  if (has_axis(info, "cp")) return axis_values(info, "cp");
  for (const auto& [k, v] : info.grid.fixed)
    if (k == "cp") return {v};
  return {common::shortest_text(AlcParameters{}.cp_duration_s / 3600.0)};
}

std::string grid_cp(const StudyInfo& info, const std::string& text) {
  const std::vector<std::string> values = cp_values(info);
  std::string list;
  for (const std::string& v : values) list += (list.empty() ? "" : ", ") + v;
  double want = NAN;
  try {
    want = common::parse_number("cp", text, true);
  } catch (const std::invalid_argument&) {
  }
  for (const std::string& v : values) {
    double have = NAN;
    try {
      have = number(v);
    } catch (const std::invalid_argument&) {
      continue;
    }
    if (have == want) return v;
  }
  throw FigureError("'" + text + "' is not a CP of the grid (cp [h]: " + list + ")");
}

std::string default_heatmap_cp(const StudyInfo& info, const Analysis& analysis) {
  if (!analysis.cases.empty() && analysis.cases.front().optimum) {
    const std::string v = info.sets[analysis.cases.front().optimum->set].value("cp");
    if (!v.empty()) return v;
  }
  return cp_values(info).front();
}

FiguresRendered render_figures(const StudyInfo& info, const std::vector<storage::StudyRowRecord>& rows,
                               const Analysis& analysis, const std::optional<std::string>& heatmap_cp) {
  FiguresRendered out;
  out.heatmap_cp = heatmap_cp ? grid_cp(info, *heatmap_cp) : default_heatmap_cp(info, analysis);
  std::set<std::string> names;
  for (std::size_t ci = 0; ci < analysis.cases.size() && ci < info.cases.size(); ++ci) {
    // Two cases can write the same file part ('x y' and 'x_y'), and a case's own name can end as another
    // one's suffix would ('x_y-3'): the suffix grows until the name is free.
    const std::string base = "pareto-" + file_part(info.cases[ci].name);
    std::string name = base;
    for (std::size_t k = ci + 1; !names.insert(name).second; ++k) name = base + "-" + std::to_string(k);
    out.figures.push_back({name, pareto_svg(info, rows, analysis, ci)});
  }
  if (!has_axis(info, "interval") || !has_axis(info, "ng-meas")) {
    out.notes.push_back(std::string("no heat map: the grid has no '") +
                        (has_axis(info, "interval") ? "ng-meas" : "interval") + "' axis");
    return out;
  }
  const HeatMap h = heat_map(info, rows, analysis, out.heatmap_cp);
  for (const bool p99 : {true, false})
    out.figures.push_back({std::string(p99 ? "heatmap-p99-cp" : "heatmap-pd-cp") + file_part(out.heatmap_cp),
                           heat_map_svg(info, analysis, h, p99)});
  return out;
}

FiguresWritten write_figures(const StudyInfo& info, const std::vector<storage::StudyRowRecord>& rows,
                             const Analysis& analysis, const fs::path& dir,
                             const std::optional<std::string>& heatmap_cp) {
  FiguresRendered rendered = render_figures(info, rows, analysis, heatmap_cp);
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw std::runtime_error("cannot create '" + dir.string() + "': " + ec.message());
  FiguresWritten out;
  for (const Figure& f : rendered.figures) {
    const fs::path file = dir / (f.name + ".svg");
    io::write_file_atomically(file, f.svg);
    out.files.push_back(file);
  }
  out.notes = std::move(rendered.notes);
  return out;
}

}  // namespace alc::study
