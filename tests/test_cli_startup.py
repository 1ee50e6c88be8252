"""The command line imports only what the subcommand it runs needs.

* ``robolobes --help`` and ``robolobes lobes --help`` import none of the engines' heavy
  dependencies (pinocchio, numba, scipy, matplotlib, python-control);
* every subcommand listed by the top-level help has the same help line as its full parser.
"""

import argparse
import importlib
import subprocess
import sys

import pytest

from robolobes.main import _COMMANDS

HEAVY = ("pinocchio", "numba", "scipy", "matplotlib", "control", "dask")


def _loaded_after(argv):
    code = ("import sys\nfrom robolobes.main import main\ntry:\n    main(sys.argv[1:])\nexcept SystemExit:\n    pass\n"
            f"print('LOADED:' + ','.join(m for m in {HEAVY!r} if m in sys.modules))")
    r = subprocess.run([sys.executable, "-c", code, *argv], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]
    return r.stdout.strip().splitlines()[-1].removeprefix("LOADED:")


@pytest.mark.parametrize("argv", [["--help"], ["lobes", "--help"], ["modes", "--help"]])
def test_help_imports_no_engine(argv):
    assert _loaded_after(argv) == ""


def test_listed_help_lines_match_the_full_parsers():
    p = argparse.ArgumentParser()
    sub = p.add_subparsers()
    for module in dict.fromkeys(m for m, _ in _COMMANDS.values()):
        importlib.import_module(module).register(sub)
    full = {a.dest: a.help for a in sub._choices_actions}
    assert full == {c: h for c, (_, h) in _COMMANDS.items()}
