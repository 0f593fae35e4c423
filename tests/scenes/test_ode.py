"""Tests of vrcal.scenes.ode: the scene in the real ODE library against vrcal's event-driven simulator,
and `vrcal scene --engine ode / --compare`."""

import math
import os
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from vrcal.cli import main
from vrcal.errors import EngineUnavailable
from vrcal.scenes.compare import compare_results
from vrcal.scenes.multibody import simulate_scene
from vrcal.scenes.spec import contact_epsilon, load_scene, validate_scene

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.fixture(scope="module")
def ode():
    try:
        from vrcal.engines.ode_ctypes import load_ode

        load_ode()
    except EngineUnavailable as exc:
        if os.environ.get("VRCAL_REQUIRE_ENGINES") == "1":
            pytest.fail(f"ODE required but unavailable: {exc}")
        pytest.skip(f"ODE unavailable: {exc}")
    from vrcal.scenes import ode as scene_ode

    return scene_ode


def with_duration(path, duration):
    doc = yaml.safe_load(Path(path).read_text())
    doc["duration_s"] = duration
    return validate_scene(doc, str(path))


def test_near_callback_bounce_is_eq6_then_eq7(ode):
    assert ode.near_callback_bounce((0.05, 0.4), (0.0, 0.0), 4.0) == pytest.approx(math.exp(-4.0 * 0.05 / 0.8))
    assert ode.near_callback_bounce((0.05, 0.4), (0.01, 0.1), 4.0) == contact_epsilon(0.05, 0.4, 0.01, 0.1, 4.0)


def test_ode_basketball_drop_agrees_with_vrcal(ode):
    """Figure 8's drop (epsilon 0.766): ODE (dt = 1e-4 s) and the exact event-driven run agree to three steps
    in impact time and 0.1 % in apex height over the bounces of the first 3 s (0.06 % measured)."""
    scene = with_duration(EXAMPLES / "figure8-basketball.yaml", 3.0)
    a = simulate_scene(scene)
    b = ode.simulate_scene_ode(scene, dt_s=1e-4)
    assert b.engine == "ode"
    assert b.position_m.shape == a.position_m.shape
    cmp = compare_results(a, b)
    assert len(cmp.impacts) >= 3
    assert cmp.max_impact_time_difference_s <= 3e-4
    assert cmp.max_apex_relative_difference < 1e-3
    assert [c.epsilon for c in b.contacts[:3]] == [c.epsilon for c in a.contacts[:3]]
    np.testing.assert_allclose(b.bottom_height_m(), a.bottom_height_m(), atol=0.01)


def test_ode_error_shrinks_with_the_time_step(ode):
    scene = with_duration(EXAMPLES / "figure8-basketball.yaml", 1.3)
    exact = simulate_scene(scene)
    errors = []
    for dt in (1e-3, 1e-4):
        cmp = compare_results(exact, ode.simulate_scene_ode(scene, dt_s=dt))
        errors.append(cmp.max_apex_difference_m)
    assert errors[1] < errors[0]


def test_ode_five_balls_each_bounce_with_their_own_epsilon(ode):
    scene = with_duration(EXAMPLES / "figure9-five-balls.yaml", 1.0)
    a, b = simulate_scene(scene), ode.simulate_scene_ode(scene, dt_s=2e-4)
    first_a = {c.body_a: c.epsilon for c in a.contacts}
    first_b = {c.body_a: c.epsilon for c in b.contacts}
    assert first_a == first_b and len(first_a) == 5
    apex_a = {n: h for n, t, h in a.apexes if t > 0}
    apex_b = {n: h for n, t, h in b.apexes if t > 0}
    for name in apex_a:
        assert apex_b[name] == pytest.approx(apex_a[name], rel=2e-3)


def test_ode_stack_drop_launches_the_tennis_ball_like_vrcal(ode):
    scene = with_duration(EXAMPLES / "stack-drop.yaml", 1.3)
    a, b = simulate_scene(scene), ode.simulate_scene_ode(scene, dt_s=1e-4)
    pairs = [(c.body_a, c.body_b) for c in b.contacts[:2]]
    assert pairs == [("basketball", "floor"), ("basketball", "tennis")]
    ha = [h for n, t, h in a.apexes if n == "tennis"][1]
    hb = [h for n, t, h in b.apexes if n == "tennis"][1]
    assert hb == pytest.approx(ha, rel=5e-3)


def test_bad_time_step_is_a_usage_error(ode):
    from vrcal.errors import UsageError

    scene = load_scene(EXAMPLES / "figure8-basketball.yaml")
    with pytest.raises(UsageError, match="--ode-dt"):
        ode.simulate_scene_ode(scene, dt_s=0.5)


def test_ode_dt_without_ode_is_a_usage_error(tmp_path):
    result = CliRunner().invoke(main, ["scene", str(EXAMPLES / "stack-drop.yaml"), "--engine", "vrcal",
                                       "--ode-dt", "1e-3", "-o", str(tmp_path / "o")])
    assert result.exit_code == 2
    assert result.output.strip().splitlines()[-1].startswith("vrcal: error: --ode-dt sets ODE's time step and has "
                                                              "no effect with --engine vrcal")
    assert not (tmp_path / "o").exists()


def test_cli_compare_reports_differences_and_why(ode, tmp_path):
    doc = yaml.safe_load((EXAMPLES / "figure8-basketball.yaml").read_text())
    doc["duration_s"] = 1.5
    path = tmp_path / "drop.yaml"
    path.write_text(yaml.safe_dump(doc))
    result = CliRunner().invoke(main, ["scene", str(path), "--compare", "--no-animation", "-o", str(tmp_path / "o")])
    assert result.exit_code == 0, result.output
    assert "vrcal against ode (ODE step 0.0001 s):" in result.output
    assert "why they differ:" in result.output and "bounce_vel" in result.output
    names = sorted(p.name for p in (tmp_path / "o").iterdir())
    assert names == ["drop-contacts-ode.csv", "drop-contacts-vrcal.csv", "drop-trajectories-ode.csv",
                     "drop-trajectories-vrcal.csv", "drop.png"]


def test_cli_engine_ode(ode, tmp_path):
    doc = yaml.safe_load((EXAMPLES / "figure8-basketball.yaml").read_text())
    doc["duration_s"] = 0.8
    path = tmp_path / "drop.yaml"
    path.write_text(yaml.safe_dump(doc))
    result = CliRunner().invoke(main, ["scene", str(path), "--engine", "ode", "--no-animation", "-o",
                                       str(tmp_path / "o")])
    assert result.exit_code == 0, result.output
    assert "(ode)" in result.output and "basketball - floor" in result.output


def test_ode_messages_are_collected_not_printed(ode, capfd):
    """ODE prints its messages to stderr; during a scene run they are counted and become notes."""
    import ctypes

    from vrcal.engines.ode_ctypes import load_ode

    lib = load_ode()
    dmessage = ctypes.CFUNCTYPE(None, ctypes.c_int, ctypes.c_char_p)(("dMessage", lib))
    with ode._OdeMessages(lib) as messages:
        dmessage(7, b"test message")
        dmessage(7, b"test message")
    assert messages.counts == {"ODE message 7: test message": 2}
    assert "test message" not in capfd.readouterr().err


def test_ode_cradle_reports_its_solver_messages_in_the_notes(ode, capfd):
    res = ode.simulate_scene_ode(load_scene(EXAMPLES / "cradle.yaml"), dt_s=1e-4)
    assert "ODE Message" not in capfd.readouterr().err
    n = res.settings["ode_messages"]
    assert (n > 0) == any("LCP" in note for note in res.notes)


def oblique_scene(mu=0.2, duration=0.45):
    """The probe's pyramid.yaml: 0.5 kg, R 0.1 m, dropped from 0.5 m (bottom) with 4 m/s horizontally,
    along x and along the diagonal x = y; floor epsilon exp(-4 * 0.05 / (2 * 0.5)) = 0.8187."""
    body = {"mass_kg": 0.5, "radius_m": 0.1, "virtual_body": {"x_m": 0.05, "v_m_per_s": 0.5}, "position_of": "bottom"}
    s = 4.0 / math.sqrt(2.0)
    return validate_scene({"name": "pyramid", "K_per_s": 4.0, "duration_s": duration, "sample_dt_s": 0.001,
                           "friction_mu": mu, "floor": {"material": "steel"},
                           "bodies": [{**body, "name": "alongx", "position_m": [0, 0, 0.5],
                                       "velocity_m_per_s": [4.0, 0, 0]},
                                      {**body, "name": "diag", "position_m": [0, 1.0, 0.5],
                                       "velocity_m_per_s": [s, s, 0]}]}, "pyramid.yaml")


def test_friction_is_coulombs_circle_in_both_engines_also_off_the_axes(ode):
    """A sliding impact: the horizontal speed drops by mu j / m whatever the slip's direction.

    Hand values: impact speed sqrt(2 g 0.5) = 3.1316 m/s, j = m (1 + 0.8187) 3.1316 = 2.8477 N s,
    mu j / m = 1.1391 m/s, so 4 - 1.1391 = 2.8609 m/s. ODE's default friction pyramid capped each of
    its axes separately and gave 2.400 m/s along the diagonal; with fdir1 along the slip it agrees."""
    g = 9.80665
    v_in = math.sqrt(2 * g * 0.5)
    eps = math.exp(-4.0 * 0.05 / (2 * 0.5))
    j = 0.5 * (1 + eps) * v_in
    hand = 4.0 - 0.2 * j / 0.5
    assert hand == pytest.approx(2.8609, abs=1e-4)
    scene = oblique_scene()
    for res, tol in ((simulate_scene(scene), 1e-9), (ode.simulate_scene_ode(scene), 2e-4)):
        speed = np.hypot(res.velocity_m_per_s[-1, :, 0], res.velocity_m_per_s[-1, :, 1])
        assert speed == pytest.approx([hand, hand], rel=tol), res.engine
        direction = res.velocity_m_per_s[-1, 1, :2] / speed[1]
        assert direction == pytest.approx([2 ** -0.5, 2 ** -0.5], abs=1e-9)   # the slip's direction is kept
        c = res.contacts[0]
        assert c.normal_impulse_N_s == pytest.approx(j, rel=1e-3)   # ODE's includes m g dt = 0.0005 N s
        assert c.tangential_impulse_N_s == pytest.approx(0.2 * j, rel=1e-3)


def test_ode_ball_sliding_on_the_floor_rolls_like_vrcal(ode):
    """The probe's slide.yaml: hollow ball, mu 0.3, vx 2 m/s: rolls at 3/5 * 2 = 1.2 m/s; with backspin
    omega_y = -40 rad/s (slip 6 m/s) it comes back at 2 - 6 * 2/5 = -0.4 m/s (hand values)."""
    body = {"mass_kg": 0.5, "radius_m": 0.1, "virtual_body": {"x_m": 0.05, "v_m_per_s": 0.5},
            "velocity_m_per_s": [2.0, 0, 0]}
    scene = validate_scene({"name": "slide", "K_per_s": 4.0, "duration_s": 1.0, "friction_mu": 0.3,
                            "floor": {"material": "steel"},
                            "bodies": [{**body, "name": "slider", "position_m": [0, 0, 0.1]},
                                       {**body, "name": "backspin", "position_m": [0, 1.0, 0.1],
                                        "spin_rad_per_s": [0, -40.0, 0]}]}, "slide.yaml")
    for res in (simulate_scene(scene), ode.simulate_scene_ode(scene, dt_s=1e-3)):
        assert res.velocity_m_per_s[-1, :, 0] == pytest.approx([1.2, -0.4], abs=1e-3), res.engine
        assert res.contacts == []    # balls placed on the floor make no impact in either engine


def test_ode_contacts_carry_impulses_not_nan(ode, tmp_path):
    run = CliRunner().invoke(main, ["scene", str(EXAMPLES / "stack-drop.yaml"), "--engine", "ode", "--ode-dt", "1e-3",
                                    "--no-animation", "-o", str(tmp_path)])
    assert run.exit_code == 0, run.output
    text = (tmp_path / "stack-drop-contacts.csv").read_text()
    assert "nan" not in text
    rows = [line.split(",") for line in text.splitlines()[1:]]
    assert rows and all(float(r[5]) > 0 for r in rows)


def cradle(striker_last):
    """A frictionless striker at 2 m/s rolls into three touching equal balls, epsilon = 1 (the probe's
    cradle_last.yaml lists the striker last)."""
    ball = {"mass_kg": 0.2, "radius_m": 0.1, "virtual_body": {"x_m": 0.0}}
    row = [{**ball, "name": f"b{k + 1}", "position_m": [0.2 * k, 0, 0.1]} for k in range(3)]
    striker = {**ball, "name": "striker", "position_m": [-1.0, 0, 0.1], "velocity_m_per_s": [2.0, 0, 0]}
    return validate_scene({"name": "cradle", "K_per_s": 4.0, "duration_s": 1.0, "friction_mu": 0.0,
                           "floor": {"material": "steel"},
                           "bodies": row + [striker] if striker_last else [striker] + row}, "cradle.yaml")


def test_compare_flags_a_reordered_cradle_and_names_the_order_dependence(ode):
    from vrcal.scenes.compare import comparison_text

    scene = cradle(striker_last=True)
    a, b = simulate_scene(scene), ode.simulate_scene_ode(scene)
    # vrcal: striker, b1, b2 stop, b3 leaves at 2 m/s; ODE's LCP: b1-b3 leave at 1 m/s, the striker at -1 m/s
    assert a.velocity_m_per_s[-1, :, 0] == pytest.approx([0, 0, 2.0, 0], abs=1e-9)
    assert b.velocity_m_per_s[-1, :, 0] == pytest.approx([1.0, 1.0, 1.0, -1.0], abs=1e-3)
    cmp = compare_results(a, b)
    assert cmp.differing_bodies == ["b1", "b2", "b3", "striker"]
    assert cmp.max_position_difference_m == pytest.approx(0.6, abs=0.01)   # 1 m/s for the 0.6 s after 0.4 s
    text = comparison_text(cmp)
    assert "DIFFERENT: b1, b2, b3, striker end in other states" in text
    assert "order dependence: at t = 0.4 s vrcal resolved 3 touching contacts one after another" in text
    from vrcal.scenes.compare import difference_flags
    from vrcal.scenes.output import plot_difference

    ax = plot_difference(a, b, flags=difference_flags(cmp))          # the PNG's lower panel says it too
    assert any("DIFFERENT: b1, b2, b3, striker" in t.get_text() for t in ax.texts)
    assert len(ax.lines) == 2 * 4 + 1            # per body: x difference and horizontal distance; the zero line


def test_compare_of_agreeing_runs_flags_nothing_but_reports_the_horizontal_difference(ode):
    from vrcal.scenes.compare import comparison_text

    scene = oblique_scene()
    cmp = compare_results(simulate_scene(scene), ode.simulate_scene_ode(scene))
    assert cmp.differing_bodies == [] and cmp.max_position_difference_m < 1e-3
    assert "DIFFERENT" not in comparison_text(cmp) and "largest |Δposition|" in comparison_text(cmp)


def slow_hit_scene(speed):
    """The probe's slowhit.yaml: a 0.6 kg ball rolls (frictionless) at ``speed`` into a resting 0.06 kg ball,
    same radius, pair epsilon exp(-4 (0.06/0.9 + 0.017/0.22)) = 0.5623."""
    return validate_scene({
        "name": "slowhit", "K_per_s": 4.0, "duration_s": 1.0, "friction_mu": 0.0, "floor": {"material": "steel"},
        "bodies": [
            {"name": "heavy", "mass_kg": 0.6, "radius_m": 0.1, "virtual_body": {"x_m": 0.06, "v_m_per_s": 0.45},
             "position_m": [-0.21, 0, 0.1], "velocity_m_per_s": [speed, 0, 0]},
            {"name": "light", "mass_kg": 0.06, "radius_m": 0.1, "virtual_body": {"x_m": 0.017, "v_m_per_s": 0.11},
             "position_m": [0.0, 0, 0.1]}]}, "slowhit.yaml")


def test_a_slow_ball_ball_hit_bounces_in_both_engines(ode):
    """The rest speed is a floor-only rule: a 0.04 m/s ball-ball hit (below rest_speed 0.05 m/s) bounces with
    the pair's epsilon in both runs, (1 + e) m1/(m1 + m2) v = 0.05681 m/s for the light ball (ODE gave
    0.0364, perfectly inelastic, 'no bounce: slower than bounce_vel', before)."""
    scene = slow_hit_scene(0.04)
    e = float(scene.epsilon_matrix()[0, 1])
    expected = (1 + e) * 0.6 / 0.66 * 0.04
    a, b = simulate_scene(scene), ode.simulate_scene_ode(scene)
    for run in (a, b):
        assert run.velocity_m_per_s[-1, 1, 0] == pytest.approx(expected, rel=1e-6)
        assert [(c.body_a, c.body_b, c.epsilon, c.note) for c in run.contacts] == [("heavy", "light", e, "")]
    cmp = compare_results(a, b)
    assert cmp.differing_bodies == [] and cmp.unmatched == []
    assert ode.bounce_velocity(scene, on_floor=False) == 0.0
    assert ode.bounce_velocity(scene, on_floor=True) == scene.rest_speed_m_per_s


def test_a_gapped_five_ball_row_matches_every_slow_re_hit(ode):
    """The probe's cradle5_e08_gap: a striker at 2 m/s into four balls 1 mm apart; the slow re-hits
    (0.03-0.05 m/s) bounce in ODE too: 'unmatched: s - b1: 4 impacts (vrcal) vs 2 (ode)' before."""
    bodies = [{"name": name, "mass_kg": 0.2, "radius_m": 0.1, "virtual_body": {"x_m": 0.01, "v_m_per_s": 0.1},
               "position_m": [x, 0, 0.1]} for name, x in
              [("s", -1.0), ("b1", 0.0), ("b2", 0.201), ("b3", 0.402), ("b4", 0.603)]]
    bodies[0]["velocity_m_per_s"] = [2.0, 0, 0]
    scene = validate_scene({"name": "cradle5", "K_per_s": 4.0, "duration_s": 1.0, "friction_mu": 0.0,
                            "floor": {"material": "steel"}, "bodies": bodies}, "cradle5.yaml")
    cmp = compare_results(simulate_scene(scene), ode.simulate_scene_ode(scene))
    assert cmp.unmatched == [] and cmp.differing_bodies == []
    assert len(cmp.impacts) == 10


def test_compare_explains_the_rest_rule_as_it_is(ode):
    from vrcal.scenes.compare import EXPLANATIONS

    text = " ".join(EXPLANATIONS)
    assert "both use the scene's rest_speed_m_per_s" not in text
    assert "Ball-ball contacts bounce at any speed in both" in text
