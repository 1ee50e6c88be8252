"""Milling mechanics, defined once: tool geometry, cutting law, cut, and the force law.

Both :mod:`lobes` (linear stability) and :mod:`timedomain` (nonlinear simulation) use these
objects and functions; nothing else in robolobes defines a milling force.

Conventions (Altintas, *Manufacturing Automation*, ch. 2-3)
-----------------------------------------------------------
Cut frame ``(x_c, y_c, z_c)``: ``x_c`` along the feed, ``z_c`` along the spindle axis pointing
*into* the spindle (opposite to the tool axis of the TCP frame), ``y_c = z_c x x_c``.
The tool turns clockwise seen from ``+z_c`` (M03, right-hand cutter). The immersion angle ``phi``
of a cutting edge is measured clockwise from ``+y_c``; the edge point then sits at
``R (sin phi, cos phi)`` from the tool axis, in ``(x_c, y_c)``.

* up-milling: the tooth enters at ``phi_st = 0`` and leaves at ``phi_ex = arccos(1 - 2 ae / D)``;
  the material is on the ``+y_c`` side.
* down-milling: ``phi_st = pi - arccos(1 - 2 ae / D)``, ``phi_ex = pi``; material on ``-y_c``.

Tooth ``j`` sits at angle ``theta_j`` at ``t = 0`` with ``theta_0 = 0`` and
``theta_{j+1} = theta_j - pitch_j``: tooth ``j+1`` trails tooth ``j`` by ``pitch_j`` and cuts the
surface it left ``pitch_j / Omega`` seconds later. With a helix angle ``beta`` the edge at height
``z`` above the tool tip lags by ``psi(z) = 2 z tan(beta) / D``:
``phi_j(t, z) = Omega t + theta_j - psi(z)``.

Force law (linear in chip thickness ``h``, per edge element of axial width ``db``)::

    dFt = Ktc h db + Kte db,  dFr = Krc h db + Kre db,  dFa = Kac h db + Kae db   (h > 0)

and zero when ``h <= 0`` (the edge is out of the material). The force *on the tool*, cut frame::

    dFx = -dFt cos(phi) - dFr sin(phi)
    dFy = +dFt sin(phi) - dFr cos(phi)
    dFz = +dFa

which is the paper's eq. 14-15 with kappa = 90 deg (cylindrical end mill). The dynamic chip
thickness is ``h = h_static + n(phi) . (r(t) - r(t - tau))`` with ``n = (sin phi, cos phi)`` and
``r`` the tool displacement in ``(x_c, y_c)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import partial
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from robolobes.core.validate import shown
from robolobes.core.errors import BadInput
from robolobes.core.validate import finite, integer

__all__ = [
    "MillingMode",
    "Tool",
    "CuttingLaw",
    "Cut",
    "MillingError",
    "check_cut",
    "engagement_rad",
    "in_cut",
    "edge_forces",
    "eccentric_runout",
    "edge_force_law",
    "project_cut_frame",
    "tool_force_cut_frame",
    "directional_matrix",
    "cut_frame",
    "regeneration",
    "ToothRegeneration",
    "principal_period",
    "PeriodName",
    "ANGLE_TOL_RAD",
]

MillingMode = Literal["up", "down"]
PeriodName = Literal["tooth", "revolution"]

#: Tolerance (rad) for deciding that two spindle angles computed in floating point are equal
#: (a regenerative delay against the pitch ``2 pi / N``, two delays against each other). The
#: angles are sums of at most N pitches of order 1 rad, so their rounding error is below
#: ``N * 2 pi * eps`` ~ 1e-14 rad for any real tool: 1e-9 rad is 1e5 times that, and it is far below
#: any pitch difference that matters (1e-9 rad is 1e-6 of one SDM step even at m = 1000 steps per
#: tooth period of an 8-tooth tool, and the Tool check lets the pitches sum to 360 deg within
#: 1e-6 deg = 1.7e-8 rad, so pitches typed in degrees are not told apart below that anyway).
ANGLE_TOL_RAD = 1e-9


class MillingError(BadInput):
    """A tool, cutting law or cut that is physically impossible or inconsistent."""


_finite = partial(finite, error=MillingError)


@dataclass(frozen=True)
class Tool:
    """A cylindrical end mill.

    Parameters
    ----------
    diameter_m : float
        Tool diameter D in m (> 0).
    teeth : int
        Number of teeth N (>= 1).
    helix_rad : float
        Helix angle beta in rad, 0 <= beta < pi/2.
    pitch_rad : tuple of float, length N, optional
        Angle in rad from tooth j to the next (trailing) tooth j+1, cyclically; must sum to 2 pi.
        Default: equal pitch 2 pi / N.
    runout_m : tuple of float, length N, optional
        Radial offset of each tooth tip in m (tooth radius is ``D/2 + runout_m[j]``). Default 0.
    """

    diameter_m: float
    teeth: int
    helix_rad: float = 0.0
    pitch_rad: tuple[float, ...] = ()  # () or None: equal pitch
    runout_m: tuple[float, ...] = ()   # () or None: no runout

    def __post_init__(self) -> None:
        d = _finite("tool diameter_m", self.diameter_m, positive=True)
        n = integer("tool teeth", self.teeth, minimum=1, error=MillingError)
        helix = _finite("tool helix_rad", self.helix_rad)
        if not 0.0 <= helix < math.pi / 2:
            raise MillingError(
                f"tool helix angle must be in [0, 90) deg, got {math.degrees(helix):.6g} deg"
            )
        if self.pitch_rad is None or len(self.pitch_rad) == 0:
            pitch = (2 * math.pi / n,) * n
        else:
            pitch = tuple(_finite("tool pitch angle", p, positive=True) for p in self.pitch_rad)
            if len(pitch) != n:
                raise MillingError(
                    f"tool has {n} teeth but {len(pitch)} pitch angles {np.degrees(pitch).round(6).tolist()} deg;"
                    f" give one pitch angle per tooth"
                )
            total = math.degrees(sum(pitch))
            if abs(total - 360.0) > 1e-6:
                raise MillingError(
                    f"tool pitch angles {np.degrees(pitch).round(6).tolist()} deg sum to {total:.6g} deg;"
                    f" they must sum to 360 deg"
                )
        if self.runout_m is None or len(self.runout_m) == 0:
            runout = (0.0,) * n
        else:
            runout = tuple(_finite("tool runout_m", r) for r in self.runout_m)
            if len(runout) != n:
                raise MillingError(f"tool has {n} teeth but {len(runout)} runout values; give one per tooth")
            if any(abs(r) >= d / 2 for r in runout):
                raise MillingError(f"tool runout {runout} m must be smaller than the radius {d / 2} m")
        object.__setattr__(self, "diameter_m", d)
        object.__setattr__(self, "teeth", n)
        object.__setattr__(self, "helix_rad", helix)
        object.__setattr__(self, "pitch_rad", pitch)
        object.__setattr__(self, "runout_m", runout)

    @property
    def radius_m(self) -> float:
        """Nominal radius D/2 in m."""
        return self.diameter_m / 2

    @property
    def tooth_angle_rad(self) -> np.ndarray:
        """Angular position ``theta_j`` of each tooth tip at t = 0, shape (N,), rad."""
        th = -np.concatenate([[0.0], np.cumsum(self.pitch_rad[:-1])])
        th.setflags(write=False)
        return th

    def lag_rad(self, z_m: np.ndarray | float) -> np.ndarray:
        """Helix lag angle ``psi(z) = 2 z tan(beta) / D`` in rad at height ``z_m`` (m) above the tip."""
        return 2.0 * np.asarray(z_m, dtype=float) * math.tan(self.helix_rad) / self.diameter_m


@dataclass(frozen=True)
class CuttingLaw:
    """Linear mechanistic cutting law (cutting and edge coefficients).

    Parameters
    ----------
    ktc_pa, krc_pa, kac_pa : float
        Tangential, radial, axial cutting coefficients in Pa (N/m^2). ``ktc_pa > 0``.
    kte_n_per_m, kre_n_per_m, kae_n_per_m : float
        Edge (ploughing) coefficients in N/m. Default 0.
    name : str
        Material name, for reports.
    """

    ktc_pa: float
    krc_pa: float
    kac_pa: float = 0.0
    kte_n_per_m: float = 0.0
    kre_n_per_m: float = 0.0
    kae_n_per_m: float = 0.0
    name: str = ""

    def __post_init__(self) -> None:
        _finite("cutting coefficient ktc_pa", self.ktc_pa, positive=True)
        for key in ("krc_pa", "kac_pa", "kte_n_per_m", "kre_n_per_m", "kae_n_per_m"):
            object.__setattr__(self, key, _finite(f"cutting coefficient {key}", getattr(self, key)))
        object.__setattr__(self, "ktc_pa", float(self.ktc_pa))

    @property
    def cutting_pa(self) -> np.ndarray:
        """``(Ktc, Krc, Kac)`` in Pa, shape (3,)."""
        return np.array([self.ktc_pa, self.krc_pa, self.kac_pa])

    @property
    def edge_n_per_m(self) -> np.ndarray:
        """``(Kte, Kre, Kae)`` in N/m, shape (3,)."""
        return np.array([self.kte_n_per_m, self.kre_n_per_m, self.kae_n_per_m])


@dataclass(frozen=True)
class Cut:
    """One milling operation: immersion, depth, speed, feed, direction.

    Parameters
    ----------
    ae_m : float
        Radial depth of cut in m, ``0 < ae <= D`` (checked against a tool by :func:`check_cut`).
    ap_m : float
        Axial depth of cut in m, > 0.
    spindle_rpm : float
        Spindle speed in rev/min (an edge unit, hence the name), > 0.
    feed_per_tooth_m : float
        Feed per tooth in m (mean over the teeth), >= 0.
    mode : {"up", "down"}
        Up- or down-milling.
    feed_direction : tuple of 3 float
        Feed direction in the robot base frame (normalized on construction).
    """

    ae_m: float
    ap_m: float
    spindle_rpm: float
    feed_per_tooth_m: float = 0.0
    mode: MillingMode = "down"
    feed_direction: tuple[float, float, float] = (1.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        object.__setattr__(self, "ae_m", _finite("radial depth ae_m", self.ae_m, positive=True))
        object.__setattr__(self, "ap_m", _finite("axial depth ap_m", self.ap_m, positive=True))
        object.__setattr__(self, "spindle_rpm", _finite("spindle_rpm", self.spindle_rpm, positive=True))
        object.__setattr__(
            self, "feed_per_tooth_m", _finite("feed_per_tooth_m", self.feed_per_tooth_m, nonneg=True)
        )
        if self.mode not in ("up", "down"):
            raise MillingError(f"milling mode must be 'up' or 'down', got {self.mode!r}")
        f = np.asarray(self.feed_direction, dtype=float)
        if f.shape != (3,) or not np.all(np.isfinite(f)) or np.linalg.norm(f) == 0:
            raise MillingError(f"feed_direction must be a finite non-zero 3-vector, got {shown(self.feed_direction)}")
        object.__setattr__(self, "feed_direction", tuple((f / np.linalg.norm(f)).tolist()))

    @property
    def omega_rad_s(self) -> float:
        """Spindle speed Omega in rad/s."""
        return self.spindle_rpm * 2 * math.pi / 60.0

    @property
    def spindle_period_s(self) -> float:
        """Time of one spindle revolution in s."""
        return 60.0 / self.spindle_rpm

    def feed_rate_m_per_s(self, tool: Tool) -> float:
        """Feed rate ``fz N Omega / 2 pi`` in m/s."""
        return self.feed_per_tooth_m * tool.teeth * self.spindle_rpm / 60.0

    @staticmethod
    def from_feed_rate(
        tool: Tool, *, ae_m: float, ap_m: float, spindle_rpm: float, feed_m_per_s: float, **kw
    ) -> "Cut":
        """Build a cut from the feed rate (m/s) instead of the feed per tooth."""
        fz = _finite("feed rate", feed_m_per_s, nonneg=True) * 60.0 / (tool.teeth * float(spindle_rpm))
        return Cut(ae_m=ae_m, ap_m=ap_m, spindle_rpm=spindle_rpm, feed_per_tooth_m=fz, **kw)


def check_cut(tool: Tool, cut: Cut) -> None:
    """Raise :class:`MillingError` if the cut is impossible with this tool (``ae > D``)."""
    if cut.ae_m > tool.diameter_m * (1 + 1e-12):
        raise MillingError(
            f"radial depth ae = {cut.ae_m * 1e3:.6g} mm exceeds the tool diameter D = "
            f"{tool.diameter_m * 1e3:.6g} mm; valid: 0 < ae <= D"
        )


def engagement_rad(tool: Tool, cut: Cut) -> tuple[float, float]:
    """Entry and exit immersion angles ``(phi_st, phi_ex)`` in rad, ``0 <= phi_st < phi_ex <= pi``."""
    check_cut(tool, cut)
    sweep = math.acos(max(-1.0, 1.0 - 2.0 * cut.ae_m / tool.diameter_m))
    if cut.mode == "up":
        return 0.0, sweep
    return math.pi - sweep, math.pi


def in_cut(phi_rad: np.ndarray, phi_st: float | np.ndarray, phi_ex: float | np.ndarray) -> np.ndarray:
    """Screen function g: True where ``phi mod 2 pi`` lies in ``[phi_st, phi_ex]``. Same shape as phi
    (bounds given as arrays broadcast with it)."""
    p = np.mod(phi_rad, 2 * math.pi)
    return (p >= phi_st) & (p <= phi_ex)


def edge_force_law(h, db, ktc, krc, kac, kte, kre, kae):
    """The force law itself, as plain arithmetic on scalars or arrays (numba can compile it).

    ``(dFt, dFr, dFa) = K_c h db + K_e db`` where ``h > 0``, else 0. Units: h, db in m; cutting
    coefficients in Pa, edge coefficients in N/m; forces in N. :func:`edge_forces` is the array API.
    """
    on = h > 0.0
    return (on * (ktc * h + kte) * db, on * (krc * h + kre) * db, on * (kac * h + kae) * db)


def project_cut_frame(phi, ft, fr, fa):
    """Edge forces (tangential, radial, axial) at immersion ``phi`` to the cut frame, force on the
    tool: plain arithmetic on scalars or arrays (numba can compile it). Returns ``(Fx, Fy, Fz)``."""
    sn = np.sin(phi)
    cs = np.cos(phi)
    return (-ft * cs - fr * sn, ft * sn - fr * cs, fa)


def edge_forces(h_m: np.ndarray, db_m: np.ndarray | float, law: CuttingLaw) -> np.ndarray:
    """Tangential, radial, axial edge forces for chip thickness ``h_m`` (array API of :func:`edge_force_law`).

    Parameters
    ----------
    h_m : array, any shape
        Chip thickness in m; elements with ``h <= 0`` are out of the material and carry no force.
    db_m : float or array broadcastable to ``h_m``
        Axial width of the edge element in m.

    Returns
    -------
    array, shape ``h_m.shape + (3,)``
        ``(dFt, dFr, dFa)`` in N.
    """
    h = np.asarray(h_m, dtype=float)
    db = np.broadcast_to(np.asarray(db_m, dtype=float), h.shape)
    return np.stack(edge_force_law(h, db, law.ktc_pa, law.krc_pa, law.kac_pa,
                                   law.kte_n_per_m, law.kre_n_per_m, law.kae_n_per_m), axis=-1)


def tool_force_cut_frame(phi_rad: np.ndarray, f_tra: np.ndarray) -> np.ndarray:
    """Project edge forces ``(dFt, dFr, dFa)`` (shape ``(..., 3)``) at angle ``phi_rad`` (shape ``(...)``)
    into the cut frame: force on the tool, shape ``(..., 3)``, N (array API of :func:`project_cut_frame`)."""
    fx, fy, fz = project_cut_frame(np.asarray(phi_rad, dtype=float), f_tra[..., 0], f_tra[..., 1], f_tra[..., 2])
    return np.stack(np.broadcast_arrays(fx, fy, fz), axis=-1)


def directional_matrix(phi_rad: np.ndarray, law: CuttingLaw, rotation_rad: np.ndarray | float | None = None) -> np.ndarray:
    """Linear force sensitivity of one edge element to the dynamic displacement.

    ``d(force on tool) = db * D(phi) @ (r(t) - r(t - tau))`` for an engaged edge, where ``r`` is the
    tool displacement in ``(x_c, y_c)``; edge coefficients do not enter (they do not depend on h).
    The chip's sensitivity is the ray direction ``u = (sin phi, cos phi)``; with ``rotation_rad``
    (``alpha``, rad, broadcast with ``phi``) it is ``u + alpha du/dphi``, the first-order tilt of the
    regenerated surface against the ray (:mod:`lobes.chip_direction`); the force direction is unchanged.

    Returns
    -------
    array, shape ``phi.shape + (3, 2)``, N/m^2 (force per unit width per unit displacement)
        Rows: force x_c, y_c, z_c; columns: displacement x_c, y_c.
    """
    phi = np.asarray(phi_rad, dtype=float)
    s, c = np.sin(phi), np.cos(phi)
    kt, kr, ka = law.ktc_pa, law.krc_pa, law.kac_pa
    fvec = np.stack([-kt * c - kr * s, kt * s - kr * c, np.full_like(phi, ka)], axis=-1)  # (...,3)
    if rotation_rad is None:
        n = np.stack([s, c], axis=-1)  # (..., 2)
    else:
        a = np.asarray(rotation_rad, dtype=float)
        n = np.stack([s + a * c, c - a * s], axis=-1)
    return fvec[..., :, None] * n[..., None, :]


def cut_frame(feed_direction: ArrayLike, tool_axis: ArrayLike) -> np.ndarray:
    """Rotation whose rows are the cut frame axes ``x_c, y_c, z_c`` in base coordinates.

    Parameters
    ----------
    feed_direction : array (3,)
        Feed direction in the base frame.
    tool_axis : array (3,)
        Tool axis in the base frame, pointing out of the spindle (TCP frame z).

    Returns
    -------
    array (3, 3)
        ``R`` such that ``v_cut = R @ v_base``.
    """
    f = np.asarray(feed_direction, dtype=float)
    a = np.asarray(tool_axis, dtype=float)
    f = f / np.linalg.norm(f)
    a = a / np.linalg.norm(a)
    if abs(f @ a) > 1e-3:
        raise MillingError(
            f"feed direction {f.round(6).tolist()} is not perpendicular to the tool axis "
            f"{a.round(6).tolist()} (cos = {f @ a:.3g}); 2.5-axis milling needs the feed in the plane of the tool"
        )
    z = -a
    x = f - (f @ z) * z
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return np.vstack([x, y, z])


def eccentric_runout(tool: Tool, amplitude_m: float, phase_rad: float) -> np.ndarray:
    """Tooth-tip radius offsets of a tool whose axis is offset from the spindle axis, shape (N,), m.

    An axis offset (eccentricity) ``e = amplitude_m`` towards the tool angle ``phi = phase_rad``
    (measured like the tooth angles, from tooth 0 at t = 0) moves tooth j's tip, at angular position
    ``theta_j`` (:attr:`Tool.tooth_angle_rad`, variable pitch included), radially by
    ``r_j = e cos(theta_j - phi)`` to first order in ``e / R`` (the tangential part, ``e sin``, only
    shifts the tooth's phase by ``e / R`` rad, negligible at micrometres). For an equal-pitch
    two-tooth tool ``r = (e cos phi, -e cos phi)``: only ``e cos phi`` shows in the forces.
    Add the result to ``Tool.runout_m`` to model the offset.
    """
    if not (math.isfinite(amplitude_m) and math.isfinite(phase_rad)) or amplitude_m < 0:
        raise MillingError(f"runout amplitude {shown(amplitude_m)} m must be finite and >= 0, phase {shown(phase_rad)} finite")
    return amplitude_m * np.cos(np.asarray(tool.tooth_angle_rad) - phase_rad)


@dataclass(frozen=True)
class ToothRegeneration:
    """Which surface tooth ``j`` cuts (linear, no vibration): the result of runout and pitch.

    Attributes
    ----------
    tooth : int
    cuts : bool
        False when the tooth never reaches the material left by earlier teeth.
    chip_m : float
        Largest static chip thickness (at phi = 90 deg) in m; <= 0 when the tooth does not cut.
    delay_rad : float
        Spindle rotation between the pass that left the surface and this tooth, rad
        (``delay_s = delay_rad / Omega``).
    """

    tooth: int
    cuts: bool
    chip_m: float
    delay_rad: float


def regeneration(tool: Tool, cut: Cut) -> list[ToothRegeneration]:
    """Static chip and regenerative delay of each tooth, with pitch and runout.

    Tooth j, one step of k teeth after tooth j-k, meets the surface that tooth left after the
    spindle turned by ``sum(pitch[j-k .. j-1])``, during which the tool fed by
    ``fz N sum(pitch) / 2 pi``. The surface it cuts is the innermost one left by the previous
    teeth, so its chip is ``h_j = min_k (fz N sum(pitch)/2pi + r_j - r_{j-k})`` over k = 1..N,
    and the regenerative delay is that of the minimizing k. A tooth whose chip is <= 0 does not
    cut; the teeth after it then see the surface of an earlier tooth (a longer delay).

    Returns
    -------
    list of ToothRegeneration, one per tooth.
    """
    n = tool.teeth
    fz = cut.feed_per_tooth_m
    out = []
    for j in range(n):
        best = (math.inf, 0.0)  # (chip, delay) of the previous tooth that cuts deepest
        for k in range(1, n + 1):
            ang = sum(tool.pitch_rad[(j - i) % n] for i in range(1, k + 1))
            h = fz * n * ang / (2 * math.pi) + tool.runout_m[j] - tool.runout_m[(j - k) % n]
            if h < best[0] - 1e-15:
                best = (h, ang)
        # A tie (h == 0: no feed, no runout difference) counts as cutting: the linear model with
        # zero feed still regenerates on every tooth.
        out.append(ToothRegeneration(tooth=j, cuts=best[0] > -1e-12, chip_m=best[0], delay_rad=best[1]))
    return out


def principal_period(tool: Tool, cut: Cut) -> tuple[float, PeriodName]:
    """The period of the cut's linear (regenerative) dynamics, and its name.

    The tooth period ``T / N`` when every tooth cuts and regenerates on the surface its predecessor
    left one equal pitch ``2 pi / N`` earlier (uniform pitch, runout too small to make a tooth skip;
    :func:`regeneration`); otherwise (variable pitch, skipped teeth) one spindle revolution ``T``.
    Angles are compared within :data:`ANGLE_TOL_RAD`. This is the one decision used by the lobes
    and the time domain: a flip bifurcation is a period doubling of this period, which a
    once-per-revolution section cannot see when N = 2.

    Returns
    -------
    (period_s, name) : (float, {"tooth", "revolution"})
        Period in s and which one it is.
    """
    pitch = 2 * math.pi / tool.teeth
    if all(r.cuts and abs(r.delay_rad - pitch) <= ANGLE_TOL_RAD for r in regeneration(tool, cut)):
        return cut.spindle_period_s / tool.teeth, "tooth"
    return cut.spindle_period_s, "revolution"
