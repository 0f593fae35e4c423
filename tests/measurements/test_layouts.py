"""The layouts people have (issue 9, part 2): one-column and headerless files, units in the header,
tables of drop and rebound heights, runs side by side, spreadsheets (phyphox's .xlsx and .xls),
several files at once -- and no reader crashes on arbitrary text (hypothesis)."""

import builtins
import warnings

import numpy as np
import pytest
from click.testing import CliRunner
from helpers import EXAMPLES, shared_file
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from vrcal.cli import main
from vrcal.errors import DataError, UsageError, VrcalError
from vrcal.measurements import (
    FORMATS,
    ApexHeights,
    ImpactTimes,
    Runs,
    Trajectory,
    detect_format,
    read_measurement,
    read_measurements,
)
from vrcal.measurements.table import columns as tb_columns
from vrcal.model.restitution import STANDARD_GRAVITY_M_PER_S2 as G


def impact_times(H=1.0, eps=0.85, n=10):
    v0 = np.sqrt(2 * G * H)
    return np.sqrt(2 * H / G) + np.concatenate([[0.0], np.cumsum(2.0 * eps ** np.arange(1, n) * v0 / G)])


def fall(n=60, fs=100.0, H=1.2):
    t = np.arange(n) / fs
    return t, np.maximum(H - 0.5 * G * t * t, 0.0) + 0.2 * (t > 0.5)


def write(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text)
    return p


# --------------------------------------------------------------------------- one column, no header


@pytest.mark.parametrize("header", ["t_impact", "time", "t", "Impacts", "t (s)", "T_IMPACT [s]", None])
def test_one_numeric_column_is_impact_times_whatever_its_name(tmp_path, header):
    t = impact_times()
    lines = ([header] if header else []) + [repr(float(v)) for v in t]
    p = write(tmp_path, "one.csv", "\n".join(lines) + "\n")
    assert detect_format(p) == "impacts"
    data = read_measurement(p)
    assert isinstance(data, ImpactTimes)
    np.testing.assert_allclose(data.t_s, t)


def test_one_column_in_ms_and_one_with_a_decimal_comma_without_header(tmp_path):
    t = impact_times()
    ms = write(tmp_path, "ms.csv", "t_impact (ms)\n" + "\n".join(f"{v * 1e3:.4f}" for v in t) + "\n")
    np.testing.assert_allclose(read_measurement(ms).t_s, t, atol=1e-7)
    comma = write(tmp_path, "comma.csv", "\n".join(f"{v:.6f}".replace(".", ",") for v in t) + "\n")
    np.testing.assert_allclose(read_measurement(comma).t_s, t, atol=1e-6)


@pytest.mark.parametrize("sep", [",", ";", "\t", "   "])
def test_headerless_two_columns_are_t_and_y(tmp_path, sep):
    t, y = fall()
    p = write(tmp_path, "ty.txt", "\n".join(f"{float(a)!r}{sep}{float(b)!r}" for a, b in zip(t, y)) + "\n")
    assert detect_format(p) == "trajectory"
    data = read_measurement(p)
    assert isinstance(data, Trajectory)
    np.testing.assert_allclose(data.y_m, y)
    assert any("no header" in n for n in data.notes)
    assert list(data.lines[:3]) == [1, 2, 3]


def test_headerless_three_columns_ask_for_a_header(tmp_path):
    t, y = fall()
    p = write(tmp_path, "three.txt", "\n".join(f"{a},{b},7" for a, b in zip(t, y)) + "\n")
    with pytest.raises(DataError, match=r"three\.txt:1: no header row"):
        read_measurement(p)


def test_infinite_first_cells_are_no_headerless_times(tmp_path):
    """Two rows 'inf, -1e6' asked for as impacts: looking for a t, y reading took np.diff of inf - inf
    (RuntimeWarning 'invalid value in subtract', found by the fuzz test); the error names the header."""
    p = write(tmp_path, "inf.csv", "inf\t-1000000\ninf\t-1000000\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(DataError, match=r"inf\.csv:1: no header row"):
            read_measurement(p, "impacts")


@pytest.mark.parametrize("unit,factor", [("m", 1.0), ("cm", 1e-2), ("mm", 1e-3)])
def test_units_in_the_header_are_converted(tmp_path, unit, factor):
    t, y = fall()
    body = "\n".join(f"{float(a) * 1e3!r},{float(b) / factor!r}" for a, b in zip(t, y))
    p = write(tmp_path, "u.csv", f"t (ms),y ({unit})\n" + body)
    data = read_measurement(p)
    np.testing.assert_allclose(data.t_s, t, atol=1e-12)
    np.testing.assert_allclose(data.y_m, y, atol=1e-12)


@pytest.mark.parametrize("t_head,y_head,t_factor,y_factor", [
    ("t_s", "y_m", 1.0, 1.0), ("time_ms", "height_cm", 1e-3, 1e-2), ("t/s", "h / mm", 1.0, 1e-3),
    ("Time in s", "Height in cm", 1.0, 1e-2), ("t", "position", 1.0, 1.0),
    ('"Latest: Time (s)"', '"Latest: Position (m)"', 1.0, 1.0), ("Run 1: Time (ms)", "Run 1: y (mm)", 1e-3, 1e-3),
])
def test_units_after_the_name_and_other_height_names(tmp_path, t_head, y_head, t_factor, y_factor):
    """``t_s``, ``t/s`` (ISO 80000), ``height in cm``, a motion sensor's ``position`` and a Vernier data
    set's prefix (``Latest: Time (s)``) are a trajectory like ``t (s),y (m)``, not impact times."""
    t, y = fall()
    body = "\n".join(f"{float(a) / t_factor!r},{float(b) / y_factor!r}" for a, b in zip(t, y))
    p = write(tmp_path, "u.csv", f"{t_head},{y_head}\n" + body + "\n")
    assert detect_format(p) == "trajectory"
    data = read_measurement(p)
    np.testing.assert_allclose(data.t_s, t, atol=1e-12)
    np.testing.assert_allclose(data.y_m, y, atol=1e-12)


def test_a_name_ending_in_no_unit_keeps_its_name(tmp_path):
    from vrcal.measurements.table import columns

    assert [(c.name, c.unit) for c in columns(["t_impact", "bounce_no", "y_in", "H_cm", "t/ms"])] == [
        ("t impact", ""), ("bounce no", ""), ("y in", ""), ("h", "cm"), ("t", "ms")]


def test_a_frame_column_gives_the_times_with_fs_and_keeps_the_gaps(tmp_path):
    """Frames a tracker missed leave gaps: times are frame / fs, not the row number / fs."""
    t, y = fall(n=80, fs=60.0)
    keep = np.arange(t.size) % 7 != 3
    frames = np.flatnonzero(keep)
    px = np.round((1.5 - y[keep]) / 0.002, 1)
    p = write(tmp_path, "px.csv", "frame,x_px,y_px\n" + "\n".join(f"{f},320,{v}" for f, v in zip(frames, px)) + "\n")
    assert detect_format(p) == "trajectory"
    with pytest.raises(UsageError, match="--fs.*column 'frame'"):
        read_measurement(p, scale_m_per_px=0.002, y_down=True)
    data = read_measurement(p, scale_m_per_px=0.002, y_down=True, fs_hz=60.0)
    np.testing.assert_allclose(data.t_s, frames / 60.0)
    np.testing.assert_allclose(data.y_m, -px * 0.002)


def test_times_printed_too_coarsely_for_the_frame_rate_are_put_back_on_their_grid(tmp_path):
    """A tracker writing 0.017, 0.033, 0.050 at 60 frames/s moves samples by up to 0.33 ms (1.6 mm at 5
    m/s); the reader restores the grid (frames missed kept as gaps) and says so."""
    fs, t0 = 60.0, 0.0123
    k = np.flatnonzero(np.arange(200) % 11 != 5)
    t_true = t0 + k / fs
    y = np.linspace(1.0, 0.5, k.size)
    p = write(tmp_path, "r.csv", "t,y\n" + "\n".join(f"{a:.3f},{float(b)!r}" for a, b in zip(t_true, y)) + "\n")
    data = read_measurement(p)
    assert np.max(np.abs(data.t_s - t_true)) < 1e-4 < 3e-4 < np.max(np.abs(np.round(t_true, 3) - t_true))
    assert any("times printed to 0.001 s" in n for n in data.notes)


@pytest.mark.parametrize("fps", [24.0, 25.0, 30000 / 1001, 30.0, 60.0, 120.0, 240.0])
@pytest.mark.parametrize("decimals", [3, 4, 6])
def test_impact_times_read_off_video_frames_carry_the_grid_as_their_timing_noise(tmp_path, fps, decimals):
    t = np.round(np.round(impact_times(H=1.0, eps=0.8, n=8) * fps) / fps, decimals)
    data = read_measurement(write(tmp_path, "v.csv", "t\n" + "\n".join(f"{v:.{decimals}f}" for v in t) + "\n"))
    if decimals == 3 and fps >= 120:   # 1 ms printing is the coarser grid... or the frames cannot be told
        assert data.timing_sd_s == pytest.approx(1e-3 / np.sqrt(12)) or data.timing_sd_s > 1e-3 / np.sqrt(12)
        return
    assert data.timing_sd_s == pytest.approx(1.0 / fps / np.sqrt(12), rel=0.01)
    assert any(f"{1e3 / fps:.4g} ms grid" in n and "fps video" in n for n in data.notes), data.notes


def test_a_fast_video_printed_to_ms_is_told_by_many_times_not_by_chance():
    """240 fps printed to 1 ms: a time lands within the rounding of a frame by chance in 29 %, so 8 times
    cannot tell the frames; 14 can (chance 14 x 0.29^13 < 1e-6), and times at random printed to 1 ms
    are not taken for frames."""
    from vrcal.measurements.cleanup import time_grid

    t = np.round(np.round(impact_times(H=2.0, eps=0.85, n=14) * 240) / 240, 3)
    assert time_grid(t).period_s == pytest.approx(1 / 240) and "240 fps" in time_grid(t).what
    rng = np.random.default_rng(3)
    found = [time_grid(np.round(np.cumsum(rng.uniform(0.1, 0.6, 14)), 3)) for _ in range(2000)]
    assert sum("fps" in g.what for g in found if g is not None) <= 2


def test_finely_timed_impacts_have_no_grid():
    from vrcal.measurements.cleanup import time_grid

    rng = np.random.default_rng(7)
    found = [time_grid(np.round(np.cumsum(rng.uniform(0.1, 0.6, 8)), 6)) for _ in range(2000)]
    assert sum(g is not None for g in found) <= 2
    assert read_measurement(shared_file("realval/giiulia/golf_100cm_r1.csv")).timing_sd_s == 0.0


@settings(max_examples=60, deadline=None)
@given(fs=st.floats(20.0, 250.0), t0=st.floats(0.0, 5.0), n=st.integers(20, 400), decimals=st.integers(2, 3),
       gap=st.integers(3, 40))
@example(fs=24.0, t0=4.0, n=289, decimals=2, gap=3)   # printed intervals 0.04/0.05 s: the first step guess is low
@example(fs=142.0, t0=1.9375, n=20, decimals=3, gap=4)  # the least-squares line missed the grid by 0.81 ms at an end
@example(fs=66.6875, t0=0.4375, n=21, decimals=3, gap=3)  # a period 0.014995 s ~ 15 print steps: errors all ~+0.45
def test_regular_grid_recovery_is_never_worse_than_the_rounding(fs, t0, n, decimals, gap):
    """The recovered grid is never further from the true times than the printed ones (rms), or, when the
    frame period is so near a whole number of print steps that every time is rounded alike (the errors'
    phases on the digit's circle agree, resultant > 0.9), within half a digit: the grid's offset inside one
    digit is then not in the data (fs 66.6875 printed to 1 ms: errors near the tie, +-0.37..0.50 of a
    digit, resultant 0.97; found 0.486 ms rms for the printed 0.437)."""
    from vrcal.measurements.cleanup import regular_frame_times

    k = np.flatnonzero(np.arange(n + n // gap) % gap != 1)[:n]
    t_true = t0 + k / fs
    printed = np.round(t_true, decimals)
    if np.any(np.diff(printed) <= 0):
        return   # printed too coarsely to keep the order: not a record anyone can have
    found = regular_frame_times(printed)
    if found is None:   # only when the rounding is fine (or too coarse) for this frame rate, the times are a regular
        res = 10.0 ** -decimals   # grid already (nothing to restore), or they sit on ties of the rounding
        line = np.polyval(np.polyfit(k, printed, 1), k)
        ties = np.max(np.abs(np.abs(printed - t_true) - 0.5 * res)) < 1e-9
        assert not 0.02 / fs <= res <= 0.25 / fs or np.max(np.abs(line - printed)) < 1e-9 or ties
        return
    res = 10.0 ** -decimals
    assert np.max(np.abs(found.t_s - printed)) <= 0.8 * res
    rms_found, rms_printed = np.sqrt(np.mean((found.t_s - t_true) ** 2)), np.sqrt(np.mean((printed - t_true) ** 2))
    # how alike the times are rounded: 1 when every rounding error is the same point of the digit (on a circle:
    # -0.5 and +0.5 of a digit are one tie), about 0 when they spread over it
    alike = np.abs(np.mean(np.exp(2j * np.pi * (printed - t_true) / res)))
    assert rms_found <= rms_printed + 1e-12 or (alike > 0.9 and rms_found <= 0.5 * res)


def test_irregular_or_finely_printed_times_are_left_alone():
    from vrcal.measurements.cleanup import regular_frame_times

    rng = np.random.default_rng(3)
    t = np.arange(100) / 30.0
    assert regular_frame_times(t) is None                                        # full precision
    assert regular_frame_times(np.round(t + rng.normal(0, 0.004, t.size), 3)) is None   # a variable frame rate
    assert regular_frame_times(np.arange(100) * 0.01) is None                  # exact on its grid already
    # irregular times printed exactly, with gaps of thousands of "frames" (found by the round-trip property
    # test): a grid would move them by up to 0.8 of the last digit
    t = np.concatenate([[1.0, 1.96875, 2.03125, 2.09375, 2.15625], 2.15625 + 1e-4 * np.arange(1, 14),
                        [2.28255, 2.34505]])
    assert regular_frame_times(t) is None


# --------------------------------------------------------------------------- drop tables


def _labels(times, *, region_s=0.0, text=lambda k: "", spectral=False, comma=False):
    out = []
    for k, t in enumerate(times):
        cells = [f"{t:.6f}", f"{t + region_s:.6f}", text(k)]
        out.append("\t".join(c.replace(".", ",") if comma and i < 2 else c for i, c in enumerate(cells)))
        if spectral:
            out.append("\\\t120.000000\t4000.000000")
    return "\n".join(out) + "\n"


@pytest.mark.parametrize("kw", [{}, {"region_s": 0.012, "text": lambda k: f"bounce {k + 1}"},
                                {"spectral": True, "text": lambda k: "S"}, {"comma": True}])
def test_an_audacity_label_export_gives_the_label_starts_as_impact_times(tmp_path, kw):
    t = impact_times(H=0.8, eps=0.8, n=8)
    p = write(tmp_path, "labels.txt", _labels(t, **kw))
    assert detect_format(p) == "audacity-labels"
    d = read_measurement(p)
    assert isinstance(d, ImpactTimes)
    np.testing.assert_allclose(d.t_s, t, atol=1e-6)
    assert "Audacity label export" in d.notes[0]


def test_an_echo_in_a_label_file_is_named_by_its_label_and_line(tmp_path):
    t = impact_times(H=0.8, eps=0.8, n=8)
    events = np.sort(np.append(t, t[3] + 0.004))   # an echo 4 ms after the 4th impact
    p = write(tmp_path, "labels.txt", _labels(events, text=lambda k: f"b{k + 1}"))
    d = read_measurement(p)
    np.testing.assert_allclose(d.t_s, t, atol=1e-6)
    assert any("label 5 'b5' (line 5)" in n for n in d.notes)


@pytest.mark.parametrize("bad,said", [("1.71\tx\tb2", "the end 'x' is not a time in s"),
                                      ("1.71\t1.70\tb2", "the end 1.7 s is before the start 1.71 s"),
                                      ("1.71 1.71 b2", "1 tab-separated cells, not 2 or 3")])
@pytest.mark.parametrize("n", [2, 5])
def test_a_bad_line_of_a_label_file_is_named_with_its_cell(tmp_path, bad, said, n):
    """A label file with a bad line 2 said "cannot tell the layout from the header '0.95\\t0.95\\tb1'"."""
    lines = ["0.95\t0.95\tb1", bad] + [f"{2 + k * 0.3:.2f}\t{2 + k * 0.3:.2f}\tb{k + 3}" for k in range(n - 2)]
    p = write(tmp_path, "labels_bad.txt", "\n".join(lines) + "\n")
    with pytest.raises(DataError, match=rf"labels_bad.txt:2: not an Audacity label line .*: {said}"):
        read_measurement(p)


def test_labels_out_of_order_are_named_not_taken_for_a_title(tmp_path):
    p = write(tmp_path, "l.txt", "0.5\t0.5\tb1\n0.4\t0.4\tb2\n0.9\t0.9\tb3\n1.2\t1.2\tb4\n")
    with pytest.raises(DataError, match=r"l.txt:2: label start not increasing \(0.4 after 0.5\)"):
        read_measurement(p)


def test_a_headerless_trajectory_is_not_a_label_file(tmp_path):
    t, y = fall()
    p = write(tmp_path, "fall.txt", "".join(f"{a:.4f}\t{b:.4f}\n" for a, b in zip(t, y)))
    assert detect_format(p) == "trajectory"


def test_unsorted_labels_are_an_error_naming_the_line(tmp_path):
    p = write(tmp_path, "labels.txt", "0.5\t0.5\t\n1.2\t1.2\t\n0.9\t0.9\t\n")
    with pytest.raises(DataError, match=r"labels.txt:3: label start not increasing"):
        read_measurement(p, "audacity-labels")
    p = write(tmp_path, "bad.txt", "0.5\t0.5\t\n1.2\tx\t\n1.6\t1.6\t\n")
    with pytest.raises(DataError, match=r"bad.txt:2: not an Audacity label line"):
        read_measurement(p, "audacity-labels")


@pytest.mark.parametrize("header", ["Drop height (cm),Rebound height (cm)", "Height dropped (cm),Height bounced (cm)",
                                    "drop_cm,bounce_cm", "Dropped from (cm);Bounced to (cm)",
                                    "Release height [cm],Bounce height [cm]", "Initial height (cm),Return height (cm)",
                                    "Initial Height (cm),Final Height (cm)", "Starting height (cm),Bounce height (cm)"])
def test_drop_tables_as_students_name_their_columns(tmp_path, header):
    H, h = [50.0, 100.0, 150.0], [32.1, 63.5, 94.2]
    sep = ";" if ";" in header else ","
    p = write(tmp_path, "t.csv", header + "\n" + "".join(f"{a}{sep}{b}\n" for a, b in zip(H, h)))
    assert detect_format(p) == "drops"
    data = read_measurement(p)
    assert [tuple(r.h_m) for r in data.runs] == [pytest.approx((a / 100, b / 100)) for a, b in zip(H, h)]


@pytest.mark.parametrize("header", ["Versuch;Fallhöhe (cm);Rückprallhöhe (cm)",
                                    "Versuch;Fallhöhe in cm;Sprunghöhe in cm",
                                    "Versuch;Fallhoehe (cm);Rueckprallhoehe (cm)",
                                    "Versuch;Starthöhe (cm);Endhöhe (cm)",
                                    "Versuch;Fallhöhe in cm;Höhe nach 1. Aufprall in cm",
                                    "Essai;Hauteur de chute (cm);Hauteur du rebond (cm)",
                                    "Intento;Altura de caída (cm);Altura de rebote (cm)",
                                    "Intento;Altura de caida [cm];Altura de rebote [cm]",
                                    "Prova;Altezza di caduta (cm);Altezza di rimbalzo (cm)",
                                    "Ensaio;Altura de queda (cm);Altura do ressalto (cm)"])
def test_drop_tables_in_the_class_language_are_read(tmp_path, header):
    """A German, French, Spanish, Italian or Portuguese class names its columns in its own language, writes
    decimal commas and ';' (accents optional, 'in cm' as well as '(cm)'): 'cannot tell the layout' before."""
    rows = [(30, "17,0"), (30, "16,5"), (100, "55,0"), (200, "107,0")]
    p = write(tmp_path, "de.csv", header + "\n" + "".join(f"{i};{H};{h}\n" for i, (H, h) in enumerate(rows, 1)))
    assert detect_format(p) == "drops"
    data = read_measurement(p)
    assert [tuple(r.h_m) for r in data.runs] == [pytest.approx((0.30, 0.17)), pytest.approx((0.30, 0.165)),
                                                 pytest.approx((1.00, 0.55)), pytest.approx((2.00, 1.07))]


def test_a_table_of_heights_whose_names_are_not_known_says_how_to_name_them(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    p = write(tmp_path, "x.csv", "Versuch;Höhe A (cm);Höhe B (cm)\n1;30;17\n2;60;34\n")
    with pytest.raises(DataError, match=r"x.csv:1: cannot tell the layout from the header .*: for drop and rebound "
                                        r"heights, a drop table needs a drop-height column \('H', 'drop'.*and a "
                                        r"rebound column \('h', 'rebound'.*\(other layouts: see --format\)"):
        read_measurement(p)
    result = CliRunner().invoke(main, ["discover", "x.csv", "--ball", "tennis"])
    assert result.exit_code == 1 and "characters]" not in result.output   # one line, not cut
    with pytest.raises(DataError, match=r"x.csv:1: a drop table needs a drop-height column"):
        read_measurement(p, "drops")
    p = write(tmp_path, "y.csv", "a,b\n1,2\n")   # no heights: no drop-table hint
    with pytest.raises(DataError, match=r"cannot tell the layout from the header 'a,b' \(known formats"):
        read_measurement(p)


@pytest.mark.parametrize("header,factor", [("trial,H (in),h (in)", 0.0254), ("Drop height (inches),Rebound height "
                                           "(inches)", 0.0254), ("drop_inch,rebound_inch", 0.0254),
                                           ("Drop height in inches,Rebound height in inches", 0.0254),
                                           ("H [ft],h [ft]", 0.3048)])
def test_a_drop_table_in_inches_or_feet(tmp_path, header, factor):
    """A US class measures in inches: 'no time column: give the frame rate with --fs HZ' before."""
    rows = [(40, 29), (40, 28), (20, 15)]
    trial = header.startswith("trial")
    text = header + "\n" + "".join((f"{i}," if trial else "") + f"{H},{h}\n" for i, (H, h) in enumerate(rows))
    data = read_measurement(write(tmp_path, "in.csv", text))
    assert isinstance(data, Runs)
    np.testing.assert_allclose([r.h_m for r in data.runs], np.array(rows) * factor)


@pytest.mark.parametrize("header,factor", [("Drop height (meters),Bounce height (meters)", 1.0),
                                           ("Drop height in centimetres,Rebound height in centimetres", 0.01),
                                           ("Fallhöhe [Zentimeter],Rückprallhöhe [Zentimeter]", 0.01),
                                           ("Drop Height (in.),Bounce Height (in.)", 0.0254),
                                           ("Drop height (cm.),Bounce height (cm.)", 0.01)])
def test_units_written_out_or_with_a_full_stop(tmp_path, header, factor):
    """'(meters)', '[Zentimeter]' were 'unknown length unit'; '(in.)' could not tell the layout; 'in
    centimetres' was told to write its unit (an independent probe's tables)."""
    rows = [(1.0, 0.7), (0.5, 0.36)] if factor == 1.0 else [(100, 70), (50, 36)]
    data = read_measurement(write(tmp_path, "u.csv", header + "\n" + "".join(f"{H},{h}\n" for H, h in rows)))
    np.testing.assert_allclose([r.h_m for r in data.runs], np.array(rows) * factor)


def test_inches_and_feet_are_read_wherever_metres_are(tmp_path):
    t, y = fall()
    traj = read_measurement(write(tmp_path, "t.csv", "t (s),y (in)\n" + "".join(f"{a},{b / 0.0254}\n"
                                                                                 for a, b in zip(t, y))))
    np.testing.assert_allclose(traj.y_m, y, atol=1e-12)
    apex = read_measurement(write(tmp_path, "a.csv", "bounce,h (ft)\n0,4\n1,3\n2,2.25\n"))
    np.testing.assert_allclose(apex.h_m, np.array([4, 3, 2.25]) * 0.3048)


@pytest.mark.parametrize("header,said", [("trial,drop_in,rebound_in", "'drop_in', 'rebound_in'"),
                                         ("trial,H_in,h_in", "'H_in', 'h_in'"), ("H_in,h", "'H_in'")])
def test_in_after_a_drop_tables_height_names_is_inches(tmp_path, header, said):
    """``drop_in`` was read as metres (drops of 20-40 m) and ``H_in,h_in`` could not tell the layout; a
    trajectory's ``y_in`` still keeps its name (``test_a_name_ending_in_no_unit_keeps_its_name``)."""
    data = read_measurement(write(tmp_path, "in.csv", header + "\n" + "".join(
        (f"{k},{H},{h}\n" if header.count(",") == 2 else f"{H},{h}\n")
        for k, (H, h) in enumerate([(40, 29), (20, 15)], start=1))))
    assert isinstance(data, Runs)
    np.testing.assert_allclose([r.h_m for r in data.runs], np.array([[40, 29], [20, 15]]) * 0.0254)
    assert any(n.startswith(f"column(s) {said}: the 'in' after the name read as inches") for n in data.notes)


@pytest.mark.parametrize("text", ["trial,H (yd),h (yd)\n1,40,29\n2,40,28\n", "t (s),y (yd)\n0,1\n0.01,0.99\n",
                                  "bounce,h (yd)\n0,1\n1,0.8\n2,0.6\n"])
def test_an_unknown_length_unit_is_named_with_the_known_ones(tmp_path, text):
    with pytest.raises(DataError, match=r"unknown length unit 'yd' of column '.*' \(known: m, cm, mm, in, .*ft"):
        read_measurement(write(tmp_path, "yd.csv", text))


@pytest.mark.parametrize("title,first", [(["Ball bounce lab - group 3"], 3),
                                         (["Ball bounce lab", "Group 3; 12 May"], 4),
                                         (["Golf ball, 1 m, group 3"], 3)])
def test_title_lines_above_the_header_are_skipped_with_a_note(tmp_path, title, first):
    """A class's sheet starts with a title: 'is not a number (column ...)' or '3 cells but the header names 1
    columns' before."""
    text = "\n".join(title) + "\nTrial,Drop height (cm),Rebound height (cm)\n1,100,72.5\n2,100,73\n1,50,37.5\n"
    data = read_measurement(write(tmp_path, "title.csv", text))
    assert isinstance(data, Runs) and len(data.runs) == 3 and data.labels[0] == f"row 1 (line {first})"
    assert data.notes[0].startswith("line 1 " if len(title) == 1 else "lines 1-2 (")
    assert "a title: skipped" in data.notes[0] and repr(title[-1]) in data.notes[0]


def test_a_title_cell_above_a_workbooks_table_is_skipped(tmp_path):
    openpyxl = pytest.importorskip("openpyxl")
    wb = openpyxl.Workbook()
    ws = wb.active
    ws["A1"] = "Ball bounce lab - group 3"
    ws.append([])
    for row in [["Trial", "Drop height (cm)", "Rebound height (cm)"], [1, 30, 17], [2, 30, 16.5], [1, 100, 55]]:
        ws.append(row)
    path = tmp_path / "class.xlsx"
    wb.save(path)
    data = read_measurement(path)
    assert len(data.runs) == 3 and "line 1 'Ball bounce lab - group 3' is a title: skipped" in data.notes
    np.testing.assert_allclose(data.runs[2].h_m, [1.0, 0.55])


@pytest.mark.parametrize("title", ["", "Bouncing ball lab,,\n", "Bouncing ball lab\n"])
@pytest.mark.parametrize("units", [",cm,cm", ",(cm),[cm]", "-,centimetres,cm"])
def test_a_units_row_below_the_header_gives_the_units(tmp_path, title, units):
    """A class's sheet names its units in a row under the header (with or without a title above): "'cm' is
    not a number" or '3 cells but the header names 1 columns' before."""
    text = f"{title}Trial,Drop height,Rebound height\n{units}\n1,30,16.9\n2,30,17\n1,100,56.3\n"
    data = read_measurement(write(tmp_path, "units.csv", text))
    assert isinstance(data, Runs) and len(data.runs) == 3
    np.testing.assert_allclose(data.runs[2].h_m, [1.0, 0.563])
    first = 3 if title else 2
    assert f"line {first} is a row of units" in " ".join(data.notes)
    assert "read into the header ('Drop height (" in " ".join(data.notes)
    assert data.labels[0] == f"row 1 (line {first + 1})"


def test_a_units_row_repeating_or_contradicting_the_header(tmp_path):
    same = read_measurement(write(tmp_path, "same.csv", "t (s),y (m)\ns,m\n" + "".join(
        f"{t:.3f},{y:.5f}\n" for t, y in zip(*fall()))))
    assert isinstance(same, Trajectory) and "line 2 is a row of units (s, m) that repeats the header's: skipped" \
        in same.notes
    ms = read_measurement(write(tmp_path, "ms.csv", "t,y\nms,cm\n" + "".join(
        f"{t * 1e3:.1f},{y * 100:.3f}\n" for t, y in zip(*fall()))))
    np.testing.assert_allclose(ms.t_s[-1], fall()[0][-1]) and np.testing.assert_allclose(ms.y_m[0], 1.2)
    with pytest.raises(DataError, match=r"units.csv:2: column 'Drop height' is in cm by its header \(line 1\) "
                                        r"and in mm by the units row below it"):
        read_measurement(write(tmp_path, "units.csv", "Drop height (cm),Rebound height\nmm,mm\n30,16.9\n"))


def test_a_second_header_row_of_names_is_no_units_row(tmp_path):
    """Only a row of units is read into the header: a row of other words stays an error naming it."""
    with pytest.raises(DataError, match="'x' is not a number"):
        read_measurement(write(tmp_path, "two.csv", "Drop height,Rebound height\nx,y\n30,16.9\n"))


@pytest.mark.parametrize("sep", [",", ";", "\t"])
def test_rows_of_empty_cells_between_the_data_are_skipped_with_a_note(tmp_path, sep):
    """Excel and LibreOffice save an empty row of a sheet as ',,': 'empty cell in column ...' before."""
    rows = ["Trial,Drop height (cm),Rebound height (cm)", "1,30,16.9", ",,", "1,50,27.9", ",,", ",,", "1,100,56.3",
            ",,", ",,"]
    data = read_measurement(write(tmp_path, "blank.csv", "\n".join(r.replace(",", sep) for r in rows) + "\n"))
    assert len(data.runs) == 3 and data.notes[0] == "lines 3, 5, 6: 3 rows of empty cells, skipped"


def test_empty_rows_inside_a_workbooks_table_are_said(tmp_path):
    openpyxl = pytest.importorskip("openpyxl")
    wb = openpyxl.Workbook()
    ws = wb.active
    for row in [["Drop height"], ["cm"], [30], [], [50], [], []]:
        ws.append(row)
    ws["B1"], ws["B2"], ws["B3"], ws["B5"] = "Rebound height", "cm", 16.9, 27.9
    path = tmp_path / "class.xlsx"
    wb.save(path)
    data = read_measurement(path)
    assert len(data.runs) == 2 and "line 4: a row of empty cells, skipped" in data.notes
    assert any(n.startswith("line 2 is a row of units (cm, cm)") for n in data.notes)


@pytest.mark.parametrize("title,header", [("Tennis ball drop 100 cm", '"Event time (s)"'),
                                          ("Ball lab, group 3", "t"), ("Golf ball\nGroup 3", "Time (ms)")])
def test_a_title_above_a_one_column_impact_file_is_skipped(tmp_path, title, header):
    """A one-column file cannot have a title with fewer cells than its header: a line with no number above one
    naming a time column over numbers is the title ("'Event time (s)' is not a number (column 'tennis ball
    drop 100 cm')" before)."""
    t = impact_times(H=1.0, eps=0.8, n=6)
    scale = 1e3 if "ms" in header else 1.0
    p = write(tmp_path, "b_title.csv", f"{title}\n{header}\n" + "".join(f"{v * scale:.6f}\n" for v in t))
    assert detect_format(p) == "impacts"
    data = read_measurement(p)
    np.testing.assert_allclose(data.t_s, t, atol=1e-6)
    assert "a title: skipped" in data.notes[0] and repr(title.split("\n")[-1]) in data.notes[0]


def test_a_one_column_file_whose_header_is_no_time_name_keeps_its_header(tmp_path):
    """Only a time column's name marks the line above as a title: 'Event 1' over 't_impact' is not read
    as a title over a header (the one column is read whatever its name, its header being 'Event 1')."""
    with pytest.raises(DataError, match=r"b.csv:2: 't_impact' is not a number"):
        read_measurement(write(tmp_path, "b.csv", "Event 1\nt_impact\n0.45\n1.22\n1.87\n"))


@pytest.mark.parametrize("text,said", [
    ('{\n  "schema_version": 1,\n  "verdict": "explained",\n  "epsilon": 0.85\n}\n', "a JSON document"),
    ("<mujoco>\n<option timestep='0.001'/>\n</mujoco>\n", "an XML or HTML document"),
    ("Lab notes\nwe dropped the ball, then\n1,2\n", r"doc.txt:2: 'we dropped the ball, then' is not a number")])
def test_documents_and_prose_are_not_tables_below_a_title(tmp_path, text, said):
    with pytest.raises(DataError, match=said):
        read_measurement(write(tmp_path, "doc.txt", text))


def test_trials_side_by_side_are_one_run_each_and_the_average_is_not_read(tmp_path):
    text = ("Drop height (cm),Trial 1 (cm),Trial 2 (cm),Trial 3 (cm),Average (cm)\n"
            "50,32.0,33.1,,32.6\n100,64.2,63.0,65.1,64.1\n")
    data = read_measurement(write(tmp_path, "trials.csv", text))
    assert len(data.runs) == 5   # the empty cell is a trial not made
    assert [r.h_m[1] for r in data.runs] == pytest.approx([0.320, 0.331, 0.642, 0.630, 0.651])
    assert data.labels[1] == "row 1 (line 2), 'Trial 2'"
    assert any("'Average' not read" in n for n in data.notes)


@pytest.mark.parametrize("names", ["1st bounce,2nd bounce,3rd bounce", "First bounce,Second bounce,Third bounce",
                                   "first rebound,second rebound,third rebound", "3rd bounce,1st bounce,2nd bounce"])
def test_ordinal_bounce_columns_are_the_successive_rebounds(tmp_path, names):
    """'1st bounce, 2nd bounce, 3rd bounce': only the first was read before, silently ('4 heights' of 8)."""
    header = "Drop height (cm)," + ",".join(f"{n} (cm)" for n in names.split(","))
    order = [int(n[0]) if n[0].isdigit() else 0 for n in names.split(",")]
    rows = [[100, 56.3, 31.6, 17.8], [50, 28.1, 15.8, 8.9]]
    if order == [3, 1, 2]:
        rows = [[r[0], r[3], r[1], r[2]] for r in rows]
    data = read_measurement(write(tmp_path, "o.csv", header + "\n" + "".join(",".join(map(str, r)) + "\n"
                                                                              for r in rows)))
    assert [list(r.bounce) for r in data.runs] == [[0, 1, 2, 3]] * 2
    np.testing.assert_allclose(data.runs[0].h_m, [1.0, 0.563, 0.316, 0.178])
    assert any("successive rebounds of one drop" in n for n in data.notes)


def test_a_numeric_column_not_read_is_named(tmp_path):
    """A column of numbers the drop table does not read is said, not dropped silently; a trial number is not;
    a comment column is named as such."""
    data = read_measurement(write(tmp_path, "x.csv", "Trial,Drop height (cm),Rebound height (cm),Bounce after (cm),"
                                                     "Comment\n1,100,56.3,31.6,ok\n2,100,56.0,31.2,\n"))
    assert len(data.runs) == 2 and data.runs[0].h_m.size == 2
    said = [n for n in data.notes if "not read" in n]
    assert len(said) == 2 and said[0].startswith("column(s) 'Bounce after' not read: not a drop or rebound height")
    assert said[1] == "column 'Comment' not read (comments)"


@pytest.mark.parametrize("rows,trials", [(("100,64,63,65", "50,32,33,31"), True),
                                         (("100,64,41,26", "50,32,20.5,13"), False)])
def test_numbered_rebound_columns_are_trials_or_successive_bounces_by_their_values(tmp_path, rows, trials):
    data = read_measurement(write(tmp_path, "n.csv", "H (cm),Bounce 1 (cm),Bounce 2 (cm),Bounce 3 (cm)\n"
                                  + "\n".join(rows) + "\n"))
    if trials:
        assert len(data.runs) == 6 and all(list(r.bounce) == [0, 1] for r in data.runs)
        assert any("trials of the row's drop height" in n for n in data.notes)
    else:
        assert len(data.runs) == 2 and list(data.runs[0].bounce) == [0, 1, 2, 3]
        assert any("successive rebounds of one drop" in n for n in data.notes)


def test_numbered_rebound_columns_that_neither_agree_nor_fall_are_an_error(tmp_path):
    p = write(tmp_path, "n.csv", "H (cm),Bounce 1 (cm),Bounce 2 (cm)\n100,64,30\n50,20,32\n")
    with pytest.raises(DataError, match="n.csv:1: columns 'Bounce 1', 'Bounce 2' neither agree"):
        read_measurement(p)


@pytest.mark.parametrize("header,scale", [("H,h", 1.0), ("drop (cm),rebound (cm)", 100.0),
                                          ("trial;H [mm];h1 [mm]", 1000.0), ("Drop height,Rebound height", 1.0)])
def test_a_drop_table_is_read_as_one_run_per_trial(tmp_path, header, scale):
    rows = [(0.5, 0.41), (1.0, 0.80), (1.5, 1.17), (2.0, 1.52)]
    sep = ";" if ";" in header else ","
    trial = header.startswith("trial")
    lines = [header] + [sep.join(([str(i)] if trial else []) + [f"{H * scale:g}", f"{h * scale:g}"])
                        for i, (H, h) in enumerate(rows)]
    p = write(tmp_path, "table.csv", "\n".join(lines) + "\n")
    assert detect_format(p) == "drops"
    data = read_measurement(p)
    assert isinstance(data, Runs) and data.kind == "apexes" and len(data.runs) == 4
    for run, (H, h) in zip(data.runs, rows):
        assert isinstance(run, ApexHeights) and list(run.bounce) == [0, 1]
        np.testing.assert_allclose(run.h_m, [H, h])
    assert data.labels[0] == "row 1 (line 2)"


def test_a_drop_table_with_further_rebounds_and_a_unit_given_once(tmp_path):
    p = write(tmp_path, "t.csv", "H (cm),h1,h2\n100,80,64\n150,120,\n")
    data = read_measurement(p)
    np.testing.assert_allclose(data.runs[0].h_m, [1.0, 0.8, 0.64])
    assert list(data.runs[1].bounce) == [0, 1]
    assert any("has no unit: taken as cm" in n for n in data.notes)


@pytest.mark.parametrize("header,rows,runs", [
    ("Height (cm),Rebound height (cm)", ["100,64", "50,32.5"], [(1.0, 0.64), (0.5, 0.325)]),
    ("Height (cm),Bounce (cm)", ["100,64", "50,32.5", "150,96"], [(1.0, 0.64), (0.5, 0.325), (1.5, 0.96)]),
    ("Height (cm),Bounce (cm)", ["100,64", "50,32", "150,96"], [(1.0, 0.64), (0.5, 0.32), (1.5, 0.96)]),
    ("Height (cm),Bounce 1 (cm),Bounce 2 (cm),Bounce 3 (cm)", ["100,64,65,63", "50,32,33,31"],
     [(1.0, 0.64), (1.0, 0.65), (1.0, 0.63), (0.5, 0.32), (0.5, 0.33), (0.5, 0.31)]),
    ("Versuch;Höhe (cm);Sprunghöhe (cm)", ["1;100;64", "2;50;32,5"], [(1.0, 0.64), (0.5, 0.325)]),
    ("Height (cm),Rebound height", ["100,64", "50,32.5"], [(1.0, 0.64), (0.5, 0.325)])])
def test_a_height_beside_rebound_columns_is_the_drop_height(tmp_path, header, rows, runs):
    """A class heads its sheet 'Height (cm), Rebound height (cm)' (or 'Bounce (cm)', 'Bounce 1 (cm)', ...): 'no
    time column: give the frame rate with --fs HZ', 'bounce number 32.5 is not an integer' and 'bounce number
    not increasing' before (a teacher's probe). A bounce column with a length unit is a height."""
    p = write(tmp_path, "class.csv", header + "\n" + "\n".join(rows) + "\n")
    assert detect_format(p) == "drops"
    data = read_measurement(p)
    assert [tuple(r.h_m) for r in data.runs] == [pytest.approx(r) for r in runs]
    assert data.notes[0].startswith("format: drop table") and "'H" in data.notes[0]


@pytest.mark.parametrize("text,fmt", [("bounce,height (cm)\n0,100\n1,64\n2,41\n", "apexes"),
                                      ("bounce,h (cm)\n0,100\n1,64\n", "apexes"),
                                      ("t (s),height (cm)\n0,100\n0.01,99.95\n0.02,99.8\n", "trajectory"),
                                      ("frame,height (cm)\n0,100\n1,99.95\n2,99.8\n", "trajectory")])
def test_a_height_beside_a_bounce_number_or_a_time_keeps_its_layout(tmp_path, text, fmt):
    assert detect_format(write(tmp_path, "k.csv", text)) == fmt


@pytest.mark.parametrize("header", ["drop,bounce", "Drop,Bounce", "drop height,bounce", "H,bounce"])
def test_a_bounce_beside_a_drop_height_is_the_rebound(tmp_path, header):
    """'drop,bounce' (a real record's header): refused as 'cannot tell the layout' although it names a drop and
    a bounce. An apex file has a height and no drop: beside a drop the bounce is the rebound."""
    p = write(tmp_path, "d.csv", header + "\n1.0,0.64\n0.5,0.33\n")
    assert detect_format(p) == "drops"
    assert [tuple(r.h_m) for r in read_measurement(p).runs] == [pytest.approx((1.0, 0.64)),
                                                               pytest.approx((0.5, 0.33))]


def test_a_drop_table_in_an_unknown_unit_names_the_unit(tmp_path):
    p = write(tmp_path, "b.csv", "drop (bricks),bounce (bricks)\n10,7.5\n5,3.5\n")
    with pytest.raises(DataError, match=r"unknown length unit 'bricks' of column 'drop'"):
        read_measurement(p)


def test_a_drop_table_in_bricks_is_told_what_to_do_and_read_with_scale(tmp_path):
    """Heights in 'number of bricks' (a real class's record) failed 'unknown length unit ... (known: ...)'
    without saying what to do. epsilon = sqrt(h/H) needs no unit, air drag does: the error says so and names
    the fixes (a length unit, or --scale metres per brick), and --scale reads the file."""
    p = write(tmp_path, "b.csv", "drop (bricks),bounce (bricks)\n10,7.5\n5,3.5\n")
    with pytest.raises(DataError, match=r"unknown length unit 'bricks' of column 'drop' \(known: .*\): write the "
                                        r"heights in one of them \(e.g. 'drop \(cm\)'\), or give --scale M_PER_UNIT "
                                        r"\(metres per 'bricks'\); epsilon = sqrt\(h/H\) needs no unit, but air drag"):
        read_measurement(p)
    data = read_measurement(p, scale_m_per_px=0.067)
    assert [tuple(r.h_m) for r in data.runs] == [pytest.approx((0.67, 0.5025)), pytest.approx((0.335, 0.2345))]
    h = write(tmp_path, "h.csv", "bounce,h (bricks)\n0,10\n1,7.5\n")
    with pytest.raises(DataError, match=r"give --scale M_PER_UNIT .*needs no unit"):
        read_measurement(h)
    assert tuple(read_measurement(h, scale_m_per_px=0.067).h_m) == pytest.approx((0.67, 0.5025))


@pytest.mark.parametrize("name,text,said", [
    ("bounce.trk", '<?xml version="1.0" encoding="UTF-8"?>\n<object class="org.opensourcephysics.cabrillo.tracker.'
                   'TrackerPanel">\n    <property name="width" type="double">640.0</property>\n</object>\n',
     r"bounce.trk:1: a Tracker project \(.trk, XML\), not its data: in Tracker, File > Export > Data writes the "
     r"track's table, which vrcal reads \(docs/measurements.md, 'Tracker'\)"),
    ("bounce.cmbl", '<?xml version="1.0" encoding="UTF-8"?>\n<Document><DataSet><DataColumn><DataObjectName>Time'
                    '</DataObjectName><ColumnCells>0\n0.05\n</ColumnCells></DataColumn></DataSet></Document>\n',
     r"bounce.cmbl:1: a Logger Pro file \(.cmbl, XML\), not its data: in Logger Pro, File > Export As > Text"),
])
def test_a_tracker_or_logger_pro_file_is_named_with_its_export(tmp_path, name, text, said):
    """A Tracker project and a Logger Pro file were 'an XML or HTML document (a MuJoCo or Gazebo export, a
    web page?)': the program is named, and the menu that writes the table vrcal reads."""
    with pytest.raises(DataError, match=said):
        read_measurement(write(tmp_path, name, text))


def test_a_timestamp_column_is_the_time_counted_from_its_first(tmp_path):
    """'Timestamp,X,Y' (Unix-epoch seconds, steps of 0.08-0.13 s) was 'no time column: give the frame rate with
    --fs HZ'. A time stamp is the time; a clock's is counted from the first sample (squared in a parabola's fit
    its 1.7e9 s lose their digits)."""
    t, y = fall(n=40, fs=30.0, H=3.0)
    t = 1740924233.7096126 + t + np.random.default_rng(0).uniform(-0.01, 0.01, t.size)
    rows = "".join(f"{a:.7f},489,{b:.6f}\n" for a, b in zip(t, y))
    for header in ("Timestamp,X,Y", "time stamp,x,y"):
        data = read_measurement(write(tmp_path, "ts.csv", f"{header}\n{rows}"))
        assert data.t_s[0] == 0.0 and np.diff(data.t_s) == pytest.approx(np.diff(t), abs=1e-6)
        assert any("counted from the first sample" in n for n in data.notes)
    with pytest.raises(UsageError, match=r"no time column \(columns: when, x, y\): name it 't', 'time', "
                                         r"'timestamp', .*or give the frame rate with --fs HZ"):
        read_measurement(write(tmp_path, "no.csv", f"when,x,y\n{rows}"))


def test_columns_a_trajectory_does_not_read_are_named_and_set_heights_are_no_track(tmp_path):
    """'H,T0,T1,T2' (a drop height per trial and three hand-timed flight times) with --fs 30 was read as a
    trajectory of H: 'gap of 113150 mm ... epsilon = 1.00', T0-T2 dropped without a word. Unread columns are
    named; a height column that changes at a few rows only is no track, and is refused saying so."""
    heights = [200] * 10 + [280] * 7 + [75] * 5 + [300] * 7 + [550]
    rows = "".join(f"{h},1.06,0.95,0.86\n" for h in heights)
    p = write(tmp_path, "bounce.csv", "H,T0,T1,T2\n" + rows)
    with pytest.raises(DataError, match=r"bounce.csv:2: column 'H' changes at 4 of its 30 rows \(line\(s\) 12, 19, "
                                        r"24, 31\): no ball's track .*column\(s\) 'T0', 'T1', 'T2' not read"):
        read_measurement(p, fs_hz=30.0)
    t, y = fall(n=60)
    data = read_measurement(write(tmp_path, "v.csv", "t,y,vy,note\n" + "".join(
        f"{a:.4f},{b:.6f},0,x\n" for a, b in zip(t, y))))
    assert "column(s) 'vy', 'note' not read (a trajectory reads a time, a height and an x column)" in data.notes


def test_an_apex_files_fractional_bounce_number_says_how_to_name_heights(tmp_path):
    p = write(tmp_path, "hb.csv", "Height,Bounce\n1.0,0.64\n0.5,0.33\n")
    with pytest.raises(DataError, match=r"bounce number 0.64 is not an integer \(if 'Bounce' holds rebound "
                                        r"heights, write its unit, e.g. 'Bounce \(cm\)'"):
        read_measurement(p)


def test_a_bounce_column_in_a_length_unit_is_no_bounce_number_of_an_apex_file(tmp_path):
    p = write(tmp_path, "a.csv", "Height (cm),Bounce (cm)\n100,64\n50,32.5\n")
    with pytest.raises(DataError, match=r"a.csv:1: column 'Bounce' is in cm: a height, not a bounce number"):
        read_measurement(p, "apexes")


@pytest.mark.parametrize("header", ["Trial,Rebound height (cm)", "Ball height (cm),Bounce (cm)",
                                    "Trial,Rebound height"])
def test_a_rebound_without_a_drop_height_column_says_so(tmp_path, monkeypatch, header):
    """A rebound column but no drop height: 'no time column: give the frame rate with --fs' or 'cannot tell the
    layout' before."""
    monkeypatch.chdir(tmp_path)
    write(tmp_path, "r.csv", header + "\n1,64\n2,63\n")
    said = r"r.csv:1: no drop-height column: name it e.g. 'Drop height \(cm\)' \(column '.*' is the rebound height\)"
    with pytest.raises(DataError, match=said):
        read_measurement("r.csv")
    result = CliRunner().invoke(main, ["discover", "r.csv", "--ball", "tennis"])
    assert result.exit_code == 1 and "--fs" not in result.output and "no drop-height column" in result.output


def test_an_empty_trial_beside_others_is_named_in_a_note(tmp_path):
    """Trials side by side with one cell empty: the trial was dropped without a word (a re-check probe)."""
    p = write(tmp_path, "t.csv", "Drop height (cm),Trial 1 (cm),Trial 2 (cm),Trial 3 (cm)\n100,64,,63\n50,32,33,31\n")
    data = read_measurement(p)
    assert len(data.runs) == 5
    assert "line 2 'Trial 2': empty, a trial not made (the row's other trials are fitted)" in data.notes


def test_a_column_naming_different_balls_is_refused_with_their_names(tmp_path):
    """Tennis, golf and ping-pong rows were fitted as one ball, the 'Ball' column dropped silently."""
    p = write(tmp_path, "balls.csv", "Ball,Drop height (cm),Bounce height (cm)\nTennis,100,55\nGolf,100,70\n"
                                     "Ping pong,100,78\nTennis,50,28\n")
    with pytest.raises(DataError, match=r"balls.csv:1: column 'Ball' names 3 different balls \(Tennis, Golf, Ping "
                                        r"pong\): one epsilon cannot describe them all; put each ball's rows in a "
                                        r"file of its own"):
        read_measurement(p)
    p = write(tmp_path, "floors.csv", "Surface;H (cm);h (cm)\nwood;100;55\ntiles;100;60\n")
    with pytest.raises(DataError, match=r"column 'Surface' names 2 different surfaces \(wood, tiles\)"):
        read_measurement(p)
    # one ball written 'Tennis', 'tennis ', 'TENNIS' in a class's sheet is one ball (was refused as two)
    p = write(tmp_path, "one.csv", "Ball,Drop height (cm),Bounce height (cm)\nTennis,100,55\ntennis ,100,56\n"
                                   "TENNIS,50,28\n")
    assert "column 'Ball' not read (text: 'Tennis' in every row that fills it)" in read_measurement(p).notes


@pytest.mark.parametrize("column,cells,said", [
    ("Ball", ["Tennis", "Tennis", "Tennis"], "column 'Ball' not read (text: 'Tennis' in every row that fills it)"),
    ("Student", ["Ann", "Ben", "Ann"], "column 'Student' not read: its text differs between rows (Ann, Ben); if the "
                                       "rows are different balls or surfaces, one epsilon does not describe them: "
                                       "put each one's rows in a file of its own"),
    ("Notes", ["ok", "crooked drop", ""], "column 'Notes' not read (comments)")])
def test_a_text_column_is_named_in_a_note(tmp_path, column, cells, said):
    rows = [(100, 55), (100, 56), (50, 28)]
    p = write(tmp_path, "t.csv", f"{column},Drop height (cm),Rebound height (cm)\n"
              + "".join(f"{c},{H},{h}\n" for c, (H, h) in zip(cells, rows)))
    data = read_measurement(p)
    assert len(data.runs) == 3 and said in data.notes


def test_a_row_without_its_rebound_is_skipped_with_a_note_naming_its_line(tmp_path):
    """A blank rebound cell stopped the whole file ('a trial needs its drop height and its first rebound'); a
    class's sheet with its trial numbers written ahead has rows of a number and empty cells."""
    p = write(tmp_path, "e.csv", "Trial,Drop height (cm),Bounce height (cm)\n1,100,64\n2,100,\n3,50,32\n4,50,33\n"
                                 "5,,\n6,,\n")
    data = read_measurement(p)
    assert [tuple(r.h_m) for r in data.runs] == [pytest.approx(r) for r in [(1.0, 0.64), (0.5, 0.32), (0.5, 0.33)]]
    assert "lines 3, 6, 7: no first rebound (empty cells): 3 rows skipped" in data.notes
    assert data.labels == ("row 1 (line 2)", "row 3 (line 4)", "row 4 (line 5)")
    one = read_measurement(write(tmp_path, "one.csv", "H (cm),h1 (cm),h2 (cm)\n100,,41\n100,64,41\n"))
    assert len(one.runs) == 1 and "line 2: no first rebound (an empty cell): row skipped" in one.notes


@pytest.mark.parametrize("text,said", [("H (cm),h (cm)\n100,\n100,\n", r"x.csv:3: no trial with a drop height and "
                                                                       r"a rebound"),
                                       ("H (cm),h (cm)\n100,64\n,63\n", r"x.csv:3: empty cell in column 'H'")])
def test_a_table_without_a_complete_trial_or_a_rebound_without_its_drop_is_an_error(tmp_path, text, said):
    with pytest.raises(DataError, match=said):
        read_measurement(write(tmp_path, "x.csv", text))


@pytest.mark.parametrize("rows,said", [("100,64\n100,65\n", "2 trial(s), drop height 1 m"),
                                       ("100,64\n50,32\n", "2 trial(s), drop heights 0.5-1 m")])
def test_the_drop_heights_note_says_one_height_once(tmp_path, rows, said):
    """'drop heights 1-1 m' when every row shares one height."""
    assert said in read_measurement(write(tmp_path, "d.csv", "H (cm),h (cm)\n" + rows)).notes


def test_two_apex_rows_give_one_drop(tmp_path):
    p = write(tmp_path, "two.csv", "bounce,h (cm)\n0,110\n1,86.77\n")
    data = read_measurement(p)
    assert isinstance(data, ApexHeights)
    np.testing.assert_allclose(data.h_m, [1.10, 0.8677])


def test_the_real_first_rebound_table_is_read():
    data = read_measurement(shared_file("realval/giiulia_method1/golf_110cm_first_rebound.csv"))
    assert isinstance(data, ApexHeights) and data.h_m.size == 2


# --------------------------------------------------------------------------- several files, runs side by side


def test_several_files_of_one_kind_are_runs(tmp_path):
    a = write(tmp_path, "a.csv", "t\n" + "\n".join(repr(float(v)) for v in impact_times(0.8)) + "\n")
    b = write(tmp_path, "b.csv", "t\n" + "\n".join(repr(float(v)) for v in impact_times(1.2)) + "\n")
    data = read_measurements([a, b])
    assert isinstance(data, Runs) and data.labels == (str(a), str(b))
    t, y = fall()
    c = write(tmp_path, "c.csv", "t,y\n" + "\n".join(f"{float(u)!r},{float(v)!r}" for u, v in zip(t, y)) + "\n")
    with pytest.raises(UsageError, match="one kind") as err:
        read_measurements([a, c])
    assert str(err.value).endswith("run them separately")


def test_a_file_given_twice_is_refused(tmp_path):
    """The same file twice counted its data twice: C_d's ± fell from 0.078 to 0.051 and a table's repeated
    trials doubled, silently. Refused in one line naming it; a copy (identical content, which trials read off a
    video's frame grid can be) is kept with a note naming both."""
    a = write(tmp_path, "a.csv", "t\n" + "\n".join(repr(float(v)) for v in impact_times(0.8)) + "\n")
    b = write(tmp_path, "b.csv", "t\n" + "\n".join(repr(float(v)) for v in impact_times(1.2)) + "\n")
    copy = write(tmp_path, "copy.csv", (tmp_path / "a.csv").read_text())
    with pytest.raises(UsageError, match=r"a\.csv is the same file as .*a\.csv: give each file once"):
        read_measurements([a, b, f"{tmp_path}/./a.csv"])
    with pytest.raises(UsageError, match=r"a\.csv is given twice: give each file once"):
        read_measurements([a, b, a])
    data = read_measurements([a, copy])
    assert len(data.runs) == 2
    assert any(n.startswith(f"{copy} has the same content as {a}: fitted as a repeated trial") for n in data.notes)


def test_columns_of_the_same_name_are_runs_side_by_side(tmp_path):
    t1, t2 = impact_times(0.8, n=8), impact_times(0.8, n=6)
    lines = ['"Event time (s)","Interval (s)",,"Event time (s)","Interval (s)"']
    for i in range(8):
        second = f"{float(t2[i])!r},0" if i < 6 else ","
        lines.append(f"{float(t1[i])!r},0,,{second}")
    data = read_measurement(write(tmp_path, "side.csv", "\n".join(lines) + "\n"))
    assert isinstance(data, Runs) and [r.t_s.size for r in data.runs] == [8, 6]


def test_trajectories_side_by_side_are_runs_and_unpaired_columns_an_error(tmp_path):
    t, y = fall()
    rows = [f"{a:.3f},{b:.4f},{a:.3f},{0.5 * b:.4f}" for a, b in zip(t, y)]
    data = read_measurement(write(tmp_path, "two.csv", "Run 1: Time (s),Run 1: Position (cm),Run 2: Time (s),"
                                                       "Run 2: Position (cm)\n" + "\n".join(rows) + "\n"))
    assert isinstance(data, Runs) and data.kind == "trajectory"
    assert data.labels == ("Run 1 (columns 1, 2)", "Run 2 (columns 3, 4)")
    assert [c.data_set for c in tb_columns(["Run 1: Time (s)", "Latest: Position (m)", "t (s)"])] == [
        "Run 1", "Latest", ""]
    np.testing.assert_allclose(data.runs[1].y_m, 0.01 * np.round(0.5 * y, 4), atol=1e-9)
    bad = write(tmp_path, "bad.csv", "t,y,y\n" + "\n".join(f"{a},{b},{b}" for a, b in zip(t, y)) + "\n")
    with pytest.raises(DataError, match="bad.csv:1: 2 columns 'y' but 1 columns 't'"):
        read_measurement(bad)


# --------------------------------------------------------------------------- phyphox (In)elastic collision


def collision_row(t):
    """One row of phyphox's (In)elastic collision export for impact times t (its own heights and
    energies computed as the experiment does: h = g dt^2 / 8, E = (dt_k / dt_1)^2)."""
    cells, dt = [], np.diff(t)
    for k in range(6):
        time = t[k] if k < len(t) else 0.0
        h = G * dt[k - 1] ** 2 / 8 if 0 < k < len(t) else 0.0
        cells += [time, h] + ([(dt[k - 1] / dt[0]) ** 2 if 0 < k < len(t) else 0.0] if k else [])
    return ",".join(f"{float(v):.6E}" for v in cells)


COLLISION_HEADER = ",".join(f'"Bounce {k} (s)","Height {k} (m)"' + (f',"Energy {k}"' if k else "") for k in range(6))


def test_phyphox_collision_export_gives_its_impact_times(tmp_path):
    t = impact_times(H=0.5, eps=0.9, n=6) + 0.31
    p = write(tmp_path, "collision.csv", COLLISION_HEADER + "\n" + collision_row(t) + "\n")
    assert detect_format(p) == "phyphox-collision"
    data = read_measurement(p)
    assert isinstance(data, ImpactTimes)
    np.testing.assert_allclose(data.t_s, t, rtol=1e-6)
    assert any("not read" in n for n in data.notes)


def test_phyphox_collision_bounces_not_heard_are_skipped_and_rows_are_runs(tmp_path):
    t1 = impact_times(H=0.5, eps=0.9, n=4) + 0.2
    t2 = impact_times(H=0.8, eps=0.9, n=6) + 0.4
    p = write(tmp_path, "two.csv", COLLISION_HEADER + "\n" + collision_row(t1) + "\n" + collision_row(t2) + "\n")
    data = read_measurement(p)
    assert isinstance(data, Runs) and [r.t_s.size for r in data.runs] == [4, 6]
    np.testing.assert_allclose(data.runs[0].t_s, t1, rtol=1e-6)
    assert any("'Bounce 4', 'Bounce 5' empty or 0 (not heard)" in n for n in data.runs[0].notes)


def test_phyphox_collision_names_its_bounce_in_the_notes(tmp_path):
    t = impact_times(H=0.5, eps=0.9, n=6) + 0.3
    t[4:] += 0.05      # bounce 4 late: the flight before it is 1.2 x too long
    data = read_measurement(write(tmp_path, "late.csv", COLLISION_HEADER + "\n" + collision_row(t) + "\n"))
    assert any("'Bounce 3' (line 2)" in n or "'Bounce 4' (line 2)" in n for n in data.notes), data.notes


def test_phyphox_collision_export_from_a_workbook(tmp_path):
    openpyxl = pytest.importorskip("openpyxl")
    t = impact_times(H=0.5, eps=0.9, n=6) + 0.31
    wb = openpyxl.Workbook()
    ws = wb.active
    ws.title = "Energy"
    ws.append([c.strip('"') for c in COLLISION_HEADER.split(",")])
    ws.append([float(v) for v in collision_row(t).split(",")])
    wb.create_sheet("Metadata Device").append(["property", "value"])
    wb.save(tmp_path / "collision.xlsx")
    data = read_measurement(tmp_path / "collision.xlsx")
    np.testing.assert_allclose(data.t_s, t, rtol=1e-6)


def test_the_acoustic_stopwatch_multiple_set_gives_its_six_events(tmp_path):
    t = impact_times(H=0.5, eps=0.9, n=6) + 0.31
    header = '"Start (s)",' + ",".join(f'"Stop {k} (s)"' for k in range(1, 6))
    p = write(tmp_path, "multiple.csv", header + "\n" + ",".join(f"{v:.6f}" for v in t) + "\n")
    assert detect_format(p) == "phyphox-collision"
    data = read_measurement(p)
    np.testing.assert_allclose(data.t_s, t, atol=1e-6)
    assert "Acoustic Stopwatch" in data.notes[0]


def test_the_real_stopwatch_workbook_gives_the_same_events_from_its_multiple_sheet_and_refuses_simple():
    pytest.importorskip("xlrd")
    path = shared_file("realval/giiulia_phyphox_excel/tennis_ball/Lancio 1, tennis, 65.xls")
    every = read_measurement(path)                      # the sheet 'All'
    six = read_measurement(path, sheet="Multiple")
    np.testing.assert_allclose(six.t_s, every.t_s[:six.t_s.size], atol=1e-9)
    with pytest.raises(DataError, match="set 'Simple' holds two events.*export the set 'All'"):
        read_measurement(path, sheet="Simple")


# --------------------------------------------------------------------------- spreadsheets


def test_phyphox_xls_export_reads_its_all_sheet():
    pytest.importorskip("xlrd")
    data = read_measurement(shared_file("realval/giiulia_phyphox_excel/tennis_ball/Lancio 1, tennis, 65.xls"))
    csv = read_measurement(shared_file("realval/giiulia/tennis_65cm_L1.csv"))
    np.testing.assert_allclose(data.t_s, csv.t_s, atol=1e-6)
    assert data.source.endswith("[All]")


def test_phyphox_xlsx_export_and_a_named_sheet():
    pytest.importorskip("openpyxl")
    data = read_measurement(shared_file("realval/giiulia_phyphox_excel/pingpong_ball/Lancio1,30cm.xlsx"))
    csv = read_measurement(shared_file("realval/giiulia/pingpong_30cm_L1.csv"))
    np.testing.assert_allclose(data.t_s, csv.t_s, atol=1e-6)
    golf = read_measurement(shared_file("realval/giiulia_phyphox_excel/golf_ball/data_golfball.xlsx"), sheet="100 cm")
    assert isinstance(golf, Runs) and len(golf.runs) == 4
    with pytest.raises(UsageError, match="no sheet 'nope'.*'80 cm'"):
        read_measurement(shared_file("realval/giiulia_phyphox_excel/golf_ball/data_golfball.xlsx"), sheet="nope")


def test_a_written_workbook_is_a_table_like_any_other(tmp_path):
    openpyxl = pytest.importorskip("openpyxl")
    wb = openpyxl.Workbook()
    ws = wb.active
    ws.title = "drops"
    ws.append(["H (cm)", "h (cm)"])
    for H, h in [(50, 41), (100, 80), (150, 117)]:
        ws.append([H, h])
    path = tmp_path / "table.xlsx"
    wb.save(path)
    data = read_measurement(path)
    assert isinstance(data, Runs) and len(data.runs) == 3
    np.testing.assert_allclose(data.runs[1].h_m, [1.0, 0.8])


@pytest.mark.parametrize("name,content,said", [
    ("fake.xlsx", b"not a workbook\n", r"it is text .*rename it to .csv, or give --format"),
    ("t.xls", b"t\n0.45\n1.22\n1.87\n", r"it is text .*rename it to .csv"),
    ("page.xls", b"<html><table><tr><td>t</td></tr></table></html>\n", "it is an HTML or XML document"),
    ("zip.xls", b"PK\x03\x04" + bytes(40), r"it is a zip archive \(an .xlsx workbook named .xls"),
    ("empty.xlsx", b"", "it is empty")])
def test_a_file_named_as_a_workbook_that_is_none_says_what_it_is(tmp_path, name, content, said):
    """A text file named .xlsx said "fake.xlsx:1: header but no data rows"."""
    path = tmp_path / name
    path.write_bytes(content)
    with pytest.raises(DataError, match=rf"{name}: not an Excel workbook: {said}"):
        read_measurement(path)
    with pytest.raises(DataError, match="not an Excel workbook"):
        detect_format(path)


def test_a_text_table_named_xlsx_is_read_with_format(tmp_path):
    t = impact_times(n=5)
    path = tmp_path / "t.xlsx"
    path.write_text("t\n" + "".join(f"{v}\n" for v in t))
    np.testing.assert_allclose(read_measurement(path, fmt="impacts").t_s, t)


def test_detect_format_reads_a_workbooks_sheet(tmp_path):
    openpyxl = pytest.importorskip("openpyxl")
    wb = openpyxl.Workbook()
    for row in [["H (cm)", "h (cm)"], [50, 41], [100, 80]]:
        wb.active.append(row)
    wb.save(tmp_path / "d.xlsx")
    assert detect_format(tmp_path / "d.xlsx") == "drops"


def _phyphox_zip(path, members):
    import zipfile

    with zipfile.ZipFile(path, "w") as zf:
        for name, text in members.items():
            zf.writestr(name, text)
    return path


def test_a_phyphox_zip_export_is_read_from_its_all_csv(tmp_path):
    """phyphox's CSV export is a zip of one CSV per data set and a meta folder: 'binary file ... save it as
    CSV' before. Its 'All.csv' is read (like the 'All' sheet of its Excel export), --sheet reads another."""
    t = impact_times(n=8)
    all_csv = '"Event time (s)","Interval (s)"\n' + "".join(f"{v:.9E},0\n" for v in t)
    multiple = ",".join(['"Start (s)"'] + [f'"Stop {i} (s)"' for i in range(1, 6)]) + "\n" + \
        ",".join(f"{v:.9E}" for v in t[:6]) + "\n"
    path = _phyphox_zip(tmp_path / "export.zip", {"All.csv": all_csv, "Simple.csv": '"Start (s)","Stop (s)"\n1,2\n',
                                                   "Multiple.csv": multiple, "meta/device.csv": '"property","value"\n'})
    assert detect_format(path) == "impacts"
    data = read_measurement(path)
    np.testing.assert_allclose(data.t_s, t, atol=1e-8)
    assert data.source == f"{path}[All.csv]"
    assert data.notes[0] == ("zip archive: 'All.csv' read (also in it: 'Simple.csv', 'Multiple.csv'; --sheet to read "
                             "another)")
    np.testing.assert_allclose(read_measurement(path, sheet="Multiple").t_s, t[:6], atol=1e-8)
    with pytest.raises(UsageError, match=r"no table 'Raw' in the archive \(tables: 'All.csv', 'Simple.csv'"):
        read_measurement(path, sheet="Raw")


def test_a_zip_without_one_table_to_read_says_how_to_choose(tmp_path):
    one = _phyphox_zip(tmp_path / "one.zip", {"Raw data.csv": "t\n" + "".join(f"{v}\n" for v in impact_times(n=6))})
    assert read_measurement(one).t_s.size == 6
    two = _phyphox_zip(tmp_path / "two.zip", {"a.csv": "t\n1\n", "b.csv": "t\n2\n"})
    with pytest.raises(DataError, match=r"two.zip: a zip archive of 2 tables \('a.csv', 'b.csv'\): give --sheet NAME"):
        read_measurement(two)
    none = _phyphox_zip(tmp_path / "none.zip", {"photo.jpg": "x"})
    with pytest.raises(DataError, match="a zip archive with no CSV or text table in it"):
        read_measurement(none)
    bad = tmp_path / "bad.zip"
    bad.write_bytes(b"PK\x03\x04" + b"\x00" * 40)
    with pytest.raises(DataError, match="not a readable zip archive"):
        read_measurement(bad)


@pytest.mark.parametrize("encoding", ["utf-16", "utf-16-be"])
def test_a_utf16_text_file_is_read(tmp_path, encoding):
    """Excel's "Unicode Text" is UTF-16 with a byte order mark, tab-separated: 'binary file' before."""
    text = "Trial\tDrop height (cm)\tRebound height (cm)\r\n1\t30\t16.9\r\n2\t100\t56.3\r\n"
    path = tmp_path / "unicode.txt"
    path.write_bytes(("\ufeff" + text).encode(encoding))
    data = read_measurement(path)
    np.testing.assert_allclose(data.runs[1].h_m, [1.0, 0.563])


def test_a_missing_spreadsheet_library_is_a_one_line_hint(monkeypatch):
    path = shared_file("realval/giiulia_phyphox_excel/tennis_ball/Lancio 1, tennis, 65.xls")
    real_import = builtins.__import__

    def no_xlrd(name, *args, **kwargs):
        if name == "xlrd":
            raise ImportError("no xlrd")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_xlrd)
    hint = r"needs xlrd: pip install xlrd \(or, in vrcal's folder, pip install '\.\[excel\]'\)"
    with pytest.raises(UsageError, match=hint):
        read_measurement(path)


# --------------------------------------------------------------------------- no crash on arbitrary input


CELLS = st.one_of(st.floats(allow_nan=True, allow_infinity=True).map(repr), st.integers(-10**6, 10**6).map(str),
                  st.sampled_from(["t", "y", "h", "H", "bounce", "time (ms)", "y (px)", "drop", "rebound", "",
                                   "nan", "1,5", "-", "x", "#", '"', "mass_A", "0.0687", "84.1", "Fallhöhe (cm)",
                                   "Rückprallhöhe in cm", "H (in)", "h (yd)", "Ball lab - group 3", "cm", "(s)",
                                   "m/s"]))
LINES = st.lists(st.lists(CELLS, min_size=1, max_size=4).map(lambda cs: st.sampled_from([",", ";", "\t", " "]).map(
    lambda sep: sep.join(cs))), min_size=0, max_size=30)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data(), fmt=st.sampled_from([None, *FORMATS]))
def test_no_reader_crashes_on_arbitrary_tables(tmp_path_factory, data, fmt):
    lines = [data.draw(line) for line in data.draw(LINES)]
    path = tmp_path_factory.mktemp("fuzz") / "f.csv"
    path.write_text("\n".join(lines) + "\n")
    try:
        read_measurement(path, fmt, fs_hz=data.draw(st.sampled_from([None, 30.0])),
                         scale_m_per_px=data.draw(st.sampled_from([None, 0.001])))
    except VrcalError:
        pass


@settings(max_examples=200, deadline=None)
@given(text=st.text(max_size=400))
def test_no_reader_crashes_on_arbitrary_text(tmp_path_factory, text):
    path = tmp_path_factory.mktemp("text") / "f.txt"
    path.write_text(text, encoding="utf-8", errors="surrogatepass") if "\ud800" not in text else path.write_bytes(b"x")
    try:
        read_measurement(path)
    except VrcalError:
        pass


@pytest.mark.parametrize("example,options,said", [
    ("apexes.csv", {"fs_hz": 30.0, "y_down": True}, "--fs, --y-down ignored: they apply to trajectories"),
    ("drop-table.csv", {"scale_m_per_px": 0.01}, "--scale ignored: it applies to trajectories"),
    ("phyphox-impacts.csv", {"fs_hz": 30.0}, "--fs ignored: it applies to trajectories, and this file holds impacts"),
])
def test_trajectory_options_on_other_records_are_said_to_be_ignored(example, options, said):
    """--fs, --scale and --y-down given for impact times or heights changed nothing, silently."""
    got = read_measurement(EXAMPLES / "data" / example, **options)
    assert any(said in n for n in got.notes), got.notes


@pytest.mark.parametrize("header", ['"Ereigniszeit (s)";"Intervall (s)"', '"Zeit (s)";"Intervall (s)"',
                                    '"Tiempo (s)";"Intervalo (s)"'])
def test_a_phones_export_in_the_class_language_is_read(tmp_path, header):
    """phyphox in German writes 'Ereigniszeit (s)' with semicolons and decimal commas: 'cannot tell the
    layout' before."""
    t = impact_times(H=0.5, eps=0.9, n=8)
    rows = [f"{a:.9E};{b:.9E}".replace(".", ",") for a, b in zip(t, np.diff(t, prepend=0.0))]
    got = read_measurement(write(tmp_path, "de.csv", header + "\n" + "\n".join(rows) + "\n"))
    assert got.kind == "impacts"
    np.testing.assert_allclose(got.t_s, t, rtol=1e-8)


def test_a_vrcal_scenes_trajectories_are_read_as_the_bottoms_height_of_one_body(tmp_path):
    """vrcal's own writer, read back: NAME-trajectories.csv of `vrcal scene` has t_s, body, x_m, y_m
    (horizontal), z_m, bottom_m. One body: its bottom_m is the height (Figure 8's basketball gives its
    0.766 back); several bodies: one line naming them (it used to read y_m, always 0: 'no fall')."""
    runner = CliRunner()
    for scene in ("figure8-basketball", "stack-drop"):
        result = runner.invoke(main, ["scene", str(EXAMPLES / f"{scene}.yaml"), "-o", str(tmp_path / scene),
                                      "--no-animation"])
        assert result.exit_code == 0, result.output
    one = read_measurement(str(tmp_path / "figure8-basketball" / "figure8-basketball-trajectories.csv"))
    assert isinstance(one, Trajectory) and one.y_m[0] == pytest.approx(1.8)
    assert any("bottom_m" in n for n in one.notes)
    found = runner.invoke(main, ["discover", str(tmp_path / "figure8-basketball" /
                                                 "figure8-basketball-trajectories.csv"), "--ball", "basketball",
                                 "-q", "--json", "-"])
    assert found.exit_code == 0, found.output
    assert '"epsilon": 0.7661' in found.stdout
    with pytest.raises(DataError, match=r"2 bodies \(basketball, tennis\)"):
        read_measurement(str(tmp_path / "stack-drop" / "stack-drop-trajectories.csv"))
