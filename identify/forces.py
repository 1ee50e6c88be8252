"""Identification pipelines of the force-side measurements: ``forces``, ``force_stats``, ``stability``.

``forces`` (a cutting-force series)
-----------------------------------
1. The spindle frequency is estimated from the data and the model is run at it
   (:mod:`identify.force_signals`).
2. The complete revolutions of the window are split in two contiguous blocks: the first half
   trains, the second is held out. Each block's time-synchronous average (TSA) is compared with the
   model's average over the same pass times (the linearized pass, :mod:`identify.force_model`),
   after a circular shift that aligns the unknown spindle phase (fitted on the training block).
3. Forward-backward selection over the force-side library (:mod:`identify.cutting_effects`) by
   :func:`identify.selection.stepwise_select`: each candidate is fitted on the training TSA (bounded
   least squares, the phase shift a nuisance parameter) on top of the effects already chosen, then
   every selected effect and the new one are refitted jointly (:func:`_joint_fit`), and the model is
   scored on the held-out TSA; after each step an earlier effect that is no longer significant
   given the others is removed (the others refitted jointly). A candidate that is not credible or
   below its own detection threshold cannot be chosen (:func:`identify.evidence.accept`). The
   significance rule is the framework's (gain of squared held-out residual against the noise of
   the held-out average, Bonferroni over the ``2 max_effects`` forward steps the search can make x
   the candidates, family-wise 1 %); the noise per bin and axis is ``sigma / sqrt(N)`` from the
   scatter of the held-out revolutions about their average. Values, uncertainties (covariance),
   ``determined`` combinations, ``on_bound`` and credibility of each effect come from the final
   joint fit.
4. Diagnosis (:mod:`identify.signatures`): the named signatures of the starting model's held-out
   residual (mean offset, once-per-revolution lines, ringing, roll-off), each against the noise of
   the average, and the candidates ranked by the signatures they explain (``signatures``,
   ``ranking``; each effect's ``evidence`` says why it ranks where it does).

``force_stats`` (8 published numbers)
------------------------------------
No held-out part: every subset of the library with at most 3 parameters in total is fitted to the
8 numbers (least squares in N), ranked by AICc ``n ln(RSS/n) + 2k + 2k(k+1)/(n-k-1)``; a fit with
a value on its bound is rejected. The error is the RMS over the 8 numbers (N); the degrees of
freedom ``n - k`` are reported.

``stability`` (observed stable / chatter cuts)
----------------------------------------------
See :func:`identify.force_stability.identify_stability`: the joint-damping scale (and the process damping it would take)
that makes the lobes' verdict agree with every observation.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, replace

import numpy as np

from robolobes.core.errors import BadInput

from .cutting_effects import FORCE_EFFECTS, ForceEffect, chain_transfer, transfer_product
from .effects import SIGNATURES, ModelState, effects_for
from .force_data import ForceSeries, ForceStatistics, read_force_set, read_force_stats, read_stability
from .force_model import revolution_averages, simulate_forces, with_spindle_hz
from .force_signals import (ERROR_METRIC, align_shift, apply_transfer, estimate_spindle_hz, heldout_error,
                            revolutions, shift_average, spectrum_lines, sync_average)
from .model_toml import model_toml
from .result import EffectFit, Identification
from .evidence import accept, credibility, determined
from .selection import Selection, Trial, stepwise_select
from .ranking import annotate
from .signatures import force_signatures

__all__ = ["read_forces", "read_force_stats", "read_stability", "identify_forces", "identify_force_stats",
           "ForceContext", "check_window", "aicc"]

read_forces = read_force_set

#: Angle bins per revolution at most (fewer when a revolution holds fewer samples).
MAX_BINS = 256


def check_window(path, window: tuple, case) -> None:
    """BadInput when ``window`` (pass time, s) is not inside the case's pass."""
    from robolobes.linearize.path import FeedProfile

    feed = case.cut.feed_rate_m_per_s(case.tool)
    dur = float(FeedProfile(travel_m=case.path.travel_m(case.tool), feed_m_per_s=feed,
                            ramp_s=case.path.ramp_s).duration_s)
    if window[1] > dur + 1e-9:
        raise BadInput(f"{path}: window_s = {list(window)} s is outside the pass of case {case.name!r}, which lasts "
                       f"{dur:.4g} s; valid: 0 <= t0 < t1 <= {dur:.4g}")


# ---------------------------------------------------------------------------------------------
# cutting-force series
# ---------------------------------------------------------------------------------------------

class ForceContext:
    """Measured averages of the training and held-out blocks, and the model's over the same times.

    Attributes: ``spindle_hz``, ``bins``, ``train``/``heldout`` (:class:`SyncAverage`), ``blocks``
    (revolution start times per block), ``t_end_s`` (model run length).
    """

    def __init__(self, series: ForceSeries, case, *, nominal_hz: float | None = None):
        t, f = series.t_s, series.force_n
        nominal = nominal_hz or case.cut.spindle_rpm / 60.0
        self.spindle_hz = estimate_spindle_hz(t, f[:, :2], nominal)
        per_rev = series.sample_rate_hz / self.spindle_hz
        self.bins = int(min(MAX_BINS, 2 * (int(per_rev) // 2)))
        starts, revs = revolutions(t, f, self.spindle_hz, self.bins)
        if len(starts) < 8:
            raise BadInput(f"{series.path}: the window holds {len(starts)} spindle revolutions; identification needs "
                           f"at least 8 (4 to train, 4 held out)")
        half = len(starts) // 2
        period = 1.0 / self.spindle_hz
        self.blocks = [starts[:half], starts[half:]]
        self.train = sync_average(starts[:half], revs[:half], period)
        self.heldout = sync_average(starts[half:], revs[half:], period)
        self.t_end_s = float(starts[-1] + period + 4 * period / self.bins)

    def raw_averages(self, state: ModelState) -> list:
        t, f = simulate_forces(state, self.t_end_s)
        return revolution_averages(t, f, self.spindle_hz, self.bins, self.blocks)

    def filtered(self, avg: np.ndarray, h) -> np.ndarray:
        return apply_transfer(avg, self.spindle_hz, h)

    def averages(self, state: ModelState) -> list:
        raw = self.raw_averages(state)
        if not state.chain:
            return raw
        h = chain_transfer(state.chain)
        return [self.filtered(a, h) for a in raw]


def _on_bound(x: np.ndarray, effects, tol: float) -> bool:
    """Whether a fitted value (``x`` scaled to [0, 1] per parameter) sits on a physical bound; periodic
    parameters (angles) have no physical bound and are skipped."""
    periodic = np.array([p.periodic for e in effects for p in e.parameters], bool)
    edge = (x <= tol) | (x >= 1 - tol)
    return bool(np.any(edge & ~periodic))


@dataclass
class _Fit:
    values: np.ndarray
    sigma: np.ndarray
    shift: float
    train: np.ndarray  # aligned model average of the training block (bins, 3)
    heldout: np.ndarray  # aligned model average of the held-out block
    on_bound: bool
    cov: np.ndarray | None = None   # covariance of the values (P, P), SI


#: Gauss-Newton re-centrings of an inexact family (:attr:`ForceEffect.family_exact` False) at most.
REFINE_STEPS = 4
#: Finite-difference step of a re-centred family, as a fraction of each parameter's range.
REFINE_STEP = 0.01
#: Re-centring stops when no value moved by more than this fraction of its range.
REFINE_TOL = 1e-4


def _least_squares_fit(ctx: ForceContext, fc, model_u, h, starts_u, shift0: float):
    """Fit ``model_u`` (fit coordinates ``u`` -> raw averages, :class:`identify.cutting_effects.FitCoordinates`
    ``fc``) to the training average: the best ``least_squares`` result over ``starts_u``, in the scaled
    variables ``x = (u - lower) / range`` plus the alignment shift."""
    from scipy.optimize import least_squares

    lo, hi = np.asarray(fc.lower, float), np.asarray(fc.upper, float)
    scale = hi - lo
    meas = ctx.train.mean[:, :2]

    def resid(x):
        a = model_u(lo + x[:-1] * scale)[0]
        a = ctx.filtered(a, h) if h is not None else a
        return (shift_average(a, x[-1])[:, :2] - meas).ravel()

    best = None
    for u0 in starts_u:
        x0 = np.append(np.clip((np.asarray(u0, float) - lo) / scale, 0, 1), shift0)
        r = least_squares(resid, x0, bounds=(np.append(np.zeros(len(lo)), shift0 - 0.5),
                                             np.append(np.ones(len(lo)), shift0 + 0.5)), x_scale="jac")
        if best is None or r.cost < best.cost:
            best = r
    assert best is not None  # starts_for gives at least one start
    return best


def _fd_columns(raw_at, center: np.ndarray, lo: np.ndarray, hi: np.ndarray, idx) -> dict:
    """Finite-difference columns ``{i: [d raw_k / d u_i per block k]}`` of the raw averages at ``center``
    (fit coordinates u, shape (P,)) for the coordinates ``idx``: one simulated run per coordinate at
    ``center + d_i e_i``, ``d_i = REFINE_STEP`` of its range, stepped inwards at an upper bound.
    ``raw_at(u)`` gives the raw averages (list of (bins, 3) arrays, N) at ``u``."""
    base = raw_at(center)
    cols = {}
    for i in idx:
        d = REFINE_STEP * (hi[i] - lo[i])
        d = -d if center[i] + d > hi[i] else d
        u = center.copy()
        u[i] += d
        cols[int(i)] = [(a - b) / d for a, b in zip(raw_at(u), base)]
    return cols


def secant_update(cols: dict, c_old: np.ndarray, raw_old: list, c_new: np.ndarray, raw_new: list,
                  scale: np.ndarray) -> dict:
    """Broyden's rank-one update of the columns of an affine model of the raw averages when its centre
    moves from ``c_old`` to ``c_new`` (fit coordinates, (P,)), where ``raw_new`` was simulated.

    ``cols``: ``{i: [d raw_k / d u_i per block k]}``; ``raw_old``/``raw_new``: the averages at the two
    centres (lists of arrays, N); ``scale`` (P,): each coordinate's range (the update is the least change
    of the Jacobian in the coordinates scaled to [0, 1]). The updated model through ``c_new`` is exact at
    ``c_new`` (the secant condition: from ``c_old`` it predicts ``raw_new``) and unchanged along every
    direction orthogonal to the step. Returns the new columns (``cols`` is not modified)."""
    idx = sorted(cols)
    sx = np.array([(c_new[i] - c_old[i]) / scale[i] for i in idx])
    nn = float(sx @ sx)
    if nn == 0.0:
        return dict(cols)
    miss = [rn - ro - sum((c_new[i] - c_old[i]) * cols[i][k] for i in idx)
            for k, (ro, rn) in enumerate(zip(raw_old, raw_new))]
    return {i: [col + m * (sx[j] / (scale[i] * nn)) for col, m in zip(cols[i], miss)] for j, i in enumerate(idx)}


def _affine(center: np.ndarray, base: list, cols: dict):
    """The affine model ``u -> [base_k + sum_i (u_i - center_i) cols[i][k]]`` (lists of arrays, N)."""
    c = center.copy()
    return lambda u: [b + sum((float(u[i]) - c[i]) * col[k] for i, col in cols.items()) for k, b in enumerate(base)]


def _fit_effect(ctx: ForceContext, effect, state: ModelState, shift0: float) -> _Fit:
    """Fit one effect's parameters and the alignment shift to the training average.

    The fit searches the effect's fit coordinates (:meth:`ForceEffect.fit_coordinates`: the
    parameters, or for runout on a two-tooth tool the one combination the forces determine). The
    effect's :meth:`family` gives the first fit. Where that family only approximates the simulated
    model (``family_exact`` False: the edge coefficients' superposition, the runout's spline, both
    ignoring how the robot's deflection changes the engagement), the fit is re-centred: an affine
    family through a simulated run at the current values is fitted again, up to :data:`REFINE_STEPS`
    times (Gauss-Newton), and the model averages returned are the simulated ones at the final values,
    not the family's. The first re-centring takes the family's own slopes at the centre (no run: for
    the edge coefficients the superposition of the basis runs, for runout the spline's), through the
    simulated run at the centre; the later ones update them by Broyden's secant rule from the run at
    the new centre (:func:`secant_update`, no run of their own). Each re-centring thus costs one run."""
    family = effect.family(ctx, state)
    fc = effect.fit_coordinates(state.case.tool)
    h = chain_transfer(state.chain) if state.chain else None
    lo, hi = np.asarray(fc.lower, float), np.asarray(fc.upper, float)
    scale = hi - lo
    meas = ctx.train.mean[:, :2]

    def cost(v):  # training cost at values v, the phase re-aligned (for effects that scan: starts_for)
        a = family(np.asarray(v, float))[0]
        a = ctx.filtered(a, h) if h is not None else a
        return float(np.sum((shift_average(a, align_shift(a, ctx.train.mean))[:, :2] - meas) ** 2))

    starts = [fc.from_values(np.asarray(v, float)) for v in effect.starts_for(cost)]
    best = _least_squares_fit(ctx, fc, lambda u: family(fc.to_values(u)), h, starts, shift0)
    if not effect.family_exact:
        def raw_at(uu):
            return ctx.raw_averages(effect.apply_values(state, fc.to_values(uu)))
        prev = None   # (centre, its simulated raw averages, the columns there) of the re-centring before
        for _ in range(REFINE_STEPS):
            center = lo + best.x[:-1] * scale
            raw0 = raw_at(center)
            if prev is None:   # the family's own slopes: its basis runs are done (edge: the superposition)
                cols = _fd_columns(lambda uu: family(fc.to_values(uu)), center, lo, hi, range(len(center)))
            else:
                cols = secant_update(prev[2], prev[0], prev[1], center, raw0, scale)
            prev = (center, raw0, cols)
            local = _affine(center, raw0, cols)
            new = _least_squares_fit(ctx, fc, local, h, [center], float(best.x[-1]))
            moved = float(np.max(np.abs(new.x[:-1] - best.x[:-1])))
            best = new
            if moved < REFINE_TOL:
                break
    x = best.x
    u = lo + x[:-1] * scale
    v = fc.to_values(u)
    n, p = best.fun.size, x.size
    try:
        cov = np.linalg.inv(best.jac.T @ best.jac) * (2 * best.cost / max(n - p, 1))
        J = fc.jacobian(u)
        cov_v = J @ (cov[:-1, :-1] * np.outer(scale, scale)) @ J.T + np.diag(fc.unresolved_sd ** 2)
        sig = np.sqrt(np.clip(np.diag(cov_v), 0, None))
    except np.linalg.LinAlgError:
        sig = np.full(len(v), np.inf)
        cov_v = np.full((len(v), len(v)), np.inf)
    if effect.family_exact:
        avgs = family(v)
    else:  # the simulated model at the fitted values (memoised when the last step did not move)
        avgs = ctx.raw_averages(effect.apply_values(state, v))
    avgs = [ctx.filtered(a, h) for a in avgs] if h is not None else avgs
    plo, phi = np.array(effect.lower, float), np.array(effect.upper, float)
    on_bound = _on_bound((v - plo) / (phi - plo), [effect], 1e-6)
    return _Fit(values=v, sigma=sig, shift=float(x[-1]), train=shift_average(avgs[0], x[-1]),
                heldout=shift_average(avgs[1], x[-1]), on_bound=on_bound, cov=cov_v)


# ---------------------------------------------------------------------------------------------
# joint refit of the selected effects (forward-backward selection)
# ---------------------------------------------------------------------------------------------

#: Joint Gauss-Newton iterations of a force refit at most.
JOINT_STEPS = REFINE_STEPS


@dataclass(frozen=True, eq=False)
class _Joint:
    """A force model of the selection: the starting state ``base``, the selected effects and their
    values (in the order they entered), the alignment shift, the aligned model averages of the training
    and held-out blocks (bins, 3), the covariance of all values (concatenated in effect order, SI) and,
    per effect, whether a value sits on a physical bound."""

    base: ModelState
    effects: tuple = ()
    values: tuple = ()
    shift: float = 0.0
    train: np.ndarray | None = None
    heldout: np.ndarray | None = None
    cov: np.ndarray | None = None
    on_bound: tuple = ()

    @property
    def model(self) -> ModelState:
        return _compose(self.base, self.effects, self.values)

    def block(self, k: int) -> np.ndarray | None:
        """The covariance of the ``k``-th effect's values."""
        if self.cov is None:
            return None
        i = sum(len(e.parameters) for e in self.effects[:k])
        n = len(self.effects[k].parameters)
        return self.cov[i:i + n, i:i + n]


def _compose(base: ModelState, effects, values) -> ModelState:
    """``base`` with every effect applied at its values, in order (the force effects commute: edge
    coefficients and runout add to the law and the tool, chain stages multiply, backlash replaces)."""
    st = base
    for e, v in zip(effects, values):
        st = e.apply_values(st, v)
    return st


def _chain_of(base: ModelState, effects, values):
    """The transfer of ``base``'s chain and of the chain effects at ``values`` (None: no chain)."""
    hs = [e.transfer(v) for e, v in zip(effects, values) if e.chain]
    if base.chain:
        hs.append(chain_transfer(base.chain))
    return transfer_product(hs) if hs else None


def _joint_fit(ctx: ForceContext, base: ModelState, effects, values, shift0: float) -> _Joint:
    """Refit every effect of ``effects`` jointly, from ``values`` and the alignment ``shift0``, on the
    training average: Gauss-Newton over the concatenated fit coordinates (:meth:`ForceEffect.fit_coordinates`)
    and the shift, on simulated runs.

    Why Gauss-Newton and not block coordinate descent: the force effects are correlated in the
    averages (edge coefficients and runout both move the tooth-passing harmonics' levels, a low-pass
    and backlash both roll them off), and descent along one block at a time crawls along such a
    valley, each sweep re-building every effect's family (16 runs for a backlash scan); one
    Gauss-Newton step solves the coupled linear problem at once. Each iteration takes the model's raw
    averages as affine in the coordinates of the cutting-law and element effects, through a simulated
    run at the centre (the one evaluated at the end of the iteration before, memoised); the chain
    effects filter that exactly. The first iteration's columns are finite differences
    (:func:`_fd_columns`: one run per coordinate at ``REFINE_STEP`` of its range), a later
    iteration's are the earlier ones updated by Broyden's secant rule through the run at its centre
    (:func:`secant_update`, no run of their own). The least-squares solution
    is then simulated; it is kept only if its simulated training cost is lower than the centre's
    (a step that does not pay stops the refit at the centre, so the refit never ends worse than its
    start, the conditional fit). The refit stops after :data:`JOINT_STEPS` iterations, or when no
    coordinate moved by more than :data:`REFINE_TOL` of its range, or when the simulated training
    cost fell by less than one noise variance of the training average (a change of the training
    chi-square below 1, inside the fit's one-sigma region). The covariance is that of the last
    local problem at the values kept (``(J^T J)^-1 RSS / (n - p)``, mapped to the values)."""
    from scipy.optimize import least_squares

    tool = base.case.tool
    fcs = [e.fit_coordinates(tool) for e in effects]
    offs = np.cumsum([0] + [len(fc.lower) for fc in fcs])
    lo = np.concatenate([np.asarray(fc.lower, float) for fc in fcs])
    hi = np.concatenate([np.asarray(fc.upper, float) for fc in fcs])
    scale = hi - lo
    cut = np.concatenate([np.full(len(fc.lower), not e.chain) for e, fc in zip(effects, fcs)])
    meas = ctx.train.mean[:, :2]
    var = float(np.mean(ctx.train.noise[:, :2] ** 2))

    def vals(u):
        return [fc.to_values(u[offs[k]:offs[k + 1]]) for k, fc in enumerate(fcs)]

    def filt(avgs, v):
        h = _chain_of(base, effects, v)
        return [ctx.filtered(a, h) for a in avgs] if h is not None else list(avgs)

    def simulated(v):
        return filt(ctx.raw_averages(_compose(base, effects, v)), v)

    def cost_of(avgs, shift):
        return float(np.sum((shift_average(avgs[0], shift)[:, :2] - meas) ** 2))

    v = [np.asarray(x, float) for x in values]
    u = np.clip(np.concatenate([fc.from_values(x) for fc, x in zip(fcs, v)]), lo, hi)
    shift = float(shift0)
    sim = simulated(v)     # the start's run (memoised: the conditional fit simulated it)
    cost = cost_of(sim, shift)
    def local(c, cols, raw0):  # the training residual of the affine model through the runs at c
        def resid(x):
            uu = lo + x[:-1] * scale
            raw = [b + sum((uu[i] - c[i]) * col[k] for i, col in cols.items()) for k, b in enumerate(raw0)]
            return (shift_average(filt(raw[:1], vals(uu))[0], x[-1])[:, :2] - meas).ravel()
        return resid

    def raw_at(uu):
        return ctx.raw_averages(_compose(base, effects, vals(uu)))

    resid, prev = None, None   # prev: (centre, its raw averages, the columns there) of the iteration before
    for _ in range(JOINT_STEPS):
        raw0 = raw_at(u)
        cols = (_fd_columns(raw_at, u, lo, hi, np.flatnonzero(cut)) if prev is None
                else secant_update(prev[2], prev[0], prev[1], u, raw0, scale))
        prev = (u.copy(), raw0, cols)
        resid = local(u.copy(), cols, raw0)
        x0 = np.append((u - lo) / scale, shift)
        r = least_squares(resid, x0, bounds=(np.append(np.zeros(len(lo)), shift - 0.5),
                                             np.append(np.ones(len(lo)), shift + 0.5)), x_scale="jac")
        u_new, shift_new = lo + r.x[:-1] * scale, float(r.x[-1])
        v_new = vals(u_new)
        sim_new = simulated(v_new)
        cost_new = cost_of(sim_new, shift_new)
        if not cost_new < cost:
            break
        moved = float(np.max(np.abs(r.x - x0)[:-1])) if len(lo) else 0.0
        fell = cost - cost_new
        u, v, shift, sim, cost = u_new, v_new, shift_new, sim_new, cost_new
        if moved < REFINE_TOL or fell < var:
            break
    x = np.append((u - lo) / scale, shift)
    n, p = meas.size, x.size
    try:
        assert resid is not None
        h = 1e-6
        J = np.column_stack([(resid(x + h * e) - resid(x - h * e)) / (2 * h) for e in np.eye(p)])
        cov = np.linalg.inv(J.T @ J) * (cost / max(n - p, 1))
        Jv = np.zeros((sum(len(e.parameters) for e in effects), len(lo)))
        row = 0
        for k, fc in enumerate(fcs):
            jk = np.asarray(fc.jacobian(u[offs[k]:offs[k + 1]]), float)
            Jv[row:row + jk.shape[0], offs[k]:offs[k + 1]] = jk
            row += jk.shape[0]
        cov_v = Jv @ (cov[:-1, :-1] * np.outer(scale, scale)) @ Jv.T + np.diag(
            np.concatenate([np.asarray(fc.unresolved_sd, float) for fc in fcs]) ** 2)
    except (np.linalg.LinAlgError, AssertionError):
        P = sum(len(e.parameters) for e in effects)
        cov_v = np.full((P, P), np.inf)
    on_bound = tuple(_on_bound((np.asarray(vk) - np.array(e.lower, float)) / (np.array(e.upper, float)
                                                                              - np.array(e.lower, float)), [e], 1e-6)
                     for e, vk in zip(effects, v))
    return _Joint(base, tuple(effects), tuple(v), shift, shift_average(sim[0], shift), shift_average(sim[1], shift),
                  cov_v, on_bound)


class _ForceSearch:
    """``trial`` and ``drop`` of :func:`identify.selection.stepwise_select` for a force series.

    ``trial(state, effect)``: the effect fitted alone on top of ``state`` (:func:`_fit_effect`, its
    family, scan and starts), then every effect of ``state`` and the new one refitted jointly from
    there (:func:`_joint_fit`); scored on the held-out average. ``drop(state, k)``: ``state`` without
    its ``k``-th effect, the others refitted jointly. ``joint=False``: the forward-only search of
    before, each effect fitted alone with the earlier ones frozen (kept for comparison, tests)."""

    def __init__(self, ctx: ForceContext, base: ModelState, meas: np.ndarray, sigma: np.ndarray, start: _Joint,
                 joint: bool = True):
        self.ctx, self.base, self.meas, self.sigma, self.start = ctx, base, meas, sigma, start
        self.joint = joint

    def __call__(self, st: _Joint, eff) -> Trial:
        if eff is None:
            assert st.heldout is not None
            return Trial(residual=st.heldout[:, :2].ravel() - self.meas, measured=self.meas, sigma=self.sigma,
                         state=st)
        fit = _fit_effect(self.ctx, eff, st.model, st.shift)
        if st.effects and self.joint:
            new = _joint_fit(self.ctx, self.base, st.effects + (eff,), st.values + (fit.values,), fit.shift)
        elif st.effects:   # forward only: the earlier effects frozen, the covariance of the new one alone
            P = sum(len(e.parameters) for e in st.effects)
            cov = np.full((P + len(fit.values),) * 2, np.nan)
            cov[P:, P:] = fit.cov if fit.cov is not None else np.inf
            new = _Joint(self.base, st.effects + (eff,), st.values + (fit.values,), fit.shift, fit.train, fit.heldout,
                         cov, st.on_bound + (fit.on_bound,))
        else:
            new = _Joint(self.base, (eff,), (fit.values,), fit.shift, fit.train, fit.heldout, fit.cov,
                         (fit.on_bound,))
        assert new.heldout is not None
        k = len(new.effects) - 1
        return Trial(residual=new.heldout[:, :2].ravel() - self.meas, measured=self.meas, sigma=self.sigma,
                     state=new, params=eff.as_dict(new.values[k]), uncertainty=eff.as_dict(_sd(new.block(k))),
                     evidence=_evidence(eff, new, k))

    def drop(self, st: _Joint, k: int) -> _Joint:
        rest = [j for j in range(len(st.effects)) if j != k]
        if not rest:
            return self.start
        return _joint_fit(self.ctx, self.base, tuple(st.effects[j] for j in rest), tuple(st.values[j] for j in rest),
                          st.shift)

    @staticmethod
    def params_of(st: _Joint, k: int) -> dict:
        return st.effects[k].as_dict(st.values[k])


def _sd(cov) -> np.ndarray:
    return np.sqrt(np.clip(np.diag(cov), 0, None)) if cov is not None else np.array([])


def _evidence(eff, st: _Joint, k: int) -> dict:
    """What a force fit of the ``k``-th effect of ``st`` reports (at ``st``'s joint fit)."""
    tool = st.base.case.tool
    return {"signature": [SIGNATURES[s] for s in eff.signatures], "on_bound": bool(st.on_bound[k]),
            "detection_threshold": dict(eff.threshold), "phase_shift_rev": st.shift,
            "determined": force_determined(eff, tool, st.values[k], st.block(k)),
            **(eff.identified(tool, st.values[k]) if hasattr(eff, "identified") else {})}


def _select_forces(ctx: ForceContext, state: ModelState, library, *, alpha: float, max_effects: int,
                   progress=None, joint: bool = True) -> Selection:
    """The forward-backward search over ``library`` (module docstring, step 3); ``Selection.state`` is
    the final :class:`_Joint` and ``Selection.effects`` are reported at its joint fit. ``joint=False``:
    the forward-only search with frozen values (:class:`_ForceSearch`), for comparison."""
    tr, ho = ctx.averages(state)
    shift0 = align_shift(tr, ctx.train.mean)
    start = _Joint(state, shift=shift0, train=shift_average(tr, shift0), heldout=shift_average(ho, shift0))
    search = _ForceSearch(ctx, state, ctx.heldout.mean[:, :2].ravel(), ctx.heldout.noise[:, :2].ravel(), start,
                          joint)
    sel = stepwise_select(start, library, search, alpha=alpha, max_effects=max_effects, progress=progress,
                          drop=search.drop if joint else None, accept=accept,
                          params_of=search.params_of if joint else None)
    if not joint:   # each effect as fitted at its step (its values frozen since)
        return sel
    final: _Joint = sel.state
    fits = []
    for k, f in enumerate(sel.effects):
        eff = final.effects[k]
        assert eff.name == f.name
        fits.append(replace(f, params=eff.as_dict(final.values[k]), uncertainty=eff.as_dict(_sd(final.block(k))),
                            evidence={**f.evidence, **_evidence(eff, final, k)}))
    return replace(sel, effects=tuple(fits))


def identify_forces(measurement: ForceSeries, model: ModelState, *, alpha: float = 0.01, max_effects: int = 3,
                    progress=None, effects=None) -> Identification:
    """Identify the force-side effects in a cutting-force series (module docstring).

    Parameters
    ----------
    measurement : ForceSeries
    model : ModelState
        The starting model (its case's commanded spindle speed is replaced by the measured one).
    alpha : float
        Family-wise false-positive rate of the selection (:func:`identify.selection.stepwise_select`).
    max_effects : int
    progress : callable ``(message)``, optional
    effects : sequence of ForceEffect, optional
        The library searched (default: every registered effect that observes ``"forces"``).
    """
    case = model.case
    check_window(measurement.path, measurement.window_s, case)
    ctx = ForceContext(measurement, case)
    state = replace(model, case=with_spindle_hz(case, ctx.spindle_hz))
    library = [e for e in (effects if effects is not None else effects_for("forces", state))
               if hasattr(e, "family") and e.applicable(state)]
    sel = _select_forces(ctx, state, library, alpha=alpha, max_effects=max_effects, progress=progress)
    start, final = sel.base.state, sel.state
    _, floor = heldout_error(start.heldout, ctx.heldout)
    final_ho = final.heldout
    verdict = _force_unexplained(ctx, final_ho, sel.error_after, floor, alpha, case.tool.teeth)
    fits = tuple(_finished(f, library, verdict["unexplained"]) for f in sel.effects)
    extra = {"spindle_hz": ctx.spindle_hz, "spindle_rpm": ctx.spindle_hz * 60.0,
             "phase_shift_rev": final.shift, "bins_per_rev": ctx.bins,
             "revolutions": {"train": ctx.train.n, "heldout": ctx.heldout.n},
             "heldout_span_s": list(ctx.heldout.t_span_s),
             "signatures_before": spectrum_lines(ctx.heldout.mean - start.heldout, case.tool.teeth),
             "signatures_after": spectrum_lines(ctx.heldout.mean - final_ho, case.tool.teeth),
             "not_applicable": {e.name: e.reason_not_applicable(state) for e in FORCE_EFFECTS
                                if not e.applicable(state)},
             "noise_floor_meaning": "RMS sigma/sqrt(N) of the held-out average over RMS of the measured average",
             "selection": {"rule": "forward-backward, joint refit, Bonferroni over 2 max_effects x candidates",
                           "n_tests": sel.n_tests, "z_threshold": sel.threshold}}
    res = Identification(kind="forces", effects=fits, error_before=sel.error_before,
                         error_after=sel.error_after, metric=ERROR_METRIC, noise_floor=floor, steps=sel.steps,
                         model_toml=model_toml(final.model), extra=extra, unexplained=verdict,
                         arrays={"heldout_measured_n": ctx.heldout.mean, "model_before_n": start.heldout,
                                 "model_after_n": final_ho, "heldout_noise_n": ctx.heldout.noise})
    detected = force_signatures(ctx.heldout.mean, start.heldout, ctx.heldout.noise, case.tool.teeth, alpha=alpha)
    return annotate(res, detected, library)


def force_determined(eff, tool, values, cov) -> dict:
    """What a force fit determines (:func:`identify.evidence.determined`, log variables for log
    parameters); for runout also the tooth-radius differences ``r_j - r_0`` (what the forces see)
    with their standard deviations (delta method on the fit's covariance)."""
    values = np.asarray(values, float)
    if cov is None:
        return {}
    jac = np.array([1.0 / v if p.log and v > 0 else 1.0 for p, v in zip(eff.parameters, values)])
    out = determined([(p.name, p) for p in eff.parameters], list(values), cov * np.outer(jac, jac))
    if eff.name == "runout" and np.all(np.isfinite(cov)):
        from robolobes.cases.milling import eccentric_runout

        def diff(v):
            r = np.asarray(eccentric_runout(tool, float(v[0]), float(v[1])), float)
            return r[1:] - r[0]
        d0 = diff(values)
        G = np.column_stack([(diff(values + h) - d0) / h[k] for k, h in
                             enumerate((np.array([1e-9, 0.0]), np.array([0.0, 1e-6])))])
        sd = np.sqrt(np.clip(np.diag(G @ cov @ G.T), 0, None))
        out["shared"] = [{"quantity": f"tooth {j + 1} radius minus tooth 0's (m)", "value": float(d0[j]),
                          "sd": float(sd[j])} for j in range(len(d0))]
        out["meaning"] = ("the forces depend on the teeth's radius differences; the offset's amplitude and phase "
                          "are reported only where the combinations above say they are determined")
    return out


def _finished(fit: EffectFit, library, surrogate: bool) -> EffectFit:
    """The force effect with ``credible``, ``determined`` and ``surrogate`` set."""
    eff = next(e for e in library if e.name == fit.name)
    ok, why = credibility(eff, fit.params)
    return replace(fit, credible=ok, not_credible_because=tuple(why), determined=fit.evidence.get("determined", {}),
                   surrogate=bool(surrogate))


def _force_unexplained(ctx, final_ho: np.ndarray, error: float, floor: float, alpha: float, teeth: int) -> dict:
    """The verdict on the final held-out residual of a force series (:func:`identify.evidence.unexplained`)
    and where it stays above the noise: force axes (ratio of RMS residual to RMS noise against their own
    margin, Bonferroni over the axes) and the signatures of the final residual."""
    from .evidence import ESTIMATOR_TOL, margin, unexplained

    meas, noise = ctx.heldout.mean[:, :2], ctx.heldout.noise[:, :2]
    r = final_ho[:, :2] - meas
    out = unexplained(error, floor, r.size, alpha, False, ESTIMATOR_TOL["forces"])
    where: dict = {"axes": []}
    for a, name in enumerate("xy"):
        ratio = float(np.sqrt(np.mean(r[:, a] ** 2) / np.mean(noise[:, a] ** 2)))
        lim = margin(r.shape[0], alpha / 2, False, ESTIMATOR_TOL["forces"])
        if ratio > lim:
            where["axes"].append({"name": f"F{name}", "ratio_to_noise": ratio, "margin": lim})
    if out["unexplained"]:
        det = force_signatures(ctx.heldout.mean, final_ho, ctx.heldout.noise, teeth, alpha=alpha)
        where["signatures"] = [k for k, v in det.items() if v.present]
    out["where"] = where
    return out


# ---------------------------------------------------------------------------------------------
# force statistics (8 numbers)
# ---------------------------------------------------------------------------------------------

#: Angle bins per revolution for the statistics of a model run.
STATS_BINS = 720
#: Most parameters fitted to 8 statistics.
MAX_STATS_PARAMS = 3


def _stats_of(avg: np.ndarray) -> np.ndarray:
    """(x min, max, mean, rms, y min, max, mean, rms) of a periodic average (bins, >=2), N."""
    out = []
    for j in range(2):
        a = avg[:, j]
        out += [a.min(), a.max(), a.mean(), math.sqrt(float(np.mean(a ** 2)))]
    return np.array(out)


class _StatsContext:
    """Model averages over the statistics window: one block of every revolution in it."""

    def __init__(self, stats: ForceStatistics, case):
        self.spindle_hz = case.cut.spindle_rpm / 60.0
        self.bins = STATS_BINS
        t0, t1 = stats.window_s
        period = 1.0 / self.spindle_hz
        n = int(math.floor((t1 - t0) / period))
        self.blocks = [t0 + period * np.arange(n)]
        self.t_end_s = float(t0 + (n + 1) * period)

    raw_averages = ForceContext.raw_averages
    filtered = ForceContext.filtered
    averages = ForceContext.averages


def _fit_stats(ctx, combo, state, target):
    """Fit a combination of effects to the 8 statistics; returns (values per effect, sigma, rss, on_bound,
    fitted statistics). Cut-model effects combine by superposition of their changes of the average
    (first order), measurement-chain effects filter the result."""
    from scipy.optimize import least_squares

    sizes = [len(e.params) for e in combo]
    lo = np.concatenate([np.array(e.lower, float) for e in combo])
    hi = np.concatenate([np.array(e.upper, float) for e in combo])
    scale = hi - lo
    base = ctx.raw_averages(state)[0]
    fams = [e.family(ctx, state) for e in combo]
    h_state = chain_transfer(state.chain) if state.chain else None

    def model(x):
        v = lo + x * scale
        avg, k, chains = base.copy(), 0, []
        for e, n, fam in zip(combo, sizes, fams):
            if e.chain:
                chains.append(e.transfer(v[k:k + n]))
            else:
                avg = avg + (fam(v[k:k + n])[0] - base)
            k += n
        for h in chains + ([h_state] if h_state is not None else []):
            avg = ctx.filtered(avg, h)
        return _stats_of(avg)

    best = None
    starts = [np.concatenate(s) for s in itertools.product(*[e.starts() for e in combo])]
    for v0 in starts[:8]:
        x0 = np.clip((v0 - lo) / scale, 1e-3, 1 - 1e-3)
        r = least_squares(lambda x: model(x) - target, x0, bounds=(0, 1), diff_step=1e-4)
        if best is None or r.cost < best.cost:
            best = r
    assert best is not None  # at least one start
    v = lo + best.x * scale
    out, k = [], 0
    for n in sizes:
        out.append(v[k:k + n])
        k += n
    sig = np.full(len(v), np.nan)
    try:
        cov = np.linalg.inv(best.jac.T @ best.jac) * (2 * best.cost / max(len(target) - len(v), 1))
        sig = np.sqrt(np.clip(np.diag(cov), 0, None)) * scale
    except np.linalg.LinAlgError:
        pass
    on_bound = _on_bound(best.x, combo, 1e-4)
    return out, sig, 2 * best.cost, on_bound, model(best.x)


def aicc(rss: float, n: int, k: int) -> float:
    """Akaike's criterion with the small-sample correction, for least squares with Gaussian errors."""
    if n - k - 1 <= 0:
        return math.inf
    return n * math.log(max(rss, 1e-300) / n) + 2 * k + 2 * k * (k + 1) / (n - k - 1)


def identify_force_stats(measurement: ForceStatistics, model: ModelState, *, alpha: float = 0.01,
                         max_effects: int = 3, progress=None, effects=None) -> Identification:
    """Fit at most 3 parameters of the library to 8 published force statistics by AICc (module docstring).

    ``alpha`` is not used (no held-out part: the choice is by AICc); ``max_effects`` bounds the size of
    the combinations tried."""
    stats, case, state = measurement, model.case, model
    check_window(stats.path, stats.window_s, case)
    lib = [e for e in (effects if effects is not None else effects_for("force_stats", state))
           if isinstance(e, ForceEffect)]
    ctx = _StatsContext(stats, case)
    target = stats.workpiece
    base = _stats_of(ctx.averages(state)[0])
    n = len(target)
    rss0 = float(np.sum((base - target) ** 2))
    rms0 = math.sqrt(rss0 / n)
    combos = [c for r in range(1, min(3, max_effects) + 1)
              for c in itertools.combinations([e for e in lib if e.applicable(state)], r)
              if sum(len(e.params) for e in c) <= MAX_STATS_PARAMS]
    table = [{"effects": [], "k": 0, "rss_n2": rss0, "aicc": aicc(rss0, n, 0), "rms_n": rms0}]
    best = None
    for i, combo in enumerate(combos):
        if progress:
            progress(f"force statistics {i + 1}/{len(combos)}: " + "+".join(e.name for e in combo))
        vals, sig, rss, on_bound, fitted = _fit_stats(ctx, combo, state, target)
        k = sum(len(e.params) for e in combo)
        row = {"effects": [e.name for e in combo], "k": k, "rss_n2": rss, "aicc": aicc(rss, n, k),
               "rms_n": math.sqrt(rss / n), "on_bound": on_bound,
               "params": [e.as_dict(v) for e, v in zip(combo, vals)]}
        table.append(row)
        if not on_bound and row["aicc"] < table[0]["aicc"] and (best is None or row["aicc"] < best[0]["aicc"]):
            best = (row, combo, vals, sig, fitted)
    fits, final = [], state
    err_after, fitted = rms0, base
    if best is not None:
        row, combo, vals, sig, fitted = best
        k = 0
        for e, v in zip(combo, vals):
            fits.append(EffectFit(name=e.name, params=e.as_dict(v), uncertainty=e.as_dict(sig[k:k + len(v)]),
                                  evidence={"aicc": row["aicc"], "aicc_without": table[0]["aicc"],
                                            "dof": n - row["k"], "rss_n2": row["rss_n2"]}))
            k += len(v)
            final = e.apply_values(final, v)
        err_after = row["rms_n"]
    table.sort(key=lambda r: r["aicc"])
    extra = {"n_statistics": n, "dof": n - (best[0]["k"] if best else 0), "aicc_table": table[:12],
             "target_workpiece_axes_n": target.tolist(), "model_before_n": base.tolist(),
             "model_after_n": np.asarray(fitted).tolist(), "error_unit": "N",
             "note": "statistics-only data: no held-out part; errors are the RMS over the 8 numbers in N"}
    return Identification(kind="force_stats", effects=tuple(fits), error_before=rms0, error_after=err_after,
                          metric="RMS over the 8 statistics (x, y min, max, mean, rms) of model - measured, N "
                                 "(training fit: statistics-only data have no held-out part; chosen by AICc)",
                          noise_floor=float("nan"), steps=(), model_toml=model_toml(final), extra=extra)
