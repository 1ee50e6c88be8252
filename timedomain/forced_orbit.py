"""The forced periodic orbit of a simulated pass: the synchronous part of the tool's normal
deflection over the steady window, and the deflection when the teeth meet the part.

The eroded part is linearized about this orbit, not about the mean deflection: a tooth's
engagement starts where its edge meets the block face, at the tool's deflection of that instant
(docs/guide/timedomain-convergence.md, "The steel damping bracket: the eroded part's floor").
The functions take a :class:`~robolobes.timedomain.result.SimulationResult`: its
``steady_window_s`` (full engagement), its cut-frame deviation ``tcp_deviation_m`` (n_t, 3), m, the force on
the tool ``force_tool_n`` (n_t, 3), N, and the spindle angle ``spindle_angle_rad`` (n_t,), rad.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from robolobes.cases.milling import principal_period

__all__ = ["entry_deflection", "mean_deflection", "orbit_period_s", "sync_deflection"]


def orbit_period_s(tool, cut) -> float:
    """Period of the forced orbit, s: the principal (tooth) period, or the spindle revolution for a
    tool with runout, whose teeth meet the part at different deflections (the orbit and the motion
    about it then repeat once per revolution)."""
    from .summary import has_runout
    return cut.spindle_period_s if has_runout(tool) else principal_period(tool, cut)[0]


def _steady(r) -> np.ndarray:
    """Boolean mask (n_t,) of the run's steady window (full engagement)."""
    t0, t1 = r.steady_window_s
    t = np.asarray(r.t_s)
    return (t >= t0) & (t <= t1)


def mean_deflection(r) -> float:
    """Mean normal deflection over the steady window, m (> 0: away from the material's side the cut
    frame's y points to; the eroded part then cuts the radial depth ``ae`` minus it)."""
    return float(np.mean(np.asarray(r.tcp_deviation_m)[_steady(r), 1]))


def entry_deflection(r, bins: int = 90) -> float:
    """Normal deflection when the teeth meet the part, m: the synchronous average over the tooth
    period (``bins`` phases over the steady window) of the cut-frame normal deviation, at the phase
    where the synchronous cutting force rises most (one number: the helix spreads the entry over
    some degrees, where the deflection changes little, see :func:`lobes.entry_shift.slice_edge_angles`)."""
    sel = _steady(r)
    t0 = r.steady_window_s[0]
    case = r.problem.case
    tp, _ = principal_period(case.tool, case.cut)
    t = np.asarray(r.t_s)[sel]
    b = np.floor((((t - t0) / tp) % 1.0) * bins).astype(int)
    f = np.linalg.norm(np.asarray(r.force_tool_n)[sel, :2], axis=1)
    y = np.asarray(r.tcp_deviation_m)[sel, 1]
    fa = np.bincount(b, f, bins) / np.bincount(b, None, bins)
    ya = np.bincount(b, y, bins) / np.bincount(b, None, bins)
    return float(ya[(int(np.argmax(np.roll(fa, -1) - fa)) + 1) % bins])


def sync_deflection(r, harmonics: int = 20) -> Callable[[np.ndarray], np.ndarray]:
    """The synchronous normal deflection over the steady window as a function of the spindle angle
    (array of rad in, array of m out, same shape): a least-squares Fourier series in the tooth
    period (``harmonics`` harmonics of the tooth passing; the non-synchronous motion averages out)."""
    sel = _steady(r)
    teeth = r.problem.case.tool.teeth
    k = np.arange(1, harmonics + 1)

    def basis(a):
        x = np.multiply.outer(np.asarray(a, dtype=float) * teeth, k)
        return np.concatenate([np.ones(x.shape[:-1] + (1,)), np.cos(x), np.sin(x)], axis=-1)
    coef = np.linalg.lstsq(basis(np.asarray(r.spindle_angle_rad)[sel]), np.asarray(r.tcp_deviation_m)[sel, 1],
                           rcond=None)[0]
    return lambda a: basis(a) @ coef
