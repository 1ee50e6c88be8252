"""Each warning once per run.

Python's ``"default"`` warning action shows a warning once per code location, but every
``warnings.catch_warnings()`` block (robolobes uses several to silence expected warnings) resets
that memory, so the same warning reached again from another step of a job is shown again: the
Tab. 7 joint-limit warning appeared four times in one quick study. :func:`each_warning_once`
remembers what it has shown, by category and message text, for the duration of one run.
"""

from __future__ import annotations

import contextlib
import warnings
from typing import Iterator

__all__ = ["each_warning_once"]


@contextlib.contextmanager
def each_warning_once() -> Iterator[set]:
    """Within the block, a warning with the category and text of one already shown is not shown.

    Wraps :func:`warnings.showwarning` (whatever it is on entry: the terminal, a log, pytest's
    recorder) and restores it on exit, so two runs in one process each show their warnings.
    Filters still apply first: an ignored or once-only warning never reaches the wrapper.

    Yields
    ------
    set of (category, message text)
        The warnings shown so far in the block.
    """
    shown: set = set()
    previous = warnings.showwarning

    def show_new(message, category, filename, lineno, file=None, line=None):
        key = (category, str(message))
        if key in shown:
            return
        shown.add(key)
        previous(message, category, filename, lineno, file, line)

    warnings.showwarning = show_new
    try:
        yield shown
    finally:
        warnings.showwarning = previous
