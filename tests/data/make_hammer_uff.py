"""Write tests/data/hammer_tooltip.uff: a synthetic hammer test of a tool tip (UFF58 accelerance).

Provenance (everything the file holds comes from here; nothing from robolobes):

* model: two uncoupled modes of the tool tip, in the measured axes x (along the feed) and y (the
  cut normal):  x: 922 Hz, zeta 0.011, k 1.340049648e6 N/m;  y: 1100 Hz, zeta 0.02, k 2e6 N/m;
  receptance ``H(w) = 1 / (k (1 - r^2 + 2 i zeta r))``, ``r = w / w_n``; no cross terms;
* stored as accelerance ``A = -w^2 H`` in m/s^2 per N (UFF ordinate type 12, force 13), the
  driving points xx (directions +1/+1) and yy (directions -2/-2: the sign convention of many
  hammer set-ups, which cancels on a driving point);
* lines 200-2500 Hz every 1 Hz (2301 lines; 20 lines per half-power bandwidth at 922 Hz);
* noise: complex Gaussian, per line 1 % RMS of |A| plus 0.05 % RMS of the largest |A| of the
  pair, numpy default_rng(17).

Run ``python tests/data/make_hammer_uff.py [OUT]`` (default: next to this script); it refuses to
overwrite an existing file.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

MODES = {"xx": (922.0, 0.011, 1.340049648e6), "yy": (1100.0, 0.02, 2e6)}
DIRS = {"xx": (1, 1), "yy": (-2, -2)}
F_HZ = np.arange(200.0, 2500.0 + 0.5, 1.0)
SEED = 17


def accelerance(pair: str, f_hz: np.ndarray) -> np.ndarray:
    fn, z, k = MODES[pair]
    r = f_hz / fn
    return -(2 * math.pi * f_hz) ** 2 / (k * (1 - r**2 + 2j * z * r))


def noisy(a: np.ndarray, rng) -> np.ndarray:
    sigma = 0.01 * np.abs(a) + 0.0005 * np.abs(a).max()
    return a + sigma * (rng.standard_normal(a.shape) + 1j * rng.standard_normal(a.shape)) / math.sqrt(2)


def main(out: Path) -> None:
    import pyuff

    if out.exists():
        raise SystemExit(f"{out} exists; not overwritten")
    rng = np.random.default_rng(SEED)
    sets = []
    for pair in ("xx", "yy"):
        a = noisy(accelerance(pair, F_HZ), rng)
        rsp, ref = DIRS[pair]
        sets.append(pyuff.prepare_58(
            binary=0, id1=f"synthetic hammer test H{pair}", id2="tests/data/make_hammer_uff.py",
            func_type=4, rsp_node=1, rsp_dir=rsp, ref_node=1, ref_dir=ref, ord_data_type=6,
            num_pts=len(F_HZ), abscissa_spacing=1, abscissa_min=float(F_HZ[0]), abscissa_inc=1.0,
            abscissa_spec_data_type=18, ordinate_spec_data_type=12, orddenom_spec_data_type=13,
            ordinate_axis_units_lab="m/s^2", orddenom_axis_units_lab="N",
            data=np.ascontiguousarray(a, dtype=np.complex128), x=F_HZ))
    pyuff.UFF(str(out)).write_sets(sets, mode="add")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).with_name("hammer_tooltip.uff"))
