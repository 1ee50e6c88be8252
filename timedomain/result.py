"""What a time-domain simulation returns: the time series (:class:`SimulationResult`) and the derived
numbers (:class:`SimulationSummary`, computed by :func:`timedomain.summary.summarize`)."""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from robolobes.core.io import to_jsonable
from robolobes.core.verdict import Verdict
from .problem import LinearizedNewmark, NonlinearNewmark, SimulationProblem

__all__ = ["PAPER_AXES", "SimulationSummary", "SimulationResult"]

#: How the paper's Tab. 10 axes relate to ours (evidence in :mod:`timedomain.workpiece_force`):
#: paper Fx = force on the tool along x_c = -F_workpiece.x ; paper Fy = -F_tool.y = F_workpiece.y.
PAPER_AXES = np.array([-1.0, 1.0])


@dataclass(frozen=True)
class SimulationSummary:
    """Derived numbers of a run. Every field is always present; a number that cannot be computed on
    this run is ``None`` and the matching ``*note`` field says why.

    Attributes
    ----------
    variant : str
        The robot's variant name (``"basic+"`` etc. when damping or extra elements were changed).
    elements : tuple of str
        Names of the robot's elements.
    damping_scale : float or None
        Motion-axis damping over the spec's (None if not one common factor).
    linearized : bool
        Method: :class:`LinearizedNewmark` (True) or :class:`NonlinearNewmark`.
    spindle_rpm : float
    t_end_s : float
        Last simulated time, s.
    steady_window_s : (float, float) or None
        Full engagement, clipped to the run, s; None when the run ends before it starts.
    force_stats_window_s : (float, float) or None
        Window of the force statistics, s.
    force_stats : dict or None
        Per axis ``x, y, z`` of the dynamometer (cut) frame: ``min, max, mean, rms`` in N.
    force_stats_paper_axes : dict or None
        The same for ``x, y`` in the paper's Tab. 10 sign convention (:data:`PAPER_AXES`), N.
    verdict_section : str or None
        Sampling of the stability verdict (once per principal period).
    verdict : Verdict
        ``stable`` / ``unstable`` / ``undetermined`` with its reason (:mod:`core.verdict`); JSON
        ``verdict``, ``stable`` (true / false / null) and ``verdict_reason``.
    growth_rate_per_s, growth_rate_se_per_s : float or None
        Growth rate of the non-synchronous motion and its standard error, 1/s.
    growth_rate_ci_per_s : (float, float) or None
        Its 95 % confidence interval, 1/s.
    regenerative_ratio : float or None
        Regenerative chip variation over the mean chip.
    chip_loss_fraction : float or None
        Share of the chip-weighted arc where teeth leave the cut (>= 0.05: saturated regime).
    duration_to_decide_s : float or None
        Steady window that would decide an undetermined verdict, s.
    stability : dict or None
        The verdict rule's other numbers (window, periods, degrees of freedom).
    chatter_freq_hz : float or None
        Chatter frequency (only when unstable, and only when the non-synchronous peak is a spectral
        line: ``nonsynchronous_coherence >= timedomain.signals.LINE_COHERENCE``), Hz.
    nonsynchronous_peak_hz : float or None
        Strongest non-synchronous peak of the TCP deviation, Hz.
    nonsynchronous_ratio : float or None
        Its amplitude over the forced response's.
    nonsynchronous_coherence : float or None
        Its phase coherence over the quarters of the window (1: a line; low: a band, as the
        bursts of saturated chatter whose sign changes from burst to burst).
    note : str or None
        Why the verdict or the statistics are missing.
    tcp_deviation_y_um : dict or None
        ``min, max`` of the normal TCP deviation over the steady window, um.
    wall_x_range_m : (float, float) or None
        Finished wall used for the roughness, m along the feed.
    roughness_um : dict or None
        ISO 4287 ``Ra, Rq, Rt`` of the middle slice, um.
    roughness_evaluation_length_m : float or None
    roughness_note : str or None
        Why the roughness is missing.
    wall_y_um : dict or None
        ``min, max`` of the middle slice's wall over ``wall_x_range_m``, um (cut frame y).
    verdict_basis : str
        "this run" or the companion run without runout that decided the verdict.
    runout_run_verdict : dict or None
        This run's own ``verdict, stable, verdict_reason, stability, chatter_freq_hz`` when a
        companion run decided.
    wall_s : float
        Wall-clock time of the run, s.
    provenance : dict
        :func:`robolobes.core.io.provenance` of the problem and method.
    """

    variant: str
    elements: tuple[str, ...]
    damping_scale: float | None
    linearized: bool
    spindle_rpm: float
    t_end_s: float
    steady_window_s: tuple[float, float] | None = None
    force_stats_window_s: tuple[float, float] | None = None
    force_stats: dict | None = None
    force_stats_paper_axes: dict | None = None
    verdict_section: str | None = None
    verdict: Verdict = Verdict("undetermined", "not evaluated")
    growth_rate_per_s: float | None = None
    growth_rate_se_per_s: float | None = None
    growth_rate_ci_per_s: tuple[float, float] | None = None
    regenerative_ratio: float | None = None
    chip_loss_fraction: float | None = None
    duration_to_decide_s: float | None = None
    stability: dict | None = None
    chatter_freq_hz: float | None = None
    nonsynchronous_peak_hz: float | None = None
    nonsynchronous_ratio: float | None = None
    nonsynchronous_coherence: float | None = None
    note: str | None = None
    tcp_deviation_y_um: dict | None = None
    wall_x_range_m: tuple[float, float] | None = None
    roughness_um: dict | None = None
    roughness_evaluation_length_m: float | None = None
    roughness_note: str | None = None
    wall_y_um: dict | None = None
    verdict_basis: str = "this run"
    runout_run_verdict: dict | None = None
    wall_s: float | None = None
    provenance: dict | None = None

    @property
    def stable(self) -> bool | None:
        """True / False, or None when the verdict is undetermined."""
        return self.verdict.stable

    def to_json(self) -> dict:
        """Every field, JSON-ready (tuples as lists, numpy scalars as Python numbers); the verdict as
        ``verdict``, ``stable`` and ``verdict_reason``."""
        out = {}
        for f in fields(self):
            v = getattr(self, f.name)
            out.update(v.to_json() if isinstance(v, Verdict) else {f.name: v})
        return to_jsonable(out)


@dataclass(frozen=True, eq=False)
class SimulationResult:
    """Time series and derived numbers of a simulated pass (SI; arrays read-only).

    Attributes
    ----------
    problem : SimulationProblem
    method : LinearizedNewmark or NonlinearNewmark
    t_s : array (N,)
    force_workpiece_n : array (N, 3)
        Force on the workpiece (what the dynamometer measures), cut frame axes, N.
    tcp_deviation_m : array (N, 3)
        TCP minus the commanded path, cut frame, m (z is NaN on the linearized path).
    spindle_angle_rad : array (N,)
    wall_x_m : array (n,), wall_y_m : array (K, n)
        Machined lateral wall per slice (y of the wall, cut frame; nominal ``-R`` for down-milling), m.
    steady_window_s : (float, float)
        Full engagement of the tool in the part (of the whole pass), s.
    stats : dict
        Run statistics (wall time, steps, Newton iterations, rejections).
    summary : SimulationSummary
    """

    problem: SimulationProblem
    method: LinearizedNewmark | NonlinearNewmark
    t_s: np.ndarray
    force_workpiece_n: np.ndarray
    tcp_deviation_m: np.ndarray
    spindle_angle_rad: np.ndarray
    wall_x_m: np.ndarray
    wall_y_m: np.ndarray
    steady_window_s: tuple[float, float]
    stats: dict
    summary: SimulationSummary | None = None

    @property
    def force_tool_n(self) -> np.ndarray:
        """Force on the tool, cut frame, (N, 3), N."""
        return -self.force_workpiece_n

    @property
    def force_paper_axes_n(self) -> np.ndarray:
        """(Fx, Fy) as the paper's Tab. 10 reports them, (N, 2), N (see ``PAPER_AXES``)."""
        return self.force_workpiece_n[:, :2] * PAPER_AXES
