"""``report.md`` of the study, rendered from a :class:`StudyResult` (numbers from :func:`to_json`)."""

from __future__ import annotations

import math

import numpy as np

from robolobes.linearize.model import VARIANTS

from . import prose
from .findings import findings, summary_table
from .results_json import to_json
from .result import StudyResult
from .settings import MATERIALS, POSES

__all__ = ["render_report"]


def _fmt(v, nd: int = 2) -> str:
    if v is None:
        return "-"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, (float, np.floating)):
        return f"{v:.{nd}f}" if math.isfinite(v) else ("inf" if v > 0 else "-")
    return str(v)


def _mm(v) -> str:
    """m -> mm; None or inf: no limit found up to the search bound."""
    return "none below the bound" if v is None or not math.isfinite(v) else _fmt(v * 1e3)


def _header(res: StudyResult) -> list[str]:
    p = res.provenance
    return ["# robolobes study: stable aluminium, unstable steel on the Staubli TX200\n",
            f"{'Quick' if res.settings.quick else 'Full'} study, computed by robolobes {p['robolobes_version']} in "
            f"{res.wall_s:.0f} s ({res.generated}; inputs sha256 {p['inputs_sha256'][:16]}...). Every number below "
            "is in `results.json`; every number labelled \"paper\" is the paper's, every other one was computed "
            "here.\n", "![main figure](study.png)\n"]


def _explanation(data: dict) -> list[str]:
    return ["## What the study finds\n", summary_table(data), ""] + [f"* {s}" for s in findings(data)] + [""]


def _modes_table(res: StudyResult) -> list[str]:
    n = len(res.mode_set("basic", "start").freq_hz)
    out = ["## Modes at the start, middle and end of the pass\n",
           f"The first {n} natural frequencies (Hz) and the smallest eigenvalue of the symmetric part of the "
           "static TCP stiffness (N/um).\n",
           "| variant | pose | " + " | ".join(f"f{i + 1}" for i in range(n)) + " | min TCP stiffness |",
           "|---|---|" + "---|" * (n + 1)]
    for v in VARIANTS:
        for pose in POSES:
            m = res.mode_set(v, pose)
            K = np.asarray(m.summary["tcp_static_stiffness_n_per_m"])
            kmin = np.linalg.eigvalsh(0.5 * (K + K.T))[0] / 1e6
            out.append(f"| {v} | {pose} | " + " | ".join(f"{x:.1f}" for x in m.freq_hz[:n]) + f" | {kmin:.3f} |")
    return out + ["\n![FRFs](frf.png)\n"]


def _operating_points_table(res: StudyResult) -> list[str]:
    out = ["## Operating points against the lobes\n",
           "| material | variant | pose | verdict | limit (mm) | margin | bifurcation | chatter (Hz) |",
           "|---|---|---|---|---|---|---|---|"]
    for mat in MATERIALS:
        for o in (o for o in res.operating_points if o.material == mat):
            out.append(f"| {mat} | {o.variant} | {o.pose} | {o.verdict.status} | {_mm(o.depth_limit_m)} | "
                       f"{_fmt(o.margin)} | {o.limit_bifurcation} | {_fmt(o.limit_chatter_freq_hz, 1)} |")
    undetermined = [o for o in res.operating_points if o.verdict.status == "undetermined"]
    for o in undetermined:
        out.append(f"\n{o.material} [{o.variant}], {o.pose}: undetermined, {o.verdict.reason}.")
    out += [f"\n![{d.figure}]({d.figure})" for d in res.diagrams]
    return out


def _time_domain_table(res: StudyResult) -> list[str]:
    out = ["\n## Time domain\n",
           f"Path: {'linearized fast path' if res.td_linearized else 'full nonlinear model'}.\n",
           "| run | damping | verdict | chatter (Hz) | Fy min (N) | Fy rms (N) | Ra / Rt (um) | simulated (s) "
           "| wall (s) |",
           "|---|---|---|---|---|---|---|---|---|"]
    for r in res.time_domain:
        fs = (r.summary.get("force_stats_paper_axes") or {}).get("y", {})
        ru = r.summary.get("roughness_um") or {}
        out.append(f"| {r.key} | x{r.damping_scale:g} | {r.verdict.status} | {_fmt(r.chatter_freq_hz, 1)} | "
                   f"{_fmt(fs.get('min'), 1)} | {_fmt(fs.get('rms'), 1)} | "
                   f"{_fmt(ru.get('Ra'))} / {_fmt(ru.get('Rt'))} | "
                   f"{r.t_end_s:.2f} | {r.wall_s:.1f} |")
    for r in res.time_domain:
        if r.verdict.status == "undetermined":
            out.append(f"\n{r.key} (x{r.damping_scale:g}): undetermined, {r.verdict.reason}")
    return out + ["\n![time domain](time_domain.png)\n"]


def _rate(info: dict) -> str:
    """``+0.68 ± 0.01``: a growth rate and twice its standard error, 1/s ("-" when not fitted)."""
    r, se = info.get("growth_rate_per_s"), info.get("growth_rate_se_per_s")
    return "-" if r is None or se is None else f"{r:+.3f} ± {2 * se:.3f}"


def _exponent(info: dict) -> str:
    """``+0.45 ± 0.08``: a Floquet exponent and its Richardson error, 1/s."""
    return f"{info['exponent_per_s']:+.3f} ± {info['exponent_error_per_s']:.3f}"


def _damping_section(res: StudyResult) -> list[str]:
    dl, dt, dd, dle = res.damping_lobes, res.damping_time_domain, res.damping_delay, res.damping_lobes_eroded
    dlf = res.damping_lobes_orbit
    cross = ""
    if dd is not None:
        cross = (" " + prose.damping_cross_check(dl.bracket, dd.bracket, dt.bracket, res.eroded_deflection_m,
                                                 dle.bracket if dle else None, dlf.bracket if dlf else None,
                                                 res.eroded_entry_deflection_m)
                 + f" Resolution of the delay-based search: {dd.resolution:g}.")
    out = ["## Steel: how much joint damping stabilizes it\n",
           prose.damping_comparison(dl.bracket, dt.bracket, res.paper_damping_scale,
                                    "the eroded-part time domain" if dd is not None else "the time domain")
           + f" Resolution: {dl.resolution:g} (lobes), {dt.resolution:g} (time domain). Both at the Tab. 7 pose "
           f"with the {dl.variant} model: the time domain runs the linearized path, frozen at that pose."
           + cross + "\n",
           "| scale | lobes verdict | limit (mm) | eroded-part verdict | growth rate ± 2 SE (1/s) | chatter (Hz) "
           "| dy (um) | dy at entry (um) | delay-based verdict | delay-based rate ± 2 SE (1/s) | lobes at ae - dy "
           "| limit at ae - dy (mm) | lobes about the forced orbit | exponent ± error (1/s) |",
           "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    lp = {p.scale: p for p in dl.probes}
    tp = {p.scale: p for p in dt.probes}
    dp = {p.scale: p for p in dd.probes} if dd is not None else {}
    ep = {p.scale: p for p in dle.probes} if dle is not None else {}
    fp = {p.scale: p for p in dlf.probes} if dlf is not None else {}
    for sc in sorted(set(lp) | set(tp) | set(dp) | set(ep) | set(fp)):
        a, b, c, e, f = lp.get(sc), tp.get(sc), dp.get(sc), ep.get(sc), fp.get(sc)
        dy = b.info.get("mean_normal_deflection_m") if b else None
        dy_in = b.info.get("entry_normal_deflection_m") if b else None
        out.append(f"| {sc:g} | {a.verdict.status if a else ''} | {_mm(a.info['depth_limit_m']) if a else ''} | "
                   f"{b.verdict.status if b else ''} | {_rate(b.info) if b else ''} | "
                   f"{_fmt(b.info.get('chatter_freq_hz'), 1) if b else ''} | "
                   f"{_fmt(dy * 1e6) if dy is not None else ''} | {_fmt(dy_in * 1e6) if dy_in is not None else ''} | "
                   f"{c.verdict.status if c else ''} | {_rate(c.info) if c else ''} | "
                   f"{e.verdict.status if e else ''} | {_mm(e.info['depth_limit_m']) if e else ''} | "
                   f"{f.verdict.status if f else ''} | {_exponent(f.info) if f else ''} |")
    return out


def _tab10_section(res: StudyResult) -> list[str]:
    out = ["\n## Tab. 10: aluminium forces over the paper's window (paper axes, N)\n",
           "| row | Fx min | Fx max | Fx mean | Fx rms | Fy min | Fy max | Fy mean | Fy rms |",
           "|---|---|---|---|---|---|---|---|---|"]
    for row in res.tab10:
        out.append(f"| {row.name} | " + " | ".join(_fmt(row.values[f'f{ax}_{k}']) for ax in ('x', 'y')
                                                   for k in ('min', 'max', 'mean', 'rms')) + " |")
    return out


def _facts_section(res: StudyResult) -> list[str]:
    from robolobes.study.force_facts import facts_markdown

    out = ["\n## The seed's facts, confronted with identification\n"]
    f = res.identify_facts or {}
    a, b = f.get("tab10"), f.get("steel")
    if a is None:
        out.append("Fact (a), Tab. 10 identified from its 8 statistics, was not computed in this quick study (it "
                   "takes minutes); the full study (`robolobes study`) computes it.\n")
    else:
        rows = a["paper_rows_rms_n"]
        best = min(rows, key=rows.get)
        out.append(prose.tab10_identified(a["rms_before_n"], a["rms_after_n"], rows["basic"], rows[best], best)
                   + "\n")
    if b is None:
        out.append("Fact (b), the steel cut observed stable, was not computed in this study.\n")
    return out + [facts_markdown(a, b) + "\n"]


def _roughness_cell(v) -> str:
    return f"{v[0]:g}-{v[1]:g}" if isinstance(v, (tuple, list)) else _fmt(v)


def _roughness_section(res: StudyResult) -> list[str]:
    out = ["\n## Roughness of the lateral wall (um)\n", "| | Ra | Rq | Rt |", "|---|---|---|---|"]
    out += [f"| {r.name} | {_roughness_cell(r.Ra)} | {_roughness_cell(r.Rq)} | {_roughness_cell(r.Rt)} |"
            for r in res.roughness]
    return out + ["\nOurs: ISO 4287 on the middle slice, Gaussian mean line with lambda_c = 0.8 mm (ISO 4288), over "
                  "the wall the tool has fully passed. The paper does not state its filter.\n",
                  "![wall aluminium](wall_aluminium.png)\n![wall steel](wall_steel.png)\n"]


def _notes(res: StudyResult) -> list[str]:
    return ["## Notes\n"] + [f"* {n}" for n in res.notes] + [
        f"* Provenance: robolobes {res.provenance['robolobes_version']}, inputs sha256 "
        f"{res.provenance['inputs_sha256']}.", ""]


def render_report(res: StudyResult) -> str:
    """The markdown report of a study result."""
    data = to_json(res)
    parts = (_header(res) + _explanation(data) + _modes_table(res) + _operating_points_table(res)
             + _time_domain_table(res) + _damping_section(res) + _tab10_section(res) + _facts_section(res)
             + _roughness_section(res)
             + _notes(res))
    return "\n".join(parts) + "\n"
