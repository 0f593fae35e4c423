"""What every engine module shares: the drop-test setup, its target, and measuring it in an engine.

A drop test (Eq. 9 of [1]): the ball is released from rest with its bottom at the drop height
H above a floor plane and bounces ``n_bounces`` times. The *target* is vrcal's own
event-driven model of the same drop (:func:`vrcal.drop.simulate.simulate_drops`: exact
impacts, closed-form flights, with the air drag and the speed-dependent epsilon of a
``vrcal discover`` result when there are any). An engine's run is read back two ways:

* apex ratio ``sqrt(h_k / h_{k-1})`` from the highest sampled bottom height of each flight
  (``h_0 = H``), the quantity the association rules measure; its target is the model's
  apex ratio (epsilon itself without drag);
* velocity ratio ``v_out / v_in`` of each contact, each speed taken from the last free-flight
  sample before and the first after the contact and carried to floor level, so the step at
  which the engine happens to detect the contact does not enter. Each speed is that of the
  parabola the sampled positions lie on, where it crosses z = 0 (:func:`floor_speed_m_per_s`):
  for semi-implicit Euler (ODE, Bullet, MuJoCo's Euler/implicit/implicitfast: velocity first,
  then position) the stored velocity is half a step behind the positions, and the carry
  takes that into account; for an exact flight (MuJoCo's RK4) the sample's own velocity is
  carried. So ``v_out / v_in`` is the ratio of the flights' speeds at floor level, which is
  also the ratio sqrt(h'/h) of the flights' own apexes (the sampled apex falls up to
  ``g dt^2/8`` below its flight's). Its target is the model's epsilon at that impact speed.

The *error* is the largest |achieved - target| over both ratios, all bounces and contact
phases. The *penetration* is the deepest the ball's bottom went below the floor, the
*hover* the highest it turned above it (a MuJoCo contact with a margin acts before touch).

"Contact phase": the impact falls at a different fraction of a time step depending on the
release height; :func:`phase_shifts_m` shifts the release height across one step of fall
so that the impacts cover the step evenly.

References
----------
[1] "The Graphical Method for Decision of Restitution Coefficient and Its Applications".
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from vrcal.errors import DataError, UsageError, unit_hint
from vrcal.model.restitution import STANDARD_GRAVITY_M_PER_S2, check_epsilon  # noqa: F401 (engines use it)

#: Gravity of every exported engine file unless ``--g`` [m/s^2] (the same in every command).
GRAVITY_M_PER_S2 = STANDARD_GRAVITY_M_PER_S2

#: Default tolerance on |achieved - target| epsilon (``--tolerance``).
DEFAULT_TOLERANCE = 0.01

#: Default largest penetration (or hover), as a fraction of the ball's radius (``--max-penetration``):
#: about what a real ball deforms at drop-test speed (a tennis ball ~10 mm at 7 m/s, R = 33 mm).
MAX_PENETRATION_RADII = 0.25

#: Default bounces and contact phases of a drop test.
N_BOUNCES = 3
N_PHASES = 4

#: Contact phases a step is confirmed with before an export accepts or names it, and the default of
#: ``vrcal verify``: a search runs N_PHASES phases per step, a step that passes there is run again
#: with these. Measured (benchmarks/bench_step_monotonic.py, worst error over 4 / 16 / 64 phases):
#: a 200 g, 70 mm ball of epsilon 0.45 dropped 0.5 m, 0.0069 / 0.0127 / 0.0127 in PyBullet at
#: 0.77 ms, 0.0099 / 0.0204 / 0.0229 in ODE at 1 ms, 0.0047 / 0.0119 / 0.0119 in MuJoCo at 0.7 ms;
#: 16 phases came within 15 % of 64 at every step measured; 4 phases were up to 67 % below.
CONFIRM_PHASES = 16

#: Most bounces a drop test may ask for (each one more is a longer run and a smaller rebound).
MAX_BOUNCES = 50

#: Smallest rebound [m] that counts as a bounce (below it the ball rests: a drop test refuses such bounces).
RISE_M = 1e-3

#: Smallest time step vrcal accepts [s] (below it no engine run ends in reasonable time).
MIN_DT_S = 1e-7

#: Largest time step [s].
MAX_DT_S = 0.1

#: Rebound heights (each relative to the height the ball fell from) off the target's by more than this
#: fraction are shown beside the epsilon error (:meth:`DropRuns.height_ratio_text`): at the default
#: tolerance 0.01, epsilon 0.2 and below.
HEIGHT_RATIO_SHOWN = 0.1

#: Relative rounding of ``v_out / v_in`` still read as 1 (above it, the engine added energy: :attr:`DropRuns.gain`).
GAIN_RTOL = 1e-6

#: Integrators whose flights are semi-implicit Euler (velocity updated first, then position).
SEMI_IMPLICIT = ("euler", "implicit", "implicitfast", "ode", "bullet")


@dataclass(frozen=True)
class DropSetup:
    """Everything an engine file needs for a ball-on-floor drop test, SI units.

    Attributes
    ----------
    ball : str
        the body's name (or a label)
    mass_kg : float
        ball mass [kg]
    radius_m : float
        ball radius [m]
    drop_height_m : float
        height of the ball's bottom at release (from rest) [m]
    epsilon : float
        target coefficient of restitution of the ball/floor pair, in (0, 1]; with a
        ``restitution_exponent`` the value at the first impact speed
    dt_s : float
        engine time step [s]
    g_m_per_s2 : float
        gravitational acceleration [m/s^2]
    ball_epsilon : float
        the ball's own epsilon against a rigid floor (equal to ``epsilon`` on a rigid floor)
    floor_epsilon : float
        the floor's factor (Eq. 6: 1 for a rigid floor)
    notes : tuple
        how the numbers were chosen, for the exported file's header and the reports
    n_bounces : int
        bounces the export is calibrated and verified over
    drag_coefficient : float
        C_d of quadratic air drag, ``a = -g - k v|v|`` (0: no drag;
        :func:`vrcal.drop.effects.drag_constant_per_m` gives k)
    restitution_exponent : float
        p of ``eps(v) = 1 - (1 - eps)(v / v_1)^p``, v_1 = the first impact speed (0: constant)
    tolerance : float
        largest accepted |achieved - target| epsilon
    max_penetration_m : float or None
        largest accepted penetration or hover [m]; None: a quarter of the radius
    integrator : str or None
        MuJoCo's integrator (euler, implicit, implicitfast, rk4); None for other engines
    release_time_s : float
        time of release in a replayed record [s] (0 for a drop test)
    height_offset_m : float
        tracked point above the ball's bottom in a replayed record [m]
    baseline_epsilon : float or None
        the constant epsilon a drag-free engine reproduces a discover result's bounce heights with
        (``epsilon_effective_without_drag``; an older result's baseline epsilon), if any
    apex_goal : float or None
        each rebound's apex within this fraction of vrcal's model's (the heights compound each
        bounce's error), as ``vrcal verify --against`` judges a record's
        (:data:`vrcal.model.restitution.APEX_GOAL`); set for an export from a discover result's record
        in an engine that carries its law; None: not judged
    apex_floor_m : float
        ... or within this many metres of it: 3 sigmas of the record's noise (the same goal) [m]
    substeps : int
        PyBullet's ``numSubSteps`` (``--substeps``; 0: none): each ``stepSimulation()`` advances
        ``substeps x dt_s``, the file's ``fixedTimeStep``, in that many steps of ``dt_s``, the step the
        engine runs at and every check is made at
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
    n_bounces: int = N_BOUNCES
    drag_coefficient: float = 0.0
    restitution_exponent: float = 0.0
    tolerance: float = DEFAULT_TOLERANCE
    max_penetration_m: float = None
    integrator: str = None
    release_time_s: float = 0.0
    height_offset_m: float = 0.0
    baseline_epsilon: float = None
    apex_goal: float = None
    apex_floor_m: float = 0.0
    substeps: int = 0

    @property
    def step_options(self):
        """The options that give this step, for a message: '--dt DT s' or, with PyBullet's substeps,
        '--dt DT s --substeps N' (DT the stepSimulation() step, ``substeps x dt_s``)."""
        if self.substeps:
            return f"--dt {self.dt_s * self.substeps:g} s --substeps {self.substeps:d}"
        return f"--dt {self.dt_s:g} s"

    @property
    def penetration_limit_m(self):
        """``max_penetration_m``, or a quarter of the radius [m]."""
        if self.max_penetration_m is not None:
            return float(self.max_penetration_m)
        return MAX_PENETRATION_RADII * self.radius_m

    @property
    def drag_k_per_m(self):
        """Quadratic-drag constant k of ``a = -g - k v|v|`` [1/m] (0 without drag)."""
        if not self.drag_coefficient:
            return 0.0
        from vrcal.drop.effects import drag_constant_per_m

        return float(drag_constant_per_m(self.drag_coefficient, 2.0 * self.radius_m, self.mass_kg))

    @property
    def effects(self):
        """The setup's effects as ``{effect: {param: value}}`` for :func:`vrcal.drop.simulate.simulate_drops`."""
        out = {}
        if self.drag_coefficient:
            out["air_drag"] = {"drag_coefficient": float(self.drag_coefficient)}
        if self.restitution_exponent:
            out["velocity_dependent_restitution"] = {"exponent": float(self.restitution_exponent)}
        return out

    @property
    def semi_implicit(self):
        """True when the engine's flights are semi-implicit Euler (see the module docstring)."""
        return self.integrator is None or self.integrator.lower() in SEMI_IMPLICIT

    @cached_property
    def model(self):
        """vrcal's exact model of this drop (:class:`vrcal.drop.simulate.Drops`, one drop)."""
        return self.model_at(self.drop_height_m)

    def model_at(self, drop_heights_m):
        """vrcal's model of drops released from rest at ``drop_heights_m`` [m] (one per height)."""
        from vrcal.drop.simulate import simulate_drops
        from vrcal.model.body import BallProperties

        H = np.atleast_1d(np.asarray(drop_heights_m, dtype=float))
        # v_ref of the speed-dependent epsilon is the first impact speed of the nominal drop
        # for every shifted drop too (shifts of a fraction of a step barely move it)
        eps = self.epsilon
        if self.restitution_exponent:
            from vrcal.drop.effects import restitution_at_speed
            from vrcal.drop.simulate import fall_from_rest

            v_own = fall_from_rest(H, self.g_m_per_s2, self.drag_k_per_m)[1]
            eps = restitution_at_speed(self.epsilon, v_own, self.impact_speed_m_per_s, self.restitution_exponent)
        return simulate_drops(H, eps, int(self.n_bounces), BallProperties(self.mass_kg, 2.0 * self.radius_m,
                                                                          self.ball),
                              effects=self.effects or None, g_m_per_s2=self.g_m_per_s2)

    @property
    def impact_speed_m_per_s(self):
        """Speed at the first impact [m/s]: ``sqrt(2 g H)`` (Eq. 8 of [1]) without drag."""
        from vrcal.drop.simulate import fall_from_rest

        return float(fall_from_rest(self.drop_height_m, self.g_m_per_s2, self.drag_k_per_m)[1])

    @property
    def impact_speeds_m_per_s(self):
        """Speeds of the ``n_bounces`` impacts of the model's drop [m/s]."""
        return np.asarray(self.model.impact_speeds_m_per_s[0], dtype=float)

    @property
    def epsilons(self):
        """The model's epsilon at each of the ``n_bounces`` impacts."""
        return np.asarray(self.model.epsilons[0], dtype=float)

    def flight_time_s(self, drop_height_m=None):
        """Time from release to the apex after the last bounce [s] (the model's, closed form)."""
        H = self.drop_height_m if drop_height_m is None else drop_height_m
        return float(self.model_at(H).apex_times_s[0, -1])


def metadata(setup):
    """The numbers of the drop test that an exported file carries for ``vrcal verify --file``."""
    return {
        "epsilon": setup.epsilon, "drop_height_m": setup.drop_height_m, "g_m_per_s2": setup.g_m_per_s2,
        "n_bounces": setup.n_bounces, "drag_coefficient": setup.drag_coefficient,
        "restitution_exponent": setup.restitution_exponent, "tolerance": setup.tolerance,
        "max_penetration_m": setup.penetration_limit_m, "release_time_s": setup.release_time_s,
        "height_offset_m": setup.height_offset_m,
        **({"apex_goal": setup.apex_goal, "apex_floor_m": setup.apex_floor_m} if setup.apex_goal is not None
           else {}),
    }


#: How the note of an ODE, PyBullet or Gazebo export that did not run in its engine starts (the engine
#: is not installed here: :func:`vrcal.engines.export.check_step`); :func:`step_note` then says so.
NOT_RUN = "not run"


def engine_label(engine):
    """How a note names the engine that runs ``engine``'s file: ODE (also Gazebo's), PyBullet, MuJoCo
    (the ``label`` of its :func:`vrcal.engines.runtime` entry); ``engine`` itself for any other name."""
    from vrcal.engines import ENGINES

    entry = ENGINES.get(engine)
    return ENGINES[entry.runs_in].label if entry is not None and entry.runs_in else engine


def step_note(setup, engine):
    """The line every exported file carries: the time step its numbers hold for (< 100 columns).

    MuJoCo's contact is tuned to its step (the damper's ``D = (1 + eps)/dt`` and margin
    ``v dt/2``, or a spring calibrated at dt): at another step the bounce is another one. ODE's
    and Bullet's bounce is epsilon at any step, but the depth and the epsilon error were checked
    at this step only, and a smaller step can miss where this one passed (measured:
    ``benchmarks/bench_step_monotonic.py``); where the engine is not installed (a note of the
    setup starts with :data:`NOT_RUN`) nothing was checked, and the line says so. The MuJoCo and
    Gazebo lines go into XML comments, which may not hold two dashes: they name no option.
    """
    from vrcal.engines import get_engine

    if engine == "mujoco":
        return f"valid at timestep {setup.dt_s:g} s only (the contact is tuned to it): export again for another"
    verified = get_engine(engine).runs          # vrcal verify runs the file itself (not Gazebo's SDF)
    if any(note.startswith(NOT_RUN) for note in setup.notes):
        line = f"NOT checked at step {setup.dt_s:g} s: not run, {engine_label(engine)} is not installed here"
        return line + "; vrcal verify --file F runs it" if verified else line
    line = f"checked at step {setup.dt_s:g} s only (another, even a smaller one, can miss)"
    return line + "; vrcal verify --file F --dt DT runs it at DT" if verified else line


def drag_force_coefficient_kg_per_m(setup):
    """c of the drag force ``F = -c |v| v`` = 1/2 rho C_d pi R^2 [kg/m] (= m k)."""
    return setup.mass_kg * setup.drag_k_per_m


def restitution_table(setup, n=8):
    """A table of the setup's speed-dependent epsilon over its impact speeds: (speeds [m/s], epsilons)."""
    from vrcal.drop.effects import restitution_at_speed

    v = setup.impact_speeds_m_per_s
    lo, hi = float(np.min(v)), float(np.max(v))
    speeds = np.linspace(0.5 * lo, 1.2 * hi, n)
    eps = restitution_at_speed(setup.epsilon, speeds, setup.impact_speed_m_per_s, setup.restitution_exponent)
    return speeds, np.asarray(eps, dtype=float)


def check_dt(dt_s, what="--dt"):
    """Return the time step as a float in [:data:`MIN_DT_S`, :data:`MAX_DT_S`] [s]; UsageError otherwise.

    The message is the command line's (:data:`vrcal.options.TIME_STEP_S`); ``what`` names the
    step (``--dt``, or the file's ``timestep``).
    """
    try:
        dt = float(dt_s)
    except (TypeError, ValueError):
        raise UsageError(f"{what} must be a number between {MIN_DT_S:g} and {MAX_DT_S:g} [s], got {dt_s!r}") from None
    if not (math.isfinite(dt) and MIN_DT_S <= dt <= MAX_DT_S):
        raise UsageError(f"{what} must be a number between {MIN_DT_S:g} and {MAX_DT_S:g} [s], got {dt:g}"
                         + unit_hint(dt, MAX_DT_S, what, "s", "ms", 1000))
    return dt


def check_positive(value, what):
    """Return ``value`` as a finite float > 0; UsageError naming ``what`` otherwise."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise UsageError(f"{what} must be a number > 0, got {value!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise UsageError(f"{what} must be a number > 0, got {v:g}")
    return v


def check_max_penetration(max_penetration_m, radius_m, what="--max-penetration"):
    """``--max-penetration`` [m] as a float in (0, radius): a UsageError (one line) for a limit at or
    above the ball's radius ``radius_m`` [m], where the ball's centre would reach the floor's surface
    (the engine's contact would still hold it, and the drop test pass, while no real ball deforms that
    far). None stays None (the default: a quarter of the radius). ``what`` names the value in the error
    (an exported file's own limit: give --max-penetration instead)."""
    if max_penetration_m is None:
        return None
    limit = check_positive(max_penetration_m, what)
    if limit >= radius_m:
        instead = "" if what == "--max-penetration" else "--max-penetration "
        raise UsageError(f"{what} {limit * 1e3:.4g} mm is not below the ball's radius {radius_m * 1e3:.4g} mm "
                         f"(its centre would reach the floor): give {instead}less than the radius (default a quarter "
                         f"of it, {MAX_PENETRATION_RADII * radius_m * 1e3:.3g} mm), or a smaller --dt, which lets the "
                         "ball sink less")
    return limit


def check_counts(n_bounces, n_phases):
    """Return (n_bounces, n_phases) as ints in [1, MAX_BOUNCES] and [1, 64]; UsageError otherwise."""
    for label, value, hi in (("--bounces", n_bounces, MAX_BOUNCES), ("--phases", n_phases, 64)):
        if isinstance(value, bool) or int(value) != value or not 1 <= int(value) <= hi:
            raise UsageError(f"{label} must be an integer from 1 to {hi}, got {value}")
    return int(n_bounces), int(n_phases)


def check_steps(setup, n_phases, engine, max_steps, what="the drop test"):
    """Refuse up front a run longer than ``max_steps`` engine steps, naming the limit.

    Parameters
    ----------
    setup : DropSetup
    n_phases : int
        drops in the run
    engine : str
        for the message
    max_steps : int
        the engine's limit (:data:`vrcal.engines.Engine.max_steps`)

    Returns
    -------
    int
        steps the run will take
    """
    duration = setup.flight_time_s(setup.drop_height_m + setup.impact_speed_m_per_s * setup.dt_s) * 1.05
    steps = int(math.ceil(duration / setup.dt_s)) * int(n_phases)
    if steps > max_steps:
        dt_ok = duration * n_phases / max_steps
        raise UsageError(
            f"{what} needs {steps:.3g} {engine} steps at --dt {setup.dt_s:g} s ({n_phases} drop(s) of "
            f"{duration:.3g} s, {setup.n_bounces} bounce(s)); the limit is {max_steps:,} steps: use --dt "
            f"{_round_up(dt_ok)} or larger, or fewer --bounces/--phases"
        )
    return steps


def confirmed(first, passed, setup, n_phases, engine, max_steps, rerun):
    """The confirmation of a drop test that passed: run again over :data:`CONFIRM_PHASES` contact
    phases, and those runs decide (4 phases sample the contact's place in its step too coarsely to
    bound a slow last bounce: measured in ODE, PyBullet and MuJoCo, see :data:`CONFIRM_PHASES`).

    Parameters
    ----------
    first : object
        the result at ``n_phases`` (a DropRuns, a MuJoCo calibration, or why there is none)
    passed : bool
        whether ``first`` meets both limits (only a pass is confirmed)
    setup : DropSetup
        the drop test at the step it ran at (for the run limit)
    n_phases : int
        contact phases ``first`` ran over (none more: no confirmation)
    engine : str
        the engine, for :func:`check_steps`
    max_steps : int
        its run limit: when :data:`CONFIRM_PHASES` phases would pass it, ``first`` stands (its phase
        count is what a note or a refusal names)
    rerun : callable
        ``rerun(n_phases)``: the result over that many phases

    Returns
    -------
    object
        ``rerun(CONFIRM_PHASES)``, or ``first`` where no confirmation runs
    """
    if not passed or n_phases >= CONFIRM_PHASES:
        return first
    try:
        check_steps(setup, CONFIRM_PHASES, engine, max_steps)
    except UsageError:
        return first
    return rerun(CONFIRM_PHASES)


def error_text(error):
    """An epsilon error as text: four decimals from 0.001 on (0.0234), else two significant digits (3.4e-06,
    not 0.0000)."""
    from vrcal.textout import number

    return f"{error:.4f}" if abs(error) >= 1e-3 else number(error, 2)


def _round_up(x):
    """``x`` rounded up to two significant digits, as text."""
    mag = 10.0 ** (math.floor(math.log10(x)) - 1)
    return f"{math.ceil(x / mag - 1e-9) * mag:.2g}"


def export_for_speeds(fastest_m_per_s, slowest_m_per_s, drop_height_m=None):
    """What to do about impacts slower than an export holds for (a verify failure, an export's
    terminal): an export for these speeds [m/s] (``drop_height_m`` [m]: the drop that gives them),
    or a smaller step."""
    height = f"--drop-height {drop_height_m:.4g} or " if drop_height_m else ""
    return (f"export again for these speeds ({height}--impact-speed {round_down(slowest_m_per_s):g}:"
            f"{_round_up(fastest_m_per_s)}), or at a smaller --dt")


def round_down(x):
    """``x`` rounded down to two significant digits (a time step to name in a message)."""
    mag = 10.0 ** (math.floor(math.log10(x)) - 1)
    return float(f"{math.floor(x / mag + 1e-9) * mag:.2g}")


def step_resolution_s(dt_s):
    """The resolution [s] a search for the largest passing step refines to near ``dt_s`` [s]: the power
    of ten at most 5 % of it (0.0001 s near 2.5 ms, 1e-05 s near 1.9 ms)."""
    return 10.0 ** math.floor(math.log10(0.05 * dt_s) + 1e-9)


def refine_step(run, dt_pass_s, passed, dt_miss_s):
    """The largest step between ``dt_pass_s`` (which passed, with result ``passed``) and the larger
    ``dt_miss_s`` (which missed), found by bisection (:func:`bisect_boundary`) to :func:`step_resolution_s`:
    each step tried is run by ``run(dt) -> (ok, result)``, the same check an export runs at its own step.

    A coarse search (a grid of steps each 0.8 or 0.9 times the last) names a step up to 25 % below one
    that passes (a probe's ball in MuJoCo: 0.0025 s named where 0.003 s exports); the bisection
    narrows the gap to the resolution. The error need not be monotonic in the step (ODE, PyBullet),
    so what it returns is a step that was run and passed, with a step at most one resolution above it
    that was run and missed -- not a proof that no larger step passes.

    Returns
    -------
    (float, object, float)
        the step that passed [s], its result, and the smallest step above it that missed [s]
    """
    return bisect_boundary(run, dt_pass_s, passed, dt_miss_s, step_resolution_s(dt_pass_s))


def bisect_boundary(run, passing, passed, failing, unit=1.0):
    """Bisection between ``passing`` (a value run that passed, with result ``passed``) and ``failing`` (one
    run that missed), on either side of it, until they are at most ``unit`` apart: each value tried is a whole
    multiple of ``unit`` strictly between them, run by ``run(value) -> (ok, result)``. Serves the largest
    passing step (:func:`refine_step`) and the fewest passing PyBullet substeps (``unit`` 1).

    Returns
    -------
    (float, object, float)
        the passing value next to the boundary, its result, and the failing value next to it
    """
    while abs(failing - passing) > unit * (1 + 1e-6):
        lo, hi = sorted((passing, failing))
        k = max(math.floor((lo + hi) / 2.0 / unit + 1e-9), math.floor(lo / unit + 1e-9) + 1)
        mid = float(f"{k * unit:.12g}")
        if not lo < mid < hi:
            break
        ok, result = run(mid)
        if ok:
            passing, passed = mid, result
        else:
            failing = mid
    return passing, passed, failing


def phase_shifts_m(setup, n_phases):
    """Release-height shifts [m] that move the first impact across one time step.

    The ball falls ``v dt`` in the step around the impact; shifting H by ``k/n`` of that
    moves the impact by ``k/n`` of a step.
    """
    n = max(int(n_phases), 1)
    return setup.impact_speed_m_per_s * setup.dt_s * np.arange(n) / n


def flight_mask(v_m_per_s, dt_s, g_m_per_s2, rtol=1e-6, atol=1e-12):
    """True for each step ``i -> i+1`` that is free flight: ``v[i+1] - v[i] == -g dt``.

    ``atol`` [m/s] admits a small force in flight (air drag: ``k v^2 dt``).
    """
    dv = np.diff(np.asarray(v_m_per_s, dtype=float))
    return np.abs(dv + g_m_per_s2 * dt_s) <= rtol * max(g_m_per_s2 * dt_s, 1e-300) + atol


def floor_speed_m_per_s(z_m, v_m_per_s, g_m_per_s2, dt_s, semi_implicit):
    """Speed at floor level of the free flight through the sample (z, v) [m/s].

    The flight is the parabola on which the sampled positions lie, and its speed where it
    crosses z = 0 (the speed of which epsilon is the ratio, Eq. 1 of [1]).

    Parameters
    ----------
    z_m, v_m_per_s : float
        bottom height [m] and vertical velocity (up positive) [m/s] of one sample
    g_m_per_s2, dt_s : float
        gravity [m/s^2] and time step [s]
    semi_implicit : bool
        the flight is semi-implicit Euler (velocity first, then position: ``z[n] - z[n-1] =
        v[n] dt``). Its stored velocity is then the mean over the step just taken, the parabola's
        velocity half a step earlier; the parabola's own velocity at the sample is ``v - g dt/2``
        and ``(v - g dt/2)^2 + 2 g z = v^2 + 2 g z - g v dt + g^2 dt^2/4`` is its conserved energy.
        False: an exact flight (MuJoCo's RK4), whose samples hold the parabola's own velocity:
        ``v^2 + 2 g z``.

    Returns
    -------
    float
        ``sqrt(v^2 + 2 g z - g v dt + (g dt/2)^2)`` (semi-implicit), ``sqrt(v^2 + 2 g z)``
        (exact): the same both ways, so a flight that rises as high as it fell has the ratio 1

    Notes
    -----
    Not an equation of [1]. Earlier vrcal returned the *stored* velocity a sample at z = 0
    would hold, ``(root +- g dt)/2`` with ``root`` twice the value above: half a step off, so
    ``v_out / v_in`` read high by about ``(1 + epsilon) g dt / (2 v)`` (ODE at epsilon 1: 1.020
    at dt = 5 ms, v = 2.4 m/s, while its apex ratio and its contact step were exactly 1).
    """
    e = v_m_per_s * v_m_per_s + 2.0 * g_m_per_s2 * z_m
    if semi_implicit:
        gdt = g_m_per_s2 * dt_s
        e += 0.25 * gdt * gdt - gdt * v_m_per_s
    return math.sqrt(max(e, 0.0))


class StillBouncing(DataError):
    """A run ended with the ball still bouncing: it bounced higher than the target it was sized for.

    ``ratio`` is the largest apex or velocity ratio seen (a lower bound of the ball's own).
    """

    def __init__(self, message, ratio):
        super().__init__(message)
        self.ratio = float(ratio)


@dataclass
class Bounces:
    """What one engine run shows of the first ``n_bounces`` bounces.

    Attributes
    ----------
    apex_m : ndarray (n_bounces + 1,)
        apex heights of the ball's bottom [m]; [0] is the release height
    apex_ratios, velocity_ratios : ndarray (n_bounces,)
    impact_speeds_m_per_s : ndarray (n_bounces,)
        speed at floor level before each contact [m/s]
    impact_steps : ndarray of int (n_bounces,)
        sample index of the first step of each contact
    turn_m : ndarray (n_bounces,)
        lowest bottom height in each contact [m]: < 0 is penetration, > 0 hover
    """

    apex_m: np.ndarray
    apex_ratios: np.ndarray
    velocity_ratios: np.ndarray
    impact_speeds_m_per_s: np.ndarray
    impact_steps: np.ndarray
    turn_m: np.ndarray


def measure_bounces(z_m, v_m_per_s, drop_height_m, dt_s, g_m_per_s2, n_bounces, semi_implicit=True,
                    flight_atol=1e-12):
    """Apex and velocity ratios, impact speeds and contact depths of a sampled drop.

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
    semi_implicit : bool
        see :func:`floor_speed_m_per_s`
    flight_atol : float
        velocity change per step [m/s] still taken as free flight (air drag)

    Returns
    -------
    Bounces

    Raises
    ------
    DataError
        when the trajectory holds fewer bounces than asked (the ball stuck to the floor,
        or passed through it).
    """
    z = np.asarray(z_m, dtype=float)
    v = np.asarray(v_m_per_s, dtype=float)
    if not (np.all(np.isfinite(z)) and np.all(np.isfinite(v))):      # no ratio (and no worst error) is NaN
        raise DataError("the ball's position or velocity became infinite or NaN in the run: the engine is "
                        "unstable at this step")
    free = flight_mask(v, dt_s, g_m_per_s2, atol=flight_atol)
    steps = np.flatnonzero(~free)
    if steps.size == 0:
        raise DataError("the ball never touched the floor in the simulated time")
    breaks = np.flatnonzero(np.diff(steps) > 1)
    starts = np.r_[steps[0], steps[breaks + 1]]
    ends = np.r_[steps[breaks], steps[-1]]
    apex, ratios, vel, speeds, first, turn = [float(drop_height_m)], [], [], [], [], []
    inside = ""
    for k in range(min(len(starts), n_bounces)):
        i_in, i_out = starts[k], ends[k] + 1          # last free sample before, first after
        if i_out >= len(v) or v[i_out] <= 0:
            break
        v_in = floor_speed_m_per_s(z[i_in], v[i_in], g_m_per_s2, dt_s, semi_implicit)
        v_out = floor_speed_m_per_s(z[i_out], v[i_out], g_m_per_s2, dt_s, semi_implicit)
        nxt = starts[k + 1] if k + 1 < len(starts) else len(z) - 1
        if nxt <= i_out + 1 or np.all(v[i_out:nxt + 1] > 0):
            break                                      # flight not finished: no apex
        h = float(np.max(z[i_out:nxt + 1]))
        if h <= 0 or v_in <= 0:                        # turned back inside the floor: no rebound
            inside = f" (it turned back {-h * 1e3:.3g} mm inside the floor)" if h <= 0 else ""
            break
        ratios.append(math.sqrt(h / apex[-1]))
        vel.append(v_out / v_in)
        speeds.append(v_in)
        first.append(int(i_in))
        turn.append(float(np.min(z[i_in:i_out + 1])))
        apex.append(h)
    if len(ratios) < n_bounces:
        last_out = ends[-1] + 1
        if last_out < len(v) - 1 and np.any(v[last_out:] > 0) and np.max(z[last_out:]) >= RISE_M:
            # the run ended with the ball in flight, risen from the floor: it was still bouncing
            seen = [*ratios, *vel]
            if len(ratios) < len(starts):              # the last contact's flight is unfinished: its rise so far
                seen.append(math.sqrt(max(float(np.max(z[last_out:])), 0.0) / apex[-1]))
            raise StillBouncing(
                f"the ball made only {len(ratios)} complete bounce(s) of the {n_bounces} asked for before "
                f"the simulated time ended: it bounced higher than the target (ratio up to {max(seen):.4g})",
                max(seen))
        raise DataError(
            f"the ball made only {len(ratios)} complete bounce(s) of the {n_bounces} asked for: "
            + (f"it does not rebound at this step{inside}" if inside else
               "it stuck to the floor or the contact settings do not bounce")
        )
    return Bounces(np.array(apex), np.array(ratios), np.array(vel), np.array(speeds), np.array(first),
                   np.array(turn))


def measure_ratios(z_m, v_m_per_s, drop_height_m, dt_s, g_m_per_s2, n_bounces, semi_implicit=True):
    """Apex and velocity ratios of the first ``n_bounces`` bounces (see :func:`measure_bounces`)."""
    b = measure_bounces(z_m, v_m_per_s, drop_height_m, dt_s, g_m_per_s2, n_bounces, semi_implicit)
    return b.apex_ratios, b.velocity_ratios


def flight_time_s(drop_height_m, epsilon, n_bounces, g_m_per_s2):
    """Time to the apex after bounce ``n_bounces`` for a ball dropped from rest, no drag [s]."""
    t_fall = math.sqrt(2.0 * drop_height_m / g_m_per_s2)
    return t_fall * (1.0 + 2.0 * sum(epsilon ** k for k in range(1, n_bounces)) + epsilon ** n_bounces)


def epsilon_spread(setup):
    """(lowest, highest) epsilon of the target over the setup's impacts, and the least worst error
    any constant epsilon can have against it: half their difference (0 for a constant target)."""
    eps = setup.epsilons
    lo, hi = float(np.min(eps)), float(np.max(eps))
    return lo, hi, 0.5 * (hi - lo)


def constant_epsilon(setup):
    """The one epsilon of an engine that takes a constant per material (Gazebo, PhysX, Unity, Box2D)
    for the setup's ball/floor pair: the target, or for a speed-dependent epsilon the centre of its
    spread over the setup's impacts (no constant is nearer all of them, :func:`epsilon_spread`)."""
    if not setup.restitution_exponent:
        return float(setup.epsilon)
    lo, hi, _ = epsilon_spread(setup)
    return 0.5 * (lo + hi)


def constant_engine_notes(setup, engines, option=lambda name: f"--{name}"):
    """What an engine with one epsilon per material and no air drag leaves out of a discover result:
    one line per effect the setup carries (none without effects), each saying what to do.

    ``option(name)`` writes an option's name (an XML comment may not hold two dashes).
    """
    lines = []
    if setup.restitution_exponent:
        lo, hi, least = epsilon_spread(setup)
        v = setup.impact_speeds_m_per_s
        lines.append(f"epsilon(v) spans {lo:.4f}..{hi:.4f} over the {setup.n_bounces} bounce(s) at "
                     f"{float(np.max(v)):.3g}..{float(np.min(v)):.3g} m/s; {engines} take one restitution per "
                     f"material: the value given is its centre, {constant_epsilon(setup):.4f}, off by up to "
                     f"{least:.4f} at either end (choose the speeds with {option('impact-speed')} LO:HI)")
    if setup.drag_coefficient:
        what = (f"{engines} apply no air drag (the record's C_d {setup.drag_coefficient:.3g}): add the force "
                f"F = -c|v|v, c = {drag_force_coefficient_kg_per_m(setup):.3g} kg/m, to the ball every step")
        if setup.baseline_epsilon is not None:
            what += (f", or export the constant that reproduces the record's bounce heights without drag "
                     f"({option('epsilon')} {setup.baseline_epsilon:.4f})")
        lines.append(what)
    return lines


def drop_window_s(setup, drop_height_m, ratio=None, at_least=None):
    """Simulated time of one drop of a drop test [s], 5 % beyond the apex after the last bounce.

    Sized for vrcal's model of the target; with ``ratio`` (what a run that ended too early saw,
    :class:`StillBouncing`) for a ball that bounces that high (at least epsilon 1, no drag: an
    upper bound for a ball that does not gain energy); with ``at_least`` also long enough for a
    constant epsilon ``at_least`` without drag (a constant tried against a speed-dependent target).
    """
    t = setup.flight_time_s(drop_height_m)
    if at_least is not None:
        t = max(t, flight_time_s(drop_height_m, min(float(at_least), 1.0), setup.n_bounces, setup.g_m_per_s2))
    if ratio is not None:
        r = min(max(float(ratio), 1.0), 10.0)      # a ball gaining energy: sized for what it showed
        t = max(t, flight_time_s(drop_height_m, r, setup.n_bounces, setup.g_m_per_s2))
    return 1.05 * t


def sized_run(run, setup, n_phases, max_steps=None):
    """``run(ratio)`` (a :class:`DropRuns`) sized for the target, once more for what the ball did.

    A ball that bounces higher than the target (a file with another epsilon, a step that adds
    energy) is still in the air when a run sized for the target ends: ``run`` is called again
    with the window of :func:`drop_window_s` for that ball, unless that run would be longer than
    ``max_steps`` steps (then the :class:`StillBouncing` error, which says so, stands).
    """
    try:
        return run(None)
    except StillBouncing as exc:
        longest = drop_window_s(setup, setup.drop_height_m + setup.impact_speed_m_per_s * setup.dt_s, exc.ratio)
        if max_steps and longest / setup.dt_s * n_phases > max_steps:
            raise
        return run(exc.ratio)


@dataclass
class DropRuns:
    """An engine's drop test: one run per contact phase, each measured by :func:`measure_bounces`.

    Arrays have shape (n_phases, n_bounces) unless said otherwise.

    Attributes
    ----------
    shifts_m : ndarray (n_phases,)
        release-height shift of each run [m]
    apex_ratios, velocity_ratios : ndarray
        what the engine did
    target_apex_ratios, target_epsilons : ndarray
        what vrcal's model of the same drops does (apex ratios; epsilon at each impact speed)
    apex_m : ndarray (n_phases, n_bounces + 1)
        the engine's apex heights [m]
    target_apex_m : ndarray (n_phases, n_bounces + 1)
        the model's apex heights [m]
    turn_m : ndarray
        lowest bottom height in each contact [m]
    phase_fractions : ndarray (n_phases,)
        where in its time step the first impact of each run falls (0 ... 1)
    """

    shifts_m: np.ndarray
    apex_ratios: np.ndarray
    velocity_ratios: np.ndarray
    target_apex_ratios: np.ndarray
    target_epsilons: np.ndarray
    apex_m: np.ndarray
    target_apex_m: np.ndarray
    turn_m: np.ndarray
    phase_fractions: np.ndarray = None

    @property
    def errors(self):
        """All |achieved - target| values: apex and velocity ratios, (2, n_phases, n_bounces)."""
        return np.stack([self.apex_ratios - self.target_apex_ratios, self.velocity_ratios - self.target_epsilons])

    @property
    def worst_error(self):
        """Largest |achieved - target| over bounces, phases, apex and velocity ratios."""
        return float(np.max(np.abs(self.errors)))

    @property
    def bounce_errors(self):
        """Largest |achieved - target| of each bounce over phases, apex and velocity ratios, (n_bounces,)."""
        return np.max(np.abs(self.errors), axis=(0, 1))

    @property
    def median_error(self):
        """Median |achieved - target| over the same."""
        return float(np.median(np.abs(self.errors)))

    @property
    def midrange_error(self):
        """(max + min) / 2 of the signed errors: 0 when the errors are centred on the target."""
        e = self.errors
        return float(0.5 * (np.max(e) + np.min(e)))

    @property
    def penetration_m(self):
        """Deepest the bottom went below the floor in a contact [m] (0 when never)."""
        return float(max(-np.min(self.turn_m), 0.0))

    @property
    def hover_m(self):
        """Highest a contact turned the ball above the floor [m] (0 when never)."""
        return float(max(np.max(self.turn_m), 0.0))

    @property
    def gain(self):
        """The largest ``v_out / v_in`` when it is above 1 (the engine added energy in a contact), else None.

        No floor returns more speed than it receives (epsilon <= 1, Eq. 1 of [1]): an achieved
        ratio above 1 fails a drop test whatever its tolerance (a PyBullet superball of epsilon
        0.9995 at 1 ms read 1.0017, within a tolerance of 0.01 of the target, and climbed from
        1.000 to 1.112 m over 32 bounces). ``v_out / v_in`` is exact for a free flight
        (:func:`floor_speed_m_per_s`: 1 exactly for ODE's bounce 1), so only its rounding
        (:data:`GAIN_RTOL`) is allowed above 1.
        """
        top = float(np.max(self.velocity_ratios))
        return top if top > 1.0 + GAIN_RTOL else None

    def gain_text(self):
        """The clause a failure says of a :attr:`gain` ('' without one)."""
        if self.gain is None:
            return ""
        k = int(np.argmax(np.max(self.velocity_ratios, axis=0)))
        return (f"the engine adds energy: v_out/v_in reaches {self.gain:.5g} > 1 (bounce {k + 1}), the ball "
                "climbs higher every bounce")

    def height_ratio_text(self, beyond=HEIGHT_RATIO_SHOWN):
        """'rebound heights LO..HI x the target's' when a bounce's rebound height, relative to the height it
        fell from (the apex ratio squared), is off the target's by more than ``beyond`` (a fraction), else
        ''. An absolute epsilon error is small beside a small epsilon: 0.026 at clay's 0.1 lets a 10 mm
        rebound from 1 m be 7..15 mm; 0.0059 at a tennis ball's 0.5 moves it by 2.4 %."""
        ratio = (self.apex_ratios / self.target_apex_ratios) ** 2
        lo, hi = float(np.min(ratio)), float(np.max(ratio))
        if max(hi - 1.0, 1.0 - lo) <= beyond:
            return ""
        return f"rebound heights {lo:.2f}..{hi:.2f} x the target's"

    @property
    def apex_relative_errors(self):
        """(engine apex / model apex - 1) of each rebound, (n_phases, n_bounces)."""
        return self.apex_m[:, 1:] / self.target_apex_m[:, 1:] - 1.0

    def worst_apex(self, floor_m=0.0, goal=None):
        """(rebound number, relative error, share of its allowance) of the rebound apex farthest from the
        model's, over the phases, judged against ``max(goal x its rise, floor_m)`` (``goal`` a fraction, None:
        :data:`vrcal.model.restitution.APEX_GOAL`; the share: 1 at the allowance): each bounce's epsilon error
        compounds in the heights (PyBullet's +0.002..+0.005 per bounce put a record's 5th rebound 3 % high
        where every bounce was within 0.01)."""
        from vrcal.model.restitution import APEX_GOAL

        target = self.target_apex_m[:, 1:]
        allowed = np.maximum((APEX_GOAL if goal is None else goal) * target, floor_m)
        share = np.abs(self.apex_m[:, 1:] - target) / allowed
        i, k = np.unravel_index(int(np.argmax(share)), share.shape)
        return int(k) + 1, float(self.apex_relative_errors[i, k]), float(share[i, k])

    def apex_miss(self, goal, floor_m=0.0):
        """Whether a rebound apex is off the model's by more than ``goal`` of its rise (a fraction; None: not
        judged) and more than ``floor_m`` [m] (a record's noise): :meth:`worst_apex` beyond its allowance."""
        return goal is not None and self.worst_apex(floor_m, goal)[2] > 1.0

    def apex_text(self, goal=None, floor_m=0.0):
        """'rebound apexes -0.1..+3.0 % of vrcal's model's (worst: rebound 5)', and the goal when one is given."""
        err = 100.0 * self.apex_relative_errors
        k = self.worst_apex(floor_m, goal)[0]
        text = (f"rebound apexes {float(np.min(err)):+.1f}..{float(np.max(err)):+.1f} % of vrcal's model's "
                f"(worst: rebound {k})")
        if goal is None:
            return text
        return text + f", goal within {100 * goal:g} %" + (f" or {floor_m * 1e3:.3g} mm" if floor_m else "")


def drop_runs(setup, shifts_m, trajectories, dt_s, g_m_per_s2, n_bounces, semi_implicit, flight_atol=1e-12):
    """Measure the runs of a drop test against vrcal's model: a :class:`DropRuns`.

    ``trajectories`` is a sequence of (z_m, v_m_per_s) arrays, one per shift.
    """
    bounces, missed = [], []
    for s, (z, v) in zip(shifts_m, trajectories):
        try:
            bounces.append(measure_bounces(z, v, setup.drop_height_m + s, dt_s, g_m_per_s2, n_bounces, semi_implicit,
                                           flight_atol))
        except StillBouncing:
            raise
        except DataError as exc:
            missed.append(str(exc))
    if missed:      # one message for the phases that did not bounce as asked, saying how many they are
        some = "every contact phase" if len(missed) == len(shifts_m) else \
            f"{len(missed)} of {len(shifts_m)} contact phases"
        raise DataError(f"{missed[0]} (in {some})")
    model = setup.model_at(setup.drop_height_m + np.asarray(shifts_m))
    apex = model.apex_heights_m[:, :n_bounces + 1]
    return DropRuns(
        shifts_m=np.asarray(shifts_m, dtype=float),
        apex_ratios=np.array([b.apex_ratios for b in bounces]),
        velocity_ratios=np.array([b.velocity_ratios for b in bounces]),
        target_apex_ratios=np.sqrt(apex[:, 1:] / apex[:, :-1]),
        target_epsilons=np.asarray(model.epsilons[:, :n_bounces]),
        apex_m=np.array([b.apex_m for b in bounces]),
        target_apex_m=apex,
        turn_m=np.array([b.turn_m for b in bounces]),
        phase_fractions=np.asarray(shifts_m, dtype=float) / (setup.impact_speed_m_per_s * setup.dt_s),
    )


def drag_atol(setup):
    """Velocity change per step [m/s] that air drag alone can make (flights stay 'free flight')."""
    if not setup.drag_coefficient:
        return 1e-12
    v = setup.impact_speed_m_per_s
    return 2.0 * setup.drag_k_per_m * v * v * setup.dt_s + 1e-12


def stepped_drop_test(run_drop, params, setup, n_bounces, n_phases, max_steps=None):
    """The drop test of a time-stepping engine, once per contact phase: a :class:`DropRuns`.

    ``run_drop(params, drop_height_m, duration_s)`` runs one drop and returns the sampled
    bottom height z [m] and vertical velocity v [m/s] of every step, the step dt [s] and g
    [m/s^2]. The runs are sized for the target, and once more for a ball that bounced
    higher (:func:`sized_run`, at most ``max_steps`` steps).
    """
    shifts = phase_shifts_m(setup, n_phases)

    def run(ratio):
        runs, dt, g = [], setup.dt_s, setup.g_m_per_s2
        for shift in shifts:
            H = setup.drop_height_m + shift
            z, v, dt, g = run_drop(params, H, drop_window_s(setup, H, ratio))
            runs.append((z, v))
        return drop_runs(setup, shifts, runs, dt, g, n_bounces, True, drag_atol(setup))

    return sized_run(run, setup, n_phases, max_steps)


#: Steps of free flight the two balls of the pair test close in before the (first phase's) contact.
PAIR_APPROACH_STEPS = 3

#: Steps the pair test runs past the contact (the balls fly apart, gravity off).
PAIR_AFTER_STEPS = 4


@dataclass(frozen=True)
class PairSetup:
    """The two-ball collision test of an ``--against`` export's pair ball/ball2, SI units.

    The balls fly head-on along x with gravity off (far from the floor): ball at x = 0, ball2 at
    ``R + R2 + gap``, their velocities in the frame of their centre of mass, so that they close at
    ``speed_m_per_s``. The achieved epsilon is the relative normal speed after the contact over
    the one before.

    Attributes
    ----------
    name : str
        the pair, 'BALL/BALL2'
    target : float
        the file's pair epsilon (Eq. 6 of [1]: the product of the two balls' own)
    mass_kg, radius_m, mass2_kg, radius2_m : float
        the two balls' masses [kg] and radii [m]
    speed_m_per_s : float
        relative speed at which they meet [m/s]: the ball's first impact speed of the drop test
    dt_s : float
        the engine's time step [s]
    tolerance : float
        largest accepted |achieved - target|
    max_penetration_m : float
        the floor contact's limit [m], shown beside the pair's overlap (not judged: the pair's
        contact detection is the engine's, e.g. MuJoCo's margin of the ball's speed)
    margin_m : float
        distance [m] at which the engine's contact acts before touch (MuJoCo's pair margin; 0 else)
    contact_steps : int
        steps a contact may last (1 for the one-step contacts; a spring's half period)
    """

    name: str
    target: float
    mass_kg: float
    radius_m: float
    mass2_kg: float
    radius2_m: float
    speed_m_per_s: float
    dt_s: float
    tolerance: float = DEFAULT_TOLERANCE
    max_penetration_m: float = math.inf
    margin_m: float = 0.0
    contact_steps: int = 1

    @property
    def velocities_m_per_s(self):
        """(ball's, ball2's) x velocity [m/s] before the contact: centre-of-mass frame, closing at the speed."""
        m1, m2, v = self.mass_kg, self.mass2_kg, self.speed_m_per_s
        return v * m2 / (m1 + m2), -v * m1 / (m1 + m2)

    @property
    def contact_distance_m(self):
        """Distance of the centres [m] at touch: R + R2."""
        return self.radius_m + self.radius2_m


def pair_setup(setup, name2, mass2_kg, radius2_m, target):
    """The :class:`PairSetup` of an ``--against`` file: the ball of ``setup`` (a :class:`DropSetup`)
    against the second ball (``name2``, ``mass2_kg`` [kg], ``radius2_m`` [m]), meeting at the ball's
    first impact speed of the drop test, at its step and tolerance; ``target`` is the pair's Eq. 6 epsilon."""
    return PairSetup(name=f"{setup.ball}/{name2}", target=check_epsilon(target, "the pair's epsilon"),
                     mass_kg=float(setup.mass_kg), radius_m=float(setup.radius_m), mass2_kg=float(mass2_kg),
                     radius2_m=float(radius2_m), speed_m_per_s=setup.impact_speed_m_per_s, dt_s=setup.dt_s,
                     tolerance=setup.tolerance, max_penetration_m=setup.penetration_limit_m)


def pair_gaps_m(pair, n_phases):
    """Gaps [m] between the two balls' surfaces at the start of each phase of the pair test.

    Like :func:`phase_shifts_m` for the drop: the balls close ``speed dt`` per step, so adding
    ``k/n`` of that to the gap moves the contact by ``k/n`` of a step; each run starts
    :data:`PAIR_APPROACH_STEPS` steps of flight outside the engine's margin.
    """
    n = max(int(n_phases), 1)
    step = pair.speed_m_per_s * pair.dt_s
    return pair.margin_m + step * (PAIR_APPROACH_STEPS + np.arange(n) / n)


def pair_steps(pair, gap_m):
    """Steps [-] a run of the pair test lasts from ``gap_m``: the approach, the contact, the parting."""
    step = pair.speed_m_per_s * pair.dt_s
    # the parting: out of an overlap up to a step's closing and the margin, at epsilon times the speed
    parting = (step + 2.0 * pair.margin_m) / (max(pair.target, 0.05) * step)
    return int(math.ceil(gap_m / step)) + int(pair.contact_steps) + int(math.ceil(parting)) + PAIR_AFTER_STEPS


@dataclass
class PairRuns:
    """The pair test's runs, one per contact phase (arrays of shape (n_phases,)).

    Attributes
    ----------
    gaps_m : ndarray
        the starting gap of each run [m] (:func:`pair_gaps_m`)
    epsilons : ndarray
        achieved epsilon: relative normal speed after / before the contact
    overlaps_m : ndarray
        largest overlap of the two spheres in each run [m] (0 when they never touched)
    parted : ndarray of bool
        the balls were apart and flying apart when the run ended
    phase_fractions : ndarray
        where in its time step the contact of each run falls (0 ... 1)
    """

    gaps_m: np.ndarray
    epsilons: np.ndarray
    overlaps_m: np.ndarray
    parted: np.ndarray
    phase_fractions: np.ndarray


def pair_run(pair, x1_m, x2_m, v1_m_per_s, v2_m_per_s):
    """(achieved epsilon, largest overlap [m], parted) of one run of the pair test.

    ``x1_m, x2_m, v1_m_per_s, v2_m_per_s`` are the two centres' x [m] and x velocities [m/s] at every
    step, sample 0 = start. The speeds are the relative ones before (sample 0) and at the end.
    """
    x1, x2 = np.asarray(x1_m, dtype=float), np.asarray(x2_m, dtype=float)
    rel = np.asarray(v2_m_per_s, dtype=float) - np.asarray(v1_m_per_s, dtype=float)   # > 0: apart
    distance = x2 - x1
    overlap = float(max(np.max(pair.contact_distance_m - distance), 0.0))
    parted = bool(distance[-1] > pair.contact_distance_m + pair.margin_m and rel[-1] > 0)
    return float(-rel[-1] / rel[0]), overlap, parted


def stepped_pair_test(run_pair, params, pair, n_phases):
    """The pair test of an engine, once per contact phase: a :class:`PairRuns`.

    ``run_pair(params, pair, gap_m, n_steps)`` runs the two balls from ``gap_m`` apart for
    ``n_steps`` steps and returns the arrays of :func:`pair_run`.
    """
    gaps = pair_gaps_m(pair, n_phases)
    runs = [pair_run(pair, *run_pair(params, pair, float(gap), pair_steps(pair, gap))) for gap in gaps]
    eps, overlap, parted = (np.array(x) for x in zip(*runs))
    return PairRuns(gaps_m=gaps, epsilons=eps, overlaps_m=overlap, parted=parted,
                    phase_fractions=np.arange(len(gaps)) / len(gaps))


@dataclass
class PairResult:
    """The two-ball collision test of a file's pair in a real engine, judged against Eq. 6."""

    engine: str
    pair: PairSetup
    runs: PairRuns
    notes: tuple = ()

    @property
    def target(self):
        return self.pair.target

    @property
    def tolerance(self):
        return self.pair.tolerance

    @property
    def error(self):
        """Largest |achieved - target| over the phases."""
        return float(np.max(np.abs(self.runs.epsilons - self.pair.target)))

    @property
    def overlap_m(self):
        """Largest overlap of the two balls over the phases [m]."""
        return float(np.max(self.runs.overlaps_m))

    @property
    def passed(self):
        return self.error <= self.pair.tolerance and bool(np.all(self.runs.parted))

    def failure(self):
        """Why the pair missed, in one line ('' when it passed)."""
        if self.passed:
            return ""
        p, eps = self.pair, self.runs.epsilons
        if not np.all(self.runs.parted):
            return (f"the pair {p.name}: the two balls had not parted {p.contact_steps + PAIR_AFTER_STEPS} steps "
                    "after the contact the file's engine settings make (a contact this long is not the file's)")
        return (f"the pair {p.name} reaches epsilon {np.min(eps):.4f}..{np.max(eps):.4f} in {self.engine}, Eq. 6 "
                f"gives {p.target:.4f}: off by {self.error:.4f} > tolerance {p.tolerance:g}")

    def as_dict(self):
        p, r = self.pair, self.runs
        return {"name": p.name, "target_epsilon": p.target, "tolerance": p.tolerance,
                "speed_m_per_s": p.speed_m_per_s, "dt_s": p.dt_s,
                "mass_kg": [p.mass_kg, p.mass2_kg], "radius_m": [p.radius_m, p.radius2_m],
                "gaps_m": [float(x) for x in r.gaps_m], "epsilons": [float(x) for x in r.epsilons],
                "overlaps_m": [float(x) for x in r.overlaps_m], "error": self.error,
                "overlap_m": self.overlap_m, "max_penetration_m": p.max_penetration_m,
                "passed": self.passed, "notes": list(self.notes)}


class RunsSummary:
    """What a result with a :class:`DropRuns` ``runs`` reports of it (verify and MuJoCo's calibration)."""

    @property
    def worst_error(self):
        """Largest |achieved - target| over bounces, phases, apex and velocity ratios."""
        return self.runs.worst_error

    @property
    def median_error(self):
        return self.runs.median_error

    @property
    def penetration_m(self):
        return self.runs.penetration_m

    @property
    def hover_m(self):
        return self.runs.hover_m

    @property
    def depth_m(self):
        """The larger of penetration and hover [m]."""
        return max(self.penetration_m, self.hover_m)


@dataclass
class VerifyResult(RunsSummary):
    """The outcome of a drop test in a real engine: :class:`DropRuns` and what was asked."""

    engine: str
    engine_version: str
    ball: str
    target: float
    dt_s: float
    tolerance: float
    runs: DropRuns
    max_penetration_m: float
    settings: dict = field(default_factory=dict)       # what the engine was given: SI numbers, unit in the key
    settings_text: dict = field(default_factory=dict)  # the same for people: {label: text}
    notes: tuple = ()
    g_m_per_s2: float = STANDARD_GRAVITY_M_PER_S2
    impact_speeds_m_per_s: tuple = ()
    holds_down_to_m_per_s: float | None = None
    drop_height_m: float | None = None
    others: tuple = ()       # drop tests of the file's other bodies on the floor (``--against``)
    unverified: tuple = ()   # the contacts a file writes that no drop test ran (text)
    pair: PairResult | None = None   # the two-ball collision test of the file's pair (``--against``)
    apex_goal: float | None = None   # the file's goal for the rebound apexes (DropSetup.apex_goal)
    apex_floor_m: float = 0.0        # ... or within this [m] (DropSetup.apex_floor_m)
    from_record: bool = False        # the target is a discover result's (its drag or speed law)

    @property
    def apex_ratios(self):
        return self.runs.apex_ratios

    @property
    def velocity_ratios(self):
        return self.runs.velocity_ratios

    @property
    def error(self):
        """Largest |achieved - target| over bounces, phases, apex and velocity ratios."""
        return self.runs.worst_error

    @property
    def mean_apex_ratio(self):
        return float(np.mean(self.runs.apex_ratios))

    @property
    def mean_velocity_ratio(self):
        return float(np.mean(self.runs.velocity_ratios))

    @property
    def depth_ok(self):
        """Penetration and hover within ``max_penetration_m``."""
        return self.depth_m <= self.max_penetration_m * (1 + 1e-9)

    @property
    def passed(self):
        return (self.error <= self.tolerance and self.depth_ok and self.runs.gain is None
                and not self.runs.apex_miss(self.apex_goal, self.apex_floor_m)
                and all(o.passed for o in self.others) and (self.pair is None or self.pair.passed))

    def failure(self):
        """Why the drop test failed, in one line for the terminal ('' when it passed): the error or
        the depth, and for an error at impacts slower than the export holds for, what to do."""
        failed = next((o for o in self.others if not o.passed), None)
        if self.runs.gain is not None:
            other = next((n for n in self.notes if n.startswith("run at --dt")), None)     # not the file's step
            fix = (f"{other}: export again with --dt {self.dt_s:g}" if other else
                   "a smaller --dt, or an epsilon further below 1")
            return (f"{self.runs.gain_text()}, whatever the tolerance (worst epsilon error {error_text(self.error)}); "
                    f"{fix}")
        if self.error <= self.tolerance and self.depth_ok and failed is not None:
            return f"{failed.ball} on the floor: {failed.failure()}"
        if self.error <= self.tolerance and self.depth_ok and self.pair is not None and not self.pair.passed:
            return self.pair.failure()
        if self.error > self.tolerance:
            return f"epsilon error {self.error:.4g} exceeds the tolerance {self.tolerance:g}" + self.slow_impacts()
        if not self.depth_ok:
            return (f"the ball turns {1e3 * self.depth_m:.3g} mm from the floor, more than --max-penetration "
                    f"{1e3 * self.max_penetration_m:.3g} mm")
        if self.runs.apex_miss(self.apex_goal, self.apex_floor_m):
            k, err, _ = self.runs.worst_apex(self.apex_floor_m, self.apex_goal)
            return (f"rebound {k}'s apex is {100 * err:+.1f} % off vrcal's model's (the file's goal: within "
                    f"{100 * self.apex_goal:g} % or {self.apex_floor_m * 1e3:.3g} mm, as vrcal verify --against "
                    f"judges a record): the per-bounce error compounds; a smaller --dt")
        return ""

    def slow_impacts(self):
        """The failure's clause when its impacts are slower than the export was made for: below the
        speed the file's contact is measured to hold down to (the header's 'holds down to', its
        ``holds_down_to_m_per_s``), or, where that is not known, an error worst at the last, slowest
        bounce that grew there: the first bounce within the tolerance, or the last off by twice as much
        (an error about even over the bounces, e.g. a softened contact, is no matter of speed). It names
        the fix: an export for these speeds, or a smaller step. '' otherwise (and for a file run at
        another step than its own: that is the note's cause).

        MuJoCo's damper is tuned to the exported speeds (its margin ``v dt/2``): a slower ball falls
        into the margin and bounces off it higher; ODE's and Bullet's error bound ``g dt / (e v)``
        grows as the impacts slow (:func:`vrcal.engines.export.step_bound`).
        """
        v = np.asarray(self.impact_speeds_m_per_s, dtype=float)
        err = self.runs.bounce_errors
        if v.size != err.size or v.size == 0 or any(n.startswith("run at --dt") for n in self.notes):
            return ""
        slow = f"this drop's impacts, {v[0]:.3g}..{v[-1]:.3g} m/s,"
        holds = self.holds_down_to_m_per_s
        if holds is not None and v[-1] < holds * (1 - 1e-6):
            what = f"{slow} go below the {holds:.3g} m/s the export was measured to hold down to (its header)"
        elif v.size > 1 and int(np.argmax(err)) == v.size - 1 and (err[0] <= self.tolerance or err[-1] >= 2 * err[0]):
            what = (f"the error grows as the impacts slow (bounce 1 at {v[0]:.3g} m/s off by {err[0]:.3g}, bounce "
                    f"{v.size} at {v[-1]:.3g} m/s by {err[-1]:.3g})")
        else:
            return ""
        return f"; {what}: {export_for_speeds(float(v[0]), float(v[-1]), self.drop_height_m)}"

    def as_dict(self):
        r = self.runs
        return {
            "engine": self.engine, "engine_version": self.engine_version, "ball": self.ball,
            "target_epsilon": self.target, "dt_s": self.dt_s, "g_m_per_s2": self.g_m_per_s2,
            "tolerance": self.tolerance, "phase_shifts_m": [float(p) for p in r.shifts_m],
            "apex_ratios": r.apex_ratios.tolist(),
            "velocity_ratios": r.velocity_ratios.tolist(),
            "target_apex_ratios": r.target_apex_ratios.tolist(),
            "target_epsilons": r.target_epsilons.tolist(),
            "apex_heights_m": r.apex_m.tolist(),
            "target_apex_heights_m": r.target_apex_m.tolist(),
            "error": self.error, "median_error": self.median_error,
            "penetration_m": self.penetration_m, "hover_m": self.hover_m,
            "max_penetration_m": self.max_penetration_m,
            "passed": self.passed, "settings": self.settings, "notes": list(self.notes),
            "impact_speeds_m_per_s": [float(x) for x in self.impact_speeds_m_per_s],
            "holds_down_to_m_per_s": self.holds_down_to_m_per_s,
            "other_bodies": [o.as_dict() for o in self.others], "not_verified": list(self.unverified),
            "pair": None if self.pair is None else self.pair.as_dict(),
        }
