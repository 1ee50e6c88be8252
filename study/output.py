"""Write a :class:`StudyResult` into one directory: ``results.json`` (:func:`to_json`), the
report, the figures and the FRF files."""

from __future__ import annotations

import os
from pathlib import Path

from robolobes.core.io import write_json, write_text

from .figures import write_figures
from .report import render_report
from .result import StudyResult
from .results_json import SOURCE, damping_json, facts_json, to_json

__all__ = ["to_json", "write_study", "damping_json", "facts_json", "SOURCE"]


def _write_frfs(res: StudyResult, work: Path) -> None:
    from robolobes.linearize.frf_io import write_frf
    (work / "frf").mkdir(exist_ok=True)
    for m in res.modes:
        write_frf(m.frf, work / m.frf_file)


def write_study(res: StudyResult, directory: str | os.PathLike) -> Path:
    """Write ``report.md``, ``results.json``, the figures and the FRF CSVs into ``directory``
    (which must exist; :func:`robolobes.study.run.run_study` gives it a staging directory that
    replaces the target only when complete)."""
    work = Path(directory)
    _write_frfs(res, work)
    write_figures(res, work)
    write_json(work / "results.json", to_json(res))
    write_text(work / "report.md", render_report(res))
    return work
