"""Readers of force-side measurements: cutting-force series, force statistics, stability observations.

Three kinds of set, each recognised from its files:

* **cutting-force set** (``kind = "forces"``): a directory with ``forces.csv`` (header
  ``t_s,fx_n,fy_n,fz_n``: forces on the workpiece in the cut frame, the convention of
  ``simulate``'s ``force_stats``) and ``cut.toml`` (``case``, ``sample_rate_hz``,
  ``window_s = [t0, t1]`` of pass time covered by the file, optional ``variant``);
* **force statistics** (``kind = "force_stats"``): ``force_stats.toml`` with ``case``,
  ``window_s``, ``axes = "workpiece" | "paper"`` and tables ``[x]``, ``[y]`` holding ``min``,
  ``max``, ``mean``, ``rms`` in N (the paper's Tab. 10 is shipped in this format);
* **stability observations** (``kind = "stability"``): ``stability.csv`` with columns
  ``case,rpm,depth_mm,observed`` (``stable`` or ``chatter``) and either ``path_s_m`` or
  ``q1_deg..q6_deg``.

Every reader checks before any work and raises :class:`~robolobes.core.errors.BadInput` with one
line naming the file and the bad value: NaN, a sample rate that disagrees with ``t_s`` (more than
0.1 % or non-uniform sampling beyond 1 % jitter), a window outside the pass or not covered by the
samples, unknown axes or observations, a force beyond ``MAX_FORCE_N`` (1 MN), a speed outside (0, ``MAX_RPM``] rpm or a depth outside (0, ``MAX_DEPTH_MM``]
mm. Files are read, never modified. Sizes are bounded (``MAX_SAMPLES``, ``MAX_ROWS``).
"""

from __future__ import annotations

import csv
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from robolobes.core.errors import BadInput

__all__ = ["ForceSeries", "ForceStatistics", "StabilityObservation", "StabilityObservations", "read_force_set",
           "read_force_stats", "read_stability", "force_kind", "read_force_measurement", "STAT_KEYS",
           "MAX_SAMPLES", "MAX_ROWS", "paper_to_workpiece"]

#: Largest force series accepted (10 s at 1 MHz): bounds memory (3 float64 per sample) and run time.
MAX_SAMPLES = 10_000_000
#: Largest number of stability observations.
MAX_ROWS = 100_000
#: Order of the statistics in the 8-vector of a force-statistics set (per axis x then y).
STAT_KEYS = ("min", "max", "mean", "rms")
#: Relative disagreement allowed between ``sample_rate_hz`` and the mean spacing of ``t_s``.
RATE_TOL = 1e-3
#: Largest force magnitude accepted in a sample or a statistic, N. A robot's milling forces are
#: hundreds of N; 1 MN is beyond what any spindle, tool or robot carries, and squares of forces up
#: to it stay far from float64 overflow (1e308).
MAX_FORCE_N = 1e6
#: Fastest spindle speed accepted, rpm (the bound of every other command's speeds).
MAX_RPM = 100_000.0
#: Deepest axial cut accepted, mm: longer than any end mill's flutes; deeper "depths" are typos
#: (a depth in um), and the lobe computation becomes ill-conditioned far beyond it.
MAX_DEPTH_MM = 100.0


def _bad(path, msg: str) -> BadInput:
    return BadInput(f"{path}: {msg}")


@dataclass(frozen=True)
class ForceSeries:
    """A measured cutting-force series (forces on the workpiece, cut frame).

    Attributes
    ----------
    path : Path
        The set's directory.
    case : str or None
        The case named in ``cut.toml`` (a built-in name or a path relative to the set).
    variant : str or None
    sample_rate_hz : float
    window_s : (float, float)
        Pass time covered, s.
    t_s : array (n,)
        Pass time of each sample, s (read-only).
    force_n : array (n, 3)
        ``(fx, fy, fz)`` on the workpiece in the cut frame, N (read-only).
    """

    path: Path
    case: str | None
    variant: str | None
    sample_rate_hz: float
    window_s: tuple
    t_s: np.ndarray
    force_n: np.ndarray

    kind = "forces"


@dataclass(frozen=True)
class ForceStatistics:
    """Published force statistics over a window (8 numbers).

    Attributes
    ----------
    path : Path
    case : str or None
    window_s : (float, float)
    axes : {"workpiece", "paper"}
        As written in the file; :attr:`workpiece` gives them in the workpiece (cut-frame) axes.
    stats : dict
        ``{"x": {"min", "max", "mean", "rms"}, "y": {...}}`` in N, as written in the file.
    """

    path: Path
    case: str | None
    window_s: tuple
    axes: str
    stats: dict

    kind = "force_stats"
    variant = None

    @property
    def workpiece(self) -> np.ndarray:
        """The 8 statistics in the workpiece axes, shape (8,): x min, max, mean, rms, then y, N."""
        if self.axes == "workpiece":
            return np.array([self.stats[a][k] for a in "xy" for k in STAT_KEYS], dtype=float)
        return paper_to_workpiece(np.array([self.stats[a][k] for a in "xy" for k in STAT_KEYS], dtype=float))


def paper_to_workpiece(v: np.ndarray) -> np.ndarray:
    """Statistics (x min, max, mean, rms, y min, max, mean, rms) from the paper's Tab. 10 axes to the
    workpiece axes, shape (8,), N. The paper's Fx is the force on the tool (``-F_workpiece.x``): its min
    and max swap and change sign, its mean changes sign, its RMS stays; its Fy is the workpiece's."""
    v = np.asarray(v, dtype=float)
    return np.array([-v[1], -v[0], -v[2], v[3], v[4], v[5], v[6], v[7]])


@dataclass(frozen=True)
class StabilityObservation:
    """One observed cut: speed, depth, pose and whether it chattered.

    ``path_s_m`` (metres along the pass) or ``q_rad`` (six motor angles, rad) gives the pose.
    """

    case: str
    rpm: float
    depth_m: float
    chatter: bool
    path_s_m: float | None = None
    q_rad: tuple | None = None


@dataclass(frozen=True)
class StabilityObservations:
    """Rows of ``stability.csv``."""

    path: Path
    rows: tuple

    kind = "stability"
    variant = None

    @property
    def case(self) -> str | None:
        names = {r.case for r in self.rows}
        return names.pop() if len(names) == 1 else None


def _load_toml(path: Path) -> dict:
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        raise _bad(path, "file not found") from None
    except tomllib.TOMLDecodeError as e:
        raise _bad(path, f"not valid TOML: {e}") from None


def _number(path, key: str, value, *, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise _bad(path, f"key {key!r} must be a number, got {value!r}")
    v = float(value)
    if not math.isfinite(v):
        raise _bad(path, f"key {key!r} must be finite, got {value!r}")
    if positive and v <= 0:
        raise _bad(path, f"key {key!r} must be > 0, got {value!r}")
    return v


def _window(path, value) -> tuple:
    if not isinstance(value, list) or len(value) != 2:
        raise _bad(path, f"key 'window_s' must be [t0, t1] in s, got {value!r}")
    t0, t1 = (_number(path, "window_s", v) for v in value)
    if not 0 <= t0 < t1:
        raise _bad(path, f"key 'window_s' = {value!r}: needs 0 <= t0 < t1 (pass time, s)")
    return t0, t1


def _case_key(path, data: dict) -> str | None:
    c = data.get("case")
    if c is None:
        return None
    if not isinstance(c, str) or not c:
        raise _bad(path, f"key 'case' must be a case name or path, got {c!r}")
    return c


def _check_keys(path, data: dict, allowed: set) -> None:
    extra = sorted(set(data) - allowed)
    if extra:
        raise _bad(path, f"unknown key(s) {extra}; valid: {sorted(allowed)}")


def read_force_set(directory) -> ForceSeries:
    """Read a cutting-force set (module docstring). Raises BadInput naming the file and the value."""
    d = Path(directory)
    toml_path, csv_path = d / "cut.toml", d / "forces.csv"
    meta = _load_toml(toml_path)
    _check_keys(toml_path, meta, {"case", "sample_rate_hz", "window_s", "variant"})
    if "sample_rate_hz" not in meta:
        raise _bad(toml_path, "missing key 'sample_rate_hz' (samples per second of forces.csv)")
    if "window_s" not in meta:
        raise _bad(toml_path, "missing key 'window_s' = [t0, t1] (pass time covered, s)")
    rate = _number(toml_path, "sample_rate_hz", meta["sample_rate_hz"], positive=True)
    window = _window(toml_path, meta["window_s"])
    variant = meta.get("variant")
    if variant is not None and not isinstance(variant, str):
        raise _bad(toml_path, f"key 'variant' must be a string, got {variant!r}")
    t, f = _read_force_csv(csv_path)
    _check_sampling(csv_path, t, rate)
    if t[0] > window[0] + 1.5 / rate or t[-1] < window[1] - 1.5 / rate:
        raise _bad(toml_path, f"window_s = {list(window)} s is not covered by forces.csv, which holds "
                              f"t_s = {t[0]:.6g} .. {t[-1]:.6g} s")
    sel = (t >= window[0] - 0.5 / rate) & (t <= window[1] + 0.5 / rate)
    t, f = t[sel], f[sel]
    t.setflags(write=False)
    f.setflags(write=False)
    return ForceSeries(path=d, case=_case_key(toml_path, meta), variant=variant, sample_rate_hz=rate,
                       window_s=window, t_s=t, force_n=f)


def _read_force_csv(path: Path) -> tuple[np.ndarray, np.ndarray]:
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:
            header = fh.readline().strip().replace(" ", "").split(",")
            if header != ["t_s", "fx_n", "fy_n", "fz_n"]:
                raise _bad(path, f"header must be t_s,fx_n,fy_n,fz_n, got {','.join(header)!r}")
            try:
                a = np.loadtxt(fh, delimiter=",", ndmin=2, max_rows=MAX_SAMPLES + 1)
            except ValueError as e:
                raise _bad(path, f"not a table of numbers: {e}") from None
    except FileNotFoundError:
        raise _bad(path, "file not found (a cutting-force set needs forces.csv and cut.toml)") from None
    except UnicodeDecodeError as e:
        raise _bad(path, f"not a UTF-8 CSV file ({e})") from None
    if a.shape[0] > MAX_SAMPLES:
        raise _bad(path, f"more than {MAX_SAMPLES} samples; split the series or decimate it")
    if a.shape[0] < 2 or a.shape[1] != 4:
        raise _bad(path, f"needs at least 2 rows of 4 columns, got shape {a.shape}")
    bad = ~np.isfinite(a)
    if bad.any():
        i, j = np.argwhere(bad)[0]
        raise _bad(path, f"row {i + 2}, column {['t_s', 'fx_n', 'fy_n', 'fz_n'][j]} is {a[i, j]}; values must "
                         f"be finite numbers")
    big = np.abs(a[:, 1:]) > MAX_FORCE_N
    if big.any():
        i, j = np.argwhere(big)[0]
        raise _bad(path, f"row {i + 2}, column {['fx_n', 'fy_n', 'fz_n'][j]} is {float(a[i, j + 1]):.6g} N; a cutting "
                         f"force is at most {MAX_FORCE_N:.0e} N in magnitude (check the unit)")
    return np.ascontiguousarray(a[:, 0]), np.ascontiguousarray(a[:, 1:])


def _check_sampling(path: Path, t: np.ndarray, rate: float) -> None:
    dt = np.diff(t)
    if np.any(dt <= 0):
        i = int(np.argmax(dt <= 0))
        raise _bad(path, f"t_s must increase: row {i + 3} has t_s = {t[i + 1]!r} after {t[i]!r}")
    mean = (t[-1] - t[0]) / (len(t) - 1)
    if abs(mean * rate - 1) > RATE_TOL:
        raise _bad(path, f"sample_rate_hz = {rate:.9g} in cut.toml disagrees with t_s, whose mean spacing "
                         f"gives {1 / mean:.9g} Hz (tolerance {RATE_TOL:.0e})")
    if np.max(np.abs(dt - mean)) > 0.01 * mean:
        raise _bad(path, f"t_s is not uniformly sampled (spacing {dt.min():.6g} .. {dt.max():.6g} s); "
                         f"resample it at sample_rate_hz")


def read_force_stats(path) -> ForceStatistics:
    """Read ``force_stats.toml`` (module docstring). Raises BadInput naming the file and the value."""
    p = Path(path)
    data = _load_toml(p)
    _check_keys(p, data, {"case", "window_s", "axes", "x", "y", "source", "kind", "name"})
    if "window_s" not in data:
        raise _bad(p, "missing key 'window_s' = [t0, t1] (s)")
    axes = data.get("axes")
    if axes not in ("workpiece", "paper"):
        raise _bad(p, f"key 'axes' = {axes!r}; valid: 'workpiece' (cut frame, forces on the workpiece) or "
                      f"'paper' (Tab. 10 signs)")
    stats = {}
    for ax in "xy":
        tab = data.get(ax)
        if not isinstance(tab, dict):
            raise _bad(p, f"missing table [{ax}] with min, max, mean, rms (N)")
        _check_keys(p, tab, set(STAT_KEYS))
        row = {}
        for k in STAT_KEYS:
            if k not in tab:
                raise _bad(p, f"table [{ax}] lacks key {k!r}; it needs min, max, mean, rms (N)")
            row[k] = _number(p, f"{ax}.{k}", tab[k])
            if abs(row[k]) > MAX_FORCE_N:
                raise _bad(p, f"[{ax}] {k} = {row[k]:.6g} N; a cutting force is at most {MAX_FORCE_N:.0e} N in "
                              "magnitude (check the unit)")
        if not row["min"] <= row["mean"] <= row["max"] or row["rms"] < abs(row["mean"]) - 1e-9:
            raise _bad(p, f"table [{ax}] = {row} is inconsistent: needs min <= mean <= max and rms >= |mean|")
        stats[ax] = row
    return ForceStatistics(path=p, case=_case_key(p, data), window_s=_window(p, data["window_s"]), axes=axes,
                           stats=stats)


def read_stability(path) -> StabilityObservations:
    """Read ``stability.csv`` (module docstring). Raises BadInput naming the file, row and value."""
    p = Path(path)
    try:
        with open(p, newline="", encoding="utf-8-sig") as fh:
            reader = csv.DictReader(fh)
            cols = [c.strip() for c in (reader.fieldnames or [])]
            need = {"case", "rpm", "depth_mm", "observed"}
            qcols = [f"q{i}_deg" for i in range(1, 7)]
            if not need <= set(cols) or not ("path_s_m" in cols or set(qcols) <= set(cols)):
                raise _bad(p, f"columns {cols}: need case,rpm,depth_mm,observed and path_s_m or q1_deg..q6_deg")
            rows = []
            for i, raw in enumerate(reader, start=2):
                if len(rows) >= MAX_ROWS:
                    raise _bad(p, f"more than {MAX_ROWS} observations")
                rows.append(_stability_row(p, i, {k.strip(): (v or "").strip() for k, v in raw.items() if k}, qcols))
    except FileNotFoundError:
        raise _bad(p, "file not found") from None
    except (UnicodeDecodeError, csv.Error) as e:
        raise _bad(p, f"not a UTF-8 CSV file ({e})") from None
    if not rows:
        raise _bad(p, "no observations")
    return StabilityObservations(path=p, rows=tuple(rows))


def _stability_row(p, i: int, r: dict, qcols: list) -> StabilityObservation:
    def num(key, positive=False, most=None, unit=""):
        try:
            v = float(r[key])
        except (KeyError, ValueError):
            raise _bad(p, f"row {i}: {key} = {r.get(key)!r} is not a number") from None
        if most is not None and not (math.isfinite(v) and 0 < v <= most):
            raise _bad(p, f"row {i}: {key} = {r[key]!r}; valid: (0, {most:g}] {unit}")
        if not math.isfinite(v) or (positive and v <= 0):
            raise _bad(p, f"row {i}: {key} = {r[key]!r}; valid: a finite number{' > 0' if positive else ''}")
        return v

    obs = r.get("observed", "").lower()
    if obs not in ("stable", "chatter"):
        raise _bad(p, f"row {i}: observed = {r.get('observed')!r}; valid: 'stable' or 'chatter'")
    if not r.get("case"):
        raise _bad(p, f"row {i}: empty case")
    path_s = num("path_s_m") if r.get("path_s_m") else None
    q = tuple(math.radians(num(c)) for c in qcols) if path_s is None else None
    return StabilityObservation(case=r["case"], rpm=num("rpm", most=MAX_RPM, unit="rpm"),
                                depth_m=num("depth_mm", most=MAX_DEPTH_MM, unit="mm") * 1e-3,
                                chatter=obs == "chatter", path_s_m=path_s, q_rad=q)


def force_kind(path) -> str | None:
    """The force-side kind of a measurement path (``"forces"``, ``"force_stats"``, ``"stability"``) or None."""
    p = Path(path)
    if p.is_dir():
        if (p / "forces.csv").exists() or (p / "cut.toml").exists():
            return "forces"
        if (p / "force_stats.toml").is_file():
            return "force_stats"
        if (p / "stability.csv").is_file():
            return "stability"
        return None
    if p.name == "forces.csv" or p.name == "cut.toml":
        return "forces"
    if p.suffix == ".toml" and p.is_file():
        return "force_stats"
    if p.name.endswith("stability.csv"):
        return "stability"
    return None


def read_force_measurement(path):
    """Read any force-side set (kind recognised from its files); BadInput if none is recognised."""
    p = Path(path)
    kind = force_kind(p)
    if kind == "forces":
        return read_force_set(p if p.is_dir() else p.parent)
    if kind == "force_stats":
        return read_force_stats(p / "force_stats.toml" if p.is_dir() else p)
    if kind == "stability":
        return read_stability(p / "stability.csv" if p.is_dir() else p)
    raise BadInput(f"{p}: not a force measurement; valid: a directory with forces.csv + cut.toml, "
                   f"a force_stats.toml, or a stability.csv")
