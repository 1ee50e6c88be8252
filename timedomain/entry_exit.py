"""Entry and exit of the edge elements inside a time step on the eroded part, integrated exactly.

Why
---
Average-acceleration Newmark is the trapezoidal rule for the force: in its ``(q, v)`` form a step
is ``M (v1 - v0) + h/2 C (v0 + v1) + h/2 K (q0 + q1) = I_F`` with ``I_F = h/2 (F0 + F1)``. That is
second order only where the force is smooth over the step. An edge element that enters the part
inside a step (its chip jumps from 0 to about ``fz sin(phi_st)``, with the edge force ``K_e db``)
or leaves it (the edge force drops to 0) makes ``h/2 (F0 + F1)`` wrong by up to ``h/2`` times the
jump, a first-order error whose sign depends on where the step grid falls against each disc's entry
(with a helix every disc enters at another fraction of a step, so the rate changed with the disc
count and with a 1 % change of the step).

What
----
For every element whose chip is 0 at one end of the step and > 0 at the other (chips of the step's
two states, each evaluated before that state's material removal, as the force itself is), the
entry (or exit) fraction ``a`` of the step is located by bisection on the tip test (the tip in the
material is what makes the chip > 0), with the tool centre moved linearly and the tooth turned
uniformly over the step. The element's force is then integrated over its engaged part alone, by
the trapezoidal rule on ``N_SUB`` sub-intervals clustered quadratically towards the entry (exit),
where the chip ramps up on the flat block edge over a small angle (``a + (1 - a) (i / N)^2``); the
end values are the law's limit ``h -> 0+`` at the entry (``K_e db``, the edge force) and the
step's own chip at the other end. The difference ``D = 2 I_e / h - F0_e - F1_e`` (summed over the
elements) is added to the force of the step's end, so that the step integrates ``I_F`` exactly in
this sense. ``D`` is not a force at ``t1``: after the step the acceleration is reset to the one
consistent with the point force ``F1`` (``a1 - M^-1 J^T R_c^T D``), so the next step starts from
the true state (:func:`acceleration_shift`).

``D`` is computed once per step, at the Newton predictor (constant acceleration), and kept over
the iteration: the converged centre differs from the predicted one by ``O(h^2)``, which changes the
step's integral by ``O(h^3)`` per event, and it costs one evaluation per step instead of one per
iteration. Order: the linear interpolation of the centre over the step is ``O(h^2)`` and the
quadrature of the engaged part ``O(h^3)`` per event, so the scheme is second order again where the ramp is resolved
by the sub-intervals (a ramp of angle ``delta`` is resolved when ``dphi / N_SUB^2 < delta``).
Elements that enter and leave within one step are not seen (engagements shorter than a step).

The compiled loop (:mod:`timedomain.fastpath`) and its Python reference
(:func:`timedomain.equations.linear_system_python`) both call :func:`step_force_correction`.
"""

from __future__ import annotations


import math

import numpy as np
from numba import njit

import robolobes.cases.milling as _milling

from .workpiece import _chip_one, _tip_in_material

__all__ = ["N_SUB", "BISECTIONS", "step_force_correction", "acceleration_shift"]

#: Trapezoidal sub-intervals of each smooth piece of an element's engaged part of a step.
N_SUB = 4
#: Bisections locating an entry, an exit or the end of an entry ramp (resolve 2**-20 of a step).
BISECTIONS = 20
#: Chip of the law's limit h -> 0+ at the entry or exit (the edge force ``K_e db`` alone), m.
_H_EDGE = 1e-300
#: Tolerance of "on the block edge" for the boundary of a column, m (the edge is a stored constant).
_EDGE_TOL_M = 1e-12

_edge_force_law = njit(inline="always")(_milling.edge_force_law)
_project_cut_frame = njit(inline="always")(_milling.project_cut_frame)


@njit(inline="always")
def _element_force(hv, phi, db, law):  # pragma: no cover - numba
    et, er, ea = _edge_force_law(hv, db, law[0], law[1], law[2], law[3], law[4], law[5])
    return _project_cut_frame(phi, et, er, ea)


@njit(inline="always")
def _column_on_block_edge(wb, x0, dx, x, k, w_top):  # pragma: no cover - numba
    """Whether the column interval at ``x`` (m) of disc ``k`` is the untouched block edge."""
    u = (x - x0) / dx
    if not (u >= 0.0 and u < wb.shape[1] - 1):
        return False
    i = int(math.floor(u))
    return wb[k, i] >= w_top - _EDGE_TOL_M and wb[k, i + 1] >= w_top - _EDGE_TOL_M


@njit(inline="always")
def _on_block_edge(wb, x0, dx, cx, phi, r, k, hv, w_top):  # pragma: no cover - numba
    """Whether the chip ``hv`` of the element ends on the untouched block edge (the entry ramp: the
    ray leaves the material through the flat top of the part, not through an earlier tooth's arc)."""
    return hv > 0.0 and _column_on_block_edge(wb, x0, dx, cx + (r - hv) * math.sin(phi), k, w_top)


@njit(inline="always")
def _chip_at(wb, x0, dx, sgn, cx0, cy0, cx1, cy1, ph0, dphi, r, k, s):  # pragma: no cover - numba
    """Chip of the element at fraction ``s`` of the step (centre linear, tooth turning uniformly):
    ``(h, phi, cx, cw)``."""
    cx = cx0 + s * (cx1 - cx0)
    cw = sgn * (cy0 + s * (cy1 - cy0))
    ph = ph0 + s * dphi
    hv, _d0, _d1 = _chip_one(wb, x0, dx, cx, cw, sgn, ph, r, k)
    return hv, ph, cx, cw


@njit(inline="always")
def _crossing(wb, x0, dx, sgn, cx0, cy0, cx1, cy1, ph0, dphi, r, k, inside_at_start):  # pragma: no cover
    """Fraction of the step at which the tip enters (``inside_at_start`` False) or leaves the part."""
    lo = 0.0
    hi = 1.0
    for _ in range(BISECTIONS):
        s = 0.5 * (lo + hi)
        cx = cx0 + s * (cx1 - cx0)
        cy = cy0 + s * (cy1 - cy0)
        inside = _tip_in_material(wb, x0, dx, cx, sgn * cy, sgn, ph0 + s * dphi, r, k)
        if inside == inside_at_start:
            lo = s
        else:
            hi = s
    return 0.5 * (lo + hi)


@njit(inline="always")
def _ramp_end(wb, x0, dx, sgn, cx0, cy0, cx1, cy1, ph0, dphi, r, k, w_top, lo, hi, edge_at_lo):  # pragma: no cover
    """Fraction in ``(lo, hi)`` where the chip stops (``edge_at_lo``) or starts ending on the block edge."""
    for _ in range(BISECTIONS):
        s = 0.5 * (lo + hi)
        hv, ph, cx, cw = _chip_at(wb, x0, dx, sgn, cx0, cy0, cx1, cy1, ph0, dphi, r, k, s)
        if _on_block_edge(wb, x0, dx, cx, ph, r, k, hv, w_top) == edge_at_lo:
            lo = s
        else:
            hi = s
    return 0.5 * (lo + hi)


@njit(inline="always")
def _piece_integral(wb, x0, dx, sgn, cx0, cy0, cx1, cy1, ph0, dphi, r, k, db, law, s_lo, s_hi,
                    flo_x, flo_y, flo_z, fhi_x, fhi_y, fhi_z):  # pragma: no cover - numba
    """Trapezoidal integral (fractions of the step) of the element force over ``[s_lo, s_hi]`` on
    :data:`N_SUB` uniform sub-intervals, with the given end values."""
    ix = 0.5 * (flo_x + fhi_x)
    iy = 0.5 * (flo_y + fhi_y)
    iz = 0.5 * (flo_z + fhi_z)
    for i in range(1, N_SUB):
        s = s_lo + (s_hi - s_lo) * i / N_SUB
        hv, ph, _cx, _cw = _chip_at(wb, x0, dx, sgn, cx0, cy0, cx1, cy1, ph0, dphi, r, k, s)
        fx, fy, fz = _element_force(hv, ph, db, law)
        ix += fx
        iy += fy
        iz += fz
    w = (s_hi - s_lo) / N_SUB
    return w * ix, w * iy, w * iz


@njit(inline="always")
def _engaged_end(wb, x0, dx, sgn, w_top, cx0, cy0, cx1, cy1, ph0, dphi, r, k, db, law, h_end, s_end, crosses,
                 inside_at_start):  # pragma: no cover - numba
    """One end of an element's engaged part of the step: ``(s, on the block edge, force (3))``; at the
    step's end ``s_end`` with its chip ``h_end``, or, where the element ``crosses`` the boundary, at
    the crossing with the law's limit h -> 0+."""
    if crosses:
        s = _crossing(wb, x0, dx, sgn, cx0, cy0, cx1, cy1, ph0, dphi, r, k, inside_at_start)
        ph = ph0 + s * dphi
        edge = _column_on_block_edge(wb, x0, dx, cx0 + s * (cx1 - cx0) + r * math.sin(ph), k, w_top)
        fx, fy, fz = _element_force(_H_EDGE, ph, db, law)
    else:
        s = s_end
        ph = ph0 + s * dphi
        edge = _on_block_edge(wb, x0, dx, cx0 + s * (cx1 - cx0), ph, r, k, h_end, w_top)
        fx, fy, fz = _element_force(h_end, ph, db, law)
    return s, edge, fx, fy, fz


@njit(cache=True, nogil=True)
def step_force_correction(wb, x0, dx, sgn, w_top, cx0, cy0, cx1, cy1, ang0, dphi, offset, radius, db, law, h0, h1,
                          out):  # pragma: no cover - numba
    """``D`` (3,) N, cut frame, written into ``out``: the force to add at the end of the step so that
    the trapezoidal rule integrates the entering, leaving and ramping elements over their smooth
    pieces (module docstring). Returns the number of elements so treated.

    wb, x0, dx, sgn, w_top: the workpiece (:meth:`Workpiece._kernel_state`); (cx0, cy0), (cx1, cy1):
    tool centre at the step's start and end, m; ang0: spindle angle at the start, rad; dphi: its
    change over the step, rad; offset (T, K) element angle offsets, rad; radius (T,) tip radii, m;
    db: disc height, m; law (6,): Ktc, Krc, Kac (Pa), Kte, Kre, Kae (N/m); h0, h1 (T, K): chips at
    the two ends, m (each before its state's removal).
    """
    nt, nk = offset.shape
    out[0] = 0.0
    out[1] = 0.0
    out[2] = 0.0
    events = 0
    for j in range(nt):
        r = radius[j]
        for k in range(nk):
            if h0[j, k] <= 0.0 and h1[j, k] <= 0.0:
                continue
            enter = h0[j, k] <= 0.0
            leave = h1[j, k] <= 0.0
            ph0 = ang0 + offset[j, k]
            ph1 = ph0 + dphi
            if not (enter or leave):  # engaged at both ends: an event only where the entry ramp ends
                if (_on_block_edge(wb, x0, dx, cx0, ph0, r, k, h0[j, k], w_top)
                        == _on_block_edge(wb, x0, dx, cx1, ph1, r, k, h1[j, k], w_top)):
                    continue  # smooth over the whole step: the trapezoidal rule as it is
            # the ends of the engaged part and whether the chip ends on the block edge there
            s_lo, e_lo, flx, fly, flz = _engaged_end(wb, x0, dx, sgn, w_top, cx0, cy0, cx1, cy1, ph0, dphi, r, k, db,
                                                     law, h0[j, k], 0.0, enter, False)
            s_hi, e_hi, fhx, fhy, fhz = _engaged_end(wb, x0, dx, sgn, w_top, cx0, cy0, cx1, cy1, ph0, dphi, r, k, db,
                                                     law, h1[j, k], 1.0, leave, True)
            events += 1
            if e_lo != e_hi:  # the ramp on the block edge starts or ends inside: split there too
                s_m = _ramp_end(wb, x0, dx, sgn, cx0, cy0, cx1, cy1, ph0, dphi, r, k, w_top, s_lo, s_hi, e_lo)
                hm, phm, _cx, _cw = _chip_at(wb, x0, dx, sgn, cx0, cy0, cx1, cy1, ph0, dphi, r, k, s_m)
                fmx, fmy, fmz = _element_force(hm, phm, db, law)
                ax, ay, az = _piece_integral(wb, x0, dx, sgn, cx0, cy0, cx1, cy1, ph0, dphi, r, k, db, law,
                                             s_lo, s_m, flx, fly, flz, fmx, fmy, fmz)
                bx, by, bz = _piece_integral(wb, x0, dx, sgn, cx0, cy0, cx1, cy1, ph0, dphi, r, k, db, law,
                                             s_m, s_hi, fmx, fmy, fmz, fhx, fhy, fhz)
                ix, iy, iz = ax + bx, ay + by, az + bz
            else:
                ix, iy, iz = _piece_integral(wb, x0, dx, sgn, cx0, cy0, cx1, cy1, ph0, dphi, r, k, db, law,
                                             s_lo, s_hi, flx, fly, flz, fhx, fhy, fhz)
            # D_e = 2 I_e - F0_e - F1_e, with the element's own end values (0 outside the part)
            f0x, f0y, f0z = _element_force(h0[j, k], ph0, db, law)
            f1x, f1y, f1z = _element_force(h1[j, k], ph1, db, law)
            out[0] += 2.0 * ix - f0x - f1x
            out[1] += 2.0 * iy - f0y - f1y
            out[2] += 2.0 * iz - f0z - f1z
    return events


def acceleration_shift(M: np.ndarray, JtRt: np.ndarray) -> np.ndarray:
    """``M^-1 J^T R_c^T`` (n, 3): the acceleration per newton of ``D`` in the cut frame, to take out
    of a step's end acceleration after the step (module docstring)."""
    return np.ascontiguousarray(np.linalg.solve(np.asarray(M, float), np.asarray(JtRt, float)))


class StepForce:
    """The Python side of the correction, for :func:`timedomain.newmark.integrate` callers: the force
    at a step's end with ``D`` added, and the step's start (time, centre, chips) moved on at each
    accepted step.

    Parameters
    ----------
    milling : timedomain.workpiece_force.MillingForce
    omega_rad_s : float
        Spindle speed, rad/s.
    t0_s : float
        Time of the first step's start, s.
    center0_m : array (2,)
        Tool centre there, cut frame, m.
    chips0_m : array (T, K)
        Chips there (before any removal), m.
    exact : bool
        False: ``D = 0`` (the force sampled at the step ends, for comparison).
    """

    def __init__(self, milling, omega_rad_s: float, t0_s: float, center0_m, chips0_m, *, exact: bool = True):
        self.exact = bool(exact)
        self.milling, self.omega = milling, float(omega_rad_s)
        self.t0 = float(t0_s)
        self.c0 = np.array(center0_m, dtype=float)
        self.h0 = np.ascontiguousarray(chips0_m, dtype=float).copy()
        self.last_chips: np.ndarray = self.h0
        self.last_center: np.ndarray = self.c0
        self.last_d = np.zeros(3)
        self._d_t1 = math.nan

    def force(self, t1_s: float, center1_m) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(F1, dF1/dc, D)``: the point force on the tool at the step's end (cut frame, N), its
        derivative with respect to the tool centre (3, 2) (N/m, the milling force's tangent), and the
        correction ``D`` (3,) N (not differentiated: Newton treats it as a constant)."""
        m = self.milling
        c1 = np.asarray(center1_m, dtype=float)
        f, dfdc, h1, _ = m._evaluate(self.omega * t1_s, c1, m.tangent)
        wb, x0, dx, sgn, _, w_top = m.workpiece._kernel_state()[:6]
        law = m.law
        law_arr = np.array([law.ktc_pa, law.krc_pa, law.kac_pa, law.kte_n_per_m, law.kre_n_per_m, law.kae_n_per_m])
        if t1_s == self._d_t1:  # D of this step, from its first evaluation (the predictor)
            self.last_chips, self.last_center = h1, c1
            return f, dfdc, self.last_d
        d = np.zeros(3)
        self._d_t1 = t1_s
        if self.exact:
            step_force_correction(wb, x0, dx, sgn, w_top, self.c0[0], self.c0[1], float(c1[0]), float(c1[1]),
                                  self.omega * self.t0, self.omega * (t1_s - self.t0),
                                  np.ascontiguousarray(m.immersion_rad(0.0)), np.ascontiguousarray(m.tooth_radius_m),
                                  float(m.db_m), law_arr, self.h0, np.ascontiguousarray(h1), d)
        self.last_chips, self.last_center, self.last_d = h1, c1, d
        return f, dfdc, d

    def accept(self, t1_s: float, center1_m) -> np.ndarray:
        """Move the step's start to the accepted end (chips of the last evaluation); returns the ``D``
        of that evaluation, N."""
        self.t0 = float(t1_s)
        self.c0 = np.array(center1_m, dtype=float)
        self.h0 = np.ascontiguousarray(self.last_chips, dtype=float).copy()
        self._d_t1 = math.nan
        return self.last_d
