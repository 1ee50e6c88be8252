"""Compute the study: modes, lobes, time domain, damping search, paper tables -> :class:`StudyResult`.

For the two built-in cases (``tx200-aluminium``, ``tx200-steel``):

1. modes and tool-tip FRFs at the start, middle and end of the pass, four model variants;
2. each cut against the stability lobes at those poses (margin, limit, bifurcation, chatter
   frequency, the mode that chatters), lobe diagrams and the lowest limits over 300-30000 rpm;
3. time-domain passes of both cases in the four variants;
4. the smallest joint-damping scale that stabilizes steel (the paper says x10) by the lobes, by the
   eroded-part time domain and by the delay-based time domain (the lobes' linear problem), each as
   a bracket [largest unstable, smallest stable];
5. the paper's Tab. 10 (forces) and Tab. 11/12 (roughness) beside ours;
6. (full study) the seed's facts confronted with identification: (a) Tab. 10 identified by force
   statistics, (b) the steel cut observed stable (:mod:`robolobes.study.force_facts`).

Nothing here writes a file: :mod:`.output` renders the result.
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import asdict, replace
from typing import Callable, cast

import numpy as np

from robolobes import cases
from robolobes.core.io import provenance, to_jsonable
from robolobes.core.verdict import Verdict
from robolobes.linearize.summary import modes_summary
from robolobes.linearize.kinematics import JointLimitWarning
from robolobes.linearize.model import VARIANTS
from robolobes.linearize.path import Pass

from .linearizations import Linearizations
from .result import (DampingProbe, DampingSearch, DominantMode, LobeDiagram, LowestLimit, MaterialFacts, ModeSet,
                     OperatingPoint, RoughnessRow, StudyResult, Tab10Row, TimeDomainRun, as_verdict)
from .settings import LOBE_RANGES_RPM, MATERIALS, PAPER, POSES, StudySettings

__all__ = ["compute_study", "load_inputs", "study_poses", "compute_modes", "compute_operating_points",
           "compute_diagrams", "compute_lowest_limits", "lowest_limit", "bracket_search", "damping_by_lobes",
           "damping_by_time_domain", "damping_by_delay", "orbit_probe", "exponent_verdict", "lobes_tool", "eroded_deflection", "compute_time_domain", "compute_identify_facts", "FRF_FREQ_HZ"]

Progress = Callable[[float], None]

#: Frequencies of the study's FRFs, Hz (600 points over the robot's modes).
FRF_FREQ_HZ = np.linspace(1.0, 300.0, 600)


def _quiet(f: float) -> None:
    return None


def _sub(progress: Progress, lo: float, hi: float) -> Progress:
    return lambda f: progress(lo + (hi - lo) * f)


# ------------------------------------------------------------------------------------------ inputs
def load_inputs() -> tuple[dict, Pass, dict]:
    """``(cases by material, the aluminium pass, the paper's results)``.

    When both cases carry equal robots, steel gets aluminium's robot object, so that the shared
    :class:`Linearizations` builds and linearizes it once for both.
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", JointLimitWarning)  # the Tab. 7 A3 warning, reported in the notes
        cs = {k: cases.load_case(v) for k, v in MATERIALS.items()}
        pas = Pass.from_case(cs["aluminium"])
    if repr(cs["steel"].robot) == repr(cs["aluminium"].robot):
        cs["steel"] = replace(cs["steel"], robot=cs["aluminium"].robot)
    return cs, pas, cases.load_reference(PAPER)


def study_poses(pas: Pass) -> dict[str, np.ndarray]:
    """Motor angles (6,) rad of the study's poses (``POSES``: fractions of the pass travel)."""
    return {k: pas.theta_at_s(f * pas.travel_m) for k, f in POSES.items()}


def study_inputs(settings: StudySettings, cs: dict, paper: dict) -> dict:
    """What the study's result depends on (hashed into its provenance)."""
    def describe(case):
        try:
            return to_jsonable(asdict(case))
        except TypeError:
            return repr(case)
    return {"study": "tx200 aluminium vs steel", "settings": to_jsonable(asdict(settings)),
            "cases": {k: describe(c) for k, c in cs.items()}, "reference": to_jsonable(paper)}


# ------------------------------------------------------------------------------------------ modes
def _frf_peaks_um_per_n(frf) -> dict:
    """Largest |H_ii| (um/N) of the direct feed and normal receptances of a cut-frame FRF (3, 3, n)."""
    H = np.asarray(frf.H)
    return {ax: float(np.max(np.abs(H[i, i])) * 1e6) for i, ax in enumerate(("feed", "normal"))}


def compute_modes(lins: Linearizations, case, poses: dict, progress: Progress = _quiet) -> tuple:
    """Modes, TCP stiffness and cut-frame FRFs of the four variants at the study's poses."""
    out = []
    w = 2 * math.pi * FRF_FREQ_HZ
    jobs = [(v, p) for v in VARIANTS for p in poses]
    for k, (variant, pose) in enumerate(jobs):
        robot = lins.robot(case.robot, variant)
        summary = modes_summary(robot, poses[pose], case)
        frf = lins.at(case.robot, variant, pose, poses[pose]).frf(
            w, frame="cut", feed_direction=case.cut.feed_direction)
        keep = ("freq_hz", "damped_freq_hz", "damping_ratio", "q_deg", "tcp_position_m", "tool_axis",
                "tcp_static_stiffness_n_per_m", "modal_stiffness_n_per_m", "tcp_gravity_deflection_m", "notes")
        out.append(ModeSet(variant, pose, {kk: summary[kk] for kk in keep}, _frf_peaks_um_per_n(frf),
                           f"frf/frf_{variant}_{pose}.csv", frf))
        progress((k + 1) / len(jobs))
    return tuple(out)


# ------------------------------------------------------------------------------------------ lobes
def mode_contributions(lin, case, freq_hz: float) -> np.ndarray:
    """|contribution| of each mode (n_modes,) to the normal cut-frame receptance at ``freq_hz``, m/N."""
    modes = lin.modes("cut", case.cut.feed_direction)
    w = 2 * math.pi * freq_hz
    res = np.asarray(modes.residues)[:, 1, 1]
    lam = np.asarray(modes.poles)
    contrib = res / (1j * w - lam)
    out = np.zeros(modes.freq_hz.shape[-1])
    for r in range(len(out)):  # pair each listed mode (upper pole) with its conjugate
        conj = int(np.argmin(np.abs(lam - np.conj(lam[r]))))
        out[r] = abs(contrib[r] + (contrib[conj] if conj != r else 0))
    return out


def _dominant_mode(lin, case, freq_hz: float) -> DominantMode | None:
    if not math.isfinite(freq_hz):
        return None
    contrib = mode_contributions(lin, case, freq_hz)
    r = int(np.argmax(contrib))
    modes = lin.modes()
    return DominantMode(r + 1, float(modes.freq_hz[r]), float(modes.damping_ratio[r]),
                        float(contrib[r] / contrib.sum()))


def _lobe_problem(st, case):
    from robolobes.lobes.problem import LobeProblem
    return LobeProblem(st, case.tool, case.cut, case.law)


def _operating_point(lins, case, material, variant, pose, theta, method) -> OperatingPoint:
    from robolobes.lobes.solver import stability
    lin, st = lins.structure(case, variant, pose, theta)
    op = stability(_lobe_problem(st, case), method)
    f_ch = op.limit_chatter_freq_hz if math.isfinite(op.limit_chatter_freq_hz) else op.chatter_freq_hz
    return OperatingPoint(
        material, variant, pose, as_verdict(op.verdict), op.depth_m, op.depth_limit_m, op.depth_limit_error_m,
        op.margin, op.margin_error, op.spectral_radius, str(op.bifurcation), op.chatter_freq_hz,
        str(op.limit_bifurcation), op.limit_chatter_freq_hz, tuple(h["m"] for h in op.history),
        _dominant_mode(lin, case, f_ch), op)


def compute_operating_points(settings, lins, cs, poses, progress: Progress = _quiet) -> tuple:
    """Each cut against the lobes, every variant, at the settings' poses (SDM, m and 2m)."""
    from robolobes.lobes.sdm import SemiDiscretization
    method = SemiDiscretization(m=settings.sdm_m)
    jobs = [(mat, v, p) for mat in cs for v in VARIANTS for p in settings.lobe_poses]
    out = []
    for k, (mat, variant, pose) in enumerate(jobs):
        out.append(_operating_point(lins, cs[mat], mat, variant, pose, poses[pose], method))
        progress((k + 1) / len(jobs))
    return tuple(out)


def compute_diagrams(settings, lins, cs, poses, progress: Progress = _quiet) -> tuple:
    """Lobe diagrams (SDM, ``settings.n_rpm`` speeds, up to 10 mm) of the settings' variants."""
    from robolobes.lobes.sdm import SemiDiscretization
    from robolobes.lobes.solver import solve
    method = SemiDiscretization(m=settings.sdm_m)
    jobs = [(mat, v, p) for mat in cs for v in settings.lobe_variants for p in settings.lobe_poses]
    out = []
    for k, (mat, variant, pose) in enumerate(jobs):
        _, st = lins.structure(cs[mat], variant, pose, poses[pose])
        rpm = np.linspace(*LOBE_RANGES_RPM[mat], settings.n_rpm)
        res = solve(_lobe_problem(st, cs[mat]), method, rpm, depth_max_m=0.01)
        out.append(LobeDiagram(mat, variant, pose, np.asarray(res.spindle_rpm), np.asarray(res.depth_limit_m),
                               np.asarray(res.chatter_freq_hz), tuple(np.asarray(res.bifurcation).tolist()),
                               float(res.stats["wall_s"]), f"lobes_{mat}_{variant}_{pose}.png", res))
        progress((k + 1) / len(jobs))
    return tuple(out)


def compute_lowest_limits(lins, cs, poses) -> tuple:
    """Smallest limit of the default refined lobes over 300-30000 rpm, depths to 1 m, basic model,
    start pose (:class:`LowestLimit` per material), by :func:`lowest_limit`."""
    out = []
    for mat, case in cs.items():
        _, st = lins.structure(case, "basic", "start", poses["start"])
        r, j = lowest_limit(_lobe_problem(st, case), np.geomspace(300, 30000, 400))
        out.append(LowestLimit(mat, float(r.depth_limit_m[j]), float(r.depth_error_m[j]), float(r.spindle_rpm[j]),
                               str(r.bifurcation[j]), float(r.chatter_freq_hz[j])))
    return tuple(out)


def lowest_limit(problem, rpm, n_local: int = 3, depth_max_m: float = 1.0):
    """The lowest refined limit of ``problem`` over the speeds ``rpm`` (S,), rpm: ``(result, j)``,
    the :class:`~robolobes.lobes.LobeResult` holding it and its index there.

    The default ``RefinedSDM()`` diagram at ``rpm``; then, at each of its ``n_local`` lowest local
    minima ``j``, Brent's bounded search in speed between ``rpm[j-1]`` and ``rpm[j+1]`` (to 1e-4
    of the speed), each probe a one-speed diagram. The bottom of a lobe narrower than the grid's
    step lies between samples: at 400 speeds over 300-30000 rpm on the TX200 (basic, Tab. 7 pose)
    the sampled minimum was 6.5 % (steel) and 7.2 % (aluminium) above the bottom the search found.
    A lobe that the grid misses altogether stays missed.
    """
    from scipy.optimize import minimize_scalar

    from robolobes.lobes.solver import solve
    best = solve(problem, None, rpm, depth_max_m=depth_max_m)
    d = best.depth_limit_m
    j_best = int(np.argmin(d))
    inner = np.arange(1, len(d) - 1)
    minima = inner[np.isfinite(d[inner]) & (d[inner] <= d[inner - 1]) & (d[inner] <= d[inner + 1])]
    probes: dict = {}

    def limit(x):
        probes[x] = solve(problem, None, [x], depth_max_m=depth_max_m)
        return probes[x].depth_limit_m[0]

    for j in minima[np.argsort(d[minima], kind="stable")][:n_local]:
        minimize_scalar(limit, bounds=(rpm[j - 1], rpm[j + 1]), method="bounded", options={"xatol": 1e-4 * rpm[j]})
    for r in probes.values():
        if r.depth_limit_m[0] < best.depth_limit_m[j_best]:
            best, j_best = r, 0
    return best, j_best


# ------------------------------------------------------------------------------------------ damping
def bracket_search(check: Callable[[float], DampingProbe], scales, tol: float, method: str,
                   variant: str) -> DampingSearch:
    """Bracket the smallest stabilizing scale: ``check(scale)`` is tried on ``scales`` in increasing
    order until one is stable, then [last not stable, first stable] is bisected until narrower than
    ``tol``. Assumes one crossing (more damping, more stable); "undetermined" counts as not stable.
    """
    probes: dict[float, DampingProbe] = {}
    lo = hi = None
    for sc in sorted(scales):
        probes[sc] = check(sc)
        if probes[sc].verdict.stable is True:
            hi = sc
            break
        lo = sc
    while hi is not None and lo is not None and hi - lo > tol:
        mid = 0.5 * (lo + hi)
        probes[mid] = check(mid)
        lo, hi = (lo, mid) if probes[mid].verdict.stable is True else (mid, hi)
    return DampingSearch(method, variant, tuple(probes[k] for k in sorted(probes)), lo, hi, tol)


def damping_by_lobes(settings, lins, steel, theta_start, variant: str = "basic", dy_m: float | None = None,
                     seed: tuple = (), orbit: bool = False) -> DampingSearch:
    """Damping bracket by the lobes: stable when the SDM limit at the cut speed exceeds the cut
    depth beyond its discretization error bound (Tab. 7 pose).

    ``dy_m``: the SDM at the radial depth ``ae - dy_m`` instead of the nominal ``ae`` (the eroded
    part's engagement: its tool cuts deflected by ``dy``; method "lobes at ae - dy" with its mean
    normal deflection). ``orbit``: the eroded part's linearization about its forced orbit instead,
    the SDM with the entry shift, the surface tilt and the delayed instant (:func:`orbit_probe`;
    method "lobes about the forced orbit", ``dy_m`` then the deflection when the teeth meet the
    part). ``seed``: scales tried besides ``settings.damping_scales``."""
    from robolobes.lobes.sdm import SemiDiscretization
    method = SemiDiscretization(m=settings.sdm_m)
    case = steel if dy_m is None else replace(steel, cut=replace(steel.cut, ae_m=steel.cut.ae_m - dy_m))
    probe = orbit_probe if orbit else limit_probe

    def check(scale):
        lin, st = lins.structure(steel, variant, "start", theta_start, damping_scale=scale)
        verdict, info = probe(_lobe_problem(st, case), method)
        return DampingProbe(scale, verdict, {**info, "slowest_decay_per_s": _slowest_decay(lin),
                                             "ae_m": case.cut.ae_m})

    scales = sorted(set(settings.damping_scales) | {float(s) for s in seed if s is not None})
    name = "lobes about the forced orbit" if orbit else "lobes" if dy_m is None else "lobes at ae - dy"
    return bracket_search(check, scales, settings.damping_tol, name, variant)


def limit_probe(problem, method) -> tuple:
    """The lobes' verdict of ``problem`` (SDM limit against the cut depth) and its numbers."""
    from robolobes.lobes.solver import stability
    op = stability(problem, method)
    return as_verdict(op.verdict), {
        "depth_limit_m": op.depth_limit_m, "depth_limit_error_m": op.depth_limit_error_m, "margin": op.margin,
        "spectral_radius": op.spectral_radius, "bifurcation": str(op.limit_bifurcation),
        "chatter_freq_hz": op.limit_chatter_freq_hz}


def orbit_probe(problem, method) -> tuple:
    """The verdict of ``problem`` by the sign of its Floquet exponent linearized as the eroded part is,
    about its forced orbit: the entry shift, the surface tilt and the delayed instant
    (:func:`~robolobes.lobes.entry_shift.entry_shift_exponent` with ``surface_tilt`` and
    ``delay_time``, Richardson from m and 2m); "undetermined" when |exponent| is not above its
    Richardson error. Info: the exponent and its error, 1/s."""
    from robolobes.lobes.entry_shift import entry_shift_exponent
    e = entry_shift_exponent(problem, method, with_entry=True, surface_tilt=True, delay_time=True)
    return exponent_verdict(e.value_per_s, e.error_per_s), {
        "exponent_per_s": e.value_per_s, "exponent_error_per_s": e.error_per_s}


def exponent_verdict(value_per_s: float, error_per_s: float) -> Verdict:
    """Stable / unstable by the sign of a Floquet exponent, "undetermined" when ``|value| <= error``."""
    if abs(value_per_s) <= error_per_s:
        return Verdict("undetermined", f"exponent {value_per_s:+.3g} 1/s within its Richardson error "
                                       f"{error_per_s:.2g} 1/s")
    return Verdict.from_stable(value_per_s < 0, f"exponent {value_per_s:+.3g} ± {error_per_s:.2g} 1/s")


def eroded_deflection(d: DampingSearch, key: str = "mean_normal_deflection_m") -> float | None:
    """Mean over the eroded probes at the ends of their bracket of their deflection ``key`` (their
    mean normal deflection, or ``"entry_normal_deflection_m"``: when the teeth meet the part), m
    (None if unknown)."""
    dys = [p.info.get(key) for p in d.probes if p.scale in d.bracket]
    dys = [v for v in dys if v is not None]
    return float(np.mean(dys)) if dys else None


def _slowest_decay(lin) -> float:
    """Smallest modal decay rate ``zeta w_n`` of a linearization, 1/s."""
    return float(np.min(-np.real(np.asarray(lin.modes().poles))))


#: Amplitude of the eroded damping probes' kick, m: a velocity kick of a 100 nm oscillation at half
#: the tooth passing frequency (the steel flip), at the start of full engagement. Unkicked, the
#: regenerative mode starts at 1-5 nm, at the verdict's 2 nm resolution, and the verdict near the
#: bracket reads that floor (docs/guide/timedomain-convergence.md, "The steel damping bracket: the
#: eroded part's floor").
ERODED_KICK_M = 1e-7


def eroded_kick_m_s(case) -> float:
    """The eroded probes' velocity kick, m/s: ``ERODED_KICK_M`` times the angular frequency of half
    the principal (tooth) passing frequency of ``case``."""
    from robolobes.cases.milling import principal_period
    tp, _ = principal_period(case.tool, case.cut)
    return math.pi / tp * ERODED_KICK_M


def damping_by_time_domain(settings, steel, variant: str = "basic", progress: Progress = _quiet,
                           cache: dict | None = None, lins: Linearizations | None = None,
                           seed: tuple = ()) -> DampingSearch:
    """Damping bracket by the time-domain verdict of the steel pass (always the linearized fast
    path: a bisection takes about nine passes), each pass kicked at full engagement
    (:func:`eroded_kick_m_s`).

    ``seed``: scales tried besides ``settings.damping_scales`` (the study gives the lobes' bracket,
    so that the probes land where the two methods are compared). The search assumes one crossing.
    Info of each probe: its rate, its mean normal deflection and the deflection when the teeth meet
    the part (:func:`robolobes.timedomain.forced_orbit.entry_deflection`), m."""
    from robolobes.timedomain.forced_orbit import entry_deflection, mean_deflection
    fast = replace(settings, td_linearized=True)
    kick = eroded_kick_m_s(steel)
    n = [0]

    def check(scale):
        run = simulate_run(steel, "steel", variant, fast, settings.steel_t_end_s, scale, cache=cache, lins=lins,
                           kick_m_s=kick)
        n[0] += 1
        progress(min(1.0, n[0] / 9))
        s = run.summary
        steady = s.get("steady_window_s") is not None   # deflections need a steady window
        return DampingProbe(scale, run.verdict, {**{k: s.get(k) for k in
                                                    ("chatter_freq_hz", "growth_rate_per_s", "growth_rate_se_per_s",
                                                     "growth_rate_ci_per_s", "verdict_basis")},
                                                 "mean_normal_deflection_m": mean_deflection(run.series) if steady else None,
                                                 "entry_normal_deflection_m": entry_deflection(run.series) if steady else None,
                                                 "kick_m_s": kick})

    scales = sorted(set(settings.damping_scales) | {float(s) for s in seed if s is not None})
    return bracket_search(check, scales, settings.td_damping_tol, "time domain", variant)


#: Initial displacement of the delay-based damping probes, m (the convergence page's steel runs).
DELAY_KICK_M = 1e-7


def lobes_tool(tool, cut):
    """The tool as the lobes see it: without runout when the runout changes neither which teeth cut
    nor their delays (the SDM then solves the same linear problem with and without it; with runout
    the forced response has a period-2 part that above the limit is not linear)."""
    from robolobes.cases.milling import regeneration
    plain = replace(tool, runout_m=(0.0,) * tool.teeth)
    same = [(r.cuts, r.delay_rad) for r in regeneration(tool, cut)] == \
        [(r.cuts, r.delay_rad) for r in regeneration(plain, cut)]
    return plain if same else tool


def damping_by_delay(settings, lins: Linearizations, steel, theta_start, variant: str = "basic",
                     seed: tuple = (), progress: Progress = _quiet) -> DampingSearch:
    """Damping bracket by the delay-based regenerative model (``DelayNewmark``): the lobes' linear
    problem (the same linearized structure at the Tab. 7 pose, the same cut at the nominal radial
    depth, :func:`lobes_tool`) simulated for ``settings.steel_t_end_s`` from a 0.1 um kick; its rate
    converges to the SDM's Floquet exponent, so its bracket is the like-with-like check of the
    lobes'. ``seed``: scales tried besides ``settings.damping_scales`` (the lobes' bracket)."""
    from robolobes.timedomain import DelayNewmark, simulate
    from robolobes.timedomain.delay import StructureProblem
    tool = lobes_tool(steel.tool, steel.cut)
    t_end = settings.steel_t_end_s or 5.5
    n = [0]

    def check(scale):
        _, st = lins.structure(steel, variant, "start", theta_start, damping_scale=scale)
        r = simulate(StructureProblem(st, tool, steel.cut, steel.law, t_end_s=t_end), DelayNewmark(kick_m=DELAY_KICK_M))
        n[0] += 1
        progress(min(1.0, n[0] / 6))
        v = r.verdict.to_json()
        rate = r.rate
        return DampingProbe(scale, as_verdict(r.verdict.verdict), {
            "growth_rate_per_s": v.get("growth_rate_per_s"), "growth_rate_se_per_s": v.get("growth_rate_se_per_s"),
            "growth_rate_ci_per_s": v.get("growth_rate_ci_per_s"),
            "gated_rate_per_s": None if rate.estimate is None else rate.rate_per_s,
            "gated_rate_se_per_s": None if rate.estimate is None else rate.se_per_s,
            "chip_loss_fraction": v.get("chip_loss_fraction"), "t_end_s": t_end, "kick_m": DELAY_KICK_M,
            "runout": tool is steel.tool and max(tool.runout_m) > 0, "cpu_s": r.stats["cpu_s"]})

    memo: dict[float, DampingProbe] = {}

    def once(scale):
        if scale not in memo:
            memo[scale] = check(scale)
        return memo[scale]

    # from the lobes' bracket up (a run far below it, x1, costs as much as all the others: its chip
    # is lost at every tooth pass); below it only if the bracket's unstable side is stable here
    given = sorted({float(s) for s in seed if s is not None})
    low = given[0] if given else -math.inf
    scales = sorted(set(given) | {float(s) for s in settings.damping_scales if s > low})
    d = bracket_search(once, scales, settings.td_damping_tol, "delay-based time domain", variant)
    if d.largest_unstable is None and given:
        scales = sorted(set(scales) | {float(s) for s in settings.damping_scales})
        d = bracket_search(once, scales, settings.td_damping_tol, "delay-based time domain", variant)
    return DampingSearch(d.method, d.variant, tuple(memo[k] for k in sorted(memo)), d.largest_unstable,
                         d.smallest_stable, d.resolution)


# ------------------------------------------------------------------------------------------ time domain
_TD_KEYS = ("stable", "verdict", "verdict_reason", "growth_rate_per_s", "growth_rate_se_per_s",
            "growth_rate_ci_per_s", "regenerative_ratio", "chatter_freq_hz", "nonsynchronous_peak_hz", "stability",
            "verdict_basis", "force_stats", "force_stats_paper_axes", "force_stats_window_s", "roughness_um",
            "tcp_deviation_y_um", "wall_y_um", "steady_window_s", "note")


def simulate_run(case, material, variant, settings, t_end, damping_scale=1.0, stats_window=None,
                 progress=None, cache: dict | None = None, lins: Linearizations | None = None,
                 kick_m_s: float = 0.0) -> TimeDomainRun:
    """One pass of ``case`` (``settings.td_linearized``: the linearized fast path). ``cache``: runs
    already simulated, by (material, variant, damping scale, path, duration, window, kick); a run
    asked for twice is simulated once. ``kick_m_s``: the linearized path's velocity kick at full
    engagement, m/s (``LinearizedNewmark.kick_m_s``; the full model has none: 0 there)."""
    if kick_m_s != 0.0 and not settings.td_linearized:
        raise ValueError(f"kick_m_s = {kick_m_s:g}: only the linearized path has a velocity kick; valid: 0 "
                         f"on the full model")
    key = (material, variant, float(damping_scale), settings.td_linearized, t_end, stats_window, kick_m_s)
    if cache is not None and key in cache:
        return cache[key]
    run = _simulate_run(case, material, variant, settings, t_end, damping_scale, stats_window, progress,
                        Linearizations() if lins is None else lins, kick_m_s)
    if cache is not None:
        cache[key] = run
    return run


def _simulate_run(case, material, variant, settings, t_end, damping_scale, stats_window, progress,
                  lins: Linearizations, kick_m_s: float = 0.0) -> TimeDomainRun:
    from robolobes.timedomain import LinearizedNewmark, NonlinearNewmark, SimulationProblem, simulate
    from robolobes.timedomain.result import SimulationResult
    robot = lins.robot(case.robot, variant, damping_scale)
    pb = SimulationProblem(robot, case, t_end_s=t_end, stats_window_s=stats_window)
    # a SimulationProblem with a Newmark method gives a SimulationResult (simulate's return is a union)
    r = cast(SimulationResult, simulate(pb, LinearizedNewmark(kick_m_s=kick_m_s) if settings.td_linearized else NonlinearNewmark(),
                                        progress=progress))
    assert r.summary is not None
    s = r.summary.to_json()
    summary = {k: s[k] for k in _TD_KEYS if s.get(k) is not None}
    verdict = as_verdict(s.get("verdict", s.get("stable")), s.get("verdict_reason") or s.get("note") or "")
    return TimeDomainRun(material, variant, float(damping_scale), verdict, s.get("chatter_freq_hz"),
                         float(r.t_s[-1]), float(s.get("wall_s") or r.stats.get("wall_time_s", 0.0)),
                         int(r.stats["steps"]), summary, r)


def compute_time_domain(settings, cs, paper, damping_scale_extra: float | None = None,
                        progress: Progress = _quiet, cache: dict | None = None,
                        lins: Linearizations | None = None) -> tuple:
    """Aluminium and steel passes, four variants, nominal damping (aluminium's force statistics
    over the Tab. 10 window); then steel (basic) at ``damping_scale_extra`` if given."""
    win = tuple(measured_tab10().window_s)  # the window of the measured Tab. 10 row
    jobs = [("aluminium", v) for v in VARIANTS] + [("steel", v) for v in VARIANTS]
    out = []
    for i, (mat, variant) in enumerate(jobs):
        al = mat == "aluminium"
        out.append(simulate_run(cs[mat], mat, variant, settings, settings.al_t_end_s if al else settings.steel_t_end_s,
                                1.0, win if al else None, progress=lambda f: progress((i + f) / len(jobs)), cache=cache,
                                lins=lins))
    if damping_scale_extra is not None:
        out.append(simulate_run(cs["steel"], "steel", "basic", settings, settings.steel_t_end_s, damping_scale_extra,
                                cache=cache, lins=lins))
    return tuple(out)


# ------------------------------------------------------------------------------------------ paper tables
TAB10_COLUMNS = ("fx_min", "fy_min", "fx_max", "fy_max", "fx_mean", "fy_mean", "fx_rms", "fy_rms")


def measured_tab10():
    """The paper's measured Tab. 10 row as shipped in ``force_stats.toml`` (identify's format):
    ``ForceStatistics`` with ``stats[axis][min|max|mean|rms]`` in N, paper axes, and ``window_s``."""
    from robolobes.identify.force_data import read_force_stats
    from robolobes.study.force_facts import TAB10_FILE
    m = read_force_stats(TAB10_FILE)
    if m.axes != "paper":
        raise ValueError(f"{TAB10_FILE}: the study compares forces in the paper's axes, got axes = {m.axes!r}")
    return m


def tab10_rows(paper: dict, runs) -> tuple:
    """Tab. 10: the measured row (``force_stats.toml``), the paper's model rows, then ours
    (aluminium, each variant, same window and axes), N."""
    m = measured_tab10()
    rows = [Tab10Row("paper experimental", {f"f{ax}_{k}": m.stats[ax][k] for ax in ("x", "y")
                                            for k in ("min", "max", "mean", "rms")})]
    rows += [Tab10Row(f"paper {name}", dict(zip(TAB10_COLUMNS, vals)))
             for name, vals in paper["aluminium"]["tab10"].items() if name not in ("window_s", "experimental")]
    for r in runs:
        fs = r.summary.get("force_stats_paper_axes")
        if r.material == "aluminium" and r.damping_scale == 1.0 and fs:
            rows.append(Tab10Row(f"robolobes {r.variant}", {f"f{ax}_{k}": fs[ax][k] for ax in ("x", "y")
                                                            for k in ("min", "max", "mean", "rms")}))
    return tuple(rows)


def roughness_rows(paper: dict, runs) -> tuple:
    """Tab. 11/12 (simulation and measured ranges) beside ours (basic and backlash), um."""
    rows = []
    for mat in ("aluminium", "steel"):
        ref = paper[mat]["roughness_um"]
        for name in ("simulation", "experimental"):
            r = ref[name]
            rows.append(RoughnessRow(f"paper {mat} {name}", *(tuple(r[k]) if isinstance(r[k], list) else r[k]
                                                              for k in ("Ra", "Rq", "Rt"))))
        for variant in ("basic", "backlash"):
            run = next((x for x in runs if (x.material, x.variant, x.damping_scale) == (mat, variant, 1.0)), None)
            ru = (run.summary.get("roughness_um") or {}) if run else {}
            rows.append(RoughnessRow(f"robolobes {mat} {variant}", ru.get("Ra"), ru.get("Rq"), ru.get("Rt")))
    return tuple(rows)


# ------------------------------------------------------------------------------------------ explanation
def material_facts(case, modes, op: OperatingPoint, lowest: LowestLimit, run: TimeDomainRun) -> MaterialFacts:
    """The numbers of the explanation for one material (basic model, start pose)."""
    f_tp = case.cut.spindle_rpm / 60 * case.tool.teeth
    f6 = next(m for m in modes if (m.variant, m.pose) == ("basic", "start")).freq_hz
    f18 = next(m for m in modes if (m.variant, m.pose) == ("orthogonal", "start")).freq_hz
    return MaterialFacts(
        spindle_rpm=case.cut.spindle_rpm, tooth_passing_hz=f_tp, lowest_mode_hz=float(f6[0]), n_modes_basic=len(f6),
        modes_below_tooth_passing_basic=int(np.sum(f6 < f_tp)),
        modes_below_tooth_passing_orthogonal=int(np.sum(f18 < f_tp)),
        ktc_pa=case.law.ktc_pa, krc_pa=case.law.krc_pa, depth_m=case.cut.ap_m, lobes_verdict=op.verdict,
        local_limit_m=op.depth_limit_m, local_margin=op.margin, bifurcation=op.limit_bifurcation,
        chatter_freq_hz_lobes=op.limit_chatter_freq_hz, dominant_mode=op.dominant_mode,
        lowest_limit_m=lowest.depth_m, time_domain_verdict_basic=run.verdict,
        chatter_freq_hz_time_domain=run.chatter_freq_hz)


NOTES = ("The Tab. 7 pose has A3 = -212.14 deg = +147.86 deg, 2.86 deg past the +145 deg datasheet limit: "
         "accepted with a warning.",
         "Forces in the paper's axes: Fx along the feed (force on the tool), Fy normal pointing into the material "
         "(see timedomain.workpiece_force).")


# ------------------------------------------------------------------------------------------ driver
def compute_identify_facts(settings: StudySettings) -> dict:
    """Facts (a) Tab. 10 and (b) steel by identification, those named in ``settings.identify_facts``;
    a fact not computed is None."""
    from robolobes.study.force_facts import steel_fact, tab10_fact

    run = {"tab10": tab10_fact, "steel": steel_fact}
    return {k: (f() if k in settings.identify_facts else None) for k, f in run.items()}


def compute_study(settings: StudySettings, progress: Progress = _quiet,
                  lins: Linearizations | None = None) -> StudyResult:
    """Run every computation of the study and return its typed result (nothing is written).

    ``progress(fraction)`` is called as the work advances; ``lins`` (default: a new shared cache)
    is where robots and linearizations are kept; with ``lins.share`` False, simulated runs are not
    shared either (the behaviour before sharing, for ``bench/bench_study.py``).

    The whole study takes minutes (``robolobes study --quick``: :func:`robolobes.study.run_study`
    with ``quick=True``). Its first comparison in a few lines, on the same inputs and shared
    linearizations: each cut against the lobes at the start of the pass, basic variant. As in the
    paper's model, aluminium is stable and steel is not (margin -0.60, a flip at 51.7 Hz, half
    the 103.3 Hz tooth passing frequency), although the real steel cut was stable.

    >>> from robolobes.lobes import LobeProblem, stability
    >>> from robolobes.study.compute import load_inputs, study_poses
    >>> from robolobes.study.linearizations import Linearizations
    >>> cs, pas, paper = load_inputs()
    >>> theta = study_poses(pas)["start"]
    >>> lins = Linearizations()
    >>> for material, case in cs.items():
    ...     _, st = lins.structure(case, "basic", "start", theta)
    ...     op = stability(LobeProblem(st, case.tool, case.cut, case.law))
    ...     print(material, op.verdict.status, round(op.margin, 2), op.bifurcation, round(op.chatter_freq_hz, 1))
    aluminium stable 2.18 hopf 25.1
    steel unstable -0.6 flip 51.7
    """
    t0 = time.perf_counter()
    lins = Linearizations() if lins is None else lins
    runs_cache: dict | None = {} if lins.share else None
    cs, pas, paper = load_inputs()
    poses = study_poses(pas)
    modes = compute_modes(lins, cs["aluminium"], poses, _sub(progress, 0.0, 0.05))
    ops = compute_operating_points(settings, lins, cs, poses, _sub(progress, 0.05, 0.2))
    diagrams = compute_diagrams(settings, lins, cs, poses, _sub(progress, 0.2, 0.38))
    lowest = compute_lowest_limits(lins, cs, poses)
    d_lobes = damping_by_lobes(settings, lins, cs["steel"], poses["start"])
    d_td = damping_by_time_domain(settings, cs["steel"], progress=_sub(progress, 0.42, 0.58), cache=runs_cache,
                                  lins=lins, seed=d_lobes.bracket)
    d_delay = damping_by_delay(settings, lins, cs["steel"], poses["start"], seed=d_lobes.bracket,
                               progress=_sub(progress, 0.58, 0.6))
    dy, dy_entry = eroded_deflection(d_td), eroded_deflection(d_td, "entry_normal_deflection_m")
    d_lobes_dy = (None if dy is None else
                  damping_by_lobes(settings, lins, cs["steel"], poses["start"], dy_m=dy, seed=d_td.bracket))
    d_orbit = (None if dy_entry is None else  # seeded at the eroded part's bracket: fewer costly probes
               damping_by_lobes(settings, lins, cs["steel"], poses["start"], dy_m=dy_entry, seed=d_td.bracket,
                                orbit=True))
    runs = compute_time_domain(settings, cs, paper, d_td.smallest_stable, _sub(progress, 0.6, 0.97), runs_cache, lins)
    facts = {mat: material_facts(cs[mat], modes, next(o for o in ops if (o.material, o.variant, o.pose)
                                                      == (mat, "basic", "start")),
                                 next(a for a in lowest if a.material == mat),
                                 next(r for r in runs if (r.material, r.variant, r.damping_scale)
                                      == (mat, "basic", 1.0)))
             for mat in cs}
    return StudyResult(
        identify_facts=compute_identify_facts(settings),
        settings=settings, provenance=provenance(study_inputs(settings, cs, paper)),
        cases={k: c.name for k, c in cs.items()}, notes=NOTES, modes=modes, operating_points=ops,
        diagrams=diagrams, lowest_limits=lowest, td_linearized=settings.td_linearized, time_domain=runs,
        damping_lobes=d_lobes, damping_time_domain=d_td, damping_delay=d_delay,
        damping_lobes_eroded=d_lobes_dy, damping_lobes_orbit=d_orbit, eroded_deflection_m=dy,
        eroded_entry_deflection_m=dy_entry,
        paper_damping_scale=float(paper["steel"]["stabilizing_damping_scale"]),
        tab10=tab10_rows(paper, runs), roughness=roughness_rows(paper, runs), facts=facts,
        wall_s=time.perf_counter() - t0, generated=time.strftime("%Y-%m-%d %H:%M"),
        linearize_calls=lins.linearize_calls)
