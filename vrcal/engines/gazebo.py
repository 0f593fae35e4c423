"""Gazebo (classic, ODE physics): an SDF world with the calibrated ``<bounce>``. Export only.

Gazebo classic hands contacts to ODE with ``bounce = min`` of the two surfaces'
``restitution_coefficient`` and ``bounce_vel = min`` of their ``threshold`` (SDF default
threshold 100000 m/s: nothing bounces until it is lowered). The exported world therefore
sets BOTH surfaces: the ball to epsilon and the floor to 1 (the min is then the ball's value;
several balls on one floor each keep their own epsilon), and both thresholds to 0.01 m/s.
The penetration push-out speed is capped (``max_vel``, ``contact_max_correcting_vel``) at 0.01 m/s:
ODE's contact leaves at the larger of the bounce speed and the push-out speed (measured through
libode, see tests/test_engines_ode_ctypes.py).

Gazebo classic also derives the contact's ERP and CFM from the two surfaces' ``kp`` and ``kd``
(``ODEPhysics::Collide``: kp in series, kd added, ``soft_erp = dt kp / (dt kp + kd)``, ``soft_cfm =
1 / (dt kp + kd)``), so a soft floor takes energy off the ball (measured in libode, lacrosse ball of
epsilon 0.72 dropped 1.2 m, floor kd 1: first rebound 0.625 m with floor kp 1e12 or 1e8, 0.305 m with
1e6, none with 1e5). The exported world writes both surfaces' ``kp``/``kd`` (SDF's defaults 1e12 and 1,
which leave epsilon alone), and its header says what a floor of the user's needs. No Gazebo runtime is
used: :func:`ode_params` combines an SDF world's surfaces as Gazebo classic does and libode runs them
(the export's step check and ``vrcal verify --engine gazebo --file WORLD.sdf``).
"""

from __future__ import annotations

import textwrap
import xml.etree.ElementTree as ET

from vrcal.engines.common import constant_engine_notes, constant_epsilon, step_note
from vrcal.engines.ode import BOUNCE_VEL_M_PER_S

SDF_VERSION = "1.7"

#: Cap on the speed at which ODE pushes a penetrating body out [m/s] (Gazebo's surface default).
MAX_CORRECTING_VEL_M_PER_S = 0.01

#: Contact stiffness [N/m] and damping [N s/m] written on both surfaces (SDF's defaults): in series
#: and added, 5e11 N/m and 2 N s/m give soft_erp 1 - 4e-9 and soft_cfm 2e-9 at 1 ms (rigid).
SURFACE_KP_N_PER_M = 1e12
SURFACE_KD_N_S_PER_M = 1.0

#: SDF 1.7's defaults of what :func:`ode_params` reads (sdformat's surface.sdf, physics.sdf, ode.sdf).
SDF_DEFAULTS = {"restitution_coefficient": 0.0, "threshold": 1e5, "kp": 1e12, "kd": 1.0, "max_vel": 0.01,
                "min_depth": 0.0, "max_step_size": 1e-3, "solver": "quick", "iters": 50,
                "contact_max_correcting_vel": 100.0, "contact_surface_layer": 1e-3, "gravity": "0 0 -9.8"}

#: How the exported world's comment with vrcal's numbers starts (read back by ``vrcal verify --file``).
TARGET_TAG = "vrcal_target"


def soft_erp_cfm(kp_n_per_m, kd_n_s_per_m, dt_s):
    """The ERP and CFM [m/(N s)] Gazebo classic gives a contact of stiffness ``kp`` [N/m] and damping ``kd``
    [N s/m] at step ``dt_s`` [s] (``ODEPhysics::Collide``; the ODE manual's spring-damper relation)."""
    denominator = dt_s * kp_n_per_m + kd_n_s_per_m
    return dt_s * kp_n_per_m / denominator, 1.0 / denominator


def combine_surfaces(ball, floor, floor_has_body=False):
    """One contact of Gazebo classic from the ball's and the floor's surfaces (dicts of SDF values).

    ``ODEPhysics::Collide``: bounce and its threshold the smaller of the two, kp in series, kd added.
    Gazebo's ODE takes the push-out cap ``max_vel`` and the ``min_depth`` of each body the contact
    touches (a static floor has none: the ball's alone), and the world's ``contact_max_correcting_vel``
    caps the former (deps/opende contact.cpp).

    Returns
    -------
    dict
        ``bounce``, ``bounce_vel`` [m/s], ``kp`` [N/m], ``kd`` [N s/m], ``max_vel`` [m/s], ``min_depth`` [m]
    """
    both = (ball, floor) if floor_has_body else (ball,)
    return {"bounce": min(ball["restitution_coefficient"], floor["restitution_coefficient"]),
            "bounce_vel": min(ball["threshold"], floor["threshold"]),
            "kp": 1.0 / (1.0 / ball["kp"] + 1.0 / floor["kp"]), "kd": ball["kd"] + floor["kd"],
            "max_vel": min(s["max_vel"] for s in both), "min_depth": min(s["min_depth"] for s in both)}


def ode_params(world, ball, floor, floor_has_body=False):
    """The ODE parameters (as :func:`vrcal.engines.ode.run_drop` runs them) of a Gazebo classic world.

    Parameters
    ----------
    world : dict
        ``max_step_size`` [s], ``gravity`` (3 numbers, m/s^2), ``solver`` ('world' or 'quick'), ``iters``,
        ``contact_max_correcting_vel`` [m/s]
    ball : dict
        the ball's surface (``restitution_coefficient``, ``threshold`` [m/s], ``kp`` [N/m], ``kd`` [N s/m],
        ``max_vel`` [m/s], ``min_depth`` [m]) and its ``name``, ``mass_kg``, ``radius_m``, ``drop_height_m``
    floor : dict
        the floor's surface
    floor_has_body : bool
        whether the floor is a dynamic body (a static model has none)

    Returns
    -------
    dict
        ``world``, ``contact``, ``ball`` and ``gazebo`` (kp and kd, from which a run at another step
        recomputes soft_erp and soft_cfm: :func:`at_step`)
    """
    from vrcal.engines.ode import _mode_value

    c = combine_surfaces(ball, floor, floor_has_body)
    dt = float(world["max_step_size"])
    mode = ["dContactBounce", "dContactSoftERP", "dContactSoftCFM", "dContactApprox1"]
    params = {
        "engine": "ode",
        "world": {"dt": dt, "gravity": [float(x) for x in world["gravity"]],
                  "step": "dWorldQuickStep" if world["solver"] == "quick" else "dWorldStep",
                  "quick_step_iterations": int(world["iters"]),
                  "contact_max_correcting_vel": min(float(world["contact_max_correcting_vel"]), c["max_vel"]),
                  "contact_surface_layer": c["min_depth"]},
        "contact": {"mode": mode, "mode_value": _mode_value(mode), "mu": 0.0, "bounce": c["bounce"],
                    "bounce_vel": c["bounce_vel"]},
        "ball": {k: ball[k] for k in ("name", "mass_kg", "radius_m", "drop_height_m")},
        "gazebo": {"kp": c["kp"], "kd": c["kd"]},
    }
    return at_step(params, dt)


def at_step(params, dt_s):
    """``params`` (:func:`ode_params`) run at step ``dt_s`` [s]: its soft_erp and soft_cfm from kp and kd."""
    params["world"]["dt"] = dt_s
    erp, cfm = soft_erp_cfm(params["gazebo"]["kp"], params["gazebo"]["kd"], dt_s)
    params["contact"].update(soft_erp=erp, soft_cfm=cfm)
    return params


def exported_surface(restitution):
    """The SDF values of a surface as :func:`export_sdf` writes it."""
    return {"restitution_coefficient": float(restitution), "threshold": BOUNCE_VEL_M_PER_S,
            "kp": SURFACE_KP_N_PER_M, "kd": SURFACE_KD_N_S_PER_M, "max_vel": MAX_CORRECTING_VEL_M_PER_S,
            "min_depth": 0.0}


def setup_params(setup):
    """The ODE parameters of the world :func:`export_sdf` writes for ``setup`` (what its step check runs)."""
    world = {"max_step_size": setup.dt_s, "gravity": (0.0, 0.0, -setup.g_m_per_s2), "solver": "world",
             "iters": SDF_DEFAULTS["iters"], "contact_max_correcting_vel": MAX_CORRECTING_VEL_M_PER_S}
    ball = dict(exported_surface(constant_epsilon(setup)), name=setup.ball, mass_kg=setup.mass_kg,
                radius_m=setup.radius_m, drop_height_m=setup.drop_height_m)
    return ode_params(world, ball, exported_surface(1.0))


def version():
    """The runtime of a Gazebo world here: libode with Gazebo classic's contact."""
    from vrcal.engines.ode import version as ode_version

    return f"{ode_version()} (Gazebo classic's contact from the SDF)"


def drop_test(params, setup, n_bounces, n_phases):
    """The drop test of a Gazebo world's ODE parameters (:func:`ode_params`) in libode: a DropRuns."""
    from vrcal.engines.ode import drop_test as ode_drop_test

    return ode_drop_test(params, setup, n_bounces, n_phases)


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
    # Gazebo puts the two surfaces' kp in series and adds their kd: a soft surface softens the contact
    _sub(ode, "kp", SURFACE_KP_N_PER_M)
    _sub(ode, "kd", SURFACE_KD_N_S_PER_M)
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


def export_sdf(setup, pair=None, second=None, checked=None, target=None):
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
    target : dict, optional
        the drop test's numbers (:func:`vrcal.engines.common.metadata`), written as a ``vrcal_target``
        comment that ``vrcal verify --engine gazebo --file`` reads back

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
        "     Gazebo classic (ODE) combines the ball's and the floor's surfaces: bounce = min(ball, floor),\n"
        "     bounce_vel = min(thresholds), kp in series, kd added (soft_erp = dt kp/(dt kp + kd), soft_cfm =\n"
        "     1/(dt kp + kd)). So YOUR FLOOR's <collision> needs the ground_plane's <surface> below too:\n"
        "     restitution_coefficient 1 (SDF's default 0: no bounce at all; the min is then the ball's),\n"
        f"     threshold {BOUNCE_VEL_M_PER_S} (default 100000 m/s: nothing bounces; slower impacts do not bounce),\n"
        "     kp 1e12 and kd 1 (SDF's defaults; a softer floor takes energy: measured in libode, a ball of\n"
        "     epsilon 0.72 from 1.2 m rebounds 0.625 m with floor kp 1e12 or 1e8, 0.305 m with 1e6, not\n"
        "     at all with 1e5); its max_vel and min_depth act only if the floor is a dynamic body.\n"
        f"     max_step_size: {step_note(setup, 'gazebo')}"
        + ("".join(f".\n     {w}" if i == 0 else f"\n     {w}" for i, w in
                   enumerate(textwrap.wrap(checked.replace("--", ""), 92))) if checked else ".")
        + " -->\n"
    )
    if target:
        import json

        # one key a line (the header stays within 100 columns); zeros left out (verify's defaults)
        kept = {k: v for k, v in target.items() if v != 0.0 or k in ("epsilon", "drop_height_m")}
        head += f"<!-- {TARGET_TAG} {json.dumps(kept, sort_keys=True, indent=1)} -->\n"
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
