"""Case data: a robot (links, joints, payload, flexibility) and a milling case (robot + tool + cut + pass).

These are plain, validated, immutable data in SI units. Files on disk use edge units with the unit
in the key (``_mm``, ``_deg``, ``_mpa``); :mod:`cases.loader` converts.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from robolobes.core.errors import BadInput
from robolobes.core.validate import readonly

from .milling import Cut, CuttingLaw, Tool

__all__ = ["LinkSpec", "JointSpec", "PayloadSpec", "RobotSpec", "UrdfSpec", "PassSpec", "MillingCase", "Assumption", "Axis",
           "ElementSpec"]

Axis = Literal["x", "y", "z"]


@dataclass(frozen=True)
class Assumption:
    """A number or convention the source does not give, with the reason for the choice."""

    reason: str
    key: str | None = None
    value: float | None = None


@dataclass(frozen=True)
class ElementSpec:
    """An extra model element as data: an ``[[elements]]`` table of a robot or case TOML.

    ``type`` names it (``"tcp_mode"``, ``"joint_correction"``, ...); ``params`` holds its other keys
    as in the file (units in the keys). :func:`robolobes.linearize.extra_elements.element_from_spec`
    checks them and builds the :class:`~robolobes.linearize.Element`.
    """

    type: str
    params: dict = field(default_factory=dict)


@dataclass(frozen=True)
class LinkSpec:
    """A rigid link, in its own frame (origin at its entry joint).

    Attributes
    ----------
    name : str
    mass_kg : float
    com_m : array (3,)
        Entry joint to centre of mass (AG), m.
    next_joint_m : array (3,)
        Centre of mass to the next joint (GB), m.
    inertia_kg_m2 : array (3, 3)
        Inertia tensor at the centre of mass, link axes, kg m^2.
    """

    name: str
    mass_kg: float
    com_m: np.ndarray
    next_joint_m: np.ndarray
    inertia_kg_m2: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "com_m", readonly(self.com_m, shape=(3,)))
        object.__setattr__(self, "next_joint_m", readonly(self.next_joint_m, shape=(3,)))
        object.__setattr__(self, "inertia_kg_m2", readonly(self.inertia_kg_m2, shape=(3, 3)))


@dataclass(frozen=True)
class JointSpec:
    """A motion joint (revolute) with its drive flexibility.

    Attributes
    ----------
    name : str
    axis : {"x", "y", "z"}
        Rotation axis in the parent link frame at the joint. For a URDF robot (``RobotSpec.urdf``):
        the joint frame's axis nearest the URDF axis (the URDF's own axis is in ``UrdfSpec.axes``).
    stiffness_n_m_per_rad, damping_n_m_s_per_rad : float
        Torsional spring and damper of eq. 7.
    range_rad : array (2,)
        Lower and upper joint limit, rad.
    gravity_compensation : bool
        Whether the robot cancels the gravity torque on this axis (paper section 2.1.1).
    """

    name: str
    axis: Axis
    stiffness_n_m_per_rad: float
    damping_n_m_s_per_rad: float
    range_rad: np.ndarray
    gravity_compensation: bool = False

    def __post_init__(self):
        object.__setattr__(self, "range_rad", readonly(self.range_rad, shape=(2,)))


@dataclass(frozen=True)
class PayloadSpec:
    """The spindle (or any tool) rigidly fixed to the flange face.

    Attributes
    ----------
    mass_kg : float
    com_m : array (3,)
        Flange face to centre of mass, flange axes, m.
    tcp_m : array (3,)
        Flange face to the tool centre point, flange axes, m.
    inertia_kg_m2 : array (3, 3)
        At the centre of mass, flange axes.
    tcp_rotation : array (3, 3)
        Orientation of the TCP frame in flange axes; its z axis is the tool axis (out of the spindle).
    """

    name: str
    mass_kg: float
    com_m: np.ndarray
    tcp_m: np.ndarray
    inertia_kg_m2: np.ndarray
    tcp_rotation: np.ndarray

    def __post_init__(self):
        for k, shape in (("com_m", (3,)), ("tcp_m", (3,)), ("inertia_kg_m2", (3, 3)), ("tcp_rotation", (3, 3))):
            object.__setattr__(self, k, readonly(getattr(self, k), shape=shape))


@dataclass(frozen=True)
class UrdfSpec:
    """A robot's kinematic tree from its URDF, and the controller's convention for its joints.

    Joint ``i`` is the i-th motion joint, base to flange. Its URDF position ``p_i`` and the
    controller's angle ``c_i`` (what poses, ``--q-deg`` and the cases give) are related by
    ``p_i = sign[i] * c_i + offset_rad[i]``.

    Attributes
    ----------
    path : str
        The URDF file the tree was read from.
    joint_names : tuple of str
        URDF names of the motion joints, base to flange.
    flange : str
        URDF link (or frame) the payload is fixed to; ``PayloadSpec`` is in its axes.
    sign : array (n,) of +-1
    offset_rad : array (n,), rad
    placements : array (n, 4, 4)
        Frame of joint i at URDF position 0 in the frame of joint i - 1 (joint 0: base frame), m.
    axes : array (n, 3)
        Unit rotation axis of joint i in its frame, as the URDF writes it.
    mass_kg : array (n,); com_m : array (n, 3), m; inertia_kg_m2 : array (n, 3, 3), kg m^2
        Body moving with joint i (joint-i frame; inertia at the centre of mass).
    flange_placement : array (4, 4)
        The flange frame in the frame of the last joint.
    orthogonal_axes : array (n, 2, 3)
        Axes of the two orthogonal-compliance rotations after joint i, joint-i frame
        (:func:`robolobes.cases.urdf.completing_axes` unless the TOML names them).
    """

    path: str
    joint_names: tuple[str, ...]
    flange: str
    sign: np.ndarray
    offset_rad: np.ndarray
    placements: np.ndarray
    axes: np.ndarray
    mass_kg: np.ndarray
    com_m: np.ndarray
    inertia_kg_m2: np.ndarray
    flange_placement: np.ndarray
    orthogonal_axes: np.ndarray

    def __post_init__(self):
        n = len(self.joint_names)
        for k, shape in (("sign", (n,)), ("offset_rad", (n,)), ("placements", (n, 4, 4)), ("axes", (n, 3)),
                         ("mass_kg", (n,)), ("com_m", (n, 3)), ("inertia_kg_m2", (n, 3, 3)),
                         ("flange_placement", (4, 4)), ("orthogonal_axes", (n, 2, 3))):
            object.__setattr__(self, k, readonly(getattr(self, k), shape=shape))


@dataclass(frozen=True)
class RobotSpec:
    """A serial robot as data: links from the floor, joints between them, payload, flexibility.

    ``links[0]`` is the fixed base; joint ``i`` (0-based) joins ``links[i]`` to ``links[i + 1]`` and
    sits at ``links[i].com_m + links[i].next_joint_m`` in the frame of ``links[i]``. The last link
    carries the payload at its exit (the flange face).

    A robot read from a URDF has ``urdf`` set and no ``links`` (its tree is in ``urdf``); its
    ``joints`` carry the flexibility, ranges and gravity compensation of the motion joints.
    """

    name: str
    links: tuple[LinkSpec, ...]
    joints: tuple[JointSpec, ...]
    payload: PayloadSpec
    gravity_m_per_s2: float
    orthogonal_stiffness_n_m_per_rad: float
    orthogonal_damping_n_m_s_per_rad: float
    backlash_half_width_rad: float
    poses_rad: dict[str, np.ndarray] = field(default_factory=dict)
    assumptions: tuple[Assumption, ...] = ()
    source: str = ""
    elements: tuple[ElementSpec, ...] = ()
    urdf: UrdfSpec | None = None

    def __post_init__(self):
        if self.urdf is not None:
            if len(self.urdf.joint_names) != len(self.joints) or self.links:
                raise BadInput(f"robot {self.name!r}: a URDF robot needs one joint per URDF motion joint "
                               f"({len(self.urdf.joint_names)}), got {len(self.joints)}, and no links")
        elif len(self.links) != len(self.joints) + 1:
            raise BadInput(
                f"robot {self.name!r}: {len(self.links)} links need {len(self.links) - 1} joints, got {len(self.joints)}"
            )

    @property
    def n_joints(self) -> int:
        return len(self.joints)

    @property
    def joint_stiffness(self) -> np.ndarray:
        """Motion-axis stiffness k, shape (n_joints,), N m/rad."""
        return np.array([j.stiffness_n_m_per_rad for j in self.joints])

    @property
    def joint_damping(self) -> np.ndarray:
        """Motion-axis damping d, shape (n_joints,), N m s/rad."""
        return np.array([j.damping_n_m_s_per_rad for j in self.joints])

    @property
    def joint_range_rad(self) -> np.ndarray:
        """Joint limits, shape (n_joints, 2), rad."""
        return np.array([j.range_rad for j in self.joints])

    def pose(self, name: str) -> np.ndarray:
        """A named pose (joint angles, rad, shape (n_joints,))."""
        try:
            return self.poses_rad[name]
        except KeyError:
            raise KeyError(f"robot {self.name!r} has no pose {name!r}; known: {sorted(self.poses_rad)}") from None


@dataclass(frozen=True)
class PassSpec:
    """A straight milling pass at constant tool orientation.

    Attributes
    ----------
    start_q_rad : array (n_joints,)
        Motor angles at the start of the pass, rad.
    part_length_m : float
        Workpiece length along the feed, m.
    approach_m, overrun_m : float
        Clearance between tool and part before entry and after exit, m.
    ramp_s : float
        Duration of the jerk-limited feed ramp from rest (and back to rest), s.
    """

    start_q_rad: np.ndarray
    part_length_m: float
    approach_m: float
    overrun_m: float
    ramp_s: float

    def __post_init__(self):
        object.__setattr__(self, "start_q_rad", readonly(self.start_q_rad))

    def travel_m(self, tool: Tool) -> float:
        """TCP travel from start to end: approach + D + part length + overrun, m."""
        return self.approach_m + tool.diameter_m + self.part_length_m + self.overrun_m


@dataclass(frozen=True)
class MillingCase:
    """A complete milling case: which robot, which tool and material, which cut, which pass."""

    name: str
    robot: RobotSpec
    tool: Tool
    law: CuttingLaw
    cut: Cut
    path: PassSpec
    source: str = ""

    @property
    def material(self) -> str:
        return self.law.name
