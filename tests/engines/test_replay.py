"""Replay the real ping-pong video in an engine from its discover result (issue 8's number)."""

import json

import numpy as np
import pytest
from click.testing import CliRunner
from helpers import require_engine, shared_file

from vrcal.cli import main
from vrcal.engines.replay import APEX_GOAL, replay, replay_figure

RECORD = "pingpong-drop-video/raw.txt"


@pytest.fixture(scope="module")
def pingpong(tmp_path_factory):
    """``vrcal discover raw.txt --ball table_tennis --fs 100 --json pp.json``, once for the module."""
    record = shared_file(RECORD)
    path = tmp_path_factory.mktemp("pp") / "pp.json"
    result = CliRunner().invoke(main, ["discover", str(record), "--ball", "table_tennis", "--fs", "100",
                                       "--json", str(path), "-q"])
    assert result.exit_code == 0, result.output
    return str(record), str(path)


def test_the_discover_result_names_drag(pingpong):
    doc = json.loads(open(pingpong[1]).read())
    assert "air_drag" in doc["effects"]
    assert 0.3 < doc["parameters"]["air_drag"]["drag_coefficient"] < 0.5


def test_mujoco_replays_each_rebound_apex_within_3_percent(pingpong):
    """At a step of 1 ms (>= 1e-4 s), with drag through MuJoCo's fluid model."""
    require_engine("mujoco")
    record, doc = pingpong
    r = replay(doc, record, "mujoco", dt_s=1e-3, fs_hz=100)
    assert r.dt_s == 1e-3 and r.apex_measured_m.size == 3
    assert np.all(np.abs(r.apex_errors("engine")) <= APEX_GOAL) and r.within_goal
    # the constant-epsilon export misses the later rebounds by far more
    assert np.max(np.abs(r.apex_errors("constant"))) > 0.15
    # the engine is as close to the data as vrcal's own model, and far closer than a constant epsilon
    assert r.gaps_m["engine"] < 2 * r.gaps_m["vrcal"] < r.gaps_m["constant"] / 5
    ax = replay_figure(r)
    assert len(ax.figure.axes) == 2
    import matplotlib.pyplot as plt

    plt.close(ax.figure)


def test_ode_replays_with_the_per_step_drag_force(pingpong):
    require_engine("ode")
    record, doc = pingpong
    r = replay(doc, record, "ode", dt_s=5e-4, fs_hz=100)
    assert r.within_goal


def test_cli_replay_writes_the_figure_and_needs_from(pingpong, tmp_path):
    require_engine("mujoco")
    record, doc = pingpong
    png = tmp_path / "pp.png"
    result = CliRunner().invoke(main, ["verify", "--from", doc, "--against", record, "--fs", "100", "--engine",
                                       "mujoco", "--dt", "1e-3", "--plot", str(png)])
    assert result.exit_code == 0, result.output
    assert "within 3 % of the measured ones: yes" in result.output
    assert png.stat().st_size > 10_000
    result = CliRunner().invoke(main, ["verify", "--against", record, "--engine", "mujoco"])
    assert result.exit_code == 2 and "give --from too" in result.output


def test_a_joint_result_replays_the_run_of_the_record(tmp_path):
    """A discover result of several records: the run whose source is the replayed file gives the release."""
    from vrcal.engines.replay import release_state

    doc = {"model": {"drop_height_m": 1.0, "release_time_s": 0.1, "epsilon": 0.8},
           "runs": [{"source": "a/one.csv", "drop_height_m": 1.5, "release_time_s": 0.3},
                    {"source": "b/two.csv", "model": {"drop_height_m": 2.0, "release_time_s": 0.4}}]}
    assert release_state(doc, "x/two.csv")["drop_height_m"] == 2.0
    assert release_state(doc, "one.csv")["release_time_s"] == 0.3
    assert release_state(doc, "three.csv")["drop_height_m"] == 1.0


def test_a_replay_runs_the_users_file_and_fails_when_its_apexes_miss(pingpong, tmp_path):
    """--file replaces the fresh export (a tampered bounce shows, exit 1); options a replay ignores: exit 2."""
    require_engine("ode")
    record, doc = pingpong
    good = tmp_path / "pp-ode.json"
    result = CliRunner().invoke(main, ["export", "--from", doc, "--engine", "ode", "--dt", "5e-4", "-o", str(good)])
    assert result.exit_code == 0, result.output
    replay_args = ["verify", "--from", doc, "--against", record, "--fs", "100", "--engine", "ode"]
    result = CliRunner().invoke(main, replay_args + ["--file", str(good)])
    assert result.exit_code == 0, result.output
    assert f"engine: {good}" in " ".join(result.output.split()) and "measured ones: yes" in result.output
    tampered = json.loads(good.read_text())
    tampered["contact"]["bounce"] = 0.5
    bad = tmp_path / "tampered.json"
    bad.write_text(json.dumps(tampered))
    result = CliRunner().invoke(main, replay_args + ["--file", str(bad)])
    assert result.exit_code == 1, result.output
    assert "measured ones: no" in result.output
    assert result.output.strip().splitlines()[-1].startswith("vrcal: error: the engine's rebound")
    for extra in (["--epsilon", "0.3"], ["--bounces", "2"], ["--phases", "4"], ["--drop-height", "1"],
                  ["--g", "9.8"], ["--file", str(good), "--stiffness", "0"], ["--K", "8"]):
        result = CliRunner().invoke(main, replay_args + extra)
        assert result.exit_code == 2, (extra, result.output)
        assert "not apply to a replay" in result.output and len(result.output.strip().splitlines()) == 1
