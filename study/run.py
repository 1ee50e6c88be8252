"""``run_study``: compute the study and write its output directory."""

from __future__ import annotations

import os
from pathlib import Path

from .compute import compute_study
from .output import to_json, write_study
from .settings import StudySettings

__all__ = ["run_study"]


def run_study(out_dir: str | os.PathLike = "robolobes-study", quick: bool = False, progress=None) -> dict:
    """Run the study and write ``report.md``, ``results.json``, figures and FRFs into ``out_dir``.

    Parameters
    ----------
    out_dir : path
        Target directory, replaced only when the study completes (its parent must exist).
    quick : bool
        Coarser grids and shorter runs (:meth:`StudySettings.make`).
    progress : callable ``(fraction, note)``, optional

    Returns
    -------
    dict
        ``results.json``'s content.
    """
    prog = progress or (lambda f, note="": None)
    target = Path(out_dir).resolve()
    target.parent.mkdir(parents=True, exist_ok=True)
    res = compute_study(StudySettings.make(quick), lambda f: prog(0.97 * f))
    prog(0.97, "report")
    write_study(res, target)
    prog(1.0, "done")
    return to_json(res)
