"""Robots from URDF: the TX200 from its exported URDF, and rewritten by hand in other frames.

Two checks that the URDF path builds the same physics as the TOML path:

1. Round trip: ``write_urdf`` + ``robot_toml`` of the TX200, loaded back, gives the same M, C, K,
   J, modes, FRFs and lobes for every variant (1e-9 relative; the writers print floats with
   ``repr``, so the numbers are in fact equal to the last bit).
2. By hand: the TX200 written here as a URDF string in other joint frames: every joint frame
   rotated (its axis along local z, turned about it by an angle of its own), negative URDF axes,
   negative controller signs and non-zero offsets (``p = sign * c + offset``), inertias given in
   rotated inertial frames. The construction below uses numpy only (no robolobes code): joint
   frame ``J_i = L_i Q_i`` with ``L_i`` the TOML link frame and ``Q_i (s_i a_i) = e_i`` (the
   TOML axis), so the URDF origin of joint i is ``Q_{i-1}^T o_{i-1}`` and
   ``Q_{i-1}^T Q_i R(a_i, -offset_i)``. At the same controller angles the modes and the tool-tip
   FRFs must agree to 1e-9 (relative), for every variant; the orthogonal-compliance axes are the
   TOML's in the joint frame (``Q_i^T u``), named with ``orthogonal_axes_xyz``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from robolobes.cases import load_robot
from robolobes.cases.loader import CaseError
from robolobes.linearize import build_model, linearize
from robolobes.linearize.urdf_export import robot_toml, write_urdf

VARIANTS = ("basic", "gravity", "orthogonal", "backlash")
# 1e-9 relative: both paths do the same float operations up to a few rotations (1e-15 each);
# the tolerance leaves six orders of magnitude for the conditioning of the modal solve.
RTOL = 1e-9
POSES_DEG = ([-11.71, 20.78, -212.14, 82.76, 60.80, -166.96], [20.0, 35.0, 95.0, -40.0, 50.0, 30.0])


def _rot(axis, angle):
    """Rodrigues rotation about a unit axis (3,), angle rad: (3, 3)."""
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def _rpy(R):
    """URDF rpy (fixed axes x, y, z: R = Rz(y) Ry(p) Rx(r)) of a rotation matrix."""
    p = math.asin(-max(-1.0, min(1.0, R[2, 0])))
    return math.atan2(R[2, 1], R[2, 2]), p, math.atan2(R[1, 0], R[0, 0])


def _fmt(xs):
    return " ".join(repr(float(x)) for x in xs)


def _frame_along(e, phi):
    """A rotation Q with Q @ z = e (unit), turned by phi about e."""
    e = np.asarray(e, float)
    x = np.cross(e, [0.3, 0.5, 0.8])
    x /= np.linalg.norm(x)
    x = _rot(e, phi) @ x
    return np.column_stack([x, np.cross(e, x), e])


_LETTER = {"x": np.array([1.0, 0, 0]), "y": np.array([0, 1.0, 0]), "z": np.array([0, 0, 1.0])}
_CYCLIC = {"z": ("x", "y"), "y": ("z", "x"), "x": ("y", "z")}
URDF_AXIS_SIGN = (1, -1, -1, 1, -1, 1)         # URDF axis +z or -z
CONTROLLER_SIGN = (1, 1, -1, -1, 1, -1)         # p = sign * c + offset
OFFSET_DEG = (0.0, 90.0, -30.0, 180.0, 12.5, -90.0)
PHI_DEG = (17.0, -40.0, 110.0, 5.0, 73.0, -150.0)  # turn of each joint frame about its axis


def hand_written_tx200(tmp_path):
    """The TX200 as a hand-made URDF + TOML in tmp_path; returns the TOML path."""
    tx = load_robot("tx200")
    Q = [np.eye(3)]
    for i, js in enumerate(tx.joints):
        d = URDF_AXIS_SIGN[i] * CONTROLLER_SIGN[i]  # Q_i (s a) = e: Q_i z = (s * sigma) e
        Q.append(_frame_along(d * _LETTER[js.axis], math.radians(PHI_DEG[i])))
    b = tx.links[0]
    parts = ['<?xml version="1.0"?>\n<robot name="tx200-by-hand">\n',
             f'<link name="base_link"><inertial><origin xyz="{_fmt(b.com_m)}"/><mass value="{b.mass_kg!r}"/>'
             '<inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>\n']
    toml = ['kind = "robot"', 'name = "TX200 by hand"', 'urdf = "tx200_hand.urdf"', "gravity_m_per_s2 = 9.81",
            'flange_link = "tool0"', ""]
    parent = "base_link"
    for i, js in enumerate(tx.joints):
        prev, link = tx.links[i], tx.links[i + 1]
        a = np.array([0.0, 0.0, URDF_AXIS_SIGN[i]])
        off = math.radians(OFFSET_DEG[i])
        R = Q[i].T @ Q[i + 1] @ _rot(a, -off)
        xyz = Q[i].T @ (prev.com_m + prev.next_joint_m)
        B = _rot([1.0, 2.0, 3.0], 0.4 + 0.3 * i)           # inertial frame, in the joint frame
        I_joint = Q[i + 1].T @ link.inertia_kg_m2 @ Q[i + 1]
        I_b = B.T @ I_joint @ B
        child = f"l{i + 1}"
        parts.append(
            f'<link name="{child}"><inertial><origin xyz="{_fmt(Q[i + 1].T @ link.com_m)}" rpy="{_fmt(_rpy(B))}"/>'
            f'<mass value="{link.mass_kg!r}"/><inertia ixx="{float(I_b[0, 0])!r}" iyy="{float(I_b[1, 1])!r}" izz="{float(I_b[2, 2])!r}" '
            f'ixy="{float(I_b[0, 1])!r}" ixz="{float(I_b[0, 2])!r}" iyz="{float(I_b[1, 2])!r}"/></inertial></link>\n'
            f'<joint name="j{i + 1}" type="{"continuous" if i == 5 else "revolute"}"><parent link="{parent}"/>'
            f'<child link="{child}"/><origin xyz="{_fmt(xyz)}" rpy="{_fmt(_rpy(R))}"/><axis xyz="{_fmt(a)}"/>'
            '<limit lower="-10" upper="10" effort="1" velocity="1"/></joint>\n')
        u, w = (Q[i + 1].T @ _LETTER[c] for c in _CYCLIC[js.axis])
        toml += ["[[joints]]", f'name = "{js.name}"', f'urdf_joint = "j{i + 1}"', f"sign = {CONTROLLER_SIGN[i]}",
                 f"offset_deg = {OFFSET_DEG[i]!r}", f"stiffness_n_m_per_rad = {js.stiffness_n_m_per_rad!r}",
                 f"damping_n_m_s_per_rad = {js.damping_n_m_s_per_rad!r}",
                 f"range_deg = [{_fmt(np.degrees(js.range_rad)).replace(' ', ', ')}]",
                 f"gravity_compensation = {str(js.gravity_compensation).lower()}",
                 f"orthogonal_axes_xyz = [{', '.join(repr(float(x)) for x in (*u, *w))}]", ""]
        parent = child
    last = tx.links[-1]
    parts.append(f'<link name="tool0"/>\n<joint name="flange" type="fixed"><parent link="{parent}"/>'
                 f'<child link="tool0"/><origin xyz="{_fmt(Q[6].T @ (last.com_m + last.next_joint_m))}" '
                 f'rpy="{_fmt(_rpy(Q[6].T))}"/></joint>\n</robot>\n')
    p = tx.payload
    ip = p.inertia_kg_m2
    toml += ["[orthogonal]", f"stiffness_n_m_per_rad = {tx.orthogonal_stiffness_n_m_per_rad!r}",
             f"damping_n_m_s_per_rad = {tx.orthogonal_damping_n_m_s_per_rad!r}", "", "[backlash]",
             f"half_width_rad = {tx.backlash_half_width_rad!r}", "", "[payload]", f"mass_kg = {p.mass_kg!r}",
             f"ag_m = [{', '.join(repr(float(x)) for x in p.com_m)}]",
             f"gb_m = [{', '.join(repr(float(x)) for x in p.tcp_m - p.com_m)}]",
             f"inertia_kg_m2 = [{', '.join(repr(float(x)) for x in (ip[0, 0], ip[1, 1], ip[2, 2], ip[0, 1], ip[0, 2], ip[1, 2]))}]",
             'tcp_rotation_deg = [["y", 60]]', ""]
    (tmp_path / "tx200_hand.urdf").write_text("".join(parts))
    (tmp_path / "tx200_hand.toml").write_text("\n".join(toml))
    return tmp_path / "tx200_hand.toml"


def exported_tx200(tmp_path):
    tx = load_robot("tx200")
    (tmp_path / "tx200.urdf").write_text(write_urdf(tx))
    (tmp_path / "tx200.toml").write_text(robot_toml(tx, "tx200.urdf"))
    return tmp_path / "tx200.toml"


def _close(a, b, what):
    scale = np.max(np.abs(a))
    assert np.max(np.abs(np.asarray(a) - np.asarray(b))) <= RTOL * scale, what


def _compare_dynamics(ref_spec, spec, variant, q_deg):
    la = linearize(build_model(ref_spec, variant), np.radians(q_deg))
    lb = linearize(build_model(spec, variant), np.radians(q_deg))
    assert la.n == lb.n
    _close(la.p_tcp, lb.p_tcp, "TCP position")
    _close(la.R_tcp, lb.R_tcp, "TCP orientation")
    ma, mb = la.modes(), lb.modes()
    _close(ma.freq_hz, mb.freq_hz, "natural frequencies")
    _close(ma.damping_ratio, mb.damping_ratio, "damping ratios")
    w = 2 * np.pi * np.linspace(1.0, 400.0, 120)
    _close(la.frf(w).H, lb.frf(w).H, "tool-tip FRF, base frame")
    _close(la.compliance(), lb.compliance(), "static TCP compliance")
    return la, lb


@pytest.mark.parametrize("variant", VARIANTS)
def test_exported_urdf_gives_the_same_model(tmp_path, variant):
    tx = load_robot("tx200")
    spec = load_robot(exported_tx200(tmp_path))
    assert spec.urdf is not None and spec.links == ()
    for q in POSES_DEG:
        la, lb = _compare_dynamics(tx, spec, variant, q)
        for k in ("M", "C", "K", "J"):
            _close(getattr(la, k), getattr(lb, k), k)


@pytest.mark.parametrize("variant", VARIANTS)
def test_hand_written_urdf_in_other_frames_gives_the_same_modes_and_frfs(tmp_path, variant):
    tx = load_robot("tx200")
    spec = load_robot(hand_written_tx200(tmp_path))
    assert spec.urdf is not None
    assert_allclose(spec.urdf.sign, CONTROLLER_SIGN)
    for q in POSES_DEG:
        _compare_dynamics(tx, spec, variant, q)


def test_hand_written_urdf_is_not_read_in_robolobes_frames(tmp_path):
    """The hand-made URDF's frames really differ: its joint placements are rotated, its axes -z."""
    spec = load_robot(hand_written_tx200(tmp_path))
    assert spec.urdf is not None
    rotations = spec.urdf.placements[:, :3, :3]
    assert min(np.linalg.norm(r - np.eye(3)) for r in rotations) > 0.1
    assert_allclose(spec.urdf.axes[:, 2], URDF_AXIS_SIGN)


def test_exported_urdf_gives_the_same_lobes(tmp_path):
    from robolobes.cases import load_case
    from robolobes.lobes import LobeProblem, PhysicalStructure, SemiDiscretization, solve

    case = load_case("tx200-aluminium")
    spec = load_robot(exported_tx200(tmp_path))
    limits = []
    for s in (case.robot, spec):
        lin = linearize(build_model(s, "basic"), case.robot.poses_rad["tab7"])
        p = LobeProblem(PhysicalStructure.from_linear(lin, case.cut.feed_direction), case.tool, case.cut, case.law)
        limits.append(solve(p, SemiDiscretization(m=20), [15000.0, 18700.0, 22000.0]).depth_limit_m)
    assert_allclose(limits[1], limits[0], rtol=RTOL)


def test_urdf_errors_name_the_file_and_the_joint(tmp_path):
    path = exported_tx200(tmp_path)
    text = path.read_text()
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace('name = "A3"', 'name = "A3"\nurdf_joint = "nope"'))
    with pytest.raises(CaseError, match="no movable joint 'nope'"):
        load_robot(bad)
    bad.write_text(text.replace('urdf = "tx200.urdf"', 'urdf = "missing.urdf"'))
    with pytest.raises(CaseError, match="missing.urdf"):
        load_robot(bad)
    bad.write_text(text.replace('name = "A2"', 'name = "A2"\nsign = 2'))
    with pytest.raises(CaseError, match="'joints\\[1\\].sign' must be 1 or -1"):
        load_robot(bad)
    bad.write_text(text.replace('name = "A2"', 'name = "A2"\naxis = "y"'))
    with pytest.raises(CaseError, match="unknown key 'joints\\[1\\].axis'"):
        load_robot(bad)


def test_continuous_joint_needs_a_range(tmp_path):
    path = hand_written_tx200(tmp_path)
    text = path.read_text()
    # j6 is continuous in the hand-made URDF: without range_deg the loader asks for it
    i = text.rindex("range_deg")
    j = text.index("\n", i)
    path.write_text(text[:i] + text[j + 1:])
    with pytest.raises(CaseError, match="range_deg.*no limits"):
        load_robot(path)


def test_export_urdf_command_writes_a_robot_that_loads_back(tmp_path):
    from robolobes.main import main

    out = tmp_path / "tx200-urdf"
    assert main(["export-urdf", "--robot", "tx200", "--out", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == [".robolobes.json", "staubli-tx200.toml", "staubli-tx200.urdf"]
    spec, tx = load_robot(out / "staubli-tx200.toml"), load_robot("tx200")
    assert_allclose(spec.joint_range_rad, tx.joint_range_rad, rtol=1e-15)  # read from the URDF's limits
    assert_allclose(spec.pose("tab7"), tx.pose("tab7"), rtol=1e-12)
    assert main(["export-urdf", "--out", str(out)]) == 0          # same inputs: replaced
    (out / "notes.txt").write_text("mine")
    assert main(["export-urdf", "--out", str(out)]) == 2          # a user's file: refused, untouched
    assert (out / "notes.txt").read_text() == "mine"


def test_orthogonal_pair_turned_in_its_plane_matters_only_through_gravity(tmp_path):
    """Without ``orthogonal_axes_xyz`` the hand-made URDF's virtual axes follow the default rule in
    its turned frames: physically another orthogonal pair in the same plane. The linear model
    without gravity is invariant to that turn (equal stiffness on both axes: an orthogonal change
    of coordinates); with gravity it is not (the second-order term of two non-commuting rotations
    enters the gravity stiffness), which is why the axes are named in the TOML."""
    import re

    from robolobes.linearize.base_elements import MotionSprings, Payload, VirtualJoints
    from robolobes.linearize.model import assemble

    path = hand_written_tx200(tmp_path)
    path.write_text(re.sub(r"orthogonal_axes_xyz = .*\n", "", path.read_text()))
    hand, tx = load_robot(path), load_robot("tx200")
    q = tx.pose("tab7")

    def no_gravity(s):
        return assemble(s, (Payload(s.payload), MotionSprings(tuple(s.joint_stiffness), tuple(s.joint_damping)),
                            VirtualJoints(s.orthogonal_stiffness_n_m_per_rad, s.orthogonal_damping_n_m_s_per_rad)))

    fa, fb = (linearize(no_gravity(s), q).modes().freq_hz for s in (tx, hand))
    assert_allclose(fb, fa, rtol=RTOL)
    fa, fb = (linearize(build_model(s, "orthogonal"), q).modes().freq_hz for s in (tx, hand))
    assert np.max(np.abs(fb - fa) / fa) > 1e3 * RTOL


def test_extra_elements_work_on_the_hand_written_urdf(tmp_path):
    """Elements added on top of a variant (as identification adds them) give the same modes and
    FRFs on the URDF robot as on the TOML robot: a tool mode at the TCP, a servo drive, a payload
    correction, a joint correction and the orthogonal correction."""
    from robolobes.linearize.extra_elements import JointCorrection, OrthogonalCorrection, PayloadMass, ServoDrive
    from robolobes.linearize.tool import TcpOscillator

    extra = (TcpOscillator.one_axis(freq_hz=900.0, damping_ratio=0.03, stiffness_n_per_m=2e7, direction=(1.0, 1.0, 0.0)),
             ServoDrive(joint=3, rotor_inertia_kg_m2=20.0, kp_n_m_per_rad=4e6, kd_n_m_s_per_rad=2e3),
             PayloadMass(delta_mass_kg=-3.0), JointCorrection(joint=5, stiffness_scale=0.7, damping_scale=2.0),
             OrthogonalCorrection(stiffness_scale=0.5))
    tx = load_robot("tx200")
    spec = load_robot(hand_written_tx200(tmp_path))
    q = np.radians(POSES_DEG[1])
    la, lb = (linearize(build_model(s, "orthogonal", extra_elements=extra), q) for s in (tx, spec))
    assert la.n == 6 + 12 + 1 + 1
    _close(la.modes().freq_hz, lb.modes().freq_hz, "natural frequencies")
    w = 2 * np.pi * np.linspace(1.0, 1200.0, 200)
    _close(la.frf(w).H, lb.frf(w).H, "tool-tip FRF, base frame")


def test_a_urdf_robot_exports_to_controller_angles(tmp_path):
    """The hand-written URDF robot (signs, offsets, turned frames, named orthogonal axes) exported
    again: sign 1 and offset 0 everywhere, and the same modes and FRFs for every variant."""
    spec = load_robot(hand_written_tx200(tmp_path))
    out = tmp_path / "again"
    out.mkdir()
    (out / "r.urdf").write_text(write_urdf(spec))
    (out / "r.toml").write_text(robot_toml(spec, "r.urdf"))
    again = load_robot(out / "r.toml")
    assert again.urdf is not None
    assert_allclose(again.urdf.sign, 1.0)
    assert_allclose(again.urdf.offset_rad, 0.0)
    for variant in VARIANTS:
        _compare_dynamics(spec, again, variant, POSES_DEG[1])


def test_kinematics_of_the_hand_written_urdf_are_the_tx200s(tmp_path):
    """Forward and inverse kinematics through the URDF robot's rigid chain (``linearize.chain``,
    with its signs and offsets) give the TX200's TCP poses and controller angles (1e-9 m / rad:
    float rounding in other frames, far below any machining tolerance)."""
    from robolobes.linearize.kinematics import fk, ik

    tx = load_robot("tx200")
    hand = load_robot(hand_written_tx200(tmp_path))
    for q_deg in POSES_DEG:
        q = np.radians(q_deg)
        p, R = fk(tx, q)
        ph, Rh = fk(hand, q)
        assert_allclose(ph, p, rtol=0, atol=1e-9)
        assert_allclose(Rh, R, rtol=0, atol=1e-9)
        assert_allclose(ik(hand, p, R, q_ref=q, limits=False), q, rtol=0, atol=1e-9)
