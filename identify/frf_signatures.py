"""FRF residual signatures (per pose and pair): the FRF detectors of :mod:`identify.signatures`,
whose module doc states the rule (band medians of ``q = 2 |r|^2 / sigma^2`` against chi2(2))."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.stats import norm

from .chain_signatures import channel_ratio, phase_slope
from .signatures import ALPHA, EDGE_LINES, FRF_SIGNATURES, NOISE_CAL, QUASI_STATIC, Signature

__all__ = ["PoseResidual", "frf_pose_residual", "frf_signatures"]


@dataclass(frozen=True)
class PoseResidual:
    """What the FRF detectors need of one pose.

    f_hz : (L,) line frequencies;  measured, model : (P, L) complex receptances, m/N, per pair;
    sigma : (P, L) noise per line (``E|n|^2 = sigma^2``), m/N;  modes : ((freq_hz, zeta), ...) of the model;
    channels : (P,) the pairs' response channels (0, 1, 2), None: one channel for all.
    """

    name: str
    f_hz: np.ndarray
    measured: np.ndarray
    model: np.ndarray
    sigma: np.ndarray
    modes: tuple
    channels: np.ndarray | None = None


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
    channel = getattr(pd, "pair_channel", None)
    return PoseResidual(name=pd.name, f_hz=f, measured=rows(pd.H), model=rows(model_h), sigma=rows(pd.sigma),
                        modes=in_band, channels=None if channel is None else np.asarray(channel)[keep])


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
    # the measurement chain first (identify.chain_signatures): a common factor found is removed; the
    # delay before the scale (a delay's second order, 1 - (w tau)^2 / 2, is a real ratio; a scale has
    # no phase)
    out["phase_slope"], poses = phase_slope(poses, s_det)
    out["channel_ratio"], poses = channel_ratio(poses, s_det)
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
