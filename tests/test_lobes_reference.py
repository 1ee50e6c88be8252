"""Convergence studies behind the reference numbers of test_lobes.py (slow).

``python tests/test_lobes_reference.py --write`` recomputes every table and writes
tests/data/lobes_reference.json (atomically); the slow tests recompute the tables up to m = 320
and check them against the file and the converged values quoted in test_lobes.py.

All values are computed here by this code (not published values; see tests/data/README.md).
Tables (parameters of the Insperger & Stepan 2004 benchmark, SDM with exact step averages):
* ``rho``: spectral radius, 1-DOF (feed), a/D = 0.05 down, 10 000 rpm, 1 mm, m = 10..640;
* ``limit_full``: critical depth, 1-DOF, a/D = 1, 10 126 rpm, m = 10..320, both schemes;
* ``min_1dof``: flip-lobe minimum (rpm, depth), 1-DOF, a/D = 0.05, m = 20..640;
* ``min_2dof``: flip-lobe minimum, symmetric 2-DOF, a/D = 0.05, down and up, m = 20..640.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.optimize import minimize_scalar

from lobes_benchmark import limit, problem, radius

from robolobes.core.numerics import richardson
from robolobes.lobes import SemiDiscretization, solve

DATA = Path(__file__).resolve().parent / "data" / "lobes_reference.json"


def lobe_min(p, m, lo, hi):
    """Minimum of the limit over [lo, hi] rpm: 26-point scan, then bounded 1-D minimization."""
    meth = SemiDiscretization(m=m)
    sp = np.linspace(lo, hi, 26)
    r = solve(p, meth, sp, rtol=1e-6)
    j = int(np.argmin(r.depth_limit_m))
    a, b = sp[max(j - 1, 0)], sp[min(j + 1, len(sp) - 1)]
    res = minimize_scalar(lambda s: limit(p, meth, s), bounds=(a, b), method="bounded", options={"xatol": 0.01})
    return [float(res.x), float(res.fun)]  # pyright: ignore[reportAttributeAccessIssue]  # scipy's stub: object


def finest_richardson(table: dict) -> float:
    """Richardson value (core.numerics) of the two finest levels of a {m: value} table."""
    ms = sorted(table, key=int)
    return float(richardson(table[ms[-2]], table[ms[-1]]).value)


def compute(max_m: int = 640) -> dict:
    out: dict = {"note": "SDM (first order, exact step averages); depths in m, speeds in rpm"}
    p = problem(0.05)
    out["rho"] = {str(m): radius(p, SemiDiscretization(m=m)) for m in (10, 20, 40, 80, 160, 320, 640) if m <= max_m}
    pf = problem(1.0)
    out["limit_full"] = {s: {str(m): limit(pf, SemiDiscretization(m=m, scheme=s), 10126.0)
                             for m in (10, 20, 40, 80, 160, 320) if m <= min(max_m, 320)}
                         for s in ("sdm", "free-exact")}
    out["min_1dof"] = {str(m): lobe_min(p, m, 17800, 18600) for m in (20, 40, 80, 160, 320, 640) if m <= max_m}
    for mode in ("down", "up"):
        p2 = problem(0.05, ((1, 0), (0, 1)), mode=mode)
        out[f"min_2dof_{mode}"] = {str(m): lobe_min(p2, m, 18300, 19100)
                                   for m in (20, 40, 80, 160, 320, 640) if m <= max_m}
    return out


@pytest.mark.slow
def test_reference_tables_reproduce_and_converge():
    ref = json.loads(DATA.read_text())
    new = compute(max_m=320)
    for key in ("rho", "min_1dof", "min_2dof_down", "min_2dof_up"):
        for m, v in new[key].items():
            # deterministic code: the stored value is reproduced to the root-finding tolerance
            assert_allclose(v, ref[key][m], rtol=1e-6)
    for s in ("sdm", "free-exact"):
        for m, v in new["limit_full"][s].items():
            assert_allclose(v, ref["limit_full"][s][m], rtol=1e-8)
    # converged values quoted in test_lobes.py, computed here (Richardson of the two finest levels)
    assert_allclose(finest_richardson(ref["rho"]), 0.704893, rtol=2e-6)
    assert_allclose(finest_richardson(ref["limit_full"]["sdm"]), 0.3163574e-3, rtol=1e-6)
    assert_allclose(finest_richardson(ref["limit_full"]["free-exact"]), 0.3163574e-3, rtol=1e-6)
    assert_allclose(finest_richardson({m: v[1] for m, v in ref["min_1dof"].items()}), 1.0777e-3, rtol=2e-4)
    assert_allclose(finest_richardson({m: v[1] for m, v in ref["min_2dof_down"].items()}), 0.8315e-3, rtol=2e-4)
    assert_allclose(ref["min_1dof"]["640"][0], 18190, atol=2)
    assert_allclose(ref["min_2dof_down"]["640"][0], 18702, atol=2)
    # up- and down-milling minima of the symmetric 2-DOF model coincide (1e-7 at m = 20 from where
    # the entry/exit angles fall on the mesh, 1e-12 from m = 80 on)
    for m in ref["min_2dof_down"]:
        assert_allclose(ref["min_2dof_up"][m][1], ref["min_2dof_down"][m][1], rtol=1e-6)


if __name__ == "__main__":
    if "--write" in sys.argv:
        from robolobes.core.io import write_json

        write_json(DATA, compute())
        print(f"wrote {DATA}")
