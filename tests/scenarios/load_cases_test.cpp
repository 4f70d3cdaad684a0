// Load cases A–D and S16: what the sensors and the probe give, determinism, and magnitudes.
#include <catch2/catch.hpp>
#include <algorithm>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>

#include "scenarios/load_cases.hpp"
#include "scenarios/scenario_csv.hpp"
#include "scenarios/scenario_figures.hpp"

namespace sc = alc::scenarios;
using Catch::Matchers::WithinAbs;

namespace {

constexpr double kQuantisationTolerance = 1e-9;  // [-] of one resolution step

std::string file_bytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::string csv_text(const sc::Scenario& s) {
  std::ostringstream out;
  sc::write_scenario_csv(out, s);
  return out.str();
}

bool is_multiple_of(double value, double resolution) {
  const double steps = value / resolution;
  return std::abs(steps - std::round(steps)) < kQuantisationTolerance * 1e3;
}

// Standard deviation of measured minus true errors over columns [first, last), without outliers.
double noise_sigma(const sc::SimulatedCase& run, int first, int last, double outlier_threshold) {
  double sum = 0.0, sum2 = 0.0;
  int n = 0;
  for (Eigen::Index r = 0; r < run.scenario.outputs.rows(); ++r)
    for (int e = first; e < last; ++e) {
      const double m = run.scenario.outputs(r, e);
      if (std::isnan(m)) continue;
      const double d = m - run.truth.errors(r, e);
      if (std::abs(d) > outlier_threshold) continue;
      sum += d;
      sum2 += d * d;
      ++n;
    }
  const double mean = sum / n;
  return std::sqrt(sum2 / n - mean * mean);
}

}  // namespace

TEST_CASE("load cases: A-D and S16 are listed with their durations and sampling") {
  REQUIRE(sc::load_cases().size() == 4);
  const char* names[] = {"A", "B", "C", "D"};
  for (std::size_t i = 0; i < 4; ++i) {
    const auto& c = sc::load_cases()[i];
    CHECK(c.name == names[i]);
    CHECK(c.duration_h >= 192.0);
    CHECK(c.step_s == 60.0);
    CHECK(!c.description.empty());
  }
  REQUIRE(sc::recording_cases().size() == 1);
  CHECK(sc::recording_cases()[0].name == "S16");
  CHECK(sc::find_case("S16").has_value());
  CHECK_FALSE(sc::find_case("E").has_value());
  CHECK_THROWS_WITH(sc::simulate_case("E"), Catch::Matchers::Contains("unknown case 'E'"));
  CHECK_THROWS_WITH(sc::load_case_spec("S16"), Catch::Matchers::Contains("no load case 'S16'"));
}

TEST_CASE("load cases: sensors only, with the case's column names, quantised to 0.01 K") {
  for (const auto& info : sc::load_cases()) {
    const auto run = sc::simulate_case(info.name);
    const sc::Scenario& s = run.scenario;
    INFO("case " << info.name);
    const bool fluid = info.name == "D";
    const std::vector<std::string> expected =
        fluid ? std::vector<std::string>{"T_ENV", "T_CF", "T_COOL", "n_C", "CF_on"}
              : std::vector<std::string>{"T_ENV", "T_WS", "T_COOL", "n_C"};
    CHECK(s.input_names == expected);
    CHECK(s.output_names == std::vector<std::string>{"E_X0C", "E_Y0C", "E_Z0T", "E_R0T", "E_A0C", "E_B0C", "E_C0C"});
    REQUIRE(s.samples() == 192 * 60 + 1);
    REQUIRE_THAT(s.time_s.back(), WithinAbs(192.0 * 3600.0, 0.0));
    for (Eigen::Index r = 0; r < s.inputs.rows(); r += 7)
      for (int j : {0, 1, 2}) REQUIRE(is_multiple_of(s.inputs(r, j), 0.01));
    CHECK(s.inputs.col(3).maxCoeff() > 1000.0);  // the C axis runs
    CHECK(s.inputs.col(3).minCoeff() == 0.0);    // and stands
    if (fluid) {
      CHECK(s.inputs.col(4).maxCoeff() == 1.0);
      CHECK(s.inputs.col(4).minCoeff() == 0.0);
    }
    // The coolant sensor: the coolant node plus noise of about 0.02 K.
    double sum2 = 0.0;
    for (Eigen::Index r = 0; r < s.inputs.rows(); ++r) {
      const double d = s.inputs(r, 2) - run.truth.nodes(r, sc::kCoolant);
      sum2 += d * d;
    }
    const double sigma = std::sqrt(sum2 / static_cast<double>(s.inputs.rows()));
    CHECK(sigma > 0.015);
    CHECK(sigma < 0.025);
  }
}

TEST_CASE("load cases: all seven errors are probed every 5 minutes with the stated noise and rare outliers") {
  for (const auto& info : sc::load_cases()) {
    const auto run = sc::simulate_case(info.name);
    const sc::Scenario& s = run.scenario;
    INFO("case " << info.name);
    int cycles = 0, outliers = 0;
    for (Eigen::Index r = 0; r < s.outputs.rows(); ++r) {
      const bool due = std::fmod(s.time_s[static_cast<std::size_t>(r)], 300.0) == 0.0;
      for (int e = 0; e < 7; ++e) REQUIRE(std::isnan(s.outputs(r, e)) != due);
      if (!due) continue;
      ++cycles;
      bool outlier = false;
      for (int e = 0; e < 4; ++e) {
        REQUIRE(is_multiple_of(s.outputs(r, e), 0.001));
        outlier = outlier || std::abs(s.outputs(r, e) - run.truth.errors(r, e)) > 2.5;
      }
      outliers += outlier ? 1 : 0;
    }
    CHECK(cycles == 192 * 12 + 1);
    CHECK(outliers >= 1);
    CHECK(outliers <= cycles / 50);
    const double linear = noise_sigma(run, 0, 4, 2.5);
    const double angular = noise_sigma(run, 4, 7, 6.0);
    CHECK(linear > 0.3);
    CHECK(linear < 0.5);
    CHECK(angular > 1.0);
    CHECK(angular < 1.5);
  }
}

TEST_CASE("load cases: magnitudes like a real machine") {
  // Uncompensated linear errors: P99 >= 10 µm, peaks 15-40 µm; angular peaks 20-80 µm/m.
  for (const auto& info : sc::load_cases()) {
    const auto figures = sc::scenario_figures(sc::simulate_case(info.name).scenario);
    CHECK(figures.duration_h >= 192.0);
    for (const auto& e : figures.errors) {
      INFO("case " << info.name << " " << e.name << ": peak " << e.peak << ", P99 " << e.p99);
      if (e.angular) {
        CHECK(e.peak >= 20.0);
        CHECK(e.peak <= 80.0);
      } else {
        CHECK(e.p99 >= 10.0);
        CHECK(e.peak >= 15.0);
        CHECK(e.peak <= 40.0);
      }
    }
  }
}

TEST_CASE("load cases: the same case and seed give a byte-identical CSV") {
  // One directory per test process: a release and a sanitizer run of this test may run at once.
  const auto dir = std::filesystem::temp_directory_path() / ("alc_twin_determinism_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  for (const std::string name : {"A", "B", "C", "D", "S16"}) {
    INFO("case " << name);
    sc::write_scenario_csv(dir / "first.csv", sc::simulate_case(name).scenario);
    sc::write_scenario_csv(dir / "second.csv", sc::simulate_case(name).scenario);
    const std::string first = file_bytes(dir / "first.csv");
    REQUIRE(first.size() > 100000);
    CHECK(first == file_bytes(dir / "second.csv"));
    // A given seed is used as given: the default seed reproduces the default file...
    const auto info = sc::find_case(name);
    CHECK(csv_text(sc::simulate_case(name, info->default_seed).scenario) == first);
    // ...and another seed gives another case.
    CHECK(csv_text(sc::simulate_case(name, 7).scenario) != first);
  }
  std::filesystem::remove_all(dir);
}

TEST_CASE("load cases: write then read gives the same numbers") {
  const auto run = sc::simulate_case("D");
  std::istringstream in(csv_text(run.scenario));
  const sc::Scenario back = sc::parse_scenario_csv(in, "D.csv");
  CHECK(back.input_names == run.scenario.input_names);
  CHECK(back.output_names == run.scenario.output_names);
  CHECK(back.time_s == run.scenario.time_s);
  CHECK(back.inputs == run.scenario.inputs);
  for (Eigen::Index r = 0; r < back.outputs.rows(); ++r)
    for (Eigen::Index c = 0; c < back.outputs.cols(); ++c) {
      const double a = back.outputs(r, c), b = run.scenario.outputs(r, c);
      REQUIRE(((std::isnan(a) && std::isnan(b)) || a == b));
    }
}

TEST_CASE("load cases: production patterns differ as described") {
  const auto hours_running = [](const sc::SimulatedCase& run, auto&& when) {
    double h = 0.0;
    for (std::size_t k = 0; k < run.profile.loads.size(); ++k)
      if (run.profile.loads[k].speed_rpm > 0.0 && when(run.profile.time_s[k])) h += run.info.step_s / 3600.0;
    return h;
  };
  const double start_s = sc::load_case_spec("B").start_h * 3600.0;  // after Monday 00:00
  const auto at_night = [&](double t) { return std::fmod((start_s + t) / 3600.0, 24.0) < 5.0; };
  const auto on_sunday = [&](double t) { return start_s + t >= 6 * 86400.0 && start_s + t < 7 * 86400.0; };
  const auto a = sc::simulate_case("A"), b = sc::simulate_case("B"), c = sc::simulate_case("C");
  CHECK(hours_running(a, at_night) > 20.0);         // A runs round the clock
  CHECK(hours_running(b, at_night) == 0.0);         // B stops at night
  CHECK(hours_running(b, on_sunday) == 0.0);        // and over the weekend
  const auto speed_changes = [](const sc::SimulatedCase& run) {
    int n = 0;
    for (std::size_t k = 1; k < run.profile.loads.size(); ++k)
      n += run.profile.loads[k].speed_rpm != run.profile.loads[k - 1].speed_rpm ? 1 : 0;
    return n;
  };
  CHECK(speed_changes(c) > 3 * speed_changes(a));   // C: fast-changing small batches
  // Hall-door events: the hall air drops by more than 1 K within 10 minutes now and then.
  int drops = 0;
  for (std::size_t k = 10; k < a.profile.loads.size(); ++k)
    drops += a.profile.loads[k - 10].ambient_C - a.profile.loads[k].ambient_C > 1.0 ? 1 : 0;
  CHECK(drops > 0);
}

TEST_CASE("S16: a recording-like spindle run with 16 temperatures, a speed and 5 sparse linear errors") {
  const auto run = sc::simulate_case("S16");
  const sc::Scenario& s = run.scenario;
  REQUIRE(s.input_names.size() == 17);
  int temperatures = 0;
  for (const auto& n : s.input_names) temperatures += n.rfind("T_", 0) == 0 ? 1 : 0;
  CHECK(temperatures == 16);
  CHECK(s.input_names.back() == "n_S");
  CHECK(s.output_names == std::vector<std::string>{"E_X1", "E_Y1", "E_Z1", "E_X2", "E_Z2"});
  CHECK(s.time_s[1] - s.time_s[0] == 15.0);
  CHECK(s.time_s.back() >= 46.0 * 3600.0);
  std::vector<double> probe_times;
  for (Eigen::Index r = 0; r < s.outputs.rows(); ++r)
    if (!std::isnan(s.outputs(r, 0))) probe_times.push_back(s.time_s[static_cast<std::size_t>(r)]);
  CHECK(probe_times.size() > 80);
  CHECK(probe_times.size() < 200);
  CHECK(probe_times[1] - probe_times[0] <= 600.0);              // dense at first
  CHECK(probe_times.back() - probe_times[probe_times.size() - 2] >= 1800.0);  // sparse later
  const auto figures = sc::scenario_figures(s);
  for (const auto& e : figures.errors) {
    INFO(e.name << ": peak " << e.peak);
    CHECK(!e.angular);
    CHECK(e.peak > 5.0);
    CHECK(e.peak < 100.0);
  }
}

TEST_CASE("load cases: an 8-day case has 11521 samples at 1 min") {
  // How fast a case simulates is measured by `alc bench` (column "sim"), not asserted here.
  const auto run = sc::simulate_case("A");
  CHECK(run.scenario.samples() == 11521);
  CHECK(run.profile.loads.size() == 11521);
}

TEST_CASE("load cases: a slow drift that no fixed model explains rides on every error") {
  const auto run = sc::simulate_case("A");
  const Eigen::MatrixXd& drift = run.profile.drift;
  REQUIRE(drift.rows() == static_cast<Eigen::Index>(run.profile.time_s.size()));
  REQUIRE(drift.cols() == 7);
  const auto spec = sc::load_case_spec("A");
  for (Eigen::Index e = 0; e < drift.cols(); ++e) {
    INFO("error " << run.truth.error_names[static_cast<std::size_t>(e)]);
    const bool angular = e >= 4;
    const double sigma = angular ? spec.drift.sigma_angular_um_per_m : spec.drift.sigma_linear_um;
    const Eigen::ArrayXd d = drift.col(e).array();
    const double sd = std::sqrt((d - d.mean()).square().mean());
    CHECK(sd > 0.2 * sigma);  // present, of the configured size (an OU process over 4 time constants)
    CHECK(sd < 3.0 * sigma);
    // Slow: neighbouring minutes differ by a small part of the swing.
    const double step = (d.tail(d.size() - 1) - d.head(d.size() - 1)).abs().maxCoeff();
    CHECK(step < 0.1 * (d.maxCoeff() - d.minCoeff()));
  }
}

TEST_CASE("load cases: D switches the cutting fluid on and off for intervals of varying length") {
  const auto run = sc::simulate_case("D");
  std::vector<double> on_min, off_min;
  double since = run.profile.time_s.front();
  for (std::size_t k = 1; k < run.profile.loads.size(); ++k) {
    if (run.profile.loads[k].fluid_on == run.profile.loads[k - 1].fluid_on) continue;
    const double length_min = (run.profile.time_s[k] - since) / 60.0;
    (run.profile.loads[k - 1].fluid_on ? on_min : off_min).push_back(length_min);
    since = run.profile.time_s[k];
  }
  INFO(on_min.size() << " on intervals, " << off_min.size() << " off intervals");
  REQUIRE(on_min.size() >= 5);
  REQUIRE(off_min.size() >= 5);
  const auto spread = [](const std::vector<double>& v) {
    return *std::max_element(v.begin(), v.end()) / *std::min_element(v.begin(), v.end());
  };
  CHECK(spread(on_min) > 3.0);  // from minutes to hours, not a fixed rhythm
  CHECK(spread(off_min) > 3.0);
  for (const char* other : {"A", "B", "C"}) {
    const auto o = sc::simulate_case(other);
    bool any_on = false;
    for (const auto& l : o.profile.loads) any_on = any_on || l.fluid_on;
    CHECK_FALSE(any_on);
  }
}

TEST_CASE("load cases: the hall air follows a daily cycle, warmest in the afternoon") {
  const auto run = sc::simulate_case("B");
  const double start_h = sc::load_case_spec("B").start_h;
  // Mean hall air per hour of the day over the 8 days: the afternoon is warmer than the early morning.
  std::vector<double> sum(24, 0.0), n(24, 0.0);
  for (std::size_t k = 0; k < run.profile.loads.size(); ++k) {
    const auto hour = static_cast<std::size_t>(std::fmod(start_h + run.profile.time_s[k] / 3600.0, 24.0));
    sum[hour] += run.profile.loads[k].ambient_C;
    n[hour] += 1.0;
  }
  const double afternoon = sum[15] / n[15];
  const double early = sum[4] / n[4];
  INFO("15:00 " << afternoon << " °C, 04:00 " << early << " °C");
  CHECK(afternoon - early > 1.0);  // the configured half swing is 1.5 K; weather and doors blur it
}
