#pragma once
// The parameter grid of a study: axes (an option of alc replay and its values), the product of the
// axes, plus options fixed for every set. The built-in `paper` grid is Tab. 1 of seed 004 read so
// that it gives the study's 2,191 sets; any other grid is a TOML file (docs/study.md).
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "alc/controller.hpp"
#include "runtime/parameter_options.hpp"

namespace alc::study {

// A grid file that cannot be used: the message names the file, line, key and value.
struct GridError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// One set of the grid: the axes' values (options that cannot matter given the others are left out,
// e.g. the NG options when interval = inf) and the parameters they give with the fixed options.
struct ParameterSet {
  std::size_t index = 0;             // position in the grid's set order
  runtime::OptionTexts options;      // axis options of this set, in axis order
  std::string key;                   // "cp=6.5 interval=2 ng-interval=10 ng-meas=12"
  AlcParameters parameters;          // valid unless `error` is set
  std::string error;                 // why the combination is invalid (the set's rows carry it)
  std::string value(std::string_view option) const;  // the axis value, "" if not set here
};

// The most sets a grid file may give (the product of its axes, before moot duplicates are left out):
// a study holds its sets in memory, about 1.3 KB each.
inline constexpr std::uint64_t kMaxGridSets = 1'000'000;

struct Grid {
  std::string name;                                                  // "paper" or the file
  std::vector<std::pair<std::string, std::vector<std::string>>> axes;  // option, values (text)
  runtime::OptionTexts fixed;                                        // options of every set

  // What identifies the grid (axes and fixed options; not its name).
  nlohmann::json canonical() const;
  static Grid from_canonical(const nlohmann::json& j, std::string name);
  // The sets in order: the product of the axes, the last axis fastest, moot duplicates left out.
  std::vector<ParameterSet> sets() const;
};

// Tab. 1 of seed 004: CP 6.5/12/16/24/36/48/60 h, Post-CP 1-12 h, 24 h or inf, NG interval
// 5-30 min, NG measurements 6/12/18/24; fixed: CP interval 5 min, ACL 5 µm and 15 µm/m, no update.
Grid paper_grid();
// The TOML text of the paper grid (what docs/study.md shows).
std::string_view paper_grid_toml();
// "paper" or a TOML file; throws GridError.
Grid load_grid(const std::string& grid);
// Parses grid TOML `text` read from `file` (for messages). Throws GridError naming file, line, key, value.
Grid parse_grid(std::string_view text, const std::string& file);

}  // namespace alc::study
