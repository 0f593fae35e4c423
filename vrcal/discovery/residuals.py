"""From a model to residuals and statistics: the fitting core of ``vrcal discover``.

A *model* is the paper's baseline -- a ball released from rest at a drop height,
bouncing with one constant restitution ε (Eq. (3) of [1]), g known -- plus zero or
more candidate effects of the registry :data:`vrcal.drop.effects.EFFECTS`. This module

* lays out the free parameters of a model for a data kind (:func:`parameter_layout`),
* predicts the data with the vectorised simulator (:func:`predict`): many parameter
  sets in ONE :func:`vrcal.drop.simulate.simulate_drops` call,
* fits a model by bounded least squares (Levenberg-Marquardt, :mod:`vrcal.discovery.lsq`)
  with a finite-difference Jacobian computed in one vectorised call (:func:`fit_model`),
* computes the statistics of the fit from the same residuals (:func:`rss`,
  :func:`chi_square`, :func:`aic`, :func:`bic`), the evidence of a model with the
  registry's prior densities (:func:`minus_two_ln_evidence`) and the noise floor of the
  data (:func:`noise_floor`).

Residuals are ``data - model`` in the data's unit: metres for trajectories and apex
heights, seconds for impact times.

References
----------
[1] "The Graphical Method for Decision of Restitution Coefficient and Its
    Applications" (the baseline: constant ε, Eq. (3); drop test Eqs. (8), (9)).
[2] K. P. Burnham, D. R. Anderson, "Model Selection and Multimodel Inference",
    2nd ed., Springer 2002 (AIC; BIC of Schwarz 1978), for least squares:
    AIC = n ln(RSS/n) + 2k, BIC = n ln(RSS/n) + k ln n.
[3] R. E. Kass, A. E. Raftery, "Bayes factors", J. Am. Stat. Assoc. 90, 773 (1995),
    Sec. 4.1.1 (Laplace approximation of the evidence); D. J. C. MacKay, "Information
    Theory, Inference, and Learning Algorithms", CUP 2003, Ch. 28 (Occam factor).

Departures from [1]
-------------------
* [1] reads ε from two heights (Eq. (9)); here ε is fitted to a whole record
  together with the drop height and the release time, so every sample counts.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field

import numpy as np

from vrcal.errors import DataError, UsageError
from vrcal.measurements.cleanup import third_difference_sigma
from vrcal.model.restitution import STANDARD_GRAVITY_M_PER_S2

#: Data kinds the fitter knows, and the unit of their residuals.
KINDS = {"trajectory": "m", "impacts": "s", "apexes": "m"}

#: Most bounces a model simulates (beyond this, flights are shorter than any sampling).
MAX_BOUNCES = 40


# --------------------------------------------------------------------------- statistics (pure)


def rss(residuals):
    """Residual sum of squares [unit²] of ``residuals`` (last axis)."""
    r = np.asarray(residuals, dtype=float)
    return np.sum(r * r, axis=-1)


def rms(residuals):
    """Root-mean-square residual [unit] (the "gap") of ``residuals`` (last axis)."""
    r = np.asarray(residuals, dtype=float)
    return np.sqrt(np.mean(r * r, axis=-1))


def chi_square(rss_value, sigma):
    """χ² = RSS / σ² (dimensionless) with σ the noise of one datum [unit]."""
    return np.asarray(rss_value, dtype=float) / np.asarray(sigma, dtype=float) ** 2


def aic(rss_value, n, k):
    """Akaike information criterion of a least-squares fit, AIC = n ln(RSS/n) + 2k [2].

    Parameters
    ----------
    rss_value : float or ndarray
        residual sum of squares [unit²]
    n : int
        number of data
    k : int
        number of free parameters
    """
    return n * np.log(np.asarray(rss_value, dtype=float) / n) + 2.0 * k


def bic(rss_value, n, k):
    """Bayesian (Schwarz) information criterion, BIC = n ln(RSS/n) + k ln n [2].

    Parameters as :func:`aic`. Lower is better; a difference of more than 10 is
    "very strong" evidence (Kass and Raftery 1995).
    """
    return n * np.log(np.asarray(rss_value, dtype=float) / n) + k * math.log(n)


def _prior_integral(param, value, sd, ball, n_grid=2001):
    """ln of the integral of exp(-(x - value)^2 / (2 sd^2)) times the prior density of ``param``
    (a :class:`vrcal.drop.effects.Parameter`), renormalised to its hard physical limits (within the
    fitter's bounds), over those limits: the density vanishes beyond them. A fit held at a limit (its
    optimum beyond: :func:`vrcal.discovery.ranking.fit_physical`) keeps only the likelihood inside, about
    half of it (2 ln 2 = 1.4 more in -2 ln Z), against an effect that fits as well inside its limits."""
    lo, hi = map(float, param.bounds)
    a, b = param.physical_limits(ball)
    lo, hi = max(lo, a), min(hi, b)
    if math.isinf(sd):
        return 0.0   # the data say nothing about the parameter: the whole prior
    grid = np.linspace(lo, hi, n_grid)
    sd = float(sd) if math.isfinite(sd) and sd > 0 else 0.0
    sd = max(sd, 1e-9 * (hi - lo))
    local = np.clip(value + sd * np.linspace(-8.0, 8.0, 161), lo, hi)
    x = np.unique(np.concatenate([grid, local]))
    dens = param.prior_pdf(x, ball)
    dx = np.diff(x)

    def trapezoid(f):   # np.trapezoid needs numpy >= 2
        return float(np.sum(0.5 * (f[1:] + f[:-1]) * dx))

    mass = trapezoid(dens)
    if not mass > 0:
        return -700.0
    z = (x - value) / sd
    integral = trapezoid(np.exp(-0.5 * z * z) * dens) / mass
    return math.log(integral) if integral > 1e-300 else -700.0


def minus_two_ln_evidence(fit, sigma):
    """-2 ln of the model evidence of a fit (Laplace approximation), up to a constant that is
    the same for every model of the same data.

    Parameters
    ----------
    fit : FitResult
        a fitted model (its ``extra["jtj"]``, JᵀJ at the optimum, is used)
    sigma : float
        noise of one datum [data unit], the same for every model that is compared

    Returns
    -------
    float
        ``chi2 + ln det(F_b / 2 pi) - 2 ln I_e``, lower is better. chi2 = RSS / sigma^2;
        F = JᵀJ / sigma^2 is the Fisher matrix, F_b its block of the baseline parameters
        (drop height, release time, epsilon: flat priors, common to every model);
        I_e = the integral over the effect parameters of the likelihood (a Gaussian with
        their marginal covariance, the baseline profiled out) times their prior densities
        (``Parameter.prior_pdf``, :mod:`vrcal.drop.effects`): the Occam factor, the fraction of
        the prior that the data allow. One effect parameter theta with marginal sd s gives
        ``-2 ln I_e = -2 ln integral exp(-(theta - theta_hat)^2 / 2 s^2) prior(theta) dtheta``
        (about ``-ln(2 pi s^2) - 2 ln prior(theta_hat)`` when s is small); several are taken
        as independent, corrected by ``-ln det`` of their correlation matrix.

    Notes
    -----
    The BIC is the large-n limit of this with a unit-information prior; with a physical
    prior the evidence also asks how plausible the fitted value is: a candidate that
    mimics another effect with an implausible parameter (a drag coefficient of 0.1, a
    speed exponent of 0.02) loses to the effect that fits as well with a plausible one
    [3]. The integral is numerical (the bounds' grid plus +-8 s around theta_hat), so a
    likelihood wider than the prior costs nothing (ln I -> 0) and a value where the prior
    vanishes costs a lot (ln I floored at -700).
    """
    from vrcal.drop.effects import EFFECTS

    sigma2 = float(sigma) ** 2
    jtj = fit.extra.get("jtj")
    if jtj is None:
        obj = _Objective(fit.layout, fit.problem, _scales(fit.layout, fit.values))
        J = obj.jac(np.asarray(fit.values, dtype=float).copy())
        jtj = fit.extra["jtj"] = J.T @ J
    F = np.asarray(jtj, dtype=float) / sigma2
    base = [i for i, p in enumerate(fit.layout) if p.effect is None]
    eff = [i for i, p in enumerate(fit.layout) if p.effect is not None]
    Fbb = F[np.ix_(base, base)]
    _sign, logdet_b = np.linalg.slogdet(Fbb / (2.0 * math.pi))
    out = fit.rss / sigma2 + float(logdet_b)
    if not eff:
        return float(out)
    Feb = F[np.ix_(eff, base)]
    precision = F[np.ix_(eff, eff)] - Feb @ np.linalg.pinv(Fbb) @ Feb.T   # baseline profiled out
    precision = 0.5 * (precision + precision.T)
    w, V = np.linalg.eigh(precision)
    good = w > 1e-12 * max(float(np.max(np.abs(w))), 1e-300)
    cov = (V[:, good] / w[good]) @ V[:, good].T
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    # a direction the data do not constrain at all: the likelihood is flat there (infinite sd)
    flat = np.any(np.abs(V[:, ~good]) > 1e-6, axis=1) if np.any(~good) else np.zeros(len(eff), bool)
    sd = np.where(flat, np.inf, sd)
    ball = fit.problem.ball
    for j, i in enumerate(eff):
        p = fit.layout[i]
        param = EFFECTS[p.effect].parameter(p.name)
        out -= 2.0 * _prior_integral(param, float(fit.values[i]), sd[j], ball)
    if len(eff) > 1 and np.all(np.isfinite(sd)) and np.all(sd > 0):
        corr = cov / np.outer(sd, sd)
        out -= float(np.log(np.clip(np.linalg.det(corr), 1e-12, 1.0)))
    return float(out)


def noise_floor(data):
    """Noise of one datum [unit] estimated from the data alone, or None.

    For a trajectory sampled at a constant rate, the third difference of a flight
    (a parabola, or nearly so with drag) is zero, so the third differences are noise
    with variance 20 σ² (coefficients 1, -3, 3, -1). The median absolute deviation
    makes the estimate robust to the few differences that straddle an impact or the
    release. Several runs: the root mean square of the runs' estimates (weighted by their
    samples). Apex heights: the pooled scatter of the rebounds of trials repeated at one drop
    height (:func:`replicate_sigma`), when the table repeats trials. Impact times, and apex
    heights without repeated trials, are too few for a model-free estimate: None (the discover
    workflow then assumes an instrument noise).
    """
    runs = _runs_of(data)
    if runs[0].kind == "apexes":
        return replicate_sigma(runs)[0]
    if runs[0].kind != "trajectory":
        return None
    values, weights = [], []
    for run in runs:
        s = third_difference_sigma(np.asarray(run.t_s, dtype=float), np.asarray(run.y_m, dtype=float))
        if s is not None:
            values.append(s * s)
            weights.append(len(run.t_s))
    if not values:
        return None
    return float(math.sqrt(np.average(values, weights=weights)))


#: Fewest degrees of freedom of repeated trials that give a measured noise (:func:`replicate_sigma`).
MIN_REPLICATE_DOF = 3


def replicate_sigma(runs):
    """(σ [m] or None, degrees of freedom): the pooled standard deviation of the rebound heights of
    trials repeated at one drop height (in one file, the same drop height as written, the same bounce number).

    It is the "pure error" of a lack-of-fit test: what no model of the contact can follow (the
    reading of each rebound, and the ball's own bounce-to-bounce scatter), measured without a model.
    None with fewer than :data:`MIN_REPLICATE_DOF` degrees of freedom.
    """
    ss, dof = _pure_error(runs, _replicate_groups(runs))
    if dof < MIN_REPLICATE_DOF:
        return None, dof
    return math.sqrt(ss / dof), dof


#: Likelihood-ratio statistic above which the trials' scatter is taken to grow with the height
#: (:func:`replicate_noise_model`; chi-square of 1 degree of freedom at 5 %).
HEIGHT_DEPENDENT_NOISE_LR = 3.84


def replicate_noise_model(runs):
    """How the scatter of repeated trials depends on the height: ``{"absolute_m": a, "relative": b,
    "lr": ...}`` with the variance of a rebound of height h [m] ``a**2 + (b h)**2``, fitted by maximum
    likelihood to the groups of :func:`replicate_sigma` (each group's sample variance s² of d degrees of
    freedom is σ² χ²_d / d), and ``lr`` the likelihood ratio statistic against one pooled σ (b = 0); None
    with fewer than three groups or :data:`MIN_REPLICATE_DOF` degrees of freedom.

    A class reads a rebound of 1.9 m to about 1 % (19 mm) and one of 0.15 m to 1.5 mm: one pooled σ
    (10.5 mm) over 0.2-2.5 m drops weighs them alike, and the least-squares ± of ε, which rests on the
    high drops most, came out 1.5 times too small (an independent probe's 24 planted tables: 79 % within
    2 σ).
    """
    from scipy.optimize import minimize

    groups = _replicate_groups(runs)
    h = np.concatenate([np.asarray(run.h_m, dtype=float) for run in runs]) if runs else np.zeros(0)
    if len(groups) < 3:
        return None
    m = np.array([h[i].mean() for i in groups.values()])
    s2 = np.array([h[i].var(ddof=1) for i in groups.values()])
    d = np.array([i.size - 1 for i in groups.values()], dtype=float)
    if d.sum() < MIN_REPLICATE_DOF or not np.sum(d * s2) > 0:
        return None
    floor = (1e-5 * float(np.median(m))) ** 2      # 0.001 % of the heights, which no reading reaches: ln v finite

    def nll(v):
        v = np.maximum(v, floor)
        return float(0.5 * np.sum(d * (np.log(v) + s2 / v)))

    pooled = float(np.sum(d * s2) / d.sum())
    scale = max(pooled, floor)
    # the two variances in units of the pooled one (b² over the mean squared height), from three starts
    unit = np.array([scale, scale / float(np.mean(m * m))])
    best = min((minimize(lambda y: nll(y[0] * unit[0] + y[1] * unit[1] * m * m), np.array(start),
                         method="L-BFGS-B", bounds=[(0.0, None), (0.0, None)], options={"ftol": 1e-12})
                for start in ((1.0, 0.0), (0.0, 1.0), (0.5, 0.5))), key=lambda r: r.fun)
    a2, b2 = best.x * unit
    lr = 2.0 * (nll(np.full(m.size, pooled)) - float(best.fun))
    return {"absolute_m": float(math.sqrt(max(a2, 0.0))), "relative": float(math.sqrt(max(b2, 0.0))),
            "lr": float(max(lr, 0.0))}


def heteroscedastic_uncertainties(fit, model):
    """1-sigma of a fit's parameters (its layout's order and units) from the sandwich
    ``(JᵀJ)⁻¹ Jᵀ V J (JᵀJ)⁻¹``: the least-squares values with each datum's own variance V, ``a² + (b h)²``
    for a rebound of the model's height h and ``a²`` for a drop height, set by the experimenter (``model``:
    :func:`replicate_noise_model`)."""
    from dataclasses import replace

    obj = _Objective(fit.layout, replace(fit.problem, weights=None), _scales(fit.layout, fit.values))
    J = obj.jac(np.asarray(fit.values, dtype=float).copy())[: fit.n]
    a2, b2 = model["absolute_m"] ** 2, model["relative"] ** 2
    h = observed_values(fit.problem.data) - np.asarray(fit.residuals, dtype=float)
    first = np.concatenate([np.asarray(run.bounce, dtype=int) == 0 for run in _runs_of(fit.problem.data)])
    v = np.where(first, a2, a2 + b2 * h * h)
    inv = np.linalg.pinv(J.T @ J)
    cov = inv @ (J.T * v) @ J @ inv
    return np.sqrt(np.clip(np.diag(cov), 0.0, None))


def flight_offset_uncertainties(fit, sigma_m):
    """1-sigma of a fit's parameters (its layout's order and units) from an error of the heights that is the
    same over each flight between bounces and independent from flight to flight, of standard deviation
    ``sigma_m`` [m]: the sandwich ``(JᵀJ)⁻¹ Jᵀ V J (JᵀJ)⁻¹`` with ``V = sigma_m² Σ_f 1_f 1_fᵀ`` (a flight's
    samples fully correlated). A video tracker's systematic error of the centres (a blurred ball's centre
    pulled a little along its motion, a frame's brightness moving it) does not average away over a flight's
    frames as independent noise does: on a render with a flickering light and the camera's auto-exposure,
    epsilon came out 10 of its fit's +- from the truth.

    Parameters
    ----------
    fit : FitResult
        a fit of trajectories
    sigma_m : float
        the error common to a flight's samples [m]
    """
    from dataclasses import replace

    obj = _Objective(fit.layout, replace(fit.problem, weights=None), _scales(fit.layout, fit.values))
    J = obj.jac(np.asarray(fit.values, dtype=float).copy())[: fit.n]
    sums = []
    for r, (run, part) in enumerate(zip(_runs_of(fit.problem.data), fit.run_slices())):
        impacts = np.asarray(fit.model(run=r).impact_times_s, dtype=float).ravel()
        flight = np.searchsorted(np.sort(impacts[np.isfinite(impacts)]), np.asarray(run.t_s, dtype=float))
        Jr = J[part]
        sums += [Jr[flight == f].sum(axis=0) for f in np.unique(flight)]
    G = np.array(sums)
    inv = np.linalg.pinv(J.T @ J)
    cov = float(sigma_m) ** 2 * inv @ (G.T @ G) @ inv
    return np.sqrt(np.clip(np.diag(cov), 0.0, None))


def run_file(run):
    """The file a run was read from: its ``source`` without the ``:LINE`` a drop table's row adds to it; None
    when that names no file (runs built in code, whose sources are labels: one record)."""
    source = str(getattr(run, "source", "") or "")
    head, colon, line = source.rpartition(":")
    path = head if colon and line.isdigit() else source
    return path if path and os.path.isfile(path) else None


def _replicate_groups(runs):
    """{(file, drop height as written [m], bounce number): [index of the rebound among the runs' heights, one
    run after another]} of the rebounds of runs that start at their drop height (bounce 0), two or more a
    group. Trials of one file only (:func:`run_file`): two files' rows at one height are no repeated trials
    until they are shown to be of one ball (two balls' tables pooled gave a "noise" of 65 mm for 5 mm)."""
    groups, start = {}, 0
    for run in runs:
        b, h = np.asarray(run.bounce, dtype=int), np.asarray(run.h_m, dtype=float)
        if b.size >= 2 and b[0] == 0:
            for i, bounce in enumerate(b[1:], start=1):
                groups.setdefault((run_file(run) or "", round(float(h[0]), 9), int(bounce)), []).append(start + i)
        start += b.size
    return {key: np.asarray(idx) for key, idx in groups.items() if len(idx) >= 2}


def _pure_error(runs, groups):
    """(sum of squares [m^2], degrees of freedom) of the rebounds about their group's mean."""
    h = np.concatenate([np.asarray(run.h_m, dtype=float) for run in runs])
    return (float(sum(np.sum((h[i] - h[i].mean()) ** 2) for i in groups.values())),
            int(sum(i.size - 1 for i in groups.values())))


#: Probability under which :func:`lack_of_fit` calls a model's misfit of repeated trials real (one in a thousand).
LACK_OF_FIT_P = 1e-3


def lack_of_fit(runs, residuals_m, k_shared, sigma_floor_m=0.0):
    """The lack-of-fit F test of a drop table's repeated trials: do the rebounds of one drop height and
    bounce number agree with each other better than with the model?

    Trials repeated at one drop height (:func:`replicate_sigma`'s groups) measure the pure error
    without a model; the mean residual of each group is the model's misfit there. Under a model that
    holds, ``F = (SS_lof / dof_lof) / (SS_pe / dof_pe)`` follows the F distribution, with
    ``SS_lof = sum_g n_g rbar_g^2`` over the G groups, ``dof_lof = G - k_shared`` (at least 1), and
    ``SS_pe``, ``dof_pe`` the pure error (Draper & Smith, *Applied Regression Analysis*, Sec. 2.1). The
    gap alone, the RMS of every residual, dilutes a misfit shared by all trials of one bounce in
    their scatter: a golf ball's second rebounds 41 mm below a constant epsilon over 10 trials that
    scatter by 28 mm were "1.2 times the noise floor".

    Parameters
    ----------
    runs : sequence of apex runs
        the table's trials, each from its drop height (bounce 0)
    residuals_m : ndarray
        data - model of every height of the runs, one run after another [m]
    k_shared : int
        parameters the runs share (epsilon and the effects'); each run's own drop height is fitted to
        its bounce 0, outside the groups
    sigma_floor_m : float
        least pure error of one rebound [m]: trials written to whole cm that agree (17, 17, 18) scatter
        less than their rounding, which is the same for all trials of a group and so shows as misfit;
        the written step / sqrt(12) keeps it from being called one

    Returns
    -------
    dict or None
        {"F", "dof_lof", "dof_pe", "p", "groups": [{"drop_height_m", "bounce", "trials", "mean_residual_m",
        "standard_error_m"}]}; None without :data:`MIN_REPLICATE_DOF` degrees of pure error
    """
    from vrcal.discovery.lsq import f_sf

    groups = _replicate_groups(runs)
    ss_pe, dof_pe = _pure_error(runs, groups)
    if dof_pe < MIN_REPLICATE_DOF or ss_pe <= 0:
        return None
    r = np.asarray(residuals_m, dtype=float)
    sigma = max(math.sqrt(ss_pe / dof_pe), float(sigma_floor_m))
    rows = [{"drop_height_m": key[1], "bounce": key[2], "trials": int(i.size), "mean_residual_m": float(r[i].mean()),
             "standard_error_m": sigma / math.sqrt(i.size)}
            for key, i in sorted(groups.items(), key=lambda item: (item[0][1], item[0][2], item[0][0]))]
    ss_lof = sum(g["trials"] * g["mean_residual_m"] ** 2 for g in rows)
    dof_lof = max(len(rows) - int(k_shared), 1)
    F = (ss_lof / dof_lof) / sigma ** 2
    return {"F": float(F), "dof_lof": dof_lof, "dof_pe": dof_pe, "p": float(f_sf(F, dof_lof, dof_pe)), "groups": rows}


#: Most values :func:`qn_scale` takes all pairs of (beyond: the median absolute deviation).
QN_MOST = 2000
#: Small-sample factors of :func:`qn_scale` for n = 2-9 (Croux & Rousseeuw 1992, Table 2).
_QN_SMALL = {2: 0.399, 3: 0.994, 4: 0.512, 5: 0.844, 6: 0.611, 7: 0.857, 8: 0.669, 9: 0.872}


def qn_scale(x):
    """Robust standard deviation of ``x``: Rousseeuw and Croux's Qn (J. Am. Stat. Assoc. 88, 1273
    (1993)), 2.2219 c_n times the k-th smallest of the |x_i - x_j|, i < j, k = C(n // 2 + 1, 2), c_n
    the small-sample factor (Croux & Rousseeuw, Comput. Stat. 1992). It bears an odd value as the
    median absolute deviation does (a 50 % breakdown point) and is twice as efficient: of 2000
    records of 8 impacts with bounces scattering by 2 %, the median absolute deviation put the
    scatter below half its size in 26 % (a false "unexplained"), Qn in 16 %; of 12 impacts, 12 %
    and 5.5 %.

    Parameters
    ----------
    x : ndarray
        at least two values

    Returns
    -------
    float
        in the unit of ``x``
    """
    x = np.asarray(x, dtype=float)
    n = x.size
    if n > QN_MOST:   # n^2 / 2 pairs: the median absolute deviation, whose efficiency no longer matters
        return 1.4826 * float(np.median(np.abs(x - np.median(x))))
    pairs = np.abs(x[:, None] - x[None, :])[np.triu_indices(n, 1)]
    h = n // 2 + 1
    c = _QN_SMALL.get(n, n / (n + 1.4) if n % 2 else n / (n + 3.8))
    return 2.2219 * c * float(np.partition(pairs, h * (h - 1) // 2 - 1)[h * (h - 1) // 2 - 1])


def ratio_scatter(t_s):
    """Bounce-to-bounce scatter of a series of impact times: the robust standard deviation
    (:func:`qn_scale`) of the change of ln(dt_{i+1} / dt_i) from one ratio to the next, divided by
    sqrt(2) (dimensionless; 0.006 = the interval ratios scatter by 0.6 %), or None with fewer than
    four ratios.

    A slow trend of the ratios (air drag, a speed-dependent epsilon, a contact time) hardly
    changes successive ratios; a ball that hits the floor at slightly different spots, with
    some spin or drifting sideways, changes each one at random. This is the scatter a
    constant law cannot follow, whatever its effects. It includes the timing noise's share: with
    a known timing noise, :func:`bounce_scatter` gives the bounces' own.
    """
    t = np.asarray(t_s, dtype=float)
    if t.size < SCATTER_MIN_TIMES:
        return None
    return qn_scale(_ratio_change_values(t)) / math.sqrt(2.0)


def _ratio_change_values(t_s):
    """The changes of successive ratios ln(dt_{i+1} / dt_i) of a series of impact times (the second
    differences of ln dt)."""
    return np.diff(np.log(np.diff(np.asarray(t_s, dtype=float))), n=2)


def _ratio_changes(t_s):
    """(d, M) of a series of n impact times: the m = n - 3 changes d of successive ratios
    (:func:`_ratio_change_values`) and, to first order, the matrix M with d = M e for errors e [s] of the
    times (d ln dt_j = (e_{j+1} - e_j) / dt_j), as its band: M is (m, n) and row j touches only the
    times j .. j + 3, so it is held as an (m, 4) array [1/s] with ``M[j, j + c] = band[j, c]``
    (:func:`_band_matrix` gives the matrix). With a = 1/dt the row is
    (-a_j, a_j + 2 a_{j+1}, -2 a_{j+1} - a_{j+2}, a_{j+2}): the second difference of the rows
    (-a_i, a_i) of d ln dt."""
    t = np.asarray(t_s, dtype=float)
    a = 1.0 / np.diff(t)
    band = np.column_stack([-a[:-2], a[:-2] + 2.0 * a[1:-1], -2.0 * a[1:-1] - a[2:], a[2:]])
    return _ratio_change_values(t), band


def _band_matrix(band, n):
    """The sparse (m, n) matrix (scipy.sparse) whose row j holds ``band[j, c]`` in column j + c
    (m = band.shape[0]; :func:`_ratio_changes`)."""
    from scipy import sparse

    return sparse.diags([band[:, c] for c in range(band.shape[1])], list(range(band.shape[1])),
                        shape=(band.shape[0], n))


#: How much larger than assumed a stopwatch's timing noise may be (a phone's acoustic onsets: 0.05-1 ms
#: against the 0.2 ms assumed): :func:`bounce_scatter` sees the bounces' scatter beyond that.
UNKNOWN_TIMING_FACTOR = 5.0

#: Fewest impact times of one run in which :func:`bounce_scatter` and :func:`ratio_scatter` see the bounces'
#: scatter: 6 times, 4 interval ratios, 3 changes of ratio, 2 degrees of freedom about their mean.
SCATTER_MIN_TIMES = 6

#: Most changes of ratio :func:`bounce_scatter` weighs with their full covariance (beyond: each alone).
FULL_COVARIANCE_CHANGES = 300


def bounce_scatter(t_s, timing_sigma_s, t_model_s=None, alpha=0.05, timing_known=True, share_alpha=1.0):
    """The scatter of the bounces themselves (dimensionless: 0.02 = each bounce's epsilon scatters by
    2 %), for an uncertainty; 0 when the changes of successive ratios are what the timing noise alone
    gives, None with fewer than six times.

    Model: each bounce's epsilon is the ball's times exp(s z), z standard normal, so the changes of
    successive ln interval ratios are d = d_model + a + s (z_{j+1} - z_j) + M e
    (:func:`_ratio_changes`; d_model those of the fitted model's times ``t_model_s``, which follow its
    drag or speed law; a what is left of a trend; e the timing errors of standard deviation
    ``timing_sigma_s``): covariance C(s) = s^2 T + sigma_t^2 M M^T, T = tridiag(-1, 2, -1). With s = 0
    the generalized chi-square q = r^T C^-1 r of d about its weighted mean has m - 1 degrees of
    freedom; s is 0 unless q is beyond its ``alpha`` quantile, else the s at which q = m - 1 (a
    moment estimate). Beyond :data:`FULL_COVARIANCE_CHANGES` changes each is weighed alone (C's
    diagonal; M is held as its band of four times a row, so a long series costs O(n) memory and time).
    Measured: noise-only times of 10-14 impacts (0.2 ms, the model's times given) have a scatter
    in 5.0-5.8 % of 400 series; planted scatters of 0.5-3 % are found in 98-100 % of 300 series of
    8-12 impacts, RMS of the estimate 0.99-1.02 times the planted one.

    With ``timing_known`` False (an assumed stopwatch noise, not a given or a grid's), the assumed
    noise may be low. Changes beyond it but not beyond :data:`UNKNOWN_TIMING_FACTOR` times it are
    shared between timing and scatter by their shape, at the maximum of the restricted likelihood
    (REML over the share of the two in C, :func:`_scatter_by_reml`; tested at ``share_alpha``, by default
    its maximum, significant or not): timing weighs the short late
    intervals (1/dt^2) and correlates three neighbours, the bounces' scatter weighs all alike. A golf
    ball's 10 impact times with 1 ms jitter, the noise assumed 0.2 ms, had a "scatter" in 30 of 30
    records and their +- 21 times too wide; now the +- is widened in 12 of 30 (median ratio 1.0,
    within 1 / 2 +-: 0.73 / 0.90). The price: a planted 0.5 % scatter over 8 impacts, which 1 ms of
    timing would also explain, is covered within 1 +- in about half the records (coverage_scatter.py).

    Taken as the plain mean square of d less a typical timing share, the trend of a ping-pong ball's
    ratios (its drag) and the short late intervals counted as scatter: 34-38 % of noise-only series
    of 10 tennis-ball impacts with 0.2 ms jitter had a "scatter", and their +- came out 9-21 times
    too wide.
    """
    from vrcal.discovery.lsq import chi2_sf

    setup = _scatter_chi2(t_s, timing_sigma_s, t_model_s)
    if setup is None:
        return None
    q, dof, d, MMt, T, full = setup
    sigma2 = float(timing_sigma_s) ** 2
    if sigma2 == 0:   # no timing noise: all of it is the bounces'
        return math.sqrt(q(1.0) / dof)
    q0 = q(0.0)
    if chi2_sf(q0, dof) >= alpha:
        return 0.0
    if not timing_known and full and chi2_sf(q0 / UNKNOWN_TIMING_FACTOR**2, dof) >= alpha:
        # beyond the assumed noise, not beyond a timing UNKNOWN_TIMING_FACTOR times worse (the chi-square
        # scales as 1 / sigma^2): the shape of the changes shares them out (the maximum of the restricted
        # likelihood, significant or not)
        return _scatter_by_reml(d, MMt, T, alpha=share_alpha)
    return math.sqrt(_scatter_where(q, dof, d))


def likeliest_scatter(t_s, t_model_s=None):
    """The bounces' own scatter (dimensionless, as :func:`bounce_scatter`) of a series of impact times whose
    timing noise is not known: the maximum of the restricted likelihood over how the changes of successive
    ratios share out between the bounces' scatter and a timing noise of any size (:func:`_scatter_by_reml`,
    untested: the likeliest share). Timing weighs the short late intervals and correlates neighbours, the
    bounces weigh all alike, so times whose changes look like timing noise give about 0 whatever that noise's
    size. None with fewer than six times; beyond :data:`FULL_COVARIANCE_CHANGES` changes the robust scatter
    of the ratios (:func:`ratio_scatter`, which counts the timing noise as scatter).

    The robust scatter alone counted the timing noise as the ball's: golf impact times with 0.2 ms of
    jitter and no scatter "varied by 0.67 %", above the 0.41 % those times allow at that noise
    (:func:`scatter_upper_limit`), in 47 of 58 records.

    Parameters
    ----------
    t_s : ndarray
        impact times of one run [s]
    t_model_s : ndarray, optional
        the fitted model's impact times [s] (their changes of ratio are the model's, not scatter)
    """
    setup = _scatter_chi2(t_s, 1.0, t_model_s)
    if setup is None:
        return None
    _, _, d, MMt, T, full = setup
    if not full:
        return ratio_scatter(t_s)
    return _scatter_by_reml(d, MMt, T, alpha=1.0)


def _scatter_chi2(t_s, timing_sigma_s, t_model_s=None):
    """(q, dof, d, M M^T, T, full) of a series of impact times (:func:`bounce_scatter`): q(s^2) the
    generalized chi-square of the changes of ratio d about their mean under C = s^2 T + sigma_t^2 M M^T,
    decreasing in s^2, with dof degrees of freedom; None with fewer than six times."""
    t = np.asarray(t_s, dtype=float)
    if t.size < SCATTER_MIN_TIMES:
        return None
    d, band = _ratio_changes(t)
    if t_model_s is not None:
        d = d - _ratio_change_values(t_model_s)
    m = d.size
    full = m <= FULL_COVARIANCE_CHANGES
    if full:   # at most FULL_COVARIANCE_CHANGES x (FULL_COVARIANCE_CHANGES + 3): dense is cheap
        M = _band_matrix(band, t.size).toarray()
        MMt = M @ M.T
    else:      # each change alone: the diagonal of M M^T, the rows' sums of squares
        MMt = np.sum(band * band, axis=1)
    C0 = float(timing_sigma_s) ** 2 * MMt
    T = (2.0 * np.eye(m) - np.eye(m, k=1) - np.eye(m, k=-1)) if full else np.full(m, 2.0)

    def q(s2):   # generalized least squares of d on its mean: the chi-square
        return _gls_about_mean(d, s2 * T + C0, full)[0]

    return q, m - 1, d, MMt, T, full


def _scatter_where(q, target, d):
    """The s^2 at which the decreasing q(s^2) falls to ``target`` (bisection; q(0) > target)."""
    lo, hi = 0.0, max(float(np.mean((d - d.mean()) ** 2)), 1e-12)
    while q(hi) > target:
        hi *= 4.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if q(mid) > target else (lo, mid)
    return 0.5 * (lo + hi)


def scatter_upper_limit(t_s, timing_sigma_s, t_model_s=None, alpha=0.05):
    """The largest scatter of the bounces (dimensionless, as :func:`bounce_scatter`) that a series of
    impact times allows at confidence 1 - ``alpha``: the s at which the generalized chi-square of the
    changes of ratio, q(s^2), falls to the lower ``alpha`` quantile of its distribution (a larger
    scatter would make them vary more than they do). 0 when even none is too much; None with fewer
    than six times.

    A timing noise much larger than the bounces' effect on the ratios hides them: times printed to
    0.01 s (2.9 ms of noise) of 12 golf-ball impacts cannot tell a 2 % scatter from none, and then the
    +- of epsilon must not rest on none (:data:`vrcal.discovery.ranking.TYPICAL_BOUNCE_SCATTER`).

    Parameters
    ----------
    t_s : ndarray
        impact times of one run [s]
    timing_sigma_s : float
        standard deviation of each time [s], > 0
    t_model_s : ndarray, optional
        the fitted model's impact times [s] (their changes of ratio are the model's, not scatter)
    alpha : float
        one minus the confidence
    """
    from vrcal.discovery.lsq import chi2_sf

    if not timing_sigma_s > 0:
        return None
    setup = _scatter_chi2(t_s, timing_sigma_s, t_model_s)
    if setup is None:
        return None
    q, dof, d = setup[:3]
    lo, hi = 0.0, float(dof)      # the lower alpha quantile of chi2(dof): chi2_sf(c, dof) = 1 - alpha
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if chi2_sf(mid, dof) > 1.0 - alpha else (lo, mid)
    c = 0.5 * (lo + hi)
    if q(0.0) <= c:
        return 0.0
    return math.sqrt(_scatter_where(q, c, d))


def _gls_about_mean(d, C, full=True):
    """(chi-square, 1^T C^-1 1): the generalized chi-square of ``d`` about its weighted mean under
    covariance ``C`` (a matrix, or its diagonal when not ``full``), and the weight of that mean."""
    one = np.ones(d.size)
    w = np.linalg.solve(C, np.column_stack([d, one])) if full else np.column_stack([d, one]) / C[:, None]
    mu = float(one @ w[:, 0]) / float(one @ w[:, 1])
    return float((d - mu) @ (w[:, 0] - mu * w[:, 1])), float(one @ w[:, 1])


def _scatter_by_reml(d, MMt, T, alpha, shares=np.linspace(0.0, 1.0, 41)):
    """The bounces' scatter s from the changes of ratios ``d`` with covariance s^2 T + sigma_t^2 M M^T,
    both unknown (:func:`bounce_scatter`): the restricted likelihood (the mean of d profiled out) over
    the share f of timing in B(f) = (1 - f) T + f K (K = M M^T scaled to T's trace), the scale
    profiled too; 0 unless 2 (nll(timing alone) - nll(best)) passes ``alpha`` on a boundary."""
    from vrcal.discovery.lsq import chi2_sf

    m = d.size
    K = MMt * (np.trace(T) / np.trace(MMt))

    def nll(f):
        B = (1.0 - f) * T + f * K
        sign, logdet = np.linalg.slogdet(B)
        if sign <= 0:
            return math.inf, 0.0
        q, weight = _gls_about_mean(d, B)
        v = q / (m - 1)
        return 0.5 * ((m - 1) * math.log(max(v, 1e-300)) + logdet + math.log(weight)), v

    fits = [(*nll(f), f) for f in shares]
    best, v, f = min(fits)
    timing_alone = fits[-1][0]
    if alpha < 1.0 and 0.5 * chi2_sf(2.0 * (timing_alone - best), 1) >= alpha:   # on a boundary: half a chi2(1)
        return 0.0
    return math.sqrt(v * (1.0 - f))


def _run_slices(problem):
    """The residuals' slice of each run of a problem."""
    out, start = [], 0
    for run in problem.runs:
        n = observed_values(run).size
        out.append(slice(start, start + n))
        start += n
    return out


def _run_times(problem):
    """[(slice, t)] of a problem's impact times: each run's slice of the residuals and its times [s]."""
    return [(sl, np.asarray(run.t_s, dtype=float)) for run, sl in zip(problem.runs, _run_slices(problem))]


def _scatter_design(fit):
    """(J, runs) of a fit of impact times: its Jacobian J (n, k) at the fitted values and
    :func:`_run_times`, the runs' slices and times, which define the sensitivity A (n, n) of impact k
    to a change d ln(eps_j) at bounce j: ``A[k, j] = t_k - t_j`` [s] for j < k within a run, else 0 (a
    change of bounce j's epsilon stretches every later flight of its run by the same factor). A is
    never formed: :func:`_scatter_transpose_product` and :func:`_scatter_frobenius2` give what the
    statistics need of it in O(n k)."""
    from dataclasses import replace

    obj = _Objective(fit.layout, replace(fit.problem, weights=None), _scales(fit.layout, fit.values))
    J = obj.jac(np.asarray(fit.values, dtype=float).copy())
    return J, _run_times(fit.problem)


def _scatter_transpose_product(runs, X):
    """A^T X (n, p) for the scatter's sensitivity A of :func:`_scatter_design` (``runs`` its
    :func:`_run_times`) and X (n, p), in X's unit times seconds, without forming A.

    Row j within a run is ``sum_{k>j} (t_k - t_j) X_k``. With t_k - t_j = sum_{i=j}^{k-1} dt_i it is
    ``sum_{i>=j} dt_i H_i``, H_i = sum_{k>i} X_k: two reverse cumulative sums, O(n p), and no
    difference of large times (the dense form's A @ ... would cost O(n^2 p) and an (n, n) array)."""
    X = np.asarray(X, dtype=float)
    out = np.zeros_like(X)
    for sl, t in runs:
        if t.size < 2:
            continue
        x = X[sl]
        after = np.cumsum(x[::-1], axis=0)[::-1][1:]           # H_i = sum_{k>i} X_k, i = 0 .. n-2
        out[sl][:-1] = np.cumsum((np.diff(t)[:, None] * after)[::-1], axis=0)[::-1]
    return out


def _scatter_frobenius2(runs):
    """||A||_F^2 [s^2] of the scatter's sensitivity A (:func:`_scatter_design`): the sum over the pairs
    j < k of a run of (t_k - t_j)^2, O(n). With c_k = sum_{j<k} (t_k - t_j) and q_k = sum_{j<k}
    (t_k - t_j)^2: c_{k+1} = c_k + (k + 1) dt_k and q_{k+1} = q_k + 2 dt_k c_k + (k + 1) dt_k^2, sums of
    positive terms (no cancellation)."""
    total = 0.0
    for _sl, t in runs:
        if t.size < 2:
            continue
        dt = np.diff(t)
        k1 = np.arange(1, t.size, dtype=float)                  # k + 1 for k = 0 .. n-2
        c = np.concatenate([[0.0], np.cumsum(k1 * dt)])[:-1]    # c_k, k = 0 .. n-2
        total += float(np.sum(np.cumsum(2.0 * dt * c + k1 * dt * dt)))   # sum of q_1 .. q_{n-1}
    return total


class ScatterWhitening:
    """The whitening ``W = sigma_t L^-1`` of impact times whose bounces scatter (:func:`scatter_weights`),
    applied without forming W: ``w(r)`` maps residual rows r (..., n) [s] to W r^T row by row [s], as
    ``r @ W.T`` did, in O(n) per row.

    Per run, Sigma = s^2 A A^T + sigma_t^2 I (A of :func:`_scatter_design`). The scatter's part of the
    times is an integrated random walk: with z_j the bounces' deviates, p = A z has p_0 = 0 and
    (p_{k+1} - p_k) / dt_k = z_0 + ... + z_k, so the banded lower-triangular K of the divided
    differences (row 0 picks p_0; row 1 is (p_1 - p_0) / dt_0; row k + 1 the change of the slopes,
    (p_{k+1} - p_k) / dt_k - (p_k - p_{k-1}) / dt_{k-1}) gives K A = the shift that drops z_{n-1}, and
    ``K Sigma K^T = s^2 diag(0, 1, ..., 1) + sigma_t^2 K K^T`` =: B, pentadiagonal. With B = L_B L_B^T
    (banded Cholesky, scipy.linalg.cholesky_banded), L = K^-1 L_B is lower triangular with a positive
    diagonal and L L^T = Sigma: it is THE Cholesky factor, so ``W r = sigma_t L_B^-1 (K r)`` (a banded
    product and a banded triangular solve, LAPACK dtbtrs) equals the dense ``sigma_t L^-1 r`` -- the
    innovations of a Kalman filter of the walk, standardised. The dense form needed an (n, n) Cholesky
    (O(n^3)) and W (n, n); it was refused beyond 2000 times.
    """

    def __init__(self, runs, scatter, timing_sigma_s):
        from scipy import sparse
        from scipy.linalg import cholesky_banded

        self.sigma = float(timing_sigma_s)
        self.n = sum(t.size for _sl, t in runs)
        self.blocks = []
        for sl, t in runs:
            dt = np.diff(t)
            if np.any(~(dt > 0)):
                raise DataError("impact times to weigh must increase within a run")
            a = 1.0 / dt
            diag = np.concatenate([[1.0], a])
            sub = -np.concatenate([a[:1], a[1:] + a[:-1]])             # K[k+1, k]
            bands = [diag, sub, a[:-1]][:t.size]                      # a run of one or two times: fewer
            K = sparse.diags(bands, [0, -1, -2][:t.size], shape=(t.size, t.size), format="csr")
            B = self.sigma**2 * (K @ K.T) + float(scatter) ** 2 * sparse.diags(np.r_[0.0, np.ones(t.size - 1)])
            lower = np.zeros((3, t.size))
            for o in range(min(3, t.size)):
                lower[o, :t.size - o] = B.diagonal(-o)
            self.blocks.append((sl, K, cholesky_banded(lower, lower=True)))

    def __call__(self, r):
        from scipy.linalg.lapack import dtbtrs

        r = np.asarray(r, dtype=float)
        rows = r.reshape(-1, r.shape[-1])
        out = np.empty_like(rows)
        for sl, K, LB in self.blocks:
            x, info = dtbtrs(LB, np.asfortranarray(K @ rows[:, sl].T), uplo="L")
            if info != 0:
                raise DataError(f"the whitening of the impact times failed (LAPACK dtbtrs info {info})")
            out[:, sl] = self.sigma * x.T
        return out.reshape(r.shape)

    def matrix(self):
        """W as a dense (n, n) array (for a small problem: what the callable applies)."""
        return self(np.eye(self.n)).T


def scatter_weights(problem, scatter, timing_sigma_s):
    """The whitening W of a problem of impact times whose bounces scatter, as a
    :class:`ScatterWhitening` (``W(r)`` maps residual rows to W r): fits that minimise ``|W r|^2`` are
    generalized least squares under the covariance of the times ``Sigma = s^2 A A^T + sigma_t^2 I``
    (:func:`_scatter_design`'s A: a bounce's scatter shifts every later time of its run; each run a
    block), with ``W = sigma_t L^-1``, ``Sigma = L L^T``: the weighted residuals are in the data's unit
    at the timing noise, so that the noise floor ``timing_sigma_s`` still judges them. None when there
    is nothing to weigh (no scatter or no timing noise).

    Least squares takes the times' errors as independent. They are not when the bounces scatter: a
    low epsilon at one bounce shortens every later flight, so the late residuals share a trend that a
    drag or a speed law can follow. Judged as independent, a tennis ball's phone times with bounces
    scattering by 1 % named a speed law in 3 of 30 records, and records of 100-200 impacts were
    "suspect input" (drag "fitting far better", at C_d 3).

    W is applied in O(n) memory and time per residual row through the banded structure of Sigma^-1
    (:class:`ScatterWhitening`), with the same numbers as the dense Cholesky; the dense form was
    refused beyond 2000 times (an (n, n) matrix and an O(n^3) factorisation), which left the long
    records judged by least squares.

    Parameters
    ----------
    problem : Problem
        impact times (one run or several)
    scatter : float
        relative standard deviation s of each bounce's epsilon (:func:`bounce_scatter`), dimensionless
    timing_sigma_s : float
        standard deviation of one impact time [s], > 0
    """
    runs = problem.runs
    s, sigma = float(scatter or 0.0), float(timing_sigma_s or 0.0)
    if runs[0].kind != "impacts" or s <= 0 or sigma <= 0:
        return None
    return ScatterWhitening(_run_times(problem), s, sigma)


def scatter_gap(fit, scatter):
    """RMS residual [s] a fit of impact times leaves when each bounce's epsilon scatters at random
    by the relative standard deviation ``scatter`` (:func:`ratio_scatter`).

    The times' covariance is s^2 A A^T (A from :func:`_scatter_design`). The fit absorbs the part in
    the span of its Jacobian J; the expected residual sum of squares is ``trace((I - P) s^2 A A^T)`` =
    ``s^2 ||(I - P) A||_F^2``, P = Q Q^T the projection on J (Q from J's QR). Computed as
    ``s^2 (||A||_F^2 - ||A^T Q||_F^2)`` (:func:`_scatter_frobenius2`, :func:`_scatter_transpose_product`):
    O(n k), where the dense ``A - Q (Q^T A)`` needed (n, n) arrays and O(n^2 k).
    """
    if scatter is None or fit.problem.runs[0].kind != "impacts":
        return None
    J, runs = _scatter_design(fit)
    Q, _ = np.linalg.qr(J)
    AtQ = _scatter_transpose_product(runs, Q)
    expected = scatter**2 * max(_scatter_frobenius2(runs) - float(np.sum(AtQ * AtQ)), 0.0)
    dof = max(J.shape[0] - J.shape[1], 1)
    return math.sqrt(expected / dof)


def scatter_uncertainties(fit, scatter, timing_sigma_s=0.0):
    """1-sigma uncertainties of a fit's parameters (in its layout's order and units) when each
    bounce's epsilon scatters at random by the relative standard deviation ``scatter``
    (:func:`ratio_scatter`) and each time by ``timing_sigma_s`` [s].

    Least squares weighs every impact time alike, as if their errors were independent; a scatter
    of the bounces is not: it shifts every later time of its run (covariance
    Sigma = s^2 A A^T + sigma_t^2 I, :func:`_scatter_design`). The covariance of the least-squares
    estimate under Sigma is the sandwich (J^T J)^-1 J^T Sigma J (J^T J)^-1 (e.g. Seber & Wild,
    *Nonlinear Regression*, 2003, section 2.1.4). (J^T J)^-1 RSS/(n-k) alone understates it: the
    blue ball's phyphox run blue_25cm_L3 (ratios scattering by 3.1 %) gave epsilon +- 0.0029 where
    two methods on the same times differ by 0.02; the sandwich gives +- 0.009.

    J^T Sigma J = s^2 (A^T J)^T (A^T J) + sigma_t^2 J^T J, with A^T J from reverse cumulative sums
    (:func:`_scatter_transpose_product`): O(n k), where the dense Sigma was (n, n) and O(n^3) to form.
    """
    J, runs = _scatter_design(fit)
    AtJ = _scatter_transpose_product(runs, J)
    middle = float(scatter) ** 2 * (AtJ.T @ AtJ) + float(timing_sigma_s) ** 2 * (J.T @ J)
    B = np.linalg.pinv(J.T @ J)
    cov = B @ middle @ B
    return np.sqrt(np.clip(np.diag(cov), 0.0, None))


# --------------------------------------------------------------------------- model layout


@dataclass(frozen=True)
class FitParameter:
    """One free parameter of a model, in SI units."""

    key: str            # "epsilon", "drop_height_m[2]" (run 2 of a joint fit) or "air_drag.drag_coefficient"
    effect: str | None  # None for the baseline's parameters
    name: str           # parameter name inside its effect (or the baseline name)
    unit: str
    bounds: tuple
    prior: tuple
    null: float | None  # value at which the effect vanishes (None for the baseline)
    run: int | None = None  # the run of a release-state parameter (0-based); None when shared


def _runs_of(data):
    """The runs of a measurement: its ``runs`` (a :class:`vrcal.measurements.Runs`) or (data,)."""
    runs = getattr(data, "runs", None)
    return tuple(runs) if runs is not None else (data,)


def _baseline_parameters(runs):
    """The baseline's parameters: per run a drop height and a release time (not for apexes), then ε."""
    out = []
    joint = len(runs) > 1
    for r, run in enumerate(runs):
        suffix = f"[{r + 1}]" if joint else ""
        out.append(FitParameter("drop_height_m" + suffix, None, "drop_height_m", "m", (1e-3, 100.0), (1e-3, 100.0),
                                None, r))
        if run.kind != "apexes":
            t = np.asarray(run.t_s, dtype=float)
            span = float(t[-1] - t[0]) if t.size > 1 else 10.0
            lo, hi = float(t[0]) - span - 10.0, float(t[-1])
            out.append(FitParameter("release_time_s" + suffix, None, "release_time_s", "s", (lo, hi), (lo, hi),
                                    None, r))
    out.append(FitParameter("epsilon", None, "epsilon", "1", (0.05, 0.999), (0.05, 0.999), None))
    return out


def applicable_effects(kind):
    """Names of the registry's effects that can be seen in data of ``kind`` (sorted)."""
    from vrcal.drop.effects import EFFECTS

    _check_kind(kind)
    return sorted(name for name, eff in EFFECTS.items() if kind in tuple(eff.kinds))


def _check_kind(kind):
    if kind not in KINDS:
        raise UsageError(f"unknown data kind '{kind}' (known: {', '.join(KINDS)})")


def parameter_layout(data, effects=(), ball=None):
    """The free parameters of the baseline plus ``effects`` for ``data`` (a tuple of FitParameter);
    ``data`` is one measurement or :class:`vrcal.measurements.Runs` (a release state per run). With
    ``ball`` the effects' bounds are those of this ball (:meth:`vrcal.drop.effects.Parameter.fit_bounds`:
    an air density at which it would float is not tried)."""
    from vrcal.drop.effects import EFFECTS

    runs = _runs_of(data)
    kind = runs[0].kind
    _check_kind(kind)
    layout = _baseline_parameters(runs)
    for name in effects:
        if name not in EFFECTS:
            raise UsageError(f"unknown effect '{name}' (known: {', '.join(sorted(EFFECTS))})")
        eff = EFFECTS[name]
        if kind not in tuple(eff.kinds):
            raise UsageError(f"effect '{name}' cannot be seen in {kind} data (it shows in: {', '.join(eff.kinds)})")
        for p in eff.parameters:
            null = eff.null_values.get(p.name) if eff.null_values else None
            layout.append(FitParameter(f"{name}.{p.name}", name, p.name, p.unit, p.fit_bounds(ball),
                                       tuple(map(float, p.prior)), None if null is None else float(null)))
    return tuple(layout)


# --------------------------------------------------------------------------- prediction


@dataclass(frozen=True)
class Problem:
    """What the fitter needs besides the parameters: the data (one run or several), the ball, g,
    the bounce count, and for a joint fit the one reference speed of a speed-dependent ε."""

    data: object
    ball: object                 # vrcal.model.body.BallProperties
    g_m_per_s2: float = STANDARD_GRAVITY_M_PER_S2
    n_bounces: int = 1
    reference_speed_m_per_s: float | None = None
    noise: float | None = None   # noise of one datum [data unit], for uncertainties without degrees of freedom
    noise_known: bool = False    # the noise was given or measured (not assumed): a floor of the uncertainties
    # the noise is a floor of the uncertainties though assumed (impact times, apex heights: :func:`make_problem`)
    noise_floors_uncertainties: bool = False
    # whitening W, a callable on residual rows (..., n) -> W r: fits minimise |W (data - model)|^2 (the
    # bounces' scatter, :func:`scatter_weights`, a :class:`ScatterWhitening`); None: least squares
    weights: object | None = field(default=None, compare=False)

    @property
    def runs(self):
        """The runs fitted jointly ((data,) for one record)."""
        return _runs_of(self.data)


def _split(theta, layout, n_runs=1):
    """Parameter matrix (m, k) -> (drop heights (m, R), release times (m, R), ε (m,), effects dict of (m,))."""
    theta = np.atleast_2d(np.asarray(theta, dtype=float))
    m = theta.shape[0]
    H = np.zeros((m, n_runs))
    t0 = np.zeros((m, n_runs))
    eps = None
    effects = {}
    for j, p in enumerate(layout):
        if p.effect is not None:
            effects.setdefault(p.effect, {})[p.name] = theta[:, j]
        elif p.name == "epsilon":
            eps = theta[:, j]
        elif p.name == "drop_height_m":
            H[:, p.run or 0] = theta[:, j]
        else:
            t0[:, p.run or 0] = theta[:, j]
    return H, t0, eps, effects


def simulate(theta, layout, problem, n_bounces=None):
    """Simulate the model for every parameter set (rows of ``theta``) and every run: a
    :class:`vrcal.drop.simulate.Drops` whose drop ``i * R + r`` is run r of set i."""
    from vrcal.drop.simulate import simulate_drops

    R = len(problem.runs)
    H, t0, eps, effects = _split(theta, layout, R)
    if R > 1:
        eps = np.repeat(eps, R)
        effects = {e: {k: np.repeat(v, R) for k, v in ps.items()} for e, ps in effects.items()}
    return simulate_drops(H.ravel(), eps, int(n_bounces or problem.n_bounces), problem.ball,
                          effects=effects or None, g_m_per_s2=problem.g_m_per_s2, release_time_s=t0.ravel(),
                          reference_speed_m_per_s=problem.reference_speed_m_per_s)


def _run_prediction(drops, rows, run):
    if run.kind == "trajectory":
        return np.asarray(drops.height_m(np.asarray(run.t_s, dtype=float)), dtype=float)
    if run.kind == "impacts":
        return np.asarray(drops.impact_times_s, dtype=float)[:, :len(run.t_s)]
    return np.asarray(drops.observed_apex_heights_m, dtype=float)[:, np.asarray(run.bounce, dtype=int)]


def predict(theta, layout, problem):
    """Model values of the data for every parameter set: ndarray (m, n_data), the runs one after another.

    trajectory: height of the observed point at the sample times [m];
    impacts: time of the first ``n`` floor impacts [s];
    apexes: apex heights of the observed point at the data's bounce numbers [m].
    """
    drops = simulate(theta, layout, problem)
    runs = problem.runs
    if len(runs) == 1:
        return _run_prediction(drops, None, runs[0])
    R = len(runs)
    m = drops.n_drops // R
    if runs[0].kind == "trajectory":
        sizes = [len(r.t_s) for r in runs]
        width = max(sizes)
        T = np.empty((R, width))
        for r, run in enumerate(runs):
            t = np.asarray(run.t_s, dtype=float)
            T[r, :t.size] = t
            T[r, t.size:] = t[-1]
        y = np.asarray(drops.height_m(np.tile(T, (m, 1))), dtype=float).reshape(m, R, width)
        return np.concatenate([y[:, r, :n] for r, n in enumerate(sizes)], axis=1)
    out = []
    for r, run in enumerate(runs):
        sub = _SubDrops(drops, r, R)
        out.append(_run_prediction(sub, None, run))
    return np.concatenate(out, axis=1)


class _SubDrops:
    """The drops of one run (every R-th drop from r) of a joint simulation (impacts, apexes)."""

    def __init__(self, drops, r, R):
        self.impact_times_s = np.asarray(drops.impact_times_s)[r::R]
        self.observed_apex_heights_m = np.asarray(drops.observed_apex_heights_m)[r::R]


def observed_values(data):
    """The data values the residuals compare with: (n_data,) in the data's unit, the runs one after another."""
    out = []
    for run in _runs_of(data):
        if run.kind == "trajectory":
            out.append(np.asarray(run.y_m, dtype=float))
        elif run.kind == "impacts":
            out.append(np.asarray(run.t_s, dtype=float))
        else:
            out.append(np.asarray(run.h_m, dtype=float))
    return out[0] if len(out) == 1 else np.concatenate(out)


def residuals(theta, layout, problem):
    """data - model, ndarray (m, n_data) (a row per parameter set) in the data's unit."""
    return observed_values(problem.data)[None, :] - predict(theta, layout, problem)


# --------------------------------------------------------------------------- starting values


def count_bounces(data, drop_height_m, epsilon, release_time_s, g_m_per_s2):
    """How many impacts a model must simulate to cover the data (with a margin)."""
    if data.kind == "impacts":
        return int(len(data.t_s))
    if data.kind == "apexes":
        return int(np.max(np.asarray(data.bounce, dtype=int)))
    t = np.asarray(data.t_s, dtype=float)
    seen = impacts_in_trajectory(t, data.y_m, getattr(data, "release_index", 0) or 0).size
    t_end = float(t[-1])
    eps = min(max(float(epsilon), 0.3) + 0.05, 0.97)
    fall = math.sqrt(2.0 * max(float(drop_height_m), 1e-4) / g_m_per_s2)
    dt = float(np.median(np.diff(t))) if t.size > 1 else 0.0
    tk, n, flight = float(release_time_s) + fall, 1, 2.0 * fall * eps
    while tk < t_end and n < MAX_BOUNCES and flight > dt:
        tk += flight
        flight *= eps
        n += 1
    return int(min(max(n, seen) + 2, MAX_BOUNCES))


def impacts_in_trajectory(t_s, y_m, release_index=0, sigma_m=None):
    """Sample indices of the bounces seen in a trajectory: prominent minima after release.

    A minimum counts as an impact when its prominence (the lower of the two apexes
    around it, above it) exceeds 8 noise standard deviations (``sigma_m``, estimated
    from the data when None) and 0.5 % of the height range.
    """
    from vrcal.measurements.cleanup import prominent_minima

    y = np.asarray(y_m, dtype=float)
    r = int(release_index)
    seg = y[r:]
    if seg.size < 3:
        return np.array([], dtype=int)
    if sigma_m is None:
        sigma_m = third_difference_sigma(np.asarray(t_s, dtype=float), y) or 0.0
    span = float(np.max(seg) - np.min(seg))
    return prominent_minima(seg, max(8.0 * sigma_m, 0.005 * span, 1e-9)) + r


#: Share of each flight's rise next to a contact whose samples give its speed in :func:`bounce_speed_ratios`:
#: the samples below this fraction of the flight's apex above the contact (0.97: 83 % of the way to the
#: apex in time; a 240 fps video's 0.3 mm of noise leaves about 0.007 of scatter in a bounce's ratio, and
#: a still segment at the drop height is never taken for the fall).
SPEED_WINDOW_HEIGHT = 0.97


def bounce_speed_ratios(t_s, y_m, release_index=0, height_fraction=SPEED_WINDOW_HEIGHT):
    """Each bounce's own epsilon from a trajectory: its speeds in and out, where free parabolas through the
    flights on either side meet.

    Parameters
    ----------
    t_s : ndarray
        sample times [s]
    y_m : ndarray
        heights [m] (any offset)
    release_index : int
        first sample of the free fall
    height_fraction : float
        on each side of a contact, the samples next to it (its lowest left out) that lie below this fraction
        of the flight's apex above the contact are fitted

    Returns
    -------
    ndarray, (n_bounces, 4)
        per bounce seen (:func:`impacts_in_trajectory`): time where the two parabolas meet [s], the speed
        in [m/s], the ratio out/in [1] and its standard error from the parabolas' scatter [1]; bounces with
        fewer than 5 samples on a side, or whose parabolas do not fall in and rise out, are left out

    Notes
    -----
    Model-free: no drag, contact time, speed law or floor level is assumed, and a length scale that
    drifts across the picture scales both speeds of a bounce alike where they are taken. The speeds are
    those where the parabolas meet: a contact of tau lowers that point by about g tau^2 / 8, raising both
    speeds by g tau / 2 (0.04 m/s for 8 ms); drag bends the flights. Read off a model's heights at the same
    samples, the same estimator has the same bias (:attr:`vrcal.discovery.ranking.Discovery.bounce_epsilons`).
    """
    t, y = np.asarray(t_s, dtype=float), np.asarray(y_m, dtype=float)
    minima = [int(m) for m in impacts_in_trajectory(t, y, release_index)]
    edges = [int(release_index)] + minima + [t.size]
    out = []

    def side(m, stop, step):
        """Samples from next to the contact ``m`` towards ``stop`` (exclusive) while below the share of the
        apex between them."""
        seg = y[m + step:stop:step] if step > 0 or stop > 0 else y[m - 1::-1]
        if seg.size == 0:
            return np.array([], dtype=int)
        above = seg >= y[m] + height_fraction * (float(np.max(seg)) - y[m])
        n = int(np.argmax(above)) if above.any() else seg.size
        return np.sort(m + step * np.arange(1, n + 1))

    for k, m in enumerate(minima):
        before, after = side(m, edges[k], -1), side(m, edges[k + 2], 1)
        if before.size < 5 or after.size < 5:
            continue
        (p_in, c_in), (p_out, c_out) = (np.polyfit(t[i], y[i], 2, cov=True) for i in (before, after))
        roots = [x.real for x in np.roots(np.polysub(p_in, p_out))
                 if abs(x.imag) < 1e-12 and t[before[0]] <= x.real <= t[after[-1]]]
        tc = min(roots, key=lambda x: abs(x - t[m])) if roots else float(t[m])
        v_in, v_out = np.polyval(np.polyder(p_in), tc), np.polyval(np.polyder(p_out), tc)
        if v_in < 0 < v_out:
            grad = np.array([2.0 * tc, 1.0, 0.0])   # d(v)/d(coefficients) at tc
            rel = math.sqrt(float(grad @ c_in @ grad) / v_in ** 2 + float(grad @ c_out @ grad) / v_out ** 2)
            ratio = float(v_out / -v_in)
            out.append((float(tc), float(-v_in), ratio, ratio * rel))
    return np.array(out, dtype=float).reshape(-1, 4)


#: Fewest samples of a flight, clear of the bounces, that :func:`bounce_flight_ratios` fits a parabola through
#: (two fix one of known curvature; the third leaves a residual: a record of clicked apex and contact
#: points, one sample a flight between its contacts, gives none).
FLIGHT_PARABOLA_MIN_SAMPLES = 3


def _flights(t_s, y_m, release_index=0):
    """(the bounces seen (:func:`impacts_in_trajectory`), the sample indices of each flight between them, the
    samples at the bounces left out, the first flight from the release)."""
    minima = [int(m) for m in impacts_in_trajectory(t_s, y_m, release_index)]
    edges = [int(release_index) - 1] + minima + [np.asarray(t_s).size]
    return minima, [np.arange(a + 1, b) for a, b in zip(edges[:-1], edges[1:])]


def flight_samples(t_s, y_m, release_index=0):
    """How many samples each flight of a trajectory holds clear of its bounces: a list, the first flight
    from the release."""
    return [idx.size for idx in _flights(t_s, y_m, release_index)[1]]


def flight_parabolas(t_s, y_m, release_index=0, g_m_per_s2=STANDARD_GRAVITY_M_PER_S2,
                     min_samples=FLIGHT_PARABOLA_MIN_SAMPLES):
    """Parabolas of curvature -g through each whole flight of a trajectory (the samples at its bounces
    left out, :func:`_flights`): ``y = c + b (t - mid) - g t^2 / 2``.

    Parameters as :func:`bounce_flight_ratios`.

    Returns
    -------
    (minima, lines, sigma2)
        the bounces seen (sample indices); per flight, the first from the release, None when it holds fewer
        than ``min_samples`` samples (at least 2), else (sample indices, mid [s], (c [m], b [m/s]), the
        inverse normal matrix of (c, b)); the flights' scatter about their parabolas [m^2] (the median of
        theirs: a still segment left in the first flight bends its parabola; NaN when none has three samples)
    """
    t, y = np.asarray(t_s, dtype=float), np.asarray(y_m, dtype=float)
    g = float(g_m_per_s2)
    minima, flights = _flights(t, y, release_index)
    lines, variances = [], []
    for idx in flights:
        if idx.size < max(int(min_samples), 2):
            lines.append(None)
            continue
        mid = float(np.mean(t[idx]))
        X = np.column_stack([np.ones(idx.size), t[idx] - mid])
        z = y[idx] + 0.5 * g * t[idx] ** 2          # a line in t for a parabola of curvature -g
        coef, res_ss, *_ = np.linalg.lstsq(X, z, rcond=None)
        if idx.size > 2:
            variances.append(float(res_ss[0]) / (idx.size - 2) if res_ss.size else 0.0)
        lines.append((idx, mid, coef, np.linalg.inv(X.T @ X)))
    return minima, lines, float(np.median(variances)) if variances else math.nan


def flight_apex(line, g_m_per_s2=STANDARD_GRAVITY_M_PER_S2):
    """(time [s], height [m]) of the top of a flight's parabola (a line of :func:`flight_parabolas`)."""
    _, mid, (c, b), _ = line
    g = float(g_m_per_s2)
    t_top = float(b) / g
    return t_top, float(c + b * (t_top - mid) - 0.5 * g * t_top ** 2)


def bounce_flight_ratios(t_s, y_m, release_index=0, g_m_per_s2=STANDARD_GRAVITY_M_PER_S2,
                         min_samples=FLIGHT_PARABOLA_MIN_SAMPLES):
    """Each bounce's own epsilon from a sparsely sampled trajectory: parabolas of curvature -g through
    the whole flights on either side of it meet at the contact; their speeds there, out over in.

    For frames too sparse for :func:`bounce_speed_ratios` (fewer than 5 samples a side near a contact: a
    30 fps video). With g known a flight's parabola has two free numbers, so three samples fix it and
    leave a residual. The ratio is that of the flights' apex heights above where they meet, square-rooted
    (v^2 = 2 g (apex - h)), and of the flights' durations at that level.

    Parameters
    ----------
    t_s : ndarray
        sample times [s]
    y_m : ndarray
        heights [m] (any offset)
    release_index : int
        first sample of the free fall
    g_m_per_s2 : float
        the parabolas' downward acceleration [m/s^2]
    min_samples : int
        fewest samples of a flight, clear of the bounces, to fit it

    Returns
    -------
    ndarray, (n_bounces, 4)
        as :func:`bounce_speed_ratios`: per bounce seen, the time where the parabolas meet [s], the speed
        in [m/s], the ratio out/in [1] and its standard error [1] (from the median scatter of the flights
        about their parabolas); bounces with a flight of fewer than ``min_samples`` samples, or
        whose parabolas do not meet between the flights falling in and rising out, are left out

    Notes
    -----
    Model-free but for g: drag bends a flight from the parabola, a contact of tau lowers the meeting point
    (raising both speeds by g tau / 2), a scale that drifts across the picture scales the flights' heights
    unlike. Read off a model's heights at the same samples, the same estimator has the same bias
    (:attr:`vrcal.discovery.ranking.Discovery.bounce_epsilons`).
    """
    t, y = np.asarray(t_s, dtype=float), np.asarray(y_m, dtype=float)
    g = float(g_m_per_s2)
    minima, lines, sigma2 = flight_parabolas(t, y, release_index, g, min_samples)

    def meet(p):
        """(contact time, speed in, speed out) of lines c1 + b1 (t - m1), c2 + b2 (t - m2)."""
        c1, b1, c2, b2 = p
        tc = (c2 - c1 + b1 * m1 - b2 * m2) / (b1 - b2)
        return tc, b1 - g * tc, b2 - g * tc

    out = []
    for k, m in enumerate(minima):
        before, after = lines[k], lines[k + 1]
        if before is None or after is None or before[2][1] == after[2][1]:
            continue
        (i1, m1, p1, v1), (i2, m2, p2, v2) = before, after
        p = np.array([p1[0], p1[1], p2[0], p2[1]])
        tc, v_in, v_out = meet(p)
        if not (v_in < 0 < v_out and t[i1[-1]] <= tc <= t[i2[0]]):
            continue
        ratio = float(v_out / -v_in)
        step = 1e-6 * np.maximum(np.abs(p), 1.0)
        grad = np.array([(-meet(p + e)[2] / meet(p + e)[1] - ratio) / h
                         for e, h in zip(np.diag(step), step)])
        cov = np.zeros((4, 4))
        cov[:2, :2], cov[2:, 2:] = v1 * sigma2, v2 * sigma2
        out.append((float(tc), float(-v_in), ratio, float(math.sqrt(max(float(grad @ cov @ grad), 0.0)))))
    return np.array(out, dtype=float).reshape(-1, 4)


def initial_baseline(data, g_m_per_s2=STANDARD_GRAVITY_M_PER_S2):
    """Starting values {drop_height_m, release_time_s, epsilon} read from the data (one run).

    trajectory: drop height from the still level before release (or the first sample; of a record
    that starts in flight, rising or falling, from its flights' parabolas: :func:`_in_flight_start`),
    ε from the ratios of successive impact intervals (with fewer than three impacts, from the bounces'
    own ratios, :func:`bounce_flight_ratios`), release time from the first impact and the free-fall
    time (no bounce seen: a DataError, nothing tells ε); impacts: ε from interval ratios, drop height from
    the first interval (v = g Δt / 2); apexes: drop height = apex 0, ε from the apex
    ratios (Eq. (9) of [1]).
    """
    g = float(g_m_per_s2)
    kind = data.kind
    if kind == "apexes":
        b = np.asarray(data.bounce, dtype=int)
        h = np.asarray(data.h_m, dtype=float)
        if h.size < 2:
            raise DataError(f"{data.source}: need at least two apex heights to fit ε, got {h.size}")
        ok = h > 0
        slope = np.polyfit(b[ok], np.log(h[ok]), 1)
        eps = float(np.clip(math.exp(slope[0] / 2.0), 0.1, 0.99))
        H = float(h[b == 0][0]) if np.any(b == 0) else float(math.exp(slope[1]))
        return {"drop_height_m": max(H, 1e-3), "epsilon": eps}
    if kind == "impacts":
        t = np.asarray(data.t_s, dtype=float)
        if t.size < 3:
            raise DataError(f"{data.source}: need at least three impact times to fit ε, got {t.size}")
        d = np.diff(t)
        eps = float(np.clip(np.median(d[1:] / d[:-1]), 0.1, 0.99))
        v_up = g * d[0] / 2.0
        v0 = v_up / eps
        return {"drop_height_m": v0 * v0 / (2 * g), "release_time_s": float(t[0] - v0 / g), "epsilon": eps}
    t = np.asarray(data.t_s, dtype=float)
    y = np.asarray(data.y_m, dtype=float)
    if t.size < 10:
        raise DataError(f"{data.source}: need at least 10 samples to fit a trajectory, got {t.size}")
    r = int(getattr(data, "release_index", 0) or 0)
    still = float(np.median(y[: r + 1])) if r > 0 else float(y[0])
    imp = impacts_in_trajectory(t, y, r)
    floor = float(np.min(y[r:]))
    spread_mm = (float(np.max(y)) - float(np.min(y))) * 1e3
    if imp.size == 0 and still - floor < 0.02 and spread_mm < 20.0:
        raise DataError(f"{data.source}: no fall or bounce in the trajectory (the heights vary by {spread_mm:.1f} mm)")
    if imp.size == 0:   # one flight (a fall, or a record cut inside a flight): nothing tells epsilon
        raise DataError(f"{data.source}: no bounce in the trajectory (its {t.size} samples from t = {t[r]:.3f} s "
                        f"hold one flight, the heights varying by {spread_mm:.0f} mm): epsilon is read from the "
                        f"flights on either side of a bounce; give a record that holds a bounce and the flight "
                        f"after it")
    fall_height = max(still - floor, 1e-3)
    ratios = bounce_flight_ratios(t, y, r, g)[:, 2] if imp.size < 3 else np.array([])
    if imp.size >= 3:
        d = np.diff(t[imp])
        eps = float(np.clip(np.median(d[1:] / d[:-1]), 0.1, 0.99))
    elif ratios.size:     # the bounces' own ratios from the flights' parabolas (a start in flight too)
        eps = float(np.clip(np.median(ratios), 0.1, 0.99))
    elif imp.size == 2:
        eps = float(np.clip((t[imp[1]] - t[imp[0]]) / (2 * math.sqrt(2 * fall_height / g)), 0.1, 0.99))
    else:
        eps = 0.8
    if imp.size:
        t0 = float(t[imp[0]] - math.sqrt(2 * fall_height / g))
    else:
        t0 = float(t[r])
    in_flight = _in_flight_start(t, y, eps, g) if r == 0 else None
    if in_flight is not None:  # the record starts in flight (a video whose ball enters the picture)
        still, t0 = in_flight
    return {"drop_height_m": still, "release_time_s": t0, "epsilon": eps}


def _in_flight_start(t, y, eps, g):
    """(drop height [m], release time [s]) of a record that starts in flight (a video whose ball
    enters the picture, or whose first frames are cut), from the parabolas of g through its flights
    (:func:`flight_parabolas`; heights above the model's floor, 0 or the lowest sample if lower).

    The first flight's parabola, when it holds two samples: falling from the start (its top at or before
    the first sample), it IS the model's drop from rest, released at its top from its height; rising, it
    left an unseen impact with the speed ``v`` that carries it to its top, and ``v / eps`` fell into that
    one from rest: the drop is ``v^2 / (2 g eps^2)``, released ``(v + v / eps) / g`` before the top (the
    first samples off that parabola, falling into that impact at the record's edge, left out of it).
    Without it, the flight after the first impact seen: its take-off speed ``u``, over ``eps``, ended the
    fall from rest. None when the record starts at rest (its first flight no parabola, :func:`_parabolic`,
    or its top after the first sample with no rise beyond the noise: a still segment the release
    detection left in), or when no flight next to the first impact has two samples."""
    minima, lines, _ = flight_parabolas(t, y, 0, g, 2)
    if not minima:
        return None
    floor = min(float(np.min(y)), 0.0)
    noise = third_difference_sigma(t, y) or 0.0
    first = lines[0]
    if first is not None and not _parabolic(t, y, first, g, noise):
        # the first samples may fall into a bounce at the record's edge (no minimum seen there): the
        # first flight rises from the sample after the first turn upward on
        turn = int(np.argmax(np.diff(y) > 0)) + 1
        after = flight_parabolas(t, y, turn, g, 2)[1][0] if turn < first[0][-1] else None
        if after is None or not _parabolic(t, y, after, g, noise):
            return None
        first = after
    if first is not None:
        top_t, top = flight_apex(first, g)
        top -= floor
        idx = first[0]
        if top <= 0:
            return None
        if top_t <= t[idx[0]]:            # falling from the start: the drop itself
            return top, top_t
        if not float(np.max(y[idx]) - y[idx[0]]) > max(8.0 * noise, 1e-3 * top):
            return None                 # no rise: at rest at the top
        v = math.sqrt(2.0 * g * top)
        w = v / eps
        return w * w / (2.0 * g), top_t - (v + w) / g
    if len(lines) < 2 or lines[1] is None:
        return None
    top_t, top = flight_apex(lines[1], g)
    u = math.sqrt(2.0 * g * max(top - floor, 0.0))
    v = u / eps
    return v * v / (2.0 * g), top_t - (u + v) / g


#: How far [share of its height] a flight's samples may lie from its parabola of g, root-mean-square, and
#: still be a flight (:func:`_parabolic`): a real video's perspective and a scale fitted to all flights bend a
#: 30 fps flight by about 1 % (bounceAmeen.avi: 2.6 mm in 0.33 m); a ball held still 0.1 s before a release
#: the release detection missed bends one by 4-5 %.
FLIGHT_PARABOLA_TOLERANCE = 0.02


def _parabola_rms(t, y, line, g):
    """Root-mean-square distance [m] of a flight's samples from its parabola of g (a line of
    :func:`flight_parabolas`)."""
    idx, mid, (c, b), _ = line
    fit = c + b * (t[idx] - mid) - 0.5 * g * t[idx] ** 2
    return float(np.sqrt(np.mean((y[idx] - fit) ** 2)))


def _parabolic(t, y, line, g, noise):
    """Do a flight's samples lie on its parabola of g (a line of :func:`flight_parabolas`) to within
    4 times the record's ``noise`` [m] (:func:`vrcal.measurements.cleanup.third_difference_sigma`) or
    :data:`FLIGHT_PARABOLA_TOLERANCE` of its height? A ball held still before its release bends it, and so
    does a sample before a bounce at the record's edge."""
    limit = max(4.0 * noise, FLIGHT_PARABOLA_TOLERANCE * float(np.max(y[line[0]]) - np.min(y)))
    return _parabola_rms(t, y, line, g) <= limit


def initial_values(problem):
    """Starting values by parameter key for every run (see :func:`initial_baseline`); ε is the
    median of the runs' estimates."""
    runs = problem.runs
    joint = len(runs) > 1
    out, eps = {}, []
    for r, run in enumerate(runs):
        base = initial_baseline(run, problem.g_m_per_s2)
        suffix = f"[{r + 1}]" if joint else ""
        for k, v in base.items():
            if k == "epsilon":
                eps.append(v)
            else:
                out[k + suffix] = v
    out["epsilon"] = float(np.median(eps))
    return out


# --------------------------------------------------------------------------- fitting


@dataclass
class FitResult:
    """A fitted model: parameters, uncertainties, residuals and statistics."""

    effects: tuple                 # names of the effects on top of the baseline
    layout: tuple                  # FitParameter per column
    values: np.ndarray             # (k,)
    uncertainties: np.ndarray      # (k,) 1-σ from (JᵀJ)⁻¹ σ² with σ² = RSS/(n-k)
    residuals: np.ndarray          # (n,) data - model
    problem: Problem
    nfev: int = 0
    success: bool = True
    message: str = ""
    extra: dict = field(default_factory=dict)

    @property
    def n(self):
        return int(self.residuals.size)

    @property
    def k(self):
        return len(self.layout)

    @property
    def weighted_residuals(self):
        """The residuals the fit minimised: ``W (data - model)`` for a problem with weights
        (:func:`scatter_weights`, in the data's unit at the timing noise), else the residuals."""
        w = self.extra.get("weighted_residuals")
        return self.residuals if w is None else w

    @property
    def rss(self):
        """Sum of the squared residuals that the fit minimised (:attr:`weighted_residuals`): every
        statistic (chi-square, AIC, BIC, evidence) is of these."""
        return float(rss(self.weighted_residuals))

    @property
    def gap(self):
        """RMS residual [data unit] (data - model, unweighted: what a user sees in the data)."""
        return float(rms(self.residuals))

    @property
    def judged_gap(self):
        """RMS of the residuals the fit minimised [data unit] (:attr:`weighted_residuals`; the gap
        without weights): what fits of one problem are compared by."""
        return float(rms(self.weighted_residuals))

    @property
    def residual_variance(self):
        """RSS / (n - k) [data unit²] (RSS / 1 with no degree of freedom left)."""
        return self.rss / max(self.n - self.k, 1)

    def noise_sigma(self, sigma_floor):
        """The noise σ of one datum [data unit] that this fit is judged at: the noise floor, or its own
        residual standard deviation when that is larger (the data are not fitted down to the floor)."""
        return math.sqrt(max(float(sigma_floor or 0.0) ** 2, self.residual_variance, 1e-300))

    @property
    def aic(self):
        return float(aic(max(self.rss, 1e-300), self.n, self.k))

    @property
    def bic(self):
        return float(bic(max(self.rss, 1e-300), self.n, self.k))

    def chi_square(self, sigma):
        return float(chi_square(self.rss, sigma))

    def value(self, key):
        return float(self.values[[p.key for p in self.layout].index(key)])

    def uncertainty(self, key):
        return float(self.uncertainties[[p.key for p in self.layout].index(key)])

    def run_values(self, run=0):
        """{drop_height_m, release_time_s (not for apexes), epsilon} of one run (the release state)."""
        out = {p.name: float(v) for p, v in zip(self.layout, self.values)
               if p.effect is None and p.run in (run, None)}
        return out

    @property
    def baseline_values(self):
        """{drop_height_m, release_time_s (not for apexes), epsilon} of the first run."""
        return self.run_values(0)

    def _by_effect(self, numbers):
        out = {}
        for p, x in zip(self.layout, numbers):
            if p.effect is not None:
                out.setdefault(p.effect, {})[p.name] = float(x)
        return out

    @property
    def effect_values(self):
        """{effect: {parameter: value}} of the effects on top of the baseline."""
        return self._by_effect(self.values)

    @property
    def effect_uncertainties(self):
        """{effect: {parameter: 1-sigma uncertainty}} of the effects on top of the baseline."""
        return self._by_effect(self.uncertainties)

    def outside_limits(self, effect):
        """[(parameter, value, (lo, hi))] of the parameters of ``effect`` outside their hard physical
        limits (:meth:`vrcal.drop.effects.Parameter.physical_limits`, for this ball); [] when all lie inside."""
        from vrcal.drop.effects import EFFECTS

        out = []
        for p, v in zip(self.layout, self.values):
            if p.effect == effect:
                lo, hi = EFFECTS[effect].parameter(p.name).physical_limits(self.problem.ball)
                if not lo <= v <= hi:
                    out.append((p.name, float(v), (lo, hi)))
        return out

    def model(self, n_bounces=None, run=0):
        """The fitted model of one run simulated once (a :class:`vrcal.drop.simulate.Drops` with n_drops = 1)."""
        drops = simulate(self.values[None, :], self.layout, self.problem, n_bounces)
        R = len(self.problem.runs)
        if R == 1:
            return drops
        from vrcal.drop.simulate import simulate_drops

        H, t0, eps, effects = _split(self.values[None, :], self.layout, R)
        return simulate_drops(H[:, run], eps, int(n_bounces or self.problem.n_bounces), self.problem.ball,
                              effects=effects or None, g_m_per_s2=self.problem.g_m_per_s2,
                              release_time_s=t0[:, run], reference_speed_m_per_s=self.problem.reference_speed_m_per_s)

    def predict_at(self, t_s, run=0):
        """Height of the observed point [m] at times ``t_s`` (trajectory models), (n_t,)."""
        return np.asarray(self.model(run=run).height_m(np.asarray(t_s, dtype=float)), dtype=float)[0]

    def run_slices(self):
        """The residuals' slice of each run."""
        return _run_slices(self.problem)


def _scales(layout, x0):
    out = []
    for p, v in zip(layout, x0):
        if p.name == "epsilon":
            out.append(0.01)
        elif p.name == "release_time_s":
            out.append(0.01)
        elif p.name == "drop_height_m":
            out.append(max(0.01, 0.01 * abs(v)))
        else:
            lo, hi = p.prior
            width = hi - lo if math.isfinite(hi - lo) and hi > lo else 1.0
            out.append(max(abs(v) * 0.1, width * 0.02, 1e-9))
    return np.asarray(out)


class _Objective:
    """Residual and forward-difference Jacobian sharing ONE vectorised simulation per point."""

    def __init__(self, layout, problem, scales, lo=None, hi=None, prior=None):
        self.layout, self.problem = layout, problem
        self.steps = 1e-4 * np.asarray(scales)
        self.lo = np.array([p.bounds[0] for p in layout]) if lo is None else lo
        self.hi = np.array([p.bounds[1] for p in layout]) if hi is None else hi
        self.cache_x, self.cache_r = None, None
        self.nsim = 0
        self.y = observed_values(problem.data)
        self.prior = prior   # (deviate function, noise sigma) for a posterior mode, or None

    def _batch(self, thetas):
        self.nsim += thetas.shape[0]
        r = self.y[None, :] - predict(thetas, self.layout, self.problem)
        r = np.where(np.isfinite(r), r, 1e3)
        if self.problem.weights is not None:
            r = self.problem.weights(r)
        if self.prior is None:
            return r
        deviate, sigma = self.prior
        return np.concatenate([r, sigma * deviate(thetas)], axis=1)

    def fun(self, x):
        if self.cache_x is not None and np.array_equal(x, self.cache_x):
            return self.cache_r
        r = self._batch(x[None, :])[0]
        self.cache_x, self.cache_r = x.copy(), r
        return r

    def jac(self, x):
        k = x.size
        h = self.steps.copy()
        # step away from the nearer bound so that every perturbed set is feasible
        h = np.where(x + h > self.hi, -h, h)
        thetas = np.repeat(x[None, :], k + 1, axis=0)
        thetas[1:][np.arange(k), np.arange(k)] += h
        r = self._batch(thetas)
        self.cache_x, self.cache_r = x.copy(), r[0]
        return ((r[1:] - r[0][None, :]) / h[:, None]).T


def prior_deviates(layout, ball):
    """``deviate(values) -> (m, j)`` for a posterior mode: the deviate of each of the j effect parameters
    of ``layout`` that have a prior density in the registry, under that density
    (``LogNormalPrior.deviate``: ln(x / median) / sigma_ln; ``TrackedPointPrior``: sqrt(2 ln(pdf_max /
    pdf))), for m parameter sets (rows of ``values``). Parameters with a uniform density have none
    (their bounds become the density's support in :func:`fit_model`)."""
    from vrcal.drop.effects import EFFECTS

    cols, densities = [], []
    for j, p in enumerate(layout):
        if p.effect is not None:
            density = EFFECTS[p.effect].parameter(p.name).density
            if density is not None:
                cols.append(j)
                densities.append(density)

    def deviate(values):
        values = np.atleast_2d(values)
        return np.stack([np.asarray(dens.deviate(values[:, j], ball), dtype=float)
                         for j, dens in zip(cols, densities)], axis=1) if cols else values[:, :0]

    return deviate


def fit_model(problem, effects=(), start=None, *, max_nfev=60, prior_sigma=None, fixed=None, within=()):
    """Fit the baseline plus ``effects`` to ``problem.data`` by bounded least squares.

    Parameters
    ----------
    problem : Problem
        data (one run or several), ball, g [m/s²] and the number of bounces to simulate
    effects : sequence of str
        effect names on top of the baseline (registry :data:`vrcal.drop.effects.EFFECTS`)
    start : dict, optional
        starting values by parameter key ("epsilon", "air_drag.drag_coefficient", ...);
        missing keys start at :func:`initial_values` and at each effect's default.
    max_nfev : int
        most Jacobian evaluations (each one vectorised simulation of k + 1 sets)
    prior_sigma : float or None
        None: least squares. A number (the noise σ of one datum, in the data's unit): the
        posterior mode (maximum a posteriori) with the registry's prior densities of the effect
        parameters: each adds the residual σ z, z its deviate under the density
        (:func:`prior_deviates`; for a log-normal ln(x / median) / σ_ln, the prior on ln x), so that
        the cost is χ² + Σ z² at noise σ; a parameter with a uniform density is held inside its
        support. The returned residuals and RSS are the data's alone; ``extra["prior_chi2"]`` holds Σ z².
    fixed : dict, optional
        parameters held at a value ({key: value}, e.g. ``{"contact_duration.contact_time_s": 0.005}``:
        what epsilon would be if the contact lasted 5 ms)
    within : sequence of str
        effects whose parameters are held inside their hard physical limits
        (:meth:`vrcal.drop.effects.Parameter.physical_limits`, for this ball) instead of the fitter's wide
        ``bounds``: the best physical fit when the unconstrained optimum lies beyond them

    Returns
    -------
    FitResult
        uncertainties are 1-σ from the Jacobian, (JᵀJ)⁻¹ σ² with σ² = RSS/(n - k), or the square of
        the problem's noise when that is known (given or measured: ``Problem.noise_known``; for impact
        times and apex heights assumed too: ``Problem.noise_floors_uncertainties``) and larger
        (the scale factor of the Particle Data Group, never below 1); for a posterior mode: J with the
        prior's rows, σ = ``prior_sigma``.
    """
    from vrcal.discovery.lsq import least_squares_box
    from vrcal.drop.effects import EFFECTS

    data = problem.data
    layout = parameter_layout(data, tuple(effects), problem.ball)
    start = dict(start or {})
    base0 = problem_start(problem)
    x0 = []
    for p in layout:
        if p.key in start:
            v = start[p.key]
        elif p.effect is None:
            v = base0[p.key]
        else:
            v = next(q.default for q in EFFECTS[p.effect].parameters if q.name == p.name)
        lo, hi = p.bounds
        span = hi - lo
        v = float(np.clip(v, lo + 1e-6 * span, hi - 1e-6 * span))
        x0.append(v)
    x0 = np.asarray(x0, dtype=float)
    n = observed_values(data).size
    k_free = len(layout) - sum(p.key in (fixed or {}) for p in layout)   # a parameter held is not fitted
    if n < k_free:
        raise DataError(f"{data.source}: {n} data cannot fit {k_free} parameters")
    lo = np.array([p.bounds[0] for p in layout])
    hi = np.array([p.bounds[1] for p in layout])
    for j, p in enumerate(layout):
        if p.effect is not None and p.effect in within:
            a, b = EFFECTS[p.effect].parameter(p.name).physical_limits(problem.ball)
            lo[j], hi[j] = max(lo[j], a), min(hi[j], b)
            x0[j] = float(np.clip(x0[j], lo[j], hi[j]))
        if p.key in (fixed or {}):       # held at a value: its bounds closed on it
            lo[j] = hi[j] = x0[j] = float(fixed[p.key])
    prior = None
    if prior_sigma is not None:
        from vrcal.drop.effects import LogNormalPrior

        for j, p in enumerate(layout):
            if p.effect is None:
                continue
            q = EFFECTS[p.effect].parameter(p.name)
            if q.density is None:        # uniform: its support
                lo[j], hi[j] = max(lo[j], q.prior[0]), min(hi[j], q.prior[1])
            elif isinstance(q.density, LogNormalPrior):   # it vanishes at 0
                lo[j] = max(lo[j], 1e-3 * q.density.center(problem.ball))
        x0 = np.clip(x0, lo, hi)
        prior = (prior_deviates(layout, problem.ball), float(prior_sigma))
    scales = _scales(layout, x0)
    obj = _Objective(layout, problem, scales, lo, hi, prior)
    sol = least_squares_box(obj.fun, obj.jac, x0, lo, hi, scales, max_iter=max_nfev, xtol=1e-10, ftol=1e-8)
    r, J = sol.fun[:n], sol.jac
    extra = {}
    if problem.weights is not None:   # the residuals a user sees: data - model, unweighted
        extra["weighted_residuals"] = r.copy()
        r = observed_values(data) - predict(sol.x[None, :], layout, problem)[0]
    prior_chi2 = float(np.sum((sol.fun[n:] / prior_sigma) ** 2)) if prior is not None else 0.0
    # sigma^2 from the residuals; with no degree of freedom left (as many data as parameters: two
    # apexes give epsilon exactly) from the noise the problem assumes
    rw = extra.get("weighted_residuals", r)
    s2 = float(rw @ rw) / (n - k_free) if n > k_free else float(problem.noise or 0.0) ** 2
    if problem.noise_known or problem.noise_floors_uncertainties:
        # a noise given or measured apart from this fit is the least scatter there is: the residuals of a
        # few data (8 apexes, 15 impact times) scatter below it half of the time, and uncertainties scaled
        # by them alone covered the truth like a t-distribution of few degrees of freedom (pull SD 1.3)
        s2 = max(s2, float(problem.noise) ** 2)
    if prior is not None:
        s2 = float(prior_sigma) ** 2   # the posterior's covariance: data and prior rows at the same sigma
    cov = np.linalg.pinv(J.T @ J) * s2
    unc = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    return FitResult(tuple(effects), layout, sol.x.copy(), unc, r.copy(), problem, nfev=obj.nsim,
                     success=bool(sol.success), message=str(sol.message),
                     extra={"start": x0, "jtj": J[:n].T @ J[:n], "prior_chi2": prior_chi2, **extra})


def separation_chi2(data, ball, effects, sigma, g_m_per_s2=STANDARD_GRAVITY_M_PER_S2, starts=()):
    """Chi-square of the best fit of the baseline plus ``effects`` to ``data`` at noise ``sigma``.

    On noise-free data of another model (:func:`vrcal.drop.synthetic.noise_free_measurement`) this
    is how far apart the two models are for this record's samples: the expected chi-square
    difference between them on noisy data, the most that any rule can go on to tell them apart
    (below a few units no rule can: the prior densities decide).

    Parameters
    ----------
    data : Trajectory or ImpactTimes or ApexHeights or Runs
    ball : BallProperties
    effects : sequence of str
        effect names of the model fitted
    sigma : float
        noise of one datum [data unit], > 0
    g_m_per_s2 : float
        gravitational acceleration [m/s²]
    starts : sequence of dict
        further starting values (:func:`fit_model`'s ``start``); the lowest RSS counts

    Returns
    -------
    float
        RSS / sigma², dimensionless
    """
    problem = make_problem(data, ball, g_m_per_s2, noise=sigma)
    return min(fit_model(problem, tuple(effects), start=s).rss for s in (None, *starts)) / float(sigma) ** 2


def problem_start(problem):
    """The baseline's starting values of a problem (cached on it)."""
    cache = problem.__dict__.get("_start")
    if cache is None:
        cache = initial_values(problem)
        object.__setattr__(problem, "_start", cache)
    return cache


def make_problem(data, ball, g_m_per_s2=STANDARD_GRAVITY_M_PER_S2, noise=None, noise_known=False):
    """A :class:`Problem` for ``data`` (one measurement or Runs) with enough bounces simulated to cover it.

    A joint fit of several runs takes one reference speed for a speed-dependent ε: the first
    impact speed of the highest drop as the starting values give it, sqrt(2 g H_max) (fixed,
    so that every run follows one law ε(v)).
    """
    runs = _runs_of(data)
    kinds = {getattr(r, "kind", None) for r in runs}
    for k in kinds:
        _check_kind(k)
    if len(kinds) > 1:
        raise UsageError(f"a joint fit needs runs of one kind, got {', '.join(sorted(map(str, kinds)))}")
    g = float(g_m_per_s2)
    if not (math.isfinite(g) and g > 0):
        raise UsageError(f"g must be a finite number > 0 [m/s^2], got {g_m_per_s2!r}")
    n_b, heights = 1, []
    for run in runs:
        base = initial_baseline(run, g)
        n_b = max(n_b, count_bounces(run, base["drop_height_m"], base["epsilon"], base.get("release_time_s", 0.0), g))
        heights.append(max(base["drop_height_m"], 1e-4))
    v_ref = math.sqrt(2.0 * g * max(heights)) if len(runs) > 1 else None
    # impact times: an assumed timing noise (a stopwatch's 0.2 ms) is a floor of the uncertainties too. Their
    # few residuals alone gave epsilon = 0.780000 +- 4e-09 on noise-free golf times judged at 0.2 ms (+- 3e-5
    # at that noise), and on 60 records of 0.2 ms jitter put 63 % / 88 % of the truths within 1 / 2 +-.
    # Apex heights read by eye alike: exact heights said epsilon 0.800000 +- 3e-17 under an assumed 2 mm.
    # (A trajectory's noise is measured from its own samples.)
    floors = bool(noise) and (bool(noise_known) or kinds in ({"impacts"}, {"apexes"}))
    return Problem(data, ball, g, max(n_b, 1), v_ref, noise, bool(noise_known and noise), floors)


def drop_height_spread(problem):
    """Highest over lowest starting drop height of the runs (1 for one run): how much the impact
    speeds differ between runs, which is what separates drag from a speed-dependent ε."""
    heights = [v for k, v in problem_start(problem).items() if k.startswith("drop_height_m")]
    return max(heights) / min(heights) if heights and min(heights) > 0 else 1.0
