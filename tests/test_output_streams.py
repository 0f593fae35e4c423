"""What a script that consumes vrcal's output relies on: the discover JSON's top-level epsilon is the one to
use; text survives any stdout encoding; a failed stdout write is one line; '-' is stdout; machine files carry
SI numbers; an -o file keeps its permissions and a figure its bytes; a file name that is not UTF-8 is
escaped, never a lone surrogate."""

import json
import os
import stat
import subprocess
import sys

import pytest
from click.testing import CliRunner
from helpers import require_engine, shared_file

from vrcal.cli import main

PINGPONG = "realval/giiulia/pingpong_30cm_L1.csv"


def run(*args, code=0):
    result = CliRunner().invoke(main, [str(a) for a in args])
    assert result.exit_code == code, result.output
    return result


def vrcal(*args, env=None, **kwargs):
    """``python -m vrcal ARGS`` in a subprocess (real stdout/stderr file descriptors and encodings)."""
    streams = {"stdout": subprocess.PIPE, "stderr": subprocess.PIPE, **kwargs}
    return subprocess.run([sys.executable, "-m", "vrcal", *map(str, args)], timeout=300,
                          env={**os.environ, **(env or {})}, **streams)


# --------------------------------------------------------------------------- 1: the discover JSON's epsilon


@pytest.fixture(scope="module")
def pingpong_json(tmp_path_factory):
    out = tmp_path_factory.mktemp("pp") / "pp30.json"
    result = run("discover", shared_file(PINGPONG), "--ball", "table_tennis", "-q", "--json", out)
    return out, result.stdout


def test_discover_json_top_level_epsilon_is_the_recommended_one(pingpong_json):
    path, report = pingpong_json
    d = json.loads(path.read_text())
    assert d["schema_version"] == 2 and d["recommended"] == "prior_split"
    # the report's "Use this" value (at the reference speed), not the named model's rival
    assert f"{d['epsilon']:.4f} ± {d['epsilon_uncertainty']:.4f} at {d['epsilon_reference_speed_m_per_s']:.2f}" \
        in " ".join(report.split())
    assert d["epsilon"] == d["prior_split"]["epsilon"] != d["named"]["epsilon"]
    assert round(d["named"]["epsilon"], 4) == 0.9542 and round(d["epsilon"], 4) == 0.9495
    assert d["effects"] == ["air_drag", "velocity_dependent_restitution"] and d["named"]["effects"] == ["air_drag"]
    assert d["parameters"] == d["prior_split"]["parameters"]
    assert d["uncertainties"]["velocity_dependent_restitution"]["exponent"] > 0
    # what --from takes is the top-level value
    from vrcal.model.body import read_discover_json

    assert read_discover_json(path)["epsilon"] == d["epsilon"]


def test_discover_json_of_schema_1_is_still_read_as_before(pingpong_json, tmp_path):
    """A file of schema 1 held the named model at the top level: --from takes its prior split as before."""
    from vrcal.model.body import read_discover_json

    d = json.loads(pingpong_json[0].read_text())
    old = {**d, "schema_version": 1, **{k: d["named"][k] for k in ("epsilon", "effects", "parameters")}}
    del old["named"], old["recommended"]
    (tmp_path / "v1.json").write_text(json.dumps(old))
    doc, new = read_discover_json(tmp_path / "v1.json"), read_discover_json(pingpong_json[0])
    assert doc["epsilon"] == new["epsilon"] == d["epsilon"]
    assert doc["effects"] == new["effects"] and doc["named"]["epsilon"] == new["named"]["epsilon"]
    fit_old = run("fit", "--from", tmp_path / "v1.json", "--format", "json").stdout
    fit_new = run("fit", "--from", pingpong_json[0], "--format", "json").stdout
    assert json.loads(fit_old)["epsilon"] == json.loads(fit_new)["epsilon"]


# --------------------------------------------------------------------------- 2: any stdout encoding


@pytest.mark.parametrize("encoding", ["latin-1", "cp1252"])   # ascii: click writes UTF-8
@pytest.mark.parametrize("args", [("fit", "basketball"), ("pair", "tennis", "floor"), ("table2",)], ids=" ".join)
def test_text_output_survives_a_stdout_encoding_without_its_characters(args, encoding):
    done = vrcal(*args, env={"PYTHONIOENCODING": encoding, "PYTHONUTF8": "0", "LC_ALL": "C"})
    assert done.returncode == 0, done.stderr.decode("latin-1")
    assert b"Traceback" not in done.stderr
    text = done.stdout.decode(encoding)
    assert "eps" in text or "ε" in text


def test_ascii_fallback_spells_vrcal_s_characters():
    from vrcal.textout import ASCII_FALLBACK

    assert "ε = 0.7 ± 0.1 m/s² √x·y −1 s⁻¹ 5 °".encode("ascii", ASCII_FALLBACK) == \
        b"eps = 0.7 +- 0.1 m/s^2 sqrtx*y -1 s^-1 5  deg"
    assert "ε ± ²".encode("latin-1", ASCII_FALLBACK) == "eps ± ²".encode("latin-1")


def test_plot_curves_and_scene_print_on_a_latin1_stdout(tmp_path):
    from helpers import EXAMPLES

    env = {"PYTHONIOENCODING": "latin-1", "MPLBACKEND": "Agg"}
    done = vrcal("plot", "curves", "-o", tmp_path / "figs", env=env)
    assert done.returncode == 0 and b"Traceback" not in done.stderr, done.stderr
    done = vrcal("scene", EXAMPLES / "figure8-basketball.yaml", "--no-animation", "-o", tmp_path / "s", env=env)
    assert done.returncode == 0 and b"Traceback" not in done.stderr, done.stderr


# --------------------------------------------------------------------------- 3: a full stdout


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="no /dev/full here")
@pytest.mark.parametrize("args", [("fit", "tennis"), ("table2", "--format", "json"), ("simulate", "tennis")],
                         ids=" ".join)
def test_a_full_stdout_is_one_line_and_exit_2(args):
    with open("/dev/full", "w") as full:
        done = vrcal(*args, stdout=full, stderr=subprocess.PIPE)
    err = done.stderr.decode()
    assert done.returncode == 2, err
    assert err == "vrcal: error: cannot write to stdout: No space left on device\n"


def test_a_broken_pipe_stays_quiet():
    done = subprocess.run(f"{sys.executable} -m vrcal simulate tennis --fs 20000 | head -1", shell=True,
                          capture_output=True, timeout=300)
    assert done.stdout.startswith(b"t [s]") and done.stderr == b""


# --------------------------------------------------------------------------- 4: '-' is stdout


def test_report_dash_is_refused_and_makes_no_directory(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    run("simulate", "tennis", "--noise", "0.002", "-o", "drop.csv")
    result = run("discover", "drop.csv", "--ball", "tennis", "--json", "-", "--report", "-", code=2)
    assert "a directory of several files" in result.output and len(result.output.splitlines()) == 1
    assert not os.path.exists("-")
    result = run("plot", "curves", "-o", "-", code=2)
    assert not os.path.exists("-")


def test_dash_is_stdout_even_beside_a_directory_named_dash(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    os.mkdir("-")
    assert run("fit", "tennis", "-o", "-").stdout.startswith("tennis: ")
    assert json.loads(run("pair", "tennis", "floor", "--format", "json", "-o", "-").stdout)["schema_version"]


# --------------------------------------------------------------------------- 5, 6: engine machine files


@pytest.mark.parametrize("engine,name", [("mujoco", "t.xml"), ("ode", "t.json"), ("bullet", "t.json"),
                                         ("gazebo", "t.sdf")])
def test_verify_json_settings_are_si_numbers_with_units_in_keys(engine, name, tmp_path):
    require_engine("ode" if engine == "gazebo" else engine)
    path = tmp_path / name
    run("export", "tennis", "--engine", engine, "--dt", "1e-3", "-o", path)
    settings = json.loads(run("verify", "--engine", engine, "--file", path, "--format", "json").stdout)["settings"]
    assert all(" " not in k for k in settings), settings
    assert all(not isinstance(v, str) or k in ("integrator", "solver", "contact") for k, v in settings.items())
    if engine == "mujoco":
        assert isinstance(settings["solref"], list) and 0 < settings["margin_m"] < 0.05
        text = run("verify", "--engine", engine, "--file", path).stdout
        assert "margin " in text and " mm" in text   # people keep their text


def test_export_json_carries_what_the_file_sets():
    require_engine("mujoco")
    d = json.loads(run("export", "tennis", "--engine", "mujoco", "--format", "json").stdout)
    assert d["dt_s"] == 0.002 and d["integrator"] == "Euler" and len(d["solref"]) == 2
    g = json.loads(run("export", "tennis", "--engine", "gazebo", "--format", "json").stdout)
    assert g["dt_s"] > 0 and g["surfaces"]["ball"]["restitution_coefficient"] == pytest.approx(g["target_epsilon"])
    assert g["surfaces"]["floor"]["kp_n_per_m"] > 0 and g["target"]["drop_height_m"] > 0


def test_export_format_and_extension_agree(tmp_path):
    require_engine("mujoco")
    result = run("export", "tennis", "--engine", "mujoco", "--format", "json", "-o", tmp_path / "mjx.xml", code=2)
    assert "--format json with -o" in result.output and not (tmp_path / "mjx.xml").exists()
    run("export", "tennis", "--engine", "mujoco", "--format", "text", "-o", tmp_path / "mj.txt")
    assert (tmp_path / "mj.txt").read_text().startswith("<mujoco")
    run("export", "tennis", "--engine", "mujoco", "--format", "text", "-o", tmp_path / "mj.json", code=2)


# --------------------------------------------------------------------------- 7, 8: files


def test_replacing_a_file_keeps_its_permissions(tmp_path):
    path = tmp_path / "m600.json"
    path.write_text("{}")
    path.chmod(0o600)
    run("fit", "tennis", "-o", path)
    assert stat.S_IMODE(path.stat().st_mode) == 0o600 and json.loads(path.read_text())["ball"]


@pytest.mark.parametrize("fmt", ["svg", "pdf", "png"])   # what --plot and plot curves write
def test_figures_are_the_same_bytes_every_time(fmt):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from vrcal.fileio import figure_bytes

    def draw():
        fig, ax = plt.subplots()
        ax.plot([0, 1], [1, 0])
        ax.set_title("ε")
        try:
            return figure_bytes(fig, fmt)
        finally:
            plt.close(fig)

    first = draw()
    assert draw() == first
    assert b"dc:date" not in first and b"CreationDate" not in first


# --------------------------------------------------------------------------- 9: names that are not UTF-8


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX file names are bytes")
def test_a_file_name_that_is_not_utf8_is_escaped_in_json_and_messages(tmp_path):
    run("simulate", "tennis", "--noise", "0.002", "-o", tmp_path / "drop.csv")
    name = os.fsdecode(b"lat\xe9.csv")
    os.rename(tmp_path / "drop.csv", tmp_path / name)
    done = vrcal("discover", name, "--ball", "tennis", "-q", "--json", "lat.json", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    raw = (tmp_path / "lat.json").read_bytes()
    raw.decode("utf-8")                       # strict UTF-8
    assert "\\udce9" not in raw.decode() and json.loads(raw)["data"]["source"] == "lat\\xe9.csv"
    assert b"lat\\xe9.csv" in done.stdout and b"\xe9" not in done.stdout
