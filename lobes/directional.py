"""The time-discretized directional plan of a :class:`LobeProblem`: regeneration pattern and the
step-averaged directional matrices of the linearized force (the force law itself is :mod:`cases.milling`).

Linearized about the static cut, the force on the tool (cut frame, N) is::

    F(t) = sum_j W_j(t) (r(t) - r(t - tau_j)),    W_j(t) = sum_s db g(phi_j(t, z_s)) D(phi_j(t, z_s))

with ``D`` = :func:`cases.milling.directional_matrix` (3 x 2), ``g`` = :func:`cases.milling.in_cut`,
``phi_j(t, z) = Omega t + theta_j - psi(z)`` (``psi`` = :meth:`Tool.lag_rad`), ``db = ap / n_slices``
and slices at the mid-heights ``z_s = (s + 1/2) db``. Tooth ``j`` regenerates on the surface given by
:func:`cases.milling.regeneration` (delay ``tau_j = delay_rad_j / Omega``); a tooth that does not
reach the surface (runout) carries no force and the next tooth's delay is longer.

The principal period is :func:`cases.milling.principal_period`: the tooth period ``2 pi / (N Omega)``
when the pitch is uniform and every tooth regenerates on its predecessor, else one spindle revolution.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from robolobes.cases.milling import (ANGLE_TOL_RAD, CuttingLaw, Cut, PeriodName, Tool, directional_matrix, engagement_rad,
                                     in_cut, principal_period, regeneration)

from robolobes.core.validate import readonly

from ._errors import LobeError
from .chip_direction import delay_advance_rad, feed_per_radian_m, surface_rotation_rad

__all__ = ["DirectionalPlan", "PeriodChoice", "QuadratureRule", "average_directional_matrix"]

PeriodChoice = Literal["auto", "revolution"]
QuadratureRule = Literal["gauss", "midpoint"]


def average_directional_matrix(tool: Tool, cut: Cut, law: CuttingLaw, nodes: int = 200) -> np.ndarray:
    """Zero-order (time-averaged) directional matrix of one tooth per unit depth.

    ``a0 = (1 / 2 pi) * integral_{phi_st}^{phi_ex} D(phi) dphi`` (Gauss-Legendre, exact to
    rounding for the trigonometric integrand), shape (3, 2), N/m^2. The helix does not change it.
    """
    st, ex = engagement_rad(tool, cut)
    x, w = np.polynomial.legendre.leggauss(nodes)
    phi = st + (x + 1) * (ex - st) / 2
    D = directional_matrix(phi, law)
    return np.einsum("n,nij->ij", w, D) * (ex - st) / 2 / (2 * math.pi)


@functools.cache
def _gauss_nodes(q: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre nodes on [0, 1] and weights summing to 1, ``q`` points (read-only, computed
    once per ``q``: a lobe diagram asks for the same rule at every step average)."""
    x, w = np.polynomial.legendre.leggauss(q)
    return readonly((x + 1) / 2), readonly(w / 2)


@dataclass(frozen=True, eq=False)
class DirectionalPlan:
    """Time discretization of the cutting force over one principal period (depth-independent data).

    Attributes
    ----------
    period_rad : float
        Principal period as a spindle angle (``2 pi / N`` or ``2 pi``), rad.
    period_name : {"tooth", "revolution"}
        Which period it is (:func:`cases.milling.principal_period`, or "revolution" when forced).
    m : int
        Steps per principal period; step angle ``period_rad / m``.
    quadrature : int
        Quadrature points per step for averaging ``W`` (see :meth:`wbar`).
    slices : int
        Axial slices along the depth (1 without helix).
    tooth_angle_rad : array (Nc,)
        ``theta_j`` of the cutting teeth (over one principal period: all of them).
    tooth_group : array (Nc,) of int
        Index of the delay group of each cutting tooth.
    group_delay_rad : array (G,)
        Distinct regenerative delays as spindle angles, rad.
    group_r, group_f : arrays (G,)
        Delay in steps ``r + f`` (integer part >= 1, fraction in [0, 1)).
    k_force : int
        Force components carried (2, or 3 when the axial coefficient is non-zero).
    surface_tilt : bool
        The dynamic chip along the regenerated surface's normal instead of the ray (the first-order
        ``fz / R`` turn of :mod:`lobes.chip_direction`); default False, the linear model of the lobes.
    tooth_chip_m : array (Nc,) or None
        Static chip of each cutting tooth, m (:func:`cases.milling.regeneration`); the tilt uses it.
    slice_edge_rad : array (slices,) or None
        The block-edge angle of each axial slice, rad: the entry (down-milling) or the exit
        (up-milling) of the slice at the mid-height fraction ``(s + 1/2) / slices`` of the depth,
        in place of the uniform ``phi_st`` / ``phi_ex`` (e.g. from
        :func:`lobes.entry_shift.slice_edge_angles`); None (default): the uniform engagement.
    delay_time : bool
        The delayed instant of :mod:`lobes.chip_direction` (:func:`~lobes.chip_direction.delay_advance_rad`):
        :meth:`wbar` with ``delay_shift=True`` gives the weights of the extra delay; used only by
        :meth:`lobes.sdm.SDMEngine.monodromy_dense`. Default False.
    """

    tool: Tool
    cut: Cut
    law: CuttingLaw
    period_rad: float
    period_name: PeriodName
    m: int
    quadrature: int
    slices: int
    phi_st: float
    phi_ex: float
    tooth_angle_rad: np.ndarray
    tooth_group: np.ndarray
    group_delay_rad: np.ndarray
    group_r: np.ndarray
    group_f: np.ndarray
    k_force: int
    rule: QuadratureRule = "gauss"
    surface_tilt: bool = False
    tooth_chip_m: np.ndarray | None = None
    slice_edge_rad: np.ndarray | None = None
    delay_time: bool = False

    def period_s(self, rpm) -> np.ndarray:
        """The principal period at spindle speeds ``rpm`` (array, rpm), s: ``period_rad / omega``."""
        return self.period_rad / (2 * math.pi) * 60.0 / np.asarray(rpm, dtype=float)

    @classmethod
    def build(cls, tool: Tool, cut: Cut, law: CuttingLaw, *, m: int, quadrature: int, slices: int,
              period: PeriodChoice = "auto", k_force: int = 3,
              rule: QuadratureRule = "gauss", surface_tilt: bool = False,
              slice_edge_rad: np.ndarray | None = None, delay_time: bool = False) -> "DirectionalPlan":
        st, ex = engagement_rad(tool, cut)
        regs = regeneration(tool, cut)
        cutting = [r for r in regs if r.cuts]
        if not cutting:
            raise LobeError("no tooth cuts (runout larger than the feed for every tooth); nothing to regenerate")
        if period not in ("auto", "revolution"):
            raise LobeError(f"period must be 'auto' or 'revolution', got {period!r}")
        name: PeriodName = principal_period(tool, cut)[1] if period == "auto" else "revolution"
        period_rad = 2 * math.pi / tool.teeth if name == "tooth" else 2 * math.pi
        theta_all = np.array(tool.tooth_angle_rad)
        angles = np.array([theta_all[r.tooth] for r in cutting])
        delays = np.array([r.delay_rad for r in cutting])
        # group equal delays
        gd: list[float] = []
        grp = []
        for d in delays:
            for gi, v in enumerate(gd):
                if abs(v - d) <= ANGLE_TOL_RAD:
                    grp.append(gi)
                    break
            else:
                gd.append(float(d))
                grp.append(len(gd) - 1)
        step = period_rad / m
        rs, fs = [], []
        for d in gd:
            x = d / step
            r = math.floor(x + 1e-9)
            f = x - r
            if f < 1e-9:
                f = 0.0
            if x < 1.0 - 1e-9:
                raise LobeError(
                    f"m = {m} steps per principal period is too coarse: the shortest regenerative delay "
                    f"({math.degrees(d):.6g} deg of spindle rotation) is shorter than one step "
                    f"({math.degrees(step):.6g} deg); use m >= {math.ceil(period_rad / d - 1e-9)}"
                )
            rs.append(r)
            fs.append(f)
        return cls(tool=tool, cut=cut, law=law, period_rad=period_rad, period_name=name, m=int(m), quadrature=int(quadrature),
                   slices=int(slices), phi_st=st, phi_ex=ex, tooth_angle_rad=readonly(angles),
                   tooth_group=readonly(grp, int), group_delay_rad=readonly(gd),
                   group_r=readonly(rs, int), group_f=readonly(fs), k_force=int(k_force), rule=rule,
                   surface_tilt=bool(surface_tilt), tooth_chip_m=readonly([r.chip_m for r in cutting]),
                   slice_edge_rad=_checked_edges(slice_edge_rad, int(slices), cut.mode, st, ex),
                   delay_time=bool(delay_time))

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Entry and exit angles per slice, arrays (slices, 1), rad (:attr:`slice_edge_rad`)."""
        st = np.full((self.slices, 1), self.phi_st)
        ex = np.full((self.slices, 1), self.phi_ex)
        if self.slice_edge_rad is not None:
            (st if self.cut.mode == "down" else ex)[:, 0] = self.slice_edge_rad
        return st, ex

    @property
    def n_groups(self) -> int:
        return len(self.group_delay_rad)

    @property
    def step_rad(self) -> float:
        return self.period_rad / self.m

    def lag_max_rad(self, depth_m: float) -> float:
        return float(self.tool.lag_rad(depth_m))

    def candidate_steps(self, depth_max_m: float) -> np.ndarray:
        """Steps in which some tooth may be engaged for any depth up to ``depth_max_m`` (sorted)."""
        i = np.arange(self.m)
        a0 = i * self.step_rad
        a1 = a0 + self.step_rad
        lag = self.lag_max_rad(depth_max_m)
        twopi = 2 * math.pi
        hit = np.zeros(self.m, bool)
        b = self.bounds()
        st, ex = float(b[0].min()), float(b[1].max())
        for th in self.tooth_angle_rad:
            # phi in [a0 + th - lag, a1 + th] must meet [st, ex] modulo 2 pi
            lo = a0 + th - lag
            hi = a1 + th
            for shift in range(-3, 4):
                s = shift * twopi
                hit |= (hi + s >= st - 1e-12) & (lo + s <= ex + 1e-12)
        return np.flatnonzero(hit)

    def wbar(self, depth_m: np.ndarray, steps: np.ndarray, delay_shift: bool = False) -> np.ndarray:
        """Step-averaged directional matrices of each delay group.

        ``Wbar_i = (1 / dphi) * integral over step i of sum_s db g(phi) D(phi) dphi`` (as spindle
        angle). ``rule == "gauss"``: ``quadrature`` Gauss-Legendre points on the engaged part of
        the step of each tooth and slice (the integrand is smooth there, so the average is exact
        to rounding and the entry/exit discontinuities cost nothing). ``rule == "midpoint"``:
        ``quadrature`` midpoints of the whole step, screen function sampled (the classic code;
        its error at the entry/exit steps is O(dt / quadrature)).

        Parameters
        ----------
        depth_m : array (B,)
            Axial depths of cut, m (> 0).
        steps : array (P,) of int
            Step indices.
        delay_shift : bool
            Instead, the step averages of ``g(phi) D(phi) d(phi)``, ``d = -(h_j / R) cos(phi) / step_rad``
            the delayed instant's extra delay in steps (:func:`~lobes.chip_direction.delay_advance_rad`;
            negative: a shorter delay), N/m.

        Returns
        -------
        array (B, P, G, k_force, 2), N/m
        """
        b = np.asarray(depth_m, dtype=float).reshape(-1)
        steps = np.asarray(steps, dtype=int)
        out = np.zeros((len(b), len(steps), self.n_groups, self.k_force, 2))
        if len(steps) == 0 or len(b) == 0:
            return out
        a0 = steps * self.step_rad  # (P,) angle of each step's start
        if self.tool.helix_rad == 0:
            # W is linear in the depth: compute per unit depth once
            unit = np.zeros((len(steps), self.n_groups, self.k_force, 2))
            st, ex = (float(v[0, 0]) for v in self.bounds())
            for th, g, hj in zip(self.tooth_angle_rad, self.tooth_group, self._chips()):
                unit[:, g] += self._step_average(a0 + th, hj, st, ex, delay_shift)
            return b[:, None, None, None, None] * unit[None]
        # helix: the lag of each slice depends on the depth. Batched callers often repeat a depth
        # (a coarse scan evaluates one depth at every speed): compute each distinct depth once.
        ub, inv = np.unique(b, return_inverse=True)
        if len(ub) < len(b):
            return self.wbar(ub, steps, delay_shift)[inv.reshape(-1)]
        # chunk over depths to bound memory
        ns = self.slices
        zfrac = (np.arange(ns) + 0.5) / ns  # (ns,) slice mid-heights as fractions of the depth
        chunk = max(1, int(2e6 // max(1, len(steps) * self.quadrature * ns)))
        st, ex = (self.phi_st, self.phi_ex) if self.slice_edge_rad is None else (v[None] for v in self.bounds())
        for c0 in range(0, len(b), chunk):
            bc = b[c0:c0 + chunk]
            psi = self.tool.lag_rad(bc[:, None] * zfrac[None, :])  # (Bc, ns)
            for th, g, hj in zip(self.tooth_angle_rad, self.tooth_group, self._chips()):
                start = a0[None, None, :] + th - psi[:, :, None]  # (Bc, ns, P)
                avg = self._step_average(start, hj, st, ex, delay_shift).sum(axis=1)  # (Bc, P, k, 2)
                out[c0:c0 + chunk, :, g] += avg * (bc / ns)[:, None, None, None]
        return out

    def _nodes(self) -> tuple[np.ndarray, np.ndarray]:
        """Quadrature nodes (fractions of the interval) and weights (summing to 1) of ``rule``."""
        q = self.quadrature
        if self.rule == "midpoint":
            return (np.arange(q) + 0.5) / q, np.full(q, 1.0 / q)
        return _gauss_nodes(q)

    def _chips(self) -> np.ndarray:
        """Static chip of each cutting tooth, m (plans built without it: zeros, unused)."""
        return np.zeros(len(self.tooth_angle_rad)) if self.tooth_chip_m is None else self.tooth_chip_m

    def _directional(self, phi: np.ndarray, chip_m: float, delay_shift: bool = False) -> np.ndarray:
        """``D(phi)`` (..., k_force, 2); with ``surface_tilt`` the chip direction turned by the
        regenerated surface's tilt (:mod:`lobes.chip_direction`) for a tooth of static chip ``chip_m``;
        ``delay_shift``: times the extra delay in steps ``d(phi)`` (:meth:`wbar`)."""
        rot = None
        if self.surface_tilt:
            rot = surface_rotation_rad(phi, chip_m, self.tool.radius_m, feed_per_radian_m(self.tool, self.cut))
        D = directional_matrix(phi, self.law, rot)[..., :self.k_force, :]
        if delay_shift:
            D = D * self._delay_steps(phi, chip_m)[..., None, None]
        return D

    def _delay_steps(self, phi: np.ndarray, chip_m: float) -> np.ndarray:
        """The delayed instant's extra delay in steps at edge angles ``phi`` (rad) of a tooth with static
        chip ``chip_m`` (m): ``-(h_j / R) cos(phi) / step_rad`` (:func:`~lobes.chip_direction.delay_advance_rad`)."""
        return -delay_advance_rad(phi, chip_m, self.tool.radius_m) / self.step_rad

    def _step_average(self, start: np.ndarray, chip_m: float = 0.0, st=None, ex=None,
                      delay_shift: bool = False) -> np.ndarray:
        """Average of ``g(phi) D(phi)`` over one step for an edge whose angle at the step start is
        ``start`` (array (..., P), rad) of a tooth with static chip ``chip_m`` (m, used only with
        ``surface_tilt``): array (..., P, k_force, 2), N/m^2 (see :meth:`wbar`). ``st``, ``ex``: the
        engagement, floats or arrays broadcasting with ``start`` (default ``phi_st``, ``phi_ex``).
        ``delay_shift``: the integrand times the extra delay in steps (:meth:`wbar`)."""
        k, dphi = self.k_force, self.step_rad
        st = self.phi_st if st is None else st
        ex = self.phi_ex if ex is None else ex
        nodes, wts = self._nodes()
        if self.rule == "midpoint":
            phi = start[..., None] + nodes * dphi  # (..., P, q)
            D = self._directional(phi, chip_m, delay_shift)
            D = D * in_cut(phi, np.asarray(st)[..., None], np.asarray(ex)[..., None])[..., None, None]
            return np.einsum("...qij,q->...ij", D, wts)
        # Gauss: integrate only over the engaged part of the step (smooth integrand there)
        s0 = np.mod(start, 2 * math.pi)
        s1 = s0 + dphi
        acc = np.zeros(start.shape + (k, 2))
        for shift in (0.0, 2 * math.pi):
            lo = np.maximum(s0, st + shift)
            ln = np.minimum(s1, ex + shift) - lo
            sel = ln > 0
            if not sel.any():
                continue
            phi = lo[sel][:, None] + nodes[None, :] * ln[sel][:, None]  # (n_sel, q)
            D = self._directional(phi, chip_m, delay_shift)
            acc[sel] += np.einsum("nqij,q->nij", D, wts) * (ln[sel] / dphi)[:, None, None]
        return acc


def _checked_edges(edges, slices: int, mode: str, st: float, ex: float) -> np.ndarray | None:
    """``edges`` as a read-only array (slices,), each inside ``[0, pi]`` and before the exit (down)
    or after the entry (up); None stays None."""
    if edges is None:
        return None
    e = np.asarray(edges, dtype=float).reshape(-1)
    if e.shape != (slices,) or not np.all(np.isfinite(e)):
        raise LobeError(f"slice_edge_rad needs {slices} finite angles (one per axial slice), got {e.shape}")
    lo, hi = (0.0, ex) if mode == "down" else (st, math.pi)
    if np.any(e < lo) or np.any(e > hi):
        raise LobeError(f"slice_edge_rad must lie in [{lo:.6g}, {hi:.6g}] rad, got {e.min():.6g}..{e.max():.6g}")
    return readonly(e)
