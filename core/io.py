"""Atomic output: a result file is either complete or absent, never half-written.

Every writer in robolobes (CSV, JSON, UFF, PNG/PDF, reports) goes through :func:`atomic_path`:
the content is written to a temporary file in the target directory and moved into place with
``os.replace`` only when writing succeeded; on any error or interruption the temporary file is
removed and an existing target is left untouched.
"""

from __future__ import annotations

import contextlib
import json
import os
import tempfile
from pathlib import Path
from typing import Iterator

import numpy as np

__all__ = ["atomic_path", "write_json", "write_text", "save_figure", "pyplot", "to_jsonable", "Progress", "provenance"]


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; move it onto ``path`` when the block succeeds."""
    target = Path(path)
    if target.parent and not target.parent.exists():
        raise FileNotFoundError(f"output directory {target.parent} does not exist")
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".part" + target.suffix, dir=target.parent or ".")
    os.close(fd)
    tmp_path = Path(tmp)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp_path, 0o666 & ~umask)  # mkstemp makes 0600; results are ordinary files
    try:
        yield tmp_path
        os.replace(tmp_path, target)
    except BaseException:
        tmp_path.unlink(missing_ok=True)
        raise


def to_jsonable(obj):
    """Convert numpy scalars/arrays (and complex numbers as [re, im]) to JSON-ready Python objects."""
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return to_jsonable(obj.tolist())
    if isinstance(obj, (np.bool_,)):
        return bool(obj)
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, (np.floating, float)):
        v = float(obj)
        return v if np.isfinite(v) else None
    if isinstance(obj, complex):
        return [obj.real, obj.imag]
    return obj


def write_json(path: str | os.PathLike, obj) -> None:
    """Write ``obj`` as indented JSON, atomically (NaN/inf become null)."""
    text = json.dumps(to_jsonable(obj), indent=2)
    write_text(path, text + "\n")


def write_text(path: str | os.PathLike, text: str) -> None:
    """Write a text file atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(text)


def pyplot():
    """``matplotlib.pyplot`` on the headless Agg backend (figures are only ever saved to files)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig, path: str | os.PathLike, **kw) -> None:
    """Save a matplotlib figure atomically; the format follows the suffix (png, pdf, svg)."""
    target = Path(path)
    with atomic_path(target) as tmp:
        fig.savefig(tmp, format=target.suffix.lstrip(".") or "png", **kw)


class Progress:
    """A one-line progress display on stderr for long work (simulations, lobe maps, studies).

    ``Progress("simulate")(fraction)`` redraws ``simulate  42 %  (elapsed 3.1 s, left ~4.2 s)``
    on a terminal (carriage return) and prints a line every 10 % otherwise; ``done()`` ends the
    line. Silent when ``enabled`` is False.
    """

    def __init__(self, label: str, enabled: bool = True, stream=None):
        import sys
        import time

        self.label, self.enabled = label, enabled
        self.stream = stream if stream is not None else sys.stderr
        self.tty = hasattr(self.stream, "isatty") and self.stream.isatty()
        self.t0 = time.perf_counter()
        self._last = -1

    def __call__(self, fraction: float, note: str = "") -> None:
        import time

        if not self.enabled:
            return
        pct = int(100 * min(max(fraction, 0.0), 1.0))
        step = 1 if self.tty else 10
        if pct // step == self._last // step and note == "":
            return
        self._last = pct
        el = time.perf_counter() - self.t0
        left = f", left ~{el * (1 - fraction) / fraction:.0f} s" if 0 < fraction < 1 else ""
        msg = f"{self.label} {pct:3d} %  (elapsed {el:.0f} s{left}){'  ' + note if note else ''}"
        if self.tty:
            self.stream.write("\r" + msg.ljust(78))
        else:
            self.stream.write(msg + "\n")
        self.stream.flush()

    def done(self, note: str = "") -> None:
        import time

        if not self.enabled:
            return
        el = time.perf_counter() - self.t0
        msg = f"{self.label} done in {el:.1f} s{'  ' + note if note else ''}"
        self.stream.write(("\r" + msg.ljust(78) + "\n") if self.tty else msg + "\n")
        self.stream.flush()

    def sub(self, lo: float, hi: float):
        """A callback mapping a sub-task's 0..1 onto ``[lo, hi]`` of this display."""
        return lambda f, note="": self(lo + (hi - lo) * f, note)


def provenance(inputs) -> dict:
    """What produced a result: ``{"robolobes_version": str, "inputs_sha256": str}``.

    ``inputs`` is any JSON-able description of the inputs (case, variant, options, measured files'
    hashes...); its hash is the SHA-256 of its canonical JSON (sorted keys, no whitespace), so two
    runs with equal inputs record equal hashes. Every JSON and report robolobes writes records this.
    """
    import hashlib

    from robolobes import __version__

    text = json.dumps(to_jsonable(inputs), sort_keys=True, separators=(",", ":"))
    return {"robolobes_version": __version__, "inputs_sha256": hashlib.sha256(text.encode()).hexdigest()}
