"""Gazebo: the SDF world is valid XML with the calibrated bounce (no Gazebo runtime is used)."""

import xml.etree.ElementTree as ET

import pytest
from helpers import EPSILONS, require_engine

from vrcal.engines.export import export
from vrcal.errors import UsageError


def _parse(text):
    return ET.fromstring(text.split("?>", 1)[1])


@pytest.mark.parametrize("eps", EPSILONS)
def test_sdf_has_the_expected_elements(eps):
    ex = export("football", "gazebo", epsilon=eps, dt_s=2e-4)
    root = _parse(ex.text)
    assert root.tag == "sdf" and tuple(map(int, root.get("version").split("."))) >= (1, 6)
    physics = root.find("world/physics")
    assert physics.get("type") == "ode"
    assert float(physics.findtext("max_step_size")) == pytest.approx(2e-4)
    ball = root.find("world/model[@name='ball']")
    bounce = ball.find("link/collision/surface/bounce")
    assert float(bounce.findtext("restitution_coefficient")) == pytest.approx(eps)
    assert 0 < float(bounce.findtext("threshold")) < 0.1            # SDF default 1e5 never bounces
    floor = root.find("world/model[@name='ground_plane']/link/collision/surface/bounce")
    assert float(floor.findtext("restitution_coefficient")) == 1.0   # min rule: the ball's value is used
    radius = float(ball.findtext("link/collision/geometry/sphere/radius"))
    z = float(ball.findtext("pose").split()[2])
    assert z - radius == pytest.approx(ex.setup.drop_height_m)
    assert float(ball.findtext("link/inertial/mass")) == pytest.approx(ex.setup.mass_kg)


def test_pair_explains_the_min_rule():
    text = export("basketball", "gazebo", against="volleyball").text
    root = _parse(text)
    assert root.find("world/model[@name='ball2']") is not None
    assert "min" in text and "cannot multiply" in text


def test_gazebo_refuses_a_time_step_too_large_for_odes_bounce():
    """Measured in libode (the engine behind Gazebo): football, epsilon 0.5, at 2 ms misses
    (error 0.0103 measured); at 1 ms it meets (0.0067), which the step bound alone refused."""
    require_engine("ode")
    with pytest.raises(UsageError, match=r"^ODE at --dt 0\.002 s misses \(4 phases.*error 0\.01"):
        export("football", "gazebo", epsilon=0.5, dt_s=2e-3)
    assert "checked in ODE" in export("football", "gazebo", epsilon=0.5, dt_s=1e-3).text


def test_compliant_floor_goes_into_the_balls_value_under_the_min_rule():
    ex = export("basketball", "gazebo", epsilon=0.8, floor="x=0.01,v=0.05", dt_s=2e-4)
    root = _parse(ex.text)
    ball = float(root.findtext("world/model[@name='ball']/link/collision/surface/bounce/restitution_coefficient"))
    floor = float(root.findtext("world/model[@name='ground_plane']/link/collision/surface/bounce/"
                                "restitution_coefficient"))
    assert min(ball, floor) == pytest.approx(ex.setup.epsilon) == pytest.approx(0.8 * ex.setup.floor_epsilon)
