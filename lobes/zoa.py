"""Zero-order approximation (Altintas & Budak 1995, CIRP Annals 44:357-362).

The directional matrix is replaced by its time average over a revolution; with ``a0`` the average
of one tooth per unit depth (:func:`lobes.directional.average_directional_matrix`, 3 x 2) and
``G(iw) = S2 (iw - A)^-1 B`` the tool-tip receptance (2 x 3, cut frame), a harmonic chatter
``r = r0 exp(iwt)`` exists at depth ``b`` when::

    det(I - b E(w) X(w)) = 0,   X = G a0 (2 x 2),   E(w) = sum_j (1 - exp(-i w tau_j))

the sum running over the teeth that cut (variable pitch: each tooth with its own delay, as in
Altintas, Engin & Budak 1999, J. Manuf. Sci. Eng. 121:173-178; runout: a tooth that does not cut
drops out and its successor's delay is longer). The helix does not change the average. The
determinant is the quadratic ``1 - mu tr X + mu^2 det X = 0`` in ``mu = b E``; the chatter frequencies at a speed are the ``w`` where one of its roots is
real and positive, and the limit is the smallest such root. We scan ``w`` on a grid (uniform, finer
than 1/40 of the lowest tooth-passing frequency, plus dense grids around each pole) for sign
changes of the imaginary parts of the two roots (ordered by imaginary part, which keeps them
continuous), then refine each crossing by secant steps.

For one mode of stiffness ``k``, damping ``zeta`` along a unit direction ``d`` with
``a_dd = d^T a0 d < 0`` and ``N`` teeth of uniform pitch, the lowest limit is the closed form
``b_min = 2 k zeta (1 + zeta) / (N |a_dd|)`` at ``w = w_n sqrt(1 + 2 zeta)``
(``a_dd > 0``: ``2 k zeta (1 - zeta) / (N a_dd)`` at ``w_n sqrt(1 - 2 zeta)``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from robolobes.cases.milling import regeneration
from robolobes.core.validate import integer

from ._errors import LobeError
from .directional import average_directional_matrix
from .problem import LobeProblem

__all__ = ["ZeroOrder"]


@dataclass(frozen=True)
class ZeroOrder:
    """Altintas-Budak zero-order approximation (multi-DOF, oriented-FRF eigenvalue form).

    Parameters
    ----------
    points_per_tooth_band : int
        Frequency grid points per lowest tooth-passing frequency (>= 8).
    points_per_mode : int
        Extra grid points across +-8 half-power bandwidths of each pole (>= 8).
    freq_range_hz : (float, float) or None
        Chatter frequencies searched; default ``(0.2 f_min, 2.5 f_max)`` of the structure's poles.
    """

    points_per_tooth_band: int = 40
    points_per_mode: int = 400
    freq_range_hz: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        for k in ("points_per_tooth_band", "points_per_mode"):
            integer(f"ZeroOrder {k}", getattr(self, k), minimum=8, error=LobeError)
        if self.freq_range_hz is not None:
            lo, hi = self.freq_range_hz
            if not (0 < lo < hi and math.isfinite(hi)):
                raise LobeError(f"freq_range_hz must be (lo, hi) with 0 < lo < hi, got {self.freq_range_hz!r}")

    @property
    def name(self) -> str:
        return "zoa"


class ZOAEngine:
    def __init__(self, problem: LobeProblem, method: ZeroOrder):
        self.problem, self.method = problem, method
        ss = problem.structure.state_space()
        ss.check_stable()
        self.ss = ss
        k = 3 if problem.law.kac_pa != 0.0 else 2
        self.a0 = average_directional_matrix(problem.tool, problem.cut, problem.law)[:k]  # (k, 2)
        self.k = k
        regs = [r for r in regeneration(problem.tool, problem.cut) if r.cuts]
        if not regs:
            raise LobeError("no tooth cuts (runout larger than the feed for every tooth)")
        self.delay_rad = np.array([r.delay_rad for r in regs])
        lam = ss.poles
        self.pole_f = np.abs(lam.imag) / (2 * np.pi)
        self.pole_zeta = np.where(np.abs(lam) > 0, -lam.real / np.maximum(np.abs(lam), 1e-300), 1.0)

    def _X(self, freq_hz: np.ndarray) -> np.ndarray:
        H = self.ss.receptance(2 * np.pi * np.asarray(freq_hz, dtype=float))  # (3, 3, F), m/N
        return np.einsum("ikf,kj->fij", H[:2, : self.k], self.a0)  # (F, 2, 2)

    def grid(self, rpm_min: float) -> np.ndarray:
        osc = self.pole_f[self.pole_f > 0]
        if self.method.freq_range_hz is not None:
            lo, hi = self.method.freq_range_hz
        else:
            if len(osc) == 0:
                raise LobeError("the structure has no oscillating mode; give ZeroOrder(freq_range_hz=...)")
            lo, hi = 0.2 * osc.min(), 2.5 * osc.max()
        ft = rpm_min / 60.0 * 2 * math.pi / self.delay_rad.max()  # lowest regeneration frequency, Hz
        df = ft / self.method.points_per_tooth_band
        n = int(math.ceil((hi - lo) / df)) + 1
        if n > 2_000_000:
            raise LobeError(f"ZOA frequency grid would need {n} points; narrow freq_range_hz or raise the speeds")
        parts = [np.linspace(lo, hi, n)]
        for f, z in zip(self.pole_f, self.pole_zeta):
            if f > 0:
                bw = max(z, 1e-6) * f
                parts.append(np.linspace(max(lo, f - 8 * bw), min(hi, f + 8 * bw), self.method.points_per_mode))
        g = np.unique(np.concatenate(parts))
        return g[np.r_[True, np.diff(g) > 1e-9 * g[1:]]]

    @staticmethod
    def _roots(E: np.ndarray, X: np.ndarray):
        """Roots b of det(I - b E X) = 0, ordered by imaginary part (lo, hi); NaN where absent.

        ``mu = b E`` solves ``1 - mu tr X + mu^2 det X = 0``: ``mu = 2 / (tr X -+ sqrt(tr^2 - 4 det))``.
        Where X has rank 1 (``|det X| <= 1e-9 |tr X|^2``, e.g. a single mode) the second root is at
        infinity and is dropped, so that rounding noise in ``det X`` cannot produce spurious roots.
        """
        detX = X[..., 0, 0] * X[..., 1, 1] - X[..., 0, 1] * X[..., 1, 0]
        trX = X[..., 0, 0] + X[..., 1, 1]
        s = np.sqrt(trX**2 - 4 * detX + 0j)
        with np.errstate(divide="ignore", invalid="ignore"):
            mu1 = 2.0 / (trX + s)
            mu2 = 2.0 / (trX - s)
            rank1 = np.abs(detX) <= 1e-9 * np.abs(trX) ** 2
            mu1 = np.where(rank1, 1.0 / trX, mu1)
            mu2 = np.where(rank1, np.nan, mu2)
            b1 = mu1 / E
            b2 = mu2 / E
        b1 = np.where(np.isfinite(b1), b1, np.nan)
        b2 = np.where(np.isfinite(b2), b2, np.nan)
        # order by imaginary part, a missing root last (keeps each list continuous)
        k1 = np.where(np.isfinite(b1), b1.imag, np.inf)
        k2 = np.where(np.isfinite(b2), b2.imag, np.inf)
        swap = k1 > k2
        lo = np.where(swap, b2, b1)
        hi = np.where(swap, b1, b2)
        return lo, hi

    def _E(self, freq_hz, rpm):
        w = 2 * np.pi * np.asarray(freq_hz)
        om = np.asarray(rpm) * 2 * np.pi / 60.0
        tau = self.delay_rad[None, :] / om[:, None]  # (S, teeth)
        return (1 - np.exp(-1j * w[..., None] * tau[:, None, :])).sum(axis=-1)  # (S, F)

    def limits(self, rpm: np.ndarray):
        """Depth limit (m), chatter frequency (Hz) at each speed (S,)."""
        rpm = np.asarray(rpm, dtype=float).reshape(-1)
        f = self.grid(rpm.min())
        X = self._X(f)  # (F, 2, 2)
        out_b = np.full(len(rpm), np.inf)
        out_f = np.full(len(rpm), np.nan)
        chunk = max(1, int(2e6 // len(f)))
        for c0 in range(0, len(rpm), chunk):
            r = rpm[c0:c0 + chunk]
            E = self._E(f, r)  # (S, F)
            roots = self._roots(E, X[None])
            for which in (0, 1):
                im = roots[which].imag
                re = roots[which].real
                ok = np.isfinite(im[:, :-1]) & np.isfinite(im[:, 1:])
                cross = ok & (np.sign(im[:, :-1]) != np.sign(im[:, 1:])) & (np.sign(im[:, :-1]) != 0)
                cross |= ok & (im[:, :-1] == 0)
                si, fi = np.nonzero(cross)
                if len(si) == 0:
                    continue
                # discard crossings through a pole of b (huge jumps, both real parts huge or of
                # opposite sign): keep those with positive real parts at both ends
                keep = (re[si, fi] > 0) & (re[si, fi + 1] > 0)
                si, fi = si[keep], fi[keep]
                if len(si) == 0:
                    continue
                fa, fb = f[fi], f[fi + 1]
                ga, gb = im[si, fi], im[si, fi + 1]
                side = np.zeros(len(si), int)
                rs = r[si]
                for _ in range(60):  # Illinois regula falsi on Im(b)
                    den = gb - ga
                    fm = np.where(den != 0, fa - ga * (fb - fa) / np.where(den != 0, den, 1.0), 0.5 * (fa + fb))
                    fm = np.clip(fm, np.minimum(fa, fb), np.maximum(fa, fb))
                    tau = self.delay_rad[None, :] / (rs * 2 * np.pi / 60.0)[:, None]  # (n, teeth)
                    Em = (1 - np.exp(-1j * (2 * np.pi * fm)[:, None] * tau)).sum(axis=1)
                    gm_all = self._roots(Em, self._X(fm))
                    gm = gm_all[which].imag
                    left = np.sign(gm) == np.sign(ga)  # root in [fm, fb]
                    ga = np.where(left, gm, np.where(side == -1, ga / 2, ga))
                    gb = np.where(left, np.where(side == 1, gb / 2, gb), gm)
                    fa = np.where(left, fm, fa)
                    fb = np.where(left, fb, fm)
                    side = np.where(left, 1, -1)
                    if np.all(np.abs(fb - fa) <= 1e-13 * np.abs(fm)):
                        break
                bm = gm_all[which]
                valid = (bm.real > 0) & np.isfinite(bm.real) & (np.abs(bm.imag) <= 1e-6 * np.abs(bm.real) + 1e-12)
                for s_, b_, f_ in zip(si[valid], bm.real[valid], fm[valid]):
                    if b_ < out_b[c0 + s_]:
                        out_b[c0 + s_] = b_
                        out_f[c0 + s_] = f_
        return out_b, out_f
