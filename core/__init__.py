"""Shared types and helpers used by every other package (imports nothing from them).

* :mod:`robolobes.core.errors`  -- :class:`BadInput`, the one error type for bad user input;
* :mod:`robolobes.core.verdict` -- :class:`Verdict`, the one stability verdict (lobes and time domain);
* :mod:`robolobes.core.io`      -- atomic output files, JSON, headless pyplot, progress.
"""

from .errors import BadInput
from .verdict import Verdict

__all__ = ["BadInput", "Verdict"]
