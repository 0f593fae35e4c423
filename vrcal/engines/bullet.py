"""PyBullet: restitution per body, multiplied over the pair; export and drop test.

Bullet combines the two bodies' ``restitution`` by their product and never bounces below
``restitutionVelocityThreshold`` (default 0.2 m/s). Its defaults are wrong for a drop test:
contacts are created before touch (``contactProcessingThreshold``) and the solver subtracts
the gap over dt, ERP adds energy on the way out, and bodies carry hidden linear/angular
damping. The exported settings switch all of that off; then the ball's restitution is its
epsilon and the floor's is 1 (rigid floor, Eq. 10 of [1]); a pair of balls then gets
``eps_A * eps_B`` by Bullet's own product rule -- exactly Eq. (6) of [1] for bodies
calibrated at the same K.
"""

from __future__ import annotations

import math

import numpy as np

from vrcal.engines.common import stepped_drop_test
from vrcal.errors import EngineUnavailable, UsageError

#: Default Bullet time step [s].
DEFAULT_DT_S = 2e-4

#: Bounce threshold [m/s] (Bullet's default 0.2).
RESTITUTION_VELOCITY_THRESHOLD = 0.01


def export_params(setup, n_bounces=3, pair=None):
    """``changeDynamics`` / ``setPhysicsEngineParameter`` keyword arguments (JSON-ready dict)."""
    v_last = setup.impact_speed_m_per_s * setup.epsilon ** (n_bounces - 1)
    if RESTITUTION_VELOCITY_THRESHOLD >= v_last:
        raise UsageError(f"restitution threshold {RESTITUTION_VELOCITY_THRESHOLD} m/s is not below the last "
                         f"impact speed {v_last:.3g} m/s")
    ball_eps = setup.ball_epsilon if setup.ball_epsilon is not None else setup.epsilon
    out = {
        "engine": "bullet",
        "ball": {"name": setup.ball, "mass_kg": setup.mass_kg, "radius_m": setup.radius_m,
                 "drop_height_m": setup.drop_height_m},
        "target_epsilon": setup.epsilon,
        "changeDynamics": {
            "ball": {"restitution": ball_eps, "contactProcessingThreshold": 0.0,
                     "linearDamping": 0.0, "angularDamping": 0.0, "lateralFriction": 0.0},
            "floor": {"restitution": setup.floor_epsilon, "contactProcessingThreshold": 0.0},
        },
        "setPhysicsEngineParameter": {
            "fixedTimeStep": setup.dt_s, "numSubSteps": 0, "erp": 0.0, "contactERP": 0.0,
            "frictionERP": 0.0, "restitutionVelocityThreshold": RESTITUTION_VELOCITY_THRESHOLD,
        },
        "setGravity": [0.0, 0.0, -setup.g_m_per_s2],
        "notes": [
            "Bullet multiplies the two bodies' restitution: ball x floor = "
            f"{ball_eps:.6g} x {setup.floor_epsilon:.6g} = {setup.epsilon:.6g}",
            f"no bounce below restitutionVelocityThreshold (Bullet's default 0.2 m/s; set here to "
            f"{RESTITUTION_VELOCITY_THRESHOLD} m/s; last verified impact {v_last:.3g} m/s)",
            "contactProcessingThreshold=0, erp=contactERP=0 and zero damping: Bullet's defaults give "
            "step-phase dependent epsilon (0.16..0.87 for a target of 0.85)",
        ],
    }
    if pair:
        out["changeDynamics"]["ball2"] = {"restitution": pair["epsilon_ball2"], "contactProcessingThreshold": 0.0,
                                          "linearDamping": 0.0, "angularDamping": 0.0, "lateralFriction": 0.0}
        out["pairs"] = {
            f"{setup.ball}/floor": ball_eps * setup.floor_epsilon,
            f"{pair['ball2']}/floor": pair["epsilon_ball2"] * setup.floor_epsilon,
            f"{setup.ball}/{pair['ball2']}": pair["epsilon"],
        }
        out["notes"].append(
            "pair: Bullet's product rule gives ball x ball2 = "
            f"{ball_eps:.6g} x {pair['epsilon_ball2']:.6g} = {ball_eps * pair['epsilon_ball2']:.6g}, "
            f"Eq. 6 gives {pair['epsilon']:.6g}: nothing else to set"
        )
    return out


def _pybullet():
    try:
        pybullet = _quiet_import("pybullet")
    except ImportError:
        raise EngineUnavailable("PyBullet is not installed: pip install pybullet (or pip install 'vrcal[engines]')") \
            from None
    return pybullet


def _quiet_import(name):
    """Import a module whose C code prints a banner at import (pybullet's "build time" line, on stderr)."""
    import importlib
    import os
    import sys

    if name in sys.modules:
        return sys.modules[name]
    sys.stdout.flush()
    sys.stderr.flush()
    saved = {fd: os.dup(fd) for fd in (1, 2)}
    try:
        with open(os.devnull, "w") as null:
            for fd in saved:
                os.dup2(null.fileno(), fd)
            return importlib.import_module(name)
    finally:
        for fd, copy in saved.items():
            os.dup2(copy, fd)
            os.close(copy)


def version():
    p = _pybullet()
    return f"pybullet API {p.getAPIVersion()}"


def run_drop(params, drop_height_m, duration_s):
    """Drop the ball of an exported parameter set once in a DIRECT PyBullet client."""
    p = _pybullet()
    cid = p.connect(p.DIRECT)
    try:
        ball = params["ball"]
        R = float(ball["radius_m"])
        eng = dict(params["setPhysicsEngineParameter"])
        dt = float(eng["fixedTimeStep"])
        p.setPhysicsEngineParameter(physicsClientId=cid, **eng)
        p.setGravity(*params["setGravity"], physicsClientId=cid)
        plane = p.createCollisionShape(p.GEOM_PLANE, physicsClientId=cid)
        floor = p.createMultiBody(0, plane, physicsClientId=cid)
        sphere = p.createCollisionShape(p.GEOM_SPHERE, radius=R, physicsClientId=cid)
        body = p.createMultiBody(float(ball["mass_kg"]), sphere, basePosition=[0, 0, drop_height_m + R],
                                 physicsClientId=cid)
        p.changeDynamics(body, -1, physicsClientId=cid, **params["changeDynamics"]["ball"])
        p.changeDynamics(floor, -1, physicsClientId=cid, **params["changeDynamics"]["floor"])
        g = -float(params["setGravity"][2])
        n = int(math.ceil(duration_s / dt))
        z = np.empty(n + 1)
        v = np.empty(n + 1)
        z[0], v[0] = drop_height_m, 0.0
        for i in range(1, n + 1):
            p.stepSimulation(physicsClientId=cid)
            z[i] = p.getBasePositionAndOrientation(body, physicsClientId=cid)[0][2] - R
            v[i] = p.getBaseVelocity(body, physicsClientId=cid)[0][2]
        return z, v, dt, g
    finally:
        p.disconnect(cid)


def drop_test(params, setup, n_bounces, n_phases):
    """Run the exported settings in PyBullet; apex and velocity ratios, shape (n_phases, n_bounces)."""
    return stepped_drop_test(run_drop, params, setup, n_bounces, n_phases)


PY_SNIPPET = """\
import pybullet as p
p.connect(p.DIRECT)
p.setPhysicsEngineParameter(**{engine})
p.setGravity(0, 0, {gz})
# ball = your sphere body, floor = your plane body
p.changeDynamics(ball, -1, **{ball})
p.changeDynamics(floor, -1, **{floor})
"""


def py_snippet(params):
    """The Python lines that apply an exported parameter set to a user's bodies."""
    return PY_SNIPPET.format(engine=params["setPhysicsEngineParameter"], gz=params["setGravity"][2],
                             ball=params["changeDynamics"]["ball"], floor=params["changeDynamics"]["floor"])
