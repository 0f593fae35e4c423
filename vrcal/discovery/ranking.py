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
   * every fitted parameter, the candidate's and those of the effects named before, lies inside
     its hard physical limits (``Parameter.physical_limits``: C_d 0.2-1.0, a contact time up to
     twice the ball's membrane estimate, an offset within the ball, ...). When the unconstrained
     optimum lies beyond them, the model fitted inside them is judged instead (:func:`_try`,
     :func:`fit_physical`): named at its limit when it passes every test and the data cannot reject
     the limit; otherwise the candidate is not named and is reported with the value it would need
     and what to check (``Discovery.unphysical``). Every later fit of the model (a later round's,
     the backward step's, the final ones) keeps the named effects inside their limits;
   * the RMS gap shrinks by at least ``Thresholds.gap_factor``, or the gap removed,
     sqrt(gap_before² - gap_after²), is at least 0.2 noise sigma (on n samples that is a
     Δχ² of at least 0.04 n, e.g. 60 for a 1,500-sample trajectory) and, where the model
     before misfits, at least what a shrink by ``gap_factor`` takes of the misfit beyond the noise
     (:func:`gap_removed_enough`: the residuals of a misfit are structure, not independent noise,
     and the χ² and F tests would pass any parameter that follows a little of it);

4. rank the candidates of the round by their evidence (:func:`rank_by_evidence`: the
   Laplace approximation of the marginal likelihood, with ONE noise σ for the round and
   the prior densities of the effect parameters from the registry, ``Parameter.density``),
   name the material candidate with the highest evidence, add it to the model and repeat
   until no candidate is material (so every hidden effect is found: there is no cap; a caller's
   ``max_effects`` stops the rounds, and what it leaves out is reported, ``Discovery.cut``). With a large
   χ² gap between candidates the order is the BIC's; when two candidates fit equally well
   (impact times, apex heights: a handful of data), the one whose parameter is physically
   plausible wins (a drag coefficient of 0.47 over a speed exponent of 0.02).

5. give ONE verdict (:func:`verdict`), which every part of the report follows: "suspect input"
   when the record looks wrong (:mod:`vrcal.measurements.plausibility`), "explained" when the
   final model's gap is within :data:`EXPLAINED_FACTOR` of the noise floor (or of the record's
   own bounce-to-bounce scatter, for impact times), else "unexplained".

Several runs (a drop table, several files, the pieces of a record around a bounce that does
not belong: :mod:`vrcal.discovery.prepare`) are fitted jointly: one epsilon and one set of
effects, a release state per run.

What each data kind can tell apart is documented in docs/discover.md ("What each data kind can tell apart"); in
short: a trajectory separates all five effects; impact times alone cannot see the
tracked point (height_offset) nor buoyancy, and air drag, a speed-dependent ε and a
finite contact time all bend the interval sequence in similar ways; apex heights
cannot see contact durations. When the winner has a material rival in its
:data:`CONFUSABLE` group for the data kind that the data cannot reject (its χ² within
``Thresholds.indistinguishable_chi2`` of the winner's), or any rival within
``Thresholds.indistinguishable_bic`` of its evidence, the winner is named but the rival is
listed in ``Discovery.ambiguous`` and the report says so, instead of pretending the data
chose. A rival the data reject (a χ² 9 or more above the winner's) is not listed, however
close the group; nor is one whose posterior odds are decisively lower
(``Thresholds.decisive_two_ln_odds``).

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

import functools
import math
from dataclasses import dataclass, field, replace

import numpy as np

from vrcal.discovery import residuals as res
from vrcal.discovery.lsq import chi2_sf, f_sf
from vrcal.discovery.prepare import FLOOR_BAND_M, floor_referenced, heights_to_bottom  # noqa: F401 (re-exported)
from vrcal.errors import UsageError
from vrcal.measurements.cleanup import TIMING_SIGMA_S
from vrcal.model.restitution import STANDARD_GRAVITY_M_PER_S2
from vrcal.textout import number

#: Assumed noise of one datum where the data alone cannot tell it (no model-free
#: estimate from a handful of impact times or apex heights): acoustic timing jitter
#: 0.2 ms (phyphox-like), apex heights read to 2 mm; 1 mm for a trajectory whose third
#: differences show no noise at all (noise-free or heavily smoothed data). The residual
#: standard deviation replaces it when the residuals are larger; ``noise=`` overrides it.
ASSUMED_NOISE = {"impacts": TIMING_SIGMA_S, "apexes": 2e-3, "trajectory": 1e-3}

#: The two effects that apex heights and impact times over a narrow range of speeds cannot tell apart
#: (:attr:`Discovery.speeds_too_narrow`): both take more from the faster bounces.
DRAG_OR_SPEED_LAW = ("air_drag", "velocity_dependent_restitution")

#: ``Discovery.noise_source`` when the noise of a drop table is the scatter of its repeated trials
#: (:func:`vrcal.discovery.residuals.replicate_sigma`).
REPLICATE_SOURCE = "scatter of the rebounds of trials repeated at one drop height"
#: ... when it is what the reader knows of the way the times were taken (vrcal's onsets in a lossless recording:
#: ``ImpactTimes.instrument_sd_s``), still an assumption.
INSTRUMENT_SOURCE = "assumed for onsets timed in a lossless recording"
#: ... when it is the grid that impact times were read on (a video's frames, times printed to 0.01 s:
#: ``ImpactTimes.timing_sd_s``).
GRID_SOURCE = "grid of the impact times (step/sqrt(12))"

#: The verdict "explained": the final gap is at most this many times the noise floor (or the
#: record's bounce-to-bounce scatter, when larger).
EXPLAINED_FACTOR = 3.0

#: Kept for compatibility: the factor of the misfit note (the same as EXPLAINED_FACTOR).
MISFIT_FACTOR = EXPLAINED_FACTOR

#: Effects that a data kind cannot reliably tell apart (found with the hidden-effect sweep of
#: benchmarks/bench_discover.py, see docs/discover.md): impact times see only the
#: flight durations, which air drag, a speed-dependent epsilon and a finite contact time all
#: stretch in nearly the same way; a handful of apex heights sees only the ratio of
#: successive heights, which drag, a speed-dependent epsilon and a tracked point above the
#: bottom (height_offset > 0) all make rise as the bounces get lower. A trajectory separates
#: all of them (the shape of each flight, the floor level, the contact gap); there a rival is
#: ambiguous only when its evidence is within ``Thresholds.indistinguishable_bic``.
CONFUSABLE = {
    "trajectory": (),
    "impacts": (frozenset({"air_drag", "velocity_dependent_restitution", "contact_duration"}),),
    "apexes": (frozenset({"air_drag", "velocity_dependent_restitution", "height_offset"}),),
}

#: Runs whose drop heights differ by this factor or more are not held to :data:`CONFUSABLE`: their
#: impact speeds differ from run to run, which tells drag, a speed-dependent epsilon and an offset
#: apart; a rival is then ambiguous only when its evidence is close.
SPREAD_SEPARATES = 1.5

#: Effects every ball has, held at their prior's median by :attr:`Discovery.systematic` when a record of
#: these kinds does not resolve them: (effect, parameter, kinds). A speed law's exponent differs from
#: material to material (near 0 for some), so it is held only where the data allow it
#: (:data:`HELD_IF_ALLOWED`).
EXPECTED_EFFECTS = (("air_drag", "drag_coefficient", ("impacts", "apexes")),
                    ("velocity_dependent_restitution", "exponent", ("apexes",)),
                    ("contact_duration", "contact_time_s", ("impacts",)))

#: Of :data:`EXPECTED_EFFECTS`, those :attr:`Discovery.systematic` holds only when the record does not
#: reject the held value (its chi-square at most ``Thresholds.indistinguishable_chi2`` above the final
#: model's): a drop table of a ball of constant epsilon excludes a viscoelastic p = 1/5 (chi2 +34 on
#: ``examples/data/drop-table.csv``), one of a Hertzian ping-pong ball does not (+0.2 to +1.5). Air drag
#: too: every ball has it, but heights that reject a sphere's C_d (a ping-pong table of 0.2-2.5 m fitted
#: without drag: chi2 +50,909, epsilon pinned at 1 with it) say the ball's mass or size is not the one
#: given, not that epsilon is 0.999; the drag only at a noise measured (repeated trials) or given.
HELD_IF_ALLOWED = frozenset({"velocity_dependent_restitution", "air_drag"})

#: The verdicts (``Discovery.verdict``; the JSON's ``verdict``).
VERDICTS = ("explained", "unexplained", "untested", "suspect input")


@dataclass(frozen=True)
class Thresholds:
    """When a candidate effect is material (all must hold; see the module docstring)."""

    delta_bic: float = 10.0
    p_value: float = 1e-4
    gap_factor: float = 0.9
    removed_noise_fraction: float = 0.2
    indistinguishable_bic: float = 6.0   # a rival within this of the winner's -2 ln Z (odds < 20:1) is ambiguous
    #: files of a joint fit whose own ε lie this many standard deviations apart are no one ball (:func:`files_disagree`)
    file_sigmas: float = 5.0
    #: a rival of the winner's CONFUSABLE group is ambiguous when its chi-square is within this of the winner's (3
    #: sigma: the data cannot reject it), however the priors weigh the two; the chi-square is at the noise floor, or
    #: at the winner's residual variance when that is larger
    indistinguishable_chi2: float = 9.0
    #: ... unless its posterior odds against the rival are decisive (2 ln 100: Jeffreys' "decisive", [2]):
    #: a speed law that fits only with p near 0, where its prior has no mass, is the absence of the effect,
    #: and sharing by the priors would invent one (golf impact times with drag alone: p 0.01 at odds
    #: 9,100:1, and the shared epsilon 0.0017 low, 14 times its +-)
    decisive_two_ln_odds: float = 9.2


@dataclass
class Candidate:
    """One candidate effect fitted on top of the current model in one round."""

    name: str
    round: int
    fit: res.FitResult
    delta_bic: float
    delta_chi2: float
    p_value: float
    in_prior: bool                    # every parameter inside its hard physical limits
    gap_ok: bool
    material: bool = False
    verdict: str = ""
    members: tuple = ()
    evidence: float = math.nan        # -2 ln Z of the candidate model (see rank_by_evidence)
    two_ln_bayes: float = math.nan    # 2 ln B against the current model (> 0 favours the candidate)
    outside: list = field(default_factory=list)   # [(effect, parameter, value, (lo, hi))] beyond the limits
    # the unconstrained fit, when ``fit`` is the fit held inside the physical limits (:func:`_try`): its optimum
    # lay beyond them, and the data cannot reject the limits
    free: res.FitResult | None = None

    def __post_init__(self):
        if not self.members:
            self.members = tuple(self.name.split("+"))

    @property
    def gap(self):
        return self.fit.gap

    @property
    def physical(self):
        return self.in_prior

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
    warnings: list = field(default_factory=list)    # what looks wrong in the input (verdict "suspect input")
    labels: tuple = ()                # one label per run
    scatter: float | None = None      # relative bounce-to-bounce scatter of impact-interval ratios
    scatter_gap: float | None = None  # the gap that scatter alone leaves [data unit]
    reader: dict = field(default_factory=dict)      # how the file was read (for a replay)
    decimation: int = 1               # every k-th sample of a long trajectory was fitted (1: all)
    n_read: int | None = None         # data read before decimation (None: as fitted)
    split: res.FitResult | None = None  # named effects and their ambiguous rivals at the posterior mode
    nuisance: tuple = ()              # effects in every model that are not named: the floor's level, when
                                      # the record has no floor (``height_offset``)
    # (baseline, final) by generalized least squares, when the effects were judged so (impact times whose
    # bounces scatter: :func:`vrcal.discovery.residuals.scatter_weights`); the candidates are of the same kind
    judged: tuple | None = None
    scatter_limit: float | None = None   # impact times with no scatter found: the largest they allow (95 %)
    cut: list = field(default_factory=list)  # effects material in the last round but not named: ``max_effects``
    max_effects: int | None = None       # the cap on the effects named (None: none)
    # the g [m/s^2] of the world when the fit took the record's own (:func:`at_apparent_g`: a length scale or a
    # frame rate off); None when the fit's g is the world's
    g_nominal_m_per_s2: float | None = None

    @property
    def unit(self):
        return res.KINDS[self.kind]

    @property
    def kind(self):
        return self.final.problem.runs[0].kind

    @property
    def runs(self):
        return self.final.problem.runs

    @property
    def gap_before(self):
        return self.baseline.gap

    @property
    def gap_after(self):
        return self.final.gap

    @property
    def epsilon(self):
        """ε of the extended model: the contact's own restitution, at the reference speed (the first
        impact speed of the drop, or of the highest drop of a joint fit) when
        ``velocity_dependent_restitution`` is named."""
        return self.final.baseline_values["epsilon"]

    @functools.cached_property
    def systematic(self):
        """What ε would be if the effects every ball has, which this record did not resolve, acted as
        physics expects of this ball: ``{"held": {parameter key: value}, "epsilon_shift": ...,
        "named_with_held": {the named effects' parameter keys: their values so}}``, or
        None (a trajectory, which resolves them; nothing left to hold; an untested record).

        Held (when not named, :data:`EXPECTED_EFFECTS`): air drag at a smooth sphere's C_d (the prior's
        median, 0.47) for impact times and apex heights, and for impact times the contact's duration
        expected of the ball (its prior's median, :func:`vrcal.drop.effects.expected_contact_time_s`);
        for apex heights a viscoelastic ball's speed-dependent epsilon (p = 1/5, the prior's median);
        the speed law and the drag only when the data allow them (:data:`HELD_IF_ALLOWED`; else
        ``excluded``: {key: chi-square increase}).
        Impact times cannot tell a contact of duration tau from a higher epsilon (each interval grows
        by tau), nor a little drag from a slightly speed-dependent one; a drop table's few heights
        cannot prove drag at its size, yet the ball has it, nor tell drag from a speed law (both take
        more from the higher drops: a Hertzian ping-pong ball's table named drag alone at C_d 0.465
        for 0.39-0.42, epsilon 0.934 for 0.916-0.931; held at p = 1/5 it gives 0.921 at 5.4 m/s).
        The final model is fitted again with them held there (its own effects free): the shift of ε
        is a systematic uncertainty beside the fit's statistical one. The contact's duration is
        known to a band only (:func:`vrcal.drop.effects.contact_time_range_s`: the moduli of the
        ball's density class, or an inflated ball's gauge pressures): ``epsilon_shift_range`` [lo,
        hi] is the shift over it (``held_range``), and holds ``epsilon_shift``. Measured: the
        blue ball's phyphox records move by -0.0012 to -0.0027 for a 5 ms contact (1-3 x their +-);
        a tennis ball's phone impact times with C_d 0.55 and 5 ms contacts named a speed law with
        epsilon 0.0064 (20 sigma) low, which the held fit restores.
        """
        if self.kind == "trajectory" or self.verdict == "untested":
            return None
        from vrcal.drop.effects import EFFECTS, contact_time_range_s, surface_of

        f = self.final
        added = [(effect, name) for effect, name, kinds in EXPECTED_EFFECTS
                 if self.kind in kinds and effect not in f.effects]
        if not added:
            return None
        # where physics puts them: the median of the parameter's prior density for this ball
        held = {f"{effect}.{name}": EFFECTS[effect].parameter(name).density.center(self.ball)
                for effect, name in added}
        start = {p.key: float(v) for p, v in zip(f.layout, f.values)}
        excluded = {}
        sigma2 = self.reference_sigma ** 2
        # drag, which every ball has, is excluded only by a noise measured or given, not by an assumed one
        # (three rows of a table, two at one height, "excluded" it at an assumed 2 mm), and judged at the final
        # model's own misfit when that does not explain the record (a joint fit of two balls' tables): a
        # chi-square increase there says how much worse, not that the drag is excluded
        drag_sigma2 = sigma2 if self.within_noise else _at_misfit(sigma2, f)
        for effect, name in added:
            if effect in HELD_IF_ALLOWED and (effect != "air_drag" or f.problem.noise_known):
                key = f"{effect}.{name}"
                alone = res.fit_model(f.problem, tuple(f.effects) + (effect,), start, fixed={key: held[key]})
                increase = (alone.rss - f.rss) / (drag_sigma2 if effect == "air_drag" else sigma2)
                if increase > self.thresholds.indistinguishable_chi2:
                    excluded[key] = float(increase)
                    del held[key]
        added = [(effect, name) for effect, name in added if f"{effect}.{name}" in held]
        if not added:
            return {"held": {}, "epsilon_shift": 0.0, "excluded": excluded} if excluded else None

        def shift(fixed):
            return self.held_epsilon(fixed) - float(f.baseline_values["epsilon"])

        out = {"held": held, "epsilon_shift": shift(held)}
        held_fit = self.held_fit(held)
        # the named effects' own parameters move too (a speed law named alone on a table of a ball with drag and
        # a speed law: p 0.387 +- 0.012, 0.30 planted with C_d 0.55, 0.326 with a sphere's 0.47 held):
        # {parameter key: value held}
        out["named_with_held"] = {p.key: float(v) for p, v in zip(held_fit.layout, held_fit.values)
                                  if p.effect in f.effects}
        if "velocity_dependent_restitution" in held_fit.effects:
            # a speed law: epsilon at the fastest impact the held model makes (its drag slows the ball)
            eps, v = self.fastest_impact(held_fit)
            out["fastest_impact"] = {"epsilon": eps, "speed_m_per_s": v}
        if excluded:
            out["excluded"] = excluded
        key = "contact_duration.contact_time_s"
        if key in held:
            # the contact time is known to a band (the ball's plausible moduli or gauge pressures), not a point
            span = contact_time_range_s(float(np.mean(self.ball.mass_kg)), float(np.mean(self.ball.diameter_m)),
                                        surface_of(self.ball))
            shifts = [shift({**held, key: tau}) for tau in span]
            out["held_range"] = {key: list(span)}
            out["epsilon_shift_range"] = [min(shifts + [out["epsilon_shift"]]), max(shifts + [out["epsilon_shift"]])]
        return out

    def held_epsilon(self, held):
        """ε of the final model fitted again, over all the runs, with the parameters ``held`` ({parameter key:
        value}; their effects added to the final model's in that order) held there. One fit per set, kept: the
        report's sentences, :attr:`systematic` and :attr:`epsilon_with_sphere_drag` read the same number."""
        return float(self.held_fit(held).baseline_values["epsilon"])

    def held_fit(self, held):
        """The final model fitted again with the parameters ``held`` held there (:meth:`held_epsilon`): the
        fit, kept per set."""
        key = tuple((k, float(v)) for k, v in held.items())
        kept = self.__dict__.setdefault("_held_fits", {})
        if key not in kept:
            f = self.final
            added = tuple(dict.fromkeys(k.split(".")[0] for k in held if k.split(".")[0] not in f.effects))
            start = {p.key: float(v) for p, v in zip(f.layout, f.values)}
            kept[key] = res.fit_model(f.problem, tuple(f.effects) + added, start, fixed=dict(held))
        return kept[key]

    def fastest_impact(self, fit=None):
        """(ε, speed [m/s]) of the fastest impact of the record's bounces in the final model (or in ``fit``,
        e.g. :meth:`held_fit`): where a speed law's ε is quoted. Not at :attr:`reference_speed`, the law's
        pivot: a drop table's is sqrt(2 g H) of the highest drop without drag, and a ball held to a sphere's
        drag lands slower (5.42 m/s without, 4.93 with: epsilon 0.6815 quoted at 5.42 m/s, 0.7046 at the
        4.93 it reaches)."""
        fit = self.final if fit is None else fit
        v = float(self.speed_range(fit)[1])
        return float(self.epsilon_at([v], fit=fit)[0]), v

    @property
    def epsilon_with_sphere_drag(self):
        """ε with a smooth sphere's air drag (C_d :data:`vrcal.model.restitution.SPHERE_DRAG_COEFFICIENT`, the
        median of the drag's prior; its added mass included) held in the final model, fitted over all the runs:
        the contact's own ε if the ball has the drag every ball has (:meth:`held_epsilon`). None for a
        trajectory (which resolves drag) and when air drag is named (its fitted C_d then holds)."""
        if self.kind == "trajectory" or "air_drag" in self.final.effects:
            return None
        from vrcal.drop.effects import EFFECTS

        key = "air_drag.drag_coefficient"
        return self.held_epsilon({key: EFFECTS["air_drag"].parameter("drag_coefficient").density.center(self.ball)})

    @property
    def fit_epsilon_uncertainty(self):
        """The fit's own 1-sigma of ε, from its residuals taken as independent ((JᵀJ)⁻¹ σ²). For impact
        times it is less than the reported one when the bounces scatter (each shifts every later time:
        :func:`vrcal.discovery.residuals.scatter_uncertainties`)."""
        own = self.final.extra.get("fit_uncertainties")
        if own is None:
            return self.final.uncertainty("epsilon")
        return float(own[[p.key for p in self.final.layout].index("epsilon")])

    @functools.cached_property
    def bounce_epsilons(self):
        """Each bounce's own speed ratio in a trajectory, and the final model's as the same estimator reads it
        off the model's heights at the same samples (:func:`vrcal.discovery.residuals.bounce_speed_ratios`:
        the speeds in and out where free parabolas through the flights on either side meet; read off both,
        the estimator's own bias -- drag bending a flight, a contact's duration -- cancels in the
        difference). A run whose frames are too sparse for that (fewer than 5 near each contact: a 30 fps
        video) is read with parabolas of g through whole flights (:func:`vrcal.discovery.residuals.
        bounce_flight_ratios`): [{"run", "time_s", "impact_speed_m_per_s", "epsilon", "epsilon_standard_error",
        "epsilon_model", "estimator"}] ("speed ratio" or "flight parabolas"); [] for impact times and heights."""
        if self.kind != "trajectory":
            return []
        out = []
        g = self.final.problem.g_m_per_s2
        for r, run in enumerate(self.runs):
            t, start = np.asarray(run.t_s, dtype=float), int(getattr(run, "release_index", 0) or 0)
            heights = self.final.predict_at(t, run=r)
            found = res.bounce_speed_ratios(t, run.y_m, start)
            model = res.bounce_speed_ratios(t, heights, start)
            estimator = "speed ratio"
            if not found.size or not model.size:
                found = res.bounce_flight_ratios(t, run.y_m, start, g)
                model = res.bounce_flight_ratios(t, heights, start, g)
                estimator = "flight parabolas"
            if not found.size or not model.size:
                continue
            for tc, v_in, ratio, se in found:
                k = int(np.argmin(np.abs(model[:, 0] - tc)))
                if abs(model[k, 0] - tc) > 0.25 * (tc - t[start]) / (k + 1):   # no such bounce in the model
                    continue
                out.append({"run": r, "time_s": float(tc), "impact_speed_m_per_s": float(v_in),
                            "epsilon": float(ratio), "epsilon_standard_error": float(se),
                            "epsilon_model": float(model[k, 2]), "estimator": estimator})
        return out

    @property
    def epsilon_uncertainty(self):
        """The 1-sigma of ε the report gives. A trajectory the final model does not reproduce ("unexplained")
        leaves residuals that are structure, not independent noise: the fit's (JᵀJ)⁻¹ σ² (σ from the
        residuals: Birge's ratio is in it) rests on n independent samples where the misfit moves whole
        flights together (a marble on paper: 0.75002 ± 0.00054 at a gap 70.6 times the noise; its speeds
        say 0.737). There the fit's ± and :attr:`bounce_spread` add in quadrature; else the fit's own
        (:attr:`epsilon_uncertainty_basis` says which)."""
        hetero = self.height_dependent_noise
        u = self.final.uncertainty("epsilon") if hetero is None else hetero["epsilon_uncertainty"]
        u = math.hypot(u, self.epsilon_uncertainty_systematic or 0.0)
        spread = self.bounce_spread
        return u if spread is None else float(math.hypot(u, spread))

    @functools.cached_property
    def epsilon_uncertainty_systematic(self):
        """The 1-sigma of ε from a video tracker's systematic error of the centres (the runs' ``systematic_m``)
        taken as common to each flight's frames and independent from flight to flight
        (:func:`vrcal.discovery.residuals.flight_offset_uncertainties`), which :attr:`epsilon_uncertainty`
        adds in quadrature; None for records without it."""
        systematic = ReaderErrors.of(self.runs).systematic_m if self.kind == "trajectory" else 0.0
        if systematic <= 0:
            return None
        unc = res.flight_offset_uncertainties(self.final, systematic)
        return float(unc[[p.key for p in self.final.layout].index("epsilon")])

    @functools.cached_property
    def height_dependent_noise(self):
        """A drop table's repeated trials whose scatter grows with the height (:func:`residuals.replicate_noise_model`,
        its likelihood ratio beyond :data:`residuals.HEIGHT_DEPENDENT_NOISE_LR`): the model (``absolute_m``,
        ``relative``, ``lr``) and ``epsilon_uncertainty``, the final fit's ± of ε with each datum's own variance
        (:func:`residuals.heteroscedastic_uncertainties`), which :attr:`epsilon_uncertainty` then gives; else None.
        Planted 1 % readings of 4-6 heights, 3 trials each: the pooled ± put 79 % of 24 tables within 2 σ."""
        if self.kind != "apexes" or not self.noise_source.startswith(REPLICATE_SOURCE):
            return None
        model = res.replicate_noise_model(self.runs)
        if model is None or model["lr"] < res.HEIGHT_DEPENDENT_NOISE_LR:
            return None
        unc = res.heteroscedastic_uncertainties(self.final, model)
        i = [p.key for p in self.final.layout].index("epsilon")
        return {**model, "epsilon_uncertainty": float(unc[i])}

    @property
    def bounce_spread(self):
        """The largest difference between a bounce's own ε and the final model's at it (:attr:`bounce_epsilons`)
        beyond that bounce's standard error (sqrt(d^2 - se^2)), when it widens :attr:`epsilon_uncertainty`
        (an "unexplained" trajectory), else None. The largest, not the RMS: with a speed law the reported ε
        is the first bounce's, and a misfit bends the law (a height-dependent scale planted on a constant
        0.75: the law's 0.738 at the first bounce, its own speeds 0.749, the bounces' RMS 0.0065)."""
        if self.kind != "trajectory" or not self.bounce_epsilons or self.verdict != "unexplained":
            return None
        excess = [(b["epsilon"] - b["epsilon_model"]) ** 2 - np.nan_to_num(b["epsilon_standard_error"]) ** 2
                  for b in self.bounce_epsilons]
        return float(math.sqrt(max(max(excess), 0.0)))

    @property
    def epsilon_uncertainty_basis(self):
        """What :attr:`epsilon_uncertainty` rests on: "fit" (the residuals taken as independent; for impact
        times with the bounces' scatter), "fit and bounce speed ratios" or "fit and flight parabolas" (an
        unexplained trajectory, :attr:`bounce_epsilons`), or "fit, a lower bound" (an unexplained trajectory
        whose bounces cannot be read one by one: :attr:`epsilon_lower_bound`)."""
        if self.bounce_spread is not None:
            used = {b["estimator"] for b in self.bounce_epsilons}
            return "fit and bounce speed ratios" if "speed ratio" in used else "fit and flight parabolas"
        if self.height_dependent_noise is not None:
            return "fit, each rebound at the trials' scatter for its height"
        return "fit, a lower bound" if self.epsilon_lower_bound else "fit"

    @property
    def epsilon_lower_bound(self):
        """Why the ± of an unexplained trajectory is only a lower bound, or None: no bounce's own ratio can be
        read (no flight beside a bounce holds :data:`vrcal.discovery.residuals.FLIGHT_PARABOLA_MIN_SAMPLES`
        samples clear of its contacts), so the fit's ± stands, which takes the residuals as independent.
        With at most two samples a flight (an apex and a contact) the record looks like clicked points."""
        if self.kind != "trajectory" or self.verdict != "unexplained" or self.bounce_epsilons:
            return None
        counts = [c for run in self.runs
                  for c in res.flight_samples(run.t_s, run.y_m, int(getattr(run, "release_index", 0) or 0))[1:]]
        text = ("the fit's ± assumes independent residuals and is a lower bound: no bounce's own ratio can be read "
                f"(fewer than {res.FLIGHT_PARABOLA_MIN_SAMPLES} samples in a flight beside each bounce)")
        if counts and float(np.median(counts)) <= 1:
            text += ("; the record looks like clicked apex and contact points (one sample a flight between its "
                     "contacts): give the apex heights above the contacts as an apexes file (header 'bounce,h', "
                     "bounce 0 the drop height), which fits them without a trajectory's flights")
        return text

    @property
    def judged_baseline(self):
        """The baseline as the candidates were judged against it (:attr:`judged`, else :attr:`baseline`)."""
        return self.baseline if self.judged is None else self.judged[0]

    @property
    def judged_final(self):
        """The final model as the candidates were judged against it (:attr:`judged`, else :attr:`final`)."""
        return self.final if self.judged is None else self.judged[1]

    @property
    def epsilon_baseline(self):
        """ε of the baseline: the constant that best mimics the record in a model without the effects."""
        return self.baseline.baseline_values["epsilon"]

    #: Named effects an engine without air drag leaves out (:attr:`effective_without_drag`): the air's and
    #: a speed law, which a constant epsilon stands in for.
    DRAG_LIKE = ("air_drag", "buoyancy", "velocity_dependent_restitution")

    @functools.cached_property
    def effective_without_drag(self):
        """The constant ε an engine without air drag reproduces the record's bounce heights best with:
        {"epsilon", "bounces" (how many, from the first, it reproduces within the goal of ``vrcal verify``,
        :data:`vrcal.model.restitution.APEX_GOAL`, 3 % of each rise), "of" (the bounces the record shows),
        "misfit" (the largest relative misfit over those bounces)}; "epsilon" None and "bounces" 0 when no
        constant reproduces even the first two within the goal ("misfit" then the nearest one's over them).

        Fitted to the heights, not to the record: the apexes of the ball's bottom that the model the advice
        leads with (the prior split, else the final model) gives from its drop height, and the drag-free
        heights H ε^(2n) nearest them at the worst bounce
        (:func:`vrcal.model.restitution.constant_epsilon_for_heights`), over the longest run of bounces from
        the first that the goal allows. The baseline's ε was offered
        before: a fit of the whole record, which puts the flights' timing into ε with the heights (an
        exercise ball with buoyancy, g_eff 0.8 g, and drag got 0.8238, 11.6 % to 35.7 % too high at its five
        rebounds, whose heights ask for 0.774 to 0.802), and which a tracked point off the ball's bottom or a
        contact's duration biased too."""
        from vrcal.model.restitution import APEX_GOAL, constant_epsilon_for_heights

        model = self.split if self.split is not None else self.final
        H, h, n = [], [], []
        for r, run in enumerate(self.runs):
            drop = model.model(run=r)
            if run.kind == "apexes":
                seen = int(np.max(np.asarray(run.bounce, dtype=int)))
            else:   # the apexes before the record's last datum
                seen = int(np.sum(drop.apex_times_s[0, 1:] <= float(np.asarray(run.t_s, dtype=float)[-1])))
            H += [drop.apex_heights_m[0, 0]] * seen
            h += list(drop.apex_heights_m[0, 1:seen + 1])
            n += list(range(1, seen + 1))
        H, h, n = (np.asarray(v, dtype=float) for v in (H, h, n))
        of = int(np.max(n)) if n.size else 0
        out = {"epsilon": None, "bounces": 0, "of": of, "misfit": None}
        for upto in range(of, 0, -1):
            keep = n <= upto
            eps, misfit = constant_epsilon_for_heights(H[keep], h[keep], n[keep])
            worst = float(np.max(np.abs(misfit)))
            if upto == min(2, of):
                out["misfit"] = worst
            if worst <= APEX_GOAL:
                if upto >= min(2, of):
                    out.update(epsilon=eps, bounces=upto, misfit=worst)
                break
        return out

    @property
    def candidates(self):
        return [c for rnd in self.rounds for c in rnd]

    @property
    def reference_sigma(self):
        """σ [data unit] of the candidates' χ²: the data's noise floor, else the final model's residual
        standard deviation sqrt(RSS/(n - k))."""
        if self.noise_floor:
            return float(self.noise_floor)
        return math.sqrt(self.final.residual_variance)

    @property
    def reference_gap(self):
        """What the final gap is compared with: the noise floor, or the scatter's gap when larger."""
        return max(self.noise_floor or 0.0, self.scatter_gap or 0.0) or None

    @property
    def scatter_assumed(self):
        """Whether :attr:`scatter` is the typical one of real balls (:data:`TYPICAL_BOUNCE_SCATTER`), not
        seen in the times but allowed by them (:attr:`scatter_limit`), or too few to see one."""
        if self.kind != "impacts" or self.scatter is None:
            return False
        too_few = all(np.size(run.t_s) < res.SCATTER_MIN_TIMES for run in self.runs)
        return too_few or (self.scatter_limit is not None and self.scatter_limit > TYPICAL_BOUNCE_SCATTER)

    @property
    def verdict(self):
        return verdict(self)

    @property
    def within_noise(self):
        """Whether the final gap is at most :data:`EXPLAINED_FACTOR` times the noise floor (or the bounces'
        scatter's gap), and a table's repeated trials show no misfit of the final model beyond their
        scatter (:attr:`lack_of_fit`)."""
        ref = self.reference_gap
        misfit = self.lack_of_fit is not None and self.lack_of_fit["p"] < res.LACK_OF_FIT_P
        return bool(ref) and self.gap_after <= EXPLAINED_FACTOR * ref and not misfit

    @functools.cached_property
    def lack_of_fit(self):
        """The final model's lack-of-fit test on a drop table's repeated trials
        (:func:`vrcal.discovery.residuals.lack_of_fit`), or None (no repeated trials; not a table)."""
        if self.kind != "apexes":
            return None
        shared = sum(1 for p in self.final.layout if p.run is None)
        step = written_step_m(self.runs)
        return res.lack_of_fit(self.runs, self.final.residuals, shared, (step or 0.0) / math.sqrt(12.0))

    @property
    def reproduces(self):
        """Whether the final model reproduces the numbers as read: within the noise, and no candidate beyond
        its physical limits fits far better. "explained", or "suspect input" for a plausibility warning
        alone (a table in inches read as metres fits as well as one in metres: :func:`verdict`)."""
        return self.within_noise and not self.unphysical_better

    @property
    def at_limit(self):
        """The named effects' parameters that the final model holds at a hard physical limit because the
        unconstrained optimum lies beyond it: [{"effect", "parameter", "value", "limit", "unconstrained",
        "chi2"}], chi2 what the limit costs at the noise (:func:`fit_physical`)."""
        f = self.final
        free = f.extra.get("free")
        if free is None:
            return []
        cost = (f.rss - free.rss) / (self.noise_floor or f.noise_sigma(None)) ** 2
        out = []
        for effect, param, value, (lo, hi) in f.extra.get("beyond", ()):
            if effect not in self.effects:
                continue
            limit = lo if value < lo else hi
            out.append({"effect": effect, "parameter": param, "value": f.effect_values[effect][param],
                        "limit": limit, "unconstrained": value, "chi2": float(max(cost, 0.0))})
        return out

    @property
    def unusual(self):
        """The named effects' parameters that lie inside their hard limits but outside the range such balls
        measure (:meth:`vrcal.drop.effects.Parameter.typical_range`: a table-tennis ball's C_d 0.87, where a
        sphere below the drag crisis has 0.26-0.85): [{"effect", "parameter", "value", "typical"}]. Physical,
        so not refused; but another effect of the same sign that the registry cannot express (a speed
        law of another form), or a wrong mass or diameter, may be inside it, and the report says so."""
        from vrcal.drop.effects import EFFECTS

        out = []
        for effect in self.effects:
            for p in EFFECTS[effect].parameters:
                typical = p.typical_range(self.ball)
                value = self.final.effect_values[effect].get(p.name)
                if typical is not None and value is not None and not typical[0] <= value <= typical[1]:
                    out.append({"effect": effect, "parameter": p.name, "value": float(value),
                                "typical": [float(typical[0]), float(typical[1])]})
        return out

    @property
    def floor_level(self):
        """Where the contact is [m] above the lowest sample of a record without a floor (fitted with
        every model, :attr:`nuisance`), or None when the record gives the floor."""
        if "height_offset" not in self.nuisance:
            return None
        return float(self.final.effect_values["height_offset"]["offset_m"])

    @property
    def unphysical(self):
        """Candidates that would shrink the gap materially but only with a parameter beyond its
        physical limits: [{"effect", "parameter", "value", "limits", "gap", "check"}], best first."""
        return [entry for _, entry in self._unphysical()]

    @property
    def unphysical_better(self):
        """The entries of :attr:`unphysical` whose candidate fits materially better than the final
        model: as many parameters or fewer and a chi-square lower by more than
        ``indistinguishable_chi2``, or more and a chi-square drop significant at ``p_value``; and
        removing enough of the gap (:func:`gap_removed_enough`, without the shrink alone). The
        named effects are then stand-ins for one that needs an unphysical value, and the input
        (mass, diameter, length scale, frame rate) is the first suspect."""
        th = self.thresholds
        final = self.judged_final
        sigma2 = final.noise_sigma(self.noise_floor) ** 2
        out = []
        for c, entry in self._unphysical():
            drop = (final.rss - c.fit.rss) / sigma2
            extra = c.fit.k - final.k
            # as for naming an effect: the gap it removes must be a share of the noise, not only many
            # samples' worth of a sliver of it (a noise-free simulation is fitted far below its noise)
            if self.noise_floor and not gap_removed_enough(final.judged_gap, c.fit.judged_gap, self.noise_floor, th,
                                                           shrink=False):
                continue
            # nor what a tracker's systematic error of the centres can fake (:class:`ReaderErrors`)
            if ReaderErrors.of(self.runs).fakes(final.judged_gap, c.fit.judged_gap):
                continue
            if (extra <= 0 and drop > th.indistinguishable_chi2) or (
                    extra > 0 and drop > 0 and chi2_sf(drop, extra) <= th.p_value):
                out.append(entry)
        return out

    def _unphysical(self):
        out, seen = [], set()
        for c in sorted(self.candidates, key=lambda c: c.fit.gap):
            if c.material or not c.outside or c.delta_bic < self.thresholds.delta_bic or not c.gap_ok:
                continue
            if len(c.members) > 1:
                continue
            if any(m in self.effects for m in c.members):
                continue
            for effect, param, value, limits in c.outside:
                if effect not in c.members or (effect, param) in seen:   # an effect named before, pushed out
                    continue
                seen.add((effect, param))
                out.append((c, {"effect": effect, "parameter": param, "value": value, "limits": list(limits),
                                "gap": c.fit.judged_gap,
                                "check": effect_check(effect, self.kind, self.ball, self.warnings)}))
        return out

    def gap_per_bounce(self):
        """RMS residual per flight (trajectory) or per datum (impacts, apexes): (before, after)."""
        return gap_per_bounce(self.baseline, self.final)

    def speed_range(self, fit=None):
        """(lowest, highest) impact speed [m/s] over every run's bounces in :attr:`recommended`, the model
        whose ε the report says to use and the JSON's top level holds (or in ``fit``, e.g. the final
        model alone as a rival): each model's drag slows the ball its own way, so the speeds of one
        model are quoted beside its own ε only. The final model's were quoted beside the split's
        before: a table-tennis ball's drop table said "0.869 at 4.08 m/s" (the split, C_d 0.61) and
        "impact speeds covered: 1.93 to 4.01 m/s" (drag alone, C_d 0.745) of the same highest drop."""
        speeds = _over_record_bounces(self.recommended if fit is None else fit, self.runs, "impact_speeds_m_per_s")
        return float(np.min(speeds)), float(np.max(speeds))

    @property
    def all_notes(self):
        """Every note, as the report prints them and the JSON holds them: the joint record's, each run's
        as read (of several files, a note that not every file has is led by its file's name; the pieces
        of one file around a bounce left out share its notes), then discover's."""
        import os

        runs = self.runs
        per_run = [list(getattr(run, "notes", ())) for run in runs]
        files = [os.path.basename(str(run.source)) for run in runs]
        common = set.intersection(*(set(n) for n in per_run)) if len(runs) > 1 else set()
        one_file = len(set(files)) == 1
        read = [n if one_file or n in common else f"{name}: {n}" for name, notes in zip(files, per_run) for n in notes]
        joint = list(getattr(self.data, "notes", ())) if len(runs) > 1 else []
        return list(dict.fromkeys(joint + read + list(self.notes)))

    @functools.cached_property
    def drag_or_speed_law_chi2(self):
        """How far apart air drag alone and a speed-dependent ε alone fit this record: the chi-square (at
        the record's noise, or at the final model's own misfit when larger) of the final model with one of
        them in place of the other, the larger less the smaller; None where the question does not arise: a
        trajectory (which resolves both), both named (each was material on top of the other), an untested
        record, or neither named nor both held as the systematic (:attr:`systematic`: apex heights)."""
        pair = DRAG_OR_SPEED_LAW
        if self.kind == "trajectory" or self.verdict == "untested":
            return None
        named = [e for e in pair if e in self.effects]
        if len(named) == 2:
            return None
        if not named:
            held = (self.systematic or {}).get("held", {})
            if not all(any(k.startswith(e + ".") for k in held) for e in pair):
                return None
        f = self.judged_final   # as the candidates are judged: weighted by the bounces' scatter when they scatter
        others = tuple(e for e in f.effects if e not in pair)
        start = {p.key: float(v) for p, v in zip(f.layout, f.values)}
        rss = [f.rss if e in named else fit_physical(f.problem, others + (e,), start).rss for e in pair]
        # at the final model's own misfit when it leaves more than the noise (five ping-pong records fitted
        # jointly, chi2 286 for 61 degrees of freedom: 17 apart at the noise floor, 3.6 at their misfit)
        return abs(rss[0] - rss[1]) / _at_misfit(self.reference_sigma ** 2, f)

    @property
    def speeds_too_narrow(self):
        """Whether these speeds cannot tell air drag from a speed-dependent ε: each alone fits the record
        within ``Thresholds.indistinguishable_chi2`` of the other (:attr:`drag_or_speed_law_chi2`), asked
        when one of them is named or, with neither named, when the systematic holds both (a drop table).
        One rule whatever the heights' spread: a table of 0.2-2.5 m may not tell them apart, one of
        1.0-1.2 m never does."""
        apart = self.drag_or_speed_law_chi2
        return apart is not None and apart <= self.thresholds.indistinguishable_chi2

    @functools.cached_property
    def pair_rival(self):
        """With one of air drag and a speed-dependent ε named (:data:`DRAG_OR_SPEED_LAW`), the other alone as
        the round that named it tried it: ``{"named", "rival", "parameters", "odds" (posterior odds for the
        named one), "decisive" (odds beyond the selection's ``decisive_two_ln_odds``)}``; else None."""
        named = [e for e in DRAG_OR_SPEED_LAW if e in self.effects]
        if len(named) != 1:
            return None
        win = named[0]
        rival = next(e for e in DRAG_OR_SPEED_LAW if e != win)
        for rnd in self.rounds:
            by_name = {c.name: c for c in rnd}
            won = [c for c in rnd if c.verdict.startswith("named") and win in c.members]
            if won and rival in by_name:
                two_ln = by_name[rival].score - won[0].score
                return {"named": win, "rival": rival, "parameters": by_name[rival].fit.effect_values.get(rival, {}),
                        "odds": math.exp(min(two_ln, 1400.0) / 2.0),
                        "decisive": two_ln >= self.thresholds.decisive_two_ln_odds}
        return None

    def epsilon_at(self, speeds_m_per_s, fit=None):
        """ε of the final model (or of ``fit``, e.g. ``split``) at these impact speeds [m/s] (the
        constant ε without a speed law)."""
        from vrcal.drop.effects import restitution_at_speed

        fit = self.final if fit is None else fit
        v = np.asarray(speeds_m_per_s, dtype=float)
        eps = fit.value("epsilon")
        if "velocity_dependent_restitution" not in fit.effects:
            return np.full(v.shape, eps)
        p = fit.effect_values["velocity_dependent_restitution"]["exponent"]
        return np.asarray(restitution_at_speed(eps, v, self.reference_speed, p))

    def epsilon_at_uncertainty(self, speeds_m_per_s):
        """The 1-sigma of :meth:`epsilon_at` at these impact speeds [m/s]: the fit's covariance of ε and a speed
        law's exponent carried through ε(v) = 1 - (1 - ε)(v / v_ref)^p (their correlation included), scaled as
        :attr:`epsilon_uncertainty` scales the fit's ± of ε (the bounces' spread of an unexplained trajectory,
        the bounces' scatter of impact times)."""
        f = self.final
        v = np.atleast_1d(np.asarray(speeds_m_per_s, dtype=float))
        keys = [p.key for p in f.layout]
        i = keys.index("epsilon")
        u_fit = f.uncertainty("epsilon")
        scale = self.epsilon_uncertainty / u_fit if u_fit > 0 else 1.0
        key = "velocity_dependent_restitution.exponent"
        jtj = f.extra.get("jtj")
        if key not in keys or jtj is None or not u_fit > 0:
            return np.full(v.shape, self.epsilon_uncertainty)
        j = keys.index(key)
        inv = np.linalg.pinv(np.asarray(jtj, dtype=float))
        s2 = u_fit**2 / inv[i, i] if inv[i, i] > 0 else 0.0
        cov = inv[np.ix_([i, j], [i, j])] * s2
        eps, p = f.value("epsilon"), f.value(key)
        x = v / self.reference_speed
        grad = np.stack([x**p, -(1.0 - eps) * x**p * np.log(x)])
        var = np.einsum("in,ij,jn->n", grad, cov, grad)
        return scale * np.sqrt(np.clip(var, 0.0, None))

    @property
    def reference_speed(self):
        """The impact speed [m/s] at which ``epsilon`` holds for a speed-dependent ε."""
        v_ref = self.final.problem.reference_speed_m_per_s
        if v_ref is not None:
            return float(v_ref)
        return float(np.asarray(self.final.model().impact_speeds_m_per_s)[0, 0])

    @property
    def recommended(self):
        """The fit whose ε the report says to use, and ``fit/export/simulate/pair --from`` take: the named
        effects and their ambiguous rivals shared by their priors (:attr:`split`) when the data cannot tell
        them apart, else the final model."""
        return self.final if self.split is None else self.split

    @property
    def recommended_epsilon_uncertainty(self):
        """The 1-sigma of :attr:`recommended`'s ε: its fit's own, widened as :attr:`epsilon_uncertainty`
        widens the final model's (the bounces' scatter, a misfit), and with :attr:`rivals_epsilon_spread`
        in quadrature: the split's own ± is the spread along its prior densities only, while the rivals
        alone, each about as probable, put ε elsewhere (drag alone planted on a basketball's drop table,
        ε 0.800: drag 0.7992, a speed law alone 0.7652, the split 0.7882 ± 0.0050)."""
        f = self.recommended
        if f is self.final:
            return self.epsilon_uncertainty
        u_fit = self.final.uncertainty("epsilon")
        scale = max(self.epsilon_uncertainty / u_fit, 1.0) if u_fit > 0 else 1.0
        return float(math.hypot(f.uncertainty("epsilon") * scale, self.rivals_epsilon_spread or 0.0))

    @property
    def rivals_epsilon_spread(self):
        """How far the explanations the data cannot tell apart put ε [1] from :attr:`recommended`'s (the
        prior split), or None without one: the RMS over the named model and each ambiguous rival alone of
        (ε_i - ε_split)² at the reference speed, weighted by their posterior probabilities (the named
        model 1, a rival 1 / :attr:`ambiguous_odds`)."""
        if self.split is None:
            return None
        odds = self.ambiguous_odds
        weights, values = [1.0], [self.final.value("epsilon")]
        for name, rivals in self._rival_fits.items():
            for rival, fit in rivals.items():
                weights.append(1.0 / max(odds[name][rival], 1e-300))
                values.append(fit.value("epsilon"))
        w = np.asarray(weights) / np.sum(weights)
        return float(np.sqrt(np.sum(w * (np.asarray(values) - self.split.value("epsilon")) ** 2)))

    @property
    def prior_split(self):
        """The named effects and their ambiguous rivals fitted together at the posterior mode with the
        registry's prior densities (:func:`split_by_priors`), or None when nothing is ambiguous:
        ``{"effects", "parameters", "uncertainties", "epsilon" (at the reference speed),
        "epsilon_range" ([lowest, highest] over the record's bounces), "gap", "prior_chi2"}``.
        The data fix what the rivals do together, the priors how it is shared: the most probable ε
        while the data cannot tell them apart."""
        f = self.split
        if f is None:
            return None
        return {"effects": list(f.effects), "parameters": f.effect_values, "uncertainties": f.effect_uncertainties,
                "epsilon": f.value("epsilon"), "epsilon_range": _epsilon_range(f, self.runs),
                "gap": f.gap, "prior_chi2": float(f.extra.get("prior_chi2", 0.0))}

    def _rivals(self):
        """``{named effect: (winner, {rival: Candidate})}`` of the ambiguous namings, from the round
        that named the effect."""
        out = {}
        for name, rivals in self.ambiguous.items():
            for rnd in self.rounds:
                win = [c for c in rnd if c.verdict.startswith("named") and name in c.members]
                if win:
                    by_name = {c.name: c for c in rnd}
                    out[name] = (win[0], {r: by_name[r] for r in rivals if r in by_name})
                    break
        return out

    @property
    def ambiguous_odds(self):
        """``{named effect: {rival: posterior odds for the named one}}`` of the ambiguous namings:
        exp of half the difference of the candidates' -2 ln evidence in the round that named it."""
        return {name: {r: math.exp(min(c.score - win.score, 1400.0) / 2.0) for r, c in rivals.items()}
                for name, (win, rivals) in self._rivals().items()}

    @functools.cached_property
    def ambiguous_epsilon(self):
        """``{named effect: {rival: {"epsilon": [lowest, highest], "parameters": {...}}}}``: the
        contact's epsilon over the record's bounces had the rival been named instead (one value
        twice for a constant epsilon), and the rival's parameters: what the ambiguity means for the
        number an engine needs; ``"at_limit"``: the rival's parameters held at a hard physical limit (a speed
        law's exponent at 1, where the record would have it beyond)."""
        from vrcal.drop.effects import EFFECTS

        def entry(rival, fit):
            values = dict(fit.effect_values.get(rival, {}))
            at = [p.name for p in EFFECTS[rival].parameters
                  if any(abs(values[p.name] - b) <= 1e-9 * max(1.0, abs(b)) for b in p.physical_limits(self.ball))
                  and fit.outside_limits(rival) == [] and _at_limit_fit(fit, rival, p.name)]
            return {"epsilon": _epsilon_range(fit, self.runs), "parameters": values, "at_limit": at}

        return {name: {r: entry(r, fit) for r, fit in rivals.items()} for name, rivals in self._rival_fits.items()}

    @functools.cached_property
    def _rival_fits(self):
        """``{named effect: {rival: its fit as the final model is fitted}}`` of the ambiguous namings."""
        return {name: {r: self._as_final(c.fit) for r, c in rivals.items()}
                for name, (_, rivals) in self._rivals().items()}

    def _as_final(self, fit):
        """A candidate's fit as the final model is fitted: by least squares when the candidates were
        judged by generalized least squares (:attr:`judged`), else the fit itself."""
        if self.judged is None:
            return fit
        return res.fit_model(self.final.problem, fit.effects, start=_start_from(fit))

    def as_dict(self):
        """JSON-ready summary: the stable keys of earlier versions, the verdict, the runs and the reader.

        ``epsilon`` and what sits beside it (``epsilon_uncertainty``, ``effects``, ``parameters``,
        ``uncertainties``) are :attr:`recommended`'s, the value to use; ``named`` holds the named model's own."""
        before, after = self.gap_per_bounce()
        runs = self.runs
        data = self.data
        lo, hi = self.speed_range()
        return {
            "schema_version": DISCOVER_SCHEMA_VERSION,
            "verdict": self.verdict,
            "verdict_reason": verdict_reason(self),
            "warnings": list(self.warnings),
            "effects": [e for e in self.recommended.effects if e not in self.nuisance],
            "ambiguous": {k: list(v) for k, v in self.ambiguous.items()},
            "ambiguous_odds": self.ambiguous_odds,
            "ambiguous_epsilon": self.ambiguous_epsilon,
            "prior_split": self.prior_split,
            "unphysical": self.unphysical,
            "at_limit": self.at_limit,
            "unusual": self.unusual,
            "cut_by_max_effects": list(self.cut),
            "recommended": "named" if self.split is None else "prior_split",
            "named": {"effects": list(self.effects), "epsilon": self.epsilon,
                      "epsilon_uncertainty": self.epsilon_uncertainty,
                      "parameters": {k: v for k, v in self.final.effect_values.items() if k not in self.nuisance},
                      "uncertainties": {k: v for k, v in self.final.effect_uncertainties.items()
                                        if k not in self.nuisance}},
            "parameters": {k: v for k, v in self.recommended.effect_values.items() if k not in self.nuisance},
            "uncertainties": {k: v for k, v in self.recommended.effect_uncertainties.items()
                              if k not in self.nuisance},
            "floor_level_m": self.floor_level,
            "gap_before": self.gap_before,
            "gap_after": self.gap_after,
            "gap_unit": self.unit,
            "gap_per_bounce": {"before": [float(v) for v in before], "after": [float(v) for v in after]},
            "epsilon": self.recommended.value("epsilon"),
            "epsilon_uncertainty": self.recommended_epsilon_uncertainty,
            "epsilon_uncertainty_basis": self.epsilon_uncertainty_basis,
            "epsilon_uncertainty_rivals": self.rivals_epsilon_spread,
            "height_dependent_noise": self.height_dependent_noise,
            "epsilon_uncertainty_fit": self.final.uncertainty("epsilon"),
            "epsilon_uncertainty_independent_errors": self.fit_epsilon_uncertainty,
            "bounce_epsilons": self.bounce_epsilons,
            "lack_of_fit": self.lack_of_fit,
            "epsilon_baseline": self.epsilon_baseline,
            "epsilon_effective_without_drag": self.effective_without_drag["epsilon"],
            "effective_without_drag": self.effective_without_drag,
            "epsilon_systematic": self.systematic,
            "epsilon_with_sphere_drag": self.epsilon_with_sphere_drag,
            "epsilon_reference_speed_m_per_s": self.reference_speed,
            "impact_speed_range_m_per_s": [lo, hi],
            "speeds_too_narrow": self.speeds_too_narrow,
            "drag_or_speed_law_chi2": self.drag_or_speed_law_chi2,
            "baseline": self.baseline.baseline_values,
            "model": self.final.baseline_values,
            "runs": [{"source": str(run.source), "label": label, "kind": run.kind,
                      "n": int(res.observed_values(run).size),
                      "release": {k: v for k, v in self.final.run_values(r).items() if k != "epsilon"}}
                     for r, (run, label) in enumerate(zip(runs, self.labels or [""] * len(runs)))],
            "noise_floor": self.noise_floor,
            "noise_source": self.noise_source,
            "scatter": self.scatter,
            "scatter_gap": self.scatter_gap,
            "scatter_upper_limit": self.scatter_limit,
            "statistic": "-2 ln evidence (Laplace, registry priors)",
            "judged_by": ("generalized least squares (the bounces' scatter)" if self.judged is not None
                          else "least squares"),
            "candidates": [
                {"name": c.name, "round": c.round, "gap": c.gap, "judged_gap": c.fit.judged_gap,
                 "chi2": c.fit.rss / self.reference_sigma ** 2,
                 "score": c.score, "bic": c.fit.bic,
                 "delta_bic": c.delta_bic, "two_ln_bayes_factor": c.two_ln_bayes,
                 "p_value": c.p_value, "in_prior": c.in_prior, "physical": c.physical, "material": c.material,
                 "held_at_limit": c.free is not None,
                 "verdict": c.verdict,
                 "parameters": ({m: c.fit.effect_values.get(m, {}) for m in c.members} if len(c.members) > 1
                                else c.fit.effect_values.get(c.name, {}))}
                for c in self.candidates
            ],
            "data": {"kind": self.kind, "source": str(data.source), "n": int(self.baseline.n), "runs": len(runs),
                     "decimation": int(self.decimation), "n_read": int(self.n_read or self.baseline.n)},
            "reader": dict(self.reader),
            "ball": {"name": str(getattr(self.ball, "name", "ball")), "mass_kg": float(self.ball.mass_kg),
                     "diameter_m": float(self.ball.diameter_m),
                     **({"surface": "soft"} if getattr(self.ball, "surface", "rigid") == "soft" else {})},
            "g_m_per_s2": self.g_m_per_s2,
            "g_nominal_m_per_s2": self.g_nominal_m_per_s2,
            "notes": self.all_notes,
        }


#: ``schema_version`` of discover's JSON: 2 from when the top-level ``epsilon``, ``epsilon_uncertainty``,
#: ``effects``, ``parameters`` and ``uncertainties`` are the recommended model's (the prior split of rivals the
#: data cannot tell apart, as the report advises), the named model's under ``named``; 1 had the named model's.
DISCOVER_SCHEMA_VERSION = 2


#: A trajectory holds a bounce of its model when the impact falls within the record, the flight into it rises
#: at least this many noise sigmas above the floor, and the record shows it (:func:`_record_bounces`).
SEEN_BOUNCE_SIGMAS = 5.0


def _record_bounces(run, drops, sigma=None):
    """How many of the model's bounces (``drops``, a simulation of ``run``) the record holds: one per
    impact time, up to the last apex's bounce, or, of a trajectory, those up to its last sample whose flight
    in rises :data:`SEEN_BOUNCE_SIGMAS` noise sigmas (``sigma`` [m]) above the floor, and at most one more
    than the bounces seen in it (:func:`vrcal.discovery.residuals.impacts_in_trajectory`; the one more ends
    the last flight seen). The model simulates bounces on beyond: a marble on paper, tracked to 0.03 mm,
    had its model's 0.03-0.07 m/s bounces in the ball's jitter at rest quoted among the speeds covered, and a
    record that ends in the second fall a second impact at 0.79 m/s."""
    if run.kind == "impacts":
        return len(run.t_s)
    if run.kind == "apexes":
        return int(np.max(run.bounce))
    t = np.asarray(run.t_s, dtype=float)
    shown = res.impacts_in_trajectory(t, run.y_m, int(getattr(run, "release_index", 0) or 0)).size + 1
    seen = (np.asarray(drops.impact_times_s, dtype=float)[0] <= t[-1]) & (
        np.asarray(drops.apex_heights_m, dtype=float)[0][:drops.n_bounces] >= SEEN_BOUNCE_SIGMAS * float(sigma or 0.0))
    return int(min(np.cumprod(seen).sum(), shown))


def _over_record_bounces(fit, runs, quantity):
    """``quantity`` (an attribute of :class:`vrcal.drop.simulate.Drops` per bounce, e.g.
    ``"epsilons"``) of ``fit``'s model at every bounce the record holds (:func:`_record_bounces`), every
    run's (the rows of a drop table, the files of a joint fit), as one array (a run without one: its first
    bounce)."""
    out = []
    for r, run in enumerate(runs):
        drops = fit.model(run=r)
        held = _record_bounces(run, drops, fit.problem.noise)
        out.append(np.asarray(getattr(drops, quantity), dtype=float)[0][:max(held, 1)])
    return np.concatenate(out)


def _at_limit_fit(fit, effect, name):
    """Whether ``fit`` holds ``effect``'s parameter ``name`` at a physical limit because its unconstrained
    optimum lies beyond it (:func:`fit_physical`'s ``extra["beyond"]``)."""
    return any(e == effect and p == name for e, p, *_ in fit.extra.get("beyond", ()))


def _epsilon_range(fit, runs):
    """[lowest, highest] ε of ``fit``'s model over the bounces the record holds, every run's."""
    eps = _over_record_bounces(fit, runs, "epsilons")
    return [float(np.min(eps)), float(np.max(eps))]


def verdict(d):
    """The one verdict of a discovery (every section of the report follows it):

    * "suspect input": the plausibility checks found something that looks wrong (``d.warnings``), or
      the gap is near the noise but a candidate beyond its physical limits fits far better than
      the named effects (:attr:`Discovery.unphysical_better`: a wrong mass makes drag need C_d 1.8,
      and a speed law stands in for it);
    * "explained": the final model's gap is at most :data:`EXPLAINED_FACTOR` times the noise floor
      (or the gap that the record's own bounce-to-bounce scatter leaves, when larger), and no
      unphysical candidate fits far better;
    * "untested": as many parameters as data (a drop and one rebound): the model is fixed by the
      data, no residual is left to judge it or an effect by;
    * "unexplained": otherwise -- structure that no named effect removes.
    """
    if d.warnings:
        return "suspect input"
    if not d.rounds and d.final.n <= d.final.k:
        return "untested"
    if d.within_noise:
        # near the noise, yet a candidate beyond its physical limits fits far better: the named effects
        # stand in for it, and the input (mass, diameter, scale, frame rate) is the first suspect
        return "suspect input" if d.unphysical_better else "explained"
    return "unexplained"


def verdict_reason(d):
    """One sentence: why the verdict is what it is."""
    v = verdict(d)
    if v == "suspect input":
        return "; ".join(list(d.warnings) + [_stand_in_reason(d, u) for u in d.unphysical_better])
    if v == "untested":
        return (f"{d.final.n} data and {d.final.k} parameters: the model goes through every datum, which "
                "tests neither it nor any effect")
    ref = d.reference_gap
    ratio = d.gap_after / ref if ref else math.inf
    what = "the noise floor"
    if (d.scatter_gap or 0) > (d.noise_floor or 0):
        what = "the gap a typical bounce-to-bounce scatter leaves" if d.scatter_assumed else \
            "the bounce-to-bounce scatter's gap"
    reason = f"the final gap is {ratio:.1f} times {what} (explained up to {EXPLAINED_FACTOR:g} times)"
    lof = d.lack_of_fit
    if v == "unexplained" and ratio <= EXPLAINED_FACTOR and lof is not None:
        g = max(lof["groups"], key=lambda r: abs(r["mean_residual_m"]) / r["standard_error_m"])
        side = "above" if g["mean_residual_m"] > 0 else "below"
        reason += (f", but the repeated trials agree with each other better than with the model: the rebounds of "
                   f"bounce {g['bounce']} from {number(g['drop_height_m'], 4)} m lie "
                   f"{abs(g['mean_residual_m']) * 1e3:.3g} ± {g['standard_error_m'] * 1e3:.1f} mm {side} it over "
                   f"{g['trials']} trials (lack-of-fit F = {lof['F']:.3g}, p = {lof['p']:.1g})")
    return reason


def _stand_in_reason(d, u):
    """Why a better-fitting unphysical candidate makes the input suspect, in one clause."""
    from vrcal.drop.effects import EFFECTS

    (p,) = [p for p in EFFECTS[u["effect"]].parameters if p.name == u["parameter"]]
    named = " and ".join(d.effects) if d.effects else "the constant-epsilon model"
    return (f"{u['effect']} fits far better than {named} (gap {u['gap'] * 1e3:.3g} against "
            f"{d.judged_final.judged_gap * 1e3:.3g} {'mm' if d.unit == 'm' else 'ms'}) but only with {u['parameter']} "
            f"{u['value']:.3g} (physical: {u['limits'][0]:.3g} to {u['limits'][1]:.3g}): {u['check']}")


def gap_per_bounce(before, after):
    """RMS residuals grouped by bounce, for two fits of the same data.

    trajectory: samples grouped by the flight they belong to in ``after``'s model
    (0 = still segment and first fall, j = after the j-th impact), run after run; impacts and
    apexes: the absolute residual of each datum. Returns (before, after) arrays.
    """
    runs = after.problem.runs
    if runs[0].kind != "trajectory":
        return np.abs(before.residuals), np.abs(after.residuals)
    out_b, out_a = [], []
    for r, (run, sl) in enumerate(zip(runs, after.run_slices())):
        t = np.asarray(run.t_s, dtype=float)
        impacts = after.model(run=r).impact_times_s[0]
        seg = np.searchsorted(impacts, t, side="right")
        rb, ra = before.residuals[sl], after.residuals[sl]
        for j in range(int(seg.max()) + 1):
            m = seg == j
            if np.any(m):
                out_b.append(float(res.rms(rb[m])))
                out_a.append(float(res.rms(ra[m])))
    return np.asarray(out_b), np.asarray(out_a)


def _start_from(fit):
    return {p.key: float(v) for p, v in zip(fit.layout, fit.values)}


def _start_without(fit, effects):
    """:func:`_start_from` ``fit`` without the parameters of ``effects``."""
    return {k: v for k, v in _start_from(fit).items() if k.split(".")[0] not in effects}


def _mark_dropped(rounds, dropped, verdict):
    """Give ``verdict`` to the named candidates of ``rounds`` with a member in ``dropped``."""
    for c in (c for r in rounds for c in r):
        if c.verdict.startswith("named") and set(c.members) & set(dropped):
            c.verdict = verdict


def split_by_priors(problem, current, named, ambiguous, sigma):
    """The named effects and every ambiguous rival fitted together at the posterior mode
    (:func:`vrcal.discovery.residuals.fit_model` with ``prior_sigma``), or None when no rival is
    ambiguous or the data are too few.

    Rivals are ambiguous when each alone fits about as well as the named effect: the data fix what
    they do together (a line of equally good fits, e.g. air drag C_d against a speed exponent p), not
    how it is shared. The registry's prior densities -- a sphere's C_d near 0.47, p near 1/5 -- pick
    the most probable point on that line: what a physicist would report, who knows that a ball in
    air has drag, instead of either end. ``sigma``: the noise of one datum (the noise floor, or what
    the named model leaves when that is more). None too when the mode lies beyond a physical limit.
    """
    rivals = list(dict.fromkeys(r for names in ambiguous.values() for r in names if r not in named))
    if not rivals:
        return None
    from vrcal.drop.effects import EFFECTS

    effects = (*named, *rivals)
    if current.n - current.k - sum(len(EFFECTS[r].parameters) for r in rivals) < 1:
        return None
    fit = res.fit_model(problem, effects, start=_start_from(current), prior_sigma=sigma)
    return None if any(fit.outside_limits(e) for e in effects) else fit


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
                lo, hi = p.fit_bounds(problem.ball)
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
    sigma = min(cands, key=lambda c: c.fit.residual_variance).fit.noise_sigma(sigma_floor)
    ref = res.minus_two_ln_evidence(current, sigma)
    for c in cands:
        c.evidence = res.minus_two_ln_evidence(c.fit, sigma)
        c.two_ln_bayes = ref - c.evidence
    return sigma


def _outside(fit, effects, fading=True):
    """[(effect, parameter, value, (lo, hi))] of the parameters of ``effects`` in ``fit`` beyond their hard
    physical limits; ``fading=False`` leaves out those beyond on the side of the value at which the effect
    vanishes (C_d below 0.2 towards 0: the effect fading, which the backward step judges)."""
    from vrcal.drop.effects import EFFECTS

    out = [(e, *o) for e in effects for o in fit.outside_limits(e)]
    if not fading:
        def fades(e, name, value, lo, hi):
            null = EFFECTS[e].null_values.get(name)
            return null is not None and ((value < lo and null <= lo) or (value > hi and null >= hi))
        out = [o for o in out if not fades(o[0], o[1], o[2], *o[3])]
    return out


def fit_physical(problem, effects, start=None, *, limited=None, free=None):
    """The baseline plus ``effects`` fitted with every effect of ``limited`` (default: all of ``effects``)
    inside its hard physical limits (:meth:`vrcal.drop.effects.Parameter.physical_limits`).

    The unconstrained fit (``free``, or fitted here from ``start``) when it lies inside them; else the fit
    bounded by them (:func:`vrcal.discovery.residuals.fit_model` with ``within``), the better of two starts
    (the unconstrained optimum brought inside, and ``start``), whose ``extra`` holds ``"beyond"``, the
    unconstrained values beyond the limits [(effect, parameter, value, (lo, hi))], and ``"free"``, that fit.
    A model's every refit goes through here, so that a named effect never leaves its limits (a speed law
    named with p 0.3 went to 1.06 once a height offset was added beside it).
    """
    effects = tuple(effects)
    limited = effects if limited is None else tuple(limited)
    fit = free if free is not None else res.fit_model(problem, effects, start=start)
    beyond = _outside(fit, limited)
    if not beyond:
        return fit
    bounded = res.fit_model(problem, effects, start=_start_from(fit), within=limited)
    if start is not None:
        other = res.fit_model(problem, effects, start=start, within=limited)
        if other.rss < bounded.rss:
            bounded = other
    bounded.extra.update(beyond=beyond, free=fit)
    return bounded


def _limits_distance(cand):
    """How far the physical limits lie from the unconstrained optimum of ``cand``: the sum of the squared
    distances of its parameters beyond them, each in its standard uncertainty (the quadratic estimate of
    the chi-square that holding them costs)."""
    sds = cand.fit.effect_uncertainties
    z2 = 0.0
    for effect, param, value, (lo, hi) in cand.outside:
        sd = sds[effect][param]
        z2 += ((value - min(max(value, lo), hi)) / sd) ** 2 if sd > 0 else math.inf
    return z2


def _try(problem, named, names, current, sigma_floor, th, rnd, reader=None, nuisance=()):
    """Fit and judge the current model plus ``names`` (one effect, or a pair): a :class:`Candidate`.

    When the unconstrained optimum puts a parameter (its own, or one of an effect named before) beyond its
    physical limits, the model is fitted again inside them (:func:`fit_physical`) and that fit is judged:
    the candidate is material, at its limit, when the bounded fit passes every test and the data cannot
    reject the limit (its chi-square at the noise floor at most ``Thresholds.indistinguishable_chi2`` above
    the unconstrained one's: the limit lies within 3 sigma of the optimum); ``Candidate.free`` then keeps the
    unconstrained fit. Otherwise the unconstrained candidate is returned, not material, with what the limits cost.
    """
    checked = [n for n in named if n not in nuisance]
    fit = _fit_candidate(problem, named, names, current)
    cand = _judge(Candidate("+".join(names), rnd, fit, 0.0, 0.0, 1.0, False, False, members=tuple(names)),
                  current, sigma_floor, th, reader, checked)
    if cand.in_prior or cand.delta_bic < th.delta_bic or cand.p_value > th.p_value or not cand.gap_ok:
        return cand   # inside them, or failing another test: held inside them it can only fit worse
    z2 = _limits_distance(cand)
    if z2 > 4.0 * th.indistinguishable_chi2:   # far beyond reach: not worth a fit
        cand.verdict += f"; the limits lie {math.sqrt(z2):.3g} standard uncertainties away: the data reject them"
        return cand
    bounded = fit_physical(problem, (*named, *names), start=_start_from(current), limited=(*checked, *names),
                           free=fit)
    held = _judge(Candidate(cand.name, rnd, bounded, 0.0, 0.0, 1.0, False, False, members=cand.members, free=fit),
                  current, sigma_floor, th, reader, checked)
    # at the noise floor, not at what a misfit leaves: a model that misses the record by 8 times its noise
    # cannot reject a limit at its own residuals (a tennis record's contact of 14.3 ms held at 13.4 ms,
    # "chi2 +0.2", stood in for what it misses)
    cost = (bounded.rss - fit.rss) / (sigma_floor or fit.noise_sigma(None)) ** 2
    if held.material and cost <= th.indistinguishable_chi2:
        held.verdict = "material at its physical limit"
        return held
    cand.verdict += (f"; inside them chi2 +{cost:.3g}: the data reject the limits" if cost > th.indistinguishable_chi2
                     else f"; inside them {held.verdict.replace('not material: ', '')}")
    return cand


def _every_flight(name):
    from vrcal.drop.effects import EFFECTS

    return bool(EFFECTS[name].every_flight)


def later_flights_gain(cand, current, var):
    """How much the flights after the first fall of a trajectory need a candidate whose effect is alike in every
    flight (``Effect.every_flight``: a camera's rolling shutter): the chi-square drop, ``(RSS_current -
    RSS_candidate) / var`` over the samples after each run's first impact (of ``current``'s model), or None
    (no such effect among the candidate's, or no trajectory).

    A camera distorts every frame alike, so a shutter the later flights do not want (a first fall slowed by a
    pull that none of the later flights has: a held release, a hand) stands in for something else: fitted to
    such a track it took 1.23 -> 0.34 mm from the first fall and made the later flights worse.

    Parameters
    ----------
    cand : Candidate
    current : vrcal.discovery.residuals.FitResult
        the model before
    var : float
        the noise variance the chi-square is taken at [m^2]
    """
    runs = current.problem.runs
    if runs[0].kind != "trajectory" or not any(_every_flight(m) for m in cand.members):
        return None
    later = np.zeros(current.residuals.size, dtype=bool)
    for r, (run, part) in enumerate(zip(runs, current.run_slices())):
        first = float(current.model(run=r).impact_times_s[0, 0])
        later[part] = np.asarray(run.t_s, dtype=float) > first
    a, b = np.asarray(current.residuals)[later], np.asarray(cand.fit.residuals)[later]
    return float(a @ a - b @ b) / var


def gap_removed_enough(gap_before, gap_after, sigma, th, shrink=True):
    """Whether a fit that takes the gap (RMS residual [data unit]) from ``gap_before`` to ``gap_after``
    removes enough of it to count (``Thresholds.gap_factor``, ``Thresholds.removed_noise_fraction``).

    The gap removed, sqrt(gap_before² - gap_after²), must be at least ``removed_noise_fraction`` of the
    noise sigma AND, of the misfit the model before leaves beyond the noise, m² = gap_before² - sigma²,
    the share a shrink by ``gap_factor`` takes: removed² >= (0.2 sigma)² + (1 - 0.9²) m². Or (``shrink``)
    the gap shrinks by ``gap_factor`` (a fit far below its noise: a noise-free simulation).

    Near the noise (m ~ 0) that is the fifth of a sigma that, on n independent residuals, is a chi-square
    drop of 0.04 n. A model that still misfits leaves residuals that are structure, not independent noise:
    any added parameter follows a little of it, and the chi-square and F tests (which take the n residuals
    as independent) pass it on thousands of samples. There the effect must remove a share of the misfit
    itself: a speed law planted as a line, fitted as a power law, left 5.2 mm at 1.0 mm noise on a
    960-sample trajectory, and drag took it to 5.0 mm (1.2 mm removed, p 1e-13, dBIC 49): named with C_d
    0.35 on a record without drag. Now it needs 2.2 mm.

    Parameters
    ----------
    gap_before, gap_after : float
        the gaps of the model before and of the candidate [data unit]
    sigma : float or None
        noise of one datum [data unit] (None: only the shrink counts)
    th : Thresholds
    shrink : bool
        whether a shrink by ``gap_factor`` alone suffices

    Returns
    -------
    bool
    """
    if shrink and gap_after <= th.gap_factor * gap_before:
        return True
    if not sigma:
        return False
    removed2 = max(gap_before**2 - gap_after**2, 0.0)
    misfit2 = max(gap_before**2 - sigma**2, 0.0)
    return removed2 >= (th.removed_noise_fraction * sigma) ** 2 + (1.0 - th.gap_factor**2) * misfit2


def changes_heights_by(gap_before, gap_after):
    """The RMS change of the fitted heights [data unit] that takes the gap (RMS residual) from ``gap_before``
    to ``gap_after``: sqrt(gap_before² - gap_after²) (for nested least-squares fits the drop of the residual
    sum of squares is the sum of squares of the change of the fitted curve)."""
    return math.sqrt(max(gap_before**2 - gap_after**2, 0.0))


@dataclass(frozen=True)
class ReaderErrors:
    """What a reader knows of its own errors beyond the noise from datum to datum (a video tracker's,
    :class:`vrcal.measurements.types.Trajectory`): the floor level's standard uncertainty ``floor_sd_m`` [m]
    and the centres' systematic error ``systematic_m`` [m]. An error that is the same, or changes slowly, from
    frame to frame (a blurred ball's centre pulled a little along its motion) is not averaged away by many
    frames: an effect that changes the heights by less (RMS) than it may be that error, and is not named
    (:func:`_judge`). A rolling shutter of 0.34 ms/m (0.11 mm RMS) stood in for a blurred ball's centre
    errors of a clean render whose tracker was uncertain by 0.13 mm; a real 20 ms readout changes the
    heights by millimetres."""

    floor_sd_m: float = 0.0
    systematic_m: float = 0.0

    @classmethod
    def of(cls, data):
        """The largest of each over the runs of ``data`` (a run, Runs, or a sequence of runs; 0 for a reader
        that gives none)."""
        runs = tuple(data) if isinstance(data, (list, tuple)) else res._runs_of(data)
        return cls(max(float(getattr(r, "floor_sd_m", 0.0) or 0.0) for r in runs),
                   max(float(getattr(r, "systematic_m", 0.0) or 0.0) for r in runs))

    def fakes(self, gap_before, gap_after):
        """Why a model that takes the gap (RMS residual) from ``gap_before`` to ``gap_after`` may be the
        centres' systematic error rather than an effect (its change of the heights, :func:`changes_heights_by`,
        is smaller), else ''."""
        change = changes_heights_by(gap_before, gap_after)
        if self.systematic_m > 0 and change < self.systematic_m:
            return (f"it changes the heights by {change * 1e3:.2g} mm RMS, within the tracker's systematic error of "
                    f"the centres ({self.systematic_m * 1e3:.2g} mm)")
        return ""


#: A fitted height offset is named only beyond this many standard uncertainties of the floor level
#: when the reader estimated the floor (a video's contact row; ``Trajectory.floor_sd_m``): a smaller
#: offset is the floor's own uncertainty, not a tracked point off the ball's bottom.
FLOOR_SIGMAS = 3.0


def _judge(cand, current, sigma_floor, th, reader=None, checked=()):
    """Judge a candidate against ``current`` (the tests of the module docstring); ``checked``: the effects
    named before, whose parameters must stay inside their physical limits too when the candidate is added
    (a refit can push them out: drag named with C_d 0.46 went to 1.36 once buoyancy was added)."""
    fit = cand.fit
    n, k0, k1 = fit.n, current.k, fit.k
    dk = max(k1 - k0, 1)
    dof = max(n - k1, 1)
    var = fit.rss / dof
    # the noise counts as known when the candidate's residuals are consistent with the floor
    # (chi-square goodness of fit, p >= 1e-3); else the residual variance is used
    known = bool(sigma_floor) and (sigma_floor**2 >= var or chi2_sf(fit.rss / sigma_floor**2, dof) >= 1e-3)
    if known:
        var = sigma_floor**2
    var = max(var, 1e-300)
    drop = max(current.rss - fit.rss, 0.0)
    cand.delta_chi2 = drop / var
    # noise known (the residuals do not exceed the floor): chi-square test of the RSS drop;
    # otherwise the F test of nested models with the residual variance
    cand.p_value = chi2_sf(cand.delta_chi2, dk) if known else f_sf(cand.delta_chi2 / dk, dk, dof)
    cand.delta_bic = current.bic - fit.bic
    # an effect named before that the candidate makes fade (drag to C_d 0 once a speed law explains the
    # record) is left to the backward step, which drops it; one pushed the other way is beyond its limits
    cand.outside = _outside(fit, cand.members) + _outside(fit, [n for n in checked if n not in cand.members],
                                                          fading=False)
    cand.in_prior = not cand.outside
    cand.gap_ok = gap_removed_enough(current.judged_gap, fit.judged_gap, sigma_floor, th)
    reasons = []
    if cand.delta_bic < th.delta_bic:
        reasons.append(f"dBIC {cand.delta_bic:.1f} < {th.delta_bic:g}")
    if cand.p_value > th.p_value:
        reasons.append(f"p {cand.p_value:.2g} > {th.p_value:g}")
    for effect, param, value, (lo, hi) in cand.outside:
        whose = "" if effect in cand.members else f" ({effect}, named before)"
        reasons.append(f"{param}{whose} {value:.3g} outside its physical limits {lo:.3g}-{hi:.3g}")
    if not cand.gap_ok:
        reasons.append("gap barely shrinks")
    gain = later_flights_gain(cand, current, var)
    if gain is not None and gain < th.indistinguishable_chi2:
        reasons.append(f"the flights after the first fall do not need it (chi2 {-gain:+.3g} there; "
                       f"{' and '.join(m for m in cand.members if _every_flight(m))} shows in every flight)")
    offset = fit.effect_values.get("height_offset", {}).get("offset_m")
    reader = reader or ReaderErrors()
    floor_sd_m = reader.floor_sd_m
    if offset is not None and floor_sd_m > 0 and abs(offset) <= FLOOR_SIGMAS * floor_sd_m:
        reasons.append(f"offset {offset * 1e3:+.2g} mm within the floor level's uncertainty "
                       f"({FLOOR_SIGMAS:g} x {floor_sd_m * 1e3:.2g} mm)")
    faked = reader.fakes(current.judged_gap, fit.judged_gap)
    if faked:
        reasons.append(faked)
    cand.material = not reasons
    cand.verdict = "material" if cand.material else "not material: " + "; ".join(reasons)
    return cand


def _select(problem, baseline, pool, nuisance, th, sigma_floor, reader, max_effects, progress):
    """Forward selection with a backward check from ``baseline``: (final fit, named effects (the
    nuisances first), rounds of candidates, ambiguous namings, notes)."""
    from vrcal.drop.effects import EFFECTS

    kind = problem.runs[0].kind
    spread = res.drop_height_spread(problem)
    current, named, rounds, ambiguous, notes, cut = baseline, list(nuisance), [], {}, [], []
    pool = list(pool)
    while pool:
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
            cands.append(_try(problem, named, (name,), current, sigma_floor, th, rnd, reader, nuisance))
        material = [c for c in cands if c.material]
        if not material and (max_effects is None or len(named) - len(nuisance) + 2 <= max_effects):
            cands += _pairs(problem, named, pool, cands, current, sigma_floor, th, rnd, progress, reader, nuisance)
            material = [c for c in cands if c.material]
        rank_by_evidence(cands, current, sigma_floor)
        cands.sort(key=lambda c: c.score)
        material.sort(key=lambda c: c.score)
        rounds.append(cands)
        if not material:
            break
        win = material[0]
        if max_effects is not None and len(named) - len(nuisance) + len(win.members) > max_effects:
            # the cap stops the rounds, never silently: what it leaves out is material, said so and kept -- the
            # winner, and each other material candidate that stays material on top of it (one that only stands
            # in for the winner, a rolling shutter's timing for missing drag, is not what the values lack)
            stays = [win] + [c for c in material[1:] if not set(c.members) <= set(win.members) and _try(
                problem, [*named, *win.members], tuple(m for m in c.members if m not in win.members), win.fit,
                sigma_floor, th, rnd, reader, nuisance).material]
            cut = list(dict.fromkeys(m for c in stays for m in c.members))
            for c in material:
                c.verdict = f"material, not named: at most {max_effects} effects are named (max_effects)" + (
                    "" if any(c is k for k in stays) else f"; not material once {win.name} is in")
            notes.append(f"round {rnd}: {', '.join(cut)} material but not named: at most {max_effects} effect(s) "
                         f"are named (max_effects = {max_effects}); the values found lack "
                         f"{'it' if len(cut) == 1 else 'them'}")
            break
        # drops from several heights (a drop table, several files) separate what one drop cannot
        groups = [g for g in CONFUSABLE[kind] if set(win.members) & g] if spread < SPREAD_SEPARATES else []
        # the noise a rival is judged against: the floor, or what the winner leaves when that is more (a
        # record's own scatter from bounce to bounce)
        var = win.fit.noise_sigma(sigma_floor) ** 2
        rivals = [c for c in material[1:] if len(c.members) == 1 and c.name not in win.members and (
            c.score - win.score < th.indistinguishable_bic
            or (any(c.name in g for g in groups) and (c.fit.rss - win.fit.rss) / var < th.indistinguishable_chi2
                and c.score - win.score < th.decisive_two_ln_odds))]
        close = [c.name for c in rivals]
        if close:
            ambiguous[win.name] = close
            odds = ", ".join(f"{c.name} {_odds(c.score - win.score)}" for c in rivals)
            notes.append(f"round {rnd}: {win.name} is named (highest evidence) but {', '.join(close)} also "
                         f"explain(s) the {kind} data (posterior odds for {win.name} with the registry's priors: "
                         f"{odds}); {kind} data cannot reliably tell them apart"
                         + ("" if kind == "trajectory" else " (a trajectory can)"))
        win.verdict = "named" + (f" (ambiguous with {', '.join(close)})" if close else "")
        named.extend(win.members)
        current = win.fit
        pool = [n for n in pool if n not in win.members]
        before = list(named)
        named, current = _backward(problem, named, win.members, current, th, rnd, notes, keep=nuisance)
        kept = [n for n in named if n not in nuisance]
        # one the backward step kept though it faded: held inside its limits (unchanged when inside them)
        current = fit_physical(problem, named, start=_start_from(current), limited=kept, free=current)
        _mark_dropped(rounds, [m for m in before if m not in named], f"named, dropped in round {rnd}")
    ambiguous = {k: v for k, v in ambiguous.items() if k in named}
    return current, named, rounds, ambiguous, notes, cut


#: The effects of impact times are judged again by generalized least squares when the bounces' scatter is
#: found at this level (a test at 5 % widens the +-): found in noise alone, it costs an effect its
#: power (a speed law planted in 6 impacts was lost in 1 of 12 records when the share of an assumed timing
#: noise was not tested).
JUDGE_SCATTER_ALPHA = 0.01


def _bounce_scatter(problem, fit, sigma_floor, alpha=0.05, share_alpha=1.0):
    """The median over the runs of the bounces' own scatter beyond ``fit``'s model and the timing noise
    (:func:`vrcal.discovery.residuals.bounce_scatter`, tested at ``alpha`` and ``share_alpha``; 0 when
    none is found), or None (too few impacts)."""
    return _over_runs(problem, fit, lambda t, model_t: res.bounce_scatter(
        t, sigma_floor, model_t, alpha=alpha, timing_known=problem.noise_known, share_alpha=share_alpha))


def _over_runs(problem, fit, quantity, each=False):
    """The median over the runs of ``quantity(t, model_t)`` (the run's impact times and ``fit``'s model
    times [s]), its None values left out; None when all are. ``each``: the list of the values instead."""
    values = [quantity(t, t - fit.residuals[sl]) for sl, t in res._run_times(problem)]
    values = [v for v in values if v is not None]
    if each:
        return values
    return float(np.median(values)) if values else None


#: A bounce-to-bounce scatter real balls have: the median of the blue ball's phyphox runs (0.3-7 %).
#: When the times cannot see one this large (their timing noise hides it: times printed to 0.01 s),
#: the +- of epsilon is given with it, not with none.
TYPICAL_BOUNCE_SCATTER = 0.015


def _with_scatter(problem, current, sigma_floor):
    """Impact times: (fit with its +- widened by the bounces' scatter, scatter, scatter_gap, scatter_limit,
    notes) of the final model (:func:`discover`)."""
    scatter = scatter_gap = scatter_limit = None
    notes = []
    # the bounces' own scatter, beyond the final model's changes of ratio and the timing noise (a test
    # at 5 %, then a moment estimate; the timing's share by the changes' shape when the noise is only
    # assumed): a bounce's scatter moves every later time of its run, and errors taken as independent
    # understate the +- (60 seeds each of 8 and 12 impacts, bounces scattering by 0.5-3 %: the fit's own
    # +- covered 7-12 % of the truths; benchmarks/coverage_scatter.py)
    own = _bounce_scatter(problem, current, sigma_floor)
    if own is None:
        # too few times to see it (fewer than SCATTER_MIN_TIMES in every run: the changes of ratio then
        # have no degree of freedom to test): the +- and the verdict allow what real balls have, as where
        # a coarse timing hides it below. Five impact times (one missed in phyphox's six slots) said
        # "unexplained, 7.6 times the noise" at the assumed 0.2 ms and +- 0.0021 where six said
        # "explained" and +- 0.0065
        most = max(run.t_s.size for run in problem.runs)
        times = f"{most} impact times" if len(problem.runs) == 1 else f"runs of at most {most} impact times"
        notes.append(f"{times} are too few to see the bounces' own scatter ({res.SCATTER_MIN_TIMES} "
                     f"are needed), and real balls scatter by 0.3-7 % (median "
                     f"{100 * TYPICAL_BOUNCE_SCATTER:.2g} %): the ± of epsilon and the verdict allow "
                     f"{100 * TYPICAL_BOUNCE_SCATTER:.2g} %")
        own = TYPICAL_BOUNCE_SCATTER
        values = []
    elif problem.noise_known:
        # a known timing noise (the user's --noise, a grid of the times): the same estimate judges the
        # record. Times printed to 0.01 s with no scatter said "vary by 3.0 %" (the grid's share taken out
        # by a typical row, which the short late intervals exceed) and let the gap be 3.7 times larger
        values = [own]
    else:
        # the assumed stopwatch noise: a phone's is often far below it, and taking out more than the
        # timing's share hides the ball's; the likeliest share of the record's changes of ratio, with a
        # timing noise of any size, judges it (the robust scatter of the ratios, Qn, counted the timing
        # noise as the ball's: 0.67 % on golf times of 0.2 ms jitter and no scatter)
        values = _over_runs(problem, current, lambda t, model_t: res.likeliest_scatter(t, model_t), each=True)
    if own == 0.0:
        # none found: but a coarse timing can hide a scatter that real balls have (times printed to
        # 0.01 s of 12 golf-ball impacts scattering by 2 %: the fit's own +- put the truth 12 +- away)
        scatter_limit = _over_runs(problem, current, lambda t, model_t: res.scatter_upper_limit(
            t, sigma_floor, model_t))
        if scatter_limit is not None and scatter_limit > TYPICAL_BOUNCE_SCATTER:
            own = TYPICAL_BOUNCE_SCATTER
            notes.append(f"these times cannot see a bounce-to-bounce scatter up to {100 * scatter_limit:.2g} % "
                         f"(95 % upper limit at their timing noise), and real balls scatter by 0.3-7 % "
                         f"(median {100 * TYPICAL_BOUNCE_SCATTER:.2g} %): the ± of epsilon is given with "
                         f"{100 * TYPICAL_BOUNCE_SCATTER:.2g} %")
    if values or own:
        # the verdict allows the scatter the +- holds (the robust scatter of the ratios can be less: a
        # golf record "varying by 0.55 %" was "unexplained" with its +- widened for 2.4 %), and never more
        # than the times allow at their timing noise
        scatter = max(float(np.median(values)) if values else 0.0, own or 0.0)
        if scatter_limit is not None:
            scatter = min(scatter, max(scatter_limit, own or 0.0))
        scatter_gap = res.scatter_gap(current, scatter)
    if own:
        wide = res.scatter_uncertainties(current, own, sigma_floor if problem.noise_known else 0.0)
        current = replace(current, uncertainties=np.maximum(current.uncertainties, wide),
                          extra=dict(current.extra, fit_uncertainties=current.uncertainties))
    return current, scatter, scatter_gap, scatter_limit, notes


#: A named effect whose value lies within this many of its final +- of the value at which it vanishes is
#: not resolved (the +- widened by the bounces' scatter after the effect was judged material).
NULL_SIGMAS = 2.0


def _unresolved(fit, names):
    """The effects of ``names`` in ``fit`` whose every parameter lies within :data:`NULL_SIGMAS` of its
    +- of the value at which the effect vanishes."""
    from vrcal.drop.effects import EFFECTS

    values, sds = fit.effect_values, fit.effect_uncertainties
    return [n for n in names if n in values and all(
        abs(v - EFFECTS[n].null_values.get(k, 0.0)) < NULL_SIGMAS * sds[n][k] for k, v in values[n].items())]


def discover(data, ball, *, g_m_per_s2=STANDARD_GRAVITY_M_PER_S2, candidates=None, thresholds=None,
             progress=None, max_effects=None, floor_m=None, noise=None, y_down=False, reader=None, stages=None,
             surface=None):
    """Name the effects that the constant-ε baseline misses in ``data``.

    Parameters
    ----------
    data : Trajectory or ImpactTimes or ApexHeights or Runs
        a measurement from :func:`vrcal.measurements.read_measurement` (or the synthetic generator);
        :class:`vrcal.measurements.Runs` are fitted jointly (one contact, a release state per run)
    ball : BallProperties or vrcal.model.standards.Ball
        mass [kg] and diameter [m] of the ball (used by air drag, buoyancy and the physical limits)
    g_m_per_s2 : float
        gravitational acceleration [m/s²], known (default standard gravity)
    candidates : sequence of str, optional
        effect names to try (default: every effect of the registry whose ``kinds``
        include the data's kind)
    thresholds : Thresholds, optional
        materiality test (see the module docstring)
    progress : callable, optional
        ``progress(round, index, total, name)`` called before each candidate fit
    max_effects : int or None
        most effects to name; None (the default): no cap -- every effect material on top of those named
        before is named, until none is (the materiality test stops the rounds; the registry's effects the
        data kind can show and the data's degrees of freedom bound them). With a cap, the effects it leaves
        out while they are material are said in a note and kept in ``Discovery.cut``: never silently (a
        cap of 3 dropped a tennis ball's drag and bent epsilon 0.011 low, 84 of its +-)
    floor_m : float or None
        trajectories: height of the floor in the file's frame [m], along its y axis (see :func:`floor_referenced`)
    noise : float or None
        noise of one datum in the data's unit (m or s); default: estimated from a
        trajectory (:func:`vrcal.discovery.residuals.noise_floor`), else :data:`ASSUMED_NOISE`
    y_down : bool
        the reader turned the file's y axis over: ``floor_m`` is along the file's axis, and the hint when the
        record looks upside down
    reader : dict or None
        how the file was read (format and options), kept in the result for a replay
    stages : callable, optional
        ``stages(fraction, message)`` called as the record is prepared (noise, decimation, bounces)
        and before the fits (``vrcal discover`` shows them on a terminal from the first second on)
    surface : {"rigid", "soft"} or None
        the floor (:data:`vrcal.drop.effects.SURFACES`); None: the ball's own (``BallProperties.surface``,
        rigid by default). A soft floor (paper, a mat, turf, sand) holds the ball longer: the contact time's
        physical limits and prior widen to its tens of ms (:func:`vrcal.drop.effects.contact_time_limit_s`)

    Returns
    -------
    Discovery

    Raises
    ------
    DataError
        a record that cannot be fitted as it is (:mod:`vrcal.measurements.plausibility`)
    """
    from vrcal.discovery.prepare import prepare
    from vrcal.drop.effects import (
        EFFECTS,
        check_surface,
        contact_time_limit_s,
        record_readout_limit_s_per_m,
        surface_of,
    )
    from vrcal.model.body import ball_properties

    th = thresholds or Thresholds()
    ball = ball_properties(ball)
    if surface is not None:
        ball = replace(ball, surface=check_surface(surface))
    if noise is not None and not (math.isfinite(noise) and noise > 0):
        raise UsageError(f"noise must be a number > 0 in the data's unit, got {noise:g}")
    if not (math.isfinite(g_m_per_s2) and g_m_per_s2 > 0):
        raise UsageError(f"g must be a finite number > 0 [m/s^2], got {g_m_per_s2!r}")
    given_kind = res._runs_of(data)[0].kind
    if given_kind == "trajectory":
        # the rolling shutter a video can hold: a frame read within one frame interval, over the heights it held
        ball = replace(ball, readout_limit_s_per_m=min(record_readout_limit_s_per_m(r.t_s, r.y_m)
                                                       for r in res._runs_of(data)))
    if noise is not None:
        _check_noise_scale(data, noise)
    prepared = prepare(data, ball, g_m_per_s2, floor_m=floor_m, y_down=y_down,
                       sigma_m=noise if given_kind == "trajectory" else None, progress=stages)
    fitted = prepared.data
    kind = res._runs_of(fitted)[0].kind
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
    sigma_floor, noise_source = chosen_noise(data, prepared, noise)
    reader_errors = ReaderErrors.of(data)
    notes = list(prepared.notes)
    if surface_of(ball) == "soft" and "contact_duration" in pool:
        limit = EFFECTS["contact_duration"].parameter("contact_time_s").physical_limits(ball)[1]
        notes.append(f"the floor is soft (--surface soft): contacts of up to {limit * 1e3:.3g} ms are physical "
                     f"(on a rigid floor up to "
                     f"{contact_time_limit_s(float(np.mean(ball.mass_kg)), float(np.mean(ball.diameter_m))) * 1e3:.3g}"
                     f" ms)")
    nuisance = ()
    shifts = prepared.floor_shifts_m
    if kind == "trajectory" and floor_m is None and shifts and all(s != 0.0 for s in shifts):
        # no floor in the record: the contact's level is a nuisance of every model, not an effect to name
        nuisance = ("height_offset",)
        pool = [n for n in pool if n not in nuisance]
    problem = res.make_problem(fitted, ball, g_m_per_s2, noise=sigma_floor, noise_known=noise_known(noise_source))
    if stages is not None:
        stages(1.0, f"fitting {problem_size(problem):,} data")
    baseline = res.fit_model(problem, nuisance)
    if nuisance:
        level = float(baseline.effect_values["height_offset"]["offset_m"])
        notes.append(f"the floor is not in the record: the contact's level is fitted with every model (the "
                     f"baseline's: {level * 1e3:+.2f} mm from the lowest sample); a tracked point off the ball's "
                     f"bottom cannot be told from it (height_offset not tried; give --floor to test it)")
    skipped = sorted(set(res.applicable_effects(kind)) ^ set(EFFECTS))
    if skipped:
        notes.append(f"not tried ({kind} data cannot show them): {', '.join(skipped)}")
    selection = _select(problem, baseline, pool, nuisance, th, sigma_floor, reader_errors, max_effects, progress)
    judged = None
    if kind == "impacts":
        # the bounces' own scatter beyond the selected model's changes of ratio and the timing noise; when
        # there is one, the times' errors are not independent and every model is judged again by
        # generalized least squares under their covariance (res.scatter_weights)
        own = _bounce_scatter(problem, selection[0], sigma_floor, JUDGE_SCATTER_ALPHA, JUDGE_SCATTER_ALPHA)
        weights = res.scatter_weights(problem, own, sigma_floor)
        if weights is not None:
            weighted = replace(problem, weights=weights)
            judged_baseline = res.fit_model(weighted, nuisance)
            selection = _select(weighted, judged_baseline, pool, nuisance, th, sigma_floor, reader_errors, max_effects,
                                progress)
            judged = (judged_baseline, selection[0])
            notes.append(f"the bounces scatter by {100 * own:.2g} % (each bounce's epsilon, beyond the timing "
                         f"noise): a low one shortens every later flight, so the times' errors are not "
                         f"independent; the effects were judged by generalized least squares under their "
                         f"covariance, the values fitted by least squares")
    current, named, rounds, ambiguous, round_notes, cut = selection
    notes.extend(round_notes)
    limited = [n for n in named if n not in nuisance]
    if judged is not None:
        # the values of the named model by least squares: the times a deterministic engine reproduces
        # best (generalized least squares lets the late times drift by what the scatter allows: 1.8 s
        # over 200 impacts)
        current = fit_physical(problem, named, start=_start_from(current), limited=limited)
    if kind == "apexes" and "height_offset" in named:
        notes.append("a height offset in heights says how they were read (the ball's top is one diameter above its "
                     "bottom); if you know the point, give --drop-measured-to and --rebound-measured-to: no offset "
                     "is then fitted (in a drop table one can stand in for the shape of epsilon(v) or for drag)")
    scatter = scatter_gap = scatter_limit = None
    if kind == "impacts":
        current, scatter, scatter_gap, scatter_limit, scatter_notes = _with_scatter(problem, current, sigma_floor)
        weak = _unresolved(current, [n for n in named if n not in nuisance])
        if weak:
            # material when judged, but not resolved with the +- the scatter gives: a speed law p = 0.099
            # +- 0.100 and a contact of 1.0 +- 2.3 ms were named on records of a constant epsilon
            vals = "; ".join(f"{k} {v:.3g} ± {current.effect_uncertainties[n][k]:.2g}"
                             for n in weak for k, v in current.effect_values[n].items())
            notes.append(f"{', '.join(weak)} not named: material in the test, but with the ± the bounces' scatter "
                         f"gives its value ({vals}) is within {NULL_SIGMAS:g} ± of none")
            _mark_dropped(rounds, weak, "named, then dropped: not resolved with the bounces' scatter")
            named = [n for n in named if n not in weak]
            ambiguous = {k: v for k, v in ambiguous.items() if k in named}
            current = fit_physical(problem, named, start=_start_without(current, weak),
                                   limited=[n for n in named if n not in nuisance])
            current, scatter, scatter_gap, scatter_limit, scatter_notes = _with_scatter(problem, current,
                                                                                        sigma_floor)
        notes.extend(scatter_notes)
    split = split_by_priors(problem, current, named, ambiguous, current.noise_sigma(sigma_floor))
    n_read = sum(int(res.observed_values(run).size) for run in res._runs_of(data))
    found = Discovery(fitted, ball, float(g_m_per_s2), sigma_floor, baseline, current,
                      [n for n in named if n not in nuisance], rounds, th, notes,
                      noise_source, ambiguous, list(prepared.warnings), prepared.labels, scatter, scatter_gap,
                      dict(reader or {}, floor_shift_m=list(shifts), floor_m=floor_m),
                      prepared.decimation, n_read, split, nuisance, judged, scatter_limit, list(cut), max_effects)
    _speeds_make_rivals(found, problem)
    if kind == "trajectory":
        notes.extend(_contact_drifts(found))
    if not found.within_noise:
        # files fitted jointly that the shared contact does not reproduce: is each file one ball?
        found.warnings.extend(files_disagree(current, th.file_sigmas))
    for e in found.at_limit:
        within = e["chi2"] <= th.indistinguishable_chi2
        notes.append(f"{e['effect']}: {e['parameter']} held at its physical limit {e['limit']:.4g}; the best fit "
                     f"beyond the limits has {e['unconstrained']:.4g} and a chi2 lower by {e['chi2']:.2g}"
                     + (" (within the noise: the data cannot reject the limit)" if within else "")
                     + "; a value at the edge of what is physical: "
                     + effect_check(e['effect'], found.kind, ball, found.warnings))
    return found


def _speeds_make_rivals(found, problem):
    """One rule for air drag and a speed-dependent ε: when the report says the speeds cannot tell them
    apart (:attr:`Discovery.speeds_too_narrow`) and one of them is named, the other is its ambiguous rival,
    and the prior split (:func:`split_by_priors`) shares the two, as for any rival. The selection's own
    test of rivals asks more (the rival material, the drops' spread narrow): drag and a speed law planted
    together on a ping-pong ball's apexes named the speed law alone, epsilon 0.8034 ± 0.0019 for 0.9008,
    while the report said both fit and listed no rival."""
    pair = found.pair_rival
    # as the selection judges a rival: not one the priors make decisively less probable (a speed law that
    # fits drag's golf impact times only with p near 0, where its prior has no mass)
    if not found.speeds_too_narrow or pair is None or pair["decisive"]:
        return
    win, rival = pair["named"], pair["rival"]
    if rival in found.ambiguous.get(win, ()):
        return
    found.ambiguous = {**found.ambiguous, win: [*found.ambiguous.get(win, ()), rival]}
    for rnd in found.rounds:
        for c in rnd:
            if c.verdict.startswith("named") and win in c.members:
                c.verdict = f"named (ambiguous with {', '.join(found.ambiguous[win])})"
    found.notes.append(f"{win} is named, but {rival} alone fits these {found.kind} data within chi2 "
                       f"{number(found.drag_or_speed_law_chi2, 2)} of it: the speeds cannot tell them apart, so "
                       f"{rival} is listed as its rival and the two are shared by their priors")
    found.split = split_by_priors(problem, found.final, [*found.nuisance, *found.effects], found.ambiguous,
                                  found.final.noise_sigma(found.noise_floor))


def effect_check(effect, kind, ball, warnings):
    """What to check when ``effect`` would fit only with an unphysical value (:meth:`Effect.check_for`), or
    the heights' unit first when a warning already suspects it (the ball's mass and diameter are then not to
    blame: :func:`vrcal.measurements.plausibility.unit_suspected`)."""
    from vrcal.drop.effects import EFFECTS, surface_of
    from vrcal.measurements.plausibility import CHECK_UNIT_FIRST, unit_suspected

    return CHECK_UNIT_FIRST if unit_suspected(warnings) else EFFECTS[effect].check_for(kind, surface_of(ball))


def _at_misfit(sigma2, fit):
    """The variance [unit^2] a chi-square of ``fit``'s record is taken at: the noise's ``sigma2``, or the
    model's own residual variance (its RSS over its degrees of freedom) when that is larger."""
    return sigma2 * max(1.0, fit.rss / sigma2 / max(fit.n - fit.k, 1))


def _contact_drifts(found):
    """Notes on the runs of a trajectory whose contact level drifts from bounce to bounce beyond what the
    final model's heights show (:func:`vrcal.discovery.prepare.contact_level_drift`)."""
    from vrcal.discovery.prepare import _of_run, contact_level_drift

    out = []
    diameter = float(np.mean(found.ball.diameter_m))
    g = found.final.problem.g_m_per_s2
    for r, (run, label) in enumerate(zip(found.runs, found.labels or [""] * len(found.runs))):
        start = int(getattr(run, "release_index", 0) or 0)
        minima = [int(m) for m in res.impacts_in_trajectory(run.t_s, run.y_m, start, found.noise_floor or None)]
        model = found.final.predict_at(np.asarray(run.t_s, dtype=float), run=r)
        note = contact_level_drift(run, minima, g, float(found.noise_floor or 0.0), diameter, model_y_m=model)
        if note:
            out.append(_of_run(label, note))
    return out


def files_disagree(fit, n_sigma):
    """Sentences naming the files of a joint fit whose own ε disagrees with the first file's, or [].

    Each file's runs are fitted alone with the joint model's effects (its ε at the joint fit's reference
    speed); a file whose ε lies more than ``n_sigma`` combined standard deviations from the first file's is
    named with both values: two balls' drop tables (a tennis ball's ε 0.75, a golf ball's 0.80) pooled
    as one gave ε 0.776 "explained" by a "noise" of 65 mm, the two files' rows taken for repeated trials.

    Parameters
    ----------
    fit : FitResult
        the joint fit (the final model)
    n_sigma : float
        standard deviations apart that make two files disagree

    Returns
    -------
    list of str
    """
    import os

    from vrcal.measurements import Runs

    problem = fit.problem
    runs = problem.runs
    files = list(dict.fromkeys(res.run_file(r) for r in runs))
    if len(files) < 2 or None in files:
        return []
    start = {p.key: float(v) for p, v in zip(fit.layout, fit.values) if p.run is None}
    found = []
    for name in files:
        own = tuple(r for r in runs if res.run_file(r) == name)
        sub = res.make_problem(Runs(runs=own, source=name), problem.ball, problem.g_m_per_s2, noise=problem.noise,
                               noise_known=problem.noise_known)
        sub = replace(sub, reference_speed_m_per_s=problem.reference_speed_m_per_s)
        alone = res.fit_model(sub, tuple(fit.effects), start)
        found.append((name, alone.value("epsilon"), alone.uncertainty("epsilon")))
    (first, e0, u0), out = found[0], []
    for name, e, u in found[1:]:
        apart = abs(e - e0) / math.hypot(u, u0) if math.hypot(u, u0) > 0 else math.inf
        if apart > n_sigma:
            out.append(f"file {os.path.basename(name)} disagrees with file {os.path.basename(first)} (epsilon "
                       f"{e:.4f} vs {e0:.4f}, {number(apart, 2)} standard deviations apart): not the same ball or "
                       f"conditions? Fit them separately")
    return out


def _check_noise_scale(data, noise):
    """A given noise that is as large as the data themselves is in the wrong unit (``--noise 5`` meant
    5 mm of a table in cm: it was taken as 5 m, and epsilon came out 0.8 +- 2.5, 'explained'): a
    UsageError saying the unit."""
    runs = res._runs_of(data)
    kind = runs[0].kind
    if kind == "impacts":
        dt = np.concatenate([np.diff(np.asarray(r.t_s, dtype=float)) for r in runs])
        scale, unit, what = (float(np.median(dt)) if dt.size else math.inf), "s", "the median interval between impacts"
    elif kind == "apexes":
        h = np.concatenate([np.asarray(r.h_m, dtype=float)[np.asarray(r.bounce) >= 1] for r in runs])
        scale, unit, what = (float(np.median(h)) if h.size else math.inf), "m", "the median rebound"
    else:
        y = np.concatenate([np.asarray(r.y_m, dtype=float) for r in runs])
        scale, unit, what = float(np.ptp(y)) if y.size else math.inf, "m", "the heights' whole range"
    if noise >= 0.5 * scale:
        example = "0.0002 for 0.2 ms" if unit == "s" else "0.005 for 5 mm"
        raise UsageError(f"--noise {noise:g} {unit} is more than half {what} ({scale:.3g} {unit}): --noise is in "
                         f"{unit} whatever unit the file uses (e.g. {example})")


def chosen_noise(data, prepared, noise=None):
    """The noise of one datum a record is judged at, and where it comes from.

    In order: the user's ``noise`` as given; the noise of every sample of a decimated trajectory
    (:class:`vrcal.discovery.prepare.Prepared`, measured before decimation); what the data alone
    tell (:func:`vrcal.discovery.residuals.noise_floor`: third differences of a trajectory, the
    scatter of repeated trials of a drop table); else :data:`ASSUMED_NOISE` of the kind. What the
    reader knows of its own errors is then added (a given ``noise`` is taken as it is): impact
    times read on a coarse grid (a video's frames) are uncertain by step/sqrt(12) when that is
    more (:data:`GRID_SOURCE`); a video tracker's systematic error of the centres adds in quadrature.

    Parameters
    ----------
    data : run or sequence of runs
        the record as read (the readers' ``timing_sd_s`` and ``systematic_m`` are taken from it)
    prepared : Prepared
        the record as fitted (:func:`vrcal.discovery.prepare.prepare`)
    noise : float or None
        the user's noise of one datum [m or s]

    Returns
    -------
    (float, str)
        sigma [m or s] and its source, as the report prints it
    """
    if noise is not None:
        return float(noise), "given"
    fitted = prepared.data
    kind = res._runs_of(fitted)[0].kind
    read_runs = res._runs_of(data)
    if prepared.noise_m is not None:   # a decimated record: the noise of every sample as read
        sigma = prepared.noise_m
        source = f"third differences of all samples (every {prepared.decimation}th fitted)"
    else:
        sigma = res.noise_floor(fitted)
        source = REPLICATE_SOURCE if kind == "apexes" else "third differences of the samples"
        if kind == "apexes" and sigma is not None:
            # repeated trials that agree to the step they are written to (whole cm: 17, 17, 17) do not
            # say the noise is nil, only that the ball's scatter is under the step: judged at their
            # pooled 0, a class table was "inf times the noise floor" with a +- 6 times too small
            step = written_step_m(fitted)
            if step is not None and sigma < step / math.sqrt(12.0):
                sigma = step / math.sqrt(12.0)
                source = (f"{REPLICATE_SOURCE}, at least the step the heights are written to "
                          f"({100 * step:.3g} cm) / sqrt(12)")
            elif sigma <= 0:
                sigma = None
        if sigma is None:
            sigma, source = ASSUMED_NOISE[kind], "assumed; give --noise to change it"
            if kind == "impacts":
                instrument = max(float(getattr(r, "instrument_sd_s", 0.0) or 0.0) for r in read_runs)
                if instrument > 0:
                    sigma, source = instrument, f"{INSTRUMENT_SOURCE}; give --noise to change it"
            elif kind == "trajectory":
                source = "no noise measurable in the samples; assumed, give --noise to change it"
            elif kind == "apexes":
                sigma, source = reading_noise(fitted)
    timing = max(float(getattr(r, "timing_sd_s", 0.0) or 0.0) for r in read_runs)
    systematic = ReaderErrors.of(read_runs).systematic_m
    if kind == "impacts" and timing > sigma:
        return timing, GRID_SOURCE
    if kind == "trajectory" and systematic > 0:
        sigma = math.hypot(sigma, systematic)
        source += (f", with the tracker's systematic error of the centres ({systematic * 1e3:.2g} mm) "
                   "added in quadrature")
    return sigma, source


def noise_known(source):
    """Whether a noise of :func:`chosen_noise`'s ``source`` is known (given, or measured in the record
    or its grid) rather than assumed: a known noise is the floor of the fit's uncertainties."""
    return source in ("given", GRID_SOURCE) or source.startswith(("third differences", REPLICATE_SOURCE))


#: Relative standard deviation of a height read by eye against a ruler (a rebound's apex).
READING_FRACTION = 0.01


def written_step_m(data):
    """The step [m] the heights of a drop table or apex file were written to (the readers'
    ``resolution_m``: the file's own unit, whole inches 25.4 mm), else that of the heights in metres;
    None when they hold more than six decimals. Not the heights in metres when the reader knew the file's
    step: 40 in = 1.016 m has four decimals (0.1 mm), and a shift to the ball's bottom
    (--rebound-measured-to) adds more."""
    from vrcal.measurements.cleanup import printed_resolution

    runs = tuple(data) if isinstance(data, (list, tuple)) else res._runs_of(data)
    written = [r.resolution_m for r in runs if getattr(r, "resolution_m", None) is not None]
    if written:
        return max(written)
    return printed_resolution(np.concatenate([np.asarray(r.h_m, dtype=float) for r in runs]), max_decimals=6)


def reading_noise(data):
    """Assumed noise of one apex height [m], and its source: the largest of :data:`ASSUMED_NOISE`
    (2 mm) and the step the file wrote the heights to over sqrt(12) (``resolution_m`` of the runs: the
    file's own unit, so whole inches are 25.4 mm); heights written to whole centimetres or coarser were
    read by eye against a ruler, good to about :data:`READING_FRACTION` of the rebound (the median
    rebound is taken). Taken from the heights in metres, whole inches had looked like 0.1 mm steps and
    the same drop in inches was judged with a third of the noise of it in centimetres.

    Judged at a flat 2 mm, a class's table of rebounds of 0.4-1.3 m written to whole centimetres
    (read to about 1 cm) was 'unexplained' with epsilon 0.16 low: the drag it hides was rejected by
    an F test on 3 degrees of freedom. One sigma for every datum (the fitter takes one); repeated
    trials of a table measure it instead (:func:`vrcal.discovery.residuals.replicate_sigma`).

    Parameters
    ----------
    data : ApexHeights or Runs of them

    Returns
    -------
    (float, str)
    """
    runs = res._runs_of(data)
    rebounds = np.concatenate([np.asarray(r.h_m, dtype=float)[np.asarray(r.bounce) >= 1] for r in runs])
    parts = {"2 mm": ASSUMED_NOISE["apexes"]}
    step = written_step_m(data)
    if step is not None:
        parts[f"heights written to {step * 100:.3g} cm, / sqrt(12)"] = step / math.sqrt(12.0)
        if step >= 0.01 - 1e-12 and rebounds.size:
            parts[f"written to {step * 100:.3g} cm: read by eye, {100 * READING_FRACTION:g} % of the median "
                  "rebound"] = READING_FRACTION * float(np.median(rebounds))
    why, sigma = max(parts.items(), key=lambda kv: kv[1])
    return float(sigma), f"assumed ({why}); give --noise to change it"


def problem_size(problem):
    """How many data a problem fits."""
    return int(res.observed_values(problem.data).size)


def _backward(problem, named, added, current, th, rnd, notes, keep=()):
    """Stepwise backward check: drop an earlier-named effect that the newly added one has made
    unnecessary (removing it raises the BIC by less than the threshold). Forward selection
    alone can name a stand-in first (a speed-dependent epsilon mimics drag plus an offset).
    ``keep``: nuisances of every model (the floor's level of a record without one), never dropped."""
    changed = True
    while changed:
        changed = False
        for name in [n for n in named if n not in added and n not in keep]:
            rest = [n for n in named if n != name]
            start = _start_without(current, (name,))
            fit = res.fit_model(problem, tuple(rest), start=start)
            if fit.bic - current.bic >= th.delta_bic:
                continue   # needed; held inside the limits the rest would fit no better
            fit = fit_physical(problem, rest, start=start, limited=[n for n in rest if n not in keep], free=fit)
            if fit.bic - current.bic < th.delta_bic:
                notes.append(f"round {rnd}: {name} dropped again: once {' + '.join(added)} is in the model "
                             f"it no longer helps (dBIC {current.bic - fit.bic:+.1f} when removed)")
                named, current, changed = rest, fit, True
                break
    return named, current


def _pairs(problem, named, pool, singles, current, sigma_floor, th, rnd, progress, reader=None, nuisance=()):
    """Pairs of effects, tried when no single effect is material but some improve the fit
    strongly (dBIC >= threshold) with an unphysical parameter: two effects can bend the
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
        cand = _try(problem, named, (a, b), current, sigma_floor, th, rnd, reader, nuisance)
        needed = min(by_name[a].fit.bic, by_name[b].fit.bic) - cand.fit.bic
        if cand.material and needed < th.delta_bic:
            cand.material = False
            cand.verdict = f"not material: dBIC {needed:.1f} < {th.delta_bic:g} against one effect alone"
        out.append(cand)
    return out


def odds_text(odds):
    """Posterior odds as text: '18.8:1', or '>1e4:1' beyond ten thousand."""
    return f"{odds:.3g}:1" if odds < 1e4 else ">1e4:1"


def _odds(delta_score):
    """Posterior odds exp(delta / 2) of two models whose -2 ln Z differ by ``delta``, as text."""
    return odds_text(math.exp(min(delta_score, 1400.0) / 2.0))


def discover_file(path, ball, *, fmt=None, mass_kg=None, diameter_m=None, g_m_per_s2=STANDARD_GRAVITY_M_PER_S2,
                  standards=None, scale_m_per_px=None, y_down=False, fs_hz=None, progress=None, floor_m=None,
                  noise=None, sheet=None, read_options=None, drop_measured_to=None, rebound_measured_to=None,
                  surface=None):
    """Read measurement file(s) and run :func:`discover` on them (what ``vrcal discover`` calls).

    Parameters
    ----------
    path : str or sequence of str
        measurement file(s) (see :func:`vrcal.measurements.read_measurement`); several files of
        one ball are fitted jointly
    ball : str or None
        a ball of the standards, or any name with ``mass_kg`` and ``diameter_m``; None with
        ``mass_kg`` and ``diameter_m`` (see :func:`vrcal.model.body.describe_body`)
    fmt : str or None
        the file's format (None: auto-detect)
    mass_kg, diameter_m : float or None
        ball mass [kg] and diameter [m]; override the standard's nominal values
    g_m_per_s2 : float or None
        gravitational acceleration [m/s²] (None: 9.80665)
    standards : dict or None
        :func:`vrcal.model.standards.load_standards` output (the shipped file when None)
    scale_m_per_px, y_down, fs_hz, sheet :
        passed to the reader (pixel scale [m/px], image y axis down, frame rate [Hz], workbook sheet)
    progress : callable, optional
        see :func:`discover`
    floor_m : float or None
        see :func:`floor_referenced`
    noise : float or None
        noise of one datum in the data's unit, see :func:`discover`
    read_options : dict or None
        options of the sound and video readers (``roi``, ``color``, ``rotate``, ``progress``, see
        :func:`vrcal.measurements.read_measurement`); a video's scale comes from the ball's diameter
    drop_measured_to, rebound_measured_to : {"bottom", "centre", "top"} or None
        the point of the ball that drop and rebound heights were measured to
        (:func:`vrcal.discovery.prepare.heights_to_bottom`; heights only). Given, a height offset is
        not tried: the point is known. None: not stated, the bottom, and a height offset is tried
    surface : {"rigid", "soft"} or None
        the floor, see :func:`discover`

    Returns
    -------
    Discovery
    """
    from vrcal.measurements import read_measurements
    from vrcal.model.body import describe_body

    body = describe_body(ball, mass_kg=mass_kg, diameter_m=diameter_m, standards=standards, ball_label="--ball",
                         from_label=None)
    props, g_m_per_s2 = body.properties, body.gravity_m_per_s2(g_m_per_s2)
    paths = [path] if isinstance(path, (str, bytes)) or not hasattr(path, "__iter__") else list(path)
    options = {"scale_m_per_px": scale_m_per_px, "y_down": bool(y_down), "fs_hz": fs_hz, "sheet": sheet}
    recording = {"diameter_m": float(np.mean(props.diameter_m)), "g_m_per_s2": float(g_m_per_s2),
                 **(read_options or {})}
    stages = recording.get("progress")
    if stages is not None:
        stages(0.0, f"reading {', '.join(map(str, paths))}")
    data = read_measurements(paths, fmt, **options, **recording)
    data = heights_to_bottom(data, float(np.mean(props.diameter_m)), drop_measured_to, rebound_measured_to)
    turned = bool(y_down) or any("y axis points down" in n for run in res._runs_of(data) for n in run.notes)
    reader = {"files": [str(p) for p in paths], "format": fmt, **options, "drop_measured_to": drop_measured_to,
              "rebound_measured_to": rebound_measured_to,
              **{key: recording[key] for key in ("rotate", "roi", "color") if recording.get(key)}}
    stated = drop_measured_to is not None or rebound_measured_to is not None
    candidates = [e for e in res.applicable_effects("apexes") if e != "height_offset"] if stated else None
    def run(g):
        return discover(data, props, g_m_per_s2=g, progress=progress, floor_m=floor_m, noise=noise,
                        y_down=turned, reader=reader, stages=stages, candidates=candidates, surface=surface)

    return at_apparent_g(run(g_m_per_s2), run, g_m_per_s2)


#: Relative margin about the g this ball's flights can show -- between its g less buoyancy (a real ball in air)
#: and bare g (in a vacuum chamber, or a simulation without buoyancy) -- inside which a trajectory's flights fall
#: as they should (:func:`at_apparent_g`): air drag bends a parabola fitted to a table-tennis ball's flight by
#: about 0.2 % of g.
APPARENT_G_TOLERANCE = 0.005

#: ... and beyond which they must lie by this many standard errors of their g.
APPARENT_G_SIGMAS = 5.0

#: The fit at the flights' g is taken when its -2 ln evidence is lower by this much, plus ln n for the one
#: parameter the record gave it (g): odds beyond e^5, 150 to 1.
APPARENT_G_EVIDENCE = 10.0


def flights_g(found):
    """The g a trajectory's flights show [m/s^2] and its standard error: the mean of the parabolas through
    the flights between two bounces of every run (:func:`vrcal.measurements.plausibility.flight_curvatures`),
    weighted by their errors, which the flights' scatter about it widens (Birge's ratio, when above 1); None
    for other data or fewer than two such flights. The first fall and a flight the record ends in are left
    out: rising and falling, air drag bends a parabola one way and then the other, but a fall alone only one
    way (a table-tennis ball's first fall from 1 m shows 0.94 g)."""
    from vrcal.measurements.plausibility import flight_curvatures

    if found.kind != "trajectory":
        return None
    fits = [f for run in found.runs
            for f in flight_curvatures(run.t_s, run.y_m, int(getattr(run, "release_index", 0) or 0),
                                       found.noise_floor or 0.0, between_bounces=True)]
    if len(fits) < 2:
        return None
    g = -np.array([f[0] for f in fits])
    w = 1.0 / np.array([f[3] for f in fits]) ** 2
    mean = float(np.sum(w * g) / np.sum(w))
    birge = math.sqrt(max(float(np.sum(w * (g - mean) ** 2)) / (g.size - 1), 1.0))
    return mean, birge / math.sqrt(float(np.sum(w)))


def at_apparent_g(found, rerun, g_m_per_s2):
    """The discovery of a trajectory at the g its flights show, when they show another and that explains it far
    better.

    A length scale off by a factor s (a metre stick in another plane than the ball) or a clock off by a (a
    29 fps video read at 30) makes the flights fall with s g or g / a^2, and nothing else: ratios of heights,
    and so epsilon, do not change. At the nominal g the fit named a speed law and a height offset for a
    table-tennis track whose scale was 3 % off (epsilon 0.817 for 0.90). The flights' curvature does not
    depend on what happens at the bounces, so it tells a scale from a misfit of the bounce model. When the
    flights' g (:func:`flights_g`) lies outside what this ball's flights can show (its g less buoyancy to
    bare g, :data:`APPARENT_G_TOLERANCE` either side) by :data:`APPARENT_G_SIGMAS` standard errors,
    ``rerun(g)`` fits the record at the g its flights show; its result is taken when its -2 ln evidence (with the
    same noise) is lower by :data:`APPARENT_G_EVIDENCE` + ln n, with a warning (the verdict is "suspect
    input") that says what to check and the epsilon the nominal g gave.

    Parameters
    ----------
    found : Discovery
        the result at ``g_m_per_s2``
    rerun : callable
        ``rerun(g)``: the same discovery at gravity g [m/s^2]
    g_m_per_s2 : float
        the nominal gravity [m/s^2]

    Returns
    -------
    Discovery
    """
    from vrcal.drop.effects import flight_expectation

    seen = flights_g(found)
    if seen is None or not found.noise_floor:
        return found
    g_seen, se = seen
    g = float(g_m_per_s2)
    g_exp, _ = flight_expectation(float(np.mean(found.ball.mass_kg)), float(np.mean(found.ball.diameter_m)), g)
    lo, hi = min(g, g_exp) * (1.0 - APPARENT_G_TOLERANCE), max(g, g_exp) * (1.0 + APPARENT_G_TOLERANCE)
    if lo - APPARENT_G_SIGMAS * se <= g_seen <= hi + APPARENT_G_SIGMAS * se:
        return found
    ref = max(g, g_exp) if g_seen > hi else min(g, g_exp)     # the nearest g this ball's flights can show
    ratio = g_seen / ref
    other = rerun(g_seen)     # the flights as they are; buoyancy, a candidate, would only lower them
    sigma = found.noise_floor
    nominal, refit = res.minus_two_ln_evidence(found.final, sigma), res.minus_two_ln_evidence(other.final, sigma)
    if not nominal - refit > APPARENT_G_EVIDENCE + math.log(other.final.n):
        return found
    other.g_nominal_m_per_s2 = g
    side = ("large", "high") if ratio > 1 else ("small", "low")
    other.warnings.append(
        f"the flights fall at {number(g_seen, 4)} ± {se:.2g} m/s^2, {ratio:.4f} times this ball's ({number(g_exp, 4)} "
        f"with buoyancy, {number(g, 4)} without): a length scale {100 * abs(ratio - 1):.1f} % too {side[0]} "
        f"(--scale; a metre stick in the ball's plane) or a frame rate {100 * abs(math.sqrt(ratio) - 1):.1f} % too "
        f"{side[1]} (--fs, the time column); fitted at g = {number(g_seen, 4)} m/s^2 (as --g "
        f"{number(g_seen, 4)}), which fits far better than g = {number(g, 4)} (epsilon {found.epsilon:.4f} there): "
        f"epsilon from heights does not depend on the scale; the speeds and C_d do")
    return other
