"""``robolobes modes`` and ``robolobes frf``; the pose selectors shared by every robot subcommand."""

from __future__ import annotations

import argparse
import math

import numpy as np

from robolobes.cases import DEFAULT_CASE, load_case
from robolobes.core.errors import BadInput
from robolobes.core.io import provenance, to_jsonable
from robolobes.core.outdir import check_output_file, cli_inputs, user_path_errors

from .variants import VARIANTS

__all__ = ["add_pose_arguments", "resolve_pose", "register", "run_modes", "run_frf", "validate_modes", "validate_frf", "MAX_FRF_POINTS"]

MAX_FRF_POINTS = 100_000  # H is 3 x 3 x n complex (144 B per frequency): 14 MB; a direct solve per frequency


def add_pose_arguments(p: argparse.ArgumentParser) -> None:
    """Add ``--case``, ``--variant`` and the mutually exclusive pose selectors to a parser."""
    p.add_argument("--case", default=DEFAULT_CASE,
                   help=f"built-in case name or path of a case TOML (default {DEFAULT_CASE})")
    p.add_argument("--variant", default="basic", choices=VARIANTS, help="model variant (default basic)")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--pose", default=None, help="a named pose of the robot file (default: the pass start, tab7)")
    g.add_argument("--path-s", type=float, default=None, metavar="S",
                   help="pose at S metres along the case's pass (0 = start)")
    g.add_argument("--q-deg", default=None, metavar="Q1,...,Q6", help="motor angles in degrees, comma separated")


def _parse_q_deg(text: str, n: int) -> np.ndarray:
    try:
        vals = [float(t) for t in text.split(",")]
    except ValueError:
        raise BadInput(f"--q-deg must be {n} comma-separated numbers in degrees, got {text!r}") from None
    if len(vals) != n or not all(math.isfinite(v) for v in vals):
        raise BadInput(f"--q-deg must be {n} finite comma-separated numbers in degrees, got {text!r}")
    return np.radians(vals)


def resolve_pose(args: argparse.Namespace, case=None):
    """Case, robot model and motor angles selected by :func:`add_pose_arguments` options.

    ``case``: the already loaded ``args.case`` (loaded here if None).

    Returns
    -------
    case : cases.MillingCase
    robot : FlexibleRobot
    theta : array (n_joints,), rad
    label : str
        Human-readable description of the pose.
    """
    from .kinematics import check_limits
    from .model import build_model

    case = case if case is not None else load_case(args.case)
    robot = build_model(case.robot, args.variant, damping_scale=getattr(args, "damping_scale", 1.0) or 1.0)
    if args.q_deg is not None:
        theta, label = _parse_q_deg(args.q_deg, case.robot.n_joints), "q = " + args.q_deg + " deg"
        check_limits(case.robot, theta)
    elif args.path_s is not None:
        from .path import Pass
        pas = Pass.from_case(case)
        theta, label = pas.theta_at_s(args.path_s), f"pass s = {args.path_s:g} m"
    elif args.pose is not None:
        if args.pose not in case.robot.poses_rad:
            raise BadInput(f"--pose {args.pose!r}: robot {case.robot.name!r} has no pose {args.pose!r}; known: "
                           f"{', '.join(sorted(case.robot.poses_rad))}")
        theta, label = case.robot.pose(args.pose), f"pose {args.pose}"
        check_limits(case.robot, theta)
    else:
        theta, label = case.path.start_q_rad, "pass start"
        names = [k for k, v in case.robot.poses_rad.items() if np.array_equal(v, theta)]
        if names:
            label = f"pose {names[0]}"
        check_limits(case.robot, theta)
    return case, robot, np.asarray(theta, dtype=float), label


def run_modes(args) -> int:
    from .summary import modes_summary

    case, robot, theta, label = resolve_pose(args)
    s = modes_summary(robot, theta, case)
    if args.json:
        import json
        s["provenance"] = provenance(cli_inputs(args, case=case))
        print(json.dumps(to_jsonable(s), indent=2))
        return 0
    print(f"{robot.describe()}")
    print(f"case {case.name}, {label}: motor angles (deg) " + ", ".join(f"{v:.3f}" for v in s["q_deg"]))
    p = s["tcp_position_m"]
    print(f"TCP (m, base frame): {p[0]:.4f} {p[1]:.4f} {p[2]:.4f}; tool axis " +
          " ".join(f"{v:+.6f}" for v in s["tool_axis"]))
    for n in s["notes"]:
        print(f"note: {n}")
    print(f"{'mode':>4} {'f_n (Hz)':>10} {'f_d (Hz)':>10} {'zeta (%)':>9}  modal stiffness at TCP (N/um)  x / y / z")
    k = np.asarray(s["modal_stiffness_n_per_m"]) / 1e6
    for r, (fn, fd, z) in enumerate(zip(s["freq_hz"], s["damped_freq_hz"], s["damping_ratio"])):
        ks = " ".join(f"{v:9.3g}" if np.isfinite(v) else f"{'-':>9}" for v in k[:, r])
        print(f"{r + 1:4d} {fn:10.2f} {fd:10.2f} {100 * z:9.3f}  {ks}")
    S = np.asarray(s["tcp_static_stiffness_n_per_m"]) / 1e6
    print("static TCP stiffness (N/um, base frame):")
    for row in S:
        print("   " + " ".join(f"{v:9.3f}" for v in row))
    return 0


def validate_modes(args) -> None:
    """Every check ``modes`` makes before any work (ROBOLOBES_VALIDATE_ONLY): case, variant, pose."""
    resolve_pose(args)


def _frf_checked(args):
    """``frf``'s checks before any work: the band, ``--n``, the case, the pose and both output
    files. Returns ``(case, robot, theta, label, inputs, out, png)``."""
    if not (math.isfinite(args.fmax_hz) and 0 <= args.fmin_hz < args.fmax_hz):
        raise BadInput(f"need 0 <= --fmin-hz < --fmax-hz (finite), got {args.fmin_hz}, {args.fmax_hz}")
    if not 2 <= args.n <= MAX_FRF_POINTS:
        raise BadInput(f"--n must be between 2 and {MAX_FRF_POINTS} frequencies, got {args.n}")
    case = load_case(args.case)
    inputs = cli_inputs(args, case=case)
    out = check_output_file(args.out, (".csv", ".uff", ".unv"), inputs)
    png = check_output_file(out.with_suffix(".png"), (".png",), inputs, name="the Bode plot beside --out,")
    case, robot, theta, label = resolve_pose(args, case)
    return case, robot, theta, label, inputs, out, png


def validate_frf(args) -> None:
    """Every check ``frf`` makes before any work (ROBOLOBES_VALIDATE_ONLY)."""
    _frf_checked(args)


def run_frf(args) -> int:
    from .frf_io import plot_bode, write_frf
    from .linear import linearize

    case, robot, theta, label, inputs, out, png = _frf_checked(args)
    lin = linearize(robot, theta)
    w = 2 * math.pi * np.linspace(args.fmin_hz, args.fmax_hz, args.n)
    frf = lin.frf(w, frame=args.frame, feed_direction=case.cut.feed_direction)
    prov = provenance(inputs)
    with user_path_errors(out):
        write_frf(frf, out, provenance=prov)
    with user_path_errors(png):
        plot_bode(frf, png, title=f"{case.name} [{robot.variant}], {label}: tool-tip receptance ({args.frame} frame)",
                  provenance=prov)
    print(f"wrote {out} and {png}")
    return 0


def register(sub) -> None:
    p = sub.add_parser("modes", help="modes and TCP stiffness at a pose",
                       description="Complex modes (natural/damped frequency, damping, TCP modal stiffness) "
                                   "and static TCP stiffness of the linearized flexible robot.")
    add_pose_arguments(p)
    p.add_argument("--json", action="store_true", help="print a JSON object (SI units, base frame)")
    p.set_defaults(run=run_modes, validate=validate_modes)

    p = sub.add_parser("frf", help="tool-tip FRF at a pose (CSV or UFF58 + Bode PNG)",
                       description="Tool-tip receptance matrix (m/N) by direct solve; written as CSV or UFF58 "
                                   "(by extension) with a Bode plot PNG beside it.")
    add_pose_arguments(p)
    p.add_argument("--fmin-hz", type=float, default=1.0)
    p.add_argument("--fmax-hz", type=float, default=300.0)
    p.add_argument("--n", type=int, default=600, help=f"number of frequencies (linear grid), 2..{MAX_FRF_POINTS} "
                   "(default 600)")
    p.add_argument("--frame", choices=("base", "cut"), default="base",
                   help="axes of the FRF: robot base, or the cut frame (feed, normal, axial)")
    p.add_argument("--out", required=True, help="output file: .csv, .uff or .unv")
    p.set_defaults(run=run_frf, validate=validate_frf)
