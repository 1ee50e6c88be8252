"""Greedy forward selection of effects by held-out error, with a significance rule against the noise.

Generic over the measurement kind: the pipeline supplies ``trial(state, effect)``, which fits
``effect`` on the training part of every fold and returns the residuals on the held-out part
(:class:`Trial`); ``trial(state, None)`` returns the held-out residuals of ``state`` itself.

The metric: ``e = RMS_heldout |model - measured| / RMS_heldout |measured|``, not squared.

The significance rule (derived once, from the noise model, not tuned)
---------------------------------------------------------------------
Held-out lines carry independent noise ``n`` of variance ``sigma^2`` per line (``E|n|^2`` for
complex FRF lines), estimated from the data by the pipeline. Let ``r0`` be the held-out residual of
the current model and ``r1 = r0 + d`` that of the candidate, whose change ``d`` was fitted on other
data (so is independent of the held-out noise). If the candidate effect is absent (the current
model is right, ``r0 = -n``), the gain ``G = sum|r0|^2 - sum|r1|^2 = -sum|d|^2 + 2 Re sum conj(d) n``
has mean ``-sum|d|^2 <= 0`` and variance ``2 sum sigma^2 |d|^2`` (complex lines; ``4 sum sigma^2 d^2``
for real samples). So ``z = G / sqrt(var)`` exceeds the one-sided normal quantile ``z_(a/L)``
with probability at most ``a/L``; testing all ``L`` candidates of a step at ``a/L`` (Bonferroni)
bounds the family-wise false-positive rate of the step by ``a`` (default ``a = 1 %``). Selection
stops at the first step whose best candidate fails the test, so the first false effect can only
enter at that step: the rate over the whole run is at most ``a`` too.

An effect is added only when it passes the test *and* lowers the held-out error; the best candidate
of a step is the one with the lowest held-out error.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np
from scipy.stats import norm

from .result import EffectFit, SelectionStep

__all__ = ["Trial", "Selection", "forward_select", "heldout_error", "significance", "z_threshold"]


@dataclass(frozen=True)
class Trial:
    """Held-out outcome of one candidate model.

    Attributes
    ----------
    residual : array (N,), complex or real
        Model minus measurement on the held-out lines/samples, all folds concatenated (SI).
    measured : array (N,)
        The measurement on the same lines (for the metric's normalization).
    sigma : array (N,)
        Noise standard deviation of each held-out line, estimated from the data (``E|n|^2``).
    state : Any
        The model with the effect added at its parameters fitted on all the data.
    params, uncertainty : dict
        Those parameters and one standard deviation of each (SI, unit in the key).
    evidence : dict
        Anything the pipeline wants reported (signature, per-fold errors...).
    """

    residual: np.ndarray
    measured: np.ndarray
    sigma: np.ndarray
    state: Any = None
    params: dict = field(default_factory=dict)
    uncertainty: dict = field(default_factory=dict)
    evidence: dict = field(default_factory=dict)

    @property
    def error(self) -> float:
        return heldout_error(self.residual, self.measured)


def heldout_error(residual: np.ndarray, measured: np.ndarray) -> float:
    """RMS |residual| / RMS |measured| (dimensionless, not squared)."""
    den = float(np.sqrt(np.mean(np.abs(measured) ** 2)))
    return float(np.sqrt(np.mean(np.abs(residual) ** 2))) / den if den > 0 else float("inf")


def z_threshold(alpha: float, n_candidates: int) -> float:
    """One-sided normal quantile for a family-wise rate ``alpha`` over ``n_candidates`` tests (Bonferroni)."""
    return float(norm.isf(alpha / max(1, n_candidates)))


def significance(r0: np.ndarray, r1: np.ndarray, sigma: np.ndarray) -> float:
    """The z statistic of the gain ``sum|r0|^2 - sum|r1|^2`` against held-out noise ``sigma`` (see module doc)."""
    d = r1 - r0
    factor = 2.0 if np.iscomplexobj(r0) or np.iscomplexobj(r1) else 4.0
    var = factor * float(np.sum(sigma ** 2 * np.abs(d) ** 2))
    gain = float(np.sum(np.abs(r0) ** 2) - np.sum(np.abs(r1) ** 2))
    if var <= 0:
        return 0.0
    return gain / np.sqrt(var)


@dataclass(frozen=True)
class Selection:
    """Outcome of :func:`forward_select`."""

    effects: tuple          # EffectFit, in the order added (best first)
    steps: tuple            # SelectionStep
    state: Any              # the final model
    base: Trial             # held-out trial of the starting model
    final: Trial            # held-out trial of the final model

    @property
    def error_before(self) -> float:
        return self.base.error

    @property
    def error_after(self) -> float:
        return self.final.error


def forward_select(state: Any, candidates: Sequence[Any], trial: Callable[[Any, Any], Trial], *,
                   alpha: float = 0.01, max_effects: int = 3, name: Callable[[Any], str] = lambda e: e.name,
                   progress: Callable[[str], None] | None = None) -> Selection:
    """Add effects greedily while one clearly lowers the held-out error.

    Parameters
    ----------
    state : the starting model (whatever ``trial`` takes).
    candidates : effects to try; each is tried at most once.
    trial : ``trial(state, effect_or_None) -> Trial``.
    alpha : family-wise false-positive rate (default 0.01), Bonferroni over the candidates of a step.
    max_effects : at most this many effects are added.
    """
    base = current = trial(state, None)
    remaining = list(candidates)
    effects, steps = [], []
    while remaining and len(effects) < max_effects:
        thr = z_threshold(alpha, len(remaining))
        results = {}
        for c in remaining:
            if progress is not None:
                progress(f"step {len(steps) + 1}: {name(c)}")
            results[name(c)] = (c, trial(current.state if current.state is not None else state, c))
        best_name = min(results, key=lambda k: results[k][1].error)
        best_c, best = results[best_name]
        z = significance(current.residual, best.residual, best.sigma)
        kept = best_name if (z > thr and best.error < current.error) else None
        steps.append(SelectionStep(candidates={k: v[1].error for k, v in results.items()}, kept=kept,
                                   error_before=current.error, error_after=best.error if kept else current.error,
                                   statistic=float(z), threshold=thr))
        if kept is None:
            break
        effects.append(EffectFit(name=best_name, params=dict(best.params), uncertainty=dict(best.uncertainty),
                                 evidence={**best.evidence, "heldout_error_without": current.error,
                                           "heldout_error_with": best.error, "z": float(z), "z_threshold": thr}))
        current = best
        remaining.remove(best_c)
    return Selection(effects=tuple(effects), steps=tuple(steps), state=current.state if current.state is not None else state,
                     base=base, final=current)
