#include <catch2/catch.hpp>
#include <algorithm>
#include <map>
#include <random>

#include "runtime/replay.hpp"
#include "runtime/report_json.hpp"
#include "scenarios/load_cases.hpp"
#include "study/engine.hpp"
#include "study/results.hpp"

using namespace alc;
using namespace alc::study;

namespace {

// Load case A cut to its first `hours` (a study row equals a replay on any scenario; shorter is cheaper).
StudyCase case_a(double hours) {
  scenarios::Scenario s = scenarios::simulate_case("A", std::nullopt).scenario;
  std::size_t n = 0;
  while (n < s.samples() && s.time_s[n] < s.time_s.front() + hours * 3600.0) ++n;
  s.time_s.resize(n);
  s.inputs.conservativeResize(static_cast<Eigen::Index>(n), Eigen::NoChange);
  s.outputs.conservativeResize(static_cast<Eigen::Index>(n), Eigen::NoChange);
  const std::string hash = content_hash(s);
  return {"A", "case A", std::move(s), hash};
}

const std::vector<StudyCase>& cases() {
  static const std::vector<StudyCase> c = {case_a(60.0)};
  return c;
}

// Two CP lengths and two intervals (four units), three NG intervals x two NG counts each, and an
// invalid set (CP shorter than its probe interval).
const std::vector<ParameterSet>& sets() {
  static const std::vector<ParameterSet> s =
      parse_grid("cp = [0.05, 6.5, 12]\ninterval = [1, 3]\nng-interval = [5, 10, 20]\nng-meas = [6, 12]\n", "t.toml").sets();
  return s;
}

std::map<std::pair<std::size_t, std::size_t>, StudyRow> run(const StudyOptions& base) {
  std::map<std::pair<std::size_t, std::size_t>, StudyRow> rows;
  StudyOptions o = base;
  o.on_rows = [&](std::vector<StudyRow>&& r) {
    for (auto& row : r) {
      const auto key = std::make_pair(row.set, row.case_index);
      REQUIRE(rows.find(key) == rows.end());
      rows.emplace(key, std::move(row));
    }
  };
  run_study(cases(), sets(), o);
  return rows;
}

std::string json_of(const StudyRow& r) { return r.report ? runtime::report_json(*r.report).dump() : "error: " + r.error; }

}  // namespace

TEST_CASE("a study row equals alc replay of its set bit for bit (a seeded random sample), with work shared") {
  StudyOptions o;
  o.jobs = 2;
  StudyStats stats;
  std::map<std::pair<std::size_t, std::size_t>, StudyRow> rows;
  o.on_rows = [&](std::vector<StudyRow>&& r) {
    for (auto& row : r) rows.emplace(std::make_pair(row.set, row.case_index), std::move(row));
  };
  stats = run_study(cases(), sets(), o);
  REQUIRE(rows.size() == sets().size());
  CHECK(stats.units == 4);
  CHECK(stats.forks > 0);               // the sets did share a trunk and forked at a breach
  CHECK(stats.samples < stats.samples_alone);
  // Invalid sets are rows with their error.
  for (const auto& s : sets())
    if (!s.error.empty()) {
      CHECK_FALSE(rows.at({s.index, 0}).report);
      CHECK(rows.at({s.index, 0}).error == s.error);
    }
  std::vector<std::size_t> valid;
  for (const auto& s : sets())
    if (s.error.empty()) valid.push_back(s.index);
  std::mt19937_64 rng(20261123);
  std::shuffle(valid.begin(), valid.end(), rng);
  valid.resize(6);
  for (const std::size_t set : valid) {
    INFO("set " << set << ": " << sets()[set].key);
    const runtime::ReplayReport alone = runtime::replay(cases()[0].scenario, sets()[set].parameters);
    CHECK(json_of(rows.at({set, 0})) == runtime::report_json(alone).dump());
  }
}

TEST_CASE("shards hold every row once and equal the whole study and sharing changes no row") {
  StudyOptions whole;
  whole.jobs = 2;
  const auto all = run(whole);
  std::map<std::pair<std::size_t, std::size_t>, std::string> joined;
  for (int shard = 1; shard <= 3; ++shard) {
    StudyOptions o;
    o.shard = shard;
    o.shards = 3;
    for (const auto& [key, row] : run(o)) {
      CHECK(joined.find(key) == joined.end());
      joined[key] = json_of(row);
    }
  }
  REQUIRE(joined.size() == all.size());
  for (const auto& [key, row] : all) CHECK(joined.at(key) == json_of(row));
  StudyOptions alone;
  alone.share = false;
  alone.jobs = 2;
  alone.wanted = [](std::size_t set, std::size_t) { return set % 5 == 1; };
  for (const auto& [key, row] : run(alone)) CHECK(json_of(row) == json_of(all.at(key)));
}

TEST_CASE("the stop flag ends a study between units and keeps the rows given") {
  std::atomic<bool> stop{false};
  StudyOptions o;
  o.stop = &stop;
  std::size_t given = 0;
  o.on_rows = [&](std::vector<StudyRow>&& r) {
    given += r.size();
    stop = true;  // after the first batch (the invalid sets' rows)
  };
  const StudyStats st = run_study(cases(), sets(), o);
  CHECK(st.stopped);
  CHECK(given == st.rows);
  CHECK(given < sets().size());
}
