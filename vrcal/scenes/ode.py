"""The same scene in the real ODE library (libode via ctypes): the paper's Section 7 algorithm.

Each sphere is an ODE body with a sphere geom in a hash space; the floor is a static plane
geom (z = 0). Every geom carries its virtual body (x, v) -- the two variables [1] adds to
ODE's ``Geom`` struct -- here in a Python table keyed by the geom. Every time step
``dSpaceCollide`` calls the near-callback for each candidate pair; for every contact point
from ``dCollide`` the callback, as in Section 7 of [1]:

1. enables the contact bounce parameter (``surface.mode = dContactBounce``),
2. calculates the time constant T from the two geoms' virtual bodies (Eq. 6),
3. calculates ``surface.bounce = exp(-K T)`` (Eq. 7),

and attaches a contact joint. Friction: ``dContactApprox1`` with ``mu`` = the scene's
``friction_mu``: ODE's friction pyramid, which caps the friction force along each of its two
tangential axes at mu times the normal force separately. With ODE's own axes that is not
Coulomb's law: a slip along the diagonal of the axes may be opposed by up to sqrt(2) mu N (a
ball hitting the floor at mu = 0.2 with 4 m/s of slip along the diagonal kept 2.400 m/s, against
2.861 m/s along an axis). So every contact also sets ``dContactFDir1`` with ``fdir1`` along the
contact point's relative tangential velocity (:func:`slip_direction`): the slip then lies on one
axis of the pyramid, nothing slips along the other, and the friction opposes the slip with at most
mu N -- the Coulomb circle of vrcal's simulator, for the slip at the start of each step (tested:
2.861 m/s in both directions). Where a contact does not slip ODE chooses the axes; a
sticking contact needs no friction beyond mu N along the slip it stops. ``bounce_vel``: on a floor
contact the scene's ``rest_speed_m_per_s`` (slower floor impacts do not bounce: vrcal's resting rule,
which ends a ball's infinite series of ever smaller bounces under gravity), on a ball-ball contact 0
(every approaching ball-ball contact bounces, as in vrcal: a slow horizontal hit is no settling ball;
:data:`BALL_BALL_BOUNCE_VEL_M_PER_S`). The hollow
shell inertia I = k m R^2 of each body is set in its ``dMass``.

World settings (see /work/shared/engines-facts.md): fixed step :data:`DEFAULT_DT_S`,
``dWorldStep``, CFM = 1e-10 (a soft contact eats energy), ERP = 0.2 with the push-out
speed capped at 0.1 m/s (the ERP push-out otherwise fakes a bounce), no damping, no
auto-disable.

The binding is :mod:`vrcal.engines.ode_ctypes` (struct layouts checked at load time).

Differences from vrcal's event-driven simulator (reported by ``vrcal scene --compare``):
ODE finds a contact only at the end of the step in which the spheres have already
interpenetrated (impact times late by up to one step, and the rebound starts from a
slightly lower point); ODE's bounce sets the outgoing normal speed of the contact from the
incoming one after gravity's step, and simultaneous contacts (a stack) are solved together
by the LCP rather than one after another.

References
----------
[1] "The Graphical Method for Decision of Restitution Coefficient and Its Applications", Section 7.
"""

from __future__ import annotations

import ctypes
import math

import numpy as np

from vrcal.errors import UsageError
from vrcal.scenes.spec import SceneContact, SceneResult, contact_epsilon

#: Default fixed time step of the ODE run [s].
DEFAULT_DT_S = 1e-4
#: World constraint force mixing (tiny: a soft contact loses energy).
WORLD_CFM = 1e-10
#: World error reduction parameter and the cap on its push-out speed [m/s].
WORLD_ERP = 0.2
MAX_CORRECTING_VEL_M_PER_S = 0.1
#: ``bounce_vel`` of a ball-ball contact [m/s]: every approaching ball-ball contact bounces (vrcal's rule;
#: the rest speed is a floor-only cut-off of the Zeno series of bounces under gravity).
BALL_BALL_BOUNCE_VEL_M_PER_S = 0.0
#: Largest number of contact points per geom pair.
MAX_CONTACTS = 4
#: Most body-steps (time steps x bodies) of one run: about 30 s at ~15 us a body-step.
MAX_BODY_STEPS = 2_000_000


def near_callback_bounce(virtual_a, virtual_b, K_per_s):
    """``surface.bounce`` for one contact in the near-callback, Eqs. (6) and (7) of [1].

    Parameters
    ----------
    virtual_a, virtual_b : tuple of float
        (x [m], v [m/s]) of the two geoms' virtual bodies (floor: (0, 0))
    K_per_s : float
        rate constant K [1/s]

    Returns
    -------
    bounce : float
        ``exp(-K (x_a/(2 v_a) + x_b/(2 v_b)))``
    """
    return float(contact_epsilon(virtual_a[0], virtual_a[1], virtual_b[0], virtual_b[1], K_per_s))


#: ``void dMessageFunction(int errnum, const char *msg, va_list ap)`` (ode/error.h); va_list as a pointer.
_MessageFunction = ctypes.CFUNCTYPE(None, ctypes.c_int, ctypes.c_char_p, ctypes.c_void_p)


class _OdeMessages:
    """Collect ODE's messages (printed to stderr by default) while a scene runs.

    ``dSetMessageHandler``/``dGetMessageHandler`` are not in :mod:`vrcal.engines.ode_ctypes`; their
    prototypes are declared here on the loaded library, as separate function objects (the shared
    library object's attributes are left alone). The previous handler is restored on exit.
    """

    def __init__(self, lib):
        self.set = ctypes.CFUNCTYPE(None, ctypes.c_void_p)(("dSetMessageHandler", lib))
        self.get = ctypes.CFUNCTYPE(ctypes.c_void_p)(("dGetMessageHandler", lib))
        self.counts = {}
        self._callback = _MessageFunction(self._on_message)

    def _on_message(self, errnum, msg, _ap):
        text = (msg or b"").decode("utf-8", "replace")
        key = f"ODE message {errnum}: {text}"
        self.counts[key] = self.counts.get(key, 0) + 1

    def __enter__(self):
        self._previous = self.get()
        self.set(ctypes.cast(self._callback, ctypes.c_void_p))
        return self

    def __exit__(self, *exc):
        self.set(self._previous)
        return False

    def notes(self):
        return [f"{text} (format string; {n} times) -- ODE's LCP could not solve some steps; its result "
                "there is unreliable" if "LCP" in text else f"{text} ({n} times)"
                for text, n in sorted(self.counts.items())]


def simulate_scene_ode(scene, *, dt_s=DEFAULT_DT_S):
    """Run a scene in ODE with the near-callback of Section 7 of [1].

    Parameters
    ----------
    scene : vrcal.scenes.spec.Scene
    dt_s : float
        fixed time step [s], > 0 and at most the scene's sample_dt_s

    Returns
    -------
    vrcal.scenes.spec.SceneResult
        trajectories at ``scene.sample_times_s()`` (the nearest step), contacts (one per
        first touch of a pair that approaches, with the bounce used and the impulses on body a
        from ODE's joint feedback over the impact step: ``dJointSetFeedback``'s force x dt, which
        includes the step's support against gravity, m g dt), apexes (vertex of the parabola through the
        three highest steps of each flight)

    Raises
    ------
    EngineUnavailable
        when libode cannot be loaded (the message names the package)
    """
    from vrcal.engines import ode_ctypes as O

    if not (math.isfinite(dt_s) and 0 < dt_s <= scene.sample_dt_s):
        raise UsageError(f"--ode-dt must be > 0 and at most the scene's sample_dt_s = {scene.sample_dt_s:g} s, "
                         f"got {dt_s!r}")
    body_steps = scene.duration_s / dt_s * len(scene.bodies)
    if body_steps > MAX_BODY_STEPS:
        raise UsageError(f"{scene.source}: duration_s / --ode-dt = {scene.duration_s / dt_s:.3g} steps of "
                         f"{len(scene.bodies)} bodies, more than the limit of {MAX_BODY_STEPS:.0e} body-steps: "
                         "a larger --ode-dt or a shorter duration_s")
    lib = O.load_ode()
    with _OdeMessages(lib) as messages:
        result = _run(O, lib, scene, dt_s)
    result.notes.extend(messages.notes())
    result.settings["ode_messages"] = sum(messages.counts.values())
    return result


def _run(O, lib, scene, dt_s):
    n = len(scene.bodies)
    n_steps = int(round(scene.duration_s / dt_s))
    world = lib.dWorldCreate()
    space = lib.dHashSpaceCreate(None)
    group = lib.dJointGroupCreate(0)
    try:
        lib.dWorldSetGravity(world, 0.0, 0.0, -scene.g_m_per_s2)
        lib.dWorldSetCFM(world, WORLD_CFM)
        lib.dWorldSetERP(world, WORLD_ERP)
        lib.dWorldSetContactMaxCorrectingVel(world, MAX_CORRECTING_VEL_M_PER_S)
        lib.dWorldSetContactSurfaceLayer(world, 0.0)
        lib.dWorldSetAutoDisableFlag(world, 0)
        lib.dWorldSetLinearDamping(world, 0.0)
        lib.dWorldSetAngularDamping(world, 0.0)
        floor = lib.dCreatePlane(space, 0.0, 0.0, 1.0, 0.0)
        index = {floor: -1}                      # geom -> body index (-1: floor)
        virtual = {-1: (scene.floor_x_m, scene.floor_v_m_per_s)}
        bodies = []
        for i, b in enumerate(scene.bodies):
            body = lib.dBodyCreate(world)
            m = O.dMass()
            lib.dMassSetSphereTotal(ctypes.byref(m), b.mass_kg, b.radius_m)
            inertia = b.inertia_kg_m2
            for k in (0, 5, 10):                 # solid sphere -> this body's k m R^2
                m.I[k] = inertia
            lib.dBodySetMass(body, ctypes.byref(m))
            lib.dBodySetPosition(body, *b.position_m)
            lib.dBodySetLinearVel(body, *b.velocity_m_per_s)
            lib.dBodySetAngularVel(body, *b.spin_rad_per_s)
            geom = lib.dCreateSphere(space, b.radius_m)
            lib.dGeomSetBody(geom, body)
            index[geom] = i
            virtual[i] = (b.x_m, b.v_m_per_s)
            bodies.append(body)
        bounce_cache = {}
        touching_prev, touching_now = set(), set()
        contacts = []
        state = {"t": 0.0}
        geoms = (O.dContact * MAX_CONTACTS)()
        friction = scene.friction_mu > 0
        mode = O.dContactBounce | (O.dContactApprox1 if friction else 0)

        def near_callback(o1, o2):
            i, j = index[o1], index[o2]
            if i == -1:                          # keep the floor second: normal points to body a
                i, j, o1, o2 = j, i, o2, o1
            count = lib.dCollide(o1, o2, MAX_CONTACTS, ctypes.byref(geoms[0].geom), ctypes.sizeof(O.dContact))
            if count == 0:
                return
            key = (i, j) if j == -1 or i < j else (j, i)
            if key not in bounce_cache:          # "calculate time constant T, calculate epsilon"
                bounce_cache[key] = near_callback_bounce(virtual[i], virtual[j], scene.K_per_s)
            bounce = bounce_cache[key]
            bounce_vel = bounce_velocity(scene, j == -1)
            touching_now.add(key)
            b1 = lib.dGeomGetBody(o1)
            b2 = lib.dGeomGetBody(o2) if j != -1 else None
            feedback = None
            if key not in touching_prev:
                nrm = np.array(geoms[0].geom.normal[:3])   # from body b (or the floor) towards body a
                va = np.array(O.vec3(lib.dBodyGetLinearVel(b1)))
                vb = np.array(O.vec3(lib.dBodyGetLinearVel(b2))) if b2 else np.zeros(3)
                approach = float(-nrm @ (va - vb))
                if approach > 0.0:               # an impact; a touch that does not approach (placed) is none
                    names = [scene.bodies[k].name for k in key if k != -1] + (["floor"] if key[1] == -1 else [])
                    bounces = approach > bounce_vel
                    note = "" if bounces else "no bounce: slower than bounce_vel"
                    contacts.append(SceneContact(state["t"], names[0], names[1], approach,
                                                 bounce if bounces else 0.0, math.nan, math.nan, note))
                    feedback = (O.dJointFeedback * count)()
                    impacts_now.append((len(contacts) - 1, feedback, nrm))
            for c in range(count):
                s = geoms[c].surface
                s.mode = mode                    # "enable contact bounce parameter"
                s.mu = scene.friction_mu
                s.bounce = bounce
                s.bounce_vel = bounce_vel
                if friction:
                    direction = slip_direction(O, lib, geoms[c].geom, b1, b2)
                    if direction is not None:    # the pyramid's first axis along the slip: Coulomb's circle
                        s.mode = mode | O.dContactFDir1
                        geoms[c].fdir1[:3] = direction
                joint = lib.dJointCreateContact(world, group, ctypes.byref(geoms[c]))
                lib.dJointAttach(joint, b1, b2)
                if feedback is not None:
                    lib.dJointSetFeedback(joint, ctypes.byref(feedback[c]))

        pos = np.empty((n_steps + 1, n, 3))
        vel = np.empty((n_steps + 1, n, 3))
        times = scene.sample_times_s()
        sample_steps = np.clip(np.round(times / dt_s).astype(int), 0, n_steps)
        wanted = np.zeros(n_steps + 1, dtype=bool)
        wanted[sample_steps] = True
        spin = np.zeros((n_steps + 1, n, 3))
        ang = np.zeros((n_steps + 1, n))
        in_contact = np.zeros((n_steps + 1, n), dtype=bool)

        def record(k):
            for b, body in enumerate(bodies):
                pos[k, b] = O.vec3(lib.dBodyGetPosition(body))
                vel[k, b] = O.vec3(lib.dBodyGetLinearVel(body))
                if wanted[k]:
                    spin[k, b] = O.vec3(lib.dBodyGetAngularVel(body))
                    r = lib.dBodyGetRotation(body)
                    ang[k, b] = math.atan2(-r[8], r[0])

        record(0)
        impacts_now = []

        for k in range(n_steps):
            state["t"] = k * dt_s
            touching_now = set()
            impacts_now.clear()
            O.collide_pairs(lib, space, near_callback)
            for key in touching_now:
                for b in key:
                    if b != -1:
                        in_contact[k, b] = True
            touching_prev = touching_now
            lib.dWorldStep(world, dt_s)
            for index_c, feedback, nrm in impacts_now:   # the impact step's impulse on body a
                force = np.sum([np.array(f.f1[:3]) for f in feedback], axis=0)
                normal = float(force @ nrm)
                contacts[index_c].normal_impulse_N_s = normal * dt_s
                contacts[index_c].tangential_impulse_N_s = float(np.linalg.norm(force - normal * nrm)) * dt_s
            lib.dJointGroupEmpty(group)
            record(k + 1)
    finally:
        lib.dJointGroupDestroy(group)
        lib.dSpaceDestroy(space)
        lib.dWorldDestroy(world)
    apexes = _apexes(scene, pos, vel, in_contact, dt_s)
    idx = sample_steps
    return SceneResult(scene=scene, engine="ode", t_s=times, position_m=pos[idx], velocity_m_per_s=vel[idx],
                       spin_rad_per_s=spin[idx], angle_y_rad=ang[idx], contacts=contacts, apexes=apexes,
                       notes=[f"ODE {n_steps} steps of {dt_s:g} s (dWorldStep); bounce from Eqs. 6, 7 in the "
                              f"near-callback; bounce_vel = {scene.rest_speed_m_per_s:g} m/s on the floor, "
                              f"{BALL_BALL_BOUNCE_VEL_M_PER_S:g} between balls; "
                              + (f"dContactApprox1 with fdir1 along the slip, mu = {scene.friction_mu:g}" if friction
                                 else "no friction")],
                       settings={"dt_s": dt_s, "steps": n_steps, "cfm": WORLD_CFM, "erp": WORLD_ERP,
                                 "max_correcting_vel_m_per_s": MAX_CORRECTING_VEL_M_PER_S})


def bounce_velocity(scene, on_floor):
    """ODE's ``bounce_vel`` of one contact [m/s]: below it an impact does not bounce.

    Parameters
    ----------
    scene : vrcal.scenes.spec.Scene
    on_floor : bool
        the contact is between a ball and the floor

    Returns
    -------
    float
        the scene's ``rest_speed_m_per_s`` on the floor (vrcal's resting rule), else
        :data:`BALL_BALL_BOUNCE_VEL_M_PER_S` (0: every approaching ball-ball contact bounces, as in vrcal)
    """
    return scene.rest_speed_m_per_s if on_floor else BALL_BALL_BOUNCE_VEL_M_PER_S


def slip_direction(O, lib, contact_geom, body_a, body_b, tolerance_m_per_s=1e-9):
    """Unit vector of the tangential velocity of body a's contact point relative to body b's, or None.

    Parameters
    ----------
    O : module
        :mod:`vrcal.engines.ode_ctypes`
    lib : ctypes.CDLL
        the loaded libode
    contact_geom : dContactGeom
        the contact from ``dCollide`` (pos [m], normal pointing towards body a)
    body_a, body_b : dBodyID
        the two bodies (``body_b`` None for the static floor)
    tolerance_m_per_s : float
        below this slip speed [m/s] there is no direction (None): ODE picks its own axes

    Returns
    -------
    ndarray, shape (3,) or None
        ``u_t/|u_t|`` with ``u = (v_a + w_a x (p - x_a)) - (v_b + w_b x (p - x_b))`` and
        ``u_t = u - (u.n) n``: the direction set as ``fdir1`` so that ODE's friction pyramid has
        an axis along the slip (its friction then opposes the slip with at most mu * normal force,
        the Coulomb circle, instead of mu on each of two fixed axes).
    """
    pos = np.array(contact_geom.pos[:3])
    n = np.array(contact_geom.normal[:3])

    def point_velocity(body):
        if not body:
            return np.zeros(3)
        centre = np.array(O.vec3(lib.dBodyGetPosition(body)))
        return (np.array(O.vec3(lib.dBodyGetLinearVel(body)))
                + np.cross(np.array(O.vec3(lib.dBodyGetAngularVel(body))), pos - centre))

    u = point_velocity(body_a) - point_velocity(body_b)
    u_t = u - (u @ n) * n
    speed = float(np.linalg.norm(u_t))
    return u_t / speed if speed > tolerance_m_per_s else None


def _apexes(scene, pos, vel, in_contact, dt_s):
    """Apex of every free flight: the vertex of the parabola through the three highest steps."""
    out = []
    radii = np.array([b.radius_m for b in scene.bodies])
    for b, body in enumerate(scene.bodies):
        z, vz = pos[:, b, 2], vel[:, b, 2]
        if vz[0] == 0.0 and z[0] - radii[b] > 1e-9:     # released from rest above the floor
            out.append((body.name, 0.0, float(z[0] - radii[b])))
        k = np.flatnonzero((vz[1:-1] > 0) & (vz[2:] <= 0)) + 1   # last rising step
        for kk in k:
            lo = kk - 1 if z[kk] >= z[kk + 1] else kk
            if lo < 0 or lo + 2 >= len(z) or in_contact[lo:lo + 3, b].any():
                continue
            z0, z1, z2 = z[lo], z[lo + 1], z[lo + 2]
            denom = z0 - 2 * z1 + z2
            if denom >= 0:
                continue
            s = 0.5 * (z0 - z2) / denom               # vertex offset from the middle step, in steps
            h = z1 - 0.25 * (z0 - z2) * s
            out.append((body.name, float((lo + 1 + s) * dt_s), float(h - radii[b])))
    out.sort(key=lambda a: (a[1], a[0]))
    return out
