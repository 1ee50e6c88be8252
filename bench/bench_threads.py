"""Why the library limits BLAS to one thread: heavy entry points timed with 1 and with all BLAS threads.

Run (do NOT set OMP_NUM_THREADS & co., the comparison needs BLAS free to use every core):

    env -u OMP_NUM_THREADS -u OPENBLAS_NUM_THREADS -u MKL_NUM_THREADS python bench/bench_threads.py

Each workload calls the undecorated function (``f.__wrapped__``, without robolobes' own limit)
under threadpoolctl limits of 1 thread and of ``os.cpu_count()`` threads, alternating A/B three
times and keeping the fastest of each (the machine is shared: compare the printed ratio
t(all threads) / t(1 thread), not seconds). Workloads:

1. ``lobes.solve``, Insperger 2-DOF benchmark, 40 speeds, SDM m = 40;
2. ``lobes.solve``, TX200 18-DOF orthogonal at Tab. 7, aluminium cut, 10 speeds, SDM m = 40;
3. ``linearize_many`` + batch modes + 200-point FRF, 200 poses of the 18-DOF model.
"""

from __future__ import annotations

import os

# read before anything loads BLAS (bench_lobes, imported below, pins its own process to one thread)
USER_SET = [v for v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS") if os.environ.get(v)]

import math  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402  (loads BLAS with its default threads)
from threadpoolctl import ThreadpoolController  # noqa: E402

from robolobes import cases, linearize  # noqa: E402
from robolobes.lobes import LobeProblem, PhysicalStructure, SemiDiscretization, solve  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_lobes import insperger_2dof  # noqa: E402


def workloads():
    raw_solve = solve.__wrapped__
    p2 = insperger_2dof()
    yield "lobes.solve, 2-DOF benchmark, 40 speeds, m = 40", lambda: raw_solve(
        p2, SemiDiscretization(m=40), np.linspace(5000, 25000, 40), depth_max_m=10e-3)
    case = cases.load_case("tx200-aluminium")
    rob = linearize.build_model(case.robot, "orthogonal")
    lin = linearize.linearize(rob, case.robot.poses_rad["tab7"])
    p18 = LobeProblem(PhysicalStructure.from_linear(lin, case.cut.feed_direction), case.tool, case.cut, case.law)
    yield "lobes.solve, TX200 18-DOF, 10 speeds, m = 40", lambda: raw_solve(
        p18, SemiDiscretization(m=40), np.linspace(2000, 25000, 10), depth_max_m=10e-3)
    rng = np.random.default_rng(0)
    thetas = case.robot.poses_rad["tab7"] + np.radians(rng.uniform(-20, 20, (200, 6)))
    w = 2 * math.pi * np.linspace(1.0, 500.0, 200)

    def lin_batch():
        b = linearize.linearize_many.__wrapped__(rob, thetas)
        modes = type(b).modes.__wrapped__(b)
        type(b).frf.__wrapped__(b, w, modes)

    yield "linearize_many + modes + FRF, 200 poses, 18 DOF", lin_batch


def main() -> int:
    if USER_SET:
        print(f"unset {', '.join(USER_SET)} first: BLAS read them at load time and cannot be compared", file=sys.stderr)
        return 2
    ctl = ThreadpoolController()
    n_all = os.cpu_count() or 1
    print(f"BLAS libraries: {[(i['internal_api'], i['num_threads']) for i in ctl.info() if i['user_api'] == 'blas']}")
    for name, f in workloads():
        f()  # warm-up (imports, numba, caches)
        best = {1: math.inf, n_all: math.inf}
        for _ in range(3):
            for n in (1, n_all):
                with ctl.limit(limits=n, user_api="blas"):
                    t0 = time.perf_counter()
                    f()
                    best[n] = min(best[n], time.perf_counter() - t0)
        print(f"{name}: 1 thread {best[1]:.2f} s, {n_all} threads {best[n_all]:.2f} s, "
              f"ratio t({n_all}) / t(1) = {best[n_all] / best[1]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
