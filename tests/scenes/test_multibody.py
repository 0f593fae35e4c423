"""Tests of vrcal.scenes.multibody: Eq. (5) of [1] checked by conservation laws, friction and spin,
the event-driven simulator against `vrcal simulate` and against closed forms."""

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vrcal.errors import UsageError
from vrcal.scenes import multibody as mb
from vrcal.scenes.spec import validate_scene

finite = dict(allow_nan=False, allow_infinity=False)
EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.fixture
def examples_dir():
    return EXAMPLES


def unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def random_inertia(rng_values, mass):
    """A symmetric positive definite inertia tensor from 6 numbers."""
    a = np.array(rng_values[:9]).reshape(3, 3)
    return mass * (a @ a.T + 0.1 * np.eye(3))


def kinetic_energy(m, I, v, w):
    return 0.5 * m * v @ v + 0.5 * w @ I @ w


# --------------------------------------------------------------------------- Eq. (5) for general rigid bodies

vec = st.lists(st.floats(-3, 3, **finite), min_size=3, max_size=3)


@settings(max_examples=200, deadline=None)
@given(
    ma=st.floats(0.01, 10), mb_=st.floats(0.01, 10), eps=st.floats(0, 1),
    va=vec, vb=vec, wa=vec, wb=vec, ra=vec, rb=vec, n=vec,
    Ia=st.lists(st.floats(-1, 1, **finite), min_size=9, max_size=9),
    Ib=st.lists(st.floats(-1, 1, **finite), min_size=9, max_size=9),
)
def test_eq5_general_bodies_conserve_momentum_and_set_relative_velocity(ma, mb_, eps, va, vb, wa, wb, ra, rb, n,
                                                                        Ia, Ib):
    """Eq. (5) with arbitrary inertia tensors and contact offsets: momentum conserved, angular momentum
    about the contact point conserved, v_rel+ = -eps v_rel- (Eq. 3), kinetic energy not increased."""
    if np.linalg.norm(n) < 1e-3:
        return
    n = unit(n)
    va, vb, wa, wb, ra, rb = map(np.asarray, (va, vb, wa, wb, ra, rb))
    Ia, Ib = random_inertia(Ia, ma), random_inertia(Ib, mb_)
    pa, pb = va + np.cross(wa, ra), vb + np.cross(wb, rb)
    vrel = n @ (pa - pb)
    if vrel >= -1e-6:
        return  # not colliding
    j = mb.normal_impulse_N_s(vrel, eps, n, ma, np.linalg.inv(Ia), ra, mb_, np.linalg.inv(Ib), rb)
    J = j * n
    va2, vb2 = va + J / ma, vb - J / mb_
    wa2 = wa + np.linalg.solve(Ia, np.cross(ra, J))
    wb2 = wb - np.linalg.solve(Ib, np.cross(rb, J))
    assert j > 0
    np.testing.assert_allclose(ma * va2 + mb_ * vb2, ma * va + mb_ * vb, atol=1e-9 * (1 + abs(j)))
    vrel2 = n @ (va2 + np.cross(wa2, ra) - vb2 - np.cross(wb2, rb))
    assert vrel2 == pytest.approx(-eps * vrel, rel=1e-7, abs=1e-9)
    e0 = kinetic_energy(ma, Ia, va, wa) + kinetic_energy(mb_, Ib, vb, wb)
    e1 = kinetic_energy(ma, Ia, va2, wa2) + kinetic_energy(mb_, Ib, vb2, wb2)
    assert e1 <= e0 * (1 + 1e-9) + 1e-12


def test_eq5_scalar_and_array_inputs_agree():
    n = np.array([[0, 0, 1.0], unit([1, 0, 1])])
    ra = np.array([[0, 0, -0.1], [0.05, 0, -0.1]])
    inv_i = np.broadcast_to(np.eye(3) / 0.004, (2, 3, 3))
    arr = mb.normal_impulse_N_s(np.array([-2.0, -1.0]), np.array([0.8, 0.5]), n, np.array([0.6, 0.3]), inv_i, ra,
                                np.inf, np.zeros((2, 3, 3)), np.zeros((2, 3)))
    for k in range(2):
        one = mb.normal_impulse_N_s([-2.0, -1.0][k], [0.8, 0.5][k], n[k], [0.6, 0.3][k], inv_i[k], ra[k], np.inf,
                                    np.zeros((3, 3)), np.zeros(3))
        assert isinstance(one, float)
        assert arr[k] == pytest.approx(one, rel=1e-15)


def test_eq5_sphere_on_floor_reduces_to_m_times_velocity_change():
    """For a sphere (r parallel to n) on a static floor the angular terms vanish: j = (1+eps) m |v|."""
    j = mb.normal_impulse_N_s(-3.0, 0.7, [0, 0, 1.0], 0.5, np.eye(3) / 0.002, [0, 0, -0.1], np.inf, np.zeros((3, 3)),
                              np.zeros(3))
    assert j == pytest.approx(1.7 * 0.5 * 3.0, rel=1e-14)


def test_eq5_never_pulls_bodies_that_already_separate():
    """A contact only pushes: separating (v_rel > 0) or grazing bodies get j = 0, not Eq. (5)'s negative value."""
    j = mb.normal_impulse_N_s(np.array([-3.0, 0.0, 2.0]), 0.7, [0, 0, 1.0], 0.5, np.eye(3) / 0.002, [0, 0, -0.1],
                              np.inf, np.zeros((3, 3)), np.zeros(3))
    assert j.tolist() == pytest.approx([1.7 * 0.5 * 3.0, 0.0, 0.0], abs=1e-15)
    assert np.all(j >= 0)


# --------------------------------------------------------------------------- sphere-sphere impacts in the simulator


def two_body_scene(n, ra, rb, ma, mb_, va, vb, wa, wb, xa, xb, mu, inertia="hollow", K=4.0):
    """Two spheres touching along n, high above the floor."""
    pb = np.array([0.0, 0.0, 5.0])
    pa = pb + (ra + rb) * np.asarray(n) * (1 + 1e-12)
    doc = {
        "K_per_s": K, "duration_s": 1.0, "friction_mu": mu, "floor": {"material": "steel"},
        "bodies": [
            {"name": "a", "mass_kg": ma, "radius_m": ra, "virtual_body": {"x_m": xa, "v_m_per_s": 0.1},
             "inertia": inertia, "position_m": list(pa), "velocity_m_per_s": list(va), "spin_rad_per_s": list(wa)},
            {"name": "b", "mass_kg": mb_, "radius_m": rb, "virtual_body": {"x_m": xb, "v_m_per_s": 0.1},
             "inertia": inertia, "position_m": list(pb), "velocity_m_per_s": list(vb), "spin_rad_per_s": list(wb)},
        ],
    }
    return validate_scene(doc, "test.yaml")


def state_energy(s):
    return float(np.sum(0.5 * s.m * np.sum(s.v**2, axis=1) + 0.5 * s.I * np.sum(s.w**2, axis=1)))


@settings(max_examples=150, deadline=None)
@given(
    n=vec, va=vec, vb=vec, wa=vec, wb=vec,
    ra=st.floats(0.02, 0.2), rb=st.floats(0.02, 0.2), ma=st.floats(0.01, 1), mb_=st.floats(0.01, 1),
    xa=st.floats(0, 0.02), xb=st.floats(0, 0.02), mu=st.floats(0, 1), inertia=st.sampled_from(["hollow", "solid"]),
)
def test_every_sphere_sphere_impact_conserves_momentum_and_never_adds_energy(n, va, vb, wa, wb, ra, rb, ma, mb_, xa,
                                                                             xb, mu, inertia):
    if np.linalg.norm(n) < 1e-3:
        return
    n = unit(n)
    scene = two_body_scene(n, ra, rb, ma, mb_, va, vb, wa, wb, xa, xb, mu, inertia)
    s = mb._State(scene)
    found = mb._touching_approaching(s)
    pairs = [f for f in found if f[2] == 1]
    if not pairs:
        return
    vrel, i, j = pairs[0]
    p0 = s.m @ s.v
    # angular momentum about the origin: orbital + spin
    L0 = np.sum(s.m[:, None] * np.cross(s.p, s.v) + s.I[:, None] * s.w, axis=0)
    e0 = state_energy(s)
    contacts = []
    mb._resolve(s, i, j, vrel, contacts)
    c = contacts[0]
    assert c.epsilon == pytest.approx(math.exp(-4.0 * (xa / 0.2 + xb / 0.2)), rel=1e-12)  # Eqs. 6, 7
    np.testing.assert_allclose(s.m @ s.v, p0, atol=1e-10 * (1 + np.abs(p0).max()))
    L1 = np.sum(s.m[:, None] * np.cross(s.p, s.v) + s.I[:, None] * s.w, axis=0)
    np.testing.assert_allclose(L1, L0, atol=1e-9 * (1 + np.abs(L0).max()))
    n_hat = unit(s.p[0] - s.p[1])
    after = n_hat @ (s.v[0] + np.cross(s.w[0], -ra * n_hat) - s.v[1] - np.cross(s.w[1], rb * n_hat))
    assert after == pytest.approx(-c.epsilon * vrel, rel=1e-9, abs=1e-12)
    assert state_energy(s) <= e0 * (1 + 1e-12) + 1e-15


def test_head_on_equal_spheres_with_epsilon_one_swap_velocities():
    """Two equal spheres with rigid virtual bodies (x = 0, epsilon = 1) meeting head-on exchange velocities."""
    doc = {
        "K_per_s": 4.0, "duration_s": 0.5, "sample_dt_s": 0.01, "friction_mu": 0.5, "floor": {"material": "steel"},
        "bodies": [
            {"name": "left", "mass_kg": 0.2, "radius_m": 0.05, "virtual_body": {"x_m": 0.0},
             "position_m": [-0.5, 0, 3.0], "velocity_m_per_s": [3.0, 0.4, 0]},
            {"name": "right", "mass_kg": 0.2, "radius_m": 0.05, "virtual_body": {"x_m": 0.0},
             "position_m": [0.5, 0.0, 3.0], "velocity_m_per_s": [-1.0, 0.4, 0]},
        ],
    }
    res = mb.simulate_scene(validate_scene(doc, "t.yaml"))
    (c,) = res.contacts
    assert c.epsilon == 1.0 and c.body_b == "right"
    assert c.t_s == pytest.approx(0.9 / 4.0, rel=1e-12)  # gap 0.9 m closed at 4 m/s
    vel = res.velocity_m_per_s[-1]
    assert vel[0, 0] == pytest.approx(-1.0, abs=1e-12)
    assert vel[1, 0] == pytest.approx(3.0, abs=1e-12)
    np.testing.assert_allclose(res.spin_rad_per_s[-1], 0.0, atol=1e-12)


# --------------------------------------------------------------------------- friction and spin


def oblique_floor_scene(vx, mu, inertia, spin_y=0.0):
    doc = {
        "K_per_s": 4.0, "duration_s": 0.6, "friction_mu": mu, "floor": {"material": "steel"},
        "bodies": [{"name": "ball", "mass_kg": 0.6, "radius_m": 0.12, "inertia": inertia,
                    "virtual_body": {"x_m": 0.03, "v_m_per_s": 0.2}, "position_m": [0, 0, 1.0],
                    "velocity_m_per_s": [vx, 0, 0], "spin_rad_per_s": [0, spin_y, 0]}],
    }
    return validate_scene(doc, "t.yaml")


def velocities_around(res, t):
    """Velocity and spin just before and after time t (ballistic: reconstruct from the samples)."""
    k = np.searchsorted(res.t_s, t)
    g = res.scene.g_m_per_s2
    before_v = res.velocity_m_per_s[k - 1, 0] + np.array([0, 0, -g]) * (t - res.t_s[k - 1])
    after_v = res.velocity_m_per_s[k, 0] - np.array([0, 0, -g]) * (res.t_s[k] - t)
    return before_v, after_v, res.spin_rad_per_s[k - 1, 0], res.spin_rad_per_s[k, 0]


@pytest.mark.parametrize("inertia,k", [("hollow", 2 / 3), ("solid", 2 / 5)])
def test_off_centre_impact_makes_the_spin_eq5_and_friction_predict(inertia, k):
    """An oblique impact on the floor: the total impulse J = m dv gives d(omega) = I^-1 (r x J); a sticking
    contact leaves the contact point without slip, so v_x keeps 1/(1+k) of itself (3/5 hollow, 5/7 solid)."""
    scene = oblique_floor_scene(2.0, 0.8, inertia)
    res = mb.simulate_scene(scene)
    c = res.contacts[0]
    assert c.note == "sticking"
    v0, v1, w0, w1 = velocities_around(res, c.t_s)
    m, R = 0.6, 0.12
    J = m * (v1 - v0)
    r = np.array([0, 0, -R])
    np.testing.assert_allclose(w1 - w0, np.cross(r, J) / (k * m * R**2), rtol=1e-9, atol=1e-9)
    assert v1[0] == pytest.approx(2.0 / (1 + k), rel=1e-12)
    assert v1[0] - R * w1[1] == pytest.approx(0.0, abs=1e-12)  # contact point: v + w x r, x component
    assert J[2] == pytest.approx(c.normal_impulse_N_s, rel=1e-12)
    assert -v1[2] == pytest.approx(-c.epsilon * c.impact_speed_m_per_s, rel=1e-12)


def test_sliding_contact_is_limited_by_mu_times_j():
    scene = oblique_floor_scene(5.0, 0.05, "hollow")
    res = mb.simulate_scene(scene)
    c = res.contacts[0]
    assert c.note == "sliding"
    v0, v1, w0, w1 = velocities_around(res, c.t_s)
    assert 0.6 * (v0[0] - v1[0]) == pytest.approx(0.05 * c.normal_impulse_N_s, rel=1e-12)
    assert c.tangential_impulse_N_s == pytest.approx(0.05 * c.normal_impulse_N_s, rel=1e-12)
    assert w1[1] > 0  # forward roll: the ball spins up in the direction it slides


def test_without_friction_a_sphere_gets_no_spin():
    res = mb.simulate_scene(oblique_floor_scene(2.0, 0.0, "hollow"))
    np.testing.assert_allclose(res.spin_rad_per_s, 0.0, atol=0)


# --------------------------------------------------------------------------- one ball = vrcal simulate


def test_one_ball_scene_reproduces_vrcal_simulate():
    """Impact times and apex heights of a single-ball scene equal `simulate_drops` to 1e-9 relative."""
    from vrcal.drop.simulate import simulate_drops
    from vrcal.model.body import BallProperties

    H, R, m = 1.8, 0.12, 0.6
    doc = {"K_per_s": 4.0, "duration_s": 6.0, "floor": {"material": "steel"}, "rest_speed_m_per_s": 0.01,
           "bodies": [{"name": "ball", "mass_kg": m, "radius_m": R, "virtual_body": {"x_m": 0.05, "v_m_per_s": 0.5},
                       "position_m": [0, 0, H], "position_of": "bottom"}]}
    scene = validate_scene(doc, "t.yaml")
    eps = math.exp(-4.0 * 0.05 / (2 * 0.5))
    res = mb.simulate_scene(scene)
    n = 8
    drops = simulate_drops(H, eps, n, BallProperties(mass_kg=m, diameter_m=2 * R))
    times = np.array([c.t_s for c in res.contacts[:n]])
    np.testing.assert_allclose(times, drops.impact_times_s[0], rtol=1e-9)
    apex = np.array([h for _name, _t, h in res.apexes[: n + 1]])
    np.testing.assert_allclose(apex, drops.apex_heights_m[0], rtol=1e-9)
    speeds = np.array([c.impact_speed_m_per_s for c in res.contacts[:n]])
    np.testing.assert_allclose(speeds, drops.impact_speeds_m_per_s[0], rtol=1e-9)


def test_trajectory_between_events_is_the_flight_parabola():
    res = mb.simulate_scene(oblique_floor_scene(0.0, 0.5, "hollow"))
    t_hit = res.contacts[0].t_s
    early = res.t_s < t_hit
    z = res.position_m[early, 0, 2]
    np.testing.assert_allclose(z, 1.0 - 0.5 * res.scene.g_m_per_s2 * res.t_s[early] ** 2, rtol=1e-13)
    assert t_hit == pytest.approx(math.sqrt(2 * (1.0 - 0.12) / res.scene.g_m_per_s2), rel=1e-13)


# --------------------------------------------------------------------------- energy, rest, stacks


def total_energy(res):
    s = res.scene
    m = np.array([b.mass_kg for b in s.bodies])
    inertia = np.array([b.inertia_kg_m2 for b in s.bodies])
    kin = 0.5 * m * np.sum(res.velocity_m_per_s**2, axis=2) + 0.5 * inertia * np.sum(res.spin_rad_per_s**2, axis=2)
    return np.sum(kin + m * s.g_m_per_s2 * res.position_m[:, :, 2], axis=1)


@pytest.mark.parametrize("example", ["stack-drop", "figure9-five-balls", "figure8-basketball"])
def test_energy_never_increases_in_the_example_scenes(example, examples_dir):
    from vrcal.scenes.spec import load_scene

    res = mb.simulate_scene(load_scene(examples_dir / f"{example}.yaml"))
    e = total_energy(res)
    assert np.all(np.diff(e) <= 1e-9 * e[0])
    assert e[-1] < e[0]  # the bounces lose energy (epsilon < 1)


def test_stack_drop_launches_the_top_ball_above_its_drop_height(examples_dir):
    """Sequential impulses in a stack: the tennis ball rebounds far above where it was dropped from."""
    from vrcal.scenes.spec import load_scene

    res = mb.simulate_scene(load_scene(examples_dir / "stack-drop.yaml"))
    first = res.contacts[:2]
    assert [(c.body_a, c.body_b) for c in first] == [("basketball", "floor"), ("basketball", "tennis")]
    tennis = [h for name, _t, h in res.apexes if name == "tennis"]
    assert tennis[1] > 1.8 * tennis[0]
    assert np.any(res.spin_rad_per_s[-1] != 0)  # the oblique ball-ball contact made spin


def test_ball_resting_on_floor_is_hit_from_above_at_the_quartic_root():
    """A ball resting on the floor (no gravity acceleration) and one falling onto it: the contact time
    comes from the quartic of the relative motion and equals sqrt(2 h / g)."""
    gap = 0.3
    doc = {"K_per_s": 4.0, "duration_s": 0.3, "floor": {"material": "steel"},
           "bodies": [
               {"name": "low", "mass_kg": 0.6, "radius_m": 0.12, "virtual_body": {"x_m": 0.0},
                "position_m": [0, 0, 0.12]},
               {"name": "high", "mass_kg": 0.06, "radius_m": 0.03, "virtual_body": {"x_m": 0.0},
                "position_m": [0.05, 0, 0.0]},
           ]}
    # place 'high' directly above 'low' with a vertical gap: centre distance along the line of centres
    dz = math.sqrt(0.15**2 - 0.05**2)
    doc["bodies"][1]["position_m"] = [0.05, 0, 0.12 + dz + gap]
    res = mb.simulate_scene(validate_scene(doc, "t.yaml"))
    c = next(c for c in res.contacts if c.body_b == "high" or c.body_a == "high")
    assert c.t_s == pytest.approx(math.sqrt(2 * gap / res.scene.g_m_per_s2), rel=1e-9)


def test_tiny_bounces_end_at_rest():
    doc = {"K_per_s": 4.0, "duration_s": 20.0, "sample_dt_s": 0.05, "floor": {"material": "steel"},
           "rest_speed_m_per_s": 0.05,
           "bodies": [{"name": "ball", "ball": "tennis", "position_m": [0, 0, 1.0], "position_of": "bottom"}]}
    res = mb.simulate_scene(validate_scene(doc, "t.yaml"))
    last = res.contacts[-1]
    assert last.note.startswith("rest") and last.epsilon == 0.0
    assert last.impact_speed_m_per_s < 0.05
    assert all(c.impact_speed_m_per_s >= 0.05 for c in res.contacts[:-1])
    np.testing.assert_allclose(res.bottom_height_m()[res.t_s > last.t_s + 1e-9], 0.0, atol=1e-12)


def test_a_ball_resting_on_another_stops_with_a_clear_error():
    from vrcal.errors import DataError

    doc = {"K_per_s": 4.0, "duration_s": 2.0, "floor": {"material": "steel"},
           "bodies": [
               {"name": "low", "mass_kg": 0.6, "radius_m": 0.12, "virtual_body": {"x_m": 0.0},
                "position_m": [0, 0, 0.12]},
               {"name": "top", "mass_kg": 0.06, "radius_m": 0.03, "virtual_body": {"x_m": 0.01, "v_m_per_s": 0.1},
                "position_m": [0, 0, 0.3]},
           ]}
    with pytest.raises(DataError, match="a ball resting on a ball"):
        mb.simulate_scene(validate_scene(doc, "t.yaml"), max_events=2000)


def test_cradle_of_touching_balls_passes_the_striker_speed_to_the_last_ball(examples_dir):
    """Sequential impulses with epsilon = 1 (rigid virtual bodies): Newton's cradle."""
    from vrcal.scenes.spec import load_scene

    res = mb.simulate_scene(load_scene(examples_dir / "cradle.yaml"))
    assert [(c.body_a, c.body_b) for c in res.contacts] == [("striker", "b1"), ("b1", "b2"), ("b2", "b3")]
    assert all(c.epsilon == 1.0 for c in res.contacts)
    np.testing.assert_allclose(res.velocity_m_per_s[-1, :, 0], [0.0, 0.0, 0.0, 2.0], atol=1e-12)


# --------------------------------------------------------------------------- sliding on the floor


def sliding_scene(inertia="hollow", spin_y=0.0, mu=0.3, duration=2.0, more=()):
    """The probe's slide.yaml: m 0.5 kg, R 0.1 m, vx 2 m/s on the floor."""
    return validate_scene({
        "name": "slide", "K_per_s": 4.0, "duration_s": duration, "friction_mu": mu, "floor": {"material": "steel"},
        "bodies": [{"name": "ball", "mass_kg": 0.5, "radius_m": 0.1, "inertia": inertia,
                    "virtual_body": {"x_m": 0.05, "v_m_per_s": 0.5}, "position_m": [0, 0, 0.1],
                    "velocity_m_per_s": [2.0, 0, 0], "spin_rad_per_s": [0, spin_y, 0]}, *more]}, "t.yaml")


@pytest.mark.parametrize("inertia,spin_y,rolling", [
    # hand values (kinetic friction until the contact point stops slipping, I = k m R^2):
    # v_roll = v0 - u0/(1 + 1/k) with the slip u0 = v0 - omega_y R (e.g. Marion & Thornton, rolling billiard ball)
    ("hollow", 0.0, 1.2),             # k = 2/3: 3/5 * 2 m/s
    ("solid", 0.0, 10.0 / 7.0),       # k = 2/5: 5/7 * 2 m/s
    ("hollow", -40.0, -0.4),          # backspin: u0 = 2 + 4 = 6 m/s, 2 - 6 * 2/5 = -0.4 m/s (comes back)
])
def test_a_ball_sliding_on_the_floor_ends_rolling_at_the_textbook_speed(inertia, spin_y, rolling):
    res = mb.simulate_scene(sliding_scene(inertia, spin_y))
    v, w = res.velocity_m_per_s[-1, 0], res.spin_rad_per_s[-1, 0]
    assert v[0] == pytest.approx(rolling, rel=1e-12)
    assert w[1] * 0.1 == pytest.approx(v[0], rel=1e-12)      # rolling: omega_y R = v_x
    assert res.position_m[-1, 0, 2] == 0.1 and v[2] == 0.0     # it stays on the floor


def test_sliding_distance_is_the_closed_form():
    # hollow, mu 0.3: t_roll = 2 / (0.3 g 2.5) = 0.27191 s, x = 2 t - mu g t^2 / 2 + 1.2 (2 s - t) = 2.5088 m
    g = 9.80665
    t_roll = 2.0 / (0.3 * g * 2.5)
    x = 2.0 * t_roll - 0.5 * 0.3 * g * t_roll**2 + 1.2 * (2.0 - t_roll)
    res = mb.simulate_scene(sliding_scene())
    assert res.position_m[-1, 0, 0] == pytest.approx(x, rel=1e-12)
    assert x == pytest.approx(2.5088, abs=1e-4)
    mid = np.searchsorted(res.t_s, 0.1)   # still sliding at 0.1 s: v = 2 - mu g t
    assert res.velocity_m_per_s[mid, 0, 0] == pytest.approx(2.0 - 0.3 * g * res.t_s[mid], rel=1e-12)


def test_sliding_never_adds_energy_and_a_rolling_ball_keeps_its_energy():
    more = [{"name": "hit", "mass_kg": 0.5, "radius_m": 0.1, "virtual_body": {"x_m": 0.05, "v_m_per_s": 0.5},
             "position_m": [1.0, 0.003, 0.1], "spin_rad_per_s": [3.0, 0, 5.0]}]
    res = mb.simulate_scene(sliding_scene(more=more, duration=3.0))
    assert (res.contacts[0].body_a, res.contacts[0].body_b) == ("ball", "hit")   # rolls into the other ball
    e = total_energy(res)
    assert np.all(np.diff(e) <= 1e-9 * e[0])
    rolled = res.t_s > 2.0   # long after every slip has ended: no rolling resistance, no loss
    assert np.ptp(e[rolled]) <= 1e-9 * e[0]


def test_without_friction_a_ball_slides_on_for_ever():
    res = mb.simulate_scene(sliding_scene(mu=0.0))
    assert res.velocity_m_per_s[-1, 0, 0] == 2.0


# --------------------------------------------------------------------------- the equations' inputs


@pytest.mark.parametrize("call", [
    lambda: mb.normal_impulse_N_s(-3.0, 1.5, _N, 0.058, _I, _R, np.inf, _Z, _O),
    lambda: mb.normal_impulse_N_s(-3.0, -0.1, _N, 0.058, _I, _R, np.inf, _Z, _O),
    lambda: mb.normal_impulse_N_s(-3.0, 0.8, _N, 0.0, _I, _R, np.inf, _Z, _O),
    lambda: mb.normal_impulse_N_s(-3.0, 0.8, _N, np.inf, _Z, _R, np.inf, _Z, _O),
    lambda: mb.friction_impulse_N_s([0.5, 0, 0], 0.1, -0.3, 40.0),
    lambda: mb.friction_impulse_N_s([0.5, 0, 0], 0.1, 0.3, 0.0),
    lambda: mb.floor_sliding_friction([1.0, 0, 0], 0.3, 9.81, 0.0335, 0.0),
])
def test_impulses_refuse_epsilon_outside_0_1_negative_friction_and_massless_bodies(call):
    with np.errstate(all="raise"):
        with pytest.raises(UsageError):
            call()


_N, _R, _O, _Z = np.array([0, 0, 1.0]), np.array([0, 0, -0.0335]), np.zeros(3), np.zeros((3, 3))
_I = np.eye(3) / (2 / 3 * 0.058 * 0.0335**2)
