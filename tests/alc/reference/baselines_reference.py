#!/usr/bin/python3
"""Reference values for tests/alc/baselines_test.cpp, computed once with independent tools
(numpy, scipy, scikit-learn from Debian 12: python3-numpy, python3-scipy, python3-sklearn).

    /usr/bin/python3 tests/alc/reference/baselines_reference.py

The data are the formulas of baselines_test.cpp (data_x, data_y, grey_history)."""
import math

import numpy as np
from scipy import stats
from sklearn.linear_model import LassoCV
from sklearn.model_selection import KFold
from sklearn.svm import SVR

m = 30
X = np.array([[20 + 0.5 * i + 0.8 * math.sin(0.7 * i),
               22 + 3 * (1 - math.exp(-i / 8)) + 0.3 * math.cos(1.3 * i),
               0.1 * i * i / 30 + 0.5 * math.sin(2.1 * i)] for i in range(m)])
y = np.array([3 + 2.0 * (X[i, 0] - 20) - 1.5 * (X[i, 1] - 22) + 0.4 * math.sin(3.7 * i) for i in range(m)])
mean, sd = X.mean(axis=0), X.std(axis=0)  # population sd, as the C++ code
Z = (X - mean) / sd
np.set_printoptions(precision=17)

# Lasso (seed 003 Eq. 13): sklearn's objective is the same 1/(2N)|y - Xw|^2 + alpha |w|_1.
yc = y - y.mean()
lmax = np.max(np.abs(Z.T @ yc)) / m
grid = lmax * 10.0 ** (-3.0 * np.arange(50) / 49)
lasso = LassoCV(alphas=grid, cv=KFold(5), tol=1e-14, max_iter=1000000).fit(Z, y)
coef = lasso.coef_ / sd
print("lasso lambda", repr(lasso.alpha_))
print("lasso coefficients", [repr(c) for c in coef])
print("lasso intercept", repr(lasso.intercept_ - np.sum(coef * mean)))

# OLS with p-values (seed 000), then OLS on the inputs with p < 0.05.
def ols(cols):
    A = np.column_stack([np.ones(m)] + [X[:, c] for c in cols])
    b, *_ = np.linalg.lstsq(A, y, rcond=None)
    dof = m - A.shape[1]
    s2 = np.sum((y - A @ b) ** 2) / dof
    se = np.sqrt(np.diag(s2 * np.linalg.inv(A.T @ A)))
    p = 2 * stats.t.sf(np.abs(b / se), dof)
    return b, p
b, p = ols([0, 1, 2])
print("ols p-values", [repr(v) for v in p[1:]])
kept = [c for c in range(3) if p[c + 1] < 0.05]
b2, _ = ols(kept)
print("ols kept", kept, "refit", [repr(v) for v in b2])

# epsilon-SVR, RBF kernel, standardised inputs and output, fixed parameters.
ys = (y - y.mean()) / y.std()
svr = SVR(kernel="rbf", C=10.0, gamma=0.5, epsilon=0.05, tol=1e-8).fit(Z, ys)
x_new = np.array([[27.0, 24.0, 1.0], X[7]])
print("svr predictions", [repr(v) for v in y.mean() + y.std() * svr.predict((x_new - mean) / sd)])
print("svr support vectors", len(svr.support_))
# The CV grid of SvrBaseline::fit_by_cv.
best = None
for C in (1.0, 10.0, 100.0, 1000.0):
    for g in (0.1, 1.0, 10.0):
        mse = 0.0
        for tr, te in KFold(5).split(Z):
            s = SVR(kernel="rbf", C=C, gamma=g / 3, epsilon=0.05, tol=1e-3).fit(Z[tr], ys[tr])
            mse += np.mean((ys[te] - s.predict(Z[te])) ** 2) / 5
        if best is None or mse < best[0]:
            best = (mse, C, g / 3)
print("svr cv C", best[1], "gamma", repr(best[2]))

# GM(1,N) on unequal intervals (docs/baselines.md): inputs sampled every 60 s for 6 h, held from
# sample to sample; measurements every 20 min, then every 40 min.
t = np.arange(0, 6 * 3600 + 1, 60.0)
U = np.column_stack([20 + 5 * (1 - np.exp(-t / 7200)) + 0.2 * np.sin(t / 900),
                     21 + 2 * np.sin(t / 5000)])
tm = np.concatenate([np.arange(0, 3 * 3600, 1200.0), np.arange(3 * 3600, 6 * 3600 + 1, 2400.0)])
# The measured error: dy' = -a dy + b . du with a = 1/1.5 h, b = (1.2, -0.5), exact for held inputs,
# from y(0) = 1, plus 0.05 sin(t / 1000) at the measurements.
ysim = [0.0]
for k in range(1, len(t)):
    h = (t[k] - t[k - 1]) / 3600
    f = np.array([1.2, -0.5]) @ (U[k - 1] - U[0])
    ysim.append(ysim[-1] * math.exp(-h / 1.5) + f * 1.5 * (1 - math.exp(-h / 1.5)))
ym = np.array([1 + ysim[int(tt // 60)] + 0.05 * math.sin(tt / 1000) for tt in tm])
def integral(tq):  # int_{t1}^{tq} (u - u(t1)) dt [unit h], zero-order hold
    k = np.searchsorted(t, tq, side="right") - 1
    du = U[: k + 1] - U[0]
    dt = np.diff(np.append(t[: k + 1], tq)) / 3600
    return (du * dt[:, None]).sum(axis=0)
Y1 = np.concatenate([[0], np.cumsum(0.5 * ((ym[1:] - ym[0]) + (ym[:-1] - ym[0])) * np.diff(tm) / 3600)])
A = np.column_stack([-Y1[1:], np.array([integral(tt) for tt in tm[1:]])])
theta, *_ = np.linalg.lstsq(A, ym[1:] - ym[0], rcond=None)
print("gm a", repr(theta[0]), "b", [repr(v) for v in theta[1:]])
# The whitened equation solved exactly from t1 on the sample grid.
a, bb = theta[0], theta[1:]
dy, pred = 0.0, [ym[0]]
for k in range(1, len(t)):
    h = (t[k] - t[k - 1]) / 3600
    f = bb @ (U[k - 1] - U[0])
    dy = dy * math.exp(-a * h) + f * (1 - math.exp(-a * h)) / a
    pred.append(ym[0] + dy)
print("gm predictions at 2 h, 6 h", repr(pred[120]), repr(pred[360]))
