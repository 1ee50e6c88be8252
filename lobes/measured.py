"""A measured tool-tip receptance used as it is (no model): the zero-order approximation's input.

The FRF holds the 2 x 2 receptance in the cut plane (x_c feed, y_c normal) on the measured lines;
between lines it is interpolated linearly in its real and imaginary parts, and outside the
measured band it is not defined (the ZOA searches the measured band only). The axial column and
row are zero (a hammer test of the tool tip measures the cut plane).

Resolution: the ZOA follows the phase of the receptance across each resonance, which turns by
``pi/2`` within one half-power bandwidth ``2 zeta f_n``; with fewer than :data:`MIN_LINES_PER_BANDWIDTH`
lines in it the peak height and phase are under-sampled (a line half-way between two lines
spaced a fifth of the bandwidth apart sees ``1 / sqrt(1 + 0.2^2)``, 2 % below the peak; at half the
bandwidth, ``1 / sqrt(1 + 0.5^2)``, 11 % below), so such an FRF is
refused.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from robolobes.core.frf import CUT_LABELS, FRF
from robolobes.core.validate import readonly

from ._errors import LobeError

__all__ = ["MeasuredStructure", "Peak", "resonance_peaks", "MIN_LINES_PER_BANDWIDTH"]

MIN_LINES_PER_BANDWIDTH = 5.0


@dataclass(frozen=True)
class Peak:
    """A resolved resonance peak of ``|H|``: its line's frequency (Hz), the half-power bandwidth
    (Hz, between the linearly interpolated crossings of ``peak / sqrt 2``) and the number of lines
    per bandwidth (bandwidth / local line spacing)."""

    freq_hz: float
    bandwidth_hz: float
    lines_per_bandwidth: float
    magnitude: float


def resonance_peaks(freq_hz: np.ndarray, mag: np.ndarray, min_fraction: float = 0.1) -> list[Peak]:
    """Resolved peaks of a magnitude ``mag`` (F,) on lines ``freq_hz`` (F,), Hz.

    A local maximum counts when it reaches ``min_fraction`` of the largest ``mag`` and ``mag``
    falls below ``peak / sqrt 2`` on both sides before it rises above the peak (noise ripples on a
    flank or in a valley do not) and before the band ends.
    """
    f, a = np.asarray(freq_hz, float), np.asarray(mag, float)
    out = []
    h = a / math.sqrt(2)
    loc = np.flatnonzero((a[1:-1] > a[:-2]) & (a[1:-1] >= a[2:]) & (a[1:-1] >= min_fraction * a.max())) + 1
    for i in loc:
        lo = _half_power_crossing(f, a, i, h[i], -1)
        hi = _half_power_crossing(f, a, i, h[i], +1)
        if lo is None or hi is None:
            continue
        df = (f[min(i + 1, len(f) - 1)] - f[max(i - 1, 0)]) / 2
        out.append(Peak(float(f[i]), hi - lo, (hi - lo) / df, float(a[i])))
    return out


def _half_power_crossing(f, a, i, level, step):
    j = i
    while 0 <= j + step < len(a):
        j += step
        if a[j] > a[i]:
            return None
        if a[j] < level:
            t = (a[j - step] - level) / (a[j - step] - a[j])
            return float(f[j - step] + t * (f[j] - f[j - step]))
    return None


@dataclass(frozen=True, eq=False)
class MeasuredStructure:
    """A measured tool-tip receptance in the cut plane.

    Parameters
    ----------
    omega : array (F,), rad/s
        Measured lines, increasing, > 0.
    H : complex array (2, 2, F), m/N
        Receptance: rows displacement x_c, y_c; columns force x_c, y_c.
    cross_measured : bool
        False when only the driving points were measured (``H[0, 1] = H[1, 0] = 0`` assumed).
    source : str
        Where it came from (a file name), for messages.
    """

    omega: np.ndarray
    H: np.ndarray
    cross_measured: bool = True
    source: str = "measured FRF"

    def __post_init__(self) -> None:
        w = readonly(self.omega, float, error=LobeError).reshape(-1)
        H = readonly(self.H, complex, error=LobeError)
        if H.shape != (2, 2, len(w)):
            raise LobeError(f"{self.source}: H must be (2, 2, F) with F = {len(w)} lines, got {H.shape}")
        if len(w) < 3 or not np.all(np.isfinite(w)) or w[0] <= 0 or np.any(np.diff(w) <= 0):
            raise LobeError(f"{self.source}: needs at least 3 increasing frequency lines > 0")
        if not np.all(np.isfinite(H)):
            raise LobeError(f"{self.source}: NaN or inf in the FRF")
        object.__setattr__(self, "omega", w)
        object.__setattr__(self, "H", H)

    @property
    def freq_hz(self) -> np.ndarray:
        return self.omega / (2 * math.pi)

    @property
    def band_hz(self) -> tuple[float, float]:
        """Measured band (first line, last line), Hz."""
        return float(self.freq_hz[0]), float(self.freq_hz[-1])

    def peaks(self) -> list[Peak]:
        """Resolved peaks of the driving points ``|H_xx|``, ``|H_yy|`` of at least a tenth of their
        largest (:func:`resonance_peaks`): the modes that shape the lobes."""
        return resonance_peaks(self.freq_hz, np.abs(self.H[0, 0])) + resonance_peaks(self.freq_hz, np.abs(self.H[1, 1]))

    def check_resolution(self, min_lines: float = MIN_LINES_PER_BANDWIDTH) -> list[Peak]:
        """The peaks, or :class:`LobeError` if one has fewer than ``min_lines`` lines per half-power bandwidth."""
        pk = self.peaks()
        if not pk:
            raise LobeError(f"{self.source}: no resolved resonance peak in the driving points "
                            f"({self.band_hz[0]:g}-{self.band_hz[1]:g} Hz); the ZOA needs the resonances inside the band")
        worst = min(pk, key=lambda p: p.lines_per_bandwidth)
        if worst.lines_per_bandwidth < min_lines:
            raise LobeError(
                f"{self.source}: the peak at {worst.freq_hz:.5g} Hz has {worst.lines_per_bandwidth:.2g} lines per "
                f"half-power bandwidth ({worst.bandwidth_hz:.3g} Hz); at least {min_lines:g} are needed: measure "
                f"with a finer frequency resolution")
        return pk

    def receptance(self, omega_rad_s: np.ndarray) -> np.ndarray:
        """Interpolated receptance (3, 3, F') m/N at ``omega_rad_s`` (F',) inside the measured band."""
        w = np.asarray(omega_rad_s, dtype=float).reshape(-1)
        tol = 1e-9 * self.omega[-1]
        if np.any(w < self.omega[0] - tol) or np.any(w > self.omega[-1] + tol):
            raise LobeError(f"{self.source}: frequencies outside the measured band "
                            f"{self.band_hz[0]:g}-{self.band_hz[1]:g} Hz were asked for")
        out = np.zeros((3, 3, len(w)), complex)
        for i in range(2):
            for j in range(2):
                out[i, j] = np.interp(w, self.omega, self.H[i, j].real) + 1j * np.interp(w, self.omega, self.H[i, j].imag)
        return out

    def frf(self, omega_rad_s: np.ndarray | None = None) -> FRF:
        """The measured receptance as :class:`robolobes.core.frf.FRF` (3, 3, F), cut frame (on the measured lines by default)."""
        w = self.omega if omega_rad_s is None else np.asarray(omega_rad_s, dtype=float)
        return FRF(omega=w, H=self.receptance(w), frame="cut", labels=CUT_LABELS)

    def state_space(self):
        raise LobeError(f"{self.source}: a measured FRF has no state-space model; the semi-discretization needs one: "
                        "fit it first (robolobes.lobes.fit_modal), or use the zero-order method")
