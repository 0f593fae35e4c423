"""ODE through libode: the exported contact settings, drag force and eps(v) near callback in the real engine."""

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
    ex = export("basketball", "ode", epsilon=eps, dt_s=2e-4)
    params = parse_exported("ode", ex.text)
    assert params["contact"]["bounce"] == pytest.approx(eps)
    runs = E.drop_test(params, ex.setup, 3, 2)
    assert runs.apex_ratios.shape == (2, 3)
    assert runs.worst_error < 0.005


def test_json_has_the_documented_fields():
    data = json.loads(export("tennis", "ode").text)
    contact = data["contact"]
    assert contact["mode"] == ["dContactBounce", "dContactSoftERP", "dContactSoftCFM"]
    assert contact["mode_value"] == 4 | 8 | 16
    assert contact["soft_erp"] == 0.0 and 0 < contact["soft_cfm"] <= 1e-10
    assert set(data["world"]) == {"dt", "gravity", "step"}               # the world's ERP and CFM stay the user's
    assert data["world"]["dt"] == 1e-3 and data["world"]["gravity"][2] == -9.80665
    assert 0 < contact["bounce_vel"] < 0.1
    assert "dContactBounce" in data["snippet"] and "bounce_vel" in data["snippet"]
    assert "drag" not in data and "restitution_law" not in data


def test_snippet_sets_the_balls_contacts_only_and_the_gravity():
    """Pasted into a model with joints, the snippet must not zero the world ERP (joints drift
    apart) nor set every contact's friction: soft ERP/CFM and mu on the ball's contacts only."""
    snippet = json.loads(export("tennis", "ode", g_m_per_s2=9.81).text)["snippet"]
    assert "dWorldSetERP" not in snippet and "dWorldSetCFM" not in snippet
    assert "dWorldSetGravity(world, 0.0, 0.0, -9.81);" in snippet
    assert "if (o1 != ball_geom && o2 != ball_geom)" in snippet
    assert "soft_erp = 0.0;" in snippet and "dContactSoftERP" in snippet
    assert max(len(line) for line in snippet.splitlines()) <= 100


def test_the_users_world_erp_and_cfm_leave_the_bounce_alone():
    """A world with ODE's default ERP 0.2 and the single-precision CFM 1e-5 (a user's model with
    joints): the ball's own contact settings still give epsilon; the same world without them does not."""
    require_engine("ode")
    ex = export("basketball", "ode", dt_s=1e-3)
    params = parse_exported("ode", ex.text)
    params["world"].update(erp=0.2, cfm=1e-5)
    assert E.drop_test(params, ex.setup, 3, 2).worst_error < 0.005
    for key in ("soft_erp", "soft_cfm"):
        del params["contact"][key]
    params["contact"]["mode"] = ["dContactBounce"]
    assert E.drop_test(params, ex.setup, 3, 2).worst_error > 0.01


def test_a_file_of_an_earlier_vrcal_with_world_erp_and_cfm_still_runs():
    require_engine("ode")
    ex = export("basketball", "ode", dt_s=1e-3)
    params = parse_exported("ode", ex.text)
    params["world"].update(erp=0.0, cfm=1e-10)
    params["contact"] = {k: params["contact"][k] for k in ("mu", "bounce", "bounce_vel")} | {
        "mode": ["dContactBounce"]}
    text = json.dumps(params)
    again = parse_exported("ode", text)
    assert E.drop_test(again, ex.setup, 3, 1).worst_error < 0.005


def test_impacts_below_bounce_vel_do_not_bounce():
    """A planted effect: raise bounce_vel above the impact speed and the ball sticks."""
    require_engine("ode")
    ex = export("basketball", "ode", epsilon=0.8)
    params = parse_exported("ode", ex.text)
    params["contact"]["bounce_vel"] = 100.0
    with pytest.raises(DataError, match="stuck to the floor"):
        E.drop_test(params, ex.setup, 1, 1)


def test_a_time_step_too_large_is_refused():
    with pytest.raises(UsageError, match="time step 0.004 s is too large"):
        export("basketball", "ode", epsilon=0.5, dt_s=4e-3)


def test_pair_values_follow_eq6():
    data = json.loads(export("basketball", "ode", against="volleyball").text)
    pairs = data["pairs"]
    assert pairs["basketball/volleyball"] == pytest.approx(pairs["basketball/floor"] * pairs["volleyball/floor"])
    assert any("near callback" in n for n in data["notes"])


def test_drag_and_speed_dependent_epsilon_run_in_ode(write_discover):
    """A discover result with drag (C_d 0.4) and eps(v) (p 0.3): the per-step dBodyAddForce and the
    near callback's bounce from the normal speed reproduce vrcal's model in libode."""
    require_engine("ode")
    path = write_discover(effects={"air_drag": {"drag_coefficient": 0.4},
                                   "velocity_dependent_restitution": {"exponent": 0.3}}, drop_height_m=2.0)
    ex = export(None, "ode", from_json=path, dt_s=2e-4)
    params = parse_exported("ode", ex.text)
    assert params["drag"]["force_coefficient_kg_per_m"] == pytest.approx(
        0.5 * 1.204 * 0.4 * np.pi * 0.02 ** 2, rel=1e-6)
    law = params["restitution_law"]
    assert law["table"]["epsilon"][0] > law["table"]["epsilon"][-1]        # slower impacts, more elastic
    assert "dBodyAddForce" in params["snippet"] and "pow(vn /" in params["snippet"]
    runs = E.drop_test(params, ex.setup, 3, 2)
    assert runs.worst_error < 0.01
    assert np.max(np.abs(runs.apex_relative_errors)) < 0.01
    # the planted effects matter: the same drop without them rises well above vrcal's model of it
    plain = export(None, "ode", mass_kg=0.0027, diameter_m=0.04, epsilon=0.86, drop_height_m=2.0, dt_s=2e-4)
    off = E.drop_test(parse_exported("ode", plain.text), plain.setup, 3, 1).apex_m[0, 1:]
    assert np.all(off / ex.setup.model.apex_heights_m[0, 1:] - 1 > 0.05)
