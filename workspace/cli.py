"""``robolobes map``: lobes across the workspace (poses, placements, tool rotation, tilt).

Writes ``DIR/map.zarr`` (xarray/zarr, resumable: run the same command again after an interruption),
``DIR/map.json`` (summary) and the figures ``map_heatmap.png``, ``map_margin.png``,
``map_robot.png``. Placement offsets move the pass start from the case's (Tab. 7 for the built-in
cases); yaw turns the part (and the feed) about the base z axis.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from robolobes.core.errors import BadInput

__all__ = ["register", "run_map", "parse_range"]

MAX_N = 20_000
MAX_N_RPM = 1_000


def parse_range(name: str, text: str | None, scale: float, default):
    """``"A,B"`` -> ``(A * scale, B * scale)`` with ``A <= B`` finite; None -> ``default``."""
    if text is None:
        return default
    try:
        a, b = (float(t) for t in text.split(","))
    except ValueError:
        raise BadInput(f"{name} must be two comma-separated numbers A,B, got {text!r}") from None
    if not (math.isfinite(a) and math.isfinite(b) and a <= b):
        raise BadInput(f"{name} must be finite with A <= B, got {text!r}")
    return a * scale, b * scale


def _common(p: argparse.ArgumentParser) -> None:
    from robolobes.cases import DEFAULT_CASE
    from robolobes.linearize.model import VARIANTS

    p.add_argument("--case", default=DEFAULT_CASE, help=f"built-in case or case TOML (default {DEFAULT_CASE})")
    p.add_argument("--variant", default="basic", choices=VARIANTS, help="model variant (default basic)")
    p.add_argument("--model", default=None, metavar="FILE",
                   help="identified model TOML (robolobes identify's case TOML with [[elements]]); replaces --case")
    p.add_argument("--tool-modes", default=None, metavar="FILE",
                   help="[[modes]] TOML of tool-tip modes (as lobes --modal), in series with the robot")
    p.add_argument("--at-rpm", type=float, default=None, help="operating speed, rpm (default: the case's)")
    p.add_argument("--scheduler", default="local", metavar="ADDR",
                   help="local (default: 2 processes), serial, or a Dask scheduler tcp://HOST:PORT")
    p.add_argument("--workers", type=int, default=2, help="processes of the local pool (default 2)")
    p.add_argument("--json", action="store_true", help="print the summary as JSON on stdout")
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")


def register(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser("map", help="lobe maps across the workspace", description=__doc__,
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    _common(p)
    p.add_argument("--over", required=True, choices=("pass", "placement", "tool-rotation", "lead-tilt"))
    p.add_argument("--n", type=int, default=25, help=f"poses (about; placement grids share it), 1..{MAX_N}")
    p.add_argument("--x-range-mm", default=None, metavar="A,B", help="pass start offset x, mm (default -200,200)")
    p.add_argument("--y-range-mm", default=None, metavar="A,B", help="pass start offset y, mm (default -200,200)")
    p.add_argument("--z-range-mm", default=None, metavar="A,B", help="pass start offset z, mm (default 0,0)")
    p.add_argument("--yaw-range-deg", default=None, metavar="A,B", help="part yaw about base z, deg (default 0,0)")
    p.add_argument("--rotation-range-deg", default=None, metavar="A,B",
                   help="tool rotation about its axis, deg (default -180,180)")
    p.add_argument("--tilt-range-deg", default=None, metavar="A,B",
                   help="tool tilt about the feed, deg (default -20,20); lead (towards the feed) is not "
                        "modelled: the 2.5-D cut needs the feed perpendicular to the tool axis")
    p.add_argument("--rpm-min", type=float, default=2000.0)
    p.add_argument("--rpm-max", type=float, default=25000.0)
    p.add_argument("--n-rpm", type=int, default=100, help=f"speeds, 1..{MAX_N_RPM} (default 100)")
    p.add_argument("--out", default="robolobes-map", metavar="DIR", help="output directory (default robolobes-map)")
    p.set_defaults(run=run_map)
    return p


def _check_scheduler(s: str) -> str:
    if s in ("local", "serial"):
        return s
    if s.startswith("tcp://") and ":" in s[6:] and s.rsplit(":", 1)[1].isdigit():
        return s
    raise BadInput(f"--scheduler must be local, serial or tcp://HOST:PORT, got {s!r}")


def _tool_modes(path: str | None) -> tuple:
    if path is None:
        return ()
    from robolobes.lobes.cli import read_modal_toml

    return read_modal_toml(path).modes


def problem_from_args(args):
    """MapProblem and MapMethod from the command line, every input checked before any work."""
    from robolobes.cases import load_case

    from .problem import MAX_SPEEDS, MapMethod, MapProblem

    if isinstance(args.n, bool) or not 1 <= args.n <= MAX_N:
        raise BadInput(f"--n must be from 1 to {MAX_N}, got {args.n}")
    if not 1 <= args.n_rpm <= min(MAX_N_RPM, MAX_SPEEDS):
        raise BadInput(f"--n-rpm must be from 1 to {MAX_N_RPM}, got {args.n_rpm}")
    for name in ("rpm_min", "rpm_max"):
        v = getattr(args, name)
        if not (math.isfinite(v) and 0 < v <= 100_000):
            raise BadInput(f"--{name.replace('_', '-')} must be a speed in (0, 100000] rpm, got {v}")
    if args.rpm_max < args.rpm_min:
        raise BadInput(f"--rpm-max ({args.rpm_max}) must be >= --rpm-min ({args.rpm_min})")
    if args.at_rpm is not None and not (math.isfinite(args.at_rpm) and 0 < args.at_rpm <= 100_000):
        raise BadInput(f"--at-rpm must be a speed in (0, 100000] rpm, got {args.at_rpm}")
    if not 1 <= args.workers <= 64:
        raise BadInput(f"--workers must be from 1 to 64, got {args.workers}")
    _check_scheduler(args.scheduler)
    ranges = dict(x_range_m=parse_range("--x-range-mm", args.x_range_mm, 1e-3, (-0.2, 0.2)),
                  y_range_m=parse_range("--y-range-mm", args.y_range_mm, 1e-3, (-0.2, 0.2)),
                  z_range_m=parse_range("--z-range-mm", args.z_range_mm, 1e-3, (0.0, 0.0)),
                  yaw_range_rad=parse_range("--yaw-range-deg", args.yaw_range_deg, math.pi / 180, (0.0, 0.0)),
                  rotation_range_rad=parse_range("--rotation-range-deg", args.rotation_range_deg, math.pi / 180,
                                                 (-math.pi, math.pi)),
                  tilt_range_rad=parse_range("--tilt-range-deg", args.tilt_range_deg, math.pi / 180,
                                             (-math.radians(20), math.radians(20))))
    if abs(ranges["tilt_range_rad"][0]) >= math.pi / 2 or abs(ranges["tilt_range_rad"][1]) >= math.pi / 2:
        raise BadInput(f"--tilt-range-deg must lie within (-90, 90) deg, got {args.tilt_range_deg!r}")
    case = load_case(args.model if args.model is not None else args.case)
    modes = _tool_modes(args.tool_modes)
    speeds = np.linspace(args.rpm_min, args.rpm_max, args.n_rpm)
    problem = MapProblem.make(case, args.variant, args.over, n=args.n, speeds_rpm=speeds, op_rpm=args.at_rpm,
                              tool_modes=modes, model_file=args.model, **ranges)
    return problem, MapMethod()


def _out_dir(args, problem, method):
    """The output directory protocol (core.outdir), checked before any work; resumable."""
    from robolobes.core.outdir import OutputDir

    inputs = {"command": "map", "problem": problem.describe(), "method": method.describe(),
              "robot": repr(problem.case.robot)}
    return OutputDir(args.out, "map", inputs, resume=True)


def _progress(quiet: bool):
    if quiet:
        return None, lambda: None
    from tqdm import tqdm

    bar = {"t": None}

    def cb(done, total):
        if bar["t"] is None:
            bar["t"] = tqdm(total=total, initial=done, unit="pose", desc="map", file=sys.stderr,
                            mininterval=1.0, dynamic_ncols=True)
        else:
            bar["t"].update(done - bar["t"].n)

    return cb, lambda: bar["t"] is not None and bar["t"].close()


def run_map(args: argparse.Namespace) -> int:
    from robolobes.core.io import write_json

    from .plot import plot_map
    from .solver import solve_map

    t0 = time.perf_counter()
    problem, method = problem_from_args(args)
    out = _out_dir(args, problem, method)
    cb, close = _progress(args.quiet)
    with out:
        try:
            result = solve_map(problem, method, path=out.path / "map.zarr", scheduler=args.scheduler,
                               workers=args.workers, progress=cb)
        finally:
            close()
        figures = plot_map(result, out.path)
        summary = result.summary()
        summary.update(wall_s=time.perf_counter() - t0, case=problem.case.name, variant=problem.variant,
                       over=problem.over, store="map.zarr", figures=figures, method=method.describe(),
                       **out.provenance)
        write_json(out.path / "map.json", summary)
    if args.json:
        from robolobes.core.io import to_jsonable

        print(json.dumps(to_jsonable(summary), indent=1))
    else:
        print(f"map over {problem.over}: {summary['n_poses']} poses x {summary['n_speeds']} speeds, "
              f"{summary['n_unreachable']} unreachable, {summary['computed_poses']} computed, "
              f"{summary['wall_s']:.1f} s -> {out.target}")
        if summary["min_depth_limit_m"] is not None:
            print(f"lowest limit {summary['min_depth_limit_m'] * 1e3:.4g} mm at pose {summary['worst_pose']}; "
                  f"at {problem.op_rpm:.0f} rpm the limit ranges {summary['op_min_depth_limit_m'] * 1e3:.4g} to "
                  f"{summary['op_max_depth_limit_m'] * 1e3:.4g} mm (cut {problem.case.cut.ap_m * 1e3:g} mm)")
    return 0
