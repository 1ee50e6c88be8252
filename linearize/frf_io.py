"""Read and write tool-tip FRFs: CSV and Universal File Format dataset 58 (via pyuff), Bode plots.

CSV layout (one header line, then one row per frequency)::

    freq_hz, H_<out>_<in>_re, H_<out>_<in>_im, ...       receptance in m/N

UFF58: one dataset per (output, input) pair, function type 4 (FRF), ordinate displacement
(type 8) over force (13), node 1, directions +1/+2/+3 for the frame's x/y/z axes, evenly spaced
frequencies in Hz (UFF's own unit), complex128 data. pyuff is used because UFF is a fixed-column
legacy format with many flags; a hand-written writer would be long and easy to get subtly wrong.

Measured FRF sets (``robolobes identify``): a directory with ``poses.csv``
(``pose,q1_deg,...,q6_deg``, optional ``case`` column) and one file per pose, ``<pose>.uff|.unv``
or ``<pose>.csv``; a UFF dataset whose ``id1`` holds ``pose <name>`` (or ``pose=<name>``) belongs
to that pose whatever the file is called. Read by :func:`read_frf_set`:

* UFF58 ordinate types 8 (displacement), 11 (velocity), 12 (acceleration) over force (13), in the
  units of ``ordinate_axis_units_lab`` (m, mm, um; m/s, mm/s; m/s^2, mm/s^2, g; ``NONE`` = SI)
  and ``orddenom_axis_units_lab`` (N, kN; ``NONE`` = N), converted to receptance in m/N
  (``H_x = H_v / (i w) = -H_a / w^2``; lines at 0 Hz of mobility or accelerance are dropped);
* directions ``rsp_dir`` / ``ref_dir`` = +-1, 2, 3 for the frame's x, y, z, sign kept; the frame
  from ``id2`` (``frame base`` or ``frame cut``), base by default;
* CSV: the columns :func:`write_frf` writes (any subset of the pairs), frame from the header;
* any subset of the pairs, and poses (even pairs) with different frequency axes;
* the response channel of each pair (:attr:`MeasuredPair.channel`): one channel per response
  direction (the sensor along the frame's x, y or z), the default for both formats.

Bad input raises :class:`~robolobes.core.errors.BadInput` naming the file and the value: NaN,
a frequency axis not increasing, a pose not in ``poses.csv``, unknown ordinate types, units or
directions. A file is read completely or refused: an empty file, one that is not text (binary
bytes, UTF-16), one whose datasets are not closed by their ``-1`` delimiter (truncated), one with
fewer values than its ``num_pts``, one with no dataset 58, or with a units dataset 164 other than
SI is an error naming it (other datasets, such as 151 headers or geometry, are skipped); so are an FRF that is zero at every line, a
pair measured twice for one pose, and a dataset labelled with another pose inside a file named
after a pose of ``poses.csv``. ``poses.csv`` (UTF-8, a byte-order mark accepted) must have the
columns ``pose`` and ``q1_deg`` .. ``q6_deg``.
"""

from __future__ import annotations

import csv
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from robolobes.core.errors import BadInput
from robolobes.core.io import atomic_path, provenance_text, pyplot, save_figure
from .linear import FRF

__all__ = ["write_frf", "read_frf", "plot_bode", "MeasuredPair", "PoseFRF", "FRFSet", "read_frf_set",
           "write_frf_set", "G_M_PER_S2", "ToolFRF", "read_tool_frf", "parse_frf_axes", "tool_frf_files"]

G_M_PER_S2 = 9.80665  # standard gravity, for accelerances in g
#: motor angles per pose in ``poses.csv`` (the six-axis arm)
N_JOINTS = 6

_FMT = {".csv": "csv", ".uff": "uff", ".unv": "uff"}


def _fmt(path: Path) -> str:
    try:
        return _FMT[path.suffix.lower()]
    except KeyError:
        raise BadInput(f"FRF file {path} must end in .csv, .uff or .unv (UFF58)") from None


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
                raise BadInput("UFF58 export needs at least 2 frequencies")
            df = np.diff(f)
            if not np.allclose(df, df[0], rtol=1e-9, atol=0):
                raise BadInput("UFF58 export needs evenly spaced frequencies (pyuff writes uneven ones "
                                 "with 6 significant digits); use a linear frequency grid or CSV")
            tmp.unlink()  # pyuff appends; start from no file
            uff = pyuff.UFF(str(tmp))
            sets = []
            for i in range(n_out):
                for j in range(n_in):
                    sets.append(pyuff.prepare_58(
                        binary=0, id1=f"robolobes receptance H_{frf.labels[i]}_{frf.labels[j]}",
                        id2=f"frame {frf.frame}", func_type=4, **_uff_ids(provenance), ordinate_axis_units_lab="m",
                        orddenom_axis_units_lab="N", rsp_node=1, rsp_dir=i + 1, ref_node=1,
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


def read_frf(path: str | Path, frame: str | None = None) -> FRF:
    """Read an FRF written by :func:`write_frf` (CSV or UFF58), shape (n_out, n_in, F), m/N.

    The frame is the file's (``frame`` overrides it). Every pair of the square matrix must be
    present on one frequency axis; for subsets and other ordinate types see :func:`read_frf_set`.
    """
    path = Path(path)
    file_frame, pairs = _read_pairs(path)
    if not pairs:
        raise BadInput(f"{path}: no FRF data")
    n = int(round(math.sqrt(len(pairs))))
    omega = pairs[0].omega
    H = np.zeros((n, n, len(omega)), dtype=complex)
    seen = set()
    for p in pairs:
        if p.out_axis >= n or p.in_axis >= n or len(p.omega) != len(omega) or not np.allclose(p.omega, omega):
            raise BadInput(f"{path}: not a full square FRF matrix on one frequency axis; use read_frf_set")
        H[p.out_axis, p.in_axis] = p.out_sign * p.in_sign * p.H
        seen.add((p.out_axis, p.in_axis))
    if len(seen) != n * n:
        raise BadInput(f"{path}: pairs {sorted(seen)} do not form a full {n} x {n} matrix; use read_frf_set")
    frame = frame or file_frame
    labels = ("x", "y", "z")[:n] if frame == "base" else ("feed", "normal", "axial")[:n]
    return FRF(omega=omega, H=H, frame=frame, axes=np.eye(3), labels=labels)


# ----------------------------------------------------------------------------------------------
# measured sets


@dataclass(frozen=True)
class MeasuredPair:
    """One measured FRF: response along ``out_sign`` x axis ``out_axis`` per force along ``in_sign`` x ``in_axis``.

    Attributes
    ----------
    out_axis, in_axis : int
        0, 1, 2 = the frame's x, y, z (cut frame: feed, normal, axial).
    out_sign, in_sign : {+1, -1}
    omega : array (F,), rad/s, increasing
    H : complex array (F,), m/N: the receptance as measured along the signed directions, i.e.
        ``out_sign * in_sign * H_frame[out_axis, in_axis]``.
    channel : int
        The response channel (sensor) that measured it, 0, 1, 2 = the frame's x, y, z: what a
        calibration scale of the measurement chain belongs to (``identify.chain_effects``). Default
        (None): one channel per response direction, ``out_axis`` (a triaxial accelerometer, or one
        sensor per axis); the readers set that default.
    """

    out_axis: int
    out_sign: int
    in_axis: int
    in_sign: int
    omega: np.ndarray
    H: np.ndarray
    channel: int | None = None

    def __post_init__(self) -> None:
        if self.channel is None:
            object.__setattr__(self, "channel", int(self.out_axis))
        elif isinstance(self.channel, bool) or not isinstance(self.channel, int) or not 0 <= self.channel <= 2:
            raise BadInput(f"response channel {self.channel!r}; valid: 0, 1, 2 (the frame's x, y, z)")

    @property
    def response_channel(self) -> int:
        """:attr:`channel` as an int (set by ``__post_init__``)."""
        return int(self.out_axis if self.channel is None else self.channel)


@dataclass(frozen=True)
class PoseFRF:
    """The pairs measured at one pose.

    Attributes
    ----------
    pose : str
    theta : array (n_joints,), rad     commanded motor angles (``poses.csv``)
    frame : {"base", "cut"}
    pairs : tuple of MeasuredPair
    """

    pose: str
    theta: np.ndarray
    frame: str
    pairs: tuple


@dataclass(frozen=True)
class FRFSet:
    """A tool-tip FRF measurement set (``kind = "frf"``)."""

    path: Path
    poses: tuple
    case: str | None = None
    variant: str | None = None
    kind: str = "frf"

    @property
    def n_lines(self) -> int:
        return sum(len(p.omega) for pf in self.poses for p in pf.pairs)


_LEN = {"m": 1.0, "mm": 1e-3, "um": 1e-6, "µm": 1e-6, "none": 1.0, "": 1.0}
_UNITS = {8: _LEN,
          11: {"m/s": 1.0, "mm/s": 1e-3, "none": 1.0, "": 1.0},
          12: {"m/s^2": 1.0, "m/s2": 1.0, "m/s**2": 1.0, "mm/s^2": 1e-3, "g": G_M_PER_S2, "none": 1.0, "": 1.0}}
_FORCE = {"n": 1.0, "kn": 1e3, "none": 1.0, "": 1.0}
_POSE_RE = re.compile(r"\bpose\s*[=:]?\s*([A-Za-z0-9_.+-]+)")
_FRAME_RE = re.compile(r"\bframe\s*[=:]?\s*([A-Za-z]+)")


def _frame_of(text: str, where: str) -> str:
    m = _FRAME_RE.search(text or "")
    if not m:
        return "base"
    fr = m.group(1).lower()
    if fr not in ("base", "cut"):
        raise BadInput(f"{where}: frame {m.group(1)!r}; valid: base, cut")
    return fr


def _check_axis(f_hz, H, where: str) -> None:
    if len(f_hz) < 2:
        raise BadInput(f"{where}: needs at least 2 frequency lines, got {len(f_hz)}")
    if not np.all(np.isfinite(f_hz)) or not np.all(np.isfinite(H)):
        raise BadInput(f"{where}: NaN or inf in the frequencies or the FRF values")
    if not np.any(H):
        raise BadInput(f"{where}: the FRF is zero at every line; a measured FRF is not (an empty or "
                       "failed channel?)")
    if np.any(np.diff(f_hz) <= 0) or f_hz[0] < 0:
        i = int(np.argmax(np.diff(f_hz) <= 0)) if np.any(np.diff(f_hz) <= 0) else 0
        raise BadInput(f"{where}: the frequency axis must be >= 0 and increasing; it is not at line {i} "
                       f"({f_hz[i]:g} Hz)")


def _dir(code, where: str, which: str) -> tuple[int, int]:
    try:
        c = int(code)
    except (TypeError, ValueError):
        c = 0
    if abs(c) not in (1, 2, 3):
        raise BadInput(f"{where}: {which} = {code!r}; valid: +-1, +-2, +-3 (x, y, z translations)")
    return abs(c) - 1, 1 if c > 0 else -1


def _to_receptance(f_hz, H, ordinate: int, units: str, denom: str, where: str):
    """Convert a UFF ordinate (8/11/12 over force) in its units to receptance in m/N; drop 0 Hz lines
    that cannot be converted. Returns (f_hz, H)."""
    table = _UNITS.get(ordinate)
    if table is None:
        raise BadInput(f"{where}: ordinate_spec_data_type = {ordinate}; valid: 8 (displacement), 11 (velocity), "
                       "12 (acceleration) over force")
    u = (units or "").strip().lower()
    if u not in table:
        raise BadInput(f"{where}: ordinate unit {units!r} for type {ordinate}; valid: "
                       f"{', '.join(k for k in table if k)} (or NONE = SI)")
    d = (denom or "").strip().lower()
    if d not in _FORCE:
        raise BadInput(f"{where}: force unit {denom!r}; valid: N, kN (or NONE = N)")
    H = np.asarray(H, dtype=complex) * table[u] / _FORCE[d]
    if ordinate == 8:
        return f_hz, H
    keep = f_hz > 0
    f_hz, H = f_hz[keep], H[keep]
    w = 2 * math.pi * f_hz
    return f_hz, (H / (1j * w) if ordinate == 11 else -H / w ** 2)


def _uff_text_check(path: Path) -> int | None:
    """Refuse a file that cannot be a complete UFF: empty, not text, not opened or closed by the
    ``-1`` delimiter. Returns the number of datasets its delimiters enclose (None for binary 58b
    datasets, whose payload is not line-structured)."""
    try:
        raw = path.read_bytes()
    except OSError as e:
        raise BadInput(f"{path}: cannot read ({e.strerror or e})") from None
    if not raw.strip():
        raise BadInput(f"{path}: empty file; a UFF file holds datasets 58 between '-1' lines")
    if b"\x00" in raw or raw[:2] in (b"\xff\xfe", b"\xfe\xff"):
        if re.search(rb"^\s*58b\b", raw, re.M) is None:
            raise BadInput(f"{path}: not a text UFF file (NUL bytes: binary data or UTF-16); save it as "
                           "ASCII UFF")
    lines = [ln.strip() for ln in raw.decode("latin-1").splitlines()]
    body = [ln for ln in lines if ln]
    if body[0] != "-1":
        raise BadInput(f"{path}: not a UFF file (the first line is not the '-1' delimiter)")
    if re.search(rb"^\s*58b\b", raw, re.M) is not None:
        return None
    n_delim = sum(ln == "-1" for ln in body)
    if n_delim % 2 or body[-1] != "-1":
        raise BadInput(f"{path}: truncated UFF file (the last dataset is not closed by a '-1' line)")
    return n_delim // 2


def _uff_sets(path: Path) -> list[dict]:
    """The datasets 58 of a UFF file, read completely or refused (BadInput naming the file)."""
    import pyuff

    n_blocks = _uff_text_check(path)
    try:
        sets = pyuff.UFF(str(path)).read_sets()
    except Exception as e:  # pyuff raises bare exceptions on malformed files
        raise BadInput(f"{path}: not a readable UFF file ({e})") from None
    sets = [sets] if isinstance(sets, dict) else list(sets)
    if n_blocks is not None and len(sets) != n_blocks:
        raise BadInput(f"{path}: {n_blocks} datasets between '-1' lines, of which pyuff read {len(sets)}: "
                       "a damaged or truncated file")
    types = [s.get("type") for s in sets]
    if 58 not in types:
        raise BadInput(f"{path}: datasets {sorted(set(types), key=str)} and no dataset 58 (function at a node: "
                       "the FRFs); an FRF file holds datasets 58")
    for k, s in enumerate(sets):
        if s.get("type") == 164 and int(s.get("units_code", 1)) != 1:
            raise BadInput(f"{path} dataset {k + 1}: units dataset 164 with units_code {s.get('units_code')}; "
                           "only SI (1) is read: the units come from each dataset's axis labels")
    out = [s for s in sets if s.get("type") == 58]
    for k, s in enumerate(out):
        n = int(s.get("num_pts", -1))
        if len(np.atleast_1d(s.get("data", []))) != n or len(np.atleast_1d(s.get("x", []))) != n:
            raise BadInput(f"{path} dataset {k + 1}: {len(np.atleast_1d(s.get('data', [])))} values for num_pts "
                           f"= {n}: a truncated or damaged dataset")
    return out


def _uff_pair(s: dict, where: str) -> tuple[str | None, str, MeasuredPair]:
    if int(s.get("orddenom_spec_data_type", 13)) != 13:
        raise BadInput(f"{where}: orddenom_spec_data_type = {s.get('orddenom_spec_data_type')}; valid: 13 (force)")
    f = np.asarray(s["x"], dtype=float)
    data = np.asarray(s["data"])
    if not np.iscomplexobj(data):
        raise BadInput(f"{where}: real data (ord_data_type {s.get('ord_data_type')}); an FRF must be complex (5 or 6)")
    _check_axis(f, data, where)
    f, H = _to_receptance(f, data, int(s.get("ordinate_spec_data_type", 8)), str(s.get("ordinate_axis_units_lab", "")),
                          str(s.get("orddenom_axis_units_lab", "")), where)
    o, so = _dir(s.get("rsp_dir"), where, "rsp_dir")
    i, si = _dir(s.get("ref_dir"), where, "ref_dir")
    m = _POSE_RE.search(str(s.get("id1", "")))
    pose = m.group(1) if m else None
    return pose, _frame_of(str(s.get("id2", "")), where), MeasuredPair(o, so, i, si, 2 * math.pi * f, H, channel=o)


_CSV_LABELS = {"x": 0, "y": 1, "z": 2, "feed": 0, "normal": 1, "axial": 2}


def _csv_pairs(path: Path) -> tuple[str, list[MeasuredPair]]:
    try:
        raw = path.read_bytes()
        text = raw.decode("utf-8")
    except OSError as e:
        raise BadInput(f"{path}: cannot read ({e.strerror or e})") from None
    except UnicodeDecodeError:
        raise BadInput(f"{path}: not a UTF-8 text file (binary data or UTF-16?); save it as UTF-8 CSV") from None
    if not text.strip():
        raise BadInput(f"{path}: empty file")
    if "\x00" in text:
        raise BadInput(f"{path}: NUL bytes in a CSV file (binary data or UTF-16?)")
    if not text.endswith("\n"):
        raise BadInput(f"{path}: the last line does not end with a newline: a truncated file?")
    first, _, rest = text.partition("\n")
    names = rest.partition("\n")[0].strip().split(",")
    if not first.startswith("#") or not names or names[0] != "freq_hz":
        raise BadInput(f"{path}: not an FRF CSV written by robolobes frf (a '# ...' line, then freq_hz,H_<out>_<in>_re_m_per_n,...)")
    try:
        data = np.loadtxt(text.splitlines()[2:], delimiter=",", ndmin=2)
    except ValueError as e:
        raise BadInput(f"{path}: {e}") from None
    if data.shape[1] != len(names):
        raise BadInput(f"{path}: {data.shape[1]} columns of numbers for {len(names)} names")
    frame = _frame_of(first, str(path))
    f = data[:, 0]
    pairs = []
    for c in range(1, len(names), 2):
        m = re.fullmatch(r"H_(-?)([a-z]+)_(-?)([a-z]+)_re(_m_per_n)?", names[c])
        if not m or m.group(2) not in _CSV_LABELS or m.group(4) not in _CSV_LABELS or c + 1 >= len(names) \
                or names[c + 1] != names[c].replace("_re", "_im"):
            raise BadInput(f"{path}: column {names[c]!r}; valid: H_<out>_<in>_re_m_per_n then _im_m_per_n, "
                           "<out>/<in> among x, y, z, feed, normal, axial (a leading - flips the sign)")
        H = data[:, c] + 1j * data[:, c + 1]
        _check_axis(f, H, f"{path} column {names[c]}")
        pairs.append(MeasuredPair(_CSV_LABELS[m.group(2)], -1 if m.group(1) else 1, _CSV_LABELS[m.group(4)],
                                  -1 if m.group(3) else 1, 2 * math.pi * f, H,
                                  channel=_CSV_LABELS[m.group(2)]))
    return frame, pairs


def _read_pairs(path: Path) -> tuple[str, list[MeasuredPair]]:
    """(frame, pairs) of one FRF file, any pose."""
    if _fmt(path) == "csv":
        return _csv_pairs(path)
    frames, pairs = set(), []
    for k, s in enumerate(_uff_sets(path)):
        _, fr, pair = _uff_pair(s, f"{path} dataset {k + 1}")
        frames.add(fr)
        pairs.append(pair)
    if len(frames) > 1:
        raise BadInput(f"{path}: datasets in different frames {sorted(frames)}")
    return (frames.pop() if frames else "base"), pairs


# ----------------------------------------------------------------------------------------------
# one tool-tip FRF (a hammer test of the tool)


@dataclass(frozen=True)
class ToolFRF:
    """A tool-tip receptance in the cut plane read from hammer-test files.

    Attributes
    ----------
    frf : FRF
        ``H`` (2, 2, F) m/N, frame ``"cut"`` (rows/columns x_c feed, y_c normal), the file's lines.
    cross_measured : bool
        False when the files hold the driving points only (then ``H_xy = H_yx = 0``).
    notes : tuple of str
        What was assumed (missing cross terms, reciprocity, ignored z pairs), for the output.
    source : str
        The file or directory read.
    """

    frf: FRF
    cross_measured: bool
    notes: tuple
    source: str


_AXES = {"x": (0, 1), "-x": (0, -1), "+x": (0, 1), "y": (1, 1), "-y": (1, -1), "+y": (1, 1)}


def parse_frf_axes(text: str) -> np.ndarray:
    """``"FEED,NORMAL"`` (each ``x``, ``-x``, ``y`` or ``-y``: the measured axis, with its sign, along
    the feed x_c and the cut normal y_c) -> ``T`` (2, 2) with ``r_cut = T r_measured``."""
    parts = [p.strip().lower() for p in str(text).split(",")]
    if len(parts) != 2 or any(p not in _AXES for p in parts) or _AXES[parts[0]][0] == _AXES[parts[1]][0]:
        raise BadInput(f"FRF axes {text!r}; valid: FEED,NORMAL with each one of x, -x, y, -y and both different axes "
                       "(e.g. x,y: the measured x along the feed, y along the cut normal; -y,x)")
    T = np.zeros((2, 2))
    for c, p in enumerate(parts):
        axis, sign = _AXES[p]
        T[c, axis] = sign
    return T


def tool_frf_files(path: Path) -> list[Path]:
    """The FRF files of ``path``: the file itself, or every .uff, .unv, .csv file of a directory."""
    if path.is_dir():
        files = sorted(f for f in path.iterdir() if f.suffix.lower() in _FMT)
        if not files:
            raise BadInput(f"{path}: no FRF file (.uff, .unv or .csv) in the directory")
        return files
    if not path.exists():
        raise BadInput(f"{path}: no such FRF file or directory")
    _fmt(path)
    return [path]


def read_tool_frf(path: str | Path, axes: str = "x,y") -> ToolFRF:
    """Read a tool-tip FRF (hammer test): a UFF58 or CSV file, or a directory of them.

    Each file is read by the measured-set readers (UFF58 receptance, mobility or accelerance in
    their units, signed directions; CSV as ``robolobes frf`` writes it). The pairs in the plane of
    the measured x and y must include xx and yy, on one set of lines; xy and yx are optional (one
    alone: the other by reciprocity; none: zero); pairs with z are ignored. ``axes`` says which
    measured axis lies along the feed and which along the cut normal (:func:`parse_frf_axes`):
    ``H_cut = T H_measured T^T``. Every problem is a :class:`BadInput` naming the file.
    """
    T = parse_frf_axes(axes)
    src = Path(path)
    got: dict = {}
    omega = None
    notes = []
    z_pairs = 0
    for f in tool_frf_files(src):
        _, pairs = _read_pairs(f)
        if not pairs:
            raise BadInput(f"{f}: no FRF dataset (UFF58) or column in it")
        for p in pairs:
            if p.out_axis > 1 or p.in_axis > 1:
                z_pairs += 1
                continue
            key = (p.out_axis, p.in_axis)
            if key in got:
                raise BadInput(f"{f}: the pair {'xy'[key[0]]}{'xy'[key[1]]} is given twice")
            if omega is None:
                omega = p.omega
            elif len(p.omega) != len(omega) or not np.allclose(p.omega, omega, rtol=1e-9, atol=0):
                raise BadInput(f"{f}: the pair {'xy'[key[0]]}{'xy'[key[1]]} is on other frequency lines than the "
                               "first pair read; all pairs of a tool FRF must share the lines")
            got[key] = p.out_sign * p.in_sign * np.asarray(p.H)
    missing = [f"{'xy'[i]}{'xy'[i]}" for i in (0, 1) if (i, i) not in got]
    if missing or omega is None:
        raise BadInput(f"{src}: the driving point(s) {', '.join(missing or ['xx', 'yy'])} are missing; a tool FRF "
                       "needs xx and yy (x, y the measured axes)")
    if omega[0] <= 0:
        keep = omega > 0
        omega = omega[keep]
        got = {k: v[keep] for k, v in got.items()}
        notes.append("the 0 Hz line is dropped")
    cross = (0, 1) in got or (1, 0) in got
    if not cross:
        notes.append("xy = yx = 0 assumed (only the driving points xx, yy were measured)")
    elif (0, 1) not in got or (1, 0) not in got:
        have, other = ((0, 1), (1, 0)) if (0, 1) in got else ((1, 0), (0, 1))
        got[other] = got[have]
        notes.append(f"H{'xy'[other[0]]}{'xy'[other[1]]} = H{'xy'[have[0]]}{'xy'[have[1]]} assumed (reciprocity)")
    if z_pairs:
        notes.append(f"{z_pairs} pair(s) with z ignored (the chip sees the cut plane)")
    Hm = np.zeros((2, 2, len(omega)), complex)
    for (i, j), h in got.items():
        Hm[i, j] = h
    H = np.einsum("ai,ijf,bj->abf", T, Hm, T)
    frf = FRF(omega=omega, H=H, frame="cut", labels=("feed", "normal"))
    return ToolFRF(frf=frf, cross_measured=cross, notes=tuple(notes), source=str(src))


def _read_poses_csv(path: Path) -> tuple[dict, str | None]:
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:   # a byte-order mark is not a column name
            reader = csv.DictReader(fh)
            names = [(c or "").strip() for c in (reader.fieldnames or [])]
            rows = [{(k or "").strip(): v for k, v in r.items()} for r in reader]
    except FileNotFoundError:
        raise BadInput(f"{path}: no such file; an FRF set needs poses.csv (pose,q1_deg,...,q6_deg)") from None
    except (OSError, UnicodeDecodeError, csv.Error) as e:
        raise BadInput(f"{path}: cannot read as UTF-8 CSV ({e})") from None
    qcols = [f"q{i}_deg" for i in range(1, N_JOINTS + 1)]
    missing = [c for c in ["pose"] + qcols if c not in names]
    extra = [c for c in names if re.fullmatch(r"q\d+_deg", c) and c not in qcols]
    if missing or extra:
        raise BadInput(f"{path}: columns {names}: {'missing ' + ', '.join(missing) if missing else ''}"
                       f"{'; ' if missing and extra else ''}{'unknown ' + ', '.join(extra) if extra else ''}; "
                       f"needs pose,q1_deg,...,q{N_JOINTS}_deg (commanded motor angles, degrees)")
    poses, cases = {}, set()
    for k, row in enumerate(rows, start=2):
        name = (row["pose"] or "").strip()
        if not name or name in poses:
            raise BadInput(f"{path} line {k}: pose name {name!r} empty or repeated")
        try:
            q = np.array([float(row[c]) for c in qcols])
        except (TypeError, ValueError):
            raise BadInput(f"{path} line {k}: angles {[row[c] for c in qcols]} must be numbers (degrees)") from None
        if not np.all(np.isfinite(q)):
            raise BadInput(f"{path} line {k}: angles must be finite, got {q.tolist()}")
        poses[name] = np.radians(q)
        if row.get("case"):
            cases.add(row["case"].strip())
    if not poses:
        raise BadInput(f"{path}: no poses")
    if len(cases) > 1:
        raise BadInput(f"{path}: column case names several cases {sorted(cases)}; one set is one case")
    return poses, (cases.pop() if cases else None)


def read_frf_set(path: str | Path) -> FRFSet:
    """Read a measured FRF set (a directory, see the module doc). Files are only read.

    Returns
    -------
    FRFSet with one :class:`PoseFRF` per pose that has data, in ``poses.csv`` order.
    """
    d = Path(path)
    if d.is_file():
        d = d.parent
    poses, case = _read_poses_csv(d / "poses.csv")
    found: dict[str, list] = {name: [] for name in poses}
    frames: dict[str, set] = {name: set() for name in poses}
    where_pair: dict[tuple, str] = {}

    def add(pose: str, fr: str, pair: MeasuredPair, where: str) -> None:
        key = (pose, pair.out_axis, pair.in_axis)
        if key in where_pair:
            raise BadInput(f"{where}: pose {pose} pair (out {'xyz'[pair.out_axis]}, in {'xyz'[pair.in_axis]}) is "
                           f"measured twice (also in {where_pair[key]}); give each pair once")
        where_pair[key] = where
        found[pose].append(pair)
        frames[pose].add(fr)

    for f in sorted(d.iterdir()):
        if f.name == "poses.csv" or f.suffix.lower() not in _FMT or not f.is_file():
            continue
        if _fmt(f) == "csv":
            if f.stem not in poses:
                raise BadInput(f"{f}: pose {f.stem!r} is not in {d / 'poses.csv'} (poses: {', '.join(poses)})")
            fr, pairs = _csv_pairs(f)
            for pair in pairs:
                add(f.stem, fr, pair, str(f))
            continue
        for k, s in enumerate(_uff_sets(f)):
            where = f"{f} dataset {k + 1}"
            pose, fr, pair = _uff_pair(s, where)
            if pose is not None and f.stem in poses and pose != f.stem:
                raise BadInput(f"{where}: labelled pose {pose!r} (id1) inside {f.name}, the file of pose "
                               f"{f.stem!r}; rename the file or fix its id1")
            pose = pose or f.stem
            if pose not in poses:
                raise BadInput(f"{where}: pose {pose!r} is not in {d / 'poses.csv'} (poses: {', '.join(poses)})")
            add(pose, fr, pair, where)
    out = []
    for name, pairs in found.items():
        if not pairs:
            continue
        if len(frames[name]) > 1:
            raise BadInput(f"{d}: pose {name} measured in several frames {sorted(frames[name])}")
        out.append(PoseFRF(pose=name, theta=poses[name], frame=frames[name].pop(), pairs=tuple(pairs)))
    if not out:
        raise BadInput(f"{d}: no FRF file for any pose of poses.csv (<pose>.uff, .unv or .csv)")
    return FRFSet(path=d, poses=tuple(out), case=case)


def write_frf_set(directory: str | Path, poses_deg: dict, frfs: dict, *, fmt: str = "uff",
                  case: str | None = None) -> Path:
    """Write a measurement set: ``poses.csv`` and ``<pose>.<fmt>`` (full matrices, :func:`write_frf`).

    ``poses_deg``: pose -> motor angles (deg); ``frfs``: pose -> :class:`FRF`. The directory must
    not exist yet (nothing a user owns is overwritten).
    """
    d = Path(directory)
    if d.exists():
        raise BadInput(f"{d} exists; give a new directory for the FRF set")
    d.mkdir(parents=True)
    n = len(next(iter(poses_deg.values())))
    lines = ["pose," + ",".join(f"q{i + 1}_deg" for i in range(n)) + (",case" if case else "")]
    for name, q in poses_deg.items():
        lines.append(name + "," + ",".join(f"{float(v):.12g}" for v in q) + (f",{case}" if case else ""))
    with atomic_path(d / "poses.csv") as tmp:
        tmp.write_text("\n".join(lines) + "\n")
    for name, frf in frfs.items():
        write_frf(frf, d / f"{name}.{fmt}")
    return d


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
