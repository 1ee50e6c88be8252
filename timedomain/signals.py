"""Post-processing of time-domain milling results: force statistics, once-per-revolution sections,
chatter frequency, roughness of the machined wall.

All inputs and outputs are SI (s, m, N); ``_hz`` and ``_um`` appear only in names that say so.

The stability verdict is not here: it is :mod:`timedomain.verdict` (a growth rate of the
non-synchronous motion with its confidence interval, and a chip-based saturation criterion).

Chatter frequency (:func:`chatter_frequency`)
---------------------------------------------
Hann-windowed, zero-padded amplitude spectrum of the window; bins within ``guard_hz`` (default
``3 / window length``, 1.5 Hann main-lobe half-widths) of every forced harmonic are masked: the
spindle harmonics ``k f_s`` (runout and variable pitch force all of them) or only the
tooth-passing harmonics ``k N f_s``; the highest remaining peak, refined by a parabola through the
log-amplitudes of its three bins (exact for a Gaussian, within ~1 % of a bin for Hann), is the
chatter frequency.

A line or a band (:attr:`ChatterFrequency.coherence`). The highest peak is the chatter frequency
only if it is a spectral line: periodic or quasi-periodic motion (locked flip, Hopf chatter, at any
amplitude envelope: growing, decaying, saturated). Saturated chatter that is not periodic has a
continuous spectrum, and its highest peak is one of many in a band. Example: steel at 5000 rpm
(6-DOF TX200, 1.25 times the limit) chatters in bursts 7.2 Hz apart, each a flip exactly at
half the tooth passing, whose sign changes irregularly from burst to burst; the spectrum is a band
of about +-10 Hz with a dip at the flip frequency itself, and the highest peak lies 1.1-2.1 %
below it, where the sign pattern happens to put it (82.09 Hz over the steady window, 82.37 and
82.41 Hz over its halves). The test: the window is cut into ``Q = 4`` quarters; in each,
the complex amplitude ``X_q`` (over axes) at the peak frequency is fitted by Hann-weighted least
squares together with a constant, a slope and the forced harmonics within ``2 Q / T`` (``T`` the
window) of the peak; the coherence is ``C = |sum_q X_q| / sum_q |X_q|``. A line keeps its phase
(``C = 1`` whatever its envelope); a line whose frequency drifts by one resolution bin ``1 / T``
over the window has ``C = 0.98``, by two bins 0.92; the peak is a line when ``C >= 0.9``
(:data:`LINE_COHERENCE`): its frequency is then defined to the resolution of the window. The
bursts of steel at 5000 rpm: ``C = 0.44``. A sign pattern that repeats within the window makes
lines of its own (sidebands at the carrier +- the pattern's frequency): over the second half of
that window alone (2.4 s) the pattern is nearly periodic (four bursts of each sign, 0.9 Hz) and its
82.42 Hz sideband is called a line (``C = 0.91``). The rule says whether the peak is a line, not
whether it is the carrier.

Roughness (:func:`roughness`, ISO 4287)
---------------------------------------
On a profile ``z(x)`` sampled uniformly: the form (``form="line"``: least-squares line over the
evaluation length) or the waviness (``form="gaussian"``: ISO 16610-21 Gaussian mean line,
cutoff ``lambda_c``, default 0.8 mm as ISO 4288 gives for 0.1 < Ra <= 2 um; weights
``exp(-pi (x / (alpha lambda_c))^2)``, ``alpha = sqrt(ln 2 / pi)``, 50 % transmission at
``lambda_c``, renormalized at the ends) is removed, then over the evaluation length
``Ra = mean |z|``, ``Rq = sqrt(mean z^2)``, ``Rt = max z - min z``. With the Gaussian filter the
evaluation length is the profile less ``lambda_c / 2`` at each end (run-in/run-out, where the mean
line is not defined by a full weighting function). ISO computes Ra and Rq per sampling length and
averages; for a stationary profile that equals the value over the evaluation length used here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import partial
from typing import Literal

import numpy as np

from robolobes.core.validate import finite, readonly

__all__ = [
    "SignalError",
    "HarmonicSet",
    "FormRemoval",
    "ForceStats",
    "force_stats",
    "once_per_revolution",
    "synchronous_average",
    "ChatterFrequency",
    "LINE_COHERENCE",
    "chatter_frequency",
    "Roughness",
    "roughness",
    "gaussian_mean_line",
]

HarmonicSet = Literal["spindle", "tooth"]
FormRemoval = Literal["line", "gaussian"]

_ALPHA = math.sqrt(math.log(2.0) / math.pi)


class SignalError(ValueError):
    """Signals that cannot be processed as asked (bad shapes, non-uniform sampling, short window)."""


#: core.validate.finite raising SignalError: a finite number > 0
_positive = partial(finite, positive=True, error=SignalError)


def _series(t_s, x, name: str = "signal") -> tuple[np.ndarray, np.ndarray, bool]:
    """Validate a uniformly sampled series; returns (t (n,), x (n, m), was_1d)."""
    t = np.asarray(t_s, dtype=float)
    xx = np.asarray(x, dtype=float)
    if t.ndim != 1 or t.size < 3:
        raise SignalError(f"time must be a 1-D array of at least 3 samples, got shape {t.shape}")
    one_d = xx.ndim == 1
    if one_d:
        xx = xx[:, None]
    if xx.ndim != 2 or xx.shape[0] != t.size:
        raise SignalError(f"{name} must have shape (n,) or (n, m) with n = {t.size} samples, got {np.shape(x)}")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(xx))):
        raise SignalError(f"time and {name} must be finite (found NaN or inf)")
    dt = np.diff(t)
    if np.any(dt <= 0):
        raise SignalError("time must be strictly increasing")
    if np.ptp(dt) > 1e-6 * dt.mean():
        raise SignalError(
            f"{name} must be sampled uniformly (steps from {dt.min():.6g} to {dt.max():.6g} s); resample it, "
            f"e.g. keep only the on-grid steps of the integrator or use np.interp"
        )
    return t, xx, one_d


def _window(t: np.ndarray, t_start_s, t_end_s) -> tuple[float, float]:
    lo = t[0] if t_start_s is None else float(t_start_s)
    hi = t[-1] if t_end_s is None else float(t_end_s)
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi <= lo:
        raise SignalError(f"window [{lo}, {hi}] s must be finite and increasing")
    if lo < t[0] - 1e-12 or hi > t[-1] + 1e-12:
        raise SignalError(f"window [{lo}, {hi}] s is outside the signal's time span [{t[0]}, {t[-1]}] s")
    return lo, hi


# --------------------------------------------------------------------------------------------
# force statistics


@dataclass(frozen=True)
class ForceStats:
    """Statistics of a force over a time window, per axis (as in the paper's Tab. 10).

    Attributes
    ----------
    t_start_s, t_end_s : float
        The window, s.
    min_n, max_n, mean_n, rms_n, std_n : array (m,)
        Per axis, N. ``rms = sqrt(mean(F^2))`` (includes the mean, as Tab. 10); ``std`` excludes it.
    n_samples : int
    """

    t_start_s: float
    t_end_s: float
    min_n: np.ndarray
    max_n: np.ndarray
    mean_n: np.ndarray
    rms_n: np.ndarray
    std_n: np.ndarray
    n_samples: int


def force_stats(t_s, f_n, t_start_s: float | None = None, t_end_s: float | None = None) -> ForceStats:
    """Min, max, mean and RMS of each force component over ``[t_start_s, t_end_s]``.

    Parameters
    ----------
    t_s : array (n,)
        Uniformly spaced times, s.
    f_n : array (n,) or (n, m)
        Force samples, N.
    t_start_s, t_end_s : float, optional
        Window, s (inclusive). Default: the whole record.

    Returns
    -------
    ForceStats
    """
    t, f, _ = _series(t_s, f_n, "force")
    lo, hi = _window(t, t_start_s, t_end_s)
    sel = (t >= lo - 1e-12) & (t <= hi + 1e-12)
    if sel.sum() < 2:
        raise SignalError(f"window [{lo}, {hi}] s holds fewer than 2 samples")
    w = f[sel]
    return ForceStats(
        t_start_s=lo, t_end_s=hi, min_n=readonly(w.min(0)), max_n=readonly(w.max(0)), mean_n=readonly(w.mean(0)),
        rms_n=readonly(np.sqrt((w**2).mean(0))), std_n=readonly(w.std(0)), n_samples=int(sel.sum()),
    )


# --------------------------------------------------------------------------------------------
# once per revolution


def _spline(t: np.ndarray, x: np.ndarray):
    from scipy.interpolate import CubicSpline

    return CubicSpline(t, x, axis=0)


def once_per_revolution(
    t_s, x, period_s: float, *, t_start_s: float | None = None, t_end_s: float | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Sample a signal once per spindle revolution (cubic-spline interpolation).

    Parameters
    ----------
    t_s : array (n,)
        Uniform times, s.
    x : array (n,) or (n, m)
        Signal (tool displacement, force ...).
    period_s : float
        Spindle period ``60 / rpm``, s.
    t_start_s, t_end_s : float, optional
        Window; samples at ``t_start + k T <= t_end``.

    Returns
    -------
    t_k : array (n_rev,)
    x_k : array (n_rev,) or (n_rev, m)
    """
    t, xx, one_d = _series(t_s, x)
    period = _positive("spindle period_s", period_s)
    lo, hi = _window(t, t_start_s, t_end_s)
    n = int(math.floor((hi - lo) / period + 1e-9)) + 1
    tk = lo + period * np.arange(n)
    xk = _spline(t, xx)(tk)
    return readonly(tk), readonly(xk[:, 0] if one_d else xk)


def synchronous_average(
    t_s, x, period_s: float, *, t_start_s: float | None = None, t_end_s: float | None = None, bins: int = 128
) -> np.ndarray:
    """Average of the signal over the whole revolutions of the window, vs spindle phase.

    Returns
    -------
    array (bins,) or (bins, m)
        ``mean_k x(t_start + k T + b T / bins)``, the forced (synchronous) part of the response.
    """
    t, xx, one_d = _series(t_s, x)
    period = _positive("spindle period_s", period_s)
    lo, hi = _window(t, t_start_s, t_end_s)
    n_rev = int(math.floor((hi - lo) / period + 1e-9))
    if n_rev < 1:
        raise SignalError(f"window of {hi - lo:.6g} s is shorter than one revolution ({period:.6g} s)")
    if bins < 4:
        raise SignalError(f"bins must be >= 4, got {bins}")
    tt = lo + period * (np.arange(n_rev)[:, None] + np.arange(bins)[None, :] / bins)
    avg = _spline(t, xx)(tt.ravel()).reshape(n_rev, bins, -1).mean(0)
    return readonly(avg[:, 0] if one_d else avg)


# --------------------------------------------------------------------------------------------
# chatter frequency


#: Phase coherence at or above which the highest peak is a spectral line (module docstring).
LINE_COHERENCE = 0.9
#: Sub-windows of the coherence test.
_QUARTERS = 4


def _amplitude_at(t, y, f_hz: float, forced_hz) -> np.ndarray:
    """Complex amplitude at ``f_hz`` of ``y`` (n, m) sampled at ``t`` (n,), s (phase referred to
    ``t = 0``), by Hann-weighted least squares with a constant, a slope and the lines ``forced_hz``
    fitted alongside; shape (m,), units of ``y``."""
    tc = t - t.mean()
    cols = [np.ones_like(t), tc] + [g(2 * math.pi * h * t) for h in (*forced_hz, f_hz) for g in (np.cos, np.sin)]
    sw = np.sqrt(np.hanning(t.size))[:, None]
    c, *_ = np.linalg.lstsq(np.stack(cols, 1) * sw, y * sw, rcond=None)
    return c[-2] - 1j * c[-1]


def _coherence(t, y, f_hz: float, base_hz: float) -> float:
    """``|sum_q X_q| / sum_q |X_q|`` over the quarters of the window ``t`` (n,), s, ``y`` (n, m):
    ``X_q`` the amplitude at ``f_hz`` with the forced harmonics ``k base_hz`` within ``2 Q / T`` of it
    (a quarter's Hann main lobe) fitted alongside (module docstring)."""
    n = t.size // _QUARTERS
    reach = 2 * _QUARTERS / (t[-1] - t[0])
    ks = range(max(1, math.floor((f_hz - reach) / base_hz)), math.ceil((f_hz + reach) / base_hz) + 1)
    forced = [k * base_hz for k in ks if abs(k * base_hz - f_hz) < reach]
    x = np.array([_amplitude_at(t[q * n:(q + 1) * n] - t[0], y[q * n:(q + 1) * n], f_hz, forced)
                  for q in range(_QUARTERS)])
    total = float(np.linalg.norm(x, axis=1).sum())
    return float(np.linalg.norm(x.sum(0)) / total) if total > 0 else 0.0


@dataclass(frozen=True)
class ChatterFrequency:
    """Dominant non-forced spectral line.

    Attributes
    ----------
    freq_hz : float
        Chatter frequency, Hz.
    amplitude : float
        Amplitude of that line (units of the signal; root-sum-square over axes).
    forced_amplitude : float
        Largest amplitude among the masked forced harmonics.
    resolution_hz : float
        ``1 / window length``, Hz.
    coherence : float
        Phase coherence of the peak over the window's quarters, in [0, 1] (module docstring).
    """

    freq_hz: float
    amplitude: float
    forced_amplitude: float
    resolution_hz: float
    coherence: float

    @property
    def is_line(self) -> bool:
        """The peak is a spectral line (``coherence >= LINE_COHERENCE``), so its frequency is the
        chatter frequency; else the motion has a band and the peak is one of many in it."""
        return self.coherence >= LINE_COHERENCE

    @property
    def ratio(self) -> float:
        """Chatter amplitude / largest forced amplitude."""
        return self.amplitude / self.forced_amplitude if self.forced_amplitude > 0 else math.inf


def chatter_frequency(
    t_s,
    x,
    spindle_hz: float,
    *,
    teeth: int | None = None,
    harmonics: HarmonicSet = "spindle",
    t_start_s: float | None = None,
    t_end_s: float | None = None,
    guard_hz: float | None = None,
    min_hz: float = 0.0,
    max_hz: float | None = None,
    pad: int = 8,
) -> ChatterFrequency:
    """Chatter frequency: the largest spectral peak away from the forced harmonics.

    Parameters
    ----------
    t_s : array (n,)
        Uniform times, s.
    x : array (n,) or (n, m)
        Signal; the power spectra of the axes are summed.
    spindle_hz : float
        Spindle rotation frequency ``rpm / 60``, Hz.
    teeth : int, optional
        Number of teeth; required with ``harmonics="tooth"``.
    harmonics : {"spindle", "tooth"}
        Mask all spindle harmonics ``k f_s`` (runout, variable pitch) or only the tooth-passing
        ones ``k N f_s`` (equal pitch, no runout).
    guard_hz : float, optional
        Half-width of the masked band around each harmonic, Hz. Default ``3 / window``.
    min_hz, max_hz : float
        Search band, Hz (default: 0 to Nyquist; DC is always masked as harmonic 0).
    pad : int
        Zero-padding factor (>= 1).

    Returns
    -------
    ChatterFrequency
    """
    t, xx, _ = _series(t_s, x)
    fs = _positive("spindle_hz", spindle_hz)
    lo, hi = _window(t, t_start_s, t_end_s)
    sel = (t >= lo - 1e-12) & (t <= hi + 1e-12)
    y = xx[sel]
    n = y.shape[0]
    if n < 16:
        raise SignalError(f"window holds {n} samples; need at least 16")
    dt = float(np.mean(np.diff(t)))
    t_win = n * dt
    if harmonics == "tooth":
        if teeth is None or int(teeth) < 1:
            raise SignalError(f"harmonics='tooth' needs teeth >= 1, got {teeth!r}")
        base = fs * int(teeth)
    elif harmonics == "spindle":
        base = fs
    else:
        raise SignalError(f"harmonics must be 'spindle' or 'tooth', got {harmonics!r}")
    guard = 3.0 / t_win if guard_hz is None else _positive("guard_hz", guard_hz)
    if int(pad) < 1:
        raise SignalError(f"pad must be an integer >= 1, got {pad!r}")
    y = y - y.mean(0)
    w = np.hanning(n)
    nfft = 1 << int(math.ceil(math.log2(n * int(pad))))
    spec = np.fft.rfft(y * w[:, None], n=nfft, axis=0)
    amp = np.sqrt((np.abs(spec) ** 2).sum(1)) * 2.0 / w.sum()
    f = np.fft.rfftfreq(nfft, dt)
    k = np.round(f / base)
    forced = np.abs(f - k * base) <= guard
    band = (f >= min_hz) & (f <= (f[-1] if max_hz is None else float(max_hz)))
    cand = band & ~forced
    if not cand.any():
        raise SignalError("no frequency left after masking the forced harmonics; narrow guard_hz or widen the band")
    forced_amp = float(amp[forced & band].max()) if (forced & band).any() else 0.0
    masked = np.where(cand, amp, -1.0)
    i = int(np.argmax(masked))
    fi, ai = f[i], amp[i]
    if 0 < i < f.size - 1 and cand[i - 1] and cand[i + 1] and amp[i - 1] > 0 and amp[i + 1] > 0:
        la, lb, lc = np.log(amp[i - 1]), np.log(amp[i]), np.log(amp[i + 1])
        den = la - 2 * lb + lc
        if den < 0:
            d = 0.5 * (la - lc) / den
            fi = f[i] + d * (f[1] - f[0])
            ai = math.exp(lb - 0.25 * (la - lc) * d)
    return ChatterFrequency(freq_hz=float(fi), amplitude=float(ai), forced_amplitude=forced_amp, resolution_hz=1.0 / t_win,
                            coherence=_coherence(t[sel], y, float(fi), base))


# --------------------------------------------------------------------------------------------
# roughness


@dataclass(frozen=True)
class Roughness:
    """ISO 4287 roughness parameters of a profile (procedure in the module docstring).

    Attributes
    ----------
    ra_m, rq_m, rt_m : float
        Arithmetic mean deviation, root-mean-square deviation, total height, m.
    evaluation_length_m : float
    form : {"line", "gaussian"}
    cutoff_m : float or None
        Gaussian cutoff ``lambda_c``, m (None for ``form="line"``).
    x_m, profile_m : array (n,)
        The roughness profile over the evaluation length, m.
    """

    ra_m: float
    rq_m: float
    rt_m: float
    evaluation_length_m: float
    form: FormRemoval
    cutoff_m: float | None
    x_m: np.ndarray
    profile_m: np.ndarray

    @property
    def ra_um(self) -> float:
        return self.ra_m * 1e6

    @property
    def rq_um(self) -> float:
        return self.rq_m * 1e6

    @property
    def rt_um(self) -> float:
        return self.rt_m * 1e6


def gaussian_mean_line(x_m, z_m, cutoff_m: float) -> np.ndarray:
    """ISO 16610-21 Gaussian mean line of a uniformly sampled profile, shape (n,), m.

    Weights ``exp(-pi (x / (alpha lambda_c))^2) / (alpha lambda_c)`` truncated at ``+-lambda_c``
    (the weight there is 7e-7 of the peak) and renormalized where the profile ends.
    """
    x, z, _ = _series(x_m, z_m, "profile")
    cutoff = _positive("cutoff_m", cutoff_m)
    dx = float(np.mean(np.diff(x)))
    half = int(math.ceil(cutoff / dx))
    u = np.arange(-half, half + 1) * dx
    k = np.exp(-math.pi * (u / (_ALPHA * cutoff)) ** 2)
    from scipy.signal import fftconvolve

    num = fftconvolve(z[:, 0], k, mode="same")
    den = fftconvolve(np.ones(z.shape[0]), k, mode="same")
    return readonly(num / den)


def roughness(x_m, z_m, *, form: FormRemoval = "line", cutoff_m: float | None = None) -> Roughness:
    """Ra, Rq, Rt of a profile ``z(x)`` (ISO 4287; procedure in the module docstring).

    Parameters
    ----------
    x_m : array (n,)
        Uniformly spaced positions along the profile, m.
    z_m : array (n,)
        Profile heights, m.
    form : {"line", "gaussian"}
        Remove the least-squares line, or the Gaussian mean line of cutoff ``cutoff_m``.
    cutoff_m : float, optional
        Gaussian cutoff ``lambda_c`` in m (default 0.8e-3); only with ``form="gaussian"``.

    Returns
    -------
    Roughness
    """
    x, z, _ = _series(x_m, z_m, "profile")
    z = z[:, 0]
    if form == "line":
        if cutoff_m is not None:
            raise SignalError("cutoff_m applies to form='gaussian' only")
        keep = np.ones(x.size, bool)
        cutoff = None
    elif form == "gaussian":
        cutoff = 0.8e-3 if cutoff_m is None else _positive("cutoff_m", cutoff_m)
        length = x[-1] - x[0]
        if length <= cutoff:
            raise SignalError(
                f"profile of {length * 1e3:.6g} mm is not longer than the cutoff {cutoff * 1e3:.6g} mm;"
                f" the Gaussian filter needs length > lambda_c (ISO 4288: 5 lambda_c + lambda_c)"
            )
        z = z - gaussian_mean_line(x, z, cutoff)
        keep = (x >= x[0] + cutoff / 2 - 1e-12) & (x <= x[-1] - cutoff / 2 + 1e-12)
    else:
        raise SignalError(f"form must be 'line' or 'gaussian', got {form!r}")
    xe, ze = x[keep], z[keep]
    if xe.size < 3:
        raise SignalError("evaluation length holds fewer than 3 samples")
    # Least-squares line over the evaluation length (the form for "line"; for "gaussian" it removes
    # only the mean of the filtered profile, whose slope is already ~0).
    a = np.vstack([np.ones_like(xe), xe - xe.mean()]).T
    coef, *_ = np.linalg.lstsq(a, ze, rcond=None)
    if form == "gaussian":
        coef[1] = 0.0
    r = ze - a @ coef
    return Roughness(
        ra_m=float(np.abs(r).mean()), rq_m=float(np.sqrt((r**2).mean())), rt_m=float(r.max() - r.min()),
        evaluation_length_m=float(xe[-1] - xe[0]), form=form, cutoff_m=cutoff, x_m=readonly(xe), profile_m=readonly(r),
    )
