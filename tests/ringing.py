"""The frequency of a free ringing from its zero crossings (shared by the elements' time-domain tests)."""

import numpy as np


def crossing_frequency_hz(t_s, x, min_crossings: int = 20) -> float:
    """Frequency (Hz) of the oscillation ``x`` (N,) sampled at ``t_s`` (N,) s: a straight line through
    its zero crossings (linearly interpolated between samples), half a period apart. Fails (assert)
    with fewer than ``min_crossings`` crossings."""
    t_a, x_a = np.asarray(t_s, float), np.asarray(x, float)
    i = np.nonzero(np.sign(x_a[:-1]) != np.sign(x_a[1:]))[0]
    tc = t_a[i] - x_a[i] * (t_a[i + 1] - t_a[i]) / (x_a[i + 1] - x_a[i])
    assert tc.size > min_crossings, tc.size
    return float(1.0 / (2.0 * np.polyfit(np.arange(tc.size), tc, 1)[0]))
