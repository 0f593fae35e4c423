"""Reading exported engine files back (``vrcal verify --file``): checked, one-line errors, no bombs.

* :func:`read_file` -- the text of a file, refused when it is not a file, too large or binary;
* :func:`read_params` -- an ODE or PyBullet JSON export, every key the runner uses checked;
* :func:`read_mjcf` -- an MJCF export, parsed by ``defusedxml`` first (a DTD, an entity -- a
  "billion laughs" bomb or an external entity -- is refused before anything is expanded, so
  MuJoCo never sees such a file) and its time step, integrator and ``vrcal_*`` numbers read.
"""

from __future__ import annotations

import json
import math

from vrcal.errors import DataError
from vrcal.model.body import read_limited

#: Largest exported file read [bytes]; an export is a few kB.
MAX_FILE_BYTES = 4 * 1024 * 1024


def read_file(path):
    """The UTF-8 text of an exported file; DataError (one line) for anything else."""
    raw = read_limited(path, MAX_FILE_BYTES, "an exported engine file")
    if b"\x00" in raw:
        raise DataError(f"{path}: a binary file, not an exported engine file")
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError:
        raise DataError(f"{path}: not UTF-8 text, not an exported engine file") from None


def _number(value, what, lo=-math.inf, hi=math.inf, lo_open=False):
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise DataError(f"{what} must be a finite number, got {str(value)[:40]!r}")
    v = float(value)
    if v < lo or (lo_open and v == lo) or v > hi:
        raise DataError(f"{what} = {v:g} is out of range")
    return v


def _get(doc, path, engine):
    cur = doc
    for key in path.split("."):
        if not isinstance(cur, dict) or key not in cur:
            raise DataError(f"not a vrcal {engine} export: missing '{path}'")
        cur = cur[key]
    return cur


#: (key path, low, high) of the numbers a runner reads when the file has them (ODE: the world's ERP and
#: CFM in older files, the contact's own in newer ones).
_OPTIONAL_NUMBERS = {
    "ode": [("world.erp", 0, 1), ("world.cfm", 0, 1e6), ("contact.soft_erp", 0, 1), ("contact.soft_cfm", 0, 1e6),
            ("world.contact_max_correcting_vel", 0, math.inf), ("world.contact_surface_layer", 0, 1e3),
            ("world.quick_step_iterations", 1, 1e4),
            # an --against export's second ball and the two balls' contact (older files have neither)
            ("ball2.mass_kg", 0, 1e6), ("ball2.radius_m", 0, 1e3), ("contact_pair.mu", 0, math.inf),
            ("contact_pair.bounce", 0, 1), ("contact_pair.bounce_vel", 0, 1e6), ("contact_pair.soft_erp", 0, 1),
            ("contact_pair.soft_cfm", 0, 1e6)],
    "bullet": [("ball2.mass_kg", 0, 1e6), ("ball2.radius_m", 0, 1e3)],
}

#: (key path, low, high) of the numbers each runner reads.
_NUMBERS = {
    "ode": [("ball.mass_kg", 0, 1e6), ("ball.radius_m", 0, 1e3), ("ball.drop_height_m", 0, 1e4),
            ("target_epsilon", 0, 1), ("world.dt", 0, 1),
            ("contact.mu", 0, math.inf), ("contact.bounce", 0, 1), ("contact.bounce_vel", 0, 1e6)],
    "bullet": [("ball.mass_kg", 0, 1e6), ("ball.radius_m", 0, 1e3), ("ball.drop_height_m", 0, 1e4),
               ("target_epsilon", 0, 1), ("setPhysicsEngineParameter.fixedTimeStep", 0, 1),
               ("changeDynamics.ball.restitution", 0, 1), ("changeDynamics.floor.restitution", 0, 1)],
}


def read_params(engine, text):
    """An ODE or PyBullet export (JSON) with every number the runner uses checked.

    Parameters
    ----------
    engine : {"ode", "bullet"}
    text : str

    Returns
    -------
    dict

    Raises
    ------
    DataError
        not JSON, not an object, another engine's file, a missing or non-numeric key
    """
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise DataError(f"not a vrcal {engine} export (JSON): line {exc.lineno}: {exc.msg}") from None
    except RecursionError:
        raise DataError(f"not a vrcal {engine} export: JSON nested too deeply") from None
    if not isinstance(data, dict):
        raise DataError(f"not a vrcal {engine} export: the top level is a {type(data).__name__}, not an object")
    if data.get("engine") != engine:
        raise DataError(f"not a vrcal {engine} export: engine is {str(data.get('engine'))[:40]!r}")
    for path, lo, hi in _NUMBERS[engine]:
        _number(_get(data, path, engine), f"{engine} export: {path}", lo, hi, lo_open=path.endswith(
            ("mass_kg", "radius_m", "dt", "fixedTimeStep")))
    for path, lo, hi in _OPTIONAL_NUMBERS[engine]:
        block, _, key = path.partition(".")
        if isinstance(data.get(block), dict) and key in data[block]:
            _number(data[block][key], f"{engine} export: {path}", lo, hi,
                    lo_open=path.endswith(("mass_kg", "radius_m")))
    if engine == "ode":
        gravity = _get(data, "world.gravity", engine)
        if not (isinstance(gravity, list) and len(gravity) == 3):
            raise DataError("ode export: world.gravity must be a list of 3 numbers")
        for x in gravity:
            _number(x, "ode export: world.gravity", -1e3, 1e3)
        from vrcal.engines import ode_ctypes as O

        for block in ("contact", "contact_pair"):
            if block == "contact_pair" and not isinstance(data.get(block), dict):
                continue
            modes = _get(data, f"{block}.mode", engine)
            if not (isinstance(modes, list) and all(isinstance(m, str) and m.startswith("dContact")
                                                    and isinstance(getattr(O, m, None), int) for m in modes)):
                raise DataError(f"ode export: {block}.mode must be a list of dContact... flag names")
        if data["world"].get("step", "dWorldStep") not in ("dWorldStep", "dWorldQuickStep"):
            raise DataError("ode export: world.step must be dWorldStep or dWorldQuickStep")
    else:
        gravity = _get(data, "setGravity", engine)
        if not (isinstance(gravity, list) and len(gravity) == 3):
            raise DataError("bullet export: setGravity must be a list of 3 numbers")
        for x in gravity:
            _number(x, "bullet export: setGravity", -1e3, 1e3)
        ball2 = isinstance(data.get("changeDynamics"), dict) and "ball2" in data["changeDynamics"]
        for key in ("setPhysicsEngineParameter", "changeDynamics.ball", "changeDynamics.floor",
                    *(("changeDynamics.ball2",) if ball2 else ())):
            block = _get(data, key, engine)
            if not isinstance(block, dict):
                raise DataError(f"bullet export: {key} must be an object")
            for name, value in block.items():
                _number(value, f"bullet export: {key}.{name}")
    _check_effects(data, engine)
    _check_target(data, engine)
    return data


def _check_effects(data, engine):
    drag = data.get("drag")
    if drag is not None:
        if not isinstance(drag, dict):
            raise DataError(f"{engine} export: drag must be an object")
        _number(drag.get("force_coefficient_kg_per_m"), f"{engine} export: drag.force_coefficient_kg_per_m", 0, 1e3)
    law = data.get("restitution_law")
    if law is not None:
        if not isinstance(law, dict):
            raise DataError(f"{engine} export: restitution_law must be an object")
        _number(law.get("epsilon_ref"), f"{engine} export: restitution_law.epsilon_ref", 0, 1, lo_open=True)
        _number(law.get("reference_speed_m_per_s"), f"{engine} export: restitution_law.reference_speed_m_per_s", 0,
                1e3, lo_open=True)
        _number(law.get("exponent"), f"{engine} export: restitution_law.exponent", -1, 2)


def _check_target(data, engine):
    target = data.get("target")
    if target is None:
        return
    if not isinstance(target, dict):
        raise DataError(f"{engine} export: target must be an object")
    for key, value in target.items():
        _number(value, f"{engine} export: target.{key}")


def engine_of_file(text, path):
    """The engine an exported file is for (``vrcal verify --file`` without ``--engine``): a JSON export's
    ``engine`` ("ode" or "bullet"), an MJCF (root ``<mujoco>``) "mujoco", an SDF (root ``<sdf>``) "gazebo".

    Parameters
    ----------
    text : str
        the file's text (:func:`read_file`)
    path : str
        its name, for the error

    Raises
    ------
    UsageError
        when the file does not say: give --engine
    """
    import json

    from vrcal.errors import UsageError

    head = text.lstrip()[:4096]
    if head.startswith("{"):
        try:
            engine = json.loads(text).get("engine")
        except (ValueError, AttributeError, RecursionError):
            engine = None
        if engine in ("ode", "bullet"):
            return engine
    elif head.startswith("<"):
        root = next((tag for tag in ("mujoco", "sdf") if f"<{tag}" in head), None)
        if root is not None:
            return {"mujoco": "mujoco", "sdf": "gazebo"}[root]
    raise UsageError(f"{path}: no vrcal export of a known engine (a JSON 'engine' of ode or bullet, an MJCF <mujoco> "
                     "or an SDF <sdf> root): give --engine")


def _parse_xml(text, what):
    """The root element of an engine's XML file (``what``: "MJCF", "SDF"), parsed with a DTD, entities and
    external references refused unexpanded (defusedxml); :class:`DataError` naming ``what`` otherwise."""
    from defusedxml import DefusedXmlException
    from defusedxml import ElementTree as DET

    try:
        return DET.fromstring(text, forbid_dtd=True, forbid_entities=True, forbid_external=True)
    except DefusedXmlException as exc:
        raise DataError(f"refused the {what} file: it declares a DTD or entities ({type(exc).__name__}); "
                        "a vrcal export has none") from None
    except Exception as exc:  # noqa: BLE001 - xml.etree.ElementTree.ParseError and friends
        raise DataError(f"not an {what} file: {str(exc).splitlines()[0] if str(exc) else type(exc).__name__}") from None


def read_mjcf(text):
    """Read an MJCF export with a hardened parser.

    Returns
    -------
    dict
        ``timestep`` [s], ``integrator`` (lower case), ``ball`` (the ``vrcal_ball`` label, else
        'ball'), ``target`` {name: number} from the ``vrcal_*`` custom numerics and ``texts``
        {name: text} from the ``vrcal_*`` custom texts (``--against``: ``ball2``). The ball's and
        the floor's geoms, its radius and mass are read from the compiled model
        (:func:`vrcal.engines.mujoco.scene_of`), which resolves a user's defaults and classes.

    Raises
    ------
    DataError
        XML with a DTD or entities (refused unexpanded), malformed XML, not a MuJoCo model,
        a non-numeric time step
    """
    if text.lstrip().startswith("{"):   # `vrcal export --engine mujoco -o x.json` writes the export's summary
        raise DataError("not an MJCF file: a JSON file (the export's summary from -o FILE.json or --format json); "
                        "verify runs the model: export it with -o FILE.xml")
    root = _parse_xml(text, "MJCF")
    if root.tag != "mujoco":
        raise DataError(f"not an MJCF file: the root element is <{root.tag[:40]}>, not <mujoco>")
    option = root.find("option")
    out = {"timestep": 0.002, "integrator": "euler"}
    if option is not None:
        if option.get("timestep") is not None:
            out["timestep"] = _xml_number(option.get("timestep"), "<option timestep>", 0, 1)
        if option.get("integrator") is not None:
            out["integrator"] = option.get("integrator").strip().lower()
    target = {}
    for numeric in root.iter("numeric"):
        name = numeric.get("name") or ""
        if name.startswith("vrcal_"):
            target[name[len("vrcal_"):]] = _xml_number(numeric.get("data"), f"<numeric {name}>")
    out["target"] = target
    out["ball"] = "ball"
    out["texts"] = {}
    for text_el in root.iter("text"):
        name = text_el.get("name") or ""
        if name.startswith("vrcal_"):
            out["texts"][name[len("vrcal_"):]] = (text_el.get("data") or "")[:80]
    out["ball"] = out["texts"].get("ball") or "ball"
    return out


def _xml_number(text, what, lo=-math.inf, hi=math.inf):
    try:
        v = float(str(text).strip())
    except (TypeError, ValueError):
        raise DataError(f"MJCF: {what} '{str(text)[:40]}' is not a number") from None
    if not math.isfinite(v) or v <= lo or v > hi:
        raise DataError(f"MJCF: {what} {v:g} is out of range")
    return v


def read_sdf(text):
    """Read a Gazebo classic world (SDF) with a hardened parser: what :func:`vrcal.engines.gazebo.ode_params`
    combines, each value SDF 1.7's default where the file leaves it out
    (:data:`vrcal.engines.gazebo.SDF_DEFAULTS`).

    The ball is the model named 'ball', else the first model with a ``<sphere>`` collision; the floor
    the model named 'ground_plane', else the first other model with a ``<plane>`` collision.

    Returns
    -------
    dict
        ``world`` (``max_step_size`` [s], ``gravity`` [m/s^2], ``solver``, ``iters``,
        ``contact_max_correcting_vel`` [m/s]), ``ball`` (its surface, ``name``, ``mass_kg``, ``radius_m``,
        ``drop_height_m`` from its pose), ``floor`` (its surface), ``floor_has_body`` and ``target`` (the
        ``vrcal_target`` comment of a vrcal export, else {})

    Raises
    ------
    DataError
        XML with a DTD or entities, malformed XML, not an SDF world, no ball or floor, a bad number
    """
    import json
    import re

    from vrcal.engines.gazebo import SDF_DEFAULTS, TARGET_TAG

    root = _parse_xml(text, "SDF")
    world = root.find("world")
    if root.tag != "sdf" or world is None:
        raise DataError(f"not an SDF world: the root element is <{root.tag[:40]}> without a <world>")

    def number(el, path, key, lo=-math.inf, hi=math.inf):
        found = el.find(path) if el is not None else None
        if found is None or found.text is None:
            return SDF_DEFAULTS[key]
        return _xml_number(found.text, f"SDF <{path.rsplit('/', 1)[-1]}>", lo, hi)

    physics = world.find("physics")
    ode = physics.find("ode") if physics is not None else None
    gravity = world.findtext("gravity") or (physics.findtext("gravity") if physics is not None else None)
    try:
        g = tuple(float(x) for x in (gravity or SDF_DEFAULTS["gravity"]).split())
    except ValueError:
        raise DataError(f"SDF <gravity> '{gravity[:40]}' is not three numbers") from None
    if len(g) != 3 or not all(math.isfinite(x) for x in g) or not g[2] < 0:
        raise DataError(f"SDF <gravity> '{gravity[:40]}' must be three numbers pointing down (z < 0)")
    solver = ((ode.findtext("solver/type") if ode is not None else None) or SDF_DEFAULTS["solver"]).strip().lower()
    out = {"world": {"max_step_size": number(physics, "max_step_size", "max_step_size", 0, 1), "gravity": g,
                     "solver": solver, "iters": number(ode, "solver/iters", "iters", 0, 1e4),
                     "contact_max_correcting_vel": number(ode, "constraints/contact_max_correcting_vel",
                                                          "contact_max_correcting_vel", -1e-300)}}

    def collisions(model, shape):
        return [c for c in model.iter("collision") if c.find(f"geometry/{shape}") is not None]

    def surface(collision):
        s = collision.find("surface")
        return {"restitution_coefficient": number(s, "bounce/restitution_coefficient", "restitution_coefficient",
                                                  -1e-300, 1),
                "threshold": number(s, "bounce/threshold", "threshold", -1e-300),
                "kp": number(s, "contact/ode/kp", "kp", 0), "kd": number(s, "contact/ode/kd", "kd", -1e-300),
                "max_vel": number(s, "contact/ode/max_vel", "max_vel", -1e-300),
                "min_depth": number(s, "contact/ode/min_depth", "min_depth", -1e-300)}

    models = world.findall("model")
    balls = [m for m in models if collisions(m, "sphere") and (m.findtext("static") or "").strip() not in ("1", "true")]
    ball = next((m for m in balls if m.get("name") == "ball"), balls[0] if balls else None)
    floors = [m for m in models if m is not ball and collisions(m, "plane")]
    floor = next((m for m in floors if m.get("name") == "ground_plane"), floors[0] if floors else None)
    if ball is None or floor is None:
        raise DataError(f"the SDF world has no {'ball (a model with a <sphere> collision)' if ball is None else ''}"
                        f"{' and no ' if ball is None and floor is None else ''}"
                        f"{'floor (a model with a <plane> collision)' if floor is None else ''}")
    sphere = collisions(ball, "sphere")[0]
    radius_text = sphere.findtext("geometry/sphere/radius")
    if radius_text is None:
        raise DataError("SDF: the ball's <sphere> has no <radius>")
    radius = _xml_number(radius_text, "SDF <radius>", 0, 1e3)
    mass = ball.find("link/inertial/mass")
    mass_kg = _xml_number(mass.text, "SDF <mass>", 0, 1e6) if mass is not None and mass.text else 1.0
    pose = (ball.findtext("pose") or "0 0 0").split()
    try:
        z = float(pose[2])
    except (IndexError, ValueError):
        raise DataError(f"SDF: the ball's <pose> '{' '.join(pose)[:40]}' has no height") from None
    out["ball"] = dict(surface(sphere), name=ball.get("name") or "ball", mass_kg=mass_kg, radius_m=radius,
                       drop_height_m=z - radius)
    out["floor"] = surface(collisions(floor, "plane")[0])
    out["floor_has_body"] = (floor.findtext("static") or "").strip() not in ("1", "true")
    found = re.search(r"<!--\s*" + TARGET_TAG + r"\s+(\{.*?\})\s*-->", text, re.S)
    target = {}
    if found:
        try:
            target = json.loads(found.group(1))
        except (ValueError, RecursionError):
            raise DataError(f"SDF: the {TARGET_TAG} comment is not JSON") from None
        if not isinstance(target, dict):
            raise DataError(f"SDF: the {TARGET_TAG} comment is not a JSON object")
    out["target"] = target
    return out
