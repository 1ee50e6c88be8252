"""Which discretization parameter moves the kicked steel eroded rate (step, columns, chord, amplitude)?

The quick study's steel pass (basic model, Tab. 7 start pose, companion run without runout,
``LinearizedNewmark``, the eroded part, a velocity kick at full engagement) as in
``bench_timedomain_steel_floor.py``, whose run and fit it reuses: the verdict's fit on the first
``--window`` s of full engagement (2.41-4.41 s for 2 s). For every scale, kick amplitude, column
spacing and chord tolerance of the part it runs every step of ``--degs`` and prints the rate +- SE,
the block RMS first / last (nm), the chip-loss fraction and the CPU time; then, per sequence of
halved steps, the differences between successive steps and the observed order
``log2(d1 / d2)`` where three successive rates change monotonically (same sign, shrinking).
``--delay`` adds the delay-based method (``DelayNewmark``, same structure and cut at ae, its own
gated rate, initial displacements ``--delay-kicks-nm``, default 5 um) at the same steps: a control for the step dependence of the Newmark scheme
itself on this structure. ``--chord-nm`` sets the part's chord tolerance (the largest sagitta of the
chords of the tooth-tip paths, ``Workpiece(chord_tol_m=...)``, default 1 nm; not a method option,
so set here by wrapping the constructor the simulation uses).

``--no-backlash`` runs the linear motion springs (a control: the basic model has no backlash, so
nothing changes); ``--feed-factor`` scales the feed per tooth (lengthen ``--t-end``: 7.5 s at 0.5).

Usage: python bench/bench_timedomain_steel_step.py [--scales 11.84,11.98] [--degs 4,2,1,0.5,0.25]
[--dx 1e-6,1e-7] [--kicks-nm 100,1000] [--chord-nm 0.1,10] [--delay]
Runtime (2 cores, load 1-3, 7 Dec 2026): per 4.5 s run, 1-3 s of CPU at 1 um columns (4 to 0.25 deg
per step), 1-3.5 s at 0.5 um, 4-9 s at 0.1 um; the compiled loop's first call in a fresh cache adds
about 40 s. The default grid (2 scales x 5 steps x 2 kicks, 1 um columns) takes about 70 s.
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import math
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_timedomain_steel_floor import eroded_run, floor_numbers

from robolobes.study import compute
from robolobes.study.linearizations import Linearizations


@contextlib.contextmanager
def chord_tolerance(chord_m: float | None):
    """Build the simulation's workpiece with this chord tolerance, m (None: the default, unchanged)."""
    from robolobes.timedomain import equations
    if chord_m is None:
        yield
        return
    orig = equations.Workpiece
    equations.Workpiece = functools.partial(orig, chord_tol_m=chord_m)  # type: ignore[assignment]
    try:
        yield
    finally:
        equations.Workpiece = orig  # type: ignore[assignment]


@contextlib.contextmanager
def backlash(on: bool):
    """Run the linearized path with the robot's backlash dead zone (on: unchanged) or without it
    (the motion springs linear, engaged: ``k o dq``); prints each run's dead-zone margin
    ``|d0| - s`` per motion axis, rad (the static deflection's distance from the dead zone)."""
    from robolobes.timedomain import drivers
    orig = drivers.linear_system_data

    def wrapped(S):
        d = orig(S)
        margin = np.abs(np.asarray(d.d0)) - d.backlash_rad
        print(f"       backlash s {d.backlash_rad:.3g} rad, margins |d0| - s " + " ".join(f"{m:.2e}" for m in margin)
              + ("" if on else "  -> removed for this run"))
        return d if on else replace(d, backlash_rad=0.0)

    drivers.linear_system_data = wrapped  # type: ignore[assignment]
    try:
        yield
    finally:
        drivers.linear_system_data = orig  # type: ignore[assignment]


def observed_orders(degs: list[float], rates: list[float]) -> str:
    """Successive differences and, where three successive rates change monotonically with a
    shrinking difference at a constant step ratio, the observed order log(d1/d2)/log(ratio)."""
    d = [rates[i + 1] - rates[i] for i in range(len(rates) - 1)]
    out = ["diffs " + ", ".join(f"{x:+.3f}" for x in d)]
    for i in range(len(d) - 1):
        q = degs[i] / degs[i + 1]
        if math.isclose(q, degs[i + 1] / degs[i + 2]) and d[i] * d[i + 1] > 0 and abs(d[i + 1]) < abs(d[i]):
            out.append(f"p({degs[i]:g}-{degs[i + 2]:g}) {math.log(abs(d[i] / d[i + 1])) / math.log(q):.2f}")
        else:
            out.append(f"p({degs[i]:g}-{degs[i + 2]:g}) not monotone")
    return "; ".join(out)


def delay_problem(lins, steel, scale: float, t_end_s: float):
    """The delay-based problem on the same structure and cut (at ae, the tool without runout)."""
    from robolobes.timedomain import SimulationProblem
    robot = lins.robot(steel.robot, "basic", scale)
    case0 = replace(steel, tool=replace(steel.tool, runout_m=(0.0,) * steel.tool.teeth))
    return SimulationProblem(robot, case0, t_end_s=t_end_s)


def delay_rate(lins, steel, scale: float, deg: float, t_end_s: float, kick_m: float = 5e-6):
    """The delay-based method's gated rate +- SE (1/s) on the same structure and cut (at ae), kicked
    by an initial displacement ``kick_m``."""
    from robolobes.timedomain import DelayNewmark, simulate
    r = simulate(delay_problem(lins, steel, scale, t_end_s), DelayNewmark(deg_per_step=deg, kick_m=kick_m))
    return r.rate.rate_per_s, r.rate.se_per_s, r.rate.n_gated


def floats(s: str) -> list[float]:
    return [float(x) for x in s.split(",") if x]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--scales", default="11.84,11.98")
    ap.add_argument("--degs", default="4,2,1,0.5,0.25", help="spindle rotation per step, deg")
    ap.add_argument("--dx", default="1e-6", help="column spacings of the part, m")
    ap.add_argument("--kicks-nm", default="100,1000", help="velocity kicks, as normal amplitudes at the flip, nm")
    ap.add_argument("--chord-nm", default="", help="chord tolerances of the part, nm (empty: the default 1 nm)")
    ap.add_argument("--window", type=float, default=2.0, help="fit window after full engagement, s")
    ap.add_argument("--t-end", type=float, default=4.5)
    ap.add_argument("--delay", action="store_true", help="add the delay-based method at the same steps")
    ap.add_argument("--delay-kicks-nm", default="5000", help="initial displacements of the delay-based runs, nm")
    ap.add_argument("--feed-factor", type=float, default=1.0, help="feed per tooth times this (lengthen --t-end)")
    ap.add_argument("--no-backlash", action="store_true", help="linear motion springs (no dead zone) in the runs")
    a = ap.parse_args()
    degs, chords = floats(a.degs), floats(a.chord_nm) or [None]
    cs, _, _ = compute.load_inputs()
    steel, lins = cs["steel"], Linearizations()
    steel = replace(steel, cut=replace(steel.cut, feed_per_tooth_m=steel.cut.feed_per_tooth_m * a.feed_factor))
    print("scale  kick nm  dx um   chord nm  deg    rate+-SE (1/s)     blocks first/last nm  loss   cpu s")
    for sc in floats(a.scales):
        for kick in floats(a.kicks_nm):
            for dx in floats(a.dx):
                for ch in chords:
                    rates = []
                    for deg in degs:
                        t = time.process_time()
                        with chord_tolerance(None if ch is None else ch * 1e-9), backlash(not a.no_backlash):
                            r = eroded_run(lins, steel, sc, dx, a.t_end, kick * 1e-9, None, deg)
                        f = floor_numbers(r, a.window)
                        rates.append(f["rate"])
                        print(f"{sc:5.2f}  {kick:7g}  {dx * 1e6:5.3f}  {ch or 1:7g}  {deg:5.3g}  {f['rate']:+.3f} +- "
                              f"{f['se']:.3f}   {f['amp_nm'][0]:9.1f} {f['amp_nm'][-1]:9.1f}  {f['loss'] or 0:.3f}  "
                              f"{time.process_time() - t:5.1f}", flush=True)
                    print(f"       scale {sc:g}, kick {kick:g} nm, dx {dx * 1e6:g} um, chord {ch or 1:g} nm: "
                          + observed_orders(degs, rates), flush=True)
        if a.delay:
            for dk in floats(a.delay_kicks_nm):
                rates = []
                for deg in degs:
                    t = time.process_time()
                    rate, se, n = delay_rate(lins, steel, sc, deg, a.t_end, dk * 1e-9)
                    rates.append(rate)
                    print(f"{sc:5.2f}  delay-based (kick {dk:g} nm, ae)  {deg:5.3g}  {rate:+.3f} +- {se:.3f} "
                          f"({n} periods)  {time.process_time() - t:5.1f}", flush=True)
                print(f"       scale {sc:g}, delay-based, kick {dk:g} nm: " + observed_orders(degs, rates), flush=True)


if __name__ == "__main__":
    main()
