"""The ``robolobes`` command line: one entry point, one subcommand per job.

Each package owns its subcommands (``register(subparsers)`` and ``run(args)`` in its ``cli``
module); this module only dispatches, importing the one CLI module of the subcommand it runs.

    robolobes study     the main job: aluminium vs steel on the TX200, report + numbers
    robolobes modes     modes and TCP stiffness at a pose
    robolobes frf       tool-tip FRF at a pose (CSV or UFF58, and a Bode plot)
    robolobes lobes     stability lobe diagram
    robolobes simulate  time-domain simulation of a pass
    robolobes identify  fit the model to measured data (FRFs, forces)
    robolobes export-urdf  a robot as a URDF plus the TOML of what the URDF lacks
"""

from __future__ import annotations

import argparse
import importlib
import os
import re
import signal
import sys
import threading
import warnings

# The work is many small matrices (18 x 18 robots, 2 x 2 cut planes): multi-threaded BLAS only
# adds overhead, and two processes each spinning threads on a 2-core machine slow down ~10x.
# Set before numpy is imported; a user's explicit setting wins.
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

# subcommand -> (module that registers it, one-line help). Only the module of the subcommand being
# run is imported: ``robolobes --help`` imports nothing, ``robolobes lobes ...`` only the lobes CLI.
_COMMANDS = {
    "study": ("robolobes.study.cli", "the main job: why aluminium is stable and steel is not (TX200)"),
    "modes": ("robolobes.linearize.cli", "modes and TCP stiffness at a pose"),
    "frf": ("robolobes.linearize.cli", "tool-tip FRF at a pose (CSV or UFF58 + Bode PNG)"),
    "lobes": ("robolobes.lobes.cli", "stability lobe diagram (semi-discretization or zero-order)"),
    "simulate": ("robolobes.timedomain.cli", "time-domain simulation of a milling pass"),
    "identify": ("robolobes.identify.cli", "fit the model to measured data: find the missing effect, report the error before and after"),
    "map": ("robolobes.workspace.cli", "lobe maps across the workspace"),
    "optimize": ("robolobes.workspace.cli", "placement and tool rotation that maximize the minimum stable depth over the pass"),
    "export-urdf": ("robolobes.linearize.export_cli", "write a robot as a URDF plus the TOML of what the URDF lacks"),
}


def _chosen_command(argv: list[str]) -> str | None:
    """The subcommand named in ``argv`` (the first argument that is not an option), or None."""
    for a in argv:
        if not a.startswith("-"):
            return a if a in _COMMANDS else None
    return None


def build_parser(argv: list[str] | None = None) -> argparse.ArgumentParser:
    """The ``robolobes`` parser. Full subparsers for the subcommand named in ``argv`` (every
    subcommand when ``argv`` is None); the others are listed with their help line only."""
    parser = argparse.ArgumentParser(prog="robolobes", description="Dynamics of robotic milling.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    chosen = None if argv is None else _chosen_command(argv)
    modules = dict.fromkeys(m for c, (m, _) in _COMMANDS.items() if argv is None or c == chosen)
    registered = set(sub.choices)
    for module in modules:
        importlib.import_module(module).register(sub)
        registered = set(sub.choices)
    for command, (_, help_line) in _COMMANDS.items():
        if command not in registered:
            sub.add_parser(command, help=help_line)
    return parser


# a value such as -200,200 or -10,20,30 (numbers, the first negative): argparse takes it for an option
_NEGATIVE_LIST = re.compile(r"^-\d*\.?\d+(?:[eE][-+]?\d+)?(?:,\s*[-+]?\d*\.?\d+(?:[eE][-+]?\d+)?)+$")


def join_negative_values(argv: list[str]) -> list[str]:
    """``["--x-range-mm", "-200,200"]`` -> ``["--x-range-mm=-200,200"]``: a comma list of numbers that
    starts with a minus is a value, never an option, so it is joined to the option before it."""
    out: list[str] = []
    for tok in argv:
        if out and out[-1].startswith("--") and "=" not in out[-1] and _NEGATIVE_LIST.match(tok):
            out[-1] = f"{out[-1]}={tok}"
        else:
            out.append(tok)
    return out


#: environment switch: parse and validate the command line (every check made before any work),
#: then stop with exit code 0 (used by the test of every documented command line)
VALIDATE_ONLY = "ROBOLOBES_VALIDATE_ONLY"


def _validate_only(args) -> int:
    """Run the subcommand's ``validate(args)`` (registered with ``set_defaults``) if it has one."""
    check = getattr(args, "validate", None)
    if check is not None:
        check(args)
    print(f"robolobes {args.command}: {'inputs valid' if check else 'command line parsed'} ({VALIDATE_ONLY})",
          file=sys.stderr)
    return 0


def _format_warning(message, category, filename, lineno, line=None):
    return f"robolobes: warning: {message}\n"


def _error(command: str, message) -> None:
    print(f"robolobes {command}: error: {message}", file=sys.stderr)


#: the signal that :func:`_early_interrupt` took during this call of :func:`main` (empty: none)
_early_signal: list[int] = []


def _early_interrupt(signum, frame) -> None:
    """SIGINT / SIGTERM during start-up (numpy and the subcommand's modules are being imported,
    before :func:`robolobes.core.interrupt.handling` is installed): the first one interrupts,
    later ones are ignored, so start-up ends in the same one line as the work would."""
    for s in (signal.SIGINT, signal.SIGTERM):
        signal.signal(s, signal.SIG_IGN)
    _early_signal.append(signum)
    raise KeyboardInterrupt(128 + signum)


def _forget_caught_interrupt() -> None:
    """Clear CPython's "unhandled KeyboardInterrupt" mark after :func:`main` has caught it.

    CPython (3.8 to at least 3.13) sets that process-wide mark whenever a KeyboardInterrupt leaves code
    run by ``exec`` / ``eval`` of a string, even if a caller then catches it; dataclasses, namedtuple
    and enum create their methods that way while numpy, scipy and robolobes are imported, so a
    Ctrl-C during the imports lands there about one time in eight. Under ``python -m robolobes``
    (not a script or the console entry point) the interpreter then kills itself with SIGINT at exit
    (status -2 instead of 130) after the one line was printed. Every ``exec`` of a string resets the
    mark first, so an empty one clears it; an interruption that is really left unhandled sets it
    again on its way out."""
    exec("")  # resets the mark: the documented entry of string code, nothing is run


def main(argv: list[str] | None = None) -> int:
    """Run one subcommand; returns the exit code; a signal during start-up ends it the same way.

    Exit codes: 0 done; 2 bad input (:class:`~robolobes.core.errors.BadInput`, one line on stderr,
    raised before any work; the CLIs turn OSErrors on a user's paths into it); 130 Ctrl-C (SIGINT),
    143 SIGTERM (one line, however many signals follow); 1 out of memory (one line). Any other
    exception is an internal error and keeps its traceback.

    The lobes of a two-mode model (a hammer test's modes in a TOML file), five speeds, as JSON:

    >>> import contextlib, io, json, pathlib, tempfile
    >>> modes = pathlib.Path(tempfile.mkdtemp()) / "modes.toml"
    >>> _ = modes.write_text("".join(f"[[modes]]\\nfreq_hz = 922\\ndamping_ratio = 0.011\\nstiffness_n_per_m = 1.34e6\\n"
    ...                              f"direction = {d}\\n" for d in ("[1, 0]", "[0, 1]")))
    >>> out = io.StringIO()
    >>> with contextlib.redirect_stdout(out):
    ...     code = main(["lobes", "--modal", str(modes), "--teeth", "2", "--diameter-mm", "10", "--ae-mm", "0.5",
    ...                  "--down", "--ktc-mpa", "600", "--krc-mpa", "200", "--n-rpm", "5", "--json", "--quiet"])
    >>> code, json.loads(out.getvalue())["rpm"]
    (0, [2000.0, 7750.0, 13500.0, 19250.0, 25000.0])
    """
    _early_signal.clear()
    in_main_thread = threading.current_thread() is threading.main_thread()
    old = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)} if in_main_thread else {}
    for s in old:
        signal.signal(s, _early_interrupt)
    try:
        from robolobes.core import interrupt   # imports numpy: seconds on a busy machine

        argv = join_negative_values(sys.argv[1:] if argv is None else list(argv))
        args = build_parser(argv).parse_args(argv)
        if _early_signal:                      # taken, but a library's bare ``except:`` swallowed it
            raise KeyboardInterrupt(128 + _early_signal[0])
        return _run(args, interrupt)           # replaces the early handler while it runs
    except KeyboardInterrupt as e:             # raised by _early_interrupt, before the work
        print("\nrobolobes: interrupted", file=sys.stderr)
        return e.args[0] if e.args and isinstance(e.args[0], int) else 130
    except Exception:
        if not _early_signal:                  # an error of its own: internal, keeps its traceback
            raise
        # a library that reports the interruption of its import as its own error (numpy's C import
        # raises ImportError "PyCapsule_Import could not import module"): the signal ends it all the same
        print("\nrobolobes: interrupted", file=sys.stderr)
        return 128 + _early_signal[0]
    finally:
        for s, h in old.items():
            if signal.getsignal(s) is _early_interrupt:
                signal.signal(s, h)
        _forget_caught_interrupt()             # see there: else ``python -m`` may die by SIGINT at exit


def _run(args, interrupt) -> int:
    """Run the parsed subcommand inside :func:`robolobes.core.interrupt.handling` (see :func:`main`)."""
    from robolobes.core.errors import BadInput
    from robolobes.core.warnonce import each_warning_once

    warnings.formatwarning = _format_warning  # users see one plain line, not a source location
    # SIGINT / SIGTERM: the first interrupts, later ones wait for the clean-up (core.interrupt)
    with interrupt.handling():
        try:
            if os.environ.get(VALIDATE_ONLY) == "1":
                return _validate_only(args)
            with each_warning_once():  # the same warning reached from several steps is shown once
                return int(args.run(args) or 0)
        except KeyboardInterrupt:
            print("\nrobolobes: interrupted", file=sys.stderr)
            return interrupt.exit_code()
        except MemoryError:
            _error(args.command, "out of memory: reduce the grid sizes (--n, --m, --n-rpm) or the simulated duration")
            return 1
        except BadInput as e:  # only bad input; any other error is internal and keeps its traceback
            _error(args.command, e)
            return 2


if __name__ == "__main__":
    sys.exit(main())
