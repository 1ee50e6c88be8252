"""Validation helpers: the one home of the checks every package makes on its inputs.

Each check raises ``error`` (default :class:`robolobes.core.errors.BadInput`; packages pass their own
subclass, e.g. ``MillingError``) with a message naming the value and what would be valid.
"""

from __future__ import annotations

import math

from typing import Any

import numpy as np

from .errors import BadInput

__all__ = ["readonly", "finite", "finite_array", "integer", "shown"]


def shown(value) -> str:
    """``repr`` of a value for a user's message, numpy scalars and arrays as plain Python numbers:
    ``(0.0, 0.0)``, never ``(np.float64(0.0), np.float64(0.0))`` (numpy >= 2 scalar repr).

    >>> shown((np.float64(0.0), np.float64(1.5)))
    '(0.0, 1.5)'
    """
    return repr(_plain(value))


def _plain(v):
    """``v`` with numpy scalars and arrays (also inside lists, tuples, dicts) as Python objects."""
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, (list, tuple)):
        return type(v)(_plain(x) for x in v)
    if isinstance(v, dict):
        return {k: _plain(x) for k, x in v.items()}
    return v


def readonly(a, dtype: Any = float, shape: tuple | None = None, name: str = "array", error: type[Exception] = BadInput) -> np.ndarray:
    """A read-only copy of ``a`` as ``dtype`` (``None`` keeps the dtype); ``shape`` is checked if given."""
    arr = np.array(a, dtype=dtype, copy=True)
    if shape is not None and arr.shape != tuple(shape):
        raise error(f"{name} must have shape {tuple(shape)}, got {arr.shape}")
    arr.setflags(write=False)
    return arr


def finite(name: str, value, *, positive: bool = False, nonneg: bool = False, error: type[Exception] = BadInput) -> float:
    """``value`` as a finite float; ``positive``: > 0, ``nonneg``: >= 0."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise error(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(v):
        raise error(f"{name} must be finite, got {v}")
    if positive and v <= 0:
        raise error(f"{name} must be > 0, got {v}")
    if nonneg and v < 0:
        raise error(f"{name} must be >= 0, got {v}")
    return v


def finite_array(name: str, x, shape: tuple | None = None, *, ndim: int | None = None, error: type[Exception] = BadInput,
                 contiguous: bool = False) -> np.ndarray:
    """``x`` as a float64 array (a copy) whose entries are all finite; ``shape`` / ``ndim`` checked if given.

    ``contiguous=True`` returns a C-contiguous array (for compiled kernels)."""
    try:
        a = np.array(x, dtype=np.float64, copy=True)
    except (TypeError, ValueError):
        raise error(f"{name} must be an array of real numbers, got {x!r}") from None
    if contiguous:
        a = np.ascontiguousarray(a)
    if shape is not None and a.shape != tuple(shape):
        raise error(f"{name} must have shape {tuple(shape)}, got {a.shape}")
    if ndim is not None and a.ndim != ndim:
        raise error(f"{name} must be a {ndim}-D array, got shape {a.shape}")
    bad = ~np.isfinite(a)
    if bad.any():
        where = tuple(int(i) for i in np.argwhere(bad)[0])
        raise error(f"{name} must be finite; entry {list(where)} is {a[where]}")
    return a


def integer(name: str, value, *, minimum: int | None = None, maximum: int | None = None, error: type[Exception] = BadInput) -> int:
    """``value`` as an int in ``[minimum, maximum]`` (bounds that are None are open)."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise error(f"{name} must be an integer, got {value!r}")
    v = int(value)
    if (minimum is not None and v < minimum) or (maximum is not None and v > maximum):
        if maximum is None:
            raise error(f"{name} must be an integer >= {minimum}, got {v}")
        if minimum is None:
            raise error(f"{name} must be an integer <= {maximum}, got {v}")
        raise error(f"{name} must be an integer in [{minimum}, {maximum}], got {v}")
    return v
