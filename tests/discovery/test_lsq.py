"""vrcal.discovery.lsq: the numpy-only bounded least squares and tail probabilities of discover,
against scipy (which the tests may import; discover itself does not)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import least_squares
from scipy.special import chdtrc, fdtrc

from vrcal.discovery.lsq import chi2_sf, f_sf, least_squares_box


@settings(max_examples=300, deadline=None)
@given(x=st.floats(0.0, 5e3), dof=st.integers(1, 60))
def test_chi2_tail_matches_scipy(x, dof):
    expected = chdtrc(dof, x)
    assert chi2_sf(x, dof) == pytest.approx(expected, rel=1e-8, abs=1e-290)


@settings(max_examples=300, deadline=None)
@given(x=st.floats(0.0, 1e3), dfn=st.integers(1, 4), dfd=st.integers(1, 5000))
def test_f_tail_matches_scipy(x, dfn, dfd):
    expected = fdtrc(dfn, dfd, x)
    assert f_sf(x, dfn, dfd) == pytest.approx(expected, rel=1e-8, abs=1e-290)


def test_tails_at_the_edges():
    assert chi2_sf(0.0, 3) == 1.0 and chi2_sf(float("inf"), 3) == 0.0
    assert f_sf(-1.0, 1, 10) == 1.0 and f_sf(float("inf"), 2, 10) == 0.0


def _exp_problem(seed):
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 4, 60)
    y = 2.5 * np.exp(-0.7 * t) + 0.3 + rng.normal(0, 0.01, t.size)

    def fun(p):
        return y - (p[0] * np.exp(-p[1] * t) + p[2])

    def jac(p):
        e = np.exp(-p[1] * t)
        return -np.column_stack([e, -p[0] * t * e, np.ones_like(t)])

    return fun, jac


@pytest.mark.parametrize("seed", range(4))
def test_least_squares_box_finds_scipys_optimum(seed):
    fun, jac = _exp_problem(seed)
    x0, lo, hi = np.array([1.0, 0.1, 0.0]), np.array([0.0, 0.0, -1.0]), np.array([10.0, 5.0, 1.0])
    ours = least_squares_box(fun, jac, x0, lo, hi, np.array([1.0, 0.1, 0.1]))
    ref = least_squares(fun, x0, jac=jac, bounds=(lo, hi), xtol=1e-12, ftol=1e-12)
    assert ours.success
    np.testing.assert_allclose(ours.x, ref.x, rtol=1e-5)
    assert float(ours.fun @ ours.fun) <= float(ref.fun @ ref.fun) * (1 + 1e-8)


def test_a_bound_that_binds_holds_the_parameter_there():
    fun, jac = _exp_problem(0)
    # the offset may not exceed 0.1 although the data want 0.3: it ends on the bound, the rest adapts
    ours = least_squares_box(fun, jac, np.array([1.0, 0.5, 0.0]), np.array([0.0, 0.0, -1.0]),
                             np.array([10.0, 5.0, 0.1]), np.ones(3))
    ref = least_squares(fun, np.array([1.0, 0.5, 0.0]), jac=jac, bounds=([0, 0, -1], [10, 5, 0.1]))
    assert ours.x[2] == pytest.approx(0.1)
    np.testing.assert_allclose(ours.x, ref.x, rtol=1e-4)
