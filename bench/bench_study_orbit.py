"""The study's damping search by the SDM about the eroded part's forced orbit (at ae minus the
deflection when the teeth meet the part, with the entry shift, the surface tilt and the delayed
instant) against the plain search at ae - dy: CPU time of each, timed alternately in this one
process.

Both searches use the quick study's settings and the committed quick study's deflections and seeds
(``docs/study-results.json``: the orbit search seeded by the eroded part's bracket, the plain one by
the eroded part's and its own bracket, as the study seeds them); the linearizations are shared and
warmed first, so both time the SDM only. Prints each search's bracket, probes and CPU, and the
ratio orbit / plain.
Usage: python bench/bench_study_orbit.py   (about a minute)
"""

from __future__ import annotations

import json
import time
from pathlib import Path

from robolobes.study import compute
from robolobes.study.linearizations import Linearizations
from robolobes.study.settings import StudySettings

RESULTS = Path(__file__).resolve().parents[1] / "docs" / "study-results.json"


def _bracket(d: dict) -> tuple:
    return d["largest_unstable_scale"], d["smallest_stable_scale"]


def main() -> None:
    settings = StudySettings.make(True)
    sd = json.loads(RESULTS.read_text())["steel_damping"]
    cs, pas, _ = compute.load_inputs()
    theta, lins = compute.study_poses(pas)["start"], Linearizations()
    args = (settings, lins, cs["steel"], theta)
    plain = {"dy_m": sd["eroded_deflection_m"], "seed": _bracket(sd["time_domain"])}
    orbit = {"dy_m": sd["eroded_entry_deflection_m"], "seed": _bracket(sd["time_domain"]), "orbit": True}
    compute.damping_by_lobes(*args, **plain)  # warm the linearizations
    cpu: dict[bool, list[float]] = {False: [], True: []}
    for is_orbit in (False, True, False, True):
        t = time.process_time()
        d = compute.damping_by_lobes(*args, **(orbit if is_orbit else plain))
        cpu[is_orbit].append(time.process_time() - t)
        print(f"{d.method:30} bracket [{d.bracket[0]:.4g}, {d.bracket[1]:.4g}] probes {len(d.probes)} "
              f"cpu {cpu[is_orbit][-1]:.2f} s")
    print(f"ratio orbit / plain (CPU, min over 2): {min(cpu[True]) / min(cpu[False]):.1f}")


if __name__ == "__main__":
    main()
