"""Benchmark: the SDM's step exponentials, ``phi_exps`` against scipy's ``expm`` (Van Loan form).

Printed, all measured in this process (CPU time of this process, so that other jobs on the machine
inflate both sides alike):

1. the step matrices of the 18-DOF orthogonal TX200 at Tab. 7, truncated to 300 Hz as in a map
   (aluminium cut, 101 speeds 2000-25 000 rpm, engaged steps at 1 and 10 mm): CPU time of each
   method, the ratio, and the largest relative difference of ``Phi, Gamma0, Gamma1``;
2. ``lobes.solve`` at ``--poses`` placement-map poses (map fidelity with the opt-in 300 Hz
   truncation: m = 40, prescan m = 12,
   depths to 10 mm, rtol 1e-3, 101 speeds) with the step exponentials of each method: CPU time,
   ratio, and the largest relative difference of the finite limits.

    python bench/bench_sdm_steps.py
"""

from __future__ import annotations

import argparse
import os
import time

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import numpy as np  # noqa: E402


def _expm_steps(self, dt, wsum):
    """The SDM's step exponentials as before ``phi_exps``: scipy expm of the Van Loan matrix."""
    from scipy.linalg import expm

    ns, k = self.ns, self.k
    Z = np.zeros((len(dt), ns + 2 * k, ns + 2 * k))
    Z[:, :ns, :ns] = (self.A[None] + self.Bk[None] @ wsum @ self.S2[None]) * dt[:, None, None]
    Z[:, :ns, ns:ns + k] = self.Bk[None] * dt[:, None, None]
    Z[:, ns:ns + k, ns + k:] = np.eye(k)[None]
    E = expm(Z)
    return E[:, :ns, :ns], E[:, :ns, ns:ns + k] - E[:, :ns, ns + k:], E[:, :ns, ns + k:]


def _cpu(f, n=3):
    f()
    t = time.process_time()
    for _ in range(n):
        f()
    return (time.process_time() - t) / n


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--poses", type=int, default=3, help="map poses solved with each method (default 3)")
    args = ap.parse_args(argv)

    from dataclasses import replace

    from robolobes import cases, linearize
    from robolobes.lobes import LobeProblem, PhysicalStructure, SemiDiscretization, solve
    from robolobes.lobes.sdm import SDMEngine
    from robolobes.workspace import MapMethod, MapProblem, pose_table
    from robolobes.workspace.compute import build_robot, pose_structure

    case = cases.load_case("tx200-aluminium")
    speeds = np.append(np.linspace(2000.0, 25000.0, 100), case.cut.spindle_rpm)
    robot = linearize.build_model(case.robot, "orthogonal")
    lin = linearize.linearize(robot, case.path.start_q_rad)
    red = PhysicalStructure.from_linear(lin, case.cut.feed_direction).truncated(max_freq_hz=300.0)
    eng = SDMEngine(LobeProblem(red, case.tool, case.cut, case.law), SemiDiscretization(m=40), 0.01)
    new_steps = SDMEngine._step_exps
    print(f"1. step exponentials, TX200 Tab. 7 truncated to 300 Hz ({eng.ns} states), {len(speeds)} speeds:")
    for depth in (1e-3, 1e-2):
        W = eng.plan.wbar(np.full(len(speeds), depth), eng.cand).sum(axis=2).reshape(-1, eng.k, 2)
        dt = np.repeat(eng.period_s(speeds) / eng.plan.m, len(eng.cand))
        t_old = _cpu(lambda: _expm_steps(eng, dt, W))
        t_new = _cpu(lambda: new_steps(eng, dt, W))
        a, b = _expm_steps(eng, dt, W), new_steps(eng, dt, W)
        err = max(float(np.max(np.abs(x - y)) / np.max(np.abs(x))) for x, y in zip(a, b))
        print(f"   {depth * 1e3:g} mm, {len(dt)} steps: expm {t_old:.3f} s, phi_exps {t_new:.3f} s CPU, "
              f"ratio {t_old / t_new:.2f}; largest relative difference {err:.1e}")

    pr = MapProblem.make(case, "orthogonal", "placement", n=40, x_range_m=(-0.2, 0.2), y_range_m=(-0.2, 0.2),
                         speeds_rpm=speeds[:-1])
    meth = MapMethod(reduce_max_freq_hz=300.0)  # the 300 Hz truncation its documented numbers were measured with
    tab = pose_table(pr)
    ok = np.flatnonzero(tab["reason"] <= 1)
    ok = ok[np.linspace(0, len(ok) - 1, args.poses).astype(int)]
    probs = []
    for i in ok:
        st, _ = pose_structure(pr, meth, linearize.linearize(build_robot(pr), tab["theta"][i]), tab["feed"][i])
        cut = replace(case.cut, feed_direction=tuple(tab["feed"][i]))
        probs.append(LobeProblem(st, case.tool, cut, case.law))
    sdm = SemiDiscretization(m=meth.m, prescan_m=meth.prescan_m)

    def run():
        return [solve(p, sdm, speeds, depth_max_m=meth.depth_max_m, rtol=meth.rtol, chunk=len(speeds)).depth_limit_m
                for p in probs]

    t0 = time.process_time()
    d_new = run()
    t_new = time.process_time() - t0
    setattr(SDMEngine, "_step_exps", _expm_steps)  # noqa: B010  (the old step code patched in; setattr: its return arrays are typed looser than the method's)
    try:
        t0 = time.process_time()
        d_old = run()
        t_old = time.process_time() - t0
    finally:
        SDMEngine._step_exps = new_steps
    d_new, d_old = np.array(d_new), np.array(d_old)
    fin = np.isfinite(d_old)
    same_inf = bool(np.array_equal(fin, np.isfinite(d_new)))
    diff = float(np.max(np.abs(d_new[fin] / d_old[fin] - 1))) if fin.any() else 0.0
    print(f"2. lobes.solve at {len(probs)} map poses (poses {ok.tolist()}), {len(speeds)} speeds, map fidelity: "
          f"expm steps {t_old:.2f} s, phi_exps {t_new:.2f} s CPU, ratio {t_old / t_new:.2f}; "
          f"{int(fin.sum())} finite limits, largest relative difference {diff:.1e}, same stable speeds: {same_inf}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
