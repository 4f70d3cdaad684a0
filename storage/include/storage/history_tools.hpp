#pragma once
// What `alc db check|export|bench` do, as functions.
#include <cstdint>
#include <filesystem>
#include <iosfwd>
#include <string>
#include <string_view>
#include <vector>

#include "storage/history_writer.hpp"

namespace alc::storage {

struct CheckReport {
  std::vector<std::string> problems;   // one line each; empty = the database is sound
  // What the history truly records but a reader should know, one line each; not a problem (the file is
  // sound): a finished run whose NC commands the safety gate passed never reached the NC (delivered 0:
  // the sink failed; NULL: not settled, the run was killed before the delivery and resumed without it).
  std::vector<std::string> findings;
  bool ok() const { return problems.empty(); }
};

// PRAGMA integrity_check, foreign_key_check, then the project's checks: every run has a JSON
// configuration and channel names; times strictly increase per run for input samples and never
// decrease for the other tables; vector lengths match the run's channels; JSON snapshots parse.
// With `snapshot_check` (runtime::run_state_problem), every snapshot whose payload it refuses is a
// problem naming the snapshot id and run. Throws StorageError only if the file cannot be opened as
// an ALC history at all.
CheckReport check_history(const std::filesystem::path& path, const SnapshotCheck& snapshot_check = {});

// Why `text` is not an indicators document as `alc replay --json` prints it (a JSON object whose
// "outputs" is an object and whose "M" is a whole number), or "" when it is one: what a finished
// study_rows.report_json holds, and what the study's analysis and CSV rely on.
std::string report_json_problem(const std::string& text);

// Why a study's cases_json is not what `alc study` writes (a non-empty array of objects with string
// "name", "source" and "content_hash"), or "" when it is.
std::string study_cases_problem(const std::string& cases_json);

// Why a study row's indices do not name a row of its study (set_index in [0, set_count), case_index
// in [0, case_count)), or "": a row outside them would index past the grid or the cases.
std::string study_row_problem(std::int64_t set_index, std::int64_t case_index, std::int64_t set_count,
                              std::int64_t case_count);

// Tables `alc db export` accepts (the fixed list; nothing else reaches SQL).
const std::vector<std::string>& exportable_tables();

// Writes `table` as CSV (RFC 4180 quoting, header line, shortest round-trip numbers, empty cell
// for NaN/NULL, "inf" for infinity). Vectors are spread into one column per channel name,
// e.g. input_samples: run_id,sample_index,time_s,<input names...>. Throws StorageError
// (InvalidArgument) for a table not in exportable_tables().
void export_table_csv(const std::filesystem::path& path, std::string_view table, std::ostream& out);

struct BenchOptions {
  std::int64_t samples = 20000;          // input samples written per mode
  int inputs = 16;                       // values per sample
  std::size_t batch_size = 1000;         // records per transaction in the batched mode
};

struct BenchResult {
  std::int64_t records = 0;              // records per mode (samples + predictions)
  double batched_records_per_s = 0.0;    // [1/s]
  double unbatched_records_per_s = 0.0;  // [1/s] one transaction per record
  std::vector<std::filesystem::path> scratch_files;  // the new files written (and removed), one per mode
  double ratio() const { return unbatched_records_per_s > 0 ? batched_records_per_s / unbatched_records_per_s : 0.0; }
};

// Writes the same synthetic run twice, each time into a new file alc-bench-<pid>-<n>.sqlite that it
// creates in `directory` (never an existing file) and removes afterwards.
BenchResult bench_history(const std::filesystem::path& directory, const BenchOptions& options);

}  // namespace alc::storage
