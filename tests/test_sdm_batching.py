"""The SDM engine's grouped batching (``SemiDiscretization(batching="grouped")``, the default)
against the single-layout batching of the earlier code (``batching="single"``).

"grouped" evaluates the pairs of a batch in depth-sorted runs, each with the reduced monodromy of
its own largest depth (a helical tool engages more steps at larger depths), and keeps the critical
multiplier and chatter frequency of the unstable pairs it evaluated (eigenvector by one step of
inverse iteration, :func:`lobes.sdm.eigenvector_of`). The multipliers are the same products of
the same step matrices: a smaller layout only leaves out zero multipliers (unread history nodes)
and treats non-engaged steps as merged free flight (``exp(A L dt)`` instead of ``L`` steps with
zero cutting term, equal to rounding). Tolerances are therefore rounding-level (1e-11 relative on
multipliers; measured 2e-14 on the TX200), far below anything a depth search resolves.
"""

import numpy as np
import pytest

from robolobes import linearize
from robolobes.cases.milling import Cut, CuttingLaw, Tool
from robolobes.lobes import LobeProblem, Mode, ModalStructure, PhysicalStructure, RefinedSDM, SemiDiscretization, solve
from robolobes.lobes._errors import LobeError
from robolobes.lobes.sdm import SDMEngine, eigenvector_of


def _helical_2dof() -> LobeProblem:
    """The symmetric 2-DOF benchmark with a 30 deg helix (16 axial slices: depth-dependent layout)."""
    fn, zeta, mt = 922.0, 0.011, 0.03993
    k = mt * (2 * np.pi * fn) ** 2
    s = ModalStructure((Mode(fn, zeta, k, (1.0, 0.0)), Mode(fn, zeta, k, (0.0, 1.0))))
    return LobeProblem(s, Tool(diameter_m=0.01, teeth=2, helix_rad=np.radians(30.0)),
                       Cut(ae_m=0.0005, ap_m=1e-3, spindle_rpm=1e4, mode="down"), CuttingLaw(ktc_pa=6e8, krc_pa=2e8))


@pytest.fixture(scope="module")
def tx200_problem(alu_case, tx200_robot):
    case = alu_case
    lin = linearize.linearize(tx200_robot("orthogonal"), case.robot.poses_rad["tab7"])
    return LobeProblem(PhysicalStructure.from_linear(lin, case.cut.feed_direction), case.tool, case.cut, case.law)


def _engines(problem, m=40):
    return (SDMEngine(problem, SemiDiscretization(m=m, batching="single"), 0.01),
            SDMEngine(problem, SemiDiscretization(m=m), 0.01))


def test_eigenvector_of_closed_form():
    # U = V diag(lam) V^-1 with known V: the returned vector is parallel to V[:, k] (|cos| = 1 to
    # 1e-10; the inverse-iteration error is ~1e-12 |mu| / gap, gaps here >= 0.05).
    rng = np.random.default_rng(3)
    N = 12
    V = rng.normal(size=(N, N)) + 1j * rng.normal(size=(N, N))
    lam = np.exp(1j * np.linspace(0.1, 3.0, N)) * np.linspace(0.2, 1.05, N)
    U = (V * lam) @ np.linalg.inv(V)
    for k in (N - 1, 0, 5):
        z = eigenvector_of(U[None], lam[k:k + 1])[0]
        cos = abs(np.vdot(V[:, k], z)) / np.linalg.norm(V[:, k])
        assert abs(cos - 1) < 1e-10
    # an exactly diagonal matrix (the shifted matrix is far from singular only by the 1e-12 shift)
    z = eigenvector_of(np.diag([0.3, 1.0, 0.7])[None], np.array([1.0 + 0j]))[0]
    np.testing.assert_allclose(np.abs(z), [0, 1, 0], atol=1e-10)


def test_grouped_runs_use_smaller_layouts_and_same_multipliers(tx200_problem):
    # TX200 18-DOF, m = 40, depths 0.5 mm .. 10 mm mixed: "single" uses the 10 mm layout for every
    # pair; "grouped" runs of shallower pairs have fewer history nodes. Spectral radius and
    # critical multiplier agree to 1e-11, and so do the 36 largest multipliers.
    single, grouped = _engines(tx200_problem)
    rpm = np.linspace(2000.0, 25000.0, 40)
    depth = np.tile([0.5e-3, 1e-2, 2e-3, 4e-3], 10)
    runs = grouped.batches(depth)
    sizes = {grouped.structure_for(float(depth[j].max())).n_red for j in runs}
    assert len(runs) > 1 and min(sizes) < single.n_red
    assert sorted(np.concatenate(runs).tolist()) == list(range(len(depth)))
    e1, e2 = single.spectra(rpm, depth), grouped.spectra(rpm, depth)
    assert e2.shape[1] <= e1.shape[1]
    r1, r2 = np.abs(e1).max(axis=1), np.abs(e2).max(axis=1)
    np.testing.assert_allclose(r2, r1, rtol=1e-11)
    top = lambda e: -np.sort(-np.abs(e), axis=1)[:, :36]
    np.testing.assert_allclose(top(e2), top(e1), rtol=0, atol=1e-11)
    mu1, mu2 = single.multipliers(rpm, depth)[1], grouped.multipliers(rpm, depth)[1]
    np.testing.assert_allclose(mu2, mu1, rtol=1e-11)


def test_kept_critical_equals_lapack_eigenvectors(tx200_problem):
    # The critical multiplier and chatter frequency kept by spectra() (inverse iteration) equal
    # those of the earlier code (LAPACK eigenvectors, a fresh evaluation): mu to 1e-11, frequency
    # to 1e-9 relative; and critical() at the kept pairs evaluates nothing.
    single, grouped = _engines(tx200_problem)
    rpm = np.linspace(2000.0, 25000.0, 12)
    depth = np.full(12, 9.5e-3)
    un = np.abs(grouped.spectra(rpm, depth)).max(axis=1) >= 1.0
    assert 2 <= un.sum() < len(rpm)
    rho2, mu2, f2 = grouped.critical(rpm[un], depth[un])
    assert grouped.critical_evaluations == 0
    rho1, mu1, f1 = single.critical(rpm[un], depth[un])
    assert single.critical_evaluations == un.sum()
    np.testing.assert_allclose(mu2, mu1, rtol=1e-11)
    np.testing.assert_allclose(f2, f1, rtol=1e-9)
    # the stable pairs were not kept: computed now (same values as the earlier code)
    _, mu3, f3 = grouped.critical(rpm[~un], depth[~un])
    _, mu4, f4 = single.critical(rpm[~un], depth[~un])
    assert grouped.critical_evaluations == (~un).sum()
    np.testing.assert_allclose(mu3, mu4, rtol=1e-11)
    np.testing.assert_allclose(f3, f4, rtol=1e-9)


def test_refined_diagram_same_as_single_batching():
    # The default diagram of a helical 2-DOF problem with both batchings: the depth searches see
    # the same multipliers to rounding, so they take the same steps; limits agree to 1e-9 relative
    # (not bitwise: the layouts differ), status, levels and bifurcations are identical. Same search
    # ("fast") in both.
    p = _helical_2dof()
    speeds = np.linspace(6000.0, 24000.0, 24)
    a = solve(p, RefinedSDM(SemiDiscretization(batching="single")), speeds, depth_max_m=10e-3)
    b = solve(p, RefinedSDM(), speeds, depth_max_m=10e-3)
    assert np.all(np.isfinite(a.depth_limit_m) == np.isfinite(b.depth_limit_m))
    fin = np.isfinite(a.depth_limit_m)
    assert fin.sum() > 10
    np.testing.assert_allclose(b.depth_limit_m[fin], a.depth_limit_m[fin], rtol=1e-9)
    np.testing.assert_allclose(b.chatter_freq_hz[fin], a.chatter_freq_hz[fin], rtol=1e-9)
    assert np.array_equal(np.asarray(b.status), np.asarray(a.status))
    assert np.array_equal(np.asarray(b.m_final), np.asarray(a.m_final))
    assert list(b.bifurcation) == list(a.bifurcation)
    # 4 states: below _KEEP_MIN_STATES nothing is kept, so the searches made the same evaluations
    assert b.stats["evaluations"] == a.stats["evaluations"]


def test_batching_is_checked():
    with pytest.raises(LobeError, match="batching"):
        SemiDiscretization(batching="fast")  # type: ignore[arg-type]
