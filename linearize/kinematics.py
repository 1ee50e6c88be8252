"""Rigid-robot kinematics from a :class:`~cases.spec.RobotSpec`: forward, Jacobian, closed-form inverse.

SI units (m, rad); degrees appear only in messages and in names ending in ``_deg``. Nothing here
knows the TX200: the geometry is read from the spec.

Any 6-axis arm
--------------
Every public function takes a ``RobotSpec`` or a :class:`~linearize.chain.KinematicChain` and works
in controller angles (``q_joint = sign * q + offset`` inside the chain). Forward kinematics of a
spec in robolobes' own convention is the pure numpy below; any other arm's is its chain's
(:func:`linearize.chain.chain_from_spec`, pinocchio). The inverse of every arm goes through its
chain: the OPW closed form (:mod:`linearize.ik_opw`) when its geometry is ortho-parallel with a
spherical wrist (the TX200 and robolobes' own z, y, y, z, y, z arms are), otherwise the numerical
inverse (:mod:`linearize.ik_numeric`), continued from ``q_ref`` or started from the nearest OPW
arm's closed form. The branches, errors and tolerances below are the same for both; the numerical
inverse adds two failures: no convergence (:class:`UnreachableError`, which cannot tell an
unreachable target from a start too far away) and convergence onto another branch (the
:class:`SingularityError` of the singularity crossed; the start pose's branch is kept).

Conventions
-----------
* Each link frame sits at its entry joint; all link frames are parallel to the base frame at
  ``q = 0`` (zero-encoder pose). Joint ``i`` (0-based) joins ``links[i]`` to ``links[i + 1]`` and
  sits at ``o_i = links[i].com_m + links[i].next_joint_m`` in ``links[i]`` axes; it rotates about
  ``joints[i].axis`` of that frame by ``q[i]``, used as it is (no offsets).
* The flange face is at ``o_6 = links[-1].com_m + links[-1].next_joint_m`` from joint 6, the TCP at
  ``payload.tcp_m`` from the flange face (flange axes); the TCP orientation is
  ``R_flange @ payload.tcp_rotation``. Its z axis is the tool axis (out of the spindle).

Robolobes' own arms (:func:`arm_geometry`)
------------------------------------------
An anthropomorphic arm with a spherical wrist in robolobes' frames: axes z, y, y, z, y, z, the
offsets ``o_4`` (joint 4 -> 5) and ``o_5`` (joint 5 -> 6) along z so that axes 4, 5, 6 meet at
the wrist centre (joint 5); :func:`arm_geometry` reads its parameters (and raises
:class:`RobotStructureError` for another structure), and :func:`branch_of` and
:func:`singularity_measures` compute the branch indicators from them in numpy. The y offsets from
joint 1 to the wrist centre may sum to a non-zero ``y_offset`` (OPW's ``b``). The wrist centre is
``C = p - R_flange (o_5 + o_6 + tcp_m)``; the inverse (OPW, the same as Paul's decomposition for
this arm: q1 puts C in the arm plane, q2, q3 solve the planar two-link problem, q4, q5, q6 are the
z-y-z Euler angles of ``(Rz(q1) Ry(q2 + q3))^T R_flange``) is checked against that decomposition,
written in ``tests/test_ik_any.py``, to 1e-10 rad.

Branches (index ``b = 4 * shoulder + 2 * elbow + wrist``, 8 in all):

* shoulder ``front`` (0) / ``back`` (1): the wrist centre is in front of (``x > 0``) or behind
  (``x < 0``) axis 1, in the frame of link 1 (the shoulder). The back branch reaches over the
  head of the robot.
* elbow ``up`` (0) / ``down`` (1): with the elbow angle ``psi = q3 + alpha3 - alpha2`` (0 when the
  arm is stretched, ``alpha2, alpha3`` the directions of the arm and forearm in the arm plane),
  ``up`` is ``sin(psi) > 0`` on the front branch and ``sin(psi) < 0`` on the back branch (the
  mirror image): the elbow above the line from joint 2 to the wrist centre whenever the wrist
  centre is farther from axis 1 than joint 2 is. For the TX200 ``psi = q3``.
* wrist ``noflip`` (0) / ``flip`` (1): ``sin(q5) > 0`` / ``< 0`` (Staubli's ``wpositive`` /
  ``wnegative``). The flip is ``(q4 + pi, -q5, q6 + pi)``.

Each branch has one solution modulo 2 pi per joint; :func:`ik` picks the representation
``q + 2 pi k`` inside the joint range (A4, A6 of the TX200 have +-270 deg: two choices) closest
to ``q_ref`` (or to 0 without ``q_ref``).

Tolerances (module constants, documented where used)
-----------------------------------------------------
``LIMIT_TOLERANCE_DEG = 5``: a joint up to 5 deg past its datasheet limit is accepted with a
:class:`JointLimitWarning` (the paper's own Tab. 7 pose has A3 2.86 deg past +145 deg), beyond it
:class:`JointLimitError`. ``SHOULDER_TOL_M = ELBOW_TOL = WRIST_TOL = 1e-3``: closer to a
singularity than this (1 mm from axis 1; ``|sin psi|`` or ``|sin q5|`` below 1e-3, i.e. 0.057
deg), the joint rates for a unit TCP speed exceed ~1000 times their nominal value and a pose is
not usable for machining, so :class:`SingularityError` is raised.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from typing import TYPE_CHECKING, Sequence, TypeGuard, Union

from robolobes.cases.spec import RobotSpec

from .ik_errors import (_ELBOW, _NEAR_AXIS, _OK, _SHOULDER, _TOO_CLOSE, _TOO_FAR, _WRIST, REACH_EPS_M,
                        ElbowSingularityError, JointLimitError, JointLimitWarning, KinematicsError,
                        RobotStructureError, ShoulderSingularityError, SingularityError, TargetError,
                        UnreachableError, WristSingularityError)

if TYPE_CHECKING:
    from .chain import KinematicChain
    from .ik_opw import OPWGeometry

#: A robot for the kinematics: a spec (its chain is built once) or a chain itself.
Robot = Union[RobotSpec, "KinematicChain"]

__all__ = [
    "KinematicsError",
    "RobotStructureError",
    "TargetError",
    "UnreachableError",
    "SingularityError",
    "ShoulderSingularityError",
    "ElbowSingularityError",
    "WristSingularityError",
    "JointLimitError",
    "JointLimitWarning",
    "LIMIT_TOLERANCE_DEG",
    "SHOULDER_TOL_M",
    "ELBOW_TOL",
    "WRIST_TOL",
    "ORTHONORMAL_TOL",
    "STRUCTURE_TOL_M",
    "REACH_EPS_M",
    "BRANCHES",
    "ArmGeometry",
    "IKSolution",
    "arm_geometry",
    "rot",
    "fk",
    "fk_frames",
    "wrist_centre",
    "jacobian",
    "ik",
    "ik_all",
    "ik_batch",
    "branch_of",
    "branch_name",
    "branch_index",
    "singularity_measures",
    "check_limits",
    "check_structure",
    "NUMERIC_RESIDUAL_TOL",
    "Robot",
]

LIMIT_TOLERANCE_DEG = 5.0
SHOULDER_TOL_M = 1e-3
ELBOW_TOL = 1e-3
WRIST_TOL = 1e-3
ORTHONORMAL_TOL = 1e-6
STRUCTURE_TOL_M = 1e-9

#: Branch names by index ``4 * shoulder + 2 * elbow + wrist``.
BRANCHES: tuple[str, ...] = tuple(
    f"{s}-{e}-{w}" for s in ("front", "back") for e in ("up", "down") for w in ("noflip", "flip")
)


# ------------------------------------------------------------------------------------- rotations
def rot(axis: str, angle) -> np.ndarray:
    """Elementary rotation matrix about a frame axis.

    Parameters
    ----------
    axis : {"x", "y", "z"}
    angle : float or array (...)
        Angle in rad.

    Returns
    -------
    array (..., 3, 3)
    """
    if axis not in _AXES:
        raise ValueError(f"axis must be 'x', 'y' or 'z', got {axis!r}")
    a = np.asarray(angle, dtype=float)
    c, s = np.cos(a), np.sin(a)
    i, j = _AXES[axis]
    m = np.zeros(a.shape + (3, 3))
    k = 3 - i - j
    m[..., k, k] = 1.0
    m[..., i, i] = c
    m[..., j, j] = c
    m[..., i, j] = -s
    m[..., j, i] = s
    return m


# plane (i, j) rotated by rot(axis): x -> (y, z), y -> (z, x), z -> (x, y)
_AXES = {"x": (1, 2), "y": (2, 0), "z": (0, 1)}
_UNIT = {"x": np.array([1.0, 0, 0]), "y": np.array([0, 1.0, 0]), "z": np.array([0, 0, 1.0])}


def _offsets(spec: RobotSpec) -> np.ndarray:
    """Joint placements ``o_0 .. o_n`` (n+1, 3): o_i in links[i] axes; o_n is the flange face."""
    return np.array([ln.com_m + ln.next_joint_m for ln in spec.links])


def _as_q(spec: Robot, q) -> np.ndarray:
    q = np.asarray(q, dtype=float)
    n = _n_joints(spec)
    if q.ndim == 0 or q.shape[-1] != n:
        raise TargetError(f"q must have shape (..., {n}) (rad), got shape {q.shape}")
    if not np.all(np.isfinite(q)):
        raise TargetError(f"q must be finite, got {q}")
    return q


# ------------------------------------------------------------------------------ forward kinematics
def fk_frames(spec: Robot, q) -> tuple[np.ndarray, np.ndarray]:
    """Joint origins and link orientations in the base frame.

    Parameters
    ----------
    spec : RobotSpec
    q : array (..., n)
        Joint angles, rad.

    Returns
    -------
    positions : array (..., n + 1, 3)
        Origin of joint 1 .. n, then the flange face, m (base frame).
    rotations : array (..., n + 1, 3, 3)
        ``rotations[..., i]`` is the orientation of ``links[i]`` (the parent of joint i+1, so
        ``rotations[..., i] @ e_axis`` is the axis of joint i+1); the last entry is the flange.
        For a robot not in robolobes' own convention (a URDF or a :class:`~linearize.chain.KinematicChain`):
        the joint origins then the TCP, and the joint frames' parents then the frame of joint 6.
    """
    q = _as_q(spec, q)
    if not _toml(spec):
        return _chain_frames(_chain(spec), q)
    o = _offsets(spec)
    batch = q.shape[:-1]
    R = np.broadcast_to(np.eye(3), batch + (3, 3)).copy()
    p = np.zeros(batch + (3,))
    ps, Rs = [], []
    for i, jt in enumerate(spec.joints):
        p = p + R @ o[i]
        ps.append(p)
        Rs.append(R)
        R = R @ rot(jt.axis, q[..., i])
    p = p + R @ o[-1]
    ps.append(p)
    Rs.append(R)
    return np.stack(ps, axis=-2), np.stack(Rs, axis=-3)


def fk(spec: Robot, q) -> tuple[np.ndarray, np.ndarray]:
    """TCP pose of the rigid robot in the base frame.

    Parameters
    ----------
    spec : RobotSpec
    q : array (n,) or (..., n)
        Joint angles, rad (vectorized over leading axes).

    Returns
    -------
    p : array (..., 3)
        TCP position, m.
    R : array (..., 3, 3)
        TCP orientation (columns: TCP axes in base coordinates); ``R[..., :, 2]`` is the tool axis.
    """
    if not _toml(spec):
        return _chain(spec).fk(_as_q(spec, q))
    pos, rots = fk_frames(spec, q)
    Rf = rots[..., -1, :, :]
    p = pos[..., -1, :] + Rf @ spec.payload.tcp_m
    return p, Rf @ spec.payload.tcp_rotation


def wrist_centre(spec: Robot, q) -> np.ndarray:
    """Origin of joint 5 (the wrist centre for a spherical wrist), base frame, m; shape (..., 3).

    For a robot not in robolobes' own convention: the point nearest to axes 4, 5, 6."""
    if not _toml(spec):
        return _chain_wrist(_chain(spec), _as_q(spec, q))
    return fk_frames(spec, q)[0][..., 4, :]


def jacobian(spec: Robot, q) -> np.ndarray:
    """Geometric Jacobian of the TCP in the base frame.

    Parameters
    ----------
    spec : RobotSpec
    q : array (n,) or (..., n)
        Joint angles, rad.

    Returns
    -------
    array (..., 6, n)
        Rows 0-2: TCP linear velocity (m/s per rad/s), rows 3-5: angular velocity (base axes).
    """
    q = _as_q(spec, q)
    if not _toml(spec):
        ch = _chain(spec)
        data = ch.model.createData()
        flat = np.array([ch.jacobian(x, data) for x in q.reshape(-1, 6)])
        return flat.reshape(q.shape[:-1] + (6, 6))
    pos, rots = fk_frames(spec, q)
    p_tcp, _ = fk(spec, q)
    cols = []
    for i, jt in enumerate(spec.joints):
        # joint i+1 rotates about the axis of links[i+1] == axis of links[i] rotated by q_i (same)
        z = rots[..., i, :, :] @ _UNIT[jt.axis]
        cols.append(np.concatenate([np.cross(z, p_tcp - pos[..., i, :]), z], axis=-1))
    return np.stack(cols, axis=-1)


# ----------------------------------------------------------------------------------- arm geometry
@dataclass(frozen=True)
class ArmGeometry:
    """Parameters of an anthropomorphic arm with spherical wrist, derived from a RobotSpec.

    Attributes
    ----------
    o0 : array (3,)
        Base origin to joint 1, base axes, m.
    o1 : array (3,)
        Joint 1 to joint 2, shoulder axes, m.
    y_offset : float
        Sum of the y offsets from joint 1 to the wrist centre (shoulder axes), m. 0 for the TX200.
    a2, alpha2 : float
        Joint 2 to joint 3 in the arm plane: length (m) and direction from z towards x (rad).
    a3, alpha3 : float
        Joint 3 to the wrist centre in the arm plane: length (m) and direction (rad).
    wrist_to_tcp : array (3,)
        Wrist centre to TCP in flange axes, m.
    tcp_rotation : array (3, 3)
        TCP orientation in flange axes.
    lower, upper : array (6,)
        Joint limits, rad.
    names : tuple of str
        Joint names.
    """

    o0: np.ndarray
    o1: np.ndarray
    y_offset: float
    a2: float
    alpha2: float
    a3: float
    alpha3: float
    wrist_to_tcp: np.ndarray
    tcp_rotation: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    names: tuple[str, ...]

    @property
    def reach_max_m(self) -> float:
        """Largest distance joint 2 -> wrist centre in the arm plane (stretched), m."""
        return self.a2 + self.a3

    @property
    def reach_min_m(self) -> float:
        """Smallest distance joint 2 -> wrist centre in the arm plane (folded), m."""
        return abs(self.a2 - self.a3)


_GEOM_CACHE: dict[int, tuple[RobotSpec, ArmGeometry]] = {}


def arm_geometry(spec: RobotSpec) -> ArmGeometry:
    """Derive (and check) the closed-form IK parameters of a robot.

    Raises
    ------
    RobotStructureError
        Not 6 joints with axes z, y, y, z, y, z; wrist axes 4, 5, 6 not meeting at one point
        (x, y of joint 4 -> 5 or joint 5 -> 6 offsets above ``STRUCTURE_TOL_M`` = 1e-9 m); a
        zero-length arm or forearm.
    """
    hit = _GEOM_CACHE.get(id(spec))
    if hit is not None and hit[0] is spec:
        return hit[1]
    axes = tuple(j.axis for j in spec.joints)
    if axes != ("z", "y", "y", "z", "y", "z"):
        raise RobotStructureError(
            f"robot {spec.name!r}: closed-form IK needs 6 joints with axes z, y, y, z, y, z "
            f"(anthropomorphic arm, spherical wrist), got {', '.join(axes)}")
    o = _offsets(spec)
    for k, what in ((4, "joint 4 -> joint 5"), (5, "joint 5 -> joint 6")):
        off = np.hypot(o[k][0], o[k][1])
        if off > STRUCTURE_TOL_M:
            raise RobotStructureError(
                f"robot {spec.name!r}: the wrist axes 4, 5, 6 do not meet at one point: the {what} "
                f"offset {o[k].tolist()} m has {off:.3g} m off the z axis (tolerance {STRUCTURE_TOL_M:g} m)")
    u = o[3] + o[4]  # joint 3 -> wrist centre (rotz(q4) leaves o[4] unchanged), elbow axes
    a2, alpha2 = math.hypot(o[2][2], o[2][0]), math.atan2(o[2][0], o[2][2])
    a3, alpha3 = math.hypot(u[2], u[0]), math.atan2(u[0], u[2])
    if a2 < 1e-6 or a3 < 1e-6:
        raise RobotStructureError(
            f"robot {spec.name!r}: arm length a2 = {a2:.3g} m or forearm length a3 = {a3:.3g} m is zero "
            f"in the plane of joints 2, 3")
    g = ArmGeometry(
        o0=o[0].copy(), o1=o[1].copy(), y_offset=float(o[1][1] + o[2][1] + u[1]), a2=a2, alpha2=alpha2,
        a3=a3, alpha3=alpha3, wrist_to_tcp=o[5] + o[6] + spec.payload.tcp_m,
        tcp_rotation=np.array(spec.payload.tcp_rotation), lower=spec.joint_range_rad[:, 0].copy(),
        upper=spec.joint_range_rad[:, 1].copy(), names=tuple(j.name for j in spec.joints))
    _GEOM_CACHE[id(spec)] = (spec, g)
    return g


# --------------------------------------------------------------------------------------- branches
def branch_name(branch: int) -> str:
    """Name of a branch index, e.g. ``0 -> "front-up-noflip"``."""
    return BRANCHES[branch_index(branch)]


def branch_index(branch) -> int:
    """Branch index 0..7 from an index or a name (``"front-up-noflip"``; order of words free)."""
    if isinstance(branch, (int, np.integer)) and not isinstance(branch, bool):
        if 0 <= branch < 8:
            return int(branch)
        raise TargetError(f"branch index must be 0..7, got {branch}")
    if isinstance(branch, str):
        words = set(branch.replace("_", "-").replace(" ", "-").lower().split("-"))
        bits = []
        for pair in (("front", "back"), ("up", "down"), ("noflip", "flip")):
            got = words & set(pair)
            if len(got) != 1:
                break
            bits.append(pair.index(got.pop()))
        else:
            if len(words) == 3:
                return 4 * bits[0] + 2 * bits[1] + bits[2]
    raise TargetError(f"branch must be an index 0..7 or a name like 'front-up-noflip' (one of {list(BRANCHES)}), "
                      f"got {branch!r}")


def _xs_and_psi(g: ArmGeometry, spec: RobotSpec, q: np.ndarray):
    C = wrist_centre(spec, q) - g.o0
    xs = np.cos(q[..., 0]) * C[..., 0] + np.sin(q[..., 0]) * C[..., 1]
    psi = q[..., 2] + g.alpha3 - g.alpha2
    return xs, psi


def branch_of(spec: Robot, q) -> int | np.ndarray:
    """Branch index of joint angles ``q`` (n,) or (..., n), see the module docstring."""
    q = _as_q(spec, q)
    if not _own(spec):
        b = _bits(_indicators(spec, q))
        return int(b) if np.ndim(b) == 0 else b
    g = arm_geometry(spec)
    xs, psi = _xs_and_psi(g, spec, q)
    back = xs < 0
    down = np.where(back, np.sin(psi) > 0, np.sin(psi) < 0)
    flip = np.sin(q[..., 4]) < 0
    b = 4 * back.astype(int) + 2 * down.astype(int) + flip.astype(int)
    return int(b) if np.ndim(b) == 0 else b


def singularity_measures(spec: Robot, q) -> dict[str, np.ndarray]:
    """Distances to the three singularities at joint angles q (n,) or (..., n).

    Returns
    -------
    dict
        ``"shoulder"``: distance of the wrist centre from axis 1 beyond the y offset,
        ``sqrt(r^2 - y_offset^2)`` (m); ``"elbow"``: ``|sin psi|``; ``"wrist"``: ``|sin q5|``.
        For any arm: the absolute values of :func:`linearize.ik_opw.branch_indicators` (the same
        numbers for the TX200).
    """
    q = _as_q(spec, q)
    if not _own(spec):
        ind = np.abs(_indicators(spec, q))
        return {"shoulder": ind[..., 0], "elbow": ind[..., 1], "wrist": ind[..., 2]}
    g = arm_geometry(spec)
    C = wrist_centre(spec, q) - g.o0
    r2 = C[..., 0] ** 2 + C[..., 1] ** 2
    psi = q[..., 2] + g.alpha3 - g.alpha2
    return {"shoulder": np.sqrt(np.maximum(r2 - g.y_offset ** 2, 0.0)), "elbow": np.abs(np.sin(psi)),
            "wrist": np.abs(np.sin(q[..., 4]))}


# ----------------------------------------------------------------------------------- target check
def _check_target(p, R) -> tuple[np.ndarray, np.ndarray]:
    """Validate a target (p (..., 3), R (..., 3, 3)); project R on SO(3) when within tolerance."""
    try:
        p = np.asarray(p, dtype=float)
        R = np.asarray(R, dtype=float)
    except (TypeError, ValueError) as e:
        raise TargetError(f"target position and rotation must be numeric arrays: {e}") from None
    if p.ndim < 1 or p.shape[-1] != 3:
        raise TargetError(f"target position must have shape (3,) or (N, 3) (m), got {p.shape}")
    if R.ndim < 2 or R.shape[-2:] != (3, 3):
        raise TargetError(f"target rotation must have shape (3, 3) or (N, 3, 3), got {R.shape}")
    if not np.all(np.isfinite(p)):
        raise TargetError(f"target position must be finite, got {p}")
    if not np.all(np.isfinite(R)):
        raise TargetError(f"target rotation must be finite, got {R}")
    err = np.abs(np.swapaxes(R, -1, -2) @ R - np.eye(3)).max(axis=(-2, -1))
    det = np.linalg.det(R)
    bad = (err > ORTHONORMAL_TOL) | (det <= 0)
    if np.any(bad):
        k = np.flatnonzero(np.atleast_1d(bad))[0]
        e1 = np.atleast_1d(err)[k]
        d1 = np.atleast_1d(det)[k]
        raise TargetError(
            f"target rotation is not a proper rotation matrix: max |R^T R - I| = {e1:.3g} "
            f"(tolerance {ORTHONORMAL_TOL:g}), det = {d1:.6g} (must be +1)")
    if np.any(err > 1e-15):  # polar projection onto SO(3): R (R^T R)^(-1/2)
        U, _, Vt = np.linalg.svd(R)
        R = U @ Vt
    return p, R




def _ik_error(g: ArmGeometry | OPWGeometry, code: int, info: dict, k, where: str = "", tols=None) -> KinematicsError:
    """The exception for failure ``code`` of sample ``k`` (index into the arrays of ``info``)."""
    tols = tols or {}
    v = {key: float(val[k]) for key, val in info.items()}
    name = BRANCHES[int(v["branch"])]
    if code == _NEAR_AXIS:
        return UnreachableError(
            f"target unreachable{where}: the wrist centre is {v['r']:.6g} m from axis 1, closer than the shoulder "
            f"y offset |{g.y_offset:.6g}| m allows (by {abs(g.y_offset) - v['r']:.3g} m)")
    if code == _TOO_FAR:
        return UnreachableError(
            f"target unreachable{where} (branch {name}): the wrist centre is {v['rho']:.6g} m from joint 2 in the arm "
            f"plane, farther than the stretched arm a2 + a3 = {g.reach_max_m:.6g} m, by {v['rho'] - g.reach_max_m:.6g} m")
    if code == _TOO_CLOSE:
        return UnreachableError(
            f"target unreachable{where} (branch {name}): the wrist centre is {v['rho']:.6g} m from joint 2 in the arm "
            f"plane, closer than the folded arm |a2 - a3| = {g.reach_min_m:.6g} m, by {g.reach_min_m - v['rho']:.6g} m")
    if code == _SHOULDER:
        return ShoulderSingularityError(
            f"shoulder singularity{where}: the wrist centre is {v['h']:.3g} m from the axis of joint 1 (tolerance "
            f"{tols.get('shoulder_tol', SHOULDER_TOL_M):g} m); q1 is undetermined there")
    if code == _ELBOW:
        state = "stretched" if v["D"] > 0 else "folded"
        return ElbowSingularityError(
            f"elbow singularity{where} (branch {name}): the arm is {state}, |sin(elbow angle)| = {abs(v['spsi']):.3g} "
            f"< {tols.get('elbow_tol', ELBOW_TOL):g} (elbow angle {math.degrees(v['psi']):.4f} deg, wrist centre "
            f"{v['rho']:.6g} m from joint 2, reach {g.reach_min_m:.6g} .. {g.reach_max_m:.6g} m)")
    if code == _WRIST:
        return WristSingularityError(
            f"wrist singularity{where} (branch {name}): q5 = {math.degrees(v['q5']):.4f} deg, |sin q5| = "
            f"{abs(v['s5']):.3g} < {tols.get('wrist_tol', WRIST_TOL):g}: axes 4 and 6 are aligned, only q4 + q6 is "
            f"determined")
    raise AssertionError(code)


# ---------------------------------------------------------------------------------- limits, wraps
def _deg(x: float) -> float:
    return math.degrees(x)


def _wrap_joint(q: float, lo: float, hi: float, ref: float | None):
    """Candidates q + 2 pi k; return (value, excess_rad) with excess = 0 when inside [lo, hi]."""
    cands = q + 2 * np.pi * np.arange(-3, 4)
    exc = np.maximum(np.maximum(lo - cands, cands - hi), 0.0)
    inside = exc == 0
    target = q if ref is None else ref
    if np.any(inside):
        c = cands[inside]
        return float(c[np.argmin(np.abs(c - target))]), 0.0
    k = np.argmin(exc)
    return float(cands[k]), float(exc[k])


def _angle_text(deg: float, sign: bool = True) -> str:
    """An angle in deg for a message: 2 decimals, or 3 significant digits when huge (1e300 deg)."""
    return f"{deg:{'+' if sign else ''}{'.2f' if abs(deg) < 1e6 else '.3g'}}"


def check_limits(spec: Robot, q, tolerance_deg: float = LIMIT_TOLERANCE_DEG, *, stacklevel: int = 2) -> np.ndarray:
    """Check joint angles against the joint ranges, modulo 2 pi.

    Each angle is first taken modulo 2 pi: a value outside the range whose equivalent
    ``q + 2 pi k`` is inside is accepted silently (same physical angle) and replaced by the
    equivalent closest to it. A value whose every equivalent is outside the range by at most
    ``tolerance_deg`` is accepted with a :class:`JointLimitWarning` that names the joint, the
    given and wrapped values, the limit and the excess (the paper's Tab. 7 pose: A3 = -212.14 deg,
    i.e. +147.86 deg, 2.86 deg past +145 deg). Beyond the tolerance: :class:`JointLimitError`.

    Parameters
    ----------
    spec : RobotSpec
    q : array (n,) or (N, n)
        Joint angles, rad. For a batch, one warning per joint names the worst sample.
    tolerance_deg : float
        Accepted excess beyond a limit, deg (default ``LIMIT_TOLERANCE_DEG`` = 5 deg: covers the
        paper's own start pose with margin; the datasheet ranges are the controller's software
        limits, not hard stops).

    Returns
    -------
    array like q
        The wrapped angles (each inside its range, or at most ``tolerance_deg`` outside), rad.
    """
    q = _as_q(spec, q)
    single = q.ndim == 1
    qs = np.atleast_2d(q)
    out = qs.copy()
    lo, hi = _range(spec).T
    tol = math.radians(tolerance_deg)
    for j in range(_n_joints(spec)):
        worst = (0.0, None)
        for k in range(qs.shape[0]):
            v, exc = _wrap_joint(qs[k, j], lo[j], hi[j], qs[k, j])
            out[k, j] = v
            if exc > worst[0]:
                worst = (exc, k)
        exc, k = worst
        if k is None:
            continue
        name = _names(spec)[j]
        given, wrapped = _deg(qs[k, j]), _deg(out[k, j])
        side, lim = ("upper", hi[j]) if out[k, j] > hi[j] else ("lower", lo[j])
        wrap_txt = f", wrapped to {wrapped:+.2f} deg," if abs(given - wrapped) > 1e-9 else ""
        sample = f" (sample {k})" if not single else ""
        rng = f"[{_deg(lo[j]):+.2f}, {_deg(hi[j]):+.2f}] deg"
        if exc > tol:
            raise JointLimitError(
                f"joint {name}{sample} = {_angle_text(given)} deg{wrap_txt} is outside its range {rng} by "
                f"{_angle_text(_deg(exc), sign=False)} deg, more than the tolerance of {tolerance_deg:g} deg")
        warnings.warn(
            f"joint {name}{sample} = {given:+.2f} deg{wrap_txt} is {_deg(exc):.2f} deg past its {side} limit "
            f"{_deg(lim):+.2f} deg (range {rng}); accepted within the tolerance of {tolerance_deg:g} deg",
            JointLimitWarning, stacklevel=stacklevel)
    return out[0] if single else out


def _representation(lower: np.ndarray, upper: np.ndarray, q: np.ndarray, q_ref, limits: bool, tol: float):
    """Per joint, pick q + 2 pi k: inside the range if possible (else within tol), closest to q_ref.

    Parameters
    ----------
    q : array (..., 6), principal angles.

    Returns
    -------
    q_chosen : array (..., 6)
    status : int array (...)
        0 all inside, 1 some joint only within tolerance, 2 some joint outside.
    """
    ref = np.zeros(6) if q_ref is None else np.asarray(q_ref, dtype=float)
    cands = q[..., None] + 2 * np.pi * np.arange(-3, 4)            # (..., 6, 7)
    dist = np.abs(cands - ref[:, None])
    if not limits:
        k = np.argmin(dist, axis=-1)
        return np.take_along_axis(cands, k[..., None], -1)[..., 0], np.zeros(q.shape[:-1], int)
    exc = np.maximum(np.maximum(lower[:, None] - cands, cands - upper[:, None]), 0.0)
    level = np.where(exc == 0, 0, np.where(exc <= tol, 1, 2))
    # lexicographic: level first, then distance to ref (level 2: smallest excess)
    key = level * 1e6 + np.where(level == 2, exc, dist)
    k = np.argmin(key, axis=-1)
    out = np.take_along_axis(cands, k[..., None], -1)[..., 0]
    lev = np.take_along_axis(level, k[..., None], -1)[..., 0]
    return out, lev.max(axis=-1)


# ---------------------------------------------------------------------------------------- public IK
@dataclass(frozen=True)
class IKSolution:
    """One inverse-kinematics solution.

    Attributes
    ----------
    q : array (6,)
        Joint angles, rad (representation chosen within the limits when possible).
    branch : int
        Branch index 0..7 (see :data:`BRANCHES`).
    within_limits : bool
        Every joint inside its range (strictly; a joint within the tolerance band counts as False).
    """

    q: np.ndarray
    branch: int
    within_limits: bool

    @property
    def branch_name(self) -> str:
        return BRANCHES[self.branch]


def _solve_all(spec, p, R, q_ref, limits, tol, branches: Sequence[int] = range(8), **tols):
    p, R = _check_target(p, R)
    if p.shape != (3,) or R.shape != (3, 3):
        raise TargetError(f"ik expects one target: p (3,), R (3, 3); got {p.shape}, {R.shape} (use ik_batch)")
    q, code, error = _chain_all(_chain(spec), p, R, q_ref, branches, tols)
    lower, upper = _range(spec).T
    qc, status = _representation(lower, upper, np.nan_to_num(q), q_ref, limits, tol)
    sols, errs = [], {}
    for b in branches:
        if code[b] != _OK:
            errs[b] = error(b)
        else:
            sols.append((IKSolution(q=qc[b], branch=b, within_limits=bool(status[b] == 0)), int(status[b])))
    return sols, errs


def ik_all(spec: Robot, p, R, *, q_ref=None, shoulder_tol: float = SHOULDER_TOL_M,
           elbow_tol: float = ELBOW_TOL, wrist_tol: float = WRIST_TOL) -> list[IKSolution]:
    """All IK solutions (up to 8, one per branch) of a TCP pose (closed form or numerical, see above).

    Parameters
    ----------
    spec : RobotSpec
    p : array (3,)
        TCP position, base frame, m.
    R : array (3, 3)
        TCP orientation (tool axis ``R[:, 2]``); must be orthonormal to ``ORTHONORMAL_TOL``.
    q_ref : array (6,), optional
        Reference pose for the 2 pi representation of each joint (default: closest to 0).
    shoulder_tol, elbow_tol, wrist_tol : float
        Singularity tolerances (see the module docstring).

    Returns
    -------
    list of IKSolution
        One per branch that is reachable and not singular, in branch order; each ``q`` is taken
        inside the joint range when an equivalent ``q + 2 pi k`` is (``within_limits`` tells).

    Raises
    ------
    UnreachableError, SingularityError
        When no branch has a solution (the error of the lowest branch index is raised).
    TargetError
        Malformed target.
    """
    if q_ref is not None:
        q_ref = _as_q(spec, q_ref)
    sols, errs = _solve_all(spec, p, R, q_ref, True, math.radians(LIMIT_TOLERANCE_DEG),
                               shoulder_tol=shoulder_tol, elbow_tol=elbow_tol, wrist_tol=wrist_tol)
    if not sols:
        raise errs[min(errs)]
    return [s for s, _ in sols]


def ik(spec: Robot, p, R, *, branch=None, q_ref=None, limits: bool = True,
       tolerance_deg: float = LIMIT_TOLERANCE_DEG, shoulder_tol: float = SHOULDER_TOL_M,
       elbow_tol: float = ELBOW_TOL, wrist_tol: float = WRIST_TOL) -> np.ndarray:
    """Inverse kinematics: joint angles that put the TCP at ``(p, R)`` (closed form or numerical, see above).

    Parameters
    ----------
    spec : RobotSpec
    p : array (3,)
        TCP position, base frame, m.
    R : array (3, 3)
        TCP orientation in the base frame; must be orthonormal to ``ORTHONORMAL_TOL`` (1e-6, then
        projected onto SO(3)).
    branch : None, int 0..7 or str
        Branch (index or name such as ``"front-up-noflip"``). None: the branch of ``q_ref`` when
        given (path continuation), else the first branch in index order whose solution is inside
        the joint limits or within ``tolerance_deg`` of them (so ``front-up-noflip`` whenever it
        exists).
    q_ref : array (6,), optional
        Previous pose along a path, rad. Each joint's 2 pi representation is the one closest to
        it; with ``branch=None`` the solution is continued on the branch of ``q_ref`` (if that
        branch fails, e.g. at a singularity, its error is raised rather than jumping branch).
    limits : bool
        If True, representations are chosen inside the joint range (A4, A6: +-270 deg), a joint
        within ``tolerance_deg`` outside is accepted with a :class:`JointLimitWarning`, and a
        solution out of range raises :class:`JointLimitError`. If False, the closest
        representation to ``q_ref`` (or to 0) is returned, unchecked.
    tolerance_deg : float
        See :func:`check_limits`.
    shoulder_tol, elbow_tol, wrist_tol : float
        Singularity tolerances (m, -, -).

    Returns
    -------
    array (6,)
        Joint angles, rad.

    Raises
    ------
    UnreachableError, ShoulderSingularityError, ElbowSingularityError, WristSingularityError,
    JointLimitError, TargetError
    """
    if q_ref is not None:
        q_ref = _as_q(spec, q_ref)
        if q_ref.shape != (_n_joints(spec),):
            raise TargetError(f"q_ref must have shape ({_n_joints(spec)},), got {q_ref.shape}")
    tol = math.radians(tolerance_deg)
    want = None if branch is None else branch_index(branch)
    if want is None and q_ref is not None:
        want = int(branch_of(spec, q_ref))
    tols = dict(shoulder_tol=shoulder_tol, elbow_tol=elbow_tol, wrist_tol=wrist_tol)
    sols, errs = _solve_all(spec, p, R, q_ref, limits, tol, range(8) if want is None else (want,), **tols)
    if want is not None:
        if want in errs:
            raise errs[want]
        sol, status = next((s, st) for s, st in sols if s.branch == want)
    else:
        if not sols:
            raise errs[min(errs)]
        sol, status = min(sols, key=lambda x: (x[1] == 2, x[0].branch)) if limits else sols[0]
    if limits:
        if status == 2:
            others = [s.branch_name for s, st in sols if st < 2]
            hint = f"; branches within limits: {others}" if others else "; no branch is within the limits"
            try:
                check_limits(spec, sol.q, tolerance_deg, stacklevel=3)
            except JointLimitError as e:
                raise JointLimitError(f"IK branch {sol.branch_name}: {e}{hint}") from None
        elif status == 1:
            check_limits(spec, sol.q, tolerance_deg, stacklevel=3)
    return sol.q


def ik_batch(spec: Robot, p, R, branch, *, errors: str = "raise", shoulder_tol: float = SHOULDER_TOL_M,
             elbow_tol: float = ELBOW_TOL, wrist_tol: float = WRIST_TOL, where=None, q_ref=None) -> np.ndarray:
    """Vectorized IK, principal angles (closed form or numerical, see the module docstring).

    Parameters
    ----------
    spec : RobotSpec
    p : array (N, 3)
        TCP positions, m.
    R : array (N, 3, 3) or (3, 3)
        TCP orientations (one shared orientation allowed).
    branch : int, str, or int array (N,)
        Branch index or name (one for all targets, or one per target).
    errors : {"raise", "nan"}
        On an unreachable or singular sample: raise its error (the first one), or return NaN
        rows for the failing samples.
    where : callable, optional
        ``where(k) -> str`` describing sample k in error messages.
    q_ref : array (6,), optional
        Numerical inverse only (arms that are not OPW): the pose the continuation starts from, rad
        (the targets are solved in order, each from the previous solution); default: the closed
        form of the nearest OPW arm for the first target. The closed forms do not use it.

    Returns
    -------
    array (N, 6)
        Joint angles in (-pi, pi], rad; no limit check, no 2 pi continuation (see
        :class:`linearize.path.Pass` for continuation along a path).

    Raises
    ------
    UnreachableError, SingularityError
        For the first offending sample (``errors="raise"``).
    """
    if errors not in ("raise", "nan"):
        raise ValueError(f"errors must be 'raise' or 'nan', got {errors!r}")
    p, R = _check_target(p, R)
    if isinstance(branch, (str, int, np.integer)):
        b = branch_index(branch)
    else:
        b = np.asarray(branch)
        if not np.issubdtype(b.dtype, np.integer) or np.any((b < 0) | (b > 7)):
            raise TargetError(f"branch array must hold integers 0..7, got {branch!r}")
    tols = dict(shoulder_tol=shoulder_tol, elbow_tol=elbow_tol, wrist_tol=wrist_tol)
    if q_ref is not None:
        q_ref = _as_q(spec, q_ref)
    return _chain_batch(_chain(spec), p, R, b, errors, tols, where, q_ref)


# --------------------------------------------------------------------------- any arm, through its chain
_NO_CONVERGENCE, _OTHER_BRANCH = 7, 8
#: FK(IK) residual (|log6|, m and rad) above which a numerical solution is not accepted.
NUMERIC_RESIDUAL_TOL = 1e-11
_OWN_CACHE: dict[int, tuple[RobotSpec, bool]] = {}


def _toml(spec) -> TypeGuard[RobotSpec]:
    """robolobes' own TOML convention (numpy forward kinematics, any number of joints)."""
    return isinstance(spec, RobotSpec) and getattr(spec, "urdf", None) is None


def _own(spec) -> TypeGuard[RobotSpec]:
    """robolobes' own convention with :func:`arm_geometry`'s structure (numpy branch indicators)."""
    if not _toml(spec):
        return False
    hit = _OWN_CACHE.get(id(spec))
    if hit is not None and hit[0] is spec:
        return hit[1]
    try:
        arm_geometry(spec)
        ok = True
    except RobotStructureError:
        ok = False
    _OWN_CACHE[id(spec)] = (spec, ok)
    return ok


def _chain(spec) -> KinematicChain:
    from .chain import KinematicChain, chain_from_spec
    return spec if isinstance(spec, KinematicChain) else chain_from_spec(spec)


def _n_joints(spec) -> int:
    return spec.n_joints if _toml(spec) else 6


def _range(spec) -> np.ndarray:
    return spec.joint_range_rad if _toml(spec) else _chain(spec).range_rad


def _names(spec) -> tuple[str, ...]:
    if isinstance(spec, RobotSpec) and len(spec.joints) == _n_joints(spec):
        return tuple(j.name for j in spec.joints)
    return tuple(str(n) for n in _chain(spec).model.names[1:7])


def check_structure(spec: Robot) -> None:
    """Raise :class:`RobotStructureError` before any work when the robot has no inverse kinematics here.

    Every 6-axis chain gets the OPW closed form (:mod:`linearize.ik_opw`) or the numerical inverse
    (:mod:`linearize.ik_numeric`); only a chain without an arm plane (axes 1 and 2 parallel, joint 3
    on axis 2) is refused.
    """
    if not _own(spec):
        from .ik_opw import opw_geometry
        opw_geometry(_chain(spec))


def _principal(q: np.ndarray) -> np.ndarray:
    """Angles in (-pi, pi], rad."""
    return np.pi - np.mod(np.pi - q, 2 * np.pi)


def _indicators(spec, q: np.ndarray) -> np.ndarray:
    from .ik_opw import branch_indicators
    ch = _chain(spec)
    return branch_indicators(ch, ch.joint_positions(q))


def _bits(ind: np.ndarray) -> np.ndarray:
    """Branch index of indicators (..., 3), as :func:`branch_of`."""
    back = ind[..., 0] < 0
    down = np.where(back, ind[..., 1] > 0, ind[..., 1] < 0)
    return 4 * back.astype(int) + 2 * down.astype(int) + (ind[..., 2] < 0).astype(int)


def _chain_frames(ch: KinematicChain, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    import pinocchio as pin
    data = ch.model.createData()
    flat = ch.joint_positions(q).reshape(-1, 6)
    P, Rs = np.empty((len(flat), 7, 3)), np.empty((len(flat), 7, 3, 3))
    for n, x in enumerate(flat):
        pin.framesForwardKinematics(ch.model, data, x)
        frames = [data.oMi[j] for j in range(1, 7)] + [data.oMf[ch.tcp_frame_id]]
        P[n] = [m.translation for m in frames]
        Rs[n] = [m.rotation for m in frames]
    return P.reshape(q.shape[:-1] + (7, 3)), Rs.reshape(q.shape[:-1] + (7, 3, 3))


def _chain_wrist(ch: KinematicChain, q: np.ndarray) -> np.ndarray:
    from .chain import joint_axes
    from .ik_opw import wrist_point
    data = ch.model.createData()
    flat = ch.joint_positions(q).reshape(-1, 6)
    return np.array([wrist_point(*joint_axes(ch, x, data)) for x in flat]).reshape(q.shape[:-1] + (3,))


def _chain_all(ch: KinematicChain, p, R, q_ref, branches, tols):
    """Principal controller angles (8, 6) of one validated target, codes (8,), error(b) -> exception."""
    from .ik_opw import opw_geometry, opw_solve
    g = opw_geometry(ch)
    if not g.is_opw:
        return _numeric_all(ch, p, R, q_ref, branches, tols)
    th, code, info = opw_solve(g, p[None], R[None], **tols)
    q = _principal(ch.controller_angles(g.sign * th[0] + g.zero))
    one = {k: v[0] for k, v in info.items()}
    return q, code[0], lambda b: _ik_error(g, int(code[0][b]), one, b, tols=tols)


def _opw_seeds(ch: KinematicChain, p, R) -> np.ndarray:
    """Start poses (8, 6), controller angles: the closed form of the OPW arm nearest to the chain."""
    from .ik_opw import opw_geometry, opw_solve
    g = opw_geometry(ch)
    th, _, _ = opw_solve(g, p[None], R[None], shoulder_tol=0.0, elbow_tol=0.0, wrist_tol=0.0)
    return _principal(ch.controller_angles(g.sign * th[0] + g.zero))


def _numeric_one(ch: KinematicChain, p, R, start, b: int, tols, data=None) -> tuple[np.ndarray, int, dict]:
    """Damped least squares from ``start`` for branch ``b``: (q (6,), code, values for the message)."""
    from .ik_numeric import dls_solve
    from .ik_opw import branch_indicators
    q, res, it = dls_solve(ch, p, R, start, data)
    ind = branch_indicators(ch, ch.joint_positions(q))
    v = dict(residual=res, iterations=it, xs=ind[0], spsi=ind[1], s5=ind[2], landed=int(_bits(ind)),
             branch=b, start=np.asarray(start, dtype=float))
    if not res < NUMERIC_RESIDUAL_TOL:
        return q, _NO_CONVERGENCE, v
    if abs(ind[0]) < tols["shoulder_tol"]:
        return q, _SHOULDER, v
    if abs(ind[1]) < tols["elbow_tol"]:
        return q, _ELBOW, v
    if abs(ind[2]) < tols["wrist_tol"]:
        return q, _WRIST, v
    return q, (_OK if v["landed"] == b else _OTHER_BRANCH), v


def _numeric_all(ch: KinematicChain, p, R, q_ref, branches, tols):
    q = np.full((8, 6), np.nan)
    code = np.full(8, _OK)
    vals: dict[int, dict] = {}
    ref_branch = None if q_ref is None else int(_bits(_indicators(ch, q_ref)))
    seeds = None
    data = ch.model.createData()
    for b in branches:
        if ref_branch == b:
            start = q_ref
        else:
            seeds = _opw_seeds(ch, p, R) if seeds is None else seeds
            start = seeds[b]
        q[b], code[b], vals[b] = _numeric_one(ch, p, R, start, b, tols, data)
    return _principal(q), code, lambda b: _numeric_error(int(code[b]), vals[b], "", tols)


def _chain_batch(ch: KinematicChain, p, R, b, errors, tols, where, q_ref) -> np.ndarray:
    from .ik_opw import opw_geometry, opw_solve
    lead = p.shape[:-1]
    P = p.reshape(-1, 3)
    Rb = np.broadcast_to(R, lead + (3, 3)).reshape(-1, 3, 3)
    bb = np.broadcast_to(b, lead).reshape(-1).astype(int)
    g = opw_geometry(ch)
    n = np.arange(len(P))
    if g.is_opw:
        th, code8, info8 = opw_solve(g, P, Rb, **tols)
        q = _principal(ch.controller_angles(g.sign * th[n, bb] + g.zero))
        code = code8[n, bb]
        info = {k: v[n, bb] for k, v in info8.items()}
        error = lambda k, w: _ik_error(g, int(code[k]), info, k, w, tols)
    else:
        q, code, vals = np.empty((len(P), 6)), np.full(len(P), _OK), {}
        prev = q_ref
        data = ch.model.createData()
        for k in n:
            start = prev if prev is not None and int(_bits(_indicators(ch, prev))) == bb[k] else None
            if start is None:
                start = _opw_seeds(ch, P[k], Rb[k])[bb[k]]
            q[k], code[k], vals[k] = _numeric_one(ch, P[k], Rb[k], start, int(bb[k]), tols, data)
            if code[k] == _OK:
                prev = q[k]
            elif errors == "raise":
                break
        q = _principal(q)
        error = lambda k, w: _numeric_error(int(code[k]), vals[k], w, tols)
    bad = code != _OK
    if np.any(bad):
        if errors == "nan":
            q = np.where(bad[:, None], np.nan, q)
        else:
            k = int(np.flatnonzero(bad)[0])
            raise error(k, where(k) if where else "")
    return q.reshape(lead + (6,))


def _numeric_error(code: int, v: dict, where: str, tols) -> KinematicsError:
    """The exception for a numerical-inverse failure (values ``v`` of :func:`_numeric_one`)."""
    name = BRANCHES[v["branch"]]
    if code == _NO_CONVERGENCE:
        return UnreachableError(
            f"target unreachable{where} (branch {name}): the numerical inverse did not converge from its start "
            f"pose {np.degrees(v['start']).round(2).tolist()} deg: |log6 error| = {v['residual']:.3g} after "
            f"{v['iterations']} steps (needs < {NUMERIC_RESIDUAL_TOL:g}); the target is out of reach, or too far "
            f"from the start pose on this branch")
    if code == _SHOULDER:
        return ShoulderSingularityError(
            f"shoulder singularity{where}: the wrist centre is {abs(v['xs']):.3g} m from the axis of joint 1 "
            f"(tolerance {tols['shoulder_tol']:g} m); q1 is undetermined there")
    if code == _ELBOW:
        return ElbowSingularityError(
            f"elbow singularity{where} (branch {name}): |sin(elbow angle)| = {abs(v['spsi']):.3g} < "
            f"{tols['elbow_tol']:g}: the arm is stretched or folded")
    if code == _WRIST:
        return WristSingularityError(
            f"wrist singularity{where} (branch {name}): |sin q5| = {abs(v['s5']):.3g} < {tols['wrist_tol']:g}: "
            f"axes 4 and 6 are aligned, only q4 + q6 is determined")
    if code == _OTHER_BRANCH:
        landed = v["landed"]
        diff = landed ^ v["branch"]
        kind, cls = ((("shoulder", ShoulderSingularityError) if diff & 4 else
                      ("elbow", ElbowSingularityError) if diff & 2 else ("wrist", WristSingularityError)))
        return cls(
            f"{kind} singularity{where}: continued from its start pose on branch {name}, the numerical inverse "
            f"reached branch {BRANCHES[landed]}: the motion crosses the {kind} singularity between them; refused "
            f"(the start pose's branch is kept)")
    raise AssertionError(code)
