"""Quick study: wall time without and with sharing robots, linearizations and simulated runs.

Both are timed in this one process, one after the other, after a warm-up that loads the compiled
(numba) kernels, so that neither pays the one-time compilation:

* "before": ``Linearizations(share=False)``: every section builds and linearizes its own robot,
  and the damping search and the time-domain section each simulate their runs (the behaviour of
  the study before sharing);
* "after": the default shared cache.

Prints the wall and CPU (process) times, the number of linearizations and of simulated passes,
and the ratios (single-threaded BLAS: the CPU time is the work done, the wall time also counts the
time spent waiting for a core when others are busy).
Usage: python bench/bench_study.py   (about 2 x the quick study's time)
"""

from __future__ import annotations

import time

from robolobes.study.compute import compute_study
from robolobes.study.linearizations import Linearizations
from robolobes.study.settings import StudySettings


def _warm_up() -> None:
    from robolobes import cases
    from robolobes.linearize.model import build_model
    from robolobes.timedomain import LinearizedNewmark, SimulationProblem, simulate
    case = cases.load_case("tx200-steel")
    simulate(SimulationProblem(build_model(case.robot, "basic"), case, t_end_s=0.05), LinearizedNewmark())


def _timed(share: bool):
    import robolobes.study.compute as compute
    calls = {"n": 0}
    inner = compute._simulate_run

    def counting(*a, **k):
        calls["n"] += 1
        return inner(*a, **k)

    compute._simulate_run = counting
    try:
        lins = Linearizations(share=share)
        t0, c0 = time.perf_counter(), time.process_time()
        res = compute_study(StudySettings.make(quick=True), lins=lins)
        return time.perf_counter() - t0, time.process_time() - c0, lins.linearize_calls, calls["n"], res
    finally:
        compute._simulate_run = inner


def main() -> None:
    _warm_up()
    rows = {}
    for name, share in (("before (no sharing)", False), ("after (shared)", True)):
        wall, cpu, n_lin, n_sim, res = _timed(share)
        rows[name] = (wall, cpu)
        print(f"{name:22s} wall {wall:7.1f} s, CPU {cpu:7.1f} s, {n_lin:3d} linearizations in the study's sections, "
              f"{n_sim:2d} passes simulated; steel damping brackets: lobes {res.damping_lobes.bracket}, "
              f"time domain {res.damping_time_domain.bracket}", flush=True)
    (wa, ca), (wb, cb) = rows.values()
    print(f"ratio before / after: wall {wa / wb:.2f}, CPU {ca / cb:.2f} (on a shared machine the CPU time is the "
          "measure; the wall time includes waiting for the cores)")


if __name__ == "__main__":
    main()
