"""The hidden-effect generator: repeatable, realistic noise, material and plausible effects."""

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vrcal.drop.effects import EFFECTS
from vrcal.drop.synthetic import JITTER_S, hidden_effect_case, measurement_csv, noise_free_measurement
from vrcal.errors import UsageError
from vrcal.measurements import ApexHeights, ImpactTimes, Trajectory, read_measurement
from vrcal.model.body import BallProperties
from vrcal.model.standards import get_ball

TYPES = {"trajectory": Trajectory, "impacts": ImpactTimes, "apexes": ApexHeights}


VALUES = {"trajectory": "y_m", "impacts": "t_s", "apexes": "h_m"}


def _residual(measurement, truth):
    """Data minus the noise-free observations of the case, simulated again from the truth alone
    (vrcal.drop.synthetic.noise_free_measurement)."""
    clean = noise_free_measurement(measurement, truth)
    assert type(clean) is type(measurement) and clean.source == measurement.source
    field = VALUES[measurement.kind]
    return getattr(measurement, field) - getattr(clean, field)


CASES = [(kind, effects) for kind in TYPES
         for effects in [()] + [(n,) for n in EFFECTS if kind in EFFECTS[n].kinds]]


@pytest.mark.parametrize("kind, effects", CASES)
def test_case_is_the_readers_type_and_the_truth_explains_it(kind, effects):
    m, truth = hidden_effect_case(11, kind, effects)
    assert isinstance(m, TYPES[kind]) and m.kind == kind
    assert set(truth["effects"]) == set(effects)
    assert truth["ball"] in ("basketball", "volleyball", "football", "tennis", "table_tennis")
    r = _residual(m, truth)
    # the truth leaves only the noise: chi2 / N near 1
    chi2 = np.mean((r / truth["noise"]) ** 2)
    assert 0.5 < chi2 < 1.8, chi2
    for name, params in truth["effects"].items():
        assert truth["signal_sigma"][name] >= 10.0
        for p in EFFECTS[name].parameters:
            lo, hi = p.prior
            assert lo <= params[p.name] <= hi, (name, params)


def test_noise_levels_follow_the_measurement_model():
    m, truth = hidden_effect_case(3, "trajectory", ("air_drag",), ball="table_tennis")
    assert truth["noise"] == 0.001 and truth["fs_hz"] == 240.0
    assert np.std(_residual(m, truth)) == pytest.approx(0.001, rel=0.15)
    _, truth = hidden_effect_case(3, "trajectory", ("air_drag",), ball="basketball")
    assert truth["noise"] == 0.002
    m, truth = hidden_effect_case(3, "impacts", ("air_drag",))
    assert truth["noise"] == JITTER_S


def test_trajectory_has_a_still_segment_and_a_random_phase():
    m, truth = hidden_effect_case(5, "trajectory", ("height_offset",))
    assert m.t_s[0] == 0.0
    assert np.allclose(np.diff(m.t_s), 1 / 240.0)
    i = m.release_index
    assert m.t_s[i - 1] <= truth["release_time_s"] < m.t_s[i]
    still = m.y_m[:i]
    assert truth["still_s"] >= 0.1 and i > 20
    offset = truth["effects"]["height_offset"]["offset_m"]
    assert np.mean(still) == pytest.approx(truth["drop_height_m"] + offset, abs=4 * truth["noise"] / np.sqrt(i))
    phases = {round(hidden_effect_case(s, "trajectory", ())[1]["release_time_s"] * 240 % 1, 3) for s in range(6)}
    assert len(phases) > 3


def test_same_seed_same_case_other_seed_other_case():
    a, ta = hidden_effect_case(42, "impacts", ("velocity_dependent_restitution",))
    b, tb = hidden_effect_case(42, "impacts", ("velocity_dependent_restitution",))
    c, _ = hidden_effect_case(43, "impacts", ("velocity_dependent_restitution",))
    np.testing.assert_array_equal(a.t_s, b.t_s)
    assert ta == tb
    assert a.t_s.shape != c.t_s.shape or not np.array_equal(a.t_s, c.t_s)


@pytest.mark.parametrize("kind", sorted(TYPES))
def test_two_hidden_effects(kind):
    names = [n for n in EFFECTS if kind in EFFECTS[n].kinds]
    for seed, pair in enumerate(itertools.islice(itertools.combinations(names, 2), 3)):
        m, truth = hidden_effect_case(seed, kind, pair)
        assert set(truth["effects"]) == set(pair)
        assert min(truth["signal_sigma"].values()) >= 10.0


def test_round_trip_through_the_readers(tmp_path):
    for kind in TYPES:
        m, _ = hidden_effect_case(1, kind, ())
        path = tmp_path / f"{kind}.csv"
        path.write_text(measurement_csv(m))
        back = read_measurement(str(path))
        assert back.kind == kind
        if kind == "apexes":
            np.testing.assert_allclose(back.h_m, m.h_m, rtol=1e-9)
        else:
            np.testing.assert_allclose(back.t_s, m.t_s, rtol=1e-9)


def test_weak_effects_are_not_planted():
    # a 0.8-3 ms contact of a table-tennis ball is swallowed by epsilon in impact times
    with pytest.raises(UsageError, match="could not plant contact_duration"):
        hidden_effect_case(1, "impacts", ("contact_duration",), ball="table_tennis", max_tries=3)
    # a lower bar lets it through, and the signal is reported honestly
    _, truth = hidden_effect_case(1, "trajectory", ("contact_duration",), ball="table_tennis", min_signal_sigma=1)
    assert truth["signal_sigma"]["contact_duration"] >= 1


@pytest.mark.parametrize("kind, effects, message", [
    ("impacts", ("buoyancy",), "cannot be seen in impacts"),
    ("apexes", ("contact_duration",), "cannot be seen in apexes"),
    ("video", (), "unknown kind"),
    ("trajectory", ("spin",), "unknown effect"),
    ("trajectory", ("air_drag", "air_drag"), "two different effects"),
])
def test_bad_requests(kind, effects, message):
    with pytest.raises(UsageError, match=message):
        hidden_effect_case(0, kind, effects)


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 10_000), kind=st.sampled_from(sorted(TYPES)))
def test_any_seed_gives_a_material_case(seed, kind):
    names = [n for n in EFFECTS if kind in EFFECTS[n].kinds]
    name = names[seed % len(names)]
    m, truth = hidden_effect_case(seed, kind, (name,))
    assert truth["signal_sigma"][name] >= 10.0
    assert truth["n_bounces"] >= 3
    values = m.y_m if kind == "trajectory" else (m.t_s if kind == "impacts" else m.h_m)
    assert np.all(np.isfinite(values))


@pytest.mark.parametrize("kind, effect", [("trajectory", "buoyancy"), ("impacts", "air_drag"),
                                          ("apexes", "height_offset")])
def test_planted_effect_stands_out_of_the_noise(kind, effect):
    # with the noise on, the best baseline fit is still far worse than the truth: Delta chi2 >> 0
    from vrcal.drop.synthetic import baseline_misfit_sigma

    m, truth = hidden_effect_case(21, kind, (effect,))
    props = BallProperties.from_ball(get_ball(truth["ball"]))
    values = m.y_m if kind == "trajectory" else (m.t_s if kind == "impacts" else m.h_m)
    base = baseline_misfit_sigma(kind, values, truth["noise"], truth["n_bounces"], props,
                                 t_s=getattr(m, "t_s", None) if kind == "trajectory" else None,
                                 start=(truth["drop_height_m"], truth["epsilon"], truth["release_time_s"]))
    chi2_truth = np.sum((_residual(m, truth) / truth["noise"]) ** 2)
    assert base ** 2 - chi2_truth > 0.5 * truth["signal_sigma"][effect] ** 2
