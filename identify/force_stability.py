"""Stability observations: which effect, with which value, makes the lobes agree with observed cuts.

Candidates: the :class:`identify.cutting_effects.DampingEffect` s of the effect library
(:data:`identify.effects.REGISTRY`), each one parameter ``theta``, more damping = larger ``theta``:

* ``joint_damping`` (:class:`identify.cutting_effects.JointDamping`): a scale on every motion-axis
  damper, bounds [0.2, 50] (the paper's damping values come from a guess, eq. 8, so they are the
  first suspect);
* ``process_damping``: flank indentation, parameter ``Ksp L^2`` in [0, 9e6] N/m
  (:class:`identify.cutting_effects.ProcessDamping`): per observation a tool-tip damper in the cut
  plane ``Cc = Ksp L^2 b / (2 V) * (N / 2 pi) int n n^T dphi``, so it weakens as ``1 / V`` and
  grows with the depth ``b``.

**Pipeline** (fast: seconds per observation; the observation model, critical values and verdicts
are in :mod:`identify.stability_model`, the fit and the evidence here). Each observation's pose is linearized once; the
candidate enters only the damping, ``C(theta) = C_a + theta C_b`` (joint damping: ``C_b`` is the
motion-axis dampers, from a second linearization at scale 2; process damping: ``C_b = tcp^T Cc tcp``
per unit ``Ksp L^2``). The verdict at one (speed, depth, theta) is one SDM monodromy: stable when
its spectral radius is below 1. For each observation and candidate the *critical value*
``theta*`` (the radius crosses 1; the radius is taken to fall with damping, as it does for these
structures) is found by Brent's method on ``log theta`` with ``m = 40`` steps per period.

**The decision rule** (stated here once; the lobes' depth rule, :func:`lobes.depth_verdict`, read on
the parameter instead of the depth): ``theta*`` at ``m = 40`` is bounded by
``e = |theta*_40 - theta*_20|`` (for a first-order SDM, error ~ 1/m^2, the m = 40 error is e / 3,
so ``e`` bounds it with a factor 3 to spare). At a value ``theta`` an observation is *stable* if
``theta > theta* + e``, *unstable* if ``theta < theta* - e``, *undetermined* otherwise, and
undetermined counts as not stable (as "marginal" does in the lobes).

**Fit and error.** The error is the fraction of observations whose verdict disagrees with the
observed one; it is a step function of ``theta`` with steps at ``theta* +- e``, so it is minimized
exactly over those breakpoints. The value reported is inside the minimizing interval nearest the
neutral value (the smallest change that explains the data): just past its edge when the interval
runs to the bound, its geometric centre when observations bound it on both sides (the interval is
reported as ``consistent_interval``). An effect is reported only if it makes strictly fewer
observations disagree; candidates are ranked by their error after, then by credibility, and at
most ``max_effects`` are reported (the first is written into the model).

Binary observations hold no noise estimate and no held-out part: the error is the training
misclassification (``noise_floor`` 0). Ratio before/after for binary data (tests): misclassified
counts with +1 smoothing, ``(wrong_before + 1) / (wrong_after + 1)``.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from robolobes.cases import load_case
from robolobes.core.errors import BadInput

from .cutting_effects import FLANK_RANGE_M, KSP_RANGE_N_PER_M3, DampingEffect, ProcessDamping, process_damping_c
from .effects import REGISTRY
from .force_data import StabilityObservations
from .result import EffectFit, Evidence, Identification, SelectionStep
from .stability_model import (M_BOUND, M_VERDICT, SCALE_CREDIBLE, XTOL_LOG, Candidate, ObservationModel, Threshold,
                              candidate, critical_value, stability_effects, threshold, value_verdict, wavelength_m)

__all__ = ["identify_stability", "verdict_at", "wavelength_m", "KSP_RANGE_N_PER_M3", "FLANK_RANGE_M", "Candidate",
           "candidate", "ObservationModel", "Threshold", "critical_value", "threshold", "value_verdict",
           "M_VERDICT", "M_BOUND", "stability_effects"]


def _wrong(value: float, thresholds, chatter) -> int:
    return sum(1 for t, c in zip(thresholds, chatter) if (value_verdict(value, t).status == "stable") == c)


def _fit(cand: Candidate, thresholds, chatter) -> dict:
    """Minimize the misclassified count over ``theta`` (module doc): value, interval, count.

    The count is constant between the sorted breakpoints ``theta* +- e``: one probe inside each
    elementary interval decides it; runs of minimal intervals merge, and the run nearest the
    neutral value is kept."""
    pts = sorted({x for t in thresholds for x in t.band if math.isfinite(x) and cand.lower < x < cand.upper}
                 | {cand.lower, cand.upper})
    ivs = []
    for a, b in zip(pts[:-1], pts[1:]):
        mid = math.sqrt(a * b) if a > 0 else 0.5 * (a + b)
        ivs.append([a, b, _wrong(mid, thresholds, chatter)])
    best = min(w for _, _, w in ivs)
    runs = []
    for a, b, w in ivs:
        if w == best and runs and runs[-1][1] == a:
            runs[-1][1] = b
        elif w == best:
            runs.append([a, b])

    def dist(r):
        lo, hi = r
        if lo <= cand.neutral <= hi:
            return 0.0
        x = hi if hi < cand.neutral else lo
        return abs(math.log(x / cand.neutral)) if cand.neutral > 0 else x

    lo, hi = min(runs, key=dist)
    if lo <= cand.neutral <= hi:
        v = cand.neutral
    elif hi == cand.upper:
        v = lo * (1 + 2 * XTOL_LOG)
    elif lo == cand.lower:
        v = hi * (1 - 2 * XTOL_LOG)
    else:
        v = math.sqrt(lo * hi)
    return {"value": v, "wrong": best, "interval": (lo, hi)}


def verdict_at(state, case, obs, *, damping_scale: float = 1.0, ksp_l2_n_per_m: float = 0.0,
               m: int = M_VERDICT) -> dict:
    """The m-step SDM verdict of one observation (``|mu| < 1``: stable) with a joint-damping scale and
    a process damping ``Ksp L^2`` (N/m); ``state``: :class:`identify.effects.ModelState`."""
    om = ObservationModel.build(state, case, obs)
    s = om.physical
    C = np.asarray(s.C) + (damping_scale - 1.0) * om.lines["joint_damping"][1] + ksp_l2_n_per_m * om.lines["process_damping"][1]
    from robolobes.lobes import PhysicalStructure
    from robolobes.lobes.sdm import SDMEngine, SemiDiscretization

    prob = replace(om.problem, structure=PhysicalStructure(s.M, C, s.K, s.tcp))
    eng = SDMEngine(prob, SemiDiscretization(m=m), 1.01 * obs.depth_m)
    rho, _, f = eng.critical(np.array([obs.rpm]), np.array([obs.depth_m]))
    return {"stable": bool(rho[0] < 1), "spectral_radius": float(rho[0]), "chatter_freq_hz": float(f[0]), "m": m}


def _cases(obs: StabilityObservations, state) -> dict:
    names = {o.case for o in obs.rows}
    try:
        return {n: (state.case if n in (state.case.name, state.case_ref) or len(names) == 1 else load_case(n))
                for n in names}
    except BadInput as e:
        raise BadInput(f"{obs.path}: {e}") from None


def _pd_evidence(fit: dict, models, chatter_hz=None) -> dict:
    """Credibility of a process damping ``Ksp L^2``: the flank contact it needs against the surface
    wavelength, at the lowest observed speed (where the damper is largest) and that observation's
    chatter frequency (without the effect; ``chatter_hz`` overrides it, Hz)."""
    pdm = ProcessDamping()
    p = fit["value"]
    om = min(models, key=lambda o: o.obs.rpm)
    chatter_hz = chatter_hz if chatter_hz is not None else om.chatter_hz("joint_damping", 1.0)
    speed = pdm.speed_m_per_s(om.case.tool, om.problem.cut)
    flank = pdm.flank_m(p)
    lam = wavelength_m(speed, chatter_hz) if chatter_hz and math.isfinite(chatter_hz) else None
    cmax = process_damping_c(KSP_RANGE_N_PER_M3[1], FLANK_RANGE_M[1], om.obs.depth_m, speed)
    c = process_damping_c(p, 1.0, om.obs.depth_m, speed)
    credible = flank[1] <= FLANK_RANGE_M[1] and (lam is None or flank[1] <= 0.1 * lam)
    return {"cutting_speed_m_per_s": speed, "chatter_freq_hz": chatter_hz, "wavelength_m": lam,
            "flank_length_needed_m": list(flank), "c_per_tooth_n_s_per_m": c,
            "plausible_c_range_n_s_per_m": [process_damping_c(KSP_RANGE_N_PER_M3[0], FLANK_RANGE_M[0], om.obs.depth_m,
                                                              speed), cmax],
            "credible": bool(credible),
            "why": (f"Ksp L^2 = {p:.3g} N/m: c = Ksp L^2 b / (2V) = {c:.3g} N s/m per engaged tooth at "
                    f"{om.obs.rpm:g} rpm (V = {speed:.3g} m/s), b = {om.obs.depth_m * 1e3:.3g} mm; it needs a flank "
                    f"contact L = {flank[0] * 1e3:.2f}-{flank[1] * 1e3:.2f} mm for Ksp = "
                    f"{KSP_RANGE_N_PER_M3[1]:.0e}-{KSP_RANGE_N_PER_M3[0]:.0e} N/m^3 (sharp to worn: "
                    f"{FLANK_RANGE_M[0] * 1e3:.2f}-{FLANK_RANGE_M[1] * 1e3:.1f} mm)"
                    + (f", against a surface wavelength V/f = {lam * 1e3:.1f} mm" if lam else ""))}


def _jd_evidence(fit: dict) -> dict:
    s = fit["value"]
    ok = 1 / SCALE_CREDIBLE <= s <= SCALE_CREDIBLE
    return {"credible": bool(ok),
            "why": (f"x{s:.4g} of the paper's eq. 8 damping on every motion axis: "
                    f"{'within' if ok else 'far beyond'} the factor ~{SCALE_CREDIBLE:g} by which guessed joint "
                    f"damping is usually off (a servo's velocity loop can add damping, not {s:.3g}-fold on every axis)"
                    if not ok else f"x{s:.4g} of the paper's eq. 8 damping: within the factor ~{SCALE_CREDIBLE:g} by "
                    f"which guessed joint damping is usually off")}


def _model_toml(state, fit: EffectFit) -> str:
    """The case TOML with the best effect (its :meth:`Effect.apply`): joint damping as a
    ``joint_correction`` damping scale on every motion axis; process damping as the ``tip_damper`` of
    the case's own cut (it depends on depth and speed, so the file holds the damper of that cut only)."""
    from .model_toml import model_toml

    return model_toml(REGISTRY[fit.name].apply(state, fit.params))


def _evidence(c: Candidate, f: dict, models) -> dict:
    if c.name == "joint_damping":
        return _jd_evidence(f)
    if c.name == "process_damping":
        return _pd_evidence(f, models)
    from .evidence import credibility

    ok, why = credibility(REGISTRY[c.name], {c.param: f["value"]})
    return {"credible": bool(ok), "why": "; ".join(why) or f"{c.param} = {f['value']:.5g} inside its physical range"}


def identify_stability(obs: StabilityObservations, state, *, effects=None, max_effects: int = 3,
                       progress=None) -> Identification:
    """Which candidate (joint-damping scale, process damping ``Ksp L^2``) reconciles the observations.

    ``state`` is the model (:class:`identify.effects.ModelState`); rows whose case is the model's use
    its case (``--case`` overrides the measurement's, see :func:`identify.api.model_state`), other
    rows load theirs. ``effects``: the candidate damping effects (default :func:`stability_effects`;
    BadInput for one that is not a :class:`DampingEffect`); ``max_effects``: at most this many
    effects are reported, best first (0: none)."""
    chosen = stability_effects(state) if effects is None else list(effects)
    bad = [getattr(e, "name", repr(e)) for e in chosen if not isinstance(e, DampingEffect)]
    if bad or not chosen:
        raise BadInput(f"effects {', '.join(bad) or '(none)'}: stability observations fit damping effects (one "
                       f"parameter entering the damping); valid: {', '.join(e.name for e in stability_effects())}")
    cands = [Candidate.of(e) for e in chosen]
    cases_ = _cases(obs, state)
    models = []
    for o in obs.rows:
        models.append(ObservationModel.build(state, cases_[o.case], o))
    chatter = [o.chatter for o in obs.rows]
    n = len(obs.rows)
    thr = {}
    for c in cands:
        thr[c.name] = []
        for i, om in enumerate(models):
            if progress is not None:
                progress(f"{c.name}: observation {i + 1}/{n}")
            thr[c.name].append(threshold(om, c))
    ref = cands[0]  # the model before: every candidate at its neutral value is the unchanged model
    before = [value_verdict(ref.neutral, t) for t in thr[ref.name]]
    wrong0 = _wrong(ref.neutral, thr[ref.name], chatter)
    err0 = wrong0 / n
    chatter_hz = next((models[i].chatter_hz("joint_damping", 1.0) for i, v in enumerate(before)
                       if v.status != "stable"), None)
    fits, cand_err = [], {}
    for c in cands:
        f = _fit(c, thr[c.name], chatter)
        cand_err[c.name] = f["wrong"] / n
        if f["wrong"] >= wrong0:
            continue
        ev = _evidence(c, f, models)
        lo, hi = f["interval"]
        ev.update(rule="smallest change from neutral inside the interval of values with the fewest disagreeing "
                       "observations (SDM m = 40 verdict, bound |m 40 - m 20|)",
                  consistent_interval=[lo, hi], wrong_after=f["wrong"], wrong_before=wrong0,
                  thresholds=[{"value": t.value, "bound": t.bound} for t in thr[c.name]])
        half = 0.5 * (hi - lo) if math.isfinite(hi - lo) and hi < c.upper and lo > c.lower else \
            max((t.bound for t in thr[c.name] if math.isfinite(t.bound)), default=math.nan)
        fits.append(EffectFit(c.name, {c.param: f["value"]}, {c.param: half}, ev))
    fits.sort(key=lambda f: (f.evidence["wrong_after"], not f.evidence["credible"], f.name))
    if len(fits) > 1 and fits[0].evidence["wrong_after"] == fits[1].evidence["wrong_after"]:
        fits = [replace(f, evidence=Evidence.of(f.evidence, tied=True)) for f in fits]
    fits = fits[:max_effects]
    err_after = fits[0].evidence["wrong_after"] / n if fits else err0
    steps = (SelectionStep(candidates=cand_err, kept=fits[0].name if fits else None, error_before=err0,
                           error_after=err_after, statistic=float(wrong0 - (fits[0].evidence["wrong_after"] if fits
                                                                            else wrong0)), threshold=1.0),)
    model = _model_toml(state, fits[0]) if fits else ""
    keys = {e.name: e.verdict_key or f"critical_{e.name}" for e in chosen if isinstance(e, DampingEffect)}
    vb = [{"rpm": obs.rows[i].rpm, "depth_mm": obs.rows[i].depth_m * 1e3,
           "observed": "chatter" if obs.rows[i].chatter else "stable",
           "verdict": v.status, "stable": v.stable, "verdict_reason": v.reason,
           **{keys[c.name]: thr[c.name][i].value for c in cands}}
          for i, v in enumerate(before)]
    return Identification(kind="stability", effects=tuple(fits), error_before=err0, error_after=err_after,
                          metric="fraction of the observations whose lobe verdict (SDM m = 40, bound |m 40 - m 20| on "
                                 "the critical value; undetermined = not stable) disagrees with the observed one "
                                 "(no held-out part: every observation is used)",
                          noise_floor=0.0, steps=steps, model_toml=model,
                          extra={"observations": n, "verdicts_before": vb, "chatter_freq_hz": chatter_hz,
                                 "variant": state.variant})
