#include <catch2/catch.hpp>
#include <cmath>

#include "runtime/run.hpp"
#include "study/grid.hpp"

using namespace alc;
using namespace alc::study;

namespace {
std::string error_of(const std::string& toml) {
  try {
    parse_grid(toml, "g.toml");
  } catch (const GridError& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST_CASE("the paper grid has the study's 2191 sets") {
  const Grid g = paper_grid();
  const auto sets = g.sets();
  CHECK(sets.size() == 2191);  // 7 x (13 x 6 x 4 + 1)
  std::size_t inf_sets = 0;
  for (const auto& s : sets) {
    CHECK(s.error.empty());
    CHECK(s.parameters.cp_interval_s == 300.0);
    CHECK(s.parameters.acl_linear_um == 5.0);
    CHECK(std::isinf(s.parameters.update_interval_s));
    if (s.value("interval") == "inf") {
      ++inf_sets;
      CHECK(s.value("ng-meas").empty());  // moot without Post-CP probes
      CHECK(s.options.size() == 2);
    }
  }
  CHECK(inf_sets == 7);
  CHECK(sets.front().key == "cp=6.5 interval=1 ng-interval=5 ng-meas=6");
  CHECK(sets[1].key == "cp=6.5 interval=1 ng-interval=5 ng-meas=12");
  CHECK(sets[1].parameters.ng_measurements == 12.0);
  CHECK(sets[1].parameters.post_cp_interval_s == 3600.0);
  CHECK(sets[1].parameters.ng_interval_s == 300.0);
}

TEST_CASE("a TOML grid is the product of its axes in file order, plus the fixed options") {
  const Grid g = parse_grid("ng-meas = [6, 12]\ninterval = [2.5, \"inf\"]\n[fixed]\ncp = 12\nno-confirm = true\n", "g.toml");
  REQUIRE(g.axes.size() == 2);
  CHECK(g.axes[0].first == "ng-meas");
  CHECK(g.axes[1].second == std::vector<std::string>{"2.5", "inf"});
  const auto sets = g.sets();
  // ng-meas=6/12 x interval=2.5, and one set for interval=inf (ng-meas moot there).
  REQUIRE(sets.size() == 3);
  CHECK(sets[0].key == "ng-meas=6 interval=2.5");
  CHECK(sets[1].key == "interval=inf");
  CHECK(sets[2].key == "ng-meas=12 interval=2.5");
  CHECK(sets[0].parameters.cp_duration_s == 12 * 3600.0);
  CHECK_FALSE(sets[0].parameters.confirm_breach);
  CHECK(sets[0].parameters.post_cp_interval_s == 2.5 * 3600.0);
}

TEST_CASE("options that cannot change a run are left out: ng-meas 0, the adaptive options under the paper schedule or without Post-CP probes, no-confirm under no-refit, move-fraction without the move check") {
  const auto keys = [](const std::string& toml) {
    std::vector<std::string> k;
    for (const ParameterSet& s : parse_grid(toml, "g.toml").sets()) k.push_back(s.key);
    return k;
  };
  // No NG probe: the NG interval and the confirmation are never asked; ng-interval = inf comes first.
  CHECK(keys("ng-meas = [0, 6]\nng-interval = [10, 20]\n") ==
        std::vector<std::string>{"ng-meas=0", "ng-meas=6 ng-interval=10", "ng-meas=6 ng-interval=20"});
  CHECK(keys("ng-meas = [0, 6]\nng-interval = [10, \"inf\"]\nno-confirm = [true, false]\n") ==
        std::vector<std::string>{"ng-meas=0", "ng-interval=inf", "ng-meas=6 ng-interval=10 no-confirm=true",
                                 "ng-meas=6 ng-interval=10 no-confirm=false"});
  // The adaptive schedule's options under the paper schedule (given or by default).
  CHECK(keys("schedule = [\"paper\", \"adaptive\"]\nuncertainty-fraction = [0.3, 0.5]\nmin-interval = [0.5, 1]\n") ==
        std::vector<std::string>{"schedule=paper", "schedule=adaptive uncertainty-fraction=0.3 min-interval=0.5",
                                 "schedule=adaptive uncertainty-fraction=0.3 min-interval=1",
                                 "schedule=adaptive uncertainty-fraction=0.5 min-interval=0.5",
                                 "schedule=adaptive uncertainty-fraction=0.5 min-interval=1"});
  CHECK(keys("max-interval = [4, \"inf\"]\n") == std::vector<std::string>{""});
  CHECK(keys("max-interval = [4, \"inf\"]\n[fixed]\nschedule = \"adaptive\"\n") ==
        std::vector<std::string>{"max-interval=4", "max-interval=inf"});
  // Without Post-CP probes the adaptive schedule has no interval to choose (before: one set per value,
  // the same run each).
  CHECK(keys("interval = [2, \"inf\"]\nuncertainty-fraction = [0.5, 1]\nmax-interval = [4, 8]\n[fixed]\n"
             "schedule = \"adaptive\"\n") ==
        std::vector<std::string>{"interval=2 uncertainty-fraction=0.5 max-interval=4",
                                 "interval=2 uncertainty-fraction=0.5 max-interval=8",
                                 "interval=2 uncertainty-fraction=1 max-interval=4",
                                 "interval=2 uncertainty-fraction=1 max-interval=8", "interval=inf"});
  // Without refits a breach is never confirmed: no-refit implies no-confirm (before: two sets, one run).
  CHECK(keys("no-refit = [false, true]\nno-confirm = [false, true]\n") ==
        std::vector<std::string>{"no-refit=false no-confirm=false", "no-refit=false no-confirm=true",
                                 "no-refit=true"});
  // The guard's move check runs only with the guard, with refits on probes and with Post-CP probes.
  CHECK(keys("guard = [true, false]\nmove-fraction = [0.5, \"inf\"]\n") ==
        std::vector<std::string>{"guard=true move-fraction=0.5", "guard=true move-fraction=inf", "guard=false"});
  CHECK(keys("no-refit = [false, true]\nmove-fraction = [0.25, 1]\n") ==
        std::vector<std::string>{"no-refit=false move-fraction=0.25", "no-refit=false move-fraction=1", "no-refit=true"});
  CHECK(keys("interval = [2, \"inf\"]\nmove-fraction = [0.25, 1]\n") ==
        std::vector<std::string>{"interval=2 move-fraction=0.25", "interval=2 move-fraction=1", "interval=inf"});
  const std::vector<ParameterSet> sets = parse_grid("move-fraction = [0.25, \"inf\"]\n", "g.toml").sets();
  REQUIRE(sets.size() == 2);
  CHECK(sets[0].parameters.move_fraction == 0.25);
  CHECK(std::isinf(sets[1].parameters.move_fraction));
  // A run's identity holds the fraction only where it is not the default and a move check runs, so the
  // runs before the option (and a moot value) keep theirs.
  CHECK(runtime::canonical_parameters(sets[0].parameters).at("move_fraction") == 0.25);
  CHECK(runtime::canonical_parameters(sets[1].parameters).at("move_fraction") == "inf");
  CHECK_FALSE(runtime::canonical_parameters(AlcParameters{}).contains("move_fraction"));
  AlcParameters unguarded = sets[0].parameters;
  unguarded.guard = false;
  CHECK_FALSE(runtime::canonical_parameters(unguarded).contains("move_fraction"));
}

TEST_CASE("a bad grid names the file, line, key and value before any run") {
  CHECK(error_of("cp = [6.5, -1]\n") == "g.toml:1:12: key 'cp', value '-1': cp: '-1' is not a number > 0");
  CHECK(error_of("cp = [6.5]\nintervall = [2]\n").rfind("g.toml:2:13: 'intervall' is not a grid key", 0) == 0);
  CHECK(error_of("cp = 6.5\n").find("key 'cp' must be a list of values") != std::string::npos);
  CHECK(error_of("cp = []\n").find("key 'cp' has no values") != std::string::npos);
  CHECK(error_of("cp = [6, 6]\n").find("value '6' is listed twice") != std::string::npos);
  CHECK(error_of("cp = [6]\n[fixed]\ncp = 6\n").find("key 'cp' is given twice") != std::string::npos);
  CHECK(error_of("interval = [\"nan\"]\n").find("value 'nan'") != std::string::npos);
  CHECK(error_of("cp = [\"0x10\"]\n").find("value '0x10'") != std::string::npos);
  CHECK(error_of("method = [\"magic\"]\n").find("not fixed-poles or output-error") != std::string::npos);
  CHECK(error_of("cp = [1\n").rfind("g.toml:", 0) == 0);  // a TOML syntax error keeps file:line
  CHECK(error_of("[fixed]\ncp = 6\n").find("no axis") != std::string::npos);
  // A number written as a string is that number: a duplicate is found (before: 6 equal sets).
  CHECK(error_of("cp = [6.5, \"6.50\"]\n").find("g.toml:1:12: key 'cp', value '6.5' is listed twice") == 0);
  CHECK(error_of("interval = [2, \"2.0\"]\n").find("value '2' is listed twice") != std::string::npos);
  CHECK(error_of("interval = [\"inf\", \"Inf\"]\n").find("value 'inf' is listed twice") != std::string::npos);
  // Hex, octal and binary TOML integers are refused, as "0x10" is (before: cp = 16).
  CHECK(error_of("cp = [0x10]\n") ==
        "g.toml:1:7: key 'cp', value '0x10': write it in decimal digits (hex, octal and binary integers are not taken)");
  // The value as written, not as decimal (before: value '16').
  CHECK(error_of("cp = [0o20]\n").find("value '0o20': write it in decimal digits") != std::string::npos);
  CHECK(error_of("cp = [0b10000]\n").find("value '0b10000': write it in decimal digits") != std::string::npos);
}

TEST_CASE("a number written as a string takes its shortest form, the one the CSV shows") {
  const Grid g = parse_grid("interval = [\"2.50\", \"Inf\", \"1e1\"]\nng-meas = [\"6.0\"]\n", "g.toml");
  CHECK(g.axes[0].second == std::vector<std::string>{"2.5", "inf", "10"});
  CHECK(g.axes[1].second == std::vector<std::string>{"6"});
}

TEST_CASE("a grid of more sets than a study takes is refused before any work, without wrapping") {
  std::string text;
  for (const char* key : {"cp", "cp-interval", "interval", "ng-interval", "ng-meas", "acl-lin", "acl-ang", "window"}) {
    text += std::string(key) + " = [";
    for (int v = 1; v <= 256; ++v) text.append(v > 1 ? ", " : "").append(std::to_string(v));
    text += "]\n";
  }
  // 256^8 = 2^64 sets: counted in 64 bits it would be 0. Before: memory grew until the machine ran out.
  CHECK_THAT(error_of(text), Catch::Contains("= more than 1000000 combinations, more than a study takes (1000000)"));
  // At the limit it is taken: 1000 x 1000.
  std::string limit = "cp = [", second = "acl-lin = [";
  for (int v = 1; v <= 1000; ++v) {
    limit.append(v > 1 ? ", " : "").append(std::to_string(v));  // GCC 12: -Wrestrict on "…" + string
    second.append(v > 1 ? ", " : "").append(std::to_string(v));
  }
  const std::string at_limit = limit + "]\n" + second + "]\n";
  CHECK_NOTHROW(parse_grid(at_limit, "g.toml"));
  CHECK_THAT(error_of(at_limit + "acl-ang = [1, 2]\n"),
             Catch::Contains("1000 (cp) x 1000 (acl-lin) x 2 (acl-ang) = more than 1000000 combinations"));
}

TEST_CASE("an invalid combination is a set with its error, not a refused grid") {
  // 0.05 h = 3 min of CP is shorter than the 5 min CP interval.
  const auto sets = parse_grid("cp = [0.05, 6.5]\n", "g.toml").sets();
  REQUIRE(sets.size() == 2);
  CHECK(sets[0].error.find("cp_interval_s") != std::string::npos);
  CHECK(sets[1].error.empty());
}

TEST_CASE("a grid survives its canonical form") {
  const Grid g = paper_grid();
  const Grid back = Grid::from_canonical(g.canonical(), "x");
  CHECK(back.canonical() == g.canonical());
  CHECK(back.sets().size() == 2191);
}

TEST_CASE("the plausibility limits are grid keys like every replay option, and a run's identity holds them only when "
          "they differ from the defaults") {
  const Grid g = parse_grid("plausible-lin = [500, \"inf\"]\n[fixed]\nplausible-temp = 120\n", "g.toml");
  const auto sets = g.sets();
  REQUIRE(sets.size() == 2);
  CHECK(sets[0].error.empty());
  CHECK(sets[0].parameters.plausible_linear_um == 500.0);
  CHECK(std::isinf(sets[1].parameters.plausible_linear_um));
  CHECK(sets[1].parameters.plausible_temperature_C == 120.0);
  CHECK(sets[1].parameters.plausible_angular_um_per_m == AlcParameters{}.plausible_angular_um_per_m);
  CHECK_THAT(error_of("plausible-ang = [-1]\n"), Catch::Matchers::Contains("plausible-ang"));
  // 0 is a value the option never takes: refused with the grid, before any run.
  CHECK_THAT(error_of("plausible-speed = [0]\n"), Catch::Matchers::Contains("key 'plausible-speed', value '0'") &&
                                                      Catch::Matchers::Contains("is not a number > 0 or inf"));
  // The identity (config_json) of a run with the defaults is that of a run before the limits existed.
  CHECK_FALSE(runtime::canonical_parameters(AlcParameters{}).contains("plausible"));
  const auto j = runtime::canonical_parameters(sets[1].parameters);
  CHECK(j.at("plausible").at("linear_um") == "inf");
  CHECK(j.at("plausible").at("temperature_C") == 120.0);
  CHECK_FALSE(j.at("plausible").contains("angular_um_per_m"));
}
