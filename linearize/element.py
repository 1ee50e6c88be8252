"""The element contract of the flexible robot, and the builder elements hook into.

An element is an immutable specification (a frozen dataclass of physical parameters). It never
stores anything about the robot it is part of, so one instance can sit in any number of robots.
Following pinocchio (a constant ``Model``, a ``Data`` workspace per call), the assembly goes in
three steps, each with its own home for what it produces:

1. ``before_chain(b, parent)``, ``after_motion_joint(b, index, joint_id)`` and ``finish(b)`` add
   joints, bodies and frames to the :class:`ModelBuilder` (``before_chain``: between the universe
   and the first motion joint, e.g. the robot's mount); ``finish`` returns what the element needs to find its part of
   the model again (a joint name, or None);
2. ``bind(robot, built)`` returns the element's robot-specific indices (joint and dof indices,
   scaled gains), which the robot keeps: ``robot.element_indices[i]`` for element ``i``;
3. ``force(robot, ix, data, q, v, theta)`` and ``tangent(robot, ix, data, q, v, theta, engaged)``
   read those indices ``ix`` and write only into the caller's ``pin.Data`` ``data``.

Example: the base element changes nothing and applies no force.

>>> Element().force(None, None, None, None, None, None) is None
True
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from robolobes.cases.spec import RobotSpec

if TYPE_CHECKING:
    from .model import FlexibleRobot

__all__ = ["Element", "ModelBuilder", "dead_zone", "revolute"]

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

    def add_joint(self, parent: int, axis: str | np.ndarray, placement: pin.SE3, name: str) -> int:
        """Add a revolute joint at ``placement`` in the parent joint's frame. Returns its id.

        ``axis``: ``"x"``, ``"y"``, ``"z"``, or a unit vector (3,) in the joint's frame.
        """
        return self.model.addJoint(parent, revolute(axis), placement, name)

    def orthogonal_axes(self, index: int) -> list[tuple[str, str | np.ndarray]]:
        """The two axes of orthogonal compliance after motion joint ``index``, in order, as
        ``(label, axis)`` pairs for :meth:`add_joint` (axes in the motion joint's frame).

        TOML robots: the two other frame axes in cyclic order (``z -> x, y``; ``y -> z, x``;
        ``x -> y, z``), eq. 11. URDF robots: ``spec.urdf.orthogonal_axes`` (the same rule for an
        arbitrary axis, :func:`robolobes.cases.urdf.completing_axes`, or the axes the TOML names).
        """
        if self.spec.urdf is not None:
            return [(str(k + 1), ax) for k, ax in enumerate(self.spec.urdf.orthogonal_axes[index])]
        return [(a, a) for a in _ORTHO[self.spec.joints[index].axis]]


def revolute(axis: str | np.ndarray) -> pin.JointModel:
    """A pinocchio revolute joint model about ``axis`` (``"x"``/``"y"``/``"z"`` or a unit 3-vector);
    a vector along +x, +y or +z gives the same joint type as its letter.

    >>> revolute("y").shortname(), revolute(np.array([0.0, 0.0, -1.0])).shortname()
    ('JointModelRY', 'JointModelRevoluteUnaligned')
    """
    if isinstance(axis, str):
        return _JOINT[axis]()
    a = np.asarray(axis, dtype=float)
    for k, letter in enumerate("xyz"):
        if a[k] == 1.0 and np.count_nonzero(a) == 1:
            return _JOINT[letter]()
    return pin.JointModelRevoluteUnaligned(a / np.linalg.norm(a))


class Element:
    """Base class of model elements. Subclasses override what they need; defaults do nothing.

    Subclasses are frozen dataclasses; none of these methods may write into the element.
    """

    name: str = "element"

    def before_chain(self, b: ModelBuilder, parent: int) -> int:
        """Called before the first motion joint; may add joints under ``parent`` (0: the universe).

        Returns the joint the chain (the base link and motion joint 1) hangs from: ``parent`` when
        the element adds none. When the result is not the universe, :func:`~robolobes.linearize.model.assemble`
        puts the base link's inertia (``spec.links[0]``) on it.
        """
        return parent

    def after_motion_joint(self, b: ModelBuilder, index: int, joint_id: int) -> int:
        """Called after motion joint ``index`` is added; may add joints. Returns the new tail joint."""
        return joint_id

    def finish(self, b: ModelBuilder) -> Any:
        """Called once the chain up to the flange exists; may add joints and bodies.

        Returns what :meth:`bind` needs to find them in the finished model (e.g. a joint name), or None.
        """
        return None

    def bind(self, robot: FlexibleRobot, built: Any = None) -> Any:
        """The element's robot-specific indices, computed once the model is complete.

        ``built`` is what :meth:`finish` returned. The robot stores the result
        (``robot.element_indices``) and hands it back to :meth:`force` and :meth:`tangent` as ``ix``.
        ``robot.element_indices`` is not yet filled when this is called.
        """
        return None

    def force(self, robot: FlexibleRobot, ix: Any, data: pin.Data, q: np.ndarray, v: np.ndarray,
              theta: np.ndarray) -> np.ndarray | None:
        """Generalized force, shape (nv,), N m or N; None when the element applies none.

        ``ix``: what :meth:`bind` returned for this robot; ``data``: the caller's ``pin.Data``
        workspace (the only thing the element may write into).
        """
        return None

    def tangent(self, robot: FlexibleRobot, ix: Any, data: pin.Data, q: np.ndarray, v: np.ndarray,
                theta: np.ndarray, engaged: bool = False) -> tuple[np.ndarray, np.ndarray] | None:
        """``(d force/d q, d force/d v)``, each (nv, nv); None when the element applies no force.

        ``engaged=True`` asks piecewise elements (backlash) for the tangent with contact closed.
        """
        return None


def dead_zone(delta: np.ndarray, s: np.ndarray | float) -> np.ndarray:
    """Backlash dead zone of eq. 12: ``delta - s`` above ``s``, ``delta + s`` below ``-s``, 0 inside.

    >>> dead_zone(np.array([-2.0, 0.5, 3.0]), 1.0).tolist()
    [-1.0, 0.0, 2.0]
    """
    return np.where(delta >= s, delta - s, np.where(delta <= -s, delta + s, 0.0))
