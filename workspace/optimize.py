"""Placement and tool-rotation optimization: maximize the minimum stable depth over the pass, or
the material removal rate.

Decision variables (any subset, ``over``): the pass start offset ``x, y, z`` (m, base frame), the
part's yaw about base z (rad), and the tool's rotation about its own axis (rad), constant along the
pass. Objectives (SDM, :func:`robolobes.lobes.solve`, on the structure of :class:`MapMethod`: the
full model by default, a modal truncation only when the method asks for one):

* ``depth``: the smallest critical depth over ``n_s`` poses along the (moved) pass at the chosen
  spindle speed;
* ``mrr``: the material removal rate ``MRR = a_p a_e v_f`` with ``v_f = f_z N n`` (m^3/s; the
  case's ``a_e`` and ``f_z``). At a fixed speed MRR is proportional to the depth, so this
  objective frees the speed too: ``max over n in speeds_rpm of [min over the pass poses of
  a_lim(n)] * a_e f_z N n``. A depth with no limit below ``depth_max_m`` counts as
  ``depth_max_m`` (so the MRR is then a lower bound).

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

Why the objective is the full model by default: the search returns the maximum of the model it
evaluates. A 300 Hz truncation moved placement-pose limits by up to 3.9 % (aluminium) and 10.2 %
(steel) from the full model, pose-dependent, so a truncated objective can rank two candidates the
wrong way and the full-model check of its optimum then reports a point that is not the full
model's optimum, without saying so. With the full model the search and the reported number are
the same model (the check repeats the objective's computation at the two reported points). A
truncation (``MapMethod(reduce_max_freq_hz=...)``) stays possible for speed: the reported depths
are then still the full model's, the choice of the point is not.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from robolobes.core.errors import BadInput
from robolobes.lobes import LobeProblem, PhysicalStructure, SemiDiscretization, solve

from .compute import build_robot, pose_structure
from .poses import solve_pose, start_pose, target
from .problem import MapMethod, MapProblem, series_modes

__all__ = ["OptimizeProblem", "Optimum", "PassEvaluation", "StrictOptimum", "evaluate_pass", "optimize_placement",
           "optimize_with_strict", "mrr_per_depth_m2_per_s", "strict_violation", "VARIABLES", "OBJECTIVES",
           "MAX_MRR_SPEEDS"]

VARIABLES = ("x_offset_m", "y_offset_m", "z_offset_m", "yaw_rad", "tool_rotation_rad")
OBJECTIVES = ("depth", "mrr")
#: speeds searched per candidate by the MRR objective (each multiplies the cost of an evaluation)
MAX_MRR_SPEEDS = 200


def mrr_per_depth_m2_per_s(case, rpm) -> np.ndarray:
    """Material removal rate per unit axial depth, ``a_e v_f`` with ``v_f = f_z N n`` (the case's
    radial depth and feed per tooth; the feed rate from ``Cut.feed_rate_m_per_s``), m^2/s, at each
    spindle speed ``rpm`` (S,) rpm. Times the depth (m) gives the MRR in m^3/s."""
    rpm = np.atleast_1d(np.asarray(rpm, dtype=float))
    cut = case.cut
    return np.array([cut.ae_m * replace(cut, spindle_rpm=float(n)).feed_rate_m_per_s(case.tool) for n in rpm])


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
    objective : {"depth", "mrr"}
        Maximize the minimum critical depth over the pass at ``map_problem.op_rpm``, or the
        material removal rate with the speed free over ``speeds_rpm`` (module docstring).
    speeds_rpm : tuple of float, rpm
        The speeds searched by the ``mrr`` objective (1 to :data:`MAX_MRR_SPEEDS`); must be empty
        for ``depth``.
    """

    map_problem: MapProblem
    variables: tuple
    bounds: dict
    n_s: int = 5
    depth_max_m: float = 0.05
    strict: bool = False
    min_sin: float = 0.05
    min_shoulder_m: float = 0.05
    objective: str = "depth"
    speeds_rpm: tuple = ()

    def __post_init__(self) -> None:
        if self.objective not in OBJECTIVES:
            raise BadInput(f"objective must be one of {', '.join(OBJECTIVES)}, got {self.objective!r}")
        sp = tuple(float(v) for v in np.asarray(self.speeds_rpm, dtype=float).reshape(-1))
        if self.objective == "mrr" and not (1 <= len(sp) <= MAX_MRR_SPEEDS
                                            and all(math.isfinite(v) and v > 0 for v in sp)):
            raise BadInput(f"the mrr objective needs 1 to {MAX_MRR_SPEEDS} finite speeds > 0 rpm, got {len(sp)}")
        if self.objective == "depth" and sp:
            raise BadInput("speeds_rpm is for the mrr objective; the depth objective uses map_problem.op_rpm")
        object.__setattr__(self, "speeds_rpm", sp)
        bad = [v for v in self.variables if v not in VARIABLES]
        if bad or not self.variables:
            raise BadInput(f"variables must be a non-empty subset of {', '.join(VARIABLES)}, got {self.variables!r}")
        for v in self.variables:
            lo, hi = self.bounds.get(v, (None, None))
            if lo is None or not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
                raise BadInput(f"bounds[{v}] must be finite (lo, hi) with lo < hi, got {self.bounds.get(v)!r}")
        if not 2 <= self.n_s <= 50:
            raise BadInput(f"n_s (poses along the pass) must be from 2 to 50, got {self.n_s}")

    @property
    def eval_speeds_rpm(self) -> np.ndarray:
        """The speeds each candidate is solved at (S,), rpm: the chosen speed, or the MRR range."""
        return np.array(self.speeds_rpm if self.objective == "mrr" else (self.map_problem.op_rpm,))


@dataclass(frozen=True)
class PassEvaluation:
    """The pass at one candidate: ``feasible`` (and ``reason`` if not), the critical depth at each
    pass pose ``depth_m`` (n_s,) m at the speed ``rpm`` (inf: none below ``depth_max_m``),
    ``theta`` (n_s, 6) rad, ``feed`` (3,), ``s_m`` (n_s,); ``strict_ok`` every pose inside the
    strict joint ranges. ``speeds_rpm`` (S,) the speeds solved, ``depth_by_speed_m`` (n_s, S) m,
    ``rpm`` the speed of ``depth_m`` (the chosen one, or the MRR's best), ``mrr_m3_per_s`` the
    removal rate there (the smallest depth capped at ``depth_max_m``; -inf when infeasible)."""

    x: np.ndarray
    feasible: bool
    reason: str
    depth_m: np.ndarray
    theta: np.ndarray
    feed: np.ndarray
    s_m: np.ndarray
    strict_ok: bool = False
    speeds_rpm: np.ndarray = field(default_factory=lambda: np.zeros(0))
    depth_by_speed_m: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    rpm: float = math.nan
    mrr_m3_per_s: float = -math.inf

    def objective(self, name: str) -> float:
        """The value maximized: ``min_depth_m`` (m) for "depth", ``mrr_m3_per_s`` for "mrr";
        -inf when infeasible."""
        return self.min_depth_m if name == "depth" else (self.mrr_m3_per_s if self.feasible else -math.inf)

    @property
    def min_depth_m(self) -> float:
        return float(np.min(self.depth_m)) if self.feasible else -math.inf

    @property
    def worst(self) -> int:
        return int(np.argmin(self.depth_m))


def _travel(case) -> float:
    import warnings

    from robolobes.linearize.kinematics import JointLimitWarning
    from robolobes.linearize.path import Pass

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", JointLimitWarning)
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


def _depths_at(opt: OptimizeProblem, method: MapMethod, theta, feed, full: bool) -> np.ndarray:
    """Critical depth (S,) m at one pose at each of ``opt.eval_speeds_rpm``."""
    mp = opt.map_problem
    from robolobes.linearize import linearize

    lin = linearize(build_robot(mp), theta)
    if full:
        structure = PhysicalStructure.from_linear(lin, feed)
        if series_modes(mp):
            structure, _ = pose_structure(mp, replace(method, reduce_max_freq_hz=None), lin, feed)
    else:
        structure, _ = pose_structure(mp, method, lin, feed)
    cut = replace(mp.case.cut, feed_direction=tuple(feed), spindle_rpm=mp.op_rpm)
    speeds = opt.eval_speeds_rpm
    res = solve(LobeProblem(structure, mp.case.tool, cut, mp.case.law), SemiDiscretization(m=method.m),
                speeds, depth_max_m=opt.depth_max_m, rtol=method.rtol, chunk=len(speeds))
    return np.asarray(res.depth_limit_m, dtype=float)


def _best_speed(opt: OptimizeProblem, depth_by_speed: np.ndarray) -> tuple[int, float]:
    """Index of the speed of the evaluation and the MRR there, m^3/s: the chosen speed for
    "depth"; for "mrr" the speed that maximizes (min over poses of the capped depth) x a_e v_f.
    ``depth_by_speed`` (n_s, S) m."""
    speeds = opt.eval_speeds_rpm
    low = np.min(np.minimum(depth_by_speed, opt.depth_max_m), axis=0)           # (S,) m
    mrr = low * mrr_per_depth_m2_per_s(opt.map_problem.case, speeds)            # (S,) m^3/s
    k = int(np.argmax(mrr)) if opt.objective == "mrr" else 0
    return k, float(mrr[k])


def evaluate_pass(opt: OptimizeProblem, x, method: MapMethod | None = None, *, full: bool = False) -> PassEvaluation:
    """The pass at the variables ``x`` (in the order of ``opt.variables``, SI)."""
    from threadpoolctl import threadpool_limits

    method = MapMethod() if method is None else method
    x = np.asarray(x, dtype=float)
    values = dict.fromkeys(VARIABLES, 0.0)
    values.update(zip(opt.variables, x.tolist()))
    s = np.linspace(0.0, _travel(opt.map_problem.case), opt.n_s)
    thetas, feed, why = _pass_poses(opt, values, s)
    assert feed is not None  # the pass has n_s >= 1 points, each sets the feed
    strict_ok = why == ""
    speeds = opt.eval_speeds_rpm
    if thetas is None:
        return PassEvaluation(x, False, why, np.full(len(s), np.nan), np.full((len(s), 6), np.nan), feed, s,
                              speeds_rpm=speeds, depth_by_speed_m=np.full((len(s), len(speeds)), np.nan))
    with threadpool_limits(1):
        by_speed = np.array([_depths_at(opt, method, th, feed, full) for th in thetas])   # (n_s, S)
    k, mrr = _best_speed(opt, by_speed)
    return PassEvaluation(x, True, "", by_speed[:, k], thetas, feed, s, strict_ok, speeds_rpm=speeds,
                          depth_by_speed_m=by_speed, rpm=float(speeds[k]), mrr_m3_per_s=mrr)


@dataclass(frozen=True, eq=False)
class Optimum:
    """Result of :func:`optimize_placement`.

    ``baseline`` and ``best`` are :class:`PassEvaluation` on the full structure (the SDM check);
    ``gain`` = best / baseline minimum depth (at their speeds); ``mrr_gain`` = best / baseline
    removal rate; ``history`` the objective of every evaluation on the method's model (the full
    model by default; x, value: min depth m, or MRR m^3/s); ``stats`` evaluations and wall time.
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

    @property
    def mrr_gain(self) -> float:
        b = self.baseline.mrr_m3_per_s
        return self.best.mrr_m3_per_s / b if b > 0 and math.isfinite(b) else math.nan


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
    baseline and the optimum are re-evaluated on the full structure; the baseline always with the
    tolerant joint ranges (the paper's placement is not strictly feasible).
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

    # the objective's largest possible value: depth_max_m (at the fastest speed, for the MRR)
    top = opt.depth_max_m * (1.0 if opt.objective == "depth"
                             else float(np.max(mrr_per_depth_m2_per_s(opt.map_problem.case, opt.eval_speeds_rpm))))

    def f(x):
        x = np.clip(x, lo, hi)
        ev = evaluate_pass(opt, x, method)
        v = ev.objective(opt.objective)
        history.append((x.copy(), v))
        if progress is not None:
            progress(min(len(history), budget), budget)
        # infeasible below every feasible point; "no limit below depth_max" counts as depth_max
        return 1.0 if not math.isfinite(v) and v < 0 else -min(v, top) / top

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
    # the baseline is the paper's placement as the paper cut it: inside the tolerant ranges (its
    # start pose is 2.86 deg past A3's limit), also for a strict problem, where it is therefore not
    # a candidate (its strict_ok is False) but the reference of the gain
    base = evaluate_pass(replace(opt, strict=False), base_x, method, full=True)
    return Optimum(problem=opt, baseline=base, best=best, history=tuple(history),
                   stats={"evaluations": len(history), "wall_s": time.perf_counter() - t0})


def strict_violation(spec, thetas) -> str:
    """Which joints of the poses ``thetas`` (n, 6) rad lie past their strict datasheet ranges
    (modulo 2 pi), and by how much (deg), e.g. ``"A3 2.86 deg past +145 deg at 2 of 5 pass poses"``; "" if none."""
    import warnings

    from robolobes.linearize.kinematics import JointLimitWarning, check_limits

    with warnings.catch_warnings():   # each angle's 2 pi representation nearest its range (no raise)
        warnings.simplefilter("ignore", JointLimitWarning)
        th = np.atleast_2d(check_limits(spec, np.atleast_2d(np.asarray(thetas, dtype=float)), tolerance_deg=180.0))
    parts = []
    for j, js in enumerate(spec.joints):
        lo, hi = (float(v) for v in js.range_rad)
        over_hi, under_lo = th[:, j] - hi, lo - th[:, j]
        for excess, bound in ((over_hi, hi), (under_lo, lo)):
            bad = excess > 0
            if bad.any():
                parts.append(f"{js.name} {math.degrees(float(excess.max())):.2f} deg past "
                             f"{math.degrees(bound):+.4g} deg at {int(bad.sum())} of {len(th)} pass poses")
    return "; ".join(parts)


@dataclass(frozen=True, eq=False)
class StrictOptimum:
    """The optimum within the strict joint ranges (no 5 deg tolerance).

    ``best`` (full-structure :class:`PassEvaluation`); ``how``: ``"tolerant optimum"`` (it is
    strict-feasible, so no second run), ``"strict run"`` (a second optimization with strict
    limits) or ``"strict problem"`` (the problem was strict already); ``note`` says why in words;
    ``result`` the second run's :class:`Optimum` when there was one.
    """

    best: PassEvaluation
    how: str
    note: str
    result: Optimum | None = None


def optimize_with_strict(opt: OptimizeProblem, method: MapMethod | None = None,
                         **kw) -> tuple[Optimum, StrictOptimum]:
    """:func:`optimize_placement` within the tolerance band, then the optimum with strict limits.

    The strict feasible set is a subset of the tolerant one. So when the tolerant optimum is
    strict-feasible, it is also the strict optimum (no strict point can beat a maximum over a
    superset it belongs to; a search that missed a better strict point missed a better tolerant
    point too), and no second run is made. Otherwise the optimization runs again with
    ``strict=True`` (same budget and seed). ``kw`` goes to :func:`optimize_placement`.
    """
    res = optimize_placement(opt, method, **kw)
    if opt.strict:
        return res, StrictOptimum(res.best, "strict problem", "the optimization itself used the strict ranges")
    if res.best.feasible and res.best.strict_ok:
        return res, StrictOptimum(res.best, "tolerant optimum",
                                  "the tolerant optimum lies inside the strict ranges; the strict feasible set is "
                                  "a subset of the tolerant one, so it is also the strict optimum (no second run)")
    strict = optimize_placement(replace(opt, strict=True), method, **kw)
    why = strict_violation(opt.map_problem.case.robot, res.best.theta) if res.best.feasible else "infeasible"
    return res, StrictOptimum(strict.best, "strict run",
                              f"the tolerant optimum is not strict-feasible ({why}): optimized again with "
                              "strict ranges", strict)
