// The load cases' probe readings come from probing::TwinProbe applied to the twin's truth, so a
// simulated machine can be probed again (another seed, other noise) without simulating it again.
#include <catch2/catch.hpp>
#include <cmath>

#include "probing/twin_probe.hpp"
#include "scenarios/load_cases.hpp"

namespace sc = alc::scenarios;

namespace {

// Every row the case measured holds exactly what the case's probe reads from the truth, in order.
// Returns the number of chips the probe drew.
std::size_t check_measured_rows_are_the_probe_on_the_truth(const sc::SimulatedCase& run) {
  const sc::Scenario& s = run.scenario;
  REQUIRE(run.truth.errors.rows() == s.outputs.rows());
  REQUIRE(run.truth.errors.cols() == s.outputs.cols());
  REQUIRE(run.truth.errors.allFinite());  // the truth has every error at every sample
  auto probe = sc::make_probe(run, run.probe_seed);
  int measured = 0;
  for (Eigen::Index r = 0; r < s.outputs.rows(); ++r) {
    const double t = s.time_s[static_cast<std::size_t>(r)];
    if (!probe.due(t)) {
      REQUIRE(s.outputs.row(r).array().isNaN().all());
      continue;
    }
    const auto reading = probe.cycle(run.truth.errors.row(r).transpose());
    if (!reading) {
      REQUIRE(s.outputs.row(r).array().isNaN().all());
      continue;
    }
    ++measured;
    REQUIRE(s.outputs.row(r).transpose() == *reading);
  }
  CHECK(measured > 100);
  return probe.chips();
}

Eigen::MatrixXi nan_mask(const Eigen::MatrixXd& m) { return m.array().isNaN().cast<int>().matrix(); }
Eigen::MatrixXd nan_as_zero(const Eigen::MatrixXd& m) { return m.array().isNaN().select(0.0, m.array()).matrix(); }

}  // namespace

TEST_CASE("twin probe in the load cases: case A's readings are its probe applied to its truth", "[twin_probe]") {
  const auto run = sc::simulate_case("A");
  CHECK(run.probe_seed != run.seed);
  CHECK(run.probe.noise_sigma == std::vector<double>{0.4, 0.4, 0.4, 0.4, 1.2, 1.2, 1.2});
  CHECK(check_measured_rows_are_the_probe_on_the_truth(run) >= 1);  // chips included
}

TEST_CASE("twin probe in the load cases: S16's sparse readings with missed cycles are its probe on its truth",
          "[twin_probe]") {
  std::size_t chips = 0;
  for (const std::uint64_t seed : {5, 116, 1, 2, 3}) {
    const auto run = sc::simulate_case("S16", seed);
    CHECK(run.probe.miss_probability > 0.0);
    chips += check_measured_rows_are_the_probe_on_the_truth(run);
  }
  CHECK(chips >= 1);
}

TEST_CASE("twin probe in the load cases: probing again with another seed changes only the readings", "[twin_probe]") {
  const auto run = sc::simulate_case("B");
  // The same probe seed gives the case's own readings back, bit for bit.
  const sc::Scenario same = sc::reprobe(run, run.probe_seed);
  CHECK(nan_mask(same.outputs) == nan_mask(run.scenario.outputs));
  CHECK(nan_as_zero(same.outputs) == nan_as_zero(run.scenario.outputs));

  const sc::Scenario other = sc::reprobe(run, 12345);
  CHECK(other.time_s == run.scenario.time_s);
  CHECK(other.input_names == run.scenario.input_names);
  CHECK(other.output_names == run.scenario.output_names);
  CHECK(other.inputs == run.scenario.inputs);
  // Same schedule (every 5 min, none missed), other noise.
  REQUIRE(nan_mask(other.outputs) == nan_mask(run.scenario.outputs));
  int differing = 0, cells = 0;
  double sum2 = 0.0;
  for (Eigen::Index r = 0; r < other.outputs.rows(); ++r)
    for (int e = 0; e < 4; ++e) {
      if (std::isnan(other.outputs(r, e))) continue;
      ++cells;
      differing += other.outputs(r, e) != run.scenario.outputs(r, e) ? 1 : 0;
      const double d = other.outputs(r, e) - run.truth.errors(r, e);
      if (std::abs(d) < 2.5) sum2 += d * d;
    }
  CHECK(differing > cells * 9 / 10);
  CHECK(std::sqrt(sum2 / cells) == Approx(0.4).epsilon(0.1));
  check_measured_rows_are_the_probe_on_the_truth(run);  // the run itself is untouched

  // Another probe on the same machine: a noiseless probe reads the truth (rounded) at its times.
  sc::SimulatedCase exact = run;
  exact.probe.noise_sigma.assign(exact.probe.noise_sigma.size(), 0.0);
  exact.probe.chip_probability = 0.0;
  const sc::Scenario clean = sc::reprobe(exact, 1);
  for (Eigen::Index r = 0; r < clean.outputs.rows(); ++r)
    for (Eigen::Index e = 0; e < clean.outputs.cols(); ++e)
      if (!std::isnan(clean.outputs(r, e))) REQUIRE(std::abs(clean.outputs(r, e) - run.truth.errors(r, e)) <= 0.0005);
}

TEST_CASE("twin probe in the load cases: the probe options follow the case's ProbeParams", "[twin_probe]") {
  sc::ProbeParams p;
  p.noise_linear_um = 1.0;
  p.noise_angular_um_per_m = 3.0;
  p.interval_s = 600.0;
  p.sphere_lever_m = 0.25;
  const auto o = sc::twin_probe_options(p);
  CHECK(o.noise_sigma == std::vector<double>{1.0, 1.0, 1.0, 1.0, 3.0, 3.0, 3.0});
  REQUIRE(o.schedule.size() == 1);
  CHECK(o.schedule[0].interval_s == 600.0);
  REQUIRE(o.chip_directions.size() == 3);
  CHECK(o.chip_directions[0].gains.back() == std::pair<int, double>{5, 4.0});   // X tilts about Y
  CHECK(o.chip_directions[1].gains.back() == std::pair<int, double>{4, -4.0});  // Y tilts about X
}
