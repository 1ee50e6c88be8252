"""``robolobes lobes``: stability lobe diagram of the robot at a pose, or of a user's modal model.

Robot (default): the case's tool, cutting law and cut; the structure is the robot linearized at
the selected pose (``--case --variant --pose|--path-s|--q-deg``), seen in the cut frame of the
case's feed direction. Operating point: ``--at-rpm``/``--at-depth-mm``, default the case's cut.

Modal model: ``--modal FILE.toml`` with ``[[modes]]`` tables (``freq_hz``, ``damping_ratio``,
``stiffness_n_per_m``, ``direction = [x, y]`` unit vector in the cut frame; or, for a complex mode,
``freq_hz``, ``damping_ratio`` and its residue ``residue_re``, ``residue_im`` as 2 x 2 arrays
``[[xx, xy], [yx, yy]]`` in m/(N s), ``H(s) = R / (s - lam) + conj``) and the tool and
material on the command line (``--teeth --diameter-mm --ae-mm --up|--down --ktc-mpa --krc-mpa
[--helix-deg] [--pitch-deg a,b,...]``).

Measured FRF: ``--frf FILE|DIR`` (UFF58 receptance, mobility or accelerance, or CSV as ``robolobes
frf`` writes it; a directory: every such file in it) with ``--frf-axes=FEED,NORMAL`` (which
measured axis, with its sign, lies along the feed and the cut normal, e.g. ``x,y`` or ``-y,x``) and
the tool and material as for ``--modal``. ``--method zoa`` uses the FRF itself on its band;
``--method sdm`` fits complex modes (vector fitting, ``--fit-modes N`` to set their number),
reports the fit and refuses a fit that is not credible. ``--fit-plot PNG``: measured against
fitted FRF.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from robolobes.cases import DEFAULT_CASE, load_case
from robolobes.core.io import Progress, provenance, to_jsonable
from robolobes.core.outdir import check_output_file, cli_inputs, user_path_errors
from robolobes.cases.milling import Cut, CuttingLaw, MillingError, Tool

from ._errors import LobeError
from .problem import LobeProblem
from robolobes.linearize.cli import add_pose_arguments

from .refine import RefinedSDM
from .sdm import SemiDiscretization
from .solver import solve, stability
from .modal_file import read_modal_toml
from .structure import PhysicalStructure
from .zoa import ZeroOrder

__all__ = ["register", "run", "validate_lobes", "read_modal_toml", "MAX_M", "MAX_N_RPM"]

# Bounds on what sets memory and run time (checked before any work). The SDM's monodromy matrix is
# (2 n + m n_delay)^2 per speed and its cost grows as m^3: m = 400 is 10x the default and far past
# convergence (m = 20..160 agree to 1e-3 /s on the TX200); 5000 speeds is 25x the default.
MAX_M = 400
MAX_N_RPM = 5000
_FRF_ONLY = {"--frf-axes": "frf_axes", "--fit-modes": "fit_modes", "--fit-plot": "fit_plot"}
#: finest level of the default refinement, and the accepted range of --tol-pct (%): below 0.1 % the
#: levels needed pass m = 320 on the benchmark's narrow lobes (run time), above 20 % the estimate is
#: no longer a small-error expansion
M_MAX_REFINE = 320
TOL_PCT_RANGE = (0.1, 20.0)
_MODAL_ONLY = {"--teeth": "teeth", "--diameter-mm": "diameter_mm", "--ktc-mpa": "ktc_mpa", "--krc-mpa": "krc_mpa",
               "--kac-mpa": "kac_mpa", "--helix-deg": "helix_deg", "--pitch-deg": "pitch_deg"}
_ROBOT_ONLY = {"--case": "case", "--variant": "variant", "--pose": "pose", "--path-s": "path_s", "--q-deg": "q_deg",
               "--tool-modes": "tool_modes", "--tool-frf": "tool_frf", "--tool-frf-axes": "tool_frf_axes"}
_FIGURE_SUFFIXES = (".png", ".pdf", ".svg")


def register(subparsers) -> argparse.ArgumentParser:
    """Add the ``lobes`` subcommand to an argparse subparsers object."""
    p = subparsers.add_parser(
        "lobes", help="stability lobe diagram (semi-discretization or zero-order)",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_pose_arguments(p)
    p.add_argument("--method", choices=("sdm", "zoa"), default="sdm",
                   help="sdm: first-order semi-discretization (default); zoa: Altintas-Budak zero-order")
    p.add_argument("--scheme", choices=("sdm", "free-exact"), default=None,
                   help="SDM scheme: sdm (Insperger-Stepan, default) or free-exact (exact free decay, faster)")
    p.add_argument("--m", type=int, default=None, help=f"SDM steps per principal period of the first level (default "
                   f"40, at most {MAX_M}); refined per speed (m, 2m, ... up to {M_MAX_REFINE}) until the error "
                   "estimate is below --tol-pct")
    p.add_argument("--reduced-basis", action="store_true",
                   help="SDM on a reduced modal basis (lobes.basis: modes the cut cannot feel replaced by their "
                        "static compliance, loop perturbation <= 0.1 %%); off by default: on the TX200 at 10 mm "
                        "it keeps the full model")
    p.add_argument("--tol-pct", type=float, default=None, help="target error estimate of the limit, %% of it "
                   f"(default 1, from {TOL_PCT_RANGE[0]:g} to {TOL_PCT_RANGE[1]:g})")
    p.add_argument("--no-refine", action="store_true", help="one SDM level at --m, without error estimate")
    p.add_argument("--rpm-min", type=float, default=2000.0, help="lowest spindle speed, rpm (default 2000)")
    p.add_argument("--rpm-max", type=float, default=25000.0, help="highest spindle speed, rpm (default 25000)")
    p.add_argument("--n-rpm", type=int, default=200, help=f"number of speeds (default 200, at most {MAX_N_RPM})")
    p.add_argument("--depth-max-mm", type=float, default=10.0, help="largest depth searched, mm (default 10)")
    p.add_argument("--at-rpm", type=float, default=None, help="operating point speed, rpm")
    p.add_argument("--at-depth-mm", type=float, default=None, help="operating point axial depth, mm")
    p.add_argument("--json", action="store_true", help="print the results as JSON on stdout")
    p.add_argument("--out", default=None, metavar="PNG", help="write the lobe diagram to this PNG (or .pdf, .svg)")
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")
    t = p.add_argument_group("tool-holder dynamics in series with the robot (robot mode)")
    t.add_argument("--tool-modes", default=None, metavar="FILE.toml",
                   help="[[modes]] TOML of tool-tip modes (as --modal), in series with the robot")
    t.add_argument("--tool-frf", default=None, metavar="FILE|DIR",
                   help="tool-holder FRF measured on a rigid base (as --frf), fitted, in series with the robot")
    t.add_argument("--tool-frf-axes", default=None, metavar="FEED,NORMAL",
                   help="with --tool-frf (required): measured axes along the feed and the cut normal, e.g. x,y")
    g = p.add_argument_group("user's modal model (instead of the robot)")
    g.add_argument("--modal", default=None, metavar="FILE.toml", help="[[modes]] tables: freq_hz, damping_ratio, "
                   "stiffness_n_per_m, direction = [x, y] (unit, cut frame); or freq_hz, damping_ratio, "
                   "residue_re, residue_im (2 x 2, m/(N s)) for a complex mode")
    g.add_argument("--frf", default=None, metavar="FILE|DIR",
                   help="measured tool-tip FRF (UFF58 or CSV, or a directory of them) instead of --modal")
    g.add_argument("--frf-axes", default=None, metavar="FEED,NORMAL",
                   help="with --frf (required): measured axes along the feed and the cut normal, e.g. x,y or -y,x "
                        "(write --frf-axes=-y,x)")
    g.add_argument("--fit-modes", type=int, default=None, metavar="N",
                   help="with --frf: number of modes of the modal fit (default: one per resonance peak)")
    g.add_argument("--fit-plot", default=None, metavar="PNG", help="with --frf: measured against fitted FRF figure")
    g.add_argument("--teeth", type=int, default=None)
    g.add_argument("--diameter-mm", type=float, default=None)
    g.add_argument("--ae-mm", type=float, default=None, help="radial depth of cut, mm")
    ud = g.add_mutually_exclusive_group()
    ud.add_argument("--up", dest="milling_mode", action="store_const", const="up", help="up-milling")
    ud.add_argument("--down", dest="milling_mode", action="store_const", const="down", help="down-milling (default)")
    g.add_argument("--ktc-mpa", type=float, default=None, help="tangential cutting coefficient, MPa")
    g.add_argument("--krc-mpa", type=float, default=None, help="radial cutting coefficient, MPa")
    g.add_argument("--kac-mpa", type=float, default=None, help="axial cutting coefficient, MPa (default 0)")
    g.add_argument("--helix-deg", type=float, default=None, help="helix angle, deg (default 0)")
    g.add_argument("--pitch-deg", default=None, metavar="A,B,...", help="pitch angles, deg, summing to 360")
    p.set_defaults(run=run, validate=validate_lobes, milling_mode=None, case=None, variant=None)  # None: not given (see _check_flags)
    return p


def _user_problem(args, structure, label: str) -> tuple[LobeProblem, str]:
    """The problem of a user's structure (modal file or measured FRF) with the tool and material
    from the command line."""
    pitch: tuple[float, ...] = ()  # () equal pitch
    if args.pitch_deg is not None:
        try:
            pitch = tuple(math.radians(float(x)) for x in args.pitch_deg.split(","))
        except ValueError:
            raise LobeError(f"--pitch-deg must be comma-separated angles in deg, got {args.pitch_deg!r}") from None
    try:
        tool = Tool(diameter_m=args.diameter_mm * 1e-3, teeth=args.teeth,
                    helix_rad=math.radians(args.helix_deg or 0.0), pitch_rad=pitch)
        law = CuttingLaw(ktc_pa=args.ktc_mpa * 1e6, krc_pa=args.krc_mpa * 1e6, kac_pa=(args.kac_mpa or 0.0) * 1e6)
        depth = (args.at_depth_mm if args.at_depth_mm is not None else 1.0) * 1e-3
        rpm = args.at_rpm if args.at_rpm is not None else 0.5 * (args.rpm_min + args.rpm_max)
        cut = Cut(ae_m=args.ae_mm * 1e-3, ap_m=depth, spindle_rpm=rpm, mode=args.milling_mode or "down")
    except MillingError as e:
        raise LobeError(str(e)) from None
    return LobeProblem(structure, tool, cut, law), label


def _check_tool_flags(args) -> None:
    need = {"--teeth": args.teeth, "--diameter-mm": args.diameter_mm, "--ae-mm": args.ae_mm,
            "--ktc-mpa": args.ktc_mpa, "--krc-mpa": args.krc_mpa}
    missing = [k for k, v in need.items() if v is None]
    if missing:
        which = "--modal" if args.modal is not None else "--frf"
        raise LobeError(f"{which} needs the tool and material too: missing {', '.join(missing)}")


def _modal_problem(args) -> tuple[LobeProblem, str]:
    _check_tool_flags(args)
    return _user_problem(args, read_modal_toml(args.modal), f"modal model {args.modal}")


def _frf_problem(args, fit_plot_path, prov_inputs) -> tuple[LobeProblem, str, dict]:
    """The problem of a measured FRF: the FRF itself (zoa) or its modal fit (sdm); the fit is
    plotted when asked and must be credible for the SDM. Returns (problem, label, info for output)."""
    from robolobes.linearize.frf_io import read_tool_frf

    from .measured import MeasuredStructure
    from .modal_fit import fit_modal, plot_fit

    _check_tool_flags(args)
    tf = read_tool_frf(args.frf, args.frf_axes)
    meas = MeasuredStructure(tf.frf.omega, tf.frf.H, cross_measured=tf.cross_measured, source=str(args.frf))
    info: dict = {"file": str(args.frf), "axes": args.frf_axes, "band_hz": list(meas.band_hz),
                  "lines": len(meas.omega), "cross_measured": tf.cross_measured, "notes": list(tf.notes)}
    structure = meas
    if args.method == "sdm" or fit_plot_path is not None:
        fit = fit_modal(meas, args.fit_modes)
        info["fit"] = fit.to_json()
        info["fit_summary"] = fit.summary()
        if fit_plot_path is not None:
            from robolobes.core.io import provenance

            with user_path_errors(fit_plot_path):
                plot_fit(fit, fit_plot_path, title=f"{args.frf}: " + ("credible fit" if fit.credible else
                                                                       "fit NOT CREDIBLE"),
                         provenance=provenance(prov_inputs))
        if args.method == "sdm":
            if not fit.credible:
                raise LobeError(f"{args.frf}: the modal fit is not credible ({'; '.join(fit.problems)}); the SDM needs "
                                "a credible fit: try --fit-modes N, or --method zoa (it uses the FRF itself)")
            structure = fit.structure
    label = f"measured FRF {args.frf}" + (" (modal fit)" if structure is not meas else "")
    problem, label = _user_problem(args, structure, label)
    return problem, label, info


def _robot_problem(args) -> tuple[LobeProblem, str]:
    from robolobes import linearize
    from robolobes.linearize.cli import resolve_pose

    from .tooltip import tool_from_files, with_tool

    tool_set = tool_from_files(args.tool_modes, args.tool_frf, args.tool_frf_axes)
    case, robot, theta, label = resolve_pose(args)
    lin = linearize.linearize(robot, theta)
    if tool_set is not None:
        robot = with_tool(robot, tool_set.in_tcp_frame(lin.R_tcp, case.cut.feed_direction))
        lin = linearize.linearize(robot, theta)
        label += f", tool {tool_set.source}: {len(tool_set.oscillators)} TCP oscillator(s) in the robot's M, C, K"
        for note in tool_set.notes:
            print(note, file=sys.stderr)
    structure = PhysicalStructure.from_linear(lin, case.cut.feed_direction)
    tool, law, cut = case.tool, case.law, case.cut
    over = {}
    if args.ae_mm is not None:
        over["ae_m"] = args.ae_mm * 1e-3
    if args.milling_mode is not None:
        over["mode"] = args.milling_mode
    if args.at_rpm is not None:
        over["spindle_rpm"] = args.at_rpm
    if args.at_depth_mm is not None:
        over["ap_m"] = args.at_depth_mm * 1e-3
    try:
        cut = replace(cut, **over)
    except MillingError as e:
        raise LobeError(str(e)) from None
    return LobeProblem(structure, tool, cut, law), f"{case.name}, {robot.variant} variant, {label}"


def _basis(args, problem: LobeProblem, speeds: np.ndarray, has_op: bool) -> tuple[LobeProblem, dict]:
    """The problem on the reduced modal basis if ``--reduced-basis`` (and the basis record for the
    JSON): band from the highest speed solved, loop stiffness at the deepest depth searched."""
    if not args.reduced_basis:
        return problem, {"kind": "full", "reason": "default (no --reduced-basis)"}
    from .basis import basis_for

    if not hasattr(problem.structure, "state_space"):
        raise LobeError("--reduced-basis needs a structure with modes (robot, --modal, or --frf with --method sdm)")
    depth = args.depth_max_mm * 1e-3
    rpm = speeds
    if has_op:
        depth = max(depth, 4 * problem.cut.ap_m)  # the operating point's search depth (run below)
        rpm = np.append(speeds, problem.cut.spindle_rpm)
    try:
        red = basis_for(problem, rpm, depth)
    except LobeError as e:  # no well-conditioned modal form: the full model, said so
        return problem, {"kind": "full", "reason": str(e)}
    info = red.basis.to_json()
    if red.basis.kind == "full":
        return problem, {**info, "reason": "the rule keeps every mode the reduction could save"}
    return replace(problem, structure=red), info


def _method(args):
    if args.method == "zoa":
        return ZeroOrder()
    m = RefinedSDM().m if args.m is None else args.m
    if not 2 <= m <= MAX_M:
        raise LobeError(f"--m must be an integer from 2 to {MAX_M} (steps per principal period), got {m}")
    pre = RefinedSDM().base.prescan_m  # the library default's coarser prescan, where it is coarser
    sdm = SemiDiscretization(m=m, scheme=args.scheme or "sdm", prescan_m=pre if pre is not None and pre < m else None)
    if args.no_refine:
        if args.tol_pct is not None:
            raise LobeError("--tol-pct has no effect with --no-refine (one level, no error estimate)")
        return sdm
    tol = 1.0 if args.tol_pct is None else args.tol_pct
    if not (math.isfinite(tol) and TOL_PCT_RANGE[0] <= tol <= TOL_PCT_RANGE[1]):
        raise LobeError(f"--tol-pct must be from {TOL_PCT_RANGE[0]:g} to {TOL_PCT_RANGE[1]:g} (% of the limit), "
                        f"got {tol:g}")
    return RefinedSDM(sdm, tol=tol / 100.0, m_max=max(M_MAX_REFINE, 2 * m))


def _check_flags(args) -> None:
    """Refuse options that would have no effect in the chosen mode (a user would think they did)."""
    if args.modal is not None and args.frf is not None:
        raise LobeError("give either --modal FILE.toml or --frf FILE|DIR, not both")
    if args.frf is None:
        given = [flag for flag, k in _FRF_ONLY.items() if getattr(args, k) is not None]
        if given:
            raise LobeError(f"{given[0]} applies only with --frf FILE|DIR")
    elif args.frf_axes is None:
        raise LobeError("--frf needs --frf-axes=FEED,NORMAL: which measured axis lies along the feed and which along "
                        "the cut normal (e.g. --frf-axes=x,y)")
    if args.fit_modes is not None and not 1 <= args.fit_modes <= 20:
        raise LobeError(f"--fit-modes must be an integer from 1 to 20, got {args.fit_modes}")
    if args.modal is None and args.frf is None:
        given = [flag for flag, k in _MODAL_ONLY.items() if getattr(args, k) is not None]
        if given:
            raise LobeError(f"{given[0]} applies only with --modal FILE.toml or --frf (the robot's tool and material "
                            "come from --case)")
        args.case = args.case or DEFAULT_CASE
        args.variant = args.variant or "basic"
    else:
        given = [flag for flag, k in _ROBOT_ONLY.items() if getattr(args, k) is not None]
        if given:
            raise LobeError(f"{given[0]} selects the robot and has no effect with --modal FILE.toml or --frf")
    if args.method == "zoa":
        given = [flag for flag, v in (("--m", args.m), ("--scheme", args.scheme), ("--tol-pct", args.tol_pct),
                                      ("--no-refine", args.no_refine or None),
                                      ("--reduced-basis", args.reduced_basis or None)) if v is not None]
        if given:
            raise LobeError(f"{given[0]} applies only to --method sdm, not to zoa")


def _inputs(args) -> dict:
    """The run's inputs for provenance: options, and the case or the modal file's content."""
    if args.modal is not None:
        return cli_inputs(args, files={"modal": args.modal})
    if args.frf is not None:
        from robolobes.linearize.frf_io import tool_frf_files

        return cli_inputs(args, files={f"frf:{f.name}": f for f in tool_frf_files(Path(args.frf))})
    files = {}
    if args.tool_modes is not None:
        files["tool_modes"] = args.tool_modes
    if args.tool_frf is not None:
        from robolobes.linearize.frf_io import tool_frf_files

        files.update({f"tool_frf:{f.name}": f for f in tool_frf_files(Path(args.tool_frf))})
    return cli_inputs(args, case=load_case(args.case), files=files or None)


def _checked(args: argparse.Namespace):
    """``lobes``' checks of the options and output files before any work.
    Returns ``(method, inputs, out_path, fit_path)``."""
    user = args.modal is not None or args.frf is not None
    if (args.at_rpm is None) != (args.at_depth_mm is None) and user:
        raise LobeError("give both --at-rpm and --at-depth-mm for an operating point")
    for name in ("rpm_min", "rpm_max", "depth_max_mm"):
        v = getattr(args, name)
        if not (math.isfinite(v) and v > 0):
            raise LobeError(f"--{name.replace('_', '-')} must be finite and > 0, got {v}")
    if args.rpm_max < args.rpm_min:
        raise LobeError(f"--rpm-max ({args.rpm_max}) must be >= --rpm-min ({args.rpm_min})")
    if not 1 <= args.n_rpm <= MAX_N_RPM:
        raise LobeError(f"--n-rpm must be from 1 to {MAX_N_RPM} speeds, got {args.n_rpm}")
    if args.at_rpm is not None and not (math.isfinite(args.at_rpm) and args.at_rpm > 0):
        raise LobeError(f"--at-rpm must be a speed > 0 rpm, got {args.at_rpm}")
    if args.at_depth_mm is not None and not (math.isfinite(args.at_depth_mm) and args.at_depth_mm > 0):
        raise LobeError(f"--at-depth-mm must be a depth > 0 mm, got {args.at_depth_mm}")
    _check_flags(args)
    method = _method(args)
    inputs = _inputs(args)
    out_path = check_output_file(args.out, _FIGURE_SUFFIXES, inputs) if args.out else None
    fit_path = check_output_file(args.fit_plot, _FIGURE_SUFFIXES, inputs, name="--fit-plot") if args.fit_plot else None
    return method, inputs, out_path, fit_path


def validate_lobes(args: argparse.Namespace) -> None:
    """Every check ``lobes`` makes before any work (ROBOLOBES_VALIDATE_ONLY): options, output
    files, and the structure's inputs read and checked (case and pose, modal file, measured FRF,
    tool modes); a measured FRF is read but not fitted."""
    _checked(args)
    if args.frf is not None:
        from robolobes.linearize.frf_io import read_tool_frf

        from .measured import MeasuredStructure

        _check_tool_flags(args)
        tf = read_tool_frf(args.frf, args.frf_axes)
        _user_problem(args, MeasuredStructure(tf.frf.omega, tf.frf.H, cross_measured=tf.cross_measured,
                                              source=str(args.frf)), "")
    elif args.modal is not None:
        _modal_problem(args)
    else:
        _robot_problem(args)


def run(args: argparse.Namespace) -> int:
    """Run ``robolobes lobes``; returns the exit code (0). Bad input raises ValueError."""
    method, inputs, out_path, fit_path = _checked(args)
    frf_info = None
    if args.frf is not None:
        problem, label, frf_info = _frf_problem(args, fit_path, inputs)
        has_op = args.at_rpm is not None
    elif args.modal is not None:
        problem, label = _modal_problem(args)
        has_op = args.at_rpm is not None
    else:
        problem, label = _robot_problem(args)
        has_op = True  # the case's own cut, or --at-*
    speeds = np.linspace(args.rpm_min, args.rpm_max, args.n_rpm)
    problem, basis = _basis(args, problem, speeds, has_op)

    with Progress(f"lobes {method.name}", enabled=not args.quiet) as bar:
        result = solve(problem, method, speeds, depth_max_m=args.depth_max_mm * 1e-3,
                       progress=lambda done, total: bar(0.9 * done / total, "speeds"))
        op = None
        if has_op:
            bar(0.9, "operating point")
            op = stability(problem, method, depth_max_m=max(args.depth_max_mm * 1e-3, 4 * problem.cut.ap_m))
        bar.done()
    prov = provenance(inputs)
    if out_path is not None:
        from .plot import plot_lobes

        with user_path_errors(out_path):
            plot_lobes(result, out_path, op, title=label, provenance=prov)
    if args.json:
        assert result.status is not None and result.m_final is not None  # set in LobeResult.__post_init__
        out = {
            "structure": label,
            "method": method.name,
            "m": getattr(method, "m", None),
            "tol": getattr(method, "tol", None),  # target relative error estimate (refined SDM)
            "m_max": getattr(method, "m_max", None),
            "depth_max_m": args.depth_max_mm * 1e-3,
            "rpm": result.spindle_rpm,
            "depth_limit_m": result.depth_limit_m,  # null: stable up to depth_max_m
            "depth_error_m": result.depth_error_m,  # estimate (lobes.refine); null: none
            "status": result.status.tolist(),  # converged / unconverged / no-estimate
            "m_final": result.m_final.tolist(),
            "chatter_freq_hz": result.chatter_freq_hz,
            "bifurcation": result.bifurcation.tolist(),
            "stats": {k: v for k, v in result.stats.items() if isinstance(v, (int, float, str))},
            "basis": basis,  # which modal basis the SDM used (lobes.basis.BasisInfo, or "full")
            "provenance": prov,
        }
        if frf_info is not None:
            out["frf"] = frf_info
        if op is not None:
            out["operating_point"] = {
                "rpm": op.spindle_rpm, "depth_m": op.depth_m, "spectral_radius": op.spectral_radius,
                **op.verdict.to_json(), "margin": op.margin,
                "margin_error": op.margin_error, "depth_limit_m": op.depth_limit_m,
                "depth_limit_error_m": op.depth_limit_error_m, "limit_status": op.limit_status,
                "chatter_freq_hz": op.chatter_freq_hz, "bifurcation": op.bifurcation,
            }
        print(json.dumps(to_jsonable(out), indent=1))
    else:
        if frf_info is not None:
            print(f"{args.frf}: {frf_info['lines']} lines {frf_info['band_hz'][0]:g}-{frf_info['band_hz'][1]:g} Hz, "
                  f"axes (feed, normal) = ({args.frf_axes})" + "".join(f"; {n}" for n in frf_info["notes"]))
            if "fit_summary" in frf_info:
                print(frf_info["fit_summary"])
        j = int(np.argmin(result.depth_limit_m))
        print(f"{label}: {method.name}, {len(speeds)} speeds {args.rpm_min:g}-{args.rpm_max:g} rpm, "
              f"{result.stats['wall_s']:.2f} s")
        if np.isfinite(result.depth_limit_m[j]):
            print(f"lowest limit {result.depth_limit_m[j] * 1e3:.4g} mm at {result.spindle_rpm[j]:.6g} rpm "
                  f"({result.bifurcation[j]}, chatter {result.chatter_freq_hz[j]:.5g} Hz)")
        else:
            print(f"stable at every speed up to {args.depth_max_mm:g} mm")
        if basis["kind"] == "reduced":
            print(f"reduced modal basis: {basis['n_states']} of {basis['n_states_full']} states "
                  f"({basis['n_kept']} of {basis['n_modes']} modes + {basis['n_residual']} residual block(s)), "
                  f"loop perturbation {basis['max_loop_error']:.1e} in 0-{basis['band_hz']:.0f} Hz")
        elif args.reduced_basis:
            print(f"reduced modal basis: not used, the full model ({basis['reason']})")
        if isinstance(method, RefinedSDM):
            nu = int((result.status == "unconverged").sum())
            print(f"error estimate <= {100 * method.tol:g} % at {len(speeds) - nu} / {len(speeds)} speeds "
                  f"(levels m = {'/'.join(str(x) for x in result.stats['m_levels'])})"
                  + (f"; {nu} speeds unconverged at m = {method.m_max}" if nu else ""))
        if isinstance(method, ZeroOrder):
            print("no error estimate: the zero-order approximation keeps only the time average of the cutting "
                  "force; its distance to the limits of --method sdm is not estimated")
        if op is not None:
            err = "no error estimate" if math.isnan(op.margin_error) else f"+-{op.margin_error:.2g}"
            mu = "" if math.isnan(op.spectral_radius) else f", |mu| = {op.spectral_radius:.7f}"
            print(f"operating point {op.spindle_rpm:.6g} rpm, {op.depth_m * 1e3:.4g} mm: {op.verdict.status}, "
                  f"margin {op.margin:+.4g} ({err}){mu}, {op.bifurcation}, chatter {op.chatter_freq_hz:.5g} Hz")
            print(f"  verdict: {op.verdict.reason}")
    return 0
