"""``solve`` (lobe diagram) and ``stability`` (one operating point), and their results."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Callable, Union, cast

import numpy as np

from robolobes.core.numerics import level_change
from robolobes.core.validate import shown
from robolobes.core.threads import blas_single_threaded
from robolobes.core.verdict import Verdict
from robolobes.core.validate import finite, integer, readonly

from ._errors import LobeError
from .problem import LobeProblem
from .collocation import Collocation, CollocationEngine
from .refine import RefinedSDM, combine_levels, level_pairs, next_level, same_lobe
from .sdm import Bifurcation, SDMEngine, SemiDiscretization, classify_multiplier
from .zoa import ZOAEngine, ZeroOrder

__all__ = ["Method", "LobeResult", "StabilityPoint", "solve", "stability", "depth_verdict", "Verdict",
           "ProgressCallback"]

Method = Union[RefinedSDM, SemiDiscretization, ZeroOrder, Collocation]
ProgressCallback = Callable[[int, int], None]


def _check_method(method) -> None:
    if not isinstance(method, (RefinedSDM, SemiDiscretization, ZeroOrder, Collocation)):
        raise LobeError(f"method must be RefinedSDM(...), SemiDiscretization(...), ZeroOrder(...) or Collocation(...), "
                        f"got {method!r}")


def _check_speeds(speeds_rpm) -> np.ndarray:
    try:
        s = np.array(speeds_rpm, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise LobeError(f"speeds_rpm must be an array of spindle speeds in rpm, got {speeds_rpm!r}") from None
    if s.size == 0:
        raise LobeError("speeds_rpm is empty; give at least one spindle speed in rpm (> 0)")
    bad = ~np.isfinite(s) | (s <= 0)
    if bad.any():
        raise LobeError(f"speeds_rpm must be finite and > 0 rpm; got {shown(s[bad][0])} at index {int(np.flatnonzero(bad)[0])}")
    return s


def _check_depth(name: str, v) -> float:
    return finite(f"{name} (depth, m)", v, positive=True, error=LobeError)


@dataclass(frozen=True, eq=False)
class StabilityPoint:
    """Stability of one operating point (speed, depth).

    Attributes
    ----------
    spindle_rpm, depth_m : float
    spectral_radius : float
        ``max |mu|`` of the monodromy at the method's finest ``m`` (NaN for ZeroOrder).
    critical_multiplier : complex
        The multiplier of largest modulus (NaN for ZeroOrder).
    verdict : robolobes.core.verdict.Verdict
        Decided on the depth: ``depth < limit - err`` "stable", ``> limit + err`` "unstable", else
        "undetermined" (the discretization error estimate ``err`` of the Richardson limit straddles the
        cut depth); ``verdict.reason`` says which, with the numbers.
    margin : float
        ``depth_limit / depth - 1`` (> 0 stable): how much deeper one may cut at this speed.
        ``inf`` when no limit was found below ``depth_max_m`` (then ``margin`` >= that bound).
    margin_error : float
        Bound on ``margin`` from the discretization error of ``depth_limit`` (NaN for ZeroOrder: not
        estimated).
    radius_margin : float
        ``1 - spectral_radius`` (NaN for ZeroOrder).
    depth_limit_m, depth_limit_error_m : float
        Critical depth at this speed (smallest unstable depth, m) and its error estimate (:mod:`lobes.refine`;
        NaN for ZeroOrder: not estimated).
    chatter_freq_hz : float
        Frequency of the critical Floquet solution at the operating point, Hz.
    bifurcation : {"hopf", "flip", "fold", "none"}
        Type of the critical multiplier at the operating point (by its angle).
    limit_bifurcation : str
        Type at the stability limit of this speed.
    limit_chatter_freq_hz : float
    history : tuple of dict
        Per discretization level: ``m``, ``depth_limit_m``, ``spectral_radius``, ``stable``.
    limit_status : {"converged", "unconverged", "no-estimate"}
        Of ``depth_limit_m`` at the last pair of levels, by the rule of :mod:`lobes.refine` (the same
        as the diagram's); "no-estimate" for ZeroOrder.
    """

    spindle_rpm: float
    depth_m: float
    spectral_radius: float
    critical_multiplier: complex
    verdict: Verdict
    margin: float
    margin_error: float
    radius_margin: float
    depth_limit_m: float
    depth_limit_error_m: float
    chatter_freq_hz: float
    bifurcation: Bifurcation
    limit_bifurcation: Bifurcation
    limit_chatter_freq_hz: float
    method: Method
    history: tuple = ()
    limit_status: str = "no-estimate"

    @property
    def stable(self) -> bool | None:
        """``verdict.stable``: True, False, or None when undetermined."""
        return self.verdict.stable


@dataclass(frozen=True, eq=False)
class LobeResult:
    """A stability lobe diagram.

    Attributes
    ----------
    problem : LobeProblem
    method : SemiDiscretization or ZeroOrder
    spindle_rpm : array (S,), rpm
    depth_limit_m : array (S,), m
        Smallest unstable axial depth at each speed (``inf``: stable up to ``stats['depth_max_m']``).
    depth_error_m : array (S,), m
        Error estimate of ``depth_limit_m`` (:mod:`lobes.refine`): ``|b_2m - b_m| / 3`` of the last
        pair of levels where they found the same lobe, ``|b_2m - b_m|`` where they did not (inf where
        only one found a limit, 0 where neither did); NaN for a single level (a
        ``SemiDiscretization`` without ``richardson``) and for ZeroOrder.
    chatter_freq_hz : array (S,), Hz
    bifurcation : array (S,) of str in {"hopf", "flip", "fold", "none"}
    stats : dict
        ``wall_s``, ``evaluations`` (monodromy spectra computed), ``m``, ``steps_per_period``,
        ``monodromy_size``, ``rounds``, ``max_bracket_rel`` (final relative bracket width); refined:
        ``m_levels``, ``m_max``, ``tol``, ``n_unconverged``, ...
    status : array (S,) of str
        "converged" (error estimate <= tol of the value, same lobe at both levels), "unconverged"
        (not so at the finest level ``m_max``: the speed is not resolved) or "no-estimate".
    m_final : array (S,) of int
        Finer level of the pair that gave each speed's value (the single level without estimate).
    """

    problem: LobeProblem
    method: Method
    spindle_rpm: np.ndarray
    depth_limit_m: np.ndarray
    chatter_freq_hz: np.ndarray
    bifurcation: np.ndarray
    depth_error_m: np.ndarray
    stats: dict = field(default_factory=dict)
    status: np.ndarray | None = None
    m_final: np.ndarray | None = None

    def __post_init__(self) -> None:
        for k in ("spindle_rpm", "depth_limit_m", "chatter_freq_hz", "depth_error_m"):
            object.__setattr__(self, k, readonly(getattr(self, k), float))
        object.__setattr__(self, "bifurcation", readonly(self.bifurcation, "<U4"))
        S = len(self.spindle_rpm)
        status = np.full(S, "no-estimate") if self.status is None else self.status
        object.__setattr__(self, "status", readonly(status, "<U11"))
        m_final = np.zeros(S, int) if self.m_final is None else self.m_final
        object.__setattr__(self, "m_final", readonly(m_final, int))

    def evaluate(self, spindle_rpm: float, depth_m: float, **kw) -> StabilityPoint:
        """Stability at ``(spindle_rpm, depth_m)`` with this result's problem and method."""
        cut = replace(self.problem.cut, spindle_rpm=float(spindle_rpm), ap_m=float(depth_m))
        return stability(replace(self.problem, cut=cut), self.method, **kw)

    def minimum(self) -> tuple[float, float, str]:
        """(rpm, depth_limit_m, bifurcation) at the lowest limit of the diagram."""
        j = int(np.argmin(self.depth_limit_m))
        return float(self.spindle_rpm[j]), float(self.depth_limit_m[j]), str(self.bifurcation[j])


# ---------------------------------------------------------------------------------------------
def _coarse(rho_fn, rpm: np.ndarray, rho0: np.ndarray, grid: np.ndarray, stats: dict):
    """Scan the depths ``grid`` (increasing) up to the first unstable one at each speed.

    Returns ``lo, glo, hi, ghi`` (last stable depth and ``rho - 1`` there, first unstable depth and
    ``rho - 1``; ``hi`` is NaN where no grid depth is unstable).
    """
    S = len(rpm)
    lo = np.zeros(S)
    glo = rho0 - 1.0
    hi = np.full(S, np.nan)
    ghi = np.full(S, np.nan)
    active = np.ones(S, bool)
    for d in grid:
        idx = np.flatnonzero(active)
        if len(idx) == 0:
            break
        g = rho_fn(rpm[idx], np.full(len(idx), d)) - 1.0
        stats["evaluations"] += len(idx)
        stats["rounds"] += 1
        un = g >= 0
        hi[idx[un]] = d
        ghi[idx[un]] = g[un]
        lo[idx[~un]] = d
        glo[idx[~un]] = g[~un]
        active[idx[un]] = False
    return lo, glo, hi, ghi


def _refine(rho_fn, rpm, lo, glo, hi, ghi, rtol: float, stats: dict, max_iter: int = 100,
            straddle: bool = True, eig_fn=None, mu_hi=None, tlo=None, pair_width: float = 0.0):
    """Illinois regula falsi on ``rho - 1`` inside the brackets (bisection every 4th step), until
    ``hi - lo <= rtol * hi``. Returns the root estimate (inf where there is no bracket) and ``hi``.

    ``rho_fn(rpm, depth) -> rho`` (B,) is the spectral radius. With ``eig_fn(rpm, depth) -> ev``
    (B, N) complex (all multipliers; used instead of ``rho_fn``) the interpolation follows the
    multiplier that is critical at the unstable end (the one nearest it in the complex plane) at the
    stable end too: below the limit the spectral radius is often a structural multiplier nearly
    constant in depth (``rho - 1`` has a kink at the limit, and regula falsi crawls), while the
    critical one's modulus is smooth through the limit. The bracket itself is always decided by the
    spectral radius.

    With ``straddle``, from the second step on each regula falsi point ``x`` is replaced by the pair
    ``x (1 -+ 0.45 rtol)`` evaluated in one batch: once the interpolation is within ``0.45 rtol`` of
    the root the pair brackets it and the search ends with a bracket of ``0.9 rtol``. Where the pair
    does not straddle, its nearer point is the step; from the first step already where the bracket
    is at most ``pair_width`` (relative) wide (the interpolation is then accurate). ``mu_hi`` (S,) complex: the critical multiplier
    at ``hi`` when known, ``tlo`` (S,) the followed multiplier's ``|mu| - 1`` at ``lo``.
    """
    lo, glo, hi, ghi = (np.array(x, dtype=float) for x in (lo, glo, hi, ghi))
    S = len(rpm)
    found = np.isfinite(hi)
    side = np.zeros(S, int)
    # the followed multiplier's |mu| - 1 at lo, and the critical multiplier at hi (NaN: unknown)
    tlo = glo.copy() if tlo is None else np.minimum(np.array(tlo, dtype=float), glo)
    mu_ref = np.full(S, np.nan, complex) if mu_hi is None else np.array(mu_hi, dtype=complex)
    it = 0
    while True:
        idx = np.flatnonzero(found & (hi - lo > rtol * hi))
        if len(idx) == 0 or it >= max_iter:
            break
        it += 1
        a, b, ga, gb = lo[idx], hi[idx], tlo[idx], ghi[idx]
        with np.errstate(divide="ignore", invalid="ignore"):
            x = (a * gb - b * ga) / (gb - ga)
        bad = ~np.isfinite(x) | (x <= a) | (x >= b) | (it % 4 == 0)
        x = np.where(bad, 0.5 * (a + b), x)
        pair = np.zeros(len(idx), bool)
        if straddle:
            c = 0.45 * rtol
            pair = ~bad & (x * (1 - c) > a) & (x * (1 + c) < b) & ((it >= 2) | (b - a <= pair_width * b))
        x1 = np.where(pair, x * (1 - 0.45 * rtol), x)
        x2 = x[pair] * (1 + 0.45 * rtol)
        need_ref = np.zeros(len(idx), bool) if eig_fn is None else ~np.isfinite(mu_ref[idx])
        xr = b[need_ref]
        rr = np.concatenate([rpm[idx], rpm[idx[pair]], rpm[idx[need_ref]]])
        xx = np.concatenate([x1, x2, xr])
        n1, n2 = len(idx), len(idx) + len(x2)
        if eig_fn is None:
            rad = rho_fn(rr, xx)
            trk = rad
        else:
            ev = eig_fn(rr, xx)
            aev = np.abs(ev)
            k = np.arange(len(ev))
            rad = aev.max(axis=1)
            dom = ev[k, np.argmax(aev, axis=1)]
            ref = mu_ref[idx].copy()
            ref[need_ref] = dom[n2:]
            refs = np.concatenate([ref, ref[pair], ref[need_ref]])
            trk = aev[k, np.argmin(np.abs(ev - refs[:, None]), axis=1)]
        gg = rad - 1.0
        tt = np.minimum(trk - 1.0, gg)
        stats["evaluations"] += len(gg)
        stats["rounds"] += 1
        if eig_fn is not None:
            mu_ref[idx[need_ref]] = dom[n2:]
        g, g2, t, t2 = gg[:n1], gg[n1:n2], tt[:n1], tt[n1:n2]
        # a pair whose lower point is stable steps to its upper point (straddling or not)
        up = np.zeros(len(idx), bool)
        up[pair] = g[pair] < 0
        gl, tl = g.copy(), t.copy()              # the lower point's values (a straddling pair)
        xs = x1.copy()
        ip = np.flatnonzero(pair)
        xs[ip] = np.where(up[ip], x2, x1[ip])
        g, t = g.copy(), t.copy()
        g[ip] = np.where(up[ip], g2, g[ip])
        t[ip] = np.where(up[ip], t2, t[ip])
        un = g >= 0
        lo_i, glo_i, tlo_i, hi_i, ghi_i, side_i = lo[idx], glo[idx], tlo[idx], hi[idx], ghi[idx], side[idx]
        # Illinois: an end kept twice in a row has its function value halved
        tlo_i = np.where(un & (side_i == 1), tlo_i / 2, tlo_i)
        ghi_i = np.where(~un & (side_i == -1), ghi_i / 2, ghi_i)
        hi_i = np.where(un, xs, hi_i)
        ghi_i = np.where(un, g, ghi_i)
        lo_i = np.where(un, lo_i, xs)
        glo_i = np.where(un, glo_i, g)
        tlo_i = np.where(un, tlo_i, t)
        # a straddling pair: its lower point is the new stable end
        strad = up & un
        lo_i = np.where(strad, x1, lo_i)
        glo_i = np.where(strad, gl, glo_i)
        tlo_i = np.where(strad, tl, tlo_i)
        side_i = np.where(strad, 0, np.where(un, 1, -1))
        if eig_fn is not None:
            mu_i = mu_ref[idx]
            d1 = dom[:n1].copy()
            d1[ip] = np.where(up[ip], dom[n1:n2], dom[:n1][ip])
            mu_ref[idx] = np.where(un, d1, mu_i)
        lo[idx], glo[idx], tlo[idx], hi[idx], ghi[idx], side[idx] = lo_i, glo_i, tlo_i, hi_i, ghi_i, side_i
    with np.errstate(divide="ignore", invalid="ignore"):
        est = np.where(found, (lo * ghi - hi * tlo) / (ghi - tlo), np.inf)
    est = np.where(found & ~(np.isfinite(est) & (est >= lo) & (est <= hi)), 0.5 * (lo + hi), est)
    rel = np.where(found, (hi - lo) / np.where(found, hi, 1.0), 0.0)
    stats["max_bracket_rel"] = max(stats.get("max_bracket_rel", 0.0), float(rel.max()) if S else 0.0)
    return est, hi


def _grid(depth_max: float, n_coarse: int) -> np.ndarray:
    return depth_max * (np.arange(1, n_coarse + 1) / n_coarse) ** 2


def _search(rho_fn, rpm: np.ndarray, rho0: np.ndarray, depth_max: float, n_coarse: int, rtol: float,
            stats: dict, max_iter: int = 100, straddle: bool = True, eig_fn=None):
    """Smallest depth with spectral radius >= 1 at each speed.

    Bracketing: the depth is scanned on ``depth_max (j / n_coarse)^2``, j = 1..n_coarse (dense at
    small depths) up to the first unstable point; an unstable pocket thinner than the local grid
    spacing can be missed (the spectral radius need not be monotonic in depth). The bracket is
    then refined by the Illinois variant of regula falsi on ``rho - 1`` (with a bisection
    safeguard) until its width is below ``rtol * depth``.

    Returns ``est, hi, found``.
    """
    lo, glo, hi, ghi = _coarse(rho_fn, rpm, rho0, _grid(depth_max, n_coarse), stats)
    est, hi = _refine(rho_fn, rpm, lo, glo, hi, ghi, rtol, stats, max_iter, straddle, eig_fn)
    return est, hi, np.isfinite(hi)


def _walk(rho_fn, rpm: np.ndarray, grid: np.ndarray, j0: np.ndarray, step: int, stats: dict):
    """Walk along ``grid`` from index ``j0`` (per speed) in direction ``step`` (+1 up, -1 down) until
    ``rho - 1`` changes sign: up, to the first unstable depth; down, to the first stable one.

    Returns ``j, g, gprev``: the index where the walk stopped (``len(grid)`` up or ``-1`` down when
    it ran off the grid), ``rho - 1`` there and at the index before it (``j - step``); NaN where
    not evaluated.
    """
    j = np.array(j0, dtype=int)
    g = np.full(len(rpm), np.nan)
    gprev = np.full(len(rpm), np.nan)
    active = (j >= 0) & (j < len(grid))
    while active.any():
        idx = np.flatnonzero(active)
        gi = rho_fn(rpm[idx], grid[j[idx]]) - 1.0
        stats["evaluations"] += len(idx)
        stats["rounds"] += 1
        stop = (gi >= 0) if step > 0 else (gi < 0)
        g[idx[stop]] = gi[stop]
        go = idx[~stop]
        gprev[go] = gi[~stop]
        j[go] += step
        active[idx[stop]] = False
        active[go] = (j[go] >= 0) & (j[go] < len(grid))
    return j, g, gprev


def _prescanned_search(engine: SDMEngine, pre: SDMEngine, rpm, rho0, depth_max, n_coarse, rtol, stats,
                       straddle: bool = True):
    """SDM search whose coarse scan is made with the cheap exact-free-decay scheme, then VERIFIED.

    The two schemes discretize the same equation to O(dt^2), so their brackets agree except where
    the spectral radius is within that error of 1 at a grid depth; :func:`_verified_search` checks
    each bracket with the SDM itself. The result is the SDM's own limit, bracketed by SDM
    evaluations of both signs.
    """
    grid = _grid(depth_max, n_coarse)
    pst = {"evaluations": 0, "rounds": 0}
    lo, _, hi, _ = _coarse(lambda s, d: pre.multipliers(s, d)[0], rpm, rho0, grid, pst)
    stats["prescan_evaluations"] = stats.get("prescan_evaluations", 0) + pst["evaluations"]
    return _verified_search(engine, rpm, rho0, lo, hi, grid, rtol, stats, straddle)


#: Half-width of the warm-start bracket of a finer level around the coarser level's limit,
#: relative. A converged pair has ``|b_2m - b_m| <= 3 tol b`` (estimate ``|b_2m - b_m| / 3 <= tol``),
#: 3 % at the default 1 % (1.25 % with ``RefinedSDM(ratio=1.5)``); 4 % covers that with margin.
#: Where the finer level's sign change is not inside (another lobe, a larger shift), the grid
#: bracket is verified instead (same answer, more evaluations).
_WARM_HALF_WIDTH = 0.04


#: Adaptive warm start ("fast"): every ``_WARM_PROBE_EVERY``-th speed is a probe with the full
#: +-4 % bracket; the others get ``clip(2 |shift| + 0.2 %, 0.5 %, 4 %)`` from the largest relative
#: level-to-level shift of the two nearest probes (in rpm), and a straddling pair at once when
#: their bracket is at most ``_WARM_PAIR_WIDTH`` wide. On the TX200 diagrams the shifts 40 -> 80
#: are within +-0.6 %, so most brackets are +-1 % and closed by one pair.
_WARM_PROBE_EVERY = 5
_WARM_PAIR_WIDTH = 0.025
#: Smallest structure (states) with the adaptive warm start. Its extra rounds (probes, narrow
#: brackets, retries) cost more than they save where one evaluation is cheap: on the 2-mode model
#: (4 states) of ``bench_lobes.py --targets`` it took 0.55 s against 0.49 s with +-4 %.
_ADAPTIVE_MIN_STATES = 12
#: Speeds per batch of :func:`solve` for structures of at least ``_ADAPTIVE_MIN_STATES`` states.
_CHUNK = 50


def _warm_search(engine: SDMEngine, rpm, rho0, start, grid, rtol, stats, adaptive: bool = False):
    """Critical depths at a finer level from a coarser level's limits ``start`` (S,), m.

    The bracket ``start (1 -+ w)`` is checked with ``engine`` (stable at its lower end, unstable
    at its upper end, one batch) and refined (:func:`_refine`); ``w = 0.04``, or with ``adaptive``
    the narrower width of :data:`_WARM_PROBE_EVERY` (retried at 0.04 where it does not hold).
    Where the check fails, or ``start`` is inf or too close to ``depth_max``, the coarser grid
    bracket is verified and refined as without the warm start (:func:`_verified_search`).
    Returns ``est, hi, found`` as :func:`_search`.
    """
    start = np.asarray(start, dtype=float)
    S = len(rpm)
    w = _WARM_HALF_WIDTH
    out = (np.full(S, np.inf), np.full(S, np.nan), np.zeros(S, bool))
    ok = np.zeros(S, bool)
    cand = np.flatnonzero(np.isfinite(start) & (start * (1 + w) < grid[-1]))
    if adaptive and len(cand) > _WARM_PROBE_EVERY:
        probe = cand[::_WARM_PROBE_EVERY]
        _warm_try(engine, rpm, start, probe, np.full(len(probe), w), rtol, stats, out, ok)
        rest = np.setdiff1d(cand, probe)
        wr = _warm_widths(rpm, start, out[0], probe[ok[probe]], rest)
        _warm_try(engine, rpm, start, rest, wr, rtol, stats, out, ok, "warm_narrow_rejected")
        again = rest[~ok[rest] & (wr < w)]
        _warm_try(engine, rpm, start, again, np.full(len(again), w), rtol, stats, out, ok)
    else:
        _warm_try(engine, rpm, start, cand, np.full(len(cand), w), rtol, stats, out, ok)
    est, hi, found = out
    rest = np.flatnonzero(~ok)
    if len(rest):
        lo_g, hi_g = _grid_bracket(grid, start[rest])
        e, h, f = _verified_search(engine, rpm[rest], rho0[rest], lo_g, hi_g, grid, rtol, stats)
        est[rest], hi[rest], found[rest] = e, h, f
    return est, hi, found


def _warm_widths(rpm, start, est, probes, rest) -> np.ndarray:
    """Half-widths (len(rest),) of the warm brackets at the speeds ``rest`` from the relative shifts
    ``est / start - 1`` at the successful ``probes`` (index arrays into ``rpm`` (S,))."""
    w = np.full(len(rest), _WARM_HALF_WIDTH)
    if len(probes) == 0 or len(rest) == 0:
        return w
    shift = np.abs(est[probes] / start[probes] - 1)
    d = np.abs(rpm[rest][:, None] - rpm[probes][None, :])
    near = np.argsort(d, axis=1, kind="stable")[:, :2]
    big = shift[near].max(axis=1)
    return np.clip(2 * big + 0.002, 0.005, _WARM_HALF_WIDTH)


def _warm_try(engine: SDMEngine, rpm, start, idx, w, rtol, stats, out, ok, counter: str = "warm_rejected") -> None:
    """Warm brackets ``start (1 -+ w)`` at the speeds ``idx`` (index array, ``w`` (len(idx),)):
    verified in one batch, refined where they hold; fills ``out = (est, hi, found)`` and ``ok``
    there, counts the others in ``stats[counter]``."""
    if len(idx) == 0:
        return
    a, b = start[idx] * (1 - w), start[idx] * (1 + w)
    n = len(idx)
    ev = engine.spectra(np.concatenate([rpm[idx], rpm[idx]]), np.concatenate([a, b]))
    stats["evaluations"] += 2 * n
    stats["rounds"] += 1
    aev = np.abs(ev)
    g = aev.max(axis=1) - 1.0
    ga, gb = g[:n], g[n:]
    mu_b = ev[n:][np.arange(n), np.argmax(aev[n:], axis=1)]
    ta = aev[:n][np.arange(n), np.argmin(np.abs(ev[:n] - mu_b[:, None]), axis=1)] - 1.0
    good = (ga < 0) & (gb >= 0)
    j = idx[good]
    ok[j] = True
    if len(j):
        narrow = _WARM_PAIR_WIDTH if np.any(w < _WARM_HALF_WIDTH) else 0.0
        e, h = _refine(lambda s, d: engine.multipliers(s, d)[0], rpm[j], a[good], ga[good], b[good], gb[good],
                       rtol, stats, eig_fn=engine.spectra, mu_hi=mu_b[good], tlo=ta[good], pair_width=narrow)
        out[0][j], out[1][j], out[2][j] = e, h, True
    stats[counter] = stats.get(counter, 0) + int((~good).sum())


def _grid_bracket(grid: np.ndarray, est: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Grid bracket ``(lo, hi)`` around estimated limits (S,): ``grid[j-1] < est <= grid[j]`` (lo = 0
    below the first depth; hi NaN where ``est`` is inf or beyond the grid)."""
    est = np.asarray(est, dtype=float)
    j = np.searchsorted(grid, np.where(np.isfinite(est), est, np.inf))
    inside = j < len(grid)
    hi = np.where(inside, grid[np.minimum(j, len(grid) - 1)], np.nan)
    lo = np.where(j > 0, grid[np.maximum(j - 1, 0)], 0.0)
    lo = np.where(inside, lo, grid[-1])
    return lo, hi


def _verified_search(engine: SDMEngine, rpm, rho0, lo, hi, grid, rtol, stats, straddle: bool = True):
    """Refine brackets ``[lo, hi]`` on ``grid`` (from a cheaper scheme or a coarser level), VERIFIED.

    Each bracket is checked with ``engine`` in one batch: stable at ``lo`` (or ``lo = 0``),
    unstable at ``hi``; stable at ``depth_max`` (``grid[-1]``) when no bracket was given (``hi``
    NaN). Where ``engine`` disagrees it walks along the grid from there to its own sign change: up
    from ``hi`` when it is stable there, down from ``lo`` (or ``depth_max``) when it is unstable
    there. (The stable verdicts at the grid depths below ``lo`` are kept.) Returns ``est, hi,
    found`` as :func:`_search`.
    """
    sdm = lambda s, d: engine.multipliers(s, d)[0]
    depth_max = grid[-1]
    lo, hi = np.array(lo, dtype=float), np.array(hi, dtype=float)
    S = len(rpm)
    glo = rho0 - 1.0
    ghi = np.full(S, np.nan)
    found = np.isfinite(hi)
    jh = np.flatnonzero(found)
    jl = jh[lo[jh] > 0]
    jn = np.flatnonzero(~found)
    idx = np.concatenate([jh, jl, jn])
    mu_hi = np.full(S, np.nan, complex)    # critical multiplier at hi, for _refine to follow
    tlo = np.full(S, np.nan)
    if len(idx):
        ev = engine.spectra(rpm[idx], np.concatenate([hi[jh], lo[jl], np.full(len(jn), depth_max)]))
        aev = np.abs(ev)
        g = aev.max(axis=1) - 1.0
        stats["evaluations"] += len(idx)
        stats["rounds"] += 1
        nh, nl = len(jh), len(jl)
        ghi[jh] = g[:nh]
        glo[jl] = g[nh:nh + nl]
        gn = g[nh + nl:]
        mu_hi[jh] = ev[:nh][np.arange(nh), np.argmax(aev[:nh], axis=1)]
        ref = mu_hi[jl]
        tlo[jl] = aev[nh:nh + nl][np.arange(nl), np.argmin(np.abs(ev[nh:nh + nl] - ref[:, None]), axis=1)] - 1.0
    else:
        gn = np.zeros(0)
    unstable_lo = np.zeros(S, bool)
    unstable_lo[jl] = glo[jl] >= 0
    unstable_lo[jn[gn >= 0]] = True
    down = np.flatnonzero(unstable_lo)
    up = np.flatnonzero(found & ~unstable_lo & (ghi < 0))
    stats["prescan_rejected"] = stats.get("prescan_rejected", 0) + len(up) + len(down)
    gidx = lambda d: np.searchsorted(grid, d)  # index of a grid depth
    if len(up):  # SDM stable at the prescan's first unstable depth: on up the grid
        j0 = gidx(hi[up]) + 1
        j, g, gp = _walk(sdm, rpm[up], grid, j0, +1, stats)
        glo[up] = np.where(j > j0, gp, ghi[up])
        lo[up] = grid[j - 1]
        off = j >= len(grid)  # stable at every grid depth up to depth_max: no limit
        hi[up] = np.where(off, np.nan, grid[np.minimum(j, len(grid) - 1)])
        ghi[up] = g
    if len(down):  # SDM unstable at the prescan's last stable depth (or depth_max): down the grid
        js = np.where(found[down], gidx(lo[down]), len(grid) - 1)
        gs = np.full(len(down), np.nan)
        gs[found[down]] = glo[down[found[down]]]
        nf = down[~found[down]]
        gs[~found[down]] = gn[np.searchsorted(jn, nf)]
        j, g, gp = _walk(sdm, rpm[down], grid, js - 1, -1, stats)
        hi[down] = grid[j + 1]
        ghi[down] = np.where(j + 1 < js, gp, gs)
        off = j < 0  # unstable at every grid depth below: bracket [0, grid[0]]
        lo[down] = np.where(off, 0.0, grid[np.maximum(j, 0)])
        glo[down] = np.where(off, rho0[down] - 1.0, g)
    moved = np.zeros(S, bool)
    moved[up], moved[down] = True, True
    mu_hi[moved], tlo[moved] = np.nan, np.nan
    tlo = np.where(np.isfinite(tlo), tlo, glo)
    if not straddle:
        est, hi = _refine(sdm, rpm, lo, glo, hi, ghi, rtol, stats, straddle=False)
    else:
        est, hi = _refine(sdm, rpm, lo, glo, hi, ghi, rtol, stats, eig_fn=engine.spectra, mu_hi=mu_hi, tlo=tlo)
    return est, hi, np.isfinite(hi)


def _prescan_pays(method) -> bool:
    """Whether a free-exact prescan is cheaper than the scan at ``method.m``: always for the SDM
    (its step exponentials depend on the depth), for the free-exact scheme only at a coarser
    ``prescan_m < m``, never for other schemes (collocation: ``prescan = False``)."""
    if method.scheme == "sdm":
        return True
    return method.scheme == "free-exact" and method.prescan_m is not None and method.prescan_m < method.m


def _sdm_limits(engine: SDMEngine, rpm: np.ndarray, depth_max: float, n_coarse: int, rtol: float,
                stats: dict, progress: ProgressCallback | None, chunk: int | None, done0: int = 0, total: int | None = None,
                start: np.ndarray | None = None):
    """Critical depths (m), chatter frequencies (Hz) and bifurcations at ``rpm`` (S,) for one level.

    ``start`` (S,): limits of a coarser level (m; inf: none found); their grid brackets are verified
    and refined (:func:`_verified_search`) instead of a new coarse scan.
    """
    S = len(rpm)
    total = total if total is not None else S
    if chunk is None:  # small structures: one batch (cheap evaluations, the fixed cost per round counts)
        chunk = _CHUNK if engine.ns >= _ADAPTIVE_MIN_STATES else max(S, 1)
    depth = np.full(S, np.inf)
    freq = np.full(S, np.nan)
    bif = np.full(S, "none", dtype="<U4")
    lam = engine.ss.poles
    fast = engine.method.search in ("fast", "fast-wide")
    pre = None
    use_pre = engine.method.prescan if engine.method.prescan is not None else engine.ns >= 12
    if use_pre and start is None and _prescan_pays(engine.method):
        pre_m = engine.method.prescan_m or engine.method.m
        pre = SDMEngine(engine.problem, replace(engine.method, scheme="free-exact", m=pre_m), depth_max)
    for c0 in range(0, S, chunk):
        r = rpm[c0:c0 + chunk]
        T = engine.period_s(r)
        rho0 = np.max(np.abs(np.exp(np.outer(T, lam))), axis=1)
        if start is not None and fast:
            est, hi, found = _warm_search(engine, r, rho0, start[c0:c0 + chunk], _grid(depth_max, n_coarse), rtol,
                                          stats, adaptive=engine.method.search == "fast" and engine.ns >= _ADAPTIVE_MIN_STATES)
        elif start is not None:
            grid = _grid(depth_max, n_coarse)
            lo, hi = _grid_bracket(grid, start[c0:c0 + chunk])
            est, hi, found = _verified_search(engine, r, rho0, lo, hi, grid, rtol, stats, straddle=False)
        elif pre is not None:
            est, hi, found = _prescanned_search(engine, pre, r, rho0, depth_max, n_coarse, rtol, stats, fast)
        else:
            est, hi, found = _search(lambda s, d: engine.multipliers(s, d)[0], r, rho0, depth_max, n_coarse,
                                     rtol, stats, straddle=fast, eig_fn=engine.spectra if fast else None)
        depth[c0:c0 + chunk] = est
        if found.any():
            j = np.flatnonzero(found)
            n0 = engine.critical_evaluations
            _, mu, fr = engine.critical(r[j], hi[j])
            stats["evaluations"] += engine.critical_evaluations - n0
            freq[c0 + j] = fr
            bif[c0 + j] = classify_multiplier(mu, engine.method.angle_tol_rad)
        if progress is not None:
            progress(done0 + min(c0 + chunk, S), total)
    return depth, freq, bif


@blas_single_threaded
def solve(problem: LobeProblem, method: Method | None = None, speeds_rpm=None, *, depth_max_m: float = 0.01,
          coarse_points: int = 16, rtol: float = 1e-3, progress: ProgressCallback | None = None,
          chunk: int | None = None) -> LobeResult:
    """Stability lobe diagram: the critical axial depth at each spindle speed.

    Parameters
    ----------
    problem : LobeProblem
        Its cut gives the radial immersion, milling mode and feed (runout); speed and depth vary.
    method : RefinedSDM, SemiDiscretization or ZeroOrder
        Default ``RefinedSDM()``: SDM levels m = 40, 80, ... per speed until the error estimate is
        below 1 % (:mod:`lobes.refine`). A ``SemiDiscretization`` is one level (no estimate).
    speeds_rpm : array (S,)
        Spindle speeds, rpm (> 0).
    depth_max_m : float
        Largest depth searched, m; speeds stable up to it get ``inf``.
    coarse_points : int
        Depths of the coarse bracketing scan (quadratically spaced), >= 2 (SDM only).
    rtol : float
        Relative width of the final bracket on the critical depth at each level (SDM only); the
        default 1e-3 is well below the 1 % error target.
    progress : callable(done, total), optional
        Called after each chunk of speeds.
    chunk : int or None
        Speeds evaluated together (vectorized); ``progress`` is called after each chunk. None
        (default): 50 for structures of 12 states or more, all the speeds of a level at once for
        smaller ones (their evaluations are cheap, so the fixed cost of each batch counts: the
        200-speed 2-mode diagram of ``bench/bench_lobes.py --targets`` took 0.43 s against 0.50 s
        in chunks of 50).

    Returns
    -------
    LobeResult

    Example: the symmetric 2-DOF benchmark of Insperger et al. (2003), a/D = 0.05 down-milling,
    at its flip-lobe minimum near 18 700 rpm (about 0.85 mm).

    >>> from robolobes.cases.milling import Cut, CuttingLaw, Tool
    >>> from robolobes.lobes import LobeProblem, Mode, ModalStructure
    >>> modes = ModalStructure(tuple(Mode(922.0, 0.011, 1.34003e6, d) for d in ((1.0, 0.0), (0.0, 1.0))))
    >>> p = LobeProblem(modes, Tool(diameter_m=0.01, teeth=2), Cut(ae_m=0.5e-3, ap_m=1e-3, spindle_rpm=18700.0),
    ...                 CuttingLaw(ktc_pa=6e8, krc_pa=2e8))
    >>> round(float(solve(p, SemiDiscretization(m=40), [18700.0]).depth_limit_m[0]) * 1e3, 2)  # mm
    0.85
    """
    method = RefinedSDM() if method is None else method
    _check_method(method)
    if not isinstance(problem, LobeProblem):
        raise LobeError(f"problem must be a LobeProblem, got {type(problem).__name__}")
    if speeds_rpm is None:
        raise LobeError("give speeds_rpm, e.g. numpy.linspace(5000, 25000, 200)")
    rpm = _check_speeds(speeds_rpm)
    depth_max = _check_depth("depth_max_m", depth_max_m)
    integer("coarse_points", coarse_points, minimum=2, error=LobeError)
    if not (isinstance(rtol, (int, float)) and 0 < rtol < 0.5):
        raise LobeError(f"rtol must be in (0, 0.5), got {rtol!r}")
    t0 = time.perf_counter()
    stats: dict = {"evaluations": 0, "rounds": 0, "depth_max_m": depth_max, "method": method.name}
    if isinstance(method, ZeroOrder):
        depth, freq, bif, err = _zoa_diagram(problem, method, rpm, depth_max, progress)
        status, m_final = np.full(len(rpm), "no-estimate"), np.zeros(len(rpm), int)
    elif isinstance(method, Collocation):
        depth, freq, bif, err, status, m_final = _colloc_diagram(problem, method, rpm, depth_max, coarse_points,
                                                                 rtol, stats, progress, chunk)
    elif isinstance(method, RefinedSDM):
        depth, freq, bif, err, status, m_final = _refined_diagram(problem, method, rpm, depth_max, coarse_points,
                                                                  rtol, stats, progress, chunk)
    else:
        depth, freq, bif, err, status, m_final = _sdm_diagram(problem, method, rpm, depth_max, coarse_points, rtol,
                                                              stats, progress, chunk)
    stats["wall_s"] = time.perf_counter() - t0
    return LobeResult(problem=problem, method=method, spindle_rpm=rpm, depth_limit_m=depth,
                      chatter_freq_hz=freq, bifurcation=bif, depth_error_m=err, stats=stats, status=status,
                      m_final=m_final)


def _zoa_diagram(problem: LobeProblem, method: ZeroOrder, rpm: np.ndarray, depth_max: float, progress):
    """Zero-order limits (m), chatter frequencies (Hz), bifurcations and NaN errors at ``rpm`` (S,)."""
    depth, freq = ZOAEngine(problem, method).limits(rpm)
    bif = np.where(np.isfinite(depth), "hopf", "none")
    depth = np.where(depth <= depth_max, depth, np.inf)
    if progress is not None:
        progress(len(rpm), len(rpm))
    return depth, freq, bif, np.full(len(rpm), np.nan)


def _sdm_diagram(problem: LobeProblem, method: SemiDiscretization, rpm: np.ndarray, depth_max: float,
                 coarse_points: int, rtol: float, stats: dict, progress, chunk: int | None):
    """One SDM level: limits (m), chatter frequencies (Hz), bifurcations, NaN errors, statuses and
    levels at ``rpm`` (S,); fills ``stats``. ``richardson=True`` is the refinement limited to one
    pair of levels (:class:`RefinedSDM` with ``m_max = 2 m``)."""
    if method.richardson:
        ref = RefinedSDM(replace(method, richardson=False), m_max=2 * method.m)
        return _refined_diagram(problem, ref, rpm, depth_max, coarse_points, rtol, stats, progress, chunk)
    eng = SDMEngine(problem, method, depth_max)
    _level_stats(stats, eng, method)
    depth, freq, bif = _sdm_limits(eng, rpm, depth_max, coarse_points, rtol, stats, progress, chunk)
    S = len(rpm)
    return depth, freq, bif, np.full(S, np.nan), np.full(S, "no-estimate"), np.full(S, method.m)


def _level_stats(stats: dict, eng: SDMEngine, method: SemiDiscretization) -> None:
    stats.update(m=method.m, scheme=method.scheme, steps_per_period=method.m, quadrature=method.quadrature,
                 axial_slices=eng.plan.slices, principal_period=eng.plan.period_name, engaged_steps=len(eng.cand))
    stats["monodromy_size"] = max(stats.get("monodromy_size", 0), eng.n_red)


def _colloc_diagram(problem: LobeProblem, method: Collocation, rpm: np.ndarray, depth_max: float,
                    coarse_points: int, rtol: float, stats: dict, progress, chunk: int | None):
    """Collocation at ``nodes`` and, unless ``check_nodes == 0``, at ``nodes + check_nodes`` per
    element (searched from the first level's limits): the finer level's limits, chatter
    frequencies, bifurcations, the error estimate ``|b_fine - b_coarse|`` (m), statuses (converged:
    same lobe and estimate <= ``tol`` of the value) and the nodes per element used."""
    S = len(rpm)
    levels = [method.nodes] + ([method.nodes + method.check_nodes] if method.check_nodes else [])
    out, start = [], None
    for i, n in enumerate(levels):
        eng = CollocationEngine(problem, replace(method, nodes=n), depth_max)
        stats.update(nodes=n, elements=method.elements, principal_period=eng.plan.period_name)
        stats["monodromy_size"] = max(stats.get("monodromy_size", 0), eng.n_red)
        out.append(_sdm_limits(eng, rpm, depth_max, coarse_points, rtol, stats, progress, chunk,  # type: ignore[arg-type]
                               i * S, len(levels) * S, start=start))
        start = out[-1][0]
    depth, freq, bif = out[-1]
    if len(out) == 1:
        return depth, freq, bif, np.full(S, np.nan), np.full(S, "no-estimate"), np.full(S, levels[0])
    (d1, f1, b1), T = out[0], eng.period_s(rpm)
    same = same_lobe(b1, f1, bif, freq, T)
    err = np.asarray(level_change(d1, depth).error)
    with np.errstate(invalid="ignore"):
        ok = same & (np.isinf(depth) & np.isinf(d1) | (np.isfinite(depth) & (err <= method.tol * depth)))
    return depth, freq, bif, err, np.where(ok, "converged", "unconverged"), np.full(S, levels[-1])


def _refined_diagram(problem: LobeProblem, method: RefinedSDM, rpm: np.ndarray, depth_max: float,
                     coarse_points: int, rtol: float, stats: dict, progress, chunk: int | None):
    """The refinement rule of :mod:`lobes.refine` over the speeds ``rpm`` (S,): levels m, 2m, ...
    (``method.ratio``: :func:`lobes.refine.next_level`) per speed, each finer level only where the
    previous pair did not converge, its brackets taken from the coarser level and verified. Returns
    limits (m), chatter frequencies (Hz), bifurcations, error estimates (m), statuses and the finest
    level per speed."""
    S = len(rpm)
    base = method.base
    pairs = level_pairs(base.m, method.m_max, method.ratio)
    total = S * (len(pairs) + 1)
    done = [0]

    def level(m, idx, start):
        meth = replace(base, m=m)
        eng = SDMEngine(problem, meth, depth_max)
        _level_stats(stats, eng, meth)
        out = _sdm_limits(eng, rpm[idx], depth_max, coarse_points, rtol, stats, progress, chunk, done[0], total,
                          start=start)
        done[0] += len(idx)
        return out, eng.period_s(rpm[idx])

    value = np.full(S, np.nan)
    err = np.full(S, np.inf)
    status = np.full(S, "unconverged", dtype="<U11")
    m_final = np.full(S, base.m, dtype=int)
    todo = np.arange(S)
    (depth, freq, bif), _ = level(base.m, todo, None)
    freq_out, bif_out = freq.copy(), bif.copy()
    levels_used = [base.m]
    for m1, m2 in pairs:
        (d2, f2, b2), T = level(m2, todo, depth)
        levels_used.append(m2)
        v, e, ok = combine_levels(depth, d2, same_lobe(bif, freq, b2, f2, T), method.tol, m2 / m1)
        value[todo], err[todo], m_final[todo] = v, e, m2
        freq_out[todo], bif_out[todo] = f2, b2
        status[todo[ok]] = "converged"
        keep = ~ok
        todo, depth, freq, bif = todo[keep], d2[keep], f2[keep], b2[keep]
        if len(todo) == 0:
            break
    if progress is not None:
        progress(total, total)
    stats.update(m=base.m, m_levels=levels_used, m_max=method.m_max, tol=method.tol,
                 n_unconverged=int((status == "unconverged").sum()), m_richardson=int(m_final.max()))
    return value, freq_out, bif_out, err, status, m_final


@blas_single_threaded
def stability(problem: LobeProblem, method: Method | None = None, *, depth_max_m: float | None = None,
              adaptive: bool = True, m_max: int = 640, rtol: float = 1e-7, coarse_points: int = 24) -> StabilityPoint:
    """Stability of the problem's own cut (``cut.spindle_rpm``, ``cut.ap_m``), decided robustly.

    The critical depth at this speed is computed for ``m``, ``2m`` (and more when ``adaptive``) and
    combined by the rule of :mod:`lobes.refine`, the same as the diagram's: Richardson (order 2)
    ``b = b_2m + (b_2m - b_m) / 3`` with the estimate ``err = |b_2m - b_m| / 3`` where both levels
    find the same lobe, else the finer level with ``err = |b_2m - b_m|`` (a :class:`RefinedSDM`
    with another ``ratio``: its levels, with ``(q^2 - 1)`` for 3, ``q = m_f / m_c``). The verdict
    (:func:`depth_verdict`) compares the depth with ``b +- err``. With ``adaptive``, ``m`` is
    refined while the verdict is "undetermined" and, for :class:`RefinedSDM` (the default), also
    while the limit is not converged (error above ``tol``); up to ``m_max`` (RefinedSDM: its own
    ``m_max``). The spectral radius of the operating point
    is reported too, but it is not what decides: for a robot whose modes sit at ``|mu| ~ 1 - 1e-3``
    the radius differs from 1 in the fifth decimal, while the depth ratio stays far from 0.

    Parameters
    ----------
    depth_max_m : float, optional
        Largest depth searched for the limit, m. Default ``max(10 ap, 10 mm)``.
    adaptive : bool
        Refine ``m`` while the verdict is undetermined.
    m_max : int
        Largest ``m`` used by the adaptive refinement of a plain ``SemiDiscretization`` (a
        ``RefinedSDM`` uses its own ``m_max``).
    rtol : float
        Relative bracket width of each critical depth.
    coarse_points : int
        Depths of the coarse bracketing scan.

    Examples
    --------
    The symmetric 2-DOF benchmark of :func:`solve` (limit about 0.85 mm at 18 700 rpm): 0.5 mm is
    stable, 1.2 mm is not.

    >>> from robolobes.cases.milling import Cut, CuttingLaw, Tool
    >>> from robolobes.lobes import LobeProblem, Mode, ModalStructure
    >>> modes = ModalStructure(tuple(Mode(922.0, 0.011, 1.34003e6, d) for d in ((1.0, 0.0), (0.0, 1.0))))
    >>> def at(ap_m):
    ...     return LobeProblem(modes, Tool(diameter_m=0.01, teeth=2), Cut(ae_m=0.5e-3, ap_m=ap_m, spindle_rpm=18700.0),
    ...                        CuttingLaw(ktc_pa=6e8, krc_pa=2e8))
    >>> stability(at(0.5e-3)).verdict.status, stability(at(1.2e-3)).verdict.status
    ('stable', 'unstable')
    """
    method = RefinedSDM() if method is None else method
    _check_method(method)
    if not isinstance(problem, LobeProblem):
        raise LobeError(f"problem must be a LobeProblem, got {type(problem).__name__}")
    depth = float(problem.cut.ap_m)
    dmax = _check_depth("depth_max_m", depth_max_m if depth_max_m is not None else max(10 * depth, 0.01))
    if isinstance(method, ZeroOrder):
        return _zoa_point(problem, method, dmax)
    if isinstance(method, Collocation):
        raise LobeError("stability() does not support Collocation yet; use solve(problem, Collocation(), [rpm])")
    refined = isinstance(method, RefinedSDM)
    sdm = method.base if isinstance(method, RefinedSDM) else method
    tol = method.tol if isinstance(method, RefinedSDM) else RefinedSDM().tol
    m_top = method.m_max if isinstance(method, RefinedSDM) else m_max
    ratio = method.ratio if isinstance(method, RefinedSDM) else 2.0
    levels = [_sdm_level(problem, sdm, sdm.m, dmax, rtol, coarse_points)]
    while True:
        levels.append(_sdm_level(problem, sdm, next_level(levels[-1]["m"], ratio), dmax, rtol, coarse_points))
        c, f = levels[-2], levels[-1]
        same = same_lobe([c["limit_bifurcation"]], [c["limit_chatter_freq_hz"]], [f["limit_bifurcation"]],
                         [f["limit_chatter_freq_hz"]], [f["period_s"]])
        v, e, ok = combine_levels([c["depth_limit_m"]], [f["depth_limit_m"]], same, tol, f["m"] / c["m"])
        b_ext, err = float(v[0]), float(e[0])
        verdict = depth_verdict(depth, b_ext, err, (c["m"], f["m"]), dmax)
        done = verdict.status != "undetermined" and (bool(ok[0]) or not refined)
        if done or not adaptive or next_level(f["m"], ratio) > m_top:
            break
    last = levels[-1]
    return StabilityPoint(
        spindle_rpm=float(problem.cut.spindle_rpm), depth_m=depth, spectral_radius=last["spectral_radius"],
        critical_multiplier=last["critical_multiplier"], verdict=verdict,
        margin=b_ext / depth - 1 if math.isfinite(b_ext) else math.inf,
        margin_error=err / depth if math.isfinite(err) else math.inf,
        radius_margin=1 - last["spectral_radius"], depth_limit_m=b_ext,
        depth_limit_error_m=err, chatter_freq_hz=last["chatter_freq_hz"],
        bifurcation=cast(Bifurcation, str(classify_multiplier(last["critical_multiplier"], method.angle_tol_rad))),
        limit_bifurcation=last["limit_bifurcation"], limit_chatter_freq_hz=last["limit_chatter_freq_hz"],
        method=method, history=tuple(levels), limit_status="converged" if ok[0] else "unconverged")


def depth_verdict(depth_m: float, limit_m: float, error_m: float, m_levels: tuple[int, int],
                  depth_max_m: float = math.inf) -> Verdict:
    """The lobes' decision rule: compare the cut depth with the limit and its error estimate.

    ``depth < limit - error``: stable; ``depth > limit + error``: unstable; otherwise undetermined
    (the discretization error estimate of the Richardson limit straddles the depth). Depths in m;
    ``m_levels`` (coarse, fine) and ``depth_max_m`` (the largest depth searched, when the limit is
    ``inf``) are named in the reason.
    """
    mm = lambda x: f"{x * 1e3:.5g} mm"
    ms = f"SDM m = {m_levels[0]}/{m_levels[1]}, Richardson"
    if depth_m < limit_m - error_m:
        if math.isinf(limit_m):
            return Verdict("stable", f"no stability limit up to the {mm(depth_max_m)} searched ({ms})")
        return Verdict("stable", f"depth {mm(depth_m)} below the limit {mm(limit_m)} - {mm(error_m)} ({ms})")
    if depth_m > limit_m + error_m:
        return Verdict("unstable", f"depth {mm(depth_m)} above the limit {mm(limit_m)} + {mm(error_m)} ({ms})")
    return Verdict("undetermined", f"depth {mm(depth_m)} within the discretization error estimate of the limit "
                                   f"{mm(limit_m)} +- {mm(error_m)} ({ms}); a larger m would decide")


def _zoa_point(problem: LobeProblem, method: ZeroOrder, dmax: float) -> StabilityPoint:
    """StabilityPoint of the zero-order approximation. Its limit is that of the time-averaged model,
    whose distance to the milling model's limit is not estimated: the errors are NaN and the
    verdict's reason says so (``bench/bench_lobes_levels.py``: on the TX200 the ZOA limits are up to
    2.5 times the refined SDM's)."""
    rpm, depth = float(problem.cut.spindle_rpm), float(problem.cut.ap_m)
    b, f = ZOAEngine(problem, method).limits(np.array([rpm]))
    b, f = float(b[0]), float(f[0])
    b = b if b <= dmax else math.inf
    where = (f"no limit up to the {dmax * 1e3:.5g} mm searched" if math.isinf(b) else
             f"depth {depth * 1e3:.5g} mm {'below' if depth < b else 'at or above'} the limit {b * 1e3:.5g} mm")
    verdict = Verdict("stable" if depth < b else "unstable",
                      f"ZOA: {where} (zero-order approximation: its error is not estimated)")
    bif = "hopf" if math.isfinite(b) else "none"
    return StabilityPoint(rpm, depth, math.nan, complex(math.nan, math.nan), verdict, b / depth - 1, math.nan,
                          math.nan, b, math.nan, f, bif, bif, f, method,
                          ({"m": None, "depth_limit_m": b, "stable": depth < b},))


def _sdm_level(problem: LobeProblem, method: SemiDiscretization, m: int, dmax: float, rtol: float,
               coarse_points: int) -> dict:
    """One discretization level ``m`` at the problem's speed: its critical depth (m), the spectrum at
    the cut depth and the bifurcation at the limit, as a dict (an entry of ``StabilityPoint.history``)."""
    eng = SDMEngine(problem, replace(method, m=m, richardson=False), dmax)
    st = {"evaluations": 0, "rounds": 0}
    r = np.array([float(problem.cut.spindle_rpm)])
    rho0 = np.max(np.abs(np.exp(np.outer(eng.period_s(r), eng.ss.poles))), axis=1)
    fast = method.search in ("fast", "fast-wide")
    est, hi, found = _search(lambda s, d: eng.multipliers(s, d)[0], r, rho0, dmax, coarse_points, rtol, st,
                             straddle=fast, eig_fn=eng.spectra if fast else None)
    rho, mu, fr = eng.critical(r, np.array([float(problem.cut.ap_m)]))
    lvl = {"m": m, "period_s": float(eng.period_s(r)[0]), "depth_limit_m": float(est[0]), "spectral_radius": float(rho[0]),
           "critical_multiplier": complex(mu[0]), "chatter_freq_hz": float(fr[0]),
           "stable": bool(rho[0] < 1.0), "evaluations": st["evaluations"],
           "limit_bifurcation": "none", "limit_chatter_freq_hz": math.nan}
    if found[0]:
        _, mu_l, fr_l = eng.critical(r, hi)
        lvl["limit_bifurcation"] = str(classify_multiplier(mu_l, method.angle_tol_rad)[0])
        lvl["limit_chatter_freq_hz"] = float(fr_l[0])
    return lvl
