"""BLAS thread limits for the library's heavy entry points (not only for the command line).

robolobes' work is many small matrices (6-18 DOF models, monodromy matrices of a few hundred
rows): multi-threaded BLAS only adds synchronisation to each call. ``bench/bench_threads.py``
measures the heavy entry points with one BLAS thread against the default (one thread per core) in
the same process and prints the ratios (README, Dependencies). So the heavy entry points
(``lobes.solve`` / ``stability``, ``linearize_many`` and the batch modes/FRF, the pose maps) run
with BLAS limited to one thread, through threadpoolctl, whether they are called from the command
line or from Python.

A user's explicit choice wins: when ``OMP_NUM_THREADS``, ``OPENBLAS_NUM_THREADS`` or
``MKL_NUM_THREADS`` is set in the environment (the BLAS libraries read it when they load; the
``robolobes`` command sets them to 1 unless already set), nothing is changed.
"""

from __future__ import annotations

import contextlib
import functools
import os
from typing import Callable, Iterator, TypeVar

__all__ = ["single_blas_thread", "blas_single_threaded", "USER_THREAD_VARIABLES"]

USER_THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")

F = TypeVar("F", bound=Callable)
_controller = None


def _user_chose() -> bool:
    return any(os.environ.get(v) for v in USER_THREAD_VARIABLES)


def _get_controller():
    """One threadpoolctl controller, made on first use, after numpy and scipy loaded their BLAS.

    Re-used because inspecting the loaded libraries costs ~1 ms per call, limiting with a kept
    controller ~0.1 ms. A controller knows only the libraries loaded when it was made, and scipy
    ships its own OpenBLAS, loaded when ``scipy.linalg`` is first imported: so it is imported
    here first. (Before, after a first call made before that import, scipy's BLAS was never
    limited in that process; ``tests/test_threads.py``.)"""
    global _controller
    if _controller is None:
        import numpy  # noqa: F401  (its OpenBLAS)
        import scipy.linalg  # noqa: F401  (scipy's own OpenBLAS)
        from threadpoolctl import ThreadpoolController

        _controller = ThreadpoolController()
    return _controller


@contextlib.contextmanager
def single_blas_thread() -> Iterator[None]:
    """Context manager: BLAS limited to one thread inside the block (unless the user chose, see module doc)."""
    if _user_chose():
        yield
        return
    with _get_controller().limit(limits=1, user_api="blas"):
        yield


def blas_single_threaded(func: F) -> F:
    """Decorator: run ``func`` inside :func:`single_blas_thread`."""

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        with single_blas_thread():
            return func(*args, **kwargs)

    return wrapper  # type: ignore[return-value]
