"""Inverting Eqs. (7) and (10) of [1]: from a ball's epsilon to families of virtual bodies (x, v).

For a chosen K, epsilon fixes the contact time T = -ln(epsilon)/K (Eq. 7), and every
virtual body with x/(2v) = T (Eq. 10) gives that epsilon: a straight line through the
origin in the (x, v) plane, v = x/(2T). The virtual body lies inside the ball, so its
depth x is at most the ball's radius; the family spans (0, R].

Two bodies (Eq. 6): the contact times add, T = T_A + T_B, so the pair's epsilon is
exp(-K (T_A + T_B)) = epsilon_A * epsilon_B for bodies each calibrated against a rigid
floor at the same K -- whatever member of its family each body uses.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vrcal.errors import UsageError
from vrcal.model import restitution as eq
from vrcal.model.restitution import DEFAULT_K_PER_S, check_K
from vrcal.model.standards import ball_epsilon, get_ball

_LEVELS = ("min", "nominal", "max")


def family(T_s, x_max_m, n):
    """``n`` virtual bodies (x, v) with x/(2v) = T, x evenly spaced in (0, x_max].

    Parameters
    ----------
    T_s : float
        contact time [s], > 0
    x_max_m : float
        largest depth [m], > 0 (the ball's radius)
    n : int
        number of members, >= 1

    Returns
    -------
    x_m, v_m_per_s : ndarray
    """
    if int(n) < 1:
        raise UsageError(f"--n must be at least 1, got {n}")
    x = np.linspace(x_max_m / n, x_max_m, int(n))
    return x, np.asarray(eq.virtual_speed_m_per_s(x, T_s))


@dataclass(frozen=True)
class VirtualBody:
    """A body's virtual body: depth x [m] and speed v [m/s]; x = 0 for a rigid floor."""

    x_m: float
    v_m_per_s: float

    @property
    def contact_time_s(self):
        return eq.contact_time_single_s(self.x_m, self.v_m_per_s)


def fit_ball(ball, K_per_s=DEFAULT_K_PER_S, *, x_m=None, v_m_per_s=None, n=11, as_paper=False):
    """The parameter set of a ball: epsilon window, T window, and its (x, v) family.

    Parameters
    ----------
    ball : Ball or str
        a ball of the standards, or its key
    K_per_s : float
        rate constant K of Eq. (7) [1/s], > 0
    x_m : float, optional
        fix the virtual body's depth [m]; the result gives v for epsilon min..max
    v_m_per_s : float, optional
        fix the virtual body's speed [m/s]; the result gives x for epsilon min..max
    n : int
        number of family members (x evenly spaced in (0, R])
    as_paper : bool
        use the paper's Table 1 heights as printed (see :func:`vrcal.model.standards.ball_epsilon`)

    Returns
    -------
    dict
        JSON-ready; every key carries its unit.
    """
    if isinstance(ball, str):
        ball = get_ball(ball)
    K = check_K(K_per_s)
    if x_m is not None and v_m_per_s is not None:
        raise UsageError("give --x or --v, not both")
    window = ball_epsilon(ball, as_paper=as_paper)
    eps = window.as_dict()
    T = {k: eq.contact_time_from_epsilon_s(eps[k], K) for k in _LEVELS}  # keyed by the epsilon level
    R = ball.radius_m
    out = {
        "ball": ball.key,
        "ball_name": ball.name,
        "association": ball.association,
        "official_rule": ball.official,
        "convention": window.convention,
        "K_per_s": K,
        "epsilon": eps,
        "T_s": _bounds(T),
        "bounds": "min and max are the smallest and largest value of each quantity over epsilon min..max; "
                  "the shortest T, the fastest v (at fixed x) and the shallowest x (at fixed v) give epsilon max",
        "drop_height_m": window.drop_height_m,
        "rebound_height_m": window.rebound_m.as_dict(),
        "mass_kg": ball.mass_kg.nominal,
        "diameter_m": ball.diameter_m.nominal,
        "equations": "epsilon = exp(-K*T) (Eq. 7), T = x/(2*v) (Eq. 10), epsilon = sqrt(h/H) (Eq. 9)",
        "notes": list(ball.departures),
    }
    if T["nominal"] == 0:
        out["family"] = [{"x_m": 0.0, "v_m_per_s": None}]
    else:
        xs, vs = family(T["nominal"], R, n)
        out["family"] = [{"x_m": float(x), "v_m_per_s": float(v)} for x, v in zip(xs, vs)]
    if x_m is not None:
        if not (math.isfinite(x_m) and x_m > 0):
            raise UsageError(f"--x must be a finite depth > 0 [m], got {x_m!r}")
        out["fixed"] = {
            "x_m": float(x_m),
            "v_m_per_s": _bounds({k: _or_inf(lambda t: eq.virtual_speed_m_per_s(x_m, t), T[k]) for k in _LEVELS}),
        }
        if x_m > R:
            out["fixed"]["warning"] = f"x = {x_m:g} m is deeper than the ball's radius {R:g} m"
    if v_m_per_s is not None:
        if not (math.isfinite(v_m_per_s) and v_m_per_s > 0):
            raise UsageError(f"--v must be a finite speed > 0 [m/s], got {v_m_per_s!r}")
        out["fixed"] = {
            "v_m_per_s": float(v_m_per_s),
            "x_m": _bounds({k: eq.virtual_depth_m(v_m_per_s, T[k]) for k in _LEVELS}),
        }
    return out


def _bounds(by_level):
    """{min, nominal, max} of a quantity given per epsilon level: min and max by value."""
    lo, hi = sorted((by_level["min"], by_level["max"]))
    return {"min": lo, "nominal": by_level["nominal"], "max": hi}


def _or_inf(fn, T):
    return math.inf if T == 0 else fn(T)


def parse_body(spec, K_per_s, standards=None, as_paper=False):
    """A body for :func:`pair`: a ball key, 'floor' (rigid, x = 0), or 'x=..,v=..'.

    A ball is given the virtual body of its nominal epsilon at depth x = R/2 (any member
    of its family gives the same pair epsilon).
    """
    text = str(spec).strip()
    if text.lower() in ("floor", "steel", "rigid"):
        return text.lower(), VirtualBody(0.0, 0.0), 1.0
    if "=" in text:
        try:
            parts = dict(p.split("=", 1) for p in text.replace(" ", "").split(","))
            x, v = float(parts.pop("x")), float(parts.pop("v"))
        except (KeyError, ValueError):
            raise UsageError(f"body '{spec}': give a ball name, 'floor', or 'x=DEPTH_M,v=SPEED_M_PER_S'") from None
        if parts:
            raise UsageError(f"body '{spec}': unknown field(s) {sorted(parts)}; use x= and v=")
        body = VirtualBody(x, v)
        return text, body, eq.epsilon_single(x, v, K_per_s)
    ball = get_ball(text, standards)
    eps = ball_epsilon(ball, as_paper=as_paper).nominal
    T = eq.contact_time_from_epsilon_s(eps, K_per_s)
    x = ball.radius_m / 2.0
    v = eq.virtual_speed_m_per_s(x, T) if T > 0 else 0.0
    return ball.key, VirtualBody(x, v), eps


def pair(spec_a, spec_b, K_per_s=DEFAULT_K_PER_S, standards=None, as_paper=False):
    """epsilon of two colliding bodies from their virtual bodies, Eqs. (6) and (7) of [1].

    Returns
    -------
    dict
        each body's x, v, T and its own epsilon against a rigid floor, the pair's T and
        epsilon; JSON-ready.
    """
    K = check_K(K_per_s)
    bodies = [parse_body(s, K, standards, as_paper) for s in (spec_a, spec_b)]
    (name_a, a, eps_a), (name_b, b, eps_b) = bodies
    T = eq.contact_time_pair_s(a.x_m, a.v_m_per_s, b.x_m, b.v_m_per_s)
    eps = eq.epsilon_from_contact_time(T, K)
    return {
        "K_per_s": K,
        "bodies": [
            {"name": n, "x_m": body.x_m, "v_m_per_s": body.v_m_per_s, "T_s": body.contact_time_s,
             "epsilon_on_rigid_floor": e}
            for n, body, e in bodies
        ],
        "T_s": T,
        "epsilon": eps,
        "equations": "T = x_A/(2 v_A) + x_B/(2 v_B) (Eq. 6), epsilon = exp(-K T) (Eq. 7)",
    }
