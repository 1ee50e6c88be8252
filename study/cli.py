"""``robolobes study``: the main job (see :mod:`robolobes.study`)."""

from __future__ import annotations

import sys

from robolobes.core.io import Progress

__all__ = ["register", "run_study_cli", "validate_study"]


def validate_study(args) -> None:
    """Every check ``study`` makes before any work (ROBOLOBES_VALIDATE_ONLY): the built-in inputs
    and ``--out``."""
    from .run import study_output

    study_output(args.out, args.quick)


def run_study_cli(args) -> int:
    from .run import run_study

    try:
        with Progress("study" + (" --quick" if args.quick else ""), enabled=not args.quiet) as bar:
            # run_study checks --out before any work (core.outdir: a user's directory or file is refused)
            res = run_study(args.out, quick=args.quick, progress=bar)
            bar.done()
    except KeyboardInterrupt:
        print(f"\nrobolobes study: interrupted; {args.out} left as it was", file=sys.stderr)
        return 130
    ex = res["explanation"]
    for mat in ("aluminium", "steel"):
        f = ex[mat]
        limit = "none below the bound" if f["local_limit_m"] is None else f"{f['local_limit_m'] * 1e3:.2f} mm"
        print(f"{mat:9s} {f['spindle_rpm']:.0f} rpm, ap {f['depth_m'] * 1e3:.1f} mm: lobes {f['lobes_verdict']} "
              f"(limit {limit}), time domain {f['time_domain_verdict_basic']}")
    print(f"report: {args.out}/report.md, numbers: {args.out}/results.json")
    return 0


def register(sub) -> None:
    p = sub.add_parser("study", help="the main job: why aluminium is stable and steel is not (TX200)",
                       description="Modes, lobes and time-domain runs for the built-in TX200 cases beside the "
                                   "paper; writes report.md, results.json and figures.")
    p.add_argument("--quick", action="store_true", help="coarser grids and shorter runs (under 3 minutes)")
    p.add_argument("--out", default="robolobes-study", help="output directory (default ./robolobes-study)")
    p.add_argument("--quiet", action="store_true", help="no progress display")
    p.set_defaults(run=run_study_cli, validate=validate_study)
