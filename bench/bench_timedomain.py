"""Benchmark: wall time per simulated second of a milling pass, full and linearized paths.

18-DOF ``backlash`` variant, aluminium and steel (paper Tab. 7-9). Slices simulated from t = 0
(the integration only; the model set-up is timed separately):

* aluminium: 0.3 s -- 1 mm approach (entry at 0.063 s), entry, and 0.07 s of full engagement;
  the whole pass is 1.754 s simulated;
* steel: 1.5 s -- approach (entry at 0.264 s) and 1.24 s of cutting while the tool enters the
  part (full engagement from 2.41 s; the whole pass is 21.96 s simulated).

Prints, per case and path, the wall time per simulated second, the cost per step, and both as a
ratio to a reference operation timed in the same process (1000 pinocchio ``rnea`` calls on the
same 18-DOF model: these machines are noisy, compare ratios), the ratio full / linearized (target
>= 10) and the full aluminium pass extrapolated from the slice (target < 5 min on one core;
``--full-pass`` measures it). numba compile time is excluded from the ratios (the compiled loop is
warmed up first) and measured separately in fresh subprocesses: cold (empty numba cache: the
workpiece kernels and the fast-path kernel compile) and warm (loaded from that cache).

    python bench/bench_timedomain.py [--alu-s 0.3] [--steel-s 1.5] [--repeat 3] [--full-pass]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
import warnings

import numpy as np
import pinocchio as pin

from robolobes import cases
from robolobes.linearize.model import build_model
from robolobes.timedomain.drivers import run_full, run_linearized
from robolobes.timedomain.equations import PassSetup
from robolobes.timedomain.problem import LinearizedNewmark, NonlinearNewmark, SimulationProblem

VARIANT = "backlash"

_COMPILE_SNIPPET = r"""
import time, warnings
warnings.simplefilter("ignore")
t0 = time.perf_counter()
from robolobes import cases
from robolobes.linearize.model import build_model
from robolobes.timedomain.equations import PassSetup, linear_system_data
from robolobes.timedomain.problem import LinearizedNewmark, SimulationProblem
case = cases.load_case("tx200-aluminium")
S = PassSetup(SimulationProblem(build_model(case.robot, "backlash"), case, t_end_s=0.001), LinearizedNewmark())
d = linear_system_data(S)
t1 = time.perf_counter()
from robolobes.timedomain.fastpath import run_linear_milling
run_linear_milling(d, S.milling, h_s=S.h, n_steps=S.n_steps, omega_rad_s=S.omega)
t2 = time.perf_counter()
print(t2 - t1)
"""


def _first_call_s(cache_dir: str) -> float:
    """Seconds of the first fast-path call (import + compile or cache load + a 56-step run) in a
    fresh interpreter whose numba cache is ``cache_dir``."""
    env = dict(os.environ, NUMBA_CACHE_DIR=cache_dir)
    out = subprocess.run([sys.executable, "-c", _COMPILE_SNIPPET], env=env, capture_output=True, text=True,
                         check=True)
    return float(out.stdout.strip().splitlines()[-1])


def _reference_s(S: PassSetup, n: int = 1000, repeat: int = 5) -> float:
    """Median time of ``n`` pinocchio rnea calls on the setup's model, s."""
    model, data = S.robot.model, S.robot.create_data()
    q = S.q_eq.copy()
    v = np.full(model.nv, 0.01)
    a = np.full(model.nv, 0.1)
    out = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(n):
            pin.rnea(model, data, q, v, a)
        out.append(time.perf_counter() - t0)
    return statistics.median(out)


def _setup(case, t_end, linearized):
    method = LinearizedNewmark() if linearized else NonlinearNewmark()
    return PassSetup(SimulationProblem(build_model(case.robot, VARIANT), case, t_end_s=t_end), method)


def _time_run(case, t_end, linearized):
    t0 = time.perf_counter()
    S = _setup(case, t_end, linearized)
    t1 = time.perf_counter()
    rec = (run_linearized if linearized else run_full)(S, None)
    t2 = time.perf_counter()
    assert rec.stats["steps"] == S.n_steps
    return S, t1 - t0, t2 - t1, rec.stats


def main(alu_s: float = 0.3, steel_s: float = 1.5, repeat: int = 3, full_pass: bool = False) -> None:
    warnings.simplefilter("ignore")  # the Tab. 7 pose's A3 joint-limit warning
    with tempfile.TemporaryDirectory() as cache:
        cold = _first_call_s(cache)
        warm = _first_call_s(cache)

    alu, steel = cases.load_case("tx200-aluminium"), cases.load_case("tx200-steel")
    # warm up the compiled loop (cache load or compile) and the full path's first calls
    _time_run(alu, 0.002, True)
    _time_run(alu, 0.002, False)

    S_ref = _setup(alu, 0.001, False)
    refs = [_reference_s(S_ref)]
    rows = {}
    for case, t_sim in ((alu, alu_s), (steel, steel_s)):
        lin = [_time_run(case, t_sim, True) for _ in range(repeat)]
        full = _time_run(case, t_sim, False)
        refs.append(_reference_s(S_ref))
        rows[case.name] = dict(t_sim=t_sim, S=full[0], setup=full[1], full=full[2], full_stats=full[3],
                               lin=statistics.median(x[2] for x in lin), lin_all=[x[2] for x in lin],
                               lin_stats=lin[0][3], lin_setup=lin[0][1])
    ref = statistics.median(refs)

    print(f"time-domain benchmark: TX200, {VARIANT} variant ({S_ref.robot.nv} DOF), one core")
    print(f"reference: 1000 pinocchio rnea calls = {ref * 1e3:.2f} ms (median of {5 * len(refs)} timings; "
          f"spread {min(refs) * 1e3:.2f}-{max(refs) * 1e3:.2f} ms)")
    print(f"numba first call (fresh process): cold compile {cold:.1f} s, from the cache {warm:.2f} s "
          f"(excluded from the times below)")
    print()
    print(f"{'case':<16}{'slice':>8}{'steps':>8}  {'path':<11}{'wall/sim s':>11}{'x ref':>8}{'us/step':>9}"
          f"{'x ref/1000':>11}  Newton it/step")
    for name, r in rows.items():
        S = r["S"]
        n = S.n_steps
        for path, wall, st in (("full", r["full"], r["full_stats"]), ("linearized", r["lin"], r["lin_stats"])):
            per_s = wall / r["t_sim"]
            print(f"{name:<16}{r['t_sim']:>7.2f}s{n:>8d}  {path:<11}{per_s:>10.2f}s{per_s / ref:>8.0f}"
                  f"{wall / n * 1e6:>9.1f}{wall / n / ref * 1000:>11.2f}  {st['newton_iterations'] / n:.2f}")
        ratio = r["full"] / r["lin"]
        print(f"{'':<16}full / linearized = {ratio:.1f}  (target >= 10: {'met' if ratio >= 10 else 'NOT met'}); "
              f"linearized runs {', '.join(f'{x:.2f}' for x in r['lin_all'])} s (median used); "
              f"set-up {r['setup']:.2f} s (full), {r['lin_setup']:.2f} s (linearized)")
    a = rows[alu.name]
    pass_s = a["S"].pas.duration_s
    extrap = a["full"] / a["t_sim"] * pass_s
    print()
    print(f"full aluminium pass ({pass_s:.3f} s simulated), full path, extrapolated from the {a['t_sim']} s slice: "
          f"{extrap:.0f} s = {extrap / 60:.1f} min (target < 5 min: {'met' if extrap < 300 else 'NOT met'}); "
          f"linearized: {a['lin'] / a['t_sim'] * pass_s:.1f} s")
    if full_pass:
        for linearized in (False, True):
            S, setup, wall, _ = _time_run(alu, None, linearized)
            print(f"full aluminium pass measured, {'linearized' if linearized else 'full'} path: {wall:.1f} s "
                  f"integration + {setup:.1f} s set-up ({S.n_steps} steps)")


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    p.add_argument("--alu-s", type=float, default=0.3, help="aluminium slice, simulated s (default 0.3)")
    p.add_argument("--steel-s", type=float, default=1.5, help="steel slice, simulated s (default 1.5)")
    p.add_argument("--repeat", type=int, default=3, help="linearized runs per case (median used)")
    p.add_argument("--full-pass", action="store_true", help="also measure the whole aluminium pass, both paths")
    args = p.parse_args()
    main(args.alu_s, args.steel_s, args.repeat, args.full_pass)
