"""The study: the TX200 model beside the paper's measured facts (``robolobes study``).

Why the paper's cut was stable in aluminium and unstable in steel, computed:
:func:`compute.compute_study` returns a typed :class:`result.StudyResult` (modes, lobes, time
domain, damping search, roughness, Tab. 10); :mod:`output`, :mod:`report` and :mod:`figures`
render it; :mod:`findings` and :mod:`prose` put its comparisons into words computed from the
numbers; :mod:`readme` regenerates the README's block from a ``results.json``.
"""

if __name__ != "robolobes.study":  # this folder imported by itself (from the repository root): a second copy
    raise ImportError(f"{__name__!r} is the folder of the robolobes.study package: import robolobes.study instead")

from .compute import compute_study
from .result import StudyResult
from .run import run_study
from .settings import StudySettings

__all__ = ["compute_study", "run_study", "StudyResult", "StudySettings"]
