"""MuJoCo: restitution as a damped-spring contact (``solref`` in direct form), export and drop test.

MuJoCo has no restitution parameter. A contact is a soft constraint whose reference
acceleration is ``a_ref = -b v - k r`` (r: penetration, negative inside); with the
impedance d (``solimp``) the constrained acceleration is ``a = d a_ref + (1 - d) a0``
and the constraint force ``m d (a_ref - a0)`` may not pull, so the contact ends when
the force reaches zero. In the direct form ``solref="-S -D"`` MuJoCo uses
``k = S / dmax^2`` and ``b = D / dmax``; vrcal writes ``S = d w^2``, ``D = 2 zeta w`` and
``solimp="d d ..."`` with d = 0.9999 so that the contact is the oscillator
``r'' = -2 zeta w r' - w^2 r`` with gravity held off by the constraint (the (1 - d) share
of gravity that leaks through is 1e-4 g).

For that oscillator, ended at zero force, epsilon is (Notes: force-zero relation)

    e(zeta) = exp(-zeta/sqrt(1-zeta^2) (pi - atan2(2 zeta sqrt(1-zeta^2), 1 - 2 zeta^2)))

(zeta < 1/sqrt(2)). Gravity moves the end of the contact a little (the force is zero when
``a_ref = -g``, not 0), which lowers epsilon by about ``0.5 g/(w v)`` for e = 0.5 at impact
speed v; :func:`contact_epsilon` models that exactly (it reproduces MuJoCo 4.0 to 2e-4) and
:func:`zeta_for_epsilon` solves it at the harmonic mean of the first and the last verified
impact speed, so the speed dependence is split evenly over the bounces.

Time step: the contact must be resolved in many steps. The damping force switches on in full
at the first contact step, so the scatter of epsilon over contact phases grows with
``zeta w dt`` (measured for a target of 0.5 over 4 phases x 3 bounces: max error 0.0046 at
w dt = 0.05, 0.0030 at w dt = 0.025, both at w = 1000 rad/s). vrcal sets ``w = 0.025 / dt`` (about 125 steps per
contact) with a default dt of 2.5e-5 s (w = 1000 rad/s, penetration about v/w = 6 mm for a
basketball), and refuses a time step whose ``w`` is so low that gravity alone would take
epsilon out of half the tolerance. Integrator RK4 (measured: about half the phase scatter of
Euler/implicitfast at the same step).
"""

from __future__ import annotations

import math
import re

import numpy as np
from scipy.optimize import brentq

from vrcal.engines.common import flight_time_s, measure_ratios, phase_shifts_m
from vrcal.errors import EngineUnavailable, UsageError

#: omega * dt used by the export (dimensionless).
OMEGA_DT = 0.025

#: Impedance d written to solimp (dmin = dmax): close to MuJoCo's maximum 0.9999.
IMPEDANCE = 0.9999

#: Default MuJoCo time step [s] for export and verify.
DEFAULT_DT_S = 2.5e-5

INTEGRATOR = "RK4"

#: Largest accepted contact penetration (about v/w), as a fraction of the ball's radius.
MAX_PENETRATION_RADII = 0.25

_ZETA_MAX = 1.0 / math.sqrt(2.0)


def epsilon_from_damping_ratio(zeta):
    """epsilon of a linear damped spring ended at zero contact force (no gravity).

    Parameters
    ----------
    zeta : float or ndarray
        damping ratio, in [0, 1/sqrt(2))

    Returns
    -------
    epsilon : float or ndarray
        ``exp(-zeta/sqrt(1-zeta^2) (pi - atan2(2 zeta sqrt(1-zeta^2), 1 - 2 zeta^2)))``

    Notes
    -----
    Not an equation of [1]: the contact model of MuJoCo. The classic
    ``exp(-zeta pi/sqrt(1-zeta^2))`` ends the contact at zero penetration instead and does
    not match MuJoCo (see engines-facts).
    """
    z = np.asarray(zeta, dtype=float)
    if np.any(~np.isfinite(z) | (z < 0) | (z >= _ZETA_MAX)):
        raise UsageError("damping ratio must lie in [0, 1/sqrt(2))")
    s = np.sqrt(1.0 - z * z)
    e = np.exp(-z / s * (np.pi - np.arctan2(2.0 * z * s, 1.0 - 2.0 * z * z)))
    return float(e) if e.ndim == 0 else e


def damping_ratio_from_epsilon(epsilon):
    """Invert :func:`epsilon_from_damping_ratio` (brentq); epsilon = 1 gives zeta = 0.

    Parameters
    ----------
    epsilon : float
        coefficient of restitution in (0, 1]

    Returns
    -------
    zeta : float
        damping ratio in [0, 1/sqrt(2))
    """
    if epsilon >= 1.0:
        return 0.0
    e_min = epsilon_from_damping_ratio(_ZETA_MAX * (1 - 1e-12))
    if epsilon <= e_min:
        raise UsageError(f"epsilon {epsilon:g} is below {e_min:.3g}, the least a MuJoCo contact spring gives")
    return brentq(lambda z: epsilon_from_damping_ratio(z) - epsilon, 0.0, _ZETA_MAX * (1 - 1e-12), xtol=1e-15)


def contact_epsilon(zeta, omega_per_s, impact_speed_m_per_s, g_m_per_s2):
    """epsilon of MuJoCo's contact oscillator with gravity, ended at zero constraint force.

    Parameters
    ----------
    zeta : float or ndarray
        damping ratio, in [0, 1/sqrt(2))
    omega_per_s : float or ndarray
        natural angular frequency w of the contact [rad/s]
    impact_speed_m_per_s : float or ndarray
        speed at first touch [m/s], > 0
    g_m_per_s2 : float or ndarray
        gravity [m/s^2], >= 0

    Returns
    -------
    epsilon : float or ndarray
        speed at which the bottom crosses floor level on the way up / impact speed

    Notes
    -----
    Contact: ``r'' = -2 zeta w r' - w^2 r`` from ``r = 0, r' = -v``; the constraint holds while
    its force ``m (a_ref + g)`` is positive, i.e. until ``a_ref = -g``; then free flight to
    r = 0. Measured MuJoCo 4.0 agrees to 2e-4 (e.g. 0.4919 at w = 100, v = 6 m/s, target 0.5).
    """
    out = np.vectorize(_contact_epsilon, otypes=[float])(zeta, omega_per_s, impact_speed_m_per_s, g_m_per_s2)
    return float(out) if out.ndim == 0 else out


def _contact_epsilon(zeta, omega_per_s, impact_speed_m_per_s, g_m_per_s2):
    w, v, g = float(omega_per_s), float(impact_speed_m_per_s), float(g_m_per_s2)
    if not (0.0 <= zeta < _ZETA_MAX and w > 0 and v > 0 and g >= 0):
        raise UsageError("contact_epsilon needs 0 <= zeta < 1/sqrt(2), w > 0, v > 0, g >= 0")
    wd = w * math.sqrt(1.0 - zeta * zeta)
    s = zeta * w

    def r(t):
        return -v / wd * math.exp(-s * t) * math.sin(wd * t)

    def rd(t):
        return -v / wd * math.exp(-s * t) * (wd * math.cos(wd * t) - s * math.sin(wd * t))

    def force(t):  # per unit mass, a_ref - a0
        return -2.0 * s * rd(t) - w * w * r(t) + g

    t_end = math.pi / wd
    if force(t_end) > 0:
        return rd(t_end) / v
    t1 = brentq(force, 0.0, t_end, xtol=1e-15)
    r1, v1 = r(t1), rd(t1)
    return math.sqrt(max(v1 * v1 + 2.0 * g * r1, 0.0)) / v


def omega_for_dt(dt_s):
    """Contact angular frequency w = OMEGA_DT / dt [rad/s]."""
    return OMEGA_DT / dt_s


def zeta_for_epsilon(epsilon, omega_per_s, impact_speed_m_per_s, g_m_per_s2):
    """Damping ratio for which :func:`contact_epsilon` equals ``epsilon`` at the given impact speed."""
    if epsilon >= 1.0:
        return 0.0
    zeta0 = damping_ratio_from_epsilon(epsilon)

    def f(z):
        return contact_epsilon(z, omega_per_s, impact_speed_m_per_s, g_m_per_s2) - epsilon

    lo = 0.0
    if f(lo) < 0:
        raise UsageError(
            f"a MuJoCo contact at w = {omega_per_s:g} rad/s cannot reach epsilon {epsilon:g} at "
            f"{impact_speed_m_per_s:.3g} m/s (gravity ends the contact early): use a smaller --dt"
        )
    return brentq(f, lo, min(zeta0 * 1.5 + 1e-3, _ZETA_MAX * (1 - 1e-9)), xtol=1e-15)


def contact_parameters(setup, n_bounces=3, tolerance=0.005):
    """solref/solimp and the numbers behind them for a :class:`DropSetup`.

    Raises
    ------
    UsageError
        when the time step is too large for a contact stiff enough that gravity keeps
        epsilon within ``tolerance`` over ``n_bounces`` bounces.
    """
    w = omega_for_dt(setup.dt_s)
    if setup.g_m_per_s2 == 0:          # ball/ball contact: gravity acts on both, not on their distance
        zeta = damping_ratio_from_epsilon(setup.epsilon)
        return {"omega_per_s": w, "damping_ratio": zeta, "damping_ratio_no_gravity": zeta,
                "solref": [-IMPEDANCE * w * w, -2.0 * zeta * w], "solimp": [IMPEDANCE, IMPEDANCE, 0.001, 0.5, 2]}
    v0 = setup.impact_speed_m_per_s
    v_last = v0 * setup.epsilon ** (n_bounces - 1)
    # gravity lowers epsilon by about c/v: calibrating at the harmonic mean of the first and
    # the last impact speed splits that error evenly between them
    v_ref = 2.0 / (1.0 / v0 + 1.0 / v_last)
    zeta = zeta_for_epsilon(setup.epsilon, w, v_ref, setup.g_m_per_s2)
    predicted = {v: contact_epsilon(zeta, w, v, setup.g_m_per_s2) for v in (v0, v_last)}
    worst = max(predicted.values(), key=lambda e: abs(e - setup.epsilon))
    if abs(worst - setup.epsilon) > tolerance / 2:
        dt_ok = setup.dt_s * (tolerance / 2) / abs(worst - setup.epsilon)
        raise UsageError(
            f"time step {setup.dt_s:g} s is too large for MuJoCo: the contact spring it allows "
            f"(w = {OMEGA_DT:g}/dt = {w:.4g} rad/s) lets gravity move epsilon to {worst:.4f} "
            f"over {n_bounces} bounces (target {setup.epsilon:.4f}); use --dt {dt_ok:.2g} or smaller"
        )
    if v0 / w > MAX_PENETRATION_RADII * setup.radius_m:
        dt_ok = OMEGA_DT * MAX_PENETRATION_RADII * setup.radius_m / v0
        raise UsageError(
            f"time step {setup.dt_s:g} s is too large for MuJoCo: the contact spring it allows "
            f"(w = {OMEGA_DT:g}/dt = {w:.4g} rad/s) lets the ball sink about {1000 * v0 / w:.3g} mm into the floor, "
            f"more than {MAX_PENETRATION_RADII:g} of its radius; use --dt {dt_ok:.2g} or smaller"
        )
    stiffness = IMPEDANCE * w * w
    damping = 2.0 * zeta * w
    return {
        "omega_per_s": w,
        "damping_ratio": zeta,
        "damping_ratio_no_gravity": damping_ratio_from_epsilon(setup.epsilon),
        "solref": [-stiffness, -damping],
        "solimp": [IMPEDANCE, IMPEDANCE, 0.001, 0.5, 2],
        "max_penetration_m": v0 / w,
        "calibration_speed_m_per_s": v_ref,
        "predicted_epsilon_first_bounce": predicted[v0],
        "predicted_epsilon_last_bounce": predicted[v_last],
    }


def _fmt(x):
    return f"{x:.10g}"


def export_mjcf(setup, n_bounces=3, tolerance=0.005, pair_bodies=None):
    """A complete MJCF model: floor plane, the ball on a free joint, contact pair with solref.

    Parameters
    ----------
    setup : DropSetup
    n_bounces, tolerance : int, float
        used to check that the time step is small enough (see :func:`contact_parameters`)
    pair_bodies : list of DropSetup, optional
        ``[second ball (its own epsilon vs floor), pair setup (epsilon of ball/ball2)]``
        for ``--against``: adds the second ball and ball/ball2 and ball2/floor pairs.

    Returns
    -------
    str
        MJCF text (loads with ``mujoco.MjModel.from_xml_string``)
    """
    p = contact_parameters(setup, n_bounces, tolerance)
    R, H = setup.radius_m, setup.drop_height_m
    lines = [
        '<mujoco model="vrcal-drop">',
        f"  <!-- vrcal export: {setup.ball} on a rigid floor, target epsilon {setup.epsilon:.6f} -->",
        f"  <!-- contact spring w = {p['omega_per_s']:.6g} rad/s (w*dt = {OMEGA_DT}), damping ratio "
        f"{p['damping_ratio']:.6f} (force-zero relation, gravity-corrected at {p['calibration_speed_m_per_s']:.4g} m/s) -->",
        f"  <!-- predicted epsilon {p['predicted_epsilon_first_bounce']:.5f} at the first impact "
        f"({setup.impact_speed_m_per_s:.4g} m/s), {p['predicted_epsilon_last_bounce']:.5f} at bounce {n_bounces} -->",
        f"  <!-- solref direct form: -(d w^2), -(2 zeta w); solimp d = {IMPEDANCE}; "
        f"max penetration about {p['max_penetration_m'] * 1000:.3g} mm -->",
        f'  <option timestep="{_fmt(setup.dt_s)}" integrator="{INTEGRATOR}" gravity="0 0 {-setup.g_m_per_s2:g}"/>',
        "  <default>",
        '    <geom contype="0" conaffinity="0"/>  <!-- contacts come only from the explicit pairs below -->',
        "  </default>",
        "  <worldbody>",
        '    <geom name="floor" type="plane" size="10 10 0.1"/>',
        f'    <body name="ball" pos="0 0 {_fmt(H + R)}">',
        "      <freejoint/>",
        f'      <geom name="ball" type="sphere" size="{_fmt(R)}" mass="{_fmt(setup.mass_kg)}"/>',
        "    </body>",
    ]
    pairs = [("ball", "floor", p)]
    if pair_bodies:
        second, pair_setup = pair_bodies
        p2 = contact_parameters(second, n_bounces, tolerance)
        pp = contact_parameters(pair_setup, n_bounces, tolerance)
        R2 = second.radius_m
        lines += [
            f'    <body name="ball2" pos="{_fmt(3 * (R + R2))} 0 {_fmt(second.drop_height_m + R2)}">',
            "      <freejoint/>",
            f'      <geom name="ball2" type="sphere" size="{_fmt(R2)}" mass="{_fmt(second.mass_kg)}"/>',
            "    </body>",
        ]
        pairs += [("ball2", "floor", p2), ("ball", "ball2", pp)]
    lines += ["  </worldbody>", "  <contact>"]
    for g1, g2, q in pairs:
        solref = " ".join(_fmt(x) for x in q["solref"])
        solimp = " ".join(_fmt(x) for x in q["solimp"])
        lines.append(f'    <pair geom1="{g1}" geom2="{g2}" condim="1" solref="{solref}" solimp="{solimp}"/>')
    lines += ["  </contact>", "</mujoco>", ""]
    return "\n".join(lines)


def _mujoco():
    try:
        import mujoco
    except ImportError:
        raise EngineUnavailable("MuJoCo is not installed: pip install mujoco (or pip install 'vrcal[engines]')") from None
    return mujoco


def version():
    return _mujoco().__version__


def run_drops(mjcf, drop_height_m, shifts_m, duration_s, radius_m):
    """Drop the ball of an exported MJCF from ``drop_height_m + shift`` for every shift.

    Uses ``mujoco.rollout`` (one batch, C loop).

    Returns
    -------
    z_m, v_m_per_s : ndarray
        (n_shifts, n_steps + 1) bottom height and vertical velocity, sample 0 = release
    dt_s, g_m_per_s2 : float
        as read back from the loaded model
    """
    mujoco = _mujoco()
    from mujoco import rollout

    try:
        model = mujoco.MjModel.from_xml_string(mjcf)
    except ValueError as exc:
        raise UsageError(f"MuJoCo cannot load the model: {exc}") from None
    data = mujoco.MjData(model)
    dt = float(model.opt.timestep)
    g = -float(model.opt.gravity[2])
    joint = model.body("ball").jntadr[0]
    qadr, vadr = model.jnt_qposadr[joint], model.jnt_dofadr[joint]
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    states = []
    for shift in shifts_m:
        mujoco.mj_resetData(model, data)
        data.qpos[qadr + 2] = drop_height_m + shift + radius_m
        mujoco.mj_forward(model, data)
        st = np.empty(mujoco.mj_stateSize(model, spec))
        mujoco.mj_getState(model, data, st, spec)
        states.append(st)
    states = np.array(states)
    nstep = int(math.ceil(duration_s / dt))
    out, _ = rollout.rollout(model, data, states, nstep=nstep)
    # state layout: time, qpos, qvel, ...
    zq = np.concatenate([states[:, None, 1 + qadr + 2], out[:, :, 1 + qadr + 2]], axis=1) - radius_m
    vq = np.concatenate([states[:, None, 1 + model.nq + vadr + 2], out[:, :, 1 + model.nq + vadr + 2]], axis=1)
    return zq, vq, dt, g


def drop_test(mjcf, setup, n_bounces, n_phases):
    """Run the exported model and measure apex and velocity ratios, shape (n_phases, n_bounces)."""
    shifts = phase_shifts_m(setup, n_phases)
    duration = flight_time_s(setup.drop_height_m + shifts[-1], setup.epsilon, n_bounces, setup.g_m_per_s2) * 1.05
    stiffness = [-float(x) for x in re.findall(r'solref="(-[0-9.e+-]+) ', mjcf)]
    if stiffness:                      # contacts last about pi/w each: add two periods per bounce
        duration += n_bounces * 2.0 * math.pi / math.sqrt(min(stiffness))
    z, v, dt, g = run_drops(mjcf, setup.drop_height_m, shifts, duration, setup.radius_m)
    apex, vel = [], []
    for k, shift in enumerate(shifts):
        a, b = measure_ratios(z[k], v[k], setup.drop_height_m + shift, dt, g, n_bounces)
        apex.append(a)
        vel.append(b)
    return shifts, np.array(apex), np.array(vel)
