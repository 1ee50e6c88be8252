"""The entry shift: the non-delayed force term of a tooth meeting the flat block edge.

In the eroded part (:mod:`timedomain.workpiece`) a tooth meets the uncut block where its tip
crosses the flat block edge, at ``y_c = -(R - ae)`` (down-milling) or ``+(R - ae)`` (up-milling)
from the nominal tool axis. With the tool displaced by ``r = (x, y)`` in the cut frame::

    down: cos(phi_st) = -(R - ae + y) / R      up: cos(phi_ex) = (R - ae - y) / R

so ``d phi / d y = 1 / (R sin phi)`` at that angle (the feed direction ``x`` does not move it).
Down-milling: the entry comes later by that angle, the tooth misses the chip it would have cut
there; up-milling: the exit comes later, the tooth cuts more. The chip at the block edge is the
static chip ``h_j sin(phi)`` (the dynamic part is of second order), so each edge element of width
``db`` of tooth ``j`` gives, once per revolution at the instant it crosses the edge, the impulse::

    dI = -s (db h_j / (Omega R)) f(phi) y,      s = +1 down, -1 up

with ``f(phi) = (-Ktc cos - Krc sin, Ktc sin - Krc cos, Kac)`` the force on the tool per unit chip
and width (:mod:`cases.milling`); ``sin(phi)`` cancels. This is a periodic, impulsive,
non-delayed stiffness proportional to the feed per tooth. The linear regenerative model of the
lobes (and :class:`~robolobes.timedomain.DelayNewmark`) keeps the engagement fixed and lacks it;
its static part is the narrowing of the immersion by the mean deflection (``ae - dy``).

:func:`entry_shift_exponent` adds the term to the plain SDM (:meth:`SDMEngine.monodromy_dense`): each
impulse is split between the two mesh nodes around its instant, linearly, and the exponent is
Richardson-extrapolated from ``m`` and ``2 m`` like :func:`lobes.exponent.floquet_exponent`.
A full slot (``ae = D``) has no block edge: no term.

Per-slice edges (optional, default off): linearized about a forced periodic orbit instead of the
static cut, each axial slice meets the edge when its own tooth edge gets there, with the tool at the
orbit's deflection of that instant. :func:`slice_edge_angles` solves for that angle per slice, and
``slice_edge_rad`` carries it into the SDM's engagement and into the impulses (each slice's impulse
at its own angle, with ``f`` of that angle). A uniform edge equal to the cut's own is the plain term.
"""

from __future__ import annotations

import math

import numpy as np

from collections.abc import Callable

from robolobes.cases.milling import Cut, Tool, engagement_rad, regeneration

from ._errors import LobeError

from .exponent import FloquetExponent, two_level_exponent
from .problem import LobeProblem
from .sdm import SemiDiscretization

__all__ = ["entry_shift_impulses", "entry_shift_exponent", "slice_edge_angles"]


def entry_shift_impulses(problem: LobeProblem, m: int, slices: int, period_rad: float,
                         slice_edge_rad: np.ndarray | None = None) -> list[tuple[int, np.ndarray]]:
    """Impulses ``(node, E)`` of the entry shift over one principal period of ``m`` steps (module
    docstring): ``E`` (3, 2) in N s/m, the force impulse on the tool being ``-E r``.
    ``slice_edge_rad`` (slices,): each slice's own edge angle, rad (None: the cut's, uniform)."""
    tool, cut, law = problem.tool, problem.cut, problem.law
    if cut.ae_m >= tool.diameter_m:
        return []
    st, ex = engagement_rad(tool, cut)
    down = cut.mode == "down"
    phi = st if down else ex
    sign = 1.0 if down else -1.0
    omega = cut.omega_rad_s
    radius = tool.radius_m
    n_slices = slices if tool.helix_rad > 0 else 1
    db = cut.ap_m / n_slices
    z = (np.arange(n_slices) + 0.5) * db
    lag = tool.lag_rad(z)
    edge = np.full(n_slices, phi) if slice_edge_rad is None else np.asarray(slice_edge_rad, float).reshape(n_slices)
    c, s = np.cos(edge), np.sin(edge)
    f = np.stack([-law.ktc_pa * c - law.krc_pa * s, law.ktc_pa * s - law.krc_pa * c, np.full(n_slices, law.kac_pa)], 1)
    regs = regeneration(tool, cut)
    teeth = range(tool.teeth) if period_rad > math.pi * 2 / tool.teeth + 1e-12 else range(1)
    step = period_rad / m
    out: list[tuple[int, np.ndarray]] = []
    for j in teeth:
        r = regs[j]
        if not r.cuts or r.chip_m <= 0:
            continue
        for psi, ph, fs in zip(lag, edge, f):
            E = sign * db * r.chip_m / (omega * radius) * np.outer(fs, [0.0, 1.0])
            pos = ((ph - tool.tooth_angle_rad[j] + psi) % period_rad) / step
            i0 = int(math.floor(pos))
            a = pos - i0
            out.append((i0 % m, (1 - a) * E))
            out.append(((i0 + 1) % m, a * E))
    return out


def entry_shift_exponent(problem: LobeProblem, method: SemiDiscretization | None = None,
                         with_entry: bool = True, surface_tilt: bool = False,
                         slice_edge_rad: np.ndarray | None = None, delay_time: bool = False) -> FloquetExponent:
    """The Floquet exponent of ``problem`` with the entry-shift term (``with_entry=False``: without
    it, the same dense SDM), at ``m`` and ``2 m``, Richardson-extrapolated, 1/s. ``surface_tilt``:
    the dynamic chip along the regenerated surface's normal (:mod:`lobes.chip_direction`).
    ``slice_edge_rad``: the block-edge angle of each axial slice (``method.axial_slices`` of them,
    :func:`slice_edge_angles`), in the engagement and in the impulses; None: the cut's own.
    ``delay_time``: the delayed displacement at the instant the previous tooth cut the point
    (:mod:`lobes.chip_direction`, :meth:`SDMEngine.monodromy_dense`); default False."""
    def radius(engine, rpm, depth):
        plan = engine.plan
        imp = (entry_shift_impulses(problem, plan.m, plan.slices, plan.period_rad, plan.slice_edge_rad)
               if with_entry else None)
        return float(np.max(np.abs(np.linalg.eigvals(engine.monodromy_dense(rpm, depth, impulses=imp)))))
    return two_level_exponent(problem, method, radius, surface_tilt=surface_tilt, slice_edge_rad=slice_edge_rad,
                              delay_time=delay_time)


def slice_edge_angles(tool: Tool, cut: Cut, slices: int, deflection: Callable[[np.ndarray], np.ndarray],
                      tol_rad: float = 1e-13, max_iter: int = 100) -> np.ndarray:
    """The block-edge angle of each axial slice on a forced periodic orbit, rad, array (slices,).

    Slice ``s`` at mid-height ``z_s = (s + 1/2) ap / slices`` of the first tooth (angle
    ``phi = a + theta_0 - psi(z_s)`` at spindle angle ``a``) meets the edge at the angle solving
    ``cos(phi) = -(R - ae + y(a)) / R`` (down) or ``(R - ae - y(a)) / R`` (up), with
    ``y = deflection(a)`` the tool centre's normal deflection (m, cut frame) at spindle angle ``a``
    (rad, array in, array out); solved by fixed-point iteration from the static cut. The pitch must
    be uniform (the orbit is then the same for every tooth, shifted by its pitch)."""
    if max(tool.pitch_rad) - min(tool.pitch_rad) > 1e-12:
        raise LobeError("slice_edge_angles needs a uniform pitch (one orbit for every tooth)")
    st, ex = engagement_rad(tool, cut)
    down = cut.mode == "down"
    n = slices if tool.helix_rad > 0 else 1
    offset = tool.lag_rad((np.arange(n) + 0.5) * cut.ap_m / n) - tool.tooth_angle_rad[0]
    big_r = tool.radius_m
    phi = np.full(n, st if down else ex)
    for _ in range(max_iter):
        y = np.asarray(deflection(phi + offset), dtype=float)
        c = -(big_r - cut.ae_m + y) / big_r if down else (big_r - cut.ae_m - y) / big_r
        new = np.arccos(np.clip(c, -1.0, 1.0))
        if np.max(np.abs(new - phi)) <= tol_rad:
            return new
        phi = new
    raise LobeError(f"slice_edge_angles: no convergence in {max_iter} iterations")
