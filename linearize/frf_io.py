"""Read and write tool-tip FRFs: CSV and Universal File Format dataset 58 (via pyuff), Bode plots.

CSV layout (one header line, then one row per frequency)::

    freq_hz, H_<out>_<in>_re, H_<out>_<in>_im, ...       receptance in m/N

UFF58: one dataset per (output, input) pair, function type 4 (FRF), ordinate displacement
(type 8) over force (13), node 1, directions +1/+2/+3 for the frame's x/y/z axes, evenly spaced
frequencies in Hz (UFF's own unit), complex128 data. pyuff is used because UFF is a fixed-column
legacy format with many flags; a hand-written writer would be long and easy to get subtly wrong.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from robolobes.core.io import atomic_path, provenance_text, pyplot, save_figure
from .linear import FRF

__all__ = ["write_frf", "read_frf", "plot_bode"]

_FMT = {".csv": "csv", ".uff": "uff", ".unv": "uff"}


def _fmt(path: Path) -> str:
    try:
        return _FMT[path.suffix.lower()]
    except KeyError:
        raise ValueError(f"FRF file {path} must end in .csv, .uff or .unv (UFF58)") from None


def write_frf(frf: FRF, path: str | Path, provenance: dict | None = None) -> Path:
    """Write an FRF to ``path`` (format from the suffix), atomically. Returns the path.

    ``provenance`` (``core.io.provenance(inputs)``) is recorded in the CSV's first header line or
    in the UFF58 id4 / id5 lines (80 characters each)."""
    path = Path(path)
    fmt = _fmt(path)
    H = np.asarray(frf.H)
    n_out, n_in, nf = H.shape
    with atomic_path(path) as tmp:
        if fmt == "csv":
            cols = [np.asarray(frf.freq_hz)]
            names = ["freq_hz"]
            for i in range(n_out):
                for j in range(n_in):
                    cols += [H[i, j].real, H[i, j].imag]
                    names += [f"H_{frf.labels[i]}_{frf.labels[j]}_re_m_per_n", f"H_{frf.labels[i]}_{frf.labels[j]}_im_m_per_n"]
            header = f"# tool-tip receptance (m/N), frame {frf.frame}, axes rows (base coords): " + \
                     "; ".join(" ".join(f"{v:.12g}" for v in row) for row in np.asarray(frf.axes)) + \
                     (f"; {provenance_text(provenance)}" if provenance else "") + "\n" + ",".join(names)
            np.savetxt(tmp, np.column_stack(cols), delimiter=",", header=header, comments="", fmt="%.12e")
        else:
            import pyuff
            f = np.asarray(frf.freq_hz)
            if nf < 2:
                raise ValueError("UFF58 export needs at least 2 frequencies")
            df = np.diff(f)
            if not np.allclose(df, df[0], rtol=1e-9, atol=0):
                raise ValueError("UFF58 export needs evenly spaced frequencies (pyuff writes uneven ones "
                                 "with 6 significant digits); use a linear frequency grid or CSV")
            tmp.unlink()  # pyuff appends; start from no file
            uff = pyuff.UFF(str(tmp))
            sets = []
            for i in range(n_out):
                for j in range(n_in):
                    sets.append(pyuff.prepare_58(
                        binary=0, id1=f"robolobes receptance H_{frf.labels[i]}_{frf.labels[j]}",
                        id2=f"frame {frf.frame}", func_type=4, **_uff_ids(provenance), rsp_node=1, rsp_dir=i + 1, ref_node=1,
                        ref_dir=j + 1, ord_data_type=6, num_pts=nf, abscissa_spacing=1,
                        abscissa_min=float(f[0]), abscissa_inc=float(df[0]), abscissa_spec_data_type=18,
                        ordinate_spec_data_type=8, orddenom_spec_data_type=13,
                        data=np.ascontiguousarray(H[i, j], dtype=np.complex128), x=f))
            uff.write_sets(sets, mode="add")
    return path


def _uff_ids(provenance: dict | None) -> dict:
    if not provenance:
        return {}
    return {"id4": f"robolobes_version={provenance['robolobes_version']}",
            "id5": f"inputs_sha256={provenance['inputs_sha256']}"}


def read_frf(path: str | Path, frame: str = "base") -> FRF:
    """Read an FRF written by :func:`write_frf` (CSV or UFF58). Shape (n_out, n_in, F)."""
    path = Path(path)
    fmt = _fmt(path)
    if fmt == "csv":
        with open(path) as fh:
            first = fh.readline()
            names = fh.readline().strip().split(",")
        data = np.loadtxt(path, delimiter=",", skiprows=2)
        f = data[:, 0]
        n = int(round(math.sqrt((len(names) - 1) / 2)))
        H = (data[:, 1::2] + 1j * data[:, 2::2]).T.reshape(n, n, -1)
        labels = tuple(names[1 + 2 * i].split("_")[2] for i in range(0, n * n, n))
    else:
        import pyuff
        sets = pyuff.UFF(str(path)).read_sets()
        sets = [sets] if isinstance(sets, dict) else sets
        sets = [s for s in sets if s.get("type") == 58]
        n = int(round(math.sqrt(len(sets))))
        f = np.asarray(sets[0]["x"], dtype=float)
        H = np.zeros((n, n, len(f)), dtype=complex)
        for s in sets:
            H[abs(int(s["rsp_dir"])) - 1, abs(int(s["ref_dir"])) - 1] = s["data"]
        labels = ("x", "y", "z")[:n]
    if not np.all(np.isfinite(f)) or not np.all(np.isfinite(H)):
        raise ValueError(f"{path}: NaN or inf in the FRF data")
    return FRF(omega=2 * math.pi * f, H=H, frame=frame, axes=np.eye(3), labels=labels)


def plot_bode(frf: FRF, path: str | Path, title: str = "", provenance: dict | None = None) -> Path:
    """Bode plot (magnitude in um/N, phase in deg) of the direct and cross terms, saved atomically."""
    plt = pyplot()

    H = np.asarray(frf.H)
    f = frf.freq_hz
    fig, (ax1, ax2) = plt.subplots(2, 1, sharex=True, figsize=(7.5, 6))
    n = H.shape[0]
    for i in range(n):
        for j in range(i, n):
            style = "-" if i == j else ":"
            lab = f"H{frf.labels[i]}{frf.labels[j]}"
            ax1.semilogy(f, np.abs(H[i, j]) * 1e6, style, label=lab)
            ax2.plot(f, np.degrees(np.angle(H[i, j])), style)
    ax1.set_ylabel("|H| (um/N)")
    ax1.legend(ncol=3, fontsize=8)
    ax1.grid(True, which="both", alpha=0.3)
    ax2.set_ylabel("phase (deg)")
    ax2.set_xlabel("frequency (Hz)")
    ax2.grid(True, alpha=0.3)
    ax1.set_title(title or f"tool-tip receptance, {frf.frame} frame")
    fig.tight_layout()
    save_figure(fig, path, provenance=provenance, dpi=120)
    plt.close(fig)
    return Path(path)
