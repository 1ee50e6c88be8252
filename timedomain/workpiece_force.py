"""The milling force of a discretized end mill on the eroded workpiece (paper eq. 13-15), and runs
along a prescribed (rigid-tool) motion.

The force law, the angle convention and the projection are those of :mod:`cases.milling`
(:func:`~cases.milling.edge_forces`, :func:`~cases.milling.tool_force_cut_frame`,
:func:`~cases.milling.directional_matrix`); this module only supplies the geometry: which edge
element is where, and how thick its chip is (from :class:`~timedomain.workpiece.Workpiece`).

Discretization
--------------
The tool is cut into the K discs of the workpiece's :class:`~timedomain.workpiece.AxialDiscs`
(heights ``z_k``, thickness ``dz = ap / K``). Tooth ``j`` on disc ``k`` is at immersion angle::

    phi_jk = spindle_angle + theta_j - psi(z_k)

with ``theta_j = Tool.tooth_angle_rad`` (variable pitch) and ``psi = Tool.lag_rad`` (helix), and
has tip radius ``R_j = D/2 + runout_j``.

**Element width** ``db = dz`` (the disc height), not ``dz / cos(helix)``: the cutting coefficients
of the paper (and of Altintas' average-force identification) are per unit *axial* depth, and the
linear lobes (:mod:`lobes`) use the same ``db = dz``, so the two models agree on the linear limit.

Forces and signs
----------------
:meth:`MillingForce.force` returns the force **on the tool** in the cut frame,
``F_tool = sum_jk tool_force_cut_frame(phi_jk, edge_forces(h_jk, dz))`` (N); the force on the
workpiece (what a dynamometer under the part measures) is ``F_workpiece = -F_tool``.
:class:`CutForce` carries both. The robot is loaded by ``F_tool`` at its TCP.

Mapping to the paper's Tab. 10 (aluminium, down-milling): paper ``Fx = +F_tool . x_c`` and paper
``Fy = -F_tool . y_c = F_workpiece . y_c``. Evidence (closed form, rigid tool, ``h = fz sin phi``):
over ``phi in [101.5, 180] deg`` ``F_tool . y_c = h (Ktc sin phi - Krc cos phi) >= 0`` always, and
the paper's Fy has max 0 and min -111 N; ``F_tool . x_c`` runs from -18 N (entry, no helix) to +36 N
(phi = 145.5 deg) with mean +8.51 N, and the paper's Fx has max 38.8, min -7.6, mean 8.78 N; the
mean of ``F_tool . y_c`` is +25.69 N against the paper's -25.67 N. Neither ``F_tool`` nor
``F_workpiece`` alone matches both rows: the paper's y axis is the opposite of our ``y_c`` (it
points into the material). With the real tool (helix 30 deg, pitch 170/190, 22 discs) and a rigid
spindle this module gives, one sample per degree in steady cut, in the paper's axes: Fx min -8.10,
max 38.36, mean 8.75, RMS 16.29 N; Fy min -112.59, max 0, mean -25.90, RMS 44.63 N (paper's
basic model: -7.63, 38.82, 8.78, 16.28; -111.39, 0, -25.67, 44.42).

Tangent
-------
``d F_tool / d c`` (3 x 2, N/m) for the tool centre ``c = (x_c, y_c)``:

* ``"geometric"`` (default): the exact derivative of the computed force,
  ``sum_jk (dF/dh)_jk (dh/dc)_jk`` with ``dh/dc`` from the workpiece's local boundary (for a
  chip bounded by the previous tooth's arc this is ``~ n = (sin phi, cos phi)``; on the flat
  block edge it is ``(0, 1/cos phi)``);
* ``"directional"``: ``sum over engaged elements of dz * directional_matrix(phi)``, the linear
  regenerative model's ``dh/dc = n``.

Either is fine for the Newton iteration of a robot (the cutting stiffness, ~1e6 N/m, is tiny next
to ``M / (beta h^2)``); "geometric" is the consistent one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from robolobes.cases.milling import (Cut, CuttingLaw, MillingError, Tool, check_cut, directional_matrix, edge_forces,
                           tool_force_cut_frame)

from robolobes.core.validate import readonly

from .workpiece import Workpiece, WorkpieceError

__all__ = ["TangentKind", "CutForce", "MillingForce", "PrescribedRun", "run_prescribed", "straight_path"]

TangentKind = Literal["geometric", "directional"]


@dataclass(frozen=True)
class CutForce:
    """Cutting force at one instant, with its parts.

    Attributes
    ----------
    tool_n : array (3,)
        Force on the tool, cut frame ``(x_c, y_c, z_c)``, N.
    workpiece_n : array (3,)
        Force on the workpiece (dynamometer), ``-tool_n``, N.
    dtool_dcenter_n_per_m : array (3, 2)
        ``d tool_n / d (x_c, y_c)`` of the tool centre, N/m.
    chip_m : array (T, K)
        Chip thickness of tooth j on disc k, m (0 out of the cut).
    phi_rad : array (T, K)
        Immersion angles, rad.
    """

    tool_n: np.ndarray
    workpiece_n: np.ndarray
    dtool_dcenter_n_per_m: np.ndarray
    chip_m: np.ndarray
    phi_rad: np.ndarray

    @property
    def engaged(self) -> np.ndarray:
        """Elements in the cut (h > 0), bool (T, K)."""
        return self.chip_m > 0

    @property
    def tooth_chip_m(self) -> np.ndarray:
        """Largest chip of each tooth over the discs, shape (T,), m."""
        return self.chip_m.max(axis=1)


class MillingForce:
    """Cutting force of a tool on a :class:`~timedomain.workpiece.Workpiece` (module docstring).

    Parameters
    ----------
    tool : Tool
    law : CuttingLaw
    cut : Cut
        Must be the cut the workpiece was built for.
    workpiece : Workpiece
        Gives the discs and the material; :meth:`commit` erodes it.
    tangent : {"geometric", "directional"}
        Which ``dF/dc`` :meth:`force` returns.
    """

    def __init__(self, tool: Tool, law: CuttingLaw, cut: Cut, workpiece: Workpiece, *,
                 tangent: TangentKind = "geometric") -> None:
        if not isinstance(law, CuttingLaw):
            raise MillingError(f"law must be a cases.milling.CuttingLaw, got {type(law).__name__}")
        check_cut(tool, cut)
        if not isinstance(workpiece, Workpiece):
            raise WorkpieceError(f"workpiece must be a timedomain.workpiece.Workpiece, got {type(workpiece).__name__}")
        if workpiece.tool != tool or workpiece.cut != cut:
            raise WorkpieceError("the workpiece was built for another tool or cut; build it with the same ones")
        if tangent not in ("geometric", "directional"):
            raise ValueError(f"tangent must be 'geometric' or 'directional', got {tangent!r}")
        self.tool = tool
        self.law = law
        self.cut = cut
        self.workpiece = workpiece
        self.tangent: TangentKind = tangent
        discs = workpiece.discs
        self.db_m = discs.dz_m
        self._offset = np.ascontiguousarray(
            tool.tooth_angle_rad[:, None] - tool.lag_rad(discs.z_m)[None, :], dtype=float
        )  # (T, K)
        self._radius = np.ascontiguousarray(tool.radius_m + np.asarray(tool.runout_m, float))
        self._kc = law.cutting_pa * self.db_m  # (3,) N/m: dF_tra/dh of one element
        # The last force() result, reused when residual and tangent ask for the same state (Newton
        # evaluates both at each iterate); keyed with the workpiece's revision (bumped by removal).
        self._memo_key: tuple | None = None
        self._memo_val: tuple[np.ndarray, np.ndarray] | None = None

    @property
    def tooth_radius_m(self) -> np.ndarray:
        """Tip radius of each tooth ``D/2 + runout``, shape (T,), m."""
        return readonly(self._radius)

    def immersion_rad(self, spindle_angle_rad: float) -> np.ndarray:
        """Immersion angle ``phi_jk`` of every element, shape (T, K), rad (not wrapped)."""
        return readonly(float(spindle_angle_rad) + self._offset)

    def _state(self, spindle_angle_rad, center_m):
        a = float(spindle_angle_rad)
        if not math.isfinite(a):
            raise ValueError(f"spindle angle must be finite, got {spindle_angle_rad!r}")
        c = np.asarray(center_m, dtype=float)
        if c.shape != (2,) or not (math.isfinite(c[0]) and math.isfinite(c[1])):
            raise ValueError(f"tool centre must be a finite (x_c, y_c) pair in m, got {center_m!r}")
        return a, c

    def _evaluate(self, a: float, c: np.ndarray, tangent: TangentKind | None):
        phi = a + self._offset
        h, dh = self.workpiece._chip(float(c[0]), float(c[1]), phi, self._radius)
        on = h > 0
        if not on.any():
            return np.zeros(3), np.zeros((3, 2)), h, phi
        p = phi[on]
        # Elements out of the cut carry no force (edge_forces gives 0 for h <= 0), so only the
        # engaged ones are projected. The edge forces and, for the geometric tangent, the force
        # per unit chip dF/dh = db (Ktc, Krc, Kac) go through one projection call.
        e = edge_forces(h[on], self.db_m, self.law)  # (n, 3)
        if tangent == "geometric":
            tra = np.empty((e.shape[0], 2, 3))
            tra[:, 0] = e
            tra[:, 1] = self._kc
            proj = tool_force_cut_frame(p[:, None], tra)  # (n, 2, 3)
            force = proj[:, 0].sum(axis=0)
            dfdc = proj[:, 1].T @ dh[on]
        else:
            force = tool_force_cut_frame(p, e).sum(axis=0)
            if tangent is None:
                dfdc = np.zeros((3, 2))
            else:
                dfdc = self.db_m * directional_matrix(p, self.law).sum(axis=0)
        return force, dfdc, h, phi

    def force(self, spindle_angle_rad: float, center_m) -> tuple[np.ndarray, np.ndarray]:
        """Force on the tool and its tangent; the fast call for the integrator.

        Parameters
        ----------
        spindle_angle_rad : float
            Spindle rotation ``Omega t`` (plus any phase), rad.
        center_m : array (2,)
            Tool centre ``(x_c, y_c)`` in the workpiece's cut frame, m.

        Returns
        -------
        force_tool_n : array (3,)
            Force on the tool, cut frame, N (read-only).
        dforce_dcenter : array (3, 2)
            ``d force / d center``, N/m (see the module docstring for the two kinds; read-only).

        Notes
        -----
        The last result is remembered and returned again for the same arguments and the same
        workpiece revision (a residual and a tangent evaluated at the same Newton iterate cost one
        evaluation).
        """
        a, c = self._state(spindle_angle_rad, center_m)
        key = (a, float(c[0]), float(c[1]), self.workpiece.revision)
        if key == self._memo_key and self._memo_val is not None:  # the key and value are set together
            return self._memo_val
        f, d, _, _ = self._evaluate(a, c, self.tangent)
        f.setflags(write=False)
        d.setflags(write=False)
        self._memo_key, self._memo_val = key, (f, d)
        return f, d

    def evaluate(self, spindle_angle_rad: float, center_m) -> CutForce:
        """Force on the tool and on the workpiece, tangent, chips and angles (copies)."""
        a, c = self._state(spindle_angle_rad, center_m)
        f, d, h, phi = self._evaluate(a, c, self.tangent)
        return CutForce(tool_n=readonly(f), workpiece_n=readonly(-f), dtool_dcenter_n_per_m=readonly(d),
                        chip_m=readonly(h), phi_rad=readonly(phi))

    def commit(self, spindle_angle0_rad: float, center0_m, spindle_angle1_rad: float, center1_m) -> int:
        """Erode the workpiece along the tooth tips' paths of one accepted step (t0 -> t1).

        Call it once per accepted step, in order, from the integrator's step hook. Record the force
        of the accepted state *before* committing its step: afterwards the tips sit on the surface
        they have just cut, and the force at t1 itself is no longer the cutting force (the next
        step's evaluations, further on, are unaffected).

        Returns the number of column updates (see :meth:`Workpiece.remove`).
        """
        a0, c0 = self._state(spindle_angle0_rad, center0_m)
        a1, c1 = self._state(spindle_angle1_rad, center1_m)
        return self.workpiece._remove(
            float(c0[0]), float(c0[1]), float(c1[0]), float(c1[1]), a0 + self._offset, a1 + self._offset, self._radius
        )


@dataclass(frozen=True)
class PrescribedRun:
    """Forces along a prescribed (rigid-tool) motion.

    Attributes
    ----------
    t_s : array (n,)
    force_tool_n : array (n, 3)
        Force on the tool, cut frame, N.
    tooth_chip_m : array (n, T)
        Largest chip of each tooth over the discs, m.
    """

    t_s: np.ndarray
    force_tool_n: np.ndarray
    tooth_chip_m: np.ndarray

    @property
    def force_workpiece_n(self) -> np.ndarray:
        """Force on the workpiece ``-force_tool_n``, (n, 3), N."""
        return readonly(-self.force_tool_n)


def run_prescribed(model: MillingForce, t_s, center_m, spindle_angle_rad) -> PrescribedRun:
    """Cut along a prescribed tool-centre motion (no dynamics): evaluate, then commit, each step.

    The force at ``t_i`` is evaluated on the part left by the steps up to ``t_i`` (the tips sit on the
    path they have just cut), then the step ``t_i -> t_{i+1}`` is committed. The dynamic simulation
    evaluates the force of ``t_i`` before committing the step that reached it; the chip is the same
    either way (the tooth's own sweep up to ``t_i`` is not on its edge line; the workpiece takes the
    boundary in the tip's column interval from the unswept side, see
    :mod:`~timedomain.workpiece`).

    Parameters
    ----------
    model : MillingForce
    t_s : array (n,)
        Times, s (increasing).
    center_m : array (n, 2)
        Tool centre in the cut frame, m.
    spindle_angle_rad : array (n,)
        Spindle angle, rad.

    Returns
    -------
    PrescribedRun
    """
    t = np.asarray(t_s, dtype=float)
    c = np.asarray(center_m, dtype=float)
    ang = np.asarray(spindle_angle_rad, dtype=float)
    n = t.size
    if t.ndim != 1 or c.shape != (n, 2) or ang.shape != (n,):
        raise ValueError(f"t_s (n,), center_m (n, 2), spindle_angle_rad (n,) expected; got {t.shape}, {c.shape}, {ang.shape}")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(c)) and np.all(np.isfinite(ang))):
        raise ValueError("t_s, center_m and spindle_angle_rad must be finite")
    if n > 1 and np.any(np.diff(t) <= 0):
        raise ValueError("t_s must be strictly increasing")
    f = np.empty((n, 3))
    hmax = np.empty((n, model.tool.teeth))
    for i in range(n):
        fi, _, h, _ = model._evaluate(float(ang[i]), c[i], None)
        f[i] = fi
        hmax[i] = h.max(axis=1)
        if i + 1 < n:
            model.commit(ang[i], c[i], ang[i + 1], c[i + 1])
    return PrescribedRun(t_s=readonly(t), force_tool_n=readonly(f), tooth_chip_m=readonly(hmax))


def straight_path(tool: Tool, cut: Cut, t_s, x0_m: float, y_m: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """A rigid tool at constant feed: centre ``(x0 + v_f t, y)`` and spindle angle ``Omega t``.

    Parameters
    ----------
    tool, cut : Tool, Cut
        Give the feed rate ``v_f = fz N Omega / 2 pi`` and ``Omega``.
    t_s : array (n,)
        Times, s.
    x0_m, y_m : float
        Centre at t = 0, m.

    Returns
    -------
    center_m : array (n, 2)
    spindle_angle_rad : array (n,)
    """
    t = np.asarray(t_s, dtype=float)
    v = cut.feed_rate_m_per_s(tool)
    c = np.stack([x0_m + v * t, np.full_like(t, float(y_m))], axis=-1)
    return c, cut.omega_rad_s * t
