"""The tool on the robot: TCP oscillators (tool, holder and spindle modes), the one tool-mode class.

A :class:`TcpOscillator` is a mass ``m`` riding on one or two springs and dampers at the TCP. In its
planar form the two principal axes lie in the TCP x-y plane (z is the tool axis; the chip sees that
plane)::

    u1 = (cos a, sin a, 0),  u2 = (-sin a, cos a, 0)        (TCP frame, a = ``angle_rad``)
    k1, k2 (N/m), c_i = 2 zeta_i sqrt(k_i m) (N s/m)

``k2_n_per_m = inf`` leaves the second axis out (a mode along ``u1`` only); a one-axis oscillator
may instead take its axis along any ``direction`` of the TCP frame, the tool axis z included.
:meth:`TcpOscillator.one_axis` builds that case from a natural frequency, damping ratio and
stiffness (``m = k / (2 pi f)^2``): it is what the ``type = "tcp_mode"`` element table, identify's
``tcp_mode`` effect and ``--tool-modes`` / ``--tool-frf`` (one axis per mode) give. There is no
other tool-mode class (``linearize.extra_elements.TcpMode`` is a deprecated alias of ``one_axis``).

The oscillator is an :class:`~robolobes.linearize.element.Element`: one prismatic joint per axis at
the TCP (massless bodies between them, ``m`` on the last), the TCP frame moved onto the mass, and
``m`` taken from the body it sits on (the declared payload weighed the tool whole; the robot's
total mass is unchanged). So ``modes``, ``frf``, ``lobes``, ``simulate`` and ``map`` see it through
M, C, K like any element. Several oscillators chain: each sits on the previous one's mass, and
takes its mass from it.

On a rigid base one oscillator's receptance at the tip is the closed form
(:func:`oscillator_receptance`)::

    H(w) = sum_i u_i u_i^T / (k_i - w^2 m + i w c_i)        (2, 2), TCP x-y, m/N

(a one-axis oscillator along the tool axis adds nothing in x-y). A chain's rigid-base receptance
is that of its own small M, C, K (:func:`chain_receptance`); it is the sum of the oscillators'
closed forms when their axes are mutually orthogonal (each mass taken from the previous body
makes every axis carry exactly its own oscillator's mass).

In a robot or case TOML (the two tables below with ``k2_n_per_m = inf`` and a ``direction`` build
equal oscillators when ``mass_kg = k / (2 pi f)^2``)::

    [[elements]]
    type = "tcp_oscillator"
    mass_kg = 0.25
    k1_n_per_m = 4.0e5
    k2_n_per_m = 4.3e5           # inf: one axis only
    angle_rad = 0.0              # u1 from TCP x, about TCP z
    zeta1 = 0.03
    zeta2 = 0.03
    # direction = [0.6, 0.0, 0.8]  # instead of angle_rad, with k2_n_per_m = inf: u1 in the TCP frame

    [[elements]]
    type = "tcp_mode"            # TcpOscillator.one_axis: one axis along any TCP direction
    freq_hz = 900.0
    damping_ratio = 0.03
    stiffness_n_per_m = 2.0e7
    direction = [1.0, 0.0, 0.0]  # TCP frame, normalized
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


def _scalar(name: str, v, *, positive=True) -> float:
    """``v`` (a Python or numpy real number, not a bool) as a float, checked by :func:`_number`."""
    if isinstance(v, (np.integer, np.floating)) and not isinstance(v, np.bool_):
        v = float(v)
    _number(name, v, positive=positive)
    return float(v)


def _unit(v, what: str) -> tuple:
    """``v`` (3,) normalized, as a tuple; BadInput naming ``what`` unless a finite non-zero 3-vector.

    A vector already of unit length to 4 ulp is kept as it is, so normalizing twice (a table
    written and read back) changes no bit."""
    try:
        d = np.asarray(v, dtype=float)
    except (TypeError, ValueError):
        raise BadInput(f"{what} must be a non-zero 3-vector, got {v!r}") from None
    if d.shape != (3,) or not np.all(np.isfinite(d)) or np.linalg.norm(d) == 0:
        raise BadInput(f"{what} must be a non-zero 3-vector, got {v!r}")
    n = np.linalg.norm(d)
    return tuple(d if abs(n - 1.0) <= 4 * np.finfo(float).eps else d / n)


@dataclass(frozen=True)
class TcpOscillator(Element):
    """A TCP oscillator (module docstring): mass, one or two principal stiffnesses, their axes, damping.

    Parameters
    ----------
    mass_kg : float > 0
    k1_n_per_m : float > 0          stiffness along u1
    k2_n_per_m : float > 0 or inf   stiffness along u2 (inf: no second axis)
    angle_rad : float               angle of u1 from TCP x, about TCP z (0 when ``direction`` is given)
    zeta1, zeta2 : float >= 0       damping ratios of the two axes
    direction : (3,) or None        u1 along any direction of the TCP frame (z the tool axis),
                                    normalized here; only for one axis (``k2_n_per_m = inf``).
                                    None: u1 from ``angle_rad`` in the TCP x-y plane

    Examples
    --------
    The one-axis case from a frequency, damping ratio and stiffness (``type = "tcp_mode"``):

    >>> osc = TcpOscillator.one_axis(900.0, 0.03, 2.0e7, (0.0, 0.0, 2.0))
    >>> round(osc.mass_kg, 6), osc.n_axes, osc.axes_tcp.tolist()
    (0.625439, 1, [[0.0, 0.0, 1.0]])
    """

    mass_kg: float
    k1_n_per_m: float
    k2_n_per_m: float
    angle_rad: float = 0.0
    zeta1: float = 0.0
    zeta2: float = 0.0
    direction: tuple | None = None
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
        if self.direction is not None:
            self._check_one_axis()
            object.__setattr__(self, "direction", _unit(self.direction, "tcp_oscillator direction"))

    def _check_one_axis(self) -> None:
        if self.k2_n_per_m != math.inf:
            raise BadInput(f"tcp_oscillator direction is for one axis only: k2_n_per_m must be inf with it, got "
                           f"{self.k2_n_per_m!r}")
        if self.angle_rad != 0:
            raise BadInput(f"tcp_oscillator: give either direction or angle_rad, got angle_rad = {self.angle_rad!r} "
                           "with a direction")

    @classmethod
    def one_axis(cls, freq_hz: float, damping_ratio: float, stiffness_n_per_m: float,
                 direction=(1.0, 0.0, 0.0), name: str = "tcp oscillator") -> TcpOscillator:
        """A one-axis oscillator along ``direction`` (3,), TCP frame (normalized; z the tool axis).

        ``freq_hz`` > 0 is its natural frequency on a rigid base (Hz), ``damping_ratio`` >= 0,
        ``stiffness_n_per_m`` > 0; the mass is ``m = k / (2 pi f)^2`` (kg) and the damper
        ``c = 2 zeta sqrt(k m)`` (N s/m). On a base much stiffer and heavier than the mode, the TCP
        receptance along ``direction`` adds ``1 / (k - w^2 m + i w c)``. This is the
        ``type = "tcp_mode"`` table and identify's ``tcp_mode`` effect.
        """
        f = _scalar("tcp_mode freq_hz", freq_hz)
        zeta = _scalar("tcp_mode damping_ratio", damping_ratio, positive=False)
        k = _scalar("tcp_mode stiffness_n_per_m", stiffness_n_per_m)
        _unit(direction, "tcp_mode direction")      # checked here, to name the table's key
        return cls(k / (2 * math.pi * f) ** 2, k, math.inf, 0.0, zeta, 0.0, direction, name)

    # -- the physics ------------------------------------------------------------------------------
    @property
    def axes_tcp(self) -> np.ndarray:
        """Principal axes (n_axes, 3), TCP frame: ``u1`` (``direction``, else from ``angle_rad``) and,
        unless ``k2`` is inf, ``u2``."""
        if self.direction is not None:
            return np.array([self.direction], dtype=float)
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
    moves with ``sum_{i <= j} A_i u_i`` (``A`` the axes in the TCP frame, 3-D: an axis along the
    tool carries mass too) and the mass of ``j + 1`` is taken from it, so
    ``M = sum_j (m_j - m_{j+1}) B_j^T B_j`` (``m_{N+1} = 0``, ``B_j`` the columns of ``A`` of
    oscillators ``<= j``); the tip is the last mass, ``D`` its TCP x-y rows.
    """
    osc = list(oscillators)
    blocks = [o.axes_tcp.T for o in osc]
    n = sum(b.shape[1] for b in blocks)
    A = np.hstack(blocks) if blocks else np.zeros((3, 0))
    M = np.zeros((n, n))
    start = 0
    for j, o in enumerate(osc):
        start += blocks[j].shape[1]
        body = o.mass_kg - (osc[j + 1].mass_kg if j + 1 < len(osc) else 0.0)
        B = np.zeros((3, n))
        B[:, :start] = A[:, :start]
        M += body * B.T @ B
    K = np.diag(np.concatenate([o.stiffness for o in osc])) if osc else np.zeros((0, 0))
    C = np.diag(np.concatenate([o.damping for o in osc])) if osc else np.zeros((0, 0))
    return M, C, K, A[:2]


def chain_receptance(oscillators, omega) -> np.ndarray:
    """Rigid-base receptance (2, 2, n_freq), m/N, TCP x-y, at the tip of a chain (:func:`chain_matrices`)."""
    M, C, K, D = chain_matrices(oscillators)
    w = np.atleast_1d(np.asarray(omega, dtype=float))
    Z = K[None] - w[:, None, None] ** 2 * M[None] + 1j * w[:, None, None] * C[None]
    X = np.linalg.solve(Z, np.broadcast_to(D.T.astype(complex), (w.size,) + D.T.shape))
    return np.einsum("in,fnj->ijf", D, X)

