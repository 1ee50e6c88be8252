"""The time-domain stability verdict: a statistical statement about the growth of the
non-synchronous motion of the tool. The rule is stated here once.

Physics
-------
Linearized about its forced (periodic) response, a milling process is a linear delay system with
coefficients periodic in the principal period ``Tp`` (the tooth period for a uniform pitch where
every tooth cuts, else the revolution: :func:`principal_period`, the same as the lobes). Its
deviation from the forced response, sampled once per ``Tp``, is a sum of Floquet terms
``c_i mu_i^k`` (Insperger & Stepan 2004): the forced response is a constant of the section, and
the amplitude of the rest changes at the rate ``sigma = ln|mu_max| / Tp`` (1/s) once the least
damped term dominates. The cut is stable iff ``sigma < 0``.

Estimator (:func:`growth_rate`)
-------------------------------
1. Poincare sections (after Honeycutt & Schmitz 2016): the TCP deviation ``x(t)`` (n, m), at
   ``P`` phases of each principal period, ``p_k = x(t0 + k Tp + j Tp / P)``, k = 0..K-1.
2. Non-synchronous part: the second difference ``e_k = p_{k+1} - 2 p_k + p_{k-1}``. It removes
   the forced response exactly, and a drift of it along the pass to ``x'' Tp^2`` (a quasi-static
   drift over seconds gives < 1e-9 m at Tp = 3 ms); a Floquet term keeps its rate:
   ``e_k = (mu - 1)^2 c mu^(k-1)``.
3. Block amplitudes: the K - 2 differences are cut into ``B`` blocks (default 12) of equal
   length; ``a_b = ln sqrt(mean e^2)`` over the block (all phases and axes) at the block's mean
   time ``t_b``. Amplitudes below ``resolution_m`` are clamped to it (what the simulation resolves).
4. ``a_b = a_0 + sigma t_b + r_b``: least squares gives ``sigma_hat`` and the usual standard
   error. The residuals are correlated (beating of close modes, a sinusoid that does not fill a
   whole number of cycles per block): the SE is multiplied by ``sqrt((1 + rho) / (1 - rho))``
   (AR(1) correction, ``rho`` the lag-1 autocorrelation of the residuals, taken in [0, 0.9]).
   The blocking itself is an approximation: the same fit with 3/4 and 3/2 as many blocks gives
   other slopes, and the largest difference is added to the SE in quadrature. The confidence
   interval is ``sigma_hat +- t SE`` with the Student quantile ``t_{0.975, B - 2}`` (95 %,
   two-sided; 2.23 for B = 12).

Saturated chatter (:func:`regenerative_ratio`, :meth:`ChipScale.loss_fraction`)
------------------------------------------------------------------------------
Chatter that has grown until a tooth leaves the cut is bounded: its rate is ~0 and the linear test
cannot call it. Tooth j's chip is ``h_j(phi) = h_j0 sin(phi) + n(phi) . (y(t) - y(t - tau_j))``:
the static chip (``h_j0`` the tooth's chip at 90 deg, :func:`cases.milling.regeneration`) plus
the regenerative variation of the non-synchronous motion ``y`` over the tooth's delay ``tau_j``.
Its amplitude ``A_j = sqrt(2) rms|y(t) - y(t - tau_j)|`` over the last block (``y = x`` minus its
synchronous average over that block; ``|.|`` the vector norm bounds the projection
``n . Delta``; ``sqrt 2`` the peak of a sinusoid of that RMS) is compared with the chip:

* the regenerative ratio ``R = max_j A_j / hbar_j``, ``hbar_j`` the mean static chip over the
  engaged arc ``[phi_st, phi_ex]`` (reported);
* the chip-loss fraction ``L = max_j int_{h_j0 sin phi < A_j} sin phi dphi / int_arc sin phi dphi``:
  the share of the tooth's chip-weighted engagement where, at the peaks of the variation, the
  chip is negative and the tooth out of the cut. The regenerative force, hence the linear
  model's gain, is reduced by up to this share. A linear-theory instability saturates once the
  loss matches its excess gain (e.g. about 20 % at 1.25 times the limit), whereas a cut in the
  linear regime loses ~0 (down-milling's chip vanishes at the exit, so some loss is always
  there at the end of the arc: ``L`` weighs it by the chip it carries).
  ``L >= 0.05`` is the nonlinear regime: the cut's gain differs from the linear one by 5 % or
  more, the resolution at which the lobes and the time domain are compared here.

The rule (:func:`decide`)
-------------------------
* **undetermined** when the window is shorter than ``3 B + 2`` principal periods, or than the
  beat period ``1 / min |f_i - f_j|`` of the structure's two closest modes that ring for three
  cycles or more (:func:`beat_period_s`): two decaying modes beat, and over less than one beat
  their summed envelope can rise (or fall) smoothly, so the residuals of the fit cannot reveal
  that the line is the wrong model. (The TX200's 25.2 and 27.7 Hz modes: 0.39 s.)
* ``L >= 0.05`` (teeth leave the cut), and still >= 0.05 one window later if the amplitude
  changed at the upper confidence bound of ``sigma`` (growing, bounded, or decaying too slowly to
  leave the nonlinear regime within the window's own length): **unstable**, saturated chatter
  (steel; the backlash period-2 cycle). Saturated chatter drifts: along a pass its amplitude can
  shrink by a fraction of a percent per second, a "decay" that does not make the cut stable.
* ``L >= 0.05`` but below it one window later: **undetermined** (a large transient leaving the
  nonlinear regime).
* ``L < 0.05``: **stable** when the non-synchronous motion of the second half of the window is
  below ``resolution_m`` throughout (nothing is left to grow) or when the whole 95 % interval is
  below 0, **unstable** when it is above 0, **undetermined** otherwise.

An undetermined verdict states the window that would decide: the SE falls at least as
``T_window^-1`` (a deterministic residual such as beating; white noise gives ``T^-3/2``), so
``|sigma_hat| = t SE`` is reached at ``T (t SE / |sigma_hat|)`` (a conservative, i.e. long, estimate).

Nothing here is tuned on the robot: the 95 % level is conventional, ``B = 12`` gives 10 degrees
of freedom, ``L = 0.05`` is the 5 % comparison resolution above, and
``resolution_m`` = 2 nm is the accuracy of the simulated chip (tests/test_workpiece.py: 2 nm
against the exact trochoid; the removal chords' sagitta is <= 1 nm): near a stability limit the
cutting stiffness is of the order of the structure's, so a chip error of 2 nm moves the tool by
about as much, and a flat floor of ~0.7 nm is what a damped steel run settles on. The
synthetic tests (tests/test_verdict.py) check coverage and decisiveness on signals of known rate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from robolobes.cases.milling import engagement_rad, principal_period, regeneration
from robolobes.core.verdict import Verdict

__all__ = ["VERDICT_KEYS", "LOSS_LIMIT", "GrowthRule", "GrowthEstimate", "ChipScale", "TimeDomainVerdict",
           "chip_scale", "poincare_sections", "growth_rate", "regenerative_amplitudes", "regenerative_ratio",
           "beat_period_s", "decide", "verdict_summary", "floquet_rate_per_s", "floquet_comparison"]

#: The summary keys of the verdict (:func:`verdict_summary`); a runout companion run copies them.
VERDICT_KEYS = ("verdict", "stable", "verdict_reason", "growth_rate_per_s", "growth_rate_se_per_s",
                "growth_rate_ci_per_s", "regenerative_ratio", "chip_loss_fraction", "duration_to_decide_s",
                "verdict_section", "stability")


@dataclass(frozen=True)
class GrowthRule:
    """The constants of the rule (module docstring); defaults are the rule.

    phases : int         Poincare sections per principal period, >= 1.
    blocks : int         Blocks of the log-linear fit, >= 6.
    confidence : float   Two-sided level of the interval on the rate, in (0.5, 1).
    resolution_m : float Smallest meaningful non-synchronous amplitude, m (> 0).
    """

    phases: int = 8
    blocks: int = 12
    confidence: float = 0.95
    resolution_m: float = 2e-9

    def __post_init__(self):
        from robolobes.core.errors import BadInput
        if isinstance(self.phases, bool) or not isinstance(self.phases, (int, np.integer)) or self.phases < 1:
            raise BadInput(f"phases must be an integer >= 1, got {self.phases!r}")
        if isinstance(self.blocks, bool) or not isinstance(self.blocks, (int, np.integer)) or self.blocks < 6:
            raise BadInput(f"blocks must be an integer >= 6, got {self.blocks!r}")
        if not 0.5 < float(self.confidence) < 1:
            raise BadInput(f"confidence must be in (0.5, 1), got {self.confidence!r}")
        if not (math.isfinite(self.resolution_m) and self.resolution_m > 0):
            raise BadInput(f"resolution_m must be a finite length > 0 m, got {self.resolution_m!r}")

    @property
    def min_periods(self) -> int:
        """Fewest principal periods a window must hold: 3 second differences per block."""
        return 3 * self.blocks + 2


@dataclass(frozen=True)
class GrowthEstimate:
    """Growth rate of the non-synchronous motion (module docstring, estimator).

    rate_per_s, se_per_s : float     sigma_hat and its AR(1)-corrected standard error, 1/s.
    ci_per_s : (float, float)        the two-sided confidence interval, 1/s.
    dof : float                      effective degrees of freedom of the t quantile.
    rho : float                      lag-1 autocorrelation of the fit residuals used (0..0.9).
    block_t_s : array (B,)           block times, s.
    block_log_amp : array (B,)       ln of the block RMS amplitude (ln m).
    window_s : (float, float)        the periods used.
    n_periods : int
    below_resolution : bool          second half of the blocks all at or below resolution_m.
    """

    rate_per_s: float
    se_per_s: float
    ci_per_s: tuple[float, float]
    dof: float
    rho: float
    block_t_s: np.ndarray
    block_log_amp: np.ndarray
    window_s: tuple[float, float]
    n_periods: int
    below_resolution: bool
    t_quantile: float

    def duration_to_decide_s(self) -> float:
        """Window length at which ``|rate| = t SE`` if the estimate stays (SE ~ 1/T): s, inf at 0."""
        if self.rate_per_s == 0 or not math.isfinite(self.se_per_s):
            return math.inf
        length = self.window_s[1] - self.window_s[0]
        return length * max(1.0, self.t_quantile * self.se_per_s / abs(self.rate_per_s))


@dataclass(frozen=True)
class ChipScale:
    """What the saturation criterion compares with, per cutting tooth.

    delays_s : tuple of float        regenerative delay of each cutting tooth, s.
    max_chip_m : tuple of float      its static chip at phi = 90 deg, ``h_j0``, m (> 0).
    arc_rad : (float, float)         engaged arc ``(phi_st, phi_ex)``, rad, within [0, pi].
    """

    delays_s: tuple[float, ...]
    max_chip_m: tuple[float, ...]
    arc_rad: tuple[float, float] = (0.0, math.pi)

    def _sin(self) -> np.ndarray:
        phi = np.linspace(self.arc_rad[0], self.arc_rad[1], 4001)
        return np.sin(phi)

    @property
    def mean_chip_m(self) -> tuple[float, ...]:
        """Static chip averaged over the arc, ``h_j0 (cos phi_st - cos phi_ex) / (phi_ex - phi_st)``, m."""
        st, ex = self.arc_rad
        return tuple(h * (math.cos(st) - math.cos(ex)) / (ex - st) for h in self.max_chip_m)

    def loss_fraction(self, amplitude_m: float, tooth: int) -> float:
        """Share of the chip-weighted arc where ``h_j0 sin phi < amplitude`` (trapezoid on 4001 points)."""
        w = self._sin()
        lost = np.where(self.max_chip_m[tooth] * w < amplitude_m, w, 0.0)
        return float(np.trapezoid(lost) / np.trapezoid(w))


#: Chip-loss fraction from which the cut is in the nonlinear regime (module docstring).
LOSS_LIMIT = 0.05


def chip_scale(tool, cut) -> ChipScale:
    """Delays, static chips and arc of the cutting teeth (module docstring, saturated chatter)."""
    reg = [r for r in regeneration(tool, cut) if r.cuts and r.chip_m > 0]
    return ChipScale(delays_s=tuple(r.delay_rad / cut.omega_rad_s for r in reg),
                     max_chip_m=tuple(r.chip_m for r in reg), arc_rad=engagement_rad(tool, cut))


def _as_series(t_s, x):
    from robolobes.core.errors import BadInput
    t = np.asarray(t_s, dtype=float)
    xx = np.asarray(x, dtype=float)
    if xx.ndim == 1:
        xx = xx[:, None]
    if t.ndim != 1 or xx.ndim != 2 or xx.shape[0] != t.size or t.size < 4:
        raise BadInput(f"t_s must be (n,) and x (n,) or (n, m) with n >= 4; got {t.shape} and {np.shape(x)}")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(xx))):
        raise BadInput("t_s and x must be finite (found NaN or inf)")
    dt = np.diff(t)
    if np.any(dt <= 0) or np.ptp(dt) > 1e-6 * dt.mean():
        raise BadInput("t_s must be uniformly spaced and increasing")
    return t, xx


def poincare_sections(t_s, x, period_s: float, t_start_s: float, t_end_s: float, phases: int) -> np.ndarray:
    """Samples ``x(t_start + k Tp + j Tp / P)`` for the whole periods in the window, (K, P, m).

    On the sample grid when ``Tp / P`` is a whole number of steps (the integrator's grid: exact),
    else by cubic-spline interpolation.
    """
    from robolobes.core.errors import BadInput
    t, xx = _as_series(t_s, x)
    if not (math.isfinite(period_s) and period_s > 0):
        raise BadInput(f"period_s must be a finite time > 0 s, got {period_s!r}")
    lo, hi = max(float(t_start_s), t[0]), min(float(t_end_s), t[-1])
    n_per = int(math.floor((hi - lo) / period_s + 1e-9))
    if n_per < 1:
        return np.zeros((0, phases, xx.shape[1]))
    dt = (t[-1] - t[0]) / (t.size - 1)
    steps = period_s / phases / dt
    i0 = int(math.ceil((lo - t[0]) / dt - 1e-6))
    if abs(steps - round(steps)) < 1e-6 and round(steps) >= 1:
        s = int(round(steps))
        n_per = min(n_per, (t.size - 1 - i0) // (s * phases))
        idx = i0 + s * (np.arange(n_per)[:, None] * phases + np.arange(phases)[None, :])
        return xx[idx]
    from scipy.interpolate import CubicSpline
    sel = slice(max(0, i0 - 4), None)
    tk = lo + period_s * (np.arange(n_per)[:, None] + np.arange(phases)[None, :] / phases)
    return CubicSpline(t[sel], xx[sel], axis=0)(tk.ravel()).reshape(n_per, phases, -1)


def _t_quantile(confidence: float, dof: float) -> float:
    from scipy.stats import t as student
    return float(student.ppf(0.5 + confidence / 2, max(dof, 1.0)))


def _block_fit(e: np.ndarray, tk: np.ndarray, nb: int, floor: float):
    """Log-linear fit of the block RMS of ``e`` (K', d) at times ``tk`` (K',): slope, AR(1)-corrected
    SE, dof, rho, block times (nb,), block log-amplitudes (nb,), second half below ``floor``."""
    length = e.shape[0] // nb
    start = e.shape[0] - nb * length  # drop the remainder at the start (keep the latest motion)
    ms = (e[start:] ** 2).reshape(nb, length, -1).mean(axis=(1, 2))
    tb = tk[start:].reshape(nb, length).mean(1)
    a = 0.5 * np.log(np.maximum(ms, floor**2))
    below = bool(np.all(ms[nb // 2:] <= floor**2))
    tc = tb - tb.mean()
    sxx = float((tc**2).sum())
    slope = float((tc * (a - a.mean())).sum() / sxx)
    r = a - a.mean() - slope * tc
    s2 = float((r**2).sum()) / (nb - 2)
    rho = float(np.clip((r[1:] * r[:-1]).sum() / (r**2).sum(), 0.0, 0.9)) if s2 > 0 else 0.0
    infl = (1 + rho) / (1 - rho)
    return slope, math.sqrt(s2 / sxx * infl), nb - 2, rho, tb, a, below


def growth_rate(t_s, x, period_s: float, *, t_start_s: float, t_end_s: float,
                rule: GrowthRule = GrowthRule(), min_periods: int | None = None) -> GrowthEstimate:
    """Growth rate of the non-synchronous motion of ``x`` over ``[t_start_s, t_end_s]``.

    Parameters
    ----------
    t_s : array (n,)                 uniform times, s.
    x : array (n,) or (n, m)         TCP deviation (cut frame), m.
    period_s : float                 principal period Tp, s.
    t_start_s, t_end_s : float       window, s; it must hold ``rule.min_periods`` periods.
    min_periods : int, optional      fewer periods accepted (at least ``rule.blocks + 2``: one
                                     difference per block), for :mod:`timedomain.rate`.

    Returns
    -------
    GrowthEstimate (module docstring). Raises BadInput for a window too short.
    """
    from robolobes.core.errors import BadInput
    p = poincare_sections(t_s, x, period_s, t_start_s, t_end_s, rule.phases)
    k = p.shape[0]
    need = rule.min_periods if min_periods is None else max(int(min_periods), rule.blocks + 2)
    if k < need:
        raise BadInput(f"the window holds {k} principal periods; the growth rate needs {need}: "
                       f"lengthen it to >= {need * period_s:.6g} s")
    e = (p[2:] - 2 * p[1:-1] + p[:-2]).reshape(k - 2, -1)
    tk = float(t_start_s) + period_s * np.arange(1, k - 1)
    slope, se, dof, rho, tb, a, below = _block_fit(e, tk, rule.blocks, rule.resolution_m)
    # blocking error: the same fit with 3/4 and 3/2 as many blocks (a sinusoid that does not fill a
    # whole number of cycles per block leaves a deterministic residual the AR(1) SE can miss)
    alt = [_block_fit(e, tk, nb, rule.resolution_m)[0] for nb in (rule.blocks * 3 // 4, rule.blocks * 3 // 2)
           if 3 <= nb <= e.shape[0]]
    se = math.hypot(se, max((abs(s_ - slope) for s_ in alt), default=0.0))
    q = _t_quantile(rule.confidence, dof)
    return GrowthEstimate(rate_per_s=slope, se_per_s=se, ci_per_s=(slope - q * se, slope + q * se), dof=dof, rho=rho,
                          block_t_s=tb, block_log_amp=a, window_s=(float(t_start_s), float(tk[-1]) + period_s),
                          n_periods=k, below_resolution=below, t_quantile=q)


def regenerative_amplitudes(t_s, x, period_s: float, chip: ChipScale, *, t_start_s: float,
                            t_end_s: float) -> np.ndarray:
    """``A_j = sqrt(2) rms|y(t) - y(t - tau_j)|`` per cutting tooth over the window, m, shape (teeth,)
    (module docstring); ``y`` is ``x`` minus its average over the window's whole periods as a
    function of the phase in ``period_s``."""
    t, xx = _as_series(t_s, x)
    dt = (t[-1] - t[0]) / (t.size - 1)
    sel = np.flatnonzero((t >= t_start_s - 1e-12) & (t <= t_end_s + 1e-12))
    n_per = int((t[sel[-1]] - t[sel[0]]) / period_s + 1e-9)
    steps = period_s / dt
    xs = xx[sel]
    if abs(steps - round(steps)) < 1e-6 and n_per >= 1:
        s = int(round(steps))
        w = xs[:n_per * s].reshape(n_per, s, -1)
        y = (w - w.mean(0)).reshape(n_per * s, -1)
    else:  # off-grid period: remove the synchronous average by phase bins of one step
        ph = np.floor(((t[sel] - t[sel[0]]) % period_s) / dt).astype(int)
        avg = np.zeros((ph.max() + 1, xs.shape[1]))
        np.add.at(avg, ph, xs)
        avg /= np.maximum(np.bincount(ph), 1)[:, None]
        y = xs - avg[ph]
    amp = np.zeros(len(chip.delays_s))
    for j, tau in enumerate(chip.delays_s):
        lag = int(round(tau / dt))
        if 1 <= lag < y.shape[0]:
            d = np.linalg.norm(y[lag:] - y[:-lag], axis=1)
            amp[j] = math.sqrt(2.0) * float(np.sqrt((d**2).mean()))
    return amp


def regenerative_ratio(t_s, x, period_s: float, chip: ChipScale, *, t_start_s: float, t_end_s: float) -> float:
    """``R = max_j A_j / hbar_j`` (module docstring); inf when no tooth cuts."""
    if not chip.delays_s:
        return math.inf
    amp = regenerative_amplitudes(t_s, x, period_s, chip, t_start_s=t_start_s, t_end_s=t_end_s)
    return float(max(a / h for a, h in zip(amp, chip.mean_chip_m)))


@dataclass(frozen=True)
class TimeDomainVerdict:
    """The decision and what it rests on.

    verdict : Verdict                     stable / unstable / undetermined, with the reason.
    growth : GrowthEstimate or None       None when the window is too short for a rate.
    regenerative_ratio : float            R over the last block (module docstring).
    chip_loss_fraction : float            L over the last block (module docstring).
    duration_to_decide_s : float or None  window that would decide an undetermined verdict, s.
    """

    verdict: Verdict
    growth: GrowthEstimate | None
    regenerative_ratio: float
    chip_loss_fraction: float
    duration_to_decide_s: float | None = None

    def to_json(self) -> dict:
        """Summary keys: verdict, stable, verdict_reason, growth_rate_per_s, growth_rate_se_per_s,
        growth_rate_ci_per_s, regenerative_ratio, chip_loss_fraction, duration_to_decide_s."""
        g = self.growth
        out = self.verdict.to_json()
        out.update(growth_rate_per_s=None if g is None else g.rate_per_s,
                   growth_rate_se_per_s=None if g is None else g.se_per_s,
                   growth_rate_ci_per_s=None if g is None else list(g.ci_per_s),
                   regenerative_ratio=self.regenerative_ratio, chip_loss_fraction=self.chip_loss_fraction,
                   duration_to_decide_s=self.duration_to_decide_s)
        return out


def decide(t_s, x, period_s: float, chip: ChipScale, *, t_start_s: float, t_end_s: float,
           rule: GrowthRule = GrowthRule(), beat_period_s: float = 0.0) -> TimeDomainVerdict:
    """The rule of the module docstring on the TCP deviation ``x`` (n, m), m, over the window.

    A window shorter than ``rule.min_periods`` principal periods, or than ``beat_period_s`` (the
    structure's, :func:`beat_period_s`), gives ``undetermined`` with the length that is needed.
    """
    t, xx = _as_series(t_s, x)
    lo, hi = float(t_start_s), min(float(t_end_s), float(t[-1]))
    n_per = int((hi - lo) / period_s + 1e-9)
    need = max(rule.min_periods * period_s, float(beat_period_s))
    if hi - lo < need - 1e-12 or n_per < rule.min_periods:
        why = (f"{n_per} principal periods, the growth rate needs {rule.min_periods}" if n_per < rule.min_periods else
               f"shorter than the beat period {beat_period_s:.3f} s of the structure's two closest ringing modes "
               f"(a ringing structure can look like growth over less)")
        v = Verdict("undetermined", f"the window {lo:.3f}-{hi:.3f} s is too short ({why}): simulate to at least "
                                    f"{lo + need:.3f} s")
        return TimeDomainVerdict(v, None, math.nan, math.nan, need)
    g = growth_rate(t, xx, period_s, t_start_s=lo, t_end_s=hi, rule=rule)
    last = (g.window_s[1] - g.window_s[0]) / rule.blocks
    tail = max(lo, hi - max(last, 2 * period_s))
    ratio = regenerative_ratio(t, xx, period_s, chip, t_start_s=tail, t_end_s=hi)
    amp = regenerative_amplitudes(t, xx, period_s, chip, t_start_s=tail, t_end_s=hi)
    loss = max((chip.loss_fraction(a, j) for j, a in enumerate(amp)), default=1.0)
    out = lambda status, why, need=None: TimeDomainVerdict(Verdict(status, why), g, ratio, loss, need)
    lo_ci, hi_ci = g.ci_per_s
    pct = f"{100 * rule.confidence:g} %"
    rate = f"growth rate {g.rate_per_s:+.4g} 1/s ({pct} interval {lo_ci:+.3g} to {hi_ci:+.3g})"
    lost = f"teeth leave the cut over {100 * loss:.0f} % of the chip-weighted arc"
    if loss >= LOSS_LIMIT:
        # still in the nonlinear regime one window later at the slowest decay the interval allows?
        later = math.exp(hi_ci * (g.window_s[1] - g.window_s[0]))
        loss_later = max(chip.loss_fraction(a * later, j) for j, a in enumerate(amp))
        if loss_later >= LOSS_LIMIT:
            return out("unstable", f"saturated chatter: {lost} (regenerative variation {ratio:.2f} times the mean "
                                   f"chip), and at the {rate} still {100 * loss_later:.0f} % one window later")
        return out("undetermined", f"{lost} (nonlinear regime), but the {rate} takes it below "
                                   f"{100 * LOSS_LIMIT:g} % within one window", g.duration_to_decide_s())
    if g.below_resolution and lo_ci <= 0:
        return out("stable", f"the non-synchronous motion of the second half of the window is below the resolution "
                             f"{rule.resolution_m:.1e} m")
    if hi_ci < 0:
        return out("stable", f"the non-synchronous motion decays: {rate}")
    if lo_ci > 0:
        return out("unstable", f"the non-synchronous motion grows: {rate}")
    need = g.duration_to_decide_s()
    when = ("no window decides a rate of zero" if not math.isfinite(need)
            else f"a window of about {need:.2g} s would decide")
    return out("undetermined", f"the {rate} contains 0: {when}", need)


def floquet_rate_per_s(spectral_radius: float, principal_period_s: float) -> float:
    """``ln|mu| / Tp``: the growth rate a time-domain run should measure (1/s), from the SDM's
    spectral radius per principal period (Insperger & Stepan 2004)."""
    return math.log(spectral_radius) / principal_period_s


def beat_period_s(poles_rad_s) -> float:
    """Beat period ``1 / min |f_i - f_j|`` (s) of the two closest modes that ring for at least
    three cycles (damping ratio <= 1 / (6 pi) = 0.053: amplitude >= 1/e after three cycles), from
    the structure's poles (rad/s, complex; conjugates counted once); 0 with fewer than two distinct
    frequencies (a repeated pole, within 1e-9 relative, is one mode and does not beat).

    Two decaying modes of close frequencies beat: over less than a beat their summed envelope can
    rise while both decay, and the fit's residuals cannot show it (module docstring).
    """
    p = np.asarray(poles_rad_s, dtype=complex).ravel()
    p = p[np.imag(p) > 0]
    zeta = -np.real(p) / np.abs(p)
    f = np.sort(np.abs(p[zeta <= 1 / (6 * math.pi)]) / (2 * math.pi))
    # a repeated pole (e.g. a symmetric tool in x and y) is one mode whose directions combine: no beat
    df = np.diff(f)
    df = df[df > 1e-9 * f[1:]] if f.size >= 2 else df
    if df.size == 0:
        return 0.0
    return 1.0 / float(np.min(df))


def verdict_summary(t_s, deviation_m, tool, cut, window_s: tuple[float, float], *,
                    rule: GrowthRule = GrowthRule(), poles_rad_s=()) -> dict:
    """The verdict block of a time-domain summary (the policy, in one place).

    Parameters
    ----------
    t_s : array (n,)                 uniform times, s.
    deviation_m : array (n, 2)       TCP deviation from the commanded path in the cut plane, m.
    tool, cut : cases.milling.Tool, Cut
    window_s : (float, float)        steady window (full engagement), s.
    poles_rad_s : array (k,), complex   the structure's poles (for :func:`beat_period_s`).

    Returns
    -------
    dict with ``verdict``, ``stable``, ``verdict_reason``, ``growth_rate_per_s``,
    ``growth_rate_se_per_s``, ``growth_rate_ci_per_s``, ``regenerative_ratio``, ``chip_loss_fraction``,
    ``duration_to_decide_s``, ``verdict_section`` and ``stability`` (the rule's numbers).
    """
    tp, name = principal_period(tool, cut)
    t = np.asarray(t_s, dtype=float)
    t0, t1 = float(window_s[0]), min(float(window_s[1]), float(t[-1]))
    out: dict[str, Any] = {"verdict_section": f"once per {name} period ({tp * 1e3:.3f} ms)"}
    if t1 <= t0:
        v = TimeDomainVerdict(Verdict("undetermined", f"the run ends at {t[-1]:.3f} s, before full engagement at "
                                                      f"{t0:.3f} s: simulate longer"), None, math.nan, math.nan,
                              t0 - float(t[0]) + rule.min_periods * tp)
    else:
        v = decide(t, deviation_m, tp, chip_scale(tool, cut), t_start_s=t0, t_end_s=t1, rule=rule,
                   beat_period_s=beat_period_s(poles_rad_s))
    out.update(v.to_json())
    g = v.growth
    out["stability"] = {"rule": "growth rate of the non-synchronous motion (timedomain.verdict)",
                        "confidence": rule.confidence, "window_s": [t0, max(t0, t1)],
                        "n_periods": None if g is None else g.n_periods,
                        "dof": None if g is None else g.dof, "rho": None if g is None else g.rho}
    return out


def floquet_comparison(growth: GrowthEstimate, spectral_radius: float, principal_period_s: float) -> dict:
    """The measured rate against the SDM's ``ln|mu| / Tp``: both (1/s), their difference and the
    difference in units of the measured SE."""
    ref = floquet_rate_per_s(spectral_radius, principal_period_s)
    diff = growth.rate_per_s - ref
    return {"floquet_rate_per_s": ref, "growth_rate_per_s": growth.rate_per_s, "difference_per_s": diff,
            "difference_in_se": diff / growth.se_per_s if growth.se_per_s > 0 else math.inf}
