"""Tests of vrcal.measurements.video: the ball's centre in synthetic videos rendered from a
simulated drop (vrcal.drop.render) -- noise, motion blur, a cluttered background with a static
ball-coloured decoy, a frame-rate conversion that repeats frames --, the scale (from g and the
diameter), the floor, the frames left out, the real video of a green ball, and bad videos.
OpenCV is the optional extra 'video': these tests skip without it (and fail in CI).
The videos are small (320x320 px, a 27 px ball, about 3 s) to keep the tests fast."""

import numpy as np
import pytest
from helpers import require_extra, shared_file

from vrcal.drop.render import VideoScene, render_video
from vrcal.drop.simulate import simulate_drops
from vrcal.errors import DataError, UsageError
from vrcal.measurements import read_measurement
from vrcal.measurements.video import STANDARD_GRAVITY, parse_color, parse_roi, track_video
from vrcal.model.body import BallProperties

D = 0.067
BALL = BallProperties(0.0577, D, "tennis")
M_PER_PX = 0.0025
FLOOR_ROW = 300.0


@pytest.fixture(autouse=True)
def _opencv():
    require_extra("cv2", "video")


def render(directory, name="drop.avi", eps=0.75, H=0.6, n=5, effects=None, **scene):
    drops = simulate_drops(H, eps, n, BALL, release_time_s=0.2, effects=effects)
    sc = VideoScene(width=320, x_px=160.0, m_per_px=M_PER_PX, floor_row=FLOOR_ROW, height=320, **scene)
    path = directory / name
    truth = render_video(path, drops, D, scene=sc, seed=1)
    return path, truth


def contact_row(truth):
    return FLOOR_ROW - truth["diameter_px"] / 2


@pytest.fixture(scope="module")
def hard(tmp_path_factory):
    """Noise, motion blur and a cluttered background with a static ball-coloured decoy, at once."""
    require_extra("cv2", "video")
    return render(tmp_path_factory.mktemp("video"), blur=True, noise_sd=3.0, clutter=True)


@pytest.fixture(scope="module")
def plain(tmp_path_factory):
    """A noise-free video of a ball lit from above (lighter on top, darker below)."""
    require_extra("cv2", "video")
    return render(tmp_path_factory.mktemp("video"))


@pytest.mark.parametrize("case", ["plain", "hard"])
def test_centre_scale_and_floor(plain, hard, case):
    path, truth = plain if case == "plain" else hard
    vt = track_video(path, diameter_m=D)
    kept = vt.kept & ~truth["straddles_impact"]  # a blurred frame spanning an impact has no single centre
    assert kept.sum() > 40
    err = np.hypot(vt.row_px[kept] - truth["row_px"][kept], vt.col_px[kept] - truth["col_px"][kept])
    assert np.max(err) < 0.5
    # the shading of a ball lit from above biases no centroid: the mean row error is far below a pixel
    assert abs(np.mean(vt.row_px[kept] - truth["row_px"][kept])) < 0.05
    assert abs(vt.diameter_px / truth["diameter_px"] - 1) < 0.01
    assert abs(vt.scale_m_per_px / M_PER_PX - 1) < 0.003
    assert abs(vt.contact_row_px - contact_row(truth)) < 0.1
    assert abs(vt.g_measured / STANDARD_GRAVITY - 1) < 0.02
    assert not vt.repeated.any()  # a noise-free still scene repeats no frame


def test_clean_videos_give_epsilon_and_name_no_effect(plain, hard):
    """epsilon within 0.005, and no effect named: the trajectory carries the tracker's own errors
    (the centres' systematic error, 0.05 px, and the floor level's uncertainty), which discover adds
    to the noise it measures -- the third differences of a noise-free video see none of it, and a
    floor 0.01 px off would otherwise be a 'material' height offset (see benchmarks/bench_track.py)."""
    from vrcal.discovery.ranking import discover

    for path, _ in (plain, hard):
        vt = track_video(path, diameter_m=D)
        data = vt.trajectory
        assert data.release_index > 0
        assert abs(np.min(data.y_m)) < 0.01  # heights are of the ball's bottom above the floor
        assert data.systematic_m == pytest.approx(vt.systematic_m) and data.systematic_m > 0
        assert 0 < data.floor_sd_m < 0.01 * D
        result = discover(data, BALL)
        assert abs(result.epsilon - 0.75) < 0.005
        assert not result.effects
        assert "systematic error of the centres" in result.noise_source


def test_a_tracked_file_keeps_the_trackers_errors(plain, tmp_path):
    """'vrcal track' writes the systematic error and the floor's uncertainty as '# vrcal KEY = VALUE'
    comments; reading the file back gives them to discover."""
    from vrcal.measurements.recording import track

    path, _ = plain
    tracked = track(str(path), diameter_m=D)
    out = tmp_path / "drop.csv"
    out.write_text(tracked.text)
    back = read_measurement(out)
    assert back.systematic_m == pytest.approx(tracked.measurement.systematic_m, rel=1e-3)
    assert back.floor_sd_m == pytest.approx(tracked.measurement.floor_sd_m, rel=1e-3)
    out.write_text(tracked.text.replace("# vrcal floor_sd_m = ", "# vrcal floor_sd_m = -"))
    with pytest.raises(DataError, match=r"drop.csv:\d+: 'floor_sd_m = -"):
        read_measurement(out)


def test_a_blurred_frame_spanning_an_impact_is_left_out(hard):
    path, truth = hard
    vt = track_video(path, diameter_m=D)
    straddling = truth["straddles_impact"]
    above = straddling & (truth["row_px"] - vt.row_px > 0.3)  # the blurred image lies above the path
    assert above.any() and not (vt.kept & above).any()
    assert any("spans the impact" in n for n in vt.notes)


def test_the_scale_comes_from_g_when_the_diameter_disagrees(plain):
    path, truth = plain
    vt = track_video(path, diameter_m=1.1 * D)  # as if the apparent diameter were 10 % too small
    assert abs(vt.scale_m_per_px / M_PER_PX - 1) < 0.003
    assert abs(vt.g_measured / STANDARD_GRAVITY - 1.1) < 0.02
    assert any(n.startswith("scale:") and "from g" in n for n in vt.notes)
    assert any(n.startswith("not used: the ball's apparent diameter") for n in vt.notes)
    assert any("buoyancy" in n and "cannot be told" in n for n in vt.notes)
    # the flights' scale takes the local g as known (--g)
    local = track_video(path, diameter_m=1.1 * D, g_m_per_s2=9.78)
    assert local.scale_m_per_px == pytest.approx(vt.scale_m_per_px * 9.78 / STANDARD_GRAVITY, rel=1e-9)
    assert any("from g (9.78 m/s^2" in n for n in local.notes)
    read = read_measurement(path, diameter_m=1.1 * D, g_m_per_s2=9.78)  # discover's way in
    assert np.allclose(read.y_m, local.trajectory.y_m)
    vt = track_video(path, diameter_m=D, scale_m_per_px=0.003)  # a given scale is kept
    assert vt.scale_m_per_px == 0.003 and any("(given)" in n for n in vt.notes)


def test_a_wrong_frame_rate_is_suspected_not_absorbed(hard):
    path, truth = hard
    for fps, off in ((120.0, lambda g: g > STANDARD_GRAVITY * 10), (7.5, lambda g: g < STANDARD_GRAVITY / 10)):
        vt = track_video(path, diameter_m=D, fps=fps)  # as if a slow-motion video were read at a wrong rate
        assert off(vt.g_measured)
        assert abs(vt.scale_m_per_px / (D / vt.diameter_px) - 1) < 1e-9  # the diameter's scale is kept
        warning = [n for n in vt.notes if n.startswith("WARNING")]
        assert warning and "frame rate is suspect" in warning[0] and "about 30 fps" in warning[0]


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


def test_planted_drag_keeps_the_fall_and_the_floor(tmp_path):
    """Air drag skews the flights (faster up than down) and bends the fall: the fall is still a
    fall (it is kept) and the floor stays within a tenth of a pixel."""
    path, truth = render(tmp_path, effects={"air_drag": {"drag_coefficient": 1.0}}, noise_sd=2.0)
    vt = track_video(path, diameter_m=D)
    assert not any(n.startswith("the fall from the hand is left out") for n in vt.notes)
    assert vt.trajectory.release_index > 0
    assert abs(vt.contact_row_px - contact_row(truth)) < 0.1


def test_a_fall_is_told_from_a_fall_seen_nearer_the_camera():
    """The fall test (no video): a fall with air drag fits the best fall with the bounces' g; the same
    fall of a ball released 10 % nearer the camera that recedes to its bounces' distance within about
    0.1 s (its image's offset from the principal point, row 540, shrinks so) misses it by pixels."""
    from vrcal.measurements.video import _fall_misfit_px

    d = simulate_drops(0.8, 0.7, 1, BALL, effects={"air_drag": {"drag_coefficient": 1.0}})
    t = np.arange(1, 15) / 30.0
    t = t[t < d.impact_times_s[0][0]]
    scale = 0.0009  # m/px
    row = 985.0 - d.height_m(t)[0] / scale  # image rows grow downwards
    curvature = 0.5 * 9.80665 / scale
    assert _fall_misfit_px(t, row, np.arange(t.size), curvature) < 0.05
    nearer = 540.0 + (row - 540.0) * (1.0 + 0.1 * np.exp(-t / 0.1))
    assert _fall_misfit_px(t, nearer, np.arange(t.size), curvature) > 2.0


def test_color_and_roi_help_and_are_checked(hard):
    path, truth = hard
    vt = track_video(path, diameter_m=D, color="#28a028", roi="100,0,120,320")
    kept = vt.kept & ~truth["straddles_impact"]
    assert kept.sum() > 40
    assert np.max(np.abs(vt.row_px[kept] - truth["row_px"][kept])) < 0.5  # the region starts at y = 0
    assert np.max(np.abs(vt.col_px[kept] + 100 - truth["col_px"][kept])) < 0.5
    assert parse_color("green") == (50, 150, 50) and parse_color("#ff0000") == (0, 0, 255)
    with pytest.raises(UsageError, match="--color"):
        parse_color("greenish")
    with pytest.raises(UsageError, match="--roi"):
        parse_roi("1,2,3")


def test_bad_videos_fail_in_one_line(tmp_path, plain):
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
    with pytest.raises(UsageError, match="diameter"):
        read_measurement(plain[0])


@pytest.fixture(scope="module")
def ameen():
    """bounceAmeen.avi (arzafiruddin/BouncingBall): a 26 g, 68.7 mm ball on wood at 29.97 fps, held
    nearer the camera than it bounces, ending with a hand picking the ball up. Hand tracking gives
    per-bounce epsilon 0.68-0.72 (../shared README)."""
    require_extra("cv2", "video")
    return track_video(shared_file("realval/ameen/bounceAmeen.avi"), diameter_m=0.0687)


def test_real_video_of_a_green_ball(ameen):
    """The scale from g, the fall left out, per-bounce epsilon 0.68-0.73, and discover's epsilon 0.70
    with no effect named (docs/track.md shows the same through 'vrcal discover')."""
    from vrcal.discovery.ranking import discover

    vt = ameen
    # the flights between bounces tell g to under 1 %; the apparent diameter (about 92 px at the
    # apexes) would give g = 8.9 m/s^2 with the container's 29.97 fps: the scale is the flights'
    assert vt.bounces.curvature_sd_px_per_s2 / vt.bounces.curvature_px_per_s2 < 0.01
    assert 90 < vt.diameter_px < 94 and 8.7 < vt.g_measured < 9.2
    assert abs(vt.scale_m_per_px * vt.bounces.g_px_per_s2 - STANDARD_GRAVITY) < 1e-9
    assert any(n.startswith("not used: the ball's apparent diameter") for n in vt.notes)
    # the fall from the hand is no free fall (the ball was held nearer the camera): the track starts
    # at the first apex and ends before the hand picks the ball up
    assert any(n.startswith("the fall from the hand is left out") and "nearer the camera" in n for n in vt.notes)
    t = vt.t_s[vt.kept]
    assert 25 <= t.size <= 40 and 2.7 < t[0] < 2.9 and t[-1] < 4.0
    durations = np.array([t1 - t0 for _, t0, t1 in vt.bounces.flights])
    ratios = durations[1:] / durations[:-1]
    assert ratios.size >= 2 and np.all((ratios > 0.68) & (ratios < 0.73))
    result = discover(vt.trajectory, BallProperties(0.026, 0.0687, "green"))
    assert abs(result.epsilon - 0.70) < 0.015
    assert not result.effects


@pytest.mark.parametrize("name", ["drop.mp4", "drop.mov"])
def test_an_mp4_or_mov_is_written_with_a_codec_it_takes(tmp_path, capfd, name):
    """Motion JPEG in MP4 or QuickTime made OpenCV print two FFMPEG warnings and fall back; the codec
    follows the extension, and the video tracks."""
    path, truth = render(tmp_path, name=name, n=2, H=0.4)
    assert "not supported" not in capfd.readouterr().err
    avi, _ = render(tmp_path, name="drop.avi", n=2, H=0.4)
    assert track_video(path, diameter_m=D).kept.sum() == track_video(avi, diameter_m=D).kept.sum() > 0
