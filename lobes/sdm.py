"""First-order semi-discretization (Insperger & Stepan 2004, Int. J. Numer. Meth. Eng. 61:117-141).

The linearized milling dynamics (cut frame, see :mod:`lobes.directional`)::

    dy/dt = (A + B W(t) S2) y(t) - B sum_g W_g(t) S2 y(t - tau_g)

are discretized over the principal period ``T`` in ``m`` steps ``dt = T / m``. On step ``i`` the
periodic coefficient is replaced by its average ``Wbar_i`` (:meth:`DirectionalPlan.wbar`),
the delayed displacement ``r(t - tau_g)`` by the straight line through its values at the step ends,
each obtained by linear interpolation between the mesh nodes (``tau_g = (r_g + f_g) dt``; for
``f_g = 0`` this is exactly the first-order SDM), and the resulting linear ODE is solved exactly::

    y_{i+1} = Phi_i y_i + Gamma0_i u_0 + Gamma1_i u_1,     u = -sum_g Wbar_{i,g} r_delayed

with ``[Phi, H0, H1] = expm([[Abar dt, B dt, 0], [0, 0, I], [0, 0, 0]])`` (Van Loan),
``Gamma0 = H0 - H1``, ``Gamma1 = H1``. The monodromy matrix maps ``y_0`` and the delayed tool
displacements at the mesh nodes to the same quantities one period later; its eigenvalues are the
Floquet multipliers.

Fast path (same multipliers, not an approximation of them): only the tool displacement (2
numbers per node) is delayed, not the whole state; history nodes that no engaged step ever reads
are dropped (they only add zero eigenvalues); consecutive steps with no tooth engaged are merged
into one exact ``expm(A L dt)``; everything is batched over (speed, depth) pairs. The step
exponentials are evaluated by :func:`phi_exps` (``exp``, ``phi1``, ``phi2`` of ``Abar dt`` by a
scaled Taylor sum and doubling: the same blocks as the Van Loan ``expm`` to ~1e-14, several times
cheaper in batches).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from robolobes.core.validate import integer

from ._errors import LobeError
from .directional import DirectionalPlan, PeriodChoice, QuadratureRule
from .problem import LobeProblem
from .structure import StateSpace

__all__ = ["SemiDiscretization", "Bifurcation", "Scheme", "classify_multiplier"]

Bifurcation = Literal["hopf", "flip", "fold", "none"]
Scheme = Literal["sdm", "free-exact"]
Search = Literal["fast", "fast-wide", "plain"]
Batching = Literal["grouped", "single"]
Eigen = Literal["dense", "arnoldi"]


@dataclass(frozen=True)
class SemiDiscretization:
    """First-order semi-discretization method (multi-DOF, multiple delays).

    Parameters
    ----------
    m : int
        Steps per principal period (tooth period for uniform pitch without skipped teeth, else
        one revolution), >= 2. Error of the stability limit ~ 1/m^2.
    quadrature : int
        Quadrature points per step for the step average of the periodic coefficient, >= 1.
    rule : {"gauss", "midpoint"}
        "gauss": Gauss-Legendre points on the engaged part of each step (the integrand is a
        trigonometric polynomial of degree 2 there, so 8 points give the exact average to
        rounding for steps up to 90 deg -- 2e-10 at 180 deg; the limit then converges cleanly
        as 1/m^2). "midpoint": midpoints of the whole step with the screen function sampled, as
        in the classic code (adds an O(1/(m q)) error at the entry and exit steps).
    axial_slices : int or None
        Slices along the depth for a helical tool (each with its own lag angle). None: 1 without
        helix, 16 with helix.
    angle_tol_rad : float
        A critical multiplier with ``|arg mu| <= angle_tol_rad`` is a fold, with
        ``|arg mu| >= pi - angle_tol_rad`` a flip, otherwise a Hopf (secondary Hopf) bifurcation.
    period : {"auto", "revolution"}
        "revolution" forces one spindle revolution as the principal period (for checks).
    scheme : {"sdm", "free-exact"}
        "sdm": the first-order SDM above (step-averaged periodic coefficient inside the matrix
        exponential: ``m`` exponentials per monodromy). "free-exact": the free structure is
        integrated exactly (one exponential per speed, shared by every depth) and the whole
        cutting force ``Wbar_i (r(t) - r(t - tau))`` is held linear over the step, the current
        ``r_{i+1}`` being solved for implicitly (a 2 x 2 solve per step) -- a variant of the
        full-discretization method (Ding et al. 2010, Int. J. Mach. Tools Manuf. 50:502-509).
        Also second order in ``dt``, several times cheaper for large structures; the two schemes
        converge to the same limit, which is a check of both.
    richardson : bool
        In :func:`lobes.solve`, also solve with ``2 m`` and return the Richardson extrapolation
        ``b_2m + (b_2m - b_m) / 3`` with the error estimate ``|b_2m - b_m| / 3``
        (:func:`robolobes.core.numerics.richardson`, the one definition), flagged by the rule of
        :mod:`lobes.refine` (``RefinedSDM`` with ``m_max = 2 m``).
    prescan : bool or None
        In :func:`lobes.solve` with ``scheme="sdm"`` (or "free-exact" with ``prescan_m < m``), make
        the coarse depth scan with the cheap "free-exact" scheme (at ``prescan_m``) and verify each
        bracket with the SDM (where the check fails, the SDM
        walks along the depth grid from the failed end to its own sign change). The limits are
        the SDM's; only the bracketing is accelerated. None (default): only for structures with
        at least 12 states, where the SDM's per-step exponentials dominate.
    prescan_m : int or None
        Steps per principal period of that prescan (None: ``m``). A coarser prescan is cheaper
        (smaller monodromy); its brackets are still verified by the SDM at ``m``, so the limits
        stay the SDM's (a failed bracket is repaired by the SDM).
    search : {"fast", "fast-wide", "plain"}
        Depth search of :func:`lobes.solve`. "fast" (default): regula falsi points closed by a
        straddling pair (``lobes.solver._refine``) and, in a refinement, each finer level started
        from a verified bracket around the coarser level's limit: +-4 % at every 5th speed, and at
        the others a bracket sized from the level-to-level shifts of those neighbours (+-0.5 % to
        +-4 %; where it does not hold, +-4 %), closed at once by a straddling pair when it is at
        most 2.5 % wide; this for structures of 12 states or more (robots), +-4 % at every speed
        below. "fast-wide": the same with +-4 % at every speed (the earlier "fast").
        "plain": the earlier search (Illinois until the bracket is ``rtol`` wide; finer levels
        from the coarse depth grid's bracket), kept as the reference of ``bench/bench_lobes.py``.
        All return a limit bracketed by SDM evaluations of both signs to ``rtol``, so they agree
        to ``rtol``.
    batching : {"grouped", "single"}
        How :meth:`SDMEngine.spectra` and :meth:`SDMEngine.critical` evaluate a batch of (speed,
        depth) pairs. "grouped" (default): the pairs are grouped by their set of engaged steps
        (for a helical tool it grows with the depth, and with it the reduced monodromy) and each
        group is evaluated with its own, smaller layout, in cache-sized sub-batches. The
        multipliers are the same to rounding; only zero multipliers of unread history nodes are
        left out (the spectra are padded with zeros to a common width). "single": one layout, that
        of the batch's largest depth, for every pair (the earlier code), kept as the reference of
        ``bench/bench_lobes.py`` and ``tests/test_sdm_batching.py``.
    eigen : {"dense", "arnoldi"}
        Eigenvalues of the reduced monodromies. "dense" (default): all of them by LAPACK
        (``numpy.linalg.eigvals``). "arnoldi" (opt-in): for monodromies of at least
        :data:`_ARNOLDI_MIN_N` rows, the :data:`_ARNOLDI_K` largest in modulus by ARPACK
        (:func:`arnoldi_eigvals`; the other multipliers are returned as zeros), smaller ones dense.
        The spectral radius is the same to rounding (``bench/bench_sdm_krylov.py``: within 1.5e-14
        relative on the TX200, same verdicts). ARPACK pays only for large monodromies: 2.2 times
        less CPU than LAPACK at 116-166 rows, none below; the steel TX200 diagram 1.12 times less
        CPU, the same spectra and limits to 5.4e-14. A depth search that follows a multiplier
        which is not among the largest ones interpolates on another one (the same limits to
        ``rtol``, more spectra).
    """

    m: int = 40
    quadrature: int = 8
    rule: QuadratureRule = "gauss"
    axial_slices: int | None = None
    angle_tol_rad: float = 1e-6
    period: PeriodChoice = "auto"
    scheme: Scheme = "sdm"
    richardson: bool = False
    prescan: bool | None = None
    prescan_m: int | None = None
    search: Search = "fast"
    batching: Batching = "grouped"
    eigen: Eigen = "dense"

    def __post_init__(self) -> None:
        integer("SemiDiscretization m (steps per principal period)", self.m, minimum=2, error=LobeError)
        integer("SemiDiscretization quadrature (points per step)", self.quadrature, minimum=1, error=LobeError)
        if self.prescan_m is not None:
            integer("SemiDiscretization prescan_m (prescan steps per period)", self.prescan_m, minimum=2, error=LobeError)
        if self.axial_slices is not None:
            integer("SemiDiscretization axial_slices", self.axial_slices, minimum=1, error=LobeError)
        a = self.angle_tol_rad
        if not (isinstance(a, (int, float)) and math.isfinite(a) and 0 <= a < math.pi / 2):
            raise LobeError(f"angle_tol_rad must be in [0, pi/2), got {a!r}")
        if self.period not in ("auto", "revolution"):
            raise LobeError(f"period must be 'auto' or 'revolution', got {self.period!r}")
        if self.scheme not in ("sdm", "free-exact"):
            raise LobeError(f"scheme must be 'sdm' or 'free-exact', got {self.scheme!r}")
        if self.search not in ("fast", "fast-wide", "plain"):
            raise LobeError(f"search must be 'fast', 'fast-wide' or 'plain', got {self.search!r}")
        if self.batching not in ("grouped", "single"):
            raise LobeError(f"batching must be 'grouped' or 'single', got {self.batching!r}")
        if self.eigen not in ("dense", "arnoldi"):
            raise LobeError(f"eigen must be 'dense' or 'arnoldi', got {self.eigen!r}")
        if self.rule not in ("gauss", "midpoint"):
            raise LobeError(f"rule must be 'gauss' or 'midpoint', got {self.rule!r}")

    @property
    def name(self) -> str:
        return "sdm"


def classify_multiplier(mu: complex | np.ndarray, angle_tol_rad: float = 1e-6) -> np.ndarray:
    """Bifurcation type of critical multipliers: |arg| <= tol -> fold, >= pi - tol -> flip, else Hopf.

    Returns an array of str with the shape of ``mu`` ("none" where ``mu`` is not finite).
    """
    mu = np.asarray(mu, dtype=complex)
    a = np.abs(np.angle(mu))
    out = np.where(a <= angle_tol_rad, "fold", np.where(a >= math.pi - angle_tol_rad, "flip", "hopf"))
    out = np.where(np.isfinite(mu), out, "none")
    return out.astype("<U4")


@dataclass(frozen=True)
class _Structure:
    cand: np.ndarray
    neg_nodes: list
    store: set
    segments: list
    free_lengths: list
    n_red: int


class SDMEngine:
    """Monodromy matrices of one problem (all speeds, all depths) for one semi-discretization."""

    def __init__(self, problem: LobeProblem, method: SemiDiscretization, depth_max_m: float,
                 surface_tilt: bool = False, slice_edge_rad: np.ndarray | None = None,
                 delay_time: bool = False):
        """``surface_tilt``: the dynamic chip along the regenerated surface's normal, not the ray
        (:mod:`lobes.chip_direction`; default False, the linear model of the lobes).
        ``slice_edge_rad``: the block-edge angle per axial slice (:class:`DirectionalPlan`; default
        None, the uniform engagement). ``delay_time``: the delayed instant of
        :mod:`lobes.chip_direction` (only :meth:`monodromy_dense` carries it; the fast path refuses it)."""
        self.problem = problem
        self.method = method
        ss = problem.structure.state_space()
        ss.check_stable()
        self.ss: StateSpace = ss
        law = problem.law
        k = 3 if (law.kac_pa != 0.0 and np.any(ss.B[:, 2])) else 2
        slices = method.axial_slices or (16 if problem.tool.helix_rad > 0 else 1)
        if problem.tool.helix_rad == 0:
            slices = 1
        self.plan = DirectionalPlan.build(problem.tool, problem.cut, law, m=method.m, quadrature=method.quadrature,
                                      slices=slices, period=method.period, k_force=k, rule=method.rule,
                                      surface_tilt=surface_tilt, slice_edge_rad=slice_edge_rad,
                                      delay_time=delay_time)
        self.k = k
        self.ns = ss.n_states
        self.A = ss.A
        self.Bk = np.ascontiguousarray(ss.B[:, :k])
        self.S2 = np.ascontiguousarray(ss.S[:2])
        self.depth_max_m = float(depth_max_m)
        self._build_structure(self.plan.candidate_steps(self.depth_max_m))
        self._free_cache: dict[tuple[float, int | str], tuple[np.ndarray, ...]] = {}  # (dt, key) -> propagators
        self._kept: dict[tuple[float, float], tuple[float, complex, float]] = {}  # (rpm, depth) -> critical
        self.critical_evaluations = 0

    # ----- structure of the reduced recurrence --------------------------------------------------
    def _build_structure(self, cand: np.ndarray) -> None:
        st = self._structure(cand)
        self.cand, self.n_red = st.cand, st.n_red
        self._structs: dict = {tuple(st.cand.tolist()): st}

    def _structure(self, cand: np.ndarray) -> "_Structure":
        """Kept mesh nodes, segments and reduced-state layout for a set of engaged steps."""
        plan, m = self.plan, self.plan.m
        cand = np.asarray(cand, dtype=int)
        cset = set(cand.tolist())
        needed: set[int] = set()
        for i in cand:
            for r, f in zip(plan.group_r, plan.group_f):
                needed.update({i - r, i - r + 1})
                if f > 0:
                    needed.add(i - r - 1)
        neg_nodes = sorted(k for k in needed if k < 0)
        store = {k for k in needed if k >= 0} | {k + m for k in neg_nodes}
        bounds = sorted({0, m} | cset | {i + 1 for i in cset} | {k % m for k in needed})
        cidx = {s_: j for j, s_ in enumerate(cand.tolist())}
        segments = []  # (start, end, index into cand or -1 for a merged free span)
        for a, b in zip(bounds[:-1], bounds[1:]):
            segments.append((a, b, cidx[a] if (b == a + 1 and a in cset) else -1))
        return _Structure(cand=cand, neg_nodes=neg_nodes, store=store, segments=segments,
                          free_lengths=sorted({b - a for a, b, c in segments if c < 0}),
                          n_red=self.ns + 2 * len(neg_nodes))

    def structure_for(self, depth_max_m: float) -> "_Structure":
        cand = self.plan.candidate_steps(float(depth_max_m))
        key = tuple(cand.tolist())
        st = self._structs.get(key)
        if st is None:
            st = self._structs[key] = self._structure(cand)
        return st

    def period_s(self, rpm) -> np.ndarray:
        """The principal period at spindle speeds ``rpm`` (array, rpm), s (:meth:`DirectionalPlan.period_s`)."""
        return self.plan.period_s(rpm)

    # ----- matrix exponentials --------------------------------------------------------------------
    def _step_exps(self, dt: np.ndarray, wsum: np.ndarray):
        """``Phi, Gamma0, Gamma1`` for batched steps: dt (P,), wsum (P, k, 2).

        ``[Phi, H0, H1]`` is the first block row of the Van Loan exponential (module docstring),
        evaluated as ``Phi = exp(Abar dt)``, ``H0 = phi1(Abar dt) B dt``, ``H1 = phi2(Abar dt) B dt``
        by :func:`phi_exps`; ``Gamma0 = H0 - H1``, ``Gamma1 = H1``."""
        Abar = self.A[None] + self.Bk[None] @ wsum @ self.S2[None]
        dt = np.asarray(dt, dtype=float)
        Phi, H0, H1 = phi_exps(Abar * dt[:, None, None], self.Bk[None] * dt[:, None, None])
        return Phi, H0 - H1, H1

    def _cached(self, dt: np.ndarray, key, compute):
        """Per-speed cache of depth-independent propagators: compute(dt_missing) -> tuple of arrays."""
        vals: list[Any] = [self._free_cache.get((float(d), key)) for d in dt]
        miss = [j for j, v in enumerate(vals) if v is None]
        if miss:
            res = compute(dt[miss])
            for jj, j in enumerate(miss):
                v = tuple(x[jj] for x in res)
                vals[j] = v
                if len(self._free_cache) < 200000:
                    self._free_cache[(float(dt[j]), key)] = v
        return tuple(np.stack([v[i] for v in vals]) for i in range(len(vals[0])))

    def _free_step(self, dt: np.ndarray):
        """``Phi, Gamma0, Gamma1`` of the free structure (W = 0) for each dt (B,), cached."""
        return self._cached(dt, "step", lambda d: self._step_exps(d, np.zeros((len(d), self.k, 2))))

    def _free_exp(self, dt: np.ndarray, L: int) -> np.ndarray:
        """``expm(A L dt)`` (B, ns, ns), cached per speed; from the 2 x 2 blocks of a block-diagonal
        ``A``. Dense: one batched product applies it faster than the blocks elementwise."""
        if self.ss.block2:
            Ab = self.ss.blocks
            nb = len(Ab)
            r = np.arange(self.ns).reshape(nb, 2)

            def compute(d):
                Eb = phi_exps((Ab[None] * (d * L)[:, None, None, None]).reshape(-1, 2, 2), np.zeros((1, 2, 0)))[0]
                E = np.zeros((len(d), self.ns, self.ns))
                E[:, r[:, :, None], r[:, None, :]] = Eb.reshape(len(d), nb, 2, 2)
                return (E,)
        else:
            compute = lambda d: (phi_exps(self.A[None] * (d * L)[:, None, None], np.zeros((1, self.ns, 0)))[0],)
        return self._cached(dt, L, compute)[0]

    # ----- reduced monodromy (fast path) --------------------------------------------------------
    def monodromy(self, rpm: np.ndarray, depth_m: np.ndarray, record: bool = False):
        """Reduced monodromy matrices, (B, N, N), for paired speeds and depths (B,).

        With ``record=True`` also returns the list of ``X`` (B, ns, N) at every kept mesh node,
        mapping the reduced initial state to the state there.
        """
        if self.plan.delay_time:
            raise LobeError("delay_time is carried only by monodromy_dense")
        rpm = np.asarray(rpm, dtype=float).reshape(-1)
        depth = np.asarray(depth_m, dtype=float).reshape(-1)
        Bn = len(rpm)
        plan = self.plan
        dt = self.period_s(rpm) / plan.m
        st = self.structure_for(float(np.max(depth)) if len(depth) else 0.0)
        nc = len(st.cand)
        exact_free = self.method.scheme == "free-exact"
        if nc:
            W = plan.wbar(depth, st.cand)  # (B, nc, G, k, 2)
            wsum = W.sum(axis=2)
            if exact_free:
                Phi1, G01, G11 = self._free_step(dt)
            else:
                Phi, G0, G1 = self._step_exps(np.repeat(dt, nc), wsum.reshape(Bn * nc, self.k, 2))
                Phi = Phi.reshape(Bn, nc, self.ns, self.ns)
                G0 = G0.reshape(Bn, nc, self.ns, self.k)
                G1 = G1.reshape(Bn, nc, self.ns, self.k)
        free = {L: self._free_exp(dt, L) for L in st.free_lengths}
        ns, N = self.ns, st.n_red
        X = np.zeros((Bn, ns, N))
        X[:, :, :ns] = np.eye(ns)
        R: dict[int, np.ndarray] = {}
        for j, k in enumerate(st.neg_nodes):
            sel = np.zeros((1, 2, N))
            sel[0, 0, ns + 2 * j] = 1.0
            sel[0, 1, ns + 2 * j + 1] = 1.0
            R[k] = sel
        recs = []
        for a, b, c in st.segments:
            if a in st.store:
                R[a] = self.S2[None] @ X
            if record:
                recs.append(X)
            if c < 0:
                X = free[b - a] @ X
                continue
            acc0 = np.zeros((Bn, self.k, N))
            acc1 = np.zeros((Bn, self.k, N))
            for g, (r, f) in enumerate(zip(plan.group_r, plan.group_f)):
                Wg = W[:, c, g]  # (B, k, 2)
                if not np.any(Wg):
                    continue
                if f > 0:
                    v0 = (1 - f) * R[a - r] + f * R[a - r - 1]
                    v1 = (1 - f) * R[a - r + 1] + f * R[a - r]
                else:
                    v0 = R[a - r]
                    v1 = R[a - r + 1]
                acc0 -= Wg @ v0
                acc1 -= Wg @ v1
            if exact_free:
                Wc = wsum[:, c]  # (B, k, 2)
                acc0 += Wc @ (self.S2[None] @ X)
                rhs = Phi1 @ X + G01 @ acc0 + G11 @ acc1
                G1W = G11 @ Wc  # (B, ns, 2)
                Mi = np.linalg.inv(np.eye(2)[None] - self.S2[None] @ G1W)
                X = rhs + G1W @ (Mi @ (self.S2[None] @ rhs))
            else:
                X = Phi[:, c] @ X + G0[:, c] @ acc0 + G1[:, c] @ acc1
        rows = [X] + [np.broadcast_to(R[k + plan.m], (Bn, 2, N)) for k in st.neg_nodes]
        U = np.concatenate(rows, axis=1)
        if record:
            return U, recs
        return U

    def batches(self, depth_m) -> list[np.ndarray]:
        """Index arrays (into ``depth_m`` (B,)) of the sub-batches that :meth:`spectra` evaluates.

        ``batching="single"``: one batch. "grouped": the pairs sorted by depth and cut into runs of
        :func:`_sub_batch` pairs (sized for the largest depth's layout), so that each run is
        evaluated with the reduced layout of its own largest depth (:meth:`structure_for`; for a
        helical tool the engaged steps grow with the depth) and its step propagators stay in
        cache. Runs are not cut smaller than that: each call has a fixed Python cost (~3 ms for
        the TX200 at m = 80, as much as 1 pair).
        """
        depth = np.asarray(depth_m, dtype=float).reshape(-1)
        B = len(depth)
        if self.method.batching == "single" or B == 0:
            return [np.arange(B)]
        st = self.structure_for(float(np.max(depth)))
        n = _sub_batch(len(st.cand), self.ns, st.n_red)
        order = np.argsort(depth, kind="stable")
        return [order[a:a + n] for a in range(0, B, n)]

    def spectra(self, rpm, depth_m) -> np.ndarray:
        """All Floquet multipliers (B, N) complex of the reduced monodromy at paired speeds/depths (B,).

        With ``batching="grouped"`` each sub-batch of :meth:`batches` has its own layout; rows are
        padded with zero multipliers to the widest one (N = the largest reduced size used). The
        depth searches evaluate through this method: with "grouped" it also keeps the critical
        multiplier and chatter frequency of every unstable pair (a search's limit is bracketed
        from above by one; :meth:`critical` at a pair evaluated here then costs nothing). :meth:`multipliers` (the coarse scans) does not keep them."""
        return self._spectra(rpm, depth_m, keep=self.method.batching == "grouped" and self.ns >= _KEEP_MIN_STATES)

    def _spectra(self, rpm, depth_m, keep: bool) -> np.ndarray:
        rpm = np.asarray(rpm, dtype=float).reshape(-1)
        depth = np.asarray(depth_m, dtype=float).reshape(-1)
        if len(rpm) == 0:
            return np.zeros((0, self.n_red), dtype=complex)
        parts = []
        for j in self.batches(depth):
            if keep:
                U, recs = self.monodromy(rpm[j], depth[j], record=True)
                ev = self._eigvals(U)
                un = np.flatnonzero(np.abs(ev).max(axis=1) >= 1.0)  # only an unstable pair ends a search
                if len(un):
                    crit = self._critical_of(rpm[j][un], U[un], [X[un] for X in recs], ev[un])
                    for i, (r, d) in enumerate(zip(rpm[j][un].tolist(), depth[j][un].tolist())):
                        self._kept[(r, d)] = (crit[0][i], crit[1][i], crit[2][i])
            else:
                ev = self._eigvals(self.monodromy(rpm[j], depth[j]))
            parts.append((j, ev))
        width = max(ev.shape[1] for _, ev in parts)
        out = np.zeros((len(rpm), width), dtype=complex)
        for j, ev in parts:
            out[j, :ev.shape[1]] = ev
        return out

    def _eigvals(self, U) -> np.ndarray:
        """Multipliers (B, N) complex of monodromies ``U`` (B, N, N): dense, or the largest by
        :func:`arnoldi_eigvals` (zeros for the rest) with ``eigen="arnoldi"`` from
        :data:`_ARNOLDI_MIN_N` rows on."""
        if self.method.eigen == "arnoldi" and U.shape[1] >= _ARNOLDI_MIN_N:
            return arnoldi_eigvals(U, arnoldi_ncv(U.shape[1], self.ns))
        return np.linalg.eigvals(U)

    def multipliers(self, rpm, depth_m):
        """Spectral radius (B,) and critical multiplier (B,) complex."""
        ev = self._spectra(rpm, depth_m, keep=False)
        j = np.argmax(np.abs(ev), axis=1)
        mu = ev[np.arange(len(ev)), j]
        return np.abs(mu), mu

    def critical(self, rpm, depth_m):
        """Critical multiplier and chatter frequency (Hz) at paired speeds/depths (B,).

        The chatter frequency is ambiguous modulo the principal frequency 1/T: among the
        candidates ``|arg mu + 2 pi p| / (2 pi T)`` we take the one nearest the damped frequency of
        the structural pole that dominates the tool motion of the critical Floquet solution
        (modal decomposition of the eigen-solution's states at the kept mesh nodes, weighted by
        each pole's tool-tip displacement). Pairs already evaluated by :meth:`spectra` (with
        ``batching="grouped"``) are taken from it; ``self.critical_evaluations`` counts the others.
        """
        rpm = np.asarray(rpm, dtype=float).reshape(-1)
        depth = np.asarray(depth_m, dtype=float).reshape(-1)
        rho, mu, freq = np.zeros(len(rpm)), np.zeros(len(rpm), complex), np.zeros(len(rpm))
        kept = [self._kept.get(k) for k in zip(rpm.tolist(), depth.tolist())]
        for i, v in enumerate(kept):
            if v is not None:
                rho[i], mu[i], freq[i] = v
        miss = np.array([i for i, v in enumerate(kept) if v is None], dtype=int)
        self.critical_evaluations += len(miss)
        for j in self.batches(depth[miss]) if len(miss) else ():
            k = miss[j]
            U, recs = self.monodromy(rpm[k], depth[k], record=True)
            if self.method.batching == "single":  # the earlier code: eigenvectors by LAPACK
                ev, vec = np.linalg.eig(U)
                jj = np.argmax(np.abs(ev), axis=1)
                idx = np.arange(len(ev))
                m_, z = ev[idx, jj], vec[idx, :, jj]
                rho[k], mu[k], freq[k] = np.abs(m_), m_, self._chatter_freq(rpm[k], m_, z, recs)
            else:
                rho[k], mu[k], freq[k] = self._critical_of(rpm[k], U, recs, self._eigvals(U))
        return rho, mu, freq

    def _critical_of(self, rpm: np.ndarray, U: np.ndarray, recs: list, ev: np.ndarray):
        """``|mu|, mu, freq`` (B,) of the dominant multiplier of monodromies ``U`` (B, N, N) with
        multipliers ``ev`` (B, N) and recorded node states ``recs``; its eigenvector by
        :func:`eigenvector_of`."""
        idx = np.arange(len(ev))
        mu = ev[idx, np.argmax(np.abs(ev), axis=1)]
        return np.abs(mu), mu, self._chatter_freq(rpm, mu, eigenvector_of(U, mu), recs)

    def _chatter_freq(self, rpm: np.ndarray, mu: np.ndarray, z: np.ndarray, recs: list) -> np.ndarray:
        """Chatter frequency (Hz) (B,) of multipliers ``mu`` (B,) with eigenvectors ``z`` (B, N)."""
        Y = np.stack([np.einsum("bsn,bn->bs", Xr, z) for Xr in recs], axis=1)  # (B, nodes, ns)
        wfreq, wts = self.ss.mode_weights(Y.reshape(-1, self.ns))
        wts = wts.reshape(Y.shape[0], Y.shape[1], -1)
        tot = (wts / np.maximum(np.linalg.norm(wts, axis=2, keepdims=True), 1e-300)).sum(axis=1)
        dom = wfreq[np.argmax(tot, axis=1)]  # rad/s
        return chatter_branch(mu, self.period_s(rpm), dom)

    # ----- straightforward reference (dense, every step, full history) ---------------------------
    def _van_loan(self, dt: float, wsum: np.ndarray):
        """``Phi, Gamma0, Gamma1`` of one step (wsum (k, 2)) by scipy's expm of the Van Loan matrix
        (module docstring): the reference's own exponentials, independent of :func:`phi_exps`."""
        from scipy.linalg import expm

        ns, k = self.ns, self.k
        Z = np.zeros((ns + 2 * k, ns + 2 * k))
        Z[:ns, :ns] = (self.A + self.Bk @ wsum @ self.S2) * dt
        Z[:ns, ns:ns + k] = self.Bk * dt
        Z[ns:ns + k, ns + k:] = np.eye(k)
        E = expm(Z)
        return E[:ns, :ns], E[:ns, ns:ns + k] - E[:ns, ns + k:], E[:ns, ns + k:]

    def monodromy_dense(self, rpm: float, depth_m: float, impulses=None) -> np.ndarray:
        """The plain SDM monodromy: all ``m`` steps, one scipy expm each, full history, dense products.

        ``impulses`` (optional): pairs ``(i, E)``, node ``i`` in ``[0, m)`` and ``E`` (k, 2) in N s/m:
        a non-delayed impulsive force ``-E r(t_i)`` on the tool at node ``i`` (the state jumps by
        ``-B E S2 y``), applied before step ``i``. :mod:`lobes.entry_shift` builds them.

        With ``plan.delay_time`` each delayed value is taken ``d(phi)`` steps further back
        (:meth:`DirectionalPlan.wbar` with ``delay_shift``; ``d`` per quadrature point and axial slice)
        by linear interpolation in the delay between ``tau_g`` and ``tau_g + dt``:
        ``r(t - tau_g - d dt) ~ (1 - d) r(t - tau_g) + d r(t - tau_g - dt)``, i.e. the weights
        ``W - Wd`` on the delay ``tau_g`` and ``Wd`` on ``tau_g + dt``, ``Wd`` the step average of
        ``g D d``. Exact for a displacement linear in time; error ``O(|d| (1 + |d|) dt^2 r'')`` (an
        extrapolation for ``d < 0``), the SDM's own order."""
        plan, ns = self.plan, self.ns
        m = plan.m
        dt = float(self.period_s(rpm)) / m
        W = plan.wbar(np.array([depth_m]), np.arange(m))[0]  # (m, G, k, 2)
        groups = [(r, f, W[:, g]) for g, (r, f) in enumerate(zip(plan.group_r, plan.group_f))]
        if plan.delay_time:
            Wd = plan.wbar(np.array([depth_m]), np.arange(m), delay_shift=True)[0]
            groups = [(r, f, Wg - Wd[:, g]) for g, (r, f, Wg) in enumerate(groups)]
            groups += [(r + 1, f, Wd[:, g]) for g, (r, f) in enumerate(zip(plan.group_r, plan.group_f))]
        h = int(max(r + (1 if f > 0 else 0) for r, f, _ in groups))
        Ns = ns + 2 * h
        U = np.eye(Ns)
        jumps: dict[int, np.ndarray] = {}
        for i, E in impulses or ():
            jumps[int(i)] = jumps.get(int(i), 0.0) + np.asarray(E, dtype=float)[:self.k]
        for i in range(m):
            if i in jumps:
                J = np.eye(Ns)
                J[:ns, :ns] -= self.Bk @ jumps[i] @ self.S2
                U = J @ U
            wsum = W[i].sum(axis=0)
            wexp = np.zeros_like(wsum) if self.method.scheme == "free-exact" else wsum
            Phi, G0, G1 = self._van_loan(dt, wexp)
            D = np.zeros((Ns, Ns))
            D[:ns, :ns] = Phi

            def add(node_off, coef):  # coef (ns, 2) multiplies r_{i - node_off}
                if node_off == 0:
                    D[:ns, :ns] += coef @ self.S2
                else:
                    c0 = ns + 2 * (node_off - 1)
                    D[:ns, c0:c0 + 2] += coef

            for r, f, Wr in groups:
                Wg = Wr[i]
                add(r, -(G0 @ Wg) * (1 - f) - (G1 @ Wg) * f)
                add(r - 1, -(G1 @ Wg) * (1 - f))
                if f > 0:
                    add(r + 1, -(G0 @ Wg) * f)
            if self.method.scheme == "free-exact":
                # y_{i+1} = Q [ (Phi + Gamma0 W S2) y_i + delayed terms ],  Q = (I - Gamma1 W S2)^-1
                D[:ns, :ns] += G0 @ wsum @ self.S2
                Q = np.linalg.inv(np.eye(ns) - G1 @ wsum @ self.S2)
                D[:ns] = Q @ D[:ns]
            D[ns:ns + 2, :ns] = self.S2
            if h > 1:
                D[ns + 2:, ns:ns + 2 * (h - 1)] = np.eye(2 * (h - 1))
            U = D @ U
        return U


#: Smallest structure (states) whose critical multipliers :meth:`SDMEngine.spectra` keeps: below it
#: the re-evaluation at each limit is cheaper than keeping them at every unstable search point
#: (2-mode model, 4 states: 0.53 s without, 0.56 s with, in one run of ``bench_lobes.py --targets``).
_KEEP_MIN_STATES = 12


#: ``eigen="arnoldi"``: multipliers asked of ARPACK, and the smallest monodromy (rows) given to it.
#: ``bench/bench_sdm_krylov.py`` (TX200, 36 states, ncv 40, CPU of one process at load 2-3): 0.57-1.03
#: times the dense CPU at 78-114 rows, 2.0-2.4 times less at 116-166 rows (steel, m = 80; k = 4 to
#: 16 cost about the same). k = 16, not 6: the depth search follows the critical multiplier of the
#: unstable end down to the stable end, where it can sit below a dozen structural multipliers of
#: |mu| ~ 0.99; with k = 6 the steel diagram took 1845 spectra instead of 1620.
_ARNOLDI_K = 16
_ARNOLDI_MIN_N = 116


def arnoldi_ncv(n: int, n_states: int) -> int:
    """Arnoldi basis size for a monodromy of ``n`` rows of a structure with ``n_states`` states.

    ``n_states + 4`` (at least 20, at most ``n``): the TX200's 36 structural multipliers and the
    few delay multipliers of comparable modulus fit in one basis, and ARPACK converged without a
    restart (41-42 products; with scipy's default 20: 270-310 products, 2.4-2.6 times the dense CPU
    at 116-166 rows)."""
    return int(min(n, max(20, n_states + 4)))


def arnoldi_eigvals(U: np.ndarray, ncv: int) -> np.ndarray:
    """The :data:`_ARNOLDI_K` largest-modulus eigenvalues of real matrices ``U`` (B, N, N) by ARPACK.

    ``scipy.sparse.linalg.eigs(which="LM", tol=0)`` (residuals to machine precision) with a fixed
    generic start vector and ``ncv`` basis vectors; the conjugate of a complex value is added when
    ARPACK left it out. Where ARPACK does not converge, all eigenvalues by LAPACK. Returns (B, N)
    complex, the values found first and zeros after them."""
    from scipy.sparse.linalg import ArpackNoConvergence, eigs

    B, N, _ = U.shape
    out = np.zeros((B, N), dtype=complex)
    k = min(_ARNOLDI_K, N - 2)  # ARPACK: k < N - 1 and k + 1 < ncv <= N
    if k < 1:
        return np.linalg.eigvals(U)
    ncv = int(min(N, max(ncv, k + 2)))
    v0 = np.cos(np.arange(N) * 1.6180339887) + 0.1
    for b in range(B):
        try:
            w = eigs(U[b], k=k, ncv=ncv, which="LM", v0=v0, tol=0, return_eigenvectors=False)
        except ArpackNoConvergence:
            out[b] = np.linalg.eigvals(U[b])
            continue
        w = np.asarray(w, dtype=complex)
        miss = [np.conj(x) for x in w if x.imag != 0 and np.min(np.abs(w - np.conj(x))) > 1e-12 * abs(x)]
        w = np.concatenate([w, np.array(miss, dtype=complex)])[:N]
        out[b, :len(w)] = w
    return out


#: Bytes of step propagators (``Phi``, ``Gamma0``, ``Gamma1`` of every engaged step) plus the
#: propagated state ``X`` per sub-batch of :meth:`SDMEngine.batches`. Measured on the TX200 (36
#: states, m = 80, 64 pairs): 3.2-3.8 ms per pair in runs of 8-32, 4.4 ms in one run of 64 and
#: 6.5 ms one by one (the fixed cost per call); this budget gives runs of ~14 there. The 2-mode
#: model's whole batches fit.
_SUB_BATCH_BYTES = 8 << 20


def _sub_batch(n_engaged: int, ns: int, n_red: int) -> int:
    """Pairs per sub-batch: :data:`_SUB_BATCH_BYTES` over one pair's propagators and state."""
    per_pair = 8 * (n_engaged * (ns * ns + 4 * ns) + 3 * ns * n_red)
    return max(1, _SUB_BATCH_BYTES // per_pair)


#: Taylor degree of phi2 and the norm bound it is used up to: the first neglected term of
#: ``phi2(X) = sum_i X^i / (i + 2)!`` is at most ``1 / 19! = 8e-18`` times ``phi2(0) = 1/2`` for
#: ``||X||_1 <= 1`` (the remainder is below ``e / 19!``), i.e. below double rounding.
_PHI_DEGREE = 16
_PHI_THETA = 1.0
_PHI_CHUNK = 32


def phi_exps(M: np.ndarray, V: np.ndarray):
    """``exp(M)``, ``phi1(M) V`` and ``phi2(M) V`` for a batch of small square matrices.

    ``phi1(X) = sum_i X^i / (i + 1)!`` and ``phi2(X) = sum_i X^i / (i + 2)!`` (so ``exp(X) = I + X
    phi1(X)``, ``phi1(X) = I + X phi2(X)``): with ``M = A dt`` and ``V = B dt`` these are the
    propagator and the two input integrals of a step with a piecewise-linear input, i.e. the first
    block row of the Van Loan exponential ``expm([[M, V, 0], [0, 0, I], [0, 0, 0]])``.

    Scaling and squaring: each matrix is scaled by ``2^-s`` so that ``||X||_1 <= 1``, ``phi2(X)`` is
    summed to degree 16 (Paterson-Stockmeyer, 6 products; truncation below double rounding), and
    the doubling identities ``exp(2X) = exp(X)^2``, ``phi1(2X) = (exp(X) + I) phi1(X) / 2``,
    ``phi2(2X) = (phi1(X) + (exp(X) + I) phi2(X)) / 4`` are applied ``s`` times (one matrix product
    each; the ``phi`` terms are carried as ``(n, k)`` blocks). Agrees with :func:`scipy.linalg.expm`
    to ~1e-14 (``tests/test_sdm_fast.py``) at several times less cost for batches.

    Parameters
    ----------
    M : array (P, n, n)
    V : array (P, n, k) or broadcastable (1, n, k)

    Returns
    -------
    E, H0, H1 : arrays (P, n, n), (P, n, k), (P, n, k)
    """
    M = np.asarray(M, dtype=float)
    P, n, _ = M.shape
    V = np.broadcast_to(np.asarray(V, dtype=float), (P, n, np.shape(V)[-1]))
    norm = np.abs(M).sum(axis=1).max(axis=1) if P else np.zeros(0)
    with np.errstate(divide="ignore"):
        s = np.where(norm > _PHI_THETA, np.ceil(np.log2(norm / _PHI_THETA)), 0).astype(int)
    E = np.empty((P, n, n))
    H0 = np.empty((P, n, V.shape[2]))
    H1 = np.empty_like(H0)
    for sv in np.unique(s):
        js = np.flatnonzero(s == sv)
        for a in range(0, len(js), _PHI_CHUNK):  # cache-sized pieces: the sums are memory-bound
            j = js[a:a + _PHI_CHUNK]
            E[j], H0[j], H1[j] = _phi_scaled(M[j] * 2.0 ** -int(sv), V[j], int(sv))
    return E, H0, H1


def _phi_scaled(X: np.ndarray, V: np.ndarray, s: int):
    """:func:`phi_exps` of ``2^s X`` for ``||X||_1 <= 1``: Taylor of ``phi2`` then ``s`` doublings."""
    P, n, _ = X.shape
    d = np.arange(n)
    pw = np.empty((4, P, n, n))               # X, X^2, X^3, X^4
    pw[0] = X
    np.matmul(X, X, out=pw[1])
    np.matmul(pw[1], X, out=pw[2])
    np.matmul(pw[1], pw[1], out=pw[3])
    # Paterson-Stockmeyer: phi2(X) = sum_j X^(4j) B_j, B_j = sum_{i<4} c_(4j+i) X^i (+ c_16 X^4 in B_3);
    # the four B_j in one product with the coefficient matrix (elementwise sums cost as much as
    # products for matrices this small)
    Bj = (_PHI_COEF @ pw.reshape(4, -1)).reshape(4, P, n, n)
    Bj[:, :, d, d] += _PHI_DIAG
    P2 = Bj[3]
    for j in (2, 1, 0):                         # Horner in X^4
        P2 = pw[3] @ P2
        P2 += Bj[j]
    E = pw[1] @ P2                              # exp(X) = I + X + X^2 phi2(X)
    E += X
    E[:, d, d] += 1.0
    k = V.shape[-1]
    h = np.empty((P, n, 2 * k))                 # [phi1(X) V, phi2(X) V]
    h[..., k:] = P2 @ V
    h[..., :k] = V + X @ h[..., k:]
    for _ in range(s):
        Eh = E @ h
        Eh += h                                 # (exp(X) + I) [phi1 V, phi2 V]
        Eh[..., k:] += h[..., :k]
        Eh[..., k:] *= 0.25
        Eh[..., :k] *= 0.5
        h = Eh
        E = E @ E
    return E, h[..., :k], h[..., k:]


def _phi_tables():
    c = [1.0 / math.factorial(i + 2) for i in range(_PHI_DEGREE + 1)]
    C = np.zeros((4, 4))
    for j in range(4):
        C[j, :3] = c[4 * j + 1:4 * j + 4]
    C[3, 3] = c[16]
    return C, np.array(c[0:16:4])[:, None, None]


_PHI_COEF, _PHI_DIAG = _phi_tables()


def eigenvector_of(U: np.ndarray, mu: np.ndarray) -> np.ndarray:
    """Eigenvectors (B, N) complex of matrices ``U`` (B, N, N) for their eigenvalues ``mu`` (B,).

    One step of inverse iteration: ``(U - s I) z = v`` with the shift ``s = mu (1 + 1e-12)`` and a
    fixed generic ``v``; ``z`` is the eigenvector up to a factor ``1 + O(1e-12 |mu| / gap)`` in
    the other eigen-directions (``gap``: distance of ``mu`` to the next eigenvalue). One LU
    (``2/3 N^3``) instead of the eigenvectors of the QR algorithm. Where the shifted matrix is
    singular to working precision, LAPACK's eigenvectors are taken. Normalized to unit 2-norm.
    """
    B, N, _ = U.shape
    shift = mu * (1 + 1e-12) + 1e-300
    M = U.astype(complex) - shift[:, None, None] * np.eye(N)[None]
    v = np.cos(np.arange(N) * 1.6180339887) + 0.5j * np.sin(np.arange(N) * 2.718281828)
    try:
        z = np.linalg.solve(M, np.broadcast_to(v, (B, N))[..., None])[..., 0]
    except np.linalg.LinAlgError:
        z = np.full((B, N), np.nan, complex)
    bad = ~np.all(np.isfinite(z), axis=1)
    if bad.any():
        ev, vec = np.linalg.eig(U[bad])
        z[bad] = vec[np.arange(int(bad.sum())), :, np.argmin(np.abs(ev - mu[bad, None]), axis=1)]
    return z / np.linalg.norm(z, axis=1, keepdims=True)


def chatter_branch(mu: np.ndarray, period_s: np.ndarray, omega_ref: np.ndarray) -> np.ndarray:
    """Frequency (Hz) ``|arg mu + 2 pi p| / (2 pi T)`` nearest ``omega_ref`` (rad/s), per element."""
    mu = np.asarray(mu, dtype=complex)
    T = np.asarray(period_s, dtype=float)
    wr = np.asarray(omega_ref, dtype=float)
    th = np.angle(mu)
    p0 = np.round((wr * T - th) / (2 * np.pi))
    best = np.full(mu.shape, np.nan)
    err = np.full(mu.shape, np.inf)
    for dp in range(-2, 3):
        for sgn in (1.0, -1.0):
            p = sgn * p0 + dp
            w = np.abs(th + 2 * np.pi * p) / T
            e = np.abs(w - wr)
            better = e < err
            best = np.where(better, w, best)
            err = np.where(better, e, err)
    return best / (2 * np.pi)
