// alc replay --baselines: the seeds' static models beside ALC (docs/baselines.md). Runs the built
// program.
#include <catch2/catch.hpp>

#include <cmath>
#include <fstream>
#include <sstream>
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
  // Every model counts the CP measurements it learnt from (78 per output on A: 6.5 h at 5 min), 5 parameters.
  for (const char* name : {"mlr", "lasso", "svr", "gm", "ols"}) {
    INFO(name);
    CHECK(b[name]["parameters"] == 5);
    REQUIRE(b[name]["fitted_on"].size() == j["outputs"].size());
    for (const auto& [output, count] : b[name]["fitted_on"].items()) CHECK(count == 78);
  }
  // report_from_json reads the baselines back (what a study file would store).
  CHECK(alc::runtime::report_json(alc::runtime::report_from_json(j)) == j);
  // Without the flag the document is the one with the flag minus "baselines".
  const alc_test::CliRun without = run_cli("replay --case A --json");
  REQUIRE(without.exit_code == 0);
  j.erase("baselines");
  CHECK(j.dump(2) + "\n" == without.out);
}

TEST_CASE("alc replay --baselines: a model fitted on fewer CP measurements than its parameters says so") {
  // Case A with E_X0C measured at 2 CP probes only and E_A0C at 3: 5 parameters (4 inputs + 1).
  const auto dir = alc_test::work_dir("replay_baselines_cli_test");
  const auto full = dir / "a.csv", cut = dir / "a_few.csv";
  REQUIRE(run_cli("simulate --case A --out \"" + full.string() + "\"").exit_code == 0);
  std::ifstream in(full);
  std::ofstream out(cut);
  std::string line;
  std::getline(in, line);
  out << line << "\n";  // time_s,T_ENV,T_WS,T_COOL,n_C,E_X0C,E_Y0C,E_Z0T,E_R0T,E_A0C,E_B0C,E_C0C
  int x = 0, a = 0;
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::stringstream ss(line);
    for (std::string c; std::getline(ss, c, ',');) cells.push_back(c);
    cells.resize(12);
    const double t = std::stod(cells[0]);
    if (t < 6.5 * 3600.0 && !cells[5].empty() && ++x > 2) cells[5].clear();
    if (t < 6.5 * 3600.0 && !cells[9].empty() && ++a > 3) cells[9].clear();
    for (std::size_t k = 0; k < cells.size(); ++k) out << (k ? "," : "") << cells[k];
    out << "\n";
  }
  out.close();
  const alc_test::CliRun text = run_cli("replay \"" + cut.string() + "\" --baselines mlr,svr");
  REQUIRE(text.exit_code == 0);
  CHECK_THAT(text.out, Catch::Matchers::Contains(
                           "; underdetermined (fewer CP measurements than its 5 parameters, inputs + 1): E_X0C 2 E_A0C 3\n"));
  const alc_test::CliRun js = run_cli("replay \"" + cut.string() + "\" --baselines svr --json");
  REQUIRE(js.exit_code == 0);
  const auto j = nlohmann::json::parse(js.out);
  CHECK(j["baselines"]["svr"]["fitted_on"]["E_X0C"] == 2);
  CHECK(j["baselines"]["svr"]["fitted_on"]["E_A0C"] == 3);
  CHECK(j["baselines"]["svr"]["fitted_on"]["E_Y0C"] == 78);
  // The full recording: no such note.
  CHECK_THAT(run_cli("replay \"" + full.string() + "\" --baselines mlr").out, !Catch::Matchers::Contains("underdetermined"));
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
