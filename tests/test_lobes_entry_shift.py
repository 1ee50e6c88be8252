"""The entry-shift term (lobes/entry_shift.py): a tooth meets the flat block edge where its tip
crosses it, so the engagement moves with the tool's current normal position. References: the
closed-form mean force of the linear law (its derivative in the radial depth is the term's
static part), the SDM without the term, and the term's proportionality to the feed."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Literal

import numpy as np
import pytest

from robolobes.cases.milling import Cut, CuttingLaw, Tool, engagement_rad
from robolobes.lobes import LobeProblem, ModalStructure, Mode, SemiDiscretization
from robolobes.lobes.entry_shift import entry_shift_exponent, entry_shift_impulses
from robolobes.lobes.exponent import floquet_exponent

LAW = CuttingLaw(ktc_pa=661.553e6, krc_pa=253.458e6)


def _problem(mode: Literal["down", "up"] = "down", helix_deg=0.0, pitch_deg=(170.0, 190.0), fz=3e-5, ae=4e-3, ap=1.5e-3):
    k = 0.03993 * (2 * math.pi * 922.0) ** 2
    structure = ModalStructure((Mode(922.0, 0.011, k, (1.0, 0.0)), Mode(922.0, 0.011, k, (0.0, 1.0))))
    tool = Tool(diameter_m=0.01, teeth=2, helix_rad=math.radians(helix_deg),
                pitch_rad=tuple(math.radians(p) for p in pitch_deg))
    cut = Cut(ae_m=ae, ap_m=ap, spindle_rpm=10000.0, mode=mode, feed_per_tooth_m=fz)
    return LobeProblem(structure, tool, cut, LAW)


def _mean_force(problem, ae_m):
    """Mean force on the tool over a revolution (x_c, y_c), N, for the static chip fz sin(phi) of every
    tooth over the engagement of ``ae_m``: Gauss-Legendre on the arc (the pitch does not change the
    mean: the chips sum to N fz)."""
    tool, cut, law = problem.tool, replace(problem.cut, ae_m=ae_m), problem.law
    st, ex = engagement_rad(tool, cut)
    x, w = np.polynomial.legendre.leggauss(64)
    phi = st + (x + 1) * (ex - st) / 2
    c, s = np.cos(phi), np.sin(phi)
    f = np.stack([-law.ktc_pa * c - law.krc_pa * s, law.ktc_pa * s - law.krc_pa * c])
    h = cut.feed_per_tooth_m * s
    return tool.teeth * cut.ap_m / (2 * math.pi) * (f * h * w).sum(axis=1) * (ex - st) / 2


@pytest.mark.parametrize("mode", ["down", "up"])
@pytest.mark.parametrize("helix_deg", [0.0, 30.0])
def test_mean_impulse_is_the_derivative_of_the_mean_force(mode, helix_deg):
    # The term's static part: a tool held at a normal offset y cuts the immersion ae - y (down-milling,
    # material on -y_c) or ae + y (up-milling, material on +y_c). So the impulses' mean force per unit
    # y, -sum(E[:, y]) / Tp, must equal -dF/dae (down) or +dF/dae (up), dF/dae from the closed-form
    # mean force (central difference, step 1 um: error ~1e-7 relative). Tolerance 1e-5 relative: the
    # quadrature and the difference, not the model.
    p = _problem(mode=mode, helix_deg=helix_deg)
    period_rad, m, slices = 2 * math.pi, 80, 16
    imp = entry_shift_impulses(p, m, slices, period_rad)
    period_s = period_rad / p.cut.omega_rad_s
    mean_per_y = -sum(E[:2, 1] for _, E in imp) / period_s
    d = 1e-6
    dF_dae = (_mean_force(p, p.cut.ae_m + d) - _mean_force(p, p.cut.ae_m - d)) / (2 * d)
    expect = -dF_dae if mode == "down" else dF_dae
    np.testing.assert_allclose(mean_per_y, expect, rtol=1e-5)
    assert all(np.all(E[:, 0] == 0) for _, E in imp)  # the feed direction does not move the block edge


def test_impulses_sit_where_the_tooth_meets_the_block_edge():
    # Straight tool, down-milling: tooth j meets the edge at phi_st, i.e. at spindle angle
    # phi_st - theta_j (mod 2 pi); the two nodes around it share the impulse linearly.
    p = _problem()
    m = 360
    imp = entry_shift_impulses(p, m, 1, 2 * math.pi)
    st, _ = engagement_rad(p.tool, p.cut)
    for j in range(2):
        pos = ((st - p.tool.tooth_angle_rad[j]) % (2 * math.pi)) / (2 * math.pi / m)
        i0, a = int(pos), pos - int(pos)
        (n0, e0), (n1, e1) = imp[2 * j], imp[2 * j + 1]
        assert (n0, n1) == (i0, (i0 + 1) % m)
        np.testing.assert_allclose(e1[1, 1] / (e0[1, 1] + e1[1, 1]), a, rtol=1e-12)


def test_full_slot_has_no_term():
    assert entry_shift_impulses(_problem(ae=0.01), 40, 1, 2 * math.pi) == []


def test_without_the_term_the_dense_sdm_is_the_sdm():
    # Same discretization, dense products against the fast path: the same exponent to round-off.
    p = _problem(ap=1.2e-3)
    a = floquet_exponent(p, SemiDiscretization(m=40))
    b = entry_shift_exponent(p, SemiDiscretization(m=40), with_entry=False)
    assert b.value_per_s == pytest.approx(a.value_per_s, rel=1e-9, abs=1e-9)


def test_the_terms_effect_is_proportional_to_the_feed():
    # The term is the static chip at the edge times the edge's shift: linear in the feed per tooth
    # (the SDM without it does not depend on the feed). Its effect on the exponent, small against
    # the SDM's, doubles with the feed to first order: ratio 2 within 2 % (the second-order part).
    p = _problem(ap=1.2e-3)
    meth = SemiDiscretization(m=40)
    base = floquet_exponent(p, meth).value_per_s
    shift = [entry_shift_exponent(replace(p, cut=replace(p.cut, feed_per_tooth_m=fz)), meth).value_per_s - base
             for fz in (1e-5, 2e-5)]
    assert abs(shift[0]) > 1e-3
    assert shift[1] / shift[0] == pytest.approx(2.0, rel=0.02), shift
