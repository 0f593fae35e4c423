"""MuJoCo: restitution as a contact calibrated in MuJoCo itself, at the user's step and integrator.

MuJoCo has no restitution parameter. A contact is a soft constraint whose reference
acceleration is ``a_ref = -b v - k r`` (r: distance minus margin, negative inside); with the
impedance d (``solimp``) the constrained acceleration is ``a = d a_ref + (1 - d) a0`` and the
constraint force may not pull, so the contact ends when the force reaches zero. In the direct
form ``solref="-S -D"`` MuJoCo uses ``k = S / d^2`` and ``b = D / d``, so the contact adds
``-D v - (S / d) r`` to the acceleration. vrcal writes ``solimp="d d 0.001 0.5 2"`` with
d = 0.9999 (1e-4 of gravity leaks through a contact).

Two contacts, both calibrated by running MuJoCo (:func:`calibrate`):

* **damper** (``S = 0``; Euler, implicit and implicitfast, whose flights are semi-implicit:
  velocity first, then position). At the first contact step the ball's velocity becomes
  ``(1 - D dt) v``: with ``D = (1 + eps) / dt`` the contact reverses it to ``-eps v`` in one
  step, at any step size, so epsilon does not depend on where in its step the impact falls.
  The ball moves up to ``v dt`` in the step in which it reaches the floor; a contact margin of
  ``v dt / 2`` (``v`` the fastest impact) makes it turn between ``v dt / 2`` below and above the
  floor. A resting ball creeps into the floor at ``(1 - d) g / D`` (about 1 um/s at 2 ms).
* **spring** (``S = d w^2``, any integrator, the only one for RK4): a damped spring of
  angular frequency w, chosen so that the ball sinks about ``v / w`` = the penetration limit;
  epsilon then scatters with the contact phase unless ``w dt`` is small. For a linear spring
  ended at zero force (no gravity)

      e(zeta) = exp(-zeta/sqrt(1-zeta^2) (pi - atan2(2 zeta sqrt(1-zeta^2), 1 - 2 zeta^2)))

  (:func:`epsilon_from_damping_ratio`; gravity ends the contact earlier:
  :func:`contact_epsilon`). These formulas give the start; the damping is then found by a
  root-find in MuJoCo at the user's step.

The root-find (:func:`calibrate`) runs the drop test (``n_phases`` contact phases x
``n_bounces`` bounces, :mod:`vrcal.engines.common`) and moves the damping until the errors
are centred on the target (their largest and smallest sum to 0), which minimises the worst
error; a speed-dependent epsilon thus gets the best constant over the drop's impact speeds.
Where the tolerance or the penetration limit cannot be met at the asked step,
:func:`suggest_dt` finds, again in MuJoCo, the largest step that meets both.
"""

from __future__ import annotations

import math
import textwrap
from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import brentq

from vrcal.engines.common import (
    N_PHASES,
    DropRuns,
    PairResult,
    RunsSummary,
    StillBouncing,
    check_steps,
    confirmed,
    drag_atol,
    drop_runs,
    drop_window_s,
    epsilon_spread,
    error_text,
    metadata,
    phase_shifts_m,
    refine_step,
    round_down,
    sized_run,
    step_note,
    stepped_pair_test,
)
from vrcal.errors import DataError, EngineUnavailable, UsageError, install_hint
from vrcal.textout import counted

#: Impedance d written to solimp (dmin = dmax): close to MuJoCo's maximum 0.9999.
IMPEDANCE = 0.9999

#: MuJoCo's own default time step [s] and integrator: the defaults of export and verify.
DEFAULT_DT_S = 0.002
DEFAULT_INTEGRATOR = "euler"

#: ``--integrator`` values and MuJoCo's spelling of each.
INTEGRATORS = {"euler": "Euler", "implicit": "implicit", "implicitfast": "implicitfast", "rk4": "RK4"}

#: Integrators with semi-implicit flights (the damper contact works with these).
SEMI_IMPLICIT = ("euler", "implicit", "implicitfast")

#: A pair's friction (tangent 1, tangent 2, torsion, rolling 1, rolling 2): MuJoCo's default. vrcal
#: calibrates the vertical bounce only, which it does not move (condim 3 against 1: the same drop
#: test to 4 decimals); with it a ball sliding on the floor ends rolling (5/7 of a 2 m/s slide, spin
#: = v/R). In an impact the contact's damping acts on the slip too: :func:`friction_lines`.
PAIR_FRICTION = "1 1 0.005 0.0001 0.0001"

#: Most MuJoCo steps of one drop test (all contact phases together).
MAX_STEPS = 4_000_000

#: Steps simulated at once by :func:`run_drops` (memory: 112 bytes per step and drop).
CHUNK_STEPS = 50_000

#: Most drop tests of one root-find.
MAX_EVALUATIONS = 10

#: Root-find stops when the errors are centred to within this.
CENTRE_TOLERANCE = 1e-4

_ZETA_MAX = 1.0 / math.sqrt(2.0)


# --------------------------------------------------------------------------- the contact spring


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
    """epsilon of MuJoCo's contact spring with gravity, ended at zero constraint force.

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


def zeta_for_epsilon(epsilon, omega_per_s, impact_speed_m_per_s, g_m_per_s2):
    """Damping ratio for which :func:`contact_epsilon` equals ``epsilon`` at the given impact speed."""
    if epsilon >= 1.0:
        return 0.0
    zeta0 = damping_ratio_from_epsilon(epsilon)

    def f(z):
        return contact_epsilon(z, omega_per_s, impact_speed_m_per_s, g_m_per_s2) - epsilon

    if f(0.0) < 0:
        raise UsageError(
            f"a MuJoCo contact at w = {omega_per_s:g} rad/s cannot reach epsilon {epsilon:g} at "
            f"{impact_speed_m_per_s:.3g} m/s (gravity ends the contact early): use a stiffer contact"
        )
    return brentq(f, 0.0, min(zeta0 * 1.5 + 1e-3, _ZETA_MAX * (1 - 1e-9)), xtol=1e-15)


# --------------------------------------------------------------------------- contact settings


@dataclass(frozen=True)
class Contact:
    """A ball/floor contact of MuJoCo: ``solref="-S -D"``, ``solimp="d d ..."`` and a margin.

    Attributes
    ----------
    stiffness : float
        S of the direct-form solref [1/s^2] (0: the damper contact)
    damping : float
        D of the direct-form solref [1/s]
    margin_m : float
        distance at which the contact acts [m]
    impedance : float
        d of solimp
    """

    stiffness: float
    damping: float
    margin_m: float = 0.0
    impedance: float = IMPEDANCE

    @property
    def kind(self):
        return "damper" if self.stiffness == 0 else "spring"

    @property
    def solref(self):
        return [-float(self.stiffness) if self.stiffness else 0.0, -float(self.damping)]

    @property
    def solimp(self):
        return [self.impedance, self.impedance, 0.001, 0.5, 2]

    @property
    def omega_per_s(self):
        """Angular frequency of the spring, sqrt(S / d) [rad/s] (0 for the damper)."""
        return math.sqrt(self.stiffness / self.impedance)


def contact_for(x, kind, dt_s, omega_per_s=0.0, margin_m=0.0):
    """The :class:`Contact` whose own epsilon (no gravity, exact time) is ``x``.

    damper: ``D = (1 + x) / dt``, the velocity reversal of one semi-implicit step; spring:
    ``S = d w^2``, ``D = 2 zeta(x) w`` (:func:`damping_ratio_from_epsilon`).
    """
    if kind == "damper":
        return Contact(0.0, (1.0 + x) / dt_s, margin_m)
    zeta = damping_ratio_from_epsilon(min(max(x, 0.2085), 1.0))
    return Contact(IMPEDANCE * omega_per_s ** 2, 2.0 * zeta * omega_per_s, margin_m)


def resting_height_m(margin_m, stiffness_per_s2, g_m_per_s2, impedance=IMPEDANCE):
    """Height [m] of a resting ball's bottom above the floor in MuJoCo's contact.

    At rest (v = 0, a = 0) the constrained acceleration ``d a_ref + (1 - d) a0`` with ``a_ref =
    -(S / d^2) r`` and ``a0 = -g`` gives ``r = -(1 - d) d g / S``: the ball rests that far inside the
    margin, ``margin - (1 - d) d g / S`` above the floor (a fraction of a micrometre for vrcal's
    springs). The damper (S = 0) has no such level: the ball floats at the margin and sinks through
    it at :func:`resting_sink_speed_m_per_s`.

    Parameters
    ----------
    margin_m : float or ndarray
        the contact's margin [m]
    stiffness_per_s2 : float or ndarray
        S of the direct-form solref [1/s^2] (0: the damper)
    g_m_per_s2 : float or ndarray
        gravity [m/s^2]
    impedance : float
        d of solimp

    Returns
    -------
    float or ndarray
        height above the floor [m] (negative: the ball rests in the floor)
    """
    S = np.asarray(stiffness_per_s2, dtype=float)
    sink = (1.0 - impedance) * impedance * np.asarray(g_m_per_s2, dtype=float) / np.where(S > 0, S, 1.0)
    out = np.asarray(margin_m, dtype=float) - np.where(S > 0, sink, 0.0)
    return float(out) if out.ndim == 0 else out


def resting_sink_speed_m_per_s(damping_per_s, stiffness_per_s2, g_m_per_s2, impedance=IMPEDANCE):
    """Speed [m/s] at which a resting ball sinks through MuJoCo's damper contact: ``(1 - d) g / D``.

    At a = 0 the constrained acceleration ``d (-(D / d) v) + (1 - d) (-g)`` gives ``v = -(1 - d) g / D``:
    1e-4 of gravity leaks through the damper (about 1.2 um/s for D = 850 1/s at 2 ms). A spring
    (S > 0) holds the ball at :func:`resting_height_m`: 0.

    Parameters
    ----------
    damping_per_s : float or ndarray
        D of the direct-form solref [1/s]
    stiffness_per_s2, g_m_per_s2, impedance
        S [1/s^2] (0: the damper), gravity [m/s^2] and d, as for :func:`resting_height_m`

    Returns
    -------
    float or ndarray
        sinking speed [m/s], >= 0
    """
    S = np.asarray(stiffness_per_s2, dtype=float)
    out = np.where(S > 0, 0.0, (1.0 - impedance) * np.asarray(g_m_per_s2, dtype=float)
                   / np.asarray(damping_per_s, dtype=float))
    return float(out) if out.ndim == 0 else out


def resting_note(contact, g_m_per_s2, smaller_step):
    """What a resting ball does in ``contact``, for people (< 100 columns): '' where it rests on the
    floor (within 10 um), else how high it floats, how fast it sinks, and that ``smaller_step`` (the
    option's or the attribute's name) lowers it (the damper's margin is ``v dt / 2``)."""
    height = resting_height_m(contact.margin_m, contact.stiffness, g_m_per_s2, contact.impedance)
    if abs(height) < 1e-5:
        return ""
    sink = resting_sink_speed_m_per_s(contact.damping, contact.stiffness, g_m_per_s2, contact.impedance)
    sinking = f" (sinks {sink * 1e6:.2g} um/s)" if sink > 0 else ""
    return f"a resting ball floats {height * 1e3:.3g} mm above the floor{sinking}; a smaller {smaller_step} lowers it"


def spring_omega(setup, penetration_m=None):
    """Angular frequency [rad/s] for which the fastest impact sinks about ``penetration_m`` (v / w)."""
    p = setup.penetration_limit_m if penetration_m is None else penetration_m
    return setup.impact_speed_m_per_s / p


def damper_margin(setup):
    """Margin [m] of the damper contact: half the fastest impact's travel in one step."""
    return 0.5 * setup.impact_speed_m_per_s * setup.dt_s


# --------------------------------------------------------------------------- the MJCF


def _fmt(x):
    return f"{x:.10g}"


def integrator_name(setup):
    """MuJoCo's spelling of the setup's integrator (Euler by default)."""
    key = (setup.integrator or DEFAULT_INTEGRATOR).lower()
    if key not in INTEGRATORS:
        raise UsageError(f"unknown --integrator '{setup.integrator}' (known: {', '.join(INTEGRATORS)})")
    return INTEGRATORS[key]


def model_xml(setup, contact, header=(), pairs=(), extra_bodies=(), numbers=None, texts=None):
    """A complete MJCF model: floor plane, the ball on a free joint, the contact pair(s).

    Parameters
    ----------
    setup : DropSetup
    contact : Contact
        the ball/floor contact
    header : sequence of str
        comment lines (each kept under 100 columns)
    pairs : sequence of (geom1, geom2, Contact)
        further contact pairs (``--against``)
    extra_bodies : sequence of str
        MJCF lines of further bodies
    numbers : dict, optional
        further ``vrcal_*`` numerics after the drop test's (e.g. ``holds_down_to_m_per_s``; with
        ``--against`` ``ball2_epsilon`` and ``pair_epsilon``)
    texts : dict, optional
        further ``vrcal_*`` texts after ``vrcal_ball`` (``--against``: ``ball2``, the second ball's name)

    Returns
    -------
    str
        MJCF text (loads with ``mujoco.MjModel.from_xml_string``); the drop test's target sits
        in ``<custom>`` numerics named ``vrcal_*`` (read back by ``vrcal verify --file``)
    """
    R, H = setup.radius_m, setup.drop_height_m
    fluid = ""
    option = (f'  <option timestep="{_fmt(setup.dt_s)}" integrator="{integrator_name(setup)}" '
              f'gravity="0 0 {-setup.g_m_per_s2:g}"')
    if setup.drag_coefficient:
        from vrcal.drop.effects import AIR_DENSITY_KG_PER_M3

        option += f' density="{AIR_DENSITY_KG_PER_M3:g}" viscosity="0"'
        # MuJoCo's ellipsoid model: blunt drag force = C_blunt rho (pi R^2) v^2 = 1/2 rho C_d A v^2
        fluid = f' fluidshape="ellipsoid" fluidcoef="{_fmt(setup.drag_coefficient / 2.0)} 0 0 0 0"'
    lines = ['<mujoco model="vrcal-drop">']
    lines += [f"  <!-- {h} -->" for h in header]
    lines += [
        option + "/>",
        "  <default>",
        '    <geom contype="0" conaffinity="0"/>  <!-- contacts come only from the pairs below -->',
        "  </default>",
        "  <worldbody>",
        '    <geom name="floor" type="plane" size="10 10 0.1"/>',
        f'    <body name="ball" pos="0 0 {_fmt(H + R)}">',
        "      <freejoint/>",
        f'      <geom name="ball" type="sphere" size="{_fmt(R)}" mass="{_fmt(setup.mass_kg)}"{fluid}/>',
        "    </body>",
        *extra_bodies,
        "  </worldbody>",
        "  <contact>",
    ]
    for g1, g2, c in [("ball", "floor", contact), *pairs]:
        lines.append(f'    <pair geom1="{g1}" geom2="{g2}" condim="3" friction="{PAIR_FRICTION}"')
        lines.append(f'          margin="{_fmt(c.margin_m)}" solref="{" ".join(_fmt(x) for x in c.solref)}" '
                     f'solimp="{" ".join(_fmt(x) for x in c.solimp)}"/>')
    lines += ["  </contact>", "  <custom>"]
    for key, value in {**metadata(setup), **(numbers or {})}.items():
        lines.append(f'    <numeric name="vrcal_{key}" data="{_fmt(value)}"/>')
    lines += [f'    <text name="vrcal_{key}" data="{_xml_text(value)}"/>'
              for key, value in {"ball": setup.ball, **(texts or {})}.items()]
    lines += ["  </custom>", "</mujoco>", ""]
    return "\n".join(lines)


def _xml_text(text):
    return (str(text).replace("&", "&amp;").replace('"', "&quot;").replace("<", "&lt;")
            .replace(">", "&gt;").replace("\n", " "))


# --------------------------------------------------------------------------- running MuJoCo


def _mujoco():
    try:
        import mujoco
    except ImportError:
        raise EngineUnavailable(f"MuJoCo is not installed: {install_hint('mujoco', 'engines')}") from None
    return mujoco


def version():
    return _mujoco().__version__


def load_model(mjcf):
    """Compile MJCF text; a MuJoCo error becomes one line."""
    mujoco = _mujoco()
    try:
        return mujoco.MjModel.from_xml_string(mjcf)
    except ValueError as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else "unknown error"
        raise DataError(f"MuJoCo cannot load the model: {first}") from None


#: How many of a model's geom names an error lists.
LISTED_GEOMS = 12


@dataclass(frozen=True)
class Scene:
    """A compiled MuJoCo model and the geoms of its ball and floor (vrcal's exports name them
    'ball' and 'floor'; a user's model names them its own way: :func:`scene_of`).

    Attributes
    ----------
    model : mujoco.MjModel
    ball_geom, floor_geom : str
        the names of the ball's sphere geom (on a body with a free joint) and the floor's geom
    """

    model: object
    ball_geom: str = "ball"
    floor_geom: str = "floor"


def as_scene(runnable):
    """A :class:`Scene` of MJCF text, a compiled model (vrcal's geom names) or a Scene."""
    if isinstance(runnable, Scene):
        return runnable
    return Scene(load_model(runnable) if isinstance(runnable, str) else runnable)


def geom_names(model):
    """The names of a compiled model's named geoms, in the model's order."""
    names = (model.geom(i).name for i in range(model.ngeom))
    return [n for n in names if n]


def _listing(names):
    """'a, b and c' of at most :data:`LISTED_GEOMS` geom names, for a message."""
    if not names:
        return "it has no named geom"
    shown = names[:LISTED_GEOMS]
    more = f" and {len(names) - len(shown)} more" if len(names) > len(shown) else ""
    return "its geoms: " + ", ".join(shown) + more


def _geom_type(model, gid):
    """MuJoCo's name of a geom's type ('sphere', 'plane', ...)."""
    return _mujoco().mjtGeom(int(model.geom_type[gid])).name.removeprefix("mjGEOM_").lower()


def scene_of(model, ball_geom=None, floor_geom=None):
    """The :class:`Scene` of a compiled model: its ball's and floor's geoms, checked.

    The ball is ``ball_geom`` (``--ball-geom``), else the geom named 'ball' (vrcal's exports), else
    the one sphere of the model's ``<pair>`` elements; the floor is ``floor_geom`` (``--floor-geom``), else the
    other geom of the one pair that holds the ball, else the geom named 'floor'. The ball must be a
    sphere on a body with a free joint (vrcal drops that body); the floor a plane or a box, facing up.

    Raises
    ------
    DataError
        one line naming the geoms the model has and the option that names the ball or the floor
    """
    mujoco = _mujoco()
    names = geom_names(model)
    pairs = [(int(model.pair_geom1[i]), int(model.pair_geom2[i])) for i in range(model.npair)]

    def named(name, option):
        if name not in names:
            raise DataError(f"{option} {name}: the model has no geom of that name ({_listing(names)})")
        return model.geom(name).id

    if ball_geom is not None:
        ball = named(ball_geom, "--ball-geom")
    elif "ball" in names:
        ball = model.geom("ball").id
    else:
        spheres = sorted({g for pair in pairs for g in pair if _geom_type(model, g) == "sphere"})
        if len(spheres) != 1:
            raise DataError(f"the model has no geom named 'ball' (vrcal's name) and {len(spheres)} sphere(s) in its "
                            f"{len(pairs)} <pair> element(s), not one to take for the ball: name the ball's geom with "
                            f"--ball-geom NAME ({_listing(names)})")
        ball = spheres[0]
    ball_name = model.geom(ball).name or f"geom {ball}"
    if floor_geom is not None:
        floor = named(floor_geom, "--floor-geom")
    else:
        others = {b if a == ball else a for a, b in pairs if ball in (a, b)}
        if len(others) == 1:
            floor = others.pop()
        elif "floor" in names:
            floor = model.geom("floor").id
        else:
            raise DataError(f"the model has no geom named 'floor' (vrcal's name) and {len(others)} <pair> element(s) "
                            f"of the ball '{ball_name}', not one to take the floor from: name the floor's geom with "
                            f"--floor-geom NAME ({_listing(names)})")
    if floor == ball:
        raise DataError(f"the ball and the floor are the same geom '{ball_name}': name the floor with --floor-geom")
    if _geom_type(model, ball) != "sphere":
        raise DataError(f"the ball geom '{ball_name}' is a {_geom_type(model, ball)}, not a sphere: vrcal drops a "
                        f"ball (name its sphere geom with --ball-geom NAME)")
    body = int(model.geom_bodyid[ball])
    joint = int(model.body_jntadr[body])
    if joint < 0 or int(model.jnt_type[joint]) != int(mujoco.mjtJoint.mjJNT_FREE):
        raise DataError(f"the ball geom '{ball_name}' is on the body '{model.body(body).name}', which has no free "
                        f"joint: vrcal drops the ball's body (give it <freejoint/>)")
    floor_name = model.geom(floor).name or f"geom {floor}"
    if _geom_type(model, floor) not in ("plane", "box"):
        raise DataError(f"the floor geom '{floor_name}' is a {_geom_type(model, floor)}: vrcal drops the ball on a "
                        f"plane or a box (name it with --floor-geom NAME)")
    return Scene(model, model.geom(ball).name, model.geom(floor).name)


def floor_top_m(model, data, floor_geom):
    """Height [m] of the floor geom's top (a plane's surface, a box's top face) in ``data``'s state;
    DataError for a floor that does not face up (+z)."""
    gid = model.geom(floor_geom).id
    axis = np.asarray(data.geom_xmat[gid]).reshape(3, 3)[:, 2]
    if axis[2] < 1.0 - 1e-9:
        raise DataError(f"the floor geom '{floor_geom}' is tilted (its normal {axis[0]:.3g} {axis[1]:.3g} "
                        f"{axis[2]:.3g}): vrcal drops the ball on a floor facing up (+z)")
    top = float(data.geom_xpos[gid][2])
    return top + float(model.geom_size[gid][2]) if _geom_type(model, gid) == "box" else top


def run_drops(model, drop_height_m, shifts_m, duration_s, radius_m, max_steps=MAX_STEPS):
    """Drop the ball of a compiled model from ``drop_height_m + shift`` for every shift.

    ``model`` is MJCF text, a compiled model (vrcal's geom names 'ball' and 'floor') or a
    :class:`Scene`: the ball's body is moved so that the bottom of its sphere is ``drop_height_m +
    shift`` above the floor's top (the sphere's offset in its body and the floor's height as the
    model has them). Uses ``mujoco.rollout`` (all drops in one C loop), in chunks of
    :data:`CHUNK_STEPS`.

    Returns
    -------
    z_m, v_m_per_s : ndarray
        (n_shifts, n_steps + 1) bottom height above the floor and vertical velocity, sample 0 = release
    dt_s, g_m_per_s2 : float
        as read from the model
    """
    mujoco = _mujoco()
    from mujoco import rollout

    scene = as_scene(model)
    model = scene.model
    data = mujoco.MjData(model)
    dt = float(model.opt.timestep)
    g = -float(model.opt.gravity[2])
    joint = model.body(int(model.geom_bodyid[model.geom(scene.ball_geom).id])).jntadr[0]
    qadr, vadr = model.jnt_qposadr[joint], model.jnt_dofadr[joint]
    mujoco.mj_resetData(model, data)
    mujoco.mj_forward(model, data)
    # the sphere's centre above the body's origin, and the floor's top: 0 and 0 in vrcal's own model
    offset = float(data.geom_xpos[model.geom(scene.ball_geom).id][2]) - float(data.qpos[qadr + 2])
    floor = floor_top_m(model, data, scene.floor_geom)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    states = []
    for shift in shifts_m:
        mujoco.mj_resetData(model, data)
        data.qpos[qadr + 2] = floor + drop_height_m + shift + radius_m - offset
        mujoco.mj_forward(model, data)
        st = np.empty(mujoco.mj_stateSize(model, spec))
        mujoco.mj_getState(model, data, st, spec)
        states.append(st)
    state = np.array(states)
    nstep = int(math.ceil(duration_s / dt))
    if nstep * len(states) > max_steps:
        raise UsageError(f"the MuJoCo run needs {nstep * len(states):,} steps (limit {max_steps:,}): use a larger --dt")
    iz, iv = 1 + qadr + 2, 1 + model.nq + vadr + 2
    zs, vs = [state[:, iz:iz + 1]], [state[:, iv:iv + 1]]
    done = 0
    while done < nstep:
        n = min(CHUNK_STEPS, nstep - done)
        out, _ = rollout.rollout(model, data, state, nstep=n)
        zs.append(out[:, :, iz])
        vs.append(out[:, :, iv])
        state = out[:, -1, :]
        done += n
    return np.concatenate(zs, axis=1) + (offset - floor - radius_m), np.concatenate(vs, axis=1), dt, g


def _semi_implicit(model):
    mujoco = _mujoco()
    return int(model.opt.integrator) != int(mujoco.mjtIntegrator.mjINT_RK4)


def drop_test(mjcf, setup, n_bounces, n_phases, resize=True, at_least=None):
    """Run a model (MJCF text, compiled, or a :class:`Scene`) and measure it against vrcal's model: a
    :class:`DropRuns`.

    ``resize``: run once more, longer, for a ball that bounced higher than the target
    (:func:`vrcal.engines.common.sized_run`); the calibration, which needs only the sign of the
    error, does not. ``at_least``: each run lasts long enough for a constant epsilon that high
    (the calibration against a speed-dependent target, whose best constant bounces higher than
    the target's first, fast impact).
    """
    scene = as_scene(mjcf)
    model = scene.model
    setup = replace(setup, n_bounces=int(n_bounces))
    shifts = phase_shifts_m(setup, n_phases)
    stiff = [-float(s) for s in model.pair_solref[:, 0] if s < 0]
    # spring contacts last about pi/w each: two periods per bounce
    contacts = n_bounces * 2.0 * math.pi / math.sqrt(min(stiff)) if stiff else 0.0

    def run(ratio):
        duration = drop_window_s(setup, setup.drop_height_m + shifts[-1], ratio, at_least) + contacts
        z, v, dt, g = run_drops(scene, setup.drop_height_m, shifts, duration, setup.radius_m)
        return drop_runs(setup, shifts, list(zip(z, v)), dt, g, int(n_bounces), _semi_implicit(model),
                         drag_atol(setup))

    return sized_run(run, setup, n_phases, MAX_STEPS) if resize else run(None)


def _pair_index(model, geom1, geom2):
    """The index of the ``<pair>`` of two geoms in a compiled model (None without one)."""
    ids = {model.geom(geom1).id, model.geom(geom2).id}
    return next((i for i in range(model.npair) if {int(model.pair_geom1[i]), int(model.pair_geom2[i])} == ids), None)


def pair_test(scene, pair, n_phases, ball2_geom="ball2"):
    """The two-ball collision test of a :class:`Scene`'s ball and ``ball2_geom``: a
    :class:`vrcal.engines.common.PairResult`.

    Gravity is off for the runs (the balls fly 1 m above the floor, which they never reach); the
    pair's margin and contact (its ``<pair>``'s solref: a damper acts in one step, a spring over
    its period) set where the runs start and how long they last. Each run steps MuJoCo itself
    (``mj_step``), reading the two sphere centres and the free joints' velocities.
    """
    mujoco = _mujoco()
    model = scene.model
    i = _pair_index(model, scene.ball_geom, ball2_geom)
    if i is None:
        raise DataError(f"the model has no <pair> of '{scene.ball_geom}' and '{ball2_geom}': the pair test runs "
                        "the pair's own contact")
    k = -float(model.pair_solref[i][0])
    steps = 2 if k <= 0 else int(math.ceil(2.0 * math.pi / math.sqrt(k) / float(model.opt.timestep))) + 2
    pair = replace(pair, margin_m=float(model.pair_margin[i]), contact_steps=steps,
                   dt_s=float(model.opt.timestep))
    data = mujoco.MjData(model)
    geoms = [model.geom(scene.ball_geom).id, model.geom(ball2_geom).id]
    joints = [int(model.body_jntadr[int(model.geom_bodyid[g])]) for g in geoms]
    qadr = [int(model.jnt_qposadr[j]) for j in joints]
    vadr = [int(model.jnt_dofadr[j]) for j in joints]
    height = floor_top_m(model, _forward(model, data), scene.floor_geom) + 1.0 + pair.radius2_m + pair.margin_m
    gravity = model.opt.gravity.copy()

    def run(_params, pair, gap_m, n_steps):
        mujoco.mj_resetData(model, data)
        mujoco.mj_forward(model, data)
        for g, q, x in zip(geoms, qadr, (0.0, pair.contact_distance_m + gap_m)):
            centre = np.asarray(data.geom_xpos[g])
            data.qpos[q:q + 3] += np.array([x, 0.0, height]) - centre
        for a, v in zip(vadr, pair.velocities_m_per_s):
            data.qvel[a:a + 6] = (v, 0.0, 0.0, 0.0, 0.0, 0.0)
        mujoco.mj_forward(model, data)
        out = np.empty((4, n_steps + 1))
        for n in range(n_steps + 1):
            if n:
                mujoco.mj_step(model, data)
            out[:, n] = (data.geom_xpos[geoms[0]][0], data.geom_xpos[geoms[1]][0], data.qvel[vadr[0]],
                         data.qvel[vadr[1]])
        return out

    try:
        model.opt.gravity[:] = 0.0
        runs = stepped_pair_test(run, None, pair, n_phases)
    finally:
        model.opt.gravity[:] = gravity
    return PairResult("mujoco", pair, runs)


def _forward(model, data):
    """``data`` after ``mj_resetData`` and ``mj_forward`` (the model's initial pose)."""
    mujoco = _mujoco()
    mujoco.mj_resetData(model, data)
    mujoco.mj_forward(model, data)
    return data


# --------------------------------------------------------------------------- calibration in MuJoCo


@dataclass
class Calibration(RunsSummary):
    """The contact found by :func:`calibrate` and the drop test it passed (or failed)."""

    setup: object
    contact: Contact
    runs: DropRuns
    evaluations: int

    @property
    def meets_tolerance(self):
        return self.worst_error <= self.setup.tolerance

    @property
    def meets_depth(self):
        return self.depth_m <= self.setup.penetration_limit_m * (1 + 1e-9)

    @property
    def ok(self):
        return self.meets_tolerance and self.meets_depth and self.runs.gain is None

    @property
    def excess(self):
        """The larger of worst error / tolerance and depth / penetration limit (<= 1: meets both)."""
        return max(self.worst_error / self.setup.tolerance, self.depth_m / self.setup.penetration_limit_m)

    @property
    def best_constant(self):
        """The epsilon the contact gives (mean velocity ratio over phases and bounces)."""
        return float(np.mean(self.runs.velocity_ratios))


def default_kind(setup):
    """damper for semi-implicit integrators, spring for RK4."""
    return "damper" if (setup.integrator or DEFAULT_INTEGRATOR).lower() in SEMI_IMPLICIT else "spring"


def calibrate(setup, n_phases=N_PHASES, kind=None, omega_per_s=None):
    """Find the contact damping in MuJoCo itself, at the setup's step and integrator.

    Parameters
    ----------
    setup : DropSetup
        ball, drop, target, dt, integrator, tolerance and penetration limit
    n_phases : int
        contact phases of the drop test (``setup.n_bounces`` bounces each)
    kind : {"damper", "spring"} or None
        the contact (default: :func:`default_kind`)
    omega_per_s : float or None
        the spring's angular frequency [rad/s] (default :func:`spring_omega`)

    Returns
    -------
    Calibration
        the contact whose drop-test errors are centred on the target (see the module docstring)

    Raises
    ------
    UsageError
        the damper with RK4; a run longer than :data:`MAX_STEPS`
    """
    kind = kind or default_kind(setup)
    if kind == "damper" and (setup.integrator or DEFAULT_INTEGRATOR).lower() not in SEMI_IMPLICIT:
        raise UsageError("the damper contact needs a semi-implicit integrator (euler, implicit, implicitfast); "
                         "RK4 takes a spring (give --stiffness)")
    check_steps(setup, n_phases, "MuJoCo", MAX_STEPS, "the calibration's drop test")
    if kind == "spring":
        return _confirmed(_calibrate_at(setup, n_phases, kind, omega_per_s or spring_omega(setup), 0.0), n_phases)
    # the damper: the ball turns between margin - v dt and margin; the slow late bounces (low
    # apexes) want a margin of their own half step, the fast first one half of its step
    speeds = setup.impact_speeds_m_per_s
    v1, vn = float(np.max(speeds)), float(np.min(speeds))
    best = None
    for margin in (0.5 * v1 * setup.dt_s, 0.25 * (v1 + vn) * setup.dt_s, 0.5 * vn * setup.dt_s):
        cal = _calibrate_at(setup, n_phases, kind, 0.0, margin)
        if best is None or cal.excess < best.excess:
            best = cal
        if best.excess <= 0.5:
            break
    return _confirmed(best, n_phases)


def _confirmed(cal, n_phases, passed=None):
    """A calibration that meets both limits at ``n_phases`` (or ``passed`` says it is run regardless),
    run again with :data:`CONFIRM_PHASES` contact phases (when more, and within the run limit): those
    runs are the ones it reports and is judged by (4 phases under-sample a slow last bounce: a 200 g,
    70 mm ball of epsilon 0.45 from 0.5 m at 0.7 ms, 0.0047 with 4 phases, 0.0119 with 16 and with 64)."""
    setup = cal.setup

    def rerun(phases):
        targets = setup.epsilons
        at_least = float(np.max(targets)) if np.ptp(targets) > 0 else None
        model = load_model(model_xml(setup, cal.contact))
        runs = drop_test(model, setup, setup.n_bounces, phases, at_least=at_least)
        return replace(cal, runs=runs, evaluations=cal.evaluations + 1)

    return confirmed(cal, cal.ok if passed is None else passed, setup, n_phases, "MuJoCo", MAX_STEPS, rerun)


def widened(cal, n_phases):
    """A calibration that missed, its contact run over :data:`CONFIRM_PHASES` contact phases as a pass
    would be confirmed (within the run limit; else as it is): what a refusal reports, the misses the
    limits it offers instead are confirmed against. A probe's marble at 2 ms was told 'worst epsilon
    error 0.0332' (4 phases) and offered '--tolerance 0.059', which the same contact needs over 16
    phases (0.0532)."""
    return _confirmed(cal, n_phases, passed=True)


def _calibrate_at(setup, n_phases, kind, w, margin):
    """:func:`calibrate` with the contact's kind, frequency and margin fixed: the root-find on damping."""
    mujoco = _mujoco()
    model = load_model(model_xml(setup, contact_for(setup.epsilon, kind, setup.dt_s, w, margin)))
    targets = setup.epsilons
    centre = 0.5 * (float(np.max(targets)) + float(np.min(targets)))
    # a speed-dependent target: every constant up to its largest epsilon is run to the end
    at_least = float(np.max(targets)) if np.ptp(targets) > 0 else None
    lo_x, hi_x = (0.0, 1.0) if kind == "damper" else (0.2085, 1.0)
    cache = {}

    def evaluate(x):
        c = contact_for(x, kind, setup.dt_s, w, margin)
        model.pair_solref[0] = c.solref
        model.pair_margin[0] = c.margin_m
        try:
            runs = drop_test(model, setup, setup.n_bounces, n_phases, resize=False, at_least=at_least)
            f = runs.midrange_error
        except StillBouncing:
            runs, f = None, 1.0                      # bounced on past the window: far too much epsilon
        except DataError:
            runs, f = None, -1.0                     # no bounce: far too little epsilon
        cache[x] = (c, runs, f)
        return f

    x0 = min(max(centre, lo_x), hi_x)
    f0 = evaluate(x0)
    x1 = min(max(x0 - f0, lo_x), hi_x)              # epsilon moves about one for one with x
    if x1 == x0:
        x1 = min(max(x0 - math.copysign(1e-3, f0), lo_x), hi_x)
    f1 = evaluate(x1)
    lo = hi = None
    for x, f in ((x0, f0), (x1, f1)):
        if f < 0:
            lo = (x, f) if lo is None or x > lo[0] else lo
        else:
            hi = (x, f) if hi is None or x < hi[0] else hi
    ftol = max(CENTRE_TOLERANCE, setup.tolerance / 20.0)
    while len(cache) < MAX_EVALUATIONS and min(abs(f) for _, _, f in cache.values()) > ftol:
        if abs(f1 - f0) > 1e-12:
            x2 = x1 - f1 * (x1 - x0) / (f1 - f0)
        else:
            x2 = x1 - f1
        if lo is not None and hi is not None and not (lo[0] < x2 < hi[0]):
            x2 = 0.5 * (lo[0] + hi[0])
        x2 = min(max(x2, lo_x), hi_x)
        if x2 in cache:
            break
        f2 = evaluate(x2)
        if f2 < 0:
            lo = (x2, f2) if lo is None or x2 > lo[0] else lo
        else:
            hi = (x2, f2) if hi is None or x2 < hi[0] else hi
        x0, f0, x1, f1 = x1, f1, x2, f2
    done = [(c, r) for c, r, _ in cache.values() if r is not None]
    if not done:
        if all(f > 0 for _, _, f in cache.values()):
            raise StillBouncing("MuJoCo's ball bounced higher than the target at every damping tried "
                                "(the contact adds energy at this step)", 1.0)
        raise DataError("MuJoCo did not bounce the ball at any damping tried")
    contact, runs = min(done, key=lambda cr: cr[1].worst_error)
    del mujoco
    return Calibration(setup, contact, runs, len(cache))


def suggest_dt(setup, n_phases=N_PHASES, kind=None, omega_per_s=None):
    """The largest time step at which MuJoCo meets the tolerance and the penetration limit, found by
    calibrating in MuJoCo at smaller and smaller steps (a grid, two significant digits), then by
    bisection between the largest that passed and the smallest above it that missed (the setup's own
    step when the first passed) to :func:`vrcal.engines.common.step_resolution_s`
    (:func:`vrcal.engines.common.refine_step`): each step is the calibration an export at it runs.

    Returns
    -------
    (float, Calibration, float) or (None, None, None)
        the step [s], the calibration that met both there, and the smallest larger step that was
        calibrated and missed [s]; None when no step down to a run of :data:`MAX_STEPS` steps does
    """
    kind = kind or default_kind(setup)
    V = setup.impact_speed_m_per_s
    if kind == "damper":
        start = min(0.9 * setup.dt_s, 0.98 * 2.0 * setup.penetration_limit_m / V)
        candidates = [start * 0.8 ** j for j in range(12)]
        # and the smaller steps --trade-off lists, so the refusal and the table name the same step
        candidates = sorted({round_down(dt) for dt in candidates} | set(trade_off_steps(setup.dt_s)[1:]), reverse=True)
    else:
        w = omega_per_s or spring_omega(setup)
        candidates = [c / w for c in (0.4, 0.2, 0.1, 0.05, 0.025, 0.0125, 0.00625)]
        candidates = [round_down(dt) for dt in candidates if dt < setup.dt_s]

    def run(dt):
        trial = replace(setup, dt_s=dt)
        check_steps(trial, n_phases, "MuJoCo", MAX_STEPS)
        try:
            cal = calibrate(trial, n_phases, kind, omega_per_s)
        except StillBouncing:                    # no damping brings it down at this step: a miss
            return False, None
        return cal.ok, cal

    missed = setup.dt_s
    for dt in candidates:
        try:
            ok, cal = run(dt)
        except UsageError:
            return None, None, None
        if ok:
            return refine_step(run, dt, cal, missed)
        missed = dt
    return None, None, None


def trade_off_steps(dt_s):
    """The steps :func:`trade_off` calibrates at by default [s]: dt, dt/2 and dt/5 (three digits)."""
    return [float(f"{dt:.3g}") for dt in (dt_s, dt_s / 2, dt_s / 5)]


def trade_off(setup, n_phases=N_PHASES, steps=None):
    """Calibrations to choose from: (dt, contact, stiffness, damping, errors, penetration, hover).

    For the setup's step and smaller ones (``steps``, default dt, dt/2, dt/5), the damper
    (semi-implicit integrators) and springs that sink the fastest impact about R/4 and R/16,
    each calibrated in MuJoCo.

    Returns
    -------
    list of (dt_s, kind, omega_per_s, Calibration or str)
        the str says why there is no calibration: 'no bounce' (MuJoCo did not bounce the ball
        with that contact at that step) or 'too high' (it bounced higher at every damping)
    """
    steps = steps or trade_off_steps(setup.dt_s)
    rows = []
    for dt in steps:
        trial = replace(setup, dt_s=float(f"{dt:.3g}"))
        try:
            check_steps(trial, n_phases, "MuJoCo", MAX_STEPS)
        except UsageError:
            continue
        kinds = [("damper", 0.0)] if default_kind(trial) == "damper" else []
        R = trial.radius_m
        kinds += [("spring", spring_omega(trial, R * f)) for f in (0.25, 0.0625)]
        for kind, w in kinds:
            try:
                cal = calibrate(trial, n_phases, kind, w or None)
            except StillBouncing:
                cal = "too high"
            except (UsageError, DataError):
                cal = "no bounce"
            rows.append((trial.dt_s, kind, w, cal))
    return rows


# --------------------------------------------------------------------------- export


def header_lines(setup, cal):
    """Comment lines of an exported MJCF: what was asked, what MuJoCo did (each < 100 columns)."""
    c = cal.contact
    how = ("damper: one-step velocity reversal, D = (1 + eps)/dt, margin v dt/2" if c.kind == "damper"
           else f"spring: w = {c.omega_per_s:.4g} rad/s, sinks about v/w")
    lines = [
        f"vrcal export: {setup.ball}, target epsilon {setup.epsilon:.4f}, dt {setup.dt_s:g} s, "
        f"{integrator_name(setup)}",
        step_note(setup, "mujoco"),
        f"contact {how}",
        f"calibrated in MuJoCo ({cal.evaluations} runs); drop test {cal.runs.apex_ratios.shape[0]} phases x "
        f"{counted(setup.n_bounces, 'bounce')}",
        f"worst eps error {error_text(cal.worst_error)}, median {error_text(cal.median_error)} "
        f"(tolerance {setup.tolerance:g})",
        f"penetration {cal.penetration_m * 1e3:.3g} mm, hover {cal.hover_m * 1e3:.3g} mm "
        f"(limit {setup.penetration_limit_m * 1e3:.3g} mm)",
    ]
    lines += textwrap.wrap(resting_note(c, setup.g_m_per_s2, "dt"), 88)   # no two dashes in a comment
    if setup.restitution_exponent:
        lo, hi, least = epsilon_spread(setup)
        lines.append(f"eps(v) {lo:.4f}..{hi:.4f} over the drop: MuJoCo's contact is one "
                     f"constant, {cal.best_constant:.4f}")
        lines.append(f"no constant is nearer eps(v) than {least:.4f} (half its spread); "
                     "ODE, PyBullet carry the law")
    lines += friction_lines(setup, cal.contact)
    if setup.drag_coefficient:
        lines.append(f"air drag C_d {setup.drag_coefficient:.4g}: MuJoCo's fluid model, blunt drag = C_d/2")
    if setup.release_time_s:
        # the fit's release: where a record's fit restarts at an apex (a bounce left out) it is that apex, not
        # where the ball left the hand (a marble's 31 mm at 0.53 s, where the hand let go 19 cm up at 0.25 s)
        lines.append(f"release state: bottom at {setup.drop_height_m:.4f} m, at rest, at t = "
                     f"{setup.release_time_s:.4f} s of the record (where its fit starts)")
    return lines


def friction_lines(setup, contact):
    """The header's lines on friction (< 100 columns, no two dashes): what the contact's damping does to it.

    MuJoCo's pyramidal friction cone (its default) mixes the normal and the friction rows, so
    solref's damping D acts on the slip too: the damper (``D dt = 1 + eps``) reverses a sliding
    ball's slip instead of stopping it (measured at 2 ms over 8 contact phases: a tennis ball at 1
    m/s sideways leaves at vx 0.42..0.55 m/s spinning at 1.2..1.3 m/s / R; rolling would be 5/7 =
    0.71). With the elliptic cone the friction rows take ``solreffriction`` instead: ``0 -1/dt``
    stops the slip in one step (vx 0.67..0.74, spin 0.69..0.75 m/s / R: about rolling) and leaves
    the bounce as it is (tests/engines/test_mujoco.py).
    """
    lines = ["friction mu 1, MuJoCo's default (yours: friction=\"MU MU 0.005 0.0001 0.0001\" on the",
             "pair); solref's damping acts on the friction rows too (pyramidal cone, MuJoCo's default):"]
    if contact.kind == "damper":
        lines += ["a sliding ball's slip is reversed, not stopped (a tennis ball at 1 m/s sideways leaves at",
                  "0.42..0.55 m/s, spin 1.2..1.3 m/s / R); to stop it at rolling, bounce unchanged:",
                  f"cone=\"elliptic\" on option, solreffriction=\"0 {-1.0 / setup.dt_s:.6g}\" (D = 1/dt) on the pair"]
    else:
        lines.append("the spring's, not a friction of vrcal's choice (cone=\"elliptic\": solreffriction)")
    return lines


def pair_contact(eps, setup):
    """The contact of a pair that vrcal does not calibrate in MuJoCo (``--against``): the damper's
    one-step reversal for semi-implicit integrators, the force-zero spring (no gravity) for RK4."""
    if default_kind(setup) == "damper":
        return contact_for(eps, "damper", setup.dt_s, margin_m=damper_margin(setup))
    w = spring_omega(setup)
    return contact_for(eps, "spring", setup.dt_s, w)


def _ball2_body(setup, second):
    """MJCF lines of an ``--against`` export's second ball: beside the ball, at the drop height."""
    R, R2 = setup.radius_m, second.radius_m
    return [
        f'    <body name="ball2" pos="{_fmt(3 * (R + R2))} 0 {_fmt(second.drop_height_m + R2)}">',
        "      <freejoint/>",
        f'      <geom name="ball2" type="sphere" size="{_fmt(R2)}" mass="{_fmt(second.mass_kg)}"/>',
        "    </body>",
    ]


#: |midrange error| of the pair test at which the pair's contact is kept (the root-find's tolerance).
PAIR_XTOL = 1e-6


@dataclass
class PairCalibration:
    """The ball/ball2 contact of an ``--against`` export and its pair test in MuJoCo
    (:class:`vrcal.engines.common.PairResult`)."""

    contact: Contact
    result: object


def calibrate_pair(setup, second, pair, n_phases):
    """The ball/ball2 ``<pair>`` contact, found in MuJoCo by the pair test (the two balls head-on,
    gravity off, at the ball's first impact speed, ``n_phases`` contact phases).

    It starts from :func:`pair_contact` (the damper's one-step reversal, the force-zero spring for
    RK4) and root-finds the contact's own epsilon x so that the achieved epsilons are centred on
    Eq. 6's value (midrange error 0, like the floor's calibration); a contact already centred to
    :data:`PAIR_XTOL` is kept as it is (the damper: one semi-implicit step reverses the relative
    velocity exactly). The spring misses without it: a tennis ball against a basketball at RK4 and
    0.23 ms reached 0.5630..0.5744 for 0.5707.
    """
    from vrcal.engines.common import pair_setup

    base = pair_contact(pair["epsilon"], setup)
    target = pair_setup(setup, second.ball, second.mass_kg, second.radius_m, pair["epsilon"])
    bodies = _ball2_body(setup, second)
    runs = {}

    def run(x):
        contact = contact_for(x, base.kind, setup.dt_s, base.omega_per_s, base.margin_m)
        model = load_model(model_xml(setup, base, pairs=[("ball", "ball2", contact)], extra_bodies=bodies))
        runs[x] = PairCalibration(contact, pair_test(Scene(model), target, n_phases))
        eps = runs[x].result.runs.epsilons
        return 0.5 * (float(np.max(eps)) + float(np.min(eps))) - target.target

    x0 = float(pair["epsilon"])
    f0 = run(x0)
    if abs(f0) <= PAIR_XTOL:
        return runs[x0]
    lo, hi = max(x0 - 0.2, 0.2085 if base.kind == "spring" else 1e-3), 1.0
    f_lo = run(lo) if f0 > 0 else f0
    f_hi = run(hi) if f0 < 0 else f0
    if f_lo * f_hi > 0:               # nothing brackets: the best end stands (verify says it misses)
        return min(runs.values(), key=lambda c: c.result.error)
    a, b = (lo, x0) if f0 > 0 else (x0, hi)
    brentq(run, a, b, xtol=PAIR_XTOL, maxiter=50)
    return min(runs.values(), key=lambda c: c.result.error)


def export_mjcf(setup, cal, pair=None, second=None, coverage=None, cal2=None, pair_cal=None):
    """The MJCF text of a calibrated setup (with ``--against``: the second ball and its pairs, ``cal2`` the
    second ball's floor contact calibrated in MuJoCo, ``pair_cal`` the ball/ball2 contact of
    :func:`calibrate_pair`; with a :class:`vrcal.engines.export.SpeedCoverage`, the impact speeds the
    calibration holds for)."""
    from vrcal.engines.export import AIR_LEFT_OUT, RECORD_NOTE

    header = header_lines(setup, cal)
    record = [w for n in setup.notes if n.startswith((RECORD_NOTE, *AIR_LEFT_OUT)) for w in textwrap.wrap(n, 88)]
    header[3:3] = record + (textwrap.wrap(coverage.note(setup.tolerance), 88) if coverage is not None else [])
    pairs, bodies = [], []
    if pair and second is not None:
        bodies = _ball2_body(setup, second)
        floor2 = cal2.contact if cal2 is not None else pair_contact(second.epsilon, setup)
        contact = pair_cal.contact if pair_cal is not None else pair_contact(pair["epsilon"], setup)
        pairs = [("ball2", "floor", floor2), ("ball", "ball2", contact)]
        if cal2 is not None:
            header += textwrap.wrap(f"ball2 ({second.ball}) on the floor: epsilon {second.epsilon:.4f}, calibrated "
                                    f"in MuJoCo like the ball's over the same drop (worst eps error "
                                    f"{error_text(cal2.worst_error)})", 88)
        header.append(f"pair {pair['name']}: Eq. 6 gives {pair['epsilon']:.4f}; MuJoCo would average two geoms'")
        if pair_cal is None:
            header.append("solref, so ball/ball2 has its own pair (one-step reversal, not calibrated in MuJoCo)")
        else:
            r = pair_cal.result
            how = "one-step reversal" if contact.kind == "damper" else "spring"
            header += textwrap.wrap(
                f"solref, so ball/ball2 has its own pair ({how}), checked in MuJoCo: the two balls head-on at "
                f"{r.pair.speed_m_per_s:.3g} m/s (gravity off, {r.runs.epsilons.size} phases) give "
                f"{float(np.min(r.runs.epsilons)):.4f}..{float(np.max(r.runs.epsilons)):.4f} (worst error "
                f"{r.error:.4f}, overlap {1e3 * r.overlap_m:.3g} mm)", 88, break_on_hyphens=False)
    numbers = {"holds_down_to_m_per_s": coverage.holds_down_to_m_per_s} if coverage is not None else {}
    if pair and second is not None:
        numbers.update(ball2_epsilon=second.epsilon, pair_epsilon=pair["epsilon"])
    return model_xml(setup, cal.contact, header, pairs, bodies, numbers or None,
                     {"ball2": second.ball} if pair and second is not None else None)


def ball_of(scene):
    """(radius [m], mass [kg]) of a :class:`Scene`'s ball as MuJoCo has it compiled: the sphere's
    size and the mass its free joint carries (its body's, with any child bodies)."""
    model = scene.model
    gid = model.geom(scene.ball_geom).id
    return float(model.geom_size[gid][0]), float(model.body_subtreemass[int(model.geom_bodyid[gid])])


def contact_values(scene):
    """The ball/floor ``<pair>``'s ``solref`` (list) and ``margin_m`` [m] of a :class:`Scene`, full precision
    (a model whose ball and floor meet through their geoms' own contact, no pair: ``{"contact": text}``)."""
    model = scene.model
    ids = {model.geom(scene.ball_geom).id, model.geom(scene.floor_geom).id}
    for i in range(model.npair):
        if {int(model.pair_geom1[i]), int(model.pair_geom2[i])} == ids:
            return {"solref": [float(x) for x in model.pair_solref[i]], "margin_m": float(model.pair_margin[i])}
    return {"contact": f"no <pair> of '{scene.ball_geom}' and '{scene.floor_geom}' (the geoms' own)"}
