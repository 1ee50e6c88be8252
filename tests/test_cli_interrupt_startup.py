"""Ctrl-C or SIGTERM during start-up (numpy and the subcommand's modules being imported, which
takes seconds on a busy machine) ends in the same one line and exit code as during the work.

The moment is made exact: the child process sends the signals to itself from inside the import of
the subcommand's module (``importlib.import_module``, which ``robolobes.main.build_parser`` calls),
exactly as many as each test states, before any handler of ``robolobes.core.interrupt`` exists.
"""

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
