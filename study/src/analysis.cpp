#include "study/analysis.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include "runtime/parameter_options.hpp"
#include "runtime/run.hpp"

namespace alc::study {

namespace {

constexpr std::size_t kClosest = 5;
// No row with indicators to judge (an empty shard, every run failed): said so, not "closest:" and nothing.
constexpr const char* kNoRow = "no row with indicators (none stored, or every run failed)";
constexpr const char* kNoRowOnEveryCase = "no set has a row with indicators on every case";

// Seed 004's chosen set: its four values with every other option at replay's default (which are the
// paper's). A grid whose [fixed] options change anything else (an ACL, the CP interval, the adaptive
// schedule) has no such set, although one of its sets has the four values.
std::optional<std::size_t> find_paper_set(const StudyInfo& info) {
  const auto want = runtime::canonical_parameters(runtime::parameters_of(
      runtime::OptionTexts{{"cp", "6.5"}, {"interval", "2"}, {"ng-interval", "10"}, {"ng-meas", "12"}}));
  for (const ParameterSet& s : info.sets)
    if (s.error.empty() && runtime::canonical_parameters(s.parameters) == want) return s.index;
  return std::nullopt;
}

bool better(const Point& a, const Point& b) {  // Eq. 8 order: higher Pd, then lower P99, then first set
  if (a.pd != b.pd) return a.pd > b.pd;
  if (a.p99_linear != b.p99_linear) return a.p99_linear < b.p99_linear;
  return a.set < b.set;
}

nlohmann::json point_json(const Point& p, const StudyInfo& info) {
  const ParameterSet& s = info.sets[p.set];
  nlohmann::json params = nlohmann::json::object();
  for (const auto& [k, v] : s.options) params[k] = v;
  return {{"set", p.set}, {"parameters", params}, {"P99_linear", p.p99_linear}, {"P99_angular", p.p99_angular},
          {"Pd", p.pd}, {"M", p.M}};
}

std::string fmt(double v, int precision = 2) {
  if (std::isnan(v)) return "-";  // no output of that kind (S16 has no angular one)
  char b[64];
  std::snprintf(b, sizeof b, "%.*f", precision, v);
  return b;
}

}  // namespace

Analysis analyse(const StudyInfo& info, const std::vector<storage::StudyRowRecord>& rows, double limit_um) {
  Analysis a;
  a.limit_um = limit_um;
  a.paper_set = find_paper_set(info);
  a.expected = info.runs();
  a.rows = rows.size();
  std::vector<std::map<std::size_t, Point>> by_case(info.cases.size());
  for (std::size_t c = 0; c < info.cases.size(); ++c) a.cases.push_back({info.cases[c].name, 0, 0, {}, {}, {}});
  for (const auto& r : rows) {
    const auto c = static_cast<std::size_t>(r.case_index);
    if (c >= a.cases.size()) continue;
    ++a.cases[c].rows;
    if (!r.ok || !r.p99_linear || !r.pd) {
      ++a.cases[c].failed;
      continue;
    }
    const auto j = nlohmann::json::parse(r.report_json);
    by_case[c][static_cast<std::size_t>(r.set_index)] =
        Point{static_cast<std::size_t>(r.set_index), *r.p99_linear, r.p99_angular.value_or(NAN), *r.pd, j.at("M").get<int>()};
  }
  for (std::size_t c = 0; c < a.cases.size(); ++c) {
    CaseAnalysis& ca = a.cases[c];
    std::vector<Point> points;
    for (const auto& [_, p] : by_case[c]) points.push_back(p);
    for (const Point& p : points)
      if (p.p99_linear < limit_um && (!ca.optimum || better(p, *ca.optimum))) ca.optimum = p;
    if (!ca.optimum) {
      std::vector<Point> sorted = points;
      std::sort(sorted.begin(), sorted.end(), [](const Point& x, const Point& y) {
        return x.p99_linear != y.p99_linear ? x.p99_linear < y.p99_linear : x.set < y.set;
      });
      sorted.resize(std::min(sorted.size(), kClosest));
      ca.closest = sorted;
    }
    // Pareto front: by P99 ascending (Pd descending on ties), keep each point with a higher Pd than all
    // before, and every set with the very same (P99, Pd) as the one kept last (none beats the other).
    std::sort(points.begin(), points.end(), [](const Point& x, const Point& y) {
      if (x.p99_linear != y.p99_linear) return x.p99_linear < y.p99_linear;
      if (x.pd != y.pd) return x.pd > y.pd;
      return x.set < y.set;
    });
    double best_pd = -INFINITY;
    for (const Point& p : points)
      if (p.pd > best_pd ||
          (!ca.pareto.empty() && p.pd == ca.pareto.back().pd && p.p99_linear == ca.pareto.back().p99_linear)) {
        ca.pareto.push_back(p);
        best_pd = p.pd;
      }
  }
  // Tab. 3 analog: the set that meets the limit on every case with the highest mean Pd.
  std::vector<CommonChoice::Near> all;
  double common_p99 = INFINITY;  // the mean P99 over the cases of a.common.set (ties of mean Pd: the lower)
  for (const ParameterSet& s : info.sets) {
    double worst = -INFINITY, pd_sum = 0.0, p99_sum = 0.0;
    bool complete = !info.cases.empty();
    for (std::size_t c = 0; c < info.cases.size() && complete; ++c) {
      const auto it = by_case[c].find(s.index);
      if (it == by_case[c].end()) {
        complete = false;
        break;
      }
      worst = std::max(worst, it->second.p99_linear);
      pd_sum += it->second.pd;
      p99_sum += it->second.p99_linear;
    }
    if (!complete) continue;
    const double mean_pd = pd_sum / static_cast<double>(info.cases.size());
    const double mean_p99 = p99_sum / static_cast<double>(info.cases.size());
    all.push_back({s.index, worst, mean_pd});
    // Eq. 8's order over the cases: the higher mean Pd, then the lower mean P99, then the first set (with
    // one case the same set as that case's optimum).
    if (worst < limit_um &&
        (!a.common.set || mean_pd > a.common.mean_pd || (mean_pd == a.common.mean_pd && mean_p99 < common_p99))) {
      a.common.set = s.index;
      a.common.mean_pd = mean_pd;
      common_p99 = mean_p99;
    }
  }
  if (a.common.set) {
    for (std::size_t c = 0; c < info.cases.size(); ++c) a.common.per_case.push_back(by_case[c].at(*a.common.set));
  } else {
    std::sort(all.begin(), all.end(), [](const auto& x, const auto& y) {
      return x.worst_p99 != y.worst_p99 ? x.worst_p99 < y.worst_p99 : x.set < y.set;
    });
    all.resize(std::min(all.size(), kClosest));
    a.common.closest = all;
  }
  return a;
}

nlohmann::json analysis_json(const Analysis& a, const StudyInfo& info) {
  nlohmann::json cases = nlohmann::json::object();
  for (const CaseAnalysis& c : a.cases) {
    nlohmann::json j = {{"rows", c.rows}, {"failed", c.failed}};
    j["optimum"] = c.optimum ? point_json(*c.optimum, info) : nlohmann::json(nullptr);
    if (!c.optimum) {
      j["note"] = c.closest.empty() ? std::string(kNoRow)
                                    : "no set keeps the mean linear P99 below " + fmt(a.limit_um, 1) +
                                          " µm; the closest sets instead";
      j["closest"] = nlohmann::json::array();
      for (const Point& p : c.closest) j["closest"].push_back(point_json(p, info));
    }
    j["pareto"] = nlohmann::json::array();
    for (const Point& p : c.pareto) j["pareto"].push_back(point_json(p, info));
    cases[c.name] = j;
  }
  nlohmann::json common;
  if (a.common.set) {
    common = point_json(Point{*a.common.set, 0, 0, a.common.mean_pd, 0}, info);
    common.erase("P99_linear");
    common.erase("P99_angular");
    common.erase("M");
    common["mean_Pd"] = a.common.mean_pd;
    common.erase("Pd");
    common["per_case"] = nlohmann::json::object();
    for (std::size_t c = 0; c < a.common.per_case.size(); ++c)
      common["per_case"][info.cases[c].name] = point_json(a.common.per_case[c], info);
  } else {
    common = {{"set", nullptr},
              {"note", a.common.closest.empty()
                           ? std::string(kNoRowOnEveryCase)
                           : "no set keeps the mean linear P99 below " + fmt(a.limit_um, 1) + " µm on every case"},
              {"closest", nlohmann::json::array()}};
    for (const auto& n : a.common.closest) {
      nlohmann::json p = point_json(Point{n.set, n.worst_p99, 0, n.mean_pd, 0}, info);
      common["closest"].push_back({{"set", n.set}, {"parameters", p["parameters"]}, {"worst_P99_linear", n.worst_p99},
                                   {"mean_Pd", n.mean_pd}});
    }
  }
  return {{"limit_um", a.limit_um},
          {"rows", a.rows},
          {"expected_rows", a.expected},
          {"partial", a.rows < a.expected},
          {"paper_set", a.paper_set ? nlohmann::json(*a.paper_set) : nlohmann::json(nullptr)},
          {"per_case", cases},
          {"all_cases", common}};
}

void print_analysis(std::ostream& os, const Analysis& a, const StudyInfo& info) {
  const auto params = [&](std::size_t set) { return info.sets[set].key; };
  os << "Study: " << a.rows << " of " << a.expected << " rows (" << info.sets.size() << " sets x " << info.cases.size()
     << " cases)\n";
  if (a.rows < a.expected)
    os << "PARTIAL: " << a.expected - a.rows << " rows are missing (a shard, or a run not finished: --resume it, or "
       << "merge the shards); what follows covers only the rows present, and \"on every case\" only the sets "
          "that have a row on every case\n";
  os << "Eq. 8 optimum per case (highest Pd with mean linear P99 < " << fmt(a.limit_um, 1) << " µm; Tab. 2 analog):\n";
  for (const CaseAnalysis& c : a.cases) {
    if (c.optimum) {
      os << "  " << c.name << ": " << params(c.optimum->set) << "  P99 " << fmt(c.optimum->p99_linear) << " µm, "
         << fmt(c.optimum->p99_angular) << " µm/m, Pd " << fmt(c.optimum->pd) << " %, M " << c.optimum->M << "\n";
    } else if (c.closest.empty()) {
      os << "  " << c.name << ": " << kNoRow << "\n";
    } else {
      os << "  " << c.name << ": no set meets the limit; closest:\n";
      for (const Point& p : c.closest)
        os << "      " << params(p.set) << "  P99 " << fmt(p.p99_linear) << " µm, Pd " << fmt(p.pd) << " %\n";
    }
    if (c.failed) os << "      (" << c.failed << (c.failed == 1 ? " failed row)\n" : " failed rows)\n");
  }
  if (a.common.set) {
    os << "Best set on every case (Tab. 3 analog): " << params(*a.common.set) << ", mean Pd " << fmt(a.common.mean_pd)
       << " %\n";
    for (std::size_t c = 0; c < a.common.per_case.size(); ++c) {
      const Point& p = a.common.per_case[c];
      os << "  " << info.cases[c].name << ": P99 " << fmt(p.p99_linear) << " µm, " << fmt(p.p99_angular) << " µm/m, Pd "
         << fmt(p.pd) << " %, M " << p.M << "\n";
    }
  } else if (a.common.closest.empty()) {
    os << "Best set on every case: none, " << kNoRowOnEveryCase << "\n";
  } else {
    os << "No set keeps the mean linear P99 below " << fmt(a.limit_um, 1) << " µm on every case; closest:\n";
    for (const auto& n : a.common.closest)
      os << "  " << params(n.set) << "  worst P99 " << fmt(n.worst_p99) << " µm, mean Pd " << fmt(n.mean_pd) << " %\n";
  }
  if (a.paper_set) os << "Seed 004's chosen set in this grid: set " << *a.paper_set << " (" << params(*a.paper_set) << ")\n";
  os << "Pareto front (mean linear P99 against Pd) per case: ";
  for (const CaseAnalysis& c : a.cases) os << c.name << " " << c.pareto.size() << (c.pareto.size() == 1 ? " set; " : " sets; ");
  os << "the sets in --json\n";
}

}  // namespace alc::study
