"""PyBullet: the exported changeDynamics / engine parameters reproduce epsilon in the real engine."""

import json

import numpy as np
import pytest
from helpers import EPSILONS, require_engine

from vrcal.engines import bullet as E
from vrcal.engines.export import export, parse_exported


@pytest.mark.parametrize("eps", EPSILONS)
def test_exported_settings_reproduce_epsilon_in_pybullet(eps):
    require_engine("bullet")
    ex = export("basketball", "bullet", epsilon=eps)
    params = parse_exported("bullet", ex.text)
    assert params["changeDynamics"]["ball"]["restitution"] * params["changeDynamics"]["floor"]["restitution"] \
        == pytest.approx(eps)
    shifts, apex, vel = E.drop_test(params, ex.setup, 3, 2)
    assert np.max(np.abs(apex - eps)) < 0.005
    assert np.max(np.abs(vel - eps)) < 0.005


def test_floor_restitution_multiplies():
    """A planted effect: Bullet multiplies the floor's restitution into the ball's."""
    require_engine("bullet")
    ex = export("basketball", "bullet", epsilon=0.85)
    params = parse_exported("bullet", ex.text)
    params["changeDynamics"]["floor"]["restitution"] = 0.5        # product rule: 0.85 * 0.5
    shifts, apex, vel = E.drop_test(params, ex.setup, 1, 1)
    assert vel[0, 0] == pytest.approx(0.85 * 0.5, abs=0.005)


def test_pair_is_the_product_rule():
    data = json.loads(export("basketball", "bullet", against="tennis").text)
    cd = data["changeDynamics"]
    assert cd["ball"]["restitution"] * cd["ball2"]["restitution"] == pytest.approx(data["pair"]["epsilon"])
    assert data["setPhysicsEngineParameter"]["erp"] == 0.0 and data["setPhysicsEngineParameter"]["contactERP"] == 0.0
    assert cd["ball"]["contactProcessingThreshold"] == 0.0 and cd["floor"]["contactProcessingThreshold"] == 0.0
