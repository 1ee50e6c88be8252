"""Where the exact entries' extra CPU goes: the linearized fast path (default settings, basic model)
with its compiled loop rebuilt around variants of the entry/exit correction, timed in one process.

Variants (``timedomain.entry_exit.step_force_correction`` replaced inside the compiled loop):

* ``sampled``: no correction (``entry_exit="sampled"``, the loop as shipped);
* ``exact``: the correction as shipped (the default);
* ``screen``: only the per-element screening (which elements enter, leave or end their entry ramp
  inside the step), no event integrated (``D = 0``, so the dynamics are the sampled run's);
* ``no-ramp``: the correction without the bisection of the entry ramp's end (a split piece is
  integrated as one piece);
* ``no-cross``: the correction with each entry or exit taken at the step's end instead of bisected.

``no-ramp`` and ``no-cross`` change ``D`` (a diagnostic, not a method): their CPU against ``exact``
is the cost of the part they leave out. The CPU per simulated second (``time.process_time``) of each
is printed, the median over ``--repeat`` rounds, each round running all variants in turn.

    python bench/profile_timedomain_entry_exit.py [--alu-s 0.3] [--steel-s 1.0] [--repeat 2]
"""

from __future__ import annotations

import argparse
import inspect
import statistics
import textwrap
import time
import warnings

from numba import njit

from robolobes import cases
import robolobes.timedomain.entry_exit as ee
import robolobes.timedomain.fastpath as fp
from robolobes.linearize.model import build_model
from robolobes.timedomain.drivers import run_linearized
from robolobes.timedomain.equations import PassSetup
from robolobes.timedomain.problem import LinearizedNewmark, SimulationProblem

_SCREEN = '''
def step_force_correction(wb, x0, dx, sgn, w_top, cx0, cy0, cx1, cy1, ang0, dphi, offset, radius, db, law, h0, h1,
                          out):
    nt, nk = offset.shape
    events = 0
    for j in range(nt):
        r = radius[j]
        for k in range(nk):
            if h0[j, k] <= 0.0 and h1[j, k] <= 0.0:
                continue
            if h0[j, k] > 0.0 and h1[j, k] > 0.0:
                if (_on_block_edge(wb, x0, dx, cx0, ang0 + offset[j, k], r, k, h0[j, k], w_top)
                        == _on_block_edge(wb, x0, dx, cx1, ang0 + offset[j, k] + dphi, r, k, h1[j, k], w_top)):
                    continue
            events += 1
    return events
'''


def _variant(edit) -> object:
    """``step_force_correction`` with its source edited by ``edit`` (str -> str), compiled in the
    namespace of :mod:`timedomain.entry_exit`."""
    src = textwrap.dedent(inspect.getsource(ee.step_force_correction.py_func))
    src = edit("\n".join(ln for ln in src.splitlines() if not ln.startswith("@")))
    ns: dict = {}
    exec(src, ee.__dict__, ns)  # the project's own source, edited above
    return njit(ns["step_force_correction"])


def _loop_with(sfc) -> object:
    """The compiled loop of :mod:`timedomain.fastpath` with ``step_force_correction`` replaced."""
    py = fp._run_chunk.py_func
    g = py.__globals__
    saved = g["step_force_correction"]
    g["step_force_correction"] = sfc
    try:
        loop = njit(nogil=True)(py)
        _cpu_per_s(cases.load_case("tx200-aluminium"), 0.002, "exact", loop)  # compile now, with sfc
    finally:
        g["step_force_correction"] = saved
    return loop


def _cpu_per_s(case, t_end: float, entry_exit: str, loop) -> float:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the Tab. 7 pose is past A3's limit (accepted, warned elsewhere)
        robot = build_model(case.robot, "basic")
        S = PassSetup(SimulationProblem(robot, case, t_end_s=t_end), LinearizedNewmark(entry_exit=entry_exit))
    shipped = fp._run_chunk
    fp._run_chunk = loop
    try:
        c0 = time.process_time()
        run_linearized(S, None)
        return (time.process_time() - c0) / t_end
    finally:
        fp._run_chunk = shipped


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    ap.add_argument("--alu-s", type=float, default=0.3)
    ap.add_argument("--steel-s", type=float, default=1.0)
    ap.add_argument("--repeat", type=int, default=2)
    a = ap.parse_args(argv)
    if not (0 < a.alu_s <= 1.7 and 0 < a.steel_s <= 20 and 1 <= a.repeat <= 20):
        ap.error("--alu-s in (0, 1.7], --steel-s in (0, 20], --repeat in [1, 20]")
    shipped = fp._run_chunk
    variants = {
        "sampled": ("sampled", shipped),
        "exact": ("exact", shipped),
        "screen": ("exact", _loop_with(_variant(lambda s: _SCREEN))),
        "no-ramp": ("exact", _loop_with(_variant(lambda s: s.replace("if e_lo != e_hi:", "if False:")))),
        "no-cross": ("exact", _loop_with(_variant(
            lambda s: s.replace("0.0, enter, False)", "0.0, False, False)").replace("1.0, leave, True)",
                                                                                    "1.0, False, True)")))),
    }
    _cpu_per_s(cases.load_case("tx200-aluminium"), 0.002, "exact", shipped)  # compile or load the shipped loop
    for name, t_end in (("tx200-aluminium", a.alu_s), ("tx200-steel", a.steel_s)):
        case = cases.load_case(name)
        cpu: dict[str, list[float]] = {v: [] for v in variants}
        for _ in range(a.repeat):
            for v, (mode, loop) in variants.items():
                cpu[v].append(_cpu_per_s(case, t_end, mode, loop))
        base = statistics.median(cpu["sampled"])
        print(f"{name} ({t_end:g} s), CPU per simulated second (median of {a.repeat}), ratio to sampled: "
              + ", ".join(f"{v} {statistics.median(c):.3f} s ({statistics.median(c) / base:.3f})"
                          for v, c in cpu.items()), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
