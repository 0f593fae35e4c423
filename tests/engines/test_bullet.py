"""PyBullet: the exported changeDynamics / engine parameters and the snippet's vrcal_step in the real engine."""

import json
import re

import numpy as np
import pytest
from click.testing import CliRunner
from helpers import EPSILONS, require_engine

from vrcal.cli import main
from vrcal.engines import bullet as E
from vrcal.engines.common import CONFIRM_PHASES
from vrcal.engines.export import check_step, export, parse_exported
from vrcal.errors import UsageError


@pytest.mark.parametrize("eps", EPSILONS)
def test_exported_settings_reproduce_epsilon_in_pybullet(eps):
    require_engine("bullet")
    ex = export("basketball", "bullet", epsilon=eps, dt_s=5e-4)
    params = parse_exported("bullet", ex.text)
    assert params["changeDynamics"]["ball"]["restitution"] * params["changeDynamics"]["floor"]["restitution"] \
        == pytest.approx(eps)
    runs = E.drop_test(params, ex.setup, 3, 2)
    assert runs.worst_error < 0.005


def test_floor_restitution_multiplies():
    """A planted effect: Bullet multiplies the floor's restitution into the ball's."""
    require_engine("bullet")
    ex = export("basketball", "bullet", epsilon=0.85, dt_s=5e-4)
    params = parse_exported("bullet", ex.text)
    params["changeDynamics"]["floor"]["restitution"] = 0.5        # product rule: 0.85 * 0.5
    runs = E.drop_test(params, ex.setup, 1, 1)
    assert runs.velocity_ratios[0, 0] == pytest.approx(0.85 * 0.5, abs=0.005)


def test_pair_is_the_product_rule():
    data = json.loads(export("basketball", "bullet", against="tennis", dt_s=5e-4).text)
    cd = data["changeDynamics"]
    assert cd["ball"]["restitution"] * cd["ball2"]["restitution"] == pytest.approx(data["pair"]["epsilon"])
    assert "contactERP" not in data["setPhysicsEngineParameter"]          # the balls' own contacts: ERP 0
    for ball in ("ball", "ball2"):
        assert cd[ball]["contactProcessingThreshold"] == 0.0 and cd[ball]["contactStiffness"] == 0.0
        assert cd[ball]["contactDamping"] == E.CONTACT_DAMPING_N_S_PER_M
    assert cd["floor"] == {"restitution": 1.0}          # a pair takes the smaller processing threshold


def test_pybullets_default_step_is_refused_naming_one_that_works():
    """At Bullet's 1/240 s a basketball sinks up to 14 mm before its contact acts: refused, and the
    named step then passes in PyBullet."""
    require_engine("bullet")
    with pytest.raises(UsageError, match=r"bullet at --dt 0.00416667 s misses.*--dt ([0-9.e-]+) meets") as info:
        export("basketball", "bullet")
    dt_ok = float(re.search(r"--dt ([0-9.e-]+) meets", str(info.value)).group(1))
    ex = export("basketball", "bullet", dt_s=dt_ok)
    runs = E.drop_test(parse_exported("bullet", ex.text), ex.setup, 3, 4)
    assert runs.worst_error <= 0.01


def test_the_snippets_vrcal_step_carries_drag_and_eps_v(write_discover):
    """verify steps with the snippet's own vrcal_step: drag force and restitution at this speed."""
    require_engine("bullet")
    path = write_discover(effects={"air_drag": {"drag_coefficient": 0.4},
                                   "velocity_dependent_restitution": {"exponent": 0.3}}, drop_height_m=2.0)
    ex = export(None, "bullet", from_json=path, dt_s=5e-4)
    params = parse_exported("bullet", ex.text)
    assert "def vrcal_step(ball):" in params["snippet"] and "applyExternalForce" in params["snippet"]
    assert E.step_code(params) in params["snippet"]
    runs = E.drop_test(params, ex.setup, 3, 1)
    assert runs.worst_error < 0.01
    assert np.max(np.abs(runs.apex_relative_errors)) < 0.01


def test_only_the_balls_contacts_lose_their_error_reduction():
    """The export set contactERP 0 world-wide (setPhysicsEngineParameter) and its note read as if only the
    ball were affected: a 1 kg box dropped 0.3 m onto the floor stayed 7.78 mm in it for good (PyBullet's
    defaults: 0.01 mm), one started 5 mm deep stayed 5.03 mm deep. Now the ball's own contactStiffness 0
    and contactDamping make Bullet give the ball's contacts ERP 0 and no other's: the box rests at the
    surface as with PyBullet's defaults, the ball still meets the tolerance, and the notes say what is
    world-wide. erp (joints), frictionERP and contactERP stay the user's."""
    data = json.loads(export("basketball", "bullet", dt_s=1e-3).text)
    engine = data["setPhysicsEngineParameter"]
    assert not {"contactERP", "erp", "frictionERP"} & set(engine)
    assert "ERP" not in data["snippet"] and "erp" not in data["snippet"]
    notes = " ".join(data["notes"])
    assert "the world's contactERP, erp and frictionERP stay yours" in notes
    assert "world-wide (setPhysicsEngineParameter acts on every body): restitutionVelocityThreshold" in notes
    require_engine("bullet")
    ex = export("basketball", "bullet", dt_s=1e-3)
    params = parse_exported("bullet", ex.text)
    runs = E.drop_test(params, ex.setup, 3, 2)
    assert runs.worst_error < 0.01
    p = E._pybullet()
    for start_m, label in ((0.3, "dropped 0.3 m"), (-0.005, "started 5 mm deep")):
        cid = p.connect(p.DIRECT)
        try:       # the world and the floor as the snippet sets them; a box of the user's, left as it comes
            p.setPhysicsEngineParameter(physicsClientId=cid, **params["setPhysicsEngineParameter"])
            p.setGravity(*params["setGravity"], physicsClientId=cid)
            floor = p.createMultiBody(0, p.createCollisionShape(p.GEOM_PLANE, physicsClientId=cid), physicsClientId=cid)
            p.changeDynamics(floor, -1, physicsClientId=cid, **params["changeDynamics"]["floor"])
            box = p.createMultiBody(1.0, p.createCollisionShape(p.GEOM_BOX, halfExtents=[0.1, 0.1, 0.05],
                                                                physicsClientId=cid),
                                    basePosition=[0, 0, 0.05 + start_m], physicsClientId=cid)
            for _ in range(int(5 / params["setPhysicsEngineParameter"]["fixedTimeStep"])):
                p.stepSimulation(physicsClientId=cid)
            bottom = p.getBasePositionAndOrientation(box, physicsClientId=cid)[0][2] - 0.05
        finally:
            p.disconnect(cid)
        assert abs(bottom) < 1e-4, f"a 1 kg box {label} rests {bottom * 1e3:.2f} mm from the floor"


def test_vrcal_step_clamps_the_speed_law_to_0_1():
    """eps(v) = 1 - 0.5 (v / 5)^-1 is below 0 for v < 2.5 m/s and eps(v) = 1 - 0.5 (v / 5)^2 below 0
    above 7.1 m/s: the restitution vrcal_step sets stays in [0, 1]; the snippet says it takes |v_z|."""
    set_to = []

    class FakePyBullet:
        WORLD_FRAME = 2

        def __init__(self, vz):
            self.vz = vz

        def getBaseVelocity(self, ball):
            return (0.0, 0.0, self.vz), (0.0, 0.0, 0.0)

        def changeDynamics(self, ball, link, restitution):
            set_to.append(restitution)

        def stepSimulation(self):
            pass

    for exponent, vz in ((-1.0, -1.0), (2.0, -9.0), (0.5, -5.0)):
        params = {"restitution_law": {"epsilon_ref": 0.5, "reference_speed_m_per_s": 5.0, "exponent": exponent}}
        E.step_function(params, FakePyBullet(vz))(1)
    assert set_to == [0.0, 0.0, pytest.approx(0.5)]
    assert "z-up floor" in E.step_code(params)


# A soft ball of a user's own: its third impact is at 0.63 m/s and rises 4 mm
# (benchmarks/bench_step_monotonic.py, benchmarks/bench_bullet_slop.py).
SOFT = dict(mass_kg=0.2, diameter_m=0.07, epsilon=0.45, drop_height_m=0.5)


def _passes(setup, dt, n_phases=CONFIRM_PHASES):
    from dataclasses import replace

    from vrcal.engines.export import _depth, _run_in_engine

    runs = _run_in_engine(replace(setup, dt_s=dt), "bullet", dt, n_phases)
    return runs.worst_error <= setup.tolerance and _depth(runs) <= setup.penetration_limit_m


def test_the_slow_bounce_keeps_its_restitution_at_small_steps():
    """PyBullet's contact slop (1e-5 m) counted a ball less deep than that as apart and took
    (slop - depth) / dt off its rebound: the soft ball's third bounce (0.63 m/s) lost up to 0.11
    of epsilon 0.45 at 0.1 ms. The export sets contactSlop 0 and the bounce holds; planted back,
    the slop takes the bounce again."""
    require_engine("bullet")
    from dataclasses import replace

    from vrcal.engines.export import build_setup

    setup = replace(build_setup(None, "bullet", **SOFT), dt_s=1e-4)
    params = E.export_params(setup)
    assert params["setPhysicsEngineParameter"]["contactSlop"] == 0.0
    assert "'contactSlop': 0.0" in E.py_snippet(params)
    runs = E.drop_test(params, setup, 3, 2)
    assert runs.worst_error < 0.005
    assert np.max(np.abs(runs.velocity_ratios[:, 2] - 0.45)) < 0.005
    params["setPhysicsEngineParameter"]["contactSlop"] = E.PYBULLET_CONTACT_SLOP_M
    assert E.drop_test(params, setup, 3, 2).worst_error > 0.03


def test_a_refusal_names_only_steps_it_ran_and_says_passing_is_not_monotonic():
    """Every step named was run: the one that meets both passes when run (16 phases), the larger
    ones named as missed miss."""
    require_engine("bullet")
    with pytest.raises(UsageError) as info:
        export(None, "bullet", **SOFT)                               # Bullet's own step, 1/240 s
    message = str(info.value)
    # the miss over the 16 phases the limits offered are confirmed over (it said 4 phases, 11.3 mm, and offered
    # --max-penetration 0.014 for the 13.1 mm of 16)
    assert message.startswith("bullet at --dt 0.00416667 s misses (16 phases x 3 bounces)")
    turns = float(re.search(r"the ball turns ([0-9.]+) mm", message).group(1))
    offered = float(re.search(r"--max-penetration ([0-9.]+)$", message).group(1))
    assert turns <= 1e3 * offered < 1.1 * turns
    assert "not monotonic in the step" in message and "\n" not in message
    dt_ok = float(re.search(r"--dt ([0-9.e-]+) meets both \(run in bullet", message).group(1))
    missed = [float(x) for x in re.search(r"; ([0-9.e, and-]+) s missed", message).group(1).replace(" and", ",")
              .split(", ")]
    setup = export(None, "bullet", dt_s=dt_ok, **SOFT).setup        # exported at the named step
    assert _passes(setup, dt_ok) and not any(_passes(setup, dt) for dt in missed)
    assert all(dt > dt_ok for dt in missed)


def test_a_step_that_passes_at_4_phases_is_confirmed_with_16():
    """At 0.77 ms the soft ball's worst error in PyBullet is 0.0069 over 4 contact phases and
    0.0127 over 16 (and 64): the export ran 4 and accepted the step; it now confirms with 16 and
    refuses, naming the 16."""
    require_engine("bullet")
    from vrcal.engines.export import _run_in_engine, build_setup

    setup = build_setup(None, "bullet", dt_s=7.7e-4, **SOFT)
    assert _run_in_engine(setup, "bullet", 7.7e-4, 4).worst_error <= 0.01      # 4 phases: a pass
    with pytest.raises(UsageError, match=r"^bullet at --dt 0\.00077 s misses \(16 phases x 3 bounces\): "
                                         r"worst epsilon error 0\.0127"):
        check_step(setup, "bullet")


def test_small_steps_pass_in_bullet_as_the_bound_says():
    """With the slop the soft ball missed at 0.2 ms (0.0118) where the step bound said 0.0069; without
    it PyBullet keeps within the bound there (measured 0.0041 over 16 phases) and the step is exported."""
    require_engine("bullet")
    from vrcal.engines.export import step_bound

    ex = export(None, "bullet", dt_s=2e-4, **SOFT)
    note = json.loads(ex.text)["how_chosen"]
    assert any(n.startswith("step 0.0002 s checked in bullet (16 phases x 3 bounces)") for n in note)
    runs = E.drop_test(parse_exported("bullet", ex.text), ex.setup, 3, 4)
    assert runs.worst_error <= step_bound(ex.setup, "bullet")[0]


def test_the_pasted_snippet_sets_the_second_ball_too():
    """``--against tennis``: the snippet, pasted as bullet.md says (ball, ball2 and floor are the
    user's bodies), gives the head-on basketball/tennis contact the pair's 0.5707 of Eq. 6. The
    snippet set ball and floor only: the tennis ball kept Bullet's restitution 0 and the pair
    bounced at 0.0000 at every speed."""
    require_engine("bullet")
    p = E._pybullet()
    data = json.loads(export("basketball", "bullet", against="tennis", dt_s=5e-4).text)
    assert "changeDynamics(ball2" in data["snippet"]
    cid = p.connect(p.DIRECT)
    try:
        bp = E._Bound(p, cid)
        (M1, R1), (M2, R2) = (data["ball"]["mass_kg"], data["ball"]["radius_m"]), (0.057, 0.0335)
        ball = bp.createMultiBody(M1, bp.createCollisionShape(p.GEOM_SPHERE, radius=R1), basePosition=[0, 0, 2])
        ball2 = bp.createMultiBody(M2, bp.createCollisionShape(p.GEOM_SPHERE, radius=R2),
                                   basePosition=[R1 + R2 + 0.01, 0, 2])
        floor = bp.createMultiBody(0, bp.createCollisionShape(p.GEOM_PLANE))
        code = data["snippet"].replace("import pybullet as p\np.connect(p.DIRECT)\n", "")
        exec(compile(code, "<snippet>", "exec"), {"p": bp, "ball": ball, "ball2": ball2, "floor": floor})  # noqa: S102
        bp.setGravity(0, 0, 0)                                     # head-on, no gravity
        v_rel = 3.0
        bp.resetBaseVelocity(ball, [v_rel * M2 / (M1 + M2), 0, 0])
        bp.resetBaseVelocity(ball2, [-v_rel * M1 / (M1 + M2), 0, 0])
        for _ in range(100):
            bp.stepSimulation()
        e = (bp.getBaseVelocity(ball2)[0][0] - bp.getBaseVelocity(ball)[0][0]) / v_rel
    finally:
        p.disconnect(cid)
    assert e == pytest.approx(data["pairs"]["basketball/tennis"], abs=0.01)


def test_an_impact_speed_range_not_reached_is_said_with_what_the_engine_does_there():
    """``--impact-speed 0.3:4 --bounces 2``: the bounce chain stops at 3.2 m/s; the terminal names the
    part not covered and the error measured at 0.3 m/s (PyBullet's step-phase error there, above the
    tolerance), and the file's notes the speeds it was checked over."""
    require_engine("bullet")
    result = CliRunner().invoke(main, ["export", "--mass", "5", "--diameter", "0.2", "--epsilon", "0.9",
                                       "--impact-speed", "0.3:4", "--bounces", "2", "--engine", "bullet",
                                       "--dt", "1e-3"])
    assert result.exit_code == 0, result.output
    said = " ".join(result.stderr.split())
    m = re.search(r"covers 4\.\.([0-9.]+) m/s, not down to 0\.3 m/s; measured below it: holds down to "
                  r"([0-9.]+) m/s; at 0\.3 m/s one bounce is off by ([0-9.]+) \((MISSES|within)", said)
    assert m, said
    data = json.loads(result.stdout)
    assert any(n.startswith("checked over impact speeds 4..") for n in data["notes"])
    assert float(m.group(3)) > 0 and (m.group(4) == "MISSES") == (float(m.group(3)) > 0.01)


@pytest.mark.parametrize("engine, dt", [("bullet", 1 / 240), ("ode", 0.005)])
def test_a_refusal_names_the_limits_that_keep_the_users_step(engine, dt):
    """A lacrosse ball (145 g, 63.5 mm, epsilon 0.7219 from 1.199 m) at PyBullet's 240 Hz was refused naming
    a smaller step only; a robot's fixed step cannot change: the refusal names --tolerance and
    --max-penetration that accept the user's step (measured over the 16 phases an export confirms with),
    and the export with them passes."""
    require_engine(engine)
    lacrosse = dict(mass_kg=0.145, diameter_m=0.0635, epsilon=0.7218670880622122, drop_height_m=1.1987817632818059,
                    dt_s=dt)
    with pytest.raises(UsageError) as info:
        export(None, engine, **lacrosse)
    found = re.search(r"; to keep --dt [0-9.]+ s, accept what it achieves: --tolerance ([0-9.]+) "
                      r"--max-penetration ([0-9.]+)$", str(info.value))
    assert found, str(info.value)
    tolerance, depth = float(found.group(1)), float(found.group(2))
    assert 0.01 < tolerance < 0.02 and 0.0159 < depth < lacrosse["diameter_m"] / 2
    ex = export(None, engine, tolerance=tolerance, max_penetration_m=depth, **lacrosse)
    assert f"step {dt:g} s checked in" in " ".join(ex.setup.notes)


def test_a_clay_ball_that_does_not_rebound_at_bullets_step_is_refused_in_one_line():
    """Clay (epsilon 0.1, 50 g, 40 mm) from 1 m at Bullet's 1/240 s turns back inside the floor in some
    contact phases: once a traceback (NaN worst error into round_down), now a refusal saying so and
    naming a step that was run and passes."""
    require_engine("bullet")
    result = CliRunner().invoke(main, ["export", "--mass", "0.05", "--diameter", "0.04", "--epsilon", "0.1",
                                       "--drop-height", "1", "--engine", "bullet", "--bounces", "1"])
    assert result.exit_code != 0 and result.exception is None or isinstance(result.exception, SystemExit)
    line = result.output.strip()
    assert "\n" not in line and "Traceback" not in line
    assert re.search(r"does not rebound at this step .*contact phases\).*--dt ([0-9.e-]+) meets both", line), line
    dt_ok = float(re.search(r"--dt ([0-9.e-]+) meets both", line).group(1))
    ex = export(None, "bullet", epsilon=0.1, mass_kg=0.05, diameter_m=0.04, drop_height_m=1, n_bounces=1, dt_s=dt_ok)
    assert "checked in bullet" in ex.setup.notes[-1]


def test_a_step_at_which_bullet_adds_energy_fails_whatever_the_tolerance():
    """A superball of epsilon 0.9995 (25 g, 35 mm) from 1 m at 1 ms: PyBullet reverses the speed after the
    step's gravity (e (u + g dt)), v_out/v_in 1.0017: once within the tolerance 0.01 and PASSED while the
    ball climbed every bounce; now export refuses it, naming a step that adds none, and verify fails it."""
    require_engine("bullet")
    ball = dict(epsilon=0.9995, mass_kg=0.025, diameter_m=0.035, drop_height_m=1.0)
    with pytest.raises(UsageError, match=r"adds energy: v_out/v_in reaches 1\.00[0-9]+ > 1.*whatever the "
                                         r"tolerance.*--dt ([0-9.e-]+) meets both") as info:
        export(None, "bullet", dt_s=1e-3, tolerance=0.05, **ball)
    dt_ok = float(re.search(r"--dt ([0-9.e-]+) meets both", str(info.value)).group(1))
    text = export(None, "bullet", dt_s=dt_ok, **ball).text
    from vrcal.engines.verify import format_report, verify

    at_own = verify(engine="bullet", exported_text=text, n_phases=4)
    assert at_own.passed and at_own.runs.gain is None
    coarse = verify(engine="bullet", exported_text=text, dt_s=1e-3, tolerance=0.05, n_phases=4)
    assert coarse.error < 0.05 and not coarse.passed
    assert coarse.failure().startswith("the engine adds energy") and "adds energy" in format_report(coarse)


def test_the_notes_carry_no_number_measured_for_another_target():
    """The notes said 'Bullet's defaults give step-phase dependent epsilon (0.16..0.87 for a target of 0.85)'
    whatever the target (a canned measurement, e.g. in a file for 0.775): that line holds no number now."""
    from vrcal.engines.export import build_setup

    setup = build_setup(None, "bullet", 0.775, 5e-4, mass_kg=0.6, diameter_m=0.24, drop_height_m=1.0)
    notes = " ".join(E.export_params(setup)["notes"])
    assert "target of 0.85" not in notes and "0.16..0.87" not in notes
    assert "depends on where in its step the contact falls" in notes
