"""The velocity kick of the linearized path (``LinearizedNewmark.kick_m_s``): zero changes nothing,
a kick leaves the run before it untouched and moves the tool centre at the asked normal speed."""

from __future__ import annotations

import warnings

import pytest
from numpy.testing import assert_array_equal

from robolobes import cases
from robolobes.timedomain.drivers import run_linearized
from robolobes.timedomain.equations import PassSetup
from robolobes.timedomain.problem import LinearizedNewmark, SimulationProblem
from robolobes.timedomain.simulation import SimulationError

STEEL = cases.load_case("tx200-steel")
T_END_S = 0.2  # before the tool reaches the steel part (0.264 s): the structure alone, no cut
KICK_AT_S = 0.1


def _records(robot, method):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the Tab. 7 pose is 2.86 deg past A3's limit (accepted, warned)
        S = PassSetup(SimulationProblem(robot("basic"), STEEL, t_end_s=T_END_S), method)
        return S, run_linearized(S, None)


def test_zero_kick_changes_nothing(tx200_robot):
    _, a = _records(tx200_robot, LinearizedNewmark())
    _, b = _records(tx200_robot, LinearizedNewmark(kick_m_s=0.0, kick_at_s=KICK_AT_S))
    assert_array_equal(a.center_m, b.center_m)
    assert_array_equal(a.force_tool_n, b.force_tool_n)


def test_kick_moves_the_centre_at_the_asked_normal_speed(tx200_robot):
    v = 1e-4  # m/s
    S, a = _records(tx200_robot, LinearizedNewmark())
    _, b = _records(tx200_robot, LinearizedNewmark(kick_m_s=v, kick_at_s=KICK_AT_S))
    k = int(round(KICK_AT_S / S.h))
    assert_array_equal(a.center_m[:k + 1], b.center_m[:k + 1])  # nothing changes before the kick
    d = b.center_m[k:k + 3] - a.center_m[k:k + 3]  # the kick's own motion (the system is linear: no cut)
    # Newmark: dq1 = h dv + h^2/4 (da0 + da1), so the first step moves the centre by v h up to the
    # accelerations' share, O(h |M^-1 C|, h^2 |M^-1 K|), well under 1 % at the 0.108 ms step (measured
    # 0.9997 v h, and 4e-4 v h along x); 3 % bounds it with room (a kick along x, of the wrong sign or
    # one step late fails). Along the feed (x) the minimum-norm change moves nothing at
    # first order (Jc dv = (0, v)); later steps couple through the structure.
    assert d[1, 1] / (v * S.h) == pytest.approx(1.0, rel=0.03)
    assert abs(d[1, 0]) < 0.03 * v * S.h


@pytest.mark.parametrize("kw", [dict(kick_m_s=float("nan")), dict(kick_m_s=1e-4, kick_at_s=-1.0),
                                dict(kick_m_s=2.0)])
def test_bad_kick_is_refused(kw):
    with pytest.raises(SimulationError):
        LinearizedNewmark(**kw)


def test_kick_after_the_run_is_refused_before_the_run(tx200_robot):
    # the run ends at 0.2 s: a kick at 0.3 s would never be applied
    with pytest.raises(SimulationError, match="after the run's end"):
        _records(tx200_robot, LinearizedNewmark(kick_m_s=1e-4, kick_at_s=0.3))


def test_python_reference_refuses_a_kick(tx200_robot):
    from robolobes.timedomain.drivers import run_linearized_python
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        S = PassSetup(SimulationProblem(tx200_robot("basic"), STEEL, t_end_s=T_END_S),
                      LinearizedNewmark(kick_m_s=1e-4, kick_at_s=KICK_AT_S))
    with pytest.raises(SimulationError, match="no velocity kick"):
        run_linearized_python(S, None)
