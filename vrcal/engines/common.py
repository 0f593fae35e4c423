"""What every engine module shares: the drop-test setup, the target epsilon, and measuring epsilon.

A drop test (Eq. 9 of [1]): the ball is released from rest with its bottom at the drop height
H above a floor plane, bounces ``n_bounces`` times, and epsilon is read back two ways:

* apex ratio ``sqrt(h_k / h_{k-1})`` from the highest sampled bottom height of each flight
  (``h_0 = H``), the quantity the association rules measure;
* velocity ratio ``v_out / v_in`` of each contact, each speed taken from the last free-flight
  sample before and the first after the contact and carried ballistically to floor level
  (``sqrt(v^2 + 2 g z)``), so the step at which the engine happens to detect the contact
  does not enter.

"Contact phase": the impact falls at a different fraction of a time step depending on the
release height; :func:`phase_shifts_m` shifts the release height across one step of fall
so that the impacts cover the step evenly.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from vrcal.errors import DataError, UsageError

#: Gravity used by every exported engine file [m/s^2].
GRAVITY_M_PER_S2 = 9.81

#: Default tolerance on |achieved - target| epsilon.
DEFAULT_TOLERANCE = 0.005


@dataclass(frozen=True)
class DropSetup:
    """Everything an engine file needs for a ball-on-floor drop test, SI units.

    Attributes
    ----------
    ball : str
        ball key (or a label)
    mass_kg : float
        ball mass [kg]
    radius_m : float
        ball radius [m]
    drop_height_m : float
        height of the ball's bottom at release [m]
    epsilon : float
        target coefficient of restitution of the ball/floor pair, in (0, 1]
    dt_s : float
        engine time step [s]
    g_m_per_s2 : float
        gravitational acceleration [m/s^2]
    ball_epsilon : float
        the ball's own epsilon against a rigid floor (equal to ``epsilon`` on a rigid floor)
    floor_epsilon : float
        the floor's factor (Eq. 6: 1 for a rigid floor)
    notes : tuple
        how the numbers were chosen, for the exported file's header
    """

    ball: str
    mass_kg: float
    radius_m: float
    drop_height_m: float
    epsilon: float
    dt_s: float
    g_m_per_s2: float = GRAVITY_M_PER_S2
    ball_epsilon: float = None
    floor_epsilon: float = 1.0
    notes: tuple = ()

    @property
    def impact_speed_m_per_s(self):
        """Speed at the first impact, ``sqrt(2 g H)`` (Eq. 8 of [1]) [m/s]."""
        return math.sqrt(2.0 * self.g_m_per_s2 * self.drop_height_m)


def check_epsilon(epsilon, what="epsilon"):
    """Return epsilon as a float in (0, 1]; :class:`UsageError` otherwise."""
    try:
        e = float(epsilon)
    except (TypeError, ValueError):
        raise UsageError(f"{what} must be a number in (0, 1], got {epsilon!r}") from None
    if not (math.isfinite(e) and 0.0 < e <= 1.0):
        raise UsageError(f"{what} must lie in (0, 1], got {e:g}")
    return e


def check_dt(dt_s):
    """Return the time step as a float > 0 [s]; :class:`UsageError` otherwise."""
    try:
        dt = float(dt_s)
    except (TypeError, ValueError):
        raise UsageError(f"--dt must be a time step in seconds, got {dt_s!r}") from None
    if not (math.isfinite(dt) and 0.0 < dt <= 0.1):
        raise UsageError(f"--dt must be a time step in (0, 0.1] s, got {dt:g}")
    return dt


def phase_shifts_m(setup, n_phases):
    """Release-height shifts [m] that move the first impact across one time step.

    The ball falls ``v dt`` in the step around the impact; shifting H by ``k/n`` of that
    moves the impact by ``k/n`` of a step.
    """
    n = max(int(n_phases), 1)
    return setup.impact_speed_m_per_s * setup.dt_s * np.arange(n) / n


def flight_mask(v_m_per_s, dt_s, g_m_per_s2, rtol=1e-6):
    """True for each step ``i -> i+1`` that is free flight: ``v[i+1] - v[i] == -g dt``."""
    dv = np.diff(np.asarray(v_m_per_s, dtype=float))
    return np.abs(dv + g_m_per_s2 * dt_s) <= rtol * max(g_m_per_s2 * dt_s, 1e-300) + 1e-12


def measure_ratios(z_m, v_m_per_s, drop_height_m, dt_s, g_m_per_s2, n_bounces):
    """Apex and velocity ratios of the first ``n_bounces`` bounces of a sampled drop.

    Parameters
    ----------
    z_m : ndarray
        height of the ball's bottom above the floor at every step [m]; sample 0 is the release
    v_m_per_s : ndarray
        vertical velocity at every step [m/s], up positive
    drop_height_m : float
        bottom height at release [m]
    dt_s : float
        the engine's time step [s]
    g_m_per_s2 : float
        gravity [m/s^2]
    n_bounces : int
        bounces to measure

    Returns
    -------
    apex_ratios, velocity_ratios : ndarray
        each of length ``n_bounces``

    Raises
    ------
    DataError
        when the trajectory holds fewer bounces than asked (the ball stuck to the floor,
        or passed through it).
    """
    z = np.asarray(z_m, dtype=float)
    v = np.asarray(v_m_per_s, dtype=float)
    free = flight_mask(v, dt_s, g_m_per_s2)
    # contact runs: maximal runs of non-free steps
    steps = np.flatnonzero(~free)
    if steps.size == 0:
        raise DataError("the ball never touched the floor in the simulated time")
    breaks = np.flatnonzero(np.diff(steps) > 1)
    starts = np.r_[steps[0], steps[breaks + 1]]
    ends = np.r_[steps[breaks], steps[-1]]
    apex, vel = [], []
    prev_apex = float(drop_height_m)
    for k in range(min(len(starts), n_bounces)):
        i_in, i_out = starts[k], ends[k] + 1          # last free sample before, first after
        if i_out >= len(v) or v[i_out] <= 0:
            break
        v_in = math.sqrt(max(v[i_in] ** 2 + 2 * g_m_per_s2 * z[i_in], 0.0))
        v_out = math.sqrt(max(v[i_out] ** 2 + 2 * g_m_per_s2 * z[i_out], 0.0))
        nxt = starts[k + 1] if k + 1 < len(starts) else len(z) - 1
        if nxt <= i_out + 1 or np.all(v[i_out:nxt + 1] > 0):
            break                                      # flight not finished: no apex
        h = float(np.max(z[i_out:nxt + 1]))
        apex.append(math.sqrt(h / prev_apex) if prev_apex > 0 else math.nan)
        vel.append(v_out / v_in if v_in > 0 else math.nan)
        prev_apex = h
    if len(apex) < n_bounces:
        raise DataError(
            f"the ball made only {len(apex)} complete bounce(s) of the {n_bounces} asked for: "
            "it stuck to the floor or the contact settings do not bounce"
        )
    return np.array(apex), np.array(vel)


def flight_time_s(drop_height_m, epsilon, n_bounces, g_m_per_s2):
    """Time to the apex after bounce ``n_bounces`` for a ball dropped from rest [s] (closed form)."""
    t_fall = math.sqrt(2.0 * drop_height_m / g_m_per_s2)
    return t_fall * (1.0 + 2.0 * sum(epsilon ** k for k in range(1, n_bounces)) + epsilon ** n_bounces)


@dataclass
class VerifyResult:
    """The outcome of a drop test in a real engine.

    ``apex_ratios`` and ``velocity_ratios`` have shape (n_phases, n_bounces).
    """

    engine: str
    engine_version: str
    ball: str
    target: float
    dt_s: float
    tolerance: float
    phases_s: np.ndarray
    apex_ratios: np.ndarray
    velocity_ratios: np.ndarray
    settings: dict = field(default_factory=dict)
    notes: tuple = ()

    @property
    def error(self):
        """Largest |achieved - target| over bounces, phases, apex and velocity ratios."""
        both = np.concatenate([np.ravel(self.apex_ratios), np.ravel(self.velocity_ratios)])
        return float(np.max(np.abs(both - self.target)))

    @property
    def mean_apex_ratio(self):
        return float(np.mean(self.apex_ratios))

    @property
    def mean_velocity_ratio(self):
        return float(np.mean(self.velocity_ratios))

    @property
    def passed(self):
        return self.error <= self.tolerance

    def as_dict(self):
        return {
            "engine": self.engine, "engine_version": self.engine_version, "ball": self.ball,
            "target_epsilon": self.target, "dt_s": self.dt_s, "tolerance": self.tolerance,
            "phases_s": [float(p) for p in self.phases_s],
            "apex_ratios": np.round(self.apex_ratios, 6).tolist(),
            "velocity_ratios": np.round(self.velocity_ratios, 6).tolist(),
            "error": self.error, "passed": self.passed, "settings": self.settings,
        }


def stepped_drop_test(run_drop, params, setup, n_bounces, n_phases):
    """The drop test of a time-stepping engine, once per contact phase.

    ``run_drop(params, drop_height_m, duration_s)`` runs one drop and returns the sampled
    bottom height z [m] and vertical velocity v [m/s] of every step, the step dt [s] and g
    [m/s^2]. Returns the height shifts [m] and the apex and velocity ratios, each of shape
    (n_phases, n_bounces).
    """
    shifts = phase_shifts_m(setup, n_phases)
    apex, vel = [], []
    for shift in shifts:
        H = setup.drop_height_m + shift
        duration = flight_time_s(H, setup.epsilon, n_bounces, setup.g_m_per_s2) * 1.05
        z, v, dt, g = run_drop(params, H, duration)
        a, b = measure_ratios(z, v, H, dt, g, n_bounces)
        apex.append(a)
        vel.append(b)
    return shifts, np.array(apex), np.array(vel)
