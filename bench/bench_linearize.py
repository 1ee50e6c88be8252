"""Benchmark: linearize + complex modes + 500-point tool-tip FRF at 1000 poses, 18-DOF model.

Prints the wall time and its ratio to 1000 bare pinocchio ``crba`` calls timed in the same run
(these machines are noisy: compare ratios, not seconds). Target (issue 2): under 2 s on one core.

    python bench/bench_linearize.py
"""

import math
import time

import numpy as np
import pinocchio as pin

from robolobes import cases
import robolobes.linearize as L


def main(n_poses: int = 1000, n_freq: int = 500):
    spec = cases.load_robot("tx200")
    robot = L.build_model(spec, "orthogonal")
    rng = np.random.default_rng(0)
    # poses around Tab. 7 (a workspace patch: +-20 deg on every axis)
    thetas = spec.pose("tab7") + np.radians(rng.uniform(-20, 20, (n_poses, 6)))
    w = 2 * math.pi * np.linspace(1.0, 500.0, n_freq)

    q = L.rigid_q(robot, thetas[0])
    data = robot.create_data()
    t0 = time.perf_counter()
    for th in thetas:
        q[robot.motion_dofs] = th
        pin.crba(robot.model, data, q)
    t_ref = time.perf_counter() - t0

    t0 = time.perf_counter()
    batch = L.linearize_many(robot, thetas)
    t1 = time.perf_counter()
    modes = batch.modes()
    t2 = time.perf_counter()
    H = batch.frf(w, modes)
    t3 = time.perf_counter()
    total = t3 - t0
    print(f"{n_poses} poses, {robot.nv}-DOF '{robot.variant}' model, {n_freq}-point FRF (3x3)")
    print(f"  reference: {n_poses} pinocchio crba calls        {t_ref * 1e3:8.1f} ms")
    print(f"  linearize (equilibrium + M, C, K, J)       {(t1 - t0) * 1e3:8.1f} ms")
    print(f"  complex modes (batched eig)                {(t2 - t1) * 1e3:8.1f} ms")
    print(f"  FRF by modal superposition                 {(t3 - t2) * 1e3:8.1f} ms")
    print(f"  total                                      {total * 1e3:8.1f} ms  = {total / t_ref:.0f} x crba reference"
          f"  (target < 2 s: {'met' if total < 2 else 'NOT met'})")
    assert H.shape == (n_poses, 3, 3, n_freq) and np.all(np.isfinite(H))


if __name__ == "__main__":
    main()
