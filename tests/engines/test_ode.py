"""ODE through libode: the exported contact settings reproduce epsilon in the real engine."""

import json

import numpy as np
import pytest
from helpers import EPSILONS, require_engine

from vrcal.engines import ode as E
from vrcal.engines.export import export, parse_exported
from vrcal.errors import DataError, UsageError


@pytest.mark.parametrize("eps", EPSILONS)
def test_exported_settings_reproduce_epsilon_in_ode(eps):
    require_engine("ode")
    ex = export("basketball", "ode", epsilon=eps)
    params = parse_exported("ode", ex.text)
    assert params["contact"]["bounce"] == pytest.approx(eps)
    assert params["world"]["dt"] == E.DEFAULT_DT_S
    shifts, apex, vel = E.drop_test(params, ex.setup, 3, 4)
    assert apex.shape == (4, 3)
    assert np.max(np.abs(apex - eps)) < 0.005
    assert np.max(np.abs(vel - eps)) < 0.005


def test_json_has_the_documented_fields():
    data = json.loads(export("tennis", "ode").text)
    assert data["contact"]["mode"] == ["dContactBounce"] and data["contact"]["mode_value"] == 4
    assert set(data["world"]) >= {"erp", "cfm", "dt", "gravity"}
    assert 0 < data["contact"]["bounce_vel"] < 0.1
    assert "dContactBounce" in data["snippet"] and "bounce_vel" in data["snippet"]


def test_impacts_below_bounce_vel_do_not_bounce():
    """A planted effect: raise bounce_vel above the impact speed and the ball sticks."""
    require_engine("ode")
    ex = export("basketball", "ode", epsilon=0.8)
    params = parse_exported("ode", ex.text)
    params["contact"]["bounce_vel"] = 100.0
    with pytest.raises(DataError, match="stuck to the floor"):
        E.drop_test(params, ex.setup, 1, 1)


def test_a_time_step_too_large_is_refused():
    with pytest.raises(UsageError, match="time step 0.002 s is too large"):
        export("basketball", "ode", epsilon=0.5, dt_s=2e-3)


def test_pair_values_follow_eq6():
    data = json.loads(export("basketball", "ode", against="volleyball").text)
    pairs = data["pairs"]
    assert pairs["basketball/volleyball"] == pytest.approx(pairs["basketball/floor"] * pairs["volleyball/floor"])
    assert any("near callback" in n for n in data["notes"])
