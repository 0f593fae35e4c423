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
import numbers

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


def real_number(value):
    """The float of one real number, else None.

    Parameters
    ----------
    value : object
        a Python int or float, a numpy integer or floating scalar, or a 0-d array of one; a bool
        (True is no rate or mass), a string, a complex number or an array of several values is
        not one

    Returns
    -------
    float or None
    """
    if isinstance(value, (bool, np.bool_)):
        return None
    if isinstance(value, np.ndarray):
        return float(value) if value.ndim == 0 and value.dtype.kind in "iuf" else None
    return float(value) if isinstance(value, numbers.Real) else None


def check_number(value, what, lo=0.0, hi=math.inf, *, lo_open=True, hi_open=False, unit=""):
    """One finite real number in an interval, as a float; :class:`UsageError` naming ``what`` otherwise.

    Parameters
    ----------
    value : object
        any real scalar (:func:`real_number`): int, float, numpy scalar, 0-d array; not a bool
    what : str
        its name in the message (``"K"``, ``"--mass"``)
    lo, hi : float
        the interval's ends (default: > 0)
    lo_open, hi_open : bool
        whether each end is excluded
    unit : str
        shown after the bound, e.g. ``"[1/s]"``

    Returns
    -------
    float
    """
    x = real_number(value)
    if x is None:
        raise UsageError(f"{what} must be a number{_unit(_bound(lo, hi, lo_open, hi_open))}{_unit(unit)}, "
                         f"got {_brief(value)}")
    if not _inside(np.float64(x), lo, hi, lo_open, hi_open):
        raise UsageError(_refusal(what, x, lo, hi, lo_open, hi_open, _unit(unit)))
    return x


def check_integer(value, what, lo=1):
    """One whole number >= ``lo`` as an int (an int, a numpy integer, or a float with no fraction such as
    2.0); :class:`UsageError` naming ``what`` otherwise (a bool, 2.5, '3')."""
    x = real_number(value)
    if x is None or not math.isfinite(x) or x != int(x) or x < lo:
        shown = _show(x) if x is not None else _brief(value)
        raise UsageError(f"{what} must be an integer >= {lo}, got {shown}")
    return int(x)


def check_array(what, value, lo=0.0, hi=math.inf, *, lo_open=True, hi_open=False, unit="", where=None,
                where_text="", allow_inf=False):
    """Numbers (a scalar or an array) in an interval, as a float ndarray; :class:`UsageError` naming
    ``what`` and the first value refused otherwise.

    Parameters
    ----------
    what : str
        the parameter's name in the message (``"x_m"``)
    value : float or array_like
        the numbers
    lo, hi : float
        the interval's ends (default: > 0)
    lo_open, hi_open : bool
        whether each end is excluded
    unit : str
        shown after the bound
    where : ndarray of bool, optional
        check only these entries (broadcast with ``value``)
    where_text : str
        says where in the message (``"where x_m > 0"``)
    allow_inf : bool
        accept +inf (a static body's mass); nan is always refused

    Returns
    -------
    ndarray of float
    """
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise UsageError(f"{what} must be numbers{_unit(_bound(lo, hi, lo_open, hi_open))}{_unit(unit)}, "
                         f"got {_brief(value)}") from None
    bad = ~_inside(arr, lo, hi, lo_open, hi_open, allow_inf)
    if where is not None:
        bad = bad & where
    if np.any(bad):
        shown = np.broadcast_to(arr, bad.shape)[bad]
        raise UsageError(_refusal(what, float(shown.flat[0]), lo, hi, lo_open, hi_open,
                                  _unit(unit) + _unit(where_text), allow_inf))
    return arr


def _inside(arr, lo, hi, lo_open, hi_open, allow_inf=False):
    ok = (arr > lo) if lo_open else (arr >= lo)
    ok &= (arr < hi) if hi_open else (arr <= hi)
    return ok & (np.isfinite(arr) | (allow_inf & (arr == np.inf)))


def _bound(lo, hi, lo_open, hi_open):
    if hi == math.inf:
        return "" if lo == -math.inf else f"{'>' if lo_open else '>='} {_show(lo)}"
    return f"in {'(' if lo_open else '['}{_show(lo)}, {_show(hi)}{')' if hi_open else ']'}"


def _unit(unit):
    return f" {unit}" if unit else ""


def _refusal(what, x, lo, hi, lo_open, hi_open, suffix="", allow_inf=False):
    """The message for a number ``x`` outside the interval (or not finite); ``suffix`` follows the bound."""
    if hi != math.inf:
        return f"{what} must lie in {_bound(lo, hi, lo_open, hi_open)[3:]}{suffix}, got {_show(x)}"
    infinite = ", not a finite number" if math.isinf(x) and not allow_inf else ""   # nan: "must be a number" says it
    return f"{what} must be a number{_unit(_bound(lo, hi, lo_open, hi_open))}{suffix}, got {_show(x)}{infinite}"


def _show(x):
    """A number as short as :g when that is the value itself, else at repr precision (the value refused)."""
    x = float(x)
    short = f"{x:g}"
    return short if float(short) == x or not math.isfinite(x) else repr(x)


def _brief(value):
    """What was given instead of a number, short."""
    if isinstance(value, np.ndarray):
        return f"an array of shape {value.shape}"
    if isinstance(value, (bool, np.bool_)):
        return f"{value} (a bool)"
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def check_K(K_per_s):
    """K [1/s] as a float; UsageError unless it is one finite real number > 0 (:func:`check_number`)."""
    return check_number(K_per_s, "K", unit="[1/s]")


def check_epsilon(epsilon, what="epsilon"):
    """Return epsilon as a float in (0, 1]; :class:`UsageError` naming ``what`` otherwise."""
    return check_number(epsilon, what, 0.0, 1.0)


def _out(value):
    """Return a Python float for 0-d results, the array otherwise."""
    arr = np.asarray(value, dtype=float)
    return float(arr) if arr.ndim == 0 else arr


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
        ``x / (2 v)`` [s]; 0 where x = 0; ``inf`` where v is so small that the quotient leaves
        double precision (v below about x·1e-308 m/s).
    """
    x = check_array("x_m", x_m, lo_open=False)
    v = check_array("v_m_per_s", v_m_per_s, where=x > 0, where_text="where x_m > 0")
    x, v = np.broadcast_arrays(x, v)
    needs_v = x > 0
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
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
        ``exp(-K T)``, dimensionless, in (0, 1]; 0 where K T > 745, the underflow of double
        precision (the smallest epsilon it holds is about 5e-324, K T = 744.4)
    """
    T = check_array("T_s", T_s, lo_open=False)
    K = check_array("K_per_s", K_per_s)
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
    eps = check_array("epsilon", epsilon, 0.0, 1.0)
    K = check_array("K_per_s", K_per_s)
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
    x = check_array("x_m", x_m)
    T = check_array("T_s", T_s)
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
    v = check_array("v_m_per_s", v_m_per_s)
    T = check_array("T_s", T_s, lo_open=False)
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
    h = check_array("rebound height h", rebound_height_m, lo_open=False)
    H = check_array("drop height H", drop_height_m)
    h, H = np.broadcast_arrays(h, H)
    if np.any(h > H):
        i = np.flatnonzero(np.ravel(h > H))[0]
        raise UsageError(
            f"rebound height h = {_show(np.ravel(h)[i])} m exceeds drop height H = {_show(np.ravel(H)[i])} m: "
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
    H = check_array("drop height", drop_height_m, lo_open=False)
    g = check_array("g_m_per_s2", g_m_per_s2)
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
    D = check_array("diameter_m", diameter_m)
    h = np.asarray(height_m, dtype=float)
    return _out(h - POINT_OFFSET_DIAMETERS[measured_to] * D)


# --------------------------------------------------------------------------- air drag (not in the paper)


#: Density of dry air at 20 C and 101.325 kPa [kg/m^3], used by ``air_drag``.
AIR_DENSITY_KG_PER_M3 = 1.204
#: A smooth sphere's drag coefficient below the drag crisis (1e4 < Re < 2e5; Achenbach 1972, Mehta
#: 1985): the median of ``air_drag``'s prior, and the C_d vrcal assumes where a ball's own is not known.
SPHERE_DRAG_COEFFICIENT = 0.47


def sphere_volume_m3(diameter_m):
    """Volume of a sphere of diameter D.

    Parameters
    ----------
    diameter_m : float or ndarray
        sphere diameter D [m], > 0

    Returns
    -------
    volume_m3 : float or ndarray
        ``pi D^3 / 6`` [m^3]

    Raises
    ------
    UsageError
        if a diameter is not a finite number > 0

    Notes
    -----
    Not in [1]; the air a ball displaces (``buoyancy``) and its added mass rho V / 2.

    Examples
    --------
    >>> round(sphere_volume_m3(0.067) * 1e6, 2)   # a tennis ball [cm^3]
    157.48
    """
    D = check_array("diameter_m", diameter_m)
    return _out(math.pi * D**3 / 6.0)


def added_mass_kg(diameter_m, air_density_kg_per_m3=AIR_DENSITY_KG_PER_M3):
    """Added mass of a sphere moving through still air: the air it carries along [kg].

    Parameters
    ----------
    diameter_m : float or ndarray
        sphere diameter D [m], > 0
    air_density_kg_per_m3 : float or ndarray
        rho [kg/m^3], >= 0, default 1.204 (20 C)

    Returns
    -------
    added_mass_kg : float or ndarray
        ``rho V / 2``, V = pi D^3 / 6 [kg]

    Raises
    ------
    UsageError
        if a value is not finite or outside its range above

    Notes
    -----
    Not in [1]. Potential flow around a sphere (Landau & Lifshitz, Fluid Mechanics, Sec. 11),
    quasi-steady; it slows a light ball's drag and, with Archimedes' force, its fall (``buoyancy``).

    Examples
    --------
    >>> round(float(added_mass_kg(0.040)) * 1e3, 4)   # a table-tennis ball [g]; it weighs 2.7 g
    0.0202
    """
    D = check_array("diameter_m", diameter_m)
    rho = check_array("air_density_kg_per_m3", air_density_kg_per_m3, lo_open=False)
    return _out(_added_mass_kg(D, rho))


def _added_mass_kg(D, rho):
    """:func:`added_mass_kg` of checked arrays (the simulator's inner call)."""
    return 0.5 * rho * (math.pi * D**3 / 6.0)


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
        rho [kg/m^3], >= 0, default 1.204 (20 C)
    added_mass_kg : float or ndarray
        added mass of the air moving with the ball [kg], >= 0 (0 unless ``buoyancy`` is on)

    Returns
    -------
    k_per_m : float or ndarray
        ``rho C_d (pi D^2 / 4) / (2 (m + m_added))`` [1/m], >= 0; the terminal speed is sqrt(g/k).

    Raises
    ------
    UsageError
        if a value is not finite or outside its range above

    Notes
    -----
    Not in [1] (drag-free flights). C_d is taken constant (no drag crisis, no spin).
    """
    cd = check_array("drag_coefficient", drag_coefficient, lo_open=False)
    D = check_array("diameter_m", diameter_m)
    rho = check_array("air_density_kg_per_m3", air_density_kg_per_m3, lo_open=False)
    m = check_array("mass_kg", mass_kg) + check_array("added_mass_kg", added_mass_kg, lo_open=False)
    return _out(_drag_constant_per_m(cd, D, m, rho))


def _drag_constant_per_m(cd, D, m, rho):
    """:func:`drag_constant_per_m` of checked arrays (m the mass with the added mass)."""
    return rho * cd * (math.pi * D**2 / 4.0) / (2.0 * m)


#: Rounding allowed above epsilon = 1 by :func:`epsilon_from_heights_with_drag` (the closed form of a
#: drop at epsilon 1 gives 1 only to a few units in the last place).
#: An engine reproduces a measured rebound when its apex lies within this fraction of the rebound's rise
#: (its height above the contact level): the goal of ``vrcal verify`` (:mod:`vrcal.engines.replay`) and of
#: the constant epsilon ``vrcal discover`` offers for an engine without drag.
APEX_GOAL = 0.03


def constant_epsilon_for_heights(drop_height_m, apex_height_m, bounce):
    """The one constant epsilon whose drag-free bounce heights come nearest to given apex heights.

    Parameters
    ----------
    drop_height_m : float or ndarray
        drop height H [m] of the ball's bottom above the floor from which each apex was reached, > 0
    apex_height_m : float or ndarray
        apex height h [m] of the ball's bottom after bounce ``bounce`` of its drop, > 0
    bounce : int or ndarray
        the bounce n (1 = the first rebound) of each apex, >= 1; the three broadcast together (several
        drops of a drop table share the epsilon)

    Returns
    -------
    epsilon : float
        the constant whose heights H eps^(2n) (Eq. (9) of [1] bounce after bounce: no drag) miss the
        apexes least at the worst one: it minimises max |ln(H eps^(2n) / h)|
    misfit : ndarray
        H eps^(2n) / h - 1 of each apex [1] (the broadcast shape)

    Notes
    -----
    With x = ln eps every apex is a line 2 n x - ln(h / H); the least largest |line| (a Chebyshev fit of
    one parameter) lies where two of them have equal size and opposite sign, at the pair (i, j) whose
    |2 n_j ln(h_i / H_i) - 2 n_i ln(h_j / H_j)| / (2 n_i + 2 n_j) is largest (which is then that least
    misfit). Without drag (and a constant epsilon) every line meets at x = ln eps and the misfit is 0.
    """
    H = check_array("drop height H", drop_height_m)
    h = check_array("apex height h", apex_height_m)
    n = check_array("bounce n", bounce, 1.0, lo_open=False)
    H, h, n = np.broadcast_arrays(H, h, n)
    a, y = 2.0 * np.ravel(n), np.log(np.ravel(h / H))
    A = a[:, None] + a[None, :]
    gap = np.abs(a[None, :] * y[:, None] - a[:, None] * y[None, :]) / A
    i, j = np.unravel_index(int(np.argmax(gap)), gap.shape)
    x = (y[i] + y[j]) / A[i, j]
    return float(math.exp(x)), np.expm1(a * x - y).reshape(h.shape)


EPSILON_ROUNDING = 1e-12


def epsilon_from_heights_with_drag(rebound_height_m, drop_height_m, k_per_m, *, allow_above_one=False):
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
    allow_above_one : bool
        return an epsilon > 1 instead of raising: heights that no ball of epsilon <= 1 reaches
        with this drag (h > H, or too little lost for the drag), for a caller that tells the user
        what that means (``inf`` where it exceeds double precision)

    Returns
    -------
    epsilon : float or ndarray
        ``sqrt(expm1(2 k h) / (1 - exp(-2 k H)))``; ``sqrt(h / H)`` (Eq. 9) for k = 0. In (0, 1]
        (up to :data:`EPSILON_ROUNDING`) unless ``allow_above_one``.

    Raises
    ------
    UsageError
        if a height or k is negative or not finite, H = 0, or (without ``allow_above_one``)
        h > H or epsilon > 1: with drag a ball of epsilon 1 rises less than it fell.

    Notes
    -----
    Departure from [1], whose Eq. (9) ignores drag. The impact speed after a fall from
    rest is v_t sqrt(1 - exp(-2kH)) and a rebound at speed u rises to ln(1 + k u^2/g)/(2k)
    (v_t = sqrt(g/k)); eliminating u gives this closed form, independent of g. With C_d =
    0.5 the drag-free Eq. (9) underestimates the contact epsilon of the standards' drop
    tests by 0.024 (basketball, volleyball) to 0.037 (football).
    """
    h = check_array("rebound height h", rebound_height_m, lo_open=False)
    H = check_array("drop height H", drop_height_m)
    k = check_array("drag constant k_per_m", k_per_m, lo_open=False)
    h, H, k = np.broadcast_arrays(h, H, k)
    pos = k > 1e-150  # smaller k change nothing in double precision (and would overflow)
    ks = np.where(pos, k, 1.0)
    with np.errstate(over="ignore"):   # exp(2 k h) beyond double precision: epsilon = inf, far above 1
        eps = np.where(pos, np.sqrt(np.expm1(2.0 * ks * h) / -np.expm1(-2.0 * ks * H)), np.sqrt(h / H))
    above = eps > 1.0 + EPSILON_ROUNDING
    if not allow_above_one and np.any(above):
        i = np.flatnonzero(np.ravel(above))[0]
        hi, Hi, ki = (float(np.ravel(a)[i]) for a in (h, H, k))
        if hi > Hi:
            raise UsageError(f"rebound height h = {_show(hi)} m exceeds drop height H = {_show(Hi)} m: "
                             "a ball cannot rebound higher than it fell")
        raise UsageError(f"with air drag k = {_show(ki)} 1/m no ball rebounds h = {_show(hi)} m from H = "
                         f"{_show(Hi)} m (epsilon would be {float(np.ravel(eps)[i]):.6g} > 1)")
    return _out(eps)
