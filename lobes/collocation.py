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
add zero multipliers). Helical tool: ``W`` is integrated analytically along the depth
(:func:`node_directional`); it is continuous with kinks where the edge's ends enter and leave
the cut. The elements cover the bottom edge's cutting interval widened by the lag of the largest
depth; the kinks at the top edge's entry and exit move with the depth and fall inside elements
(there the convergence in the nodes is algebraic, not spectral), and ``H``, ``Kp`` are
assembled per depth (``Q H`` etc. per pair).
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
from .sdm import Search, chatter_branch, eigenvector_of, phi_exps
from .structure import StateSpace

__all__ = ["Collocation", "CollocationEngine", "kernel_weights", "element_layout", "node_directional"]


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
        # at most 10 (12 with check_nodes): the kernel weights go through the monomial basis on
        # [0, 1], accurate to ~1e-9 at 10 nodes and ~1e-7 at 12 (tests/test_collocation.py)
        integer("Collocation nodes (per element)", self.nodes, minimum=1, maximum=10, error=LobeError)
        integer("Collocation elements (per principal period)", self.elements, minimum=1, error=LobeError)
        integer("Collocation check_nodes", self.check_nodes, minimum=0, maximum=2, error=LobeError)
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
    Gauss-Legendre nodes on [0, 1], ``l_j`` their Lagrange basis). Exact: with ``l_j(s) = sum_p
    c_jp s^p``, ``int_0^(h u) e^(lam (h u - s)) (s / h)^p ds = h u^(p+1) p! phi_(p+1)(lam h u)``,
    and ``phi_1 .. phi_n`` of ``w`` are the first row of the exponential of the
    ``(n + 1) x (n + 1)`` matrix with ``w`` in the corner and ones on the superdiagonal (Sidje
    1998), by :func:`lobes.sdm.phi_exps` (batched scaling and squaring) of its real ``2 (n + 1)``
    form. ``lam`` (K,) complex, 1/s; ``h`` s.

    Returns ``full`` (K, n) and ``part`` (K, n, n), complex, s.
    """
    lam = np.asarray(lam, dtype=complex)
    up = np.flatnonzero(np.imag(lam) >= 0)
    down = np.flatnonzero(np.imag(lam) < 0)
    if len(down) and len(up) < len(lam):  # conjugate poles: conjugate weights
        pair = up[np.argmin(np.abs(lam[down, None].conj() - lam[None, up]), axis=1)]
        if np.allclose(lam[pair], lam[down].conj(), rtol=1e-12, atol=0.0):
            f, p = kernel_weights(lam[up], h, n)
            full = np.empty((len(lam), n), complex)
            part = np.empty((len(lam), n, n), complex)
            full[up], part[up] = f, p
            where = np.searchsorted(up, pair)
            full[down], part[down] = f[where].conj(), p[where].conj()
            return full, part
    u, _ = _gauss01(n)
    ends = np.concatenate([u, [1.0]])                  # (n + 1,) upper limits (fractions of the element)
    w = lam[:, None] * h * ends[None, :]               # (K, n + 1)
    Z = np.zeros(w.shape + (n + 1, n + 1), complex)
    Z[..., 0, 0] = w
    Z[..., np.arange(n), np.arange(1, n + 1)] = 1.0
    phi = _expm_complex(Z.reshape(-1, n + 1, n + 1)).reshape(Z.shape)[..., 0, 1:]  # (K, n + 1, n): phi_1..phi_n
    p = np.arange(n)
    fact = np.array([math.factorial(int(q)) for q in p], dtype=float)
    mono = h * ends[None, :, None] ** (p + 1) * fact * phi  # (K, n + 1, n): integrals of (s/h)^p
    coef = np.linalg.inv(np.vander(u, n, increasing=True))  # (p, j): l_j(s) = sum_p coef[p, j] s^p
    val = mono @ coef                                  # (K, n + 1, n)
    return val[:, n], val[:, :n]


def _expm_complex(Z: np.ndarray) -> np.ndarray:
    """``expm`` of complex matrices (P, n, n) through their real form ``[[Re, -Im], [Im, Re]]``."""
    n = Z.shape[-1]
    re, im = np.real(Z), np.imag(Z)
    R = np.block([[re, -im], [im, re]])
    E = phi_exps(R, np.zeros((1, 2 * n, 0)))[0]
    return E[:, :n, :n] + 1j * E[:, n:, :n]


@dataclass(frozen=True, eq=False)
class Layout:
    """Angular layout of the elements and nodes over one principal period (speed-independent).

    ``bounds`` (E, 2) element ends as spindle angles in ``[0, period]``, rad; ``alpha`` (M,) node
    angles; ``elem`` (M,) element of each node; ``cols``, ``weights`` (G, M, n): the delayed
    displacement of group ``g`` at node ``i`` is ``sum_l weights[g, i, l] Z[cols[g, i, l]]`` with
    ``Z = [Y, Y_prev]`` (2M nodes); ``prev`` (R,): the previous period's nodes read by some delayed
    value (indices into the nodes).
    """

    bounds: np.ndarray
    alpha: np.ndarray
    elem: np.ndarray
    cols: np.ndarray
    weights: np.ndarray
    prev: np.ndarray

    def force_matrices(self, Wg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``H`` (B, kM, 2M) and ``Kp`` (B, kM, 2R) of ``F = H Y - Kp Y_prev`` from the directional
        matrices at the nodes ``Wg`` (B, M, G, k, 2), N/m (depth included)."""
        B, M, G, k, _ = Wg.shape
        D = np.zeros((B, M, k, 2 * M, 2))
        i = np.arange(M)
        D[:, i, :, i, :] = -Wg.sum(axis=2).transpose(1, 0, 2, 3)
        for g in range(G):
            for col, w in zip(self.cols[g].T, self.weights[g].T):  # one interpolation node at a time
                D[:, i, :, col, :] += (w[:, None, None, None] * Wg[:, :, g].transpose(1, 0, 2, 3))
        H = -D[:, :, :, :M].reshape(B, M * k, 2 * M)
        Kp = D[:, :, :, M + self.prev].reshape(B, M * k, 2 * len(self.prev))
        return H, Kp


def element_layout(plan: DirectionalPlan, n: int, elements: int, lag_rad: float = 0.0) -> Layout:
    """Elements on the cutting intervals (the bottom edge's, widened by the helix lag ``lag_rad`` of
    the largest depth), their Gauss-Legendre nodes and the interpolation of the delayed values."""
    P = plan.period_rad
    cuts = _cutting_intervals(plan, lag_rad)
    edges = sorted({0.0, P} | {e for iv in cuts for e in iv} | set(_kink_edges(plan, lag_rad)))
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
    M = len(alpha)
    cols = np.zeros((plan.n_groups, M, n), int)
    weights = np.zeros((plan.n_groups, M, n))
    for g, delay in enumerate(plan.group_delay_rad):
        beta = alpha - delay
        back = np.floor(beta / P + 1e-12).astype(int)  # periods back: 0 or -1
        if np.any(back < -1):
            raise LobeError("a regenerative delay longer than the principal period is not supported by Collocation")
        beta = beta - back * P
        e = np.searchsorted(bounds[:, 1], beta, side="left").clip(0, len(bounds) - 1)
        weights[g] = lagrange(u, (beta - bounds[e, 0]) / (bounds[e, 1] - bounds[e, 0]))
        cols[g] = e[:, None] * n + np.arange(n)[None] + np.where(back < 0, M, 0)[:, None]
    prev = np.unique(cols[cols >= M]) - M
    return Layout(bounds=bounds, alpha=alpha, elem=np.repeat(np.arange(len(bounds)), n), cols=cols,
                  weights=weights, prev=prev)


def _kink_edges(plan: DirectionalPlan, lag_rad: float) -> list[float]:
    """Element edges at the helix kinks: the bottom edge's entry and exit (lag 0), and around the
    top edge's, ``lag`` later with ``lag`` in ``(lag_rad / 2, lag_rad]`` for the depths of a cap
    (:data:`_CAPS`): edges at both ends of that range keep each such kink in a short element."""
    if lag_rad <= 0:
        return []
    P, out = plan.period_rad, []
    for th in plan.tooth_angle_rad:
        for turn in range(-2, 3):
            for phi in (plan.phi_st, plan.phi_ex):
                for lag in (0.0, lag_rad / 2, lag_rad):
                    e = phi + lag - th + 2 * math.pi * turn
                    if 0 < e < P:
                        out.append(e)
    return out


def _cutting_intervals(plan: DirectionalPlan, lag_rad: float) -> list[tuple[float, float]]:
    """Angular intervals of ``[0, period]`` in which some tooth may cut (one per tooth and turn)."""
    P, out = plan.period_rad, []
    for th in plan.tooth_angle_rad:
        for turn in range(-2, 3):
            lo = plan.phi_st - th + 2 * math.pi * turn
            hi = plan.phi_ex + lag_rad - th + 2 * math.pi * turn
            a, b = max(lo, 0.0), min(hi, P)
            if b > a:
                out.append((a, b))
    return out


def node_directional(plan: DirectionalPlan, alpha: np.ndarray, depth_m: np.ndarray, points: int = 8) -> np.ndarray:
    """Directional matrices of each delay group at the node angles ``alpha`` (M,): (B, M, G, k, 2), N/m.

    Straight tool: ``a g(phi) D(phi)`` summed over the group's teeth. Helical tool (lag
    ``psi(z) = kappa z``): the integral along the depth ``int_0^a g(phi - kappa z) D(phi - kappa z)
    dz = (1 / kappa) int_(phi - kappa a)^phi g D``, by ``points`` Gauss-Legendre points on the
    engaged part (a smooth trigonometric integrand: exact to rounding; continuous in ``phi``, with
    kinks where an end of the edge enters or leaves the cut). ``depth_m`` (B,), m.
    """
    depth = np.asarray(depth_m, dtype=float).reshape(-1)
    k = plan.k_force
    out = np.zeros((len(depth), len(alpha), plan.n_groups, k, 2))
    kappa = float(plan.tool.lag_rad(1.0))
    x, w = _gauss01(points)
    for th, g in zip(plan.tooth_angle_rad, plan.tooth_group):
        phi = alpha + th
        if kappa == 0:
            D = directional_matrix(phi, plan.law)[..., :k, :] * in_cut(phi, plan.phi_st, plan.phi_ex)[:, None, None]
            out[:, :, g] += depth[:, None, None, None] * D[None]
            continue
        hi = np.mod(phi, 2 * math.pi)[None, :] + np.zeros((len(depth), 1))  # (B, M)
        lo = hi - kappa * depth[:, None]
        for shift in (-2 * math.pi, 0.0, 2 * math.pi):
            a = np.maximum(lo, plan.phi_st + shift)
            ln = np.minimum(hi, plan.phi_ex + shift) - a
            sel = ln > 0
            if sel.any():
                pts = a[sel][:, None] + x[None] * ln[sel][:, None]
                D = directional_matrix(pts, plan.law)[..., :k, :]
                out[sel, g] += np.einsum("nqij,q->nij", D, w) * (ln[sel] / kappa)[:, None, None]
    return out


#: Depth caps of a helical tool's layouts (depth_max / 2^j, j < _CAPS).
_CAPS = 6


class CollocationEngine:
    """Monodromy matrices of one problem (all speeds, all depths) for one collocation."""

    def __init__(self, problem: LobeProblem, method: Collocation, depth_max_m: float = 0.01, caps: bool = True):
        self.problem, self.method = problem, method
        self._subs: dict[int, CollocationEngine] = {}
        ss = problem.structure.state_space()
        ss.check_stable()
        self.ss: StateSpace = ss
        law = problem.law
        k = 3 if (law.kac_pa != 0.0 and np.any(ss.B[:, 2])) else 2
        self.plan = DirectionalPlan.build(problem.tool, problem.cut, law, m=1 << 20, quadrature=1, slices=1,
                                          k_force=k)
        self.k, self.ns = k, ss.n_states
        self.helix = problem.tool.helix_rad > 0
        self.depth_max_m = float(depth_max_m)
        # helix: the cutting intervals widen with the depth; pairs are evaluated on the layout of
        # the smallest depth cap depth_max / 2^j (j < _CAPS) above their depth (smaller monodromy)
        self.capped = caps and self.helix
        lag = float(problem.tool.lag_rad(self.depth_max_m))
        self.layout = element_layout(self.plan, method.nodes, method.elements, lag)
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

    def period_s(self, rpm) -> np.ndarray:
        """The principal period at spindle speeds ``rpm`` (array, rpm), s (:meth:`DirectionalPlan.period_s`)."""
        return self.plan.period_s(rpm)

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
        key = np.round((b - a) / (b - a).max(), 12)  # elements of equal length share their weights
        for kv in np.unique(key):
            sel = np.flatnonzero(key == kv)
            full[sel], part[sel] = kernel_weights(lam, float((b - a)[sel[0]]), n)
        e, loc = lay.elem, np.arange(M) % n
        lag = np.maximum(t[:, None] - b[e][None, :], 0.0)  # (M_i, M_j): only earlier elements are used
        qz = np.exp(lam[None, None, :] * lag[..., None]) * full[e, :, loc][None]
        qz = np.where((e[None, :] < e[:, None])[..., None], qz, 0.0)  # (M_i, M_j, ns)
        same = e[None, :] == e[:, None]
        ii, jj = np.nonzero(same)
        qz[ii, jj] = part[e[ii], :, loc[ii], loc[jj]]
        # Q[i, :, j, :] = Sz diag(qz[i, j]) Bz, as one batched product (BLAS)
        Q = (self.Sz @ (qz[..., None] * self.Bz)).real.transpose(0, 2, 1, 3).reshape(2 * M, k * M)
        pz = np.exp(lam[None, :] * (T - b[e])[:, None]) * full[e, :, loc]  # (M, ns)
        P = (self.V @ (pz[..., None] * self.Bz)).real.transpose(1, 0, 2).reshape(ns, k * M)
        C = ((self.Sz[None] * np.exp(np.outer(t, lam))[:, None, :]) @ self.Vi).real.reshape(2 * M, ns)
        E = (self.V * np.exp(lam * T)[None]) @ self.Vi
        return E.real, C, Q, P

    def _compute_speed(self, rpm: float) -> tuple[np.ndarray, ...]:
        E, C, Q, P = self.propagators(rpm)
        if self.helix:  # the force matrices depend on the depth: products per pair
            return E, C, Q, P
        H, Kp = self.layout.force_matrices(node_directional(self.plan, self.layout.alpha, np.ones(1)))
        return E, C, Q @ H[0], Q @ Kp[0], P @ H[0], P @ Kp[0]

    def _products(self, rpm: np.ndarray, depth: np.ndarray):
        """``E, C, a QH, a QKp, a PH, a PKp`` stacked over the pairs (depth ``a`` included)."""
        mats = [self.speed_matrices(r) for r in rpm]
        stack = lambda i: np.stack([m_[i] for m_ in mats])
        if not self.helix:
            a = depth[:, None, None]
            return (stack(0), stack(1)) + tuple(a * stack(i) for i in range(2, 6))
        H, Kp = self.layout.force_matrices(node_directional(self.plan, self.layout.alpha, depth))
        Q, P = stack(2), stack(3)
        return stack(0), stack(1), Q @ H, Q @ Kp, P @ H, P @ Kp

    # ----- monodromy ---------------------------------------------------------------------------
    def monodromy(self, rpm, depth_m) -> np.ndarray:
        """Monodromy matrices (B, ns + 2R, ns + 2R) on ``(x0, Y_prev)`` at paired speeds/depths (B,)."""
        rpm = np.asarray(rpm, dtype=float).reshape(-1)
        depth = np.asarray(depth_m, dtype=float).reshape(-1)
        if len(depth) and float(depth.max()) > self.depth_max_m * (1 + 1e-12):
            raise LobeError(f"depth {float(depth.max())} m beyond the engine's depth_max_m {self.depth_max_m} m")
        E, C, QH, QKp, PH, PKp = self._products(rpm, depth)
        G = np.eye(2 * self.M)[None] - QH
        Ysol = np.linalg.solve(G, np.concatenate([C, -QKp], axis=2))  # (B, 2M, ns + 2R)
        top = PH @ Ysol
        top[:, :, :self.ns] += E
        top[:, :, self.ns:] -= PKp
        rows = (2 * self.layout.prev[:, None] + np.arange(2)[None]).reshape(-1)
        return np.concatenate([top, Ysol[:, rows]], axis=1)

    def _groups(self, depth: np.ndarray) -> list[tuple["CollocationEngine", np.ndarray]]:
        """(engine, index array) per depth cap used by the pairs of depths ``depth`` (B,)."""
        if not self.capped:
            return [(self, np.arange(len(depth)))]
        with np.errstate(divide="ignore"):
            j = np.floor(np.log2(self.depth_max_m / np.maximum(depth, 1e-300)) - 1e-12)
        j = np.clip(j, 0, _CAPS - 1).astype(int)
        out = []
        for jj in np.unique(j):
            if jj == 0:
                out.append((self, np.flatnonzero(j == 0)))
                continue
            if int(jj) not in self._subs:
                self._subs[int(jj)] = CollocationEngine(self.problem, self.method, self.depth_max_m * 2.0 ** -int(jj),
                                                        caps=False)
            out.append((self._subs[int(jj)], np.flatnonzero(j == jj)))
        return out

    def spectra(self, rpm, depth_m) -> np.ndarray:
        """All Floquet multipliers (B, N) complex at paired speeds/depths (B,); pairs on a smaller
        depth cap's layout are padded with zero multipliers to the widest."""
        rpm = np.asarray(rpm, dtype=float).reshape(-1)
        depth = np.asarray(depth_m, dtype=float).reshape(-1)
        if len(rpm) == 0:
            return np.zeros((0, self.n_red), complex)
        parts = [(j, np.linalg.eigvals(e.monodromy(rpm[j], depth[j]))) for e, j in self._groups(depth)]
        out = np.zeros((len(rpm), max(ev.shape[1] for _, ev in parts)), complex)
        for j, ev in parts:
            out[j, :ev.shape[1]] = ev
        return out

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
        depth = np.asarray(depth_m, dtype=float).reshape(-1)
        self.critical_evaluations += len(rpm)
        rho, mu, freq = np.zeros(len(rpm)), np.zeros(len(rpm), complex), np.zeros(len(rpm))
        for e, j in self._groups(depth) if len(rpm) else ():
            rho[j], mu[j], freq[j] = e._critical(rpm[j], depth[j])
        return rho, mu, freq

    def _critical(self, rpm: np.ndarray, depth: np.ndarray):
        U = self.monodromy(rpm, depth)
        ev = np.linalg.eigvals(U)
        mu = ev[np.arange(len(ev)), np.argmax(np.abs(ev), axis=1)]
        z = eigenvector_of(U, mu)
        wfreq, wts = self.ss.mode_weights(z[:, :self.ns])
        dom = wfreq[np.argmax(wts, axis=1)]
        return np.abs(mu), mu, chatter_branch(mu, self.period_s(rpm), dom)
