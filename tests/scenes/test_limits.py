"""Tests of the scene simulator's limits (issue 10): the up-front cost estimate, the refusal of a ball
resting on a ball, and the pair screening that makes an event cost numpy work instead of a Python
loop over every pair (it must find exactly the event the full loop finds)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vrcal.errors import DataError
from vrcal.scenes import multibody as mb
from vrcal.scenes.spec import validate_scene


def _grid(n, duration=2.0, height=0.3):
    side = int(n ** 0.5) + 1
    return validate_scene({"K_per_s": 4.0, "duration_s": duration, "floor": {"material": "steel"}, "bodies": [
        {"name": f"b{k}", "ball": "table_tennis", "position_m": [0.05 * (k % side), 0.05 * (k // side), height],
         "position_of": "bottom"} for k in range(n)]}, "grid.yaml")


def _reference_next_event(st_):
    """The full loop over every pair, as the simulator did before the screening."""
    best, what = np.inf, None
    a = st_.accel()
    for i in range(st_.n):
        if not st_.rest[i]:
            t = mb._floor_time(st_.p[i, 2], st_.v[i, 2], st_.R[i], st_.g)
            if t < best:
                best, what = t, (i, mb._FLOOR)
        for j in range(i + 1, st_.n):
            t = mb._pair_time(st_.p[i] - st_.p[j], st_.v[i] - st_.v[j], a[i] - a[j], st_.R[i] + st_.R[j])
            if t < best:
                best, what = t, (i, j)
    return best, what


def _reference_touching(st_):
    found = []
    for i in range(st_.n):
        for j in [mb._FLOOR] + list(range(i + 1, st_.n)):
            n, ra, rb, gap = mb._contact_geometry(st_, i, j)
            if gap > mb.CONTACT_TOLERANCE_M:
                continue
            vrel = float(n @ (mb._point_velocity(st_, i, ra) - mb._point_velocity(st_, j, rb)))
            if vrel < -1e-12:
                found.append((vrel, i, j))
    return sorted(found)


@settings(max_examples=60, deadline=None)
@given(st.integers(2, 8), st.integers(0, 2**32 - 1))
def test_the_screened_event_search_finds_what_the_full_loop_finds(n, seed):
    rng = np.random.default_rng(seed)
    state = mb._State(_grid(n))
    state.p = np.column_stack([rng.uniform(-0.2, 0.2, n), rng.uniform(-0.2, 0.2, n), rng.uniform(0.02, 0.6, n)])
    state.v = rng.normal(0, 1.0, (n, 3))
    state.rest = rng.random(n) < 0.3
    state.p[state.rest, 2] = state.R[state.rest]
    state.v[state.rest, 2] = 0.0
    if n > 2:  # two bodies exactly touching, one approaching
        d = state.p[1] - state.p[0]
        state.p[1] = state.p[0] + d / np.linalg.norm(d) * (state.R[0] + state.R[1])
        state.v[1] = state.v[0] - d
    assert mb._next_event(state) == _reference_next_event(state)
    assert mb._touching_approaching(state) == _reference_touching(state)


def test_the_floor_impact_estimate_matches_a_grid_of_falling_balls():
    scene = _grid(20)
    res = mb.simulate_scene(scene)
    assert mb.floor_impacts_estimate(scene) == pytest.approx(len(res.contacts), rel=0.05)


def test_too_many_bodies_for_the_time_asked_is_refused_before_any_event():
    scene = _grid(100, duration=60.0)
    with pytest.raises(DataError, match=r"too many bodies for the time asked: at least \d+ floor impacts"):
        mb.check_simulable(scene)


def test_the_same_bodies_for_a_short_time_run():
    assert mb.check_simulable(_grid(100, duration=0.5)) > 0


def test_a_ball_starting_on_a_resting_ball_is_refused():
    r = 0.02
    scene = validate_scene({"K_per_s": 4.0, "duration_s": 1.0, "floor": {"material": "steel"}, "bodies": [
        {"name": "low", "ball": "table_tennis", "position_m": [0, 0, r]},
        {"name": "top", "ball": "table_tennis", "position_m": [0.01, 0, r + np.sqrt((2 * r) ** 2 - 0.01 ** 2)]}]},
        "s.yaml")
    with pytest.raises(DataError, match="'top' starts resting on 'low'"):
        mb.simulate_scene(scene)


def test_a_ball_moving_away_from_the_ball_below_is_not_resting():
    r = 0.02
    scene = validate_scene({"K_per_s": 4.0, "duration_s": 0.5, "floor": {"material": "steel"}, "bodies": [
        {"name": "low", "ball": "table_tennis", "position_m": [0, 0, r]},
        {"name": "top", "ball": "table_tennis", "position_m": [0, 0, 3 * r], "velocity_m_per_s": [1.0, 0, 2.0]}]},
        "s.yaml")
    assert mb.simulate_scene(scene).t_s[-1] == pytest.approx(0.5)


@pytest.mark.parametrize("field, value, message", [
    ("velocity_m_per_s", [0, 0, -1e300], r"every component must lie within \+-10000"),
    ("position_m", [1e5, 0, 1], r"every component must lie within \+-10000"),
    ("radius_m", 1e3, "must be <= 5"),
    ("mass_kg", 10**400, "must be a number"),
])
def test_absurd_body_quantities_are_refused(field, value, message):
    body = {"name": "a", "mass_kg": 0.1, "radius_m": 0.05, "virtual_body": {"x_m": 0.0}, "position_m": [0, 0, 1]}
    body[field] = value
    with pytest.raises(DataError, match=message):
        validate_scene({"K_per_s": 4.0, "duration_s": 1.0, "floor": {"material": "steel"}, "bodies": [body]}, "s")
