"""vrcal's own multi-sphere simulator: event-driven, with the impulse of Eq. (5) of [1] at every contact.

Between events every sphere flies under gravity alone (no air drag), in closed form. The
next event is the earliest sphere-floor contact (a quadratic in t) or sphere-sphere contact
(a quadratic in the relative motion when both spheres fly; a quartic, solved with numpy's
companion-matrix roots and polished by Newton steps, when one of them rests on the floor).
At a contact the restitution comes from the two bodies' virtual bodies, Eqs. (6) and (7)
(:func:`vrcal.scenes.spec.contact_epsilon`), the normal impulse from Eq. (5)
(:func:`normal_impulse_N_s`) and a Coulomb friction impulse (:func:`friction_impulse_N_s`).

Choices (departures from [1], which relied on ODE for all of this):

* Friction: Coulomb friction in impulse form, one coefficient mu per scene. The tangential
  impulse stops the sliding of the contact point if that needs at most mu*j ("sticking"),
  otherwise it is mu*j against the sliding direction ("sliding"). There is no tangential
  restitution: a sticking contact leaves the contact point with zero tangential speed. For a
  sphere r is parallel to n, so the normal impulse of Eq. (5) makes no spin; spin comes from
  the friction impulse only, Delta omega = I^-1 (r x J). A hollow shell (sports ball,
  I = 2/3 m R^2) that sticks keeps 3/5 of its tangential speed (a solid sphere, I = 2/5 m R^2:
  5/7).
* Simultaneous contacts (a stack of balls dropped together) are resolved one at a time, the
  fastest-approaching first, repeated until no touching pair (gap <= 1e-9 m) approaches
  ("sequential impulses"). For a stack this is the classic sequential-collision result.
* Resting: a floor impact slower than the scene's ``rest_speed_m_per_s`` is perfectly inelastic
  (epsilon = 0, with the same friction impulse) and puts the ball at rest on the floor: its
  vertical motion stops. This ends the infinite series of ever smaller bounces (Zeno). It is a
  floor-only rule: a ball-ball contact bounces with its pair epsilon at any speed (ODE's run sets
  ``bounce_vel`` 0 between balls for the same reason, :func:`vrcal.scenes.ode.bounce_velocity`).
* Sliding on the floor: while a ball rests on the floor (placed there, or after its last impact) and
  its lowest point slips, kinetic Coulomb friction mu m g acts against the slip
  (:func:`floor_sliding_friction`) until the ball rolls -- a closed-form event like the impacts;
  then it rolls on with no further loss (no rolling resistance is modelled). A hollow ball sliding
  at v0 without spin rolls at 3/5 v0 (solid: 5/7 v0). Spin about the vertical axis is left alone.
  A ball resting on another ball is not modelled: a scene that starts with one is refused
  up front, and one that comes to it (a ball settling on a ball that rests on the floor, or
  contacts piling up at one instant) stops at that moment with an error naming the bodies.
* Cost: every event screens every pair of bodies (numpy) and solves the few that may meet, so a
  run costs about events x (pairs + :data:`EVENT_COST_CHECKS`) contact checks.
  :func:`check_simulable` estimates the events (floor impacts before each body rests or the
  scene ends) and refuses a scene above :data:`MAX_CONTACT_CHECKS` before it starts.

References
----------
[1] "The Graphical Method for Decision of Restitution Coefficient and Its Applications",
    Eq. (5) (after Baraff's "Physically based modelling" notes, its reference [16]).
"""

from __future__ import annotations

import numpy as np

from vrcal.errors import DataError, UsageError
from vrcal.model.restitution import check_array
from vrcal.scenes.spec import SceneContact, SceneResult

#: Two surfaces closer than this [m] are in contact.
CONTACT_TOLERANCE_M = 1e-9
#: Default cap on the number of events (contacts and snapshots) of one run.
DEFAULT_MAX_EVENTS = 200_000
#: Most contact checks (events x (pairs + EVENT_COST_CHECKS)) a scene may be estimated to need: about
#: 20 s at ~2 us a check. A run whose events outgrow the estimate stops at 1.5 times this.
MAX_CONTACT_CHECKS = 10_000_000
#: The work of an event besides its pair checks (solving the contact, the snapshot), in checks.
EVENT_COST_CHECKS = 500
#: Events this close together in time [s] count as piling up at one instant ...
ZENO_STEP_S = 1e-6
#: ... and this many of them in a row stop the run (a ball settling on a ball, never at rest).
ZENO_EVENTS = 200

#: A ball on the floor whose lowest point slips slower than this [m/s] rolls.
SLIP_TOLERANCE_M_PER_S = 1e-9

_FLOOR = -1
_ROLL = -2      # the event "ball i stops slipping and rolls"


# --------------------------------------------------------------------------- equations


def _dot(a, b):
    return np.sum(np.asarray(a, dtype=float) * np.asarray(b, dtype=float), axis=-1)


def _matvec(m, v):
    return np.einsum("...ij,...j->...i", np.asarray(m, dtype=float), np.asarray(v, dtype=float))


def inverse_effective_mass_per_kg(direction, mass_a_kg, inv_inertia_a_per_kg_m2, r_a_m,
                                  mass_b_kg, inv_inertia_b_per_kg_m2, r_b_m):
    """The denominator of Eq. (5) of [1] for an impulse along ``direction``.

    Parameters
    ----------
    direction : array_like, shape (..., 3)
        unit vector of the impulse (the contact normal n for Eq. 5) [-]
    mass_a_kg, mass_b_kg : float or ndarray
        masses M_a, M_b [kg], > 0; ``np.inf`` for a static body (the floor), not both
    inv_inertia_a_per_kg_m2, inv_inertia_b_per_kg_m2 : array_like, shape (..., 3, 3)
        inverse inertia tensors I_a^-1, I_b^-1 in world axes [1/(kg m^2)]; zeros for a static body
    r_a_m, r_b_m : array_like, shape (..., 3)
        contact point relative to each body's centre of mass [m]

    Returns
    -------
    k_per_kg : float or ndarray
        ``1/M_a + 1/M_b + d.[(I_a^-1 (r_a x d)) x r_a] + d.[(I_b^-1 (r_b x d)) x r_b]`` [1/kg]
    """
    d = np.asarray(direction, dtype=float)
    ra, rb = np.asarray(r_a_m, dtype=float), np.asarray(r_b_m, dtype=float)
    m_a = check_array("mass_a_kg", mass_a_kg, allow_inf=True)
    m_b = check_array("mass_b_kg", mass_b_kg, allow_inf=True)
    term_a = _dot(d, np.cross(_matvec(inv_inertia_a_per_kg_m2, np.cross(ra, d)), ra))
    term_b = _dot(d, np.cross(_matvec(inv_inertia_b_per_kg_m2, np.cross(rb, d)), rb))
    k = 1.0 / m_a + 1.0 / m_b + term_a + term_b
    if np.any(~(k > 0)):
        raise UsageError("no impulse between two static bodies (both masses infinite, no inverse inertia): "
                         "1/M_a + 1/M_b + ... must be > 0")
    return float(k) if np.ndim(k) == 0 else k


def normal_impulse_N_s(v_rel_m_per_s, epsilon, normal, mass_a_kg, inv_inertia_a_per_kg_m2, r_a_m,
                       mass_b_kg, inv_inertia_b_per_kg_m2, r_b_m):
    """Magnitude j of the impulse J = j n at a colliding contact, Eq. (5) of [1].

    Parameters
    ----------
    v_rel_m_per_s : float or ndarray
        normal relative velocity before the impact, ``n . (pdot_a - pdot_b)`` [m/s]; < 0 when colliding
        (``pdot = v + omega x r`` is the velocity of the contact point, Eq. 4 of [1])
    epsilon : float or ndarray
        coefficient of restitution of the contact [-], in [0, 1] (Eqs. 6, 7 of [1])
    normal : array_like, shape (..., 3)
        unit contact normal n, pointing from body b towards body a [-]
    mass_a_kg, mass_b_kg : float or ndarray
        masses [kg], > 0; ``np.inf`` for a static body (the floor), not both
    inv_inertia_a_per_kg_m2, inv_inertia_b_per_kg_m2 : array_like, shape (..., 3, 3)
        inverse inertia tensors in world axes [1/(kg m^2)]; zeros for a static body
    r_a_m, r_b_m : array_like, shape (..., 3)
        contact point relative to each centre of mass [m]

    Returns
    -------
    j_N_s : float or ndarray
        ``-(1 + epsilon) v_rel / (1/M_a + 1/M_b + n.[(I_a^-1 (r_a x n)) x r_a] + n.[(I_b^-1 (r_b x n)) x r_b])``
        [N s]; body a receives +j n, body b receives -j n. Afterwards the normal relative
        velocity is exactly ``-epsilon v_rel`` (Eq. 3 of [1], sign as in Baraff's notes). 0 where the
        bodies already separate (``v_rel >= 0``): a contact only pushes (Eq. 5 as printed would pull).
    """
    k = inverse_effective_mass_per_kg(normal, mass_a_kg, inv_inertia_a_per_kg_m2, r_a_m, mass_b_kg,
                                      inv_inertia_b_per_kg_m2, r_b_m)
    eps = check_array("epsilon", epsilon, 0.0, 1.0, lo_open=False)
    v_rel = check_array("v_rel_m_per_s", v_rel_m_per_s, -np.inf, lo_open=False)
    j = -(1.0 + eps) * np.minimum(v_rel, 0.0) / k
    return float(j) if np.ndim(j) == 0 else j


def friction_impulse_N_s(slip_velocity_m_per_s, j_N_s, mu, k_tangential_per_kg):
    """Coulomb friction impulse at a contact (vrcal's choice; [1] leaves friction to ODE).

    Parameters
    ----------
    slip_velocity_m_per_s : array_like, shape (..., 3)
        tangential velocity of body a's contact point relative to body b's before the impulse [m/s]
    j_N_s : float or ndarray
        the normal impulse j of Eq. (5) [N s], >= 0
    mu : float or ndarray
        Coulomb friction coefficient [-], >= 0
    k_tangential_per_kg : float or ndarray
        :func:`inverse_effective_mass_per_kg` along the slip direction [1/kg], > 0

    Returns
    -------
    J_t_N_s : ndarray, shape (..., 3)
        friction impulse on body a [N s] (body b receives its opposite): the impulse that stops
        the slip, ``-u_t / k_t``, when its size is at most ``mu j`` (sticking), otherwise
        ``-mu j u_t/|u_t|`` (sliding). It never reverses the slip, so it never adds energy.
    """
    u = np.asarray(slip_velocity_m_per_s, dtype=float)
    speed = np.linalg.norm(u, axis=-1)
    stick = speed / check_array("k_tangential_per_kg", k_tangential_per_kg)
    size = np.minimum(stick, check_array("mu", mu, lo_open=False) * check_array("j_N_s", j_N_s, lo_open=False))
    with np.errstate(invalid="ignore", divide="ignore"):
        unit = np.where(speed[..., None] > 0, u / np.where(speed > 0, speed, 1.0)[..., None], 0.0)
    return -size[..., None] * unit


def floor_sliding_friction(slip_velocity_m_per_s, mu, g_m_per_s2, radius_m, inertia_factor):
    """Kinetic Coulomb friction on a sphere that slides while it rests on the floor (vrcal's choice).

    The floor pushes up with m g and, while the contact point slips with velocity u (horizontal),
    pulls with the constant force F = -mu m g u/|u| at r = -R z. The slip keeps its direction and
    shrinks at the constant rate mu g (1 + 1/k) until the ball rolls (u = 0); from then on there is
    no friction force (no rolling resistance is modelled).

    Parameters
    ----------
    slip_velocity_m_per_s : array_like, shape (..., 3)
        velocity of the contact point, ``v + omega x (-R z)``, horizontal [m/s]
    mu : float
        Coulomb friction coefficient [-], >= 0
    g_m_per_s2 : float
        gravitational acceleration [m/s^2], > 0
    radius_m : float or ndarray
        sphere radius R [m], > 0
    inertia_factor : float or ndarray
        k in I = k m R^2 [-], > 0 (2/3 hollow shell, 2/5 solid sphere)

    Returns
    -------
    acceleration_m_per_s2 : ndarray, shape (..., 3)
        ``-mu g u/|u|`` (zero when u = 0)
    angular_acceleration_rad_per_s2 : ndarray, shape (..., 3)
        ``I^-1 (r x F) = mu g (z x u/|u|) / (k R)``
    time_to_roll_s : ndarray, shape (...)
        ``|u| / (mu g (1 + 1/k))`` (inf when mu = 0 and u != 0; 0 when u = 0)

    Notes
    -----
    Textbook result (e.g. a billiard ball struck without spin): a ball sliding at v0 without spin
    rolls after ``v0 / (mu g (1 + 1/k))`` at ``v0 / (1 + k)`` -- 3/5 v0 for a hollow shell, 5/7 v0
    for a solid sphere; energy only decreases.
    """
    u = np.asarray(slip_velocity_m_per_s, dtype=float)
    speed = np.linalg.norm(u, axis=-1)
    mu = check_array("mu", mu, lo_open=False)
    g_m_per_s2 = check_array("g_m_per_s2", g_m_per_s2)
    radius_m = check_array("radius_m", radius_m)
    k = check_array("inertia_factor", inertia_factor)
    with np.errstate(invalid="ignore", divide="ignore"):
        unit = np.where(speed[..., None] > 0, u / np.where(speed > 0, speed, 1.0)[..., None], 0.0)
        rate = mu * g_m_per_s2 * (1.0 + 1.0 / k)
        t_roll = np.where(speed > 0, speed / np.where(rate > 0, rate, 0.0), 0.0)
    acc = -mu * g_m_per_s2 * unit
    alpha = mu * g_m_per_s2 * np.cross([0.0, 0.0, 1.0], unit) / (k * np.asarray(radius_m, dtype=float))[..., None]
    return acc, alpha, t_roll


# --------------------------------------------------------------------------- the simulator


class _State:
    def __init__(self, scene):
        self.scene = scene
        b = scene.bodies
        self.n = len(b)
        self.p = np.array([x.position_m for x in b], dtype=float)
        self.v = np.array([x.velocity_m_per_s for x in b], dtype=float)
        self.w = np.array([x.spin_rad_per_s for x in b], dtype=float)
        self.ang = np.zeros(self.n)
        self.rest = np.zeros(self.n, dtype=bool)
        self.R = np.array([x.radius_m for x in b])
        self.m = np.array([x.mass_kg for x in b])
        self.I = np.array([x.inertia_kg_m2 for x in b])
        self.t = 0.0
        self.g = scene.g_m_per_s2
        self.eps = scene.epsilon_matrix()
        self.k = self.I / (self.m * self.R * self.R)
        self.slide_acc = np.zeros((self.n, 3))   # floor friction on balls sliding on the floor [m/s^2]
        self.alpha = np.zeros((self.n, 3))       # its angular acceleration [rad/s^2]
        self.t_roll = np.full(self.n, np.inf)    # time from now until each sliding ball rolls [s]

    def floor_slip(self):
        """Velocity of each ball's lowest point [m/s], horizontal: v + omega x (-R z)."""
        u = self.v + np.cross(self.w, -self.R[:, None] * np.array([0.0, 0.0, 1.0]))
        u[:, 2] = 0.0
        return u

    def update_sliding(self):
        """After an event: kinetic friction on every ball that rests on the floor and slips."""
        u = self.floor_slip()
        sliding = self.rest & (np.linalg.norm(u, axis=1) > SLIP_TOLERANCE_M_PER_S) & (self.scene.friction_mu > 0)
        self.slide_acc[:] = 0.0
        self.alpha[:] = 0.0
        self.t_roll[:] = np.inf
        if sliding.any():
            acc, alpha, t_roll = floor_sliding_friction(u[sliding], self.scene.friction_mu, self.g,
                                                        self.R[sliding], self.k[sliding])
            self.slide_acc[sliding], self.alpha[sliding], self.t_roll[sliding] = acc, alpha, t_roll

    def roll(self, i):
        """Ball ``i`` has stopped slipping: set its spin to rolling exactly (removes rounding)."""
        self.w[i, 0] = -self.v[i, 1] / self.R[i]
        self.w[i, 1] = self.v[i, 0] / self.R[i]

    def accel(self):
        a = self.slide_acc.copy()
        a[~self.rest, 2] = -self.g
        return a

    def advance(self, dt):
        a = self.accel()
        self.p = self.p + self.v * dt + 0.5 * a * dt * dt
        self.v = self.v + a * dt
        self.ang = self.ang + self.w[:, 1] * dt + 0.5 * self.alpha[:, 1] * dt * dt
        self.w = self.w + self.alpha * dt
        self.t += dt            # t_roll needs no update: update_sliding sets it after every event

    def snapshot(self):
        return (self.t, self.p.copy(), self.v.copy(), self.w.copy(), self.ang.copy(), self.rest.copy(),
                self.accel(), self.alpha.copy())


def _floor_time(z0, vz, R, g):
    """Time until a flying sphere's bottom reaches z = 0 descending (inf if never)."""
    h = z0 - R
    disc = vz * vz + 2.0 * g * h
    if disc < 0:
        return np.inf
    s = np.sqrt(disc)
    if vz > 0:
        t = (vz + s) / g
    elif s - vz > 0:
        t = 2.0 * h / (s - vz)
    else:
        return np.inf
    return max(t, 0.0)


def _pair_time(d0, dv, da, S):
    """Time until two spheres' centres are S apart and approaching (inf if never)."""
    if not np.any(da):
        a, b, c = dv @ dv, 2.0 * (d0 @ dv), d0 @ d0 - S * S
        if a == 0 or b >= 0:
            return np.inf
        disc = b * b - 4.0 * a * c
        if disc < 0:
            return np.inf
        q = -0.5 * (b - np.sqrt(disc))
        return max(c / q, 0.0)
    A = 0.5 * da
    coeffs = [A @ A, 2.0 * (A @ dv), dv @ dv + 2.0 * (A @ d0), 2.0 * (dv @ d0), d0 @ d0 - S * S]

    def f(t):
        d = d0 + dv * t + A * t * t
        return d @ d - S * S, 2.0 * (d @ (dv + 2.0 * A * t))

    best = np.inf
    for root in np.roots(coeffs):
        if abs(root.imag) > 1e-6 * (1.0 + abs(root.real)):
            continue
        t = root.real
        for _ in range(3):
            val, der = f(t)
            if der == 0:
                break
            t -= val / der
        if t < -1e-12:
            continue
        t = max(t, 0.0)
        if f(t)[1] < 0 and t < best:
            best = t
    return best


def _contact_geometry(st, i, j):
    """normal n (from b to a), r_a, r_b, gap for body i against body j (or the floor)."""
    if j == _FLOOR:
        n = np.array([0.0, 0.0, 1.0])
        return n, -st.R[i] * n, np.zeros(3), st.p[i, 2] - st.R[i]
    d = st.p[i] - st.p[j]
    dist = np.linalg.norm(d)
    n = d / dist
    return n, -st.R[i] * n, st.R[j] * n, dist - st.R[i] - st.R[j]


def _point_velocity(st, k, r):
    if k == _FLOOR:
        return np.zeros(3)
    return st.v[k] + np.cross(st.w[k], r)


def _pair_gaps(st):
    """Gap between the surfaces of every pair i < j (vectorised; exact to rounding) [m], (n, n) upper."""
    d = st.p[:, None, :] - st.p[None, :, :]
    gaps = np.sqrt(np.einsum("ijk,ijk->ij", d, d)) - st.R[:, None] - st.R[None, :]
    return np.triu(gaps, 1) + np.tril(np.full((st.n, st.n), np.inf))


def _touching_approaching(st):
    """All touching pairs that approach, fastest first: [(v_rel, i, j)].

    The gaps of all pairs are screened at once (numpy); only the pairs that may touch (a margin of
    1e-9 m covers rounding) are examined one by one, exactly as before the screening.
    """
    found = []
    near = _pair_gaps(st) <= CONTACT_TOLERANCE_M + 1e-9
    for i in range(st.n):
        for j in [_FLOOR] + [int(k) for k in np.flatnonzero(near[i])]:
            n, ra, rb, gap = _contact_geometry(st, i, j)
            if gap > CONTACT_TOLERANCE_M:
                continue
            vrel = float(n @ (_point_velocity(st, i, ra) - _point_velocity(st, j, rb)))
            if vrel < -1e-12:
                found.append((vrel, i, j))
    found.sort()
    return found


def _resolve(st, i, j, vrel, contacts):
    scene = st.scene
    n, ra, rb, _gap = _contact_geometry(st, i, j)
    name_b = "floor" if j == _FLOOR else scene.bodies[j].name
    eps = float(st.eps[i, j])  # j == -1 picks the floor's column
    to_rest = j == _FLOOR and -vrel < scene.rest_speed_m_per_s
    if j != _FLOOR and -vrel < scene.rest_speed_m_per_s and (st.rest[i] or st.rest[j]) and abs(n[2]) > 0.5:
        lower, upper = (i, j) if st.rest[i] else (j, i)
        raise _resting_on_ball(scene, st.t, upper, lower)
    if to_rest:
        eps = 0.0  # a perfectly inelastic last impact (with friction) puts the ball at rest
    inv_ia = np.eye(3) / st.I[i]
    inv_ib = np.zeros((3, 3)) if j == _FLOOR else np.eye(3) / st.I[j]
    mb = np.inf if j == _FLOOR else st.m[j]
    u = _point_velocity(st, i, ra) - _point_velocity(st, j, rb)
    jn = normal_impulse_N_s(vrel, eps, n, st.m[i], inv_ia, ra, mb, inv_ib, rb)
    slip = u - (u @ n) * n
    jt_vec = np.zeros(3)
    note = ""
    if scene.friction_mu > 0 and np.linalg.norm(slip) > 1e-12:
        t_hat = slip / np.linalg.norm(slip)
        kt = inverse_effective_mass_per_kg(t_hat, st.m[i], inv_ia, ra, mb, inv_ib, rb)
        jt_vec = friction_impulse_N_s(slip, jn, scene.friction_mu, kt)
        note = "sliding" if np.linalg.norm(jt_vec) < np.linalg.norm(slip) / kt * (1 - 1e-12) else "sticking"
    J = jn * n + jt_vec
    st.v[i] += J / st.m[i]
    st.w[i] += inv_ia @ np.cross(ra, J)
    if st.v[i, 2] != 0.0:
        st.rest[i] = False
    if j != _FLOOR:
        st.v[j] -= J / st.m[j]
        st.w[j] -= inv_ib @ np.cross(rb, J)
        if st.v[j, 2] != 0.0:
            st.rest[j] = False
    if j == _FLOOR:
        st.p[i, 2] = max(st.p[i, 2], st.R[i])
    if to_rest:
        st.p[i, 2] = st.R[i]
        st.v[i, 2] = 0.0
        st.rest[i] = True
        note = "rest: slower than rest_speed_m_per_s" + (f"; {note}" if note else "")
    contacts.append(SceneContact(float(st.t), scene.bodies[i].name, name_b, -vrel, eps, jn,
                                 float(np.linalg.norm(jt_vec)), note))


def _resolve_all(st, contacts, max_rounds=10_000):
    for _ in range(max_rounds):
        found = _touching_approaching(st)
        if not found:
            # a ball on the floor with no vertical speed rests there (e.g. placed on the floor)
            on_floor = (st.p[:, 2] - st.R <= CONTACT_TOLERANCE_M) & (np.abs(st.v[:, 2]) <= 1e-12)
            st.p[on_floor, 2] = st.R[on_floor]
            st.v[on_floor, 2] = 0.0
            st.rest |= on_floor
            return
        vrel, i, j = found[0]
        _resolve(st, i, j, vrel, contacts)
    raise DataError(f"t = {st.t:.6g} s: simultaneous contacts did not settle after {max_rounds} impulses")


def _next_event(st, horizon_s=np.inf):
    """The earliest event (time from now [s], (i, j)); none (inf, None) within ``horizon_s``.

    A pair whose surfaces cannot close their gap before the earliest floor impact (or the
    horizon) -- its relative speed and acceleration bound how far they can approach -- is
    skipped without solving for its contact time: it cannot be the earliest event. The rest
    are solved one by one in the same order as without the screening, so the result is the same.
    """
    best, what = np.inf, None
    a = st.accel()
    floor_t = [_floor_time(st.p[i, 2], st.v[i, 2], st.R[i], st.g) if not st.rest[i] else np.inf
               for i in range(st.n)]
    bound = min(min(floor_t, default=np.inf), float(np.min(st.t_roll, initial=np.inf)), horizon_s)
    dv = np.linalg.norm(st.v[:, None, :] - st.v[None, :, :], axis=2)
    da = np.linalg.norm(a[:, None, :] - a[None, :, :], axis=2)
    gaps = _pair_gaps(st)
    upper = np.triu(np.ones((st.n, st.n), dtype=bool), 1)
    with np.errstate(invalid="ignore", over="ignore"):
        reach = dv * bound + 0.5 * da * bound * bound if np.isfinite(bound) else np.full_like(gaps, np.inf)
        may_meet = upper & ~(reach < gaps - 1e-9 * (1.0 + np.abs(gaps)))
    for i in range(st.n):
        if floor_t[i] < best:
            best, what = floor_t[i], (i, _FLOOR)
        if st.t_roll[i] < best:
            best, what = max(float(st.t_roll[i]), 0.0), (i, _ROLL)
        for j in np.flatnonzero(may_meet[i]):
            j = int(j)
            t = _pair_time(st.p[i] - st.p[j], st.v[i] - st.v[j], a[i] - a[j], st.R[i] + st.R[j])
            if t < best:
                best, what = t, (i, j)
    return best, what


def _resting_on_ball(scene, t_s, upper, lower):
    a, b = scene.bodies[upper].name, scene.bodies[lower].name
    return DataError(f"{scene.source}: t = {t_s:.6g} s: {a!r} comes to rest on {b!r}, which rests on the floor: "
                     "vrcal's simulator does not model a ball resting on a ball; use --engine ode, move the "
                     f"balls apart sideways, or end the scene before {t_s:.4g} s (duration_s)")


def floor_impacts_estimate(scene, cap=None):
    """Floor impacts of all bodies before each rests or the scene ends, as if no body met another.

    Parameters
    ----------
    scene : vrcal.scenes.spec.Scene
    cap : int or None
        stop counting above this many

    Returns
    -------
    int
        the count: each body falls from its start, rebounds with its floor epsilon (Eqs. 6, 7) and
        rests once an impact is slower than ``rest_speed_m_per_s``
    """
    eps = scene.epsilon_matrix()[:-1, -1]
    g, end, rest = scene.g_m_per_s2, scene.duration_s, max(scene.rest_speed_m_per_s, 1e-9)
    total = 0
    for body, e in zip(scene.bodies, eps):
        vz = body.velocity_m_per_s[2]
        v = float(np.sqrt(vz * vz + 2.0 * g * max(body.position_m[2] - body.radius_m, 0.0)))
        t = (vz + v) / g
        while t < end and v >= rest:
            total += 1
            if cap is not None and total > cap:
                return total
            v *= e
            t += 2.0 * v / g
    return total


def check_simulable(scene):
    """Refuse, before any work, a scene this simulator cannot run (in seconds) or does not model.

    Raises
    ------
    DataError
        a ball starts resting on a ball that rests on the floor (not modelled), or the run would
        need more than :data:`MAX_CONTACT_CHECKS` pair checks (too many bodies for the time asked)
    """
    p = np.array([b.position_m for b in scene.bodies])
    v = np.array([b.velocity_m_per_s for b in scene.bodies])
    r = np.array([b.radius_m for b in scene.bodies])
    on_floor = (p[:, 2] - r <= CONTACT_TOLERANCE_M) & (v[:, 2] <= 0)
    for lower in np.flatnonzero(on_floor):
        d = p - p[lower]
        gap = np.linalg.norm(d, axis=1) - r - r[lower]
        for upper in np.flatnonzero((gap <= CONTACT_TOLERANCE_M) & (d[:, 2] > 0.5 * (r + r[lower]))):
            if v[upper] @ d[upper] <= 0:  # not moving away: gravity presses it onto the lower ball
                raise DataError(f"{scene.source}: {scene.bodies[upper].name!r} starts resting on "
                                f"{scene.bodies[lower].name!r}, which rests on the floor: vrcal's simulator does "
                                "not model a ball resting on a ball; use --engine ode, or lift it or move it "
                                "sideways")
    n = len(scene.bodies)
    per_event = n * (n + 1) // 2 + EVENT_COST_CHECKS
    impacts = floor_impacts_estimate(scene, cap=MAX_CONTACT_CHECKS // per_event + 1)
    if impacts * per_event > MAX_CONTACT_CHECKS:
        more = "at least " if impacts > MAX_CONTACT_CHECKS // per_event else ""
        raise DataError(f"{scene.source}: too many bodies for the time asked: {more}{impacts} floor impacts, "
                        f"each checking {n * (n + 1) // 2} pairs of bodies and floor: {impacts * per_event:.2g} "
                        f"contact checks, more than the limit of {MAX_CONTACT_CHECKS:.0e} (about 20 s): fewer "
                        "bodies or a shorter duration_s")
    return impacts


def simulate_scene(scene, *, max_events=DEFAULT_MAX_EVENTS):
    """Run a scene in vrcal's event-driven simulator.

    Parameters
    ----------
    scene : vrcal.scenes.spec.Scene
    max_events : int
        stop with an error after this many events (a ball resting on another ball makes
        infinitely many contacts in finite time)

    Returns
    -------
    vrcal.scenes.spec.SceneResult
        trajectories at ``scene.sample_times_s()``, every contact with its epsilon and impulses,
        and every apex (exact, from the flight parabolas)
    """
    check_simulable(scene)
    n = len(scene.bodies)
    max_events = min(max_events, 3 * MAX_CONTACT_CHECKS // (2 * (n * (n + 1) // 2 + EVENT_COST_CHECKS)))
    st = _State(scene)
    contacts = []
    _resolve_all(st, contacts)
    st.update_sliding()
    snaps = [st.snapshot()]
    n_events = 0
    piled = 0  # events in a row closer together than ZENO_STEP_S
    while st.t < scene.duration_s:
        dt, what = _next_event(st, scene.duration_s - st.t)
        if st.t + dt >= scene.duration_s or what is None:
            st.advance(scene.duration_s - st.t)
            snaps.append(st.snapshot())
            break
        st.advance(dt)
        piled = piled + 1 if dt < ZENO_STEP_S else 0
        if piled >= ZENO_EVENTS:
            last = contacts[-1] if contacts else None
            who = f" ({last.body_a!r} on {last.body_b!r})" if last else ""
            raise DataError(f"{scene.source}: t = {st.t:.6g} s: {ZENO_EVENTS} contacts in a row less than "
                            f"{ZENO_STEP_S:g} s apart{who}: the simulation cannot advance (a ball settling on a "
                            "ball is not modelled by vrcal's simulator); use --engine ode, move the balls apart, "
                            f"or end the scene before {st.t:.4g} s (duration_s)")
        i, j = what
        if j == _FLOOR:
            st.p[i, 2] = st.R[i]  # the root of the quadratic: the bottom is at z = 0
        elif j == _ROLL:
            st.roll(i)
        _resolve_all(st, contacts)
        st.update_sliding()
        snaps.append(st.snapshot())
        n_events += 1
        if n_events >= max_events:
            last = contacts[-1] if contacts else None
            who = f" (last contact: {last.body_a} on {last.body_b})" if last else ""
            raise DataError(f"{scene.source}: more than {max_events} events before t = {st.t:.6g} s{who}, the "
                            f"limit for {n} bodies (1.5 x {MAX_CONTACT_CHECKS:.0e} contact checks): fewer bodies "
                            "or a shorter duration_s")
    return _sample(scene, snaps, contacts)


def _sample(scene, snaps, contacts):
    times = scene.sample_times_s()
    starts = np.array([s[0] for s in snaps])
    idx = np.clip(np.searchsorted(starts, times, side="right") - 1, 0, len(snaps) - 1)
    n_t, n_b = len(times), len(scene.bodies)
    pos = np.empty((n_t, n_b, 3))
    vel = np.empty((n_t, n_b, 3))
    spin = np.empty((n_t, n_b, 3))
    ang = np.empty((n_t, n_b))
    g = scene.g_m_per_s2
    for k in np.unique(idx):
        sel = idx == k
        t0, p, v, w, a0, rest, acc, alpha = snaps[k]
        tau = (times[sel] - t0)[:, None, None]
        pos[sel] = p[None] + v[None] * tau + 0.5 * acc[None] * tau**2
        vel[sel] = v[None] + acc[None] * tau
        spin[sel] = w[None] + alpha[None] * tau
        ang[sel] = a0[None] + w[None, :, 1] * tau[:, :, 0] + 0.5 * alpha[None, :, 1] * tau[:, :, 0] ** 2
    apexes = []
    radii = np.array([b.radius_m for b in scene.bodies])
    for k, (t0, p, v, _w, _a, rest, _acc, _alpha) in enumerate(snaps):
        t1 = snaps[k + 1][0] if k + 1 < len(snaps) else t0
        for b in range(n_b):
            if rest[b] or v[b, 2] < 0:
                continue
            ta = v[b, 2] / g
            if (k == 0 and ta == 0) or 0 < ta < t1 - t0 or (ta == t1 - t0 and k + 1 == len(snaps) - 1):
                apexes.append((scene.bodies[b].name, float(t0 + ta),
                               float(p[b, 2] + v[b, 2] * ta - 0.5 * g * ta**2 - radii[b])))
    apexes.sort(key=lambda a: (a[1], a[0]))
    return SceneResult(scene=scene, engine="vrcal", t_s=times, position_m=pos, velocity_m_per_s=vel,
                       spin_rad_per_s=spin, angle_y_rad=ang, contacts=contacts, apexes=apexes,
                       notes=[f"event-driven; {len(contacts)} contacts; friction mu = {scene.friction_mu:g} "
                              f"(Coulomb: impulse form at impacts, kinetic friction mu m g while a ball slides on the "
                              f"floor until it rolls); rest below {scene.rest_speed_m_per_s:g} m/s"],
                       settings={"events": len(snaps) - 1})
