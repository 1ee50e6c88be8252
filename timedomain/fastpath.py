"""The linearized path's time loop, compiled with numba (the fast path for sweeps).

What it integrates
------------------
Exactly the equations of :class:`timedomain.equations.LinearSystemData` (read its
``residual(dq, v, a, t, f_cut_tool)`` and ``center(dq, t)``): the robot linearized at the start
pose, the nonlinear milling force of :class:`timedomain.workpiece_force.MillingForce` on the eroded
:class:`timedomain.workpiece.Workpiece`, and the backlash dead zone of the motion springs::

    r(dq, v, a, t) = M a + C v + K_rest dq - J^T R_c^T F_tool(c(dq, t), Omega t) + f_nom(t)
                     + P k o (dz(d0 + P^T dq) - dz(d0))            (k o P^T dq without backlash)
    c(dq, t) = (s(t), 0) + c_off + J_c dq

The force of a step's end carries the correction of :mod:`timedomain.entry_exit` for the edge
elements that enter or leave the part (or end their entry ramp) inside the step, and the accepted
acceleration is that of the point force (``entry_exit="exact"``, the default of the methods).

Nothing of the physics is defined here. The compiled loop calls

* :func:`cases.milling.edge_force_law` and :func:`cases.milling.project_cut_frame` (wrapped with
  ``numba.njit``): the force law and the projection to the cut frame;
* :func:`linearize.model.dead_zone` (wrapped with ``numba.njit``): the backlash of eq. 12;
* the workpiece kernels ``_chip_kernel`` (chip thickness) and ``_remove_kernel`` (removal along
  the tooth-tip arcs, with the pending updates) of :mod:`timedomain.workpiece`, on the live arrays
  of the part (:meth:`Workpiece._kernel_state`).

The time integration is the compiled form of ``newmark.integrate(residual, 0, 0, h_s=h,
constant_tangent=(K, C, M), options=NewmarkOptions(atol=1e-11, rtol=1e-8, max_iter=20))`` for this
system, i.e. of the Python reference ``drivers.run_linearized_python``: average acceleration
(gamma = 1/2, beta = 1/4, :mod:`timedomain.newmark`), Newton on ``q1`` from the
constant-acceleration predictor with the effective matrix ``S = K + 2/h C + 4/h^2 M`` factorized
once (modified Newton: the true tangent differs from ``S`` only by the cutting stiffness,
~1e6-1e7 N/m at the TCP, and, inside a dead zone, by a motion spring; both are ~1e-6-1e-4 of
``4 M / h^2``, so each iteration contracts the error by that factor), the same convergence test
``|dq_i| <= atol + rtol |q1_i - q0_i|`` and the same bookkeeping of the outputs: the force of an
accepted step is that of the last residual evaluation (at most one increment, <= atol = 1e-11 m,
from the accepted state), the centre is at the accepted state, and both are recorded before the
step's material removal is committed. The initial acceleration is
:func:`timedomain.newmark.initial_acceleration`, in Python, as on the reference path.

Newton includes the cutting stiffness exactly (a rank-3 Woodbury correction of ``S`` with
``dF/dc`` from the chip kernel's derivatives); only the backlash softening stays out of the matrix.
Step halving is not compiled: a step whose Newton iteration fails in the kernel (it happens in
violent chatter, when the tool is thrown millimetres in and out of the part and teeth bury
themselves) is redone by the Python reference (:func:`timedomain.newmark.integrate`, which halves
the step) from the last accepted state, on the same workpiece, and the kernel resumes after it;
``stats["python_fallback_steps"]`` counts them. Only if that fails too is
:class:`FastPathConvergenceError` raised, naming the time.

Chunks, progress, interruption
------------------------------
The loop runs in chunks of at most ``chunk_steps`` steps (default: 1 % of the run, 1 to 2000
steps) per compiled call; ``progress(fraction)`` is called after each chunk. A chunk runs to its
end once started (numba holds the interpreter), so Ctrl-C lands between chunks, with the state and
the workpiece consistent (every accepted step committed, nothing else): it is raised as
:class:`timedomain.newmark.NewmarkInterrupted` carrying the last accepted state, like the Python
paths. Latency: one chunk, at most 2000 steps x ~30 us = 60 ms.

Compilation and its cache
-------------------------
The kernel is compiled with ``cache=True``: the first call in a fresh environment compiles it
(~10 s, with the workpiece kernels; ``bench/bench_timedomain.py`` measures it), later processes
load it from ``timedomain/__pycache__`` (~0.3 s). numba's cache
only watches the file that defines a function, not the files of the functions it calls (a known
numba limitation, "cache invalidation fails to recognize changes in symbols defined in another
file"), so this module fingerprints the sources it compiles in (``cases/milling.py``,
``linearize/model.py``, ``timedomain/workpiece.py``, and the numba version) and flushes its own
cache index when the fingerprint changes (:func:`_guard_cache`).
"""

from __future__ import annotations

import hashlib
import inspect
import math
import os
from dataclasses import dataclass
from functools import partial
from typing import Callable

import numpy as np
import scipy.linalg as sla
from numba import njit

import robolobes.cases.milling as _milling
import robolobes.linearize.model as _model
from robolobes.core.validate import finite_array

from . import entry_exit as _entry_exit
from . import workpiece as _workpiece
from .newmark import (NewmarkConvergenceError, NewmarkInterrupted, NewmarkOptions, NewmarkResult, NewmarkStats, integrate,
                      effective_matrix, initial_acceleration)
from .entry_exit import StepForce, acceleration_shift, step_force_correction
from .equations import step_residual
from .workpiece import _chip_kernel, _remove_kernel
from .workpiece_force import MillingForce

__all__ = ["FastPathError", "FastPathConvergenceError", "LinearRun", "run_linear_milling", "DEFAULT_ATOL_M",
           "DEFAULT_RTOL", "DEFAULT_MAX_ITER", "MAX_CHUNK_STEPS"]

#: Newton tolerances of the reference path (``drivers._run_newmark``): absolute on the increment
#: of every coordinate (rad or m), relative to the step's change of that coordinate.
DEFAULT_ATOL_M = 1e-11
DEFAULT_RTOL = 1e-8
DEFAULT_MAX_ITER = 20
#: Largest number of steps per compiled call (bounds the Ctrl-C latency).
MAX_CHUNK_STEPS = 2000

# The Newmark parameters of timedomain.newmark (average acceleration); the kernel's update is
# written for these values.
_GAMMA = NewmarkOptions().gamma
_BETA = NewmarkOptions().beta
assert _GAMMA == 0.5 and _BETA == 0.25

# Status codes of the kernel.
_OK, _NO_CONVERGENCE, _NOT_FINITE = 0, 1, 2


class FastPathError(ValueError):
    """Bad input to :func:`run_linear_milling`."""


class FastPathConvergenceError(NewmarkConvergenceError):
    """Newton did not converge at some step of the compiled loop (``.result``: last accepted state)."""


# ---------------------------------------------------------------------------------------------
# compiled pieces: the project's own functions, wrapped (not rewritten)

_edge_force_law = njit(inline="always")(_milling.edge_force_law)
_project_cut_frame = njit(inline="always")(_milling.project_cut_frame)
_dead_zone = njit(_model.dead_zone)


@njit(inline="always")
def _interp(tab, dt, t):  # pragma: no cover - numba
    """Row of a uniform table at time t: the arithmetic of ``LinearSystemData.interp``."""
    x = t / dt
    i = min(max(int(x), 0), tab.shape[0] - 2)
    f = x - i
    return i, f


@njit(inline="always")
def _newmark_av(q, q_n, v_n, base_a, vpred, ca, gh, h, a, v):  # pragma: no cover - numba
    """Newmark (gamma 1/2, beta 1/4): acceleration and velocity of the iterate q, in place."""
    for i in range(q.shape[0]):
        a[i] = ca * (q[i] - q_n[i] - h * v_n[i]) - base_a[i]
        v[i] = vpred[i] + gh * a[i]


@njit(inline="always")
def _solve3(G, w):  # pragma: no cover - numba
    """``G^-1 w`` for a 3 x 3 ``G`` and a (3,) ``w``, as three floats: Gaussian elimination with partial
    pivoting (LAPACK gesv's algorithm) on scalars, so that the step allocates nothing (numba's
    ``np.linalg.solve`` copies its arguments on every call). G is not modified."""
    a00, a01, a02, b0 = G[0, 0], G[0, 1], G[0, 2], w[0]
    a10, a11, a12, b1 = G[1, 0], G[1, 1], G[1, 2], w[1]
    a20, a21, a22, b2 = G[2, 0], G[2, 1], G[2, 2], w[2]
    if abs(a10) > abs(a00) and abs(a10) >= abs(a20):
        a00, a01, a02, b0, a10, a11, a12, b1 = a10, a11, a12, b1, a00, a01, a02, b0
    elif abs(a20) > abs(a00):
        a00, a01, a02, b0, a20, a21, a22, b2 = a20, a21, a22, b2, a00, a01, a02, b0
    m1 = a10 / a00
    m2 = a20 / a00
    a11 -= m1 * a01
    a12 -= m1 * a02
    b1 -= m1 * b0
    a21 -= m2 * a01
    a22 -= m2 * a02
    b2 -= m2 * b0
    if abs(a21) > abs(a11):
        a11, a12, b1, a21, a22, b2 = a21, a22, b2, a11, a12, b1
    m = a21 / a11
    a22 -= m * a12
    b2 -= m * b1
    x2 = b2 / a22
    x1 = (b1 - a12 * x2) / a11
    x0 = (b0 - a01 * x1 - a02 * x2) / a00
    return x0, x1, x2


@njit(inline="always")
def _centre(Jc, q, s1, c_off):  # pragma: no cover - numba
    """Tool centre (x_c, y_c) of ``LinearSystemData.center``: commanded s + static offset + Jc q."""
    jx = 0.0
    jy = 0.0
    for i in range(q.shape[0]):
        jx += Jc[0, i] * q[i]
        jy += Jc[1, i] * q[i]
    return (s1 + c_off[0]) + jx, c_off[1] + jy


@njit(cache=True, nogil=True)
def _run_chunk(k0, k1, h, omega, max_iter, atol, rtol,
               lu, piv, M, C, K_rest, JtRt, Jc, c_off, dt_tab, s_tab, f_nom_tab,
               idx, k_motion, backlash, d0,
               offset, radius, db, law,
               wb, x0, dx, sgn, dtheta_max, w_top, pend_i, pend_w, pend_a, pend_n,
               q_n, v_n, a_n, c_n, h_n, rec_f, rec_c, counters, Z, JcZ, MiJ, exact):  # pragma: no cover - numba
    """Steps k0 -> k1 (t = k h) of the linearized path; state (q_n, v_n, a_n, c_n, h_n) updated in place
    (h_n (T, K): the chips of the accepted state, before its removal, m).

    Entries and exits of the edge elements inside a step are integrated exactly
    (:func:`timedomain.entry_exit.step_force_correction`: ``D`` is added to the step's end force, and
    ``M^-1 J^T R_c^T D`` (``MiJ D``) taken out of the accepted acceleration); ``exact`` False: not
    (the force sampled at the step ends).

    counters (int64): [0] accepted steps, [1] Newton iterations, [2] most iterations of a step,
    [3] column updates, [4] pending-buffer overflows, [5] step that failed (-1: none).
    Returns a status code (_OK, _NO_CONVERGENCE, _NOT_FINITE); on failure the state is the last
    accepted one and nothing of the failed step was committed.
    """
    n = q_n.shape[0]
    nt, nk = offset.shape
    n_idx = idx.shape[0]
    ca = 1.0 / (_BETA * h * h)  # 1 / (beta h^2)
    gh = _GAMMA * h
    ktc, krc, kac, kte, kre, kae = law[0], law[1], law[2], law[3], law[4], law[5]
    dz0 = _dead_zone(d0, backlash)
    q = np.empty(n)
    v = np.empty(n)
    a = np.empty(n)
    r = np.empty(n)
    y = np.empty(n)
    base_a = np.empty(n)
    vpred = np.empty(n)
    dqm = np.empty(n_idx)
    phi = np.empty((nt, nk))
    phi0 = np.empty((nt, nk))
    hh = np.empty((nt, nk))
    dh = np.empty((nt, nk, 2))
    dF = np.zeros((3, 2))
    G = np.empty((3, 3))
    wv = np.empty(3)
    Dv = np.zeros(3)
    for k in range(k0, k1):
        t0 = k * h
        t1 = (k + 1) * h
        for i in range(n):
            base_a[i] = (0.5 / _BETA - 1.0) * a_n[i]  # (1 / (2 beta) - 1) a_n
            vpred[i] = v_n[i] + h * (1.0 - _GAMMA) * a_n[i]
            q[i] = q_n[i] + h * v_n[i] + 0.5 * h * h * a_n[i]  # predictor: constant acceleration a_n
        ang = omega * t1
        for j in range(nt):
            for kk in range(nk):
                phi[j, kk] = ang + offset[j, kk]
        # nominal-motion forcing and path coordinate at t1 (constant over the Newton iteration)
        it_, ft_ = _interp(s_tab, dt_tab, t1)
        s1 = s_tab[it_] + ft_ * (s_tab[it_ + 1] - s_tab[it_])
        fx = fy = fz = 0.0
        cx = cy = 0.0
        status = _NO_CONVERGENCE
        its = 0
        for it in range(1, max_iter + 1):
            its = it
            _newmark_av(q, q_n, v_n, base_a, vpred, ca, gh, h, a, v)
            # tool centre c(dq, t1) and the cutting force on the tool (cut frame)
            cx, cy = _centre(Jc, q, s1, c_off)
            _chip_kernel(wb, x0, dx, cx, sgn * cy, sgn, phi, radius, hh, dh)
            fx = 0.0
            fy = 0.0
            fz = 0.0
            for ii in range(3):
                dF[ii, 0] = 0.0
                dF[ii, 1] = 0.0
            for j in range(nt):
                for kk in range(nk):
                    if hh[j, kk] > 0.0:
                        et, er, ea = _edge_force_law(hh[j, kk], db, ktc, krc, kac, kte, kre, kae)
                        px, py, pz = _project_cut_frame(phi[j, kk], et, er, ea)
                        fx += px
                        fy += py
                        fz += pz
                        # cutting tangent dF/dc: the law is linear in h, dF/dh = project(K_c db)
                        gx, gy, gz = _project_cut_frame(phi[j, kk], ktc * db, krc * db, kac * db)
                        dF[0, 0] += gx * dh[j, kk, 0]
                        dF[0, 1] += gx * dh[j, kk, 1]
                        dF[1, 0] += gy * dh[j, kk, 0]
                        dF[1, 1] += gy * dh[j, kk, 1]
                        dF[2, 0] += gz * dh[j, kk, 0]
                        dF[2, 1] += gz * dh[j, kk, 1]
            # entries and exits inside the step, integrated over their engaged parts
            if exact and it == 1:  # from the predictor, kept over the iteration (module entry_exit)
                step_force_correction(wb, x0, dx, sgn, w_top, c_n[0], c_n[1], cx, cy, omega * t0, omega * h,
                                      offset, radius, db, law, h_n, hh, Dv)
            # residual (LinearSystemData.residual)
            for i in range(n):
                sm = 0.0
                sc = 0.0
                sk = 0.0
                for jj in range(n):
                    sm += M[i, jj] * a[jj]
                    sc += C[i, jj] * v[jj]
                    sk += K_rest[i, jj] * q[jj]
                fn = f_nom_tab[it_, i] + ft_ * (f_nom_tab[it_ + 1, i] - f_nom_tab[it_, i])
                r[i] = (sm + sc + sk - (JtRt[i, 0] * (fx + Dv[0]) + JtRt[i, 1] * (fy + Dv[1])
                                        + JtRt[i, 2] * (fz + Dv[2])) + fn)
            if backlash > 0.0:
                for m in range(n_idx):
                    dqm[m] = d0[m] + q[idx[m]]
                dzm = _dead_zone(dqm, backlash)
                for m in range(n_idx):
                    r[idx[m]] += k_motion[m] * (dzm[m] - dz0[m])
            else:
                for m in range(n_idx):
                    r[idx[m]] += k_motion[m] * q[idx[m]]
            finite = True
            for i in range(n):
                if not math.isfinite(r[i]):
                    finite = False
            if not finite:
                status = _NOT_FINITE
                break
            # increment: -S^-1 r with the LU factors of S (LAPACK getrf layout, 0-based pivots)
            for i in range(n):
                y[i] = r[i]
            for i in range(n):
                p = piv[i]
                if p != i:
                    tmp = y[i]
                    y[i] = y[p]
                    y[p] = tmp
            for i in range(n):
                s = y[i]
                for jj in range(i):
                    s -= lu[i, jj] * y[jj]
                y[i] = s
            for i in range(n - 1, -1, -1):
                s = y[i]
                for jj in range(i + 1, n):
                    s -= lu[i, jj] * y[jj]
                y[i] = s / lu[i, i]
            # Newton with the cutting stiffness: the residual's tangent is S - U V with U = J^T R_c^T
            # (n x 3) and V = dF/dc Jc (3 x n), so (Woodbury, Z = S^-1 U precomputed)
            # (S - U V)^-1 r = y + Z (I - V Z)^-1 V y,  y = S^-1 r. Only the backlash softening
            # stays out of the matrix (modified Newton for it: a contraction, |dk| << 4 M / h^2).
            jy0 = 0.0
            jy1 = 0.0
            for i in range(n):
                jy0 += Jc[0, i] * y[i]
                jy1 += Jc[1, i] * y[i]
            for ii in range(3):
                wv[ii] = dF[ii, 0] * jy0 + dF[ii, 1] * jy1
                for jj in range(3):
                    G[ii, jj] = (1.0 if ii == jj else 0.0) - (dF[ii, 0] * JcZ[0, jj] + dF[ii, 1] * JcZ[1, jj])
            u0, u1, u2 = _solve3(G, wv)
            for i in range(n):
                y[i] += Z[i, 0] * u0 + Z[i, 1] * u1 + Z[i, 2] * u2
            converged = True
            for i in range(n):
                dq = -y[i]
                if not math.isfinite(dq):
                    finite = False
                q[i] = q[i] + dq
                if not (abs(dq) <= atol + rtol * abs(q[i] - q_n[i])):
                    converged = False
            if not finite:
                status = _NOT_FINITE
                break
            if converged:
                status = _OK
                break
        counters[1] += its
        if status != _OK:
            counters[5] = k + 1
            return status
        # accept
        _newmark_av(q, q_n, v_n, base_a, vpred, ca, gh, h, a, v)
        cx, cy = _centre(Jc, q, s1, c_off)
        # record (force of the last residual evaluation; centre at the accepted state), then commit
        rec_f[k + 1, 0] = fx
        rec_f[k + 1, 1] = fy
        rec_f[k + 1, 2] = fz
        rec_c[k + 1, 0] = cx
        rec_c[k + 1, 1] = cy
        ang0 = omega * t0
        for j in range(nt):
            for kk in range(nk):
                phi0[j, kk] = ang0 + offset[j, kk]
        touched, overflow = _remove_kernel(wb, x0, dx, c_n[0], sgn * c_n[1], cx, sgn * cy, sgn, phi0, phi, radius,
                                           dtheta_max, w_top, pend_i, pend_w, pend_a, pend_n)
        for i in range(n):
            q_n[i] = q[i]
            v_n[i] = v[i]
            a_n[i] = a[i] - (MiJ[i, 0] * Dv[0] + MiJ[i, 1] * Dv[1] + MiJ[i, 2] * Dv[2])
        for j in range(nt):
            for kk in range(nk):
                h_n[j, kk] = hh[j, kk]
        c_n[0] = cx
        c_n[1] = cy
        counters[0] += 1
        if its > counters[2]:
            counters[2] = its
        counters[3] += touched
        counters[4] += overflow
    return _OK


# ---------------------------------------------------------------------------------------------
# numba's cache does not see edits of the functions compiled into the kernel from other files


def _dependency_fingerprint() -> str:
    """sha256 of the sources compiled into :func:`_run_chunk` from other files, and numba's version."""
    import numba

    hsh = hashlib.sha256(numba.__version__.encode())
    for mod in (_milling, _model, _workpiece, _entry_exit):
        try:
            src = inspect.getsourcefile(mod)
            if src is None:
                raise OSError(f"no source file for {mod.__name__}")
            with open(src, "rb") as f:
                hsh.update(f.read())
        except (OSError, TypeError):  # pragma: no cover - sources not available: never trust the cache
            hsh.update(os.urandom(16))
    return hsh.hexdigest()


def _guard_cache(dispatcher) -> None:
    """Flush ``dispatcher``'s on-disk cache index if the dependency fingerprint changed since it
    was written (stamp file next to the cache); best effort, silent when the cache is read-only."""
    cache = getattr(dispatcher, "_cache", None)
    path = getattr(cache, "cache_path", None)
    if cache is None or not path:  # pragma: no cover - caching disabled
        return
    fp = _dependency_fingerprint()
    stamp = os.path.join(path, f"fastpath.{dispatcher.py_func.__name__}.deps")
    try:
        with open(stamp) as f:
            if f.read().strip() == fp:
                return
    except OSError:
        pass
    try:
        cache.flush()
        os.makedirs(path, exist_ok=True)
        with open(stamp, "w") as f:
            f.write(fp)
    except OSError:  # pragma: no cover - read-only cache directory: numba then recompiles anyway
        pass


_guard_cache(_run_chunk)


# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class LinearRun:
    """Output of :func:`run_linear_milling`: every grid time ``t = k h``, k = 0..n_steps.

    Attributes
    ----------
    t_s : array (N,)
        Times, s (N = n_steps + 1).
    force_tool_n : array (N, 3)
        Force on the tool, cut frame, N, at each accepted state before its step's removal.
    center_m : array (N, 2)
        Tool centre in the cut frame, m.
    q, v, a : array (n,)
        Final deviation state (rad or m, /s, /s^2).
    stats : dict
        steps, rejected (always 0), newton_iterations, max_iterations, removed_cells,
        removal_overflows, chunks.
    """

    t_s: np.ndarray
    force_tool_n: np.ndarray
    center_m: np.ndarray
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    stats: dict


#: ``x`` as a C-contiguous finite float64 array of ``shape`` (FastPathError otherwise)
_f64 = partial(finite_array, error=FastPathError, contiguous=True)


def _is_int(x, lo: int, hi: int | None = None) -> bool:
    return bool(not isinstance(x, bool) and isinstance(x, (int, np.integer)) and x >= lo
                and (hi is None or x <= hi))


def _check_run_args(h_s, n_steps, omega_rad_s, chunk_steps, atol, rtol, max_iter,
                    fallback_halvings) -> tuple[float, int, float, int]:
    """Validated ``(h, n_steps, omega, chunk)`` of :func:`run_linear_milling`."""
    try:
        h = float(h_s)
        omega = float(omega_rad_s)
    except (TypeError, ValueError):
        raise FastPathError(f"h_s and omega_rad_s must be numbers, got {h_s!r}, {omega_rad_s!r}") from None
    if not (math.isfinite(h) and h > 0):
        raise FastPathError(f"time step h_s must be finite and > 0 s, got {h_s!r}")
    if not math.isfinite(omega):
        raise FastPathError(f"spindle speed omega_rad_s must be finite, got {omega_rad_s!r}")
    if not _is_int(n_steps, 1):
        raise FastPathError(f"n_steps must be an integer >= 1, got {n_steps!r}")
    n_steps = int(n_steps)
    if chunk_steps is None:
        chunk = min(MAX_CHUNK_STEPS, max(1, math.ceil(n_steps / 100)))
    elif not _is_int(chunk_steps, 1):
        raise FastPathError(f"chunk_steps must be an integer >= 1, got {chunk_steps!r}")
    else:
        chunk = int(chunk_steps)
    if not (math.isfinite(atol) and atol > 0 and math.isfinite(rtol) and rtol >= 0):
        raise FastPathError(f"atol must be > 0 and rtol >= 0, got {atol!r}, {rtol!r}")
    if not _is_int(max_iter, 1):
        raise FastPathError(f"max_iter must be an integer >= 1, got {max_iter!r}")
    if not _is_int(fallback_halvings, 0, 40):
        raise FastPathError(f"fallback_halvings must be an integer in [0, 40], got {fallback_halvings!r}")
    return h, n_steps, omega, chunk


def _system_arrays(data, end_s: float) -> tuple:
    """The linearized system's arrays, validated and contiguous, in the kernel's argument order:
    ``(M, C, K_rest, JtRt, Jc, c_off, dt_tab, s_tab, f_nom_tab, idx, k_motion, backlash, d0)``, and K."""
    M = _f64("M", data.M)
    nd = M.shape[0]
    if M.shape != (nd, nd):
        raise FastPathError(f"M must be square, got {M.shape}")
    C = _f64("C", data.C, (nd, nd))
    K = _f64("K", data.K, (nd, nd))
    K_rest = _f64("K_rest", data.K_rest, (nd, nd))
    JtRt = _f64("JtRt", data.JtRt, (nd, 3))
    Jc = _f64("Jc", data.Jc, (2, nd))
    c_off = _f64("c_off", data.c_off, (2,))
    idx = np.ascontiguousarray(data.motion_dofs, dtype=np.int64)
    if idx.ndim != 1 or np.any(idx < 0) or np.any(idx >= nd) or len(set(idx.tolist())) != idx.size:
        raise FastPathError(f"motion_dofs must be distinct indices into q (n = {nd}), got {data.motion_dofs!r}")
    k_motion = _f64("k_motion", data.k_motion, idx.shape)
    d0 = _f64("d0", data.d0, idx.shape)
    backlash = float(data.backlash_rad)
    if not (math.isfinite(backlash) and backlash >= 0):
        raise FastPathError(f"backlash_rad must be finite and >= 0, got {data.backlash_rad!r}")
    t_tab = _f64("t_tab", data.t_tab)
    if t_tab.ndim != 1 or t_tab.size < 2:
        raise FastPathError("t_tab must be a 1-D table of at least 2 times")
    s_tab = _f64("s_tab", data.s_tab, t_tab.shape)
    f_nom_tab = _f64("f_nom_tab", data.f_nom_tab, (t_tab.size, nd))
    if end_s > t_tab[-1] * (1 + 1e-12):
        raise FastPathError(f"the run ends at {end_s:.6g} s, after the end of the tables ({t_tab[-1]:.6g} s)")
    return (M, C, K_rest, JtRt, Jc, c_off, float(data.dt_tab), s_tab, f_nom_tab, idx, k_motion, backlash, d0), K


def _milling_arrays(milling: MillingForce) -> tuple:
    """The tool and the live workpiece arrays in the kernel's argument order: ``(offset, radius, db,
    law, wb, x0, dx, sgn, dtheta_max, w_top, pend_i, pend_w, pend_a, pend_n)``."""
    wp_state = milling.workpiece._kernel_state()
    offset = np.ascontiguousarray(milling.immersion_rad(0.0))
    radius = np.ascontiguousarray(milling.tooth_radius_m)
    law = milling.law
    law_arr = np.array([law.ktc_pa, law.krc_pa, law.kac_pa, law.kte_n_per_m, law.kre_n_per_m, law.kae_n_per_m])
    return (offset, radius, float(milling.db_m), law_arr) + tuple(wp_state)


def _factorized(K, C, M, JtRt, Jc, h: float) -> tuple:
    """LU of the effective matrix ``S`` and the Woodbury factors ``Z = S^-1 J^T R_c^T``, ``Jc Z``."""
    lu, piv = sla.lu_factor(effective_matrix(K, C, M, h, _GAMMA, _BETA))
    lu = np.ascontiguousarray(lu)
    Z = np.ascontiguousarray(sla.lu_solve((lu, piv), JtRt))  # S^-1 J^T R_c^T, (n, 3)
    JcZ = np.ascontiguousarray(Jc @ Z)
    return lu, np.ascontiguousarray(piv, dtype=np.int64), Z, JcZ


class _Loop:
    """State of a compiled run (updated in place by the kernel), its records and counters, the
    workpiece bookkeeping and the Python fallback for a step the kernel could not converge."""

    def __init__(self, data, milling: MillingForce, h: float, n_steps: int, omega: float, K, C, M, *, atol: float,
                 rtol: float, max_iter: int, fallback_halvings: int, exact: bool = True):
        self.data, self.milling, self.h, self.n_steps, self.omega = data, milling, h, n_steps, omega
        self.exact = bool(exact)
        self.KCM = (K, C, M)
        self.atol, self.rtol, self.max_iter, self.fallback_halvings = atol, rtol, max_iter, fallback_halvings
        nd = M.shape[0]
        # initial state: rest, consistent acceleration (as the reference path)
        self.q_n = np.zeros(nd)
        self.v_n = np.zeros(nd)
        self.c_n = np.asarray(data.center(self.q_n, 0.0), dtype=float).copy()
        f0, _ = milling.force(omega * 0.0, self.c_n)
        self.h_n = np.ascontiguousarray(milling.evaluate(omega * 0.0, self.c_n).chip_m, dtype=float).copy()
        self.MiJ = acceleration_shift(M, data.JtRt)
        self.a_n = np.array(initial_acceleration(self._residual({}), self.q_n, self.v_n, 0.0, constant_tangent=self.KCM),
                            dtype=float)
        N = n_steps + 1
        self.rec_f = np.empty((N, 3))
        self.rec_c = np.empty((N, 2))
        self.rec_f[0] = np.array(f0)
        self.rec_c[0] = self.c_n
        # accepted steps, Newton iterations, max iterations, removed cells, overflows, failed step
        self.counters = np.zeros(6, dtype=np.int64)
        self.counters[5] = -1
        self.chunks = 0
        self.acct = [0, 0, 0]  # kernel commits, column updates, overflows already reported to the workpiece
        self.fb = {"steps": 0, "substeps": 0, "rejected": 0, "iterations": 0}

    def _residual(self, last: dict):
        data, milling, omega = self.data, self.milling, self.omega

        def res(q, v, a, t):
            f, _ = milling.force(omega * t, data.center(q, t))
            last["f"] = f
            return data.residual(q, v, a, t, f)

        return res

    def state(self) -> NewmarkResult:
        """The last accepted state as a :class:`NewmarkResult`."""
        c, h = self.counters, self.h
        st = NewmarkStats(accepted=int(c[0]), rejected=0, newton_iterations=int(c[1]),
                          max_iterations=int(c[2]), min_step_s=h if c[0] else math.inf)
        return NewmarkResult(int(c[0]) * h, self.q_n.copy(), self.v_n.copy(), self.a_n.copy(), st, False)

    def account(self) -> None:
        """Report the kernel's removal steps to the workpiece (revision, counters)."""
        c, fb, acct = self.counters, self.fb, self.acct
        self.milling.workpiece._account_removal(int(c[0]) - fb["steps"] - acct[0], int(c[3]) - acct[1],
                                                int(c[4]) - acct[2])
        acct[:] = [int(c[0]) - fb["steps"], int(c[3]), int(c[4])]

    def fallback_step(self, status: int) -> None:
        """One nominal step with the Python reference (step halving) from the last accepted state."""
        kf = int(self.counters[5])
        k_acc = int(self.counters[0])
        h, milling, omega, data = self.h, self.milling, self.omega, self.data
        self.account()  # the workpiece revision must be current before the Python force is evaluated
        step = StepForce(milling, omega, k_acc * h, self.c_n, self.h_n, exact=self.exact)
        residual, accepted, last = step_residual(data, step, self.MiJ)
        prev = {"t": k_acc * h, "c": self.c_n.copy()}

        def on_step(st):
            c = np.asarray(data.center(st.q, st.t_s), dtype=float)
            if st.on_grid:
                self.rec_f[k_acc + 1] = last["f"]
                self.rec_c[k_acc + 1] = c
            milling.commit(omega * prev["t"], prev["c"], omega * st.t_s, c)
            prev.update(t=st.t_s, c=c)

        opts = NewmarkOptions(atol=self.atol, rtol=self.rtol, max_iter=self.max_iter, defer_interrupts=False,
                              max_halvings=int(self.fallback_halvings))
        try:
            out = integrate(residual, self.q_n, self.v_n, a0=self.a_n, t0_s=k_acc * h, h_s=h, n_steps=1,
                            constant_tangent=self.KCM, options=opts, on_step=on_step,
                            accepted_acceleration=accepted)
        except NewmarkConvergenceError:
            why = ("did not converge in %d iterations" % self.max_iter if status == _NO_CONVERGENCE
                   else "gave a non-finite residual or increment")
            raise FastPathConvergenceError(
                f"linearized fast path: Newton {why} at the step to t = {kf * h:.9g} s (step {kf} of {self.n_steps}, "
                f"h = {h:.6g} s), also with step halving; the last accepted state is t = {k_acc * h:.9g} s",
                self.state()) from None
        self.q_n[:], self.v_n[:], self.a_n[:] = out.q, out.v, out.a
        self.c_n[:] = prev["c"]
        self.h_n[:] = step.h0
        self.counters[0] += 1
        self.counters[1] += out.stats.newton_iterations
        self.counters[2] = max(int(self.counters[2]), out.stats.max_iterations)
        self.counters[5] = -1
        for key, val in (("steps", 1), ("substeps", out.stats.accepted), ("rejected", out.stats.rejected),
                         ("iterations", out.stats.newton_iterations)):
            self.fb[key] += val

    def stats(self) -> dict:
        c, fb = self.counters, self.fb
        return dict(steps=int(c[0]), rejected=fb["rejected"], newton_iterations=int(c[1]),
                    max_iterations=int(c[2]), removed_cells=int(c[3]), removal_overflows=int(c[4]),
                    chunks=self.chunks, python_fallback_steps=fb["steps"], python_fallback_substeps=fb["substeps"])


def _apply_kick(loop: _Loop, system: tuple, v_m_s: float) -> None:
    """Add the minimum-norm joint velocity that moves the tool centre at ``v_m_s`` along the cut
    frame's y (``Jc dv = (0, v)``); the acceleration changes by ``-M^-1 C dv`` (the force depends on
    the position only), so the state stays consistent."""
    M, C, Jc = system[0], system[1], system[4]
    dv = np.linalg.pinv(Jc)[:, 1] * v_m_s
    loop.v_n[:] += dv
    loop.a_n[:] -= np.linalg.solve(M, C @ dv)


def _run_chunks(loop: _Loop, chunk: int, system: tuple, tool_part: tuple, factors: tuple, progress,
                kick: tuple[int, float] | None = None) -> None:
    """Run the kernel chunk by chunk to the end, redoing failed steps with the Python fallback;
    Ctrl-C lands between chunks as :class:`NewmarkInterrupted`. ``kick``: (step, normal velocity
    m/s) applied once the run has reached that step (:func:`_apply_kick`)."""
    lu, piv, Z, JcZ = factors
    (M, C, K_rest, JtRt, Jc, c_off, dt_tab, s_tab, f_nom_tab, idx, k_motion, backlash, d0) = system
    (offset, radius, db, law_arr, wb, x0, dx, sgn, dtheta_max, w_top, pend_i, pend_w, pend_a, pend_n) = tool_part
    n_steps, h, omega = loop.n_steps, loop.h, loop.omega
    k_kick = -1 if kick is None or kick[1] == 0.0 else int(kick[0])
    k = 0
    try:
        while k < n_steps:
            if k == k_kick:
                _apply_kick(loop, system, kick[1])  # type: ignore[index]
            k1 = min(n_steps, k + chunk, k_kick if k < k_kick else n_steps)
            status = _run_chunk(k, k1, h, omega, int(loop.max_iter), float(loop.atol), float(loop.rtol),
                                lu, piv, M, C, K_rest, JtRt, Jc, c_off, dt_tab, s_tab, f_nom_tab,
                                idx, k_motion, backlash, d0,
                                offset, radius, db, law_arr,
                                wb, x0, dx, sgn, dtheta_max, w_top, pend_i, pend_w, pend_a, pend_n,
                                loop.q_n, loop.v_n, loop.a_n, loop.c_n, loop.h_n, loop.rec_f, loop.rec_c, loop.counters,
                                Z, JcZ, loop.MiJ, loop.exact)
            loop.chunks += 1
            if status != _OK:
                loop.fallback_step(status)
            k = int(loop.counters[0])
            if progress is not None:
                progress(k / n_steps)
    except KeyboardInterrupt as e:
        if isinstance(e, NewmarkInterrupted):
            raise
        raise NewmarkInterrupted(loop.state()) from e
    finally:
        # Each compiled call is atomic, so the counters match the eroded part whatever stopped the loop.
        loop.account()


def run_linear_milling(data, milling: MillingForce, *, h_s: float, n_steps: int, omega_rad_s: float,
                       progress: Callable[[float], None] | None = None, chunk_steps: int | None = None,
                       atol: float = DEFAULT_ATOL_M, rtol: float = DEFAULT_RTOL,
                       max_iter: int = DEFAULT_MAX_ITER, fallback_halvings: int = 12,
                       exact_entry_exit: bool = True, kick: tuple[float, float] | None = None) -> LinearRun:
    """Integrate the linearized path from rest (``dq = v = 0`` at t = 0) over ``n_steps`` steps.

    Parameters
    ----------
    data : timedomain.equations.LinearSystemData
        The equations (n DOF).
    milling : MillingForce
        Force law, tool and part; its workpiece is eroded in place, step by step.
    h_s : float
        Time step, s (> 0); the grid is ``t = k h_s``.
    n_steps : int
        Number of steps (>= 1).
    omega_rad_s : float
        Spindle speed, rad/s: the spindle angle is ``omega t``.
    progress : callable ``(fraction) -> None``, optional
        Called after every chunk (about every 1 % of the run) and at the end.
    chunk_steps : int, optional
        Steps per compiled call (default ``ceil(n_steps / 100)``, at most :data:`MAX_CHUNK_STEPS`).
    atol : float
        Newton increment tolerance, absolute, units of q (rad, m); > 0.
    rtol : float
        Newton increment tolerance relative to the step's change of q; >= 0.
    max_iter : int
        Newton iterations per step in the kernel (and per attempt of the Python fallback).
    fallback_halvings : int
        Step halvings the Python fallback may use on a step the kernel could not converge
        (smallest step ``h / 2**fallback_halvings``); beyond, :class:`FastPathConvergenceError`.
    exact_entry_exit : bool
        Integrate the edge elements that enter or leave the part inside a step over their engaged
        part (default; :mod:`timedomain.entry_exit`); False samples the force at the step ends.
    kick : (float, float), optional
        ``(t_s, v_m_s)``: at the grid time nearest ``t_s`` the tool centre's normal (cut-frame y)
        velocity jumps by ``v_m_s`` (minimum-norm joint velocity, acceleration kept consistent).
        None or ``v_m_s = 0``: no kick, the run is bit for bit the same.

    Returns
    -------
    LinearRun

    Raises
    ------
    FastPathError
        Bad input.
    FastPathConvergenceError
        Newton did not converge at some step (the message names the time; ``.result`` holds the
        last accepted state, the workpiece is eroded up to it).
    timedomain.newmark.NewmarkInterrupted
        KeyboardInterrupt (Ctrl-C) between two chunks; ``.result`` holds the last accepted state,
        the workpiece is eroded up to it.
    """
    if not isinstance(milling, MillingForce):
        raise FastPathError(f"milling must be a timedomain.workpiece_force.MillingForce, got {type(milling).__name__}")
    h, n_steps, omega, chunk = _check_run_args(h_s, n_steps, omega_rad_s, chunk_steps, atol, rtol, max_iter,
                                               fallback_halvings)
    system, K = _system_arrays(data, n_steps * h)
    M, C, _, JtRt, Jc = system[:5]
    tool_part = _milling_arrays(milling)
    factors = _factorized(K, C, M, JtRt, Jc, h)
    loop = _Loop(data, milling, h, n_steps, omega, K, C, M, atol=atol, rtol=rtol, max_iter=max_iter,
                 fallback_halvings=fallback_halvings, exact=exact_entry_exit)
    k_kick = None if kick is None else (int(round(float(kick[0]) / h)), float(kick[1]))
    _run_chunks(loop, chunk, system, tool_part, factors, progress, k_kick)
    t = np.arange(n_steps + 1) * h
    return LinearRun(t_s=t, force_tool_n=loop.rec_f, center_m=loop.rec_c, q=loop.q_n, v=loop.v_n, a=loop.a_n,
                     stats=loop.stats())
