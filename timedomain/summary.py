"""The derived numbers of a simulated pass (:class:`~timedomain.result.SimulationSummary`): the model
description, force statistics, the stability verdict, the chatter frequency and the roughness.

* Force statistics over ``problem.stats_window_s`` (default: the steady window), per axis of the
  dynamometer (cut) frame, N; ``force_stats_paper_axes`` gives (Fx, Fy) as the paper's Tab. 10.
* Stability: the verdict policy is :func:`stability_verdict`, the only place where the verdict is
  decided (see its docstring).
* Roughness: ISO 4287 on the wall of the middle slice, Gaussian mean line with the ISO 4288
  cutoff 0.8 mm (waviness from the robot modes, wavelengths v/f of millimetres, is form, not
  roughness), over the part the tool has fully passed.

Every field is present on every run; what cannot be computed on a short run is ``None`` with the
reason in ``note`` (verdict, statistics) or ``roughness_note``. No range is ever inverted: a
steady window the run does not reach is ``None``, not ``[t0, t_end]`` with ``t_end < t0``.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from robolobes.cases.milling import principal_period
from robolobes.core.io import provenance
from robolobes.core.verdict import Verdict
from robolobes.linearize.model import MotionSprings

from .problem import LinearizedNewmark, SimulationProblem
from .result import SimulationResult, SimulationSummary
from .signals import chatter_frequency, force_stats
from .verdict import verdict_summary
from .workpiece import Workpiece

__all__ = ["summarize", "stability_verdict", "has_runout", "MIN_STEADY_PERIODS",
           "simulation_inputs"]

#: Spindle revolutions of steady cut needed for statistics and a verdict.
MIN_STEADY_PERIODS = 15
#: The finished wall must exceed the 0.8 mm cutoff's run-in and run-out plus a sampling length.
MIN_WALL_M = 2.5e-3


def has_runout(tool) -> bool:
    """Whether the teeth's radii differ (runout)."""
    return max(tool.runout_m) - min(tool.runout_m) > 0


def _damping_scale(robot) -> float | None:
    """Motion-axis damping over the spec's, if it is one common factor (else None)."""
    springs = [e for e in robot.elements if isinstance(e, MotionSprings)]
    base = np.asarray(robot.spec.joint_damping, dtype=float)
    if len(springs) != 1 or not np.all(base > 0):
        return None
    r = np.asarray(springs[0].damping, dtype=float) / base
    return float(r[0]) if np.allclose(r, r[0], rtol=1e-12, atol=0) else None


def _describe(obj):
    """A JSON-able description of a (nested) dataclass for the provenance hash."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {"type": type(obj).__name__, **{f.name: _describe(getattr(obj, f.name))
                                                for f in dataclasses.fields(obj) if not f.name.startswith("_")}}
    if isinstance(obj, dict):
        return {str(k): _describe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_describe(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if obj is None or isinstance(obj, (bool, int, float, str, np.generic)):
        return obj
    return repr(obj)


def simulation_inputs(problem: SimulationProblem, method) -> dict:
    """What determines a run: the case, the robot (spec and elements), the method and the times."""
    r = problem.robot
    return {"case": _describe(problem.case), "robot_spec": _describe(r.spec), "variant": r.variant,
            "elements": [_describe(e) for e in r.elements], "method": _describe(method),
            "t_end_s": problem.t_end_s, "stats_window_s": problem.stats_window_s}


def _model_fields(problem: SimulationProblem, method, t_end_s: float) -> dict:
    r = problem.robot
    return {"variant": r.variant, "elements": tuple(e.name for e in r.elements), "damping_scale": _damping_scale(r),
            "linearized": isinstance(method, LinearizedNewmark), "spindle_rpm": problem.case.cut.spindle_rpm,
            "t_end_s": t_end_s, "provenance": provenance(simulation_inputs(problem, method))}


def _force_fields(result: SimulationResult, window: tuple[float, float]) -> dict:
    """Force statistics (cut frame and paper axes) over ``problem.stats_window_s`` if the run covers
    it, else over the steady ``window``."""
    t = np.asarray(result.t_s)
    sw = result.problem.stats_window_s
    win = sw if sw and t[0] <= sw[0] < sw[1] <= t[-1] else window
    fs = force_stats(t, result.force_workpiece_n, *win)
    fp = force_stats(t, result.force_paper_axes_n, *win)
    return {"force_stats_window_s": (fs.t_start_s, fs.t_end_s),
            "force_stats": {ax: {"min": fs.min_n[i], "max": fs.max_n[i], "mean": fs.mean_n[i], "rms": fs.rms_n[i]}
                            for i, ax in enumerate("xyz")},
            "force_stats_paper_axes": {ax: {"min": fp.min_n[i], "max": fp.max_n[i], "mean": fp.mean_n[i],
                                            "rms": fp.rms_n[i]} for i, ax in enumerate("xy")}}


def stability_verdict(result: SimulationResult, window: tuple[float, float], poles_rad_s=()) -> dict:
    """The time-domain stability verdict, the one policy: :func:`timedomain.verdict.verdict_summary`
    on the TCP deviation (x, y) over the steady ``window`` (the rule is stated once, in
    :mod:`timedomain.verdict`: growth rate of the non-synchronous motion with its 95 % interval,
    saturated chatter by the regenerative chip ratio, no decision on a window shorter than the
    structure's beat period ``poles_rad_s``), plus the chatter frequency, reported when unstable and
    the peak is a spectral line (:attr:`timedomain.signals.ChatterFrequency.is_line`: saturated
    chatter that is not periodic has a band, not a frequency).
    """
    case = result.problem.case
    t = np.asarray(result.t_s)
    dev = np.asarray(result.tcp_deviation_m)[:, :2]
    out = verdict_summary(t, dev, case.tool, case.cut, window, poles_rad_s=poles_rad_s)
    Tp, pname = principal_period(case.tool, case.cut)
    forced = "tooth" if (pname == "tooth" and not has_runout(case.tool)) else "spindle"
    cf = chatter_frequency(t, dev, 1.0 / case.cut.spindle_period_s, teeth=case.tool.teeth, harmonics=forced,
                           t_start_s=window[0], t_end_s=window[1])
    stable = out.pop("stable")
    out["verdict"] = Verdict(out["verdict"], out.pop("verdict_reason") or "")
    out["chatter_freq_hz"] = cf.freq_hz if (stable is False and cf.is_line) else None
    out["nonsynchronous_peak_hz"] = cf.freq_hz
    out["nonsynchronous_ratio"] = cf.ratio
    out["nonsynchronous_coherence"] = cf.coherence
    return out


def _steady_fields(result: SimulationResult, poles_rad_s=()) -> dict:
    """Steady window clipped to the run, statistics and verdict over it (or None with a note)."""
    T = result.problem.case.cut.spindle_period_s
    t = np.asarray(result.t_s)
    t0, t1 = result.steady_window_s
    t1 = min(t1, float(t[-1]))
    if t1 <= t0:
        note = (f"the run ends at {t[-1]:.3f} s, before the steady cut starts ({t0:.3f} s): no verdict, "
                f"no statistics (simulate longer)")
        return {"note": note, "verdict": Verdict("undetermined", note)}
    out: dict = {"steady_window_s": (t0, t1)}
    if t1 - t0 < MIN_STEADY_PERIODS * T:
        out["note"] = (f"steady window {t0:.3f}-{t1:.3f} s holds fewer than {MIN_STEADY_PERIODS} revolutions: "
                       f"no verdict, no statistics (simulate longer)")
        out["verdict"] = Verdict("undetermined", out["note"])
        return out
    out.update(_force_fields(result, (t0, t1)))
    out.update(stability_verdict(result, (t0, t1), poles_rad_s))
    dy = result.tcp_deviation_m[(t >= t0) & (t <= t1), 1]
    out["tcp_deviation_y_um"] = {"min": float(dy.min() * 1e6), "max": float(dy.max() * 1e6)}
    return out


def _roughness_fields(result: SimulationResult, workpiece: Workpiece, last_centre_x_m: float) -> dict:
    """Roughness of the finished wall: from the entry face + R to the last tool-centre position - R."""
    R = result.problem.case.tool.radius_m
    x_lo = workpiece.x_entry_m + R
    x_hi = min(workpiece.x_exit_m, last_centre_x_m - R)
    if x_hi - x_lo <= MIN_WALL_M:
        return {"roughness_note": f"finished wall {max(0.0, x_hi - x_lo) * 1e3:.2f} mm long: too short for the "
                                  f"0.8 mm cutoff and its run-in/run-out (needs > {MIN_WALL_M * 1e3:.1f} mm); "
                                  f"simulate longer"}
    rough = workpiece.roughness(x_range_m=(x_lo, x_hi), form="gaussian", cutoff_m=0.8e-3)
    k = workpiece.discs.count // 2
    y = np.asarray(result.wall_y_m[k])
    x = np.asarray(result.wall_x_m)
    sel = (x >= x_lo) & (x <= x_hi)
    return {"wall_x_range_m": (x_lo, x_hi), "roughness_um": {"Ra": rough.ra_um, "Rq": rough.rq_um, "Rt": rough.rt_um},
            "roughness_evaluation_length_m": rough.evaluation_length_m,
            "wall_y_um": {"min": float(y[sel].min() * 1e6), "max": float(y[sel].max() * 1e6)}}


def summarize(result: SimulationResult, workpiece: Workpiece, *, last_centre_x_m: float,
              poles_rad_s=(), wall_s: float | None = None) -> SimulationSummary:
    """The :class:`SimulationSummary` of a run (module docstring).

    Parameters
    ----------
    result : SimulationResult
    workpiece : Workpiece
        The part after the run (roughness).
    last_centre_x_m : float
        Tool centre along the feed at the end of the run, cut frame, m.
    poles_rad_s : array (k,), complex, optional
        Poles of the linearized robot, rad/s (the verdict's shortest window, its beat period).
    wall_s : float, optional
        Wall-clock time of the run, s.
    """
    fields = _model_fields(result.problem, result.method, float(result.t_s[-1]))
    fields.update(_steady_fields(result, poles_rad_s))
    fields.update(_roughness_fields(result, workpiece, last_centre_x_m))
    return SimulationSummary(**fields, wall_s=wall_s)
