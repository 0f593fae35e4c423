"""MuJoCo: the force-zero damping relation, the gravity model, and the real engine's drop test."""

import math

import numpy as np
import pytest
from helpers import EPSILONS, require_engine
from hypothesis import given, settings
from hypothesis import strategies as st

from vrcal.engines import mujoco as M
from vrcal.engines.common import DropSetup
from vrcal.engines.export import export
from vrcal.errors import UsageError


@pytest.mark.parametrize("eps, zeta", [(0.5, 0.2553), (0.7, 0.1222), (0.85, 0.0535), (0.9, 0.0343), (0.95, 0.0165)])
def test_damping_ratio_matches_the_measured_table(eps, zeta):
    # engines-facts.md: zeta for these targets from the force-zero relation (which matched MuJoCo 4.0)
    assert M.damping_ratio_from_epsilon(eps) == pytest.approx(zeta, abs=1e-4)


@settings(max_examples=50, deadline=None)
@given(st.floats(0.21, 1.0))
def test_damping_ratio_round_trip(eps):
    assert M.epsilon_from_damping_ratio(M.damping_ratio_from_epsilon(eps)) == pytest.approx(eps, abs=1e-12)


def test_an_epsilon_below_what_a_contact_spring_gives_is_refused():
    e_min = M.epsilon_from_damping_ratio(0.7071)
    with pytest.raises(UsageError, match="least a MuJoCo contact spring gives"):
        M.damping_ratio_from_epsilon(e_min / 2)


def test_scalar_and_array_give_the_same_numbers():
    z = np.array([0.0, 0.1, 0.3])
    assert np.allclose(M.epsilon_from_damping_ratio(z), [M.epsilon_from_damping_ratio(float(x)) for x in z])
    assert M.epsilon_from_damping_ratio(0.0) == 1.0
    v = np.array([1.0, 3.0, 6.0])
    assert np.allclose(M.contact_epsilon(0.2, 500.0, v, 9.81), [M.contact_epsilon(0.2, 500.0, float(x), 9.81) for x in v])
    assert M.damping_ratio_from_epsilon(1.0) == 0.0


def test_the_classic_relation_is_not_the_force_zero_one():
    # the force-zero contact ends before the spring is back at rest length: less damping work
    zeta = 0.1
    classic = math.exp(-zeta * math.pi / math.sqrt(1 - zeta * zeta))
    assert M.epsilon_from_damping_ratio(zeta) > classic + 0.01


@pytest.mark.parametrize("eps", EPSILONS)
def test_gravity_free_contact_model_is_the_force_zero_relation(eps):
    zeta = M.damping_ratio_from_epsilon(eps)
    assert M.contact_epsilon(zeta, 500.0, 3.0, 0.0) == pytest.approx(eps, abs=1e-9)
    # gravity ends the contact early: epsilon drops, more at low speed
    assert M.contact_epsilon(zeta, 500.0, 1.0, 9.81) < M.contact_epsilon(zeta, 500.0, 6.0, 9.81) <= eps + 1e-12


def test_contact_model_predicts_a_real_low_stiffness_run():
    require_engine("mujoco")
    setup = DropSetup("test", 0.6, 0.12, 0.2, 0.5, 1e-4)
    zeta = M.damping_ratio_from_epsilon(0.5)       # no gravity correction: the planted effect
    w = 200.0
    xml = M.export_mjcf(DropSetup("test", 0.6, 0.12, 0.2, 0.5, 2.5e-4), tolerance=1.0)
    xml = xml.replace(xml.split('solref="')[1].split('"')[0], f"{-M.IMPEDANCE * w * w} {-2 * zeta * w}")
    xml = xml.replace('timestep="0.00025"', 'timestep="1e-05"')
    shifts, apex, vel = M.drop_test(xml, DropSetup("test", 0.6, 0.12, 0.2, 0.5, 1e-5), 1, 1)
    predicted = M.contact_epsilon(zeta, w, setup.impact_speed_m_per_s, 9.81)
    assert predicted < 0.5 - 0.01
    assert vel[0, 0] == pytest.approx(predicted, abs=1e-3)


@pytest.mark.parametrize("eps", EPSILONS)
def test_exported_model_reproduces_epsilon_in_mujoco(eps):
    require_engine("mujoco")
    ex = export("basketball", "mujoco", epsilon=eps)
    setup = ex.setup
    assert setup.dt_s == M.DEFAULT_DT_S
    shifts, apex, vel = M.drop_test(ex.text, setup, 3, 2)
    assert apex.shape == (2, 3)
    assert np.max(np.abs(apex - eps)) < 0.005
    assert np.max(np.abs(vel - eps)) < 0.005


def test_export_is_a_complete_loadable_model():
    mujoco = pytest.importorskip("mujoco") if not _required() else __import__("mujoco")
    ex = export("tennis", "mujoco", epsilon=0.75)
    model = mujoco.MjModel.from_xml_string(ex.text)
    assert model.opt.timestep == pytest.approx(M.DEFAULT_DT_S)
    assert model.npair == 1
    w = M.omega_for_dt(M.DEFAULT_DT_S)
    assert model.pair_solref[0][0] == pytest.approx(-M.IMPEDANCE * w * w)
    assert model.pair_solref[0][1] < 0
    ball = model.body("ball")
    assert model.body_mass[ball.id] == pytest.approx(ex.setup.mass_kg)
    assert model.geom_size[model.geom("ball").id][0] == pytest.approx(ex.setup.radius_m)
    # bottom of the ball at the standard's drop height
    assert model.body_pos[ball.id][2] - ex.setup.radius_m == pytest.approx(ex.setup.drop_height_m)


def _required():
    import os

    return os.environ.get("VRCAL_REQUIRE_ENGINES") == "1"


def test_pair_export_has_a_ball_ball_pair_with_the_product():
    ex = export("basketball", "mujoco", against="volleyball")
    assert ex.text.count("<pair ") == 3
    assert ex.pair["epsilon"] == pytest.approx(ex.setup.ball_epsilon * ex.pair["epsilon_ball2"])


def test_a_time_step_too_large_for_the_contact_is_refused():
    with pytest.raises(UsageError, match="too large for MuJoCo"):
        export("basketball", "mujoco", epsilon=0.5, dt_s=1e-3)


def test_pair_contact_gives_the_eq6_value_in_mujoco():
    """Head-on ball/ball collision without gravity: relative speed ratio = eps_A * eps_B."""
    require_engine("mujoco")
    import mujoco

    ex = export("basketball", "mujoco", against="volleyball")
    m = mujoco.MjModel.from_xml_string(ex.text)
    d = mujoco.MjData(m)
    m.opt.gravity[:] = 0.0
    adr = {b: (m.jnt_qposadr[m.body(b).jntadr[0]], m.jnt_dofadr[m.body(b).jntadr[0]]) for b in ("ball", "ball2")}
    gap = m.geom_size[m.geom("ball").id][0] + m.geom_size[m.geom("ball2").id][0] + 1e-4
    d.qpos[adr["ball"][0]:adr["ball"][0] + 3] = [0.0, 0.0, 1.0]
    d.qpos[adr["ball2"][0]:adr["ball2"][0] + 3] = [gap, 0.0, 1.0]
    d.qvel[adr["ball"][1]], d.qvel[adr["ball2"][1]] = 3.0, -1.0
    mujoco.mj_step(m, d, nstep=4000)
    ratio = (d.qvel[adr["ball2"][1]] - d.qvel[adr["ball"][1]]) / 4.0
    assert ratio == pytest.approx(ex.pair["epsilon"], abs=0.005)
    assert ex.pair["epsilon"] < min(ex.setup.ball_epsilon, ex.pair["epsilon_ball2"])
