"""A robotics engineer's own ball at their own step (probe PN): the largest step a refusal names, the limits
it offers, an export from one record, PyBullet's substeps, a depth beyond the radius, one's own drop test."""

import json
import math
import re

import numpy as np
import pytest
from click.testing import CliRunner
from helpers import require_engine

from vrcal.cli import main
from vrcal.engines.export import build_setup

#: Probe PN's rubber ball: 58 g, 62 mm, epsilon sqrt(0.71/1.2), dropped from 1.2 m.
BALL = ["--mass", "0.058", "--diameter", "0.062", "--epsilon", "0.7692", "--drop-height", "1.2"]

#: The discover result of probe PN's record (rubber_disc.json): one drop from 1.2 m, 5 bounces down to
#: 1.79 m/s, air drag C_d 0.505 and epsilon(v) = 1 - (1 - 0.7693)(v / v_1)^0.2.
RECORD = dict(name="ball", mass_kg=0.058, diameter_m=0.062, epsilon=0.769290364, drop_height_m=1.2000499538,
              effects={"air_drag": {"drag_coefficient": 0.5050431778},
                       "velocity_dependent_restitution": {"exponent": 0.1997558996}},
              runs=[{"kind": "trajectory", "label": "", "n": 756, "source": "rubber_rec.csv",
                     "release": {"drop_height_m": 1.2000499538, "release_time_s": 0.1999666195}}],
              impact_speed_range_m_per_s=[1.7920571811, 4.8057812852], noise_floor=0.000519)


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def _named_step(message):
    return float(re.search(r"--dt ([0-9.e-]+) meets", " ".join(message.split())).group(1))


def test_refine_step_bisects_to_its_resolution():
    """Between 0.0025 (passes) and 0.0031 (misses), a step that passes up to 0.003 s: 0.003, with 0.0031 the
    miss above it, at a resolution of 0.0001 s (at most 5 % of the step)."""
    from vrcal.engines.common import refine_step, step_resolution_s

    assert step_resolution_s(0.0025) == pytest.approx(1e-4) and step_resolution_s(0.0019) == pytest.approx(1e-5)
    tried = []

    def passes(dt):
        tried.append(dt)
        return dt <= 0.003 + 1e-12, dt

    dt, result, miss = refine_step(passes, 0.0025, "first", 0.0031)
    assert (dt, result, miss) == (0.003, 0.003, 0.0031) and len(tried) <= 3
    # from the user's own step: at most log2 of the span in resolutions
    dt, _, miss = refine_step(passes, 0.0025, None, 0.01)
    assert dt == 0.003 and miss - dt <= step_resolution_s(dt) * (1 + 1e-9)


@pytest.mark.parametrize("engine, dt", [("mujoco", "0.01"), ("ode", "0.01")])
def test_the_step_a_refusal_names_passes_and_one_a_tenth_larger_is_refused(engine, dt, tmp_path):
    """Probe PN: MuJoCo at 0.01 s named 0.0025 s where 0.003 s exports (ODE: 0.0014 where 0.00159 does); the
    search now bisects between the largest grid step that passed and the smallest that missed. The step
    named exports, one 10 % larger is refused."""
    require_engine(engine)
    refused = run("export", *BALL, "--engine", engine, "--dt", dt)
    assert refused.exit_code == 2
    named = _named_step(refused.output)
    assert named > {"mujoco": 0.0025, "ode": 0.0014}[engine]
    ok = run("export", *BALL, "--engine", engine, "--dt", named, "-o", tmp_path / f"ok.{engine}")
    assert ok.exit_code == 0, ok.output
    larger = float(f"{1.1 * named:.2g}")
    assert run("export", *BALL, "--engine", engine, "--dt", larger, "-o", tmp_path / "no").exit_code == 2
    if engine == "mujoco":        # the trade-off table's last row is the same step
        table = run("export", *BALL, "--engine", "mujoco", "--dt", dt, "--trade-off")
        assert f"the largest step that meets both: --dt {named:g}" in table.output


@pytest.mark.parametrize("engine", ["mujoco", "gazebo"])
def test_the_tolerance_a_speed_law_refusal_offers_is_accepted(engine, write_discover, tmp_path):
    """Probe PN: a speed law MuJoCo's one constant cannot follow within 0.01 offered '--tolerance 0.012' (half
    the spread, 0.0115, rounded up), which the export then refused (worst error 0.0124). The offer is now
    checked by the engine's own export at it: given, it is accepted."""
    require_engine("mujoco" if engine == "mujoco" else "ode")
    path = write_discover(**RECORD)
    refused = run("export", "--from", path, "--engine", engine, "--bounces", "3")
    assert refused.exit_code == 2
    text = " ".join(refused.output.split())
    offer = re.search(r"(--tolerance [0-9.]+(?: --max-penetration [0-9.]+)?) \(checked", text).group(1).split()
    assert float(offer[1]) > 0.0115
    ok = run("export", "--from", path, "--engine", engine, "--bounces", "3", *offer, "-o", tmp_path / "ok")
    assert ok.exit_code == 0, ok.output


def test_an_export_from_one_record_covers_its_bounces(write_discover):
    """Probe PN: a record of 5 bounces down to 1.79 m/s was exported over 3 (down to 2.84 m/s); one drop is
    now covered as a table of drops is, and ODE and PyBullet are judged on its heights too."""
    path = write_discover(**RECORD)
    setup = build_setup(None, "ode", from_json=path)
    speeds = setup.impact_speeds_m_per_s
    assert setup.n_bounces == 5 and float(speeds[-1]) <= 1.7921 * (1 + 1e-6) < float(speeds[-2])
    assert any(n.startswith("the discover result's record: one drop, impacts 4.81..1.79 m/s; exported with 5 "
                            "bounce(s)") for n in setup.notes)
    assert setup.apex_goal == 0.03 and setup.apex_floor_m == pytest.approx(3 * 0.000519)
    assert build_setup(None, "mujoco", from_json=path).apex_goal is None      # one constant: not judged
    assert build_setup(None, "ode", from_json=path, n_bounces=3).n_bounces == 3


def test_pybullet_judged_on_the_records_heights_and_verify_says_what_it_checked(write_discover, tmp_path):
    """Probe PN: PyBullet at 1/960 s passed verify (per-bounce error <= 0.0047) while the record's 5th rebound
    was 3.0 % high (the error is one-sided and compounds). A file from a record carries the apex goal and
    verify judges it; a file without it says its PASS is per bounce and names --against."""
    require_engine("bullet")
    path = write_discover(**RECORD)
    out = tmp_path / "b.json"
    assert run("export", "--from", path, "--engine", "bullet", "--dt", 1 / 960, "--bounces", 3,
               "-o", out).exit_code == 0
    doc = json.loads(out.read_text())
    assert doc["target"]["apex_goal"] == 0.03
    judged = run("verify", "--engine", "bullet", "--file", out, "--phases", 2)
    assert judged.exit_code == 0 and "goal within 3 % or 1.56 mm (judged" in judged.output
    del doc["target"]["apex_goal"]
    plain = tmp_path / "plain.json"
    plain.write_text(json.dumps(doc))
    said = run("verify", "--engine", "bullet", "--file", plain, "--phases", 2)
    text = " ".join(said.output.split())
    assert said.exit_code == 0 and "not judged: the verdict checks each bounce's epsilon" in text
    assert "vrcal verify --from RESULT.json --against RECORD --engine bullet --file FILE" in text


def test_an_apex_beyond_the_goal_fails_where_each_bounce_passes():
    """DropRuns: each bounce 0.004 high (within 0.01) compounds to a 5th rebound more than 3 % high."""
    from vrcal.engines.common import DropRuns

    n = 5
    target = 0.78 ** (2 * np.arange(n + 1))[None, :] * np.ones((2, 1))
    engine = target * (1.004 ** (2 * np.arange(n + 1)))[None, :]
    ratios = np.sqrt(target[:, 1:] / target[:, :-1])
    runs = DropRuns(np.zeros(2), ratios + 0.004, ratios + 0.004, ratios, ratios, engine, target, np.zeros((2, n)))
    assert runs.worst_error == pytest.approx(0.004)
    assert runs.apex_miss(0.03) and not runs.apex_miss(None) and not runs.apex_miss(0.03, floor_m=1.0)
    assert runs.worst_apex()[:2] == (5, pytest.approx(1.004 ** 10 - 1))


def test_pybullets_substeps_are_run_as_the_file_sets_them(tmp_path):
    """Probe PN: the snippet hard-coded numSubSteps 0, so a file exported at 1/960 s and pasted into a world
    stepping 1/240 s with 4 substeps changed what each stepSimulation() advances. --substeps 4 at 1/240 s
    writes fixedTimeStep 1/240 and numSubSteps 4 and is checked at 1/960 s: the same numbers as --dt 1/960.
    The check steps one by one (every step sampled): the positions are PyBullet's own with its substeps, the
    snippet's drag and restitution law included."""
    require_engine("bullet")
    from dataclasses import replace

    from vrcal.engines import bullet as B

    sub, plain = tmp_path / "sub.json", tmp_path / "plain.json"
    assert run("export", *BALL, "--engine", "bullet", "--substeps", 4, "-o", sub).exit_code == 0
    assert run("export", *BALL, "--engine", "bullet", "--dt", 1 / 960, "-o", plain).exit_code == 0
    a, b = json.loads(sub.read_text()), json.loads(plain.read_text())
    assert a["setPhysicsEngineParameter"]["fixedTimeStep"] == pytest.approx(1 / 240)
    assert a["setPhysicsEngineParameter"]["numSubSteps"] == 4 and "'numSubSteps': 4" in a["snippet"]
    checked = [next(n for n in d["how_chosen"] if n.startswith("step ")) for d in (a, b)]
    assert checked[0].split("checked in")[1] == checked[1].split("checked in")[1]
    assert "(--dt 0.00416667 s --substeps 4)" in checked[0]
    # the step-by-step run against PyBullet's own substeps, with the snippet (drag, law)
    setup = replace(build_setup(None, "bullet", mass_kg=0.058, diameter_m=0.062, epsilon=0.7692, drop_height_m=1.2,
                                dt_s=1 / 240, substeps=4), drag_coefficient=0.5, restitution_exponent=0.2)
    params = B.export_params(setup)
    z, _, dt, _ = B.run_drop(params, 1.2, 1.5)
    assert dt == pytest.approx(1 / 960)
    p = B._pybullet()
    cid = p.connect(p.DIRECT)
    try:
        p.setPhysicsEngineParameter(physicsClientId=cid, **params["setPhysicsEngineParameter"])
        p.setGravity(*params["setGravity"], physicsClientId=cid)
        floor = p.createMultiBody(0, p.createCollisionShape(p.GEOM_PLANE, physicsClientId=cid), physicsClientId=cid)
        ball = p.createMultiBody(0.058, p.createCollisionShape(p.GEOM_SPHERE, radius=0.031, physicsClientId=cid),
                                 basePosition=[0, 0, 1.2 + 0.031], physicsClientId=cid)
        p.changeDynamics(ball, -1, physicsClientId=cid, **params["changeDynamics"]["ball"])
        p.changeDynamics(floor, -1, physicsClientId=cid, **params["changeDynamics"]["floor"])
        step = B.step_function(params, B._Bound(p, cid))
        own = []
        for _ in range((len(z) - 1) // 4):
            step(ball)
            own.append(p.getBasePositionAndOrientation(ball, physicsClientId=cid)[0][2] - 0.031)
    finally:
        p.disconnect(cid)
    assert np.min(z) < 0 and np.max(np.abs(np.array(own) - z[4::4])) < 1e-12
    # verify runs the file's substeps, or others
    assert run("verify", "--engine", "bullet", "--file", sub, "--phases", 2, "--bounces", 1).exit_code == 0
    other = run("verify", "--engine", "bullet", "--file", sub, "--phases", 2, "--bounces", 1, "--substeps", 1)
    said = " ".join(other.output.split())
    assert "run with --substeps 1: a step of 0.00416667 s; the file's numSubSteps is 4" in said


def test_too_few_substeps_are_refused_naming_a_count_that_passes(tmp_path):
    """--substeps 2 at 1/240 s turns the ball 9.9 mm deep (limit 7.75 mm): the refusal names the fewest
    substeps of the user's 1/240 s that pass, found in PyBullet, and that count exports."""
    require_engine("bullet")
    refused = run("export", *BALL, "--engine", "bullet", "--substeps", 2, "--bounces", 2)
    assert refused.exit_code == 2
    text = " ".join(refused.output.split())
    assert "at --dt 0.00416667 s --substeps 2 misses" in text
    count = int(re.search(r"--dt 0.00416667 --substeps (\d+) meets both", text).group(1))
    assert f"--substeps {count - 1} missed" in text
    assert run("export", *BALL, "--engine", "bullet", "--substeps", count, "--bounces", 2,
               "-o", tmp_path / "ok.json").exit_code == 0
    assert run("export", *BALL, "--engine", "ode", "--substeps", 2).exit_code == 2


def test_a_depth_beyond_the_radius_still_states_what_the_step_gives():
    """Probe PN: ODE at 0.01 s was refused with 'no --max-penetration keeps --dt 0.01 s' and no word of what a
    user whose step is fixed gets: the refusal states the error and depth measured there and what it means."""
    require_engine("ode")
    refused = run("export", *BALL, "--engine", "ode", "--dt", "0.01")
    text = " ".join(refused.output.split())
    assert refused.exit_code == 2
    assert "no --max-penetration keeps --dt 0.01 s: the ball turns 47.3 mm from the floor, beyond its radius 31 mm" \
        in text
    assert "its centre passes the floor's surface" in text and "can pass through it" in text
    assert "at --dt 0.01 s the drop test measured worst epsilon error 0.0138 (--tolerance 0.014 accepts it)" in text


def test_ones_own_drop_test_exports_through_fits_reading_of_it(tmp_path):
    """Probe PN: export had no --rebound-height (fit has). H 1.2 m, h 0.71 m gives epsilon sqrt(0.71/1.2) =
    0.7692 and drops the ball from 1.2 m; heights read to the top are brought to the bottom as fit does."""
    require_engine("ode")
    outs = []
    for k, heights in enumerate((["--drop-height", 1.2, "--rebound-height", 0.71],
                                 ["--drop-height", 1.262, "--rebound-height", 0.772, "--drop-measured-to", "top",
                                  "--rebound-measured-to", "top"])):
        out = tmp_path / f"own{k}.json"
        result = run("export", "--mass", 0.058, "--diameter", 0.062, *heights, "--engine", "ode", "-o", out)
        assert result.exit_code == 0, result.output
        outs.append(json.loads(out.read_text()))
    for doc in outs:
        assert doc["target_epsilon"] == pytest.approx(math.sqrt(0.71 / 1.2))
        assert doc["target"]["drop_height_m"] == pytest.approx(1.2)
        assert "your drop test" in doc["how_chosen"][0]
    fit = run("fit", "--mass", 0.058, "--diameter", 0.062, "--drop-height", 1.262, "--rebound-height", 0.772,
              "--drop-measured-to", "top", "--rebound-measured-to", "top")
    assert "0.7692" in fit.output
    for bad, words in ((["--drop-height", 1.2, "--rebound-height", 0.71, "--epsilon", 0.7], "leave out --epsilon"),
                       (["--rebound-height", 0.71], "needs the --drop-height"),
                       (["--drop-height", 1, "--drop-measured-to", "top", "--epsilon", 0.7], "give --rebound-height")):
        result = run("export", "--mass", 0.058, "--diameter", 0.062, *bad, "--engine", "ode")
        assert result.exit_code == 2 and words in result.output and len(result.output.strip().splitlines()) == 1
