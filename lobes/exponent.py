"""The Floquet exponent of a cut: ``sigma = ln|mu_max| / Tp`` (1/s), the growth rate a time-domain
run must measure (Insperger & Stepan 2004), from the semi-discretization at ``m`` and ``2 m`` steps
per principal period, extrapolated by :func:`robolobes.core.numerics.richardson` (order 2)."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from robolobes.core.numerics import richardson
from robolobes.core.threads import blas_single_threaded

from .problem import LobeProblem
from .sdm import SDMEngine, SemiDiscretization

__all__ = ["FloquetExponent", "floquet_exponent"]


@dataclass(frozen=True)
class FloquetExponent:
    """``sigma`` at ``m`` and ``2 m`` steps per period and its Richardson extrapolation, 1/s.

    coarse_per_s, fine_per_s : float   ln|mu| / Tp at m and 2 m.
    value_per_s, error_per_s : float   extrapolation and its error bound ``|fine - coarse|``.
    period_s : float                   the principal period Tp, s.
    m : int
    """

    coarse_per_s: float
    fine_per_s: float
    value_per_s: float
    error_per_s: float
    period_s: float
    m: int


def floquet_exponent(problem: LobeProblem, method: SemiDiscretization | None = None,
                     surface_tilt: bool = False) -> FloquetExponent:
    """Floquet exponent of ``problem`` at its own cut (``cut.spindle_rpm``, ``cut.ap_m``).

    Parameters
    ----------
    problem : LobeProblem
    method : SemiDiscretization, optional
        The coarse level (default ``SemiDiscretization(m=40)``); the fine level doubles ``m``.
    surface_tilt : bool
        The dynamic chip along the regenerated surface's normal (:mod:`lobes.chip_direction`);
        default False, the linear model of the lobes.
    """
    return two_level_exponent(problem, method, lambda engine, rpm, depth: float(engine.multipliers([rpm], [depth])[0][0]),
                              surface_tilt=surface_tilt)


@blas_single_threaded
def two_level_exponent(problem: LobeProblem, method: SemiDiscretization | None, spectral_radius,
                       surface_tilt: bool = False, slice_edge_rad: np.ndarray | None = None,
                       delay_time: bool = False) -> FloquetExponent:
    """ln|mu| / T at ``m`` and ``2 m`` (``method.m``, default 40), Richardson-extrapolated, 1/s, with
    ``spectral_radius(engine, rpm, depth_m)`` the largest multiplier's modulus of one
    :class:`~robolobes.lobes.sdm.SDMEngine` at the problem's own cut (``surface_tilt``: passed to
    the engine, :mod:`lobes.chip_direction`; ``slice_edge_rad``: the block-edge angle per axial
    slice, :class:`~robolobes.lobes.directional.DirectionalPlan`; ``delay_time``: the delayed instant,
    :mod:`lobes.chip_direction`, for a ``spectral_radius`` that uses :meth:`SDMEngine.monodromy_dense`).
    BLAS runs on one thread (:mod:`robolobes.core.threads`): called from Python without
    ``OMP_NUM_THREADS``, the steel study's exponent about the forced orbit took 0.70 s of wall time
    with the default threads against 0.036 s with one."""
    method = SemiDiscretization(m=40) if method is None else method
    rpm, depth = float(problem.cut.spindle_rpm), float(problem.cut.ap_m)
    rates = []
    period = math.nan
    for m in (method.m, 2 * method.m):
        engine = SDMEngine(problem, replace(method, m=m), max(depth, 1e-6), surface_tilt=surface_tilt,
                           slice_edge_rad=slice_edge_rad, delay_time=delay_time)
        period = float(engine.period_s(np.array([rpm]))[0])
        rates.append(math.log(spectral_radius(engine, rpm, depth)) / period)
    ext = richardson(rates[0], rates[1])
    return FloquetExponent(coarse_per_s=rates[0], fine_per_s=rates[1], value_per_s=float(ext.value),
                           error_per_s=float(ext.error), period_s=period, m=method.m)
