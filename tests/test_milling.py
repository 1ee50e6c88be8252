"""Tests of cases.milling: geometry, force law, its linearization, cut frame, regeneration.

The references are independent of the code under test: closed-form integrals of the force law,
finite differences of the nonlinear force, hand-derived angles.
"""

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from robolobes.cases.milling import (Cut, CuttingLaw, MillingError, Tool, check_cut, cut_frame, directional_matrix,
                           edge_forces, engagement_rad, in_cut, principal_period, regeneration,
                                     tool_force_cut_frame)

D = 0.01
LAW = CuttingLaw(ktc_pa=6e8, krc_pa=2e8, kac_pa=1e8, name="test")


def test_engagement_angles_closed_form():
    tool = Tool(diameter_m=D, teeth=2)
    # down-milling, ae/D = 0.05: phi_st = arccos(2 ae/D - 1) = arccos(-0.9), phi_ex = pi
    # (Insperger et al. 2003, IJMTM 43:25); exact up to rounding.
    st, ex = engagement_rad(tool, Cut(ae_m=0.05 * D, ap_m=1e-3, spindle_rpm=1e4, mode="down"))
    assert_allclose([st, ex], [math.acos(-0.9), math.pi], rtol=1e-14)
    # up-milling: phi_st = 0, phi_ex = arccos(1 - 2 ae/D)
    st, ex = engagement_rad(tool, Cut(ae_m=0.4 * D, ap_m=1e-3, spindle_rpm=1e4, mode="up"))
    assert_allclose([st, ex], [0.0, math.acos(0.2)], rtol=1e-14, atol=0)
    # full immersion: [0, pi] for both modes
    for mode in ("up", "down"):
        st, ex = engagement_rad(tool, Cut(ae_m=D, ap_m=1e-3, spindle_rpm=1e4, mode=mode))
        assert_allclose([st, ex], [0.0, math.pi], atol=1e-15)


def test_ae_larger_than_diameter_rejected():
    tool = Tool(diameter_m=D, teeth=2)
    with pytest.raises(MillingError, match="exceeds the tool diameter"):
        check_cut(tool, Cut(ae_m=1.5 * D, ap_m=1e-3, spindle_rpm=1e4))


def test_in_cut_wraps_angles():
    st, ex = 2.0, math.pi
    phi = np.array([2.5, 2.5 + 2 * math.pi, 2.5 - 4 * math.pi, 1.0, 4.0])
    assert in_cut(phi, st, ex).tolist() == [True, True, True, False, False]


def test_directional_matrix_is_the_derivative_of_the_force_law():
    """d(force)/d(displacement) by central differences of edge_forces + tool_force_cut_frame.

    Reference: the nonlinear law F(phi, h = h0 + n.dr) with n = (sin phi, cos phi); it is
    linear in h for h > 0, so the central difference is exact up to rounding (tolerance 1e-7
    relative for a step 1e-9 m on h0 = 1e-4 m)."""
    rng = np.random.default_rng(1)
    phi = rng.uniform(0.1, math.pi - 0.1, 7)
    db = 2e-4
    h0 = 1e-4
    eps = 1e-9
    n = np.stack([np.sin(phi), np.cos(phi)], -1)
    Dm = directional_matrix(phi, LAW)
    for col in range(2):
        dr = np.zeros(2)
        dr[col] = eps
        fp = tool_force_cut_frame(phi, edge_forces(h0 + n @ dr, db, LAW))
        fm = tool_force_cut_frame(phi, edge_forces(h0 - n @ dr, db, LAW))
        assert_allclose((fp - fm) / (2 * eps), db * Dm[:, :, col], rtol=1e-7, atol=1e-3)


def test_average_directional_matrix_full_immersion_closed_form():
    """(1/2pi) int_0^pi D dphi = [[-Kr/4, -Kt/4], [Kt/4, -Kr/4], [Ka/pi, 0]] (integrals of sin^2,
    sin cos, cos^2 and sin over [0, pi]); Gauss-Legendre with 200 nodes is exact to rounding."""
    from robolobes.lobes.directional import average_directional_matrix

    tool = Tool(diameter_m=D, teeth=2)
    a0 = average_directional_matrix(tool, Cut(ae_m=D, ap_m=1e-3, spindle_rpm=1e4), LAW)
    kt, kr, ka = LAW.ktc_pa, LAW.krc_pa, LAW.kac_pa
    ref = np.array([[-kr / 4, -kt / 4], [kt / 4, -kr / 4], [ka / math.pi, 0.0]])
    assert_allclose(a0, ref, rtol=1e-12, atol=1e-6 * kt)


def test_cut_frame_axes():
    """Rows x_c, y_c, z_c: x_c = feed, z_c = -tool axis, y_c = z_c x x_c; orthonormal, right-handed."""
    R = cut_frame(np.array([1.0, 0, 0]), np.array([0, 0, -1.0]))
    assert_allclose(R, np.eye(3), atol=1e-15)
    rng = np.random.default_rng(3)
    a = rng.normal(size=3)
    a /= np.linalg.norm(a)
    f = np.cross(a, rng.normal(size=3))
    R = cut_frame(f, a)
    assert_allclose(R @ R.T, np.eye(3), atol=1e-14)
    assert_allclose(np.linalg.det(R), 1.0, rtol=1e-14)
    assert_allclose(R[2], -a, atol=1e-14)
    assert_allclose(R[0], f / np.linalg.norm(f), atol=1e-14)
    with pytest.raises(MillingError, match="not perpendicular"):
        cut_frame(np.array([1.0, 0, 1.0]), np.array([0, 0, 1.0]))


def test_regeneration_pitch_and_runout():
    cut = Cut(ae_m=0.004, ap_m=1e-3, spindle_rpm=3100, feed_per_tooth_m=45e-6)
    # variable pitch 170/190 deg: tooth 0 trails tooth 1 by 190 deg, tooth 1 trails tooth 0 by 170
    tool = Tool(diameter_m=D, teeth=2, pitch_rad=(math.radians(170), math.radians(190)))
    reg = regeneration(tool, cut)
    assert [r.cuts for r in reg] == [True, True]
    assert_allclose([r.delay_rad for r in reg], np.radians([190, 170]), rtol=1e-14)
    # chip of tooth j = fz N pitch/2pi: 45 um * 2 * 190/360 and * 170/360
    assert_allclose([r.chip_m for r in reg], [45e-6 * 2 * 190 / 360, 45e-6 * 2 * 170 / 360], rtol=1e-12)
    # runout 6.929 um < fz: both cut, chips fz +- runout, delays one pitch (steel case, Tab. 9)
    tool = Tool(diameter_m=D, teeth=2, runout_m=(6.929e-6, 0.0))
    reg = regeneration(tool, cut)
    assert [r.cuts for r in reg] == [True, True]
    assert_allclose([r.chip_m for r in reg], [45e-6 + 6.929e-6, 45e-6 - 6.929e-6], rtol=1e-12)
    assert_allclose([r.delay_rad for r in reg], [math.pi, math.pi], rtol=1e-14)
    # runout 60 um > fz = 45 um: the short tooth 1 never reaches the surface; tooth 0 cuts the
    # surface it left itself one revolution earlier (delay 2 pi, chip N fz = 90 um)
    tool = Tool(diameter_m=D, teeth=2, runout_m=(60e-6, 0.0))
    reg = regeneration(tool, cut)
    assert [r.cuts for r in reg] == [True, False]
    assert_allclose(reg[0].delay_rad, 2 * math.pi, rtol=1e-14)
    assert_allclose(reg[0].chip_m, 90e-6, rtol=1e-12)


def test_tool_validation_messages():
    with pytest.raises(MillingError, match="sum to"):
        Tool(diameter_m=D, teeth=2, pitch_rad=(1.0, 1.0))
    with pytest.raises(MillingError, match="pitch angles"):
        Tool(diameter_m=D, teeth=3, pitch_rad=(math.pi, math.pi))
    with pytest.raises(MillingError, match="teeth"):
        Tool(diameter_m=D, teeth=0)
    with pytest.raises(MillingError, match="helix"):
        Tool(diameter_m=D, teeth=2, helix_rad=math.pi / 2)
    with pytest.raises(MillingError, match="mode"):
        Cut(ae_m=1e-3, ap_m=1e-3, spindle_rpm=1e4, mode="sideways")  # pyright: ignore[reportArgumentType]  # deliberately invalid input
    with pytest.raises(MillingError, match="finite"):
        Cut(ae_m=float("nan"), ap_m=1e-3, spindle_rpm=1e4)


def test_helix_lag_and_tooth_angles():
    tool = Tool(diameter_m=D, teeth=3, helix_rad=math.radians(30))
    # psi(z) = 2 z tan(beta) / D
    assert_allclose(tool.lag_rad(1.6e-3), 2 * 1.6e-3 * math.tan(math.radians(30)) / D, rtol=1e-15)
    assert_allclose(tool.tooth_angle_rad, [0.0, -2 * math.pi / 3, -4 * math.pi / 3], rtol=1e-15)


def test_principal_period_one_decision():
    """Tooth period T/N when every tooth regenerates one equal pitch back, else the revolution T.

    Hand-derived cases at 6000 rpm (T = 10 ms): uniform 3 teeth -> 10/3 ms "tooth"; pitch
    110/130/120 deg -> 10 ms "revolution"; runout 20 um on one tooth of 2 with fz = 10 um: the other
    tooth's chip 10 - 20 < 0 um, it skips -> "revolution"; runout 2 um < fz -> still "tooth". The
    tolerance (ANGLE_TOL_RAD = 1e-9 rad) tells floating-point rounding (pitches that are 2 pi / 3 up to
    1e-15 rad after a degree conversion) from a real variable pitch (1e-6 rad).
    """
    cut = Cut(ae_m=0.5 * D, ap_m=1e-3, spindle_rpm=6000.0, feed_per_tooth_m=10e-6)
    T = 60.0 / 6000.0
    period, name = principal_period(Tool(diameter_m=D, teeth=3), cut)
    assert name == "tooth"
    assert_allclose(period, T / 3, rtol=1e-15)
    assert principal_period(Tool(diameter_m=D, teeth=3, pitch_rad=tuple(np.radians([110, 130, 120]))),
                            cut) == (pytest.approx(T, rel=1e-15), "revolution")
    assert principal_period(Tool(diameter_m=D, teeth=2, runout_m=(20e-6, 0.0)), cut)[1] == "revolution"
    assert principal_period(Tool(diameter_m=D, teeth=2, runout_m=(2e-6, 0.0)), cut)[1] == "tooth"
    rounded = tuple(np.radians([120.0, 120.0, 120.0]) * (1 + np.array([1, -1, 0]) * 2e-16))
    assert principal_period(Tool(diameter_m=D, teeth=3, pitch_rad=rounded), cut)[1] == "tooth"
    off = (2 * math.pi / 3 + 1e-6, 2 * math.pi / 3 - 1e-6, 2 * math.pi / 3)
    assert principal_period(Tool(diameter_m=D, teeth=3, pitch_rad=off), cut)[1] == "revolution"
