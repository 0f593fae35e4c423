"""Synthetic drop tests that hide one or two effects: test cases for effect discovery.

:func:`hidden_effect_case` draws a random ball of the standards, drop height, epsilon,
effect strength, sampling phase and still segment, simulates the drop with
:func:`vrcal.drop.simulate.simulate_drops`, adds realistic noise, and returns the data as the
dataclasses of :mod:`vrcal.measurements` (what a workflow gets from a file) together with
the truth (what the workflow should find).

Noise (defaults, after the issue's measurement model):

* trajectory: video at 240 Hz, Gaussian height noise 1 mm for a table-tennis ball,
  2 mm for the larger balls;
* impacts: acoustic timing jitter 0.2 ms;
* apexes: Gaussian height noise 1 mm (table tennis) / 2 mm (others).

Detectability rule: a planted effect must be *material*. Its strength is drawn in a
physically plausible range (:data:`STRENGTH_RANGES`) and the case is kept only if the
baseline model (constant epsilon, no drag, instantaneous contacts, heights of the
bottom: the model of [1]), fitted by least squares to the noise-free data, misses it by
at least ``min_signal_sigma`` noise sigmas in total: ``sqrt(chi2_min) >= min_signal_sigma``
(default 10, so Delta chi^2 >= 100 between the baseline and the true model). Otherwise
the strength is raised within the plausible range and, failing that, ball and drop are
drawn again. The signal of each planted effect is returned in the truth
(``truth["signal_sigma"]``). With ``effects=()`` a null case (no effect) is returned,
for false-positive tests.

References
----------
[1] "The Graphical Method for Decision of Restitution Coefficient and Its Applications".
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from vrcal.drop.effects import EFFECTS, get_effect
from vrcal.drop.simulate import FORMATS, observations, sample_measurement, simulate_drops
from vrcal.errors import UsageError
from vrcal.model.body import BallProperties
from vrcal.model.restitution import STANDARD_GRAVITY_M_PER_S2

#: Frame rate of synthetic video [Hz].
FS_HZ = 240.0
#: Acoustic timing jitter [s].
JITTER_S = 0.0002
#: Height noise [m]: table tennis, and every larger ball.
NOISE_TABLE_TENNIS_M = 0.001
NOISE_LARGE_BALL_M = 0.002

#: Drop heights drawn per ball [m] (the ball's bottom at release).
DROP_RANGES_M = {
    "table_tennis": (0.25, 1.0),
    "tennis": (1.0, 2.54),
    "basketball": (1.0, 2.0),
    "volleyball": (1.0, 2.0),
    "football": (1.0, 2.0),
}

#: Plausible strength ranges ``{effect: {ball or "*": (lo, hi)}}`` from which planted strengths are drawn.
#: air_drag: C_d of smooth to rough spheres below the drag crisis; velocity_dependent_restitution:
#: around the viscoelastic 1/5; contact_duration: measured contact times (about 1 ms for table
#: tennis on steel, 4-6 ms tennis, 6-12 ms for inflated large balls); height_offset: see
#: :func:`_draw_offset`; buoyancy: air densities from 2000 m altitude to a cold sea-level day; rolling_shutter:
#: kappa = R / H_frame of a 240 fps camera held upright, whose readout R is at most one frame (4.2 ms), over a
#: frame that holds the drop (up to 1 m table tennis, 2.54 m tennis, 2 m the others): inside the record's limit
#: (:func:`vrcal.drop.effects.record_readout_limit_s_per_m`).
STRENGTH_RANGES = {
    "air_drag": {"*": (0.35, 0.6)},
    "velocity_dependent_restitution": {"*": (0.1, 0.4)},
    "contact_duration": {"table_tennis": (0.0008, 0.003), "tennis": (0.003, 0.006), "*": (0.006, 0.012)},
    "height_offset": {"*": (0.005, 0.02)},
    "buoyancy": {"*": (1.0, 1.3)},
    "rolling_shutter": {"table_tennis": (0.0015, 0.004), "tennis": (0.0007, 0.0016), "*": (0.001, 0.002)},
}


def _noise_for(ball_key, kind):
    if kind == "impacts":
        return JITTER_S
    return NOISE_TABLE_TENNIS_M if ball_key == "table_tennis" else NOISE_LARGE_BALL_M


def _strength_range(name, ball_key):
    ranges = STRENGTH_RANGES[name]
    return ranges.get(ball_key, ranges["*"])


def _param_name(name):
    return EFFECTS[name].parameters[0].name


def _draw_offset(rng, diameter_m, frac):
    """Tracked point: the centre (D/2), the top (D), or a mis-set floor line of 5-20 mm either way."""
    choice = rng.integers(3)
    if choice == 0:
        return 0.5 * diameter_m, "centre of the ball"
    if choice == 1:
        return float(diameter_m), "top of the ball"
    lo, hi = STRENGTH_RANGES["height_offset"]["*"]
    return float(rng.choice([-1.0, 1.0]) * (lo + frac * (hi - lo))), "floor line mis-set"


# --------------------------------------------------------------------------- the baseline refit


def _observe(kind, drops, t_s=None):
    return observations(drops, kind, t_s)[0]


def baseline_misfit_sigma(kind, observed, sigma, n_bounces, ball, *, t_s=None, start=None,
                          g_m_per_s2=STANDARD_GRAVITY_M_PER_S2):
    """How far noise-free data lie from the best baseline model, in noise sigmas.

    The baseline is [1]'s model: constant epsilon, drag-free flights, instantaneous
    contacts, the bottom of the ball observed. Its free parameters are fitted by least
    squares: trajectory (H, epsilon, release time), impacts (t_1, first impact speed,
    epsilon), apexes (H, epsilon).

    Parameters
    ----------
    kind : {"trajectory", "impacts", "apexes"}
    observed : ndarray
        noise-free observations (heights [m] or impact times [s])
    sigma : float
        noise standard deviation of one observation [m] or [s]
    n_bounces : int
    ball : BallProperties
    t_s : ndarray or None
        sample times of a trajectory [s]
    start : tuple
        starting values (H, epsilon, release time) for the fit

    Returns
    -------
    float
        ``sqrt(chi2_min)``: the planted effect's signal in noise sigmas
    """
    H0, eps0, t00 = start
    g = g_m_per_s2
    if kind == "impacts":
        def residual(p):
            t1, v1, eps = p
            flights = (2 * v1 / g) * np.concatenate([[0.0], np.cumsum(eps ** np.arange(1, n_bounces))])
            return (t1 + flights - observed) / sigma

        x0 = (observed[0], np.sqrt(2 * g * H0), eps0)
        bounds = ([-np.inf, 1e-6, 1e-3], [np.inf, np.inf, 1.0])
    elif kind == "apexes":
        def residual(p):
            H, eps = p
            return (H * eps ** (2 * np.arange(n_bounces + 1)) - observed) / sigma

        x0 = (H0, eps0)
        bounds = ([1e-6, 1e-3], [np.inf, 1.0])
    else:
        def residual(p):
            H, eps, t0 = p
            d = simulate_drops(H, eps, n_bounces, ball, g_m_per_s2=g, release_time_s=t0)
            return (d.height_m(t_s)[0] - observed) / sigma

        x0 = (H0, eps0, t00)
        bounds = ([1e-6, 1e-3, -np.inf], [np.inf, 1.0, np.inf])
    x0 = np.clip(np.asarray(x0, dtype=float), np.asarray(bounds[0]) + 1e-9, np.asarray(bounds[1]) - 1e-9)
    fit = least_squares(residual, x0, bounds=bounds, x_scale="jac", xtol=1e-12, ftol=1e-12, gtol=1e-12)
    return float(np.sqrt(2.0 * fit.cost))


# --------------------------------------------------------------------------- the generator


def hidden_effect_case(seed, kind="trajectory", effects=("air_drag",), *, ball=None, min_signal_sigma=10.0,
                       noise=None, fs_hz=FS_HZ, max_tries=40, standards=None):
    """A synthetic measurement that hides ``effects``, and the truth behind it.

    Parameters
    ----------
    seed : int
        seed of ``numpy.random.default_rng``: the same seed gives the same case
    kind : {"trajectory", "impacts", "apexes"}
        the data kind to produce
    effects : tuple of str
        names of the effects to hide (zero, one or two of :data:`vrcal.drop.effects.EFFECTS`),
        each visible in ``kind`` (``Effect.kinds``); ``()`` gives a null case
    ball : str or None
        a ball key of the standards; None draws one at random (re-drawn when the effect
        cannot be made material for it)
    min_signal_sigma : float
        each planted effect must leave the best baseline fit this many noise sigmas away
        (``sqrt(chi2_min)``, noise-free), see the module docstring
    noise : float or None
        height noise [m] (trajectory, apexes) or timing jitter [s] (impacts); None: the
        defaults of the module docstring
    fs_hz : float
        video frame rate [Hz] (trajectory)
    max_tries : int
        draws before giving up with a UsageError
    standards : dict or None
        :func:`vrcal.model.standards.load_standards` output

    Returns
    -------
    measurement : vrcal.measurements.Trajectory or ImpactTimes or ApexHeights
        the data, ``source = "synthetic:seed=SEED"``; a Trajectory starts with a still
        segment and ``release_index`` is the first frame after the release
    truth : dict
        ``ball`` (key), ``kind``, ``drop_height_m`` (bottom), ``epsilon``, ``n_bounces``,
        ``effects`` ({name: {param: value}}), ``signal_sigma`` ({name: sqrt(chi2)}),
        ``noise`` (m or s), ``fs_hz``, ``release_time_s``, ``still_s``, ``notes``, ``seed``
    """
    from vrcal.measurements import ApexHeights, ImpactTimes, Trajectory
    from vrcal.model.standards import ball_epsilon, get_ball, load_standards

    if kind not in FORMATS:
        raise UsageError(f"unknown kind '{kind}' (valid: {', '.join(FORMATS)})")
    if isinstance(effects, str):
        effects = (effects,)
    effects = tuple(get_effect(name).name for name in effects)
    if len(set(effects)) != len(effects) or len(effects) > 2:
        raise UsageError(f"hide zero, one or two different effects, got {effects}")
    for name in effects:
        if kind not in EFFECTS[name].kinds:
            seen = ", ".join(EFFECTS[name].kinds)
            raise UsageError(f"effect '{name}' cannot be seen in {kind} data (only in {seen})")
    standards = load_standards() if standards is None else standards
    keys = [get_ball(ball, standards).key] if ball is not None else [k for k in DROP_RANGES_M if k in standards]
    rng = np.random.default_rng(seed)
    last = None
    for _attempt in range(int(max_tries)):
        std = standards[keys[rng.integers(len(keys))]]
        props = BallProperties.from_ball(std)
        w = ball_epsilon(std)
        lo, hi = DROP_RANGES_M.get(std.key, (0.5, 2.0))
        H = float(rng.uniform(lo, hi))
        eps = float(rng.uniform(max(0.3, w.min - 0.03), min(0.97, w.max + 0.03)))
        sigma = float(noise) if noise is not None else _noise_for(std.key, kind)
        n_bounces = int(rng.integers(6, 13) if kind == "impacts" else rng.integers(4, 8))
        still = float(rng.uniform(0.1, 0.5))
        phase = float(rng.uniform(0.0, 1.0 / fs_hz))
        release = still + phase
        fracs = rng.uniform(0.0, 1.0, len(effects))
        offset_draw = rng.integers(1 << 30)
        planted, notes = {}, []
        # raise the strength in steps from the drawn value to the top of the plausible range
        for step in np.linspace(0.0, 1.0, 4):
            planted, notes = {}, []
            for name, frac in zip(effects, fracs):
                f = frac + step * (1.0 - frac)
                if name == "height_offset":
                    value, note = _draw_offset(np.random.default_rng(offset_draw), props.diameter_m, f)
                    notes.append(f"height_offset: {note}")
                else:
                    a, b = _strength_range(name, std.key)
                    value = a + f * (b - a)
                planted[name] = {_param_name(name): float(value)}
            drops = simulate_drops(H, eps, n_bounces, props, effects=planted, release_time_s=release)
            # keep bounces whose apex stands clear of the noise
            ok = drops.observed_apex_heights_m[0, 1:] > (20 * sigma if kind != "impacts" else 0.005)
            n_keep = int(np.argmin(ok)) if not ok.all() else n_bounces
            if n_keep < 3:
                break
            if n_keep < n_bounces:
                n_bounces = n_keep
                drops = simulate_drops(H, eps, n_bounces, props, effects=planted, release_time_s=release)
            t = None
            if kind == "trajectory":
                t = np.arange(int(np.floor(drops.landing_times_s[0] * fs_hz)) + 1) / fs_hz
            signals = {}
            for name in effects:
                alone = simulate_drops(H, eps, n_bounces, props, effects={name: planted[name]},
                                       release_time_s=release)
                signals[name] = baseline_misfit_sigma(kind, _observe(kind, alone, t), sigma, n_bounces, props,
                                                      t_s=t, start=(H, eps, release))
            last = signals
            if all(s >= min_signal_sigma for s in signals.values()):
                break
        else:
            continue
        if n_keep < 3 or not all(s >= min_signal_sigma for s in signals.values()):
            continue
        break
    else:
        raise UsageError(f"could not plant {', '.join(effects) or 'the case'} in {kind} data with a signal of "
                         f"{min_signal_sigma:g} sigma in {max_tries} draws (last: {last}); lower min_signal_sigma "
                         "or choose another ball")

    columns = sample_measurement(drops, kind, fs_hz=fs_hz, noise_m=sigma if kind != "impacts" else 0.0,
                                 jitter_s=sigma if kind == "impacts" else 0.0, rng=rng)
    source = f"synthetic:seed={seed}"
    case_notes = (f"synthetic {std.key} drop, {kind}, {len(effects)} hidden effect(s)",)
    if kind == "trajectory":
        release_index = int(np.searchsorted(columns["t"], release, side="right"))
        measurement = Trajectory(t_s=columns["t"], y_m=columns["y"], source=source, notes=case_notes,
                                 release_index=release_index)
    elif kind == "impacts":
        measurement = ImpactTimes(t_s=columns["t"], source=source, notes=case_notes, rejected=())
    else:
        measurement = ApexHeights(bounce=columns["bounce"], h_m=columns["h"], source=source, notes=case_notes)
    truth = {
        "seed": seed, "ball": std.key, "kind": kind, "drop_height_m": H, "epsilon": eps, "n_bounces": n_bounces,
        "effects": planted, "signal_sigma": signals, "noise": sigma, "fs_hz": fs_hz if kind == "trajectory" else None,
        "release_time_s": release, "still_s": still, "notes": tuple(notes),
    }
    return measurement, truth


def noise_free_measurement(measurement, truth):
    """The measurement of :func:`hidden_effect_case` without its noise: the same samples, the values
    the planted model gives (to ask what the data could tell apart at best, at any noise).

    Parameters
    ----------
    measurement : Trajectory or ImpactTimes or ApexHeights
        the first return value of :func:`hidden_effect_case`
    truth : dict
        its second return value

    Returns
    -------
    Trajectory or ImpactTimes or ApexHeights
        a copy whose heights [m] or impact times [s] are noise-free
    """
    import dataclasses

    from vrcal.model.standards import get_ball

    props = BallProperties.from_ball(get_ball(truth["ball"]))
    drops = simulate_drops(truth["drop_height_m"], truth["epsilon"], truth["n_bounces"], props,
                           effects=truth["effects"] or None, release_time_s=truth["release_time_s"])
    kind = measurement.kind
    if kind == "trajectory":
        return dataclasses.replace(measurement, y_m=_observe(kind, drops, measurement.t_s))
    if kind == "impacts":
        return dataclasses.replace(measurement, t_s=_observe(kind, drops)[:measurement.t_s.size])
    return dataclasses.replace(measurement, h_m=_observe(kind, drops)[np.asarray(measurement.bounce, dtype=int)])


def measurement_csv(measurement):
    """CSV text of a synthetic measurement in the layout ``vrcal simulate`` writes (for the readers)."""
    from vrcal.drop.simulate import columns_csv

    if measurement.kind == "trajectory":
        return columns_csv({"t": measurement.t_s, "y": measurement.y_m}, "trajectory")
    if measurement.kind == "impacts":
        return columns_csv({"t": measurement.t_s}, "impacts")
    return columns_csv({"bounce": measurement.bounce, "h": measurement.h_m}, "apexes")


# --------------------------------------------------------------------------- drop tables


#: Drop heights of a synthetic drop table [m] (the classroom experiment: a few heights, a few trials each).
TABLE_HEIGHTS_M = {"table_tennis": (0.3, 2.0), "*": (0.5, 2.5)}


def drop_table_case(seed, effects=(), *, ball="table_tennis", n_heights=5, trials=3, noise=0.002,
                    standards=None):
    """A synthetic table of drop and rebound heights (one trial per row) hiding ``effects``.

    Parameters
    ----------
    seed : int
        seed of ``numpy.random.default_rng``
    effects : tuple of str
        effects that apex heights can show (``air_drag``, ``velocity_dependent_restitution``,
        ``height_offset``), drawn from :data:`STRENGTH_RANGES`
    ball : str
        a ball of the standards
    n_heights, trials : int
        drop heights (evenly spread over :data:`TABLE_HEIGHTS_M`, 4-6 in the tests) and trials per height
    noise : float
        standard deviation of each height reading [m] (a ruler read to a few mm)

    Returns
    -------
    (Runs, truth) : the table as the reader gives it (ApexHeights of bounces 0 and 1 per row) and
        ``{"ball", "epsilon", "effects", "heights_m", "noise"}``
    """
    from vrcal.measurements import ApexHeights, Runs
    from vrcal.model.standards import ball_epsilon, get_ball, load_standards

    standards = load_standards() if standards is None else standards
    std = get_ball(ball, standards)
    props = BallProperties.from_ball(std)
    rng = np.random.default_rng(seed)
    lo, hi = TABLE_HEIGHTS_M.get(std.key, TABLE_HEIGHTS_M["*"])
    heights = np.repeat(np.linspace(lo, hi, n_heights), trials)
    w = ball_epsilon(std)
    eps = float(rng.uniform(max(0.3, w.min), min(0.97, w.max)))
    planted = {}
    for name in effects:
        if name == "height_offset":
            planted[name] = {"offset_m": 0.5 * float(props.diameter_m)}
        else:
            a, b = _strength_range(name, std.key)
            planted[name] = {_param_name(name): float(rng.uniform(a, b))}
    v_ref = float(np.sqrt(2.0 * STANDARD_GRAVITY_M_PER_S2 * hi))
    drops = simulate_drops(heights, eps, 1, props, effects=planted or None, reference_speed_m_per_s=v_ref)
    apex = drops.observed_apex_heights_m + rng.normal(0.0, noise, (heights.size, 2))
    runs = tuple(ApexHeights(bounce=np.array([0, 1]), h_m=apex[i], source=f"synthetic:seed={seed}:row{i + 1}")
                 for i in range(heights.size))
    labels = tuple(f"row {i + 1}" for i in range(heights.size))
    truth = {"ball": std.key, "epsilon": eps, "effects": planted, "heights_m": heights, "noise": noise,
             "reference_speed_m_per_s": v_ref}
    return Runs(runs=runs, source=f"synthetic:seed={seed}", labels=labels), truth


def drop_table_csv(runs):
    """CSV text of a drop table (``H (m),h (m)``, one trial per row) that the readers read back."""
    lines = ["H (m),h (m)"] + [f"{float(r.h_m[0]):.6g},{float(r.h_m[1]):.6g}" for r in runs.runs]
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------- bounces that scatter


def scattered_impact_times(seed, *, drop_height_m=0.45, epsilon=0.88, scatter=0.02, n_impacts=10,
                           timing_sd_s=JITTER_S, release_time_s=1.0, g_m_per_s2=STANDARD_GRAVITY_M_PER_S2):
    """Impact times of a drag-free drop whose every bounce has its own restitution: a ball that hits
    the floor at slightly different spots, with some spin, loses a little more or less each time.

    Parameters
    ----------
    seed : int
        seed of the random numbers
    drop_height_m : float
        height of the ball's bottom at release [m]
    epsilon : float
        the ball's restitution: bounce j has epsilon exp(scatter z_j), z_j standard normal
    scatter : float
        relative standard deviation of a bounce's epsilon (0.02: 2 %; the blue ball's phyphox runs
        scatter by 0.3-7 %, median 1.5 %)
    n_impacts : int
        impact times, >= 2
    timing_sd_s : float
        standard deviation of the normal error of each time [s] (a phone's acoustic stopwatch)
    release_time_s : float
        time of release [s]
    g_m_per_s2 : float
        gravitational acceleration [m/s²]

    Returns
    -------
    vrcal.measurements.ImpactTimes
    """
    from vrcal.measurements.types import ImpactTimes

    rng = np.random.default_rng(seed)
    speed = np.sqrt(2.0 * g_m_per_s2 * drop_height_m) * np.cumprod(
        np.concatenate([[1.0], epsilon * np.exp(scatter * rng.standard_normal(n_impacts - 2))]))
    flights = 2.0 * speed / g_m_per_s2
    t = release_time_s + np.sqrt(2.0 * drop_height_m / g_m_per_s2) + np.concatenate([[0.0], np.cumsum(flights)])
    return ImpactTimes(t + rng.normal(0.0, timing_sd_s, n_impacts), f"synthetic (scatter {scatter:g}, seed {seed})")
