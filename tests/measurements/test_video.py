"""Tests of vrcal.measurements.video: the ball's centre in synthetic videos rendered from a
simulated drop (vrcal.drop.render) -- noise, motion blur, a cluttered background with a static
ball-coloured decoy, a frame-rate conversion that repeats frames --, the scale from the
diameter, the floor, the check against g, the real video of a green ball, and bad videos.
OpenCV is the optional extra 'video': these tests skip without it (and fail in CI)."""

import numpy as np
import pytest
from helpers import require_extra, shared_file

from vrcal.drop.render import VideoScene, render_video
from vrcal.drop.simulate import simulate_drops
from vrcal.errors import DataError, UsageError
from vrcal.measurements import Trajectory, read_measurement
from vrcal.measurements.video import parse_color, parse_roi, track_video
from vrcal.model.body import BallProperties

D = 0.067
BALL = BallProperties(0.0577, D, "tennis")


@pytest.fixture(autouse=True)
def _opencv():
    require_extra("cv2", "video")


def render(directory, name="drop.avi", eps=0.75, H=0.6, n=5, **scene):
    drops = simulate_drops(H, eps, n, BALL, release_time_s=0.2)
    sc = VideoScene(m_per_px=0.0025, floor_row=300.0, height=320, **scene)
    path = directory / name
    truth = render_video(path, drops, D, scene=sc, seed=1)
    return path, truth


@pytest.fixture(scope="module")
def hard(tmp_path_factory):
    """Noise, motion blur and a cluttered background with a static ball-coloured decoy, at once."""
    require_extra("cv2", "video")
    return render(tmp_path_factory.mktemp("video"), blur=True, noise_sd=3.0, clutter=True)


@pytest.mark.parametrize("case", ["plain", "hard"])
def test_centre_within_half_a_pixel(tmp_path, hard, case):
    path, truth = render(tmp_path) if case == "plain" else hard
    vt = track_video(path, diameter_m=D)
    kept = vt.kept & ~truth["straddles_impact"]  # a blurred frame spanning an impact has no single centre
    assert kept.sum() > 40
    err = np.hypot(vt.row_px[kept] - truth["row_px"][kept], vt.col_px[kept] - truth["col_px"][kept])
    assert np.max(err) < 0.5
    assert abs(vt.diameter_px / truth["diameter_px"] - 1) < 0.03
    assert abs(vt.g_measured / 9.80665 - 1) < 0.05


def test_trajectory_gives_epsilon_within_0_005(hard):
    from vrcal.discovery.ranking import discover

    data = read_measurement(hard[0], diameter_m=D)
    assert isinstance(data, Trajectory)
    assert data.release_index > 0
    assert abs(np.min(data.y_m)) < 0.01  # heights are of the ball's bottom above the floor
    result = discover(data, BALL)
    assert abs(result.epsilon - 0.75) < 0.005


def test_a_frame_rate_conversion_is_found_and_undone(tmp_path):
    path, truth = render(tmp_path, repeat_every=5, noise_sd=2.0)
    vt = track_video(path, diameter_m=D)
    assert vt.repeated.sum() == np.sum(np.diff(truth["source_index"]) == 0)
    assert any("evenly spaced at 24.000 fps" in n for n in vt.notes)
    kept = vt.kept
    # times are the source's (24 fps), not the container's 30 fps
    assert np.max(np.abs(vt.t_s[kept] - truth["t_s"][kept])) < 1e-6
    err = np.hypot(vt.row_px[kept] - truth["row_px"][kept], vt.col_px[kept] - truth["col_px"][kept])
    assert np.max(err) < 0.5


def test_a_wrong_frame_rate_shows_in_g(hard):
    path, _ = hard
    vt = track_video(path, diameter_m=D, fps=120.0)  # as if a 4x slow-motion video were read at its capture rate
    assert vt.g_measured > 9.81 * 10
    vt = track_video(path, diameter_m=D, fps=7.5)
    assert vt.g_measured < 9.81 / 10
    assert any("slow-motion" in n for n in vt.notes)


def test_color_and_roi_help_and_are_checked(hard):
    path, truth = hard
    vt = track_video(path, diameter_m=D, color="#28a028", roi="200,0,240,320")
    kept = vt.kept & ~truth["straddles_impact"]
    assert kept.sum() > 40
    assert np.max(np.abs(vt.row_px[kept] - truth["row_px"][kept])) < 0.5  # the region starts at y = 0
    assert np.max(np.abs(vt.col_px[kept] + 200 - truth["col_px"][kept])) < 0.5
    assert parse_color("green") == (50, 150, 50) and parse_color("#ff0000") == (0, 0, 255)
    with pytest.raises(UsageError, match="--color"):
        parse_color("greenish")
    with pytest.raises(UsageError, match="--roi"):
        parse_roi("1,2,3")


def test_bad_videos_fail_in_one_line(tmp_path):
    import cv2

    empty = tmp_path / "empty.avi"
    writer = cv2.VideoWriter(str(empty), cv2.VideoWriter_fourcc(*"MJPG"), 30, (160, 120))
    for _ in range(40):
        writer.write(np.full((120, 160, 3), 128, np.uint8))
    writer.release()
    with pytest.raises(DataError, match="no ball found"):
        read_measurement(empty, diameter_m=D)
    corrupt = tmp_path / "corrupt.mp4"
    corrupt.write_bytes(b"\x00\x00\x00\x18ftypmp42" + b"\x13" * 500)
    with pytest.raises(DataError, match="not a readable video|no frames") as err:
        read_measurement(corrupt, diameter_m=D)
    assert "\n" not in str(err.value)
    path, _ = render(tmp_path)
    with pytest.raises(UsageError, match="diameter"):
        read_measurement(path)


def test_real_video_of_a_green_ball():
    """bounceAmeen.avi (arzafiruddin/BouncingBall): a 26 g, 68.7 mm ball on wood at 29.97 fps, ending with a
    hand picking the ball up. Hand tracking gives per-bounce epsilon 0.68-0.72 (../shared README)."""
    path = shared_file("realval/ameen/bounceAmeen.avi")
    vt = track_video(path, diameter_m=0.0687)
    t, row = vt.t_s[vt.kept], vt.row_px[vt.kept]
    assert 60 <= t.size <= 120  # the hold, the drop and the bounces; not the hand picking it up
    assert t[-1] < 4.5
    # per-bounce epsilon from the flight times (scale-free, g-free): the crossings of the flight parabolas
    from vrcal.measurements.video import _bounce_crossings, _flights

    rel = vt.trajectory.release_index
    crossings = np.array([c[0] for c in _bounce_crossings(t[rel:], _flights(t[rel:], row[rel:]))])
    ratios = np.diff(crossings)[1:] / np.diff(crossings)[:-1]
    assert ratios.size >= 2 and np.all((ratios > 0.68) & (ratios < 0.73))
