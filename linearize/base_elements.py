"""The elements of the built-in model variants: payload, motion-axis springs, virtual joints, gravity.

Each is an immutable :class:`~robolobes.linearize.element.Element`; its robot-specific indices
are returned by ``bind`` and kept by the robot (see :mod:`robolobes.linearize.element`).

Example: the motion springs pull a link that runs ahead of its motor back.

>>> import numpy as np
>>> from robolobes.cases import load_robot
>>> from robolobes.linearize import build_model, element_forces
>>> robot = build_model(load_robot("tx200"), "basic")
>>> q = np.zeros(robot.nq); q[robot.motion_dofs[0]] = 1e-3   # link 1 one milliradian ahead
>>> tau = element_forces(robot, q, np.zeros(robot.nv), np.zeros(6))
>>> round(float(tau[robot.motion_dofs[0]]) / -1e-3)  # N m/rad: axis 1 of the paper's Tab. 6
2030000
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from robolobes.cases.spec import PayloadSpec

from .element import Element, ModelBuilder, dead_zone

__all__ = ["Payload", "MotionSprings", "VirtualJoints", "Gravity", "GravityCompensation", "virtual_dofs"]

_VIRTUAL_TAG = "_v"  # virtual joint names: "<motion joint name>_v<axis>"


def diagonal_force(nv: int, idx, k, d, q: np.ndarray, v: np.ndarray, rest=0.0) -> np.ndarray:
    """Force ``-k (q[idx] - rest) - d v[idx]`` (nv,) of springs and dampers on single coordinates ``idx``.

    >>> diagonal_force(3, [0, 2], 5.0, 1.0, np.array([1.0, 9.0, 2.0]), np.array([0.5, 9.0, 0.0])).tolist()
    [-5.5, 0.0, -10.0]
    """
    tau = np.zeros(nv)
    tau[idx] = -k * (q[idx] - rest) - d * v[idx]
    return tau


def diagonal_tangent(nv: int, idx, k, d) -> tuple[np.ndarray, np.ndarray]:
    """``(-k, -d)`` on the diagonal entries ``idx`` of two (nv, nv) zero matrices.

    >>> kq, kv = diagonal_tangent(3, [0, 2], 5.0, 1.0)
    >>> np.diag(kq).tolist(), np.diag(kv).tolist()
    ([-5.0, 0.0, -5.0], [-1.0, 0.0, -1.0])
    """
    kq = np.zeros((nv, nv))
    kv = np.zeros((nv, nv))
    kq[idx, idx] = -k
    kv[idx, idx] = -d
    return kq, kv


def virtual_dofs(model: pin.Model) -> np.ndarray:
    """Indices in v of the virtual (orthogonal) joints of a model, in chain order; (n_virtual,) int."""
    idx = [model.joints[j].idx_v for j in range(1, model.njoints) if _VIRTUAL_TAG in model.names[j]]
    out = np.asarray(idx, dtype=int)
    out.setflags(write=False)
    return out


@dataclass(frozen=True)
class Payload(Element):
    """The spindle body fixed to the flange, and the TCP frame (paper Tab. 3)."""

    spec: PayloadSpec
    name: str = "payload"

    def finish(self, b: ModelBuilder) -> None:
        p = self.spec
        at_com = b.flange_placement * pin.SE3(np.eye(3), p.com_m)
        b.model.appendBodyToJoint(b.tail, pin.Inertia(p.mass_kg, at_com.translation,
                                                      at_com.rotation @ p.inertia_kg_m2 @ at_com.rotation.T),
                                  pin.SE3.Identity())
        b.tcp_parent = b.tail
        b.tcp_placement = b.flange_placement * pin.SE3(np.asarray(p.tcp_rotation), p.tcp_m)


@dataclass(frozen=True)
class MotionSprings(Element):
    """Torsional spring and damper on each motion axis (eq. 7), optionally with backlash (eq. 12).

    ``tau_i = -k_i dz(q_i - theta_i) - d_i qd_i`` with ``dz`` the identity, or the dead zone of
    half-width ``backlash_rad``. As in the paper the damper acts on the absolute link velocity.
    Indices (``bind``): the motion axes' dofs.

    Parameters
    ----------
    stiffness : array (n_joints,), N m/rad
    damping : array (n_joints,), N m s/rad
    backlash_rad : float, half-width s of the dead zone (0: none)
    """

    stiffness: tuple[float, ...]
    damping: tuple[float, ...]
    backlash_rad: float = 0.0
    name: str = "motion springs"

    def bind(self, robot, built=None):
        return robot.motion_dofs

    def force(self, robot, ix, data, q, v, theta):
        k, d = np.asarray(self.stiffness), np.asarray(self.damping)
        delta = q[ix] - theta
        spring = dead_zone(delta, self.backlash_rad) if self.backlash_rad > 0 else delta
        tau = np.zeros(robot.nv)
        tau[ix] = -k * spring - d * v[ix]
        return tau

    def tangent(self, robot, ix, data, q, v, theta, engaged=False):
        k, d = np.asarray(self.stiffness), np.asarray(self.damping)
        if self.backlash_rad > 0 and not engaged:
            k = np.where(np.abs(q[ix] - theta) >= self.backlash_rad, k, 0.0)
        return diagonal_tangent(robot.nv, ix, k, d)


@dataclass(frozen=True)
class VirtualJoints(Element):
    """Orthogonal compliance (virtual joint method, eq. 10-11): two rotations per motion joint,
    about the axes orthogonal to it, inserted right after it, with springs and dampers to rest angle 0.
    Indices (``bind``): the virtual joints' dofs (:func:`virtual_dofs`).
    """

    stiffness: float
    damping: float
    name: str = "virtual joints"

    def after_motion_joint(self, b, index, joint_id):
        tail = joint_id
        for label, a in b.orthogonal_axes(index):
            tail = b.add_joint(tail, a, pin.SE3.Identity(), f"{b.spec.joints[index].name}{_VIRTUAL_TAG}{label}")
        return tail

    def bind(self, robot, built=None):
        return virtual_dofs(robot.model)

    def force(self, robot, ix, data, q, v, theta):
        tau = np.zeros(robot.nv)
        tau[ix] = -self.stiffness * q[ix] - self.damping * v[ix]
        return tau

    def tangent(self, robot, ix, data, q, v, theta, engaged=False):
        return diagonal_tangent(robot.nv, ix, self.stiffness, self.damping)


@dataclass(frozen=True)
class Gravity(Element):
    """Gravity field ``-g_m_per_s2`` along base z, applied through pinocchio's dynamics."""

    g_m_per_s2: float
    name: str = "gravity"

    def finish(self, b):
        b.model.gravity = pin.Motion(np.array([0.0, 0.0, -self.g_m_per_s2]), np.zeros(3))


@dataclass(frozen=True)
class GravityCompensation(Element):
    """Torques that cancel the gravity load on the given motion axes (paper section 2.1.1, eq. 9).

    ``tau_i = g_i(q)`` for each compensated motion axis i, evaluated at the current link angles q.
    Its tangent is the corresponding rows of ``dg/dq``: a torque that cancels gravity on some axes
    only does not derive from a potential, so the linearized stiffness is slightly non-symmetric.
    Indices (``bind``): the compensated axes' dofs.

    Parameters
    ----------
    axes : tuple of int
        0-based motion joint indices (TX200: axes 2, 3, 5 -> (1, 2, 4)).
    """

    axes: tuple[int, ...]
    name: str = "gravity compensation"

    def bind(self, robot, built=None):
        rows = np.asarray([robot.motion_dofs[i] for i in self.axes], dtype=int)
        rows.setflags(write=False)
        return rows

    def force(self, robot, ix, data, q, v, theta):
        g = pin.computeGeneralizedGravity(robot.model, data, q)
        tau = np.zeros(robot.nv)
        tau[ix] = g[ix]
        return tau

    def tangent(self, robot, ix, data, q, v, theta, engaged=False):
        dg = pin.computeGeneralizedGravityDerivatives(robot.model, data, q)
        kq = np.zeros((robot.nv, robot.nv))
        kq[ix] = dg[ix]
        return kq, np.zeros((robot.nv, robot.nv))
