"""The main job: why the TX200 cut was stable in aluminium and unstable in steel, beside the paper.

:func:`run_study` computes, for the two built-in cases (``tx200-aluminium``, ``tx200-steel``):

1. modes and tool-tip FRFs at the start, middle and end of the pass, four model variants;
2. the operating point of each cut against the stability lobes at those poses (margin, limit,
   bifurcation, chatter frequency) and lobe diagrams;
3. time-domain passes, aluminium and steel, four variants, and the smallest joint-damping scale
   that stabilizes steel (the paper says x10), decided by the lobes and checked in time domain;
4. the paper's Tab. 10 (forces) and Tab. 11/12 (roughness) beside ours;
5. the explanation, computed: tooth-passing frequency against the robot modes, the ratio of the
   cutting coefficients, absolute and local stability limits, which mode chatters in steel;

and writes ``report.md`` (with figures) and ``results.json`` (every number) into a directory,
atomically: the directory is built beside the target and swapped in only when complete.
"""

from __future__ import annotations

import math
import os
import time
import warnings
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from robolobes import cases
from robolobes.core.io import Progress, provenance_text, pyplot, save_figure, to_jsonable, write_json, write_text
from robolobes.core.outdir import OutputDir
from robolobes.linearize.summary import modes_summary
from robolobes.linearize.kinematics import JointLimitWarning
from robolobes.linearize.linear import linearize
from robolobes.linearize.model import VARIANTS, build_model
from robolobes.linearize.path import Pass

__all__ = ["StudySettings", "run_study", "study_output", "POSES"]

#: Poses of the study as fractions of the pass travel.
POSES = {"start": 0.0, "middle": 0.5, "end": 1.0}
MATERIALS = {"aluminium": "tx200-aluminium", "steel": "tx200-steel"}
PAPER = "tx200-paper-results"


@dataclass(frozen=True)
class StudySettings:
    """Resolution of the study. ``quick``: coarser grids and shorter runs, same conclusions.

    Attributes
    ----------
    n_rpm : int                 speeds per lobe diagram
    lobe_variants : tuple       variants whose diagrams are drawn (operating points: all)
    lobe_poses : tuple          poses of the operating-point and diagram computations
    sdm_m : int                 SDM steps per principal period (Richardson with 2m on top)
    td_linearized : bool        time domain on the linearized fast path (else the full model)
    steel_t_end_s : float|None  simulated steel time (None: whole pass, 22 s; 6 s covers entry and
                                3.5 s of full engagement, enough for the verdict)
    al_t_end_s : float|None     simulated aluminium time (None: whole pass, 1.75 s)
    damping_scales : tuple      scales tried for steel (then bisected to ``damping_tol``)
    """

    quick: bool = False
    n_rpm: int = 200
    lobe_variants: tuple = VARIANTS
    lobe_poses: tuple = tuple(POSES)
    sdm_m: int = 40
    td_linearized: bool = False
    steel_t_end_s: float | None = 6.0
    al_t_end_s: float | None = None
    damping_scales: tuple = (1.0, 10.0, 20.0, 40.0)
    damping_tol: float = 0.1

    @staticmethod
    def make(quick: bool) -> "StudySettings":
        if quick:
            return StudySettings(quick=True, n_rpm=40, lobe_variants=("basic", "orthogonal"),
                                 lobe_poses=("start",), td_linearized=True, steel_t_end_s=5.5,
                                 al_t_end_s=None, damping_tol=0.25)
        return StudySettings()


# ------------------------------------------------------------------------------------------ helpers
def _poses(pas: Pass) -> dict[str, np.ndarray]:
    return {k: pas.theta_at_s(f * pas.travel_m) for k, f in POSES.items()}


def _cut_frame_structure(robot, theta, case):
    from robolobes.lobes.structure import PhysicalStructure
    lin = linearize(robot, theta)
    return lin, PhysicalStructure.from_linear(lin, case.cut.feed_direction)


def _mode_contributions(lin, case, freq_hz: float) -> np.ndarray:
    """|contribution| of each mode to the normal-direction receptance at ``freq_hz`` (cut frame)."""
    modes = lin.modes("cut", case.cut.feed_direction)
    w = 2 * math.pi * freq_hz
    res = np.asarray(modes.residues)[:, 1, 1]
    lam = np.asarray(modes.poles)
    n = modes.freq_hz.shape[-1]
    contrib = res / (1j * w - lam)
    # pair each listed mode (upper pole) with its conjugate
    out = np.zeros(n)
    for r in range(n):
        conj = np.argmin(np.abs(lam - np.conj(lam[r])))
        out[r] = abs(contrib[r] + (contrib[conj] if conj != r else 0))
    return out


# ------------------------------------------------------------------------------------------ sections
def section_modes(settings, pas, al_case, progress, figdir: Path) -> dict:
    """Modes, TCP stiffness and FRFs at the three poses for the four variants."""
    from robolobes.linearize.frf_io import write_frf
    out = {}
    poses = _poses(pas)
    w = 2 * math.pi * np.linspace(1.0, 300.0, 600)
    frfs = {}
    k = 0
    for variant in VARIANTS:
        robot = build_model(al_case.robot, variant)
        out[variant] = {}
        for pose, theta in poses.items():
            s = modes_summary(robot, theta, al_case)
            lin = linearize(robot, theta)
            frf = lin.frf(w, frame="cut", feed_direction=al_case.cut.feed_direction)
            (figdir / "frf").mkdir(exist_ok=True)
            write_frf(frf, figdir / "frf" / f"frf_{variant}_{pose}.csv")
            frfs[(variant, pose)] = frf
            out[variant][pose] = {kk: s[kk] for kk in ("freq_hz", "damped_freq_hz", "damping_ratio", "q_deg",
                                                        "tcp_position_m", "tool_axis", "tcp_static_stiffness_n_per_m",
                                                        "modal_stiffness_n_per_m", "tcp_gravity_deflection_m", "notes")}
            H = np.asarray(frf.H)
            out[variant][pose]["frf_peak_um_per_n"] = {
                ax: float(np.max(np.abs(H[i, i])) * 1e6) for i, ax in enumerate(("feed", "normal"))}
            out[variant][pose]["frf_file"] = f"frf/frf_{variant}_{pose}.csv"
            k += 1
            progress(k / (len(VARIANTS) * len(poses)))
    _plot_frfs(frfs, figdir / "frf.png", al_case)
    return out


def section_lobes(settings, pas, cases_, progress, figdir: Path) -> dict:
    """Operating points (all variants, study poses) and lobe diagrams (selected variants)."""
    from dataclasses import replace as dc_replace

    from robolobes.lobes.plot import plot_lobes
    from robolobes.lobes.problem import LobeProblem
    from robolobes.lobes.sdm import SemiDiscretization
    from robolobes.lobes import solve, stability
    from robolobes.lobes.zoa import ZeroOrder

    method = SemiDiscretization(m=settings.sdm_m)
    poses = _poses(pas)
    out: dict = {}
    jobs = [(mat, v, p) for mat in cases_ for v in VARIANTS for p in settings.lobe_poses]
    diag_jobs = [(mat, v, p) for mat in cases_ for v in settings.lobe_variants for p in settings.lobe_poses]
    total = len(jobs) + len(diag_jobs) + 2
    done = 0
    ranges = {"aluminium": (10000.0, 25000.0), "steel": (1000.0, 6000.0)}
    lobe_results = {}
    for mat, variant, pose in jobs:
        case = cases_[mat]
        robot = build_model(case.robot, variant)
        lin, st = _cut_frame_structure(robot, poses[pose], case)
        problem = LobeProblem(st, case.tool, case.cut, case.law)
        op = stability(problem, method)
        entry = {"verdict": op.verdict.status, "margin": op.margin, "margin_error": op.margin_error,
                 "depth_m": op.depth_m, "depth_limit_m": op.depth_limit_m,
                 "depth_limit_error_m": op.depth_limit_error_m, "spectral_radius": op.spectral_radius,
                 "bifurcation": op.bifurcation, "chatter_freq_hz": op.chatter_freq_hz,
                 "limit_bifurcation": op.limit_bifurcation, "limit_chatter_freq_hz": op.limit_chatter_freq_hz,
                 "m_levels": [h["m"] for h in op.history]}
        f_ch = op.limit_chatter_freq_hz if math.isfinite(op.limit_chatter_freq_hz) else op.chatter_freq_hz
        if math.isfinite(f_ch):
            contrib = _mode_contributions(lin, case, f_ch)
            r = int(np.argmax(contrib))
            modes = lin.modes()
            entry["dominant_mode"] = {"index": r + 1, "freq_hz": float(modes.freq_hz[r]),
                                      "damping_ratio": float(modes.damping_ratio[r]),
                                      "share": float(contrib[r] / contrib.sum())}
        out.setdefault(mat, {}).setdefault(variant, {})[pose] = {"operating_point": entry}
        lobe_results[(mat, variant, pose, "op")] = op
        done += 1
        progress(done / total)
    for mat, variant, pose in diag_jobs:
        case = cases_[mat]
        robot = build_model(case.robot, variant)
        _, st = _cut_frame_structure(robot, poses[pose], case)
        problem = LobeProblem(st, case.tool, case.cut, case.law)
        rpm = np.linspace(*ranges[mat], settings.n_rpm)
        res = solve(problem, method, rpm, depth_max_m=0.01)
        lobe_results[(mat, variant, pose)] = res
        out[mat][variant][pose]["diagram"] = {"rpm": res.spindle_rpm, "depth_limit_m": res.depth_limit_m,
                                              "chatter_freq_hz": res.chatter_freq_hz,
                                              "bifurcation": res.bifurcation.tolist(), "wall_s": res.stats["wall_s"]}
        plot_lobes(res, figdir / f"lobes_{mat}_{variant}_{pose}.png",
                   operating_point=lobe_results[(mat, variant, pose, "op")],
                   title=f"{case.name} [{variant}], {pose} of the pass")
        done += 1
        progress(done / total)
    # absolute (ZOA) limits over a wide speed range: the asymptote of the lobes
    for mat, case in cases_.items():
        robot = build_model(case.robot, "basic")
        _, st = _cut_frame_structure(robot, poses["start"], case)
        problem = LobeProblem(st, case.tool, case.cut, case.law)
        rpm = np.geomspace(300, 30000, 400)
        z = solve(problem, ZeroOrder(), rpm, depth_max_m=1.0)
        j = int(np.nanargmin(z.depth_limit_m))
        out[mat]["absolute_limit_zoa"] = {"depth_m": float(z.depth_limit_m[j]), "at_rpm": float(z.spindle_rpm[j]),
                                          "variant": "basic", "pose": "start"}
        done += 1
        progress(done / total)
    out["_figures"] = sorted(p.name for p in figdir.glob("lobes_*.png"))
    out["_results"] = lobe_results
    return out


def smallest_stable_scale(check, scales, tol) -> dict:
    """Smallest damping scale for which ``check(scale) -> (stable: bool, info: dict)`` holds.

    The scales are tried in increasing order until one is stable, then the last unstable / first
    stable pair is bisected down to ``tol``. Assumes a single crossing in the bracket (more
    damping, more stable).
    """
    tried = {}
    lo = hi = None
    for sc in sorted(scales):
        ok, info = check(sc)
        tried[sc] = info
        if ok:
            hi = sc
            break
        lo = sc
    if hi is not None and lo is not None:
        while hi - lo > tol:
            mid = 0.5 * (lo + hi)
            ok, info = check(mid)
            tried[mid] = info
            lo, hi = (lo, mid) if ok else (mid, hi)
    return {"stabilizing_scale": hi, "unstable_scale": lo,
            "tried": {f"{k:g}": v for k, v in sorted(tried.items())}}


def steel_damping_by_lobes(settings, pas, steel, variant="basic") -> dict:
    """Smallest motion-axis damping scale for which the SDM limit at 3100 rpm exceeds ap = 1.6 mm
    (an "undetermined" verdict counts as not stable)."""
    from robolobes.lobes.problem import LobeProblem
    from robolobes.lobes.sdm import SemiDiscretization
    from robolobes.lobes import stability

    theta = _poses(pas)["start"]
    method = SemiDiscretization(m=settings.sdm_m)

    def check(scale):
        robot = build_model(steel.robot, variant, damping_scale=scale)
        _, st = _cut_frame_structure(robot, theta, steel)
        op = stability(LobeProblem(st, steel.tool, steel.cut, steel.law), method)
        return op.verdict.status == "stable", {"verdict": op.verdict.status, "depth_limit_m": op.depth_limit_m, "margin": op.margin,
                                        "bifurcation": op.limit_bifurcation,
                                        "chatter_freq_hz": op.limit_chatter_freq_hz}

    out = smallest_stable_scale(check, settings.damping_scales, settings.damping_tol)
    out["variant"] = variant
    return out


def steel_damping_by_time_domain(settings, steel, variant="basic", progress=None) -> dict:
    """Smallest damping scale for which the time-domain verdict of the steel pass is "stable"
    (linearized fast path, also in the full study: a bisection takes about nine passes)."""
    n = [0]

    fast = replace(settings, td_linearized=True)  # the search runs ~9 passes: always the fast path

    def check(scale):
        r = _simulate(steel, variant, fast, settings.steel_t_end_s, scale)
        n[0] += 1
        if progress is not None:
            progress(min(1.0, n[0] / 9))
        e = _td_entry(r)
        return e.get("stable") is True, {k: e.get(k) for k in ("stable", "chatter_freq_hz", "stability", "note",
                                                                "verdict_basis")}

    out = smallest_stable_scale(check, settings.damping_scales, max(settings.damping_tol, 0.25))
    out["variant"] = variant
    return out


def _simulate(case, variant, settings, t_end, damping_scale=1.0, stats_window=None, progress=None):
    from robolobes.linearize.model import build_model
    from robolobes.timedomain import LinearizedNewmark, NonlinearNewmark, SimulationProblem, simulate
    robot = build_model(case.robot, variant, damping_scale=damping_scale)
    pb = SimulationProblem(robot, case, t_end_s=t_end, stats_window_s=stats_window)
    return simulate(pb, LinearizedNewmark() if settings.td_linearized else NonlinearNewmark(), progress=progress)


def section_time_domain(settings, cases_, paper, progress, figdir: Path, lobes_damping: dict) -> dict:
    """Aluminium and steel passes for the four variants; steel at the stabilizing damping."""
    from robolobes.timedomain.output import plot_wall
    out: dict = {"linearized": settings.td_linearized, "runs": {}}
    win = tuple(paper["aluminium"]["tab10"]["window_s"])
    runs = [("aluminium", v, 1.0) for v in VARIANTS] + [("steel", v, 1.0) for v in VARIANTS]
    total = len(runs) + 3
    sims = {}
    for i, (mat, variant, scale) in enumerate(runs):
        case = cases_[mat]
        t_end = settings.al_t_end_s if mat == "aluminium" else settings.steel_t_end_s
        r = _simulate(case, variant, settings, t_end, scale, win if mat == "aluminium" else None,
                      progress=lambda f: progress((i + f) / total))
        sims[(mat, variant, scale)] = r
        out["runs"][f"{mat}/{variant}"] = _td_entry(r)
    # steel with more damping: the smallest stabilizing scale, in time domain (basic)
    td_damp = steel_damping_by_time_domain(settings, cases_["steel"],
                                           progress=lambda f: progress((len(runs) + 3 * f) / total))
    out["steel_damping"] = td_damp
    if td_damp["stabilizing_scale"] is not None:
        sc = td_damp["stabilizing_scale"]
        sims[("steel", "basic", sc)] = _simulate(cases_["steel"], "basic", settings, settings.steel_t_end_s, sc)
    _plot_td(sims, figdir / "time_domain.png")
    plot_wall(sims[("aluminium", "basic", 1.0)], figdir / "wall_aluminium.png")
    plot_wall(sims[("steel", "basic", 1.0)], figdir / "wall_steel.png")
    out["_sims"] = sims
    return out


def _td_entry(r) -> dict:
    s = r.summary.to_json()
    keys = ("stable", "chatter_freq_hz", "nonsynchronous_peak_hz", "stability", "verdict_basis", "force_stats",
            "force_stats_paper_axes", "force_stats_window_s", "roughness_um", "tcp_deviation_y_um", "wall_y_um",
            "steady_window_s", "note")
    e = {k: s[k] for k in keys if s[k] is not None or k == "stable"}
    e["t_end_s"] = float(r.t_s[-1])
    e["wall_s"] = r.stats["wall_time_s"]
    e["steps"] = r.stats["steps"]
    return e


# ------------------------------------------------------------------------------------------ figures


def _plot_frfs(frfs, path, case):
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), sharey=True)
    for ax, (i, name) in zip(axes, ((0, "feed"), (1, "normal"))):
        for variant in VARIANTS:
            for pose, ls in (("start", "-"), ("end", ":")):
                frf = frfs[(variant, pose)]
                ax.semilogy(frf.freq_hz, np.abs(np.asarray(frf.H)[i, i]) * 1e6, ls, lw=1,
                            label=f"{variant}, {pose}" if i == 0 else None)
        ax.set_title(f"TCP receptance H_{name},{name} (cut frame)")
        ax.set_xlabel("frequency (Hz)")
        ax.grid(alpha=0.3, which="both")
    axes[0].set_ylabel("|H| (um/N)")
    axes[0].legend(fontsize=7, ncol=2)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)


def _plot_td(sims, path):
    plt = pyplot()
    fig, axes = plt.subplots(2, 1, figsize=(9, 6))
    for ax, mat in zip(axes, ("aluminium", "steel")):
        r = sims[(mat, "basic", 1.0)]
        f = np.asarray(r.force_paper_axes_n)
        ax.plot(r.t_s, f[:, 1], lw=0.4, label="Fy, nominal damping")
        ax.plot(r.t_s, f[:, 0], lw=0.4, label="Fx, nominal damping")
        extra = [k for k in sims if k[0] == mat and k[2] != 1.0 and k[1] == "basic"]
        if extra:
            k = max(extra, key=lambda k: k[2])
            r2 = sims[k]
            ax.plot(r2.t_s, np.asarray(r2.force_paper_axes_n)[:, 1], lw=0.4, alpha=0.8,
                    label=f"Fy, damping x{k[2]:g}")
        st = r.summary.stable
        ax.set_title(f"{mat} [basic]: {'stable' if st else 'unstable' if st is False else 'no verdict'}", fontsize=10)
        ax.set_ylabel("force (N, paper axes)")
        ax.legend(fontsize=7, loc="lower left")
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time (s)")
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)


def _plot_main(results, lobes_out, sims, path):
    """The study's main figure: modes vs tooth passing, the two operating points, the two cuts."""
    plt = pyplot()
    fig, axes = plt.subplots(2, 2, figsize=(11, 7.5))
    ax = axes[0, 0]
    ex = results["explanation"]
    for v, c in zip(VARIANTS, ("tab:blue", "tab:orange", "tab:green", "tab:red")):
        f = np.asarray(results["modes"][v]["start"]["freq_hz"])
        ax.plot(f, np.full_like(f, VARIANTS.index(v)), "|", ms=14, mew=2, color=c, label=v)
    for mat, col in (("aluminium", "tab:gray"), ("steel", "k")):
        ftp = ex[mat]["tooth_passing_hz"]
        for kharm in range(1, 4):
            ax.axvline(kharm * ftp, color=col, ls="--" if kharm > 1 else "-", lw=1,
                       label=f"{mat} tooth passing {ftp:.0f} Hz" if kharm == 1 else None)
    ax.set_xscale("log")
    ax.set_xlim(5, 3000)
    ax.set_yticks(range(len(VARIANTS)))
    ax.set_yticklabels(VARIANTS)
    ax.set_xlabel("frequency (Hz)")
    ax.set_title("robot modes (start pose) vs tooth-passing frequencies", fontsize=10)
    ax.legend(fontsize=7, loc="lower right")
    for ax, mat in ((axes[0, 1], "aluminium"), (axes[1, 0], "steel")):
        res = lobes_out["_results"].get((mat, "basic", "start"))
        op = lobes_out["_results"].get((mat, "basic", "start", "op"))
        if res is not None:
            d = np.asarray(res.depth_limit_m) * 1e3
            ax.plot(res.spindle_rpm, np.where(np.isfinite(d), d, np.nan), "k", lw=1.2, label="SDM limit [basic]")
        if op is not None:
            col = "tab:green" if op.verdict.status == "stable" else "tab:red"
            ax.plot([op.spindle_rpm], [op.depth_m * 1e3], "o" if op.verdict.status == "stable" else "X", color=col, ms=10,
                    mec="k", label=f"cut: {op.verdict.status}, limit {op.depth_limit_m * 1e3:.2f} mm")
        ax.set_ylim(0, 10)
        ax.set_xlabel("spindle speed (rpm)")
        ax.set_ylabel("axial depth (mm)")
        ax.set_title(f"{mat}: lobes at the start pose", fontsize=10)
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3)
    ax = axes[1, 1]
    for mat, col in (("aluminium", "tab:blue"), ("steel", "tab:red")):
        r = sims[(mat, "basic", 1.0)]
        T = r.problem.case.cut.spindle_period_s
        t0 = r.steady_window_s[0]
        sel = (np.asarray(r.t_s) >= t0) & (np.asarray(r.t_s) <= t0 + 0.6)
        ax.plot(np.asarray(r.t_s)[sel] - t0, np.asarray(r.force_paper_axes_n)[sel, 1], lw=0.5, color=col,
                label=f"{mat}: {'stable' if r.summary.stable else 'unstable'}")
    ax.set_xlabel("time from full engagement (s)")
    ax.set_ylabel("Fy (N, paper axes)")
    ax.set_title("time domain [basic]: normal force", fontsize=10)
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)


# ------------------------------------------------------------------------------------------ tables
def _tab10(paper, td) -> dict:
    rows = {}
    for name, vals in paper["aluminium"]["tab10"].items():
        if name == "window_s":
            continue
        rows[f"paper {name}"] = dict(zip(("fx_min", "fy_min", "fx_max", "fy_max", "fx_mean", "fy_mean", "fx_rms",
                                          "fy_rms"), vals))
    for v in VARIANTS:
        fs = td["runs"][f"aluminium/{v}"].get("force_stats_paper_axes")
        if fs:
            rows[f"robolobes {v}"] = {f"f{ax}_{k}": fs[ax][k] for ax in ("x", "y") for k in ("min", "max", "mean", "rms")}
    return rows


def _explanation(cases_, modes, lobes_out, td, lobes_damping, td_damping) -> dict:
    al, st = cases_["aluminium"], cases_["steel"]
    ex = {}
    for mat, case in cases_.items():
        f_tp = case.cut.spindle_rpm / 60 * case.tool.teeth
        f_modes = np.asarray(modes["basic"]["start"]["freq_hz"])
        f18 = np.asarray(modes["orthogonal"]["start"]["freq_hz"])
        op = lobes_out[mat]["basic"]["start"]["operating_point"]
        ex[mat] = {
            "spindle_rpm": case.cut.spindle_rpm, "tooth_passing_hz": f_tp,
            "tooth_passing_over_lowest_mode": f_tp / f_modes[0],
            "modes_below_tooth_passing_basic": int(np.sum(f_modes < f_tp)),
            "modes_below_tooth_passing_orthogonal": int(np.sum(f18 < f_tp)),
            "ktc_pa": case.law.ktc_pa, "krc_pa": case.law.krc_pa, "krc_over_ktc": case.law.krc_pa / case.law.ktc_pa,
            "depth_m": case.cut.ap_m, "lobes_verdict": op["verdict"],
            "local_limit_m": op["depth_limit_m"], "local_margin": op["margin"],
            "bifurcation": op["limit_bifurcation"], "chatter_freq_hz_lobes": op["limit_chatter_freq_hz"],
            "dominant_mode": op.get("dominant_mode"),
            "absolute_limit_zoa_m": lobes_out[mat]["absolute_limit_zoa"]["depth_m"],
            "time_domain_stable_basic": td["runs"][f"{mat}/basic"].get("stable"),
            "chatter_freq_hz_time_domain": td["runs"][f"{mat}/basic"].get("chatter_freq_hz"),
        }
    ex["ktc_ratio_steel_over_aluminium"] = st.law.ktc_pa / al.law.ktc_pa
    ex["absolute_limit_ratio_aluminium_over_steel"] = (ex["aluminium"]["absolute_limit_zoa_m"]
                                                       / ex["steel"]["absolute_limit_zoa_m"])
    ex["steel_stabilizing_damping_scale_lobes"] = lobes_damping.get("stabilizing_scale")
    ex["steel_stabilizing_damping_scale_time_domain"] = td_damping.get("stabilizing_scale")
    return ex


# ------------------------------------------------------------------------------------------ report
def _fmt(v, nd=2):
    if v is None:
        return "-"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, (float, np.floating)):
        if not math.isfinite(v):
            return "inf" if v > 0 else "-"
        return f"{v:.{nd}f}"
    return str(v)


def _verdict(v):
    return "stable" if v else "unstable" if v is False else "undecided (window too short)"


def _mm(v):
    """m -> mm for the report; None: no limit found up to the search bound (10 x ap for operating
    points, lobes.stability's default)."""
    return "none below 10 ap" if v is None else _fmt(v * 1e3)


def _report(results: dict, settings: StudySettings) -> str:
    ex = results["explanation"]
    al, st = ex["aluminium"], ex["steel"]
    L = []
    a = L.append
    a("# robolobes study: stable aluminium, unstable steel on the Staubli TX200\n")
    a(f"{'Quick' if settings.quick else 'Full'} study, computed in {results['wall_s']:.0f} s "
      f"({results['generated']}). Every number below is in `results.json`. Provenance: "
      f"{provenance_text(results['provenance'])}.\n")
    a("![main figure](study.png)\n")
    a("## The explanation, in numbers\n")
    a(f"* **Tooth passing against the robot modes.** Aluminium is cut at {al['spindle_rpm']:.0f} rpm: "
      f"the tooth-passing frequency is {al['tooth_passing_hz']:.0f} Hz, {al['tooth_passing_over_lowest_mode']:.0f} "
      f"times the lowest robot mode; all {al['modes_below_tooth_passing_basic']} modes of the 6-DOF model lie below "
      f"it. Steel is cut at {st['spindle_rpm']:.0f} rpm: {st['tooth_passing_hz']:.1f} Hz, "
      f"{st['tooth_passing_over_lowest_mode']:.1f} times the lowest mode, right among the modes "
      f"({st['modes_below_tooth_passing_basic']} of 6 below it).")
    a(f"* **Cutting coefficients.** Ktc is {ex['ktc_ratio_steel_over_aluminium']:.2f} times larger in steel "
      f"({st['ktc_pa'] / 1e6:.0f} against {al['ktc_pa'] / 1e6:.1f} MPa) and Krc/Ktc rises from "
      f"{al['krc_over_ktc']:.2f} to {st['krc_over_ktc']:.2f}. The absolute (ZOA, speed-independent) stability limit "
      f"scales with 1/Kt: {al['absolute_limit_zoa_m'] * 1e3:.2f} mm in aluminium against "
      f"{st['absolute_limit_zoa_m'] * 1e3:.2f} mm in steel (ratio {ex['absolute_limit_ratio_aluminium_over_steel']:.2f}).")
    a(f"* **Local limits at the operating speeds** (SDM, 6-DOF model, Tab. 7 pose). Aluminium: "
      f"{_mm(al['local_limit_m'])} mm against the {al['depth_m'] * 1e3:.1f} mm cut, margin {_fmt(al['local_margin'])} "
      f"({al['lobes_verdict']}). Steel: {_mm(st['local_limit_m'])} mm, margin {_fmt(st['local_margin'])} "
      f"({st['lobes_verdict']}), a {st['bifurcation']} bifurcation at {_fmt(st['chatter_freq_hz_lobes'], 1)} Hz. "
      f"Time domain (basic model, the pass): aluminium {_verdict(al['time_domain_stable_basic'])}, steel "
      f"{_verdict(st['time_domain_stable_basic'])}.")
    dm = st.get("dominant_mode")
    if dm:
        a(f"* **Which mode chatters in steel.** Mode {dm['index']} ({dm['freq_hz']:.1f} Hz, damping "
          f"{100 * dm['damping_ratio']:.1f} %) carries {100 * dm['share']:.0f} % of the normal-direction receptance "
          f"at the lobes' chatter frequency. In time domain the basic model's non-synchronous motion peaks at "
          f"{_fmt(st['chatter_freq_hz_time_domain'], 1)} Hz.")
    if al["lobes_verdict"] == "stable" and st["lobes_verdict"] == "unstable":
        a(f"* **Why aluminium is stable and steel is not.** In aluminium the teeth pass at "
          f"{al['tooth_passing_hz']:.0f} Hz, far above every robot mode: the cut sits to the right of the robot's "
          f"lobes, where the limit ({_mm(al['local_limit_m'])} mm) is "
          f"{al['local_limit_m'] / al['absolute_limit_zoa_m']:.1f} times the absolute limit "
          f"({_mm(al['absolute_limit_zoa_m'])} mm) and {al['local_margin'] + 1:.1f} times the cut. Steel needs "
          f"{ex['ktc_ratio_steel_over_aluminium']:.1f} times the force per unit chip, which divides every limit by "
          f"about as much, and its tooth passing ({st['tooth_passing_hz']:.0f} Hz) falls among the modes: its limit "
          f"({_mm(st['local_limit_m'])} mm) is {st['local_limit_m'] / st['absolute_limit_zoa_m']:.1f} times its "
          f"absolute limit and {st['local_limit_m'] / st['depth_m']:.2f} times the cut.")
    else:
        a(f"* **Verdicts differ from the paper's observations** (aluminium {al['lobes_verdict']}, steel "
          f"{st['lobes_verdict']} by the lobes): see the sections below.")
    sc = ex["steel_stabilizing_damping_scale_lobes"]
    sct = ex["steel_stabilizing_damping_scale_time_domain"]
    a(f"* **The paper's x10 damping.** The smallest joint-damping scale that stabilizes the steel cut (basic model, "
      f"Tab. 7 pose) is x{_fmt(sc, 2)} by the lobes and x{_fmt(sct, 2)} in time domain: "
      + ("x10 is not enough for this model." if (sc is not None and sc > 10 and sct is not None and sct > 10)
         else "x10 is enough here." if (sc is not None and sc <= 10) else "see the damping section.") + "\n")
    a("## Modes at the start, middle and end of the pass\n")
    a("| variant | pose | f1 | f2 | f3 | f4 | f5 | f6 (Hz) | min TCP stiffness (N/um) |")
    a("|---|---|---|---|---|---|---|---|---|")
    for v in VARIANTS:
        for pose in POSES:
            m = results["modes"][v][pose]
            f = m["freq_hz"][:6]
            K = np.asarray(m["tcp_static_stiffness_n_per_m"])
            kmin = np.linalg.eigvalsh(0.5 * (K + K.T))[0] / 1e6
            a(f"| {v} | {pose} | " + " | ".join(f"{x:.1f}" for x in f) + f" | {kmin:.3f} |")
    a("\n![FRFs](frf.png)\n")
    a("## Operating points against the lobes\n")
    a("| material | variant | pose | verdict | limit (mm) | margin | bifurcation | chatter (Hz) |")
    a("|---|---|---|---|---|---|---|---|")
    for mat in MATERIALS:
        for v in VARIANTS:
            for pose, d in results["lobes"][mat][v].items():
                op = d["operating_point"]
                a(f"| {mat} | {v} | {pose} | {op['verdict']} | {_mm(op['depth_limit_m'])} | "
                  f"{_fmt(op['margin'])} | {op['limit_bifurcation']} | {_fmt(op['limit_chatter_freq_hz'], 1)} |")
    for fig in results["lobes"]["_figures"]:
        a(f"\n![{fig}]({fig})")
    a("\n## Time domain\n")
    a(f"Path: {'linearized fast path' if results['time_domain']['linearized'] else 'full nonlinear model'}.\n")
    a("| run | stable | chatter (Hz) | Fy min (N) | Fy rms (N) | Ra / Rt (um) | simulated (s) | wall (s) |")
    a("|---|---|---|---|---|---|---|---|")
    for k, e in results["time_domain"]["runs"].items():
        fs = e.get("force_stats_paper_axes", {}).get("y", {})
        r = (e.get("roughness_um") or {})
        a(f"| {k} | {_fmt(e.get('stable'))} | {_fmt(e.get('chatter_freq_hz'), 1)} | {_fmt(fs.get('min'), 1)} | "
          f"{_fmt(fs.get('rms'), 1)} | {_fmt(r.get('Ra'))} / {_fmt(r.get('Rt'))} | {e['t_end_s']:.2f} | {e['wall_s']:.1f} |")
    a("\n![time domain](time_domain.png)\n")
    a("## Steel: how much joint damping stabilizes it\n")
    sd = results["steel_damping"]
    ld, tdd = sd["lobes"], sd["time_domain"]
    a(f"The paper: x{sd['paper_scale']} was enough. Here, at the Tab. 7 pose with the {ld['variant']} model: "
      f"lobes (SDM): stable from x{_fmt(ld.get('stabilizing_scale'))}, still unstable at "
      f"x{_fmt(ld.get('unstable_scale'))}; time domain (the pass): stable from x{_fmt(tdd.get('stabilizing_scale'))},"
      f" unstable at x{_fmt(tdd.get('unstable_scale'))}.\n")
    a("| scale | lobes verdict | limit (mm) | time-domain verdict | chatter (Hz) |")
    a("|---|---|---|---|---|")
    for k in sorted(set(ld["tried"]) | set(tdd["tried"]), key=float):
        lv, tv = ld["tried"].get(k, {}), tdd["tried"].get(k, {})
        a(f"| {k} | {lv.get('verdict', '')} | {_mm(lv['depth_limit_m']) if lv else ''} | "
          f"{_verdict(tv['stable']) if tv else ''} | {_fmt(tv.get('chatter_freq_hz'), 1) if tv else ''} |")
    a("\n## Tab. 10: aluminium forces, 0.4-1.4 s (paper axes, N)\n")
    a("| row | Fx min | Fx max | Fx mean | Fx rms | Fy min | Fy max | Fy mean | Fy rms |")
    a("|---|---|---|---|---|---|---|---|---|")
    for name, row in results["tab10"].items():
        a(f"| {name} | " + " | ".join(_fmt(row[f'f{ax}_{k}']) for ax in ('x', 'y') for k in ('min', 'max', 'mean', 'rms'))
          + " |")
    a("\n## Roughness of the lateral wall (um)\n")
    a("| | Ra | Rq | Rt |")
    a("|---|---|---|---|")
    for name, row in results["roughness"].items():
        a(f"| {name} | " + " | ".join(_fmt(row.get(k)) if not isinstance(row.get(k), list) else
                                      f"{row[k][0]}-{row[k][1]}" for k in ("Ra", "Rq", "Rt")) + " |")
    a("\nOurs: ISO 4287 on the middle slice, Gaussian mean line with lambda_c = 0.8 mm (ISO 4288), over the wall "
      "the tool has fully passed. The paper does not state its filter.\n")
    a("![wall aluminium](wall_aluminium.png)\n![wall steel](wall_steel.png)\n")
    return "\n".join(L) + "\n"


# ------------------------------------------------------------------------------------------ driver
def study_output(out_dir: str | os.PathLike, quick: bool) -> OutputDir:
    """The study's output directory, checked now (``core.outdir``: refuses a user's directory or file)."""
    return OutputDir(out_dir, "study", {"command": "study", "quick": bool(quick)})


def run_study(out_dir: str | os.PathLike | OutputDir = "robolobes-study", quick: bool = False, progress=None) -> dict:
    """Run the study and write ``report.md``, ``results.json`` and figures into ``out_dir``.

    Parameters
    ----------
    out_dir : path or OutputDir
        Target directory (:func:`study_output`: checked before any work, swapped in atomically when
        the study completes; never a directory or file robolobes did not write).
    quick : bool
        Coarser grids and shorter runs (:meth:`StudySettings.make`).
    progress : callable ``(fraction, note)``, optional

    Returns
    -------
    dict
        ``results.json``'s content.
    """
    t0 = time.perf_counter()
    settings = StudySettings.make(quick)
    prog = progress or (lambda f, note="": None)
    out = out_dir if isinstance(out_dir, OutputDir) else study_output(out_dir, quick)
    work = out.open()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", JointLimitWarning)  # the Tab. 7 A3 warning, reported below
            cases_ = {k: cases.load_case(v) for k, v in MATERIALS.items()}
            pas = Pass.from_case(cases_["aluminium"])
        paper = cases.load_reference(PAPER)
        results: dict = {"settings": settings.__dict__, "cases": {k: c.name for k, c in cases_.items()},
                         "notes": ["The Tab. 7 pose has A3 = -212.14 deg = +147.86 deg, 2.86 deg past the +145 deg "
                                   "datasheet limit: accepted with a warning.",
                                   "Forces in the paper's axes: Fx along the feed (force on the tool), Fy normal "
                                   "pointing into the material (see timedomain.workpiece_force)."]}
        prog(0.0, "modes")
        results["modes"] = section_modes(settings, pas, cases_["aluminium"], lambda f: prog(0.05 * f, "modes"), work)
        prog(0.05, "lobes")
        lobes_out = section_lobes(settings, pas, cases_, lambda f: prog(0.05 + 0.35 * f, "lobes"), work)
        prog(0.40, "damping (lobes)")
        lobes_damping = steel_damping_by_lobes(settings, pas, cases_["steel"])
        prog(0.45, "time domain")
        td = section_time_domain(settings, cases_, paper, lambda f: prog(0.45 + 0.5 * f, "time domain"), work,
                                 lobes_damping)
        sims = td.pop("_sims")
        results["lobes"] = {k: v for k, v in lobes_out.items() if k != "_results"}
        results["time_domain"] = td
        results["steel_damping"] = {"lobes": lobes_damping, "time_domain": td.pop("steel_damping"),
                                    "paper_scale": paper["steel"]["stabilizing_damping_scale"]}
        results["tab10"] = _tab10(paper, td)
        results["roughness"] = {
            "paper aluminium simulation": paper["aluminium"]["roughness_um"]["simulation"],
            "paper aluminium experimental": paper["aluminium"]["roughness_um"]["experimental"],
            "robolobes aluminium basic": td["runs"]["aluminium/basic"].get("roughness_um") or {},
            "robolobes aluminium backlash": td["runs"]["aluminium/backlash"].get("roughness_um") or {},
            "paper steel simulation": paper["steel"]["roughness_um"]["simulation"],
            "paper steel experimental": paper["steel"]["roughness_um"]["experimental"],
            "robolobes steel basic": td["runs"]["steel/basic"].get("roughness_um") or {},
            "robolobes steel backlash": td["runs"]["steel/backlash"].get("roughness_um") or {},
        }
        results["explanation"] = _explanation(cases_, results["modes"], lobes_out, td, lobes_damping,
                                              results["steel_damping"]["time_domain"])
        results["wall_s"] = time.perf_counter() - t0
        results["generated"] = time.strftime("%Y-%m-%d %H:%M")
        results["provenance"] = out.provenance
        prog(0.97, "report")
        _plot_main(results, lobes_out, sims, work / "study.png")
        write_json(work / "results.json", results)
        write_text(work / "report.md", _report(to_jsonable(results), settings))
        out.commit()  # swap the finished directory in
        prog(1.0, "done")
        return to_jsonable(results)
    finally:
        out.discard()  # after an error or Ctrl-C; a no-op after commit
