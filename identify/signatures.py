"""Diagnosis by named signatures: which residual signatures are present, and which effects explain them.

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

import math
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.stats import chi2, norm

from .effects import SIGNATURES
from .force_signals import harmonic_noise, revolution_harmonics

__all__ = ["Signature", "PoseResidual", "force_signatures", "frf_signatures", "frf_pose_residual", "rank_candidates", "annotate", "ALPHA",
           "FORCE_SIGNATURES", "FRF_SIGNATURES", "diagnosis_markdown"]

#: Family-wise rate of a false signature (per measurement).
ALPHA = 0.01
FORCE_SIGNATURES = ("mean_offset", "once_per_rev", "entry_ringing", "harmonic_rolloff")
FRF_SIGNATURES = ("static_offset", "extra_peak", "peak_height", "pose_shift", "uniform_shift")
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


# ---------------------------------------------------------------------------------------------
# FRFs
# ---------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class PoseResidual:
    """What the FRF detectors need of one pose.

    f_hz : (L,) line frequencies;  measured, model : (P, L) complex receptances, m/N, per pair;
    sigma : (P, L) noise per line (``E|n|^2 = sigma^2``), m/N;  modes : ((freq_hz, zeta), ...) of the model.
    """

    name: str
    f_hz: np.ndarray
    measured: np.ndarray
    model: np.ndarray
    sigma: np.ndarray
    modes: tuple


def frf_pose_residual(pd, model_h: np.ndarray, modes) -> PoseResidual:
    """A :class:`PoseResidual` from an FRF pipeline's pose (``identify.frf.PoseData``: flattened lines
    ``H``, ``sigma``, ``pair``, ``index`` into ``omega``), the model on the same lines (N,) and the
    model's modes ``(freq_hz array, zeta array)``. Pairs on other lines than the first pair's are left out."""
    pairs = np.unique(pd.pair)
    idx0 = pd.index[pd.pair == pairs[0]]
    keep = [k for k in pairs if np.array_equal(pd.index[pd.pair == k], idx0)]
    f = pd.omega[idx0] / (2 * math.pi)
    inner = slice(EDGE_LINES, len(f) - EDGE_LINES) if len(f) > 4 * EDGE_LINES else slice(None)
    f = f[inner]
    rows = lambda x: np.array([x[pd.pair == k][inner] for k in keep])
    fr, zr = modes
    in_band = tuple((float(a), float(b)) for a, b in zip(fr, zr) if f[0] < a < f[-1])
    return PoseResidual(name=pd.name, f_hz=f, measured=rows(pd.H), model=rows(model_h), sigma=rows(pd.sigma),
                        modes=in_band)


def _band_q(pr: PoseResidual, mask: np.ndarray) -> np.ndarray:
    """``2 |r|^2 / sigma^2 / NOISE_CAL`` on the band's lines, flattened."""
    r = pr.measured[:, mask] - pr.model[:, mask]
    return (2 * np.abs(r) ** 2 / pr.sigma[:, mask] ** 2).ravel() / NOISE_CAL


def _median_z(q: np.ndarray) -> float:
    """z of the median of ``q`` against the median of chi2(2), ``2 ln 2``: the sample median of n
    chi2(2) values is asymptotically normal with variance ``1 / (4 n f(m)^2) = 4 / n`` (density
    ``f(m) = exp(-m/2)/2 = 1/4`` at the median). Robust to the few lines whose noise estimate is far off."""
    if q.size == 0:
        return -math.inf
    return float((np.median(q) - 2 * math.log(2)) / math.sqrt(4.0 / q.size))


def _band_z(pr: PoseResidual, mask: np.ndarray) -> float:
    return _median_z(_band_q(pr, mask))


def _peak_hz(f: np.ndarray, mag: np.ndarray) -> float | None:
    """Frequency of the largest ``mag`` inside the window (parabola in log magnitude), None when the
    largest value is at the window's edge (no peak inside)."""
    i = int(np.argmax(mag))
    if not 0 < i < len(f) - 1:
        return None
    y0, y1, y2 = np.log(mag[i - 1:i + 2])
    den = y0 - 2 * y1 + y2
    off = float(np.clip(0.5 * (y0 - y2) / den, -1, 1)) if den < 0 else 0.0
    return float(f[i] + off * (f[i + 1] - f[i - 1]) / 2)


def _without_offset(pr: PoseResidual, f_low: float | None) -> PoseResidual:
    """The pose with the constant compliance offset (mean residual per pair on the static lines) removed."""
    mask = pr.f_hz < QUASI_STATIC * f_low if f_low else pr.f_hz <= np.quantile(pr.f_hz, 0.1)
    off = np.mean(pr.measured[:, mask] - pr.model[:, mask], axis=1, keepdims=True)
    return replace(pr, measured=pr.measured - off)


def _extra_peaks(pr: PoseResidual) -> list:
    """(frequency, band z) of the measured resonances of a pose farther than 10 % from every model mode."""
    mag = np.sum(np.abs(pr.measured), axis=0)
    f = pr.f_hz
    out = []
    for i in range(1, len(f) - 1):
        if pr.modes and min(abs(f[i] / f0 - 1) for f0, _ in pr.modes) <= 0.10:
            continue
        win = np.abs(f / f[i] - 1) < 0.05
        idx = np.flatnonzero(win)
        if idx[0] == 0 or idx[-1] == len(f) - 1 or mag[i] < mag[win].max():
            continue
        if mag[i] > 1.2 * max(mag[idx[0]], mag[idx[-1]]):
            out.append((float(f[i]), _band_z(pr, win)))
    return out


def frf_signatures(poses: list[PoseResidual], *, alpha: float = ALPHA, n_bands: int = 40) -> dict:
    """FRF signatures over the poses (module docstring). Returns dict name -> :class:`Signature`."""
    s_det = alpha / len(FRF_SIGNATURES)
    out = {}
    # static compliance: below QUASI_STATIC (a quarter) of the lowest model mode
    f_low = min(f for pr in poses for f, _ in pr.modes) if any(pr.modes for pr in poses) else None
    low = [pr.f_hz < QUASI_STATIC * f_low if f_low else pr.f_hz <= np.quantile(pr.f_hz, 0.1) for pr in poses]
    q = np.concatenate([_band_q(pr, m) for pr, m in zip(poses, low)])
    zs, thr = _median_z(q), float(norm.isf(s_det))
    ratio = [float(np.median(np.abs(pr.measured[:, m]) / np.abs(pr.model[:, m]))) for pr, m in zip(poses, low)
             if m.any()]
    out["static_offset"] = Signature("static_offset", zs > thr, zs, thr,
                                     f"median test (z, {q.size} lines) of the residual below {QUASI_STATIC} x the "
                                     "lowest model mode", {"measured_over_model": ratio})
    if out["static_offset"].present:   # the other detectors look at what a compliance offset leaves
        poses = [_without_offset(pr, f_low) for pr in poses]

    # extra peak: a resonance of the measurement far from every model mode, in every pose
    zthr = float(norm.isf(s_det / n_bands))
    peaks = [_extra_peaks(pr) for pr in poses]
    best = (-math.inf, None)
    for f, _ in peaks[0]:
        zs = [max((z for g, z in pk if abs(g / f - 1) < 0.05), default=-math.inf) for pk in peaks]
        if min(zs) > best[0]:
            best = (min(zs), f)
    out["extra_peak"] = Signature("extra_peak", best[0] > zthr, float(best[0]), zthr,
                                  "a resonance of the measured magnitude (largest within +-5 %, 20 % above both "
                                  "ends) farther than 10 % from every model mode, in every pose; statistic: the "
                                  "smallest over the poses of its +-5 % band's chi2 (as z)", {"peak_hz": best[1]})

    # near the model modes: shift or height, per mode over the poses
    n_modes = max(len(pr.modes) for pr in poses) or 1
    zthr_m = float(norm.isf(s_det / (n_modes * len(poses))))
    per_mode = {}                               # j -> list of (shift or None, band z, zeta)
    for pr in poses:
        for j, (f0, zeta) in enumerate(pr.modes):
            others = [abs(f / f0 - 1) for i, (f, _) in enumerate(pr.modes) if i != j]
            mask = np.abs(pr.f_hz / f0 - 1) < min([0.15] + [0.5 * g for g in others])
            if mask.sum() < 3:
                continue
            z = _band_z(pr, mask)
            fm = _peak_hz(pr.f_hz[mask], np.sum(np.abs(pr.measured[:, mask]), axis=0))
            fo = _peak_hz(pr.f_hz[mask], np.sum(np.abs(pr.model[:, mask]), axis=0))
            per_mode.setdefault(j, []).append((fm / fo - 1 if fm is not None and fo is not None else None, z, zeta))
    kinds, shift_z, height_z, found_all = {}, -math.inf, -math.inf, {}
    for j, rows in per_mode.items():
        zmax = max(z for _, z, _ in rows)
        found = np.array([x for x, _, _ in rows if x is not None])
        found_all[j] = found.tolist()
        moved = found.size >= max(2, len(poses) / 2) and np.max(np.abs(found)) > max(zt for _, _, zt in rows) / 2
        if zmax <= zthr_m:
            continue
        if moved:
            shift_z = max(shift_z, zmax)
            kinds[j] = bool((np.all(found > 0) or np.all(found < 0)) and np.std(found) < 0.5 * abs(np.mean(found)))
        else:
            height_z = max(height_z, zmax)
    detail = {"shift_per_mode": {f"mode_{j + 1}": v for j, v in found_all.items()},
              "uniform_modes": [f"mode_{j + 1}" for j, u in kinds.items() if u],
              "pose_dependent_modes": [f"mode_{j + 1}" for j, u in kinds.items() if not u]}
    out["uniform_shift"] = Signature("uniform_shift", any(kinds.values()), shift_z, zthr_m,
                                     "a mode with a significant band residual whose peak moved by > zeta/2, with one "
                                     "sign and a spread < half the mean over the poses where its peak was found "
                                     "(at least 2 and half of them)", detail)
    out["pose_shift"] = Signature("pose_shift", not all(kinds.values()), shift_z, zthr_m,
                                  "a mode with a significant band residual whose peak moved by > zeta/2, not "
                                  "uniformly over the poses", detail)
    out["peak_height"] = Signature("peak_height", height_z > zthr_m, height_z, zthr_m,
                                   "a mode with a significant band residual whose peak did not move by more than "
                                   "zeta/2")
    return out


# ---------------------------------------------------------------------------------------------
# ranking
# ---------------------------------------------------------------------------------------------

def _group(effect) -> str:
    """The effect's type: instances of one class (six joint corrections, six servo drives) are one
    explanation of a signature, whichever joint it is."""
    return getattr(effect, "group", None) or type(effect).__qualname__


def rank_candidates(detected: dict, effects, heldout: dict, error_before: float) -> list[dict]:
    """The candidates ranked by the detected signatures they explain, ties by the residual they explain.

    Score of an effect: the sum over the detected signatures it explains of ``1 / n``, ``n`` the number
    of effect *types* that explain that signature (the six joint corrections are one type): a
    signature only one type explains counts fully, one that two types explain counts 1/2 for each
    (one unit of evidence per signature, shared among its explanations). The signatures narrow the
    candidates to the types the evidence points to; among equal scores the residual each fit
    removes decides.

    ``detected``: name -> :class:`Signature`; ``effects``: the candidate Effect objects;
    ``heldout``: name -> held-out error with the effect added (first selection step), missing if untried.
    Returns JSON-ready rows, best first, each with ``why``.
    """
    present = [k for k, s in detected.items() if s.present]
    groups = {}                                   # effect type -> the signatures it explains
    for e in effects:
        groups.setdefault(_group(e), set()).update(e.signatures)
    n_explain = {k: sum(k in sig for sig in groups.values()) for k in present}
    rows = []
    for e in effects:
        explains = [k for k in e.signatures if k in present]
        err = heldout.get(e.name)
        gain = (error_before - err) if err is not None and math.isfinite(err) else -math.inf
        rows.append({"name": e.name, "explains": explains, "score": sum(1.0 / n_explain[k] for k in explains),
                     "heldout_error_with": err, "explained_error": gain if math.isfinite(gain) else None})
    rows.sort(key=lambda r: (-round(r["score"], 9), -(r["explained_error"] if r["explained_error"] is not None
                                                      else -math.inf)))
    for i, r in enumerate(rows):
        sig = ", ".join(f"{k} (1/{n_explain[k]})" for k in r["explains"]) or "none of the detected signatures"
        gain = "untried" if r["explained_error"] is None else f"lowers the held-out error by {r['explained_error']:.4g}"
        r["rank"] = i + 1
        r["why"] = f"explains {sig}, score {r['score']:.3g} ({len(present)} detected); {gain}"
    return rows


def annotate(result, detected: dict, effects):
    """``result`` (an :class:`Identification`) with the detected signatures, the ranking and each
    selected effect's rank and explained signatures in its ``evidence``."""
    heldout = result.steps[0].candidates if result.steps else {}
    ranking = rank_candidates(detected, effects, heldout, result.error_before)
    by_name = {r["name"]: r for r in ranking}
    fits = tuple(replace(f, evidence={**f.evidence, "rank": by_name[f.name]["rank"] if f.name in by_name else None,
                                      "signatures_explained": by_name.get(f.name, {}).get("explains", []),
                                      "why_ranked": by_name.get(f.name, {}).get("why")})
                 for f in result.effects)
    extra = {**result.extra, "signatures": {k: s.to_json() for k, s in detected.items()},
             "signatures_detected": [k for k, s in detected.items() if s.present], "ranking": ranking}
    return replace(result, effects=fits, extra=extra)


def diagnosis_markdown(extra: dict) -> list[str]:
    """Markdown lines: the signature tests and the ranking of an annotated result's ``extra``."""
    sigs = extra.get("signatures")
    if not sigs:
        return []
    out = ["## Diagnosis: residual signatures (before)", "",
           "| signature | present | statistic | threshold | rule |", "|---|---|---|---|---|"]
    for k, s in sigs.items():
        out.append(f"| {k} | {'yes' if s['present'] else 'no'} | {s['statistic']:.4g} | {s['threshold']:.4g} | "
                   f"{s['rule']} |")
    out += ["", "Candidates ranked by the detected signatures they explain, ties by the held-out error "
                "they remove (the selection rule decides; the ranking orders and explains):", ""]
    out += [f"{r['rank']}. **{r['name']}**: {r['why']}" for r in extra.get("ranking", [])]
    return out + [""]
