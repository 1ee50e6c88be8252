"""The one error type for bad user input.

The command line maps :class:`BadInput` (and only it) to one line on stderr and exit code 2; any
other exception is an internal error and keeps its traceback. Library modules raise ``BadInput``
(or a subclass named after their concern, e.g. ``CaseError``) for values a user chose: a bad path,
a key that does not exist, a number out of its valid range. The message names the bad value and
what would be valid.
"""

from __future__ import annotations

__all__ = ["BadInput"]


class BadInput(ValueError):
    """A value chosen by the user is invalid; the message says which and what would be valid.

    Subclasses ``ValueError`` so that library callers catching ``ValueError`` keep working.
    """
