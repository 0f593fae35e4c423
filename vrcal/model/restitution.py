"""The equations of the virtual-body restitution model, one pure function each.

Every function takes floats or numpy arrays (broadcast together) in SI units and
returns a float for scalar input, an ndarray otherwise; scalar and array inputs
give the same numbers.

References
----------
[1] "The Graphical Method for Decision of Restitution Coefficient and Its
    Applications", equations (6), (7), (8), (9), (10).

Departures from [1]
-------------------
* Eq. (9) ``eps = sqrt(h/H)`` holds for the heights of the ball's **bottom** above the
  floor: the ball (any point of it, its centre too) falls H_bottom before it touches
  the floor and rises h_bottom after. Heights of the centre or the top are not enough
  even when both are to the same point (sqrt(h_c/H_c) is not sqrt(h_b/H_b));
  :func:`height_to_bottom_m` brings each height to the bottom first (top: minus D,
  centre: minus D/2). [1] applies Eq. (9) to FIBA's heights as printed (the drop to
  the bottom, the rebound to the top of the ball).
* [1] prints Table 2 with values that follow ``T = v/(2x)`` rather than its own
  Eq. (10) ``T = x/(2v)``; vrcal follows the equations as printed (see
  :mod:`vrcal.model.table2`).
"""

from __future__ import annotations

import math

import numpy as np

from vrcal.errors import UsageError

#: Standard gravity [m/s^2] (CGPM 1901), used wherever g is not given.
STANDARD_GRAVITY_M_PER_S2 = 9.80665

#: Default rate constant K [1/s]. The paper does not state its K; its Table 2 implies
#: K = 3.9-4.2 1/s (least squares 4.11 1/s) when x and v are read interchanged (the x column
#: a speed, the v column a depth: T = v/(2x) is a time [s], so K is in 1/s; see
#: :mod:`vrcal.model.table2`). vrcal uses the round value 4 1/s.
DEFAULT_K_PER_S = 4.0

#: Offset [in units of the ball diameter] from a named point of the ball to its bottom.
POINT_OFFSET_DIAMETERS = {"bottom": 0.0, "centre": 0.5, "top": 1.0}


def check_K(K_per_s):
    """K [1/s] as a float; UsageError unless it is a finite number > 0."""
    if not (isinstance(K_per_s, (int, float)) and math.isfinite(K_per_s) and K_per_s > 0):
        raise UsageError(f"K must be a finite number > 0 [1/s], got {K_per_s!r}")
    return float(K_per_s)


def check_epsilon(epsilon, what="epsilon"):
    """Return epsilon as a float in (0, 1]; :class:`UsageError` naming ``what`` otherwise."""
    try:
        e = float(epsilon)
    except (TypeError, ValueError):
        raise UsageError(f"{what} must be a number in (0, 1], got {epsilon!r}") from None
    if not (math.isfinite(e) and 0.0 < e <= 1.0):
        raise UsageError(f"{what} must lie in (0, 1], got {e:g}")
    return e


def _out(value):
    """Return a Python float for 0-d results, the array otherwise."""
    arr = np.asarray(value, dtype=float)
    return float(arr) if arr.ndim == 0 else arr


def _positive(name, value, allow_zero=False):
    arr = np.asarray(value, dtype=float)
    bad = ~np.isfinite(arr) | ((arr < 0) if allow_zero else (arr <= 0))
    if np.any(bad):
        bound = ">= 0" if allow_zero else "> 0"
        raise UsageError(f"{name} must be a finite number {bound}, got {_show(arr[bad])}")
    return arr


def _show(bad):
    flat = np.ravel(bad)
    return f"{flat[0]:g}" if flat.size else "?"


def _epsilon_in_unit_interval(epsilon, allow_zero=False):
    eps = np.asarray(epsilon, dtype=float)
    low_ok = (eps >= 0) if allow_zero else (eps > 0)
    bad = ~np.isfinite(eps) | ~low_ok | (eps > 1)
    if np.any(bad):
        interval = "[0, 1]" if allow_zero else "(0, 1]"
        raise UsageError(f"epsilon must lie in {interval}, got {_show(eps[bad])}")
    return eps


def contact_time_pair_s(x_a_m, v_a_m_per_s, x_b_m, v_b_m_per_s):
    """Time T for the two virtual bodies to meet, Eq. (6) of [1].

    Parameters
    ----------
    x_a_m : float or ndarray
        depth of body A's virtual body below its surface [m], >= 0
    v_a_m_per_s : float or ndarray
        speed of body A's virtual body [m/s], > 0 (ignored where x_a_m == 0)
    x_b_m : float or ndarray
        depth of body B's virtual body [m], >= 0; a rigid (steel) floor has x = 0
    v_b_m_per_s : float or ndarray
        speed of body B's virtual body [m/s], > 0 (ignored where x_b_m == 0)

    Returns
    -------
    T_s : float or ndarray
        ``x_A/(2 v_A) + x_B/(2 v_B)`` [s]

    Notes
    -----
    A body whose virtual body lies on its surface (x = 0) adds no time, whatever
    its v: [1] states that x = 0 goes with v = 0, and 0/0 is taken as 0 here.
    """
    return _out(contact_time_single_s(x_a_m, v_a_m_per_s) + contact_time_single_s(x_b_m, v_b_m_per_s))


def contact_time_single_s(x_m, v_m_per_s):
    """Contact time of one body against a rigid floor, Eq. (10) of [1].

    Parameters
    ----------
    x_m : float or ndarray
        depth of the virtual body below the body's surface [m], >= 0
    v_m_per_s : float or ndarray
        speed of the virtual body [m/s], > 0 where x_m > 0

    Returns
    -------
    T_s : float or ndarray
        ``x / (2 v)`` [s]; 0 where x = 0.
    """
    x = _positive("x_m", x_m, allow_zero=True)
    v = np.asarray(v_m_per_s, dtype=float)
    x, v = np.broadcast_arrays(x, v)
    needs_v = x > 0
    if np.any(needs_v & ~(np.isfinite(v) & (v > 0))):
        raise UsageError(f"v_m_per_s must be a finite number > 0 where x_m > 0, got {_show(v[needs_v & ~(v > 0)])}")
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(needs_v, x / (2.0 * np.where(needs_v, v, 1.0)), 0.0)
    return _out(t)


def epsilon_from_contact_time(T_s, K_per_s):
    """Coefficient of restitution from the virtual-body contact time, Eq. (7) of [1].

    Parameters
    ----------
    T_s : float or ndarray
        time for the virtual bodies to meet [s], >= 0
    K_per_s : float or ndarray
        the model's rate constant K [1/s], > 0

    Returns
    -------
    epsilon : float or ndarray
        ``exp(-K T)``, dimensionless, in (0, 1]
    """
    T = _positive("T_s", T_s, allow_zero=True)
    K = _positive("K_per_s", K_per_s)
    return _out(np.exp(-K * T))


def contact_time_from_epsilon_s(epsilon, K_per_s):
    """Contact time that gives a coefficient of restitution, the inverse of Eq. (7) of [1].

    Parameters
    ----------
    epsilon : float or ndarray
        coefficient of restitution, in (0, 1]
    K_per_s : float or ndarray
        the model's rate constant K [1/s], > 0

    Returns
    -------
    T_s : float or ndarray
        ``-ln(epsilon) / K`` [s]
    """
    eps = _epsilon_in_unit_interval(epsilon)
    K = _positive("K_per_s", K_per_s)
    return _out(-np.log(eps) / K + 0.0)   # + 0.0: epsilon = 1 gives 0, not -0


def epsilon_pair(x_a_m, v_a_m_per_s, x_b_m, v_b_m_per_s, K_per_s):
    """Coefficient of restitution of two colliding bodies, Eqs. (6) and (7) of [1].

    Parameters
    ----------
    x_a_m, x_b_m : float or ndarray
        depths of the two virtual bodies [m], >= 0
    v_a_m_per_s, v_b_m_per_s : float or ndarray
        speeds of the two virtual bodies [m/s], > 0 where the depth is > 0
    K_per_s : float or ndarray
        the model's rate constant K [1/s], > 0

    Returns
    -------
    epsilon : float or ndarray
        ``exp(-K (x_A/(2 v_A) + x_B/(2 v_B)))``

    Notes
    -----
    Because the two contact times add, the pair's epsilon is the product of
    each body's epsilon against a rigid floor (x = 0) at the same K.
    """
    return epsilon_from_contact_time(contact_time_pair_s(x_a_m, v_a_m_per_s, x_b_m, v_b_m_per_s), K_per_s)


def epsilon_single(x_m, v_m_per_s, K_per_s):
    """Coefficient of restitution of one body on a rigid floor, Eqs. (10) and (7) of [1].

    Parameters
    ----------
    x_m : float or ndarray
        depth of the virtual body [m], >= 0
    v_m_per_s : float or ndarray
        speed of the virtual body [m/s], > 0 where x_m > 0
    K_per_s : float or ndarray
        the model's rate constant K [1/s], > 0

    Returns
    -------
    epsilon : float or ndarray
        ``exp(-K x / (2 v))``
    """
    return epsilon_from_contact_time(contact_time_single_s(x_m, v_m_per_s), K_per_s)


def virtual_speed_m_per_s(x_m, T_s):
    """Speed of the virtual body that meets the contact time T at depth x, Eq. (10) solved for v.

    Parameters
    ----------
    x_m : float or ndarray
        depth of the virtual body [m], > 0
    T_s : float or ndarray
        contact time [s], > 0

    Returns
    -------
    v_m_per_s : float or ndarray
        ``x / (2 T)`` [m/s]
    """
    x = _positive("x_m", x_m)
    T = _positive("T_s", T_s)
    return _out(x / (2.0 * T))


def virtual_depth_m(v_m_per_s, T_s):
    """Depth of the virtual body that meets the contact time T at speed v, Eq. (10) solved for x.

    Parameters
    ----------
    v_m_per_s : float or ndarray
        speed of the virtual body [m/s], > 0
    T_s : float or ndarray
        contact time [s], >= 0

    Returns
    -------
    x_m : float or ndarray
        ``2 v T`` [m]
    """
    v = _positive("v_m_per_s", v_m_per_s)
    T = _positive("T_s", T_s, allow_zero=True)
    return _out(2.0 * v * T)


def epsilon_from_heights(rebound_height_m, drop_height_m):
    """Coefficient of restitution from a drop test, Eq. (9) of [1].

    Parameters
    ----------
    rebound_height_m : float or ndarray
        rebound height h [m] of the ball's bottom above the floor, >= 0 (a height read to
        the centre or top first through :func:`height_to_bottom_m`)
    drop_height_m : float or ndarray
        drop height H [m] of the ball's bottom above the floor, > 0

    Returns
    -------
    epsilon : float or ndarray
        ``sqrt(h / H)``

    Raises
    ------
    UsageError
        if h > H (the ball would gain energy) or a height is negative.

    Notes
    -----
    Eq. (9) ignores air drag; see :mod:`vrcal.drop.effects` for the correction.
    """
    h = _positive("rebound height h", rebound_height_m, allow_zero=True)
    H = _positive("drop height H", drop_height_m)
    h, H = np.broadcast_arrays(h, H)
    if np.any(h > H):
        i = np.flatnonzero(np.ravel(h > H))[0]
        raise UsageError(
            f"rebound height h = {np.ravel(h)[i]:g} m exceeds drop height H = {np.ravel(H)[i]:g} m: "
            "a ball cannot rebound higher than it fell"
        )
    return _out(np.sqrt(h / H))


def impact_speed_m_per_s(drop_height_m, g_m_per_s2=STANDARD_GRAVITY_M_PER_S2):
    """Speed of a body dropped from rest when it reaches the floor, Eq. (8) of [1].

    Parameters
    ----------
    drop_height_m : float or ndarray
        fall height [m], >= 0
    g_m_per_s2 : float or ndarray
        gravitational acceleration [m/s^2], > 0

    Returns
    -------
    v_m_per_s : float or ndarray
        ``sqrt(2 g H)`` [m/s]
    """
    H = _positive("drop height", drop_height_m, allow_zero=True)
    g = _positive("g_m_per_s2", g_m_per_s2)
    return _out(np.sqrt(2.0 * g * H))


def height_to_bottom_m(height_m, measured_to, diameter_m):
    """Height of the ball's bottom from a height measured to another point of the ball.

    Parameters
    ----------
    height_m : float or ndarray
        height of the named point of the ball above the floor [m] (a ball resting
        on the floor has its top at D, its centre at D/2, its bottom at 0)
    measured_to : {"bottom", "centre", "top"}
        the point of the ball the height was measured to
    diameter_m : float or ndarray
        ball diameter D [m], > 0

    Returns
    -------
    height_m : float or ndarray
        height of the ball's bottom above the floor [m]

    Notes
    -----
    A rule that measures the rebound "to the top of the ball" states the floor-to-top
    distance, so the bottom is ``h - D``; to the centre, ``h - D/2``. This is the
    correction [1] omits for FIBA's basketball rule.
    """
    if measured_to not in POINT_OFFSET_DIAMETERS:
        raise UsageError(f"measured_to must be one of {sorted(POINT_OFFSET_DIAMETERS)}, got {measured_to!r}")
    D = _positive("diameter_m", diameter_m)
    h = np.asarray(height_m, dtype=float)
    return _out(h - POINT_OFFSET_DIAMETERS[measured_to] * D)


# --------------------------------------------------------------------------- air drag (not in the paper)


#: Density of dry air at 20 C and 101.325 kPa [kg/m^3], used by ``air_drag``.
AIR_DENSITY_KG_PER_M3 = 1.204


def sphere_volume_m3(diameter_m):
    """Volume of a sphere of diameter D [m]: ``pi D^3 / 6`` [m^3]."""
    D = np.asarray(diameter_m, dtype=float)
    return _out(math.pi * D**3 / 6.0)


def drag_constant_per_m(drag_coefficient, diameter_m, mass_kg, air_density_kg_per_m3=AIR_DENSITY_KG_PER_M3,
                        added_mass_kg=0.0):
    """Quadratic-drag constant k of ``a = -g - k v|v|`` [1/m].

    Parameters
    ----------
    drag_coefficient : float or ndarray
        C_d of the sphere, dimensionless, >= 0 (0.47 for a smooth sphere at 1e4 < Re < 2e5; Mehta 1985)
    diameter_m : float or ndarray
        ball diameter D [m], > 0
    mass_kg : float or ndarray
        ball mass m [kg], > 0
    air_density_kg_per_m3 : float or ndarray
        rho [kg/m^3], default 1.204 (20 C)
    added_mass_kg : float or ndarray
        added mass of the air moving with the ball [kg] (0 unless ``buoyancy`` is on)

    Returns
    -------
    k_per_m : float or ndarray
        ``rho C_d (pi D^2 / 4) / (2 (m + m_added))`` [1/m]; the terminal speed is sqrt(g/k).

    Notes
    -----
    Not in [1] (drag-free flights). C_d is taken constant (no drag crisis, no spin).
    """
    cd = np.asarray(drag_coefficient, dtype=float)
    D = np.asarray(diameter_m, dtype=float)
    m = np.asarray(mass_kg, dtype=float) + np.asarray(added_mass_kg, dtype=float)
    return _out(air_density_kg_per_m3 * cd * (math.pi * D**2 / 4.0) / (2.0 * m))


def epsilon_from_heights_with_drag(rebound_height_m, drop_height_m, k_per_m):
    """Coefficient of restitution from a drop test with quadratic air drag: Eq. (9) of [1] corrected.

    Parameters
    ----------
    rebound_height_m : float or ndarray
        apex height h of the first rebound [m], >= 0, of the ball's bottom above the floor (as H;
        :func:`height_to_bottom_m` brings a height to the centre or top there)
    drop_height_m : float or ndarray
        drop height H [m] of the ball's bottom above the floor, > 0 (released from rest)
    k_per_m : float or ndarray
        drag constant k [1/m] (:func:`drag_constant_per_m`), >= 0

    Returns
    -------
    epsilon : float or ndarray
        ``sqrt(expm1(2 k h) / (1 - exp(-2 k H)))``; ``sqrt(h / H)`` (Eq. 9) for k = 0

    Notes
    -----
    Departure from [1], whose Eq. (9) ignores drag. The impact speed after a fall from
    rest is v_t sqrt(1 - exp(-2kH)) and a rebound at speed u rises to ln(1 + k u^2/g)/(2k)
    (v_t = sqrt(g/k)); eliminating u gives this closed form, independent of g. With C_d =
    0.5 the drag-free Eq. (9) underestimates the contact epsilon of the standards' drop
    tests by 0.024 (basketball, volleyball) to 0.037 (football).
    """
    h = np.asarray(rebound_height_m, dtype=float)
    H = np.asarray(drop_height_m, dtype=float)
    k = np.asarray(k_per_m, dtype=float)
    h, H, k = np.broadcast_arrays(h, H, k)
    pos = k > 1e-150  # smaller k change nothing in double precision (and would overflow)
    ks = np.where(pos, k, 1.0)
    return _out(np.where(pos, np.sqrt(np.expm1(2.0 * ks * h) / -np.expm1(-2.0 * ks * H)), np.sqrt(h / H)))
