"""The FRF pipeline: measured tool-tip FRFs against the model, residuals, fit, held-out selection.

Per pose, the model is linearized once (:func:`structural.pose_matrices`); effects perturb those
matrices (fast, see :mod:`identify.structural`) and the receptance is solved directly on the
measured lines. Fits are weighted least squares on the residual divided by the noise of each line
(scipy ``least_squares``, trust-region reflective, bounds; parameters in log space when declared
so); the uncertainty is the Gauss-Newton covariance ``s^2 (J^T J)^-1`` with ``s^2`` the reduced
chi-square (so a model that does not fit within the noise widens its own error bars).

Noise of each line, from the data: for white noise of variance ``sigma^2`` (``E|n|^2``) on a
smooth FRF, the fourth difference ``d = (H_(f-2) - 4 H_(f-1) + 6 H_f - 4 H_(f+1) + H_(f+2)) / sqrt(70)``
has ``E|d|^2 = sigma^2`` and is blind to any cubic trend of the FRF; the noise relative to ``|H|``
is the running median (41 lines) of ``|d|^2 / |H|^2`` divided by ``ln 2`` (the median of an
exponential variable, ``|d|^2`` of complex Gaussian noise, is ``ln 2`` times its mean), times
``|H|^2`` of the 4 neighbouring lines (not the line's own value, which carries its noise): the
weights of the fits and signatures. The noise of a residual (noise floor, verdict) differences the
residual and scales by the 5-line mean of ``|H|^2``; the floor fits one relative-plus-additive noise
model per pair (:func:`pair_noise`), the verdict takes the running median. Median windows are mirrored at the ends, never
padded with the end line. Lines
near a sharp peak, where the FRF's own curvature enters ``d``, are a minority of every window, so
the median ignores them; any bias left makes ``sigma`` larger, i.e. the selection more cautious.

Selection is leave-one-pose-out and forward-backward (:func:`identify.selection.stepwise_select`):
each candidate is fitted jointly with every effect already in the model (all refitted), first on
all the data; only the ``SHORTLIST`` best by that training fit, whose training gain could pass the
test (``sqrt(gain / 2) >= z_threshold / 2``, see ``_Trials._shortlisted``), are fitted fold by fold
(the others keep the current model's held-out residual, so they cannot be chosen). The
significance threshold counts every candidate of the library at every forward step the search may
make (``2 max_effects L`` tests). ``tcp_mode`` may enter more than once (a mode per direction);
its fits start from the measured poles (:func:`residual_peaks`). After the selection:
``final_effects`` (credible, determined, surrogate) and ``_unexplained`` (the verdict on the final
residual against :func:`noise_floor`, and where it stays above the noise), see :mod:`identify.evidence`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np
from scipy.ndimage import median_filter, uniform_filter1d
from scipy.optimize import least_squares

from robolobes.linearize.frf_io import FRFSet
from robolobes.linearize.linear import _state_matrix

from .effects import ModelState, effects_for
from .result import Identification
from .selection import Trial, heldout_error
from .structural import PoseMatrices, ServoEffect, StructuralEffect, TcpModeEffect, pose_matrices

__all__ = ["identify_frf", "PoseData", "prepare", "predict", "line_noise", "METRIC", "SHORTLIST"]

METRIC = ("held-out (leave-one-pose-out) RMS over lines of |H_model - H_measured| / RMS |H_measured|, "
          "receptance in m/N, not squared")
SHORTLIST = 3
RESIDUAL_PEAKS = 4    # measured poles offered to a tool-mode fit as start frequencies
#: A servo's rotor inertia, reflected through the gearbox, is matched to the load it drives: inertia
#: matching puts it within 0.1-10x the link-side inertia of the axis. A fit far above that is not a
#: drive but a surrogate for something else.
MAX_ROTOR_RATIO = 10.0
MAX_LINES = 500_000   # lines over all poses and pairs (the 1200-line, 24-pair bench has 28 800)
_NOISE_WINDOW = 41
_PAIR_NOISE_STEPS = 200   # fixed-point steps of pair_noise at most (on the generator's 1128 pairs the upper half's median
#                           met ln 2 to 1e-5; b tends to 0 where the noise is relative only)


@dataclass(frozen=True)
class PoseData:
    """One pose's measurement, flattened to lines, and its linearized model.

    Attributes
    ----------
    name : str
    pm : PoseMatrices
    omega : array (F,), rad/s          union of the pairs' lines
    index : array (N,) of int          line -> position in ``omega``
    out_vec, in_vec : array (N, 3)     signed measurement directions in base axes, per line
    H : complex array (N,), m/N        measured
    sigma : array (N,), m/N            noise standard deviation per line (``E|n|^2``)
    pair : array (N,) of int           which pair of the pose each line belongs to
    pair_out, pair_in : array (P, 3)   each pair's signed directions in base axes
    pair_channel : array (P,) of int   each pair's response channel (0, 1, 2: the frame's x, y, z;
                                       :attr:`~robolobes.linearize.frf_io.MeasuredPair.channel`); None:
                                       one channel per response direction (the largest of ``pair_out``)
    """

    name: str
    pm: PoseMatrices
    omega: np.ndarray
    index: np.ndarray
    out_vec: np.ndarray
    in_vec: np.ndarray
    H: np.ndarray
    sigma: np.ndarray
    pair: np.ndarray
    pair_out: np.ndarray
    pair_in: np.ndarray
    pair_channel: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.pair_channel is None:
            object.__setattr__(self, "pair_channel", np.argmax(np.abs(self.pair_out), axis=1))


def line_noise(H: np.ndarray, residual: np.ndarray | None = None) -> np.ndarray:
    """Noise standard deviation of each line of one FRF (F,), from fourth differences (module doc).

    ``residual``: difference the residual ``H_model - H`` (same lines) instead of ``H``: the model
    takes the FRF's own curvature out, so near sharp peaks the differences are noise only (the
    noise-floor estimator, :func:`noise_floor`). The noise is still judged relative to ``|H|``.
    """
    H = np.asarray(H)
    if len(H) < 5:
        return np.full(len(H), np.inf)
    size = min(_NOISE_WINDOW, len(H) | 1)
    # "mirror" median windows: each window near an end holds distinct lines; "nearest" would repeat the
    # end line's ratio over half the window, so that the median *is* that one line's chi2(2) draw (1 % of
    # them below 0.01 of their mean: a 100x weight on the lines where the FRF is largest, the static end)
    a2 = np.abs(H) ** 2
    if residual is None:
        d = _fourth_difference(H)
        # weights of the fits and signatures: |H|^2 of the 4 neighbouring lines (2 on each side), not the
        # line's own, which carries its noise: a weight from it would down-weight the lines whose noise
        # happened to raise |H| and bias the fit (peaks too low) and the measurement chain's scale
        # (identify.chain_signatures: z -0.8 on average on noise alone)
        mag2 = (5 * uniform_filter1d(a2, size=5, mode="mirror") - a2) / 4
    else:
        # the noise of a residual (floor, verdict): the residual's differences over the 5-line mean of
        # |H|^2 (the residual is the noise; a weight is not formed from it)
        d = _fourth_difference(np.asarray(residual))
        mag2 = uniform_filter1d(a2, size=5, mode="mirror")
    mag2 = np.maximum(mag2, 1e-300)
    rel = median_filter(np.abs(d) ** 2 / mag2, size=size, mode="mirror")
    return np.sqrt(rel * mag2 / math.log(2))


def _fourth_difference(x: np.ndarray) -> np.ndarray:
    """``(x_(f-2) - 4 x_(f-1) + 6 x_f - 4 x_(f+1) + x_(f+2)) / sqrt(70)`` (F,), the two end lines copying
    their neighbour's (module doc): ``E|d|^2 = sigma^2`` for white noise, 0 for a cubic."""
    d = np.zeros(len(x), dtype=complex)
    d[2:-2] = (x[:-4] - 4 * x[1:-3] + 6 * x[2:-2] - 4 * x[3:-1] + x[4:]) / math.sqrt(70.0)
    d[:2], d[-2:] = d[2], d[-3]
    return d


def residual_sigma(poses: list[PoseData], residual: np.ndarray, pooled: bool = False) -> np.ndarray:
    """Per-line noise (N,) from the fourth differences of ``residual`` (all poses' lines concatenated,
    as the held-out trials give them), pair by pair in frequency order: :func:`line_noise` (local, the
    verdict's), or with ``pooled`` :func:`pair_noise` (one relative-plus-additive noise model per pair,
    the floor's)."""
    estimate = pair_noise if pooled else line_noise
    out = np.empty(len(residual))
    for pd, sl in zip(poses, _splits(poses)):
        r = residual[sl]
        for k in np.unique(pd.pair):
            idx = np.flatnonzero(pd.pair == k)
            order = idx[np.argsort(pd.omega[pd.index[idx]])]
            out[sl.start + order] = estimate(pd.H[order], r[order])
    return out


def pair_noise(H: np.ndarray, residual: np.ndarray) -> np.ndarray:
    """Noise standard deviation of each line of one pair (F,), m/N, from one noise model for the whole
    pair: ``sigma^2 = a m + b``, ``m`` the 5-line mirrored mean of ``|H|^2`` (m^2/N^2), ``a`` (-) the
    relative and ``b`` (m^2/N^2) the additive part of the noise.

    ``d``, the fourth difference of ``residual``, has ``|d|^2 / sigma^2`` Exp(1) on noise alone, whose
    median is ``ln 2``. ``a`` and ``b`` are solved so that this median holds in each half of the pair's
    lines, split at the median of ``m`` (the upper half mostly sets ``a``, the lower ``b``), by
    multiplicative fixed-point steps (``a, b >= 0`` throughout; ``b`` tends to 0 when the lower half's
    median stays below ``ln 2`` without it, i.e. the noise is relative only). Assumption: within one pair the noise
    variance is a fixed fraction of ``|H|^2`` plus a constant. A residual the model leaves near the FRF's
    own poles (an unexplained effect shifts them) is then a minority of a half-pair (20-28 of 200 lines
    on the generator's arm_bend draws), where it was 13-21 of the 41 lines (30 Hz at 0.75 Hz per line,
    both of the robot's first poles) of :func:`line_noise`'s windows at those poles."""
    H = np.asarray(H)
    if len(H) < 5:
        return np.full(len(H), np.inf)
    m = np.maximum(uniform_filter1d(np.abs(H) ** 2, size=5, mode="mirror"), 1e-300)
    d2 = np.abs(_fourth_difference(np.asarray(residual))) ** 2
    up = m >= np.median(m)
    ln2 = math.log(2)
    a = max(float(np.median(d2[up] / m[up])) / ln2, 1e-300)
    b = max(float(np.median(d2[~up])) / ln2, 1e-300)
    for _ in range(_PAIR_NOISE_STEPS):
        s2 = a * m + b
        ga, gb = float(np.median(d2[up] / s2[up])) / ln2, float(np.median(d2[~up] / s2[~up])) / ln2
        a, b = max(a * ga, 1e-300), max(b * gb, 1e-300)
        if abs(ga - 1) < 1e-9 and (abs(gb - 1) < 1e-9 or b < 1e-12 * a * m.min()):   # b = 0: relative noise only
            break
    return np.sqrt(a * m + b)


def noise_floor(poses: list[PoseData], residual: np.ndarray) -> tuple[float, np.ndarray]:
    """The noise floor: the error a model equal to the truth would have on these lines.

    Estimator: ``sqrt(mean sigma_p^2) / RMS |H|`` over every line, ``sigma_p`` from the fourth
    differences of the held-out residual of the final model with one noise model per pair,
    relative plus additive (:func:`pair_noise`: ``sigma^2 = a m + b``, ``m`` the 5-line mean of
    ``|H|^2``, the median of ``|d|^2 / sigma^2`` equal to ln 2 in each half of the pair's lines).
    Returns the floor and the local per-line noise ``sigma_r`` (N,) of the verdict
    (:func:`residual_sigma`: running median over 41 lines of ``|d|^2 / m``, no noise model)."""
    sig_p = residual_sigma(poses, residual, pooled=True)
    H = np.concatenate([pd.H for pd in poses])
    floor = float(np.sqrt(np.mean(sig_p ** 2)) / np.sqrt(np.mean(np.abs(H) ** 2)))
    return floor, residual_sigma(poses, residual)


def _frame_axes(frame: str, pm: PoseMatrices, feed_direction) -> np.ndarray:
    if frame == "base":
        return np.eye(3)
    from robolobes.cases.milling import cut_frame
    return cut_frame(feed_direction, pm.R_tcp[:, 2])


def prepare(measurement: FRFSet, model: ModelState, progress: Callable[[str], None] | None = None) -> list[PoseData]:
    """Linearize the model at every measured pose and flatten the measurement to lines."""
    robot = model.robot()
    out = []
    for pf in measurement.poses:
        if progress:
            progress(f"linearize pose {pf.pose}")
        pm = pose_matrices(robot, pf.theta)
        axes = _frame_axes(pf.frame, pm, model.case.cut.feed_direction)
        omega = np.unique(np.concatenate([p.omega for p in pf.pairs]))
        idx, ov, iv, H, sig, pair = [], [], [], [], [], []
        for k, p in enumerate(pf.pairs):
            n = len(p.omega)
            idx.append(np.searchsorted(omega, p.omega))
            ov.append(np.tile(p.out_sign * axes[p.out_axis], (n, 1)))
            iv.append(np.tile(p.in_sign * axes[p.in_axis], (n, 1)))
            H.append(p.H)
            sig.append(line_noise(p.H))
            pair.append(np.full(n, k))
        out.append(PoseData(pf.pose, pm, omega, np.concatenate(idx), np.vstack(ov), np.vstack(iv),
                            np.concatenate(H), np.concatenate(sig), np.concatenate(pair),
                            np.array([v[0] for v in ov]), np.array([v[0] for v in iv]),
                            np.array([p.response_channel for p in pf.pairs])))
    return out


def predict(pose: PoseData, effects: list) -> np.ndarray:
    """Model receptance on the pose's lines (N,), m/N, with ``effects`` = [(effect, params), ...]:
    the structural prediction with every effect's ``perturb``, then the measured() stage, the
    measurement-chain effects (:mod:`identify.chain_effects`) in their ``order``, per response channel."""
    pm = pose.pm
    for eff, params in effects:
        pm = eff.perturb(pm, params)
    # modal superposition over the 2n state-space poles, only on the measured lines and pairs:
    # H_line = sum_r (o . J phi_r) (psi_r M^-1 J^T . i) / (i w - lambda_r)   (same as frf_modal)
    n = pm.M.shape[0]
    A, Minv = _state_matrix(pm.M, pm.C, pm.K)
    lam, V = np.linalg.eig(A)
    W = np.linalg.inv(V)
    out_r = pm.J @ V[:n]                       # (3, 2n)
    in_r = W[:, n:] @ (Minv @ pm.J.T)          # (2n, 3)
    coef = (pose.pair_out @ out_r) * (in_r @ pose.pair_in.T).T        # (P, 2n)
    den = 1.0 / (1j * pose.omega[:, None] - lam[None, :])             # (F, 2n)
    H = (den @ coef.T)[pose.index, pose.pair]
    return measured(pose, H, effects, lambda: np.einsum("ar,fr,rb->fab", out_r, den, in_r))


def measured(pose: PoseData, H: np.ndarray, effects: list, point) -> np.ndarray:
    """The measured() stage: ``H`` (N,) through the measurement-chain effects among ``effects`` (those
    with a ``measured`` method), in their ``order``; ``point()`` the model's TCP receptance (F, 3, 3)."""
    chain = sorted(((e, p) for e, p in effects if hasattr(e, "measured")), key=lambda ep: ep[0].order)
    for eff, params in chain:
        H = eff.measured(pose, H, params, point)
    return H


# ----------------------------------------------------------------------------------------------
# parameters <-> optimizer variables


def _layout(effects: list) -> list:
    """``[(k, effect, parameter)]``: the fit variables, ``k`` the effect's position (an effect may repeat)."""
    return [(k, e, p) for k, e in enumerate(effects) for p in e.parameters]


def _to_x(layout, values: list[dict]) -> np.ndarray:
    return np.array([math.log(values[k][p.name]) if p.log else float(values[k][p.name]) for k, _, p in layout])


def _from_x(layout, x) -> list:
    res: list = []
    for xi, (k, e, p) in zip(x, layout):
        if k == len(res):
            res.append((e, {}))
        res[k][1][p.name] = math.exp(xi) if p.log else float(xi)
    return res


def _bounds(layout):
    lo = np.array([math.log(p.lower) if p.log else p.lower for _, _, p in layout])
    hi = np.array([math.log(p.upper) if p.log else p.upper for _, _, p in layout])
    return lo, hi


def _whitened(poses: list[PoseData], effects: list) -> np.ndarray:
    r = np.concatenate([(predict(pd, effects) - pd.H) / pd.sigma for pd in poses])
    return np.concatenate([r.real, r.imag])


def fit(poses: list[PoseData], fixed: list, effects: list, starts: list[list[dict]]) -> tuple[list, float, np.ndarray]:
    """Weighted least squares of the parameters of ``effects`` (each start: one dict per effect).

    ``fixed``: [(effect, params)] applied first and not fitted. Returns the best
    ``[(effect, params)]``, its chi-square and the parameter covariance in optimizer variables.
    """
    layout = _layout(effects)
    lo, hi = _bounds(layout)
    span = hi - lo
    best = None
    x0s = [np.clip(_to_x(layout, start), lo + 1e-6 * span, hi - 1e-6 * span) for start in starts]
    if len(x0s) > 2:   # many starts (a scan): optimize from the two with the lowest cost
        cost = [float(np.sum(_whitened(poses, fixed + _from_x(layout, x)) ** 2)) for x in x0s]
        x0s = [x0s[i] for i in np.argsort(cost)[:2]]
    for x0 in x0s:
        res = least_squares(lambda x: _whitened(poses, fixed + _from_x(layout, x)), x0, bounds=(lo, hi),
                            x_scale=np.maximum(span, 1e-12) / 10, method="trf", max_nfev=25 * (len(x0) + 1))
        if best is None or res.cost < best.cost:
            best = res
    assert best is not None  # at least one start
    chi2 = 2 * best.cost
    Jm = best.jac
    dof = max(1, len(best.fun) - len(best.x))
    try:
        cov = np.linalg.inv(Jm.T @ Jm) * max(chi2 / dof, 1.0)
    except np.linalg.LinAlgError:
        cov = np.full((len(best.x), len(best.x)), np.inf)
    return fixed + _from_x(layout, best.x), chi2, cov


def _uncertainty(effects_params: list, layout, cov) -> dict:
    sd = np.sqrt(np.clip(np.diag(cov), 0, None))
    out, k = {}, 0
    for e, params in effects_params:
        for p in e.parameters:
            v = params[p.name]
            out[p.name] = float(v * sd[k]) if p.log else float(sd[k])
            k += 1
    return out


# ----------------------------------------------------------------------------------------------
# diagnosis: what the residual looks like


def diagnose(poses: list[PoseData], effects: list) -> dict:
    """Signatures of the residual of the model with ``effects``: the extra peak (frequency where the
    measured / model magnitude ratio, averaged over poses and pairs, is largest) and its size; and
    the mass on the robot's mount (kg, :class:`~robolobes.identify.structural.PoseMatrices`), which
    sets a mount's start values."""
    fmin = min(pd.omega.min() for pd in poses) / (2 * math.pi)
    fmax = max(pd.omega.max() for pd in poses) / (2 * math.pi)
    edges = np.geomspace(max(fmin, 0.1), fmax * (1 + 1e-9), 241)
    acc = np.zeros(len(edges) - 1)
    cnt = np.zeros(len(edges) - 1)
    per_pose = []
    amp = np.zeros(len(edges) - 1)
    for pd in poses:
        Hm = predict(pd, effects)
        f = pd.omega[pd.index] / (2 * math.pi)
        b = np.clip(np.searchsorted(edges, f) - 1, 0, len(edges) - 2)
        lr = np.log(np.maximum(np.abs(pd.H), 1e-300) / np.maximum(np.abs(Hm), 1e-300))
        pp = np.bincount(b, lr, len(acc)) / np.maximum(np.bincount(b, minlength=len(acc)), 1)
        per_pose.append(pp)
        acc += np.bincount(b, lr, len(acc))
        cnt += np.bincount(b, minlength=len(acc))
        amp = np.maximum(amp, np.bincount(b, np.abs(pd.H - Hm), len(acc)) / np.maximum(np.bincount(b, minlength=len(acc)), 1))
    mean = np.where(cnt > 0, acc / np.maximum(cnt, 1), -np.inf)
    k = int(np.argmax(mean))
    f_peak = float(math.sqrt(edges[k] * edges[k + 1]))
    every_pose = bool(all(pp[k] > math.log(1.5) for pp in per_pose))
    return {"extra_peak_hz": f_peak, "extra_peak_m_per_n": float(amp[k]),
            "extra_peak_log_ratio": float(mean[k]), "extra_peak_in_every_pose": every_pose,
            "extra_peak_direction_tcp": _peak_direction(poses, effects, f_peak),
            "residual_peaks": residual_peaks(poses, effects, edges),
            "mount_mass_kg": float(poses[0].pm.mount_mass_kg), "rock_inertia_kg_m2": _rock_inertia(poses[0].pm)}


def _rock_inertia(pm) -> float:
    """Mean inertia about base x and y of the mass on the mount at the pose ``pm``, kg m^2 (a rocking
    mount's start values); 0 without it."""
    inertia = pm.mount_inertia_kg_m2
    return 0.0 if inertia is None else float(0.5 * (inertia[0, 0] + inertia[1, 1]))


def residual_peaks(poses: list[PoseData], effects: list, edges: np.ndarray, n_peaks: int = RESIDUAL_PEAKS) -> list:
    """The measured poles the model lacks: up to ``n_peaks`` local maxima, largest first, of the residual's
    amplitude ``|H_model - H|`` (mean over the lines of log-spaced bins, each pose's divided by its RMS
    |H|, averaged over the poses), among the bins where the residual stands above the noise (mean
    ``|r|^2`` over mean ``sigma^2`` above 2, twice a noise-only residual's). Each as ``(freq_hz,
    amplitude m/N)``, the amplitude the largest bin mean of ``|r|`` over the poses. A missing mode's
    residual peaks at its resonance; tool-mode fits start from these frequencies, so a fit cannot
    settle away from a pole the data show."""
    nb = len(edges) - 1
    power = np.zeros(nb)
    noise = np.zeros(nb)
    rel = np.zeros(nb)
    amp = np.zeros(nb)
    for pd in poses:
        r = predict(pd, effects) - pd.H
        b = np.clip(np.searchsorted(edges, pd.omega[pd.index] / (2 * math.pi)) - 1, 0, nb - 1)
        n = np.maximum(np.bincount(b, minlength=nb), 1)
        power += np.bincount(b, np.abs(r) ** 2, nb) / n
        noise += np.bincount(b, pd.sigma ** 2, nb) / n
        a = np.bincount(b, np.abs(r), nb) / n
        rel += a / np.sqrt(np.mean(np.abs(pd.H) ** 2)) / len(poses)
        amp = np.maximum(amp, a)
    above = power > 2.0 * np.maximum(noise, 1e-300)
    sm = np.convolve(rel, np.ones(3) / 3, mode="same")
    idx = [i for i in range(1, nb - 1) if above[i] and sm[i] >= sm[i - 1] and sm[i] > sm[i + 1]]
    idx.sort(key=lambda i: -sm[i])
    out: list = []
    for i in idx:
        j = i - 1 + int(np.argmax(rel[i - 1:i + 2]))
        f = float(math.sqrt(edges[j] * edges[j + 1]))
        if all(abs(f / g - 1) > 0.02 for g, _ in out):
            out.append((f, float(amp[j])))
        if len(out) == n_peaks:
            break
    return out


def _peak_direction(poses: list[PoseData], effects: list, f_hz: float):
    """Direction (TCP frame) of a rank-one residual ``d d^T g(w)`` near ``f_hz``, from the first pose
    with the three direct pairs: ``|d_k| = sqrt|r_kk|``, relative signs from the cross pairs."""
    for pd in poses:
        r = predict(pd, effects) - pd.H
        f = pd.omega[pd.index] / (2 * math.pi)
        near = np.abs(f / f_hz - 1) < 0.03
        R = np.full((3, 3), np.nan, dtype=complex)
        for k in np.unique(pd.pair):
            s = (pd.pair == k) & near
            o, i = np.argmax(np.abs(pd.pair_out[k])), np.argmax(np.abs(pd.pair_in[k]))
            if s.any() and np.isclose(abs(pd.pair_out[k][o]), 1) and np.isclose(abs(pd.pair_in[k][i]), 1):
                v = r[s][np.argmax(np.abs(r[s]))] * np.sign(pd.pair_out[k][o]) * np.sign(pd.pair_in[k][i])
                R[o, i] = R[i, o] = v
        diag = np.diagonal(R)
        if np.any(np.isnan(diag)):
            continue
        ref = diag[np.argmax(np.abs(diag))]
        d = np.sqrt(np.abs(diag))
        j = int(np.argmax(d))
        for k in range(3):
            if k != j and not np.isnan(R[j, k]) and (R[j, k] / ref).real < 0:
                d[k] = -d[k]
        if np.linalg.norm(d) == 0:
            continue
        d_tcp = pd.pm.R_tcp.T @ (d / np.linalg.norm(d))
        return [float(x) for x in d_tcp]
    return None


# ----------------------------------------------------------------------------------------------
# correlation measures


def correlation(poses: list[PoseData], effects: list) -> dict:
    """Per pose and pair: relative error, FRAC; per pose: mean CSAC and CSF over the lines."""
    out = {}
    for pd in poses:
        Hm = predict(pd, effects)
        pairs = {}
        for k in np.unique(pd.pair):
            s = pd.pair == k
            x, m = pd.H[s], Hm[s]
            frac = abs(np.vdot(m, x)) ** 2 / (np.vdot(m, m).real * np.vdot(x, x).real)
            pairs[int(k)] = {"error": heldout_error(m - x, x), "frac": float(frac)}
        # CSAC / CSF across the pairs at each line of the union axis (lines measured in all pairs)
        P = len(np.unique(pd.pair))
        csac, csf = [], []
        for fi in np.unique(pd.index):
            s = pd.index == fi
            if s.sum() < P:
                continue
            x, m = pd.H[s], Hm[s]
            csac.append(abs(np.vdot(x, m)) ** 2 / (np.vdot(x, x).real * np.vdot(m, m).real))
            csf.append(2 * abs(np.vdot(x, m)) / (np.vdot(x, x).real + np.vdot(m, m).real))
        out[pd.name] = {"pairs": pairs, "error": heldout_error(Hm - pd.H, pd.H),
                        "csac_mean": float(np.mean(csac)) if csac else None,
                        "csf_mean": float(np.mean(csf)) if csf else None}
    return out


# ----------------------------------------------------------------------------------------------
# the pipeline


class _Trials:
    """``trial(state, effect)`` for :func:`forward_select`, state = [(effect, params), ...]."""

    def __init__(self, poses: list[PoseData], candidates: list, progress=None, z_threshold: float = 0.0):
        self.poses, self.candidates, self.progress = poses, candidates, progress
        self.z_threshold = z_threshold
        self._screen: dict = {}

    def _diag(self, state):
        return diagnose(self.poses, state)

    def _starts(self, state, effect) -> list:
        current = [dict(p) for _, p in state]
        return [current + [g] for g in effect.guesses(self._diag(state))]

    def _full(self, state, effect):
        """Full-data fit of state + effect, cached per state."""
        key = (tuple((e.name, tuple(sorted(p.items()))) for e, p in state), effect.name)
        if key not in self._screen:
            starts = self._starts(state, effect)
            if not starts:
                self._screen[key] = None
            else:
                effs = [e for e, _ in state] + [effect]
                params, chi2, cov = fit(self.poses, [], effs, starts)
                self._screen[key] = (params, chi2, cov)
        return self._screen[key]

    def _shortlisted(self, state, effect) -> bool:
        """Among the SHORTLIST best training fits, and a training gain that could pass the test.

        With whitened residuals the gain of a least-squares fit is ``X2_0 - X2_1 ~ sum|d|^2`` and
        the held-out z is about ``gain / sqrt(2 sum|d|^2) = sqrt(gain / 2)``; held-out gains are
        smaller than training gains, so a candidate with ``sqrt(gain / 2) < z_thr / 2`` cannot pass
        and is not refitted fold by fold."""
        fits = {c.name: self._full(state, c) for c in self.candidates
                if c.repeatable or c.name not in {e.name for e, _ in state}}
        ranked = sorted((v[1], k) for k, v in fits.items() if v is not None)
        if effect.name not in [k for _, k in ranked[:SHORTLIST]]:
            return False
        gain = self._chi2(state) - fits[effect.name][1]
        return gain > 0 and math.sqrt(gain / 2) >= 0.5 * self.z_threshold

    def _chi2(self, state) -> float:
        r = _whitened(self.poses, list(state))
        return float(r @ r)

    def heldout(self, state_params: list, refit: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        res, meas, sig = [], [], []
        for i, pd in enumerate(self.poses):
            params = state_params
            if refit:
                train = [p for j, p in enumerate(self.poses) if j != i]
                params, _, _ = fit(train, [], [e for e, _ in state_params], [[dict(p) for _, p in state_params]])
            res.append(predict(pd, params) - pd.H)
            meas.append(pd.H)
            sig.append(pd.sigma)
        return np.concatenate(res), np.concatenate(meas), np.concatenate(sig)

    def drop(self, state, k: int) -> list:
        """``state`` without its ``k``-th effect, the others refitted jointly on all the data."""
        rest = [x for j, x in enumerate(state) if j != k]
        if not rest:
            return []
        params, _, _ = fit(self.poses, [], [e for e, _ in rest], [[dict(p) for _, p in rest]])
        return params

    def __call__(self, state, effect) -> Trial:
        state = list(state or [])
        if effect is None:
            r, m, s = self.heldout(state, refit=bool(state))
            return Trial(r, m, s, state=state)
        full = self._full(state, effect)
        if full is None or not self._shortlisted(state, effect):
            r, m, s = self.heldout(state, refit=bool(state))
            return Trial(r, m, s, state=state, evidence={"screened_out": True})
        params, chi2, cov = full
        if self.progress:
            self.progress(f"leave-one-pose-out: {effect.name}")
        r, m, s = self.heldout(params, refit=True)
        unc = _uncertainty(params[-1:], _layout([effect]), cov[-len(effect.parameters):, -len(effect.parameters):])
        diag = self._diag(state)
        ev = {"signatures": list(effect.signatures), "training_chi2": chi2,
              "per_pose_heldout_error": {pd.name: heldout_error(r[k], m[k]) for pd, k in
                                         zip(self.poses, _splits(self.poses))}}
        limits = effect.detect_limits(self.poses)
        if limits:
            ev["detect"] = limits
        if isinstance(effect, TcpModeEffect):
            ev["extra_peak_hz"] = diag["extra_peak_hz"]
            ev["extra_peak_in_every_pose"] = diag["extra_peak_in_every_pose"]
            ev["direction_tcp"] = effect.direction_tcp(params[-1][1])
        if isinstance(effect, ServoEffect):   # the element's SI values (what the model TOML gets)
            J, kp, kd = effect.physical(float(self.poses[0].pm.joint_k[effect.joint - 1]), params[-1][1])
            ev["servo_drive"] = {"rotor_inertia_kg_m2": J, "kp_n_m_per_rad": kp, "kd_n_m_s_per_rad": kd}
            ratio = rotor_inertia_ratio(self.poses, effect.joint, J)
            ev["rotor_to_link_inertia"] = ratio
            if ratio > MAX_ROTOR_RATIO:
                ev["not_credible_because"] = [f"rotor inertia {J:.3g} kg m^2 is {ratio:.3g}x the largest link-side "
                                              f"inertia of axis {effect.joint} over the poses (at most "
                                              f"{MAX_ROTOR_RATIO:g}x for a reflected rotor)"]
        return Trial(r, m, s, state=params, params=dict(params[-1][1]), uncertainty=unc, evidence=ev)


def rotor_inertia_ratio(poses: list[PoseData], joint: int, J: float) -> float:
    """A servo's rotor inertia ``J`` (kg m^2) over the largest link-side inertia of the axis over the
    poses (``M[i, i]`` of the linearized model, kg m^2)."""
    link = max(float(pd.pm.M[pd.pm.motion_dofs[joint - 1], pd.pm.motion_dofs[joint - 1]]) for pd in poses)
    return float(J / link) if link > 0 else math.inf


def _splits(poses):
    out, k = [], 0
    for pd in poses:
        out.append(slice(k, k + len(pd.H)))
        k += len(pd.H)
    return out


def identify_frf(measurement: FRFSet, model: ModelState, *, alpha: float = 0.01, max_effects: int = 3,
                 progress: Callable[[str], None] | None = None, poles: bool = True,
                 effects=None) -> Identification:
    """Identify structural effects from a tool-tip FRF set (see the module doc).

    ``poles``: also fit the measurement's poles (LSCF/LSFD, :mod:`identify.modal`) and set them beside
    the model's, before and after (a few seconds per pose). ``effects``: the candidate
    :class:`Effect` s (default: the library's default candidates, ``effects_for("frf", model)``).
    """
    from robolobes.core.errors import BadInput

    from .model_toml import model_toml

    if measurement.n_lines > MAX_LINES:
        raise BadInput(f"{measurement.path}: {measurement.n_lines} FRF lines; at most {MAX_LINES} (run time and "
                       "memory grow with it): decimate the frequency axis or measure fewer pairs")
    if len(measurement.poses) < 2:
        raise BadInput(f"{measurement.path}: leave-one-pose-out needs at least 2 poses with data, "
                       f"got {len(measurement.poses)}")
    chosen = effects_for("frf", model) if effects is None else list(effects)
    candidates = [e for e in chosen if isinstance(e, StructuralEffect)]
    from .chain_effects import check_driving_points
    check_driving_points(measurement, candidates)
    poses = prepare(measurement, model, progress)
    from .evidence import accept
    from .selection import stepwise_select, z_threshold
    n_tests = 2 * max(1, max_effects) * max(1, len(candidates))
    trials = _Trials(poses, candidates, progress, z_threshold(alpha, n_tests))
    sel = stepwise_select([], candidates, trials, alpha=alpha, max_effects=max_effects, progress=progress,
                          repeatable=lambda c: c.repeatable, drop=trials.drop, accept=accept,
                          params_of=lambda st, k: st[k][1])
    final = list(sel.state)
    floor, sig_r = noise_floor(poses, sel.final.residual)
    verdict = _unexplained(poses, sel.final.residual, sig_r, floor, sel.error_after, alpha, final)
    fits = final_effects(poses, final, sel.effects, surrogate=verdict["unexplained"])
    state = model
    for eff, params in final:
        state = eff.apply(state, params)
    extra = {"n_poses": len(poses), "n_lines": int(sum(len(pd.H) for pd in poses)),
             "correlation_before": correlation(poses, []), "correlation_after": correlation(poses, final),
             "diagnosis": diagnose(poses, []), "n_candidates": len(candidates),
             "selection": {"rule": "forward-backward, joint refit, Bonferroni over 2 max_effects x candidates",
                           "n_tests": sel.n_tests, "z_threshold": sel.threshold},
             "noise_floor_estimator": "sqrt(mean sigma_p^2) / RMS |H_measured|, sigma_p from fourth differences of "
                                      "the final model's held-out residual (per pair sigma^2 = a mean5|H|^2 + b, median of "
                                      "|d|^2 / sigma^2 = ln 2 in each half of the pair's lines)"}
    if poles:
        from .modal import compare_poles
        if progress:
            progress("modal fit (LSCF/LSFD)")
        got = compare_poles(poses, {"before": [], "after": final}, extra["diagnosis"]["extra_peak_hz"])
        extra["poles_before"], extra["poles_after"] = got["before"], got["after"]
    res = Identification(kind="frf", effects=fits, error_before=sel.error_before, error_after=sel.error_after,
                         metric=METRIC, noise_floor=floor, steps=sel.steps, model_toml=model_toml(state), extra=extra,
                         unexplained=verdict)
    from .modal import _model_modes
    from .frf_signatures import frf_pose_residual, frf_signatures
    from .ranking import annotate
    detected = frf_signatures([frf_pose_residual(pd, predict(pd, []), _model_modes(pd, [])) for pd in poses],
                              alpha=alpha)
    return annotate(res, detected, candidates)


def final_effects(poses: list[PoseData], final: list, selected: tuple, surrogate: bool) -> tuple:
    """The selected :class:`EffectFit` s at the final joint fit: parameters, one sigma, ``credible``,
    ``determined`` (Fisher information of the joint fit, :func:`identify.evidence.determined`) and the
    quantities shared with indistinguishable alternatives."""
    from dataclasses import replace as _replace

    from .evidence import credibility, determined

    if not final:
        return ()
    effs = [e for e, _ in final]
    _, _, cov = fit(poses, [], effs, [[dict(p) for _, p in final]])
    layout = _layout(effs)
    out, k = [], 0
    for (eff, params), sel in zip(final, selected):
        n = len(eff.parameters)
        block = cov[k:k + n, k:k + n]
        unc = _uncertainty([(eff, params)], layout[k:k + n], block)
        ok, why = credibility(eff, params, sel.evidence.get("not_credible_because"))
        det = determined([(p.name, p) for p in eff.parameters], [params[p.name] for p in eff.parameters], block)
        shared = _shared(eff, params, block, sel.evidence.get("alternatives", []))
        if shared:
            det["shared"] = shared
        out.append(_replace(sel, params=dict(params), uncertainty=unc, credible=ok, not_credible_because=tuple(why),
                            determined=det, surrogate=bool(surrogate)))
        k += n
    return tuple(out)


def _shared(eff, params: dict, block: np.ndarray, alternatives: list) -> list:
    """What an effect and the alternatives the data cannot tell from it agree on: for a joint
    correction and a servo of the same axis, the axis's static stiffness scale (value, one sigma)."""
    from .effects import REGISTRY

    if not hasattr(eff, "static_stiffness_scale"):
        return []
    value = eff.static_stiffness_scale(params)
    if isinstance(eff, ServoEffect):   # kp_scale / (1 + kp_scale), kp_scale fitted in log: d/dln = kp/(1+kp)^2
        kp = params["kp_scale"]
        sd = kp / (1 + kp) ** 2 * math.sqrt(max(block[0, 0], 0.0))
    else:                               # stiffness_scale fitted in log
        sd = value * math.sqrt(max(block[0, 0], 0.0))
    same_axis = [a for a in alternatives if a["name"] in REGISTRY and getattr(REGISTRY[a["name"]], "joint", None)
                 == getattr(eff, "joint", -1) and hasattr(REGISTRY[a["name"]], "static_stiffness_scale")]
    if not same_axis:
        return []
    scaled: dict[str, Any] = {a["name"]: REGISTRY[a["name"]] for a in same_axis}  # each has static_stiffness_scale
    return [{"quantity": f"axis {eff.joint} static stiffness / joint table's", "value": value, "sd": float(sd),
             "indistinguishable_from": [{"name": a["name"],
                                         "value": scaled[a["name"]].static_stiffness_scale(a["params"])}
                                        for a in same_axis],
             "meaning": "below the rotor resonance a joint's stiffness and its servo's gain act in series and the "
                        "FRFs cannot tell them apart; only this combination is determined"}]


def _pair_label(pd: PoseData, k: int) -> str:
    def lab(v):
        i = int(np.argmax(np.abs(v)))
        return ("-" if v[i] < 0 else "") + "xyz"[i]
    return lab(pd.pair_out[k]) + lab(pd.pair_in[k])


#: Monte-Carlo draws of pure noise for the verdict's null distribution (seeded: the verdict is repeatable).
NULL_DRAWS = 100


def _null_whitened(poses: list[PoseData], sigma: np.ndarray, masks: list, draws: int = NULL_DRAWS) -> np.ndarray:
    """``W`` of pure complex noise of standard deviation ``sigma`` (N,) run through the same noise estimator
    (:func:`residual_sigma`), on every line and on each mask: (draws, 1 + len(masks))."""
    from .evidence import whitened_ratio

    rng = np.random.default_rng(0)
    out = np.empty((draws, 1 + len(masks)))
    for i in range(draws):
        r = sigma * (rng.standard_normal(len(sigma)) + 1j * rng.standard_normal(len(sigma))) / math.sqrt(2)
        s = residual_sigma(poses, r)
        out[i] = [whitened_ratio(r, s)] + [whitened_ratio(r[m], s[m]) for m in masks]
    return out


def _unexplained(poses: list[PoseData], residual: np.ndarray, sigma: np.ndarray, floor: float, error: float,
                 alpha: float, final: list) -> dict:
    """The verdict on the final residual (:func:`identify.evidence.whitened_unexplained`: each line's
    residual over its own noise, against Monte-Carlo draws of pure noise through the same estimator) and,
    when unexplained, where it is: poses, pairs, octave bands whose whitened ratio exceeds their own
    margin (Bonferroni over the parts tested), and the signatures of the final residual."""
    from .evidence import whitened_margin, whitened_ratio, whitened_unexplained

    parts = []   # (kind, label, mask)
    splits = _splits(poses)
    for pd, sl in zip(poses, splits):
        m = np.zeros(len(residual), bool)
        m[sl] = True
        parts.append(("poses", pd.name, m))
    labels = sorted({_pair_label(pd, int(k)) for pd in poses for k in np.unique(pd.pair)})
    pair_of = np.concatenate([[_pair_label(pd, int(k)) for k in pd.pair] for pd in poses])
    for lab in labels:
        parts.append(("pairs", lab, pair_of == lab))
    f = np.concatenate([pd.omega[pd.index] / (2 * math.pi) for pd in poses])
    lo = 2.0 ** np.floor(np.log2(max(f.min(), 1e-3)))
    while lo < f.max():
        m = (f >= lo) & (f < 2 * lo)
        if m.sum() >= 10:
            parts.append(("bands_hz", [float(lo), float(2 * lo)], m))
        lo *= 2
    null = _null_whitened(poses, sigma, [m for _, _, m in parts])
    out = whitened_unexplained(residual, sigma, floor, error, null[:, 0], alpha)
    where: dict = {"poses": [], "pairs": [], "bands_hz": []}
    n_parts = len(parts)
    for j, (kind, label, m) in enumerate(parts):
        ratio = whitened_ratio(residual[m], sigma[m])
        lim = whitened_margin(null[:, 1 + j], alpha / n_parts)
        if ratio > lim:
            where[kind].append({"name": label, "ratio_to_noise": ratio, "margin": lim})
    for v in where.values():
        v.sort(key=lambda x: -x["ratio_to_noise"])
    if out["unexplained"]:
        from .modal import _model_modes
        from .frf_signatures import frf_pose_residual, frf_signatures
        det = frf_signatures([frf_pose_residual(pd, predict(pd, final), _model_modes(pd, final)) for pd in poses],
                             alpha=alpha)
        where["signatures"] = [k for k, v in det.items() if v.present]
    out["where"] = where
    return out
