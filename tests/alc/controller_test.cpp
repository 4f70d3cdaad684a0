









// The ALC state machine on scripted probe results: CP -> Post-CP -> NG -> update -> Post-CP,
// the update interval, each `inf`, an ACL breach on an angular error only, save/restore.
#include <catch2/catch.hpp>
#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <limits>

#include "alc/controller.hpp"
#include "common/number_text.hpp"

using namespace alc;

namespace {

constexpr double kMinute = 60.0;
constexpr double kHour = 3600.0;

// The time constant of the third pole of the default identification grid (about 17 min).
double grid_tau_2() {
  const IdentificationOptions o;
  return o.tau_min_s * std::pow(o.tau_max_s / o.tau_min_s, 2.0 / (o.pole_grid_size - 1));
}

// A plant whose errors follow a lag of one input with a pole on the identification grid:
// E_X0C = 3 * x, E_A0C = -4 * x, x = lag(T - 20), plus scripted disturbances.
struct Plant {
  double offset_x = 0.0;  // [µm] scripted disturbance added to E_X0C
  double offset_a = 0.0;  // [µm/m] scripted disturbance added to E_A0C
  double lag = 0.0;       // [K] state of the lag
  double last_t = 0.0;    // [s]
  inline static const double kTau = grid_tau_2();  // [s]
  static double temperature(double t) { return 20.0 + 2.0 * std::sin(2.0 * M_PI * t / (6.0 * kHour)); }
  Eigen::VectorXd inputs(double t) const {
    Eigen::VectorXd u(2);
    u << temperature(t), 500.0 + 400.0 * std::sin(2.0 * M_PI * t / (2.5 * kHour));
    return u;
  }
  // Advances the lag to t with the previous sample held (exact discretisation).
  void advance(double t) {
    if (t > last_t) lag += (1.0 - std::exp(-(t - last_t) / kTau)) * (temperature(last_t) - 20.0 - lag);
    last_t = t;
  }
  Eigen::VectorXd errors() const {
    Eigen::VectorXd e(2);
    e << 3.0 * lag + offset_x, -4.0 * lag + offset_a;
    return e;
  }
};

AlcParameters test_parameters() {
  AlcParameters p;
  p.cp_duration_s = 2 * kHour;
  p.cp_interval_s = 5 * kMinute;
  p.post_cp_interval_s = 1 * kHour;
  p.ng_interval_s = 10 * kMinute;
  p.ng_measurements = 3;
  p.identification.max_order = 1;
  p.identification.min_measurements = 6;
  p.refit_on_probe = false;  // the paper's literal state machine; refit_on_probe has its own test
  return p;
}

// test_parameters() with seed 004's schedule exactly, also where a test turns refit_on_probe on: the
// guard off, whose first check would then take the first probe after CP and after an NG update at half
// the Post-CP interval. The tests of the phases time their disturbances to seed 004's probes; the first
// check has its own test.
AlcParameters paper_parameters() {
  AlcParameters p = test_parameters();
  p.guard = false;
  return p;
}

// test_parameters() with the adaptive schedule between `min_h` and `max_h` hours.
AlcParameters adaptive_parameters(double min_h, double max_h) {
  AlcParameters p = test_parameters();
  p.schedule_kind = AlcParameters::Schedule::Adaptive;
  p.min_interval_s = min_h * kHour;
  p.max_interval_s = max_h * kHour;
  return p;
}

// Drives a controller minute by minute, probing whenever it asks; collects every event.
struct Driver {
  Plant plant;
  Controller controller;
  std::vector<ControllerEvent> events;
  std::vector<FitResult> fits;  // every identification that ran, in order
  int probes = 0;
  double t = 0.0;
  explicit Driver(AlcParameters p)
      : controller({"T_ENV", "n_C"}, {"E_X0C", "E_A0C"}, std::move(p)) {}
  // Continues `from`'s plant and time with a controller restored from `state` (its events are not copied).
  Driver(AlcParameters p, const ControllerState& state, const Driver& from)
      : plant(from.plant), controller({"T_ENV", "n_C"}, {"E_X0C", "E_A0C"}, std::move(p), state), t(from.t) {}
  void run_until(double end_s, const std::function<void(double)>& before_probe = {}) {
    for (; t < end_s; t += kMinute) {
      plant.advance(t);
      auto out = controller.on_sample(t, plant.inputs(t));
      events.insert(events.end(), out.events.begin(), out.events.end());
      if (out.fit) fits.push_back(*out.fit);
      if (t >= out.next_probe_due_s) {
        if (before_probe) before_probe(t);
        ProbeMeasurement m{t, plant.errors(), {}};
        auto pout = controller.on_probe(m);
        ++probes;
        events.insert(events.end(), pout.events.begin(), pout.events.end());
        if (pout.fit) fits.push_back(*pout.fit);
      }
    }
  }
  std::vector<ControllerEvent> of_type(ControllerEvent::Type type) const {
    std::vector<ControllerEvent> r;
    for (const auto& e : events)
      if (e.type == type) r.push_back(e);
    return r;
  }
};

// The guard events among `events` whose reason starts with `start`.
std::vector<ControllerEvent> holds_of(const std::vector<ControllerEvent>& events, const char* start) {
  std::vector<ControllerEvent> r;
  for (const auto& e : events)
    if (e.type == ControllerEvent::Type::Guard && e.reason.rfind(start, 0) == 0) r.push_back(e);
  return r;
}

// Without the guard, and in the paper's literal loop (no refit on a probe within the ACL), `p`'s first
// Post-CP probe comes one Post-CP interval (1 h) after CP (2 h), and no interval names the first check.
void check_no_first_check(const AlcParameters& p) {
  AlcParameters unguarded = p, literal = p;
  unguarded.guard = false;
  literal.refit_on_probe = false;
  for (const AlcParameters& q : {unguarded, literal}) {
    Driver off(q);
    off.run_until(2 * kHour + kMinute);
    CHECK(off.controller.state().next_probe_due_s == 3 * kHour);
    for (const auto& e : off.of_type(ControllerEvent::Type::ProbeIntervalChange))
      CHECK(e.reason.find("first check") == std::string::npos);
  }
}

// The guard's level of output i as docs/adaptive.md defines it: the decaying sum over the Post-CP probes
// within the ACL of the error the gain-scaled prediction left, over its weights plus one (0: none yet).
double level_of(const ControllerState& s, Eigen::Index i) {
  return s.guard_level_weight(i) > 0.0 ? s.guard_level_sum(i) / (s.guard_level_weight(i) + 1.0) : 0.0;
}

}  // namespace

TEST_CASE("controller: the guard's first check takes the first probe after CP and after an NG update at half a fixed Post-CP interval") {
  // With the guard and refits on probes (both the default): CP ends at 2 h and the first check's half of
  // the Post-CP interval (1 h) is announced, alone (the NC reads every interval); the probe at 2.5 h puts
  // the interval back to 1 h.
  AlcParameters p = test_parameters();
  p.refit_on_probe = true;
  Driver d(p);
  d.run_until(2 * kHour + kMinute);
  auto intervals = d.of_type(ControllerEvent::Type::ProbeIntervalChange);
  REQUIRE(intervals.size() == 2);
  CHECK(intervals[0].interval_s == 5 * kMinute);
  CHECK(intervals[1].interval_s == 30 * kMinute);
  CHECK(intervals[1].time_s == 2 * kHour);
  CHECK(intervals[1].reason == "the guard's first check of the model after the CP probes: half the Post-CP interval");
  CHECK(d.controller.state().next_probe_due_s == 2 * kHour + 30 * kMinute);
  d.run_until(2 * kHour + 31 * kMinute);
  intervals = d.of_type(ControllerEvent::Type::ProbeIntervalChange);
  REQUIRE(intervals.size() == 3);
  CHECK(intervals[2].interval_s == 1 * kHour);
  CHECK(intervals[2].time_s == 2 * kHour + 30 * kMinute);
  CHECK(d.controller.state().next_probe_due_s == 3 * kHour + 30 * kMinute);
  // A breach (E_X0C 12 µm off from 3 h on): NG, 3 probes 10 min apart, the update at its end
  // is a model fitted on a burst again: the next probe at half the interval, then the interval again.
  Driver b(p);
  b.run_until(3 * kHour - kMinute);
  b.plant.offset_x = 12.0;  // a step the model cannot know: the probe at 3.5 h breaches
  b.run_until(6 * kHour);
  const auto phases = b.of_type(ControllerEvent::Type::PhaseChange);
  REQUIRE(phases.size() >= 3);
  REQUIRE(phases[2].to == Phase::PostCalibration);
  const double ng_end = phases[2].time_s;
  std::vector<double> after;
  for (const auto& e : b.of_type(ControllerEvent::Type::ProbeIntervalChange))
    if (e.time_s >= ng_end) after.push_back(e.interval_s);
  REQUIRE(after.size() >= 2);
  CHECK(after[0] == 30 * kMinute);
  CHECK(after[1] == 1 * kHour);
  // Seed 004's schedule, the first Post-CP probe one interval after CP: without the guard and in the
  // paper's literal loop (no refit on a probe within the ACL). The adaptive schedule has its own test.
  check_no_first_check(p);
}

TEST_CASE("controller: under the adaptive schedule the guard's first check comes at half the interval the policy would choose, and judges the model") {
  AlcParameters p = adaptive_parameters(0.25, 4);
  p.refit_on_probe = true;  // with the guard (default)
  const auto first_checks = [](const Driver& d, double from_s) {
    std::vector<ControllerEvent> r;
    for (const auto& e : d.of_type(ControllerEvent::Type::ProbeIntervalChange))
      if (e.time_s >= from_s && e.reason.find("first check") != std::string::npos) r.push_back(e);
    return r;
  };
  // CP ends at 2 h; the policy's first interval is the Post-CP interval (1 h, before any probe has told),
  // the first check takes half of it.
  Driver d(p);
  d.run_until(2 * kHour + kMinute);
  REQUIRE(d.controller.phase() == Phase::PostCalibration);
  CHECK(d.controller.state().first_check_due);
  CHECK(d.controller.state().next_probe_due_s == 2 * kHour + 30 * kMinute);
  auto checks = first_checks(d, 0.0);
  REQUIRE(checks.size() == 1);
  CHECK(checks[0].time_s == 2 * kHour);
  CHECK(checks[0].interval_s == 30 * kMinute);
  CHECK_THAT(checks[0].reason, Catch::Matchers::StartsWith("adaptive: next probe in 0.50 h (the guard's first check"));
  // A state saved before the check continues bit for bit: the check is due in the state, not in the policy.
  Driver resumed(p, d.controller.state(), d);
  // At the check E_X0C is a third of what the model learnt: its compensation leaves about twice the error
  // that none would, and compensation holds the probe's error (as under the paper schedule).
  const auto third = [](Driver& x) { return [&x](double) { x.plant.offset_x = -2.0 * x.plant.lag; }; };
  d.run_until(2 * kHour + 31 * kMinute, third(d));
  resumed.run_until(2 * kHour + 31 * kMinute, third(resumed));
  const auto holds = holds_of(d.events, "compensation holds the latest probe's error");
  REQUIRE(holds.size() == 1);
  CHECK(holds[0].output == "E_X0C");
  CHECK(holds[0].time_s == 2 * kHour + 30 * kMinute);
  CHECK_FALSE(d.controller.state().first_check_due);
  CHECK(d.controller.state().guard_check_hold(0) == holds[0].limit);
  std::size_t from = 0;
  for (std::size_t i = 0; i < d.events.size(); ++i)
    if (d.events[i].time_s >= 2 * kHour + kMinute) {
      from = i;
      break;
    }
  REQUIRE(resumed.events.size() == d.events.size() - from);
  for (std::size_t i = 0; i < resumed.events.size(); ++i) CHECK(resumed.events[i].reason == d.events[from + i].reason);
  // After the check the policy's own interval again, not halved.
  const auto intervals = d.of_type(ControllerEvent::Type::ProbeIntervalChange);
  REQUIRE(intervals.back().time_s == 2 * kHour + 30 * kMinute);
  CHECK(intervals.back().reason.find("first check") == std::string::npos);
  CHECK(d.controller.state().next_probe_due_s - d.t > 30 * kMinute);
  // An NG update is a model fitted on a burst too: after it the first check again.
  Driver ng(p);
  ng.run_until(3 * kHour);
  ng.plant.offset_x = 12.0;  // a step the model cannot know: the next probe breaches
  ng.run_until(8 * kHour);
  double ng_end = -1.0;
  for (const auto& e : ng.of_type(ControllerEvent::Type::PhaseChange))
    if (e.from == Phase::NoGood && e.to == Phase::PostCalibration) ng_end = e.time_s;
  REQUIRE(ng_end > 3 * kHour);
  checks = first_checks(ng, ng_end);
  REQUIRE_FALSE(checks.empty());
  CHECK(checks[0].time_s == ng_end);
  // No first check without the guard, nor in the paper's literal loop: the policy's interval alone.
  check_no_first_check(p);
}

TEST_CASE("controller: a model that does worse than none at the guard's first check holds the latest probe's error until the next probe") {
  AlcParameters p = test_parameters();
  p.refit_on_probe = true;  // with the guard (default): the first check at 2.5 h, then a probe every hour
  Driver d(p);
  d.run_until(2 * kHour + 29 * kMinute);
  REQUIRE(d.controller.phase() == Phase::PostCalibration);
  REQUIRE(d.controller.state().first_check_due);
  // From here E_X0C is a third of what the model learnt during CP: at the first check its compensation
  // leaves twice the error that none would (within the ACL, no breach); E_A0C stays as learnt.
  const auto third = [&d](double) { d.plant.offset_x = -2.0 * d.plant.lag; };
  d.run_until(2 * kHour + 31 * kMinute, third);
  const auto holds = holds_of(d.events, "compensation holds the latest probe's error");
  REQUIRE(holds.size() == 1);
  CHECK(holds[0].output == "E_X0C");
  CHECK(holds[0].time_s == 2 * kHour + 30 * kMinute);
  const double u = holds[0].limit;  // the error without compensation
  REQUIRE(u > 0.1);
  CHECK_THAT(holds[0].value, Catch::Matchers::WithinAbs(-2.0 * u, 0.05 * u));  // what the model's compensation left
  CHECK_THAT(holds[0].reason, Catch::Matchers::Contains("until the next probe: at the first check of the model it left"));
  CHECK(d.of_type(ControllerEvent::Type::AclBreach).empty());
  const ControllerState held = d.controller.state();
  CHECK_FALSE(held.first_check_due);
  CHECK(held.guard_check_hold(0) == u);
  CHECK(std::isnan(held.guard_check_hold(1)));
  // Compensated: the error the probe measured, not the model's prediction (about 2 u after the refit that
  // learnt from the check's probe); E_A0C as the model predicts.
  const ControllerOutput now = d.controller.on_tick(d.t);
  CHECK(now.prediction(0) == u);
  CHECK(held.prediction(0) > 1.5 * u);
  CHECK(now.prediction(1) == held.prediction(1) + level_of(held, 1));
  CHECK(std::abs(level_of(held, 1)) < 0.01);  // E_A0C is what the model learnt: no level to speak of
  // A state saved during the hold continues bit for bit.
  Controller restored({"T_ENV", "n_C"}, {"E_X0C", "E_A0C"}, d.controller.parameters(), held);
  Driver twin(p);
  twin.plant = d.plant;
  twin.t = d.t;
  twin.controller = restored;
  twin.run_until(5 * kHour, [&twin](double) { twin.plant.offset_x = -2.0 * twin.plant.lag; });
  // The next probe (3.5 h) ends the hold, whatever it finds: the model compensates again.
  const std::size_t before = d.events.size();
  d.run_until(5 * kHour, third);
  const std::vector<ControllerEvent> after(d.events.begin() + static_cast<std::ptrdiff_t>(before), d.events.end());
  const auto again = holds_of(after, "compensation by the model again");
  REQUIRE_FALSE(again.empty());
  CHECK(again[0].output == "E_X0C");
  CHECK(again[0].time_s == 3 * kHour + 30 * kMinute);
  CHECK(std::isnan(d.controller.state().guard_check_hold(0)));
  REQUIRE(twin.events.size() == after.size());
  for (std::size_t i = 0; i < after.size(); ++i) CHECK(twin.events[i].reason == after[i].reason);
  CHECK(twin.controller.on_tick(twin.t).prediction == d.controller.on_tick(d.t).prediction);
  // Only the first check judges: the same disturbance from the probe after it on holds nothing, and
  // without the guard there is no first check to judge.
  Driver late(p);
  late.run_until(3 * kHour + 29 * kMinute);
  late.run_until(5 * kHour, [&late](double) { late.plant.offset_x = -2.0 * late.plant.lag; });
  CHECK(holds_of(late.events, "compensation holds").empty());
  AlcParameters unguarded = p;
  unguarded.guard = false;
  Driver off(unguarded);
  off.run_until(2 * kHour + 29 * kMinute);
  off.run_until(5 * kHour, [&off](double) { off.plant.offset_x = -2.0 * off.plant.lag; });
  CHECK(off.of_type(ControllerEvent::Type::Guard).empty());
  CHECK(off.controller.state().guard_check_hold.array().isNaN().all());
}

TEST_CASE("controller: the guard's move check takes a probe as soon as a compensation has moved half its ACL since the last probe") {
  // The plant's E_X0C (3 x the lag of a +-2 K sine of 6 h) moves up to about 6 µm per hour, its E_A0C
  // (-4 x) 8 µm/m: with a Post-CP interval of 2 h the model's E_X0C compensation moves more than half the
  // linear ACL (2.5 µm) between two probes, the E_A0C one less than half the angular ACL (7.5 µm/m).
  AlcParameters p = test_parameters();
  p.refit_on_probe = true;
  p.post_cp_interval_s = 2 * kHour;
  // What an output's compensation by the model has moved since the last probe; 0 where the guard's range
  // switched it off or its first check holds the probe's error (nothing of the model reaches an axis).
  const auto moved = [](const Controller& c, Eigen::Index i) {
    const ControllerState& s = c.state();
    if (s.guard_off_range(i) != 0.0 || !std::isnan(s.guard_check_hold(i))) return 0.0;
    return s.guard_gain(i) * (s.prediction(i) - s.schedule_prediction(i));
  };
  // The run of 30 h at a move fraction (AlcParameters::move_fraction): the number of move checks.
  const auto run = [&](double fraction) {
    INFO("move fraction " << fraction);
    AlcParameters q = p;
    q.move_fraction = fraction;
    const double lin = fraction * q.acl_linear_um, ang = fraction * q.acl_angular_um_per_m;
    Driver d(q);
    d.run_until(2 * kHour + kMinute);  // CP ends at 2 h
    REQUIRE(d.controller.phase() == Phase::PostCalibration);
    int checks = 0;
    for (; d.t < 30 * kHour; d.t += kMinute) {
      d.plant.advance(d.t);
      const ControllerState before = d.controller.state();
      const ControllerOutput out = d.controller.on_sample(d.t, d.plant.inputs(d.t));
      d.events.insert(d.events.end(), out.events.begin(), out.events.end());
      const bool waiting = d.controller.phase() == Phase::PostCalibration && before.next_probe_due_s > d.t;
      bool move_event = false;
      for (const auto& e : out.events)
        if (e.type == ControllerEvent::Type::ProbeIntervalChange && e.reason.rfind("the guard's move check", 0) == 0) {
          move_event = true;
          const bool x = std::abs(moved(d.controller, 0)) > lin;  // the first output beyond its limit is named
          CHECK_THAT(e.reason, Catch::Matchers::Contains(x ? "the compensation of E_X0C moved" : "the compensation of E_A0C moved"));
          CHECK_THAT(e.reason, Catch::Matchers::Contains("more than " + alc::common::shortest_text(fraction) + " x its ACL (" +
                                                         alc::common::shortest_text(x ? lin : ang) + "): probe now"));
          CHECK(e.time_s == d.t);
          CHECK(e.interval_s == d.t - before.schedule_since_s);
          CHECK(e.interval_s < 2 * kHour);
        }
      // Complete and exact: while a probe is not yet due, it is due now exactly where an output's compensation
      // has moved beyond the fraction of its ACL since the last probe (at 0.5 E_A0C never does here).
      if (waiting) {
        const bool beyond = std::abs(moved(d.controller, 0)) > lin || std::abs(moved(d.controller, 1)) > ang;
        if (fraction == 0.5) CHECK(std::abs(moved(d.controller, 1)) <= ang);
        CHECK(beyond == move_event);
        CHECK(move_event == (out.next_probe_due_s == d.t));
        checks += move_event;
      }
      if (d.t >= out.next_probe_due_s) {
        const auto pout = d.controller.on_probe(ProbeMeasurement{d.t, d.plant.errors(), {}});
        d.events.insert(d.events.end(), pout.events.begin(), pout.events.end());
        // After the probe, the movement counts from it.
        if (d.controller.phase() == Phase::PostCalibration)
          for (Eigen::Index i = 0; i < 2; ++i) CHECK(moved(d.controller, i) == 0.0);
      }
    }
    return checks;
  };
  const int half = run(0.5);  // the default
  CHECK(half >= 5);
  CHECK(AlcParameters{}.move_fraction == 0.5);
  // A smaller fraction checks more often; inf turns the check off (the probes keep the schedule).
  CHECK(run(0.25) > half);
  CHECK(run(std::numeric_limits<double>::infinity()) == 0);
  // Not without the guard, nor in the paper's literal loop (no refit on a probe within the ACL): there
  // the probes after CP keep the schedule (the first at 2 h + the interval).
  AlcParameters unguarded = p, literal = p;
  unguarded.guard = false;
  literal.refit_on_probe = false;
  for (const AlcParameters& q : {unguarded, literal}) {
    Driver off(q);
    off.run_until(30 * kHour);
    for (const auto& e : off.of_type(ControllerEvent::Type::ProbeIntervalChange))
      CHECK(e.reason.rfind("the guard's move check", 0) == std::string::npos);
  }
  // It brings a planned probe forward and adds none where the schedule plans none (Post-CP interval inf).
  AlcParameters never = p;
  never.post_cp_interval_s = std::numeric_limits<double>::infinity();
  Driver stopped(never);
  stopped.run_until(2 * kHour + kMinute);
  const int cp_probes = stopped.probes;
  stopped.run_until(30 * kHour);
  CHECK(stopped.probes == cp_probes);
  // Within half the ACL: with the ACLs at 20 µm and 60 µm/m no compensation moves half of them between
  // two probes 2 h apart (E_A0C would move 7.5 µm/m: the probes that E_X0C's checks brought kept it below).
  AlcParameters wide = p;
  wide.acl_linear_um = 20.0;
  wide.acl_angular_um_per_m = 60.0;
  Driver quiet(wide);
  quiet.run_until(30 * kHour);
  for (const auto& e : quiet.of_type(ControllerEvent::Type::ProbeIntervalChange))
    CHECK(e.reason.rfind("the guard's move check", 0) == std::string::npos);
}

TEST_CASE("controller: CP ends with a first model and the Post-CP interval") {
  Driver d(paper_parameters());
  d.run_until(2 * kHour + 30 * kMinute);
  const auto phases = d.of_type(ControllerEvent::Type::PhaseChange);
  REQUIRE(phases.size() == 1);
  CHECK(phases[0].from == Phase::Calibration);
  CHECK(phases[0].to == Phase::PostCalibration);
  CHECK(phases[0].time_s == 2 * kHour);
  CHECK(d.of_type(ControllerEvent::Type::ModelUpdate).size() == 1);
  const auto intervals = d.of_type(ControllerEvent::Type::ProbeIntervalChange);
  REQUIRE(intervals.size() == 2);
  CHECK(intervals[0].interval_s == 5 * kMinute);
  CHECK(intervals[1].interval_s == 1 * kHour);
  CHECK(d.controller.state().next_probe_due_s == 3 * kHour);
  // CP probes at 0, 5, ..., 115 min; CP ends with the sample at 120 min, before its probe was due.
  CHECK(d.controller.state().probe_cycles == 24);
  // The model learned the plant (which its structure can represent): prediction close to the truth.
  constexpr double kLearnedTolerance = 0.5;  // [µm]: the structure holds the plant exactly; noise-free data
  const auto out = d.controller.on_tick(d.t);
  CHECK_THAT(out.prediction[0], Catch::Matchers::WithinAbs(d.plant.errors()[0], kLearnedTolerance));
  CHECK_THAT(out.prediction[1], Catch::Matchers::WithinAbs(d.plant.errors()[1], kLearnedTolerance));
}

TEST_CASE("controller: a probe asked for is due at once in any phase, says why, and a step it finds starts NG") {
  Driver d(paper_parameters());
  // Before the first sample there is no time to take it at: rejected, nothing changes.
  const auto early = d.controller.request_probe(0.0, "too early");
  CHECK_FALSE(early.accepted);
  CHECK(early.reason == "probe requested before the first input sample");
  CHECK_FALSE(d.controller.state().started);
  // In CP a probe is due every 5 min: asked 4 min before the next, it is brought forward.
  d.run_until(30 * kMinute + kMinute);  // the probe of 30 min taken
  REQUIRE(d.controller.state().next_probe_due_s == 35 * kMinute);
  auto out = d.controller.request_probe(31 * kMinute, "during CP");
  CHECK(out.accepted);
  REQUIRE(out.events.size() == 1);
  CHECK(out.events[0].type == ControllerEvent::Type::ProbeIntervalChange);
  CHECK(out.events[0].reason == "probe requested: during CP");
  CHECK(out.events[0].interval_s == 1 * kMinute);  // since the probe of 30 min: what the NC is told
  CHECK(out.next_probe_due_s == 31 * kMinute);
  // Asked again while it is due: nothing changes, nothing is said.
  out = d.controller.request_probe(31 * kMinute, "again");
  CHECK(out.accepted);
  CHECK(out.events.empty());
  // Once taken, CP's interval is told again (the NC must not keep probing every minute).
  d.events.clear();
  d.run_until(32 * kMinute);
  CHECK(d.controller.state().next_probe_due_s == 36 * kMinute);
  auto told = d.of_type(ControllerEvent::Type::ProbeIntervalChange);
  REQUIRE(told.size() == 1);
  CHECK(told[0].interval_s == 5 * kMinute);
  CHECK(told[0].reason == "CP interval again after the probe asked for");
  d.run_until(3 * kHour + 10 * kMinute);  // CP over, the first Post-CP probe at 3 h taken
  REQUIRE(d.controller.phase() == Phase::PostCalibration);
  REQUIRE(d.controller.state().next_probe_due_s == 4 * kHour);
  // After CP, asked where nothing has changed: the probe is within the ACL, and the Post-CP interval
  // counts again from it and is told again.
  out = d.controller.request_probe(d.t, "checked after a tool change");
  REQUIRE(out.events.size() == 1);
  CHECK(out.events[0].interval_s == 10 * kMinute);  // since the probe of 3 h
  d.events.clear();
  const double calm = d.t;
  d.run_until(calm + kMinute);
  CHECK(d.of_type(ControllerEvent::Type::PhaseChange).empty());
  told = d.of_type(ControllerEvent::Type::ProbeIntervalChange);
  REQUIRE(told.size() == 1);
  CHECK(told[0].interval_s == 1 * kHour);
  CHECK_THAT(told[0].reason, Catch::StartsWith("Post-CP interval after an early probe"));
  CHECK(d.controller.state().next_probe_due_s == calm + 1 * kHour);
  d.run_until(calm + 10 * kMinute);
  // Times that cannot be: before the latest sample, not finite.
  const ControllerState before = d.controller.state();
  for (const double bad : {d.t - 2 * kMinute, std::numeric_limits<double>::quiet_NaN(),
                           std::numeric_limits<double>::infinity()}) {
    out = d.controller.request_probe(bad, "bad time");
    CHECK_FALSE(out.accepted);
    CHECK_THAT(out.reason, Catch::StartsWith("probe requested at t = "));
    CHECK(d.controller.state().next_probe_due_s == before.next_probe_due_s);
  }
  // The machine is moved at 3 h 20 min: a step of 7 µm (beyond the ACL of 5 µm) that no input shows,
  // and someone who knows asks for a probe. It is due at once, not at 4 h 10 min, and NG starts there.
  const double moved = d.t;
  d.plant.offset_x = 7.0;
  out = d.controller.request_probe(moved, "the machine was relevelled");
  CHECK(out.accepted);
  REQUIRE(out.events.size() == 1);
  CHECK(out.events[0].reason == "probe requested: the machine was relevelled");
  CHECK(out.events[0].interval_s == moved - calm);
  CHECK(out.next_probe_due_s == moved);
  CHECK(out.prediction.size() == 2);
  const int probes_before = d.controller.state().probe_cycles;
  d.events.clear();
  d.run_until(moved + kMinute);  // the sample at `moved` takes the probe
  CHECK(d.controller.state().probe_cycles == probes_before + 1);
  const auto phases = d.of_type(ControllerEvent::Type::PhaseChange);
  REQUIRE(phases.size() == 1);
  CHECK(phases[0].to == Phase::NoGood);
  CHECK(phases[0].time_s == moved);
  // In NG (probes every 10 min) too: asked 2 min after the breach, then NG's interval told again.
  REQUIRE(d.controller.state().next_probe_due_s == moved + 10 * kMinute);
  d.run_until(moved + 2 * kMinute);
  out = d.controller.request_probe(d.t, "during NG");
  REQUIRE(out.events.size() == 1);
  CHECK(out.events[0].interval_s == 2 * kMinute);
  d.events.clear();
  d.run_until(moved + 3 * kMinute);
  REQUIRE(d.controller.phase() == Phase::NoGood);
  told = d.of_type(ControllerEvent::Type::ProbeIntervalChange);
  REQUIRE(told.size() == 1);
  CHECK(told[0].interval_s == 10 * kMinute);
  CHECK(told[0].reason == "NG interval again after the probe asked for");
  CHECK(d.controller.state().next_probe_due_s == moved + 12 * kMinute);
  // Without the requests the step waits for the scheduled probe at 4 h.
  Driver silent(paper_parameters());
  silent.run_until(moved);
  silent.plant.offset_x = 7.0;
  silent.run_until(4 * kHour);
  CHECK(silent.of_type(ControllerEvent::Type::PhaseChange).size() == 1);  // CP -> Post-CP only
  silent.run_until(4 * kHour + kMinute);
  const auto silent_phases = silent.of_type(ControllerEvent::Type::PhaseChange);
  REQUIRE(silent_phases.size() == 2);
  CHECK(silent_phases[1].time_s == 4 * kHour);
}

TEST_CASE("controller: an ACL breach starts NG, after N probes the model is updated and Post-CP resumes") {
  Driver d(paper_parameters());
  d.run_until(3 * kHour - kMinute);
  d.plant.offset_x = 12.0;  // a step the model cannot know: residual 12 µm > 5 µm
  d.run_until(5 * kHour);
  const auto breaches = d.of_type(ControllerEvent::Type::AclBreach);
  REQUIRE(!breaches.empty());
  CHECK(breaches[0].output == "E_X0C");
  CHECK(breaches[0].time_s == 3 * kHour);
  CHECK_THAT(breaches[0].value, Catch::Matchers::WithinAbs(12.0, 0.5));
  CHECK(breaches[0].limit == 5.0);
  const auto phases = d.of_type(ControllerEvent::Type::PhaseChange);
  REQUIRE(phases.size() >= 3);
  CHECK(phases[1].to == Phase::NoGood);
  CHECK(phases[1].time_s == 3 * kHour);
  CHECK(phases[2].to == Phase::PostCalibration);
  CHECK(phases[2].time_s == 3 * kHour + 30 * kMinute);  // 3 NG probes at 10 min
  const auto updates = d.of_type(ControllerEvent::Type::ModelUpdate);
  REQUIRE(updates.size() == 2);
  CHECK(updates[1].time_s == 3 * kHour + 30 * kMinute);
  const auto intervals = d.of_type(ControllerEvent::Type::ProbeIntervalChange);
  REQUIRE(intervals.size() == 4);
  CHECK(intervals[2].interval_s == 10 * kMinute);
  CHECK(intervals[3].interval_s == 1 * kHour);
  CHECK(d.controller.state().ng_phases == 1);
}

TEST_CASE("controller: a breach on an angular error only is judged against the angular limit") {
  Driver d(paper_parameters());
  d.run_until(3 * kHour - kMinute);
  d.plant.offset_a = 10.0;  // 10 µm/m: beyond 5 (linear) but within 15 µm/m
  d.run_until(4 * kHour - kMinute);
  CHECK(d.of_type(ControllerEvent::Type::AclBreach).empty());
  CHECK(d.controller.phase() == Phase::PostCalibration);
  d.plant.offset_a = 20.0;
  d.run_until(4 * kHour + kMinute);
  const auto breaches = d.of_type(ControllerEvent::Type::AclBreach);
  REQUIRE(breaches.size() == 1);
  CHECK(breaches[0].output == "E_A0C");
  CHECK(breaches[0].limit == 15.0);
  CHECK(d.controller.phase() == Phase::NoGood);
}

TEST_CASE("controller: the periodic parameter update interval") {
  AlcParameters p = test_parameters();
  p.update_interval_s = 3 * kHour;
  Driver d(p);
  d.run_until(12 * kHour);
  const auto updates = d.of_type(ControllerEvent::Type::ModelUpdate);
  // First model at 2 h, then periodic updates at 5, 8 and 11 h (no breaches on this plant).
  REQUIRE(updates.size() == 4);
  CHECK(updates[1].time_s == 5 * kHour);
  CHECK(updates[2].time_s == 8 * kHour);
  CHECK(updates[3].time_s == 11 * kHour);
  CHECK(d.of_type(ControllerEvent::Type::AclBreach).empty());
}

TEST_CASE("controller: a fit that is not usable keeps the previous model and says why") {
  AlcParameters p = paper_parameters();
  p.learning_window_s = 40 * kMinute;  // CP end at 2 h: the 8 probes from 80 to 115 min
  p.update_interval_s = 1.5 * kHour;   // 3.5 h: only the 3 h probe is in the window
  Driver d(p);
  d.run_until(3 * kHour + 30 * kMinute);
  REQUIRE(d.of_type(ControllerEvent::Type::ModelUpdate).size() == 1);
  REQUIRE(d.fits.size() == 1);
  CHECK(d.fits[0].outputs[0].measurements == 8);
  const ThermalModel before = d.controller.state().predictor.model();
  const Eigen::VectorXd state_before = d.controller.state().predictor.state();

  d.run_until(3 * kHour + 31 * kMinute);  // the sample at 3.5 h runs the periodic update
  const auto rejected = d.of_type(ControllerEvent::Type::ModelRejected);
  REQUIRE(rejected.size() == 1);
  CHECK(rejected[0].time_s == 3.5 * kHour);
  CHECK(rejected[0].reason.find("periodic parameter update") == 0);
  CHECK(rejected[0].reason.find("E_X0C: only 1 measurements in the window") != std::string::npos);
  CHECK(rejected[0].reason.find("previous model kept") != std::string::npos);
  REQUIRE(d.fits.size() == 2);
  CHECK_FALSE(d.fits[1].usable);
  CHECK(d.controller.state().rejected_fits == 1);
  CHECK(d.controller.state().updates == 1);
  CHECK(d.controller.state().has_model);
  // The same model, stepped on by one sample: its parameters are untouched and it still predicts.
  const ThermalModel& after = d.controller.state().predictor.model();
  REQUIRE(after.outputs.size() == before.outputs.size());
  for (std::size_t k = 0; k < before.outputs.size(); ++k) {
    CHECK(after.outputs[k].parameters == before.outputs[k].parameters);
    CHECK(after.outputs[k].poles == before.outputs[k].poles);
  }
  ModelPredictor replayed(before);
  replayed.set_state(state_before);
  const Eigen::VectorXd expected = replayed.step(3.5 * kHour, d.plant.inputs(3.5 * kHour));
  CHECK(d.controller.state().prediction == expected);
  CHECK_THAT(d.controller.state().prediction[0], Catch::Matchers::WithinAbs(d.plant.errors()[0], 0.5));
  // A failed periodic update waits for the next interval instead of retrying at every sample.
  d.run_until(4 * kHour + 50 * kMinute);
  CHECK(d.of_type(ControllerEvent::Type::ModelRejected).size() == 1);
}

TEST_CASE("controller: learning_since_s and learning_window_s choose the probes an identification learns from") {
  const auto cp_fit_measurements = [](AlcParameters p) {
    Driver d(p);
    d.run_until(2 * kHour + kMinute);
    REQUIRE(d.fits.size() == 1);
    REQUIRE(d.fits[0].usable);
    CHECK(d.fits[0].outputs[0].measurements == d.fits[0].outputs[1].measurements);
    return d.fits[0].outputs[0].measurements;
  };
  AlcParameters p = test_parameters();
  CHECK(cp_fit_measurements(p) == 24);  // CP probes at 0, 5, ..., 115 min
  p.learning_since_s = 1 * kHour;
  CHECK(cp_fit_measurements(p) == 12);  // 60 ... 115 min
  p.learning_window_s = 30 * kMinute;
  CHECK(cp_fit_measurements(p) == 6);   // the later of the two starts: 90 ... 115 min
  p.learning_since_s = -kInf;
  p.learning_window_s = 50 * kMinute;
  CHECK(cp_fit_measurements(p) == 10);  // 70 ... 115 min

  SECTION("a start after the data: CP is extended until enough probes exist since then") {
    AlcParameters q = test_parameters();
    q.learning_since_s = 1.75 * kHour;  // 105, 110, 115 min at CP end: too few
    Driver d(q);
    d.run_until(2 * kHour + 20 * kMinute);
    CHECK(d.controller.phase() == Phase::PostCalibration);
    const auto rejected = d.of_type(ControllerEvent::Type::ModelRejected);
    REQUIRE(rejected.size() == 3);  // at 2 h (3 probes, then 4 after its probe), 2 h 05 (5); 2 h 10 has 6
    CHECK(rejected[0].reason.find("no model yet") != std::string::npos);
    REQUIRE(d.fits.back().usable);
    CHECK(d.fits.back().outputs[0].measurements == 6);
  }
  SECTION("validation") {
    AlcParameters q = test_parameters();
    q.learning_since_s = kInf;
    CHECK(q.validate().find("learning_since_s") == 0);
    q.learning_since_s = std::nan("");
    CHECK(q.validate().find("learning_since_s") == 0);
  }
}

TEST_CASE("controller: refit_on_probe learns from every Post-CP probe within the ACL") {
  AlcParameters p = paper_parameters();
  p.refit_on_probe = true;
  Driver d(p);
  d.run_until(6 * kHour + kMinute);
  // First model at 2 h, then one update per hourly probe at 3, 4, 5 and 6 h.
  const auto updates = d.of_type(ControllerEvent::Type::ModelUpdate);
  REQUIRE(updates.size() == 5);
  for (std::size_t i = 1; i < updates.size(); ++i) {
    CHECK(updates[i].time_s == (2.0 + static_cast<double>(i)) * kHour);
    CHECK(updates[i].reason.rfind("Post-CP probe within the ACL", 0) == 0);
  }
  CHECK(d.controller.phase() == Phase::PostCalibration);
}

TEST_CASE("controller: a confirming probe keeps the structure until the data span has grown by structure_refresh") {
  const auto kept = [](const ControllerEvent& e) { return e.reason.find("structure kept") != std::string::npos; };
  SECTION("1.5: after CP at 2 h the structure is searched again at 3 h (span 1.5 x 2 h), kept at 4 h, searched at 5 h") {
    AlcParameters p = paper_parameters();
    p.refit_on_probe = true;
    p.structure_refresh = 1.5;
    Driver d(p);
    d.run_until(6 * kHour + kMinute);
    const auto updates = d.of_type(ControllerEvent::Type::ModelUpdate);
    REQUIRE(updates.size() == 5);
    CHECK_FALSE(kept(updates[0]));  // CP end: 2 h of data
    CHECK_FALSE(kept(updates[1]));  // 3 h >= 1.5 x 2 h
    CHECK(kept(updates[2]));        // 4 h < 1.5 x 3 h
    CHECK_FALSE(kept(updates[3]));  // 5 h >= 4.5 h
    CHECK(kept(updates[4]));        // 6 h < 7.5 h
  }
  SECTION("1: every confirming probe searches the structure") {
    AlcParameters p = paper_parameters();
    p.refit_on_probe = true;
    p.structure_refresh = 1.0;
    Driver d(p);
    d.run_until(6 * kHour + kMinute);
    for (const auto& e : d.of_type(ControllerEvent::Type::ModelUpdate)) CHECK_FALSE(kept(e));
  }
  SECTION("inf: the structure found at CP end stays; the parameters follow the probes") {
    AlcParameters p = paper_parameters();
    p.refit_on_probe = true;
    p.structure_refresh = kInf;
    Driver d(p);
    d.run_until(2 * kHour + kMinute);
    const ThermalModel at_cp = d.controller.state().predictor.model();
    d.run_until(6 * kHour + kMinute);
    const auto updates = d.of_type(ControllerEvent::Type::ModelUpdate);
    REQUIRE(updates.size() == 5);
    for (std::size_t i = 1; i < updates.size(); ++i) CHECK(kept(updates[i]));
    const ThermalModel& now = d.controller.state().predictor.model();
    for (std::size_t o = 0; o < now.outputs.size(); ++o) {
      CHECK(now.outputs[o].inputs == at_cp.outputs[o].inputs);
      CHECK((now.outputs[o].poles.array() == at_cp.outputs[o].poles.array()).all());
    }
  }
  SECTION("below 1 is refused") {
    AlcParameters p = paper_parameters();
    p.structure_refresh = 0.5;
    CHECK_THAT(p.validate(), Catch::Matchers::Contains("structure_refresh = 0.5"));
  }
}

TEST_CASE("controller: with refit_on_probe a breach confirmed by the first NG probe is learned from at once") {
  AlcParameters p = paper_parameters();
  p.refit_on_probe = true;
  Driver d(p);
  d.run_until(3 * kHour - kMinute);
  d.plant.offset_x = 12.0;  // a lasting change: the first NG probe (3 h 10) confirms the breach of 3 h
  d.run_until(3 * kHour + 31 * kMinute);
  std::vector<double> update_times;
  for (const auto& e : d.of_type(ControllerEvent::Type::ModelUpdate)) update_times.push_back(e.time_s);
  // CP end, the confirmation (3 h 10) and the end of the 3-probe NG burst (3 h 30).
  REQUIRE(update_times == std::vector<double>{2 * kHour, 3 * kHour + 10 * kMinute, 3 * kHour + 30 * kMinute});
  CHECK(d.of_type(ControllerEvent::Type::ModelUpdate)[1].reason.rfind("ACL breach confirmed by the first NG probe", 0) == 0);
  CHECK(d.of_type(ControllerEvent::Type::OutlierRejected).empty());
  CHECK(d.controller.phase() == Phase::PostCalibration);
  CHECK(d.controller.state().ng_phases == 1);
  for (const ProbeRecord& r : d.controller.state().probes) CHECK(r.weight == 1.0);

  SECTION("confirm_breach = false learns from the breaching probe itself") {
    p.confirm_breach = false;
    Driver e(p);
    e.run_until(3 * kHour - kMinute);
    e.plant.offset_x = 12.0;
    e.run_until(3 * kHour + 31 * kMinute);
    std::vector<double> times;
    for (const auto& u : e.of_type(ControllerEvent::Type::ModelUpdate)) times.push_back(u.time_s);
    CHECK(times == std::vector<double>{2 * kHour, 3 * kHour, 3 * kHour + 30 * kMinute});
  }
}

TEST_CASE("controller: a breach that the first NG probe does not confirm is set aside as an outlier") {
  AlcParameters p = paper_parameters();
  p.refit_on_probe = true;
  Driver d(p);
  d.run_until(3 * kHour - kMinute);
  // A chip on the sphere: only the probe at 3 h reads 12 µm too much on E_X0C.
  d.run_until(3 * kHour + kMinute, [&](double t) { d.plant.offset_x = t == 3 * kHour ? 12.0 : 0.0; });
  // Until the first NG probe judges it, the breach is no evidence for the guard's drift bound either:
  // compensation stays with the model (which predicts this plant), not with the chip's reading.
  d.plant.offset_x = 0.0;
  REQUIRE(d.controller.state().breach_probe >= 0);
  for (; d.t < 3 * kHour + 10 * kMinute; d.t += kMinute) {
    d.plant.advance(d.t);
    const ControllerOutput out = d.controller.on_sample(d.t, d.plant.inputs(d.t));
    INFO("t = " << d.t / kHour << " h");
    CHECK_THAT(out.prediction[0], Catch::Matchers::WithinAbs(d.plant.errors()[0], 1.0));
  }
  d.run_until(6 * kHour + kMinute, [&](double) { d.plant.offset_x = 0.0; });
  REQUIRE(d.of_type(ControllerEvent::Type::AclBreach).size() == 1);
  const auto rejected = d.of_type(ControllerEvent::Type::OutlierRejected);
  REQUIRE(rejected.size() == 1);
  CHECK(rejected[0].time_s == 3 * kHour + 10 * kMinute);  // judged by the first NG probe
  CHECK(rejected[0].value == 3 * kHour);                  // the probe set aside
  const auto phases = d.of_type(ControllerEvent::Type::PhaseChange);
  REQUIRE(phases.size() == 3);                              // CP->Post-CP, Post-CP->NG, NG->Post-CP
  CHECK(phases[1].to == Phase::NoGood);
  CHECK(phases[2].to == Phase::PostCalibration);
  CHECK(phases[2].time_s == 3 * kHour + 10 * kMinute);      // NG ends at once: no 3-probe burst
  // The outlier has weight 0 and never reached a fit: the model still predicts the plant.
  int set_aside = 0;
  for (const ProbeRecord& r : d.controller.state().probes) set_aside += r.weight == 0.0 ? 1 : 0;
  CHECK(set_aside == 1);
  CHECK(d.controller.state().probes[static_cast<std::size_t>(d.probes - 1)].weight == 1.0);
  const auto out = d.controller.on_tick(d.t);
  CHECK_THAT(out.prediction[0], Catch::Matchers::WithinAbs(d.plant.errors()[0], 0.5));
  // Post-CP resumes its hourly probes from the NG probe on.
  CHECK(d.controller.state().next_probe_due_s > 6 * kHour);
}

TEST_CASE("controller: Post-CP interval inf means no probe after CP") {
  AlcParameters p = test_parameters();
  p.post_cp_interval_s = kInf;
  Driver d(p);
  d.run_until(10 * kHour);
  CHECK(d.controller.state().probe_cycles == 24);
  CHECK(std::isinf(d.controller.state().next_probe_due_s));
}

TEST_CASE("controller: NG interval inf re-identifies at the breach without a burst") {
  AlcParameters p = paper_parameters();
  p.ng_interval_s = kInf;
  Driver d(p);
  d.run_until(3 * kHour - kMinute);
  d.plant.offset_x = 12.0;
  d.run_until(3 * kHour + kMinute);
  CHECK(d.of_type(ControllerEvent::Type::AclBreach).size() == 1);
  CHECK(d.controller.phase() == Phase::PostCalibration);
  CHECK(d.of_type(ControllerEvent::Type::ModelUpdate).size() == 2);
  CHECK(d.controller.state().ng_phases == 0);
  CHECK(d.controller.state().next_probe_due_s == 4 * kHour);
}

TEST_CASE("controller: NG measurements inf updates after each NG probe beyond the ACL and leaves at the first within") {
  AlcParameters p = paper_parameters();
  p.ng_measurements = kInf;
  Driver d(p);
  d.run_until(3 * kHour - kMinute);
  d.plant.offset_x = 12.0;
  d.run_until(5 * kHour - kMinute);
  const auto phases = d.of_type(ControllerEvent::Type::PhaseChange);
  REQUIRE(phases.size() == 3);
  CHECK(phases[1].to == Phase::NoGood);
  CHECK(phases[1].time_s == 3 * kHour);
  CHECK(phases[2].to == Phase::PostCalibration);
  CHECK(phases[2].reason == "NG probe within the ACL");
  const double back = phases[2].time_s;
  REQUIRE(back > 3 * kHour);
  // NG probes at 3h10, 3h20, ... until `back`: each one before `back` breached and was learned from.
  const int ng_probes_breached = static_cast<int>(std::lround((back - 3 * kHour) / (10 * kMinute))) - 1;
  CHECK(d.of_type(ControllerEvent::Type::ModelUpdate).size() == static_cast<std::size_t>(1 + ng_probes_breached));
  CHECK(d.of_type(ControllerEvent::Type::AclBreach).size() == static_cast<std::size_t>(1 + ng_probes_breached));
  CHECK(d.controller.state().current_interval_s == 1 * kHour);
}

TEST_CASE("controller: NG measurements 0 updates right at the breach") {
  AlcParameters p = paper_parameters();
  p.ng_measurements = 0;
  Driver d(p);
  d.run_until(3 * kHour - kMinute);
  d.plant.offset_x = 12.0;
  d.run_until(3 * kHour + kMinute);
  CHECK(d.controller.phase() == Phase::PostCalibration);
  CHECK(d.of_type(ControllerEvent::Type::ModelUpdate).size() == 2);
}

TEST_CASE("controller: invalid parameters are refused naming the field and value") {
  AlcParameters p = test_parameters();
  p.ng_measurements = 2.5;
  CHECK(p.validate() == "ng_measurements = 2.5: must be a whole number >= 0 or inf");
  p = test_parameters();
  p.cp_duration_s = kInf;
  CHECK(p.validate() == "cp_duration_s = inf: must be positive and finite");
  p = test_parameters();
  p.acl_linear_um = -1.0;
  CHECK_THROWS_WITH(Controller({"T"}, {"E_X0C"}, p), "acl_linear_um = -1: must be positive and finite");
  // The adaptive schedule: a budget beyond the ACL and no maximum interval are valid, a non-positive
  // budget and a maximum below the minimum are not.
  p = test_parameters();
  p.uncertainty_fraction = 2.0;
  p.max_interval_s = kInf;
  CHECK(p.validate().empty());
  p.uncertainty_fraction = 0.0;
  CHECK(p.validate() == "uncertainty_fraction = 0: must be positive and finite");
  p.uncertainty_fraction = 0.5;
  p.move_fraction = 0.0;
  CHECK(p.validate() == "move_fraction = 0: must be positive or inf (inf: no move check)");
  p.move_fraction = std::numeric_limits<double>::infinity();
  CHECK(p.validate().empty());
  p.move_fraction = 0.5;
  p.max_interval_s = 0.25 * kHour;
  CHECK(p.validate() == "max_interval_s = 900: must not be below min_interval_s (inf: no bound)");
}

TEST_CASE("controller: bad samples and probes are rejected with a reason and change nothing") {
  Controller c({"T"}, {"E_X0C"}, test_parameters());
  Eigen::VectorXd u(1);
  u << 20.0;
  CHECK_FALSE(c.on_probe(ProbeMeasurement{0.0, Eigen::VectorXd::Zero(1), {}}).accepted);  // before any sample
  REQUIRE(c.on_sample(60.0, u).accepted);
  const ControllerState before = c.state();
  auto rejected = [&](const ControllerOutput& out, const std::string& says) {
    INFO(out.reason);
    CHECK_FALSE(out.accepted);
    CHECK(out.reason.find(says) != std::string::npos);
    CHECK(out.events.empty());
    CHECK(c.state().samples == before.samples);
    CHECK(c.state().probe_cycles == before.probe_cycles);
    CHECK(c.state().now_s == before.now_s);
    CHECK(c.state().history.time_s == before.history.time_s);
  };
  rejected(c.on_sample(60.0, u), "not after the previous one");
  rejected(c.on_sample(30.0, u), "not after the previous one");
  rejected(c.on_probe(ProbeMeasurement{30.0, Eigen::VectorXd::Zero(1), {}}), "before the latest sample");
  rejected(c.on_probe(ProbeMeasurement{90.0, Eigen::VectorXd::Zero(2), {}}), "2 errors, expected 1");
  rejected(c.on_probe(ProbeMeasurement{90.0, Eigen::VectorXd::Constant(1, kInf), {}}), "E_X0C is inf");
  rejected(c.on_probe(ProbeMeasurement{90.0, Eigen::VectorXd::Zero(1), Eigen::VectorXd::Zero(3)}), "compensation has 3");
  Eigen::VectorXd bad(1);
  bad << std::nan("");
  rejected(c.on_sample(120.0, bad), "input 'T' is nan");
  bad << -kInf;
  rejected(c.on_sample(120.0, bad), "input 'T' is -inf");
  rejected(c.on_sample(120.0, Eigen::VectorXd::Zero(2)), "2 inputs, expected 1");
  rejected(c.on_sample(std::nan(""), u), "not finite");
  // And the controller goes on as if nothing had come.
  const ControllerOutput ok = c.on_sample(120.0, u);
  CHECK(ok.accepted);
  CHECK(c.state().samples == 2);
}

TEST_CASE("controller: after CP, memory holds the learning window plus the warm-up, not the whole run") {
  // One sample a minute for 40 days with a 2-day window: the history is trimmed to the window, the
  // warm-up of the slowest lag (5 x 20 h) and at most a quarter window of slack.
  AlcParameters p = test_parameters();
  p.learning_window_s = 2 * 86400.0;
  p.post_cp_interval_s = 6 * 3600.0;
  p.refit_on_probe = true;  // learn from every Post-CP probe: the fits run on the trimmed history
  Controller c({"T"}, {"E_X0C"}, p);
  Eigen::VectorXd u(1);
  const double bound_s = p.learning_window_s * 1.25 + kWarmupTimeConstants * p.identification.tau_max_s;
  std::size_t largest = 0;
  for (int k = 0; k < 40 * 1440; ++k) {
    const double t = k * 60.0;
    u << 20.0 + 2.0 * std::sin(t / 20000.0);
    const ControllerOutput out = c.on_sample(t, u);
    REQUIRE(out.accepted);
    if (t >= out.next_probe_due_s) {
      Eigen::VectorXd e(1);
      e << 3.0 * (u[0] - 20.0);
      c.on_probe(ProbeMeasurement{t, e, {}});
    }
    const ControllerState& s = c.state();
    largest = std::max(largest, s.history.time_s.size());
    if (k % 1440 == 0 && s.phase != Phase::Calibration) {
      INFO("day " << k / 1440);
      CHECK(s.history.time_s.back() - s.history.time_s.front() <= bound_s);
      CHECK(s.history_first_index + static_cast<std::int64_t>(s.history.time_s.size()) == s.samples);
      CHECK(s.history.inputs.rows() == static_cast<Eigen::Index>(s.history.time_s.size()));
      for (const ProbeRecord& pr : s.probes) {
        REQUIRE(pr.sample_index < s.history.time_s.size());
        CHECK(s.history.time_s[pr.sample_index] <= pr.time_s);
      }
    }
  }
  CHECK(c.state().samples == 40 * 1440);
  CHECK(c.state().history_first_index > 30 * 1440);  // most of the run is gone from memory
  CHECK(largest <= static_cast<std::size_t>(bound_s / 60.0) + 2);
  INFO("rejected fits " << c.state().rejected_fits << ", probes kept " << c.state().probes.size() << ", cycles " << c.state().probe_cycles << ", phase " << to_string(c.phase()));
  CHECK(c.state().updates > 10);  // and it kept learning from the probes of its window
}

TEST_CASE("controller: another schedule policy is consulted without touching the phase logic") {
  // A policy that probes every 30 min after CP, whatever the paper's interval says.
  struct Every30 : probing::PaperSchedule {
    using PaperSchedule::PaperSchedule;
    std::string_view name() const override { return "every-30-min"; }
    double interval(Phase phase) const override {
      return phase == Phase::PostCalibration ? 1800.0 : PaperSchedule::interval(phase);
    }
  };
  AlcParameters p = test_parameters();
  Controller c({"T"}, {"E_X0C"}, p, std::make_shared<const Every30>(p.schedule()));
  CHECK(c.schedule().name() == "every-30-min");
  Eigen::VectorXd u(1);
  std::vector<double> post_cp;
  for (int k = 0; k < 24 * 60; ++k) {
    const double t = k * 60.0;
    u << 20.0 + std::sin(t / 5000.0);
    const ControllerOutput out = c.on_sample(t, u);
    if (t >= out.next_probe_due_s) {
      if (c.phase() == Phase::PostCalibration) post_cp.push_back(t);
      Eigen::VectorXd e(1);
      e << 2.0 * (u[0] - 20.0);
      c.on_probe(ProbeMeasurement{t, e, {}});
    }
  }
  REQUIRE(post_cp.size() > 10);
  for (std::size_t i = 1; i < post_cp.size(); ++i) CHECK(post_cp[i] - post_cp[i - 1] == 1800.0);
}

TEST_CASE("controller: closed loop learns measured residual plus the active compensation") {
  Controller c({"T"}, {"E_X0C"}, test_parameters());
  Eigen::VectorXd u(1);
  u << 20.0;
  c.on_sample(0.0, u);
  Eigen::VectorXd measured(1), comp(1);
  measured << 1.5;
  comp << 4.0;
  c.on_probe(ProbeMeasurement{0.0, measured, comp});
  REQUIRE(c.state().probes.size() == 1);
  CHECK(c.state().probes[0].errors[0] == 5.5);
}

TEST_CASE("controller: a restored state continues bit for bit") {
  AlcParameters p = test_parameters();
  p.update_interval_s = 2 * kHour;
  // Save at many points; each copy continues on its own and must match the uninterrupted run.
  for (double stop : {1 * kHour, 2 * kHour, 3 * kHour + 10 * kMinute, 4 * kHour + 10 * kMinute}) {
    Driver a(p), b(p);
    a.run_until(stop);
    b.run_until(stop);
    Controller restored({"T_ENV", "n_C"}, {"E_X0C", "E_A0C"}, p, a.controller.state());
    for (double t = stop; t < 9 * kHour; t += kMinute) {
      if (t >= 4 * kHour) b.plant.offset_x = 9.0;
      b.plant.advance(t);
      const auto ob = b.controller.on_sample(t, b.plant.inputs(t));
      const auto orr = restored.on_sample(t, b.plant.inputs(t));
      REQUIRE(ob.prediction == orr.prediction);
      REQUIRE(ob.next_probe_due_s == orr.next_probe_due_s);
      REQUIRE(ob.events.size() == orr.events.size());
      if (t >= ob.next_probe_due_s) {
        ProbeMeasurement m{t, b.plant.errors(), {}};
        const auto pb = b.controller.on_probe(m);
        const auto pr = restored.on_probe(m);
        REQUIRE(pb.prediction == pr.prediction);
        REQUIRE(pb.events.size() == pr.events.size());
        for (std::size_t i = 0; i < pb.events.size(); ++i) REQUIRE(pb.events[i].reason == pr.events[i].reason);
      }
    }
    CHECK(restored.state().updates == b.controller.state().updates);
    CHECK(restored.state().updates >= 3);
  }
}

TEST_CASE("controller: the adaptive schedule lengthens the Post-CP interval while the model holds and explains each decision") {
  AlcParameters p = adaptive_parameters(0.5, 4);
  Driver d(p);
  CHECK(d.controller.schedule().name() == "adaptive");
  d.run_until(30 * kHour);
  // Every Post-CP decision is an interval event with its reason; the first is the paper's interval.
  std::vector<ControllerEvent> adaptive;
  for (const auto& e : d.of_type(ControllerEvent::Type::ProbeIntervalChange))
    if (e.reason.rfind("adaptive", 0) == 0) adaptive.push_back(e);
  REQUIRE(adaptive.size() >= 4);
  CHECK(adaptive.front().interval_s == Approx(1 * kHour));
  CHECK_THAT(adaptive.front().reason, Catch::Contains("no drift evidence") || Catch::Contains("E_X0C") ||
                                          Catch::Contains("E_A0C"));
  // The plant is the model's own structure: the residuals stay near the fit noise, the interval grows
  // to the maximum.
  CHECK(adaptive.back().interval_s == Approx(p.max_interval_s));
  CHECK_THAT(adaptive.back().reason, Catch::Contains("maximum interval"));
  for (const auto& e : adaptive) {
    CHECK(e.interval_s >= p.min_interval_s);
    CHECK(e.interval_s <= p.max_interval_s);
  }
  // The same plant with the paper's schedule probes more often after CP.
  Driver paper(test_parameters());
  paper.run_until(30 * kHour);
  CHECK(d.probes < paper.probes);
}

TEST_CASE("controller: the adaptive schedule shortens the interval when the residuals drift") {
  AlcParameters p = test_parameters();
  p.schedule_kind = AlcParameters::Schedule::Adaptive;
  p.acl_linear_um = 20.0;  // drift below the ACL: no NG, only the schedule reacts
  p.acl_angular_um_per_m = 20.0;
  p.min_interval_s = 0.25 * kHour;
  Driver d(p);
  d.run_until(3 * kHour);
  // From now on an unmodelled drift grows on E_X0C: 6 µm per hour.
  d.run_until(20 * kHour, [&](double t) { d.plant.offset_x = 6.0 * (t - 3 * kHour) / kHour; });
  std::vector<double> intervals;
  for (const auto& e : d.of_type(ControllerEvent::Type::ProbeIntervalChange))
    if (e.reason.rfind("adaptive", 0) == 0 && e.time_s > 5 * kHour) intervals.push_back(e.interval_s);
  REQUIRE(intervals.size() >= 3);
  CHECK(intervals.back() < 1 * kHour);  // shorter than the paper's interval of 1 h
}

namespace {

// Runs a copy of `state` (Post-CP, just decided) minute by minute on `inputs(t)` until a probe is due;
// returns that time and the events on the way.
std::pair<double, std::vector<ControllerEvent>> first_due(const AlcParameters& p, const ControllerState& state,
                                                          const std::function<Eigen::VectorXd(double)>& inputs) {
  Controller c({"T_ENV", "n_C"}, {"E_X0C", "E_A0C"}, p, state);
  std::vector<ControllerEvent> events;
  for (double t = state.now_s + kMinute; t < state.now_s + 24 * kHour; t += kMinute) {
    const ControllerOutput out = c.on_sample(t, inputs(t));
    events.insert(events.end(), out.events.begin(), out.events.end());
    if (t >= out.next_probe_due_s) return {t, events};
  }
  return {kInf, events};
}

}  // namespace

TEST_CASE("controller: the adaptive schedule probes earlier when the prediction moves fast, not when it stays") {
  AlcParameters p = adaptive_parameters(0.25, 4);
  Driver d(p);
  d.run_until(2 * kHour + kMinute);  // CP ended at 2 h: the first decision is the paper's 1 h
  REQUIRE(d.controller.phase() == Phase::PostCalibration);
  ControllerState s = d.controller.state();
  REQUIRE(s.schedule_since_s == 2 * kHour);
  REQUIRE(s.next_probe_due_s == 3 * kHour);
  // The evidence says: E_X0C's error grows by 1 µm² per µm² of prediction change (a model whose gain is off).
  // E_X0C's drift alone would last 2 h: E_A0C's 1 h decides, unless E_X0C's prediction moves.
  s.drift_rate(0) *= 0.5;
  s.kappa(0) = 1.0;
  Plant moving = d.plant;
  const auto [fast, fast_events] = first_due(p, s, [&](double t) {
    moving.advance(t);
    return moving.inputs(t);
  });
  // Held inputs: the prediction settles (the lag of the last 17 min) and stays.
  const Eigen::VectorXd held = d.plant.inputs(d.t - kMinute);
  const auto [still, still_events] = first_due(p, s, [&](double) { return held; });
  // The same evidence without kappa: the time alone.
  s.kappa(0) = 0.0;
  const auto [timed, timed_events] = first_due(p, s, [&](double t) {
    Plant again = d.plant;
    again.advance(t);
    return again.inputs(t);
  });
  CHECK(timed == 3 * kHour);
  CHECK(still == 3 * kHour);
  CHECK(fast < 3 * kHour);
  CHECK(fast >= 2 * kHour + p.min_interval_s);
  // One event says why the probe came early, and it is the only interval event on the way (no flood).
  REQUIRE(fast_events.size() == 1);
  CHECK(fast_events[0].type == ControllerEvent::Type::ProbeIntervalChange);
  CHECK(fast_events[0].time_s == fast);
  CHECK(fast_events[0].interval_s == Approx(fast - 2 * kHour));
  CHECK_THAT(fast_events[0].reason, Catch::Contains("probe due now") && Catch::Contains("E_X0C") &&
                                        Catch::Contains("the prediction moved by"));
  CHECK(still_events.empty());
  CHECK(timed_events.empty());
}

TEST_CASE("controller: the adaptive schedule learns kappa from a model whose gain is off, and resumes bit for bit") {
  AlcParameters p = adaptive_parameters(0.25, 4);
  p.refit_on_probe = true;
  p.acl_linear_um = 10.0;  // the gain error stays below the ACL: only the schedule reacts
  p.acl_angular_um_per_m = 30.0;
  p.uncertainty_fraction = 0.3;
  // After CP the plant's E_X0C gain grows by 0.1 µm/K an hour: the refits, on the older probes too, are
  // behind, and the residual at a probe grows with how far the lag moved since the last one.
  const auto gain_drift = [](Driver& d, double t) { d.plant.offset_x = 0.1 * (t - 2 * kHour) / kHour * d.plant.lag; };
  double kappa = 0.0;  // the largest kappa of E_X0C learned
  const auto run = [&](Driver& d, double until) {
    for (; d.t < until; d.t += kMinute) {
      d.plant.advance(d.t);
      if (d.t > 2 * kHour) gain_drift(d, d.t);
      const auto out = d.controller.on_sample(d.t, d.plant.inputs(d.t));
      d.events.insert(d.events.end(), out.events.begin(), out.events.end());
      if (d.t >= out.next_probe_due_s) {
        const auto pout = d.controller.on_probe(ProbeMeasurement{d.t, d.plant.errors(), {}});
        d.events.insert(d.events.end(), pout.events.begin(), pout.events.end());
        kappa = std::max(kappa, d.controller.state().kappa(0));
      }
    }
  };
  Driver whole(p);
  run(whole, 60 * kHour);
  CHECK(kappa > 0.0);
  int early = 0;
  for (const auto& e : whole.of_type(ControllerEvent::Type::ProbeIntervalChange)) {
    if (e.reason.rfind("adaptive: probe due now", 0) == 0) ++early;
    if (e.time_s > 2 * kHour) CHECK(e.interval_s <= p.max_interval_s);
    if (e.time_s > 2 * kHour) CHECK(e.interval_s >= p.min_interval_s);
  }
  CHECK(early > 0);
  // Saved in the middle (before, between and after early probes), restored, continued: the same run.
  for (const double stop : {2 * kHour + 20 * kMinute, 11 * kHour + 7 * kMinute, 30 * kHour + 31 * kMinute}) {
    Driver a(p);
    run(a, stop);
    Driver b(p, a.controller.state(), a);
    b.events = a.events;
    run(a, 60 * kHour);
    run(b, 60 * kHour);
    INFO("saved at " << stop / kHour << " h");
    REQUIRE(a.events.size() == b.events.size());
    for (std::size_t i = 0; i < a.events.size(); ++i) {
      REQUIRE(a.events[i].time_s == b.events[i].time_s);
      REQUIRE(a.events[i].reason == b.events[i].reason);
    }
    CHECK(a.events.size() == whole.events.size());
    CHECK(a.controller.state().kappa == b.controller.state().kappa);
    CHECK(a.controller.state().drift_rate == b.controller.state().drift_rate);
    CHECK(a.controller.state().schedule_sums == b.controller.state().schedule_sums);
    CHECK(a.controller.state().prediction == b.controller.state().prediction);
    CHECK(a.controller.state().next_probe_due_s == b.controller.state().next_probe_due_s);
  }
}

// An event of the guard's drift bound (its own test below).
bool is_drift_bound(const ControllerEvent& e) { return e.reason.rfind("compensation held", 0) == 0; }
bool is_range(const ControllerEvent& e) {
  return e.reason.rfind("compensation off", 0) == 0 || e.reason.rfind("compensation on again", 0) == 0;
}

// The errors vanish from 2 h on while no identification succeeds any more (the model stays): the
// model's predictions are wrong, no compensation would be right.
Driver wrong_model(bool guard) {
  AlcParameters p = test_parameters();
  p.acl_linear_um = 1.0;
  p.acl_angular_um_per_m = 1.0;
  p.guard = guard;
  Driver d(p);
  d.run_until(2 * kHour + kMinute);
  REQUIRE(d.controller.phase() != Phase::Calibration);
  AlcParameters frozen = p;
  frozen.identification.min_measurements = 100000;
  d.controller = d.controller.fork(frozen);
  return d;
}

void errors_vanish(Driver& d, double until_s) {
  d.run_until(until_s, [&](double) {
    d.plant.offset_x = -3.0 * d.plant.lag;
    d.plant.offset_a = 4.0 * d.plant.lag;
  });
}

TEST_CASE("controller: the guard backs compensation off where the model does worse than none, and says so") {
  for (const bool guard : {true, false}) {
    Driver d = wrong_model(guard);
    errors_vanish(d, 30 * kHour);
    const auto guards = d.of_type(ControllerEvent::Type::Guard);
    const Eigen::VectorXd model = d.controller.state().prediction;
    const ControllerOutput out = d.controller.on_tick(d.t);
    INFO("guard " << guard);
    if (guard) {
      REQUIRE_FALSE(guards.empty());
      // Each change of the gain is an event with the recent RMS without and with the prediction; the
      // drift bound and the range (their own tests below) hold the wrong prediction back too, with their
      // own events: the range's when the prediction passes the edge of the errors measured (a peak of
      // 5.756 µm, settled at 5.750 by the median of its probe and the two beside it).
      int gains = 0;
      for (const auto& e : guards) {
        if (is_drift_bound(e)) continue;
        if (is_range(e)) {
          CHECK(e.time_s > 2 * kHour);
          if (e.reason.rfind("compensation off", 0) == 0)
            CHECK((e.limit < 0.0 ? e.value < e.limit : e.value > e.limit));  // beyond the edge it names
          else
            CHECK(e.value >= e.limit);  // back within: above the lower edge
          continue;
        }
        ++gains;
        CHECK_THAT(e.reason, Catch::StartsWith("compensation gain") && Catch::Contains("uncompensated"));
        CHECK((e.output == "E_X0C" || e.output == "E_A0C"));
        CHECK(e.from == e.to);
        CHECK(e.from != Phase::Calibration);  // evidence after CP only
        CHECK(e.time_s > 2 * kHour);
        CHECK(e.value < e.limit);  // only down here: the model never gets better
        CHECK(e.value >= 0.0);
      }
      CHECK(gains > 0);
      CHECK((d.controller.state().guard_gain.array() == 0.0).all());
      CHECK(out.prediction.isZero());
      CHECK_FALSE(model.isZero());
    } else {
      CHECK(guards.empty());
      CHECK(out.prediction == model);
    }
  }
}

TEST_CASE("controller: the guard leaves a model that explains the errors alone") {
  AlcParameters p = test_parameters();
  CHECK(AlcParameters{}.guard);  // on by default
  p.refit_on_probe = true;
  Driver d(p);
  d.run_until(40 * kHour);
  REQUIRE(d.controller.state().guard_probes >= 30);
  CHECK(d.of_type(ControllerEvent::Type::Guard).empty());
  CHECK((d.controller.state().guard_gain.array() == 1.0).all());
  const ControllerOutput out = d.controller.on_tick(d.t);
  // The prediction as it is, but for the level of what the probes left, which is probe noise here.
  const ControllerState& s = d.controller.state();
  for (Eigen::Index i = 0; i < 2; ++i) {
    CHECK(out.prediction(i) == s.prediction(i) + level_of(s, i));
    CHECK(std::abs(level_of(s, i)) < 1e-3);
  }
  CHECK_FALSE(out.prediction.isZero());
}

TEST_CASE("controller: the guard's level takes out a lasting offset the model does not, learns no breach, and starts again after an NG update") {
  AlcParameters p = test_parameters();
  p.refit_on_probe = true;  // with the guard (default): the first check at 2.5 h, then a probe every hour
  Driver d(p);
  // Per Post-CP probe the error the gain-scaled prediction left (the prediction just before the probe).
  struct Seen {
    double t, left, phase_post;
  };
  std::vector<Seen> seen;
  const auto watch = [&d, &seen](double t) {
    const ControllerState& s = d.controller.state();
    seen.push_back({t, d.plant.errors()(0) - s.guard_gain(0) * s.prediction(0),
                    s.phase == Phase::PostCalibration ? 1.0 : 0.0});
  };
  d.run_until(3 * kHour + 31 * kMinute, watch);  // the first check and the probe at 3.5 h: nothing to correct
  REQUIRE(d.controller.phase() == Phase::PostCalibration);
  CHECK(std::abs(level_of(d.controller.state(), 0)) < 0.01);
  const auto levels_of = [](const std::vector<ControllerEvent>& events) {
    std::vector<ControllerEvent> r;
    for (const auto& e : events)
      if (e.type == ControllerEvent::Type::Guard && e.reason.rfind("compensation level", 0) == 0) r.push_back(e);
    return r;
  };
  CHECK(levels_of(d.events).empty());
  // From here E_X0C is 3 µm off what the model learnt (within the ACL of 5 µm: no breach, each probe is
  // learnt from), a lasting offset no input shows: the level takes it out as the probes measure it.
  d.plant.offset_x = 3.0;
  // The level is the rule's, recomputed from what each Post-CP probe left.
  const auto expected = [&seen]() {
    double sum = 0.0, weight = 0.0;
    for (const Seen& x : seen)
      if (x.phase_post != 0.0 && x.t > 2 * kHour) {
        sum = 0.5 * sum + x.left;
        weight = 0.5 * weight + 1.0;
      }
    return sum / (weight + 1.0);
  };
  const int probes = d.probes;
  while (d.probes == probes) d.run_until(d.t + kMinute, watch);  // the first probe that measures the offset
  CHECK(d.of_type(ControllerEvent::Type::AclBreach).empty());
  auto levels = levels_of(d.events);
  REQUIRE(levels.size() == 1);
  CHECK(levels[0].output == "E_X0C");
  CHECK(levels[0].time_s == seen.back().t);
  CHECK(levels[0].limit == 0.0);  // the level told before
  CHECK_THAT(seen.back().left, Catch::Matchers::WithinAbs(3.0, 0.3));
  CHECK_THAT(levels[0].value, Catch::Matchers::WithinAbs(expected(), 1e-9));
  CHECK(levels[0].value > 0.9);  // a third of it and more: the two probes before it, near 0, weigh 3/4 of one
  CHECK_THAT(levels[0].reason, Catch::Matchers::Contains("Post-CP probes within the ACL"));
  d.run_until(8 * kHour + 31 * kMinute, watch);
  REQUIRE(d.of_type(ControllerEvent::Type::AclBreach).empty());
  const ControllerState& s = d.controller.state();
  CHECK_THAT(level_of(s, 0), Catch::Matchers::WithinAbs(expected(), 1e-9));
  CHECK(s.guard_level_told(0) == levels_of(d.events).back().value);
  // Compensated: the gain-scaled prediction plus the level, within the drift bound; what the compensation
  // leaves of E_X0C is below what the prediction alone leaves, and E_A0C has no level to speak of.
  const ControllerOutput out = d.controller.on_tick(d.t);
  const double u = d.plant.errors()(0), model = s.guard_gain(0) * s.prediction(0);
  CHECK(out.prediction(0) == model + level_of(s, 0));
  CHECK(level_of(s, 0) > 0.5);
  CHECK(std::abs(u - out.prediction(0)) < std::abs(u - model) - 0.5);
  CHECK(std::abs(level_of(s, 1)) < 0.1);
  // A breach is not learnt: 12 µm more from the next probe on starts NG, the sums stay; the NG update at
  // its end refits the model on the burst and starts the level again (an event back to 0).
  const ControllerState before = d.controller.state();
  // The same run from here with every fit rejected (more measurements asked for than any window holds).
  AlcParameters rejecting_p = d.controller.parameters();
  rejecting_p.identification.min_measurements = 100000;
  Driver rejecting(rejecting_p, before, d);
  d.plant.offset_x = 15.0;
  const int probes_before = d.probes;
  while (d.probes == probes_before) d.run_until(d.t + kMinute);
  REQUIRE(d.of_type(ControllerEvent::Type::AclBreach).size() >= 1);
  CHECK(d.controller.phase() == Phase::NoGood);
  CHECK(d.controller.state().guard_level_sum(0) == before.guard_level_sum(0));
  CHECK(d.controller.state().guard_level_weight(0) == before.guard_level_weight(0));
  const std::size_t at_breach = d.events.size();
  d.run_until(d.t + 2 * kHour);
  REQUIRE(d.controller.phase() == Phase::PostCalibration);
  const std::vector<ControllerEvent> after(d.events.begin() + static_cast<std::ptrdiff_t>(at_breach), d.events.end());
  const auto reset = levels_of(after);
  REQUIRE_FALSE(reset.empty());
  CHECK(reset[0].output == "E_X0C");
  CHECK(reset[0].value == 0.0);
  CHECK_THAT(reset[0].reason, Catch::Matchers::Contains("refitted on the NG probes"));
  // Where the NG update's fit is rejected the breached model stays, and the level starts again all the
  // same: the event says the fit was rejected, not that the model was refitted.
  rejecting.plant.offset_x = 15.0;
  // Until the first NG phase has ended (the old model, still off, breaches again at the next probe).
  while (rejecting.controller.phase() != Phase::NoGood && rejecting.t < d.t) rejecting.run_until(rejecting.t + kMinute);
  while (rejecting.controller.phase() == Phase::NoGood && rejecting.t < d.t) rejecting.run_until(rejecting.t + kMinute);
  REQUIRE(rejecting.controller.phase() == Phase::PostCalibration);
  REQUIRE_FALSE(rejecting.of_type(ControllerEvent::Type::AclBreach).empty());
  CHECK(rejecting.of_type(ControllerEvent::Type::ModelUpdate).empty());
  CHECK_FALSE(rejecting.of_type(ControllerEvent::Type::ModelRejected).empty());
  CHECK(rejecting.controller.state().predictor.model().outputs[0].parameters ==
        before.predictor.model().outputs[0].parameters);
  const auto rejected_reset = levels_of(rejecting.events);
  REQUIRE_FALSE(rejected_reset.empty());
  CHECK(rejected_reset[0].output == "E_X0C");
  CHECK(rejected_reset[0].value == 0.0);
  CHECK_THAT(rejected_reset[0].reason, Catch::Matchers::Contains("fit was rejected"));
  CHECK(level_of(rejecting.controller.state(), 0) == 0.0);
  // A state saved with a level continues bit for bit.
  Driver twin(d.controller.parameters(), d.controller.state(), d);
  d.run_until(d.t + 3 * kHour);
  twin.run_until(d.t);
  CHECK(twin.controller.on_tick(twin.t).prediction == d.controller.on_tick(d.t).prediction);
  CHECK(twin.controller.state().guard_level_sum == d.controller.state().guard_level_sum);
  // Without the guard the sums are kept (the evidence is), but nothing is compensated by them or told.
  AlcParameters unguarded = p;
  unguarded.guard = false;
  Driver off(unguarded);
  off.run_until(3 * kHour + 31 * kMinute);
  off.plant.offset_x = 2.0;
  off.run_until(8 * kHour + 31 * kMinute);
  REQUIRE(off.of_type(ControllerEvent::Type::AclBreach).empty());
  CHECK(levels_of(off.events).empty());
  CHECK(level_of(off.controller.state(), 0) > 0.5);
  CHECK(off.controller.on_tick(off.t).prediction == off.controller.state().prediction);
}

TEST_CASE("controller: the guard compensates nothing of the model while the prediction leaves the measured range") {
  AlcParameters p = test_parameters();
  Driver d(p);
  d.run_until(6 * kHour);
  REQUIRE(d.of_type(ControllerEvent::Type::AclBreach).empty());  // the plant is the model's structure
  const auto [low, high] = std::pair(d.controller.state().error_low(0), d.controller.state().error_high(0));
  REQUIRE(low < high);
  // A temperature never seen (100 K above the hall): the lag and with it the prediction run far out.
  Eigen::VectorXd hot(2);
  hot << 120.0, 500.0;
  bool off = false;
  for (int i = 0; i < 120 && !off; ++i) {
    d.t += kMinute;
    const ControllerOutput out = d.controller.on_sample(d.t, hot);
    for (const auto& e : out.events)
      if (e.type == ControllerEvent::Type::Guard && e.output == "E_X0C" && !is_drift_bound(e)) {
        CHECK_THAT(e.reason, Catch::StartsWith("compensation off") && Catch::Contains("left the range"));
        CHECK(e.time_s == d.t);
        CHECK(e.from == d.controller.phase());
        CHECK(e.to == e.from);
        CHECK(e.value > e.limit);
        CHECK(e.limit > high);
        off = true;
      }
    if (off) {
      // 0: here the drift bound around the latest probe's error reaches 0 by the time the range switches
      // the model off, so it holds nothing away from 0 (where it does not: the next test).
      CHECK(out.prediction(0) == 0.0);
      CHECK(d.controller.state().prediction(0) > high);
    }
  }
  REQUIRE(off);
  // Back to normal inputs: the prediction returns into the range and compensation with it.
  bool on = false;
  for (int i = 0; i < 24 * 60 && !on; ++i) {
    d.t += kMinute;
    d.plant.advance(d.t);
    const ControllerOutput out = d.controller.on_sample(d.t, d.plant.inputs(d.t));
    for (const auto& e : out.events)
      if (e.type == ControllerEvent::Type::Guard && e.output == "E_X0C" && !is_drift_bound(e)) {
        CHECK_THAT(e.reason, Catch::StartsWith("compensation on again"));
        CHECK(e.limit <= e.value);  // back within the range: above its lower bound
        on = true;
        // Compensated again: the prediction with its gain, within the drift bound around the latest probe's
        // error (test below), i.e. between that error and the prediction.
        const double g = d.controller.state().prediction(0) * d.controller.state().guard_gain(0) +
                         level_of(d.controller.state(), 0);
        const double anchor = d.controller.state().probes.back().errors(0);
        CHECK(out.prediction(0) >= std::min(g, anchor));
        CHECK(out.prediction(0) <= std::max(g, anchor));
        CHECK(out.prediction(0) != 0.0);
      }
  }
  CHECK(on);
  // Without the guard the same run compensates the far prediction.
  AlcParameters unguarded = p;
  unguarded.guard = false;
  Driver u(unguarded);
  u.run_until(6 * kHour);
  ControllerOutput out;
  for (int i = 0; i < 120; ++i) out = u.controller.on_sample(u.t += kMinute, hot);
  CHECK(out.prediction(0) == u.controller.state().prediction(0));
  CHECK(out.prediction(0) > high);
}

// The fastest |change| of output 0's error between two probes at least `span_s` apart, each probe
// paired with the latest one that far before it, every probe but the first and the latest taken as the
// median of itself and the probes beside it (the rule of docs/adaptive.md, recomputed here; `settle`
// false: the probes' values as they are).
double fastest_drift(const ControllerState& s, double span_s, bool settle = true) {
  const auto& probes = s.probes;
  std::vector<double> v(probes.size());
  for (std::size_t k = 0; k < probes.size(); ++k) {
    v[k] = probes[k].errors(0);
    if (settle && k > 0 && k + 1 < probes.size()) {
      std::array<double, 3> three{probes[k - 1].errors(0), v[k], probes[k + 1].errors(0)};
      std::sort(three.begin(), three.end());
      v[k] = three[1];
    }
  }
  double rate = 0.0;
  for (std::size_t j = 0; j < probes.size(); ++j)
    for (std::size_t k = j; k-- > 0;)
      if (probes[j].time_s - probes[k].time_s >= span_s) {
        rate = std::max(rate, std::abs(v[j] - v[k]) / (probes[j].time_s - probes[k].time_s));
        break;
      }
  return rate;
}

TEST_CASE("controller: off by the range, compensation is the latest probe's error fading towards 0 within the drift bound") {
  // E_X0C sits about 40 µm from 0 (a lasting offset the probes measure); the inputs then jump to a
  // temperature never seen, the prediction leaves the range and the model's compensation goes off. What
  // remains is what the latest probes bound: that probe's error, fading towards 0 no faster than twice
  // the fastest drift the probes measured, not a step to 0 (H7 at seed 72: E_X0C 18 µm off for half an
  // hour during an NG burst whose probes had just measured it).
  AlcParameters p = test_parameters();
  Driver d(p);
  d.plant.offset_x = 40.0;
  d.run_until(6 * kHour + kMinute);  // the probe at 6 h is the latest
  REQUIRE(d.of_type(ControllerEvent::Type::AclBreach).empty());
  const ControllerState& s = d.controller.state();
  REQUIRE(s.probes.back().time_s == 6 * kHour);
  const double anchor = s.probes.back().errors(0);
  REQUIRE(anchor > 30.0);
  Eigen::VectorXd hot(2);
  hot << 120.0, 500.0;
  double off_at = -1.0, last = 0.0;
  bool held_at_off = false, held_told_at_off = false, released_told = false;
  for (int i = 0; i < 8 * 60; ++i) {
    d.t += kMinute;
    const ControllerOutput out = d.controller.on_sample(d.t, hot);  // no probe: the bound only widens
    for (const auto& e : out.events) {
      if (e.type != ControllerEvent::Type::Guard || e.output != "E_X0C") continue;
      if (e.reason.rfind("compensation off", 0) == 0) {
        CHECK_THAT(e.reason, Catch::Contains("left the range") && Catch::Contains("fading towards 0 within"));
        off_at = d.t;
      }
      // Before the switch the bound may hold the running-away prediction back (its own event); at the
      // switch, still holding, it is told again with what it now holds back: 0, not the model.
      if (e.reason.rfind("compensation held to", 0) == 0 && off_at >= 0.0) {
        CHECK_THAT(e.reason, Catch::Contains("off by the range") && Catch::Contains("fades towards 0"));
        CHECK(e.value == 0.0);
        if (e.time_s == off_at) held_told_at_off = true;
      }
      if (e.reason.rfind("compensation held no more than the ACL", 0) == 0 && off_at >= 0.0) {
        CHECK_THAT(e.reason, Catch::Contains("off by the range"));
        CHECK(std::abs(out.prediction(0)) <= p.acl_linear_um);
        released_told = true;
      }
    }
    if (off_at < 0.0) continue;
    REQUIRE(s.guard_off_range(0) == 1.0);
    const double c = out.prediction(0);
    if (d.t == off_at) {
      // Not 0 at the switch: within the drift bound of the latest probe's error, on its side of 0.
      CHECK(c > 0.0);
      CHECK(c <= anchor);
      // Held back from 0 by more than the ACL: the guard's held state, told at the switch (above) and
      // again when the bound reaches within the ACL of 0.
      held_at_off = c > p.acl_linear_um;
      CHECK((s.guard_held(0) == 1.0) == held_at_off);
    } else {
      CHECK(c <= last);  // fading, never back up while no probe comes
      CHECK(c >= 0.0);   // towards 0, never past it
    }
    last = c;
  }
  REQUIRE(off_at > 0.0);
  REQUIRE(held_at_off);  // the case this test is about: 40 µm from 0 and a slow drift
  CHECK(held_told_at_off);
  CHECK(released_told);
  CHECK(last == 0.0);  // the bound reached 0 hours later: nothing is compensated then
}

TEST_CASE("controller: the guard holds compensation within the drift the probes have measured") {
  for (const bool guard : {true, false}) {
    AlcParameters p = test_parameters();
    p.guard = guard;
    p.acl_linear_um = 2.0;  // the model explains this plant: no breach, and a hold beyond 2 µm is an event
    Driver d(p);
    d.run_until(6 * kHour + kMinute);  // just after the probe at 6 h
    REQUIRE(d.of_type(ControllerEvent::Type::AclBreach).empty());
    const ControllerState before = d.controller.state();
    REQUIRE(before.probes.back().time_s == 6 * kHour);
    const double anchor = before.probes.back().errors(0);
    const double anchor_s = before.probes.back().time_s;
    const double rate = fastest_drift(before, 1 * kHour);  // probes at least 1 h apart
    REQUIRE(rate > 0.0);
    // 3 K above the warmest hour of the run, for 2 h without a probe: the prediction leaves the latest
    // probe's error far faster than any drift measured, but stays within the measured range.
    Eigen::VectorXd warm(2);
    warm << 25.0, 500.0;
    int held = 0, events = 0;
    for (int i = 0; i < 120; ++i) {
      d.t += kMinute;
      const ControllerOutput out = d.controller.on_sample(d.t, warm);
      d.events.insert(d.events.end(), out.events.begin(), out.events.end());
      const ControllerState& s = d.controller.state();
      INFO("guard " << guard << ", t = " << d.t / kHour << " h");
      REQUIRE(s.guard_off_range(0) == 0.0);  // the range's switch is not what acts here
      const double g = s.prediction(0) * s.guard_gain(0) + level_of(s, 0);
      if (!guard) {
        CHECK(out.prediction(0) == s.prediction(0));
        continue;
      }
      // Within the latest probe's error +- 2 x the fastest drift x the time since, as near g as that allows.
      const double reach = 2.0 * rate * (d.t - anchor_s);
      CHECK(out.prediction(0) >= anchor - reach - 1e-9);
      CHECK(out.prediction(0) <= anchor + reach + 1e-9);
      if (out.prediction(0) != g) {
        ++held;
        CHECK(std::abs(std::abs(out.prediction(0) - anchor) - reach) < 1e-9);  // held at the bound's edge
      }
      for (const auto& e : out.events)
        if (e.type == ControllerEvent::Type::Guard && e.output == "E_X0C") {
          // First the hold starts (held back by more than the ACL), then, as the bound widens with the
          // time since the probe, it ends; no event in between.
          ++events;
          CHECK(e.time_s == d.t);
          CHECK(e.value == Approx(g));
          if (events == 1) {
            CHECK_THAT(e.reason, Catch::StartsWith("compensation held to") && Catch::Contains("latest probe"));
            CHECK(std::abs(e.value - e.limit) > p.acl_linear_um);
            CHECK(s.guard_held(0) == 1.0);
          } else {
            CHECK_THAT(e.reason, Catch::StartsWith("compensation held no more than the ACL"));
            CHECK(std::abs(e.value - e.limit) <= p.acl_linear_um);
            CHECK(s.guard_held(0) == 0.0);
          }
        }
    }
    INFO("prediction " << d.controller.state().prediction(0) << ", anchor " << anchor << " at " << anchor_s / kHour << " h, rate " << rate * kHour << " per h, held before " << before.guard_held(0));
    if (guard) {
      CHECK(held > 60);
      CHECK(events == 2);
      // The model's prediction at the end is beyond what 2 x the drift allows 1 h after the probe.
      CHECK(std::abs(d.controller.state().prediction(0) - anchor) > p.acl_linear_um + 2.0 * rate * kHour);
    } else {
      CHECK(d.of_type(ControllerEvent::Type::Guard).empty());
    }
  }
}

TEST_CASE("controller: a chip on the sphere during CP widens neither the guard's range nor its drift bound") {
  // No breach judges a CP probe: the chip (+10 µm on E_X0C at the probe at 1 h only) enters the probes,
  // and the probes beside it settle it away (the median of three).
  AlcParameters p = test_parameters();
  p.acl_linear_um = 2.0;  // a hold beyond 2 µm is an event
  Driver clean(p), chipped(p);
  clean.run_until(2 * kHour + kMinute);  // CP ends with the sample at 2 h
  chipped.run_until(2 * kHour + kMinute, [&](double t) { chipped.plant.offset_x = t == 1 * kHour ? 10.0 : 0.0; });
  const ControllerState& c = clean.controller.state();
  const ControllerState& s = chipped.controller.state();
  REQUIRE(s.phase == Phase::PostCalibration);
  REQUIRE(s.probes.size() == c.probes.size());
  double highest = -std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < s.probes.size(); ++k) {
    INFO("probe at " << s.probes[k].time_s / kHour << " h");
    CHECK(s.probes[k].errors(0) == c.probes[k].errors(0) + (s.probes[k].time_s == 1 * kHour ? 10.0 : 0.0));
    highest = std::max(highest, s.probes[k].errors(0));
  }
  // The range: as without the chip, which lies above it.
  CHECK(s.error_low(0) == c.error_low(0));
  CHECK(s.error_high(0) == c.error_high(0));
  CHECK(highest > s.error_high(0) + 5.0);
  // The drift bound: its rate is the settled one, a third of what the chip would make it, and near the
  // clean run's (the chip's place takes the value of a probe beside it, 5 min away).
  const double rate = fastest_drift(s, 1 * kHour);
  REQUIRE(fastest_drift(s, 1 * kHour, false) > 3.0 * rate);
  CHECK(rate < 1.1 * fastest_drift(c, 1 * kHour));
  // A temperature far above the run's: the (chip-bent) model's prediction runs off, the bound holds it,
  // and the hold's edge is the latest probe's error + 2 x the settled rate x the time since.
  const ProbeRecord& latest = s.probes.back();
  Eigen::VectorXd hot(2);
  hot << 30.0, 500.0;
  bool held = false;
  for (int i = 0; i < 60 && !held; ++i) {
    chipped.t += kMinute;
    const ControllerOutput out = chipped.controller.on_sample(chipped.t, hot);
    for (const auto& e : out.events)
      if (e.type == ControllerEvent::Type::Guard && e.output == "E_X0C") {
        INFO(e.reason);
        REQUIRE(is_drift_bound(e));
        CHECK(e.limit == Approx(latest.errors(0) + 2.0 * rate * (chipped.t - latest.time_s)));
        CHECK(out.prediction(0) == Approx(e.limit));
        held = true;
      }
  }
  CHECK(held);
}

TEST_CASE("controller: a state saved while the guard backs off continues bit for bit") {
  Driver d = wrong_model(true);
  errors_vanish(d, 12 * kHour);
  // Mid-way: some gain below 1 already, not yet all at 0.
  const ControllerState saved = d.controller.state();
  REQUIRE(saved.guard_probes >= 12);
  REQUIRE((saved.guard_gain.array() < 1.0).any());
  Controller restored({"T_ENV", "n_C"}, {"E_X0C", "E_A0C"}, d.controller.parameters(), saved);
  for (double t = d.t; t < 30 * kHour; t += kMinute) {
    d.plant.advance(t);
    const auto od = d.controller.on_sample(t, d.plant.inputs(t));
    const auto orr = restored.on_sample(t, d.plant.inputs(t));
    REQUIRE(od.prediction == orr.prediction);
    REQUIRE(od.events.size() == orr.events.size());
    if (t >= od.next_probe_due_s) {
      d.plant.offset_x = -3.0 * d.plant.lag;
      d.plant.offset_a = 4.0 * d.plant.lag;
      ProbeMeasurement m{t, d.plant.errors(), od.prediction};
      m.measured -= od.prediction;  // closed loop: the probe sees what compensation leaves
      const auto pd = d.controller.on_probe(m);
      const auto pr = restored.on_probe(m);
      REQUIRE(pd.prediction == pr.prediction);
      REQUIRE(pd.events.size() == pr.events.size());
      for (std::size_t i = 0; i < pd.events.size(); ++i) REQUIRE(pd.events[i].reason == pr.events[i].reason);
    }
  }
  CHECK(restored.state().guard_gain == d.controller.state().guard_gain);
  CHECK(restored.state().guard_cross == d.controller.state().guard_cross);
  CHECK((restored.state().guard_gain.array() == 0.0).all());
}

TEST_CASE("controller: an implausible error is set aside for its output alone and the other output is learned") {
  AlcParameters p = test_parameters();
  Plant plant;
  Controller c({"T_ENV", "n_C"}, {"E_X0C", "E_A0C"}, p);
  std::vector<ControllerEvent> implausible;
  int probes = 0, updates = 0;
  double t = 0.0;
  for (; t < 2.5 * kHour; t += kMinute) {
    plant.advance(t);
    const auto out = c.on_sample(t, plant.inputs(t));
    REQUIRE(out.accepted);
    for (const auto& e : out.events) updates += e.type == ControllerEvent::Type::ModelUpdate;
    if (t < out.next_probe_due_s) continue;
    Eigen::VectorXd measured = plant.errors();
    measured(1) = 1e300;  // a sensor fault: finite, absurd
    ProbeMeasurement m{t, measured, {}};
    // Judged on what the probe would learn from: as if E_A0C had not been measured.
    ProbeMeasurement without = m;
    without.measured(1) = std::numeric_limits<double>::quiet_NaN();
    CHECK(c.breaches_acl(m) == c.breaches_acl(without));
    without.measured(0) = 1e300;  // only an implausible reading left: no breach
    CHECK_FALSE(c.breaches_acl(without));
    const auto pout = c.on_probe(m);
    REQUIRE(pout.accepted);
    ++probes;
    for (const auto& e : pout.events) {
      if (e.type == ControllerEvent::Type::Implausible) implausible.push_back(e);
      if (e.type == ControllerEvent::Type::ModelUpdate) ++updates;
    }
  }
  REQUIRE(probes > 6);
  REQUIRE(implausible.size() == static_cast<std::size_t>(probes));
  CHECK(implausible[0].output == "E_A0C");
  CHECK(implausible[0].value == 1e300);
  CHECK(implausible[0].limit == p.plausible_angular_um_per_m);
  CHECK_THAT(implausible[0].reason, Catch::Matchers::Contains("E_A0C = 1e+300 µm/m is beyond the plausible ±1000 µm/m"));
  // E_X0C is learned (CP ended with a model), E_A0C has none: not compensated.
  CHECK(updates >= 1);
  CHECK(c.phase() == Phase::PostCalibration);
  for (const auto& probe : c.state().probes) CHECK(std::isnan(probe.errors(1)));
  const auto now = c.on_tick(t);
  CHECK_THAT(now.prediction[0], Catch::Matchers::WithinAbs(plant.errors()[0], 0.5));
  CHECK(now.prediction[1] == 0.0);

  // A probe with no plausible error left is rejected, naming each, and changes nothing.
  const int cycles = c.state().probe_cycles;
  Eigen::VectorXd both(2);
  both << -2000.0, std::numeric_limits<double>::quiet_NaN();
  const auto rejected = c.on_probe({t, both, {}});
  CHECK_FALSE(rejected.accepted);
  CHECK_THAT(rejected.reason, Catch::Matchers::Contains("no plausible error (E_X0C = -2000 beyond ±1000"));
  CHECK(c.state().probe_cycles == cycles);
}

TEST_CASE("controller: an implausible input (a sensor fault) rejects the sample with a limit per input kind") {
  AlcParameters p = test_parameters();
  Controller c({"T_ENV", "n_C", "CF_on"}, {"E_X0C"}, p);
  Eigen::VectorXd u(3);
  u << 21.0, 1000.0, 1.0;
  REQUIRE(c.on_sample(0.0, u).accepted);
  const auto expect_rejected = [&](Eigen::Index i, double v, const std::string& reason) {
    Eigen::VectorXd bad = u;
    bad(i) = v;
    const auto out = c.on_sample(60.0, bad);
    CHECK_FALSE(out.accepted);
    CHECK_THAT(out.reason, Catch::Matchers::Contains(reason));
  };
  expect_rejected(0, -1e308, "input 'T_ENV' = -1e+308 °C is beyond the plausible ±200 °C");
  expect_rejected(0, 250.0, "input 'T_ENV' = 250 °C is beyond the plausible ±200 °C");
  expect_rejected(1, 2e5, "input 'n_C' = 200000 rpm is beyond the plausible ±100000 rpm");
  expect_rejected(2, 5e6, "input 'CF_on' = 5e+06 is beyond the plausible ±1e+06 (a sensor fault?)");
  CHECK(c.state().samples == 1);
  Eigen::VectorXd hot = u;
  hot(0) = 199.0;  // within the limit
  CHECK(c.on_sample(60.0, hot).accepted);
  // inf: no limit.
  p.plausible_temperature_C = kInf;
  Controller unlimited({"T_ENV", "n_C", "CF_on"}, {"E_X0C"}, p);
  hot(0) = 1e300;
  CHECK(unlimited.on_sample(0.0, hot).accepted);
}

TEST_CASE("controller: plausibility limits must be positive or inf") {
  AlcParameters p;
  p.plausible_linear_um = 0.0;
  CHECK_THROWS_WITH(Controller({"T"}, {"E_X0C"}, p), "plausible_linear_um = 0: must be positive or inf (inf: no limit)");
  p = AlcParameters{};
  p.plausible_speed_rpm = std::numeric_limits<double>::quiet_NaN();
  CHECK_THROWS_WITH(Controller({"T"}, {"E_X0C"}, p), Catch::Matchers::Contains("plausible_speed_rpm = nan"));
}
