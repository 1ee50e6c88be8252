"""The opt-in Arnoldi eigenvalues of the SDM engine (``SemiDiscretization(eigen="arnoldi")``).

ARPACK (``scipy.sparse.linalg.eigs``, residuals to machine precision) returns the largest
multipliers of monodromies of at least ``_ARNOLDI_MIN_N`` rows; smaller ones stay dense. The
references here are independent of the code under test: a matrix built from known eigenvalues,
and LAPACK's eigenvalues of the same monodromies (``eigen="dense"``, the default). Tolerances are
rounding-level (1e-10 relative; ``bench/bench_sdm_krylov.py`` measured 2e-14 on the TX200).
"""

import numpy as np
import pytest

from robolobes.cases.milling import Cut, CuttingLaw, Tool
from robolobes.lobes import LobeProblem, Mode, ModalStructure, SemiDiscretization, solve
from robolobes.lobes._errors import LobeError
from robolobes.lobes.sdm import _ARNOLDI_K, _ARNOLDI_MIN_N, SDMEngine, arnoldi_eigvals


def _slotting_2dof() -> LobeProblem:
    """The symmetric 2-DOF benchmark structure in full-immersion slotting: every step engaged, so
    at m = 80 the reduced monodromy has 4 + 2 x 80 = 164 rows (above ``_ARNOLDI_MIN_N``)."""
    fn, zeta, mt = 922.0, 0.011, 0.03993
    k = mt * (2 * np.pi * fn) ** 2
    s = ModalStructure((Mode(fn, zeta, k, (1.0, 0.0)), Mode(fn, zeta, k, (0.0, 1.0))))
    return LobeProblem(s, Tool(diameter_m=0.01, teeth=2), Cut(ae_m=0.01, ap_m=1e-3, spindle_rpm=1e4, mode="down"),
                       CuttingLaw(ktc_pa=6e8, krc_pa=2e8))


def test_arnoldi_eigvals_of_a_matrix_with_known_eigenvalues():
    # U = V diag(lam) V^-1, N = 150, real: 10 conjugate pairs near |mu| = 0.99-1.02 and 130 real
    # eigenvalues spread over [-0.9, 0.9]. The k = 16 largest in modulus (8 pairs) are returned to
    # 1e-10, each a true eigenvalue; the rest of the row is zero.
    rng = np.random.default_rng(7)
    r = np.linspace(0.99, 1.02, 10)
    th = np.linspace(0.3, 2.8, 10)
    pairs = r * np.exp(1j * th)
    real = np.linspace(-0.9, 0.9, 130)
    N = 150
    V = np.zeros((N, N))
    V[:, :130] = rng.normal(size=(N, 130))
    X = rng.normal(size=(N, 10)) + 1j * rng.normal(size=(N, 10))
    D = np.zeros((N, N))
    D[np.arange(130), np.arange(130)] = real
    for j, mu in enumerate(pairs):  # real 2 x 2 blocks [[a, b], [-b, a]] on [Re x, Im x]
        c = 130 + 2 * j
        V[:, c], V[:, c + 1] = X[:, j].real, X[:, j].imag
        D[c:c + 2, c:c + 2] = [[mu.real, mu.imag], [-mu.imag, mu.real]]
    U = V @ D @ np.linalg.inv(V)
    ev = arnoldi_eigvals(U[None], 40)[0]
    found = ev[ev != 0]
    top = pairs[-(_ARNOLDI_K // 2):]  # the k largest in modulus: the last k/2 pairs (r up to 1.02)
    assert _ARNOLDI_K <= len(found) <= _ARNOLDI_K + 1
    for mu in np.concatenate([top, top.conj()]):
        assert np.min(np.abs(found - mu)) < 1e-10
    spectrum = np.concatenate([pairs, pairs.conj(), real])
    assert all(np.min(np.abs(spectrum - mu)) < 1e-10 for mu in found)
    np.testing.assert_allclose(np.abs(found).max(), 1.02, rtol=1e-10)


@pytest.fixture(scope="module")
def engines():
    p = _slotting_2dof()
    return (SDMEngine(p, SemiDiscretization(m=80), 10e-3),
            SDMEngine(p, SemiDiscretization(m=80, eigen="arnoldi"), 10e-3))


def test_arnoldi_spectral_radius_equals_dense_on_a_modal_slotting_case(engines):
    dense, arn = engines
    assert arn.n_red >= _ARNOLDI_MIN_N
    rpm = np.repeat(np.linspace(6000.0, 24000.0, 7), 4)
    depth = np.tile([0.05e-3, 0.2e-3, 0.5e-3, 2e-3], 7)
    e1, e2 = dense.spectra(rpm, depth), arn.spectra(rpm, depth)
    r1, r2 = np.abs(e1).max(axis=1), np.abs(e2).max(axis=1)
    assert np.any(r1 < 1) and np.any(r1 >= 1)  # both verdicts occur
    np.testing.assert_allclose(r2, r1, rtol=1e-10)
    assert np.array_equal(r2 < 1, r1 < 1)
    # the critical multiplier: the same up to complex conjugation
    mu1, mu2 = dense.multipliers(rpm, depth)[1], arn.multipliers(rpm, depth)[1]
    off = np.minimum(np.abs(mu2 - mu1), np.abs(mu2 - mu1.conj()))
    assert np.all(off <= 1e-10 * np.abs(mu1))


def test_small_monodromies_stay_dense():
    p = _slotting_2dof()
    e1 = SDMEngine(p, SemiDiscretization(m=20), 10e-3)
    e2 = SDMEngine(p, SemiDiscretization(m=20, eigen="arnoldi"), 10e-3)
    assert e2.n_red < _ARNOLDI_MIN_N
    rpm, depth = np.array([9000.0, 15000.0]), np.array([0.3e-3, 1e-3])
    np.testing.assert_array_equal(e2.spectra(rpm, depth), e1.spectra(rpm, depth))


def test_arnoldi_limits_equal_dense_limits_to_the_search_tolerance():
    p = _slotting_2dof()
    speeds = np.linspace(8000.0, 20000.0, 6)
    a = solve(p, SemiDiscretization(m=80), speeds, depth_max_m=5e-3, rtol=1e-4)
    b = solve(p, SemiDiscretization(m=80, eigen="arnoldi"), speeds, depth_max_m=5e-3, rtol=1e-4)
    assert np.all(np.isfinite(a.depth_limit_m))
    np.testing.assert_allclose(b.depth_limit_m, a.depth_limit_m, rtol=2e-4)
    assert np.array_equal(a.bifurcation, b.bifurcation)


def test_eigen_is_validated():
    with pytest.raises(LobeError, match="eigen"):
        SemiDiscretization(eigen="eigs")  # type: ignore[arg-type]
