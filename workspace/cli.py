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

import numpy as np

from robolobes.core.errors import BadInput

__all__ = ["register", "register_optimize", "run_map", "run_optimize", "parse_range"]

MAX_N = 20_000
MAX_N_RPM = 1_000
#: speeds per candidate of the MRR objective (robolobes.workspace.optimize.MAX_MRR_SPEEDS)
MAX_OPT_RPM = 200
#: default simulated time of an optimize --time-domain check, s
TD_END_S = 4.0
#: largest difference (%) measured between a 300 Hz truncated map and lobes.solve of the full
#: model (steel placement poses, docs/guide/workspace.md), quoted by the --truncate-hz help
TRUNCATION_OFF_PCT = 10.2


def method_from_args(args):
    """The :class:`MapMethod` of ``map`` and ``optimize``: the full model, or the opt-in
    ``--truncate-hz`` (a frequency > 0 Hz, checked)."""
    from .problem import MapMethod

    hz = args.truncate_hz
    if hz is not None and not (math.isfinite(hz) and 0 < hz <= 1e5):
        raise BadInput(f"--truncate-hz must be a frequency in (0, 100000] Hz, got {hz}")
    return MapMethod(reduce_max_freq_hz=hz)


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


#: the range options each ``map --over`` uses (any other one given has no effect: refused)
MAP_RANGES = {"pass": (), "placement": ("x_range_mm", "y_range_mm", "z_range_mm", "yaw_range_deg"),
              "tool-rotation": ("rotation_range_deg",), "lead-tilt": ("tilt_range_deg", "lead_range_deg")}
#: the range options each ``optimize --over`` item uses
OPT_RANGES = {"placement": ("x_range_mm", "y_range_mm", "z_range_mm", "yaw_range_deg"),
              "tool-rotation": ("rotation_range_deg",)}


def _flag(dest: str) -> str:
    return "--" + dest.replace("_", "-")


def _refuse_unused(args, used: set, candidates, why: str) -> None:
    """BadInput for the first option among ``candidates`` that was given but is not in ``used``."""
    for dest in candidates:
        if getattr(args, dest, None) is not None and dest not in used:
            raise BadInput(f"{_flag(dest)} has no effect {why}; drop it")


def _case_ref(args) -> str:
    """``--model`` or ``--case`` (the default case if neither); both given: refused (--model replaces
    the case)."""
    from robolobes.cases import DEFAULT_CASE

    if args.model is not None and args.case is not None:
        raise BadInput("--case has no effect with --model (the identified model TOML is a whole case); drop one")
    if args.model is not None:
        return str(args.model)
    if args.case is None:
        args.case = DEFAULT_CASE
    return str(args.case)


def _common(p: argparse.ArgumentParser) -> None:
    from robolobes.cases import DEFAULT_CASE
    from robolobes.linearize.model import VARIANTS

    p.add_argument("--case", default=None, help=f"built-in case or case TOML (default {DEFAULT_CASE}; not with "
                                                "--model)")
    p.add_argument("--variant", default="basic", choices=VARIANTS, help="model variant (default basic)")
    p.add_argument("--model", default=None, metavar="FILE",
                   help="identified model TOML (robolobes identify's case TOML with [[elements]]); replaces --case")
    p.add_argument("--tool-modes", default=None, metavar="FILE",
                   help="[[modes]] TOML of tool-tip modes (as lobes --modal), in series with the robot")
    p.add_argument("--tool-frf", default=None, metavar="FILE|DIR",
                   help="tool-holder FRF measured on a rigid base (as lobes --frf), fitted, in series with the robot")
    p.add_argument("--tool-frf-axes", default=None, metavar="FEED,NORMAL",
                   help="with --tool-frf (required): measured axes along the feed and the cut normal, e.g. x,y")
    p.add_argument("--at-rpm", type=float, default=None, help="operating speed, rpm (default: the case's)")
    p.add_argument("--json", action="store_true", help="print the summary as JSON on stdout")
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")
    p.add_argument("--truncate-hz", type=float, default=None, metavar="HZ",
                   help="opt-in modal truncation of the robot at each pose to its modes up to HZ: faster, not "
                        f"covered by the error estimate, measured up to {TRUNCATION_OFF_PCT:g} %% off the full model "
                        "at 300 Hz (default: the full model)")


def register(subparsers) -> argparse.ArgumentParser:
    """Add ``map`` and ``optimize`` (both commands live here; ``_COMMANDS`` names this module twice)."""
    if "optimize" not in subparsers.choices:
        register_optimize(subparsers)
    p = subparsers.add_parser("map", help="lobe maps across the workspace", description=__doc__,
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    _common(p)
    p.add_argument("--over", required=True, choices=("pass", "placement", "tool-rotation", "lead-tilt"))
    p.add_argument("--scheduler", default="local", metavar="ADDR",
                   help="local (default: 2 processes), serial, or a Dask scheduler tcp://HOST:PORT")
    p.add_argument("--workers", type=int, default=2, help="processes of the local pool (default 2)")
    p.add_argument("--n", type=int, default=25, help=f"poses (about; placement grids share it), 1..{MAX_N}")
    p.add_argument("--x-range-mm", default=None, metavar="A,B", help="pass start offset x, mm (default -200,200)")
    p.add_argument("--y-range-mm", default=None, metavar="A,B", help="pass start offset y, mm (default -200,200)")
    p.add_argument("--z-range-mm", default=None, metavar="A,B", help="pass start offset z, mm (default 0,0)")
    p.add_argument("--yaw-range-deg", default=None, metavar="A,B", help="part yaw about base z, deg (default 0,0)")
    p.add_argument("--rotation-range-deg", default=None, metavar="A,B",
                   help="tool rotation about its axis, deg (default -180,180)")
    p.add_argument("--tilt-range-deg", default=None, metavar="A,B",
                   help="tool tilt about the feed (sideways), deg (default -20,20)")
    p.add_argument("--lead-range-deg", default=None, metavar="A,B",
                   help="tool lead towards the feed, deg: only 0,0 (the default) is accepted, because the 2.5-D "
                        "cut model needs the feed perpendicular to the tool axis")
    p.add_argument("--rpm-min", type=float, default=2000.0)
    p.add_argument("--rpm-max", type=float, default=25000.0)
    p.add_argument("--n-rpm", type=int, default=100, help=f"speeds, 1..{MAX_N_RPM} (default 100)")
    p.add_argument("--out", default="robolobes-map", metavar="DIR", help="output directory (default robolobes-map)")
    p.set_defaults(run=run_map, validate=validate_map)
    return p


def validate_map(args) -> None:
    """Every check ``map`` makes before any work (ROBOLOBES_VALIDATE_ONLY): options, case, output."""
    problem, method = problem_from_args(args)
    _out_dir(args, problem, method).release()


#: seconds to wait for a Dask scheduler to accept a connection before refusing --scheduler
SCHEDULER_TIMEOUT_S = 5.0


def _check_scheduler(s: str) -> str:
    """``local``, ``serial`` or a ``tcp://HOST:PORT`` that accepts a TCP connection now (checked before
    any work, whatever the number of chunks)."""
    import socket

    if s in ("local", "serial"):
        return s
    host, _, port = s[6:].rpartition(":") if s.startswith("tcp://") else ("", "", "")
    host = host.strip("[]")
    if not host or not port.isdigit() or not 1 <= int(port) <= 65535:
        raise BadInput(f"--scheduler must be local, serial or tcp://HOST:PORT with PORT in 1..65535, got {s!r}")
    try:
        with socket.create_connection((host, int(port)), timeout=SCHEDULER_TIMEOUT_S):
            pass
    except OSError as e:
        raise BadInput(f"--scheduler {s}: no Dask scheduler answers there ({e.strerror or e}); start one "
                       "(dask scheduler) or use --scheduler local") from None
    return s


def _tool_modes(args, case) -> tuple:
    """The tool of --tool-modes or --tool-frf as TCP oscillators (lobes.tooltip), angles turned into
    the TCP frame at the case's pass start (then fixed to the spindle at every pose)."""
    from robolobes.linearize.kinematics import fk
    from robolobes.lobes.tooltip import tool_from_files

    tool = tool_from_files(args.tool_modes, args.tool_frf, args.tool_frf_axes)
    if tool is None:
        return ()
    for note in tool.notes:
        print(note, file=sys.stderr)
    _, R = fk(case.robot, case.path.start_q_rad)
    return tool.in_tcp_frame(np.asarray(R), case.cut.feed_direction)


def problem_from_args(args):
    """MapProblem and MapMethod from the command line, every input checked before any work."""
    from robolobes.cases import load_case

    from .problem import MAX_SPEEDS, MapProblem

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
    all_ranges = sorted({d for v in MAP_RANGES.values() for d in v})
    _refuse_unused(args, set(MAP_RANGES[args.over]), all_ranges, f"with --over {args.over}")
    case_ref = _case_ref(args)
    _check_scheduler(args.scheduler)
    ranges = dict(x_range_m=parse_range("--x-range-mm", args.x_range_mm, 1e-3, (-0.2, 0.2)),
                  y_range_m=parse_range("--y-range-mm", args.y_range_mm, 1e-3, (-0.2, 0.2)),
                  z_range_m=parse_range("--z-range-mm", args.z_range_mm, 1e-3, (0.0, 0.0)),
                  yaw_range_rad=parse_range("--yaw-range-deg", args.yaw_range_deg, math.pi / 180, (0.0, 0.0)),
                  rotation_range_rad=parse_range("--rotation-range-deg", args.rotation_range_deg, math.pi / 180,
                                                 (-math.pi, math.pi)),
                  tilt_range_rad=parse_range("--tilt-range-deg", args.tilt_range_deg, math.pi / 180,
                                             (-math.radians(20), math.radians(20))))
    lead = parse_range("--lead-range-deg", args.lead_range_deg, 1.0, (0.0, 0.0))
    if lead != (0.0, 0.0):
        from .problem import LEAD_REASON

        raise BadInput(f"--lead-range-deg {args.lead_range_deg} refused: {LEAD_REASON}")
    if abs(ranges["tilt_range_rad"][0]) >= math.pi / 2 or abs(ranges["tilt_range_rad"][1]) >= math.pi / 2:
        raise BadInput(f"--tilt-range-deg must lie within (-90, 90) deg, got {args.tilt_range_deg!r}")
    case = load_case(case_ref)
    modes = _tool_modes(args, case)
    speeds = np.linspace(args.rpm_min, args.rpm_max, args.n_rpm)
    problem = MapProblem.make(case, args.variant, args.over, n=args.n, speeds_rpm=speeds, op_rpm=args.at_rpm,
                              tool_modes=modes, model_file=args.model, **ranges)
    return problem, method_from_args(args)


def _out_dir(args, problem, method):
    """The output directory protocol (core.outdir), checked before any work; resumable."""
    from robolobes.core.outdir import OutputDir

    inputs = {"command": "map", "problem": problem.describe(), "method": method.describe(),
              "robot": repr(problem.case.robot)}
    return OutputDir(args.out, "map", inputs, resume=True)


def _progress(quiet: bool, label: str = "map"):
    """``(callback(done, total), close)`` on the shared progress display (``core.io.Progress``:
    tqdm on a terminal, a few lines in a log file, nothing with ``--quiet``)."""
    from robolobes.core.io import Progress

    bar = Progress(label, enabled=not quiet)
    return (lambda done, total: bar(done / total if total else 1.0, f"{done}/{total}")), bar.close


def run_map(args: argparse.Namespace) -> int:
    from robolobes.core.io import write_json

    from .plot import plot_map
    from .solver import solve_map

    t0 = time.perf_counter()
    problem, method = problem_from_args(args)
    out = _out_dir(args, problem, method)
    cb, close = _progress(args.quiet)
    with out:
        assert out.path is not None  # set by entering the OutputDir
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
        if problem.over == "lead-tilt":
            from .problem import LEAD_REASON

            summary.update(lead_deg=0.0, lead_note=f"the sweep is over tilt (about the feed) only; lead is fixed at "
                                                  f"0 deg: {LEAD_REASON}")
        summary = limits_for_json(summary, method.depth_max_m)
        write_json(out.path / "map.json", summary)
    if args.json:
        from robolobes.core.io import to_jsonable

        print(json.dumps(to_jsonable(summary), indent=1))
    else:
        print(f"map over {problem.over}: {summary['n_poses']} poses x {summary['n_speeds']} speeds, "
              f"{summary['n_unreachable']} unreachable, {summary['computed_poses']} computed, "
              f"{summary['wall_s']:.1f} s -> {out.target}")
        if summary["min_depth_limit_m"] is not None:
            mm = _limit_text(method.depth_max_m)
            print(f"lowest limit {mm(summary['min_depth_limit_m'])} at pose {summary['worst_pose']}; "
                  f"at {problem.op_rpm:.0f} rpm the limit ranges {mm(summary['op_min_depth_limit_m'])} to "
                  f"{mm(summary['op_max_depth_limit_m'])} (cut {problem.case.cut.ap_m * 1e3:g} mm)")
    return 0


#: the limits of ``map.json`` (m) that are infinite when no limit lies below the depth searched
LIMIT_KEYS = ("min_depth_limit_m", "best_pose_min_depth_limit_m", "op_min_depth_limit_m", "op_max_depth_limit_m")
#: how ``map.json`` writes an infinite limit (JSON has no infinity; ``float("inf")`` reads it back)
STABLE = "inf"
LIMIT_NOTE = (f'a limit of "{STABLE}" means stable at every speed up to depth_max_m (the store holds inf); '
              "null means no reachable pose (the store holds NaN for an unreachable pose)")


def limits_for_json(summary: dict, depth_max_m: float) -> dict:
    """``summary`` with each infinite limit of :data:`LIMIT_KEYS` written as :data:`STABLE`, so that
    "stable up to ``depth_max_m``" is never written as the null of "no reachable pose"."""
    out = dict(summary)
    for k in LIMIT_KEYS:
        v = out.get(k)
        if v is not None and math.isinf(v) and v > 0:
            out[k] = STABLE
    out.update(depth_max_m=depth_max_m, limit_note=LIMIT_NOTE)
    return out


def _limit_text(depth_max_m: float):
    """A map.json limit (m, or :data:`STABLE`) as text in mm."""
    return lambda v: f"none below {depth_max_m * 1e3:g} mm" if v == STABLE else f"{v * 1e3:.4g} mm"


# ------------------------------------------------------------------------------------ optimize
def register_optimize(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "optimize", help="placement and tool rotation that maximize the minimum stable depth over the pass",
        description="Choose the part's placement (x, y, z offset of the pass start, yaw) and the tool's rotation "
                    "about its axis to maximize the smallest critical depth over the pass at the chosen speed "
                    "(multistart + Nelder-Mead on the SDM limit; the optimum is checked by SDM on the full model "
                    "and, with --time-domain, by the linearized time domain). Writes DIR/optimize.json and "
                    "DIR/optimize.png.")
    _common(p)
    p.add_argument("--over", default="placement,tool-rotation",
                   help="comma list of placement, tool-rotation (default both)")
    p.add_argument("--x-range-mm", default=None, metavar="A,B", help="pass start offset x, mm (default -100,100)")
    p.add_argument("--y-range-mm", default=None, metavar="A,B", help="pass start offset y, mm (default -100,100)")
    p.add_argument("--z-range-mm", default=None, metavar="A,B", help="pass start offset z, mm (default 0,0: fixed)")
    p.add_argument("--yaw-range-deg", default=None, metavar="A,B", help="part yaw, deg (default -30,30)")
    p.add_argument("--rotation-range-deg", default=None, metavar="A,B", help="tool rotation, deg (default -180,180)")
    p.add_argument("--n-s", type=int, default=5, help="poses along the pass (default 5)")
    p.add_argument("--n-starts", type=int, default=12, help="multistart sample size (default 12)")
    p.add_argument("--max-local-evals", type=int, default=40, help="Nelder-Mead evaluations per local run (default 40)")
    p.add_argument("--objective", default="depth", choices=("depth", "mrr"),
                   help="depth: the minimum critical depth over the pass at the chosen speed (default); mrr: the "
                        "material removal rate a_p a_e f_z N n with the speed free over --rpm-min..--rpm-max")
    p.add_argument("--rpm-min", type=float, default=None,
                   help="mrr: lowest speed searched, rpm (default half the case's speed)")
    p.add_argument("--rpm-max", type=float, default=None,
                   help="mrr: highest speed searched, rpm (default the case's speed: the cutting speed the tool and "
                        "material allow, which the model does not know)")
    p.add_argument("--n-rpm", type=int, default=None, help=f"mrr: speeds searched, 1..{MAX_OPT_RPM} (default 16)")
    p.add_argument("--strict", action="store_true", help="joint ranges without the 5 deg tolerance")
    p.add_argument("--time-domain", action="store_true", help="verify baseline and optimum in the time domain")
    p.add_argument("--td-end-s", type=float, default=None, help="with --time-domain: simulated time of each "
                   f"verification run, s (default {TD_END_S:g}, capped at the pass duration)")
    p.add_argument("--out", default="robolobes-optimize", metavar="DIR", help="output directory")
    p.set_defaults(run=run_optimize, validate=validate_optimize)
    return p


def validate_optimize(args) -> None:
    """Every check ``optimize`` makes before any work (ROBOLOBES_VALIDATE_ONLY)."""
    from robolobes.core.outdir import OutputDir

    opt = optimize_problem_from_args(args)
    method_from_args(args)
    OutputDir(args.out, "optimize", _optimize_inputs(args, opt))


def optimize_problem_from_args(args):
    from robolobes.cases import load_case

    from .optimize import OptimizeProblem
    from .problem import MapProblem

    over = [s.strip() for s in args.over.split(",") if s.strip()]
    bad = [s for s in over if s not in ("placement", "tool-rotation")]
    if bad or not over:
        raise BadInput(f"--over must be a comma list of placement, tool-rotation, got {args.over!r}")
    if not 2 <= args.n_s <= 50:
        raise BadInput(f"--n-s must be from 2 to 50, got {args.n_s}")
    if not 1 <= args.n_starts <= 500:
        raise BadInput(f"--n-starts must be from 1 to 500, got {args.n_starts}")
    if not 0 <= args.max_local_evals <= 2000:
        raise BadInput(f"--max-local-evals must be from 0 to 2000, got {args.max_local_evals}")
    used = {d for o in over for d in OPT_RANGES[o]}
    _refuse_unused(args, used, OPT_RANGES["placement"] + OPT_RANGES["tool-rotation"], f"with --over {args.over}")
    if args.td_end_s is not None and not args.time_domain:
        raise BadInput("--td-end-s has no effect without --time-domain; drop it or add --time-domain")
    args.td_end_s = TD_END_S if args.td_end_s is None else args.td_end_s
    if not (math.isfinite(args.td_end_s) and 0 < args.td_end_s <= 60):
        raise BadInput(f"--td-end-s must be in (0, 60] s, got {args.td_end_s}")
    case_ref = _case_ref(args)
    if args.at_rpm is not None and not (math.isfinite(args.at_rpm) and 0 < args.at_rpm <= 100_000):
        raise BadInput(f"--at-rpm must be a speed in (0, 100000] rpm, got {args.at_rpm}")
    rng = {"x_offset_m": parse_range("--x-range-mm", args.x_range_mm, 1e-3, (-0.1, 0.1)),
           "y_offset_m": parse_range("--y-range-mm", args.y_range_mm, 1e-3, (-0.1, 0.1)),
           "z_offset_m": parse_range("--z-range-mm", args.z_range_mm, 1e-3, (0.0, 0.0)),
           "yaw_rad": parse_range("--yaw-range-deg", args.yaw_range_deg, math.pi / 180,
                                  (-math.radians(30), math.radians(30))),
           "tool_rotation_rad": parse_range("--rotation-range-deg", args.rotation_range_deg, math.pi / 180,
                                            (-math.pi, math.pi))}
    names = []
    if "placement" in over:
        names += [k for k in ("x_offset_m", "y_offset_m", "z_offset_m", "yaw_rad") if rng[k][1] > rng[k][0]]
    if "tool-rotation" in over and rng["tool_rotation_rad"][1] > rng["tool_rotation_rad"][0]:
        names.append("tool_rotation_rad")
    if not names:
        raise BadInput("every range of --over is empty (A = B): nothing to optimize")
    flags = {"x_offset_m": ("--x-range-mm", 1e3), "y_offset_m": ("--y-range-mm", 1e3),
             "z_offset_m": ("--z-range-mm", 1e3), "yaw_rad": ("--yaw-range-deg", 180 / math.pi),
             "tool_rotation_rad": ("--rotation-range-deg", 180 / math.pi)}
    for k in names:
        if not rng[k][0] <= 0.0 <= rng[k][1]:
            flag, scale = flags[k]
            raise BadInput(f"{flag} must contain 0 (the paper's placement is the baseline), got "
                           f"{rng[k][0] * scale:g},{rng[k][1] * scale:g}")
    speed_flags = [f for f, v in (("--rpm-min", args.rpm_min), ("--rpm-max", args.rpm_max), ("--n-rpm", args.n_rpm))
                   if v is not None]
    if args.objective == "depth" and speed_flags:
        raise BadInput(f"{speed_flags[0]} is for --objective mrr (the depth objective uses --at-rpm)")
    if args.objective == "mrr" and args.at_rpm is not None:
        raise BadInput("--at-rpm is for --objective depth (mrr searches --rpm-min..--rpm-max)")
    case = load_case(case_ref)
    speeds = tuple(_mrr_speeds(args, case)) if args.objective == "mrr" else ()
    mp = MapProblem.make(case, args.variant, "placement", n=1, speeds_rpm=[case.cut.spindle_rpm],
                         op_rpm=args.at_rpm, tool_modes=_tool_modes(args, case), model_file=args.model)
    return OptimizeProblem(mp, tuple(names), {k: rng[k] for k in names}, n_s=args.n_s, strict=args.strict,
                           objective=args.objective, speeds_rpm=speeds)


def _mrr_speeds(args, case) -> np.ndarray:
    """The speeds the MRR objective searches (rpm), checked: default half the case's speed to the
    case's speed, 16 of them."""
    lo = case.cut.spindle_rpm / 2 if args.rpm_min is None else args.rpm_min
    hi = case.cut.spindle_rpm if args.rpm_max is None else args.rpm_max
    n = 16 if args.n_rpm is None else args.n_rpm
    for name, v in (("--rpm-min", lo), ("--rpm-max", hi)):
        if not (math.isfinite(v) and 0 < v <= 100_000):
            raise BadInput(f"{name} must be a speed in (0, 100000] rpm, got {v}")
    if hi < lo:
        raise BadInput(f"--rpm-max ({hi}) must be >= --rpm-min ({lo})")
    if isinstance(n, bool) or not 1 <= n <= MAX_OPT_RPM:
        raise BadInput(f"--n-rpm must be from 1 to {MAX_OPT_RPM}, got {n}")
    return np.linspace(lo, hi, n)


def _optimize_inputs(args, opt) -> dict:
    """What determines an optimize run's results (its output's ``inputs_sha256``)."""
    return {"command": "optimize", "problem": opt.map_problem.describe(), "variables": list(opt.variables),
            "bounds": {k: list(v) for k, v in opt.bounds.items()}, "n_s": opt.n_s, "strict": opt.strict,
            "objective": opt.objective, "speeds_rpm": list(opt.speeds_rpm),
            "n_starts": args.n_starts, "max_local_evals": args.max_local_evals,
            "time_domain": args.time_domain, "td_end_s": args.td_end_s, "robot": repr(opt.map_problem.case.robot),
            **({} if args.truncate_hz is None else {"truncate_hz": args.truncate_hz})}


def run_optimize(args: argparse.Namespace) -> int:
    from robolobes.core.io import to_jsonable, write_json
    from robolobes.core.outdir import OutputDir

    from .optimize import optimize_with_strict
    from .output import lobes_check_command, optimize_json, optimum_case_toml, plot_optimum
    from .verify import time_domain_check

    t0 = time.perf_counter()
    opt = optimize_problem_from_args(args)
    method = method_from_args(args)
    out = OutputDir(args.out, "optimize", _optimize_inputs(args, opt))
    cb, close = _progress(args.quiet, "optimize")
    try:
        res, strict = optimize_with_strict(opt, method, n_starts=args.n_starts, max_local_evals=args.max_local_evals,
                                           progress=cb)
    finally:
        close()
    js = optimize_json(opt, res, strict, method)
    if args.time_domain:
        js["time_domain"] = time_domain_check(opt, res, args.td_end_s)
    js["wall_s"] = time.perf_counter() - t0
    with out:
        assert out.path is not None  # set by entering the OutputDir
        js.update(out.provenance)
        if res.best.feasible:
            from robolobes.core.io import write_text

            write_text(out.path / "optimum-case.toml", optimum_case_toml(args.model or args.case, res))
            js["lobes_check"] = lobes_check_command(opt, js)
        write_json(out.path / "optimize.json", js)
        plot_optimum(res, out.path / "optimize.png")
    if args.json:
        print(json.dumps(to_jsonable(js), indent=1))
    else:
        _print_optimum(js, out.target)
    return 0


def _print_optimum(js: dict, target) -> None:
    def mm(v):
        if v is None or math.isinf(v):   # JSON writes inf as null: no limit below the depth searched
            return f"no limit below {js['depth_max_m'] * 1e3:g} mm"
        return f"{v * 1e3:.4g} mm"

    g = js["gain"]
    gain = f"{g:.3g}" if g is not None and math.isfinite(g) else (
        f"at least {js['gain_at_least']:.3g}" if js["gain_at_least"] is not None else "none")
    where = (f"offset {np.round(np.array(js['placement_offset_m']) * 1e3, 1).tolist()} mm, yaw {js['yaw_deg']:.1f} deg, "
             f"tool rotation {js['tool_rotation_deg']:.1f} deg")
    if not js["optimum_feasible"]:
        print(f"{js['case']}: no feasible candidate found ({js['optimum_reason']}); try more --n-starts or wider "
              f"ranges -> {target}")
    elif js["objective"] == "mrr":
        print(f"{js['case']}: material removal rate {js['baseline_mrr_cm3_per_min']:.4g} cm^3/min (paper's placement, "
              f"{js['baseline_rpm']:.0f} rpm) -> {js['optimized_mrr_cm3_per_min']:.4g} cm^3/min at {js['best_rpm']:.0f} "
              f"rpm (gain {js['mrr_gain']:.3g}; depth {mm(js['optimized_min_depth_m'])}) with {where} -> {target}")
    else:
        print(f"{js['case']} at {js['rpm']:.0f} rpm: minimum critical depth over the pass "
              f"{mm(js['baseline_min_depth_m'])} (paper's placement) -> {mm(js['optimized_min_depth_m'])} "
              f"(gain {gain}) with {where} -> {target}")
    st = js["strict_optimum"]
    found = mm(st["min_depth_m"]) if st["feasible"] else "none (no strictly feasible candidate found)"
    print(f"strict joint ranges ({st['how']}): minimum depth {found}; baseline strict-feasible: "
          f"{js['baseline_strict_ok']} ({js['baseline_strict_violation'] or 'inside'})")
