"""Newmark integration of nonlinear second-order systems in residual form (paper eq. 16).

The system is given by its residual ``r(q, v, a, t) = 0`` (n equations, n unknowns; e.g.
``r = M(q) a + c(q, v) + tau_el(q, v) - f(q, v, t)``) and, for Newton, its partial derivatives
``(dr/dq, dr/dv, dr/da)``. The Newmark relations (average acceleration: ``gamma = 1/2``,
``beta = 1/4``, the paper's choice, unconditionally stable and second-order)::

    q1 = q0 + h v0 + h^2 (1/2 - beta) a0 + beta h^2 a1
    v1 = v0 + h (1 - gamma) a0 + gamma h a1

make ``a1`` and ``v1`` functions of ``q1``; Newton is done on ``q1`` with the effective matrix
``S = dr/dq + gamma / (beta h) dr/dv + 1 / (beta h^2) dr/da``, starting from the
constant-acceleration predictor ``q1 = q0 + h v0 + h^2 a0 / 2``.

Convergence: an iteration converges when every increment satisfies
``|dq_i| <= atol_i + rtol |q1_i - q0_i|`` and, if ``residual_atol`` is given, the residual
before that increment satisfies ``|r_i| <= residual_atol_i``.

Step control: the nominal step ``h`` defines a grid ``t0 + k h``. A step whose Newton iteration
does not converge in ``max_iter`` iterations (or produces NaN/inf) is rejected and retried from
the last accepted state with half the step, down to ``h / 2**max_halvings``; after
``regrow_after`` accepted steps at a reduced size the step doubles again, but only at a time
that lies on the coarser grid, so every nominal grid time is hit exactly (``AcceptedStep.on_grid``
marks them: record uniform outputs there). The time is kept as an integer number of the finest
ticks, so it does not drift.

Piecewise-smooth elements (backlash dead zones, contact loss)
-------------------------------------------------------------
Chosen approach: full Newton with the tangent of the piece the iterate lies on (no smoothing, no
event location), step halving on failure, and optional event refinement (below). Why Newton
converges through contact loss and re-engagement: for one dead zone the residual is monotone and
piecewise linear in ``q1``, slope ``A = m / (beta h^2) + c gamma / (beta h)`` inside the zone and
``A + k`` outside; it is convex on ``q > -s`` and concave on ``q < s``. Newton on such a function
ends on the right piece after at most two jumps (a jump from an outer piece lands either on the
root's piece or inside the zone, and from inside the zone the linearization's root is exact when
the root is inside, or lies on the root's outer piece), so a step costs at most 4 iterations
(3 linear solves + 1 zero increment) at *any* step size (tested at omega h = 7). With several
coupled dead zones cycling is possible in principle; the slopes of neighbouring pieces then
differ by ``1 + k beta h^2 / m = 1 + (omega h)^2 / 4``, which is ~1 + 1e-6 for a robot joint at
h ~ 1e-5 s, so each iteration contracts the error by ~(omega h)^2 / 4; a step that still fails
``max_iter`` is halved (4x smaller factor each time).

Accuracy across a kink: a dead-zone force is continuous, only its slope jumps, so the step that
straddles the kink has a local error O(h^2 k |v| / m) instead of O(h^3); a bounded number of such
steps per unit time adds O(h^2) to the global error, and the scheme stays second order (tested).
For elements whose *force* jumps, the caller may give ``events(q, v, t) -> g (m,)`` (e.g.
``|q_i - theta_i| - s``): a step over which any ``g`` changes sign is rejected and halved until it
is at most ``h / 2**event_halvings`` long (then accepted), which bounds the error committed at
each event without locating it exactly. ``event_halvings = 0`` (default) turns this off.

Interruption: during a run (main thread) a SIGINT handler raises ``KeyboardInterrupt`` at once,
except while the step hook (where the workpiece is eroded and outputs are recorded) runs: there
it is held until the hook returns, so the hook always completes. The integrator then raises
:class:`NewmarkInterrupted` (a ``KeyboardInterrupt``) carrying the last accepted state; a trial
iteration in progress is simply dropped (trial evaluations change no state).

Cost (measured, 18 DOF, trivial residual): ~30 us per step on the linear fast path, ~60 us with
a constant tangent (modified Newton, 2 residual evaluations), ~90 us with full Newton.
"""

from __future__ import annotations

import math
import signal
import threading
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np
import scipy.linalg as sla

from robolobes.core.validate import finite_array, readonly

# LAPACK's dgetrs (the LU solve without sla.lu_solve's checks); scipy's stubs do not list the
# lapack module's names, so it is looked up by name
_getrs = sla.get_lapack_funcs(("getrs",), dtype=np.float64)[0]

__all__ = [
    "NewmarkError",
    "NewmarkConvergenceError",
    "NewmarkInterrupted",
    "NewmarkOptions",
    "AcceptedStep",
    "NewmarkStats",
    "NewmarkResult",
    "LinearSystem",
    "effective_matrix",
    "initial_acceleration",
    "integrate",
]

ResidualFn = Callable[[np.ndarray, np.ndarray, np.ndarray, float], np.ndarray]
TangentFn = Callable[[np.ndarray, np.ndarray, np.ndarray, float], tuple[np.ndarray, np.ndarray, np.ndarray]]
EventFn = Callable[[np.ndarray, np.ndarray, float], np.ndarray]


class NewmarkError(ValueError):
    """Invalid input to the integrator (shapes, non-finite values, bad options)."""


class NewmarkConvergenceError(RuntimeError):
    """Newton did not converge even at the smallest allowed step.

    Attributes
    ----------
    result : NewmarkResult
        The last accepted state (``completed=False``).
    """

    def __init__(self, message: str, result: "NewmarkResult"):
        super().__init__(message)
        self.result = result


class NewmarkInterrupted(KeyboardInterrupt):
    """Ctrl-C (or a KeyboardInterrupt raised by a callback) during :func:`integrate`.

    Attributes
    ----------
    result : NewmarkResult
        The last accepted state (``completed=False``); the step hook has seen exactly the
        accepted steps up to ``result.t_s``.
    """

    def __init__(self, result: "NewmarkResult"):
        super().__init__(f"integration interrupted at t = {result.t_s:.9g} s after {result.stats.accepted} steps")
        self.result = result


@dataclass(frozen=True)
class NewmarkOptions:
    """Parameters of :func:`integrate`.

    Parameters
    ----------
    gamma, beta : float
        Newmark parameters (default average acceleration 1/2, 1/4).
    rtol : float
        Relative tolerance on the Newton increment, relative to the step's change of q.
    atol : float or sequence of float (n,)
        Absolute tolerance on the Newton increment, in the units of each q (> 0).
    residual_atol : float or sequence (n,), optional
        Also require ``|r_i| <= residual_atol_i`` (units of the residual) before the last increment.
    max_iter : int
        Newton iterations before the step is rejected.
    max_halvings : int
        Smallest step ``h / 2**max_halvings``.
    regrow_after : int
        Accepted steps at a reduced size before the step doubles again.
    event_halvings : int
        Steps over which an event function changes sign are refined down to ``h / 2**event_halvings``
        (0: off). Must be <= ``max_halvings``.
    modified_newton : bool
        Reuse the first iteration's effective matrix within a step (fewer tangent evaluations,
        linear instead of quadratic convergence).
    progress_every : float
        Fraction of the run between two progress calls, in (0, 1].
    defer_interrupts : bool
        Defer SIGINT while the step hook runs (main thread only).
    """

    gamma: float = 0.5
    beta: float = 0.25
    rtol: float = 1e-8
    atol: float | Sequence[float] | np.ndarray = 1e-12
    residual_atol: float | Sequence[float] | None = None
    max_iter: int = 12
    max_halvings: int = 12
    regrow_after: int = 4
    event_halvings: int = 0
    modified_newton: bool = False
    progress_every: float = 0.01
    defer_interrupts: bool = True

    def __post_init__(self) -> None:
        for name in ("gamma", "beta", "rtol", "progress_every"):
            v = getattr(self, name)
            if not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise NewmarkError(f"NewmarkOptions.{name} must be a finite number > 0, got {v!r}")
        if self.progress_every > 1:
            raise NewmarkError(f"progress_every must be in (0, 1], got {self.progress_every}")
        for name, lo in (("max_iter", 1), ("max_halvings", 0), ("regrow_after", 1), ("event_halvings", 0)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < lo:
                raise NewmarkError(f"NewmarkOptions.{name} must be an integer >= {lo}, got {v!r}")
        if self.max_halvings > 40:
            raise NewmarkError(f"max_halvings must be <= 40, got {self.max_halvings}")
        if self.event_halvings > self.max_halvings:
            raise NewmarkError(
                f"event_halvings ({self.event_halvings}) must not exceed max_halvings ({self.max_halvings})"
            )
        for name in ("atol", "residual_atol"):
            v = getattr(self, name)
            if v is None and name == "residual_atol":
                continue
            arr = np.asarray(v, dtype=float)
            if arr.ndim > 1 or not np.all(np.isfinite(arr)) or not np.all(arr > 0):
                raise NewmarkError(f"NewmarkOptions.{name} must be > 0 (a scalar or one value per DOF), got {v!r}")


@dataclass(frozen=True)
class AcceptedStep:
    """One accepted step, passed to the ``on_step`` hook (arrays read-only).

    Attributes
    ----------
    index : int
        1 for the first accepted step.
    t_prev_s, t_s, h_s : float
        Start, end and length of the step, s.
    q_prev, v_prev, a_prev, q, v, a : array (n,)
        State at the start and at the end of the step.
    iterations : int
        Newton iterations of this step.
    on_grid : bool
        ``t_s`` is a nominal grid time ``t0 + k h``.
    """

    index: int
    t_prev_s: float
    t_s: float
    h_s: float
    q_prev: np.ndarray
    v_prev: np.ndarray
    a_prev: np.ndarray
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    iterations: int
    on_grid: bool


@dataclass(frozen=True)
class NewmarkStats:
    """Counters of a run.

    Attributes
    ----------
    accepted, rejected : int
        Steps accepted; attempts rejected because Newton failed.
    event_refinements : int
        Attempts rejected to refine a step over which an event function changed sign.
    newton_iterations : int
        Total iterations (= residual evaluations in Newton), accepted and rejected attempts.
    max_iterations : int
        Most iterations of an accepted step.
    min_step_s : float
        Smallest accepted step, s.
    """

    accepted: int = 0
    rejected: int = 0
    event_refinements: int = 0
    newton_iterations: int = 0
    max_iterations: int = 0
    min_step_s: float = math.inf


@dataclass(frozen=True)
class NewmarkResult:
    """Final (or last accepted) state of :func:`integrate`."""

    t_s: float
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    stats: NewmarkStats
    completed: bool


@dataclass(frozen=True)
class LinearSystem:
    """Linear system ``M a + C v + K q = f(t)`` with constant matrices.

    Parameters
    ----------
    M, C, K : array (n, n)
    force : callable ``f(t) -> (n,)``
    """

    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    force: Callable[[float], np.ndarray]

    def __post_init__(self) -> None:
        mats = [np.asarray(x, dtype=float) for x in (self.M, self.C, self.K)]
        n = mats[0].shape[0] if mats[0].ndim == 2 else -1
        for name, m in zip("MCK", mats):
            if m.shape != (n, n) or not np.all(np.isfinite(m)):
                raise NewmarkError(f"{name} must be a finite square matrix like M {mats[0].shape}, got {m.shape}")
        for name, m in zip("MCK", mats):
            object.__setattr__(self, name, readonly(m))

    def residual(self, q, v, a, t) -> np.ndarray:
        return self.M @ a + self.C @ v + self.K @ q - np.asarray(self.force(t), dtype=float)

    def tangent(self, q, v, a, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return self.K, self.C, self.M

    @property
    def matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(dr/dq, dr/dv, dr/da) = (K, C, M)`` for ``constant_tangent``."""
        return self.K, self.C, self.M


def effective_matrix(dr_dq, dr_dv, dr_da, h_s: float, gamma: float = 0.5, beta: float = 0.25) -> np.ndarray:
    """``S = dr/dq + gamma / (beta h) dr/dv + 1 / (beta h^2) dr/da``, shape (n, n)."""
    return np.asarray(dr_dq) + (gamma / (beta * h_s)) * np.asarray(dr_dv) + (1.0 / (beta * h_s**2)) * np.asarray(dr_da)


class _InterruptGuard:
    """SIGINT handler for a whole run: raises KeyboardInterrupt at once, except while the step hook
    runs, where it is remembered and raised when the hook returns (main thread only)."""

    def __init__(self, enabled: bool):
        self.enabled = enabled and threading.current_thread() is threading.main_thread()
        self.in_hook = False
        self.pending = False
        self._old = None

    def _handler(self, signum, frame):
        if self.in_hook:
            self.pending = True
        else:
            raise KeyboardInterrupt

    def __enter__(self):
        if self.enabled:
            try:
                self._old = signal.signal(signal.SIGINT, self._handler)
            except (ValueError, TypeError):  # pragma: no cover - no signals here
                self.enabled = False
        return self

    def __exit__(self, *exc):
        if self.enabled:
            signal.signal(signal.SIGINT, self._old)
        return False

    def run_hook(self, hook, info) -> None:
        self.in_hook = True
        try:
            hook(info)
        finally:
            self.in_hook = False
        if self.pending:
            self.pending = False
            raise KeyboardInterrupt


def _vec(name, x, n=None) -> np.ndarray:
    """A finite 1-D float copy of ``x`` (of length n if given)."""
    return finite_array(name, x, None if n is None else (n,), ndim=1, error=NewmarkError)


def initial_acceleration(
    residual: ResidualFn,
    q0,
    v0,
    t0_s: float,
    *,
    tangent: TangentFn | None = None,
    constant_tangent: tuple | None = None,
    max_iter: int = 20,
    rtol: float = 1e-12,
    atol: float = 1e-10,
) -> np.ndarray:
    """Acceleration consistent with the initial state: solve ``r(q0, v0, a, t0) = 0`` for ``a``.

    Newton on ``a`` with ``dr/da`` (one iteration when the residual is linear in ``a``); converged
    when ``|da| <= rtol |a| + atol`` (``atol`` in the units of a, default 1e-10: a start at rest in
    equilibrium has ``a ~ 1e-13`` of round-off, where a purely relative test never passes).

    Returns
    -------
    array (n,)
    """
    q = _vec("q0", q0)
    v = _vec("v0", v0, q.size)
    if tangent is None and constant_tangent is None:
        raise NewmarkError("give tangent or constant_tangent")
    a = np.zeros_like(q)
    for _ in range(max_iter):
        r = np.asarray(residual(q, v, a, float(t0_s)), dtype=float)
        if constant_tangent is not None:
            m = constant_tangent[2]
        else:
            assert tangent is not None  # one of the two, checked above
            m = tangent(q, v, a, float(t0_s))[2]
        da = np.linalg.solve(np.asarray(m, float), -r)
        a = a + da
        if np.all(np.abs(da) <= rtol * np.abs(a) + atol):
            return a
    scale = np.abs(a).max() if a.size else 0.0
    if np.all(np.abs(da) <= 1e-9 * (scale + 1e-300)):
        return a
    raise NewmarkConvergenceError(
        f"initial acceleration did not converge in {max_iter} iterations (last |da| = {np.abs(da).max():.3g})",
        NewmarkResult(float(t0_s), readonly(q), readonly(v), readonly(a), NewmarkStats(), False),
    )


def _check_start(q0, v0, t0_s, h_s, n_steps) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Validated initial state, start time and nominal step of :func:`integrate`."""
    q_n = _vec("q0", q0)
    v_n = _vec("v0", v0, q_n.size)
    try:
        t0 = float(t0_s)
        h_nom = float(h_s)
    except (TypeError, ValueError):
        raise NewmarkError(f"t0_s and h_s must be numbers, got {t0_s!r}, {h_s!r}") from None
    if not math.isfinite(t0):
        raise NewmarkError(f"t0_s must be finite, got {t0}")
    if not math.isfinite(h_nom) or h_nom <= 0:
        raise NewmarkError(f"step size h_s must be finite and > 0, got {h_nom}")
    if isinstance(n_steps, bool) or not isinstance(n_steps, (int, np.integer)) or n_steps < 1:
        raise NewmarkError(f"n_steps must be an integer >= 1, got {n_steps!r}")
    return q_n, v_n, t0, h_nom


#: the constant tangent (dr/dq, dr/dv, dr/da), each (n, n)
_Tangents = tuple[np.ndarray, np.ndarray, np.ndarray]


def _check_tangents(n: int, tangent, constant_tangent, linear: bool) -> _Tangents | None:
    """The constant tangent as float arrays (n, n), or None when full Newton uses ``tangent``."""
    if tangent is None and constant_tangent is None:
        raise NewmarkError("give tangent (full Newton) or constant_tangent (prefactored)")
    if linear and constant_tangent is None:
        raise NewmarkError("linear=True needs constant_tangent")
    if constant_tangent is None:
        return None
    if len(constant_tangent) != 3:
        raise NewmarkError("constant_tangent must be (dr/dq, dr/dv, dr/da)")
    dq, dv, da = (np.asarray(m, dtype=float) for m in constant_tangent)
    const = (dq, dv, da)
    for m in const:
        if m.shape != (n, n) or not np.all(np.isfinite(m)):
            raise NewmarkError(f"constant_tangent matrices must be finite ({n}, {n}), got {m.shape}")
    return const


class _NewtonStep:
    """Newton on ``q1`` for one Newmark step from an accepted state (module docstring)."""

    def __init__(self, residual, tangent, const: _Tangents | None, opt: NewmarkOptions, n: int, h_nom: float,
                 linear: bool):
        self.residual, self.tangent, self.const, self.opt, self.n = residual, tangent, const, opt, n
        self.h_nom, self.linear = h_nom, linear
        self.gamma, self.beta = float(opt.gamma), float(opt.beta)
        self.atol = np.broadcast_to(np.asarray(opt.atol, dtype=float), (n,))
        self.ratol = None if opt.residual_atol is None else np.broadcast_to(np.asarray(opt.residual_atol, float), (n,))
        self.lu_cache: dict[int, tuple] = {}

    def _factor(self, h: float):
        """LU of the constant effective matrix for step h (cached per halving level), or None."""
        if self.const is None:
            return None
        key = round(math.log2(self.h_nom / h))
        lu = self.lu_cache.get(key)
        if lu is None:
            lu = sla.lu_factor(effective_matrix(*self.const, h, self.gamma, self.beta))
            self.lu_cache[key] = lu
        return lu

    def _effective(self, q, v, a, t1, ca: float, cv: float) -> np.ndarray:
        jq, jv, ja = self.tangent(q, v, a, t1)
        s_mat = np.asarray(jq, dtype=float) + cv * np.asarray(jv, dtype=float) + ca * np.asarray(ja, dtype=float)
        if s_mat.shape != (self.n, self.n):
            raise NewmarkError(f"tangent gives an effective matrix of shape {s_mat.shape}, expected ({self.n}, {self.n})")
        return s_mat

    def _converged(self, dq, r, q, q_n) -> bool:
        if self.linear:
            return True
        ok = bool((np.abs(dq) <= self.atol + self.opt.rtol * np.abs(q - q_n)).all())
        if ok and self.ratol is not None:
            ok = bool((np.abs(r) <= self.ratol).all())
        return ok

    def solve(self, q_n, v_n, a_n, h: float, t1: float):
        """Returns (q, v, a, iterations), or (None, None, None, iterations) on failure."""
        gamma, beta, opt = self.gamma, self.beta, self.opt
        ca = 1.0 / (beta * h * h)
        cv = gamma / (beta * h)
        base_a = (0.5 / beta - 1.0) * a_n
        vpred = v_n + h * (1.0 - gamma) * a_n
        q = q_n + h * v_n + 0.5 * h * h * a_n
        lu = self._factor(h)
        s_mat = None
        for it in range(1, opt.max_iter + 1):
            a = ca * (q - q_n - h * v_n) - base_a
            v = vpred + gamma * h * a
            r = np.asarray(self.residual(q, v, a, t1), dtype=float)
            if r.shape != (self.n,):
                raise NewmarkError(f"residual returned shape {r.shape}, expected ({self.n},)")
            if not np.isfinite(r).all():
                return None, None, None, it
            if lu is not None:
                dq, _info = _getrs(lu[0], lu[1], r)
                dq = -dq
            else:
                if s_mat is None or not opt.modified_newton:
                    s_mat = self._effective(q, v, a, t1, ca, cv)
                try:
                    dq = -np.linalg.solve(s_mat, r)
                except np.linalg.LinAlgError:
                    return None, None, None, it
            if not np.isfinite(dq).all():
                return None, None, None, it
            q = q + dq
            if self._converged(dq, r, q, q_n):
                a = ca * (q - q_n - h * v_n) - base_a
                v = vpred + gamma * h * a
                return q, v, a, it
        return None, None, None, opt.max_iter


class _StepSize:
    """Dyadic step control: the step is ``h / 2**level``; time is counted in ticks of
    ``h / 2**max_halvings`` so that every nominal grid time is hit exactly."""

    def __init__(self, opt: NewmarkOptions, n_steps: int, h_nom: float):
        self.H = int(opt.max_halvings)
        self.regrow_after = opt.regrow_after
        self.ticks_nom = 1 << self.H
        self.p_end = int(n_steps) * self.ticks_nom
        self.tick = h_nom / self.ticks_nom
        self.p = 0
        self.level = 0
        self.streak = 0

    @property
    def step_ticks(self) -> int:
        return 1 << (self.H - self.level)

    @property
    def at_smallest(self) -> bool:
        return self.level >= self.H

    @property
    def on_grid(self) -> bool:
        return self.p % self.ticks_nom == 0

    def halve(self) -> None:
        self.level += 1
        self.streak = 0

    def advance(self, step_ticks: int) -> None:
        """After an accepted step: move on by its ticks."""
        self.p += step_ticks

    def regrow(self) -> None:
        """Double the step again after ``regrow_after`` accepted steps at a reduced size, at a time
        on the coarser grid."""
        if self.level > 0:
            self.streak += 1
            if self.streak >= self.regrow_after and self.p % (1 << (self.H - self.level + 1)) == 0:
                self.level -= 1
                self.streak = 0


def _frozen(*arrays) -> None:
    for arr in arrays:
        arr.setflags(write=False)


def integrate(
    residual: ResidualFn,
    q0,
    v0,
    *,
    t0_s: float,
    h_s: float,
    n_steps: int,
    tangent: TangentFn | None = None,
    constant_tangent: tuple | None = None,
    linear: bool = False,
    a0=None,
    options: NewmarkOptions | None = None,
    on_step: Callable[[AcceptedStep], None] | None = None,
    events: EventFn | None = None,
    progress: Callable[[float], None] | None = None,
    accepted_acceleration: Callable[[float, np.ndarray, np.ndarray, np.ndarray], np.ndarray] | None = None,
) -> NewmarkResult:
    """Integrate ``r(q, v, a, t) = 0`` from ``t0_s`` over ``n_steps`` nominal steps of ``h_s``.

    Parameters
    ----------
    residual : callable ``(q, v, a, t) -> (n,)``
        Must not change any state (it is called for trial iterates); state changes belong in
        ``on_step``.
    q0, v0 : array (n,)
        Initial position and velocity.
    t0_s, h_s : float
        Start time and nominal step, s (``h_s > 0``).
    n_steps : int
        Number of nominal steps (>= 1); the run ends at ``t0 + n_steps h``.
    tangent : callable ``(q, v, a, t) -> (dr/dq, dr/dv, dr/da)``, optional
        Partial derivatives (n, n) each, for full Newton.
    constant_tangent : tuple of 3 arrays (n, n), optional
        Constant ``(dr/dq, dr/dv, dr/da)``: the effective matrix is factorized once per step size
        and reused (modified Newton; exact Newton for a linear system).
    linear : bool
        With ``constant_tangent``: the residual is affine with exactly these matrices, so one
        solve per step is exact (the fast path; no convergence check).
    a0 : array (n,), optional
        Initial acceleration; default :func:`initial_acceleration`.
    options : NewmarkOptions
    on_step : callable ``(AcceptedStep) -> None``, optional
        Called once per accepted step, in order (commit the workpiece, record outputs here).
    events : callable ``(q, v, t) -> (m,)``, optional
        Kink/event functions for step refinement (module docstring).
    progress : callable ``(fraction) -> None``, optional
        Called with the fraction of the run done, every ``options.progress_every`` and at the end.
    accepted_acceleration : callable ``(t1, q1, v1, a1) -> (n,)``, optional
        Called once per accepted step, before ``on_step``: the acceleration the next step starts
        from (default ``a1``). For a residual whose force at a step's end carries a correction of
        the step's integral (:mod:`timedomain.entry_exit`), which must not be carried on.

    Returns
    -------
    NewmarkResult

    Raises
    ------
    NewmarkError
        Bad input.
    NewmarkConvergenceError
        Newton fails at the smallest step (``.result`` holds the last accepted state).
    NewmarkInterrupted
        KeyboardInterrupt (``.result`` holds the last accepted state).
    """
    opt = NewmarkOptions() if options is None else options
    if not isinstance(opt, NewmarkOptions):
        raise NewmarkError(f"options must be NewmarkOptions, got {type(opt).__name__}")
    q_n, v_n, t0, h_nom = _check_start(q0, v0, t0_s, h_s, n_steps)
    n = q_n.size
    const = _check_tangents(n, tangent, constant_tangent, linear)
    if a0 is None:
        a_n = initial_acceleration(residual, q_n, v_n, t0, tangent=tangent, constant_tangent=const)
    else:
        a_n = _vec("a0", a0, n)
    newton = _NewtonStep(residual, tangent, const, opt, n, h_nom, linear)
    ctl = _StepSize(opt, n_steps, h_nom)
    t_n = t0
    g_n = None if events is None else np.asarray(events(q_n, v_n, t_n), dtype=float)
    stats: dict[str, Any] = dict(accepted=0, rejected=0, event_refinements=0, newton_iterations=0, max_iterations=0,
                                 min_step_s=math.inf)
    next_progress = opt.progress_every

    def result(done: bool) -> NewmarkResult:
        return NewmarkResult(t_n, readonly(q_n), readonly(v_n), readonly(a_n), NewmarkStats(**stats), done)

    a_n = np.array(a_n, dtype=float)
    _frozen(q_n, v_n, a_n)
    guard = _InterruptGuard(opt.defer_interrupts)
    try:
        with guard:
            while ctl.p < ctl.p_end:
                step_ticks = ctl.step_ticks
                h = step_ticks * ctl.tick
                t1 = t0 + (ctl.p + step_ticks) * ctl.tick
                q1, v1, a1, its = newton.solve(q_n, v_n, a_n, h, t1)
                stats["newton_iterations"] += its
                if q1 is None:
                    stats["rejected"] += 1
                    if ctl.at_smallest:
                        raise NewmarkConvergenceError(
                            f"Newton did not converge at t = {t_n:.9g} s even with the smallest step "
                            f"h = {h:.3g} s ({opt.max_iter} iterations, {ctl.H} halvings); check the tangent, "
                            f"loosen atol/rtol, raise max_iter or max_halvings",
                            result(False),
                        )
                    ctl.halve()
                    continue
                assert v1 is not None and a1 is not None  # solve returns all three states or none
                if events is not None:
                    g1 = np.asarray(events(q1, v1, t1), dtype=float)
                    assert g_n is not None  # evaluated at the start when events are given
                    if ctl.level < opt.event_halvings and np.any(np.sign(g1) != np.sign(g_n)):
                        stats["event_refinements"] += 1
                        ctl.halve()
                        continue
                    g_n = g1
                # accept (the new arrays are owned here and never modified: freeze them, no copies)
                if accepted_acceleration is not None:
                    a1 = np.array(accepted_acceleration(t1, q1, v1, a1), dtype=float)
                _frozen(q1, v1, a1)
                stats["accepted"] += 1
                stats["max_iterations"] = max(stats["max_iterations"], its)
                stats["min_step_s"] = min(stats["min_step_s"], h)
                q_prev, v_prev, a_prev, t_prev = q_n, v_n, a_n, t_n
                q_n, v_n, a_n, t_n = q1, v1, a1, t1
                ctl.advance(step_ticks)
                if on_step is not None:
                    guard.run_hook(on_step, AcceptedStep(
                        index=stats["accepted"], t_prev_s=t_prev, t_s=t1, h_s=h, q_prev=q_prev, v_prev=v_prev,
                        a_prev=a_prev, q=q1, v=v1, a=a1, iterations=its, on_grid=ctl.on_grid))
                ctl.regrow()
                if progress is not None and (ctl.p / ctl.p_end >= next_progress or ctl.p == ctl.p_end):
                    progress(ctl.p / ctl.p_end)
                    next_progress = (math.floor(ctl.p / ctl.p_end / opt.progress_every) + 1) * opt.progress_every
    except KeyboardInterrupt as e:
        if isinstance(e, NewmarkInterrupted):
            raise
        raise NewmarkInterrupted(result(False)) from e
    return result(True)
