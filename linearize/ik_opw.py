"""Closed-form inverse kinematics of ortho-parallel arms with a spherical wrist (OPW), for any kinematic chain.

The parametrization is that of Brandstötter, Angerer and Hofbaur (2014), "An analytical solution of
the inverse kinematics problem of industrial serial manipulators with an ortho-parallel basis and a
spherical wrist": in its base frame (z along axis 1) and at its zero pose (arm straight up, axes
z, y, y, z, y, z), joint 2 sits at ``(a1, ., c1)``, joint 3 at ``(a1, ., c1 + c2)``, the wrist centre
at ``(a1 + a2, b, c1 + c2 + c3)`` and the TCP ``c4`` further along axis 6 (plus any tool offset).

Detection (:func:`opw_geometry`) reads these from a :class:`~linearize.chain.KinematicChain` at its
joint zero and along each axis, with the map ``q_joint = sign * theta_opw + zero`` from the OPW
angles to the chain's joint positions. The choices that fix it, stated once:

* OPW z = +-axis 1, the sign that puts joint 2 at ``c1 >= 0`` above the base origin's foot on
  axis 1; OPW x = from axis 1 towards axis 2 (so ``a1 >= 0``) at joint 1 = 0; y = z x x.
* joint 2's zero puts joint 3 straight above joint 2 (``c2 > 0``);
* joint 3's zero puts axis 4 along +-z, the sign with the wrist centre above joint 3 (``c3 > 0``);
* joint 4's zero puts axis 5 along +-y, the sign that turns theta5 the way the controller's axis 5
  turns (so the wrist names follow the controller's sign of axis 5);
* joint 5's zero puts axis 6 along +-z, the sign with the TCP beyond the wrist centre (``c4 > 0``).

An arm that does not have the structure (axes 1, 2 not perpendicular, 2, 3 not parallel, 3, 4 or 4,
5 or 5, 6 not perpendicular, axes 4, 5, 6 not through one point, to ``OPW_TOL``) gets the same
quantities by projection, with the reasons in ``defects``: the numerical inverse
(:mod:`linearize.ik_numeric`) uses them for its start points and its branch names.

Branches (the indicators of :func:`branch_indicators`, the same for every arm): shoulder ``front``
when the wrist centre is in front of axis 1 (along OPW x turned by joint 1), elbow ``up`` when the
elbow angle ``psi = theta3 + atan2(a2, c3)`` has ``sin psi > 0`` in front (``< 0`` behind, the mirror
image), wrist ``noflip`` when ``sin theta5 > 0``. For robolobes' TX200 the OPW angles are the TX200
angles and these are :data:`linearize.kinematics.BRANCHES` as before.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from .chain import KinematicChain, joint_axes
from .ik_errors import (_ELBOW, _NEAR_AXIS, _OK, _SHOULDER, _TOO_CLOSE, _TOO_FAR, _WRIST, REACH_EPS_M,
                        RobotStructureError)

__all__ = ["OPW_TOL", "OPWGeometry", "opw_geometry", "require_opw", "opw_solve", "branch_indicators",
           "wrist_point"]

#: Structure tolerance (rad for the angles between axes, m for distances): the closed form is exact only
#: for the exact structure; a defect d moves the TCP by about d times the reach (< 5 m), so 1e-11
#: keeps FK(IK) within the 1e-10 the closed form promises. A URDF with rounded angles (1.5708) fails it
#: and gets the numerical inverse, which is exact for it.
OPW_TOL = 1e-11


@dataclass(frozen=True, eq=False)
class OPWGeometry:
    """OPW parameters of a chain and the map from OPW angles to its joint positions.

    Attributes
    ----------
    a1, a2, b, c1, c2, c3, c4 : float
        The OPW lengths, m (``a1, c2, c3, c4 >= 0`` by the choices in the module docstring).
    origin : array (3,)
        OPW base origin (on axis 1), base frame, m.
    axes : array (3, 3)
        Columns: OPW base x, y, z in the base frame.
    sign, zero : array (6,)
        ``q_joint = sign * theta_opw + zero`` (pinocchio joint positions, rad).
    wrist_in_tcp : array (3,)
        Wrist centre in TCP axes, from the TCP, m.
    tcp_zero : array (3, 3)
        TCP orientation at the OPW zero pose, OPW base axes.
    defects : tuple of str
        Why the chain is not OPW (empty: it is, to ``OPW_TOL``).
    """

    a1: float
    a2: float
    b: float
    c1: float
    c2: float
    c3: float
    c4: float
    origin: np.ndarray
    axes: np.ndarray
    sign: np.ndarray
    zero: np.ndarray
    wrist_in_tcp: np.ndarray
    tcp_zero: np.ndarray
    defects: tuple[str, ...]

    @property
    def k(self) -> float:
        """Joint 3 to wrist centre in the arm plane, m."""
        return math.hypot(self.a2, self.c3)

    @property
    def y_offset(self) -> float:
        return self.b

    @property
    def reach_max_m(self) -> float:
        """Largest distance joint 2 -> wrist centre in the arm plane (stretched), m."""
        return self.c2 + self.k

    @property
    def reach_min_m(self) -> float:
        """Smallest distance joint 2 -> wrist centre in the arm plane (folded), m."""
        return abs(self.c2 - self.k)

    @property
    def is_opw(self) -> bool:
        return not self.defects


# ------------------------------------------------------------------------------------------ geometry
def wrist_point(points: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    """Point nearest (least squares) to the axes 4, 5, 6 (the wrist centre of a spherical wrist), m.

    ``points``, ``dirs``: (6, 3) joint origins and unit axes (:func:`linearize.chain.joint_axes`)."""
    A = np.zeros((3, 3))
    rhs = np.zeros(3)
    for i in (3, 4, 5):
        P = np.eye(3) - np.outer(dirs[i], dirs[i])
        A += P
        rhs += P @ points[i]
    return np.linalg.solve(A, rhs)


def _line_distance(p, d, x) -> float:
    r = x - p
    return float(np.linalg.norm(r - (r @ d) * d))


def _angle_in_plane(v_a: float, v_b: float) -> float:
    """Angle of (v_a, v_b) measured from the b axis towards the a axis, rad."""
    return math.atan2(v_a, v_b)


def _wrap(x: float) -> float:
    return (x + math.pi) % (2 * math.pi) - math.pi


_GEOM: dict[int, tuple[KinematicChain, OPWGeometry]] = {}


def opw_geometry(chain: KinematicChain) -> OPWGeometry:
    """Detect the OPW parameters, frame, signs and zeros of a chain (by projection if it is not OPW).

    Raises
    ------
    RobotStructureError
        Axes 1 and 2 parallel, or joint 3 on axis 2, or the wrist centre on axis 3: no arm plane
        and no branches.
    """
    hit = _GEOM.get(id(chain))
    if hit is not None and hit[0] is chain:
        return hit[1]
    g = _detect(chain)
    _GEOM[id(chain)] = (chain, g)
    return g


def _structure_error(chain: KinematicChain, what: str):
    return RobotStructureError(f"robot {chain.name!r}: {what}")


def _detect(chain: KinematicChain) -> OPWGeometry:
    data = chain.model.createData()
    sign, zero = np.ones(6), np.zeros(6)
    pts, d = joint_axes(chain, zero, data)
    defects = _defects(pts, d)
    F, origin = _base_frame(chain, pts, d)
    sign[0], sign[1] = _side(d[0], F[:, 2]), _side(d[1], F[:, 1])
    zero[1] = _upper_arm_zero(chain, pts, d, F, sign[1])
    pts, d = joint_axes(chain, zero, data)
    sign[2] = _side(d[2], F[:, 1])
    sign[3], zero[2] = _forearm_zero(pts, d, F, sign[2])
    pts, d = joint_axes(chain, zero, data)
    sign[4] = chain.sign[4]       # theta5 turns the way the controller's axis 5 turns
    d5 = F.T @ d[4]               # axis 5 along +y: theta4 = 0
    zero[3] = _wrap(-sign[3] * _angle_in_plane(-sign[4] * d5[0], sign[4] * d5[1]))
    pts, d = joint_axes(chain, zero, data)
    sign[5], zero[4] = _wrist_bend_zero(chain, data, pts, d, F, sign[4])
    return _at_opw_zero(chain, data, F, origin, sign, zero, defects)


def _side(axis: np.ndarray, ref: np.ndarray) -> float:
    """+1 if the joint axis points along the OPW axis ``ref``, else -1."""
    return 1.0 if axis @ ref >= 0 else -1.0


def _base_frame(chain: KinematicChain, pts: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """OPW base axes (3, 3) (z along axis 1 towards joint 2's side, x towards axis 2) and origin (3,)
    (the base origin's foot on axis 1), at joint zero."""
    if np.linalg.norm(np.cross(d[0], d[1])) < 1e-6:
        raise _structure_error(chain, "axes 1 and 2 are parallel: no arm plane, no shoulder/elbow/wrist branches")
    P2 = _foot_on(pts[1], d[1], pts[0], d[0])
    origin = pts[0] - (pts[0] @ d[0]) * d[0]
    z = -d[0] if (P2 - origin) @ d[0] < -1e-12 else d[0]
    r = P2 - pts[0]
    r = r - (r @ z) * z
    x = r if np.linalg.norm(r) > 1e-12 else np.cross(d[1], z)
    x = x / np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z]), origin


def _upper_arm_zero(chain: KinematicChain, pts, d, F, s2: float) -> float:
    """Joint 2's position (rad) that puts joint 3 straight above joint 2 (along OPW z)."""
    u = F.T @ (pts[2] - _foot_on(pts[1], d[1], pts[0], d[0]))
    if math.hypot(u[0], u[2]) < 1e-9:
        raise _structure_error(chain, "joint 3 lies on axis 2: no upper arm")
    return -s2 * _angle_in_plane(u[0], u[2])


def _forearm_zero(pts, d, F, s3: float) -> tuple[float, float]:
    """(sign of joint 4, joint 3's position in rad) that put axis 4 along +z with the wrist centre
    above joint 3 (``c3 > 0``; the smaller turn when ``c3 = 0``)."""
    d4, v = F.T @ d[3], F.T @ (wrist_point(pts, d) - pts[2])
    best = None
    for s4 in (1.0, -1.0):
        gam = _angle_in_plane(s4 * d4[0], s4 * d4[2])
        c3 = math.sin(gam) * v[0] + math.cos(gam) * v[2]   # v in the forearm frame turned back by gam
        key = (c3 <= 1e-12, abs(gam))
        if best is None or key < best[0]:
            best = (key, s4, gam)
    assert best is not None
    return best[1], -s3 * best[2]


def _wrist_bend_zero(chain: KinematicChain, data, pts, d, F, s5: float) -> tuple[float, float]:
    """(sign of joint 6, joint 5's position in rad) that put axis 6 along +z with the TCP beyond the
    wrist centre (``c4 > 0``; the smaller turn when ``c4 = 0``)."""
    pin.updateFramePlacements(chain.model, data)
    along = float((data.oMf[chain.tcp_frame_id].translation - wrist_point(pts, d)) @ d[5])
    d6 = F.T @ d[5]
    cands = [(s6, _angle_in_plane(s6 * d6[0], s6 * d6[2])) for s6 in (1.0, -1.0)]
    if abs(along) > 1e-12:
        s6, gam = next(c for c in cands if c[0] == (1.0 if along > 0 else -1.0))
    else:
        s6, gam = min(cands, key=lambda c: abs(_wrap(-s5 * c[1])))
    return s6, _wrap(-s5 * gam)


def _at_opw_zero(chain: KinematicChain, data, F, origin, sign, zero, defects) -> OPWGeometry:
    """The OPW lengths, the wrist centre in TCP axes and the TCP orientation, read at the OPW zero."""
    pts, d = joint_axes(chain, zero, data)
    pin.updateFramePlacements(chain.model, data)
    M = data.oMf[chain.tcp_frame_id]
    C = wrist_point(pts, d)
    P2 = _foot_on(pts[1], d[1], pts[0], d[0])
    j2, j3, c = F.T @ (P2 - origin), F.T @ (pts[2] - P2), F.T @ (C - pts[2])
    for a in (sign, zero):
        a.setflags(write=False)
    return OPWGeometry(
        a1=float(j2[0]), a2=float(c[0]), b=float(F[:, 1] @ (C - origin)), c1=float(j2[2]), c2=float(j3[2]),
        c3=float(c[2]), c4=float(abs((M.translation - C) @ d[5])), origin=origin, axes=F, sign=sign, zero=zero,
        wrist_in_tcp=M.rotation.T @ (C - M.translation), tcp_zero=F.T @ M.rotation, defects=defects)


def _foot_on(p: np.ndarray, d: np.ndarray, p_other: np.ndarray, d_other: np.ndarray) -> np.ndarray:
    """Point of line (p, d) nearest to line (p_other, d_other) (not parallel), m."""
    w = p - p_other
    a, b, c = d @ d, d @ d_other, d_other @ d_other
    t = (b * (d_other @ w) - c * (d @ w)) / (a * c - b * b)
    return p + t * d


def _defects(pts: np.ndarray, d: np.ndarray) -> tuple[str, ...]:
    out = []
    for i, j, rel in ((0, 1, "perpendicular"), (1, 2, "parallel"), (2, 3, "perpendicular"),
                      (3, 4, "perpendicular"), (4, 5, "perpendicular")):
        dev = abs(d[i] @ d[j]) if rel == "perpendicular" else float(np.linalg.norm(np.cross(d[i], d[j])))
        if dev > OPW_TOL:
            out.append(f"axes {i + 1} and {j + 1} are not {rel} ({math.degrees(math.asin(min(dev, 1.0))):.3g} deg off)")
    C = wrist_point(pts, d)
    far = max(_line_distance(pts[i], d[i], C) for i in (3, 4, 5))
    if far > OPW_TOL:
        out.append(f"axes 4, 5, 6 do not meet at one point (one passes {far:.3g} m from their nearest point)")
    return tuple(out)


def require_opw(chain: KinematicChain) -> OPWGeometry:
    """The OPW geometry of an OPW chain; :class:`RobotStructureError` naming the defects otherwise."""
    g = opw_geometry(chain)
    if g.defects:
        raise _structure_error(chain, "not an ortho-parallel arm with a spherical wrist: " + "; ".join(g.defects))
    return g


# -------------------------------------------------------------------------------------- solutions
def opw_solve(g: OPWGeometry, p: np.ndarray, R: np.ndarray, *, shoulder_tol: float, elbow_tol: float,
              wrist_tol: float):
    """The 8 OPW solutions of validated TCP targets, in OPW angles.

    Parameters
    ----------
    p : array (N, 3)
        TCP positions, base frame, m.
    R : array (N, 3, 3)
        TCP orientations, base frame.

    Returns
    -------
    theta : array (N, 8, 6)
        OPW angles, rad; index 1 is the branch ``4 * shoulder + 2 * elbow + wrist``.
    code : int array (N, 8)
        0 valid, else the first failure in the order: near axis 1 (offset b), too far, too close,
        shoulder, elbow, wrist singularity (the codes of :mod:`linearize.kinematics`).
    info : dict of arrays (N, 8)
        The values the error messages quote.
    """
    F = g.axes
    Ropw = np.einsum("ji,njk,lk->nil", F, R, g.tcp_zero)            # F^T R tcp_zero^T
    C = np.einsum("ji,nj->ni", F, p + np.einsum("nij,j->ni", R, g.wrist_in_tcp) - g.origin)
    cx, cy, cz = C[:, 0], C[:, 1], C[:, 2]
    r2 = cx * cx + cy * cy
    h2 = r2 - g.b ** 2
    h = np.sqrt(np.maximum(h2, 0.0))
    k = g.k
    b_ = np.arange(8)
    sh, el, wr = (b_ >> 2) & 1, (b_ >> 1) & 1, b_ & 1
    # per shoulder side: the wrist centre's distance along OPW x from joint 2, the arm-plane distance
    nx = np.where(sh == 0, h[:, None] - g.a1, h[:, None] + g.a1)                      # (N, 8)
    dz = (cz - g.c1)[:, None]
    rho = np.hypot(nx, dz)
    th1 = np.arctan2(cy, cx)[:, None] + np.where(sh == 0, -np.arctan2(g.b, h[:, None]),
                                                   np.arctan2(g.b, h[:, None]) - np.pi)
    sgn = np.where(sh == el, 1.0, -1.0)
    D = (rho * rho - g.c2 ** 2 - k * k) / (2 * g.c2 * k)
    cos_shoulder = np.clip((rho * rho + g.c2 ** 2 - k * k) / (2 * np.maximum(rho, 1e-300) * g.c2), -1, 1)
    psi = sgn * np.arccos(np.clip(D, -1, 1))
    th3 = psi - math.atan2(g.a2, g.c3)
    th2 = np.where(sh == 0, -sgn * np.arccos(cos_shoulder) + np.arctan2(nx, dz),
                   -sgn * np.arccos(cos_shoulder) - np.arctan2(nx, dz))
    # wrist: M = (Rz(th1) Ry(th2 + th3))^T Ropw = Rz(th4) Ry(th5) Rz(th6)
    c1, s1, c23, s23 = np.cos(th1), np.sin(th1), np.cos(th2 + th3), np.sin(th2 + th3)
    E = Ropw[:, None]                                                                 # (N, 1, 3, 3)
    row0 = c1[..., None] * E[..., 0, :] + s1[..., None] * E[..., 1, :]
    row1 = -s1[..., None] * E[..., 0, :] + c1[..., None] * E[..., 1, :]
    m0 = c23[..., None] * row0 - s23[..., None] * E[..., 2, :]
    m2 = s23[..., None] * row0 + c23[..., None] * E[..., 2, :]
    w = np.where(wr == 1, -1.0, 1.0)
    s5 = w * np.hypot(m0[..., 2], row1[..., 2])
    th5 = np.arctan2(s5, m2[..., 2])
    th4 = np.arctan2(w * row1[..., 2], w * m0[..., 2])
    th6 = np.arctan2(w * m2[..., 1], -w * m2[..., 0])
    theta = np.stack(np.broadcast_arrays(th1, th2, th3, th4, th5, th6), axis=-1)
    code = np.full(theta.shape[:-1], _OK)
    spsi = np.sin(psi)
    for c, bad in reversed(((_NEAR_AXIS, np.broadcast_to(h2[:, None] < 0, code.shape)),
                            (_TOO_FAR, rho > g.reach_max_m + REACH_EPS_M), (_TOO_CLOSE, rho < g.reach_min_m - REACH_EPS_M),
                            (_SHOULDER, np.broadcast_to(h[:, None] < shoulder_tol, code.shape)),
                            (_ELBOW, np.abs(spsi) < elbow_tol), (_WRIST, np.abs(s5) < wrist_tol))):
        code = np.where(bad, c, code)
    info = dict(r=np.sqrt(r2)[:, None], rho=rho, h=h[:, None], D=D, spsi=spsi, psi=psi, q5=th5, s5=s5,
                branch=b_[None, :])
    return theta, code, {key: np.broadcast_to(val, code.shape) for key, val in info.items()}


# ---------------------------------------------------------------------------------------- branches
def branch_indicators(chain: KinematicChain, q_joint: np.ndarray) -> np.ndarray:
    """Shoulder, elbow and wrist indicators at pinocchio joint positions (..., 6), from the geometry.

    Returns
    -------
    array (..., 3)
        ``[xs, sin_psi, sin_q5]``: the wrist centre's distance in front of axis 1 (m, along the
        OPW x axis turned by joint 1), the sine of the elbow angle (turning about OPW y as turned
        by joint 1), the sine of the wrist bend (axis 4 to axis 6 about axis 5, OPW signs). The
        branch bits are ``xs < 0``, ``sin_psi < 0`` in front / ``> 0`` behind, ``sin_q5 < 0``.
    """
    g = opw_geometry(chain)
    qj = np.asarray(q_joint, dtype=float)
    flat = qj.reshape(-1, 6)
    data = chain.model.createData()
    out = np.empty((len(flat), 3))
    for n, x in enumerate(flat):
        pts, d = joint_axes(chain, x, data)
        C = wrist_point(pts, d)
        z = g.axes[:, 2]
        yq = g.sign[1] * d[1]
        yq = yq - (yq @ z) * z
        yq /= np.linalg.norm(yq)
        xq = np.cross(yq, z)
        upper, fore = pts[2] - pts[1], C - pts[2]
        upper, fore = upper - (upper @ yq) * yq, fore - (fore @ yq) * yq
        spsi = np.cross(upper, fore) @ yq / (np.linalg.norm(upper) * np.linalg.norm(fore))
        s5 = np.cross(g.sign[3] * d[3], g.sign[5] * d[5]) @ (g.sign[4] * d[4])
        out[n] = ((C - g.origin) @ xq, spsi, s5)
    return out.reshape(qj.shape[:-1] + (3,))
