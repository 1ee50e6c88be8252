"""Benchmark: identify on a 6-pose, 4-pair, 1200-line tool-tip FRF set (target: under 2 minutes).

The set comes from the TX200 basic model plus an undeclared tool-holder mode (identify/synthetic.py,
every default candidate of the library tried: 14 for the basic variant, servos of axes 1-6 among them;
2 % relative + 2 % additive noise), written as UFF58 files and read back. Prints the wall time of
reading + identification (with and without the LSCF/LSFD modal fit), the effect found and the
held-out errors, and the time per line-evaluation of the model as a ratio to one pinocchio ``crba``
call timed in the same run (these machines are noisy: compare ratios, not seconds).

    python bench/bench_identify.py
"""

import math
import os
import tempfile
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np
import pinocchio as pin

from robolobes.cases import load_case
from robolobes.identify import FRFSet, IdentifyProblem, StepwiseSelection, identify, model_state, read_measurement
from robolobes.identify.synthetic import synthetic_frf_set
from robolobes.linearize import build_model, rigid_q
from robolobes.linearize.tool import TcpOscillator


def main(n_poses: int = 6, n_lines: int = 1200):
    case = load_case("tx200-aluminium")
    el = TcpOscillator.one_axis(230.0, 0.025, 0.3 * (2 * math.pi * 230.0) ** 2, (0.6, 0.0, 0.8))
    with tempfile.TemporaryDirectory() as tmp:
        d = os.path.join(tmp, "set")
        synthetic_frf_set(d, case, elements=(el,), n_poses=n_poses, f_hz=np.linspace(2, 300, n_lines),
                          rel_noise=0.02, add_noise=0.02, seed=0)
        robot = build_model(case.robot, "basic")
        q = rigid_q(robot, case.path.start_q_rad)
        data = robot.create_data()
        t0 = time.perf_counter()
        for _ in range(1000):
            pin.crba(robot.model, data, q)
        t_crba = (time.perf_counter() - t0) / 1000
        for poles in (False, True):
            t0 = time.perf_counter()
            m = read_measurement(d)
            state, _ = model_state(m)
            res = identify(IdentifyProblem(m, state), StepwiseSelection(poles=poles))
            wall = time.perf_counter() - t0
            print(f"identify, {n_poses} poses x 4 pairs x {n_lines} lines, {res.extra['n_candidates']} candidate "
                  f"effects, modal fit {'on ' if poles else 'off'}: "
                  f"{wall:.1f} s (target < 120 s: {'met' if wall < 120 else 'NOT met'}); "
                  f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
        e = res.effects[0] if res.effects else None
        print(f"  found: {[x.name for x in res.effects]}; held-out error {res.error_before:.4f} -> {res.error_after:.4f}"
              f" (noise floor {res.noise_floor:.4f})")
        if e:
            print("  " + ", ".join(f"{k} = {v:.5g} +- {e.uncertainty[k]:.2g}" for k, v in e.params.items()))
        print(f"  truth: freq_hz 230, damping_ratio 0.025, stiffness_n_per_m {el.k1_n_per_m:.5g}")
        from robolobes.identify.frf import prepare, predict
        assert isinstance(res.problem.measurement, FRFSet)  # the set written above
        poses = prepare(res.problem.measurement, state)
        t0 = time.perf_counter()
        for _ in range(50):
            for pd in poses:
                predict(pd, [])
        t_eval = (time.perf_counter() - t0) / 50
        print(f"  one model evaluation on all {sum(len(p.H) for p in poses)} lines: {t_eval * 1e3:.2f} ms "
              f"= {t_eval / t_crba:.0f} crba calls")


if __name__ == "__main__":
    main()
