"""Synthetic measurement sets for tests and benchmarks: the project's model plus undeclared elements.

The FRFs come from the full model path (pinocchio model built with the extra
:mod:`robolobes.linearize.extra_elements`, linearized at the static equilibrium, direct solve),
not from identification's fast perturbations, and are written as UFF58 files with pyuff (each
pair one dataset, ``id1`` naming the pose), so that reading, conversion and identification are all
exercised. Noise: complex Gaussian, relative (``rel_noise`` x |H| per line) plus additive
(``add_noise`` x RMS |H| of the pair), fixed seed.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from robolobes.core.errors import BadInput
from robolobes.linearize.linear import FrameName

__all__ = ["POSE_OFFSETS_DEG", "PAIRS", "synthetic_frf_set", "write_uff_pairs", "truth_errors"]

# motor-angle offsets from the case's start pose (deg): reachable, within the joint ranges (the
# start pose's A3 is 2.86 deg past +145 deg, so A3 only moves back into its range: identify refuses
# a pose more than 5 deg past a limit, as every command does)
POSE_OFFSETS_DEG = np.array([[0, 0, 0, 0, 0, 0], [15, 5, -5, 0, 10, 0], [-15, -5, -8, 10, -10, 20],
                             [30, 8, -10, -20, 5, -30], [-30, 10, -5, 15, 15, 10], [10, -8, -12, -10, -5, -15]],
                            dtype=float)
PAIRS = ((0, 0), (1, 1), (2, 2), (0, 1))  # (out, in) axes: xx, yy, zz, xy


def write_uff_pairs(path: Path, pose: str, f_hz: np.ndarray, pairs, H: np.ndarray, *, frame: str = "base",
                    ordinate: int = 8, units: str = "m") -> None:
    """One UFF58 dataset per pair: ``H[k]`` (F,) receptance in m/N, written as ordinate type
    ``ordinate`` (8 receptance, 11 mobility, 12 accelerance) in ``units``."""
    import pyuff

    scale = {"m": 1.0, "mm": 1e3, "m/s": 1.0, "mm/s": 1e3, "m/s^2": 1.0, "g": 1 / 9.80665}[units]
    w = 2 * math.pi * f_hz
    conv = {8: 1.0, 11: 1j * w, 12: -w ** 2}[ordinate]
    df = np.diff(f_hz)
    if path.exists():
        raise BadInput(f"{path} exists")
    uff = pyuff.UFF(str(path))
    sets = []
    for (o, i), h in zip(pairs, H):
        sets.append(pyuff.prepare_58(
            binary=0, id1=f"pose {pose}", id2=f"frame {frame}", func_type=4, rsp_node=1, rsp_dir=o + 1, ref_node=1,
            ref_dir=i + 1, ord_data_type=6, num_pts=len(f_hz), abscissa_spacing=1, abscissa_min=float(f_hz[0]),
            abscissa_inc=float(df[0]), abscissa_spec_data_type=18, ordinate_spec_data_type=ordinate,
            ordinate_axis_units_lab=units, orddenom_spec_data_type=13, orddenom_axis_units_lab="N",
            data=np.ascontiguousarray(h * conv * scale, dtype=np.complex128), x=f_hz))
    uff.write_sets(sets, mode="add")


def synthetic_frf_set(directory, case, *, variant: str = "basic", elements=(), n_poses: int = 4,
                      pairs=PAIRS, f_hz=None, rel_noise: float = 0.02, add_noise: float = 0.02, seed: int = 0,
                      ordinate: int = 8, frame: FrameName = "base", offsets_deg=None) -> dict:
    """Write ``poses.csv`` and ``p<k>.uff`` into the new ``directory``; return the truth.

    ``frame``: the axes of the written FRFs (``"base"`` or ``"cut"``, the case's feed direction).
    ``offsets_deg``: (n_poses, 6) motor-angle offsets from the case's start pose (default
    :data:`POSE_OFFSETS_DEG`).

    Returns
    -------
    dict with ``H_true`` (per pose, (n_pairs, F) noiseless with the elements), ``H_base`` (the same
    without them), ``H_meas`` (with noise), ``f_hz``.
    """
    from robolobes.linearize import build_model, linearize

    d = Path(directory)
    d.mkdir(parents=False, exist_ok=False)
    f_hz = np.linspace(2.0, 300.0, 600) if f_hz is None else np.asarray(f_hz, dtype=float)
    w = 2 * math.pi * f_hz
    rng = np.random.default_rng(seed)
    truth = build_model(case.robot, variant, extra_elements=tuple(elements))
    base = build_model(case.robot, variant)
    q0 = np.degrees(case.path.start_q_rad)
    lines = ["pose," + ",".join(f"q{i + 1}_deg" for i in range(6)) + ",case"]
    out = {"H_true": [], "H_base": [], "H_meas": [], "f_hz": f_hz}
    offsets = POSE_OFFSETS_DEG if offsets_deg is None else np.asarray(offsets_deg, dtype=float)
    for k in range(n_poses):
        q = q0 + offsets[k]
        lines.append(f"p{k}," + ",".join(f"{v:.12g}" for v in q) + f",{case.name}")
        fd = case.cut.feed_direction
        Ht = linearize(truth, np.radians(q)).frf(w, frame=frame, feed_direction=fd).H
        Hb = linearize(base, np.radians(q)).frf(w, frame=frame, feed_direction=fd).H
        ht = np.array([Ht[o, i] for o, i in pairs])
        hb = np.array([Hb[o, i] for o, i in pairs])
        cn = lambda: (rng.standard_normal(ht.shape) + 1j * rng.standard_normal(ht.shape)) / math.sqrt(2)
        rms = np.sqrt(np.mean(np.abs(ht) ** 2, axis=1, keepdims=True))
        hm = ht + rel_noise * np.abs(ht) * cn() + add_noise * rms * cn()
        write_uff_pairs(d / f"p{k}.uff", f"p{k}", f_hz, pairs, hm, ordinate=ordinate, frame=frame,
                        units={8: "m", 11: "m/s", 12: "m/s^2"}[ordinate])
        out["H_true"].append(ht)
        out["H_base"].append(hb)
        out["H_meas"].append(hm)
    (d / "poses.csv").write_text("\n".join(lines) + "\n")
    return out


def truth_errors(truth: dict) -> tuple[float, float]:
    """For a set written by :func:`synthetic_frf_set` (its returned ``truth``): the error of the
    generating model on the data (the noise alone) and the undeclared elements' own size (model
    with them minus model without), both RMS over all lines divided by RMS |H_meas|."""
    meas = np.concatenate([h.ravel() for h in truth["H_meas"]])
    true = np.concatenate([h.ravel() for h in truth["H_true"]])
    base = np.concatenate([h.ravel() for h in truth["H_base"]])
    den = np.sqrt(np.mean(np.abs(meas) ** 2))
    return (float(np.sqrt(np.mean(np.abs(true - meas) ** 2)) / den),
            float(np.sqrt(np.mean(np.abs(true - base) ** 2)) / den))
