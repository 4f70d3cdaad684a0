#pragma once
// What a study is (grid, sets, cases, program version, shard) and its rows as stored, written as
// CSV, and compared when a study resumes or shards merge.
#include <ostream>
#include <string>
#include <vector>

#include "storage/study_store.hpp"
#include "study/engine.hpp"
#include "study/grid.hpp"

namespace alc::study {

struct CaseInfo {
  std::string name;
  std::string source;
  std::string content_hash;
};

struct StudyInfo {
  Grid grid;
  std::vector<ParameterSet> sets;   // grid.sets()
  std::vector<CaseInfo> cases;
  std::string software_version;
  std::string shard = "all";        // "I/N" or "all"

  storage::StudyHeader header() const;
  // The study a file holds; `file` names it in the error when the stored grid or cases cannot be read.
  static StudyInfo of(const storage::StudyHeader& header, const std::string& file);
  std::size_t runs() const { return sets.size() * cases.size(); }
};

// The cases of a study as its header names them.
std::vector<CaseInfo> case_infos(const std::vector<StudyCase>& cases);
// The cases of a stored header's cases_json (throws nlohmann::json::exception on a malformed one).
std::vector<CaseInfo> cases_of(const std::string& cases_json);

// "" if `now` continues `stored` (same grid, cases, program version and shard), else what differs,
// naming both values (a case: its name and content hash). A recording is its content: the same file
// reached by another path (./a.csv, /data/a.csv: a SLURM task resubmitted with the paths as typed) is
// the same case; renamed_cases says which, and the stored names stay the study's.
std::string difference(const storage::StudyHeader& stored, const storage::StudyHeader& now);

// The file cases of `now` that are a stored case reached by another path, as "now -> stored" texts.
std::vector<std::string> renamed_cases(const storage::StudyHeader& stored, const storage::StudyHeader& now);

// A row as a study file stores it: report_json is alc replay --json of the run.
storage::StudyRowRecord record_of(const StudyRow& row);

// Rows as CSV (header: set, case, the grid's axes, status, error, Pd, M, ng_phases, updates,
// rejected_fits, cp_end_h, duration_h, P99_linear, P99_angular, baseline and uncompensated means,
// then per output PV, RMSE, P99, SMAPE, P99_uncompensated, measurements). Numbers in their shortest
// exact form, an empty cell where there is none; pandas reads it as it is.
void write_rows_csv(std::ostream& os, const StudyInfo& info, const std::vector<storage::StudyRowRecord>& rows);

}  // namespace alc::study
