"""Runout as an axis offset (amplitude, phase): :func:`cases.milling.eccentric_runout`.

Closed form: a tool axis offset by ``e`` towards angle ``phi`` puts a tip at angle ``theta`` at
distance ``|R u(theta) + e u(phi)| = R + e cos(theta - phi) + O(e^2 / R)`` from the spindle axis.
"""

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from robolobes.cases.milling import MillingError, Tool, eccentric_runout


@pytest.mark.parametrize("pitch_deg", [(180, 180), (120, 120, 120), (80, 100, 90, 90)])
def test_offset_matches_the_geometry_of_a_displaced_circle(pitch_deg):
    tool = Tool(diameter_m=0.01, teeth=len(pitch_deg), pitch_rad=tuple(math.radians(p) for p in pitch_deg))
    e, phi = 7e-6, 0.7
    r = eccentric_runout(tool, e, phi)
    th = tool.tooth_angle_rad
    # exact distance of each tip from the spindle axis, from vectors (independent of the formula)
    tips = tool.radius_m * np.stack([np.cos(th), np.sin(th)], 1) + e * np.array([math.cos(phi), math.sin(phi)])
    exact = np.linalg.norm(tips, axis=1) - tool.radius_m
    # first order in e/R: error ~ e^2 / (2R) = 1e-8 m
    assert_allclose(r, exact, atol=2 * e ** 2 / tool.radius_m)


def test_two_equal_teeth_see_only_e_cos_phi():
    tool = Tool(diameter_m=0.01, teeth=2)
    assert_allclose(eccentric_runout(tool, 4e-6, math.pi / 2), [0.0, 0.0], atol=1e-18)
    assert_allclose(eccentric_runout(tool, 4e-6, math.pi / 3), [2e-6, -2e-6], rtol=1e-12)


def test_negative_amplitude_is_rejected():
    with pytest.raises(MillingError, match="amplitude"):
        eccentric_runout(Tool(diameter_m=0.01, teeth=2), -1e-6, 0.0)


def test_runout_family_is_exact_for_outputs_without_cross_terms(alu_case):
    """The identification family (cubic spline in a = e cos phi over 5 runs, plus the quadratic change
    b = e sin phi makes at a = 0) is exact for any model output that is a quadratic in a plus a
    quadratic in b (no a*b term); the stand-in context returns such an output instead of simulating.
    With theta = (0, theta_1): r_0 = a, r_1 = a cos theta_1 + b sin theta_1."""
    import math

    from robolobes.identify.cutting_effects import Runout
    from robolobes.identify.effects import ModelState

    st = ModelState(case=alu_case)   # 170/190 deg pitch: (e, phi) both enter
    c1 = math.cos(st.case.tool.tooth_angle_rad[1])

    class Ctx:
        def raw_averages(self, s):
            r = np.array(s.case.tool.runout_m) * 1e5
            return [np.full((4, 3), r[0] + 3 * r[1] - 2 * r[0] ** 2 + 5 * (r[1] - r[0] * c1) ** 2)]

    fam = Runout().family(Ctx(), st)
    for v in ((1.2e-5, 0.7), (2.9e-5, -2.5), (3e-6, 3.0)):
        exp = Ctx().raw_averages(Runout().apply_values(st, v))
        assert_allclose(fam(v)[0], exp[0], rtol=1e-9, atol=1e-12)
