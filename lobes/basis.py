"""Reduced modal basis of a tool-tip structure for the lobes (speed).

The SDM's cost grows with the number of states (about ``ns^3`` per step exponential and per
monodromy product). Modes far above the frequencies the cut excites, or that barely move the tool
tip, need not be carried: :func:`reduced_basis` keeps only the modes the cut can feel and replaces
the others by their static compliance. (On the TX200 at the default 10 mm search depth the rule
keeps every mode: ``docs/guide/lobes-accuracy.md``.)

**The rule.** In the real block-diagonal modal form ``H(w) = sum_j H_j(w)`` (one 2 x 2 block
``j`` per complex pole pair or pair of real poles; its natural frequency is the largest ``|lambda|``). A dropped set ``D`` is replaced by a *residual mode*: its static
compliance ``G_D = sum_{j in D} H_j(0)`` (3 x 3, m/N) behind a second-order filter
``g_r(w) = w_r^2 / (w_r^2 - w^2 + 2 i zeta_r w_r w)`` at the lowest natural frequency ``w_r`` of the
dropped modes above the band (damping ``zeta_r`` of that mode), realized with ``D = 0`` (a
feedthrough would close an algebraic loop through the chip) by one 2 x 2 block per singular value
of its cut-plane rows ``G_D[:2]`` (at most 2 blocks; the axial displacement enters no chip
thickness). So ``H_red(0)[:2] = H(0)[:2]`` exactly (the truncated modes' static compliance is
kept), and the error is::

    H_red(w) - H(w) = G_D g_r(w) - sum_{j in D} H_j(w)          (= 0 at w = 0)

Modes are dropped, in increasing order of their own in-band error, as long as the *loop
perturbation* stays below :data:`BASIS_REL_TOL` at every frequency of the band ``[0, f_band]`` (a
1500-point grid plus each mode's damped frequency and half-power points), computed, not
estimated::

    e(w) = 2 k_loop ||(H_red - H)(w)[:2, :]||_2 <= BASIS_REL_TOL,
    k_loop = N a_max (1 / 2 pi) integral_engaged ||D(phi)||_2 dphi       (N/m)

``k_loop`` bounds every Fourier coefficient of the periodic cutting stiffness ``W(t)`` at the
deepest depth searched ``a_max`` (``D`` the per-tooth directional matrix per unit depth), and 2
bounds ``|1 - exp(-i w tau)|``, so ``e`` bounds the change of the regenerative loop
``(1 - e^{-i w tau}) W H`` in any harmonic. On the stability boundary the critical loop eigenvalue
is -1 (zero-order picture), so a loop perturbation ``e`` moves it by about ``e`` and the limit by
about ``e`` relative (times the eigenvector condition number); at depths below ``a_max`` the
perturbation is smaller still. The band is what the cut excites: ``f_band = BASIS_HARMONICS *
f_tooth_max``, with ``f_tooth_max`` the highest tooth-passing frequency of the speeds solved
(chatter frequencies lie within one tooth-passing frequency of a structural mode, and the periodic
cutting force folds the response by multiples of it).

A reduction is used only if it has fewer states than the full model (the residual costs up
to 2 blocks, so at least 3 modes must go); otherwise the result is the full basis
(``basis.kind == "full"``).

Why not an error relative to ``||H||``: at 1.7 kHz the robot's receptance is 400 times below its
static compliance, so a relative criterion keeps every mode; the loop scale says how much
receptance the cut can feel. And why not relative to the band's peak (the earlier 300 Hz
truncation's report): the lobe peaks, where the limit is 50 times the minimum, are set by a loop
50 times stiffer, which the peak-relative error does not see (that truncation was off by 9.8 %).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ._errors import LobeError
from .structure import ReducedStructure, StateSpace, TruncationReport, _real_modal_form

__all__ = ["BASIS_HARMONICS", "BASIS_REL_TOL", "BasisInfo", "band_edge_hz", "basis_for", "loop_stiffness", "reduced_basis",
           "residual_mode", "truncated_with_residual"]

#: largest loop perturbation ``e(w)`` allowed in the band (module docstring): the one accuracy
#: parameter of the rule. It moves the limits by about 0.1 %, 5 times below the 0.5 % target and
#: 10 times below the 1 % accuracy budget of the default diagram.
BASIS_REL_TOL = 1e-3
#: band edge in multiples of the highest tooth-passing frequency (see the module docstring)
BASIS_HARMONICS = 2.0
_GRID = 1500


@dataclass(frozen=True)
class BasisInfo:
    """Which basis a structure uses (recorded in results).

    Attributes
    ----------
    kind : {"reduced", "full"}
    band_hz : float
        Band edge ``f_band`` of the rule, Hz.
    loop_stiffness_n_per_m : float
        ``k_loop`` of the rule at the deepest depth searched, N/m.
    tol : float
        :data:`BASIS_REL_TOL` of the rule.
    n_modes, n_kept, n_residual : int
        Modes (2 x 2 blocks) of the full model, kept, and residual-mode blocks added.
    n_states, n_states_full : int
    max_loop_error : float
        Largest loop perturbation ``e(w)`` over the band grid.
    residual_freq_hz : float
        Frequency of the residual mode, Hz (0 if none).
    """

    kind: str
    band_hz: float
    loop_stiffness_n_per_m: float
    tol: float
    n_modes: int
    n_kept: int
    n_residual: int
    n_states: int
    n_states_full: int
    max_loop_error: float
    residual_freq_hz: float

    def to_json(self) -> dict:
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


def band_edge_hz(teeth: int, rpm_max: float, harmonics: float = BASIS_HARMONICS) -> float:
    """``f_band = harmonics * teeth * rpm_max / 60``, Hz: the rule's band edge."""
    if not (teeth >= 1 and math.isfinite(rpm_max) and rpm_max > 0):
        raise LobeError(f"band edge needs teeth >= 1 and a speed > 0 rpm, got teeth {teeth}, rpm {rpm_max}")
    return float(harmonics) * int(teeth) * float(rpm_max) / 60.0


def loop_stiffness(tool, cut, law, depth_max_m: float, nodes: int = 400) -> float:
    """``k_loop = N a_max (1 / 2 pi) integral_engaged ||D(phi)||_2 dphi``, N/m (module docstring):
    a bound on every Fourier coefficient of the cutting stiffness at depth ``depth_max_m`` (m)."""
    from robolobes.cases.milling import directional_matrix, engagement_rad

    if not (math.isfinite(depth_max_m) and depth_max_m > 0):
        raise LobeError(f"depth_max_m must be a depth > 0 m, got {depth_max_m!r}")
    st, ex = engagement_rad(tool, cut)
    x, wq = np.polynomial.legendre.leggauss(nodes)
    phi = st + (x + 1) * (ex - st) / 2
    nrm = np.linalg.norm(directional_matrix(phi, law), ord=2, axis=(1, 2))
    return float(tool.teeth * depth_max_m * np.dot(wq, nrm) * (ex - st) / 2 / (2 * math.pi))


def basis_for(problem, speeds_rpm, depth_max_m: float, tol: float = BASIS_REL_TOL) -> ReducedStructure:
    """:func:`reduced_basis` of ``problem.structure`` with the rule's band and loop stiffness for
    the speeds ``speeds_rpm`` (rpm) and depths up to ``depth_max_m`` (m)."""
    rpm_max = float(np.max(np.asarray(speeds_rpm, dtype=float)))
    return reduced_basis(problem.structure, band_edge_hz(problem.tool.teeth, rpm_max),
                         loop_stiffness(problem.tool, problem.cut, problem.law, depth_max_m), tol)


def _block_diag(*mats: np.ndarray) -> np.ndarray:
    """Block-diagonal matrix of square blocks (scipy is not imported at start-up)."""
    n = sum(m.shape[0] for m in mats)
    out = np.zeros((n, n))
    i = 0
    for m in mats:
        k = m.shape[0]
        out[i:i + k, i:i + k] = m
        i += k
    return out


def _blocks(ss: StateSpace):
    """The modal 2 x 2 blocks ``(A_j, B_j, S_j)`` of ``ss`` (its real block-diagonal modal form)."""
    if not ss.block2:
        modal = _real_modal_form(ss.A, ss.B, ss.S)
        if modal is None or not modal.block2:
            raise LobeError("the structure has no well-conditioned real modal form; use the full basis")
        ss = modal
    n = ss.n_states // 2
    return [(ss.A[2 * j:2 * j + 2, 2 * j:2 * j + 2], ss.B[2 * j:2 * j + 2], ss.S[:, 2 * j:2 * j + 2]) for j in range(n)]


def _block_frf(A2: np.ndarray, B2: np.ndarray, S2: np.ndarray, w: np.ndarray) -> np.ndarray:
    """``S (i w I - A)^-1 B`` of one 2 x 2 block, (F, 3, 3), closed-form 2 x 2 inverse."""
    a, b, c, d = A2[0, 0], A2[0, 1], A2[1, 0], A2[1, 1]
    s = 1j * w
    det = (s - a) * (s - d) - b * c
    inv = np.empty((len(w), 2, 2), complex)
    inv[:, 0, 0], inv[:, 0, 1] = (s - d) / det, b / det
    inv[:, 1, 0], inv[:, 1, 1] = c / det, (s - a) / det
    return S2[None] @ inv @ B2[None]


def _block_freq(A2: np.ndarray) -> tuple[float, float, float]:
    """Natural frequency ``max |lambda|`` (rad/s), damping ratio and damped frequency of a block."""
    lam = np.linalg.eigvals(A2)
    k = int(np.argmax(np.abs(lam)))
    wn = float(np.abs(lam[k]))
    return wn, float(-np.real(lam[k]) / wn), float(abs(np.imag(lam[k])))


def residual_mode(G: np.ndarray, omega_rad_s: float, zeta: float) -> StateSpace | None:
    """A ``D = 0`` realization of ``G w_r^2 / (w_r^2 - w^2 + 2 i zeta w_r w)`` for the cut-plane
    rows of ``G`` (3, 3) m/N (outputs x_c, y_c; the axial output enters no chip thickness).

    One block ``[[0, w_r], [-w_r, -2 zeta w_r]]`` per singular value ``s_i`` of ``G[:2] = U S V^T``
    (those above 1e-12 of the largest; at most 2), input row ``w_r s_i v_i``, output column
    ``u_i``: its static compliance is ``G[:2]`` (axial row 0). None if ``G[:2]`` is zero."""
    U, sv, Vh = np.linalg.svd(np.asarray(G, dtype=float)[:2])
    if sv[0] <= 0:
        return None
    As, Bs, Ss = [], [], []
    for i in range(2):
        if sv[i] <= 1e-12 * sv[0]:
            continue
        As.append(np.array([[0.0, omega_rad_s], [-omega_rad_s, -2 * zeta * omega_rad_s]]))
        B = np.zeros((2, 3))
        B[1] = omega_rad_s * sv[i] * Vh[i]
        S = np.zeros((3, 2))
        S[:2, 0] = U[:, i]
        Bs.append(B)
        Ss.append(S)
    return StateSpace(np.asarray(_block_diag(*As)), np.vstack(Bs), np.hstack(Ss))


def _grid(f_band_hz: float, freqs: list[tuple[float, float, float]]) -> np.ndarray:
    """Band grid, rad/s: uniform plus each in-band mode's damped frequency and half-power points."""
    wb = 2 * math.pi * f_band_hz
    pts = [np.linspace(0.0, wb, _GRID)]
    for _wn, z, wd in freqs:
        if wd <= wb:
            pts.append(np.clip(wd * np.array([1 - z, 1 - z / 2, 1.0, 1 + z / 2, 1 + z]), 0.0, wb))
    return np.unique(np.concatenate(pts))


def _residual_for(dropped: list[int], G0: list[np.ndarray], freqs, wb: float):
    """(G_D, w_r, zeta_r) of a dropped set: residual at the lowest dropped frequency above the band
    (below it if none is above)."""
    G = sum((G0[j] for j in dropped), np.zeros((3, 3)))
    above = [j for j in dropped if freqs[j][0] > wb]
    j = min(above or dropped, key=lambda k: freqs[k][0])
    return G, freqs[j][0], freqs[j][1]


def _loop_error(Hd: np.ndarray, G: np.ndarray, w_r: float, z_r: float, w: np.ndarray, k2: float) -> float:
    """``max_w 2 k_loop ||(G g_r - H_D)(w)[:2, :]||`` (``k2 = 2 k_loop``)."""
    g = w_r**2 / (w_r**2 - w**2 + 2j * z_r * w_r * w)
    E = G[None, :2] * g[:, None, None] - Hd[:, :2]
    return float(k2 * np.max(np.linalg.norm(E, ord=2, axis=(1, 2))))


def reduced_basis(structure, f_band_hz: float, loop_stiffness_n_per_m: float,
                  tol: float = BASIS_REL_TOL) -> ReducedStructure:
    """The reduced modal basis of ``structure`` for the band ``[0, f_band_hz]`` (module docstring).

    Parameters
    ----------
    structure : PhysicalStructure, StateSpace or any structure with ``state_space()``
    f_band_hz : float
        Band edge, Hz (:func:`band_edge_hz`).
    loop_stiffness_n_per_m : float
        ``k_loop``, N/m (:func:`loop_stiffness`).
    tol : float
        Largest loop perturbation allowed in the band.

    Returns
    -------
    ReducedStructure
        Kept modal blocks plus the residual mode; ``basis`` holds the :class:`BasisInfo`, ``report``
        the :class:`TruncationReport` (static error at rounding level, FRF error in the band).
    """
    for name, v in (("f_band_hz", f_band_hz), ("loop_stiffness_n_per_m", loop_stiffness_n_per_m)):
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise LobeError(f"{name} must be finite and > 0, got {v!r}")
    if not (isinstance(tol, (int, float)) and math.isfinite(tol) and 0 < tol < 1):
        raise LobeError(f"tol must be in (0, 1), got {tol!r}")
    ss = structure.state_space()
    blocks = _blocks(ss)
    freqs = [_block_freq(A2) for A2, _, _ in blocks]
    w = _grid(f_band_hz, freqs)
    wb = 2 * math.pi * f_band_hz
    k2 = 2.0 * float(loop_stiffness_n_per_m)
    Hj = [_block_frf(A2, B2, S2, w) for A2, B2, S2 in blocks]
    G0 = [-S2 @ np.linalg.solve(A2, B2) for A2, B2, S2 in blocks]
    own = [float(k2 * np.max(np.linalg.norm((Hj[j] - G0[j][None])[:, :2], ord=2, axis=(1, 2))))
           for j in range(len(blocks))]
    dropped: list[int] = []
    Hd = np.zeros((len(w), 3, 3), complex)
    err = 0.0
    for j in np.argsort(own, kind="stable"):
        trial = dropped + [int(j)]
        G, w_r, z_r = _residual_for(trial, G0, freqs, wb)
        e = _loop_error(Hd + Hj[j], G, w_r, z_r, w, k2)
        if e <= tol:
            dropped, Hd, err = trial, Hd + Hj[j], e
    rule = (float(f_band_hz), float(loop_stiffness_n_per_m), float(tol))
    red = _assemble(ss, blocks, freqs, dropped, G0, rule, err)
    if red.ss.n_states >= ss.n_states:  # the residual would cost as many states as it saves
        return _assemble(ss, blocks, freqs, [], G0, rule, 0.0)
    return red


def truncated_with_residual(structure, max_freq_hz: float, f_band_hz: float | None = None) -> ReducedStructure:
    """Keep the modes up to ``max_freq_hz`` (natural frequency ``max |lambda| / 2 pi``, Hz) and
    replace the others by the residual mode (static correction), without the rule's check: for
    comparisons and closed-form checks. ``f_band_hz`` (default ``max_freq_hz``) only sets where
    the residual frequency is taken (lowest dropped mode above it) and the report's band."""
    if not (isinstance(max_freq_hz, (int, float)) and math.isfinite(max_freq_hz) and max_freq_hz > 0):
        raise LobeError(f"max_freq_hz must be a frequency > 0 Hz, got {max_freq_hz!r}")
    fb = float(max_freq_hz if f_band_hz is None else f_band_hz)
    ss = structure.state_space()
    blocks = _blocks(ss)
    freqs = [_block_freq(A2) for A2, _, _ in blocks]
    G0 = [-S2 @ np.linalg.solve(A2, B2) for A2, B2, S2 in blocks]
    dropped = [j for j in range(len(blocks)) if freqs[j][0] > 2 * math.pi * max_freq_hz]
    return _assemble(ss, blocks, freqs, dropped, G0, (fb, 0.0, 0.0), float("nan"))


def _assemble(ss, blocks, freqs, dropped, G0, rule, err) -> ReducedStructure:
    f_band_hz, k_loop, tol = rule
    wb = 2 * math.pi * f_band_hz
    kept = [j for j in range(len(blocks)) if j not in set(dropped)]
    parts = [StateSpace(blocks[j][0], blocks[j][1], blocks[j][2]) for j in kept]
    w_r = 0.0
    if dropped:
        G, w_r, z_r = _residual_for(dropped, G0, freqs, wb)
        res = residual_mode(G, w_r, z_r)
        if res is not None:
            parts.append(res)
    if not parts:
        raise LobeError("the reduced basis kept no mode")
    A = np.asarray(_block_diag(*[p.A for p in parts]))
    red = StateSpace(A, np.vstack([p.B for p in parts]), np.hstack([p.S for p in parts]))
    n_res = (red.n_states - 2 * len(kept)) // 2
    G_full, G_red = ss.static_compliance()[:2], red.static_compliance()[:2]  # cut plane (residual_mode)
    st = float(np.linalg.norm(G_red - G_full, 2) / np.linalg.norm(G_full, 2))
    fk = tuple(sorted(freqs[j][0] / (2 * math.pi) for j in kept))
    fd = tuple(sorted(freqs[j][0] / (2 * math.pi) for j in dropped))
    wg = np.linspace(0.0, wb, 2001)
    Hf, Hr = ss.receptance(wg), red.receptance(wg)
    Hf, Hr = Hf[:2], Hr[:2]
    frf = float(np.max(np.linalg.norm(Hr - Hf, ord=2, axis=(0, 1))) / np.max(np.linalg.norm(Hf, ord=2, axis=(0, 1))))
    report = TruncationReport(fk, fd, st, frf, (0.0, float(f_band_hz)))
    info = BasisInfo("reduced" if dropped else "full", float(f_band_hz), k_loop, tol, len(blocks), len(kept), n_res, red.n_states,
                     ss.n_states, float(err), float(w_r / (2 * math.pi)))
    return ReducedStructure(red, report, info)
