"""Statics, linearization, complex modes and tool-tip FRFs of the flexible robot.

Linearized about a static equilibrium ``q0`` (motor angles ``theta`` fixed, velocity 0)::

    M dqdd + C dqd + K dq = J^T dF
    M = M(q0)                      (pinocchio crba)
    C = -d(sum tau_e)/d(qd)        (joint and virtual dampers)
    K = dg/dq - d(sum tau_e)/dq    (joint springs, gravity stiffness, compensation)

``dg/dq`` is pinocchio's analytic gravity derivative, not a finite difference. ``J`` (3 x n) is the
translational TCP Jacobian in base-frame axes (pinocchio ``LOCAL_WORLD_ALIGNED``): the TCP
displacement is ``J dq`` and a TCP force ``F`` (N, base axes) does the generalized work ``J^T F``.

The tool-tip receptance (m/N) is ``H(w) = J (K - w^2 M + i w C)^-1 J^T``, stored as in
python-control's ``FrequencyResponseData``: shape ``(n_out, n_in, n_freq)``, ``omega`` in rad/s.
Its static limit is the compliance ``J K^-1 J^T``. The modal form uses the state-space eigenvectors
(non-proportional damping, possibly non-symmetric K), so it needs no symmetry.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import partial
from typing import Literal

import numpy as np
import pinocchio as pin

from robolobes.core.validate import shown
from robolobes.core.errors import BadInput
from robolobes.core.frf import BASE_LABELS, CUT_LABELS, FRF
from robolobes.core.threads import blas_single_threaded
from robolobes.core.validate import readonly

from .model import FlexibleRobot, element_forces, element_tangents, rigid_q, tcp_jacobian, tcp_pose

__all__ = [
    "Equilibrium",
    "equilibrium",
    "LinearModel",
    "linearize",
    "Modes",
    "modal_analysis",
    "FRF",
    "frf_direct",
    "frf_modal",
    "FrameName",
    "SingularConfigurationError",
    "state_space",
    "LinearBatch",
    "linearize_many",
]

FrameName = Literal["base", "cut"]


_ro = partial(readonly, dtype=None)  # a read-only copy, dtype kept (complex modes)


class SingularConfigurationError(BadInput):
    """The TCP Jacobian or the stiffness is singular at this configuration."""


# ----------------------------------------------------------------------------------------------
# statics


@dataclass(frozen=True)
class Equilibrium:
    """Static equilibrium of the flexible robot.

    Attributes
    ----------
    theta : array (n_joints,), rad        motor angles
    q : array (nq,), rad                   link (and virtual joint) angles at equilibrium
    deflection : array (nq,), rad          ``q - rigid_q(theta)``
    tcp_position : array (3,), m           TCP at equilibrium, base frame
    tcp_deflection : array (3,), m         TCP displacement from the rigid robot's TCP, base frame
    f_tcp : array (3,), N                  constant TCP force applied (base frame)
    residual : float                       max |generalized force imbalance| at the solution, N m
    iterations : int
    """

    theta: np.ndarray
    q: np.ndarray
    deflection: np.ndarray
    tcp_position: np.ndarray
    tcp_deflection: np.ndarray
    f_tcp: np.ndarray
    residual: float
    iterations: int


def _newton_equilibrium(robot, q, theta, f, tol, max_iter, data):
    v0 = np.zeros(robot.nv)
    loaded = robot.has_gravity or np.any(f != 0)
    res = 0.0
    for it in range(1, max_iter + 1):
        g = pin.computeGeneralizedGravity(robot.model, data, q) if robot.has_gravity else 0.0
        r = g - element_forces(robot, q, v0, theta, data)
        if np.any(f != 0):
            r = r - tcp_jacobian(robot, q, data)[:3].T @ f
        res = float(np.max(np.abs(r)))
        if res < tol or not loaded:
            return q, res, it
        kq, _ = element_tangents(robot, q, v0, theta, engaged=True, data=data)
        dg = pin.computeGeneralizedGravityDerivatives(robot.model, data, q) if robot.has_gravity else 0.0
        q = q - np.linalg.solve(dg - kq, r)
    raise RuntimeError(f"static equilibrium did not converge in {max_iter} iterations (residual {res:.3g} N m)")


def equilibrium(robot: FlexibleRobot, theta: np.ndarray, f_tcp: np.ndarray | None = None, *,
                tol: float = 1e-9, max_iter: int = 50, data: pin.Data | None = None) -> Equilibrium:
    """Static equilibrium ``g(q) = sum tau_e(q, 0, theta) + J(q)^T f_tcp`` by Newton's method.

    Parameters
    ----------
    theta : array (n_joints,), rad
        Motor angles.
    f_tcp : array (3,), N, optional
        Constant force on the TCP, base frame (a dead load, fixed in the world).
    tol : float
        Convergence on the generalized force imbalance, N m.
    data : pin.Data, optional
        Workspace for pinocchio's algorithms (default: a new one; the robot is never written).

    Notes
    -----
    The Newton tangent omits the load stiffness of ``f_tcp`` (``d(J^T F)/dq``, of order
    ``|F| x lever arm`` against joint stiffnesses of 1e5-1e6 N m/rad), so convergence is linear
    with a tiny rate; the residual itself is exact.

    With backlash, a spring with a dead zone of half-width s under a load tau settles at
    ``q - theta = -tau/k - s sign(tau)``; Newton inside the zone (zero slope) would creep. So the
    equilibrium is found for the engaged twin (no dead zone), then again with each motor angle
    shifted by ``s`` on the side its spring torque pushes; axes without load (the gravity-
    compensated ones) stay centred in their dead zone. The result is checked against the real
    dead-zone residual.
    """
    q_r = rigid_q(robot, theta)
    theta = q_r[robot.motion_dofs]
    data = robot.create_data() if data is None else data
    f = np.zeros(3) if f_tcp is None else np.asarray(f_tcp, dtype=float)
    if f.shape != (3,) or not np.all(np.isfinite(f)):
        raise BadInput(f"f_tcp must be a finite force (3,) in N, got {shown(f_tcp)}")
    s = robot.backlash_rad
    if s > 0:
        twin = robot.engaged_twin()
        q, _, it1 = _newton_equilibrium(twin, q_r.copy(), theta, f, tol, max_iter, data)
        delta = q[robot.motion_dofs] - theta
        k = robot.spec.joint_stiffness
        loaded = np.abs(k * delta) > 1e3 * tol
        shifted = theta + np.where(loaded, s * np.sign(delta), 0.0)
        q, _, it2 = _newton_equilibrium(twin, q, shifted, f, tol, max_iter, data)
        g = pin.computeGeneralizedGravity(robot.model, data, q) if robot.has_gravity else 0.0
        r = g - element_forces(robot, q, np.zeros(robot.nv), theta, data)
        if np.any(f != 0):
            r = r - tcp_jacobian(robot, q, data)[:3].T @ f
        res, it = float(np.max(np.abs(r))), it1 + it2
        if res > 10 * tol:
            raise RuntimeError(f"backlash equilibrium inconsistent: residual {res:.3g} N m with the dead zone")
    else:
        q, res, it = _newton_equilibrium(robot, q_r.copy(), theta, f, tol, max_iter, data)
    p, _ = tcp_pose(robot, q, data)
    p0, _ = tcp_pose(robot, q_r, data)
    return Equilibrium(theta=_ro(theta), q=_ro(q), deflection=_ro(q - q_r), tcp_position=_ro(p),
                       tcp_deflection=_ro(p - p0), f_tcp=_ro(f), residual=res, iterations=it)


# ----------------------------------------------------------------------------------------------
# modal analysis (vectorized over leading axes)


@dataclass(frozen=True)
class Modes:
    """Complex modes of ``M qdd + C qd + K q = J^T F`` (non-proportional damping).

    Only the poles with positive imaginary part (and real, overdamped poles) are listed as modes;
    the modal FRF uses all ``2n`` poles. Arrays may carry leading batch axes ``(...)``.

    Attributes
    ----------
    poles : complex array (..., 2n)            all eigenvalues of the state matrix, rad/s
    residues : complex array (..., 2n, 3, 3)   TCP receptance residues, m/N * rad/s
    freq_hz : array (..., n_modes)             undamped natural frequency |lambda| / 2 pi
    damped_freq_hz : array (..., n_modes)      Im(lambda) / 2 pi
    damping_ratio : array (..., n_modes)       -Re(lambda) / |lambda|
    shapes : complex array (..., n, n_modes)   displacement mode shapes (largest entry 1)
    tcp_shapes : complex array (..., 3, n_modes)  TCP displacement of each shape, m per unit shape
    modal_stiffness_n_per_m : array (..., 3, n_modes)
        effective stiffness of each mode along the frame's x, y, z at the TCP:
        ``k = w_n^2 / (2 w_d |R_dd|)`` (exact for a single-DOF oscillator); inf when the mode
        does not move the TCP along that axis.
    """

    poles: np.ndarray
    residues: np.ndarray
    freq_hz: np.ndarray
    damped_freq_hz: np.ndarray
    damping_ratio: np.ndarray
    shapes: np.ndarray
    tcp_shapes: np.ndarray
    modal_stiffness_n_per_m: np.ndarray


def _state_matrix(M, C, K):
    n = M.shape[-1]
    Minv = np.linalg.inv(M)
    A = np.zeros(M.shape[:-2] + (2 * n, 2 * n))
    A[..., :n, n:] = np.eye(n)
    A[..., n:, :n] = -Minv @ K
    A[..., n:, n:] = -Minv @ C
    return A, Minv


def modal_analysis(M: np.ndarray, C: np.ndarray, K: np.ndarray, J: np.ndarray) -> Modes:
    """Complex modal analysis, batched over leading axes.

    Parameters
    ----------
    M, C, K : array (..., n, n)
        Mass (kg m^2 / kg), damping, stiffness matrices in SI.
    J : array (..., 3, n)
        TCP selection: TCP displacement (m) per generalized coordinate, in the frame of interest.

    Returns
    -------
    Modes
    """
    n = M.shape[-1]
    A, Minv = _state_matrix(M, C, K)
    lam, V = np.linalg.eig(A)
    order = np.argsort(np.where(np.imag(lam) >= 0, 0, 1) * 1e30 + np.abs(lam), axis=-1)
    lam = np.take_along_axis(lam, order, -1)
    V = np.take_along_axis(V, order[..., None, :], -1)
    W = np.linalg.inv(V)  # rows: left eigenvectors, W V = I
    # H(s) = sum_r (J V[:n, r]) (W[r, n:] Minv J^T) / (s - lam_r)
    out_r = J @ V[..., :n, :]                                  # (..., 3, 2n)
    in_r = W[..., :, n:] @ (Minv @ np.swapaxes(J, -1, -2))     # (..., 2n, 3)
    residues = np.einsum("...ir,...rj->...rij", out_r, in_r)
    # modes: poles with Im > 0 (one per underdamped pair) plus real poles (overdamped)
    pos = (np.imag(lam) > 1e-9 * np.abs(lam)) | (np.abs(np.imag(lam)) <= 1e-9 * np.abs(lam))
    # with the ordering above, underdamped positive poles come first; count per batch must agree
    n_modes = int(np.min(np.sum(pos, axis=-1)))
    sel = slice(0, n_modes)
    lm = lam[..., sel]
    wn = np.abs(lm)
    wd = np.abs(np.imag(lm))
    zeta = -np.real(lm) / np.where(wn > 0, wn, 1)
    shapes = V[..., :n, sel]
    k = np.argmax(np.abs(shapes), axis=-2)[..., None, :]
    shapes = shapes / np.take_along_axis(shapes, k, -2)
    Rdiag = np.abs(np.diagonal(residues[..., sel, :, :], axis1=-2, axis2=-1))  # (..., n_modes, 3)
    with np.errstate(divide="ignore", over="ignore"):
        kmod = np.where(Rdiag > 0, (wn ** 2)[..., None] / (2 * np.maximum(wd, 1e-300)[..., None] * Rdiag), np.inf)
    return Modes(poles=_ro(lam), residues=_ro(residues), freq_hz=_ro(wn / (2 * math.pi)),
                 damped_freq_hz=_ro(wd / (2 * math.pi)), damping_ratio=_ro(zeta), shapes=_ro(shapes),
                 tcp_shapes=_ro(J @ shapes), modal_stiffness_n_per_m=_ro(np.swapaxes(kmod, -1, -2)))


def frf_direct(M, C, K, J, omega_rad_s: np.ndarray) -> np.ndarray:
    """Receptance ``J (K - w^2 M + i w C)^-1 J^T`` by direct solve.

    Parameters
    ----------
    M, C, K : array (n, n)
    J : array (n_out, n)
    omega_rad_s : array (F,)

    Returns
    -------
    complex array (n_out, n_out, F), m/N
    """
    w = np.asarray(omega_rad_s, dtype=float)
    Z = K[None] - (w ** 2)[:, None, None] * M[None] + 1j * w[:, None, None] * C[None]
    X = np.linalg.solve(Z, np.broadcast_to(J.T.astype(complex), (len(w),) + J.T.shape))
    H = np.einsum("in,fnj->ijf", J, X)
    return H


def frf_modal(modes: Modes, omega_rad_s: np.ndarray) -> np.ndarray:
    """Receptance by modal superposition over all 2n poles, shape (..., 3, 3, F), m/N.

    ``H(w) = sum_r R_r / (i w - lambda_r)``; evaluated in chunks of poses so the (poses x poles x
    frequencies) denominator stays in cache.
    """
    w = np.asarray(omega_rad_s, dtype=float)
    poles = np.asarray(modes.poles)
    batch, n2 = poles.shape[:-1], poles.shape[-1]
    n_out, n_in = modes.residues.shape[-2:]
    P = int(np.prod(batch, dtype=int))
    lam = poles.reshape(P, n2)
    R = np.asarray(modes.residues).reshape(P, n2, n_out * n_in).transpose(0, 2, 1)
    out = np.empty((P, n_out * n_in, len(w)), dtype=complex)
    chunk = max(1, (1 << 18) // max(1, n2 * len(w)))
    for c in range(0, P, chunk):
        den = 1.0 / (1j * w[None, None, :] - lam[c:c + chunk, :, None])
        out[c:c + chunk] = R[c:c + chunk] @ den
    return out.reshape(batch + (n_out, n_in, len(w)))


# ----------------------------------------------------------------------------------------------
# the linear model at one pose


@dataclass(frozen=True)
class LinearModel:
    """The robot linearized at a static equilibrium.

    Attributes
    ----------
    robot : FlexibleRobot
    theta : array (n_joints,), rad          motor angles
    q : array (n,), rad                     equilibrium configuration
    M, C, K : array (n, n)                  SI (kg m^2, N m s/rad, N m/rad for rotations)
    J : array (3, n), m/rad                 translational TCP Jacobian, base-frame axes
    p_tcp : array (3,), m                   TCP position, base frame
    R_tcp : array (3, 3)                    TCP orientation; columns are the TCP axes in base
    notes : tuple of str                    assumptions made (e.g. backlash engaged)
    """

    robot: FlexibleRobot
    theta: np.ndarray
    q: np.ndarray
    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    J: np.ndarray
    p_tcp: np.ndarray
    R_tcp: np.ndarray
    notes: tuple[str, ...] = ()

    @property
    def n(self) -> int:
        return self.M.shape[0]

    @property
    def tool_axis(self) -> np.ndarray:
        """Tool axis (TCP z, out of the spindle) in base coordinates, (3,)."""
        return self.R_tcp[:, 2].copy()

    def frame_axes(self, frame: FrameName = "base", feed_direction=None) -> np.ndarray:
        """Rows = unit axes of the named frame in base coordinates, (3, 3).

        ``"cut"``: x along ``feed_direction`` (base frame, required), z opposite to the tool axis,
        y = z x x (see :func:`cases.milling.cut_frame`).
        """
        if frame == "base":
            return np.eye(3)
        if frame == "cut":
            if feed_direction is None:
                raise BadInput("frame 'cut' needs the feed direction (base frame)")
            from robolobes.cases.milling import cut_frame
            return cut_frame(feed_direction, self.tool_axis)
        raise BadInput(f"unknown frame {frame!r}; valid: 'base', 'cut'")

    def tcp_matrix(self, frame: FrameName = "base", feed_direction=None) -> np.ndarray:
        """TCP displacement per generalized coordinate in the named frame, (3, n)."""
        return self.frame_axes(frame, feed_direction) @ self.J

    def compliance(self, frame: FrameName = "base", feed_direction=None) -> np.ndarray:
        """Static TCP compliance ``J K^-1 J^T`` (3, 3), m/N, in the named frame."""
        Jf = self.tcp_matrix(frame, feed_direction)
        return Jf @ np.linalg.solve(self.K, Jf.T)

    def stiffness(self, frame: FrameName = "base", feed_direction=None) -> np.ndarray:
        """Static TCP stiffness (3, 3), N/m: the inverse of :meth:`compliance`."""
        c = self.compliance(frame, feed_direction)
        if np.linalg.cond(c) > 1e12:
            raise SingularConfigurationError(
                f"TCP compliance is singular (condition number {np.linalg.cond(c):.3g}): the TCP cannot move "
                "along some direction at this configuration")
        return np.linalg.inv(c)

    def modes(self, frame: FrameName = "base", feed_direction=None) -> Modes:
        """Complex modes, with TCP residues and modal stiffnesses in the named frame."""
        return modal_analysis(self.M, self.C, self.K, self.tcp_matrix(frame, feed_direction))

    def frf(self, omega_rad_s: np.ndarray, frame: FrameName = "base", feed_direction=None,
            method: Literal["direct", "modal"] = "direct") -> FRF:
        """Tool-tip receptance FRF (m/N) at ``omega_rad_s`` (F,), in the named frame."""
        w = np.asarray(omega_rad_s, dtype=float)
        if w.ndim != 1 or not np.all(np.isfinite(w)) or np.any(w < 0):
            raise BadInput(f"omega_rad_s must be a 1-D array of finite frequencies >= 0 rad/s, got shape {w.shape}")
        axes = self.frame_axes(frame, feed_direction)
        Jf = axes @ self.J
        if method == "direct":
            H = frf_direct(self.M, self.C, self.K, Jf, w)
        elif method == "modal":
            H = frf_modal(modal_analysis(self.M, self.C, self.K, Jf), w)
        else:
            raise BadInput(f"unknown FRF method {method!r}; valid: 'direct', 'modal'")
        labels = BASE_LABELS if frame == "base" else CUT_LABELS
        return FRF(omega=w, H=H, frame=frame, axes=axes, labels=labels)

    def state_space(self, frame: FrameName = "base", feed_direction=None):
        """``(A, B, C, D)`` with input TCP force (3, N) and output TCP displacement (3, m)."""
        return state_space(self.M, self.C, self.K, self.tcp_matrix(frame, feed_direction))

    def to_control(self, frame: FrameName = "base", feed_direction=None):
        """A ``control.StateSpace`` system: TCP force (N) -> TCP displacement (m)."""
        import control
        return control.ss(*self.state_space(frame, feed_direction))


def state_space(M, C, K, J):
    """State-space matrices ``x = [q, qd]``: ``A (2n, 2n), B (2n, 3), C (3, 2n), D (3, 3)``."""
    n = M.shape[0]
    A, Minv = _state_matrix(M, C, K)
    B = np.vstack([np.zeros((n, J.shape[0])), Minv @ J.T])
    Cm = np.hstack([J, np.zeros((J.shape[0], n))])
    return A, B, Cm, np.zeros((J.shape[0], J.shape[0]))


@dataclass(frozen=True)
class LinearBatch:
    """Linear models at P poses of one robot, stacked (for pose maps and benchmarks).

    Attributes
    ----------
    theta : array (P, n_joints), rad
    q : array (P, n)
    M, C, K : array (P, n, n)
    J : array (P, 3, n), m/rad, base-frame axes
    p_tcp : array (P, 3), m;  R_tcp : array (P, 3, 3)
    """

    robot: FlexibleRobot
    theta: np.ndarray
    q: np.ndarray
    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    J: np.ndarray
    p_tcp: np.ndarray
    R_tcp: np.ndarray

    def __len__(self):
        return self.M.shape[0]

    @blas_single_threaded
    def modes(self) -> Modes:
        """Complex modes at every pose (base frame), leading axis P."""
        return modal_analysis(self.M, self.C, self.K, self.J)

    def compliance(self) -> np.ndarray:
        """Static TCP compliance (P, 3, 3), m/N, base frame."""
        return self.J @ np.linalg.solve(self.K, np.swapaxes(self.J, -1, -2))

    @blas_single_threaded
    def frf(self, omega_rad_s: np.ndarray, modes: Modes | None = None) -> np.ndarray:
        """Tool-tip receptance (P, 3, 3, F), m/N, base frame, by modal superposition."""
        return frf_modal(self.modes() if modes is None else modes, omega_rad_s)


@blas_single_threaded
def linearize_many(robot: FlexibleRobot, thetas: np.ndarray, progress=None) -> LinearBatch:
    """Linearize at many poses. ``thetas``: (P, n_joints) motor angles in rad.

    ``progress``: optional callable ``progress(done, total)``.
    """
    thetas = np.asarray(thetas, dtype=float)
    if thetas.ndim != 2 or thetas.shape[1] != robot.spec.n_joints:
        raise BadInput(f"thetas must have shape (P, {robot.spec.n_joints}), got {thetas.shape}")
    P, n = len(thetas), robot.nv
    out = {k: np.empty((P,) + sh) for k, sh in
           (("q", (n,)), ("M", (n, n)), ("C", (n, n)), ("K", (n, n)), ("J", (3, n)), ("p_tcp", (3,)), ("R_tcp", (3, 3)))}
    data = robot.create_data()
    for i, th in enumerate(thetas):
        lin = linearize(robot, th, data=data)
        for k in out:
            out[k][i] = getattr(lin, k)
        if progress is not None:
            progress(i + 1, P)
    return LinearBatch(robot=robot, theta=_ro(thetas), **{k: _ro(v) for k, v in out.items()})


def linearize(robot: FlexibleRobot, theta: np.ndarray, *, q: np.ndarray | None = None,
              f_tcp: np.ndarray | None = None, data: pin.Data | None = None) -> LinearModel:
    """Linearize the robot at the static equilibrium for motor angles ``theta``.

    Parameters
    ----------
    robot : FlexibleRobot
    theta : array (n_joints,), rad
        Motor angles.
    q : array (nq,), optional
        Configuration to linearize at; default: the static equilibrium under gravity (if the
        variant has gravity) and ``f_tcp``.
    f_tcp : array (3,), N, optional
        Constant TCP force for the equilibrium (its load stiffness is not included in K).
    data : pin.Data, optional
        Workspace for pinocchio's algorithms (default: a new one; the robot is never written, so
        threads may share it, each with its own ``data``).

    Returns
    -------
    LinearModel

    Example: the first mode of the TX200 at the paper's Tab. 7 pose (basic model).

    >>> from robolobes.cases import load_robot
    >>> from robolobes.linearize import build_model
    >>> robot = build_model(load_robot("tx200"), "basic")
    >>> lin = linearize(robot, np.radians([0.0, 30.0, 100.0, 0.0, -40.0, 0.0]))
    >>> lin.M.shape, lin.J.shape
    ((6, 6), (3, 6))
    """
    notes = []
    data = robot.create_data() if data is None else data
    if q is None:
        eq = equilibrium(robot, theta, f_tcp, data=data)
        q, theta = eq.q, eq.theta
    else:
        theta = rigid_q(robot, theta)[robot.motion_dofs]
        q = np.asarray(q, dtype=float)
        if q.shape != (robot.nq,):
            raise BadInput(f"q must have shape ({robot.nq},), got {q.shape}")
    v0 = np.zeros(robot.nv)
    M = pin.crba(robot.model, data, q)
    M = 0.5 * (M + M.T)
    kq, kv = element_tangents(robot, q, v0, theta, engaged=True, data=data)
    K = -kq
    if robot.has_gravity:
        K = K + pin.computeGeneralizedGravityDerivatives(robot.model, data, q)
    if robot.backlash_rad > 0:
        notes.append(f"backlash (half-width {robot.backlash_rad:.3g} rad) linearized with the gears engaged")
    J = tcp_jacobian(robot, q, data)[:3]
    p, R = tcp_pose(robot, q, data)
    return LinearModel(robot=robot, theta=_ro(theta), q=_ro(q), M=_ro(M), C=_ro(-kv), K=_ro(K), J=_ro(J),
                       p_tcp=_ro(p), R_tcp=_ro(R), notes=tuple(notes))
