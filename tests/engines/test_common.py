"""The drop-test setup, its target (vrcal's model) and measuring an engine's run."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vrcal.drop.simulate import simulate_drops
from vrcal.engines.common import (
    DropSetup,
    StillBouncing,
    check_counts,
    check_dt,
    check_steps,
    floor_speed_m_per_s,
    measure_bounces,
    phase_shifts_m,
    round_down,
)
from vrcal.errors import DataError, UsageError
from vrcal.model.body import BallProperties


def semi_implicit_flight(z0, v0, g, dt, n):
    """A free flight stepped as ODE/Bullet/MuJoCo's Euler do: velocity first, then position."""
    z, v = [z0], [v0]
    for _ in range(n):
        v.append(v[-1] - g * dt)
        z.append(z[-1] + v[-1] * dt)
    return np.array(z), np.array(v)


@settings(max_examples=40, deadline=None)
@given(st.floats(0.1, 3.0), st.floats(1e-4, 5e-3), st.integers(5, 200))
def test_floor_speed_is_exact_for_a_semi_implicit_flight(H, dt, k):
    # every sample of one stepped flight from rest gives the same speed at floor level
    g = 9.80665
    z, v = semi_implicit_flight(H, 0.0, g, dt, 400)
    k = min(k, int(np.argmax(z < 0)) - 1 if np.any(z < 0) else 399)
    first = floor_speed_m_per_s(z[1], v[1], g, dt, True)
    later = floor_speed_m_per_s(z[k], v[k], g, dt, True)
    assert later == pytest.approx(first, rel=1e-9)
    # the exact-flight formula is off by about g dt / 2 [m/s]
    assert abs(floor_speed_m_per_s(z[k], v[k], g, dt, False) - first) <= g * dt


@settings(max_examples=40, deadline=None)
@given(st.floats(0.3, 8.0), st.floats(1e-4, 5e-3), st.floats(0.0, 1.0))
def test_floor_speed_is_the_speed_of_the_parabola_the_positions_lie_on(v_up, dt, start):
    """A stepped flight rising from the floor and falling back: its positions lie on a parabola with
    acceleration -g; the floor speed of a rising and of a falling sample is that parabola's speed at
    z = 0, the same both ways (an earlier reading carried the stored velocity, half a step behind the
    positions: up g dt/2 high on the way up, g dt/2 low on the way down)."""
    g = 9.80665
    z, v = semi_implicit_flight(-start * v_up * dt, v_up, g, dt, int(2.5 * v_up / (g * dt)) + 2)
    n = np.arange(z.size)
    a, b, c = np.polyfit(n * dt, z, 2)                 # the parabola through the positions
    assert a == pytest.approx(-g / 2, rel=1e-6)
    parabola = math.sqrt(b * b - 4 * a * c)          # its speed where it crosses z = 0
    up, down = 1, int(np.flatnonzero(v < 0)[0]) + 1  # a rising and a falling sample
    rising = floor_speed_m_per_s(z[up], v[up], g, dt, True)
    falling = floor_speed_m_per_s(z[down], v[down], g, dt, True)
    assert rising == pytest.approx(parabola, rel=1e-6, abs=1e-9)
    assert falling == pytest.approx(parabola, rel=1e-6, abs=1e-9)
    apex = float(np.max(z))                          # and the sampled apex lies within g dt^2/8 of its own
    assert 0 <= parabola ** 2 / (2 * g) - apex <= g * dt * dt / 8 * (1 + 1e-6) + 1e-12


def test_a_contact_that_reverses_the_stored_velocity_reads_epsilon_one_exactly():
    """ODE's bounce 1 and MuJoCo's damper D = 2/dt set the stored velocity to minus the one before:
    v_out/v_in reads 1 exactly at any step and contact phase (an earlier reading gave 1.020 for a
    2.45 m/s impact at 5 ms)."""
    for dt in (1e-3, 5e-3):
        for phase in np.linspace(0, 0.9, 4):
            z, v = planted_drop(2.0, eps=1.0, dt=dt, H=0.305 + phase * 2.45 * dt)
            b = measure_bounces(np.array(z), np.array(v), 0.305 + phase * 2.45 * dt, dt, 9.80665, 3)
            assert np.allclose(b.velocity_ratios, 1.0, atol=1e-9)
            assert np.allclose(b.apex_ratios, 1.0, atol=dt * dt)


def planted_drop(duration_s, eps=0.6, dt=1e-4, g=9.80665, H=1.0):
    """(z, v) of a stepped drop from H [m] with an instantaneous velocity reversal at each floor crossing."""
    z, v = [H], [0.0]
    for _ in range(int(duration_s / dt)):
        vn = v[-1] - g * dt
        zn = z[-1] + vn * dt
        if zn < 0 and vn < 0:
            vn = -eps * v[-1]                      # the contact step reverses the incoming velocity
            zn = z[-1] + vn * dt
        v.append(vn)
        z.append(zn)
    return z, v


def test_measure_bounces_of_a_planted_bounce():
    """A stepped drop with an instantaneous velocity reversal (eps 0.6) at each floor crossing."""
    g, dt, eps = 9.80665, 1e-4, 0.6
    z, v = planted_drop(3.0, eps, dt, g)
    b = measure_bounces(np.array(z), np.array(v), 1.0, dt, g, 3)
    assert np.allclose(b.velocity_ratios, eps, atol=2e-3)
    assert np.allclose(b.apex_ratios, eps, atol=3e-3)
    assert b.apex_m[0] == 1.0 and np.all(np.diff(b.apex_m) < 0)
    with pytest.raises(DataError, match="complete bounce"):
        measure_bounces(np.array(z[:9000]), np.array(v[:9000]), 1.0, dt, g, 40)


def test_a_run_that_ends_in_flight_is_still_bouncing_not_stuck():
    """Cut a planted bounce sequence (eps 0.6) mid-flight: the ball is said to be still bouncing,
    with the ratio it showed; a ball that comes to rest on the floor is said to stick."""
    g, dt, eps = 9.80665, 1e-4, 0.6
    z, v = planted_drop(1.2, eps, dt, g)
    with pytest.raises(StillBouncing) as info:
        measure_bounces(np.array(z), np.array(v), 1.0, dt, g, 3)
    assert info.value.ratio == pytest.approx(eps, abs=0.01) and "bounced higher" in str(info.value)
    k = int(np.argmax(np.array(z) < 0))                   # rest from the first contact on
    z_rest = np.r_[z[:k], np.zeros(len(z) - k)]
    v_rest = np.r_[v[:k], np.zeros(len(v) - k)]
    with pytest.raises(DataError, match="stuck to the floor") as info:
        measure_bounces(z_rest, v_rest, 1.0, dt, g, 1)
    assert not isinstance(info.value, StillBouncing)


def test_setup_model_is_vrcals_simulator_with_drag():
    s = DropSetup("tt", 0.0027, 0.02, 2.0, 0.86, 1e-3, drag_coefficient=0.4, n_bounces=3)
    ref = simulate_drops(2.0, 0.86, 3, BallProperties(0.0027, 0.04), effects={"air_drag": {"drag_coefficient": 0.4}})
    assert np.allclose(s.model.apex_heights_m, ref.apex_heights_m)
    assert s.impact_speed_m_per_s == pytest.approx(ref.impact_speeds_m_per_s[0, 0])
    assert s.impact_speed_m_per_s < math.sqrt(2 * 9.80665 * 2.0)           # drag slows the fall


def test_speed_dependent_epsilon_is_the_reference_value_at_the_first_impact():
    s = DropSetup("b", 0.6, 0.12, 1.8, 0.8, 1e-3, restitution_exponent=0.2, n_bounces=3)
    eps = s.epsilons
    assert eps[0] == pytest.approx(0.8)
    assert eps[1] > eps[0] and eps[2] > eps[1]                              # slower bounces, more elastic


def test_phase_shifts_cover_one_step():
    s = DropSetup("b", 0.6, 0.12, 1.8, 0.8, 2e-3)
    shifts = phase_shifts_m(s, 4)
    assert shifts[0] == 0 and shifts[1] == pytest.approx(s.impact_speed_m_per_s * 2e-3 / 4)


@pytest.mark.parametrize("bad", [0.0, -1e-3, 1e-320, 1e-9, float("nan"), float("inf"), 0.5, "x"])
def test_bad_time_steps_are_refused_with_the_limits(bad):
    with pytest.raises(UsageError, match=r"--dt must be a number between 1e-07 and 0.1 \[s\]"):
        check_dt(bad)


def test_the_command_line_and_the_engines_refuse_the_same_steps():
    """One range for --dt: the option type of export/verify and check_dt agree on both ends."""
    from vrcal.engines.common import MAX_DT_S, MIN_DT_S
    from vrcal.options import ODE_TIME_STEP_S, TIME_STEP_S

    assert (TIME_STEP_S.minimum, TIME_STEP_S.maximum) == (MIN_DT_S, MAX_DT_S)
    assert (ODE_TIME_STEP_S.minimum, ODE_TIME_STEP_S.maximum) == (MIN_DT_S, MAX_DT_S)
    assert f"--dt must be a number {TIME_STEP_S.range_text()}" in str(pytest.raises(UsageError, check_dt, 0.5).value)


@pytest.mark.parametrize("bounces, phases", [(0, 4), (1000000, 4), (3, 0), (3, 1000), (2.5, 4)])
def test_bad_counts_are_refused(bounces, phases):
    with pytest.raises(UsageError, match="must be an integer"):
        check_counts(bounces, phases)


def test_a_run_too_long_is_refused_up_front_naming_the_limit():
    s = DropSetup("b", 0.6, 0.12, 1.8, 0.8, 1e-6)
    with pytest.raises(UsageError, match=r"limit is 400,000 steps: use --dt .* or larger"):
        check_steps(s, 4, "bullet", 400_000)
    assert check_steps(DropSetup("b", 0.6, 0.12, 1.8, 0.8, 1e-3), 4, "bullet", 400_000) < 400_000


def test_round_down_keeps_two_digits_and_never_rounds_up():
    assert round_down(0.0013871) == 0.0013
    assert round_down(2.0e-4) == 2.0e-4


def test_a_second_balls_depth_limit_is_a_quarter_of_its_own_radius():
    """verify --file read the file's limit (a quarter of the tennis ball's radius, 8.37 mm) and judged the
    basketball dropped beside it by it (26.7 mm: FAILED); a limit the user gave stays the same for both."""
    from vrcal.engines.export import second_setup

    tennis = DropSetup("tennis", 0.0577, 0.0335, 1.0, 0.745, 2e-4, max_penetration_m=0.25 * 0.0335)
    basket = second_setup(tennis, "basketball", 0.6085, 0.1217, 0.766, 0.766)
    assert basket.penetration_limit_m == pytest.approx(0.25 * 0.1217)
    given = second_setup(DropSetup("tennis", 0.0577, 0.0335, 1.0, 0.745, 2e-4, max_penetration_m=0.02),
                         "basketball", 0.6085, 0.1217, 0.766, 0.766)
    assert given.penetration_limit_m == 0.02


def test_a_rebound_that_turns_back_inside_the_floor_is_no_bounce():
    """A contact that sends the ball up but lets it turn back still below the floor (Bullet's clay ball of
    epsilon 0.1 at 1/240 s in some contact phases): no bounce, said in one line; the apex ratio of such a
    'flight' was sqrt(negative) = NaN, which reached int() in the step search as a traceback."""
    g, dt = 9.80665, 1e-3
    z1, v1 = semi_implicit_flight(1.0, 0.0, g, dt, 460)          # falls to about -3 mm
    z2, v2 = semi_implicit_flight(-0.007, 0.2, g, dt, 300)        # pushed up from 7 mm deep, turns back at -5 mm
    z_in, v_in = np.r_[z1, z2], np.r_[v1, v2]
    with pytest.raises(DataError, match=r"only 0 complete bounce.*does not rebound at this step \(it turned back "
                                        r"[0-9.]+ mm inside the floor\)") as info:
        measure_bounces(z_in, v_in, 1.0, dt, g, 1)
    assert "nan" not in str(info.value).lower()
    with pytest.raises(DataError, match="infinite or NaN"):
        measure_bounces(np.r_[z1, np.full(10, np.nan)], np.r_[v1, np.full(10, np.nan)], 1.0, dt, g, 1)


def test_rebound_heights_are_shown_against_the_targets_when_far_off():
    """An absolute epsilon error of 0.026 at clay's 0.1 lets a 10 mm rebound be 7..15 mm: the drop test says
    so in heights (an epsilon 0.5 off by 0.005 is not said)."""
    from vrcal.engines.common import DropRuns

    def runs(eps, target):
        eps, h = np.array([[eps[0]], [eps[1]]]), np.array([[1.0, eps[0] ** 2], [1.0, eps[1] ** 2]])
        return DropRuns(np.zeros(2), eps, eps, np.full_like(eps, target), np.full_like(eps, target), h,
                        np.array([[1.0, target ** 2]] * 2), np.zeros_like(eps))

    assert runs((0.0838, 0.1234), 0.1).height_ratio_text() == "rebound heights 0.70..1.52 x the target's"
    assert runs((0.495, 0.505), 0.5).height_ratio_text() == ""
    assert runs((0.99, 1.0017), 0.9995).gain == pytest.approx(1.0017)
    assert runs((0.99, 1.0), 1.0).gain is None
