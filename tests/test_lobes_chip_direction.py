"""The tilt of the regenerated surface (lobes/chip_direction.py): the first-order (fz / R) turn of the
dynamic chip's direction. References: the eroded part's own chip derivative (timedomain/workpiece.py,
an exact ray walk on the material columns, written independently of the closed form), and the SDM
without the tilt (zero feed; linearity in the feed)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from generators.ideal_cut import chip_jacobians
from robolobes import cases
from robolobes.cases.milling import directional_matrix
from robolobes.lobes.chip_direction import feed_per_radian_m, surface_rotation_rad
from robolobes.lobes.exponent import floquet_exponent
from robolobes.lobes import SemiDiscretization

from test_lobes_entry_shift import LAW, _problem

ALU = cases.load_case("tx200-aluminium")


@pytest.mark.parametrize("mode, angles", [("down", (105, 120, 135, 150, 165, 175)), ("up", (5, 15, 30, 45, 60, 75))])
def test_the_workpiece_chip_derivative_turns_by_the_closed_form_angle(mode, angles):
    # The eroded part's d h / d (tool centre) after a vibration-free cut (0.03 mm per tooth, pitch
    # 170 / 190 deg, 40 % immersion) against the ray u = (sin, cos) of the linear model and against
    # u + alpha du/dphi with alpha of the module, from each tooth's own static chip h / sin(phi).
    # Measured (down): |dh/dc - u| up to 6.7e-3, |dh/dc - (u + alpha du/dphi)| up to 3.9e-4. The
    # rest is the removal's chords (0.1 nm sagitta: facets turned by up to half their angle,
    # sqrt(8e-10 / 5e-3) / 2 = 2e-4) and the columns' linear interpolation (1 um), second order
    # terms ~(fz / R)^2 = 4e-5: bound 1e-3, while the turn itself must exceed 4e-3 somewhere.
    tool = replace(ALU.tool, helix_rad=0.0)
    cut = replace(ALU.cut, feed_per_tooth_m=3e-5, ap_m=4e-3, mode=mode)
    jac = chip_jacobians(tool, cut, set(angles))
    assert len(jac) == 2 * len(angles)
    off_u, off_g = [], []
    for (j, deg), (h, d) in jac.items():
        phi = math.radians(deg)
        assert h > 0, (j, deg)
        u, du = np.array([math.sin(phi), math.cos(phi)]), np.array([math.cos(phi), -math.sin(phi)])
        a = float(surface_rotation_rad(phi, h / math.sin(phi), tool.radius_m, feed_per_radian_m(tool, cut)))
        off_u.append(np.linalg.norm(d - u))
        off_g.append(np.linalg.norm(d - (u + a * du)))
    assert max(off_u) > 4e-3, off_u
    assert max(off_g) < 1e-3, off_g


def test_directional_matrix_with_zero_rotation_is_the_plain_one():
    phi = np.linspace(0, 2 * math.pi, 17)
    assert np.array_equal(directional_matrix(phi, LAW, np.zeros_like(phi)), directional_matrix(phi, LAW))


def test_the_tilt_vanishes_with_the_feed_and_grows_linearly_with_it():
    # alpha is linear in the feed (both terms), so the tilt's effect on the exponent is, to first
    # order: zero at zero feed (bit-identical plan: the rotation is exactly 0), and doubling with the
    # feed up to the SDM's own second order in alpha (~1e-2 relative here: 2 % tolerance).
    meth = SemiDiscretization(m=40)
    base = _problem(fz=0.0)
    assert floquet_exponent(base, meth, surface_tilt=True).value_per_s == floquet_exponent(base, meth).value_per_s
    shifts = []
    for fz in (3e-5, 6e-5):
        p = replace(base, cut=replace(base.cut, feed_per_tooth_m=fz))
        shifts.append(floquet_exponent(p, meth, surface_tilt=True).value_per_s - floquet_exponent(p, meth).value_per_s)
    assert shifts[0] != 0.0
    assert shifts[1] / shifts[0] == pytest.approx(2.0, rel=0.02), shifts
