"""Where the tool is: the poses a map sweeps over, and the robot's joint angles there.

A pose of the workspace is the paper's pass moved and turned (all SI, base frame):

* ``offset_m`` (3,): translation of the pass start from the case's start TCP position;
* ``yaw_rad``: turn of the part (feed direction and TCP frame) about the base z axis through the
  pass start;
* ``tool_rotation_rad``: turn of the TCP frame about the tool's own axis (the redundant DOF of
  milling: the cut is the same, the robot's posture is not);
* ``tilt_rad``: turn of the TCP frame about the feed direction (the tool axis tilts sideways; the
  feed stays perpendicular to it, which the 2.5-D cut model needs -- a *lead* angle, which tilts
  the axis towards the feed, is refused for that reason);
* ``s_m``: travel along the (moved) pass.

The joint angles come from the closed-form IK of :mod:`robolobes.linearize` on the branch of the
case's start pose, each joint's 2 pi representation closest to a reference pose (the start pose, or
the previous pose along a pass: a continuous branch). Targets that are unreachable, singular or
past the joint limits are kept with a reason code, never dropped. Joint limits: accepted up to
``LIMIT_TOLERANCE_DEG`` (5 deg) past the datasheet range, as the case loader does (the paper's
Tab. 7 pose is 2.86 deg past A3's +145 deg); a pose inside the strict ranges is flagged too.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from robolobes.cases.spec import MillingCase
from robolobes.linearize.kinematics import (JointLimitError, JointLimitWarning, KinematicsError, SingularityError,
                                            UnreachableError, fk, ik, singularity_measures)

__all__ = ["REASONS", "PoseTarget", "target", "solve_pose", "PoseSolution", "start_pose"]

#: reason codes stored per pose (``reason`` variable of a map), with their meaning
REASONS = {
    0: "ok: inside the strict joint ranges",
    1: "ok within tolerance: some joint past its datasheet range by at most 5 deg",
    2: "unreachable: the TCP target is outside the arm's reach",
    3: "singular: too close to a shoulder, elbow or wrist singularity",
    4: "joint limit: some joint past its range by more than the 5 deg tolerance",
    5: "no solution: other kinematics error",
}


def _axis_rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation matrix (3, 3) of ``angle`` rad about the unit vector ``axis`` (Rodrigues)."""
    k = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + math.sin(angle) * K + (1.0 - math.cos(angle)) * (K @ K)


@dataclass(frozen=True)
class PoseTarget:
    """A TCP target: position ``p_m`` (3,), orientation ``R`` (3, 3, columns = TCP axes in base) and
    the feed direction ``feed`` (3,, unit, base frame)."""

    p_m: np.ndarray
    R: np.ndarray
    feed: np.ndarray


def target(case: MillingCase, start_p_m: np.ndarray, start_R: np.ndarray, *, offset_m=(0.0, 0.0, 0.0),
           yaw_rad: float = 0.0, tool_rotation_rad: float = 0.0, tilt_rad: float = 0.0,
           s_m: float = 0.0) -> PoseTarget:
    """The TCP target of the case's pass moved by ``offset_m``, turned by ``yaw_rad`` (part),
    ``tool_rotation_rad`` (about the tool axis) and ``tilt_rad`` (about the feed), at travel ``s_m``.

    ``start_p_m`` (3,) and ``start_R`` (3, 3) are the TCP pose of the case's start (``fk``).
    """
    feed0 = np.asarray(case.cut.feed_direction, dtype=float)
    Rz = _axis_rotation(np.array([0.0, 0.0, 1.0]), yaw_rad)
    feed = Rz @ feed0
    R = Rz @ start_R
    R = _axis_rotation(feed, tilt_rad) @ R                # tilt about the feed: feed stays perpendicular
    R = R @ _axis_rotation(np.array([0.0, 0.0, 1.0]), tool_rotation_rad)  # about the TCP's own z
    p = np.asarray(start_p_m, dtype=float) + np.asarray(offset_m, dtype=float) + s_m * feed
    return PoseTarget(p_m=p, R=R, feed=feed)


@dataclass(frozen=True)
class PoseSolution:
    """Joint angles of a target: ``theta`` (6,) rad (NaN when there is none), ``reason`` (code of
    :data:`REASONS`), ``message`` (the kinematics error, "" when reachable), distance to the
    singularities: ``sin_margin`` = min(|sin psi_elbow|, |sin q5|) (dimensionless) and
    ``shoulder_m`` (wrist centre from axis 1, m); NaN when unreachable."""

    theta: np.ndarray
    reason: int
    message: str
    sin_margin: float
    shoulder_m: float

    @property
    def reachable(self) -> bool:
        return self.reason in (0, 1)


def solve_pose(case: MillingCase, tgt: PoseTarget, q_ref: np.ndarray) -> PoseSolution:
    """Closed-form IK of ``tgt`` on the branch of ``q_ref`` (rad, (6,)), representation closest to it."""
    spec = case.robot
    nan = np.full(spec.n_joints, np.nan)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", JointLimitWarning)
            q = ik(spec, tgt.p_m, tgt.R, q_ref=q_ref)
    except UnreachableError as e:
        return PoseSolution(nan, 2, str(e), math.nan, math.nan)
    except SingularityError as e:
        return PoseSolution(nan, 3, str(e), math.nan, math.nan)
    except JointLimitError as e:
        return PoseSolution(nan, 4, str(e), math.nan, math.nan)
    except KinematicsError as e:
        return PoseSolution(nan, 5, str(e), math.nan, math.nan)
    tol = any(issubclass(w.category, JointLimitWarning) for w in caught)
    meas = singularity_measures(spec, q)
    sin_margin = float(min(meas["elbow"], meas["wrist"]))
    return PoseSolution(np.asarray(q, dtype=float), 1 if tol else 0, "", sin_margin, float(meas["shoulder"]))


def start_pose(case: MillingCase) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(q0 (6,) rad, p0 (3,) m, R0 (3, 3))``: the case's start pose and its TCP pose."""
    q0 = np.asarray(case.path.start_q_rad, dtype=float)
    p0, R0 = fk(case.robot, q0)
    return q0, np.asarray(p0), np.asarray(R0)
