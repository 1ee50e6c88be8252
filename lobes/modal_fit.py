"""Modal fit of a measured tool-tip FRF: complex poles and residues by vector fitting.

The measured 2 x 2 receptance (or its driving points alone) is fitted by a common set of stable
complex pole pairs with a complex residue matrix each and no direct term::

    H(s) = sum_r R_r / (s - lam_r) + conj(R_r) / (s - conj(lam_r))

(:class:`lobes.structure.ComplexMode`), by vector fitting (Gustavsen & Semlyen 1999, IEEE Trans.
Power Delivery 14:1052-1061): the poles are relocated by repeated linear least squares, unstable
ones reflected into the left half plane, and the residues follow from a last least-squares solve.
No feedthrough and no lower or upper residual is fitted: the semi-discretization needs ``D = 0``
(a feedthrough closes an algebraic loop through the chip) and a residual ``1 / s^2`` would be an
undamped rigid-body pole. Modes outside the band therefore show as a fit error near its edges.

Vector fitting is hand-written (about 60 lines) rather than sdypy-EMA's LSCF + LSFD because it is
automatic: LSCF needs a pole selection from a stabilization diagram and LSFD's residuals are the
direct term the SDM must not have.

All entries are fitted with one weight (in m/N), so a small, noisy cross term does not pull the
poles more than its share of the receptance.

Quality and credibility, stated once: with ``e_ij`` the RMS deviation of the fitted ``H_ij`` from
the measurement over the band relative to the RMS of the largest measured entry (the scale of the
receptance the chip sees; an RMS is weighted by ``|H|^2``, hence by the resonances, and noise on
single lines averages out), a fit is **not credible** when

* ``max e > 5 %`` (:data:`MAX_RMS_ERROR`): the depth limit scales with ``1 / |Re G|`` at the
  lobe minimum, so a fit error of ``e`` at the resonance moves the limit by about ``e``; beyond 5 %
  the fitted lobes are no longer a copy of the measured ones to the accuracy a lobe chart is read;
* a mode's driving-point modal constant ``Re(2 i w_d R_ii)`` is negative (a real mode has
  ``d_i^2 / m > 0``) and the mode's own peak in that driving point, ``|R_ii| / (zeta w_n)``, exceeds
  three RMS residuals of the entry (below that it is zero within the noise): the mode is not a
  physical resonance of the tool tip;
* a driving point is not passive: ``Im H_ii(w) > 0`` somewhere in the band by more than three times
  the RMS residual of that entry (a passive structure dissipates, ``Im H_ii <= 0``; three RMS
  residuals is what noise alone reaches with a probability below 0.3 % per line).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from robolobes.core.threads import blas_single_threaded

from ._errors import LobeError
from .measured import MeasuredStructure
from .structure import ComplexMode, ModalStructure

__all__ = ["ModalFit", "fit_modal", "plot_fit", "MAX_RMS_ERROR", "MAX_MODES"]

MAX_RMS_ERROR = 0.05
MAX_MODES = 20
_ITERATIONS = 30


@dataclass(frozen=True, eq=False)
class ModalFit:
    """A vector fit of a :class:`MeasuredStructure`.

    Attributes
    ----------
    structure : ModalStructure
        The fitted :class:`ComplexMode` s (a structure for :class:`LobeProblem`).
    measured : MeasuredStructure
    entries : tuple of (int, int)
        The fitted entries ``(i, j)`` of ``H`` (all four, or the driving points alone).
    peak_error : dict
        ``"xx"`` etc. -> largest ``|H_fit - H|`` over the band / largest ``|H|`` of the entry.
    rms_error : dict
        ``"xx"`` etc. -> RMS of ``|H_fit - H|`` / RMS of ``|H|`` of the largest entry (the credibility measure).
    problems : tuple of str
        Why the fit is not credible (empty: credible; see the module doc for the rules).
    """

    structure: ModalStructure
    measured: MeasuredStructure
    entries: tuple
    peak_error: dict
    rms_error: dict
    problems: tuple = field(default=())

    @property
    def credible(self) -> bool:
        return not self.problems

    @property
    def modes(self) -> tuple:
        return self.structure.modes

    def fitted(self) -> np.ndarray:
        """Fitted receptance on the measured lines (2, 2, F), m/N."""
        return self.structure.state_space().receptance(self.measured.omega)[:2, :2]

    def summary(self) -> str:
        """One line: modes, errors, verdict."""
        err = ", ".join(f"{k} {v * 100:.2g} %" for k, v in self.rms_error.items())
        modes = ", ".join(f"{m.freq_hz:.5g} Hz (zeta {m.damping_ratio:.3g})" for m in self.modes)
        verdict = "credible" if self.credible else "NOT CREDIBLE: " + "; ".join(self.problems)
        return f"modal fit (vector fitting, {len(self.modes)} modes: {modes}); RMS error {err}; {verdict}"

    def to_json(self) -> dict:
        return {"method": "vector fitting, no direct term", "credible": self.credible, "problems": list(self.problems),
                "peak_error": self.peak_error, "rms_error": self.rms_error,
                "modes": [{"freq_hz": m.freq_hz, "damping_ratio": m.damping_ratio,
                           "residue_re": np.real(m.residue).tolist(), "residue_im": np.imag(m.residue).tolist(),
                           "modal_constants_per_kg": np.real(m.modal_constants).tolist()} for m in self.modes]}


_NAMES = {(0, 0): "xx", (0, 1): "xy", (1, 0): "yx", (1, 1): "yy"}


def _initial_poles(meas: MeasuredStructure, n_modes: int | None) -> np.ndarray:
    """Starting poles (rad/s): one per distinct resolved peak of the driving points reaching a tenth
    of their largest (every mode moves some driving point; :meth:`MeasuredStructure.peaks`), then
    evenly spread ones up to ``n_modes``; damping from each peak's half-power bandwidth."""
    f = meas.freq_hz
    pk = sorted(meas.peaks(), key=lambda p: p.freq_hz)
    chosen = []
    for p in pk:
        if chosen and abs(p.freq_hz - chosen[-1].freq_hz) < max(p.bandwidth_hz, chosen[-1].bandwidth_hz):
            if p.magnitude > chosen[-1].magnitude:
                chosen[-1] = p
            continue
        chosen.append(p)
    chosen = sorted(chosen, key=lambda p: -p.magnitude)[:MAX_MODES if n_modes is None else n_modes]
    poles = [complex(-p.bandwidth_hz / 2, p.freq_hz) * 2 * math.pi for p in chosen]
    n = len(poles) if n_modes is None else n_modes
    if n == 0:
        raise LobeError(f"{meas.source}: no resonance peak to fit; give the number of modes")
    extra = n - len(poles)
    for fx in np.linspace(f[0], f[-1], extra + 2)[1:-1]:
        poles.append(complex(-0.01 * fx, fx) * 2 * math.pi)
    return np.array(sorted(poles, key=lambda a: a.imag))


def _basis(s: np.ndarray, poles: np.ndarray) -> np.ndarray:
    """(Ns, 2N) complex: per pole pair ``1/(s-a) + 1/(s-conj a)`` and ``i/(s-a) - i/(s-conj a)``."""
    p = 1.0 / (s[:, None] - poles[None]), 1.0 / (s[:, None] - poles.conj()[None])
    return np.stack([p[0] + p[1], 1j * p[0] - 1j * p[1]], axis=2).reshape(len(s), -1)


def _ri(M: np.ndarray) -> np.ndarray:
    return np.concatenate([np.real(M), np.imag(M)], axis=0)


def _relocate(s: np.ndarray, F: np.ndarray, poles: np.ndarray) -> np.ndarray:
    """One vector-fitting pole relocation: zeros of ``sigma = 1 + Phi c~`` from
    ``Phi c_k - f_k Phi c~ = f_k`` for every response k (real unknowns)."""
    Phi = _basis(s, poles)
    K, Ns = F.shape
    n2 = Phi.shape[1]
    A = np.zeros((2 * Ns * K, n2 * (K + 1)))
    rhs = np.zeros(2 * Ns * K)
    for k in range(K):
        rows = slice(2 * Ns * k, 2 * Ns * (k + 1))
        A[rows, n2 * k:n2 * (k + 1)] = _ri(Phi)
        A[rows, n2 * K:] = _ri(-F[k][:, None] * Phi)
        rhs[rows] = _ri(F[k][:, None])[:, 0]
    ct = np.linalg.lstsq(A, rhs, rcond=None)[0][n2 * K:]
    if not np.all(np.isfinite(ct)):
        raise LobeError("the modal fit diverged (NaN in the pole relocation); give fewer modes")
    # real state space of sigma's poles: blocks [[a', a''], [-a'', a']], b = [2, 0]
    N = len(poles)
    Am = np.zeros((2 * N, 2 * N))
    b = np.zeros(2 * N)
    for n, a in enumerate(poles):
        Am[2 * n:2 * n + 2, 2 * n:2 * n + 2] = [[a.real, a.imag], [-a.imag, a.real]]
        b[2 * n] = 2.0
    z = np.linalg.eigvals(Am - np.outer(b, ct))
    z = np.where(z.real > 0, -z.real + 1j * z.imag, z)  # reflect unstable zeros
    up = sorted(z[np.imag(z) > 1e-9 * np.abs(z)], key=lambda a: np.imag(a))
    real = sorted(np.abs(np.real(z[np.abs(np.imag(z)) <= 1e-9 * np.abs(z)])))
    for r in real[1::2]:  # two real poles -> one lightly damped pair at the same magnitude
        up.append(complex(-0.01 * r, r))
    return np.array(sorted(up, key=lambda a: a.imag)[:N] if len(up) >= N else
                    sorted(list(up) + list(poles[len(up):]), key=lambda a: a.imag))


def _residues(s: np.ndarray, F: np.ndarray, poles: np.ndarray) -> np.ndarray:
    """Residues (K, N) complex of ``f_k = sum Phi c_k`` by least squares."""
    Phi = _ri(_basis(s, poles))
    C = np.linalg.lstsq(Phi, _ri(F.T), rcond=None)[0]  # (2N, K)
    c = C.reshape(len(poles), 2, F.shape[0])
    return (c[:, 0] + 1j * c[:, 1]).T


@blas_single_threaded
def fit_modal(measured: MeasuredStructure, n_modes: int | None = None) -> ModalFit:
    """Vector fit of a measured FRF over its band (see the module doc).

    Parameters
    ----------
    measured : MeasuredStructure
    n_modes : int, optional
        Number of pole pairs (1..MAX_MODES); default one per distinct resolved peak.

    Returns
    -------
    ModalFit (check ``credible`` before solving lobes with it).
    """
    if n_modes is not None and (isinstance(n_modes, bool) or not 1 <= int(n_modes) <= MAX_MODES):
        raise LobeError(f"n_modes must be an integer from 1 to {MAX_MODES}, got {n_modes!r}")
    entries = ((0, 0), (0, 1), (1, 0), (1, 1)) if measured.cross_measured else ((0, 0), (1, 1))
    w0 = float(measured.omega[-1])
    s = 1j * measured.omega / w0
    scale = np.full(len(entries), max(float(np.max(np.abs(measured.H[i, j]))) for i, j in entries))
    F = np.array([measured.H[i, j] for i, j in entries]) / scale[:, None]
    poles = _initial_poles(measured, n_modes) / w0
    for _ in range(_ITERATIONS):
        new = _relocate(s, F, poles)
        done = np.max(np.abs(new - poles) / np.abs(poles)) < 1e-10
        poles = new
        if done:
            break
    res = _residues(s, F, poles) * scale[:, None] * w0  # (K, N), m/(N s)
    lam = poles * w0
    modes = []
    for n, a in enumerate(lam):
        R = np.zeros((2, 2), complex)
        for k, (i, j) in enumerate(entries):
            R[i, j] = res[k, n]
        wn = abs(a)
        modes.append(ComplexMode(wn / (2 * math.pi), -a.real / wn, R))
    return _assess(ModalStructure(tuple(modes)), measured, entries)


def _assess(structure: ModalStructure, meas: MeasuredStructure, entries) -> ModalFit:
    Hf = structure.state_space().receptance(meas.omega)[:2, :2]
    peak, rms, problems = {}, {}, []
    ref = max(float(np.sqrt(np.mean(np.abs(meas.H[i, j]) ** 2))) for i, j in entries)
    for i, j in entries:
        d = np.abs(Hf[i, j] - meas.H[i, j])
        peak[_NAMES[i, j]] = float(np.max(d) / np.max(np.abs(meas.H[i, j])))
        rms[_NAMES[i, j]] = float(np.sqrt(np.mean(d**2)) / ref)
    worst = max(rms, key=lambda k: rms[k])
    if rms[worst] > MAX_RMS_ERROR:
        problems.append(f"H{worst} deviates from the measurement by {rms[worst] * 100:.3g} % RMS "
                        f"(> {MAX_RMS_ERROR * 100:g} %)")
    noise = [float(np.sqrt(np.mean(np.abs(Hf[i, i] - meas.H[i, i]) ** 2))) for i in range(2)]
    for m in structure.modes:
        for i in range(2):
            c = float(np.real(m.modal_constants[i, i]))
            # the mode's own peak in H_ii, |R_ii| / (zeta w_n): below 3 RMS residuals it is noise
            height = abs(m.residue[i, i]) / (-m.pole.real)
            if c < 0 and height > 3 * noise[i]:
                problems.append(f"the mode at {m.freq_hz:.5g} Hz has a negative driving-point modal constant "
                                f"({'xy'[i]}{'xy'[i]}: {c:.3g} 1/kg, peak {height:.3g} m/N > 3 RMS residuals)")
    for i in range(2):
        top = float(np.max(Hf[i, i].imag))
        if top > 3 * noise[i]:
            k = int(np.argmax(Hf[i, i].imag))
            problems.append(f"the fitted driving point H{'xy'[i]}{'xy'[i]} is not passive: Im H = {top:.3g} m/N > 0 "
                            f"at {meas.freq_hz[k]:.5g} Hz (3 RMS residuals = {3 * noise[i]:.3g} m/N)")
    return ModalFit(structure, meas, tuple(entries), peak, rms, tuple(problems))


def _phase_deg(H: np.ndarray) -> np.ndarray:
    """Phase in (-270, 90] deg: a receptance's -180 deg does not flip to +180 with noise."""
    return (np.degrees(np.angle(H)) + 270.0) % 360.0 - 270.0


def plot_fit(fit: ModalFit, path, title: str = "", provenance: dict | None = None) -> None:
    """Measured (grey dots) against fitted (lines) magnitude and phase of each fitted entry; saved atomically."""
    from robolobes.core.io import pyplot, save_figure

    plt = pyplot()
    f = fit.measured.freq_hz
    Hm, Hf = fit.measured.H, fit.fitted()
    fig, (a1, a2) = plt.subplots(2, 1, sharex=True, figsize=(8, 6.5), gridspec_kw={"height_ratios": [1.6, 1]})
    for (i, j), col in zip(fit.entries, ("tab:blue", "tab:orange", "tab:green", "tab:red")):
        name = _NAMES[i, j]
        a1.semilogy(f, np.abs(Hm[i, j]) * 1e6, ".", ms=1.5, color="0.6")
        a1.semilogy(f, np.abs(Hf[i, j]) * 1e6, "-", lw=1.1, color=col,
                    label=f"H{name} fit (RMS error {fit.rms_error[name] * 100:.2g} %)")
        a2.plot(f, _phase_deg(Hm[i, j]), ".", ms=1.5, color="0.6")
        a2.plot(f, _phase_deg(Hf[i, j]), "-", lw=1.1, color=col)
    a1.plot([], [], ".", color="0.6", label="measured")
    a1.set_ylabel("|H| (um/N)")
    a1.legend(fontsize=8)
    a1.grid(True, which="both", alpha=0.3)
    a1.set_title(title or ("modal fit: " + ("credible" if fit.credible else "NOT CREDIBLE")), fontsize=10)
    a2.set_ylabel("phase (deg)")
    a2.set_xlabel("frequency (Hz)")
    a2.grid(True, alpha=0.3)
    fig.tight_layout()
    try:
        save_figure(fig, path, provenance=provenance, dpi=110)
    finally:
        plt.close(fig)
