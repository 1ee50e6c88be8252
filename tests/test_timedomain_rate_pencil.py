"""The matrix-pencil (ESPRIT) estimate of the leading Floquet multiplier (timedomain/rate.py,
``pencil_growth_rate``) on synthetic sections: closed-form sums of damped complex exponentials
(steel-like: the leading mode at -3.4 1/s and +-97 deg per tooth period, a faster one at -7.6 1/s,
two channels) with seeded Gaussian noise.

The tolerance on a rate is derived from the noise: 10 x the Cramer-Rao standard deviation of the
leading mode's rate alone (its amplitude fitted, the other modes known), computed here from the
closed form; the pencil is not efficient and the other modes cost information, hence the factor 10,
chosen before the tests were run."""

from __future__ import annotations

import math

import numpy as np

from robolobes.timedomain.rate import PENCIL_MAX_ORDER, pencil_growth_rate

TP = 1.0 / 103.33  # principal period: the steel case's tooth period, s
K = 100  # sections (0.97 s)
NOISE_M = 5e-10  # noise standard deviation per section and channel, m


def _mode(rate: float, deg: float, amp_m: tuple[float, float], phase: tuple[float, float]) -> np.ndarray:
    """Sections (K, 2) of one real mode: per channel ``a |z|^k cos(k theta + phase)``, |z| = e^(rate TP)."""
    k = np.arange(K)[:, None]
    return np.asarray(amp_m) * np.exp(rate * TP * k) * np.cos(math.radians(deg) * k + np.asarray(phase))


def _noise(seed: int, sd: float = NOISE_M) -> np.ndarray:
    return np.random.default_rng(seed).normal(0.0, sd, (K, 2))


def _rate_tolerance(clean_mode: np.ndarray, rate: float) -> float:
    """10 x the Cramer-Rao SD of ``rate`` (1/s) from one mode's clean sections (K, 2) in white noise
    NOISE_M: d y / d ln|z| = k y; the amplitude fitted (k centred on its weighted mean)."""
    k = np.arange(K)[:, None]
    w = clean_mode ** 2
    kbar = float((w * k).sum() / w.sum())
    info = float((w * (k - kbar) ** 2).sum()) / NOISE_M ** 2
    return 10.0 / math.sqrt(info) / TP


def test_leading_rate_of_a_fast_and_a_slow_mode_is_the_slow_one():
    # the fast mode starts 10 x larger (the kick's share in the robot's faster modes on steel)
    slow = _mode(-3.4, 97.0, (2e-7, 1.4e-7), (0.3, 1.2))
    fast = _mode(-7.6, 150.0, (2e-6, 1.5e-6), (1.0, -0.4))
    for seed in range(5):
        p = pencil_growth_rate(slow + fast + _noise(seed), TP)
        assert p.order == 4, (seed, p.order)
        assert abs(p.rate_per_s - (-3.4)) <= _rate_tolerance(slow, -3.4), (seed, p.rate_per_s)
        assert abs(abs(math.degrees(np.angle(p.multipliers[p.leading]))) - 97.0) < 1.0
        assert 0 < p.se_per_s < 1.0
        assert p.reason == ""


def test_order_is_two_per_oscillating_mode():
    slow = _mode(-3.4, 97.0, (2e-7, 1.4e-7), (0.3, 1.2))
    fast = _mode(-7.6, 150.0, (2e-6, 1.5e-6), (1.0, -0.4))
    third = _mode(-9.9, 40.0, (1e-6, 8e-7), (-0.7, 0.2))
    assert pencil_growth_rate(slow + _noise(11), TP).order == 2
    assert pencil_growth_rate(slow + fast + third + _noise(12), TP).order == 6
    p = pencil_growth_rate(slow + fast + third + _noise(13), TP)
    assert abs(p.rate_per_s - (-3.4)) <= _rate_tolerance(slow, -3.4)


def test_single_exponential_gives_the_log_linear_answer():
    # a flip (z real, negative): ln|y_k| is exactly linear in k without noise; with it the
    # least-squares line through ln|y_k| and the pencil must agree with -3.4 within the tolerance
    k = np.arange(K)
    clean = np.column_stack([3e-7 * (-math.exp(-3.4 * TP)) ** k, -2e-7 * (-math.exp(-3.4 * TP)) ** k])
    y = clean + _noise(21)
    loglin = np.polyfit(k * TP, np.log(np.abs(y[:, 0])), 1)[0]
    p = pencil_growth_rate(y, TP)
    tol = _rate_tolerance(clean, -3.4)
    assert p.order == 1
    assert abs(p.rate_per_s - (-3.4)) <= tol
    assert abs(loglin - (-3.4)) <= tol
    assert abs(p.rate_per_s - loglin) <= 2 * tol


def test_growing_mode_is_leading():
    grow = _mode(+0.45, 97.0, (1e-7, 8e-8), (0.3, 1.2))
    fast = _mode(-7.6, 150.0, (2e-6, 1.5e-6), (1.0, -0.4))
    p = pencil_growth_rate(grow + fast + _noise(31), TP)
    assert abs(p.rate_per_s - 0.45) <= _rate_tolerance(grow, 0.45)


def test_pure_noise_gives_no_rate():
    p = pencil_growth_rate(_noise(41, 1e-9), TP)
    assert p.order == 0 and math.isnan(p.rate_per_s) and "order 0" in p.reason


def test_a_mode_below_ten_resolutions_gives_no_rate():
    # 10 nm at the window start: above the 2 nm resolution (order >= 1; one of the pair's two
    # singular values can fall below the floor), below 10 x 2 nm (not resolved)
    p = pencil_growth_rate(_mode(-3.4, 97.0, (1e-8, 1e-8), (0.0, 0.5)) + _noise(51, 1e-10), TP)
    assert p.order >= 1 and math.isnan(p.rate_per_s) and "no mode resolved" in p.reason


def test_short_window_gives_no_rate():
    p = pencil_growth_rate(_mode(-3.4, 97.0, (2e-7, 1.4e-7), (0.3, 1.2))[:17], TP)
    assert math.isnan(p.rate_per_s) and "17 sections" in p.reason


def test_order_is_capped():
    modes = sum(_mode(-3.0 - i, 20.0 + 30 * i, (1e-7, 1e-7), (0.1 * i, 0.0)) for i in range(6))
    p = pencil_growth_rate(modes + _noise(61), TP)
    assert p.order == PENCIL_MAX_ORDER
