"""Typed results of identification (shared by the FRF and the force pipelines).

``identify(problem, method)`` returns an :class:`Identification`; the command line writes
``Identification.to_json()``. Errors are relative (dimensionless) and always held out: computed on
data the fit did not see (leave-one-pose-out for FRF sets, held-out blocks of revolutions for
force series); statistics-only data (8 numbers) have no held-out part and report AICc instead.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any

__all__ = ["Evidence", "EffectFit", "SelectionStep", "Identification"]


@dataclass(frozen=True, eq=False)
class Evidence(Mapping):
    """Why an effect was chosen: a read-only mapping, frozen at construction, in the order written.

    Keys by pipeline (values JSON-ready): FRF sets and force series (:mod:`identify.selection`)
    ``heldout_error_with``, ``heldout_error_without``, ``z``, ``z_threshold``, ``alternatives``,
    ``signature``...; force statistics ``aicc``, ``aicc_without``, ``dof``, ``rss_n2``; stability
    observations ``credible``, ``why``, ``consistent_interval``, ``wrong_before``, ``wrong_after``,
    ``thresholds`` (and ``tied`` when two candidates explain as many observations). A changed copy
    is made with :meth:`with_entries`; the object itself never changes.

    Attributes
    ----------
    entries : tuple of (str, value) pairs
    """

    entries: tuple = ()

    def __post_init__(self) -> None:
        keys = [k for k, _ in self.entries]
        if len(set(keys)) != len(keys) or not all(isinstance(k, str) for k in keys):
            raise ValueError(f"evidence keys must be distinct strings, got {keys}")

    @classmethod
    def of(cls, mapping: Mapping | None = None, **entries) -> "Evidence":
        """Evidence from a mapping (and keywords, which replace its keys)."""
        merged = {**dict(mapping or {}), **entries}
        return cls(tuple(merged.items()))

    def with_entries(self, **entries) -> "Evidence":
        """A copy with ``entries`` added or replaced (this evidence is not changed)."""
        return Evidence.of(self, **entries)

    def __getitem__(self, key: str) -> Any:
        for k, v in self.entries:
            if k == key:
                return v
        raise KeyError(key)

    def __iter__(self) -> Iterator[str]:
        return (k for k, _ in self.entries)

    def __len__(self) -> int:
        return len(self.entries)

    def to_json(self) -> dict:
        return dict(self.entries)


@dataclass(frozen=True)
class EffectFit:
    """One effect found in the data, with its fitted parameters.

    Attributes
    ----------
    name : str
        The effect's registry name (e.g. ``"tcp_mode"``, ``"joint_damping"``, ``"edge_coefficients"``).
    params : dict[str, float]
        Fitted values, SI units, unit in the key (``freq_hz``, ``stiffness_n_per_m``, ``kte_n_per_m``).
    uncertainty : dict[str, float]
        One standard deviation of each parameter (same keys and units).
    evidence : Evidence
        (a dict given to the constructor is frozen into one) Why it was chosen: the signature it explains, the held-out error with and without it, the
        test statistic and its threshold, the candidates the data could not tell from it
        (``alternatives``).
    credible : bool
        False when a parameter sits on a bound or outside its physical range (``not_credible_because``
        says which, with the bound): then it is not an identified effect (:mod:`identify.evidence`).
    determined : dict
        What the data determine (:func:`identify.evidence.determined`): per parameter, the
        combinations of the Fisher information with their standard deviation, and physical
        combinations shared with indistinguishable alternatives (``shared``).
    surrogate : bool
        True when the final residual stays unexplained: the effect lowers the error but is not shown
        to be the physical cause.
    """

    name: str
    params: dict
    uncertainty: dict
    evidence: Mapping  # an Evidence after construction (a dict given is frozen into one)
    credible: bool = True
    not_credible_because: tuple = ()
    determined: dict = field(default_factory=dict)
    surrogate: bool = False

    def __post_init__(self) -> None:
        if not isinstance(self.evidence, Evidence):
            object.__setattr__(self, "evidence", Evidence.of(self.evidence))

    def to_json(self) -> dict:
        return {"name": self.name, "params": dict(self.params), "uncertainty": dict(self.uncertainty),
                "credible": self.credible, "not_credible_because": list(self.not_credible_because),
                "determined": dict(self.determined), "surrogate": self.surrogate,
                "evidence": dict(self.evidence)}


@dataclass(frozen=True)
class SelectionStep:
    """One selection step: candidates tried, their held-out errors, the one kept (or none).

    ``action``: ``"add"`` (a forward step), ``"drop"`` (a backward step that removed ``removed``,
    whose gain ``statistic`` no longer passed ``threshold``) or ``"replace"`` (``removed``, not
    credible at the final joint fit, replaced by ``kept``, which the held-out data cannot tell from it). ``rejected``: candidates that could not
    be findings (not credible, or below their detection threshold), name -> reason. ``provisional``:
    the effect kept was not credible on its own and entered to be refitted with the next one
    (:mod:`identify.selection`).
    """

    candidates: dict  # name -> held-out error with that effect added
    kept: str | None
    error_before: float
    error_after: float
    statistic: float
    threshold: float
    action: str = "add"
    removed: str | None = None
    rejected: dict = field(default_factory=dict)
    provisional: bool = False

    def to_json(self) -> dict:
        return dict(self.__dict__)


@dataclass(frozen=True)
class Identification:
    """What identification found.

    Attributes
    ----------
    kind : {"frf", "forces", "force_stats", "stability"}
    effects : tuple of EffectFit
        Best first; empty when the model already explains the data within its noise.
    error_before, error_after : float
        Held-out error of the model before and after (same metric, dimensionless).
    metric : str
        The metric in words.
    noise_floor : float
        The error a perfect model would have on the held-out data, estimated from the data.
    steps : tuple of SelectionStep
    model_toml : str
        The updated case / robot TOML (loads under the strict key check).
    extra : dict
        Kind-specific numbers (per-pose errors, FRAC, poles...).
    unexplained : dict
        ``unexplained`` (bool): ``statistic`` exceeds ``margin`` (the rule in ``rule``, the statistic's
        meaning in ``statistic_meaning``: for FRF sets the RMS of the held-out residual over each line's
        noise, for force series the held-out error over the noise floor); ``ratio_to_noise_floor``;
        ``where``: the poses, pairs or axes, frequency bands and signatures where the residual stays
        above the noise.
    arrays : dict
        Arrays for ``--report``, not written to the JSON. Force series: ``heldout_measured_n``,
        ``model_before_n``, ``model_after_n`` (M, 3) N, the held-out synchronous average and the model's
        (aligned) over the M bins of one revolution, and ``heldout_noise_n`` (M, 3) N, its standard
        error per bin.
    problem : IdentifyProblem or None
        The problem solved (set by :func:`identify.api.identify`; not written to the JSON).
    method : the method object or None
        The selection rule used (set by :func:`identify.api.identify`; not written to the JSON).
    """

    kind: str
    effects: tuple
    error_before: float
    error_after: float
    metric: str
    noise_floor: float
    steps: tuple = ()
    model_toml: str = ""
    extra: dict = field(default_factory=dict)
    arrays: dict = field(default_factory=dict, repr=False, compare=False)
    unexplained: dict = field(default_factory=dict)
    problem: Any = field(default=None, repr=False, compare=False)
    method: Any = field(default=None, compare=False)

    @property
    def identified(self) -> tuple:
        """Names of the effects that are findings: credible and not surrogates."""
        return tuple(e.name for e in self.effects if e.credible and not e.surrogate)

    def to_json(self) -> dict:
        return {"kind": self.kind, "effects": [e.to_json() for e in self.effects],
                "identified": list(self.identified),
                "error_before": self.error_before, "error_after": self.error_after, "metric": self.metric,
                "noise_floor": self.noise_floor, "unexplained": dict(self.unexplained),
                "steps": [s.to_json() for s in self.steps], "model": self.model_toml, **self.extra}
