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
