// SampleRows (the history's growing matrix), ModelPredictor (state save/restore, sampling rates, bounds) and IdentificationOptions::validate().
#include <catch2/catch.hpp>
#include <cmath>
#include <random>

#include "alc/thermal_model.hpp"
#include "synthetic_system.hpp"

using namespace alc;
using Catch::Matchers::Contains;
using Catch::Matchers::WithinAbs;

TEST_CASE("SampleRows: appended rows, dropped rows and copies hold exactly the rows in use") {
  const auto value = [](Eigen::Index r, Eigen::Index c) { return 1000.0 * static_cast<double>(r) + static_cast<double>(c); };
  SampleRows rows;
  CHECK(rows.rows() == 0);
  for (Eigen::Index r = 0; r < 300; ++r) rows.append(Eigen::Vector3d(value(r, 0), value(r, 1), value(r, 2)));
  REQUIRE(rows.rows() == 300);
  REQUIRE(rows.cols() == 3);
  InputMatrix expected(300, 3);
  for (Eigen::Index r = 0; r < 300; ++r)
    for (Eigen::Index c = 0; c < 3; ++c) expected(r, c) = value(r, c);
  CHECK(rows.matrix() == expected);
  CHECK(rows.col(2).size() == 300);  // a column is as long as the rows in use, not the storage
  CHECK(rows.bottomRows(1) == expected.bottomRows(1));

  SampleRows copy = rows;  // a copy holds the rows in use and is independent of the original
  copy(0, 0) = -1.0;
  CHECK(rows(0, 0) == 0.0);
  CHECK(copy.rows() == 300);

  SampleRows moved = std::move(copy);  // a moved-from buffer is empty and usable again
  CHECK(moved.rows() == 300);
  CHECK(copy.rows() == 0);
  copy.append(Eigen::Vector3d(1.0, 2.0, 3.0));
  CHECK(copy.matrix() == Eigen::RowVector3d(1.0, 2.0, 3.0));
  moved = std::move(copy);
  CHECK(moved.rows() == 1);
  CHECK(copy.rows() == 0);

  rows.drop_front(0);
  CHECK(rows.matrix() == expected);
  rows.drop_front(70);  // the oldest rows go, the rest move up in order
  REQUIRE(rows.rows() == 230);
  CHECK(rows.matrix() == expected.bottomRows(230));
  rows.append(Eigen::Vector3d(7.0, 8.0, 9.0));
  CHECK(rows.rows() == 231);
  CHECK(rows.row(230) == Eigen::RowVector3d(7.0, 8.0, 9.0));
  CHECK(rows.row(229) == expected.row(299));

  rows = InputMatrix(expected.topRows(5));  // a matrix given whole
  CHECK(rows.rows() == 5);
  CHECK(rows.matrix() == expected.topRows(5));
  rows.append(Eigen::Vector3d(1.0, 2.0, 3.0));
  CHECK(rows.row(5) == Eigen::RowVector3d(1.0, 2.0, 3.0));
  CHECK(rows.topRows(5) == expected.topRows(5));
}

TEST_CASE("ModelPredictor: save/restore continues bit for bit") {
  std::mt19937_64 rng(42);
  const InputHistory h = test::make_history(rng, 86400.0, 15.0);
  const ThermalModel model = test::truth_model(
      h, {test::output_model("E_X0C", {0, 1}, {900.0, 20000.0}, {0.3, 2.0, -1.0, 0.001, 0.004}),
          test::output_model("E_A0C", {2}, {3000.0}, {-1.0, 6.0})});
  ModelPredictor a(model);
  const Eigen::Index half = h.inputs.rows() / 2;
  for (Eigen::Index k = 0; k < half; ++k) a.step(h.time_s[static_cast<std::size_t>(k)], h.inputs.row(k).transpose());
  const Eigen::VectorXd saved = a.state();
  ModelPredictor b(model);
  b.set_state(saved);
  for (Eigen::Index k = half; k < h.inputs.rows(); ++k) {
    const Eigen::VectorXd ya = a.step(h.time_s[static_cast<std::size_t>(k)], h.inputs.row(k).transpose());
    const Eigen::VectorXd yb = b.step(h.time_s[static_cast<std::size_t>(k)], h.inputs.row(k).transpose());
    REQUIRE(ya.size() == 2);
    REQUIRE((ya.array() == yb.array()).all());
  }
  REQUIRE(a.state() == b.state());
  REQUIRE_THROWS_AS(b.set_state(Eigen::VectorXd::Zero(3)), std::invalid_argument);
}

TEST_CASE("ModelPredictor: a first-order lag reaches 1 - exp(-t/tau) of a step, at any sample spacing") {
  constexpr double kTol = 1e-12;  // [µm] exact discretisation
  ThermalModel m;
  m.input_names = {"T"};
  m.input_reference = Eigen::VectorXd::Zero(1);
  m.outputs.push_back(test::output_model("E_X0C", {0}, {1200.0}, {0.0, 2.0}));
  for (const double dt : {15.0, 60.0, 300.0}) {
    ModelPredictor p(m);
    p.step(0.0, Eigen::VectorXd::Zero(1));
    Eigen::VectorXd y;
    for (double t = dt; t <= 3600.0 + 1e-9; t += dt) y = p.step(t, Eigen::VectorXd::Ones(1));
    // the unit step is held from t = dt on (zero-order hold of the previous sample)
    REQUIRE_THAT(y(0), WithinAbs(2.0 * (1.0 - std::exp(-(3600.0 - dt) / 1200.0)), kTol));
  }
}

TEST_CASE("ModelPredictor: non-finite inputs are held and predictions are clamped to the output limit") {
  ThermalModel m;
  m.input_names = {"T"};
  m.input_reference = Eigen::VectorXd::Zero(1);
  m.outputs.push_back(test::output_model("E_X0C", {0}, {600.0}, {0.0, 100.0}));
  m.outputs[0].output_limit = 50.0;
  ModelPredictor p(m);
  p.step(0.0, Eigen::VectorXd::Zero(1));
  const Eigen::VectorXd nan = Eigen::VectorXd::Constant(1, std::nan(""));
  Eigen::VectorXd y = p.step(60.0, nan);
  REQUIRE(std::isfinite(y(0)));
  for (double t = 120.0; t < 20000.0; t += 60.0) y = p.step(t, Eigen::VectorXd::Ones(1));
  REQUIRE(y(0) == 50.0);
  REQUIRE(ModelPredictor().step(0.0, Eigen::VectorXd::Zero(1)).size() == 0);
}

TEST_CASE("IdentificationOptions::validate names the field and the value") {
  CHECK(IdentificationOptions{}.validate().empty());
  IdentificationOptions o;
  o.base_step_s = -1.0;
  CHECK_THAT(o.validate(), Contains("base_step_s") && Contains("-1"));
  o = {};
  o.max_order = 0;
  CHECK_THAT(o.validate(), Contains("max_order = 0"));
  o = {};
  o.ridge = std::nan("");
  CHECK_THAT(o.validate(), Contains("ridge = nan"));
  o = {};
  o.tau_max_s = 10.0;
  CHECK_THAT(o.validate(), Contains("tau_max_s = 10"));
  o = {};
  o.forgetting_half_life_s = 0.0;
  CHECK_THAT(o.validate(), Contains("forgetting_half_life_s = 0"));
  o = {};
  o.min_measurements = 1;
  CHECK_THAT(o.validate(), Contains("min_measurements = 1"));
  o = {};
  o.robust_scale_ang = -3.0;
  CHECK_THAT(o.validate(), Contains("robust_scale_ang = -3"));
  o = {};
  o.pole_grid_size = 2;
  CHECK_THAT(o.validate(), Contains("pole_grid_size = 2"));
}
