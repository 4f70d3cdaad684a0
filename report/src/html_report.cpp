#include "report/html_report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <limits>
#include <nlohmann/json.hpp>

#include "alc/error_kind.hpp"
#include "probing/schedule.hpp"
#include "report/run_data.hpp"
#include "report/svg_chart.hpp"
#include "runtime/report_json.hpp"
#include "storage/history_reader.hpp"
#include "storage/study_store.hpp"
#include "study/analysis.hpp"
#include "study/figures.hpp"
#include "study/results.hpp"

namespace alc::report {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
const char* const kPalette[] = {"#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd",
                                "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"};
constexpr std::size_t kPaletteSize = sizeof kPalette / sizeof kPalette[0];

std::string fmt(double v, int precision = 2) {
  if (std::isnan(v)) return "-";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", precision, v);
  return buf;
}

std::string utc_text(double unix_s) {
  const auto t = static_cast<std::time_t>(unix_s);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%d %H:%M UTC", &tm);
  return text;
}

// Unit of an input channel from its name: T… temperatures, n_… speeds, anything else a state.
std::string input_unit(const std::string& name) {
  if (!name.empty() && name[0] == 'T') return "°C";
  if (name.rfind("n_", 0) == 0) return "rpm";
  return "-";
}

// Unit of an offset channel from its name ("X_um", "C_urad").
std::string offset_unit(const std::string& name) {
  const auto u = name.rfind('_');
  const std::string s = u == std::string::npos ? "" : name.substr(u + 1);
  if (s == "um") return "µm";
  if (s == "urad") return "µrad";
  return s.empty() ? "-" : s;
}

class Page {
 public:
  explicit Page(ReportStats& stats) : stats_(stats) {}
  void chart(const Chart& c) {
    html += render_svg(c);
    ++stats_.charts;
    stats_.series += c.series.size();
    for (const auto& s : c.series) stats_.points += drawn_points(c, s);
  }
  ReportStats& stats() { return stats_; }
  std::string html;

 private:
  ReportStats& stats_;
};

// The per-run part of the page.
class RunSection {
 public:
  RunSection(const RunData& d, Page& page) : d_(d), page_(page) {
    t0_s_ = d.samples.empty() ? 0.0 : d.samples.front().time_s;
    double last = d.samples.empty() ? 0.0 : d.samples.back().time_s;
    for (const auto& p : d.probes) last = std::max(last, p.time_s);
    x_range_ = {0.0, std::max(hours(last), 1e-3)};
    // Phase spans: from the start to the first change in its from-phase (replay records no change at
    // the start), then from each change to the next, the last to the end of the run. A run without a
    // change (stopped, or ended, in calibration) spent all of it in the phase a controller starts in.
    if (d.phases.empty()) spans_.push_back({0.0, x_range_.second, "CP"});
    if (!d.phases.empty() && !d.phases.front().from_phase.empty())
      spans_.push_back({0.0, hours(d.phases.front().time_s), d.phases.front().from_phase});
    for (std::size_t i = 0; i < d.phases.size(); ++i) {
      const double end = i + 1 < d.phases.size() ? hours(d.phases[i + 1].time_s) : x_range_.second;
      spans_.push_back({hours(d.phases[i].time_s), end, d.phases[i].to_phase});
    }
    for (const auto& m : d.models)
      updates_.push_back({hours(m.time_s), m.adopted ? "update" : "rejected",
                          (m.adopted ? "model update at " : "rejected fit at ") + fmt(hours(m.time_s)) + " h: " +
                              m.reason});
  }

  void write() {
    const auto& r = d_.run;
    std::string& h = page_.html;
    const std::string id = "run-" + std::to_string(r.run_id);
    h += "<section class=\"run\" id=\"" + id + "\" data-run=\"" + std::to_string(r.run_id) + "\">\n";
    h += "<h2>Run " + std::to_string(r.run_id) + ": " + escape_xml(r.source) + " <small>(" +
         storage::to_string(r.status) + ")</small></h2>\n";
    h += "<p class=\"meta\">started " + utc_text(r.started_unix_s) +
         (r.ended_unix_s ? ", ended " + utc_text(*r.ended_unix_s) : std::string(", not ended")) +
         (r.software_version.empty() ? "" : " by " + escape_xml(r.software_version)) + "; " + std::to_string(d_.samples.size()) + " input samples, " +
         std::to_string(d_.probes.size()) + " probes, " + std::to_string(d_.models.size()) +
         " model parameter sets. Time axes: hours from the run's first sample (time_s " + fmt(t0_s_, 0) +
         " s).</p>\n";
    indicators();
    if (d_.samples.empty() && d_.probes.empty() && d_.predictions.empty()) {
      // Twenty frames, each empty, said nothing about why.
      h += "<p class=\"note no-data\">This run holds no input samples, probes or predictions (it ended, or the file "
           "was read, before its first sample): no chart to draw.</p>\n";
    } else {
      errors();
      inputs();
      probing();
      offsets();
    }
    models();
    parameters();
    h += "</section>\n";
  }

 private:
  double hours(double time_s) const { return (time_s - t0_s_) / 3600.0; }

  Chart base(const std::string& id, const std::string& title, const std::string& y_label) const {
    Chart c;
    c.id = "run" + std::to_string(d_.run.run_id) + "-" + id;
    c.title = title;
    c.x_label = "time [h]";
    c.y_label = y_label;
    c.x_range = x_range_;
    return c;
  }

  // The indicators table: the run's stored indicators (what `alc replay --json` printed when it
  // ended) when the history holds them, else the ones computed from its probes, labelled as such.
  // Every number also carries its exact value (data-value) for tests and tools.
  void indicators() {
    std::string& h = page_.html;
    const bool stored = d_.indicators.has_value();
    nlohmann::json doc;
    runtime::ReplayReport rep;
    std::string unreadable;  // why the stored document cannot be shown (a damaged row)
    if (stored) {
      doc = nlohmann::json::parse(d_.indicators->report_json, nullptr, false);
      if (doc.is_discarded())
        unreadable = "run_indicators.report_json is not JSON";
      else if (!doc.is_object() || !doc.contains("outputs"))
        unreadable = "run_indicators.report_json is not a JSON object with \"outputs\"";
      else
        try {
          rep = runtime::report_from_json(doc, d_.run.output_names);
        } catch (const nlohmann::json::exception& e) {
          unreadable = std::string("run_indicators.report_json: ") + e.what();
        }
    }
    const bool usable = stored && unreadable.empty();
    if (!usable) {
      doc = runtime::report_json(history_indicators(d_));
      rep = runtime::report_from_json(doc, d_.run.output_names);
    }
    // One time convention on the page, the axes': hours from the run's first sample. Both documents
    // give the end of CP in the scenario's time (time_s / 3600), which differs when a recording does
    // not start at 0 (a recording shifted by 10 h said "CP ended at 16.50 h" beside CP shaded to 6.5 h).
    // The shown value is also the one in data-value.
    if (t0_s_ != 0.0 && std::isfinite(rep.cp_end_s)) {
      rep.cp_end_s -= t0_s_;
      doc["cp_end_h"] = doc.at("cp_end_h").get<double>() - t0_s_ / 3600.0;
    }
    const auto value = [&](const nlohmann::json& j, const char* key, const std::string& text) {
      const nlohmann::json& v = j.contains(key) ? j.at(key) : nlohmann::json();
      return "<span data-key=\"" + std::string(key) + "\" data-value=\"" + escape_xml(v.dump()) + "\">" + text +
             "</span>";
    };
    const std::string source = usable ? "replay" : "probes";
    h += "<h3>Indicators" + std::string(usable ? "" : " (from the probes of this history)") + "</h3>\n";
    h += "<p class=\"summary\" data-indicators=\"" + source + "\">duration " +
         value(doc, "duration_h", fmt(rep.duration_s / 3600.0, 1)) + " h, CP " +
         (std::isfinite(rep.cp_end_s)
              ? "ended at " + value(doc, "cp_end_h", fmt(rep.cp_end_s / 3600.0, 2)) + " h"
              : value(doc, "cp_end_h", "not ended") + " (the run was in calibration up to its last sample)") +
         ", M = " + value(doc, "M", std::to_string(rep.M)) + " probe cycles, Pd = " + value(doc, "Pd", fmt(rep.Pd)) +
         " %, NG phases " + value(doc, "ng_phases", std::to_string(rep.ng_phases)) + ", model updates " +
         value(doc, "updates", std::to_string(rep.updates)) + ", rejected fits " +
         value(doc, "rejected_fits", std::to_string(rep.rejected_fits)) + "</p>\n";
    h += "<table class=\"indicators\" data-indicators=\"" + source +
         "\"><thead><tr><th>output</th><th>unit</th><th>PV [%]</th><th>RMSE</th><th>P99</th><th>SMAPE [%]</th>"
         "<th>P99 uncomp</th><th>P99 baseline</th><th>" +
         (usable ? "measurements evaluated" : "probes evaluated") + "</th></tr></thead><tbody>\n";
    const nlohmann::json& outs = doc.at("outputs");
    const nlohmann::json& base = doc.at("baseline").at("outputs");
    const auto cell = [&](const nlohmann::json& o, const char* key, const std::string& text) {
      return "<td data-key=\"" + std::string(key) + "\" data-value=\"" +
             escape_xml(o.contains(key) ? o.at(key).dump() : "null") + "\">" + text + "</td>";
    };
    for (std::size_t i = 0; i < rep.outputs.size(); ++i) {
      const auto& o = rep.outputs[i];
      const nlohmann::json& oj = outs.at(o.name);
      const nlohmann::json bj = base.contains(o.name) ? base.at(o.name) : nlohmann::json::object();
      const auto b = std::find_if(rep.baseline.begin(), rep.baseline.end(),
                                  [&](const runtime::OutputIndicators& x) { return x.name == o.name; });
      const double base_p99 = b != rep.baseline.end() ? b->P99 : kNaN;
      h += "<tr data-output=\"" + escape_xml(o.name) + "\"><td>" + escape_xml(o.name) + "</td><td>" +
           std::string(unit_of(o.kind)) + "</td>" + cell(oj, "PV", fmt(o.PV, 1)) + cell(oj, "RMSE", fmt(o.RMSE)) +
           cell(oj, "P99", fmt(o.P99)) + cell(oj, "SMAPE", fmt(o.SMAPE, 1)) +
           cell(oj, "P99_uncompensated", fmt(o.P99_uncompensated)) +
           "<td data-key=\"baseline.P99\" data-value=\"" + escape_xml(bj.contains("P99") ? bj.at("P99").dump() : "null") +
           "\">" + fmt(base_p99) + "</td>" + cell(oj, "measurements", std::to_string(o.measurements)) + "</tr>\n";
    }
    h += "</tbody></table>\n<p>mean P99 linear: ALC " + fmt(rep.mean_p99(ErrorKind::Linear)) + " µm, baseline " +
         fmt(rep.mean_p99(ErrorKind::Linear, true)) + " µm, uncompensated " +
         fmt(rep.mean_p99_uncompensated(ErrorKind::Linear)) + " µm; mean P99 angular: ALC " +
         fmt(rep.mean_p99(ErrorKind::Angular)) + " µm/m, baseline " + fmt(rep.mean_p99(ErrorKind::Angular, true)) +
         " µm/m, uncompensated " + fmt(rep.mean_p99_uncompensated(ErrorKind::Angular)) + " µm/m.</p>\n";
    for (const auto& b : rep.baselines) {
      h += "<p>" + escape_xml(b.name) + ": mean P99 linear " + fmt(b.mean_p99(ErrorKind::Linear)) +
           " µm, angular " + fmt(b.mean_p99(ErrorKind::Angular)) + " µm/m";
      std::string selected;
      for (const auto& [output, inputs] : b.selected) {
        std::string list;
        for (const auto& i : inputs) list += (list.empty() ? "" : ",") + i;
        selected += " " + output + " " + (list.empty() ? std::string("none") : list);
      }
      h += (selected.empty() ? "" : "; inputs selected:" + escape_xml(selected)) + ".</p>\n";
    }
    if (usable && d_.run.status != storage::RunStatus::Finished)
      h += "<p class=\"note\">The run stopped before the end of its data: these are its indicators up to there, "
           "as the replay evaluated them when it stopped.</p>\n";
    else if (usable)
      h += "<p class=\"note\">As <code>alc replay</code> printed them when the run ended (stored in the history): "
           "every recorded measurement from the end of CP on against the prediction in force.</p>\n";
    else
      h += "<p class=\"note\">" +
           (stored ? "The indicators stored for this run cannot be read (" + escape_xml(unreadable) + "), so those shown"
                   : std::string("This history stores no indicators of the run (a supervisor run, which has no truth "
                                 "between its probes, a run that has not ended, or a file written before schema "
                                 "version 5), so they")) +
           " are computed from its probes: every probe from the end of CP on against the stored prediction in force at "
           "its time. A replay's own table also counts the measurements that were not probed.</p>\n";
  }

  void errors() {
    page_.html += "<h3>Errors</h3>\n<p class=\"note\">Shaded: CP (blue), Post-CP (white), NG (red). Vertical lines: "
                  "model updates (green), rejected fits (grey, dashed); where too dense for lines, a tick per pixel "
                  "column at the top edge. Error = probe measurement + compensation in "
                  "force.</p>\n";
    const Acl acl = acl_of(d_.run);
    const auto& names = d_.run.output_names;
    for (std::size_t k = 0; k < names.size(); ++k) {
      const ErrorKind kind = error_kind(names[k]);
      const std::string unit(unit_of(kind));
      Chart c = base(names[k], names[k] + ": measured and predicted", names[k] + " [" + unit + "]");
      c.spans = spans_;
      c.markers = updates_;
      Series pred{"predicted", "#1f77b4", Series::Style::Line, {}, {}};
      for (const auto& p : d_.predictions) {
        pred.x.push_back(hours(p.time_s));
        pred.y.push_back(k < p.predicted.size() ? p.predicted[k] : kNaN);
      }
      Series meas{"measured (probes)", "#d62728", Series::Style::Points, {}, {}};
      Series res{"residual (measured - predicted)", "#9467bd", Series::Style::Points, {}, {}};
      for (const auto& p : d_.probes) {
        const double e = probe_error(p, k);
        if (std::isnan(e)) continue;
        meas.x.push_back(hours(p.time_s));
        meas.y.push_back(e);
        const storage::PredictionRecord* at = prediction_at(d_, p.time_s);
        res.x.push_back(hours(p.time_s));
        res.y.push_back(at && k < at->predicted.size() ? e - at->predicted[k] : e);
      }
      c.series = {std::move(pred), std::move(meas)};
      page_.chart(c);
      Chart r = base(names[k] + "-residual", names[k] + ": residual at the probes and the ACL",
                     "residual [" + unit + "]");
      r.height = 170;
      r.spans = spans_;
      r.markers = updates_;
      const double limit = kind == ErrorKind::Linear ? acl.linear_um : acl.angular_um_per_m;
      if (std::isfinite(limit)) r.hbands.push_back({-limit, limit, "ACL ±" + fmt(limit, 1) + " " + unit});
      r.series = {std::move(res)};
      page_.chart(r);
    }
  }

  void inputs() {
    page_.html += "<h3>Inputs</h3>\n";
    charts_by_unit(d_.run.input_names, input_unit, d_.samples,
                   [](const storage::InputSampleRecord& r) -> const std::vector<double>& { return r.values; },
                   [&](std::size_t n, const std::string& unit) {
                     const std::string what = unit == "°C" ? "temperatures" : unit == "rpm" ? "speeds" : "machine states";
                     Chart c = base("inputs-" + std::to_string(n), "Inputs: " + what, what + " [" + unit + "]");
                     c.spans = spans_;
                     return c;
                   });
  }

  // One chart per unit of the channels `names` (units in order of first appearance), one line per
  // channel: values_of(record)[channel] over the records.
  template <class Record, class Values, class Make>
  void charts_by_unit(const std::vector<std::string>& names, std::string (*unit_of_name)(const std::string&),
                      const std::vector<Record>& records, Values values_of, Make make_chart) {
    std::vector<std::string> units;
    for (const auto& n : names)
      if (std::find(units.begin(), units.end(), unit_of_name(n)) == units.end()) units.push_back(unit_of_name(n));
    for (std::size_t u = 0; u < units.size(); ++u) {
      Chart c = make_chart(u, units[u]);
      for (std::size_t i = 0; i < names.size(); ++i) {
        if (unit_of_name(names[i]) != units[u]) continue;
        // Beyond the palette's 10 colours (case S16 has 16 temperatures) the colours repeat with a
        // dashed, then a dotted line, so no two lines of a chart look alike up to 30.
        const std::size_t k = c.series.size();
        Series s{names[i], kPalette[k % kPaletteSize], Series::Style::Line, {}, {}};
        s.dash = static_cast<Series::Dash>(k / kPaletteSize % 3);
        for (const auto& r : records) {
          const std::vector<double>& v = values_of(r);
          s.x.push_back(hours(r.time_s));
          s.y.push_back(i < v.size() ? v[i] : kNaN);
        }
        c.series.push_back(std::move(s));
      }
      page_.chart(c);
    }
  }

  void probing() {
    page_.html += "<h3>Probing</h3>\n";
    Chart c = base("interval", "Probe interval", "interval [min]");
    c.spans = spans_;
    Series s{"probe interval", "#2ca02c", Series::Style::Step, {}, {}};
    for (const auto& i : d_.intervals) {
      s.x.push_back(hours(i.time_s));
      s.y.push_back(std::isfinite(i.interval_s) ? i.interval_s / 60.0 : kNaN);  // inf: no more probing
    }
    c.series = {std::move(s)};
    page_.chart(c);
    // Pd so far (Eq. 7): 1 - M(t) t_probe / t with M(t) the probes up to t. Between two probes M
    // holds and Pd rises with t, a curve, not a line: it is drawn at every pixel column (joining
    // the values at the probes alone put case A with --interval inf at 71 % at 24 h instead of
    // 91.4 %), and at each probe twice, without it and with it (the drop).
    Chart p = base("pd", "Productivity Pd so far (Eq. 7)", "Pd [%]");
    p.spans = spans_;
    Series pd{"Pd", "#8c564b", Series::Style::Line, {}, {}};
    const auto add = [&](double span_s, std::size_t m) {
      if (!(span_s > 0)) return;  // at the first sample Pd is not defined
      pd.x.push_back(span_s / 3600.0);
      pd.y.push_back(probing::productivity_percent(static_cast<double>(m), span_s));
    };
    double end_s = d_.samples.empty() ? 0.0 : d_.samples.back().time_s - t0_s_;
    if (!d_.probes.empty()) end_s = std::max(end_s, d_.probes.back().time_s - t0_s_);
    const auto columns = static_cast<std::size_t>(std::max(1, p.width - kMarginLeft - kMarginRight));
    const double column_s = end_s / static_cast<double>(columns);
    std::size_t m = 0, next_column = 1;
    for (const auto& probe : d_.probes) {
      const double at_s = probe.time_s - t0_s_;
      for (; next_column <= columns && static_cast<double>(next_column) * column_s < at_s; ++next_column)
        add(static_cast<double>(next_column) * column_s, m);
      add(at_s, m);
      add(at_s, ++m);
    }
    for (; next_column <= columns; ++next_column) add(static_cast<double>(next_column) * column_s, m);
    p.series = {std::move(pd)};
    page_.chart(p);
  }

  void offsets() {
    const auto& names = d_.run.offset_names;
    std::string& h = page_.html;
    h += "<h3>Axis offsets</h3>\n";
    // The gate's verdict and, for a command it passed, whether the sink took it (delivered 1), failed
    // (0) or was never settled (NULL: killed before the delivery, resumed without NC output, or a sink
    // that records none): only the first reached the NC.
    std::size_t delivered = 0, failed = 0, unsettled = 0, refused = 0;
    std::string failure;  // the first sink error
    std::vector<Marker> marks;
    for (const auto& c : d_.nc_commands) {
      if (c.kind != "offsets") continue;
      const std::string at = fmt(hours(c.time_s)) + " h";
      if (!c.accepted) {
        ++refused;
        marks.push_back({hours(c.time_s), "refused", "refused at " + at + (c.message.empty() ? "" : ": " + c.message)});
      } else if (c.delivered == true) {
        ++delivered;
        marks.push_back({hours(c.time_s), "sent", "passed at " + at + ", delivered" +
                                                      (c.message.empty() ? "" : " (" + c.message + ")")});
      } else if (c.delivered == false) {
        ++failed;
        if (failure.empty()) failure = c.delivery_message;
        marks.push_back({hours(c.time_s), "undelivered",
                         "passed at " + at + ", NOT delivered" +
                             (c.delivery_message.empty() ? "" : ": " + c.delivery_message)});
      } else {
        ++unsettled;
        marks.push_back({hours(c.time_s), "unsettled", "passed at " + at + ", not settled (no delivery recorded)"});
      }
    }
    if (names.empty()) {
      h += "<p>This run has no offset channels (no output is a C-axis location error).</p>\n";
      return;
    }
    const std::size_t passed = delivered + failed + unsettled;
    h += "<p>Lines: the offsets that cancel each prediction (targets). Green ticks at the bottom: offset commands "
         "the safety gate passed that were delivered to the NC (" + std::to_string(delivered) + ")";
    if (failed) h += "; orange: passed but not delivered, the sink failed (" + std::to_string(failed) + ")";
    if (unsettled) h += "; purple: passed but not settled, no delivery recorded (" + std::to_string(unsettled) + ")";
    h += "; red lines: refused commands (" + std::to_string(refused) + ")" +
         (d_.nc_commands.empty() ? "; this run recorded no NC commands (alc replay without --nc-out)" : "") + ".</p>\n";
    if (failed || unsettled) {
      h += "<p class=\"nc-undelivered\" data-passed=\"" + std::to_string(passed) + "\" data-delivered=\"" +
           std::to_string(delivered) + "\" data-not-delivered=\"" + std::to_string(failed) + "\" data-not-settled=\"" +
           std::to_string(unsettled) + "\"><strong>" +
           (delivered == 0 ? "None of the " + std::to_string(passed) +
                                 " offset commands the safety gate passed is recorded as delivered to"
                           : std::to_string(failed + unsettled) + " of the " + std::to_string(passed) +
                                 " offset commands the safety gate passed are not recorded as delivered to") +
           " the NC</strong>: ";
      if (failed)
        h += std::to_string(failed) + " not delivered (delivered 0: the sink failed" +
             (failure.empty() ? std::string() : ": " + escape_xml(failure)) + ")";
      if (failed && unsettled) h += "; ";
      if (unsettled)
        h += std::to_string(unsettled) +
             " not settled (delivered NULL: no delivery recorded; the process stopped between the command and its "
             "delivery, e.g. killed, and a resume writes no NC output; or its sink records no delivery)";
      h += ". The offset lines are targets, not what the NC holds.</p>\n";
    }
    charts_by_unit(names, offset_unit, d_.predictions,
                   [](const storage::PredictionRecord& r) -> const std::vector<double>& { return r.offsets; },
                   [&](std::size_t n, const std::string& unit) {
                     Chart c = base("offsets-" + std::to_string(n), "Axis offsets [" + unit + "]", "offset [" + unit + "]");
                     c.markers = marks;
                     if (delivered) c.marker_keys.push_back({"sent", "passed, delivered (" + std::to_string(delivered) + ")"});
                     if (failed) c.marker_keys.push_back({"undelivered", "passed, NOT delivered (" + std::to_string(failed) + ")"});
                     if (unsettled)
                       c.marker_keys.push_back({"unsettled", "passed, not settled (" + std::to_string(unsettled) + ")"});
                     if (refused) c.marker_keys.push_back({"refused", "refused (" + std::to_string(refused) + ")"});
                     return c;
                   });
    if (refused) {
      h += "<table class=\"refused\"><thead><tr><th>time [h]</th><th>refused offset command: the gate's reason</th>"
           "</tr></thead><tbody>\n";
      for (const auto& c : d_.nc_commands)
        if (c.kind == "offsets" && !c.accepted)
          h += "<tr><td>" + fmt(hours(c.time_s)) + "</td><td>" + escape_xml(c.message) + "</td></tr>\n";
      h += "</tbody></table>\n";
    }
  }

  void models() {
    std::string& h = page_.html;
    h += "<h3>Model parameter sets</h3>\n<details><summary>" + std::to_string(d_.models.size()) +
         " identifications</summary><table><thead><tr><th>time [h]</th><th>adopted</th><th>order</th><th>inputs</th>"
         "<th>reason</th></tr></thead><tbody>\n";
    for (const auto& m : d_.models) {
      std::string inputs;
      for (const auto& i : m.inputs_chosen) inputs += (inputs.empty() ? "" : ", ") + i;
      h += "<tr><td>" + fmt(hours(m.time_s)) + "</td><td>" + (m.adopted ? "yes" : "no") + "</td><td>" +
           std::to_string(m.order) + "</td><td>" + escape_xml(inputs) + "</td><td>" + escape_xml(m.reason) +
           "</td></tr>\n";
    }
    h += "</tbody></table></details>\n";
  }

  void parameters() {
    std::string& h = page_.html;
    h += "<h3>Parameters</h3>\n<table class=\"parameters\"><tbody>\n";
    const auto j = nlohmann::json::parse(d_.run.config_json, nullptr, false);
    if (j.is_discarded()) {
      h += "<tr><td>config_json</td><td>" + escape_xml(d_.run.config_json) + "</td></tr>\n";
    } else {
      // Flattened: "parameters.identification.method" = value.
      const nlohmann::json flat = j.flatten();
      for (const auto& [key, value] : flat.items()) {
        std::string k = key.size() > 1 ? key.substr(1) : key;
        std::replace(k.begin(), k.end(), '/', '.');
        h += "<tr><td>" + escape_xml(k) + "</td><td>" +
             escape_xml(value.is_string() ? value.get<std::string>() : value.dump()) + "</td></tr>\n";
      }
    }
    h += "</tbody></table>\n";
  }

  const RunData& d_;
  Page& page_;
  double t0_s_ = 0.0;
  std::pair<double, double> x_range_;
  std::vector<Span> spans_;
  std::vector<Marker> updates_;
};

// An SVG document of the study's figures (study/figures.hpp) as an element of the page: its XML
// declaration dropped.
std::string inline_svg(const std::string& document) {
  const auto start = document.find("<svg");
  return start == std::string::npos ? document : document.substr(start);
}

// The study part: the study's own figures (`alc study report --svg` writes the same SVG): per case
// the Pareto front of mean linear P99 against Pd over every set, then the heat maps of P99 and Pd.
void study_section(const std::filesystem::path& file, const storage::StudyHeader& header, Page& page) {
  const study::StudyInfo info = study::StudyInfo::of(header, file.string());
  const auto rows = storage::StudyStore::rows_of(file);
  const study::Analysis a = study::analyse(info, rows);
  const study::FiguresRendered figures = study::render_figures(info, rows, a, std::nullopt);
  std::string& h = page.html;
  // A grid without an interval or ng-meas axis has no heat map (a note below says so): then the
  // text does not describe any.
  const bool heat_maps = std::any_of(figures.figures.begin(), figures.figures.end(),
                                     [](const study::Figure& f) { return f.name.rfind("heatmap-", 0) == 0; });
  h += "<section class=\"study\" id=\"study\">\n<h2>Study: " + std::to_string(info.sets.size()) + " parameter sets x " +
       std::to_string(info.cases.size()) + " cases</h2>\n<p>" + std::to_string(a.rows) + " of " +
       std::to_string(a.expected) + " rows present (shard " + escape_xml(info.shard) + ", " +
       escape_xml(info.software_version) + "). Per case every parameter set is a point of mean linear P99 against "
       "Pd; the line joins the sets no other set beats on both (Pareto front); dashed: the P99 limit of Eq. 8." +
       (heat_maps ? " The heat maps show the mean over the cases of P99 and of Pd over Post-CP interval x NG "
                    "measurements at CP " +
                        escape_xml(figures.heatmap_cp) +
                        " h (<code>alc study report --svg DIR --heatmap-cp H</code> draws another CP)."
                  : std::string()) +
       "</p>\n";
  // As alc study report says it: the figures and optima of a partial file cover the rows present only.
  if (a.rows < a.expected)
    h += "<p class=\"study-partial\">PARTIAL: " + std::to_string(a.expected - a.rows) +
         " rows are missing (a shard, or a run not finished): the figures and optima below cover the rows present "
         "only.</p>\n";
  for (std::size_t ci = 0; ci < a.cases.size(); ++ci)
    if (const auto& ca = a.cases[ci]; ca.optimum)
      h += "<p>Eq. 8 optimum of case " + escape_xml(ca.name) + ": set " + std::to_string(ca.optimum->set) +
           ", P99 " + fmt(ca.optimum->p99_linear) + " µm, Pd " + fmt(ca.optimum->pd) + " %.</p>\n";
  for (const study::Figure& f : figures.figures) {
    const bool heat = f.name.rfind("heatmap-", 0) == 0;
    h += "<figure class=\"study-figure " + std::string(heat ? "heatmap" : "pareto") + "\" id=\"study-" +
         escape_xml(f.name) + "\">" + inline_svg(f.svg) + "</figure>\n";
    ++page.stats().figures;
  }
  for (const std::string& note : figures.notes) h += "<p class=\"note\">" + escape_xml(note) + ".</p>\n";
  h += "</section>\n";
}

const char* const kStyle = R"(
body{font:14px/1.4 system-ui,sans-serif;margin:0 24px 40px;color:#222;max-width:1000px}
h1{margin:16px 0 4px}h2{border-top:2px solid #444;padding-top:12px;margin-top:32px}h3{margin:24px 0 6px}
nav a{margin-right:12px}p.meta,p.note{color:#555;font-size:13px}
table{border-collapse:collapse;margin:6px 0;font-size:13px}td,th{border:1px solid #ccc;padding:2px 8px;text-align:right}
td:first-child,th:first-child,.parameters td{text-align:left}
figure.chart{margin:8px 0 14px}svg.alc-chart{display:block;background:#fff}
svg.alc-chart text{font:11px system-ui,sans-serif;fill:#333}svg.alc-chart .chart-title{font-size:13px;font-weight:600}
svg.alc-chart .axis-label{font-size:12px}svg.alc-chart .no-data{font-size:13px;fill:#888}svg.alc-chart .grid{stroke:#e4e4e4;stroke-width:1}svg.alc-chart .frame{fill:none;stroke:#888}
svg.alc-chart .span-CP{fill:#dbe9f7}svg.alc-chart .span-NG{fill:#f9d6d5}svg.alc-chart .span-Post-CP{fill:none}
svg.alc-chart .hband{fill:#ffe8c2;opacity:.8}
svg.alc-chart .marker{stroke-width:1}svg.alc-chart .marker-update{stroke:#2ca02c;opacity:.45}svg.alc-chart .marker-rejected{stroke:#999;stroke-dasharray:3 3}
svg.alc-chart .marker-ticks{opacity:.9;stroke-dasharray:none}svg.alc-chart .marker-refused{stroke:#d62728;stroke-width:2}svg.alc-chart .marker-sent{stroke:#2ca02c;opacity:.7}
svg.alc-chart .marker-undelivered{stroke:#ff7f0e;stroke-width:2.5}svg.alc-chart .marker-unsettled{stroke:#9467bd;stroke-width:2.5}
p.nc-undelivered,p.study-partial{background:#fff1e0;border-left:4px solid #ff7f0e;padding:4px 8px}
.legend i.marker-key{width:3px;height:12px}.legend i.marker-key-sent{background:#2ca02c}.legend i.marker-key-refused{background:#d62728}
.legend i.marker-key-undelivered{background:#ff7f0e}.legend i.marker-key-unsettled{background:#9467bd}
.legend i.marker-key-update{background:#2ca02c}.legend i.marker-key-rejected{background:#999}
svg.alc-chart path.series{fill:none;stroke-width:1.3;stroke-linejoin:round}
svg.alc-chart path.series-points{stroke-width:4.5;stroke-linecap:round}svg.alc-chart path.dashed{stroke-dasharray:6 4}svg.alc-chart path.dotted{stroke-dasharray:2 3}
figcaption.legend{font-size:12px;color:#333}.legend .key{margin-right:14px;white-space:nowrap}
.legend i{display:inline-block;width:14px;height:4px;margin-right:5px;vertical-align:middle}
.legend .key-points i{width:7px;height:7px;border-radius:50%}.legend i.hband-key{background:#ffe8c2;height:10px}
figure.study-figure{margin:10px 0 20px}figure.study-figure svg{display:block;max-width:100%;height:auto}
#alc-dom-check{display:none}
)";

// Counts what the charts drew into #alc-dom-check (JSON): per chart the series and their points,
// read back from the DOM (path commands), any script error, and the time to the first frame.
const char* const kScript = R"(<script>
(function () {
  var errors = [];
  window.addEventListener('error', function (e) { errors.push(String(e.message)); });
  function count() {
    var charts = [];
    document.querySelectorAll('svg.alc-chart').forEach(function (svg) {
      var series = [];
      svg.querySelectorAll('path.series').forEach(function (p) {
        var d = p.getAttribute('d') || '';
        series.push({name: p.getAttribute('data-name'), points: (d.match(/[MLV]/g) || []).length});
      });
      var markers = {};
      svg.querySelectorAll('.marker').forEach(function (m) {
        var kind = (m.getAttribute('class').match(/marker-([a-z]+)/) || [])[1];
        if (kind === 'ticks') return;
        if (!markers[kind]) markers[kind] = {count: 0, stroke: getComputedStyle(m).stroke};
        markers[kind].count += m.tagName === 'path' ? Number(m.getAttribute('data-markers')) : 1;
      });
      charts.push({id: svg.parentNode.id, series: series, markers: markers});
    });
    var figures = [];
    document.querySelectorAll('figure.study-figure').forEach(function (f) {
      figures.push({id: f.id, svgs: f.querySelectorAll('svg').length, cells: f.querySelectorAll('g.cell').length,
                    rows: f.querySelectorAll('circle.row').length});
    });
    var out = document.getElementById('alc-dom-check');
    out.textContent = JSON.stringify({charts: charts, figures: figures, errors: errors,
                                      render_ms: Math.round(performance.now())});
    out.setAttribute('data-done', '1');
  }
  // Once the document is parsed (the charts are inline SVG: all there), and again after the first
  // frame for render_ms: a headless browser that dumps the DOM before a frame was drawn (seen under
  // load) still finds the counts.
  if (document.readyState === 'loading') document.addEventListener('DOMContentLoaded', count);
  else count();
  window.addEventListener('load', function () { requestAnimationFrame(function () { setTimeout(count, 0); }); });
})();
</script>
)";

}  // namespace

const char* page_style() { return kStyle; }
const char* dom_check_script() { return kScript; }

std::string html_report(const std::filesystem::path& file, const ReportOptions& options, ReportStats* stats_out) {
  const storage::HistoryReader reader(file);
  const auto runs = reader.runs();
  std::vector<storage::RunId> chosen;  // options.runs, each once
  for (const storage::RunId id : options.runs)
    if (std::find(chosen.begin(), chosen.end(), id) == chosen.end()) chosen.push_back(id);
  for (const storage::RunId id : chosen)
    if (std::none_of(runs.begin(), runs.end(), [&](const auto& r) { return r.run_id == id; })) {
      std::string list;
      for (const auto& r : runs) list += (list.empty() ? "" : ", ") + std::to_string(r.run_id);
      throw UnknownRun("history database '" + file.string() + "' has no run " + std::to_string(id) +
                       (runs.empty() ? " (it holds no runs)" : " (its runs: " + list + ")"));
    }
  if (chosen.empty())
    for (const auto& r : runs) chosen.push_back(r.run_id);
  const auto study_header =
      options.runs.empty() ? storage::StudyStore::header_of(file) : std::optional<storage::StudyHeader>();

  ReportStats stats;
  Page page(stats);
  std::string& h = page.html;
  h += "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>ALC report: " +
       escape_xml(file.filename().string()) + "</title>\n<style>" + kStyle + "</style>\n</head>\n<body>\n";
  h += "<header><h1>ALC report</h1><p class=\"meta\">" + escape_xml(file.string()) + " (schema version " +
       std::to_string(reader.schema_version()) + "), " + std::to_string(runs.size()) + " run(s) in the file" +
       (options.runs.empty() ? std::string() : ", " + std::to_string(chosen.size()) + " shown") +
       (options.software_version.empty() ? "" : "; written by " + escape_xml(options.software_version)) +
       ".</p>\n<nav>";
  for (auto id : chosen) h += "<a href=\"#run-" + std::to_string(id) + "\">run " + std::to_string(id) + "</a>";
  if (study_header) h += "<a href=\"#study\">study</a>";
  h += "</nav></header>\n";
  if (chosen.empty() && !study_header) h += "<p>The file holds no runs and no study.</p>\n";
  for (auto id : chosen) {
    const RunData d = load_run(reader, id);
    RunSection(d, page).write();
    ++stats.runs;
  }
  if (study_header) {
    study_section(file, *study_header, page);
    stats.study = true;
  }
  h += "<pre id=\"alc-dom-check\"></pre>\n";
  h += kScript;
  h += "</body>\n</html>\n";
  if (stats_out) *stats_out = stats;
  return std::move(page.html);
}

}  // namespace alc::report
