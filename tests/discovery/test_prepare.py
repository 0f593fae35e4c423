"""Preparing a record for the fit (vrcal.discovery.prepare): decimation of long trajectories (issue 10,
"big honest inputs") and the odd-bounce test that leaves bounces low against the noise alone."""

import numpy as np
import pytest

from vrcal.discovery import prepare as prep
from vrcal.discovery.ranking import discover
from vrcal.drop.simulate import sample_measurement, simulate_drops
from vrcal.drop.synthetic import hidden_effect_case
from vrcal.measurements import Trajectory
from vrcal.model.body import BallProperties
from vrcal.model.standards import get_ball

TENNIS = BallProperties.from_ball(get_ball("tennis"))


def test_decimation_factor():
    assert prep.decimation_factor(1000, 1e-3, max_samples=2000) == 1
    assert prep.decimation_factor(10_001, 1e-4, max_samples=1000) == 11
    # never below MIN_FIT_RATE_HZ: a 100 Hz record is thinned to 60 Hz at most (k = 1)
    assert prep.decimation_factor(10**6, 0.01, max_samples=1000) == 1


def test_decimate_keeps_lines_and_release():
    t = np.arange(100) * 0.001
    data = Trajectory(t, 1.0 - t, "x", release_index=7, lines=np.arange(100) + 2)
    thin = prep.decimate(data, 3)
    assert list(thin.t_s[:3]) == [0.0, 0.003, 0.006]
    assert list(thin.lines[:3]) == [2, 5, 8]
    assert thin.release_index == 3          # the first kept sample at or after sample 7 (sample 9)


@pytest.mark.parametrize("planted", [(), ("air_drag",)])
def test_decimation_keeps_the_answer_of_a_planted_case(planted, monkeypatch):
    """The same record fitted whole and every 4th sample: the same named effects, the same epsilon
    (within the uncertainties), and a note saying what was fitted; the noise is measured on every sample."""
    data, truth = hidden_effect_case(3, "trajectory", planted, ball="tennis", fs_hz=1000.0)
    n = len(data.t_s)
    whole = discover(data, TENNIS)
    monkeypatch.setattr(prep, "MAX_FIT_SAMPLES", -(-n // 4))
    thin = discover(data, TENNIS)
    assert thin.decimation == 4 and thin.n_read == n and thin.baseline.n == -(-n // 4)
    assert whole.decimation == 1 and not any("decimated" in note for note in whole.notes)
    assert any(f"every 4th sample is fitted ({thin.baseline.n:,} of {n:,}" in note for note in thin.notes)
    assert whole.effects == thin.effects == list(planted)
    err = np.hypot(whole.final.uncertainty("epsilon"), thin.final.uncertainty("epsilon"))
    assert abs(whole.epsilon - thin.epsilon) < 4 * err
    assert thin.epsilon == pytest.approx(truth["epsilon"], abs=0.01)
    # the noise floor is the same sample noise either way, measured on every sample when decimated
    assert thin.noise_floor == pytest.approx(whole.noise_floor, rel=0.05)
    assert thin.noise_source.startswith("third differences of all samples")
    assert thin.as_dict()["data"]["decimation"] == 4


def test_low_last_bounces_are_not_called_odd():
    """30 bounces with 2 mm noise: the last ones rise a few noise sigmas; none is called odd
    (missed, a kick, off the floor), whatever the sampling rate."""
    drops = simulate_drops(1.0, 0.85, 30, TENNIS)
    for fs, seed in ((240.0, 3), (3500.0, 3), (10_000.0, 1)):
        cols = sample_measurement(drops, "trajectory", fs_hz=fs, noise_m=0.002, rng=seed)
        p = prep.prepare(Trajectory(cols["t"], cols["y"], "low"), TENNIS, 9.80665)
        assert not [n for n in p.notes if "left out" in n], (fs, p.notes)


def test_more_runs_than_a_joint_fit_takes_is_one_error(monkeypatch):
    """Chains of impacts (drops) beyond MAX_RUNS: a one-line error naming the limit, not a fit that
    grows as the cube of the runs."""
    from vrcal.errors import DataError
    from vrcal.measurements.impacts import impact_times_from_events

    v = np.sqrt(2 * 9.80665)
    one = np.sqrt(2 / 9.80665) + np.concatenate([[0.0], np.cumsum(2 * 0.85 ** np.arange(1, 12) * v / 9.80665)])
    data = impact_times_from_events("drops.csv", np.concatenate([one + 6.0 * k for k in range(4)]))
    assert len(data.chains) == 4
    monkeypatch.setattr(prep, "MAX_RUNS", 3)
    with pytest.raises(DataError, match=r"drops.csv: 4 chains of consecutive bounces \(drops\) to fit jointly, "
                                        r"more than 3"):
        prep.prepare(data, TENNIS, 9.80665)


# --------------------------------------------------------------------------- heights to the bottom


@pytest.mark.parametrize("drop_to, rebound_to, shift", [
    ("bottom", "top", (0.0, 0.067)), ("top", "top", (0.067, 0.067)), ("centre", "bottom", (0.0335, 0.0)),
])
def test_heights_measured_to_another_point_are_brought_to_the_bottom(drop_to, rebound_to, shift):
    from vrcal.measurements import ApexHeights, Runs

    row = ApexHeights(bounce=np.array([0, 1]), h_m=np.array([1.0, 0.6]), source="row")
    table = Runs(runs=(row, row), source="table", labels=("row 1", "row 2"))
    moved = prep.heights_to_bottom(table, 0.067, drop_to, rebound_to)
    for run in moved.runs:
        np.testing.assert_allclose(run.h_m, [1.0 - shift[0], 0.6 - shift[1]])
    assert "brought to its bottom" in moved.notes[-1]
    one = prep.heights_to_bottom(row, 0.067, drop_to, rebound_to)     # one drop's apexes: the same
    np.testing.assert_allclose(one.h_m, moved.runs[0].h_m)
    assert prep.heights_to_bottom(table, 0.067) is table


def test_heights_to_the_bottom_refuse_other_data():
    from vrcal.errors import UsageError
    from vrcal.measurements import ImpactTimes

    with pytest.raises(UsageError, match="apply to heights"):
        prep.heights_to_bottom(ImpactTimes(np.array([0.3, 0.9, 1.4]), "t"), 0.067, "bottom", "top")


def test_a_table_of_rebounds_read_at_the_balls_top_gives_the_planted_epsilon(tmp_path):
    """A class reads each rebound at the top of a tennis ball against the ruler (one diameter, 67 mm,
    more than the bottom the model's heights are): as read, epsilon comes out high; told so, it is the
    planted one (an independent probe's table had a speed law p = 0.28 named on a constant epsilon)."""
    from click.testing import CliRunner

    from vrcal.cli import main
    from vrcal.drop.synthetic import drop_table_case

    runs, truth = drop_table_case(3, (), ball="tennis", n_heights=5, trials=3, noise=0.002)
    D = 0.067
    path = tmp_path / "top.csv"
    path.write_text("H (m),h (m)\n" + "".join(f"{r.h_m[0]:.4f},{r.h_m[1] + D:.4f}\n" for r in runs.runs))
    ball = ["--ball", "tennis", "--mass", "0.057", "--diameter", str(D), "-q", "--json"]
    told = CliRunner().invoke(main, ["discover", str(path), *ball, str(tmp_path / "told.json"),
                                     "--rebound-measured-to", "top"])
    assert told.exit_code == 0, told.output
    assert "heights measured to the ball's bottom (drops) and top (rebounds, -67.0 mm)" in " ".join(
        told.output.split())
    import json

    doc = json.loads((tmp_path / "told.json").read_text())
    assert abs(doc["epsilon"] - truth["epsilon"]) < max(3 * doc["epsilon_uncertainty"], 0.005), doc["epsilon"]
    assert doc["reader"]["rebound_measured_to"] == "top"
    assert all(c["name"] != "height_offset" for c in doc["candidates"])     # the point is given: no offset
    as_read = CliRunner().invoke(main, ["discover", str(path), *ball, str(tmp_path / "read.json")])
    wrong = json.loads((tmp_path / "read.json").read_text())
    assert wrong["epsilon"] > truth["epsilon"] + 0.01 or wrong["effects"], wrong["epsilon"]
    assert as_read.exit_code == 0
    assert any(c["name"] == "height_offset" for c in wrong["candidates"])   # not stated: an offset is tried


def test_rebounds_a_ball_cannot_reach_through_air_are_suspect_input():
    """Heights in inches with no unit in the header are read as metres: drops of 20-40 m, from which
    air drag keeps any ball far lower than these rebounds; the verdict was 'explained' with impact
    speeds of 20-28 m/s (an independent probe's table)."""
    from vrcal.measurements import ApexHeights, Runs
    from vrcal.model.standards import get_ball

    tennis = BallProperties.from_ball(get_ball("tennis"))
    rows = [(40.0, 29.0), (40.0, 28.5), (20.0, 15.0), (0.5, 0.37)]
    runs = tuple(ApexHeights(np.array([0, 1]), np.array(r), "t.csv") for r in rows)
    warnings = prep.rebounds_beyond_drag(runs, tennis)
    assert len(warnings) == 1 and warnings[0].startswith("2 of 4 drops rebound higher than air lets") and \
        "'H (in)'" in warnings[0]
    d = discover(Runs(runs, "t.csv", labels=("1", "2", "3", "4")), tennis)
    assert d.verdict == "suspect input"
    # the numbers as read fit to their noise: the report says so, not that something is left unexplained
    from vrcal.discovery.report import fit_report

    text = " ".join(fit_report(d).split())
    assert d.reproduces and "explains this record" in text and "The baseline suffices" in text
    assert "no effect of the registry explains it" not in text and "does not reproduce the record" not in text
    real = read_measurement_of("examples/data/drop-table.csv")
    assert prep.rebounds_beyond_drag(real.runs, BallProperties.from_ball(get_ball("table_tennis"))) == []


def test_a_ball_cannot_fall_faster_than_air_lets_it_and_the_unit_not_the_ball_is_blamed():
    """Pixels read as metres: a ping-pong ball's track whose flights no parabola fits (a 10 fps phone record)
    was fitted with a 100 m drop and 44 m/s impacts ("epsilon = 1 ± 71"). No ball falls, on average, faster
    than its terminal speed (9 m/s for it): the record is suspect input, naming the unit as the likely cause;
    and where the unit is suspected, the ball's mass and diameter are not blamed for what drag fails to fit."""
    from vrcal.measurements import ApexHeights, Runs

    ball = BallProperties.from_ball(get_ball("table_tennis"))
    drops = simulate_drops(0.35, 0.88, 6, ball, release_time_s=0.3, effects={"air_drag": {"drag_coefficient": 0.47}})
    cols = sample_measurement(drops, "trajectory", fs_hz=240.0, noise_m=3e-4, rng=1)
    t, y = np.asarray(cols["t"], float), np.asarray(cols["y"], float)
    assert prep.falls_faster_than_air_lets([Trajectory(t, y, "m.csv")], ball) == []
    for factor in (500.0, 1000.0):    # pixels at 2 mm each; millimetres
        warnings = prep.falls_faster_than_air_lets([Trajectory(t, y * factor, "px.csv")], ball)
        assert len(warnings) == 1 and "1 of 1 runs fall faster than air lets this ball" in warnings[0]
        assert "terminal speed of 8.6 m/s" in warnings[0] and "give --scale M_PER_PX" in warnings[0]
    # a drop table's heights in a unit not written (bricks): the unit, not the ball, is what to check
    from vrcal.discovery.report import fit_report

    tennis = BallProperties.from_ball(get_ball("tennis"))
    rows = [(H, 0.79 * H + dh) for H in (10.0, 12.0, 14.0, 16.0, 18.0, 20.0) for dh in (-0.25, 0.0, 0.25)]
    runs = tuple(ApexHeights(np.array([0, 1]), np.array(r), "b.csv") for r in rows)
    d = discover(Runs(runs, "b.csv", labels=tuple(str(i) for i in range(len(rows)))), tennis)
    text = " ".join(fit_report(d).split())
    assert d.verdict == "suspect input" and "are the heights in metres?" in text
    assert "excluded by these apex heights" in text and "check the heights' unit first" in text
    assert "mass and diameter" not in text


def read_measurement_of(relpath):
    from helpers import ROOT

    from vrcal.measurements import read_measurement

    return read_measurement(str(ROOT / relpath))


@pytest.mark.parametrize("distortion", [1.0, -1.0])
def test_a_flight_bent_by_a_scale_that_changes_across_the_picture_names_the_scale(distortion):
    """A lens's distortion: the length scale changes with the height in the picture (planted: heights
    scaled by 1 + a (y - 0.1 m)), so the high first fall bends otherwise than the low flights and is cut;
    the reason names the scale beside a hand at release, with the spread of the flights' apparent g."""
    ball = BallProperties(0.0054, 0.016, "marble")
    drops = simulate_drops(0.19, 0.7, 5, ball, release_time_s=0.1)
    cols = sample_measurement(drops, "trajectory", fs_hz=200.0, noise_m=2e-5, rng=0)
    y = cols["y"] * (1.0 + distortion * (cols["y"] - 0.1))
    d = discover(Trajectory(t_s=cols["t"], y_m=y, source="lens"), ball)
    cut = [n for n in d.all_notes if "no free flight" in n]
    assert cut and all("the length scale changes across the picture (a lens's distortion, perspective" in n
                       for n in cut)
    assert all("the flights' g ranges" in n for n in cut)
    # an undistorted record of the same drop cuts nothing
    clean = discover(Trajectory(t_s=cols["t"], y_m=cols["y"], source="clean"), ball)
    assert not [n for n in clean.all_notes if "no free flight" in n]
