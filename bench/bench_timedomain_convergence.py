"""Convergence of the time domain's growth rates to the SDM's Floquet exponent ln|mu| / Tp.

For each case and depth factor (0.5, 0.8, 1.25, 2 times the SDM limit at the case's speed) prints:

* the SDM exponent (Richardson from m and 2 m steps per period, :func:`robolobes.lobes.exponent.floquet_exponent`)
  at the nominal radial depth, and, for the eroded part, at ``ae`` minus that run's mean normal
  deflection (like with like: the deflected tool cuts a narrower immersion);
* the delay-based rate (:class:`~robolobes.timedomain.DelayNewmark`) and, for the robot cases, the
  eroded-part rate (:class:`~robolobes.timedomain.LinearizedNewmark`) at three step sizes (2, 1,
  0.5 deg per step, default discs) and three disc counts (half, default, twice; 2 deg per step),
  each with its standard error, and the observed order ``log2(e_2 / e_1)`` of successive step
  halvings where the error exceeds 10 standard errors;
* the CPU time per simulated second of both methods at their default settings.

Cases: ``is-1dof`` and ``is-2dof`` (Insperger & Stepan: 922 Hz, zeta 0.011, 2 teeth, Kt 600 MPa,
Kn 200 MPa, a/D = 0.05 down-milling at 10 000 rpm), ``alu-helix`` (the aluminium case, 30 deg
helix, 170/190 deg pitch, basic model, linearized path, feed 0.03 mm and a 45 mm part so that the
steady window is long), ``alu-straight`` (the same tool without helix), ``steel`` (the steel case,
30 deg helix, runout), ``steel-no-runout`` (its tool without runout: the same linear problem; with
runout the forced response has a period-2 part at the flip frequency, 51.7 Hz, that above the limit
is in the nonlinear regime from the start).

With ``--orbit`` (robot cases only) it prints instead, per factor, the kicked eroded part at 2 deg per
step and the default discs (``LinearizedNewmark(kick_m_s=...)``: the speed of a ``--kick-nm``
oscillation at the chatter frequency, :data:`CHATTER_HZ`, at full engagement, above the limit;
``--kick-below-nm`` below it, where the robot's faster modes take most of a small kick away
before the regenerative one is the slowest), its rate fitted over
the gated periods (motion >= 10 x 2 nm, chip loss < 5 %, :func:`_period_loss`), the mean deflection
and the one when the teeth meet the part (:mod:`robolobes.timedomain.forced_orbit`), the plain SDM at
ae - mean (``floquet_exponent``), the SDM about the forced orbit (``entry_shift_exponent`` with the
surface tilt and the delayed instant at ae - entry, m = 40 / 80) and the criterion
``|rate - sigma| <= max(10 % |sigma|, 0.03) + 2 SE`` against the latter, with its margin (allowance
minus ``|rate - sigma|``: met when not below 0). ``--orbit-skip-s`` starts the fit later (a
diagnostic: the robot's faster modes first). ``--kick-below-nm 0`` kicks below the limit with the
largest kick the chip-loss gate calls linear (:mod:`robolobes.timedomain.rate`). ``--orbit-difference`` (below the
limit) fits instead the kicked run minus the same run unkicked, so that the forced part, runout's
included, cancels without second differences (which see only ``(1 - 0.936)^2`` of a flip decaying
over a revolution), sectioned once per period of the forced orbit (the revolution with runout). ``--pencil`` adds the matrix-pencil (ESPRIT) rate of the
leading mode over the same gated window (:func:`robolobes.timedomain.rate.pencil_growth_rate`): on the
difference's sections, or on the second differences of the single run's sections.

    python bench/bench_timedomain_convergence.py [--case is-1dof,alu-helix] [--factor 0.8] [--no-eroded]
    python bench/bench_timedomain_convergence.py --orbit --case alu-helix,steel,steel-no-runout [--kick-nm 100] [--kick-below-nm 100] [--orbit-skip-s 0] [--orbit-difference] [--pencil]
"""

from __future__ import annotations

import argparse
import math
import sys
import time
import warnings
from dataclasses import replace
from typing import Any, Callable

import numpy as np
import robolobes.linearize as L
from robolobes import cases
from robolobes.cases.milling import Cut, CuttingLaw, Tool, principal_period
from robolobes.lobes import (
    LobeProblem,
    ModalStructure,
    Mode,
    PhysicalStructure,
    SemiDiscretization,
    solve,
)
from robolobes.lobes.entry_shift import entry_shift_exponent
from robolobes.lobes.exponent import floquet_exponent
from robolobes.timedomain import (
    DelayNewmark,
    LinearizedNewmark,
    SimulationProblem,
    simulate,
)
from robolobes.timedomain.delay import StructureProblem
from robolobes.timedomain.forced_orbit import entry_deflection, mean_deflection, orbit_period_s
from robolobes.timedomain.rate import (
    PencilRate,
    gated_growth_rate,
    linear_kick_amplitude_m,
    pencil_over_window,
    regenerative_loss_per_period,
)
from robolobes.timedomain.summary import has_runout
from robolobes.timedomain.verdict import LOSS_LIMIT, chip_scale

FACTORS = (0.5, 0.8, 1.25, 2.0)
STEPS_DEG = (2.0, 1.0, 0.5)
TOL = 0.03  # 1/s: the criterion's absolute floor (docs/guide/timedomain-convergence.md, "The criterion")
#: Chatter frequency of the kick, Hz: aluminium 24.7 Hz (docs/guide/timedomain-convergence.md, the
#: feed-per-tooth section); steel the flip, half the tooth passing frequency (None: computed).
CHATTER_HZ = {"alu-helix": 24.7, "alu-straight": 24.7, "steel": None, "steel-no-runout": None}


def _benchmark(two_dof: bool) -> dict[str, Any]:
    fn, zeta, mass = 922.0, 0.011, 0.03993
    k = mass * (2 * math.pi * fn) ** 2
    dirs = ((1.0, 0.0), (0.0, 1.0)) if two_dof else ((1.0, 0.0),)
    structure = ModalStructure(tuple(Mode(fn, zeta, k, d) for d in dirs))
    tool = Tool(diameter_m=0.01, teeth=2)
    cut = Cut(ae_m=0.0005, ap_m=1e-3, spindle_rpm=10000.0, mode="down", feed_per_tooth_m=1e-4)
    return dict(structure=structure, tool=tool, cut=cut, law=CuttingLaw(ktc_pa=6e8, krc_pa=2e8), robot=None,
                t_end_s=0.2, slices=None, m=80)


def _robot_case(name: str) -> dict[str, Any]:
    warnings.filterwarnings("ignore", category=L.JointLimitWarning)
    if name.startswith("steel"):
        case = cases.load_case("tx200-steel")
        if name == "steel-no-runout":
            case = replace(case, tool=replace(case.tool, runout_m=(0.0, 0.0)))
        t_end = 4.5
    else:
        case = cases.load_case("tx200-aluminium")
        tool = case.tool if name == "alu-helix" else replace(case.tool, helix_rad=0.0)
        case = replace(case, tool=tool, cut=replace(case.cut, feed_per_tooth_m=3e-5),
                       path=replace(case.path, part_length_m=0.045))
        t_end = None
    robot = L.build_model(case.robot, "basic")
    structure = PhysicalStructure.from_linear(L.linearize(robot, case.path.start_q_rad), case.cut.feed_direction)
    return dict(structure=structure, tool=case.tool, cut=case.cut, law=case.law, robot=robot, case=case,
                t_end_s=t_end, slices=32, m=40)


CASES = {"is-1dof": lambda: _benchmark(False), "is-2dof": lambda: _benchmark(True),
         "alu-helix": lambda: _robot_case("alu-helix"), "alu-straight": lambda: _robot_case("alu-straight"),
         "steel": lambda: _robot_case("steel"), "steel-no-runout": lambda: _robot_case("steel-no-runout")}


def _sdm(c, cut):
    p = LobeProblem(c["structure"], c["tool"], cut, c["law"])
    return floquet_exponent(p, SemiDiscretization(m=c["m"], axial_slices=c["slices"]))


def _limit(c) -> float:
    p = LobeProblem(c["structure"], c["tool"], c["cut"], c["law"])
    meth = SemiDiscretization(m=c["m"], axial_slices=c["slices"], richardson=True)
    return float(solve(p, meth, [c["cut"].spindle_rpm]).depth_limit_m[0])


def _kick(c, factor, sigma) -> dict[str, Any]:
    """Initial kick: 20 um (benchmarks) or the default 5 um below the limit; above it 1 nm where the
    motion would grow by more than e^9 over the run (else the default), so that the gated window
    (10 x 2 nm to 5 % chip loss) is crossed during the run."""
    if factor < 1:
        return {"kick_m": 2e-5} if c["robot"] is None else {}
    t_end = c["t_end_s"] if c["t_end_s"] is not None else 2.5
    return {"kick_m": 1e-9} if sigma * t_end > 9 else {}


def _delay(c, cut, factor, deg, n_discs=None, sigma=0.0):
    kick = _kick(c, factor, sigma)
    meth = DelayNewmark(deg_per_step=deg, n_discs=n_discs, **kick)
    if c["robot"] is None:
        prob = StructureProblem(c["structure"], c["tool"], cut, c["law"], t_end_s=c["t_end_s"])
    else:
        prob = SimulationProblem(c["robot"], replace(c["case"], cut=cut), t_end_s=c["t_end_s"])
    c0 = time.process_time()
    r = simulate(prob, meth)
    cpu = time.process_time() - c0
    return r.rate.rate_per_s, r.rate.se_per_s, cpu / float(r.t_s[-1]), r.stats["n_discs"]


def _eroded(c, cut, deg, n_discs=None):
    case = replace(c["case"], cut=cut)
    prob = SimulationProblem(c["robot"], case, t_end_s=c["t_end_s"])
    c0 = time.process_time()
    run = simulate(prob, LinearizedNewmark(deg_per_step=deg, n_discs=n_discs))
    cpu = time.process_time() - c0
    tp = orbit_period_s(case.tool, cut)  # with runout the forced response repeats once per revolution
    t0, t1 = run.steady_window_s
    g = gated_growth_rate(run.t_s, run.tcp_deviation_m[:, :2], tp, t_start_s=t0, t_end_s=min(t1, run.t_s[-1]))
    sel = (run.t_s >= t0) & (run.t_s <= t1)
    dy = float(np.mean(run.tcp_deviation_m[sel, 1]))
    return g.rate_per_s, g.se_per_s, cpu / float(run.t_s[-1]), run.stats["n_discs"], dy


def _orders(rates, ref):
    """Observed order of successive halvings where both errors exceed 10 SE, else '-'."""
    out = []
    for (r1, s1), (r2, s2) in zip(rates[:-1], rates[1:]):
        e1, e2 = abs(r1 - ref), abs(r2 - ref)
        out.append(f"{math.log2(e1 / e2):.2f}" if (e1 > 10 * s1 and e2 > 10 * s2 and e2 > 0) else "-")
    return " ".join(out)


def _fmt(r, s):
    return f"{r:+9.4f} +- {s:.4f}" if math.isfinite(r) else "      n/a       "


def run_case(name: str, factors, eroded: bool) -> None:
    c = CASES[name]()
    lim = _limit(c)
    tp = principal_period(c["tool"], c["cut"])[0]
    print(f"\n## {name}: {c['cut'].spindle_rpm:g} rpm, SDM limit {lim * 1e3:.4f} mm, "
          f"principal period {tp * 1e3:.4f} ms",
          flush=True)
    for f in factors:
        cut = replace(c["cut"], ap_m=f * lim)
        sdm = _sdm(c, cut)
        print(f"{name} {f:g}x: SDM sigma {sdm.value_per_s:+.4f} 1/s (m={sdm.m}: {sdm.coarse_per_s:+.4f}, "
              f"2m: {sdm.fine_per_s:+.4f}, error {sdm.error_per_s:.4f})", flush=True)
        methods: list[tuple[str, Callable[..., Any]]] = [("delay", lambda d, n, f=f, cut=cut, sg=sdm.value_per_s: _delay(c, cut, f, d, n, sg))]
        if eroded and c["robot"] is not None:
            methods.append(("eroded", lambda d, n, cut=cut: _eroded(c, cut, d, n)))
        for label, fn in methods:
            by_step = [fn(d, None) for d in STEPS_DEG]
            ref = sdm.value_per_s
            extra = ""
            if label == "eroded":
                dy = by_step[0][4]
                sgn = 1.0 if cut.mode == "down" else -1.0
                narrow = replace(cut, ae_m=cut.ae_m - sgn * dy)
                ref = _sdm(c, narrow).value_per_s
                extra = f"; SDM at ae - {sgn * dy * 1e6:.1f} um: {ref:+.4f}"
            steps = ", ".join(f"{d:g} deg {_fmt(r[0], r[1])}" for d, r in zip(STEPS_DEG, by_step))
            print(f"  {label:6s} steps: {steps}; order {_orders([r[:2] for r in by_step], ref)}{extra}", flush=True)
            nd = by_step[0][3]
            if c["tool"].helix_rad > 0:
                counts = sorted({max(1, nd // 2), nd, 2 * nd})
                by_disc = [by_step[0] if n == nd else fn(2.0, n) for n in counts]
                discs = ", ".join(f"{n} discs {_fmt(r[0], r[1])}" for n, r in zip(counts, by_disc))
                print(f"  {label:6s} discs (2 deg): {discs}", flush=True)
            print(f"  {label:6s} CPU per simulated second at 2 deg, {nd} discs: {by_step[0][2]:.3f} s", flush=True)


def _chatter_hz(name: str, c) -> float:
    """Chatter frequency of the kick, Hz (:data:`CHATTER_HZ`; None: the flip, half the tooth frequency)."""
    f = CHATTER_HZ[name]
    return c["cut"].spindle_rpm / 60.0 * c["tool"].teeth / 2.0 if f is None else f


def _period_loss(run, tp: float, t0: float, t1: float) -> np.ndarray:
    """Chip loss per principal period of ``[t0, t1]``, shape (K,)
    (:func:`robolobes.timedomain.rate.regenerative_loss_per_period` of the cut-plane deviation)."""
    chip = chip_scale(run.problem.case.tool, run.problem.case.cut)
    return regenerative_loss_per_period(run.t_s, np.asarray(run.tcp_deviation_m)[:, :2], chip, tp, t0, t1)


def _margin(rate: float, se: float, sigma: float) -> tuple[float, float]:
    """(allowance, margin) of the criterion ``|rate - sigma| <= max(10 % |sigma|, TOL) + 2 se``, 1/s."""
    allow = max(0.1 * abs(sigma), TOL) + 2 * se
    return allow, allow - abs(rate - sigma)


def _criterion_line(rate: float, se: float, sigma: float, cpu: str) -> str:
    """One printed line: the criterion against ``sigma`` for ``rate`` +- ``se`` (nan: no rate), 1/s."""
    if not math.isfinite(rate):
        return f"  criterion not met: no rate; {cpu}"
    allow, margin = _margin(rate, se, sigma)
    return (f"  criterion {'met' if margin >= 0 else 'NOT met'}: |rate - sigma| {abs(rate - sigma):.4f}, allowance "
            f"{allow:.4f}, margin {margin:+.4f} 1/s; {cpu}")


def _pencil_line(p: PencilRate | None, reason: str, orbit: float) -> str:
    """One printed line: the pencil's rate, order, leading multiplier and the criterion against ``orbit``."""
    if p is None:
        return f"  pencil: no rate: no gated window ({reason})"
    if not math.isfinite(p.rate_per_s):
        return f"  pencil: no rate: {p.reason} (order {p.order}, remainder {p.residual_m:.2e} m)"
    z = p.multipliers[p.leading]
    _, margin = _margin(p.rate_per_s, p.se_per_s, orbit)
    return (f"  pencil {_fmt(p.rate_per_s, p.se_per_s)} (order {p.order}, remainder {p.residual_m:.2e} m; leading "
            f"|z| {abs(z):.4f} at {math.degrees(float(np.angle(z))):+.1f} deg, {p.amplitudes_m[p.leading]:.2e} m; "
            f"|z| all {' '.join(f'{abs(v):.3f}' for v in p.multipliers)}); criterion "
            f"{'met' if margin >= 0 else 'NOT met'}: margin {margin:+.4f} 1/s")


def _orbit_run(name: str, c, cut, kick_nm: float, skip_s: float = 0.0,
               pencil: bool = False) -> dict[str, Any]:
    """The kicked eroded part at 2 deg per step, default discs: rate, SE, window, deflections, the
    first contact (s) and the chip loss of the second full-engagement period (the first whose
    delayed samples all lie in the window); the fit starts ``skip_s``
    (whole periods) after full engagement."""
    case = replace(c["case"], cut=cut)
    v = 2 * math.pi * _chatter_hz(name, c) * kick_nm * 1e-9
    run = simulate(SimulationProblem(c["robot"], case, t_end_s=c["t_end_s"]), LinearizedNewmark(kick_m_s=v),
                   verdict_companion=False)
    tp = orbit_period_s(case.tool, cut)  # with runout the forced response repeats once per revolution
    t0, t1 = run.steady_window_s
    t1 = min(t1, float(run.t_s[-1]))
    loss = _period_loss(run, tp, t0, t1)
    k = int(round(skip_s / tp))
    g = gated_growth_rate(run.t_s, run.tcp_deviation_m[:, :2], tp, t_start_s=t0 + k * tp, t_end_s=t1, loss=loss[k:])
    touch = np.flatnonzero(np.linalg.norm(np.asarray(run.force_tool_n)[:, :2], axis=1) > 0)
    pen = pencil_over_window(run.t_s, np.asarray(run.tcp_deviation_m)[:, :2], tp, g, second_differences=True) if pencil else None
    return dict(rate=g.rate_per_s, se=g.se_per_s, window=g.window_s, reason=g.reason, v=v, pencil=pen,
                contact=float(run.t_s[touch[0]]) if touch.size else math.nan, t0=t0,
                loss1=float(loss[1]) if loss.size > 1 else math.nan,
                dy_in=entry_deflection(run), dy_mean=mean_deflection(run),
                loss_max=float(loss.max()) if loss.size else math.nan,
                lossy=int(np.sum(loss >= LOSS_LIMIT)), n_per=loss.size)


def _difference_run(name: str, c, cut, kick_nm: float, pencil: bool = False) -> dict[str, Any]:
    """``--orbit-difference``: the kicked eroded part minus the same run unkicked (identical until the
    kick, so the forced response, runout's included, cancels without differencing sections), its
    rate fitted over sections once per period of the forced orbit: the tooth period without runout;
    the revolution with runout, where the part is met at a different deflection by each tooth, so
    that the motion about the orbit is periodic in the revolution (the Floquet model of the pencil
    needs the period of the linear system). The chip loss per revolution of the kicked run applies
    to each of its tooth periods."""
    case = replace(c["case"], cut=cut)
    prob = SimulationProblem(c["robot"], case, t_end_s=c["t_end_s"])
    v = 2 * math.pi * _chatter_hz(name, c) * kick_nm * 1e-9
    kicked = simulate(prob, LinearizedNewmark(kick_m_s=v), verdict_companion=False)
    plain = simulate(prob, LinearizedNewmark(), verdict_companion=False)
    d = np.asarray(kicked.tcp_deviation_m)[:, :2] - np.asarray(plain.tcp_deviation_m)[:, :2]
    t0, t1 = kicked.steady_window_s
    t1 = min(t1, float(kicked.t_s[-1]))
    tp = orbit_period_s(case.tool, cut)
    loss = _period_loss(kicked, cut.spindle_period_s, t0, t1)
    loss = np.repeat(loss, round(cut.spindle_period_s / tp))  # the revolution's loss for each of its periods
    g = gated_growth_rate(kicked.t_s, d, tp, t_start_s=t0, t_end_s=t1, loss=loss)
    pen = pencil_over_window(kicked.t_s, d, tp, g, second_differences=False) if pencil else None
    return dict(rate=g.rate_per_s, se=g.se_per_s, window=g.window_s, reason=g.reason, pencil=pen,
                dy_in=entry_deflection(kicked), dy_mean=mean_deflection(kicked),
                before=float(np.abs(d[kicked.t_s < t0]).max()))


def run_difference(name: str, factors, kick_below_nm: float, pencil: bool = False) -> None:
    """``--orbit-difference``: :func:`_difference_run` below the limit against the SDM about the orbit."""
    c = CASES[name]()
    if kick_below_nm <= 0:
        kick_below_nm = linear_kick_amplitude_m(chip_scale(c["tool"], c["cut"])) * 1e9
    lim = _limit(c)
    per = "revolution" if has_runout(c["tool"]) else "tooth period"
    print(f"\n## {name} (kicked minus unkicked, sections per {per}): kick {kick_below_nm:g} nm", flush=True)
    for f in factors:
        cut = replace(c["cut"], ap_m=f * lim)
        c0 = time.process_time()
        r = _difference_run(name, c, cut, kick_below_nm, pencil)
        orbit = _orbit_sdm(c, cut, r["dy_in"])
        win = "none" if r["window"] is None else f"{r['window'][0]:.2f}-{r['window'][1]:.2f} s"
        print(f"{name} {f:g}x: difference {_fmt(r['rate'], r['se'])} (window {win}; largest difference before "
              f"full engagement {r['before']:.2e} m){'; ' + r['reason'] if r['reason'] else ''}", flush=True)
        print(f"  SDM about the orbit {orbit:+.4f} 1/s", flush=True)
        print(_criterion_line(r["rate"], r["se"], orbit, f"CPU {time.process_time() - c0:.1f} s"), flush=True)
        if pencil:
            print(_pencil_line(r["pencil"], r["reason"], orbit), flush=True)


def _orbit_sdm(c, cut, dy_m: float) -> float:
    """The SDM about the forced orbit at ae - dy_m: entry shift, surface tilt, delayed instant, 1/s."""
    sgn = 1.0 if cut.mode == "down" else -1.0
    p = LobeProblem(c["structure"], c["tool"], replace(cut, ae_m=cut.ae_m - sgn * dy_m), c["law"])
    return entry_shift_exponent(p, SemiDiscretization(m=40), surface_tilt=True, delay_time=True).value_per_s


def run_orbit(name: str, factors, kick_nm: float, kick_below_nm: float, skip_s: float = 0.0,
              pencil: bool = False) -> None:
    """``--orbit``: the kicked eroded part against the SDM about its forced orbit (module docstring);
    ``kick_below_nm`` <= 0: the largest linear kick (:func:`linear_kick_amplitude_m`)."""
    c = CASES[name]()
    if kick_below_nm <= 0:
        kick_below_nm = linear_kick_amplitude_m(chip_scale(c["tool"], c["cut"])) * 1e9
    if c["robot"] is None:
        print(f"## {name}: no eroded part (not a robot case)")
        return
    lim = _limit(c)
    print(f"\n## {name} (orbit): {c['cut'].spindle_rpm:g} rpm, SDM limit {lim * 1e3:.4f} mm, kick {kick_below_nm:g} "
          f"nm below the limit, {kick_nm:g} nm above, at {_chatter_hz(name, c):.2f} Hz"
          + (f", fit from {skip_s:g} s after full engagement" if skip_s else ""), flush=True)
    for f in factors:
        cut = replace(c["cut"], ap_m=f * lim)
        c0 = time.process_time()
        r = _orbit_run(name, c, cut, kick_below_nm if f < 1 else kick_nm, skip_s, pencil)
        cpu_run = time.process_time() - c0
        sgn = 1.0 if cut.mode == "down" else -1.0
        plain = _sdm(c, replace(cut, ae_m=cut.ae_m - sgn * r["dy_mean"])).value_per_s
        orbit = _orbit_sdm(c, cut, r["dy_in"])
        cpu = time.process_time() - c0
        win = "none" if r["window"] is None else f"{r['window'][0]:.2f}-{r['window'][1]:.2f} s"
        print(f"{name} {f:g}x: eroded {_fmt(r['rate'], r['se'])} (window {win}; periods with loss >= 5 %: "
              f"{r['lossy']}/{r['n_per']}, max {r['loss_max']:.3f}){'; ' + r['reason'] if r['reason'] else ''}",
              flush=True)
        print(f"  first contact {r['contact']:.3f} s, full engagement {r['t0']:.3f} s (chip loss in its second "
              f"period {r['loss1']:.3f})", flush=True)
        print(f"  deflection mean {r['dy_mean'] * 1e6:.2f} um, entry {r['dy_in'] * 1e6:.2f} um; SDM at ae - mean "
              f"{plain:+.4f}, SDM about the orbit {orbit:+.4f} 1/s", flush=True)
        print(_criterion_line(r["rate"], r["se"], orbit, f"CPU run {cpu_run:.1f} s, all {cpu:.1f} s"), flush=True)
        if pencil:
            print(_pencil_line(r["pencil"], r["reason"], orbit), flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    ap.add_argument("--case", default=",".join(CASES), help=f"comma-separated, from {', '.join(CASES)}")
    ap.add_argument("--factor", default=",".join(f"{f:g}" for f in FACTORS), help="comma-separated depth factors")
    ap.add_argument("--no-eroded", action="store_true", help="only the delay-based method")
    ap.add_argument("--orbit", action="store_true",
                    help="the kicked eroded part against the SDM about its forced orbit (robot cases)")
    ap.add_argument("--kick-nm", type=float, default=100.0,
                    help="with --orbit: kick above the limit, as the amplitude of an oscillation at the chatter frequency, nm")
    ap.add_argument("--kick-below-nm", type=float, default=100.0,
                    help="with --orbit: the same below the limit, nm (0: the largest linear kick, rate.py)")
    ap.add_argument("--orbit-difference", action="store_true",
                    help="with --orbit: the kicked run minus the unkicked one, sections per period of the forced orbit")
    ap.add_argument("--pencil", action="store_true",
                    help="with --orbit: also the matrix-pencil rate of the leading mode over the gated window (rate.py)")
    ap.add_argument("--orbit-skip-s", type=float, default=0.0,
                    help="with --orbit: start the fit this long after full engagement, s (default 0: the rule's window)")
    a = ap.parse_args(argv)
    names = [n for n in a.case.split(",") if n]
    bad = [n for n in names if n not in CASES]
    if bad:
        print(f"unknown case {bad[0]!r}; valid: {', '.join(CASES)}", file=sys.stderr)
        return 2
    try:
        factors = [float(x) for x in a.factor.split(",")]
    except ValueError:
        print(f"--factor must be comma-separated numbers, got {a.factor!r}", file=sys.stderr)
        return 2
    if not all(0 < f <= 4 for f in factors):
        print(f"--factor values must be in (0, 4], got {a.factor!r}", file=sys.stderr)
        return 2
    if a.orbit:
        for n in names:
            if a.orbit_difference:
                run_difference(n, factors, a.kick_below_nm, a.pencil)
            else:
                run_orbit(n, factors, a.kick_nm, a.kick_below_nm, a.orbit_skip_s, a.pencil)
        return 0
    c = _benchmark(False)  # compile (or load) the delay kernel outside the CPU timings
    simulate(StructureProblem(c["structure"], c["tool"], c["cut"], c["law"], t_end_s=0.01), DelayNewmark())
    for n in names:
        run_case(n, factors, not a.no_eroded)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
