"""Per-slice block edges (lobes/entry_shift.py ``slice_edge_angles``, ``slice_edge_rad`` of the SDM):
the engagement of each axial slice set by the tool's deflection when that slice meets the block edge.
References: the closed-form engagement ``acos(-(R - ae + y) / R)``, and the existing path through
the cut's own radial depth (a uniform edge at ``ae - d`` must be the problem cut at ``ae - d``)."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Literal

import numpy as np
import pytest

from robolobes.cases.milling import Cut, CuttingLaw, Tool, engagement_rad
from robolobes.lobes import LobeProblem, ModalStructure, Mode, SemiDiscretization
from robolobes.lobes._errors import LobeError
from robolobes.lobes.entry_shift import entry_shift_exponent, slice_edge_angles

LAW = CuttingLaw(ktc_pa=661.553e6, krc_pa=253.458e6)
METHOD = SemiDiscretization(m=20, axial_slices=8)


def _problem(mode: Literal["down", "up"] = "down", helix_deg=30.0, ae=4e-3, ap=1.5e-3):
    k = 0.03993 * (2 * math.pi * 922.0) ** 2
    structure = ModalStructure((Mode(922.0, 0.011, k, (1.0, 0.0)), Mode(922.0, 0.011, k, (0.0, 1.0))))
    tool = Tool(diameter_m=0.01, teeth=2, helix_rad=math.radians(helix_deg))
    cut = Cut(ae_m=ae, ap_m=ap, spindle_rpm=10000.0, mode=mode, feed_per_tooth_m=3e-5)
    return LobeProblem(structure, tool, cut, LAW)


def _exp(p, edges=None):
    return entry_shift_exponent(p, METHOD, with_entry=True, surface_tilt=True, slice_edge_rad=edges).value_per_s


@pytest.mark.parametrize("mode", ["down", "up"])
def test_uniform_edge_at_a_narrower_cut_is_that_cut(mode: Literal["down", "up"]):
    # A uniform edge at the engagement of ae - d must give the exponent of the problem cut at ae - d
    # (the existing path, which moves the edge through the cut). 1e-9 relative: only the set of
    # candidate steps differs (steps with a zero directional matrix), i.e. rounding.
    p = _problem(mode)
    d = 0.4e-3
    narrow = replace(p, cut=replace(p.cut, ae_m=p.cut.ae_m - d))
    st, ex = engagement_rad(narrow.tool, narrow.cut)
    edge = np.full(8, st if mode == "down" else ex)
    ref = _exp(narrow)
    assert _exp(p, edge) == pytest.approx(ref, rel=1e-9, abs=1e-9)
    assert abs(ref - _exp(p)) > 1.0  # the narrowing matters: the check can fail


def test_own_edge_is_the_plain_term_and_a_tilted_edge_is_not():
    # The cut's own edge on every slice reproduces the plain exponent (1e-12: same arithmetic);
    # edges that differ along the helix give another exponent.
    p = _problem()
    st, _ = engagement_rad(p.tool, p.cut)
    assert _exp(p, np.full(8, st)) == pytest.approx(_exp(p), rel=1e-12, abs=1e-12)
    assert abs(_exp(p, st + np.linspace(-0.1, 0.1, 8)) - _exp(p)) > 1e-3


@pytest.mark.parametrize("mode", ["down", "up"])
def test_slice_edge_angles_closed_form(mode: Literal["down", "up"]):
    # A constant deflection y: every slice at the closed-form edge of ae - y (down) / ae + y (up).
    p = _problem(mode)
    y = 3e-4
    e = slice_edge_angles(p.tool, p.cut, 8, lambda a: np.full_like(a, y))
    cut = replace(p.cut, ae_m=p.cut.ae_m - y if mode == "down" else p.cut.ae_m + y)
    st, ex = engagement_rad(p.tool, cut)
    np.testing.assert_allclose(e, st if mode == "down" else ex, rtol=0, atol=1e-12)


def test_slice_edge_angles_solve_the_edge_equation_at_each_slices_instant():
    # A deflection varying with the spindle angle: each slice's angle must satisfy
    # cos(phi) = -(R - ae + y(phi - theta_0 + psi(z_s))) / R at its own instant (residual 1e-12),
    # and the slices differ (the helix lag moves the instant).
    p = _problem()
    tool, cut = p.tool, p.cut

    def y(a):
        return 2e-4 + 1e-4 * np.sin(2 * a + 0.3)
    e = slice_edge_angles(tool, cut, 8, y)
    psi = tool.lag_rad((np.arange(8) + 0.5) * cut.ap_m / 8)
    a = e - tool.tooth_angle_rad[0] + psi
    np.testing.assert_allclose(np.cos(e), -(tool.radius_m - cut.ae_m + y(a)) / tool.radius_m, rtol=0, atol=1e-12)
    assert np.ptp(e) > 1e-3


def test_bad_edges_are_refused():
    p = _problem()
    with pytest.raises(LobeError):
        _exp(p, np.zeros(3))
    with pytest.raises(LobeError):
        _exp(p, np.full(8, 4.0))
    with pytest.raises(LobeError):
        slice_edge_angles(replace(p.tool, pitch_rad=(3.0, 2 * math.pi - 3.0)), p.cut, 8, lambda a: 0 * a)
