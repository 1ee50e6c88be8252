"""The ``[[modes]]`` TOML of a user's modal model (``lobes --modal``, ``--tool-modes``).

Each table is a real mode (``freq_hz``, ``damping_ratio``, ``stiffness_n_per_m``, ``direction =
[x, y]`` unit vector in the cut frame) or a complex one (``freq_hz``, ``damping_ratio``,
``residue_re``, ``residue_im``: 2 x 2 arrays ``[[xx, xy], [yx, yy]]`` in m/(N s) of the residue of
``H(s) = R / (s - lam) + conj``); an optional ``name``.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np

from ._errors import LobeError
from .structure import ComplexMode, Mode, ModalStructure

__all__ = ["read_modal_toml", "load_toml"]


def load_toml(path: str | Path, what: str = "modal file") -> dict:
    """The tables of a user's TOML file; LobeError (one line naming it) if it cannot be read or parsed."""
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except OSError as e:
        raise LobeError(f"cannot read the {what} {path}: {e.strerror or e}") from None
    except tomllib.TOMLDecodeError as e:
        raise LobeError(f"{path}: not valid TOML: {e}") from None


def read_modal_toml(path: str | Path) -> ModalStructure:
    """A :class:`ModalStructure` from a TOML file of ``[[modes]]`` tables (see module docstring)."""
    path = Path(path)
    data = load_toml(path)
    modes = data.get("modes")
    if not isinstance(modes, list) or not modes or not all(isinstance(m, dict) for m in modes):
        raise LobeError(f"{path}: needs at least one [[modes]] table with freq_hz, damping_ratio, "
                        f"stiffness_n_per_m, direction = [x, y]")
    out = []
    for i, m in enumerate(modes):
        out.append(_read_mode(path, i, m))
    return ModalStructure(tuple(out))


_REAL_KEYS = ("freq_hz", "damping_ratio", "stiffness_n_per_m", "direction")
_COMPLEX_KEYS = ("freq_hz", "damping_ratio", "residue_re", "residue_im")


def _number(path, i, m, k):
    if isinstance(m[k], bool) or not isinstance(m[k], (int, float)):
        raise LobeError(f"{path}: modes[{i}].{k} must be a number, got {m[k]!r}")
    return float(m[k])


def _matrix2(path, i, m, k) -> np.ndarray:
    v = m[k]
    ok = isinstance(v, list) and len(v) == 2 and all(isinstance(r, list) and len(r) == 2 for r in v) and all(
        not isinstance(x, bool) and isinstance(x, (int, float)) for r in v for x in r)
    if not ok:
        raise LobeError(f"{path}: modes[{i}].{k} must be a 2 x 2 array [[xx, xy], [yx, yy]] of numbers, got {v!r}")
    return np.array(v, dtype=float)


def _read_mode(path, i: int, m: dict):
    """One [[modes]] table: a real mode (stiffness, direction) or a complex one (residue_re, residue_im)."""
    keys = _COMPLEX_KEYS if ("residue_re" in m or "residue_im" in m) else _REAL_KEYS
    missing = [k for k in keys if k not in m]
    if missing:
        raise LobeError(f"{path}: modes[{i}] is missing {', '.join(missing)}")
    unknown = sorted(set(m) - set(keys) - {"name"})
    if unknown:
        raise LobeError(f"{path}: modes[{i}] has unknown key(s) {unknown}; valid: {', '.join(keys)}, name (a real "
                        f"mode: {', '.join(_REAL_KEYS)}; a complex one: {', '.join(_COMPLEX_KEYS)})")
    f, z = _number(path, i, m, "freq_hz"), _number(path, i, m, "damping_ratio")
    try:
        if keys is _COMPLEX_KEYS:
            R = _matrix2(path, i, m, "residue_re") + 1j * _matrix2(path, i, m, "residue_im")
            return ComplexMode(f, z, R)
        d = m["direction"]
        if not isinstance(d, list) or len(d) != 2 or any(isinstance(x, bool) or not isinstance(x, (int, float)) for x in d):
            raise LobeError(f"{path}: modes[{i}].direction must be [x, y] (unit vector in the cut frame), got {d!r}")
        return Mode(f, z, _number(path, i, m, "stiffness_n_per_m"), (float(d[0]), float(d[1])))
    except LobeError as e:
        if str(e).startswith(str(path)):
            raise
        raise LobeError(f"{path}: modes[{i}]: {e}") from None
