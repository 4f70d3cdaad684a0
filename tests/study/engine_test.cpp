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
// invalid set (CP shorter than its probe interval); a linear ACL of 2.5 µm, so that a Post-CP probe of
// these 60 h breaches and the NG options fork there (at 5 µm the guard's move check keeps them all within).
const std::vector<ParameterSet>& sets() {
  static const std::vector<ParameterSet> s =
      parse_grid("cp = [0.05, 6.5, 12]\ninterval = [1, 3]\nng-interval = [5, 10, 20]\nng-meas = [6, 12]\nacl-lin = [2.5]\n", "t.toml").sets();
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

TEST_CASE("a set that alc replay refuses on a case is an error row with replay's reason, not a status-ok run") {
  // CP 300 h on a 60-h case would never end: replay refuses it; a study row of it used to read ok with
  // Pd 68 % and no indicator. The same for learning from after the case's end. Two cases of different
  // length: the set runs on the long one and is an error row on the short one only.
  std::vector<StudyCase> two = {case_a(60.0), case_a(20.0)};
  two[1].name = "A20";
  two[1].source = "file a20.csv";
  const std::vector<ParameterSet> grid =
      parse_grid("cp = [6.5, 30]\nsince = [0, 40]\n", "t.toml").sets();
  REQUIRE(grid.size() == 4);
  std::map<std::pair<std::size_t, std::size_t>, StudyRow> rows;
  StudyOptions o;
  o.on_rows = [&](std::vector<StudyRow>&& r) {
    for (auto& row : r) REQUIRE(rows.emplace(std::make_pair(row.set, row.case_index), std::move(row)).second);
  };
  run_study(two, grid, o);
  REQUIRE(rows.size() == 8);
  CHECK(shard_rows(two, grid, 1, 1) == 8);
  for (const ParameterSet& set : grid) {
    INFO(set.key);
    const double cp_h = set.parameters.cp_duration_s / 3600.0, since_h = set.parameters.learning_since_s / 3600.0;
    for (std::size_t c = 0; c < two.size(); ++c) {
      const StudyRow& row = rows.at({set.index, c});
      const std::string why = runtime::scenario_problem(two[c].scenario, set.parameters, two[c].source, {"cp =", "", "since =", ""});
      const bool refused = (c == 1 && (cp_h > 20.0 || since_h > 20.0));
      CHECK(why.empty() == !refused);
      CHECK(static_cast<bool>(row.report) == !refused);
      if (!refused) continue;
      // The first reason replay gives: learning after the end, then the CP.
      CHECK(row.error.find(since_h > 20.0 ? "since = 40 h is after the end of file a20.csv"
                                          : "cp = 30 h is longer than file a20.csv") != std::string::npos);
    }
  }
  // Shards count and hold the error rows once.
  std::size_t in_shards = 0;
  for (int shard = 1; shard <= 3; ++shard) in_shards += shard_rows(two, grid, shard, 3);
  CHECK(in_shards == 8);
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
