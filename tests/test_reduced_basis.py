"""Reduced modal basis (lobes.basis): closed forms on spring-mass chains, and lobes against the full model."""

import math
from dataclasses import replace

import numpy as np
import pytest

from robolobes.lobes import LobeError, PhysicalStructure, SemiDiscretization, solve
from robolobes.lobes.basis import (BASIS_REL_TOL, basis_for, loop_stiffness, reduced_basis, residual_mode,
                                   truncated_with_residual)


def _chain(masses, k, c_ground, beta):
    """Fixed-free chain ground-k-m1-k-m2-...; dashpot c_ground on the first mass only plus
    stiffness-proportional beta K (non-proportional overall); tool tip = last mass, along x_c."""
    n = len(masses)
    K = np.zeros((n, n))
    for i in range(n):
        K[i, i] += k
        if i > 0:
            K[i - 1, i - 1] += k
            K[i - 1, i] -= k
            K[i, i - 1] -= k
    M = np.diag(np.asarray(masses, dtype=float))
    C = beta * K
    C[0, 0] += c_ground
    tcp = np.zeros((2, n))
    tcp[0, -1] = 1.0
    return M, C, K, tcp


def _direct(M, C, K, tcp, w):
    """Tip receptance x_c/F_x by a direct solve of (K - w^2 M + i w C) x = tcp^T: independent of the
    modal code under test."""
    return np.array([np.linalg.solve(K - wi**2 * M + 1j * wi * C, tcp[0])[-1] for wi in w])


def _natural_hz(M, C, K):
    n = len(M)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    lam = np.linalg.eigvals(A)
    return np.sort(np.abs(lam[np.imag(lam) > 0]) / (2 * math.pi))


CHAIN3 = _chain([10.0, 5.0, 0.2], 1e7, 2e3, 0.0)


def test_static_residual_makes_the_chain_compliance_exact_at_zero_frequency():
    M, C, K, tcp = CHAIN3
    C = C.copy()
    C[1:, 1:] += 50.0 * np.array([[1.0, -1.0], [-1.0, 1.0]])  # damp the top mode (a dashpot across spring 3)
    st = PhysicalStructure(M, C, K, tcp)
    fn = _natural_hz(M, C, K)
    assert fn[1] < 300.0 < fn[2]  # the top mode (about 1150 Hz) is the one truncated
    red = truncated_with_residual(st, 300.0)
    assert red.report.dropped_freq_hz == pytest.approx((fn[2],), rel=1e-9)
    # closed form: the tip of a fixed-free chain of three springs k in series, 3 / k
    h0 = red.ss.receptance(np.array([0.0]))[0, 0, 0]
    assert h0 == pytest.approx(3 / 1e7, rel=1e-12)  # rounding only
    plain = st.truncated(max_freq_hz=300.0).ss.receptance(np.array([0.0]))[0, 0, 0]
    assert abs(plain / (3 / 1e7) - 1) > 1e-3  # without the correction the top mode's share is lost
    # the residual mode sits at the dropped mode's frequency: the reduced receptance up to 300 Hz
    # stays within 1e-4 of the direct solve (the dropped mode's complex residue differs from
    # its static compliance by its non-proportional damping only)
    w = 2 * math.pi * np.linspace(0.0, 300.0, 301)
    Hd = _direct(M, C, K, tcp, w)
    Hr = red.ss.receptance(w)[0, 0]
    assert np.max(np.abs(Hr - Hd) / np.abs(Hd)) < 1e-4


def test_residual_mode_is_the_second_order_filter_of_the_static_compliance():
    rng = np.random.default_rng(7)
    G = rng.normal(size=(3, 3)) * 1e-7
    wr, z = 2 * math.pi * 900.0, 0.05
    res = residual_mode(G, wr, z)
    assert res is not None and res.n_states == 4  # rank 2 in the cut plane: two blocks
    w = 2 * math.pi * np.array([0.0, 100.0, 500.0, 899.0, 2000.0])
    g = wr**2 / (wr**2 - w**2 + 2j * z * wr * w)
    H = res.receptance(w)
    np.testing.assert_allclose(H[:2], G[:2, :, None] * g[None, None, :], rtol=1e-12, atol=1e-12 * np.abs(G).max())
    assert not np.any(H[2])  # the axial output is not carried


def test_the_rule_meets_its_bound_at_the_band_edge_and_keeps_the_low_modes():
    # five masses: two heavy (modes near 120 and 290 Hz) and three light (modes above 1 kHz)
    M, C, K, tcp = _chain([10.0, 5.0, 0.05, 0.05, 0.05], 1e7, 2e3, 1e-6)
    st = PhysicalStructure(M, C, K, tcp)
    fn = _natural_hz(M, C, K)
    f_band, k_loop = 300.0, 1e5
    red = reduced_basis(st, f_band, k_loop)
    assert red.basis.kind == "reduced" and red.basis.n_states < 10
    assert red.report.kept_freq_hz == pytest.approx(tuple(fn[:2]), rel=1e-9)  # the two in-band modes stay
    # the rule's bound e(w) = 2 k_loop |H_red - H| <= BASIS_REL_TOL, checked against the direct solve
    w = 2 * math.pi * np.array([0.0, 0.5 * f_band, f_band])
    Hd = _direct(M, C, K, tcp, w)
    e = 2 * k_loop * np.abs(red.ss.receptance(w)[0, 0] - Hd)
    assert e[-1] <= BASIS_REL_TOL and e.max() <= BASIS_REL_TOL
    assert e[0] <= 1e-12 * 2 * k_loop * abs(Hd[0])  # exact at w = 0 (rounding)
    # a stiffer loop feels more modes: the rule keeps the 1 kHz mode at 1e6 N/m, and at 1e8 N/m
    # everything (dropping the two top modes would need as many residual states as they have)
    assert reduced_basis(st, f_band, 1e6).report.kept_freq_hz == pytest.approx(tuple(fn[:3]), rel=1e-9)
    assert reduced_basis(st, f_band, 1e8).basis.kind == "full"


def test_the_rule_keeps_the_full_model_when_the_residual_saves_no_state():
    M, C, K, tcp = CHAIN3
    C = C.copy()
    C[1:, 1:] += 50.0 * np.array([[1.0, -1.0], [-1.0, 1.0]])
    red = reduced_basis(PhysicalStructure(M, C, K, tcp), 300.0, 1e5)
    # dropping the one top mode would need one residual block for it: no saving
    assert red.basis.kind == "full" and red.basis.n_states == red.basis.n_states_full == 6


def test_bad_rule_inputs_name_the_value():
    st = PhysicalStructure(*CHAIN3)
    with pytest.raises(LobeError, match="f_band_hz"):
        reduced_basis(st, -1.0, 1e5)
    with pytest.raises(LobeError, match="loop_stiffness"):
        reduced_basis(st, 300.0, float("nan"))


@pytest.mark.parametrize("ae_frac,angle", [(1.0, math.pi), (0.5, math.pi / 2)])
def test_loop_stiffness_is_the_closed_form(ae_frac, angle):
    # D(phi) = f n^T with |n| = 1 and |f| = sqrt(Ktc^2 + Krc^2 + Kac^2): ||D||_2 is that constant, so
    # k_loop = N a_max sqrt(Ktc^2 + Krc^2) * (engaged angle) / (2 pi); slot: pi, half immersion: pi / 2
    from robolobes.cases.milling import Cut, CuttingLaw, Tool

    tool = Tool(diameter_m=0.02, teeth=2)
    cut = Cut(ae_m=0.02 * ae_frac, ap_m=1e-3, spindle_rpm=10000.0, mode="down")
    law = CuttingLaw(ktc_pa=1e9, krc_pa=3e8)
    k = loop_stiffness(tool, cut, law, 2e-3)
    assert k == pytest.approx(2 * 2e-3 * math.hypot(1e9, 3e8) * angle / (2 * math.pi), rel=1e-10)


def test_reduced_basis_lobes_match_the_full_model_on_a_robot_pose(alu_case, tx200_robot):
    from robolobes import linearize
    from robolobes.lobes import LobeProblem

    case = alu_case
    lin = linearize.linearize(tx200_robot("orthogonal"), case.robot.poses_rad["tab7"])
    p = LobeProblem(PhysicalStructure.from_linear(lin, case.cut.feed_direction), case.tool, case.cut, case.law)
    speeds, depth = np.linspace(2000.0, 8000.0, 20), 3e-3
    red = basis_for(p, speeds, depth)
    assert red.basis.kind == "reduced" and red.basis.n_states < red.basis.n_states_full
    m40 = SemiDiscretization(m=40)  # one level: the same discretization for both, so only the basis differs
    full = solve(p, m40, speeds, depth_max_m=depth)
    reduced = solve(replace(p, structure=red), m40, speeds, depth_max_m=depth)
    fin = np.isfinite(full.depth_limit_m)
    assert fin.sum() >= 5 and np.array_equal(fin, np.isfinite(reduced.depth_limit_m))
    # the rule's loop perturbation <= 1e-3 moves a limit by about 0.1 % (times an eigenvector
    # condition number); asserted at the 0.5 % target
    np.testing.assert_allclose(reduced.depth_limit_m[fin], full.depth_limit_m[fin], rtol=5e-3)


@pytest.mark.parametrize("flag", [[], ["--reduced-basis"]])
def test_lobes_json_records_the_basis(flag, capsys, monkeypatch, tmp_path):
    import json

    from robolobes.main import main

    monkeypatch.chdir(tmp_path)
    rc = main(["lobes", "--case", "tx200-aluminium", "--variant", "orthogonal", "--n-rpm", "4", "--rpm-max", "8000",
               "--depth-max-mm", "3", "--at-rpm", "6000", "--at-depth-mm", "0.5", "--no-refine", "--json", "--quiet",
               *flag])
    assert rc == 0
    basis = json.loads(capsys.readouterr().out)["basis"]
    if flag:  # band 2 x 2 teeth x 8000 rpm = 533 Hz, loop at 3 mm: the rule drops modes (as in the test above)
        assert basis["kind"] == "reduced" and basis["n_states"] < basis["n_states_full"] == 36
        assert basis["band_hz"] == pytest.approx(2 * 2 * 8000 / 60) and basis["max_loop_error"] <= BASIS_REL_TOL
    else:
        assert basis["kind"] == "full"
