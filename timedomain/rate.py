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

Below the limit the kick's motion first rings in the robot's faster modes as well as in the
regenerative one; two opt-in parts of the rule (stated before they were run on the steel case, from
the physics of the cut and the statistics of the fit, not from its outcomes) deal with them:

* **the kick's size** (:func:`linear_kick_amplitude_m`): the largest kick that keeps the cut in the
  gate's linear regime. As the amplitude ``A`` of an oscillation at the chatter frequency, its
  regenerative amplitude ``|y(t) - y(t - tau)|`` is at most ``2 A`` (the flip's case); ``A`` is set so
  that ``2 A`` gives the chip loss of the gate, :data:`timedomain.verdict.LOSS_LIMIT` (5 %), on the
  tooth with the smallest static chip (:meth:`ChipScale.loss_fraction`). In down-milling the chip
  vanishes at the exit, so a loss of 0 is out of reach for any kick; the gate's own limit is the
  largest kick its definition calls linear, and the share of the kick that goes into faster modes
  (smaller displacement for the same speed) only lowers the motion. The slow mode is then as far
  above the 20 nm gate as the cut allows: a factor about e^6 on the steel and aluminium cases.
* **the faster modes**: they are separated from the leading one by the
  matrix pencil (:func:`pencil_growth_rate`, below), not by a later start. (A curvature test of the
  log amplitude, stated before the steel runs, was measured and removed: it lacked the power to see a
  -7.6 1/s mode beside a -3.4 1/s one; ``docs/guide/timedomain-convergence.md``.)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .verdict import (
    LOSS_LIMIT,
    ChipScale,
    GrowthEstimate,
    GrowthRule,
    growth_rate,
    poincare_sections,
)

__all__ = ["MIN_DIFFERENCES", "PENCIL_MAX_ORDER", "RESOLVED_FACTOR", "GatedRate", "PencilRate", "gated_growth_rate",
           "linear_kick_amplitude_m", "loss_per_period", "pencil_growth_rate", "pencil_over_window",
           "regenerative_loss_per_period"]

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


def regenerative_loss_per_period(t_s, x, chip: ChipScale, period_s: float, t_start_s: float,
                                 t_end_s: float) -> np.ndarray:
    """Chip loss per principal period of ``[t_start_s, t_end_s]``, shape (K,), for a run without
    per-sample engagement weights (the eroded part): the verdict's share of the chip-weighted arc
    (:meth:`ChipScale.loss_fraction`) at each tooth's regenerative amplitude
    ``sqrt(2) rms|y(t) - y(t - tau_j)|`` over that period, the largest over the teeth; ``y`` is ``x``
    (n, 2), m, on uniform times ``t_s`` (n,), s, minus its synchronous average over the window
    (phase bins of one step)."""
    t = np.asarray(t_s, float)
    dt = (t[-1] - t[0]) / (t.size - 1)
    sel = np.flatnonzero((t >= t_start_s) & (t <= t_end_s))
    ts, xs = t[sel], np.asarray(x, float)[sel]
    ph = np.floor(((ts - t_start_s) % period_s) / dt).astype(int)
    avg = np.zeros((ph.max() + 1, xs.shape[1]))
    np.add.at(avg, ph, xs)
    y = xs - (avg / np.maximum(np.bincount(ph), 1)[:, None])[ph]
    k = np.floor((ts - t_start_s) / period_s + 1e-9).astype(int)
    n_per = int((t_end_s - t_start_s) / period_s + 1e-9)
    loss = np.zeros(n_per)
    for j, tau in enumerate(chip.delays_s):
        lag = int(round(tau / dt))
        d2 = np.sum((y[lag:] - y[:-lag]) ** 2, axis=1)
        kk = k[lag:]
        ok = kk < n_per
        ms = np.bincount(kk[ok], d2[ok], n_per) / np.maximum(np.bincount(kk[ok], None, n_per), 1)
        loss = np.maximum(loss, [chip.loss_fraction(math.sqrt(2.0 * m), j) for m in ms])
    return loss


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


def linear_kick_amplitude_m(chip: ChipScale, loss: float = LOSS_LIMIT) -> float:
    """The largest kick the gate calls linear (module docstring): amplitude ``A`` of an oscillation at
    the chatter frequency, m, whose regenerative amplitude ``2 A`` gives chip loss ``loss`` on the tooth
    with the smallest static chip (bisection on :meth:`ChipScale.loss_fraction`, monotonic in ``A``)."""
    h = min(chip.max_chip_m)
    j = list(chip.max_chip_m).index(h)
    lo, hi = 0.0, h
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if chip.loss_fraction(mid, j) < loss else (lo, mid)
    return 0.25 * (lo + hi)


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


#: Largest model order of :func:`pencil_growth_rate` (real modes; a complex pair counts 2).
PENCIL_MAX_ORDER = 8
#: Contiguous groups of Hankel columns of the pencil's delete-a-group jackknife.
PENCIL_JACKKNIFE_GROUPS = 8


@dataclass(frozen=True)
class PencilRate:
    """The leading Floquet multiplier of a run's sections by the matrix pencil (:func:`pencil_growth_rate`).

    rate_per_s, se_per_s : float   ln|z| / Tp of the leading mode and its jackknife SE, 1/s (nan: no rate).
    order : int                    model order r (0..PENCIL_MAX_ORDER).
    multipliers : array (r,)       the pencil's eigenvalues z_i, per principal period (complex).
    amplitudes_m : array (r,)      each mode's RMS amplitude at the window's first section, m.
    leading : int                  index of the leading mode in ``multipliers`` (-1: none).
    residual_m : float             RMS of the rank-r remainder of the Hankel matrix, m.
    reason : str                   why there is no rate, or "".
    """

    rate_per_s: float
    se_per_s: float
    order: int
    multipliers: np.ndarray
    amplitudes_m: np.ndarray
    leading: int
    residual_m: float
    reason: str = ""


def _block_hankel(y: np.ndarray, rows: int) -> np.ndarray:
    """Block-Hankel matrix of ``y`` (K, c): ``rows`` block rows, shape (rows c, K - rows + 1)."""
    n = y.shape[0] - rows + 1
    return np.concatenate([y[i:i + n].T for i in range(rows)], axis=0)


def _esprit(h: np.ndarray, r: int, c: int) -> np.ndarray:
    """ESPRIT eigenvalues (r,) from the r leading left singular vectors of ``h`` (L c, n), c channels."""
    u = np.linalg.svd(h, full_matrices=False)[0][:, :r]
    phi = np.linalg.lstsq(u[:-c], u[c:], rcond=None)[0]
    return np.linalg.eigvals(phi)


def _mode_amplitudes(y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """RMS amplitude (r,) at k = 0 of each mode ``a_i z_i^k`` fitted to ``y`` (K, c) by least squares
    (over channels and, for a complex z, over its cycle: sqrt(2) |a| of the real pair)."""
    v = z[None, :] ** np.arange(y.shape[0])[:, None]
    a = np.linalg.lstsq(v, y.astype(complex), rcond=None)[0]
    pair = np.abs(np.imag(z)) > 1e-9 * np.abs(z)
    return np.sqrt((np.abs(a) ** 2).mean(axis=1)) * np.where(pair, math.sqrt(2.0), 1.0)


def _pencil_order(s: np.ndarray, size: int, floor: float, cap: int) -> tuple[int, float]:
    """Smallest r <= cap whose rank-r Hankel remainder has an RMS entry below ``floor`` (else cap),
    from the singular values ``s`` of a matrix with ``size`` entries; (r, that RMS)."""
    tail = np.sqrt(np.append(np.cumsum((s ** 2)[::-1])[::-1], 0.0) / size)
    for r in range(min(cap, s.size) + 1):
        if tail[r] < floor:
            return r, float(tail[r])
    r = min(cap, s.size)
    return r, float(tail[r])


def _jackknife_se(h: np.ndarray, r: int, c: int, z0: complex, period_s: float) -> float:
    """Delete-a-group jackknife SE of ln|z| / Tp, 1/s: the pencil repeated without each of
    :data:`PENCIL_JACKKNIFE_GROUPS` contiguous groups of Hankel columns, the eigenvalue nearest ``z0``."""
    groups = np.array_split(np.arange(h.shape[1]), PENCIL_JACKKNIFE_GROUPS)
    rates = []
    for g in groups:
        z = _esprit(np.delete(h, g, axis=1), r, c)
        rates.append(math.log(abs(z[np.argmin(np.abs(z - z0))])) / period_s)
    q = np.asarray(rates)
    return float(math.sqrt((q.size - 1) / q.size * ((q - q.mean()) ** 2).sum()))


def _no_pencil(reason: str, r: int = 0, z=None, amp=None, resid: float = math.nan) -> PencilRate:
    z = np.zeros(0, complex) if z is None else z
    amp = np.zeros(0) if amp is None else amp
    return PencilRate(math.nan, math.nan, r, z, amp, -1, resid, reason)


def pencil_growth_rate(sections, period_s: float, *, rule: GrowthRule = _DEFAULT_RULE,
                       max_order: int = PENCIL_MAX_ORDER) -> PencilRate:
    """The leading Floquet multiplier of a run by the matrix pencil (ESPRIT) on its sections; opt-in.

    The estimator, stated before it was run on the steel case (Hua and Sarkar 1990, "Matrix pencil
    method for estimating parameters of exponentially damped/undamped sinusoids in noise", IEEE
    Trans. ASSP 38(5); Roy and Kailath 1989, "ESPRIT -- estimation of signal parameters via
    rotational invariance techniques", IEEE Trans. ASSP 37(7)):

    * **input** ``sections`` (K, c), m: one vector per principal period over the gated window
      (:func:`gated_growth_rate`'s window), its c channels the cut-plane x and y at the rule's
      phases. Free motion only: the kicked-minus-unkicked difference of two runs, or the second
      differences of one run's sections (the forced response repeats each period and cancels; a
      mode ``z^k`` keeps its multiplier, its amplitude scaled by ``|z - 1|^2``).
    * **model** ``y_k = sum_i a_i z_i^k``, ``z_i`` the multipliers per principal period.
    * **Hankel and order**: the block-Hankel matrix of ``L = K // 3`` block rows (L c, K - L + 1);
      its SVD; the order r is the smallest whose rank-r remainder has an RMS entry below the
      verdict's resolution (``rule.resolution_m``, 2 nm: motion below it is not resolved),
      capped at ``max_order`` (8; a complex pair counts 2). If no order up to the cap reaches it,
      r is the cap and the remainder is reported (``residual_m``).
    * **multipliers**: ESPRIT on the r leading left singular vectors (the shift invariance between
      the first and last L - 1 block rows, least squares); **amplitudes** ``a_i`` by least squares on
      ``y`` (Vandermonde in ``z_i``); a mode's amplitude is its RMS at the window's first section.
    * **leading mode**: the largest ``|z_i|`` among the modes whose amplitude is at least
      :data:`RESOLVED_FACTOR` (10) x the resolution (20 nm); **rate** ``ln|z| / period_s``.
    * **SE**: delete-a-group jackknife over :data:`PENCIL_JACKKNIFE_GROUPS` (8) contiguous groups
      of Hankel columns (sub-windows of the data), order fixed, the eigenvalue nearest the
      leading one; ``sqrt((g - 1) / g sum (rate_j - mean)^2)``.
    * **no rate** (nan, with the reason): fewer than ``3 MIN_DIFFERENCES`` (18) sections (L < 6
      block rows), order 0 (nothing above the resolution), or no mode resolved at 20 nm.

    Parameters
    ----------
    sections : array (K, c)   free motion per principal period, m (above).
    period_s : float          principal period, s.
    rule : GrowthRule         its ``resolution_m`` (the order's floor and the leading mode's gate).
    max_order : int           cap on the order.
    """
    y = np.asarray(sections, float)
    y = y.reshape(y.shape[0], -1)
    k, c = y.shape
    if k < 3 * MIN_DIFFERENCES:
        return _no_pencil(f"only {k} sections in the window; the pencil needs {3 * MIN_DIFFERENCES}")
    h = _block_hankel(y, k // 3)
    r, resid = _pencil_order(np.linalg.svd(h, compute_uv=False), h.size, rule.resolution_m, max_order)
    if r == 0:
        return _no_pencil(f"order 0: the window's motion is below the resolution {rule.resolution_m:.0e} m", 0,
                          resid=resid)
    z = _esprit(h, r, c)
    amp = _mode_amplitudes(y, z)
    ok = np.flatnonzero(amp >= RESOLVED_FACTOR * rule.resolution_m)
    if ok.size == 0:
        return _no_pencil(f"no mode resolved: all {r} amplitudes below {RESOLVED_FACTOR:g} x "
                          f"{rule.resolution_m:.0e} m", r, z, amp, resid)
    lead = int(ok[np.argmax(np.abs(z[ok]))])
    rate = math.log(abs(z[lead])) / period_s
    se = _jackknife_se(h, r, c, complex(z[lead]), period_s)
    return PencilRate(rate, se, r, z, amp, lead, resid)


def pencil_over_window(t_s, x, period_s: float, gated: GatedRate, *, second_differences: bool) -> PencilRate | None:
    """:func:`pencil_growth_rate` over the window of a gated fit (None where it has none): the
    Poincare sections of ``x`` (n, m), m, at times ``t_s`` (n,), s, per ``period_s`` at the rule's
    phases, as (K, m P); their second differences for a single run (``second_differences``), as they
    are for the kicked-minus-unkicked difference of two runs (False)."""
    if gated.window_s is None:
        return None
    lo, hi = gated.window_s
    p = poincare_sections(t_s, x, period_s, lo, hi + 1e-9 * period_s, _DEFAULT_RULE.phases)
    y = p.reshape(p.shape[0], -1)
    if second_differences:
        y = y[2:] - 2 * y[1:-1] + y[:-2]
    return pencil_growth_rate(y, period_s)
