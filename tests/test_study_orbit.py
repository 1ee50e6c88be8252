"""The study's like-with-like lobes bracket of the eroded part: the SDM linearized about its forced
orbit, at ae minus the deflection when the teeth meet the part, with the entry shift, the surface
tilt and the delayed instant (``damping_by_lobes(..., orbit=True)``), each probe decided by the sign
of its Floquet exponent. References: the plain SDM's multipliers (``floquet_exponent``, a second
implementation) where the feed terms vanish, and the eroded-part time domain's fitted growth rates
(``docs/study-results.json``, computed by robolobes' eroded-part simulator, not by the SDM)."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pytest

import robolobes.study.compute as compute
from robolobes.cases.milling import Cut, CuttingLaw, Tool
from robolobes.lobes import LobeProblem, ModalStructure, Mode, SemiDiscretization
from robolobes.lobes.exponent import floquet_exponent
from robolobes.study.settings import StudySettings

ROOT = Path(__file__).resolve().parents[1]
LAW = CuttingLaw(ktc_pa=661.553e6, krc_pa=253.458e6)
METHOD = SemiDiscretization(m=20)


@dataclass(frozen=True)
class _Case:
    tool: Tool
    cut: Cut
    law: CuttingLaw


def _structure(scale: float) -> ModalStructure:
    """Two orthogonal 922 Hz modes, damping ratio 1.1 % times ``scale`` (the lobes' test structure)."""
    k = 0.03993 * (2 * math.pi * 922.0) ** 2
    return ModalStructure((Mode(922.0, 0.011 * scale, k, (1.0, 0.0)), Mode(922.0, 0.011 * scale, k, (0.0, 1.0))))


def _case(fz: float) -> _Case:
    # down-milling, ae 4 mm of a 10 mm two-tooth 30 deg helix tool, ap 0.3 mm: the SDM limit crosses
    # 0.3 mm between the damping scales 1.5 (0.293 mm) and 1.6 (0.311 mm)
    tool = Tool(diameter_m=0.01, teeth=2, helix_rad=math.radians(30.0), pitch_rad=(math.pi, math.pi))
    return _Case(tool, Cut(ae_m=4e-3, ap_m=3e-4, spindle_rpm=10000.0, mode="down", feed_per_tooth_m=fz), LAW)


class _Lin:
    """What ``damping_by_lobes`` asks of a linearization: its poles (for the slowest decay)."""

    def __init__(self, st: ModalStructure):
        w = np.array([2 * math.pi * m.freq_hz for m in st.modes])
        z = np.array([m.damping_ratio for m in st.modes])
        self._poles = -z * w + 1j * w * np.sqrt(1 - z ** 2)

    def modes(self):
        return type("Modes", (), {"poles": self._poles})()


class _Lins:
    def structure(self, case, variant, pose, theta, damping_scale=1.0):
        st = _structure(damping_scale)
        return _Lin(st), st


def test_exponent_verdict_by_sign_and_richardson_error():
    assert compute.exponent_verdict(0.5, 0.1).status == "unstable"
    assert compute.exponent_verdict(-0.5, 0.1).status == "stable"
    for v in (0.05, -0.1, 0.0):  # not above its error: neither side
        assert compute.exponent_verdict(v, 0.1).status == "undetermined"


def test_orbit_probe_without_feed_is_the_plain_sdm():
    # the entry shift, the tilt and the delayed instant are proportional to the feed per tooth: at 1 nm they move the
    # exponent by ~3e-5 1/s (0.8 1/s at 30 um, below), so the probe must give the exponent of the
    # plain SDM's multipliers (floquet_exponent, a second implementation: multipliers rather than the
    # dense monodromy). Tolerance 1e-3 1/s: that residual term and the two implementations' rounding.
    for scale in (1.5, 1.6):
        p = LobeProblem(_structure(scale), *(lambda c: (c.tool, c.cut, c.law))(_case(1e-9)))
        verdict, info = compute.orbit_probe(p, METHOD)
        ref = floquet_exponent(p, METHOD)
        assert abs(info["exponent_per_s"] - ref.value_per_s) < 1e-3, (scale, info, ref)
        assert verdict.status == ("unstable" if scale == 1.5 else "stable")


def test_feed_terms_shift_doubles_with_the_feed():
    # first order in fz / R (0.006 here): the shift from the plain SDM at 2 fz is twice that at fz, to
    # the second-order share (ratio 2.005 measured here, 1.84 on the steel study at x11.67); bounds [1.8, 2.2]
    def exponent(fz):
        c = _case(fz)
        return compute.orbit_probe(LobeProblem(_structure(1.55), c.tool, c.cut, c.law), METHOD)[1]["exponent_per_s"]
    e0, e1, e2 = exponent(1e-9), exponent(3e-5), exponent(6e-5)
    assert abs(e1 - e0) > 0.3  # the terms are there (0.8 1/s): the ratio below is not noise
    assert 1.8 <= (e2 - e0) / (e1 - e0) <= 2.2, (e0, e1, e2)


def test_damping_by_lobes_about_the_orbit_at_zero_feed_gives_the_plain_verdicts():
    settings = replace(StudySettings(), damping_scales=(1.0, 2.0), damping_tol=0.1, sdm_m=20)
    plain = compute.damping_by_lobes(settings, _Lins(), _case(1e-9), None, dy_m=0.0)
    feed = compute.damping_by_lobes(settings, _Lins(), _case(1e-9), None, dy_m=0.0, orbit=True)
    assert feed.method == "lobes about the forced orbit" and plain.method == "lobes at ae - dy"
    assert feed.bracket == plain.bracket
    lo, hi = plain.bracket
    assert lo is not None and hi is not None and 1.5 <= lo < hi <= 1.6, plain.bracket  # the limits above
    assert [(p.scale, p.verdict.status) for p in feed.probes] == [(p.scale, p.verdict.status) for p in plain.probes]
    for p in feed.probes:
        assert p.verdict.status != "undetermined" and p.info["ae_m"] == 4e-3


@pytest.fixture(scope="module")
def steel_probes():
    """The committed quick study's damping results, and the steel SDM problem at a scale and ae - dy."""
    from robolobes.study.linearizations import Linearizations
    sd = json.loads((ROOT / "docs" / "study-results.json").read_text())["steel_damping"]
    cs, pas, _ = compute.load_inputs()
    theta = compute.study_poses(pas)["start"]
    steel, lins = cs["steel"], Linearizations()

    def problem(scale, dy_m):
        _, st = lins.structure(steel, "basic", "start", theta, damping_scale=scale)
        return compute._lobe_problem(st, replace(steel, cut=replace(steel.cut, ae_m=steel.cut.ae_m - dy_m)))
    return sd, problem


def test_orbit_exponent_meets_the_eroded_rates_at_the_bracket_ends(steel_probes):
    # the eroded part's kicked growth rates at both ends of its bracket (fitted by its simulator, the
    # reference) against the SDM linearized about its forced orbit (steel tool: 30 deg helix, 6.9 um
    # runout), by the project's like-with-like criterion |rate - sigma| <= max(10 % |sigma|,
    # 0.03 1/s) + 2 SE (measured 0.003 and 0.017 1/s apart); the plain SDM at ae minus the mean
    # deflection misses both (by 0.90 and 0.89 1/s: the criterion can fail); ~1 s
    sd, problem = steel_probes
    td = sd["time_domain"]
    method = SemiDiscretization(m=40)
    for sc in (td["largest_unstable_scale"], td["smallest_stable_scale"]):
        p = td["probes"][f"{sc:g}"]
        rate, se = p["growth_rate_per_s"], p["growth_rate_se_per_s"]
        _, info = compute.orbit_probe(problem(sc, sd["eroded_entry_deflection_m"]), method)
        e = info["exponent_per_s"]
        assert abs(rate - e) <= max(0.1 * abs(e), 0.03) + 2 * se, (sc, rate, se, e)
        plain = floquet_exponent(problem(sc, sd["eroded_deflection_m"]), method).value_per_s
        assert abs(rate - plain) > max(0.1 * abs(plain), 0.03) + 2 * se, (sc, rate, plain)
