"""``simulate(problem, method)``: a milling pass in time domain, in the lobes' shape
(``solve(problem, method)``).

The equations are in :mod:`timedomain.equations`, the time loops in :mod:`timedomain.drivers`, the
derived numbers in :mod:`timedomain.summary`, the runout companion run in :mod:`timedomain.runout`.

Outputs (:class:`~timedomain.result.SimulationResult`): forces on the workpiece in the dynamometer
frame (the cut frame: x along the feed, y normal, z along the spindle, up), the TCP deviation from
the commanded path (cut frame), the machined wall, and the
:class:`~timedomain.result.SimulationSummary` (force statistics, roughness, stability verdict,
chatter frequency).
"""

from __future__ import annotations

import time
from dataclasses import replace
from typing import TYPE_CHECKING, Callable, overload

import numpy as np

from robolobes.core.threads import blas_single_threaded
from robolobes.core.validate import readonly
from robolobes.linearize.linear import linearize

from .drivers import Records, run_full, run_linearized
from .equations import PassSetup
from .problem import DelayNewmark, LinearizedNewmark, NonlinearNewmark, SimulationError, SimulationProblem
from .result import SimulationResult
from .runout import needs_companion, with_companion_verdict
from .summary import summarize

if TYPE_CHECKING:
    from .delay import DelayResult

__all__ = ["simulate"]


def _poles(S: PassSetup) -> np.ndarray:
    """Poles of the linearized robot at the start, rad/s (complex; the verdict's beat period)."""
    return np.asarray(linearize(S.robot, S.th_tab[0]).modes().poles)


def _deviation(S: PassSetup, rec: Records) -> np.ndarray:
    """TCP deviation from the commanded path ``(s(t), 0, 0)``, cut frame, (N, 3), m (z is NaN on the
    linearized path, which has no axial output)."""
    t = rec.t_s
    dev = np.zeros((len(t), 3))
    dev[:, 0] = rec.center_m[:, 0] - S.pas.s(t)
    dev[:, 1] = rec.center_m[:, 1]
    dev[:, 2] = (rec.tcp_m - S.p_ref) @ S.Rc[2]
    return dev


def _result(problem, method, S: PassSetup, rec: Records, stats: dict) -> SimulationResult:
    t = rec.t_s
    wall = S.workpiece.wall_profile()
    return SimulationResult(problem=problem, method=method, t_s=readonly(t),
                            force_workpiece_n=readonly(-rec.force_tool_n),
                            tcp_deviation_m=readonly(_deviation(S, rec)), spindle_angle_rad=readonly(S.omega * t),
                            wall_x_m=readonly(wall.x_m), wall_y_m=readonly(wall.y_m), steady_window_s=S.steady,
                            stats=stats)


@overload
def simulate(problem, method: DelayNewmark, progress: Callable[[float], None] | None = None, *,
             verdict_companion: bool = True) -> DelayResult: ...


@overload
def simulate(problem, method: LinearizedNewmark | NonlinearNewmark | None = None,
             progress: Callable[[float], None] | None = None, *, verdict_companion: bool = True) -> SimulationResult: ...


@blas_single_threaded
def simulate(problem, method: LinearizedNewmark | NonlinearNewmark | DelayNewmark | None = None,
             progress: Callable[[float], None] | None = None, *,
             verdict_companion: bool = True) -> SimulationResult | DelayResult:
    """Simulate the pass of ``problem`` with ``method`` (:mod:`timedomain.equations` for the equations).

    BLAS runs on one thread inside (:mod:`core.threads`: the matrices are 6-18 DOF), unless the user
    set a thread variable.

    Parameters
    ----------
    problem : SimulationProblem, or timedomain.delay.StructureProblem (only with DelayNewmark)
    method : LinearizedNewmark, NonlinearNewmark or DelayNewmark, optional
        Default ``NonlinearNewmark()`` (the full nonlinear equations). ``DelayNewmark`` runs the
        delay-based regenerative model (:mod:`timedomain.delay`) and returns a
        :class:`~timedomain.delay.DelayResult`.
    progress : callable ``(fraction) -> None``, optional
        Called about every 1 % of the run.
    verdict_companion : bool
        For a tool with runout whose principal period is the tooth period, decide stability on a
        companion run without runout (:mod:`timedomain.runout`, the summary's ``verdict_basis``).

    Returns
    -------
    SimulationResult (DelayResult for DelayNewmark)

    Raises
    ------
    timedomain.problem.SimulationError
        Bad method or a run whose records would exceed the memory bound (before any work).
    timedomain.newmark.NewmarkInterrupted
        On Ctrl-C (KeyboardInterrupt), carrying the last accepted state; nothing is written.

    Examples
    --------
    The symmetric 2-DOF benchmark of :func:`lobes.solve` (Insperger et al. 2003) at 10 000 rpm,
    where the lobes put the limit at 1.51 mm, run for 0.2 s without a robot (the delay-based
    model): half the limit decays after a 2 um kick, twice the limit grows from a 1 nm kick at
    about the SDM's Floquet exponent, +37.7 1/s (``tests/test_timedomain_delay.py``). A robot
    runs the same way: ``simulate(SimulationProblem(robot, case), LinearizedNewmark())``.

    >>> from robolobes.cases.milling import Cut, CuttingLaw, Tool
    >>> from robolobes.lobes import Mode, ModalStructure
    >>> from robolobes.timedomain import DelayNewmark
    >>> from robolobes.timedomain.delay import StructureProblem
    >>> modes = ModalStructure(tuple(Mode(922.0, 0.011, 1.34003e6, d) for d in ((1.0, 0.0), (0.0, 1.0))))
    >>> def run(ap_m, kick_m):
    ...     cut = Cut(ae_m=0.5e-3, ap_m=ap_m, spindle_rpm=10000.0, feed_per_tooth_m=1e-4)
    ...     p = StructureProblem(modes, Tool(diameter_m=0.01, teeth=2), cut, CuttingLaw(ktc_pa=6e8, krc_pa=2e8),
    ...                          t_end_s=0.2)
    ...     return simulate(p, DelayNewmark(kick_m=kick_m))
    >>> run(0.75e-3, 2e-6).verdict.verdict.status
    'stable'
    >>> r = run(3e-3, 1e-9)
    >>> r.verdict.verdict.status, round(r.rate.rate_per_s)  # 1/s
    ('unstable', 37)
    """
    method = NonlinearNewmark() if method is None else method
    if isinstance(method, DelayNewmark):
        from .delay import run_delay

        return run_delay(problem, method)
    if not isinstance(problem, SimulationProblem):
        raise SimulationError(f"problem must be a SimulationProblem for {type(method).__name__}, got "
                              f"{type(problem).__name__} (a structure without robot runs with DelayNewmark)")
    wall0 = time.perf_counter()
    S = PassSetup(problem, method)
    rec = (run_linearized(S, progress) if isinstance(method, LinearizedNewmark) else run_full(S, progress, method))
    stats = dict(h_s=S.h, n_dof=S.robot.nv, n_discs=S.workpiece.discs.count,
                 linearized=isinstance(method, LinearizedNewmark), **rec.stats)
    result = _result(problem, method, S, rec, stats)
    summary = summarize(result, S.workpiece, last_centre_x_m=float(rec.center_m[-1, 0]),
                        poles_rad_s=_poles(S))
    if verdict_companion and needs_companion(problem, summary):
        summary = with_companion_verdict(summary, lambda p: simulate(p, method, verdict_companion=False), problem,
                                         float(rec.t_s[-1]), S.steady[0])
    stats["wall_time_s"] = time.perf_counter() - wall0
    return replace(result, summary=replace(summary, wall_s=stats["wall_time_s"]))
