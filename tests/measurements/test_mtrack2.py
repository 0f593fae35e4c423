"""The ImageJ MTrack2 reader (vrcal.measurements.mtrack2): exports written here in MTrack2's layout from a
simulated drop (pixels, image y down), as the plugin writes them to a file (tabs) and as its Results window
saves them as CSV (commas), with a second, still track, MTrack2's flags, a 'Tracks 1 to N' line, a second
block of tracks and the summary."""

import json

import numpy as np
import pytest
from click.testing import CliRunner

from vrcal.cli import main
from vrcal.drop.simulate import sample_measurement, simulate_drops
from vrcal.errors import DataError, UsageError
from vrcal.measurements import detect_format, read_measurement
from vrcal.model.body import BallProperties

SCALE = 0.0002      # m per pixel
FS = 200.0          # frames per second
FLOOR_ROW = 950.0   # image row of the floor (y down)


def marble_rows(contact_time_s=0.008):
    """Frame numbers (from 1) and image rows [px] of a marble dropped 19 cm on a soft floor, 200 fps."""
    ball = BallProperties(0.0054, 0.016, "marble")
    drops = simulate_drops(0.19, 0.66, 5, ball, release_time_s=0.1,
                           effects={"contact_duration": {"contact_time_s": contact_time_s}})
    cols = sample_measurement(drops, "trajectory", fs_hz=FS, noise_m=1e-5, rng=1)
    frames = np.arange(1, cols["t"].size + 1)
    return frames, FLOOR_ROW - cols["y"] / SCALE, cols["y"]


def mtrack2_text(frames, rows, sep="\t", still=(3, 40), per_block=2, summary=True, flags=(5, 6)):
    """An MTrack2 export: the ball as track 1, a still mark as track 2 from frame ``still[0]`` on (at row
    ``still[1]``), ``per_block`` tracks to a block (1: a second block, 'Tracks 2 to 2', for the mark)."""
    blank = [" "] * 3
    tracks = {1: {int(f): (f"{100.0 + 0.01 * f:.5f}", f"{r:.6f}", "*" if f in flags else " ")
                  for f, r in zip(frames, rows)},
              2: {int(f): ("33.2", f"{still[1] + 0.3 * np.sin(f):.5f}", " ") for f in frames if f >= still[0]}}
    header = ["Frame"] + [f"{a}{k}" for k in range(1, per_block + 1) for a in ("X", "Y", "Flag")]
    lines = [sep.join(header)]
    for first in range(1, 3, per_block):
        numbers = list(range(first, min(first + per_block, 3)))
        lines.append(f"Tracks {first} to {numbers[-1]}".replace(" ", sep if sep == "," else " "))
        for f in frames:
            cells = [str(int(f))]
            for n in numbers:
                cells += list(tracks[n].get(int(f), blank))
            cells += blank * (per_block - len(numbers))
            lines.append(sep.join(cells))
    if summary:
        lines += ["", sep.join(["Track ", "Length", "Distance traveled", "Nr of Frames"])]
        lines += [sep.join(["1", "1002.3", "575.4", str(len(frames))]), sep.join(["2", "60.5", "6.6", "50"])]
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("sep", ["\t", ","])
def test_an_mtrack2_export_is_read_as_the_balls_trajectory(tmp_path, sep):
    frames, rows, heights = marble_rows()
    path = tmp_path / "Results.csv"
    path.write_text(mtrack2_text(frames, rows, sep))
    assert detect_format(path) == "mtrack2"
    data = read_measurement(path, fs_hz=FS, scale_m_per_px=SCALE)
    assert data.kind == "trajectory"
    np.testing.assert_allclose(data.t_s, frames / FS)
    # image y down: height = -row * scale, relative to the picture's top
    np.testing.assert_allclose(data.y_m, heights - FLOOR_ROW * SCALE, atol=1e-9)
    said = " ".join(data.notes)
    assert "ImageJ MTrack2 export, track 1 of 2" in said and "moves most" in said and "--sheet N" in said
    assert "2 frame(s) of track 1 flagged '*'" in said and "summary of the tracks" in said
    assert "y axis points down" in said and "/ 200 Hz" in said


def test_an_export_whose_tabs_became_single_blanks_is_read(tmp_path):
    """An editor turned each tab into one blank (a real export of the XS06 marble project): empty cells are
    blanks in a row. 'Tracks 1 to 2' is not a number (column 'Frame X1 Y1 Flag1 X2 Y2 Flag2') before."""
    frames, rows, heights = marble_rows()
    lines = ["Frame X1 Y1 Flag1 X2 Y2 Flag2", "Tracks 1 to 2     "]
    for f, r in zip(frames, rows):
        flag = "*" if f in (5, 6) else ""
        mark = f"33.2 {40.0 + 0.3 * np.sin(f):.5f} " if f >= 3 else "   "
        lines.append(f"{f} {100.0 + 0.01 * f:.5f} {r:.6f} {flag} {mark}")
    lines += [f"{frames[-1] + 1}    33.2 40.1 ", "", "Track Length Distance traveled Nr of Frames",
              "1 1002.3 575.4 90   "]
    path = tmp_path / "Results.csv"
    path.write_text("\r\n".join(lines) + "\r\n")
    assert detect_format(path) == "mtrack2"
    data = read_measurement(path, fs_hz=FS, scale_m_per_px=SCALE)
    np.testing.assert_allclose(data.t_s, frames / FS)
    np.testing.assert_allclose(data.y_m, heights - FLOOR_ROW * SCALE, atol=1e-9)
    said = " ".join(data.notes)
    assert "track 1 of 2" in said and "2 frame(s) of track 1 flagged '*'" in said
    mark = read_measurement(path, fs_hz=FS, scale_m_per_px=SCALE, sheet="2")
    assert mark.t_s.size == frames.size - 1   # frames 3.. and the one after the ball's last


def test_the_track_is_the_one_that_moves_or_the_one_asked_for(tmp_path):
    """The ball is read whichever number MTrack2 gave it (here 2, the mark 1); --sheet N reads track N."""
    frames, rows, _ = marble_rows()
    lines = mtrack2_text(frames, rows).splitlines()
    body = [ln.split("\t") for ln in lines[2:2 + frames.size]]
    for cells in body:     # the ball's columns last: MTrack2 numbered the mark first
        cells[1:7] = cells[4:7] + cells[1:4]
    path = tmp_path / "swapped.txt"
    path.write_text("\n".join(lines[:2] + ["\t".join(c) for c in body] + lines[2 + frames.size:]) + "\n")
    data = read_measurement(path, fs_hz=FS, scale_m_per_px=SCALE)
    assert "track 2 of 2" in data.notes[0] and np.ptp(data.y_m) > 0.15
    mark = read_measurement(path, fs_hz=FS, scale_m_per_px=SCALE, sheet="1")
    assert "track 1 of 2 (as asked" in mark.notes[0] and np.ptp(mark.y_m) < 1e-3
    with pytest.raises(UsageError, match=r"no track 3 in this MTrack2 export \(tracks: 1, 2\)"):
        read_measurement(path, fs_hz=FS, scale_m_per_px=SCALE, sheet="3")


def test_tracks_in_a_second_block_are_read(tmp_path):
    """More tracks than the header's columns: MTrack2 writes a second block ('Tracks 2 to 2') of the same
    frames in the same columns."""
    frames, rows, _ = marble_rows()
    path = tmp_path / "blocks.txt"
    path.write_text(mtrack2_text(frames, rows, per_block=1))
    ball = read_measurement(path, fs_hz=FS, scale_m_per_px=SCALE)
    mark = read_measurement(path, fs_hz=FS, scale_m_per_px=SCALE, sheet="2")
    assert ball.t_s.size == frames.size and mark.t_s.size == frames.size - 2
    assert "track 1 of 2" in ball.notes[0]


def test_an_mtrack2_export_needs_the_frame_rate_and_the_scale(tmp_path):
    frames, rows, _ = marble_rows()
    path = tmp_path / "Results.txt"
    path.write_text(mtrack2_text(frames, rows))
    with pytest.raises(UsageError, match="counts frames, not seconds: give the frame rate with --fs HZ"):
        read_measurement(path, scale_m_per_px=SCALE)
    with pytest.raises(UsageError, match="in pixels: give --scale"):
        read_measurement(path, fs_hz=FS)
    with pytest.raises(DataError, match="reads as mtrack2: --format mtrack2"):
        read_measurement(path, "tracker", fs_hz=FS, scale_m_per_px=SCALE)
    other = tmp_path / "ty.csv"
    other.write_text("t,y\n0,1\n0.1,0.9\n0.2,0.8\n")
    with pytest.raises(UsageError, match="--sheet applies to .* MTrack2 exports"):
        read_measurement(other, sheet="2")


def test_a_marble_on_paper_tracked_by_mtrack2_end_to_end(tmp_path):
    """``vrcal discover`` on an MTrack2 export of a marble with 8 ms contacts on a soft floor: the track is
    read with --fs and --scale, and with --surface soft the contact is named and epsilon is the planted one."""
    frames, rows, _ = marble_rows()
    path = tmp_path / "Results.csv"
    path.write_text(mtrack2_text(frames, rows, ","))
    out = CliRunner().invoke(main, ["discover", str(path), "--mass", "0.0054", "--diameter", "0.016", "--fs", "200",
                                    "--scale", str(SCALE), "--surface", "soft", "-q", "--json", "-"])
    assert out.exit_code == 0, out.output
    result = json.loads(out.output)
    assert result["effects"] == ["contact_duration"]
    assert result["epsilon"] == pytest.approx(0.66, abs=0.005)
    assert result["reader"]["format"] is None and "MTrack2" in result["notes"][0]


def test_a_trackers_glitches_are_left_out_with_their_lines(tmp_path):
    """MTrack2 jumps to another object for a frame or three (a real XS06 track at 30 mbar: 8-10 px while the
    marble is held, one just after the release): a jump down after the release was taken for a first bounce
    19 cm above the floor, and the fall was cut from the fit. The jumps are left out, with their lines, and
    the record reads as the clean one."""
    frames, rows, _ = marble_rows()
    glitched = rows.copy()
    glitched[7] += 10.0               # frame 8, held: down in the picture
    glitched[11:14] += 9.0            # frames 12-14
    glitched[23] += 8.0               # frame 24, just after the release at 0.1 s
    results = []
    for name, r in (("clean.csv", rows), ("glitched.csv", glitched)):
        path = tmp_path / name
        path.write_text(mtrack2_text(frames, r, ","))
        out = CliRunner().invoke(main, ["discover", str(path), "--mass", "0.0054", "--diameter", "0.016", "--fs",
                                        "200", "--scale", str(SCALE), "--surface", "soft", "-q", "--json", "-"])
        assert out.exit_code == 0, out.output
        results.append(json.loads(out.output))
    clean, got = results
    said = [n for n in got["notes"] if n.startswith("left out 5 sample(s) that jump off the smooth path")]
    assert said and said[0].endswith("line 10, lines 14-16, line 26"), got["notes"]
    assert got["effects"] == clean["effects"] == ["contact_duration"]
    assert got["verdict"] == clean["verdict"] == "explained"     # 'unexplained' before
    assert got["epsilon"] == pytest.approx(clean["epsilon"], abs=0.002)


def test_an_infinite_frame_number_is_a_one_line_error(tmp_path):
    """'inf' as a frame number crashed with OverflowError (found by the fuzz test of every reader)."""
    p = tmp_path / "f.csv"
    p.write_text("Frame\tX1\tY1\tFlag1\ninf\t1\t2\t\n")
    with pytest.raises(DataError, match=r"f.csv:2: expected a frame number .* found 'inf\\t1\\t2'"):
        read_measurement(str(p), "mtrack2")


def test_a_line_without_cells_is_a_one_line_error(tmp_path):
    """A line of one quote has no cell at all: IndexError before (found by the fuzz test)."""
    p = tmp_path / "f.csv"
    p.write_text('Frame,X1,Y1,Flag1\n1,2,3,\n"\n')
    with pytest.raises(DataError, match=r"f.csv:3: expected a frame number and 1 track\(s\) of X, Y, Flag"):
        read_measurement(str(p), "mtrack2")


def test_mtrack2_asked_for_another_file_names_the_header_it_expects(tmp_path):
    """--format mtrack2 on a t, y file read its first line as a header of 0 tracks and crashed on a later
    line (found by the fuzz test)."""
    p = tmp_path / "f.csv"
    p.write_text("0.0,0.0\n0.1,0.2\n")
    with pytest.raises(DataError, match=r"f.csv:1: expected MTrack2's header 'Frame, X1, Y1, Flag1, \.\.\.', "
                                        r"found '0.0,0.0'"):
        read_measurement(str(p), "mtrack2")
