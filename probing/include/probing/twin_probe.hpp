#pragma once
// The touch probe of the virtual machine (the twin): what a probe cycle on the precision sphere
// reads when the machine's true errors are `truth`. Kept apart from the twin's simulation, so the
// probe's noise, chips and schedule can change (or a run be probed again with another seed)
// without simulating the machine again.
//
// Every draw comes from the probe's own seeded stream (common::SeededRandom), in a fixed order:
//   per due cycle: missed? (only if miss_probability > 0), then the reading;
//   reading, ChipOrder::kAfterNoise:  noise of output 0..n-1, chip?, and on a chip its size,
//                                     its sign (if chip_random_sign), its direction;
//   reading, ChipOrder::kBeforeNoise: chip?, its direction (drawn on every cycle), then the noise
//                                     of output 0..n-1 with the chip's size (on a chip) drawn
//                                     right after the noise of the first output the chip moves.
// Readings are rounded to `resolution`.
#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

#include "common/seeded_random.hpp"

namespace alc::probing {

// How draws of one reading are ordered (see above); both exist in the built-in load cases.
enum class ChipOrder {
  kAfterNoise,   // load cases A–D
  kBeforeNoise,  // the S16 spindle recording
};

// One way a chip can sit on the sphere: a chip of size s [µm] adds s * gain to each listed output
// (gain 1 for a linear error, ±1/lever [1/m] for the tilt seen through a lever [µm/m]).
struct ChipDirection {
  std::vector<std::pair<int, double>> gains;  // (output index, gain)
};

// Probe cycles are due every `interval_s` while the time is at most `until_s` (the first segment
// whose until_s is not passed applies); times are compared in whole seconds.
struct ProbeInterval {
  double until_s = std::numeric_limits<double>::infinity();  // [s]
  double interval_s = 300.0;                                   // [s]
};

struct TwinProbeOptions {
  std::vector<double> noise_sigma;   // per output: [µm] (linear) or [µm/m] (angular) standard deviation
  double chip_probability = 0.0;     // [-] per reading: a chip on the sphere
  double chip_min_um = 0.0;          // [µm] chip size, uniform in [min, max)
  double chip_max_um = 0.0;          // [µm]
  bool chip_random_sign = false;     // a chip pushes either way (probability 1/2 each)
  std::vector<ChipDirection> chip_directions;  // equally likely; needed if chip_probability > 0
  ChipOrder chip_order = ChipOrder::kAfterNoise;
  double resolution = 0.001;         // readings rounded to a multiple of this (0: not rounded)
  std::vector<ProbeInterval> schedule = std::vector<ProbeInterval>(1);  // when cycles are due (every 300 s)
  double miss_probability = 0.0;     // [-] per due cycle: the cycle is skipped (no reading)
};

class TwinProbe {
 public:
  // Throws std::invalid_argument naming the field if the options are inconsistent.
  TwinProbe(TwinProbeOptions options, std::uint64_t seed);
  TwinProbe(TwinProbeOptions options, common::SeededRandom random);

  const TwinProbeOptions& options() const { return options_; }
  std::size_t outputs() const { return options_.noise_sigma.size(); }

  // True if a cycle is scheduled at `t_s` [s] (no draw).
  bool due(double t_s) const;
  // What one reading of every output gives when the true errors are `truth` (noise, maybe a
  // chip, rounded). Throws std::invalid_argument if truth has not outputs() entries.
  Eigen::VectorXd measure(const Eigen::VectorXd& truth);
  // A due cycle: draws whether it is missed, else measures. nullopt if missed.
  std::optional<Eigen::VectorXd> cycle(const Eigen::VectorXd& truth);
  // A whole run: `time_s` per row and the true errors (rows x outputs) -> the probe's readings,
  // NaN in rows without a reading. Cycles run at the due rows, in row order.
  Eigen::MatrixXd probe_run(const std::vector<double>& time_s, const Eigen::MatrixXd& truth);

  // Chips drawn so far.
  std::size_t chips() const { return chips_; }

 private:
  TwinProbeOptions options_;
  common::SeededRandom random_;
  std::size_t chips_ = 0;
};

}  // namespace alc::probing
