"""PyBullet: the exported changeDynamics / engine parameters and the snippet's vrcal_step in the real engine."""

import json
import re

import numpy as np
import pytest
from helpers import EPSILONS, require_engine

from vrcal.engines import bullet as E
from vrcal.engines.export import export, parse_exported
from vrcal.errors import UsageError


@pytest.mark.parametrize("eps", EPSILONS)
def test_exported_settings_reproduce_epsilon_in_pybullet(eps):
    require_engine("bullet")
    ex = export("basketball", "bullet", epsilon=eps, dt_s=5e-4)
    params = parse_exported("bullet", ex.text)
    assert params["changeDynamics"]["ball"]["restitution"] * params["changeDynamics"]["floor"]["restitution"] \
        == pytest.approx(eps)
    runs = E.drop_test(params, ex.setup, 3, 2)
    assert runs.worst_error < 0.005


def test_floor_restitution_multiplies():
    """A planted effect: Bullet multiplies the floor's restitution into the ball's."""
    require_engine("bullet")
    ex = export("basketball", "bullet", epsilon=0.85, dt_s=5e-4)
    params = parse_exported("bullet", ex.text)
    params["changeDynamics"]["floor"]["restitution"] = 0.5        # product rule: 0.85 * 0.5
    runs = E.drop_test(params, ex.setup, 1, 1)
    assert runs.velocity_ratios[0, 0] == pytest.approx(0.85 * 0.5, abs=0.005)


def test_pair_is_the_product_rule():
    data = json.loads(export("basketball", "bullet", against="tennis", dt_s=5e-4).text)
    cd = data["changeDynamics"]
    assert cd["ball"]["restitution"] * cd["ball2"]["restitution"] == pytest.approx(data["pair"]["epsilon"])
    assert data["setPhysicsEngineParameter"]["contactERP"] == 0.0
    assert cd["ball"]["contactProcessingThreshold"] == 0.0 and cd["floor"]["contactProcessingThreshold"] == 0.0


def test_pybullets_default_step_is_refused_naming_one_that_works():
    """At Bullet's 1/240 s a basketball sinks up to 14 mm before its contact acts: refused, and the
    named step then passes in PyBullet."""
    require_engine("bullet")
    with pytest.raises(UsageError, match=r"time step 0.00416667 s is too large.*--dt ([0-9.e-]+) meets") as info:
        export("basketball", "bullet")
    dt_ok = float(re.search(r"--dt ([0-9.e-]+) meets", str(info.value)).group(1))
    ex = export("basketball", "bullet", dt_s=dt_ok)
    runs = E.drop_test(parse_exported("bullet", ex.text), ex.setup, 3, 4)
    assert runs.worst_error <= 0.01


def test_the_snippets_vrcal_step_carries_drag_and_eps_v(write_discover):
    """verify steps with the snippet's own vrcal_step: drag force and restitution at this speed."""
    require_engine("bullet")
    path = write_discover(effects={"air_drag": {"drag_coefficient": 0.4},
                                   "velocity_dependent_restitution": {"exponent": 0.3}}, drop_height_m=2.0)
    ex = export(None, "bullet", from_json=path, dt_s=5e-4)
    params = parse_exported("bullet", ex.text)
    assert "def vrcal_step(ball):" in params["snippet"] and "applyExternalForce" in params["snippet"]
    assert E.step_code(params) in params["snippet"]
    runs = E.drop_test(params, ex.setup, 3, 1)
    assert runs.worst_error < 0.01
    assert np.max(np.abs(runs.apex_relative_errors)) < 0.01


def test_only_the_contacts_error_reduction_is_set():
    """erp (joints) and frictionERP are the user's: the export sets contactERP alone, and the
    drop test still meets the tolerance with PyBullet's own erp and frictionERP."""
    data = json.loads(export("basketball", "bullet", dt_s=1e-3).text)
    engine = data["setPhysicsEngineParameter"]
    assert engine["contactERP"] == 0.0 and "erp" not in engine and "frictionERP" not in engine
    assert "erp" not in data["snippet"].replace("contactERP", "")
    require_engine("bullet")
    ex = export("basketball", "bullet", dt_s=1e-3)
    runs = E.drop_test(parse_exported("bullet", ex.text), ex.setup, 3, 2)
    assert runs.worst_error < 0.01


def test_vrcal_step_clamps_the_speed_law_to_0_1():
    """eps(v) = 1 - 0.5 (v / 5)^-1 is below 0 for v < 2.5 m/s and eps(v) = 1 - 0.5 (v / 5)^2 below 0
    above 7.1 m/s: the restitution vrcal_step sets stays in [0, 1]; the snippet says it takes |v_z|."""
    set_to = []

    class FakePyBullet:
        WORLD_FRAME = 2

        def __init__(self, vz):
            self.vz = vz

        def getBaseVelocity(self, ball):
            return (0.0, 0.0, self.vz), (0.0, 0.0, 0.0)

        def changeDynamics(self, ball, link, restitution):
            set_to.append(restitution)

        def stepSimulation(self):
            pass

    for exponent, vz in ((-1.0, -1.0), (2.0, -9.0), (0.5, -5.0)):
        params = {"restitution_law": {"epsilon_ref": 0.5, "reference_speed_m_per_s": 5.0, "exponent": exponent}}
        E.step_function(params, FakePyBullet(vz))(1)
    assert set_to == [0.0, 0.0, pytest.approx(0.5)]
    assert "z-up floor" in E.step_code(params)
