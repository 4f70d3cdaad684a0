#pragma once
// Seeded random draws for the virtual machine. Every draw of the twin and the load cases goes
// through SeededRandom, so the same case and seed give the same numbers (and a byte-identical
// CSV). Uniform and normal variates are computed here from the raw std::mt19937_64 output, whose
// sequence the C++ standard fixes, rather than with std::*_distribution, whose algorithms differ
// between standard libraries.
#include <cmath>
#include <cstdint>
#include <random>

namespace alc::scenarios {

class SeededRandom {
 public:
  explicit SeededRandom(std::uint64_t seed) : engine_(seed) {}

  // An independent stream for one part of a simulation (ambient, production, probes, ...):
  // changing how many draws one part makes then leaves the others unchanged. SplitMix64 mixing.
  static std::uint64_t derive_seed(std::uint64_t seed, std::uint64_t stream) {
    std::uint64_t z = seed + 0x9E3779B97F4A7C15ULL * (stream + 1);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
  }

  // Uniform in [0, 1) with 53 random bits.
  double uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  // Uniform in [lo, hi).
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  // True with probability p.
  bool chance(double p) { return uniform() < p; }
  // Standard normal (Box–Muller; the second variate of a pair is kept for the next call).
  double normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    const double u1 = 1.0 - uniform();  // (0, 1]: log stays finite
    const double u2 = uniform();
    const double r = std::sqrt(-2.0 * std::log(u1));
    constexpr double kTwoPi = 6.283185307179586;
    spare_ = r * std::sin(kTwoPi * u2);
    has_spare_ = true;
    return r * std::cos(kTwoPi * u2);
  }
  // Normal with the given standard deviation.
  double normal(double sigma) { return sigma * normal(); }
  // Exponential waiting time with the given mean (mean <= 0 or inf: never).
  double exponential(double mean) { return -mean * std::log(1.0 - uniform()); }

 private:
  std::mt19937_64 engine_;
  bool has_spare_ = false;
  double spare_ = 0.0;
};

// Ornstein–Uhlenbeck process sampled exactly at a fixed step: a slow, bounded random wander
// (weather, the drift of a machine that no fixed model explains). Starts at 0.
class OrnsteinUhlenbeck {
 public:
  OrnsteinUhlenbeck(double sigma, double time_constant_s, double step_s)
      : phi_(std::exp(-step_s / time_constant_s)), kick_(sigma * std::sqrt(1.0 - phi_ * phi_)) {}
  // Advances one step and returns the new value.
  double step(SeededRandom& random) {
    value_ = phi_ * value_ + kick_ * random.normal();
    return value_;
  }
  double value() const { return value_; }

 private:
  double phi_;          // [-] decay per step
  double kick_;         // standard deviation of the innovation per step
  double value_ = 0.0;
};

// Rounds to a multiple of `resolution` (a sensor's quantisation, or rounding before writing).
// Below 1, divides by the integer scale (100 for 0.01) so that the result is the double nearest
// the decimal value and the shortest-text writer prints 21.37, not 21.370000000000001.
inline double quantise(double value, double resolution) {
  if (resolution >= 1.0) return std::round(value / resolution) * resolution;
  const double scale = std::round(1.0 / resolution);
  return std::round(value * scale) / scale;
}

}  // namespace alc::scenarios
