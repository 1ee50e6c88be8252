"""The study's damping search at ae - dy with and without the feed terms (entry shift and surface
tilt): CPU time of each, timed alternately in this one process on the same probes.

Both searches use the quick study's settings and the committed quick study's dy and seeds
(``docs/study-results.json``: the eroded part's and the plain ae - dy brackets, as the study seeds
the feed-terms search); the linearizations are shared and warmed first, so both time the SDM only.
Prints each search's bracket, probes and CPU, and the ratio feed terms / plain.
Usage: python bench/bench_study_feed_terms.py   (about a minute)
"""

from __future__ import annotations

import json
import time
from pathlib import Path

from robolobes.study import compute
from robolobes.study.linearizations import Linearizations
from robolobes.study.settings import StudySettings

RESULTS = Path(__file__).resolve().parents[1] / "docs" / "study-results.json"


def main() -> None:
    settings = StudySettings.make(True)
    sd = json.loads(RESULTS.read_text())["steel_damping"]
    seed = tuple(sd[k][s] for k in ("time_domain", "lobes_at_ae_minus_dy")
                 for s in ("largest_unstable_scale", "smallest_stable_scale"))
    cs, pas, _ = compute.load_inputs()
    theta, lins = compute.study_poses(pas)["start"], Linearizations()
    args = (settings, lins, cs["steel"], theta)
    compute.damping_by_lobes(*args, dy_m=sd["eroded_deflection_m"], seed=seed)  # warm the linearizations
    cpu = {False: [], True: []}
    for feed in (False, True, False, True):
        t = time.process_time()
        d = compute.damping_by_lobes(*args, dy_m=sd["eroded_deflection_m"], seed=seed, feed_terms=feed)
        cpu[feed].append(time.process_time() - t)
        print(f"feed_terms={feed!s:5} bracket [{d.bracket[0]:.4g}, {d.bracket[1]:.4g}] probes {len(d.probes)} "
              f"cpu {cpu[feed][-1]:.2f} s")
    print(f"ratio feed terms / plain (CPU, min over 2): {min(cpu[True]) / min(cpu[False]):.1f}")


if __name__ == "__main__":
    main()
