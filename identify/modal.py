"""Modal fit of a measurement (sdypy-EMA's LSCF poles, LSFD constants) beside the model's poles.

Per pose: the measured pairs on the pose's common lines go to ``sdypy.EMA.Model`` as arrays (its
``read_uff`` breaks on single-set files), in receptance form; LSCF poles are computed up to
``POLE_ORDER`` and the stable poles closest to the model's natural frequencies (and to the extra
peak diagnosis found) are kept, then LSFD gives the constants. The comparison reports, per model
mode, the measured frequency and damping, the relative frequency shift and the damping error; over
the poses, the mean and spread of each mode's shift tell a uniform shift (mass, global stiffness)
from a pose-dependent one (a joint), and a measured pole with no model pole within 5 % is extra.
"""

from __future__ import annotations

import contextlib
import io
import math
import warnings

import numpy as np

__all__ = ["pose_poles", "compare_poles", "POLE_ORDER"]

POLE_ORDER = 30


def _model_modes(pd, effects):
    from robolobes.linearize.linear import modal_analysis

    pm = pd.pm
    for eff, params in effects:
        pm = eff.perturb(pm, params)
    m = modal_analysis(pm.M, pm.C, pm.K, pm.J)
    keep = (m.damping_ratio < 0.5) & (m.freq_hz > 0)
    return m.freq_hz[keep], m.damping_ratio[keep]


def pose_poles(pd, approx_hz) -> tuple[np.ndarray, np.ndarray] | None:
    """Measured natural frequencies (Hz) and damping ratios near ``approx_hz`` at one pose, or None."""
    import sdypy.EMA as EMA

    pairs = np.unique(pd.pair)
    idx = [pd.index[pd.pair == k] for k in pairs]
    if any(not np.array_equal(i, idx[0]) for i in idx):
        return None           # pairs on different lines: not one EMA model
    f = pd.omega[pd.index[pd.pair == pairs[0]]] / (2 * math.pi)
    frf = np.array([pd.H[pd.pair == k] for k in pairs])
    lo, hi = max(f[0], f[1] * 0.5), f[-2]
    approx = [a for a in approx_hz if lo < a < hi]
    if not approx:
        return None
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()), \
            warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = EMA.Model(frf=frf, freq=f, lower=lo, upper=hi, pol_order_high=POLE_ORDER, frf_form="receptance")
        m.get_poles("lscf", show_progress=False)
        m.select_closest_poles(list(approx), f_window=max(2.0, 0.1 * min(approx)))  # type: ignore[arg-type]  # sdypy types f_window int; it is a band in Hz, a float
        m.get_constants(method="lsfd")
    return np.asarray(m.nat_freq, dtype=float), np.asarray(m.nat_xi, dtype=float)


def _rows(fm, zm, fx, zx, shifts):
    rows = []
    for k, (f0, z0) in enumerate(zip(fm, zm)):
        j = int(np.argmin(np.abs(fx - f0))) if len(fx) else None
        if j is None or abs(fx[j] / f0 - 1) > 0.2:
            rows.append({"model_freq_hz": f0, "model_damping": z0, "measured_freq_hz": None})
            continue
        rows.append({"model_freq_hz": f0, "model_damping": z0, "measured_freq_hz": fx[j],
                     "measured_damping": zx[j], "shift": fx[j] / f0 - 1, "damping_error": zx[j] / z0 - 1})
        shifts.setdefault(k, []).append(fx[j] / f0 - 1)
    return rows


def compare_poles(poses, models: dict, extra_hz: float | None = None) -> dict:
    """Measured poles (fitted once per pose) beside each model's: ``models`` = {label: effects}.

    Returns, per label, per pose the rows (model and measured frequency, damping, shift) and the
    measured poles with no model pole within 5 %, and per mode the mean and spread of the shift over
    the poses (JSON-ready).
    """
    out: dict[str, dict] = {label: {"per_pose": {}, "shifts": {}} for label in models}
    shifts = {label: {} for label in models}
    for pd in poses:
        modal = {label: _model_modes(pd, eff) for label, eff in models.items()}
        approx = sorted(set(np.concatenate([fm for fm, _ in modal.values()]).round(3)) | ({extra_hz} if extra_hz else set()))
        try:
            got = pose_poles(pd, approx)
        except Exception as e:  # sdypy fails on degenerate data: report it, identification goes on
            for label in models:
                out[label]["per_pose"][pd.name] = {"error": f"modal fit failed: {e}"}
            continue
        if got is None:
            continue
        fx, zx = got
        for label, (fm, zm) in modal.items():
            extra = [float(f) for f in fx if np.all(np.abs(f / fm - 1) > 0.05)]
            out[label]["per_pose"][pd.name] = {"modes": _rows(fm, zm, fx, zx, shifts[label]), "extra_poles_hz": extra}
    for label in models:
        out[label]["shifts"] = {f"mode_{k + 1}": {"mean_shift": float(np.mean(v)), "shift_spread": float(np.std(v)),
                                                  "n_poses": len(v)} for k, v in shifts[label].items()}
        out[label]["method"] = f"sdypy-EMA LSCF (order {POLE_ORDER}) + LSFD"
    return out
