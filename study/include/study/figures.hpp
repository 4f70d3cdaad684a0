#pragma once
// Figures of a study as self-contained SVG files (docs/study.md, "Figures"): per case the rows as
// points of mean linear P99 against Pd with the Pareto front, the limit, the Eq. 8 optimum and seed
// 004's set; heat maps of the mean over the cases of P99 and of Pd over Post-CP interval x NG
// measurements for one CP length, the other axes fixed. Hand-written SVG, no library.
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "storage/study_store.hpp"
#include "study/analysis.hpp"
#include "study/results.hpp"

namespace alc::study {

// A CP value that is not one of the grid's (the message names it and the values there are).
struct FigureError : std::invalid_argument {
  using std::invalid_argument::invalid_argument;
};

struct FiguresWritten {
  std::vector<std::filesystem::path> files;  // in the order written
  std::vector<std::string> notes;            // what was left out and why (e.g. no heat map: no ng-meas axis)
};

// The CP values of the grid (the `cp` axis in grid order; the fixed or default CP when there is no axis).
std::vector<std::string> cp_values(const StudyInfo& info);

// The CP text of the grid that `text` means (compared as numbers: "12.0" is "12"); throws FigureError
// naming `text` and the values available.
std::string grid_cp(const StudyInfo& info, const std::string& text);

// The heat maps' CP when none is given: the CP of the first case's Eq. 8 optimum, else the first CP.
std::string default_heatmap_cp(const StudyInfo& info, const Analysis& analysis);

// One figure as a self-contained SVG document (with its XML declaration).
struct Figure {
  std::string name;  // file stem: "pareto-<case>", "heatmap-p99-cp<H>", "heatmap-pd-cp<H>"
  std::string svg;
};

struct FiguresRendered {
  std::vector<Figure> figures;       // Pareto per case, then the heat maps of P99 and Pd
  std::string heatmap_cp;            // the CP of the heat maps
  std::vector<std::string> notes;    // what was left out and why
};

// The figures write_figures() writes, in memory (`alc report` embeds them in its page).
FiguresRendered render_figures(const StudyInfo& info, const std::vector<storage::StudyRowRecord>& rows,
                               const Analysis& analysis, const std::optional<std::string>& heatmap_cp);

// Writes pareto-<case>.svg per case and heatmap-p99-cp<H>.svg, heatmap-pd-cp<H>.svg into `dir`
// (created if missing; each file replaced atomically). `heatmap_cp`: a CP of the grid (grid_cp), or
// nullopt for default_heatmap_cp. Throws FigureError for a CP not in the grid, std::runtime_error when
// a file cannot be written.
FiguresWritten write_figures(const StudyInfo& info, const std::vector<storage::StudyRowRecord>& rows,
                             const Analysis& analysis, const std::filesystem::path& dir,
                             const std::optional<std::string>& heatmap_cp);

// Text as XML character data or attribute value: & < > " ' escaped; bytes that XML 1.0 cannot hold
// (control characters other than tab, newline, carriage return) become U+FFFD.
std::string xml_escape(const std::string& text);

}  // namespace alc::study
