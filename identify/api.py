"""``identify(problem, method)``: run the method's selection on the problem's measurement, return typed results.

In the shape of :mod:`robolobes.lobes` (problem / method / solve)::

    measurement = read_measurement("rig/frf")                  # FRFSet, ForceSeries, ... (frozen)
    model, notes = model_state(measurement)                   # the case named in the files
    result = identify(IdentifyProblem(measurement, model), StepwiseSelection(alpha=0.01))

Kinds of measurement sets (recognised from their files, see :func:`measurement_kind`), with their
type and default method:

* ``frf``: ``poses.csv`` + ``<pose>.uff|.unv|.csv``; ``FRFSet`` (``read_frf_set``); ``StepwiseSelection``;
* ``forces``: ``forces.csv`` + ``cut.toml``; ``ForceSeries``; ``ForwardSelection``;
* ``force_stats``: ``force_stats.toml``; ``ForceStatistics``; ``AICcSelection``;
* ``stability``: ``stability.csv``; ``StabilityObservations``; ``StabilitySelection``.

:func:`identify` dispatches on the measurement's type (:data:`PIPELINES`); a method of another
kind is refused (BadInput).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Callable

from robolobes.core.errors import BadInput
from robolobes.linearize.frf_io import FRFSet, read_frf_set

from .effects import ModelState
from .force_data import (ForceSeries, ForceStatistics, StabilityObservations, read_force_set, read_force_stats,
                         read_stability)
from .method import AICcSelection, ForwardSelection, Method, StabilitySelection, StepwiseSelection
from .problem import IdentifyProblem, Measurement
from .result import Identification

__all__ = ["identify", "read_measurement", "measurement_kind", "model_state", "default_method", "READERS",
           "PIPELINES"]

#: The reader of each kind of set (path -> measurement).
READERS: dict[str, Callable] = {"frf": read_frf_set, "forces": read_force_set, "force_stats": read_force_stats,
                                "stability": read_stability}

Progress = Callable[[str], None] | None


def _frf(problem: IdentifyProblem, method: StepwiseSelection, progress: Progress) -> Identification:
    from .frf import identify_frf

    assert isinstance(problem.measurement, FRFSet)
    return identify_frf(problem.measurement, problem.model, alpha=method.alpha, max_effects=method.max_effects,
                        progress=progress, poles=method.poles, effects=problem.effects)


def _forces(problem: IdentifyProblem, method: ForwardSelection, progress: Progress) -> Identification:
    from .forces import identify_forces

    assert isinstance(problem.measurement, ForceSeries)
    return identify_forces(problem.measurement, problem.model, alpha=method.alpha, max_effects=method.max_effects,
                           progress=progress, effects=problem.effects)


def _force_stats(problem: IdentifyProblem, method: AICcSelection, progress: Progress) -> Identification:
    from .forces import identify_force_stats

    assert isinstance(problem.measurement, ForceStatistics)
    return identify_force_stats(problem.measurement, problem.model, max_effects=method.max_effects,
                                progress=progress, effects=problem.effects)


def _stability(problem: IdentifyProblem, method: StabilitySelection, progress: Progress) -> Identification:
    from .force_stability import identify_stability

    assert isinstance(problem.measurement, StabilityObservations)
    return identify_stability(problem.measurement, problem.model, effects=problem.effects,
                              max_effects=method.max_effects, progress=progress)


#: measurement type -> (its method type, the pipeline ``(problem, method, progress) -> Identification``).
PIPELINES: dict[type, tuple[type, Callable]] = {FRFSet: (StepwiseSelection, _frf),
                                                ForceSeries: (ForwardSelection, _forces),
                                                ForceStatistics: (AICcSelection, _force_stats),
                                                StabilityObservations: (StabilitySelection, _stability)}


def default_method(measurement, **fields) -> Method:
    """The method of ``measurement``'s kind with ``fields`` set (BadInput for a field it does not have)."""
    cls = PIPELINES[_measurement_type(measurement)][0]
    unknown = sorted(set(fields) - set(cls.field_names()))
    if unknown:
        raise BadInput(f"{', '.join(unknown)}: not used with {measurement.kind} measurements ({cls.__name__}); "
                       f"valid: {', '.join(cls.field_names())}")
    return cls(**fields)


def _measurement_type(measurement) -> type:
    for t in PIPELINES:
        if isinstance(measurement, t):
            return t
    raise BadInput(f"measurement: a {type(measurement).__name__}; valid: {', '.join(t.__name__ for t in PIPELINES)}")


# a file that identifies its set's kind
_MARKERS = {"poses.csv": "frf", "forces.csv": "forces", "cut.toml": "forces", "force_stats.toml": "force_stats",
            "stability.csv": "stability"}


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


def read_measurement(path: str | Path) -> Measurement:
    """Read a measurement set of any kind (files are never modified)."""
    kind, target = measurement_kind(path)
    return READERS[kind](target)


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


def identify(problem: IdentifyProblem, method: Method | None = None, *,
             progress: Callable[[str], None] | None = None) -> Identification:
    """Identify the effects ``problem.model`` lacks from ``problem.measurement`` (any kind).

    Parameters
    ----------
    problem : IdentifyProblem
        The measurement (its type selects the pipeline), the model, the candidate effects.
    method : StepwiseSelection, ForwardSelection, AICcSelection or StabilitySelection, optional
        The selection rule; default the measurement kind's with its default fields (:func:`default_method`).
        A method of another kind is refused (BadInput).
    progress : callable ``(message)``, optional

    Returns
    -------
    Identification
        Carries its problem and method (``result.problem``, ``result.method``).

    Examples
    --------
    A method's fields are checked when it is made, before any work.

    >>> StepwiseSelection(alpha=0.05, max_effects=2)
    StepwiseSelection(alpha=0.05, max_effects=2, poles=True)
    >>> StabilitySelection(max_effects=11)
    Traceback (most recent call last):
    ...
    robolobes.core.errors.BadInput: StabilitySelection: max_effects = 11: must be an integer in 0..10 (each step fits every candidate)

    Runs on each kind of measurement: ``tests/test_identify_api_shape.py``. A tool-tip FRF set of the aluminium case written with a 200 Hz tool-holder mode the model
    lacks (0.2 kg modal mass along x, 3 % damping; 2 poses, 150 lines 2-300 Hz, 1 % noise): the
    mode is found, the held-out error falls from the whole response to the noise floor
    (``max_effects=1`` keeps the example to one step of the search, about 3 s of CPU; the default
    gives the same answer here in about three times the time).

    >>> import math, tempfile
    >>> import numpy as np
    >>> from robolobes.cases import load_case
    >>> from robolobes.identify.synthetic import synthetic_frf_set
    >>> from robolobes.linearize.tool import TcpOscillator
    >>> d = tempfile.mkdtemp() + "/set"
    >>> mode = TcpOscillator.one_axis(200.0, 0.03, 0.2 * (2 * math.pi * 200.0) ** 2, (1.0, 0.0, 0.0))
    >>> _ = synthetic_frf_set(d, load_case("tx200-aluminium"), elements=(mode,), n_poses=2,
    ...                       f_hz=np.linspace(2, 300, 150), rel_noise=0.01, add_noise=0.01, seed=5)
    >>> measurement = read_measurement(d)
    >>> problem = IdentifyProblem(measurement, model_state(measurement)[0])
    >>> res = identify(problem, StepwiseSelection(max_effects=1, poles=False))
    >>> [(e.name, round(e.params["freq_hz"], 1)) for e in res.effects]
    [('tcp_mode', 200.0)]
    >>> res.error_before > 0.5, res.error_after < 1.1 * res.noise_floor
    (True, True)
    """
    if not isinstance(problem, IdentifyProblem):
        raise BadInput(f"problem: a {type(problem).__name__}; valid: an IdentifyProblem(measurement, model, effects)")
    wanted, run = PIPELINES[_measurement_type(problem.measurement)]
    method = wanted() if method is None else method
    if not isinstance(method, wanted):
        raise BadInput(f"method {type(method).__name__}: does not apply to a {problem.kind} measurement; valid: "
                       f"{wanted.__name__}(...)")
    from threadpoolctl import threadpool_limits

    # the fits' matrices are small (a few thousand rows by a few columns, 7-20 DOF): threaded BLAS only
    # adds contention (a least-squares SVD took 30x the CPU with two threads on a loaded machine)
    # (the pipeline's modules are imported first: a BLAS loaded inside the context would keep its threads)
    _import_pipelines()
    with threadpool_limits(1):
        result = run(problem, method, progress)
    return replace(result, problem=problem, method=method)


def _import_pipelines() -> None:
    from . import force_stability, forces, frf  # noqa: F401  (imported for their BLAS, see identify())
