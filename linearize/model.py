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
from functools import cached_property
from typing import Any, Sequence

import numpy as np
import pinocchio as pin

from robolobes.cases.spec import RobotSpec
from robolobes.core.errors import BadInput
from robolobes.core.validate import finite_array

from .base_elements import Gravity, GravityCompensation, MotionSprings, Payload, VirtualJoints
from .element import Element, ModelBuilder, dead_zone
from .extra_elements import element_from_spec
from .variants import VARIANTS, Variant

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
    "base_inertia",
]

@dataclass(frozen=True)
class FlexibleRobot:
    """A flexible robot model: the constant pinocchio model, its elements and their indices.

    Nothing here changes after :func:`assemble` (as pinocchio's ``Model``): the algorithms take a
    ``pin.Data`` workspace per call (:meth:`create_data`, or one the caller passes in), so one
    robot can be shared by threads, processes and maps. Elements are specifications; what an
    element needs to know about this robot (its dof indices) is in ``element_indices``.

    Attributes
    ----------
    spec : RobotSpec
    variant : str
        Variant name, or ``"custom"``.
    model : pin.Model
    elements : tuple of Element
    element_indices : tuple
        ``element_indices[i]``: what ``elements[i].bind`` returned for this robot.
    motion_dofs : array (n_joints,) of int
        Index in q (and v) of each motion joint.
    tcp_frame, flange_frame : int
        pinocchio frame ids.

    Example

    >>> from robolobes.cases import load_robot
    >>> robot = build_model(load_robot("tx200"), "orthogonal")
    >>> robot.nv, robot.motion_dofs.tolist()
    (18, [0, 3, 6, 9, 12, 15])
    """

    spec: RobotSpec
    variant: str
    model: pin.Model
    elements: tuple[Element, ...]
    element_indices: tuple[Any, ...]
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

    def create_data(self) -> pin.Data:
        """A new ``pin.Data`` workspace for this robot's model (one per thread or call)."""
        return self.model.createData()

    @cached_property
    def _engaged(self) -> FlexibleRobot:
        els = tuple(replace(e, backlash_rad=0.0) if isinstance(e, MotionSprings) else e for e in self.elements)
        return assemble(self.spec, els, variant=self.variant + " (engaged)")

    def engaged_twin(self) -> FlexibleRobot:
        """The same robot with every backlash dead zone closed (built once). Same coordinates."""
        return self._engaged

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
        els += [element_from_spec(e, f"elements[{i}]") for i, e in enumerate(spec.elements)]
    return tuple(els)


def chain_links(spec: RobotSpec) -> tuple[list[tuple[pin.SE3, str | np.ndarray, pin.Inertia]], pin.SE3]:
    """The motion chain of ``spec`` in controller coordinates: per motion joint ``(placement, axis,
    body)`` (placement in the previous motion joint's frame, axis for
    :meth:`ModelBuilder.add_joint`, the body moving with it), and the flange in the last joint's frame.

    TOML robots: link frames parallel at q = 0 (``links[i].com_m + links[i].next_joint_m``), axes
    x/y/z. URDF robots: :func:`robolobes.linearize.urdf.controller_chain`.
    """
    if spec.urdf is not None:
        from .urdf import controller_chain
        return controller_chain(spec.urdf)
    out = []
    for i, js in enumerate(spec.joints):
        prev, link = spec.links[i], spec.links[i + 1]
        out.append((pin.SE3(np.eye(3), prev.com_m + prev.next_joint_m), js.axis,
                    pin.Inertia(link.mass_kg, link.com_m, link.inertia_kg_m2)))
    last = spec.links[-1]
    return out, pin.SE3(np.eye(3), last.com_m + last.next_joint_m)


def base_inertia(spec: RobotSpec) -> pin.Inertia:
    """The base link's inertia (``spec.links[0]``: mass kg, centre of mass m, inertia kg m^2, base
    frame); zero for a URDF robot (its tree starts at the first motion joint's parent, fixed).

    >>> from robolobes.cases import load_robot
    >>> float(base_inertia(load_robot("tx200")).mass)
    226.0
    """
    if not spec.links:
        return pin.Inertia.Zero()
    link = spec.links[0]
    return pin.Inertia(link.mass_kg, np.asarray(link.com_m), np.asarray(link.inertia_kg_m2))


def assemble(spec: RobotSpec, elements: Sequence[Element], variant: str = "custom") -> FlexibleRobot:
    """Build the pinocchio model of ``spec`` with ``elements`` hooked into the assembly."""
    b = ModelBuilder(spec)
    links, flange_placement = chain_links(spec)
    parent = 0
    for e in elements:
        parent = e.before_chain(b, parent)
    if parent != 0:      # the base link rides on what an element put under it (the mount)
        b.model.appendBodyToJoint(parent, base_inertia(spec), pin.SE3.Identity())
    for i, (js, (placement, axis, body)) in enumerate(zip(spec.joints, links)):
        jid = b.add_joint(parent, axis, placement, js.name)
        b.motion_joints.append(jid)
        tail = jid
        for e in elements:
            tail = e.after_motion_joint(b, i, tail)
        b.model.appendBodyToJoint(tail, body, pin.SE3.Identity())
        parent = tail
    b.tail = parent
    b.flange_placement = placement = flange_placement
    built = [e.finish(b) for e in elements]
    flange = b.model.addFrame(pin.Frame("flange", b.tail, placement, pin.FrameType.OP_FRAME))
    if b.tcp_parent is None:
        b.tcp_parent, b.tcp_placement = b.tail, placement
    tcp = b.model.addFrame(pin.Frame("tcp", b.tcp_parent, b.tcp_placement, pin.FrameType.OP_FRAME))
    motion_dofs = np.array([b.model.joints[j].idx_v for j in b.motion_joints], dtype=int)
    motion_dofs.setflags(write=False)
    robot = FlexibleRobot(spec=spec, variant=variant, model=b.model, elements=tuple(elements),
                          element_indices=(None,) * len(elements), motion_dofs=motion_dofs, tcp_frame=tcp,
                          flange_frame=flange)
    indices = tuple(e.bind(robot, x) for e, x in zip(elements, built))
    return replace(robot, element_indices=indices)


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

    >>> from robolobes.cases import load_robot
    >>> robot = build_model(load_robot("tx200"), "orthogonal")
    >>> robot.nv, [e.name for e in robot.elements]
    (18, ['payload', 'motion springs', 'gravity', 'gravity compensation', 'virtual joints'])
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


def element_forces(robot: FlexibleRobot, q: np.ndarray, v: np.ndarray, theta: np.ndarray,
                   data: pin.Data | None = None) -> np.ndarray:
    """Sum of the elements' generalized forces, shape (nv,), at configuration q (nq,), velocity v
    (nv,), motor angles theta (n_joints,) in SI. ``data``: a ``pin.Data`` workspace (default: a new one)."""
    data = robot.create_data() if data is None else data
    tau = np.zeros(robot.nv)
    for e, ix in zip(robot.elements, robot.element_indices):
        f = e.force(robot, ix, data, q, v, theta)
        if f is not None:
            tau += f
    return tau


def element_tangents(robot: FlexibleRobot, q: np.ndarray, v: np.ndarray, theta: np.ndarray,
                     engaged: bool = False, data: pin.Data | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(d tau/d q, d tau/d v)`` of the summed element forces, each (nv, nv).

    ``engaged=True`` treats backlash gears as in contact (the linearization's assumption).
    ``data``: a ``pin.Data`` workspace (default: a new one).
    """
    data = robot.create_data() if data is None else data
    kq = np.zeros((robot.nv, robot.nv))
    kv = np.zeros((robot.nv, robot.nv))
    for e, ix in zip(robot.elements, robot.element_indices):
        t = e.tangent(robot, ix, data, q, v, theta, engaged)
        if t is not None:
            kq += t[0]
            kv += t[1]
    return kq, kv


def tcp_pose(robot: FlexibleRobot, q: np.ndarray, data: pin.Data | None = None) -> tuple[np.ndarray, np.ndarray]:
    """TCP position (3,) in m and orientation (3, 3) in the base frame; ``R[:, 2]`` is the tool axis.

    ``data``: a ``pin.Data`` workspace (default: a new one).

    >>> from robolobes.cases import load_robot
    >>> robot = build_model(load_robot("tx200"))
    >>> p, R = tcp_pose(robot, rigid_q(robot, np.zeros(6)))
    >>> p.shape, R.shape
    ((3,), (3, 3))
    """
    work = robot.create_data() if data is None else data
    pin.framesForwardKinematics(robot.model, work, q)
    m = work.oMf[robot.tcp_frame]
    return m.translation.copy(), m.rotation.copy()


def tcp_jacobian(robot: FlexibleRobot, q: np.ndarray, data: pin.Data | None = None) -> np.ndarray:
    """TCP Jacobian, shape (6, nv): rows 0-2 linear velocity of the TCP point (m/s per rad/s),
    rows 3-5 angular velocity, both in base-frame axes (pinocchio ``LOCAL_WORLD_ALIGNED``).

    ``data``: a ``pin.Data`` workspace (default: a new one).
    """
    data = robot.create_data() if data is None else data
    J = pin.computeFrameJacobian(robot.model, data, q, robot.tcp_frame, pin.LOCAL_WORLD_ALIGNED)
    return np.asarray(J).reshape(6, robot.nv)  # eigenpy returns a vector when nv == 1
