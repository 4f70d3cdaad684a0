// alc db: inspect, check, export and benchmark a history database (storage/, docs/storage.md).
#include <algorithm>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <limits>

#include "commands.hpp"
#include "common/atomic_file.hpp"
#include "common/number_text.hpp"
#include "runtime/run.hpp"
#include "runtime/run_state.hpp"
#include "storage/history_reader.hpp"
#include "storage/history_writer.hpp"
#include "storage/history_tools.hpp"
#include "storage/schema.hpp"
#include "storage/storage_error.hpp"
#include "supervisor/supervisor.hpp"

namespace alc::cli {
namespace {

std::string utc_text(double unix_s) {
  const auto t = static_cast<std::time_t>(unix_s);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return text;
}

void run_info(const std::string& file) {
  const storage::HistoryReader reader(file);
  std::cout << "file: " << file << "\n"
            << "schema version: " << reader.schema_version() << " (this alc writes " << storage::kSchemaVersion << ")\n";
  const auto runs = reader.runs();
  std::cout << "runs: " << runs.size() << "\n";
  for (const auto& run : runs) {
    std::cout << "  run " << run.run_id << ": " << run.source << ", " << storage::to_string(run.status)
              << ", started " << utc_text(run.started_unix_s);
    if (run.ended_unix_s) std::cout << ", ended " << utc_text(*run.ended_unix_s);
    std::cout << ", " << run.input_names.size() << " inputs, " << run.output_names.size() << " outputs";
    const auto span = reader.time_span(run.run_id);
    if (!span.empty)
      std::cout << ", time_s " << common::shortest_text(span.first_s) << " .. " << common::shortest_text(span.last_s)
                << " (" << std::setprecision(4)
                << (span.last_s - span.first_s) / 3600.0 << std::setprecision(6) << " h)";
    if (const auto snapshot = reader.latest_snapshot(run.run_id)) {
      if (snapshot->time_s == storage::kSnapshotBeforeStart_s)
        std::cout << ", latest snapshot before the first sample";
      else
        std::cout << ", latest snapshot at time_s " << common::shortest_text(snapshot->time_s);
    }
    if (reader.indicators(run.run_id)) std::cout << ", indicators stored";
    std::cout << "\n";
  }
  std::cout << "rows per table:\n";
  for (const auto& count : reader.table_counts())
    std::cout << "  " << std::left << std::setw(24) << count.table << std::right << count.rows << "\n";
}

void run_check(const std::string& file) {
  // Snapshots of the replay's run state must decode (checksum); other formats are their writers' business.
  const auto report = storage::check_history(file, [](const storage::ControllerSnapshot& s) {
    return s.format == runtime::kRunStateFormat ? runtime::run_state_problem(s) : std::string();
  });
  // Findings (NC commands of a finished run not recorded as delivered) are true records of what
  // happened, not damage: said on stdout, and the exit stays 0 when nothing else is wrong.
  for (const auto& finding : report.findings) std::cout << file << ": finding: " << finding << "\n";
  if (report.ok()) {
    std::cout << file << ": ok"
              << (report.findings.empty() ? std::string()
                                          : " (no problem; " + std::to_string(report.findings.size()) +
                                                " finding(s) above: NC commands the safety gate passed that are not "
                                                "recorded as delivered to the NC)")
              << "\n";
    return;
  }
  for (const auto& problem : report.problems) std::cerr << file << ": " << problem << "\n";
  throw std::runtime_error(file + ": " + std::to_string(report.problems.size()) + " problem(s) found");
}

void run_export(const std::string& file, const std::string& table, const std::string& out) {
  const auto& tables = storage::exportable_tables();
  if (std::find(tables.begin(), tables.end(), table) == tables.end()) {
    std::string known;
    for (const auto& name : tables) known += (known.empty() ? "" : ", ") + name;
    throw UsageError("--table '" + table + "' is not a table of the history; tables: " + known);
  }
  if (out == "-") {
    storage::export_table_csv(file, table, std::cout);
    return;
  }
  // The rename below would replace the database (or its WAL journal) with CSV.
  const std::filesystem::path target(out);
  refuse_output_over_input("--out", target, file, "the history database");
  // Written beside the target and renamed, so a reader never sees half a file.
  io::write_file_atomically(target, [&](std::ostream& stream) { storage::export_table_csv(file, table, stream); });
}

// Marks a supervisor's unfinished run (running: its process was killed; stopped: stopped by SIGTERM)
// finished, so that the supervisor on this history begins a new run (calibration first) at its next
// start instead of resuming it. Through the history's writer, so a supervisor or replay that has the
// file open makes this fail (locked), unchanged.
void run_finish(const std::string& file, std::int64_t run_id) {
  { const storage::HistoryReader exists(file); }  // a missing file: "no such file", as db info says
  storage::WriterOptions options;
  options.must_exist = true;
  storage::HistoryWriter writer(file, options);
  // Read under the writer's claim on the file, after any migration the writer made on opening it.
  const storage::HistoryReader reader(file);
  const auto runs = reader.runs();
  const auto run = std::find_if(runs.begin(), runs.end(), [&](const auto& r) { return r.run_id == run_id; });
  if (run == runs.end())
    throw std::runtime_error(file + ": there is no run " + std::to_string(run_id) + "; " +
                             runtime::unfinished_runs_text(reader, runs));
  if (!runtime::unfinished(*run))
    throw std::runtime_error(file + ": run " + std::to_string(run_id) + " of '" + run->source + "' is " +
                             storage::to_string(run->status) + " already; nothing changed");
  // A replay's run stopped part-way holds the indicators of that part, which a finished run would
  // present as the whole run's (alc report, replay --case all --resume); a new replay begins a run of
  // its own anyway.
  if (!supervisor::is_run_source(run->source))
    throw std::runtime_error(file + ": run " + std::to_string(run_id) + " of '" + run->source +
                             "' is not a supervisor's: a replay's run is continued with alc replay --resume or left "
                             "as it is (a replay without --resume begins a new run); nothing changed");
  writer.end_run(run_id, storage::RunStatus::Finished);
  writer.close();
  std::cout << file << ": run " << run_id << " of '" << run->source << "' is finished (it was "
            << storage::to_string(run->status) << "); its records stay\n";
}

void run_bench(const storage::BenchOptions& options, const std::string& dir) {
  const auto result = storage::bench_history(dir, options);
  std::cout << std::fixed << std::setprecision(0) << "records per mode: " << result.records << " ("
            << options.samples << " input samples of " << options.inputs << " values + as many predictions)\n"
            << "batched (" << options.batch_size << " per transaction): " << result.batched_records_per_s
            << " records/s\n"
            << "unbatched (1 per transaction): " << result.unbatched_records_per_s << " records/s\n"
            << std::setprecision(1) << "ratio batched/unbatched: " << result.ratio() << "\n";
  std::cout << "scratch databases (new files, removed afterwards; no existing file is touched):";
  for (const auto& scratch : result.scratch_files) std::cout << " " << scratch.string();
  std::cout << "\n";
}

// k when `value` names FILE.k of the log file `log` (the same directory after resolving symlinks and
// `.`/`..`, its name FILE.k with k a whole number from 1), else 0.
std::size_t rotation_of(const std::string& log, const std::string& value) {
  namespace fs = std::filesystem;
  std::error_code ec1, ec2;
  const fs::path l = fs::weakly_canonical(fs::absolute(fs::path(log), ec1), ec1);
  const fs::path v = fs::weakly_canonical(fs::absolute(fs::path(value), ec2), ec2);
  if (ec1 || ec2 || l.parent_path() != v.parent_path()) return 0;
  const std::string base = l.filename().string() + ".", name = v.filename().string();
  if (name.size() <= base.size() || name.compare(0, base.size(), base) != 0 || name.size() - base.size() > 9) return 0;
  std::size_t k = 0;
  for (std::size_t i = base.size(); i < name.size(); ++i) {
    if (name[i] < '0' || name[i] > '9') return 0;
    k = k * 10 + static_cast<std::size_t>(name[i] - '0');
  }
  return name[base.size()] == '0' ? 0 : k;
}

// "choose another --out file", "choose another [log] file": the option, and "file" unless it says so.
std::string another_file(const std::string& option) {
  return "choose another " + option + (option.ends_with(" file") ? "" : " file");
}

}  // namespace

void refuse_output_over_input(const std::string& option, const std::filesystem::path& target,
                                 const std::string& database, const std::string& what,
                                 const std::string& consequence) {
  namespace fs = std::filesystem;
  if (database.empty() || target.empty() || target == "-") return;
  std::error_code ec1, ec2;
  const fs::path db = fs::weakly_canonical(fs::absolute(fs::path(database), ec1), ec1);
  const fs::path out = fs::weakly_canonical(fs::absolute(target, ec2), ec2);
  for (const char* suffix : {"", "-wal", "-shm", "-journal"}) {
    const fs::path own = fs::path(database + suffix);
    const fs::path own_canonical = db.string() + suffix;
    std::error_code eq;
    const bool same = (!ec1 && !ec2 && out == own_canonical) ||
                      (fs::exists(own, eq) && fs::exists(target, eq) && fs::equivalent(own, target, eq));
    if (same)
      throw UsageError(option + " '" + target.string() + "' is " + what +
                       (*suffix ? std::string(" journal '") + database + suffix + "'" : " '" + database + "'") +
                       " itself; " + consequence + "; " + another_file(option));
  }
}

void refuse_log_over(const std::string& option, const std::string& log, std::size_t max_files,
                     const std::string& value, const std::string& what) {
  refuse_output_over_input(option, log, value, what, "log lines would be written into it");
  // The names the log rotates to (FILE.1 ... FILE.N): a rotation would rename the log over it.
  if (const auto k = rotation_of(log, value); k >= 1 && k <= max_files)
    throw UsageError(option + " '" + log + "' rotates to '" + value + "', which is " + what +
                     ": a rotation would replace it with the log; " + another_file(option) +
                     (option == "--log-file" ? " or --log-max-files" : ""));
}

void refuse_unwritable_output(const std::string& option, const std::string& target) {
  if (target.empty()) return;
  if (target == "-") throw UsageError(option + " writes a file; '-' (stdout) is not offered");
  if (const std::string problem = io::output_file_problem(target); !problem.empty())
    throw std::runtime_error(option + ": cannot write '" + target + "': " + problem);
}

void add_db_command(CLI::App& app) {
  auto* db = app.add_subcommand("db", "Inspect, check, export and benchmark a history database (docs/storage.md)");
  db->require_subcommand(1);

  auto file = std::make_shared<std::string>();
  auto table = std::make_shared<std::string>();
  auto out = std::make_shared<std::string>();

  auto* info = db->add_subcommand("info", "Schema version, runs, rows per table and time span of each run");
  info->add_option("FILE", *file, "History database")->required();
  info->callback([file] { run_info(*file); });

  auto* check = db->add_subcommand("check", "PRAGMA integrity_check and the project's consistency checks; "
                                            "exit 1 and the problems on stderr if any");
  check->add_option("FILE", *file, "History database")->required();
  check->callback([file] { run_check(*file); });

  auto* exp = db->add_subcommand("export", "One table as CSV (header line, RFC 4180 quoting, vectors spread "
                                           "into one column per channel)");
  exp->add_option("FILE", *file, "History database")->required();
  std::string tables;
  for (const auto& name : storage::exportable_tables()) tables += (tables.empty() ? "" : ", ") + name;
  exp->add_option("--table", *table, "Table to export: " + tables)->required();
  exp->add_option("--out", *out, "CSV file to write ('-' for stdout)")->required();
  exp->callback([file, table, out] { run_export(*file, *table, *out); });

  auto run = std::make_shared<std::int64_t>(0);
  auto* finish = db->add_subcommand("finish", "Mark a supervisor's unfinished run (running or stopped) finished, so "
                                              "that the supervisor begins a new run at its next start");
  finish->add_option("FILE", *file, "History database")->required();
  add_whole_option(finish, "--run", *run, "The run to finish (alc db info lists them)", 1,
                   std::numeric_limits<std::int64_t>::max())->required();
  finish->callback([file, run] { run_finish(*file, *run); });

  auto options = std::make_shared<storage::BenchOptions>();
  auto dir = std::make_shared<std::string>(std::filesystem::temp_directory_path().string());
  auto* bench = db->add_subcommand("bench", "Records per second written, batched against one transaction per record");
  add_whole_option(bench, "--samples", options->samples, "Input samples per mode (each with a prediction)", 1,
                   1000000000);
  add_whole_option(bench, "--inputs", options->inputs, "Values per input sample", 1, 100000);
  add_whole_option(bench, "--batch", options->batch_size, "Records per transaction in the batched mode", 1, 1000000000);
  bench->add_option("--dir", *dir, "Directory for the scratch databases (new files alc-bench-<pid>-<n>.sqlite, "
                                   "removed afterwards)")->capture_default_str();
  bench->callback([options, dir] { run_bench(*options, *dir); });

  db->add_subcommand("path", "Print the default history database location")->callback([] {
    std::cout << storage::default_history_path().string() << "\n";
  });
}

}  // namespace alc::cli
