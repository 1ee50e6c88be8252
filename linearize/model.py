"""The configuration-dependent flexible robot, built once from a case and composable elements.

The robot is data (a pinocchio ``Model`` plus a tuple of *elements*); algorithms are functions of
``(robot, q, v, theta, ...)``, as in pinocchio's examples. An element may

* change the kinematic tree while it is assembled (``after_motion_joint``, ``finish``): virtual
  joints insert rotations after each motion joint, the payload adds the spindle body and the TCP
  frame, a future spindle mode could add a joint at the flange;
* apply a generalized force ``force(robot, q, v, theta)`` with its tangent
  ``tangent(robot, q, v, theta, engaged)``: joint springs and dampers, backlash, gravity
  compensation, a stiffness correction.

Equations of motion (n = ``robot.nv`` coordinates q, motor angles theta of the motion axes)::

    M(q) qdd + c(q, qd) + g(q) = sum_e tau_e(q, qd, theta) + J_tcp(q)^T F_tcp

``M, c, g`` come from pinocchio (``rnea``); gravity is on when the ``Gravity`` element is present.
Elements are added by :func:`build_model` from a variant name, or passed explicitly
(``extra_elements``) so that :mod:`identify` can add an effect without editing this module.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Literal, Sequence

import numpy as np
import pinocchio as pin

from robolobes.cases.spec import PayloadSpec, RobotSpec
from robolobes.core.errors import BadInput
from robolobes.core.validate import finite_array

__all__ = [
    "Variant",
    "VARIANTS",
    "Element",
    "Payload",
    "MotionSprings",
    "VirtualJoints",
    "Gravity",
    "GravityCompensation",
    "FlexibleRobot",
    "ModelBuilder",
    "build_model",
    "rigid_q",
    "element_forces",
    "element_tangents",
    "tcp_pose",
    "tcp_jacobian",
    "dead_zone",
]

Variant = Literal["basic", "gravity", "orthogonal", "backlash"]
VARIANTS: tuple[str, ...] = ("basic", "gravity", "orthogonal", "backlash")

_JOINT = {"x": pin.JointModelRX, "y": pin.JointModelRY, "z": pin.JointModelRZ}
# Orthogonal (virtual) axes inserted after a motion axis, in order: cyclic, as eq. 11 (rotz, rotx, roty).
_ORTHO = {"z": ("x", "y"), "y": ("z", "x"), "x": ("y", "z")}


class ModelBuilder:
    """Assembles a pinocchio model link by link; elements hook into the assembly.

    Attributes
    ----------
    model : pin.Model
        The model under construction.
    spec : RobotSpec
    motion_joints : list of int
        pinocchio joint id of each motion joint, in chain order.
    tail : int
        Joint id that carries the flange (the last joint of the chain so far).
    flange_placement : pin.SE3
        Flange face in the frame of ``tail``.
    tcp_parent : int, tcp_placement : pin.SE3
        Where the TCP frame goes (set by the payload element; defaults to the flange).
    """

    def __init__(self, spec: RobotSpec):
        self.spec = spec
        self.model = pin.Model()
        self.model.name = spec.name
        self.model.gravity = pin.Motion.Zero()
        self.motion_joints: list[int] = []
        self.tail = 0
        self.flange_placement = pin.SE3.Identity()
        self.tcp_parent: int | None = None
        self.tcp_placement: pin.SE3 | None = None

    def add_joint(self, parent: int, axis: str, placement: pin.SE3, name: str) -> int:
        """Add a revolute joint about ``axis`` of the parent frame, at ``placement``. Returns its id."""
        return self.model.addJoint(parent, _JOINT[axis](), placement, name)


class Element:
    """Base class of model elements. Subclasses override what they need; defaults do nothing."""

    name: str = "element"

    def after_motion_joint(self, b: ModelBuilder, index: int, joint_id: int) -> int:
        """Called after motion joint ``index`` is added; may add joints. Returns the new tail joint."""
        return joint_id

    def finish(self, b: ModelBuilder) -> None:
        """Called once the chain up to the flange exists."""

    def bind(self, robot: "FlexibleRobot") -> None:
        """Called once the model is complete; cache indices here."""

    def force(self, robot: "FlexibleRobot", q: np.ndarray, v: np.ndarray, theta: np.ndarray) -> np.ndarray | None:
        """Generalized force, shape (nv,), N m or N; None when the element applies none."""
        return None

    def tangent(self, robot: "FlexibleRobot", q: np.ndarray, v: np.ndarray, theta: np.ndarray,
                engaged: bool = False) -> tuple[np.ndarray, np.ndarray] | None:
        """``(d force/d q, d force/d v)``, each (nv, nv); None when the element applies no force.

        ``engaged=True`` asks piecewise elements (backlash) for the tangent with contact closed.
        """
        return None


def dead_zone(delta: np.ndarray, s: np.ndarray | float) -> np.ndarray:
    """Backlash dead zone of eq. 12: ``delta - s`` above ``s``, ``delta + s`` below ``-s``, 0 inside."""
    return np.where(delta >= s, delta - s, np.where(delta <= -s, delta + s, 0.0))


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

    def bind(self, robot):
        object.__setattr__(self, "_idx", np.asarray(robot.motion_dofs))

    def _delta(self, q, theta):
        return q[self._idx] - theta

    def force(self, robot, q, v, theta):
        k, d = np.asarray(self.stiffness), np.asarray(self.damping)
        delta = self._delta(q, theta)
        spring = dead_zone(delta, self.backlash_rad) if self.backlash_rad > 0 else delta
        tau = np.zeros(robot.nv)
        tau[self._idx] = -k * spring - d * v[self._idx]
        return tau

    def tangent(self, robot, q, v, theta, engaged=False):
        k, d = np.asarray(self.stiffness), np.asarray(self.damping)
        if self.backlash_rad > 0 and not engaged:
            k = np.where(np.abs(self._delta(q, theta)) >= self.backlash_rad, k, 0.0)
        kq = np.zeros((robot.nv, robot.nv))
        kv = np.zeros((robot.nv, robot.nv))
        kq[self._idx, self._idx] = -k
        kv[self._idx, self._idx] = -d
        return kq, kv


@dataclass(frozen=True)
class VirtualJoints(Element):
    """Orthogonal compliance (virtual joint method, eq. 10-11): two rotations per motion joint,
    about the axes orthogonal to it, inserted right after it, with springs and dampers to rest angle 0.
    """

    stiffness: float
    damping: float
    name: str = "virtual joints"

    def after_motion_joint(self, b, index, joint_id):
        axis = b.spec.joints[index].axis
        tail = joint_id
        for a in _ORTHO[axis]:
            tail = b.add_joint(tail, a, pin.SE3.Identity(), f"{b.spec.joints[index].name}_v{a}")
        return tail

    def bind(self, robot):
        names = [robot.model.names[j] for j in range(1, robot.model.njoints)]
        idx = [robot.model.joints[robot.model.getJointId(n)].idx_v for n in names if "_v" in n]
        object.__setattr__(self, "_idx", np.asarray(idx, dtype=int))

    def force(self, robot, q, v, theta):
        tau = np.zeros(robot.nv)
        tau[self._idx] = -self.stiffness * q[self._idx] - self.damping * v[self._idx]
        return tau

    def tangent(self, robot, q, v, theta, engaged=False):
        kq = np.zeros((robot.nv, robot.nv))
        kv = np.zeros((robot.nv, robot.nv))
        kq[self._idx, self._idx] = -self.stiffness
        kv[self._idx, self._idx] = -self.damping
        return kq, kv


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

    Parameters
    ----------
    axes : tuple of int
        0-based motion joint indices (TX200: axes 2, 3, 5 -> (1, 2, 4)).
    """

    axes: tuple[int, ...]
    name: str = "gravity compensation"

    def bind(self, robot):
        object.__setattr__(self, "_rows", np.asarray([robot.motion_dofs[i] for i in self.axes], dtype=int))

    def force(self, robot, q, v, theta):
        g = pin.computeGeneralizedGravity(robot.model, robot.data, q)
        tau = np.zeros(robot.nv)
        tau[self._rows] = g[self._rows]
        return tau

    def tangent(self, robot, q, v, theta, engaged=False):
        dg = pin.computeGeneralizedGravityDerivatives(robot.model, robot.data, q)
        kq = np.zeros((robot.nv, robot.nv))
        kq[self._rows] = dg[self._rows]
        return kq, np.zeros((robot.nv, robot.nv))


@dataclass(frozen=True)
class FlexibleRobot:
    """A flexible robot model: pinocchio model and data, its elements and index maps.

    Attributes
    ----------
    spec : RobotSpec
    variant : str
        Variant name, or ``"custom"``.
    model, data : pin.Model, pin.Data
    elements : tuple of Element
    motion_dofs : array (n_joints,) of int
        Index in q (and v) of each motion joint.
    tcp_frame, flange_frame : int
        pinocchio frame ids.
    """

    spec: RobotSpec
    variant: str
    model: pin.Model
    data: pin.Data
    elements: tuple[Element, ...]
    motion_dofs: np.ndarray
    tcp_frame: int
    flange_frame: int

    @property
    def nq(self) -> int:
        return self.model.nq

    @property
    def nv(self) -> int:
        return self.model.nv

    @property
    def has_gravity(self) -> bool:
        return bool(np.any(self.model.gravity.linear != 0))

    @property
    def backlash_rad(self) -> float:
        return max((e.backlash_rad for e in self.elements if isinstance(e, MotionSprings)), default=0.0)

    def engaged_twin(self) -> "FlexibleRobot":
        """The same robot with every backlash dead zone closed (cached). Same coordinates."""
        twin = self.__dict__.get("_engaged")
        if twin is None:
            els = tuple(replace(e, backlash_rad=0.0) if isinstance(e, MotionSprings) else e for e in self.elements)
            twin = assemble(self.spec, els, variant=self.variant + " (engaged)")
            object.__setattr__(self, "_engaged", twin)
        return twin

    def with_elements(self, *extra: Element, variant: str = "custom") -> "FlexibleRobot":
        """A new robot with the same elements plus ``extra`` (the model is rebuilt)."""
        return assemble(self.spec, tuple(self.elements) + tuple(extra), variant=variant)

    def describe(self) -> str:
        return f"{self.spec.name} [{self.variant}]: {self.nv} DOF; elements: " + ", ".join(e.name for e in self.elements)


def variant_elements(spec: RobotSpec, variant: str, damping_scale: float = 1.0) -> tuple[Element, ...]:
    """The elements of a named variant.

    * ``basic``: motion-axis springs and dampers, no gravity;
    * ``gravity``: plus gravity and the compensation torques on the compensated axes;
    * ``orthogonal``: plus two virtual rotations per joint (18 DOF for 6 joints);
    * ``backlash``: orthogonal plus the dead zone on the motion axes.

    ``damping_scale`` multiplies the motion-axis damping (the paper's x10 experiment).
    """
    if variant not in VARIANTS:
        raise BadInput(f"unknown model variant {variant!r}; valid: {', '.join(VARIANTS)}")
    if not (math.isfinite(damping_scale) and damping_scale >= 0):
        raise BadInput(f"damping_scale must be a finite number >= 0, got {damping_scale!r}")
    backlash = spec.backlash_half_width_rad if variant == "backlash" else 0.0
    els: list[Element] = [
        Payload(spec.payload),
        MotionSprings(tuple(spec.joint_stiffness), tuple(spec.joint_damping * damping_scale), backlash),
    ]
    if variant != "basic":
        axes = tuple(i for i, j in enumerate(spec.joints) if j.gravity_compensation)
        els += [Gravity(spec.gravity_m_per_s2), GravityCompensation(axes)]
    if variant in ("orthogonal", "backlash"):
        els.append(VirtualJoints(spec.orthogonal_stiffness_n_m_per_rad, spec.orthogonal_damping_n_m_s_per_rad))
    if spec.elements:  # [[elements]] of the robot/case TOML (tool modes, identified corrections)
        from .extra_elements import element_from_spec
        els += [element_from_spec(e, f"elements[{i}]") for i, e in enumerate(spec.elements)]
    return tuple(els)


def assemble(spec: RobotSpec, elements: Sequence[Element], variant: str = "custom") -> FlexibleRobot:
    """Build the pinocchio model of ``spec`` with ``elements`` hooked into the assembly."""
    b = ModelBuilder(spec)
    base = spec.links[0]
    placement = pin.SE3(np.eye(3), base.com_m + base.next_joint_m)
    parent = 0
    for i, js in enumerate(spec.joints):
        jid = b.add_joint(parent, js.axis, placement, js.name)
        b.motion_joints.append(jid)
        tail = jid
        for e in elements:
            tail = e.after_motion_joint(b, i, tail)
        link = spec.links[i + 1]
        b.model.appendBodyToJoint(tail, pin.Inertia(link.mass_kg, link.com_m, link.inertia_kg_m2), pin.SE3.Identity())
        placement = pin.SE3(np.eye(3), link.com_m + link.next_joint_m)
        parent = tail
    b.tail = parent
    b.flange_placement = placement
    for e in elements:
        e.finish(b)
    flange = b.model.addFrame(pin.Frame("flange", b.tail, placement, pin.FrameType.OP_FRAME))
    if b.tcp_parent is None:
        b.tcp_parent, b.tcp_placement = b.tail, placement
    tcp = b.model.addFrame(pin.Frame("tcp", b.tcp_parent, b.tcp_placement, pin.FrameType.OP_FRAME))
    motion_dofs = np.array([b.model.joints[j].idx_v for j in b.motion_joints], dtype=int)
    motion_dofs.setflags(write=False)
    robot = FlexibleRobot(spec=spec, variant=variant, model=b.model, data=b.model.createData(),
                          elements=tuple(elements), motion_dofs=motion_dofs, tcp_frame=tcp, flange_frame=flange)
    for e in elements:
        e.bind(robot)
    return robot


def build_model(spec: RobotSpec, variant: str = "basic", *, damping_scale: float = 1.0,
                extra_elements: Sequence[Element] = ()) -> FlexibleRobot:
    """Build the flexible robot of a named variant, plus any extra elements.

    Parameters
    ----------
    spec : RobotSpec
    variant : {"basic", "gravity", "orthogonal", "backlash"}
    damping_scale : float
        Factor on the motion-axis damping (1: the paper's Tab. 6).
    extra_elements : sequence of Element
        Effects added on top of the variant (e.g. by :mod:`identify`).
    """
    els = variant_elements(spec, variant, damping_scale) + tuple(extra_elements)
    name = variant if not extra_elements and damping_scale == 1.0 else f"{variant}+"
    return assemble(spec, _with_dead_zone(els), variant=name)


def _with_dead_zone(els: tuple) -> tuple:
    """Fold elements that set the motion springs' dead zone (``dead_zone_rad``: the ``backlash``
    element of :mod:`linearize.extra_elements`, any variant) into the :class:`MotionSprings`; the
    last one wins. The solvers read the dead zone from the springs only."""
    widths = [float(e.dead_zone_rad) for e in els if hasattr(e, "dead_zone_rad")]
    if not widths:
        return els
    return tuple(replace(e, backlash_rad=widths[-1]) if isinstance(e, MotionSprings) else e
                 for e in els if not hasattr(e, "dead_zone_rad"))


def rigid_q(robot: FlexibleRobot, theta: np.ndarray) -> np.ndarray:
    """Configuration of the undeformed robot: motion joints at the motor angles, virtual joints at 0.

    Parameters
    ----------
    theta : array (n_joints,), rad
    Returns
    -------
    q : array (nq,), rad
    """
    theta = finite_array("theta (motor angles, rad)", theta, (robot.spec.n_joints,))
    q = np.zeros(robot.nq)
    q[robot.motion_dofs] = theta
    return q


def element_forces(robot: FlexibleRobot, q: np.ndarray, v: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """Sum of the elements' generalized forces, shape (nv,), at configuration q, velocity v, motor angles theta."""
    tau = np.zeros(robot.nv)
    for e in robot.elements:
        f = e.force(robot, q, v, theta)
        if f is not None:
            tau += f
    return tau


def element_tangents(robot: FlexibleRobot, q: np.ndarray, v: np.ndarray, theta: np.ndarray,
                     engaged: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """``(d tau/d q, d tau/d v)`` of the summed element forces, each (nv, nv).

    ``engaged=True`` treats backlash gears as in contact (the linearization's assumption).
    """
    kq = np.zeros((robot.nv, robot.nv))
    kv = np.zeros((robot.nv, robot.nv))
    for e in robot.elements:
        t = e.tangent(robot, q, v, theta, engaged)
        if t is not None:
            kq += t[0]
            kv += t[1]
    return kq, kv


def tcp_pose(robot: FlexibleRobot, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """TCP position (3,) in m and orientation (3, 3) in the base frame; ``R[:, 2]`` is the tool axis."""
    pin.framesForwardKinematics(robot.model, robot.data, q)
    m = robot.data.oMf[robot.tcp_frame]
    return m.translation.copy(), m.rotation.copy()


def tcp_jacobian(robot: FlexibleRobot, q: np.ndarray) -> np.ndarray:
    """TCP Jacobian, shape (6, nv): rows 0-2 linear velocity of the TCP point (m/s per rad/s),
    rows 3-5 angular velocity, both in base-frame axes (pinocchio ``LOCAL_WORLD_ALIGNED``)."""
    J = pin.computeFrameJacobian(robot.model, robot.data, q, robot.tcp_frame, pin.LOCAL_WORLD_ALIGNED)
    return np.asarray(J).reshape(6, robot.nv)  # eigenpy returns a vector when nv == 1
