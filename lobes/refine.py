"""The refinement rule of the lobes: SDM levels m, r m, r^2 m ... per speed until the error is small.

One rule for the diagram (:func:`lobes.solve`) and the operating point (:func:`lobes.stability`):

* at each speed the critical depth is computed at two levels ``m_c`` and ``m_f`` (default
  ``m_f = 2 m_c``); the value is their Richardson extrapolation and its error estimate
  ``|b_f - b_c| / (q^2 - 1)`` with the actual level ratio ``q = m_f / m_c``
  (:func:`robolobes.core.numerics.richardson`, order 2: the SDM converges at second order; ``q = 2``
  gives ``|b_2m - b_m| / 3``);
* the speed is **converged** when both levels find the same lobe (:func:`same_lobe`) and the
  estimate is at most ``tol`` times the value (both levels finding no limit below the searched
  depth is converged too, with error 0);
* otherwise the level is multiplied by the ratio at that speed (:func:`next_level`; the other
  speeds are not recomputed), up to ``m_max``;
* a speed still not converged at ``m_max`` is **unconverged**: where the last two levels found
  different lobes, or only one of them a limit, the finer level's depth is reported as it is
  (not extrapolated across lobes) with the error ``|b_f - b_c|``; else the extrapolation with its
  estimate, which is then above ``tol``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from robolobes.core.numerics import richardson
from robolobes.core.validate import integer

from ._errors import LobeError
from .sdm import SemiDiscretization

__all__ = ["RefinedSDM", "LimitStatus", "same_lobe", "combine_levels", "next_level", "level_pairs"]

LimitStatus = Literal["converged", "unconverged", "no-estimate"]


@dataclass(frozen=True)
class RefinedSDM:
    """The semi-discretization refined per speed until its error estimate is below ``tol``.

    Parameters
    ----------
    base : SemiDiscretization
        The scheme, quadrature, slices ... and the first level ``base.m`` (default m = 40). Starting
        at m = 20 was measured and rejected: on the benchmark of ``tests/test_lobes_accuracy.py``
        the pair 20/40 is not yet in the asymptotic regime at low immersion and in the slot (its
        values were up to 1.5 % off at the reference speeds while their estimates said less); from
        40/80 on, the values were within 0.37 % there (``docs/guide/lobes-accuracy.md``). The
        default prescan (robots only: 12 states or more) has 20 steps per period: it only brackets
        the limits, which the SDM verifies (CPU 15.9 -> 13.2 s on the TX200 steel diagram of
        ``bench/bench_lobes.py``, limits unchanged to the search's ``rtol``).
    tol : float
        Target relative error estimate of the critical depth, in (0, 0.5); default 0.01 (1 %).
    m_max : int
        Finest level (steps per principal period); a speed not converged there is "unconverged".
    ratio : float
        Nominal ratio of successive levels, in (1, 4] (default 2: 40, 80, 160, 320). Each level is
        ``round(ratio m)`` rounded half up (:func:`next_level`; 1.5: 40, 60, 90, 135, 203, 305) and
        the extrapolation uses the actual ratio ``m_f / m_c`` of each pair.
    """

    base: SemiDiscretization = SemiDiscretization(prescan_m=20)
    tol: float = 0.01
    m_max: int = 320
    ratio: float = 2.0

    def __post_init__(self) -> None:
        if not isinstance(self.base, SemiDiscretization):
            raise LobeError(f"RefinedSDM base must be a SemiDiscretization, got {self.base!r}")
        if self.base.richardson:
            raise LobeError("RefinedSDM base must not set richardson=True (the refinement makes the levels)")
        t = self.tol
        if isinstance(t, bool) or not isinstance(t, (int, float)) or not (0 < t < 0.5):
            raise LobeError(f"RefinedSDM tol (relative error target) must be in (0, 0.5), got {t!r}")
        r = self.ratio
        if isinstance(r, bool) or not isinstance(r, (int, float)) or not (1 < r <= 4):
            raise LobeError(f"RefinedSDM ratio (of successive levels) must be in (1, 4], got {r!r}")
        m2 = next_level(self.base.m, r)
        if m2 <= self.base.m:
            raise LobeError(f"RefinedSDM ratio {r!r} does not refine m = {self.base.m} (round(ratio m) = {m2})")
        integer("RefinedSDM m_max (finest steps per period)", self.m_max, minimum=m2, error=LobeError)

    @property
    def name(self) -> str:
        return "sdm"

    @property
    def m(self) -> int:
        """The first level."""
        return self.base.m

    @property
    def angle_tol_rad(self) -> float:
        return self.base.angle_tol_rad


def same_lobe(bif_a, freq_a, bif_b, freq_b, period_s) -> np.ndarray:
    """Whether two levels found the same lobe at each speed (arrays (S,)).

    Same bifurcation type, and chatter frequencies closer than a quarter of the principal
    frequency ``1 / T``: on one lobe the frequency moves with the discretization by its own
    O(1/m^2) error, while the critical multipliers of two different lobes at one speed differ in
    angle by an O(1) part of a turn, i.e. their frequencies by an O(1) part of ``1 / T`` (two flip
    lobes by exactly ``1 / T``). Both levels stable up to the searched depth ("none") is the same.
    """
    bif_a, bif_b = np.asarray(bif_a), np.asarray(bif_b)
    fa, fb = np.asarray(freq_a, dtype=float), np.asarray(freq_b, dtype=float)
    T = np.asarray(period_s, dtype=float)
    with np.errstate(invalid="ignore"):
        close = np.abs(fa - fb) * T < 0.25
    none = (bif_a == "none") & (bif_b == "none")
    return none | ((bif_a == bif_b) & close)


def combine_levels(coarse, fine, same, tol: float, ratio: float = 2.0):
    """Value, error (m), converged flag of two levels' critical depths (arrays (S,), m).

    ``ratio``: the levels' actual step ratio ``m_f / m_c`` (> 1). Richardson (order 2) where the
    levels find the same lobe; the finer depth with the whole difference as its error where they do
    not (or where only one found a limit). Converged: same lobe and error <= ``tol * value`` (both
    inf: converged, error 0).
    """
    coarse, fine = np.asarray(coarse, dtype=float), np.asarray(fine, dtype=float)
    value, err = (np.asarray(x, dtype=float) for x in richardson(coarse, fine, ratio=ratio))
    value, err = np.atleast_1d(value).copy(), np.atleast_1d(err).copy()
    same = np.atleast_1d(np.asarray(same, bool))
    with np.errstate(invalid="ignore"):
        jump = np.where(np.isfinite(coarse) & np.isfinite(fine), np.abs(fine - coarse), np.inf)
    value = np.where(same, value, fine)
    err = np.where(same, err, np.where(coarse == fine, 0.0, jump))
    both_inf = np.isinf(coarse) & np.isinf(fine)
    with np.errstate(invalid="ignore"):
        ok = same & (both_inf | (np.isfinite(value) & (err <= tol * value)))
    return value, err, ok


def next_level(m: int, ratio: float = 2.0) -> int:
    """The level after ``m``: ``ratio m`` rounded half up to an integer (``2 m`` exactly for 2)."""
    return int(math.floor(m * ratio + 0.5))


def level_pairs(m0: int, m_max: int, ratio: float = 2.0) -> list[tuple[int, int]]:
    """The (coarse, fine) level pairs of the refinement: (m0, m1), (m1, m2), ... with
    ``m_(k+1) = next_level(m_k, ratio)``, up to ``m_max``."""
    out = []
    m = m0
    while (m2 := next_level(m, ratio)) <= m_max:
        out.append((m, m2))
        m = m2
    return out
