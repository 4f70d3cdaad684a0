#pragma once
// The first-order lag shared by the predictor and the identification, so that both compute the
// same doubles: x(t + dt) = a x(t) + (1 - a) u_held, a = exp(-dt / tau) (exact for a held input).
#include <cmath>

namespace alc::detail {

inline double lag_factor(double dt_s, double tau_s) { return std::exp(-dt_s / tau_s); }

inline double lag_step(double x, double a, double u_held) { return a * x + (1.0 - a) * u_held; }

}  // namespace alc::detail
