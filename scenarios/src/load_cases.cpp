#include "scenarios/load_cases.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "scenarios/random_processes.hpp"
#include "scenarios/spindle_twin.hpp"

namespace alc::scenarios {

namespace {

constexpr double kHour = 3600.0;  // [s]
constexpr double kDay = 24.0 * kHour;
constexpr double kPi = 3.141592653589793;
constexpr double kErrorResolution = 0.001;  // [µm], [µm/m] rounding of written errors

// Independent random streams of one simulation (see SeededRandom::derive_seed).
enum Stream : std::uint64_t { kAmbientStream = 1, kProductionStream, kFluidStream, kDriftStream, kSensorStream, kProbeStream,
                              kHiddenStream };

SeededRandom stream(std::uint64_t seed, Stream s) { return SeededRandom(SeededRandom::derive_seed(seed, s)); }

// Seconds since Monday 00:00 -> weekday (0 = Monday) and hour of day.
int weekday_of(double week_s) { return static_cast<int>(std::floor(week_s / kDay)) % 7; }
double hour_of(double week_s) { return std::fmod(week_s, kDay) / kHour; }

double log_uniform(SeededRandom& random, double lo, double hi) {
  return std::exp(random.uniform(std::log(lo), std::log(hi)));
}

// Hall air at each sample; the run starts `start_s` after Monday 00:00.
std::vector<double> ambient_series(const AmbientParams& p, std::size_t samples, double step_s, double start_s,
                                   SeededRandom& random) {
  struct DoorEvent {
    double open_s, close_s, drop_K, recovery_s;
  };
  constexpr double kDoorFall_s = 180.0;  // [s] how fast the air near the door cools while it is open
  OrnsteinUhlenbeck weather(p.weather_sigma_K, p.weather_time_constant_h * kHour, step_s);
  std::vector<DoorEvent> doors;
  std::vector<double> ambient(samples);
  for (std::size_t k = 0; k < samples; ++k) {
    const double t = static_cast<double>(k) * step_s;
    const double week_s = start_s + t;
    const double h = hour_of(week_s);
    const bool hall_working = weekday_of(week_s) < 5 && h >= p.work_start_h && h < p.work_end_h;
    const double rate = (hall_working ? p.door_rate_work_per_h : p.door_rate_off_per_h) / kHour;  // [1/s]
    if (random.chance(rate * step_s)) {
      const double open = 60.0 * random.uniform(p.door_open_min_min, p.door_open_max_min);
      doors.push_back({t, t + open, random.uniform(p.door_drop_min_K, p.door_drop_max_K),
                       60.0 * random.uniform(p.door_recovery_min_min, p.door_recovery_max_min)});
    }
    double deficit = 0.0;  // [K] cooling by open or recently opened doors
    for (const DoorEvent& d : doors) {
      if (t < d.open_s) continue;
      const double at_close = d.drop_K * (1.0 - std::exp(-(std::min(t, d.close_s) - d.open_s) / kDoorFall_s));
      deficit += t <= d.close_s ? at_close : at_close * std::exp(-(t - d.close_s) / d.recovery_s);
    }
    std::erase_if(doors, [&](const DoorEvent& d) { return t > d.close_s + 8.0 * d.recovery_s; });
    ambient[k] = p.base_C + p.daily_amplitude_K * std::cos(2.0 * kPi * (h - p.daily_peak_hour) / 24.0) +
                 weather.step(random) - deficit;
  }
  return ambient;
}

// Speed at each sample: jobs of random length and speed inside the shifts, standstill outside.
std::vector<double> speed_series(const ProductionPattern& p, std::size_t samples, double step_s, double start_s,
                                 double speed_resolution_rpm, SeededRandom& random) {
  std::vector<double> speed(samples, 0.0);
  std::size_t k = 0;
  while (k < samples) {
    const double week_s = start_s + static_cast<double>(k) * step_s;
    const double h = hour_of(week_s);
    const bool working = weekday_of(week_s) < p.working_days && h >= p.shift_start_h && h < p.shift_end_h;
    if (!working) {
      ++k;
      continue;
    }
    const double job_s = 60.0 * random.uniform(p.job_min_min, p.job_max_min);
    const double rpm = random.chance(p.idle_share)
                           ? 0.0
                           : quantise(random.uniform(p.speed_min_rpm, p.speed_max_rpm), speed_resolution_rpm);
    const double shift_end_s = week_s - h * kHour + p.shift_end_h * kHour;
    const double end_s = std::min(week_s + job_s, shift_end_s);
    for (; k < samples && start_s + static_cast<double>(k) * step_s < end_s; ++k) speed[k] = rpm;
  }
  return speed;
}

// Cutting-fluid state at each sample: alternating off / on intervals, starting off.
std::vector<bool> fluid_series(const FluidPattern& p, std::size_t samples, double step_s, SeededRandom& random) {
  std::vector<bool> on(samples, false);
  if (!p.enabled) return on;
  double t = 0.0;
  bool state = false;
  std::size_t k = 0;
  while (k < samples) {
    const double length_s = 60.0 * (state ? log_uniform(random, p.on_min_min, p.on_max_min)
                                          : log_uniform(random, p.off_min_min, p.off_max_min));
    t += length_s;
    for (; k < samples && static_cast<double>(k) * step_s < t; ++k) on[k] = state;
    state = !state;
  }
  return on;
}

// samples x errors of independent OU drifts, each with the sigma of its kind.
Eigen::MatrixXd drift_series(const std::vector<double>& sigma, double time_constant_h, std::size_t samples,
                             double step_s, SeededRandom& random) {
  Eigen::MatrixXd drift(static_cast<Eigen::Index>(samples), static_cast<Eigen::Index>(sigma.size()));
  for (std::size_t e = 0; e < sigma.size(); ++e) {
    OrnsteinUhlenbeck process(sigma[e], time_constant_h * kHour, step_s);
    for (std::size_t k = 0; k < samples; ++k) drift(static_cast<Eigen::Index>(k), static_cast<Eigen::Index>(e)) = process.step(random);
  }
  return drift;
}

double sensor_reading(double truth, const SensorParams& s, SeededRandom& random) {
  return quantise(truth + random.normal(s.noise_K), s.resolution_K);
}

std::uint64_t probe_seed_of(std::uint64_t seed) { return SeededRandom::derive_seed(seed, kProbeStream); }

std::size_t samples_for(const LoadCaseInfo& info) {
  return static_cast<std::size_t>(std::llround(info.duration_h * kHour / info.step_s)) + 1;
}

std::vector<double> uniform_times(std::size_t samples, double step_s) {
  std::vector<double> t(samples);
  for (std::size_t k = 0; k < samples; ++k) t[k] = static_cast<double>(k) * step_s;
  return t;
}

const std::vector<LoadCaseInfo>& case_list() {
  static const std::vector<LoadCaseInfo> cases = {
      {"A", 192.0, 60.0, "round the clock: arbitrary C-axis speeds, jobs of 15-120 min, 7 days a week", 101},
      {"B", 192.0, 60.0, "two shifts Mon-Fri 06-22 h: stops at night and over the weekend", 102},
      {"C", 192.0, 60.0, "fast-changing small batches: jobs of 2-20 min, frequent setups, Mon-Sat", 103},
      {"D", 192.0, 60.0, "arbitrary speeds round the clock, cutting fluid on/off for 10 min to 5 h", 104},
  };
  return cases;
}

const std::vector<LoadCaseInfo>& recording_list() {
  static const std::vector<LoadCaseInfo> cases = {
      {"S16", 46.0, 15.0,
       "recording-like spindle run: 16 temperatures, spindle speed, 5 linear errors, sparse probes", 116},
  };
  return cases;
}

const std::vector<LoadCaseInfo>& heldout_list() {
  static const std::vector<LoadCaseInfo> cases = {
      {"H1", 144.0, 60.0, "another machine: lighter and faster, weak bearing cooling, hot hall; T_ENV, T_BED, T_TBL, T_COL", 201},
      {"H2", 192.0, 300.0, "5-min logger: T_WS drifts 0.1 K/day, T_COOL dead (stuck) from 60 h; two shifts Mon-Fri", 202},
      {"H3", 48.0, 10.0, "10-s sampling; the machine is moved at 26 h: errors jump, the bed's gains change", 203},
      {"H4", 192.0, 60.0, "strongly nonlinear cradle bending, slow creep, three gaps in the data (0.5-12 h)", 204},
      {"H5", 144.0, 60.0, "errors driven mostly by an unmeasured heat source (no sensor, no logged state)", 205},
  };
  return cases;
}

// Held-out cases built after the adaptive policy and its grids were settled (2026-12-07), so that
// no choice was made while looking at them: each judged once (docs/adaptive.md, "A case built after",
// "A second case built after").
const std::vector<LoadCaseInfo>& later_heldout_list() {
  static const std::vector<LoadCaseInfo> cases = {
      {"H6", 168.0, 120.0,
       "a heavier machine on three shifts with several faults at once: 2-min logger, cutting fluid, a drifting and a "
       "dead sensor, a small unlogged heat source, a 4-h gap",
       206},
      {"H7", 120.0, 60.0,
       "a machine repaired mid-run: re-levelled at 60 h (errors jump, the bed's gains 0.6x), settling after; "
       "a light bearing on a heavy bed, hot fast jobs, a weathery hall, a column sensor drifting, a 1-h gap",
       207},
  };
  return cases;
}

// A sensor on one node, or between nodes and the hall air.
SensorPlacement on_nodes(std::string name, std::vector<std::pair<TwinNode, double>> nodes, double ambient = 0.0) {
  SensorPlacement p;
  p.name = std::move(name);
  for (const auto& [node, weight] : nodes) p.node_weights[static_cast<std::size_t>(node)] = weight;
  p.ambient_weight = ambient;
  return p;
}

// A–D's sensors as placements (for the held-out cases that break one of them).
std::vector<SensorPlacement> default_sensors() {
  return {on_nodes("T_ENV", {}, 1.0), on_nodes("T_WS", {{kWorkspace, 1.0}}), on_nodes("T_COOL", {{kCoolant, 1.0}})};
}

void held_out_spec(std::string_view name, LoadCaseSpec& spec) {
  VariantSpec& v = spec.variant;
  ThermalTwinParams& twin = spec.twin;
  if (name == "H1") {
    // A smaller machine: lighter structure (shorter time constants), a weak cooling jacket, stiffer
    // couplings to the bed, friction rising with the square of the speed, another output map; a
    // hall without air conditioning; other sensors in other places (no coolant sensor).
    twin.c_bearing = 2.5e4;
    twin.c_table = 1.0e5;
    twin.c_cradle = 3.0e5;
    twin.c_bed = 2.0e6;
    twin.c_column = 6.0e5;
    twin.g_bearing_coolant = 8.0;
    twin.g_bearing_table = 25.0;
    twin.g_cradle_bed = 35.0;
    twin.g_bed_ambient = 30.0;
    twin.friction_power_W = 90.0;
    twin.friction_exponent = 2.0;
    twin.gains = {{
        //  bearing table  cradle  bed   column  ws   cool chill fluid
        {{  2.0,   -0.6,  0.8,   -2.2,  1.8,   0.0, 0.0, 0.0, 0.0}},  // E_X0C
        {{  0.8,   1.5,   2.2,   -1.4,  -1.0,  0.0, 0.0, 0.0, 0.0}},  // E_Y0C
        {{  2.4,   1.2,   0.6,   1.6,   -2.5,  0.0, 0.0, 0.0, 0.0}},  // E_Z0T
        {{  0.5,   3.5,   0.4,   -0.8,  0.0,   0.0, 0.0, 0.0, 0.0}},  // E_R0T
        {{  4.0,   1.0,   2.5,   -3.0,  -1.0,  0.0, 0.0, 0.0, 0.0}},  // E_A0C
        {{  1.5,   -1.5,  2.0,   2.5,   3.0,   0.0, 0.0, 0.0, 0.0}},  // E_B0C
        {{  6.0,   2.0,   -2.5,  0.0,   -1.0,  0.0, 0.0, 0.0, 0.0}},  // E_C0C
    }};
    spec.ambient.base_C = 23.0;
    spec.ambient.daily_amplitude_K = 3.0;
    spec.ambient.door_rate_work_per_h = 0.6;
    spec.production.job_min_min = 5.0;
    spec.production.job_max_min = 45.0;
    spec.production.working_days = 6;
    v.sensors = {on_nodes("T_ENV", {}, 1.0), on_nodes("T_BED", {{kBed, 1.0}}),
                 on_nodes("T_TBL", {{kTable, 0.6}, {kWorkspace, 0.4}}), on_nodes("T_COL", {{kColumn, 0.8}}, 0.2)};
  } else if (name == "H2") {
    // A's machine, logged every 5 min (the probe reads at every row), with a drifting workspace
    // sensor and a coolant sensor that dies at 60 h and keeps its last reading.
    spec.ambient.base_C = 20.0;
    spec.production.job_min_min = 10.0;
    spec.production.job_max_min = 90.0;
    spec.production.shift_start_h = 6.0;
    spec.production.shift_end_h = 22.0;
    spec.production.working_days = 5;
    v.sensors = default_sensors();
    v.sensors[1].drift_K_per_day = 0.1;
    v.sensors[2].dead_after_h = 60.0;
  } else if (name == "H3") {
    // A's machine sampled every 10 s; at 26 h it is moved (or its levelling repaired): the errors
    // jump and the bed, on its new foundation, deforms the axis 1.8 times as much.
    spec.ambient.base_C = 21.5;
    v.move_at_h = 26.0;
    v.move_offset = {6.0, -4.0, 3.0, 2.0, 12.0, -8.0, 5.0};
    v.move_bed_gain_factor = 1.8;
  } else if (name == "H4") {
    // The cradle bends 25 times as much with the square of its gradient, friction grows with
    // n^2.4; a new foundation settles (creep, τ 120 h); the logger was off three times.
    for (double& q : twin.quadratic) q *= 25.0;
    twin.friction_exponent = 2.4;
    spec.ambient.base_C = 20.5;
    v.creep = {3.0, -2.0, 6.0, 2.0, 8.0, -5.0, 4.0};
    v.creep_time_constant_h = 120.0;
    v.gaps_h = {{30.0, 36.0}, {100.0, 100.5}, {150.0, 162.0}};
  } else if (name == "H6") {
    // A heavier machine (time constants about 1.5 x A's) with a strong cooling jacket and a weaker
    // cradle-bed coupling, another output map and more bending; three shifts Mon-Fri (a weekend
    // cool-down from 112 h), cutting fluid on and off; a 2-min logger; the workspace sensor sits
    // half on the table and drifts, a cradle sensor dies at 110 h; a hydraulic unit nobody logs
    // adds a smaller share of the error than H5's; the logger was off for 4 h.
    twin.c_bearing = 9.0e4;
    twin.c_table = 3.5e5;
    twin.c_cradle = 1.1e6;
    twin.c_bed = 5.5e6;
    twin.c_column = 2.2e6;
    twin.g_bearing_coolant = 40.0;
    twin.g_cradle_bed = 12.0;
    twin.friction_power_W = 170.0;
    twin.friction_exponent = 1.8;
    twin.gains = {{
        //  bearing table  cradle  bed   column  ws   cool chill fluid
        {{  1.4,   1.1,   -0.9,  -1.2,  2.0,   0.0, 0.0, 0.0, 0.0}},  // E_X0C
        {{  -1.2,  0.9,   2.6,   -1.8,  1.2,   0.0, 0.0, 0.0, 0.0}},  // E_Y0C
        {{  2.0,   -1.0,  2.2,   0.8,   -2.8,  0.0, 0.0, 0.0, 0.0}},  // E_Z0T
        {{  0.6,   2.4,   0.9,   -0.7,  0.5,   0.0, 0.0, 0.0, 0.0}},  // E_R0T
        {{  1.8,   -1.5,  3.5,   -2.0,  1.5,   0.0, 0.0, 0.0, 0.0}},  // E_A0C
        {{  -2.0,  1.0,   1.8,   2.2,   3.0,   0.0, 0.0, 0.0, 0.0}},  // E_B0C
        {{  4.0,   -2.0,  1.0,   -1.5,  0.8,   0.0, 0.0, 0.0, 0.0}},  // E_C0C
    }};
    for (double& q : twin.quadratic) q *= 5.0;
    spec.ambient.base_C = 22.5;
    spec.ambient.daily_amplitude_K = 2.5;
    spec.ambient.weather_sigma_K = 1.5;
    spec.ambient.door_rate_work_per_h = 0.5;
    spec.production.job_min_min = 20.0;
    spec.production.job_max_min = 180.0;
    spec.production.speed_min_rpm = 200.0;
    spec.production.speed_max_rpm = 1200.0;
    spec.production.working_days = 5;
    spec.fluid.enabled = true;
    spec.fluid.on_min_min = 30.0;
    spec.fluid.on_max_min = 240.0;
    spec.fluid.off_min_min = 60.0;
    spec.fluid.off_max_min = 600.0;
    v.sensors = {on_nodes("T_ENV", {{kColumn, 0.2}}, 0.8), on_nodes("T_WS", {{kWorkspace, 0.7}, {kTable, 0.3}}),
                 on_nodes("T_COOL", {{kCoolant, 1.0}}), on_nodes("T_CRD", {{kCradle, 1.0}})};
    v.sensors[1].drift_K_per_day = -0.08;
    v.sensors[3].dead_after_h = 110.0;
    v.hidden.enabled = true;
    v.hidden.rise_K = 2.5;
    v.hidden.time_constant_h = 5.0;
    v.hidden.on_min_h = 2.0;
    v.hidden.on_max_h = 12.0;
    v.hidden.off_min_h = 2.0;
    v.hidden.off_max_h = 16.0;
    v.hidden.gains = {1.2, -0.8, 1.5, 0.4, 2.0, -2.5, 1.0};
    v.gaps_h = {{70.0, 74.0}};
    spec.probe.interval_s = 240.0;  // the recorded probe: every second row (300 s is no multiple of 120 s)
  } else if (name == "H7") {
    // Built after the first check came to the adaptive schedule (2026-12-07), before any study ran on
    // it. A light, quickly cooled bearing on a heavy bed and column (time constants spread wider than
    // A's), a strong cradle-bed coupling, friction 150 W (n/1000)^2.2 on long fast jobs; another output
    // map led by the column and the bed; a hall with more weather; the machine is re-levelled at 60 h
    // (the errors jump, the bed's gains drop to 0.6x on the new supports) and settles a little from
    // the start (creep, tau 200 h); T_COL on the column drifts +0.12 K/day; the logger was off 1 h.
    twin.c_bearing = 3.5e4;
    twin.c_table = 2.0e5;
    twin.c_cradle = 6.0e5;
    twin.c_bed = 5.0e6;
    twin.c_column = 2.0e6;
    twin.g_bearing_coolant = 30.0;
    twin.g_cradle_bed = 32.0;
    twin.g_bed_ambient = 35.0;
    twin.friction_power_W = 150.0;
    twin.friction_exponent = 2.2;
    twin.gains = {{
        //  bearing table  cradle  bed   column  ws   cool chill fluid
        {{  0.7,   0.5,   1.0,   -2.4,  3.0,   0.0, 0.0, 0.0, 0.0}},  // E_X0C
        {{  1.2,   -0.8,  1.6,   1.8,   -2.6,  0.0, 0.0, 0.0, 0.0}},  // E_Y0C
        {{  1.6,   0.6,   -1.2,  2.2,   2.0,   0.0, 0.0, 0.0, 0.0}},  // E_Z0T
        {{  0.4,   2.0,   1.2,   -1.0,  0.8,   0.0, 0.0, 0.0, 0.0}},  // E_R0T
        {{  2.5,   1.0,   -2.0,  3.0,   -2.0,  0.0, 0.0, 0.0, 0.0}},  // E_A0C
        {{  -1.0,  2.0,   2.5,   -2.5,  2.0,   0.0, 0.0, 0.0, 0.0}},  // E_B0C
        {{  3.0,   -1.0,  1.5,   2.0,   -1.5,  0.0, 0.0, 0.0, 0.0}},  // E_C0C
    }};
    spec.ambient.base_C = 21.0;
    spec.ambient.daily_amplitude_K = 2.0;
    spec.ambient.weather_sigma_K = 1.8;
    spec.production.job_min_min = 60.0;
    spec.production.job_max_min = 240.0;
    spec.production.speed_min_rpm = 600.0;
    spec.production.speed_max_rpm = 2000.0;
    spec.production.working_days = 6;
    v.sensors = default_sensors();
    v.sensors.push_back(on_nodes("T_COL", {{kColumn, 1.0}}));
    v.sensors[3].drift_K_per_day = 0.12;
    v.move_at_h = 60.0;
    v.move_offset = {-3.0, 2.0, -4.0, 1.0, -6.0, 4.0, -3.0};
    v.move_bed_gain_factor = 0.6;
    v.creep = {1.5, -1.0, 2.0, 1.0, 3.0, -2.0, 2.0};
    v.creep_time_constant_h = 200.0;
    v.gaps_h = {{90.0, 91.0}};
  } else {  // H5
    // Little C-axis heat; most of the error comes from a spindle head or hydraulic unit whose
    // state no input shows, switched on and off at random.
    twin.friction_power_W = 50.0;
    spec.ambient.daily_amplitude_K = 1.0;
    spec.ambient.weather_sigma_K = 0.6;
    v.hidden.enabled = true;
    v.hidden.rise_K = 5.0;
    v.hidden.time_constant_h = 2.5;
    v.hidden.gains = {2.5, -1.5, -4.0, 0.8, -3.0, 6.0, 1.5};
  }
}

// ---- S16: the spindle recording ---------------------------------------------------------------

// A test-bench style program: warm-up steps, a cool-down, random jobs, a night stop, more jobs.
std::vector<double> spindle_speed_series(std::size_t samples, double step_s, SeededRandom& random) {
  struct Block {
    double end_h;
    double rpm;  // < 0: random jobs
  };
  const std::vector<Block> program = {{1.0, 0.0},   {3.5, 3000.0}, {5.5, 6000.0}, {7.0, 0.0},  {9.0, 8000.0},
                                      {12.0, 0.0},  {20.0, -1.0},  {30.0, 0.0},   {42.0, -1.0}, {46.5, 0.0}};
  std::vector<double> speed(samples, 0.0);
  std::size_t k = 0;
  for (const Block& b : program) {
    while (k < samples && static_cast<double>(k) * step_s < b.end_h * kHour) {
      const bool jobs = b.rpm < 0.0;
      const double rpm = jobs ? (random.chance(0.2) ? 0.0 : quantise(random.uniform(1500.0, 8000.0), 100.0)) : b.rpm;
      const double end_s = jobs ? std::min(static_cast<double>(k) * step_s + 60.0 * random.uniform(10.0, 60.0), b.end_h * kHour)
                                : b.end_h * kHour;
      for (; k < samples && static_cast<double>(k) * step_s < end_s; ++k) speed[k] = rpm;
    }
  }
  return speed;
}

// The spindle recording's probe: sparse measurement times like a real recording (every 5 min for
// 6 h, every 30 min to 24 h, then hourly; a few cycles missed), noise 0.5 µm, and a rare chip that
// moves one output.
probing::TwinProbeOptions spindle_probe_options() {
  probing::TwinProbeOptions o;
  o.noise_sigma.assign(kSpindleErrors, 0.5);
  o.chip_probability = 0.01;
  o.chip_min_um = 3.0;
  o.chip_max_um = 10.0;
  for (int e = 0; e < kSpindleErrors; ++e) o.chip_directions.push_back({{{e, 1.0}}});
  o.chip_order = probing::ChipOrder::kBeforeNoise;
  o.resolution = kErrorResolution;
  o.schedule = {{6.0 * kHour, 300.0}, {24.0 * kHour, 1800.0}, {std::numeric_limits<double>::infinity(), 3600.0}};
  o.miss_probability = 0.04;
  return o;
}

SimulatedCase simulate_spindle_recording(const LoadCaseInfo& info, std::uint64_t seed) {
  const std::size_t n = samples_for(info);
  const double start_s = 1 * kDay + 8.0 * kHour;  // Tuesday 08:00
  AmbientParams hall;
  hall.base_C = 21.5;
  hall.daily_amplitude_K = 1.3;
  hall.door_rate_work_per_h = 0.15;
  hall.door_drop_max_K = 2.5;
  auto ambient_random = stream(seed, kAmbientStream);
  auto production_random = stream(seed, kProductionStream);
  auto drift_random = stream(seed, kDriftStream);
  auto sensor_random = stream(seed, kSensorStream);

  SimulatedCase run;
  run.info = info;
  run.seed = seed;
  run.probe = spindle_probe_options();
  run.probe_seed = probe_seed_of(seed);
  const std::vector<double> ambient = ambient_series(hall, n, info.step_s, start_s, ambient_random);
  const std::vector<double> speed = spindle_speed_series(n, info.step_s, production_random);
  run.profile.time_s = uniform_times(n, info.step_s);
  run.profile.loads.resize(n);
  for (std::size_t k = 0; k < n; ++k) run.profile.loads[k] = ThermalLoad{ambient[k], speed[k], false};
  run.profile.drift = drift_series(std::vector<double>(kSpindleErrors, 0.6), 36.0, n, info.step_s, drift_random);

  SpindleTwinParams params;
  params.reference_temperature_C = ambient[0];
  const SpindleTwin twin(params, info.step_s);
  run.truth = twin.simulate(twin.steady_state(ThermalLoad{ambient[0], 0.0, false}), run.profile.loads, run.profile.drift);

  Scenario& s = run.scenario;
  s.input_names = SpindleTwin::sensor_names();
  s.input_names.push_back("n_S");
  s.output_names = SpindleTwin::error_names();
  s.time_s = run.profile.time_s;
  s.inputs.resize(static_cast<Eigen::Index>(n), kSpindleSensors + 1);
  const SensorParams sensors;
  for (std::size_t k = 0; k < n; ++k) {
    const auto r = static_cast<Eigen::Index>(k);
    const Eigen::VectorXd t = twin.sensors(run.truth.nodes.row(r).transpose(), ambient[k]);
    for (int j = 0; j < kSpindleSensors; ++j) s.inputs(r, j) = sensor_reading(t(j), sensors, sensor_random);
    s.inputs(r, kSpindleSensors) = speed[k];
  }
  s.outputs = make_probe(run, run.probe_seed).probe_run(s.time_s, run.truth.errors);
  return run;
}

}  // namespace

const std::vector<LoadCaseInfo>& load_cases() { return case_list(); }
const std::vector<LoadCaseInfo>& recording_cases() { return recording_list(); }

const std::vector<LoadCaseInfo>& heldout_cases() { return heldout_list(); }
const std::vector<LoadCaseInfo>& later_heldout_cases() { return later_heldout_list(); }

const std::vector<LoadCaseInfo>& all_cases() {
  static const std::vector<LoadCaseInfo> all = [] {
    std::vector<LoadCaseInfo> cases;
    for (const auto* list : {&case_list(), &recording_list(), &heldout_list(), &later_heldout_list()})
      cases.insert(cases.end(), list->begin(), list->end());
    return cases;
  }();
  return all;
}

std::optional<LoadCaseInfo> find_case(std::string_view name) {
  for (const LoadCaseInfo& c : all_cases())
    if (c.name == name) return c;
  return std::nullopt;
}

LoadCaseSpec load_case_spec(std::string_view name) {
  LoadCaseSpec spec;
  const auto info = find_case(name);
  if (!info || info->name == "S16")
    throw std::invalid_argument("load_case_spec: no load case '" + std::string(name) + "' (A, B, C, D or H1-H7)");
  spec.info = *info;
  if (name.front() == 'H') {
    held_out_spec(name, spec);
    return spec;
  }
  ProductionPattern& prod = spec.production;
  AmbientParams& hall = spec.ambient;
  if (name == "A") {
    hall.base_C = 21.0;
    hall.daily_amplitude_K = 1.5;
  } else if (name == "B") {
    hall.base_C = 19.5;
    hall.daily_amplitude_K = 2.0;
    prod.job_min_min = 10.0;
    prod.job_max_min = 90.0;
    prod.idle_share = 0.1;
    prod.shift_start_h = 6.0;
    prod.shift_end_h = 22.0;
    prod.working_days = 5;
  } else if (name == "C") {
    hall.base_C = 22.0;
    hall.daily_amplitude_K = 2.2;
    prod.job_min_min = 2.0;
    prod.job_max_min = 20.0;
    prod.speed_min_rpm = 300.0;
    prod.idle_share = 0.1;
    prod.working_days = 6;
  } else {  // D
    hall.base_C = 20.5;
    hall.daily_amplitude_K = 1.8;
    prod.job_min_min = 5.0;
    prod.job_max_min = 60.0;
    prod.idle_share = 0.2;
    spec.fluid.enabled = true;
  }
  return spec;
}

namespace {

// Excess temperature [K] of the hidden node at each sample: on/off periods of the source (log-uniform
// lengths, starting off), a first-order lag towards rise_K while on.
std::vector<double> hidden_temperature(const HiddenSource& h, std::size_t samples, double step_s, SeededRandom& random) {
  const double phi = std::exp(-step_s / (h.time_constant_h * kHour));
  std::vector<double> excess(samples, 0.0);
  double next_switch_s = kHour * log_uniform(random, h.off_min_h, h.off_max_h);
  bool on = false;
  double x = 0.0;
  for (std::size_t k = 0; k < samples; ++k) {
    const double t = static_cast<double>(k) * step_s;
    while (t >= next_switch_s) {
      on = !on;
      next_switch_s += kHour * (on ? log_uniform(random, h.on_min_h, h.on_max_h) : log_uniform(random, h.off_min_h, h.off_max_h));
    }
    excess[k] = x;
    x = phi * x + (1.0 - phi) * (on ? h.rise_K : 0.0);
  }
  return excess;
}

// Adds a held-out case's creep, the offset of its move and its hidden source to the drift.
void add_variant_drift(const VariantSpec& v, std::uint64_t seed, LoadProfile& profile) {
  const auto n = static_cast<Eigen::Index>(profile.time_s.size());
  const bool creep = std::any_of(v.creep.begin(), v.creep.end(), [](double c) { return c != 0.0; });
  std::vector<double> hidden;
  if (v.hidden.enabled) {
    auto hidden_random = stream(seed, kHiddenStream);
    const double step = n > 1 ? profile.time_s[1] - profile.time_s[0] : 60.0;
    hidden = hidden_temperature(v.hidden, profile.time_s.size(), step, hidden_random);
  }
  for (Eigen::Index k = 0; k < n; ++k) {
    const double t = profile.time_s[static_cast<std::size_t>(k)];
    for (int e = 0; e < kTwinErrors; ++e) {
      const auto i = static_cast<std::size_t>(e);
      if (creep) profile.drift(k, e) += v.creep[i] * (1.0 - std::exp(-t / (v.creep_time_constant_h * kHour)));
      if (t >= v.move_at_h * kHour) profile.drift(k, e) += v.move_offset[i];
      if (!hidden.empty()) profile.drift(k, e) += v.hidden.gains[i] * hidden[static_cast<std::size_t>(k)];
    }
  }
}

// From the move on, the errors of the machine on its new foundation (the bed's gains scaled); the
// jump itself is in the drift (add_variant_drift).
void apply_move(const VariantSpec& v, const ThermalTwinParams& before, SimulatedCase& run) {
  ThermalTwinParams after = before;
  for (auto& row : after.gains) row[kBed] *= v.move_bed_gain_factor;
  const ThermalTwin moved(after, run.info.step_s);
  for (Eigen::Index k = 0; k < run.truth.errors.rows(); ++k)
    if (run.profile.time_s[static_cast<std::size_t>(k)] >= v.move_at_h * kHour)
      run.truth.errors.row(k) = moved.errors(run.truth.nodes.row(k).transpose(), run.profile.drift.row(k).transpose()).transpose();
}

// Removes the rows inside the gaps from the profile and the truth (the logger was off; the machine
// ran on).
void drop_gaps(const std::vector<std::pair<double, double>>& gaps_h, SimulatedCase& run) {
  std::vector<Eigen::Index> keep;
  for (std::size_t k = 0; k < run.profile.time_s.size(); ++k) {
    const double h = run.profile.time_s[k] / kHour;
    if (std::none_of(gaps_h.begin(), gaps_h.end(), [h](const auto& g) { return h >= g.first && h < g.second; }))
      keep.push_back(static_cast<Eigen::Index>(k));
  }
  LoadProfile& p = run.profile;
  std::vector<double> time_s;
  std::vector<ThermalLoad> loads;
  for (const Eigen::Index k : keep) {
    time_s.push_back(p.time_s[static_cast<std::size_t>(k)]);
    loads.push_back(p.loads[static_cast<std::size_t>(k)]);
  }
  p.time_s = std::move(time_s);
  p.loads = std::move(loads);
  p.drift = Eigen::MatrixXd(p.drift(keep, Eigen::all));
  run.truth.nodes = Eigen::MatrixXd(run.truth.nodes(keep, Eigen::all));
  run.truth.errors = Eigen::MatrixXd(run.truth.errors(keep, Eigen::all));
}

// The inputs of a held-out case with its own sensors: each a weighted mix of nodes and the hall
// air, with drift, noise and quantisation, stuck at its last reading once dead; then n_C (and
// CF_on).
void placed_sensor_readings(const LoadCaseSpec& spec, SeededRandom& random, SimulatedCase& run) {
  const std::vector<SensorPlacement>& sensors = spec.variant.sensors;
  Scenario& s = run.scenario;
  const bool fluid = spec.fluid.enabled;
  for (const SensorPlacement& p : sensors) s.input_names.push_back(p.name);
  s.input_names.push_back("n_C");
  if (fluid) s.input_names.push_back("CF_on");
  const auto n = static_cast<Eigen::Index>(run.profile.time_s.size());
  const auto m = static_cast<Eigen::Index>(sensors.size());
  s.inputs.resize(n, static_cast<Eigen::Index>(s.input_names.size()));
  for (Eigen::Index r = 0; r < n; ++r) {
    const double t = run.profile.time_s[static_cast<std::size_t>(r)];
    const ThermalLoad& load = run.profile.loads[static_cast<std::size_t>(r)];
    for (Eigen::Index j = 0; j < m; ++j) {
      const SensorPlacement& p = sensors[static_cast<std::size_t>(j)];
      if (r > 0 && t >= p.dead_after_h * kHour) {
        s.inputs(r, j) = s.inputs(r - 1, j);
        continue;
      }
      double truth = p.ambient_weight * load.ambient_C + p.drift_K_per_day * t / kDay;
      for (int i = 0; i < kTwinNodes; ++i) truth += p.node_weights[static_cast<std::size_t>(i)] * run.truth.nodes(r, i);
      s.inputs(r, j) = sensor_reading(truth, spec.sensors, random);
    }
    s.inputs(r, m) = load.speed_rpm;
    if (fluid) s.inputs(r, m + 1) = load.fluid_on ? 1.0 : 0.0;
  }
}

}  // namespace

LoadProfile make_load_profile(const LoadCaseSpec& spec, std::uint64_t seed) {
  const std::size_t n = samples_for(spec.info);
  const double step = spec.info.step_s;
  auto ambient_random = stream(seed, kAmbientStream);
  auto production_random = stream(seed, kProductionStream);
  auto fluid_random = stream(seed, kFluidStream);
  auto drift_random = stream(seed, kDriftStream);
  const double start_s = spec.start_h * kHour;
  const std::vector<double> ambient = ambient_series(spec.ambient, n, step, start_s, ambient_random);
  const std::vector<double> speed = speed_series(spec.production, n, step, start_s, 10.0, production_random);
  const std::vector<bool> fluid = fluid_series(spec.fluid, n, step, fluid_random);
  LoadProfile profile;
  profile.time_s = uniform_times(n, step);
  profile.loads.resize(n);
  for (std::size_t k = 0; k < n; ++k) profile.loads[k] = ThermalLoad{ambient[k], speed[k], fluid[k]};
  std::vector<double> sigma(kTwinErrors, spec.drift.sigma_linear_um);
  std::fill(sigma.begin() + 4, sigma.end(), spec.drift.sigma_angular_um_per_m);  // E_A0C, E_B0C, E_C0C
  profile.drift = drift_series(sigma, spec.drift.time_constant_h, n, step, drift_random);
  add_variant_drift(spec.variant, seed, profile);
  return profile;
}

SimulatedCase simulate_load_case(const LoadCaseSpec& spec, std::uint64_t seed) {
  SimulatedCase run;
  run.info = spec.info;
  run.seed = seed;
  run.profile = make_load_profile(spec, seed);

  // The machine stood still in the hall long enough to be in equilibrium with it at the start,
  // and its errors are taken against that state (as a recording zeroes them at its start).
  ThermalTwinParams params = spec.twin;
  const ThermalLoad at_rest{run.profile.loads.front().ambient_C, 0.0, false};
  params.reference_temperature_C = at_rest.ambient_C;
  const ThermalTwin twin(params, spec.info.step_s);
  run.truth = twin.simulate(twin.steady_state(at_rest), run.profile.loads, run.profile.drift);
  const VariantSpec& variant = spec.variant;
  if (std::isfinite(variant.move_at_h)) apply_move(variant, params, run);
  if (!variant.gaps_h.empty()) drop_gaps(variant.gaps_h, run);
  const std::size_t n = run.profile.loads.size();

  Scenario& s = run.scenario;
  s.output_names = ThermalTwin::error_names();
  s.time_s = run.profile.time_s;
  auto sensor_random = stream(seed, kSensorStream);
  const bool fluid = spec.fluid.enabled;
  if (!variant.sensors.empty()) {
    placed_sensor_readings(spec, sensor_random, run);
  } else {
    s.input_names = {"T_ENV", fluid ? "T_CF" : "T_WS", "T_COOL", "n_C"};
    if (fluid) s.input_names.push_back("CF_on");
    s.inputs.resize(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(s.input_names.size()));
    for (std::size_t k = 0; k < n; ++k) {
      const auto r = static_cast<Eigen::Index>(k);
      const ThermalLoad& load = run.profile.loads[k];
      s.inputs(r, 0) = sensor_reading(load.ambient_C, spec.sensors, sensor_random);
      s.inputs(r, 1) = sensor_reading(run.truth.nodes(r, fluid ? kFluidTank : kWorkspace), spec.sensors, sensor_random);
      s.inputs(r, 2) = sensor_reading(run.truth.nodes(r, kCoolant), spec.sensors, sensor_random);
      s.inputs(r, 3) = load.speed_rpm;
      if (fluid) s.inputs(r, 4) = load.fluid_on ? 1.0 : 0.0;
    }
  }
  run.probe = twin_probe_options(spec.probe);
  run.probe_seed = probe_seed_of(seed);
  s.outputs = make_probe(run, run.probe_seed).probe_run(s.time_s, run.truth.errors);
  return run;
}

probing::TwinProbeOptions twin_probe_options(const ProbeParams& probe) {
  probing::TwinProbeOptions o;
  o.noise_sigma.assign(kTwinErrors, probe.noise_angular_um_per_m);  // E_A0C, E_B0C, E_C0C
  std::fill(o.noise_sigma.begin(), o.noise_sigma.begin() + 4, probe.noise_linear_um);  // E_X0C .. E_R0T
  // A chip on the sphere shifts its measured centre along X, Y or Z; as the sphere sits on a
  // lever above the table, the axis tilt seen in that direction jumps too.
  o.chip_probability = probe.outlier_probability;
  o.chip_min_um = probe.outlier_min_um;
  o.chip_max_um = probe.outlier_max_um;
  o.chip_random_sign = true;
  const double tilt = 1.0 / probe.sphere_lever_m;  // [µm/m] per µm
  o.chip_directions = {
      {{{0, 1.0}, {3, 1.0}, {5, tilt}}},  // X: E_X0C, E_R0T and the tilt about Y, E_B0C
      {{{1, 1.0}, {4, -tilt}}},           // Y: E_Y0C and the tilt about X, E_A0C
      {{{2, 1.0}}},                       // Z: E_Z0T
  };
  o.chip_order = probing::ChipOrder::kAfterNoise;
  o.resolution = kErrorResolution;
  o.schedule = {probing::ProbeInterval{std::numeric_limits<double>::infinity(), probe.interval_s}};
  return o;
}

probing::TwinProbe make_probe(const SimulatedCase& run, std::uint64_t probe_seed) {
  return probing::TwinProbe(run.probe, probe_seed);
}

Scenario reprobe(const SimulatedCase& run, std::uint64_t probe_seed) {
  Scenario s = run.scenario;
  s.outputs = make_probe(run, probe_seed).probe_run(s.time_s, run.truth.errors);
  return s;
}

SimulatedCase simulate_case(std::string_view name, std::optional<std::uint64_t> seed) {
  const auto info = find_case(name);
  if (!info) throw std::invalid_argument("unknown case '" + std::string(name) + "' (A, B, C, D, S16 or H1-H7)");
  const std::uint64_t s = seed.value_or(info->default_seed);
  if (info->name == "S16") return simulate_spindle_recording(*info, s);
  return simulate_load_case(load_case_spec(name), s);
}

}  // namespace alc::scenarios
