"""Zero-order approximation (Altintas & Budak 1995, CIRP Annals 44:357-362).

The directional matrix is replaced by its time average over a revolution; with ``a0`` the average
of one tooth per unit depth (:func:`lobes.directional.average_directional_matrix`, 3 x 2) and
``G(iw) = S2 (iw - A)^-1 B`` the tool-tip receptance (2 x 3, cut frame), a harmonic chatter
``r = r0 exp(iwt)`` exists at depth ``b`` when::

    det(I - b E(w) X(w)) = 0,   X = G a0 (2 x 2),   E(w) = sum_j (1 - exp(-i w tau_j))

the sum running over the teeth that cut (variable pitch: each tooth with its own delay, as in
Altintas, Engin & Budak 1999, J. Manuf. Sci. Eng. 121:173-178; runout: a tooth that does not cut
drops out and its successor's delay is longer). The helix does not change the average. With
``lambda`` an eigenvalue of ``X``, ``b = 1 / (lambda E)``: the chatter frequencies at a speed are the
``w`` where ``z = lambda(w) E(w)`` is real and positive, and the limit is the smallest ``1 / z``. We
follow the two eigenvalues of ``X`` as continuous branches over a frequency grid (uniform, finer than
1/40 of the lowest tooth-passing frequency, plus dense grids around each pole; each step pairs them
with the previous point's so that they move least), look for sign changes of ``Im z`` on each
branch where ``Re z > 0``, and refine each by regula falsi. Pairing by continuity matters: ordering
the two roots by their imaginary part instead swaps their labels whenever both cross the real axis
in one grid interval, one at a positive and one at a negative depth, and then neither ordered list
changes sign (e.g. the 0.594 mm limit at 22 500 rpm of a two-mode up-milling case, chatter 1066 Hz).

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
from .measured import MeasuredStructure
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
        st = problem.structure
        if isinstance(st, MeasuredStructure):
            # the measured FRF itself, on its band: the resonances must be resolved
            pk = st.check_resolution()
            self._receptance = st.receptance
            self.measured = st
            self.pole_f = np.array([p.freq_hz for p in pk])
            self.pole_zeta = np.array([p.bandwidth_hz / (2 * p.freq_hz) for p in pk])
        else:
            ss = st.state_space()
            ss.check_stable()
            self._receptance = ss.receptance
            self.measured = None
            lam = ss.poles
            self.pole_f = np.abs(np.imag(lam)) / (2 * np.pi)
            self.pole_zeta = np.where(np.abs(lam) > 0, -np.real(lam) / np.maximum(np.abs(lam), 1e-300), 1.0)
        k = 3 if problem.law.kac_pa != 0.0 else 2
        self.a0 = average_directional_matrix(problem.tool, problem.cut, problem.law)[:k]  # (k, 2)
        self.k = k
        regs = [r for r in regeneration(problem.tool, problem.cut) if r.cuts]
        if not regs:
            raise LobeError("no tooth cuts (runout larger than the feed for every tooth)")
        self.delay_rad = np.array([r.delay_rad for r in regs])

    def _X(self, freq_hz: np.ndarray) -> np.ndarray:
        H = self._receptance(2 * np.pi * np.asarray(freq_hz, dtype=float))  # (3, 3, F), m/N
        return np.einsum("ikf,kj->fij", H[:2, : self.k], self.a0)  # (F, 2, 2)

    def grid(self, rpm_min: float) -> np.ndarray:
        """Chatter frequencies searched (Hz, increasing): uniform plus dense grids around the poles;
        for a measured FRF, the measured band only, uniform plus the measured lines."""
        osc = self.pole_f[self.pole_f > 0]
        if self.measured is not None:
            lo, hi = self.measured.band_hz
            if self.method.freq_range_hz is not None:
                lo, hi = max(lo, self.method.freq_range_hz[0]), min(hi, self.method.freq_range_hz[1])
                if hi <= lo:
                    raise LobeError(f"freq_range_hz {self.method.freq_range_hz} lies outside the measured band "
                                    f"{self.measured.band_hz[0]:g}-{self.measured.band_hz[1]:g} Hz")
        elif self.method.freq_range_hz is not None:
            lo, hi = self.method.freq_range_hz
        else:
            if len(osc) == 0:
                raise LobeError("the structure has no oscillating mode; give ZeroOrder(freq_range_hz=...)")
            lo, hi = 0.2 * osc.min(), 2.5 * osc.max()
        ft = rpm_min / 60.0 * 2 * math.pi / self.delay_rad.max()  # lowest regeneration frequency, Hz
        df = ft / self.method.points_per_tooth_band
        n = math.ceil((hi - lo) / df) + 1
        if n > 2_000_000:
            raise LobeError(f"ZOA frequency grid would need {n} points; narrow freq_range_hz or raise the speeds")
        parts = [np.linspace(lo, hi, n)]
        if self.measured is not None:
            fm = self.measured.freq_hz
            parts.append(fm[(fm >= lo) & (fm <= hi)])
        for f, z in zip(self.pole_f, self.pole_zeta):
            if f > 0:
                bw = max(z, 1e-6) * f
                parts.append(np.linspace(max(lo, f - 8 * bw), min(hi, f + 8 * bw), self.method.points_per_mode))
        g = np.unique(np.concatenate(parts))
        return g[np.r_[True, np.diff(g) > 1e-9 * g[1:]]]

    @staticmethod
    def _eig(X: np.ndarray) -> np.ndarray:
        """Eigenvalues ``lambda`` of X (..., 2, 2), shape (..., 2), m/N per unit depth.

        ``(tr X +- sqrt(tr^2 - 4 det)) / 2``. Where X has rank 1 (``|det X| <= 1e-9 |tr X|^2``,
        e.g. a single mode) the second eigenvalue is set to exactly 0 (its root b is at infinity), so
        that rounding noise in ``det X`` cannot produce spurious roots.
        """
        detX = X[..., 0, 0] * X[..., 1, 1] - X[..., 0, 1] * X[..., 1, 0]
        trX = X[..., 0, 0] + X[..., 1, 1]
        s = np.sqrt(trX**2 - 4 * detX + 0j)
        rank1 = np.abs(detX) <= 1e-9 * np.abs(trX) ** 2
        l1 = np.where(rank1, trX, 0.5 * (trX + s))
        l2 = np.where(rank1, 0.0, 0.5 * (trX - s))
        return np.stack([l1, l2], axis=-1)

    @classmethod
    def _tracked_eig(cls, X: np.ndarray) -> np.ndarray:
        """Eigenvalues of X (F, 2, 2) on an increasing frequency grid, as two continuous branches (F, 2).

        Each step keeps the pairing with the previous point that moves the eigenvalues least.
        (Ordering the roots by real or imaginary part instead makes two roots that cross the real
        axis in the same grid interval swap labels, and both crossings are lost.)
        """
        lam = cls._eig(X)
        if len(lam) < 2:
            return lam
        a, b = lam[:-1], lam[1:]
        straight = np.abs(b[:, 0] - a[:, 0]) + np.abs(b[:, 1] - a[:, 1])
        crossed = np.abs(b[:, 1] - a[:, 0]) + np.abs(b[:, 0] - a[:, 1])
        parity = np.concatenate([[0], np.cumsum(crossed < straight) % 2]).astype(bool)
        return np.where(parity[:, None], lam[:, ::-1], lam)

    def _E(self, freq_hz, rpm):
        w = 2 * np.pi * np.asarray(freq_hz)
        om = np.asarray(rpm) * 2 * np.pi / 60.0
        tau = self.delay_rad[None, :] / om[:, None]  # (S, teeth)
        return (1 - np.exp(-1j * w[..., None] * tau[:, None, :])).sum(axis=-1)  # (S, F)

    def _E_at(self, freq_hz: np.ndarray, rpm: np.ndarray) -> np.ndarray:
        """``E`` at paired frequencies and speeds (n,) -> (n,)."""
        tau = self.delay_rad[None, :] / (np.asarray(rpm) * 2 * np.pi / 60.0)[:, None]  # (n, teeth)
        return (1 - np.exp(-1j * (2 * np.pi * np.asarray(freq_hz))[:, None] * tau)).sum(axis=1)

    def limits(self, rpm: np.ndarray):
        """Depth limit (m), chatter frequency (Hz) at each speed (S,).

        On each eigenvalue branch ``lambda(w)`` of X, ``b = 1 / z`` with ``z = lambda E`` (bounded,
        no poles): a root is a sign change of ``Im z`` with ``Re z > 0``, refined by Illinois
        regula falsi on ``Im z`` (the eigenvalue at a trial frequency is the one nearest the
        branch's value at the bracket's end).
        """
        rpm = np.asarray(rpm, dtype=float).reshape(-1)
        f = self.grid(rpm.min())
        lam = self._tracked_eig(self._X(f))  # (F, 2)
        out_b = np.full(len(rpm), np.inf)
        out_f = np.full(len(rpm), np.nan)
        chunk = max(1, int(2e6 // len(f)))
        for c0 in range(0, len(rpm), chunk):
            r = rpm[c0:c0 + chunk]
            E = self._E(f, r)  # (S, F)
            for which in (0, 1):
                b, fr, s_idx = self._branch_roots(f, lam[:, which], E, r)
                for s_, b_, f_ in zip(s_idx, b, fr):
                    if b_ < out_b[c0 + s_]:
                        out_b[c0 + s_] = b_
                        out_f[c0 + s_] = f_
        return out_b, out_f

    def _branch_roots(self, f: np.ndarray, lam: np.ndarray, E: np.ndarray, r: np.ndarray):
        """Real positive roots b (m), their frequencies (Hz) and speed indices on one branch ``lam`` (F,)."""
        z = lam[None, :] * E  # (S, F)
        im, re = np.imag(z), np.real(z)
        cross = (np.sign(im[:, :-1]) != np.sign(im[:, 1:])) & (im[:, 1:] != 0)
        si, fi = np.nonzero(cross)
        # the real part where Im z crosses 0, interpolated: a root only if it is > 0 (b = 1 / Re z)
        t = im[si, fi] / (im[si, fi] - im[si, fi + 1])
        keep = re[si, fi] + t * (re[si, fi + 1] - re[si, fi]) > 0
        si, fi = si[keep], fi[keep]
        empty = np.zeros(0)
        if len(si) == 0:
            return empty, empty, np.zeros(0, int)
        fa, fb = f[fi], f[fi + 1]
        la, lb = lam[fi], lam[fi + 1]
        ga, gb = im[si, fi], im[si, fi + 1]
        rs = r[si]
        side = np.zeros(len(si), int)
        fm, zm = fa, la * E[si, fi]
        for _ in range(60):  # Illinois regula falsi on Im z
            den = gb - ga
            fm = np.where(den != 0, fa - ga * (fb - fa) / np.where(den != 0, den, 1.0), 0.5 * (fa + fb))
            fm = np.clip(fm, np.minimum(fa, fb), np.maximum(fa, fb))
            cand = self._eig(self._X(fm))  # (n, 2)
            ref = la + (lb - la) * ((fm - fa) / np.where(fb != fa, fb - fa, 1.0))
            pick = np.abs(cand[:, 1] - ref) < np.abs(cand[:, 0] - ref)
            lm = np.where(pick, cand[:, 1], cand[:, 0])
            zm = lm * self._E_at(fm, rs)
            gm = np.imag(zm)
            left = np.sign(gm) == np.sign(ga)  # root in [fm, fb]
            ga = np.where(left, gm, np.where(side == -1, ga / 2, ga))
            gb = np.where(left, np.where(side == 1, gb / 2, gb), gm)
            la = np.where(left, lm, la)
            lb = np.where(left, lb, lm)
            fa = np.where(left, fm, fa)
            fb = np.where(left, fb, fm)
            side = np.where(left, 1, -1)
            if np.all(np.abs(fb - fa) <= 1e-13 * np.abs(fm)):
                break
        valid = (np.real(zm) > 0) & (np.abs(np.imag(zm)) <= 1e-6 * np.abs(np.real(zm)))
        return 1.0 / np.real(zm)[valid], fm[valid], si[valid]
