"""An independent cutting-force generator for test data: Altintas' mechanistic milling force, rigid tool.

Nothing here imports ``robolobes``: the force law is written from the textbook (Altintas,
*Manufacturing Automation*, 2nd ed., ch. 2.3-2.5), the cut's numbers are typed in from the shipped
case ``tx200-aluminium`` (paper Tab. 7-8, NOTES.md), and every effect is built here in its own way.

Model (rigid tool and workpiece; the robot's vibration at the 623 Hz tooth passing is left out,
see :data:`ROBOT_VIBRATION_NOTE`):

* immersion of tooth ``j`` at height ``z`` above the tip: ``phi_j(t, z) = Omega t + theta_j - 2 z tan(beta) / D``,
  measured clockwise from ``+y`` (feed ``+x``), ``theta_0 = 0``, ``theta_(j+1) = theta_j - pitch_j``;
* down milling: a tooth cuts for ``pi - arccos(1 - 2 ae / D) <= phi <= pi``;
* chip thickness with tooth radii ``R + r_j``: the smallest over the ``k = 1..N`` teeth ahead of
  ``j`` of ``v_f tau_jk sin(phi) + r_j - r_(j-k)`` (``tau_jk`` the time since tooth ``j-k`` passed
  the same angle), and zero when negative (the tooth is out of the material);
* forces per axial element ``db``: ``dFt = Ktc h db + Kte db``, ``dFr = Krc h db + Kre db``; on the tool
  ``dFx = -dFt cos(phi) - dFr sin(phi)``, ``dFy = dFt sin(phi) - dFr cos(phi)``; the data are the
  forces on the workpiece (minus those), ``z`` zero (``Kac = Kae = 0``);
* the dynamometer: a second-order stage ``wn^2 / (s^2 + 2 zeta wn s + wn^2)`` on each axis, simulated
  in time (``scipy.signal.lsim``) from a lead-in of the periodic force so the window has no start
  transient;
* noise: white Gaussian, ``noise_n`` N on each axis and sample.

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


def _chip(spec: CutSpec, eff: ForceEffects, j: int, phi: np.ndarray) -> np.ndarray:
    n = len(spec.pitch_rad)
    h = np.full(phi.shape, np.inf)
    ang = 0.0
    for k in range(1, n + 1):
        ang += spec.pitch_rad[(j - k) % n]          # angle from tooth j-k to tooth j
        tau = ang / spec.omega_rad_s
        h = np.minimum(h, spec.feed_m_per_s * tau * np.sin(phi) + eff.tooth_radius_m[j] - eff.tooth_radius_m[(j - k) % n])
    return np.maximum(h, 0.0)


def rigid_forces(t_s: np.ndarray, spec: CutSpec = CutSpec(), eff: ForceEffects = ForceEffects(),
                 n_slices: int = 40) -> np.ndarray:
    """Forces on the workpiece (n, 3), N, cut frame, at times ``t_s`` (n,): rigid tool, no dynamometer."""
    t = np.asarray(t_s, float)
    db = spec.ap_m / n_slices
    z = (np.arange(n_slices) + 0.5) * db
    phi_st = math.pi - math.acos(1 - 2 * spec.ae_m / spec.diameter_m)
    theta = np.concatenate([[0.0], -np.cumsum(spec.pitch_rad[:-1])])
    out = np.zeros((len(t), 3))
    for j in range(len(spec.pitch_rad)):
        phi = spec.omega_rad_s * t[:, None] + theta[j] - 2 * z[None, :] * math.tan(spec.helix_rad) / spec.diameter_m
        phi = np.mod(phi, 2 * math.pi)
        engaged = (phi >= phi_st) & (phi <= math.pi)
        h = _chip(spec, eff, j, phi)
        cutting = engaged & (h > 0)
        ft = np.where(cutting, spec.ktc_pa * h * db + eff.kte_n_per_m * db, 0.0)
        fr = np.where(cutting, spec.krc_pa * h * db + eff.kre_n_per_m * db, 0.0)
        out[:, 0] -= np.sum(-ft * np.cos(phi) - fr * np.sin(phi), axis=1)
        out[:, 1] -= np.sum(ft * np.sin(phi) - fr * np.cos(phi), axis=1)
    return out


def _dynamometer(t: np.ndarray, f: np.ndarray, fn_hz: float, zeta: float) -> np.ndarray:
    from scipy import signal

    w = 2 * math.pi * fn_hz
    sys_ = signal.lti([w * w], [1.0, 2 * zeta * w, w * w])
    return np.column_stack([signal.lsim(sys_, f[:, k], t)[1] for k in range(3)])


def measured_forces(spec: CutSpec = CutSpec(), eff: ForceEffects = ForceEffects(), window_s=WINDOW_S,
                    lead_in_s: float = 0.02) -> tuple[np.ndarray, np.ndarray]:
    """Noise-free forces through the measurement chain: ``(t_s (n,), force_n (n, 3))`` over ``window_s``."""
    rate = spec.spindle_rpm / 60.0 * SAMPLES_PER_REV
    t = np.arange(math.ceil((window_s[0] - lead_in_s) * rate), math.floor(window_s[1] * rate) + 1) / rate
    f = rigid_forces(t, spec, eff)
    if eff.dynamometer is not None:
        f = _dynamometer(t, f, *eff.dynamometer)
    keep = t >= window_s[0] - 1e-12
    return t[keep], f[keep]


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
