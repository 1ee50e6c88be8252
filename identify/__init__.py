"""Identify: close the loop with measured data.

``identify(measurement, model)`` (:mod:`identify.api`) computes the residual between a measurement
(tool-tip FRF sets; cutting forces in :mod:`identify.forces`) and the model, traces it to an effect
the model lacks (:mod:`identify.effects`, the library: a tool-holder mode, joint or orthogonal
stiffness and damping corrections, a payload mass error, cutting-law effects), adds it, refits,
and reports the held-out error before and after (:mod:`identify.selection`). The study
(``robolobes study``) lives in :mod:`robolobes.study`, above identify in the data flow.
"""

if __name__ != "robolobes.identify":  # this folder imported by itself (from the repository root): a second copy
    raise ImportError(f"{__name__!r} is the folder of the robolobes.identify package: import robolobes.identify instead")
