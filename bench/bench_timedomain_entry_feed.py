"""The eroded part's growth rate against the feed per tooth (TX200 aluminium near its limit).

Tests the entry-shift hypothesis: in the eroded part a tooth enters where its tip meets the flat
block edge, so the entry angle moves with the tool's current normal position; that force term is
proportional to the static chip at entry, i.e. to the feed per tooth. The linear model of the SDM
and the delay-based method lack it. For each feed this prints the eroded rate (gated, as the
convergence bench), the run's mean normal deflection dy, the SDM exponent (m = 40 / 80,
Richardson) at the nominal ae and at ae - dy, the same with the entry-shift term
(:mod:`lobes.entry_shift`) at ae - dy, and the delay-based rate at ae - dy. The part length
is scaled with the feed so that the steady window keeps its length (about 1.9 s); every other
input is the one of ``bench_timedomain_convergence.py --case alu-straight`` (basic model,
linearized at the pass start, 18 700 rpm, 40 % immersion down-milling, ap = factor x 5.09 mm).

    python bench/bench_timedomain_entry_feed.py [--feed 0.0075,0.015,0.03,0.06] [--factor 0.8] [--helix]
        [--scaled-gate] [--ae-mm 3] [--dx-um 0.5] [--no-delay]
"""

from __future__ import annotations

import argparse
import math
import time
import warnings
from dataclasses import replace

import numpy as np
import robolobes.linearize as L
from robolobes import cases
from robolobes.cases.milling import engagement_rad, principal_period
from robolobes.lobes import LobeProblem, PhysicalStructure, SemiDiscretization, solve
from robolobes.lobes.entry_shift import entry_shift_exponent, entry_shift_impulses
from robolobes.lobes.exponent import floquet_exponent
from robolobes.timedomain import DelayNewmark, LinearizedNewmark, SimulationProblem, simulate
from robolobes.timedomain.rate import gated_growth_rate
from robolobes.timedomain.verdict import GrowthRule

ALU_LIMIT_M = 5.09e-3
WINDOW_S = 1.87  # the steady window of the 45 mm part at 0.03 mm/tooth


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    ap.add_argument("--feed", default="0.0075,0.015,0.03,0.06", help="feeds per tooth, mm, comma-separated")
    ap.add_argument("--factor", type=float, default=0.8)
    ap.add_argument("--helix", action="store_true", help="the helical tool (default: straight, one disc)")
    ap.add_argument("--deg", type=float, default=2.0, help="spindle degrees per step")
    ap.add_argument("--no-delay", action="store_true")
    ap.add_argument("--ae-mm", type=float, default=None,
                    help="radial depth, mm (default the case's 4 mm); the depth is then factor x the SDM limit at it")
    ap.add_argument("--dx-um", type=float, default=1.0, help="workpiece column spacing, um (default 1)")
    ap.add_argument("--scaled-gate", action="store_true",
                    help="scale the rate gate's resolution (2 nm) with fz / 0.03 mm: the eroded part has no kick, "
                         "its motion after the entry is proportional to the feed")
    a = ap.parse_args(argv)
    warnings.filterwarnings("ignore", category=L.JointLimitWarning)
    base = cases.load_case("tx200-aluminium")
    tool = base.tool if a.helix else replace(base.tool, helix_rad=0.0)
    robot = L.build_model(base.robot, "basic")
    structure = PhysicalStructure.from_linear(L.linearize(robot, base.path.start_q_rad), base.cut.feed_direction)
    sdm = SemiDiscretization(m=40, axial_slices=32)
    limit = ALU_LIMIT_M
    if a.ae_mm is not None:
        base = replace(base, cut=replace(base.cut, ae_m=a.ae_mm * 1e-3))
        p = LobeProblem(structure, tool, base.cut, base.law)
        limit = float(solve(p, replace(sdm, richardson=True), [base.cut.spindle_rpm]).depth_limit_m[0])
        print(f"ae {a.ae_mm:g} mm: SDM limit {limit * 1e3:.4f} mm", flush=True)
        if not math.isfinite(limit):
            print("no finite limit at this radial depth: nothing to scale the depth by", flush=True)
            return 1
    print(f"tool {'helical' if a.helix else 'straight'}, factor {a.factor:g}, {a.deg:g} deg per step, "
          f"columns {a.dx_um:g} um", flush=True)
    for fz_mm in (float(x) for x in a.feed.split(",")):
        fz = fz_mm * 1e-3
        cut = replace(base.cut, feed_per_tooth_m=fz, ap_m=a.factor * limit)
        v = fz * tool.teeth * cut.spindle_rpm / 60.0
        length = 0.010 + WINDOW_S * v
        case = replace(base, tool=tool, cut=cut, path=replace(base.path, part_length_m=length))
        c0 = time.process_time()
        run = simulate(SimulationProblem(robot, case), LinearizedNewmark(deg_per_step=a.deg, dx_m=a.dx_um * 1e-6))
        cpu = time.process_time() - c0
        tp = principal_period(tool, cut)[0]
        t0, t1 = run.steady_window_s
        rule = GrowthRule(resolution_m=2e-9 * fz / 3e-5) if a.scaled_gate else GrowthRule()
        g = gated_growth_rate(run.t_s, run.tcp_deviation_m[:, :2], tp, t_start_s=t0, t_end_s=min(t1, run.t_s[-1]),
                              rule=rule)
        sel = (run.t_s >= t0) & (run.t_s <= t1)
        dy = float(np.mean(run.tcp_deviation_m[sel, 1]))
        narrow = replace(cut, ae_m=cut.ae_m - dy)
        s_nom = floquet_exponent(LobeProblem(structure, tool, cut, base.law), sdm).value_per_s
        s_dy = floquet_exponent(LobeProblem(structure, tool, narrow, base.law), sdm).value_per_s
        s_en = entry_shift_exponent(LobeProblem(structure, tool, narrow, base.law), sdm).value_per_s
        line = (f"fz {fz_mm:.4f} mm: part {length * 1e3:.1f} mm, window {t0:.2f}-{t1:.2f} s, eroded "
                f"{g.rate_per_s:+.4f} +- {g.se_per_s:.4f} ({g.n_gated} periods), chip loss {run.summary.chip_loss_fraction if run.summary else None}, "
                f"dy {dy * 1e6:.2f} um, SDM nominal {s_nom:+.4f}, SDM at ae - dy {s_dy:+.4f}, "
                f"eroded - SDM(ae - dy) {g.rate_per_s - s_dy:+.4f}, SDM with the entry shift at ae - dy {s_en:+.4f}, "
                f"eroded - that {g.rate_per_s - s_en:+.4f}, CPU {cpu:.0f} s")
        # the normal deflection at the instants the teeth meet the block edge, against its mean
        st, ex = engagement_rad(tool, narrow)
        edge = st if cut.mode == "down" else ex
        ang, y = run.spindle_angle_rad, run.tcp_deviation_m[:, 1]
        at_edge = []
        for th in tool.tooth_angle_rad:
            k = np.arange(math.ceil((ang[sel][0] + th - edge) / (2 * math.pi)),
                          math.floor((ang[sel][-1] + th - edge) / (2 * math.pi)) + 1)
            at_edge.append(float(np.mean(np.interp(edge - th + 2 * math.pi * k, ang, y))) - dy)
        imp = entry_shift_impulses(LobeProblem(structure, tool, narrow, base.law), 360, 32, 2 * math.pi)
        k_entry = -sum(E[1, 1] for _, E in imp) / cut.spindle_period_s
        line += (f"; normal deflection RMS {np.std(y[sel]) * 1e6:.2f} um, at the edge instants minus dy "
                 f"{', '.join(f'{v * 1e6:+.3f}' for v in at_edge)} um; entry-shift stiffness, mean, normal "
                 f"{k_entry:.0f} N/m")
        if not a.no_delay:
            d = simulate(SimulationProblem(robot, replace(case, cut=narrow)), DelayNewmark(deg_per_step=a.deg))
            line += f"; delay at ae - dy {d.rate.rate_per_s:+.4f} +- {d.rate.se_per_s:.4f}"
        print(line, flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
