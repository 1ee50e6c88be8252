"""The force model used for fitting: the linearized time-domain pass, its synchronous averages,
and the measurement chain.

Model forces come from the **linearized** time-domain path (:mod:`timedomain.simulate`, compiled
fast path: the linearization at the pass start with the full nonlinear milling force on the eroded
workpiece), run from t = 0 to the end of the measured window at the measured spindle speed. The
synthetic data of the tests come from the full nonlinear path instead (a different code path:
pinocchio's nonlinear dynamics, Newton on the full residual); the two agree to 3e-5 of the force
RMS on the aluminium pass (tests/test_fastpath.py), far below the 1-3 N noise of a measurement.

Runs are memoised per process (a pass takes ~2 s): the key is the cut, the law, the tool, the
robot variant and the end time.
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import replace

import numpy as np

from robolobes.cases.spec import MillingCase
from robolobes.core.threads import blas_single_threaded

__all__ = ["simulate_forces", "with_spindle_hz", "revolution_averages", "model_disc_count", "MODEL_MAX_LAG_DEG"]

#: Helix lag per axial disc of the model pass, deg. The time domain's default is 0.5 deg (its growth
#: rates are converged there), but a disc switches its share of the force on and off at once, and a
#: synchronous average resolves that staircase: on the aluminium pass 0.5 deg (22 discs) is 0.136 N RMS
#: per bin off the helix's continuous entry (the independent generator at 400 slices against 22), a
#: third of the 0.42 N noise of one bin of a 23-revolution average at 2 N, so a set with no effect sits
#: above the "unexplained" margin in some draws. At 0.25 deg (44 discs) the generator at 40 slices is
#: 0.019 N off its converged force, under a twentieth of that noise (docs/guide/identify-answers.md).
MODEL_MAX_LAG_DEG = 0.25

_CACHE: OrderedDict = OrderedDict()
_CACHE_SIZE = 128  # a backlash scan is 16 runs + its refinement (~0.7 MB per run of the aluminium set)


def _key(state, t_end_s: float) -> tuple:
    case = state.case
    r = case.robot
    return (case.name, repr(case.tool), repr(case.law), repr(case.cut), repr(case.path.ramp_s),
            float(case.path.approach_m), float(case.path.part_length_m), state.variant, repr(state.elements),
            round(float(t_end_s), 9), float(getattr(r, "backlash_half_width_rad", 0.0)),
            tuple(np.round(np.asarray(r.joint_damping, float), 12)))


def simulate_forces(state, t_end_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Forces on the workpiece (cut frame) of the linearized pass of a model state
    (:class:`identify.effects.ModelState`: case, variant, added elements) from 0 to ``t_end_s``.

    Returns ``(t_s (n,), force_n (n, 3))`` (N). Memoised (module docstring).
    """
    key = _key(state, t_end_s)
    if key in _CACHE:
        _CACHE.move_to_end(key)
        return _CACHE[key]
    out = _linearized_pass(state, t_end_s)
    _CACHE[key] = out
    if len(_CACHE) > _CACHE_SIZE:
        _CACHE.popitem(last=False)
    return out


@blas_single_threaded
def _linearized_pass(state, t_end_s: float) -> tuple[np.ndarray, np.ndarray]:
    """The time and workpiece force of :func:`timedomain.simulate`'s linearized pass, ``(t_s (n,),
    force_n (n, 3))`` (s, N), without what the fit does not read: the machined wall, the roughness, the
    stability summary and the read-only copies (a fifth of a pass's CPU). The same equations and
    kernel (:func:`timedomain.drivers.run_linearized`), so the same numbers (tests/test_force_model_pass.py)."""
    from robolobes.timedomain import LinearizedNewmark, SimulationProblem
    from robolobes.timedomain.drivers import run_linearized
    from robolobes.timedomain.equations import PassSetup

    problem = SimulationProblem(state.robot(), state.case, t_end_s=float(t_end_s))
    rec = run_linearized(PassSetup(problem, LinearizedNewmark(n_discs=model_disc_count(state.case))), None)
    return np.asarray(rec.t_s), -np.asarray(rec.force_tool_n)


def model_disc_count(case: MillingCase) -> int:
    """Axial discs of the model pass: :data:`MODEL_MAX_LAG_DEG` of helix lag per disc (1 for a straight
    tool)."""
    from robolobes.timedomain.workpiece import default_disc_count

    return default_disc_count(case.tool, case.cut.ap_m, max_lag_deg=MODEL_MAX_LAG_DEG)


def with_spindle_hz(case: MillingCase, spindle_hz: float) -> MillingCase:
    """The case at another spindle speed with the same feed rate (m/s): what a spindle whose real speed
    differs from the commanded one does (the feed axis and the spindle are driven independently)."""
    cut = case.cut
    rpm = spindle_hz * 60.0
    fz = cut.feed_per_tooth_m * cut.spindle_rpm / rpm
    return replace(case, cut=replace(cut, spindle_rpm=rpm, feed_per_tooth_m=fz))


def revolution_averages(t_s: np.ndarray, force_n: np.ndarray, spindle_hz: float, bins: int, blocks) -> list:
    """Synchronous averages of a (model) series over blocks of revolutions given by their start times.

    ``blocks``: list of arrays of revolution start times (s). Returns one (bins, 3) array per block: the
    mean over the revolutions of the block, resampled like the measurement (same pass times).
    """
    period = 1.0 / spindle_hz
    out = []
    grid = np.arange(bins) / bins * period
    t = np.asarray(t_s)
    for starts in blocks:
        tq = (np.asarray(starts)[:, None] + grid[None, :]).ravel()
        if tq[0] < t[0] - 1e-12 or tq[-1] > t[-1] + period / bins:
            raise ValueError(f"model run {t[0]:.4g}-{t[-1]:.4g} s does not cover the block {tq[0]:.4g}-{tq[-1]:.4g} s")
        x = np.stack([np.interp(tq, t, force_n[:, j]) for j in range(force_n.shape[1])], axis=-1)
        out.append(x.reshape(len(starts), bins, -1).mean(axis=0))
    return out

