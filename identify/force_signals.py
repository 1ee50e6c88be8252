"""Signal processing of cutting-force series: spindle frequency, revolutions, synchronous average,
alignment, spectra, and the held-out error metric.

A milling force in a stable cut is periodic in the spindle revolution. Everything here works on
the **revolution grid**: the series is resampled (linear interpolation) at ``M`` equally spaced
spindle angles in each complete revolution, giving an array ``(n_rev, M, n_axes)``. Its mean over
revolutions is the time-synchronous average (TSA); the scatter of the revolutions about it, divided
by ``sqrt(n_rev)``, is the TSA's own noise.

* The spindle frequency is estimated from the data (:func:`estimate_spindle_hz`): the frequency
  ``f`` near the nominal one that maximises the energy of the series at the harmonics ``k f``,
  ``k = 1..K`` (a harmonic-sum periodogram; its peak width is ``~1 / (K T)`` for a record of length
  ``T``, refined by a parabola through the three best grid points).
* The spindle angle at ``t = 0`` is unknown: the model's TSA is aligned to the measured one by the
  circular shift (fraction of a revolution) that maximises their cross-correlation
  (:func:`align_shift`), computed in the Fourier domain and refined to a fraction of a bin.
* Error metric (:func:`heldout_error`): ``RMS over bins and axes of (model - measured) / RMS of the
  measured``, on the TSA of a held-out block of contiguous revolutions; beside it the noise floor
  ``RMS(sigma / sqrt(N)) / RMS(measured)``, what a perfect model would score.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from robolobes.core.errors import BadInput

__all__ = ["estimate_spindle_hz", "revolutions", "SyncAverage", "sync_average", "align_shift", "shift_average",
           "apply_transfer", "heldout_error", "spectrum_lines", "ERROR_METRIC"]

ERROR_METRIC = ("RMS over the angle bins and the x, y axes of (model - measured) time-synchronous average of a "
                "held-out block of contiguous revolutions, divided by the RMS of the measured average "
                "(dimensionless); noise floor = RMS of sigma/sqrt(N) of that average over the same RMS")


def _harmonic_energy(t: np.ndarray, x: np.ndarray, f: float, k_max: int) -> float:
    k = np.arange(1, k_max + 1)
    e = np.exp(-2j * np.pi * np.outer(k * f, t))  # (K, n)
    c = e @ x  # (K, axes)
    return float(np.sum(np.abs(c) ** 2))


def estimate_spindle_hz(t_s: np.ndarray, force_n: np.ndarray, nominal_hz: float, *, rel_range: float = 0.01,
                        k_max: int = 12) -> float:
    """Spindle revolution frequency from a force series (harmonic-sum periodogram, module docstring).

    Parameters
    ----------
    t_s : array (n,)
        Uniform sample times, s.
    force_n : array (n, a)
        Forces, N (mean removed here).
    nominal_hz : float
        Expected revolution frequency, Hz (the case's rpm / 60).
    rel_range : float
        Search ``nominal * (1 +- rel_range)``.
    k_max : int
        Harmonics used.

    Returns
    -------
    float
        The estimate, Hz; ``nominal_hz`` itself when the estimate is within half a grid step
        ``0.1 / (k_max T)`` of it (T the record length): the peak of the harmonic sum of a
        non-stationary record (a drifting envelope, e.g. with backlash) is biased by up to a quarter
        of a step (0.026 Hz on 0.15 s of the aluminium pass, 0.11 Hz steps), so closer estimates do
        not tell the two apart, and a model run at the commanded speed is then the better choice.
    """
    t = np.asarray(t_s, float)
    x = np.asarray(force_n, float)
    x = x - x.mean(axis=0)
    # at most ~20k samples: decimate by striding (the harmonics used are far below Nyquist)
    step = max(1, len(t) // 20000)
    t, x = t[::step] - t[0], x[::step]
    span = t[-1] - t[0]
    df = 0.2 / (k_max * span)
    grid = np.arange(nominal_hz * (1 - rel_range), nominal_hz * (1 + rel_range) + df, df)
    e = np.array([_harmonic_energy(t, x, f, k_max) for f in grid])
    i = int(np.clip(np.argmax(e), 1, len(grid) - 2))
    y0, y1, y2 = e[i - 1], e[i], e[i + 1]
    den = y0 - 2 * y1 + y2
    off = 0.5 * (y0 - y2) / den if den < 0 else 0.0
    est = float(grid[i] + np.clip(off, -1, 1) * df)
    return float(nominal_hz) if abs(est - nominal_hz) < 0.5 * df else est


def revolutions(t_s: np.ndarray, force_n: np.ndarray, spindle_hz: float, bins: int, *, t_ref_s: float | None = None
                ) -> tuple[np.ndarray, np.ndarray]:
    """Resample a series onto ``bins`` spindle angles per complete revolution.

    Revolution ``i`` spans ``[t_ref + i / f, t_ref + (i + 1) / f)``; bin ``m`` is at angle ``2 pi m / bins``
    from its start. Returns ``(start_s (n_rev,), samples (n_rev, bins, a))``. ``t_ref`` defaults to the
    first sample.
    """
    t = np.asarray(t_s, float)
    x = np.asarray(force_n, float)
    t0 = float(t[0] if t_ref_s is None else t_ref_s)
    period = 1.0 / spindle_hz
    n_rev = int(math.floor((t[-1] - t0) / period + 1e-9))
    first = max(0, int(math.ceil((t[0] - t0) / period - 1e-9)))
    if n_rev - first < 1:
        raise BadInput(f"the series ({t[-1] - t[0]:.4g} s) holds no complete spindle revolution "
                       f"({period:.4g} s)")
    starts = t0 + period * np.arange(first, n_rev)
    tq = (starts[:, None] + period * np.arange(bins)[None, :] / bins).ravel()
    out = np.stack([np.interp(tq, t, x[:, j]) for j in range(x.shape[1])], axis=-1)
    return starts, out.reshape(len(starts), bins, x.shape[1])


@dataclass(frozen=True)
class SyncAverage:
    """Time-synchronous average of a block of revolutions.

    mean : (M, a) N;  sigma : (M, a) N (scatter of single revolutions);  n : revolutions averaged;
    t_span_s : (first start, last end) of the block.
    """

    mean: np.ndarray
    sigma: np.ndarray
    n: int
    t_span_s: tuple

    @property
    def noise(self) -> np.ndarray:
        """sigma / sqrt(n): the standard error of the average per bin and axis, (M, a), N."""
        return self.sigma / math.sqrt(max(self.n, 1))


def sync_average(starts: np.ndarray, revs: np.ndarray, period_s: float) -> SyncAverage:
    """TSA of revolutions ``revs`` (n, M, a) that start at ``starts`` (n,)."""
    n = revs.shape[0]
    mean = revs.mean(axis=0)
    sigma = revs.std(axis=0, ddof=1) if n > 1 else np.zeros_like(mean)
    return SyncAverage(mean=mean, sigma=sigma, n=n, t_span_s=(float(starts[0]), float(starts[-1] + period_s)))


def shift_average(avg: np.ndarray, shift_rev: float) -> np.ndarray:
    """Circularly delay a periodic average (M, a) by ``shift_rev`` revolutions (any real number)."""
    m = avg.shape[0]
    spec = np.fft.rfft(avg, axis=0)
    k = np.arange(spec.shape[0])
    ph = np.exp(-2j * np.pi * k * shift_rev)
    if m % 2 == 0:
        # the Nyquist line of a real signal cannot carry a fractional phase: keep its real part
        ph[-1] = np.cos(np.pi * m * shift_rev)
    return np.fft.irfft(spec * ph[:, None], n=m, axis=0)


def align_shift(model: np.ndarray, measured: np.ndarray, *, oversample: int = 16) -> float:
    """The delay (revolutions, in [0, 1)) to apply to ``model`` (M, a) so it best matches ``measured``.

    Maximises the cross-correlation summed over axes, on an ``oversample`` times finer grid, refined by
    a parabola through the best three points.
    """
    m = model.shape[0]
    a = np.fft.rfft(measured - measured.mean(0), axis=0)
    b = np.fft.rfft(model - model.mean(0), axis=0)
    cross = np.sum(a * np.conj(b), axis=1)
    n = m * oversample
    c = np.fft.irfft(cross, n=n)
    i = int(np.argmax(c))
    y0, y1, y2 = c[i - 1], c[i], c[(i + 1) % n]
    den = y0 - 2 * y1 + y2
    off = 0.5 * (y0 - y2) / den if den < 0 else 0.0
    return float(((i + off) / n) % 1.0)


def apply_transfer(avg: np.ndarray, rev_hz: float, h_of_f) -> np.ndarray:
    """Pass a periodic average (M, a) through a linear filter ``h_of_f(f_hz) -> complex`` (exact in
    steady state for a periodic signal: each revolution harmonic ``k f_rev`` is multiplied by
    ``H(k f_rev)``)."""
    m = avg.shape[0]
    spec = np.fft.rfft(avg, axis=0)
    f = rev_hz * np.arange(spec.shape[0])
    h = np.asarray(h_of_f(f), dtype=complex)
    if m % 2 == 0:
        h[-1] = h[-1].real
    return np.fft.irfft(spec * h[:, None], n=m, axis=0)


def heldout_error(model: np.ndarray, measured: SyncAverage, axes=(0, 1)) -> tuple[float, float]:
    """(error, noise floor) of a model average (M, a) against a held-out measured average (module docstring)."""
    ax = list(axes)
    ref = math.sqrt(float(np.mean(measured.mean[:, ax] ** 2)))
    err = math.sqrt(float(np.mean((model[:, ax] - measured.mean[:, ax]) ** 2))) / ref
    floor = math.sqrt(float(np.mean(measured.noise[:, ax] ** 2))) / ref
    return err, floor


def revolution_harmonics(avg: np.ndarray) -> np.ndarray:
    """Harmonics of a revolution average (M, a): ``c_k = (1/M) sum_m x_m exp(-2 pi i k m / M)``,
    (M // 2 + 1, a) complex, N (``c_0`` the mean; a line of amplitude A at k > 0 has |c_k| = A / 2)."""
    return np.fft.rfft(avg, axis=0) / avg.shape[0]


def harmonic_noise(noise: np.ndarray) -> np.ndarray:
    """RMS of |c_k| (:func:`revolution_harmonics`) of an average that is noise only, per axis (a,) N:
    ``E|c_k|^2 = sum_m s_m^2 / M^2`` for independent bins of standard error ``s_m`` (``noise`` (M, a))."""
    return np.sqrt(np.sum(noise ** 2, axis=0)) / noise.shape[0]


def spectrum_lines(avg: np.ndarray, teeth: int, *, axes=(0, 1)) -> dict:
    """Signatures of a periodic average (M, a): mean offsets, tooth-passing harmonics, once-per-revolution
    lines (revolution harmonics that are not multiples of the tooth count: runout, pitch), and the
    content above the 5th tooth-passing harmonic (ringing after each entry). Amplitudes in N."""
    spec = revolution_harmonics(avg)
    amp = 2 * np.abs(spec)
    amp[0] = np.abs(spec[0])
    k = np.arange(amp.shape[0])
    ax = list(axes)
    tooth = (k > 0) & (k % teeth == 0)
    rev = (k > 0) & (k % teeth != 0)
    high = k > 5 * teeth
    return {
        "mean_n": np.real(spec[0, ax]).tolist(),
        "tooth_harmonics_n": [amp[teeth * i, ax].tolist() for i in range(1, 6) if teeth * i < len(k)],
        "once_per_rev_rms_n": float(np.sqrt(np.sum(amp[rev][:, ax] ** 2) / 2)),
        "tooth_rms_n": float(np.sqrt(np.sum(amp[tooth][:, ax] ** 2) / 2)),
        "above_5th_tooth_harmonic_rms_n": float(np.sqrt(np.sum(amp[high][:, ax] ** 2) / 2)),
    }
