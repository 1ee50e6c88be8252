"""``run_study``: compute the study and write its output directory."""

from __future__ import annotations

import os

from .compute import compute_study, load_inputs, study_inputs
from .output import to_json, write_study
from .settings import StudySettings

__all__ = ["run_study", "study_output"]


def study_output(out_dir: str | os.PathLike, quick: bool):
    """The study's settings and its output directory, checked before any work (``OutputRefused``:
    the target may not be written). Returns ``(StudySettings, core.outdir.OutputDir)``."""
    from robolobes.core.outdir import OutputDir

    settings = StudySettings.make(quick)
    cs, _, paper = load_inputs()
    return settings, OutputDir(out_dir, "study", study_inputs(settings, cs, paper))


def run_study(out_dir: str | os.PathLike = "robolobes-study", quick: bool = False, progress=None) -> dict:
    """Run the study and write ``report.md``, ``results.json``, figures and FRFs into ``out_dir``.

    The target is checked before any work (:class:`robolobes.core.outdir.OutputDir`: an existing
    file, or a directory robolobes did not write from these inputs, is refused with
    :class:`~robolobes.core.outdir.OutputRefused`), written into a staging directory and swapped in
    only when complete.

    Parameters
    ----------
    out_dir : path
        Target directory (its parent must exist).
    quick : bool
        Coarser grids and shorter runs (:meth:`StudySettings.make`).
    progress : callable ``(fraction, note)``, optional

    Returns
    -------
    dict
        ``results.json``'s content.
    """
    prog = progress or (lambda f, note="": None)
    settings, out = study_output(out_dir, quick)
    res = compute_study(settings, lambda f: prog(0.97 * f))
    prog(0.97, "report")
    with out:
        assert out.path is not None  # set by entering the OutputDir
        write_study(res, out.path)
    prog(1.0, "done")
    return to_json(res)
