"""Classroom lab-software exports of a ball bouncing under a motion detector (a probe's findings): PASCO
Capstone's and SPARKvue's run numbers after the unit (``Position (m) Run #1``), a lost echo's empty cell inside
a run, an Arduino sketch's banner above its Vernier header, CASSY Lab's ``t / s``, ``s_A1 / m`` and Coach's
Dutch ``Tijd (s)``, ``Afstand (m)``. Every record is built here: a drop from 1.2 m, epsilon 0.80, the distance
from a sensor 1.9 m above the floor to the ball's top (read with --y-down)."""

import re

import numpy as np
import pytest
from click.testing import CliRunner
from helpers import bottom_height

from vrcal.cli import main
from vrcal.errors import DataError
from vrcal.measurements import Runs, Trajectory, detect_format, read_measurement

EPS, H, SENSOR, D = 0.80, 1.20, 1.90, 0.24


def distance(t, release=0.5, n=10):
    """Distance [m] from the sensor to the top of a ball dropped from rest at ``release`` (bottom at H),
    bouncing with EPS, drag-free, to 1 mm."""
    return np.round(SENSOR - D - bottom_height(t, H, EPS, n, release), 3)


def write(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return str(p)


def discover_epsilon(path):
    result = CliRunner().invoke(main, ["discover", path, "--ball", "basketball", "--y-down"])
    assert result.exit_code == 0, result.output
    return float(re.search(r"epsilon = ([0-9.]+)", result.output).group(1))


# --------------------------------------------------------------------------- 1. run numbers after the unit


def capstone(runs, fs=50.0, duration=4.0):
    t = np.round(np.arange(0, duration, 1 / fs), 3)
    d = distance(t)
    head = ",".join(f"{name} Run #{k}" for k in range(1, runs + 1)
                    for name in ("Time (s)", "Position (m)", "Velocity (m/s)"))
    rows = [",".join(f"{a:.2f},{b:.3f},0.000" for _ in range(runs)) for a, b in zip(t, d)]
    return head + "\n" + "\n".join(rows) + "\n", d


@pytest.mark.parametrize("runs", [1, 2])
def test_pasco_capstone_runs_after_the_unit_read_as_vernier_prefixed_runs(tmp_path, runs):
    """``Time (s) Run #1,Position (m) Run #1,...`` was read as impact times ('the intervals do not shrink')
    and, with --format trajectory, told to name 'Position (m) Run #1' 'position'."""
    text, d = capstone(runs)
    p = write(tmp_path, "capstone.csv", text)
    assert detect_format(p) == "trajectory"
    data = read_measurement(p, y_down=True)
    if runs == 1:
        assert isinstance(data, Trajectory)
        np.testing.assert_allclose(data.y_m, -d)
    else:
        assert isinstance(data, Runs) and data.labels == ("Run #1 (columns 1, 2)", "Run #2 (columns 4, 5)")
        for run in data.runs:
            np.testing.assert_allclose(run.y_m, -d)
    assert abs(discover_epsilon(p) - EPS) < 0.002


def test_sparkvue_quoted_run_suffix_is_one_run(tmp_path):
    t = np.round(np.arange(0, 4.0, 0.05), 2)
    d = distance(t)
    p = write(tmp_path, "sparkvue.csv", '"Time (s) Run 1","Position (m) Run 1"\n'
              + "\n".join(f"{a:.2f},{b:.3f}" for a, b in zip(t, d)) + "\n")
    data = read_measurement(p, y_down=True)
    assert isinstance(data, Trajectory)
    np.testing.assert_allclose(data.t_s, t)


def test_impact_times_of_a_file_with_a_height_column_are_not_told_to_name_it_so(tmp_path):
    """--format impacts on a motion detector's table: the message told to name the height column 'position',
    which it was."""
    text, _ = capstone(1)
    p = write(tmp_path, "capstone.csv", text)
    with pytest.raises(DataError) as info:
        read_measurement(p, "impacts")
    said = str(info.value)
    assert "column 'Position' holds the heights of a trajectory: give --format trajectory" in said
    assert "is named 'y', 'height', 'position'" not in said


def test_a_drop_table_of_trials_numbered_after_the_unit_keeps_its_trials(tmp_path):
    """``Rebound (cm) Run 1``, ``Rebound (cm) Run 2``: the run's number after the unit tells the trials apart."""
    p = write(tmp_path, "drops.csv", "Drop height (cm),Rebound (cm) Run 1,Rebound (cm) Run 2\n"
              "100,63.8,64.1\n80,51.3,51.0\n60,38.5,38.2\n")
    data = read_measurement(p)
    assert len(data.runs) == 6
    assert data.runs[1].h_m[1] == pytest.approx(0.641)


# --------------------------------------------------------------------------- 2. empty cells inside the data


def test_a_lost_echo_inside_a_run_is_left_out_naming_its_lines(tmp_path):
    t = np.round(np.arange(0, 5.5, 0.05), 2)
    d = distance(t)
    rows = [f"{a:g},{b:.3f},0.0" for a, b in zip(t, d)]
    for k in (49, 75, 100):   # lines 51, 77, 102
        rows[k] = f"{t[k]:g},,"
    p = write(tmp_path, "ga.csv", '"Latest: Time (s)","Latest: Position (m)","Latest: Velocity (m/s)"\n'
              + "\n".join(rows) + "\n")
    data = read_measurement(p, y_down=True)
    assert "3 rows with no height left out: lines 51, 77, 102" in data.notes
    assert data.t_s.size == t.size - 3 and 2.45 not in data.t_s
    assert abs(discover_epsilon(p) - EPS) < 0.002


def test_an_empty_time_inside_a_run_is_left_out_and_an_empty_column_is_an_error(tmp_path):
    t = np.round(np.arange(0, 4.0, 0.05), 2)
    rows = [f"{a:g},{b:.3f}" for a, b in zip(t, distance(t))]
    rows[10] = "," + rows[10].split(",")[1]
    data = read_measurement(write(tmp_path, "t.csv", "t (s),distance (m)\n" + "\n".join(rows) + "\n"))
    assert "1 row with no time left out: line 12" in data.notes
    with pytest.raises(DataError, match=r"e.csv:1: column 'y' \(height\) holds no number"):
        read_measurement(write(tmp_path, "e.csv", "t,y,x\n" + "\n".join(f"{a:g},,1" for a in t) + "\n"))


def test_an_empty_cell_inside_a_shorter_run_beside_a_longer_one_is_named_by_its_line(tmp_path):
    text, _ = capstone(2)
    lines = text.splitlines()
    cells = lines[40].split(",")
    cells[4] = ""                     # run 2's position at line 41
    lines[40] = ",".join(cells)
    for k in range(150, len(lines)):  # run 2 ends at line 150
        lines[k] = ",".join(lines[k].split(",")[:3]) + ",,,"
    data = read_measurement(write(tmp_path, "two.csv", "\n".join(lines) + "\n"), y_down=True)
    notes = data.runs[1].notes
    assert "1 row with no height left out: line 41" in notes
    assert any(n.startswith(f"skipped {len(lines) - 150} row(s) without a position (after the end of Run #2")
               for n in notes)


def test_impact_times_and_drop_tables_leave_out_a_row_with_an_empty_cell(tmp_path):
    times = "Event time (s),Interval (s)\n0.5,0\n1.3,0.8\n1.94,0.64\n,\n2.45,0.51\n2.86,0.41\n3.19,0.33\n"
    got = read_measurement(write(tmp_path, "i.csv", times.replace("\n,\n", "\n,0.1\n")))
    assert got.t_s.size == 6 and "1 row with no impact time left out: line 5" in got.notes
    drops = read_measurement(write(tmp_path, "d.csv", "H (cm),h (cm)\n100,64\n80,\n60,38.4\n"))
    assert len(drops.runs) == 2 and "line 3: no first rebound (an empty cell): row skipped" in drops.notes


# --------------------------------------------------------------------------- 3. a preamble above the header


def test_an_arduino_banner_above_a_vernier_header_is_a_preamble(tmp_path):
    """An Arduino sketch's Serial Monitor copy: 'line 8: 2 cells but the header names 1 columns'."""
    t = np.round(np.arange(0, 4.0, 0.04), 2)
    d = distance(t)
    head = ["*" * 49, "Push button (D12) to start data collection.", "Use reset button to reset / stop.", "*" * 49,
            "Vernier Format 2", "Motion Detector Readings taken using Ardunio", "Data Set", "Time\tDistance",
            "seconds\tcentimeters"]
    p = write(tmp_path, "sketch.txt", "\n".join(head + [f"{a:.2f}\t{100 * b:.2f}" for a, b in zip(t, d)]) + "\n")
    data = read_measurement(p, y_down=True)
    np.testing.assert_allclose(data.y_m, -d, atol=1e-9)
    assert any(n.startswith("lines 1-7 above the header (line 8) skipped: a preamble ('*****") for n in data.notes)
    assert abs(discover_epsilon(p) - EPS) < 0.002


def test_prose_above_a_t_y_header_is_a_preamble_and_a_table_without_numbers_still_fails(tmp_path):
    t = np.round(np.arange(0, 4.0, 0.05), 2)
    prose = "\n".join(f"Note {k}, written by the class: sensor, ball, floor" for k in range(8))
    rows = "\n".join(f"{a:g},{b:.3f}" for a, b in zip(t, distance(t)))
    p = write(tmp_path, "p.csv", prose + "\nt (s),y (m)\n" + rows)
    assert read_measurement(p).t_s.size == t.size
    with pytest.raises(DataError):
        read_measurement(write(tmp_path, "q.csv", prose + "\nt (s),y (m)\n"))


def test_a_vernier_data_set_with_a_tab_is_shown_with_one_blank(tmp_path):
    t = np.round(np.arange(0, 4.0, 0.04), 2)
    head = ["Vernier Format 2", "Ultrasonic sensor readings", "Data\tSet", "Time\tDistance", "t\tx", "seconds\tcm"]
    p = write(tmp_path, "e2.txt", "\n".join(head + [f"{a:.2f}\t{100 * b:.2f}" for a, b in zip(t, distance(t))]) + "\n")
    said = "format: Vernier text export ('Ultrasonic sensor readings', data set 'Data Set')"
    assert read_measurement(p).notes[0] == said


# --------------------------------------------------------------------------- 4. CASSY Lab and Coach


@pytest.mark.parametrize("header", ["n\tt / s\ts_A1 / m", "n\tt / s\ts_B1 / m", "Tijd (s)\tAfstand (m)",
                                    "Tijd (s)\tHoogte (m)", "Tijd (s)\tpositie (m)", "Zeit (s)\tAbstand (m)",
                                    "Zeit (s)\tWeg (m)"])
def test_cassy_and_coach_headers_are_trajectories(tmp_path, header):
    t = np.round(np.arange(0, 4.0, 0.05), 2)
    d = distance(t)
    n = header.startswith("n\t")
    rows = [("{}\t".format(k + 1) if n else "") + f"{a:.2f}\t{b:.3f}".replace(".", ",") for k, (a, b) in
            enumerate(zip(t, d))]
    p = write(tmp_path, "lab.txt", header + "\n" + "\n".join(rows) + "\n")
    assert detect_format(p) == "trajectory"
    data = read_measurement(p, y_down=True)
    np.testing.assert_allclose(data.y_m, -d)
    np.testing.assert_allclose(data.t_s, t)


@pytest.mark.parametrize("clock,per_s", [("millis", 1e3), ("micros", 1e6)])
def test_an_arduino_clock_column_is_a_time_in_its_unit(tmp_path, clock, per_s):
    """An HC-SR04 sketch prints ``millis,distance_cm`` (Arduino's millis() since power-up): the column is
    read as a time in ms (micros() in us), not refused for having no time column."""
    t = np.round(np.arange(0, 4.0, 0.04), 2)
    d = distance(t)
    rows = [f"{round((2.346 + a) * per_s)},{b * 100:.1f}" for a, b in zip(t, d)]
    p = write(tmp_path, "hcsr04.csv", f"{clock},distance_cm\n" + "\n".join(rows) + "\n")
    data = read_measurement(p, y_down=True)
    np.testing.assert_allclose(data.t_s, 2.346 + t, atol=1e-9)
    assert discover_epsilon(p) == pytest.approx(EPS, abs=0.003)
