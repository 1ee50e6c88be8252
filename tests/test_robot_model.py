"""The robot model is constant, as pinocchio's ``Model``: elements are immutable specifications,
the robot keeps each element's indices, and every algorithm works in a ``pin.Data`` of its own.

* one element instance in two robots with different coordinate layouts: each robot's forces and
  tangents equal those of a robot built with its own copy of the element (bitwise), and the
  element gains no attribute by being assembled;
* two threads linearizing one robot at different poses give the single-threaded numbers bitwise
  (both start together and the interpreter is asked to switch threads every microsecond; under
  the GIL a shared workspace is overwritten only between two statements, so this run is a stress
  check, and the structural checks below pin the design: no workspace on the robot);
* linearizing leaves the robot's state as it was (no workspace on the robot).
"""

import copy
import sys
import threading

import numpy as np
import pytest

from robolobes.cases import load_robot
from robolobes.linearize import build_model, element_forces, element_tangents, linearize, rigid_q
from robolobes.linearize.extra_elements import ServoDrive
from robolobes.linearize.tool import TcpOscillator

SPEC = load_robot("tx200")
REPS = 25  # rounds over the poses per thread
POSES = np.radians([[0.0, 30.0, 100.0, 0.0, -40.0, 0.0], [20.0, 10.0, 80.0, 30.0, -60.0, 45.0],
                    [-30.0, 45.0, 70.0, -20.0, -30.0, 90.0], [45.0, 0.0, 120.0, 60.0, -80.0, -45.0]])


def _state(robot, seed):
    rng = np.random.default_rng(seed)
    q = rigid_q(robot, POSES[0]) + 1e-3 * rng.standard_normal(robot.nq)
    return q, 1e-2 * rng.standard_normal(robot.nv)


@pytest.mark.parametrize("element", [ServoDrive(2, 5.0, 2e7, 2e3), TcpOscillator.one_axis(900.0, 0.03, 2e7, (1.0, 0.0, 0.0))],
                         ids=["servo_drive", "tcp_mode"])
def test_one_element_instance_in_two_robots(element):
    before = dict(vars(element))
    shared_a = build_model(SPEC, "basic", extra_elements=(element,))        # 6 + 1 coordinates
    shared_b = build_model(SPEC, "orthogonal", extra_elements=(element,))   # 18 + 1: other indices
    assert vars(element) == before  # assembling wrote nothing into the element
    for shared, variant in ((shared_a, "basic"), (shared_b, "orthogonal")):
        own = build_model(SPEC, variant, extra_elements=(copy.deepcopy(element),))
        q, v = _state(own, 3)
        np.testing.assert_array_equal(element_forces(shared, q, v, POSES[0]), element_forces(own, q, v, POSES[0]))
        for a, b in zip(element_tangents(shared, q, v, POSES[0]), element_tangents(own, q, v, POSES[0])):
            np.testing.assert_array_equal(a, b)
    # the element's own coordinate differs between the two robots: its force lands on each robot's own row
    i_a, i_b = shared_a.element_indices[-1], shared_b.element_indices[-1]
    assert i_a != i_b


def _lin_numbers(robot, theta):
    lin = linearize(robot, theta)
    return np.concatenate([lin.q, lin.M.ravel(), lin.C.ravel(), lin.K.ravel(), lin.J.ravel(), lin.p_tcp,
                           lin.modes().poles.view(float)])


def test_two_threads_share_one_robot():
    robot = build_model(SPEC, "gravity", extra_elements=(TcpOscillator.one_axis(900.0, 0.03, 2e7, (1.0, 0.0, 0.0)),))
    single = [_lin_numbers(robot, th) for th in POSES]
    out = {0: [], 1: []}
    start = threading.Barrier(2)

    def work(k):
        start.wait()
        for _ in range(REPS):
            for i in range(k, len(POSES), 2):
                out[k].append((i, _lin_numbers(robot, POSES[i])))

    old = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    try:
        threads = [threading.Thread(target=work, args=(k,)) for k in (0, 1)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    finally:
        sys.setswitchinterval(old)
    assert len(out[0]) == len(out[1]) == REPS * 2
    for k in (0, 1):
        for i, numbers in out[k]:
            np.testing.assert_array_equal(numbers, single[i])


def test_linearize_leaves_the_robot_unchanged(tx200_robot):
    robot = tx200_robot("orthogonal")
    assert not hasattr(robot, "data")
    state = {k: v for k, v in vars(robot).items()}
    linearize(robot, POSES[1])
    assert vars(robot).keys() == state.keys() and all(vars(robot)[k] is v for k, v in state.items())
