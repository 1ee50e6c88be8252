"""The force model's pass (:func:`identify.force_model.simulate_forces`) against the public
:func:`timedomain.simulate` of the same linearized problem.

Tolerance asserted: bit-identical time and force arrays (``assert_array_equal``). The model pass calls
the same setup and compiled kernel as ``simulate`` and only skips what the fit does not read (wall,
roughness, summary), so any difference is a change of the equations, not round-off.
"""

from dataclasses import replace

import numpy as np

#: A short pass (s): past the first contact of the aluminium pass's tool, so the cut is in it.
T_END_S = 0.16


def _simulate(case):
    from robolobes.identify.effects import ModelState
    from robolobes.identify.force_model import model_disc_count
    from robolobes.timedomain import LinearizedNewmark, SimulationProblem, simulate

    st = ModelState(case=case)
    run = simulate(SimulationProblem(st.robot(), case, t_end_s=T_END_S), LinearizedNewmark(n_discs=model_disc_count(case)),
                   verdict_companion=False)
    return np.asarray(run.t_s), np.asarray(run.force_workpiece_n)


def test_model_pass_equals_simulate():
    from robolobes.cases import load_case
    from robolobes.identify.effects import ModelState
    from robolobes.identify.force_model import _CACHE, simulate_forces

    case = load_case("tx200-aluminium")
    case = replace(case, law=replace(case.law, kte_n_per_m=3e4, kre_n_per_m=2e4))
    _CACHE.clear()
    t, f = simulate_forces(ModelState(case=case), T_END_S)
    t_ref, f_ref = _simulate(case)
    assert np.abs(f_ref).max() > 10.0      # the tool is in the cut: a force of tens of N
    np.testing.assert_array_equal(t, t_ref)
    np.testing.assert_array_equal(f, f_ref)
