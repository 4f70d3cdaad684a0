// alc replay --baselines: the seeds' static models beside ALC (docs/baselines.md). Runs the built
// program.
#include <catch2/catch.hpp>

#include <cmath>
#include <nlohmann/json.hpp>

#include "../cli_support.hpp"
#include "runtime/report_json.hpp"

namespace {
alc_test::CliRun run_cli(const std::string& args) { return alc_test::run_alc(args, "replay_baselines_cli_test"); }
}  // namespace

TEST_CASE("alc replay --baselines all: one entry per model with finite indicators on case A and the rest unchanged") {
  const alc_test::CliRun with = run_cli("replay --case A --json --baselines all");
  REQUIRE(with.exit_code == 0);
  nlohmann::json j = nlohmann::json::parse(with.out);
  REQUIRE(j.contains("baselines"));
  const auto& b = j["baselines"];
  CHECK(b.size() == 5);
  for (const char* name : {"mlr", "lasso", "svr", "gm", "ols"}) {
    INFO(name);
    REQUIRE(b.contains(name));
    REQUIRE(b[name]["outputs"].size() == j["outputs"].size());
    for (const auto& [output, o] : b[name]["outputs"].items()) {
      INFO(output);
      for (const char* f : {"PV", "RMSE", "P99", "SMAPE"}) {
        REQUIRE(o[f].is_number());
        CHECK(std::isfinite(o[f].get<double>()));
      }
      CHECK(o["measurements"] == j["outputs"][output]["measurements"]);
    }
  }
  // mlr is the static baseline; lasso and ols name the inputs they selected, per output.
  CHECK(b["mlr"]["outputs"] == j["baseline"]["outputs"]);
  for (const char* name : {"lasso", "ols"}) {
    REQUIRE(b[name].contains("selected"));
    CHECK(b[name]["selected"].size() == j["outputs"].size());
  }
  CHECK_FALSE(b["svr"].contains("selected"));
  // report_from_json reads the baselines back (what a study file would store).
  CHECK(alc::runtime::report_json(alc::runtime::report_from_json(j)) == j);
  // Without the flag the document is the one with the flag minus "baselines".
  const alc_test::CliRun without = run_cli("replay --case A --json");
  REQUIRE(without.exit_code == 0);
  j.erase("baselines");
  CHECK(j.dump(2) + "\n" == without.out);
}

TEST_CASE("alc replay --baselines prints one line per model and rejects an unknown name") {
  const alc_test::CliRun r = run_cli("replay --case B --baselines gm,lasso");
  REQUIRE(r.exit_code == 0);
  CHECK_THAT(r.out, Catch::Matchers::Contains("  gm     mean P99 linear "));
  CHECK_THAT(r.out, Catch::Matchers::Contains("  lasso  mean P99 linear "));
  CHECK_THAT(r.out, Catch::Matchers::Contains("; inputs selected: E_X0C "));
  CHECK_THAT(r.out, !Catch::Matchers::Contains("  svr "));
  const alc_test::CliRun bad = run_cli("replay --case A --baselines mlr,knn");
  CHECK(bad.exit_code == 2);
  CHECK_THAT(bad.err,
             Catch::Matchers::Contains("--baselines: 'knn' is not one of mlr, lasso, svr, gm, ols, or all"));
  const auto db = alc_test::work_dir("replay_baselines_cli_test") / "none.sqlite";
  const alc_test::CliRun resumed = run_cli("replay --case A --baselines svr --db \"" + db.string() + "\" --resume");
  CHECK(resumed.exit_code == 2);
  CHECK_THAT(resumed.err, Catch::Matchers::Contains("baselines cannot be evaluated on a resumed run"));
}
