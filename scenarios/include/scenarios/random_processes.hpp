#pragma once
// Random processes of the virtual machine (the weather, slow drifts). The seeded draws themselves
// are common::SeededRandom (common/seeded_random.hpp), the rounding common::quantise.
#include <cmath>

#include "common/quantise.hpp"
#include "common/seeded_random.hpp"

namespace alc::scenarios {

using common::quantise;
using common::SeededRandom;

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

}  // namespace alc::scenarios
