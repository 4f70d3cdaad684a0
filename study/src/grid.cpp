#include "study/grid.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>
#include <unordered_set>
#include <sstream>
#include <toml++/toml.h>

#include "common/input_file.hpp"
#include "common/number_text.hpp"
#include "common/toml_text.hpp"
#include "runtime/toml_option.hpp"

namespace alc::study {

namespace {

constexpr std::string_view kPaperToml = R"toml(# Tab. 1 of seed 004, read so that it gives the study's 2,191 sets.
cp = [6.5, 12, 16, 24, 36, 48, 60]                   # [h] calibration phase
interval = [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 24, "inf"]  # [h] Post-CP probe interval
ng-interval = [5, 10, 15, 20, 25, 30]                 # [min] No-Good probe interval
ng-meas = [6, 12, 18, 24]                             # [-] No-Good measurements

[fixed]
cp-interval = 5                                       # [min]
acl-lin = 5                                           # [µm]
acl-ang = 15                                          # [µm/m]
update = "inf"                                        # no periodic update
)toml";

std::string where(const std::string& file, const toml::node& node) {
  const auto& src = node.source();
  return file + ":" + std::to_string(src.begin.line) + ":" + std::to_string(src.begin.column);
}

std::string known_keys() {
  std::string k;
  for (const auto& o : runtime::parameter_options()) k += (k.empty() ? "" : ", ") + std::string(o.name);
  return k;
}

// A TOML value as the text an option takes (runtime::option_text_of), refused with its place.
std::string text_of(const std::string& file, const std::string& key, const toml::node& node) {
  try {
    return runtime::option_text_of(key, node);
  } catch (const std::invalid_argument& e) {
    const std::string value = common::toml_value_text(&node);
    throw GridError(where(file, node) + ": key '" + key + "'" + (value.empty() ? "" : ", value '" + value + "'") + ": " +
                    e.what());
  }
}

// Checks that `text` is a value option `key` takes (alone; combinations are judged per set).
void check_value(const std::string& at, const std::string& key, const std::string& text) {
  AlcParameters p;
  try {
    runtime::set_parameter(p, key, text);
  } catch (const std::invalid_argument& e) {
    throw GridError(at + ": key '" + key + "', value '" + text + "': " + e.what());
  }
}

void check_key(const std::string& at, const std::string& key) {
  if (!runtime::find_parameter_option(key))
    throw GridError(at + ": '" + key + "' is not a grid key (the options of alc replay without the dashes: " +
                    known_keys() + ")");
}

bool is_inf(const runtime::OptionTexts& options, std::string_view name) {
  for (const auto& [k, v] : options)
    if (k == name) return v == "inf" || v == "Inf";
  return false;
}

bool is_value(const runtime::OptionTexts& options, std::string_view name, std::string_view value) {
  for (const auto& [k, v] : options)
    if (k == name) return v == value;
  return false;
}

// Options that cannot change a run given the others (docs/study.md): without Post-CP probes there is
// no breach, so no NG, and no interval for the adaptive schedule to choose; without an NG burst
// (ng-interval inf, or no NG probe: ng-meas 0) the NG interval, count and confirmation are never
// asked; without refits on probes a breach is never confirmed (no-refit implies no-confirm); the
// adaptive schedule's options under the paper's (the default) are never read; the guard's move-fraction
// is never read without the guard or without refits on probes. ng-interval = inf takes precedence: with it
// ng-meas is the moot one.
bool moot(const runtime::OptionTexts& all, std::string_view option) {
  const bool ng_option = option == "ng-interval" || option == "ng-meas" || option == "no-confirm";
  const bool adaptive_option =
      option == "uncertainty-fraction" || option == "min-interval" || option == "max-interval";
  if ((ng_option || adaptive_option) && is_inf(all, "interval")) return true;
  if ((option == "ng-meas" || option == "no-confirm") && is_inf(all, "ng-interval")) return true;
  if ((option == "ng-interval" || option == "no-confirm") && !is_inf(all, "ng-interval") &&
      is_value(all, "ng-meas", "0"))
    return true;
  if (option == "no-confirm" && is_value(all, "no-refit", "true")) return true;
  // The guard's move check runs only with the guard and refits on probes, and brings Post-CP probes forward.
  if (option == "move-fraction" &&
      (is_value(all, "guard", "false") || is_value(all, "no-refit", "true") || is_inf(all, "interval")))
    return true;
  return adaptive_option && !is_value(all, "schedule", "adaptive");
}

}  // namespace

std::string ParameterSet::value(std::string_view option) const {
  for (const auto& [k, v] : options)
    if (k == option) return v;
  return {};
}

nlohmann::json Grid::canonical() const {
  nlohmann::json axes_j = nlohmann::json::array();
  for (const auto& [k, values] : axes) axes_j.push_back({k, values});
  nlohmann::json fixed_j = nlohmann::json::array();
  for (const auto& [k, v] : fixed) fixed_j.push_back({k, v});
  return {{"axes", axes_j}, {"fixed", fixed_j}};
}

Grid Grid::from_canonical(const nlohmann::json& j, std::string name) {
  Grid g;
  g.name = std::move(name);
  for (const auto& a : j.at("axes")) g.axes.emplace_back(a.at(0).get<std::string>(), a.at(1).get<std::vector<std::string>>());
  for (const auto& f : j.at("fixed")) g.fixed.emplace_back(f.at(0).get<std::string>(), f.at(1).get<std::string>());
  return g;
}

std::vector<ParameterSet> Grid::sets() const {
  std::vector<ParameterSet> sets;
  std::set<std::string> seen;
  std::vector<std::size_t> at(axes.size(), 0);
  const bool empty = std::any_of(axes.begin(), axes.end(), [](const auto& a) { return a.second.empty(); });
  while (!empty) {
    runtime::OptionTexts all = fixed;
    for (std::size_t a = 0; a < axes.size(); ++a) all.emplace_back(axes[a].first, axes[a].second[at[a]]);
    ParameterSet s;
    for (std::size_t a = 0; a < axes.size(); ++a) {
      if (moot(all, axes[a].first)) continue;
      s.options.emplace_back(axes[a].first, axes[a].second[at[a]]);
      s.key += (s.key.empty() ? "" : " ") + axes[a].first + "=" + axes[a].second[at[a]];
    }
    if (seen.insert(s.key).second) {
      s.index = sets.size();
      runtime::OptionTexts applied = fixed;
      applied.insert(applied.end(), s.options.begin(), s.options.end());
      try {
        s.parameters = runtime::parameters_of(applied);
      } catch (const std::invalid_argument& e) {
        s.error = e.what();
      }
      sets.push_back(std::move(s));
    }
    // Next combination, the last axis fastest.
    std::size_t a = axes.size();
    while (a > 0) {
      --a;
      if (++at[a] < axes[a].second.size()) break;
      at[a] = 0;
      if (a == 0) return sets;
    }
    if (axes.empty()) return sets;
  }
  return sets;
}

std::string_view paper_grid_toml() { return kPaperToml; }

Grid paper_grid() {
  Grid g = parse_grid(kPaperToml, "paper");
  g.name = "paper";
  return g;
}

Grid parse_grid(std::string_view text, const std::string& file) {
  toml::table root;
  try {
    root = toml::parse(text, file);
  } catch (const toml::parse_error& e) {
    throw GridError(common::toml_syntax_error(file, e));
  }
  Grid g;
  g.name = file;
  std::set<std::string> keys;
  // In the order of the file (a TOML table iterates its keys sorted).
  std::vector<std::pair<std::string, const toml::node*>> entries;
  for (const auto& [k, node] : root) entries.emplace_back(std::string(k.str()), &node);
  std::stable_sort(entries.begin(), entries.end(), [](const auto& a, const auto& b) {
    return a.second->source().begin.line < b.second->source().begin.line;
  });
  // Refused before any value is read: a grid's sets are held in memory (and run), so a product of 20
  // values on 8 axes (2.56e10 combinations) would grow until the machine runs out, and 2^64 would
  // wrap to 0; and a million values of one axis take minutes to check.
  {
    std::uint64_t count = 1;
    std::string product;
    bool beyond = false;
    for (const auto& [key, node_ptr] : entries) {
      const toml::array* values = node_ptr->as_array();
      if (key == "fixed" || !values || values->empty()) continue;
      product += (product.empty() ? "" : " x ") + std::to_string(values->size()) + " (" + key + ")";
      if (!beyond && count > kMaxGridSets / values->size()) beyond = true;
      if (!beyond) count *= values->size();
    }
    if (beyond || count > kMaxGridSets)
      throw GridError(file + ": " + product + " = " +
                      (beyond ? "more than " + std::to_string(kMaxGridSets) : std::to_string(count)) +
                      " combinations, more than a study takes (" + std::to_string(kMaxGridSets) +
                      "); split the grid into several files or list fewer values");
  }
  for (const auto& [key, node_ptr] : entries) {
    const toml::node& node = *node_ptr;
    const std::string at = where(file, node);
    if (key == "fixed") {
      const toml::table* fixed = node.as_table();
      if (!fixed) throw GridError(at + ": 'fixed' must be a table of option = value");
      for (const auto& [fk, fnode] : *fixed) {
        const std::string fkey(fk.str());
        const std::string fat = where(file, fnode);
        check_key(fat, fkey);
        if (fnode.is_array()) throw GridError(fat + ": key '" + fkey + "' in [fixed] takes one value, not a list");
        if (!keys.insert(fkey).second) throw GridError(fat + ": key '" + fkey + "' is given twice");
        const std::string v = text_of(file, fkey, fnode);
        check_value(fat, fkey, v);
        g.fixed.emplace_back(fkey, v);
      }
      continue;
    }
    check_key(at, key);
    const toml::array* values = node.as_array();
    if (!values) throw GridError(at + ": key '" + key + "' must be a list of values (or go into [fixed])");
    if (values->empty()) throw GridError(at + ": key '" + key + "' has no values");
    if (!keys.insert(key).second) throw GridError(at + ": key '" + key + "' is given twice");
    std::vector<std::string> texts;
    std::unordered_set<std::string> seen;
    for (const toml::node& v : *values) {
      const std::string vat = where(file, v);
      std::string t = text_of(file, key, v);
      check_value(vat, key, t);
      if (!seen.insert(t).second) throw GridError(vat + ": key '" + key + "', value '" + t + "' is listed twice");
      texts.push_back(std::move(t));
    }
    g.axes.emplace_back(key, std::move(texts));
  }
  if (g.axes.empty()) throw GridError(file + ": no axis (a key with a list of values)");
  return g;
}

Grid load_grid(const std::string& grid) {
  if (grid == "paper") return paper_grid();
  if (const std::string problem = io::input_file_problem(grid); !problem.empty()) throw GridError(grid + ": " + problem);
  std::ifstream in(grid, std::ios::binary);
  if (!in) throw GridError(grid + ": cannot open the grid file (give 'paper' or a TOML file)");
  std::ostringstream text;
  text << in.rdbuf();
  return parse_grid(text.str(), grid);
}

}  // namespace alc::study
