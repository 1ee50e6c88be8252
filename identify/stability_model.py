"""Stability observations, the model side: each observation linearized once, the critical value of
a damping effect at which its verdict flips, and the verdict at a value (the decision rule of
:mod:`identify.force_stability`, which fits the candidates to the observations).

Candidates are the library's damping effects (:class:`identify.cutting_effects.DampingEffect`,
registered in :data:`identify.effects.REGISTRY`): one parameter ``theta`` each, entering only the
damping, ``C(theta) = C_a + theta C_b`` per observation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from robolobes.core.errors import BadInput
from robolobes.core.verdict import Verdict

from .cutting_effects import JOINT_DAMPING_CREDIBLE, DampingEffect
from .effects import effects_for
from .force_data import StabilityObservation

if TYPE_CHECKING:
    from robolobes.cases.spec import MillingCase
    from robolobes.lobes import LobeProblem

__all__ = ["Candidate", "stability_effects", "candidate", "SCALE_CREDIBLE", "wavelength_m", "ObservationModel",
           "critical_value", "Threshold", "threshold", "value_verdict", "M_VERDICT", "M_BOUND", "XTOL_LOG"]

#: SDM steps per period of the verdict, and of the coarser level that bounds its error.
M_VERDICT = 40
M_BOUND = 20
#: Relative tolerance of each critical value (Brent on log theta), far below the m = 40 bound.
XTOL_LOG = 2e-3


@dataclass(frozen=True)
class Candidate:
    """One candidate effect of stability observations: its parameter, bounds and neutral value."""

    name: str
    param: str
    lower: float
    upper: float
    neutral: float

    @classmethod
    def of(cls, effect: DampingEffect) -> "Candidate":
        """The candidate of a registered damping effect (its one parameter, bounds and neutral value)."""
        p, = effect.parameters
        return cls(effect.name, p.name, p.lower, p.upper, float(p.neutral if p.neutral is not None else p.lower))


def stability_effects(state=None, names=None) -> list[DampingEffect]:
    """The library's effects stability observations fit: the registered :class:`DampingEffect` s
    (registry order), or those named in ``names`` (BadInput for a name that is not one)."""
    if names is None:
        return [e for e in effects_for("stability", state) if isinstance(e, DampingEffect)]
    chosen = effects_for("stability", state, list(names))
    bad = [e.name for e in chosen if not isinstance(e, DampingEffect)]
    if bad:
        raise BadInput(f"--effects {','.join(bad)}: stability observations fit damping effects only (one parameter "
                       f"entering the damping); valid: {', '.join(e.name for e in stability_effects(state))}")
    return [e for e in chosen if isinstance(e, DampingEffect)]


def candidate(name: str, state=None) -> Candidate:
    """The candidate of the registered damping effect ``name`` (read from the registry at the call;
    BadInput for a name that is not one)."""
    effect, = stability_effects(state, [name])
    return Candidate.of(effect)


SCALE_CREDIBLE = JOINT_DAMPING_CREDIBLE


def wavelength_m(speed_m_per_s: float, freq_hz: float) -> float:
    """Wavelength ``V / f`` of a surface wave cut at speed V (m/s) and vibration frequency f (Hz), m."""
    return speed_m_per_s / freq_hz


def _pose(case, obs) -> np.ndarray:
    from robolobes.linearize.path import Pass

    if obs.q_rad is not None:
        return np.asarray(obs.q_rad, float)
    pas = Pass.from_case(case)
    return np.asarray(pas.theta_at_s(obs.path_s_m), float)


@dataclass(frozen=True, eq=False)
class ObservationModel:
    """One observation linearized once: the lobe problem at its speed and depth and, per candidate,
    the damping line ``C(theta) = C_a + theta C_b`` (``lines[name] = (C_a, C_b)``, (n, n) SI)."""

    obs: StabilityObservation
    case: MillingCase
    problem: LobeProblem  # at theta = neutral
    lines: dict

    @classmethod
    def build(cls, state, case, obs) -> "ObservationModel":
        """Linearize ``state``'s robot (for ``case``) at the observation's pose; the damping line of
        every library damping effect (:meth:`DampingEffect.damping_line`)."""
        from robolobes.linearize import linearize
        from robolobes.lobes import LobeProblem, PhysicalStructure

        st = replace(state, case=case)
        theta = _pose(case, obs)
        s1 = PhysicalStructure.from_linear(linearize(st.robot(), theta), case.cut.feed_direction)
        cut = replace(case.cut, spindle_rpm=obs.rpm, ap_m=obs.depth_m)
        lines = {e.name: e.damping_line(st, theta, s1, case.tool, cut) for e in stability_effects()}
        return cls(obs=obs, case=case, problem=LobeProblem(s1, case.tool, cut, case.law), lines=lines)

    @property
    def physical(self):
        """The observation's :class:`lobes.PhysicalStructure` (M, C, K, tcp in the cut frame)."""
        from robolobes.lobes import PhysicalStructure

        s = self.problem.structure
        assert isinstance(s, PhysicalStructure), type(s)  # build() makes one
        return s

    def structure(self, name: str, value: float):
        from robolobes.lobes import PhysicalStructure

        s = self.physical
        ca, cb = self.lines[name]
        return PhysicalStructure(s.M, ca + value * cb, s.K, s.tcp)

    def engine(self, name: str, value: float, m: int):
        from robolobes.lobes.sdm import SDMEngine, SemiDiscretization

        prob = replace(self.problem, structure=self.structure(name, value))
        return SDMEngine(prob, SemiDiscretization(m=m), 1.01 * self.obs.depth_m)

    def radius(self, name: str, value: float, m: int = M_VERDICT) -> float:
        """Spectral radius of the SDM monodromy (``m`` steps) at the observation's speed and depth."""
        eng = self.engine(name, value, m)
        return float(eng.multipliers(np.array([self.obs.rpm]), np.array([self.obs.depth_m]))[0][0])

    def chatter_hz(self, name: str, value: float, m: int = M_VERDICT) -> float:
        """Frequency of the critical Floquet solution at the operating point, Hz."""
        eng = self.engine(name, value, m)
        return float(eng.critical(np.array([self.obs.rpm]), np.array([self.obs.depth_m]))[2][0])


def critical_value(om: ObservationModel, cand: Candidate, m: int = M_VERDICT) -> float:
    """``theta*`` (m-step SDM): the radius is 1 there, below 1 above it. ``-inf`` when stable at the
    lower bound, ``+inf`` when unstable at the upper bound."""
    from scipy.optimize import brentq

    g = lambda v: om.radius(cand.name, v, m) - 1.0
    if g(cand.neutral) < 0:
        lo_v = cand.lower if cand.lower > 0 else None
        if lo_v is None or g(lo_v) < 0:
            return -math.inf
        a, b = math.log(lo_v), math.log(cand.neutral)
    else:
        if g(cand.upper) >= 0:
            return math.inf
        lo_v = cand.neutral if cand.neutral > 0 else cand.upper * 1e-6
        if cand.neutral == 0 and g(lo_v) < 0:  # crossing below 1e-6 of the range: negligible
            return lo_v
        a, b = math.log(lo_v), math.log(cand.upper)
    root = brentq(lambda u: g(math.exp(u)), a, b, xtol=XTOL_LOG)
    assert isinstance(root, float)  # a float without full_output (scipy's stub also allows the tuple)
    return math.exp(root)


@dataclass(frozen=True)
class Threshold:
    """Critical value of one observation for one candidate, at m = 40 with its bound (module doc)."""

    value: float
    bound: float
    coarse: float

    @property
    def band(self) -> tuple[float, float]:
        if math.isinf(self.value) and self.value == self.coarse:
            return self.value, self.value
        if not (math.isfinite(self.value) and math.isfinite(self.coarse)):
            return min(self.value, self.coarse), max(self.value, self.coarse)
        return self.value - self.bound, self.value + self.bound


def threshold(om: ObservationModel, cand: Candidate) -> Threshold:
    v40 = critical_value(om, cand, M_VERDICT)
    v20 = critical_value(om, cand, M_BOUND)
    bound = abs(v40 - v20) if math.isfinite(v40) and math.isfinite(v20) else math.inf
    return Threshold(v40, bound, v20)


def value_verdict(value: float, thr: Threshold) -> Verdict:
    """The decision rule (module doc) at parameter ``value`` for an observation's threshold."""
    lo, hi = thr.band
    if value > hi:
        return Verdict("stable", f"value {value:.5g} above the critical {thr.value:.5g} + {thr.bound:.3g} "
                                 f"(SDM m = {M_VERDICT}, bound |m {M_VERDICT} - m {M_BOUND}|)")
    if value < lo:
        return Verdict("unstable", f"value {value:.5g} below the critical {thr.value:.5g} - {thr.bound:.3g} "
                                   f"(SDM m = {M_VERDICT}, bound |m {M_VERDICT} - m {M_BOUND}|)")
    return Verdict("undetermined", f"value {value:.5g} within the bound of the critical {thr.value:.5g} +- "
                                   f"{thr.bound:.3g} (SDM m = {M_VERDICT}/{M_BOUND})")
