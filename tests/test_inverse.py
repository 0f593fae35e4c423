"""Tests of vrcal.inverse: epsilon -> (x, v) families and the two-body pair (Eqs. 6, 7, 10 of [1])."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vrcal.errors import UsageError
from vrcal.inverse import DEFAULT_K_PER_S, family, fit_ball, fit_text, pair
from vrcal.model import restitution as eq
from vrcal.model.standards import ball_epsilon, get_ball


@pytest.mark.parametrize("key", ["basketball", "volleyball", "football", "tennis", "table_tennis"])
@pytest.mark.parametrize("K", [0.5, DEFAULT_K_PER_S, 40.0])
def test_family_members_give_the_nominal_epsilon_back(key, K):
    result = fit_ball(key, K, n=7)
    eps = result["epsilon"]["nominal"]
    assert eps == pytest.approx(ball_epsilon(get_ball(key)).nominal, rel=1e-15)
    assert len(result["family"]) == 7
    R = get_ball(key).radius_m
    for member in result["family"]:
        assert 0 < member["x_m"] <= R * (1 + 1e-12)
        forward = eq.epsilon_single(member["x_m"], member["v_m_per_s"], K)
        assert forward == pytest.approx(eps, rel=1e-12)


def test_json_keys_required_by_the_issue():
    result = fit_ball("basketball")
    for key in ("ball", "K_per_s", "epsilon", "T_s", "family"):
        assert key in result
    for level in ("min", "nominal", "max"):
        assert level in result["epsilon"] and level in result["T_s"]
    # min and max are bounds by value; the shortest T belongs to epsilon max (Eq. 7)
    assert result["T_s"]["min"] < result["T_s"]["nominal"] < result["T_s"]["max"]
    K = result["K_per_s"]
    assert result["T_s"]["min"] == pytest.approx(-math.log(result["epsilon"]["max"]) / K, rel=1e-12)
    assert result["T_s"]["max"] == pytest.approx(-math.log(result["epsilon"]["min"]) / K, rel=1e-12)


def test_fixed_x_gives_v_range_and_fixed_v_gives_x_range():
    K = 4.0
    fx = fit_ball("football", K, x_m=0.02)["fixed"]
    for level in ("min", "nominal", "max"):
        # a faster virtual body at fixed x gives a larger epsilon: v min..max maps to epsilon min..max
        eps = fit_ball("football", K)["epsilon"][level]
        assert eq.epsilon_single(0.02, fx["v_m_per_s"][level], K) == pytest.approx(eps, rel=1e-12)
    fv = fit_ball("football", K, v_m_per_s=0.3)["fixed"]
    eps = fit_ball("football", K)["epsilon"]
    # a deeper virtual body gives a smaller epsilon (Sec. 5 of [1]): x max belongs to epsilon min
    assert fv["x_m"]["min"] < fv["x_m"]["nominal"] < fv["x_m"]["max"]
    assert eq.epsilon_single(fv["x_m"]["max"], 0.3, K) == pytest.approx(eps["min"], rel=1e-12)
    assert eq.epsilon_single(fv["x_m"]["min"], 0.3, K) == pytest.approx(eps["max"], rel=1e-12)


def test_x_and_v_together_is_a_usage_error():
    with pytest.raises(UsageError, match="not both"):
        fit_ball("football", 4.0, x_m=0.01, v_m_per_s=0.1)


@pytest.mark.parametrize("K", [0.0, -3.0, float("nan")])
def test_bad_K(K):
    with pytest.raises(UsageError, match="K must be"):
        fit_ball("tennis", K)


def test_as_paper_basketball_is_085():
    """Table 1 of [1]: basketball epsilon 0.85 (1.3 m rebound from 1.8 m, no point correction)."""
    assert fit_ball("basketball", as_paper=True)["epsilon"]["nominal"] == pytest.approx(0.85, abs=0.001)


def test_pair_is_product_of_single_epsilons_and_independent_of_K():
    """Eq. (6): the contact times add, so epsilon_AB = epsilon_A * epsilon_B for balls calibrated on a rigid floor."""
    eps_b = ball_epsilon(get_ball("basketball")).nominal
    eps_t = ball_epsilon(get_ball("tennis")).nominal
    for K in (0.7, 4.0, 60.0):
        result = pair("basketball", "tennis", K)
        assert result["epsilon"] == pytest.approx(eps_b * eps_t, rel=1e-12)


def test_pair_with_floor_and_explicit_bodies():
    assert pair("tennis", "floor")["epsilon"] == pytest.approx(ball_epsilon(get_ball("tennis")).nominal, rel=1e-12)
    result = pair("x=0.01,v=0.1", "x=0.03,v=0.5", 4.0)
    assert result["T_s"] == pytest.approx(0.08)
    assert result["epsilon"] == pytest.approx(math.exp(-0.32))
    with pytest.raises(UsageError, match="x=DEPTH"):
        pair("x=0.01", "floor")


def test_family_spacing():
    x, v = family(0.05, 0.1, 4)
    np.testing.assert_allclose(x, [0.025, 0.05, 0.075, 0.1])
    np.testing.assert_allclose(v, x / 0.1)
    with pytest.raises(UsageError):
        family(0.05, 0.1, 0)


@settings(max_examples=100, deadline=None)
@given(eps=st.floats(0.01, 0.999), K=st.floats(0.01, 100.0))
def test_fit_then_forward_round_trip(eps, K):
    """Property: for any epsilon in (0, 1) and K > 0 the inverted family gives epsilon back to 1e-12."""
    T = eq.contact_time_from_epsilon_s(eps, K)
    x, v = family(T, 0.1, 5)
    np.testing.assert_allclose(eq.epsilon_single(x, v, K), eps, rtol=1e-12)


def test_own_drop_test_gives_eq9_and_its_model_time():
    """A teacher's own drop: H = 1 m, h = 0.55 m to the bottom of a 67 mm ball: epsilon = sqrt(0.55)
    (Eq. 9), T = -ln(epsilon)/K (Eq. 7); read to the ball's top, h is brought down by the diameter."""
    from vrcal.model.body import describe_body

    body = describe_body(None, mass_kg=0.0577, diameter_m=0.067)
    r = fit_ball(body, 4.0, drop_height_m=1.0, rebound_height_m=0.55, rebound_measured_to="bottom")
    assert r["epsilon"]["nominal"] == pytest.approx(math.sqrt(0.55))
    assert r["T_s"]["nominal"] == pytest.approx(-math.log(math.sqrt(0.55)) / 4.0)
    assert r["drop_height_m"] == 1.0 and r["rebound_height_m"] == pytest.approx(0.55)
    top = fit_ball(body, 4.0, drop_height_m=1.0, rebound_height_m=0.6, rebound_measured_to="top")
    assert top["epsilon"]["nominal"] == pytest.approx(math.sqrt(0.6 - 0.067))
    assert top["rebound_height_m"] == pytest.approx(0.533)


@pytest.mark.parametrize("drop_to, rebound_to", [("centre", "centre"), ("top", "top"), ("centre", None)])
def test_own_drop_test_brings_both_heights_to_the_bottom(drop_to, rebound_to):
    """Eq. 9 takes heights of the ball's bottom: the centre falls H_bottom before contact. A tennis ball
    (D = 0.067 m) read to the centre, H_c = 1.0 m, h_c = 0.6 m: by hand sqrt((0.6 - 0.0335)/(1.0 - 0.0335))
    = 0.7656 -- not sqrt(0.6/1.0) = 0.7746 ("the same point"), nor 0.7527 (drop left at the bottom)."""
    from vrcal.model.standards import get_ball

    D = get_ball("tennis").diameter_m.nominal   # 0.066995 m
    offset = {"centre": D / 2, "top": D, None: 0.0}
    r = fit_ball("tennis", 4.0, drop_height_m=1.0, rebound_height_m=0.6, drop_measured_to=drop_to,
                 rebound_measured_to=rebound_to)
    hand = math.sqrt((0.6 - offset[rebound_to]) / (1.0 - offset[drop_to]))
    assert r["epsilon"]["nominal"] == pytest.approx(hand, rel=1e-12)
    assert r["drop_height_m"] == pytest.approx(1.0 - offset[drop_to])
    if drop_to == rebound_to == "centre":
        assert round(r["epsilon"]["nominal"], 4) == 0.7656


def test_own_drop_test_without_a_body_gives_eq9_and_says_what_needs_the_ball():
    """Eq. (9) needs no mass: 'vrcal fit --drop-height 1 --rebound-height 0.64' demanded --mass/--diameter. The
    family (depths up to the radius) and the drag check need the ball; a note says so, and a height read to the
    ball's top or centre cannot be brought to its bottom."""
    from vrcal.inverse import NO_BODY_NOTE

    r = fit_ball(None, 4.0, drop_height_m=1.0, rebound_height_m=0.64)
    assert r["epsilon"] == {"nominal": pytest.approx(0.8, rel=1e-12)} and r["ball"] is None
    assert r["T_s"]["nominal"] == pytest.approx(-math.log(0.8) / 4.0)
    assert "family" not in r and "epsilon_with_drag" not in r and NO_BODY_NOTE in r["notes"]
    assert fit_ball(None, 4.0, drop_height_m=1.0, rebound_height_m=0.64, x_m=0.01)["fixed"]["v_m_per_s"][
        "nominal"] == pytest.approx(0.01 / (2 * r["T_s"]["nominal"]))
    with pytest.raises(UsageError, match="to the ball's top: bringing it to the bottom needs the ball's diameter"):
        fit_ball(None, 4.0, drop_height_m=1.0, rebound_height_m=0.64, rebound_measured_to="top")
    with pytest.raises(UsageError, match="^no body"):
        fit_ball(None, 4.0, epsilon=0.8)


@pytest.mark.parametrize("heights, epsilon, message", [
    ((1.0, None, "bottom"), None, "needs both --drop-height and --rebound-height"),
    ((1.0, 0.5, "bottom"), 0.7, "not both"),
    ((100.0, 55.0, "bottom"), None,
     r"^--drop-height must be at most 20 m \(higher than a drop test is made from\), got 100; "
     r"--drop-height is in m: 100 cm = 1 m$"),
    ((1.0, 1.5, "bottom"), None, "cannot rebound higher"),
    ((1.0, 0.05, "top"), None, r"^--rebound-height 0.05 m to the ball's top: a height to the top cannot be below "
                               r"the diameter D = 0.067 m"),
    ((1.0, 0.02, "centre"), None, "cannot be below the radius D/2 = 0.0335 m"),
])
def test_own_drop_test_bad_input_is_a_usage_error(heights, epsilon, message):
    from vrcal.model.body import describe_body

    body = describe_body(None, mass_kg=0.0577, diameter_m=0.067)
    with pytest.raises(UsageError, match=message):
        drop, rebound, point = heights
        fit_ball(body, 4.0, drop_height_m=drop, rebound_height_m=rebound, rebound_measured_to=point, epsilon=epsilon)


def test_epsilon_one_is_the_lossless_body_x_0_v_0():
    """epsilon = 1: T = 0 (Eq. 7), which only x = 0 has (Eq. 10); [1] gives that body no speed (v = 0).
    The machine file holds plain numbers (no null, no inf), and --x cannot be fixed."""
    import json

    from vrcal.fileio import dumps
    from vrcal.model.body import describe_body

    body = describe_body(None, mass_kg=0.0027, diameter_m=0.04)
    r = fit_ball(body, 4.0, epsilon=1.0)
    assert r["T_s"]["nominal"] == 0.0
    assert r["family"] == [{"x_m": 0.0, "v_m_per_s": 0.0}]
    assert eq.contact_time_single_s(r["family"][0]["x_m"], r["family"][0]["v_m_per_s"]) == 0.0
    text = dumps(r, "json")
    assert "null" not in text and "Infinity" not in text and json.loads(text)["family"][0]["v_m_per_s"] == 0.0
    assert any("x = 0" in n for n in r["notes"])
    assert "inf" not in fit_text(r)
    assert fit_ball(body, 4.0, epsilon=1.0, v_m_per_s=0.1)["fixed"]["x_m"]["nominal"] == 0.0
    with pytest.raises(UsageError, match="only x = 0"):
        fit_ball(body, 4.0, epsilon=1.0, x_m=0.01)


@pytest.mark.parametrize("spec, message", [
    ("x=0.01,v=0.1,x=0.5", "body 'x=0.01,v=0.1,x=0.5': x= given more than once; give each of x= and v= once"),
    ("v=0.1,x=0.01,v=0.2", "v= given more than once"),
    ("x=0.01,v=0.1,x=0.5,v=1", "v= and x= given more than once"),
])
def test_a_repeated_virtual_body_key_is_refused_not_the_last_kept(spec, message):
    """`vrcal pair x=0.01,v=0.1,x=0.5 floor` kept x = 0.5 silently (a dict keeps the last)."""
    with pytest.raises(UsageError, match=message.replace("(", r"\(").replace(")", r"\)")):
        pair(spec, "floor")


def test_a_discovered_balls_left_out_effects_are_named_in_the_pair(tmp_path):
    """`vrcal pair from=DISCOVER.json tennis` dropped a speed-dependent epsilon with no note: the notes name
    what is left out and the impact speed the constant epsilon holds at."""
    from click.testing import CliRunner

    from vrcal.cli import main

    runner = CliRunner()
    csv, doc = tmp_path / "vdr.csv", tmp_path / "vdr.json"
    assert runner.invoke(main, ["simulate", "basketball", "--effect", "velocity_dependent_restitution",
                                "--noise", "0.0005", "--seed", "1", "-o", str(csv)]).exit_code == 0
    assert runner.invoke(main, ["discover", str(csv), "--ball", "basketball", "--json", str(doc), "-q"]).exit_code == 0
    result = pair(f"from={doc}", "tennis")
    notes = " ".join(result["notes"])
    assert "velocity_dependent_restitution left out" in notes
    assert "the pair takes its one constant epsilon" in notes and " m/s impacts" in notes
    assert notes.count(" m/s") == 1   # the speed it holds at, said once (two notes said it)
    assert pair("football", "tennis")["notes"] == []   # balls of the standards tested on rigid floors: no note


# ------------------------------------------------------------------ the paper's drop tests, read as a physicist


@pytest.mark.parametrize("key", ["basketball", "volleyball", "football", "tennis", "table_tennis"])
def test_a_standard_ball_gives_its_window_with_air_drag_as_its_own_heights_do(key):
    """A referee found `vrcal fit basketball` silent on drag where the same ball's own heights (--mass,
    --diameter, --drop-height 1.8, --rebound-height 1.0567) noted the contact's ε 0.790. Both now say it, with
    the same function: Eq. 9's ε stays the result (an engine without drag), the window's with-drag ε beside it."""
    from vrcal.inverse import drop_test_drag

    ball = get_ball(key)
    r = fit_ball(key)
    window = ball_epsilon(ball)
    with_drag = r["epsilon_with_drag"]
    assert set(with_drag) == {"min", "nominal", "max"}
    for level, h in (("min", window.rebound_m.min), ("nominal", window.rebound_m.nominal),
                     ("max", window.rebound_m.max)):
        own = fit_ball(None, drop_height_m=window.drop_height_m, rebound_height_m=h)["epsilon"]["nominal"]
        assert r["epsilon"][level] == pytest.approx(own, rel=1e-12)       # Eq. 9 stays the result
        same = drop_test_drag(ball.mass_kg.nominal, ball.diameter_m.nominal, window.drop_height_m, h)
        assert with_drag[level] == pytest.approx(same["epsilon_with_drag"], rel=1e-12)
        assert with_drag[level] > r["epsilon"][level] + 0.01              # drag hides 0.02-0.04 at every test
    assert "ε, drag" in fit_text(r)
    assert "epsilon_with_drag" not in fit_ball(key, as_paper=True)       # the paper's Eq. 9 is drag-free


def test_as_paper_notes_say_what_was_read_not_vrcals_own_window():
    """`fit football --as-paper` computed with 1.2-1.65 m while its note said "vrcal uses the current FIFA
    Quality Pro window 1.35-1.55 m"; the basketball's one printed rebound read as a window "(0.850 .. 0.850)"."""
    football = fit_ball("football", as_paper=True)
    notes = " ".join(football["notes"])
    assert "h = 1.2-1.65 m" in notes and "1.35-1.55" not in notes
    assert football["epsilon"]["min"] == pytest.approx(math.sqrt(1.2 / 2.0), rel=1e-12)
    text = fit_text(fit_ball("basketball", as_paper=True))
    assert text.startswith("basketball: ε = 0.850 (one value)") and "0.850 .. 0.850" not in text


@settings(max_examples=60, deadline=None)
@given(H=st.floats(0.2, 5.0), ratio=st.floats(0.05, 0.95), sd_H=st.floats(0.0, 0.01), sd_h=st.floats(0.0, 0.01))
def test_epsilon_uncertainty_from_heights_is_the_first_order_propagation(H, ratio, sd_H, sd_h):
    """u(ε) of Eq. 9 against a numerical derivative of sqrt(h/H); scalar and array inputs agree."""
    from vrcal.inverse import epsilon_uncertainty_from_heights

    h = ratio * H
    step = 1e-7
    d_h = (math.sqrt((h + step) / H) - math.sqrt((h - step) / H)) / (2 * step)
    d_H = (math.sqrt(h / (H + step)) - math.sqrt(h / (H - step))) / (2 * step)
    u = epsilon_uncertainty_from_heights(h, H, sd_h, sd_H)
    assert u == pytest.approx(math.hypot(d_h * sd_h, d_H * sd_H), rel=1e-5, abs=1e-12)
    arr = epsilon_uncertainty_from_heights(np.array([h, h]), np.array([H, H]), sd_h, sd_H)
    assert np.all(arr == u)


def test_one_drop_test_has_a_plus_minus_from_its_heights():
    """`vrcal fit tennis --drop-height 1 --rebound-height 0.6 --rebound-measured-to top` printed 0.7301 with no
    ± and no way to say how well the heights were read. A Monte Carlo of the readings agrees with the ±."""
    from vrcal.inverse import HEIGHT_SD_FLOOR_M

    r = fit_ball("tennis", drop_height_m=1.0, rebound_height_m=0.6, rebound_measured_to="top")
    assert r["height_sd_m"] == {"drop": HEIGHT_SD_FLOOR_M, "rebound": pytest.approx(0.006)}   # 1 % of 0.6 m
    assert "assumed" in r["height_sd_source"]
    rng = np.random.default_rng(3)
    D = get_ball("tennis").diameter_m.nominal
    h = 0.6 + rng.normal(0, 0.006, 200_000) - D
    H = 1.0 + rng.normal(0, 0.002, 200_000)
    assert r["epsilon_uncertainty"] == pytest.approx(float(np.std(np.sqrt(h / H))), rel=0.02)
    given_sd = fit_ball(None, drop_height_m=1.0, rebound_height_m=0.64, height_sd_m=0.005)
    assert given_sd["epsilon_uncertainty"] == pytest.approx(0.8 / 2 * math.hypot(0.005 / 0.64, 0.005), rel=1e-12)
    assert given_sd["height_sd_source"] == "given (--height-sd)"
    assert "0.8000 ± 0.0037" in fit_text(given_sd)
    with pytest.raises(UsageError, match="--height-sd is the uncertainty of your own drop test"):
        fit_ball("tennis", height_sd_m=0.005)


def test_a_height_converted_to_the_bottom_is_said_when_refused():
    """`--drop-measured-to top` refused a rebound with "H = 0.933005 m", a number the user never typed."""
    with pytest.raises(UsageError, match=r"H = 1 m to the top \(0\.933 m to the bottom\)"):
        fit_ball("tennis", drop_height_m=1.0, rebound_height_m=1.03, drop_measured_to="top")
    with pytest.raises(UsageError, match=r"h = 1.0000001 m exceeds drop height H = 1 m"):
        fit_ball(None, drop_height_m=1.0, rebound_height_m=1.0000001)


def test_pair_says_when_a_virtual_body_cannot_be_a_balls_or_a_floor_is_not_rigid():
    """`vrcal pair x=5,v=0.42 floor` (Table 2's basketball row typed as printed) gave ε 4.6e-11 without a word;
    the basketball's ε, FIBA's on a playing floor, was taken as against a rigid floor silently."""
    notes = " ".join(pair("x=5,v=0.42", "floor")["notes"])
    assert "x = 5 m is deeper than the radius of any ball of the standards" in notes
    assert "no bounce a drop test could see" in notes
    assert pair("x=0.01,v=0.1", "floor")["notes"] == []
    assert "playing floor, not a rigid one" in " ".join(pair("basketball", "floor")["notes"])
    assert "not stated" in " ".join(pair("volleyball", "tennis")["notes"])


def test_a_height_sd_beyond_first_order_is_refused_and_zero_gives_no_plus_minus():
    """A re-check: `--height-sd 1` for a 0.53 m rebound printed 0.7301 ± 0.7761 (first order far out of its
    range); `--height-sd 0` dropped the ± but the note still explained it."""
    with pytest.raises(UsageError, match=r"--height-sd 1 m is 188 % of a height .* does not hold beyond 10 %"):
        fit_ball("tennis", drop_height_m=1.0, rebound_height_m=0.6, rebound_measured_to="top", height_sd_m=1.0)
    exact = fit_ball(None, drop_height_m=1.0, rebound_height_m=0.64, height_sd_m=0.0)
    assert exact["epsilon_uncertainty"] == 0.0 and "±" not in fit_text(exact).splitlines()[4]
    assert "heights taken as exact (--height-sd 0): no ± of ε" in exact["notes"]
    low = fit_ball(None, drop_height_m=1.0, rebound_height_m=0.01)      # an assumed 2 mm on 1 cm: given, not refused
    assert low["epsilon_uncertainty"] == pytest.approx(0.1 / 2 * math.hypot(0.2, 0.002), rel=1e-9)
