"""Bounded least squares and the two tail probabilities that ``vrcal discover`` needs, with numpy alone.

Why not scipy: importing ``scipy.optimize`` and ``scipy.special`` takes longer (0.5-1 s on a
small machine) than all the fits of a discover run, and the speed goal of the command (issue 9:
the whole process at most 0.6 times a plain script of one ``scipy.optimize.least_squares`` per
candidate) cannot be met while paying it. The problems here are small (3-25 parameters, box
bounds, a Jacobian computed in one vectorised simulation), for which Levenberg-Marquardt with
an active set is the textbook method.

* :func:`least_squares_box` -- Levenberg-Marquardt (Marquardt's diagonal damping, Nielsen's
  update of the damping) on variables scaled by ``x_scale``; a parameter at a bound whose
  gradient points outwards is held there for the step (active set), every trial point is
  clipped into the box.
* :func:`chi2_sf`, :func:`f_sf` -- P(X > x) of the chi-square and F distributions through the
  regularized incomplete gamma and beta functions (series and continued fractions, Numerical
  Recipes 3rd ed., Secs. 6.2 and 6.4); tested against scipy.special to 1e-10.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np


class Solution(NamedTuple):
    """What :func:`least_squares_box` returns."""

    x: np.ndarray
    fun: np.ndarray
    jac: np.ndarray
    nfev: int
    success: bool
    message: str


def least_squares_box(fun, jac, x0, lo, hi, x_scale, *, max_iter=60, xtol=1e-10, ftol=1e-10):
    """Minimise ``|fun(x)|^2`` over the box ``lo <= x <= hi``.

    Parameters
    ----------
    fun : callable
        ``fun(x) -> r`` residuals (n,)
    jac : callable
        ``jac(x) -> J`` (n, k); it may cache ``fun(x)`` (``fun`` is called again at the same x)
    x0, lo, hi, x_scale : ndarray (k,)
        start, bounds and the typical size of each parameter (the solver works on x / x_scale)
    max_iter : int
        most Jacobian evaluations
    xtol, ftol : float
        stop when a step changes no scaled parameter by more than xtol (relative), or the
        cost by less than ftol (relative) in a step that the local quadratic model predicted
        well (as scipy's ``least_squares`` does)

    Returns
    -------
    Solution
    """
    lo = np.asarray(lo, dtype=float)
    hi = np.asarray(hi, dtype=float)
    scale = np.asarray(x_scale, dtype=float)
    x = np.clip(np.asarray(x0, dtype=float), lo, hi)
    r = fun(x)
    cost = float(r @ r)
    nfev = 1
    lam, nu = None, 2.0
    message, success = "the most iterations were used", False
    J = None
    for _ in range(int(max_iter)):
        J = jac(x)
        r = fun(x)
        Js = J * scale[None, :]
        g = Js.T @ r                          # half the gradient of the cost, scaled variables
        A = Js.T @ Js
        free = ~(((x <= lo) & (g > 0)) | ((x >= hi) & (g < 0)))
        if not np.any(free):
            message, success = "every parameter is held at a bound", True
            break
        if np.max(np.abs(g[free])) <= 1e-14 * max(cost, 1e-300) ** 0.5 * max(np.max(np.abs(Js)), 1e-300):
            message, success = "the gradient vanishes", True
            break
        diag = np.diag(A).copy()
        diag = np.where(diag > 0, diag, max(float(np.max(diag)), 1.0) * 1e-12)
        if lam is None:
            lam = 1e-3
        accepted = False
        while True:
            Af = A[np.ix_(free, free)] + lam * np.diag(diag[free])
            try:
                step = np.zeros_like(x)
                step[free] = -np.linalg.solve(Af, g[free])
            except np.linalg.LinAlgError:
                lam *= nu
                nu *= 2.0
                if lam > 1e16:
                    break
                continue
            x_new = np.clip(x + step * scale, lo, hi)
            r_new = fun(x_new)
            nfev += 1
            cost_new = float(r_new @ r_new)
            predicted = -(2.0 * float(g @ ((x_new - x) / scale))
                          + float(((x_new - x) / scale) @ A @ ((x_new - x) / scale)))
            if np.isfinite(cost_new) and cost_new < cost:
                rho = (cost - cost_new) / predicted if predicted > 0 else 0.0
                lam *= max(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3)
                nu = 2.0
                accepted = True
                break
            lam *= nu
            nu *= 2.0
            if lam > 1e16:
                break
        if not accepted:
            message, success = "no step lowers the cost", True
            break
        dx = np.abs(x_new - x) / scale
        dcost = cost - cost_new
        x, r, cost = x_new, r_new, cost_new
        if np.all(dx <= xtol * (np.abs(x / scale) + xtol)):
            message, success = "the step is below xtol", True
            break
        if dcost <= ftol * cost and rho > 0.25:   # a small change where the quadratic model is trusted
            message, success = "the cost changes by less than ftol", True
            break
    r = fun(x)
    if J is None or message != "every parameter is held at a bound":
        J = jac(x)
    return Solution(x, r, J, nfev, success, message)


# --------------------------------------------------------------------------- tail probabilities


def _gamma_q(a, x):
    """Regularized upper incomplete gamma Q(a, x) (NR 6.2: series for x < a + 1, else continued fraction)."""
    if x <= 0:
        return 1.0
    gln = math.lgamma(a)
    if x < a + 1.0:
        term = total = 1.0 / a
        ap = a
        for _ in range(10000):
            ap += 1.0
            term *= x / ap
            total += term
            if abs(term) < abs(total) * 1e-16:
                break
        return max(0.0, 1.0 - total * math.exp(-x + a * math.log(x) - gln))
    b = x + 1.0 - a
    c = 1.0 / _TINY
    d = 1.0 / b
    h = d
    for i in range(1, 10000):
        b += 2.0
        c, d, delta = _lentz(c, d, -i * (i - a), b)
        h *= delta
        if abs(delta - 1.0) < 1e-16:
            break
    return math.exp(-x + a * math.log(x) - gln) * h


_TINY = 1e-300


def _lentz(c, d, a_n, b_n):
    """One step of the modified Lentz method for a continued fraction b_0 + a_1/(b_1 + a_2/(b_2 + ...)):
    the new (C, D) and their product, the factor of the running value."""
    d = b_n + a_n * d
    d = _TINY if abs(d) < _TINY else d
    c = b_n + a_n / c
    c = _TINY if abs(c) < _TINY else c
    d = 1.0 / d
    return c, d, c * d


def _beta_cf(a, b, x):
    """Continued fraction of the incomplete beta function (NR 6.4, modified Lentz)."""
    qab, qap, qam = a + b, a + 1.0, a - 1.0
    c, d = 1.0, 1.0 - qab * x / qap
    d = 1.0 / (_TINY if abs(d) < _TINY else d)
    h = d
    for m in range(1, 10000):
        m2 = 2 * m
        c, d, delta = _lentz(c, d, m * (b - m) * x / ((qam + m2) * (a + m2)), 1.0)
        h *= delta
        c, d, delta = _lentz(c, d, -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2)), 1.0)
        h *= delta
        if abs(delta - 1.0) < 1e-16:
            break
    return h


def _beta_i(a, b, x, y):
    """Regularized incomplete beta I_x(a, b); ``y`` = 1 - x, computed by the caller without
    cancellation (near x = 1 the rounded ``1 - x`` loses every digit)."""
    if x <= 0.0:
        return 0.0
    if y <= 0.0:
        return 1.0
    front = math.exp(math.lgamma(a + b) - math.lgamma(a) - math.lgamma(b) + a * math.log(x) + b * math.log(y))
    if x < (a + 1.0) / (a + b + 2.0):
        return front * _beta_cf(a, b, x) / a
    return 1.0 - front * _beta_cf(b, a, y) / b


def chi2_sf(x, dof):
    """P(X > x) for a chi-square variable with ``dof`` degrees of freedom: Q(dof / 2, x / 2)."""
    x = float(x)
    if not x > 0:
        return 1.0
    if math.isinf(x):
        return 0.0
    return float(min(1.0, max(0.0, _gamma_q(0.5 * float(dof), 0.5 * x))))


def f_sf(x, dfn, dfd):
    """P(X > x) for an F variable with (dfn, dfd) degrees of freedom: I_{dfd / (dfd + dfn x)}(dfd / 2, dfn / 2)."""
    x = float(x)
    if not x > 0:
        return 1.0
    if math.isinf(x):
        return 0.0
    s = dfd + dfn * x
    return float(min(1.0, max(0.0, _beta_i(0.5 * dfd, 0.5 * dfn, dfd / s, dfn * x / s))))
