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
from vrcal.model.plausible import check_drop_test_height
from vrcal.model.restitution import DEFAULT_K_PER_S, check_epsilon, check_integer, check_K, check_number
from vrcal.model.standards import ball_epsilon, get_ball
from vrcal.textout import epsilon as epsilon_text
from vrcal.textout import mass, number, table, wrap

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
    n = check_integer(n, "--n")
    x_max_m = check_number(x_max_m, "x_max_m", unit="[m]")
    x = np.linspace(x_max_m / n, x_max_m, n)
    return x, np.asarray(eq.virtual_speed_m_per_s(x, T_s))


@dataclass(frozen=True)
class VirtualBody:
    """A body's virtual body: depth x [m] and speed v [m/s]; x = 0 for a rigid floor."""

    x_m: float
    v_m_per_s: float

    @property
    def contact_time_s(self):
        return eq.contact_time_single_s(self.x_m, self.v_m_per_s)


def fit_ball(ball, K_per_s=DEFAULT_K_PER_S, *, x_m=None, v_m_per_s=None, n=11, as_paper=False, epsilon=None,
             drop_height_m=None, rebound_height_m=None, drop_measured_to=None, rebound_measured_to=None,
             height_sd_m=None):
    """The parameter set of a body: epsilon (a window, or one value), T, and its (x, v) family.

    Parameters
    ----------
    ball : Body, Ball, str or None
        the body (:func:`vrcal.model.body.describe_body`: a ball of the standards, a user's
        own or a discover result's), a :class:`vrcal.model.standards.Ball`, or a ball's key; None
        for one's own drop test alone (``drop_height_m`` and ``rebound_height_m``): epsilon (Eq. 9) and
        T need no body, the (x, v) family (its depths reach the radius) and the air-drag check
        (:func:`drop_test_drag`) do, and a note says so
    K_per_s : float
        rate constant K of Eq. (7) [1/s], > 0
    x_m : float, optional
        fix the virtual body's depth [m]; the result gives v for each epsilon
    v_m_per_s : float, optional
        fix the virtual body's speed [m/s]; the result gives x for each epsilon
    n : int
        number of family members (x evenly spaced in (0, R])
    as_paper : bool
        use the paper's Table 1 heights as printed (see :func:`vrcal.model.standards.ball_epsilon`)
    epsilon : float, optional
        the body's epsilon against a rigid floor (``--epsilon``), instead of a standard's window
        or a discover result's value
    drop_height_m, rebound_height_m : float, optional
        your own drop test instead (``--drop-height``, ``--rebound-height``): drop height H and rebound
        height h [m] above the floor, both needed, each at most
        :data:`vrcal.model.plausible.MAX_DROP_TEST_M`; epsilon = sqrt(h/H), Eq. (9), with both heights
        of the ball's bottom, without air drag's correction (``vrcal discover`` on a one-row table
        gives the contact's own)
    drop_measured_to, rebound_measured_to : {"bottom", "centre", "top"}, optional
        the point of the ball H and h were read to (brought to the bottom with the body's diameter,
        :func:`vrcal.model.restitution.height_to_bottom_m`; default the bottom); a drop test's options
    height_sd_m : float, optional
        standard uncertainty of each height of one's own drop test [m] (``--height-sd``); default
        :func:`assumed_height_sd_m`. Gives ``epsilon_uncertainty`` (:func:`epsilon_uncertainty_from_heights`)

    Returns
    -------
    dict
        JSON-ready; every key carries its unit. A ball of the standards (without ``epsilon``)
        gives its drop test's window: ``epsilon``, ``T_s`` (and ``fixed``) with min, nominal
        and max, the drop and rebound heights, the association. Any other body has one
        epsilon: the same keys with ``nominal`` only, and ``epsilon_source`` saying where it
        came from (``--epsilon``, or the discover result with its ``drop_height_m``).

    Notes
    -----
    A ball of one's own has no rebound window to give min and max; a discover result's
    epsilon has an uncertainty (``epsilon_uncertainty``), not a window.
    """
    body = None if ball is None else _as_body(ball)
    K = check_K(K_per_s)
    if x_m is not None and v_m_per_s is not None:
        raise UsageError("give --x or --v, not both")
    if x_m is not None and not (math.isfinite(x_m) and x_m > 0):
        raise UsageError(f"--x must be a finite depth > 0 [m], got {x_m!r}")
    if v_m_per_s is not None and not (math.isfinite(v_m_per_s) and v_m_per_s > 0):
        raise UsageError(f"--v must be a finite speed > 0 [m/s], got {v_m_per_s!r}")
    own_test = None
    if any(a is not None for a in (drop_height_m, rebound_height_m, drop_measured_to, rebound_measured_to)):
        if epsilon is not None:
            raise UsageError("give --epsilon or the drop test's heights (--drop-height, --rebound-height), not both")
        epsilon, own_test = drop_test(body, drop_height_m, rebound_height_m, drop_measured_to or "bottom",
                                      rebound_measured_to or "bottom", height_sd_m)
    elif height_sd_m is not None:
        raise UsageError("--height-sd is the uncertainty of your own drop test's heights: give --drop-height and "
                         "--rebound-height with it")
    if body is None and own_test is None:
        raise UsageError("no body: give a ball of the standards, or --mass and --diameter (one's own drop test, "
                         "--drop-height and --rebound-height, needs none)")
    if body is not None and epsilon is None and body.discovered is None and body.standard is not None:
        out = _window_fit(body, K, as_paper)
        if not as_paper:   # the paper's Eq. 9 is drag-free: --as-paper reproduces it
            drag = drop_test_drag(body.mass_kg, body.diameter_m, out["drop_height_m"], out["rebound_height_m"],
                                  body.standard.key)
            drag.pop("notes", None)   # fit_text gives it a row of the window's table
            out.update(drag)
    else:
        out = _single_fit(body, K, as_paper, epsilon)
    if own_test is not None:
        out["notes"] = list(out.get("notes", [])) + own_test.pop("notes", [])
        out.update(own_test)
    if body is not None:
        out["notes"] = list(out.get("notes", [])) + buoyancy_notes(body.mass_kg, body.diameter_m)
    eps = out["epsilon"]
    T = {k: eq.contact_time_from_epsilon_s(eps[k], K) for k in eps}  # keyed by the epsilon level
    out["T_s"] = _bounds(T)
    R = None if body is None else body.radius_m   # no radius, no family: --x or --v still gives its partner
    if R is not None and T["nominal"] == 0:
        # epsilon = 1: T = 0 only at x = 0, a virtual body on the surface. [1] gives it no speed ("x = 0
        # therefore v = 0"), where Eq. 10 reads 0/0; x = 0 gives T = 0 for any v, as contact_time_single_s takes it
        out["family"] = [{"x_m": 0.0, "v_m_per_s": 0.0}]
        out["notes"].append("ε = 1 gives T = 0: the only virtual body is x = 0, on the ball's surface, and x = 0 "
                            "gives T = x/(2v) = 0 for any speed v. The file writes v = 0, as the paper's lossless "
                            "body, where x/(2v) reads 0/0: take T = 0 wherever x = 0 (vrcal does)")
        if x_m is not None:
            raise UsageError(f"--x {x_m:g}: ε = 1 gives T = 0, which only x = 0 has (v = x/(2T) would be infinite); "
                             "leave out --x, or give --v (x = 2vT = 0)")
    elif R is not None:
        xs, vs = family(T["nominal"], R, n)
        out["family"] = [{"x_m": float(x), "v_m_per_s": float(v)} for x, v in zip(xs, vs)]
    if x_m is not None:
        out["fixed"] = {
            "x_m": float(x_m),
            "v_m_per_s": _bounds({k: _or_inf(lambda t: eq.virtual_speed_m_per_s(x_m, t), T[k]) for k in T}),
        }
        if R is not None and x_m > R:
            out["fixed"]["warning"] = f"x = {x_m:g} m is deeper than the ball's radius {R:g} m"
    if v_m_per_s is not None:
        out["fixed"] = {
            "v_m_per_s": float(v_m_per_s),
            "x_m": _bounds({k: eq.virtual_depth_m(v_m_per_s, T[k]) for k in T}),
        }
    return out


#: The note of one's own drop test without a body (:func:`fit_ball` with ``ball=None``).
NO_BODY_NOTE = ("no ball given: ε = √(h/H) needs none, but the air-drag check (a light ball's drag makes the "
                "contact's own ε larger than Eq. 9's) needs its --mass and --diameter (or BALL), and the virtual "
                "bodies (x, v) its radius")


#: Assumed standard uncertainty [m] of a height set or read against a ruler (:func:`assumed_height_sd_m`).
HEIGHT_SD_FLOOR_M = 0.002
#: ... and of a rebound's apex read by eye, relative to the height: the larger of the two is taken.
REBOUND_READ_FRACTION = 0.01
#: Largest standard uncertainty of a height, relative to it, for which the first-order ± of Eq. (9) is given
#: (:func:`epsilon_uncertainty_from_heights`; at 10 % its second-order term is under 1 % of epsilon).
MAX_RELATIVE_HEIGHT_SD = 0.1


def assumed_height_sd_m(drop_height_m, rebound_height_m):
    """Assumed standard uncertainties [m] of a drop test's heights when none is given: the drop height,
    set against a ruler, :data:`HEIGHT_SD_FLOOR_M`; the rebound's apex, read by eye while the ball turns,
    the larger of that and :data:`REBOUND_READ_FRACTION` of it (the same reading as ``vrcal discover``
    assumes for a table's heights written to whole centimetres).

    Parameters
    ----------
    drop_height_m, rebound_height_m : float or ndarray
        H and h as read [m]

    Returns
    -------
    (sd_H_m, sd_h_m) : float or ndarray
    """
    h = np.asarray(rebound_height_m, dtype=float)
    sd_H = np.full_like(np.asarray(drop_height_m, dtype=float), HEIGHT_SD_FLOOR_M)
    return eq._out(sd_H), eq._out(np.maximum(HEIGHT_SD_FLOOR_M, REBOUND_READ_FRACTION * h))


def epsilon_uncertainty_from_heights(rebound_height_m, drop_height_m, rebound_sd_m, drop_sd_m):
    """Standard uncertainty of Eq. (9)'s epsilon = sqrt(h/H) from those of the heights (first order, the two
    readings independent): u = epsilon/2 * sqrt((u_h/h)^2 + (u_H/H)^2).

    Parameters
    ----------
    rebound_height_m, drop_height_m : float or ndarray
        h and H of the ball's bottom [m], 0 < h <= H
    rebound_sd_m, drop_sd_m : float or ndarray
        their standard uncertainties [m], >= 0

    Returns
    -------
    u_epsilon : float or ndarray
        [1]
    """
    h = np.asarray(rebound_height_m, dtype=float)
    H = np.asarray(drop_height_m, dtype=float)
    eps = np.asarray(eq.epsilon_from_heights(h, H))
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.hypot(np.asarray(rebound_sd_m, dtype=float) / h, np.asarray(drop_sd_m, dtype=float) / H)
    return eq._out(0.5 * eps * rel)


def drop_test(body, drop_height_m, rebound_height_m, drop_measured_to="bottom", rebound_measured_to="bottom",
               height_sd_m=None):
    """(epsilon, keys) of one's own drop test: Eq. (9) with both heights brought to the ball's bottom (``body``
    None: heights of the bottom, no drag check), and its uncertainty from the heights' (``height_sd_m`` for
    each, else :func:`assumed_height_sd_m`)."""
    if drop_height_m is None or rebound_height_m is None:
        raise UsageError("a drop test needs both --drop-height and --rebound-height [m]")
    D = None if body is None else body.diameter_m
    heights = {}
    for name, value, point in (("--drop-height", drop_height_m, drop_measured_to),
                               ("--rebound-height", rebound_height_m, rebound_measured_to)):
        check_drop_test_height(value, name)
        if D is None and point != "bottom":
            raise UsageError(f"{name} to the ball's {point}: bringing it to the bottom needs the ball's diameter "
                             f"(give BALL, or --mass and --diameter)")
        if D is None:
            heights[name] = float(value)
            continue
        offset = eq.POINT_OFFSET_DIAMETERS[point] * D
        if value < offset:
            raise UsageError(f"{name} {value:g} m to the ball's {point}: a height to the {point} cannot be below "
                             f"{'the diameter D' if point == 'top' else 'the radius D/2'} = {offset:.3g} m "
                             f"(the {point} of the ball resting on the floor)")
        heights[name] = float(eq.height_to_bottom_m(value, point, D))
    H, h = heights["--drop-height"], heights["--rebound-height"]
    if h > H and (drop_measured_to, rebound_measured_to) != ("bottom", "bottom"):   # say what was converted
        def said(what, value, point, bottom):
            return f"{what} = {value:g} m" + ("" if point == "bottom" else
                                              f" to the {point} ({bottom:.4g} m to the bottom)")
        raise UsageError(f"rebound height {said('h', rebound_height_m, rebound_measured_to, h)} exceeds drop height "
                         f"{said('H', drop_height_m, drop_measured_to, H)}: a ball cannot rebound higher than it fell")
    eps = float(eq.epsilon_from_heights(h, H))
    read = ", ".join(f"{what} {value:g} m to the {point}"
                     for what, point, value in (("H", drop_measured_to, drop_height_m),
                                                ("h", rebound_measured_to, rebound_height_m)) if point != "bottom")
    if height_sd_m is None:
        sd_H, sd_h = assumed_height_sd_m(drop_height_m, rebound_height_m)
        sd_source = (f"assumed: H to {sd_H * 1e3:g} mm (a ruler), h to {sd_h * 1e3:.2g} mm (the larger of "
                     f"{HEIGHT_SD_FLOOR_M * 1e3:g} mm and {100 * REBOUND_READ_FRACTION:g} % of h, an apex read by "
                     "eye; --height-sd gives them)")
    else:
        sd_H = sd_h = float(height_sd_m)
        sd_source = "given (--height-sd)"
    keys = {
        "epsilon_source": f"your drop test, ε = √(h/H) (Eq. 9){'; ' + read if read else ''}",
        "drop_height_m": H,
        "rebound_height_m": h,
        "epsilon_uncertainty": float(epsilon_uncertainty_from_heights(h, H, sd_h, sd_H)),
        "height_sd_m": {"drop": float(sd_H), "rebound": float(sd_h)},
        "height_sd_source": sd_source,
    }
    worst = max(sd_h / h if h > 0 else math.inf, sd_H / H)
    if height_sd_m is not None and worst > MAX_RELATIVE_HEIGHT_SD:
        raise UsageError(f"--height-sd {sd_h:g} m is {100 * worst:.3g} % of a height (h = {h:.4g} m, H = {H:.4g} m of "
                         f"the ball's bottom): a first-order ± of ε = √(h/H) does not hold beyond "
                         f"{100 * MAX_RELATIVE_HEIGHT_SD:g} %; repeat the drop and fit the trials as a drop table "
                         "(vrcal discover TABLE.csv --ball BALL)")
    u_note = ("heights taken as exact (--height-sd 0): no ± of ε" if sd_h == sd_H == 0 else
              f"± of ε from the heights' standard uncertainties (u = ε/2 √((u_h/h)² + (u_H/H)²)), {sd_source}; "
              "a drop repeated a few times measures their scatter")
    if body is None:
        return eps, {**keys, "notes": [u_note, NO_BODY_NOTE]}
    drag = drop_test_drag(body.mass_kg, body.diameter_m, H, h)
    return eps, {**keys, **drag, "notes": [u_note, *drag.get("notes", [])]}


#: Shift of epsilon [1] by a sphere's drag from which :func:`drop_test_drag` notes it.
DRAG_NOTE_EPSILON = 0.005


def drop_test_drag(mass_kg, diameter_m, drop_height_m, rebound_height_m, ball_key=None):
    """What a sphere's air drag makes of a drop test: ``{}`` when it moves epsilon by less than
    :data:`DRAG_NOTE_EPSILON`, else ``epsilon_with_drag`` (:func:`vrcal.model.restitution.
    epsilon_from_heights_with_drag` at C_d :data:`vrcal.model.restitution.SPHERE_DRAG_COEFFICIENT`, with the
    added mass), ``drag_coefficient`` and a ``notes`` entry saying so. Eq. (9) stays the result: the
    ball's own C_d is not known.

    Parameters
    ----------
    mass_kg, diameter_m : float
        the ball [kg], [m]
    drop_height_m : float
        H to the ball's bottom [m]
    rebound_height_m : float or dict
        h to the ball's bottom [m]; a standard's window as ``{"min", "nominal", "max"}`` (then
        ``epsilon_with_drag`` is such a dict too)
    ball_key : str, optional
        a ball of the standards, which the note's ``vrcal discover`` command names
    """
    cd = eq.SPHERE_DRAG_COEFFICIENT
    k = eq.drag_constant_per_m(cd, diameter_m, mass_kg, added_mass_kg=eq.added_mass_kg(diameter_m))
    levels = rebound_height_m if isinstance(rebound_height_m, dict) else {"nominal": rebound_height_m}
    eps = {key: float(eq.epsilon_from_heights(h, drop_height_m)) for key, h in levels.items()}
    with_drag = {key: float(eq.epsilon_from_heights_with_drag(h, drop_height_m, k, allow_above_one=True))
                 for key, h in levels.items()}
    if abs(with_drag["nominal"] - eps["nominal"]) < DRAG_NOTE_EPSILON:
        return {}
    body = f"--ball {ball_key}" if ball_key else f"--mass {mass_kg:.3g} --diameter {diameter_m:.3g}"
    table = f"Drops from several heights (a table: vrcal discover TABLE {body}) measure the drag and the contact's ε"
    drag = f"a sphere's C_d {cd:g} slows it by k = {k:.3g} 1/m"
    h, H = levels["nominal"], drop_height_m
    if max(with_drag.values()) > 1.0:
        note = (f"air drag: this ball is light for its size ({drag}); with that drag no bounce "
                f"rises {h:g} m from {H:g} m (ε would be {max(with_drag.values()):.3g} > 1): "
                f"check the mass, the diameter and the heights. {table}")
    else:
        def shown(e):
            return f"{e['nominal']:.3f}" + (f" ({e['min']:.3f} .. {e['max']:.3f})" if "min" in e else "")
        what = "the rule's heights" if "min" in levels else "these heights"
        note = (f"air drag ({drag}): with it the contact's own ε is "
                f"{shown(with_drag)}, not {shown(eps)} (Eq. 9 ignores drag): {with_drag['nominal']:.3f} is for an "
                f"engine that applies that drag too; an engine without air drag (MuJoCo, ODE, PyBullet as they come) "
                f"reproduces {what} with {eps['nominal']:.3f}. {table}")
    return {"epsilon_with_drag": with_drag if "min" in levels else with_drag["nominal"], "drag_coefficient": cd,
            "notes": [note]}


#: Air displaced over the ball's mass, rho V / m, from which :func:`buoyancy_notes` warns.
LARGE_BUOYANCY = 0.1


def buoyancy_notes(mass_kg, diameter_m):
    """A warning (list of one text, else empty) when the air a ball displaces is at least
    :data:`LARGE_BUOYANCY` of its mass: its flights fall with g (m - rho V) / (m + rho V / 2), not g.

    Parameters
    ----------
    mass_kg, diameter_m : float
        the ball [kg], [m]
    """
    ratio = eq.AIR_DENSITY_KG_PER_M3 * float(eq.sphere_volume_m3(diameter_m)) / float(mass_kg)
    if ratio < LARGE_BUOYANCY:
        return []
    g_eff = (1.0 - ratio) / (1.0 + 0.5 * ratio)
    return [f"warning: buoyancy is large: the air this ball displaces weighs {ratio:.0%} of the ball, so it "
            f"falls with {g_eff:.2f} g (buoyancy and the air's added mass); ε from heights holds, but a "
            f"simulation needs buoyancy and air drag, and an engine has neither"]


def _as_body(ball):
    """A :class:`vrcal.model.body.Body` from a Body, a standards Ball or a ball's key."""
    from vrcal.model.body import BallProperties, Body, describe_body

    if isinstance(ball, Body):
        return ball
    if isinstance(ball, str):
        return describe_body(ball)
    return Body(BallProperties.from_ball(ball), ball, "standard")


def _window_fit(body, K, as_paper):
    """The keys of a ball of the standards: its drop test's window (Eq. 9) and its association."""
    ball = body.standard
    window = ball_epsilon(ball, as_paper=as_paper)
    return {
        "ball": ball.key,
        "ball_name": ball.name,
        "association": ball.association,
        "official_rule": ball.official,
        "convention": window.convention,
        "K_per_s": K,
        "epsilon": window.as_dict(),
        "bounds": "min and max are the smallest and largest value of each quantity over epsilon min..max; "
                  "the shortest T, the fastest v (at fixed x) and the shallowest x (at fixed v) give epsilon max",
        "drop_height_m": window.drop_height_m,
        "rebound_height_m": window.rebound_m.as_dict(),
        "mass_kg": body.mass_kg,
        "diameter_m": body.diameter_m,
        "equations": "epsilon = exp(-K*T) (Eq. 7), T = x/(2*v) (Eq. 10), epsilon = sqrt(h/H) (Eq. 9)",
        "notes": _paper_notes(ball, window) if as_paper else list(ball.departures),
    }


def _paper_notes(ball, window):
    """The notes of ``--as-paper``: the paper's Table 1 row as printed and how vrcal read it (a ball's
    ``departures`` describe vrcal's own reading, which ``--as-paper`` does not use)."""
    lo, hi = window.rebound_m.min, window.rebound_m.max
    h = f"{lo:g} m (the paper prints one rebound height)" if lo == hi else f"{lo:g}-{hi:g} m"
    return [f"--as-paper: the paper's Table 1 as printed ({ball.paper.printed}), read as H = "
            f"{window.drop_height_m:g} m and h = {h}, its typos corrected (docs/paper.md), both heights as the "
            "paper takes them (no correction for the point of the ball they are measured to), no air drag",
            f"without --as-paper, vrcal fit {ball.key} uses the rule's heights and says where they depart from the "
            "paper"]


def _single_fit(body, K, as_paper, epsilon):
    """The keys of a body with one epsilon: ``--epsilon``, or a discover result's."""
    if as_paper:
        raise UsageError("--as-paper reads a standard's drop test as the paper prints it: give a ball of the "
                         "standards without --epsilon or --from")
    notes = []
    if body is None:   # one's own drop test alone: its keys follow (fit_ball)
        return {"ball": None, "source": "drop test", "K_per_s": K,
                "epsilon": {"nominal": float(check_epsilon(epsilon, "--epsilon"))},
                "equations": "epsilon = exp(-K*T) (Eq. 7)", "notes": notes}
    if epsilon is not None:
        eps, source = check_epsilon(epsilon, "--epsilon"), "given with --epsilon"
    elif body.discovered is not None:
        eps, source = body.epsilon(), body.epsilon_source()
    else:
        raise UsageError(f"'{body.name}' is not a ball of the standards and has no drop-test window: give --epsilon "
                         "(or --from a discover JSON)")
    out = {
        "ball": body.name,
        "ball_name": body.standard.name if body.standard is not None else body.name,
        "source": body.source,
        "K_per_s": K,
        "epsilon": {"nominal": float(eps)},
        "epsilon_source": source,
        "mass_kg": body.mass_kg,
        "diameter_m": body.diameter_m,
        "equations": "epsilon = exp(-K*T) (Eq. 7), T = x/(2*v) (Eq. 10)",
        "notes": notes,
    }
    doc = body.discovered
    if doc is not None:
        out["drop_height_m"] = body.drop_height_m
        if epsilon is None and isinstance(doc.get("epsilon_uncertainty"), (int, float)):
            out["epsilon_uncertainty"] = float(doc["epsilon_uncertainty"])
        notes.extend(discovered_notes(body))
    return out


def discovered_notes(body):
    """Notes on the epsilon of a discover result's body: its effects and the speed a speed-dependent ε holds at.

    Parameters
    ----------
    body : vrcal.model.body.Body
        with ``discovered`` (a ``vrcal discover --json`` result)

    Returns
    -------
    list of str
        the effects vrcal discover named (epsilon is the contact's own, the flights' effects apart)
        and, for a speed-dependent epsilon, the impact speed [m/s] its value holds at
    """
    effects = list(body.effects)
    notes = [f"{body.source}: {', '.join(effects) or 'no effect'} named by vrcal discover"
             + ("; epsilon is the contact's own, the flights' effects apart" if effects else "")]
    if "velocity_dependent_restitution" in effects and body.reference_speed_m_per_s:
        notes.append(f"epsilon depends on the impact speed: this is its value at "
                     f"{body.reference_speed_m_per_s:.3g} m/s")
    return notes


def fit_text(result):
    """:func:`fit_ball`'s result for people: epsilon first, then T, the drop test, the family, notes.

    A ball of the standards: the columns are the drop test's epsilon levels (min, nominal, max),
    so each column is one consistent set: T at epsilon min is the longest contact time. Any
    other body: one column. At most 100 columns; about 20 lines for a ball of the standards.
    """
    r = result
    K = r["K_per_s"]
    eps = r["epsilon"]
    levels = tuple(k for k in _LEVELS if k in eps)
    T = {k: eq.contact_time_from_epsilon_s(eps[k], K) for k in levels}
    window = levels == _LEVELS
    model_time = f"model time, T = −ln ε / K (Eq. 7), K = {K:g} 1/s"
    if window:
        H, h = r["drop_height_m"], r["rebound_height_m"]
        rows = [
            ["ε", *(number(eps[k], 4) for k in levels), "drop test, ε = √(h/H) (Eq. 9), no drag"],
            *([["ε, drag", *(number(r["epsilon_with_drag"][k], 4) for k in levels),
                f"the contact's own, with air drag (C_d {r['drag_coefficient']:g})"]]
              if isinstance(r.get("epsilon_with_drag"), dict) else []),
            ["T [ms]", *(_ms_or_inf(T[k]) for k in levels), model_time],
            ["H [m]", *(number(H, 4) for _ in levels), "drop height"],
            ["h [m]", *(number(h[k], 4) for k in levels), "rebound height"],
        ]
    else:
        u = r.get("epsilon_uncertainty")
        places = max(4, 1 - math.floor(math.log10(u))) if u and math.isfinite(u) and u > 0 else 4
        shown = f"{eps['nominal']:.{places}f}" + (f" ± {u:.{places}f}" if u else "")
        rows = [
            ["ε", shown, r["epsilon_source"]],
            ["T [ms]", _ms_or_inf(T["nominal"]), model_time],
        ]
        own_test = isinstance(r.get("rebound_height_m"), float)
        if r.get("drop_height_m") is not None:
            rows.append(["H [m]", number(r["drop_height_m"], 4),
                         "drop height, to the ball's bottom" if own_test else "drop height of the discover result"])
        if own_test:
            rows.append(["h [m]", number(r["rebound_height_m"], 4), "rebound height, to the ball's bottom"])
    fixed = r.get("fixed")
    if fixed and isinstance(fixed.get("v_m_per_s"), dict):
        x = fixed["x_m"]
        rows.append([f"v at x = {x * 1e3:.4g} mm [m/s]",
                     *(number(_or_inf(lambda t: eq.virtual_speed_m_per_s(x, t), T[k]), 4) for k in levels),
                     "v = x/(2T) (Eq. 10)"])
    elif fixed:
        v = fixed["v_m_per_s"]
        rows.append([f"x at v = {v:.4g} m/s [mm]",
                     *(number(eq.virtual_depth_m(v, T[k]) * 1e3, 4) for k in levels), "x = 2vT (Eq. 10)"])
    if window:
        rule = "official rule" if r["official_rule"] else "not an official rule"
        spread = ("one value" if eps["min"] == eps["max"] else
                  f"{epsilon_text(eps['min'])} .. {epsilon_text(eps['max'])}")
        answer = (f"{r['ball']}: ε = {epsilon_text(eps['nominal'])} ({spread}), T = {_ms_or_inf(T['nominal'], 3)} ms "
                  f"at K = {K:g} 1/s")
        text = wrap(answer) + wrap(f"{r['ball_name']}, {r['association']}, {rule}; heights: {r['convention']}")
        text += "\n" + table(rows, ["", "ε min", "nominal", "ε max", ""], align="lrrrl")
    elif r["ball"] is None:   # one's own drop test alone
        text = wrap(f"your drop test: ε = {epsilon_text(eps['nominal'])}, T = {_ms_or_inf(T['nominal'], 3)} ms at "
                    f"K = {K:g} 1/s") + wrap("no ball given: one ε from the two heights")
        text += "\n" + table(rows, ["", "ε", ""], align="lrl")
    else:
        answer = (f"{r['ball']}: ε = {epsilon_text(eps['nominal'])}, T = {_ms_or_inf(T['nominal'], 3)} ms "
                  f"at K = {K:g} 1/s")
        if r["source"] not in ("standard", "options"):
            who, what = f"{r['ball_name']} from {r['source']}", "one measured ε"
        elif r["ball_name"] != r["ball"] or r["source"] == "standard":
            who, what = r["ball_name"], ("one ε (your drop test)" if own_test else "one ε (--epsilon)") + \
                ", not the standard's drop-test window"
        else:
            who, what = f"{r['ball']}, a ball of your own", "one ε, no drop-test window"
        text = wrap(answer) + wrap(f"{who}: m = {mass(r['mass_kg'])}, "
                                   f"D = {number(r['diameter_m'] * 1e3, 3)} mm; {what}")
        text += "\n" + table(rows, ["", "ε", ""], align="lrl")
    if fixed and fixed.get("warning"):
        text += wrap(f"warning: {fixed['warning']}")
    if "family" in r:
        text += "\n" + wrap(f"virtual bodies (x, v) of ε{' nominal' if window else ''}: x/(2v) = T (Eq. 10), "
                             f"x up to the radius R = {number(r['diameter_m'] / 2.0 * 1e3, 4)} mm")
        text += _family_rows(r["family"])
    if r["notes"]:
        text += "\nnotes:\n" + "".join(wrap(n, first="  - ") for n in r["notes"])
    return text


def _ms_or_inf(T_s, digits=4):
    return "inf" if math.isinf(T_s) else number(T_s * 1e3, digits)


def _family_rows(members, width=100):
    """The family as two rows (x [mm], v [m/s]), wrapped into blocks that fit ``width`` columns."""
    xs = [number(m["x_m"] * 1e3, 3) for m in members]
    vs = [number(m["v_m_per_s"], 3) for m in members]
    cell = max(len(c) for c in xs + vs)
    per_row = max(1, (width - 2 - 9) // (cell + 2))
    out = ""
    for i in range(0, len(members), per_row):
        out += table([["x [mm]", *xs[i:i + per_row]], ["v [m/s]", *vs[i:i + per_row]]],
                     ["", *[""] * len(xs[i:i + per_row])], align="l" + "r" * len(xs[i:i + per_row]),
                     indent="  ").split("\n", 1)[1]
    return out


def _bounds(by_level):
    """{min, nominal, max} of a quantity given per epsilon level: min and max by value
    ({nominal} alone for a body with one epsilon)."""
    if "min" not in by_level:
        return {"nominal": by_level["nominal"]}
    lo, hi = sorted((by_level["min"], by_level["max"]))
    return {"min": lo, "nominal": by_level["nominal"], "max": hi}


def _or_inf(fn, T):
    return math.inf if T == 0 else fn(T)


def parse_body(spec, K_per_s, standards=None, as_paper=False, notes=None):
    """A body for :func:`pair`: a ball key, 'floor' (rigid, x = 0), 'x=..,v=..' or 'from=FILE'.

    A ball of the standards, or the ball of a ``vrcal discover --json`` result ('from=FILE'),
    is given the virtual body of its epsilon at depth x = R/2 (:func:`ball_virtual_body`; any
    member of its family gives the same pair epsilon). For 'from=FILE' the list ``notes`` (if
    given) gets what the constant epsilon leaves out (:func:`discovered_notes`).

    Returns
    -------
    (str, VirtualBody, float)
        the body's name, its virtual body and its epsilon against a rigid floor
    """
    from vrcal.model.body import describe_body

    text = str(spec).strip()
    if text.lower() in ("floor", "steel", "rigid"):
        return text.lower(), VirtualBody(0.0, 0.0), 1.0
    if text.lower().startswith("from="):
        path = text[len("from="):].strip()
        if not path:
            raise UsageError(f"body '{spec}': give the discover JSON after 'from='")
        body = describe_body(from_json=path, standards=standards)
        vb, eps = ball_virtual_body(body, K_per_s)
        if notes is not None:
            # the speed a speed-dependent epsilon holds at is said once, in the pair's own note below
            notes.extend(discovered_notes(body)[:1] if body.effects else discovered_notes(body))
            if body.effects:
                held = (f" (its value at {body.reference_speed_m_per_s:.3g} m/s impacts)"
                        if "velocity_dependent_restitution" in body.effects and body.reference_speed_m_per_s else "")
                notes.append(f"{body.name}: the pair takes its one constant epsilon {eps:.4f}{held}; "
                             f"{', '.join(body.effects)} left out (Eq. 6 adds constant contact times)")
        return f"{body.name} from {path}", vb, eps
    if "=" in text:
        try:
            items = [p.split("=", 1) for p in text.replace(" ", "").split(",")]
            parts = dict(items)
            repeated = sorted({k for k, _ in items if sum(key == k for key, _ in items) > 1})
            if not repeated:
                x, v = float(parts.pop("x")), float(parts.pop("v"))
        except (KeyError, ValueError):
            raise UsageError(f"body '{spec}': give a ball name, 'floor', 'x=DEPTH_M,v=SPEED_M_PER_S' "
                             "or 'from=DISCOVER.json'") from None
        if repeated:   # a dict keeps the last: refused like an unknown field, not silently
            raise UsageError(f"body '{spec}': {' and '.join(f'{k}=' for k in repeated)} given more than once; "
                             "give each of x= and v= once")
        if parts:
            raise UsageError(f"body '{spec}': unknown field(s) {sorted(parts)}; use x= and v=")
        body = VirtualBody(x, v)
        eps = eq.epsilon_single(x, v, K_per_s)
        if notes is not None:
            notes.extend(virtual_body_notes(text, x, eps, standards))
        return text, body, eps
    ball = get_ball(text, standards)
    body = describe_body(ball.key, standards=standards)
    vb, eps = ball_virtual_body(body, K_per_s, as_paper)
    if notes is not None and not _rigid(ball.floor):
        floor = ball.floor.split(";")[0].split(" (")[0].strip()
        where = ("the floor of its drop test is not stated" if floor.lower().startswith("not stated") else
                 f"its drop test is on a {floor}, not a rigid one")
        notes.append(f"{ball.key}: {where} ({ball.association.split(' (')[0]}); the pair takes its ε as the "
                     "ε against a rigid floor (Eq. 10)")
    return body.name, vb, eps


def _rigid(floor):
    """Whether a standard's test floor (its ``floor:`` text, up to the first ';' or '(') is rigid."""
    own = floor.split(";")[0].split("(")[0].lower()
    return any(word in own for word in ("steel", "rigid", "granite", "concrete"))


#: Smallest epsilon [1] of a pair body 'x=..,v=..' below which :func:`virtual_body_notes` says it does not bounce.
NO_BOUNCE_EPSILON = 1e-3


def virtual_body_notes(name, x_m, epsilon, standards=None):
    """Notes on a virtual body typed as 'x=..,v=..': a depth beyond every standard ball's radius (a virtual
    body lies inside its ball: are x and v in cm, as the paper's Table 2 is likely printed?) and an epsilon
    below :data:`NO_BOUNCE_EPSILON`.

    Parameters
    ----------
    name : str
        the body as typed
    x_m : float
        its depth [m]
    epsilon : float
        its epsilon against a rigid floor [1]
    standards : dict, optional
        the balls whose largest radius bounds a plausible x (the shipped ones when None)
    """
    from vrcal.model.standards import load_standards

    balls = (standards or load_standards()).values()
    largest = max(ball.diameter_m.max / 2.0 for ball in balls) if balls else math.inf
    notes = []
    if x_m > largest:
        notes.append(f"{name}: x = {x_m:g} m is deeper than the radius of any ball of the standards "
                     f"({largest * 1e3:.4g} mm at most), while a virtual body lies inside its ball: x is in metres "
                     "and v in m/s (the paper's Table 2 prints them without units; vrcal table2 --compare-paper)")
    if epsilon < NO_BOUNCE_EPSILON:
        notes.append(f"{name}: ε = {epsilon:.3g}, no bounce a drop test could see")
    return notes


def depends_on_K(spec):
    """Whether the epsilon :func:`parse_body` gives ``spec`` depends on K: only a virtual body
    'x=..,v=..' (epsilon = exp(-K x/(2v)), Eqs. 10 and 7). A ball, 'from=FILE' and the rigid
    floor carry their epsilon itself; K only places their virtual body."""
    text = str(spec).strip().lower()
    return "=" in text and not text.startswith("from=")


def ball_virtual_body(body, K_per_s, as_paper=False):
    """The virtual body a ball is given in a pair or a scene: depth x = R/2, v = x/(2T) (Eq. 10).

    Parameters
    ----------
    body : vrcal.model.body.Body
        a ball of the standards (its nominal drop-test epsilon) or a discover result's ball
        (its contact epsilon), see :meth:`vrcal.model.body.Body.epsilon`
    K_per_s : float
        rate constant K [1/s] of Eq. (7), > 0
    as_paper : bool
        a standard's epsilon from the paper's Table 1 heights as printed

    Returns
    -------
    (VirtualBody, float)
        the virtual body and the body's epsilon against a rigid floor
    """
    eps = body.epsilon(as_paper=as_paper)
    if eps is None:
        raise UsageError(f"'{body.name}' has no epsilon of its own: give a ball of the standards, a discover "
                         "result, or its virtual body x and v")
    T = eq.contact_time_from_epsilon_s(eps, K_per_s)
    x = body.radius_m / 2.0
    v = eq.virtual_speed_m_per_s(x, T) if T > 0 else 0.0
    return VirtualBody(x, v), eps


def pair(spec_a, spec_b, K_per_s=DEFAULT_K_PER_S, standards=None, as_paper=False):
    """epsilon of two colliding bodies from their virtual bodies, Eqs. (6) and (7) of [1].

    Returns
    -------
    dict
        each body's x, v, T and its own epsilon against a rigid floor, the pair's T and
        epsilon; JSON-ready.
    """
    K = check_K(K_per_s)
    notes = []
    bodies = [parse_body(s, K, standards, as_paper, notes) for s in (spec_a, spec_b)]
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
        "notes": notes,
    }


def pair_text(result):
    """:func:`pair`'s result for people: the pair's epsilon first, then each body's virtual body."""
    r = result
    a, b = r["bodies"]
    rows = [[body["name"], number(body["x_m"] * 1e3, 4), number(body["v_m_per_s"], 4),
             _ms_or_inf(body["T_s"]), number(body["epsilon_on_rigid_floor"], 4)] for body in (a, b)]
    rows.append(["pair", "", "", _ms_or_inf(r["T_s"]), number(r["epsilon"], 4)])
    text = wrap(f"{a['name']} against {b['name']}: ε = {epsilon_text(r['epsilon'])}, "
                f"T = {_ms_or_inf(r['T_s'], 3)} ms at K = {r['K_per_s']:g} 1/s")
    text += "\n" + table(rows, ["body", "x [mm]", "v [m/s]", "T [ms]", "ε"], align="lrrrr")
    text += "\n" + wrap("T = x_A/(2 v_A) + x_B/(2 v_B) (Eq. 6), ε = exp(−K T) (Eq. 7). A body's ε is its ε "
                         "against a rigid floor; the contact times add, so the pair's ε is their product.")
    for note in r.get("notes", ()):
        text += wrap(f"note: {note}")
    return text
