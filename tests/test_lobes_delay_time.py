"""The delayed instant (lobes/chip_direction.py, ``delay_time`` of the dense SDM): the delayed
displacement at the instant the previous tooth cut the point, ``t - tau_j + (h_j / (R Omega)) cos(phi)``.
References: the SDM without the term (zero feed), the SDM's own fractional delay (a constant increment
of the delay must give the problem whose delay is that much longer), and the term's proportionality
to the feed."""

from __future__ import annotations

import math
from dataclasses import fields, replace

import numpy as np
import pytest

from robolobes.lobes import DirectionalPlan, SemiDiscretization
from robolobes.lobes._errors import LobeError
from robolobes.lobes.sdm import SDMEngine

from test_lobes_entry_shift import _problem

D0 = 0.37  # a constant extra delay, in steps (inside (0, 1): the interpolation, not an extrapolation)


class _ConstantDelay(DirectionalPlan):
    """The plan with the delayed instant replaced by a constant extra delay of ``D0`` steps."""

    def _delay_steps(self, phi, chip_m):
        return np.full(np.shape(phi), D0)


def _radius(problem, m=20, delay_time=False, plan=None, tilt=False):
    eng = SDMEngine(problem, SemiDiscretization(m=m), problem.cut.ap_m, surface_tilt=tilt, delay_time=delay_time)
    if plan is not None:
        eng.plan = plan(eng.plan)
    U = eng.monodromy_dense(problem.cut.spindle_rpm, problem.cut.ap_m)
    return float(np.max(np.abs(np.linalg.eigvals(U))))


def _uniform(helix_deg=0.0, fz=3e-5, ap=0.4e-3):
    return _problem(helix_deg=helix_deg, pitch_deg=(180.0, 180.0), fz=fz, ap=ap)


@pytest.mark.parametrize("helix_deg", [0.0, 30.0])
def test_zero_feed_is_the_plain_sdm(helix_deg):
    # h_j = 0: no shift. The monodromy gains zero columns (the history one step longer), so the
    # multipliers agree to rounding, not bit for bit: 1e-12 relative.
    p = _uniform(helix_deg, fz=0.0)
    a, b = _radius(p), _radius(p, delay_time=True)
    assert b == pytest.approx(a, rel=1e-12)


@pytest.mark.parametrize("helix_deg", [0.0, 30.0])
def test_constant_increment_is_the_longer_delay(helix_deg):
    # Uniform pitch: the delay is the tooth period, m steps exactly (f = 0). A constant extra delay of
    # D0 steps through the delay_time path must give the plain SDM whose delay is m + D0 steps (the
    # plan's fractional delay group_f = D0), to rounding: 1e-11 relative.
    p = _uniform(helix_deg)

    def const(plan):
        return _ConstantDelay(**{f.name: getattr(plan, f.name) for f in fields(plan)})

    def longer(plan):
        assert list(plan.group_f) == [0.0]
        return replace(plan, group_f=np.array([D0]))
    a = _radius(p, delay_time=True, plan=const)
    b = _radius(p, plan=longer)
    assert b == pytest.approx(a, rel=1e-11)
    assert abs(a - _radius(p)) > 1e-3 * a  # the increment matters at this depth


def test_effect_doubles_with_the_feed():
    # The shift is linear in h_j; the exponent's change is linear to first order. At 15 and 30 um of
    # feed (h / R = 0.003-0.006) the change of ln|mu| must double within 2 % (the second-order part
    # is of relative size h / R x the sensitivity's curvature; measured ratio 2.00).
    p = _uniform(30.0, fz=1.5e-5, ap=1.0e-3)
    q = replace(p, cut=replace(p.cut, feed_per_tooth_m=3e-5))
    d1 = math.log(_radius(p, delay_time=True, tilt=True)) - math.log(_radius(p, tilt=True))
    d2 = math.log(_radius(q, delay_time=True, tilt=True)) - math.log(_radius(q, tilt=True))
    assert abs(d1) > 1e-6
    assert d2 / d1 == pytest.approx(2.0, rel=0.02)


def test_low_frequency_limit_is_the_scaled_difference():
    # Chatter far below the tooth frequency: r(t - tau + delta) ~ r(t - tau) + delta r', and
    # r(t) - r(t - tau) ~ tau r', so the term scales the regenerative difference by
    # 1 - (fz N / (2 pi R)) cos(phi) (the estimate of bench_timedomain_chip_direction.py, a second
    # method). For r ~ exp(i w t) the two perturbations differ by the factor
    # i w tau e^(-i w tau) / (1 - e^(-i w tau)) = 1 - i w tau / 2 + O((w tau)^2): a slow structure
    # (5 Hz, tooth frequency 333 Hz, w tau = 0.094) makes the complex change of ln(mu) of the dominant
    # multiplier agree within 10 % (0.047 from the phase, the rest the SDM's interpolation at m = 20).
    import robolobes.lobes as lb
    from robolobes.cases.milling import directional_matrix
    from robolobes.lobes.chip_direction import feed_per_radian_m

    k = 0.03993 * (2 * math.pi * 5.0) ** 2 * 4000
    structure = lb.ModalStructure((lb.Mode(5.0, 0.05, k, (1.0, 0.0)), lb.Mode(5.0, 0.05, k, (0.0, 1.0))))
    p = replace(_uniform(0.0, fz=6e-5, ap=2e-3), structure=structure)

    class _Scaled(DirectionalPlan):
        def _directional(self, phi, chip_m, delay_shift=False):
            scale = 1 - feed_per_radian_m(self.tool, self.cut) / self.tool.radius_m * np.cos(phi)
            return directional_matrix(phi, self.law)[..., :self.k_force, :] * scale[..., None, None]

    def scaled(plan):
        return _Scaled(**{f.name: getattr(plan, f.name) for f in fields(plan)})
    plain = _dominant(p)
    d_term = np.log(_dominant(p, plain, delay_time=True) / plain)
    d_est = np.log(_dominant(p, plain, plan=scaled) / plain)
    assert abs(d_est) > 1e-5
    assert abs(d_term - d_est) <= 0.10 * abs(d_est)


def _dominant(problem, near=None, m=20, delay_time=False, plan=None):
    """The largest multiplier (``near`` None) or the one nearest ``near``, complex."""
    eng = SDMEngine(problem, SemiDiscretization(m=m), problem.cut.ap_m, delay_time=delay_time)
    if plan is not None:
        eng.plan = plan(eng.plan)
    ev = np.linalg.eigvals(eng.monodromy_dense(problem.cut.spindle_rpm, problem.cut.ap_m))
    return complex(ev[np.argmax(np.abs(ev))] if near is None else ev[np.argmin(np.abs(ev - near))])


def test_fast_path_refuses_the_term():
    p = _uniform()
    eng = SDMEngine(p, SemiDiscretization(m=20), p.cut.ap_m, delay_time=True)
    with pytest.raises(LobeError, match="monodromy_dense"):
        eng.multipliers([p.cut.spindle_rpm], [p.cut.ap_m])


@pytest.mark.parametrize("deg", [30.0, 80.0, 102.0, 150.0])
def test_delay_advance_is_the_trochoid_instant(deg):
    # Exact geometry, independent of the module: the tool centre moves at v along x_c, a tooth's tip is
    # at c(t) + R u(Omega t + theta), u = (sin, cos) (the repository's convention). The ray of the edge
    # at phi (time 0) meets the previous tooth's tip path at the instant t' solved by bisection; the
    # previous tooth is a pitch behind, so t' - (-tau) must be (h / (R Omega)) cos(phi) to first order
    # in h / R: relative error below 2 h / R (0.02 here) plus 1e-6 rad absolute (the bisection).
    from robolobes.lobes.chip_direction import delay_advance_rad
    R, omega, N, fz = 5e-3, 300.0, 2, 45e-6
    v = fz * N * omega / (2 * math.pi)
    tau = 2 * math.pi / (N * omega)
    phi = math.radians(deg)
    u = np.array([math.sin(phi), math.cos(phi)])
    n = np.array([math.cos(phi), -math.sin(phi)])  # normal to the ray

    def tip(t):  # the previous tooth's tip at time t
        a = omega * t + phi - 2 * math.pi / N
        return np.array([v * t + R * math.sin(a), R * math.cos(a)])

    def side(t):  # its signed distance from the edge's line
        return float(tip(t) @ n)
    lo, hi = -tau - 0.2 * tau, -tau + 0.2 * tau
    assert side(lo) * side(hi) < 0
    for _ in range(80):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if side(lo) * side(mid) > 0 else (lo, mid)
    assert tip(lo) @ u == pytest.approx(R, rel=2 * fz / R)  # on the ray, ahead of the centre
    exact = omega * ((lo + hi) / 2 + tau)  # rad of spindle rotation after t - tau
    first = float(delay_advance_rad(phi, fz, R))
    assert exact == pytest.approx(first, rel=2 * fz / R, abs=1e-6)
