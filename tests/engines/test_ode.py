"""ODE through libode: the exported contact settings, drag force and eps(v) near callback in the real engine."""

import json

import numpy as np
import pytest
from click.testing import CliRunner
from helpers import EPSILONS, require_engine

from vrcal.cli import main
from vrcal.engines import ode as E
from vrcal.engines.export import export, parse_exported
from vrcal.errors import DataError, UsageError
from vrcal.model.standards import get_ball


@pytest.mark.parametrize("eps", EPSILONS)
def test_exported_settings_reproduce_epsilon_in_ode(eps):
    require_engine("ode")
    ex = export("basketball", "ode", epsilon=eps, dt_s=2e-4)
    params = parse_exported("ode", ex.text)
    assert params["contact"]["bounce"] == pytest.approx(eps)
    runs = E.drop_test(params, ex.setup, 3, 2)
    assert runs.apex_ratios.shape == (2, 3)
    assert runs.worst_error < 0.005


def test_json_has_the_documented_fields():
    data = json.loads(export("tennis", "ode").text)
    contact = data["contact"]
    assert contact["mode"] == ["dContactBounce", "dContactSoftERP", "dContactSoftCFM", "dContactApprox1"]
    assert contact["mode_value"] == 4 | 8 | 16 | 0x7000
    assert contact["soft_erp"] == 0.0 and 0 < contact["soft_cfm"] <= 1e-10
    assert set(data["world"]) == {"dt", "gravity", "step"}               # the world's ERP and CFM stay the user's
    assert data["world"]["dt"] == 1e-3 and data["world"]["gravity"][2] == -9.80665
    assert 0 < contact["bounce_vel"] < 0.1
    assert "dContactBounce" in data["snippet"] and "bounce_vel" in data["snippet"]
    assert "drag" not in data and "restitution_law" not in data


def test_snippet_sets_the_balls_contacts_only_and_the_gravity():
    """Pasted into a model with joints, the snippet must not zero the world ERP (joints drift
    apart) nor set every contact's friction: soft ERP/CFM and mu on the ball's contacts only."""
    snippet = json.loads(export("tennis", "ode", g_m_per_s2=9.81).text)["snippet"]
    assert "dWorldSetERP" not in snippet and "dWorldSetCFM" not in snippet
    assert "dWorldSetGravity(world, 0.0, 0.0, -9.81);" in snippet
    assert "if (o1 != ball_geom && o2 != ball_geom)" in snippet
    assert "soft_erp = 0.0;" in snippet and "dContactSoftERP" in snippet
    assert max(len(line) for line in snippet.splitlines()) <= 100


def test_the_users_world_erp_and_cfm_leave_the_bounce_alone():
    """A world with ODE's default ERP 0.2 and the single-precision CFM 1e-5 (a user's model with
    joints): the ball's own contact settings still give epsilon; the same world without them does not."""
    require_engine("ode")
    ex = export("basketball", "ode", dt_s=1e-3)
    params = parse_exported("ode", ex.text)
    params["world"].update(erp=0.2, cfm=1e-5)
    assert E.drop_test(params, ex.setup, 3, 2).worst_error < 0.005
    for key in ("soft_erp", "soft_cfm"):
        del params["contact"][key]
    params["contact"]["mode"] = ["dContactBounce"]
    assert E.drop_test(params, ex.setup, 3, 2).worst_error > 0.01


def test_a_file_of_an_earlier_vrcal_with_world_erp_and_cfm_still_runs():
    require_engine("ode")
    ex = export("basketball", "ode", dt_s=1e-3)
    params = parse_exported("ode", ex.text)
    params["world"].update(erp=0.0, cfm=1e-10)
    params["contact"] = {k: params["contact"][k] for k in ("mu", "bounce", "bounce_vel")} | {
        "mode": ["dContactBounce"]}
    text = json.dumps(params)
    again = parse_exported("ode", text)
    assert E.drop_test(again, ex.setup, 3, 1).worst_error < 0.005


def test_impacts_below_bounce_vel_do_not_bounce():
    """A planted effect: raise bounce_vel above the impact speed and the ball sticks."""
    require_engine("ode")
    ex = export("basketball", "ode", epsilon=0.8)
    params = parse_exported("ode", ex.text)
    params["contact"]["bounce_vel"] = 100.0
    with pytest.raises(DataError, match="stuck to the floor"):
        E.drop_test(params, ex.setup, 1, 1)


def test_a_time_step_too_large_is_refused():
    with pytest.raises(UsageError, match=r"^(time step 0\.004 s is too large|ODE at --dt 0\.004 s misses)"):
        export("basketball", "ode", epsilon=0.5, dt_s=4e-3)


def test_odes_bounce_one_reads_one_at_a_coarse_step():
    """The probe's case: epsilon 1, a 2.7 g, 40 mm ball from 0.305 m at dt = 5 ms. ODE's contact sets the
    velocity to minus the one before, its apexes stay put; v_out/v_in read 1.020 (FAILED) when vrcal
    carried the stored velocity instead of the flight's."""
    require_engine("ode")
    from vrcal.engines.verify import verify

    r = verify(None, "ode", mass_kg=0.0027, diameter_m=0.04, epsilon=1.0, drop_height_m=0.305, dt_s=5e-3,
               max_penetration_m=0.015, n_phases=4)
    assert np.allclose(r.velocity_ratios, 1.0, atol=1e-6) and np.allclose(r.apex_ratios, 1.0, atol=1e-4)
    assert r.passed


def test_pair_values_follow_eq6():
    data = json.loads(export("basketball", "ode", against="volleyball").text)
    pairs = data["pairs"]
    assert pairs["basketball/volleyball"] == pytest.approx(pairs["basketball/floor"] * pairs["volleyball/floor"])
    assert any("near callback" in n for n in data["notes"])


def test_drag_and_speed_dependent_epsilon_run_in_ode(write_discover):
    """A discover result with drag (C_d 0.4) and eps(v) (p 0.3): the per-step dBodyAddForce and the
    near callback's bounce from the normal speed reproduce vrcal's model in libode."""
    require_engine("ode")
    path = write_discover(effects={"air_drag": {"drag_coefficient": 0.4},
                                   "velocity_dependent_restitution": {"exponent": 0.3}}, drop_height_m=2.0)
    ex = export(None, "ode", from_json=path, dt_s=2e-4)
    params = parse_exported("ode", ex.text)
    assert params["drag"]["force_coefficient_kg_per_m"] == pytest.approx(
        0.5 * 1.204 * 0.4 * np.pi * 0.02 ** 2, rel=1e-6)
    law = params["restitution_law"]
    assert law["table"]["epsilon"][0] > law["table"]["epsilon"][-1]        # slower impacts, more elastic
    assert "dBodyAddForce" in params["snippet"] and "pow(fabs(vn) /" in params["snippet"]
    runs = E.drop_test(params, ex.setup, 3, 2)
    assert runs.worst_error < 0.01
    assert np.max(np.abs(runs.apex_relative_errors)) < 0.01
    # the planted effects matter: the same drop without them rises well above vrcal's model of it
    plain = export(None, "ode", mass_kg=0.0027, diameter_m=0.04, epsilon=0.86, drop_height_m=2.0, dt_s=2e-4)
    off = E.drop_test(parse_exported("ode", plain.text), plain.setup, 3, 1).apex_m[0, 1:]
    assert np.all(off / ex.setup.model.apex_heights_m[0, 1:] - 1 > 0.05)


#: The few libode declarations the compiled snippet needs (ODE 0.16, double precision; no libode-dev here).
ODE_DECLARATIONS = """
typedef double dReal; typedef dReal dVector3[4]; typedef dReal dMatrix3[12];
typedef struct dxWorld *dWorldID; typedef struct dxSpace *dSpaceID; typedef struct dxBody *dBodyID;
typedef struct dxGeom *dGeomID; typedef struct dxJoint *dJointID; typedef struct dxJointGroup *dJointGroupID;
typedef struct { int mode; dReal mu, mu2, rho, rho2, rhoN, bounce, bounce_vel, soft_erp, soft_cfm,
  motion1, motion2, motionN, slip1, slip2; } dSurfaceParameters;
typedef struct { dVector3 pos, normal; dReal depth; dGeomID g1, g2; int side1, side2; } dContactGeom;
typedef struct { dSurfaceParameters surface; dContactGeom geom; dVector3 fdir1; } dContact;
typedef struct { dReal mass; dVector3 c; dMatrix3 I; } dMass;
enum { dContactMu2 = 1, dContactFDir1 = 2, dContactBounce = 4, dContactSoftERP = 8, dContactSoftCFM = 16,
       dContactApprox1 = 0x7000 };
typedef void dNearCallback(void *, dGeomID, dGeomID);
int dInitODE2(unsigned); dWorldID dWorldCreate(void); dSpaceID dHashSpaceCreate(dSpaceID);
dJointGroupID dJointGroupCreate(int); dBodyID dBodyCreate(dWorldID);
void dMassSetSphereTotal(dMass *, dReal, dReal); void dBodySetMass(dBodyID, const dMass *);
dGeomID dCreateSphere(dSpaceID, dReal); void dGeomSetBody(dGeomID, dBodyID);
void dGeomSetPosition(dGeomID, dReal, dReal, dReal);
dGeomID dCreatePlane(dSpaceID, dReal, dReal, dReal, dReal); void dBodySetPosition(dBodyID, dReal, dReal, dReal);
int dCollide(dGeomID, dGeomID, int, dContactGeom *, int);
dJointID dJointCreateContact(dWorldID, dJointGroupID, const dContact *);
void dJointAttach(dJointID, dBodyID, dBodyID); dBodyID dGeomGetBody(dGeomID);
void dWorldSetGravity(dWorldID, dReal, dReal, dReal); void dSpaceCollide(dSpaceID, void *, dNearCallback *);
int dWorldStep(dWorldID, dReal); void dJointGroupEmpty(dJointGroupID);
const dReal *dBodyGetPosition(dBodyID); const dReal *dBodyGetLinearVel(dBodyID);
void dBodySetLinearVel(dBodyID, dReal, dReal, dReal);
void dBodyGetPointVel(dBodyID, dReal, dReal, dReal, dVector3); void dBodyAddForce(dBodyID, dReal, dReal, dReal);
"""


#: After each step of :func:`_compiled_drop`: print the bottom's height at each apex (3 at most).
APEX_PROBE_C = """{ const dReal *p = dBodyGetPosition(ball), *v = dBodyGetLinearVel(ball);
      if (prev_v > 0 && v[2] <= 0) { k++; printf("%.9f\\n", p[2] - {R}); }
      prev_v = v[2]; }"""


def _compiled_drop(tmp_path, params, setup_c, *, callback_edit=None, probe_c=None, n_steps=None):
    """Compile the exported C snippet into a drop of its ball on a plane and run it: apex heights [m].

    ``callback_edit(text)`` edits the near callback (as a user sets mu); ``probe_c`` replaces the
    apex probe run after each step (it prints what the test reads) and ``n_steps`` the steps run.
    """
    import os
    import shutil
    import subprocess
    from ctypes.util import find_library

    from vrcal.engines.ode_ctypes import load_ode

    cc = shutil.which("cc") or shutil.which("gcc")
    lib = getattr(load_ode(), "_name", None) or find_library("ode")
    if not cc or not lib:
        pytest.skip("no C compiler or libode to compile the snippet")
    lib = lib if os.path.isabs(lib) else f"-l:{lib}"
    snippet, ball = params["snippet"], params["ball"]
    callback, _, rest = snippet.partition("/* world:")
    callback = callback_edit(callback) if callback_edit else callback
    gravity, _, each_step = ("/* world:" + rest).partition("/* each step: */")
    R, H, m = ball["radius_m"], ball["drop_height_m"], ball["mass_kg"]
    source = f"""#include <stdio.h>
#include <math.h>
{ODE_DECLARATIONS}
static dWorldID world; static dSpaceID space; static dJointGroupID contact_group;
static dGeomID ball_geom, ball2_geom; static dBodyID ball;
static void your_near_callback(void *data, dGeomID o1, dGeomID o2) {{ (void)data; (void)o1; (void)o2; }}
{callback}
int main(void) {{
  dMass mass; int i, k = 0; double prev_v = -1;
  dInitODE2(0); world = dWorldCreate(); space = dHashSpaceCreate(0); contact_group = dJointGroupCreate(0);
  ball = dBodyCreate(world); dMassSetSphereTotal(&mass, {m}, {R}); dBodySetMass(ball, &mass);
  ball_geom = dCreateSphere(space, {R}); dGeomSetBody(ball_geom, ball); dCreatePlane(space, 0, 0, 1, 0);
  dBodySetPosition(ball, 0, 0, {H} + {R});
  {setup_c}
  {gravity}
  for (i = 0; i < {n_steps or int(4.0 / params["world"]["dt"])} && k < 3; i++) {{
    {each_step}
    {probe_c or APEX_PROBE_C.replace("{R}", str(R))}
  }}
  return 0;
}}
"""
    (tmp_path / "drop.c").write_text(source)
    exe = tmp_path / "drop"
    subprocess.run([cc, "-O1", "-o", str(exe), str(tmp_path / "drop.c"), lib, "-lm"], check=True, capture_output=True)
    out = subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout
    return np.array([float(x) for x in out.split()])


def test_the_compiled_speed_law_callback_bounces_by_the_relative_normal_speed(write_discover, tmp_path):
    """The snippet compiled against libode: a ball dropped at rest follows eps(v); thrown down onto the
    plane faster than the law allows (eps(v) < 0), its bounce is clamped to 0, not negative."""
    require_engine("ode")
    path = write_discover(effects={"velocity_dependent_restitution": {"exponent": 0.6}}, epsilon=0.59,
                          mass_kg=0.16, diameter_m=0.072, drop_height_m=1.0)
    ex = export(None, "ode", from_json=path, dt_s=2e-4)
    params = parse_exported("ode", ex.text)
    assert "dBodyGetPointVel(dGeomGetBody(o2)" in params["snippet"]     # relative to the other body
    apexes = _compiled_drop(tmp_path, params, "")
    model = ex.setup.model.apex_heights_m[0]
    ratios = np.sqrt(apexes / np.concatenate([[ex.setup.drop_height_m], apexes[:-1]]))
    assert np.allclose(ratios, np.sqrt(model[1:4] / model[0:3]), atol=0.005)
    # eps(v) = 1 - 0.41 (v / 4.43)^0.6 < 0 above 19.5 m/s: thrown down at 25 m/s the ball stays down
    apexes = _compiled_drop(tmp_path, params, "dBodySetLinearVel(ball, 0, 0, -25.0);")
    assert apexes.size == 0 or apexes[0] < 0.01


@pytest.mark.parametrize("direction", [(1.0, 0.0), (2 ** -0.5, 2 ** -0.5)])
def test_the_compiled_callback_gives_coulombs_friction_on_a_diagonal_slip(tmp_path, direction):
    """With the user's mu set in the pasted callback, a ball slid at 4 m/s along the floor slows by
    mu g while it slips (Coulomb: mu N against the slip), whatever the slip's direction, and ends
    rolling at 5/7 of it. ODE's own friction axes cap each at mu N, so a diagonal slip got up to
    1.41 mu N (3.17 m/s after 0.2 s, not 3.41); the snippet now sets fdir1 along the slip."""
    require_engine("ode")
    params = json.loads(export("basketball", "ode").text)
    R, mu, g = params["ball"]["radius_m"], 0.3, -params["world"]["gravity"][2]
    assert "dContactFDir1" in params["snippet"]

    def set_mu(callback):
        assert "c[i].surface.mu = 0.0;" in callback
        return callback.replace("c[i].surface.mu = 0.0;", f"c[i].surface.mu = {mu};")

    vx, vy = 4.0 * direction[0], 4.0 * direction[1]
    start = f"dBodySetPosition(ball, 0, 0, {R}); dBodySetLinearVel(ball, {vx}, {vy}, 0);"
    probe = ('if (i == 199 || i == 1999) { const dReal *v = dBodyGetLinearVel(ball); '
             'printf("%.9f\\n%.9f\\n", v[0], v[1]); }')
    v = _compiled_drop(tmp_path, params, start, callback_edit=set_mu, probe_c=probe, n_steps=2000).reshape(2, 2)
    sliding, rolling = np.hypot(*v.T)
    assert sliding == pytest.approx(4.0 - mu * g * 0.2, abs=0.02)         # still slipping at 0.2 s
    assert rolling == pytest.approx(4.0 * 5 / 7, abs=0.02)                # rolling: 5/7 v0 (I = 2/5 m R^2)
    assert np.allclose(v / np.hypot(*v.T)[:, None], direction, atol=1e-6)  # along the slip it was thrown in


@pytest.mark.parametrize("floor", [None, "x=0.005,v=0.3"])
def test_the_compiled_pair_callback_gives_each_pair_its_own_epsilon(tmp_path, floor):
    """``--against``: pasted as it is, the near callback bounces the basketball off a (fixed) tennis
    ball with the pair's 0.5707 of Eq. 6, not the basketball's 0.7662 (an earlier snippet set that on
    every contact of ball_geom), the basketball off the floor with its own, the tennis ball with its own.
    On a soft ``--floor`` each ball's floor pair carries the floor's epsilon too (Eq. 6; 'pairs' and the
    callback had the balls' rigid-floor 0.766 and 0.745, where the target was 0.7411)."""
    require_engine("ode")
    from vrcal.inverse import pair

    params = json.loads(export("basketball", "ode", against="tennis", floor=floor).text)
    pairs, H = params["pairs"], params["ball"]["drop_height_m"]
    on = (lambda ball: pair(ball, floor)["epsilon"]) if floor else (lambda ball: pair(ball, "x=0,v=1")["epsilon"])
    assert pairs["basketball/floor"] == pytest.approx(on("basketball"), rel=1e-9)     # vrcal pair's Eq. 6
    assert pairs["tennis/floor"] == pytest.approx(on("tennis"), rel=1e-9)
    assert pairs["basketball/floor"] == pytest.approx(params["target_epsilon"], rel=1e-12)
    assert f"{pairs['tennis/floor']:.6f}" in params["snippet"]
    R2, top = get_ball("tennis").radius_m, 0.5
    on_ball2 = _compiled_drop(tmp_path, params, f"ball2_geom = dCreateSphere(space, {R2}); "
                                                f"dGeomSetPosition(ball2_geom, 0, 0, {top - R2});") - top
    assert np.sqrt(on_ball2[0] / (H - top)) == pytest.approx(pairs["basketball/tennis"], abs=0.005)
    on_floor = _compiled_drop(tmp_path, params, f"ball2_geom = dCreateSphere(space, {R2}); "
                                                "dGeomSetPosition(ball2_geom, 5, 5, 5);")
    assert np.sqrt(on_floor[0] / H) == pytest.approx(pairs["basketball/floor"], abs=0.005)
    # the dropped body as the second ball (the callback's ball_geom parked far away)
    as_ball2 = _compiled_drop(tmp_path, params, "ball2_geom = ball_geom; ball_geom = dCreateSphere(space, 0.01); "
                                                "dGeomSetPosition(ball_geom, 5, 5, 5);")
    assert np.sqrt(as_ball2[0] / H) == pytest.approx(pairs["tennis/floor"], abs=0.005)


def test_a_step_that_passes_at_4_phases_is_confirmed_with_16():
    """A soft ball of one's own (200 g, 70 mm, epsilon 0.45 from 0.5 m) at 1 ms: ODE's worst error
    was 0.0099 over 4 contact phases, 0.0204 over 16 and 0.0229 over 64. The export ran 4 phases
    and accepted the step; it now confirms a pass with 16, refuses naming them, and the step it
    names passes over 16 phases when run."""
    require_engine("ode")
    import re

    from vrcal.engines.common import CONFIRM_PHASES
    from vrcal.engines.export import _run_in_engine, build_setup

    soft = dict(mass_kg=0.2, diameter_m=0.07, epsilon=0.45, drop_height_m=0.5)
    setup = build_setup(None, "ode", dt_s=1e-3, **soft)
    assert _run_in_engine(setup, "ode", 1e-3, 4).worst_error <= 0.01
    with pytest.raises(UsageError, match=r"^ODE at --dt 0\.001 s misses \(16 phases x 3 bounces\)") as info:
        export(None, "ode", dt_s=1e-3, **soft)
    dt_ok = float(re.search(r"--dt ([0-9.e-]+) meets both", str(info.value)).group(1))
    assert _run_in_engine(setup, "ode", dt_ok, CONFIRM_PHASES).worst_error <= 0.01


def test_verify_file_of_an_against_export_drops_the_second_ball_and_runs_the_pair(tmp_path):
    """The probe's bb_ode_against.json: PASSED with no word that the tennis ball's floor contact and the
    pair were not tested; then they were named 'not verified' (the file had no second body); now the
    file carries ball2 and the pair's contact, and both run in libode."""
    require_engine("ode")
    path = tmp_path / "bt.json"
    path.write_text(export("basketball", "ode", against="tennis").text)
    result = CliRunner().invoke(main, ["verify", "--engine", "ode", "--file", str(path)])
    assert result.exit_code == 0, result.output
    out = " ".join(result.output.split())
    assert "contacts verified: basketball/floor; ball2 (tennis)/floor (target 0.7449: worst error" in out
    assert "; basketball/tennis (the two balls head-on at 5.94 m/s, gravity off, 16 phase(s); Eq. 6 target " \
           "0.5707" in out
    assert "not verified" not in out
