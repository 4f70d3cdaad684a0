#pragma once
// `alc report`: a history database (or a study file) as one self-contained HTML page of inline SVG
// charts and tables (docs/report.md). No network, no script library: the one small script in the
// page only counts what the charts drew (for tests) and reports the render time.
#include <cstddef>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "storage/records.hpp"

namespace alc::report {

// --run names a run the file does not hold: the message names the file, the run and the runs there.
class UnknownRun : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

struct ReportOptions {
  std::vector<storage::RunId> runs;    // only these runs, in this order; empty: every run of the file
  std::string software_version;        // "alc 0.1.0", shown in the page's header
};

// What a report holds (for the CLI's summary line and the tests).
struct ReportStats {
  std::size_t runs = 0;
  std::size_t charts = 0;
  std::size_t series = 0;
  std::size_t points = 0;              // drawn (after display downsampling)
  bool study = false;                  // the file holds a study (its figures embedded)
  std::size_t figures = 0;             // the study's figures (Pareto per case, heat maps)
};

// The page. Throws storage::StorageError for a file that is not an ALC database (naming the file)
// and UnknownRun for a run of options.runs not in the file.
std::string html_report(const std::filesystem::path& file, const ReportOptions& options, ReportStats* stats = nullptr);

// The report's stylesheet (a <style> element's content) and its DOM-check script (a whole <script>
// element that writes, on load, what the charts drew into <pre id="alc-dom-check">): also used by the
// supervisor's status page.
const char* page_style();
const char* dom_check_script();

}  // namespace alc::report
