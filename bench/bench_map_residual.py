"""Benchmark: the map's opt-in 300 Hz modal truncation with and without the static residual
(``MapMethod(reduce_max_freq_hz=300.0, reduce_residual=...)``), and the map's default (the full
model, ``--methods full``), against ``lobes.solve`` on the full model.

The poses are those of ``tests/test_workspace.py::test_twenty_random_poses_of_a_placement_map_agree_with_solve``
(rng seed 11, 20 of the reachable poses of a 400-pose placement map, 18-DOF orthogonal, 100
speeds 2000-25 000 rpm, depths to 10 mm); the map's limits come from ``compute_chunk`` (the map's
own code, refined to an error estimate <= 1 %), the reference from the default ``lobes.solve``
(``RefinedSDM``) of the full structure, both capped at 10 mm. Printed: the CPU time of the two
``compute_chunk`` runs (one process) and, per pose, the largest relative difference of each, its
speed and limits, and the number of speeds more than 1 % apart. ``--reports-only``: no lobes, only
the stored truncation errors of both (largest over the poses), the dropped modes' frequencies and
the band the cut excites (2 x the highest tooth-passing frequency, ``lobes.basis.band_edge_hz``).

    python bench/bench_map_residual.py                                 # aluminium, the 20 poses
    python bench/bench_map_residual.py --case tx200-steel --poses 0,9,17
    python bench/bench_map_residual.py --case tx200-steel --reports-only
    python bench/bench_map_residual.py --case tx200-steel --poses 0,9,17 --methods full,plain
"""

from __future__ import annotations

import argparse
import time

import numpy as np


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--case", default="tx200-aluminium", help="tx200-aluminium (default) or tx200-steel")
    ap.add_argument("--poses", default="", help="indices into the 20 picked poses, comma-separated (default all)")
    ap.add_argument("--reports-only", action="store_true", help="only the truncation reports (no lobes)")
    ap.add_argument("--methods", default="plain,residual",
                    help="comma list of plain (300 Hz truncation), residual (the same with the static residual), "
                         "full (the map's default, no truncation); default plain,residual")
    args = ap.parse_args(argv)

    from robolobes import cases, linearize
    from robolobes.lobes import LobeProblem, PhysicalStructure, RefinedSDM, solve
    from robolobes.workspace import MapMethod, MapProblem, compute_chunk, pose_table

    case = cases.load_case(args.case)
    rng = np.random.default_rng(11)
    pr = MapProblem.make(case, "orthogonal", "placement", n=400)
    table = pose_table(pr)
    ok = np.flatnonzero(table["reason"] <= 1)
    pick = np.sort(rng.choice(ok, size=20, replace=False))
    if args.poses:
        pick = pick[[int(k) for k in args.poses.split(",")]]
    print(f"{args.case}: poses {[int(i) for i in pick]} of a 400-pose placement map, {len(pr.speeds_rpm)} speeds, "
          "18-DOF orthogonal; plain and residual: truncation <= 300 Hz, full: no truncation")
    robot = linearize.build_model(case.robot, "orthogonal")
    if args.reports_only:
        from robolobes.lobes.basis import band_edge_hz
        from robolobes.workspace import pose_structure

        print(f"band the cut excites: 0-{band_edge_hz(case.tool.teeth, float(max(pr.speeds_rpm))):.0f} Hz")
        for name, meth in (("plain", MapMethod(reduce_max_freq_hz=300.0)),
                           ("residual", MapMethod(reduce_max_freq_hz=300.0, reduce_residual=True))):
            reps = [pose_structure(pr, meth, linearize.linearize(robot, table["theta"][i]), table["feed"][i])[1]
                    for i in pick]
            st = [r.static_compliance_rel_error for r in reps if r is not None]
            fr = [r.frf_rel_error for r in reps if r is not None]
            dropped = [f for r in reps if r is not None for f in r.dropped_freq_hz]
            print(f"{name}: static error {min(st):.2e}-{max(st):.2e}, FRF error (0-1000 Hz) {min(fr):.2e}-{max(fr):.2e}; "
                  f"dropped modes {min(dropped):.0f}-{max(dropped):.0f} Hz, "
                  f"those below 1000 Hz: {sorted({round(f, -1) for f in dropped if f < 1000})}")
        return 0
    got, cpu = {}, {}
    methods = {"plain": MapMethod(reduce_max_freq_hz=300.0),
               "residual": MapMethod(reduce_max_freq_hz=300.0, reduce_residual=True), "full": MapMethod()}
    names = [k.strip() for k in args.methods.split(",") if k.strip()]
    if not names or any(k not in methods for k in names):
        ap.error(f"--methods must be a comma list of {', '.join(methods)}, got {args.methods!r}")
    for name in names:
        meth = methods[name]
        t0 = time.process_time()
        got[name] = compute_chunk(pr, meth, 0, table["theta"][pick], table["feed"][pick],
                                  np.ones(len(pick), bool)).depth_limit_m
        cpu[name] = time.process_time() - t0
    print("compute_chunk CPU: " + ", ".join(f"{k} {v:.1f} s" for k, v in cpu.items())
          + "".join(f" (ratio {k} / {names[0]} {cpu[k] / cpu[names[0]]:.2f})" for k in names[1:]), flush=True)
    worst = {k: 0.0 for k in got}
    for k, i in enumerate(pick):
        lin = linearize.linearize(robot, table["theta"][i])
        p = LobeProblem(PhysicalStructure.from_linear(lin, table["feed"][i]), case.tool, case.cut, case.law)
        ref = np.minimum(solve(p, RefinedSDM(), pr.speeds_rpm, depth_max_m=0.01, rtol=1e-3).depth_limit_m, 0.01)
        line = f"pose {int(i)}:"
        for name, d in got.items():
            a = np.minimum(d[k], 0.01)
            e = np.abs(a / ref - 1)
            j = int(np.argmax(e))
            worst[name] = max(worst[name], float(e[j]))
            line += (f" {name} {e[j]:.3e} at {pr.speeds_rpm[j]:.0f} rpm ({a[j] * 1e3:.3f} vs {ref[j] * 1e3:.3f} mm),"
                     f" {int((e > 0.01).sum())} speeds > 1 %;")
        print(line, flush=True)
    print("largest relative difference (capped at 10 mm): " + ", ".join(f"{k} {v:.3e}" for k, v in worst.items()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
