"""Export a calibrated epsilon to a physics engine: one function, text out (the CLI writes it).

The target comes from the ball's standard (Eq. 9 of [1], drop and rebound both to the
ball's bottom; ``--epsilon`` overrides it). ``--floor`` and ``--against`` add a second body;
Eq. (6) of [1] adds the contact times, so for bodies calibrated at the same K the pair's
epsilon is the product of each body's epsilon against a rigid floor.
"""

from __future__ import annotations

import json
from dataclasses import dataclass

from vrcal.engines import get_engine, load
from vrcal.engines.common import GRAVITY_M_PER_S2, DropSetup, check_dt, check_epsilon
from vrcal.errors import UsageError
from vrcal.fileio import dumps
from vrcal.inverse import DEFAULT_K_PER_S, parse_body
from vrcal.model import restitution as eq
from vrcal.model.standards import ball_epsilon, get_ball

N_BOUNCES = 3


@dataclass(frozen=True)
class Export:
    """An exported engine file: its text, the data behind it, and the drop setup."""

    engine: str
    fmt: str
    text: str
    data: dict
    setup: DropSetup
    pair: dict | None


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


def build_setup(ball, engine, epsilon=None, dt_s=None, floor=None, standards=None, K_per_s=DEFAULT_K_PER_S):
    """The :class:`DropSetup` of a ball of the standards for an engine.

    ``epsilon`` (None: the standard's nominal value) is the ball's value against a rigid floor;
    ``floor`` is 'rigid' (default), a ball key, or 'x=DEPTH,v=SPEED' (a compliant floor's
    virtual body); the target is then the pair value (Eq. 6).
    """
    b = get_ball(ball, standards) if isinstance(ball, str) else ball
    eng = get_engine(engine)
    window = ball_epsilon(b)
    if epsilon is None:
        eps_ball = window.nominal
        note = f"epsilon {eps_ball:.6f}: nominal of the {b.association} window ({window.convention})"
    else:
        eps_ball = check_epsilon(epsilon, "--epsilon")
        note = f"epsilon {eps_ball:.6f} given with --epsilon"
    eps_floor, floor_name = 1.0, "rigid floor"
    if floor is not None and str(floor).strip().lower() not in ("rigid", "floor", "steel"):
        floor_name, _, eps_floor = parse_body(floor, K_per_s, standards)
        eps_floor = float(eps_floor)
    target = float(combine_epsilons(eps_ball, eps_floor, K_per_s))
    dt = check_dt(eng.default_dt_s if dt_s is None else dt_s)
    notes = (note,)
    if eps_floor != 1.0:
        notes += (f"floor {floor_name}: epsilon {eps_floor:.6f}; pair {eps_ball:.6f} x {eps_floor:.6f} = "
                  f"{target:.6f} (Eq. 6)",)
    return DropSetup(
        ball=b.key, mass_kg=b.mass_kg.nominal, radius_m=b.radius_m, drop_height_m=window.drop_height_m,
        epsilon=check_epsilon(target), dt_s=dt, g_m_per_s2=GRAVITY_M_PER_S2, ball_epsilon=eps_ball,
        floor_epsilon=eps_floor, notes=notes,
    )


def export(ball, engine, *, epsilon=None, dt_s=None, floor=None, against=None, standards=None,
           K_per_s=DEFAULT_K_PER_S, tolerance=0.005):
    """Export ``ball``'s calibrated epsilon for ``engine``.

    Parameters
    ----------
    ball : str
        ball key of the standards
    engine : str
        mujoco, ode, bullet, gazebo or tables (physx/unity/box2d)
    epsilon : float, optional
        the ball's epsilon against a rigid floor (default: the standard's nominal value)
    dt_s : float, optional
        engine time step [s] (default: the engine's entry in :data:`vrcal.engines.ENGINES`)
    floor : str, optional
        'rigid' (default), or a body spec (ball key, 'x=..,v=..') for a compliant floor
    against : str, optional
        a second ball: adds the ball/ball2 pair value from Eq. (6)
    standards : dict, optional
        from :func:`vrcal.model.standards.load_standards`
    K_per_s : float
        rate constant K [1/s] (the pair value does not depend on it)
    tolerance : float
        the time step must keep the predicted error below this

    Returns
    -------
    Export
    """
    eng = get_engine(engine)
    setup = build_setup(ball, eng.name, epsilon, dt_s, floor, standards, K_per_s)
    pair = second = pair_setup = None
    if against is not None:
        b2 = get_ball(against, standards)
        eps2 = ball_epsilon(b2).nominal
        eps_pair = float(combine_epsilons(setup.ball_epsilon, eps2, K_per_s))
        pair = {"name": f"{setup.ball}/{b2.key}", "ball2": b2.key, "epsilon_ball2": eps2, "epsilon": eps_pair,
                "equation": "Eq. 6: T = T_A + T_B, epsilon = exp(-K T) = epsilon_A * epsilon_B"}
        second = DropSetup(ball=b2.key, mass_kg=b2.mass_kg.nominal, radius_m=b2.radius_m,
                           drop_height_m=ball_epsilon(b2).drop_height_m, epsilon=eps2, dt_s=setup.dt_s,
                           g_m_per_s2=setup.g_m_per_s2, ball_epsilon=eps2)
        # g = 0: both balls fall alike, the contact sees only their relative motion
        pair_setup = DropSetup(ball=pair["name"], mass_kg=setup.mass_kg, radius_m=setup.radius_m,
                               drop_height_m=setup.drop_height_m, epsilon=eps_pair, dt_s=setup.dt_s,
                               g_m_per_s2=0.0)
    module = load(eng.name)
    if eng.name == "mujoco":
        text = module.export_mjcf(setup, N_BOUNCES, tolerance,
                                  pair_bodies=[second, pair_setup] if pair else None)
        if pair:
            text = text.replace(
                "  <contact>",
                f"  <!-- pair {pair['name']}: Eq. 6 gives {pair['epsilon']:.6f}; MuJoCo would average the two\n"
                "       geoms' solref, so the ball/ball2 contact has its own <pair> with the pair's solref -->\n"
                "  <contact>", 1)
        data = {"engine": "mujoco", "target_epsilon": setup.epsilon}
    elif eng.name in ("ode", "bullet"):
        _check_step(setup, tolerance)
        data = module.export_params(setup, N_BOUNCES, pair)
        data["how_chosen"] = list(setup.notes)
        data["snippet"] = module.c_snippet(data) if eng.name == "ode" else module.py_snippet(data)
        if pair:
            data["pair"] = pair
        text = dumps(data, "json")
    elif eng.name == "gazebo":
        _check_step(setup, tolerance)                    # Gazebo runs ODE: the same limit
        text = module.export_sdf(setup, pair, second)
        data = {"engine": "gazebo", "target_epsilon": setup.epsilon}
    else:
        text = module.format_table(setup, pair)
        data = {"engine": "tables", "rows": module.table(setup, pair)}
    return Export(eng.name, eng.fmt, text, data, setup, pair)


def _check_step(setup, tolerance, n_bounces=N_BOUNCES):
    """Refuse a time step whose penetration (up to v dt at the bounce) moves the last apex by > tolerance."""
    e = setup.epsilon
    v_last = setup.impact_speed_m_per_s * e ** (n_bounces - 1)
    h_last = (e * v_last) ** 2 / (2.0 * setup.g_m_per_s2)
    bound = e * v_last * setup.dt_s / (2.0 * h_last)
    if bound > tolerance:
        dt_ok = setup.dt_s * tolerance / bound
        raise UsageError(
            f"time step {setup.dt_s:g} s is too large: the ball may sink up to {v_last * setup.dt_s * 1000:.2g} mm "
            f"into the floor at bounce {n_bounces} before the contact acts, which can move epsilon by "
            f"{bound:.3g} (> tolerance {tolerance:g}); use --dt {dt_ok:.2g} or smaller"
        )


def parse_exported(engine, text):
    """Read an exported file back: the JSON dict (ode, bullet) or the MJCF text (mujoco)."""
    eng = get_engine(engine)
    if eng.name in ("ode", "bullet"):
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise UsageError(f"not a vrcal {eng.name} export (JSON): line {exc.lineno}: {exc.msg}") from None
        if data.get("engine") != eng.name:
            raise UsageError(f"not a vrcal {eng.name} export: engine is {data.get('engine')!r}")
        return data
    return text
