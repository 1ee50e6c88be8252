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

import math
import os
import sys
import time

import numpy as np
from threadpoolctl import ThreadpoolController

from robolobes import cases, linearize
from robolobes.cases.milling import Cut, CuttingLaw, Tool
from robolobes.lobes import LobeProblem, Mode, ModalStructure, PhysicalStructure, SemiDiscretization, solve


def insperger_2dof() -> LobeProblem:
    fn, zeta, mt = 922.0, 0.011, 0.03993
    k = mt * (2 * np.pi * fn) ** 2
    s = ModalStructure((Mode(fn, zeta, k, (1.0, 0.0)), Mode(fn, zeta, k, (0.0, 1.0))))
    return LobeProblem(s, Tool(diameter_m=0.01, teeth=2), Cut(ae_m=0.0005, ap_m=1e-3, spindle_rpm=1e4, mode="down"),
                       CuttingLaw(ktc_pa=6e8, krc_pa=2e8))


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
    set_vars = [v for v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS") if os.environ.get(v)]
    if set_vars:
        print(f"unset {', '.join(set_vars)} first: BLAS read them at load time and cannot be compared", file=sys.stderr)
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
