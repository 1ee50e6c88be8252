"""The time loops of a simulated pass: the full nonlinear path and the linearized path in Python
(:func:`timedomain.newmark.integrate`), and the linearized path compiled
(:func:`timedomain.fastpath.run_linear_milling`). Each returns the raw :class:`Records` of the
nominal time grid; the equations are those of :mod:`timedomain.equations`."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .equations import PassSetup, full_system, linear_system_data, linear_system_python
from .fastpath import DEFAULT_ATOL_M, DEFAULT_MAX_ITER, DEFAULT_RTOL
from .newmark import NewmarkOptions, integrate
from .problem import NonlinearNewmark, SimulationError

__all__ = ["Records", "run_full", "run_linearized_python", "run_linearized"]


@dataclass(frozen=True)
class Records:
    """Raw output of one run: every nominal grid time from 0 (inclusive).

    t_s (N,), force_tool_n (N, 3) cut frame, center_m (N, 2) cut frame, tcp_m (N, 3) base frame
    (NaN on the linearized path), stats (dict: steps, rejected, newton_iterations, ...).
    """

    t_s: np.ndarray
    force_tool_n: np.ndarray
    center_m: np.ndarray
    tcp_m: np.ndarray
    stats: dict


def _run_newmark(S: PassSetup, residual, q0, center_at, tcp_of, last, progress, options: NewmarkOptions,
                 **kw) -> Records:
    """Integrate from rest at ``q0``, recording every nominal grid time and committing each step's
    material removal after it is accepted."""
    N = S.n_steps + 1
    rec_t = np.empty(N)
    rec_f = np.empty((N, 3))
    rec_c = np.empty((N, 2))
    rec_p = np.full((N, 3), np.nan)
    count = [0]
    prev = {}

    def record(t, q, f=None):
        # f: the force of the last residual evaluation, at the converged Newton iterate (within the
        # increment tolerance, 1e-11, of the accepted q): no extra force evaluation per step
        c = center_at(q, t)
        if f is None:
            f, _ = S.milling.force(S.omega * t, c)
        i = count[0]
        rec_t[i], rec_f[i], rec_c[i] = t, f, c
        p = tcp_of(q, t)
        if p is not None:
            rec_p[i] = p
        count[0] += 1
        return c

    prev.update(t=0.0, c=record(0.0, q0))

    def on_step(st):
        if st.on_grid:
            c = record(st.t_s, st.q, last.get("f"))
        else:
            c = center_at(st.q, st.t_s)
        S.milling.commit(S.omega * prev["t"], prev["c"], S.omega * st.t_s, c)
        prev.update(t=st.t_s, c=c)

    n = len(q0)
    res = integrate(residual, q0, np.zeros(n), t0_s=0.0, h_s=S.h, n_steps=S.n_steps, options=options,
                    on_step=on_step, progress=progress, **kw)
    m = count[0]
    st = res.stats
    return Records(t_s=rec_t[:m], force_tool_n=rec_f[:m], center_m=rec_c[:m], tcp_m=rec_p[:m],
                   stats=dict(steps=st.accepted, rejected=st.rejected, newton_iterations=st.newton_iterations,
                              max_iterations=st.max_iterations))


def run_full(S: PassSetup, progress, method: NonlinearNewmark | None = None) -> Records:
    """The full nonlinear path (:func:`timedomain.equations.full_system`)."""
    m = method or NonlinearNewmark()
    residual, tangent, tcp_position, q0, last, accepted = full_system(S)
    opts = NewmarkOptions(atol=np.full(len(q0), m.atol), rtol=m.rtol, max_iter=m.max_iter)
    return _run_newmark(S, residual, q0, lambda q, t: S.center_of(tcp_position(q)), lambda q, t: tcp_position(q),
                        last, progress, opts, tangent=tangent, accepted_acceleration=accepted)


def run_linearized_python(S: PassSetup, progress) -> Records:
    """The linearized path in Python (:func:`timedomain.newmark.integrate`): the reference of the
    compiled loop :mod:`timedomain.fastpath` (tests/test_fastpath.py), ~10x slower; it has no velocity
    kick and refuses one."""
    if S.kick_m_s != 0.0:
        raise SimulationError("the Python reference of the linearized path has no velocity kick; valid: kick_m_s = 0")
    residual, const, center, q0, last, accepted = linear_system_python(S)
    opts = NewmarkOptions(atol=np.full(len(q0), DEFAULT_ATOL_M), rtol=DEFAULT_RTOL, max_iter=DEFAULT_MAX_ITER)
    return _run_newmark(S, residual, q0, center, lambda q, t: None, last, progress, opts, constant_tangent=const,
                        accepted_acceleration=accepted)


def run_linearized(S: PassSetup, progress) -> Records:
    """The linearized path, compiled (:func:`timedomain.fastpath.run_linear_milling`), with the
    method's velocity kick (``LinearizedNewmark.kick_m_s``, at the start of full engagement unless
    ``kick_at_s`` is given)."""
    from .fastpath import run_linear_milling  # numba: compiled or loaded on first use

    run = run_linear_milling(linear_system_data(S), S.milling, h_s=S.h, n_steps=S.n_steps, omega_rad_s=S.omega,
                             progress=progress, exact_entry_exit=S.exact_entry_exit, kick=(S.kick_time_s, S.kick_m_s))
    return Records(t_s=run.t_s, force_tool_n=run.force_tool_n, center_m=run.center_m,
                   tcp_m=np.full((len(run.t_s), 3), np.nan), stats=run.stats)
