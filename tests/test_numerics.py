"""core.numerics.richardson against sequences with a known limit (closed forms, no code under test).

b(h) = L + c h^p with chosen L, c, p: the extrapolation of order 2 is exact for p = 2, its error
estimate |b(h/2) - b(h)| / 3 is the fine level's error for p = 2 and bounds the extrapolation's
error for every order p >= 2 (closed form: the ratio is |1 - 3 / (2^p - 1)|); well below the assumed
order (p < 1.32) it is not a bound (module doc).
"""

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from robolobes.core.errors import BadInput
from robolobes.core.numerics import level_change, richardson


def seq(L, c, p, h):
    return L + c * h**p


def test_exact_for_the_assumed_order():
    # b = 1 + 3 h^2: value = b(h/2) + (b(h/2) - b(h)) / 3 = 1 exactly (up to rounding, 1e-15)
    v, e = richardson(seq(1.0, 3.0, 2, 0.1), seq(1.0, 3.0, 2, 0.05))
    assert_allclose(v, 1.0, rtol=1e-14)
    assert_allclose(e, abs(3 * 0.05**2 - 3 * 0.1**2) / 3, rtol=1e-12)  # |b(h/2) - b(h)| / 3, by hand
    assert_allclose(e, 3 * 0.05**2, rtol=1e-12)  # = the fine level's own error, |b(h/2) - L|


def _random_sequences(p):
    rng = np.random.default_rng(7)
    L = rng.uniform(-1, 1, 50)
    c = rng.uniform(-2, 2, 50)
    h = rng.uniform(0.01, 0.2, 50)
    return L, richardson(seq(L, c, p, h), seq(L, c, p, h / 2))


@pytest.mark.parametrize("p", [2.0, 2.5, 3.0, 4.0])
def test_estimate_bounds_the_extrapolation_from_the_assumed_order_up(p):
    L, (v, e) = _random_sequences(p)
    assert np.all(np.abs(v - L) <= e * (1 + 1e-12) + 1e-15)


@pytest.mark.parametrize("p", [1.0, 1.2])
def test_estimate_is_not_a_bound_below_the_assumed_order(p):
    # closed form: |value - L| / error = |1 - 3 / (2^p - 1)|, > 1 for p < log2(2.5) = 1.32 (2 at p = 1)
    L, (v, e) = _random_sequences(p)
    ratio = np.abs(v - L) / e
    assert_allclose(ratio, abs(3 / (2**p - 1) - 1), rtol=1e-9)
    assert np.all(ratio > 1)


def test_other_order_and_ratio():
    # b = 2 + h^4, ratio 3, order 4: value exact; error = |diff| / (ratio^order - 1) = (h / 3)^4
    h = 0.3
    v, e = richardson(2 + h**4, 2 + (h / 3) ** 4, order=4, ratio=3)
    assert_allclose(v, 2.0, rtol=1e-14)
    assert_allclose(e, (h / 3) ** 4, rtol=1e-12)


@pytest.mark.parametrize("m_c, m_f", [(40, 60), (135, 203), (40, 80)])
def test_non_integer_level_ratio_recovers_the_limit(m_c, m_f):
    # the SDM's b(m) = b0 + c / m^2 with the actual ratio m_f / m_c (135 -> 203: 1.5037): the value
    # is b0 exactly and the error the fine level's own, c / m_f^2 (closed form; 1e-15 rounding)
    b0, c = 1.0e-3, 2.5
    v, e = richardson(b0 + c / m_c**2, b0 + c / m_f**2, ratio=m_f / m_c)
    assert_allclose(v, b0, rtol=1e-12)
    assert_allclose(e, c / m_f**2, rtol=1e-12)


def test_non_finite_levels():
    v, e = (np.asarray(a) for a in richardson(np.array([math.inf, 1.0, math.inf]), np.array([math.inf, math.inf, 2.0])))
    assert v[0] == math.inf and e[0] == 0.0  # both "no limit": agree exactly
    assert v[1] == math.inf and e[1] == math.inf  # levels disagree on what they found
    assert v[2] == 2.0 and e[2] == math.inf
    assert isinstance(richardson(1.0, 1.5).value, float)


@pytest.mark.parametrize("kw, match", [({"order": 0}, "order"), ({"ratio": 1.0}, "ratio"),
                                       ({"ratio": float("nan")}, "ratio")])
def test_bad_parameters(kw, match):
    with pytest.raises(BadInput, match=match):
        richardson(1.0, 2.0, **kw)


def test_level_change_of_a_geometric_sequence():
    # b(n) = L + c q^n (geometric convergence in the level n, q = 0.1): the change between levels
    # n and n + 1 is |c| q^n (1 - q) = 9 |b(n + 1) - L|, so the whole change bounds the fine level's
    # error by a factor 9 (closed form); the value is the fine level itself.
    L, c, q = 2.0, 0.5, 0.1
    coarse, fine = L + c * q**3, L + c * q**4
    v, e = level_change(coarse, fine)
    assert v == fine
    assert_allclose(e, abs(c) * q**3 * (1 - q), rtol=1e-9)  # 1e-9: rounding of 2 + 5e-4 - (2 + 5e-5)
    assert_allclose(e / abs(fine - L), (1 - q) / q, rtol=1e-9)


def test_level_change_non_finite_levels():
    # as richardson: equal non-finite levels have error 0, differing ones inf (NaN differs from itself)
    v, e = level_change(np.array([np.inf, 1.0, np.nan, 1.0]), np.array([np.inf, np.inf, np.nan, 1.5]))
    assert_allclose(v, [np.inf, np.inf, np.nan, 1.5])
    assert_allclose(e, [0.0, np.inf, np.inf, 0.5])
