"""What ``robolobes optimize`` writes about its result: ``optimize.json`` (:func:`optimize_json`),
the optimum's case TOML (:func:`optimum_case_toml`), the figure (:func:`plot_optimum`) and the
``robolobes lobes`` command that checks the optimum (:func:`lobes_check_command`).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

__all__ = ["optimize_json", "optimum_case_toml", "plot_optimum", "lobes_check_command", "CM3_PER_MIN"]


def optimum_case_toml(case_ref: str, res) -> str:
    """The case TOML of the optimum: the case's own file with the optimum's feed direction and
    start pose (and, for the MRR objective, its speed at the case's feed per tooth), so that
    ``robolobes lobes --case THIS --q-deg WORST`` checks the optimum's limit in the optimum's cut
    frame (a yawed part feeds along another base direction)."""

    from robolobes.cases.loader import case_table
    from robolobes.identify.model_toml import dumps

    src, data = case_table(case_ref)
    robot = data.get("robot")
    if isinstance(robot, str) and robot.endswith(".toml") and not Path(robot).is_absolute():
        data["robot"] = str((src.parent / robot).resolve())
    data["name"] = f"{data.get('name', src.stem)}-optimum"
    cut = data.setdefault("cut", {})
    cut["feed_direction"] = [float(v) for v in res.best.feed]
    rpm0 = float(cut.get("spindle_rpm", res.best.rpm))
    if res.problem.objective == "mrr" and rpm0 != res.best.rpm:
        # the optimum's speed, at the case's feed per tooth (the feed rate scales with the speed)
        cut["spindle_rpm"] = float(res.best.rpm)
        if "feed_mm_per_min" in cut:
            cut["feed_mm_per_min"] = float(cut["feed_mm_per_min"]) * res.best.rpm / rpm0
    data.setdefault("pass", {})["start_pose"] = [float(v) for v in np.degrees(res.best.theta[0])]
    return f"# {data['name']}: case {case_ref} with the placement found by robolobes optimize\n" + dumps(data)


def plot_optimum(res, path) -> None:
    """Critical depth along the pass and the worst pass pose, baseline and optimum, as a PNG at ``path``."""
    from robolobes.core.io import pyplot, save_figure
    from robolobes.linearize.kinematics import fk_frames

    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8))
    ax = axes[0]
    for ev, c, lab in ((res.baseline, "r", "paper's placement"), (res.best, "g", "optimum")):
        if not ev.feasible:
            continue
        ax.plot(ev.s_m * 1e3, np.minimum(ev.depth_m, res.problem.depth_max_m) * 1e3, "o-", color=c,
                label=f"{lab}, {ev.rpm:.0f} rpm")
    ax.axhline(res.problem.map_problem.case.cut.ap_m * 1e3, color="k", ls="--", label="cut depth")
    ax.set_xlabel("travel along the pass, mm")
    ax.set_ylabel("critical depth, mm")
    ax.set_ylim(bottom=0)
    ax.legend(fontsize=8)
    ax.set_title(f"gain {res.gain:.3g}" if res.problem.objective == "depth" else f"MRR gain {res.mrr_gain:.3g}")
    ax = axes[1]
    spec = res.problem.map_problem.case.robot
    for ev, c, lab in ((res.baseline, "r", "paper's placement"), (res.best, "g", "optimum")):
        if not ev.feasible:   # no pose to draw (e.g. no strictly feasible candidate)
            continue
        pts, _ = fk_frames(spec, ev.theta[ev.worst])
        pts = np.vstack([[0.0, 0.0, 0.0], pts]) * 1e3
        ax.plot(pts[:, 0], pts[:, 2], "o-", color=c, lw=3, label=f"{lab}, worst pass pose")
    ax.set_xlabel("x, mm")
    ax.set_ylabel("z, mm")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)


#: cm^3/min per m^3/s (the edge unit of the removal rate)
CM3_PER_MIN = 1e6 * 60.0


def _placement_json(opt, ev) -> dict:
    """Where a candidate puts the part and the tool (edge units), and its worst pass pose."""
    vals = dict.fromkeys(("x_offset_m", "y_offset_m", "z_offset_m", "yaw_rad", "tool_rotation_rad"), 0.0)
    vals.update(zip(opt.variables, np.asarray(ev.x, dtype=float).tolist()))
    return {"placement_offset_m": [vals["x_offset_m"], vals["y_offset_m"], vals["z_offset_m"]],
            "yaw_deg": math.degrees(vals["yaw_rad"]), "tool_rotation_deg": math.degrees(vals["tool_rotation_rad"]),
            "worst_pose_q_deg": np.degrees(ev.theta[ev.worst]).tolist() if ev.feasible else None}


def _ratio(a: float, b: float) -> float | None:
    return a / b if b > 0 and math.isfinite(b) and math.isfinite(a) else None


def _objective_json(opt, res) -> dict:
    """The objective, the speeds, and the removal rates of baseline and optimum (cm^3/min)."""
    base, best = res.baseline, res.best
    js = {"objective": opt.objective, "best_rpm": best.rpm if best.feasible else None,
          "baseline_rpm": base.rpm if base.feasible else None,
          "baseline_mrr_cm3_per_min": base.mrr_m3_per_s * CM3_PER_MIN if base.feasible else None,
          "optimized_mrr_cm3_per_min": best.mrr_m3_per_s * CM3_PER_MIN if best.feasible else None,
          "mrr_gain": _ratio(best.mrr_m3_per_s, base.mrr_m3_per_s)}
    if opt.objective == "mrr":
        sp = opt.eval_speeds_rpm
        js["mrr_speeds_rpm"] = {"min": float(sp[0]), "max": float(sp[-1]), "n": len(sp)}
        # per speed: the smallest limit over the pass poses (m; null: none below depth_max_m)
        js["min_depth_by_speed_m"] = {"rpm": sp, **{k: (np.min(ev.depth_by_speed_m, axis=0) if ev.feasible else None)
                                                     for k, ev in (("baseline", base), ("optimum", best))}}
        js["objective_note"] = ("MRR = a_p a_e v_f, v_f = f_z N n (the case's a_e and f_z). At a fixed speed it is "
                                "proportional to the depth, so the speed is free too: the maximum over the speeds of "
                                "(the smallest critical depth over the pass poses at that speed) x a_e f_z N n. "
                                "Baseline: the paper's placement at its own best speed in the same range. A depth "
                                "with no limit below depth_max_m counts as depth_max_m (the MRR is then a lower "
                                "bound).")
    else:
        js["objective_note"] = ("the smallest critical depth over the pass poses at the chosen speed; the MRR "
                                "(a_p a_e f_z N n at that depth) is proportional to it")
    return js


def _strict_json(opt, res, strict) -> dict:
    """The optimum with strict joint ranges (gains over the tolerant baseline: the paper's
    placement is not strictly feasible)."""
    ev = strict.best
    js = {"how": strict.how, "note": strict.note, "feasible": ev.feasible,
          "min_depth_m": ev.min_depth_m if ev.feasible else None, "rpm": ev.rpm if ev.feasible else None,
          "mrr_cm3_per_min": ev.mrr_m3_per_s * CM3_PER_MIN if ev.feasible else None,
          "gain_over_tolerant_baseline": _ratio(ev.min_depth_m, res.baseline.min_depth_m),
          "mrr_gain_over_tolerant_baseline": _ratio(ev.mrr_m3_per_s, res.baseline.mrr_m3_per_s),
          "strict_ok": ev.strict_ok}
    place = _placement_json(opt, ev)
    js.update(place if ev.feasible else dict.fromkeys(place))   # no strict-feasible candidate: no placement
    if strict.result is not None:
        js["evaluations"] = strict.result.stats["evaluations"]
    return js


def _objective_model(method) -> str:
    """Which structure the search evaluated (``method``: :class:`MapMethod`, None: the default)."""
    hz = None if method is None else method.reduce_max_freq_hz
    if hz is None:
        return "full model (the search and the reported depths are the same model)"
    return (f"modal truncation at {hz:g} Hz (the search only, not covered by the check: the reported depths are "
            "the full model's, the choice of the optimum is the truncated model's)")


def optimize_json(opt, res, strict, method=None) -> dict:
    """``optimize.json`` of an optimization ``res`` and its strict-limits companion ``strict``;
    ``method`` the :class:`MapMethod` of the search (None: the default, the full model)."""
    from .optimize import strict_violation

    base, best = res.baseline, res.best
    js = {"case": opt.map_problem.case.name, "variant": opt.map_problem.variant, "rpm": opt.map_problem.op_rpm,
          "variables": list(opt.variables), **_objective_json(opt, res),
          "baseline_min_depth_m": base.min_depth_m, "optimized_min_depth_m": best.min_depth_m, "gain": res.gain,
          "depth_max_m": opt.depth_max_m,
          "gain_at_least": (opt.depth_max_m / base.min_depth_m
                            if math.isinf(best.min_depth_m) and best.feasible and base.min_depth_m > 0 else None),
          **_placement_json(opt, best),
          "baseline_worst_pose_q_deg": np.degrees(base.theta[base.worst]).tolist() if base.feasible else None,
          "optimum_strict_ok": best.strict_ok, "baseline_strict_ok": base.strict_ok,
          "baseline_strict_violation": (strict_violation(opt.map_problem.case.robot, base.theta)
                                        if base.feasible else None),
          "baseline_feasible": base.feasible, "baseline_reason": base.reason,
          "optimum_feasible": best.feasible, "optimum_reason": best.reason,
          "depth_along_pass_m": {"s_m": best.s_m, "baseline": base.depth_m, "optimum": best.depth_m},
          "strict_limits": opt.strict, "strict_optimum": _strict_json(opt, res, strict),
          "evaluations": res.stats["evaluations"],
          "objective_model": _objective_model(method),
          "check": "minimum depths recomputed by SDM (m = 40) on the full, untruncated structure"}
    return js


def lobes_check_command(opt, js: dict) -> str:
    """The ``robolobes lobes`` command that recomputes the optimum's limit at its worst pass pose."""
    rpm = js["best_rpm"]
    return ("robolobes lobes --case DIR/optimum-case.toml --variant " + opt.map_problem.variant
            + " --q-deg=" + ",".join(f"{v:.6f}" for v in js["worst_pose_q_deg"])
            + f" --rpm-min {rpm:g} --rpm-max {rpm:g} --n-rpm 1 --depth-max-mm {opt.depth_max_m * 1e3:g} --json")
