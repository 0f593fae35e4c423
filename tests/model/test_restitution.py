"""Tests of vrcal.model.restitution: the paper's equations, scalar/array agreement, round trips."""

import math
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vrcal.errors import UsageError
from vrcal.model import restitution as eq

# Table 1 of [1]: (H, h) as printed (typos 0.13 -> 1.3 and 0.12 -> 1.2 corrected) and the printed epsilon.
TABLE1_PAPER = [
    ("basketball min", 1.8, 1.3, 0.85),
    ("volleyball min", 1.0, 0.60, 0.77),
    ("volleyball max", 1.0, 0.66, 0.81),
    ("football min", 2.0, 1.2, 0.77),
    ("football max", 2.0, 1.65, 0.9),  # sqrt(0.825) = 0.908: the paper rounds to 0.9
    ("tennis min", 2.54, 1.346, 0.73),
    ("tennis max", 2.54, 1.473, 0.76),
    ("table tennis min", 0.305, 0.24, 0.89),
    ("table tennis max", 0.305, 0.26, 0.92),
]


@pytest.mark.parametrize("label,H,h,printed", TABLE1_PAPER, ids=[r[0] for r in TABLE1_PAPER])
def test_eq9_reproduces_table1_epsilon_column(label, H, h, printed):
    """Eq. (9) of [1] on the heights of Table 1 gives its epsilon column to the printed precision."""
    tolerance = 0.01 if label == "football max" else 0.005
    assert eq.epsilon_from_heights(h, H) == pytest.approx(printed, abs=tolerance)


def test_eq9_rejects_rebound_higher_than_drop():
    with pytest.raises(UsageError, match="exceeds drop height"):
        eq.epsilon_from_heights(2.0, 1.8)


def test_eq9_rejects_negative_height():
    with pytest.raises(UsageError, match="rebound height"):
        eq.epsilon_from_heights(-0.1, 1.8)


def test_eq7_eq10_known_values():
    # T = x/(2v) = 0.01/(2*0.1) = 0.05 s; epsilon = exp(-4*0.05) = exp(-0.2)
    assert eq.contact_time_single_s(0.01, 0.1) == pytest.approx(0.05, rel=1e-15)
    assert eq.epsilon_single(0.01, 0.1, 4.0) == pytest.approx(math.exp(-0.2), rel=1e-15)


def test_eq10_contact_time_beyond_double_precision_is_inf_without_warning():
    # 1 m / (2 * 5e-324 m/s) overflows: T = inf, without numpy's RuntimeWarning
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert eq.contact_time_single_s(1.0, 5e-324) == math.inf


def test_eq6_two_bodies_add_contact_times():
    T = eq.contact_time_pair_s(0.01, 0.1, 0.03, 0.5)
    assert T == pytest.approx(0.05 + 0.03, rel=1e-15)
    # the pair's epsilon is the product of each body's epsilon against a rigid floor
    K = 3.0
    assert eq.epsilon_pair(0.01, 0.1, 0.03, 0.5, K) == pytest.approx(
        eq.epsilon_single(0.01, 0.1, K) * eq.epsilon_single(0.03, 0.5, K), rel=1e-14)


def test_rigid_floor_adds_no_time():
    assert eq.contact_time_pair_s(0.01, 0.1, 0.0, 0.0) == pytest.approx(0.05)
    assert eq.epsilon_single(0.0, 0.0, 4.0) == 1.0


@pytest.mark.parametrize("K", [0.0, -1.0, float("nan"), float("inf")])
def test_bad_K_is_a_usage_error(K):
    with pytest.raises(UsageError, match="K_per_s"):
        eq.epsilon_from_contact_time(0.1, K)


@pytest.mark.parametrize("eps", [0.0, -0.2, 1.5, float("nan")])
def test_epsilon_outside_unit_interval(eps):
    with pytest.raises(UsageError, match="epsilon must lie in"):
        eq.contact_time_from_epsilon_s(eps, 4.0)


def test_positive_depth_needs_positive_speed():
    with pytest.raises(UsageError, match="v_m_per_s"):
        eq.contact_time_single_s(0.01, 0.0)


def test_height_to_bottom():
    D = 0.24
    assert eq.height_to_bottom_m(1.3, "top", D) == pytest.approx(1.06)
    assert eq.height_to_bottom_m(1.3, "centre", D) == pytest.approx(1.18)
    assert eq.height_to_bottom_m(1.3, "bottom", D) == 1.3
    with pytest.raises(UsageError, match="measured_to"):
        eq.height_to_bottom_m(1.3, "middle", D)


def test_impact_speed_eq8():
    assert eq.impact_speed_m_per_s(2.0, 9.80665) == pytest.approx(6.263, abs=1e-3)  # FIFA: about 6.25 m/s


SCALAR_VS_ARRAY = [
    (eq.contact_time_single_s, ([0.01, 0.02, 0.0], [0.1, 0.3, 1.0])),
    (eq.contact_time_pair_s, ([0.01, 0.02], [0.1, 0.3], [0.0, 0.05], [1.0, 0.2])),
    (eq.epsilon_from_contact_time, ([0.0, 0.05, 0.3], [4.0, 1.0, 2.5])),
    (eq.contact_time_from_epsilon_s, ([0.5, 0.85, 1.0], [4.0, 1.0, 2.5])),
    (eq.epsilon_pair, ([0.01, 0.02], [0.1, 0.3], [0.0, 0.05], [1.0, 0.2], [4.0, 2.0])),
    (eq.epsilon_single, ([0.01, 0.02], [0.1, 0.3], [4.0, 2.0])),
    (eq.virtual_speed_m_per_s, ([0.01, 0.02], [0.05, 0.3])),
    (eq.virtual_depth_m, ([0.1, 0.3], [0.05, 0.0])),
    (eq.epsilon_from_heights, ([0.5, 1.2], [1.0, 2.0])),
    (eq.impact_speed_m_per_s, ([0.5, 1.8], [9.81, 1.62])),
    (eq.added_mass_kg, ([0.04, 0.24], [1.204, 0.0])),
]


@pytest.mark.parametrize("fn,arrays", SCALAR_VS_ARRAY, ids=[f.__name__ for f, _ in SCALAR_VS_ARRAY])
def test_scalar_and_array_inputs_agree(fn, arrays):
    vector = fn(*[np.array(a) for a in arrays])
    assert isinstance(vector, np.ndarray)
    for i in range(len(arrays[0])):
        scalar = fn(*[a[i] for a in arrays])
        assert isinstance(scalar, float)
        assert scalar == vector[i]


@settings(max_examples=200, deadline=None)
@given(eps=st.floats(1e-6, 1.0), K=st.floats(1e-3, 1e3), x=st.floats(1e-4, 1.0))
def test_round_trip_epsilon_to_virtual_body_and_back(eps, K, x):
    """epsilon -> T (Eq. 7 inverted) -> v at depth x (Eq. 10 inverted) -> epsilon, to 1e-12."""
    T = eq.contact_time_from_epsilon_s(eps, K)
    if T == 0.0:  # epsilon == 1: the virtual body sits on the surface
        assert eq.epsilon_from_contact_time(T, K) == 1.0
        return
    v = eq.virtual_speed_m_per_s(x, T)
    assert eq.epsilon_single(x, v, K) == pytest.approx(eps, rel=1e-12, abs=1e-12)
    assert eq.virtual_depth_m(v, T) == pytest.approx(x, rel=1e-12)


@settings(max_examples=100, deadline=None)
@given(h_over_H=st.floats(0.0, 1.0), H=st.floats(0.01, 10.0))
def test_eq9_is_inverse_of_apex_law(h_over_H, H):
    eps = eq.epsilon_from_heights(h_over_H * H, H)
    assert eps ** 2 * H == pytest.approx(h_over_H * H, rel=1e-12, abs=1e-15)


# --------------------------------------------------------------------------- the shared input checks

REAL_SCALARS = [4, 4.0, np.float64(4.0), np.float32(4.0), np.int64(4), np.array(4.0), np.array(4, dtype=np.int32)]


@pytest.mark.parametrize("value", REAL_SCALARS, ids=lambda v: type(v).__name__ + str(getattr(v, "dtype", "")))
def test_any_real_scalar_is_a_number(value):
    assert eq.real_number(value) == 4.0 and type(eq.check_K(value)) is float


@pytest.mark.parametrize("value", [True, np.bool_(True), "4", [4.0], np.array([4.0]), 4 + 0j, None])
def test_what_is_no_real_scalar_is_refused_and_named(value):
    assert eq.real_number(value) is None
    with pytest.raises(UsageError, match=r"K must be a number > 0 \[1/s\], got "):
        eq.check_K(value)


@given(st.floats(allow_nan=True, allow_infinity=True, width=64))
@settings(max_examples=200, deadline=None)
def test_a_refusal_shows_the_value_refused(x):
    """The message's number is the one refused (repr precision), never '?' and never a rounded one."""
    try:
        eq.contact_time_from_epsilon_s(x, 4.0)
    except UsageError as exc:
        shown = str(exc).split("got ")[1].split(",")[0]
        assert not (0 < x <= 1)
        assert float(shown) == x or (math.isnan(x) and shown == "nan")
    else:
        assert 0 < x <= 1


def test_a_masked_check_names_an_infinite_value():
    with pytest.raises(UsageError, match="where x_m > 0, got inf, not a finite number"):
        eq.contact_time_single_s(0.02, math.inf)


def test_added_mass_is_half_the_displaced_air():
    """Landau & Lifshitz Sec. 11: a sphere carries rho V / 2 along; 0.75 % of a table-tennis ball's 2.7 g."""
    assert eq.added_mass_kg(0.04) == pytest.approx(0.5 * 1.204 * math.pi * 0.04**3 / 6, rel=1e-15)
    assert eq.added_mass_kg(0.04) / 0.0027 == pytest.approx(0.0075, abs=1e-4)


def test_sphere_volume_and_drag_constant_refuse_what_no_ball_has():
    for call in (lambda: eq.sphere_volume_m3(-1.0), lambda: eq.added_mass_kg(0.04, -1.0),
                 lambda: eq.drag_constant_per_m(0.5, 0.067, 0.0),
                 lambda: eq.drag_constant_per_m(-0.5, 0.067, 0.058), lambda: eq.drag_constant_per_m(0.5, 0.067, -1.0),
                 lambda: eq.drag_constant_per_m(0.5, 0.067, 0.058, -1.204)):
        with pytest.raises(UsageError):
            call()


@given(h=st.one_of(st.just(0.0), st.floats(1e-6, 3.0)), H=st.floats(0.01, 3.0),
       k=st.one_of(st.just(0.0), st.floats(1e-9, 0.5)))
@settings(max_examples=200, deadline=None)
def test_with_drag_epsilon_is_in_the_unit_interval_or_refused(h, H, k):
    """Default: an epsilon in [0, 1] or a UsageError; allow_above_one gives the same number where it is <= 1."""
    loose = eq.epsilon_from_heights_with_drag(h, H, k, allow_above_one=True)
    assert loose >= math.sqrt(h / H) * (1 - 1e-12)          # drag only adds to Eq. (9)
    if loose <= 1.0:
        assert eq.epsilon_from_heights_with_drag(h, H, k) == loose
    else:
        with pytest.raises(UsageError, match="exceeds drop height|no ball rebounds"):
            eq.epsilon_from_heights_with_drag(h, H, k)


@pytest.mark.parametrize("h, H, k", [(-0.1, 1.0, 0.01), (0.5, 0.0, 0.01), (0.5, 1.0, -0.5), (0.5, 1.0, math.inf),
                                     (math.nan, 1.0, 0.01)])
def test_with_drag_refuses_bad_heights_and_drag(h, H, k):
    with pytest.raises(UsageError):
        eq.epsilon_from_heights_with_drag(h, H, k, allow_above_one=True)


def test_with_drag_beyond_double_precision_is_refused_not_overflowed():
    with np.errstate(all="raise"):
        with pytest.raises(UsageError, match="no ball rebounds"):
            eq.epsilon_from_heights_with_drag(1.0, 2.0, 1e3)


@pytest.mark.parametrize("n", [2.5, True, "3", 0, -1])
def test_a_count_must_be_a_whole_number(n):
    with pytest.raises(UsageError, match="must be an integer >= 1"):
        eq.check_integer(n, "n")


def test_the_constant_epsilon_for_heights_is_exact_without_drag_and_minimax_with_it():
    """The one epsilon a drag-free engine reproduces apex heights best with: exact for a constant epsilon
    (also across the drops of a table); for the exercise ball's apexes (1 m, drag and buoyancy: 0.599, 0.375,
    0.241 m) the least largest misfit, equal and opposite at two bounces."""
    n = np.arange(1, 6)
    eps, misfit = eq.constant_epsilon_for_heights(1.5, 1.5 * 0.8 ** (2 * n), n)
    assert eps == pytest.approx(0.8, rel=1e-12) and np.max(np.abs(misfit)) < 1e-12
    table_eps, _ = eq.constant_epsilon_for_heights([0.5, 1.0, 1.0], [0.5 * 0.7**2, 0.7**2, 0.7**4], [1, 1, 2])
    assert table_eps == pytest.approx(0.7, rel=1e-12)
    h = np.array([0.5994, 0.3766, 0.2425])
    eps, misfit = eq.constant_epsilon_for_heights(1.0, h, [1, 2, 3])
    log = np.log1p(misfit)
    assert np.max(log) == pytest.approx(-np.min(log), rel=1e-9)          # equioscillation
    for other in (eps * 0.999, eps * 1.001):                               # any other constant misses more
        assert np.max(np.abs(np.log(other ** (2 * np.arange(1, 4)) / h))) > np.max(np.abs(log))
    assert 0.774 < eps < 0.802 and np.max(np.abs(misfit)) < 0.031
