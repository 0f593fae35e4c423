"""export/verify as library functions and through the CLI; tables; the engine registry."""

import json
import sys

import pytest
from click.testing import CliRunner
from helpers import require_engine

from vrcal.cli import main
from vrcal.engines import ENGINES, availability, get_engine, require_runtime
from vrcal.engines.export import build_setup, combine_epsilons, export
from vrcal.engines.verify import format_report, verify
from vrcal.errors import EngineUnavailable, UsageError
from vrcal.model.standards import ball_epsilon, get_ball


def run(*args):
    return CliRunner().invoke(main, list(args))


def test_target_defaults_to_the_standards_nominal_epsilon():
    setup = build_setup("basketball", "ode")
    assert setup.epsilon == pytest.approx(ball_epsilon(get_ball("basketball")).nominal)
    assert setup.drop_height_m == pytest.approx(1.8)          # FIBA: 1800 mm to the bottom


@pytest.mark.parametrize("bad", [0.0, -0.1, 1.01, float("nan")])
def test_epsilon_outside_the_unit_interval_is_refused(bad):
    with pytest.raises(UsageError, match=r"\(0, 1\]"):
        export("basketball", "ode", epsilon=bad)


def test_pair_epsilon_is_the_product_for_any_K():
    for K in (0.5, 4.0, 40.0):
        assert combine_epsilons(0.8, 0.7, K) == pytest.approx(0.56)


def test_compliant_floor_enters_through_eq6():
    setup = build_setup("basketball", "bullet", epsilon=0.8, floor="x=0.01,v=0.05")   # T = 0.1 s, K = 4
    assert setup.floor_epsilon == pytest.approx(0.67032, abs=1e-5)
    assert setup.epsilon == pytest.approx(0.8 * setup.floor_epsilon)


def test_tables_name_the_combine_modes():
    text = export("tennis", "tables", against="football").text
    for word in ("PhysX", "Unity", "Box2D", "Multiply", "b2MixRestitution"):
        assert word in text


def test_unknown_engine_names_the_known_ones():
    with pytest.raises(UsageError, match="known: mujoco, ode, bullet"):
        get_engine("havok")


def test_registry_entries_are_consistent():
    for name, engine in ENGINES.items():
        assert engine.name == name and engine.default_dt_s > 0
        if engine.runs:
            assert engine.install


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
        verify("basketball", "gazebo")


def test_cli_export_writes_each_engine_file(tmp_path):
    for engine, name in (("mujoco", "b.xml"), ("ode", "b.json"), ("bullet", "c.json"), ("gazebo", "b.sdf"),
                         ("physx", "b.txt")):
        out = tmp_path / name
        result = run("export", "basketball", "--engine", engine, "-o", str(out))
        assert result.exit_code == 0, result.output
        assert out.read_text().strip()
    assert json.loads((tmp_path / "b.json").read_text())["engine"] == "ode"


def test_cli_export_bad_input_is_a_one_line_error(tmp_path):
    out = tmp_path / "x.json"
    result = run("export", "basketball", "--engine", "ode", "--epsilon", "1.5", "-o", str(out))
    assert result.exit_code == 2 and "vrcal: error: --epsilon must be a number between 0.001 and 1" in result.output
    assert not out.exists()
    result = run("export", "basketball", "--engine", "mujoco", "--dt", "0.002")
    assert result.exit_code == 2 and "too large for MuJoCo" in result.output
    assert "Traceback" not in result.output


def test_cli_verify_passes_and_fails_on_the_tolerance(tmp_path):
    require_engine("ode")
    result = run("verify", "basketball", "--engine", "ode", "--phases", "2")
    assert result.exit_code == 0, result.output
    assert "[[Result]]" in result.output and "PASSED" in result.output
    result = run("verify", "basketball", "--engine", "ode", "--phases", "2", "--tolerance", "1e-7")
    assert result.exit_code == 1
    assert "FAILED" in result.output and "exceeds the tolerance" in result.output


def test_cli_verify_loads_an_exported_file(tmp_path):
    require_engine("ode")
    out = tmp_path / "t.json"
    assert run("export", "tennis", "--engine", "ode", "--epsilon", "0.7", "-o", str(out)).exit_code == 0
    data = json.loads(out.read_text())
    data["contact"]["bounce"] = 0.6                    # a file edited by hand: verify must see it
    data["target_epsilon"] = 0.6
    out.write_text(json.dumps(data))
    result = run("verify", "tennis", "--engine", "ode", "--file", str(out), "--phases", "1", "--format", "json")
    assert result.exit_code == 0, result.output
    report = json.loads(result.output)
    assert report["target_epsilon"] == 0.6
    assert max(abs(a - 0.6) for row in report["apex_ratios"] for a in row) < 0.005


def test_report_is_sectioned():
    require_engine("bullet")
    text = format_report(verify("tennis", "bullet", n_phases=1, n_bounces=2))
    for section in ("[[Engine]]", "[[Target]]", "[[Achieved]]", "[[Result]]"):
        assert section in text


def test_cli_engines_lists_the_registry():
    result = run("engines")
    assert result.exit_code == 0
    for name in ENGINES:
        assert name in result.output
