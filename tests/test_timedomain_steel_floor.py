"""Near the steel damping bracket the eroded part's regenerative mode starts below the verdict's
2 nm resolution (no kick); kicked, it follows the SDM with the feed terms in slope, with an offset
that the SDM linearized about the pass's forced orbit (the delayed instant, and the deflection
when the teeth meet the part) removes (docs/guide/timedomain-convergence.md, "The steel damping
bracket: the eroded part's floor"). Study settings: basic model, Tab. 7 start pose, linearized path, 2 deg
per step, 1 um columns, the tool without runout (the run the study's verdict comes from), the
verdict's first 2 s of full engagement."""

from __future__ import annotations

import json
import math
import warnings
from dataclasses import replace
from pathlib import Path
from typing import cast

import numpy as np
import pytest

from robolobes.cases.milling import principal_period
from robolobes.lobes.entry_shift import entry_shift_exponent
from robolobes.lobes.sdm import SemiDiscretization
from robolobes.study import compute
from robolobes.study.linearizations import Linearizations
from robolobes.timedomain import LinearizedNewmark, SimulationProblem, simulate
from robolobes.timedomain.forced_orbit import entry_deflection, mean_deflection
from robolobes.timedomain.result import SimulationResult
from robolobes.timedomain.verdict import GrowthRule, growth_rate

SCALES = (11.73, 11.84)
ORBIT_SCALE = 11.84  # the study's probe where the eroded part and the SDM's bracket met
KICK_M = 1e-7  # the speed of a 100 nm oscillation at the flip frequency
DY_M = json.loads((Path(__file__).resolve().parents[1] / "docs" / "study-results.json").read_text())[
    "steel_damping"]["eroded_deflection_m"]  # the committed quick study's mean eroded deflection (80.48 um)
WINDOW_S = 2.0  # the verdict's window of the study's companion run


@pytest.fixture(scope="module")
def runs():
    """{scale: (rate, se, smallest block amplitude m, SDM exponent with both feed terms)}."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the Tab. 7 pose is 2.86 deg past A3's limit (accepted, warned)
        cs, pas, _ = compute.load_inputs()
        steel, lins = cs["steel"], Linearizations()
        theta = compute.study_poses(pas)["start"]
        case0 = replace(steel, tool=replace(steel.tool, runout_m=(0.0,) * steel.tool.teeth))
        tp, _ = principal_period(steel.tool, steel.cut)
        v = 2 * math.pi / (2 * tp) * KICK_M
        ae_dy = replace(steel, cut=replace(steel.cut, ae_m=steel.cut.ae_m - DY_M))
        out = {}
        for sc in SCALES:
            robot = lins.robot(steel.robot, "basic", sc)
            r = cast(SimulationResult, simulate(SimulationProblem(robot, case0, t_end_s=4.5),
                                                LinearizedNewmark(kick_m_s=v), verdict_companion=False))
            assert r.summary is not None
            t0 = r.summary.to_json()["steady_window_s"][0]
            g = growth_rate(r.t_s, np.asarray(r.tcp_deviation_m)[:, :2], tp, t_start_s=t0, t_end_s=t0 + WINDOW_S,
                            rule=GrowthRule(resolution_m=1e-15))
            _, st = lins.structure(steel, "basic", "start", theta, damping_scale=sc)
            e = entry_shift_exponent(compute._lobe_problem(st, ae_dy), SemiDiscretization(m=40), surface_tilt=True)
            out[sc] = (g.rate_per_s, g.se_per_s, float(np.exp(g.block_log_amp).min()), e.value_per_s)
            if sc == ORBIT_SCALE:
                out["orbit"] = _orbit_reference(r, steel, st)
    return out


def _orbit_reference(r, steel, st) -> tuple[float, float, float]:
    """(entry deflection m, mean deflection m, SDM exponent 1/s with the entry shift, the tilt and the
    delayed instant at ae minus the entry deflection): the eroded part's linearization about its
    forced orbit."""
    dy_in, dy_mean = entry_deflection(r), mean_deflection(r)
    case = replace(steel, cut=replace(steel.cut, ae_m=steel.cut.ae_m - dy_in))
    e = entry_shift_exponent(compute._lobe_problem(st, case), SemiDiscretization(m=40), surface_tilt=True,
                             delay_time=True)
    return dy_in, dy_mean, float(e.value_per_s)


def test_kicked_mode_is_above_the_floor_and_follows_the_sdm_slope(runs):
    # Above the floor: every block at least 10 x the verdict's 2 nm resolution (measured 94-96 nm;
    # unkicked 1.1-2.5 nm, so the test fails without the kick).
    assert all(r[2] > 2e-8 for r in runs.values())
    # The change of the rate between the two scales is the SDM's within 10 % plus 2 SE of the
    # difference (measured +0.397 ± 0.017 against +0.401 1/s; the verdict's clamped fit unkicked
    # gives +0.660, the flat slope this file is about).
    (r1, s1, _, e1), (r2, s2, _, e2) = (runs[sc] for sc in SCALES)
    assert abs((r1 - r2) - (e1 - e2)) <= 0.1 * abs(e1 - e2) + 2 * math.hypot(s1, s2)


def test_kicked_rate_matches_the_sdm_linearized_about_the_forced_orbit(runs):
    # The eroded part's own linearization: the SDM (a second method) with the entry shift, the
    # tilt and the delayed instant (lobes.entry_shift_exponent(..., delay_time=True)), at ae minus
    # the deflection when the teeth meet the part (the forced orbit's, timedomain.forced_orbit),
    # not its mean. The project's like-with-like criterion: max(10 % |sigma|, 0.03 1/s) + 2 SE
    # (measured +0.297 ± 0.012 against +0.304 1/s at 70.4 um; the SDM at ae minus the mean with the
    # two feed terms only, -0.174, misses it by 0.47, so the test fails without the orbit and the
    # delayed instant).
    rate, se, _, _ = runs[ORBIT_SCALE]
    dy_in, dy_mean, e = runs["orbit"]
    assert dy_in < dy_mean - 5e-6  # the teeth meet the part on the low side of the forced orbit
    assert abs(rate - e) <= max(0.1 * abs(e), 0.03) + 2 * se
