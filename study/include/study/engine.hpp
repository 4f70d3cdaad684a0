#pragma once
// Runs a study: every parameter set of a grid over every case, one row per (set, case), each row
// equal bit for bit to `alc replay` of that set on that case.
//
// Work is shared, not only spread over threads (docs/study.md): the sets of a case that agree on
// every option of the stages Start and CpEnd (runtime/parameter_options.hpp) run as one controller
// (a unit) until the first ACL breach after CP, where the options of stage Breach first matter; there
// the controller forks (Controller::fork) into one branch per distinct set of those options. A unit
// that never breaches gives every member the same row.
#include <atomic>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "runtime/evaluation.hpp"
#include "scenarios/scenario.hpp"
#include "study/grid.hpp"

namespace alc::study {

struct StudyCase {
  std::string name;                 // "A", or the file as given
  std::string source;               // "case A", "file a.csv" (as alc replay names the run's source)
  scenarios::Scenario scenario;
  std::string content_hash;         // hex checksum of names, times and values (a changed recording differs)
};
using scenarios::content_hash;

struct StudyRow {
  std::size_t set = 0;
  std::size_t case_index = 0;
  std::string error;                            // a failed run (invalid set, exception): no report
  std::optional<runtime::ReplayReport> report;  // wall times are 0 (not part of a row)
};

// The work units of a study in a fixed order: the sets of one case that run as one controller until
// their first breach. Invalid sets are in no unit.
struct Unit {
  std::size_t case_index = 0;
  std::vector<std::size_t> sets;
};
std::vector<Unit> plan_units(const std::vector<StudyCase>& cases, const std::vector<ParameterSet>& sets);

// Shard I of N (1-based) of a study: every N-th unit from the (I-1)-th, and the error rows of
// invalid sets in the same way by set. The shards of 1..N together hold every row exactly once.
bool unit_in_shard(std::size_t unit_index, int shard, int shards);
bool invalid_set_in_shard(std::size_t set_index, int shard, int shards);
// The rows shard I of N owns (its units' sets and its invalid sets' rows): what run_study gives it
// when nothing is done yet.
std::size_t shard_rows(const std::vector<StudyCase>& cases, const std::vector<ParameterSet>& sets, int shard,
                       int shards);

struct StudyOptions {
  int jobs = 1;                     // worker threads
  int shard = 1, shards = 1;        // --shard I/N
  // Rows already done (resume): false to skip (set, case).
  std::function<bool(std::size_t set, std::size_t case_index)> wanted;
  // The rows of each finished unit, called by one thread at a time in completion order.
  std::function<void(std::vector<StudyRow>&&)> on_rows;
  const std::atomic<bool>* stop = nullptr;  // set: finish no more units (rows already given stay)
  bool share = true;                // false: every set runs alone (a baseline for the benchmark)
};

struct StudyStats {
  std::size_t rows = 0;              // rows given to on_rows
  std::size_t runs = 0;              // controller runs that produced them (<= rows: shared results)
  std::size_t units = 0;
  std::size_t forks = 0;             // Controller::fork calls
  std::int64_t samples = 0;          // sample cycles executed
  std::int64_t samples_alone = 0;    // sample cycles the rows would take run one by one
  std::int64_t fits = 0;             // identifications executed
  bool stopped = false;              // the stop flag ended the study early
};

// Runs the rows that `options` select. Thread safe with respect to its own workers only.
StudyStats run_study(const std::vector<StudyCase>& cases, const std::vector<ParameterSet>& sets,
                     const StudyOptions& options);

}  // namespace alc::study
