"""Collocation of the cutting force on the cutting intervals (a Nystrom method for the lobes).

The linearized milling dynamics (cut frame, the same equation as :mod:`lobes.sdm`)::

    dx/dt = A x + B f(t),   r = S2 x,   f(t) = sum_g W_g(t) (r(t) - r(t - tau_g))

(``W_g``: directional matrices of the teeth of delay group ``g``, :mod:`lobes.directional`, zero
where no tooth of the group cuts). Over one principal period ``[0, T)``, variation of constants
``x(t) = e^(A t) x0 + int_0^t e^(A (t - s)) B f(s) ds`` makes the only unknowns the tool
displacements ``Y`` (2 per node) at Gauss-Legendre nodes placed on elements covering the cutting
intervals only (element boundaries at every tooth entry and exit and at the period ends, where
``W`` jumps). On each element ``f`` is replaced by its Lagrange interpolant through the node values
``F`` (``n`` nodes: degree ``n - 1``); the delayed displacement ``r(t_i - tau_g)`` by the Lagrange
interpolant of ``Y`` (or of the previous period's ``Y_prev``) on the element that contains
``t_i - tau_g`` (it lies in the predecessor tooth's cutting interval). Then, with ``a`` the depth::

    Y = C x0 + Q F,    x(T) = E x0 + P F,    F = a (H Y - Kp Y_prev)

``C_i = S2 e^(A t_i)``, ``Q_ij = S2 int_0^(t_i) e^(A (t_i - s)) B l_j(s) ds``, ``P_j = int_0^T
e^(A (T - s)) B l_j(s) ds``, ``E = e^(A T)``: these depend on the speed only and are computed
once per speed in the modal form of ``A`` (:func:`kernel_weights`); ``H``, ``Kp`` (directional
matrices at the nodes, interpolation of the delayed values) on the angles only. Per depth a
``(2M, 2M)`` solve and the eigenvalues of the monodromy on ``(x0, Y_prev)`` remain::

    (I - a Q H) Y = C x0 - a Q Kp Y_prev,    x(T) = E x0 + a P H Y - a P Kp Y_prev

Only the previous-period nodes that some delayed value reads are kept in the state (the others
add zero multipliers). Straight tools only (a helix moves the element boundaries with the depth):
a helical tool is refused.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from robolobes.cases.milling import directional_matrix, in_cut
from robolobes.core.validate import integer

from ._errors import LobeError
from .directional import DirectionalPlan
from .problem import LobeProblem
from .sdm import Search, chatter_branch, eigenvector_of
from .structure import StateSpace

__all__ = ["Collocation", "CollocationEngine", "kernel_weights", "element_layout"]


@dataclass(frozen=True)
class Collocation:
    """Collocation (Nystrom) method of the stability lobes on the cutting intervals.

    Parameters
    ----------
    nodes : int
        Gauss-Legendre nodes per element (force interpolated at degree ``nodes - 1``), >= 1.
    elements : int
        Elements per principal period: each cutting interval of angular length ``L`` gets
        ``ceil(elements * L / period)`` equal elements (at least one).
    check_nodes : int or None
        In :func:`lobes.solve`: also solve with ``nodes + check_nodes`` nodes per element (default
        2) and report that finer level with the error estimate ``|b_fine - b_coarse|`` (the
        whole change, a conservative estimate for a spectrally converging method); 0: one level
        without estimate.
    tol : float
        Relative error estimate below which a speed counts as converged, in (0, 0.5).
    angle_tol_rad : float
        Fold / flip / Hopf classification of the critical multiplier (as in the SDM).
    search : {"fast", "fast-wide", "plain"}
        Depth search of :func:`lobes.solve` (as in :class:`SemiDiscretization`).
    """

    nodes: int = 6
    elements: int = 8
    check_nodes: int = 2
    tol: float = 0.01
    angle_tol_rad: float = 1e-6
    search: Search = "fast"

    def __post_init__(self) -> None:
        integer("Collocation nodes (per element)", self.nodes, minimum=1, error=LobeError)
        integer("Collocation elements (per principal period)", self.elements, minimum=1, error=LobeError)
        integer("Collocation check_nodes", self.check_nodes, minimum=0, error=LobeError)
        t = self.tol
        if isinstance(t, bool) or not isinstance(t, (int, float)) or not (0 < t < 0.5):
            raise LobeError(f"Collocation tol must be in (0, 0.5), got {t!r}")
        a = self.angle_tol_rad
        if not (isinstance(a, (int, float)) and math.isfinite(a) and 0 <= a < math.pi / 2):
            raise LobeError(f"angle_tol_rad must be in [0, pi/2), got {a!r}")
        if self.search not in ("fast", "fast-wide", "plain"):
            raise LobeError(f"search must be 'fast', 'fast-wide' or 'plain', got {self.search!r}")

    @property
    def name(self) -> str:
        return "collocation"

    # the solver's SDM drivers read these two (no prescan with another scheme)
    scheme = "collocation"
    prescan = False


@functools.cache
def _gauss01(n: int) -> tuple[np.ndarray, np.ndarray]:
    x, w = np.polynomial.legendre.leggauss(n)
    return (x + 1) / 2, w / 2


def lagrange(nodes: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Lagrange basis through ``nodes`` (n,) evaluated at ``s`` (...): array (..., n)."""
    s = np.asarray(s, dtype=float)[..., None]
    n = len(nodes)
    out = np.ones(s.shape[:-1] + (n,))
    for j in range(n):
        for m in range(n):
            if m != j:
                out[..., j] *= (s[..., 0] - nodes[m]) / (nodes[j] - nodes[m])
    return out


def kernel_weights(lam: np.ndarray, h: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Integrals of the exponential kernel against the Lagrange basis on one element of length ``h``.

    ``full[k, j] = int_0^h e^(lam_k (h - s)) l_j(s / h) ds`` and
    ``part[k, i, j] = int_0^(h u_i) e^(lam_k (h u_i - s)) l_j(s / h) ds`` (``u``: the ``n``
    Gauss-Legendre nodes on [0, 1], ``l_j`` their Lagrange basis). Composite Gauss-Legendre with
    ``n + 12`` points on sub-intervals where ``|lam h| * length <= 1`` (the polynomial part is
    integrated exactly, the exponential to double rounding). ``lam`` (K,) complex, 1/s; ``h`` s.

    Returns ``full`` (K, n) and ``part`` (K, n, n), complex, s.
    """
    u, _ = _gauss01(n)
    xq, wq = _gauss01(n + 12)
    lam = np.asarray(lam, dtype=complex)
    nsub = max(1, int(math.ceil(float(np.max(np.abs(lam), initial=0.0)) * h)))
    ends = np.concatenate([u, [1.0]])  # (n + 1,) upper limits (fractions of the element)
    sub = (np.arange(nsub)[:, None] + xq[None, :]) / nsub  # (nsub, q) in [0, 1]
    pts = ends[:, None, None] * sub[None]                   # (n + 1, nsub, q)
    wts = ends[:, None, None] * np.broadcast_to(wq / nsub, sub.shape)[None]
    L = lagrange(u, pts)                                     # (n + 1, nsub, q, n)
    ker = np.exp(lam[:, None, None, None] * h * (ends[None, :, None, None] - pts[None]))  # (K, n+1, nsub, q)
    val = h * np.einsum("kesq,esq,esqj->kej", ker, wts, L)   # (K, n + 1, n)
    return val[:, n], val[:, :n]


@dataclass(frozen=True, eq=False)
class Layout:
    """Angular layout of the elements and nodes over one principal period (speed-independent).

    ``bounds`` (E, 2) element ends as spindle angles in ``[0, period]``, rad; ``alpha`` (M,) node
    angles; ``elem`` (M,) element of each node; ``H`` (M, k, M, 2) per unit depth: ``f_i = sum_j
    H[i, :, j] r_j`` from this period's nodes; ``Kp`` (M, k, R, 2): the delayed part from the
    previous period's nodes ``prev`` (R,) (indices into the nodes).
    """

    bounds: np.ndarray
    alpha: np.ndarray
    elem: np.ndarray
    H: np.ndarray
    Kp: np.ndarray
    prev: np.ndarray


def element_layout(plan: DirectionalPlan, n: int, elements: int) -> Layout:
    """Elements on the cutting intervals, nodes, and the force matrices per unit depth (straight tool)."""
    P = plan.period_rad
    cuts = _cutting_intervals(plan)
    edges = sorted({0.0, P} | {e for iv in cuts for e in iv})
    segs = []
    for a, b in zip(edges[:-1], edges[1:]):
        if b - a > 1e-12 * P and any(lo <= 0.5 * (a + b) <= hi for lo, hi in cuts):
            ne = max(1, math.ceil(elements * (b - a) / P - 1e-9))
            segs += [(a + (b - a) * i / ne, a + (b - a) * (i + 1) / ne) for i in range(ne)]
    if not segs:
        raise LobeError("no tooth is engaged over the principal period; nothing to collocate")
    bounds = np.array(segs)
    u, _ = _gauss01(n)
    alpha = (bounds[:, :1] + u[None] * (bounds[:, 1:] - bounds[:, :1])).reshape(-1)
    elem = np.repeat(np.arange(len(bounds)), n)
    M, k = len(alpha), plan.k_force
    Wg = _node_directional(plan, alpha)  # (M, G, k, 2)
    H = np.zeros((M, k, M, 2))
    H[np.arange(M), :, np.arange(M), :] = Wg.sum(axis=1)
    D = np.zeros((M, k, 2 * M, 2))  # delayed: columns [this period | previous period]
    for g, delay in enumerate(plan.group_delay_rad):
        beta = alpha - delay
        back = np.floor(beta / P + 1e-12).astype(int)  # periods back: 0 or -1
        if np.any(back < -1):
            raise LobeError("a regenerative delay longer than the principal period is not supported by Collocation")
        e = np.searchsorted(bounds[:, 1], beta - back * P, side="left").clip(0, len(bounds) - 1)
        s = (beta - back * P - bounds[e, 0]) / (bounds[e, 1] - bounds[e, 0])
        lw = lagrange(u, s)  # (M, n)
        col = e[:, None] * n + np.arange(n)[None] + np.where(back < 0, M, 0)[:, None]
        for i in range(M):
            if np.any(Wg[i, g]):
                D[i, :, col[i], :] += lw[i][:, None, None] * Wg[i, g][None]
    H -= D[:, :, :M]
    prev = np.flatnonzero(np.any(D[:, :, M:] != 0, axis=(0, 1, 3)))
    return Layout(bounds=bounds, alpha=alpha, elem=elem, H=H, Kp=D[:, :, M + prev], prev=prev)


def _cutting_intervals(plan: DirectionalPlan) -> list[tuple[float, float]]:
    """Angular intervals of ``[0, period]`` in which some tooth cuts (one per tooth and turn)."""
    P, out = plan.period_rad, []
    for th in plan.tooth_angle_rad:
        for turn in range(-2, 3):
            lo = plan.phi_st - th + 2 * math.pi * turn
            hi = plan.phi_ex - th + 2 * math.pi * turn
            a, b = max(lo, 0.0), min(hi, P)
            if b > a:
                out.append((a, b))
    return out


def _node_directional(plan: DirectionalPlan, alpha: np.ndarray) -> np.ndarray:
    """Directional matrix per unit depth of each delay group at the node angles: (M, G, k, 2), N/m^2."""
    out = np.zeros((len(alpha), plan.n_groups, plan.k_force, 2))
    for th, g in zip(plan.tooth_angle_rad, plan.tooth_group):
        phi = alpha + th
        D = directional_matrix(phi, plan.law)[..., :plan.k_force, :]
        out[:, g] += D * in_cut(phi, plan.phi_st, plan.phi_ex)[:, None, None]
    return out


class CollocationEngine:
    """Monodromy matrices of one problem (all speeds, all depths) for one collocation."""

    def __init__(self, problem: LobeProblem, method: Collocation, depth_max_m: float = math.inf):
        if problem.tool.helix_rad > 0:
            raise LobeError("Collocation supports straight tools only (helix_rad = 0); use RefinedSDM for a helix")
        self.problem, self.method = problem, method
        ss = problem.structure.state_space()
        ss.check_stable()
        self.ss: StateSpace = ss
        law = problem.law
        k = 3 if (law.kac_pa != 0.0 and np.any(ss.B[:, 2])) else 2
        self.plan = DirectionalPlan.build(problem.tool, problem.cut, law, m=1 << 20, quadrature=1, slices=1,
                                          k_force=k)
        self.k, self.ns = k, ss.n_states
        self.layout = element_layout(self.plan, method.nodes, method.elements)
        lam, V = np.linalg.eig(ss.A)
        self.lam, self.V = lam, V
        self.Bz = np.linalg.solve(V, ss.B[:, :k])   # (ns, k) complex
        self.Sz = ss.S[:2] @ V                       # (2, ns) complex
        self.Vi = np.linalg.inv(V)
        M, R = len(self.layout.alpha), len(self.layout.prev)
        self.M, self.R = M, R
        self.n_red = self.ns + 2 * R
        self._speed: dict[float, tuple[np.ndarray, ...]] = {}
        self.critical_evaluations = 0

    @property
    def period_s_per_rpm(self) -> float:
        return self.plan.period_rad / (2 * math.pi) * 60.0

    def period_s(self, rpm) -> np.ndarray:
        return self.period_s_per_rpm / np.asarray(rpm, dtype=float)

    # ----- per-speed matrices ------------------------------------------------------------------
    def speed_matrices(self, rpm: float) -> tuple[np.ndarray, ...]:
        """``E, C, QH, QKp, PH, PKp`` at one speed (depth-independent, cached)."""
        key = float(rpm)
        if key not in self._speed:
            if len(self._speed) > 4096:
                self._speed.clear()
            self._speed[key] = self._compute_speed(key)
        return self._speed[key]

    def propagators(self, rpm: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``E`` (ns, ns), ``C`` (2M, ns), ``Q`` (2M, kM), ``P`` (ns, kM) at one speed (real)."""
        lay, n, lam = self.layout, self.method.nodes, self.lam
        om = float(rpm) * 2 * math.pi / 60.0
        T = self.plan.period_rad / om
        t = lay.alpha / om
        a, b = lay.bounds[:, 0] / om, lay.bounds[:, 1] / om
        M, ns, k = self.M, self.ns, self.k
        full = np.zeros((len(a), ns, n), complex)
        part = np.zeros((len(a), ns, n, n), complex)
        for h in np.unique(np.round(b - a, 15)):
            sel = np.flatnonzero(np.abs((b - a) - h) <= 1e-12 * max(h, 1e-300))
            full[sel], part[sel] = kernel_weights(lam, float(h), n)
        e, loc = lay.elem, np.arange(M) % n
        lag = np.maximum(t[:, None] - b[e][None, :], 0.0)  # (M_i, M_j): only earlier elements are used
        qz = np.exp(lam[None, None, :] * lag[..., None]) * full[e, :, loc][None]
        qz = np.where((e[None, :] < e[:, None])[..., None], qz, 0.0)  # (M_i, M_j, ns)
        same = e[None, :] == e[:, None]
        ii, jj = np.nonzero(same)
        qz[ii, jj] = part[e[ii], :, loc[ii], loc[jj]]
        Q = np.einsum("ak,ijk,kb->iajb", self.Sz, qz, self.Bz).real.reshape(2 * M, k * M)
        pz = np.exp(lam[None, :] * (T - b[e])[:, None]) * full[e, :, loc]  # (M, ns)
        P = np.einsum("sk,jk,kb->sjb", self.V, pz, self.Bz).real.reshape(ns, k * M)
        C = np.einsum("ak,ik,kn->ian", self.Sz, np.exp(np.outer(t, lam)), self.Vi).real.reshape(2 * M, ns)
        E = (self.V * np.exp(lam * T)[None]) @ self.Vi
        return E.real, C, Q, P

    def _compute_speed(self, rpm: float) -> tuple[np.ndarray, ...]:
        E, C, Q, P = self.propagators(rpm)
        lay, M, R, k = self.layout, self.M, self.R, self.k
        H = lay.H.reshape(k * M, 2 * M)
        Kp = lay.Kp.reshape(k * M, 2 * R)
        return E, C, Q @ H, Q @ Kp, P @ H, P @ Kp

    # ----- monodromy ---------------------------------------------------------------------------
    def monodromy(self, rpm, depth_m) -> np.ndarray:
        """Monodromy matrices (B, ns + 2R, ns + 2R) on ``(x0, Y_prev)`` at paired speeds/depths (B,)."""
        rpm = np.asarray(rpm, dtype=float).reshape(-1)
        depth = np.asarray(depth_m, dtype=float).reshape(-1)
        mats = [self.speed_matrices(r) for r in rpm]
        E, C, QH, QKp, PH, PKp = (np.stack([m_[i] for m_ in mats]) for i in range(6))
        a = depth[:, None, None]
        G = np.eye(2 * self.M)[None] - a * QH
        Ysol = np.linalg.solve(G, np.concatenate([C, -a * QKp], axis=2))  # (B, 2M, ns + 2R)
        top = a * (PH @ Ysol)
        top[:, :, :self.ns] += E
        top[:, :, self.ns:] -= a * PKp
        rows = (2 * self.layout.prev[:, None] + np.arange(2)[None]).reshape(-1)
        return np.concatenate([top, Ysol[:, rows]], axis=1)

    def spectra(self, rpm, depth_m) -> np.ndarray:
        """All Floquet multipliers (B, ns + 2R) complex at paired speeds/depths (B,)."""
        rpm = np.asarray(rpm, dtype=float).reshape(-1)
        if len(rpm) == 0:
            return np.zeros((0, self.n_red), complex)
        return np.linalg.eigvals(self.monodromy(rpm, depth_m))

    def multipliers(self, rpm, depth_m):
        """Spectral radius (B,) and critical multiplier (B,) complex."""
        ev = self.spectra(rpm, depth_m)
        mu = ev[np.arange(len(ev)), np.argmax(np.abs(ev), axis=1)]
        return np.abs(mu), mu

    def critical(self, rpm, depth_m):
        """Critical multiplier's modulus, the multiplier and the chatter frequency (Hz), each (B,).

        The frequency branch is the one nearest the damped frequency of the structural pole that
        dominates the tool motion of the critical solution's state ``x0`` (as in the SDM)."""
        rpm = np.asarray(rpm, dtype=float).reshape(-1)
        self.critical_evaluations += len(rpm)
        if len(rpm) == 0:
            return np.zeros(0), np.zeros(0, complex), np.zeros(0)
        U = self.monodromy(rpm, depth_m)
        ev = np.linalg.eigvals(U)
        mu = ev[np.arange(len(ev)), np.argmax(np.abs(ev), axis=1)]
        z = eigenvector_of(U, mu)
        wfreq, wts = self.ss.mode_weights(z[:, :self.ns])
        dom = wfreq[np.argmax(wts, axis=1)]
        return np.abs(mu), mu, chatter_branch(mu, self.period_s(rpm), dom)
