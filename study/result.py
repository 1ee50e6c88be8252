"""The typed result of the study: every number the report, the figures and ``results.json`` show.

:func:`robolobes.study.compute.compute_study` returns a :class:`StudyResult`; the renderers
(:mod:`.report`, :mod:`.figures`, :func:`to_json`) only read it. SI units inside (m, N, s, rad),
``_hz``, ``_rpm``, ``_mm``, ``_um``, ``_deg`` in the names where a field is not SI.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np

from robolobes.core.verdict import Status, Verdict

__all__ = ["ModeSet", "DominantMode", "OperatingPoint", "LobeDiagram", "LowestLimit", "TimeDomainRun",
           "DampingProbe", "DampingSearch", "Tab10Row", "RoughnessRow", "MaterialFacts", "StudyResult",
           "as_verdict"]


def as_verdict(v, reason: str = "") -> Verdict:
    """A :class:`Verdict` from a Verdict, its JSON, a status string (the lobes' older "marginal" is
    "undetermined") or True / False / None."""
    if isinstance(v, Verdict):
        return v
    if isinstance(v, dict):  # a Verdict.to_json()
        return Verdict(v["verdict"], v.get("verdict_reason") or reason)
    if v is None or isinstance(v, bool):
        return Verdict.from_stable(v, reason)
    if v == "marginal":
        return Verdict("undetermined", reason or "the cut depth lies within the discretization error of the limit")
    return Verdict(cast(Status, str(v)), reason)  # Verdict checks the status at run time


@dataclass(frozen=True)
class ModeSet:
    """Modes and TCP stiffness of one variant at one pose (base frame), and the tool-tip FRF peaks.

    ``freq_hz``, ``damped_freq_hz``, ``damping_ratio``, ``modal_stiffness_n_per_m``: (n_modes,);
    ``tcp_static_stiffness_n_per_m``: (3, 3) N/m; ``frf_peak_um_per_n``: {"feed", "normal"}: the
    largest |H| of the direct cut-frame receptance over 1-300 Hz, um/N. ``frf`` (not in JSON): the
    :class:`FRF` ``(3, 3, n_freq)``, m/N, cut frame.
    """

    variant: str
    pose: str
    summary: dict
    frf_peak_um_per_n: dict
    frf_file: str
    frf: Any = field(default=None, repr=False, compare=False)

    @property
    def freq_hz(self) -> np.ndarray:
        return np.asarray(self.summary["freq_hz"])


@dataclass(frozen=True)
class DominantMode:
    """The mode that carries the largest share of the normal receptance at a chatter frequency."""

    index: int            # 1-based, in the order of ``LinearModel.modes()``
    freq_hz: float
    damping_ratio: float
    share: float          # |its contribution| / sum of |contributions|, in [0, 1]


@dataclass(frozen=True)
class OperatingPoint:
    """A cut against the lobes (SDM, Richardson-extrapolated) at one pose and variant."""

    material: str
    variant: str
    pose: str
    verdict: Verdict
    depth_m: float
    depth_limit_m: float          # inf: no limit below the search bound
    depth_limit_error_m: float
    margin: float                 # depth_limit / depth - 1
    margin_error: float
    spectral_radius: float
    bifurcation: str
    chatter_freq_hz: float
    limit_bifurcation: str
    limit_chatter_freq_hz: float
    m_levels: tuple
    dominant_mode: DominantMode | None = None
    point: Any = field(default=None, repr=False, compare=False)  # the lobes' StabilityPoint (figures)


@dataclass(frozen=True)
class LobeDiagram:
    """A lobe diagram: ``depth_limit_m`` (n_rpm,) m, inf where none below ``depth_max_m``."""

    material: str
    variant: str
    pose: str
    spindle_rpm: np.ndarray
    depth_limit_m: np.ndarray
    chatter_freq_hz: np.ndarray
    bifurcation: tuple
    wall_s: float
    figure: str
    result: Any = field(default=None, repr=False, compare=False)  # the lobes' LobeResult (figures)


@dataclass(frozen=True)
class LowestLimit:
    """The lowest limit of the default refined lobes (``RefinedSDM()``) over 300-30 000 rpm (by
    :func:`robolobes.study.compute.lowest_limit`: 400 geometric speeds, then a local search in
    speed at the three lowest sampled minima): ``depth_m`` (m) with its error estimate
    ``depth_error_m`` (m), the speed ``at_rpm`` (rpm), the bifurcation and the chatter frequency
    ``chatter_freq_hz`` (Hz) there. Not the zero-order approximation's "absolute limit", which on
    this robot lies 45-51 % above it (the study guide)."""

    material: str
    depth_m: float
    depth_error_m: float
    at_rpm: float
    bifurcation: str
    chatter_freq_hz: float
    variant: str = "basic"
    pose: str = "start"


@dataclass(frozen=True)
class TimeDomainRun:
    """One simulated pass. ``summary``: the simulation summary's keys the study reports (SI, the
    force statistics in N, roughness in um); ``series`` (not in JSON): the SimulationResult."""

    material: str
    variant: str
    damping_scale: float
    verdict: Verdict
    chatter_freq_hz: float | None
    t_end_s: float
    wall_s: float
    steps: int
    summary: dict
    series: Any = field(default=None, repr=False, compare=False)

    @property
    def key(self) -> str:
        return f"{self.material}/{self.variant}"


@dataclass(frozen=True)
class DampingProbe:
    """One tried joint-damping scale and its verdict (``info``: the method's numbers there)."""

    scale: float
    verdict: Verdict
    info: dict


@dataclass(frozen=True)
class DampingSearch:
    """Smallest joint-damping scale that stabilizes steel, as a bracket at its resolution.

    ``largest_unstable`` < critical scale <= ``smallest_stable``; an "undetermined" probe counts
    as not stable (it would move the bracket up, never down). None: no such probe.
    """

    method: str                  # "lobes", "time domain", "delay-based time domain", "lobes at ae - dy", "lobes about the forced orbit"
    variant: str
    probes: tuple                # DampingProbe, by increasing scale
    largest_unstable: float | None
    smallest_stable: float | None
    resolution: float            # bisection stops when the bracket is this narrow

    @property
    def bracket(self) -> tuple[float | None, float | None]:
        return self.largest_unstable, self.smallest_stable


@dataclass(frozen=True)
class Tab10Row:
    """Aluminium forces over the Tab. 10 window in the paper's axes, N (``values``: fx_min ... fy_rms)."""

    name: str
    values: dict


@dataclass(frozen=True)
class RoughnessRow:
    """Ra, Rq, Rt of the lateral wall, um: a number, a measured range (lo, hi), or None."""

    name: str
    Ra: Any
    Rq: Any
    Rt: Any


@dataclass(frozen=True)
class MaterialFacts:
    """The numbers the explanation rests on, for one material (basic model, start pose)."""

    spindle_rpm: float
    tooth_passing_hz: float
    lowest_mode_hz: float
    n_modes_basic: int
    modes_below_tooth_passing_basic: int
    modes_below_tooth_passing_orthogonal: int
    ktc_pa: float
    krc_pa: float
    depth_m: float
    lobes_verdict: Verdict
    local_limit_m: float
    local_margin: float
    bifurcation: str
    chatter_freq_hz_lobes: float
    dominant_mode: DominantMode | None
    lowest_limit_m: float
    time_domain_verdict_basic: Verdict
    chatter_freq_hz_time_domain: float | None

    @property
    def tooth_passing_over_lowest_mode(self) -> float:
        return self.tooth_passing_hz / self.lowest_mode_hz

    @property
    def krc_over_ktc(self) -> float:
        return self.krc_pa / self.ktc_pa

    @property
    def local_over_lowest(self) -> float:
        return self.local_limit_m / self.lowest_limit_m


@dataclass(frozen=True)
class StudyResult:
    """Everything the study computed (see the module docstring of :mod:`robolobes.study`)."""

    settings: Any
    provenance: dict
    cases: dict                      # material -> case name
    notes: tuple
    modes: tuple                     # ModeSet
    operating_points: tuple          # OperatingPoint
    diagrams: tuple                  # LobeDiagram
    lowest_limits: tuple             # LowestLimit
    td_linearized: bool
    time_domain: tuple               # TimeDomainRun (nominal damping, all variants; then damped steel)
    damping_lobes: DampingSearch
    damping_time_domain: DampingSearch
    paper_damping_scale: float
    tab10: tuple                     # Tab10Row
    roughness: tuple                 # RoughnessRow
    facts: dict                      # material -> MaterialFacts
    wall_s: float
    generated: str
    linearize_calls: int = 0
    identify_facts: dict | None = None
    damping_delay: DampingSearch | None = None  # the delay-based time domain's (None: not computed)
    damping_lobes_eroded: DampingSearch | None = None  # the lobes' at ae - dy, the eroded part's engagement
    damping_lobes_orbit: DampingSearch | None = None  # the SDM about the eroded part's forced orbit
    eroded_deflection_m: float | None = None    # that dy: the eroded runs' mean normal deflection, m
    eroded_entry_deflection_m: float | None = None  # their deflection when the teeth meet the part, m

    # ---- look-ups -------------------------------------------------------------------------------
    def mode_set(self, variant: str, pose: str) -> ModeSet:
        return next(m for m in self.modes if m.variant == variant and m.pose == pose)

    def operating_point(self, material: str, variant: str = "basic", pose: str = "start") -> OperatingPoint:
        return next(o for o in self.operating_points
                    if (o.material, o.variant, o.pose) == (material, variant, pose))

    def diagram(self, material: str, variant: str = "basic", pose: str = "start") -> LobeDiagram | None:
        return next((d for d in self.diagrams if (d.material, d.variant, d.pose) == (material, variant, pose)), None)

    def run(self, material: str, variant: str = "basic", damping_scale: float = 1.0) -> TimeDomainRun | None:
        return next((r for r in self.time_domain if (r.material, r.variant) == (material, variant)
                     and math.isclose(r.damping_scale, damping_scale)), None)

    def lowest_limit(self, material: str) -> LowestLimit:
        return next(a for a in self.lowest_limits if a.material == material)

    @property
    def ktc_ratio_steel_over_aluminium(self) -> float:
        return self.facts["steel"].ktc_pa / self.facts["aluminium"].ktc_pa
