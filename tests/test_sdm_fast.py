"""The SDM's fast step exponentials (``lobes.sdm.phi_exps``) against closed forms and scipy's expm.

``phi_exps(M, V)`` returns ``exp(M)``, ``phi1(M) V`` and ``phi2(M) V``, the first block row of the
Van Loan exponential ``expm([[M, V, 0], [0, 0, I], [0, 0, 0]])`` that the first-order SDM uses for
every step (Insperger & Stepan 2004). Tolerances are a few hundred rounding errors of the entries'
scale: the two methods sum different (but convergent to double precision) series.
"""

import math

import numpy as np
from scipy.linalg import expm

from robolobes import linearize
from robolobes.lobes import LobeProblem, PhysicalStructure, SemiDiscretization
from robolobes.lobes.sdm import SDMEngine, phi_exps


def _van_loan(M, V):
    """Reference: scipy's expm of the augmented matrix, blocks (exp(M), phi1 V, phi2 V)."""
    P, n, _ = M.shape
    k = V.shape[-1]
    Z = np.zeros((P, n + 2 * k, n + 2 * k))
    Z[:, :n, :n] = M
    Z[:, :n, n:n + k] = V
    Z[:, n:n + k, n + k:] = np.eye(k)
    E = expm(Z)
    return E[:, :n, :n], E[:, :n, n:n + k], E[:, :n, n + k:]


def _rel(a, b):
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def test_scalar_closed_forms():
    # Closed forms for a diagonal M = diag(z): exp(z), phi1 = (e^z - 1) / z,
    # phi2 = (e^z - 1 - z) / z^2 (with expm1 for |z| > 0.01, else its series to z^8).
    # z spans 1e-4 .. 30 in modulus (no scaling up to several squarings). rtol 1e-13.
    z = np.array([-1e-4, 3e-3, -0.4, 0.9, -2.5, 7.0, -30.0, 12.5])
    M = np.diag(z)[None]
    V = np.ones((1, len(z), 1))
    E, h0, h1 = phi_exps(M, V)
    phi1 = np.expm1(z) / z
    series = sum(z**i / math.factorial(i + 2) for i in range(9))  # remainder < 1e-2^9 / 11! near 0
    phi2 = np.where(np.abs(z) > 1e-2, (np.expm1(z) - z) / z**2, series)
    np.testing.assert_allclose(np.diag(E[0]), np.exp(z), rtol=1e-13)
    np.testing.assert_allclose(h0[0, :, 0], phi1, rtol=1e-13)
    np.testing.assert_allclose(h1[0, :, 0], phi2, rtol=1e-13)
    assert np.count_nonzero(E[0] - np.diag(np.diag(E[0]))) == 0


def test_random_stable_modal_systems_against_expm():
    # Random damped 2 x 2 modal blocks (as the SDM's structures), a random rank-2 cutting term
    # B W S2 and random B: norms of M from 0.01 to ~25 (0 to 5 squarings; the SDM sees up to ~10 at 10 mm). rtol 1e-12 of the
    # largest entry of each block (scipy's own accuracy is ~1e-15 relative to the norm).
    rng = np.random.default_rng(7)
    n, k, P = 12, 2, 300
    M = np.zeros((P, n, n))
    for b in range(n // 2):
        w = rng.uniform(50, 1500, P)
        zeta = rng.uniform(0.005, 0.1, P)
        M[:, 2 * b, 2 * b + 1] = w
        M[:, 2 * b + 1, 2 * b] = -w
        M[:, 2 * b + 1, 2 * b + 1] = -2 * zeta * w
    Bm = rng.normal(size=(P, n, k))
    S2 = rng.normal(size=(P, 2, n))
    Wc = rng.normal(size=(P, k, 2)) * rng.uniform(0, 150, P)[:, None, None]
    dt = 10.0 ** rng.uniform(-5, -1.8, P)
    M = (M + Bm @ Wc @ S2) * dt[:, None, None]
    V = Bm * dt[:, None, None]
    norms = np.abs(M).sum(axis=1).max(axis=1)
    assert norms.min() < 0.05 and norms.max() > 20
    got = phi_exps(M, V)
    want = _van_loan(M, V)
    for g, w in zip(got, want):
        for i in range(P):
            assert _rel(g[i], w[i]) < 1e-12, (i, norms[i], _rel(g[i], w[i]))


def test_tx200_reduced_structure_steps_against_expm(alu_case, tx200_robot):
    # The SDM's own step matrices for the 18-DOF orthogonal TX200 at Tab. 7, truncated to 300 Hz
    # as in a map, aluminium cut, engaged steps at 2000 and 25 000 rpm and depths 1 and 10 mm.
    # Against the Van Loan expm the SDM used before: rtol 1e-12 per block.
    case, robot = alu_case, tx200_robot("orthogonal")
    lin = linearize.linearize(robot, case.path.start_q_rad)
    red = PhysicalStructure.from_linear(lin, case.cut.feed_direction).truncated(max_freq_hz=300.0)
    eng = SDMEngine(LobeProblem(red, case.tool, case.cut, case.law), SemiDiscretization(m=40), 0.01)
    rpm = np.array([2000.0, 25000.0, 2000.0, 25000.0])
    depth = np.array([1e-3, 1e-3, 1e-2, 1e-2])
    W = eng.plan.wbar(depth, eng.cand).sum(axis=2)  # (4, nc, k, 2)
    nc = W.shape[1]
    dt = np.repeat(eng.period_s(rpm) / eng.plan.m, nc)
    Abar = eng.A[None] + eng.Bk[None] @ W.reshape(-1, eng.k, 2) @ eng.S2[None]
    M = Abar * dt[:, None, None]
    V = eng.Bk[None] * dt[:, None, None]
    got = phi_exps(M, V)
    want = _van_loan(M, V)
    for g, w in zip(got, want):
        for i in range(len(dt)):
            assert _rel(g[i], w[i]) < 1e-12
    # and the SDM's (Phi, Gamma0, Gamma1) as the module docstring defines them
    Phi, G0, G1 = eng._step_exps(dt, W.reshape(-1, eng.k, 2))
    np.testing.assert_allclose(G0 + G1, want[1], rtol=0, atol=1e-12 * np.abs(want[1]).max())
    np.testing.assert_allclose(G1, want[2], rtol=0, atol=1e-12 * np.abs(want[2]).max())


def test_empty_batch():
    E, h0, h1 = phi_exps(np.zeros((0, 4, 4)), np.zeros((0, 4, 2)))
    assert E.shape == (0, 4, 4) and h0.shape == (0, 4, 2) and h1.shape == (0, 4, 2)
