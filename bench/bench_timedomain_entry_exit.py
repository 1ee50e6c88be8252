"""Cost of the exact entries and exits on the eroded part: CPU per simulated second of the linearized
fast path with ``entry_exit="exact"`` (the default) against ``"sampled"`` (the force sampled at the
step ends: the kernel's arithmetic before the correction), in the same process, alternating runs.

The speed-ups of the kernel (the chip walk's skip of cleared columns, the removal's turned chord
vertices, the step's allocation-free 3 x 3 solve) serve both settings, so the target (the default
no slower than the sampled kernel was) is measured against a reference: the ``timedomain`` package
of ``--reference-rev`` (default 7305869, the kernel before these changes), extracted with
``git archive`` into a temporary folder and imported beside the current one, in the same process.
Its ``entry_exit="sampled"`` and ``"exact"`` runs are timed in the same rounds.

``--attribute`` times, instead, the current sampled run against the same loop with one change undone
at a time (the column-by-column chip walk, the reference's removal kernel, numba's
``np.linalg.solve``): what each change saves.

Cases: the aluminium pass (basic model, 30 deg helix, default discs and 2 deg per step) over
``--alu-s`` seconds from the start (approach, entry into the part, full engagement), and the
steel pass over ``--steel-s`` seconds. Prints the CPU time (``time.process_time``) per simulated
second of each, the ratio exact / sampled of the current kernel and the ratios of the current exact
run to the reference's sampled and exact runs (medians over ``--repeat`` rounds). The kernel is
compiled (or loaded) before the timings.

    python bench/bench_timedomain_entry_exit.py [--alu-s 0.4] [--steel-s 1.5] [--repeat 3]
        [--reference-rev 7305869]
"""

from __future__ import annotations

import argparse
import atexit
import importlib
import io
import pathlib
import shutil
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
import types
import warnings

from robolobes import cases
from robolobes.linearize.model import build_model
from robolobes.timedomain import drivers, equations, problem

_REFERENCE = "robolobes_reference_timedomain"


def _reference_package(rev: str) -> tuple:
    """``(drivers, equations, problem)`` of the ``timedomain`` package at git revision ``rev`` of this
    repository, imported as :data:`_REFERENCE` from a temporary folder (its absolute imports of the
    other robolobes packages resolve to the current ones)."""
    root = pathlib.Path(__file__).resolve().parents[1]
    tar = subprocess.run(["git", "-C", str(root), "archive", rev, "timedomain"], check=True,
                         capture_output=True).stdout
    tmp = pathlib.Path(tempfile.mkdtemp(prefix="robolobes-reference-"))
    atexit.register(shutil.rmtree, tmp, ignore_errors=True)
    with tarfile.open(fileobj=io.BytesIO(tar)) as tf:
        tf.extractall(tmp, filter="data")
    pkg = types.ModuleType(_REFERENCE)  # the package without its __init__ (which refuses another name)
    pkg.__path__ = [str(tmp / "timedomain")]
    pkg.__package__ = _REFERENCE
    sys.modules[_REFERENCE] = pkg
    return tuple(importlib.import_module(f"{_REFERENCE}.{m}") for m in ("drivers", "equations", "problem"))


def _cpu_per_s(case, t_end: float, entry_exit: str, pkg=(drivers, equations, problem)) -> float:
    drv, eqs, prb = pkg
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the Tab. 7 pose is past A3's limit (accepted, warned elsewhere)
        robot = build_model(case.robot, "basic")
        S = eqs.PassSetup(prb.SimulationProblem(robot, case, t_end_s=t_end), prb.LinearizedNewmark(entry_exit=entry_exit))
    c0 = time.process_time()
    drv.run_linearized(S, None)
    return (time.process_time() - c0) / t_end


def _loop_with(ref, edit=None, **globals_) -> object:
    """The current compiled loop with some of its globals replaced (``globals_``) and its source edited
    (``edit``: str -> str), compiled now."""
    import inspect
    import textwrap

    from numba import njit

    import robolobes.timedomain.fastpath as fp

    src = textwrap.dedent(inspect.getsource(fp._run_chunk.py_func))
    src = "\n".join(ln for ln in src.splitlines() if not ln.startswith("@"))
    if edit is not None:
        new = edit(src)
        assert new != src, "the edit did not apply"
        src = new
    ns: dict = {}
    exec(src, {**fp.__dict__, **globals_}, ns)  # the project's own loop, edited above
    return njit(nogil=True)(ns["_run_chunk"])


def _attribute(ref_wp, alu, steel, alu_s: float, steel_s: float, repeat: int) -> None:
    """CPU per simulated second of the current sampled run with each change undone (module docstring)."""
    import robolobes.timedomain.fastpath as fp
    from robolobes.timedomain.workpiece import _chip_kernel_columnwise

    solve = ("            u0, u1, u2 = _solve3(G, wv)\n",
             "            uv = np.linalg.solve(G, wv)\n            u0, u1, u2 = uv[0], uv[1], uv[2]\n")
    loops = {"current": fp._run_chunk,
             "column-by-column walk": _loop_with(None, _chip_kernel=_chip_kernel_columnwise),
             "reference removal": _loop_with(None, _remove_kernel=ref_wp._remove_kernel),
             "np.linalg.solve": _loop_with(None, lambda t: t.replace(*solve))}
    shipped = fp._run_chunk
    for name, case, t_end in (("aluminium", alu, alu_s), ("steel", steel, steel_s)):
        cpu: dict[str, list[float]] = {k: [] for k in loops}
        for i in range(repeat + 1):
            for k, loop in loops.items():
                fp._run_chunk = loop
                try:
                    c = _cpu_per_s(case, t_end if i else 0.002, "sampled")
                finally:
                    fp._run_chunk = shipped
                if i:  # the first round compiles
                    cpu[k].append(c)
        base = statistics.median(cpu["current"])
        print(f"{name} ({t_end:g} s), sampled, CPU per simulated second (median of {repeat}), ratio to current: "
              + ", ".join(f"{k} {statistics.median(v):.3f} s ({statistics.median(v) / base:.3f})"
                          for k, v in cpu.items()), flush=True)


def _runs(name: str, values: list[float]) -> str:
    return f"{name} {statistics.median(values):.3f} (runs: {', '.join(f'{r:.3f}' for r in values)})"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    ap.add_argument("--alu-s", type=float, default=0.4)
    ap.add_argument("--steel-s", type=float, default=1.5)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--reference-rev", default="7305869")
    ap.add_argument("--attribute", action="store_true")
    a = ap.parse_args(argv)
    if not (0 < a.alu_s <= 1.7 and 0 < a.steel_s <= 20 and 1 <= a.repeat <= 20):
        ap.error("--alu-s in (0, 1.7], --steel-s in (0, 20], --repeat in [1, 20]")
    alu, steel = cases.load_case("tx200-aluminium"), cases.load_case("tx200-steel")
    ref = _reference_package(a.reference_rev)
    if a.attribute:
        _attribute(importlib.import_module(f"{_REFERENCE}.workpiece"), alu, steel, a.alu_s, a.steel_s, a.repeat)
        return 0
    _cpu_per_s(alu, 0.01, "exact")  # compile or load the kernels
    _cpu_per_s(alu, 0.01, "exact", ref)
    for name, case, t_end in (("aluminium", alu, a.alu_s), ("steel", steel, a.steel_s)):
        cpu: dict[str, list[float]] = {"exact": [], "sampled": [], "reference sampled": [], "reference exact": []}
        for _ in range(a.repeat):
            cpu["reference sampled"].append(_cpu_per_s(case, t_end, "sampled", ref))
            cpu["sampled"].append(_cpu_per_s(case, t_end, "sampled"))
            cpu["exact"].append(_cpu_per_s(case, t_end, "exact"))
            cpu["reference exact"].append(_cpu_per_s(case, t_end, "exact", ref))
        ex = cpu["exact"]
        print(f"{name} ({t_end:g} s), CPU per simulated second, s: "
              + ", ".join(f"{k} {statistics.median(v):.3f}" for k, v in cpu.items())
              + "; ratios: " + "; ".join(_runs(f"exact / {k}", [e / x for e, x in zip(ex, cpu[k])])
                                         for k in ("sampled", "reference sampled", "reference exact")), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
