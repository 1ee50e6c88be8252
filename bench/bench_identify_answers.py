"""Draw sets from the independent generator (tests/generators) through ``robolobes identify`` and count
the right answers per case (what "right" means: tests/generators/draws.py, docs/guide/identify-answers.md).

Every draw prints one line as it finishes (case, seed, right, why not, identified effects, the final
error over the noise floor, the reported noise floor over the true noise error, CPU seconds); the
table of counts comes at the end. Seeds run round-robin over the cases, so a run cut short still
has counts for every case.

    python bench/bench_identify_answers.py                 # 5 draws per case, 20 nulls
    python bench/bench_identify_answers.py --seeds 2 --nulls 4 --cases null,base_z
"""

import argparse
import os
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from generators.draws import CASES, run_case


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=5, help="draws per case (default 5)")
    ap.add_argument("--nulls", type=int, default=20, help="null draws (default 20)")
    ap.add_argument("--cases", default=",".join(CASES), help="comma-separated cases")
    ap.add_argument("--first-seed", type=int, default=1, help="seeds start here (default 1)")
    args = ap.parse_args(argv)
    cases = [c for c in args.cases.split(",") if c]
    plan = []
    for k in range(max(args.seeds, args.nulls)):
        s = args.first_seed + k
        plan += [(c, s) for c in cases if k < (args.nulls if c == "null" else args.seeds)]
    got: dict = {c: [] for c in cases}
    with tempfile.TemporaryDirectory() as tmp:
        for c, s in plan:
            r = run_case(c, s, Path(tmp))
            got[c].append(r)
            print(f"{c:16s} seed {s:2d}: {'right' if r['right'] else 'WRONG'}  identified {r['identified']}  "
                  f"error/floor {r['ratio']:.3g}  floor/true noise {r['floor_ratio']:.3f}  cpu {r['cpu_s']:.0f} s"
                  + (f"  ({r['why']})" if r["why"] else ""), flush=True)
    print("\n| case | draws | right | noise floor within 20 % | CPU s per draw (mean) |\n|---|---|---|---|---|")
    for c in cases:
        rs = got[c]
        if rs:
            print(f"| {c} | {len(rs)} | {sum(r['right'] for r in rs)} | {sum(r['floor_ok'] for r in rs)} | "
                  f"{sum(r['cpu_s'] for r in rs) / len(rs):.0f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
