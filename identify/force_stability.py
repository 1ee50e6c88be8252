"""Stability observations: which effect, with which value, makes the lobes agree with observed cuts.

For each observation (case, speed, depth, pose) the lobes' verdict (:func:`lobes.stability`,
first-order semi-discretization with its Richardson error bound; "marginal" counts as not
stable) is compared with what was observed. Two candidates can move a verdict:

* ``joint_damping``: a scale on every motion-axis damper (the paper's damping values come from a
  guess, eq. 8, so they are the first suspect);
* ``process_damping``: a viscous damper ``c`` (N s/m) at the tool tip, isotropic in the cut plane
  (the flank of each tooth rubs the wavy surface along its own radial direction, which sweeps
  101.5-180 deg in the TX200 cuts: isotropic is the time-invariant stand-in), ``c = Ksp b L^2 / (2 V)`` (Altintas, Eynian & Onozuka
  2008; Budak & Tunc 2010), so the value found is also given as the flank-contact length ``L`` it
  needs at an indentation coefficient ``Ksp``.

For each candidate the smallest value that makes every observation agree is found by bisection
(more damping is more stable; the error metric is the fraction of observations the model gets
wrong). Binary observations hold no noise estimate and, with few of them, no held-out part: the
result says so, and states whether the value is physically credible.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from robolobes.cases import load_case
from robolobes.core.errors import BadInput

from .cutting_effects import process_damping_c
from .force_data import StabilityObservations
from .result import EffectFit, Identification, SelectionStep

__all__ = ["identify_stability", "verdict_at", "wavelength_m", "KSP_RANGE_N_PER_M3", "FLANK_RANGE_M"]

#: Indentation (ploughing) coefficient range for steels, N/m^3 (order of magnitude of published
#: process-damping identifications; used only to judge credibility, never fitted).
KSP_RANGE_N_PER_M3 = (1e13, 1e14)
#: Flank-contact (wear land) length range for a sharp to worn end mill, m.
FLANK_RANGE_M = (2e-5, 3e-4)
#: Largest joint-damping scale and process damper searched.
SCALE_MAX = 50.0
PD_MAX_N_S_PER_M = 1e6


def wavelength_m(speed_m_per_s: float, freq_hz: float) -> float:
    """Wavelength ``V / f`` of a surface wave cut at speed V (m/s) and vibration frequency f (Hz), m."""
    return speed_m_per_s / freq_hz


def _pose(case, obs) -> np.ndarray:
    from robolobes.linearize.path import Pass

    if obs.q_rad is not None:
        return np.asarray(obs.q_rad, float)
    pas = Pass.from_case(case)
    return np.asarray(pas.theta_at_s(obs.path_s_m), float)


def verdict_at(state, case, obs, *, damping_scale: float = 1.0, pd_n_s_per_m: float = 0.0) -> dict:
    """The lobes' verdict of one observation with the given joint-damping scale and tip damper
    (``state``: the model, :class:`identify.effects.ModelState`; ``case``: the observation's case)."""
    from robolobes.linearize import linearize
    from robolobes.lobes import LobeProblem, PhysicalStructure, stability

    robot = replace(state, case=case).robot(damping_scale=damping_scale)
    lin = linearize(robot, _pose(case, obs))
    st = PhysicalStructure.from_linear(lin, case.cut.feed_direction)
    if pd_n_s_per_m > 0:
        txy = st.tcp[:2]
        st = PhysicalStructure(st.M, st.C + pd_n_s_per_m * txy.T @ txy, st.K, st.tcp)
    cut = replace(case.cut, spindle_rpm=obs.rpm, ap_m=obs.depth_m)
    op = stability(LobeProblem(st, case.tool, cut, case.law))
    return {"stable": op.verdict == "stable", "verdict": op.verdict, "depth_limit_m": op.depth_limit_m,
            "chatter_freq_hz": op.limit_chatter_freq_hz}


def _errors(state, cases_, obs, **kw) -> tuple[float, list]:
    out = [verdict_at(state, cases_[o.case], o, **kw) for o in obs.rows]
    wrong = sum(1 for o, v in zip(obs.rows, out) if v["stable"] == o.chatter)
    return wrong / len(obs.rows), out


def _smallest(agree, lo: float, hi: float, rel: float = 0.01, progress=None):
    """Smallest x in [lo, hi] with agree(x) True (monotone), by bisection on log x; None if agree(hi) is False."""
    if not agree(hi):
        return None
    if agree(lo):
        return lo
    a, b = math.log(lo), math.log(hi)
    while b - a > rel:
        m = 0.5 * (a + b)
        if agree(math.exp(m)):
            b = m
        else:
            a = m
    return math.exp(b)


def identify_stability(obs: StabilityObservations, state, *, progress=None) -> Identification:
    """The smallest joint-damping scale and tip process damper that reconcile the observations.

    ``state`` is the model (:class:`identify.effects.ModelState`); rows whose case is the model's use
    its case (``--case`` overrides the measurement's, see :func:`identify.api.model_state`), other
    rows load theirs."""
    names = {o.case for o in obs.rows}
    try:
        cases_ = {n: (state.case if n in (state.case.name, state.case_ref) or len(names) == 1 else load_case(n))
                  for n in names}
    except BadInput as e:
        raise BadInput(f"{obs.path}: {e}") from None
    variant = state.variant
    err0, before = _errors(state, cases_, obs)
    fits, steps = [], []
    if err0 > 0:
        all_agree = lambda **kw: _errors(state, cases_, obs, **kw)[0] == 0  # noqa: E731
        scale = _smallest(lambda s: all_agree(damping_scale=s), 1.0, SCALE_MAX)
        c_pd = _smallest(lambda c: all_agree(pd_n_s_per_m=c), 10.0, PD_MAX_N_S_PER_M, rel=0.05)
        cand = {"joint_damping": 0.0 if scale is not None else err0,
                "process_damping": 0.0 if c_pd is not None else err0}
        case0 = next(iter(cases_.values()))
        speed = math.pi * case0.tool.diameter_m * obs.rows[0].rpm / 60.0
        chatter_hz = next((v["chatter_freq_hz"] for v in before if v["chatter_freq_hz"]), None)
        if scale is not None:
            fits.append(EffectFit("joint_damping", {"scale": scale}, {"scale": scale * 0.01},
                                  {"rule": "smallest scale on every motion-axis damper for which every observation "
                                           "agrees (bisection, 1 % on the scale)",
                                   "credible": scale <= 3.0,
                                   "why": (f"x{scale:.3g} of the paper's eq. 8 damping: a servo's velocity loop can add "
                                           f"damping, but x{scale:.3g} on every axis is {'within' if scale <= 3 else 'far beyond'} "
                                           f"the factor ~2-3 by which guessed joint damping is usually off")}))
        if c_pd is not None:
            ksp_lo, ksp_hi = KSP_RANGE_N_PER_M3
            b = max(o.depth_m for o in obs.rows)
            flank_needed = (math.sqrt(2 * speed * c_pd / (ksp_hi * b)), math.sqrt(2 * speed * c_pd / (ksp_lo * b)))
            plausible = (process_damping_c(ksp_lo, FLANK_RANGE_M[0], b, speed),
                         process_damping_c(ksp_hi, FLANK_RANGE_M[1], b, speed))
            lam = wavelength_m(speed, chatter_hz) if chatter_hz else None
            fits.append(EffectFit("process_damping", {"c_n_s_per_m": c_pd}, {"c_n_s_per_m": c_pd * 0.01},
                                  {"rule": "smallest isotropic tip damper in the cut plane for which every observation agrees",
                                   "cutting_speed_m_per_s": speed, "chatter_freq_hz": chatter_hz,
                                   "wavelength_m": lam, "flank_length_needed_m": list(flank_needed),
                                   "plausible_c_range_n_s_per_m": list(plausible),
                                   "credible": c_pd <= plausible[1],
                                   "why": (f"c = Ksp b L^2 / (2V) with Ksp {ksp_lo:.0e}-{ksp_hi:.0e} N/m^3 and a flank "
                                           f"contact {FLANK_RANGE_M[0] * 1e3:.2f}-{FLANK_RANGE_M[1] * 1e3:.1f} mm gives "
                                           f"{plausible[0]:.3g}-{plausible[1]:.3g} N s/m; {c_pd:.3g} N s/m needs a flank "
                                           f"contact of {flank_needed[0] * 1e3:.2f}-{flank_needed[1] * 1e3:.2f} mm"
                                           + (f", against a surface wavelength of {lam * 1e3:.1f} mm" if lam else ""))}))
        fits.sort(key=lambda f: (not f.evidence["credible"], f.name))
        steps.append(SelectionStep(candidates=cand, kept=fits[0].name if fits else None, error_before=err0,
                                   error_after=0.0 if fits else err0, statistic=float("nan"), threshold=float("nan")))
    err_after = 0.0 if fits else err0
    return Identification(kind="stability", effects=tuple(fits), error_before=err0, error_after=err_after,
                          metric="fraction of the observations whose lobe verdict (SDM, 'marginal' = not stable) "
                                 "disagrees with the observed one (no held-out part: every observation is used)",
                          noise_floor=0.0, steps=tuple(steps), model_toml="",
                          extra={"observations": len(obs.rows), "verdicts_before": before, "variant": variant})
