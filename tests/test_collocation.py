"""Collocation (Nystrom) lobes against independent references: the plain SDM of the accuracy
benchmark, the dense SDM monodromy (a second method), the free structure's exact multipliers and
the kernel integrals by quadrature."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.linalg import expm

import lobes_plain_reference as ref
from lobes_benchmark import problem
from test_lobes_accuracy import lobe_problem

from robolobes.cases.milling import Tool
from robolobes.lobes import LobeError, solve
from robolobes.lobes.collocation import Collocation, CollocationEngine, kernel_weights, lagrange
from robolobes.lobes.sdm import SDMEngine, SemiDiscretization


def _critical(ev: np.ndarray) -> complex:
    return complex(ev[np.argmax(np.abs(ev))])


def kernel_weights_quadrature(lam, h: float, n: int, sub: int = 64, points: int = 24):
    """The integrals of ``kernel_weights`` by composite Gauss-Legendre quadrature (``sub``
    sub-intervals of ``points`` points per upper limit) on the product-form Lagrange basis: an
    independent check of the phi-function route for ``|lam h| / sub`` <~ 1."""
    x, w = np.polynomial.legendre.leggauss(n)
    u = (x + 1) / 2
    xq, wq = np.polynomial.legendre.leggauss(points)
    xq, wq = (xq + 1) / 2, wq / 2
    lam = np.asarray(lam, dtype=complex)
    ends = np.concatenate([u, [1.0]])
    frac = ((np.arange(sub)[:, None] + xq[None, :]) / sub).reshape(-1)
    pts = ends[:, None] * frac[None]                               # (n + 1, sub * points)
    wts = ends[:, None] * np.tile(wq / sub, sub)[None]
    ker = np.exp(lam[:, None, None] * h * (ends[None, :, None] - pts[None]))
    val = h * np.einsum("keq,eq,eqj->kej", ker, wts, lagrange(u, pts))
    return val[:, n], val[:, :n]


def test_kernel_weights_match_quadrature():
    # poles of the benchmark (922 Hz, zeta 0.011), a slow and a stiff real pole, a conjugate pair
    w = 2 * math.pi * 922.0
    lam = np.array([-0.011 * w + 1j * w, -0.011 * w - 1j * w, -300.0, -5e4, -20 + 3e3j, -20 - 3e3j])
    for h in (1e-4, 2e-3):
        for n in (1, 4, 8):
            f, p = kernel_weights(lam, h, n)
            fq, pq = kernel_weights_quadrature(lam, h, n, sub=512)
            # 512 sub-intervals of 24 Gauss points: the quadrature is exact to rounding for
            # |lam h| / 512 <= 0.2; the phi-function route loses ~1e-12 at 8 nodes (monomial basis)
            assert np.abs(f - fq).max() <= 1e-10 * np.abs(fq).max()
            assert np.abs(p - pq).max() <= 1e-10 * np.abs(pq).max()


def test_free_structure_multipliers_are_exact():
    # depth 0: the monodromy is block-triangular with e^{A T} in the corner, so its multipliers are
    # exp(lambda T) (closed form) and zeros
    p = problem(0.05)
    eng = CollocationEngine(p, Collocation(nodes=4))
    rpm = 8000.0
    T = float(eng.period_s(rpm))
    U = eng.monodromy([rpm], [0.0])[0]
    ss = p.structure.state_space()
    # expm of the structure's A is independent of the modal route of the engine; 1e-12: rounding
    assert np.allclose(U[:ss.n_states, :ss.n_states], expm(ss.A * T), rtol=0, atol=1e-12)
    ev = np.sort_complex(np.linalg.eigvals(U))
    exact = np.sort_complex(np.concatenate([np.exp(ss.poles * T), np.zeros(U.shape[0] - ss.n_states)]))
    assert np.allclose(ev, exact, rtol=0, atol=1e-12)


@pytest.mark.parametrize("aD, rpm, depth, levels", [
    (0.05, 10000.0, 1e-3, (80, 160)), (1.0, 6000.0, 0.5e-3, (80, 160)),
    pytest.param(0.05, 6000.0, 0.5e-3, (160, 320), marks=pytest.mark.slow),
    pytest.param(1.0, 10000.0, 1e-3, (160, 320), marks=pytest.mark.slow)])
def test_multipliers_match_dense_sdm(aD, rpm, depth, levels):
    # second method: the plain SDM monodromy (scipy expm per step) at m and 2m, Richardson.
    # The SDM's error is O(1/m^2); |mu_2m - mu_m| / 3 estimates the error of mu_2m, so the
    # Richardson value is far more accurate. Tolerance: that estimate (the distance from the
    # extrapolation to the truth is of higher order), at least 1e-6
    p = problem(aD)
    mus = [_critical(np.linalg.eigvals(SDMEngine(p, SemiDiscretization(m=m), 0.01).monodromy_dense(rpm, depth)))
           for m in levels]
    est = abs(mus[1] - mus[0]) / 3
    rich = mus[1] + (mus[1] - mus[0]) / 3
    mu = complex(CollocationEngine(p, Collocation(nodes=8)).multipliers([rpm], [depth])[1][0])
    assert abs(mu - rich) <= max(est, 1e-6)
    assert abs(mu - mus[1]) <= 2 * est  # and against the finer level alone: its own error + est


def test_variable_pitch_and_three_teeth_match_dense_sdm():
    # variable pitch (principal period: one revolution, two delays) and a 3-tooth slot (two teeth
    # cut at once); dense SDM m = 80/160, Richardson; tolerance as above, at least 1e-6
    cases = [(problem(0.5, tool=Tool(diameter_m=0.01, teeth=2, pitch_rad=(2.8, 2 * math.pi - 2.8)), mode="up"), 0.3e-3),
             (problem(1.0, tool=Tool(diameter_m=0.01, teeth=3)), 1e-3)]
    rpm = 9000.0
    for p, depth in cases:
        mus = [_critical(np.linalg.eigvals(SDMEngine(p, SemiDiscretization(m=m), 0.01).monodromy_dense(rpm, depth)))
               for m in (80, 160)]
        est = abs(mus[1] - mus[0]) / 3
        rich = mus[1] + (mus[1] - mus[0]) / 3
        mu = complex(CollocationEngine(p, Collocation(nodes=8, elements=8)).multipliers([rpm], [depth])[1][0])
        assert abs(mu - rich) <= max(est, 1e-6), (p.tool, mu, rich, est)


def test_limit_converges_fast_in_the_nodes():
    # spectral convergence: d(N) = |b(2N) - b(N)| falls geometrically with N (measured at 8000 rpm,
    # slot: 4.4e-4, 3.8e-5, 3.0e-6 m for N = 3, 4, 5, i.e. a factor >= 11 per node); asserted: a
    # factor 5 per node (an algebraic order-p method would shrink d(N) by only (N/(N+1))^p)
    p = lobe_problem("1dof-slot")
    b = {n: float(solve(p, Collocation(nodes=n, elements=4, check_nodes=0), [8000.0], rtol=1e-10).depth_limit_m[0])
         for n in (3, 4, 5, 6, 8, 10)}
    d = [abs(b[2 * n] - b[n]) for n in (3, 4, 5)]
    assert d[1] * 5 < d[0] and d[2] * 5 < d[1], d


@pytest.mark.parametrize("name", ["1dof-aD0.05-down", "1dof-slot"])
def test_limits_within_one_percent_of_the_independent_reference(name):
    # the independent plain SDM (Richardson 160/320, error estimate <= 0.2 % at the usable speeds);
    # a few speeds away from the cusps, pointwise 1 % (the target), default Collocation
    rows = [r for r, ok in zip(ref.load()["cases"][name], ref.usable(ref.load()["cases"][name])) if ok]
    pick = [r for r in rows if r["rpm"] in (7000.0, 12000.0, 18000.0, 23000.0) and math.isfinite(r["depth_m"])]
    assert len(pick) >= 3
    rpm = np.array([r["rpm"] for r in pick])
    res = solve(lobe_problem(name), Collocation(), rpm, depth_max_m=ref.DEPTH_MAX)
    b_ref = np.array([r["depth_m"] for r in pick])
    assert np.all(np.abs(res.depth_limit_m / b_ref - 1) <= 0.01), (res.depth_limit_m, b_ref)
    assert np.all(res.status == "converged")


def test_refusals():
    with pytest.raises(LobeError):
        Collocation(nodes=11)
    with pytest.raises(LobeError):
        Collocation(tol=0.7)
    from robolobes.lobes import stability

    with pytest.raises(LobeError, match="Collocation"):
        stability(problem(0.05), Collocation())


def test_helix_matches_sdm():
    # helical tool (30 deg; kinks of the depth-integrated W at the edges' entries and exits): the
    # SDM fast path (a second method) at m = 160/320 with 64 axial slices, Richardson in m. Its
    # errors: |mu_320 - mu_160| / 3 in m, and the slices' (midpoint rule along the depth, second
    # order) below |mu(64 slices) - mu(32 slices)|; tolerance: their sum. Collocation at 8 nodes:
    # on the layout of its depth cap (kink in a short element) and exactly at the depth (no cap)
    p = problem(0.5, directions=((1.0, 0.0), (0.0, 1.0)), tool=Tool(diameter_m=0.01, teeth=2, helix_rad=math.radians(30)),
                mode="up")
    rpm, depth = 9000.0, 1e-3
    mu = {(m, s): complex(SDMEngine(p, SemiDiscretization(m=m, axial_slices=s), 0.01).multipliers([rpm], [depth])[1][0])
          for m, s in ((160, 64), (320, 64), (320, 32))}
    rich = mu[320, 64] + (mu[320, 64] - mu[160, 64]) / 3
    tol = abs(mu[320, 64] - mu[160, 64]) / 3 + abs(mu[320, 64] - mu[320, 32])
    for eng in (CollocationEngine(p, Collocation(nodes=8), 0.01),
                CollocationEngine(p, Collocation(nodes=8), depth, caps=False)):
        got = complex(eng.multipliers([rpm], [depth])[1][0])
        assert abs(got - rich) <= tol, (got, rich, tol)
