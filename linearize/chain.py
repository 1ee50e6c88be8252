"""The rigid kinematic chain of a 6-axis arm, as pinocchio has it, with the controller's angle convention.

A :class:`KinematicChain` is constant data (a rigid pinocchio ``Model``, the TCP frame, and per joint
the map from the controller's angle to pinocchio's joint position); each call makes or takes its own
``pin.Data``. Controller angles (what ``poses.csv``, ``--q-deg``, the cases and the inverse
kinematics use) relate to pinocchio's joint positions by::

    q_joint = sign * q_controller + offset_rad        (per joint, sign = +-1, rad)

:func:`chain_from_spec` builds the chain of a robot spec: robolobes' own TOML convention (link
frames parallel to the base at q = 0, no offsets, signs +1) here, a URDF robot through
:func:`robolobes.linearize.urdf.rigid_chain`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from robolobes.cases.spec import RobotSpec
from robolobes.core.errors import BadInput

__all__ = ["KinematicChain", "chain_from_spec", "joint_axes"]

_JOINT = {"x": pin.JointModelRX, "y": pin.JointModelRY, "z": pin.JointModelRZ}
_REVOLUTE = ("JointModelRX", "JointModelRY", "JointModelRZ", "JointModelRevoluteUnaligned")


@dataclass(frozen=True, eq=False)
class KinematicChain:
    """Rigid kinematics of a 6-axis arm, as pinocchio has it.

    Attributes
    ----------
    model : pin.Model
        Rigid model, 6 revolute joints, ``nq == nv == 6`` (gravity and inertias are irrelevant).
    tcp_frame_id : int
        Frame of the TCP; its z axis is the tool axis (away from the flange).
    sign : array (6,)
        +-1 per joint: pinocchio joint position = ``sign * controller angle + offset_rad``.
    offset_rad : array (6,)
        rad.
    range_rad : array (6, 2)
        Controller-angle limits (lower, upper), rad.
    name : str
    """

    model: pin.Model
    tcp_frame_id: int
    sign: np.ndarray
    offset_rad: np.ndarray
    range_rad: np.ndarray
    name: str = ""

    @classmethod
    def from_pinocchio(cls, model, tcp_frame_id, sign, offset_rad, range_rad, name="") -> KinematicChain:
        """Check and freeze the parts of a chain.

        Raises
        ------
        BadInput
            Not 6 one-DOF revolute joints in a serial chain, a TCP frame id out of range, a sign
            not +-1, an offset or range of the wrong shape or not finite, a range with lower > upper.
        """
        label = f"robot {name!r}: " if name else ""
        kinds = [model.joints[j].shortname() for j in range(1, model.njoints)]
        if model.nq != 6 or model.nv != 6 or len(kinds) != 6 or any(k not in _REVOLUTE for k in kinds):
            raise BadInput(f"{label}a kinematic chain needs 6 revolute joints (nq = nv = 6), got nq = {model.nq}, "
                           f"nv = {model.nv}, joints {kinds}")
        if any(model.parents[j] != j - 1 for j in range(1, model.njoints)):
            raise BadInput(f"{label}the 6 joints must form one serial chain, got parents {list(model.parents)[1:]}")
        if not 0 <= int(tcp_frame_id) < model.nframes:
            raise BadInput(f"{label}TCP frame id {tcp_frame_id} is not a frame of the model (0..{model.nframes - 1})")
        sign = np.array(sign, dtype=float).reshape(-1)
        offset = np.array(offset_rad, dtype=float).reshape(-1)
        rng = np.array(range_rad, dtype=float)
        if sign.shape != (6,) or not np.all(np.abs(sign) == 1):
            raise BadInput(f"{label}sign must be 6 values of +1 or -1, got {sign.tolist()}")
        if offset.shape != (6,) or not np.all(np.isfinite(offset)):
            raise BadInput(f"{label}offset_rad must be 6 finite values (rad), got {offset.tolist()}")
        if rng.shape != (6, 2) or np.any(np.isnan(rng)) or np.any(rng[:, 0] > rng[:, 1]):
            raise BadInput(f"{label}range_rad must be (6, 2) with lower <= upper (rad), got {rng.tolist()}")
        for a in (sign, offset, rng):
            a.setflags(write=False)
        return cls(model=model, tcp_frame_id=int(tcp_frame_id), sign=sign, offset_rad=offset, range_rad=rng,
                   name=name)

    # ----------------------------------------------------------------------------- conventions
    def joint_positions(self, q) -> np.ndarray:
        """pinocchio joint positions (..., 6) of controller angles q (..., 6), rad."""
        return self.sign * np.asarray(q, dtype=float) + self.offset_rad

    def controller_angles(self, q_joint) -> np.ndarray:
        """Controller angles (..., 6) of pinocchio joint positions (..., 6), rad."""
        return self.sign * (np.asarray(q_joint, dtype=float) - self.offset_rad)

    # -------------------------------------------------------------------------------- kinematics
    def fk(self, q, data: pin.Data | None = None) -> tuple[np.ndarray, np.ndarray]:
        """TCP pose at controller angles q (6,) or (..., 6), rad: ``p (..., 3)`` m and ``R (..., 3, 3)``
        (columns: TCP axes in the base frame; ``R[..., :, 2]`` is the tool axis)."""
        work = self.model.createData() if data is None else data
        qj = self.joint_positions(q)
        flat = qj.reshape(-1, 6)
        P, R = np.empty((len(flat), 3)), np.empty((len(flat), 3, 3))
        for k, x in enumerate(flat):
            pin.framesForwardKinematics(self.model, work, x)
            M = work.oMf[self.tcp_frame_id]
            P[k], R[k] = M.translation, M.rotation
        return P.reshape(qj.shape[:-1] + (3,)), R.reshape(qj.shape[:-1] + (3, 3))

    def jacobian(self, q, data: pin.Data | None = None) -> np.ndarray:
        """Geometric TCP Jacobian (6, 6) at controller angles q (6,), per rad/s of controller angle:
        rows 0-2 TCP linear velocity (m/s), rows 3-5 angular velocity, base axes."""
        work = self.model.createData() if data is None else data
        J = pin.computeFrameJacobian(self.model, work, self.joint_positions(q), self.tcp_frame_id,
                                     pin.LOCAL_WORLD_ALIGNED)
        return np.asarray(J) * self.sign


def joint_axes(chain: KinematicChain, q_joint, data: pin.Data | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Joint axes at pinocchio joint positions q_joint (6,), rad.

    Returns
    -------
    points : array (6, 3)
        Origin of each joint (a point on its axis), base frame, m.
    directions : array (6, 3)
        Unit axis direction of each joint (positive rotation by the right-hand rule), base frame.
    """
    model = chain.model
    work = model.createData() if data is None else data
    q_joint = np.asarray(q_joint, dtype=float)
    pin.computeJointJacobians(model, work, q_joint)
    J = np.asarray(work.J)
    points = np.array([work.oMi[j].translation for j in range(1, 7)])
    dirs = np.array([J[3:, model.joints[j].idx_v] for j in range(1, 7)])
    return points, dirs / np.linalg.norm(dirs, axis=1)[:, None]


_CACHE: dict[int, tuple[RobotSpec, KinematicChain]] = {}


def chain_from_spec(spec: RobotSpec) -> KinematicChain:
    """The rigid kinematic chain of a robot spec (built once per spec object).

    robolobes' TOML convention: joint ``i`` at ``links[i].com_m + links[i].next_joint_m`` in the
    frame of ``links[i]``, rotating about ``joints[i].axis`` of it; the flange at the exit of the
    last link, the TCP at ``payload.tcp_m`` / ``payload.tcp_rotation`` from it (as
    :func:`linearize.kinematics.fk_frames` and :func:`linearize.kinematics.fk`); sign +1, offset 0.
    A spec with a URDF is built by :func:`robolobes.linearize.urdf.rigid_chain`.
    """
    hit = _CACHE.get(id(spec))
    if hit is not None and hit[0] is spec:
        return hit[1]
    if getattr(spec, "urdf", None) is not None:
        import importlib  # linearize/urdf.py builds URDF robots (its own module, loaded only for them)
        chain = importlib.import_module(".urdf", __package__).rigid_chain(spec)
    else:
        chain = _toml_chain(spec)
    _CACHE[id(spec)] = (spec, chain)
    return chain


def _toml_chain(spec: RobotSpec) -> KinematicChain:
    if spec.n_joints != 6:
        raise BadInput(f"robot {spec.name!r}: a kinematic chain needs 6 joints, got {spec.n_joints}")
    model = pin.Model()
    model.name = spec.name
    model.gravity = pin.Motion.Zero()
    parent = 0
    for link, js in zip(spec.links[:-1], spec.joints):
        placement = pin.SE3(np.eye(3), np.asarray(link.com_m + link.next_joint_m))
        parent = model.addJoint(parent, _JOINT[js.axis](), placement, js.name)
    last = spec.links[-1]
    flange = pin.SE3(np.eye(3), np.asarray(last.com_m + last.next_joint_m))
    tcp = flange * pin.SE3(np.asarray(spec.payload.tcp_rotation), np.asarray(spec.payload.tcp_m))
    fid = model.addFrame(pin.Frame("tcp", parent, tcp, pin.FrameType.OP_FRAME))
    return KinematicChain.from_pinocchio(model, fid, np.ones(6), np.zeros(6), spec.joint_range_rad, spec.name)
