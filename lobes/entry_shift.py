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
"""

from __future__ import annotations

import math

import numpy as np

from robolobes.cases.milling import engagement_rad, regeneration

from .exponent import FloquetExponent, two_level_exponent
from .problem import LobeProblem
from .sdm import SemiDiscretization

__all__ = ["entry_shift_impulses", "entry_shift_exponent"]


def entry_shift_impulses(problem: LobeProblem, m: int, slices: int, period_rad: float) -> list[tuple[int, np.ndarray]]:
    """Impulses ``(node, E)`` of the entry shift over one principal period of ``m`` steps (module
    docstring): ``E`` (3, 2) in N s/m, the force impulse on the tool being ``-E r``."""
    tool, cut, law = problem.tool, problem.cut, problem.law
    if cut.ae_m >= tool.diameter_m:
        return []
    st, ex = engagement_rad(tool, cut)
    down = cut.mode == "down"
    phi = st if down else ex
    sign = 1.0 if down else -1.0
    c, s = math.cos(phi), math.sin(phi)
    f = np.array([-law.ktc_pa * c - law.krc_pa * s, law.ktc_pa * s - law.krc_pa * c, law.kac_pa])
    omega = cut.omega_rad_s
    radius = tool.radius_m
    n_slices = slices if tool.helix_rad > 0 else 1
    db = cut.ap_m / n_slices
    z = (np.arange(n_slices) + 0.5) * db
    lag = tool.lag_rad(z)
    regs = regeneration(tool, cut)
    teeth = range(tool.teeth) if period_rad > math.pi * 2 / tool.teeth + 1e-12 else range(1)
    step = period_rad / m
    out: list[tuple[int, np.ndarray]] = []
    for j in teeth:
        r = regs[j]
        if not r.cuts or r.chip_m <= 0:
            continue
        E = sign * db * r.chip_m / (omega * radius) * np.outer(f, [0.0, 1.0])
        for psi in lag:
            pos = ((phi - tool.tooth_angle_rad[j] + psi) % period_rad) / step
            i0 = int(math.floor(pos))
            a = pos - i0
            out.append((i0 % m, (1 - a) * E))
            out.append(((i0 + 1) % m, a * E))
    return out


def entry_shift_exponent(problem: LobeProblem, method: SemiDiscretization | None = None,
                         with_entry: bool = True, surface_tilt: bool = False) -> FloquetExponent:
    """The Floquet exponent of ``problem`` with the entry-shift term (``with_entry=False``: without
    it, the same dense SDM), at ``m`` and ``2 m``, Richardson-extrapolated, 1/s. ``surface_tilt``:
    the dynamic chip along the regenerated surface's normal (:mod:`lobes.chip_direction`)."""
    def radius(engine, rpm, depth):
        m = engine.plan.m
        imp = entry_shift_impulses(problem, m, engine.plan.slices, engine.plan.period_rad) if with_entry else None
        return float(np.max(np.abs(np.linalg.eigvals(engine.monodromy_dense(rpm, depth, impulses=imp)))))
    return two_level_exponent(problem, method, radius, surface_tilt=surface_tilt)
