#pragma once
// Seeded random draws. Every draw of the virtual machine, its load cases and its probe goes
// through SeededRandom, so the same case and seed give the same numbers (and a byte-identical
// CSV). Uniform and normal variates are computed here from the raw std::mt19937_64 output, whose
// sequence the C++ standard fixes, rather than with std::*_distribution, whose algorithms differ
// between standard libraries.
#include <cmath>
#include <cstdint>
#include <random>

namespace alc::common {

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

}  // namespace alc::common
