"""The identification problem: a measurement (typed per kind), the model, the candidate effects.

Measurement types (frozen; each has ``kind``, ``path``, ``case`` and ``variant``):

* :class:`robolobes.linearize.frf_io.FRFSet`, kind ``frf``, read by :func:`robolobes.linearize.frf_io.read_frf_set`;
* :class:`identify.force_data.ForceSeries`, kind ``forces``, read by :func:`identify.force_data.read_force_set`;
* :class:`identify.force_data.ForceStatistics`, kind ``force_stats``, read by
  :func:`identify.force_data.read_force_stats`;
* :class:`identify.force_data.StabilityObservations`, kind ``stability``, read by
  :func:`identify.force_data.read_stability`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence, Union

from robolobes.core.errors import BadInput
from robolobes.linearize.frf_io import FRFSet

from .effects import Effect, ModelState, effects_for
from .force_data import ForceSeries, ForceStatistics, StabilityObservations

__all__ = ["IdentifyProblem", "Measurement", "MEASUREMENT_TYPES", "FRFSet", "ForceSeries", "ForceStatistics",
           "StabilityObservations"]

Measurement = Union[FRFSet, ForceSeries, ForceStatistics, StabilityObservations]
#: The measurement types :func:`identify.api.identify` dispatches on.
MEASUREMENT_TYPES = (FRFSet, ForceSeries, ForceStatistics, StabilityObservations)


@dataclass(frozen=True, eq=False)
class IdentifyProblem:
    """Everything an identification depends on, except the selection rule (the method).

    Variants are made with :func:`dataclasses.replace`, e.g. ``replace(problem, effects=("tcp_mode",))``.

    Parameters
    ----------
    measurement : FRFSet, ForceSeries, ForceStatistics or StabilityObservations
        What was measured (:func:`identify.api.read_measurement` reads any kind from its files).
    model : ModelState
        The starting model (:func:`identify.api.model_state`).
    effects : sequence of Effect or of registry names, optional
        The candidate effects; names are looked up in :data:`identify.effects.REGISTRY` (BadInput
        for one the measurement's kind does not observe). Default None: the library's default
        candidates for the kind. Stability observations fit damping effects only
        (:class:`identify.cutting_effects.DampingEffect`).
    """

    measurement: Measurement
    model: ModelState
    effects: Sequence | None = None  # a tuple of Effect after construction

    def __post_init__(self) -> None:
        if not isinstance(self.measurement, MEASUREMENT_TYPES):
            raise BadInput(f"measurement: a {type(self.measurement).__name__}; valid: "
                           f"{', '.join(t.__name__ for t in MEASUREMENT_TYPES)} (identify.api.read_measurement)")
        if not isinstance(self.model, ModelState):
            raise BadInput(f"model: a {type(self.model).__name__}; valid: an identify.effects.ModelState "
                           "(identify.api.model_state)")
        if self.effects is not None:
            object.__setattr__(self, "effects", self._resolve(self.effects))

    @property
    def kind(self) -> str:
        """The measurement's kind (``"frf"``, ``"forces"``, ``"force_stats"``, ``"stability"``)."""
        return self.measurement.kind

    def _resolve(self, effects) -> tuple:
        if isinstance(effects, (str, Effect)):
            effects = (effects,)
        items = tuple(effects)
        names = [e for e in items if isinstance(e, str)]
        bad = [repr(e) for e in items if not isinstance(e, (str, Effect))]
        if bad:
            raise BadInput(f"effects: {', '.join(bad)}; valid: Effect objects or names in identify.effects.REGISTRY")
        found = iter(effects_for(self.kind, None, names)) if names else iter(())
        out = tuple(next(found) if isinstance(e, str) else e for e in items)
        unobserved = [e.name for e in out if self.kind not in e.observed_by]
        if unobserved:
            raise BadInput(f"effects {', '.join(unobserved)}: not observed by a {self.kind} measurement; valid: "
                           f"{', '.join(e.name for e in effects_for(self.kind))}")
        if isinstance(self.measurement, StabilityObservations):
            from .force_stability import stability_effects

            stability_effects(None, [e.name for e in out])  # BadInput unless each is a damping effect
        return out
