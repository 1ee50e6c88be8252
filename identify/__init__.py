"""Identify: close the loop with measured data.

In the shape of :mod:`robolobes.lobes` (problem / method / solve)::

    from robolobes.identify import IdentifyProblem, StepwiseSelection, identify, model_state, read_measurement
    measurement = read_measurement("rig/frf")              # FRFSet, ForceSeries, ForceStatistics, StabilityObservations
    model, notes = model_state(measurement)
    result = identify(IdentifyProblem(measurement, model), StepwiseSelection(alpha=0.01, max_effects=3))

:func:`identify` (:mod:`identify.api`) computes the residual between a measurement (tool-tip FRF
sets; cutting forces, force statistics and stability observations in :mod:`identify.forces` and
:mod:`identify.force_stability`) and the model, traces it to an effect the model lacks
(:mod:`identify.effects`, the one library: a tool-holder mode, joint or orthogonal stiffness and
damping corrections, a payload mass error, cutting-law effects, process and joint damping), adds
it, refits, and reports the held-out error before and after (:mod:`identify.selection`). The
study (``robolobes study``) lives in :mod:`robolobes.study`, above identify in the data flow.
"""

if __name__ != "robolobes.identify":  # this folder imported by itself (from the repository root): a second copy
    raise ImportError(f"{__name__!r} is the folder of the robolobes.identify package: import robolobes.identify instead")

from .api import default_method, identify, measurement_kind, model_state, read_measurement
from .effects import REGISTRY, Effect, ModelState, Parameter, effects_for, register
from .method import AICcSelection, ForwardSelection, Method, StabilitySelection, StepwiseSelection
from .problem import FRFSet, ForceSeries, ForceStatistics, IdentifyProblem, Measurement, StabilityObservations
from .result import EffectFit, Evidence, Identification, SelectionStep

__all__ = [
    "identify", "IdentifyProblem", "StepwiseSelection", "ForwardSelection", "AICcSelection", "StabilitySelection",
    "Method", "default_method", "FRFSet", "ForceSeries", "ForceStatistics", "StabilityObservations", "Measurement",
    "read_measurement", "measurement_kind", "model_state", "Identification", "EffectFit", "Evidence",
    "SelectionStep", "ModelState", "Effect", "Parameter", "REGISTRY", "register", "effects_for",
]
