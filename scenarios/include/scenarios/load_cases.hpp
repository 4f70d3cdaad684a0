#pragma once
// Built-in load cases: the environment and production that drive the thermal twin, and what
// the sensors and the touch probe make of it (GTSAM's ScenarioRunner role).
//
// A–D: the C-axis twin (thermal_twin.hpp), 8 days at 1-minute sampling, in the spirit of the
// ALC paper's load cases (seed 004, §3). S16: a recording-like spindle scenario (spindle_twin.hpp)
// with sixteen temperatures at 15 s and sparse measurements. H1–H7: held-out variants of the C-axis
// twin whose physics differ from A–D (other machine, sensor faults, sampling, a move, creep, gaps,
// an unmeasured heat source), for reporting on cases the defaults were not tuned on. docs/twin.md
// has the figures.
#include <array>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "probing/twin_probe.hpp"
#include "scenarios/scenario.hpp"
#include "scenarios/thermal_twin.hpp"

namespace alc::scenarios {

struct LoadCaseInfo {
  std::string name;           // "A"
  double duration_h = 0.0;    // [h]
  double step_s = 0.0;        // [s] input sampling
  std::string description;    // one line
  std::uint64_t default_seed = 0;
};

// The load cases A–D, in order.
const std::vector<LoadCaseInfo>& load_cases();
// Recording-like scenarios listed apart from A–D (S16).
const std::vector<LoadCaseInfo>& recording_cases();
// The held-out variants H1–H5 of the C-axis twin (docs/twin.md, "Held-out cases").
const std::vector<LoadCaseInfo>& heldout_cases();
// Held-out variants built after the adaptive policy and its grids were settled (H6, H7; docs/twin.md):
// by name only, in no group, so that every figure of H1–H5 stays as it was.
const std::vector<LoadCaseInfo>& later_heldout_cases();
// Every built-in case: the lists above, in that order.
const std::vector<LoadCaseInfo>& all_cases();
// A case of any list by name, or nullopt.
std::optional<LoadCaseInfo> find_case(std::string_view name);

// Hall air next to the machine: daily cycle + slow weather + hall-door events.
struct AmbientParams {
  double base_C = 21.0;                 // [°C] mean hall temperature
  double daily_amplitude_K = 1.5;       // [K] half the day-night swing
  double daily_peak_hour = 15.0;        // [h] warmest time of day
  double weather_sigma_K = 1.2;         // [K] standard deviation of the weather wander
  double weather_time_constant_h = 40;  // [h]
  double door_rate_work_per_h = 0.35;   // [1/h] door openings during working hours
  double door_rate_off_per_h = 0.04;    // [1/h] at night and on weekends
  double door_drop_min_K = 1.5;         // [K] drop of a door event at the sensor
  double door_drop_max_K = 4.0;         // [K]
  double door_open_min_min = 3.0;       // [min] how long the door stays open
  double door_open_max_min = 15.0;      // [min]
  double door_recovery_min_min = 15.0;  // [min] recovery time constant after closing
  double door_recovery_max_min = 40.0;  // [min]
  double work_start_h = 6.0;            // [h] hall working hours (Mon–Fri)
  double work_end_h = 22.0;             // [h]
};

// C-axis (or spindle) speed profile: jobs of random length at random speeds inside shifts.
struct ProductionPattern {
  double job_min_min = 15.0;       // [min] shortest job at one speed
  double job_max_min = 120.0;      // [min] longest
  double speed_min_rpm = 100.0;    // [rpm]
  double speed_max_rpm = 1500.0;   // [rpm]
  double idle_share = 0.15;        // [-] share of jobs that are standstill (setup, loading)
  double shift_start_h = 0.0;      // [h] production hours on working days
  double shift_end_h = 24.0;       // [h]
  int working_days = 7;            // [-] 7: every day, 5: Mon–Fri (the week starts on Monday 00:00)
};

// Cutting-fluid supply (case D): on and off intervals with log-uniform lengths.
struct FluidPattern {
  bool enabled = false;
  double on_min_min = 10.0;    // [min]
  double on_max_min = 300.0;   // [min]
  double off_min_min = 20.0;   // [min]
  double off_max_min = 480.0;  // [min]
};

// The touch-probe cycle on the precision sphere.
struct ProbeParams {
  double interval_s = 300.0;            // [s] a measurement of every error this often
  double noise_linear_um = 0.4;         // [µm] standard deviation
  double noise_angular_um_per_m = 1.2;  // [µm/m]
  double outlier_probability = 0.004;   // [-] per probe cycle: a chip on the sphere
  double outlier_min_um = 3.0;          // [µm] shift of the measured sphere centre
  double outlier_max_um = 15.0;         // [µm]
  double sphere_lever_m = 0.5;          // [m] lever that turns a chip into a tilt error
};

struct SensorParams {
  double noise_K = 0.02;       // [K] standard deviation
  double resolution_K = 0.01;  // [K] quantisation (1/resolution must be an integer)
};

// Slow drift no fixed model explains (settling joints, creep): one OU process per error.
struct DriftParams {
  double sigma_linear_um = 0.8;         // [µm]
  double sigma_angular_um_per_m = 2.5;  // [µm/m]
  double time_constant_h = 48.0;        // [h]
};

// A temperature sensor of a held-out case: where it sits and how it fails.
// reading = Σ_i node_weights[i] T_i + ambient_weight T_hall + drift, with noise and quantisation.
struct SensorPlacement {
  std::string name;                         // column name, "T_BED"
  std::array<double, kTwinNodes> node_weights{};  // [-] TwinNode order
  double ambient_weight = 0.0;              // [-] share of the hall air
  double drift_K_per_day = 0.0;             // [K/day] calibration drift, linear from the start
  double dead_after_h = std::numeric_limits<double>::infinity();  // [h] from then on stuck at its last reading
};

// A heat source no input sees (a spindle head or hydraulic unit whose state is not logged): on/off
// periods of log-uniform length, the heat warming a hidden first-order node whose excess temperature
// deforms the structure with `gains`. What it adds goes into LoadProfile::drift.
struct HiddenSource {
  bool enabled = false;
  double rise_K = 0.0;                      // [K] excess temperature held on forever
  double time_constant_h = 3.0;             // [h]
  double on_min_h = 0.5, on_max_h = 8.0;    // [h]
  double off_min_h = 0.5, off_max_h = 10.0; // [h]
  std::array<double, 7> gains{};            // [µm/K], [µm/(m K)] per error
};

// What makes a held-out case differ from A–D beyond the parameters above. The default (empty)
// changes nothing: A–D are simulated exactly as before.
struct VariantSpec {
  std::vector<SensorPlacement> sensors;     // empty: T_ENV, T_WS (T_CF), T_COOL as in A–D
  // Slow creep (settling of a new foundation): amplitude (1 − exp(−t/τ)) per error, monotone.
  std::array<double, 7> creep{};            // [µm], [µm/m] reached after long
  double creep_time_constant_h = 96.0;      // [h]
  // A machine move or repair: from `move_at_h` on, the errors jump by `move_offset` and the bed's
  // gains are scaled by `move_bed_gain_factor` (the machine stands on another foundation).
  double move_at_h = std::numeric_limits<double>::infinity();  // [h]
  std::array<double, 7> move_offset{};      // [µm], [µm/m]
  double move_bed_gain_factor = 1.0;        // [-]
  HiddenSource hidden;
  // Gaps in the data: no rows logged in [start, end) [h] (the logger was off).
  std::vector<std::pair<double, double>> gaps_h;
};

// Everything that defines one of the cases A–D and H1–H7.
struct LoadCaseSpec {
  LoadCaseInfo info;
  AmbientParams ambient;
  ProductionPattern production;
  FluidPattern fluid;
  ProbeParams probe;
  SensorParams sensors;
  DriftParams drift;
  ThermalTwinParams twin;  // reference_temperature_C is replaced by the start equilibrium
  double start_h = 8.0;    // [h] after Monday 00:00: when the run (and its calibration phase) starts
  VariantSpec variant;     // held-out cases only
};

// The specification of case A–D or H1–H7; throws std::invalid_argument for another name.
LoadCaseSpec load_case_spec(std::string_view name);

// What happened to the machine, sample by sample (before any sensor saw it).
struct LoadProfile {
  std::vector<double> time_s;         // [s] from 0 (= LoadCaseSpec::start_h), uniform but for gaps
  std::vector<ThermalLoad> loads;     // loads[k] acts from time_s[k] for one step
  Eigen::MatrixXd drift;              // samples x errors [µm] / [µm/m]; held-out cases add creep, the
                                      // move's offset and the hidden source (VariantSpec) to it
};

LoadProfile make_load_profile(const LoadCaseSpec& spec, std::uint64_t seed);

// The probe of cases A–D (probing::TwinProbe): every error every `interval_s`, noise per kind,
// and rare chips on the sphere that shift its centre along X, Y or Z (and tilt it by the lever).
probing::TwinProbeOptions twin_probe_options(const ProbeParams& probe);

// A simulated case: what ALC may see, and the truth behind it.
struct SimulatedCase {
  LoadCaseInfo info;
  std::uint64_t seed = 0;
  Scenario scenario;          // sensors (noisy, quantised) and sparse noisy probe measurements
  TwinTruth truth;            // noiseless node temperatures and true errors at every sample
  LoadProfile profile;        // the loads that drove the twin
  // The probe that measured scenario.outputs from truth.errors: its options and the seed of its
  // stream (derived from `seed`). make_probe(run, run.probe_seed) reads the same values again.
  probing::TwinProbeOptions probe;
  std::uint64_t probe_seed = 0;
};

// The case's probe with its own stream seeded by `probe_seed`: a new probe of the same machine.
probing::TwinProbe make_probe(const SimulatedCase& run, std::uint64_t probe_seed);
// The case's scenario probed again (run.probe, `probe_seed`) from the same truth: the same times,
// inputs and names, other measurements. reprobe(run, run.probe_seed) gives run.scenario.
Scenario reprobe(const SimulatedCase& run, std::uint64_t probe_seed);

// Simulates case A–D or H1–H7 from its spec.
SimulatedCase simulate_load_case(const LoadCaseSpec& spec, std::uint64_t seed);
// Simulates any built-in case (A–D, S16, H1–H7) by name, with its default seed unless one is given.
// Throws std::invalid_argument for an unknown name.
SimulatedCase simulate_case(std::string_view name, std::optional<std::uint64_t> seed = std::nullopt);

}  // namespace alc::scenarios
