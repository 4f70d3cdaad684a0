#pragma once
// What a study answers (seed 004, Eq. 8 and Tab. 2/3): per case the set with the highest Pd among
// those whose mean linear P99 stays below the limit; the set that meets the limit on every case with
// the highest mean Pd; the Pareto front of mean linear P99 against Pd per case. When no set meets
// the limit, the closest sets instead.
#include <nlohmann/json.hpp>
#include <optional>
#include <ostream>
#include <vector>

#include "study/results.hpp"

namespace alc::study {

struct Point {
  std::size_t set = 0;
  double p99_linear = 0.0;   // [µm] mean over the linear outputs
  double p99_angular = 0.0;  // [µm/m]
  double pd = 0.0;           // [%]
  int M = 0;
};

struct CaseAnalysis {
  std::string name;
  std::size_t rows = 0, failed = 0;
  std::optional<Point> optimum;      // Eq. 8
  std::vector<Point> closest;        // lowest P99 first, when there is no optimum
  std::vector<Point> pareto;         // non-dominated (lower P99, higher Pd), by P99
};

struct CommonChoice {
  std::optional<std::size_t> set;    // meets the limit on every case with the highest mean Pd
  double mean_pd = 0.0;
  std::vector<Point> per_case;       // its row per case
  // Without such a set: the sets with the lowest worst-case P99 (set, worst P99, mean Pd).
  struct Near {
    std::size_t set;
    double worst_p99;
    double mean_pd;
  };
  std::vector<Near> closest;
};

struct Analysis {
  double limit_um = 5.0;
  std::vector<CaseAnalysis> cases;
  CommonChoice common;
  std::optional<std::size_t> paper_set;  // seed 004's chosen set (CP 6.5 h, 2 h, 10 min, 12), if in the grid
  std::size_t rows = 0, expected = 0;    // rows present of sets x cases
};

Analysis analyse(const StudyInfo& info, const std::vector<storage::StudyRowRecord>& rows, double limit_um = 5.0);
nlohmann::json analysis_json(const Analysis& a, const StudyInfo& info);
void print_analysis(std::ostream& os, const Analysis& a, const StudyInfo& info);

}  // namespace alc::study
