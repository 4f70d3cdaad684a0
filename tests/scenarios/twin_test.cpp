// The thermal twin: physics of the network and of the output map, against hand-derived values.
#include <catch2/catch.hpp>
#include <cmath>
#include <vector>

#include "scenarios/load_cases.hpp"
#include "scenarios/thermal_network.hpp"
#include "scenarios/thermal_twin.hpp"

using alc::scenarios::discretise;
using alc::scenarios::ErrorVector;
using alc::scenarios::ThermalLoad;
using alc::scenarios::ThermalNetwork;
using alc::scenarios::ThermalTwin;
using alc::scenarios::ThermalTwinParams;
using alc::scenarios::TwinTruth;
using Catch::Matchers::WithinAbs;
using Catch::Matchers::WithinRel;

namespace {

constexpr double kTemperatureTolerance_K = 1e-6;  // [K] exact discretisation vs closed form
constexpr double kErrorTolerance_um = 1e-9;       // [µm] arithmetic only
constexpr double kHour = 3600.0;

std::vector<ThermalLoad> constant_loads(const ThermalLoad& load, double hours, double step_s = 60.0) {
  return std::vector<ThermalLoad>(static_cast<std::size_t>(hours * kHour / step_s), load);
}

// A C-axis warm-up: 4 h at 1200 rpm, then 4 h standing, in a hall at the reference temperature.
std::vector<ThermalLoad> warm_up_loads(double ambient_C) {
  std::vector<ThermalLoad> loads = constant_loads({ambient_C, 1200.0, false}, 4.0);
  const auto cool = constant_loads({ambient_C, 0.0, false}, 4.0);
  loads.insert(loads.end(), cool.begin(), cool.end());
  return loads;
}

}  // namespace

TEST_CASE("thermal network: the exact discretisation of one node matches the closed form") {
  // C dT/dt = G (Ta - T) + P  =>  T(t) = T_inf + (T0 - T_inf) exp(-t G / C), T_inf = Ta + P / G.
  constexpr double c = 2.0e5, g = 40.0, ambient = 21.0, power = 100.0, t0 = 18.0, step = 60.0;
  ThermalNetwork net({"mass"}, {c}, 2);
  net.conduct_to_input(0, 0, g);
  net.heat_from_input(0, 1);
  const auto d = discretise(net, step);
  Eigen::VectorXd x(1), u(2);
  x << t0;
  u << ambient, power;
  const double t_inf = ambient + power / g;
  for (int k = 1; k <= 600; ++k) {
    x = d.next(x, u);
    if (k % 100 == 0) {
      const double expected = t_inf + (t0 - t_inf) * std::exp(-k * step * g / c);
      REQUIRE_THAT(x(0), WithinAbs(expected, kTemperatureTolerance_K));
    }
  }
  REQUIRE_THAT(net.steady_state(u)(0), WithinAbs(t_inf, kTemperatureTolerance_K));
  REQUIRE_THAT(net.time_constants_s()(0), WithinRel(c / g, 1e-12));
}

TEST_CASE("thermal network: a one-way drive pulls its node but is not felt back") {
  ThermalNetwork net({"follower", "leader"}, {1.0e5, 1.0e5}, 1);
  net.conduct_to_input(1, 0, 50.0);
  net.drive(0, 1, 50.0);
  CHECK(net.a()(1, 0) == 0.0);
  CHECK(net.a()(0, 1) > 0.0);
}

TEST_CASE("twin: the C-axis network has at least five coupled nodes and time constants from ~20 min to >10 h") {
  const ThermalTwin twin;
  REQUIRE(twin.network(false).nodes() >= 5);
  for (const bool fluid : {false, true}) {
    const Eigen::VectorXd tau = twin.network(fluid).time_constants_s();
    INFO("fluid " << fluid << ": shortest " << tau.minCoeff() / 60.0 << " min, longest " << tau.maxCoeff() / kHour << " h");
    CHECK(tau.minCoeff() > 5.0 * 60.0);
    CHECK(tau.minCoeff() < 30.0 * 60.0);
    CHECK(tau.maxCoeff() > 10.0 * kHour);
    CHECK(tau.maxCoeff() < 40.0 * kHour);
  }
}

TEST_CASE("twin: constant inputs settle to the steady state") {
  const ThermalTwin twin;
  for (const bool fluid : {false, true}) {
    const ThermalLoad load{23.0, 900.0, fluid};
    const Eigen::VectorXd start = Eigen::VectorXd::Constant(alc::scenarios::kTwinNodes, 19.0);
    const TwinTruth truth = twin.simulate(start, constant_loads(load, 400.0));
    const Eigen::VectorXd last = truth.nodes.bottomRows(1).transpose();
    const Eigen::VectorXd expected = twin.steady_state(load);
    for (Eigen::Index i = 0; i < last.size(); ++i) {
      INFO("node " << truth.node_names[static_cast<std::size_t>(i)] << " fluid " << fluid);
      REQUIRE_THAT(last(i), WithinAbs(expected(i), kTemperatureTolerance_K));
    }
    // Heat goes into the bearing: it is the warmest structural node.
    CHECK(expected(alc::scenarios::kBearing) > expected(alc::scenarios::kTable));
    // And the steady state is a fixed point of the discrete step.
    const Eigen::VectorXd again = twin.step(expected, load);
    for (Eigen::Index i = 0; i < again.size(); ++i) REQUIRE_THAT(again(i), WithinAbs(expected(i), kTemperatureTolerance_K));
  }
}

TEST_CASE("twin: no heat and constant ambient give zero error") {
  ThermalTwinParams params;
  params.reference_temperature_C = 20.0;
  const ThermalTwin twin(params);
  const ThermalLoad rest{20.0, 0.0, false};
  const TwinTruth truth = twin.simulate(twin.steady_state(rest), constant_loads(rest, 48.0));
  REQUIRE_THAT(truth.nodes.maxCoeff(), WithinAbs(20.0, kTemperatureTolerance_K));
  REQUIRE_THAT(truth.nodes.minCoeff(), WithinAbs(20.0, kTemperatureTolerance_K));
  REQUIRE_THAT(truth.errors.cwiseAbs().maxCoeff(), WithinAbs(0.0, kErrorTolerance_um));
  // Any heat or a change of the hall air does make errors.
  const TwinTruth heated = twin.simulate(twin.steady_state(rest), warm_up_loads(20.0));
  CHECK(heated.errors.cwiseAbs().maxCoeff() > 5.0);
  const TwinTruth warmer_hall = twin.simulate(twin.steady_state(rest), constant_loads({22.0, 0.0, false}, 24.0));
  CHECK(warmer_hall.errors.cwiseAbs().maxCoeff() > 1.0);
}

TEST_CASE("twin: doubling a gain doubles the error it feeds") {
  using alc::scenarios::kCradle;
  constexpr int e_y0c = 1;
  ThermalTwinParams base;
  base.gains[e_y0c] = {};  // only the cradle feeds E_Y0C, linearly
  base.quadratic[e_y0c] = 0.0;
  base.gains[e_y0c][kCradle] = 2.4;
  ThermalTwinParams doubled = base;
  doubled.gains[e_y0c][kCradle] = 4.8;
  const ThermalTwin a(base), b(doubled);
  const ThermalLoad rest{20.0, 0.0, false};
  const TwinTruth ta = a.simulate(a.steady_state(rest), warm_up_loads(20.0));
  const TwinTruth tb = b.simulate(b.steady_state(rest), warm_up_loads(20.0));
  REQUIRE(ta.errors.col(e_y0c).cwiseAbs().maxCoeff() > 1.0);
  for (Eigen::Index k = 0; k < ta.errors.rows(); k += 17) {
    REQUIRE_THAT(tb.errors(k, e_y0c), WithinAbs(2.0 * ta.errors(k, e_y0c), kErrorTolerance_um));
    // The other errors do not depend on that gain.
    REQUIRE_THAT(tb.errors(k, 0), WithinAbs(ta.errors(k, 0), kErrorTolerance_um));
  }

  // With the output map linear, doubling the friction heat doubles every error it causes.
  ThermalTwinParams linear;
  linear.quadratic = {};
  ThermalTwinParams hot = linear;
  hot.friction_power_W *= 2.0;
  const ThermalTwin l(linear), h(hot);
  const TwinTruth tl = l.simulate(l.steady_state(rest), warm_up_loads(20.0));
  const TwinTruth th = h.simulate(h.steady_state(rest), warm_up_loads(20.0));
  for (Eigen::Index k = 0; k < tl.errors.rows(); k += 17)
    for (Eigen::Index e = 0; e < tl.errors.cols(); ++e)
      REQUIRE_THAT(th.errors(k, e), WithinAbs(2.0 * tl.errors(k, e), 1e-7));
}

TEST_CASE("twin: friction heat rises faster than linearly with the C-axis speed") {
  const ThermalTwin twin;
  CHECK(twin.friction_heat_W(0.0) == 0.0);
  REQUIRE_THAT(twin.friction_heat_W(1000.0), WithinAbs(twin.params().friction_power_W, 1e-12));
  CHECK(twin.friction_heat_W(1500.0) > 1.5 * twin.friction_heat_W(1000.0));
  CHECK(twin.friction_heat_W(-800.0) == twin.friction_heat_W(800.0));
}

TEST_CASE("twin: the output map has a mild nonlinearity in the cradle gradient") {
  ThermalTwinParams params;
  const ThermalTwin twin(params);
  Eigen::VectorXd nodes = Eigen::VectorXd::Constant(alc::scenarios::kTwinNodes, params.reference_temperature_C);
  nodes(alc::scenarios::kCradle) += 2.0;
  const ErrorVector e = twin.errors(nodes);
  constexpr int e_a0c = 4;
  // gain * 2 K + quadratic * (2 K)^2
  REQUIRE_THAT(e(e_a0c), WithinAbs(params.gains[e_a0c][alc::scenarios::kCradle] * 2.0 + params.quadratic[e_a0c] * 4.0,
                                   kErrorTolerance_um));
  ErrorVector drift = ErrorVector::Zero();
  drift(0) = 1.5;
  REQUIRE_THAT(twin.errors(nodes, drift)(0), WithinAbs(e(0) + 1.5, kErrorTolerance_um));
}

TEST_CASE("twin: the fluid state changes the table's response in case D") {
  using alc::scenarios::kTable;
  const auto spec = alc::scenarios::load_case_spec("D");
  const auto run = alc::scenarios::simulate_load_case(spec, spec.info.default_seed);
  std::vector<ThermalLoad> dry = run.profile.loads;
  int on = 0;
  for (ThermalLoad& l : dry) {
    on += l.fluid_on ? 1 : 0;
    l.fluid_on = false;
  }
  REQUIRE(on > 0);
  REQUIRE(on < static_cast<int>(dry.size()));
  ThermalTwinParams params = spec.twin;
  params.reference_temperature_C = dry.front().ambient_C;
  const ThermalTwin twin(params);
  const TwinTruth without = twin.simulate(run.truth.nodes.row(0).transpose(), dry, run.profile.drift);
  const double table_difference = (run.truth.nodes.col(kTable) - without.nodes.col(kTable)).cwiseAbs().maxCoeff();
  constexpr int e_r0t = 3;
  const double r0t_difference = (run.truth.errors.col(e_r0t) - without.errors.col(e_r0t)).cwiseAbs().maxCoeff();
  INFO("table differs by up to " << table_difference << " K, E_R0T by " << r0t_difference << " µm");
  CHECK(table_difference > 0.5);
  CHECK(r0t_difference > 2.0);
  // Case D's fluid sensor reads the tank, which the pump warms above the hall air.
  const int cf = run.scenario.input_index("T_CF");
  const int env = run.scenario.input_index("T_ENV");
  REQUIRE(cf >= 0);
  CHECK((run.scenario.inputs.col(cf) - run.scenario.inputs.col(env)).mean() > 0.5);
}

TEST_CASE("twin: invalid parameters are refused with the field named") {
  ThermalTwinParams params;
  params.c_table = -1.0;
  CHECK_THAT(params.validate(), Catch::Matchers::Contains("c_table"));
  CHECK_THROWS_WITH(ThermalTwin(params), Catch::Matchers::Contains("c_table must be finite and > 0"));
  params = {};
  params.g_table_fluid = -3.0;
  CHECK_THAT(params.validate(), Catch::Matchers::Contains("g_table_fluid"));
  CHECK(ThermalTwinParams{}.validate().empty());
}
