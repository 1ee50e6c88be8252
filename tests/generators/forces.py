"""An independent cutting-force generator for test data: Altintas' mechanistic milling force on the robot's pass.

Nothing here imports ``robolobes``: the force law is written from the textbook (Altintas,
*Manufacturing Automation*, 2nd ed., ch. 2.3-2.5), the cut's numbers are typed in from the shipped
case ``tx200-aluminium`` (paper Tab. 7-8, NOTES.md), and every effect is built here in its own way.

Model:

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
* the pass with its entry (:func:`simulate_pass`, the data's default): the tool centre starts at rest
  ``approach + R`` = 6 mm before the part's entry face (case ``[pass]``), follows the jerk-limited
  feed ramp of 0.1 s to the feed (:func:`feed_profile`), touches the part at 0.065 s and is fully
  engaged at 0.147 s; the chip is bounded also by the entry face. The robot: the independent TX200
  (tests/generators/tx200.py) at the Tab. 7 pose, ``M d'' + C d' + K d = J^T F_tool - M theta'' -
  C theta'`` for the links' deflection from the motor angles (its dampers act on the absolute link
  velocity, so the commanded motion drives it through ``M theta''`` and ``C theta'``), stepped in time
  on the data's grid with the exact discretization of a force held over each step (zero-order hold);
  the force at each sample from the tool's total position then, and the earlier teeth's paths from
  its recorded positions at the actual earlier times. So the tool's motion has the periodic cut's
  vibration and the robot's ringing after the entry (its 15.8 Hz y and 25.1 Hz x modes, zeta 0.010
  and 0.018): over 0.25-0.40 s it is off its periodic part by 4.7 um RMS in x and 2.9 um in y without
  edge forces, 8.7 and 4.9 um under 90 N/mm; robolobes' pass gives the same to 0.5-1.4 % (a test).
  Neglected, with their size: the pose's change along the 22 mm travelled by 0.40 s (the 15.8 Hz mode
  falls by 1.0 %, the 25.1 Hz by 0.3 %: the ringing's phase drifts by 0.06-0.18 rad over the window, about a tenth of
  it, which moves a synchronous average by about 0.05 N); ``J6' theta'`` in the commanded joint
  acceleration (2e-3 against the ramp's 1.2 m/s^2); the hold's half-step lag (9 us); gravity (not in
  this model). ``measured_forces(..., entry=False)`` gives the steady cut instead: the periodic
  steady state by fixed-point iteration harmonic by harmonic (:func:`periodic_forces`);
* the dynamometer: a second-order stage ``wn^2 / (s^2 + 2 zeta wn s + wn^2)`` on each axis acting on the
  continuous force: the pass's force at :data:`DYNAMOMETER_OVERSAMPLING` points per sample (the robot
  propagated exactly between samples) filtered in time with ``scipy.signal.lsim`` from before the first
  contact (the steady cut: its periodic steady state harmonic by harmonic), then sampled (filtering the
  sampled force instead, with ``lsim``'s linear interpolation between samples, is 0.87 N RMS per
  sample off for a 4.7 kHz mode under edge forces of 80 N/mm: the edge force steps inside a sample
  interval);
* noise: white Gaussian, ``noise_n`` N on each axis and sample.

Cost: a pass to 0.40 s is about 15 s CPU (a Python loop over its 22441 samples), the dynamometer's
fine force about 22 s more.

Files: ``forces.csv`` (``t_s,fx_n,fy_n,fz_n``) and ``cut.toml`` (``case``, ``sample_rate_hz``,
``window_s``), the reader's format for a cutting-force set.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["CutSpec", "ForceEffects", "rigid_forces", "periodic_forces", "simulate_pass", "feed_profile",
           "measured_forces", "write_force_set", "WINDOW_S", "SAMPLES_PER_REV"]

#: The data window, s: the tool is fully engaged and the feed constant after 0.147 s (robolobes calls the
#: cut steady after 0.228 s, when the centre is a diameter past the entry face).
WINDOW_S = (0.25, 0.40)
#: Samples per spindle revolution (2 deg steps).
SAMPLES_PER_REV = 180
#: Force samples per data sample under a dynamometer: the filtered force at 20x is 0.006 N RMS off the one
#: at 40x (10x: 0.042 N; order 2), for a 4.7 kHz, zeta 0.17 mode and edge forces of 80 N/mm.
DYNAMOMETER_OVERSAMPLING = 20


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


def _tooth_at_stock_face(spec: CutSpec, eff: ForceEffects, phase: np.ndarray, z: np.ndarray, theta_j: float,
                         j: int, y: np.ndarray) -> tuple:
    """Tooth ``j``'s edge elements at heights ``z`` (S,) m and spindle angles ``phase`` (M,): ``(phi, sin phi,
    cos phi, r_j, h)`` with ``phi`` (M, S) rad, ``r_j`` the tooth radius (m) and ``h`` (M, S) m the chip bounded by
    the uncut stock's face alone, the tool centre at ``y`` (M, 1) m: the ray ``c + rho n`` meets
    ``y = y_stock`` at ``rho = (y_stock - c_y) / cos(phi)``; ``-inf`` where the ray points away from it."""
    phi = np.mod(phase[:, None] + theta_j - 2 * z[None, :] * math.tan(spec.helix_rad) / spec.diameter_m, 2 * math.pi)
    sin, cos = np.sin(phi), np.cos(phi)
    r_j = spec.diameter_m / 2 + eff.tooth_radius_m[j]
    y_stock = -spec.diameter_m / 2 + spec.ae_m         # the uncut stock's face (down milling: material at y < it)
    below = cos < 0
    return phi, sin, cos, r_j, np.where(below, r_j - (y_stock - y) / np.where(below, cos, -1.0), -np.inf)


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
    dr = np.zeros((m, 2)) if r is None else r
    dr_dt = _derivative(dr, spec.omega_rad_s)
    theta = _theta(spec)
    n = len(spec.pitch_rad)
    out = np.zeros((m, 3))
    for j in range(n):
        phi, sin, cos, r_j, h = _tooth_at_stock_face(spec, eff, phase, z, theta[j], j, dr[:, 1:2])
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
                 v_then: np.ndarray, a: float | None = None) -> np.ndarray:
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
    cut. The chip also runs on slightly past phi = 180 deg (to about ``180 + f / (2 R)`` rad).

    ``a``: the feed per radian, default the cut's; 0 when ``dr`` and ``v_then`` hold the whole centre path
    (the commanded travel included), as in the pass's entry (:func:`simulate_pass`)."""
    a = spec.feed_m_per_s / spec.omega_rad_s if a is None else a
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
                    window_s=WINDOW_S, *, entry: bool = True, n_slices: int = 40) -> tuple[np.ndarray, np.ndarray]:
    """Noise-free forces through the measurement chain: ``(t_s (n,), force_n (n, 3))`` (s, N) over ``window_s``.

    ``entry``: the pass from rest with its entry (:func:`simulate_pass`), else the steady cut (one periodic
    revolution repeated, :func:`periodic_forces`)."""
    rate = spec.spindle_rpm / 60.0 * SAMPLES_PER_REV
    k = np.arange(math.ceil(window_s[0] * rate - 1e-9), math.floor(window_s[1] * rate) + 1)
    t = k / rate
    if entry:
        run = simulate_pass(float(t[-1]), spec, eff, n_slices=n_slices)
        if eff.dynamometer is None:
            return t, run.force[k]
        return t, _dynamometer_in_time(run, spec, eff, n_slices)[k]
    if eff.dynamometer is None:
        rev = periodic_forces(spec, eff, n_slices=n_slices)
    else:
        u = DYNAMOMETER_OVERSAMPLING
        fine = periodic_forces(spec, eff, samples=SAMPLES_PER_REV * u, n_slices=n_slices)
        rev = _dynamometer_periodic(fine, spec.spindle_rpm / 60.0, *eff.dynamometer)[::u]
    return t, rev[k % SAMPLES_PER_REV]


#: The pass's forces are zero before this time, s: the edges first touch the part at ``s = approach + R - w``
#: = 1.10 mm of travel (``w = sqrt(R^2 - (R - ae)^2)``), 0.0645 s into the ramp; the tool has deflected by
#: about 52 um against the feed by then, which delays the contact.
FIRST_CONTACT_BOUND_S = 0.06


def fine_pass_forces(run: PassRun, spec: CutSpec = CutSpec(), eff: ForceEffects = ForceEffects(), n_slices: int = 40,
                     u: int = DYNAMOMETER_OVERSAMPLING) -> tuple[np.ndarray, np.ndarray]:
    """The pass's force at ``u`` points per sample of ``run``: ``(t_s (N u,), force_n (N u, 3))`` (s, N); the
    robot between samples propagated exactly from each sample's state and held force (the same model as
    :func:`simulate_pass`), zero before :data:`FIRST_CONTACT_BOUND_S`. At the samples (every ``u``-th
    point) it is ``run.force``."""
    rate = spec.spindle_rpm / 60.0 * SAMPLES_PER_REV
    dt = 1.0 / rate
    st = RobotStructure.at_pose(dt)
    n = st.out.shape[1]
    ad, bd = st.substeps(dt, np.arange(u) / u)
    fine_state = np.einsum("mab,kb->kma", ad, run.state) + np.einsum("mab,kb->kma", bd, run.u)   # (N, u, 2n)
    fine_state = fine_state.reshape(-1, 2 * n)
    tf = np.arange(len(fine_state)) * (dt / u)
    s, v, _ = feed_profile(tf, spec.feed_m_per_s)
    centre = np.column_stack([s + fine_state[:, :n] @ st.out[0], fine_state[:, :n] @ st.out[1]])
    vel = np.column_stack([v + fine_state[:, n:] @ st.out[0], fine_state[:, n:] @ st.out[1]])
    lag = _lag_samples(spec, SAMPLES_PER_REV * u)
    first = int(FIRST_CONTACT_BOUND_S / (dt / u))
    if np.abs(run.force[:int(FIRST_CONTACT_BOUND_S / dt) + 1]).max() > 0:
        raise RuntimeError("the pass cuts before FIRST_CONTACT_BOUND_S")
    x_entry = PASS_APPROACH_M + spec.diameter_m / 2
    force = np.zeros((len(tf), 3))
    for lo in range(first, len(tf), 20000):
        i = np.arange(lo, min(lo + 20000, len(tf)))
        then = [[(centre[i - m], vel[i - m]) for m in row] for row in lag]
        force[i] = _forces_in_pass(spec, eff, spec.omega_rad_s * tf[i], centre[i], then, n_slices, x_entry)
    return tf, force


def _dynamometer_in_time(run: PassRun, spec: CutSpec, eff: ForceEffects, n_slices: int,
                         u: int = DYNAMOMETER_OVERSAMPLING) -> np.ndarray:
    """The dynamometer's output (N, 3), N, at the samples of ``run``: the force at ``u`` points per sample
    (:func:`fine_pass_forces`) filtered by the stage ``wn^2 / (s^2 + 2 zeta wn s + wn^2)`` in time
    (``scipy.signal.lsim``, linear between the fine points) from :data:`FIRST_CONTACT_BOUND_S`, before which the
    force is zero."""
    from scipy import signal

    tf, force = fine_pass_forces(run, spec, eff, n_slices, u)
    first = int(FIRST_CONTACT_BOUND_S / (tf[1] - tf[0]))
    assert eff.dynamometer is not None
    fn, zeta = eff.dynamometer
    w = 2 * math.pi * fn
    stage = signal.lti([w * w], [1.0, 2 * zeta * w, w * w])
    out = np.zeros_like(force)
    tt = tf[first:] - tf[first]
    for a in range(2):
        out[first:, a] = signal.lsim(stage, force[first:, a], tt)[1]
    return out[::u]


def write_force_set(directory, eff: ForceEffects = ForceEffects(), *, noise_n: float = 2.0, seed: int = 0,
                    spec: CutSpec = CutSpec(), case: str = "tx200-aluminium", entry: bool = True) -> dict:
    """Write ``forces.csv`` and ``cut.toml`` into the new ``directory``. Returns the truth: ``t_s``,
    ``clean`` (n, 3) and ``noise`` (n, 3), N."""
    d = Path(directory)
    d.mkdir(parents=False, exist_ok=False)
    t, clean = measured_forces(spec, eff, entry=entry)
    noise = np.random.default_rng(seed).normal(0.0, noise_n, clean.shape)
    np.savetxt(d / "forces.csv", np.column_stack([t, clean + noise]), delimiter=",", header="t_s,fx_n,fy_n,fz_n",
               comments="", fmt="%.10g")
    rate = spec.spindle_rpm / 60.0 * SAMPLES_PER_REV
    (d / "cut.toml").write_text(f'case = "{case}"\nsample_rate_hz = {rate:.10g}\n'
                                f"window_s = [{t[0]:.10g}, {t[-1]:.10g}]\n")
    return {"t_s": t, "clean": clean, "noise": noise}


# ---------------------------------------------------------------------------------------------- the pass's entry

#: The pass of the shipped case ``tx200-aluminium`` (``[pass]``; cases/spec.py, linearize/path.py), SI: the tool
#: centre starts at rest ``approach + R`` before the part's entry face and follows a jerk-limited feed ramp of
#: ``PASS_RAMP_S`` (jerk ``+-4 V / T^2``, ``s(T) = V T / 2``) to the cut's feed, at constant orientation.
PASS_RAMP_S = 0.1
PASS_APPROACH_M = 1e-3


def feed_profile(t_s: np.ndarray, feed_m_per_s: float, ramp_s: float = PASS_RAMP_S) -> tuple:
    """Commanded tool-centre travel along the feed from rest: ``(s (n,) m, v (n,) m/s, a (n,) m/s^2)`` at times
    ``t_s`` (n,), s (at rest before 0). Jerk ``+J`` on ``[0, T/2]``, ``-J`` on ``[T/2, T]``, ``J = 4 V / T^2``, then
    ``v = V`` (the ramp to rest at the pass's end is beyond the data)."""
    t = np.clip(np.asarray(t_s, float), 0.0, None)
    V, T = feed_m_per_s, ramp_s
    J, h = 4 * V / T ** 2, T / 2
    tr = np.minimum(t, T)
    u = tr - h
    first = tr <= h
    s = np.where(first, J * tr ** 3 / 6, V * T / 12 + V * u / 2 + J * h * u ** 2 / 2 - J * u ** 3 / 6)
    v = np.where(first, J * tr ** 2 / 2, V / 2 + J * h * u - J * u ** 2 / 2)
    a = np.where(first, J * tr, J * h - J * u)
    late = t > T
    return (np.where(late, V * T / 2 + V * (t - T), s), np.where(late, V, v), np.where(late, 0.0, a))


@dataclass(frozen=True)
class RobotStructure:
    """The independent TX200 at the Tab. 7 pose as a state-space model of the deflection ``d = q - theta`` (n,)
    of its links from the motor angles: ``M d'' + C d' + K d = J^T F_tool - M theta'' - C theta'`` (the dampers
    act on the absolute link velocity, tests/generators/tx200.py), exactly discretized for a force held over
    each step ``dt_s`` (zero-order hold): ``x_(k+1) = ad x_k + bd u_k``, ``x = (d, d')`` (2n,).

    ``out`` (2, n): tool-centre deflection (x, y) of the cut frame per ``d``, m/rad; ``inp`` (n, 2): generalized
    force per tool force (x, y), N m/N; ``path`` (n, 2): generalized force per commanded feed
    ``(acceleration m/s^2, speed m/s)``: ``-M theta_dot_per_v`` and ``-C theta_dot_per_v`` with
    ``theta_dot = J6^-1 (v e_feed, 0)`` (constant orientation; the ``J6' theta'`` term, ``v^2`` over the arm's
    metre, 4e-3 m/s^2 against the ramp's 1.2, is left out)."""

    ad: np.ndarray
    bd: np.ndarray
    out: np.ndarray
    inp: np.ndarray
    path: np.ndarray
    a: np.ndarray
    b: np.ndarray

    @classmethod
    def at_pose(cls, dt_s: float, theta_deg=None, feed_direction=(1.0, 0.0, 0.0)) -> "RobotStructure":
        import pinocchio as pin
        from scipy.linalg import expm

        from .tx200 import POSE_TAB7_DEG, TX200

        robot = TX200()
        q_deg = POSE_TAB7_DEG if theta_deg is None else np.asarray(theta_deg, float)
        M, C, K, J = robot.matrices(q_deg)
        n = M.shape[0]
        q = np.zeros(robot.model.nq)
        q[robot.motion] = np.radians(q_deg)
        pin.computeJointJacobians(robot.model, robot.data, q)
        pin.updateFramePlacements(robot.model, robot.data)
        J6 = pin.getFrameJacobian(robot.model, robot.data, robot.tcp_frame, pin.LOCAL_WORLD_ALIGNED)[:, robot.motion]
        zc = -robot.tcp_rotation(q_deg)[:, 2]
        f = np.asarray(feed_direction, float)
        xc = f - (f @ zc) * zc
        xc /= np.linalg.norm(xc)
        Rc2 = np.vstack([xc, np.cross(zc, xc)])                 # cut x, y in base axes
        th_per_v = np.zeros(n)
        th_per_v[robot.motion] = np.linalg.solve(J6, np.concatenate([xc, np.zeros(3)]))
        Minv = np.linalg.inv(M)
        A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ C]])
        B = np.vstack([np.zeros((n, n)), Minv])
        big = np.zeros((3 * n, 3 * n))
        big[:2 * n, :2 * n] = A * dt_s
        big[:2 * n, 2 * n:] = B * dt_s
        E = expm(big)
        return cls(ad=E[:2 * n, :2 * n], bd=E[:2 * n, 2 * n:], out=Rc2 @ J, inp=J.T @ Rc2.T,
                   path=np.column_stack([-M @ th_per_v, -C @ th_per_v]), a=A, b=B)

    def substeps(self, dt_s: float, fractions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(ad (F, 2n, 2n), bd (F, 2n, n))``: the exact propagation over ``fractions`` (F,) of a step ``dt_s``."""
        from scipy.linalg import expm

        n2, n = self.b.shape
        out_a, out_b = [], []
        for fr in fractions:
            big = np.zeros((n2 + n, n2 + n))
            big[:n2, :n2] = self.a * dt_s * fr
            big[:n2, n2:] = self.b * dt_s * fr
            E = expm(big)
            out_a.append(E[:n2, :n2])
            out_b.append(E[:n2, n2:])
        return np.array(out_a), np.array(out_b)


def _forces_in_pass(spec: CutSpec, eff: ForceEffects, phase: np.ndarray, now: np.ndarray, then, n_slices: int,
                    x_entry_m: float) -> np.ndarray:
    """Forces on the workpiece (M, 3), N, at spindle angles ``phase`` (M,) with the tool centre at ``now`` (M, 2)
    (cut frame, m, the commanded travel included) and, for each tooth ``j`` and each tooth ``k`` ahead of it,
    ``then[j][k - 1] = (centre (M, 2) m, velocity (M, 2) m/s)`` at the earlier time ``t - lag_jk / Omega``.

    The same exact chip as :func:`_forces_on_workpiece`, of a tool that moves along any path (the commanded
    feed in the centre's history, so ``a = 0`` in :func:`_chip_behind`), bounded also by the part's entry face
    ``x = x_entry_m`` (material at ``x > x_entry_m``): along the ray from the tip, ``h <= r_j - (x_entry - X) /
    sin(phi)`` where ``sin(phi) > 0``; where ``sin(phi) <= 0`` the ray runs towards ``+x`` and the tip decides."""
    db = spec.ap_m / n_slices
    z = (np.arange(n_slices) + 0.5) * db
    R = spec.diameter_m / 2
    theta = _theta(spec)
    n = len(spec.pitch_rad)
    out = np.zeros((len(phase), 3))
    X, Y = now[:, 0:1], now[:, 1:2]
    for j in range(n):
        phi, sin, cos, r_j, h = _tooth_at_stock_face(spec, eff, phase, z, theta[j], j, Y)
        ahead = sin > 0
        tip_in = X + r_j * sin > x_entry_m
        h = np.minimum(h, np.where(ahead, r_j - (x_entry_m - X) / np.where(ahead, sin, 1.0),
                                   np.where(tip_in, np.inf, -np.inf)))
        for k, ang in enumerate(_lags(spec, j), start=1):
            c_then, v_then = then[j][k - 1]
            h = np.minimum(h, _chip_behind(spec, phi, r_j, R + eff.tooth_radius_m[(j - k) % n], ang,
                                           c_then - now, v_then, a=0.0))
        cutting = h > 0
        ft = np.where(cutting, spec.ktc_pa * h * db + eff.kte_n_per_m * db, 0.0)
        fr = np.where(cutting, spec.krc_pa * h * db + eff.kre_n_per_m * db, 0.0)
        out[:, 0] -= np.sum(-ft * cos - fr * sin, axis=1)
        out[:, 1] -= np.sum(ft * sin - fr * cos, axis=1)
    return out


def _lag_samples(spec: CutSpec, per_rev: int) -> list:
    """Samples (int) from tooth ``j - k`` to tooth ``j`` at ``per_rev`` samples per revolution, ``[j][k - 1]``."""
    out = []
    for j in range(len(spec.pitch_rad)):
        lags = np.asarray(_lags(spec, j)) / (2 * math.pi) * per_rev
        if np.abs(lags - np.round(lags)).max() > 1e-9:
            raise ValueError(f"the teeth's pitch is not a whole number of samples at {per_rev} per revolution")
        out.append([int(round(x)) for x in lags])
    return out


@dataclass(frozen=True)
class PassRun:
    """A simulated pass from rest: ``t_s`` (N,) s on the sample grid from 0; ``state`` (N, 2n) the deflection and
    its rate at each sample; ``u`` (N, n) the generalized force held over the step after it; ``force`` (N, 3) N on
    the workpiece; ``centre``, ``velocity`` (N, 2) the tool centre (commanded travel included), m, m/s;
    ``deflection`` (N, 2) the tool centre off its commanded path, m."""

    t_s: np.ndarray
    state: np.ndarray
    u: np.ndarray
    force: np.ndarray
    centre: np.ndarray
    velocity: np.ndarray
    deflection: np.ndarray


def simulate_pass(t_end_s: float, spec: CutSpec = CutSpec(), eff: ForceEffects = ForceEffects(), *,
                  n_slices: int = 40, structure: RobotStructure | None = None) -> PassRun:
    """The pass from rest to ``t_end_s`` on the data's sample grid (``SAMPLES_PER_REV`` per revolution), in time:
    at each sample the force at the tool's position, then the robot over the step (exact discretization,
    the force held: a lag of half a step, 9 us, 0.035 rad at the 623 Hz tooth passing)."""
    rate = spec.spindle_rpm / 60.0 * SAMPLES_PER_REV
    dt = 1.0 / rate
    st = structure or RobotStructure.at_pose(dt)
    N = int(math.floor(t_end_s * rate + 1e-9)) + 1
    t = np.arange(N) * dt
    s, v, acc = feed_profile(t, spec.feed_m_per_s)
    n = st.out.shape[1]
    x = np.zeros(2 * n)
    state, u_all = np.zeros((N, 2 * n)), np.zeros((N, n))
    force, centre, vel = np.zeros((N, 3)), np.zeros((N, 2)), np.zeros((N, 2))
    lag = _lag_samples(spec, SAMPLES_PER_REV)
    x_entry = PASS_APPROACH_M + spec.diameter_m / 2
    phase = spec.omega_rad_s * t
    rest = (np.zeros((1, 2)), np.zeros((1, 2)))
    for k in range(N):
        state[k] = x
        centre[k] = (s[k] + st.out[0] @ x[:n], st.out[1] @ x[:n])
        vel[k] = (v[k] + st.out[0] @ x[n:], st.out[1] @ x[n:])
        then = [[(centre[k - m:k - m + 1], vel[k - m:k - m + 1]) if k >= m else
                 (np.zeros((1, 2)), rest[1]) for m in row] for row in lag]
        f = _forces_in_pass(spec, eff, phase[k:k + 1], centre[k:k + 1], then, n_slices, x_entry)[0]
        force[k] = f
        u = st.inp @ (-f[:2]) + st.path @ np.array([acc[k], v[k]])
        u_all[k] = u
        x = st.ad @ x + st.bd @ u
    return PassRun(t_s=t, state=state, u=u_all, force=force, centre=centre, velocity=vel,
                   deflection=centre - np.column_stack([s, np.zeros(N)]))
