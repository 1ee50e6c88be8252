"""The depth search of ``lobes.solve``: the fast search (followed critical multiplier, straddling
pairs, warm-started finer levels) against the plain one it replaces, and on a synthetic spectrum
whose critical depth is known in closed form."""

import numpy as np
import pytest

from robolobes.cases.milling import Cut, CuttingLaw, Tool
from robolobes.lobes import LobeProblem, Mode, ModalStructure, RefinedSDM, SemiDiscretization, solve
from robolobes.lobes.sdm import SDMEngine
from robolobes.lobes.solver import _grid, _refine, _warm_search

B_STAR = 2.345e-3   # m, the synthetic critical depth
SLOPE = 12.0        # 1/m: d|mu|/db of the critical multiplier, |mu| = 1 + SLOPE (b - B_STAR) / B_STAR


def synthetic_spectrum(rpm, depth):
    """Two multipliers per point (B, 2): a structural one, 0.997 at every depth, and a flip
    multiplier ``-(1 + SLOPE (b - b*) / b*)``. The spectral radius ``max(0.997, |mu_flip|)`` has a
    kink below ``b*`` (at ``|mu_flip| = 0.997``) and crosses 1 exactly at ``b* = B_STAR``."""
    depth = np.asarray(depth, dtype=float)
    flip = -(1.0 + SLOPE * (depth - B_STAR) / B_STAR)
    return np.stack([np.full(depth.shape, 0.997 + 0.0j), flip + 0.0j], axis=1)


def _search(fast: bool):
    rpm = np.full(5, 10000.0)
    lo, hi = np.array([1.0e-3, 1.5e-3, 2.0e-3, 2.2e-3, 2.3e-3]), np.full(5, 3.0e-3)
    rho = lambda s, d: np.abs(synthetic_spectrum(s, d)).max(axis=1)
    glo, ghi = rho(rpm, lo) - 1, rho(rpm, hi) - 1
    st = {"evaluations": 0, "rounds": 0}
    est, _ = _refine(rho, rpm, lo, glo, hi, ghi, 1e-3, st, straddle=fast,
                     eig_fn=synthetic_spectrum if fast else None)
    return est, st["evaluations"]


def test_refine_finds_the_closed_form_limit_through_the_kink_with_fewer_evaluations():
    # Both searches end with a bracket of relative width <= rtol = 1e-3 around b*; the estimate
    # lies in it: rtol 1e-3. The fast one interpolates on the flip multiplier's own modulus
    # (linear in b here, so its secant is exact) instead of the kinked spectral radius: it must
    # need at most half the evaluations of the plain Illinois search.
    est_plain, n_plain = _search(False)
    est_fast, n_fast = _search(True)
    np.testing.assert_allclose(est_plain, B_STAR, rtol=1e-3)
    np.testing.assert_allclose(est_fast, B_STAR, rtol=1e-3)
    assert n_fast <= n_plain / 2, (n_fast, n_plain)


def insperger_2dof() -> LobeProblem:
    fn, zeta, k = 922.0, 0.011, 1.340049648e6
    s = ModalStructure((Mode(fn, zeta, k, (1.0, 0.0)), Mode(fn, zeta, k, (0.0, 1.0))))
    return LobeProblem(s, Tool(diameter_m=0.01, teeth=2), Cut(ae_m=0.0005, ap_m=1e-3, spindle_rpm=1e4, mode="down"),
                       CuttingLaw(ktc_pa=6e8, krc_pa=2e8))


def test_warm_start_far_from_the_limit_falls_back_to_the_grid_bracket():
    # A start 40 % below the level's own limit: the +-4 % bracket does not hold the sign change,
    # so the grid bracket is verified instead; the limit is the plain search's to the bracket
    # width (each within rtol 1e-3 of the root: rtol 2e-3 between them).
    p = insperger_2dof()
    eng = SDMEngine(p, SemiDiscretization(m=40), 0.01)
    rpm = np.array([7000.0, 18700.0])
    ref = solve(p, SemiDiscretization(m=40, search="plain"), rpm).depth_limit_m
    st = {"evaluations": 0, "rounds": 0}
    rho0 = np.max(np.abs(np.exp(np.outer(eng.period_s(rpm), eng.ss.poles))), axis=1)
    est, _, found = _warm_search(eng, rpm, rho0, 0.6 * ref, _grid(0.01, 16), 1e-3, st)
    assert found.all() and st["warm_rejected"] == 2
    np.testing.assert_allclose(est, ref, rtol=2e-3)


def _warm(adaptive: bool, rel_shift):
    """The m = 80 limits of the benchmark at 12 speeds, warm-started from ``ref (1 + rel_shift)``
    (``ref``: the plain search's own m = 80 limits to rtol 1e-7)."""
    p = insperger_2dof()
    eng = SDMEngine(p, SemiDiscretization(m=80), 0.01)
    rpm = np.linspace(15000.0, 21000.0, 12)
    ref = solve(p, SemiDiscretization(m=80, search="plain"), rpm, rtol=1e-7).depth_limit_m
    assert np.all(np.isfinite(ref))
    st = {"evaluations": 0, "rounds": 0}
    rho0 = np.max(np.abs(np.exp(np.outer(eng.period_s(rpm), eng.ss.poles))), axis=1)
    est, _, found = _warm_search(eng, rpm, rho0, ref * (1 + rel_shift), _grid(0.01, 24), 1e-3, st, adaptive=adaptive)
    assert found.all()
    return est, ref, st


def test_adaptive_warm_start_same_limits_fewer_evaluations():
    # Starts 0.2 % above the level's limits (a finer level's typical shift on the TX200): every 5th
    # speed is a probe with +-4 %, the others get +-0.6 % (2 * 0.2 % + 0.2 %) and a straddling pair
    # at once. Each search brackets the root to rtol = 1e-3 (plus the reference's 1e-7): the
    # estimates agree with the reference to 1.01e-3 either way, and the adaptive one needs fewer
    # evaluations.
    est_w, ref, st_w = _warm(False, 0.002)
    est_a, _, st_a = _warm(True, 0.002)
    np.testing.assert_allclose(est_w, ref, rtol=1.01e-3)
    np.testing.assert_allclose(est_a, ref, rtol=1.01e-3)
    assert st_a.get("warm_narrow_rejected", 0) == 0
    assert st_a["evaluations"] < st_w["evaluations"], (st_a["evaluations"], st_w["evaluations"])


def test_adaptive_warm_start_retries_the_wide_bracket_where_the_narrow_one_fails():
    # The probes (speeds 0, 5, 10) start 0.1 % off, the others 3 % below: their +-0.4 % brackets
    # do not hold the sign change, are counted, and retried at +-4 %; same limits (rtol 1.01e-3).
    shift = np.full(12, -0.03)
    shift[::5] = 0.001
    est, ref, st = _warm(True, shift)
    assert st["warm_narrow_rejected"] == 9 and st.get("warm_rejected", 0) == 0
    np.testing.assert_allclose(est, ref, rtol=1.01e-3)


@pytest.mark.parametrize("ae_m, mode", [(0.0005, "down"), (0.01, "down")])
def test_fast_and_plain_search_agree_on_the_benchmark(ae_m, mode):
    # Same levels, same rule; each level's limit is bracketed to rtol = 1e-3 by either search, so
    # a Richardson value b_2m + (b_2m - b_m)/3 moves by at most (4/3 + 1/3) 1e-3 per search:
    # rtol 3.4e-3 between them. Statuses must be equal.
    p = insperger_2dof()
    from dataclasses import replace
    p = replace(p, cut=replace(p.cut, ae_m=ae_m, mode=mode))
    rpm = np.linspace(5000.0, 25000.0, 13)
    a = solve(p, RefinedSDM(), rpm)
    b = solve(p, RefinedSDM(SemiDiscretization(search="plain")), rpm)
    assert (a.status == b.status).all()
    fin = np.isfinite(b.depth_limit_m)
    assert (np.isfinite(a.depth_limit_m) == fin).all()
    np.testing.assert_allclose(a.depth_limit_m[fin], b.depth_limit_m[fin], rtol=3.4e-3)


def test_search_option_is_validated():
    from robolobes.lobes import LobeError
    with pytest.raises(LobeError, match="search must be 'fast', 'fast-wide' or 'plain'"):
        SemiDiscretization(search="quick")  # type: ignore[arg-type]  # the bad value under test
