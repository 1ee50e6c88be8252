"""An independent cutting-force generator for test data: Altintas' mechanistic milling force, rigid tool.

Nothing here imports ``robolobes``: the force law is written from the textbook (Altintas,
*Manufacturing Automation*, 2nd ed., ch. 2.3-2.5), the cut's numbers are typed in from the shipped
case ``tx200-aluminium`` (paper Tab. 7-8, NOTES.md), and every effect is built here in its own way.

Model (rigid tool and workpiece; the robot's vibration at the 623 Hz tooth passing is left out,
see :data:`ROBOT_VIBRATION_NOTE`):

* immersion of tooth ``j`` at height ``z`` above the tip: ``phi_j(t, z) = Omega t + theta_j - 2 z tan(beta) / D``,
  measured clockwise from ``+y`` (feed ``+x``), ``theta_0 = 0``, ``theta_(j+1) = theta_j - pitch_j``;
* down milling: the uncut stock's face is at ``y = -R + ae`` (material below it);
* chip thickness with tooth radii ``R + r_j``: the exact one of the trochoidal tooth paths, the
  distance along the edge's ray from the tip to where it leaves the material, bounded by the
  stock's face and by the path of each of the ``k = 1..N`` teeth ahead of ``j`` (derivation in
  :func:`_chip_behind`), and zero when negative (the tooth is out of the material). To first order
  in ``fz / R`` this is the textbook ``v_f tau_jk sin(phi) + r_j - r_(j-k)``; the second-order part
  (about 1 % of the force here: the circles' offset across the ray, the path's lean, the stock face
  at the entry, the chip past 180 deg) is what a real cut has and robolobes' eroded part computes;
* forces per axial element ``db``: ``dFt = Ktc h db + Kte db``, ``dFr = Krc h db + Kre db``; on the tool
  ``dFx = -dFt cos(phi) - dFr sin(phi)``, ``dFy = dFt sin(phi) - dFr cos(phi)``; the data are the
  forces on the workpiece (minus those), ``z`` zero (``Kac = Kae = 0``);
* the dynamometer: a second-order stage ``wn^2 / (s^2 + 2 zeta wn s + wn^2)`` on each axis acting on the
  continuous force: its periodic steady state, harmonic by harmonic, of the force computed at
  :data:`DYNAMOMETER_OVERSAMPLING` times the sample rate, then sampled (filtering the sampled force
  instead, with ``lsim``'s linear interpolation between samples, is 0.87 N RMS per sample off for a
  4.7 kHz mode under edge forces of 80 N/mm: the edge force steps inside a sample interval);
* noise: white Gaussian, ``noise_n`` N on each axis and sample.

Not modelled: the pass's entry. The forces are the periodic steady state, but the robot's pass is
not periodic in the window: its 15.8 Hz (y, zeta 0.011) and 25.1 Hz (x, zeta 0.018) modes ring
after the entry (robolobes' pass: tool motion off its periodic part by 8.7 um in x, 5.9 um in y RMS
over 0.25-0.40 s), which moves the edge force's exits revolution by revolution; under edge forces of
90 N/mm that changes the synchronous averages by about 0.4 N per bin (docs/guide/identify-answers.md,
"Force draws").

Files: ``forces.csv`` (``t_s,fx_n,fy_n,fz_n``) and ``cut.toml`` (``case``, ``sample_rate_hz``,
``window_s``), the reader's format for a cutting-force set.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["CutSpec", "ForceEffects", "rigid_forces", "write_force_set", "WINDOW_S", "SAMPLES_PER_REV"]

#: Steady cut of the aluminium pass (the tool is fully engaged and the feed constant after 0.228 s).
WINDOW_S = (0.25, 0.40)
#: Samples per spindle revolution (2 deg steps).
SAMPLES_PER_REV = 180
#: Force samples per data sample under a dynamometer: the filtered force at 20x is 0.006 N RMS off the one
#: at 40x (10x: 0.042 N; order 2), for a 4.7 kHz, zeta 0.17 mode and edge forces of 80 N/mm.
DYNAMOMETER_OVERSAMPLING = 20
ROBOT_VIBRATION_NOTE = ("rigid: the robot's modes (< 100 Hz) are far below the 623 Hz tooth passing; the "
                        "cross-check against robolobes' pass bounds what that leaves out")


@dataclass(frozen=True)
class CutSpec:
    """The aluminium cut of the shipped case (paper Tab. 7, 8), SI."""

    diameter_m: float = 0.010
    helix_rad: float = math.radians(30.0)
    pitch_rad: tuple = (math.radians(170.0), math.radians(190.0))
    ktc_pa: float = 661.553e6
    krc_pa: float = 253.458e6
    ae_m: float = 0.004
    ap_m: float = 0.0016
    spindle_rpm: float = 18700.0
    feed_m_per_s: float = 3.7 / 60.0

    @property
    def omega_rad_s(self) -> float:
        return self.spindle_rpm / 60.0 * 2 * math.pi


@dataclass(frozen=True)
class ForceEffects:
    """What the generator adds to the nominal cut; the default is none."""

    kte_n_per_m: float = 0.0
    kre_n_per_m: float = 0.0
    tooth_radius_m: tuple = (0.0, 0.0)      # r_j, tooth-tip radius offsets (runout)
    dynamometer: tuple | None = None        # (fn_hz, zeta)


def _theta(spec: CutSpec) -> np.ndarray:
    return np.concatenate([[0.0], -np.cumsum(spec.pitch_rad[:-1])])


def _lags(spec: CutSpec, j: int) -> list:
    """Angles (rad) from tooth ``j - k`` to tooth ``j``, k = 1..N."""
    n, ang, out = len(spec.pitch_rad), 0.0, []
    for k in range(1, n + 1):
        ang += spec.pitch_rad[(j - k) % n]
        out.append(ang)
    return out


def _forces_on_workpiece(spec: CutSpec, eff: ForceEffects, phase: np.ndarray, r: np.ndarray | None,
                         n_slices: int) -> np.ndarray:
    """Forces on the workpiece (M, 3), N, at spindle angles ``phase`` (M,) = ``Omega t`` of one revolution on a
    uniform grid, with the tool displaced by ``r`` (M, 2) m in (x, y) of the cut frame (None: rigid).

    The chip is the exact one of the trochoidal tooth paths (:func:`_chip_behind`), bounded by the
    uncut stock's face and by the path of every tooth ahead."""
    m = len(phase)
    db = spec.ap_m / n_slices
    z = (np.arange(n_slices) + 0.5) * db
    R = spec.diameter_m / 2
    y_stock = -R + spec.ae_m                       # the uncut stock's face (down milling: material at y < it)
    dr = np.zeros((m, 2)) if r is None else r
    dr_dt = _derivative(dr, spec.omega_rad_s)
    theta = _theta(spec)
    n = len(spec.pitch_rad)
    out = np.zeros((m, 3))
    for j in range(n):
        phi = np.mod(phase[:, None] + theta[j] - 2 * z[None, :] * math.tan(spec.helix_rad) / spec.diameter_m,
                     2 * math.pi)
        sin, cos = np.sin(phi), np.cos(phi)
        r_j = R + eff.tooth_radius_m[j]
        # the stock's face: the ray c + rho n meets y = y_stock at rho = (y_stock - c_y) / cos(phi)
        below = cos < 0
        h = np.where(below, r_j - (y_stock - dr[:, 1:2]) / np.where(below, cos, -1.0), -np.inf)
        for k, ang in enumerate(_lags(spec, j), start=1):
            shift = ang / (2 * math.pi) * m                  # samples between the two teeth
            h = np.minimum(h, _chip_behind(spec, phi, r_j, R + eff.tooth_radius_m[(j - k) % n], ang,
                                           _delayed(dr, shift) - dr, _delayed(dr_dt, shift)))
        cutting = h > 0
        ft = np.where(cutting, spec.ktc_pa * h * db + eff.kte_n_per_m * db, 0.0)
        fr = np.where(cutting, spec.krc_pa * h * db + eff.kre_n_per_m * db, 0.0)
        out[:, 0] -= np.sum(-ft * cos - fr * sin, axis=1)
        out[:, 1] -= np.sum(ft * sin - fr * cos, axis=1)
    return out


def _chip_behind(spec: CutSpec, phi: np.ndarray, r_j: float, r_k: float, lag: float, dr: np.ndarray,
                 v_then: np.ndarray) -> np.ndarray:
    """Exact chip (M, S), m, of a tooth of radius ``r_j`` at immersion ``phi`` (M, S) against the path left
    by a tooth of radius ``r_k`` that runs ``lag`` rad ahead of it; negative where the tip is not in
    the material that path left.

    Geometry (rigid body motion of the tool, no small-feed approximation). Tool centre
    ``c(t) = (a Omega t + r_x(t), r_y(t))`` with ``a = v_f / Omega`` (feed per radian); an edge at
    immersion ``phi`` points along ``n(phi) = (sin phi, cos phi)``. The tooth ahead was at immersion
    ``phi + e`` at the time ``s = t - (lag - e) / Omega``, its tip at ``c(s) + r_k n(phi + e)``. That
    point lies on the ray ``c(t) + rho n(phi)`` when its offset ``D = c(s) - c(t) + r_k n(phi + e)`` has
    no component across the ray, ``D_x cos(phi) - D_y sin(phi) = 0``::

        g(e) = (a (e - lag) + dr_x) cos(phi) - dr_y sin(phi) + r_k sin(e) = 0,   dr = r(s) - r(t),

    solved by Newton from ``e = a lag cos(phi) / r_k``; then ``rho = D . n(phi)`` and the chip is
    ``h = r_j - rho``. ``r(s)`` is ``r(t - lag / Omega) + r'(t - lag / Omega) e / Omega``: ``e`` is
    about ``fz / R`` (0.02 rad, 10 us), over which the 623 Hz vibration's curvature moves the tool by
    under 1e-3 um. To second order in ``fz / R`` (rigid, no runout, ``f = a lag``)::

        h = f sin(phi) + f^2 cos(phi)^2 / (2 R) - a f sin(phi) cos(phi) / R,

    the textbook ``f sin(phi)`` (a circular tooth path) plus the offset of the two circles' centres
    across the ray and the trochoid's lean; about +0.8 um (1.2 %) at phi = 135 deg of the aluminium
    cut. The chip also runs on slightly past phi = 180 deg (to about ``180 + f / (2 R)`` rad)."""
    a = spec.feed_m_per_s / spec.omega_rad_s
    sin, cos = np.sin(phi), np.cos(phi)
    w = spec.omega_rad_s
    d0x, d0y = dr[:, 0:1], dr[:, 1:2]
    vx, vy = v_then[:, 0:1] / w, v_then[:, 1:2] / w
    e = a * lag * cos / r_k
    for _ in range(6):
        g = (a * (e - lag) + d0x + vx * e) * cos - (d0y + vy * e) * sin + r_k * np.sin(e)
        e = e - g / ((a + vx) * cos - vy * sin + r_k * np.cos(e))
    rho = (a * (e - lag) + d0x + vx * e) * sin + (d0y + vy * e) * cos + r_k * np.cos(e)
    return r_j - rho


def _derivative(x: np.ndarray, omega: float) -> np.ndarray:
    """Time derivative of a periodic signal (M, k) sampled over one revolution, by its Fourier series."""
    m = len(x)
    X = np.fft.rfft(x, axis=0)
    k = np.arange(X.shape[0])
    D = 1j * k * omega
    if m % 2 == 0:
        D[-1] = 0.0                                   # the Nyquist term has no defined derivative
    return np.fft.irfft(X * D[:, None], n=m, axis=0)


def _delayed(x: np.ndarray, shift: float) -> np.ndarray:
    """A periodic signal (M, k) delayed by ``shift`` samples (fractional: by its Fourier series)."""
    m = len(x)
    X = np.fft.rfft(x, axis=0)
    k = np.arange(X.shape[0])
    return np.fft.irfft(X * np.exp(-2j * np.pi * k * shift / m)[:, None], n=m, axis=0)


def tool_receptance_cut(harmonics_hz: np.ndarray, theta_deg=None, feed_direction=(1.0, 0.0, 0.0)) -> np.ndarray:
    """The independent TX200's tool-tip receptance (F, 2, 2), m/N, in (x, y) of the cut frame
    (``x`` along the feed, ``z`` into the spindle, ``y = z x x``) at ``harmonics_hz`` (F,)."""
    from .tx200 import POSE_TAB7_DEG, TX200

    robot = TX200()
    q = POSE_TAB7_DEG if theta_deg is None else np.asarray(theta_deg, float)
    zc = -robot.tcp_rotation(q)[:, 2]
    f = np.asarray(feed_direction, float)
    xc = f - (f @ zc) * zc
    xc /= np.linalg.norm(xc)
    R = np.vstack([xc, np.cross(zc, xc), zc])       # rows: cut axes in base coordinates
    H = robot.frf(q, np.maximum(np.asarray(harmonics_hz, float), 1e-6))   # (3, 3, F), base axes
    Hc = np.einsum("ai,ijf,bj->fab", R, H, R)
    return Hc[:, :2, :2]


def periodic_forces(spec: CutSpec = CutSpec(), eff: ForceEffects = ForceEffects(), *, structure: bool = True,
                    samples: int = SAMPLES_PER_REV, n_slices: int = 40, tol_n: float = 1e-9) -> np.ndarray:
    """One revolution (samples, 3) of the steady forces on the workpiece, N, at ``Omega t = 2 pi k / samples``.

    ``structure``: the tool on the independent TX200's tool-tip receptance at the Tab. 7 pose (the
    periodic steady state by fixed-point iteration: displacement ``r = H * F_tool`` harmonic by
    harmonic, including the static deflection, then the forces at that displacement; converged to
    ``tol_n``), else rigid."""
    phase = 2 * math.pi * np.arange(samples) / samples
    f = _forces_on_workpiece(spec, eff, phase, None, n_slices)
    if not structure:
        return f
    harm = np.arange(samples // 2 + 1) * spec.spindle_rpm / 60.0
    H = tool_receptance_cut(harm)
    for _ in range(200):
        F_tool = -np.fft.rfft(f[:, :2], axis=0)                # (K, 2)
        r = np.fft.irfft(np.einsum("kab,kb->ka", H, F_tool), n=samples, axis=0)
        new = _forces_on_workpiece(spec, eff, phase, r, n_slices)
        step = float(np.abs(new - f).max())
        f = new
        if step < tol_n:
            return f
    raise RuntimeError(f"the periodic cut did not converge (last change {step:.3g} N)")


def rigid_forces(t_s: np.ndarray, spec: CutSpec = CutSpec(), eff: ForceEffects = ForceEffects(),
                 n_slices: int = 40) -> np.ndarray:
    """Forces on the workpiece (n, 3), N, cut frame, at times ``t_s`` (n,): rigid tool, no dynamometer."""
    phase = spec.omega_rad_s * np.asarray(t_s, float)
    m = len(phase)
    return _forces_on_workpiece(spec, eff, phase, None, n_slices) if m else np.zeros((0, 3))


def _dynamometer_periodic(f: np.ndarray, fundamental_hz: float, fn_hz: float, zeta: float) -> np.ndarray:
    """Periodic steady state (M, k) of the unit-gain stage ``wn^2 / (s^2 + 2 zeta wn s + wn^2)`` driven by one
    period ``f`` (M, k) of a force sampled uniformly (fine enough to resolve its steps), harmonic by harmonic."""
    r = np.arange(len(f) // 2 + 1) * fundamental_hz / fn_hz
    h = 1.0 / (1.0 - r * r + 2j * zeta * r)
    return np.fft.irfft(np.fft.rfft(f, axis=0) * h[:, None], n=len(f), axis=0)


def measured_forces(spec: CutSpec = CutSpec(), eff: ForceEffects = ForceEffects(),
                    window_s=WINDOW_S) -> tuple[np.ndarray, np.ndarray]:
    """Noise-free forces through the measurement chain: ``(t_s (n,), force_n (n, 3))`` (s, N) over ``window_s``
    (the steady cut: one periodic revolution repeated)."""
    rate = spec.spindle_rpm / 60.0 * SAMPLES_PER_REV
    k = np.arange(math.ceil(window_s[0] * rate - 1e-9), math.floor(window_s[1] * rate) + 1)
    t = k / rate
    if eff.dynamometer is None:
        rev = periodic_forces(spec, eff)
    else:
        u = DYNAMOMETER_OVERSAMPLING
        fine = periodic_forces(spec, eff, samples=SAMPLES_PER_REV * u)
        rev = _dynamometer_periodic(fine, spec.spindle_rpm / 60.0, *eff.dynamometer)[::u]
    return t, rev[k % SAMPLES_PER_REV]


def write_force_set(directory, eff: ForceEffects = ForceEffects(), *, noise_n: float = 2.0, seed: int = 0,
                    spec: CutSpec = CutSpec(), case: str = "tx200-aluminium") -> dict:
    """Write ``forces.csv`` and ``cut.toml`` into the new ``directory``. Returns the truth: ``t_s``,
    ``clean`` (n, 3) and ``noise`` (n, 3), N."""
    d = Path(directory)
    d.mkdir(parents=False, exist_ok=False)
    t, clean = measured_forces(spec, eff)
    noise = np.random.default_rng(seed).normal(0.0, noise_n, clean.shape)
    np.savetxt(d / "forces.csv", np.column_stack([t, clean + noise]), delimiter=",", header="t_s,fx_n,fy_n,fz_n",
               comments="", fmt="%.10g")
    rate = spec.spindle_rpm / 60.0 * SAMPLES_PER_REV
    (d / "cut.toml").write_text(f'case = "{case}"\nsample_rate_hz = {rate:.10g}\n'
                                f"window_s = [{t[0]:.10g}, {t[-1]:.10g}]\n")
    return {"t_s": t, "clean": clean, "noise": noise}
