"""Timedomain: Newmark simulation of the flexible robot with regenerative milling, in the lobes'
shape: ``simulate(SimulationProblem(robot, case), LinearizedNewmark())``.

* :mod:`timedomain.problem` -- :class:`SimulationProblem`, the methods :class:`LinearizedNewmark`
  and :class:`NonlinearNewmark`, and the bounds on what sets memory and run time;
* :mod:`timedomain.result` -- :class:`SimulationResult`, :class:`SimulationSummary`;
* :mod:`timedomain.simulation` -- :func:`simulate`;
* :mod:`timedomain.delay` -- the delay-based regenerative model (:class:`DelayNewmark`), also for
  structures without robot (:class:`timedomain.delay.StructureProblem`);
* :mod:`timedomain.rate` -- the growth rate over the resolved, linear periods of a run;
* :mod:`timedomain.equations` -- the full and the linearized equations of a pass;
* :mod:`timedomain.drivers` -- the time loops (full, linearized in Python, compiled fast path);
* :mod:`timedomain.fastpath` -- the compiled linearized loop (numba);
* :mod:`timedomain.summary` -- statistics, verdict policy, roughness of a run;
* :mod:`timedomain.runout` -- the companion run that decides stability for a tool with runout;
* :mod:`timedomain.workpiece` -- the eraser-of-matter part (axial slices, column boundaries);
* :mod:`timedomain.workpiece_force` -- the milling force on the eroded part (law from
  :mod:`cases.milling`), prescribed runs;
* :mod:`timedomain.newmark` -- average-acceleration Newmark in residual form;
* :mod:`timedomain.verdict` -- the stability verdict (growth rate of the non-synchronous motion);
* :mod:`timedomain.signals` -- force statistics, chatter frequency, roughness;
* :mod:`timedomain.output` -- series, wall, JSON summary and plots of a run.
"""

if __name__ != "robolobes.timedomain":  # this folder imported by itself (from the repository root): a second copy
    raise ImportError(f"{__name__!r} is the folder of the robolobes.timedomain package: import robolobes.timedomain instead")

from .problem import DelayNewmark, LinearizedNewmark, NonlinearNewmark, SimulationError, SimulationProblem
from .result import SimulationResult, SimulationSummary
from .simulation import simulate

__all__ = ["simulate", "SimulationProblem", "SimulationResult", "SimulationSummary", "LinearizedNewmark",
           "NonlinearNewmark", "DelayNewmark", "SimulationError"]
