// The twin's touch probe: noise, chips and schedule drawn from the probe's own seeded stream.
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <vector>
#include <stdexcept>

#include "common/seeded_random.hpp"
#include "probing/twin_probe.hpp"

using alc::probing::ChipOrder;
using alc::probing::TwinProbe;
using alc::probing::TwinProbeOptions;

namespace {

// Two linear outputs (0.4 µm) and one angular (1.2 µm/m), no chips, no rounding.
TwinProbeOptions noise_only() {
  TwinProbeOptions o;
  o.noise_sigma = {0.4, 0.4, 1.2};
  o.resolution = 0.0;
  return o;
}

}  // namespace

TEST_CASE("twin probe: the same seed gives the same readings, another seed other readings") {
  TwinProbeOptions o = noise_only();
  o.chip_probability = 0.2;
  o.chip_min_um = 3.0;
  o.chip_max_um = 15.0;
  o.chip_random_sign = true;
  o.chip_directions = {{{{0, 1.0}, {2, 2.0}}}, {{{1, 1.0}}}};
  o.resolution = 0.001;
  const Eigen::Vector3d truth(1.0, -2.0, 3.0);
  TwinProbe a(o, 42), b(o, 42), c(o, 43);
  bool any_differs = false;
  for (int i = 0; i < 200; ++i) {
    const Eigen::VectorXd ra = a.measure(truth), rb = b.measure(truth), rc = c.measure(truth);
    CHECK(ra == rb);
    any_differs = any_differs || ra != rc;
  }
  CHECK(any_differs);
  CHECK(a.chips() == b.chips());
  // A probe built from a SeededRandom reads what the probe built from its seed reads.
  TwinProbe d(o, alc::common::SeededRandom(42)), e(o, 42);
  for (int i = 0; i < 20; ++i) CHECK(d.measure(truth) == e.measure(truth));
}

TEST_CASE("twin probe: the noise of each output has its own sigma, linear and angular, around the truth") {
  TwinProbe probe(noise_only(), 7);
  const Eigen::Vector3d truth(5.0, -1.0, 20.0);
  constexpr int kDraws = 20000;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero(), sum_sq = Eigen::Vector3d::Zero();
  for (int i = 0; i < kDraws; ++i) {
    const Eigen::Vector3d d = probe.measure(truth) - truth;
    sum += d;
    sum_sq += d.cwiseProduct(d);
  }
  const Eigen::Vector3d mean = sum / kDraws;
  const Eigen::Vector3d sigma = (sum_sq / kDraws - mean.cwiseProduct(mean)).cwiseSqrt();
  // Standard error of a sigma estimate from 20000 draws is sigma/200: 5 % is far outside chance.
  CHECK(sigma(0) == Approx(0.4).epsilon(0.05));
  CHECK(sigma(1) == Approx(0.4).epsilon(0.05));
  CHECK(sigma(2) == Approx(1.2).epsilon(0.05));
  for (int e = 0; e < 3; ++e) CHECK(std::abs(mean(e)) < 0.05);
  CHECK(probe.chips() == 0);
}

TEST_CASE("twin probe: chips come with their probability and size and move the outputs of their direction") {
  TwinProbeOptions o;
  o.noise_sigma = {0.0, 0.0, 0.0};
  o.chip_probability = 0.1;
  o.chip_min_um = 3.0;
  o.chip_max_um = 15.0;
  o.chip_random_sign = true;
  o.chip_directions = {{{{0, 1.0}, {2, 2.0}}}, {{{1, 1.0}}}};
  o.resolution = 0.0;
  for (const ChipOrder order : {ChipOrder::kAfterNoise, ChipOrder::kBeforeNoise}) {
    o.chip_order = order;
    TwinProbe probe(o, 11);
    const Eigen::Vector3d truth(1.0, 2.0, 3.0);
    constexpr int kDraws = 10000;
    int chipped = 0, negative = 0;
    for (int i = 0; i < kDraws; ++i) {
      const Eigen::Vector3d d = probe.measure(truth) - truth;
      if (d.isZero()) continue;
      ++chipped;
      if (d(1) == 0.0) {  // direction 0: output 0 by s, output 2 by 2 s
        CHECK(d(2) == Approx(2.0 * d(0)));
      } else {
        CHECK(d(0) == 0.0);
        CHECK(d(2) == 0.0);
      }
      const double s = d(1) == 0.0 ? d(0) : d(1);
      CHECK(std::abs(s) >= 3.0);
      CHECK(std::abs(s) < 15.0);
      if (s < 0.0) ++negative;
    }
    CHECK(probe.chips() == static_cast<std::size_t>(chipped));
    // 1000 expected, binomial sigma ~30.
    CHECK(chipped > 880);
    CHECK(chipped < 1120);
    CHECK(negative > chipped / 2 - 120);
    CHECK(negative < chipped / 2 + 120);
  }
}

TEST_CASE("twin probe: no chip without a chip probability, and readings are rounded to the resolution") {
  TwinProbeOptions o = noise_only();
  o.resolution = 0.01;
  TwinProbe probe(o, 3);
  for (int i = 0; i < 100; ++i) {
    const Eigen::VectorXd r = probe.measure(Eigen::Vector3d(0.123456, 0.0, -7.0));
    for (Eigen::Index e = 0; e < r.size(); ++e) CHECK(std::abs(r(e) * 100.0 - std::round(r(e) * 100.0)) < 1e-9);
  }
  CHECK(probe.chips() == 0);
}

TEST_CASE("twin probe: a run is read at the scheduled times only, segment by segment, with missed cycles") {
  TwinProbeOptions o = noise_only();
  o.schedule = {{600.0, 300.0}, {std::numeric_limits<double>::infinity(), 900.0}};
  TwinProbe probe(o, 5);
  CHECK(probe.due(0.0));
  CHECK(probe.due(300.0));
  CHECK(probe.due(600.0));
  CHECK_FALSE(probe.due(60.0));
  CHECK_FALSE(probe.due(1200.0));  // past 600 s: every 900 s
  CHECK(probe.due(1800.0));

  std::vector<double> t;
  for (int k = 0; k <= 60; ++k) t.push_back(60.0 * k);  // one hour at 1 min
  const Eigen::MatrixXd truth = Eigen::MatrixXd::Zero(61, 3);
  const Eigen::MatrixXd read = TwinProbe(o, 5).probe_run(t, truth);
  for (int k = 0; k <= 60; ++k) {
    const bool expected = k == 0 || k == 5 || k == 10 || k == 15 || k == 30 || k == 45 || k == 60;
    CHECK(read.row(k).allFinite() == expected);
    if (!expected) CHECK(read.row(k).array().isNaN().all());
  }

  o.miss_probability = 0.5;
  o.schedule = {{std::numeric_limits<double>::infinity(), 60.0}};
  const Eigen::MatrixXd sparse = TwinProbe(o, 9).probe_run(t, truth);
  int read_rows = 0;
  for (int k = 0; k <= 60; ++k) read_rows += sparse.row(k).allFinite() ? 1 : 0;
  CHECK(read_rows > 10);
  CHECK(read_rows < 51);
}

TEST_CASE("twin probe: inconsistent options and a wrong number of true errors are refused") {
  TwinProbeOptions o = noise_only();
  o.chip_probability = 0.1;  // but no directions
  CHECK_THROWS_WITH(TwinProbe(o, 1), Catch::Contains("chip_directions"));
  o = noise_only();
  o.chip_directions = {{{{3, 1.0}}}};  // output 3 of 3
  CHECK_THROWS_WITH(TwinProbe(o, 1), Catch::Contains("out of range"));
  o = noise_only();
  o.noise_sigma.clear();
  CHECK_THROWS_WITH(TwinProbe(o, 1), Catch::Contains("noise_sigma"));
  TwinProbe probe(noise_only(), 1);
  CHECK_THROWS_AS(probe.measure(Eigen::Vector2d(1.0, 2.0)), std::invalid_argument);
}
