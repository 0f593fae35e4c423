"""PyBullet: restitution per body, multiplied over the pair; export and drop test.

Bullet combines the two bodies' ``restitution`` by their product and never bounces below
``restitutionVelocityThreshold`` (default 0.2 m/s). Its defaults are wrong for a drop test:
contacts are created before touch (``contactProcessingThreshold``) and the solver subtracts
the gap over dt, ERP adds energy on the way out, the contact slop (``contactSlop``, PyBullet's
1e-5 m) counts a ball less than that deep as a gap and takes the gap over dt off its rebound,
and bodies carry hidden linear/angular damping. The exported settings switch all of that off,
on the ball's contacts where Bullet allows it (its ``contactStiffness``/``contactDamping`` give them
ERP 0; only the slop, the restitution threshold and the step are world-wide);
then the ball's restitution is its
epsilon and the floor's is 1 (rigid floor, Eq. 10 of [1]); a pair of balls then gets
``eps_A * eps_B`` by Bullet's own product rule -- exactly Eq. (6) of [1] for bodies
calibrated at the same K.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from vrcal.engines import get_engine
from vrcal.engines.common import PairResult, metadata, step_note, stepped_drop_test, stepped_pair_test
from vrcal.engines.ode import effect_params
from vrcal.errors import EngineUnavailable, UsageError, install_hint
from vrcal.textout import SCHEMA_VERSION

#: Bounce threshold [m/s] (Bullet's default 0.2): a contact whose normal speed is below it gets no
#: restitution (``restitutionCurve`` in Bullet's constraint solvers).
RESTITUTION_VELOCITY_THRESHOLD = 0.01

#: Contact slop [m] (``setPhysicsEngineParameter(contactSlop=...)``, Bullet's ``m_linearSlop``).
#: PyBullet sets 1e-5 m (PhysicsServerCommandProcessor); Bullet's multibody solver adds it to the
#: contact's distance, so a ball found less than the slop deep counts as still apart and leaves
#: slower by (slop - depth) / dt: up to ``slop / (v dt)`` off epsilon, which grows as the step
#: shrinks (measured: a 0.63 m/s impact lost 0.11 of epsilon 0.45 at 0.1 ms, a table-tennis ball
#: 0.04 at 0.1 ms; benchmarks/bench_bullet_slop.py). Bullet's own note when it exposed the
#: parameter: "Set it to zero, to avoid issues with restitution" (bullet3 pull request #1701).
CONTACT_SLOP_M = 0.0
PYBULLET_CONTACT_SLOP_M = 1e-5


#: The ball's own contact stiffness [N/m] and damping [N s/m] (``changeDynamics(contactStiffness=...,
#: contactDamping=...)``). A body with them makes Bullet compute each of its contacts' ERP and CFM from
#: them instead of the world's ``contactERP`` (btManifoldResult: stiffness in series, damping added over
#: the pair; then ERP = dt k / (dt k + d), CFM = 1 / (dt k + d)): stiffness 0 gives ERP 0, so the ball's
#: contacts leave at the bounce speed, not pushed out faster, and damping 1e12 a CFM of 1e-12 (rigid; 1e9
#: already softens it enough to move a basketball's epsilon error at 1/240 s by 1e-6, 1e6 by 2e-4). Other
#: bodies keep the world's contactERP: measured in PyBullet 3.2.7, a 1 kg box dropped 0.3 m onto the floor
#: rests 0.00 mm in it (PyBullet's defaults: 0.01 mm), where an earlier vrcal's world-wide ``contactERP=0``
#: left it 7.78 mm in the floor for good; the ball's drop test gives the same numbers either way (to 1e-9:
#: lacrosse ball at 1/240 s worst error 0.0134, basketball 0.0100007).
CONTACT_STIFFNESS_N_PER_M = 0.0
CONTACT_DAMPING_N_S_PER_M = 1e12


#: Units of the keys named as the engine's API names them (pasted into its calls as they are, so not
#: renamed with a unit): key path -> unit ('1' = dimensionless), written as the file's "units" map.
ENGINE_KEY_UNITS = {"changeDynamics.*.restitution": "1", "changeDynamics.*.contactProcessingThreshold": "m",
                  "changeDynamics.*.contactStiffness": "N/m", "changeDynamics.*.contactDamping": "N s/m",
                  "changeDynamics.*.linearDamping": "1", "changeDynamics.*.angularDamping": "1",
                  "changeDynamics.*.lateralFriction": "1", "setPhysicsEngineParameter.fixedTimeStep": "s",
                  "setPhysicsEngineParameter.restitutionVelocityThreshold": "m/s",
                  "setPhysicsEngineParameter.contactSlop": "m", "setGravity": "m/s^2"}

#: The ball's ``changeDynamics`` besides its restitution (also the second ball's of ``--against``).
BALL_DYNAMICS = {"contactProcessingThreshold": 0.0, "contactStiffness": CONTACT_STIFFNESS_N_PER_M,
                 "contactDamping": CONTACT_DAMPING_N_S_PER_M, "linearDamping": 0.0, "angularDamping": 0.0,
                 "lateralFriction": 0.0}


def export_params(setup, n_bounces=None, pair=None):
    """``changeDynamics`` / ``setPhysicsEngineParameter`` keyword arguments (JSON-ready dict), and
    from a discover result ``drag`` and ``restitution_law`` (applied by the snippet's ``vrcal_step``)."""
    n_bounces = setup.n_bounces if n_bounces is None else n_bounces
    v_last = float(np.min(setup.impact_speeds_m_per_s[:n_bounces]))
    if RESTITUTION_VELOCITY_THRESHOLD >= v_last:
        raise UsageError(f"restitution threshold {RESTITUTION_VELOCITY_THRESHOLD} m/s is not below the last "
                         f"impact speed {v_last:.3g} m/s")
    ball_eps = setup.ball_epsilon if setup.ball_epsilon is not None else setup.epsilon
    out = {
        "schema_version": SCHEMA_VERSION,
        "units": ENGINE_KEY_UNITS,
        "engine": "bullet",
        "ball": {"name": setup.ball, "mass_kg": setup.mass_kg, "radius_m": setup.radius_m,
                 "drop_height_m": setup.drop_height_m},
        "target_epsilon": setup.epsilon,
        "target": metadata(setup),
        "changeDynamics": {
            "ball": {"restitution": ball_eps, **BALL_DYNAMICS},
            "floor": {"restitution": setup.floor_epsilon},
        },
        "setPhysicsEngineParameter": {
            "fixedTimeStep": setup.dt_s * max(setup.substeps, 1), "numSubSteps": int(setup.substeps),
            "restitutionVelocityThreshold": RESTITUTION_VELOCITY_THRESHOLD, "contactSlop": CONTACT_SLOP_M,
        },
        "setGravity": [0.0, 0.0, -setup.g_m_per_s2],
        "notes": [
            step_note(setup, "bullet"),
            *([f"numSubSteps {setup.substeps:d}: each stepSimulation() advances fixedTimeStep "
               f"{setup.dt_s * setup.substeps:g} s in {setup.substeps:d} steps of {setup.dt_s:g} s, the step it was "
               f"checked at (the same positions as fixedTimeStep {setup.dt_s:g} s without substeps, measured); "
               "a fixedTimeStep pasted without its numSubSteps runs the check's step, another than yours"]
              if setup.substeps else []),
            "Bullet multiplies the two bodies' restitution: ball x floor = "
            f"{ball_eps:.6g} x {setup.floor_epsilon:.6g} = {setup.epsilon:.6g}",
            f"no bounce below restitutionVelocityThreshold (Bullet's default 0.2 m/s; set here to "
            f"{RESTITUTION_VELOCITY_THRESHOLD} m/s; drop test's last impact {v_last:.3g} m/s)",
            "the ball's contactProcessingThreshold 0 (a pair takes the smaller of its two bodies'), "
            f"contactStiffness {CONTACT_STIFFNESS_N_PER_M:g} and contactDamping {CONTACT_DAMPING_N_S_PER_M:g} (Bullet "
            f"then gives the ball's contacts ERP 0 and CFM {1 / CONTACT_DAMPING_N_S_PER_M:g}) and zero damping: "
            "with Bullet's defaults the epsilon a contact gives depends on where in its step the contact falls",
            "the ball's contacts only: the world's contactERP, erp and frictionERP stay yours, so your other "
            "bodies rest on the floor as before (a world-wide contactERP 0, as an earlier vrcal set, left a 1 kg "
            "box dropped 0.3 m 7.78 mm in the floor for good)",
            "world-wide (setPhysicsEngineParameter acts on every body): restitutionVelocityThreshold (your "
            "bodies with a restitution now bounce down to it), contactSlop 0 (resting contacts lose PyBullet's "
            "1e-05 m of slop; a 1 kg box rests 0.00 mm in the floor, 0.01 mm with the default) and the step; "
            "the floor's restitution 1 gives every body its own restitution against the floor (Bullet's "
            "default 0 for a body keeps it from bouncing)",
            f"contactSlop {CONTACT_SLOP_M:g}: with PyBullet's default {PYBULLET_CONTACT_SLOP_M:g} m a ball found "
            f"less deep than that leaves up to {PYBULLET_CONTACT_SLOP_M:g} m / dt too slowly (at this step "
            f"{PYBULLET_CONTACT_SLOP_M / setup.dt_s:.3g} m/s, up to "
            f"{PYBULLET_CONTACT_SLOP_M / (setup.dt_s * v_last):.2g} off epsilon at the drop test's last impact)",
            "friction is not set by vrcal: lateralFriction 0 makes the ball frictionless (it slides, never "
            "rolls); a vertical drop ignores it: set lateralFriction on the ball and the floor to yours",
        ],
    }
    out.update(effect_params(setup))
    if "drag" in out or "restitution_law" in out:
        out["notes"].append("PyBullet has no air drag and one restitution per body: step with the snippet's "
                            "vrcal_step(ball) instead of p.stepSimulation() (drag force; epsilon at this speed)")
    if pair:
        out["changeDynamics"]["ball2"] = {"restitution": pair["epsilon_ball2"], **BALL_DYNAMICS}
        out["pairs"] = dict(pair["pairs"])      # every pair's epsilon, Eq. 6 (export.pair_epsilons)
        out["notes"].append(
            "pair: Bullet's product rule gives ball x ball2 = "
            f"{ball_eps:.6g} x {pair['epsilon_ball2']:.6g} = {ball_eps * pair['epsilon_ball2']:.6g}, "
            f"Eq. 6 gives {pair['epsilon']:.6g}: with ball, ball2 and floor set as the snippet does, nothing "
            "else to set"
        )
    return out


def _pybullet():
    try:
        pybullet = _quiet_import("pybullet")
    except ImportError:
        raise EngineUnavailable(f"PyBullet is not installed: {install_hint('pybullet', 'engines')}") from None
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


def substeps_of(params):
    """The ``numSubSteps`` of a parameter set (0: none) and the step of each [s]: ``fixedTimeStep / numSubSteps``."""
    eng = params["setPhysicsEngineParameter"]
    n = int(eng.get("numSubSteps", 0) or 0)
    return n, float(eng["fixedTimeStep"]) / max(n, 1)


def run_drop(params, drop_height_m, duration_s):
    """Drop the ball of an exported parameter set once in a DIRECT PyBullet client.

    With ``numSubSteps`` N each ``stepSimulation()`` takes N steps of ``fixedTimeStep / N``; the run
    takes them one by one (``fixedTimeStep / N``, no substeps) so that every step is sampled, its depth
    too, and the snippet's ``vrcal_step`` holds its drag force and restitution over the N steps, as
    PyBullet's substeps do (an external force acts in every substep of the call it was applied before):
    the positions are PyBullet's own with the substeps (tests/engines/test_bullet.py)."""
    p = _pybullet()
    cid = p.connect(p.DIRECT)
    try:
        ball = params["ball"]
        R = float(ball["radius_m"])
        eng = dict(params["setPhysicsEngineParameter"])
        n_sub, dt = substeps_of(params)
        eng.update(fixedTimeStep=dt, numSubSteps=0)
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
        n_outer = max(n_sub, 1)
        n = int(math.ceil(duration_s / (dt * n_outer))) * n_outer
        z = np.empty(n + 1)
        v = np.empty(n + 1)
        z[0], v[0] = drop_height_m, 0.0
        bound = _Substeps(p, cid, n_outer, body, R, z, v)
        step = step_function(params, bound)
        while bound.i < n:
            step(body)
        return z, v, dt, g
    finally:
        p.disconnect(cid)


def drop_test(params, setup, n_bounces, n_phases):
    """Run the exported settings in PyBullet and measure them against vrcal's model: a DropRuns."""
    return stepped_drop_test(run_drop, params, replace(setup, n_bounces=int(n_bounces)), n_bounces, n_phases,
                             get_engine("bullet").max_steps)


def run_pair(params, pair, gap_m, n_steps):
    """Run the two balls of the pair test in a DIRECT PyBullet client (gravity off, no floor), each with its
    exported ``changeDynamics`` (Bullet's product rule makes the pair's restitution); returns the centres' x [m]
    and x velocities [m/s] of every step (rows of a (4, n_steps + 1) array: ball x, ball2 x, ball v, ball2 v)."""
    p = _pybullet()
    cid = p.connect(p.DIRECT)
    try:
        p.setPhysicsEngineParameter(physicsClientId=cid, **dict(params["setPhysicsEngineParameter"]))
        p.setGravity(0.0, 0.0, 0.0, physicsClientId=cid)
        bodies = []
        for key, R, m, x, v in (("ball", pair.radius_m, pair.mass_kg, 0.0, pair.velocities_m_per_s[0]),
                                ("ball2", pair.radius2_m, pair.mass2_kg, pair.contact_distance_m + gap_m,
                                 pair.velocities_m_per_s[1])):
            shape = p.createCollisionShape(p.GEOM_SPHERE, radius=float(R), physicsClientId=cid)
            body = p.createMultiBody(float(m), shape, basePosition=[x, 0, 1.0], physicsClientId=cid)
            p.changeDynamics(body, -1, physicsClientId=cid, **params["changeDynamics"][key])
            p.resetBaseVelocity(body, [v, 0, 0], [0, 0, 0], physicsClientId=cid)
            bodies.append(body)
        out = np.empty((4, n_steps + 1))
        for i in range(n_steps + 1):
            if i:
                p.stepSimulation(physicsClientId=cid)
            (x1, _, _), _ = p.getBasePositionAndOrientation(bodies[0], physicsClientId=cid)
            (x2, _, _), _ = p.getBasePositionAndOrientation(bodies[1], physicsClientId=cid)
            out[:, i] = (x1, x2, p.getBaseVelocity(bodies[0], physicsClientId=cid)[0][0],
                         p.getBaseVelocity(bodies[1], physicsClientId=cid)[0][0])
        return out
    finally:
        p.disconnect(cid)


def pair_test(params, pair, n_phases):
    """The two-ball collision test of an exported file's pair in PyBullet: a PairResult (with ``numSubSteps``
    N run at ``fixedTimeStep / N`` without substeps: the same positions, measured, :func:`run_drop`)."""
    _, dt = substeps_of(params)
    params = dict(params, setPhysicsEngineParameter=dict(params["setPhysicsEngineParameter"], fixedTimeStep=dt,
                                                         numSubSteps=0))
    pair = replace(pair, dt_s=dt, contact_steps=2)
    return PairResult("bullet", pair, stepped_pair_test(run_pair, params, pair, n_phases))


class _Bound:
    """``pybullet`` with every call bound to one client (what the snippet calls ``p``)."""

    def __init__(self, module, cid):
        self._p, self._cid = module, cid

    def __getattr__(self, name):
        attr = getattr(self._p, name)
        if callable(attr):
            return lambda *args, **kwargs: attr(*args, physicsClientId=self._cid, **kwargs)
        return attr


class _Substeps(_Bound):
    """:class:`_Bound` whose ``stepSimulation()`` is PyBullet's with ``numSubSteps`` N, taken step by step in a
    world of ``fixedTimeStep / N`` without substeps: N steps, the external forces applied before the call
    applied again before each (PyBullet applies them in every substep), each step's bottom height and
    vertical velocity written to ``z`` and ``v`` at index ``i``."""

    def __init__(self, module, cid, n_sub, body, radius_m, z, v):
        super().__init__(module, cid)
        self._n, self._body, self._R, self._z, self._v = n_sub, body, radius_m, z, v
        self._forces, self.i = [], 0

    def applyExternalForce(self, *args, **kwargs):       # noqa: N802 - pybullet's name
        self._forces.append((args, kwargs))
        return self._p.applyExternalForce(*args, physicsClientId=self._cid, **kwargs)

    def stepSimulation(self):                            # noqa: N802 - pybullet's name
        p, cid = self._p, self._cid
        for k in range(self._n):
            if k:
                for args, kwargs in self._forces:
                    p.applyExternalForce(*args, physicsClientId=cid, **kwargs)
            p.stepSimulation(physicsClientId=cid)
            self.i += 1
            if self.i < len(self._z):
                self._z[self.i] = p.getBasePositionAndOrientation(self._body, physicsClientId=cid)[0][2] - self._R
                self._v[self.i] = p.getBaseVelocity(self._body, physicsClientId=cid)[0][2]
        self._forces = []


def step_function(params, p):
    """The snippet's ``vrcal_step(ball)``, run: it is what verify steps with (``p`` is pybullet)."""
    code = step_code(params)
    if code is None:
        return lambda ball: p.stepSimulation()
    namespace = {"p": p}
    exec(compile(code, "<vrcal bullet snippet>", "exec"), namespace)  # noqa: S102 - our own snippet
    return namespace["vrcal_step"]


STEP_CODE = '''\
def vrcal_step(ball):
    """One step with what PyBullet lacks: air drag and epsilon at this impact speed."""
    v = p.getBaseVelocity(ball)[0]
    speed = (v[0] ** 2 + v[1] ** 2 + v[2] ** 2) ** 0.5
{drag}{law}    p.stepSimulation()
'''
DRAG_PY = ("    p.applyExternalForce(ball, -1, [-{c} * speed * x for x in v], "
           "p.getBasePositionAndOrientation(ball)[0], p.WORLD_FRAME)\n")
LAW_PY = ("    # epsilon at this impact speed, clamped to [0, 1]; |v_z|: the normal speed on a z-up floor at rest\n"
          "    # (another surface: the ball's speed relative to it along p.getContactPoints' normal)\n"
          "    eps = 1 - (1 - {eps_ref}) * (max(abs(v[2]), 1e-9) / {v_ref}) ** {p}\n"
          "    p.changeDynamics(ball, -1, restitution=min(max(eps, 0.0), 1.0))\n")


def step_code(params):
    """Python source of ``vrcal_step(ball)`` for a parameter set with drag or a restitution law (else None)."""
    drag, law = params.get("drag"), params.get("restitution_law")
    if not drag and not law:
        return None
    drag_py = DRAG_PY.format(c=repr(float(drag["force_coefficient_kg_per_m"]))) if drag else ""
    law_py = LAW_PY.format(eps_ref=repr(float(law["epsilon_ref"])), v_ref=repr(float(law["reference_speed_m_per_s"])),
                           p=repr(float(law["exponent"]))) if law else ""
    return STEP_CODE.format(drag=drag_py, law=law_py)


PY_SNIPPET = """\
import pybullet as p
p.connect(p.DIRECT)
p.setPhysicsEngineParameter(**{engine})
p.setGravity(0, 0, {gz})
# ball = your sphere body, floor = your plane body
p.changeDynamics(ball, -1, **{ball})
p.changeDynamics(floor, -1, **{floor})
"""

#: The snippet's line for the second ball of ``--against`` (every body the export names is set).
PY_SNIPPET_BALL2 = """# ball2 = your {name} body (Bullet's product rule then gives each pair its Eq. 6 value)
p.changeDynamics(ball2, -1, **{ball2})
"""


def py_snippet(params):
    """The Python lines that apply an exported parameter set to a user's bodies (and ``vrcal_step``)."""
    text = PY_SNIPPET.format(engine=params["setPhysicsEngineParameter"], gz=params["setGravity"][2],
                             ball=params["changeDynamics"]["ball"], floor=params["changeDynamics"]["floor"])
    if "ball2" in params["changeDynamics"]:
        text += PY_SNIPPET_BALL2.format(name=params.get("pair", {}).get("ball2", "second ball"),
                                        ball2=params["changeDynamics"]["ball2"])
    code = step_code(params)
    if code:
        text += "# each step: vrcal_step(ball) instead of p.stepSimulation()\n" + code
    return text
