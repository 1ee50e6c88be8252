"""Error against cost of each lobe method on the milling benchmark, against the independent reference.

Run: .venv/bin/python bench/bench_lobes_accuracy.py [--every K] [--only TEXT] [--tx200]

For each benchmark case of ``tests/test_lobes_accuracy.py`` (reference: the independent plain SDM
of ``tests/lobes_plain_reference.py``, stored in ``tests/data/lobes_accuracy_reference.json``) and
each method, printed: the largest shifted error of the test's criterion (some n' within 0.2 % of n
with ``|b(n') - b_ref(n)|`` smallest; 0 where neighbouring n' bracket ``b_ref``), the share of
reference speeds within 1 %, the number of speeds flagged unconverged, and the CPU time of this
process per 200 speeds (the 9 shifted speeds around each reference speed are all solved: the CPU
time is scaled by 200 / their number). One BLAS thread.

``--tx200``: also the TX200 18-DOF diagrams of ``bench/bench_lobes.py --targets`` (steel and
aluminium, Tab. 7 pose, 200 speeds 2000-25000 rpm, depths to 10 mm) for the default RefinedSDM
and each Collocation row, in this process: CPU s, the largest and the median relative difference
of the limits to the default's (capped at 10 mm), the monodromy size and the unconverged speeds.
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
from robolobes.lobes.collocation import Collocation  # noqa: E402


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
        ("RefinedSDM free-exact m0 = 40, tol 1 %", RefinedSDM(SemiDiscretization(m=40, scheme="free-exact"))),
        ("ZOA", ZeroOrder()),
    ] + collocations()


def collocations():
    return [
        ("Collocation 6/8 nodes x 8 elements (default)", Collocation()),
        ("Collocation 6/8 nodes x 4 elements", Collocation(elements=4)),
        ("Collocation 8/10 nodes x 8 elements", Collocation(nodes=8)),
        ("Collocation 6 nodes x 8 elements, one level", Collocation(check_nodes=0)),
    ]


def bench_tx200(only: str) -> None:
    """The TX200 diagrams: the default RefinedSDM and the Collocation rows in this process."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from bench_lobes import tx200_problem

    speeds = np.linspace(2000, 25000, 200)
    print("TX200 case | method | CPU s | largest diff to default | median diff | monodromy size | unconverged")
    for name in ("tx200-steel", "tx200-aluminium"):
        p = tx200_problem(name)
        t0 = time.process_time()
        r0 = solve(p, RefinedSDM(), speeds, depth_max_m=10e-3)
        print(f"{name} | RefinedSDM (default) | {time.process_time() - t0:.2f} | - | - | "
              f"{r0.stats['monodromy_size']} | {int((r0.status == 'unconverged').sum())}", flush=True)
        b0 = np.minimum(r0.depth_limit_m, 10e-3)
        for label, meth in [(lab, m) for lab, m in collocations() if only in lab]:
            t0 = time.process_time()
            r = solve(p, meth, speeds, depth_max_m=10e-3)
            cpu = time.process_time() - t0
            d = np.abs(np.minimum(r.depth_limit_m, 10e-3) / b0 - 1)
            print(f"{name} | {label} | {cpu:.2f} | {100 * d.max():.2f} % | {100 * np.median(d):.3f} % | "
                  f"{r.stats['monodromy_size']} | {int((r.status == 'unconverged').sum())}", flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--every", type=int, default=1, help="use every K-th reference speed (default 1: all 101)")
    ap.add_argument("--only", default="", help="run only the methods whose label contains this text")
    ap.add_argument("--tx200", action="store_true", help="also the TX200 diagrams against the default")
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
    if args.tx200:
        bench_tx200(args.only)
    return 0


if __name__ == "__main__":
    sys.exit(main())
