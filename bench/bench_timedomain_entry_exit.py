"""Cost of the exact entries and exits on the eroded part: CPU per simulated second of the linearized
fast path with ``entry_exit="exact"`` (the default) against ``"sampled"`` (the force sampled at the
step ends: the kernel's arithmetic before the correction), in the same process, alternating runs.

Cases: the aluminium pass (basic model, 30 deg helix, default discs and 2 deg per step) over
``--alu-s`` seconds from the start (approach, entry into the part, full engagement), and the
steel pass over ``--steel-s`` seconds. Prints the CPU time (``time.process_time``) per simulated
second of each and the ratio exact / sampled (the median over ``--repeat`` pairs). The kernel is
compiled (or loaded) before the timings.

    python bench/bench_timedomain_entry_exit.py [--alu-s 0.4] [--steel-s 1.5] [--repeat 3]
"""

from __future__ import annotations

import argparse
import statistics
import time
import warnings

from robolobes import cases
from robolobes.linearize.model import build_model
from robolobes.timedomain.drivers import run_linearized
from robolobes.timedomain.equations import PassSetup
from robolobes.timedomain.problem import LinearizedNewmark, SimulationProblem


def _cpu_per_s(case, t_end: float, entry_exit: str) -> float:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the Tab. 7 pose is past A3's limit (accepted, warned elsewhere)
        robot = build_model(case.robot, "basic")
        S = PassSetup(SimulationProblem(robot, case, t_end_s=t_end), LinearizedNewmark(entry_exit=entry_exit))
    c0 = time.process_time()
    run_linearized(S, None)
    return (time.process_time() - c0) / t_end


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    ap.add_argument("--alu-s", type=float, default=0.4)
    ap.add_argument("--steel-s", type=float, default=1.5)
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args(argv)
    if not (0 < a.alu_s <= 1.7 and 0 < a.steel_s <= 20 and 1 <= a.repeat <= 20):
        ap.error("--alu-s in (0, 1.7], --steel-s in (0, 20], --repeat in [1, 20]")
    alu, steel = cases.load_case("tx200-aluminium"), cases.load_case("tx200-steel")
    _cpu_per_s(alu, 0.01, "exact")  # compile or load the kernel
    for name, case, t_end in (("aluminium", alu, a.alu_s), ("steel", steel, a.steel_s)):
        ratios, ex, sa = [], [], []
        for _ in range(a.repeat):
            s = _cpu_per_s(case, t_end, "sampled")
            e = _cpu_per_s(case, t_end, "exact")
            ratios.append(e / s)
            ex.append(e)
            sa.append(s)
        print(f"{name} ({t_end:g} s): CPU per simulated second exact {statistics.median(ex):.3f} s, sampled "
              f"{statistics.median(sa):.3f} s; ratio exact / sampled {statistics.median(ratios):.3f} "
              f"(runs: {', '.join(f'{r:.3f}' for r in ratios)})", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
