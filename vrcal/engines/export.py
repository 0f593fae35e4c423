"""Export a calibrated drop to a physics engine: one function, text out (the CLI writes it).

The body is the one body description of :func:`vrcal.model.body.describe_body`: a ball of the
standards, a user's ``--mass``/``--diameter``, or the ball of a ``vrcal discover --json`` result
(``--from``). The target epsilon is the standard's (Eq. 9 of [1], drop and rebound both to the
ball's bottom), ``--epsilon``, or the discover result's extended model (with its air drag, its
speed-dependent epsilon and its release state). The speeds come from ``--drop-height``,
``--impact-speed LO[:HI]``, the standard's drop height or the discover result's release height.

``--floor`` and ``--against`` add a second body; Eq. (6) of [1] adds the contact times, so for
bodies calibrated at the same K the pair's epsilon is the product of each body's epsilon against
a rigid floor.

MuJoCo's contact is calibrated by running MuJoCo at the user's step and integrator
(:func:`vrcal.engines.mujoco.calibrate`); ODE and PyBullet take epsilon directly and are checked
against the penetration a step allows (:func:`check_step`), and ``vrcal verify`` runs them.
"""

from __future__ import annotations

import math
import textwrap
from dataclasses import dataclass, replace

import numpy as np

from vrcal.engines import get_engine, load, runtime
from vrcal.engines.common import (
    CONFIRM_PHASES,
    DEFAULT_TOLERANCE,
    MAX_BOUNCES,
    N_BOUNCES,
    N_PHASES,
    NOT_RUN,
    RISE_M,
    DropRuns,
    DropSetup,
    _round_up,
    bisect_boundary,
    check_dt,
    check_epsilon,
    check_max_penetration,
    check_positive,
    confirmed,
    engine_label,
    error_text,
    export_for_speeds,
    metadata,
    refine_step,
    round_down,
)
from vrcal.errors import DataError, UsageError
from vrcal.fileio import dumps
from vrcal.inverse import DEFAULT_K_PER_S, depends_on_K, parse_body
from vrcal.model import restitution as eq
from vrcal.model.body import describe_body
from vrcal.model.restitution import APEX_GOAL, check_K
from vrcal.model.standards import ball_epsilon, get_ball
from vrcal.textout import counted

#: Effects of a discover result that an engine file carries; the others are named in the notes.
CARRIED_EFFECTS = ("air_drag", "velocity_dependent_restitution", "height_offset")

#: Effects of a discover result that are the record's, not the ball's: an engine gets epsilon and the ball's
#: physics, and the note says why these are left out (a camera reading its rows one after another shifts the
#: time each height was seen; the ball moved as the engine will move it).
CAMERA_EFFECTS = {"rolling_shutter": "the camera's rolling shutter (when each row of a frame was read), not "
                                     "the ball's motion"}


@dataclass(frozen=True)
class Export:
    """An exported engine file: its text, the data behind it, the drop setup and what was achieved."""

    engine: str
    fmt: str
    text: str
    data: dict
    setup: DropSetup
    pair: dict | None
    summary: str = ""


def combine_epsilons(eps_a, eps_b, K_per_s=DEFAULT_K_PER_S):
    """epsilon of two bodies from each one's epsilon against a rigid floor, Eqs. (6) and (7) of [1].

    Parameters
    ----------
    eps_a, eps_b : float or ndarray
        each body's epsilon against a rigid floor, in (0, 1]
    K_per_s : float
        rate constant K [1/s] shared by both calibrations

    Returns
    -------
    epsilon : float or ndarray
        ``exp(-K (T_A + T_B))`` with ``T = -ln(eps)/K``; equals ``eps_a * eps_b`` for any K
    """
    T = eq.contact_time_from_epsilon_s(eps_a, K_per_s) + eq.contact_time_from_epsilon_s(eps_b, K_per_s)
    return eq.epsilon_from_contact_time(T, K_per_s)


def pair_epsilons(setup, ball2, eps_ball2):
    """epsilon of every pair of an ``--against`` export, each from :func:`combine_epsilons` (Eq. 6 of [1]).

    The floor is a body too: a compliant ``--floor`` enters both balls' floor pairs through its own
    epsilon (its virtual body, Eq. 7), a rigid floor as 1. Every engine takes its pair values from here.

    Parameters
    ----------
    setup : DropSetup
        the first ball's setup (``ball_epsilon`` against a rigid floor, ``floor_epsilon``)
    ball2 : str
        the second ball's name
    eps_ball2 : float
        the second ball's epsilon against a rigid floor, in (0, 1]

    Returns
    -------
    dict
        ``{"BALL/floor": ..., "BALL2/floor": ..., "BALL/BALL2": ...}``
    """
    eps_a = setup.ball_epsilon if setup.ball_epsilon is not None else setup.epsilon
    return {f"{setup.ball}/floor": float(combine_epsilons(eps_a, setup.floor_epsilon)),
            f"{ball2}/floor": float(combine_epsilons(eps_ball2, setup.floor_epsilon)),
            f"{setup.ball}/{ball2}": float(combine_epsilons(eps_a, eps_ball2))}


def drop_height_for_speed_m(v_m_per_s, g_m_per_s2, k_per_m=0.0):
    """Drop height [m] from which a ball released at rest hits at ``v_m_per_s`` [m/s].

    Eq. 8 of [1] inverted, ``H = v^2 / (2 g)``; with quadratic air drag ``a = -g - k v|v|``
    (``k_per_m`` [1/m], below the terminal speed) ``H = -ln(1 - k v^2 / g) / (2 k)``.
    """
    v2 = float(v_m_per_s) ** 2
    if not k_per_m:
        return v2 / (2.0 * g_m_per_s2)
    return -math.log1p(-k_per_m * v2 / g_m_per_s2) / (2.0 * k_per_m)


def parse_impact_speed(text):
    """``LO[:HI]`` [m/s] -> (lo, hi) floats with 0 < lo <= hi; UsageError otherwise."""
    parts = str(text).split(":")
    if len(parts) > 2:
        raise UsageError(f"--impact-speed must be LO or LO:HI in m/s, got '{text}'")
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise UsageError(f"--impact-speed must be LO or LO:HI in m/s, got '{text}'") from None
    for v in values:
        if not (math.isfinite(v) and 0 < v <= 1000):
            raise UsageError(f"--impact-speed must be speeds in (0, 1000] m/s, got '{text}'")
    lo, hi = min(values), max(values)
    return lo, hi


def build_setup(ball=None, engine="mujoco", epsilon=None, dt_s=None, floor=None, standards=None,
                K_per_s=None, *, mass_kg=None, diameter_m=None, drop_height_m=None,
                impact_speed=None, g_m_per_s2=None, from_json=None, integrator=None,
                tolerance=None, max_penetration_m=None, n_bounces=None, substeps=None, rebound_height_m=None,
                drop_measured_to=None, rebound_measured_to=None):
    """The :class:`DropSetup` of a body for an engine, from what a user types.

    Parameters
    ----------
    ball : str or None
        a ball of the standards (or any name with ``mass_kg`` and ``diameter_m``); None with
        ``mass_kg`` and ``diameter_m``, or with ``from_json``
    engine : str
        engine name (sets the default time step)
    epsilon : float or None
        the ball's epsilon against a rigid floor (default: the standard's nominal value, or the
        discover result's)
    dt_s : float or None
        time step [s] (default: the engine's, see :data:`vrcal.engines.ENGINES`)
    floor : str or None
        'rigid' (default), or a body spec (ball key, 'x=..,v=..') for a compliant floor
    standards : dict or None
    K_per_s : float or None
        rate constant K [1/s] of Eq. 7 for a virtual-body ``floor`` 'x=..,v=..' (None: 4 1/s);
        refused otherwise, where no epsilon depends on it (:func:`floor_K`)
    mass_kg, diameter_m : float or None
        the body's mass [kg] and diameter [m] (``--mass``, ``--diameter``)
    drop_height_m : float or None
        drop height of the ball's bottom [m] (``--drop-height``)
    impact_speed : str or tuple or None
        ``LO[:HI]`` [m/s]: drop from the height that gives HI and bounce down to LO
    g_m_per_s2 : float or None
        gravity [m/s^2] (default 9.80665, or the discover result's)
    from_json : str or None
        a ``vrcal discover --json`` result (``--from``)
    integrator : str or None
        MuJoCo's integrator (euler, implicit, implicitfast, rk4; default euler)
    tolerance : float or None
        largest accepted |achieved - target| epsilon, > 0 (None: 0.01). For ``tables`` it bounds
        the one constant's error against a speed-dependent epsilon over the impacts, and is refused
        for a constant one (:func:`_refuse_tolerance_for_tables`)
    max_penetration_m : float or None
        largest accepted penetration (or hover) [m]; default a quarter of the radius
    n_bounces : int or None
        bounces to calibrate and verify (default 3, or as ``impact_speed`` needs)
    substeps : int or None
        PyBullet only: ``numSubSteps`` (``--substeps``): ``dt_s`` is the ``stepSimulation()`` step, the
        engine runs (and is checked) at ``dt_s / substeps`` (:func:`check_substeps`)
    rebound_height_m : float or None
        one's own drop test (``--rebound-height``, with ``drop_height_m``): epsilon = sqrt(h/H), Eq. 9,
        both heights brought to the ball's bottom as ``vrcal fit`` does
        (:func:`vrcal.inverse.drop_test`); the export drops the ball from that bottom height
    drop_measured_to, rebound_measured_to : {"bottom", "centre", "top"} or None
        the point of the ball each height of that drop test was read to (default the bottom)

    Returns
    -------
    DropSetup
    """
    eng = get_engine(engine)
    substeps = check_substeps(substeps, eng.name)
    K_per_s = floor_K(floor, K_per_s)
    body = describe_body(ball, mass_kg=mass_kg, diameter_m=diameter_m, from_json=from_json, standards=standards)
    tolerance_given = tolerance is not None
    tolerance = DEFAULT_TOLERANCE if tolerance is None else check_positive(tolerance, "--tolerance")
    max_penetration_m = check_max_penetration(max_penetration_m, body.radius_m)
    if integrator is not None and eng.name != "mujoco":
        raise UsageError(f"--integrator applies to MuJoCo only, not to {eng.name}")
    if eng.name == "tables":
        _refuse_for_tables(dt_s=dt_s, max_penetration_m=max_penetration_m)
    if drop_height_m is not None and impact_speed is not None:
        raise UsageError("give --drop-height or --impact-speed, not both")
    if drop_height_m is not None:
        drop_height_m = check_drop_height(drop_height_m)
    epsilon, drop_height_m, own_test = _own_drop_test(body, epsilon, drop_height_m, rebound_height_m, drop_measured_to,
                                                      rebound_measured_to, impact_speed)
    doc = body.discovered
    record = RecordDrops.of(doc) if doc and drop_height_m is None and impact_speed is None else None
    notes = []
    g = body.gravity_m_per_s2(g_m_per_s2)
    drag = exponent = release = offset = 0.0
    whence = None      # where a drop height no option gave comes from (a refusal names it)
    baseline = None
    if doc:
        base = doc.get("baseline") if isinstance(doc.get("baseline"), dict) else {}
        # the constant a drag-free engine reproduces the bounce heights with (None: no constant does); an
        # older result has only its baseline's, which folds the flights' timing into epsilon too
        baseline = doc["epsilon_effective_without_drag"] if "epsilon_effective_without_drag" in doc else \
            base.get("epsilon", doc.get("epsilon_baseline"))
        baseline = float(baseline) if isinstance(baseline, (int, float)) and 0 < baseline <= 1 else None
        params = doc["parameters"]
        effects = list(doc["effects"])
        if "air_drag" in effects:
            drag = float(params.get("air_drag", {}).get("drag_coefficient", 0.0))
        if "velocity_dependent_restitution" in effects:
            exponent = float(params.get("velocity_dependent_restitution", {}).get("exponent", 0.0))
        if "height_offset" in effects:
            offset = float(params.get("height_offset", {}).get("offset_m", 0.0))
        elif isinstance(doc.get("floor_level_m"), (int, float)):
            offset = float(doc["floor_level_m"])   # a record without a floor: its contact level, for a replay
        release = float(doc["model"]["release_time_s"])
        # buoyancy: its own note (air_left_out); a camera's artefact: what it is
        left = [e for e in effects if e not in CARRIED_EFFECTS and e != "buoyancy" and e not in CAMERA_EFFECTS]
        notes.append(f"from {from_json}: {', '.join(effects) or 'no effect'} named by vrcal discover")
        if left:
            notes.append(f"not carried into the engine: {', '.join(left)} (no engine setting for it)")
        notes.extend(f"{e} left out: {CAMERA_EFFECTS[e]}" for e in effects if e in CAMERA_EFFECTS)
        if not (0 <= drag <= 3):
            raise DataError(f"{from_json}: air_drag.drag_coefficient {drag:g} is outside [0, 3]")
        if not (-1 <= exponent <= 2):
            raise DataError(f"{from_json}: velocity_dependent_restitution.exponent {exponent:g} is outside [-1, 2]")
    if own_test:
        eps_ball = check_epsilon(epsilon, "the drop test's epsilon")
        notes.insert(0, f"epsilon {eps_ball:.4f}: {own_test}")
    elif epsilon is not None:
        eps_ball = check_epsilon(epsilon, "--epsilon")
        notes.insert(0, f"epsilon {eps_ball:.4f} given with --epsilon")
    elif body.epsilon() is not None:
        eps_ball = check_epsilon(body.epsilon(), f"epsilon of {body.source}")
        notes.insert(0, f"epsilon {eps_ball:.4f}: {body.epsilon_source()}"
                        + (" at the first impact speed" if exponent else ""))
    else:
        raise UsageError(f"'{body.name}' is not a ball of the standards: give --epsilon")
    n = N_BOUNCES if n_bounces is None else int(n_bounces)
    if impact_speed is not None:
        lo, hi = parse_impact_speed(impact_speed) if isinstance(impact_speed, str) else impact_speed
        k = 0.0
        if drag:
            from vrcal.drop.effects import drag_constant_per_m

            k = float(drag_constant_per_m(drag, body.diameter_m, body.mass_kg))
            if hi * hi * k / g >= 1:
                raise UsageError(f"--impact-speed {hi:g} m/s is above the terminal speed {math.sqrt(g / k):.3g} m/s")
        H = drop_height_for_speed_m(hi, g, k)
        if lo < hi and n_bounces is None:
            eps_floor_guess = eps_ball
            n = 1 + math.ceil(math.log(lo / hi) / math.log(eps_floor_guess)) if eps_floor_guess < 1 else N_BOUNCES
            n = min(max(n, 1), MAX_BOUNCES)
        notes.append(f"impact speeds {lo:g}..{hi:g} m/s: drop from {H:.4g} m, {n} bounce(s)")
    elif drop_height_m is not None:
        H = drop_height_m
    elif record is not None and record.several:
        H = record.highest_m                        # the fastest impacts; bounces reach down to the slowest
        release = record.release_time_s
        whence = f"the highest drop of {from_json}"
    elif body.drop_height_m is not None:
        H = body.drop_height_m
        whence = _fitted_release(doc, from_json) if doc else "the standard's drop test"
    elif eng.name == "tables":
        H = None                                   # a material value needs no speeds
    else:
        raise UsageError("give the speeds to calibrate for: --drop-height M or --impact-speed LO[:HI] (m/s)")
    if eng.name == "tables" and tolerance_given and not (exponent and H is not None):
        _refuse_tolerance_for_tables()
    eps_floor, floor_name = 1.0, "rigid floor"
    if floor is not None and str(floor).strip().lower() not in ("rigid", "floor", "steel"):
        floor_name, _, eps_floor = parse_body(floor, K_per_s, standards)
        eps_floor = float(eps_floor)
    target = float(combine_epsilons(eps_ball, eps_floor, K_per_s))
    if eps_floor != 1.0:
        notes.append(f"floor {floor_name}: epsilon {eps_floor:.4f}; pair {eps_ball:.4f} x {eps_floor:.4f} = "
                     f"{target:.4f} (Eq. 6)")
    dt = check_dt(eng.default_dt_s if dt_s is None else dt_s) / max(substeps, 1)
    if eng.name == "mujoco":
        from vrcal.engines.mujoco import DEFAULT_INTEGRATOR, INTEGRATORS

        integrator = (integrator or DEFAULT_INTEGRATOR).lower()
        if integrator not in INTEGRATORS:
            raise UsageError(f"unknown --integrator '{integrator}' (known: {', '.join(INTEGRATORS)})")
    setup = DropSetup(
        ball=body.name, mass_kg=body.mass_kg, radius_m=body.radius_m, drop_height_m=None if H is None else float(H),
        epsilon=check_epsilon(target), dt_s=dt, g_m_per_s2=g, ball_epsilon=eps_ball, floor_epsilon=eps_floor,
        notes=tuple(notes), n_bounces=n, drag_coefficient=drag, restitution_exponent=exponent,
        tolerance=tolerance, max_penetration_m=max_penetration_m, integrator=integrator,
        release_time_s=release, height_offset_m=offset, baseline_epsilon=baseline, substeps=substeps,
    )
    if impact_speed is not None:
        setup = _reach_lowest_speed(setup, lo, hi, n_bounces)
    elif record is not None:
        setup = record.cover(setup, n_bounces)
        if eng.name in ("ode", "bullet"):         # they carry the law: judged on the record's heights too
            from vrcal.engines.replay import APEX_NOISE_SIGMAS, record_noise

            noise, _ = record_noise(doc, 0.0)
            setup = replace(setup, apex_goal=APEX_GOAL, apex_floor_m=APEX_NOISE_SIGMAS * noise)
    if H is not None:
        _check_bounces_reachable(setup, whence)
    return replace(setup, notes=setup.notes + tuple(air_left_out(setup, doc)))


#: The most substeps ``--substeps`` takes.
MAX_SUBSTEPS_GIVEN = 1000


def check_substeps(substeps, engine):
    """``--substeps`` as an int (0 when not given); UsageError (one line) for an engine other than PyBullet, or a
    count that is not a whole number from 1 to :data:`MAX_SUBSTEPS_GIVEN`."""
    if substeps is None:
        return 0
    if engine != "bullet":
        raise UsageError(f"--substeps is PyBullet's numSubSteps and applies to --engine bullet only, not to {engine}: "
                         "give that engine's step with --dt")
    if isinstance(substeps, bool) or not float(substeps).is_integer() or not 1 <= substeps <= MAX_SUBSTEPS_GIVEN:
        raise UsageError(f"--substeps must be a whole number from 1 to {MAX_SUBSTEPS_GIVEN}, got {substeps!r}")
    return int(substeps)


def _own_drop_test(body, epsilon, drop_height_m, rebound_height_m, drop_measured_to, rebound_measured_to,
                   impact_speed):
    """(epsilon, drop height of the ball's bottom [m], the note's words) of one's own drop test given with
    ``--rebound-height`` (:func:`vrcal.inverse.drop_test`, as ``vrcal fit`` reads it); the arguments as they
    came, and '', without one. UsageError (one line) for what cannot go with it."""
    if rebound_height_m is None:
        given = [flag for flag, value in (("--drop-measured-to", drop_measured_to),
                                          ("--rebound-measured-to", rebound_measured_to)) if value is not None]
        if given:
            raise UsageError(f"{' and '.join(given)} read{'s' if len(given) == 1 else ''} the heights of your own "
                             "drop test: give --rebound-height with --drop-height (epsilon = sqrt(h/H))")
        return epsilon, drop_height_m, ""
    clash = [flag for flag, value in (("--epsilon", epsilon), ("--impact-speed", impact_speed)) if value is not None]
    if clash or body.discovered:
        names = " and ".join(clash + (["--from"] if body.discovered else []))
        raise UsageError(f"--rebound-height gives epsilon = sqrt(h/H) from your drop test, and the drop: leave out "
                         f"{names}")
    if drop_height_m is None:
        raise UsageError("--rebound-height needs the --drop-height it rebounded from (epsilon = sqrt(h/H))")
    from vrcal.inverse import drop_test

    eps, keys = drop_test(body, drop_height_m, rebound_height_m, drop_measured_to or "bottom",
                           rebound_measured_to or "bottom")
    return eps, keys["drop_height_m"], (f"{keys['epsilon_source']}, H {keys['drop_height_m']:.4g} m, "
                                        f"h {keys['rebound_height_m']:.4g} m of the ball's bottom")


def _fitted_release(doc, from_json):
    """Where a discover result's drop height comes from, for a refusal: the release its fit starts from, with
    the lines of the record the fit holds (a trajectory's fit restarts at an apex after a bounce left out: a
    marble's 31 mm there, where the record's own release was 19 cm up)."""
    runs = doc.get("runs") if isinstance(doc.get("runs"), list) else []
    label = runs[0].get("label") if len(runs) == 1 and isinstance(runs[0], dict) else None
    return f"the release of the fit in {from_json}" + (f", {label}" if isinstance(label, str) and label else "")


#: How the notes start that say what of the ball's air no exported engine applies (:func:`air_left_out`):
#: the terminal prints them with the export's summary, and every file's header carries them.
AIR_LEFT_OUT = ("buoyancy left out", "warning: buoyancy")


def air_left_out(setup, doc):
    """The notes (a list, maybe empty) on the buoyancy an exported engine leaves out.

    A discover result that names ``buoyancy``: the engines apply none (MuJoCo's ``density`` drives
    its fluid model's drag and lift only: measured, a ball at rest in it falls with g), so the file's
    ball falls faster than the record's; the note says by how much at the first impact (vrcal's model
    of the drop with and without it) and how MuJoCo adds Archimedes' force (``gravcomp`` on the body,
    a fraction of its weight). A ball given by mass and diameter: ``vrcal fit``'s warning when the air
    it displaces is a large part of its mass (:func:`vrcal.inverse.buoyancy_notes`).
    """
    if not doc:
        from vrcal.inverse import buoyancy_notes

        return buoyancy_notes(setup.mass_kg, 2.0 * setup.radius_m)
    if "buoyancy" not in doc.get("effects", ()) or setup.drop_height_m is None:
        return []
    from vrcal.drop.simulate import simulate_drops
    from vrcal.model.body import BallProperties

    rho = float(doc["parameters"].get("buoyancy", {}).get("air_density_kg_per_m3", eq.AIR_DENSITY_KG_PER_M3))
    ball = BallProperties(setup.mass_kg, 2.0 * setup.radius_m, setup.ball)
    H = setup.drop_height_m
    with_it = simulate_drops(H, setup.epsilon, 1, ball, g_m_per_s2=setup.g_m_per_s2,
                             effects={**setup.effects, "buoyancy": {"air_density_kg_per_m3": rho}})
    without = setup.model_at(H)
    share = rho * float(eq.sphere_volume_m3(2.0 * setup.radius_m)) / setup.mass_kg
    return [f"buoyancy left out (the record's air, {rho:.3g} kg/m^3, weighs {share:.1%} of the ball): no engine "
            f"applies it (MuJoCo's density drives its drag only), so from {H:.4g} m the ball hits at "
            f"{float(without.impact_speeds_m_per_s[0, 0]):.3g} m/s after {float(without.impact_times_s[0, 0]):.3g} s, "
            f"the record's ball at {float(with_it.impact_speeds_m_per_s[0, 0]):.3g} m/s after "
            f"{float(with_it.impact_times_s[0, 0]):.3g} s; MuJoCo adds Archimedes' force with gravcomp=\"{share:.4g}\" "
            "on the ball's body (then export for the slower impacts)"]


#: Highest ``--drop-height`` [m] of an export or a verify: a 100 m drop hits at 44 m/s (no drag), beyond
#: any drop test; faster impacts are given as speeds (``--impact-speed``, up to 1000 m/s).
MAX_DROP_HEIGHT_M = 100.0


def check_drop_height(drop_height_m):
    """``--drop-height`` as a float in (0, :data:`MAX_DROP_HEIGHT_M`] [m]; a UsageError otherwise, naming
    the likely slip above it (centimetres typed for metres)."""
    from vrcal.errors import unit_hint

    h = check_positive(drop_height_m, "--drop-height")
    if h > MAX_DROP_HEIGHT_M:
        raise UsageError(f"--drop-height must be at most {MAX_DROP_HEIGHT_M:g} m (a drop of {h:g} m hits at "
                         f"{float(eq.impact_speed_m_per_s(h)):.3g} m/s; faster impacts: --impact-speed), got {h:g}"
                         + unit_hint(h, MAX_DROP_HEIGHT_M, "--drop-height", "m", "cm", 100))
    return h


def floor_K(floor, K_per_s):
    """K [1/s] of Eq. 7 for the floor's epsilon: 4 1/s for None; a given K only with a virtual-body
    floor 'x=..,v=..', the one body of an export whose epsilon depends on K (UsageError otherwise:
    the ball's epsilon, a ball or discover result as floor and the pair's product of Eq. 6 do not)."""
    if K_per_s is None:
        return DEFAULT_K_PER_S
    if floor is None or not depends_on_K(floor):
        raise UsageError("--K applies only with --floor x=DEPTH,v=SPEED (that floor's epsilon is exp(-K x/(2v)), "
                         "Eq. 7): the ball's epsilon, a ball or from=FILE as --floor and the --against pair (a "
                         "product, Eq. 6) do not depend on K")
    return check_K(K_per_s)


def _refuse_for_tables(**given):
    """One-line UsageError naming the options --engine tables cannot use (``dt_s``, ``max_penetration_m``)."""
    flags = [flag for key, flag in (("dt_s", "--dt"), ("max_penetration_m", "--max-penetration"))
             if given.get(key) is not None]
    if flags:
        raise UsageError(f"{' and '.join(flags)} {'does' if len(flags) == 1 else 'do'} not apply to --engine tables: "
                         "PhysX, Unity and Box2D take epsilon as a material value and vrcal runs none of them, so "
                         "no step or depth is checked (leave it out; --engine ode, bullet or mujoco check a step)")


def _refuse_tolerance_for_tables():
    """One-line UsageError for ``--tolerance`` with --engine tables and a constant epsilon: the value
    typed in is the target itself, and no engine is run whose error it could bound."""
    raise UsageError("--tolerance does not apply to this --engine tables export: the restitution typed in is the "
                     "target epsilon itself and vrcal runs none of PhysX, Unity and Box2D; it applies only to a "
                     "speed-dependent epsilon (--from a discover result naming velocity_dependent_restitution), "
                     "where it bounds the one constant's error over the impacts")


def _speeds(setup):
    """The impact speeds [m/s] of vrcal's model of the setup's drop, one per bounce."""
    return np.asarray(setup.model.impact_speeds_m_per_s[0], dtype=float)


def _bounces_down_to(setup, lo, n_bounces):
    """The setup with as many bounces as reach down to ``lo`` [m/s] when ``--bounces`` (``n_bounces``)
    was not given, each still rising :data:`RISE_M`, at most :data:`MAX_BOUNCES`; and why its last
    impact stays above ``lo`` ('' when it reaches it)."""
    if n_bounces is None:
        while float(setup.model.apex_heights_m[0][-1]) < RISE_M and setup.n_bounces > 1:
            setup = replace(setup, n_bounces=setup.n_bounces - 1)      # the guess went below what rises
        while _speeds(setup)[-1] > lo * (1 + 1e-9) and setup.n_bounces < MAX_BOUNCES:
            more = replace(setup, n_bounces=setup.n_bounces + 1)
            if float(more.model.apex_heights_m[0][-1]) < RISE_M:
                break
            setup = more
    if _speeds(setup)[-1] <= lo * (1 + 1e-6):
        return setup, ""
    return setup, ("--bounces limits it" if n_bounces is not None else
                   f"a slower bounce would rise less than {RISE_M * 1e3:g} mm" if setup.n_bounces < MAX_BOUNCES
                   else f"at most {MAX_BOUNCES} bounces")


def _reach_lowest_speed(setup, lo, hi, n_bounces):
    """The setup with as many bounces as reach down to ``lo`` [m/s] (:func:`_bounces_down_to`), and
    its ``impact speeds`` note saying where the bounces end."""
    why = ""
    if lo < hi:
        setup, why = _bounces_down_to(setup, lo, n_bounces)
    v = _speeds(setup)
    what = (f"impact speeds {lo:g}..{hi:g} m/s: drop from {setup.drop_height_m:.4g} m, {setup.n_bounces} "
            f"bounce(s) at {v[0]:.3g}..{v[-1]:.3g} m/s" if lo < hi else
            f"impact speed {hi:g} m/s (one value: the first impact): drop from {setup.drop_height_m:.4g} m, "
            f"{setup.n_bounces} bounce(s) at {v[0]:.3g}..{v[-1]:.3g} m/s")
    if why:
        what += f"; not down to {lo:g} m/s ({why})"
    notes = tuple(what if n.startswith("impact speeds ") else n for n in setup.notes)
    return replace(setup, notes=notes)


#: How the note on a discover result of several drops starts (the MJCF header finds it by it; an XML
#: comment may not hold two dashes, so it names no option).
RECORD_NOTE = "the discover result's record:"


@dataclass(frozen=True)
class RecordDrops:
    """The drops of a discover result: an export covers the impact speeds the record holds, not its
    first bounces alone -- the bounces of one drop (a record of 5 bounces down to 1.79 m/s was
    checked over 3, down to 2.84 m/s), or all the drops fitted jointly (a drop table, several
    tracks), not the first row's alone.

    A joint fit refers a speed-dependent epsilon to the highest drop's first impact
    (:func:`vrcal.discovery.residuals.make_problem`); the export drops from that height, whatever
    the rows' order (one drop: from its fit's release), with as many bounces as reach down to the
    record's slowest impact.

    Attributes
    ----------
    heights_m : tuple of float
        every run's release height [m] (the ball's bottom); empty for one drop
    highest_m : float
        the highest of them [m]
    release_time_s : float
        the highest run's release time [s] (0 when the result gives none)
    speeds_m_per_s : tuple of float or None
        (slowest, fastest) impact speed of the record [m/s], as the result gives them
    """

    heights_m: tuple
    highest_m: float
    release_time_s: float = 0.0
    speeds_m_per_s: tuple | None = None

    @classmethod
    def of(cls, doc):
        """The drops of a discover result ``doc`` when it holds two or more runs with release heights, else None."""
        runs = [r.get("release") for r in doc.get("runs") or () if isinstance(r, dict)]
        runs = [r for r in runs if isinstance(r, dict) and _positive(r.get("drop_height_m"), MAX_DROP_HEIGHT_M)]
        speeds = doc.get("impact_speed_range_m_per_s")
        speeds = (tuple(sorted(float(v) for v in speeds)) if isinstance(speeds, (list, tuple)) and len(speeds) == 2
                  and all(_positive(v, 1000.0) for v in speeds) else None)
        if len(runs) < 2:           # one drop: its fit's release, and the record's impacts to cover
            return cls((), 0.0, 0.0, speeds) if speeds is not None else None
        top = max(runs, key=lambda r: float(r["drop_height_m"]))
        t0 = top.get("release_time_s", 0.0)
        return cls(tuple(float(r["drop_height_m"]) for r in runs), float(top["drop_height_m"]),
                   float(t0) if isinstance(t0, (int, float)) and math.isfinite(t0) else 0.0, speeds)

    @property
    def several(self):
        """Whether the record holds several drops (exported from the highest), not one."""
        return len(self.heights_m) > 1

    def cover(self, setup, n_bounces):
        """The setup (dropped from :attr:`highest_m`) with as many bounces as reach the record's slowest
        impact (:func:`_bounces_down_to`), and a note saying what the drop covers."""
        why = ""
        if self.speeds_m_per_s is not None:
            setup, why = _bounces_down_to(setup, self.speeds_m_per_s[0], n_bounces)
        v = _speeds(setup)
        what = ((f"{RECORD_NOTE} {len(self.heights_m)} drops from {min(self.heights_m):.4g}..{self.highest_m:.4g} m"
                 if self.several else f"{RECORD_NOTE} one drop")
                + (f", impacts {self.speeds_m_per_s[1]:.3g}..{self.speeds_m_per_s[0]:.3g} m/s"
                   if self.speeds_m_per_s else "")
                + ("; exported from the highest: " if self.several else "; exported with ")
                + f"{setup.n_bounces} bounce(s) at {v[0]:.3g}..{v[-1]:.3g} m/s")
        if why:        # no option named: the note goes into an MJCF header's comment
            why = "as many bounces as asked" if n_bounces is not None else why
            what += f", not down to {self.speeds_m_per_s[0]:.3g} m/s ({why})"
        return replace(setup, notes=setup.notes + (what,))


def _positive(value, most):
    """Whether ``value`` is a finite number in (0, ``most``]."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value) \
        and 0 < value <= most


def _check_bounces_reachable(setup, whence=None):
    """Refuse a drop whose last bounce is too slow to measure (below 1 mm of rebound), naming
    ``--bounces`` with the most bounces that do rise that far; ``whence``: where a drop height no option
    gave came from (a discover result's fit, a standard), which the refusal names beside it."""
    try:
        apex = setup.model.apex_heights_m[0]
    except UsageError as exc:
        raise UsageError(f"cannot model this drop: {exc}") from None
    if float(apex[-1]) < RISE_M:
        rising = int(np.sum(np.asarray(apex[1:]) >= RISE_M))
        fewer = f"--bounces {rising} or fewer, or a larger --drop-height" if rising else \
            "a larger --drop-height or --epsilon"
        cause = ""
        if setup.floor_epsilon < 1 and setup.floor_epsilon < 0.5 * setup.ball_epsilon:
            # the floor's epsilon is the cause (a virtual body's exp(-K T) at a large --K): name it
            cause = (f"; the pair's epsilon is {setup.epsilon:.3g} = ball {setup.ball_epsilon:.4g} x floor "
                     f"{setup.floor_epsilon:.3g}, Eq. 6")
            if not rising:
                fewer = "a floor of a larger epsilon (a smaller --K, or a virtual body of a shorter contact)"
        rise = f"only {apex[-1] * 1e3:.2g} mm" if apex[-1] > 0 else "not at all"
        drop = f" from {setup.drop_height_m:.4g} m ({whence})" if whence else ""
        raise UsageError(f"bounce {setup.n_bounces} of this drop{drop} rises {rise} (a bounce must rise "
                         f"{RISE_M * 1e3:g} mm{cause}): ask for {fewer}")


def second_setup(setup, name, mass_kg, radius_m, epsilon, ball_epsilon_rigid):
    """The drop setup of an ``--against`` export's second ball on the export's floor.

    Parameters
    ----------
    setup : DropSetup
        the first ball's
    name : str
        the second ball's key
    mass_kg, radius_m : float
        its mass [kg] and radius [m]
    epsilon : float
        its epsilon on the export's floor (Eq. 6)
    ball_epsilon_rigid : float
        its epsilon against a rigid floor

    Returns
    -------
    DropSetup
        dropped from the export's drop height at its step, gravity, tolerance and integrator, with a
        constant epsilon (no drag): the same body as the first gets the same setup, so the same contact;
        its depth limit is a quarter of its own radius unless a limit of its own was given (a file's
        default limit, a quarter of the first ball's radius, judged a basketball by a tennis ball's 8.4 mm)
    """
    limit = setup.max_penetration_m
    if limit is not None and math.isclose(float(limit), 0.25 * float(setup.radius_m), rel_tol=1e-6):
        limit = None
    return replace(setup, ball=name, mass_kg=float(mass_kg), radius_m=float(radius_m), epsilon=float(epsilon),
                   max_penetration_m=limit,
                   ball_epsilon=float(ball_epsilon_rigid), notes=(), drag_coefficient=0.0, restitution_exponent=0.0,
                   release_time_s=0.0, height_offset_m=0.0, baseline_epsilon=None)


def export(ball=None, engine="mujoco", *, epsilon=None, dt_s=None, floor=None, against=None, standards=None,
           K_per_s=None, tolerance=None, mass_kg=None, diameter_m=None,
           drop_height_m=None, impact_speed=None, g_m_per_s2=None, from_json=None, integrator=None,
           max_penetration_m=None, stiffness=None, n_phases=N_PHASES, n_bounces=None, substeps=None,
           rebound_height_m=None, drop_measured_to=None, rebound_measured_to=None):
    """Export a body's calibrated drop for ``engine``.

    Parameters
    ----------
    ball, epsilon, dt_s, floor, standards, K_per_s, tolerance, mass_kg, diameter_m, drop_height_m,
    impact_speed, g_m_per_s2, from_json, integrator, max_penetration_m
        see :func:`build_setup`
    engine : str
        mujoco, ode, bullet (pybullet), gazebo or tables (physx/unity/box2d)
    against : str, optional
        a second ball of the standards: adds the ball/ball2 pair value from Eq. (6)
    stiffness : float, optional
        MuJoCo only: the contact's stiffness S [1/s^2] (0: the damper contact); default: the
        damper for semi-implicit integrators, a spring for RK4
    n_phases : int
        contact phases of MuJoCo's calibration runs
    n_bounces : int or None
        bounces to calibrate and verify (``--bounces``; default: see :func:`build_setup`)
    substeps : int or None
        PyBullet's ``numSubSteps`` (``--substeps``; see :func:`build_setup`)
    rebound_height_m, drop_measured_to, rebound_measured_to
        one's own drop test (see :func:`build_setup`)

    Returns
    -------
    Export

    Raises
    ------
    UsageError
        where the engine cannot meet the tolerance or the penetration limit at the asked step
        (the message names a step that does, checked in the engine where vrcal runs it)
    """
    eng = get_engine(engine)
    setup = build_setup(ball, eng.name, epsilon, dt_s, floor, standards, K_per_s, mass_kg=mass_kg,
                        diameter_m=diameter_m, drop_height_m=drop_height_m, impact_speed=impact_speed,
                        g_m_per_s2=g_m_per_s2, from_json=from_json, integrator=integrator, tolerance=tolerance,
                        max_penetration_m=max_penetration_m, n_bounces=n_bounces, substeps=substeps,
                        rebound_height_m=rebound_height_m, drop_measured_to=drop_measured_to,
                        rebound_measured_to=rebound_measured_to)
    if stiffness is not None and eng.name != "mujoco":
        raise UsageError(f"--stiffness applies to MuJoCo only, not to {eng.name}")
    pair = second = None
    if against is not None:
        try:
            b2 = get_ball(against, standards)
        except UsageError as exc:
            floor_too = " (a virtual body x=DEPTH,v=SPEED is a --floor)" if "=" in str(against) else ""
            raise UsageError(f"--against takes a second ball of the standards{floor_too}: {exc}") from None
        eps2 = ball_epsilon(b2).nominal
        pairs = pair_epsilons(setup, b2.key, eps2)
        pair = {"name": f"{setup.ball}/{b2.key}", "ball2": b2.key, "epsilon_ball2": eps2,
                "epsilon": pairs[f"{setup.ball}/{b2.key}"], "pairs": pairs,
                "equation": "Eq. 6: T = T_A + T_B, epsilon = exp(-K T) = epsilon_A * epsilon_B"}
        second = second_setup(setup, b2.key, b2.mass_kg.nominal, b2.radius_m, pairs[f"{b2.key}/floor"], eps2)
    module = load(eng.name)
    summary = ""
    asked_lo = parse_impact_speed(impact_speed)[0] if isinstance(impact_speed, str) else \
        (impact_speed[0] if impact_speed is not None else None)
    if eng.name == "mujoco":
        cal = calibrate_or_refuse(setup, stiffness, n_phases)
        # the second ball's floor contact is tuned in MuJoCo like the ball's (the same body gets the same solref)
        cal2 = calibrate_or_refuse(second, stiffness, n_phases) if second is not None else None
        # compiled once: each of the scan's drops runs the same model
        coverage = speed_coverage(setup, "mujoco", module.load_model(module.export_mjcf(setup, cal)), asked_lo)
        # the ball/ball2 contact, run (and if need be tuned) in MuJoCo by the two balls meeting head-on
        pair_cal = module.calibrate_pair(setup, second, pair, CONFIRM_PHASES) if second is not None else None
        text = module.export_mjcf(setup, cal, pair, second, coverage, cal2, pair_cal)
        data = {"engine": "mujoco", "target_epsilon": setup.epsilon, "dt_s": setup.dt_s,
                "integrator": module.integrator_name(setup), "g_m_per_s2": setup.g_m_per_s2,
                "solref": cal.contact.solref,
                "margin_m": cal.contact.margin_m, "worst_error": cal.worst_error, "median_error": cal.median_error,
                "penetration_m": cal.penetration_m, "hover_m": cal.hover_m}
        summary = (f"mujoco, dt {setup.dt_s:g} s ({module.integrator_name(setup)}), {cal.contact.kind}: "
                   f"worst eps error "
                   f"{error_text(cal.worst_error)}, penetration {cal.penetration_m * 1e3:.3g} mm, hover "
                   f"{cal.hover_m * 1e3:.3g} mm")
        missed = pair_cal is not None and not pair_cal.result.passed     # said, not refused: verify fails it
        summary = _lines(summary, cal.runs.height_ratio_text(),
                         module.resting_note(cal.contact, setup.g_m_per_s2, "--dt"),
                         _coverage_summary(setup, coverage, "mujoco"),
                         "\n".join(textwrap.wrap(pair_cal.result.failure(), 100)) if missed else "")
    elif eng.name in ("ode", "bullet"):
        setup, checked, coverage, summary = _checked_export(setup, eng.name, n_phases, asked_lo)
        data = module.export_params(setup, setup.n_bounces, pair)
        if coverage:
            data["notes"].insert(1, coverage.note(setup.tolerance))
            data["target"]["holds_down_to_m_per_s"] = coverage.holds_down_to_m_per_s
        data["how_chosen"] = list(setup.notes)
        if pair:
            data["pair"] = {k: v for k, v in pair.items() if k != "pairs"}       # the pairs are data["pairs"]
            # the second body, as "ball" is written: what verify's ball2/floor drop and pair test run
            data["ball2"] = {"name": second.ball, "mass_kg": second.mass_kg, "radius_m": second.radius_m}
        data["snippet"] = module.c_snippet(data) if eng.name == "ode" else module.py_snippet(data)
        text = dumps(data, "json")
    elif eng.name == "gazebo":
        refuse_constant_for_law(setup, eng.label, _engine_accept(setup, "gazebo", n_phases))
        setup, checked, coverage, summary = _checked_export(setup, "gazebo", n_phases, asked_lo)  # runs in ODE
        target = metadata(setup)
        if coverage:
            target["holds_down_to_m_per_s"] = coverage.holds_down_to_m_per_s
        text = module.export_sdf(setup, pair, second, checked if coverage is None else
                                 f"{checked}; {coverage.note(setup.tolerance)}", target=dict(target, ball=setup.ball))
        surface = {"restitution_coefficient": "restitution_coefficient", "threshold": "threshold_m_per_s",
                   "kp": "kp_n_per_m", "kd": "kd_n_s_per_m", "max_vel": "max_vel_m_per_s", "min_depth": "min_depth_m"}
        data = {"engine": "gazebo", "target_epsilon": setup.epsilon, "dt_s": setup.dt_s, "solver": "world",
                "g_m_per_s2": setup.g_m_per_s2, "target": dict(target),
                "contact_max_correcting_vel_m_per_s": module.MAX_CORRECTING_VEL_M_PER_S,
                "surfaces": {name: {surface[k]: v for k, v in module.exported_surface(r).items()}
                             for name, r in (("ball", module.constant_epsilon(setup)), ("floor", 1.0))}}
    else:
        if setup.drop_height_m is not None:
            refuse_constant_for_law(setup, eng.label)
        data = {"engine": "tables", "rows": module.table(setup, pair)}
        text = module.format_table(setup, pair)
    summary = _lines(summary, *(n for n in setup.notes if n.startswith(AIR_LEFT_OUT)))
    return Export(eng.name, eng.fmt, text, data, setup, pair, summary)


def _above(value, limit):
    """``value`` to 3 significant digits, more where those would not show it above ``limit`` (a miss
    of 0.01004 against 0.01 reads 0.01004, not 0.01)."""
    for digits in range(3, 8):
        text = f"{value:.{digits}g}"
        if float(text) > limit:
            return text
    return f"{value:.8g}"


def _checked_coverage(setup, engine, checked, asked_lo):
    """:func:`speed_coverage` of an ODE, Bullet or Gazebo export whose step was run here, else None."""
    if checked.startswith(NOT_RUN):
        return None
    return speed_coverage(setup, engine, _run_params(setup, engine), asked_lo)


def _coverage_summary(setup, coverage, engine):
    """The terminal's lines on the impact speeds the export holds for ('' without a coverage): where
    ``--impact-speed``'s slowest speed was not reached, what the contact does there
    (:meth:`SpeedCoverage.shortfall`); else the file header's line (:meth:`SpeedCoverage.note`, the
    same numbers) and, where a slower impact missed, what that means for a lower drop
    (:meth:`SpeedCoverage.slower`)."""
    if not coverage:
        return ""
    lines = [coverage.shortfall(setup.tolerance)] if coverage.asked_m_per_s is not None else \
        [coverage.note(setup.tolerance), coverage.slower(setup, engine)]
    return "\n".join("\n".join(textwrap.wrap(line, 100)) for line in lines if line)


#: How :func:`check_step`'s note says that the step was checked over fewer phases than it confirms with.
FEWER_PHASES = "not confirmed over"


def _phases_summary(note):
    """The terminal's line when the step was checked over fewer than :data:`CONFIRM_PHASES` phases."""
    if FEWER_PHASES not in note:
        return ""
    import textwrap

    return "\n".join(textwrap.wrap(f"step checked over {note.split(' phases x ')[0].rsplit('(', 1)[-1]} contact "
                                   f"phases only, {note[note.index(FEWER_PHASES):].split(')')[0]}", 100))


def _lines(*lines):
    """The non-empty ``lines`` joined by newlines (the terminal's summary of an export)."""
    return "\n".join(line for line in lines if line)


def _not_run(note):
    """The note of :func:`check_step` when the engine did not run (printed by the CLI), else ''."""
    return note if note.startswith(NOT_RUN) else ""


def _checked_export(setup, engine, n_phases, asked_lo):
    """The drop test of an ODE, PyBullet or Gazebo export at its step (:func:`check_step`) and the speeds
    it holds down to: (setup with the check's note, the note, the coverage or None, the terminal's lines)."""
    checked = check_step(setup, engine, n_phases=n_phases)
    setup = replace(setup, notes=setup.notes + (checked,))
    coverage = _checked_coverage(setup, engine, checked, asked_lo)
    return setup, checked, coverage, _lines(_not_run(checked), _phases_summary(checked),
                                            _coverage_summary(setup, coverage, engine))


def calibrate_or_refuse(setup, stiffness=None, n_phases=N_PHASES):
    """Calibrate MuJoCo's contact at the setup's step; refuse in one line, naming a step that works.

    Returns
    -------
    vrcal.engines.mujoco.Calibration
    """
    from vrcal.engines import mujoco as M
    from vrcal.engines.common import StillBouncing

    kind, w = _contact_choice(setup, stiffness)
    refuse_constant_for_law(setup, "MuJoCo", _mujoco_accept(setup, kind, w, n_phases))

    def step_that_works():
        dt_ok, ok, dt_miss = M.suggest_dt(setup, n_phases, kind, w)
        return (f"--dt {dt_ok:g} meets both (checked in MuJoCo: error {ok.worst_error:.3g}, "
                f"{ok.depth_m * 1e3:.3g} mm; {dt_miss:g} misses)" if dt_ok else
                "no step down to the run limit meets both")

    try:
        cal = M.calibrate(setup, n_phases, kind, w)
    except StillBouncing as exc:             # no damping brings it down: name a step that works, as below
        raise UsageError(f"MuJoCo at --dt {setup.dt_s:g} s ({M.integrator_name(setup)}, {kind} contact) misses: "
                         f"{exc}; {step_that_works()}; see --trade-off") from None
    if cal.ok:
        return cal
    try:                                 # reported over the phases the limits offered below are confirmed over
        cal = M.widened(cal, n_phases)
    except StillBouncing:
        pass
    misses = []
    if not cal.meets_tolerance:
        misses.append(f"worst epsilon error {_above(cal.worst_error, setup.tolerance)} (tolerance {setup.tolerance:g})")
    if cal.runs.gain is not None:
        misses.append(f"{cal.runs.gain_text()}, whatever the tolerance")
    if not cal.meets_depth:
        misses.append(f"the ball turns {_above(cal.depth_m * 1e3, setup.penetration_limit_m * 1e3)} mm from the floor "
                      f"(limit {setup.penetration_limit_m * 1e3:.3g} mm, --max-penetration)")
    keep = "" if cal.runs.gain is not None else _mujoco_keep(setup, cal, kind, w, n_phases)
    raise UsageError(f"MuJoCo at --dt {setup.dt_s:g} s ({M.integrator_name(setup)}, {cal.contact.kind} contact) "
                     f"misses ({_phases(cal.runs)} phases x {counted(setup.n_bounces, 'bounce')}): "
                     f"{'; '.join(misses)}; "
                     f"{step_that_works()}" + (f"; {keep}" if keep else "")
                     + "; see --trade-off")


def _mujoco_keep(setup, cal, kind, w, n_phases, tries=3):
    """:func:`keep_step` for MuJoCo, checked (:func:`_mujoco_limits`): the limits that keep the step of a
    calibration ``cal`` that missed, '' when nothing keeps it (a contact that adds energy)."""
    tol, pen, refusal, trial = _mujoco_limits(setup, cal.worst_error, cal.depth_m, kind, w, n_phases, tries)
    keep = keep_text(setup, tol, pen, refusal)
    if trial is not None and (trial.worst_error > cal.worst_error or trial.depth_m > cal.depth_m):
        # widened: say why it asks more than it missed by
        keep += (f" (at limits that loose MuJoCo's calibration picks another contact: worst epsilon error "
                 f"{trial.worst_error:.3g}, {trial.depth_m * 1e3:.3g} mm)")
    return keep


def _mujoco_limits(setup, worst, depth, kind, w, n_phases, tries=3):
    """:func:`checked_limits` for MuJoCo: each trial is the calibration an export at those limits runs (a
    looser limit picks another contact, which goes deeper or misses by more; a pass over ``n_phases`` is
    confirmed over :data:`CONFIRM_PHASES`)."""
    from vrcal.engines import mujoco as M
    from vrcal.engines.common import StillBouncing

    def trial(loose):
        try:
            cal = M.calibrate(loose, n_phases, kind, w)
        except (StillBouncing, DataError, UsageError):
            return None
        return cal.ok, cal.worst_error, cal.depth_m, cal.runs.gain is not None, cal

    return checked_limits(setup, worst, depth, trial, tries)


def checked_limits(setup, worst, depth, trial, tries=3, margin=1.1):
    """The ``--tolerance`` and ``--max-penetration`` (:func:`keep_limits`) that the export at the setup's step
    accepts, starting from a miss of ``worst`` and ``depth`` [m], checked: ``trial(setup at those limits)``
    runs the export's own check and gives ``(ok, worst_error, depth_m, gained, result)`` (None: it could not
    run); the limits are widened by what it achieved (times ``margin``: MuJoCo's calibration at a looser
    limit picks another contact, :func:`keep_limits`) until it meets them, at most ``tries`` times.

    Returns
    -------
    (float or None, float or None, str, object or None)
        the tolerance and the penetration limit [m] (None: the setup's own does), the refusal when no limit
        keeps the step ('' else), and the trial's result that met them (None: none found, nothing to name)
    """
    for _ in range(tries):
        tol, pen, refusal = keep_limits(setup, worst, depth, margin=margin)
        if refusal or (tol is None and pen is None):
            return tol, pen, refusal, None
        loose = replace(setup, tolerance=setup.tolerance if tol is None else tol,
                        max_penetration_m=setup.max_penetration_m if pen is None else
                        check_max_penetration(pen, setup.radius_m))
        got = trial(loose)
        if got is None:
            return None, None, "", None
        ok, got_worst, got_depth, gained, result = got
        if ok:
            return tol, pen, "", result
        if gained:
            return None, None, "", None
        worst, depth = max(worst, got_worst), max(depth, got_depth)
    return None, None, "", None


def refuse_constant_for_law(setup, engine, accept=None):
    """UsageError (one line) when no constant epsilon can meet the tolerance against the setup's
    speed-dependent epsilon: its spread over the calibrated impacts, half of it the least worst
    error, and what to do. Known before any engine run.

    ``accept(least)`` gives the limits to offer ('--tolerance T [--max-penetration P]', checked by the
    engine's own export at those limits; '' when none was found): an engine run adds its step's error to
    the least a constant misses by (MuJoCo at 2 ms: 0.0124 where half the spread is 0.0115, so the
    '--tolerance 0.012' that half gives was refused again). None: the least rounded up, for an export
    that runs no engine (the tables)."""
    from vrcal.engines.common import epsilon_spread

    lo, hi, least = epsilon_spread(setup)
    if least <= setup.tolerance:
        return
    offer = f"--tolerance {_round_up(least)}" if accept is None else accept(least)
    speeds = setup.impact_speeds_m_per_s
    raise UsageError(
        f"epsilon(v) spans {lo:.4f}..{hi:.4f} over {setup.n_bounces} bounces ({float(np.max(speeds)):.3g}.."
        f"{float(np.min(speeds)):.3g} m/s); {engine}: one constant epsilon, off by at least {least:.4f} (half the "
        f"spread) > --tolerance {setup.tolerance:g}: give fewer --bounces, a narrower --impact-speed, "
        + (f"{offer} (checked: {engine} at --dt {setup.dt_s:g} s then meets it), " if offer and accept else
           f"{offer}, " if offer else "")
        + "or --engine ode or bullet (their exports carry the law)")


def _mujoco_accept(setup, kind, w, n_phases):
    """``accept`` of :func:`refuse_constant_for_law` for MuJoCo: the limits its calibration at the setup's
    step meets (:func:`_mujoco_limits`), as options; '' when none was found."""
    def accept(least):
        tol, pen, refusal, trial = _mujoco_limits(setup, least, 0.0, kind, w, n_phases)
        return "" if refusal or trial is None else _limit_options(tol, pen)
    return accept


def _engine_accept(setup, engine, n_phases):
    """``accept`` of :func:`refuse_constant_for_law` for an engine whose export runs :func:`check_step`
    (Gazebo's one constant, run in libode): the limits the drop test at the setup's step meets
    (:func:`checked_limits`), as options; the least rounded up where the engine is not installed here."""
    def trial(loose):
        runs = _run_confirmed(loose, engine, loose.dt_s, n_phases)
        if not isinstance(runs, DropRuns):
            return None
        return _meets(loose, runs), runs.worst_error, _depth(runs), runs.gain is not None, runs

    def accept(least):
        if not _installed(engine):
            return f"--tolerance {_round_up(least)}"            # not run here: the bound alone, as check_step
        tol, pen, refusal, runs = checked_limits(setup, least, 0.0, trial, margin=1.0)   # the same runs decide
        return "" if refusal or runs is None else _limit_options(tol, pen)
    return accept


def _limit_options(tolerance, penetration):
    """'--tolerance T --max-penetration P' of the limits given (None: left out)."""
    return " ".join(([f"--tolerance {tolerance:g}"] if tolerance is not None else []) +
                    ([f"--max-penetration {penetration:g}"] if penetration is not None else []))


def _contact_choice(setup, stiffness):
    """(kind, w) of MuJoCo's contact from ``--stiffness`` (None: the integrator's default)."""
    from vrcal.engines import mujoco as M

    if stiffness is None:
        return M.default_kind(setup), None
    s = float(stiffness)
    if not (math.isfinite(s) and s >= 0):
        raise UsageError(f"--stiffness must be a number >= 0 [1/s^2], got {s:g}")
    if s == 0:
        return "damper", None
    return "spring", math.sqrt(s / M.IMPEDANCE)


def trade_off(ball=None, engine="mujoco", *, n_phases=N_PHASES, against=None, stiffness=None, **options):
    """The achievable (step, contact, stiffness, damping, errors, penetration, hover) of MuJoCo.

    ``options`` as for :func:`build_setup`; ``against`` and ``stiffness`` are refused (the table
    chooses the contact; a pair is exported without it). When no row at the step, half and a fifth
    of it meets both limits, one more row: the largest smaller step that does, found by
    calibrating in MuJoCo (:func:`vrcal.engines.mujoco.suggest_dt`), or none when no step down to
    the run limit does.

    Returns
    -------
    (DropSetup, list of dict)
        the setup and one dict per calibration
    """
    eng = get_engine(engine)
    if eng.name != "mujoco":
        raise UsageError("--trade-off applies to MuJoCo (ODE and PyBullet take epsilon directly)")
    given = [flag for flag, value in (("--against", against), ("--stiffness", stiffness)) if value is not None]
    if given:
        raise UsageError(f"{' and '.join(given)} cannot go with --trade-off, which lists the contacts to choose "
                         "from for the ball on the floor: leave it out, then export the chosen row")
    from vrcal.engines import mujoco as M

    setup = build_setup(ball, "mujoco", **options)
    refuse_constant_for_law(setup, "MuJoCo", _mujoco_accept(setup, M.default_kind(setup), None, n_phases))
    found = M.trade_off(setup, n_phases)
    n_table = len(found)
    if found and not any(not isinstance(cal, str) and cal.ok and dt >= setup.dt_s for dt, *_, cal in found):
        dt_ok, cal, _ = M.suggest_dt(setup, n_phases)      # as the refusal of export at this step names
        passing = [dt for dt, *_, c in found if not isinstance(c, str) and c.ok]
        if dt_ok is not None and dt_ok > max(passing, default=0.0):
            found.append((dt_ok, cal.contact.kind, None, cal))
    rows = []
    for i, (dt, kind, w, cal) in enumerate(found):
        if isinstance(cal, str):                     # 'no bounce' or 'too high'
            rows.append({"dt_s": dt, "contact": kind, "stiffness_per_s2": M.IMPEDANCE * w * w, "damping_per_s": None,
                         "margin_m": None, "worst_error": None, "median_error": None, "penetration_m": None,
                         "hover_m": None, "ok": False, "suggested": False, "failure": cal})
            continue
        c = cal.contact
        rows.append({"dt_s": dt, "contact": c.kind, "stiffness_per_s2": c.stiffness,
                     "damping_per_s": c.damping, "margin_m": c.margin_m, "worst_error": cal.worst_error,
                     "median_error": cal.median_error, "penetration_m": cal.penetration_m, "hover_m": cal.hover_m,
                     "ok": bool(cal.ok), "suggested": i >= n_table})
    return setup, rows


def format_trade_off(setup, rows):
    """The trade-off rows as an aligned table for people (<= 100 columns)."""
    from vrcal.textout import number, table

    head = (f"MuJoCo trade-off: {setup.ball}, target epsilon {setup.epsilon:.4f}, {setup.integrator}, "
            f"{N_PHASES} phases x {counted(setup.n_bounces, 'bounce')}\n"
            f"limits: tolerance {setup.tolerance:g}, penetration {setup.penetration_limit_m * 1e3:.3g} mm "
            f"(a row that meets both: rerun over {CONFIRM_PHASES} phases)\n")
    def num(value, fmt):
        return "-" if value is None else format(value, fmt)

    cells = [[f"{r['dt_s']:g}", r["contact"], number(r["stiffness_per_s2"], 3),
              "-" if r["damping_per_s"] is None else number(r["damping_per_s"], 4),
              num(r["worst_error"], ".4f"), num(r["median_error"], ".4f"),
              "-" if r["penetration_m"] is None else f"{r['penetration_m'] * 1e3:.3g}",
              "-" if r["hover_m"] is None else f"{r['hover_m'] * 1e3:.3g}",
              ("yes" if r["ok"] else "no") if r["worst_error"] is not None else r.get("failure", "no bounce")]
             for r in rows]
    body = table(cells, ["dt s", "contact", "S 1/s2", "D 1/s", "worst err", "median err", "pen mm", "hover mm",
                         "meets"])
    return head + body + _next_step(setup, rows)


def _next_step(setup, rows):
    """The footer of the trade-off table: the options of the largest step that meets both limits."""
    ok = [r for r in rows if r["ok"]]
    if not ok:
        return ("no step meets both, down to the run limit: raise --tolerance or --max-penetration, or give "
                "fewer --bounces\n")
    best = max(ok, key=lambda r: (r["dt_s"], r["contact"] == "damper", -r["worst_error"]))
    spring = f" --stiffness {best['stiffness_per_s2']:.4g}" if best["contact"] == "spring" else ""
    if best["dt_s"] >= setup.dt_s:
        return f"your step meets both: export with --dt {best['dt_s']:g}{spring}\n"
    where = " (last row: searched in MuJoCo)" if best.get("suggested") else ""
    return f"--dt {setup.dt_s:g} misses; the largest step that meets both: --dt {best['dt_s']:g}{spring}{where}\n"


def step_bound(setup, engine="ode", n_bounces=None):
    """The largest epsilon error a step of dt can make in ODE or Bullet, and the depth it allows.

    ODE and Bullet detect a contact only once the ball is in the floor, up to ``v dt`` deep, and
    leave from there, so the next flight is lower by up to ``e v dt``: its apex ratio, and its
    speed at floor level (``v_out / v_in``, :func:`vrcal.engines.common.floor_speed_m_per_s`), are
    off by up to ``e v dt / (2 h) = g dt / (e v)`` at the last, slowest bounce (h its rebound).
    Worked out for the step the contact acts in (u the stored speed before it, z its depth in
    ``(-u dt, 0]``): ODE reverses the stored velocity to ``e u``, which gives errors from
    ``-(2 - e - e^2)/(2 e)`` to ``(1 - e)/2`` times ``g dt / u``; Bullet reverses it after the
    step's gravity, to ``e (u + g dt)``, from ``-(2 - 3 e)(1 + e)/(2 e)`` to ``(1 + e)/2`` times
    ``g dt / u`` (measured: a ping-pong ball of epsilon 0.9054 at 1 ms, 2.45 m/s, 0.9084..0.9092
    in PyBullet, the formula's 0.9084..0.9092; ODE at epsilon 1 exactly 1). Both lie within
    ``g dt / (e v)``. ``engine`` is kept for the callers (the bound is the same for both).

    Returns
    -------
    (bound, depth_m) : float, float
        the error bound, and the deepest the fastest impact can sink (``v_1 dt``) [m]
    """
    n_bounces = setup.n_bounces if n_bounces is None else n_bounces
    speeds = setup.impact_speeds_m_per_s[:n_bounces]
    v_last = float(speeds[-1])
    e = float(setup.epsilons[n_bounces - 1])
    h_last = float(setup.model.apex_heights_m[0, n_bounces])
    return e * v_last * setup.dt_s / (2.0 * h_last), float(np.max(speeds)) * setup.dt_s


#: Steps tried below a step that missed: each this much smaller than the last, at most this many.
STEP_RATIO, STEP_TRIES = 0.9, 12

#: What a refusal says of the steps ODE and Bullet pass: measured (benchmarks/bench_step_monotonic.py),
#: their epsilon error is not monotonic in the step (a ball of 200 g, 70 mm, epsilon 0.45 from
#: 0.5 m passes in Bullet at 1.15 ms and misses at 0.96 and 0.80 ms over 4 phases; in ODE at 0.96 ms
#: and misses at 8 smaller steps of the grid, 0.91, 0.85, 0.80, 0.76 ms, ...
NOT_MONOTONIC = "the error is not monotonic in the step: another, even a smaller one, can miss"

def check_step(setup, engine="ode", n_phases=N_PHASES):
    """Refuse a time step at which ODE or Bullet misses the tolerance or the penetration limit.

    The drop test runs in the engine at the step (Gazebo: in libode, the engine behind it), also
    where :func:`step_bound` meets both limits: the measured error exceeds that bound at some steps
    (``benchmarks/bench_step_monotonic.py``: ODE up to 1.10 times it on a 200 g, 70 mm ball of
    epsilon 0.45 from 0.5 m whose third impact is at 0.63 m/s; Bullet 0.012 at 0.2 ms and 0.11 at
    0.1 ms on that ball, where it says 0.007 and 0.003, before the export set ``contactSlop`` 0).
    A step that passes over ``n_phases`` contact phases is run again over :data:`CONFIRM_PHASES`
    (:func:`_run_confirmed`). A step that passes there is accepted and
    the measured numbers are returned as a note; a step that misses is refused with the measured
    numbers and a step that passed in the engine (:func:`passing_step`): ODE's and Bullet's error
    is not monotonic in the step, so no step is named that was not run. Only when the engine is
    not installed here does the bound decide (a refusal says so).

    Returns
    -------
    str
        the note of the step measured in the engine, or, when the engine is not installed here and
        the bound passed, a note starting :data:`vrcal.engines.common.NOT_RUN` that says so
    """
    bound, depth = step_bound(setup, engine)
    within = bound <= setup.tolerance and depth <= setup.penetration_limit_m
    run_in = runtime(engine)
    # refusals name ODE by its label, PyBullet by its registry name (as docs/engines/bullet.md shows); a
    # refusal's subject is the engine asked for, and the one its file runs in: Gazebo (ODE)
    label = run_in.label if run_in.name == "ode" else run_in.name
    asked = get_engine(engine)
    subject = label if asked.name == run_in.name else f"{asked.label} ({label})"
    runs = _run_confirmed(setup, engine, setup.dt_s, n_phases)
    if within and runs is None:
        name = engine_label(engine)
        later = (f"vrcal verify --file F runs the drop test where {name} is installed" if get_engine(engine).runs
                 else "export again where it is: the export runs the SDF's contact in libode")
        return (f"{NOT_RUN}: {name} is not installed here ({run_in.install}); by the step bound alone, step "
                f"{setup.dt_s:g} s moves epsilon by up to {bound:.3g} and the ball sinks up to {depth * 1e3:.3g} mm "
                f"(limits {setup.tolerance:g}, {setup.penetration_limit_m * 1e3:.3g} mm); {later}")
    if isinstance(runs, DropRuns) and _meets(setup, runs):
        fewer = (f" ({FEWER_PHASES} {CONFIRM_PHASES} phases: that many would pass the run limit of "
                 f"{run_in.max_steps:d} steps)"
                 if _phases(runs) < CONFIRM_PHASES else "")
        sub = f" ({setup.step_options})" if setup.substeps else ""
        return (f"step {setup.dt_s:g} s{sub} checked in {label} "
                f"({_phases(runs)} phases x {counted(setup.n_bounces, 'bounce')}): "
                f"worst epsilon error {runs.worst_error:.3g}, the ball turns {_depth(runs) * 1e3:.3g} mm from the "
                f"floor (limits {setup.tolerance:g}, {setup.penetration_limit_m * 1e3:.3g} mm){fewer}"
                + (f"; {runs.height_ratio_text()}" if runs.height_ratio_text() else "")
                + (f"; {runs.apex_text(setup.apex_goal, setup.apex_floor_m)}" if setup.apex_goal is not None
                   else ""))
    if runs is None:
        what = (f"time step {setup.dt_s:g} s is too large for {subject}: not run here ({label} is not installed); by "
                f"the step bound its contact acts only once the ball is up to {depth * 1e3:.3g} mm in the floor")
        if depth > setup.penetration_limit_m:
            what += f" (limit {setup.penetration_limit_m * 1e3:.3g} mm, --max-penetration)"
        if bound > setup.tolerance:
            what += f", which can move epsilon by up to {bound:.3g} (> tolerance {setup.tolerance:g})"
        dt_bound = round_down(setup.dt_s * min(0.95 * setup.tolerance / bound,
                                               0.95 * setup.penetration_limit_m / depth, 0.9))
        raise UsageError(f"{what}; by the bound --dt {dt_bound:g} meets both (not run: vrcal verify runs it where "
                         f"{label} is installed)")
    keep = ""
    if isinstance(runs, DropRuns):
        wide = runs if _phases(runs) >= CONFIRM_PHASES else _run_in_engine(setup, engine, setup.dt_s, CONFIRM_PHASES)
        wide = wide if isinstance(wide, DropRuns) else runs      # over as many phases as an export confirms with
        # the misses are reported over those phases (they hold the search's), the ones the limits offered cover:
        # '4 phases: 17.9 mm' offered '--max-penetration 0.021', which the ball needs over 16
        worst, depth = max(wide.worst_error, runs.worst_error), max(_depth(wide), _depth(runs))
        gained = runs if runs.gain is not None else wide if wide.gain is not None else None
        keep = "" if gained else keep_step(setup, worst, depth)       # no tolerance accepts a gain
        misses = []
        if worst > setup.tolerance:
            misses.append(f"worst epsilon error {_above(worst, setup.tolerance)} (tolerance {setup.tolerance:g})")
        if gained is not None:
            misses.append(f"{gained.gain_text()}, whatever the tolerance")
        if depth > setup.penetration_limit_m:
            depth_mm = _above(depth * 1e3, setup.penetration_limit_m * 1e3)
            misses.append(f"the ball turns {depth_mm} mm from the floor "
                          f"(limit {setup.penetration_limit_m * 1e3:.3g} mm, --max-penetration)")
        apex_run = next((r for r in (wide, runs) if r.apex_miss(setup.apex_goal, setup.apex_floor_m)), None)
        if apex_run is not None:
            k, err, _ = apex_run.worst_apex(setup.apex_floor_m, setup.apex_goal)
            misses.append(f"rebound {k}'s apex is {100 * err:+.1f} % off vrcal's model of the record (goal within "
                          f"{100 * setup.apex_goal:g} % or {setup.apex_floor_m * 1e3:.3g} mm, as vrcal verify "
                          f"--against judges it: each bounce's error compounds; no limit option widens it)")
            keep = ""      # --tolerance and --max-penetration would be refused again on the apexes
        what = f"{_phases(wide)} phases x {counted(setup.n_bounces, 'bounce')}): {'; '.join(misses)}"
        scale = min(setup.tolerance / max(runs.worst_error, 1e-12),
                    setup.penetration_limit_m / max(_depth(runs), 1e-12))
        if runs.gain is not None:        # the gain above the target grows with the step (g dt / v): below 1 again
            top = float(np.max(runs.target_epsilons))
            scale = min(scale, (1.0 - top) / max(runs.gain - top, 1e-12))
    else:                                        # no drop test: the ball did not bounce as asked, or too long a run
        what = f"no drop test): {runs}"
        scale = min(setup.tolerance / bound, setup.penetration_limit_m / depth)
    if setup.substeps:                           # a step of the user's: more substeps of it
        how = _substeps_text(setup, engine, n_phases, label)
        raise UsageError(f"{subject} at {setup.step_options} misses ({what}; {how}" + (f"; {keep}" if keep else ""))
    dt_ok, ok, tried = passing_step(setup, engine, setup.dt_s * min(1.25 * scale, STEP_RATIO), n_phases)
    missed = [dt for dt in tried if dt != dt_ok]
    above = (f"; {_steps_text(missed)} missed" if missed else "")
    if ok is not None:
        both = "both" if setup.apex_goal is None else "them and the apex goal"
        how = (f"--dt {dt_ok:g} meets {both} (run in {label}: error {ok.worst_error:.3g}, {_depth(ok) * 1e3:.3g} mm"
               f"{above}; {NOT_MONOTONIC})")
    else:
        how = (f"none of the steps run in {label} met both ({_steps_text(tried)}): raise --tolerance or "
               "--max-penetration" + (", or give an epsilon further below 1" if isinstance(runs, DropRuns)
                                      and runs.gain is not None else ""))
    raise UsageError(f"{subject} at {setup.step_options} misses ({what}; {how}" + (f"; {keep}" if keep else ""))


#: The most PyBullet substeps a refusal's search tries (:func:`passing_substeps`).
MAX_SUBSTEPS = 256


def passing_substeps(setup, engine, n_phases=N_PHASES, most=MAX_SUBSTEPS):
    """The fewest PyBullet substeps of the setup's ``stepSimulation()`` step (``setup.substeps x setup.dt_s``)
    at which the drop test passes in the engine: doubled from ``setup.substeps`` (which missed) until a count
    passes, then bisected between the last that missed and it (:func:`_run_confirmed`, the check an export at
    it runs). Returns (substeps, its DropRuns, the largest count run that missed) or (None, None, that count)."""
    outer = setup.dt_s * setup.substeps

    def run(count):
        runs = _run_confirmed(replace(setup, substeps=count), engine, outer / count, n_phases)
        return isinstance(runs, DropRuns) and _meets(setup, runs), runs

    miss, count = setup.substeps, 2 * setup.substeps
    while True:
        ok, runs = run(count)
        if ok:
            break
        miss, count = count, 2 * count
        if count > most or runs is None:
            return None, None, miss
    count, runs, miss = bisect_boundary(lambda mid: run(int(mid)), count, runs, miss)
    return int(count), runs, int(miss)


def _substeps_text(setup, engine, n_phases, label):
    """A refusal's clause naming the substeps of the user's step that meet the limits (:func:`passing_substeps`)."""
    count, ok, miss = passing_substeps(setup, engine, n_phases)
    outer = setup.dt_s * setup.substeps
    if ok is None:
        return (f"up to {miss:d} substeps of --dt {outer:g} s none met both in {label}: raise --tolerance or "
                "--max-penetration")
    return (f"--dt {outer:g} --substeps {count:d} meets both (run in {label}: step {outer / count:.3g} s, error "
            f"{ok.worst_error:.3g}, {_depth(ok) * 1e3:.3g} mm; --substeps {miss:d} missed; {NOT_MONOTONIC})")


def keep_limits(setup, worst_error, depth_m, margin=1.0):
    """The limits that accept the user's own step: ``(tolerance or None, max_penetration [m] or None, refusal)``,
    the ``--tolerance`` and ``--max-penetration`` that the drop test at ``setup.dt_s`` met (its worst epsilon
    error and how far the ball turned from the floor [m], each rounded up), None for one it did not miss;
    ``refusal`` is '' or why no limit keeps the step: a depth at or above the ball's radius is no limit to give
    (:func:`vrcal.engines.common.check_max_penetration`). ``margin`` (>= 1) widens both first: MuJoCo's
    calibration at a looser limit picks another contact, which goes deeper (a tennis ball at 4 ms: 13.3 mm at
    the 8.37 mm limit, 14.002 mm at a 14 mm one)."""
    worst_error, depth_m = worst_error * margin, depth_m * margin
    tolerance = float(_round_up(worst_error)) if worst_error > setup.tolerance else None
    if depth_m <= setup.penetration_limit_m:
        return tolerance, None, ""
    if depth_m >= setup.radius_m:
        measured = depth_m / margin
        why = (f"beyond its radius {setup.radius_m * 1e3:.3g} mm: its centre passes the floor's surface (against a "
               f"thin floor, a box or a mesh rather than a plane, a faster impact can pass through it)"
               if measured >= setup.radius_m else
               f"and {margin - 1:.0%} more, the margin a looser calibration needs, reaches its radius "
               f"{setup.radius_m * 1e3:.3g} mm")
        # what a user whose step is fixed gets there: both numbers, measured
        return tolerance, None, (f"no --max-penetration keeps {setup.step_options}: the ball turns "
                                 f"{measured * 1e3:.3g} mm from the floor, {why}; at {setup.step_options} "
                                 f"the drop test measured worst epsilon error {worst_error / margin:.3g}"
                                 + (f" (--tolerance {tolerance:g} accepts it)" if tolerance is not None else "")
                                 + " and that depth, which no limit accepts")
    return tolerance, min(float(_round_up(depth_m)), round_down(setup.radius_m * (1 - 1e-9))), ""


def keep_step(setup, worst_error, depth_m, margin=1.0):
    """What accepts the user's own step, as text (:func:`keep_limits`): 'to keep --dt ... s, accept what it
    achieves: --tolerance T --max-penetration P' with only the limits it missed, the refusal when no limit
    keeps it, '' when neither is needed."""
    return keep_text(setup, *keep_limits(setup, worst_error, depth_m, margin))


def keep_text(setup, tolerance, penetration, refusal):
    """:func:`keep_step`'s text of the limits :func:`keep_limits` gives."""
    if refusal:
        return refusal
    options = _limit_options(tolerance, penetration)
    if not options:
        return ""
    return f"to keep {setup.step_options}, accept what it achieves: {options}"


def _steps_text(steps):
    """The steps a search ran, for a message: 'a, b and c s' or 'a ... z s (N steps)' [s]."""
    if len(steps) <= 3:
        text = ", ".join(f"{dt:g}" for dt in steps[:-1]) + (" and " if len(steps) > 1 else "") + f"{steps[-1]:g}"
        return f"{text} s"
    return f"{steps[0]:g} ... {steps[-1]:g} s ({len(steps)} steps)"


def passing_step(setup, engine, start_s, n_phases=N_PHASES, ratio=STEP_RATIO, tries=STEP_TRIES):
    """The largest step of ``start_s``, ``ratio start_s``, ... (two significant digits, at most
    ``tries``) at which the drop test passes in the engine, each run there, then refined by bisection
    between it and the smallest step above it that missed (``setup.dt_s``, the step that was refused,
    when the first passed) to :func:`vrcal.engines.common.step_resolution_s`
    (:func:`vrcal.engines.common.refine_step`).

    ODE's and Bullet's epsilon error is not monotonic in the step (:data:`NOT_MONOTONIC`), so no
    step is inferred: the step returned is one that was run and passed, with a step at most one
    resolution above it that was run and missed. A step the engine cannot run (too many steps, no
    bounce) counts as a miss.

    Returns
    -------
    (float or None, DropRuns or None, list of float)
        the step [s] and its runs (None, None when none passed or the engine is not installed here),
        and the steps run that missed, largest first, then the step returned
    """
    tried = []
    dt = start_s

    def run(dt_s):
        runs = _run_confirmed(setup, engine, dt_s, n_phases)
        return isinstance(runs, DropRuns) and _meets(setup, runs), runs

    for _ in range(tries):
        dt_try = round_down(dt)
        dt = dt * ratio
        if dt_try in tried:
            continue
        ok, runs = run(dt_try)
        if runs is None:
            return None, None, tried
        if ok:
            above = [t for t in tried if t > dt_try]
            dt_ok, runs, dt_miss = refine_step(run, dt_try, runs, min(above, default=setup.dt_s))
            missed = sorted(set(above) | ({dt_miss} if dt_miss < setup.dt_s else set()), reverse=True)
            return dt_ok, runs, missed + [dt_ok]
        tried.append(dt_try)
    return None, None, tried


def _run_confirmed(setup, engine, dt_s, n_phases=N_PHASES):
    """:func:`_run_in_engine` at ``n_phases``, confirmed over :data:`CONFIRM_PHASES` phases where a
    step meets both limits (:func:`vrcal.engines.common.confirmed`, as MuJoCo's calibration is)."""
    runs = _run_in_engine(setup, engine, dt_s, n_phases)
    run_in = runtime(engine)
    return confirmed(runs, isinstance(runs, DropRuns) and _meets(setup, runs), replace(setup, dt_s=dt_s), n_phases,
                     run_in.label, run_in.max_steps, lambda phases: _run_in_engine(setup, engine, dt_s, phases))


def _phases(runs):
    """How many contact phases a drop test ran."""
    return runs.apex_ratios.shape[0]


def _depth(runs):
    """How far from the floor a run's contacts turned the ball [m]: penetration or hover."""
    return max(runs.penetration_m, runs.hover_m)


def _meets(setup, runs):
    return (runs.worst_error <= setup.tolerance and _depth(runs) <= setup.penetration_limit_m and runs.gain is None
            and not runs.apex_miss(setup.apex_goal, setup.apex_floor_m))


def _installed(engine):
    """Whether the engine ``engine``'s drop test runs in (ODE for Gazebo) is installed here."""
    from vrcal.engines import require_runtime
    from vrcal.errors import EngineUnavailable

    try:
        require_runtime(runtime(engine).name)
    except (EngineUnavailable, UsageError):
        return False
    return True


def _run_in_engine(setup, engine, dt_s, n_phases=N_PHASES):
    """The drop test of ``setup`` at ``dt_s`` in ODE (also for Gazebo) or Bullet: a DropRuns; a str
    saying why there is none (the ball did not bounce as asked, the run is too long); None when the
    engine is not installed here."""
    from vrcal.engines.common import check_steps

    run_in = runtime(engine)
    if not _installed(engine):
        return None
    trial = replace(setup, dt_s=dt_s)
    try:
        check_steps(trial, n_phases, run_in.label, run_in.max_steps)
    except UsageError as exc:
        return str(exc)
    try:
        return load(run_in.name).drop_test(_run_params(trial, engine), trial, trial.n_bounces, n_phases)
    except DataError as exc:
        return str(exc)


def _run_params(setup, engine):
    """The parameters ODE (also Gazebo's SDF, with its one constant) or Bullet runs ``setup`` with."""
    if get_engine(engine).name == "gazebo":                 # the SDF's surfaces, combined as Gazebo does
        return load("gazebo").setup_params(setup)
    params = load(runtime(engine).name).export_params(setup, setup.n_bounces)
    if get_engine(engine).one_epsilon and params.pop("restitution_law", None):   # e.g. the SDF's one constant
        from vrcal.engines.common import constant_epsilon

        params["contact"]["bounce"] = constant_epsilon(setup)
    return params


#: The low-speed scan below a drop test's slowest impact (:func:`speed_coverage`): speeds halve from it,
#: then the step between the last that held and the first that missed is split this many times.
LOW_SPEED_HALVINGS, LOW_SPEED_SPLITS = 6, 3


@dataclass(frozen=True)
class SpeedCoverage:
    """Impact speeds an export was checked over, and how far below them its contact was measured to hold.

    Attributes
    ----------
    fastest_m_per_s, slowest_m_per_s : float
        first and last impact speed of the drop test the export was checked (or calibrated) with
    holds_down_to_m_per_s : float
        the lowest single impact measured (one bounce from rest, :data:`N_PHASES` phases) at which the
        error stays within the tolerance, every speed between it and ``slowest_m_per_s`` too
    miss : tuple or None
        (speed [m/s], worst error) of the fastest impact measured that missed, None when none did
    asked_m_per_s : float or None
        the slowest speed of ``--impact-speed LO:HI`` when the drop test did not reach it
    at_asked : float or str or None
        the worst error measured there (a str: why there is no measurement)
    """

    fastest_m_per_s: float
    slowest_m_per_s: float
    holds_down_to_m_per_s: float
    miss: tuple | None = None
    asked_m_per_s: float | None = None
    at_asked: float | str | None = None

    def note(self, tolerance):
        """The line a file's header carries (< 100 columns, no two dashes: it goes into XML comments)."""
        line = (f"checked over impact speeds {self.fastest_m_per_s:.3g}..{self.slowest_m_per_s:.3g} m/s; "
                f"holds down to {self.holds_down_to_m_per_s:.3g} m/s (single bounces, {N_PHASES} phases)")
        if self.miss and math.isfinite(self.miss[1]):
            line += f" (at {self.miss[0]:.3g} m/s off by {_above(self.miss[1], tolerance)} > {tolerance:g})"
        elif self.miss:
            line += f" (at {self.miss[0]:.3g} m/s no bounce as the target's)"
        return line

    def shortfall(self, tolerance):
        """What the terminal says when ``--impact-speed LO:HI``'s LO was not reached, else '': what the
        contact does at LO, and where it misses there, what to do."""
        if self.asked_m_per_s is None:
            return ""
        what = (f"--impact-speed: the drop test covers {self.fastest_m_per_s:.3g}..{self.slowest_m_per_s:.3g} m/s, "
                f"not down to {self.asked_m_per_s:g} m/s; measured below it: holds down to "
                f"{self.holds_down_to_m_per_s:.3g} m/s")
        if isinstance(self.at_asked, str):
            return what + f"; at {self.asked_m_per_s:g} m/s {self.at_asked}"
        verdict = "within" if self.at_asked <= tolerance else "MISSES"
        fix = "" if self.at_asked <= tolerance else \
            f": for impacts that slow, {export_for_speeds(self.slowest_m_per_s, self.asked_m_per_s)}"
        return what + (f"; at {self.asked_m_per_s:g} m/s one bounce is off by {self.at_asked:.3g} ({verdict} "
                       f"--tolerance {tolerance:g}){fix}")

    def slower(self, setup, engine):
        """What the terminal says below :meth:`note` when a slower impact was measured to miss (else
        ''): the fall that gives the speed held down to (a lower drop, or a bounce from a lower apex,
        hits slower) and how to get a file for such a drop, or check this one there (``engine``: the
        export's, for the verify command)."""
        if self.miss is None:
            return ""
        fall_m = drop_height_for_speed_m(self.holds_down_to_m_per_s, setup.g_m_per_s2, setup.drag_k_per_m)
        return (f"slower impacts (falls from below {fall_m:.3g} m: a lower drop or apex) may miss: export with "
                f"--drop-height H, or check: vrcal verify --engine {get_engine(engine).name} --file FILE "
                f"--drop-height H")


def speed_coverage(setup, engine, runnable, asked_lo=None):
    """Measure how far below the drop test's slowest impact the exported contact keeps epsilon.

    Single bounces from rest (:data:`N_PHASES` phases each, the target vrcal's model) at half the
    slowest impact speed, a quarter, ... (:data:`LOW_SPEED_HALVINGS`, while the rebound rises
    :data:`RISE_M`), then the step between the last speed that held and the first that missed split
    :data:`LOW_SPEED_SPLITS` times (geometrically); and once at ``asked_lo`` [m/s] when the drop
    test did not reach it. MuJoCo's damper is tuned to the calibrated speeds (margin ``v dt/2``): a
    slower ball falls into the margin and bounces off it higher; ODE and Bullet's bounce holds.

    Parameters
    ----------
    setup : DropSetup
    engine : str
        ode, bullet, gazebo (run in libode) or mujoco
    runnable : dict or str
        the exported parameters (ODE, Bullet: the JSON dict; Gazebo: the ODE parameters it runs;
        MuJoCo: the MJCF text or its compiled model)
    asked_lo : float or None
        the slowest speed of ``--impact-speed LO:HI`` [m/s]

    Returns
    -------
    SpeedCoverage or None
        None for a speed-dependent epsilon (its law's reference is the drop's first impact) or an
        engine not installed here
    """
    if setup.restitution_exponent or setup.drop_height_m is None or runnable is None:
        return None
    module = load(runtime(engine).name)
    v = setup.impact_speeds_m_per_s
    fastest, slowest = float(v[0]), float(v[-1])

    def error_at(speed):
        trial = replace(setup, drop_height_m=drop_height_for_speed_m(speed, setup.g_m_per_s2, setup.drag_k_per_m),
                        n_bounces=1, notes=())
        if float(trial.model.apex_heights_m[0][-1]) < RISE_M:
            return f"a bounce rises less than {RISE_M * 1e3:g} mm (not measured)"
        try:
            return float(module.drop_test(runnable, trial, 1, N_PHASES).worst_error)
        except (DataError, UsageError) as exc:
            return str(exc)

    held, miss = slowest, None
    for _ in range(LOW_SPEED_HALVINGS):
        err = error_at(held / 2.0)
        if isinstance(err, str) and "not measured" in err:
            break
        if isinstance(err, str) or err > setup.tolerance:
            miss = (held / 2.0, err if not isinstance(err, str) else float("inf"))
            break
        held /= 2.0
    if miss is not None:
        for _ in range(LOW_SPEED_SPLITS):
            mid = math.sqrt(held * miss[0])
            err = error_at(mid)
            if isinstance(err, float) and err <= setup.tolerance:
                held = mid
            else:
                miss = (mid, err if isinstance(err, float) else float("inf"))
    at_asked = None
    if asked_lo is not None and asked_lo < slowest * (1 - 1e-6):
        at_asked = error_at(asked_lo)
    else:
        asked_lo = None
    return SpeedCoverage(fastest, slowest, held, miss, asked_lo, at_asked)


def parse_exported(engine, text):
    """Read an exported file back: the JSON dict (ode, bullet) or the MJCF text (mujoco).

    Raises DataError (one line) for a file that is not a vrcal export of that engine.
    """
    eng = get_engine(engine)
    if eng.name in ("ode", "bullet"):
        from vrcal.engines.files import read_params

        return read_params(eng.name, text)
    return text


