"""A robotics engineer's own ball at their own step: refusals rest on runs in the engine, tables
need no drop height and refuse what they cannot use, notes name only the effects a result has,
and the trade-off table ends with the step to use."""

import json
import re
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from click.testing import CliRunner
from helpers import require_engine

from vrcal.cli import main
from vrcal.engines import ode as E
from vrcal.engines.common import CONFIRM_PHASES, constant_epsilon, drag_force_coefficient_kg_per_m, epsilon_spread
from vrcal.engines.export import (
    build_setup,
    export,
    format_trade_off,
    parse_exported,
    step_bound,
    trade_off,
)
from vrcal.errors import EngineUnavailable, UsageError

#: A field-hockey-like ball of the user's (not in the standards), dropped 1 m.
HOCKEY = dict(mass_kg=0.16, diameter_m=0.073, epsilon=0.5, drop_height_m=1.0)
#: A tennis-like ball of the user's.
OWN = dict(mass_kg=0.058, diameter_m=0.067, epsilon=0.75, drop_height_m=1.0)


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def _measured(text):
    """(worst error, depth [m]) written in a 'checked in ODE' note or message."""
    err = float(re.search(r"error ([0-9.e-]+)", text).group(1))
    depth = float(re.search(r"turns ([0-9.e-]+) mm", text).group(1)) * 1e-3
    return err, depth


# --------------------------------------------------------------------------- steps measured in the engine


def test_a_step_the_bound_refuses_but_ode_meets_is_accepted_with_the_measured_numbers():
    """At 1 ms the step bound says the hockey ball's epsilon may move by 0.018 (> 0.01); libode
    measures 0.0094 over 16 contact phases: the step is accepted, and the file says what was measured
    -- the same numbers the exported file gives when run again over as many phases."""
    require_engine("ode")
    setup = build_setup(None, "ode", dt_s=1e-3, **HOCKEY)
    assert step_bound(setup, "ode")[0] > setup.tolerance          # the bound alone refused it
    ex = export(None, "ode", dt_s=1e-3, **HOCKEY)
    note = next(n for n in json.loads(ex.text)["how_chosen"] if "checked in ODE" in n)
    err, depth = _measured(note)
    runs = E.drop_test(parse_exported("ode", ex.text), ex.setup, 3, CONFIRM_PHASES)
    assert err == pytest.approx(runs.worst_error, abs=6e-4) and err <= 0.01
    assert depth == pytest.approx(max(runs.penetration_m, runs.hover_m), abs=6e-5)
    sdf = export(None, "gazebo", dt_s=1e-3, **HOCKEY).text           # Gazebo: the same ODE run
    assert "checked in ODE" in sdf and max(len(line) for line in sdf.splitlines()) <= 100
    assert "--" not in sdf.split("<!--", 1)[1].split("-->", 1)[0]    # a valid XML comment


@pytest.mark.parametrize("engine, dt", [("ode", 2e-3), ("bullet", 1e-2)])
def test_a_refusal_gives_the_measured_miss_and_a_step_that_passes(engine, dt):
    require_engine(engine)
    with pytest.raises(UsageError) as info:
        export(None, engine, dt_s=dt, **OWN)
    message = str(info.value)
    label = "ODE" if engine == "ode" else "bullet"
    assert message.startswith(f"{label} at --dt {dt:g} s misses (16 phases") and len(message.splitlines()) == 1
    numbers = [float(x) for x in re.findall(r"turns ([0-9.]+) mm from the floor \(limit", message)] + \
        [float(x) for x in re.findall(r"worst epsilon error ([0-9.e-]+) \(tolerance", message)]
    assert numbers                                                     # a measured miss is named
    dt_ok = float(re.search(r"--dt ([0-9.e-]+) meets both", message).group(1))
    ex = export(None, engine, dt_s=dt_ok, **OWN)
    module = __import__(f"vrcal.engines.{engine}", fromlist=["drop_test"])
    runs = module.drop_test(parse_exported(engine, ex.text), ex.setup, 3, 4)
    assert runs.worst_error <= 0.01 and max(runs.penetration_m, runs.hover_m) <= ex.setup.penetration_limit_m


def test_without_the_engine_the_refusal_says_it_rests_on_the_bound(monkeypatch):
    import vrcal.engines as engines

    def absent(name):
        raise EngineUnavailable(f"{name} is not installed")

    monkeypatch.setattr(engines, "require_runtime", absent)
    with pytest.raises(UsageError, match=r"not run here \(ODE is not installed\).*by the bound"):
        export(None, "ode", dt_s=1e-2, **OWN)


@pytest.mark.parametrize("engine, out", [("ode", "t.json"), ("bullet", "t.json"), ("gazebo", "t.sdf")])
def test_without_the_engine_an_export_says_plainly_it_was_not_run(engine, out, monkeypatch, tmp_path):
    """libode or PyBullet absent: the export is still written (its values need no engine) at a step the
    bound passes, exit 0, but the file and the command say 'not run ... not installed', never 'checked'
    (an earlier export wrote 'checked at step 0.001 s only' although nothing ran)."""
    import vrcal.engines as engines

    def absent(name):
        raise EngineUnavailable(f"{name} is not installed")

    monkeypatch.setattr(engines, "require_runtime", absent)
    path = tmp_path / out
    result = run("export", "tennis", "--engine", engine, "--dt", "0.001", "-o", str(path))
    name = "PyBullet" if engine == "bullet" else "ODE"
    install = "pip install pybullet" if engine == "bullet" else "apt-get install libode8"
    assert result.exit_code == 0
    assert result.stderr.startswith(f"not run: {name} is not installed here ({install}")
    assert "step bound" in result.stderr
    text = path.read_text()
    assert not re.search(r"(?<!NOT )checked (at step|in)", text)
    assert f"NOT checked at step 0.001 s: not run, {name} is not installed here" in text
    if engine != "gazebo":
        data = json.loads(text)
        assert data["notes"][0].startswith("NOT checked") and data["how_chosen"][-1].startswith("not run: ")


def test_with_the_engine_an_export_says_what_it_checked(tmp_path):
    require_engine("ode")
    data = json.loads(export("tennis", "ode", dt_s=1e-3).text)
    assert data["notes"][0].startswith("checked at step 0.001 s only")
    assert data["how_chosen"][-1].startswith("step 0.001 s checked in ODE (16 phases")


# --------------------------------------------------------------------------- tables


def test_tables_take_a_users_ball_without_speeds_and_refuse_a_step_in_one_line():
    ball = dict(mass_kg=0.058, diameter_m=0.067, epsilon=0.75)
    text = export(None, "tables", **ball).text
    assert "0.7500" in text and "bounce(s) from" not in text
    with_drop = export(None, "tables", drop_height_m=1.0, **ball)
    v_last = float(with_drop.setup.impact_speeds_m_per_s[-1])
    assert f"..{v_last:.3g} m/s: keep each bounce threshold below" in with_drop.text
    for extra in (["--dt", "1e-3"], ["--max-penetration", "0.01"]):
        result = run("export", "--mass", 0.058, "--diameter", 0.067, "--epsilon", 0.75, "--engine", "unity", *extra)
        assert result.exit_code == 2
        lines = result.output.strip().splitlines()
        assert len(lines) == 1 and f"{extra[0]} does not apply to --engine tables" in lines[0], lines


SPEED_LAW = {"velocity_dependent_restitution": {"exponent": 0.4}}


@pytest.mark.parametrize("engine", ["tables", "gazebo"])
def test_a_speed_law_without_drag_gets_its_centred_constant_and_no_word_of_drag(engine, write_discover):
    path = write_discover(effects=SPEED_LAW, epsilon=0.75, mass_kg=0.058, diameter_m=0.067, drop_height_m=1.5)
    with pytest.raises(UsageError, match="half the spread"):              # 0.024 > --tolerance 0.01
        export(None, engine, from_json=path, dt_s=None if engine == "tables" else 2e-4)
    ex = export(None, engine, from_json=path, tolerance=0.03, dt_s=None if engine == "tables" else 2e-4)
    lo, hi, _ = epsilon_spread(ex.setup)
    assert constant_epsilon(ex.setup) == pytest.approx(0.5 * (lo + hi)) and lo < hi
    assert "drag" not in ex.text.lower() and f"centre, {0.5 * (lo + hi):.4f}" in " ".join(ex.text.split())
    if engine == "gazebo":
        root = ET.fromstring(ex.text.split("?>", 1)[1])
        value = float(root.findtext("world/model[@name='ball']/link/collision/surface/bounce/restitution_coefficient"))
        assert value == pytest.approx(0.5 * (lo + hi))
    else:
        assert ex.data["rows"][0]["restitution"] == pytest.approx(0.5 * (lo + hi))


def test_drag_alone_names_the_force_and_the_baselines_constant(write_discover):
    path = write_discover(effects={"air_drag": {"drag_coefficient": 0.45}})
    ex = export(None, "tables", from_json=path)
    c = drag_force_coefficient_kg_per_m(ex.setup)
    text = " ".join(ex.text.split())
    assert f"c = {c:.3g} kg/m" in text and "--epsilon 0.7600" in text     # the baseline: 0.86 - 0.1
    assert "epsilon(v)" not in ex.text
    assert ex.data["rows"][0]["restitution"] == 0.86


# --------------------------------------------------------------------------- trade-off


def test_the_trade_off_at_a_step_no_row_meets_ends_with_a_step_that_does():
    """The hockey ball at 10 ms: no row at 10, 5 or 2 ms meets the tolerance; the table gets the
    largest step found in MuJoCo and its last line names it."""
    require_engine("mujoco")
    setup, rows = trade_off(None, "mujoco", n_phases=2, dt_s=1e-2, **HOCKEY)
    assert not any(r["ok"] for r in rows if not r["suggested"])
    found = [r for r in rows if r["suggested"]]
    assert len(found) == 1 and found[0]["ok"] and found[0]["dt_s"] < 2e-3
    footer = format_trade_off(setup, rows).splitlines()[-1]
    assert footer.startswith("--dt 0.01 misses") and f"--dt {found[0]['dt_s']:g}" in footer
    assert np.isfinite(found[0]["worst_error"]) and len(footer) <= 100


def test_the_trade_off_refuses_what_it_would_ignore():
    result = run("export", "tennis", "--engine", "mujoco", "--trade-off", "--stiffness", "1e5")
    assert result.exit_code == 2 and "--stiffness cannot go with --trade-off" in result.output
    result = run("export", "tennis", "--engine", "mujoco", "--trade-off", "--against", "football")
    assert result.exit_code == 2 and "--against cannot go with --trade-off" in result.output
