"""Kinematics of any 6-axis arm: the chain, the OPW closed form, the numerical inverse.

Test arms are built here from OPW parameters published for OPW solvers (Brandstötter et al. 2014's
parametrization) in other frame conventions (rotated joint frames, negative axes, zero offsets), so that the
detection cannot pass by reading robolobes' own frames back. Tolerances and reasons are stated next
to each assertion.
"""

from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np
import pinocchio as pin
import pytest

from robolobes import cases
from robolobes.core.errors import BadInput
from robolobes.linearize.chain import KinematicChain, chain_from_spec
from robolobes.linearize.ik_numeric import dls_solve
from robolobes.linearize.ik_opw import opw_geometry, require_opw
from robolobes.linearize.kinematics import (JointLimitError, JointLimitWarning, RobotStructureError, UnreachableError,
                                            WristSingularityError, arm_geometry, branch_of, check_structure, fk, ik,
                                            ik_all, ik_batch, jacobian, singularity_measures)
from robolobes.linearize.path import Pass


@pytest.fixture(scope="module")
def spec():
    return cases.load_robot("tx200")


# ----------------------------------------------------------------------------------------- chain
def test_tx200_chain_fk_equals_kinematics_fk(spec):
    # pinocchio's FK of the chain against robolobes' own numpy FK (two implementations of the same
    # convention): round-off, 1e-12 m and 1e-12 on rotation entries, at 300 random poses.
    chain = chain_from_spec(spec)
    assert chain_from_spec(spec) is chain
    Q = np.random.default_rng(11).uniform(-np.pi, np.pi, (300, 6))
    P, R = fk(spec, Q)
    P2, R2 = chain.fk(Q)
    assert np.abs(P2 - P).max() < 1e-12 and np.abs(R2 - R).max() < 1e-12
    assert np.abs(chain.jacobian(Q[0]) - jacobian(spec, Q[0])).max() < 1e-12
    assert np.array_equal(chain.range_rad, spec.joint_range_rad)


def test_chain_sign_and_offset_convention(spec):
    # controller angle q -> joint position sign * q + offset: a chain with signs and offsets at
    # controller angles q equals the plain chain at the joint positions (exact arithmetic, 1e-15).
    plain = chain_from_spec(spec)
    sign = np.array([-1, 1, -1, 1, -1, 1.0])
    off = np.array([0.1, -0.5, 0.3, 0.0, 1.0, -2.0])
    ch = KinematicChain.from_pinocchio(plain.model, plain.tcp_frame_id, sign, off, plain.range_rad, "t")
    q = np.array([0.2, 0.1, -0.4, 0.7, 0.5, -0.3])
    p, R = ch.fk(q)
    p0, R0 = plain.fk(sign * q + off)
    assert np.abs(p - p0).max() < 1e-15 and np.abs(R - R0).max() < 1e-15
    assert np.allclose(ch.controller_angles(ch.joint_positions(q)), q, atol=1e-15)


def test_chain_refuses_bad_parts(spec):
    plain = chain_from_spec(spec)
    m = plain.model
    with pytest.raises(BadInput, match="sign must be 6 values of"):
        KinematicChain.from_pinocchio(m, plain.tcp_frame_id, [1, 1, 1, 1, 1, 0.5], np.zeros(6), plain.range_rad)
    with pytest.raises(BadInput, match="lower <= upper"):
        KinematicChain.from_pinocchio(m, plain.tcp_frame_id, np.ones(6), np.zeros(6), plain.range_rad[:, ::-1])
    with pytest.raises(BadInput, match="TCP frame id 99"):
        KinematicChain.from_pinocchio(m, 99, np.ones(6), np.zeros(6), plain.range_rad)
    five = pin.Model()
    j = 0
    for _ in range(5):
        j = five.addJoint(j, pin.JointModelRZ(), pin.SE3.Identity(), f"j{j}")
    with pytest.raises(BadInput, match="6 revolute joints"):
        KinematicChain.from_pinocchio(five, 0, np.ones(6), np.zeros(6), plain.range_rad)


# ------------------------------------------------------------------------------- test arms (OPW)
# OPW parameters (a1, a2, b, c1, c2, c3, c4) in m, with the vendor's joint signs and zero offsets:
# theta_OPW = sign * q_vendor + offset. Sources: KR 6 R700 sixx, ROS-Industrial kuka_test_resources
# opw_kinematics_kr6r700sixx.yaml (as quoted in moveit_opw_kinematics_plugin's documentation);
# IRB 2400/10, the opw_kinematics / rs-opw-kinematics READMEs. "KR 16-2": values as recalled from the
# opw_kinematics project, not re-checked here: used as one more OPW geometry, not as a published check.
PUBLISHED = {
    "KUKA KR 6 R700 sixx": ((0.025, -0.035, 0.0, 0.400, 0.315, 0.365, 0.080),
                            (-1, 1, 1, -1, 1, -1), (0, -math.pi / 2, 0, 0, 0, 0)),
    "KUKA KR 16-2": ((0.260, -0.035, 0.0, 0.675, 0.680, 0.670, 0.115),
                     (-1, 1, 1, -1, 1, -1), (0, -math.pi / 2, 0, 0, 0, 0)),
    "ABB IRB 2400/10": ((0.100, -0.135, 0.0, 0.615, 0.705, 0.755, 0.085),
                        (1, 1, 1, 1, 1, 1), (0, 0, -math.pi / 2, 0, 0, 0)),
}
# pinocchio joint = URDF_SIGN * q_vendor + URDF_OFFSET: the test URDF's own zero and directions
URDF_SIGN = np.array([1, -1, 1, 1, -1, 1.0])
URDF_OFFSET = np.array([0.3, 0.0, -0.2, 0.1, 0.4, -1.0])
RANGE = np.radians([[-170, 170], [-190, 45], [-120, 156], [-185, 185], [-120, 120], [-350, 350]])
_E = np.eye(3)


def rodrigues(w, t):
    """Rotation by angle t about the unit axis w (closed form)."""
    K = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
    return np.eye(3) + math.sin(t) * K + (1 - math.cos(t)) * K @ K


def opw_lines(params, theta):
    """Axis lines (points (6, 3), directions (6, 3)) and TCP pose of the OPW arm at OPW angles theta,
    by the product of exponentials of the paper's zero pose (arm up, axes z y y z y z)."""
    a1, a2, b, c1, c2, c3, c4 = params
    C = np.array([a1 + a2, b, c1 + c2 + c3])
    pts0 = np.array([[0, 0, 0], [a1, 0, c1], [a1, 0, c1 + c2], C, C, C], dtype=float)
    dirs0 = _E[[2, 1, 1, 2, 1, 2]]
    Rm, tm = np.eye(3), np.zeros(3)
    pts, dirs = [], []
    for p0, w0, t in zip(pts0, dirs0, theta):
        pts.append(Rm @ p0 + tm)
        dirs.append(Rm @ w0)
        Ri = rodrigues(w0, t)
        Rm, tm = Rm @ Ri, Rm @ (p0 - Ri @ p0) + tm
    return np.array(pts), np.array(dirs), Rm, Rm @ (C + [0, 0, c4]) + tm


def chain_from_lines(pts, dirs, R_tcp, p_tcp, sign, offset, name, seed=0, bend_wrist_m=0.0):
    """A pinocchio chain with the given axis lines at its joint zero, in deliberately odd frames:
    local axes x, y, z or unaligned, random turns about each axis, origins shifted along the axes."""
    rng = np.random.default_rng(seed)
    model = pin.Model()
    parent, prev = 0, pin.SE3.Identity()
    for i in range(6):
        local = [_E[0], _E[1], _E[2], None][i % 4]
        if local is None:
            local = rng.normal(size=3)
            local /= np.linalg.norm(local)
            joint = pin.JointModelRevoluteUnaligned(local)
        else:
            joint = [pin.JointModelRX, pin.JointModelRY, pin.JointModelRZ][i % 4]()
        W = rodrigues(dirs[i], rng.uniform(-np.pi, np.pi)) @ _align(local, dirs[i])
        point = pts[i] + rng.uniform(-0.2, 0.2) * dirs[i]
        if i == 4:
            point = point + bend_wrist_m * np.cross(dirs[3], dirs[4])
        world = pin.SE3(W, point)
        parent = model.addJoint(parent, joint, prev.inverse() * world, f"J{i + 1}")
        prev = world
    fid = model.addFrame(pin.Frame("tcp", parent, prev.inverse() * pin.SE3(R_tcp, p_tcp), pin.FrameType.OP_FRAME))
    return KinematicChain.from_pinocchio(model, fid, sign, offset, RANGE, name)


def _align(a, b):
    """A rotation taking unit vector a to unit vector b."""
    v, c = np.cross(a, b), float(a @ b)
    if np.linalg.norm(v) < 1e-12:
        return np.eye(3) if c > 0 else rodrigues(np.cross(a, _E[np.argmin(np.abs(a))]) /
                                                  np.linalg.norm(np.cross(a, _E[np.argmin(np.abs(a))])), np.pi)
    return rodrigues(v / np.linalg.norm(v), math.atan2(np.linalg.norm(v), c))


def published_arm(name, bend_wrist_m=0.0):
    """The published arm as a chain whose pinocchio zero is the test URDF's zero."""
    params, vsign, voff = PUBLISHED[name]
    vsign, voff = np.array(vsign, float), np.array(voff)
    q_vendor0 = URDF_SIGN * (0 - URDF_OFFSET)             # controller angles at the pinocchio zero
    pts, dirs, R, p = opw_lines(params, vsign * q_vendor0 + voff)
    dirs = dirs * (vsign * URDF_SIGN)[:, None]            # pinocchio's positive rotation
    return chain_from_lines(pts, dirs, R, p, URDF_SIGN, URDF_OFFSET, name, seed=len(name), bend_wrist_m=bend_wrist_m)


def wrap(x):
    return (np.asarray(x) + np.pi) % (2 * np.pi) - np.pi


def random_poses(robot, n, seed, margin=0.05):
    """n random controller-angle vectors within the ranges, each at least `margin` from every
    singularity (shoulder m, elbow and wrist |sin|)."""
    rng = np.random.default_rng(seed)
    lo, hi = (robot.joint_range_rad if hasattr(robot, "joint_range_rad") else robot.range_rad).T
    q = rng.uniform(lo, hi, (4 * n, 6))
    m = singularity_measures(robot, q)
    ok = (m["shoulder"] > margin) & (m["elbow"] > margin) & (m["wrist"] > margin)
    assert ok.sum() >= n
    return q[ok][:n]


# --------------------------------------------------------------------------------- OPW detection
@pytest.mark.parametrize("name", sorted(PUBLISHED))
def test_detects_published_opw_parameters(name):
    # the arm is built from the published parameters in other frames (rotated joint frames, one
    # unaligned axis, negative axes, URDF zero offsets): detection must give the published lengths
    # back to round-off (1e-12 m), and the published OPW angles for joints 2-5 (joints 1 and 6
    # differ by a constant: the detected base x and flange zero are where the chain has them).
    params, vsign, voff = PUBLISHED[name]
    chain = published_arm(name)
    g = opw_geometry(chain)
    assert g.is_opw, g.defects
    assert np.allclose([g.a1, g.a2, g.b, g.c1, g.c2, g.c3, g.c4], params, atol=1e-12, rtol=0)
    Q = np.random.default_rng(3).uniform(-2, 2, (20, 6))
    th = g.sign * (chain.joint_positions(Q) - g.zero)
    d = wrap(th - (np.array(vsign) * Q + np.array(voff)))
    assert np.abs(d[:, 1:5]).max() < 1e-12
    assert np.ptp(d[:, 0]) < 1e-12 and np.ptp(d[:, 5]) < 1e-12


def test_tx200_branches_and_measures_through_the_chain(spec):
    # the geometric indicators on the TX200's chain against the TX200's own branch_of and
    # singularity_measures (Paul's method's definitions): the same branch at 300 random poses, the
    # same distances to round-off (1e-12).
    chain = chain_from_spec(spec)
    Q = np.random.default_rng(13).uniform(-np.pi, np.pi, (300, 6))
    assert np.array_equal(branch_of(chain, Q), branch_of(spec, Q))
    a, b = singularity_measures(chain, Q), singularity_measures(spec, Q)
    for key in ("shoulder", "elbow", "wrist"):
        assert np.abs(a[key] - b[key]).max() < 1e-12, key


def test_tx200_detected_as_opw_with_its_own_angles(spec):
    # robolobes' TX200 convention is OPW at its zero (arm up): all signs +1, zeros 0; the lengths
    # are the TOML's (a1 = 0.25 m shoulder, c2 = 0.95 m arm, NOTES.md), b = 0 (no lateral offset).
    g = opw_geometry(chain_from_spec(spec))
    assert g.is_opw
    assert np.array_equal(g.sign, np.ones(6)) and np.abs(g.zero).max() < 1e-15
    assert g.a1 == pytest.approx(0.25, abs=1e-12) and g.c2 == pytest.approx(0.95, abs=1e-12)
    assert abs(g.b) < 1e-12 and abs(g.a2) < 1e-12


def test_not_opw_is_told_why():
    bent = published_arm("KUKA KR 16-2", bend_wrist_m=0.01)
    g = opw_geometry(bent)
    assert not g.is_opw and "axes 4, 5, 6 do not meet" in g.defects[0]
    with pytest.raises(RobotStructureError, match="not an ortho-parallel arm with a spherical wrist: axes 4, 5, 6"):
        require_opw(bent)
    # axes 1 and 2 parallel (a SCARA-like shoulder): no arm plane, refused before any work
    pts, dirs, R, p = opw_lines(PUBLISHED["KUKA KR 16-2"][0], np.zeros(6))
    dirs = dirs.copy()
    dirs[1] = dirs[0]
    flat = chain_from_lines(pts, dirs, R, p, np.ones(6), np.zeros(6), "scara-like")
    with pytest.raises(RobotStructureError, match="axes 1 and 2 are parallel"):
        check_structure(flat)


# ------------------------------------------------------------------------------------ round trips
ARMS = ["tx200", "tx200-chain", *sorted(PUBLISHED)]


def make_arm(which, spec):
    if which == "tx200":
        return spec                       # robolobes' own closed form
    if which == "tx200-chain":
        return chain_from_spec(spec)      # the same arm through the OPW closed form
    return published_arm(which)


@pytest.mark.parametrize("which", ARMS)
def test_fk_ik_round_trip_every_branch(which, spec):
    # 300 random poses within the ranges, >= 0.05 from every singularity; every branch that exists.
    # FK(IK(x)) = x to 1e-10 (m, rotation entries), the branch named as asked, and IK(FK(q)) = q
    # (mod 2 pi) on q's own branch to 1e-10 rad.
    robot = make_arm(which, spec)
    Q = random_poses(robot, 300, seed=7)
    P, R = fk(robot, Q)
    for b in range(8):
        qb = ik_batch(robot, P, R, b, errors="nan")
        ok = ~np.isnan(qb[:, 0])
        assert ok.sum() >= 60, (b, ok.sum())
        P2, R2 = fk(robot, qb[ok])
        assert np.abs(P2 - P[ok]).max() < 1e-10 and np.abs(R2 - R[ok]).max() < 1e-10
        assert np.all(branch_of(robot, qb[ok]) == b)
    assert np.abs(wrap(ik_batch(robot, P, R, branch_of(robot, Q)) - Q)).max() < 1e-10


def paul_reference(g, p, R, b):
    """The TX200's inverse by Paul's decomposition in robolobes' own frames (a second method: wrist
    centre, planar two-link arm, scipy's z-y-z Euler angles for the wrist), one target, branch b."""
    from scipy.spatial.transform import Rotation
    shoulder, elbow, wrist = (b >> 2) & 1, (b >> 1) & 1, b & 1
    Rf = R @ g.tcp_rotation.T
    cx, cy, cz = p - Rf @ g.wrist_to_tcp - g.o0
    xs = (-1 if shoulder else 1) * math.sqrt(cx * cx + cy * cy - g.y_offset ** 2)
    q1 = math.atan2(cy, cx) - math.atan2(g.y_offset, xs)
    vx, vz = xs - g.o1[0], cz - g.o1[2]
    D = (vx * vx + vz * vz - g.a2 ** 2 - g.a3 ** 2) / (2 * g.a2 * g.a3)
    psi = (1 if shoulder == elbow else -1) * math.acos(D)
    q3 = psi + g.alpha2 - g.alpha3
    q2 = math.atan2(vx, vz) - math.atan2(g.a2 * math.sin(g.alpha2) + g.a3 * math.sin(q3 + g.alpha3),
                                         g.a2 * math.cos(g.alpha2) + g.a3 * math.cos(q3 + g.alpha3))
    M = (rodrigues(_E[2], q1) @ rodrigues(_E[1], q2 + q3)).T @ Rf
    q4, q5, q6 = Rotation.from_matrix(M).as_euler("ZYZ")
    if wrist:
        q4, q5, q6 = q4 + np.pi, -q5, q6 + np.pi
    return np.array([q1, q2, q3, q4, q5, q6])


def test_opw_equals_tx200_closed_form(spec):
    # two closed forms of the same arm (Paul's decomposition in robolobes' frames, written in the
    # test; the OPW formulas on the detected parameters, which every arm uses): the same angles on
    # every branch to 1e-10 rad, at 100 random poses.
    g = arm_geometry(spec)
    Q = random_poses(spec, 100, seed=8)
    P, R = fk(spec, Q)
    for b in range(8):
        o = ik_batch(spec, P, R, b, errors="nan")
        ok = np.flatnonzero(~np.isnan(o[:, 0]))
        assert len(ok) > 50
        ref = np.array([paul_reference(g, P[k], R[k], b) for k in ok])
        assert np.abs(wrap(o[ok] - ref)).max() < 1e-10


# ------------------------------------------------------------------------------ numerical inverse
def test_numerical_inverse_agrees_with_opw():
    # on an OPW arm both apply: damped least squares started 0.3 rad (per joint, random) away from
    # each OPW solution converges to it: 1e-9 rad.
    chain = published_arm("KUKA KR 16-2")
    Q = random_poses(chain, 40, seed=9, margin=0.2)
    P, R = fk(chain, Q)
    rng = np.random.default_rng(10)
    for b in range(8):
        qo = ik_batch(chain, P, R, b, errors="nan")
        for k in np.flatnonzero(~np.isnan(qo[:, 0]))[:10]:
            qn, res, _ = dls_solve(chain, P[k], R[k], qo[k] + rng.uniform(-0.3, 0.3, 6))
            assert res < 1e-12
            assert np.abs(wrap(qn - qo[k])).max() < 1e-9


def test_numerical_inverse_non_opw_arm_every_branch():
    # a KR 16 with a 10 mm wrist offset (not OPW): the numerical inverse on every branch from the
    # nearest OPW arm's closed form: FK(IK) = x to 1e-10, on the asked branch.
    bent = published_arm("KUKA KR 16-2", bend_wrist_m=0.01)
    Q = random_poses(bent, 12, seed=12, margin=0.1)
    P, R = fk(bent, Q)
    found = np.zeros(8, int)
    for p, r, q in zip(P, R, Q):
        for s in ik_all(bent, p, r):
            p2, r2 = fk(bent, s.q)
            assert np.abs(p2 - p).max() < 1e-10 and np.abs(r2 - r).max() < 1e-10
            assert branch_of(bent, s.q) == s.branch
            found[s.branch] += 1
        own = ik(bent, p, r, q_ref=q, limits=False)
        assert np.abs(wrap(own - q)).max() < 1e-9
    assert np.all(found >= 3), found


def test_numerical_path_keeps_the_branch_and_refuses_a_flip():
    # continuation along a path (each pose from the previous): the start pose's branch is kept; a
    # path through the wrist singularity is refused rather than followed onto the other branch.
    bent = published_arm("KUKA KR 16-2", bend_wrist_m=0.01)
    q0 = np.radians([10, -80, 60, 20, 40, 30])
    p0, R0 = fk(bent, q0)
    line = p0 + np.linspace(0, 0.2, 41)[:, None] * np.array([0.0, 1.0, 0.0])
    qs = ik_batch(bent, line, R0, branch_of(bent, q0), q_ref=q0)
    P2, _ = fk(bent, qs)
    assert np.abs(P2 - line).max() < 1e-10 and np.all(branch_of(bent, qs) == branch_of(bent, q0))
    sweep = np.array([q0 + [0, 0, 0, 0, t - q0[4], 0] for t in np.linspace(0.3, -0.3, 9)])
    Ps, Rs = fk(bent, sweep)
    q = sweep[0]
    with pytest.raises(WristSingularityError, match="wrist singularity"):
        for p, r in zip(Ps, Rs):
            q = ik(bent, p, r, q_ref=q, limits=False)


# ------------------------------------------------------------------------------------------ errors
@pytest.mark.parametrize("which", ["KUKA KR 16-2", "bent"])
def test_errors_as_today(which):
    chain = published_arm("KUKA KR 16-2", bend_wrist_m=0.01 if which == "bent" else 0.0)
    with pytest.raises(UnreachableError):
        ik(chain, np.array([5.0, 0, 1]), np.eye(3), branch=0)
    # wrist singular: a pose with theta5 = 0 (axes 4 and 6 aligned)
    g = opw_geometry(chain)
    th = np.array([0.2, 0.1, 0.3, 0.4, 0.0, 0.5])
    q = chain.controller_angles(g.sign * th + g.zero)
    p, R = fk(chain, q)
    with pytest.raises(WristSingularityError):
        ik(chain, p, R, q_ref=q, limits=False)
    # past a limit: the same reachable pose with joint 1 beyond its range (range +-170 deg)
    q = np.radians([10, -80, 60, 20, 40, 30])
    q[0] = np.radians(178)
    p, R = fk(chain, q)
    with pytest.raises(JointLimitError, match="J1"):
        ik(chain, p, R, q_ref=q)
    with pytest.warns(JointLimitWarning, match="J1"):
        q[0] = np.radians(172)
        p, R = fk(chain, q)
        ik(chain, p, R, q_ref=q)


def test_pass_of_a_toml_robot_with_an_offset_wrist(spec):
    # a TOML robot outside the closed form's structure (the TX200 with axis 5 moved 10 mm off axis
    # 4) gets the numerical inverse along a milling pass, continued from the start pose: the TCP
    # on the line to 1e-10 m, the orientation kept to 1e-10, the start branch everywhere.
    case = cases.load_case("tx200-aluminium")
    links = list(case.robot.links)
    links[4] = dataclasses.replace(links[4], next_joint_m=links[4].next_joint_m + [0.01, 0, 0])
    bent = dataclasses.replace(case.robot, links=tuple(links))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", JointLimitWarning)   # the paper's A3 2.86 deg past its limit
        ps = Pass.from_case(dataclasses.replace(case, robot=bent))
    s = np.linspace(0, ps.travel_m, 9)
    th = ps.theta_at_s(s)
    P, R = fk(bent, th)
    assert np.abs(P - ps.tcp_position_at_s(s)).max() < 1e-10 and np.abs(R - ps.rotation).max() < 1e-10
    assert np.array_equal(th[0], ps.start_q) and np.all(branch_of(bent, th) == ps.branch)
