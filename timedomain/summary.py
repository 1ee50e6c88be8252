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
import math

import numpy as np

from robolobes.cases.milling import principal_period
from robolobes.core.io import provenance
from robolobes.core.verdict import Verdict
from robolobes.linearize.model import MotionSprings

from .problem import LinearizedNewmark, SimulationProblem
from .result import SimulationResult, SimulationSummary
from .signals import chatter_frequency, force_stats, stability
from .workpiece import Workpiece

__all__ = ["summarize", "stability_verdict", "has_runout", "DECAY_LIMIT", "MIN_STEADY_PERIODS",
           "simulation_inputs"]

#: The window must be long enough for the slowest free robot mode to lose at least 20 % of its
#: amplitude over two thirds of it; shorter, ringing after the entry cannot be told from chatter.
DECAY_LIMIT = 0.8
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


def stability_verdict(result: SimulationResult, window: tuple[float, float],
                      slowest_decay_per_s: float | None) -> dict:
    """The time-domain stability verdict (the one policy; summary fields ``verdict_section``,
    ``verdict``, ``stability``, ``chatter_freq_hz``, ``nonsynchronous_peak_hz``,
    ``nonsynchronous_ratio``, ``note``).

    Once-per-principal-period samples (:func:`cases.milling.principal_period`: tooth period for a
    uniform pitch, else the revolution) of the TCP deviation (x, y) over the steady ``window``
    (:func:`timedomain.signals.stability`, ``rule="trend"``): unstable when the non-synchronous
    motion exceeds 5 % of the forced peak-to-peak and does not decay significantly (log-linear fit
    over 6 segments: dying out iff slope + 2 standard errors < -sigma/4, a quarter of the slowest
    free robot mode's decay rate), or when it grows significantly from more than 1e-5 of the forced
    motion (a slow instability caught early). The robot's slowest mode rings after the entry with a
    decay rate ``sigma = min(zeta w_n)`` (0.5-1 1/s for the TX200): if over two thirds of the window
    it would not fall below ``DECAY_LIMIT`` itself, the window cannot tell a ringing stable robot
    from chatter and the verdict is ``None``. Fewer than 30 principal periods (6 segments of 5
    sections): ``None``.
    """
    case = result.problem.case
    T = case.cut.spindle_period_s
    t = np.asarray(result.t_s)
    t0, t1 = window
    Tp, pname = principal_period(case.tool, case.cut)
    out: dict = {"verdict_section": f"once per {pname} period ({Tp * 1e3:.3f} ms)"}
    n_sec = int((t1 - t0) / Tp + 1e-9)
    if n_sec < 30:
        # the trend rule needs 6 segments of >= 5 sections
        note = (f"steady window {t0:.3f}-{t1:.3f} s holds {n_sec} {pname} periods; the stability "
                f"verdict needs 30: simulate longer")
        out.update(verdict=Verdict("undetermined", note), chatter_freq_hz=None, note=note)
        return out
    # a transient must decay at least at a quarter of the slowest free robot mode's rate
    # (cutting slows the decay near the boundary; slower than that is, over a window of a few
    # seconds, indistinguishable from saturated chatter: conservative)
    min_decay = 0.25 * slowest_decay_per_s if slowest_decay_per_s is not None else 0.0
    verdict = stability(t, result.tcp_deviation_m[:, :2], Tp, t_start_s=t0, t_end_s=t1, decay_limit=DECAY_LIMIT,
                        rule="trend", min_decay_per_s=min_decay)
    forced = "tooth" if (pname == "tooth" and not has_runout(case.tool)) else "spindle"
    cf = chatter_frequency(t, result.tcp_deviation_m[:, :2], 1.0 / T, teeth=case.tool.teeth, harmonics=forced,
                           t_start_s=t0, t_end_s=t1)
    ringing = None if slowest_decay_per_s is None else math.exp(-slowest_decay_per_s * (t1 - t0) * 2 / 3)
    stable = verdict.stable
    reason = (f"trend rule on once-per-{pname}-period samples: non-synchronous motion {verdict.ratio:.3g} of the "
              f"forced peak-to-peak (threshold {verdict.threshold:g}), trend {verdict.trend_per_s:+.3g} "
              f"+- {2 * verdict.trend_se_per_s:.2g} 1/s (2 SE), required decay {min_decay:.3g} 1/s")
    if not stable and ringing is not None and ringing > DECAY_LIMIT:
        # a free robot mode would itself lose less than the required 20 % over this window (and
        # close modes beat): ringing after the entry cannot be told from chatter
        stable = None
        reason = out["note"] = (f"window too short for a verdict: the slowest robot mode (decay rate "
                                f"{slowest_decay_per_s:.2f} 1/s) keeps {ringing:.2f} of its amplitude over two "
                                f"thirds of the {t1 - t0:.2f} s steady window; simulate longer")
    out["verdict"] = Verdict.from_stable(stable, reason)
    out["stability"] = {"ratio": verdict.ratio, "decay": verdict.decay, "threshold": verdict.threshold,
                        "trend_per_s": verdict.trend_per_s, "trend_se_per_s": verdict.trend_se_per_s,
                        "slowest_mode_decay_over_window": ringing}
    out["chatter_freq_hz"] = cf.freq_hz if stable is False else None
    out["nonsynchronous_peak_hz"] = cf.freq_hz
    out["nonsynchronous_ratio"] = cf.ratio
    return out


def _steady_fields(result: SimulationResult, slowest_decay_per_s: float | None) -> dict:
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
    out.update(stability_verdict(result, (t0, t1), slowest_decay_per_s))
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
              slowest_decay_per_s: float | None = None, wall_s: float | None = None) -> SimulationSummary:
    """The :class:`SimulationSummary` of a run (module docstring).

    Parameters
    ----------
    result : SimulationResult
    workpiece : Workpiece
        The part after the run (roughness).
    last_centre_x_m : float
        Tool centre along the feed at the end of the run, cut frame, m.
    slowest_decay_per_s : float, optional
        Smallest modal decay rate ``zeta w_n`` of the robot, 1/s (verdict window check).
    wall_s : float, optional
        Wall-clock time of the run, s.
    """
    fields = _model_fields(result.problem, result.method, float(result.t_s[-1]))
    fields.update(_steady_fields(result, slowest_decay_per_s))
    fields.update(_roughness_fields(result, workpiece, last_centre_x_m))
    return SimulationSummary(**fields, wall_s=wall_s)
