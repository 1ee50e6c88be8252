"""The delay-based regenerative simulator (timedomain.delay, DelayNewmark) against the SDM's Floquet
exponent ln|mu| / Tp.

Reference: the semi-discretization of robolobes.lobes at m and 2m steps per principal period,
extrapolated by Richardson (robolobes.lobes.exponent.floquet_exponent): a second, independent
method (it integrates the monodromy of the linear delay equation; the time domain integrates the
nonlinear one step by step with Newmark). The criterion is the issue's:
``|rate - sigma| <= max(10 % |sigma|, 0.03 1/s) + 2 SE``.

Benchmarks (Insperger & Stepan 2004): 922 Hz, zeta 0.011, modal mass 0.03993 kg, 2 teeth, D = 10 mm,
Kt = 600 MPa, Kn = 200 MPa, a/D = 0.05 down-milling at 10 000 rpm; 1-DOF flexible along the feed,
2-DOF symmetric. Each run starts on the forced periodic response, kicked: below the limit by 20 um
(1-DOF, rates of -140 to -220 1/s) or 2 um (2-DOF, -10 to -27 1/s: the verdict's chip-loss test must
see the linear regime at the end of the 0.2 s run), and the rate is fitted while the motion decays to
10 x 2 nm; above the limit by 1 nm, fitted until 5 % chip loss.
"""

import math
import warnings
from dataclasses import replace
from typing import Any

import numpy as np
import pytest
import robolobes.linearize as L
from robolobes import cases
from robolobes.cases.milling import Cut, CuttingLaw, Tool
from robolobes.core.errors import BadInput
from robolobes.lobes import (
    LobeProblem,
    ModalStructure,
    Mode,
    PhysicalStructure,
    SemiDiscretization,
    solve,
)
from robolobes.lobes.exponent import floquet_exponent
from robolobes.timedomain import (
    DelayNewmark,
    LinearizedNewmark,
    SimulationError,
    SimulationProblem,
    simulate,
)
from robolobes.timedomain.delay import StructureProblem
from robolobes.timedomain.rate import gated_growth_rate
from robolobes.timedomain.verdict import GrowthRule

FN, ZETA, MT = 922.0, 0.011, 0.03993
K = MT * (2 * math.pi * FN) ** 2
TOOL = Tool(diameter_m=0.01, teeth=2)
LAW = CuttingLaw(ktc_pa=6e8, krc_pa=2e8)
CUT = Cut(ae_m=0.0005, ap_m=1e-3, spindle_rpm=10000.0, mode="down", feed_per_tooth_m=1e-4)
FACTORS = (0.5, 0.8, 1.25, 2.0)


def _structure(dof):
    dirs = ((1.0, 0.0),) if dof == 1 else ((1.0, 0.0), (0.0, 1.0))
    return ModalStructure(tuple(Mode(FN, ZETA, K, d) for d in dirs))


_LIMITS = {}


def _limit(dof):
    if dof not in _LIMITS:
        p = LobeProblem(_structure(dof), TOOL, CUT, LAW)
        _LIMITS[dof] = float(solve(p, SemiDiscretization(m=80, richardson=True), [CUT.spindle_rpm]).depth_limit_m[0])
    return _LIMITS[dof]


def _sigma(dof, factor):
    cut = replace(CUT, ap_m=factor * _limit(dof))
    return floquet_exponent(LobeProblem(_structure(dof), TOOL, cut, LAW), SemiDiscretization(m=80))


def _rate(dof, factor, deg_per_step, entry_exit="exact"):
    cut = replace(CUT, ap_m=factor * _limit(dof))
    kick = (2e-5 if dof == 1 else 2e-6) if factor < 1 else 1e-9
    r = simulate(StructureProblem(_structure(dof), TOOL, cut, LAW, t_end_s=0.2),
                 DelayNewmark(deg_per_step=deg_per_step, kick_m=kick, entry_exit=entry_exit))
    return r


def _within(rate, se, sigma):
    return abs(rate - sigma) <= max(0.1 * abs(sigma), 0.03) + 2 * se


@pytest.mark.parametrize("dof", [1, 2])
@pytest.mark.parametrize("factor", FACTORS)
def test_benchmark_rate_equals_the_floquet_exponent(dof, factor):
    # 1 deg of spindle rotation per step (the 2 deg default misses by 14 % at 0.8x on the 1-DOF
    # benchmark, whose rates are hundreds of 1/s: see the order test). Observed (1-DOF): 0.5x
    # -220.8 +- 3.0 (SDM -220.1), 0.8x -133.1 +- 0.1 (-137.7), 1.25x +107.8 (+105.8), 2x +296.3 +- 0.8
    # (+296.6); 2-DOF: -26.3 (-26.9), -9.98 (-9.89), +11.10 (+11.05), +37.44 (+37.68).
    sdm = _sigma(dof, factor)
    assert sdm.error_per_s < 0.02 * abs(sdm.value_per_s)
    r = _rate(dof, factor, 1.0)
    assert r.rate.estimate is not None, r.rate.reason
    assert _within(r.rate.rate_per_s, r.rate.se_per_s, sdm.value_per_s), (r.rate.rate_per_s, r.rate.se_per_s,
                                                                          sdm.value_per_s)
    assert r.verdict.verdict.status == ("stable" if factor < 1 else "unstable"), r.verdict.verdict.reason


@pytest.mark.parametrize("factor", [0.8, 1.25])
def test_observed_order_in_the_step_is_the_schemes(factor):
    # Average-acceleration Newmark is second order; with the exact entry and exit of every element
    # inside a step the delay-based scheme keeps it. Errors against the SDM at 2, 1, 0.5 deg per
    # step; the order log2(e_h / e_h/2) is asserted (2 +- 0.5) where both errors exceed 10 SE.
    # Observed: 0.8x 18.6, 4.6, 1.06 1/s (orders 2.01, 2.12); 1.25x 8.0, 2.0, 0.44 (1.99, 2.18).
    sigma = _sigma(1, factor).value_per_s
    runs = [_rate(1, factor, d).rate for d in (2.0, 1.0, 0.5)]
    errs = [abs(g.rate_per_s - sigma) for g in runs]
    checked = 0
    for (e1, g1), (e2, g2) in zip(zip(errs, runs), zip(errs[1:], runs[1:])):
        if e1 > 10 * g1.se_per_s and e2 > 10 * g2.se_per_s:
            order = math.log2(e1 / e2)
            print(f"{factor}x: errors {e1:.4g} -> {e2:.4g} 1/s, observed order {order:.2f}")
            assert 1.5 <= order <= 2.5, (errs, order)
            checked += 1
    assert checked >= 1, errs


def test_sampled_screen_function_is_less_accurate():
    # The same model with the screen function sampled at the step ends (what a plain Newmark step
    # does with the entry and exit jumps): larger errors at every step, and no clean order (the
    # error depends on where the grid falls against the entry angle). Observed at 1.25x against the
    # SDM's +105.75: sampled 14.3, 7.2, 2.0 1/s (orders 0.98, 1.82); exact 8.0, 2.0, 0.44.
    sigma = _sigma(1, 1.25).value_per_s
    for d in (2.0, 1.0, 0.5):
        sampled = abs(_rate(1, 1.25, d, "sampled").rate.rate_per_s - sigma)
        exact = abs(_rate(1, 1.25, d).rate.rate_per_s - sigma)
        assert sampled > 1.5 * exact, (d, sampled, exact)


def test_gated_fit_recovers_a_known_rate_the_plain_fit_does_not():
    # A synthetic non-synchronous motion of known rate -40 1/s (a 250 Hz oscillation sampled once
    # per 5 ms period at 8 phases) that decays below the verdict's 2 nm resolution half-way: the
    # plain fit over the whole window is flattened by the clamp, the gated one is not.
    tp, sigma = 0.005, -40.0
    t = np.arange(0, 0.6, tp / 64)
    x = 1e-6 * np.exp(sigma * t) * np.sin(2 * math.pi * 250.3 * t)
    xy = np.stack([x, 0.5 * x], axis=-1)
    gated = gated_growth_rate(t, xy, tp, t_start_s=0.0, t_end_s=t[-1])
    assert gated.estimate is not None
    assert abs(gated.rate_per_s - sigma) <= 0.02 * abs(sigma) + 2 * gated.se_per_s
    from robolobes.timedomain.verdict import growth_rate
    plain = growth_rate(t, xy, tp, t_start_s=0.0, t_end_s=t[-1], rule=GrowthRule())
    assert abs(plain.rate_per_s - sigma) > 0.2 * abs(sigma)


def test_gated_fit_stops_at_chip_loss():
    # Chip loss reported above 5 % from period 40 on: those periods are left out, and with fewer
    # than 6 gated differences there is no rate at all.
    tp = 0.005
    t = np.arange(0, 0.5, tp / 64)
    x = 1e-7 * np.exp(30.0 * t) * np.sin(2 * math.pi * 210.0 * t)
    xy = np.stack([x, x], axis=-1)
    loss = np.where(np.arange(100) >= 40, 0.2, 0.0)
    g = gated_growth_rate(t, xy, tp, t_start_s=0.0, t_end_s=t[-1], loss=loss)
    assert g.window_s is not None
    assert g.window_s[1] <= 40 * tp + 1e-12
    assert abs(g.rate_per_s - 30.0) <= 0.02 * 30 + 2 * g.se_per_s
    none = gated_growth_rate(t, xy, tp, t_start_s=0.0, t_end_s=t[-1], loss=np.where(np.arange(100) >= 4, 0.2, 0.0))
    assert none.estimate is None and "gated" in none.reason


# ---- the robot: aluminium near its limit, linearized at the pass start (the lobes' pose)

warnings.filterwarnings("ignore", category=L.JointLimitWarning)
ALU = cases.load_case("tx200-aluminium")
ALU_LIMIT_M = 5.09e-3  # SDM limit at 18 700 rpm (basic model); the factors below are of this depth


def _alu(helix=True, factor=0.8):
    tool = ALU.tool if helix else replace(ALU.tool, helix_rad=0.0)
    cut = replace(ALU.cut, feed_per_tooth_m=3e-5, ap_m=factor * ALU_LIMIT_M)
    return replace(ALU, tool=tool, cut=cut, path=replace(ALU.path, part_length_m=0.045))


def _alu_sigma(case, robot):
    st = PhysicalStructure.from_linear(L.linearize(robot, case.path.start_q_rad), case.cut.feed_direction)
    return floquet_exponent(LobeProblem(st, case.tool, case.cut, case.law), SemiDiscretization(m=40, axial_slices=32))


def test_aluminium_helical_tool_at_0p8_rate_equals_the_floquet_exponent(tx200_robot):
    # The paper's helical tool (30 deg, pitch 170/190 deg) at 0.8 times the limit, default settings
    # (2 deg per step, 54 discs): observed -0.2757 +- 0.0041 1/s against the SDM's -0.2666 (m = 40/80,
    # 32 axial slices, Richardson error 4e-4).
    case, robot = _alu(), tx200_robot("basic")
    sdm = _alu_sigma(case, robot)
    assert sdm.error_per_s < 0.01
    r = simulate(SimulationProblem(robot, case), DelayNewmark())
    assert r.stats["n_discs"] == 54
    assert _within(r.rate.rate_per_s, r.rate.se_per_s, sdm.value_per_s), (r.rate.rate_per_s, sdm.value_per_s)
    assert r.verdict.verdict.status == "stable", r.verdict.verdict.reason


@pytest.mark.slow
@pytest.mark.long
def test_aluminium_helical_rate_does_not_depend_on_the_disc_count(tx200_robot):
    # The eroded part's rate moved by 0.13 1/s between 4, 16 and 54 discs; the delay model's moves by
    # less than 0.005 1/s (observed -0.2754, -0.2756, -0.2757 +- 0.0041, whole pass).
    case = _alu()
    robot = tx200_robot("basic")
    rates = [simulate(SimulationProblem(robot, case), DelayNewmark(n_discs=n)).rate.rate_per_s for n in (4, 16, 54)]
    assert max(rates) - min(rates) < 0.005, rates


@pytest.mark.slow
@pytest.mark.long
@pytest.mark.parametrize("helix", [True, False])
@pytest.mark.parametrize("factor", FACTORS)
def test_aluminium_grid_rate_equals_the_floquet_exponent(tx200_robot, helix, factor):
    case, robot = _alu(helix, factor), tx200_robot("basic")
    sdm = _alu_sigma(case, robot)
    r = simulate(SimulationProblem(robot, case), DelayNewmark())
    assert r.rate.estimate is not None, r.rate.reason
    assert _within(r.rate.rate_per_s, r.rate.se_per_s, sdm.value_per_s), (r.rate.rate_per_s, sdm.value_per_s)


# ---- without chip loss (chip_loss=False): the linear model the SDM linearizes


def _benchmark_run(factor, kick_m, chip_loss, t_end_s=0.2):
    cut = replace(CUT, ap_m=factor * _limit(1))
    return simulate(StructureProblem(_structure(1), TOOL, cut, LAW, t_end_s=t_end_s),
                    DelayNewmark(deg_per_step=1.0, kick_m=kick_m, chip_loss=chip_loss))


def test_no_chip_loss_changes_nothing_while_every_chip_is_positive():
    # 1-DOF benchmark at 0.5x the limit kicked by 10 nm (static chip up to 100 um): no element in
    # the arc ever has a chip <= 0, so the two laws give the same force. The linear continuation
    # K_c h db + K_e db is computed differently from the law (a difference of two law evaluations),
    # hence 1e-12 relative rather than bit for bit (observed: bit for bit).
    on, off = (_benchmark_run(0.5, 1e-8, loss, t_end_s=0.05) for loss in (True, False))
    assert np.nanmax(on.chip_loss_angle) == 0.0
    scale = np.max(np.abs(on.deviation_m))
    assert np.max(np.abs(on.deviation_m - off.deviation_m)) <= 1e-12 * scale


def test_no_chip_loss_differs_once_chips_are_lost():
    # 2x the limit kicked by 1 nm: the motion grows e^59 in 0.2 s (rate +296 1/s), the teeth leave
    # the cut, and with chip loss it saturates; without, it keeps growing (observed: the final
    # displacements differ by a factor of ~1e18).
    on, off = (_benchmark_run(2.0, 1e-9, loss) for loss in (True, False))
    assert np.max(on.chip_loss) > 0.05
    assert np.max(np.abs(off.deviation_m)) > 10 * np.max(np.abs(on.deviation_m))
    # straight 2-tooth tool on a 26 deg arc: at most one element in the arc, so the share by angle
    # is the chip-weighted share (0 or 1) wherever an element is in the arc, nan elsewhere
    inside = np.isfinite(on.chip_loss_angle)
    assert 0 < inside.sum() < inside.size
    assert np.array_equal(on.chip_loss_angle[inside], on.chip_loss[inside])
    assert set(np.unique(on.chip_loss[inside])) <= {0.0, 1.0}


def test_rate_without_chip_loss_does_not_depend_on_the_kick():
    # 1-DOF benchmark at 1.25x the limit (SDM +105.8 1/s). Without chip loss the model is linear:
    # the rate is the same at a 0.1 um and a 100 um kick (the latter: the teeth leave the cut within
    # a few passes, so with chip loss the gate leaves no rate at all), within 3 SE, and equals the
    # SDM's exponent by the module's criterion. Observed: +107.7706 +- 0.0002 at both kicks.
    sdm = _sigma(1, 1.25).value_per_s
    small, large = (_benchmark_run(1.25, k, False).rate for k in (1e-7, 1e-4))
    assert small.estimate is not None and large.estimate is not None
    assert abs(small.rate_per_s - large.rate_per_s) <= 3 * math.hypot(small.se_per_s, large.se_per_s)
    assert _within(large.rate_per_s, large.se_per_s, sdm), (large.rate_per_s, sdm)
    assert _benchmark_run(1.25, 1e-4, True).rate.estimate is None


# ---- input checks


@pytest.mark.parametrize("kw, what", [(dict(kick_m=0.0), "kick_m"), (dict(kick_m=1e-2), "kick_m"),
                                      (dict(deg_per_step=20.0), "deg_per_step"), (dict(seed=-1), "seed"),
                                      (dict(entry_exit="midpoint"), "entry_exit"), (dict(n_discs=0), "n_discs"),
                                      (dict(chip_loss=1), "chip_loss")])
def test_bad_method_is_refused(kw, what):
    with pytest.raises(SimulationError, match=what):
        DelayNewmark(**kw)


def test_bad_problems_are_refused_before_any_work():
    with pytest.raises(SimulationError, match="structure must be"):
        StructureProblem("not a structure", TOOL, CUT, LAW)  # pyright: ignore[reportArgumentType]  # deliberately invalid input
    with pytest.raises(SimulationError, match="feed per tooth"):
        StructureProblem(_structure(1), TOOL, replace(CUT, feed_per_tooth_m=0.0), LAW)
    with pytest.raises(SimulationError, match="t_end_s"):
        StructureProblem(_structure(1), TOOL, CUT, LAW, t_end_s=-1.0)
    p = StructureProblem(_structure(1), TOOL, CUT, LAW, t_end_s=0.01)
    with pytest.raises(SimulationError, match="SimulationProblem"):
        simulate(p, LinearizedNewmark())
    with pytest.raises(SimulationError, match="whole number of steps per revolution"):
        simulate(p, DelayNewmark(deg_per_step=0.7))
    assert issubclass(SimulationError, BadInput)


# ---- the robot: steel (30 deg helix, runout 6.9 um), basic model, at 3100 rpm

STEEL = cases.load_case("tx200-steel")
STEEL_LIMIT_M = 0.6427e-3  # SDM limit at 3100 rpm (basic model)


@pytest.mark.slow
@pytest.mark.long
@pytest.mark.parametrize("factor, runout", [(0.5, True), (0.8, True), (1.25, False), (2.0, False)])
def test_steel_rate_equals_the_floquet_exponent(tx200_robot, factor, runout):
    # Below the limit with the tool's runout (observed 0.5x -4.68 +- 1.16, SDM -3.44; 0.8x -4.50 +-
    # 0.51, SDM -3.64: the robot's modes around the 103 Hz tooth passing beat, hence the SE). Above
    # it the runout's period-2 forced response sits at the flip frequency (51.7 Hz) and is in the
    # nonlinear regime (chip loss >= 5 %) from the start, so no linear rate exists; the linear
    # problem is the same without runout, which is what is compared there (kick 1 nm).
    tool = STEEL.tool if runout else replace(STEEL.tool, runout_m=(0.0, 0.0))
    case = replace(STEEL, tool=tool, cut=replace(STEEL.cut, ap_m=factor * STEEL_LIMIT_M))
    robot = tx200_robot("basic")
    st = PhysicalStructure.from_linear(L.linearize(robot, case.path.start_q_rad), case.cut.feed_direction)
    sdm = floquet_exponent(LobeProblem(st, case.tool, case.cut, case.law), SemiDiscretization(m=40, axial_slices=32))
    kick: dict[str, Any] = {} if factor < 1 else {"kick_m": 1e-9}
    r = simulate(SimulationProblem(robot, case, t_end_s=4.5), DelayNewmark(**kick))
    assert r.rate.estimate is not None, r.rate.reason
    assert _within(r.rate.rate_per_s, r.rate.se_per_s, sdm.value_per_s), (r.rate.rate_per_s, sdm.value_per_s)
