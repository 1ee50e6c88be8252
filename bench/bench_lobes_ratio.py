"""Level ratio of the refined SDM: the pairs (40, 80), (80, 160) ... against (40, 60), (60, 90) ...

Run: .venv/bin/python bench/bench_lobes_ratio.py [--rounds N] [--every K] [--skip-tx200] [--skip-accuracy]

1. The TX200 18-DOF diagrams of ``bench/bench_lobes.py --targets`` (steel and aluminium, orthogonal
   model, Tab. 7 pose, 200 speeds 2000-25000 rpm, depths to 10 mm) with ``RefinedSDM()`` (ratio 2,
   the default) and ``RefinedSDM(ratio=1.5)``, in this process: CPU seconds (the smallest of
   ``--rounds`` rounds, the order of the two methods alternating between rounds), the ratio of the
   CPU times, the largest relative difference of the limits (capped at 10 mm), the speeds per final
   level and the statuses.
2. The benchmark cases of ``tests/test_lobes_accuracy.py`` against the independent reference
   (``tests/lobes_plain_reference.py``): for each ratio the largest shifted error of the test's
   criterion, the share of reference speeds within 1 %, the speeds flagged unconverged and the CPU
   per 200 speeds (the 9 shifted speeds around each reference speed are all solved); and at the
   reference speeds themselves, where both limits are finite, the largest pointwise relative error
   and the speeds whose error to the reference exceeds the method's own estimate, with the largest
   of those errors (the reference has its own error, at most 0.2 % of its value).

One BLAS thread; CPU time of this process (``time.process_time``).
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_v] = "1"

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import lobes_plain_reference as ref  # noqa: E402
from bench_lobes import tx200_problem  # noqa: E402
from test_lobes_accuracy import lobe_problem  # noqa: E402

from robolobes.lobes import RefinedSDM, solve  # noqa: E402

RATIOS = (2.0, 1.5)
DEPTH_MAX = 10e-3  # m, the searched depth of the TX200 diagrams


def _levels(res) -> str:
    """Speeds per final level, e.g. '80: 197, 160: 3'."""
    m, n = np.unique(res.m_final, return_counts=True)
    return ", ".join(f"{a}: {b}" for a, b in zip(m.tolist(), n.tolist()))


def bench_tx200(rounds: int) -> None:
    """Section 1: CPU and limits of the two ratios on the TX200 diagrams."""
    speeds = np.linspace(2000, 25000, 200)
    print("TX200 case | ratio | CPU s (min of rounds) | all rounds | speeds per final level | unconverged")
    for name in ("tx200-steel", "tx200-aluminium"):
        p = tx200_problem(name)
        cpu: dict[float, list[float]] = {r: [] for r in RATIOS}
        res = {}
        for k in range(rounds):
            for r in (RATIOS if k % 2 == 0 else RATIOS[::-1]):
                t0 = time.process_time()
                res[r] = solve(p, RefinedSDM(ratio=r), speeds, depth_max_m=DEPTH_MAX)
                cpu[r].append(time.process_time() - t0)
        for r in RATIOS:
            print(f"{name} | {r:g} | {min(cpu[r]):.2f} | {' '.join(f'{t:.2f}' for t in cpu[r])} | "
                  f"{_levels(res[r])} | {int((res[r].status == 'unconverged').sum())}", flush=True)
        a, b = (np.minimum(res[r].depth_limit_m, DEPTH_MAX) for r in RATIOS)
        d = np.abs(b / a - 1)
        print(f"{name}: CPU ratio 2 / 1.5 = {min(cpu[2.0]) / min(cpu[1.5]):.2f}; limits differ by up to "
              f"{100 * d.max():.3f} % (median {100 * np.median(d):.4f} %) at {speeds[int(np.argmax(d))]:.0f} rpm; "
              f"same statuses {bool(np.all(res[2.0].status == res[1.5].status))}", flush=True)


def bench_accuracy(every: int) -> None:
    """Section 2: the accuracy criterion of tests/test_lobes_accuracy.py for both ratios."""
    print("case | ratio | max shifted error | within 1 % | unconverged | CPU s per 200 speeds | "
          "pointwise max error at n | pointwise error above the estimate | largest such error")
    for name, rows in ref.load()["cases"].items():
        rows = [r for r, ok in zip(rows, ref.usable(rows)) if ok][::every]
        b_ref = np.array([r["depth_m"] for r in rows])
        sp = ref.shifted_speeds(np.array([r["rpm"] for r in rows]))
        p = lobe_problem(name)
        for r in RATIOS:
            t0 = time.process_time()
            res = solve(p, RefinedSDM(ratio=r), sp.reshape(-1), depth_max_m=ref.DEPTH_MAX)
            cpu = (time.process_time() - t0) * 200 / sp.size
            err = ref.shifted_error(res.depth_limit_m.reshape(sp.shape), b_ref)
            nu = int((res.status == "unconverged").sum())
            pw, over, n, pw_over = _pointwise(res, sp.shape, b_ref)
            print(f"{name} | {r:g} | {100 * err.max():.3f} % | {100 * np.mean(err <= ref.TOL):.0f} % of "
                  f"{len(err)} | {nu} of {sp.size} | {cpu:.2f} | {100 * pw:.3f} % | {over} of {n} | "
                  f"{100 * pw_over:.3f} %", flush=True)


def _pointwise(res, shape, b_ref) -> tuple[float, int, int, float]:
    """At the reference speeds themselves (k = 0 of the shifted speeds), where both limits are
    finite: the largest relative error to the reference, the speeds whose error exceeds the
    method's own estimate, their number, and the largest relative error among those (0: none)."""
    b = res.depth_limit_m.reshape(shape)[:, shape[1] // 2]
    e = res.depth_error_m.reshape(shape)[:, shape[1] // 2]
    fin = np.isfinite(b) & np.isfinite(b_ref) & (b_ref < ref.DEPTH_MAX)
    d = np.abs(b[fin] - b_ref[fin])
    rel, over = d / b_ref[fin], d > e[fin]
    return float(rel.max()), int(over.sum()), int(fin.sum()), float(rel[over].max(initial=0.0))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rounds", type=int, default=2, help="rounds of the TX200 diagrams (default 2)")
    ap.add_argument("--every", type=int, default=1, help="every K-th reference speed (default 1: all)")
    ap.add_argument("--skip-tx200", action="store_true")
    ap.add_argument("--skip-accuracy", action="store_true")
    args = ap.parse_args(argv)
    if not args.skip_tx200:
        bench_tx200(args.rounds)
    if not args.skip_accuracy:
        bench_accuracy(args.every)
    return 0


if __name__ == "__main__":
    sys.exit(main())
