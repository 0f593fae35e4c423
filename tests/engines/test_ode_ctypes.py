"""The ctypes binding of libode: struct layout, library loading, a real contact."""

import ctypes

import pytest
from helpers import require_engine

from vrcal.engines import ode_ctypes as O
from vrcal.errors import EngineUnavailable


def test_struct_layout_matches_the_c_headers():
    # numbers from a C probe against libode-dev 0.16.2 (engines-facts.md)
    assert O.layout() == O.EXPECTED_LAYOUT
    assert ctypes.sizeof(O.dContact) == 248
    assert O.dContact.fdir1.offset == 216
    assert ctypes.sizeof(O.dMass) == 136


def test_a_missing_library_names_the_debian_package(monkeypatch):
    monkeypatch.setattr(O, "_LIB", None)
    monkeypatch.setattr(O, "_candidates", lambda: iter(["/nonexistent/libode.so.8"]))
    with pytest.raises(EngineUnavailable, match=r"libode8 \(apt-get install libode8\)"):
        O.load_ode()


@pytest.fixture
def ode():
    """(lib, world, space, contact group) of a fresh ODE world, destroyed after the test."""
    require_engine("ode")
    lib = O.load_ode()
    world = lib.dWorldCreate()
    space = lib.dSimpleSpaceCreate(None)
    group = lib.dJointGroupCreate(0)
    try:
        yield lib, world, space, group
    finally:
        lib.dJointGroupDestroy(group)
        lib.dSpaceDestroy(space)
        lib.dWorldDestroy(world)


def test_sphere_on_plane_contact_and_body_state(ode):
    lib, world, space, group = ode
    lib.dWorldSetGravity(world, 0.0, 0.0, -9.81)
    lib.dWorldSetERP(world, 0.0)          # else ERP pushes out at 0.2 * 1 mm / 1e-4 s = 2 m/s
    assert lib.dWorldGetERP(world) == 0.0
    body = lib.dBodyCreate(world)
    m = O.sphere_mass(0.6, 0.1)
    lib.dBodySetMass(body, ctypes.byref(m))
    got = O.dMass()
    lib.dBodyGetMass(body, ctypes.byref(got))
    assert got.mass == pytest.approx(0.6)
    sphere = lib.dCreateSphere(space, 0.1)
    lib.dGeomSetBody(sphere, body)
    lib.dCreatePlane(space, 0.0, 0.0, 1.0, 0.0)
    lib.dBodySetPosition(body, 0.0, 0.0, 0.099)             # 1 mm into the floor
    lib.dBodySetLinearVel(body, 0.0, 0.0, -2.0)
    assert O.vec3(lib.dBodyGetLinearVel(body)) == (0.0, 0.0, -2.0)
    surf = O.surface(O.dContactBounce, 0.0, bounce=0.5, bounce_vel=0.01)
    counts = []
    O.collide_pairs(lib, space, lambda a, b: counts.append(O.add_contacts(lib, world, group, a, b, surf, 1)))
    assert counts == [1]
    lib.dWorldStep(world, 1e-4)
    lib.dJointGroupEmpty(group)
    vz = O.vec3(lib.dBodyGetLinearVel(body))[2]
    assert vz == pytest.approx(1.0, abs=2e-3)                 # bounce 0.5 of 2 m/s


def test_erp_push_out_beats_the_bounce(ode):
    """ODE leaves a contact at max(bounce speed, erp*depth/dt): why the export sets erp = 0."""
    lib, world, space, group = ode
    lib.dWorldSetERP(world, 0.2)
    body = lib.dBodyCreate(world)
    lib.dBodySetMass(body, ctypes.byref(O.sphere_mass(0.6, 0.1)))
    lib.dGeomSetBody(lib.dCreateSphere(space, 0.1), body)
    lib.dCreatePlane(space, 0.0, 0.0, 1.0, 0.0)
    lib.dBodySetPosition(body, 0.0, 0.0, 0.099)
    lib.dBodySetLinearVel(body, 0.0, 0.0, -2.0)
    surf = O.surface(O.dContactBounce, 0.0, bounce=0.5, bounce_vel=0.01)
    O.collide_pairs(lib, space, lambda a, b: O.add_contacts(lib, world, group, a, b, surf, 1))
    lib.dWorldStep(world, 1e-4)
    assert O.vec3(lib.dBodyGetLinearVel(body))[2] == pytest.approx(0.2 * 1e-3 / 1e-4, rel=1e-3)


def test_errors_in_the_near_callback_are_raised():
    require_engine("ode")
    lib = O.load_ode()
    space = lib.dSimpleSpaceCreate(None)
    a = lib.dCreateSphere(space, 0.1)
    b = lib.dCreateSphere(space, 0.1)
    try:
        def boom(o1, o2):
            raise KeyError("planted")

        with pytest.raises(KeyError, match="planted"):
            O.collide_pairs(lib, space, boom)
    finally:
        lib.dGeomDestroy(a)
        lib.dGeomDestroy(b)
        lib.dSpaceDestroy(space)


def test_surface_rejects_unknown_fields():
    with pytest.raises(TypeError, match="bounciness"):
        O.surface(O.dContactBounce, bounciness=0.5)
