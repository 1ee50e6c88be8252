"""Rigid-robot kinematics: FK against the paper and pinocchio, closed-form IK on all branches, errors.

Tolerances and their reasons are stated next to each assertion.
"""

from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np
import pytest

from robolobes.linearize.kinematics import (BRANCHES, ElbowSingularityError, JointLimitError, JointLimitWarning,
                                  KinematicsError, RobotStructureError, ShoulderSingularityError, TargetError,
                                  UnreachableError, WristSingularityError, arm_geometry, branch_index, branch_name,
                                  branch_of, check_limits, fk, fk_frames, ik, ik_all, ik_batch, jacobian, rot,
                                  singularity_measures, wrist_centre)

DEG = math.pi / 180


@pytest.fixture(scope="module")
def spec(tx200_spec):
    return tx200_spec  # the shared TX200 spec (tests/conftest.py)


@pytest.fixture(scope="module")
def tab7(spec):
    return np.array(spec.poses_rad["tab7"])


def random_q(spec, n, seed=0, margin=0.05):
    """n random joint vectors within the limits, each at least `margin` from every singularity
    (shoulder: m from axis 1; elbow, wrist: |sin|)."""
    rng = np.random.default_rng(seed)
    lo, hi = spec.joint_range_rad.T
    q = rng.uniform(lo, hi, (4 * n, spec.n_joints))
    m = singularity_measures(spec, q)
    ok = (m["shoulder"] > margin) & (m["elbow"] > margin) & (m["wrist"] > margin)
    assert ok.sum() >= n
    return q[ok][:n]


def tcp_for_wrist_centre(g, C, R):
    """TCP position that puts the wrist centre at C for the TCP orientation R."""
    return C + R @ g.tcp_rotation.T @ g.wrist_to_tcp


def wrap(x):
    return (np.asarray(x) + np.pi) % (2 * np.pi) - np.pi


# ------------------------------------------------------------------------------------- Tab. 7
def test_tab7_tcp_position(spec, tab7):
    # NOTES.md: TCP "about (0.794, 0.185, 0.316) m", printed to 1 mm -> 1 mm tolerance. The GB z
    # splits of NOTES are assumptions but only split fixed sums, so they cannot move the TCP.
    p, R = fk(spec, tab7)
    print(f"Tab. 7 TCP = {p.tolist()} m, tool axis = {R[:, 2].tolist()}")
    assert np.allclose(p, [0.794, 0.185, 0.316], atol=1e-3)


def test_tab7_tool_axis_vertical_to_angle_rounding(spec, tab7):
    # The brief asks (0, 0, -1) to 1e-6. With the angles as printed (0.01 deg resolution) the axis
    # is tilted by 3.36e-5 rad (0.0019 deg): the rounding of the printed angles, not a convention
    # error. Proof: (1) the tilt is below the worst-case effect of +-0.005 deg on every joint;
    # (2) a pose within 0.005 deg of the printed one on every joint, same TCP position, has the
    # axis exactly vertical (1e-12, round-off).
    p, R = fk(spec, tab7)
    a = R[:, 2]
    tilt = math.acos(min(1.0, -a[2]))
    J = jacobian(spec, tab7)[3:]                       # angular velocity per joint rate
    da = np.stack([np.cross(J[:, i], a) for i in range(6)], axis=1)   # tool axis rate per joint rate
    bound = np.linalg.norm(da, axis=0).sum() * 0.005 * DEG
    print(f"tool axis tilt {tilt:.3e} rad, rounding bound {bound:.3e} rad")
    assert 1e-6 < tilt < bound
    # nearest exactly vertical orientation: rotate R by the smallest rotation taking a to -z
    k = np.cross(a, [0, 0, -1.0])
    ang = math.asin(np.linalg.norm(k))
    k /= np.linalg.norm(k)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    Rv = (np.eye(3) + math.sin(ang) * K + (1 - math.cos(ang)) * K @ K) @ R
    qv = ik(spec, p, Rv, q_ref=tab7, limits=False)
    assert np.abs(qv - tab7).max() < 0.005 * DEG
    pv, Rv2 = fk(spec, qv)
    assert np.allclose(Rv2[:, 2], [0, 0, -1], atol=1e-12)
    assert np.allclose(pv, p, atol=1e-12)


def test_tab7_branch_and_wrist_centre(spec, tab7):
    assert branch_name(int(branch_of(spec, tab7))) == "front-up-noflip"
    g = arm_geometry(spec)
    # NOTES: DH a2 = 0.95, d4 = 0.8, y offsets 0.235 + 0.044 - 0.279 = 0, shoulder x offset 0.25
    assert g.a2 == pytest.approx(0.95, abs=1e-12) and g.a3 == pytest.approx(0.8, abs=1e-12)
    assert g.y_offset == pytest.approx(0.0, abs=1e-12)
    assert g.o1[0] == pytest.approx(0.25) and g.o0[2] + g.o1[2] == pytest.approx(0.642)
    # flange face 0.194 m beyond the wrist centre (2194 mm reach): wrist -> TCP = 0.194 + payload
    assert np.allclose(g.wrist_to_tcp, [0.201, 0, 0.194 + 0.317], atol=1e-12)
    # the wrist centre is where axes 4, 5, 6 meet
    pos, rots = fk_frames(spec, tab7)
    assert np.allclose(wrist_centre(spec, tab7), pos[4])


# ------------------------------------------------------------------------------- FK checks
def pin_rigid_model(spec):
    """Rigid chain of the spec in pinocchio (independent construction), with a TCP frame."""
    pin = pytest.importorskip("pinocchio")
    model = pin.Model()
    joint_model = {"x": pin.JointModelRX, "y": pin.JointModelRY, "z": pin.JointModelRZ}
    parent = 0
    for i, jt in enumerate(spec.joints):
        ln = spec.links[i]
        parent = model.addJoint(parent, joint_model[jt.axis](), pin.SE3(np.eye(3), ln.com_m + ln.next_joint_m),
                                jt.name)
    fl = spec.links[-1]
    tcp = pin.SE3(np.array(spec.payload.tcp_rotation), fl.com_m + fl.next_joint_m + spec.payload.tcp_m)
    fid = model.addFrame(pin.Frame("tcp", parent, tcp, pin.FrameType.OP_FRAME))
    return pin, model, fid


def test_fk_matches_pinocchio(spec):
    # Two independent implementations of the same chain: agreement to round-off (1e-12 m, 1e-12).
    pin, model, fid = pin_rigid_model(spec)
    data = model.createData()
    rng = np.random.default_rng(1)
    Q = rng.uniform(-np.pi, np.pi, (200, 6))
    P, R = fk(spec, Q)
    for q, p, r in zip(Q, P, R):
        pin.framesForwardKinematics(model, data, q)
        M = data.oMf[fid]
        assert np.abs(M.translation - p).max() < 1e-12
        assert np.abs(M.rotation - r).max() < 1e-12
    # Jacobian too (LOCAL_WORLD_ALIGNED = our base-axes geometric Jacobian at the TCP point)
    q = Q[0]
    Jp = pin.computeFrameJacobian(model, data, q, fid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
    assert np.abs(Jp - jacobian(spec, q)).max() < 1e-12


def test_fk_vectorized_and_rot(spec):
    Q = random_q(spec, 20, seed=2).reshape(4, 5, 6)
    P, R = fk(spec, Q)
    assert P.shape == (4, 5, 3) and R.shape == (4, 5, 3, 3)
    p, r = fk(spec, Q[2, 3])
    assert np.array_equal(p, P[2, 3]) and np.array_equal(r, R[2, 3])
    from robolobes.cases.loader import _ROT
    for ax in "xyz":
        assert np.allclose(rot(ax, 0.7), _ROT[ax](0.7), atol=1e-15)


def test_jacobian_finite_difference(spec):
    # central differences, h = 1e-6 rad: truncation ~h^2, round-off ~1e-16/h: agreement to 1e-8
    q = random_q(spec, 1, seed=3)[0]
    J = jacobian(spec, q)
    h = 1e-6
    for i in range(6):
        dq = np.zeros(6)
        dq[i] = h
        (p1, R1), (p0, R0) = fk(spec, q + dq), fk(spec, q - dq)
        assert np.allclose((p1 - p0) / (2 * h), J[:3, i], atol=1e-8)
        W = (R1 - R0) / (2 * h) @ fk(spec, q)[1].T     # skew(omega)
        assert np.allclose([W[2, 1], W[0, 2], W[1, 0]], J[3:, i], atol=1e-8)


# ------------------------------------------------------------------------------- IK round trips
def test_fk_ik_round_trip_all_branches(spec):
    # 1000 random poses within limits, >= 0.05 from every singularity; every branch that exists
    # (back branches need the longer reach: some are out of reach). FK(IK(x)) = x to 1e-9 (m and
    # rotation entries); observed ~1e-15.
    Q = random_q(spec, 1000, seed=4)
    P, R = fk(spec, Q)
    for b in range(8):
        qb = ik_batch(spec, P, R, b, errors="nan")
        ok = ~np.isnan(qb[:, 0])
        assert ok.sum() >= 500, (b, ok.sum())
        P2, R2 = fk(spec, qb[ok])
        assert np.abs(P2 - P[ok]).max() < 1e-9
        assert np.abs(R2 - R[ok]).max() < 1e-9
        assert np.all(branch_of(spec, qb[ok]) == b)
    # IK(FK(q)) recovers q on its own branch, modulo 2 pi
    qb = ik_batch(spec, P, R, branch_of(spec, Q))
    assert np.abs(wrap(qb - Q)).max() < 1e-9


def test_ik_all_scalar_api(spec):
    # the scalar API on 200 of the poses: all solutions map back; the matching branch with q_ref
    # = q returns q itself (same 2 pi representation) to 1e-9.
    Q = random_q(spec, 200, seed=5)
    P, R = fk(spec, Q)
    seen = set()
    for q, p, r in zip(Q, P, R):
        sols = ik_all(spec, p, r, q_ref=q)
        for s in sols:
            p2, r2 = fk(spec, s.q)
            assert np.abs(p2 - p).max() < 1e-9 and np.abs(r2 - r).max() < 1e-9
            assert branch_of(spec, s.q) == s.branch and s.branch_name == BRANCHES[s.branch]
            seen.add(s.branch)
        mine = [s for s in sols if s.branch == branch_of(spec, q)]
        assert len(mine) == 1 and np.abs(mine[0].q - q).max() < 1e-9 and mine[0].within_limits
        assert np.abs(ik(spec, p, r, q_ref=q) - q).max() < 1e-9
    assert seen == set(range(8))


def test_ik_representation_a4_a6(spec):
    # A4, A6 have +-270 deg: q and q -+ 2 pi are both valid; q_ref picks the closest one.
    q = np.array([0.3, 0.2, 1.0, 4.0, 0.8, -4.2])          # A4 = 229 deg, A6 = -241 deg
    p, R = fk(spec, q)
    assert np.allclose(ik(spec, p, R, q_ref=q), q, atol=1e-9)
    q_alt = q + np.array([0, 0, 0, -2 * np.pi, 0, 2 * np.pi])
    assert np.allclose(ik(spec, p, R, q_ref=q_alt), q_alt, atol=1e-9)
    # no q_ref: the representation inside the range closest to 0
    assert np.allclose(ik(spec, p, R, branch=branch_of(spec, q)), q_alt, atol=1e-9)


def test_ik_default_branch_and_names(spec, tab7):
    assert branch_index("front-up-noflip") == 0 and branch_index("back-down-flip") == 7
    assert branch_index("flip-down-back") == 7 and branch_index(5) == 5
    assert [branch_index(n) for n in BRANCHES] == list(range(8))
    p, R = fk(spec, tab7)
    with pytest.warns(JointLimitWarning):
        q = ik(spec, p, R)                 # default: first branch within limits (+ tolerance)
    assert np.allclose(q, wrap(tab7), atol=1e-9)
    q7 = ik(spec, p, R, branch="back-down-flip", limits=False)
    assert branch_of(spec, q7) == 7


# ------------------------------------------------------------------------------ limits
def test_tab7_limit_warning_text(spec, tab7):
    with pytest.warns(JointLimitWarning) as rec:
        qw = check_limits(spec, tab7)
    assert len(rec) == 1
    assert str(rec[0].message) == (
        "joint A3 = -212.14 deg, wrapped to +147.86 deg, is 2.86 deg past its upper limit +145.00 deg "
        "(range [-140.00, +145.00] deg); accepted within the tolerance of 5 deg")
    assert qw[2] == pytest.approx(tab7[2] + 2 * np.pi) and np.array_equal(np.delete(qw, 2), np.delete(tab7, 2))
    # the pose itself keeps working as given, with limits off (no warning) and on (warning)
    p, R = fk(spec, tab7)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert np.allclose(ik(spec, p, R, q_ref=tab7, limits=False), tab7, atol=1e-12)
    with pytest.warns(JointLimitWarning, match=r"joint A3 = \+147\.86 deg is 2\.86 deg past"):
        assert np.allclose(ik(spec, p, R, q_ref=tab7), wrap(tab7), atol=1e-12)


def test_limit_error_and_silent_wrap(spec, tab7):
    q = tab7.copy()
    q[2] = 155 * DEG
    with pytest.raises(JointLimitError, match=r"joint A3 = \+155\.00 deg is outside its range \[-140\.00, "
                                              r"\+145\.00\] deg by 10\.00 deg, more than the tolerance of 5 deg"):
        check_limits(spec, q)
    with pytest.warns(JointLimitWarning):
        check_limits(spec, q, tolerance_deg=10.5)
    # same physical angle inside the range: silent, wrapped
    q2 = np.array([190, 10, 20, 250, 30, -400]) * DEG   # A4 = 250 inside +-270: kept
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = check_limits(spec, q2)
    assert np.allclose(out, np.array([-170, 10, 20, 250, 30, -40]) * DEG)
    q2[3] = 300 * DEG                                        # outside +-270, -60 inside
    assert check_limits(spec, q2)[3] == pytest.approx(-60 * DEG)
    assert isinstance(JointLimitError("x"), ValueError)
    # IK with limits: a pose whose every branch is beyond A5 + tolerance is refused by name
    q3 = np.array([0.2, 0.3, 1.2, 0.4, 130 * DEG, 0.1])
    p, R = fk(spec, q3)
    with pytest.raises(JointLimitError, match="A5"):
        ik(spec, p, R, branch=branch_of(spec, q3))


# ------------------------------------------------------------------------------ errors
def test_unreachable_far_and_close(spec):
    g = arm_geometry(spec)
    R = np.diag([1.0, -1.0, -1.0])                          # tool pointing down
    C = g.o0 + np.array([g.o1[0] + 2.0, 0.0, g.o1[2]])      # wrist centre 2 m beyond joint 2
    p = tcp_for_wrist_centre(g, C, R)
    with pytest.raises(UnreachableError, match=r"farther than the stretched arm a2 \+ a3 = 1\.75 m, by 0\.25 m"):
        ik(spec, p, R, branch=0)
    with pytest.raises(UnreachableError):
        ik_all(spec, p, R)
    C = g.o0 + np.array([g.o1[0] + 0.05, 0.0, g.o1[2]])     # 5 cm from joint 2, folded reach 0.15
    p = tcp_for_wrist_centre(g, C, R)
    with pytest.raises(UnreachableError, match=r"closer than the folded arm \|a2 - a3\| = 0\.15 m, by 0\.1 m"):
        ik(spec, p, R, branch=0)


def test_shoulder_singularity(spec):
    g = arm_geometry(spec)
    R = rot("x", 2.0) @ rot("z", 0.4)
    C = g.o0 + np.array([0.0, 0.0, 1.2])                    # wrist centre on axis 1
    p = tcp_for_wrist_centre(g, C, R)
    with pytest.raises(ShoulderSingularityError, match="axis of joint 1") as e:
        ik_all(spec, p, R)
    assert isinstance(e.value, ValueError) and e.value.kind == "shoulder"
    # just outside the 1 mm tolerance it solves
    p2 = p + np.array([2e-3, 0, 0])
    assert len(ik_all(spec, p2, R)) > 0


def test_elbow_singularity(spec):
    q = np.array([0.3, 0.4, 0.0, 0.5, 0.7, 0.2])            # q3 = 0: arm stretched (TX200: psi = q3)
    p, R = fk(spec, q)
    with pytest.raises(ElbowSingularityError, match="stretched"):
        ik(spec, p, R, branch=0)
    with pytest.raises(ElbowSingularityError):
        ik(spec, p, R, q_ref=q)                             # continuation on the singular branch
    q[2] = 2e-3                                             # |sin psi| = 2e-3 > 1e-3: solvable
    p, R = fk(spec, q)
    assert np.allclose(ik(spec, p, R, q_ref=q), q, atol=1e-9)


def test_wrist_singularity(spec):
    q = np.array([0.3, 0.4, 1.2, 0.5, 0.0, 0.2])            # q5 = 0: axes 4 and 6 aligned
    p, R = fk(spec, q)
    with pytest.raises(WristSingularityError, match="axes 4 and 6 are aligned"):
        ik(spec, p, R, branch="front-up-noflip")
    with pytest.raises(WristSingularityError):
        ik(spec, p, R, branch="front-up-flip")
    with pytest.raises(WristSingularityError):
        ik(spec, p, R, q_ref=q)


@pytest.mark.parametrize("p, R, msg", [
    ([0.8, 0.2], np.eye(3), "shape"),
    ([0.8, np.nan, 0.3], np.eye(3), "finite"),
    ([0.8, 0.2, 0.3], np.eye(2), "shape"),
    ([0.8, 0.2, 0.3], 1.01 * np.eye(3), "not a proper rotation"),
    ([0.8, 0.2, 0.3], np.diag([1.0, 1.0, -1.0]), "det"),
    ([0.8, 0.2, 0.3], np.full((3, 3), np.nan), "finite"),
])
def test_bad_targets(spec, p, R, msg):
    with pytest.raises(TargetError, match=msg):
        ik(spec, p, R)


def test_bad_branch_and_q(spec, tab7):
    p, R = fk(spec, tab7)
    for b in (9, "sideways", "front-up", True):
        with pytest.raises(TargetError):
            ik(spec, p, R, branch=b)
    with pytest.raises(TargetError):
        fk(spec, np.zeros(5))
    with pytest.raises(TargetError):
        ik(spec, p, R, q_ref=np.zeros(4))
    # a rotation slightly off SO(3) (1e-8) is projected and accepted
    Rn = R + 1e-8 * np.random.default_rng(0).standard_normal((3, 3))
    q = ik(spec, p, Rn, q_ref=tab7, limits=False)
    assert np.allclose(q, tab7, atol=1e-6)
    assert issubclass(KinematicsError, ValueError)


def test_structure_errors(spec):
    bad_axes = dataclasses.replace(spec, joints=tuple(dataclasses.replace(j, axis="x") if i == 1 else j
                                                      for i, j in enumerate(spec.joints)))
    with pytest.raises(RobotStructureError, match="axes z, y, y, z, y, z"):
        arm_geometry(bad_axes)
    links = list(spec.links)
    links[4] = dataclasses.replace(links[4], next_joint_m=links[4].next_joint_m + [0.01, 0, 0])
    with pytest.raises(RobotStructureError, match="do not meet"):
        arm_geometry(dataclasses.replace(spec, links=tuple(links)))


def test_shoulder_y_offset_handled(spec):
    # a robot with a shoulder y offset of 0.1 m (not the TX200): still exact on every branch
    links = list(spec.links)
    links[1] = dataclasses.replace(links[1], next_joint_m=links[1].next_joint_m + [0, 0.1, 0])
    off = dataclasses.replace(spec, links=tuple(links))
    g = arm_geometry(off)
    assert g.y_offset == pytest.approx(0.1)
    Q = random_q(off, 300, seed=6)
    P, R = fk(off, Q)
    for b in range(8):
        qb = ik_batch(off, P, R, b, errors="nan")
        ok = ~np.isnan(qb[:, 0])
        assert ok.sum() > 100
        P2, R2 = fk(off, qb[ok])
        assert np.abs(P2 - P[ok]).max() < 1e-9 and np.abs(R2 - R[ok]).max() < 1e-9
        assert np.all(branch_of(off, qb[ok]) == b)
    assert np.abs(wrap(ik_batch(off, P, R, branch_of(off, Q)) - Q)).max() < 1e-9
    # wrist centre closer to axis 1 than the offset: unreachable, with the numbers
    Rt = np.eye(3)
    p = tcp_for_wrist_centre(g, g.o0 + np.array([0.05, 0.0, 1.0]), Rt)
    with pytest.raises(UnreachableError, match=r"closer than the shoulder y offset \|0\.1\| m allows \(by 0\.05 m\)"):
        ik_all(off, p, Rt)
