"""``vrcal discover``: name the effect(s) that the paper's constant-ε model misses.

The workflow (issue 3, parts 3 and 4):

1. fit the baseline -- the model of [1]: a ball released from rest, one constant ε
   at every contact (Eq. (3) of [1]), free drop height and release time, g known;
2. fit every candidate effect of the registry :data:`vrcal.drop.effects.EFFECTS` that the
   data kind can show (``Effect.kinds``) on top of the current model;
3. call a candidate *material* only when all of these hold:

   * ΔBIC = BIC(current) - BIC(candidate) >= ``Thresholds.delta_bic`` (10: "very strong");
   * the RSS drop is far beyond the noise: p <= ``Thresholds.p_value`` for
     Δχ² = ΔRSS/σ² -- a χ² test with σ = σ_floor when the candidate's residuals are
     consistent with that noise (χ² goodness of fit p >= 1e-3), else the F test of
     nested models with σ² = RSS/(n - k)
     (σ_floor from the data alone, :func:`vrcal.discovery.residuals.noise_floor`, for
     trajectories; an assumed instrument noise, :data:`ASSUMED_NOISE`, for the few
     impact times or apex heights of a drop, or the user's ``noise``);
   * every fitted parameter lies inside the effect's physical prior
     (``Parameter.prior``), widened by ``Thresholds.prior_sigma`` (2) standard
     uncertainties so that a true value at the edge of the prior is not lost to noise;
   * the RMS gap shrinks by at least ``Thresholds.gap_factor``, or the gap removed,
     sqrt(gap_before² - gap_after²), is at least 0.2 noise sigma (on n samples that is a
     Δχ² of at least 0.04 n, e.g. 60 for a 1,500-sample trajectory);

4. rank the candidates of the round by their evidence (:func:`rank_by_evidence`: the
   Laplace approximation of the marginal likelihood, with ONE noise σ for the round and
   the prior densities of the effect parameters from the registry, ``Parameter.density``),
   name the material candidate with the highest evidence, add it to the model and repeat
   until no candidate is material (so two hidden effects are both found). With a large
   χ² gap between candidates the order is the BIC's; when two candidates fit equally well
   (impact times, apex heights: a handful of data), the one whose parameter is physically
   plausible wins (a drag coefficient of 0.47 over a speed exponent of 0.02).

What each data kind can tell apart is documented in README.md ("What each data kind can tell apart"); in
short: a trajectory separates all five effects; impact times alone cannot see the
tracked point (height_offset) nor buoyancy, and air drag, a speed-dependent ε and a
finite contact time all bend the interval sequence in similar ways; apex heights
cannot see contact durations. When the winner has a material rival in its
:data:`CONFUSABLE` group for the data kind (or within ``Thresholds.indistinguishable_bic``
of it), the winner is named but the rival is listed in ``Discovery.ambiguous`` and the
report says so, instead of pretending the data chose.

References
----------
[1] "The Graphical Method for Decision of Restitution Coefficient and Its Applications".
[2] R. E. Kass, A. E. Raftery, "Bayes factors", J. Am. Stat. Assoc. 90, 773 (1995)
    (ΔBIC > 10: very strong evidence; Sec. 4.1.1: the Laplace approximation).
[3] D. J. C. MacKay, "Information Theory, Inference, and Learning Algorithms", CUP 2003,
    Ch. 28 (model comparison and Occam's razor: evidence = best-fit likelihood times
    Occam factor).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from vrcal.discovery import residuals as res
from vrcal.errors import UsageError
from vrcal.model.restitution import STANDARD_GRAVITY_M_PER_S2

#: Assumed noise of one datum where the data alone cannot tell it (no model-free
#: estimate from a handful of impact times or apex heights): acoustic timing jitter
#: 0.2 ms (phyphox-like), apex heights read to 2 mm; 1 mm for a trajectory whose third
#: differences show no noise at all (noise-free or heavily smoothed data). The residual
#: standard deviation replaces it when the residuals are larger; ``noise=`` overrides it.
ASSUMED_NOISE = {"impacts": 2e-4, "apexes": 2e-3, "trajectory": 1e-3}

#: A final gap above this many noise sigmas is reported as a misfit the candidates do not explain.
MISFIT_FACTOR = 3.0


#: Effects that a data kind cannot reliably tell apart (found with the hidden-effect sweep of
#: benchmarks/bench_discover.py, see README.md): impact times see only the
#: flight durations, which air drag, a speed-dependent epsilon and a finite contact time all
#: stretch in nearly the same way; a handful of apex heights sees only the ratio of
#: successive heights, which drag, a speed-dependent epsilon and a tracked point above the
#: bottom (height_offset > 0) all make rise as the bounces get lower. A trajectory separates
#: all of them (the shape of each flight, the floor level, the contact gap).
CONFUSABLE = {
    "trajectory": (),
    "impacts": (frozenset({"air_drag", "velocity_dependent_restitution", "contact_duration"}),),
    "apexes": (frozenset({"air_drag", "velocity_dependent_restitution", "height_offset"}),),
}


@dataclass(frozen=True)
class Thresholds:
    """When a candidate effect is material (all must hold; see the module docstring)."""

    delta_bic: float = 10.0
    p_value: float = 1e-4
    gap_factor: float = 0.9
    removed_noise_fraction: float = 0.2
    indistinguishable_bic: float = 2.0   # a rival within this of the winner's score (-2 ln Z) is ambiguous
    prior_sigma: float = 2.0


@dataclass
class Candidate:
    """One candidate effect fitted on top of the current model in one round."""

    name: str
    round: int
    fit: res.FitResult
    delta_bic: float
    delta_chi2: float
    p_value: float
    in_prior: bool
    gap_ok: bool
    material: bool = False
    verdict: str = ""
    members: tuple = ()
    evidence: float = math.nan        # -2 ln Z of the candidate model (see rank_by_evidence)
    two_ln_bayes: float = math.nan    # 2 ln B against the current model (> 0 favours the candidate)

    def __post_init__(self):
        if not self.members:
            self.members = tuple(self.name.split("+"))

    @property
    def gap(self):
        return self.fit.gap

    @property
    def score(self):
        """The ranking statistic (lower is better): -2 ln of the candidate's evidence with the
        registry's prior densities (:func:`rank_by_evidence`); its BIC before that is known."""
        return self.evidence if math.isfinite(self.evidence) else self.fit.bic


@dataclass
class Discovery:
    """The result of :func:`discover`."""

    data: object
    ball: object
    g_m_per_s2: float
    noise_floor: float | None
    baseline: res.FitResult
    final: res.FitResult
    effects: list
    rounds: list                      # list of lists of Candidate
    thresholds: Thresholds
    notes: list = field(default_factory=list)
    noise_source: str = ""
    ambiguous: dict = field(default_factory=dict)   # named effect -> alternatives the data cannot rule out

    @property
    def unit(self):
        return res.KINDS[self.data.kind]

    @property
    def gap_before(self):
        return self.baseline.gap

    @property
    def gap_after(self):
        return self.final.gap

    @property
    def epsilon(self):
        """ε of the extended model: the contact's own restitution, at the first impact speed
        when ``velocity_dependent_restitution`` is named."""
        return self.final.baseline_values["epsilon"]

    @property
    def epsilon_baseline(self):
        """ε of the baseline: the constant that best mimics the record in a model without the effects."""
        return self.baseline.baseline_values["epsilon"]

    @property
    def candidates(self):
        return [c for rnd in self.rounds for c in rnd]

    def gap_per_bounce(self):
        """RMS residual per flight (trajectory) or per datum (impacts, apexes): (before, after)."""
        return gap_per_bounce(self.baseline, self.final)

    @property
    def ambiguous_odds(self):
        """``{named effect: {rival: posterior odds for the named one}}`` of the ambiguous namings:
        exp of half the difference of the candidates' -2 ln evidence in the round that named it."""
        out = {}
        for name, rivals in self.ambiguous.items():
            for rnd in self.rounds:
                win = [c for c in rnd if c.verdict.startswith("named") and name in c.members]
                if not win:
                    continue
                by_name = {c.name: c for c in rnd}
                out[name] = {r: math.exp(min(by_name[r].score - win[0].score, 1400.0) / 2.0)
                             for r in rivals if r in by_name}
                break
        return out

    def as_dict(self):
        """JSON-ready summary with the stable keys of the issue (and a few more)."""
        before, after = self.gap_per_bounce()
        data = self.data
        return {
            "effects": list(self.effects),
            "ambiguous": {k: list(v) for k, v in self.ambiguous.items()},
            "ambiguous_odds": self.ambiguous_odds,
            "parameters": self.final.effect_values,
            "uncertainties": self.final.effect_uncertainties,
            "gap_before": self.gap_before,
            "gap_after": self.gap_after,
            "gap_unit": self.unit,
            "gap_per_bounce": {"before": [float(v) for v in before], "after": [float(v) for v in after]},
            "epsilon": self.epsilon,
            "epsilon_baseline": self.epsilon_baseline,
            "baseline": self.baseline.baseline_values,
            "model": self.final.baseline_values,
            "noise_floor": self.noise_floor,
            "noise_source": self.noise_source,
            "statistic": "-2 ln evidence (Laplace, registry priors)",
            "candidates": [
                {"name": c.name, "round": c.round, "gap": c.gap, "score": c.score, "bic": c.fit.bic,
                 "delta_bic": c.delta_bic, "two_ln_bayes_factor": c.two_ln_bayes,
                 "p_value": c.p_value, "in_prior": c.in_prior, "material": c.material, "verdict": c.verdict,
                 "parameters": ({m: c.fit.effect_values.get(m, {}) for m in c.members} if len(c.members) > 1
                                else c.fit.effect_values.get(c.name, {}))}
                for c in self.candidates
            ],
            "data": {"kind": data.kind, "source": str(data.source), "n": int(self.baseline.n)},
            "ball": {"name": str(getattr(self.ball, "name", "ball")), "mass_kg": float(self.ball.mass_kg),
                     "diameter_m": float(self.ball.diameter_m)},
            "g_m_per_s2": self.g_m_per_s2,
            "notes": list(self.notes),
        }


def gap_per_bounce(before, after):
    """RMS residuals grouped by bounce, for two fits of the same data.

    trajectory: samples grouped by the flight they belong to in ``after``'s model
    (0 = still segment and first fall, j = after the j-th impact); impacts and apexes:
    the absolute residual of each datum. Returns (before, after) arrays.
    """
    data = after.problem.data
    if data.kind != "trajectory":
        return np.abs(before.residuals), np.abs(after.residuals)
    t = np.asarray(data.t_s, dtype=float)
    impacts = after.model().impact_times_s[0]
    seg = np.searchsorted(impacts, t, side="right")
    out_b, out_a = [], []
    for j in range(int(seg.max()) + 1):
        m = seg == j
        if np.any(m):
            out_b.append(float(res.rms(before.residuals[m])))
            out_a.append(float(res.rms(after.residuals[m])))
    return np.asarray(out_b), np.asarray(out_a)


def _start_from(fit):
    return {p.key: float(v) for p, v in zip(fit.layout, fit.values)}


def _fit_candidate(problem, named, names, current):
    """Fit current model + ``names`` (one effect, or a pair); a nested fit that ends worse than
    the current model is restarted with the new effects at their null values (a nested
    model can never be worse)."""
    from vrcal.drop.effects import EFFECTS

    start = _start_from(current)
    fit = res.fit_model(problem, (*named, *names), start=start)
    if fit.rss > current.rss * (1 + 1e-9):
        start2 = dict(start)
        for name in names:
            eff = EFFECTS[name]
            for p in eff.parameters:
                null = eff.null_values.get(p.name, p.default)
                lo, hi = p.bounds
                start2[f"{name}.{p.name}"] = float(np.clip(null, lo + 1e-3 * (hi - lo), hi - 1e-3 * (hi - lo)))
        fit2 = res.fit_model(problem, (*named, *names), start=start2)
        if fit2.rss < fit.rss:
            fit = fit2
    return fit


def rank_by_evidence(cands, current, sigma_floor):
    """Set each candidate's ``evidence`` (-2 ln Z) and ``two_ln_bayes`` against ``current``.

    All models of a round are scored with ONE noise sigma: the noise floor, or the residual
    standard deviation of the best-fitting candidate when that is larger (the data are not
    fitted down to the noise). With the noise known, chi-square differences of a few units
    are what they are -- noise -- and the prior densities of the effect parameters
    (:mod:`vrcal.drop.effects`) decide between candidates that fit equally well; with a gap of many
    sigmas the chi-square dominates and the order is the BIC's.
    Returns the sigma used.
    """
    if not cands:
        return sigma_floor
    best = min(cands, key=lambda c: c.fit.rss / max(c.fit.n - c.fit.k, 1))
    var = best.fit.rss / max(best.fit.n - best.fit.k, 1)
    sigma = math.sqrt(max(float(sigma_floor or 0.0) ** 2, var, 1e-300))
    ref = res.minus_two_ln_evidence(current, sigma)
    for c in cands:
        c.evidence = res.minus_two_ln_evidence(c.fit, sigma)
        c.two_ln_bayes = ref - c.evidence
    return sigma


def _judge(cand, current, sigma_floor, th):
    fit = cand.fit
    n, k0, k1 = fit.n, current.k, fit.k
    dk = max(k1 - k0, 1)
    dof = max(n - k1, 1)
    var = fit.rss / dof
    # the noise counts as known when the candidate's residuals are consistent with the floor
    # (chi-square goodness of fit, p >= 1e-3); else the residual variance is used
    known = bool(sigma_floor) and (sigma_floor**2 >= var or stats.chi2.sf(fit.rss / sigma_floor**2, dof) >= 1e-3)
    if known:
        var = sigma_floor**2
    var = max(var, 1e-300)
    drop = max(current.rss - fit.rss, 0.0)
    cand.delta_chi2 = drop / var
    # noise known (the residuals do not exceed the floor): chi-square test of the RSS drop;
    # otherwise the F test of nested models with the residual variance
    cand.p_value = float(stats.chi2.sf(cand.delta_chi2, dk) if known else stats.f.sf(cand.delta_chi2 / dk, dk, dof))
    cand.delta_bic = current.bic - fit.bic
    cand.in_prior = all(fit.in_prior(m, th.prior_sigma) for m in cand.members)
    removed = math.sqrt(max(current.gap**2 - fit.gap**2, 0.0))
    cand.gap_ok = (fit.gap <= th.gap_factor * current.gap) or (
        sigma_floor is not None and removed >= th.removed_noise_fraction * sigma_floor)
    reasons = []
    if cand.delta_bic < th.delta_bic:
        reasons.append(f"dBIC {cand.delta_bic:.1f} < {th.delta_bic:g}")
    if cand.p_value > th.p_value:
        reasons.append(f"p {cand.p_value:.2g} > {th.p_value:g}")
    if not cand.in_prior:
        reasons.append("parameter outside its physical prior")
    if not cand.gap_ok:
        reasons.append("gap barely shrinks")
    cand.material = not reasons
    cand.verdict = "material" if cand.material else "not material: " + "; ".join(reasons)
    return cand


#: A trajectory whose lowest sample after release lies outside this band [m] is not
#: referenced to the floor (no tracked point is that far below or above the floor).
FLOOR_BAND_M = (-0.05, 0.3)


def floor_referenced(data, floor_m=None):
    """A trajectory with heights above the floor, and a note saying what was done (or None).

    Parameters
    ----------
    data : Trajectory or ImpactTimes or ApexHeights
        only trajectories are changed
    floor_m : float or None
        height of the floor in the data's frame [m]; subtracted from every height. None:
        keep the heights when the lowest sample after release lies in
        :data:`FLOOR_BAND_M`, otherwise subtract the lowest sample (the data's origin is
        then the lowest tracked position, and ``height_offset`` measures the tracked
        point at contact relative to it).
    """
    import dataclasses

    if data.kind != "trajectory":
        if floor_m is not None:
            raise UsageError(f"--floor applies to trajectories, not to {data.kind} data")
        return data, None
    y = np.asarray(data.y_m, dtype=float)
    if floor_m is not None:
        shift = float(floor_m)
        note = f"heights shifted by {-shift:+.4f} m (--floor {shift:g} m)"
    else:
        low = float(np.min(y[int(getattr(data, "release_index", 0) or 0):]))
        if FLOOR_BAND_M[0] <= low <= FLOOR_BAND_M[1]:
            return data, None
        shift = low
        note = (f"heights are not referenced to the floor (lowest sample after release at {low:+.4f} m): "
                f"shifted by {-shift:+.4f} m so that the lowest sample is at 0; height_offset is then the "
                f"tracked point at contact relative to the lowest sample (give --floor to set the floor)")
    return dataclasses.replace(data, y_m=y - shift), note


def discover(data, ball, *, g_m_per_s2=STANDARD_GRAVITY_M_PER_S2, candidates=None, thresholds=None,
             progress=None, max_effects=3, floor_m=None, noise=None):
    """Name the effects that the constant-ε baseline misses in ``data``.

    Parameters
    ----------
    data : Trajectory or ImpactTimes or ApexHeights
        a measurement from :func:`vrcal.measurements.read_measurement` (or the synthetic generator)
    ball : BallProperties or vrcal.model.standards.Ball
        mass [kg] and diameter [m] of the ball (used by air drag and buoyancy)
    g_m_per_s2 : float
        gravitational acceleration [m/s²], known (default standard gravity)
    candidates : sequence of str, optional
        effect names to try (default: every effect of the registry whose ``kinds``
        include the data's kind)
    thresholds : Thresholds, optional
        materiality test (see the module docstring)
    progress : callable, optional
        ``progress(round, index, total, name)`` called before each candidate fit
    max_effects : int
        most effects to name
    floor_m : float or None
        trajectories: height of the floor in the data's frame [m] (see :func:`floor_referenced`)
    noise : float or None
        noise of one datum in the data's unit (m or s); default: estimated from a
        trajectory (:func:`vrcal.discovery.residuals.noise_floor`), else :data:`ASSUMED_NOISE`

    Returns
    -------
    Discovery
    """
    from vrcal.drop.effects import EFFECTS
    from vrcal.model.body import ball_properties

    th = thresholds or Thresholds()
    ball = ball_properties(ball)
    data, floor_note = floor_referenced(data, floor_m)
    problem = res.make_problem(data, ball, g_m_per_s2)
    kind = data.kind
    usable = res.applicable_effects(kind)
    if candidates is None:
        pool = list(usable)
    else:
        pool = []
        for name in candidates:
            if name not in usable:
                from vrcal.drop.effects import get_effect

                eff = get_effect(name)
                raise UsageError(f"effect '{eff.name}' cannot be seen in {kind} data "
                                 f"(it shows in: {', '.join(eff.kinds)}; usable here: {', '.join(usable)})")
            pool.append(name)
    if noise is not None:
        if not (math.isfinite(noise) and noise > 0):
            raise UsageError(f"noise must be a number > 0 in the data's unit, got {noise:g}")
        sigma_floor, noise_source = float(noise), "given"
    else:
        sigma_floor = res.noise_floor(data)
        noise_source = "third differences of the samples"
        if sigma_floor is None:
            sigma_floor, noise_source = ASSUMED_NOISE[kind], "assumed; give --noise to change it"
            if kind == "trajectory":
                noise_source = "no noise measurable in the samples; assumed, give --noise to change it"
    baseline = res.fit_model(problem, ())
    current, named, rounds, notes, ambiguous = baseline, [], [], [], {}
    if floor_note:
        notes.append(floor_note)
    skipped = sorted(set(res.applicable_effects(kind)) ^ set(_all_effects()))
    if skipped:
        notes.append(f"not tried ({kind} data cannot show them): {', '.join(skipped)}")
    while pool and len(named) < max_effects:
        rnd = len(rounds) + 1
        cands = []
        n_data = current.n
        fits_in = [n for n in pool if n_data - current.k - len(EFFECTS[n].parameters) >= 2]
        if len(fits_in) < len(pool):
            notes.append(f"round {rnd}: {n_data} data are too few to try "
                         f"{', '.join(n for n in pool if n not in fits_in)} on top of {current.k} parameters")
            pool = fits_in
            if not pool:
                break
        for i, name in enumerate(pool):
            if progress is not None:
                progress(rnd, i + 1, len(pool), name)
            fit = _fit_candidate(problem, named, (name,), current)
            cand = Candidate(name, rnd, fit, 0.0, 0.0, 1.0, False, False)
            cands.append(_judge(cand, current, sigma_floor, th))
        material = [c for c in cands if c.material]
        if not material and len(named) + 2 <= max_effects:
            cands += _pairs(problem, named, pool, cands, current, sigma_floor, th, rnd, progress)
            material = [c for c in cands if c.material]
        rank_by_evidence(cands, current, sigma_floor)
        cands.sort(key=lambda c: c.score)
        material.sort(key=lambda c: c.score)
        rounds.append(cands)
        if not material:
            break
        win = material[0]
        groups = [g for g in CONFUSABLE[kind] if set(win.members) & g]
        rivals = [c for c in material[1:] if len(c.members) == 1 and c.name not in win.members and (
            c.score - win.score < th.indistinguishable_bic or any(c.name in g for g in groups))]
        close = [c.name for c in rivals]
        if close:
            ambiguous[win.name] = close
            odds = ", ".join(f"{c.name} {_odds(c.score - win.score)}" for c in rivals)
            notes.append(f"round {rnd}: {win.name} is named (highest evidence) but {', '.join(close)} also "
                         f"explain(s) the {kind} data (posterior odds for {win.name} with the registry's priors: "
                         f"{odds}); {kind} data cannot reliably tell them apart (a trajectory can)")
        win.verdict = "named" + (f" (ambiguous with {', '.join(close)})" if close else "")
        named.extend(win.members)
        current = win.fit
        pool = [n for n in pool if n not in win.members]
        before = list(named)
        named, current = _backward(problem, named, win.members, current, th, rnd, notes)
        for c in (c for r in rounds for c in r):
            if c.verdict.startswith("named") and any(m in before and m not in named for m in c.members):
                c.verdict = f"named, dropped in round {rnd}"
    ambiguous = {k: v for k, v in ambiguous.items() if k in named}
    if current.gap > MISFIT_FACTOR * sigma_floor:
        notes.append(f"the final model leaves a gap {current.gap / sigma_floor:.1f} times the noise floor: "
                     f"structure that none of the candidates explains (check units, the y direction, the frame "
                     f"rate and the ball; or an effect outside the registry)")
    return Discovery(data, ball, float(g_m_per_s2), sigma_floor, baseline, current, named, rounds, th, notes,
                     noise_source, ambiguous)


def _backward(problem, named, added, current, th, rnd, notes):
    """Stepwise backward check: drop an earlier-named effect that the newly added one has made
    unnecessary (removing it raises the BIC by less than the threshold). Forward selection
    alone can name a stand-in first (a speed-dependent epsilon mimics drag plus an offset)."""
    changed = True
    while changed:
        changed = False
        for name in [n for n in named if n not in added]:
            rest = [n for n in named if n != name]
            start = {k: v for k, v in _start_from(current).items() if not k.startswith(name + ".")}
            fit = res.fit_model(problem, tuple(rest), start=start)
            if fit.bic - current.bic < th.delta_bic:
                notes.append(f"round {rnd}: {name} dropped again: once {' + '.join(added)} is in the model "
                             f"it no longer helps (dBIC {current.bic - fit.bic:+.1f} when removed)")
                named, current, changed = rest, fit, True
                break
    return named, current


def _pairs(problem, named, pool, singles, current, sigma_floor, th, rnd, progress):
    """Pairs of effects, tried when no single effect is material but some improve the fit
    strongly (dBIC >= threshold) with an implausible parameter: two effects can bend the
    record in opposite ways, so that each alone needs an unphysical value. A pair is
    material when it passes the test against the current model AND beats each of its
    members alone by the dBIC threshold (both are needed)."""
    from vrcal.drop.effects import EFFECTS

    strong = {c.name for c in singles if c.delta_bic >= th.delta_bic}
    if not strong:
        return []
    by_name = {c.name: c for c in singles}
    pairs = [(a, b) for i, a in enumerate(pool) for b in pool[i + 1:] if a in strong or b in strong]
    room = current.n - current.k - 2
    pairs = [(a, b) for a, b in pairs if room - len(EFFECTS[a].parameters) - len(EFFECTS[b].parameters) >= 0]
    out = []
    for j, (a, b) in enumerate(pairs):
        if progress is not None:
            progress(rnd, j + 1, len(pairs), f"{a}+{b}")
        fit = _fit_candidate(problem, named, (a, b), current)
        cand = _judge(Candidate(f"{a}+{b}", rnd, fit, 0.0, 0.0, 1.0, False, False, members=(a, b)),
                      current, sigma_floor, th)
        needed = min(by_name[a].fit.bic, by_name[b].fit.bic) - fit.bic
        if cand.material and needed < th.delta_bic:
            cand.material = False
            cand.verdict = f"not material: dBIC {needed:.1f} < {th.delta_bic:g} against one effect alone"
        out.append(cand)
    return out


def _odds(delta_score):
    """Posterior odds exp(delta / 2) of two models whose -2 ln Z differ by ``delta``, as text."""
    odds = math.exp(min(delta_score, 1400.0) / 2.0)
    return f"{odds:.3g}:1" if odds < 1e4 else ">1e4:1"


def _all_effects():
    from vrcal.drop.effects import EFFECTS

    return list(EFFECTS)


def discover_file(path, ball, *, fmt=None, mass_kg=None, diameter_m=None, g_m_per_s2=STANDARD_GRAVITY_M_PER_S2,
                  standards=None, scale_m_per_px=None, y_down=False, fs_hz=None, progress=None, floor_m=None,
                  noise=None, read_options=None):
    """Read a measurement file and run :func:`discover` on it (what ``vrcal discover`` calls).

    Parameters
    ----------
    path : str
        measurement file (see :func:`vrcal.measurements.read_measurement`)
    ball : str
        a ball of the standards, or any name with ``mass_kg`` and ``diameter_m``
    fmt : str or None
        the file's format (None: auto-detect)
    mass_kg, diameter_m : float or None
        ball mass [kg] and diameter [m]; override the standard's nominal values
    g_m_per_s2 : float
        gravitational acceleration [m/s²]
    standards : dict or None
        :func:`vrcal.model.standards.load_standards` output (the shipped file when None)
    scale_m_per_px, y_down, fs_hz :
        passed to the reader (pixel scale [m/px], image y axis down, frame rate [Hz])
    progress : callable, optional
        see :func:`discover`
    floor_m : float or None
        see :func:`floor_referenced`
    noise : float or None
        noise of one datum in the data's unit, see :func:`discover`
    read_options : dict or None
        options of the sound and video readers (``roi``, ``color``, ``progress``, see
        :func:`vrcal.measurements.read_measurement`); a video's scale comes from the ball's diameter

    Returns
    -------
    Discovery
    """
    from vrcal.measurements import read_measurement
    from vrcal.model.body import ball_from_options

    if not (math.isfinite(g_m_per_s2) and g_m_per_s2 > 0):
        raise UsageError(f"--g must be a number > 0 [m/s^2], got {g_m_per_s2:g}")
    props, _std = ball_from_options(ball, standards, mass_kg, diameter_m)
    data = read_measurement(path, fmt, scale_m_per_px=scale_m_per_px, y_down=y_down, fs_hz=fs_hz,
                            diameter_m=float(np.mean(props.diameter_m)), **(read_options or {}))
    return discover(data, props, g_m_per_s2=g_m_per_s2, progress=progress, floor_m=floor_m, noise=noise)
