"""Atomic output: a result file is either complete or absent, never half-written.

Every writer in robolobes (CSV, JSON, UFF, PNG/PDF, reports) goes through :func:`atomic_path`:
the content is written to a temporary file in the target directory and moved into place with
``os.replace`` only when writing succeeded; on any error or interruption the temporary file is
removed and an existing target is left untouched.
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import re
import tempfile
from pathlib import Path
from typing import Any, Iterator

import numpy as np

__all__ = ["atomic_path", "write_json", "write_text", "save_figure", "pyplot", "to_jsonable", "Progress", "provenance",
           "provenance_text"]


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; move it onto ``path`` when the block succeeds."""
    target = Path(path)
    if target.parent and not target.parent.exists():
        raise FileNotFoundError(f"output directory {target.parent} does not exist")
    _remove_dead_parts(target)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".part" + target.suffix, dir=target.parent or ".")
    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)   # held while this process lives: see _remove_dead_parts
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
    finally:
        os.close(fd)


def _remove_dead_parts(target: Path) -> None:
    """Remove ``.NAME.XXXXXXXX.partSUFFIX`` files beside ``target`` left by a process that died while
    writing (its ``flock`` on the file is gone: the kernel drops it with the process)."""
    pattern = re.compile(re.escape(f".{target.name}.") + r"[A-Za-z0-9_]{8}" + re.escape(".part" + target.suffix))
    parent = target.parent if str(target.parent) else Path(".")
    try:
        entries = [p for p in parent.iterdir() if pattern.fullmatch(p.name)]
    except OSError:
        return
    for p in entries:
        try:
            fd = os.open(p, os.O_RDONLY | os.O_NOFOLLOW)
        except OSError:
            continue
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            p.unlink(missing_ok=True)
        except OSError:
            pass   # a live writer's
        finally:
            os.close(fd)


def to_jsonable(obj) -> Any:
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


_FIGURE_TEXT_KEY = {"png": "Description", "svg": "Description", "pdf": "Subject"}


def save_figure(fig, path: str | os.PathLike, provenance: dict | None = None, **kw) -> None:
    """Save a matplotlib figure atomically; the format follows the suffix (png, pdf, svg).

    ``provenance`` (:func:`provenance`'s dict) is recorded in the file's metadata (PNG/SVG
    ``Description``, PDF ``Subject``) so that ``core.outdir`` recognizes the file as robolobes'."""
    target = Path(path)
    fmt = target.suffix.lstrip(".").lower() or "png"
    if provenance is not None and fmt in _FIGURE_TEXT_KEY:
        kw["metadata"] = {**kw.get("metadata", {}), _FIGURE_TEXT_KEY[fmt]: provenance_text(provenance)}
    with atomic_path(target) as tmp:
        fig.savefig(tmp, format=fmt, **kw)


class _LineStream:
    """A text stream for tqdm on a non-terminal: each redraw becomes one plain line (no ``\\r``)."""

    def __init__(self, stream):
        self.stream = stream

    def write(self, text: str) -> None:
        text = text.replace("\r", "\n")
        for line in text.split("\n"):
            if line.strip():
                self.stream.write(line.rstrip() + "\n")

    def flush(self) -> None:
        self.stream.flush()


class Progress:
    """Progress of long work on stderr (tqdm), as a callback ``progress(fraction, note="")``.

    ``Progress("simulate")(0.42, "steel")`` updates a tqdm bar ``simulate  42%|####  | [00:03<00:04, steel]``.
    On a terminal the bar redraws in place (at most 10 times a second); on a non-terminal (a log
    file) it writes one line at the start and at most one line per ``log_interval_s`` (default
    60 s), then the final line: a few lines for a long run, not one per update. ``enabled=False``
    (``--quiet``) writes nothing. ``done()`` (or leaving a ``with`` block, also on Ctrl-C) closes
    the bar. ``sub(lo, hi)`` maps a sub-task's 0..1 onto ``[lo, hi]`` of this bar.
    """

    def __init__(self, label: str, enabled: bool = True, stream=None, log_interval_s: float = 60.0):
        import sys

        self.label, self.enabled = label, enabled
        stream = stream if stream is not None else sys.stderr
        self.tty = bool(getattr(stream, "isatty", lambda: False)())
        self._bar = self._open(stream, log_interval_s) if enabled else None

    def _open(self, stream, log_interval_s: float):
        # the plain bar (tqdm.std), imported only when it is shown: tqdm.auto adds only async iteration
        # and imports asyncio (docs/guide/development.md, start-up times)
        from tqdm.std import tqdm

        return tqdm(total=1000, desc=self.label, leave=True, dynamic_ncols=self.tty,
                    file=stream if self.tty else _LineStream(stream),
                    mininterval=0.1 if self.tty else log_interval_s, miniters=1,
                    bar_format="{desc} {percentage:3.0f}%|{bar:20}| [{elapsed}<{remaining}{postfix}]"
                    if self.tty else "{desc} {percentage:3.0f}% [elapsed {elapsed}, left ~{remaining}{postfix}]")

    def __call__(self, fraction: float, note: str = "") -> None:
        if self._bar is None or self._bar.disable:
            return
        n = int(round(1000 * min(max(float(fraction), 0.0), 1.0)))
        if note:
            self._bar.set_postfix_str(note, refresh=False)
        if n > self._bar.n:
            self._bar.update(n - self._bar.n)
        elif note:
            self._bar.refresh() if self.tty else None

    def done(self, note: str = "") -> None:
        """Complete and close the bar."""
        if self._bar is not None and not self._bar.disable:
            if note:
                self._bar.set_postfix_str(note, refresh=False)
            if self.tty:
                self._bar.update(1000 - self._bar.n)
            else:
                self._bar.n = 1000  # close() writes the final line once
        self.close()

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()

    def __enter__(self) -> "Progress":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

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


def provenance_text(prov: dict) -> str:
    """``"robolobes_version=0.1.0 inputs_sha256=<64 hex>"``: :func:`provenance` as one header line.

    Writers put it where their format allows text (CSV comment, UFF id line, figure metadata) so
    that ``core.outdir.read_provenance`` recognizes the file as written by robolobes."""
    return f"robolobes_version={prov['robolobes_version']} inputs_sha256={prov['inputs_sha256']}"
