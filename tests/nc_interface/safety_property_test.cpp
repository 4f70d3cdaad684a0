// Property test of the NC safety gate (issue 13): random command streams through recorder_for() and
// write_program(), every line read back from the NC code as the control would hold it. Whatever the
// stream, the offsets the control holds never exceed max_offset and never change by more than
// max_step from one activation to the next, per axis and offset register.
#include <catch2/catch.hpp>

#include <array>
#include <cmath>
#include <cstdlib>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "nc_interface/dialects.hpp"
#include "nc_interface/nc_number.hpp"
#include "nc_interface/recorder.hpp"

using namespace alc::nc;

namespace {

constexpr const char* kAxes = "XYZABC";
using Ticks = std::array<long long, 6>;  // X Y Z A B C in 0.0001 mm / 0.0001 deg

int axis_index(char letter) {
  for (int i = 0; i < 6; ++i)
    if (kAxes[i] == letter) return i;
  return -1;
}

std::array<double, 6> as_array(const AxisLimits& l) { return {l.x_mm, l.y_mm, l.z_mm, l.a_deg, l.b_deg, l.c_deg}; }

long long ticks_of(const std::string& number) { return std::llround(std::stod(number) * kNcTicksPerUnit); }

// The control: per register the values it holds (base included for G10 L2), checked at each
// activation against the last activation of the same register.
struct Control {
  SafetyLimits limits;
  std::array<Ticks, 7> base{};              // printed base per work offset (G10 L2 dialects)
  std::map<int, Ticks> held, active;        // by register
  std::vector<std::string> violations;
  std::size_t activations = 0;

  Ticks& held_of(int reg) {
    auto it = held.find(reg);
    if (it == held.end()) it = held.emplace(reg, base[static_cast<std::size_t>(reg)]).first;
    return it->second;
  }
  void activate(int reg, const std::string& line) {
    ++activations;
    const Ticks now = held_of(reg);
    const Ticks before = active.count(reg) ? active[reg] : base[static_cast<std::size_t>(reg)];
    const auto max_offset = as_array(limits.max_offset), max_step = as_array(limits.max_step);
    for (std::size_t i = 0; i < 6; ++i) {
      const long long comp = now[i] - base[static_cast<std::size_t>(reg)][i];
      const long long step = now[i] - before[i];
      if (static_cast<double>(std::llabs(comp)) / kNcTicksPerUnit > max_offset[i])
        violations.push_back("offset " + std::string(1, kAxes[i]) + " beyond max_offset after '" + line + "'");
      if (static_cast<double>(std::llabs(step)) / kNcTicksPerUnit > max_step[i])
        violations.push_back("step " + std::string(1, kAxes[i]) + " beyond max_step at '" + line + "'");
    }
    active[reg] = now;
  }
};

// Reads "X0.0012 Y-0.0004 ..." words after `from` into `t`.
void read_words(const std::string& line, std::size_t from, Ticks& t) {
  std::istringstream words(line.substr(from));
  for (std::string w; words >> w;)
    if (const int i = axis_index(w[0]); i >= 0 && w.size() > 1) t[static_cast<std::size_t>(i)] = ticks_of(w.substr(1));
}

void read_back(Dialect dialect, const std::string& program, Control& control) {
  std::istringstream in(program);
  bool cycle_open = false;  // heidenhain: a CYCL DEF 7 being defined
  for (std::string line; std::getline(in, line);) {
    if (dialect == Dialect::LinuxCNC || dialect == Dialect::Fanuc) {
      const auto at = line.find("G10 L2 P");
      if (at == std::string::npos) continue;
      const int reg = line[at + 8] - '0';
      read_words(line, at + 9, control.held_of(reg));
      control.activate(reg, line);
    } else if (dialect == Dialect::Sinumerik) {
      if (line.rfind("$P_UIFR[", 0) == 0) {
        const int reg = line[8] - '0';
        const int i = axis_index(line[10]);
        control.held_of(reg)[static_cast<std::size_t>(i)] = ticks_of(line.substr(line.find('=') + 1));
      } else if (line == "G54" || line == "G55" || line == "G56" || line == "G57" || line == "G505" || line == "G506") {
        const int reg = line.size() == 3 ? line[2] - '3' : line[3] - '0';
        control.activate(reg, line);
      }
    } else {
      const auto at = line.find("CYCL DEF 7.");
      const bool sub = at != std::string::npos && line.compare(at, 13, "CYCL DEF 7.0 ") != 0;
      if (sub) {
        const std::string word = line.substr(at + 13);
        const int i = axis_index(word[0]);
        control.held_of(0)[static_cast<std::size_t>(i)] = ticks_of(word.substr(1));
        cycle_open = true;
        continue;
      }
      if (cycle_open) control.activate(0, line);
      cycle_open = false;
    }
  }
}

double uniform(std::mt19937_64& rng, double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); }

}  // namespace

TEST_CASE("safety property: 10^4 random streams never put an offset or a step beyond the limits on the control",
          "[nc][safety][property]") {
  std::mt19937_64 rng(20261123);  // explicit seed: a failure is reproducible
  const Dialect dialects[] = {Dialect::LinuxCNC, Dialect::Fanuc, Dialect::Sinumerik, Dialect::Heidenhain};
  std::size_t accepted = 0, split = 0, refused = 0, activations = 0;
  for (int stream = 0; stream < 10000; ++stream) {
    const Dialect dialect = dialects[rng() % 4];
    Control control;
    SafetyLimits& l = control.limits;
    // Limits that are not multiples of the resolution, from one tick up (below it validate() refuses
    // them: checked after the loop).
    for (double* v : {&l.max_offset.x_mm, &l.max_offset.y_mm, &l.max_offset.z_mm})
      *v = uniform(rng, 0.0001, 0.05);
    for (double* v : {&l.max_offset.a_deg, &l.max_offset.b_deg, &l.max_offset.c_deg}) *v = uniform(rng, 0.0001, 0.01);
    for (double* v : {&l.max_step.x_mm, &l.max_step.y_mm, &l.max_step.z_mm}) *v = uniform(rng, 0.0001, 0.01);
    for (double* v : {&l.max_step.a_deg, &l.max_step.b_deg, &l.max_step.c_deg}) *v = uniform(rng, 0.0001, 0.002);
    l.on_step_violation = rng() % 2 ? StepAction::Split : StepAction::Refuse;
    l.max_split_steps = 1 + static_cast<int>(rng() % 30);
    DialectOptions options;
    if (dialect == Dialect::LinuxCNC || dialect == Dialect::Fanuc) {
      for (std::size_t w = 0; w < 6; ++w) {
        BaseOffset& b = options.base[w];
        for (double* v : {&b.x_mm, &b.y_mm, &b.z_mm, &b.a_deg, &b.b_deg, &b.c_deg})
          *v = std::round(uniform(rng, -500.0, 500.0) * 1e6) / 1e6;
        const double values[] = {b.x_mm, b.y_mm, b.z_mm, b.a_deg, b.b_deg, b.c_deg};
        for (std::size_t i = 0; i < 6; ++i) control.base[w + 1][i] = nc_ticks(values[i]);
      }
    }
    CommandRecorder recorder = recorder_for(dialect, l);
    const auto lim = as_array(l.max_offset), step = as_array(l.max_step);
    const int n = 1 + static_cast<int>(rng() % 25);
    for (int k = 0; k < n; ++k) {
      if (rng() % 8 == 0) {
        recorder.record(ProbeInterval{uniform(rng, 1.0, 120.0), std::nullopt});
        continue;
      }
      // Mostly a walk from what the gate let through (steps around max_step), sometimes a jump
      // anywhere within ±1.3 max_offset.
      const int w = 1 + static_cast<int>(rng() % (rng() % 3 == 0 ? 6 : 2));
      const bool walk = rng() % 3 != 0;
      const AxisOffsets from = recorder.current(w);
      const auto value = [&](std::size_t i, double now) {
        return walk ? now + uniform(rng, -1.2, 1.2) * step[i] : uniform(rng, -1.3, 1.3) * lim[i];
      };
      AxisOffsets o;
      o.work_offset = w;
      o.x_mm = value(0, from.x_mm);
      o.y_mm = value(1, from.y_mm);
      o.z_mm = value(2, from.z_mm);
      o.c_deg = value(5, from.c_deg);
      switch (rng() % 4) {  // mixed rotary axes: A, B, or neither written
        case 0: o.a_deg = value(3, from.a_deg.value_or(0.0)); o.b_deg.reset(); break;
        case 1: o.a_deg.reset(); o.b_deg = value(4, from.b_deg.value_or(0.0)); break;
        case 2: o.a_deg.reset(); o.b_deg.reset(); break;
        default: o.a_deg = value(3, from.a_deg.value_or(0.0)); o.b_deg.reset(); break;
      }
      const SafetyDecision d = recorder.record(o);
      accepted += d.verdict == SafetyVerdict::Accepted;
      split += d.verdict == SafetyVerdict::Split;
      refused += d.verdict == SafetyVerdict::Refused;
    }
    read_back(dialect, write_program(dialect, recorder.to_send(), options), control);
    activations += control.activations;
    if (!control.violations.empty()) {
      INFO("stream " << stream << ", dialect " << dialect_name(dialect));
      FAIL(control.violations.front());
    }
  }
  // Every path of the gate was taken, and the control did see offsets.
  CHECK(accepted > 1000);
  CHECK(split > 100);
  CHECK(refused > 1000);
  CHECK(activations >= accepted + split);
  // A limit below one tick would refuse every step the NC can take: refused before any stream.
  SafetyLimits below;
  below.max_step.y_mm = 0.00005;
  CHECK_THAT(validate(below), Catch::Contains("max_step of axis Y must be at least the NC resolution"));
  below = SafetyLimits{};
  below.max_offset.c_deg = 0.00003;
  CHECK_THAT(validate(below), Catch::Contains("max_offset of axis C must be at least the NC resolution"));
  below = SafetyLimits{};
  below.step_period_s = 0.0;
  CHECK(validate(below) == "step_period_s must be > 0 and finite, got 0");
}
