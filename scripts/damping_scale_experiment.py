"""Why do the lobes and the time domain give different steel damping scales?

Experiment, not a test: prints, for joint-damping scales around the two methods' answers,

* the SDM operating point at the Tab. 7 pose (basic model, 3100 rpm, ap 1.6 mm): verdict, critical
  depth, and the Floquet exponent ``ln|mu| / T`` of the operating point (1/s, > 0 grows);
* the linearized time domain at the same frozen pose: verdict and the fitted growth rate of the
  non-synchronous motion (+- 2 SE, 1/s), for the default run and for one knob changed at a time
  (time step, axial discs, runout companion run, duration).

Usage: python scripts/damping_scale_experiment.py [--scales 11,11.5,...] [--knobs default,dps1,...]
Output: one line per (scale, knob); nothing is written.
"""

from __future__ import annotations

import argparse
import math
import time
import warnings
from dataclasses import replace


from robolobes import cases
from robolobes.linearize.kinematics import JointLimitWarning
from robolobes.linearize.linear import linearize
from robolobes.linearize.model import build_model
from robolobes.linearize.path import Pass
from robolobes.lobes.problem import LobeProblem
from robolobes.lobes.sdm import SemiDiscretization
from robolobes.lobes.solver import stability
from robolobes.lobes.structure import PhysicalStructure
from robolobes.timedomain.summary import principal_period


def lobes_line(steel, theta, scale, m):
    robot = build_model(steel.robot, "basic", damping_scale=scale)
    lin = linearize(robot, theta)
    st = PhysicalStructure.from_linear(lin, steel.cut.feed_direction)
    op = stability(LobeProblem(st, steel.tool, steel.cut, steel.law), SemiDiscretization(m=m))
    T = principal_period(steel.tool, steel.cut)[0]  # the lobes' period: the tooth period here
    rate = math.log(op.spectral_radius) / T
    return (f"lobes m={m:3d}: {op.verdict:9s} limit {op.depth_limit_m * 1e3:.4f} +- "
            f"{op.depth_limit_error_m * 1e3:.4f} mm, Floquet ln|mu|/T {rate:+.4f} 1/s")


def td_line(steel, scale, knob, t_end):
    from robolobes.timedomain import LinearizedNewmark, SimulationProblem, simulate
    from robolobes.timedomain.workpiece import default_disc_count
    case, method, companion = steel, LinearizedNewmark(), True
    if knob == "dps1":
        method = LinearizedNewmark(deg_per_step=1.0)
    elif knob == "discs2":
        method = LinearizedNewmark(n_discs=2 * default_disc_count(case.tool, case.cut.ap_m))
    elif knob == "norunout":
        case = replace(case, tool=replace(case.tool, runout_m=(0.0,) * case.tool.teeth))
    elif knob == "nocompanion":
        companion = False
    elif knob == "long":
        t_end = 2 * t_end
    robot = build_model(case.robot, "basic", damping_scale=scale)
    t0 = time.perf_counter()
    r = simulate(SimulationProblem(robot, case, t_end_s=t_end), method, verdict_companion=companion)
    s = r.summary.to_json()
    tr, se = s.get("growth_rate_per_s"), s.get("growth_rate_se_per_s")
    trend = f"{tr:+.3f} +- {2 * se:.3f}" if tr is not None and se is not None else "n/a"
    return (f"td {knob:11s}: verdict {s.get('verdict')!s:12s} growth rate {trend} 1/s (+- 2 SE), "
            f"basis: {s.get('verdict_basis', '')[:40]} ({time.perf_counter() - t0:.0f} s)")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--scales", default="11.25,11.875,12.1875,12.34375")
    ap.add_argument("--knobs", default="default")
    ap.add_argument("--m", default="40")
    ap.add_argument("--t-end", type=float, default=5.5)
    ap.add_argument("--no-lobes", action="store_true")
    a = ap.parse_args()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", JointLimitWarning)
        al, steel = cases.load_case("tx200-aluminium"), cases.load_case("tx200-steel")
        theta = Pass.from_case(al).theta_at_s(0.0)
    for sc in (float(x) for x in a.scales.split(",")):
        if not a.no_lobes:
            for m in (int(x) for x in a.m.split(",")):
                print(f"x{sc:<8g} {lobes_line(steel, theta, sc, m)}", flush=True)
        for knob in (k for k in a.knobs.split(",") if k):
            print(f"x{sc:<8g} {td_line(steel, sc, knob, a.t_end)}", flush=True)


if __name__ == "__main__":
    main()
