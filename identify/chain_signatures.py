"""FRF signatures of the measurement chain (:mod:`identify.chain_effects`): ``channel_ratio`` and
``phase_slope``, detectors of :func:`identify.frf_signatures.frf_signatures` under the rule of
:mod:`identify.signatures` (a statistic with a known distribution under noise alone, its one-sided
quantile at ``alpha / S``).

Both look for one *common coefficient* ``a`` of a known residual shape ``g`` on every line:
``r = measured - model = a g + noise``, with

* ``channel_ratio``: ``g = model`` on the pairs of one response channel (a calibration ``s = 1 + a``:
  a real, frequency-independent ratio, the same at every pose; not a peak height, which changes one
  mode's band, nor a static offset, which adds a constant compliance);
* ``phase_slope``: ``g = -i w model`` on every pair (a delay ``tau = a``, to first order in ``w tau``:
  ``|H|`` unchanged, a phase linear in ``w``, the same in every pair and pose).

On each block ``b`` (a pose's pair, its lines cut into ``N_SUB`` runs of equal count) the weighted
least-squares coefficient ``a_b = Re(sum conj(g) r / sigma^2) / S_b``, ``S_b = sum |g|^2 / sigma^2``,
has under complex noise (``E|n|^2 = sigma^2``) variance ``1 / (2 S_b)``, times ``NOISE_CAL`` (the FRF
line noise estimate's error, :data:`identify.signatures.NOISE_CAL`). Pooled with weights ``w_b = 1 /
var_b``: ``a = sum w_b a_b / sum w_b``, ``z = a sqrt(sum w_b)`` (normal under noise alone), and the
homogeneity ``Q = sum w_b (a_b - a)^2`` (chi-square, ``B - 1`` dof, when the coefficient is common).

The signature is present when ``|z|`` exceeds ``z_(s / 2G)`` (two-sided, Bonferroni over the ``G``
groups: the response channels, or the one group of all pairs) *and* the coefficient is common:
``Q`` below its ``chi2_(s)(B - 1)`` quantile (so a true chain signature is missed through ``Q`` with
probability ``s``; a residual that only correlates with ``g``, a shifted or reshaped mode, fails
``Q``). ``s = alpha / S`` (:func:`identify.frf_signatures.frf_signatures`). Because the shapes
``model`` and ``-i w model`` are orthogonal on every line (``Re(conj(H) (-i w H)) = 0``), a scale
does not show as a delay (and a delay's first order not as a scale). The delay is tested first: its
second order, ``1 - (w tau)^2 / 2``, is a real ratio that the scale would pick up. When present, the
common factor is removed before the other detectors run (as the static offset is), so they test what
the chain leaves.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from scipy.stats import chi2, norm

from .signatures import NOISE_CAL, Signature

__all__ = ["N_SUB", "channel_ratio", "phase_slope"]

#: Runs of lines per pair: the blocks the homogeneity of the coefficient is tested over.
N_SUB = 8


def _blocks(pr, rows: np.ndarray, shape: np.ndarray):
    """``(a_b, w_b)`` arrays over the blocks of ``rows`` of pose ``pr`` (module doc); ``shape`` (P, L) is ``g``."""
    a, w = [], []
    for k in rows:
        r = pr.measured[k] - pr.model[k]
        for idx in np.array_split(np.arange(len(pr.f_hz)), N_SUB):
            g, s2 = shape[k, idx], pr.sigma[k, idx] ** 2
            S = float(np.sum(np.abs(g) ** 2 / s2))
            if S > 0:
                a.append(float(np.sum((np.conj(g) * r[idx]).real / s2)) / S)
                w.append(2 * S / NOISE_CAL)
    return np.array(a), np.array(w)


def _common(parts) -> tuple[float, float, float, int]:
    """Pooled ``(a, z, Q, dof)`` over the ``(a_b, w_b)`` parts (module doc)."""
    a = np.concatenate([p[0] for p in parts])
    w = np.concatenate([p[1] for p in parts])
    if a.size < 2:
        return 0.0, 0.0, math.inf, 0
    mean = float(np.sum(w * a) / np.sum(w))
    return mean, mean * math.sqrt(float(np.sum(w))), float(np.sum(w * (a - mean) ** 2)), int(a.size - 1)


def _channels(pr) -> np.ndarray:
    ch = getattr(pr, "channels", None)
    return np.zeros(pr.measured.shape[0], int) if ch is None else np.asarray(ch, int)


def channel_ratio(poses: list, s_det: float) -> tuple[Signature, list]:
    """The ``channel_ratio`` signature and the poses with each channel's common scale removed when present."""
    groups = sorted({int(c) for pr in poses for c in _channels(pr)})
    zthr = float(norm.isf(s_det / (2 * max(len(groups), 1))))
    rows, best, scales = [], (-math.inf, None), {}
    for c in groups:
        a, z, Q, dof = _common([_blocks(pr, np.flatnonzero(_channels(pr) == c), pr.model) for pr in poses])
        q_thr = float(chi2.isf(s_det, dof)) if dof else math.inf
        common = Q < q_thr
        rows.append({"channel": "xyz"[c], "scale": 1 + a, "z": z, "homogeneity_chi2": Q, "homogeneity_threshold": q_thr})
        if common and abs(z) > zthr:
            scales[c] = 1 + a
        if common and abs(z) > best[0]:
            best = (abs(z), c)
    present = bool(scales)
    sig = Signature("channel_ratio", present, best[0], zthr,
                    f"|z| of a common real scale of a response channel's pairs over all poses (two-sided, "
                    f"{len(groups)} channels), with its homogeneity chi2 over {N_SUB} runs per pair below its "
                    "quantile", {"per_channel": rows})
    if not present:
        return sig, poses
    out = []
    for pr in poses:
        f = np.array([scales.get(int(c), 1.0) for c in _channels(pr)])[:, None]
        out.append(replace(pr, measured=pr.measured / f))
    return sig, out


def phase_slope(poses: list, s_det: float) -> tuple[Signature, list]:
    """The ``phase_slope`` signature and the poses with the common delay removed when present."""
    zthr = float(norm.isf(s_det / 2))
    shapes = [-1j * 2 * math.pi * pr.f_hz[None, :] * pr.model for pr in poses]
    tau, z, Q, dof = _common([_blocks(pr, np.arange(pr.measured.shape[0]), g) for pr, g in zip(poses, shapes)])
    q_thr = float(chi2.isf(s_det, dof)) if dof else math.inf
    present = bool(Q < q_thr and abs(z) > zthr)
    sig = Signature("phase_slope", present, abs(z), zthr,
                    f"|z| of a common delay (phase -w tau of the model) over every pair and pose (two-sided), with "
                    f"its homogeneity chi2 over {N_SUB} runs per pair below its quantile",
                    {"delay_s": tau, "homogeneity_chi2": Q, "homogeneity_threshold": q_thr})
    if not present:
        return sig, poses
    return sig, [replace(pr, measured=pr.measured * np.exp(2j * math.pi * pr.f_hz * tau)[None, :]) for pr in poses]
