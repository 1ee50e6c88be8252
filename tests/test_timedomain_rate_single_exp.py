"""The opt-in parts of the gated rule (timedomain/rate.py): the largest linear kick and the
single-exponential start, on synthetic motions whose rates are known in closed form."""

from __future__ import annotations

import math

import numpy as np

from robolobes.timedomain.rate import gated_growth_rate, linear_kick_amplitude_m
from robolobes.timedomain.verdict import LOSS_LIMIT, ChipScale

TP = 0.02  # principal period, s
PHASES = 64  # samples per period


def _flip(t, amp_m: float, rate: float, hz: float) -> np.ndarray:
    return amp_m * np.exp(rate * t) * np.cos(2 * math.pi * hz * t)


def _xy(x):
    return np.stack([x, 0.6 * x], axis=-1)


def test_linear_kick_is_half_the_amplitude_that_loses_the_gate_s_share_of_the_chip():
    # arc [phi_st, pi] (down-milling): the chip h sin(phi) is below a over phi in [pi - asin(a/h), pi],
    # weight 1 - sqrt(1 - (a/h)^2) of the total 1 + cos(phi_st). Solved for a: the closed form below.
    phi_st, h_small = 1.7721542475852272, 3.8e-5
    chip = ChipScale(delays_s=(0.01, 0.01), max_chip_m=(5.2e-5, h_small), arc_rad=(phi_st, math.pi))
    a = h_small * math.sqrt(1 - (1 - LOSS_LIMIT * (1 + math.cos(phi_st))) ** 2)
    assert math.isclose(linear_kick_amplitude_m(chip), a / 2, rel_tol=2e-3)


def test_single_exponential_start_drops_the_fast_mode_and_recovers_the_slow_rate():
    # a fast robot-like mode (83.3 Hz, -10 1/s, 20 um) plus the slow flip (-3.5 1/s, 1 um): the log
    # amplitude is convex; the plain gated fit sees the mixture (-4.48 when written), the
    # single-exponential start drops the early part and sees the slow rate.
    t = np.arange(0, 3.0, TP / PHASES)
    x = _flip(t, 2e-5, -10.0, 83.3) + _flip(t, 1e-6, -3.5, 0.5 / TP * 0.99)
    plain = gated_growth_rate(t, _xy(x), TP, t_start_s=0.0, t_end_s=t[-1])
    single = gated_growth_rate(t, _xy(x), TP, t_start_s=0.0, t_end_s=t[-1], single_exponential=True)
    assert single.estimate is not None and plain.estimate is not None
    assert abs(single.rate_per_s + 3.5) <= 0.1 * 3.5 + 2 * single.se_per_s
    assert abs(plain.rate_per_s + 3.5) > 0.5
    assert single.window_s is not None and plain.window_s is not None
    assert single.window_s[0] > plain.window_s[0] + 0.3


def test_single_exponential_start_keeps_a_single_exponential_whole():
    # one decaying flip: no curvature, the window and the rate are the plain rule's
    t = np.arange(0, 2.0, TP / PHASES)
    x = _flip(t, 5e-6, -3.5, 0.5 / TP * 0.95)
    plain = gated_growth_rate(t, _xy(x), TP, t_start_s=0.0, t_end_s=t[-1])
    single = gated_growth_rate(t, _xy(x), TP, t_start_s=0.0, t_end_s=t[-1], single_exponential=True)
    assert single.window_s == plain.window_s
    assert abs(single.rate_per_s + 3.5) <= 0.02 * 3.5 + 2 * single.se_per_s


def test_no_rate_when_the_log_amplitude_stays_curved():
    # two modes of equal amplitude whose sum beats with a period of the whole window: curved
    # everywhere, so the test drops quarters until too few differences are left.
    t = np.arange(0, 1.0, TP / PHASES)
    x = _flip(t, 1e-6, -1.0, 0.5 / TP * 0.95) + _flip(t, 1e-6, -1.0, 0.5 / TP * 0.95 + 0.6)
    g = gated_growth_rate(t, _xy(x), TP, t_start_s=0.0, t_end_s=t[-1], single_exponential=True)
    assert g.estimate is None
    assert "not a single exponential" in g.reason
