"""Reduced modal basis (lobes.basis) against the full model, same process (issue 18).

Run: .venv/bin/python bench/bench_reduced_basis.py [--quick] [--cases steel-orthogonal,...]

For the TX200 at the Tab. 7 pose, tx200-steel and tx200-aluminium, variants ``orthogonal`` (18
DOF) and ``basic``, 200 speeds 2000-25000 rpm, depths to 10 mm:

* reference: this code's full-model SDM (``PhysicalStructure`` of the linearized robot, all modes);
* reduced: :func:`lobes.basis.basis_for` (the rule: band ``2 x`` the highest tooth-passing
  frequency, loop stiffness at the deepest depth searched, tolerance ``BASIS_REL_TOL``).

Last, ``aluminium-orthogonal-low``: 2000-8000 rpm, depths to 3 mm, where the rule does reduce.

Also measured (no bound, not adopted): static-corrected truncations at fixed frequencies
(``--candidates``), one level m = 40 against the full model's m = 40.

Both are solved twice: one SDM level m = 40 (the basis's own effect, the discretization being
identical) and the default ``RefinedSDM`` (error estimate <= 1 %, what ``robolobes lobes`` does).
Printed: states, CPU seconds of this process (one BLAS thread), the ratio full / reduced, and the
largest relative difference of the limits over the speeds (capped at the depth searched, as
``bench_lobes.py``), with the speeds limited in one diagram only.
"""

from __future__ import annotations

import argparse
import os
import sys
from dataclasses import replace
from pathlib import Path

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_v] = "1"

import numpy as np  # noqa: E402  (after the BLAS thread count is set)

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from robolobes.lobes import RefinedSDM, SemiDiscretization, solve  # noqa: E402
from robolobes.lobes.basis import basis_for, truncated_with_residual  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_lobes import cpu, tx200_problem  # noqa: E402  (the TX200 Tab. 7 problem and the CPU timer)

DEPTH_MAX_M = 10e-3
CASES = ("steel-orthogonal", "aluminium-orthogonal", "steel-basic", "aluminium-basic", "aluminium-orthogonal-low")


def compare(full, red, depth: float) -> tuple[float, int, int]:
    """Largest relative difference of the limits capped at the depth searched, the speed where it
    is, and the number of speeds limited in one only."""
    x, y = np.minimum(full.depth_limit_m, depth), np.minimum(red.depth_limit_m, depth)
    d = np.abs(y / x - 1)
    one = int((np.isfinite(full.depth_limit_m) != np.isfinite(red.depth_limit_m)).sum())
    return float(np.max(d)), int(np.argmax(d)), one


def bench_case(name: str, n: int, candidates: tuple = ()) -> dict:
    material, variant = name.split("-")[:2]
    p = tx200_problem(f"tx200-{material}", variant)
    rpm_max, depth = (8000.0, 3e-3) if name.endswith("-low") else (25000.0, DEPTH_MAX_M)
    speeds = np.linspace(2000.0, rpm_max, n)
    tb, red = cpu(basis_for, p, speeds, depth)
    pr = replace(p, structure=red)
    info = red.basis
    print(f"{name}: {len(speeds)} speeds 2000-{rpm_max:.0f} rpm, depths to {1e3 * depth:g} mm; full {p.structure.state_space().n_states} states, reduced {info.n_states} states "
          f"({info.n_kept} of {info.n_modes} modes kept + {info.n_residual} residual blocks at "
          f"{info.residual_freq_hz:.1f} Hz), band 0-{info.band_hz:.0f} Hz, largest loop "
          f"perturbation {info.max_loop_error:.2e} (tol {info.tol:g}, k_loop {info.loop_stiffness_n_per_m:.3g} N/m), static error {red.report.static_compliance_rel_error:.1e}, "
          f"basis built in {tb:.3f} s; kept modes {[round(f, 1) for f in red.report.kept_freq_hz]} Hz", flush=True)
    out = {}
    full40 = None
    for label, meth in (("m = 40", SemiDiscretization(m=40)), ("refined", RefinedSDM())):
        tf, rf = cpu(solve, p, meth, speeds, depth_max_m=depth)
        if label == "m = 40":
            full40 = (tf, rf)
        if info.kind == "full":
            print(f"   {label}: full {tf:.2f} s; the rule keeps the full model (no reduced run, ratio 1)", flush=True)
            continue
        tr, rr = cpu(solve, pr, meth, speeds, depth_max_m=depth)
        report(label, tf, rf, tr, rr, speeds, depth)
        out[label] = (tf, tr)
    assert full40 is not None
    for f_cut in candidates:  # not adopted: no bound, measured only
        cand = truncated_with_residual(p.structure, f_cut, info.band_hz)
        tr, rr = cpu(solve, replace(p, structure=cand), SemiDiscretization(m=40), speeds, depth_max_m=depth)
        report(f"candidate (no bound): modes <= {f_cut:g} Hz + static residual, {cand.ss.n_states} states, m = 40",
               full40[0], full40[1], tr, rr, speeds, depth)
    return out


def report(label, tf, rf, tr, rr, speeds, depth: float) -> None:
    dmax, j, one = compare(rf, rr, depth)
    fin = int(np.isfinite(rf.depth_limit_m).sum())
    x, y = np.minimum(rf.depth_limit_m, depth), np.minimum(rr.depth_limit_m, depth)
    n_off = int((np.abs(y / x - 1) > 0.005).sum())
    print(f"   {label}: full {tf:.2f} s, reduced {tr:.2f} s, ratio {tf / tr:.2f}; largest limit difference "
          f"{100 * dmax:.3f} % (at {speeds[j]:.0f} rpm, full {1e3 * rf.depth_limit_m[j]:.4g} mm), {n_off} of "
          f"{len(speeds)} speeds off by > 0.5 %, {fin} limited in the full model, {one} limited in one only", flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="40 speeds instead of 200 (smoke run)")
    ap.add_argument("--candidates", default="300,600", help="also measure modes <= F Hz + static residual "
                    "(no bound, not adopted), comma-separated F; empty: none")
    ap.add_argument("--cases", default=",".join(CASES), help=f"comma-separated subset of {','.join(CASES)}")
    args = ap.parse_args(argv)
    n = 40 if args.quick else 200
    names = [c for c in args.cases.split(",") if c]
    bad = [c for c in names if c not in CASES]
    if bad:
        print(f"unknown case {bad[0]!r}; valid: {', '.join(CASES)}", file=sys.stderr)
        return 2
    print(f"reduced basis vs the full model (reference: this code's full-model SDM), {n} speeds, "
          f"CPU s of this process, load {os.getloadavg()[0]:.1f}", flush=True)
    for c in names:
        bench_case(c, n, tuple(float(f) for f in args.candidates.split(",") if f))
    return 0


if __name__ == "__main__":
    sys.exit(main())
