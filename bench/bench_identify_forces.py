"""Benchmark: identify on a 0.3 s cutting-force set at 50 kHz (target: under 2 minutes).

The set: the aluminium pass on the full nonlinear time domain (basic model) to 0.55 s, passed
through an undeclared dynamometer mode (2.5 kHz, zeta 0.04, scipy ``lsim``), resampled at 50 kHz
over 0.25-0.55 s, plus 2 N Gaussian noise. Prints the time to generate the data (not part of the
target), the wall time of ``read + identify`` (cold: the model's linearized runs, numba loaded from
its cache), the same again warm (the runs memoised in the process), the effect found and the
held-out errors.

    python bench/bench_identify_forces.py
"""

import os
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np
from scipy import signal

from robolobes.cases import load_case
from robolobes.identify import IdentifyProblem, identify, model_state, read_measurement
from robolobes.linearize import build_model
from robolobes.identify.force_model import model_disc_count
from robolobes.timedomain import NonlinearNewmark, SimulationProblem, simulate


def main(rate_hz: float = 50e3, t0: float = 0.25, t1: float = 0.55):
    case = load_case("tx200-aluminium")
    w0 = time.perf_counter()
    run = simulate(SimulationProblem(build_model(case.robot, "basic"), case, t_end_s=t1 + 1e-3),
                   NonlinearNewmark(n_discs=model_disc_count(case)),
                   verdict_companion=False)
    t, f = np.asarray(run.t_s), np.asarray(run.force_workpiece_n)
    w = 2 * np.pi * 2500.0
    f = np.column_stack([signal.lsim(signal.lti([w * w], [1, 0.08 * w, w * w]), f[:, j], t)[1] for j in range(3)])
    tq = t0 + np.arange(int(round((t1 - t0) * rate_hz))) / rate_hz
    fq = np.column_stack([np.interp(tq, t, f[:, j]) for j in range(3)])
    fq += np.random.default_rng(0).normal(0, 2.0, fq.shape)
    gen = time.perf_counter() - w0
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp) / "set"
        d.mkdir()
        np.savetxt(d / "forces.csv", np.column_stack([tq, fq]), delimiter=",", header="t_s,fx_n,fy_n,fz_n",
                   comments="", fmt="%.10g")
        (d / "cut.toml").write_text(f'case = "tx200-aluminium"\nsample_rate_hz = {rate_hz}\n'
                                    f'window_s = [{tq[0]:.10g}, {tq[-1]:.10g}]\n')
        times = []
        for _ in range(2):
            w1 = time.perf_counter()
            m = read_measurement(d)
            state, _ = model_state(m)
            res = identify(IdentifyProblem(m, state))
            times.append(time.perf_counter() - w1)
    print(f"data: full nonlinear pass to {t1} s + dynamometer 2500 Hz, zeta 0.04, 2 N noise: {gen:.1f} s "
          f"(not timed in the target)")
    print(f"identify on {len(tq)} samples ({t1 - t0:.2f} s at {rate_hz / 1e3:.0f} kHz): {times[0]:.1f} s cold, "
          f"{times[1]:.1f} s warm (target < 120 s)")
    for e in res.effects:
        print(f"  {e.name}: " + ", ".join(f"{k} = {v:.5g}" for k, v in e.params.items()))
    print(f"held-out error {res.error_before:.4g} -> {res.error_after:.4g} (noise floor {res.noise_floor:.3g})")


if __name__ == "__main__":
    main()
