"""Benchmark: CPU time of ``identify`` on a 6-pose FRF set with two effects (and, with ``--forces``, a
cutting-force set), against a reference commit's identify/ run in the same process (``--reference``,
default 0d38036, the code before the whitened verdict and the re-centred force fits; target: each
under 2 minutes of CPU). The earlier reference 77c6860 no longer runs against today's model data (its
TOML writer refuses an infinite value).

The FRF set comes from the independent generator (tests/generators/tx200.py): a tool-holder mode
(230 Hz, zeta 0.025, modal mass 0.3 kg, along TCP x) and axis 3 softer (x0.75), 6 poses x 4 pairs x
400 lines, 2 % noise. The force set comes from the independent force generator
(tests/generators/forces.py): edge coefficients (Kte 30, Kre 20 N/mm) and a 2.5 kHz dynamometer,
2 N noise. The old code is identify/ as of the reference, extracted with ``git archive`` into a
temporary package and called directly (its pipeline, its effect library). CPU time is
``time.process_time`` of this process (the machines are shared: wall times are not comparable).

    python bench/bench_identify_speed.py
    python bench/bench_identify_speed.py --forces     # also the force set
    python bench/bench_identify_speed.py --reference 77c6860
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
from robolobes.identify import IdentifyProblem, StepwiseSelection, identify, model_state, read_measurement  # noqa: E402  (same)

OLD = "0d38036"


def old_package(tmp: Path, ref: str):
    """identify/ at commit ``ref`` as the package ``identify_old`` (its own effect registry)."""
    arch = subprocess.run(["git", "-C", str(ROOT), "archive", ref, "identify"], check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(tmp)], input=arch, check=True)
    (tmp / "identify").rename(tmp / "identify_old")
    (tmp / "identify_old" / "__init__.py").write_text("")   # its guard refuses any name but robolobes.identify
    sys.path.insert(0, str(tmp))
    for m in ("identify_old.structural", "identify_old.cutting_effects"):   # register into the old registry
        importlib.import_module(m)
    return importlib.import_module("identify_old.frf"), importlib.import_module("identify_old.forces")


def cpu(fn):
    t0 = time.process_time()
    out = fn()
    return out, time.process_time() - t0


def frf_bench(tmp: Path, old_frf, ref: str) -> None:
    f0, m = 230.0, 0.3
    eff = Effects(tool_modes=((f0, 0.025, m * (2 * math.pi * f0) ** 2, (1.0, 0.0, 0.0)),), joint_scale={3: (0.75, 1.0)})
    d = tmp / "frf"
    truth = write_frf_set(d, eff, n_poses=6, f_hz=np.linspace(2, 300, 400), rel_noise=0.02, seed=0)
    meas = read_measurement(d)
    state, _ = model_state(meas)
    # a first run fills the linearizations that both codes share (whichever ran first would pay for them)
    _, t_cold = cpu(lambda: identify(IdentifyProblem(meas, state), StepwiseSelection(poles=False)))
    print(f"  (a first, cold run: CPU {t_cold:.1f} s, the pose linearizations cached after it)")
    new, t_new = cpu(lambda: identify(IdentifyProblem(meas, state), StepwiseSelection(poles=False)))
    old, t_old = cpu(lambda: old_frf.identify_frf(meas, state, poles=False))
    print(f"FRF set, 6 poses x 4 pairs x 400 lines, tool mode + axis-3 stiffness (noise error {truth['noise_error']:.4f}):")
    for lab, r, t in (("now", new, t_new), (ref, old, t_old)):
        print(f"  {lab:8s} CPU {t:7.1f} s (target < 120 s: {'met' if t < 120 else 'NOT met'}); effects "
              f"{[e.name for e in r.effects]}; held-out error {r.error_before:.4f} -> {r.error_after:.4f}, "
              f"noise floor {r.noise_floor:.4f}")
    print(f"  CPU ratio now / {ref}: {t_new / t_old:.3f}")


def forces_bench(tmp: Path, old_forces, ref: str) -> None:
    from generators.forces import ForceEffects, write_force_set

    d = tmp / "forces"
    write_force_set(d, ForceEffects(kte_n_per_m=3e4, kre_n_per_m=2e4, dynamometer=(2500.0, 0.04)), noise_n=2.0, seed=0)
    from robolobes.identify import force_model

    meas = read_measurement(d)
    state, _ = model_state(meas)
    # both cold, as a user's command is: each code's memoised model runs cleared before it (the compiled
    # time-domain kernel is shared and loaded by a first short run)
    identify(IdentifyProblem(meas, state))
    force_model._CACHE.clear()
    new, t_new = cpu(lambda: identify(IdentifyProblem(meas, state)))
    old_cache = importlib.import_module("identify_old.force_model")._CACHE
    old_cache.clear()
    old, t_old = cpu(lambda: old_forces.identify_forces(meas, state))
    print("force set, 0.15 s at 56.1 kHz, edge coefficients + dynamometer 2.5 kHz, 2 N noise:")
    for lab, r, t in (("now", new, t_new), (ref, old, t_old)):
        print(f"  {lab:8s} CPU {t:7.1f} s (target < 120 s: {'met' if t < 120 else 'NOT met'}); effects "
              f"{[e.name for e in r.effects]}; held-out error {r.error_before:.4f} -> {r.error_after:.4f}")
    print(f"  CPU ratio now / {ref}: {t_new / t_old:.3f}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--forces", action="store_true", help="also the force set")
    ap.add_argument("--forces-only", action="store_true", help="the force set alone (not the FRF set)")
    ap.add_argument("--reference", default=OLD, help=f"commit whose identify/ is the reference (default {OLD})")
    args = ap.parse_args(argv)
    ref = args.reference
    with tempfile.TemporaryDirectory() as tmp:
        old_frf, old_forces = old_package(Path(tmp), ref)
        if not args.forces_only:
            frf_bench(Path(tmp), old_frf, ref)
        if args.forces or args.forces_only:
            forces_bench(Path(tmp), old_forces, ref)
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
