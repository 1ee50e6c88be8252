"""The time-domain check of an optimum: a linearized Newmark run of the pass at the baseline's and
the optimum's placement, at a depth between their two lobe limits (so the check can fail either way).

:func:`time_domain_check` returns the block ``robolobes optimize --time-domain`` writes into
``optimize.json``.
"""

from __future__ import annotations

import math
from typing import cast

import numpy as np

__all__ = ["time_domain_check", "check_point"]


def check_point(res) -> tuple[float, float, float, float]:
    """Speed and depth of the time-domain check: ``(rpm, depth_m, baseline_limit_m,
    optimum_limit_m)``. The speed is the optimum's (the chosen one, or the MRR's best); the
    limits are the smallest over the pass at that speed. The depth lies between the two limits
    (their geometric mean, at most 1.5 times the baseline's; an optimum with no limit below
    ``depth_max_m`` counts as that), where the lobes predict "unstable" for the baseline and
    "stable" for the optimum -- a check that can fail either way. Without a gain there: the
    case's depth."""
    base, best = res.baseline, res.best
    dmax = res.problem.depth_max_m
    rpm = best.rpm if best.feasible else res.problem.map_problem.op_rpm
    b = o = math.nan
    if base.feasible and best.feasible:
        k = int(np.argmin(np.abs(np.asarray(base.speeds_rpm) - rpm)))
        b, o = float(np.min(base.depth_by_speed_m[:, k])), min(best.min_depth_m, dmax)
    if math.isfinite(b) and o > b * 1.02:
        return rpm, b * min(math.sqrt(o / b), 1.5), b, o
    return rpm, res.problem.map_problem.case.cut.ap_m, b, o


def _predict(depth_m: float, limit_m: float) -> str | None:
    """What the lobes predict at ``depth_m`` for a pass whose smallest limit is ``limit_m``."""
    return None if math.isnan(limit_m) else ("stable" if depth_m < limit_m else "unstable")


def _time_domain(opt, ev, t_end_s: float, depth_m: float, rpm: float) -> dict:
    """Linearized time-domain run of the pass at a candidate (its start pose and feed), at
    ``depth_m`` and ``rpm``: the verdict and chatter frequency."""
    import warnings
    from dataclasses import replace

    from robolobes.linearize.kinematics import JointLimitWarning
    from robolobes.timedomain import LinearizedNewmark, SimulationProblem, simulate
    from robolobes.timedomain.result import SimulationResult

    from .compute import build_robot

    mp = opt.map_problem
    case = mp.case
    case = replace(case, path=replace(case.path, start_q_rad=np.asarray(ev.theta[0])),
                   cut=replace(case.cut, feed_direction=tuple(float(v) for v in ev.feed), spindle_rpm=rpm,
                               ap_m=depth_m))
    with warnings.catch_warnings():   # the candidate's joint limits were checked by the optimizer
        warnings.simplefilter("ignore", JointLimitWarning)
        prob = SimulationProblem(build_robot(mp), case, t_end_s=None)
        t_end = min(t_end_s, prob.pass_duration_s)
        # a SimulationProblem with a Newmark method gives a SimulationResult (simulate's return is a union)
        run = cast(SimulationResult, simulate(SimulationProblem(build_robot(mp), case, t_end_s=t_end),
                                              LinearizedNewmark()))
    s = run.summary
    if s is None:
        raise RuntimeError("the time-domain check's simulation returned no summary")
    return {**s.verdict.to_json(), "chatter_freq_hz": s.chatter_freq_hz, "t_end_s": t_end,
            "depth_m": case.cut.ap_m, "rpm": rpm, "note": getattr(s, "note", None)}

def time_domain_check(opt, res, t_end_s: float) -> dict:
    """Baseline and optimum simulated at :func:`check_point` (speed rpm, depth m), each for at
    most ``t_end_s`` seconds of the pass: what the lobes predict there and each run's verdict
    (None for a placement that is not feasible)."""
    rpm, d, b, o = check_point(res)
    return {"depth_m": d, "rpm": rpm,
            "lobes_predict": {"baseline": _predict(d, b), "optimum": _predict(d, o)},
            "baseline": _time_domain(opt, res.baseline, t_end_s, d, rpm) if res.baseline.feasible else None,
            "optimum": _time_domain(opt, res.best, t_end_s, d, rpm) if res.best.feasible else None}
