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


def test_runout_family_reproduces_forces_quadratic_in_the_radii():
    """The identification family (3 x 3 runs in (e cos phi, e sin phi), biquadratic) is exact for any
    model output of degree <= 2 in the tooth radii (the radii are linear in (a, b)); the stand-in
    context returns such outputs instead of simulating."""
    from robolobes.cases import load_case
    from robolobes.identify.cutting_effects import Runout
    from robolobes.identify.effects import ModelState

    class Ctx:
        def raw_averages(self, st):
            r = np.array(st.case.tool.runout_m) * 1e5
            return [np.full((4, 3), r[0] + r[1] ** 2), np.full((4, 3), r[0] * r[1] - 3 * r[0] ** 2)]

    st = ModelState(case=load_case("tx200-aluminium"))   # 170/190 deg pitch: (e, phi) both enter
    fam = Runout().family(Ctx(), st)
    for v in ((1.2e-5, 0.7), (2.9e-5, -2.5), (3e-6, 3.0)):
        exp = Ctx().raw_averages(Runout().apply_values(st, v))
        for g, x in zip(fam(v), exp):
            assert_allclose(g, x, rtol=1e-9, atol=1e-12)
