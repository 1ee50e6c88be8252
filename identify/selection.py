"""Stepwise (forward-backward) selection of effects by held-out error, with a significance rule against the noise.

Generic over the measurement kind: the pipeline supplies ``trial(state, effect)``, which fits
``effect`` together with every effect already in ``state`` (a joint refit) on the training part of
every fold and returns the residuals on the held-out part (:class:`Trial`); ``trial(state, None)``
returns the held-out residuals of ``state`` itself. A pipeline that can take an effect out of a
state supplies ``drop(state, k)`` (the state without its ``k``-th effect, the others refitted
jointly); the search is then forward-backward, else forward only.

The metric: ``e = RMS_heldout |model - measured| / RMS_heldout |measured|``, not squared.

The significance rule (derived once, from the noise model, not tuned)
---------------------------------------------------------------------
Held-out lines carry independent noise ``n`` of variance ``sigma^2`` per line (``E|n|^2`` for
complex FRF lines), estimated from the data by the pipeline. Let ``r0`` be the held-out residual of
the current model and ``r1 = r0 + d`` that of the candidate, whose change ``d`` was fitted on other
data (so is independent of the held-out noise). If the candidate effect is absent (the current
model is right, ``r0 = -n``), the gain ``G = sum|r0|^2 - sum|r1|^2 = -sum|d|^2 + 2 Re sum conj(d) n``
has mean ``-sum|d|^2 <= 0`` and variance ``2 sum sigma^2 |d|^2`` (complex lines; ``4 sum sigma^2 d^2``
for real samples). So ``z = G / sqrt(var)`` exceeds the one-sided normal quantile ``z_(a/T)``
with probability at most ``a/T``.

The correction for the size of the search: a false effect can only enter the model through a
forward test that passes. The search makes at most ``S = 2 max_effects`` forward steps (a backward
step, which only removes, can give back a step), each testing at most ``L`` candidates (the
library; a repeatable effect such as ``tcp_mode`` is one candidate per step however many copies
the model holds). Every forward test is made at ``a / T`` with ``T = S L`` (Bonferroni over every
(step, candidate) test the search can make), so the family-wise false-positive rate over the whole
search is at most ``a`` (default ``a = 1 %``): ``z_thr = z_(a / (2 max_effects L))``. A backward
step removes an effect whose gain, tested the same way against the model without it, no longer
passes ``z_thr`` (an effect kept must stay significant once the later effects are in).

Before a candidate can be chosen it must be a possible finding (``accept(effect, trial)``, see
:mod:`identify.evidence`): credible (no parameter on a bound that is not its neutral value, none
outside its physical range) and above its own detection threshold. The best candidate of a step is
the acceptable one with the lowest held-out error; it is added when it passes the test and lowers
the held-out error.

A provisional step (forward-backward only): when every fitted candidate of a step is rejected as
not credible (none for being below its threshold), the best of them is most often a single effect
standing in for two (a servo's rotor damping pushed to its bound to mimic a second axis's change).
If it passes the same test and the model has room for at least one more effect, it enters
*provisionally* (``SelectionStep.provisional``): the next forward step refits it jointly with the
next effect, and the backward step removes it when it is no longer significant. This adds no test
(the step is one of the ``S`` forward steps, its candidates among the ``L``), so the correction
is unchanged; and whatever is left in the final model is judged on the final joint fit, so an
effect still on a bound there is reported not credible, never a finding.

A replace step (with ``params_of``): an effect of the final model that is not credible at the final
joint fit is replaced by the credible candidate, refitted jointly with the others, that the
held-out data cannot tell from it (the current model's gain over it does not pass ``z_thr``), the
lowest held-out error first (``SelectionStep.action = "replace"``). A servo whose rotor frequency
sits on its upper bound is a joint correction of its axis (no rotor resonance in the band): the
replacement reports it as what the data show. A replacement removes an effect and adds one that
the data cannot tell from it; it adds no effect, so it adds no false positive beyond the forward
tests counted above.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np
from scipy.stats import norm

from .result import EffectFit, SelectionStep

#: The prefix of :func:`identify.evidence.accept`'s reason for a fit that is not credible.
NOT_CREDIBLE = "not credible"

__all__ = ["Trial", "Selection", "forward_select", "stepwise_select", "heldout_error", "significance", "z_threshold"]


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
    """Outcome of :func:`forward_select` / :func:`stepwise_select`.

    ``effects``: one :class:`EffectFit` per effect of the final model, in the order they entered
    (their ``params`` are those of the step that added them; a pipeline that refits jointly replaces
    them with the final joint fit). ``chosen``: the candidate objects of the final model, same order.
    ``n_tests``: ``T`` of the Bonferroni correction (module doc).
    """

    effects: tuple          # EffectFit, in the order added (best first)
    steps: tuple            # SelectionStep
    state: Any              # the final model
    base: Trial             # held-out trial of the starting model
    final: Trial            # held-out trial of the final model
    chosen: tuple = ()
    n_tests: int = 1
    threshold: float = 0.0

    @property
    def error_before(self) -> float:
        return self.base.error

    @property
    def error_after(self) -> float:
        return self.final.error


def _always(effect, trial) -> tuple[bool, str]:
    return True, ""


def stepwise_select(state: Any, candidates: Sequence[Any], trial: Callable[[Any, Any], Trial], *,
                    alpha: float = 0.01, max_effects: int = 3, name: Callable[[Any], str] = lambda e: e.name,
                    progress: Callable[[str], None] | None = None,
                    repeatable: Callable[[Any], bool] = lambda e: False,
                    drop: Callable[[Any, int], Any] | None = None,
                    accept: Callable[[Any, Trial], tuple[bool, str]] = _always,
                    params_of: Callable[[Any, int], dict] | None = None) -> Selection:
    """Forward-backward selection with a joint refit at every step (see the module doc).

    Parameters
    ----------
    state : the starting model (whatever ``trial`` takes).
    candidates : the library (``L`` effects).
    trial : ``trial(state, effect_or_None) -> Trial``; the effect is fitted jointly with ``state``'s.
    alpha : family-wise false-positive rate (default 0.01), Bonferroni over ``2 max_effects L`` tests.
    max_effects : the final model holds at most this many effects.
    repeatable : whether a candidate may enter more than once (a second tool mode).
    drop : ``drop(state, k) -> state`` without its ``k``-th effect (others refitted); None: forward only.
    accept : ``accept(effect, trial) -> (ok, reason)``: whether the fitted effect can be a finding.
    params_of : ``params_of(state, k) -> dict``, the ``k``-th effect's parameters in ``state``; with
        ``drop``, an effect of the final model that is not credible at the final joint fit is replaced
        by a credible candidate the held-out data cannot tell from it (module doc).
    """
    n_forward = 2 * max(1, max_effects)
    n_tests = n_forward * max(1, len(candidates))
    thr = z_threshold(alpha, n_tests)
    base = current = trial(state, None)
    chosen: list = []
    fits: list = []
    steps: list = []
    forward = 0
    while forward < n_forward and len(chosen) < max_effects:
        forward += 1
        pool = [c for c in candidates if repeatable(c) or all(c is not x for x in chosen)]
        if not pool:
            break
        results, rejected = {}, {}
        for c in pool:
            if progress is not None:
                progress(f"step {len(steps) + 1}: {name(c)}")
            t = trial(current.state if current.state is not None else state, c)
            ok, why = accept(c, t)
            results[name(c)] = (c, t)
            if not ok:
                rejected[name(c)] = why
        usable = [k for k, (_, t) in results.items() if k not in rejected and not t.evidence.get("screened_out")]
        errors = {k: v[1].error for k, v in results.items()}
        provisional = not usable and len(chosen) < max_effects - 1 and drop is not None
        if provisional:   # every fit stopped on a bound: perhaps it stands in for two effects (module doc)
            usable = [k for k, why in rejected.items() if why.startswith(NOT_CREDIBLE)]
        if not usable:
            steps.append(SelectionStep(candidates=errors, kept=None, error_before=current.error,
                                       error_after=current.error, statistic=float("nan"), threshold=thr,
                                       rejected=rejected))
            break
        best_name = min(usable, key=lambda k: results[k][1].error)
        best_c, best = results[best_name]
        z = significance(current.residual, best.residual, best.sigma)
        kept = best_name if (z > thr and best.error < current.error) else None
        steps.append(SelectionStep(candidates=errors, kept=kept, error_before=current.error,
                                   error_after=best.error if kept else current.error, statistic=float(z),
                                   threshold=thr, rejected=rejected, provisional=bool(provisional and kept)))
        if kept is None:
            break
        fits.append(EffectFit(name=best_name, params=dict(best.params), uncertainty=dict(best.uncertainty),
                              evidence={**best.evidence, "heldout_error_without": current.error,
                                        "heldout_error_with": best.error, "z": float(z), "z_threshold": thr,
                                        "provisional": bool(provisional),
                                        "alternatives": _alternatives(results, rejected, best_name, best, thr)}))
        chosen.append(best_c)
        current = best
        if drop is not None:
            current = _backward(current, chosen, fits, steps, trial, drop, thr, name, progress)
    if drop is not None and params_of is not None:
        current = _replace_not_credible(current, candidates, chosen, fits, steps, trial, drop, accept, params_of,
                                        thr, name, repeatable, progress)
    final_state = current.state if current.state is not None else state
    return Selection(effects=tuple(fits), steps=tuple(steps), state=final_state, base=base, final=current,
                     chosen=tuple(chosen), n_tests=n_tests, threshold=thr)


def _alternatives(results: dict, rejected: dict, best_name: str, best: Trial, thr: float) -> list:
    """Candidates of the same step the held-out data cannot tell from the best: the best's gain over
    them is not significant (``significance(r_other, r_best) <= thr``, the same rule). A candidate that
    could not be a finding is listed too (``finding: false`` and the reason): a servo whose rotor sits
    on its frequency bound is a joint correction the data cannot tell apart."""
    out = []
    for k, (_, t) in results.items():
        if k == best_name or t.evidence.get("screened_out"):
            continue
        z = significance(t.residual, best.residual, best.sigma)
        if z <= thr:
            out.append({"name": k, "heldout_error": t.error, "z_best_over_it": float(z), "params": dict(t.params),
                        "finding": k not in rejected, **({"why_not": rejected[k]} if k in rejected else {})})
    return out


def _backward(current: Trial, chosen: list, fits: list, steps: list, trial, drop, thr, name, progress) -> Trial:
    """Remove, one at a time, the earlier effects that are no longer significant given the others."""
    while len(chosen) > 1:
        worst, worst_z, worst_t = None, math.inf, None
        for k in range(len(chosen) - 1):          # the newest effect has just passed its test
            if progress is not None:
                progress(f"backward: without {name(chosen[k])}")
            t = trial(drop(current.state, k), None)
            z = significance(t.residual, current.residual, current.sigma)
            if z < worst_z:
                worst, worst_z, worst_t = k, z, t
        if worst is None or worst_t is None or worst_z > thr:
            return current
        removed = name(chosen[worst])
        steps.append(SelectionStep(candidates={removed: worst_t.error}, kept=None, error_before=current.error,
                                   error_after=worst_t.error, statistic=float(worst_z), threshold=thr,
                                   action="drop", removed=removed))
        del chosen[worst]
        del fits[worst]
        current = worst_t
    return current


def _replace_not_credible(current: Trial, candidates, chosen: list, fits: list, steps: list, trial, drop, accept,
                          params_of, thr, name, repeatable, progress) -> Trial:
    """Replace each effect of the final model that is not credible at the final joint fit by the credible
    candidate (refitted jointly with the others) with the lowest held-out error among those the data
    cannot tell from it: the current model's gain over it does not pass ``thr``."""
    k = 0
    while k < len(chosen):
        here = Trial(current.residual, current.measured, current.sigma, params=dict(params_of(current.state, k)))
        if accept(chosen[k], here)[0]:
            k += 1
            continue
        rest = drop(current.state, k)
        others = chosen[:k] + chosen[k + 1:]
        best = None
        for c in candidates:
            if c is chosen[k] or (not repeatable(c) and any(c is x for x in others)):
                continue
            if progress is not None:
                progress(f"replace {name(chosen[k])}: {name(c)}")
            t = trial(rest, c)
            if t.evidence.get("screened_out") or not accept(c, t)[0]:
                continue
            z = significance(t.residual, current.residual, current.sigma)
            if z <= thr and (best is None or t.error < best[1].error):
                best = (c, t, z)
        if best is None:
            k += 1
            continue
        c, t, z = best
        old = name(chosen[k])
        steps.append(SelectionStep(candidates={name(c): t.error}, kept=name(c), error_before=current.error,
                                   error_after=t.error, statistic=float(z), threshold=thr, action="replace",
                                   removed=old))
        del chosen[k]
        del fits[k]
        chosen.append(c)
        fits.append(EffectFit(name=name(c), params=dict(t.params), uncertainty=dict(t.uncertainty),
                              evidence={**t.evidence, "replaces": old, "z_replaced_over_it": float(z),
                                        "z_threshold": thr}))
        current = t
    return current


def forward_select(state: Any, candidates: Sequence[Any], trial: Callable[[Any, Any], Trial], *,
                   alpha: float = 0.01, max_effects: int = 3, name: Callable[[Any], str] = lambda e: e.name,
                   progress: Callable[[str], None] | None = None,
                   accept: Callable[[Any, Trial], tuple[bool, str]] = _always) -> Selection:
    """Forward-only selection (no ``drop``; each candidate at most once): :func:`stepwise_select`."""
    return stepwise_select(state, candidates, trial, alpha=alpha, max_effects=max_effects, name=name,
                           progress=progress, accept=accept)
