"""``robolobes identify``: fit the model to measured data (``robolobes study`` is in :mod:`robolobes.study.cli`)."""

from __future__ import annotations

import sys

from robolobes.core.io import Progress

__all__ = ["register", "run_identify_cli"]


def register(sub) -> None:
    _register_identify(sub)


# ------------------------------------------------------------------------------------------------
# robolobes identify


def _measured_files(path) -> dict:
    """Every file of the measurement set, for provenance (recorded by content)."""
    from pathlib import Path

    p = Path(path)
    files = [p] if p.is_file() else sorted(x for x in p.iterdir() if x.is_file())
    return {x.name: x for x in files}


def _write_report(out, result, measurement, state):
    from .effects import REGISTRY
    from .frf import prepare
    from .report import write_frf_report

    poses = prepare(measurement, state)
    effects = [(REGISTRY[e.name], e.params) for e in result.effects]
    with out:
        write_frf_report(out.path, result, poses, effects, out.provenance, model=state,
                         theta=measurement.poses[0].theta)


#: measurement kinds whose numbers depend on the material (the cutting-force coefficients differ
#: ~5x between the built-in cases): their case is never assumed
_MATERIAL_KINDS = ("forces", "force_stats", "stability")


def check_measurement(measurement, state, case_given: bool) -> None:
    """The checks every command makes on its inputs, before any work (BadInput, one line).

    Joint angles inside the model's ranges (``linearize.check_limits``, the 5 deg tolerance of the
    case loader) for FRF poses and stability rows given by angles; a force-side set names its case
    (in its files or with ``--case``): its forces scale with the material's coefficients; a force
    series lies inside the case's pass and is not zero everywhere."""
    import warnings

    import numpy as np

    from robolobes.core.errors import BadInput
    from robolobes.linearize import check_limits
    from robolobes.linearize.kinematics import JointLimitWarning

    if measurement.kind in _MATERIAL_KINDS and not case_given and getattr(measurement, "case", None) is None:
        raise BadInput(f"--measured {measurement.path}: names no case (the material sets the cutting forces); "
                       "add case = \"tx200-aluminium\" (or another case) to the file, or pass --case")
    if measurement.kind == "forces":
        from .forces import check_window

        check_window(measurement.path / "cut.toml", measurement.window_s, state.case)
        if not np.any(measurement.force_n):
            raise BadInput(f"{measurement.path / 'forces.csv'}: every force sample in window_s is zero: no cut was "
                           "measured (an empty channel?)")
    robot = state.case.robot
    if measurement.kind == "frf":
        angles = [(f"pose {p.pose} of {measurement.path}/poses.csv", p.theta) for p in measurement.poses]
    elif measurement.kind == "stability":
        angles = [(f"{measurement.path} row {k + 2}", np.asarray(r.q_rad)) for k, r in enumerate(measurement.rows)
                  if r.q_rad is not None]
    else:
        angles = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", JointLimitWarning)   # within the tolerance: accepted, as the case loader does
        for where, q in angles:
            try:
                check_limits(robot, q)
            except BadInput as e:
                raise BadInput(f"{where}: {e}") from None


def _prepare(args):
    """Every check before any work: ``(problem, method, prov, report)``."""
    from robolobes.core.io import provenance
    from robolobes.core.outdir import OutputDir, cli_inputs, user_path_errors

    from .api import model_state, read_measurement
    from .problem import IdentifyProblem

    with user_path_errors(args.measured, "read"):  # pyuff wraps OSError and Ctrl-C in a bare Exception
        measurement = read_measurement(args.measured)
    method = _method(args, measurement)
    state, notes = model_state(measurement, args.case, args.variant)
    check_measurement(measurement, state, args.case is not None)
    for n in notes:
        print(f"robolobes identify: note: {n}", file=sys.stderr)
    state.robot()  # builds the model: bad [[elements]] fail here, before any work
    effects = None
    if args.effects:  # names -> the library's Effect objects (BadInput for a name the kind does not observe)
        from .effects import effects_for
        effects = effects_for(measurement.kind, state, [x.strip() for x in args.effects.split(",") if x.strip()])
    problem = IdentifyProblem(measurement, state, effects=effects)
    inputs = cli_inputs(args, case=state.case, files=_measured_files(measurement.path),
                        drop=("run", "quiet", "json", "report", "validate"))
    report = OutputDir(args.report, "identify", inputs, name="--report") if args.report else None
    return problem, method, provenance(inputs), report


#: The command line's --alpha default (the methods that use a significance level default to it too).
ALPHA_DEFAULT = 0.01


def _method(args, measurement):
    """The measurement kind's method from the flags: ``--alpha`` other than its default is refused
    where the method has no significance level (force statistics, stability observations)."""
    from robolobes.core.errors import BadInput

    from .api import default_method

    fields: dict = {"max_effects": args.max_effects}
    if measurement.kind in ("frf", "forces"):
        fields["alpha"] = args.alpha
    elif args.alpha != ALPHA_DEFAULT:
        raise BadInput(f"--alpha {args.alpha:g}: not used with {measurement.kind} measurements (no significance "
                       f"test: {'chosen by AICc' if measurement.kind == 'force_stats' else 'the fewest disagreeing observations'}); drop --alpha")
    if measurement.kind == "frf":
        fields["poles"] = not args.no_poles
    return default_method(measurement, **fields)


def validate_identify(args) -> None:
    """The checks of :func:`run_identify_cli` before any work (ROBOLOBES_VALIDATE_ONLY)."""
    _prepare(args)


def run_identify_cli(args) -> int:
    import json

    from robolobes.core.io import to_jsonable

    from .api import identify

    problem, method, prov, report = _prepare(args)
    measurement, state = problem.measurement, problem.model
    bar = Progress("identify", enabled=not args.quiet)
    steps = [0]

    def progress(msg):
        steps[0] += 1
        bar(min(0.99, 1 - 1 / (1 + 0.02 * steps[0])), msg)

    result = identify(problem, method, progress=progress)
    bar.done()
    out = {**result.to_json(), "provenance": prov}
    if report is not None and result.kind == "frf":
        _write_report(report, result, measurement, state)
    elif report is not None:
        from .report import write_report
        with report:
            assert report.path is not None  # set on entering the output directory
            write_report(report.path, result, report.provenance, teeth=state.case.tool.teeth)
    if args.json:
        print(json.dumps(to_jsonable(out), indent=2))
        return 0
    print(f"{result.kind} set {measurement.path}: {len(result.effects)} effect(s); held-out error "
          f"{result.error_before:.4g} -> {result.error_after:.4g} (noise floor {result.noise_floor:.3g})")
    u = result.unexplained or {}
    if u:
        print(f"residual {'UNEXPLAINED' if u['unexplained'] else 'within the noise'}: "
              f"{u.get('statistic_meaning', 'held-out error over the noise floor')} {u.get('statistic', 0.0):.3g} "
              f"(margin {u['margin']:.3g}); held-out error {u['ratio_to_noise_floor']:.3g}x the noise floor")
    for e in result.effects:
        ps = ", ".join(f"{k} = {v:.5g} +- {e.uncertainty.get(k, float('nan')):.2g}" for k, v in e.params.items())
        label = "not credible" if not e.credible else "surrogate" if e.surrogate else "identified"
        print(f"  {e.name} ({label}): {ps}")
    print(f"metric: {result.metric}")
    if report is not None:
        print(f"report: {report.target}/report.md")
    return 0


def _register_identify(sub) -> None:
    p = sub.add_parser("identify", help="fit the model to measured data: find the missing effect, report the error "
                                        "before and after",
                       description="Reads a measurement set (tool-tip FRFs: poses.csv + <pose>.uff|.unv|.csv), "
                                   "finds the effects the model lacks by held-out error, and prints them with "
                                   "the updated model.")
    p.add_argument("--measured", required=True, help="the measurement set's directory or one of its files")
    p.add_argument("--case", default=None, help="case name or TOML (overrides the case named in the files)")
    p.add_argument("--variant", default=None, help="model variant: basic (default), gravity, orthogonal, backlash")
    p.add_argument("--alpha", type=float, default=ALPHA_DEFAULT,
                   help="family-wise false-positive rate of the selection over the library (default 0.01)")
    p.add_argument("--max-effects", type=int, default=3, help="at most this many effects (default 3)")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument("--report", default=None, help="write report.md and figures into this directory (never "
                                                    "replaces a user's files)")
    p.add_argument("--effects", default=None,
                   help="comma-separated candidate effects (default: the library's default candidates; "
                        "e.g. --effects servo_a2,joint_correction_a2)")
    p.add_argument("--no-poles", action="store_true",
                   help="skip the modal fit (LSCF/LSFD) of the measurement (FRF sets; saves a few s per pose)")
    p.add_argument("--quiet", action="store_true", help="no progress display")
    p.set_defaults(run=run_identify_cli, validate=validate_identify)
