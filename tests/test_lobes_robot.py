"""Stability of the TX200 cuts of the paper (Tab. 7 pose), 6-DOF basic and 18-DOF orthogonal models.

Why this is delicate: at 18 700 rpm the principal period (one revolution, variable pitch) is
3.2 ms, the robot modes are at 12-540 Hz, so their Floquet multipliers sit at |mu| = 1 - 1e-3 to
1 - 5e-3 and the cutting moves them by 1e-5..1e-4. For the basic model at 18 700 rpm we measure
(m = 40 / 80 / 160 / 320, Gauss averaging, 16 slices): |mu| - 1 = -6.37e-5 / -6.21e-5 / -6.15e-5 /
-6.13e-5 at 5 mm and +8.59e-5 / +8.73e-5 / +8.78e-5 / +8.80e-5 at 10 mm; the exact-free-decay
scheme gives -6.15e-5 .. -6.13e-5 and +8.88e-5 .. +8.80e-5 (the figures quoted in the issue,
-2.5e-5..-3.4e-5 and +0.7e-5..+2.4e-5, are not reproduced; with a single axial slice and sampled
screen function the values even wander between -1.3e-4 and -4.9e-5, which is the fragility the
issue warns about). The solver therefore decides on the DEPTH: the critical depth at the
operating speed is computed for m and 2m (more while undecided), extrapolated (Richardson,
order 2) and compared with the operating depth with the bound |b_2m - b_m| (lobes.stability).

Measured (both schemes agree within the bound; these are regression anchors of the current
linearize model, not published values):

==========  ==========  =======  ============  ================  ==========  =============
variant     case        verdict  limit (mm)    margin            |mu|        critical
==========  ==========  =======  ============  ================  ==========  =============
basic       aluminium   stable   5.0918        +2.1824 +- 0.002  0.9952464   Hopf 25.07 Hz
basic       steel       unstab.  0.64270       -0.5983 +- 0.001  1.76052     flip 51.67 Hz
orthogonal  aluminium   stable   18.834        +10.771 +- 0.002  0.9978198   Hopf 13.46 Hz
orthogonal  steel       unstab.  0.66354       -0.5853 +- 0.001  1.96954     flip 51.67 Hz
==========  ==========  =======  ============  ================  ==========  =============

Steel is unstable in every model variant, as the paper found in simulation (its real cut was
stable, which the authors attribute to the robot controller); aluminium is stable.
"""

import numpy as np
import pytest
from numpy.testing import assert_allclose

import robolobes.linearize as linearize
from robolobes.cases import load_case
from robolobes.lobes import LobeProblem, PhysicalStructure, SemiDiscretization, solve, stability
from robolobes.lobes.sdm import SDMEngine

EXPECTED = {
    # (variant, case): (verdict, limit_mm, bifurcation at the operating point, chatter Hz)
    ("basic", "tx200-aluminium"): ("stable", 5.0918, "hopf", 25.07),
    ("basic", "tx200-steel"): ("unstable", 0.64270, "flip", 51.667),
    ("orthogonal", "tx200-aluminium"): ("stable", 18.834, "hopf", 13.46),
    ("orthogonal", "tx200-steel"): ("unstable", 0.66354, "flip", 51.667),
}


def robot_problem(robot, casename):
    """The lobe problem of case ``casename`` on ``robot`` (a TX200 from the ``tx200_robot`` fixture) at Tab. 7."""
    case = load_case(casename)
    lin = linearize.linearize(robot, case.robot.poses_rad["tab7"])
    st = PhysicalStructure.from_linear(lin, case.cut.feed_direction)
    return LobeProblem(st, case.tool, case.cut, case.law)


@pytest.mark.parametrize("variant, casename", list(EXPECTED))
def test_tx200_verdict_margin_and_m_convergence(tx200_robot, variant, casename):
    verdict, limit_mm, bif, freq = EXPECTED[(variant, casename)]
    p = robot_problem(tx200_robot(variant), casename)
    pt = stability(p, SemiDiscretization(m=40), depth_max_m=0.02)
    print(f"\n{variant} {casename}: {pt.verdict}, margin {pt.margin:+.5f} +- {pt.margin_error:.2g}, "
          f"limit {pt.depth_limit_m * 1e3:.5f} mm, |mu| = {pt.spectral_radius:.7f}, {pt.bifurcation} "
          f"{pt.chatter_freq_hz:.3f} Hz; limit: {pt.limit_bifurcation} {pt.limit_chatter_freq_hz:.2f} Hz")
    assert pt.verdict.status == verdict
    # the decision is far outside the discretization bound (margin error < 1e-2, |margin| > 0.5)
    assert abs(pt.margin) > 50 * pt.margin_error
    # regression anchor: limit within 0.5 % of the table (Richardson m = 40/80, two schemes)
    assert_allclose(pt.depth_limit_m * 1e3, limit_mm, rtol=5e-3)
    assert pt.bifurcation == bif
    assert_allclose(pt.chatter_freq_hz, freq, rtol=2e-3)
    # verdicts unchanged from m = 40 to m = 160, on the raw spectral radius and on the raw limit
    depth = p.cut.ap_m
    for m in (40, 80, 160):
        e = SDMEngine(p, SemiDiscretization(m=m), 0.02)
        rho = e.multipliers([p.cut.spindle_rpm], [depth])[0][0]
        assert (rho < 1) == (verdict == "stable"), (m, rho)
        b = solve(p, SemiDiscretization(m=m), [p.cut.spindle_rpm], depth_max_m=0.02, rtol=1e-5).depth_limit_m[0]
        assert (depth < b) == (verdict == "stable"), (m, b)
        assert_allclose(b * 1e3, limit_mm, rtol=5e-3)


def test_fifth_decimal_of_mu_and_the_depth_decision(tx200_robot):
    """Basic model, aluminium speed: |mu| - 1 is ~ -6e-5 at 5 mm and ~ +9e-5 at 10 mm for every m
    and both schemes (values in the module docstring); its sign never flips with m, and the
    critical depth (5.092 mm) that the verdict uses lies between the two depths."""
    p = robot_problem(tx200_robot("basic"), "tx200-aluminium")
    for scheme in ("sdm", "free-exact"):
        for m in (40, 80, 160):
            e = SDMEngine(p, SemiDiscretization(m=m, scheme=scheme), 0.02)
            r = e.multipliers([18700.0, 18700.0], [5e-3, 10e-3])[0] - 1
            assert -7e-5 < r[0] < -5.5e-5 and 8e-5 < r[1] < 9.5e-5, (scheme, m, r)
    # the exact free decay: at zero depth the multipliers are exp(lambda T) for any m
    e = SDMEngine(p, SemiDiscretization(m=40), 0.02)
    T = 60 / 18700.0
    rho0 = np.max(np.abs(np.exp(e.ss.poles * T)))
    assert_allclose(e.multipliers([18700.0], [1e-12])[0][0], rho0, rtol=1e-9)
    assert 1 - rho0 < 1e-2  # the lightly damped robot modes: |mu| > 0.99 before cutting


def test_prescan_gives_the_sdm_limits(tx200_robot):
    """The free-exact prescan only brackets; the refined limits are the SDM's own (equal within
    the bracket tolerance 1e-6), checked on the 6-DOF model (12 states: prescan on by default)."""
    p = robot_problem(tx200_robot("basic"), "tx200-aluminium")
    sp = np.linspace(3000, 20000, 6)
    a = solve(p, SemiDiscretization(m=40), sp, rtol=1e-7)
    b = solve(p, SemiDiscretization(m=40, prescan=False), sp, rtol=1e-7)
    assert a.stats["prescan_evaluations"] > 0 and "prescan_evaluations" not in b.stats
    assert_allclose(a.depth_limit_m, b.depth_limit_m, rtol=1e-6)
    assert a.bifurcation.tolist() == b.bifurcation.tolist()


def test_modal_truncation_of_the_18dof_model_reports_its_error(tx200_robot):
    """Dropping the six fast overdamped poles (|lambda| / 2 pi > 600 Hz) of the orthogonal model:
    the report gives the static compliance error (5.9e-4 measured) and the FRF error below 300 Hz
    (3.2e-5); the steel limit moves by 0.5 % -- the same order as the compliance error times the
    sensitivity of a flip lobe, and well inside the margin of that cut (-0.59)."""
    from dataclasses import replace

    p = robot_problem(tx200_robot("orthogonal"), "tx200-steel")
    assert isinstance(p.structure, PhysicalStructure)  # robot_problem builds one
    red = p.structure.truncated(max_freq_hz=600.0, band_hz=(0.0, 300.0))
    rep = red.report
    assert len(rep.kept_freq_hz) == 15 and len(rep.dropped_freq_hz) == 6 and max(rep.kept_freq_hz) <= 600
    assert rep.static_compliance_rel_error < 1e-3 and rep.frf_rel_error < 1e-4
    meth = SemiDiscretization(m=40)
    b_red = solve(replace(p, structure=red), meth, [3100.0], rtol=1e-7).depth_limit_m[0]
    b_full = solve(p, meth, [3100.0], rtol=1e-7).depth_limit_m[0]
    assert_allclose(b_red, b_full, rtol=1e-2)
    assert stability(replace(p, structure=red), meth, depth_max_m=0.02).verdict.status == "unstable"


def test_structure_frf_equals_the_linearized_robot_frf_in_the_cut_frame(steel_case, tx200_robot):
    """Two codes, one receptance: lobes.PhysicalStructure.from_linear(...).frf (direct solve on the
    cut-frame tcp rows) against linearize.LinearModel.frf(frame="cut") (its own direct solve), both in
    the core.frf convention (3, 3, F), m/N, omega rad/s, frame "cut"; equal to rounding (1e-9)."""
    case = steel_case
    lin = linearize.linearize(tx200_robot("basic"), case.robot.poses_rad["tab7"])
    w = 2 * np.pi * np.linspace(1.0, 200.0, 50)
    a = PhysicalStructure.from_linear(lin, case.cut.feed_direction).frf(w)
    b = lin.frf(w, frame="cut", feed_direction=case.cut.feed_direction)
    assert a.frame == b.frame == "cut" and a.H.shape == b.H.shape == (3, 3, 50)
    assert_allclose(a.omega, w, rtol=0)
    assert_allclose(a.H, b.H, rtol=1e-9, atol=1e-9 * np.abs(b.H).max())
