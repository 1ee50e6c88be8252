"""Is the delay-based rate's kick dependence on the steel case the chip loss at the down-milling exit?

The delay-based method (``DelayNewmark``) on the quick study's steel structure and cut at ae (basic
model, the robot linearized at the pass start, the tool without runout: the control of
``bench_timedomain_steel_step.py --delay``), for every damping scale and initial displacement
(kick), with the chip loss (the default: no force where the chip is not positive) and without it
(``chip_loss=False``: the force linear in the chip inside the nominal arc, the exact linear model
the semi-discretization linearizes). Prints the gated rate +- SE (1/s) and the gated periods, the
mean chip-weighted and by-angle share of the arc whose chip is not positive over the rate's
window (grid times with an element in the arc) (by angle: elements in the arc with chip <= 0 over the elements in the arc, not weighted by
sin phi), and the CPU time; then, per scale, the SDM exponent of the same structure and cut
(``floquet_exponent``, Richardson of m and 2m, ``--sdm-m``; an independent method).

Usage: python bench/bench_timedomain_delay_chiploss.py [--scales 11.84,12.34] [--kicks-nm 10,100,1000,5000]
[--deg 2] [--t-end 4.5] [--sdm-m 80] [--feed-factor 1] [--no-loss yes]
Runtime (2 cores, load 1.7-2.9, 7 Dec 2026): 0.2-0.3 s of CPU per run at 2 deg per step (0.6 s at
0.5 deg), the first call in a fresh cache about 10 s (the compiled loop); the default grid,
SDM at m = 80/160 included, about 5 s of wall time.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_timedomain_steel_step import delay_problem, floats

from robolobes.lobes import LobeProblem, SemiDiscretization
from robolobes.lobes.exponent import floquet_exponent
from robolobes.study import compute
from robolobes.study.linearizations import Linearizations
from robolobes.timedomain import DelayNewmark, simulate
from robolobes.timedomain.delay import StructureProblem


def window_loss(r) -> tuple[float, float]:
    """Mean chip-weighted and by-angle chip-loss share over the rate's window, at the grid times with
    an element in the arc (nan without a window)."""
    if r.rate.window_s is None:
        return math.nan, math.nan
    t = np.asarray(r.t_s)
    sel = (t >= r.rate.window_s[0]) & (t <= r.rate.window_s[1]) & np.isfinite(r.chip_loss_angle)
    return float(np.mean(r.chip_loss[sel])), float(np.mean(r.chip_loss_angle[sel]))


def sdm(problem, m: int):
    """The SDM exponent (1/s) and its Richardson error of the delay problem's structure and cut."""
    sp = StructureProblem.from_simulation(problem)
    return floquet_exponent(LobeProblem(sp.structure, sp.tool, sp.cut, sp.law), SemiDiscretization(m=m))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--scales", default="11.84,12.34")
    ap.add_argument("--kicks-nm", default="10,100,1000,5000", help="initial displacements, nm")
    ap.add_argument("--deg", type=float, default=2.0, help="spindle rotation per step, deg")
    ap.add_argument("--t-end", type=float, default=4.5)
    ap.add_argument("--feed-factor", type=float, default=1.0, help="feed per tooth and part length times this")
    ap.add_argument("--no-loss", default="yes", help="also run without chip loss (yes / no)")
    ap.add_argument("--sdm-m", type=int, default=80, help="SDM steps per period, coarse level (0: no SDM)")
    a = ap.parse_args()
    cs, _, _ = compute.load_inputs()
    steel, lins = cs["steel"], Linearizations()
    ff = a.feed_factor  # the part lengthened with the feed, so that the pass lasts as long
    steel = replace(steel, cut=replace(steel.cut, feed_per_tooth_m=steel.cut.feed_per_tooth_m * ff),
                    path=replace(steel.path, part_length_m=steel.path.part_length_m * ff))
    print("scale  kick nm  chip loss  rate+-SE (1/s)      periods  mean loss chip-w / angle  cpu s")
    for sc in floats(a.scales):
        problem = delay_problem(lins, steel, sc, a.t_end)
        for loss in (True, False) if a.no_loss == "yes" else (True,):
            for kick in floats(a.kicks_nm):
                t = time.process_time()
                r = simulate(problem, DelayNewmark(deg_per_step=a.deg, kick_m=kick * 1e-9, chip_loss=loss))
                lw, la = window_loss(r)
                print(f"{sc:5.2f}  {kick:7g}  {'yes' if loss else 'no ':9s}  {r.rate.rate_per_s:+.3f} +- "
                      f"{r.rate.se_per_s:.3f}   {r.rate.n_gated:5d}    {lw:.2e} / {la:.2e}    "
                      f"{time.process_time() - t:5.1f}", flush=True)
        if a.sdm_m:
            t = time.process_time()
            e = sdm(problem, a.sdm_m)
            print(f"{sc:5.2f}  SDM m = {a.sdm_m}/{2 * a.sdm_m}: {e.value_per_s:+.4f} 1/s (Richardson error "
                  f"{e.error_per_s:.4f})  {time.process_time() - t:5.1f}", flush=True)


if __name__ == "__main__":
    main()
