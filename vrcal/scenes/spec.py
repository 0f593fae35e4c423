"""Multi-body scenes: the scene file's schema, its loader, and the data types both simulators return.

A scene (YAML) holds spheres that bounce on a floor and on each other (Sections 4 and 7,
Figures 8 and 9 of [1]). Every body carries a virtual body (x, v); at every contact the
restitution comes from the two virtual bodies, Eq. (6) then Eq. (7) of [1]
(:func:`contact_epsilon`).

Schema (validated on load; a bad field is reported by its path, e.g.
``scene.yaml: bodies[1] (name 'b2').radius_m: must be > 0, got -0.1``)::

    name: str                     optional; default: the file name without suffix
    description: str              optional
    K_per_s: 4.0                  optional; rate constant K of Eq. (7) [1/s], > 0 (default 4, as vrcal pair)
    duration_s: 5.0               simulated time [s], > 0
    sample_dt_s: 0.01             optional; spacing of the output samples [s] (default 0.01)
    gravity_m_per_s2: 9.80665     optional; g [m/s^2], > 0
    friction_mu: 0.5              optional; Coulomb friction coefficient of every contact, >= 0
    rest_speed_m_per_s: 0.05      optional; a floor impact slower than this puts the ball at rest
    floor:                        the floor's virtual body: either
      material: steel             (steel/rigid: x = 0), or
      x_m: 0.0                    depth [m] >= 0 and
      v_m_per_s: 0.0              speed [m/s] (> 0 when x_m > 0)
    bodies:                       one or more spheres
      - name: ball1               unique
        ball: basketball          a ball of the standards: nominal mass and radius, virtual body of its
                                  nominal epsilon at K with x = R/2 (as `vrcal pair`), hollow shell;
        as_paper: false           optional; the ball's epsilon from the paper's Table 1 as printed
        from: result.json         or a `vrcal discover --json` result (path relative to the scene file):
                                  its ball's mass and radius, virtual body of its measured contact
                                  epsilon at K with x = R/2 (effects such as air drag are not simulated)
        mass_kg: 0.6              required without `ball` (overrides the ball's when given)
        radius_m: 0.12            required without `ball` (overrides the ball's when given: without a
                                  virtual_body, the ball's moves to x = R/2, same T, same epsilon)
        virtual_body: {x_m: 0.06, v_m_per_s: 0.18}   required without `ball`
        inertia: hollow           hollow (thin shell, I = 2/3 m R^2; default) | solid (I = 2/5 m R^2)
        position_m: [0, 0, 1.8]   initial position [m]
        position_of: centre       centre (default; also 'center') | bottom: position_m locates the sphere's bottom
        velocity_m_per_s: [0, 0, 0]   optional, default 0
        spin_rad_per_s: [0, 0, 0]     optional angular velocity [rad/s], default 0

The floor is the plane z = 0; z is up; gravity is -g along z.

References
----------
[1] "The Graphical Method for Decision of Restitution Coefficient and Its Applications".
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vrcal.errors import DataError, UsageError
from vrcal.fileio import read_yaml
from vrcal.model import restitution as eq

#: Default spacing of the output samples [s].
DEFAULT_SAMPLE_DT_S = 0.01
#: Default Coulomb friction coefficient of every contact.
DEFAULT_FRICTION_MU = 0.5
#: Default speed [m/s] below which a floor impact puts a ball at rest (Zeno guard).
DEFAULT_REST_SPEED_M_PER_S = 0.05
#: Moment of inertia factors k in I = k m R^2.
INERTIA_FACTORS = {"hollow": 2.0 / 3.0, "solid": 2.0 / 5.0}
#: Floor materials with a known virtual body.
FLOOR_MATERIALS = {"steel": (0.0, 0.0), "rigid": (0.0, 0.0)}
#: Most bodies in one scene.
MAX_BODIES = 100
#: Most output rows (sample times x bodies) of one scene; 10**6 rows take about 15 s and 40 MB of CSV.
MAX_SAMPLE_ROWS = 1_000_000
#: Longest name of a scene or a body [characters].
MAX_NAME_CHARS = 100
#: Largest values of a scene's quantities (the command line's options have the same ranges, docs/limits.md).
MAX_K_PER_S = 1e6
MAX_GRAVITY_M_PER_S2 = 1e3
MAX_MASS_KG = 1e4
MAX_RADIUS_M = 5.0
MAX_POSITION_M = 1e4
MAX_SPEED_M_PER_S = 1e4
MAX_SPIN_RAD_PER_S = 1e6

_TOP_FIELDS = {
    "name", "description", "K_per_s", "duration_s", "sample_dt_s", "gravity_m_per_s2", "friction_mu",
    "rest_speed_m_per_s", "floor", "bodies",
}
_BODY_FIELDS = {
    "name", "ball", "as_paper", "from", "mass_kg", "radius_m", "virtual_body", "inertia", "position_m",
    "position_of", "velocity_m_per_s", "spin_rad_per_s",
}


@dataclass(frozen=True)
class SceneBody:
    """One sphere of a scene, in SI units; position is the centre's."""

    name: str
    mass_kg: float
    radius_m: float
    inertia_factor: float
    x_m: float
    v_m_per_s: float
    position_m: tuple
    velocity_m_per_s: tuple
    spin_rad_per_s: tuple
    ball: str | None = None

    @property
    def inertia_kg_m2(self):
        """Moment of inertia about any axis through the centre [kg m^2]."""
        return self.inertia_factor * self.mass_kg * self.radius_m**2

    @property
    def contact_time_s(self):
        """This body's share of the contact time, x/(2v) (Eq. 10 of [1]) [s]."""
        return eq.contact_time_single_s(self.x_m, self.v_m_per_s)


@dataclass(frozen=True)
class Scene:
    """A validated scene."""

    name: str
    K_per_s: float
    duration_s: float
    bodies: tuple
    floor_x_m: float = 0.0
    floor_v_m_per_s: float = 0.0
    sample_dt_s: float = DEFAULT_SAMPLE_DT_S
    g_m_per_s2: float = eq.STANDARD_GRAVITY_M_PER_S2
    friction_mu: float = DEFAULT_FRICTION_MU
    rest_speed_m_per_s: float = DEFAULT_REST_SPEED_M_PER_S
    description: str = ""
    source: str = "scene"
    notes: tuple = ()

    @property
    def names(self):
        return tuple(b.name for b in self.bodies)

    def sample_times_s(self):
        """The output sample times, 0 to duration inclusive [s]."""
        n = int(math.floor(self.duration_s / self.sample_dt_s + 1e-9))
        return np.arange(n + 1) * self.sample_dt_s

    def epsilon_matrix(self):
        """Restitution of every pair (Eqs. 6, 7 of [1]): (n+1, n+1), index n is the floor."""
        x = np.array([b.x_m for b in self.bodies] + [self.floor_x_m])
        v = np.array([b.v_m_per_s for b in self.bodies] + [self.floor_v_m_per_s])
        eps = contact_epsilon(x[:, None], v[:, None], x[None, :], v[None, :], self.K_per_s)
        return np.asarray(eps)


def contact_epsilon(x_a_m, v_a_m_per_s, x_b_m, v_b_m_per_s, K_per_s):
    """Restitution of one contact from the two bodies' virtual bodies, Eqs. (6) and (7) of [1].

    Parameters
    ----------
    x_a_m, x_b_m : float or ndarray
        depths of the two virtual bodies [m], >= 0 (a steel floor has x = 0)
    v_a_m_per_s, v_b_m_per_s : float or ndarray
        speeds of the two virtual bodies [m/s], > 0 where the depth is > 0
    K_per_s : float
        rate constant K [1/s], > 0

    Returns
    -------
    epsilon : float or ndarray
        ``exp(-K (x_A/(2 v_A) + x_B/(2 v_B)))``; this is the near-callback computation of
        Section 7 of [1] ("Calculate time constant T, calculate epsilon").
    """
    return eq.epsilon_pair(x_a_m, v_a_m_per_s, x_b_m, v_b_m_per_s, K_per_s)


@dataclass
class SceneContact:
    """One contact (impact) between a body and the floor or another body."""

    t_s: float
    body_a: str
    body_b: str                 # "floor" for the floor
    impact_speed_m_per_s: float  # normal approach speed just before [m/s], > 0
    epsilon: float               # the epsilon used (Eqs. 6, 7), 0 where the ball was put at rest
    normal_impulse_N_s: float = math.nan
    tangential_impulse_N_s: float = math.nan
    note: str = ""


@dataclass
class SceneResult:
    """What a scene simulator returns; the same for vrcal's simulator and ODE."""

    scene: Scene
    engine: str
    t_s: np.ndarray             # (n_t,) sample times [s]
    position_m: np.ndarray      # (n_t, n_bodies, 3) centres [m]
    velocity_m_per_s: np.ndarray  # (n_t, n_bodies, 3)
    spin_rad_per_s: np.ndarray  # (n_t, n_bodies, 3)
    angle_y_rad: np.ndarray     # (n_t, n_bodies) rotation about the y axis (for the side-view animation)
    contacts: list              # of SceneContact, in time order
    apexes: list                # of (body name, t_s, bottom height [m]) of every free-flight apex
    notes: list = field(default_factory=list)
    settings: dict = field(default_factory=dict)

    def bottom_height_m(self):
        """Height of every body's bottom above the floor, (n_t, n_bodies) [m]."""
        radii = np.array([b.radius_m for b in self.scene.bodies])
        return self.position_m[:, :, 2] - radii[None, :]


# --------------------------------------------------------------------------- loading


def load_scene(path, standards=None):
    """Load and validate a scene file.

    Parameters
    ----------
    path : str or Path
        a YAML scene file (schema in this module's docstring)
    standards : dict or None
        the result of :func:`vrcal.model.standards.load_standards`; the shipped one when None

    Returns
    -------
    Scene

    Raises
    ------
    DataError
        unreadable file, malformed YAML (with its line) or a field that breaks the schema
        (with the body and the field)
    """
    path = Path(path)
    doc = read_yaml(path, "scene")
    return validate_scene(doc, str(path), default_name=path.stem, standards=standards, base_dir=path.parent)


def _err(where, path, msg):
    return DataError(f"{where}: {path}: {msg}")


def _brief(value, limit=40):
    """``repr(value)``, cut to ``limit`` characters (a huge value in a message)."""
    text = repr(value)
    return text if len(text) <= limit else f"{text[:limit - 3]}..."


def _finite(value):
    """True for a finite int or float (not a bool; an int beyond float's range is not finite)."""
    return (not isinstance(value, bool) and isinstance(value, (int, float))
            and (abs(value) <= 1e308 if isinstance(value, int) else math.isfinite(value)))


def _number(fields, key, where, path, *, default=None, minimum=None, strict=True, maximum=None):
    if key not in fields or fields[key] is None:
        if default is None:
            raise _err(where, f"{path}{key}", "missing")
        return float(default)
    value = fields[key]
    if not _finite(value):
        raise _err(where, f"{path}{key}", f"must be a number, got {_brief(value)}")
    if minimum is not None and (value <= minimum if strict else value < minimum):
        raise _err(where, f"{path}{key}", f"must be {'>' if strict else '>='} {minimum:g}, got {value!r}")
    if maximum is not None and value > maximum:
        raise _err(where, f"{path}{key}", f"must be <= {maximum:g}, got {value!r}")
    return float(value)


def _vector(fields, key, where, path, *, default=None, maximum=None):
    if key not in fields or fields[key] is None:
        if default is None:
            raise _err(where, f"{path}{key}", "missing")
        return tuple(default)
    value = fields[key]
    if not isinstance(value, (list, tuple)) or len(value) != 3 or not all(_finite(c) for c in value):
        raise _err(where, f"{path}{key}", f"must be a list of 3 numbers [x, y, z], got {_brief(value)}")
    if maximum is not None and max(abs(c) for c in value) > maximum:
        raise _err(where, f"{path}{key}", f"every component must lie within +-{maximum:g}, got {value!r}")
    return tuple(float(c) for c in value)


def _unknown(fields, allowed, where, path):
    """Refuse fields not in ``allowed``, offering the closest allowed name for each typo."""
    from vrcal.errors import closest_name

    unknown = sorted(set(fields) - allowed, key=str)
    if unknown:
        offers = [(str(u), closest_name(u, sorted(allowed))) for u in unknown]
        hint = "; ".join(f"did you mean {c!r} for {u!r}?" if len(unknown) > 1 else f"did you mean {c!r}?"
                         for u, c in offers if c)
        raise _err(where, path.rstrip(".") or "top level",
                   f"unknown field(s) {unknown}" + (f"; {hint}" if hint else "") + f" (allowed: {sorted(allowed)})")


def validate_scene(doc, where="scene", *, default_name="scene", standards=None, base_dir=None):
    """Validate a parsed scene document and build the :class:`Scene`.

    Parameters
    ----------
    doc : object
        the parsed YAML
    where : str
        the file name, for messages
    default_name : str
        the scene's name when the document gives none
    standards : dict or None
        ball standards; the shipped ones when None
    base_dir : str or Path or None
        the folder a body's relative ``from`` path is read from (the scene file's; None: the
        working directory)

    Returns
    -------
    Scene
    """
    if not isinstance(doc, dict):
        raise DataError(f"{where}: top level must be a mapping with duration_s, floor and bodies (K_per_s "
                        "optional, default 4)")
    _unknown(doc, _TOP_FIELDS, where, "")
    K = _number(doc, "K_per_s", where, "", default=eq.DEFAULT_K_PER_S, minimum=0, maximum=MAX_K_PER_S)
    duration = _number(doc, "duration_s", where, "", minimum=0)
    sample_dt = _number(doc, "sample_dt_s", where, "", default=DEFAULT_SAMPLE_DT_S, minimum=0)
    if sample_dt > duration:
        raise _err(where, "sample_dt_s", f"must not exceed duration_s = {duration:g}, got {sample_dt:g}")
    n_samples = duration / sample_dt + 1
    g = _number(doc, "gravity_m_per_s2", where, "", default=eq.STANDARD_GRAVITY_M_PER_S2, minimum=0,
                maximum=MAX_GRAVITY_M_PER_S2)
    mu = _number(doc, "friction_mu", where, "", default=DEFAULT_FRICTION_MU, minimum=0, strict=False)
    rest = _number(doc, "rest_speed_m_per_s", where, "", default=DEFAULT_REST_SPEED_M_PER_S, minimum=0,
                   strict=False)
    name = doc.get("name", default_name)
    if not isinstance(name, str) or not name.strip() or len(name.strip()) > MAX_NAME_CHARS:
        raise _err(where, "name", f"must be a non-empty text (at most {MAX_NAME_CHARS} characters), "
                                  f"got {_brief(name)}")
    description = doc.get("description", "")
    if not isinstance(description, str):
        raise _err(where, "description", "must be text")
    floor_x, floor_v = _floor(doc.get("floor"), where)
    raw_bodies = doc.get("bodies")
    if not isinstance(raw_bodies, list) or not raw_bodies:
        raise _err(where, "bodies", "must be a non-empty list of bodies")
    if len(raw_bodies) > MAX_BODIES:
        raise _err(where, "bodies", f"{len(raw_bodies)} bodies, more than the limit of {MAX_BODIES}")
    if n_samples * len(raw_bodies) > MAX_SAMPLE_ROWS:
        raise _err(where, "sample_dt_s", f"duration_s / sample_dt_s = {n_samples - 1:.3g} samples of "
                                         f"{len(raw_bodies)} bodies, more than the limit of {MAX_SAMPLE_ROWS:.0e} "
                                         "rows: raise sample_dt_s or shorten duration_s")
    bodies, notes = [], []
    for i, fields in enumerate(raw_bodies):
        bodies.append(_body(fields, i, where, K, standards, base_dir, notes))
    names = [b.name for b in bodies]
    for i, n in enumerate(names):
        if names.index(n) != i:
            raise _err(where, f"bodies[{i}].name", f"duplicate name {n!r} (also bodies[{names.index(n)}])")
    _check_overlaps(bodies, where)
    return Scene(
        name=name.strip(), K_per_s=K, duration_s=duration, bodies=tuple(bodies), floor_x_m=floor_x,
        floor_v_m_per_s=floor_v, sample_dt_s=sample_dt, g_m_per_s2=g, friction_mu=mu, rest_speed_m_per_s=rest,
        description=description.strip(), source=where, notes=tuple(notes),
    )


def _floor(fields, where):
    if fields is None:
        raise _err(where, "floor", "missing; give {material: steel} or {x_m: ..., v_m_per_s: ...}")
    if not isinstance(fields, dict):
        raise _err(where, "floor", "must be a mapping: {material: steel} or {x_m: ..., v_m_per_s: ...}")
    _unknown(fields, {"material", "x_m", "v_m_per_s"}, where, "floor")
    if "material" in fields:
        if set(fields) != {"material"}:
            raise _err(where, "floor", "give either material or x_m and v_m_per_s, not both")
        mat = str(fields["material"]).strip().lower()
        if mat not in FLOOR_MATERIALS:
            raise _err(where, "floor.material", f"unknown material {fields['material']!r} "
                                                f"(known: {', '.join(FLOOR_MATERIALS)}; or give x_m and v_m_per_s)")
        return FLOOR_MATERIALS[mat]
    x = _number(fields, "x_m", where, "floor.", minimum=0, strict=False)
    if x == 0:
        v = _number(fields, "v_m_per_s", where, "floor.", default=0.0, minimum=0, strict=False)
    else:
        v = _number(fields, "v_m_per_s", where, "floor.", minimum=0)
    return x, v


def _body(fields, i, where, K, standards, base_dir=None, notes=None):
    label = f"bodies[{i}]"
    if not isinstance(fields, dict):
        raise _err(where, label, "must be a mapping with name, position_m and ball (or from, or mass_kg, radius_m, "
                                 "virtual_body)")
    name = fields.get("name")
    if not isinstance(name, str) or not name.strip():
        _unknown(fields, _BODY_FIELDS, where, f"{label}.")  # a typo of 'name' is named as a typo
    if (not isinstance(name, str) or not name.strip() or name.strip().lower() == "floor"
            or len(name.strip()) > MAX_NAME_CHARS):
        raise _err(where, f"{label}.name", f"must be a non-empty text other than 'floor' (at most "
                                           f"{MAX_NAME_CHARS} characters), got {_brief(name)}")
    name = name.strip()
    path = f"{label} (name {name!r})."
    _unknown(fields, _BODY_FIELDS, where, path)
    ball_key = fields.get("ball")
    from_json = fields.get("from")
    mass = radius = x = v = None
    if from_json is not None:
        if not isinstance(from_json, str) or not from_json.strip():
            raise _err(where, f"{path}from", f"must be the path of a 'vrcal discover --json' result, got "
                                             f"{_brief(from_json)}")
        if "as_paper" in fields:
            raise _err(where, f"{path}as_paper", "only applies to a body with a 'ball' of the standards, not 'from'")
        body, vb, eps = _discovered_body(from_json.strip(), ball_key, K, standards, base_dir, where, path)
        ball_key = body.name
        mass, radius, x, v = body.mass_kg, body.radius_m, vb.x_m, vb.v_m_per_s
        if notes is not None:
            left = ", ".join(body.effects)
            notes.append(f"{name}: epsilon {eps:.4f} measured by vrcal discover ({from_json.strip()})"
                         + (f"; {left} not simulated in a scene" if left else ""))
    elif ball_key is not None:
        from vrcal.inverse import parse_body
        from vrcal.model.standards import get_ball

        as_paper = fields.get("as_paper", False)
        if not isinstance(as_paper, bool):
            raise _err(where, f"{path}as_paper", f"must be true or false, got {as_paper!r}")
        try:
            ball = get_ball(str(ball_key), standards)
            key, vb, _eps = parse_body(ball.key, K, standards, as_paper)
        except UsageError as exc:
            raise _err(where, f"{path}ball", str(exc)) from None
        ball_key = key
        mass, radius, x, v = ball.mass_kg.nominal, ball.radius_m, vb.x_m, vb.v_m_per_s
    elif "as_paper" in fields:
        raise _err(where, f"{path}as_paper", "only applies to a body with a 'ball'")
    mass = _number(fields, "mass_kg", where, path, default=mass, minimum=0, maximum=MAX_MASS_KG)
    own_radius = radius
    radius = _number(fields, "radius_m", where, path, default=radius, minimum=0, maximum=MAX_RADIUS_M)
    if ball_key is not None and "virtual_body" not in fields and radius != own_radius:
        # the ball's virtual body is x = R/2 (inverse.ball_virtual_body): another radius takes its own
        # x = R/2 with the same contact time T, so the same epsilon, and x stays inside the ball
        T = eq.contact_time_single_s(x, v)
        x = radius / 2.0
        v = eq.virtual_speed_m_per_s(x, T) if T > 0 else 0.0
        if notes is not None and abs(radius / own_radius - 1.0) > 0.01:   # not a rounding of the ball's radius
            notes.append(f"{name}: radius_m {radius:g} m instead of the ball's {own_radius:g} m: its virtual body "
                         f"is x = R/2 = {1e3 * x:.4g} mm, v = {v:.4g} m/s (the same contact time, so the same epsilon)")
    if "virtual_body" in fields or ball_key is None:
        vb = fields.get("virtual_body")
        vpath = f"{path}virtual_body"
        if not isinstance(vb, dict):
            raise _err(where, vpath, "missing or not a mapping {x_m: DEPTH, v_m_per_s: SPEED} "
                                     "(or give a ball of the standards, or from: a discover result)")
        _unknown(vb, {"x_m", "v_m_per_s"}, where, vpath)
        x = _number(vb, "x_m", where, vpath + ".", minimum=0, strict=False)
        if x == 0:
            v = _number(vb, "v_m_per_s", where, vpath + ".", default=0.0, minimum=0, strict=False)
        else:
            v = _number(vb, "v_m_per_s", where, vpath + ".", minimum=0)
        if x > radius:
            raise _err(where, f"{vpath}.x_m", f"the virtual body lies inside the ball: x must be <= radius "
                                              f"{radius:g} m, got {x:g}")
    inertia = fields.get("inertia", "hollow")
    if inertia not in INERTIA_FACTORS:
        raise _err(where, f"{path}inertia", f"must be one of {sorted(INERTIA_FACTORS)}, got {inertia!r}")
    position = _vector(fields, "position_m", where, path, maximum=MAX_POSITION_M)
    position_of = fields.get("position_of", "centre")
    if position_of == "center":          # both spellings
        position_of = "centre"
    if position_of not in ("centre", "bottom"):
        raise _err(where, f"{path}position_of", f"must be 'centre' (or 'center') or 'bottom', got {position_of!r}")
    if position_of == "bottom":
        position = (position[0], position[1], position[2] + radius)
    if position[2] < radius:
        raise _err(where, f"{path}position_m", f"the sphere reaches below the floor: centre z = {position[2]:g} m "
                                               f"< radius {radius:g} m")
    velocity = _vector(fields, "velocity_m_per_s", where, path, default=(0.0, 0.0, 0.0), maximum=MAX_SPEED_M_PER_S)
    spin = _vector(fields, "spin_rad_per_s", where, path, default=(0.0, 0.0, 0.0), maximum=MAX_SPIN_RAD_PER_S)
    return SceneBody(name=name, mass_kg=mass, radius_m=radius, inertia_factor=INERTIA_FACTORS[inertia], x_m=x,
                     v_m_per_s=v, position_m=position, velocity_m_per_s=velocity, spin_rad_per_s=spin,
                     ball=ball_key)


def _discovered_body(from_json, ball_key, K, standards, base_dir, where, path):
    """The body of a scene's ``from: FILE`` (relative to ``base_dir``): (Body, VirtualBody, epsilon).

    Every error is a DataError naming the scene file and the field's path.
    """
    from vrcal.inverse import ball_virtual_body
    from vrcal.model.body import describe_body

    file = Path(from_json)
    if base_dir is not None and not file.is_absolute():
        file = Path(base_dir) / file
    try:
        body = describe_body(None if ball_key is None else str(ball_key), from_json=file, standards=standards,
                             ball_label="ball")
        vb, eps = ball_virtual_body(body, K)
    except (UsageError, DataError) as exc:
        raise _err(where, f"{path}from", str(exc)) from None
    return body, vb, eps


def _check_overlaps(bodies, where):
    p = np.array([b.position_m for b in bodies])
    r = np.array([b.radius_m for b in bodies])
    for i in range(len(bodies)):
        for j in range(i + 1, len(bodies)):
            d = float(np.linalg.norm(p[i] - p[j]))
            if d < r[i] + r[j] - 1e-12:
                raise _err(where, f"bodies[{j}] (name {bodies[j].name!r}).position_m",
                           f"overlaps bodies[{i}] (name {bodies[i].name!r}): centres {d:.6g} m apart, "
                           f"radii add to {r[i] + r[j]:.6g} m")
