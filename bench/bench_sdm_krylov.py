"""Krylov (ARPACK Arnoldi) eigenvalues against dense eigenvalues on the SDM monodromy, CPU of one process.

Run: .venv/bin/python bench/bench_sdm_krylov.py [--quick] [--cases tx200-steel,tx200-aluminium]

The TX200 18-DOF ``orthogonal`` model at the Tab. 7 pose (built as ``bench_lobes.py --targets``
does), steel and aluminium. For m = 40 and m = 80: the stability limits of a set of speeds by
``lobes.solve`` (one level, the default search), then the (speed, depth) pairs at 0.9, 1.0 and 1.1
times each finite limit. For these pairs, in the same process:

(a) dense: the reduced monodromy formed by ``SDMEngine.monodromy`` (batched, as the depth search
    does) and ``numpy.linalg.eigvals`` of each;
(b) ``scipy.sparse.linalg.eigs(k, which="LM")`` on the same formed matrices;
(c) ``eigs`` on a ``LinearOperator`` that applies the monodromy to a vector without forming it:
    the engaged steps ``y <- Phi y + [coefficients] [delayed tool displacements]`` and the merged
    free spans, with the step exponentials of the engine (their cost is counted);
(d) (b) started from the critical eigenvector of the previous depth of the same speed (0.9 ->
    1.0 -> 1.1 of the limit), as a depth search could;
(e) the engine's opt-in ``SemiDiscretization(eigen="arnoldi")`` on the same matrices.

Each of (b)-(d) with k = 4 and 6 and with ARPACK's basis size ``ncv`` at scipy's default
(max(2 k + 1, 20)) and at 40 (``--ncv``). ``--diagram N``: instead, the refined diagram of N speeds
(``RefinedSDM``, the default) with dense and with Arnoldi eigenvalues.

Printed per variant: CPU of the eigen part (and of the formation), matrix-vector products,
ArpackNoConvergence count, the largest relative difference of the spectral radius from the dense
one, and the number of pairs whose verdict (spectral radius < 1) differs from the dense verdict.
The process is pinned to one BLAS thread (set before numpy is imported).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import cast

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_v] = "1"

import numpy as np  # noqa: E402  (after the BLAS thread count is set)
from scipy.sparse.linalg import ArpackNoConvergence, LinearOperator, eigs  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench_lobes import tx200_problem  # noqa: E402

from robolobes.lobes import LobeProblem, RefinedSDM, SemiDiscretization, solve  # noqa: E402
from robolobes.lobes.sdm import _ARNOLDI_K, _ARNOLDI_MIN_N, SDMEngine, arnoldi_ncv  # noqa: E402

DEPTH_MAX_M = 10e-3
FACTORS = (0.9, 1.0, 1.1)


@dataclass
class Tally:
    """Results of one eigen-solver variant over the sample of pairs."""

    cpu_s: float = 0.0
    matvecs: int = 0
    noconv: int = 0
    rho: list = field(default_factory=list)
    vec: list = field(default_factory=list)


def sample_pairs(p: LobeProblem, m: int, n_speeds: int):
    """Speeds (P,) in rpm and depths (P,) in m: 0.9/1.0/1.1 times the finite limits at ``m``."""
    speeds = np.linspace(2000.0, 25000.0, 2 * n_speeds)
    lim = solve(p, SemiDiscretization(m=m), speeds, depth_max_m=DEPTH_MAX_M).depth_limit_m
    fin = np.flatnonzero(np.isfinite(lim) & (1.1 * lim < DEPTH_MAX_M))
    pick = fin[np.unique(np.linspace(0, len(fin) - 1, min(n_speeds, len(fin))).round().astype(int))]
    rpm = np.repeat(speeds[pick], len(FACTORS))
    depth = (lim[pick][:, None] * np.array(FACTORS)[None]).reshape(-1)
    return rpm, depth


class MonodromyOperator:
    """The reduced monodromy of one (speed, depth) pair as a map of vectors (N,), not formed.

    Same recurrence as :meth:`SDMEngine.monodromy` (scheme "sdm"): on each engaged step
    ``y <- Phi y + C [r at the read nodes]`` with ``C`` (ns, 2 n_read) collecting the
    ``-Gamma0 W`` and ``-Gamma1 W`` terms, on each merged free span ``y <- expm(A L dt) y``; the
    tool displacement ``r = S2 y`` (m) is stored at the kept nodes; the delayed block of the result
    holds the stored displacements of the next period.
    """

    def __init__(self, eng: SDMEngine, rpm: float, depth_m: float, layout_depth_m: float):
        plan, ns = eng.plan, eng.ns
        self.eng, self.st = eng, eng.structure_for(layout_depth_m)
        st = self.st
        dt = float(eng.period_s(rpm)) / plan.m
        nc = len(st.cand)
        W = plan.wbar(np.array([depth_m]), st.cand)[0]  # (nc, G, k, 2)
        Phi, G0, G1 = eng._step_exps(np.full(nc, dt), W.sum(axis=1))
        self.free = {L: eng._free_exp(np.array([dt]), L)[0] for L in st.free_lengths}
        self.steps = []  # per segment: ("free", E) or ("step", Phi, C, read nodes)
        for a, b, c in st.segments:
            if c < 0:
                self.steps.append((a, self.free[b - a], None, ()))
                continue
            terms: dict[int, np.ndarray] = {}
            for g, (r, f) in enumerate(zip(plan.group_r, plan.group_f)):
                Wg = W[c, g]
                if not np.any(Wg):
                    continue
                for node, coef in ((a - r, -(1 - f) * G0[c] - f * G1[c]), (a - r - 1, -f * G0[c]),
                                   (a - r + 1, -(1 - f) * G1[c])):
                    if node == a - r - 1 and f == 0:
                        continue
                    terms[node] = terms.get(node, 0.0) + coef @ Wg
            nodes = tuple(terms)
            C = np.concatenate([terms[n] for n in nodes], axis=1) if nodes else np.zeros((ns, 0))
            self.steps.append((a, Phi[c], C, nodes))
        self.ns, self.N, self.m = ns, st.n_red, plan.m
        self.S2 = eng.S2

    def apply(self, v: np.ndarray) -> np.ndarray:
        """Monodromy times ``v`` (N,) -> (N,); real or complex."""
        ns, st = self.ns, self.st
        y = v[:ns]
        R = {k: v[ns + 2 * j:ns + 2 * j + 2] for j, k in enumerate(st.neg_nodes)}
        for a, M, C, nodes in self.steps:
            if a in st.store:
                R[a] = self.S2 @ y
            y = M @ y
            if nodes:
                y = y + C @ np.concatenate([R[n] for n in nodes])
        return np.concatenate([y] + [R[k + self.m] for k in st.neg_nodes])


class _Operator(LinearOperator):
    """A square ``LinearOperator`` (n, n) from a function of vectors (n,) -> (n,)."""

    def __init__(self, n: int, dtype, f):
        super().__init__(dtype=dtype, shape=(n, n))
        self.f = f

    def _matvec(self, x):
        return self.f(x)


def arnoldi(apply, n: int, dtype, k: int, ncv: int | None, v0, tally: Tally) -> None:
    """eigs(k, 'LM') of the operator ``apply`` (N,) -> (N,) with ``ncv`` Arnoldi vectors (None:
    scipy's default, max(2 k + 1, 20)); appends the spectral radius and a real start vector (the
    critical eigenvector's real plus imaginary part) to ``tally``."""
    count = [0]

    def mv(x):
        count[0] += 1
        return apply(x.reshape(-1))

    op = _Operator(n, dtype, mv)
    t = time.process_time()
    try:
        w, V = cast(tuple, eigs(op, k=k, which="LM", v0=v0, ncv=None if ncv is None else min(ncv, n)))
    except ArpackNoConvergence as e:
        tally.noconv += 1
        w, V = e.eigenvalues, e.eigenvectors
    tally.cpu_s += time.process_time() - t
    tally.matvecs += count[0]
    if len(w) == 0:
        tally.rho.append(np.nan)
        tally.vec.append(None)
        return
    j = int(np.argmax(np.abs(w)))
    tally.rho.append(float(np.abs(w[j])))
    z = V[:, j]
    tally.vec.append(np.real(z) + np.imag(z))


def run_case(name: str, p: LobeProblem, m: int, n_speeds: int, ks: tuple[int, ...], ncvs: tuple) -> None:
    rpm, depth = sample_pairs(p, m, n_speeds)
    eng = SDMEngine(p, SemiDiscretization(m=m), DEPTH_MAX_M)
    eng.monodromy(rpm[:2], depth[:2])  # warm-up (free-flight cache)
    U_all, t_form, layout = [], 0.0, np.zeros(len(depth))
    for j in eng.batches(depth):  # the search's sub-batches, each with its own layout
        t = time.process_time()
        U = eng.monodromy(rpm[j], depth[j])
        t_form += time.process_time() - t
        U_all += [(int(i), U[q]) for q, i in enumerate(j)]
        layout[j] = np.max(depth[j])
    U_all = [u for _, u in sorted(U_all, key=lambda x: x[0])]
    t = time.process_time()
    rho_d = np.array([np.max(np.abs(np.linalg.eigvals(u))) for u in U_all])
    t_dense = time.process_time() - t
    t = time.process_time()
    for j in eng.batches(depth):
        np.linalg.eigvals(np.stack([U_all[i] for i in j]))
    t_dense_b = time.process_time() - t
    sizes = sorted({u.shape[0] for u in U_all})
    print(f"  {name}, m = {m}: {len(rpm)} pairs ({len(rpm) // 3} speeds x {FACTORS} of the limit), "
          f"monodromy {sizes[0]}-{sizes[-1]} square; dense |mu| max {rho_d.min():.4f}-{rho_d.max():.4f}")
    print(f"    (a) dense: form {1e3 * t_form / len(rpm):.2f} ms/pair (batched, with step exponentials), "
          f"eigvals {1e3 * t_dense / len(rpm):.2f} ms/pair one by one, {1e3 * t_dense_b / len(rpm):.2f} "
          f"ms/pair batched")
    # the step exponentials alone (what the operator variant still needs)
    t_exp = 0.0
    for j in eng.batches(depth):
        st = eng.structure_for(float(np.max(depth[j])))
        W = eng.plan.wbar(depth[j], st.cand).sum(axis=2)
        dt = eng.period_s(rpm[j]) / eng.plan.m
        t = time.process_time()
        eng._step_exps(np.repeat(dt, len(st.cand)), W.reshape(-1, eng.k, 2))
        t_exp += time.process_time() - t
    print(f"        of which step exponentials {1e3 * t_exp / len(rpm):.2f} ms/pair")
    for ncv in ncvs:
        for k in ks:
            _variants(eng, rpm, depth, layout, U_all, k, ncv, rho_d, t_dense, t_dense_b, t_form)
    _engine_option(p, m, depth, U_all, rho_d, t_dense_b)


def _engine_option(p: LobeProblem, m: int, depth, U_all, rho_d, t_dense_b: float) -> None:
    """(e) the opt-in ``SemiDiscretization(eigen="arnoldi")`` on the same matrices, in the engine's
    sub-batches (dense below ``_ARNOLDI_MIN_N`` rows)."""
    eng = SDMEngine(p, SemiDiscretization(m=m, eigen="arnoldi"), DEPTH_MAX_M)
    n = len(U_all)
    rho = np.zeros(n)
    t = time.process_time()
    for j in eng.batches(depth):
        rho[j] = np.abs(eng._eigvals(np.stack([U_all[i] for i in j]))).max(axis=1)
    tc = time.process_time() - t
    rel = np.abs(rho / rho_d - 1)
    ncv = arnoldi_ncv(max(u.shape[0] for u in U_all), eng.ns)
    print(f"    (e) eigen=\"arnoldi\" (k = {_ARNOLDI_K}, ncv {ncv}, dense below {_ARNOLDI_MIN_N} rows): "
          f"{1e3 * tc / n:.2f} ms/pair (dense batched / this {t_dense_b / tc:.2f}), |mu| max rel. diff "
          f"{np.max(rel):.1e}, verdicts differ {int(np.sum((rho < 1.0) != (rho_d < 1.0)))}/{n}", flush=True)


def bench_diagram(name: str, n: int) -> None:
    """The refined diagram (``RefinedSDM``, the default) with dense and with Arnoldi eigenvalues,
    CPU of this process, ``n`` speeds 2000-25 000 rpm, depths to 10 mm, alternated twice."""
    p = tx200_problem(name)
    speeds = np.linspace(2000.0, 25000.0, n)
    t = {"dense": [], "arnoldi": []}
    res = {}
    for _ in range(2):
        for eigen in ("dense", "arnoldi"):
            c0 = time.process_time()
            res[eigen] = solve(p, RefinedSDM(SemiDiscretization(eigen=eigen)), speeds, depth_max_m=DEPTH_MAX_M)
            t[eigen].append(time.process_time() - c0)
    a, b = res["dense"], res["arnoldi"]
    x, y = np.minimum(a.depth_limit_m, DEPTH_MAX_M), np.minimum(b.depth_limit_m, DEPTH_MAX_M)
    print(f"  {name} diagram, {n} speeds, RefinedSDM: dense {min(t['dense']):.2f} s, arnoldi "
          f"{min(t['arnoldi']):.2f} s CPU (best of 2; ratio dense / arnoldi "
          f"{min(t['dense']) / min(t['arnoldi']):.2f}); evaluations {a.stats['evaluations']} / "
          f"{b.stats['evaluations']}; limits differ by up to {np.max(np.abs(y / x - 1)):.1e} (relative), "
          f"same statuses {bool(np.all(a.status == b.status))}", flush=True)


def _variants(eng, rpm, depth, layout, U_all, k, ncv, rho_d, t_dense, t_dense_b, t_form) -> None:
    """Variants (b), (c), (d) with ``k`` eigenvalues asked and ``ncv`` Arnoldi vectors; one line each."""
    print(f"    ARPACK ncv = {'scipy default' if ncv is None else ncv}:")
    b, c, d = Tally(), Tally(), Tally()
    for u in U_all:
        arnoldi(lambda x, u=u: u @ x, u.shape[0], u.dtype, k, ncv, None, b)
    t_op_build, err_op = 0.0, 0.0
    for i, u in enumerate(U_all):
        t = time.process_time()
        op = MonodromyOperator(eng, rpm[i], depth[i], layout[i])
        t_op_build += time.process_time() - t
        x = np.cos(np.arange(op.N) * 1.3)
        err_op = max(err_op, float(np.max(np.abs(op.apply(x) - u @ x)) / np.max(np.abs(u @ x))))
        arnoldi(op.apply, op.N, np.dtype(float), k, ncv, None, c)
    for i, u in enumerate(U_all):
        prev = b.vec[i - 1] if i % len(FACTORS) else None
        v0 = prev if prev is not None and len(prev) == u.shape[0] else None
        arnoldi(lambda x, u=u: u @ x, u.shape[0], u.dtype, k, ncv, v0, d)
    n = len(rpm)
    for label, tl, extra in (("(b) eigs, formed", b, 0.0), ("(c) eigs, operator", c, t_op_build),
                             ("(d) eigs, formed, warm v0", d, 0.0)):
        _line(label, k, tl, rho_d, t_dense, t_dense_b, n)
        if extra:
            print(f"        operator setup (step exponentials and coefficients) {1e3 * extra / n:.2f} ms/pair; "
                  f"operator against the formed matrix: {err_op:.1e} (relative, one vector per pair); "
                  f"operator total {1e3 * (extra + tl.cpu_s) / n:.2f} ms/pair against dense form + eigvals "
                  f"{1e3 * (t_form + t_dense_b) / n:.2f} ms/pair")


def _line(label: str, k: int, tl: Tally, rho_d: np.ndarray, t_dense: float, t_dense_b: float, n: int) -> None:
    rho = np.array(tl.rho)
    rel = np.abs(rho / rho_d - 1)
    bad = int(np.sum((rho < 1.0) != (rho_d < 1.0)))
    print(f"    {label:26s} k = {k}: eigen part {1e3 * tl.cpu_s / n:.2f} ms/pair (dense one by one / "
          f"this {t_dense / tl.cpu_s:.2f}, dense batched / this {t_dense_b / tl.cpu_s:.2f}), "
          f"{tl.matvecs / n:.0f} matvecs/pair, no convergence {tl.noconv}/{n}, "
          f"|mu| max rel. diff {np.nanmax(rel):.1e} (median {np.nanmedian(rel):.1e}, > 1e-10 at "
          f"{int(np.sum(~(rel <= 1e-10)))}), verdicts differ {bad}/{n}", flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="5 speeds, m = 40 only (smoke run)")
    ap.add_argument("--cases", default="tx200-steel,tx200-aluminium")
    ap.add_argument("--k", default="4,6", help="eigenvalues asked of ARPACK (comma-separated)")
    ap.add_argument("--ncv", default="default,40", help="ARPACK basis sizes, comma-separated ('default': scipy's)")
    ap.add_argument("--levels", default=None, help="m levels, comma-separated (default 40,80)")
    ap.add_argument("--diagram", type=int, default=0, metavar="N",
                    help="only the refined diagrams of N speeds, dense against eigen='arnoldi'")
    args = ap.parse_args(argv)
    ncvs = tuple(None if x == "default" else int(x) for x in args.ncv.split(","))
    n_speeds, levels = (5, (40,)) if args.quick else (20, (40, 80))
    if args.levels:
        levels = tuple(int(x) for x in args.levels.split(","))
    if args.diagram:
        print("Refined diagrams, dense against Arnoldi eigenvalues; CPU of one process, one BLAS thread")
        for name in args.cases.split(","):
            bench_diagram(name, args.diagram)
        return 0
    print("Krylov (ARPACK) against dense eigenvalues, TX200 18-DOF orthogonal, Tab. 7 pose; CPU of one "
          "process, one BLAS thread")
    for name in args.cases.split(","):
        p = tx200_problem(name)
        for m in levels:
            run_case(name, p, m, n_speeds, tuple(int(x) for x in args.k.split(",")), ncvs)
    return 0


if __name__ == "__main__":
    sys.exit(main())
