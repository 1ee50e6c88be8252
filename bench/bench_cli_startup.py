"""Start-up cost of the command line, in CPU seconds of the child process (user + system).

Run: .venv/bin/python bench/bench_cli_startup.py [--repeats N]

Times, each the minimum over N runs (the least disturbed on a loaded machine):

* ``python -c 'import numpy, scipy.linalg'`` (the reference: what any numerical script pays);
* ``robolobes --help`` and ``robolobes lobes --help`` (target: under 0.3 s);
* ``robolobes lobes --modal M.toml ... --json`` on a 2-mode model, 20 speeds (target: within
  0.2 s of the reference).

It prints each time, the differences to the reference and the ratios.
"""

from __future__ import annotations

import argparse
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

# the symmetric 2-DOF benchmark of the lobe tests
MODAL_FILE = Path(__file__).resolve().parents[1] / "tests" / "data" / "two_dof_benchmark_modes.toml"
TOOL = ["--teeth", "2", "--diameter-mm", "10", "--ae-mm", "0.5", "--down", "--ktc-mpa", "600", "--krc-mpa", "200"]


def child_cpu(cmd: list[str], cwd: str) -> float:
    """CPU seconds (user + system) of one run of ``cmd``."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(cmd, cwd=cwd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    py = sys.executable
    cli = [py, "-m", "robolobes"]
    with tempfile.TemporaryDirectory() as tmp:
        Path(tmp, "m.toml").write_text(MODAL_FILE.read_text())
        runs = {
            "import numpy, scipy.linalg": [py, "-c", "import numpy, scipy.linalg"],
            "robolobes --help": cli + ["--help"],
            "robolobes lobes --help": cli + ["lobes", "--help"],
            "robolobes lobes --modal (2 modes) --json": cli + ["lobes", "--modal", "m.toml", *TOOL, "--n-rpm", "20",
                                                              "--json", "--quiet"],
        }
        t = {name: min(child_cpu(cmd, tmp) for _ in range(args.repeats)) for name, cmd in runs.items()}
    ref = t["import numpy, scipy.linalg"]
    print(f"CPU seconds, minimum of {args.repeats} runs")
    for name, v in t.items():
        print(f"  {name:42s} {v:6.3f} s   {v - ref:+6.3f} s vs reference   ratio {v / ref:5.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
