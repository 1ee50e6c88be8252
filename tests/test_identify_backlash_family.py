"""The backlash candidate's family reuses runs instead of simulating them again, with the same numbers.

The family (``identify.cutting_effects.Backlash.family``) interpolates linearly between runs at the
nodes ``k RESOLUTION`` of the half-width. Two runs are reused: a width on a node reads that node's
run alone, and the node at width 0 is the state without a dead zone (for every variant but
``backlash``), whose run the force search has already memoised. The first two tests count the runs a
family asks for with a stand-in context (no simulation); the third checks on the compiled pass that a
dead zone of width 0 gives bit-identical forces to no dead zone (the kernel takes the linear springs
at width 0), which is what makes the reuse exact.
"""

import numpy as np
import pytest

from robolobes.cases import load_case
from robolobes.identify.cutting_effects import Backlash
from robolobes.identify.effects import ModelState
from robolobes.identify.force_model import _key, simulate_forces


class _Counting:
    """A stand-in for the force context: the raw averages of node state ``s`` are one (4, 3) array
    filled with the state's half-width in rad times 1e6 (so an interpolation has a closed form), and
    every state asked for is recorded."""

    def __init__(self):
        self.asked = []

    def raw_averages(self, state):
        self.asked.append(state)
        w = sum(e.params["half_width_rad"] for e in state.elements if e.type == "backlash")
        return [np.full((4, 3), w * 1e6)]


@pytest.fixture(scope="module")
def state():
    return ModelState(load_case("tx200-aluminium"), case_ref="tx200-aluminium")


def test_a_node_reads_its_own_run_alone(state):
    b = Backlash()
    ctx = _Counting()
    f = b.family(ctx, state)
    top = f(np.array([b.upper[0]]))                # on the last node: its run only, not its neighbour's
    assert len(ctx.asked) == 1
    assert ctx.asked[0].elements[0].params["half_width_rad"] == pytest.approx(b.upper[0], rel=1e-12)
    assert top[0][0, 0] == pytest.approx(300.0, rel=1e-12)   # 3e-4 rad * 1e6
    f(np.array([50 * b.RESOLUTION]))               # an inner node: one more run
    assert len(ctx.asked) == 2
    mid = f(np.array([50.25 * b.RESOLUTION]))      # between nodes 50 and 51: node 51 added, interpolated
    assert len(ctx.asked) == 3
    # closed form of the linear interpolation: 100 + 0.25 * (102 - 100) (rounding only)
    assert mid[0][0, 0] == pytest.approx(100.5, rel=1e-12)


def test_width_zero_is_the_state_without_dead_zone(state):
    b = Backlash()
    ctx = _Counting()
    b.family(ctx, state)(np.array([0.0]))
    assert ctx.asked[0].elements == () and _key(ctx.asked[0], 0.3) == _key(state, 0.3)   # the memo's key
    with_one = b.apply_values(state, (1e-4,))      # a state that holds a dead zone: width 0 removes it
    ctx = _Counting()
    b.family(ctx, with_one)(np.array([0.0]))
    assert _key(ctx.asked[0], 0.3) == _key(state, 0.3)
    # the backlash variant has a dead zone of its own (the robot file's): width 0 must stay explicit
    paper = ModelState(state.case, variant="backlash", case_ref="tx200-aluminium")
    ctx = _Counting()
    b.family(ctx, paper)(np.array([0.0]))
    assert [e.params["half_width_rad"] for e in ctx.asked[0].elements] == [0.0]


def test_dead_zone_of_width_zero_is_bit_identical_to_none(state):
    t_end = 0.08   # past the first contact at 0.067 s, so the cut's forces are in the compared run
    t0, f0 = simulate_forces(state, t_end)
    t1, f1 = simulate_forces(Backlash().apply_values(state, (0.0,)), t_end)
    assert np.abs(f0).max() > 1.0                  # the tool is in the cut (N)
    assert np.array_equal(t0, t1) and np.array_equal(f0, f1)   # exact: the same arithmetic
