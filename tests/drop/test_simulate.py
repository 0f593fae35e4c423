"""The event-driven drop simulator: exact drag-free series, closed-form drag flights, the CLI."""

import json
import math

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from vrcal.cli import main
from vrcal.drop.effects import drag_constant_per_m
from vrcal.drop.simulate import (
    distance_fallen_m,
    fall_from_rest,
    flight_up_down,
    height_rising_m,
    observations,
    sample_measurement,
    simulate_csv,
    simulate_drops,
)
from vrcal.errors import UsageError
from vrcal.model.body import BallProperties
from vrcal.model.standards import ball_epsilon, get_ball

G = 9.80665
TT = BallProperties(0.0027, 0.040, "table_tennis")
DRAG = {"air_drag": {"drag_coefficient": 0.5}}


# --------------------------------------------------------------------------- drag-free: Eqs. (8), (9)


@settings(max_examples=50, deadline=None)
@given(H=st.floats(0.01, 10.0), eps=st.floats(0.05, 1.0), n=st.integers(1, 15))
def test_apexes_and_impacts_follow_the_geometric_series(H, eps, n):
    d = simulate_drops(H, eps, n, TT)
    j = np.arange(n + 1)
    np.testing.assert_allclose(d.apex_heights_m[0], eps ** (2 * j) * H, rtol=1e-9, atol=0)
    t1 = math.sqrt(2 * H / G)
    # t_i = t1 + 2 t1 (eps + eps^2 + ... + eps^(i-1))
    expected = t1 + 2 * t1 * np.array([sum(eps ** np.arange(1, i)) for i in range(1, n + 1)])
    np.testing.assert_allclose(d.impact_times_s[0], expected, rtol=1e-9, atol=0)
    np.testing.assert_allclose(d.impact_speeds_m_per_s[0], math.sqrt(2 * G * H) * eps ** np.arange(n), rtol=1e-9)
    np.testing.assert_array_equal(d.liftoff_times_s, d.impact_times_s)


def test_first_bounce_of_each_standard_gives_its_epsilon():
    # Eq. (9): a drag-free drop of the standard's H with its nominal eps rebounds to its nominal h
    for key in ("basketball", "volleyball", "football", "tennis", "table_tennis"):
        ball = get_ball(key)
        w = ball_epsilon(ball)
        d = simulate_drops(w.drop_height_m, w.nominal, 1, ball)
        assert d.apex_heights_m[0, 1] == pytest.approx(w.rebound_m.nominal, rel=1e-12)


def test_trajectory_is_a_parabola_between_impacts():
    d = simulate_drops(1.0, 0.8, 3, TT, release_time_s=0.3)
    t = np.linspace(0, d.landing_times_s[0] + 0.1, 4001)
    y = d.height_m(t)[0]
    assert np.all(y[t < 0.3] == 1.0)                               # still segment
    fall = (t >= 0.3) & (t < d.impact_times_s[0, 0])
    np.testing.assert_allclose(y[fall], 1.0 - 0.5 * G * (t[fall] - 0.3) ** 2, rtol=0, atol=1e-12)
    assert np.all(y >= -1e-12)
    np.testing.assert_allclose(d.height_m(d.impact_times_s[0])[0], 0.0, atol=1e-12)
    np.testing.assert_allclose(d.height_m(d.apex_times_s[0])[0], d.apex_heights_m[0], rtol=1e-12)
    assert np.all(y[t > d.landing_times_s[0]] == 0.0)


# --------------------------------------------------------------------------- quadratic drag


@pytest.mark.parametrize("k", [0.02, 0.14, 1.5])
def test_closed_form_drag_flights_match_the_ode(k):
    def rhs(_t, s):
        return [s[1], -G - k * s[1] * abs(s[1])]

    def floor(_t, s):
        return s[0]

    floor.terminal, floor.direction = True, -1
    H, u = 1.2, 3.0
    sol = solve_ivp(rhs, (0, 10), [H, 0.0], events=floor, rtol=1e-12, atol=1e-14)
    t_fall, v = fall_from_rest(H, G, k)
    assert t_fall == pytest.approx(sol.t_events[0][0], rel=1e-9)
    assert v == pytest.approx(-sol.y_events[0][0][1], rel=1e-9)
    sol = solve_ivp(rhs, (0, 10), [0.0, u], events=floor, rtol=1e-12, atol=1e-14, dense_output=True)
    t_up, apex, t_down, v_land = flight_up_down(u, G, k)
    assert t_up + t_down == pytest.approx(sol.t_events[0][0], rel=1e-9)
    assert v_land == pytest.approx(-sol.y_events[0][0][1], rel=1e-9)
    assert apex == pytest.approx(sol.sol(t_up)[0], rel=1e-9)
    tau = np.linspace(0, t_up, 40)
    np.testing.assert_allclose(height_rising_m(tau, u, G, k), sol.sol(tau)[0], rtol=0, atol=1e-10)
    tau = np.linspace(0, t_down, 40)
    np.testing.assert_allclose(apex - distance_fallen_m(tau, G, k), sol.sol(t_up + tau)[0], rtol=0, atol=1e-10)


def test_simulated_drag_drop_matches_the_ode_across_bounces():
    d = simulate_drops(0.9, 0.85, 3, TT, effects=DRAG)
    k = d.k_per_m[0]

    def rhs(_t, s):
        return [s[1], -G - k * s[1] * abs(s[1])]

    def floor(_t, s):
        return s[0]

    floor.terminal, floor.direction = True, -1
    t, state, impacts = 0.0, [0.9, 0.0], []
    for _ in range(3):
        sol = solve_ivp(rhs, (t, t + 10), state, events=floor, rtol=1e-12, atol=1e-14)
        t = sol.t_events[0][0]
        impacts.append(t)
        state = [0.0, -0.85 * sol.y_events[0][0][1]]
    np.testing.assert_allclose(d.impact_times_s[0], impacts, rtol=1e-9)


@settings(max_examples=40, deadline=None)
@given(H=st.floats(0.05, 5.0), eps=st.floats(0.1, 1.0), cd=st.floats(0.01, 3.0))
def test_drag_never_adds_energy(H, eps, cd):
    free = simulate_drops(H, eps, 4, TT)
    d = simulate_drops(H, eps, 4, TT, effects={"air_drag": {"drag_coefficient": cd}})
    assert np.all(d.apex_heights_m[0, 1:] < free.apex_heights_m[0, 1:])
    # within each flight: landing slower than lift-off, apex below u^2 / (2 g)
    assert np.all(d.impact_speeds_m_per_s[0, 1:] < d.rebound_speeds_m_per_s[0, :-1])
    assert np.all(d.apex_heights_m[0, 1:] < d.rebound_speeds_m_per_s[0] ** 2 / (2 * G))
    assert np.all(np.diff(d.apex_heights_m[0]) < 0)
    # along the trajectory: g y + v^2 / 2 never grows (v from the exact heights, central differences)
    t = np.linspace(0, d.impact_times_s[0, 0], 2001)
    y = d.height_m(t)[0]
    v = np.gradient(y, t)
    energy = G * y[1:-1] + 0.5 * v[1:-1] ** 2
    assert np.all(np.diff(energy) <= 1e-6 * G * H)


@pytest.mark.parametrize("k", [1e-11, 1e-13, 1e-300, 1e-310])
def test_small_drag_tends_to_the_drag_free_drop(k):
    # the drag-free limit: differences shrink like k H, no cancellation error at small k
    cd = k / drag_constant_per_m(1.0, TT.diameter_m, TT.mass_kg)
    free = simulate_drops(1.3, 0.8, 6, TT)
    d = simulate_drops(1.3, 0.8, 6, TT, effects={"air_drag": {"drag_coefficient": cd}})
    assert d.k_per_m[0] == pytest.approx(k)
    np.testing.assert_allclose(d.impact_times_s, free.impact_times_s, rtol=1e-9)
    np.testing.assert_allclose(d.apex_heights_m, free.apex_heights_m, rtol=1e-9)
    t = np.linspace(0, free.landing_times_s[0], 500)
    np.testing.assert_allclose(d.height_m(t), free.height_m(t), rtol=0, atol=1e-9)


def test_zero_drag_gives_no_warnings_and_exact_limits():
    with np.errstate(all="raise"):
        t, v = fall_from_rest([0.0, 1.0], G, 0.0)
        t_up, apex, t_down, v_land = flight_up_down([0.0, 2.0], G, [0.0, 0.0])
    assert t[1] == math.sqrt(2 / G) and v[1] == math.sqrt(2 * G)
    assert apex[1] == 4 / (2 * G) and v_land[1] == 2.0


# --------------------------------------------------------------------------- effects in the timeline


def test_contact_duration_delays_each_flight_by_the_contact_time():
    base = simulate_drops(0.5, 0.9, 5, TT)
    d = simulate_drops(0.5, 0.9, 5, TT, effects={"contact_duration": {"contact_time_s": 0.004}})
    np.testing.assert_allclose(d.impact_times_s - base.impact_times_s, [0.004 * np.arange(5)], rtol=0, atol=1e-12)
    np.testing.assert_allclose(d.liftoff_times_s - d.impact_times_s, 0.004, atol=1e-12)
    # during the contact the bottom dips below the floor in a half sine of depth (v_in + v_out) tau_c / (2 pi)
    mid = 0.5 * (d.impact_times_s + d.liftoff_times_s)[0]
    depth = (d.impact_speeds_m_per_s + d.rebound_speeds_m_per_s)[0] * 0.004 / (2 * math.pi)
    np.testing.assert_allclose(d.height_m(mid)[0], -depth, rtol=1e-12)
    edges = np.concatenate([d.impact_times_s[0], d.liftoff_times_s[0]])
    np.testing.assert_allclose(d.height_m(edges)[0], 0.0, atol=1e-12)
    assert np.all(d.height_m(np.linspace(0, d.landing_times_s[0], 2000))[0] >= -depth.max() - 1e-12)


def test_a_fixed_reference_speed_gives_one_law_for_drops_from_several_heights():
    """With one v_ref for all drops, epsilon(v) is the same function of the impact speed."""
    eff = {"velocity_dependent_restitution": {"exponent": 0.3}}
    d = simulate_drops(np.array([0.3, 1.2]), 0.8, 4, TT, effects=eff, reference_speed_m_per_s=3.0)
    v, e = d.impact_speeds_m_per_s.ravel(), d.epsilons.ravel()
    np.testing.assert_allclose(e, 1 - 0.2 * (v / 3.0) ** 0.3, rtol=1e-12)
    own = simulate_drops(np.array([0.3, 1.2]), 0.8, 4, TT, effects=eff)
    np.testing.assert_allclose(own.epsilons[:, 0], 0.8)


def test_height_offset_shifts_every_observation():
    d = simulate_drops(0.5, 0.9, 3, TT, effects={"height_offset": {"offset_m": 0.02}})
    base = simulate_drops(0.5, 0.9, 3, TT)
    t = np.linspace(0, 2, 100)
    np.testing.assert_allclose(d.height_m(t) - base.height_m(t), 0.02, atol=1e-15)
    np.testing.assert_array_equal(d.apex_heights_m, base.apex_heights_m)
    np.testing.assert_allclose(d.observed_apex_heights_m, base.apex_heights_m + 0.02)


def test_velocity_dependent_restitution_keeps_eps_at_the_first_impact():
    d = simulate_drops(1.0, 0.8, 6, TT, effects={"velocity_dependent_restitution": {"exponent": 0.2}})
    assert d.epsilons[0, 0] == 0.8
    assert np.all(np.diff(d.epsilons[0]) > 0)          # slower impacts bounce better
    v = d.impact_speeds_m_per_s[0]
    np.testing.assert_allclose(1 - d.epsilons[0], 0.2 * (v / v[0]) ** 0.2, rtol=1e-12)


# --------------------------------------------------------------------------- vectorisation


def test_vectorised_equals_one_by_one():
    rng = np.random.default_rng(3)
    n = 7
    H = rng.uniform(0.2, 2.0, n)
    eps = rng.uniform(0.5, 0.95, n)
    cd = rng.uniform(0.0, 1.0, n)
    tc = rng.uniform(0.0, 0.01, n)
    mass = rng.uniform(0.002, 0.6, n)
    ball = BallProperties(mass, 0.04 + mass / 3)
    effects = {"air_drag": {"drag_coefficient": cd}, "contact_duration": {"contact_time_s": tc},
               "velocity_dependent_restitution": {"exponent": 0.2}, "buoyancy": {}}
    many = simulate_drops(H, eps, 5, ball, effects=effects, release_time_s=0.1)
    t = np.linspace(0, 4, 300)
    y_many = many.height_m(t)
    for i in range(n):
        one = simulate_drops(H[i], eps[i], 5, BallProperties(mass[i], 0.04 + mass[i] / 3), release_time_s=0.1,
                             effects={"air_drag": {"drag_coefficient": cd[i]},
                                      "contact_duration": {"contact_time_s": tc[i]},
                                      "velocity_dependent_restitution": {"exponent": 0.2}, "buoyancy": {}})
        for name in ("impact_times_s", "impact_speeds_m_per_s", "rebound_speeds_m_per_s", "apex_times_s",
                     "apex_heights_m", "liftoff_times_s", "epsilons"):
            np.testing.assert_array_equal(getattr(many, name)[i], getattr(one, name)[0], err_msg=name)
        np.testing.assert_array_equal(y_many[i], one.height_m(t)[0])


def test_monte_carlo_over_a_standards_tolerances_is_one_call():
    ball = get_ball("tennis")
    rng = np.random.default_rng(0)
    n = 1000
    props = BallProperties(rng.uniform(ball.mass_kg.min, ball.mass_kg.max, n),
                           rng.uniform(ball.diameter_m.min, ball.diameter_m.max, n))
    w = ball_epsilon(ball)
    d = simulate_drops(w.drop_height_m, rng.uniform(w.min, w.max, n), 3, props, effects=DRAG)
    assert d.apex_heights_m.shape == (n, 4)
    # with drag the first rebound lies below the drag-free window's top
    assert np.all(d.apex_heights_m[:, 1] < w.rebound_m.max)


# --------------------------------------------------------------------------- bad input


@pytest.mark.parametrize("kwargs, message", [
    (dict(drop_height_m=-1.0), "drop height"),
    (dict(drop_height_m=0.0), "drop height"),
    (dict(epsilon=1.2), "epsilon"),
    (dict(epsilon=0.0), "epsilon"),
    (dict(n_bounces=0), "n_bounces"),
    (dict(n_bounces=2.5), "n_bounces"),
    (dict(drop_height_m=[1.0, 2.0], epsilon=[0.5, 0.6, 0.7]), "broadcast"),
    (dict(effects={"air_drag": {"cd": 1}}), "valid: drag_coefficient"),
    (dict(effects={"spin": {}}), "unknown effect"),
])
def test_bad_input_is_a_usage_error(kwargs, message):
    args = dict(drop_height_m=1.0, epsilon=0.8, n_bounces=3)
    args.update(kwargs)
    with pytest.raises(UsageError, match=message):
        simulate_drops(args.pop("drop_height_m"), args.pop("epsilon"), args.pop("n_bounces"), TT, **args)


# --------------------------------------------------------------------------- CLI


def run(*args):
    return CliRunner().invoke(main, list(args))


def test_cli_apexes(tmp_path):
    out = tmp_path / "a.csv"
    result = run("simulate", "table_tennis", "--bounces", "3", "--format", "apexes", "-o", str(out))
    assert result.exit_code == 0, result.output
    lines = out.read_text().splitlines()
    assert lines[0] == "bounce,h [m]" and len(lines) == 5
    w = ball_epsilon(get_ball("table_tennis"))
    assert float(lines[2].split(",")[1]) == pytest.approx(w.nominal ** 2 * 0.305, rel=1e-9)


def test_cli_impacts_and_trajectory_are_repeatable(tmp_path):
    for fmt, header in (("impacts", "t [s]"), ("trajectory", "t [s],y [m]")):
        a, b = tmp_path / f"{fmt}1.csv", tmp_path / f"{fmt}2.csv"
        args = ["simulate", "basketball", "--bounces", "4", "--format", fmt, "--noise", "0.002", "--jitter",
                "0.0002", "--seed", "5", "--effect", "air_drag", "--effect", "contact_duration:contact_time_s=0.008"]
        assert run(*args, "-o", str(a)).exit_code == 0
        assert run(*args, "-o", str(b)).exit_code == 0
        assert a.read_text() == b.read_text()
        assert a.read_text().splitlines()[0] == header
    rows = np.loadtxt(tmp_path / "trajectory1.csv", delimiter=",", skiprows=1)
    assert np.all(np.diff(rows[:, 0]) > 0)
    assert rows[0, 0] == 0.0 and abs(rows[0, 1] - 1.8) < 0.01          # still at the drop height
    assert 1 / np.median(np.diff(rows[:, 0])) == pytest.approx(240.0)


def test_cli_output_reads_back(tmp_path):
    """The headers carry units (t [s], y [m], h [m]) and the readers take the numbers back unchanged."""
    from vrcal.measurements import read_measurement

    for fmt in ("trajectory", "impacts", "apexes"):
        out = tmp_path / f"{fmt}.csv"
        assert run("simulate", "tennis", "--bounces", "3", "--format", fmt, "-o", str(out)).exit_code == 0
        m = read_measurement(str(out))
        assert m.kind == fmt
        written = np.loadtxt(out, delimiter=",", skiprows=1, ndmin=2)
        read = {"trajectory": lambda: (m.t_s, m.y_m), "impacts": lambda: (m.t_s,),
                "apexes": lambda: (m.bounce, m.h_m)}[fmt]()
        np.testing.assert_array_equal(np.column_stack(read), written)


def test_cli_simulate_then_discover_round_trip(tmp_path):
    """`vrcal simulate` writes what `vrcal discover` reads: a planted epsilon comes back."""
    data, result = tmp_path / "impacts.csv", tmp_path / "result.json"
    assert run("simulate", "tennis", "--bounces", "5", "--format", "impacts", "--epsilon", "0.75",
               "-o", str(data)).exit_code == 0
    done = run("discover", str(data), "--ball", "tennis", "-q", "--json", str(result))
    assert done.exit_code == 0, done.output
    assert json.loads(result.read_text())["epsilon"] == pytest.approx(0.75, abs=1e-6)


def test_a_ball_lighter_than_its_air_is_refused_with_the_densities():
    """The refusal says at which air density, the ball's own density, and what to give instead."""
    result = run("simulate", "--mass", "0.1", "--diameter", "0.5", "--drop", "2", "--epsilon", "0.877", "--effect",
                 "buoyancy:air_density_kg_per_m3=1.6")
    assert result.exit_code == 2
    assert ("at an air density of 1.6 kg/m^3 a ball of 0.1 kg and 0.5 m (1.528 kg/m^3) is lighter than the air it "
            "displaces (it would not fall); give an air density below 1.528 kg/m^3") in " ".join(result.output.split())


def test_cli_virtual_body_and_free_ball():
    result = run("simulate", "marble", "--mass", "0.005", "--diameter", "0.016", "--drop", "0.5",
                 "--x", "0.01", "--v", "0.05", "--K", "4", "--bounces", "1", "--format", "apexes")
    assert result.exit_code == 0, result.output
    eps = math.exp(-4 * 0.01 / (2 * 0.05))           # Eqs. (10) and (7)
    assert float(result.output.splitlines()[2].split(",")[1]) == pytest.approx(eps ** 2 * 0.5, rel=1e-9)


@pytest.mark.parametrize("args, message", [
    (["--effect", "air_dragg"], "unknown effect 'air_dragg'; did you mean 'air_drag'"),
    (["--effect", "air_drag:cd=1"], "valid: drag_coefficient"),
    (["--effect", "air_drag:drag_coefficient=x"], "must be a number"),
    (["--bounces", "0"], "--bounces must be an integer between 1 and 1000"),
    (["--drop", "-1"], "--drop must be a number between"),
    (["--epsilon", "1.5"], "--epsilon must be a number between 0.001 and 1"),
    (["--noise", "-1"], "noise must be"),
    (["--x", "0.01"], "needs both --x"),
    (["--fs", "0"], "--fs must be"),
])
def test_cli_bad_input(args, message):
    result = run("simulate", "table_tennis", *args)
    assert result.exit_code == 2
    assert message in result.output
    assert "Traceback" not in result.output


def test_cli_unknown_ball_without_mass():
    result = run("simulate", "marble", "--epsilon", "0.5")
    assert result.exit_code == 2 and "give --mass and --diameter" in result.output


def test_sample_measurement_rejects_unknown_format():
    d = simulate_drops(1.0, 0.8, 2, TT)
    with pytest.raises(UsageError, match="valid: trajectory, impacts, apexes"):
        sample_measurement(d, "video")


def test_simulate_csv_defaults_to_the_standard():
    text = simulate_csv("football", kind="apexes", n_bounces=1)
    w = ball_epsilon(get_ball("football"))
    h0, h1 = (float(line.split(",")[1]) for line in text.splitlines()[1:])
    assert h0 == w.drop_height_m and h1 == pytest.approx(w.rebound_m.nominal, rel=1e-9)


def test_observations_of_each_kind():
    d = simulate_drops([0.5, 1.0], 0.8, 3, TT, effects={"height_offset": {"offset_m": 0.02}})
    t = np.linspace(0, 1, 11)
    assert observations(d, "trajectory", t).shape == (2, 11)
    np.testing.assert_array_equal(observations(d, "impacts"), d.impact_times_s)
    np.testing.assert_allclose(observations(d, "apexes")[:, 0], [0.52, 1.02])
    with pytest.raises(UsageError, match="need the sample times"):
        observations(d, "trajectory")
    with pytest.raises(UsageError, match="unknown format"):
        observations(d, "video")


# --------------------------------------------------------------------------- the closed forms' inputs


@pytest.mark.parametrize("call", [
    lambda: fall_from_rest(-1.0, G, 0.0), lambda: fall_from_rest(1.0, 0.0, 0.0), lambda: fall_from_rest(1.0, G, -0.02),
    lambda: flight_up_down(-1.0, G, 0.02), lambda: distance_fallen_m(-1.0, G, 0.02),
])
def test_closed_forms_refuse_negative_heights_speeds_times_and_drag(call):
    with np.errstate(all="raise"):
        with pytest.raises(UsageError):
            call()


@given(H=st.floats(0.0, 10.0), k=st.one_of(st.just(0.0), st.floats(1e-6, 1.0)))
@settings(max_examples=50, deadline=None)
def test_closed_forms_give_floats_for_scalars_and_the_same_numbers_for_arrays(H, k):
    t, v = fall_from_rest(H, G, k)
    flight = flight_up_down(v, G, k)
    assert all(type(x) is float for x in (t, v, *flight))
    ta, va = fall_from_rest(np.full(2, H), G, k)
    assert ta.tolist() == [t, t] and va.tolist() == [v, v]
    assert [a.tolist() for a in flight_up_down(np.full(2, v), G, k)] == [[x, x] for x in flight]


def test_height_m_takes_one_time():
    d = simulate_drops(1.0, 0.8, 2, BallProperties(0.058, 0.067))
    assert d.height_m(0.1).tolist() == d.height_m(np.array([0.1])).tolist()
