"""Numerical helpers shared by the packages: the one Richardson extrapolation of robolobes.

Error convention (the only one used in robolobes)
--------------------------------------------------
A quantity computed at two discretization levels, ``coarse`` with step ``h`` and ``fine`` with step
``h / ratio``, converging as ``b(h) = b_inf + c h^p + ...``, is extrapolated assuming ``p = order``::

    value = fine + (fine - coarse) / (ratio**order - 1)
    error = |fine - coarse| / (ratio - 1)

``error`` bounds ``|value - b_inf|`` for ANY true convergence order ``p >= 1`` in the asymptotic
regime (not only for ``p = order``): there ``b_inf = fine + (fine - coarse) / (ratio**p - 1)``
lies between ``fine`` and ``fine + (fine - coarse) / (ratio - 1)``, an interval of length
``error`` that contains ``value``. For the usual ``ratio = 2`` (m and 2m steps), ``error = |fine -
coarse|``: three times the textbook estimate ``|fine - coarse| / 3`` of the fine level's error, so
that a first-order pre-asymptotic behaviour (e.g. entry/exit angles between mesh points) does not
make a verdict that the discretization cannot support.

Non-finite levels: where both levels are equal (e.g. both ``inf``, "no stability limit found"),
``value`` is that and ``error`` 0; where one is not finite and they differ, ``value = fine`` and
``error = inf`` (the two levels do not agree on what they found).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .errors import BadInput

__all__ = ["Extrapolation", "richardson"]


class Extrapolation(NamedTuple):
    """``value`` and its ``error`` bound (same units and shape as the levels); see the module doc."""

    value: np.ndarray | float
    error: np.ndarray | float


def richardson(coarse, fine, *, order: float = 2.0, ratio: float = 2.0) -> Extrapolation:
    """Richardson extrapolation of two discretization levels, with the bound of the module doc.

    Parameters
    ----------
    coarse, fine : float or array (same shape)
        The quantity at step ``h`` and at step ``h / ratio`` (any unit; the results share it).
    order : float
        Assumed convergence order ``p`` (> 0); 2 for the first-order semi-discretization.
    ratio : float
        Step ratio between the levels (> 1).

    Returns
    -------
    Extrapolation(value, error)
        Floats for scalar input, arrays otherwise.
    """
    if not (np.isfinite(order) and order > 0):
        raise BadInput(f"Richardson order must be a finite number > 0, got {order!r}")
    if not (np.isfinite(ratio) and ratio > 1):
        raise BadInput(f"Richardson step ratio must be a finite number > 1, got {ratio!r}")
    b1 = np.asarray(coarse, dtype=float)
    b2 = np.asarray(fine, dtype=float)
    both = np.isfinite(b1) & np.isfinite(b2)
    with np.errstate(invalid="ignore"):
        delta = np.where(both, b2 - b1, 0.0)
        value = np.where(both, b2 + delta / (ratio ** order - 1.0), b2)
        error = np.where(both, np.abs(delta) / (ratio - 1.0), np.where(b1 == b2, 0.0, np.inf))
    if value.ndim == 0:
        return Extrapolation(float(value), float(error))
    return Extrapolation(value, error)
