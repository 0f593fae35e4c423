"""Low-level ctypes binding of ODE, the Open Dynamics Engine (libode, double precision).

vrcal ships no compiled extension: this module loads the system's C library (Debian
package ``libode8``, ``/usr/lib/x86_64-linux-gnu/libode.so.8``) with :mod:`ctypes`,
declares the structs vrcal needs (:class:`dMass`, :class:`dSurfaceParameters`,
:class:`dContactGeom`, :class:`dContact`) and sets ``argtypes``/``restype`` for the
world, space, body, geom, collision, joint-group and contact-joint functions.

The binding is general (any number of bodies, spheres, boxes, planes); the restitution
export/verify code in :mod:`vrcal.engines.ode` and the multi-body scenes use it.

Usage
-----
>>> from vrcal.engines import ode_ctypes as O
>>> lib = O.load_ode()                  # EngineUnavailable when libode is absent
>>> O.init_ode()                        # dInitODE2(0) once per process, dCloseODE at exit
>>> world = lib.dWorldCreate()
>>> space = lib.dHashSpaceCreate(None)
>>> body = lib.dBodyCreate(world)
>>> m = O.dMass(); lib.dMassSetSphereTotal(ctypes.byref(m), 0.6, 0.12); lib.dBodySetMass(body, ctypes.byref(m))
>>> geom = lib.dCreateSphere(space, 0.12); lib.dGeomSetBody(geom, body)
>>> lib.dBodySetPosition(body, 0.0, 0.0, 1.0); O.vec3(lib.dBodyGetPosition(body))
(0.0, 0.0, 1.0)

The near callback of ``dSpaceCollide`` is a :data:`NearCallback`; keep a reference to
it while ``dSpaceCollide`` runs (:func:`collide_pairs` does the bookkeeping for you).

Layout
------
The struct layouts follow ODE 0.16's headers (``ode/contact.h``, ``ode/mass.h``) for
``dReal = double``. :func:`load_ode` checks at load time that the library is built in
double precision (``dCheckConfiguration("ODE_double_precision")``), that the ctypes
offsets equal the C layout (sizeof(dContact) = 248, surface.bounce at 48, bounce_vel at
56, geom at 120, fdir1 at 216, sizeof(dMass) = 136, sizeof(dContactGeom) = 96; numbers
from a C probe compiled against libode-dev 0.16.2), and, at run time, that ``dMassSetSphereTotal``
and ``dCollide`` write the fields where these structs read them.
"""

from __future__ import annotations

import atexit
import ctypes
import ctypes.util
import math
import os
from ctypes import POINTER, Structure, byref, c_char_p, c_double, c_int, c_uint, c_void_p

from vrcal.errors import EngineUnavailable

#: ODE's floating point type in the Debian build (checked at load time).
dReal = c_double
dVector3 = dReal * 4
dVector4 = dReal * 4
dMatrix3 = dReal * 12

# Opaque handles: plain pointers. ``None`` is the null handle (e.g. a top-level space).
dWorldID = c_void_p
dSpaceID = c_void_p
dBodyID = c_void_p
dGeomID = c_void_p
dJointID = c_void_p
dJointGroupID = c_void_p

# --------------------------------------------------------------------------- constants (ode/contact.h)

dContactMu2 = 0x001
dContactAxisDep = 0x001
dContactFDir1 = 0x002
dContactBounce = 0x004
dContactSoftERP = 0x008
dContactSoftCFM = 0x010
dContactMotion1 = 0x020
dContactMotion2 = 0x040
dContactMotionN = 0x080
dContactSlip1 = 0x100
dContactSlip2 = 0x200
dContactRolling = 0x400
dContactApprox0 = 0x0000
dContactApprox1_1 = 0x1000
dContactApprox1_2 = 0x2000
dContactApprox1_N = 0x4000
dContactApprox1 = 0x7000

#: ``mu = dInfinity`` in C; any large number works the same.
dInfinity = math.inf

# joint types (ode/common.h, dJointType) for dAreConnectedExcluding
dJointTypeNone = 0
dJointTypeBall = 1
dJointTypeHinge = 2
dJointTypeSlider = 3
dJointTypeContact = 4

# geom classes (ode/collision.h) for dGeomGetClass
dSphereClass = 0
dBoxClass = 1
dCapsuleClass = 2
dCylinderClass = 3
dPlaneClass = 4

#: Names tried by :func:`load_ode`, in order (``VRCAL_LIBODE`` first when set).
LIBRARY_NAMES = ("libode.so.8", "libode.so", "libode.8.dylib", "libode.dylib", "ode.dll", "ode_double.dll")

INSTALL_HINT = "install the Debian package libode8 (apt-get install libode8)"

# --------------------------------------------------------------------------- structs


class dMass(Structure):
    """``dMass`` (ode/mass.h): total mass [kg], centre of mass, inertia matrix (3x4 rows)."""

    _fields_ = [("mass", dReal), ("c", dVector3), ("I", dMatrix3)]


class dSurfaceParameters(Structure):
    """``dSurfaceParameters`` (ode/contact.h); only fields whose flag is in ``mode`` are used.

    ``bounce`` is the coefficient of restitution in [0, 1] (flag ``dContactBounce``);
    ``bounce_vel`` [m/s] the smallest incoming normal speed that bounces.
    """

    _fields_ = [
        ("mode", c_int),
        ("mu", dReal), ("mu2", dReal),
        ("rho", dReal), ("rho2", dReal), ("rhoN", dReal),
        ("bounce", dReal), ("bounce_vel", dReal),
        ("soft_erp", dReal), ("soft_cfm", dReal),
        ("motion1", dReal), ("motion2", dReal), ("motionN", dReal),
        ("slip1", dReal), ("slip2", dReal),
    ]


class dContactGeom(Structure):
    """``dContactGeom`` (ode/contact.h), filled by ``dCollide``."""

    _fields_ = [
        ("pos", dVector3), ("normal", dVector3), ("depth", dReal),
        ("g1", dGeomID), ("g2", dGeomID),
        ("side1", c_int), ("side2", c_int),
    ]


class dContact(Structure):
    """``dContact`` (ode/contact.h): surface parameters, the contact geometry, friction direction."""

    _fields_ = [("surface", dSurfaceParameters), ("geom", dContactGeom), ("fdir1", dVector3)]


class dJointFeedback(Structure):
    """``dJointFeedback`` (ode/common.h): force [N] and torque [N m] the joint applied to body 1
    (f1, t1) and body 2 (f2, t2) during the last step, filled when set by ``dJointSetFeedback``."""

    _fields_ = [("f1", dVector3), ("t1", dVector3), ("f2", dVector3), ("t2", dVector3)]


#: The C layout (bytes) for double precision, checked against ctypes by :func:`check_layout`.
EXPECTED_LAYOUT = {
    "sizeof(dReal)": 8,
    "sizeof(dMass)": 136,
    "sizeof(dSurfaceParameters)": 120,
    "sizeof(dContactGeom)": 96,
    "sizeof(dContact)": 248,
    "sizeof(dJointFeedback)": 128,
    "dContact.surface.bounce": 48,
    "dContact.surface.bounce_vel": 56,
    "dContact.surface.soft_cfm": 72,
    "dContact.geom": 120,
    "dContact.geom.depth": 120 + 64,
    "dContact.geom.g1": 120 + 72,
    "dContact.fdir1": 216,
}

#: ``void dNearCallback(void *data, dGeomID o1, dGeomID o2)``
NearCallback = ctypes.CFUNCTYPE(None, c_void_p, dGeomID, dGeomID)


def layout():
    """Byte sizes and offsets of the ctypes structs, keyed as :data:`EXPECTED_LAYOUT`."""
    surf = dContact.surface.offset
    geom = dContact.geom.offset
    return {
        "sizeof(dReal)": ctypes.sizeof(dReal),
        "sizeof(dMass)": ctypes.sizeof(dMass),
        "sizeof(dSurfaceParameters)": ctypes.sizeof(dSurfaceParameters),
        "sizeof(dContactGeom)": ctypes.sizeof(dContactGeom),
        "sizeof(dContact)": ctypes.sizeof(dContact),
        "sizeof(dJointFeedback)": ctypes.sizeof(dJointFeedback),
        "dContact.surface.bounce": surf + dSurfaceParameters.bounce.offset,
        "dContact.surface.bounce_vel": surf + dSurfaceParameters.bounce_vel.offset,
        "dContact.surface.soft_cfm": surf + dSurfaceParameters.soft_cfm.offset,
        "dContact.geom": geom,
        "dContact.geom.depth": geom + dContactGeom.depth.offset,
        "dContact.geom.g1": geom + dContactGeom.g1.offset,
        "dContact.fdir1": dContact.fdir1.offset,
    }


def check_layout():
    """Raise :class:`EngineUnavailable` when a ctypes offset differs from the C layout."""
    got = layout()
    bad = {k: (got[k], v) for k, v in EXPECTED_LAYOUT.items() if got[k] != v}
    if bad:
        detail = ", ".join(f"{k} = {g} (C: {e})" for k, (g, e) in sorted(bad.items()))
        raise EngineUnavailable(f"ODE struct layout mismatch on this platform: {detail}")


# --------------------------------------------------------------------------- function table

_P = POINTER(dReal)
_FUNCTIONS = {
    # library
    "dInitODE2": (c_int, [c_uint]),
    "dCloseODE": (None, []),
    "dGetConfiguration": (c_char_p, []),
    "dCheckConfiguration": (c_int, [c_char_p]),
    # world
    "dWorldCreate": (dWorldID, []),
    "dWorldDestroy": (None, [dWorldID]),
    "dWorldSetGravity": (None, [dWorldID, dReal, dReal, dReal]),
    "dWorldGetGravity": (None, [dWorldID, dVector3]),
    "dWorldSetERP": (None, [dWorldID, dReal]),
    "dWorldGetERP": (dReal, [dWorldID]),
    "dWorldSetCFM": (None, [dWorldID, dReal]),
    "dWorldGetCFM": (dReal, [dWorldID]),
    "dWorldStep": (c_int, [dWorldID, dReal]),
    "dWorldQuickStep": (c_int, [dWorldID, dReal]),
    "dWorldSetQuickStepNumIterations": (None, [dWorldID, c_int]),
    "dWorldSetContactSurfaceLayer": (None, [dWorldID, dReal]),
    "dWorldGetContactSurfaceLayer": (dReal, [dWorldID]),
    "dWorldSetContactMaxCorrectingVel": (None, [dWorldID, dReal]),
    "dWorldGetContactMaxCorrectingVel": (dReal, [dWorldID]),
    "dWorldSetAutoDisableFlag": (None, [dWorldID, c_int]),
    "dWorldSetLinearDamping": (None, [dWorldID, dReal]),
    "dWorldSetAngularDamping": (None, [dWorldID, dReal]),
    # spaces
    "dSimpleSpaceCreate": (dSpaceID, [dSpaceID]),
    "dHashSpaceCreate": (dSpaceID, [dSpaceID]),
    "dSpaceDestroy": (None, [dSpaceID]),
    "dSpaceCollide": (None, [dSpaceID, c_void_p, NearCallback]),
    "dSpaceCollide2": (None, [dGeomID, dGeomID, c_void_p, NearCallback]),
    "dSpaceGetNumGeoms": (c_int, [dSpaceID]),
    # bodies
    "dBodyCreate": (dBodyID, [dWorldID]),
    "dBodyDestroy": (None, [dBodyID]),
    "dBodySetPosition": (None, [dBodyID, dReal, dReal, dReal]),
    "dBodyGetPosition": (_P, [dBodyID]),
    "dBodySetLinearVel": (None, [dBodyID, dReal, dReal, dReal]),
    "dBodyGetLinearVel": (_P, [dBodyID]),
    "dBodySetAngularVel": (None, [dBodyID, dReal, dReal, dReal]),
    "dBodyGetAngularVel": (_P, [dBodyID]),
    "dBodyGetRotation": (_P, [dBodyID]),
    "dBodySetMass": (None, [dBodyID, POINTER(dMass)]),
    "dBodyGetMass": (None, [dBodyID, POINTER(dMass)]),
    "dBodyAddForce": (None, [dBodyID, dReal, dReal, dReal]),
    "dBodySetGravityMode": (None, [dBodyID, c_int]),
    "dBodySetLinearDamping": (None, [dBodyID, dReal]),
    "dBodySetAngularDamping": (None, [dBodyID, dReal]),
    "dBodySetAutoDisableFlag": (None, [dBodyID, c_int]),
    "dBodyIsEnabled": (c_int, [dBodyID]),
    "dBodyEnable": (None, [dBodyID]),
    "dBodySetData": (None, [dBodyID, c_void_p]),
    "dBodyGetData": (c_void_p, [dBodyID]),
    # mass
    "dMassSetZero": (None, [POINTER(dMass)]),
    "dMassSetSphere": (None, [POINTER(dMass), dReal, dReal]),
    "dMassSetSphereTotal": (None, [POINTER(dMass), dReal, dReal]),
    "dMassSetBoxTotal": (None, [POINTER(dMass), dReal, dReal, dReal, dReal]),
    # geoms
    "dCreateSphere": (dGeomID, [dSpaceID, dReal]),
    "dCreatePlane": (dGeomID, [dSpaceID, dReal, dReal, dReal, dReal]),
    "dCreateBox": (dGeomID, [dSpaceID, dReal, dReal, dReal]),
    "dGeomDestroy": (None, [dGeomID]),
    "dGeomSetBody": (None, [dGeomID, dBodyID]),
    "dGeomGetBody": (dBodyID, [dGeomID]),
    "dGeomSetPosition": (None, [dGeomID, dReal, dReal, dReal]),
    "dGeomGetPosition": (_P, [dGeomID]),
    "dGeomSetData": (None, [dGeomID, c_void_p]),
    "dGeomGetData": (c_void_p, [dGeomID]),
    "dGeomGetClass": (c_int, [dGeomID]),
    "dGeomSphereSetRadius": (None, [dGeomID, dReal]),
    "dGeomSphereGetRadius": (dReal, [dGeomID]),
    # collision
    "dCollide": (c_int, [dGeomID, dGeomID, c_int, POINTER(dContactGeom), c_int]),
    "dAreConnected": (c_int, [dBodyID, dBodyID]),
    "dAreConnectedExcluding": (c_int, [dBodyID, dBodyID, c_int]),
    # joints
    "dJointGroupCreate": (dJointGroupID, [c_int]),
    "dJointGroupDestroy": (None, [dJointGroupID]),
    "dJointGroupEmpty": (None, [dJointGroupID]),
    "dJointCreateContact": (dJointID, [dWorldID, dJointGroupID, POINTER(dContact)]),
    "dJointAttach": (None, [dJointID, dBodyID, dBodyID]),
    "dJointDestroy": (None, [dJointID]),
    "dJointSetFeedback": (None, [dJointID, POINTER(dJointFeedback)]),
}

_LIB = None
_INITIALISED = False


def _candidates():
    env = os.environ.get("VRCAL_LIBODE")
    if env:
        yield env
    found = ctypes.util.find_library("ode")
    if found:
        yield found
    yield from LIBRARY_NAMES


def load_ode():
    """Load libode once, declare its functions, and check the struct layout.

    Returns
    -------
    ctypes.CDLL
        the library with ``argtypes``/``restype`` set for every name in the binding
        (see ``_FUNCTIONS`` in the source)

    Raises
    ------
    EngineUnavailable
        when the C library is not found (the message names the package to install),
        is built in single precision, lacks a function, or has another struct layout.

    Notes
    -----
    Set the environment variable ``VRCAL_LIBODE`` to a path to load a specific build.
    """
    global _LIB
    if _LIB is not None:
        return _LIB
    lib, tried = None, []
    for name in _candidates():
        try:
            lib = ctypes.CDLL(name)
            break
        except OSError:
            tried.append(name)
    if lib is None:
        raise EngineUnavailable(f"ODE C library not found: {INSTALL_HINT}")
    missing = []
    for fname, (restype, argtypes) in _FUNCTIONS.items():
        try:
            fn = getattr(lib, fname)
        except AttributeError:
            missing.append(fname)
            continue
        fn.restype = restype
        fn.argtypes = argtypes
    if missing:
        raise EngineUnavailable(f"ODE C library lacks {', '.join(missing)}: {INSTALL_HINT} (version 0.16)")
    if not lib.dCheckConfiguration(b"ODE_double_precision"):
        raise EngineUnavailable(
            f"ODE C library is built in single precision ({lib.dGetConfiguration().decode()}): {INSTALL_HINT}"
        )
    check_layout()
    _init(lib)
    _check_runtime_layout(lib)
    _LIB = lib
    return lib


def init_ode():
    """Call ``dInitODE2(0)`` once per process and ``dCloseODE`` at interpreter exit.

    :func:`load_ode` already does this; calling it again does nothing.
    """
    return _init(load_ode())


def _init(lib):
    global _INITIALISED
    if not _INITIALISED:
        if not lib.dInitODE2(0):
            raise EngineUnavailable("ODE C library failed to initialise (dInitODE2 returned 0)")
        _INITIALISED = True
        atexit.register(lib.dCloseODE)
    return lib


def _check_runtime_layout(lib):
    """Let the library fill a dMass and a dContactGeom and check the fields land where we read them."""
    m = dMass()
    lib.dMassSetSphereTotal(byref(m), 2.0, 0.5)
    inertia = 0.4 * 2.0 * 0.5 ** 2
    if not (math.isclose(m.mass, 2.0) and math.isclose(m.I[0], inertia) and math.isclose(m.I[5], inertia)):
        raise EngineUnavailable("ODE dMass layout check failed: dMassSetSphereTotal wrote unexpected fields")
    sphere = lib.dCreateSphere(None, 0.5)
    plane = lib.dCreatePlane(None, 0.0, 0.0, 1.0, 0.0)
    try:
        lib.dGeomSetPosition(sphere, 0.0, 0.0, 0.4)
        geoms = (dContactGeom * 2)()
        n = lib.dCollide(sphere, plane, 2, geoms, ctypes.sizeof(dContactGeom))
        g = geoms[0]
        ok = (n == 1 and math.isclose(g.depth, 0.1, abs_tol=1e-12) and math.isclose(g.normal[2], 1.0)
              and g.g1 == sphere and g.g2 == plane)
    finally:
        lib.dGeomDestroy(sphere)
        lib.dGeomDestroy(plane)
    if not ok:
        raise EngineUnavailable("ODE dContactGeom layout check failed: dCollide wrote unexpected fields")


# --------------------------------------------------------------------------- helpers


def vec3(ptr):
    """Copy the first three values of a ``const dReal*`` (position, velocity) into a tuple."""
    return (ptr[0], ptr[1], ptr[2])


def sphere_mass(mass_kg, radius_m):
    """A :class:`dMass` of a solid sphere of total mass ``mass_kg`` [kg] and radius ``radius_m`` [m]."""
    m = dMass()
    load_ode().dMassSetSphereTotal(byref(m), mass_kg, radius_m)
    return m


def surface(mode=0, mu=0.0, **fields):
    """A :class:`dSurfaceParameters` with ``mode`` flags, ``mu`` and any other named field set."""
    s = dSurfaceParameters()
    s.mode = int(mode)
    s.mu = float(mu)
    for name, value in fields.items():
        if name not in {f[0] for f in dSurfaceParameters._fields_}:
            raise TypeError(f"dSurfaceParameters has no field {name!r}")
        setattr(s, name, float(value))
    return s


def collide_pairs(lib, space, on_pair):
    """Run ``dSpaceCollide(space, ...)`` calling ``on_pair(o1, o2)`` for each candidate pair.

    ``on_pair`` receives two ``dGeomID`` (ints); exceptions raised in it are re-raised here
    after ``dSpaceCollide`` returns (ctypes would otherwise print and swallow them).
    """
    errors = []

    def _cb(_data, o1, o2):
        if errors:
            return
        try:
            on_pair(o1, o2)
        except BaseException as exc:  # noqa: BLE001 - re-raised below
            errors.append(exc)

    cb = NearCallback(_cb)
    lib.dSpaceCollide(space, None, cb)
    if errors:
        raise errors[0]


def add_contacts(lib, world, group, o1, o2, surf, max_contacts=4):
    """``dCollide`` two geoms and attach one contact joint per contact point with surface ``surf``.

    Parameters
    ----------
    lib : ctypes.CDLL
        from :func:`load_ode`
    world, group : dWorldID, dJointGroupID
    o1, o2 : dGeomID
    surf : dSurfaceParameters
        copied into every contact
    max_contacts : int
        at most this many contact points

    Returns
    -------
    int
        the number of contact joints created
    """
    contacts = (dContact * max_contacts)()
    # dCollide writes the dContactGeom part of each dContact: stride = sizeof(dContact)
    n = lib.dCollide(o1, o2, max_contacts, byref(contacts[0].geom), ctypes.sizeof(dContact))
    b1, b2 = lib.dGeomGetBody(o1), lib.dGeomGetBody(o2)
    for i in range(n):
        contacts[i].surface = surf
        joint = lib.dJointCreateContact(world, group, byref(contacts[i]))
        lib.dJointAttach(joint, b1, b2)
    return n
