"""``identify(measurement, model, ...)``: recognise the measurement, run its pipeline, return typed results.

Kinds of measurement sets (recognised from their files, see :func:`measurement_kind`):

=============== ============================================= ==========================================
kind            files                                         reader / pipeline
=============== ============================================= ==========================================
``frf``         ``poses.csv`` + ``<pose>.uff|.unv|.csv``      ``linearize.frf_io.read_frf_set`` /
                                                              ``identify.frf.identify_frf``
``forces``      ``forces.csv`` + ``cut.toml``                 ``identify.forces``
``force_stats`` ``force_stats.toml``                          ``identify.forces``
``stability``   ``stability.csv``                             ``identify.forces``
=============== ============================================= ==========================================

Every pipeline has the signature ``pipeline(measurement, model: ModelState, *, alpha, max_effects,
progress, effects=None) -> Identification`` (``effects``: the candidate Effect objects, default the
library's default candidates for the kind); every reader ``reader(path) -> measurement`` with attributes ``kind``,
``path``, ``case`` (the case named in the files, or None) and ``variant`` (or None).
"""

from __future__ import annotations

import importlib
from pathlib import Path
from typing import Any, Callable

from robolobes.core.errors import BadInput

from .effects import ModelState
from .result import Identification

__all__ = ["identify", "read_measurement", "measurement_kind", "model_state", "READERS", "PIPELINES"]

READERS = {"frf": ("robolobes.linearize.frf_io", "read_frf_set"),
           "forces": ("robolobes.identify.forces", "read_forces"),
           "force_stats": ("robolobes.identify.forces", "read_force_stats"),
           "stability": ("robolobes.identify.forces", "read_stability")}
PIPELINES = {"frf": ("robolobes.identify.frf", "identify_frf"),
             "forces": ("robolobes.identify.forces", "identify_forces"),
             "force_stats": ("robolobes.identify.forces", "identify_force_stats"),
             "stability": ("robolobes.identify.forces", "identify_stability")}

# a file that identifies its set's kind
_MARKERS = {"poses.csv": "frf", "forces.csv": "forces", "cut.toml": "forces", "force_stats.toml": "force_stats",
            "stability.csv": "stability"}


def _load(table, kind) -> Callable:
    module, name = table[kind]
    return getattr(importlib.import_module(module), name)


def measurement_kind(path: str | Path) -> tuple[str, Path]:
    """``(kind, path to hand to the reader)`` for a set's directory or one of its files."""
    p = Path(path)
    if not p.exists():
        raise BadInput(f"--measured {path}: no such file or directory")
    if p.is_file():
        if p.name in _MARKERS:
            kind = _MARKERS[p.name]
            return kind, p.parent if kind in ("frf", "forces") else p
        if p.suffix.lower() in (".uff", ".unv", ".csv") and (p.parent / "poses.csv").is_file():
            return "frf", p.parent
        raise BadInput(f"--measured {path}: not a measurement file; valid: a directory or one of "
                       f"{', '.join(_MARKERS)}, or a pose's .uff/.unv/.csv beside poses.csv")
    found = [k for name, k in _MARKERS.items() if (p / name).is_file()]
    kinds = sorted(set(found))
    if len(kinds) != 1:
        raise BadInput(f"--measured {path}: {'no' if not kinds else 'more than one'} measurement set in the "
                       f"directory ({', '.join(kinds) or 'none of ' + ', '.join(_MARKERS)})")
    kind = kinds[0]
    target = p if kind in ("frf", "forces") else p / next(n for n, k in _MARKERS.items() if k == kind)
    return kind, target


def read_measurement(path: str | Path) -> Any:
    """Read a measurement set of any kind (files are never modified)."""
    kind, target = measurement_kind(path)
    return _load(READERS, kind)(target)


def model_state(measurement, case: str | None = None, variant: str | None = None) -> tuple[ModelState, list[str]]:
    """The starting model: the case named by ``case`` (overrides the file's, with a note), else the file's.

    Returns the state and notes for stderr.
    """
    from robolobes.cases.loader import DEFAULT_CASE, load_case
    from robolobes.linearize.model import VARIANTS

    notes = []
    named = getattr(measurement, "case", None)
    if case is not None and named is not None and case != named:
        notes.append(f"--case {case} overrides the case {named!r} named in the measurement")
    ref = case or named or DEFAULT_CASE
    var = variant or getattr(measurement, "variant", None) or "basic"
    if var not in VARIANTS:
        raise BadInput(f"--variant {var}: valid: {', '.join(VARIANTS)}")
    return ModelState(case=load_case(ref), variant=var, case_ref=str(ref)), notes


def identify(measurement, model: ModelState, *, alpha: float = 0.01, max_effects: int = 3,
             progress: Callable[[str], None] | None = None, **options) -> Identification:
    """Identify the effects ``model`` lacks from ``measurement`` (any kind).

    Parameters
    ----------
    measurement : a measurement object from :func:`read_measurement` (``kind`` selects the pipeline)
    model : ModelState
    alpha : float
        Family-wise false-positive rate of the selection over the library (default 1 %).
    max_effects : int
        At most this many effects are added (greedy).
    options
        Passed to the kind's pipeline (e.g. ``poles=False`` for FRF sets).

    Examples
    --------
    A tool-tip FRF set of the aluminium case written with a 200 Hz tool-holder mode the model
    lacks (0.2 kg modal mass along x, 3 % damping; 2 poses, 150 lines 2-300 Hz, 1 % noise): the
    mode is found, the held-out error falls from the whole response to the noise floor
    (``max_effects=1`` keeps the example to one step of the search, about 3 s of CPU; the default
    gives the same answer here in about three times the time).

    >>> import math, tempfile
    >>> import numpy as np
    >>> from robolobes.cases import load_case
    >>> from robolobes.identify.synthetic import synthetic_frf_set
    >>> from robolobes.linearize.extra_elements import TcpMode
    >>> d = tempfile.mkdtemp() + "/set"
    >>> mode = TcpMode(200.0, 0.03, 0.2 * (2 * math.pi * 200.0) ** 2, (1.0, 0.0, 0.0))
    >>> _ = synthetic_frf_set(d, load_case("tx200-aluminium"), elements=(mode,), n_poses=2,
    ...                       f_hz=np.linspace(2, 300, 150), rel_noise=0.01, add_noise=0.01, seed=5)
    >>> measurement = read_measurement(d)
    >>> res = identify(measurement, model_state(measurement)[0], max_effects=1, poles=False)
    >>> [(e.name, round(e.params["freq_hz"], 1)) for e in res.effects]
    [('tcp_mode', 200.0)]
    >>> res.error_before > 0.5, res.error_after < 1.1 * res.noise_floor
    (True, True)
    """
    if not 0 < alpha < 1:
        raise BadInput(f"alpha = {alpha}: must be in (0, 1)")
    if not 0 <= max_effects <= 10:
        raise BadInput(f"max_effects = {max_effects}: must be in 0..10 (each step fits every candidate)")
    kind = measurement.kind
    if kind not in PIPELINES:
        raise BadInput(f"measurement kind {kind!r}; valid: {', '.join(PIPELINES)}")
    from threadpoolctl import threadpool_limits

    # the fits' matrices are small (a few thousand rows by a few columns, 7-20 DOF): threaded BLAS only
    # adds contention (a least-squares SVD took 30x the CPU with two threads on a loaded machine)
    # (the pipeline is imported first: a BLAS loaded inside the context would keep its threads)
    pipeline = _load(PIPELINES, kind)
    with threadpool_limits(1):
        return pipeline(measurement, model, alpha=alpha, max_effects=max_effects, progress=progress, **options)
