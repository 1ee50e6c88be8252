"""core.threads: the library's heavy entry points run with one BLAS thread unless the user chose."""

import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from threadpoolctl import threadpool_info, threadpool_limits

from robolobes.core.threads import USER_THREAD_VARIABLES, blas_single_threaded
from robolobes.lobes import solve, stability
from robolobes.linearize import grid_map, linearize_many, pass_map


def blas_threads():
    return sorted({i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"})


@blas_single_threaded
def inside():
    return blas_threads()


def test_decorator_limits_blas_and_restores(monkeypatch):
    for v in USER_THREAD_VARIABLES:
        monkeypatch.delenv(v, raising=False)
    np.linalg.eigvals(np.eye(3))  # BLAS loaded
    with threadpool_limits(limits=2, user_api="blas"):
        assert blas_threads() == [2]
        assert inside() == [1]
        assert blas_threads() == [2]  # restored after the call


def test_user_choice_wins(monkeypatch):
    monkeypatch.setenv("OMP_NUM_THREADS", "2")
    with threadpool_limits(limits=2, user_api="blas"):
        assert inside() == [2]


def test_heavy_entry_points_are_wrapped():
    for f in (solve, stability, linearize_many, pass_map, grid_map):
        assert f.__wrapped__.__name__ == f.__name__


@pytest.mark.skipif((os.cpu_count() or 1) < 2, reason="BLAS runs one thread anyway")
def test_limit_holds_for_scipys_blas_loaded_after_the_first_call():
    # A fresh interpreter, no thread variables: the first limited call happens before scipy.linalg
    # is imported (scipy ships its own OpenBLAS, loaded by that import); every BLAS library must
    # still run one thread inside a later limited call.
    code = textwrap.dedent("""
        from threadpoolctl import threadpool_info
        from robolobes.core.threads import blas_single_threaded

        @blas_single_threaded
        def threads():
            return sorted({i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"})

        threads()
        import scipy.linalg
        assert len({i["filepath"] for i in threadpool_info() if i["user_api"] == "blas"}) >= 2
        print(threads())
    """)
    env = {k: v for k, v in os.environ.items() if k not in USER_THREAD_VARIABLES}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[1]"
