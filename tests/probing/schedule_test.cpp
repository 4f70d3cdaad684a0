// probing/schedule: seed 004's phase schedule as a policy, breach confirmation, Pd of Eq. 7.
#include <catch2/catch.hpp>

#include <cmath>

#include "probing/schedule.hpp"

using namespace alc;
using namespace alc::probing;
using Catch::Matchers::WithinAbs;

TEST_CASE("schedule: the paper's intervals per phase and the next due time") {
  PaperScheduleOptions o;
  o.cp_interval_s = 300.0;
  o.post_cp_interval_s = 7200.0;
  o.ng_interval_s = 600.0;
  const PaperSchedule s(o);
  CHECK(s.name() == "paper");
  CHECK(s.interval(Phase::Calibration) == 300.0);
  CHECK(s.interval(Phase::PostCalibration) == 7200.0);
  CHECK(s.interval(Phase::NoGood) == 600.0);
  ScheduleContext c;
  c.now_s = 1000.0;
  c.phase = Phase::NoGood;
  CHECK(s.next_due(c) == 1600.0);
  o.post_cp_interval_s = kNever;
  c.phase = Phase::PostCalibration;
  CHECK(std::isinf(PaperSchedule(o).next_due(c)));  // --interval inf: no probes after CP
}

TEST_CASE("schedule: NG burst, counting and the unbounded count") {
  PaperScheduleOptions o;
  o.ng_measurements = 3;
  ScheduleContext c;
  c.phase = Phase::NoGood;
  const PaperSchedule three(o);
  CHECK(three.ng_burst());
  for (int k = 1; k <= 2; ++k) {
    c.ng_probes = k;
    CHECK(three.after_ng_probe(c, true) == NgStep::Continue);
  }
  c.ng_probes = 3;
  CHECK(three.after_ng_probe(c, false) == NgStep::UpdateAndLeave);
  o.ng_measurements = kNever;
  const PaperSchedule unbounded(o);
  CHECK(unbounded.after_ng_probe(c, true) == NgStep::UpdateAndContinue);
  CHECK(unbounded.after_ng_probe(c, false) == NgStep::Leave);
  o.ng_measurements = 0;
  CHECK_FALSE(PaperSchedule(o).ng_burst());
  o.ng_measurements = 12;
  o.ng_interval_s = kNever;
  CHECK_FALSE(PaperSchedule(o).ng_burst());
}

TEST_CASE("schedule: a breach is confirmed by a residual off the same way by more than half the ACL") {
  const PaperSchedule s{PaperScheduleOptions{}};
  const double nan = std::nan("");
  Eigen::VectorXd breach(3), acl(3), r(3);
  breach << 6.0, nan, -20.0;
  acl << 5.0, 5.0, 15.0;
  r << 2.6, 9.0, 0.0;  // 2.6 > 2.5 the same way
  CHECK(s.confirmed(breach, r, acl));
  r << 2.4, 9.0, 0.0;  // below half; output 1 did not breach before
  CHECK_FALSE(s.confirmed(breach, r, acl));
  r << -6.0, nan, -7.6;  // output 0 flipped sign; output 2 still off the same way beyond 7.5
  CHECK(s.confirmed(breach, r, acl));
  r << nan, nan, nan;  // not measured
  CHECK_FALSE(s.confirmed(breach, r, acl));
}

TEST_CASE("accounting: productivity Pd of Eq. 7 with T_M = 95 s") {
  constexpr double kTol = 1e-12;
  // 100 probe cycles in 8 days: (1 - 100 * 95 / 691200) * 100
  REQUIRE_THAT(productivity_percent(100, 8 * 86400.0), WithinAbs(100.0 * (1.0 - 9500.0 / 691200.0), kTol));
  REQUIRE_THAT(productivity_percent(0, 3600.0), WithinAbs(100.0, kTol));
  // one probe every 5 min of probing time alone: 1 - 95/300
  REQUIRE_THAT(productivity_percent(12, 3600.0), WithinAbs(100.0 * (1.0 - 95.0 / 300.0), kTol));
  CHECK(std::isnan(productivity_percent(1, 0.0)));
  CHECK(to_string(Phase::NoGood) == "NG");
}

// The adaptive policy of these tests: half the ACL, 0.5-12 h, the paper's Post-CP interval 2 h.
static AdaptiveScheduleOptions adaptive_options() {
  AdaptiveScheduleOptions o;
  o.paper.post_cp_interval_s = 2 * 3600.0;
  o.fraction = 0.5;
  o.min_interval_s = 1800.0;
  o.max_interval_s = 12 * 3600.0;
  return o;
}

TEST_CASE("schedule: the adaptive policy probes when the predicted sigma reaches the fraction of the ACL") {
  const AdaptiveScheduleOptions o = adaptive_options();
  const AdaptiveSchedule s(o);
  CHECK(s.name() == "adaptive");
  const std::vector<std::string> names = {"E_X0C", "E_A0C"};
  ScheduleContext c;
  c.now_s = 1000.0;
  c.phase = Phase::PostCalibration;
  c.output_names = &names;
  // No evidence: the paper's interval.
  CHECK(s.next_due(c) == 1000.0 + 2 * 3600.0);
  CHECK_THAT(s.explain(c), Catch::Contains("no drift evidence"));
  // E_X0C: (0.5 * 5)^2 - 0.25 = 6 µm² at 1e-3 µm²/s: 6000 s; E_A0C: (0.5 * 15)^2 = 56.25 at 1e-3: longer.
  c.acl = Eigen::Vector2d(5.0, 15.0);
  c.noise_var = Eigen::Vector2d(0.25, 0.0);
  c.drift_rate = Eigen::Vector2d(1e-3, 1e-3);
  CHECK(s.next_due(c) == Approx(1000.0 + 6000.0));
  CHECK_THAT(s.explain(c), Catch::Contains("E_X0C") && Catch::Contains("1.67 h"));
  // Bounds.
  c.drift_rate = Eigen::Vector2d(1.0, 1.0);
  CHECK(s.next_due(c) == 1000.0 + 1800.0);
  CHECK_THAT(s.explain(c), Catch::Contains("minimum interval"));
  c.drift_rate = Eigen::Vector2d(1e-9, 0.0);
  CHECK(s.next_due(c) == 1000.0 + 12 * 3600.0);
  // Noise beyond the budget: probe at the minimum interval.
  c.drift_rate = Eigen::Vector2d(1e-3, 1e-3);
  c.noise_var = Eigen::Vector2d(10.0, 0.0);
  CHECK(s.next_due(c) == 1000.0 + 1800.0);
  // CP and NG are the paper's; no probes after CP stays no probes.
  c.phase = Phase::NoGood;
  CHECK(s.next_due(c) == 1000.0 + o.paper.ng_interval_s);
  CHECK(s.explain(c).empty());
  AdaptiveScheduleOptions never = o;
  never.paper.post_cp_interval_s = kNever;
  c.phase = Phase::PostCalibration;
  CHECK(std::isinf(AdaptiveSchedule(never).next_due(c)));
}

TEST_CASE("schedule: the adaptive policy with a budget beyond the ACL and no maximum interval") {
  AdaptiveScheduleOptions o = adaptive_options();
  o.fraction = 2.0;
  o.max_interval_s = kNever;
  const AdaptiveSchedule s(o);
  const std::vector<std::string> names = {"E_X0C"};
  ScheduleContext c;
  c.now_s = 1000.0;
  c.phase = Phase::PostCalibration;
  c.output_names = &names;
  c.acl = Eigen::VectorXd::Constant(1, 5.0);
  c.noise_var = Eigen::VectorXd::Constant(1, 0.25);
  c.drift_rate = Eigen::VectorXd::Constant(1, 1e-3);
  // (2 x 5)^2 - 0.25 = 99.75 µm² at 1e-3 µm²/s: 99750 s, no bound above.
  CHECK(s.next_due(c) == Approx(1000.0 + 99750.0));
  CHECK_THAT(s.explain(c), Catch::Contains("2.00 x its ACL 5") && Catch::Contains("27.71 h"));
  // No drift and no move: no probe is due, and the reason says so instead of an infinite interval.
  c.drift_rate = Eigen::VectorXd::Zero(1);
  CHECK(std::isinf(s.next_due(c)));
  CHECK_THAT(s.explain(c), Catch::Contains("no probe due") && !Catch::Contains("inf h"));
  // A move of the prediction still brings it forward: with kappa 1 a move of 10 µm uses up the 99.75 µm².
  c.kappa = Eigen::VectorXd::Constant(1, 1.0);
  c.since_s = 1000.0;
  c.now_s = 5000.0;
  c.prediction_change = Eigen::VectorXd::Constant(1, 10.0);
  CHECK(s.next_due(c) == Approx(1000.0 + o.min_interval_s));
}

TEST_CASE("schedule: the adaptive policy brings the probe forward when the prediction moves, within its bounds") {
  const AdaptiveScheduleOptions o = adaptive_options();
  const AdaptiveSchedule s(o);
  CHECK(s.checks_each_sample());
  CHECK_FALSE(PaperSchedule(o.paper).checks_each_sample());
  const std::vector<std::string> names = {"E_X0C", "E_A0C"};
  ScheduleContext c;
  c.phase = Phase::PostCalibration;
  c.output_names = &names;
  c.acl = Eigen::Vector2d(5.0, 15.0);
  c.noise_var = Eigen::Vector2d(0.25, 0.0);
  c.drift_rate = Eigen::Vector2d(1e-3, 1e-3);
  c.kappa = Eigen::Vector2d(0.5, 0.0);
  c.since_s = 1000.0;  // the decision: E_X0C's budget (0.5 * 5)^2 - 0.25 = 6 µm² lasts 6000 s without a move
  c.now_s = 1000.0;
  c.prediction_change = Eigen::Vector2d::Zero();
  const double still = s.next_due(c);
  CHECK(still == Approx(1000.0 + 6000.0));
  CHECK_THAT(s.explain(c), Catch::Contains("next probe in 1.67 h") && Catch::Contains("earlier if the prediction moves"));
  // A sample 1000 s later with a prediction that has moved by 2 µm: kappa * 4 = 2 µm² of the budget are
  // gone, the rest lasts 4000 s from the decision, not 6000 s.
  c.now_s = 2000.0;
  c.prediction_change = Eigen::Vector2d(2.0, 0.0);
  CHECK(s.next_due(c) == Approx(1000.0 + 4000.0));
  // It moved by 3 µm: 4.5 µm² gone, 1500 s left: earlier than the minimum interval, so the minimum.
  c.prediction_change = Eigen::Vector2d(3.0, 0.0);
  CHECK(s.next_due(c) == Approx(1000.0 + 1800.0));
  // Moved by 4 µm: beyond the budget; due at the minimum interval after the decision, not before.
  c.prediction_change = Eigen::Vector2d(-4.0, 0.0);
  CHECK(s.next_due(c) == Approx(1000.0 + 1800.0));
  c.now_s = 1000.0 + 1800.0;
  CHECK_THAT(s.explain(c), Catch::Contains("probe due now, 0.50 h after the last") && Catch::Contains("E_X0C") &&
                               Catch::Contains("the prediction moved by -4"));
  // A move of E_A0C, whose kappa is 0, changes nothing: the uncertainty grows with what the evidence says.
  c.prediction_change = Eigen::Vector2d(0.0, 50.0);
  CHECK(s.next_due(c) == Approx(still));
  // Without drift the move alone decides; a model whose residuals stay at the noise waits the maximum.
  c.drift_rate = Eigen::Vector2d(0.0, 0.0);
  c.prediction_change = Eigen::Vector2d(4.0, 0.0);
  CHECK(s.next_due(c) == Approx(1000.0 + 1800.0));
  c.prediction_change = Eigen::Vector2d(1.0, 0.0);
  CHECK(s.next_due(c) == Approx(1000.0 + 12 * 3600.0));
  // A fast move cannot push the probe beyond the bounds either way, whatever the evidence.
  for (const double move : {0.0, 0.5, 1.0, 2.0, 3.0, 10.0, 1e6})
    for (const double rate : {0.0, 1e-6, 1e-3, 1.0}) {
      c.drift_rate = Eigen::Vector2d(rate, rate);
      c.prediction_change = Eigen::Vector2d(move, -move);
      const double due = s.next_due(c);
      CHECK(due >= 1000.0 + o.min_interval_s);
      CHECK(due <= 1000.0 + o.max_interval_s);
    }
}
