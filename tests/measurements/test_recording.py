"""End-to-end tests of 'vrcal track' and of 'vrcal discover' on recordings: the measurement file
written (notes as comments, read back to the same data), the figure, and bad input (one line,
exit 1 or 2, nothing left behind)."""

import numpy as np
from click.testing import CliRunner
from helpers import require_extra

from vrcal.cli import main
from vrcal.drop.render import SoundScene, impact_sound, write_wav
from vrcal.drop.simulate import simulate_drops
from vrcal.measurements import read_measurement
from vrcal.model.body import BallProperties


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def wav(tmp_path, name="drop.wav"):
    d = simulate_drops(0.8, 0.8, 10, BallProperties(0.0577, 0.067), release_time_s=0.3)
    t = d.impact_times_s[0]
    x = impact_sound(t, d.impact_speeds_m_per_s[0], scene=SoundScene(noise_rms=0.001, echoes=((0.005, 0.4),)),
                     seed=0)
    path = tmp_path / name
    write_wav(path, x, 48000)
    return path, t


def test_track_writes_impact_times_that_read_back(tmp_path):
    path, t = wav(tmp_path)
    out, fig = tmp_path / "impacts.csv", tmp_path / "impacts.png"
    result = run("track", path, "-o", out, "--plot", fig)
    assert result.exit_code == 0, result.output
    assert "10 impacts" in result.output
    text = out.read_text()
    assert text.startswith("# vrcal track: impact times from")
    back = read_measurement(out)
    direct = read_measurement(path)
    assert np.array_equal(back.t_s, np.round(direct.t_s, 6))
    assert np.max(np.abs(back.t_s - t)) < 2.5e-4
    assert fig.stat().st_size > 10000


def test_discover_takes_the_sound_file(tmp_path):
    path, _ = wav(tmp_path)
    result = run("discover", path, "--ball", "tennis", "-q")
    assert result.exit_code == 0, result.output
    text = " ".join(result.output.split())
    assert "drop.wav (impacts, 10 impact times)" in text
    assert "recording: WAV, 48 kHz, mono, 16-bit" in text


def test_track_of_a_video_round_trips(tmp_path):
    require_extra("cv2", "video")
    from vrcal.drop.render import VideoScene, render_video

    d = simulate_drops(0.6, 0.8, 4, BallProperties(0.0577, 0.067), release_time_s=0.2)
    path = tmp_path / "drop.avi"
    render_video(path, d, 0.067, scene=VideoScene(width=320, x_px=160.0, height=320, floor_row=300.0, noise_sd=2.0))
    out = tmp_path / "drop.csv"
    result = run("track", path, "--ball", "tennis", "-o", out, "--plot", tmp_path / "drop.png")
    assert result.exit_code == 0, result.output
    back = read_measurement(out)
    from vrcal.model.body import ball_from_options

    direct = read_measurement(path, diameter_m=float(ball_from_options("tennis", None, None, None)[0].diameter_m))
    assert np.allclose(back.t_s, direct.t_s, atol=1e-6) and np.allclose(back.y_m, direct.y_m, atol=1e-6)
    assert back.release_index == direct.release_index
    assert "t (s),y (m),x (m),quality" in out.read_text().splitlines()


def test_bad_recordings_fail_in_one_line_and_leave_nothing(tmp_path):
    silent = tmp_path / "silent.wav"
    write_wav(silent, np.zeros((24000, 1)), 48000)
    junk = tmp_path / "junk.mp4"
    junk.write_bytes(b"\x00\x00\x00\x18ftypisom" + bytes(range(256)) * 4)
    text = tmp_path / "table.csv"
    text.write_text("t,y\n0,1\n")
    for args, code, words in [
        (("track", silent), 1, "silent"),
        (("track", junk, "--diameter", "0.067"), 1, "video"),
        (("track", text), 1, "not a sound or video recording"),
        (("track", silent, "--color", "red"), 2, "apply to videos"),
        (("track", silent, "--rotate", "90"), 2, "apply to videos"),
        (("track", silent, "--rotate", "45"), 2, "'45' is not one of '0', '90', '180', '270'"),
        (("discover", silent, "--ball", "tennis"), 1, "silent"),
    ]:
        out = tmp_path / "out.csv"
        result = run(*args, "-o", out) if args[0] == "track" else run(*args)
        assert result.exit_code == code, (args, result.output)
        lines = [ln for ln in result.output.splitlines() if ln.strip()]
        assert len(lines) == 1 and lines[0].startswith("vrcal: error:") and words in lines[0], result.output
        assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["junk.mp4", "silent.wav", "table.csv"]


def test_simulate_writes_recordings(tmp_path):
    out = tmp_path / "drop.wav"
    result = run("simulate", "tennis", "--format", "wav", "--bounces", "5", "-o", out)
    assert result.exit_code == 0, result.output
    assert read_measurement(out).t_s.size == 5
    result = run("simulate", "tennis", "--format", "wav")
    assert result.exit_code == 2 and "-o FILE" in result.output
