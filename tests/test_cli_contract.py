"""The CLI held to its contract end to end (probe 9): one-line errors with usable ranges, exit
codes, the one -o extension rule, stdin/FIFO inputs, full-precision machine files, file modes."""

import json
import os
import shlex
import stat
import subprocess
import sys

import numpy as np
import pytest
from click.testing import CliRunner

from tests.helpers import require_extra
from vrcal.cli import main


def run(*args, **kw):
    return CliRunner().invoke(main, [str(a) for a in args], **kw)


def vrcal(*args, cwd, stdin=None, timeout=60):
    """The installed command (python -m vrcal) in a subprocess."""
    return subprocess.run([sys.executable, "-m", "vrcal", *map(str, args)], cwd=cwd, input=stdin,
                          capture_output=True, timeout=timeout)


def one_line_error(result, code):
    assert result.exit_code == code, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("vrcal: error: ") and "Traceback" not in result.output
    return lines[0]


@pytest.mark.parametrize("args, says", [
    (("--format", "wav", "--fs", "10"), "8000 to 384000 Hz"),
    (("--format", "wav", "--fs", "1"), "8000 to 384000 Hz"),
    (("--format", "video", "--fs", "0.001"), "10 Hz or more"),
    (("--format", "video", "--fs", "1e6"), "more than the limit of 10,000"),
])
def test_simulate_recording_rate_out_of_range_is_one_usage_line(tmp_path, args, says):
    out = tmp_path / ("k.wav" if "wav" in args else "k.avi")
    line = one_line_error(run("simulate", "tennis", *args, "-o", out), 2)
    assert says in line and not out.exists() and not list(tmp_path.iterdir())


def test_track_refuses_a_sound_below_the_lowest_rate_and_the_simulated_lowest_rate_tracks(tmp_path):
    from vrcal.drop.render import WAV_RATE_HZ, impact_sound, write_wav
    from vrcal.measurements.sound import MIN_SAMPLE_RATE_HZ

    assert WAV_RATE_HZ[0] == MIN_SAMPLE_RATE_HZ
    low = tmp_path / "low.wav"
    t = np.array([0.5, 1.2, 1.7, 2.05])
    write_wav(low, impact_sound(t, np.array([4.0, 3.0, 2.2, 1.6]), fs_hz=4000), 4000)
    line = one_line_error(run("track", low, "-q"), 1)
    assert "4000 Hz" in line and "8000 Hz" in line
    ok = tmp_path / "ok.wav"
    assert run("simulate", "tennis", "--format", "wav", "--fs", "8000", "-o", ok).exit_code == 0
    result = run("track", ok, "-q")
    assert result.exit_code == 0 and result.output.count("\n") > 5


def test_simulated_video_has_the_usual_mode(tmp_path):
    require_extra("cv2", "video")
    old = os.umask(0o022)
    try:
        out = tmp_path / "v.avi"
        assert run("simulate", "table_tennis", "--bounces", "3", "--format", "video", "-o", out).exit_code == 0
    finally:
        os.umask(old)
    assert stat.S_IMODE(out.stat().st_mode) == 0o644
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def test_corrupt_video_prints_only_vrcals_line(tmp_path):
    require_extra("cv2", "video")
    bad = tmp_path / "bin.mp4"
    bad.write_bytes(np.random.default_rng(0).integers(0, 256, 4096, dtype=np.uint8).tobytes())
    for args in (("track", bad, "--ball", "tennis", "-q"), ("discover", bad, "--ball", "tennis", "-q")):
        p = vrcal(*args, cwd=tmp_path)
        err = p.stderr.decode().strip().splitlines()
        assert p.returncode == 1 and len(err) == 1 and err[0].startswith("vrcal: error: "), p.stderr


def test_track_reads_a_fifo_and_stdin_once(tmp_path):
    wav = tmp_path / "drop.wav"
    assert run("simulate", "tennis", "--format", "wav", "-o", wav).exit_code == 0
    expected = vrcal("track", "drop.wav", "-q", cwd=tmp_path).stdout.decode().replace("drop.wav", "X")
    fifo = tmp_path / "fifo.wav"
    os.mkfifo(fifo)
    writer = subprocess.Popen(["sh", "-c", f"cat '{wav}' > '{fifo}'"])
    try:
        p = vrcal("track", "fifo.wav", "-q", cwd=tmp_path, timeout=60)
    finally:
        writer.wait(timeout=60)
    assert p.returncode == 0 and p.stdout.decode().replace("fifo.wav", "X") == expected
    for name in ("/dev/stdin", "-"):
        p = vrcal("track", name, "-q", cwd=tmp_path, stdin=wav.read_bytes())
        assert p.returncode == 0, p.stderr
        text = p.stdout.decode()
        assert f"impact times from {name}" in text
        assert text.split("# recording:")[1] == expected.split("# recording:")[1]   # all but the title
    assert not list(tmp_path.glob("vrcal-*"))


def test_round_trips_into_discover_simulate_track_stdin(tmp_path):
    """vrcal's own readers read its writers' files: simulate's CSV (t [s]), track's (t (s)), and a
    track piped into discover (-)."""
    sim = tmp_path / "sim.csv"
    assert run("simulate", "tennis", "--bounces", "5", "-o", sim).exit_code == 0
    assert "t [s]" in sim.read_text()
    result = run("discover", sim, "--ball", "tennis", "-q")
    assert result.exit_code == 0 and "(trajectory" in result.output
    wav = tmp_path / "drop.wav"
    assert run("simulate", "tennis", "--format", "wav", "-o", wav).exit_code == 0
    impacts = tmp_path / "impacts.csv"
    assert run("track", wav, "-q", "-o", impacts).exit_code == 0
    assert "t (s)" in impacts.read_text()
    from_file = run("discover", impacts, "--ball", "tennis", "-q")
    assert from_file.exit_code == 0 and "(impacts" in from_file.output
    piped = vrcal("discover", "-", "--ball", "tennis", "-q", "--json", "-", cwd=tmp_path,
                  stdin=impacts.read_bytes())
    assert piped.returncode == 0, piped.stderr
    doc = json.loads(piped.stdout)
    assert doc["reader"]["files"] == ["-"] if "reader" in doc else "-" in piped.stdout.decode()
    assert "vrcal-" not in piped.stdout.decode()
    text = vrcal("discover", "-", "--ball", "tennis", "-q", cwd=tmp_path, stdin=impacts.read_bytes())
    head = text.stdout.decode().splitlines()[0]   # wrapped with '-' in it, not the temporary copy's path
    assert head.startswith("vrcal discover: - (impacts") and head.endswith("D = 67.0 mm)"), head


def test_track_summary_and_comments_fit_100_columns(tmp_path):
    wav = tmp_path / "drop.wav"
    assert run("simulate", "tennis", "--format", "wav", "-o", wav).exit_code == 0
    out = tmp_path / "d.csv"
    result = run("track", wav, "-o", out)
    assert result.exit_code == 0
    assert max(map(len, result.output.splitlines())) <= 100
    comments = [line for line in out.read_text().splitlines() if line.startswith("#")]
    assert len(comments) > 2 and all(len(c) <= 100 and c.startswith("# ") for c in comments)
    assert run("discover", out, "--ball", "tennis", "-q").exit_code == 0


@pytest.mark.parametrize("args, out", [
    (("fit", "tennis"), "fit.csv"), (("fit", "tennis"), "fit.md"), (("pair", "tennis", "floor"), "p.csv"),
    (("simulate", "tennis"), "s.json"), (("table2",), "x.xml"), (("track", "IN.wav"), "t.json"),
    (("export", "tennis", "--engine", "ode"), "o.xml"), (("export", "tennis", "--engine", "mujoco"), "m.sdf"),
])
def test_an_extension_naming_a_format_the_command_cannot_write_is_a_usage_error(tmp_path, args, out):
    args = tuple(str(tmp_path / "IN.wav") if a == "IN.wav" else a for a in args)
    if "track" in args:
        (tmp_path / "IN.wav").write_bytes(b"")
    line = one_line_error(run(*args, "-o", tmp_path / out), 2)
    assert "which this command does not write; it writes" in line
    assert not (tmp_path / out).exists()


@pytest.mark.parametrize("args, written", [(("fit", "tennis"), "yaml"), (("table2",), "markdown"),
                                           (("simulate", "tennis", "--bounces", "3"), "csv")])
def test_an_unknown_extension_keeps_the_default_and_says_so(tmp_path, args, written):
    out = tmp_path / "result.xyz"
    result = run(*args, "-o", out)
    assert result.exit_code == 0
    assert f"vrcal: warning: -o '{out}': the extension '.xyz' names no format vrcal knows: wrote {written}" \
        in result.output
    assert out.exists()


def test_the_extension_chooses_the_export_file(tmp_path):
    t = tmp_path / "t.json"
    assert run("export", "tennis", "--engine", "tables", "-o", t).exit_code == 0
    assert json.loads(t.read_text())["engine"] == "tables"


@pytest.mark.parametrize("command, hint", [("verify", "--format json"), ("discover", "--json FILE")])
def test_o_on_a_command_without_it_hints(tmp_path, command, hint):
    line = one_line_error(run(command, "tennis", "-o", tmp_path / "x"), 2)
    assert "No such option" in line and hint in line


@pytest.mark.parametrize("engine", ["ode", "bullet"])
def test_ode_and_bullet_files_carry_schema_version_and_units(tmp_path, engine):
    out = tmp_path / "e.json"
    assert run("export", "basketball", "--engine", engine, "--dt", "1e-3", "-o", out).exit_code == 0
    doc = json.loads(out.read_text())
    assert doc["schema_version"] >= 1
    key = "world.dt" if engine == "ode" else "setPhysicsEngineParameter.fixedTimeStep"
    assert doc["units"][key] == "s"
    for path in doc["units"]:   # every unit names a key of the file
        node = doc
        for part in path.split("."):
            node = node[next(iter(node))] if part == "*" else node[part]


def test_table2_csv_has_full_precision():
    from vrcal.model.standards import load_standards
    from vrcal.model.table2 import regenerate

    rows = run("table2", "--K", "4", "--format", "csv").output.splitlines()
    first = rows[1].split(",")
    exact = regenerate(load_standards(), 4.0)["rows"][0]
    assert first[0] == exact["ball"] and float(first[2]) == exact["epsilon"]["nominal"]
    assert repr(exact["epsilon"]["nominal"]) == first[2]


def test_missing_files_in_option_values_are_usage_errors(tmp_path):
    line = one_line_error(run("pair", f"from={tmp_path / 'missing.csv'}", "floor"), 2)
    assert "does not exist" in line
    line = one_line_error(run("verify", "--from", tmp_path / "x.json", "--against", tmp_path / "raw.txt",
                              "--engine", "mujoco"), 2)
    assert "does not exist" in line


def test_help_examples_are_runnable_as_written():
    """Every 'vrcal ...' line of every command's help parses as a shell line whose explanation is a
    '#' comment, and click accepts its options."""
    def walk(group, path):
        for name, cmd in group.commands.items():
            yield [*path, name], cmd
            if hasattr(cmd, "commands"):
                yield from walk(cmd, [*path, name])

    seen = 0
    for path, cmd in walk(main, []):
        for line in (cmd.help or "").splitlines():
            line = line.strip()
            if not line.startswith("vrcal ") or "&&" in line:
                continue
            words = shlex.split(line, comments=True)
            assert not any(w.startswith("(") or w.endswith(")") for w in words), line
            main.make_context("vrcal", words[1:], resilient_parsing=True)
            seen += 1
    assert seen > 30


def test_plot_curves_creates_missing_parents(tmp_path):
    out = tmp_path / "nodir" / "figs"
    assert run("plot", "curves", "-o", out).exit_code == 0 and len(list(out.glob("*.png"))) == 4


def test_simulates_extension_chooses_a_recording_without_format(tmp_path):
    """`vrcal simulate tennis -o drop.wav` writes the WAV the extension names (it was refused: 'does not
    write wav'); with --format impacts the .wav is refused naming what that format writes."""
    wav = tmp_path / "drop.wav"
    result = run("simulate", "tennis", "-o", wav)
    assert result.exit_code == 0, result.output
    assert wav.read_bytes()[:4] == b"RIFF"
    refused = run("simulate", "tennis", "--format", "impacts", "-o", tmp_path / "x.wav")
    assert refused.exit_code == 2 and "--format impacts writes csv, not wav" in refused.output
    assert not (tmp_path / "x.wav").exists()


def test_names_a_user_would_type_for_csv_data_and_sdf_are_written(tmp_path):
    """CSV data in a .txt file (as Tracker and phyphox write it) and an SDF world in .xml were refused by
    the -o rule; a MuJoCo export's JSON summary given to verify says what verify needs."""
    ap = tmp_path / "ap.txt"
    assert run("simulate", "table_tennis", "--format", "apexes", "-o", ap).exit_code == 0
    assert ap.read_text().startswith("bounce,h")
    sdf = tmp_path / "tennis.xml"
    assert run("export", "tennis", "--engine", "gazebo", "-o", sdf).exit_code == 0
    assert "<sdf" in sdf.read_text()
    assert run("fit", "basketball", "-o", tmp_path / "f.csv").exit_code == 2    # fit writes no CSV
    summary = tmp_path / "x.json"
    assert run("export", "basketball", "--engine", "mujoco", "-o", summary).exit_code == 0
    result = run("verify", "--engine", "mujoco", "--file", summary)
    assert result.exit_code == 1 and "export it with -o FILE.xml" in result.output
