"""The milling pass: feed profile, TCP line, motor angles along the pass.

Tolerances and their reasons are stated next to each assertion.
"""

from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np
import pytest

from robolobes.linearize.kinematics import JointLimitWarning, UnreachableError, fk, jacobian
from robolobes.linearize.path import FeedProfile, Pass, PassError


def build(case):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", JointLimitWarning)   # Tab. 7: A3 2.86 deg past +145 (tested below)
        return Pass.from_case(case)


@pytest.fixture(scope="module")
def pas(alu_case):
    return build(alu_case)


# ------------------------------------------------------------------------------- feed profile
def test_profile_end_points(pas, alu_case):
    V = alu_case.cut.feed_rate_m_per_s(alu_case.tool)
    L = alu_case.path.travel_m(alu_case.tool)
    T = alu_case.path.ramp_s
    assert V == pytest.approx(3.7 / 60) and L == pytest.approx(0.102)     # 3700 mm/min; 1 + 10 + 90 + 1 mm
    assert pas.duration_s == pytest.approx(T + L / V, rel=1e-15)
    assert pas.s(0.0) == 0.0 and pas.velocity(0.0) == 0.0 and pas.acceleration(0.0) == 0.0
    te = pas.duration_s
    # at the end: exactly L, at rest (round-off of te - t: 1e-15)
    assert pas.s(te) == pytest.approx(L, abs=1e-15)
    assert abs(pas.velocity(te)) < 1e-15 and abs(pas.acceleration(te)) < 1e-15
    t = np.linspace(0, te, 20001)
    v = pas.velocity(t)
    assert v.max() == pytest.approx(V, rel=1e-15) and v.min() >= 0
    assert np.all(v[(t >= T) & (t <= te - T)] == V)
    # outside [0, te] the TCP is at rest
    assert pas.s(-1.0) == 0.0 and pas.s(te + 1) == pytest.approx(L) and pas.velocity(te + 1) == 0.0


def test_profile_continuity_and_jerk_bound(pas):
    prof = pas.profile
    T, V, te = prof.ramp_s, prof.feed_m_per_s, prof.duration_s
    J = prof.jerk_m_per_s3
    assert J == pytest.approx(4 * V / T ** 2)
    assert prof.max_acceleration_m_per_s2 == pytest.approx(2 * V / T)
    # continuity of s, v, a at every switching time (one-sided values 1e-12 s apart: jumps would be
    # O(1) x a quantity; continuity gives O(1e-12) x its derivative)
    for ts in (T / 2, T, te - T, te - T / 2):
        left, right = prof.state(ts - 1e-12), prof.state(ts + 1e-12)
        for x0, x1, scale in zip(left[:3], right[:3], (V * 1e-12, J * 1e-12, J * 1e-12)):
            assert abs(x1 - x0) <= 2 * scale + 1e-15
    # jerk piecewise constant in {-J, 0, +J}; a is its integral, v of a, s of v (finite differences,
    # dt = 1e-5 s: central differences of cubics are exact up to dt^2 J ~ 1e-8 of the scale)
    t = np.linspace(0, te, 200001)
    s, v, a, j = prof.state(t)
    assert set(np.unique(np.round(j / J, 12))) <= {-1.0, 0.0, 1.0}
    dt = t[1] - t[0]
    assert np.abs(np.diff(a) / dt).max() <= J * (1 + 1e-9)
    assert np.allclose(np.gradient(s, dt)[1:-1], v[1:-1], atol=1e-6 * V)
    assert np.allclose(np.gradient(v, dt)[1:-1], a[1:-1], atol=1e-3 * prof.max_acceleration_m_per_s2)
    assert prof.acceleration(T / 2) == pytest.approx(2 * V / T, rel=1e-14)
    assert np.abs(a).max() <= 2 * V / T * (1 + 1e-14)


def test_time_at_inverts_s(pas):
    t = np.linspace(1e-3, pas.duration_s - 1e-3, 5001)
    # bisection to double precision; away from the rest points ds/dt > 0 so t is well determined
    assert np.abs(pas.time_at_s(pas.s(t)) - t).max() < 1e-9
    assert pas.time_at_s(0.0) == 0.0 and pas.time_at_s(pas.travel_m) == pytest.approx(pas.duration_s)


def test_profile_errors():
    with pytest.raises(PassError, match="too short"):
        FeedProfile(travel_m=0.001, feed_m_per_s=0.1, ramp_s=0.1)
    with pytest.raises(PassError, match="> 0"):
        FeedProfile(travel_m=0.1, feed_m_per_s=0.0, ramp_s=0.1)


# ------------------------------------------------------------------------------- geometry
def test_tool_vertical_and_feed_perpendicular(pas):
    # Tab. 7 angles are printed to 0.01 deg: tool axis vertical to 3.4e-5 rad (see
    # test_kinematics.test_tab7_tool_axis_vertical_to_angle_rounding) -> 1e-4 here.
    assert np.allclose(pas.tool_axis, [0, 0, -1], atol=1e-4)
    assert abs(pas.direction @ pas.tool_axis) < 1e-4
    assert np.allclose(pas.direction, [1, 0, 0])
    assert pas.branch_name == "front-up-noflip"


def test_tcp_on_line_constant_orientation(pas):
    # FK of the IK motor angles: on the straight line to 1e-9 m, orientation constant to 1e-9
    # (closed-form IK is exact to round-off, observed ~1e-15)
    t = np.linspace(0, pas.duration_s, 4001)
    th = pas.theta(t)
    p, R = fk(pas.robot, th)
    d = p - pas.start_position
    off_line = d - (d @ pas.direction)[:, None] * pas.direction
    assert np.abs(off_line).max() < 1e-9
    assert np.abs(p - pas.tcp_position(t)).max() < 1e-9
    assert np.abs(R - pas.rotation).max() < 1e-9
    # travel: from the start to the end of the pass
    assert np.allclose(pas.tcp_position(pas.duration_s) - pas.start_position, pas.travel_m * pas.direction)


def test_theta_continuous_from_start_pose(pas, alu_case):
    # theta(0) is the start pose as given (A3 = -212.14 deg, not +147.86)
    assert np.array_equal(pas.theta(0.0), alu_case.path.start_q_rad)
    assert math.degrees(pas.theta(0.0)[2]) == pytest.approx(-212.14)
    n = 20001
    t, th = pas.theta_table(n)
    assert t.shape == (n,) and th.shape == (n, 6)
    assert np.array_equal(th, pas.theta(t))
    # no branch jump: adjacent steps bounded by max |theta_dot| dt (+1 % for the variation within
    # a step); a 2 pi jump would be 6 orders of magnitude above.
    dt = t[1] - t[0]
    qd = pas.theta_dot(t)
    steps = np.abs(np.diff(th, axis=0))
    assert np.all(steps <= np.abs(qd).max(axis=0) * dt * 1.01 + 1e-15)
    assert steps.max() < 1e-5
    assert np.all(np.sign(np.sin(th[:, 4])) > 0)       # wrist stays on its branch
    # theta_dot against central differences of theta (h = 1e-5 s; error ~h^2 theta''' ~ 1e-10)
    tm = np.linspace(0.2, pas.duration_s - 0.2, 7)
    h = 1e-5
    fd = (pas.theta(tm + h) - pas.theta(tm - h)) / (2 * h)
    assert np.allclose(fd, pas.theta_dot(tm), atol=1e-8)


def test_theta_at_s_matches_pose_and_jacobian(pas):
    s = 0.05
    p, R = pas.pose_at(s)
    assert np.allclose(p, pas.start_position + [s, 0, 0]) and np.array_equal(R, pas.rotation)
    th = pas.theta_at_s(s)
    p2, R2 = fk(pas.robot, th)
    assert np.abs(p2 - p).max() < 1e-12 and np.abs(R2 - R).max() < 1e-12
    assert pas.theta_at_s(np.array([[0.01, 0.02]])).shape == (1, 2, 6)
    J = jacobian(pas.robot, th)
    qd = pas.theta_dot(pas.time_at_s(s))
    assert np.allclose(J @ qd, np.r_[pas.feed_m_per_s * pas.direction, 0, 0, 0], atol=1e-12)


def test_part_entry_exit(pas, alu_case):
    D, a = alu_case.tool.diameter_m, alu_case.path.approach_m
    assert pas.part_entry_s == pytest.approx(a)                              # 1 mm
    assert pas.part_exit_s == pytest.approx(a + D + alu_case.path.part_length_m)  # 101 mm
    # ae = 4 mm < R = 5 mm: edge contact over the chord w = sqrt(R^2 - (R - ae)^2) = 4.899 mm
    w = math.sqrt(0.005 ** 2 - 0.001 ** 2)
    assert pas.contact_entry_s == pytest.approx(a + 0.005 - w)
    assert pas.contact_exit_s == pytest.approx(a + 0.005 + 0.090 + w)
    for s_, t_ in ((pas.part_entry_s, pas.part_entry_t), (pas.part_exit_s, pas.part_exit_t),
                   (pas.contact_entry_s, pas.contact_entry_t), (pas.contact_exit_s, pas.contact_exit_t)):
        assert pas.s(t_) == pytest.approx(s_, abs=1e-12)
    # entry during the ramp for aluminium: the ramp covers V T / 2 = 3.08 mm > 1 mm approach
    assert pas.part_entry_t < alu_case.path.ramp_s


def test_pose_at_errors(pas):
    with pytest.raises(PassError, match="outside the pass"):
        pas.pose_at(-0.001)
    with pytest.raises(PassError, match="outside the pass"):
        pas.theta_at_s(pas.travel_m + 0.001)
    with pytest.raises(PassError):
        pas.theta_table(1)


def test_tab7_warning_at_construction(alu_case):
    with pytest.warns(JointLimitWarning, match=r"joint A3 \(sample 0\) = -212\.14 deg, wrapped to \+147\.86 deg, "
                                               r"is 2\.86 deg past its upper limit \+145\.00 deg"):
        Pass.from_case(alu_case)


def test_steel_case_builds(steel_case):
    steel = steel_case
    ps = build(steel)
    assert ps.feed_m_per_s == pytest.approx(0.28 / 60)
    assert ps.duration_s == pytest.approx(0.1 + 0.102 / (0.28 / 60))
    assert np.array_equal(ps.theta(0.0), steel.path.start_q_rad)


def test_pass_errors(alu_case):
    too_long_ramp = dataclasses.replace(alu_case, path=dataclasses.replace(alu_case.path, ramp_s=5.0))
    with pytest.raises(PassError, match="too short for two 5 s ramps"):
        build(too_long_ramp)
    plunge = dataclasses.replace(alu_case, cut=dataclasses.replace(alu_case.cut, feed_direction=(0.0, 0.0, 1.0)))
    with pytest.raises(PassError, match="not perpendicular"):
        build(plunge)
    far = dataclasses.replace(alu_case, path=dataclasses.replace(alu_case.path, part_length_m=2.0))
    with pytest.raises(UnreachableError, match=r"at s = [0-9.]+ mm of the pass"):
        build(far)
