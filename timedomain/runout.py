"""The runout companion run: with runout, the forced response alternates from tooth to tooth, with
the same period as a flip of the tooth period, so a once-per-tooth section of the run itself cannot
separate them. While every tooth cuts, runout changes neither the delays nor the linear stability
(:func:`cases.milling.regeneration`): the verdict and the chatter frequency come from the same run
without runout, up to the end of this run's steady window (at most 2 s of it)."""

from __future__ import annotations

from dataclasses import replace
from typing import Callable

from robolobes.cases.milling import principal_period

from .result import SimulationSummary
from .summary import has_runout
from .verdict import VERDICT_KEYS

__all__ = ["needs_companion", "companion_problem", "with_companion_verdict", "VERDICT_FIELDS"]

#: The summary fields the companion run decides.
#: (``verdict`` is the Verdict object: JSON verdict / stable / verdict_reason.)
VERDICT_FIELDS = tuple(k for k in VERDICT_KEYS if k not in ("stable", "verdict_reason")) + (
    "chatter_freq_hz", "nonsynchronous_peak_hz", "nonsynchronous_ratio", "nonsynchronous_coherence", "note")
#: Longest steady cut simulated by the companion run, s.
COMPANION_STEADY_S = 2.0


def needs_companion(problem, summary: SimulationSummary) -> bool:
    """A verdict was attempted (the steady window holds a section) on a tool with runout whose
    principal period is the tooth period."""
    tool = problem.case.tool
    return (summary.stability is not None and has_runout(tool)
            and principal_period(tool, problem.case.cut)[1] == "tooth")


def companion_problem(problem, t_end_s: float, steady_start_s: float):
    """The same problem without runout, to ``min(t_end_s, steady start + 2 s)``."""
    tool = problem.case.tool
    case0 = replace(problem.case, tool=replace(tool, runout_m=(0.0,) * tool.teeth))
    return replace(problem, case=case0, t_end_s=min(t_end_s, steady_start_s + COMPANION_STEADY_S))


def with_companion_verdict(summary: SimulationSummary, run: Callable, problem, t_end_s: float,
                           steady_start_s: float) -> SimulationSummary:
    """``summary`` with its verdict fields taken from the companion run ``run(problem0)`` (a
    :class:`SimulationResult`), this run's own verdict kept in ``runout_run_verdict``."""
    comp_problem = companion_problem(problem, t_end_s, steady_start_s)
    cs = run(comp_problem).summary
    own = {**summary.verdict.to_json(), "stability": summary.stability, "chatter_freq_hz": summary.chatter_freq_hz}
    basis = (f"companion run without runout to t = {comp_problem.t_end_s:.2f} s (runout forces a tooth-to-tooth "
             f"alternation indistinguishable from a flip)")
    return replace(summary, **{k: getattr(cs, k) for k in VERDICT_FIELDS}, runout_run_verdict=own,
                   verdict_basis=basis)
