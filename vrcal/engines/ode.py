"""ODE (Open Dynamics Engine): restitution through the contact's ``bounce``, export and drop test.

ODE takes restitution directly: ``dContact.surface.mode |= dContactBounce``, ``bounce`` = epsilon
in [0, 1], and ``bounce_vel`` [m/s], the smallest incoming normal speed that bounces (slower
impacts do not bounce at all). There is no mixing rule: the near callback fills every contact,
so it must set the pair's epsilon itself (Eq. 6 of [1]: the product of the two bodies' values
for bodies calibrated at the same K).

The runner drives the system's libode (Debian package libode8) through
:mod:`vrcal.engines.ode_ctypes`; vrcal compiles nothing.
"""

from __future__ import annotations

import ctypes
import math
from dataclasses import replace

import numpy as np

from vrcal.drop.effects import AIR_DENSITY_KG_PER_M3
from vrcal.engines import get_engine
from vrcal.engines import ode_ctypes as O
from vrcal.engines.common import (
    PairResult,
    drag_force_coefficient_kg_per_m,
    metadata,
    restitution_table,
    step_note,
    stepped_drop_test,
    stepped_pair_test,
)
from vrcal.errors import UsageError
from vrcal.textout import SCHEMA_VERSION

#: Smallest incoming speed that bounces [m/s].
BOUNCE_VEL_M_PER_S = 0.01

#: CFM of the ball's contacts (``dContactSoftCFM``): ODE's double-precision world default, set on the
#: contact so that a world CFM of the user's (1e-5 is the single-precision default) does not soften it.
CONTACT_SOFT_CFM = 1e-10

#: ERP of the ball's contacts (``dContactSoftERP``). ODE's contact leaves at the larger of the
#: bounce speed and the ERP push-out speed ``erp * depth / dt``: with the world default 0.2 a ball
#: 1 mm deep at dt = 1e-4 leaves at 2 m/s whatever its bounce (tests/engines/test_ode_ctypes.py).
#: 0 on the ball's contacts only keeps the bounce exact and leaves the world ERP, which holds the
#: user's joints together, alone.
CONTACT_SOFT_ERP = 0.0

#: The contact flags of the ball's contacts. ``dContactApprox1``: a friction axis's limit is mu times
#: the normal force (without it ODE takes mu as a force in newtons); the snippet's near callback adds
#: ``dContactFDir1`` along the slip, so that a slip in any direction meets mu N (Coulomb), not up to
#: sqrt(2) mu N on ODE's two default axes. With the exported mu = 0 neither changes a drop.
CONTACT_MODE = ("dContactBounce", "dContactSoftERP", "dContactSoftCFM", "dContactApprox1")


#: Units of the keys named as the engine's API names them (pasted into its calls as they are, so not
#: renamed with a unit): key path -> unit ('1' = dimensionless), written as the file's "units" map.
ENGINE_KEY_UNITS = {"world.dt": "s", "world.gravity": "m/s^2", "contact.bounce": "1 (epsilon)",
                  "contact.bounce_vel": "m/s", "contact.mu": "1", "contact.soft_erp": "1",
                  "contact.soft_cfm": "m/(N s) (CFM = 1/(dt kp + kd), ODE manual)"}


def export_params(setup, n_bounces=None, pair=None):
    """The ODE settings (JSON-ready dict) that reproduce ``setup``'s drop.

    Parameters
    ----------
    setup : DropSetup
    n_bounces : int, optional
        bounces the settings must survive (default ``setup.n_bounces``): ``bounce_vel`` must
        stay below the impact speed of the last one
    pair : dict, optional
        ``{"name": ..., "epsilon": ..., "ball2": ..., "epsilon_ball2": ...}`` for ``--against``

    Returns
    -------
    dict
        ``world``, ``contact``, ``ball``, ``target`` (what ``vrcal verify --file`` checks) and,
        from a discover result, ``drag`` (the per-step force) and ``restitution_law``
        (epsilon at each impact speed, set in the near callback)
    """
    n_bounces = setup.n_bounces if n_bounces is None else n_bounces
    v_last = float(np.min(setup.impact_speeds_m_per_s[:n_bounces]))
    if BOUNCE_VEL_M_PER_S >= v_last:
        raise UsageError(f"bounce_vel {BOUNCE_VEL_M_PER_S} m/s is not below the last impact speed {v_last:.3g} m/s")
    out = {
        "schema_version": SCHEMA_VERSION,
        "units": ENGINE_KEY_UNITS,
        "engine": "ode",
        "ball": {"name": setup.ball, "mass_kg": setup.mass_kg, "radius_m": setup.radius_m,
                 "drop_height_m": setup.drop_height_m},
        "target_epsilon": setup.epsilon,
        "target": metadata(setup),
        "world": {"dt": setup.dt_s, "gravity": [0.0, 0.0, -setup.g_m_per_s2], "step": "dWorldStep"},
        "contact": {
            "applies_to": "the ball's contacts only (other pairs keep your settings)",
            "mode": list(CONTACT_MODE),
            "mode_value": _mode_value(CONTACT_MODE),
            "mu": 0.0,
            "bounce": setup.epsilon,
            "bounce_vel": BOUNCE_VEL_M_PER_S,
            "soft_erp": CONTACT_SOFT_ERP,
            "soft_cfm": CONTACT_SOFT_CFM,
        },
        "notes": [
            step_note(setup, "ode"),
            f"impacts slower than bounce_vel = {BOUNCE_VEL_M_PER_S} m/s do not bounce "
            f"(the drop test's last impact is at {v_last:.3g} m/s)",
            "soft_erp = 0 on the ball's contacts only (dContactSoftERP; the world ERP stays yours, for your "
            "joints): a contact leaves at max(bounce speed, erp*depth/dt), so ERP 0.2 throws a deep ball out "
            "faster than epsilon allows",
            f"soft_cfm = {CONTACT_SOFT_CFM:g} on the ball's contacts (dContactSoftCFM): a soft contact eats "
            "energy (CFM 1e-5 lowers epsilon by about 1.5 %)",
            "friction is not set by vrcal: mu = 0 makes the ball's contacts frictionless (it slides, never "
            "rolls); a vertical drop ignores it: set surface.mu to your surface's (dInfinity: no slip); with "
            "dContactApprox1 it is a coefficient (limit mu N), and the snippet points fdir1 along the slip, so "
            "a slip in any direction meets mu N (ODE's own two axes give up to 1.41 mu N on a diagonal one)",
        ],
    }
    out.update(effect_params(setup))
    if "drag" in out:
        out["notes"].append("ODE has no air drag: add the force of 'drag' to the ball before every dWorldStep")
    if "restitution_law" in out:
        out["notes"].append("epsilon depends on the impact speed: the near callback sets bounce from the "
                            "ball's normal speed (formula of 'restitution_law', or interpolate its table)")
    if pair:
        out["pairs"] = dict(pair["pairs"])      # every pair's epsilon, Eq. 6 (export.pair_epsilons)
        # the two balls' own contact, whole: what a near callback sets on a contact of ball and ball2
        out["contact_pair"] = dict(out["contact"], applies_to=f"the contacts of the two balls, {pair['name']} "
                                   "(Eq. 6: bounce is the product of their epsilons)", bounce=pair["epsilon"])
        out["notes"].append(
            f"ODE has no mixing rule: the snippet's near callback sets each contact's bounce to its pair's value "
            f"from 'pairs' (ball_geom: your {setup.ball}, ball2_geom: your {pair['ball2']}; both balls: Eq. 6, "
            "the product of the two bodies' epsilons); 'contact_pair' is the two balls' contact whole (the "
            "ball's 'contact' with the pair's bounce)"
        )
    return out


def _mode_value(flags):
    """The ``surface.mode`` integer of dContact... flag names."""
    value = 0
    for flag in flags:
        value |= getattr(O, flag)
    return value


def effect_params(setup):
    """``drag`` and ``restitution_law`` entries of an ODE or Bullet export (empty without effects)."""
    out = {}
    if setup.drag_coefficient:
        out["drag"] = {"drag_coefficient": setup.drag_coefficient,
                       "force_coefficient_kg_per_m": drag_force_coefficient_kg_per_m(setup),
                       "air_density_kg_per_m3": AIR_DENSITY_KG_PER_M3,
                       "law": "F = -c |v| v, c = 1/2 rho C_d pi R^2, every step"}
    if setup.restitution_exponent:
        speeds, eps = restitution_table(setup)
        out["restitution_law"] = {
            "epsilon_ref": setup.epsilon, "reference_speed_m_per_s": setup.impact_speed_m_per_s,
            "exponent": setup.restitution_exponent,
            "law": "eps(v) = 1 - (1 - epsilon_ref) (v / reference_speed)^exponent",
            "table": {"speed_m_per_s": [float(x) for x in speeds], "epsilon": [float(x) for x in eps]},
        }
    return out


def restitution_at(params, speed_m_per_s):
    """epsilon of an exported parameter set at an impact speed [m/s] (its law, or its constant)."""
    law = params.get("restitution_law")
    if not law:
        return None
    v = max(abs(float(speed_m_per_s)), 1e-9)
    eps = 1.0 - (1.0 - float(law["epsilon_ref"])) * (v / float(law["reference_speed_m_per_s"])) ** float(
        law["exponent"])
    return min(max(eps, 0.0), 1.0)


def version():
    """Name of the loaded C library and its precision, e.g. ``libode.so.8, double precision``."""
    import os

    lib = O.load_ode()
    return f"{os.path.basename(str(lib._name))}, double precision"


def run_drop(params, drop_height_m, duration_s):
    """Drop the ball of an exported ODE parameter set once; returns (z_m, v_m_per_s) per step."""
    lib = O.load_ode()
    world_p, contact_p, ball = params["world"], params["contact"], params["ball"]
    dt = float(world_p["dt"])
    world = _new_world(lib, world_p)
    space = lib.dHashSpaceCreate(None)
    group = lib.dJointGroupCreate(0)
    try:
        body = lib.dBodyCreate(world)
        R = float(ball["radius_m"])
        mass = O.sphere_mass(float(ball["mass_kg"]), R)
        lib.dBodySetMass(body, ctypes.byref(mass))
        sphere = lib.dCreateSphere(space, R)
        lib.dGeomSetBody(sphere, body)
        lib.dCreatePlane(space, 0.0, 0.0, 1.0, 0.0)
        lib.dBodySetPosition(body, 0.0, 0.0, drop_height_m + R)
        surf = _surface(contact_p)
        step = getattr(lib, world_p.get("step", "dWorldStep"))
        n = int(math.ceil(duration_s / dt))
        z = np.empty(n + 1)
        v = np.empty(n + 1)
        z[0], v[0] = drop_height_m, 0.0

        c_drag = float(params["drag"]["force_coefficient_kg_per_m"]) if params.get("drag") else 0.0
        law = params.get("restitution_law")

        def near(o1, o2):
            if law:                      # the near callback of the snippet: bounce from the normal speed
                surf.bounce = restitution_at(params, lib.dBodyGetLinearVel(body)[2])
            O.add_contacts(lib, world, group, o1, o2, surf, 1)

        for i in range(1, n + 1):
            if c_drag:                   # dBodyAddForce(ball, -c |v| vx, -c |v| vy, -c |v| vz)
                vel = lib.dBodyGetLinearVel(body)
                speed = math.sqrt(vel[0] ** 2 + vel[1] ** 2 + vel[2] ** 2)
                lib.dBodyAddForce(body, -c_drag * speed * vel[0], -c_drag * speed * vel[1], -c_drag * speed * vel[2])
            O.collide_pairs(lib, space, near)
            step(world, dt)
            lib.dJointGroupEmpty(group)
            z[i] = lib.dBodyGetPosition(body)[2] - R
            v[i] = lib.dBodyGetLinearVel(body)[2]
        return z, v, dt, -float(world_p["gravity"][2])
    finally:
        lib.dJointGroupDestroy(group)
        lib.dSpaceDestroy(space)
        lib.dWorldDestroy(world)


def drop_test(params, setup, n_bounces, n_phases):
    """Run the exported settings in libode and measure them against vrcal's model: a DropRuns."""
    return stepped_drop_test(run_drop, params, replace(setup, n_bounces=int(n_bounces)), n_bounces, n_phases,
                             get_engine("ode").max_steps)


def _new_world(lib, world_p):
    """A dWorld with the exported world settings (gravity, and any ERP/CFM/correcting velocity/layer/iterations)."""
    world = lib.dWorldCreate()
    lib.dWorldSetGravity(world, *[float(x) for x in world_p["gravity"]])
    if "erp" in world_p:             # files of an earlier vrcal set the world's ERP and CFM
        lib.dWorldSetERP(world, float(world_p["erp"]))
    if "cfm" in world_p:
        lib.dWorldSetCFM(world, float(world_p["cfm"]))
    if "contact_max_correcting_vel" in world_p:     # a Gazebo world's (vrcal.engines.gazebo.ode_params)
        lib.dWorldSetContactMaxCorrectingVel(world, float(world_p["contact_max_correcting_vel"]))
    if "contact_surface_layer" in world_p:
        lib.dWorldSetContactSurfaceLayer(world, float(world_p["contact_surface_layer"]))
    if "quick_step_iterations" in world_p:
        lib.dWorldSetQuickStepNumIterations(world, int(world_p["quick_step_iterations"]))
    return world


def _surface(contact_p):
    """The dSurfaceParameters of an exported contact block (mode, mu, bounce, bounce_vel, soft_erp/cfm)."""
    soft = {k: float(contact_p[k]) for k in ("soft_erp", "soft_cfm") if k in contact_p}
    return O.surface(_mode_value(contact_p["mode"]), float(contact_p["mu"]), bounce=float(contact_p["bounce"]),
                     bounce_vel=float(contact_p["bounce_vel"]), **soft)


def pair_params(params):
    """The file's ball/ball2 contact (``contact_pair``, what the near callback sets on the two balls' contacts)
    as a parameter set with the world, for :func:`pair_test`; None for a file without it (an older export)."""
    if not isinstance(params.get("contact_pair"), dict) or not isinstance(params.get("ball2"), dict):
        return None
    return {"world": params["world"], "contact": params["contact_pair"]}


def run_pair(params, pair, gap_m, n_steps):
    """Run the two balls of the pair test in libode (gravity off, no floor) with the pair's contact.

    ``params`` is :func:`pair_params`'s; returns the centres' x [m] and x velocities [m/s] of every step
    (rows of a (4, n_steps + 1) array: ball x, ball2 x, ball v, ball2 v).
    """
    lib = O.load_ode()
    world_p = dict(params["world"], gravity=[0.0, 0.0, 0.0])
    dt = float(world_p["dt"])
    world = _new_world(lib, world_p)
    space = lib.dHashSpaceCreate(None)
    group = lib.dJointGroupCreate(0)
    try:
        bodies = []
        for R, m, x, v in ((pair.radius_m, pair.mass_kg, 0.0, pair.velocities_m_per_s[0]),
                           (pair.radius2_m, pair.mass2_kg, pair.contact_distance_m + gap_m,
                            pair.velocities_m_per_s[1])):
            body = lib.dBodyCreate(world)
            mass = O.sphere_mass(float(m), float(R))
            lib.dBodySetMass(body, ctypes.byref(mass))
            sphere = lib.dCreateSphere(space, float(R))
            lib.dGeomSetBody(sphere, body)
            lib.dBodySetPosition(body, x, 0.0, 1.0)
            lib.dBodySetLinearVel(body, v, 0.0, 0.0)
            bodies.append(body)
        surf = _surface(params["contact"])
        step = getattr(lib, world_p.get("step", "dWorldStep"))
        out = np.empty((4, n_steps + 1))

        def sample(i):
            out[:, i] = (lib.dBodyGetPosition(bodies[0])[0], lib.dBodyGetPosition(bodies[1])[0],
                         lib.dBodyGetLinearVel(bodies[0])[0], lib.dBodyGetLinearVel(bodies[1])[0])

        sample(0)
        for i in range(1, n_steps + 1):
            O.collide_pairs(lib, space, lambda o1, o2: O.add_contacts(lib, world, group, o1, o2, surf))
            step(world, dt)
            lib.dJointGroupEmpty(group)
            sample(i)
        return out
    finally:
        lib.dJointGroupDestroy(group)
        lib.dSpaceDestroy(space)
        lib.dWorldDestroy(world)


def pair_test(params, pair, n_phases):
    """The two-ball collision test of an exported file's pair in libode: a PairResult."""
    runnable = pair_params(params)
    pair = replace(pair, dt_s=float(params["world"]["dt"]), contact_steps=2)
    return PairResult("ode", pair, stepped_pair_test(run_pair, runnable, pair, n_phases))


C_SNIPPET = """\
/* near callback: the ball's contacts bounce with the calibrated epsilon; other pairs keep yours */
static void near_callback(void *data, dGeomID o1, dGeomID o2)
{{
    dContact c[4];
    int i, n;
{choose}    n = dCollide(o1, o2, 4, &c[0].geom, sizeof(dContact));
    for (i = 0; i < n; i++) {{
        /* body 1's velocity relative to body 2's at the contact point: vn normal, u the slip */
        dVector3 v1 = {{0, 0, 0}}, v2 = {{0, 0, 0}};
        const dReal *q = c[i].geom.pos, *nrm = c[i].geom.normal;
        dReal u[3], vn, slip;
        int k;
        if (dGeomGetBody(o1)) dBodyGetPointVel(dGeomGetBody(o1), q[0], q[1], q[2], v1);
        if (dGeomGetBody(o2)) dBodyGetPointVel(dGeomGetBody(o2), q[0], q[1], q[2], v2);
        for (k = 0; k < 3; k++) u[k] = v1[k] - v2[k];
        vn = u[0]*nrm[0] + u[1]*nrm[1] + u[2]*nrm[2];
        for (k = 0; k < 3; k++) u[k] -= vn*nrm[k];
        slip = sqrt(u[0]*u[0] + u[1]*u[1] + u[2]*u[2]);
        c[i].surface.mode = {mode};
        c[i].surface.mu = {mu};             /* frictionless: your mu here (a drop ignores it) */
        if (slip > 1e-9) {{   /* friction's first axis along the slip: mu N against it (Coulomb);
               ODE's own two axes cap each at mu N: up to 1.41 mu N on a diagonal slip */
            c[i].surface.mode |= dContactFDir1;
            for (k = 0; k < 3; k++) c[i].fdir1[k] = u[k] / slip;
        }}
        c[i].surface.bounce = {bounce}
{law}        c[i].surface.bounce_vel = {bounce_vel};    /* m/s: slower impacts do not bounce */
        c[i].surface.soft_erp = {soft_erp};       /* this contact only: no ERP push-out */
        c[i].surface.soft_cfm = {soft_cfm};     /* this contact only: rigid */
        dJointAttach(dJointCreateContact(world, contact_group, &c[i]),
                     dGeomGetBody(o1), dGeomGetBody(o2));
    }}
}}
/* world: gravity (the world's ERP and CFM stay yours: the ball's contacts set their own) */
dWorldSetGravity(world, {gx}, {gy}, {gz});
/* each step: */
{drag}dSpaceCollide(space, 0, near_callback);
dWorldStep(world, {dt});
dJointGroupEmpty(contact_group);
"""

#: The start of the near callback for one ball: its epsilon on every contact of ``ball_geom``.
ONE_BALL_C = """\
    if (o1 != ball_geom && o2 != ball_geom) {{   /* ball_geom: your ball's sphere */
        your_near_callback(data, o1, o2);       /* every other pair: your own contacts */
        return;
    }}
"""

#: The start of the near callback for ``--against``: each pair's own epsilon (Eq. 6 for the two balls).
PAIR_C = """\
    int a = (o1 == ball_geom || o2 == ball_geom);     /* ball_geom: your {ball}'s sphere */
    int b = (o1 == ball2_geom || o2 == ball2_geom);   /* ball2_geom: your {ball2}'s sphere */
    dReal bounce;
    if (!a && !b) {{
        your_near_callback(data, o1, o2);       /* every other pair: your own contacts */
        return;
    }}
    bounce = a && b ? {pair}   /* {ball}/{ball2}: Eq. 6, the product */
           : a ? {eps_a}         /* {ball} on the floor (and on anything else) */
           : {eps_b};            /* {ball2} on the floor (and on anything else) */
"""

LAW_C = """\
        {guard}{{  /* epsilon at this impact: eps(v) = 1 - (1 - eps_1)(v / v_1)^p, clamped to [0, 1],
               v = |vn|, the normal speed of one body relative to the other at the contact point */
            dReal e = 1 - (1 - {eps_ref})*pow(fabs(vn) / {v_ref}, {p});
            c[i].surface.bounce = e < 0 ? 0 : (e > 1 ? 1 : e);
        }}
"""

DRAG_C = """\
{{  /* air drag: F = -c |v| v, c = 1/2 rho C_d pi R^2 = {c} kg/m */
    const dReal *v = dBodyGetLinearVel(ball);
    dReal s = sqrt(v[0]*v[0] + v[1]*v[1] + v[2]*v[2]);
    dBodyAddForce(ball, -{c}*s*v[0], -{c}*s*v[1], -{c}*s*v[2]);
}}
"""


def c_snippet(params):
    """The near callback, the per-step drag force and the world settings in C for an exported parameter set.

    With ``pairs`` (``--against``) the callback also takes the second ball's contacts
    (``ball2_geom``) and sets each contact's bounce to its pair's value: ball/ball2 the product of
    Eq. 6, each ball against anything else its own epsilon; a speed law applies to the first ball's
    own contacts only.
    """
    law, drag, pairs = params.get("restitution_law"), params.get("drag"), params.get("pairs")
    guard = "if (a && !b)   /* the law: the first ball's own contacts */\n        " if pairs else ""
    law_c = LAW_C.format(eps_ref=f"{law['epsilon_ref']:.6f}", v_ref=f"{law['reference_speed_m_per_s']:.6g}",
                         p=f"{law['exponent']:.6g}", guard=guard) if law else ""
    drag_c = DRAG_C.format(c=f"{drag['force_coefficient_kg_per_m']:.6g}") if drag else ""
    contact, world = params["contact"], params["world"]
    ball = params["ball"]["name"]
    if pairs:
        ball2 = params["pair"]["ball2"]
        choose = PAIR_C.format(ball=ball, ball2=ball2, pair=f"{pairs[f'{ball}/{ball2}']:.6f}",
                               eps_a=f"{pairs[f'{ball}/floor']:.6f}", eps_b=f"{pairs[f'{ball2}/floor']:.6f}")
        bounce = "bounce;      /* this pair's epsilon (above) */"
    else:
        choose = ONE_BALL_C.format()
        bounce = f"{contact['bounce']:.6f};    /* epsilon ({ball}) */"
    gx, gy, gz = (float(x) for x in world["gravity"])
    return C_SNIPPET.format(choose=choose, mode=" | ".join(contact["mode"]), mu=contact["mu"], bounce=bounce,
                            law=law_c, bounce_vel=contact["bounce_vel"],
                            soft_erp=contact.get("soft_erp", CONTACT_SOFT_ERP),
                            soft_cfm=contact.get("soft_cfm", CONTACT_SOFT_CFM), gx=repr(gx), gy=repr(gy), gz=repr(gz),
                            dt=world["dt"], drag=drag_c)
