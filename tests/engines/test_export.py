"""export/verify as library functions and through the CLI; tables; the registry; bad input."""

import json
import math
import sys

import pytest
from click.testing import CliRunner
from helpers import require_engine

from vrcal.cli import main
from vrcal.engines import ENGINES, availability, get_engine, require_runtime
from vrcal.engines.export import build_setup, combine_epsilons, export, parse_impact_speed
from vrcal.engines.verify import format_report, verify
from vrcal.errors import DataError, EngineUnavailable, UsageError
from vrcal.model.restitution import STANDARD_GRAVITY_M_PER_S2
from vrcal.model.standards import ball_epsilon, get_ball


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def test_target_defaults_to_the_standards_nominal_epsilon_and_standard_gravity():
    setup = build_setup("basketball", "ode")
    assert setup.epsilon == pytest.approx(ball_epsilon(get_ball("basketball")).nominal)
    assert setup.drop_height_m == pytest.approx(1.8)          # FIBA: 1800 mm to the bottom
    assert setup.g_m_per_s2 == STANDARD_GRAVITY_M_PER_S2 == 9.80665
    assert build_setup("basketball", "ode", g_m_per_s2=1.62).g_m_per_s2 == 1.62


def test_each_engine_defaults_to_its_own_step():
    assert build_setup("tennis", "mujoco").dt_s == 0.002
    assert build_setup("tennis", "bullet").dt_s == pytest.approx(1 / 240)
    assert build_setup("tennis", "pybullet").dt_s == pytest.approx(1 / 240)


def test_a_users_own_ball_needs_mass_diameter_epsilon_and_speeds():
    setup = build_setup(None, "mujoco", mass_kg=0.0459, diameter_m=0.0427, epsilon=0.78, drop_height_m=1.0)
    assert (setup.ball, setup.mass_kg, setup.radius_m) == ("ball", 0.0459, pytest.approx(0.02135))
    assert setup.penetration_limit_m == pytest.approx(0.02135 / 4)
    with pytest.raises(UsageError, match="no body"):
        build_setup(None, "mujoco", epsilon=0.8, drop_height_m=1.0)
    with pytest.raises(UsageError, match="give --epsilon"):
        build_setup(None, "mujoco", mass_kg=0.05, diameter_m=0.04, drop_height_m=1.0)
    with pytest.raises(UsageError, match="--drop-height M or --impact-speed"):
        build_setup(None, "mujoco", mass_kg=0.05, diameter_m=0.04, epsilon=0.8)
    with pytest.raises(UsageError, match="unknown ball.*--mass and --diameter"):
        build_setup("golf", "mujoco", epsilon=0.78)


def test_impact_speeds_set_the_drop_and_the_bounces():
    setup = build_setup(None, "ode", mass_kg=0.05, diameter_m=0.04, epsilon=0.8, impact_speed="2:6")
    assert setup.impact_speed_m_per_s == pytest.approx(6.0)
    assert setup.impact_speeds_m_per_s[-1] <= 2.0 + 1e-9 < setup.impact_speeds_m_per_s[-2]
    assert parse_impact_speed("3") == (3.0, 3.0)
    for bad in ("0", "-1:2", "a:b", "1:2:3", "nan"):
        with pytest.raises(UsageError, match="--impact-speed"):
            parse_impact_speed(bad)
    with pytest.raises(UsageError, match="not both"):
        build_setup("tennis", "ode", drop_height_m=1.0, impact_speed="3")


@pytest.mark.parametrize("bad", [0.0, -0.1, 1.01, float("nan")])
def test_epsilon_outside_the_unit_interval_is_refused(bad):
    with pytest.raises(UsageError, match=r"\(0, 1\]"):
        export("basketball", "ode", epsilon=bad)


@pytest.mark.parametrize("option", ["mass_kg", "diameter_m"])
@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), float("inf")])
def test_mass_and_diameter_must_be_positive_numbers(option, bad):
    values = {"mass_kg": 0.05, "diameter_m": 0.04, option: bad}
    with pytest.raises(UsageError, match="must be a number > 0"):
        build_setup(None, "ode", epsilon=0.8, drop_height_m=1.0, **values)


@pytest.mark.parametrize("bad", [0.0, -0.01, float("nan")])
def test_tolerance_and_penetration_must_be_positive(bad):
    with pytest.raises(UsageError, match="--tolerance must be a number > 0"):
        build_setup("tennis", "ode", tolerance=bad)
    with pytest.raises(UsageError, match="--max-penetration must be a number > 0"):
        build_setup("tennis", "ode", max_penetration_m=bad)


def test_pair_epsilon_is_the_product_for_any_K():
    for K in (0.5, 4.0, 40.0):
        assert combine_epsilons(0.8, 0.7, K) == pytest.approx(0.56)


def test_compliant_floor_enters_through_eq6():
    setup = build_setup("basketball", "bullet", epsilon=0.8, floor="x=0.01,v=0.05")   # T = 0.1 s, K = 4
    assert setup.floor_epsilon == pytest.approx(0.67032, abs=1e-5)
    assert setup.epsilon == pytest.approx(0.8 * setup.floor_epsilon)


@pytest.mark.parametrize("engine", ["mujoco", "ode", "bullet", "gazebo", "tables"])
@pytest.mark.parametrize("floor", [None, "rigid", "volleyball"])
def test_K_that_would_change_nothing_is_refused_naming_where_it_applies(engine, floor):
    """--K was accepted and ignored: the ball's epsilon, a ball as floor and the pair's product
    do not depend on K; only a virtual-body floor 'x=..,v=..' turns K into an epsilon (Eq. 7)."""
    with pytest.raises(UsageError, match=r"--K applies only with --floor x=DEPTH,v=SPEED"):
        build_setup("basketball", engine, floor=floor, K_per_s=8.0)


def test_K_sets_a_virtual_body_floors_epsilon():
    floor = "x=0.01,v=0.05"                                          # T = x/(2v) = 0.1 s
    for K in (4.0, 8.0):
        setup = build_setup("basketball", "tables", epsilon=0.8, floor=floor, K_per_s=K)
        assert setup.floor_epsilon == pytest.approx(math.exp(-K * 0.1))
        assert setup.epsilon == pytest.approx(0.8 * math.exp(-K * 0.1))
    assert build_setup("basketball", "tables", floor=floor).floor_epsilon == pytest.approx(math.exp(-0.4))


def test_K_is_refused_with_a_discover_result_and_in_the_cli_of_export_and_verify(write_discover, tmp_path):
    path = write_discover()
    with pytest.raises(UsageError, match="--K applies only"):
        build_setup(None, "ode", from_json=path, K_per_s=8.0)
    for args in (["export", "basketball", "--engine", "mujoco", "--K", "8", "-o", tmp_path / "b.xml"],
                 ["export", "basketball", "--engine", "tables", "--against", "volleyball", "--K", "8"],
                 ["export", "tennis", "--engine", "mujoco", "--trade-off", "--K", "8"],
                 ["verify", "basketball", "--engine", "ode", "--K", "8"]):
        result = run(*args)
        assert result.exit_code == 2, result.output
        assert result.output.startswith("vrcal: error: --K applies only") and len(result.output.splitlines()) == 1
    assert not (tmp_path / "b.xml").exists()
    with_K = run("export", "basketball", "--engine", "tables", "--floor", "x=0.002,v=0.5", "--K", "8")
    without = run("export", "basketball", "--engine", "tables", "--floor", "x=0.002,v=0.5")
    assert with_K.exit_code == without.exit_code == 0
    assert "0.9841" in with_K.output and "0.9920" in without.output          # exp(-K 0.002 s): K = 8, 4


def test_verify_takes_K_for_a_virtual_body_floor():
    require_engine("ode")
    result = verify("basketball", "ode", floor="x=0.002,v=0.5", K_per_s=8.0, n_phases=1, n_bounces=1)
    assert result.target == pytest.approx(build_setup("basketball", "ode", floor="x=0.002,v=0.5",
                                                      K_per_s=8.0).epsilon)
    assert result.target == pytest.approx(ball_epsilon(get_ball("basketball")).nominal * math.exp(-8 * 0.002))


def test_the_discover_result_sets_body_drop_drag_and_release(write_discover):
    path = write_discover(effects={"air_drag": {"drag_coefficient": 0.38}, "height_offset": {"offset_m": -0.007},
                                   "contact_duration": {"contact_time_s": 0.001}}, drop_height_m=2.65)
    setup = build_setup(None, "mujoco", from_json=path)
    assert (setup.ball, setup.mass_kg, setup.radius_m) == ("table_tennis", 0.0027, 0.02)
    assert (setup.drop_height_m, setup.drag_coefficient, setup.epsilon) == (2.65, 0.38, 0.86)
    assert setup.release_time_s == 0.25 and setup.height_offset_m == -0.007
    assert any("not carried" in n and "contact_duration" in n for n in setup.notes)
    assert build_setup(None, "mujoco", from_json=path, epsilon=0.8).epsilon == 0.8


def test_a_rolling_shutter_is_left_out_of_the_engine_with_a_note(write_discover):
    """A camera reading its rows one after another is the record's, not the ball's: the engine gets epsilon
    and the drag, and the notes say why the shutter is left out."""
    path = write_discover(effects={"air_drag": {"drag_coefficient": 0.5},
                                   "rolling_shutter": {"readout_s_per_m": 0.0125}}, drop_height_m=0.8)
    setup = build_setup(None, "ode", from_json=path)
    assert setup.drag_coefficient == 0.5 and setup.epsilon == 0.86
    assert "rolling_shutter" not in setup.effects
    assert any(n.startswith("rolling_shutter left out: the camera's rolling shutter") for n in setup.notes)
    assert not any("not carried" in n for n in setup.notes)


def test_tables_name_the_combine_modes_in_100_columns():
    text = export("tennis", "tables", against="football").text
    for word in ("PhysX", "Unity", "Box2D", "Multiply", "b2MixRestitution"):
        assert word in text
    assert max(len(line) for line in text.splitlines()) <= 100


def test_tables_give_the_second_ball_its_own_material_rows():
    """``--against tennis``: PhysX and Unity need the tennis ball's material (0.7449, Multiply) for
    the pair's product to come out; the table had rows for the first ball and the floor only."""
    from vrcal.inverse import pair

    for floor in (None, "x=0.005,v=0.3"):
        rows = export("basketball", "tables", against="tennis", floor=floor).data["rows"]
        tennis = {r["engine"]: r["restitution"] for r in rows if r["body"] == "tennis"}
        assert tennis["PhysX"] == tennis["Unity"] == pytest.approx(0.7449, abs=1e-4)
        on_floor = pair("tennis", floor)["epsilon"] if floor else tennis["PhysX"]
        assert tennis["Box2D"] == pytest.approx(on_floor)                   # max rule: its value on this floor


def test_tables_refuse_a_tolerance_they_cannot_apply_to_a_constant_epsilon():
    """--tolerance was accepted and ignored by --engine tables for a constant epsilon (the value
    typed in is the target; no engine is run): refused in one line naming where it applies."""
    for ball, options in (("basketball", {}), (None, dict(mass_kg=0.058, diameter_m=0.067, epsilon=0.75)),
                          (None, dict(mass_kg=0.058, diameter_m=0.067, epsilon=0.75, drop_height_m=1.0))):
        with pytest.raises(UsageError, match=r"--tolerance does not apply to this --engine tables export.*"
                                             r"speed-dependent epsilon"):
            build_setup(ball, "tables", tolerance=0.001, **options)
        assert export(ball, "tables", **options).text                  # without it: the table
    result = run("export", "basketball", "--engine", "physx", "--tolerance", "0.5")
    assert result.exit_code == 2 and len(result.output.splitlines()) == 1
    assert result.output.startswith("vrcal: error: --tolerance does not apply")


def test_tables_bound_a_speed_dependent_epsilons_constant_by_the_tolerance(write_discover):
    path = write_discover(effects={"velocity_dependent_restitution": {"exponent": 0.4}}, epsilon=0.75)
    setup = build_setup(None, "tables", from_json=path, tolerance=1.0)
    from vrcal.engines.common import epsilon_spread

    least = epsilon_spread(setup)[2]                                   # the constant's error at either end
    assert least > 0.001
    with pytest.raises(UsageError, match=r"off by at least .* > --tolerance"):
        export(None, "tables", from_json=path, tolerance=0.9 * least)
    assert export(None, "tables", from_json=path, tolerance=1.1 * least).data["rows"]


def test_tables_say_the_floor_a_compliant_floor_gives():
    text = export("basketball", "tables", floor="x=0.002,v=0.5").text
    assert "on a rigid floor" not in text and "x floor 0.9920" in text.splitlines()[0]


def test_unknown_engine_names_the_known_ones():
    with pytest.raises(UsageError, match="known: mujoco, ode, bullet"):
        get_engine("havok")


def test_registry_entries_are_consistent():
    for name, engine in ENGINES.items():
        assert engine.name == name and engine.default_dt_s > 0
        if engine.runs:
            assert engine.install and engine.max_steps > 0


def test_a_missing_engine_gives_engine_unavailable_naming_the_package(monkeypatch):
    monkeypatch.setitem(sys.modules, "mujoco", None)          # import mujoco -> ImportError
    with pytest.raises(EngineUnavailable, match="pip install mujoco"):
        require_runtime("mujoco")
    assert "unavailable" in availability()["mujoco"]
    result = run("verify", "basketball", "--engine", "mujoco")
    assert result.exit_code == 1
    assert "pip install mujoco" in result.output


def test_export_only_engines_cannot_be_verified():
    with pytest.raises(UsageError, match="export only"):
        verify("basketball", "tables")
    with pytest.raises(UsageError, match="^--engine gazebo runs an SDF world .*: give --file WORLD.sdf"):
        verify("basketball", "gazebo")            # a world runs in libode, as Gazebo classic combines it


def test_cli_export_writes_each_engine_file(tmp_path):
    for engine, name in (("mujoco", "b.xml"), ("ode", "b.json"), ("pybullet", "c.json"), ("gazebo", "b.sdf"),
                         ("physx", "b.txt")):
        out = tmp_path / name
        step = () if engine == "physx" else ("--dt", "5e-4")       # tables refuse --dt (no step is checked)
        result = run("export", "basketball", "--engine", engine, *step, "-o", out)
        assert result.exit_code == 0, result.output
        assert out.read_text().strip()
    assert json.loads((tmp_path / "b.json").read_text())["engine"] == "ode"
    assert json.loads((tmp_path / "c.json").read_text())["engine"] == "bullet"


def test_cli_export_json_format_is_a_machine_document():
    result = run("export", "basketball", "--engine", "tables", "--format", "json")
    assert result.exit_code == 0, result.output
    doc = json.loads(result.output)
    assert doc["schema_version"] == 1 and doc["rows"][0]["engine"] == "PhysX"


@pytest.mark.parametrize("args, code, message", [
    (["basketball", "--engine", "ode", "--epsilon", "1.5"], 2, "--epsilon must be a number between 0.001 and 1"),
    (["basketball", "--engine", "mujoco", "--dt", "1e-320"], 2, "--dt must be a number between 1e-07 and 0.1 [s]"),
    (["--engine", "mujoco", "--mass", "nan", "--diameter", "0.1", "--epsilon", "0.5", "--drop-height", "1"], 2,
     "--mass must be a finite number"),
    (["--engine", "mujoco", "--mass", "0.1", "--diameter", "-1", "--epsilon", "0.5", "--drop-height", "1"], 2,
     "--diameter must be a number between"),
    (["tennis", "--engine", "ode", "--tolerance", "0"], 2, "--tolerance must be a number between 1e-09 and 1"),
    (["tennis", "--engine", "ode", "--integrator", "rk4"], 2, "--integrator applies to MuJoCo only"),
])
def test_cli_export_bad_input_is_a_one_line_error(tmp_path, args, code, message):
    out = tmp_path / "x.json"
    result = run("export", *args, "-o", out)
    assert result.exit_code == code, result.output
    assert result.output.strip().splitlines() == [f"vrcal: error: {result.output.split('vrcal: error: ')[1].strip()}"]
    assert message in result.output and "Traceback" not in result.output
    assert not out.exists()


@pytest.mark.parametrize("content, message", [
    ("[1, 2]", "the top level is a list"),
    ('{"ball": {"name": "x", "mass_kg": 1, "diameter_m": 0.1}}', "missing"),
    (b"\x89PNG\r\n\x1a\n\x00\x00", "not a discover JSON"),
    ('{"schema_version": 99, "ball": {}}', "schema_version '99'"),
])
def test_from_a_file_that_is_not_a_discover_result_is_refused(tmp_path, content, message):
    path = tmp_path / "d.json"
    path.write_bytes(content if isinstance(content, bytes) else content.encode())
    out = tmp_path / "x.xml"
    result = run("export", "--from", path, "--engine", "mujoco", "-o", out)
    assert result.exit_code == 1, result.output
    assert message in result.output and len(result.output.strip().splitlines()) == 1
    assert not out.exists()


def test_cli_verify_passes_and_fails_on_the_tolerance():
    require_engine("ode")
    result = run("verify", "basketball", "--engine", "ode", "--phases", "2")
    assert result.exit_code == 0, result.output
    assert "PASSED" in result.output
    assert max(len(line) for line in result.output.splitlines()) <= 100
    result = run("verify", "basketball", "--engine", "ode", "--phases", "2", "--tolerance", "1e-7")
    assert result.exit_code == 1
    assert "FAILED" in result.output and "exceeds the tolerance" in result.output


def test_cli_verify_runs_the_confirmation_phases_by_default():
    """The CLI's --phases default is the phase count export confirms a step with (the CLI keeps its
    start-up light and writes the number itself)."""
    from vrcal.engines.common import CONFIRM_PHASES
    from vrcal.engines.verify import DEFAULT_PHASES

    option = next(p for p in main.commands["verify"].params if p.name == "n_phases")
    assert option.default == DEFAULT_PHASES == CONFIRM_PHASES


def test_cli_verify_json_is_a_machine_document():
    require_engine("mujoco")
    result = run("verify", "tennis", "--engine", "mujoco", "--phases", "2", "--format", "json")
    assert result.exit_code == 0, result.output
    doc = json.loads(result.output)
    assert doc["schema_version"] == 1 and doc["passed"] and len(doc["apex_ratios"]) == 2


def test_cli_verify_loads_an_exported_file(tmp_path):
    require_engine("ode")
    out = tmp_path / "t.json"
    assert run("export", "tennis", "--engine", "ode", "--epsilon", "0.7", "-o", out).exit_code == 0
    data = json.loads(out.read_text())
    data["contact"]["bounce"] = 0.6                    # a file edited by hand: verify must see it
    data["target_epsilon"] = 0.6
    out.write_text(json.dumps(data))
    result = run("verify", "--engine", "ode", "--file", out, "--phases", "1", "--format", "json")
    assert result.exit_code == 0, result.output
    report = json.loads(result.output)
    assert report["target_epsilon"] == 0.6
    assert max(abs(a - 0.6) for row in report["apex_ratios"] for a in row) < 0.01


def test_cli_verify_loads_an_exported_mjcf_without_ball(tmp_path):
    require_engine("mujoco")
    out = tmp_path / "b.xml"
    assert run("export", "--engine", "mujoco", "--mass", "0.0459", "--diameter", "0.0427", "--epsilon", "0.78",
               "--drop-height", "1", "-o", out).exit_code == 0
    result = run("verify", "--engine", "mujoco", "--file", out, "--phases", "2")
    assert result.exit_code == 0, result.output
    assert "PASSED" in result.output and "0.7800" in result.output
    # a much smaller step than the file's: MuJoCo's damper, tuned to 2 ms, no longer bounces; said why
    result = run("verify", "--engine", "mujoco", "--file", out, "--phases", "1", "--bounces", "1", "--dt", "1e-4")
    assert result.exit_code == 1, result.output
    assert "the file is for 0.002 s (its contact is tuned to that step)" in " ".join(result.output.split())


BOMB = """<?xml version="1.0"?>
<!DOCTYPE lolz [<!ENTITY lol "lol"><!ENTITY lol2 "&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;">
<!ENTITY lol3 "&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;">]>
<mujoco model="&lol3;"><option timestep="0.002"/></mujoco>
"""
EXTERNAL = """<?xml version="1.0"?>
<!DOCTYPE m [<!ENTITY x SYSTEM "file:///etc/passwd">]>
<mujoco model="&x;"><option timestep="0.002"/></mujoco>
"""


@pytest.mark.parametrize("engine, content, message", [
    ("ode", "[1, 2]", "the top level is a list"),
    ("ode", '{"engine": "ode"}', "missing 'ball.mass_kg'"),
    ("bullet", '{"engine": "ode"}', "the file is a vrcal ode export: use --engine ode"),
    ("ode", '<mujoco model="m"/>', "the file is an MJCF (MuJoCo) file: use --engine mujoco"),
    ("mujoco", '{"engine": "bullet"}', "the file is a vrcal bullet export: use --engine bullet"),
    ("ode", b"\x7fELF\x02\x01\x01\x00\x00\x00", "a binary file"),
    ("mujoco", '<mujoco><option timestep="fast"/><worldbody/></mujoco>', "'fast' is not a number"),
    ("mujoco", BOMB, "declares a DTD or entities"),
    ("mujoco", EXTERNAL, "declares a DTD or entities"),
    ("mujoco", "<robot/>", "not <mujoco>"),
    ("mujoco", "<mujoco", "not an MJCF file"),
])
def test_verify_file_that_is_not_an_export_is_a_one_line_error(tmp_path, engine, content, message):
    path = tmp_path / "f"
    path.write_bytes(content if isinstance(content, bytes) else content.encode())
    result = run("verify", "basketball", "--engine", engine, "--file", path)
    assert result.exit_code == 1, result.output
    assert message in result.output and len(result.output.strip().splitlines()) == 1, result.output
    assert str(path) in result.output   # which file (a YAML given as MJCF said only 'not an MJCF file')
    assert "Traceback" not in result.output


def test_verify_file_that_does_not_exist_is_a_usage_error(tmp_path):
    result = run("verify", "basketball", "--engine", "mujoco", "--file", tmp_path / "nofile.xml")
    assert result.exit_code == 2 and "does not exist" in result.output


@pytest.mark.parametrize("args, message", [
    (["--bounces", "1000000"], "--bounces must be an integer from 1 to 50"),
    (["--dt", "1e-9"], "--dt must be a number between 1e-07 and 0.1 [s]"),
    (["--dt", "1e-6"], "the limit is 400,000 steps"),
    (["--bounces", "40"], "ask for --bounces 14 or fewer"),
])
def test_runs_that_would_not_end_are_refused_up_front(args, message):
    require_engine("bullet")
    result = run("verify", "basketball", "--engine", "bullet", *args)
    assert result.exit_code == 2, result.output
    assert message in result.output and len(result.output.strip().splitlines()) == 1


def test_report_is_short_and_aligned():
    require_engine("bullet")
    text = format_report(verify("tennis", "bullet", n_phases=1, n_bounces=2, dt_s=1e-3))
    lines = text.splitlines()
    assert len(lines) <= 14 and max(len(line) for line in lines) <= 100
    assert lines[-1] == "PASSED" and "worst error" in text


def test_cli_engines_lists_the_registry():
    result = run("engines")
    assert result.exit_code == 0
    for name in ENGINES:
        assert name in result.output
    assert max(len(line) for line in result.output.splitlines()) <= 100


def test_trade_off_prints_a_table():
    require_engine("mujoco")
    result = run("export", "table_tennis", "--engine", "mujoco", "--trade-off")
    assert result.exit_code == 0, result.output
    assert "damper" in result.output and "spring" in result.output
    assert max(len(line) for line in result.output.splitlines()) <= 100
    result = run("export", "basketball", "--engine", "ode", "--trade-off")
    assert result.exit_code == 2 and "applies to MuJoCo" in result.output


def test_a_discover_result_from_another_engine_option_is_checked(write_discover):
    path = write_discover(effects={"air_drag": {"drag_coefficient": 9.0}})
    with pytest.raises(DataError, match="outside"):
        build_setup(None, "ode", from_json=path)


# --------------------------------------------------------------------------- a user's step, a user's file


@pytest.mark.parametrize("engine", ["mujoco", "ode", "bullet", "gazebo"])
def test_every_exported_file_names_the_step_it_holds_for(engine):
    dt = {"mujoco": 0.002, "ode": 1e-3, "bullet": 1e-3, "gazebo": 1e-3}[engine]
    if engine == "mujoco":
        require_engine("mujoco")
    text = export("basketball", engine, dt_s=dt).text
    line = next(line for line in text.splitlines() if f"{dt:g} s only" in line)
    if engine == "mujoco":
        assert len(line) <= 100 and "valid at timestep 0.002 s only" in line
        assert "--" not in line.strip()[4:-3]                      # an XML comment holds no two dashes
    elif engine != "gazebo":
        assert "vrcal verify --file F --dt DT" in line


def test_verify_file_runs_the_file_at_the_asked_step(tmp_path):
    """MuJoCo's damper D = (1 + eps)/dt is tuned to the file's step: run at twice that step the
    same file reverses the velocity by 1 - D dt = -(1 + 2 eps), and verify says so (it used to run
    the file at its own step and pass, ignoring --dt)."""
    require_engine("mujoco")
    out = tmp_path / "b.xml"
    assert run("export", "basketball", "--engine", "mujoco", "-o", out).exit_code == 0
    result = run("verify", "--engine", "mujoco", "--file", out, "--dt", "0.004", "--phases", "1", "--format", "json")
    assert result.exit_code == 1, result.output
    report = json.loads(result.stdout)
    assert report["dt_s"] == 0.004 and not report["passed"]
    assert any("run at --dt 0.004 s; the file is for 0.002 s" in n for n in report["notes"])
    eps = 0.7662
    assert report["velocity_ratios"][0][0] == pytest.approx(1 + 2 * eps, abs=0.05)


def test_verify_file_runs_an_ode_file_at_the_asked_step(tmp_path):
    require_engine("ode")
    out = tmp_path / "b.json"
    assert run("export", "basketball", "--engine", "ode", "-o", out).exit_code == 0
    own = verify(None, "ode", exported_text=out.read_text(), n_phases=1)
    half = verify(None, "ode", exported_text=out.read_text(), dt_s=5e-4, n_phases=1)
    assert (own.dt_s, half.dt_s) == (1e-3, 5e-4) and half.passed
    assert half.runs.penetration_m < 0.7 * own.runs.penetration_m          # the ball sinks up to v dt


@pytest.mark.parametrize("args, named", [
    (["basketball"], "BALL is fixed"),
    (["--integrator", "rk4"], "--integrator is fixed"),
    (["--stiffness", "100"], "--stiffness is fixed"),
    (["--floor", "volleyball"], "--floor is fixed"),
    (["--mass", "0.5", "--diameter", "0.2"], "--mass and --diameter are fixed"),
])
def test_verify_file_refuses_what_the_file_fixes_in_one_line(tmp_path, args, named):
    out = tmp_path / "b.xml"
    out.write_text('<mujoco><option timestep="0.002"/><worldbody><body><geom name="ball" type="sphere" '
                   'size="0.1" mass="0.5"/></body></worldbody><custom><numeric name="vrcal_epsilon" data="0.8"/>'
                   '<numeric name="vrcal_drop_height_m" data="1"/></custom></mujoco>')
    require_engine("mujoco")
    result = run("verify", "--engine", "mujoco", "--file", out, *args)
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and named in lines[0] and "only --dt, --g, --drop-height, --epsilon" in lines[0]


def test_verify_file_takes_the_files_tolerance(tmp_path):
    require_engine("ode")
    out = tmp_path / "b.json"
    assert run("export", "basketball", "--engine", "ode", "--tolerance", "0.02", "-o", out).exit_code == 0
    assert verify(None, "ode", exported_text=out.read_text(), n_phases=1).tolerance == 0.02
    assert verify(None, "ode", exported_text=out.read_text(), n_phases=1, tolerance=0.005).tolerance == 0.005


def test_verify_says_the_ball_bounced_too_high_not_that_it_stuck(tmp_path):
    """A file whose bounce is higher than its target (edited, or another ball's): the run sized
    for the target ended with the ball still bouncing; verify now measures the bounces and fails
    them (it used to say 'stuck to the floor')."""
    require_engine("ode")
    ex = export("tennis", "ode", epsilon=0.5, dt_s=2e-4)
    data = json.loads(ex.text)
    data["contact"]["bounce"] = 0.9
    result = verify(None, "ode", exported_text=json.dumps(data), n_phases=1)
    assert not result.passed
    assert result.runs.velocity_ratios == pytest.approx(0.9, abs=0.005)


def test_export_bounces_is_an_option_and_verify_bounces_is_not_ignored():
    """A slow low drop: its third bounce rises under 1 mm; --bounces 1 is what the refusal names,
    and verify --bounces 1 runs (it used to export for 3 bounces and refuse)."""
    require_engine("ode")
    low = dict(epsilon=0.3, drop_height_m=0.05, dt_s=1e-4)
    with pytest.raises(UsageError, match=r"ask for --bounces 1 or fewer"):
        export("tennis", "ode", **low)
    ex = export("tennis", "ode", n_bounces=1, **low)
    assert json.loads(ex.text)["target"]["n_bounces"] == 1
    result = run("verify", "tennis", "--engine", "ode", "--epsilon", "0.3", "--drop-height", "0.05",
                 "--dt", "1e-4", "--bounces", "1", "--phases", "1")
    assert result.exit_code == 0 and "1 bounce(s)" in result.output, result.output
    result = run("export", "tennis", "--engine", "ode", "--epsilon", "0.3", "--drop-height", "0.05",
                 "--dt", "1e-4", "--bounces", "1")
    assert result.exit_code == 0 and json.loads(result.stdout)["target"]["n_bounces"] == 1


def test_export_refuses_an_unwritable_output_before_the_work(tmp_path, monkeypatch):
    import vrcal.engines.export as ex

    def never(*args, **kwargs):
        raise AssertionError("calibrated before checking -o")

    monkeypatch.setattr(ex, "export", never)
    result = run("export", "basketball", "--engine", "mujoco", "-o", tmp_path / "missing" / "b.xml")
    assert result.exit_code == 2, result.output
    assert "directory" in result.output and "does not exist" in result.output


def test_the_ode_step_check_names_every_limit_it_misses():
    with pytest.raises(UsageError) as info:
        export("basketball", "ode", dt_s=0.05)
    text = str(info.value)
    assert "--max-penetration" in text and "tolerance 0.01" in text and "\n" not in text


def test_impact_speeds_say_where_the_bounces_end():
    """LO:HI: bounces down to LO, or the note says why they stop above it; one value: the first impact."""
    setup = build_setup("basketball", "ode", impact_speed="1:6")
    v = setup.impact_speeds_m_per_s
    assert v[-1] <= 1.0 < v[-2]
    assert any(f"bounce(s) at 6..{v[-1]:.3g} m/s" in n for n in setup.notes)
    limited = build_setup("basketball", "ode", impact_speed="1:6", n_bounces=3)
    assert any("not down to 1 m/s (--bounces limits it)" in n for n in limited.notes)
    slow = build_setup("basketball", "ode", impact_speed="0.05:6")      # below 0.14 m/s a bounce rises < 1 mm
    assert slow.impact_speeds_m_per_s[-1] > 0.05
    assert any("not down to 0.05 m/s (a slower bounce would rise less than 1 mm)" in n for n in slow.notes)
    one = build_setup("basketball", "ode", impact_speed="5")
    assert one.impact_speed_m_per_s == pytest.approx(5.0) and one.n_bounces == 3
    assert any("one value: the first impact" in n for n in one.notes)


def test_a_penetration_limit_at_or_above_the_radius_is_refused(tmp_path):
    """A 25.4 mm steel ball (the probe's steel.json) exported to ODE at 10 ms with --max-penetration 0.035:
    written, and verify PASSED with 'penetration 30.6 mm' on a ball of radius 12.7 mm. A limit at or above
    the radius is refused in one line (export, verify, and an exported file's own limit)."""
    steel = dict(mass_kg=0.0668, diameter_m=0.0254, epsilon=0.8944, drop_height_m=0.5)
    for limit in (0.035, 0.0127):
        with pytest.raises(UsageError, match=r"^--max-penetration [\d.]+ mm is not below the ball's radius 12\.7 mm "
                                             r"\(its centre would reach the floor\): give less than the radius"):
            build_setup(None, "ode", dt_s=0.01, max_penetration_m=limit, **steel)
    assert build_setup(None, "ode", dt_s=0.01, max_penetration_m=0.012, **steel).penetration_limit_m == 0.012
    result = run("export", "--engine", "ode", "--mass", 0.0668, "--diameter", 0.0254, "--epsilon", 0.8944,
                 "--drop-height", 0.5, "--dt", 0.01, "--max-penetration", 0.035)
    assert result.exit_code == 2 and result.output.count("\n") == 1 and "radius 12.7 mm" in result.output
    require_engine("ode")
    doc = json.loads(export(None, "ode", dt_s=1e-3, **steel).text)
    doc["target"]["max_penetration_m"] = 0.035           # as the export at 10 ms wrote it
    path = tmp_path / "steel.json"
    path.write_text(json.dumps(doc))
    result = run("verify", "--engine", "ode", "--file", path)
    assert result.exit_code == 2 and "the file's max_penetration_m 35 mm is not below the ball's radius" in \
        result.output and "give --max-penetration less than the radius" in result.output
    assert run("verify", "--engine", "ode", "--file", path, "--max-penetration", 0.005).exit_code == 0


def test_the_floor_rows_how_names_the_floors_own_restitution():
    """`--floor x=0.002,v=0.5 --K 8`: the PhysX floor row said 'restitution': 0.9841 but 'how': 'floor material:
    restitution 1, eMULTIPLY' (Unity: 'bounciness 1'); a rigid floor still says 1."""
    rows = export("basketball", "tables", against="tennis", floor="x=0.002,v=0.5", K_per_s=8).data["rows"]
    floors = {r["engine"]: r for r in rows if r["body"] == "floor"}
    assert floors["PhysX"]["restitution"] == pytest.approx(0.9841, abs=1e-4)
    assert "restitution 0.9841 (Eq. 6: the floor's own factor), eMULTIPLY" in floors["PhysX"]["how"]
    assert "bounciness 0.9841 (Eq. 6: the floor's own factor), Multiply" in floors["Unity"]["how"]
    rigid = {r["engine"]: r for r in export("basketball", "tables").data["rows"] if r["body"] == "floor"}
    assert rigid["PhysX"]["restitution"] == 1 and "restitution 1 (rigid)" in rigid["PhysX"]["how"]


def test_a_light_ball_given_by_mass_and_diameter_is_warned_of_as_fit_warns():
    """A 100 g, 0.5 m beach ball: vrcal fit warns that buoyancy and drag matter (the air it displaces weighs
    79 % of it); export said nothing. It carries fit's own warning now, on the terminal and in the file."""
    from vrcal.inverse import buoyancy_notes

    require_engine("mujoco")
    ex = export(None, "mujoco", epsilon=0.877, mass_kg=0.1, diameter_m=0.5, drop_height_m=2)
    warning = buoyancy_notes(0.1, 0.5)[0]
    assert warning in ex.setup.notes and warning in ex.summary
    assert "warning: buoyancy is large" in ex.text
    assert not buoyancy_notes(0.0027, 0.04)          # a ping-pong ball: no warning


def test_a_floor_whose_epsilon_stops_the_bounce_is_named_as_the_cause():
    """A virtual-body floor x = 1 mm, v = 0.1 mm/s at K = 100 1/s has epsilon exp(-500)-ish: the refusal said
    'rises only 0 mm: ask for a larger --drop-height or --epsilon'; it names the floor's epsilon now."""
    with pytest.raises(UsageError, match=r"rises not at all \(a bounce must rise 1 mm; the pair's epsilon is "
                                         r"[0-9.]+e-[0-9]+ = ball 0\.7449 x floor [0-9.]+e-[0-9]+, Eq\. 6\): ask for "
                                         r"a floor of a larger epsilon \(a smaller --K"):
        build_setup("tennis", "mujoco", floor="x=0.001,v=0.0001", K_per_s=100)


def test_the_constant_offered_for_a_drag_free_engine_is_the_one_that_reproduces_the_heights(tmp_path):
    """The export of a discover result with air drag offered the baseline's epsilon ('folds drag into
    epsilon'): 0.8238 for an exercise ball whose heights ask for 0.774..0.802. It offers the result's
    epsilon_effective_without_drag, fitted to the bounce heights."""
    rec, doc = tmp_path / "pp.csv", tmp_path / "pp.json"
    assert run("simulate", "table_tennis", "--effect", "air_drag", "--bounces", "8", "-o", rec).exit_code == 0
    assert run("discover", rec, "--ball", "table_tennis", "-q", "--json", doc).exit_code == 0
    d = json.loads(doc.read_text())
    offered, baseline = d["epsilon_effective_without_drag"], d["baseline"]["epsilon"]
    assert abs(offered - baseline) > 1e-3
    out = run("export", "--from", doc, "--engine", "tables")
    assert out.exit_code == 0, out.output
    text = " ".join(out.output.split())
    assert f"without drag (--epsilon {offered:.4f})" in text and f"{baseline:.4f})" not in text


@pytest.mark.parametrize("engine, name", [("ode", "b.json"), ("bullet", "b.json"), ("mujoco", "b.xml"),
                                          ("gazebo", "b.sdf")])
def test_verify_file_takes_the_engine_the_file_was_exported_for(engine, name, tmp_path):
    """A re-check probe: `vrcal verify --file from_ode.json` asked for --engine although the file says
    "engine": "ode". The file's own engine is taken; a file that says none names --engine."""
    from vrcal.engines.files import engine_of_file, read_file

    require_engine("bullet" if engine == "bullet" else "mujoco" if engine == "mujoco" else "ode")
    path = tmp_path / name
    runner = CliRunner()
    step = ["--dt", "0.001"] if engine == "bullet" else []      # PyBullet's 1/240 s is refused for a tennis ball
    made = runner.invoke(main, ["export", "tennis", "--engine", engine, *step, "-o", str(path)])
    assert made.exit_code == 0, made.output
    assert engine_of_file(read_file(str(path)), str(path)) == engine
    checked = runner.invoke(main, ["verify", "--file", str(path), "--bounces", "2", "--phases", "2"])
    assert checked.exit_code == 0 and "PASSED" in checked.output, checked.output


def test_verify_without_an_engine_or_a_file_that_names_one_says_give_engine(tmp_path):
    other = tmp_path / "x.json"
    other.write_text('{"a": 1}')
    runner = CliRunner()
    for args in (["verify", "tennis"], ["verify", "--file", str(other)]):
        result = runner.invoke(main, args)
        assert result.exit_code == 2 and "give --engine" in result.output
