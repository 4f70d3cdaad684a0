#pragma once
// Quality indicators of a compensation, seed 004 Eq. 1-7. Pure functions over the measured errors
// y_t and the predictions yhat_t of one output, evaluated by the caller on the samples from the end
// of the calibration phase to the end of the run (n = N - CP values).
// Undefined cases (no values, a zero denominator of PV) return NaN.
#include <span>

namespace alc {

// Eq. 1: PV = max|y - yhat| / max|y| * 100 [%].
double peak_value_percent(std::span<const double> measured, std::span<const double> predicted);

// Eq. 2: RMSE = sqrt(sum (yhat - y)^2 / n), in the unit of the error.
double rmse(std::span<const double> measured, std::span<const double> predicted);

// Eq. 3-5: the P-quantile (P in [0, 1]) of `values` with the paper's midpoint-rank interpolation:
// sorted v_1..v_n, x = n P + 1/2, Pr = v_[x] + (x % 1)(v_[x]+1 - v_[x]); x = 1 for P <= p_1 and
// x = n for P >= p_n, with p_i = (i - 1/2) / n. The values are used as given (pass |residuals|).
double percentile(std::span<const double> values, double p);

// P99 of the absolute residuals |yhat - y| (Eq. 3 with P = 0.99).
double p99_abs_residual(std::span<const double> measured, std::span<const double> predicted);

// Eq. 6: SMAPE = 100 / n * sum |yhat - y| / (|yhat| + |y|) [%], in 0..100. A term with
// y = yhat = 0 counts as 0 (a perfect prediction of a zero error), not as 0/0.
double smape_percent(std::span<const double> measured, std::span<const double> predicted);

// Eq. 7 (Pd, probe accounting) is probing's: probing::productivity_percent (probing/schedule.hpp).

}  // namespace alc
