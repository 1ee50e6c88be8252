"""Structures seen from the tool tip: physical (M, C, K, TCP rows), modal (hammer-test modes), reduced.

Every structure becomes the same internal first-order model (:class:`StateSpace`)::

    dy/dt = A y + B F,        r = S y

with ``F`` (3,) the force on the tool in the cut frame ``(x_c, y_c, z_c)`` (N) and ``r`` (3,) the
tool displacement in the cut frame (m). Only ``r[:2]`` (x_c, y_c) enters the chip thickness; the
whole force, including the axial one (``Kac``), acts through ``B``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import partial
from typing import TYPE_CHECKING, Any, Union

import numpy as np

from robolobes.core.validate import shown
from robolobes.cases.milling import cut_frame
from robolobes.core.frf import CUT_LABELS, FRF
from robolobes.core.validate import finite, finite_array, readonly

from ._errors import LobeError

__all__ = [
    "ComplexMode",
    "Mode",
    "in_series",
    "ModalStructure",
    "PhysicalStructure",
    "ReducedStructure",
    "TruncationReport",
    "StateSpace",
    "Structure",
]


_ro = partial(readonly, dtype=None)


def _omega(omega_rad_s) -> np.ndarray:
    w = finite_array("omega_rad_s (angular frequencies, rad/s)", omega_rad_s, error=LobeError).reshape(-1)
    if np.any(w < 0):
        raise LobeError(f"omega_rad_s must be >= 0 rad/s, got {w[w < 0][0]}")
    return w


def _cut_frf(omega_rad_s, H: np.ndarray) -> FRF:
    """An FRF in the cut frame (x_c feed, y_c normal, z_c axial), H (3, 3, F) m/N."""
    return FRF(omega=_omega(omega_rad_s), H=H, frame="cut", labels=CUT_LABELS)
_real_matrix = partial(finite_array, ndim=2, error=LobeError)


@dataclass(frozen=True, eq=False)
class StateSpace:
    """First-order tool-tip model ``dy/dt = A y + B F``, ``r = S y`` (internal, scaled coordinates).

    Attributes
    ----------
    A : array (ns, ns), 1/s
        Block-diagonal with 2 x 2 blocks (``block2``) in modal coordinates, which keeps its norm
        near the largest pole (fewer squarings in the matrix exponential) and makes the free
        propagator block-diagonal.
    B : array (ns, 3)
        Input: force on the tool in the cut frame, N.
    S : array (3, ns)
        Output: tool displacement in the cut frame, m.
    """

    A: np.ndarray
    B: np.ndarray
    S: np.ndarray
    if TYPE_CHECKING:  # set in __post_init__, not dataclass fields: declared for the type checker only
        _lam: np.ndarray = field(init=False)
        _V: np.ndarray = field(init=False)
        block2: bool = field(init=False)

    def __post_init__(self) -> None:
        for k in ("A", "B", "S"):
            object.__setattr__(self, k, _ro(np.asarray(getattr(self, k), dtype=float)))
        lam, V = np.linalg.eig(self.A)
        object.__setattr__(self, "_lam", lam)
        object.__setattr__(self, "_V", V)
        n = self.A.shape[0]
        off = self.A.copy()
        if n % 2 == 0:
            for k in range(0, n, 2):
                off[k:k + 2, k:k + 2] = 0.0
        object.__setattr__(self, "block2", bool(n % 2 == 0 and not np.any(off)))

    def state_space(self) -> "StateSpace":
        """The structure protocol: a StateSpace is its own first-order model."""
        return self

    @classmethod
    def from_control(cls, sys) -> "StateSpace":
        """From a ``control.StateSpace`` with inputs = force on the tool, outputs = its displacement.

        ``sys`` has 2 or 3 inputs (force along x_c, y_c[, z_c], N) and as many outputs
        (displacement along the same axes, m), continuous time, and ``D = 0``: a feedthrough would
        make the displacement respond instantly to the force, and with the chip force responding
        instantly to the displacement that closes an algebraic loop through the chip (no delay
        differential equation is left). The poles must be stable (checked where the lobes are
        solved). Put in real block-diagonal modal form when its eigenvectors are well conditioned.
        """
        try:
            A, B, C, D = (np.asarray(getattr(sys, k), dtype=float) for k in ("A", "B", "C", "D"))
        except (AttributeError, TypeError, ValueError):
            raise LobeError(f"expected a control.StateSpace (A, B, C, D), got {type(sys).__name__}") from None
        if getattr(sys, "dt", 0) not in (0, None):
            raise LobeError(f"the state space must be continuous-time (dt = 0), got dt = {sys.dt}")
        n_in, n_out = B.shape[1], C.shape[0]
        if n_in not in (2, 3) or n_out != n_in:
            raise LobeError(f"the state space must have 2 or 3 inputs (force x_c, y_c[, z_c], N) and as many outputs "
                            f"(displacement, m); got {n_in} inputs, {n_out} outputs")
        if np.any(D != 0):
            raise LobeError(f"the state space has a feedthrough D = {D.tolist()}; it must be 0: a feedthrough closes an "
                            "algebraic loop through the chip (fit without an upper residual, or model the "
                            "out-of-band stiffness by a mode above the band)")
        if not (np.all(np.isfinite(A)) and np.all(np.isfinite(B)) and np.all(np.isfinite(C))):
            raise LobeError("the state space has NaN or inf entries")
        B3 = np.zeros((A.shape[0], 3))
        B3[:, :n_in] = B
        S3 = np.zeros((3, A.shape[0]))
        S3[:n_out] = C
        modal = _real_modal_form(A, B3, S3)
        return modal if modal is not None else cls(A, B3, S3)

    @property
    def blocks(self) -> np.ndarray:
        """The 2 x 2 diagonal blocks of a block-diagonal ``A`` (``block2``), shape (ns/2, 2, 2)."""
        n = self.A.shape[0]
        return np.stack([self.A[k:k + 2, k:k + 2] for k in range(0, n, 2)])

    @property
    def n_states(self) -> int:
        return self.A.shape[0]

    @property
    def poles(self) -> np.ndarray:
        """Eigenvalues of ``A`` (ns,), complex, rad/s."""
        return self._lam.copy()

    def check_stable(self) -> None:
        """Raise :class:`LobeError` if the structure alone is not asymptotically stable."""
        worst = float(np.max(np.real(self._lam)))
        if worst >= 0:
            raise LobeError(
                f"the structure is not asymptotically stable without cutting (largest real part of its "
                f"poles {worst:.6g} 1/s >= 0); stability lobes need a damped, stable structure"
            )

    def receptance(self, omega_rad_s: np.ndarray) -> np.ndarray:
        """``S (i w I - A)^-1 B`` as a bare array (3, 3, F), m/N, cut frame (:meth:`frf` wraps it).

        ``omega_rad_s`` : array (F,), rad/s.
        """
        w = _omega(omega_rad_s)
        # modal evaluation: S V diag(1/(iw - lam)) V^-1 B
        SV = self.S @ self._V
        VB = np.linalg.solve(self._V, self.B)
        g = 1.0 / (1j * w[None, :] - self._lam[:, None])
        return np.einsum("ik,kf,kj->ijf", SV, g, VB)

    def frf(self, omega_rad_s: np.ndarray) -> FRF:
        """Tool-tip receptance in the cut frame: :class:`robolobes.core.frf.FRF`, H (3, 3, F) m/N."""
        return _cut_frf(omega_rad_s, self.receptance(omega_rad_s))

    def static_compliance(self) -> np.ndarray:
        """``-S A^-1 B`` (3, 3), m/N."""
        return -self.S @ np.linalg.solve(self.A, self.B)

    def mode_weights(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Split states ``y`` (..., ns) into modal contributions to the tool displacement.

        Returns
        -------
        freq_rad_s : array (ns,)
            ``|Im lambda_k|`` of each pole.
        weight : array (..., ns)
            ``|c_k| * ||S[:2] v_k||`` with ``y = sum_k c_k v_k``: how much pole k moves the tool
            in the (x_c, y_c) plane.
        """
        c = np.linalg.solve(self._V, np.asarray(y).T).T
        vis = np.linalg.norm(self.S[:2] @ self._V, axis=0)
        return np.abs(np.imag(self._lam)), np.abs(c) * vis


def _real_modal_form(A: np.ndarray, B: np.ndarray, S: np.ndarray) -> StateSpace | None:
    """``A`` in real 2 x 2 block-diagonal modal form, or None if the eigenvectors are ill-conditioned."""
    lam, V = np.linalg.eig(A)
    if not np.all(np.isfinite(V)) or np.linalg.cond(V) > 1e8:
        return None
    n = len(lam)
    Vinv = np.linalg.inv(V)
    cols, rows, blocks = [], [], []
    used = np.zeros(n, bool)
    reals = []
    for k in np.argsort(np.abs(np.imag(lam)), kind="stable"):
        if used[k]:
            continue
        if np.imag(lam[k]) == 0.0:
            reals.append(k)
            used[k] = True
            continue
        if np.imag(lam[k]) < 0:
            continue
        j = int(np.argmin(np.where(used, np.inf, np.abs(lam - lam[k].conjugate()))))
        used[k] = used[j] = True
        cols += [np.real(V[:, k]), np.imag(V[:, k])]
        rows += [2 * Vinv[k].real, -2 * Vinv[k].imag]
        blocks.append(np.array([[np.real(lam[k]), np.imag(lam[k])], [-np.imag(lam[k]), np.real(lam[k])]]))
    if not used.all() or len(reals) % 2:
        return None
    for a, b in zip(reals[::2], reals[1::2]):
        cols += [np.real(V[:, a]), np.real(V[:, b])]
        rows += [Vinv[a].real, Vinv[b].real]
        blocks.append(np.diag([np.real(lam[a]), np.real(lam[b])]))
    T = np.array(cols).T
    L = np.array(rows)
    if np.linalg.norm(L @ T - np.eye(n)) > 1e-8:
        return None
    from scipy.linalg import block_diag

    return StateSpace(np.asarray(block_diag(*blocks)), L @ B, S @ T)


def in_series(a: StateSpace, b: StateSpace) -> StateSpace:
    """Two structures carrying the same tool force with their displacements added (series
    receptance ``H = H_a + H_b``, no rotational coupling): block-diagonal ``A``, stacked ``B``,
    side-by-side ``S``. E.g. the robot at the TCP and a tool-holder measured on a rigid base."""
    from scipy.linalg import block_diag

    return StateSpace(np.asarray(block_diag(a.A, b.A)), np.vstack([a.B, b.B]), np.hstack([a.S, b.S]))


@dataclass(frozen=True, eq=False)
class PhysicalStructure:
    """``M q'' + C q' + K q = tcp^T F``, tool displacement ``r = tcp q`` in the cut frame.

    Parameters
    ----------
    M, C, K : array (n, n)
        Mass, damping, stiffness in SI units of the generalized coordinates (need not be
        symmetric; ``M`` must be invertible).
    tcp : array (3, n) or (2, n)
        Rows mapping the coordinates to the tool-tip displacement along ``x_c`` (feed), ``y_c``
        (normal) and, if given, ``z_c`` (axial), m per unit coordinate. A 2-row ``tcp`` means no
        axial motion (the axial force then does no work).
    """

    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    tcp: np.ndarray

    def __post_init__(self) -> None:
        M, C, K = (_real_matrix(k, getattr(self, k)) for k in ("M", "C", "K"))
        if M.shape[0] != M.shape[1]:
            raise LobeError(f"M must be square n x n, got {M.shape[0]} x {M.shape[1]}")
        n = M.shape[0]
        for name, a in (("C", C), ("K", K)):
            if a.shape != (n, n):
                raise LobeError(f"{name} is {a.shape[0]} x {a.shape[1]} but M is {n} x {n}; M, C, K must all be n x n")
        tcp = _real_matrix("tcp", self.tcp)
        if tcp.shape not in ((2, n), (3, n)):
            raise LobeError(
                f"tcp must be 2 x n or 3 x n (rows x_c, y_c[, z_c] of the cut frame) with n = {n}, "
                f"got {tcp.shape[0]} x {tcp.shape[1]}"
            )
        if tcp.shape[0] == 2:
            tcp = np.vstack([tcp, np.zeros((1, n))])
        if not np.any(tcp[:2]):
            raise LobeError("tcp rows x_c, y_c are all zero: the structure does not move the tool in the cut plane")
        cond = np.linalg.cond(M)
        if not np.isfinite(cond) or cond > 1e13:
            raise LobeError(f"M is singular or nearly so (condition number {cond:.3g}); it must be invertible")
        for k, v in (("M", M), ("C", C), ("K", K), ("tcp", tcp)):
            object.__setattr__(self, k, _ro(v))

    @property
    def n_dof(self) -> int:
        return self.M.shape[0]

    @classmethod
    def from_linear(cls, lin, feed_direction) -> "PhysicalStructure":
        """From a :class:`linearize.LinearModel` (``M, C, K``, base-frame ``J`` (3 x n), ``tool_axis``).

        ``tcp = cut_frame(feed_direction, lin.tool_axis) @ lin.J``.

        Parameters
        ----------
        lin : linearize.LinearModel
        feed_direction : array (3,)
            Feed direction in the robot base frame.
        """
        R = cut_frame(np.asarray(feed_direction, dtype=float), np.asarray(lin.tool_axis, dtype=float))
        return cls(lin.M, lin.C, lin.K, R @ np.asarray(lin.J, dtype=float))

    def state_space(self) -> StateSpace:
        """Internal first-order model in real modal coordinates (2 x 2 blocks per complex pair, real
        poles paired into diagonal blocks); if the eigenvectors are ill-conditioned (cond > 1e8),
        the physical state ``[q; q' / w_s]`` with the velocities scaled by the largest undamped
        frequency ``w_s``."""
        n = self.n_dof
        MiK = np.linalg.solve(self.M, self.K)
        MiC = np.linalg.solve(self.M, self.C)
        MiP = np.linalg.solve(self.M, self.tcp.T)
        ws = math.sqrt(max(float(np.max(np.abs(np.linalg.eigvals(MiK)))), 1e-30))
        A = np.block([[np.zeros((n, n)), ws * np.eye(n)], [-MiK / ws, -MiC]])
        B = np.vstack([np.zeros((n, 3)), MiP / ws])
        S = np.hstack([self.tcp, np.zeros((3, n))])
        modal = _real_modal_form(A, B, S)
        return modal if modal is not None else StateSpace(A, B, S)

    def frf(self, omega_rad_s: np.ndarray) -> FRF:
        """Tool-tip receptance ``tcp (K - w^2 M + i w C)^-1 tcp^T`` by direct solve, cut frame:
        :class:`robolobes.core.frf.FRF`, H (3, 3, F) m/N, at ``omega_rad_s`` (F,) rad/s."""
        w = _omega(omega_rad_s)
        Z = self.K[None] - (w**2)[:, None, None] * self.M[None] + 1j * w[:, None, None] * self.C[None]
        X = np.linalg.solve(Z, np.broadcast_to(self.tcp.T, (len(w),) + self.tcp.T.shape))
        return _cut_frf(w, np.moveaxis(self.tcp[None] @ X, 0, -1))

    def truncated(
        self,
        *,
        max_freq_hz: float | None = None,
        n_modes: int | None = None,
        band_hz: tuple[float, float] | None = None,
    ) -> "ReducedStructure":
        """Modal truncation: keep the lowest modes (by ``|lambda| / 2 pi``), drop the rest.

        Parameters
        ----------
        max_freq_hz : float, optional
            Keep modes whose natural frequency ``|lambda| / 2 pi`` is at most this, Hz (for an
            overdamped real pole that is its corner frequency).
        n_modes : int, optional
            Keep this many lowest modes (a complex pair counts once, a real pole as one mode).
        band_hz : (float, float), optional
            Band in which the FRF error is reported, Hz. Default ``(0, 1.5 * highest kept)``.

        Returns
        -------
        ReducedStructure
            With its :class:`TruncationReport` (static compliance error and FRF error in the band).
        """
        return _truncate(self.state_space(), max_freq_hz=max_freq_hz, n_modes=n_modes, band_hz=band_hz)


@dataclass(frozen=True)
class Mode:
    """One measured (hammer-test) mode of the tool tip.

    Parameters
    ----------
    freq_hz : float
        Undamped natural frequency, Hz (> 0).
    damping_ratio : float
        Viscous damping ratio zeta, 0 < zeta < 1.
    stiffness_n_per_m : float
        Modal stiffness along ``direction``, N/m (> 0).
    direction : (float, float)
        Unit vector ``[x, y]`` in the cut frame (x_c feed, y_c normal) along which the mode moves
        the tool.
    """

    freq_hz: float
    damping_ratio: float
    stiffness_n_per_m: float
    direction: tuple[float, float]

    def __post_init__(self) -> None:
        f, z, k = (finite(f"mode {name}", getattr(self, name), error=LobeError)
                   for name in ("freq_hz", "damping_ratio", "stiffness_n_per_m"))
        if f <= 0:
            raise LobeError(f"mode freq_hz must be > 0 Hz, got {f}")
        if not 0.0 < z < 1.0:
            raise LobeError(f"mode damping_ratio must be in (0, 1) (an underdamped, damped mode), got {z}")
        if k <= 0:
            raise LobeError(f"mode stiffness_n_per_m must be > 0, got {k}")
        try:
            d = np.array(self.direction, dtype=float)
        except (TypeError, ValueError):
            raise LobeError(f"mode direction must be [x, y], got {shown(self.direction)}") from None
        if d.shape != (2,) or not np.all(np.isfinite(d)):
            raise LobeError(f"mode direction must be a finite unit vector [x, y] in the cut frame, got {shown(self.direction)}")
        nd = float(np.linalg.norm(d))
        if abs(nd - 1.0) > 1e-3:
            raise LobeError(
                f"mode direction {d.tolist()} has norm {nd:.6g}; it must be a unit vector [x, y] in the cut "
                f"frame (e.g. [1, 0] for the feed direction)"
            )
        object.__setattr__(self, "freq_hz", f)
        object.__setattr__(self, "damping_ratio", z)
        object.__setattr__(self, "stiffness_n_per_m", k)
        object.__setattr__(self, "direction", tuple((d / nd).tolist()))

    @property
    def omega_rad_s(self) -> float:
        return 2 * math.pi * self.freq_hz

    @property
    def mass_kg(self) -> float:
        """Modal mass ``k / w_n^2``, kg."""
        return self.stiffness_n_per_m / self.omega_rad_s**2


@dataclass(frozen=True, eq=False)
class ComplexMode:
    """One mode of a fitted (measured) tool tip: a pole pair with a complex residue matrix.

    ``H(s) = R / (s - lam) + conj(R) / (s - conj(lam))``, ``lam = -zeta w_n + i w_n sqrt(1 - zeta^2)``,
    ``w_n = 2 pi freq_hz``: complex (non-proportional damping), cross and non-reciprocal
    (``R[0, 1] != R[1, 0]``) residues are allowed. A real mode of modal stiffness ``k`` along a unit
    direction ``d`` is ``R = d d^T / (2 i m w_d)`` with ``m = k / w_n^2``, ``w_d = w_n sqrt(1 - zeta^2)``.

    Parameters
    ----------
    freq_hz : float
        Undamped natural frequency ``|lam| / 2 pi``, Hz (> 0).
    damping_ratio : float
        ``-Re lam / |lam|``, in (0, 1).
    residue : complex array (2, 2), m/(N s)
        ``R``: rows displacement x_c, y_c; columns force x_c, y_c (cut frame).
    """

    freq_hz: float
    damping_ratio: float
    residue: np.ndarray

    def __post_init__(self) -> None:
        f = finite("mode freq_hz", self.freq_hz, error=LobeError)
        z = finite("mode damping_ratio", self.damping_ratio, error=LobeError)
        if f <= 0:
            raise LobeError(f"mode freq_hz must be > 0 Hz, got {f}")
        if not 0.0 < z < 1.0:
            raise LobeError(f"mode damping_ratio must be in (0, 1) (an underdamped, damped mode), got {z}")
        try:
            R = np.array(self.residue, dtype=complex)
        except (TypeError, ValueError):
            raise LobeError(f"mode residue must be a 2 x 2 complex matrix, got {shown(self.residue)}") from None
        if R.shape != (2, 2) or not np.all(np.isfinite(R)) or not np.any(R):
            raise LobeError(f"mode residue must be a finite, non-zero 2 x 2 matrix (m/(N s)), got {R.tolist()}")
        object.__setattr__(self, "freq_hz", f)
        object.__setattr__(self, "damping_ratio", z)
        object.__setattr__(self, "residue", readonly(R, complex))

    @property
    def pole(self) -> complex:
        """``lam`` (upper half plane), rad/s."""
        w, z = 2 * math.pi * self.freq_hz, self.damping_ratio
        return complex(-z * w, w * math.sqrt(1 - z * z))

    @property
    def modal_constants(self) -> np.ndarray:
        """``2 i w_d R`` (2, 2), 1/kg: real and, on the diagonal, positive for a real mode
        (``d d^T / m``); a negative real part on the diagonal means a non-physical driving point."""
        return 2j * self.pole.imag * np.asarray(self.residue)

    @classmethod
    def from_mode(cls, mode: "Mode") -> "ComplexMode":
        """The complex form of a real :class:`Mode`."""
        d = np.asarray(mode.direction)
        wd = mode.omega_rad_s * math.sqrt(1 - mode.damping_ratio**2)
        return cls(mode.freq_hz, mode.damping_ratio, np.outer(d, d) / (2j * mode.mass_kg * wd))


def _complex_mode_blocks(md: ComplexMode):
    """Real realization of one :class:`ComplexMode`: ``R = sum_k u_k v_k^T`` (SVD, rank 1 or 2), each
    term a complex state ``z' = lam z + v^T F`` with output ``u z + conj(u z)``; in real coordinates
    ``(Re z, Im z)``: ``A = [[s, -w], [w, s]]``, ``B`` rows ``Re v, Im v``, ``S`` columns
    ``2 Re u, -2 Im u``. Returns lists of (A 2x2, B 2x3, S 3x2)."""
    lam = md.pole
    U, sv, Vh = np.linalg.svd(np.asarray(md.residue))
    out = []
    for k in range(2):
        if sv[k] <= 1e-12 * sv[0]:
            continue
        u, v = sv[k] * U[:, k], Vh[k]
        A = np.array([[lam.real, -lam.imag], [lam.imag, lam.real]])
        B = np.zeros((2, 3))
        B[0, :2], B[1, :2] = v.real, v.imag
        S = np.zeros((3, 2))
        S[:2, 0], S[:2, 1] = 2 * u.real, -2 * u.imag
        out.append((A, B, S))
    return out


@dataclass(frozen=True)
class ModalStructure:
    """Uncoupled modes of the tool tip: real modes (:class:`Mode`, each moving it along its own
    direction in the cut plane) and fitted complex modes (:class:`ComplexMode`).

    For real modes the equivalent physical structure has one coordinate per mode (modal
    displacement in m along the mode's direction): ``M = diag(k/w^2)``, ``C = diag(2 zeta k / w)``,
    ``K = diag(k)``, ``tcp = [[d_x...], [d_y...], [0...]]``; its receptance is
    ``sum d d^T / (k (1 - r^2 + 2 i zeta r))``. Complex modes add ``R / (s - lam) + conj``.
    """

    modes: tuple

    def __post_init__(self) -> None:
        modes = tuple(self.modes) if isinstance(self.modes, (list, tuple)) else (self.modes,)
        if not modes:
            raise LobeError("a ModalStructure needs at least one Mode")
        for i, m in enumerate(modes):
            if not isinstance(m, (Mode, ComplexMode)):
                raise LobeError(f"modes[{i}] must be a Mode or ComplexMode, got {type(m).__name__}")
        object.__setattr__(self, "modes", modes)

    def to_physical(self) -> PhysicalStructure:
        """The equivalent physical structure (real modes only)."""
        if any(isinstance(m, ComplexMode) for m in self.modes):
            raise LobeError("complex modes have no M, C, K form; use state_space()")
        k = np.array([m.stiffness_n_per_m for m in self.modes])
        w = np.array([m.omega_rad_s for m in self.modes])
        z = np.array([m.damping_ratio for m in self.modes])
        d = np.array([m.direction for m in self.modes]).T  # (2, n)
        return PhysicalStructure(np.diag(k / w**2), np.diag(2 * z * k / w), np.diag(k), d)

    def state_space(self) -> StateSpace:
        """2 x 2 blocks: per real mode, state ``(q_k, q_k' / w_k)``, ``[[0, w], [-w, -2 zeta w]]``;
        per complex mode, one or two blocks (:func:`_complex_mode_blocks`)."""
        As, Bs, Ss = [], [], []
        for md in self.modes:
            if isinstance(md, ComplexMode):
                for A, B, S in _complex_mode_blocks(md):
                    As.append(A)
                    Bs.append(B)
                    Ss.append(S)
                continue
            w, z = md.omega_rad_s, md.damping_ratio
            B = np.zeros((2, 3))
            S = np.zeros((3, 2))
            B[1, :2] = np.array(md.direction) / (md.mass_kg * w)
            S[:2, 0] = md.direction
            As.append(np.array([[0.0, w], [-w, -2 * z * w]]))
            Bs.append(B)
            Ss.append(S)
        from scipy.linalg import block_diag

        return StateSpace(np.asarray(block_diag(*As)), np.vstack(Bs), np.hstack(Ss))

    def frf(self, omega_rad_s: np.ndarray) -> FRF:
        """Tool-tip receptance in the cut frame (FRF, H (3, 3, F) m/N) at ``omega_rad_s`` (F,) rad/s."""
        if any(isinstance(m, ComplexMode) for m in self.modes):
            return self.state_space().frf(omega_rad_s)
        return self.to_physical().frf(omega_rad_s)


@dataclass(frozen=True)
class TruncationReport:
    """What a modal truncation dropped and what it costs.

    Attributes
    ----------
    kept_freq_hz, dropped_freq_hz : tuple of float
        Natural frequencies ``|lambda| / 2 pi`` of the kept and dropped modes, Hz.
    static_compliance_rel_error : float
        ``||G_red(0) - G(0)|| / ||G(0)||`` (2-norm of the 3 x 3 cut-frame compliance).
    frf_rel_error : float
        ``max_band ||G_red - G|| / max_band ||G||`` over ``band_hz``.
    band_hz : (float, float)
    """

    kept_freq_hz: tuple[float, ...]
    dropped_freq_hz: tuple[float, ...]
    static_compliance_rel_error: float
    frf_rel_error: float
    band_hz: tuple[float, float]


@dataclass(frozen=True, eq=False)
class ReducedStructure:
    """A modally truncated structure (real block-diagonal modal state space) and its error report.

    ``basis``: how it was reduced when made by :func:`lobes.basis.reduced_basis` (a
    :class:`lobes.basis.BasisInfo`), else None."""

    ss: StateSpace
    report: TruncationReport
    basis: Any = None

    def state_space(self) -> StateSpace:
        return self.ss

    def frf(self, omega_rad_s: np.ndarray) -> FRF:
        """Tool-tip receptance in the cut frame (FRF, H (3, 3, F) m/N) at ``omega_rad_s`` (F,) rad/s."""
        return self.ss.frf(omega_rad_s)


def _truncate(ss: StateSpace, *, max_freq_hz, n_modes, band_hz) -> ReducedStructure:
    if (max_freq_hz is None) == (n_modes is None):
        raise LobeError("give exactly one of max_freq_hz or n_modes for a modal truncation")
    lam, V = ss._lam, ss._V
    f = np.abs(lam) / (2 * np.pi)  # undamped natural frequency; corner frequency of a real pole
    # one representative per physical mode: Im >= 0 (real poles are their own mode)
    rep = np.flatnonzero(np.imag(lam) >= 0)
    order = rep[np.argsort(f[rep], kind="stable")]
    if max_freq_hz is not None:
        if not (isinstance(max_freq_hz, (int, float)) and math.isfinite(max_freq_hz) and max_freq_hz > 0):
            raise LobeError(f"max_freq_hz must be a finite frequency > 0 Hz, got {max_freq_hz!r}")
        keep_rep = [k for k in order if f[k] <= max_freq_hz]
    else:
        if isinstance(n_modes, bool) or not isinstance(n_modes, (int, np.integer)) or not 1 <= n_modes <= len(order):
            raise LobeError(f"n_modes must be an integer in [1, {len(order)}], got {n_modes!r}")
        keep_rep = list(order[: int(n_modes)])
    if not keep_rep:
        raise LobeError(f"no mode below max_freq_hz = {max_freq_hz} Hz (lowest is {f[order[0]]:.6g} Hz)")
    Vinv = np.linalg.inv(V)
    cols, rowsL, blocks = [], [], []
    used = np.zeros(len(lam), bool)
    for k in keep_rep:
        if abs(np.imag(lam[k])) > 0:
            # real basis of the pair: V [a b], A [a b] = [a b] [[s, w], [-w, s]]
            a, b = np.real(V[:, k]), np.imag(V[:, k])
            la, lb = 2 * Vinv[k].real, -2 * Vinv[k].imag
            cols += [a, b]
            rowsL += [la, lb]
            blocks.append(np.array([[np.real(lam[k]), np.imag(lam[k])], [-np.imag(lam[k]), np.real(lam[k])]]))
            used[k] = True
            used[np.argmin(np.abs(lam - lam[k].conjugate()))] = True
        else:
            cols.append(np.real(V[:, k]))
            rowsL.append(Vinv[k].real)
            blocks.append(np.array([[np.real(lam[k])]]))
            used[k] = True
    T = np.array(cols).T
    L = np.array(rowsL)
    from scipy.linalg import block_diag

    Ar = np.asarray(block_diag(*blocks))
    Br = L @ ss.B
    Sr = ss.S @ T
    red = StateSpace(Ar, Br, Sr)
    kept = tuple(sorted(float(f[k]) for k in keep_rep))
    dropped_rep = [k for k in order if k not in set(keep_rep)]
    dropped = tuple(sorted(float(f[k]) for k in dropped_rep))
    G0 = ss.static_compliance()
    Gr0 = red.static_compliance()
    st_err = float(np.linalg.norm(Gr0 - G0, 2) / np.linalg.norm(G0, 2))
    if band_hz is None:
        band_hz = (0.0, 1.5 * max(kept) if max(kept) > 0 else 1.0)
    lo, hi = (float(band_hz[0]), float(band_hz[1]))
    if not (0 <= lo < hi and math.isfinite(hi)):
        raise LobeError(f"band_hz must be (lo, hi) with 0 <= lo < hi, got {band_hz!r}")
    wb = 2 * np.pi * np.linspace(lo, hi, 4001)
    Hf, Hr = ss.receptance(wb), red.receptance(wb)
    num = np.max(np.linalg.norm(Hr - Hf, ord=2, axis=(0, 1)))
    den = np.max(np.linalg.norm(Hf, ord=2, axis=(0, 1)))
    rep_ = TruncationReport(kept, dropped, st_err, float(num / den), (lo, hi))
    return ReducedStructure(red, rep_)


Structure = Union[PhysicalStructure, ModalStructure, ReducedStructure, StateSpace]
