"""Signal post-processing on synthetic signals with known answers (fixed seeds)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from robolobes.timedomain.signals import (SignalError, chatter_frequency, force_stats, gaussian_mean_line, once_per_revolution,
                                roughness, synchronous_average)

FS = 18700 / 60.0  # spindle frequency, Hz (the aluminium cut)
T_REV = 1 / FS


def _t(duration, per_rev=200, t0=0.0):
    dt = T_REV / per_rev
    return t0 + dt * np.arange(int(math.ceil(duration / dt - 1e-9)) + 1)


# ---- force statistics -----------------------------------------------------------------------------
def test_force_stats_of_a_known_signal():
    t = _t(1.5, per_rev=240)
    fx = 8.0 + 30.0 * np.sin(2 * math.pi * 2 * FS * t)
    fy = -25.0 + 40.0 * np.cos(2 * math.pi * FS * t)
    st = force_stats(t, np.stack([fx, fy], 1), 0.4, 1.4)
    # window 0.4..1.4 s: 311.67 revolutions; the sine terms average to O(1 / (2 pi n)) of their
    # amplitude over a non-whole number of periods: 40 / (2 pi 311) = 0.02
    assert_allclose(st.mean_n, [8.0, -25.0], atol=0.05)
    # 240 samples per revolution hit the peaks of both harmonics exactly
    assert_allclose(st.min_n, [-22.0, -65.0], rtol=1e-12)
    assert_allclose(st.max_n, [38.0, 15.0], rtol=1e-12)
    # rms^2 = mean^2 + A^2 / 2 (same O(1/n) window effect on the squares)
    assert_allclose(st.rms_n, [math.sqrt(64 + 450), math.sqrt(625 + 800)], rtol=2e-3)
    assert_allclose(st.std_n, [30 / math.sqrt(2), 40 / math.sqrt(2)], rtol=2e-3)
    assert st.n_samples == np.count_nonzero((t >= 0.4 - 1e-12) & (t <= 1.4 + 1e-12))


def test_force_stats_bad_input():
    t = _t(0.1)
    with pytest.raises(SignalError, match="sampled uniformly"):
        force_stats(np.r_[t[:10], t[11:]], np.zeros(t.size - 1))
    with pytest.raises(SignalError, match="finite"):
        force_stats(t, np.full(t.size, np.nan))
    with pytest.raises(SignalError, match="outside the signal's time span"):
        force_stats(t, np.zeros(t.size), 0.0, 1.0)
    with pytest.raises(SignalError, match=r"shape \(n,\) or \(n, m\)"):
        force_stats(t, np.zeros(t.size + 1))


# ---- once per revolution, synchronous average -----------------------------------------------------
def test_once_per_revolution_samples_the_signal():
    t = _t(0.2, per_rev=73)  # grid not aligned with the revolutions
    x = np.sin(2 * math.pi * 2 * FS * t + 0.3) + 0.1 * t
    tk, xk = once_per_revolution(t, x, T_REV, t_start_s=0.01)
    assert_allclose(np.diff(tk), T_REV, rtol=1e-12)
    # cubic spline of a sine with 36 samples per period: error ~ (2 pi / 36)^4 / 384 = 2.4e-6
    assert_allclose(xk, np.sin(2 * math.pi * 2 * FS * tk + 0.3) + 0.1 * tk, atol=5e-6)


def test_synchronous_average_keeps_the_forced_part():
    rng = np.random.default_rng(1)
    t = _t(0.5)
    forced = np.sin(2 * math.pi * 2 * FS * t) + 0.3 * np.cos(2 * math.pi * FS * t)
    x = forced + 0.5 * np.sin(2 * math.pi * 1234.5 * t) + 0.05 * rng.standard_normal(t.size)
    avg = synchronous_average(t, x, T_REV, t_start_s=0.05, t_end_s=0.45, bins=64)
    ph = 0.05 + T_REV * np.arange(64) / 64
    ref = np.sin(2 * math.pi * 2 * FS * ph) + 0.3 * np.cos(2 * math.pi * FS * ph)
    # 124 revolutions: the non-synchronous sine averages down to ~0.5 / (124 |sin|) and the noise to
    # 0.05 / sqrt(124) per bin
    assert_allclose(avg, ref, atol=0.03)


def _forced(t):
    """Forced response of a 2-tooth cutter with variable pitch: tooth-passing plus spindle harmonics."""
    return 1e-6 * (np.sin(2 * math.pi * 2 * FS * t) + 0.3 * np.sin(2 * math.pi * FS * t + 1.0)
                   + 0.2 * np.sin(2 * math.pi * 4 * FS * t))


# (the stability verdict is tested in tests/test_verdict.py)


# ---- chatter frequency ----------------------------------------------------------------------------
def test_chatter_frequency_found_between_spindle_harmonics():
    rng = np.random.default_rng(11)
    t = _t(1.0)
    f_c = 1234.5
    x = np.stack([_forced(t) + 3e-7 * np.sin(2 * math.pi * f_c * t) + 1e-8 * rng.standard_normal(t.size),
                  0.5 * _forced(t) + 2e-7 * np.cos(2 * math.pi * f_c * t)], 1)
    est = chatter_frequency(t, x, FS, t_start_s=0.2)
    # 0.8 s window: 1.25 Hz resolution; Hann + 8x zero padding + log-parabola: within 2 % of a bin
    assert_allclose(est.freq_hz, f_c, atol=0.02 * est.resolution_hz)
    assert_allclose(est.amplitude, math.hypot(3e-7, 2e-7), rtol=0.02)  # Hann amplitude, scalloping < 1 %
    assert est.forced_amplitude > est.amplitude


def test_chatter_frequency_masks_tooth_harmonics_only_when_asked():
    t = _t(1.0)
    # equal pitch, no runout: forced lines at 2 k f_s only; a line at f_s (odd spindle order) is chatter
    x = 1e-6 * np.sin(2 * math.pi * 2 * FS * t) + 2e-7 * np.sin(2 * math.pi * 3 * FS * t)
    est = chatter_frequency(t, x, FS, teeth=2, harmonics="tooth")
    assert_allclose(est.freq_hz, 3 * FS, atol=0.02 * est.resolution_hz)
    est_s = chatter_frequency(t, x + 1e-8 * np.sin(2 * math.pi * 777.7 * t), FS, harmonics="spindle")
    assert_allclose(est_s.freq_hz, 777.7, atol=0.05 * est_s.resolution_hz)
    with pytest.raises(SignalError, match="teeth >= 1"):
        chatter_frequency(t, x, FS, harmonics="tooth")


def _flip_bursts(signs, t, f_carrier_hz, rate_hz=7.0):
    """Bursts of a carrier at ``f_carrier_hz`` (Gaussian envelopes, 20 ms, 10 um, ``rate_hz`` apart from
    ``0.5 / rate_hz`` on), burst ``i`` with the sign ``signs[i]``; shape (n,), m."""
    env = sum(sg * np.exp(-0.5 * ((t - (i + 0.5) / rate_hz) / 0.02) ** 2) for i, sg in enumerate(signs))
    return 1e-5 * env * np.cos(2 * math.pi * f_carrier_hz * t)


def test_chatter_frequency_tells_a_line_from_a_band():
    # Steel at 5000 rpm (the flip at half the 166.7 Hz tooth passing): a 4 s window, 7 bursts per second,
    # 4 quarters of 7 bursts each, on a forced response at the tooth harmonics.
    fs, fc = 5000 / 60, 5000 / 60
    t = np.arange(4 * 15000 + 1) / 15000.0
    forced = 5e-5 * np.cos(2 * math.pi * 2 * fs * t) + 2e-5 * np.sin(2 * math.pi * 4 * fs * t)
    # bursts of one sign: periodic, lines at fc + k 7 Hz; the highest is the carrier and a line
    same = chatter_frequency(t, forced + _flip_bursts(np.ones(28), t, fc), fs, teeth=2, harmonics="tooth")
    assert same.is_line and same.coherence > 0.999
    assert_allclose(same.freq_hz, fc, atol=0.02 * same.resolution_hz)
    # the same bursts, + in the first half and - in the second: the carrier's Hann-weighted sum is
    # 0 (the halves cancel), the spectrum a band; its highest peak lies off the carrier, and it is not a line
    swap = chatter_frequency(t, forced + _flip_bursts(np.repeat([1, 1, -1, -1], 7), t, fc), fs, teeth=2,
                             harmonics="tooth")
    assert not swap.is_line
    assert abs(swap.freq_hz - fc) > swap.resolution_hz
    # a line keeps its phase whatever its envelope (growing 100-fold) and through a drift of one bin
    grow = chatter_frequency(t, forced + 1e-7 * np.exp(t * math.log(100) / 4) * np.sin(2 * math.pi * 77.7 * t), fs,
                             teeth=2, harmonics="tooth")
    assert grow.coherence > 1 - 1e-6 and grow.is_line
    for bins, line in ((1, True), (4, False)):  # the frequency sweeps ``bins / T`` over the window T = 4 s
        chirp = forced + 1e-5 * np.sin(2 * math.pi * (fc * t + 0.5 * bins / 16 * t ** 2))
        assert chatter_frequency(t, chirp, fs, teeth=2, harmonics="tooth").is_line == line, bins


# ---- roughness ----------------------------------------------------------------------------------
def _profile(length=4e-3, dx=0.5e-6):
    return np.arange(int(round(length / dx)) + 1) * dx


def test_roughness_of_a_sine_with_a_linear_form():
    """ISO 4287 on z = A cos(2 pi x / lambda) + tilt: Ra = 2A/pi, Rq = A/sqrt 2, Rt = 2A."""
    x = _profile()
    amp, lam = 0.4e-6, 100e-6  # 40 whole periods over 4 mm, 200 samples per period
    z = amp * np.cos(2 * math.pi * x / lam) + 3e-4 * x + 5e-6
    r = roughness(x, z, form="line")
    # Over whole periods the cosine is even about the middle, so the least-squares line is exactly
    # the added form. Sampling: 200 points per period (+1 end point) hit the crests; the discrete
    # mean of |cos| is 2/pi to O(1/200^2), the extra end point weighs 1/8000.
    assert_allclose([r.ra_m, r.rq_m, r.rt_m], [2 * amp / math.pi, amp / math.sqrt(2), 2 * amp], rtol=3e-4)
    assert_allclose(r.evaluation_length_m, x[-1], rtol=1e-12)
    assert_allclose([r.ra_um, r.rq_um, r.rt_um], np.array([r.ra_m, r.rq_m, r.rt_m]) * 1e6, rtol=1e-12)
    # a sine instead (odd about the middle): its own least-squares slope 6 A lambda / (pi L^2) tilts the
    # residual by +-3 A lambda / (pi L) at the ends, which Rt (a first-order extreme value) shows
    rs = roughness(x, amp * np.sin(2 * math.pi * x / lam), form="line")
    assert_allclose(rs.rq_m, amp / math.sqrt(2), rtol=3e-4)
    assert 2 * amp < rs.rt_m <= 2 * amp * (1 + 3 * lam / (math.pi * x[-1]))


def test_roughness_gaussian_filter_removes_the_waviness():
    x = _profile(length=8e-3)
    amp, lam = 0.4e-6, 100e-6
    w_amp, w_lam = 0.4e-6, 8e-3  # waviness 10 cutoffs long, as large as the roughness
    z = amp * np.sin(2 * math.pi * x / lam) + w_amp * np.sin(2 * math.pi * x / w_lam + 0.7)
    r = roughness(x, z, form="gaussian", cutoff_m=0.8e-3)
    # Gaussian mean line transmission exp(-pi (alpha lambda_c / lambda)^2): 1 - 2e-44 at 100 um (the
    # roughness passes), 0.9956 at 8 mm (0.44 % of the waviness leaks: 1.8e-9 m amplitude)
    alpha = math.sqrt(math.log(2) / math.pi)
    leak = w_amp * (1 - math.exp(-math.pi * (alpha * 0.8e-3 / w_lam) ** 2))
    assert_allclose(r.rq_m, math.sqrt(amp**2 + leak**2) / math.sqrt(2), rtol=2e-3)
    assert_allclose(r.ra_m, 2 * amp / math.pi, rtol=0, atol=2e-3 * amp + leak)
    assert_allclose(r.rt_m, 2 * amp, rtol=0, atol=2e-3 * amp + 2 * leak)
    assert_allclose(r.evaluation_length_m, x[-1] - 0.8e-3, rtol=1e-9)
    # without the filter only the least-squares line goes: the rest of the waviness (one full period,
    # residual rms ~0.5 w_amp / sqrt 2 after the line) adds in quadrature and Rq is ~25 % too high
    assert roughness(x, z, form="line").rq_m > 1.2 * amp / math.sqrt(2)


def test_gaussian_mean_line_has_50_percent_transmission_at_the_cutoff():
    x = _profile(length=20e-3, dx=2e-6)
    lc = 0.8e-3
    z = np.sin(2 * math.pi * x / lc)
    m = gaussian_mean_line(x, z, lc)
    mid = (x > 2 * lc) & (x < x[-1] - 2 * lc)
    assert_allclose(np.abs(m[mid]).max(), 0.5, rtol=2e-3)  # ISO 16610-21 definition of lambda_c


def test_roughness_bad_input():
    x = _profile(length=0.5e-3)
    with pytest.raises(SignalError, match="not longer than the cutoff"):
        roughness(x, np.zeros_like(x), form="gaussian")
    with pytest.raises(SignalError, match="form must be 'line' or 'gaussian'"):
        roughness(x, np.zeros_like(x), form="spline")  # pyright: ignore[reportArgumentType]  # deliberately invalid input
    with pytest.raises(SignalError, match="cutoff_m must be > 0, got -1.0"):
        roughness(_profile(), np.zeros_like(_profile()), form="gaussian", cutoff_m=-1.0)
