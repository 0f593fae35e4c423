"""vrcal.measurements.plausibility and ``vrcal discover`` on records that read fine but cannot be
physical (issue 10, "silently wrong answers"): each ends in a correct result, a warning naming what
looks wrong (the verdict "suspect input"), or a one-line error with exit status 1 -- never exit 0
with nonsense."""

import dataclasses
import json
import re

import numpy as np
import pytest
from click.testing import CliRunner

from vrcal.cli import main
from vrcal.discovery.ranking import discover
from vrcal.drop.synthetic import hidden_effect_case
from vrcal.errors import DataError
from vrcal.measurements import ApexHeights, ImpactTimes, Runs
from vrcal.measurements.plausibility import check, check_impact_times, flight_gravity
from vrcal.model.body import BallProperties
from vrcal.model.standards import get_ball


def ball(truth):
    return BallProperties.from_ball(get_ball(truth["ball"]))


@pytest.fixture(scope="module")
def track():
    return hidden_effect_case(11, "trajectory", ())


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def csv(path, header, columns):
    path.write_text(header + "\n" + "\n".join(",".join(f"{float(v)!r}" for v in row) for row in zip(*columns)) + "\n")
    return path


# --------------------------------------------------------------------------- trajectories


def test_g_from_the_flights_of_a_plausible_record(track):
    data, truth = track
    g, upside, n = flight_gravity(data.t_s, data.y_m, data.release_index, truth["noise"])
    assert not upside and n >= 2
    assert g == pytest.approx(9.80665, rel=0.03)
    assert check(data, 0.067).warnings == ()


def test_the_g_note_says_how_many_flights_it_rests_on():
    """A 30 fps track of four flights: 'g from the parabolas of 1 flight(s)' read as if the record held one,
    beside a track's g from all four (vrcal track fits them together); the note says of how many and why."""
    from vrcal.measurements import Trajectory

    t = np.arange(0.0, 1.6, 1 / 30.0)
    h = np.array([0.32, 0.16, 0.08, 0.04])              # apexes, a flight from the first on
    start, y = -np.sqrt(2 * h[0] / 9.80665), np.zeros(t.size)
    for k, a in enumerate(h):
        half = np.sqrt(2 * a / 9.80665)
        inside = (t >= start) & (t < start + 2 * half)
        y[inside] = a - 0.5 * 9.80665 * (t[inside] - start - half) ** 2
        start += 2 * half
    keep = t < start
    data = Trajectory(t[keep], y[keep] + np.random.default_rng(0).normal(0, 2e-4, int(keep.sum())), "sparse")
    (note,) = [f.text for f in check(data, 0.067).findings if "parabolas of" in f.text]
    assert note.startswith("g from the parabolas of 1 of 4 flights (each alone; the others hold fewer than 7")


def test_an_upside_down_record_names_the_fix(track, tmp_path):
    data, truth = track
    with pytest.raises(DataError, match="looks upside down.*use --y-down"):
        check(dataclasses.replace(data, y_m=-data.y_m), 0.067)
    path = csv(tmp_path / "down.csv", "t,y", (data.t_s, -data.y_m))
    result = run("discover", path, "--ball", truth["ball"], "-q")
    assert result.exit_code == 1 and "upside down" in result.output and "use --y-down" in result.output
    result = run("discover", path, "--ball", truth["ball"], "-q", "--y-down")
    assert result.exit_code == 0, result.output


@pytest.mark.parametrize("header,factor,match", [
    ("t,y", 1e3, r"heights look like mm.*1e\+03 x g"),          # mm under a header that says m (none: m)
    ("t,y (m)", 1e2, r"heights look like cm"),
    ("t,y (mm)", 1.0, r"heights look like m under a header in mm"),
])
def test_heights_in_the_wrong_unit_are_an_error(track, tmp_path, header, factor, match):
    data, truth = track
    path = csv(tmp_path / "u.csv", header, (data.t_s, data.y_m * factor))
    result = run("discover", path, "--ball", truth["ball"], "-q")
    assert result.exit_code == 1, result.output
    assert result.output.count("\n") == 1 and pytest.importorskip("re").search(match, result.output)


@pytest.mark.parametrize("factor,match", [(1e3, r"times look like ms, not s"), (1e-12, r"not in seconds")])
def test_times_in_the_wrong_unit_are_an_error(track, tmp_path, factor, match):
    data, truth = track
    path = csv(tmp_path / "t.csv", "t,y", (data.t_s * factor, data.y_m))
    result = run("discover", path, "--ball", truth["ball"], "-q")
    import re
    assert result.exit_code == 1 and re.search(match, result.output), result.output


def test_heights_in_pixels_get_the_scale_that_makes_the_flights_fall_with_g(track, tmp_path):
    """A video track in pixels under a header without a unit: the error names the --scale that gives g,
    and with it the record is read and fitted."""
    import re

    data, truth = track
    path = csv(tmp_path / "px.csv", "t,y", (data.t_s, np.round(data.y_m / 0.0025, 1)))
    result = run("discover", path, "--ball", truth["ball"], "-q")
    hint = re.search(r"if the heights are pixels, --scale ([0-9.e-]+) \(m per pixel\)", result.output)
    assert result.exit_code == 1 and result.output.count("\n") == 1 and hint, result.output
    assert float(hint.group(1)) == pytest.approx(0.0025, rel=0.05)
    fixed = run("discover", path, "--ball", truth["ball"], "-q", "--scale", hint.group(1))
    assert fixed.exit_code == 0, fixed.output


def test_a_wrong_frame_rate_is_suspect_input_with_a_warning(track, tmp_path):
    """A frame rate 10 % off gives g 20 % off: the fit runs, but the verdict says the input looks off; fitted
    at the g the flights show, epsilon (from ratios of heights) is the one planted."""
    data, truth = track
    path = csv(tmp_path / "fs.csv", "t,y", (data.t_s * 1.1, data.y_m))
    out = tmp_path / "r.json"
    result = run("discover", path, "--ball", truth["ball"], "-q", "--json", out)
    assert result.exit_code == 0, result.output
    assert "vrcal: warning: the flights fall at" in result.output and "Suspect input" in result.output
    # 9.1 % (1 / 1.1); the simulation has no buoyancy, which the ball's g it is judged against has (1.1 %)
    rate = re.search(r"a frame rate ([0-9.]+) % too low \(--fs, the time column\)", result.output)
    assert float(rate[1]) == pytest.approx(9.1, abs=1.2)
    doc = json.loads(out.read_text())
    assert doc["verdict"] == "suspect input"
    assert doc["epsilon"] == pytest.approx(truth["epsilon"], abs=0.002)


# --------------------------------------------------------------------------- impacts


def impacts(n=10, eps=0.85, H=1.0):
    v = np.sqrt(2 * 9.80665 * H)
    return np.sqrt(2 * H / 9.80665) + np.concatenate([[0.0], np.cumsum(2 * eps ** np.arange(1, n) * v / 9.80665)])


@pytest.mark.parametrize("factor,match", [(1e3, "times look like ms, not s"), (1e-12, "not in seconds"),
                                          (1e-3, "look like s under a header in ms")])
def test_impact_times_in_the_wrong_unit_are_an_error(factor, match):
    with pytest.raises(DataError, match=match):
        check_impact_times(impacts() * factor, "f.csv")


def test_growing_intervals_are_an_error(tmp_path):
    t = impacts()
    grown = t[-1] - t[::-1]           # the same list backwards: the intervals grow (epsilon > 1)
    grown = grown[1:] + 0.5
    path = tmp_path / "g.csv"
    path.write_text("t\n" + "\n".join(repr(float(v)) for v in grown) + "\n")
    result = run("discover", path, "--ball", "tennis", "-q")
    assert result.exit_code == 1 and "intervals between impacts grow" in result.output


@pytest.mark.parametrize("times", [np.arange(3.0) - 3.0, np.arange(1000) * 1e-3 + 0.5,
                                   np.arange(50) * 0.2 + np.random.default_rng(0).normal(0, 1e-4, 50)])
def test_equally_spaced_impact_times_are_an_error(tmp_path, times):
    """Intervals that do not shrink mean epsilon = 1: a clock or a sensor's samples, not a ball (the sweep
    found epsilon 0.999 with exit 0 for 't: -3, -2, -1')."""
    with pytest.raises(DataError, match=r"intervals between impacts do not shrink .*epsilon would be 1"):
        check_impact_times(times, "f.csv")
    path = tmp_path / "clock.csv"
    path.write_text("t\n" + "\n".join(repr(float(v)) for v in times) + "\n")
    result = run("discover", path, "--ball", "tennis", "-q")
    assert result.exit_code == 1 and result.output.count("\n") == 1 and "do not shrink" in result.output
    # the bounciest plausible series still passes
    check_impact_times(impacts(eps=0.97), "f.csv")


@pytest.mark.parametrize("header", ["x", "x (m)", "position", "z [mm]"])
def test_a_lone_column_of_positions_is_not_read_as_impact_times(tmp_path, header):
    path = tmp_path / "x.csv"
    path.write_text(f"{header}\n1\n2\n3\n")
    result = run("discover", path, "--ball", "tennis", "-q")
    assert result.output.startswith("vrcal: error: ") and result.output.count("\n") == 1
    if header in ("position", "z [mm]"):   # a sensor's or a 3D tracker's heights without their times: a trajectory
        # that needs --fs ('z' is a trajectory's height column since the probe of class tables: 't (s);z (m)')
        assert result.exit_code == 2 and "--fs" in result.output
    else:
        assert result.exit_code == 1
    forced = run("discover", path, "--ball", "tennis", "-q", "--format", "impacts")
    assert forced.exit_code == 1 and "holds positions, not impact times" in forced.output


def test_a_million_impact_times_end_in_one_line(tmp_path):
    """Many drops in one file: more events than any file of drops holds, refused before any work."""
    from vrcal.measurements.impacts import MAX_IMPACT_EVENTS

    drops = np.concatenate([impacts(n=30) + 6.0 * k for k in range(MAX_IMPACT_EVENTS // 30 + 1)])
    path = tmp_path / "many.csv"
    path.write_text("t\n" + "\n".join(f"{v:.6f}" for v in drops) + "\n")
    result = run("discover", path, "--ball", "tennis", "-q")
    assert result.exit_code == 1 and f"more than the {MAX_IMPACT_EVENTS:,}" in result.output


def test_impact_times_in_ms_under_s_from_the_command_line(tmp_path):
    path = tmp_path / "ms.csv"
    path.write_text("t (s)\n" + "\n".join(repr(float(v) * 1e3) for v in impacts()) + "\n")
    result = run("discover", path, "--ball", "tennis", "-q")
    assert result.exit_code == 1 and "look like ms" in result.output and "Traceback" not in result.output


# --------------------------------------------------------------------------- apexes and drop tables


def test_apexes_in_cm_under_m_are_an_error(tmp_path):
    path = tmp_path / "cm.csv"
    path.write_text("bounce,h (m)\n0,110\n1,80\n2,58\n")
    result = run("discover", path, "--ball", "golf", "--mass", "0.046", "--diameter", "0.043", "-q")
    assert result.exit_code == 1 and "heights look like cm" in result.output


def test_a_rebound_above_the_drop_is_an_error():
    data = ApexHeights(np.array([0, 1, 2]), np.array([1.0, 1.2, 0.9]), "a.csv", lines=np.array([2, 3, 4]))
    with pytest.raises(DataError, match=r"rebound \(line 3\), 1.2 m, is higher than the drop"):
        check(data, 0.04)


def test_a_later_apex_that_rises_ends_the_record_with_a_note():
    data = ApexHeights(np.arange(5), np.array([1.0, 0.7, 0.5, 0.52, 0.3]), "a.csv", lines=np.arange(2, 7))
    checked = check(data, 0.04)
    assert list(checked.data.h_m) == [1.0, 0.7, 0.5]
    assert any("apex 3 (line 5) is higher" in n for n in checked.notes)


def test_drop_table_rows_with_a_rebound_above_the_drop():
    rows = [(0.5, 0.4), (1.0, 1.2), (1.5, 1.2), (2.0, 1.6)]
    runs = Runs(tuple(ApexHeights(np.array([0, 1]), np.array(r), "t.csv") for r in rows), "t.csv",
                labels=tuple(f"row {i + 1}" for i in range(4)))
    checked = check(runs, 0.04)
    assert len(checked.data.runs) == 3 and checked.warnings == (
        "1 of 4 trials left out: a rebound higher than its drop is impossible for a ball (a misread or swapped "
        "entry? read at the ball's top: --rebound-measured-to top): row 2 1.2 m from 1 m",)
    swapped = Runs(tuple(ApexHeights(np.array([0, 1]), np.array(r[::-1]), "t.csv") for r in rows), "t.csv",
                   labels=runs.labels)
    with pytest.raises(DataError, match="columns swapped"):
        check(swapped, 0.04)


def test_a_rebound_as_high_as_its_drop_is_left_out_with_a_warning():
    """A rebound written equal to its drop (epsilon 1: the drop height typed twice) was fitted, and the
    table came out 'unexplained'."""
    rows = [(0.5, 0.4), (1.0, 1.0), (1.5, 1.2), (2.0, 1.6)]
    runs = Runs(tuple(ApexHeights(np.array([0, 1]), np.array(r), "t.csv") for r in rows), "t.csv",
                labels=tuple(f"row {i + 1}" for i in range(4)))
    checked = check(runs, 0.04)
    assert len(checked.data.runs) == 3
    assert checked.warnings == ("1 of 4 trials left out: a rebound as high as its drop or higher (epsilon >= 1) is "
                                "impossible for a ball (a misread or swapped entry? read at the ball's top: "
                                "--rebound-measured-to top): row 2 1 m from 1 m",)


def test_a_drop_table_with_rebounds_above_their_drop_is_suspect_input_naming_their_lines(tmp_path):
    """Three 30 cm trials rebounding above 30 cm were left out quietly (verdict 'explained')."""
    path = tmp_path / "t.csv"
    path.write_text("trial,H (cm),h (cm)\n1,100,72\n2,100,73\n1,50,37\n2,50,36\n1,30,35\n2,30,36\n3,30,22\n")
    out = tmp_path / "r.json"
    result = run("discover", path, "--ball", "table_tennis", "-q", "--json", out)
    assert result.exit_code == 0, result.output
    doc = json.loads(out.read_text())
    assert doc["verdict"] == "suspect input"
    assert [w for w in doc["warnings"] if "2 of 7 trials left out" in w and "row 5 (line 6) 0.35 m from 0.3 m; "
            "row 6 (line 7) 0.36 m from 0.3 m" in w]
    assert "vrcal: warning: 2 of 7 trials left out" in result.output


@pytest.mark.parametrize("option,said", [("--drop-measured-to", "the drop of line 2: -1.7 cm"),
                                         ("--rebound-measured-to", "the rebound of line 2: -4.7 cm")])
def test_heights_below_the_balls_size_measured_to_its_top_are_named_not_swapped_columns(tmp_path, option, said):
    """Drops of 5-10 cm 'measured to the top' of a 6.7 cm tennis ball were blamed on swapped columns (the
    drop -1.7 cm below the floor once brought to the ball's bottom, the rebound above it)."""
    path = tmp_path / "tiny.csv"
    path.write_text("H (cm),h (cm)\n5,2.0\n5,2.1\n10,5.5\n")
    result = run("discover", path, "--ball", "tennis", option, "top", "-q")
    assert result.exit_code == 1 and "swapped" not in result.output
    assert f"heights lie at or below the floor once brought to the ball's bottom ({said})" in result.output
    assert "a height measured to the ball's top cannot be less than its diameter (6.7 cm)" in result.output
    assert run("discover", path, "--ball", "tennis", "-q").exit_code == 0


def test_one_drops_apexes_below_the_floor_are_an_error():
    data = ApexHeights(np.array([0, 1, 2]), np.array([0.3, -0.01, -0.02]), "a.csv", lines=np.array([2, 3, 4]))
    with pytest.raises(DataError, match=r"2 of 3 heights lie at or below the floor .*the rebound of line 3: -1 cm"):
        check(data, 0.04)


def test_a_drop_smaller_than_the_ball_is_suspect(tmp_path):
    path = tmp_path / "tiny.csv"
    path.write_text("bounce,h (cm)\n0,1.1\n1,0.8\n2,0.6\n3,0.45\n")
    out = tmp_path / "r.json"
    result = run("discover", path, "--ball", "golf", "--mass", "0.046", "--diameter", "0.043", "-q", "--json", out)
    assert result.exit_code == 0 and "less than half the ball's diameter" in result.output
    assert json.loads(out.read_text())["verdict"] == "suspect input"


def test_plausible_records_of_every_kind_pass_unchanged():
    for kind in ("trajectory", "impacts", "apexes"):
        data, truth = hidden_effect_case(4, kind, ())
        checked = check(data, float(ball(truth).diameter_m))
        assert checked.warnings == () and checked.data is data
        assert discover(data, ball(truth)).verdict == "explained"


def test_impact_times_object_checks_every_chain():
    t = impacts()
    data = ImpactTimes(np.concatenate([t, t[-1] + 1000 * (t - t[0] + 1)]), "x.csv",
                       chains=((0, 10), (10, 20)))
    with pytest.raises(DataError):
        check(data, 0.05)


# --------------------------------------------------------------------------- light balls


@pytest.fixture(scope="module")
def balloon():
    """A 2 g, 100 mm balloon (rho V / m = 0.315) dropped from 1.5 m, eps 0.7, drag and buoyancy planted
    (vrcal's own simulator), tracked at 60 frames/s with 2 mm noise and a resting tail, as a trajectory
    read from a file (release found by the reader); and what vrcal expects of its flights."""
    from vrcal.drop.effects import flight_expectation
    from vrcal.drop.simulate import sample_measurement, simulate_drops

    ball = BallProperties(0.002, 0.1, "balloon")
    drops = simulate_drops(1.5, 0.7, 8, ball, release_time_s=0.5,
                           effects={"air_drag": {"drag_coefficient": 0.47},
                                    "buoyancy": {"air_density_kg_per_m3": 1.204}})
    cols = sample_measurement(drops, "trajectory", fs_hz=60, noise_m=0.002, rng=3)
    t = np.concatenate([cols["t"], cols["t"][-1] + np.arange(1, 19) / 60])
    y = np.concatenate([cols["y"], np.random.default_rng(4).normal(0.0, 0.002, 18)]) + 0.05
    g_eff, ks = flight_expectation(0.002, 0.1, 9.80665)
    return t, y, {"g_expected_m_per_s2": g_eff, "drag_per_m": ks}


def read_track(tmp_path, t, y, name="b.csv"):
    from vrcal.measurements import read_measurement

    return read_measurement(str(csv(tmp_path / name, "t,y", (t, y))))


def test_a_balloons_flights_are_judged_by_its_own_buoyancy_and_drag(balloon, tmp_path):
    """Its flights fall with 0.59 g and are no parabolas: judged against bare g and parabolas nothing
    could be said (the probe's record was even called upside down); against its own physics g is found."""
    t, y, flights = balloon
    data = read_track(tmp_path, t, y)
    assert check(data, 0.1, sigma_m=0.002).warnings == ()
    found = check(data, 0.1, sigma_m=0.002, **flights)
    assert found.warnings == () and "with this ball's air drag" in found.notes[0]
    g = float(found.notes[0].split("1/m): ")[1].split(" m/s^2")[0])
    assert g == pytest.approx(flights["g_expected_m_per_s2"], rel=0.05)


@pytest.mark.parametrize("t_factor,y_factor,match", [
    (1.0, 100.0, "heights look like cm"),
    (1.0, 1000.0, "heights look like mm"),
    (2.0, 1.0, "not in the units read"),                 # a frame rate half the true one
    (1.0, -1.0, "upside down .*falls upward.*use --y-down"),
])
def test_a_light_balls_record_in_the_wrong_unit_is_still_caught(balloon, tmp_path, t_factor, y_factor, match):
    t, y, flights = balloon
    data = read_track(tmp_path, t * t_factor, y * y_factor)
    with pytest.raises(DataError, match=match):
        check(data, 0.1, sigma_m=0.002, **flights)


def test_a_record_that_starts_at_a_bounce_or_inside_one_flight_is_not_upside_down():
    """A track that starts falling into a bounce: from its first sample the ball moves down, then up with
    its V curving upward, which read as a release falling upward ('upside down' for a light ball); turned
    over, a track cut inside one flight has its top as a bounce between two clean 'flights' and won on them.
    Neither is a fall from a release or a bounce; turned over for real, a record still is."""
    from vrcal.measurements.plausibility import release_fall_sign

    g, t = 9.80665, np.arange(0.0, 0.8, 1 / 30.0)
    noise = np.random.default_rng(0).normal(0.0, 2e-4, t.size)
    # 30 fps: 3.65 m/s into a bounce 0.02 s after the first sample, out at 3.1 m/s
    y = np.abs(np.where(t < 0.02, 3.65 * (0.02 - t), 3.1 * (t - 0.02) - 0.5 * g * (t - 0.02) ** 2)) + noise
    assert y[1] < y[0] < y[2] and release_fall_sign(t, y) == 0
    # another, cut before the next bounce and after this one: one flight
    y = np.abs(np.where(t < 0.06, 0.2 - 3.0 * t - 0.5 * g * t ** 2, 3.0 * (t - 0.06) - 0.5 * g * (t - 0.06) ** 2))
    inside = slice(2, int(np.sum(t < 0.55)))
    assert flight_gravity(t[inside], (y + noise)[inside], 0, 2e-4)[1:] == (False, 1)
    assert flight_gravity(t[inside], -(y + noise)[inside], 0, 2e-4)[1] is True
    data, _ = hidden_effect_case(3, "trajectory", ())
    assert release_fall_sign(data.t_s, -data.y_m, data.release_index) == -1


def test_a_light_ball_tracked_on_video_is_fitted_not_refused(balloon, tmp_path):
    """End to end: discover finds the balloon's planted eps 0.7 and names no suspect input."""
    t, y, _ = balloon
    path = csv(tmp_path / "balloon.csv", "t,y", (t, y))
    out = tmp_path / "r.json"
    result = run("discover", path, "--mass", 0.002, "--diameter", 0.1, "-q", "--json", out)
    assert result.exit_code == 0, result.output
    doc = json.loads(out.read_text())
    assert doc["verdict"] != "suspect input" and doc["epsilon"] == pytest.approx(0.7, abs=0.01)


def _tossed_track(flip, seed=0, fs_hz=240.0, noise_m=5e-4, epsilon=0.905):
    """A table-tennis ball simulated by vrcal (air drag) from the top of a toss at 0.30 m, with the toss in
    front: held 0.1 s at 0.18 m, thrown up by the hand (0.06 s at constant acceleration to 1.2 m/s) and rising
    freely to its top, where the simulated drop starts from rest. ``flip``: written with y pointing down."""
    from vrcal.drop.simulate import sample_measurement, simulate_drops

    g, v0, hand_s, top_m = 9.80665, 1.2, 0.06, 0.30
    rise_s, release_s = v0 / g, 0.1 + hand_s + v0 / g
    level = top_m - v0 ** 2 / (2 * g) - 0.5 * v0 * hand_s
    drops = simulate_drops(top_m, epsilon, 10, BallProperties.from_ball(get_ball("table_tennis")),
                           release_time_s=release_s, effects={"air_drag": {"drag_coefficient": 0.47}})
    cols = sample_measurement(drops, "trajectory", fs_hz=fs_hz, noise_m=0.0, rng=seed)
    t, y = np.asarray(cols["t"], dtype=float), np.asarray(cols["y"], dtype=float)
    s = t - 0.1                         # time since the throw began
    hand = level + 0.5 * (v0 / hand_s) * s ** 2
    free = top_m - 0.5 * g * (release_s - t) ** 2
    y = np.where(t < release_s, np.where(s <= 0, level, np.where(s < hand_s, hand, free)), y)
    assert release_s - hand_s - rise_s == pytest.approx(0.1) and np.max(y) == pytest.approx(top_m, abs=1e-3)
    y = y + np.random.default_rng(seed).normal(0.0, noise_m, y.size)
    return t, (-y if flip else y)


@pytest.mark.parametrize("flip", [False, True])
@pytest.mark.parametrize("seed", [0, 1])
def test_a_ball_tossed_up_before_it_falls_is_not_upside_down(tmp_path, flip, seed):
    """A ball held, tossed up and let fall (the probe's simulated table-tennis record with a toss in front)
    was 'upside down (the ball falls upward from its release)': thrown, it accelerates upward in the hand as a
    record turned over falls. With --y-down it was fitted with epsilon 0.999 for 0.905 (unexplained). The toss
    is a flight: its top is found (the record comes back past where the hand held it, which no bounce does),
    the fit starts there (a drop from rest), and either orientation is read right."""
    t, y = _tossed_track(flip, seed)
    path = csv(tmp_path / "tossed.csv", "t,y", (t, y))
    out = tmp_path / "r.json"
    result = run("discover", path, "--ball", "table_tennis", "-q", "--json", out, *(["--y-down"] if flip else []))
    assert result.exit_code == 0, result.output
    doc = json.loads(out.read_text())
    assert "tossed up" in result.output and doc["verdict"] == "explained"
    assert abs(doc["epsilon"] - 0.905) < 3 * doc["epsilon_uncertainty"]
    # told the wrong orientation, it still says so
    wrong = run("discover", path, "--ball", "table_tennis", "-q", *([] if flip else ["--y-down"]))
    assert wrong.exit_code == 1 and "upside down" in wrong.output
    assert ("use --y-down" if flip else "remove --y-down") in wrong.output


def test_the_toss_tells_the_orientation_of_a_release_that_accelerates_upward():
    """release_fall_sign of a tossed record: its first motion (up, accelerating in the hand) is what a
    turned-over drop shows; that it comes back past its start makes it a toss, upward."""
    from vrcal.measurements.cleanup import detect_release_index, toss_top_index
    from vrcal.measurements.plausibility import release_fall_sign

    t, y = _tossed_track(False)
    r = detect_release_index(y)
    assert r > 0 and y[toss_top_index(t, y, r)] == pytest.approx(0.30, abs=0.002)
    assert release_fall_sign(t, y, r) == 1 and release_fall_sign(t, -y, r) == -1
    data, _ = hidden_effect_case(3, "trajectory", ())     # a drop: no toss
    assert toss_top_index(data.t_s, data.y_m, data.release_index) is None


@pytest.mark.parametrize("k", [2.0, 8.0, 4.8])
def test_a_slow_motion_clock_is_named_with_its_rates_and_what_fits_it(track, tmp_path, k):
    """A slow-motion clip's track written at its playback rate: every time recorded/written times too long,
    g (recorded/written)^2 times too small. The error said only 'not in the units read (check --fs, ...)',
    which a file with a time column cannot take; it names the factor, both rates, and the --g that fits the
    record as it is (with which epsilon is the one planted)."""
    data, truth = track
    path = csv(tmp_path / "slow.csv", "t,y", (data.t_s * k, data.y_m))
    result = run("discover", path, "--ball", truth["ball"], "-q")
    assert result.exit_code == 1
    said = re.search(r"if the lengths are right, the times are ([0-9.]+) times too long \(recorded at (\d+) fps, "
                     r"written at (\d+): a slow-motion clip at its playback rate\?\): divide the time column by "
                     r"[0-9.]+ \(--fs (\d+) where the times come from --fs\), or give --g ([0-9.]+) to fit the record "
                     r"as it is", result.output)
    assert said, result.output
    assert float(said[1]) == pytest.approx(k, rel=0.02)
    fs = 1.0 / float(np.median(np.diff(data.t_s)))        # the fixture's own rate, written k times slower
    assert (int(said[2]), int(said[3])) == (round(fs), round(fs / k))
    assert int(said[4]) == int(said[2])
    fitted = run("discover", path, "--ball", truth["ball"], "-q", "--g", said[5], "--json", tmp_path / "r.json")
    assert fitted.exit_code == 0
    assert json.loads((tmp_path / "r.json").read_text())["epsilon"] == pytest.approx(truth["epsilon"], abs=0.002)


def test_standard_frame_rates_are_the_nearest_within_four_per_cent():
    from vrcal.measurements.plausibility import standard_frame_rate

    assert standard_frame_rate(246.0) == 240.0
    assert standard_frame_rate(29.97) == 30.0
    assert standard_frame_rate(59.94) == 60.0
    assert standard_frame_rate(75.0) is None
    assert standard_frame_rate(float("nan")) is None
