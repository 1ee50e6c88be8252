"""Ctrl-C or SIGTERM during start-up (numpy and the subcommand's modules being imported, which
takes seconds on a busy machine) ends in the same one line and exit code as during the work.

The moment is made exact: the child process sends the signals to itself from inside the import of
the subcommand's module (``importlib.import_module``, which ``robolobes.main.build_parser`` calls),
exactly as many as each test states, before any handler of ``robolobes.core.interrupt`` exists.
"""

import os
import subprocess
import sys
import textwrap

import pytest

CHILD = textwrap.dedent("""
    import importlib, os, signal, sys, time
    real = importlib.import_module
    def import_module(name, *a, **k):
        if name.startswith("robolobes.") and name.endswith(".cli"):
            for _ in range({n}):
                os.kill(os.getpid(), signal.{sig})
                time.sleep(0.05)
        return real(name, *a, **k)
    importlib.import_module = import_module
    from robolobes.main import main
    sys.argv = ["robolobes", "map", "--over", "pass", "--n", "2", "--out", "m"]
    sys.exit(main())
""")


@pytest.mark.parametrize("sig,n,rc", [("SIGINT", 1, 130), ("SIGINT", 3, 130), ("SIGTERM", 1, 143)])
def test_signal_during_start_up_is_one_line(tmp_path, sig, n, rc):
    res = subprocess.run([sys.executable, "-c", CHILD.format(n=n, sig=sig)], cwd=tmp_path, capture_output=True,
                         text=True, timeout=300)
    assert res.returncode == rc, res.stderr
    assert [ln for ln in res.stderr.splitlines() if ln.strip()] == ["robolobes: interrupted"], res.stderr
    assert list(tmp_path.iterdir()) == []            # nothing written


# ``python -m robolobes``, with the signal landing while code compiled from a string runs: dataclasses,
# namedtuple and enum create their methods with exec() of a string, so a Ctrl-C during the imports lands
# there about one time in eight. CPython then marks the KeyboardInterrupt as unhandled even though main()
# catches it, and under ``-m`` (not a script or the console entry point) kills itself with SIGINT at exit
# (status -2, for a SIGTERM too) after the one line was printed. The second case is a library that reports the interruption
# of its import as its own ImportError, as numpy's C import does ("PyCapsule_Import could not import module");
# the third a bare ``except:`` that swallows the KeyboardInterrupt and goes on (the run went on to exit 0).
RUN_AS_MODULE = textwrap.dedent("""
    import importlib, os, runpy, signal, sys, time
    real = importlib.import_module
    def import_module(name, *a, **k):
        if name.startswith("robolobes.") and name.endswith(".cli"):
            exec("for _ in range({n}):\\n    os.kill(os.getpid(), signal.{sig})\\n    time.sleep(0.05)\\n",
                 dict(os=os, signal=signal, time=time))
        return real(name, *a, **k)
    def import_module_as_numpy(name, *a, **k):
        try:
            return import_module(name, *a, **k)
        except KeyboardInterrupt:
            raise ImportError("PyCapsule_Import could not import module") from None
    def import_module_swallowing(name, *a, **k):
        try:
            return import_module(name, *a, **k)
        except BaseException:          # a library's bare except: the import goes on
            return real(name, *a, **k)
    importlib.import_module = {hook}
    sys.argv = ["robolobes", "map", "--over", "pass", "--n", "2", "--out", "m"]
    runpy.run_module("robolobes", run_name="__main__", alter_sys=True)
""")


@pytest.mark.parametrize("sig,n,rc", [("SIGINT", 1, 130), ("SIGINT", 2, 130), ("SIGTERM", 1, 143)])
@pytest.mark.parametrize("hook", ["import_module", "import_module_as_numpy", "import_module_swallowing"])
def test_signal_inside_exec_of_a_string_under_python_m(tmp_path, sig, n, rc, hook):
    (tmp_path / "child").mkdir()
    (tmp_path / "child" / "sigchild.py").write_text(RUN_AS_MODULE.format(sig=sig, n=n, hook=hook))
    (tmp_path / "work").mkdir()
    env = {**os.environ, "PYTHONPATH": str(tmp_path / "child")}
    res = subprocess.run([sys.executable, "-m", "sigchild"], cwd=tmp_path / "work", env=env, capture_output=True,
                         text=True, timeout=300)
    assert res.returncode == rc, res.stderr         # not -2 (killed by SIGINT at exit), not 1
    assert [ln for ln in res.stderr.splitlines() if ln.strip()] == ["robolobes: interrupted"], res.stderr
    assert list((tmp_path / "work").iterdir()) == []
