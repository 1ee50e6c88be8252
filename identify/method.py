"""Methods of identification: the selection rules, one per kind of measurement, as frozen objects.

* :class:`StepwiseSelection` (FRF sets): forward-backward selection with a joint refit, scored on
  the leave-one-pose-out held-out error, Bonferroni over ``2 max_effects`` x the candidates at a
  family-wise ``alpha`` (:mod:`identify.frf`);
* :class:`ForwardSelection` (force series): forward selection on the held-out revolutions, the same
  threshold rule (:mod:`identify.forces`);
* :class:`AICcSelection` (force statistics): every subset of at most 3 parameters, by AICc (no
  held-out part, so no ``alpha``);
* :class:`StabilitySelection` (stability observations): the damping value that makes the fewest
  observations disagree (no statistical test, so no ``alpha``).

Fields are checked at construction (:class:`robolobes.core.errors.BadInput`, one line).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Union

from robolobes.core.errors import BadInput

__all__ = ["StepwiseSelection", "ForwardSelection", "AICcSelection", "StabilitySelection", "Method",
           "MAX_EFFECTS"]

#: Largest ``max_effects`` (each step fits every candidate).
MAX_EFFECTS = 10


def _alpha(owner: str, alpha) -> None:
    if isinstance(alpha, bool) or not isinstance(alpha, (int, float)) or not math.isfinite(alpha) \
            or not 0 < alpha < 1:
        raise BadInput(f"{owner}: alpha = {alpha!r}: must be in (0, 1)")


def _max_effects(owner: str, n) -> None:
    if isinstance(n, bool) or not isinstance(n, int) or not 0 <= n <= MAX_EFFECTS:
        raise BadInput(f"{owner}: max_effects = {n!r}: must be an integer in 0..{MAX_EFFECTS} (each step fits every "
                       "candidate)")


@dataclass(frozen=True)
class _Method:
    def __post_init__(self) -> None:
        owner = type(self).__name__
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name == "alpha":
                _alpha(owner, v)
            elif f.name == "max_effects":
                _max_effects(owner, v)
            elif not isinstance(v, bool):
                raise BadInput(f"{owner}: {f.name} = {v!r}: must be True or False")

    @classmethod
    def field_names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in fields(cls))


@dataclass(frozen=True)
class StepwiseSelection(_Method):
    """FRF sets: forward-backward stepwise selection with a joint refit (:func:`identify.selection.stepwise_select`).

    Attributes
    ----------
    alpha : float
        Family-wise false-positive rate of the selection over the library, in (0, 1) (default 1 %).
    max_effects : int
        At most this many effects are added, 0..10.
    poles : bool
        Also fit the measurement's poles (LSCF/LSFD) and set them beside the model's (a few s per pose).
    """

    alpha: float = 0.01
    max_effects: int = 3
    poles: bool = True


@dataclass(frozen=True)
class ForwardSelection(_Method):
    """Force series: forward-backward selection with a joint refit of the selected effects at every step,
    on the held-out revolutions (:func:`identify.selection.stepwise_select`, :mod:`identify.forces`; the
    class keeps its name, part of the API).

    Attributes: ``alpha`` (family-wise false-positive rate, in (0, 1)), ``max_effects`` (0..10).
    """

    alpha: float = 0.01
    max_effects: int = 3


@dataclass(frozen=True)
class AICcSelection(_Method):
    """Force statistics (8 numbers): the subset of the library (at most 3 parameters in all, at most
    ``max_effects`` effects) with the lowest AICc; no held-out part, so no significance level."""

    max_effects: int = 3


@dataclass(frozen=True)
class StabilitySelection(_Method):
    """Stability observations: per candidate damping effect the value that makes the fewest
    observations disagree (:mod:`identify.force_stability`); at most ``max_effects`` effects are
    reported, best first (the first is written into the model). Binary observations give no noise
    estimate, so there is no significance level."""

    max_effects: int = 3


Method = Union[StepwiseSelection, ForwardSelection, AICcSelection, StabilitySelection]
