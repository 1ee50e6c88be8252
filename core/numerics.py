"""Numerical helpers shared by the packages: the one Richardson extrapolation of robolobes.

Error convention (the only one used in robolobes)
--------------------------------------------------
A quantity computed at two discretization levels, ``coarse`` with step ``h`` and ``fine`` with step
``h / ratio``, converging as ``b(h) = b_inf + c h^p + ...``, is extrapolated assuming ``p = order``::

    value = fine + (fine - coarse) / (ratio**order - 1)
    error = |fine - coarse| / (ratio**order - 1)

``error`` is Richardson's estimate of the error of the FINE level, ``|b_inf - fine|``, which is
exact to leading order when the assumed order is the true one. In that asymptotic regime the
extrapolated ``value`` is of higher order (its error ``O(h^(p+1))``), so ``error`` is a
conservative estimate of ``|value - b_inf|``. It is an estimate, not a guaranteed bound: on the
milling benchmark of the tests (first-order semi-discretization, ``order = 2``, ``ratio = 2``:
``error = |b_2m - b_m| / 3``; the default refinement from m = 40), the values were within
0.37 % of the independent reference at all 358 reference speeds with a finite limit, and the
true error exceeded ``error`` at 16 of them, all at a/D = 0.05, all below 0.37 %
(``docs/guide/lobes-accuracy.md``).

Why not the larger ``|fine - coarse| / (ratio - 1)`` (a bound for ANY order ``p >= 1``): the
order of the method is known. The first-order semi-discretization with exact step averages
converges at second order (Insperger & Stepan 2004; measured slope 2.0 in
``tests/test_lobes.py::test_second_order_convergence_in_m``; on the accuracy benchmark at 6800 and
7000 rpm, successive differences shrink by 4.1-4.5 from m = 80 on), and where the two levels are not in that regime -- they pick
different lobes, or only one of them finds a limit -- the callers flag the result instead of
trusting any estimate (``lobes.solver``). The bound for ``p >= 1`` would ask for ``sqrt(3)``
times more steps for no accuracy gain.

Geometrically converging methods (the collocation of ``lobes.collocation``, whose error falls by a
large factor per added node rather than as a power of the step) have no order to extrapolate with:
:func:`level_change` keeps the fine value and takes the whole change ``|fine - coarse|`` as its
error, an estimate of the coarse level's error and so a conservative one of the fine level's.

Non-finite levels (both functions): where both levels are equal (e.g. both ``inf``, "no stability limit found"),
``value`` is that and ``error`` 0; where one is not finite and they differ, ``value = fine`` and
``error = inf`` (the two levels do not agree on what they found).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .errors import BadInput

__all__ = ["Extrapolation", "level_change", "richardson"]


class Extrapolation(NamedTuple):
    """``value`` and its ``error`` bound (same units and shape as the levels); see the module doc."""

    value: np.ndarray | float
    error: np.ndarray | float


def richardson(coarse, fine, *, order: float = 2.0, ratio: float = 2.0) -> Extrapolation:
    """Richardson extrapolation of two discretization levels and its error estimate (module doc).

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
        error = np.where(both, np.abs(delta) / (ratio ** order - 1.0), np.where(b1 == b2, 0.0, np.inf))
    if value.ndim == 0:
        return Extrapolation(float(value), float(error))
    return Extrapolation(value, error)


def level_change(coarse, fine) -> Extrapolation:
    """The fine level with the whole change between two levels as its error (module doc), for a
    method that converges geometrically in its level (no order to extrapolate with).

    Parameters
    ----------
    coarse, fine : float or array (same shape)
        The quantity at the coarser and at the finer level (any unit; the results share it).

    Returns
    -------
    Extrapolation(value, error)
        ``value = fine``, ``error = |fine - coarse|``; non-finite levels as :func:`richardson`.
    """
    b1 = np.asarray(coarse, dtype=float)
    b2 = np.asarray(fine, dtype=float)
    both = np.isfinite(b1) & np.isfinite(b2)
    with np.errstate(invalid="ignore"):
        error = np.where(both, np.abs(b2 - b1), np.where(b1 == b2, 0.0, np.inf))
    if b2.ndim == 0:
        return Extrapolation(float(b2), float(error))
    return Extrapolation(b2, error)
