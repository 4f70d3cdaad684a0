// alc report: a history database (or a study file) as one self-contained HTML page (report/,
// docs/report.md).
#include <chrono>
#include <filesystem>
#include <iostream>

#include "alc_version.hpp"
#include "commands.hpp"
#include "common/atomic_file.hpp"
#include "report/html_report.hpp"

namespace alc::cli {

namespace {

struct ReportArgs {
  std::string file;
  std::vector<std::int64_t> runs;
  std::string out = "report.html";
};

void run_report(const ReportArgs& a) {
  refuse_output_over_input("--out", a.out, a.file, "the database to report");
  refuse_unwritable_output("--out", a.out);
  report::ReportOptions o;
  o.runs = a.runs;
  o.software_version = std::string("alc ") + ALC_VERSION;
  const auto start = std::chrono::steady_clock::now();
  report::ReportStats stats;
  std::string html;
  try {
    html = report::html_report(a.file, o, &stats);
  } catch (const report::UnknownRun& e) {
    throw UsageError(std::string("--run: ") + e.what());
  }  // a file that is not a history this alc can read exits 2 by main's one rule (wrong_input)
  io::write_file_atomically(a.out, html);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::cout << "report: " << std::filesystem::absolute(a.out).string() << " (" << stats.runs << " run(s)"
            << (stats.study ? " and the study's " + std::to_string(stats.figures) + " figures" : "") << ", " << stats.charts << " charts, " << stats.series
            << " series, " << stats.points << " points drawn, " << html.size() / 1024 << " KiB, written in "
            << static_cast<int>(seconds * 1000.0) << " ms)\n";
}

}  // namespace

void add_report_command(CLI::App& app) {
  auto args = std::make_shared<ReportArgs>();
  CLI::App* cmd = app.add_subcommand(
      "report", "Write one self-contained HTML page of a history database: per run the errors (measured, "
                "predicted, residual with the ACL band) with phases and model updates, the inputs, probe intervals "
                "and Pd, the axis offsets (refused commands marked), the indicators and the parameters; for a "
                "study file its Pareto fronts and heat maps. Opens offline in any browser (see docs/report.md).");
  cmd->add_option("file", args->file, "History database (alc replay --db, alc study --db)")->required();
  // Each value through the strict reader of whole numbers (CLI11 alone reads "0x10" as 16).
  cmd->add_option_function<std::vector<std::string>>(
         "--run",
         [args](const std::vector<std::string>& texts) {
           for (const std::string& t : texts)
             args->runs.push_back(static_cast<std::int64_t>(whole_option_value("--run", t, 1, INT64_MAX)));
         },
         "Only this run; repeat for several (default: every run of the file)")
      ->type_name("N")
      ->allow_extra_args(false);
  cmd->add_option("--out", args->out, "HTML file to write")->capture_default_str();
  cmd->callback([args] { run_report(*args); });
}

}  // namespace alc::cli
