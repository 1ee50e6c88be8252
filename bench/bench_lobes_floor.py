"""The least CPU any depth search can take with the default method, against the speed targets.

Run: .venv/bin/python bench/bench_lobes_floor.py [--speeds 100] [--cases tx200-steel,tx200-aluminium]
[--scheme free-exact]

The default diagram (``RefinedSDM``: levels m = 40 and 80, more where their pair has not
converged) of the TX200 18-DOF ``orthogonal`` model at the Tab. 7 pose (as ``bench_lobes.py
--targets`` builds it), 2000-25 000 rpm, depths to 10 mm. One run, in this process, with every
evaluation of the engines timed and counted per level (the free-exact prescan, then each SDM
level m): CPU of forming the monodromies (step exponentials included) and of their spectra, as
the search batches them.

The floor: a limit known to the search's tolerance needs, per speed and level, at least one
stable and one unstable evaluation (the bracket the search returns), and the error estimate needs
the two levels 40 and 80. So the floor of a diagram of S speeds is S x 2 x (cost of one evaluation
at m = 40 + at m = 80), each cost the mean CPU per evaluation of that level in this run, with no
prescan. Printed against the targets (a map pose of 100 speeds under 1.2 s of CPU; a diagram of
200 speeds under 2 s) and against the whole run, as ratios measured in the same process.
``--scheme free-exact``: the same with ``RefinedSDM(SemiDiscretization(scheme="free-exact"))`` (the
structure's free flight exact, no depth-dependent step exponentials; no prescan), whose levels
give its own floor. The process is pinned to one BLAS thread (set before numpy is imported).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from contextlib import contextmanager
from pathlib import Path
from typing import cast

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_v] = "1"

import numpy as np  # noqa: E402  (after the BLAS thread count is set)

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench_lobes import tx200_problem  # noqa: E402

from robolobes.lobes import RefinedSDM, SemiDiscretization, solve  # noqa: E402
from robolobes.lobes.sdm import Scheme, SDMEngine  # noqa: E402

#: CPU targets, s per speed: a map pose (100 speeds in 1.2 s) and a diagram (200 speeds in 2 s).
TARGETS_S_PER_SPEED = {"map pose": 1.2 / 100, "diagram": 2.0 / 200}


@contextmanager
def timed_levels():
    """While open, the engine's evaluations are timed; yields the tally
    {(scheme, m): [evaluations, cpu_s, forming_s, spectra_s]}. The engine is restored on exit."""
    tally: dict[tuple[str, int], list] = {}
    names = ("_spectra", "critical", "monodromy", "_eigvals")
    saved = {k: getattr(SDMEngine, k) for k in names}

    def entry(self):
        return tally.setdefault((self.method.scheme, self.plan.m), [0, 0.0, 0.0, 0.0])

    def timed(name, col, count):
        f = saved[name]

        def g(self, *a, **k):
            t = time.process_time()
            out = f(self, *a, **k)
            e = entry(self)
            e[col] += time.process_time() - t
            if count:
                e[0] += np.size(a[0])
            return out
        return g

    for name, col, count in (("_spectra", 1, True), ("critical", 1, False), ("monodromy", 2, False),
                             ("_eigvals", 3, False)):
        setattr(SDMEngine, name, timed(name, col, count))
    try:
        yield tally
    finally:
        for k, f in saved.items():
            setattr(SDMEngine, k, f)


def run_case(name: str, n: int, scheme: str) -> None:
    p = tx200_problem(name)
    speeds = np.linspace(2000.0, 25000.0, n)
    method = RefinedSDM(SemiDiscretization(scheme=cast(Scheme, scheme), prescan_m=20))
    solve(p, method, speeds[:4])  # warm-up (imports, caches of other speeds)
    with timed_levels() as tally:
        t = time.process_time()
        res = solve(p, method, speeds)
        total = time.process_time() - t
    levels, counts = np.unique(np.asarray(res.m_final), return_counts=True)
    print(f"{name}, scheme {scheme}, {n} speeds: {total:.2f} s of CPU; final levels " +
          ", ".join(f"m = {m}: {c}" for m, c in zip(levels, counts)))
    per = {}
    for (sch, m), (pairs, cpu, form, eig) in sorted(tally.items(), key=lambda kv: (kv[0][0] == scheme, kv[0][1])):
        label = "prescan (free-exact)" if m < method.base.m else f"SDM ({scheme})"
        per[(sch, m)] = cpu / max(pairs, 1)
        print(f"  {label} m = {m}: {pairs} evaluations ({pairs / n:.1f} per speed), {cpu:.2f} s "
              f"({1e3 * cpu / max(pairs, 1):.2f} ms each: forming {1e3 * form / max(pairs, 1):.2f}, "
              f"spectra {1e3 * eig / max(pairs, 1):.2f})")
    floor = 2 * (per[(scheme, 40)] + per[(scheme, 80)])
    print(f"  floor, one bracket per speed at m = 40 and 80, no prescan: {1e3 * floor:.2f} ms per speed, "
          f"{n * floor:.2f} s for {n} speeds; the run / the floor = {total / (n * floor):.2f}")
    for what, tgt in TARGETS_S_PER_SPEED.items():
        verdict = "below" if floor < tgt else "ABOVE"
        print(f"    {what} target {1e3 * tgt:.1f} ms per speed: floor / target = {floor / tgt:.2f} ({verdict} it); "
              f"the run / target = {total / n / tgt:.2f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--speeds", type=int, default=100, help="speeds per diagram, 4-400 (default 100)")
    ap.add_argument("--cases", default="tx200-steel,tx200-aluminium")
    ap.add_argument("--scheme", default="sdm", choices=("sdm", "free-exact"), help="the SDM scheme (default sdm)")
    a = ap.parse_args()
    if not 4 <= a.speeds <= 400:
        ap.error(f"--speeds must be in 4-400, got {a.speeds}")
    cases = [c for c in a.cases.split(",") if c]
    bad = [c for c in cases if c not in ("tx200-steel", "tx200-aluminium")]
    if bad:
        ap.error(f"--cases: unknown {bad}; valid: tx200-steel, tx200-aluminium")
    for c in cases:
        run_case(c, a.speeds, a.scheme)


if __name__ == "__main__":
    main()
