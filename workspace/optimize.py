"""Placement and tool-rotation optimization: maximize the minimum stable depth over the pass.

Decision variables (any subset, ``over``): the pass start offset ``x, y, z`` (m, base frame), the
part's yaw about base z (rad), and the tool's rotation about its own axis (rad), constant along the
pass. Objective: the smallest critical depth over ``n_s`` poses along the (moved) pass at the
chosen spindle speed (SDM, :func:`robolobes.lobes.solve` at that one speed, on the modally
truncated structure of :class:`MapMethod`).

Feasible poses: every pass pose reachable on one continuous IK branch (each pose's IK continued
from the previous one), joints within their ranges (5 deg tolerance as the case loader, or strict),
at least ``min_sin`` from the elbow and wrist singularities (``|sin psi|, |sin q5|``) and
``min_shoulder_m`` from the shoulder one.

How the method copes with a non-smooth objective: the stability limit is a minimum over lobes and
over poses, with kinks where the critical lobe or the worst pose changes, and the feasible set has
hard edges. So there are no gradients to trust: a multistart of the baseline and a Latin-hypercube
sample of the box, then Nelder-Mead (derivative-free) from the best few starts, on the negated
objective with infeasible points ranked below every feasible one. The optimum is then checked by
SDM on the *full* (untruncated) structure at every pass pose, and that number is the one reported.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from robolobes.core.errors import BadInput
from robolobes.lobes import LobeProblem, PhysicalStructure, SemiDiscretization, solve

from .compute import build_robot, pose_structure
from .poses import solve_pose, start_pose, target
from .problem import MapMethod, MapProblem

__all__ = ["OptimizeProblem", "Optimum", "PassEvaluation", "evaluate_pass", "optimize_placement", "VARIABLES"]

VARIABLES = ("x_offset_m", "y_offset_m", "z_offset_m", "yaw_rad", "tool_rotation_rad")


@dataclass(frozen=True, eq=False)
class OptimizeProblem:
    """What to optimize.

    Attributes
    ----------
    map_problem : MapProblem
        Case, variant, tool modes, ``op_rpm`` (the chosen speed); its axes are not used.
    variables : tuple of str
        Subset of :data:`VARIABLES`.
    bounds : dict name -> (lo, hi)
        Box of each variable, SI units.
    n_s : int
        Poses along the pass (start to end).
    depth_max_m : float
        Largest depth searched (above the maps' 10 mm: the paper's aluminium cut is stable to
        about 19 mm on the 18-DOF model).
    strict : bool
        Joint ranges without the 5 deg tolerance.
    min_sin, min_shoulder_m : float
        Distance to the singularities.
    """

    map_problem: MapProblem
    variables: tuple
    bounds: dict
    n_s: int = 5
    depth_max_m: float = 0.05
    strict: bool = False
    min_sin: float = 0.05
    min_shoulder_m: float = 0.05

    def __post_init__(self) -> None:
        bad = [v for v in self.variables if v not in VARIABLES]
        if bad or not self.variables:
            raise BadInput(f"variables must be a non-empty subset of {', '.join(VARIABLES)}, got {self.variables!r}")
        for v in self.variables:
            lo, hi = self.bounds.get(v, (None, None))
            if lo is None or not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
                raise BadInput(f"bounds[{v}] must be finite (lo, hi) with lo < hi, got {self.bounds.get(v)!r}")
        if not 2 <= self.n_s <= 50:
            raise BadInput(f"n_s (poses along the pass) must be from 2 to 50, got {self.n_s}")


@dataclass(frozen=True)
class PassEvaluation:
    """The pass at one candidate: ``feasible`` (and ``reason`` if not), the critical depth at each
    pass pose ``depth_m`` (n_s,) m (inf: none below ``depth_max_m``), ``theta`` (n_s, 6) rad,
    ``feed`` (3,), ``s_m`` (n_s,)."""

    x: np.ndarray
    feasible: bool
    reason: str
    depth_m: np.ndarray
    theta: np.ndarray
    feed: np.ndarray
    s_m: np.ndarray
    strict_ok: bool = False

    @property
    def min_depth_m(self) -> float:
        return float(np.min(self.depth_m)) if self.feasible else -math.inf

    @property
    def worst(self) -> int:
        return int(np.argmin(self.depth_m))


def _travel(case) -> float:
    import warnings

    from robolobes.linearize.path import Pass

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return Pass.from_case(case).travel_m


def _pass_poses(opt: OptimizeProblem, values: dict, s: np.ndarray):
    case = opt.map_problem.case
    q0, p0, R0 = start_pose(case)
    thetas, q_ref = [], q0
    feed = None
    strict = True
    for k, sk in enumerate(s):
        tgt = target(case, p0, R0, offset_m=(values["x_offset_m"], values["y_offset_m"], values["z_offset_m"]),
                     yaw_rad=values["yaw_rad"], tool_rotation_rad=values["tool_rotation_rad"], s_m=sk)
        feed = tgt.feed
        sol = solve_pose(case, tgt, q_ref)
        if not sol.reachable:
            return None, feed, f"pass pose {k} (s = {sk * 1e3:.1f} mm): {sol.message}"
        if opt.strict and sol.reason != 0:
            return None, feed, f"pass pose {k}: a joint is past its strict range"
        if sol.sin_margin < opt.min_sin or sol.shoulder_m < opt.min_shoulder_m:
            return None, feed, f"pass pose {k}: too close to a singularity"
        if k and np.max(np.abs(sol.theta - q_ref)) > 0.5:
            return None, feed, f"pass pose {k}: the IK branch is not continuous"
        thetas.append(sol.theta)
        strict &= sol.reason == 0
        q_ref = sol.theta
    return np.array(thetas), feed, "" if strict else "tolerance"


def _depth_at(opt: OptimizeProblem, method: MapMethod, theta, feed, full: bool) -> float:
    mp = opt.map_problem
    from robolobes.linearize import linearize

    lin = linearize(build_robot(mp), theta)
    if full:
        structure = PhysicalStructure.from_linear(lin, feed)
        if mp.tool_modes:
            structure, _ = pose_structure(mp, replace(method, reduce_max_freq_hz=None), lin, feed)
    else:
        structure, _ = pose_structure(mp, method, lin, feed)
    cut = replace(mp.case.cut, feed_direction=tuple(feed), spindle_rpm=mp.op_rpm)
    res = solve(LobeProblem(structure, mp.case.tool, cut, mp.case.law), SemiDiscretization(m=method.m),
                [mp.op_rpm], depth_max_m=opt.depth_max_m, rtol=method.rtol)
    return float(res.depth_limit_m[0])


def evaluate_pass(opt: OptimizeProblem, x, method: MapMethod | None = None, *, full: bool = False) -> PassEvaluation:
    """The pass at the variables ``x`` (in the order of ``opt.variables``, SI)."""
    from threadpoolctl import threadpool_limits

    method = MapMethod() if method is None else method
    x = np.asarray(x, dtype=float)
    values = dict.fromkeys(VARIABLES, 0.0)
    values.update(zip(opt.variables, x.tolist()))
    s = np.linspace(0.0, _travel(opt.map_problem.case), opt.n_s)
    thetas, feed, why = _pass_poses(opt, values, s)
    strict_ok = why == ""
    if thetas is None:
        return PassEvaluation(x, False, why, np.full(len(s), np.nan), np.full((len(s), 6), np.nan), feed, s)
    with threadpool_limits(1):
        depth = np.array([_depth_at(opt, method, th, feed, full) for th in thetas])
    return PassEvaluation(x, True, "", depth, thetas, feed, s, strict_ok)


@dataclass(frozen=True, eq=False)
class Optimum:
    """Result of :func:`optimize_placement`.

    ``baseline`` and ``best`` are :class:`PassEvaluation` on the full structure (the SDM check);
    ``gain`` = best / baseline minimum depth; ``history`` the truncated-model objective of every
    evaluation (x, min depth m); ``stats`` evaluations and wall time.
    """

    problem: OptimizeProblem
    baseline: PassEvaluation
    best: PassEvaluation
    history: tuple
    stats: dict = field(default_factory=dict)

    @property
    def gain(self) -> float:
        b = self.baseline.min_depth_m
        return self.best.min_depth_m / b if b > 0 and math.isfinite(b) else math.nan


def _lhs(rng, n: int, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Latin-hypercube sample (n, d) of the box."""
    d = len(lo)
    u = (rng.permuted(np.tile(np.arange(n), (d, 1)), axis=1).T + rng.random((n, d))) / n
    return lo + u * (hi - lo)


def optimize_placement(opt: OptimizeProblem, method: MapMethod | None = None, *, n_starts: int = 12,
                       n_local: int = 2, max_local_evals: int = 40, seed: int = 0, progress=None) -> Optimum:
    """Maximize the minimum critical depth over the pass (see the module docstring).

    ``n_starts`` Latin-hypercube points plus the baseline (all variables 0, if inside the box);
    Nelder-Mead from the ``n_local`` best, each at most ``max_local_evals`` evaluations. The
    baseline and the optimum are re-evaluated on the full structure.
    """
    import time

    from scipy.optimize import minimize

    method = MapMethod() if method is None else method
    t0 = time.perf_counter()
    lo = np.array([opt.bounds[v][0] for v in opt.variables])
    hi = np.array([opt.bounds[v][1] for v in opt.variables])
    scale = hi - lo
    history = []
    budget = n_starts + 1 + n_local * max_local_evals

    def f(x):
        x = np.clip(x, lo, hi)
        ev = evaluate_pass(opt, x, method)
        history.append((x.copy(), ev.min_depth_m))
        if progress is not None:
            progress(min(len(history), budget), budget)
        d = ev.min_depth_m
        # infeasible below every feasible point; "no limit below depth_max" counts as depth_max
        return 1.0 if not math.isfinite(d) and d < 0 else -min(d, opt.depth_max_m) / opt.depth_max_m

    rng = np.random.default_rng(seed)
    starts = [np.clip(np.zeros(len(lo)), lo, hi)] + list(_lhs(rng, n_starts, lo, hi))
    vals = [f(x) for x in starts]
    order = np.argsort(vals, kind="stable")
    for j in order[:n_local]:
        if vals[j] >= 1.0:
            continue
        simplex = [starts[j]] + [np.clip(starts[j] + 0.1 * scale * e, lo, hi) for e in np.eye(len(lo))]
        minimize(f, starts[j], method="Nelder-Mead",
                 options={"initial_simplex": np.array(simplex), "maxfev": max_local_evals, "xatol": 1e-4,
                          "fatol": 1e-4})
    best_x = max(history, key=lambda h: h[1])[0]
    base_x = np.zeros(len(lo))
    best = evaluate_pass(opt, best_x, method, full=True)
    base = evaluate_pass(opt, base_x, method, full=True)
    return Optimum(problem=opt, baseline=base, best=best, history=tuple(history),
                   stats={"evaluations": len(history), "wall_s": time.perf_counter() - t0})
