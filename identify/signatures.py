"""Diagnosis by named signatures: which residual signatures are present, and which effects explain them.

Split by concern: the rule, :class:`Signature` and the force detectors here; the FRF detectors in
:mod:`identify.frf_signatures`; the ranking of the candidates by the signatures they explain in
:mod:`identify.ranking`.

The residual (measured minus model) is tested for each signature of :data:`identify.effects.SIGNATURES`
that the measurement kind can show, each with a statistic against the noise estimated from the data
and a stated rule; the candidates of the library are then ranked by the number of detected
signatures they explain (``Effect.signatures``), ties broken by the residual their fit explains
(held-out error of the first selection step). The decision stays with the selection rule (held-out
error + significance, :mod:`identify.selection`): signatures only order and explain.

The rule (one for every detector)
---------------------------------
Each detector reduces the residual to a statistic whose distribution *without* the signature is
known from the noise model, and the signature is present when the statistic exceeds its one-sided
quantile at ``alpha / S`` (Bonferroni over the ``S`` detectors of the kind, and over the lines or
bands a detector scans): the family-wise rate of a false signature is at most ``alpha`` (1 %).

Forces (the time-synchronous average, ``M`` bins per revolution, noise ``s_m = sigma_m / sqrt(N)`` per bin)
    Revolution harmonic ``k`` of a periodic average is ``c_k = sum_m x_m e^{-2 pi i k m / M} / M``; with
    independent bin noise its complex noise has ``E|n_k|^2 = s^2 = sum_m s_m^2 / M^2``, so
    ``2 |c_k|^2 / s^2`` is chi-square with 2 degrees of freedom (``c_0^2 / s^2`` with 1) per axis.

    * ``mean_offset``: ``sum_axes c_0^2 / s^2 ~ chi2(2)`` of the residual.
    * ``once_per_rev``: ``sum 2 |c_k|^2 / s^2`` of the residual over the revolution harmonics below the
      tooth frequency (``k = 1 .. N - 1``; ``k = 1`` for one tooth), ``~ chi2(2 n)``. Only these: the
      model's own odd lines (the TX200 aluminium pass has ~0.9 N at ``k = 1`` against 7.7 N at
      ``k = 2``) are changed by a sensor resonance near the higher ones, which is not runout. A
      resonance below ~4 revolution harmonics changes ``k = 1`` too, and may show here.
    * ``entry_ringing``: some tooth harmonic above the first, ``k = i N``, ``i >= 2``, measured with a
      *larger* magnitude than the model: ``z = (|C_meas| - |C_model|) / (s / sqrt 2)`` above
      ``z_(alpha / (S n))`` (a resonance of the sensor amplifies the harmonics below it; the ringing after
      each entry is that amplification seen in time).
    * ``harmonic_rolloff``: some tooth harmonic measured *smaller* than the model, ``-z`` above the same
      quantile, and no amplification (a resonance also attenuates above itself: then it is ringing).

FRFs (per pose, per pair, noise ``sigma`` per line, ``E|n|^2 = sigma^2``: ``q = 2 |r|^2 / sigma^2 ~ chi2(2)``)
    The FRF pipeline's line noise (second differences) has heavy tails and band-wise errors, so a
    band is tested by the *median* of its ``q / NOISE_CAL`` against the chi2(2) median ``2 ln 2``
    (z with variance ``4 / n``, :func:`_median_z`), not by the chi-square sum; the
    :data:`EDGE_LINES` first and last lines of each pair are left out. "chi-square" below means
    this band test.
    * ``channel_ratio``, ``phase_slope`` (the measurement chain, tested first): a common real scale of
      one response channel's pairs, a common delay of every pair, each significant and homogeneous
      over the poses and runs of lines (:mod:`identify.chain_signatures`); a common factor found is
      removed before the tests below.
    * ``static_offset``: chi-square of the residual on the quasi-static lines (below a quarter of the
      lowest model mode, where a mode's dynamic amplification is under 7 %);
      when present, its mean per pose and pair (a compliance offset) is removed before the tests below.
    * ``extra_peak``: a resonance of the measured ``sum_pairs |H|`` (largest within +-5 % and 20 % above
      both ends of that window, i.e. a mode with zeta below ~5 %) farther than 10 % from every model
      mode, found within 5 % in *every* pose with a significant chi-square of its +-5 % band
      (Bonferroni over 40 bands); its frequency is reported.
    * Near a model mode (within 15 %, at most half the gap to the next mode), the peak of the
      measured ``sum_pairs |H|`` against the model's
      (parabolic refinement; a maximum at the window's edge is no peak), per mode over the poses: a
      mode with a significant band residual (largest z over the poses) whose peak moved by more
      than a quarter of its half-power bandwidth (``|df / f| > zeta / 2``) in some pose, with a peak
      found in at least 2 and half the poses, is shifted: ``uniform_shift`` when the shifts found
      have one sign and a spread below half their mean, else ``pose_shift``; a significant mode
      whose peak did not move is ``peak_height``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.stats import chi2, norm

from .effects import SIGNATURES
from .force_signals import harmonic_noise, revolution_harmonics

__all__ = ["Signature", "force_signatures", "ALPHA", "FORCE_SIGNATURES", "FRF_SIGNATURES", "NOISE_CAL", "EDGE_LINES",
           "QUASI_STATIC"]

#: Family-wise rate of a false signature (per measurement).
ALPHA = 0.01
FORCE_SIGNATURES = ("mean_offset", "once_per_rev", "entry_ringing", "harmonic_rolloff")
FRF_SIGNATURES = ("channel_ratio", "phase_slope", "static_offset", "extra_peak", "peak_height", "pose_shift",
                  "uniform_shift")
#: How far (in variance) the FRF pipeline's per-line noise estimate (second differences,
#: ``identify.frf.line_noise``) may be off in a band: on noise-only synthetic TX200 sets (4 poses,
#: seeds 3 and 5) band means of ``2|r|^2 / sigma^2`` ranged 0.22-1.35 times their expected 2. A
#: chi-square over hundreds of lines turns such an error into a false signature, so FRF band
#: statistics are divided by this factor before the test (the force noise, from the scatter of the
#: revolutions, needs none).
NOISE_CAL = 1.5
#: Lines dropped at each end of a pair's axis (its noise estimate is one-sided there).
EDGE_LINES = 2
#: Quasi-static lines: below this fraction of the lowest model mode a mode's dynamic amplification
#: ``1 / (1 - r^2)`` is under 7 %.
QUASI_STATIC = 0.25


@dataclass(frozen=True)
class Signature:
    """One detector's outcome: ``statistic`` against ``threshold`` (present when above), the rule in words."""

    name: str
    present: bool
    statistic: float
    threshold: float
    rule: str
    detail: dict = field(default_factory=dict)

    def to_json(self) -> dict:
        return {"name": self.name, "meaning": SIGNATURES[self.name], "present": self.present,
                "statistic": self.statistic, "threshold": self.threshold, "rule": self.rule, **self.detail}


# ---------------------------------------------------------------------------------------------
# forces
# ---------------------------------------------------------------------------------------------

def force_signatures(measured: np.ndarray, model: np.ndarray, noise: np.ndarray, teeth: int, *,
                     alpha: float = ALPHA, axes=(0, 1)) -> dict:
    """Force signatures of a synchronous average (module docstring).

    Parameters
    ----------
    measured, model : arrays (M, a), N
        Measured average and the model's, aligned, over one revolution (M bins).
    noise : array (M, a), N
        Standard error of the measured average per bin (``sigma / sqrt(N)``).
    teeth : int
    alpha : float
        Family-wise rate over the detectors.

    Returns
    -------
    dict name -> :class:`Signature`
    """
    ax = list(axes)
    cm = revolution_harmonics(measured[:, ax])
    cr = revolution_harmonics((measured - model)[:, ax])
    cmod = revolution_harmonics(model[:, ax])
    s2 = np.maximum(harmonic_noise(noise[:, ax]) ** 2, 1e-300)   # (a,) E|n_k|^2 per axis
    s_det = alpha / len(FORCE_SIGNATURES)
    k = np.arange(cr.shape[0])
    out = {}

    t0 = float(np.sum(cr[0].real ** 2 / s2))
    thr0 = float(chi2.isf(s_det, len(ax)))
    out["mean_offset"] = Signature("mean_offset", t0 > thr0, t0, thr0, "chi2 of the residual mean, x and y",
                                   {"residual_mean_n": cr[0].real.tolist()})

    rev = (k > 0) & (k < teeth) if teeth > 1 else (k == 1)
    t1 = float(np.sum(2 * np.abs(cr[rev]) ** 2 / s2))
    dof = int(2 * rev.sum() * len(ax))
    thr1 = float(chi2.isf(s_det, dof))
    amp1 = 2 * np.abs(cr[rev])
    out["once_per_rev"] = Signature("once_per_rev", t1 > thr1, t1, thr1,
                                    f"chi2 ({dof} dof) of the residual at the revolution harmonics below the tooth "
                                    f"frequency, k = 1..{max(teeth - 1, 1)}",
                                    {"largest_line_n": float(amp1.max()) if amp1.size else 0.0})

    tooth = np.arange(2 * teeth, cr.shape[0] - 1, teeth)      # tooth harmonics i >= 2, below Nyquist
    sd = np.sqrt(s2 / 2)
    z = (np.abs(cm[tooth]) - np.abs(cmod[tooth])) / sd         # (n, a)
    zthr = float(norm.isf(s_det / max(z.size, 1)))
    zmax = float(z.max()) if z.size else 0.0
    zmin = float(z.min()) if z.size else 0.0
    ringing = zmax > zthr
    freq = lambda idx: int(tooth[np.unravel_index(idx, z.shape)[0]] // teeth)
    out["entry_ringing"] = Signature("entry_ringing", ringing, zmax, zthr,
                                     "largest z of (|measured| - |model|) over the tooth harmonics i >= 2",
                                     {"at_tooth_harmonic": freq(int(np.argmax(z))) if z.size else None})
    out["harmonic_rolloff"] = Signature("harmonic_rolloff", (-zmin > zthr) and not ringing, -zmin, zthr,
                                        "largest z of (|model| - |measured|) over the tooth harmonics i >= 2, "
                                        "with no amplification",
                                        {"at_tooth_harmonic": freq(int(np.argmin(z))) if z.size else None})
    return out
