"""The one protocol for output files and directories: nothing a user owns is overwritten or deleted.

Every ``--out`` of every command goes through this module, **before any work**:

* :func:`check_output_file` for a single file (a CSV, a UFF, a PNG, a JSON);
* :class:`OutputDir` for a directory of results (a study, a simulation, a workspace map).

Rules (stated once; the README's "Command line" section repeats them):

1. The parent directory must exist and be writable (checked by creating and removing a probe).
2. A file target must not be a directory and must have a supported extension; a directory target
   must not be a file.
3. An existing target is replaced only if robolobes wrote it **from the same inputs** (its
   recorded ``inputs_sha256`` equals ``provenance(inputs)["inputs_sha256"]``). Anything else is
   refused with one line (:class:`OutputRefused`, a :class:`BadInput`: exit 2):

   * a file robolobes did not write (no ``robolobes_version`` / ``inputs_sha256`` in its first
     or last 64 KiB: every robolobes writer records them, see ``core.io.provenance_text``);
   * a non-empty directory without the marker file ``.robolobes.json``, or one that holds a file
     its marker does not list (a file the user added), or a file whose content differs from the
     SHA-256 its marker records (a file the user edited; files inside a ``*.zarr`` store are not
     hashed: every chunk carries its own checksum);
   * a robolobes output from other inputs (pass ``replace=True`` to allow replacing it; the CLIs
     do not, so a user deletes or renames an old result explicitly).

4. A directory is written into a staging directory beside the target and swapped in with
   ``os.rename`` only when the work succeeded. On any error or Ctrl-C the staging directory is
   removed (kept, with ``resume=True``, for the next run with the same inputs) and the previous
   output stays exactly as it was. When an old output is replaced, only the files its marker
   lists are deleted; a file robolobes did not write is never deleted.
5. An ``OSError`` while writing into the output becomes one line naming the user's path
   (:func:`user_path_errors`), not a traceback.
6. A resumable output (``resume=True``: the map) is locked for the whole run with an OS lock
   (``fcntl.flock`` on ``.NAME.robolobes-lock`` beside it, which the kernel releases when the
   holder dies, however it dies): a second run on the same target is refused at once, naming the
   holder's process id. The lock file is removed when the run ends; one left by a killed run is
   reused. The marker is written atomically, and the final swap is not cut by a Ctrl-C
   (:func:`robolobes.core.interrupt.deferred`). A staging directory is ``flock``-ed by its run;
   one left by a run that died (nothing holds its lock) is removed by the next run on the target.

Usage::

    from robolobes.core.outdir import OutputDir, check_output_file

    inputs = {"command": "simulate", "case": case_dict, "variant": "basic", "duration_s": 0.5}
    out = OutputDir(args.out, "simulate", inputs)          # checks now: exit 2 before any work
    result = simulate(problem)                             # the long work
    with out:                                              # staging dir; swapped in on success
        write_json(out.path / "summary.json", {**summary, "provenance": out.provenance})
        save_figure(fig, out.path / "forces.png", provenance=out.provenance)

    png = check_output_file(args.out, (".png",), inputs)  # a single file: checked before work
    ...
    with user_path_errors(png):
        save_figure(fig, png, provenance=provenance(inputs))   # atomic (core.io.atomic_path)

Resumable work (e.g. a workspace map written chunk by chunk)::

    out = OutputDir(path, "map", inputs, resume=True)
    with out:
        if out.resumed: ...   # out.path holds what an interrupted run with the same inputs wrote
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import json
import os
import re
import shutil
import tempfile
import time
from pathlib import Path
from typing import Iterable, Iterator

from .errors import BadInput
from .io import provenance as _provenance
from .io import provenance_text, to_jsonable

__all__ = ["MARKER", "OutputRefused", "OutputDir", "check_output_file", "read_provenance", "provenance_text",
           "user_path_errors", "cli_inputs", "file_sha256"]

MARKER = ".robolobes.json"
_MARKER_TMP = MARKER + ".tmp"
_SNIFF_BYTES = 65536
_VERSION_RE = re.compile(rb"robolobes_version\W{1,6}([0-9A-Za-z.+_-]+)")
_HASH_RE = re.compile(rb"inputs_sha256\W{1,6}([0-9a-f]{64})")


class OutputRefused(BadInput):
    """An output path that robolobes will not write to (it would overwrite or delete a user's file)."""


def read_provenance(path: str | os.PathLike) -> dict | None:
    """The robolobes provenance recorded in a file, or None if robolobes did not write it.

    Looks for ``robolobes_version`` and ``inputs_sha256`` in the first and last 64 KiB (JSON key,
    CSV header, PNG text chunk, UFF id line). Returns ``{"robolobes_version", "inputs_sha256"}``.
    """
    p = Path(path)
    try:
        with open(p, "rb") as f:
            head = f.read(_SNIFF_BYTES)
            size = f.seek(0, os.SEEK_END)
            tail = b""
            if size > _SNIFF_BYTES:
                f.seek(max(size - _SNIFF_BYTES, _SNIFF_BYTES))
                tail = f.read()
    except OSError:
        return None
    for chunk in (head, tail):
        v, h = _VERSION_RE.search(chunk), _HASH_RE.search(chunk)
        if v and h:
            return {"robolobes_version": v.group(1).decode(), "inputs_sha256": h.group(1).decode()}
    return None


def _probe_writable(directory: Path, shown: str) -> None:
    """Create and remove a file in ``directory`` (``os.access`` is wrong for root and some mounts)."""
    if not directory.is_dir():
        raise OutputRefused(f"{shown}: the directory {directory} does not exist; create it first")
    try:
        fd, tmp = tempfile.mkstemp(prefix=".robolobes-probe-", dir=directory)
        os.close(fd)
        os.unlink(tmp)
    except OSError as e:
        raise OutputRefused(f"{shown}: cannot write in {directory} ({e.strerror or e}); choose a writable directory") \
            from None


def _check_existing_file(path: Path, digest: str, replace: bool, shown: str) -> None:
    prov = read_provenance(path)
    if prov is None:
        raise OutputRefused(f"{shown} exists and was not written by robolobes; it is left untouched: "
                            "choose another path or move it away")
    if prov["inputs_sha256"] != digest and not replace:
        raise OutputRefused(f"{shown} was written by robolobes from other inputs (inputs_sha256 "
                            f"{prov['inputs_sha256'][:12]}...); it is kept: choose another path or delete it")


def check_output_file(path: str | os.PathLike, suffixes: Iterable[str], inputs, *, replace: bool = False,
                      name: str = "--out") -> Path:
    """Check a single output file before any work; returns it as a Path.

    Parameters
    ----------
    path : path of the file to write
    suffixes : the supported extensions, e.g. ``(".csv", ".uff")`` (case-insensitive)
    inputs : JSON-able description of the inputs (as given to ``core.io.provenance``)
    replace : allow replacing a robolobes file written from *other* inputs (never a user's file)
    name : the option named in messages

    Raises
    ------
    OutputRefused (a BadInput)
        Unsupported extension, the target is a directory, the parent does not exist or is not
        writable, or the target exists and robolobes did not write it from these inputs.
    """
    p = Path(path)
    shown = f"{name} {path}"
    allowed = tuple(s.lower() for s in suffixes)
    if p.suffix.lower() not in allowed:
        raise OutputRefused(f"{shown}: the extension must be one of {', '.join(allowed)}")
    if p.is_dir():
        raise OutputRefused(f"{shown} is a directory; give a file name ending in {' or '.join(allowed)}")
    _probe_writable(p.parent if str(p.parent) else Path("."), shown)
    if p.exists() or p.is_symlink():
        _check_existing_file(p, _provenance(inputs)["inputs_sha256"], replace, shown)
    return p


def _chained(e: BaseException | None, kinds) -> BaseException | None:
    """The first exception of type ``kinds`` in ``e``'s cause/context chain (``e`` included)."""
    seen = set()
    while e is not None and id(e) not in seen:
        if isinstance(e, kinds):
            return e
        seen.add(id(e))
        e = e.__cause__ or e.__context__
    return None


@contextlib.contextmanager
def user_path_errors(path: str | os.PathLike, action: str = "write") -> Iterator[None]:
    """Turn any ``OSError`` in the block into one :class:`BadInput` line naming the user's ``path``.

    Libraries that wrap every exception in a bare ``except:`` (pyuff raises ``Exception("Error
    writing data-set #58")`` for a Ctrl-C or a full disk) are unwrapped: a ``KeyboardInterrupt``
    in the chain is raised again as one (exit 130), an ``OSError`` becomes the one line."""
    try:
        yield
    except BadInput:
        raise
    except Exception as e:
        cause = _chained(e, (KeyboardInterrupt, OSError))
        if isinstance(cause, KeyboardInterrupt):
            raise KeyboardInterrupt() from e
        if isinstance(cause, OSError):
            raise BadInput(f"cannot {action} {path}: {cause.strerror or cause}") from e
        raise


def file_sha256(path: str | os.PathLike) -> str:
    """SHA-256 of a file's bytes (an input file's identity in ``inputs``)."""
    import hashlib

    with user_path_errors(path, "read"):
        return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def cli_inputs(args, *, case=None, files: dict | None = None,
               drop: Iterable[str] = ("run", "quiet", "json", "out")) -> dict:
    """The inputs of one command run, for :func:`robolobes.core.io.provenance` and the markers.

    ``args``: the parsed options (those in ``drop`` do not change the results); ``case``: the
    loaded case (a dataclass: every parsed value, so an edited case file changes the hash);
    ``files``: ``{name: path}`` of other input files, recorded by content (:func:`file_sha256`).
    """
    import dataclasses

    opts = {k: v for k, v in sorted(vars(args).items()) if k not in set(drop) and not callable(v)}
    out = {"command": getattr(args, "command", None), "options": to_jsonable(opts)}
    if case is not None:
        out["case"] = to_jsonable(dataclasses.asdict(case))
    if files:
        out["files_sha256"] = {k: file_sha256(v) for k, v in files.items()}
    return out


def _files_under(root: Path) -> list[str]:
    """Relative POSIX paths of every non-directory entry under ``root`` (the marker excluded)."""
    out = []
    for dirpath, dirnames, filenames in os.walk(root, followlinks=False):
        rel = Path(dirpath).relative_to(root)
        for d in dirnames:  # symlinked directories are entries too (never followed)
            if (Path(dirpath) / d).is_symlink():
                out.append((rel / d).as_posix())
        out += [(rel / f).as_posix() for f in filenames]
    return sorted(f for f in out if f not in (MARKER, _MARKER_TMP))


def _read_marker(directory: Path) -> dict | None:
    try:
        m = json.loads((directory / MARKER).read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(m, dict) or not isinstance(m.get("files"), list) or "provenance" not in m:
        return None
    return m


class OutputDir:
    """A directory of results, checked before the work and swapped in atomically after it.

    Parameters
    ----------
    path : the target directory (the user's ``--out``)
    command : the subcommand writing it (recorded in the marker), e.g. ``"study"``
    inputs : JSON-able description of everything that determines the results
    resume : keep the staging directory after an error or Ctrl-C and reuse it in the next run
        with the same inputs (``self.resumed`` says whether it did)
    replace : allow replacing a robolobes output written from other inputs
    name : the option named in messages

    Attributes
    ----------
    target : Path
        The final directory.
    provenance : dict
        ``{"robolobes_version", "inputs_sha256"}`` of ``inputs``; record it in every JSON.
    path : Path
        The staging directory to write into (valid inside ``with``).
    resumed : bool

    Raises
    ------
    OutputRefused
        (exit 2) From the constructor, when the target may not be written.
    """

    def __init__(self, path: str | os.PathLike, command: str, inputs, *, resume: bool = False,
                 replace: bool = False, name: str = "--out"):
        self.target = Path(path)
        self.command, self.resume, self.replace = command, resume, replace
        self.inputs = to_jsonable(inputs)
        self.provenance = _provenance(inputs)
        self._shown = f"{name} {path}"
        self.path: Path | None = None
        self.resumed = False
        self._open = False
        self._lock: tuple[int, Path] | None = None
        self._stage_fd: int | None = None
        if resume:
            self._lock = _acquire_lock(self.target, self._shown)
        _finish_dead_swaps(self.target)   # before the check: it may put the previous output back
        self.check()
        _remove_dead_stages(self.target)

    def release(self) -> None:
        """Release the output's locks (done by commit and discard; the kernel does it if we die)."""
        if self._stage_fd is not None:
            os.close(self._stage_fd)
            self._stage_fd = None
        if self._lock is not None:
            fd, path = self._lock
            self._lock = None
            with contextlib.suppress(OSError):
                path.unlink()      # while still holding the lock: see _acquire_lock
            os.close(fd)

    def __del__(self) -> None:
        with contextlib.suppress(Exception):
            self.release()

    # -- checks ---------------------------------------------------------------------------------
    @property
    def _partial(self) -> Path:
        return self.target.parent / f".{self.target.name}.robolobes-partial"

    def check(self) -> None:
        """Refuse (``OutputRefused``) a target this run may not replace; called before any work."""
        t, shown = self.target, self._shown
        if t.name in ("", ".", ".."):
            raise OutputRefused(f"{shown}: give a directory name (not {str(t)!r})")
        if t.exists() and not t.is_dir() or t.is_symlink():
            raise OutputRefused(f"{shown} exists and is not a directory; it is left untouched: choose another path")
        _probe_writable(t.parent, shown)
        if t.is_dir():
            self._check_existing_dir(t)
        if self.resume and self._partial.exists():
            self._check_existing_dir(self._partial, partial=True)

    def _check_existing_dir(self, d: Path, partial: bool = False) -> None:
        """Refuse ``d`` unless empty, or a robolobes output (every file listed) from these inputs.

        ``partial``: our own hidden staging directory of an interrupted run; its marker may predate
        files written before a hard kill, so only the marker and the inputs are checked."""
        shown = self._shown
        try:
            entries = _files_under(d)
            empty = not any(d.iterdir())
        except OSError as e:
            raise OutputRefused(f"{shown}: cannot read {d} ({e.strerror or e})") from None
        if empty:
            return
        marker = _read_marker(d)
        if marker is None:
            raise OutputRefused(f"{shown} is a directory that robolobes did not write (no valid {MARKER}); its files "
                                "are left untouched: choose a new or empty directory")
        foreign = [] if partial else sorted(set(entries) - set(marker["files"]))
        if foreign:
            raise OutputRefused(f"{shown} holds {foreign[0]!r}, which robolobes did not write; the directory is left "
                                "untouched: move that file or choose another directory")
        changed = [] if partial else _changed_files(d, marker)
        if changed:
            raise OutputRefused(f"{shown} holds {changed[0]!r}, changed since robolobes wrote it; the directory is "
                                "left untouched: move that file away (or delete it) to run again")
        digest = marker["provenance"].get("inputs_sha256")
        if digest != self.provenance["inputs_sha256"] and not self.replace:
            raise OutputRefused(f"{shown} holds a robolobes {marker.get('command', '')} output from other inputs "
                                f"(inputs_sha256 {str(digest)[:12]}...); it is kept: choose another directory or "
                                "delete it")

    # -- staging --------------------------------------------------------------------------------
    def _marker(self, files: list[str], complete: bool, d: Path | None = None) -> dict:
        m = {"command": self.command, "provenance": self.provenance, "inputs": self.inputs,
             "complete": complete, "written": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "files": files}
        if complete and d is not None:
            m["sha256"] = {f: _sha256_of(d / f) for f in files if _hashed(f) and (d / f).is_file()}
        return m

    def _write_marker(self, d: Path, complete: bool) -> None:
        """Write the marker atomically (a kill never leaves an empty or half-written one)."""
        tmp = d / _MARKER_TMP
        tmp.write_text(json.dumps(self._marker(_files_under(d), complete, d), indent=2) + "\n")
        os.replace(tmp, d / MARKER)

    def open(self) -> Path:
        """Re-check the target and create the staging directory (reused with ``resume``); returns it.

        Prefer ``with out:``; ``open`` / ``commit`` / ``discard`` are for code whose ``try`` block
        already exists (``discard`` in its ``finally`` is a no-op after ``commit``)."""
        self.check()  # the target may have changed while the work ran
        with user_path_errors(self.target, "create the staging directory for"):
            if self.resume:
                self.path = self._partial
                if self.path.is_dir() and _read_marker(self.path) is not None:
                    self.resumed = True
                elif self.target.is_dir() and _read_marker(self.target) is not None:
                    shutil.copytree(self.target, self.path, symlinks=True)
                    self.resumed = True
                else:
                    self.path.mkdir(exist_ok=True)
                self._write_marker(self.path, complete=False)
            else:
                self.path = Path(tempfile.mkdtemp(prefix=f".{self.target.name}.robolobes-stage-", dir=self.target.parent))
                self._stage_fd = _lock_dir(self.path)   # held while alive: a later run knows it is not stale
        self._open = True
        return self.path

    def __enter__(self) -> "OutputDir":
        self.open()
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        if exc_type is None:
            self.commit()
            return False
        self.discard()
        if isinstance(exc, OSError) and self._about_output(exc):
            raise BadInput(f"cannot write {self.target}: {exc.strerror or exc}") from exc
        return False

    def _about_output(self, e: OSError) -> bool:
        if e.errno in (errno.ENOSPC, errno.EDQUOT, errno.EROFS):
            return True
        staging = str(self.path) if self.path else None
        return any(staging and str(f).startswith(staging) for f in (e.filename, e.filename2) if f)

    def discard(self) -> None:
        """Drop the staging directory (kept, marked incomplete, with ``resume``); the target is untouched."""
        if not self._open:
            return
        assert self.path is not None  # open() set it
        self._open = False
        from .interrupt import deferred

        with deferred():
            if self.resume:
                with contextlib.suppress(OSError):
                    self._write_marker(self.path, complete=False)
            else:
                shutil.rmtree(self.path, ignore_errors=True)  # the staging directory is entirely ours
        self.release()

    def commit(self) -> None:
        """Write the marker, re-check the target and swap the staging directory in; ``path`` becomes the target."""
        if not self._open:
            raise RuntimeError("OutputDir.commit() without open()")
        assert self.path is not None  # open() set it
        from .interrupt import deferred

        with deferred():   # the swap and the removal of the old output are not cut by a Ctrl-C
            old, old_fd = None, None
            try:
                with user_path_errors(self.target):
                    self._write_marker(self.path, complete=True)
                    self.check()
                    if self.target.exists():
                        # locked before it is renamed, so that a later run knows it is not a dead run's
                        old_fd = _lock_dir(self.target, wait=True)
                        old = self.target.parent / f".{self.target.name}{_OLD}{os.urandom(4).hex()}"
                        os.rename(self.target, old)
                    try:
                        os.rename(self.path, self.target)
                    except BaseException:
                        if old is not None:
                            os.rename(old, self.target)
                        raise
            except BaseException:
                if old_fd is not None:
                    os.close(old_fd)
                self.discard()
                raise
            self._open = False
            self.path = self.target
            if old is not None:
                _remove_listed(old)
            if old_fd is not None:
                os.close(old_fd)
            self.release()


def _lock_dir(d: Path, wait: bool = False) -> int:
    """An open descriptor of directory ``d`` holding an exclusive ``flock`` on it (``wait``: block
    until it is free, else raise ``BlockingIOError`` if another process holds it)."""
    fd = os.open(d, os.O_RDONLY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | (0 if wait else fcntl.LOCK_NB))
    except BaseException:
        os.close(fd)
        raise
    return fd


#: infix of a replaced output while the swap runs: ``.NAME.robolobes-old-XXXXXXXX`` (8 hex digits)
_OLD = ".robolobes-old-"


def _finish_dead_swaps(target: Path) -> None:
    """Finish the swap of a run that died inside :meth:`OutputDir.commit` (SIGKILL, power loss).

    The previous output is renamed to ``.NAME.robolobes-old-XXXXXXXX`` while locked by the
    committing run (an ``flock`` the kernel drops when that run dies). Such a directory, recognized
    by its name AND a valid marker AND a free lock, is a dead run's: if the target exists, the
    swap was done and only the files its marker lists are deleted (:func:`_remove_listed`); if the
    target is missing, the run died between the two renames and the previous output is put back.
    A directory of a live run, or one without a marker, is never touched."""
    for d in _dead_dirs(target, _OLD, r"[0-9a-f]{8}"):
        if _read_marker(d) is None:
            continue   # named like ours but not ours
        with contextlib.suppress(OSError):
            if target.exists() or target.is_symlink():
                _remove_listed(d)
            else:
                os.rename(d, target)


def _dead_dirs(target: Path, infix: str, tail: str) -> Iterator[Path]:
    """The directories ``.NAME{infix}{tail}`` (``tail`` a regex) beside ``target`` whose ``flock``
    no process holds (their run died); each is yielded while this process holds its lock."""
    pattern = re.compile(re.escape(f".{target.name}{infix}") + tail)
    try:
        entries = sorted(target.parent.iterdir())
    except OSError:
        return
    for d in entries:
        if not pattern.fullmatch(d.name) or d.is_symlink() or not d.is_dir():
            continue
        try:
            fd = _lock_dir(d)
        except OSError:
            continue   # a live run's
        try:
            yield d
        finally:
            os.close(fd)


def _remove_dead_stages(target: Path) -> None:
    """Remove the staging directories of ``target`` left by runs that died (SIGKILL, power loss).

    A staging directory is ``.NAME.robolobes-stage-XXXXXXXX`` (made by :meth:`OutputDir.open`,
    entirely ours) and its run holds a ``flock`` on it while alive; one that can be locked now has
    no live holder, so it is removed. Staging directories of live runs and anything else are kept."""
    for d in _dead_dirs(target, ".robolobes-stage-", r"[A-Za-z0-9_]{8}"):
        shutil.rmtree(d, ignore_errors=True)


def _acquire_lock(target: Path, shown: str) -> tuple[int, Path]:
    """An exclusive ``flock`` on ``.NAME.robolobes-lock`` beside ``target``; OutputRefused if held.

    The holder removes the file when it is done, while holding the lock; so after locking, the
    path must still name the locked file (else another run removed it meanwhile: try again)."""
    lock = target.parent / f".{target.name}.robolobes-lock"
    for _ in range(100):
        try:
            fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as e:
            raise OutputRefused(f"{shown}: cannot create the lock {lock} ({e.strerror or e})") from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.read(fd, 32).decode(errors="replace").strip() or "?"
            os.close(fd)
            raise OutputRefused(f"{shown} is in use by another robolobes run (process {holder}); wait for it to "
                                "end or choose another directory") from None
        try:
            same = os.fstat(fd).st_ino == os.stat(lock).st_ino
        except FileNotFoundError:
            same = False
        if same:
            os.ftruncate(fd, 0)
            os.write(fd, f"{os.getpid()}\n".encode())
            return fd, lock
        os.close(fd)
    raise OutputRefused(f"{shown}: could not lock {lock}; try again")


def _hashed(rel: str) -> bool:
    """Files whose content the marker records: all but those inside a zarr store (``*.zarr/``),
    which carries a checksum in every chunk and is verified by its reader."""
    return not any(part.endswith(".zarr") for part in rel.split("/")[:-1])


def _sha256_of(path: Path) -> str:
    import hashlib

    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _changed_files(d: Path, marker: dict) -> list[str]:
    """Files of a finished output whose content differs from what its marker records (a user's edit)."""
    out = []
    for rel, digest in sorted((marker.get("sha256") or {}).items()):
        f = d / rel
        try:
            if f.is_file() and _sha256_of(f) != digest:
                out.append(rel)
        except OSError:
            out.append(rel)
    return out


def _remove_listed(old: Path) -> None:
    """Delete a replaced robolobes output: only the files its marker lists, then empty directories."""
    marker = _read_marker(old)
    listed = marker["files"] if marker else []
    for rel in listed:
        with contextlib.suppress(OSError):
            (old / rel).unlink()
    with contextlib.suppress(OSError):
        (old / MARKER).unlink()
    for dirpath, _dirs, _files in sorted(os.walk(old, topdown=False), key=lambda w: -len(w[0])):
        with contextlib.suppress(OSError):
            Path(dirpath).rmdir()  # fails, and keeps it, if anything unlisted is left inside
