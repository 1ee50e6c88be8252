"""The kinematics errors, failure codes and reach tolerance, shared by :mod:`linearize.kinematics`
and the inverses it calls (:mod:`linearize.ik_opw`); re-exported by :mod:`linearize.kinematics`."""

from __future__ import annotations

from robolobes.core.errors import BadInput

__all__ = ["KinematicsError", "RobotStructureError", "TargetError", "UnreachableError", "SingularityError",
           "ShoulderSingularityError", "ElbowSingularityError", "WristSingularityError", "JointLimitError",
           "JointLimitWarning", "REACH_EPS_M"]

#: A wrist centre at most this far beyond the stretched / folded reach counts as on the boundary
#: (an elbow singularity), not as unreachable: the round-off of an exactly stretched pose.
REACH_EPS_M = 1e-9

#: Failure codes of the closed form (:func:`linearize.ik_opw.opw_solve`) and the numerical inverse.
_OK, _NEAR_AXIS, _TOO_FAR, _TOO_CLOSE, _SHOULDER, _ELBOW, _WRIST = range(7)


# --------------------------------------------------------------------------------------- errors
class KinematicsError(BadInput):
    """Base class of every kinematics error (a :class:`robolobes.core.errors.BadInput`, so a ``ValueError``)."""


class RobotStructureError(KinematicsError):
    """The robot spec does not have the structure the closed-form IK needs."""


class TargetError(KinematicsError):
    """A malformed target: wrong shape, NaN, non-orthonormal rotation, unknown branch."""


class UnreachableError(KinematicsError):
    """The wrist centre is out of reach (too far, or closer than the arm can fold)."""


class SingularityError(KinematicsError):
    """The target is at (or within tolerance of) a singularity; ``kind`` names which."""

    kind = "singularity"


class ShoulderSingularityError(SingularityError):
    """Wrist centre on the axis of joint 1: q1 undetermined."""

    kind = "shoulder"


class ElbowSingularityError(SingularityError):
    """Arm stretched or folded: ``sin`` of the elbow angle ~ 0."""

    kind = "elbow"


class WristSingularityError(SingularityError):
    """``q5 ~ 0``: axes 4 and 6 aligned, only ``q4 + q6`` determined."""

    kind = "wrist"


class JointLimitError(KinematicsError):
    """A joint angle out of its range by more than the tolerance."""


class JointLimitWarning(UserWarning):
    """A joint angle out of its range, but within the tolerance (accepted)."""


