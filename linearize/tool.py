"""The tool on the robot: planar TCP oscillators (tool, holder and spindle modes), one representation.

A :class:`TcpOscillator` is a mass ``m`` riding on two springs and dampers at the TCP, along two
orthogonal principal axes in the TCP x-y plane (z is the tool axis; the chip sees that plane):

    u1 = (cos a, sin a, 0),  u2 = (-sin a, cos a, 0)        (TCP frame, a = ``angle_rad``)
    k1, k2 (N/m), c_i = 2 zeta_i sqrt(k_i m) (N s/m)

``k2_n_per_m = inf`` leaves the second axis out (a mode along ``u1`` only). The oscillator is an
:class:`~robolobes.linearize.element.Element`: two prismatic joints at the TCP (a massless body on
the first, ``m`` on the second), the TCP frame moved onto the mass, and ``m`` taken from the body
it sits on (the declared payload weighed the tool whole; the robot's total mass is unchanged). So
``modes``, ``frf``, ``lobes``, ``simulate`` and ``map`` see it through M, C, K like any element.
Several oscillators chain: each sits on the previous one's mass, and takes its mass from it.

On a rigid base one oscillator's receptance at the tip is the closed form
(:func:`oscillator_receptance`)::

    H(w) = sum_i u_i u_i^T / (k_i - w^2 m + i w c_i)        (2, 2), TCP x-y, m/N

A chain's rigid-base receptance is that of its own small M, C, K (:func:`chain_receptance`); it is
the sum of the oscillators' closed forms when their axes are mutually orthogonal (each mass taken
from the previous body makes every axis carry exactly its own oscillator's mass).

In a robot or case TOML::

    [[elements]]
    type = "tcp_oscillator"
    mass_kg = 0.25
    k1_n_per_m = 4.0e5
    k2_n_per_m = 4.3e5           # inf: one axis only
    angle_rad = 0.0              # u1 from TCP x, about TCP z
    zeta1 = 0.03
    zeta2 = 0.03
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from robolobes.core.errors import BadInput
from robolobes.core.validate import finite

from .base_elements import diagonal_force, diagonal_tangent
from .element import Element, ModelBuilder

__all__ = ["TcpOscillator", "oscillator_receptance", "chain_matrices", "chain_receptance", "mount_at_tcp"]


def _number(name: str, v, *, positive=True, inf_ok=False) -> None:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise BadInput(f"{name} must be a number, got {v!r}")
    if inf_ok and v == math.inf:
        return
    finite(name, v, positive=positive, nonneg=not positive)


@dataclass(frozen=True)
class TcpOscillator(Element):
    """A planar oscillator at the TCP (module docstring): mass, two principal stiffnesses, their angle, damping.

    Parameters
    ----------
    mass_kg : float > 0
    k1_n_per_m : float > 0          stiffness along u1
    k2_n_per_m : float > 0 or inf   stiffness along u2 (inf: no second axis)
    angle_rad : float               angle of u1 from TCP x, about TCP z
    zeta1, zeta2 : float >= 0       damping ratios of the two axes
    """

    mass_kg: float
    k1_n_per_m: float
    k2_n_per_m: float
    angle_rad: float = 0.0
    zeta1: float = 0.0
    zeta2: float = 0.0
    name: str = "tcp oscillator"

    def __post_init__(self):
        _number("tcp_oscillator mass_kg", self.mass_kg)
        _number("tcp_oscillator k1_n_per_m", self.k1_n_per_m)
        _number("tcp_oscillator k2_n_per_m", self.k2_n_per_m, inf_ok=True)
        if isinstance(self.angle_rad, bool) or not isinstance(self.angle_rad, (int, float)) \
                or not math.isfinite(self.angle_rad):
            raise BadInput(f"tcp_oscillator angle_rad must be a finite number, got {self.angle_rad!r}")
        for z in ("zeta1", "zeta2"):
            _number(f"tcp_oscillator {z}", getattr(self, z), positive=False)

    # -- the physics ------------------------------------------------------------------------------
    @property
    def axes_tcp(self) -> np.ndarray:
        """Principal axes (n_axes, 3), TCP frame: ``u1`` and, unless ``k2`` is inf, ``u2``."""
        c, s = math.cos(self.angle_rad), math.sin(self.angle_rad)
        u = np.array([[c, s, 0.0], [-s, c, 0.0]])
        return u[: self.n_axes]

    @property
    def n_axes(self) -> int:
        return 1 if self.k2_n_per_m == math.inf else 2

    @property
    def stiffness(self) -> np.ndarray:
        """(n_axes,) N/m."""
        return np.array([self.k1_n_per_m, self.k2_n_per_m][: self.n_axes], dtype=float)

    @property
    def damping(self) -> np.ndarray:
        """(n_axes,) N s/m: ``2 zeta_i sqrt(k_i m)``."""
        z = np.array([self.zeta1, self.zeta2][: self.n_axes])
        return 2 * z * np.sqrt(self.stiffness * self.mass_kg)

    @property
    def freq_hz(self) -> np.ndarray:
        """(n_axes,) natural frequencies on a rigid base, Hz."""
        return np.sqrt(self.stiffness / self.mass_kg) / (2 * math.pi)

    # -- the element --------------------------------------------------------------------------------
    def finish(self, b: ModelBuilder) -> str:
        base = f"tcp_oscillator_{b.model.njoints}"
        mount_at_tcp(b, self.mass_kg, self.axes_tcp, [f"{base}_{i + 1}" for i in range(self.n_axes)])
        return base

    def bind(self, robot, built=None) -> np.ndarray:
        """Indices in v (n_axes,) of the oscillator's prismatic joints (``built``: their base name)."""
        model = robot.model
        return np.array([model.joints[model.getJointId(f"{built}_{i + 1}")].idx_v for i in range(self.n_axes)])

    def force(self, robot, ix, data, q, v, theta):
        return diagonal_force(robot.nv, ix, self.stiffness, self.damping, q, v)

    def tangent(self, robot, ix, data, q, v, theta, engaged=False):
        return diagonal_tangent(robot.nv, ix, self.stiffness, self.damping)


def mount_at_tcp(b: ModelBuilder, mass_kg: float, axes_tcp, names) -> int:
    """Put a point mass on prismatic joints at the TCP (the realization of every tool element).

    ``axes_tcp`` (n, 3): the joints' axes in the TCP frame, chained in order (massless bodies
    between them), ``names`` their joint names; ``mass_kg`` sits on the last and is taken from the
    body the TCP was on (a point mass ``-m`` at the TCP there), and the TCP frame moves onto it.
    Returns the last joint's id.
    """
    parent = b.tail if b.tcp_parent is None else b.tcp_parent
    placement = b.flange_placement if b.tcp_placement is None else b.tcp_placement
    b.model.appendBodyToJoint(parent, pin.Inertia(-mass_kg, placement.translation, np.zeros((3, 3))),
                              pin.SE3.Identity())
    jid = parent
    axes = np.atleast_2d(np.asarray(axes_tcp, dtype=float))
    for i, (u, name) in enumerate(zip(axes, names)):
        jid = b.model.addJoint(jid, pin.JointModelPrismaticUnaligned(u), placement if i == 0 else pin.SE3.Identity(),
                               name)
        b.model.appendBodyToJoint(jid, pin.Inertia(mass_kg if i == len(axes) - 1 else 0.0, np.zeros(3),
                                                   np.zeros((3, 3))), pin.SE3.Identity())
    b.tcp_parent, b.tcp_placement = jid, pin.SE3.Identity()
    return jid


def oscillator_receptance(osc: TcpOscillator, omega) -> np.ndarray:
    """Closed-form rigid-base receptance (2, 2, n_freq), m/N, TCP x-y, of one oscillator at ``omega`` (rad/s)."""
    w = np.atleast_1d(np.asarray(omega, dtype=float))
    H = np.zeros((2, 2, w.size), dtype=complex)
    for u, k, c in zip(osc.axes_tcp[:, :2], osc.stiffness, osc.damping):
        H += np.outer(u, u)[:, :, None] / (k - w ** 2 * osc.mass_kg + 1j * w * c)
    return H


def chain_matrices(oscillators) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``M, C, K`` (n, n) and the tip map ``D`` (2, n) of a chain of oscillators on a rigid base.

    Coordinates: every oscillator's axis displacements, in chain order (m). Oscillator ``j``'s mass
    moves with ``sum_{i <= j} D_i u_i`` and the mass of ``j + 1`` is taken from it, so
    ``M = sum_j (m_j - m_{j+1}) B_j^T B_j`` (``m_{N+1} = 0``, ``B_j`` the columns of oscillators
    ``<= j``); the tip is the last mass, ``D`` in TCP x-y.
    """
    osc = list(oscillators)
    blocks = [o.axes_tcp[:, :2].T for o in osc]
    n = sum(b.shape[1] for b in blocks)
    D = np.hstack(blocks) if blocks else np.zeros((2, 0))
    M = np.zeros((n, n))
    start = 0
    for j, o in enumerate(osc):
        start += blocks[j].shape[1]
        body = o.mass_kg - (osc[j + 1].mass_kg if j + 1 < len(osc) else 0.0)
        B = np.zeros((2, n))
        B[:, :start] = D[:, :start]
        M += body * B.T @ B
    K = np.diag(np.concatenate([o.stiffness for o in osc])) if osc else np.zeros((0, 0))
    C = np.diag(np.concatenate([o.damping for o in osc])) if osc else np.zeros((0, 0))
    return M, C, K, D


def chain_receptance(oscillators, omega) -> np.ndarray:
    """Rigid-base receptance (2, 2, n_freq), m/N, TCP x-y, at the tip of a chain (:func:`chain_matrices`)."""
    M, C, K, D = chain_matrices(oscillators)
    w = np.atleast_1d(np.asarray(omega, dtype=float))
    Z = K[None] - w[:, None, None] ** 2 * M[None] + 1j * w[:, None, None] * C[None]
    X = np.linalg.solve(Z, np.broadcast_to(D.T.astype(complex), (w.size,) + D.T.shape))
    return np.einsum("in,fnj->ijf", D, X)

