"""Error against cost of each lobe method on the milling benchmark, against the independent reference.

Run: .venv/bin/python bench/bench_lobes_accuracy.py [--every K] [--only TEXT]

For each benchmark case of ``tests/test_lobes_accuracy.py`` (reference: the independent plain SDM
of ``tests/lobes_plain_reference.py``, stored in ``tests/data/lobes_accuracy_reference.json``) and
each method, printed: the largest shifted error of the test's criterion (some n' within 0.2 % of n
with ``|b(n') - b_ref(n)|`` smallest; 0 where neighbouring n' bracket ``b_ref``), the share of
reference speeds within 1 %, the number of speeds flagged unconverged, and the CPU time of this
process per 200 speeds (the 9 shifted speeds around each reference speed are all solved: the CPU
time is scaled by 200 / their number). One BLAS thread.
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

import lobes_plain_reference as ref  # noqa: E402
from test_lobes_accuracy import lobe_problem  # noqa: E402

from robolobes.lobes import RefinedSDM, SemiDiscretization, ZeroOrder, solve  # noqa: E402


def methods():
    return [
        ("SDM m = 40 (one level)", SemiDiscretization(m=40)),
        ("SDM m = 80 (one level)", SemiDiscretization(m=80)),
        ("SDM m = 160 (one level)", SemiDiscretization(m=160)),
        ("SDM m = 40/80 Richardson", SemiDiscretization(m=40, richardson=True)),
        ("RefinedSDM m0 = 40, tol 1 % (default, fast search)", RefinedSDM()),
        ("RefinedSDM m0 = 40, tol 1 %, plain search (previous default)",
         RefinedSDM(SemiDiscretization(search="plain"))),
        ("RefinedSDM m0 = 20, tol 1 %", RefinedSDM(SemiDiscretization(m=20))),
        ("RefinedSDM free-exact m0 = 20, tol 1 %", RefinedSDM(SemiDiscretization(m=20, scheme="free-exact"))),
        ("ZOA", ZeroOrder()),
    ]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--every", type=int, default=1, help="use every K-th reference speed (default 1: all 101)")
    ap.add_argument("--only", default="", help="run only the methods whose label contains this text")
    args = ap.parse_args(argv)
    data = ref.load()
    print("case | method | max shifted error | within 1 % | unconverged | CPU s per 200 speeds")
    for name, rows in data["cases"].items():
        rows = [r for r, ok in zip(rows, ref.usable(rows)) if ok][:: args.every]
        rpm = np.array([r["rpm"] for r in rows])
        b_ref = np.array([r["depth_m"] for r in rows])
        sp = ref.shifted_speeds(rpm)
        p = lobe_problem(name)
        for label, meth in [(lab, m) for lab, m in methods() if args.only in lab]:
            t0 = time.process_time()
            res = solve(p, meth, sp.reshape(-1), depth_max_m=ref.DEPTH_MAX)
            cpu = (time.process_time() - t0) * 200 / sp.size
            err = ref.shifted_error(res.depth_limit_m.reshape(sp.shape), b_ref)
            nu = int((res.status == "unconverged").sum())
            print(f"{name} | {label} | {100 * err.max():.2f} % | {100 * np.mean(err <= ref.TOL):.0f} % of "
                  f"{len(err)} | {nu} of {sp.size} | {cpu:.2f}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
