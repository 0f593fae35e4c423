"""Event-driven drop-test simulator: flights in closed form, impacts found exactly, many drops at once.

A ball is released from rest with its bottom at height H. Each flight is solved in
closed form -- a free fall, or, with ``air_drag``, the 1-D quadratic-drag flight
``a = -g - k v|v|`` -- so every impact time and speed is exact (no time step, no root
finder). At each contact the rebound speed is ``epsilon * impact speed`` with epsilon
given directly or from the virtual-body model (Eqs. (7) and (10) of [1], see
:func:`vrcal.model.restitution.epsilon_single`). Effects from :mod:`vrcal.drop.effects` change the
flights, the contacts or what is observed.

Closed forms (terminal speed v_t = sqrt(g/k), z = u/v_t for a flight leaving the floor
at speed u; every one reduces to the drag-free formula as k -> 0, which is used where
k == 0):

* up:   time to apex ``atan(z) / sqrt(g k)``      (k = 0: u/g),
        apex height ``ln(1 + z^2) / (2 k)``       (k = 0: u^2/(2g)),
        height ``ln(cos(b) + z sin(b)) / k``, b = tau sqrt(g k)  (k = 0: u tau - g tau^2/2);
* down: fall time from that apex ``asinh(z) / sqrt(g k)`` (k = 0: u/g),
        landing speed ``u / sqrt(1 + z^2)``       (k = 0: u),
        fallen distance ``ln cosh(b) / k``        (k = 0: g tau^2/2);
* from rest at H: landing speed ``v_t s``, fall time ``(k H + ln(1 + s)) / sqrt(g k)``,
  s = sqrt(1 - exp(-2 k H))  (k = 0: sqrt(2 g H), sqrt(2 H / g)).

All arrays carry a leading ``n_drops`` axis; numpy loops over drops, Python only over
bounces.

References
----------
[1] "The Graphical Method for Decision of Restitution Coefficient and Its Applications".
"""

from __future__ import annotations

import math

import numpy as np

from vrcal.drop.effects import (
    _buoyant_gravity_m_per_s2,
    _restitution_at_speed,
    resolve_effects,
    sampled_time_s,
)
from vrcal.errors import UsageError
from vrcal.model.body import ball_properties
from vrcal.model.plausible import ball_density_kg_per_m3
from vrcal.model.restitution import (
    AIR_DENSITY_KG_PER_M3,
    STANDARD_GRAVITY_M_PER_S2,
    _added_mass_kg,
    _drag_constant_per_m,
    _out,
    check_array,
    check_integer,
)

#: Output formats of :func:`sample_measurement` and ``vrcal simulate --format``.
FORMATS = ("trajectory", "impacts", "apexes")
#: Columns of each format (the keys of :func:`sample_measurement`'s result).
HEADERS = {"trajectory": ("t", "y"), "impacts": ("t",), "apexes": ("bounce", "h")}
#: Units written into the CSV header, ``t [s],y [m]`` (the readers of vrcal.measurements parse them).
UNITS = {"t": "s", "y": "m", "h": "m"}

_HOLD, _DOWN, _CONTACT, _UP, _REST = range(5)


# --------------------------------------------------------------------------- closed-form flights


#: Drag constants below this [1/m] are taken as 0: their effect (about k H, relative) is far below
#: double precision, and the closed forms would overflow for subnormal k.
K_NEGLIGIBLE_PER_M = 1e-150


def _safe_k(k):
    """(k > negligible mask, k elsewhere replaced by 1) -- the drag branch is selected by where()."""
    pos = k > K_NEGLIGIBLE_PER_M
    return pos, np.where(pos, k, 1.0)


def _flight_inputs(what, value, g_m_per_s2, k_per_m):
    """(value >= 0, g > 0, k >= 0) checked and broadcast: the closed forms' public boundary."""
    return np.broadcast_arrays(check_array(what, value, lo_open=False), check_array("g_m_per_s2", g_m_per_s2),
                               check_array("k_per_m", k_per_m, lo_open=False))


def fall_from_rest(drop_height_m, g_m_per_s2, k_per_m):
    """Fall time and landing speed of a ball released from rest at height H.

    Parameters
    ----------
    drop_height_m : float or ndarray
        fall height H [m], >= 0
    g_m_per_s2 : float or ndarray
        downward acceleration [m/s^2], > 0
    k_per_m : float or ndarray
        quadratic-drag constant k [1/m], >= 0 (0: no drag)

    Returns
    -------
    t_s, v_m_per_s : float or ndarray
        ``acosh(exp(k H)) / sqrt(g k)`` and ``v_t sqrt(1 - exp(-2 k H))``; for k = 0
        ``sqrt(2 H / g)`` and ``sqrt(2 g H)`` (Eq. (8) of [1]). Floats for scalar input.

    Raises
    ------
    UsageError
        if a value is not finite or outside its range above
    """
    return tuple(_out(a) for a in _fall_from_rest(*_flight_inputs("drop_height_m", drop_height_m, g_m_per_s2,
                                                                   k_per_m)))


def _fall_from_rest(H, g, k):
    """:func:`fall_from_rest` of checked arrays of one shape (the simulator's call)."""
    pos, ks = _safe_k(k)
    s = np.sqrt(-np.expm1(-2.0 * ks * H))
    t = np.where(pos, (ks * H + np.log1p(s)) / np.sqrt(g * ks), np.sqrt(2.0 * H / g))
    v = np.where(pos, s * np.sqrt(g / ks), np.sqrt(2.0 * g * H))
    return t, v


def flight_up_down(speed_m_per_s, g_m_per_s2, k_per_m):
    """Rise time, apex height, fall time and landing speed of a flight leaving the floor at speed u.

    Parameters
    ----------
    speed_m_per_s : float or ndarray
        upward speed u at lift-off [m/s], >= 0
    g_m_per_s2 : float or ndarray
        downward acceleration [m/s^2], > 0
    k_per_m : float or ndarray
        quadratic-drag constant k [1/m], >= 0

    Returns
    -------
    t_up_s, apex_m, t_down_s, v_land_m_per_s : float or ndarray
        with z = u sqrt(k/g): ``atan(z)/sqrt(gk)``, ``ln(1+z^2)/(2k)``, ``asinh(z)/sqrt(gk)``,
        ``u/sqrt(1+z^2)``; for k = 0: ``u/g``, ``u^2/(2g)``, ``u/g``, ``u``. Floats for scalar input.

    Raises
    ------
    UsageError
        if a value is not finite or outside its range above (a flight leaves the floor upward)
    """
    u, g, k = _flight_inputs("speed_m_per_s", speed_m_per_s, g_m_per_s2, k_per_m)
    pos, ks = _safe_k(k)
    z = u * np.sqrt(ks / g)
    sgk = np.sqrt(g * ks)
    t_up = np.where(pos, np.arctan(z) / sgk, u / g)
    apex = np.where(pos, np.log1p(z * z) / (2.0 * ks), u * u / (2.0 * g))
    t_down = np.where(pos, np.arcsinh(z) / sgk, u / g)
    v_land = np.where(pos, u / np.sqrt(1.0 + z * z), u)
    return _out(t_up), _out(apex), _out(t_down), _out(v_land)


def height_rising_m(tau_s, speed_m_per_s, g_m_per_s2, k_per_m):
    """Height of a ball tau after leaving the floor upward at speed u (valid up to the apex).

    Returns ``ln(cos b + z sin b) / k`` with b = tau sqrt(gk), z = u sqrt(k/g), written as
    ``log1p(z sin b - 2 sin^2(b/2)) / k``; ``u tau - g tau^2 / 2`` for k = 0 [m] (tau >= 0, u >= 0,
    g > 0, k >= 0; a float for scalar input).
    """
    tau, (u, g, k) = check_array("tau_s", tau_s, lo_open=False), _flight_inputs("speed_m_per_s", speed_m_per_s,
                                                                                g_m_per_s2, k_per_m)
    tau, u, g, k = np.broadcast_arrays(tau, u, g, k)
    pos, ks = _safe_k(k)
    b = tau * np.sqrt(g * ks)
    z = u * np.sqrt(ks / g)
    with np.errstate(invalid="ignore", divide="ignore"):
        drag = np.log1p(z * np.sin(b) - 2.0 * np.sin(0.5 * b) ** 2) / ks
    return _out(np.where(pos, drag, u * tau - 0.5 * g * tau * tau))


def distance_fallen_m(tau_s, g_m_per_s2, k_per_m):
    """Distance fallen from rest after tau: ``ln cosh(tau sqrt(gk)) / k``; ``g tau^2 / 2`` for k = 0 [m]
    (tau >= 0, g > 0, k >= 0; a float for scalar input)."""
    tau, g, k = _flight_inputs("tau_s", tau_s, g_m_per_s2, k_per_m)
    pos, ks = _safe_k(k)
    b = np.abs(tau) * np.sqrt(g * ks)
    small = np.minimum(b, 1.0)
    large = np.maximum(b, 1.0)
    logcosh = np.where(b < 1.0, np.log1p(2.0 * np.sinh(0.5 * small) ** 2),
                       large + np.log1p(np.exp(-2.0 * large)) - math.log(2.0))
    return _out(np.where(pos, logcosh / ks, 0.5 * g * tau * tau))


def _flight_kernel(g, k):
    """``flight_up_down`` specialised to fixed (g, k) arrays: the constants are computed once per call.

    Gives the same numbers as :func:`flight_up_down` up to rounding (it multiplies by
    1/sqrt(gk) instead of dividing).
    """
    pos = k > K_NEGLIGIBLE_PER_M
    if not pos.any():
        inv_g = 1.0 / g
        half_inv_g = 0.5 * inv_g
        return lambda u: (u * inv_g, u * u * half_inv_g, u * inv_g, u)
    ks = np.where(pos, k, 1.0)
    a = np.sqrt(ks / g)
    b = 1.0 / np.sqrt(g * ks)
    c = 0.5 / ks
    if pos.all():
        def flight(u):
            z = u * a
            z2 = z * z
            return np.arctan(z) * b, np.log1p(z2) * c, np.arcsinh(z) * b, u / np.sqrt(1.0 + z2)
        return flight

    def flight_mixed(u):
        z = u * a
        z2 = z * z
        return (np.where(pos, np.arctan(z) * b, u / g), np.where(pos, np.log1p(z2) * c, u * u / (2.0 * g)),
                np.where(pos, np.arcsinh(z) * b, u / g), np.where(pos, u / np.sqrt(1.0 + z2), u))
    return flight_mixed


# --------------------------------------------------------------------------- the simulation


class Drops:
    """The result of :func:`simulate_drops`; every array has a leading n_drops axis.

    Attributes
    ----------
    impact_times_s : (n_drops, n_bounces) time of each floor impact (first touch) [s]
    impact_speeds_m_per_s : (n_drops, n_bounces) speed just before impact [m/s]
    rebound_speeds_m_per_s : (n_drops, n_bounces) speed just after the contact [m/s]
    epsilons : (n_drops, n_bounces) coefficient of restitution applied at each contact
    liftoff_times_s : (n_drops, n_bounces) impact time + contact time [s]
    apex_times_s : (n_drops, n_bounces + 1) apex 0 = release [s]
    apex_heights_m : (n_drops, n_bounces + 1) apex heights of the ball's bottom [m]; [:, 0] = H
    landing_times_s : (n_drops,) landing after the flight that follows the last bounce [s]
    landing_speeds_m_per_s : (n_drops,) its speed [m/s]
    offset_m : (n_drops,) tracked point above the bottom (``height_offset``) [m]
    g_m_per_s2, k_per_m : (n_drops,) effective acceleration and drag constant of the flights
    readout_s_per_m : (n_drops,) a rolling shutter's kappa = R / H_frame (``rolling_shutter``) [s/m]
    """

    def __init__(self, **arrays):
        for name, value in arrays.items():
            setattr(self, name, value)

    @property
    def n_drops(self):
        return self.impact_times_s.shape[0]

    @property
    def n_bounces(self):
        return self.impact_times_s.shape[1]

    @property
    def observed_apex_heights_m(self):
        """(n_drops, n_bounces + 1) apex heights of the tracked point (bottom + offset) [m]."""
        return self.apex_heights_m + self.offset_m[:, None]

    def height_m(self, t_s):
        """Height of the observed point at times ``t_s`` [m].

        Parameters
        ----------
        t_s : float or ndarray
            one time, (n_t,) sample times shared by all drops, or (n_drops, n_t) [s]

        Returns
        -------
        y_m : ndarray (n_drops, n_t)  ((n_drops, 1) for one time)
            the ball's bottom plus ``offset_m``. Before release the ball is held still at
            H; during a contact of duration tau_c it dips below the floor level in a half
            sine, ``-A sin(pi (t - t_impact) / tau_c)`` with ``A = (v_in + v_out) tau_c / (2 pi)``
            (the compression of a linear spring-damper contact, the mean of the speeds in and
            out); after the landing that ends the last flight it rests on the floor (bottom at 0).
            With a rolling shutter (``readout_s_per_m`` kappa != 0) the height the camera saw in the frame
            stamped t: ``y_obs = y(t - kappa y_obs)`` (:func:`vrcal.drop.effects.sampled_time_s`), solved by
            the fixed-point iteration ``y <- y(t - kappa y)`` from y(t), which contracts by |kappa v| << 1
            per pass (0.05 for a 4 m/s ball and a 20 ms readout over 1.6 m), until no height changes by
            more than :data:`READOUT_TOLERANCE_M` (at most :data:`READOUT_MAX_PASSES` passes).
        """
        t = np.asarray(t_s, dtype=float)
        if t.ndim == 0:
            t = t.reshape(1)
        if t.ndim == 1:
            t = np.broadcast_to(t, (self.n_drops, t.size))
        if t.ndim != 2 or t.shape[0] != self.n_drops:
            raise UsageError(f"t_s must have shape (n_t,) or ({self.n_drops}, n_t), got {np.shape(t_s)}")
        y = self._height_at(t)
        kappa = getattr(self, "readout_s_per_m", None)
        rows = np.flatnonzero(kappa) if kappa is not None else ()
        if len(rows):
            # the rows of a rolling-shutter frame are read one after another: y_obs = y(t - kappa y_obs)
            y[rows] = seen_through_rolling_shutter(lambda s: self._height_at(s, rows), t[rows],
                                                   kappa[rows][:, None], y[rows])
        return y

    def _height_at(self, t, rows=None):
        """:meth:`height_m` without a rolling shutter: the height of the observed point at the times ``t``
        (n_rows, n_t) [s] of the drops ``rows`` (all drops when None) [m]."""
        breaks = self._breaks if rows is None else self._breaks[rows]
        rows = np.arange(self.n_drops) if rows is None else np.asarray(rows)
        shape = t.shape
        n_cols = self._kinds.shape[1]
        flat = (_segment_index(breaks, t) + (rows * n_cols)[:, None]).ravel()
        kind = self._kinds.ravel().take(flat)
        value = self._values.ravel().take(flat)
        tau = t.ravel() - self._starts.ravel().take(flat)
        row = flat // n_cols
        y = np.where(kind == _HOLD, value, 0.0)
        with np.errstate(all="ignore"):
            down = np.flatnonzero(kind == _DOWN)
            if down.size:
                r = row[down]
                y[down] = value[down] - _fallen(tau[down], self.g_m_per_s2[r], self.k_per_m[r])
            up = np.flatnonzero(kind == _UP)
            if up.size:
                r = row[up]
                y[up] = _risen(tau[up], value[up], self.g_m_per_s2[r], self.k_per_m[r])
            contact = np.flatnonzero(kind == _CONTACT)
            if contact.size:
                rate = self._rates.ravel().take(flat[contact])
                y[contact] = -value[contact] * np.sin(rate * tau[contact])
        return y.reshape(shape) + self.offset_m[rows][:, None]


#: A rolling shutter's fixed-point iteration (:meth:`Drops.height_m`) stops when no height changes by more
#: than this [m] (far below any noise, and below the changes the fitter's finite differences make: a
#: step of 2e-7 s/m in kappa moves a 4 m/s ball 0.5 m up by 4e-7 m) ...
READOUT_TOLERANCE_M = 1e-12
#: ... or after this many passes (at kappa v = 0.7, a 0.1 s/m readout and a 7 m/s ball, 1e-16 of the first
#: correction is left after 100).
READOUT_MAX_PASSES = 100


def seen_through_rolling_shutter(height_at, t_s, readout_s_per_m, start_m=None):
    """The heights a rolling-shutter camera shows in the frames stamped ``t_s`` [m]: the fixed point of
    ``y = height_at(t - kappa y)`` (:func:`vrcal.drop.effects.sampled_time_s`).

    Parameters
    ----------
    height_at : callable
        ``height_at(times)`` -> the heights [m] of the observed point at those times [s] (same shape)
    t_s : ndarray
        the frames' time stamps [s]
    readout_s_per_m : float or ndarray
        kappa = R / H_frame [s/m], broadcast against ``t_s``
    start_m : ndarray or None
        the heights to start from [m] (default ``height_at(t_s)``, the instant picture)

    Returns
    -------
    ndarray
        the heights seen [m]: the iteration ``y <- height_at(t - kappa y)`` contracts by |kappa v| << 1 per
        pass; it stops when no height changes by more than :data:`READOUT_TOLERANCE_M`, or after
        :data:`READOUT_MAX_PASSES` passes
    """
    t = np.asarray(t_s, dtype=float)
    y = np.asarray(height_at(t) if start_m is None else start_m, dtype=float)
    for _ in range(READOUT_MAX_PASSES):
        new = np.asarray(height_at(sampled_time_s(t, y, readout_s_per_m)), dtype=float)
        change = float(np.max(np.abs(new - y))) if new.size else 0.0
        y = new
        if not change > READOUT_TOLERANCE_M:
            break
    return y


def _fallen(tau, g, k):
    """Distance fallen from rest after tau [m] (:func:`distance_fallen_m` for tau >= 0), lean: the
    drag formula only where k > 0, ``ln cosh(b) / k`` with b = tau sqrt(g k) written as
    ``log1p(2 sinh^2(b / 2))`` below b = 1 and ``b + log1p(exp(-2 b)) - ln 2`` above (no overflow)."""
    out = 0.5 * g * tau * tau
    pos = k > K_NEGLIGIBLE_PER_M
    if pos.any():
        if not pos.all():
            idx = np.flatnonzero(pos)
            out[idx] = _fallen(tau[idx], g[idx], k[idx])
            return out
        b = tau * np.sqrt(g * k)
        small = b < 1.0
        logcosh = np.where(small, np.log1p(2.0 * np.sinh(0.5 * np.where(small, b, 0.0)) ** 2),
                           b + np.log1p(np.exp(-2.0 * b)) - math.log(2.0))
        return logcosh / k
    return out


def _risen(tau, u, g, k):
    """Height tau after leaving the floor at speed u [m] (:func:`height_rising_m`), lean."""
    pos = k > K_NEGLIGIBLE_PER_M
    if not pos.any():
        return u * tau - 0.5 * g * tau * tau
    if not pos.all():
        out = u * tau - 0.5 * g * tau * tau
        idx = np.flatnonzero(pos)
        out[idx] = _risen(tau[idx], u[idx], g[idx], k[idx])
        return out
    sgk = np.sqrt(g * k)
    b = tau * sgk
    z = u * sgk / g
    return np.log1p(z * np.sin(b) - 2.0 * np.sin(0.5 * b) ** 2) / k


def _segment_index(breaks, t):
    """Per row, how many of the row's (sorted) breaks are <= each time: one flat searchsorted."""
    n_rows, n_breaks = breaks.shape
    lo = min(float(np.min(breaks)), float(np.min(t)))
    span = max(float(np.max(breaks)), float(np.max(t))) - lo + 1.0
    offsets = (np.arange(n_rows, dtype=float) * span)[:, None]
    flat_breaks = ((breaks - lo) + offsets).ravel()
    pos = np.searchsorted(flat_breaks, ((t - lo) + offsets).ravel(), side="right").reshape(t.shape)
    return pos - (np.arange(n_rows) * n_breaks)[:, None]


def _as_drop_array(name, value, n):
    arr = np.asarray(value, dtype=float)
    if arr.shape == (n,):
        return arr.copy()
    if arr.ndim > 1 or (arr.ndim == 1 and arr.size not in (1, n)):
        raise UsageError(f"{name} must be a number or an array of shape ({n},), got shape {arr.shape}")
    return np.full(n, float(arr.reshape(-1)[0]) if arr.ndim else float(arr))


def _check(name, arr, lo, hi=np.inf, lo_open=True):
    bad = ~np.isfinite(arr) | ((arr <= lo) if lo_open else (arr < lo)) | (arr > hi)
    if np.any(bad):
        raise UsageError(f"{name} out of range, got {np.ravel(arr[bad])[0]:g}")


def simulate_drops(drop_height_m, epsilon, n_bounces, ball, *, effects=None,
                   g_m_per_s2=STANDARD_GRAVITY_M_PER_S2, release_time_s=0.0, reference_speed_m_per_s=None):
    """Simulate drop tests: n_bounces impacts and the flight after the last one, for many drops.

    Parameters
    ----------
    drop_height_m : float or ndarray
        height of the ball's bottom at release (from rest) [m], > 0
    epsilon : float or ndarray
        coefficient of restitution in (0, 1]; with ``velocity_dependent_restitution``
        the value at the reference speed (the drop's first impact speed)
    n_bounces : int
        number of floor impacts, >= 1
    ball : BallProperties or vrcal.model.standards.Ball
        mass and diameter (used by air_drag and buoyancy); arrays broadcast over drops
    effects : None or dict
        ``{effect name: {param: value}}`` (see :data:`vrcal.drop.effects.EFFECTS`); values
        are floats or arrays of shape (n_drops,); missing params take their defaults
    g_m_per_s2 : float or ndarray
        gravitational acceleration [m/s^2]
    release_time_s : float or ndarray
        time of release [s]
    reference_speed_m_per_s : float or ndarray or None
        v_ref of ``velocity_dependent_restitution`` [m/s]: ``epsilon`` is the value at this
        impact speed; None takes each drop's first impact speed (a joint fit of several drops
        passes one fixed speed, so that they share one law eps(v))

    Returns
    -------
    Drops

    Notes
    -----
    Event-driven: each flight is a closed form (see the module docstring), so impacts
    are exact. With ``buoyancy`` the flights use g_eff = g (m - rho V)/(m + rho V/2)
    and the drag constant is divided by the same added-mass factor (m + rho V/2)/m.
    ``velocity_dependent_restitution`` takes each drop's first impact speed as v_ref (unless
    ``reference_speed_m_per_s`` is given), so ``epsilon`` is the first bounce's (the drop-test
    value of Eq. (9) of [1]). With ``contact_duration`` the ball's bottom dips below the floor
    during each contact (see :meth:`Drops.height_m`).

    Without effects the apexes are ``eps^(2n) H`` and the impact times the geometric
    series ``t_n = t_1 + 2 t_1 (eps + ... + eps^(n-1))``, ``t_1 = sqrt(2 H / g)`` after release.
    """
    props = ball_properties(ball)
    n = check_integer(n_bounces, "n_bounces")
    eff = resolve_effects(effects)
    shapes = [np.shape(a) for a in (drop_height_m, epsilon, g_m_per_s2, release_time_s, props.mass_kg,
                                    props.diameter_m)]
    shapes += [np.shape(v) for params in eff.values() for v in params.values()]
    try:
        shape = np.broadcast_shapes(*shapes)
    except ValueError:
        raise UsageError(f"drop arrays do not broadcast together: shapes {sorted(set(shapes))}") from None
    if len(shape) > 1:
        raise UsageError(f"inputs must be scalars or 1-D arrays over drops, got shape {shape}")
    N = shape[0] if shape else 1
    H = _as_drop_array("drop_height_m", drop_height_m, N)
    eps = _as_drop_array("epsilon", epsilon, N)
    g0 = _as_drop_array("g_m_per_s2", g_m_per_s2, N)
    t0 = _as_drop_array("release_time_s", release_time_s, N)
    m = _as_drop_array("mass_kg", props.mass_kg, N)
    D = _as_drop_array("diameter_m", props.diameter_m, N)
    _check("drop height (drop_height_m, m)", H, 0.0)
    _check("epsilon (must lie in (0, 1])", eps, 0.0, 1.0)
    _check("g_m_per_s2", g0, 0.0)
    _check("release_time_s", t0, -np.inf)
    _check("mass_kg", m, 0.0)
    _check("diameter_m", D, 0.0)

    def param(effect, name):
        if effect not in eff:
            return None
        return _as_drop_array(f"{effect}.{name}", eff[effect][name], N)

    rho_b = param("buoyancy", "air_density_kg_per_m3")
    if rho_b is None:
        g, added = g0, 0.0
    else:
        g = _buoyant_gravity_m_per_s2(g0, D, m, rho_b)
        added = _added_mass_kg(D, rho_b)
        if np.any(g <= 0):
            i = int(np.argmin(g))
            rho_ball = float(ball_density_kg_per_m3(m[i], D[i]))
            raise UsageError(f"buoyancy: at an air density of {rho_b[i]:.4g} kg/m^3 a ball of {m[i]:g} kg and "
                             f"{D[i]:g} m ({rho_ball:.4g} kg/m^3) is lighter than the air it displaces (it would "
                             f"not fall); give an air density below {rho_ball:.4g} kg/m^3, or check the mass and "
                             f"diameter")
    cd = param("air_drag", "drag_coefficient")
    k = np.zeros(N) if cd is None else _drag_constant_per_m(cd, D, m + added, AIR_DENSITY_KG_PER_M3) * np.ones(N)
    tc = param("contact_duration", "contact_time_s")
    p = param("velocity_dependent_restitution", "exponent")
    offset = param("height_offset", "offset_m")
    offset = np.zeros(N) if offset is None else offset
    readout = param("rolling_shutter", "readout_s_per_m")

    v_ref = None if reference_speed_m_per_s is None else _as_drop_array(
        "reference_speed_m_per_s", reference_speed_m_per_s, N)
    if v_ref is not None:
        _check("reference_speed_m_per_s", v_ref, 0.0)
    impact_t = np.empty((N, n))
    impact_v = np.empty((N, n))
    rebound_v = np.empty((N, n))
    eps_used = np.empty((N, n))
    liftoff_t = np.empty((N, n))
    apex_t = np.empty((N, n + 1))
    apex_h = np.empty((N, n + 1))
    apex_t[:, 0] = t0
    apex_h[:, 0] = H
    t_fall, v_land = _fall_from_rest(H, g, k)
    flight = _flight_kernel(g, k)
    for j in range(n):
        impact_t[:, j] = apex_t[:, j] + t_fall
        impact_v[:, j] = v_land
        e = eps if p is None else _restitution_at_speed(eps, v_land, impact_v[:, 0] if v_ref is None else v_ref, p)
        eps_used[:, j] = e
        u = e * v_land
        rebound_v[:, j] = u
        liftoff_t[:, j] = impact_t[:, j] if tc is None else impact_t[:, j] + tc
        t_up, h, t_fall, v_land = flight(u)
        apex_t[:, j + 1] = liftoff_t[:, j] + t_up
        apex_h[:, j + 1] = h
    landing_t = apex_t[:, n] + t_fall

    # Segment tables for height_m: hold, fall from H, then (contact, up, down) per bounce, rest.
    breaks = np.empty((N, 3 * n + 2))
    breaks[:, 0] = t0
    breaks[:, 1:-1:3] = impact_t
    breaks[:, 2:-1:3] = liftoff_t
    breaks[:, 3:-1:3] = apex_t[:, 1:]
    breaks[:, -1] = landing_t
    kinds = np.empty((N, 3 * n + 3), dtype=np.intp)
    starts = np.zeros((N, 3 * n + 3))
    values = np.zeros((N, 3 * n + 3))
    kinds[:, 0], values[:, 0], starts[:, 0] = _HOLD, H, t0
    kinds[:, 1], values[:, 1], starts[:, 1] = _DOWN, H, t0
    kinds[:, 2:-1:3], starts[:, 2:-1:3] = _CONTACT, impact_t
    rates = np.zeros((N, 3 * n + 3))
    if tc is not None:
        dur = np.broadcast_to(np.asarray(tc, dtype=float)[:, None], impact_t.shape)
        pos = dur > 1e-9   # a contact shorter than a nanosecond has no dip worth computing
        rates[:, 2:-1:3] = np.where(pos, math.pi / np.where(pos, dur, 1.0), 0.0)
        values[:, 2:-1:3] = np.where(pos, (impact_v + rebound_v) * dur / (2.0 * math.pi), 0.0)
    kinds[:, 3:-1:3], starts[:, 3:-1:3], values[:, 3:-1:3] = _UP, liftoff_t, rebound_v
    kinds[:, 4::3], starts[:, 4::3], values[:, 4::3] = _DOWN, apex_t[:, 1:], apex_h[:, 1:]
    kinds[:, -1], starts[:, -1] = _REST, landing_t
    return Drops(
        impact_times_s=impact_t, impact_speeds_m_per_s=impact_v, rebound_speeds_m_per_s=rebound_v,
        epsilons=eps_used, liftoff_times_s=liftoff_t, apex_times_s=apex_t, apex_heights_m=apex_h,
        landing_times_s=landing_t, landing_speeds_m_per_s=v_land, offset_m=offset, g_m_per_s2=g, k_per_m=k,
        readout_s_per_m=np.zeros(N) if readout is None else readout,
        effects=eff, _breaks=breaks, _kinds=kinds, _starts=starts, _values=values, _rates=rates,
    )


# --------------------------------------------------------------------------- observations


def observations(drops, kind, t_s=None):
    """Noise-free observations of every drop, as a fitter compares them with data.

    Parameters
    ----------
    drops : Drops
    kind : {"trajectory", "impacts", "apexes"}
    t_s : ndarray or None
        sample times [s], (n_t,) or (n_drops, n_t); required for "trajectory"

    Returns
    -------
    ndarray (n_drops, n_obs)
        trajectory: heights of the tracked point at ``t_s`` [m]; impacts: impact times
        (n_bounces) [s]; apexes: apex heights of the tracked point, bounce 0 = drop height [m]
    """
    if kind == "trajectory":
        if t_s is None:
            raise UsageError("trajectory observations need the sample times t_s")
        return drops.height_m(t_s)
    if kind == "impacts":
        return drops.impact_times_s
    if kind == "apexes":
        return drops.observed_apex_heights_m
    raise UsageError(f"unknown format '{kind}' (valid: {', '.join(FORMATS)})")


#: Most frames of a simulated trajectory (2 million CSV rows take about 12 s to write).
MAX_FRAMES = 2_000_000


def sample_measurement(drops, kind, *, fs_hz=240.0, noise_m=0.0, jitter_s=0.0, rng=None, t_start_s=0.0,
                       drop_index=0):
    """What an experimenter records from one simulated drop, as columns of the CSV layouts.

    Parameters
    ----------
    drops : Drops
    kind : {"trajectory", "impacts", "apexes"}
    fs_hz : float
        frame rate of the trajectory [Hz], > 0; samples at ``t_start_s + i / fs_hz`` up to
        the landing after the last bounce
    noise_m : float
        standard deviation of Gaussian noise added to heights [m], >= 0
    jitter_s : float
        standard deviation of Gaussian noise added to impact times [s], >= 0
    rng : numpy.random.Generator or int or None
        noise source (``numpy.random.default_rng(rng)``)
    t_start_s : float
        time of the first video frame [s]
    drop_index : int
        which drop of ``drops``

    Returns
    -------
    dict
        trajectory: ``{"t": (n,), "y": (n,)}`` (tracked point, m); impacts: ``{"t": (n_bounces,)}``;
        apexes: ``{"bounce": 0..n_bounces, "h": observed apex heights}`` (bounce 0 = drop height).
    """
    if kind not in FORMATS:
        raise UsageError(f"unknown format '{kind}' (valid: {', '.join(FORMATS)})")
    for name, value in (("noise", noise_m), ("jitter", jitter_s)):
        if not (math.isfinite(value) and value >= 0):
            raise UsageError(f"{name} must be a finite number >= 0, got {value:g}")
    rng = np.random.default_rng(rng)
    i = int(drop_index)
    if kind == "trajectory":
        if not (math.isfinite(fs_hz) and fs_hz > 0):
            raise UsageError(f"--fs must be a number > 0 [Hz], got {fs_hz:g}")
        n_t = int(math.floor((drops.landing_times_s[i] - t_start_s) * fs_hz)) + 1
        if n_t < 2:
            raise UsageError("the trajectory ends before the first frame: check --fs and the start time")
        if n_t > MAX_FRAMES:
            raise UsageError(f"{n_t} frames, more than the limit of {MAX_FRAMES:,}: lower --fs or --bounces")
        t = t_start_s + np.arange(n_t) / fs_hz
        y = drops.height_m(np.broadcast_to(t, (drops.n_drops, n_t)))[i]
        if noise_m > 0:
            y = y + rng.normal(0.0, noise_m, n_t)
        return {"t": t, "y": y}
    if kind == "impacts":
        t = drops.impact_times_s[i].copy()
        if jitter_s > 0:
            t = np.sort(t + rng.normal(0.0, jitter_s, t.size))
        return {"t": t}
    h = drops.observed_apex_heights_m[i].copy()
    if noise_m > 0:
        h = h + rng.normal(0.0, noise_m, h.size)
    return {"bounce": np.arange(h.size), "h": h}


def columns_csv(columns, kind):
    """CSV text of :func:`sample_measurement`'s columns with the header of ``kind`` (repeatable)."""
    header = HEADERS[kind]
    lines = [",".join(f"{name} [{UNITS[name]}]" if name in UNITS else name for name in header)]
    cols = [np.asarray(columns[name]) for name in header]
    for row in zip(*cols):
        lines.append(",".join(str(int(v)) if name == "bounce" else f"{float(v):.10g}" for name, v in zip(header, row)))
    return "\n".join(lines) + "\n"


def simulate_csv(ball=None, *, kind="trajectory", drop_height_m=None, n_bounces=10, epsilon=None,
                 K_per_s=None, x_m=None, v_m_per_s=None, effects=None, fs_hz=240.0, noise_m=0.0,
                 jitter_s=0.0, seed=0, still_s=None, mass_kg=None, diameter_m=None, from_json=None,
                 g_m_per_s2=None, standards=None):
    """Simulate one drop as ``vrcal simulate`` does and return the CSV text.

    Parameters
    ----------
    ball : str or Body or None
        a ball of the standards, a free name with ``mass_kg`` and ``diameter_m``, None for
        ``mass_kg`` and ``diameter_m`` alone or ``from_json``, or a ready
        :class:`vrcal.model.body.Body` (see :func:`vrcal.model.body.describe_body`)
    kind : {"trajectory", "impacts", "apexes"}
    drop_height_m : float or None
        height of the ball's bottom at release [m]; default the discover result's release
        height, else the standard's drop height (to the bottom of the ball)
    n_bounces : int
    epsilon : float or None
        restitution; default from ``x_m``, ``v_m_per_s`` and ``K_per_s`` (Eqs. (7), (10) of
        [1]) when given, else the discover result's contact epsilon, else the standard's
        nominal epsilon (Eq. (9), both heights to the bottom,
        :func:`vrcal.model.standards.ball_epsilon`)
    K_per_s, x_m, v_m_per_s : float or None
        virtual body (depth [m], speed [m/s]) and rate constant [1/s]; K defaults to
        :data:`vrcal.inverse.DEFAULT_K_PER_S`
    effects : iterable of str or dict or None
        ``NAME[:PARAM=VALUE,...]`` specs or ``{name: {param: value}}``, added to (or
        replacing, by name) the discover result's effects
    fs_hz, noise_m, jitter_s, seed : see :func:`sample_measurement` (seed feeds default_rng)
    still_s : float or None
        still segment before release [s], >= 0; the release happens at t = still_s (default
        the discover result's release time, at least 0, else 0.2 s)
    mass_kg, diameter_m, from_json, standards : see :func:`vrcal.model.body.describe_body`
    g_m_per_s2 : float or None
        gravity [m/s^2]; default the discover result's, else 9.80665

    Returns
    -------
    str
        CSV text with the header of ``kind``
    """
    drops, _props = simulate_drop(ball, drop_height_m=drop_height_m, n_bounces=n_bounces, epsilon=epsilon,
                                  K_per_s=K_per_s, x_m=x_m, v_m_per_s=v_m_per_s, effects=effects, still_s=still_s,
                                  mass_kg=mass_kg, diameter_m=diameter_m, from_json=from_json, g_m_per_s2=g_m_per_s2,
                                  standards=standards)
    columns = sample_measurement(drops, kind, fs_hz=fs_hz, noise_m=noise_m, jitter_s=jitter_s, rng=seed)
    return columns_csv(columns, kind)


#: Still segment before release [s] of ``vrcal simulate`` (without a discover result's release time).
DEFAULT_STILL_S = 0.2


def simulate_drop(ball=None, *, drop_height_m=None, n_bounces=10, epsilon=None, K_per_s=None, x_m=None,
                  v_m_per_s=None, effects=None, still_s=None, mass_kg=None, diameter_m=None, from_json=None,
                  g_m_per_s2=None, standards=None):
    """One drop of a body as ``vrcal simulate`` makes it (parameters as :func:`simulate_csv`).

    With a discover result (``from_json``) this is the discovered model: its ball, contact
    epsilon, release height and time, named effects (air drag, a speed-dependent epsilon at
    its reference speed, ...) and g -- a synthetic record of what was measured.

    Returns
    -------
    (Drops, BallProperties)
    """
    from vrcal.model import restitution as eq
    from vrcal.model.body import Body, describe_body

    body = ball if isinstance(ball, Body) else describe_body(
        ball, mass_kg=mass_kg, diameter_m=diameter_m, from_json=from_json, standards=standards)
    if x_m is not None or v_m_per_s is not None:
        if epsilon is not None:
            raise UsageError("give either --epsilon or the virtual body --x/--v, not both")
        if x_m is None or v_m_per_s is None:
            raise UsageError("the virtual body needs both --x (depth, m) and --v (speed, m/s)")
        from vrcal.inverse import DEFAULT_K_PER_S

        epsilon = eq.epsilon_single(x_m, v_m_per_s, DEFAULT_K_PER_S if K_per_s is None else K_per_s)
    elif K_per_s is not None:
        raise UsageError("--K needs the virtual body --x and --v (or give --epsilon)")
    if epsilon is None:
        epsilon = body.epsilon()
        if epsilon is None:
            raise UsageError(f"'{body.name}' is not a ball of the standards: give --epsilon (or --x and --v)")
    if drop_height_m is None:
        drop_height_m = body.drop_height_m
        if drop_height_m is None:
            raise UsageError(f"'{body.name}' is not a ball of the standards: give --drop")
    if still_s is None:
        still_s = (max(0.0, float(body.discovered["model"]["release_time_s"])) if body.discovered is not None
                   else DEFAULT_STILL_S)
    if not (math.isfinite(drop_height_m) and drop_height_m > 0):
        raise UsageError(f"--drop must be a height > 0 [m], got {drop_height_m:g}")
    if isinstance(n_bounces, bool) or int(n_bounces) != n_bounces or n_bounces < 1:
        raise UsageError(f"--bounces must be an integer >= 1, got {n_bounces}")
    if not (math.isfinite(still_s) and still_s >= 0):
        raise UsageError(f"--still must be >= 0 [s], got {still_s:g}")
    if not (0 < epsilon <= 1):
        raise UsageError(f"epsilon must lie in (0, 1], got {epsilon:g}")
    g = body.gravity_m_per_s2(g_m_per_s2)
    planted = dict(body.effects)
    planted.update(resolve_effects(effects) or {})
    return simulate_drops(drop_height_m, epsilon, n_bounces, body.properties, effects=planted or None,
                          g_m_per_s2=g, release_time_s=still_s,
                          reference_speed_m_per_s=body.reference_speed_m_per_s), body.properties
