"""Shared types and helpers used by every other package (imports nothing from them).

* :mod:`robolobes.core.errors`   -- :class:`BadInput`, the one error type for bad user input;
* :mod:`robolobes.core.verdict`  -- :class:`Verdict`, the one stability verdict (lobes and time domain);
* :mod:`robolobes.core.frf`      -- :class:`FRF`, the one FRF convention ((n_out, n_in, n_freq) m/N,
  omega rad/s, frame label);
* :mod:`robolobes.core.validate` -- the input checks (read-only arrays, finite numbers, integers);
* :mod:`robolobes.core.numerics` -- the one Richardson extrapolation and its error bound;
* :mod:`robolobes.core.threads`  -- BLAS thread limits of the heavy library entry points;
* :mod:`robolobes.core.io`       -- atomic output files, JSON, headless pyplot, progress, provenance;
* :mod:`robolobes.core.outdir`   -- output directories checked before any work;
* :mod:`robolobes.core.warnonce` -- each warning once per run.
"""

if __name__ != "robolobes.core":  # this folder imported by itself (from the repository root): a second copy
    raise ImportError(f"{__name__!r} is the folder of the robolobes.core package: import robolobes.core instead")

from .errors import BadInput
from .frf import FRF
from .verdict import Verdict

__all__ = ["BadInput", "FRF", "Verdict"]
