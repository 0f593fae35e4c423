"""End-to-end tests of the core commands: click's runner and the installed ``vrcal`` command."""

import json
import os
import re
import shutil
import subprocess
import sys

import pytest
import yaml
from click.testing import CliRunner

from vrcal import __version__
from vrcal.cli import main


def run(*args):
    return CliRunner().invoke(main, list(args))


def test_version_and_help():
    result = run("--version")
    assert result.exit_code == 0 and __version__ in result.output
    result = run("--help")
    assert result.exit_code == 0 and "Examples" in result.output


@pytest.mark.parametrize("args", [(), ("plot",)])
def test_a_group_without_a_command_shows_its_help(args):
    """`vrcal` alone prints the help (click >= 8.2 raises it as a usage error, which came out as one
    garbled 'error' line of 1,500 characters)."""
    result = run(*args)
    assert result.exit_code == 0, result.output
    assert result.output.startswith("Usage: ") and "error" not in result.output.splitlines()[0]
    assert "Commands:" in result.output


def test_an_option_without_its_value_points_to_its_command_help():
    """click raises 'requires an argument' without the subcommand's context: the hint named 'vrcal --help'."""
    result = run("simulate", "tennis", "-o")
    assert result.exit_code == 2
    assert result.output.strip().endswith("(see 'vrcal simulate --help')")


@pytest.mark.parametrize("command, typo, meant", [("export", "mujuco", "mujoco"), ("verify", "pybulet", "pybullet")])
def test_a_mistyped_engine_is_named(command, typo, meant):
    """As ball names do, an engine's typo says which engine was probably meant."""
    result = run(command, "tennis", "--engine", typo)
    assert result.exit_code == 2 and f"(did you mean '{meant}'?)" in result.output
    assert "did you mean" not in run(command, "tennis", "--engine", "zzz").output


def test_every_command_has_help_with_an_example():
    def walk(group, path):
        for name, cmd in group.commands.items():
            yield [*path, name], cmd
            if hasattr(cmd, "commands"):
                yield from walk(cmd, [*path, name])

    for path, cmd in walk(main, []):
        result = run(*path, "--help")
        assert result.exit_code == 0, path
        if not hasattr(cmd, "commands"):
            assert "vrcal " in result.output.split("Example", 1)[-1], f"{' '.join(path)} --help has no example"


def test_fit_json_has_the_documented_keys(tmp_path):
    out = tmp_path / "b.json"
    result = run("fit", "basketball", "--format", "json", "-o", str(out))
    assert result.exit_code == 0, result.output
    data = json.loads(out.read_text())
    assert {"ball", "K_per_s", "epsilon", "T_s", "family"} <= set(data)
    assert set(data["epsilon"]) == {"min", "nominal", "max"}
    assert all(set(m) == {"x_m", "v_m_per_s"} for m in data["family"])


def test_fit_yaml_to_stdout_is_repeatable():
    a, b = run("fit", "tennis", "--format", "yaml"), run("fit", "tennis", "--format", "yaml")
    assert a.exit_code == 0 and a.output == b.output
    assert yaml.safe_load(a.output)["ball"] == "tennis"


def test_fit_as_paper_shows_paper_value():
    data = yaml.safe_load(run("fit", "basketball", "--as-paper", "--format", "yaml").output)
    assert data["epsilon"]["nominal"] == pytest.approx(0.85, abs=0.001)


def test_fit_fixed_x():
    data = yaml.safe_load(run("fit", "football", "--x", "0.02", "--K", "4", "--format", "yaml").output)
    assert data["fixed"]["x_m"] == 0.02
    assert data["fixed"]["v_m_per_s"]["min"] < data["fixed"]["v_m_per_s"]["max"]


def test_pair_command():
    result = run("pair", "basketball", "floor", "--format", "json")
    assert result.exit_code == 0
    data = json.loads(result.output)
    assert data["epsilon"] == pytest.approx(data["bodies"][0]["epsilon_on_rigid_floor"])


def test_pair_output_file_format_follows_its_extension_as_the_help_says(tmp_path):
    help_text = " ".join(run("pair", "--help").output.split())
    assert (".txt for the table; an extension of another format, such as .csv, or one that contradicts --format is "
            "refused; an unknown extension gets yaml, with a warning") in help_text
    assert run("pair", "tennis", "floor", "-o", str(tmp_path / "out.txt")).exit_code == 0
    assert (tmp_path / "out.txt").read_text() == run("pair", "tennis", "floor").output
    assert run("pair", "tennis", "floor", "-o", str(tmp_path / "out.dat")).exit_code == 0
    assert yaml.safe_load((tmp_path / "out.dat").read_text())["schema_version"] >= 1


def test_user_standards_file(tmp_path):
    path = tmp_path / "mine.yaml"
    path.write_text(yaml.safe_dump({"schema_version": 1, "balls": {"superball": {
        "name": "Superball", "association": "none", "rule": "own drop test", "official": False,
        "mass_kg": {"min": 0.02, "max": 0.02}, "diameter_m": {"min": 0.04, "max": 0.04},
        "drop_height_m": 1.0, "drop_measured_to": "bottom", "rebound_m": {"min": 0.81, "max": 0.81},
        "rebound_measured_to": "bottom", "floor": "concrete", "conditions": "room"}}}))
    for args in (["--standards", str(path), "fit", "superball"], ["fit", "superball", "--standards", str(path)]):
        result = run(*args, "--format", "yaml")
        assert result.exit_code == 0, result.output
        assert yaml.safe_load(result.output)["epsilon"]["nominal"] == pytest.approx(0.9)


BAD_INPUTS = [
    (["fit", "baskteball"], 2, "did you mean 'basketball'"),
    (["fit", "basketball", "--K", "0"], 2, "K must be"),
    (["fit", "basketball", "--K", "-1"], 2, "K must be"),
    (["fit", "basketball", "--K", "abc"], 2, "--K must be a number"),
    (["fit", "basketball", "--x", "-0.1"], 2, "--x must be"),
    (["fit", "basketball", "--x", "0.1", "--v", "1"], 2, "not both"),
    (["fit", "basketball", "--n", "0"], 2, "--n must be"),
    (["fit"], 2, "no body: give BALL (a ball of the standards), or --mass and --diameter, or --from"),
    (["pair", "basketball", "x=1"], 2, "x=DEPTH"),
]


@pytest.mark.parametrize("args,code,message", BAD_INPUTS, ids=[" ".join(a) for a, _, _ in BAD_INPUTS])
def test_bad_input_is_one_line_with_exit_status(args, code, message):
    result = run(*args)
    assert result.exit_code == code
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("vrcal: error:") and message in lines[0]
    assert "Traceback" not in result.output


@pytest.mark.parametrize(
    "content,message",
    [
        ("schema_version: 1\nballs: {a: [1\n", "malformed YAML"),
        ("schema_version: 1\nballs:\n  a: {name: x}\n", "balls.a"),
    ],
)
def test_bad_standards_file_is_a_data_error(tmp_path, content, message):
    path = tmp_path / "s.yaml"
    path.write_text(content)
    result = run("--standards", str(path), "fit", "a")
    assert result.exit_code == 1
    assert message in result.stderr and str(path) in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1


def test_h_above_H_in_user_file_is_a_data_error(tmp_path):
    from importlib import resources

    doc = yaml.safe_load(resources.files("vrcal").joinpath("standards.yaml").read_text())
    doc["balls"]["volleyball"]["rebound_m"]["max"] = 1.2
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(doc))
    result = run("--standards", str(path), "fit", "volleyball")
    assert result.exit_code == 1 and "cannot rebound higher" in result.stderr


def test_unwritable_output_leaves_no_file(tmp_path):
    missing_dir = tmp_path / "no" / "such" / "dir" / "out.yaml"
    result = run("fit", "basketball", "-o", str(missing_dir))
    assert result.exit_code == 2 and "does not exist" in result.stderr
    result = run("fit", "basketball", "-o", str(tmp_path))
    assert result.exit_code == 2 and "is a directory" in result.stderr


def test_failed_run_does_not_touch_existing_output(tmp_path):
    out = tmp_path / "b.yaml"
    out.write_text("previous\n")
    result = run("fit", "basketball", "--K", "-1", "-o", str(out))
    assert result.exit_code == 2
    assert out.read_text() == "previous\n"
    assert list(tmp_path.iterdir()) == [out]


def _installed_vrcal():
    exe = shutil.which("vrcal", path=os.path.dirname(sys.executable)) or shutil.which("vrcal")
    if exe is None:
        pytest.skip("the vrcal command is not installed in this environment")
    return exe


def test_installed_command_end_to_end(tmp_path):
    exe = _installed_vrcal()
    out = tmp_path / "basketball.json"
    done = subprocess.run([exe, "fit", "basketball", "--format", "json", "-o", str(out)],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert json.loads(out.read_text())["ball"] == "basketball"
    bad = subprocess.run([exe, "fit", "nosuchball"], capture_output=True, text=True, timeout=120)
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1 and "Traceback" not in bad.stderr


def test_python_dash_m():
    done = subprocess.run([sys.executable, "-m", "vrcal", "--version"], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and __version__ in done.stdout


@pytest.mark.parametrize("args", [
    ("discover", "nothere.csv", "--ball", "tennis"), ("track", "nothere.wav"), ("fit", "--from", "nothere.json"),
    ("scene", "nothere.yaml"), ("discover", ".", "--ball", "tennis"),
])
def test_a_missing_input_file_is_a_usage_error_naming_it(args, tmp_path, monkeypatch):
    """docs/limits.md: a missing file is exit 2; 'track' said 'not a sound or video recording'."""
    monkeypatch.chdir(tmp_path)
    result = run(*args)
    assert result.exit_code == 2 and ("does not exist" in result.stderr or "is a directory" in result.stderr)


@pytest.mark.parametrize("text,what", [('{\n "epsilon": 0.8\n}\n', "JSON"), ('<mujoco model="b">\n</mujoco>\n', "XML")])
def test_a_document_that_is_no_measurement_is_named(text, what, tmp_path):
    path = tmp_path / "f.txt"
    path.write_text(text)
    result = run("discover", str(path), "--ball", "tennis")
    assert result.exit_code == 1 and f" {what} " in result.stderr and "not a measurement" in result.stderr


def test_a_long_refusal_is_printed_whole_and_a_huge_value_is_cut():
    """A PyBullet step refusal (about 450 characters: what was measured, then the options that keep the
    user's step) lost its middle to the cut made for huge quoted values."""
    from vrcal.cli import _one_line

    refusal = ("bullet at --dt 0.00416667 s misses (4 phases x 3 bounces): worst epsilon error 0.013 (tolerance "
               "0.01); the ball turns 16.8 mm from the floor (limit 7.94 mm, --max-penetration); --dt 0.0017 meets "
               "both (run in bullet: error 0.00526, 7.93 mm; 0.0024, 0.0022 and 0.0019 s missed; the error is not "
               "monotonic in the step: another, even a smaller one, can miss); to keep --dt 0.00416667 s, accept "
               "what it achieves: --tolerance 0.014 --max-penetration 0.02")
    assert _one_line(refusal) == refusal
    huge = "bad value '" + "9" * 5000 + "' in column y"
    cut = _one_line(huge)
    assert len(cut) < 1100 and cut.startswith("bad value '999") and cut.endswith("' in column y")
    assert "[5,024 characters]" in cut


def test_the_dt_help_names_every_engines_default_step_from_the_registry():
    """export --help's --dt listed mujoco, bullet and ode but not gazebo (1 ms); the list is made from the
    engine registry, so every engine with a step is named with the step the export uses."""
    from vrcal.engines import ENGINES

    for command in ("export", "verify"):
        shown = " ".join(run(command, "--help").output.split())
        listed = re.search(r"--dt NUMBER Engine time step \[s\] \(default: the engine's: ([^)]*)\)", shown)
        assert listed, shown
        steps = dict(item.split(" ") for item in listed.group(1).split(", "))
        assert set(steps) == {name for name in ENGINES if name != "tables"}
        for name, text in steps.items():
            value = 1.0 / float(text[2:]) if text.startswith("1/") else float(text)
            assert value == pytest.approx(ENGINES[name].default_dt_s, rel=1e-12), (name, text)
    assert "gazebo 0.001" in shown and "bullet 1/240" in shown
