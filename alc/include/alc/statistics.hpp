#pragma once
// Distribution functions for significance tests (seed 000: OLS p-values of the inputs). Pure math.

namespace alc {

// Regularised incomplete beta function I_x(a, b) for 0 <= x <= 1, a, b > 0 (continued fraction,
// relative accuracy ~1e-14). NaN outside the domain.
double regularized_incomplete_beta(double x, double a, double b);

// P(F > f) for Fisher's F distribution with d1, d2 degrees of freedom: the p-value of an F test.
// f <= 0 gives 1; NaN for d1 <= 0, d2 <= 0 or a NaN argument.
double f_distribution_sf(double f, double d1, double d2);

}  // namespace alc
