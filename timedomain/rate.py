"""The growth rate of a run where it means what the Floquet exponent means: fitted only over the
principal periods in which the non-synchronous motion is resolved and the cut is still linear.

The rule (stated once, used by both time-domain methods and by ``bench/bench_timedomain_convergence.py``):

* the estimator is the verdict's (:func:`timedomain.verdict.growth_rate`: Poincare sections, second
  differences, block RMS, log-linear fit with its AR(1)- and blocking-corrected standard error);
* a principal period takes part only if the RMS of its second differences is at least
  ``10 x`` the verdict's resolution (:attr:`GrowthRule.resolution_m`, 2 nm: below it the amplitude is
  clamped and the slope flattened), and
* its chip loss is below :data:`timedomain.verdict.LOSS_LIMIT` (5 %: the chip-weighted share of the
  engagement where the simulated chip is <= 0; above, the regenerative gain is no longer the linear
  one and growth saturates);
* the fit uses the longest contiguous run of such second differences: 12 blocks when it holds 36
  or more, else one block per difference (at least 6: a lightly damped structure far from its
  limit changes by e^6 -- the whole range from 10 x 2 nm to chip loss -- within 6 to 20 periods);
  shorter runs give no rate (``None``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .verdict import (
    LOSS_LIMIT,
    GrowthEstimate,
    GrowthRule,
    growth_rate,
    poincare_sections,
)

__all__ = ["MIN_DIFFERENCES", "RESOLVED_FACTOR", "GatedRate", "gated_growth_rate", "loss_per_period"]

#: The motion must exceed this multiple of the verdict's resolution to enter the fit.
RESOLVED_FACTOR = 10.0
#: Fewest gated second differences of a fit (6 blocks of one).
MIN_DIFFERENCES = 6


@dataclass(frozen=True)
class GatedRate:
    """A growth rate fitted over the gated periods.

    estimate : GrowthEstimate or None   the fit (None: fewer than MIN_DIFFERENCES gated differences).
    window_s : (float, float) or None   the periods used, s.
    n_gated : int                       gated periods in the longest contiguous run.
    reason : str                        why there is no estimate, or "".
    """

    estimate: GrowthEstimate | None
    window_s: tuple[float, float] | None
    n_gated: int
    reason: str = ""

    @property
    def rate_per_s(self) -> float:
        return math.nan if self.estimate is None else self.estimate.rate_per_s

    @property
    def se_per_s(self) -> float:
        return math.nan if self.estimate is None else self.estimate.se_per_s


def loss_per_period(t_s, lost, total, period_s: float, t_start_s: float, n_periods: int) -> np.ndarray:
    """Chip-weighted lost share of the engagement per principal period from per-sample ``lost`` and
    ``total`` engagement weights (N,), shape (n_periods,)."""
    t = np.asarray(t_s, float)
    k = np.floor((t - t_start_s) / period_s + 1e-9).astype(int)
    sel = (k >= 0) & (k < n_periods)
    lo = np.bincount(k[sel], weights=np.asarray(lost, float)[sel], minlength=n_periods)
    to = np.bincount(k[sel], weights=np.asarray(total, float)[sel], minlength=n_periods)
    return np.where(to > 0, lo / np.where(to > 0, to, 1.0), 0.0)


def _longest_run(ok: np.ndarray) -> tuple[int, int]:
    best, start = (0, 0), None
    for i, flag in enumerate(np.append(ok, False)):
        if flag and start is None:
            start = i
        elif not flag and start is not None:
            if i - start > best[1] - best[0]:
                best = (start, i)
            start = None
    return best


#: the verdict's default rule (a frozen dataclass: one shared instance is safe)
_DEFAULT_RULE = GrowthRule()


def gated_growth_rate(t_s, x, period_s: float, *, t_start_s: float, t_end_s: float, loss=None,
                      rule: GrowthRule = _DEFAULT_RULE) -> GatedRate:
    """Growth rate of ``x`` (n, m), m, over the gated periods of ``[t_start_s, t_end_s]`` (module docstring).

    Parameters
    ----------
    t_s : array (n,)              uniform times, s.
    x : array (n, m)              tool displacement (deviation), cut plane, m.
    period_s : float              principal period, s.
    loss : array (K,), optional   chip loss per principal period from ``t_start_s`` (:func:`loss_per_period`);
                                  None: every period counts as linear.
    """
    p = poincare_sections(t_s, x, period_s, t_start_s, t_end_s, rule.phases)
    k = p.shape[0]
    if k < 8:
        return GatedRate(None, None, 0, f"only {k} principal periods in the window")
    e = (p[2:] - 2 * p[1:-1] + p[:-2]).reshape(k - 2, -1)
    amp = np.sqrt((e ** 2).mean(axis=1))  # e_i belongs to period i + 1
    ok = amp >= RESOLVED_FACTOR * rule.resolution_m
    if loss is not None:
        lp = np.asarray(loss, float)
        lmax = np.maximum.reduce([lp[:k - 2], lp[1:k - 1], lp[2:k]])  # the three periods of each difference
        ok &= lmax < LOSS_LIMIT
    i0, i1 = _longest_run(ok)
    n = i1 - i0
    if n < MIN_DIFFERENCES:
        why = (f"{n} gated second differences (motion >= {RESOLVED_FACTOR:g} x {rule.resolution_m:.0e} m and chip "
               f"loss < {100 * LOSS_LIMIT:g} %); the fit needs {MIN_DIFFERENCES}")
        return GatedRate(None, None, n, why)
    lo = float(t_start_s) + i0 * period_s
    hi = float(t_start_s) + (i1 + 2) * period_s
    blocks = rule.blocks if n >= 3 * rule.blocks else min(rule.blocks, n)
    g = growth_rate(t_s, x, period_s, t_start_s=lo, t_end_s=hi + 1e-9 * period_s, rule=replace(rule, blocks=blocks),
                    min_periods=n + 2)
    return GatedRate(g, (lo, hi), n)
