"""``robolobes study``: the main job (see :mod:`identify.study`)."""

from __future__ import annotations

import sys

from robolobes.core.io import Progress

__all__ = ["register", "run_study_cli"]


def run_study_cli(args) -> int:
    from .study import run_study, study_output

    out = study_output(args.out, args.quick)  # before any work: refuses a directory or file of the user's
    try:
        with Progress("study" + (" --quick" if args.quick else ""), enabled=not args.quiet) as bar:
            res = run_study(out, quick=args.quick, progress=bar)
            bar.done()
    except KeyboardInterrupt:
        print(f"\nrobolobes study: interrupted; {args.out} left as it was", file=sys.stderr)
        return 130
    ex = res["explanation"]
    al, st = ex["aluminium"], ex["steel"]
    print(f"aluminium {al['spindle_rpm']:.0f} rpm, ap {al['depth_m'] * 1e3:.1f} mm: lobes limit "
          f"{al['local_limit_m'] * 1e3:.2f} mm (margin {al['local_margin']:+.2f}), time domain "
          f"{'stable' if al['time_domain_stable_basic'] else 'unstable' if al['time_domain_stable_basic'] is False else 'no verdict'}")
    print(f"steel     {st['spindle_rpm']:.0f} rpm, ap {st['depth_m'] * 1e3:.1f} mm: lobes limit "
          f"{st['local_limit_m'] * 1e3:.2f} mm (margin {st['local_margin']:+.2f}), time domain "
          f"{'stable' if st['time_domain_stable_basic'] else 'unstable' if st['time_domain_stable_basic'] is False else 'no verdict'}")
    print(f"report: {args.out}/report.md, numbers: {args.out}/results.json")
    return 0


def register(sub) -> None:
    p = sub.add_parser("study", help="the main job: why aluminium is stable and steel is not (TX200)",
                       description="Modes, lobes and time-domain runs for the built-in TX200 cases beside the "
                                   "paper; writes report.md, results.json and figures.")
    p.add_argument("--quick", action="store_true", help="coarser grids and shorter runs (under 3 minutes)")
    p.add_argument("--out", default="robolobes-study", help="output directory (default ./robolobes-study)")
    p.add_argument("--quiet", action="store_true", help="no progress display")
    p.set_defaults(run=run_study_cli)
