"""``robolobes simulate``: time-domain simulation of a case's milling pass."""

from __future__ import annotations

import json
import math
import sys

from robolobes.cases import DEFAULT_CASE, load_case
from robolobes.core.errors import BadInput
from robolobes.core.io import Progress, write_json
from robolobes.core.outdir import MARKER, OutputDir, cli_inputs
from robolobes.linearize.model import VARIANTS

__all__ = ["register", "run_simulate"]


# Bounds on what sets memory and run time (checked before any work). The records and the series
# derived from them are about 25 float64 per time step (time, forces, tool centre, TCP, deviation,
# angle: ~0.2 kB, an estimate from the arrays allocated): 4e6 steps stay under 1 GB. That is 20
# times the default steel pass (2.04e5 steps of 2 deg over 21.96 s) and 40 times the aluminium
# one (9.8e4 steps over 1.754 s).
MAX_STEPS = 4_000_000
MAX_DEG_PER_STEP = 10.0  # coarser steps under-resolve the tooth passing (the library's own limit)


def _check_options(args, case) -> None:
    """Bounds on --duration, --deg-per-step, --damping-scale, before any work (BadInput)."""
    from robolobes.linearize.path import FeedProfile

    if not (math.isfinite(args.damping_scale) and args.damping_scale >= 0):
        raise BadInput(f"--damping-scale must be a finite number >= 0, got {args.damping_scale}")
    if not (math.isfinite(args.deg_per_step) and 0 < args.deg_per_step <= MAX_DEG_PER_STEP):
        raise BadInput(f"--deg-per-step must be in (0, {MAX_DEG_PER_STEP:g}] deg of spindle rotation, got "
                       f"{args.deg_per_step}")
    pass_s = FeedProfile(travel_m=case.path.travel_m(case.tool), feed_m_per_s=case.cut.feed_rate_m_per_s(case.tool),
                         ramp_s=case.path.ramp_s).duration_s
    if args.duration is not None and not (math.isfinite(args.duration) and 0 < args.duration <= pass_s):
        raise BadInput(f"--duration must be a simulated time > 0 s and at most the pass, {pass_s:.4g} s for case "
                       f"{case.name}, got {args.duration}")
    t_end = args.duration if args.duration is not None else pass_s
    steps = t_end * case.cut.spindle_rpm * 6.0 / args.deg_per_step  # spindle deg per s / deg per step
    if steps > MAX_STEPS:
        raise BadInput(f"--deg-per-step {args.deg_per_step:g} over {t_end:.4g} s at {case.cut.spindle_rpm:g} rpm makes "
                       f"{steps:.3g} time steps, more than {MAX_STEPS:.0e}: use at least "
                       f"{t_end * case.cut.spindle_rpm * 6.0 / MAX_STEPS:.3g} deg per step or a shorter --duration")


def run_simulate(args) -> int:
    from robolobes.linearize.model import build_model

    from .newmark import NewmarkInterrupted
    from .output import save_result, summary_dict
    from .problem import LinearizedNewmark, NonlinearNewmark, SimulationProblem
    from .simulation import simulate

    case = load_case(args.case)
    _check_options(args, case)
    out = OutputDir(args.out, "simulate", cli_inputs(args, case=case))
    method = (LinearizedNewmark if args.linearized else NonlinearNewmark)(deg_per_step=args.deg_per_step)
    robot = build_model(case.robot, args.variant, damping_scale=args.damping_scale)
    problem = SimulationProblem(robot, case, t_end_s=args.duration)
    try:
        with Progress(f"simulate {case.name} [{args.variant}{', linearized' if args.linearized else ''}]",
                      enabled=not args.quiet) as bar:
            result = simulate(problem, method, progress=bar)
            bar.done()
    except NewmarkInterrupted as e:
        print(f"\nrobolobes simulate: interrupted at t = {e.result.t_s:.4f} s; nothing written", file=sys.stderr)
        return 130
    s = {**summary_dict(result), "provenance": out.provenance}
    with out:
        save_result(result, out.path, series=args.series)
        write_json(out.path / "summary.json", s)  # with its provenance
    paths = sorted(p for p in out.target.iterdir() if p.name != MARKER)
    if args.json:
        print(json.dumps(s, indent=2))
    else:
        st = s.get("stable")
        print(f"{case.name} [{args.variant}], damping x{args.damping_scale:g}: "
              f"{'stable' if st else 'UNSTABLE' if st is False else 'no verdict'}"
              + (f", chatter at {s['chatter_freq_hz']:.1f} Hz" if s.get("chatter_freq_hz") else ""))
        fs = s.get("force_stats_paper_axes")
        if fs:
            lo, hi = s["force_stats_window_s"]
            print(f"forces {lo:.2f}-{hi:.2f} s (paper axes, N):   min     max    mean     rms")
            for ax in ("x", "y"):
                v = fs[ax]
                print(f"  F{ax}                          {v['min']:7.1f} {v['max']:7.1f} {v['mean']:7.2f} {v['rms']:7.2f}")
        r = s.get("roughness_um")
        if r:
            print(f"wall roughness (um): Ra {r['Ra']:.2f}  Rq {r['Rq']:.2f}  Rt {r['Rt']:.2f}")
        print(f"wrote {len(paths)} files to {args.out}")
    return 0


def register(sub) -> None:
    p = sub.add_parser("simulate", help="time-domain simulation of a milling pass",
                       description="Newmark simulation of the flexible robot cutting the case's part: forces, "
                                   "TCP deviation, machined wall, roughness, stability verdict.")
    p.add_argument("--case", default=DEFAULT_CASE, help=f"built-in case name or case TOML path (default {DEFAULT_CASE})")
    p.add_argument("--variant", default="basic", choices=VARIANTS, help="model variant (default basic)")
    p.add_argument("--duration", type=float, default=None, metavar="S",
                   help="simulated time in s from the start of the pass (default: the whole pass)")
    p.add_argument("--damping-scale", type=float, default=1.0, metavar="F",
                   help="multiply the joint damping by F (the paper's x10 experiment)")
    p.add_argument("--linearized", action="store_true",
                   help="fast path: robot linearized at the start pose + nonlinear milling and backlash")
    p.add_argument("--deg-per-step", type=float, default=2.0,
                   help=f"spindle rotation per time step, deg (default 2; at most {MAX_STEPS:.0e} steps in all)")
    p.add_argument("--series", choices=("npz", "csv"), default="npz", help="format of the time series file")
    p.add_argument("--json", action="store_true", help="print the JSON summary")
    p.add_argument("--quiet", action="store_true", help="no progress display")
    p.add_argument("--out", default="robolobes-simulate", help="output directory (default ./robolobes-simulate)")
    p.set_defaults(run=run_simulate)
