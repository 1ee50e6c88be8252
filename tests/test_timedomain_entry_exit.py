"""Entries and exits inside a step on the eroded part (timedomain/entry_exit.py): the step integral
of the cutting force against a fine plain trapezoidal rule, on a rigid tool (no dynamics)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robolobes import cases
from robolobes.timedomain.entry_exit import step_force_correction
from robolobes.timedomain.workpiece import Workpiece
from robolobes.timedomain.workpiece_force import MillingForce, straight_path

ALU = cases.load_case("tx200-aluminium")


def _impulse(deg_per_step: float, n_discs: int, corrected: bool, revolutions=(2, 1)) -> np.ndarray:
    """Impulse of the force on the tool (N s, cut frame) over ``revolutions[1]`` revolutions after
    ``revolutions[0]``, rigid tool at constant feed starting 6 mm inside the part (steady cut from the
    second revolution on): trapezoidal rule on the step grid, with or without the correction."""
    tool, cut, law = ALU.tool, ALU.cut, ALU.law
    wp = Workpiece(tool, cut, x_entry_m=0.0, part_length_m=20e-3, discs=n_discs)
    m = MillingForce(tool, law, cut, wp)
    h = math.radians(deg_per_step) / cut.omega_rad_s
    t_start = revolutions[0] * cut.spindle_period_s
    t_stop = t_start + revolutions[1] * cut.spindle_period_s
    # the step grid from 0, restarted at the window's start and shortened at its end
    t = np.concatenate([np.arange(0.0, t_start - 1e-3 * h, h), t_start + np.arange(0.0, t_stop - t_start - 1e-3 * h, h),
                        [t_stop]])
    n = t.size - 1
    c, ang = straight_path(tool, cut, t, 6e-3)
    law_arr = np.array([law.ktc_pa, law.krc_pa, law.kac_pa, law.kte_n_per_m, law.kre_n_per_m, law.kae_n_per_m])
    off = np.ascontiguousarray(m.immersion_rad(0.0))
    rad = np.ascontiguousarray(m.tooth_radius_m)
    ev = m.evaluate(ang[0], c[0])
    f0, h0 = np.array(ev.tool_n), np.array(ev.chip_m)
    total = np.zeros(3)
    d = np.zeros(3)
    for k in range(n):
        e1 = m.evaluate(ang[k + 1], c[k + 1])
        f1, h1 = np.array(e1.tool_n), np.array(e1.chip_m)
        dt = t[k + 1] - t[k]
        if corrected:
            wb, x0, dx, sgn, _, w_top = wp._kernel_state()[:6]
            step_force_correction(wb, x0, dx, sgn, w_top, c[k, 0], c[k, 1], c[k + 1, 0], c[k + 1, 1], ang[k],
                                  ang[k + 1] - ang[k], off, rad, m.db_m, law_arr, h0, h1, d)
        else:
            d[:] = 0.0
        if t[k] >= t_start - 1e-12:
            total += 0.5 * dt * (f0 + f1 + d)
        m.commit(ang[k], c[k], ang[k + 1], c[k + 1])
        f0, h0 = f1, h1
    return total


@pytest.fixture(scope="module")
def reference():
    # The plain trapezoidal rule at 2/64 deg per step: first order at each entry and exit, with an
    # error of at most half a step of one tooth's entry jump per event (4 events a revolution),
    # ~6e-6 N s of the ~0.088 N s impulse (the error of the same rule at 2 deg divided by 64).
    return _impulse(2.0 / 64, 1, corrected=False)


@pytest.mark.parametrize("deg, bound", [(2.0, 5e-4), (1.98, 5e-4), (1.0, 1.5e-4)])
def test_corrected_step_integral_matches_the_fine_trapezoidal_rule(reference, deg, bound):
    # One tooth entering the flat block edge per tooth pass (chip ramping up over ~0.25 deg, then
    # fz sin(phi)), leaving at 180 deg with its edge force. With the entries, exits and the end of
    # the entry ramp split out, the rule is second order per event: bound 5e-4 of the impulse at
    # 2 deg and a quarter of that (plus margin) at 1 deg. The plain rule misses by more than 1e-3 of
    # it at each of these steps (by an amount that depends on where the grid falls against the
    # entries): asserted too, so the comparison can fail.
    corr = _impulse(deg, 1, corrected=True)
    plain = _impulse(deg, 1, corrected=False)
    scale = np.linalg.norm(reference)
    assert np.linalg.norm(corr - reference) <= bound * scale, (corr - reference, scale)
    assert np.linalg.norm(plain - reference) > 1e-3 * scale, (plain - reference, scale)
