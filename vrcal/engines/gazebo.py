"""Gazebo (classic, ODE physics): an SDF world with the calibrated ``<bounce>``. Export only.

Gazebo classic hands contacts to ODE with ``bounce = min`` of the two surfaces'
``restitution_coefficient`` and ``bounce_vel = min`` of their ``threshold`` (SDF default
threshold 100000 m/s: nothing bounces until it is lowered). The exported world therefore
sets BOTH surfaces: the ball to epsilon and the floor to 1 (the min is then the ball's value;
several balls on one floor each keep their own epsilon), and both thresholds to 0.01 m/s.
The penetration push-out speed is capped (``max_vel``, ``contact_max_correcting_vel``) at 0.01 m/s:
ODE's contact leaves at the larger of the bounce speed and the push-out speed (measured through
libode, see tests/test_engines_ode_ctypes.py). No Gazebo runtime is used: the world is checked as
XML only; the ODE settings behind it are the ones verified in libode.
"""

from __future__ import annotations

import textwrap
import xml.etree.ElementTree as ET

from vrcal.engines.common import constant_engine_notes, constant_epsilon, step_note
from vrcal.engines.ode import BOUNCE_VEL_M_PER_S

SDF_VERSION = "1.7"

#: Cap on the speed at which ODE pushes a penetrating body out [m/s] (Gazebo's surface default).
MAX_CORRECTING_VEL_M_PER_S = 0.01


def _sub(parent, tag, text=None, **attrs):
    el = ET.SubElement(parent, tag, {k: str(v) for k, v in attrs.items()})
    if text is not None:
        el.text = text if isinstance(text, str) else f"{text:.10g}"
    return el


def _surface(parent, restitution):
    surface = _sub(parent, "surface")
    bounce = _sub(surface, "bounce")
    _sub(bounce, "restitution_coefficient", float(restitution))
    _sub(bounce, "threshold", BOUNCE_VEL_M_PER_S)
    contact = _sub(surface, "contact")
    ode = _sub(contact, "ode")
    # ODE leaves a contact at max(bounce speed, penetration push-out speed): keep the push-out
    # capped at Gazebo's default 0.01 m/s so the bounce, not the correction, sets the rebound
    _sub(ode, "max_vel", MAX_CORRECTING_VEL_M_PER_S)
    _sub(ode, "min_depth", 0.0)
    return surface


def _sphere_model(world, name, setup, x_m):
    R = setup.radius_m
    model = _sub(world, "model", name=name)
    _sub(model, "pose", f"{x_m:.6g} 0 {setup.drop_height_m + R:.10g} 0 0 0")
    link = _sub(model, "link", name="link")
    inertial = _sub(link, "inertial")
    _sub(inertial, "mass", setup.mass_kg)
    inertia = _sub(inertial, "inertia")
    i = 0.4 * setup.mass_kg * R * R
    for tag in ("ixx", "iyy", "izz"):
        _sub(inertia, tag, i)
    for tag in ("ixy", "ixz", "iyz"):
        _sub(inertia, tag, 0.0)
    collision = _sub(link, "collision", name="collision")
    _sub(_sub(_sub(collision, "geometry"), "sphere"), "radius", R)
    _surface(collision, constant_epsilon(setup))   # the ball/floor value: the floor is 1 and min() picks this
    visual = _sub(link, "visual", name="visual")
    _sub(_sub(_sub(visual, "geometry"), "sphere"), "radius", R)
    return model


def export_sdf(setup, pair=None, second=None, checked=None):
    """An SDF world (ODE physics, ``max_step_size`` = dt) with the ball and a ground plane.

    Parameters
    ----------
    setup : DropSetup
    pair : dict, optional
        pair values for ``--against`` (written as a comment: Gazebo's min rule cannot multiply)
    second : DropSetup, optional
        the second ball
    checked : str, optional
        the note of a step measured in libode (:func:`vrcal.engines.export.check_step`), for the header

    Returns
    -------
    str
        SDF XML text
    """
    sdf = ET.Element("sdf", version=SDF_VERSION)
    world = _sub(sdf, "world", name="vrcal_drop")
    physics = _sub(world, "physics", name="ode_physics", type="ode")
    _sub(physics, "max_step_size", setup.dt_s)
    _sub(physics, "real_time_factor", 1.0)
    _sub(physics, "real_time_update_rate", 0.0)
    ode = _sub(physics, "ode")
    solver = _sub(ode, "solver")
    _sub(solver, "type", "world")
    constraints = _sub(ode, "constraints")
    _sub(constraints, "cfm", 1e-10)
    _sub(constraints, "erp", 0.2)
    _sub(constraints, "contact_max_correcting_vel", MAX_CORRECTING_VEL_M_PER_S)
    _sub(constraints, "contact_surface_layer", 0.0)
    _sub(world, "gravity", f"0 0 {-setup.g_m_per_s2:g}")
    ground = _sub(world, "model", name="ground_plane")
    _sub(ground, "static", "true")
    link = _sub(ground, "link", name="link")
    collision = _sub(link, "collision", name="collision")
    plane = _sub(_sub(collision, "geometry"), "plane")
    _sub(plane, "normal", "0 0 1")
    _sub(plane, "size", "20 20")
    _surface(collision, 1.0)                # min rule: a compliant floor's factor is already in the ball's value
    _sphere_model(world, "ball", setup, 0.0)
    if second is not None:
        _sphere_model(world, "ball2", second, 3 * (setup.radius_m + second.radius_m))
    ET.indent(sdf, "  ")
    head = (
        f"<!-- vrcal export: {setup.ball}, target epsilon {setup.epsilon:.6f} "
        + ("on a rigid floor.\n" if setup.floor_epsilon == 1 else
           f"with its floor (floor epsilon {setup.floor_epsilon:.6f}, Eq. 6).\n")
        +
        "     Gazebo classic (ODE) uses bounce = min(ball, floor) and bounce_vel = min(thresholds):\n"
        "     the floor is set to 1 so the ball's coefficient is the one used; impacts slower than\n"
        f"     the threshold ({BOUNCE_VEL_M_PER_S} m/s) do not bounce (SDF's default 100000 m/s never bounces).\n"
        f"     max_step_size: {step_note(setup, 'gazebo')}"
        + ("".join(f".\n     {w}" if i == 0 else f"\n     {w}" for i, w in
                   enumerate(textwrap.wrap(checked.replace("--", ""), 92))) if checked else ".")
        + " -->\n"
    )
    notes = constant_engine_notes(setup, "Gazebo classic surfaces", option=lambda name: f"the {name} option")
    if notes:
        lines = [w for line in notes for w in textwrap.wrap(line, 92)]
        head += "<!-- from a discover result:\n" + "".join(f"     {w}\n" for w in lines[:-1]) + \
            f"     {lines[-1]} -->\n"
    if pair:
        head += (
            f"<!-- pair {pair['name']}: Eq. 6 gives {pair['epsilon']:.6f} = product of the two balls' values;\n"
            "     Gazebo's min rule gives min(ball, ball2) instead and cannot multiply: for the ball/ball\n"
            "     contact to use the pair value, give the balls' surfaces the pair value (then each\n"
            "     ball/floor contact also uses it) or set bounce in a contact plugin / custom ODE near callback. -->\n"
        )
    return '<?xml version="1.0"?>\n' + head + ET.tostring(sdf, encoding="unicode") + "\n"
