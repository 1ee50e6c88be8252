"""Benchmark: CPU time of ``identify`` on a 6-pose FRF set with two effects (and, with ``--forces``, a
cutting-force set), against the code at commit e070e9a run in the same process (target: each under
2 minutes of CPU).

The FRF set comes from the independent generator (tests/generators/tx200.py): a tool-holder mode
(230 Hz, zeta 0.025, modal mass 0.3 kg, along TCP x) and axis 3 softer (x0.75), 6 poses x 4 pairs x
400 lines, 2 % noise. The old code is identify/ as of e070e9a, extracted with ``git archive`` into a
temporary package and called directly (its pipeline, its effect library). CPU time is
``time.process_time`` of this process (the machines are shared: wall times are not comparable).

    python bench/bench_identify_speed.py
    python bench/bench_identify_speed.py --forces     # also the force set (its data take minutes to simulate)
"""

import argparse
import importlib
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

import numpy as np  # noqa: E402  (after the sys.path insert, with the imports it serves)
from generators.tx200 import Effects, write_frf_set  # noqa: E402  (needs the tests/ path above)
from robolobes.identify.api import identify, model_state, read_measurement  # noqa: E402  (same)

OLD = "e070e9a"


def old_package(tmp: Path):
    """identify/ at ``OLD`` as the package ``identify_old`` (its own effect registry)."""
    arch = subprocess.run(["git", "-C", str(ROOT), "archive", OLD, "identify"], check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(tmp)], input=arch, check=True)
    (tmp / "identify").rename(tmp / "identify_old")
    sys.path.insert(0, str(tmp))
    for m in ("identify_old.structural", "identify_old.cutting_effects"):   # register into the old registry
        importlib.import_module(m)
    return importlib.import_module("identify_old.frf"), importlib.import_module("identify_old.forces")


def cpu(fn):
    t0 = time.process_time()
    out = fn()
    return out, time.process_time() - t0


def frf_bench(tmp: Path, old_frf) -> None:
    f0, m = 230.0, 0.3
    eff = Effects(tool_modes=((f0, 0.025, m * (2 * math.pi * f0) ** 2, (1.0, 0.0, 0.0)),), joint_scale={3: (0.75, 1.0)})
    d = tmp / "frf"
    truth = write_frf_set(d, eff, n_poses=6, f_hz=np.linspace(2, 300, 400), rel_noise=0.02, seed=0)
    meas = read_measurement(d)
    state, _ = model_state(meas)
    new, t_new = cpu(lambda: identify(meas, state, poles=False))
    old, t_old = cpu(lambda: old_frf.identify_frf(meas, state, poles=False))
    print(f"FRF set, 6 poses x 4 pairs x 400 lines, tool mode + axis-3 stiffness (noise error {truth['noise_error']:.4f}):")
    for lab, r, t in (("now", new, t_new), (OLD, old, t_old)):
        print(f"  {lab:8s} CPU {t:7.1f} s (target < 120 s: {'met' if t < 120 else 'NOT met'}); effects "
              f"{[e.name for e in r.effects]}; held-out error {r.error_before:.4f} -> {r.error_after:.4f}, "
              f"noise floor {r.noise_floor:.4f}")
    print(f"  CPU ratio now / {OLD}: {t_new / t_old:.3f}")


def forces_bench(tmp: Path, old_forces) -> None:
    from robolobes.cases import load_case
    from robolobes.linearize import build_model
    from robolobes.timedomain import NonlinearNewmark, SimulationProblem, simulate
    from scipy import signal

    case = load_case("tx200-aluminium")
    t0, t1, rate = 0.25, 0.55, 50e3
    run = simulate(SimulationProblem(build_model(case.robot, "basic"), case, t_end_s=t1 + 1e-3), NonlinearNewmark(),
                   verdict_companion=False)
    t, f = np.asarray(run.t_s), np.asarray(run.force_workpiece_n)
    w = 2 * np.pi * 2500.0
    f = np.column_stack([signal.lsim(signal.lti([w * w], [1, 0.08 * w, w * w]), f[:, j], t)[1] for j in range(3)])
    tq = t0 + np.arange(int(round((t1 - t0) * rate))) / rate
    fq = np.column_stack([np.interp(tq, t, f[:, j]) for j in range(3)]) + np.random.default_rng(0).normal(0, 2.0, (len(tq), 3))
    d = tmp / "forces"
    d.mkdir()
    np.savetxt(d / "forces.csv", np.column_stack([tq, fq]), delimiter=",", header="t_s,fx_n,fy_n,fz_n",
               comments="", fmt="%.10g")
    (d / "cut.toml").write_text(f'case = "tx200-aluminium"\nsample_rate_hz = {rate}\n'
                                f'window_s = [{tq[0]:.10g}, {tq[-1]:.10g}]\n')
    new0, t_cold = cpu(lambda: identify(read_measurement(d), model_state(read_measurement(d))[0]))
    print(f"  (a first, cold run: CPU {t_cold:.1f} s, the model's runs memoised after it)")
    meas = read_measurement(d)
    state, _ = model_state(meas)
    new, t_new = cpu(lambda: identify(meas, state))
    old, t_old = cpu(lambda: old_forces.identify_forces(meas, state))
    print("force set, 0.3 s at 50 kHz, dynamometer 2.5 kHz, 2 N noise:")
    for lab, r, t in (("now", new, t_new), (OLD, old, t_old)):
        print(f"  {lab:8s} CPU {t:7.1f} s (target < 120 s: {'met' if t < 120 else 'NOT met'}); effects "
              f"{[e.name for e in r.effects]}; held-out error {r.error_before:.4f} -> {r.error_after:.4f}")
    print(f"  CPU ratio now / {OLD}: {t_new / t_old:.3f}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--forces", action="store_true", help="also the force set")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        old_frf, old_forces = old_package(Path(tmp))
        frf_bench(Path(tmp), old_frf)
        if args.forces:
            forces_bench(Path(tmp), old_forces)
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
