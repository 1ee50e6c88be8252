"""Interruptions (Ctrl-C, SIGTERM) that always end clean: one line, exit 130 / 143, a resumable output.

The command line installs :func:`handling` around a subcommand. Then:

* the **first** SIGINT or SIGTERM raises :class:`KeyboardInterrupt` in the main thread (a
  ``SIGTERM`` is remembered, so that the exit code is 143 instead of 130);
* **later** signals are counted and ignored: the clean-up that the first one started (stopping the
  workers, writing the "incomplete" marker, removing a staging directory) runs to its end, however
  often the user presses Ctrl-C, and so does the interpreter's exit after it;
* inside :func:`deferred` (a store's creation, a chunk's write, the final swap of a staging
  directory into ``--out``) the first signal waits until the block is done and is raised at its
  end, so a file is never left half written.

Worker processes (:func:`worker_init`) ignore SIGINT (the parent stops them), and exit by
themselves when their parent dies (SIGKILL of the parent included): a thread checks the parent
every ``PARENT_POLL_S``. :func:`blocked` holds SIGINT and SIGTERM back in the thread that starts
the workers, so that a worker never sees one before it ignores it (the signal mask is inherited
across ``fork``/``exec``); the parent itself wraps the start in :func:`deferred` as well, because a
process-directed signal may be taken by another of its threads.

Without :func:`handling` (library use, tests) :func:`deferred` and :func:`blocked` change nothing
visible: Python's default handler raises at once.
"""

from __future__ import annotations

import contextlib
import os
import signal
import threading
import time
from typing import Iterator

__all__ = ["handling", "deferred", "blocked", "worker_init", "exit_code", "PARENT_POLL_S"]

#: How often a worker checks that its parent is alive, s.
PARENT_POLL_S = 0.5
_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class _State:
    def __init__(self) -> None:
        self.active = False
        self.interrupted = 0     # 0 or the signal number that interrupted
        self.ignored = 0         # signals after the first
        self.depth = 0           # nesting of deferred()
        self.pending = 0         # a signal received inside deferred()


_state = _State()


def _handler(signum, frame) -> None:
    if _state.interrupted or _state.pending:
        _state.ignored += 1
        return
    if _state.depth:
        _state.pending = signum
        return
    _state.interrupted = signum
    raise KeyboardInterrupt()


@contextlib.contextmanager
def handling() -> Iterator[_State]:
    """Install the handlers for SIGINT and SIGTERM in the main thread; restore the old ones after."""
    if threading.current_thread() is not threading.main_thread():
        yield _state
        return
    old = {s: signal.getsignal(s) for s in _SIGNALS}
    _state.__init__()
    _state.active = True
    for s in _SIGNALS:
        signal.signal(s, _handler)
    try:
        yield _state
    finally:
        for s, h in old.items():
            # after a signal the process is ending: more signals must not kill it mid-exit
            signal.signal(s, signal.SIG_IGN if _state.interrupted or _state.pending else h)
        _state.active = False


def exit_code() -> int:
    """128 + the signal that interrupted (130 for SIGINT, 143 for SIGTERM); 130 if none was seen
    (a KeyboardInterrupt raised otherwise)."""
    return 128 + int(_state.interrupted or _state.pending or signal.SIGINT)


@contextlib.contextmanager
def deferred() -> Iterator[None]:
    """A block that an interruption does not cut: a signal inside it is raised when it ends."""
    _state.depth += 1
    try:
        yield
    finally:
        _state.depth -= 1
        if _state.depth == 0 and _state.pending and not _state.interrupted:
            _state.interrupted, _state.pending = _state.pending, 0
            raise KeyboardInterrupt()


@contextlib.contextmanager
def blocked() -> Iterator[None]:
    """SIGINT and SIGTERM held back (not lost) in this thread, e.g. while worker processes start."""
    old = signal.pthread_sigmask(signal.SIG_BLOCK, _SIGNALS)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def _watch_parent(ppid: int) -> None:
    while True:
        time.sleep(PARENT_POLL_S)
        if os.getppid() != ppid:   # re-parented: the parent died (even by SIGKILL)
            os._exit(1)


def worker_init(ppid: int | None = None) -> None:
    """Initializer of a worker process: ignore SIGINT, SIGTERM ends it, exit when the parent dies."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, _SIGNALS)
    ppid = os.getppid() if ppid is None else ppid
    if os.getppid() != ppid:
        os._exit(1)
    threading.Thread(target=_watch_parent, args=(ppid,), daemon=True, name="robolobes-parent-watch").start()
