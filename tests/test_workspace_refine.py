"""Maps refine by default: the same accuracy rule as ``robolobes lobes`` (``lobes.RefinedSDM``), its
error estimate and status stored per (pose, speed) and summarized in map.json."""

import numpy as np
import pytest

from robolobes import cases, linearize
from robolobes.lobes import LobeProblem, PhysicalStructure, RefinedSDM, SemiDiscretization, solve
from robolobes.workspace import MapMethod, MapProblem, solve_map


@pytest.fixture(scope="module")
def steel():
    return cases.load_case("tx200-steel")


def test_default_map_is_refined_and_stores_the_estimate(steel, tx200_robot):
    # No truncation, so each pose is exactly lobes.solve with the map's refinement (same levels,
    # same search): limits and estimates equal to rtol 1e-12. The status codes are those of the
    # diagram; the summary's largest relative estimate is recomputed here from the stored arrays.
    meth = MapMethod(reduce_max_freq_hz=None, chunk_poses=2)
    assert meth.tol == 0.01
    pr = MapProblem.make(steel, "basic", "placement", n=2, x_range_m=(0.0, 0.15), y_range_m=(0.0, 0.0),
                         speeds_rpm=np.array([3100.0, 6000.0]))
    res = solve_map(pr, meth, scheduler="serial")
    ds = res.dataset
    robot = tx200_robot("basic")
    ref_method = RefinedSDM(SemiDiscretization(m=meth.m, prescan_m=meth.prescan_m), tol=0.01, m_max=320)
    rel = []
    for i in np.flatnonzero(ds["reachable"].values):
        lin = linearize.linearize(robot, ds["theta_rad"].values[i])
        feed = ds["feed_direction"].values[i]
        p = LobeProblem(PhysicalStructure.from_linear(lin, feed), steel.tool, steel.cut, steel.law)
        ref = solve(p, ref_method, pr.speeds_rpm, depth_max_m=meth.depth_max_m, rtol=meth.rtol)
        np.testing.assert_allclose(ds["depth_limit_m"].values[i], ref.depth_limit_m, rtol=1e-12)
        np.testing.assert_allclose(ds["depth_error_m"].values[i], ref.depth_error_m, rtol=1e-12)
        want = np.where(ref.status == "unconverged", 1, 0)
        assert np.array_equal(ds["unconverged"].values[i], want)
        fin = np.isfinite(ref.depth_limit_m)
        rel.extend((ref.depth_error_m[fin] / ref.depth_limit_m[fin]).tolist())
    assert rel, "no finite limit to check"
    s = res.summary()
    assert s["max_depth_error_rel"] == pytest.approx(max(rel), rel=1e-12)
    assert s["n_unconverged"] == int((ds["unconverged"].values == 1).sum())
    if s["n_unconverged"] == 0:
        assert s["max_depth_error_rel"] <= 0.01
