"""The eroded part (``LinearizedNewmark``, linearized path, basic model) on the TX200 aluminium case
(30 deg helix, 170/190 deg pitch, feed 0.03 mm, 45 mm part) at 0.5, 0.8, 1.25 and 2 times the SDM
limit, kicked (the speed of a 100 nm oscillation at the 24.7 Hz chatter frequency, at full
engagement), 2 deg per step, default discs: its growth rate, fitted over the periods whose motion
is at least 10 x the verdict's 2 nm resolution, against the SDM linearized about the run's forced
orbit (entry shift, surface tilt and the delayed instant at ae minus the deflection when the teeth
meet the part). docs/guide/timedomain-convergence.md, "The eroded part about its forced orbit at
the four factors"; the same numbers print from
``python bench/bench_timedomain_convergence.py --orbit --case alu-helix``. On steel without runout
above the limit the mode saturates before full engagement: the rule must give no rate, with its
reason (section "Steel below the limit by a rule stated before the runs"). The matrix-pencil rate
(``pencil_growth_rate``) meets the criterion on steel with and without runout below the limit
(kicked minus unkicked, the largest linear kick) and on aluminium at the four factors (section
"The leading multiplier by the matrix pencil")."""

from __future__ import annotations

import math
import warnings
from dataclasses import replace

import numpy as np
import pytest

import robolobes.linearize as L
from robolobes import cases
from robolobes.cases.milling import principal_period
from robolobes.lobes import LobeProblem, PhysicalStructure, SemiDiscretization, solve
from robolobes.lobes.entry_shift import entry_shift_exponent
from robolobes.timedomain import LinearizedNewmark, SimulationProblem, simulate
from robolobes.timedomain.forced_orbit import entry_deflection, orbit_period_s
from robolobes.timedomain.rate import (
    gated_growth_rate,
    linear_kick_amplitude_m,
    pencil_over_window,
    regenerative_loss_per_period,
)
from robolobes.timedomain.verdict import chip_scale

KICK_M = 1e-7  # amplitude of the kick's oscillation, m
CHATTER_HZ = 24.7  # the aluminium case's chatter frequency, Hz
TOL = 0.03  # 1/s: the criterion's absolute floor


@pytest.fixture(scope="module")
def aluminium():
    """(robot, case, structure, SDM limit m): the bench's ``alu-helix`` case."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", L.JointLimitWarning)
        case = cases.load_case("tx200-aluminium")
        case = replace(case, cut=replace(case.cut, feed_per_tooth_m=3e-5),
                       path=replace(case.path, part_length_m=0.045))
        robot = L.build_model(case.robot, "basic")
        st = PhysicalStructure.from_linear(L.linearize(robot, case.path.start_q_rad), case.cut.feed_direction)
    p = LobeProblem(st, case.tool, case.cut, case.law)
    lim = solve(p, SemiDiscretization(m=40, axial_slices=32, richardson=True), [case.cut.spindle_rpm])
    return robot, case, st, float(lim.depth_limit_m[0])


def _kicked(robot, case, cut, kick_m_s: float, t_end_s: float | None = None):
    """(run, principal period s, steady window start s, its end s, cut-plane deviation (n, 2) m) of
    the eroded part kicked by ``kick_m_s`` at full engagement."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", L.JointLimitWarning)  # the start pose's A3, accepted within 5 deg
        run = simulate(SimulationProblem(robot, replace(case, cut=cut), t_end_s=t_end_s),
                       LinearizedNewmark(kick_m_s=kick_m_s), verdict_companion=False)
    t0, t1 = run.steady_window_s
    return run, principal_period(case.tool, cut)[0], t0, min(t1, float(run.t_s[-1])), run.tcp_deviation_m[:, :2]


def _rate_and_reference(aluminium, factor: float) -> tuple[float, float, float]:
    """(eroded rate 1/s, its SE 1/s, SDM exponent about the forced orbit 1/s) at ``factor`` x the limit."""
    robot, case, st, lim = aluminium
    cut = replace(case.cut, ap_m=factor * lim)
    run, tp, t0, t1, xy = _kicked(robot, case, cut, 2 * math.pi * CHATTER_HZ * KICK_M)
    # no chip-loss gate: the bench's per-period loss stays below 1 % at every factor (max 0.005)
    g = gated_growth_rate(run.t_s, xy, tp, t_start_s=t0, t_end_s=t1)
    return g.rate_per_s, g.se_per_s, _orbit_sigma(st, case, cut, run)


@pytest.mark.slow
@pytest.mark.long
@pytest.mark.parametrize("factor", [0.5, 0.8, 1.25, 2.0])
def test_kicked_eroded_rate_meets_the_sdm_about_its_forced_orbit(aluminium, factor):
    # The like-with-like criterion, max(10 % |sigma|, 0.03 1/s) + 2 SE. Measured (bench, 2 deg,
    # default discs): 0.5x -0.9098 +- 0.0310 against -0.8647; 0.8x -0.1855 +- 0.0139 against -0.1693;
    # 1.25x +0.3727 +- 0.0127 against +0.3793; 2x +0.4473 +- 0.0082 against +0.4501 1/s. The plain SDM
    # at ae minus the mean deflection (+0.2419 at 1.25x, +0.1743 at 2x) fails at 1.25x and 2x.
    rate, se, sigma = _rate_and_reference(aluminium, factor)
    assert math.isfinite(rate)
    assert abs(rate - sigma) <= max(0.1 * abs(sigma), TOL) + 2 * se


@pytest.fixture(scope="module")
def steel_no_runout():
    """(robot, case, structure, SDM limit m): the bench's ``steel-no-runout`` case (the steel case's
    tool without runout: the same linear problem, period one tooth)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", L.JointLimitWarning)
        case = cases.load_case("tx200-steel")
        case = replace(case, tool=replace(case.tool, runout_m=(0.0, 0.0)))
        robot = L.build_model(case.robot, "basic")
        st = PhysicalStructure.from_linear(L.linearize(robot, case.path.start_q_rad), case.cut.feed_direction)
    p = LobeProblem(st, case.tool, case.cut, case.law)
    lim = solve(p, SemiDiscretization(m=40, axial_slices=32, richardson=True), [case.cut.spindle_rpm])
    return robot, case, st, float(lim.depth_limit_m[0])


@pytest.mark.slow
@pytest.mark.long
def test_steel_above_the_limit_gives_no_rate_and_says_why(steel_no_runout):
    # Steel at 1.25x without runout: the mode (+19 1/s about the orbit) saturates during the 2.1 s
    # from first contact to full engagement, so every full-engagement period but the first has chip
    # loss >= 5 % (bench: 215 of 216, 0.346 in the second). The rule must then give no rate, with
    # its reason, never the rate of the saturated motion.
    robot, case, _, lim = steel_no_runout
    cut = replace(case.cut, ap_m=1.25 * lim)
    flip_hz = cut.spindle_rpm / 60.0 * case.tool.teeth / 2.0
    run, tp, t0, t1, xy = _kicked(robot, case, cut, 2 * math.pi * flip_hz * KICK_M, t_end_s=4.5)
    loss = regenerative_loss_per_period(run.t_s, xy, chip_scale(case.tool, cut), tp, t0, t1)
    assert (loss[1:] >= 0.05).all()
    g = gated_growth_rate(run.t_s, xy, tp, t_start_s=t0, t_end_s=t1, loss=loss)
    assert g.estimate is None and not math.isfinite(g.rate_per_s)
    assert "chip loss" in g.reason


@pytest.fixture(scope="module")
def steel():
    """(robot, case, structure, SDM limit m): the bench's ``steel`` case (its own tool, with runout)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", L.JointLimitWarning)
        case = cases.load_case("tx200-steel")
        robot = L.build_model(case.robot, "basic")
        st = PhysicalStructure.from_linear(L.linearize(robot, case.path.start_q_rad), case.cut.feed_direction)
    p = LobeProblem(st, case.tool, case.cut, case.law)
    lim = solve(p, SemiDiscretization(m=40, axial_slices=32, richardson=True), [case.cut.spindle_rpm])
    return robot, case, st, float(lim.depth_limit_m[0])


def _orbit_sigma(st, case, cut, run) -> float:
    """The SDM about the run's forced orbit (entry shift, tilt, delayed instant), 1/s."""
    narrow = replace(cut, ae_m=cut.ae_m - entry_deflection(run))  # down-milling: ae minus the deflection
    return float(entry_shift_exponent(LobeProblem(st, case.tool, narrow, case.law), SemiDiscretization(m=40),
                                      surface_tilt=True, delay_time=True).value_per_s)


def _pencil_over_gate(t_s, x, tp, t0, t1, loss, second_differences: bool):
    """The pencil over the gated window of ``x`` (n, 2), m."""
    g = gated_growth_rate(t_s, x, tp, t_start_s=t0, t_end_s=t1, loss=loss)
    p = pencil_over_window(t_s, x, tp, g, second_differences=second_differences)
    assert p is not None, g.reason  # None: no gated window
    return p


def _steel_difference_pencil(fixture, factor: float):
    """(pencil rate, SE, sigma) of steel's kicked-minus-unkicked run at ``factor`` x the limit, the
    largest linear kick at the flip frequency, sections per period of the forced orbit (the
    revolution with runout, where each tooth meets the part at its own deflection; else the tooth)."""
    robot, case, st, lim = fixture
    cut = replace(case.cut, ap_m=factor * lim)
    flip_hz = cut.spindle_rpm / 60.0 * case.tool.teeth / 2.0
    v = 2 * math.pi * flip_hz * linear_kick_amplitude_m(chip_scale(case.tool, case.cut))
    prob = SimulationProblem(robot, replace(case, cut=cut), t_end_s=4.5)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", L.JointLimitWarning)
        kicked = simulate(prob, LinearizedNewmark(kick_m_s=v), verdict_companion=False)
        plain = simulate(prob, LinearizedNewmark(), verdict_companion=False)
    d = kicked.tcp_deviation_m[:, :2] - plain.tcp_deviation_m[:, :2]
    t0, t1 = kicked.steady_window_s
    t1 = min(t1, float(kicked.t_s[-1]))
    rev = cut.spindle_period_s
    tp = orbit_period_s(case.tool, cut)
    loss = regenerative_loss_per_period(kicked.t_s, kicked.tcp_deviation_m[:, :2], chip_scale(case.tool, cut), rev,
                                        t0, t1)
    p = _pencil_over_gate(kicked.t_s, d, tp, t0, t1, np.repeat(loss, round(rev / tp)), False)
    return p.rate_per_s, p.se_per_s, _orbit_sigma(st, case, cut, kicked)


def _aluminium_pencil(fixture, factor: float):
    """(pencil rate, SE, sigma) of the kicked aluminium run (the largest linear kick below the limit,
    100 nm above, at 24.7 Hz) on the second differences of its sections."""
    robot, case, st, lim = fixture
    cut = replace(case.cut, ap_m=factor * lim)
    amp = linear_kick_amplitude_m(chip_scale(case.tool, case.cut)) if factor < 1 else KICK_M
    run, tp, t0, t1, xy = _kicked(robot, case, cut, 2 * math.pi * CHATTER_HZ * amp)
    loss = regenerative_loss_per_period(run.t_s, xy, chip_scale(case.tool, cut), tp, t0, t1)
    p = _pencil_over_gate(run.t_s, xy, tp, t0, t1, loss, True)
    return p.rate_per_s, p.se_per_s, _orbit_sigma(st, case, cut, run)


@pytest.mark.slow
@pytest.mark.long
@pytest.mark.parametrize("name, factor", [("steel", 0.5), ("steel", 0.8), ("steel_no_runout", 0.5),
                                          ("steel_no_runout", 0.8), ("aluminium", 0.5), ("aluminium", 0.8),
                                          ("aluminium", 1.25), ("aluminium", 2.0)])
def test_pencil_rate_meets_the_sdm_about_its_forced_orbit(request, name, factor):
    # The matrix pencil (timedomain/rate.py, pencil_growth_rate) over the gated window, against the
    # SDM about the orbit by the criterion max(10 % |sigma|, 0.03 1/s) + 2 SE. Measured (bench
    # --orbit --pencil --kick-below-nm 0, with --orbit-difference for steel): steel (per revolution)
    # 0.5x -4.3347 +- 0.6651 against -3.4230, 0.8x -4.1568 +- 0.5651 against -3.6148 (within the SE);
    # steel-no-runout 0.5x -3.8398 +- 0.3078 against -3.4245, 0.8x -3.2267 +- 0.5179 against -3.6164;
    # aluminium -0.8593, -0.1668, +0.3782, +0.4437 against -0.8647, -0.1693, +0.3793, +0.4501 1/s.
    fixture = request.getfixturevalue(name)
    fn = _aluminium_pencil if name == "aluminium" else _steel_difference_pencil
    rate, se, sigma = fn(fixture, factor)
    assert math.isfinite(rate)
    assert abs(rate - sigma) <= max(0.1 * abs(sigma), TOL) + 2 * se
