"""The effect library: what identification may add to a model, and how.

An *effect* is a parametrized extension of the model that the measurement may reveal (a tool-holder
mode, a joint stiffness correction, edge coefficients, a dynamometer resonance...). Every effect is
an :class:`Effect` and is registered once in :data:`REGISTRY` (:func:`register`); identification
only ever looks effects up there, so a user adds an effect by writing one class and calling
``register(MyEffect())`` (see the README, section "Identify").

An effect declares

* ``name``: the registry key, also the ``type`` of its TOML table;
* ``stage``: how it enters the model:

  - ``"element"``: a :class:`robolobes.linearize.Element` (``[[elements]]`` table of the case or
    robot TOML; lobes, simulate and the workspace maps build it like any other element);
  - ``"cutting_law"``: a parameter of the cutting law or the tool (``[material]``, ``[tool]``);
  - ``"chain"``: a stage of the measurement chain (sensor dynamics, acquisition filter): it changes
    what is measured, not the machine, so it is reported but not written into the model TOML;

* ``parameters``: :class:`Parameter` s with physical bounds (SI, unit in the name);
* ``observed_by``: the measurement kinds that observe it (``"frf"``, ``"forces"``,
  ``"force_stats"``, ``"stability"``) and, for each, its detection threshold in words;
* ``signatures``: the residual signatures it explains (:data:`SIGNATURES`), used by diagnosis to
  rank candidates before fitting;
* ``apply(model, params)``: the :class:`ModelState` with the effect added; an ``"element"`` effect
  adds ``element_specs(model, params)``, its elements with their SI values for that model;
* ``table(params)``: the effect's own TOML table (its name and parameters, read back by ``from_table``).

Per-kind pipelines (``identify/frf.py``, ``identify/forces.py``) add what they need to evaluate an
effect fast (e.g. a perturbation of the linearized M, C, K); the contract here is what every
pipeline can rely on.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any, Mapping

from robolobes.cases.spec import ElementSpec, MillingCase
from robolobes.core.errors import BadInput

__all__ = ["Parameter", "Effect", "ModelState", "REGISTRY", "register", "effects_for", "STAGES", "KINDS",
           "SIGNATURES", "check_params"]

STAGES = ("element", "cutting_law", "chain")
KINDS = ("frf", "forces", "force_stats", "stability")

# residual signatures diagnosis can report (an effect lists those it explains)
SIGNATURES = {
    "channel_ratio": "every pair of one response channel off by one real factor, at every line and pose "
                     "(a sensor calibration)",
    "phase_slope": "a phase residual linear in frequency, the same in every pair and pose (a delay)",
    "extra_peak": "a peak in the measurement the model lacks, at the same frequency in every pose",
    "peak_height": "peaks at the model's frequencies but with the wrong height (damping / modal mass)",
    "pose_shift": "peaks shifted in frequency, by an amount that depends on the pose",
    "uniform_shift": "peaks shifted in frequency by about the same ratio in every pose",
    "static_offset": "low-frequency compliance off (static stiffness)",
    "mean_offset": "force means off (edge forces)",
    "once_per_rev": "once-per-revolution lines in the force spectrum (runout)",
    "entry_ringing": "ringing above the tooth-passing harmonics after each entry (sensor dynamics)",
    "harmonic_rolloff": "tooth-passing harmonics attenuated with frequency (low-pass, sensor)",
    "stability_shift": "observed stability boundary differs from the predicted one",
}


@dataclass(frozen=True)
class Parameter:
    """One parameter of an effect.

    Attributes
    ----------
    name : str
        Key with its unit (``freq_hz``, ``stiffness_n_per_m``, ``stiffness_scale``).
    lower, upper : float
        Physical bounds (inclusive); fits stay inside them.
    neutral : float or None
        The value at which the effect vanishes (1 for a scale, 0 for an added mass); None when
        the effect has no neutral value (a mode is either there or not).
    detect : float or None
        Smallest deviation from ``neutral`` the default measurement resolves or, for a parameter
        without a neutral value, the largest value it resolves (a stiffness, a frequency, a loop gain
        beyond which the effect no longer shows): synthetic tests draw parameters on the resolved
        side, and a fit beyond it is not kept (:mod:`identify.evidence`).
    log : bool
        Fit in log space (positive quantities spanning decades).
    doc : str
    periodic : bool
        An angle (period 2 pi): its range is a search range, not a physical bound, so a fitted value
        at its end is not "on a bound" (reported wrapped to (-pi, pi]).
    plausible : (float, float) or None
        The physical range, when narrower than the fit's bounds: a fitted value outside it is not
        credible (:mod:`identify.evidence`).
    """

    name: str
    lower: float
    upper: float
    neutral: float | None = None
    detect: float | None = None
    log: bool = False
    doc: str = ""
    periodic: bool = False
    plausible: tuple | None = None

    def __post_init__(self):
        if not (math.isfinite(self.lower) and math.isfinite(self.upper) and self.lower < self.upper):
            raise ValueError(f"parameter {self.name}: bounds must be finite with lower < upper")
        if self.log and self.lower <= 0:
            raise ValueError(f"parameter {self.name}: log scale needs lower > 0")

    def check(self, value, where: str = "") -> float:
        """``value`` as a float inside the bounds, else :class:`BadInput` naming it."""
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
                or not self.lower <= value <= self.upper:
            raise BadInput(f"{where}{self.name} = {value!r}: must be a number in [{self.lower:g}, {self.upper:g}]")
        return float(value)


@dataclass(frozen=True)
class ModelState:
    """The model identification updates: a case, a variant, added elements and measurement-chain stages.

    Attributes
    ----------
    case : MillingCase
        The case (robot, tool, cutting law, cut, pass); cutting-law effects replace ``case.law``
        or ``case.tool``.
    variant : str
        Model variant (``basic``, ``gravity``, ``orthogonal``, ``backlash``).
    elements : tuple of ElementSpec
        Elements added by identification (on top of those in the case/robot TOML).
    chain : tuple of (name, params) pairs
        Measurement-chain stages (not part of the machine; reported, not written to the TOML).
    case_ref : str
        The case's built-in name or file path (the model TOML refers to its robot the same way).
    overrides : tuple of (table, key, value)
        Keys of the case TOML that cutting-law effects change (``("material", "kte_n_per_mm", 12.0)``),
        in the file's units; ``case`` already holds the SI values.
    """

    case: MillingCase
    variant: str = "basic"
    elements: tuple = ()
    chain: tuple = ()
    case_ref: str = ""
    overrides: tuple = ()

    def with_element(self, spec: ElementSpec) -> "ModelState":
        return replace(self, elements=self.elements + (spec,))

    def with_chain(self, name: str, params: Mapping[str, float]) -> "ModelState":
        return replace(self, chain=self.chain + ((name, dict(params)),))

    def with_override(self, table: str, key: str, value, case: MillingCase) -> "ModelState":
        """A cutting-law change: the new ``case`` (SI) and the TOML key it corresponds to (file units)."""
        return replace(self, case=case, overrides=self.overrides + ((table, key, value),))

    def robot(self, **kw):
        """The :class:`FlexibleRobot` of this state (variant + case elements + added elements)."""
        from robolobes.linearize.extra_elements import element_from_spec
        from robolobes.linearize.model import build_model

        extra = tuple(element_from_spec(e) for e in self.elements)
        return build_model(self.case.robot, self.variant, extra_elements=extra, **kw)


class Effect:
    """Base class of the effect library (subclass it and :func:`register` an instance).

    Class attributes to set: ``name``, ``stage``, ``parameters``, ``observed_by`` (kind -> detection
    threshold in words), ``signatures`` (keys of :data:`SIGNATURES`), ``doc``.
    """

    name: str = "effect"
    stage: str = "element"
    candidate: bool = True     # tried by default; False: only when named (``robolobes identify --effects``)
    repeatable: bool = False   # may enter a model more than once (a second tool mode)
    parameters: tuple = ()
    observed_by: Mapping[str, str] = {}
    signatures: tuple = ()
    doc: str = ""

    # -- what every effect provides ------------------------------------------------------------
    def applicable(self, model: ModelState) -> bool:
        """Whether the effect can be added to ``model`` (e.g. an orthogonal correction needs virtual joints)."""
        return True

    def apply(self, model: ModelState, params: Mapping[str, float]) -> ModelState:
        """``model`` with the effect added. Default: an element (``table``) or a chain stage."""
        params = check_params(self, params)
        if self.stage == "element":
            for spec in self.element_specs(model, params):
                model = model.with_element(spec)
            return model
        if self.stage == "chain":
            return model.with_chain(self.name, params)
        raise NotImplementedError(f"effect {self.name}: cutting-law effects implement apply()")

    def element_specs(self, model: ModelState, params: Mapping[str, float]) -> tuple[ElementSpec, ...]:
        """The elements that add the effect with ``params`` (checked) to ``model`` (an element effect's
        ``[[elements]]`` tables; their SI values may depend on the model, e.g. a mass or a joint
        stiffness). Default: one element of this effect's name with the parameters as its keys."""
        return (ElementSpec(type=self.name, params={k: float(v) for k, v in params.items()}),)

    def table(self, params: Mapping[str, float]) -> dict:
        """The effect's own TOML table: ``type`` (this effect's name) and its parameters, read back
        by :meth:`from_table`. The elements it adds to a model are :meth:`element_specs`."""
        return {"type": self.name, **{k: float(v) for k, v in params.items()}}

    def from_table(self, table: Mapping[str, Any]) -> dict:
        """The parameters of a table written by :meth:`table` (its ``type`` this effect's name);
        BadInput for another type, a missing, unknown or out-of-bounds parameter."""
        t = dict(table)
        if t.pop("type", None) != self.name:
            raise BadInput(f"effect table of type {table.get('type')!r}; valid: {self.name!r}")
        return check_params(self, t)

    # -- helpers -------------------------------------------------------------------------------
    @property
    def names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    def param(self, name: str) -> Parameter:
        for p in self.parameters:
            if p.name == name:
                return p
        raise KeyError(name)

    def describe(self) -> dict:
        """JSON-ready description (for ``--list-effects`` and the report)."""
        return {"name": self.name, "stage": self.stage, "doc": self.doc, "observed_by": dict(self.observed_by),
                "signatures": list(self.signatures),
                "parameters": [{"name": p.name, "lower": p.lower, "upper": p.upper, "neutral": p.neutral,
                                "detect": p.detect, "doc": p.doc} for p in self.parameters]}


def check_params(effect: Effect, params: Mapping[str, Any]) -> dict:
    """Every declared parameter present, inside its bounds, nothing else; BadInput otherwise."""
    unknown = set(params) - set(effect.names)
    if unknown:
        raise BadInput(f"effect {effect.name}: unknown parameter(s) {sorted(unknown)}; valid: {list(effect.names)}")
    missing = [n for n in effect.names if n not in params]
    if missing:
        raise BadInput(f"effect {effect.name}: missing parameter(s) {missing}")
    return {p.name: p.check(params[p.name], f"effect {effect.name}: ") for p in effect.parameters}


REGISTRY: dict[str, Effect] = {}


def register(effect: Effect) -> Effect:
    """Add an effect to the library (one place). Its name must be new and its declaration complete."""
    if not effect.name or effect.name in REGISTRY:
        raise ValueError(f"effect name {effect.name!r} is empty or already registered")
    if effect.stage not in STAGES:
        raise ValueError(f"effect {effect.name}: stage must be one of {STAGES}, got {effect.stage!r}")
    bad = set(effect.observed_by) - set(KINDS)
    if bad or not effect.observed_by:
        raise ValueError(f"effect {effect.name}: observed_by must name kinds among {KINDS}, got {list(effect.observed_by)}")
    unknown = set(effect.signatures) - set(SIGNATURES)
    if unknown:
        raise ValueError(f"effect {effect.name}: unknown signatures {sorted(unknown)}; valid: {sorted(SIGNATURES)}")
    REGISTRY[effect.name] = effect
    return effect


def effects_for(kind: str, model: ModelState | None = None, names=None) -> list[Effect]:
    """The registered effects that ``kind`` observes (and that apply to ``model``), in registry order.

    ``names``: only these (BadInput for a name not in the library or not observed by ``kind``);
    default: every effect with ``candidate = True``.
    """
    _load_library()
    if names is not None:
        bad = [n for n in names if n not in REGISTRY or kind not in REGISTRY[n].observed_by]
        if bad:
            valid = [n for n, e in REGISTRY.items() if kind in e.observed_by]
            raise BadInput(f"--effects {','.join(bad)}: not an effect a {kind} measurement observes; valid: "
                           f"{', '.join(valid)}")
        chosen = [REGISTRY[n] for n in names]
    else:
        chosen = [e for e in REGISTRY.values() if kind in e.observed_by and e.candidate]
    return [e for e in chosen if model is None or e.applicable(model)]


def _load_library() -> None:
    """Import the modules that register the built-in effects (idempotent)."""
    import importlib

    for mod in ("robolobes.identify.structural", "robolobes.identify.cutting_effects",
                "robolobes.identify.tool_effect", "robolobes.identify.chain_effects"):
        try:
            importlib.import_module(mod)
        except ModuleNotFoundError as e:  # a library not written yet
            if e.name != mod:
                raise
