"""``robolobes simulate``: time-domain simulation of a case's milling pass."""

from __future__ import annotations

import json
import math
import sys

from robolobes.cases import DEFAULT_CASE, load_case
from robolobes.core.errors import BadInput
from robolobes.core.io import Progress
from robolobes.core.outdir import MARKER, OutputDir
from robolobes.linearize.model import VARIANTS

__all__ = ["register", "run_simulate", "validate_simulate"]


def _check_damping(args) -> None:
    if not (math.isfinite(args.damping_scale) and args.damping_scale >= 0):
        raise BadInput(f"--damping-scale must be a finite number >= 0, got {args.damping_scale}")


def _checked(args):
    """``simulate``'s checks before any work: the case and its pass, the damping scale, the
    library's bounds (duration within the pass, deg per step, records <= 2 GiB) and ``--out``.
    Returns ``(case, problem, method, out)``."""
    from robolobes.linearize.model import build_model
    from robolobes.linearize.path import Pass

    from .problem import LinearizedNewmark, NonlinearNewmark, SimulationProblem, step_count
    from .summary import simulation_inputs

    case = load_case(args.case)
    _check_damping(args)
    method = (LinearizedNewmark if args.linearized else NonlinearNewmark)(deg_per_step=args.deg_per_step)
    robot = build_model(case.robot, args.variant, damping_scale=args.damping_scale)
    try:
        problem = SimulationProblem(robot, case, t_end_s=args.duration)
    except BadInput as e:      # the library names its argument t_end_s; the user gave --duration
        raise BadInput(f"--duration {args.duration:g} s: {e}" if "t_end_s" in str(e) else str(e)) from None
    step_count(problem, method)
    Pass.from_case(case)   # the pass itself: start pose in range, feed perpendicular to the tool axis
    return case, problem, method, OutputDir(args.out, "simulate", simulation_inputs(problem, method))


def validate_simulate(args) -> None:
    """Every check ``simulate`` makes before any work (ROBOLOBES_VALIDATE_ONLY)."""
    _checked(args)


def run_simulate(args) -> int:
    from .newmark import NewmarkInterrupted
    from .output import save_result, summary_dict
    from .simulation import simulate

    case, problem, method, out = _checked(args)
    try:
        with Progress(f"simulate {case.name} [{args.variant}{', linearized' if args.linearized else ''}]",
                      enabled=not args.quiet) as bar:
            result = simulate(problem, method, progress=bar)
            bar.done()
    except NewmarkInterrupted as e:
        print(f"\nrobolobes simulate: interrupted at t = {e.result.t_s:.4f} s; nothing written", file=sys.stderr)
        return 130
    s = summary_dict(result)  # its provenance is the marker's: simulation_inputs(problem, method)
    with out:
        save_result(result, out.path, series=args.series)
    paths = sorted(p for p in out.target.iterdir() if p.name != MARKER)
    if args.json:
        print(json.dumps(s, indent=2))
    else:
        st = s.get("stable")
        print(f"{case.name} [{args.variant}], damping x{args.damping_scale:g}: "
              f"{'stable' if st else 'UNSTABLE' if st is False else 'no verdict'}"
              + (f", chatter at {s['chatter_freq_hz']:.1f} Hz" if s.get("chatter_freq_hz") else
                 ", chatter in a band (no spectral line)" if st is False else ""))
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
                   help="spindle rotation per time step, deg (default 2; in (0, 10], records <= 2 GiB)")
    p.add_argument("--series", choices=("npz", "csv"), default="npz", help="format of the time series file")
    p.add_argument("--json", action="store_true", help="print the JSON summary")
    p.add_argument("--quiet", action="store_true", help="no progress display")
    p.add_argument("--out", default="robolobes-simulate", help="output directory (default ./robolobes-simulate)")
    p.set_defaults(run=run_simulate, validate=validate_simulate)
