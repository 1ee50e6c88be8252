"""Read a robot's kinematic tree from its URDF (pinocchio's URDF parser) into plain arrays.

The URDF gives the geometry, the joint axes and the links' masses and inertias; the robot TOML
gives what it lacks (stiffness, damping, payload, the controller convention). This module turns
the URDF into the numbers of :class:`~robolobes.cases.spec.UrdfSpec`, checked before any work:

* the six motion joints are named in the TOML; every other movable joint of the URDF is locked at
  its zero position (``pin.buildReducedModel``: its bodies are merged into the link it hangs from);
* the motion joints must be revolute (``revolute`` or ``continuous``) and form one serial chain
  from the root link, in the order given;
* fixed joints are merged by pinocchio (their links' inertias added to the parent's body).

The orthogonal-compliance axes of a joint (:func:`completing_axes`) follow one rule, stated once:
take the axis ``e_k`` of the joint frame nearest the joint axis ``a`` (largest ``|a_k|``, the
first of equals); the two orthogonal axes are the next two axes of the frame in cyclic order
(``x -> (y, z)``, ``y -> (z, x)``, ``z -> (x, y)``), made orthogonal to ``a`` and to each other
(Gram-Schmidt, in that order). For an axis along a frame axis they are exactly the two other
frame axes, as for the TOML robots.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from robolobes.core.errors import BadInput

__all__ = ["UrdfTree", "UrdfError", "read_urdf_tree", "completing_axes", "nearest_axis", "orthonormal_pair"]

_NAMES = "xyz"
_REVOLUTE = ("RX", "RY", "RZ", "RUBX", "RUBY", "RUBZ")  # pinocchio's revolute and continuous joints on x, y, z


def nearest_axis(axis: np.ndarray) -> str:
    """The frame axis (``"x"``, ``"y"`` or ``"z"``) nearest the unit vector ``axis`` (3,).

    >>> nearest_axis(np.array([0.0, -1.0, 0.0])), nearest_axis(np.array([0.6, 0.0, 0.8]))
    ('y', 'z')
    """
    return _NAMES[int(np.argmax(np.abs(np.asarray(axis, dtype=float))))]


def completing_axes(axis: np.ndarray) -> np.ndarray:
    """The two axes of orthogonal compliance of a joint of unit axis ``axis`` (3,), joint frame.

    Rule in the module docstring. Returns (2, 3), rows orthonormal and orthogonal to ``axis``.

    >>> completing_axes(np.array([0.0, 0.0, -1.0])).tolist()
    [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
    >>> completing_axes(np.array([0.0, 1.0, 0.0])).tolist()
    [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]
    """
    a = np.asarray(axis, dtype=float)
    k = int(np.argmax(np.abs(a)))
    eye = np.eye(3)
    return orthonormal_pair(a, eye[(k + 1) % 3], eye[(k + 2) % 3])


def orthonormal_pair(a: np.ndarray, u: np.ndarray, w: np.ndarray) -> np.ndarray:
    """``u`` then ``w`` made orthogonal to the unit vector ``a`` and to each other, unit length (2, 3).

    >>> orthonormal_pair(np.array([0.0, 0, 1]), np.array([1.0, 0, 0.5]), np.array([1.0, 1, 0])).round(12).tolist()
    [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
    """
    u = u - (u @ a) * a
    u = u / np.linalg.norm(u)
    w = w - (w @ a) * a - (w @ u) * u
    return np.array([u, w / np.linalg.norm(w)])


class UrdfTree:
    """The motion chain of a URDF as arrays (what :class:`~robolobes.cases.spec.UrdfSpec` keeps).

    Attributes
    ----------
    placements : array (n, 4, 4)
        Frame of joint i (at URDF position 0) in the frame of joint i - 1 (joint 0: in the root
        link's frame, the robot's base frame); homogeneous, m.
    axes : array (n, 3)
        Unit rotation axis of joint i in its own frame, as the URDF writes it (sign included).
    mass_kg : array (n,), com_m : array (n, 3), inertia_kg_m2 : array (n, 3, 3)
        The body moving with joint i (its link and everything fixed to it): mass, centre of mass
        and inertia at the centre of mass, joint-i frame.
    flange_placement : array (4, 4)
        The flange frame (where the payload is fixed) in the frame of the last joint.
    limits_rad : array (n, 2)
        URDF position limits; nan for a ``continuous`` joint (no limits).
    """

    def __init__(self, placements, axes, mass_kg, com_m, inertia_kg_m2, flange_placement, limits_rad):
        self.placements, self.axes = placements, axes
        self.mass_kg, self.com_m, self.inertia_kg_m2 = mass_kg, com_m, inertia_kg_m2
        self.flange_placement, self.limits_rad = flange_placement, limits_rad


class UrdfError(BadInput):
    """A URDF that cannot give the motion chain asked for (the loader reports it as a ``CaseError``)."""


def _err(path: Path, msg: str) -> UrdfError:
    return UrdfError(f"{path}: {msg}")


def _joint_axis(model, data, j: int) -> np.ndarray:
    """Unit rotation axis of revolute joint ``j`` in its frame (from its motion subspace), (3,)."""
    a = np.asarray(data.joints[j].S).reshape(6, -1)[3:, 0]  # motion subspace (6, 1): angular rows 3-5
    return a / np.linalg.norm(a)


def read_urdf_tree(path: Path, joint_names: tuple[str, ...], flange: str | None) -> tuple[UrdfTree, str]:
    """Read the motion chain ``joint_names`` (base to flange) of the URDF at ``path``.

    ``flange``: the URDF link (or frame) the payload is fixed to; None: the child link of the last
    motion joint. Returns the tree and the flange's name. Raises :class:`UrdfError` (exit 2) naming the
    file and what is wrong.
    """
    import pinocchio as pin

    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as e:
        raise _err(path, f"cannot read the URDF: {e}") from None
    try:
        model = pin.buildModelFromXML(text)
    except Exception as e:  # pinocchio raises RuntimeError / ValueError with its parser's message
        raise _err(path, f"not a URDF pinocchio can read: {str(e).strip().splitlines()[0] if str(e) else e}") from None
    known = [model.names[j] for j in range(1, model.njoints)]
    for n in joint_names:
        if n not in known:
            raise _err(path, f"no movable joint {n!r}; its movable joints are: {', '.join(known)}")
    if len(set(joint_names)) != len(joint_names):
        raise _err(path, f"the motion joints {list(joint_names)} name a joint twice")
    lock = [j for j in range(1, model.njoints) if model.names[j] not in joint_names]
    if lock:
        model = pin.buildReducedModel(model, lock, pin.neutral(model))
    ids = [model.getJointId(n) for n in joint_names]
    for n, j in zip(joint_names, ids):
        kind = model.joints[j].shortname()
        if "Revolute" not in kind and kind.removeprefix("JointModel") not in _REVOLUTE:
            raise _err(path, f"joint {n!r} is {kind}, not revolute: motion joints must be revolute or continuous")
    parents = [0] + ids[:-1]
    for n, j, p in zip(joint_names, ids, parents):
        if model.parents[j] != p:
            want = "the root link" if p == 0 else f"joint {model.names[p]!r}"
            raise _err(path, f"joint {n!r} does not follow {want}: the motion joints must form one serial chain "
                             "from the root link, in the order given")
    data = model.createData()
    pin.forwardKinematics(model, data, pin.neutral(model))
    limits = []
    for j in ids:
        if model.nqs[j] == 1:
            iq = model.idx_qs[j]
            limits.append([model.lowerPositionLimit[iq], model.upperPositionLimit[iq]])
        else:  # continuous: (cos, sin) coordinates, no limits
            limits.append([np.nan, np.nan])
    if flange is None:
        flange = str(next(f.name for f in model.frames if f.parentJoint == ids[-1] and f.type == pin.FrameType.BODY))
    if not model.existFrame(flange):
        raise _err(path, f"no link or frame {flange!r} (key 'flange_link')")
    fr = model.frames[model.getFrameId(flange)]
    if fr.parentJoint != ids[-1]:
        raise _err(path, f"flange_link {flange!r} is not fixed to the last motion joint {joint_names[-1]!r}")
    inertias = [model.inertias[j] for j in ids]
    tree = UrdfTree(
        placements=np.array([model.jointPlacements[j].homogeneous for j in ids]),
        axes=np.array([_joint_axis(model, data, j) for j in ids]),
        mass_kg=np.array([float(i.mass) for i in inertias]),
        com_m=np.array([np.asarray(i.lever) for i in inertias]),
        inertia_kg_m2=np.array([np.asarray(i.inertia) for i in inertias]),
        flange_placement=np.asarray(fr.placement.homogeneous),
        limits_rad=np.array(limits, dtype=float))
    return tree, flange
