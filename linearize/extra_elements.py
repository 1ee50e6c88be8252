"""Extra model elements for effects the built-in variants lack (added by identify or by hand).

Each is an :class:`~robolobes.linearize.model.Element`, so lobes, simulate and the workspace maps
build a model with them like any other. In a robot or case TOML they are ``[[elements]]`` tables,
``type`` naming the element and the other keys its parameters (units in the keys)::

    [[elements]]
    type = "tcp_oscillator"        # a tool / holder / spindle mode at the TCP (linearize.tool)
    mass_kg = 0.25
    k1_n_per_m = 4.0e5
    k2_n_per_m = 4.3e5             # inf: one axis only
    angle_rad = 0.0                # first principal axis from TCP x, about the tool axis
    zeta1 = 0.03
    zeta2 = 0.03

    [[elements]]
    type = "tcp_mode"              # the same class, one axis along any direction (TcpOscillator.one_axis)
    freq_hz = 900.0
    damping_ratio = 0.03
    stiffness_n_per_m = 2.0e7
    direction = [1.0, 0.0, 0.0]    # in the TCP (tool) frame

    [[elements]]
    type = "joint_correction"      # motion-axis spring and damper scaled (axis 1..n)
    joint = 2
    stiffness_scale = 0.8
    damping_scale = 1.5

    [[elements]]
    type = "orthogonal_correction" # virtual-joint (orthogonal) spring and damper scaled
    stiffness_scale = 0.5          # needs the orthogonal or backlash variant
    damping_scale = 1.0

    [[elements]]
    type = "payload_mass"          # a point mass added at the payload's centre of mass (may be < 0)
    delta_mass_kg = 5.0

    [[elements]]
    type = "servo_drive"           # rotor + PD position loop behind the joint spring of axis 2
    joint = 2
    rotor_inertia_kg_m2 = 5.0      # link side (reflected)
    kp_n_m_per_rad = 2.0e7
    kd_n_m_s_per_rad = 2.0e3

    [[elements]]
    type = "backlash"              # dead zone (eq. 12) on every motion axis, any variant
    half_width_rad = 7.3e-5

    [[elements]]
    type = "load_stiffness"        # a gear stiffening with the static torque it carries (axis 1..n)
    joint = 3
    stiffening = 1.0               # K3 / K1 - 1 of the gear's catalogue curve, 0..2
    reference_torque_n_m = 1000.0  # torque at which the top stiffness is reached (catalogue T2)

    [[elements]]
    type = "mount_compliance"      # the base on springs and dampers (base frame); omitted axes rigid
    kz_n_per_m = 1.5e8
    cz_n_s_per_m = 4.0e4
    krx_n_m_per_rad = 5.0e7        # rocking about base x and y (kry_n_m_per_rad, c.._n_m_s_per_rad)
    crx_n_m_s_per_rad = 1.0e3

:data:`ELEMENT_TYPES` maps each ``type`` to its class, or to the constructor that builds it
(``tcp_mode``: :meth:`TcpOscillator.one_axis`: a tool mode is always a
:class:`~robolobes.linearize.tool.TcpOscillator`); :func:`element_from_spec` checks the keys
strictly (unknown or missing keys, values out of range: :class:`BadInput` naming them).
"""

from __future__ import annotations

import inspect
import math
import threading
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np
import pinocchio as pin

from robolobes.cases.milling import cut_frame
from robolobes.cases.spec import ElementSpec
from robolobes.core.errors import BadInput
from robolobes.core.validate import finite

from .base_elements import VirtualJoints, diagonal_force, diagonal_tangent, virtual_dofs
from .element import Element, ModelBuilder
from .tool import TcpOscillator

__all__ = ["TcpOscillator", "TcpMode", "JointCorrection", "OrthogonalCorrection", "PayloadMass", "ServoDrive", "GearBacklash", "MountCompliance",
           "LoadStiffness", "ELEMENT_TYPES", "element_from_spec", "element_table", "spec_table"]


def _unit(v, what: str) -> np.ndarray:
    d = np.asarray(v, dtype=float)
    if d.shape != (3,) or not np.all(np.isfinite(d)) or np.linalg.norm(d) == 0:
        raise BadInput(f"{what} must be a non-zero 3-vector, got {v!r}")
    return d / np.linalg.norm(d)


def _positive(name, v, *, zero_ok=False):
    if isinstance(v, bool):
        raise BadInput(f"{name} must be a number, got {v!r}")
    finite(name, v, positive=not zero_ok, nonneg=zero_ok)


_diagonal_force = diagonal_force


@dataclass(frozen=True)
class _Diagonal:
    """Indices of a diagonal spring-damper element: coordinates ``iv`` with gains ``dk``, ``dd``."""

    iv: Any
    dk: Any
    dd: Any


def TcpMode(freq_hz: float, damping_ratio: float, stiffness_n_per_m: float,
            direction=(1.0, 0.0, 0.0), name: str = "tcp oscillator") -> TcpOscillator:
    """Deprecated: :meth:`TcpOscillator.one_axis` (same arguments), which it returns.

    There is one tool-mode class, :class:`~robolobes.linearize.tool.TcpOscillator`; this was the
    one-axis mode's own class (a mass ``m = k / (2 pi f)^2`` on a spring and damper along
    ``direction`` at the TCP, taken from the payload) and builds the same model, bit for bit.
    """
    warnings.warn("TcpMode is deprecated: use robolobes.linearize.tool.TcpOscillator.one_axis (same arguments), "
                  "which it returns", DeprecationWarning, stacklevel=2)
    return TcpOscillator.one_axis(freq_hz, damping_ratio, stiffness_n_per_m, direction, name)


@dataclass(frozen=True)
class JointCorrection(Element):
    """Motion axis ``joint`` (1-based) with its spring and damper scaled.

    Adds ``-(s_k - 1) k_j (q_j - theta_j) - (s_d - 1) d_j qd_j`` to the axis, ``k_j, d_j`` from the
    robot's joint table: the axis then has stiffness ``s_k k_j`` and damping ``s_d d_j`` (engaged
    gears; the backlash dead zone of the variant is not scaled).
    """

    joint: int
    stiffness_scale: float = 1.0
    damping_scale: float = 1.0
    name: str = "joint correction"

    def __post_init__(self):
        if isinstance(self.joint, bool) or not isinstance(self.joint, int) or self.joint < 1:
            raise BadInput(f"joint_correction joint must be an axis number 1, 2, ..., got {self.joint!r}")
        _positive("joint_correction stiffness_scale", self.stiffness_scale)
        _positive("joint_correction damping_scale", self.damping_scale, zero_ok=True)

    def bind(self, robot, built=None):
        n = robot.spec.n_joints
        if self.joint > n:
            raise BadInput(f"joint_correction joint = {self.joint}: the robot has axes 1..{n}")
        j = self.joint - 1
        return _Diagonal(iv=int(robot.motion_dofs[j]),
                         dk=(self.stiffness_scale - 1) * robot.spec.joints[j].stiffness_n_m_per_rad,
                         dd=(self.damping_scale - 1) * robot.spec.joints[j].damping_n_m_s_per_rad)

    def force(self, robot, ix, data, q, v, theta):
        return _diagonal_force(robot.nv, ix.iv, ix.dk, ix.dd, q, v, rest=theta[self.joint - 1])

    def tangent(self, robot, ix, data, q, v, theta, engaged=False):
        return diagonal_tangent(robot.nv, ix.iv, ix.dk, ix.dd)


@dataclass(frozen=True)
class OrthogonalCorrection(Element):
    """The virtual (orthogonal) joints' spring and damper scaled; needs a variant with virtual joints."""

    stiffness_scale: float = 1.0
    damping_scale: float = 1.0
    name: str = "orthogonal correction"

    def __post_init__(self):
        _positive("orthogonal_correction stiffness_scale", self.stiffness_scale)
        _positive("orthogonal_correction damping_scale", self.damping_scale, zero_ok=True)

    def bind(self, robot, built=None):
        vj = [e for e in robot.elements if isinstance(e, VirtualJoints)]
        if not vj:
            raise BadInput("orthogonal_correction needs virtual joints: use variant 'orthogonal' or 'backlash'")
        return _Diagonal(iv=virtual_dofs(robot.model), dk=(self.stiffness_scale - 1) * vj[0].stiffness,
                         dd=(self.damping_scale - 1) * vj[0].damping)

    def force(self, robot, ix, data, q, v, theta):
        return _diagonal_force(robot.nv, ix.iv, ix.dk, ix.dd, q, v)

    def tangent(self, robot, ix, data, q, v, theta, engaged=False):
        return diagonal_tangent(robot.nv, ix.iv, ix.dk, ix.dd)


@dataclass(frozen=True)
class PayloadMass(Element):
    """A point mass ``delta_mass_kg`` (may be negative: a payload lighter than declared) at the
    payload's centre of mass; the payload's total mass must stay positive."""

    delta_mass_kg: float
    name: str = "payload mass"

    def __post_init__(self):
        if isinstance(self.delta_mass_kg, bool) or not isinstance(self.delta_mass_kg, (int, float)) \
                or not math.isfinite(self.delta_mass_kg):
            raise BadInput(f"payload_mass delta_mass_kg must be a finite number, got {self.delta_mass_kg!r}")

    def finish(self, b: ModelBuilder) -> None:
        p = b.spec.payload
        if p.mass_kg + self.delta_mass_kg <= 0:
            raise BadInput(f"payload_mass delta_mass_kg = {self.delta_mass_kg}: the payload ({p.mass_kg} kg) "
                           "would have no mass left")
        at_com = b.flange_placement * pin.SE3(np.eye(3), p.com_m)
        b.model.appendBodyToJoint(b.tail, pin.Inertia(self.delta_mass_kg, at_com.translation, np.zeros((3, 3))),
                                  pin.SE3.Identity())


@dataclass(frozen=True)
class ServoDrive(Element):
    """Servo dynamics of motion axis ``joint`` (1-based): a rotor between the command and the joint spring.

    Without it the joint spring ``k`` pulls the link towards the commanded angle ``theta`` (an
    ideal, infinitely stiff position loop). With it the spring pulls towards the rotor angle
    ``q_m = theta + phi`` (link side, through the gear), and the rotor (reflected inertia ``J``) is
    held by a PD position loop on its error ``phi``::

        link:   tau = -k (q - theta) + k phi                    (total: -k (q - q_m))
        rotor:  J phid2 = -k (phi + theta - q) - kp phi - kd phid

    The rotor is a revolute joint on the base (its angle is ``phi``, 0 at rest, so the rigid
    configuration is the unloaded equilibrium); the commanded acceleration's inertial torque is
    taken as compensated by the drive's feed-forward. ``kp -> inf`` recovers the model without it.

    Parameters
    ----------
    joint : int >= 1
    rotor_inertia_kg_m2 : float > 0     link-side (reflected) rotor inertia, kg m^2
    kp_n_m_per_rad : float > 0          position-loop stiffness, link side
    kd_n_m_s_per_rad : float >= 0       position-loop damping, link side
    """

    joint: int
    rotor_inertia_kg_m2: float
    kp_n_m_per_rad: float
    kd_n_m_s_per_rad: float = 0.0
    name: str = "servo drive"

    def __post_init__(self):
        if isinstance(self.joint, bool) or not isinstance(self.joint, int) or self.joint < 1:
            raise BadInput(f"servo_drive joint must be an axis number 1, 2, ..., got {self.joint!r}")
        _positive("servo_drive rotor_inertia_kg_m2", self.rotor_inertia_kg_m2)
        _positive("servo_drive kp_n_m_per_rad", self.kp_n_m_per_rad)
        _positive("servo_drive kd_n_m_s_per_rad", self.kd_n_m_s_per_rad, zero_ok=True)

    def finish(self, b: ModelBuilder) -> str:
        name = f"servo_rotor_{self.joint}_{b.model.njoints}"
        jid = b.model.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), name)
        J = self.rotor_inertia_kg_m2
        b.model.appendBodyToJoint(jid, pin.Inertia(1e-9, np.zeros(3), np.diag([J, J, J])), pin.SE3.Identity())
        return name

    def bind(self, robot, built=None):
        """The rotor's and the link's dof and the joint spring (``built``: the rotor joint's name)."""
        n = robot.spec.n_joints
        if self.joint > n:
            raise BadInput(f"servo_drive joint = {self.joint}: the robot has axes 1..{n}")
        return _ServoIndices(im=robot.model.joints[robot.model.getJointId(built)].idx_v,
                             iq=int(robot.motion_dofs[self.joint - 1]),
                             k=robot.spec.joints[self.joint - 1].stiffness_n_m_per_rad)

    def force(self, robot, ix, data, q, v, theta):
        im, iq, k = ix.im, ix.iq, ix.k
        tau = np.zeros(robot.nv)
        phi, th = q[im], theta[self.joint - 1]
        tau[iq] = k * phi
        tau[im] = -k * (phi + th - q[iq]) - self.kp_n_m_per_rad * phi - self.kd_n_m_s_per_rad * v[im]
        return tau

    def tangent(self, robot, ix, data, q, v, theta, engaged=False):
        im, iq, k = ix.im, ix.iq, ix.k
        kq = np.zeros((robot.nv, robot.nv))
        kv = np.zeros((robot.nv, robot.nv))
        kq[iq, im] = k
        kq[im, iq] = k
        kq[im, im] = -(k + self.kp_n_m_per_rad)
        kv[im, im] = -self.kd_n_m_s_per_rad
        return kq, kv


@dataclass(frozen=True)
class _ServoIndices:
    """A servo drive's indices in one robot: rotor dof ``im``, link dof ``iq``, joint spring ``k`` (N m/rad)."""

    im: int
    iq: int
    k: float


@dataclass(frozen=True)
class GearBacklash(Element):
    """The backlash dead zone of eq. 12 on every motion axis, in any variant.

    ``tau_i = -k_i dz(q_i - theta_i) - d_i qd_i``, ``dz`` zero inside ``+-half_width_rad``. The dead
    zone belongs to the motion springs (the gearboxes), not to the orthogonal compliance, so the
    element applies to the ``basic`` variant as well: :func:`linearize.model.build_model` gives the
    variant's :class:`~robolobes.linearize.model.MotionSprings` this half-width (the last such
    element wins, also over the ``backlash`` variant's) and keeps no separate element, so every
    solver that knows the dead zone (the full nonlinear path, the fast path, the backlash
    equilibrium) sees it. Linearizations take the gears as engaged (no change of K).

    Parameters
    ----------
    half_width_rad : float >= 0     dead-zone half-width s, rad (the paper's 7.3e-5 = 15 arcsec)
    """

    half_width_rad: float
    name: str = "backlash"

    def __post_init__(self):
        _positive("backlash half_width_rad", self.half_width_rad, zero_ok=True)

    @property
    def dead_zone_rad(self) -> float:
        """The half-width :func:`linearize.model.build_model` gives the motion springs."""
        return float(self.half_width_rad)


_MOUNT_AXES = ("x", "y", "z", "rx", "ry")
_MOUNT_JOINTS = {"x": pin.JointModelPX, "y": pin.JointModelPY, "z": pin.JointModelPZ,
                 "rx": pin.JointModelRX, "ry": pin.JointModelRY}


@dataclass(frozen=True)
class MountCompliance(Element):
    """The robot's base on springs and dampers (its mount, the floor): compliance outside the joints.

    Up to five coordinates between the universe and the base link, in the robot's base frame:
    translations along base x, y, z (m) and rocking rotations about base x and y through the base
    frame's origin (rad), in that order (pinocchio ``PX, PY, PZ, RX, RY``), each with a spring to 0
    and a damper: ``tau_a = -k_a u_a - c_a du_a``. An axis with infinite stiffness (the default)
    adds no coordinate. The base link (``spec.links[0]``, 226 kg on the TX200) rides on the mount,
    so the mount's modes carry the whole robot: the vertical one of the rigid robot is
    ``sqrt(kz / M_total) / 2 pi``. With gravity the mount sags under the robot's weight (the static
    equilibrium finds it); rocking under gravity loses ``M g h`` of stiffness (``h`` the height of
    the centre of mass), which the linearization's ``dg/dq`` holds.

    Parameters
    ----------
    kx_n_per_m, ky_n_per_m, kz_n_per_m : float > 0 or inf      translational stiffness, N/m
    krx_n_m_per_rad, kry_n_m_per_rad : float > 0 or inf        rocking stiffness, N m/rad
    cx_n_s_per_m, cy_n_s_per_m, cz_n_s_per_m : float >= 0      translational damping, N s/m
    crx_n_m_s_per_rad, cry_n_m_s_per_rad : float >= 0          rocking damping, N m s/rad
    """

    kx_n_per_m: float = math.inf
    ky_n_per_m: float = math.inf
    kz_n_per_m: float = math.inf
    krx_n_m_per_rad: float = math.inf
    kry_n_m_per_rad: float = math.inf
    cx_n_s_per_m: float = 0.0
    cy_n_s_per_m: float = 0.0
    cz_n_s_per_m: float = 0.0
    crx_n_m_s_per_rad: float = 0.0
    cry_n_m_s_per_rad: float = 0.0
    name: str = "mount compliance"

    def __post_init__(self):
        for a, (k, c) in zip(_MOUNT_AXES, self._pairs()):
            kname, cname = self._names(a)
            if isinstance(k, bool) or not isinstance(k, (int, float)) or math.isnan(k) or k <= 0:
                raise BadInput(f"mount_compliance {kname} must be a number > 0 (inf: rigid), got {k!r}")
            _positive(f"mount_compliance {cname}", c, zero_ok=True)
            if math.isinf(k) and c != 0:
                raise BadInput(f"mount_compliance {cname} = {c!r} on a rigid axis ({kname} = inf): "
                               f"give {kname} a finite value or leave the damping out")

    @staticmethod
    def _names(axis: str) -> tuple[str, str]:
        if axis.startswith("r"):
            return f"k{axis}_n_m_per_rad", f"c{axis}_n_m_s_per_rad"
        return f"k{axis}_n_per_m", f"c{axis}_n_s_per_m"

    def _pairs(self) -> list[tuple[float, float]]:
        """``(stiffness, damping)`` per axis of ``x, y, z, rx, ry``."""
        return [(getattr(self, k), getattr(self, c)) for k, c in map(self._names, _MOUNT_AXES)]

    @property
    def axes(self) -> tuple[str, ...]:
        """The compliant axes (finite stiffness), in chain order."""
        return tuple(a for a, (k, _) in zip(_MOUNT_AXES, self._pairs()) if math.isfinite(k))

    def before_chain(self, b: ModelBuilder, parent: int) -> int:
        if any(n.startswith("mount_") for n in b.model.names):
            raise BadInput("two mount_compliance elements: a robot has one mount (give all its axes in one)")
        for a in self.axes:
            parent = b.model.addJoint(parent, _MOUNT_JOINTS[a](), pin.SE3.Identity(), f"mount_{a}")
        return parent

    def bind(self, robot, built=None):
        """The mount coordinates' dofs with their stiffness and damping, each (n_axes,)."""
        kc: dict[str, tuple[float, float]] = dict(zip(_MOUNT_AXES, self._pairs()))
        iv = np.array([robot.model.joints[robot.model.getJointId(f"mount_{a}")].idx_v for a in self.axes], dtype=int)
        return _Diagonal(iv=iv, dk=np.array([kc[a][0] for a in self.axes]), dd=np.array([kc[a][1] for a in self.axes]))

    def force(self, robot, ix, data, q, v, theta):
        return _diagonal_force(robot.nv, ix.iv, ix.dk, ix.dd, q, v)

    def tangent(self, robot, ix, data, q, v, theta, engaged=False):
        return diagonal_tangent(robot.nv, ix.iv, ix.dk, ix.dd)


LOAD_STIFFENING_MAX = 2.0     # catalogue K3 / K1 <= 3 (harmonic drives 1.5-3, cycloidal reducers 2-3)


@dataclass(frozen=True)
class _Loaded:
    """Indices of :class:`LoadStiffness`: the axis's dof ``iv``, its table stiffness ``k0`` (N m/rad),
    a copy of the robot's pinocchio model with gravity on (the gear load is computed with it) and the
    element's own pinocchio workspace for it, one per thread (``workspace``; a new Data per call
    cost 66 us against 3 us for the gravity itself on a 6-axis model)."""

    iv: int
    k0: float
    gravity_model: Any
    workspace: threading.local = field(default_factory=threading.local, compare=False, repr=False)

    def data(self) -> Any:
        """This thread's pinocchio Data of ``gravity_model`` (created on first use, never a caller's)."""
        own = getattr(self.workspace, "data", None)
        if own is None:
            own = self.workspace.data = self.gravity_model.createData()
        return own

    def __reduce__(self):
        """Pickled without the workspace (a thread's scratch; a robot goes to worker processes)."""
        return (_Loaded, (self.iv, self.k0, self.gravity_model))


@dataclass(frozen=True)
class LoadStiffness(Element):
    """Motion axis ``joint`` (1-based) whose gear stiffens with the static torque it transmits.

    Physics. Gear trains (harmonic drives, cycloidal reducers) are softest near zero torque and stiffen
    as the transmitted torque rises; catalogues give a three-segment torque-windup curve with tangent
    stiffness ``K1 < K2 < K3`` (``K3 / K1`` about 1.5-3). Here the tangent stiffness rises linearly
    with the static torque ``tau`` up to the reference torque ``T`` (the catalogue's T2) and stays at the
    top value beyond it::

        k(tau) = k0 (1 + c min(|tau| / T, 1)),   0 <= c <= 2 (K3 / K1 <= 3)

    ``k0`` the joint table's stiffness (the gear unloaded). ``tau`` is the static gravity torque the
    gear carries at the pose, ``g_j(q)`` of pinocchio's generalized gravity with the field
    ``g_m_per_s2`` (on even when the variant's dynamics omit gravity: a robot in a hammer test stands
    in it). Which gears carry it: a gravity compensation by the drive (axes 3 and 5 of the TX200, the
    motor's feed-forward torque) passes through the gear, so that gear carries ``g_j``; a balancer
    spring in parallel with the gear (axis 2 of the TX200, the preloaded spring in its arm) carries
    the load beside it, the gear only the unknown remainder; a vertical axis (axis 1) carries none.

    Force: ``-(k(q) - k0) (q_j - theta_j)``; tangent ``-(k - k0)`` on the axis plus
    ``-(q_j - theta_j) dk/dq`` (zero where the spring is at rest, e.g. a compensated axis).

    Parameters
    ----------
    joint : int, 1..n
    stiffening : float, 0..2      ``c``: top stiffness over unloaded minus 1
    reference_torque_n_m : float > 0      ``T``, N m
    g_m_per_s2 : float > 0        gravity field for the gear load, m/s^2
    """

    joint: int
    stiffening: float
    reference_torque_n_m: float
    g_m_per_s2: float = 9.81
    name: str = "load stiffness"

    def __post_init__(self):
        if isinstance(self.joint, bool) or not isinstance(self.joint, int) or self.joint < 1:
            raise BadInput(f"load_stiffness joint must be an axis number 1, 2, ..., got {self.joint!r}")
        c = self.stiffening
        if isinstance(c, bool) or not isinstance(c, (int, float)) or not 0.0 <= c <= LOAD_STIFFENING_MAX:
            raise BadInput(f"load_stiffness stiffening must be a number in [0, {LOAD_STIFFENING_MAX:g}] "
                           f"(catalogue K3 / K1 - 1), got {c!r}")
        _positive("load_stiffness reference_torque_n_m", self.reference_torque_n_m)
        _positive("load_stiffness g_m_per_s2", self.g_m_per_s2)

    def bind(self, robot, built=None):
        n = robot.spec.n_joints
        if self.joint > n:
            raise BadInput(f"load_stiffness joint = {self.joint}: the robot has axes 1..{n}")
        gm = pin.Model(robot.model)
        gm.gravity = pin.Motion(np.array([0.0, 0.0, -self.g_m_per_s2]), np.zeros(3))
        return _Loaded(iv=int(robot.motion_dofs[self.joint - 1]),
                       k0=float(robot.spec.joints[self.joint - 1].stiffness_n_m_per_rad), gravity_model=gm)

    def gear_torque(self, ix: _Loaded, data, q) -> float:
        """The static torque the gear carries at link angles ``q`` (nq,), N m: ``g_j(q)``.

        Computed in a workspace of its own (``data`` untouched): a caller may still hold arrays of
        ``data`` (``pin.rnea`` returns ``data.tau``), which pinocchio's gravity would overwrite."""
        return self._gravity(ix, q)[0]

    @staticmethod
    def _gravity(ix: _Loaded, q) -> tuple[float, Any]:
        """``(g_j(q) N m, the workspace it was computed in)``: the element's own pinocchio Data, never the
        caller's."""
        own = ix.data()
        return float(pin.computeGeneralizedGravity(ix.gravity_model, own, q)[ix.iv]), own

    def added_stiffness(self, tau_n_m: float, k0: float) -> float:
        """``k(tau) - k0``, N m/rad, for the static gear torque ``tau_n_m`` and the unloaded ``k0``."""
        return k0 * self.stiffening * min(abs(tau_n_m) / self.reference_torque_n_m, 1.0)

    def force(self, robot, ix, data, q, v, theta):
        dk = self.added_stiffness(self.gear_torque(ix, data, q), ix.k0)
        tau = np.zeros(robot.nv)
        tau[ix.iv] = -dk * (q[ix.iv] - theta[self.joint - 1])
        return tau

    def tangent(self, robot, ix, data, q, v, theta, engaged=False):
        g, own = self._gravity(ix, q)             # not the caller's data: see gear_torque
        kq = np.zeros((robot.nv, robot.nv))
        kq[ix.iv, ix.iv] = -self.added_stiffness(g, ix.k0)
        if abs(g) < self.reference_torque_n_m:
            dg = pin.computeGeneralizedGravityDerivatives(ix.gravity_model, own, q)[ix.iv]
            slope = ix.k0 * self.stiffening * math.copysign(1.0, g) / self.reference_torque_n_m
            kq[ix.iv] -= (q[ix.iv] - theta[self.joint - 1]) * slope * dg
        return kq, np.zeros((robot.nv, robot.nv))


ELEMENT_TYPES: dict[str, Callable[..., Element]] = {
                 "tcp_mode": TcpOscillator.one_axis, "joint_correction": JointCorrection,
                 "orthogonal_correction": OrthogonalCorrection, "payload_mass": PayloadMass,
                 "servo_drive": ServoDrive, "backlash": GearBacklash, "tcp_oscillator": TcpOscillator,
                 "mount_compliance": MountCompliance, "load_stiffness": LoadStiffness}


def _keys(cls) -> list[str]:
    return [f.name for f in fields(cls) if f.name != "name"]


def _parameters(builder) -> tuple[list[str], list[str]]:
    """The keys of a builder's table (its parameters but ``name``) and the required ones."""
    params = [p for p in inspect.signature(builder).parameters.values() if p.name != "name"]
    return [p.name for p in params], [p.name for p in params if p.default is inspect.Parameter.empty]


def element_from_spec(spec: ElementSpec, where: str = "elements") -> Element:
    """Build the element an ``[[elements]]`` table describes; strict about its keys.

    Raises
    ------
    BadInput
        Unknown ``type``, unknown or missing keys, values of the wrong type or out of range.
    """
    builder = ELEMENT_TYPES.get(spec.type)
    if builder is None:
        raise BadInput(f"{where}: type = {spec.type!r} is not an element; valid: {', '.join(ELEMENT_TYPES)}")
    valid, required = _parameters(builder)
    unknown = sorted(set(spec.params) - set(valid))
    if unknown:
        raise BadInput(f"{where} (type {spec.type}): unknown key(s) {unknown}; valid: {valid}")
    missing = [k for k in required if k not in spec.params]
    if missing:
        raise BadInput(f"{where} (type {spec.type}): missing key(s) {missing}")
    params = dict(spec.params)
    if "direction" in params:
        params["direction"] = tuple(params["direction"]) if isinstance(params["direction"], list) else params["direction"]
    try:
        return builder(**params)
    except BadInput as e:
        raise BadInput(f"{where}: {e}") from None
    except (TypeError, ValueError) as e:
        raise BadInput(f"{where} (type {spec.type}): {e}") from None


def element_table(element: Element) -> dict:
    """The ``[[elements]]`` table of an extra element (inverse of :func:`element_from_spec`).

    A tool mode is written as its ``tcp_oscillator`` table (``k2_n_per_m = inf`` for one axis;
    ``direction`` only when it has one): reading it back gives an equal element, bit for bit."""
    for t, cls in ELEMENT_TYPES.items():
        if isinstance(cls, type) and type(element) is cls:
            out: dict[str, Any] = {"type": t}
            for k in _keys(cls):
                v = getattr(element, k)
                if v is not None:
                    out[k] = [float(x) for x in v] if isinstance(v, tuple) else v
            return out
    raise ValueError(f"{element!r} is not one of the extra elements ({', '.join(ELEMENT_TYPES)})")


def spec_table(spec: ElementSpec, where: str = "elements") -> dict:
    """The ``[[elements]]`` table of ``spec``, checked (:func:`element_from_spec`) and written in its own
    type: a ``tcp_mode`` table stays one (its frequency, damping ratio and stiffness as given, the
    direction normalized), any other is :func:`element_table` of its element."""
    element = element_from_spec(spec, where)
    if spec.type != "tcp_mode":
        return element_table(element)
    assert isinstance(element, TcpOscillator) and element.direction is not None   # one_axis always sets it
    out: dict[str, Any] = {"type": "tcp_mode"}
    out.update({k: spec.params[k] for k in ("freq_hz", "damping_ratio", "stiffness_n_per_m")})
    out["direction"] = [float(x) for x in element.direction]
    return out


@dataclass(frozen=True)
class TipDamper(Element):
    """A viscous damper at the tool tip, acting in the cut plane (process damping's time-invariant form).

    The force on the tool is ``F = -R2^T Cc R2 v_tcp`` with ``v_tcp = J q'`` the TCP velocity (base
    frame), ``R2`` the rows ``x_c, y_c`` of the cut frame (:func:`cases.milling.cut_frame` of
    ``feed_direction`` and the current tool axis) and ``Cc = [[cxx, cxy], [cxy, cyy]]`` (N s/m,
    symmetric positive semi-definite). The generalized force is ``J^T F``; its velocity tangent
    ``-J^T R2^T Cc R2 J`` is what the linearization adds to C (the position tangent, ``O(v)``, is
    omitted: it vanishes at the linearization's rest state and only slows Newton elsewhere).

    :class:`identify.cutting_effects.ProcessDamping` computes ``Cc`` from the process-damping law
    for a cut; in a TOML it is ``type = "tip_damper"`` with ``cxx_n_s_per_m``, ``cyy_n_s_per_m``,
    ``cxy_n_s_per_m`` and ``feed_direction`` (base frame).
    """

    cxx_n_s_per_m: float
    cyy_n_s_per_m: float
    cxy_n_s_per_m: float = 0.0
    feed_direction: tuple = (1.0, 0.0, 0.0)
    name: str = "tip damper"

    def __post_init__(self):
        _positive("tip_damper cxx_n_s_per_m", self.cxx_n_s_per_m, zero_ok=True)
        _positive("tip_damper cyy_n_s_per_m", self.cyy_n_s_per_m, zero_ok=True)
        cxy = self.cxy_n_s_per_m
        if isinstance(cxy, bool) or not isinstance(cxy, (int, float)) or not math.isfinite(cxy):
            raise BadInput(f"tip_damper cxy_n_s_per_m must be a finite number, got {cxy!r}")
        if cxy * cxy > self.cxx_n_s_per_m * self.cyy_n_s_per_m * (1 + 1e-9) + 1e-300:
            raise BadInput(f"tip_damper: cxy_n_s_per_m = {cxy:g} makes the damper active (cxy^2 > cxx cyy = "
                           f"{self.cxx_n_s_per_m * self.cyy_n_s_per_m:g}); valid: |cxy| <= sqrt(cxx cyy)")
        object.__setattr__(self, "feed_direction", tuple(_unit(self.feed_direction, "tip_damper feed_direction")))

    @property
    def matrix_cut(self) -> np.ndarray:
        """``Cc`` (2, 2), N s/m, in ``(x_c, y_c)``."""
        return np.array([[self.cxx_n_s_per_m, self.cxy_n_s_per_m], [self.cxy_n_s_per_m, self.cyy_n_s_per_m]])

    def _velocity_map(self, robot, d, q) -> np.ndarray:
        """``(J^T R2^T Cc R2 J)`` (nv, nv) at q, computed in the ``pin.Data`` ``d``."""
        J = np.asarray(pin.computeFrameJacobian(robot.model, d, q, robot.tcp_frame, pin.LOCAL_WORLD_ALIGNED))
        J = J.reshape(6, robot.nv)[:3]
        pin.updateFramePlacement(robot.model, d, robot.tcp_frame)
        R2 = cut_frame(np.asarray(self.feed_direction), d.oMf[robot.tcp_frame].rotation[:, 2])[:2]
        T = R2 @ J
        return T.T @ self.matrix_cut @ T

    def force(self, robot, ix, data, q, v, theta):
        return -self._velocity_map(robot, data, q) @ v

    def tangent(self, robot, ix, data, q, v, theta, engaged=False):
        return np.zeros((robot.nv, robot.nv)), -self._velocity_map(robot, data, q)


ELEMENT_TYPES["tip_damper"] = TipDamper
__all__ += ["TipDamper"]
