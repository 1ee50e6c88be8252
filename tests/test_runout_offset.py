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
    from dataclasses import replace

    from robolobes.identify.cutting_effects import Runout
    from robolobes.identify.effects import ModelState

    # a three-tooth 110/130/120 deg tool: (e, phi) both enter (two-tooth tools fit one coordinate)
    tool3 = replace(alu_case.tool, teeth=3, pitch_rad=tuple(math.radians(p) for p in (110, 130, 120)),
                    runout_m=(0.0, 0.0, 0.0))
    st = ModelState(case=replace(alu_case, tool=tool3))
    c1 = math.cos(st.case.tool.tooth_angle_rad[1])

    class Ctx:
        def raw_averages(self, s):
            r = np.array(s.case.tool.runout_m) * 1e5
            return [np.full((4, 3), r[0] + 3 * r[1] - 2 * r[0] ** 2 + 5 * (r[1] - r[0] * c1) ** 2)]

    fam = Runout().family(Ctx(), st)
    for v in ((1.2e-5, 0.7), (2.9e-5, -2.5), (3e-6, 3.0)):
        exp = Ctx().raw_averages(Runout().apply_values(st, v))
        assert_allclose(fam(v)[0], exp[0], rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("pitch_deg", [(180, 180), (170, 190), (150, 210)])
def test_two_tooth_fit_coordinate_is_the_radius_difference(pitch_deg):
    """The runout fit's one coordinate on a two-tooth tool (``Runout.fit_coordinates``). Closed form:
    ``cos(theta_1 - phi) - cos(phi) = -2 sin(p) sin(p - phi)``, ``p = theta_1 / 2``, so for any (e, phi)
    ``r_1 - r_0 = -2 s sin(p)`` with ``s = e sin(p - phi)``; the values it stands for have that
    difference, zero mean radius and the smallest amplitude ``|r_1 - r_0| / (2 |sin p|)``."""
    from robolobes.identify.cutting_effects import Runout

    tool = Tool(diameter_m=0.01, teeth=2, pitch_rad=tuple(math.radians(p) for p in pitch_deg))
    fc = Runout().fit_coordinates(tool)
    p = 0.5 * (tool.tooth_angle_rad[1] - tool.tooth_angle_rad[0])
    for e, phi in [(7e-6, 0.7), (2e-5, -2.1), (3e-6, 3.0)]:
        r = eccentric_runout(tool, e, phi)
        s = fc.from_values(np.array([e, phi]))[0]
        # both sides from eccentric_runout's radii; s from the coordinate map: 1e-12 relative (rounding)
        assert_allclose(r[1] - r[0], -2 * s * math.sin(p), rtol=1e-12, atol=1e-20)
        v = fc.to_values(np.array([s]))
        rv = eccentric_runout(tool, v[0], v[1])
        assert_allclose(rv[1] - rv[0], r[1] - r[0], rtol=1e-12, atol=1e-20)
        assert_allclose(rv.sum(), 0.0, atol=1e-18)
        assert_allclose(v[0], abs(r[1] - r[0]) / (2 * abs(math.sin(p))), rtol=1e-12)
    assert np.all(fc.lower == -fc.upper) and fc.upper[0] == Runout().upper[0]


def test_two_tooth_family_is_exact_for_a_cubic_in_its_coordinate(alu_case):
    """On the 170/190 deg aluminium tool the family is a cubic spline in ``s`` over 5 runs of the
    canonical values (zero mean radius): exact for an output cubic in the radius difference, and the
    same for every (e, phi) with the same difference (the mean radius is not fitted)."""
    from robolobes.identify.cutting_effects import Runout
    from robolobes.identify.effects import ModelState

    st = ModelState(case=alu_case)

    class Ctx:
        def raw_averages(self, s):
            r = np.array(s.case.tool.runout_m) * 1e5
            d = r[1] - r[0]
            return [np.full((4, 3), 1.0 + 2 * d - 3 * d ** 2 + 0.5 * d ** 3 + 7 * (r[0] + r[1]))]

    fam = Runout().family(Ctx(), st)
    fc = Runout().fit_coordinates(alu_case.tool)
    for v in ((1.2e-5, 0.7), (2.9e-5, -2.5), (3e-6, 3.0)):
        canon = fc.to_values(fc.from_values(np.array(v)))
        exp = Ctx().raw_averages(Runout().apply_values(st, canon))
        # a cubic is reproduced by the not-a-knot spline to rounding
        assert_allclose(fam(v)[0], exp[0], rtol=1e-9, atol=1e-12)
