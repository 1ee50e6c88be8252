"""Why the eroded part's rate near the steel damping bracket is flatter than the SDM's exponent.

For the quick study's steel pass (basic model, linearized path, Tab. 7 start pose; ``LinearizedNewmark``,
the eroded part) at joint-damping scales around the study's bracket, prints per run:

* the verdict's fitted rate +- SE (2 nm resolution: block amplitudes below it are clamped) and its window;
* the same fit with the clamp removed (resolution 1e-15 m), on the same window;
* the block RMS of the non-synchronous motion (second differences of the Poincare sections), first /
  smallest / last block, nm, and how many of the 12 blocks sit at or below the 2 nm resolution;
* the chip-loss fraction of the verdict (teeth out of the cut);
* the SDM exponent with the feed terms (entry shift + surface tilt) at ae - dy (the committed quick
  study's dy, ``docs/study-results.json``): the like-with-like reference (a second method);
* the slopes d(rate)/d(scale) of both, least squares over the scales;
* the run's own mean normal deflection and the one when the teeth meet the part
  (:func:`robolobes.timedomain.forced_orbit.entry_deflection`), and the SDM with the feed terms at ae minus the latter;
* with ``--slice-edges``: the SDM with the feed terms linearized about the run's forced orbit, each
  axial slice with its own entry angle from the synchronous deflection at the instant that slice
  meets the part (:func:`robolobes.timedomain.forced_orbit.sync_deflection`, :func:`lobes.entry_shift.slice_edge_angles`), at the
  nominal ae, and its distance to the rate beyond the criterion;
* with ``--delay-time``: the SDM with the feed terms and the delayed instant
  (``entry_shift_exponent(..., delay_time=True)``, :mod:`lobes.chip_direction`) at ae - dy and at ae
  minus the entry deflection, and (full feed) its distance beyond the criterion to the kicked rates
  converged in the step and the columns (:data:`CONVERGED`, from ``bench_timedomain_steel_step.py``).

Variants: ``--dx`` the column spacing of the part (default 1 um; ``fz/45`` and ``fz/90`` make the
feed per tooth a whole number of columns), ``--t-end`` the simulated time (default 5.5 s),
``--deg`` the step, ``--kick-nm`` a velocity kick at full engagement (``LinearizedNewmark.kick_m_s``,
as a normal amplitude at the flip frequency), ``--feed-factor`` the feed per tooth (the SDM then
takes dy from each run; lengthen ``--t-end``: full engagement comes later).
Usage: python bench/bench_timedomain_steel_floor.py [--kick-nm 100] [--scales 11.6,11.84] ...
(about a minute for the five default scales: 1-3 s of CPU per 5.5 s run, about 5 s per SDM
exponent; the compiled loop's first call in a fresh cache adds about 40 s).
"""

from __future__ import annotations

import argparse
import json
import math
import time
from dataclasses import replace
from pathlib import Path
from typing import cast

import numpy as np

from robolobes.study import compute
from robolobes.study.linearizations import Linearizations
from robolobes.timedomain.forced_orbit import entry_deflection, mean_deflection, sync_deflection

RESULTS = Path(__file__).resolve().parents[1] / "docs" / "study-results.json"
SCALES = (11.6, 11.73, 11.84, 11.98, 12.1)
TOL = 0.03  # 1/s: the project's absolute match tolerance (with 10 % |sigma| and 2 SE)
# full feed, kicked, 0.1 um columns, 0.25 deg per step: rate, SE (1/s), bench_timedomain_steel_step.py
# (docs/guide/timedomain-convergence.md, "The kicked rate against the step, the columns and the kick amplitude")
CONVERGED = {11.73: (0.722, 0.010), 11.84: (0.320, 0.012), 11.98: (-0.191, 0.014)}


def eroded_run(lins, steel, scale: float, dx_m: float, t_end_s: float, kick_m: float = 0.0,
               kick_at_s: float | None = None, deg_per_step: float = 2.0):
    """The steel pass on the eroded part (``LinearizedNewmark``, column spacing ``dx_m``) without
    runout: the study's verdict comes from this companion run (:mod:`timedomain.runout`), cut at
    the steady start + 2 s; here it runs to ``t_end_s`` so that longer windows can be fitted.
    ``kick_m``: a velocity kick of the normal amplitude ``kick_m`` at the flip frequency (half the
    tooth passing frequency), at ``kick_at_s`` (None: full engagement)."""
    from robolobes.timedomain import LinearizedNewmark, SimulationProblem, simulate
    from robolobes.timedomain.result import SimulationResult
    robot = lins.robot(steel.robot, "basic", scale)
    case0 = replace(steel, tool=replace(steel.tool, runout_m=(0.0,) * steel.tool.teeth))
    pb = SimulationProblem(robot, case0, t_end_s=t_end_s)
    v = 2 * math.pi * steel.cut.spindle_rpm / 60 * steel.tool.teeth / 2 * kick_m
    method = LinearizedNewmark(dx_m=dx_m, deg_per_step=deg_per_step, kick_m_s=v, kick_at_s=kick_at_s)
    return cast(SimulationResult, simulate(pb, method, verdict_companion=False))


def floor_numbers(r, window_s: float) -> dict:
    """On ``[steady start, + window_s]``: the verdict's fit (2 nm clamp), the unclamped refit and
    the block amplitudes; the chip-loss fraction of the run's own verdict."""
    from robolobes.cases.milling import principal_period
    from robolobes.timedomain.verdict import GrowthRule, growth_rate
    s = r.summary.to_json()
    t0 = s["steady_window_s"][0]
    t1 = min(t0 + window_s, float(r.t_s[-1]))
    case = r.problem.case
    tp, _ = principal_period(case.tool, case.cut)
    dev = np.asarray(r.tcp_deviation_m)[:, :2]
    g = growth_rate(r.t_s, dev, tp, t_start_s=t0, t_end_s=t1)
    raw = growth_rate(r.t_s, dev, tp, t_start_s=t0, t_end_s=t1, rule=GrowthRule(resolution_m=1e-15))
    amp_nm = np.exp(raw.block_log_amp) * 1e9
    return {"rate": g.rate_per_s, "se": g.se_per_s, "window": (t0, t1), "raw_rate": raw.rate_per_s,
            "raw_se": raw.se_per_s, "amp_nm": amp_nm, "n_below": int(np.sum(amp_nm <= 2.0)),
            "loss": s.get("chip_loss_fraction")}


def sdm_slice_edges(settings, lins, steel, theta, scale: float, r) -> tuple[float, np.ndarray]:
    """The SDM exponent with entry shift and surface tilt at the nominal ae, each axial slice entering
    at its own angle on the run's forced orbit (1/s), and those angles (rad)."""
    from robolobes.lobes.entry_shift import entry_shift_exponent, slice_edge_angles
    from robolobes.lobes.sdm import SemiDiscretization
    method = SemiDiscretization(m=settings.sdm_m)
    edges = slice_edge_angles(steel.tool, steel.cut, method.axial_slices or 16, sync_deflection(r))
    _, st = lins.structure(steel, "basic", "start", theta, damping_scale=scale)
    e = entry_shift_exponent(compute._lobe_problem(st, steel), method, with_entry=True, surface_tilt=True,
                             slice_edge_rad=edges)
    return float(e.value_per_s), edges


def sdm_exponent(settings, lins, steel, theta, scale: float, dy_m: float, delay_time: bool = False) -> float:
    """The SDM exponent with entry shift and surface tilt at ae - dy, 1/s; ``delay_time``: with the
    delayed instant too (:func:`lobes.entry_shift.entry_shift_exponent`)."""
    from robolobes.lobes.entry_shift import entry_shift_exponent
    from robolobes.lobes.sdm import SemiDiscretization
    case = replace(steel, cut=replace(steel.cut, ae_m=steel.cut.ae_m - dy_m))
    _, st = lins.structure(steel, "basic", "start", theta, damping_scale=scale)
    problem, method = compute._lobe_problem(st, case), SemiDiscretization(m=settings.sdm_m)
    return float(entry_shift_exponent(problem, method, surface_tilt=True, delay_time=delay_time).value_per_s)


def beyond(rate: float, se: float, sigma: float) -> float:
    """``|rate - sigma| - (max(10 % |sigma|, TOL) + 2 SE)``, 1/s: met when not above 0."""
    return abs(rate - sigma) - max(0.1 * abs(sigma), TOL) - 2 * se


def print_delay_time(settings, lins, steel, theta, scale: float, dy_m: float, dy_in_m: float, r,
                     full_feed: bool) -> None:
    """The SDM with the feed terms and the delayed instant at ae - dy and ae - the entry deflection,
    against the run's 2 s rate and (full feed) the converged kicked rate."""
    e = sdm_exponent(settings, lins, steel, theta, scale, dy_m, delay_time=True)
    e_in = sdm_exponent(settings, lins, steel, theta, scale, dy_in_m, delay_time=True)
    f2 = floor_numbers(r, 2.0)
    line = (f"       delay time: SDM-feed+delay at ae - dy {e:+.3f}, at ae - entry {e_in:+.3f} 1/s; run (2 s) "
            f"{f2['rate']:+.3f} +- {f2['se']:.3f}: beyond {beyond(f2['rate'], f2['se'], e):+.3f} / "
            f"{beyond(f2['rate'], f2['se'], e_in):+.3f}")
    conv = CONVERGED.get(round(scale, 2)) if full_feed else None
    if conv is not None:
        line += (f"; converged {conv[0]:+.3f} +- {conv[1]:.3f}: minus SDM {conv[0] - e:+.3f} / {conv[0] - e_in:+.3f}, "
                 f"beyond {beyond(*conv, e):+.3f} / {beyond(*conv, e_in):+.3f}")
    print(line, flush=True)


def slope(x, y) -> float:
    ok = [i for i, v in enumerate(y) if v is not None]
    return float(np.polyfit(np.asarray(x)[ok], np.asarray(y, dtype=float)[ok], 1)[0]) if len(ok) > 1 else float("nan")


def main() -> None:
    from robolobes.study.settings import StudySettings
    ap = argparse.ArgumentParser()
    ap.add_argument("--dx", type=float, default=1e-6)
    ap.add_argument("--t-end", type=float, default=5.5)
    ap.add_argument("--scales", default=",".join(map(str, SCALES)))
    ap.add_argument("--deg", type=float, default=2.0, help="spindle rotation per step, deg")
    ap.add_argument("--kick-nm", type=float, default=0.0, help="velocity kick, as a normal amplitude at the flip")
    ap.add_argument("--kick-at", type=float, default=None, help="time of the kick, s (default: full engagement)")
    ap.add_argument("--feed-factor", type=float, default=1.0,
                    help="feed per tooth times this; the SDM then takes dy from each run itself")
    ap.add_argument("--no-sdm", action="store_true")
    ap.add_argument("--slice-edges", action="store_true",
                    help="also the SDM about the forced orbit: each axial slice's own entry angle")
    ap.add_argument("--delay-time", action="store_true",
                    help="also the SDM with the delayed instant (lobes.chip_direction) at ae - dy and ae - entry")
    a = ap.parse_args()
    scales = [float(s) for s in a.scales.split(",")]
    settings = StudySettings.make(True)
    dy = json.loads(RESULTS.read_text())["steel_damping"]["eroded_deflection_m"]
    cs, pas, _ = compute.load_inputs()
    steel, theta, lins = cs["steel"], compute.study_poses(pas)["start"], Linearizations()
    if a.feed_factor != 1.0:
        steel = replace(steel, cut=replace(steel.cut, feed_per_tooth_m=steel.cut.feed_per_tooth_m * a.feed_factor))
    fz = steel.cut.feed_per_tooth_m
    print(f"dx {a.dx * 1e6:.5f} um (fz / dx = {fz / a.dx:.4f}), {a.deg:g} deg per step, t_end {a.t_end} s, "
          f"kick {a.kick_nm:g} nm at {a.kick_at or 'full engagement'}, dy {dy * 1e6:.2f} um")
    print("scale  window (s)   rate+-SE (2 nm)   unclamped rate+-SE  blocks first/min/last nm  <=2nm  loss   "
          "SDM-feed  |diff|-tol  cpu s")
    rates: dict = {w: [] for w in (2.0, a.t_end)}
    sdms = []
    for sc in scales:
        t = time.process_time()
        r = eroded_run(lins, steel, sc, a.dx, a.t_end, a.kick_nm * 1e-9, a.kick_at, a.deg)
        cpu = time.process_time() - t
        dy_sc = dy if a.feed_factor == 1.0 else mean_deflection(r)
        e = float("nan") if a.no_sdm else sdm_exponent(settings, lins, steel, theta, sc, dy_sc)
        dy_in = entry_deflection(r)
        e_in = float("nan") if a.no_sdm else sdm_exponent(settings, lins, steel, theta, sc, dy_in)
        print(f"       dy {mean_deflection(r) * 1e6:.2f} um (mean of this run), {dy_in * 1e6:.2f} um at the "
              f"entry: SDM-feed at ae - that {e_in:+.3f} 1/s")
        sdms.append(e)
        if a.delay_time:
            print_delay_time(settings, lins, steel, theta, sc, dy_sc, dy_in, r, a.feed_factor == 1.0)
        if a.slice_edges:
            e_sl, edges = sdm_slice_edges(settings, lins, steel, theta, sc, r)
            f2 = floor_numbers(r, 2.0)
            y = sync_deflection(r)(np.linspace(0, 2 * math.pi / steel.tool.teeth, 721))
            rr, ae = steel.tool.radius_m, steel.cut.ae_m
            y_in = -rr * np.cos(edges) - rr + ae  # the deflection at each slice's entry (down-milling), m
            print(f"       per-slice entry {np.degrees(edges.min()):.3f}-{np.degrees(edges.max()):.3f} deg, "
                  f"deflection there {y_in.min() * 1e6:.2f}-{y_in.max() * 1e6:.2f} um "
                  f"(sync deflection {y.min() * 1e6:.1f}-{y.max() * 1e6:.1f} um): SDM-feed {e_sl:+.3f} 1/s, "
                  f"rate (2 s) - that {f2['rate'] - e_sl:+.3f}, |diff|-tol "
                  f"{abs(f2['rate'] - e_sl) - max(0.1 * abs(e_sl), TOL) - 2 * f2['se']:+.3f}", flush=True)
        for w in rates:  # the study's 2 s companion window, then the whole run
            f = floor_numbers(r, w)
            rates[w].append(f["rate"])
            tol = max(0.1 * abs(e), TOL) + 2 * f["se"]
            amp = f["amp_nm"]
            print(f"{sc:5.2f}  {f['window'][0]:.2f}-{f['window'][1]:.2f}  {f['rate']:+.3f} +- {f['se']:.3f}    "
                  f"{f['raw_rate']:+.3f} +- {f['raw_se']:.3f}    {amp[0]:7.2f} {amp.min():7.2f} {amp[-1]:7.2f}     "
                  f"{f['n_below']:2d}  {f['loss'] or 0:.3f}  {e:+.3f}   {abs(f['rate'] - e) - tol:+.3f}     {cpu:.0f}",
                  flush=True)
    for w, rr in rates.items():
        print(f"slope d(rate)/d(scale), window {w:g} s: eroded {slope(scales, rr):+.3f}, SDM feed terms "
              f"{slope(scales, sdms):+.3f} (1/s per unit scale); between neighbours: " + ", ".join(
                  f"{slope(scales[i:i + 2], rr[i:i + 2]):+.2f} / {slope(scales[i:i + 2], sdms[i:i + 2]):+.2f}"
                  for i in range(len(scales) - 1)))



if __name__ == "__main__":
    main()
