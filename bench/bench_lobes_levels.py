"""Cheaper routes to the refined diagram, measured and not adopted: coarser first levels, and the ZOA.

Run: .venv/bin/python bench/bench_lobes_levels.py [--skip-tx200] [--skip-benchmark]

1. **Level convergence of the TX200.** The 18-DOF ``orthogonal`` model at the Tab. 7 pose (as
   ``bench_lobes.py --targets`` builds it), steel and aluminium, 47 speeds 2000-25 000 rpm, depths
   to 10 mm: one SDM level at m = 10, 20, 40, 80, 160. Printed per case: the largest relative error
   (to the Richardson value of 80/160, this code's own reference, capped at 10 mm) of the single
   levels and of the Richardson values of 20/40 and 40/80.
2. **Cost of starting the refinement at m = 20 on the TX200** (100 speeds, CPU of this process):
   ``RefinedSDM`` from m = 20 (prescan m = 10), also with the free-exact scheme, against the default
   in the same run: the ratio, the largest difference of the limits to the default's, the statuses,
   and the CPU per speed against the map target (12 ms).
3. **A three-level order check on the benchmark.** On the reference speeds of
   ``tests/test_lobes_accuracy.py`` (the independent plain SDM, ``tests/data``): one level at
   m = 10, 20, 40. The rule tried: accept the pair 20/40 where its estimate ``|b40 - b20| / 3``
   is at most 1 % of its value and the observed order is about 2 (``(b20 - b10) / (b40 - b20)`` in
   [3, 5.3], i.e. order 1.6 to 2.4; or ``|b40 - b20|`` below 1e-5 of the value), else the default
   (from 40/80). Printed per case, at the speeds it accepts: how many, the largest pointwise error
   of the pair's Richardson value to the reference, the speeds where that error exceeds the
   pair's own estimate by more than the reference's 0.2 %, and the default's largest pointwise
   error at the same speeds.
4. **The ZOA on the TX200** (200 speeds, default range): the largest and the number of relative
   differences over 1 % to the default ``RefinedSDM``, both capped at 10 mm. And a first-harmonic
   check of each ZOA limit, written here (not in the library): the Hill matrix with harmonics
   -1, 0, 1 of the tooth frequency at the ZOA's chatter frequency and depth (blocks
   ``G(i(w + k wT)) A_(k-j)``, ``A_r`` the Fourier coefficients over the tooth period of the
   directional matrix of the whole cutter per unit depth, from ``DirectionalPlan.wbar`` with 512
   steps); the check flags a limit where the eigenvalue nearest the ZOA's moves by more than 1 %.
   Printed: how many of the ZOA limits more than 1 % off are flagged, and the largest miss not
   flagged, on the benchmark and on the TX200.
5. **The pairs 30/40 and 30/45** (``RefinedSDM`` from m = 30 with level ratio 4/3: 30, 40, 53 ...,
   and 1.5: 30, 45, 68 ...; prescan m = 20). On the TX200 (100 speeds, as item 2): CPU against
   the default in the same run, the largest difference of the limits to the default's, the
   statuses. On the benchmark, at the reference speeds (as item 3): the largest pointwise error to
   the reference (which has its own error, up to 0.2 %), the speeds where it is over 1 % while
   the method's own estimate is at most 1 %, the speeds where it exceeds that estimate by more
   than 0.2 %, and the same for the default.

One BLAS thread.
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_v] = "1"

import argparse  # noqa: E402
import math  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import lobes_plain_reference as ref  # noqa: E402
from bench_lobes import tx200_problem  # noqa: E402
from test_lobes_accuracy import lobe_problem  # noqa: E402

from robolobes.lobes import LobeProblem, RefinedSDM, SemiDiscretization, ZeroOrder, solve  # noqa: E402
from robolobes.lobes.directional import DirectionalPlan  # noqa: E402
from robolobes.lobes.zoa import ZOAEngine  # noqa: E402

DEPTH_MAX_M = 10e-3
TOL = 0.01
ORDER_RATIO = (3.0, 5.3)  # (b20 - b10) / (b40 - b20): observed order 1.6 to 2.4 at level ratio 2
MAP_TARGET_S_PER_SPEED = 1.2 / 100


def levels(p: LobeProblem, rpm: np.ndarray, ms, depth_max_m: float) -> dict[int, np.ndarray]:
    """One SDM level per m: the limits (S,), m, capped at ``depth_max_m``."""
    return {m: np.minimum(solve(p, SemiDiscretization(m=m), rpm, depth_max_m=depth_max_m).depth_limit_m,
                          depth_max_m) for m in ms}


def richardson2(b_coarse: np.ndarray, b_fine: np.ndarray) -> np.ndarray:
    """Second-order Richardson value of two levels at ratio 2: ``b_f + (b_f - b_c) / 3``."""
    return b_fine + (b_fine - b_coarse) / 3


def tx200_levels() -> None:
    rpm = np.linspace(2000, 25000, 47)
    print("1. TX200 18-DOF orthogonal, Tab. 7 pose, 47 speeds: largest relative error to Richardson 80/160 "
          "(this code's own reference)")
    print("case | m = 10 | m = 20 | m = 40 | m = 80 | Richardson 20/40 | Richardson 40/80")
    for name in ("tx200-steel", "tx200-aluminium"):
        b = levels(tx200_problem(name), rpm, (10, 20, 40, 80, 160), DEPTH_MAX_M)
        best = richardson2(b[80], b[160])
        use = best < DEPTH_MAX_M * (1 - 1e-3)

        def err(v):
            return f"{100 * np.max(np.abs(v[use] / best[use] - 1)):.3f} %"
        print(f"{name} | " + " | ".join(err(b[m]) for m in (10, 20, 40, 80))
              + f" | {err(richardson2(b[20], b[40]))} | {err(richardson2(b[40], b[80]))}", flush=True)


def tx200_cost() -> None:
    rows = [("RefinedSDM from m = 20, prescan m = 10", RefinedSDM(SemiDiscretization(m=20, prescan_m=10))),
            ("RefinedSDM free-exact from m = 20, prescan m = 10",
             RefinedSDM(SemiDiscretization(m=20, scheme="free-exact", prescan_m=10)))]
    against_default("2. TX200, 100 speeds, CPU of this process: starting the refinement at m = 20 against the default",
                    rows)


PAIRS = (("pair 30/40", RefinedSDM(SemiDiscretization(m=30, prescan_m=20), ratio=4 / 3)),
         ("pair 30/45", RefinedSDM(SemiDiscretization(m=30, prescan_m=20), ratio=1.5)))


def tx200_pairs() -> None:
    against_default("5a. TX200, 100 speeds, CPU of this process: the pairs from m = 30 against the default", PAIRS)


def against_default(title: str, rows) -> None:
    """The default and each ``(label, method)`` of ``rows`` on the TX200 steel and aluminium
    diagrams (100 speeds): CPU, ratio, largest difference of the limits, statuses, ms per speed."""
    rpm = np.linspace(2000, 25000, 100)
    print(title)
    print("case | method | CPU s | ratio to the default | largest diff to the default | statuses | "
          "ms per speed / map target (12 ms)")
    for name in ("tx200-steel", "tx200-aluminium"):
        p = tx200_problem(name)
        t0 = time.process_time()
        r0 = solve(p, RefinedSDM(), rpm, depth_max_m=DEPTH_MAX_M)
        c0 = time.process_time() - t0
        b0 = np.minimum(r0.depth_limit_m, DEPTH_MAX_M)
        print(f"{name} | RefinedSDM (default) | {c0:.2f} | 1 | - | {_statuses(r0.status)} | "
              f"{1e3 * c0 / len(rpm):.1f} / {c0 / len(rpm) / MAP_TARGET_S_PER_SPEED:.2f}", flush=True)
        for label, meth in rows:
            t0 = time.process_time()
            r = solve(p, meth, rpm, depth_max_m=DEPTH_MAX_M)
            c = time.process_time() - t0
            d = np.abs(np.minimum(r.depth_limit_m, DEPTH_MAX_M) / b0 - 1)
            print(f"{name} | {label} | {c:.2f} | {c0 / c:.2f} | {100 * d.max():.3f} % | {_statuses(r.status)} | "
                  f"{1e3 * c / len(rpm):.1f} / {c / len(rpm) / MAP_TARGET_S_PER_SPEED:.2f}", flush=True)


def benchmark_pairs() -> None:
    print("5b. benchmark (independent plain reference, its own error up to 0.2 %), at the reference speeds")
    print("case | method | largest pointwise error | over 1 % with an estimate <= 1 % | "
          "above the own estimate + 0.2 % | finite limits")
    for name, rpm, b_ref, p in reference_cases():
        for label, meth in (("default", RefinedSDM()),) + PAIRS:
            r = solve(p, meth, rpm, depth_max_m=ref.DEPTH_MAX)
            b, e = r.depth_limit_m, r.depth_error_m
            fin = np.isfinite(b) & np.isfinite(b_ref) & (b_ref < ref.DEPTH_MAX)
            err = np.abs(b[fin] / b_ref[fin] - 1)
            over = (err > TOL) & (e[fin] <= TOL * b[fin])
            under = err > e[fin] / b[fin] + ref.REF_TOL
            print(f"{name} | {label} | {100 * err.max():.3f} % | {int(over.sum())} | {int(under.sum())} | "
                  f"{int(fin.sum())}", flush=True)


def reference_cases():
    """Each benchmark case of ``tests/data`` at its usable reference speeds: ``(name, rpm (S,),
    reference limits (S,) m (inf: stable up to the searched depth), LobeProblem)``."""
    for name, rows in ref.load()["cases"].items():
        rows = [r for r, ok in zip(rows, ref.usable(rows)) if ok]
        yield (name, np.array([r["rpm"] for r in rows]), np.array([r["depth_m"] for r in rows], dtype=float),
               lobe_problem(name))


def _statuses(status: np.ndarray | None) -> str:
    if status is None:
        return "no status"
    u, n = np.unique(status, return_counts=True)
    return ", ".join(f"{k} {v}" for k, v in zip(u, n))


def order_checked(b: dict[int, np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The rule of item 3 on the levels 10, 20, 40 (each (S,), m): the pair 20/40's value and
    estimate (S,), m, and where it is accepted (S,) bool."""
    d1, d2 = b[20] - b[10], b[40] - b[20]
    value, est = richardson2(b[20], b[40]), np.abs(d2) / 3
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = d1 / d2
    tiny = np.abs(d2) <= 1e-5 * value
    accept = (est <= TOL * value) & (tiny | ((ratio >= ORDER_RATIO[0]) & (ratio <= ORDER_RATIO[1])))
    return value, est, accept


def benchmark_order_check() -> None:
    print("3. benchmark (independent plain reference): the pair 20/40 where an order check passes (else the default)")
    print("case | accepted at 20/40 | largest pointwise error there | there above the estimate + 0.2 % | "
          "the default's largest pointwise error at the same speeds")
    for name, rpm, b_ref, p in reference_cases():
        b_ref = np.minimum(b_ref, ref.DEPTH_MAX)
        value, est, accept = order_checked(levels(p, rpm, (10, 20, 40), ref.DEPTH_MAX))
        default = np.minimum(solve(p, RefinedSDM(), rpm, depth_max_m=ref.DEPTH_MAX).depth_limit_m, ref.DEPTH_MAX)
        use = accept & (b_ref < ref.DEPTH_MAX * (1 - 1e-3))
        err = np.abs(value / b_ref - 1)
        over = use & (err > est / value + ref.REF_TOL)
        worst = f"{100 * err[use].max():.2f} %" if use.any() else "-"
        worst0 = f"{100 * np.abs(default / b_ref - 1)[use].max():.2f} %" if use.any() else "-"
        print(f"{name} | {int(accept.sum())} of {len(rpm)} | {worst} | {int(over.sum())} | {worst0}", flush=True)


def first_harmonic_shift(p: LobeProblem, rpm: np.ndarray, b: np.ndarray, f_hz: np.ndarray, steps: int = 512):
    """Relative move of the ZOA eigenvalue when the harmonics -1, 0, 1 are kept (S,); nan where no limit."""
    eng = ZOAEngine(p, ZeroOrder())
    plan = DirectionalPlan.build(p.tool, p.cut, p.law, m=steps, quadrature=8,
                                 slices=16 if p.tool.helix_rad else 1, k_force=eng.k)
    i = np.arange(steps)
    out = np.full(len(rpm), np.nan)

    def receptance(w: float) -> np.ndarray:  # (2, k), m/N; G(-w) = conj G(w) for a real structure
        g = eng._receptance(np.array([abs(w)]))[:2, :eng.k, 0]
        return g if w >= 0 else g.conj()
    for s in np.flatnonzero(np.isfinite(b)):
        W = plan.wbar(np.array([b[s]]), i)[0].sum(axis=1) / b[s]  # (steps, k, 2), whole cutter per unit depth

        def coef(r: int) -> np.ndarray:  # Fourier coefficient over the tooth period (step averages undone)
            if r == 0:
                return W.mean(axis=0)
            x = r * math.pi / steps
            return (W * np.exp(-2j * math.pi * r * (i + 0.5) / steps)[:, None, None]).mean(axis=0) * x / math.sin(x)
        T = float(plan.period_s(rpm[s]))
        w, wT = 2 * math.pi * f_hz[s], 2 * math.pi / T
        G = {k: receptance(w + k * wT) for k in (-1, 0, 1)}
        hill = np.block([[G[k] @ coef(k - j) for j in (-1, 0, 1)] for k in (-1, 0, 1)])
        zoa = np.linalg.eigvals(G[0] @ coef(0))
        nu0 = zoa[np.argmin(np.abs(zoa - 1 / (b[s] * (1 - np.exp(-1j * w * T)))))]
        nu = np.linalg.eigvals(hill)
        out[s] = np.abs(nu[np.argmin(np.abs(nu - nu0))] - nu0) / abs(nu0)
    return out


def zoa_check(tx200: bool) -> None:
    print("4. the ZOA against the reference; a first-harmonic check of each ZOA limit (flag: > 1 %)")
    print("case | ZOA limits | over 1 % off | largest (where, ZOA above or below) | flagged among those over 1 % | flagged among those within 1 % | largest not flagged")
    cases = [(name, p, rpm, np.minimum(b_ref, ref.DEPTH_MAX), "the independent reference")
             for name, rpm, b_ref, p in reference_cases()]
    for name in ("tx200-steel", "tx200-aluminium") if tx200 else ():
        p = tx200_problem(name)
        rpm = np.linspace(2000, 25000, 200)
        b0 = np.minimum(solve(p, RefinedSDM(), rpm, depth_max_m=DEPTH_MAX_M).depth_limit_m, DEPTH_MAX_M)
        cases.append((name, p, rpm, b0, "the default RefinedSDM"))
    for name, p, rpm, b_ref, against in cases:
        r = solve(p, ZeroOrder(), rpm, depth_max_m=DEPTH_MAX_M)
        b = np.asarray(r.depth_limit_m, dtype=float)
        found = b < DEPTH_MAX_M
        shift = first_harmonic_shift(p, rpm, np.where(found, b, np.nan), np.asarray(r.chatter_freq_hz, dtype=float))
        err = np.abs(np.minimum(b, DEPTH_MAX_M) / b_ref - 1)
        off, flag = found & (err > TOL), found & (shift > TOL)
        j = _largest(err, found)
        side = "above" if b[j] > b_ref[j] else "below"
        print(f"{name} (against {against}) | {int(found.sum())} of {len(rpm)} | {int(off.sum())} | "
              f"{_worst(err, rpm, found)} ({side}) | {int((off & flag).sum())} of {int(off.sum())} | "
              f"{int((found & ~off & flag).sum())} of {int((found & ~off).sum())} | {_worst(err, rpm, off & ~flag)}",
              flush=True)


def _largest(err: np.ndarray, where: np.ndarray) -> int:
    """Index of the largest of ``err`` (S,) where ``where`` (S,) holds (some must)."""
    return int(np.argmax(np.where(where, err, -1.0)))


def _worst(err: np.ndarray, rpm: np.ndarray, where: np.ndarray) -> str:
    """The largest of ``err`` (S,) where ``where`` (S,) holds, with its speed; '-' if none."""
    if not where.any():
        return "-"
    j = _largest(err, where)
    return f"{100 * err[j]:.0f} % at {rpm[j]:.0f} rpm"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--skip-tx200", action="store_true", help="only the benchmark items (3, 4 without the TX200, 5b)")
    ap.add_argument("--skip-benchmark", action="store_true", help="only the TX200 items (1, 2, 5a)")
    args = ap.parse_args(argv)
    if not args.skip_tx200:
        tx200_levels()
        tx200_cost()
    if not args.skip_benchmark:
        benchmark_order_check()
        zoa_check(not args.skip_tx200)
    if not args.skip_tx200:
        tx200_pairs()
    if not args.skip_benchmark:
        benchmark_pairs()
    return 0


if __name__ == "__main__":
    sys.exit(main())
