"""Timedomain: Newmark simulation of the nonlinear flexible robot with regenerative milling.

* :mod:`timedomain.simulate` -- :class:`SimulationProblem`, :func:`simulate` (full nonlinear path,
  and the linearized fast path compiled in :mod:`timedomain.fastpath`);
* :mod:`timedomain.workpiece` -- the eraser-of-matter part (axial slices, column boundaries);
* :mod:`timedomain.cutting` -- the milling force of the tool on the part (law from :mod:`cases.milling`);
* :mod:`timedomain.newmark` -- average-acceleration Newmark in residual form;
* :mod:`timedomain.signals` -- force statistics, stability verdict, chatter frequency, roughness;
* :mod:`timedomain.output` -- series, wall, JSON summary and plots of a run.

Import from the submodules (``from timedomain.simulate import SimulationProblem, simulate``); the
package does not re-export ``simulate``, which would shadow the submodule of the same name.
"""
