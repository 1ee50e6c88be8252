"""Speed of the lobe solvers, as ratios against reference operations timed in the same process.

Run: .venv/bin/python bench/bench_lobes.py [--quick] [--targets]

1. Insperger 2-DOF benchmark (symmetric, a/D = 0.05, down-milling), 200 speeds 5000-25000 rpm,
   depths 0-10 mm, SDM m = 40:
   * straightforward: for every (speed, depth) of a 200 x 200 grid, the dense monodromy (m
     matrix exponentials, (2n + 2m)-wide products) and its eigenvalues. Timed on a sample of the
     grid and extrapolated (the per-point time is what is measured);
   * fast path: ``lobes.solve`` (reduced history, merged free flight, batched, bracketing +
     Illinois on the critical depth);
   * ratio straightforward / fast (target >= 20) and the agreement of the two lobes.
2. TX200, 18-DOF ``orthogonal`` model at the Tab. 7 pose, aluminium case, 200 speeds 2000-25000
   rpm, depths to 10 mm, m = 40: wall time of the full lobe diagram (target < 10 s on one core)
   for both SDM schemes, and its ratio to one straightforward grid point of the same problem.
3. The diagram targets in CPU seconds: the default (``RefinedSDM``, error estimate <= 1 % per
   speed, fast depth search with adaptive warm brackets, grouped batching) against the code before
   those two (``batching="single"``: one monodromy layout per batch, the critical multiplier
   re-evaluated at each limit; ``search="fast-wide"``: +-4 % warm brackets at every speed;
   ``chunk=50``: batches of 50 speeds for every structure), the
   older default (the same rule with ``search="plain"``) and one level m = 40 in the same run, for a 2-mode modal model (target <
   0.5 s) and the TX200 steel and aluminium diagrams (target < 2 s each), 200 speeds; for the
   TX200 also the candidate modal truncation <= 300 Hz (cost and error).

The process is pinned to one BLAS thread (set before numpy is imported).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_v] = "1"

import numpy as np  # noqa: E402  (after the BLAS thread count is set)

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from robolobes.cases.milling import Cut, CuttingLaw, Tool  # noqa: E402
from robolobes.lobes import (LobeProblem, Mode, ModalStructure, PhysicalStructure, RefinedSDM,  # noqa: E402
                             SemiDiscretization, solve)
from robolobes.lobes.sdm import SDMEngine  # noqa: E402


def insperger_2dof() -> LobeProblem:
    fn, zeta, mt = 922.0, 0.011, 0.03993
    k = mt * (2 * np.pi * fn) ** 2
    s = ModalStructure((Mode(fn, zeta, k, (1.0, 0.0)), Mode(fn, zeta, k, (0.0, 1.0))))
    return LobeProblem(s, Tool(diameter_m=0.01, teeth=2), Cut(ae_m=0.0005, ap_m=1e-3, spindle_rpm=1e4, mode="down"),
                       CuttingLaw(ktc_pa=6e8, krc_pa=2e8))


def straightforward_grid(engine: SDMEngine, speeds, depths):
    """First unstable grid depth per speed (inf if none): the classic per-grid-point approach."""
    out = np.full(len(speeds), np.inf)
    for i, s in enumerate(speeds):
        for d in depths:
            if np.max(np.abs(np.linalg.eigvals(engine.monodromy_dense(s, d)))) >= 1.0:
                out[i] = d
                break
    return out


def timed(f, *a, **k):
    t = time.perf_counter()
    r = f(*a, **k)
    return time.perf_counter() - t, r


def bench_insperger(quick: bool) -> None:
    p = insperger_2dof()
    meth = SemiDiscretization(m=40)
    speeds = np.linspace(5000, 25000, 200)
    depths = np.linspace(0.05e-3, 10e-3, 200)
    eng = SDMEngine(p, meth, 10e-3)
    # straightforward: every grid point of a sample of speeds (all 200 depths each)
    sample = speeds[:: (40 if quick else 20)]
    npts = len(sample) * len(depths)
    t0 = time.perf_counter()
    for s in sample:
        for d in depths:
            np.max(np.abs(np.linalg.eigvals(eng.monodromy_dense(s, d))))
    t_point = (time.perf_counter() - t0) / npts
    t_grid = t_point * len(speeds) * len(depths)
    t_fast, res = timed(solve, p, meth, speeds, depth_max_m=10e-3, rtol=1e-3)
    # agreement: the grid's first unstable depth brackets the fast limit within one grid step
    grid_lim = straightforward_grid(eng, sample[:3], depths)
    fast_lim = solve(p, meth, sample[:3], depth_max_m=10e-3, rtol=1e-6).depth_limit_m
    step = depths[1] - depths[0]
    agree = np.all((grid_lim >= fast_lim - 1e-12) & (grid_lim <= fast_lim + step + 1e-12))
    print("1. Insperger 2-DOF benchmark, a/D = 0.05 down, 200 speeds x depths 0-10 mm, SDM m = 40")
    print(f"   straightforward: {t_point * 1e3:.2f} ms per grid point (measured on {npts} points); "
          f"200 x 200 grid = {t_grid:.1f} s (extrapolated)")
    print(f"   fast path (solve): {t_fast:.2f} s, {res.stats['evaluations']} spectra, reduced monodromy "
          f"{res.stats['monodromy_size']} x {res.stats['monodromy_size']} (dense: "
          f"{eng.ns + 2 * 40} x {eng.ns + 2 * 40})")
    print(f"   ratio straightforward / fast = {t_grid / t_fast:.1f}  (target >= 20)")
    print(f"   grid and fast limits agree within one grid step ({step * 1e3:.3f} mm) on 3 speeds: {bool(agree)}")
    j = int(np.argmin(res.depth_limit_m))
    print(f"   lowest limit {res.depth_limit_m[j] * 1e3:.4f} mm at {res.spindle_rpm[j]:.0f} rpm ({res.bifurcation[j]})")


def bench_tx200(quick: bool) -> None:
    try:
        from robolobes import linearize
        from robolobes.cases import load_case
    except ImportError as e:  # pragma: no cover
        print(f"2. TX200: skipped ({e})")
        return
    case = load_case("tx200-aluminium")
    rob = linearize.build_model(case.robot, "orthogonal")
    lin = linearize.linearize(rob, case.robot.poses_rad["tab7"])
    st = PhysicalStructure.from_linear(lin, case.cut.feed_direction)
    p = LobeProblem(st, case.tool, case.cut, case.law)
    speeds = np.linspace(2000, 25000, 50 if quick else 200)
    print(f"2. TX200 18-DOF orthogonal, Tab. 7 pose, aluminium cut, {len(speeds)} speeds 2000-25000 rpm, "
          f"depths to 10 mm, m = 40, one core")
    for scheme in ("sdm", "free-exact"):
        meth = SemiDiscretization(m=40, scheme=scheme)
        eng = SDMEngine(p, meth, 10e-3)
        eng.monodromy_dense(18700.0, 1.6e-3)  # warm-up
        reps = 5
        t_ref = min(timed(lambda: np.linalg.eigvals(eng.monodromy_dense(18700.0, 1.6e-3)))[0] for _ in range(reps))
        t, res = timed(solve, p, meth, speeds, depth_max_m=10e-3, rtol=1e-3)
        finite = np.isfinite(res.depth_limit_m)
        j = int(np.argmin(res.depth_limit_m))
        pre = res.stats.get("prescan_evaluations", 0)
        print(f"   scheme {scheme:10s}: {t:6.2f} s ({res.stats['evaluations']} spectra"
              + (f" + {pre} free-exact prescan spectra" if pre else "") + ", monodromy "
              f"<= {res.stats['monodromy_size']}), = {t / t_ref:.0f} straightforward grid points "
              f"({t_ref * 1e3:.1f} ms each); target < 10 s")
        print(f"      limited below 10 mm at {finite.sum()} / {len(speeds)} speeds; lowest "
              f"{res.depth_limit_m[j] * 1e3:.3f} mm at {res.spindle_rpm[j]:.0f} rpm ({res.bifurcation[j]}, "
              f"{res.chatter_freq_hz[j]:.1f} Hz)")


def tx200_problem(case_name: str, variant: str = "orthogonal") -> LobeProblem:
    from robolobes import linearize
    from robolobes.cases import load_case

    case = load_case(case_name)
    rob = linearize.build_model(case.robot, variant)
    lin = linearize.linearize(rob, case.robot.poses_rad["tab7"])
    return LobeProblem(PhysicalStructure.from_linear(lin, case.cut.feed_direction), case.tool, case.cut, case.law)


def cpu(f, *a, **k):
    t = time.process_time()
    r = f(*a, **k)
    return time.process_time() - t, r


def bench_targets(quick: bool) -> None:
    """The diagram targets in CPU seconds of this process: the default (RefinedSDM, error <= 1 %,
    fast search) against the previous code's default (the same refinement with the plain search and
    prescan at m) and one level m = 40 in the same run, and against a 300 Hz modal truncation."""
    n = 50 if quick else 200
    print(f"3. diagram targets, CPU s of this process, {n} speeds; default = RefinedSDM (error estimate <= 1 %, "
          "fast search); before = the default before the grouped batching and adaptive warm brackets; previous = "
          "the same rule with the plain search (an older default)")
    cases = [("2-mode modal (2-DOF symmetric, a/D 0.05 down)", insperger_2dof(), np.linspace(5000, 25000, n), 0.5)]
    for name in ("tx200-steel", "tx200-aluminium"):
        cases.append((f"{name} 18-DOF orthogonal, Tab. 7 pose", tx200_problem(name), np.linspace(2000, 25000, n), 2.0))
    previous = RefinedSDM(SemiDiscretization(search="plain", batching="single"))
    single = RefinedSDM(SemiDiscretization(prescan_m=20, batching="single", search="fast-wide"))
    for label, p, speeds, target in cases:
        t40, r40 = cpu(solve, p, SemiDiscretization(m=40, search="plain"), speeds, depth_max_m=10e-3)
        tp, rp = cpu(solve, p, previous, speeds, depth_max_m=10e-3, chunk=50)
        ts, rs = cpu(solve, p, single, speeds, depth_max_m=10e-3, chunk=50)
        t, r = cpu(solve, p, RefinedSDM(), speeds, depth_max_m=10e-3)
        nu = int((r.status == "unconverged").sum())
        print(f"   {label}: default {t:.2f} s (target < {target:g} s: {'met' if t < target else 'not met'}); "
              f"before (batching='single', search='fast-wide') {ts:.2f} s, ratio before / default = {ts / t:.2f}, "
              f"limits differ by up to "
              f"{100 * _largest_diff(r, rs):.2e} %, same status {bool(np.all(r.status == rs.status))}; "
              f"previous {tp:.2f} s, ratio previous / default = {tp / t:.2f}; one level m = 40 {t40:.2f} s; "
              f"levels m = {r.stats['m_levels']}, unconverged {nu} / {len(speeds)}; default vs previous limits: "
              f"largest difference {100 * _largest_diff(r, rp):.3f} %, m = 40 off the default by up to "
              f"{100 * _largest_diff(r, r40):.1f} %", flush=True)
        if isinstance(p.structure, PhysicalStructure):
            from dataclasses import replace

            red = p.structure.truncated(max_freq_hz=300.0, band_hz=(0.0, 1000.0))
            tr, rr = cpu(solve, replace(p, structure=red), RefinedSDM(), speeds, depth_max_m=10e-3)
            big = _n_off(r, rr, 0.01)
            print(f"      candidate: modal truncation <= 300 Hz ({red.ss.n_states} of {p.structure.state_space().n_states} "
                  f"states, FRF error in 0-1000 Hz {red.report.frf_rel_error:.1e} of the band maximum): {tr:.2f} s, "
                  f"ratio default / truncated {t / tr:.2f}; its limits differ from the full model's by up to "
                  f"{100 * _largest_diff(r, rr):.1f} % ({big[0]} of {big[1]} finite speeds above 1 %, "
                  f"{big[2]} speeds limited in one only)", flush=True)


def _largest_diff(a, b) -> float:
    """Largest relative difference of two diagrams' limits, capped at the searched depth (10 mm)."""
    x, y = np.minimum(a.depth_limit_m, 10e-3), np.minimum(b.depth_limit_m, 10e-3)
    return float(np.max(np.abs(y / x - 1)))


def _n_off(a, b, tol: float) -> tuple[int, int, int]:
    fin = np.isfinite(a.depth_limit_m) & np.isfinite(b.depth_limit_m)
    off = np.abs(b.depth_limit_m[fin] / a.depth_limit_m[fin] - 1) > tol
    return int(off.sum()), int(fin.sum()), int((np.isfinite(a.depth_limit_m) != np.isfinite(b.depth_limit_m)).sum())


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="smaller samples (smoke run)")
    ap.add_argument("--targets", action="store_true", help="only section 3 (the diagram targets)")
    args = ap.parse_args(argv)
    if not args.targets:
        bench_insperger(args.quick)
        bench_tx200(args.quick)
    bench_targets(args.quick)
    return 0


if __name__ == "__main__":
    sys.exit(main())
