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
from vrcal.textout import number, table, wrap

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


def fit_text(result):
    """:func:`fit_ball`'s result for people: epsilon first, then T, the drop test, the family, notes.

    Columns are the drop test's epsilon levels (min, nominal, max), so each column is one
    consistent set: T at epsilon min is the longest contact time. At most 100 columns;
    about 20 lines for a ball of the standards.
    """
    r = result
    K = r["K_per_s"]
    eps = r["epsilon"]
    T = {k: eq.contact_time_from_epsilon_s(eps[k], K) for k in _LEVELS}
    H, h = r["drop_height_m"], r["rebound_height_m"]
    rule = "official rule" if r["official_rule"] else "not an official rule"
    rows = [
        ["ε", *(number(eps[k], 4) for k in _LEVELS), "drop test, ε = √(h/H) (Eq. 9)"],
        ["T [ms]", *(_ms_or_inf(T[k]) for k in _LEVELS), f"contact time, T = −ln ε / K (Eq. 7), K = {K:g} 1/s"],
        ["H [m]", *(number(H, 4) for _ in _LEVELS), "drop height"],
        ["h [m]", *(number(h[k], 4) for k in _LEVELS), "rebound height"],
    ]
    fixed = r.get("fixed")
    if fixed and isinstance(fixed.get("v_m_per_s"), dict):
        x = fixed["x_m"]
        rows.append([f"v at x = {x * 1e3:.4g} mm [m/s]",
                     *(number(_or_inf(lambda t: eq.virtual_speed_m_per_s(x, t), T[k]), 4) for k in _LEVELS),
                     "v = x/(2T) (Eq. 10)"])
    elif fixed:
        v = fixed["v_m_per_s"]
        rows.append([f"x at v = {v:.4g} m/s [mm]",
                     *(number(eq.virtual_depth_m(v, T[k]) * 1e3, 4) for k in _LEVELS), "x = 2vT (Eq. 10)"])
    answer = (f"{r['ball']}: ε = {number(eps['nominal'], 3)} ({number(eps['min'], 3)} .. {number(eps['max'], 3)}), "
              f"T = {_ms_or_inf(T['nominal'], 3)} ms at K = {K:g} 1/s")
    text = wrap(answer) + wrap(f"{r['ball_name']}, {r['association']}, {rule}; heights: {r['convention']}") + "\n"
    text += table(rows, ["", "ε min", "nominal", "ε max", ""], align="lrrrl")
    if fixed and fixed.get("warning"):
        text += wrap(f"warning: {fixed['warning']}")
    members = r["family"]
    R = r["diameter_m"] / 2.0
    text += "\n" + wrap(f"virtual bodies (x, v) of ε nominal: x/(2v) = T (Eq. 10), x up to the radius "
                         f"R = {number(R * 1e3, 4)} mm")
    text += _family_rows(members)
    if r["notes"]:
        text += "\nnotes:\n" + "".join(wrap(n, first="  - ") for n in r["notes"])
    return text


def _ms_or_inf(T_s, digits=4):
    return "inf" if math.isinf(T_s) else number(T_s * 1e3, digits)


def _family_rows(members, width=100):
    """The family as two rows (x [mm], v [m/s]), wrapped into blocks that fit ``width`` columns."""
    xs = [number(m["x_m"] * 1e3, 3) for m in members]
    vs = ["inf" if m["v_m_per_s"] is None else number(m["v_m_per_s"], 3) for m in members]
    cell = max(len(c) for c in xs + vs)
    per_row = max(1, (width - 2 - 9) // (cell + 2))
    out = ""
    for i in range(0, len(members), per_row):
        out += table([["x [mm]", *xs[i:i + per_row]], ["v [m/s]", *vs[i:i + per_row]]],
                     ["", *[""] * len(xs[i:i + per_row])], align="l" + "r" * len(xs[i:i + per_row]),
                     indent="  ").split("\n", 1)[1]
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


def pair_text(result):
    """:func:`pair`'s result for people: the pair's epsilon first, then each body's virtual body."""
    r = result
    a, b = r["bodies"]
    rows = [[body["name"], number(body["x_m"] * 1e3, 4), number(body["v_m_per_s"], 4),
             _ms_or_inf(body["T_s"]), number(body["epsilon_on_rigid_floor"], 4)] for body in (a, b)]
    rows.append(["pair", "", "", _ms_or_inf(r["T_s"]), number(r["epsilon"], 4)])
    text = wrap(f"{a['name']} against {b['name']}: ε = {number(r['epsilon'], 3)}, "
                f"T = {_ms_or_inf(r['T_s'], 3)} ms at K = {r['K_per_s']:g} 1/s")
    text += "\n" + table(rows, ["body", "x [mm]", "v [m/s]", "T [ms]", "ε"], align="lrrrr")
    text += "\n" + wrap("T = x_A/(2 v_A) + x_B/(2 v_B) (Eq. 6), ε = exp(−K T) (Eq. 7). A body's ε is its ε "
                         "against a rigid floor; the contact times add, so the pair's ε is their product.")
    return text
