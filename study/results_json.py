"""``results.json`` of a :class:`StudyResult`: :func:`to_json` and its parts (no rendering here,
so that the report and the writer both build on it)."""

from __future__ import annotations

from dataclasses import asdict, fields, is_dataclass

from robolobes.core.io import to_jsonable

from .result import DampingSearch, MaterialFacts, StudyResult

__all__ = ["to_json", "damping_json", "facts_json", "SOURCE"]

#: What ``results.json`` is: computed here, except the entries that say they are the paper's.
SOURCE = ("computed by robolobes (robolobes study); only the entries named 'paper ...' and "
          "steel_damping.paper_scale are the paper's published values")


def _plain(obj, skip=()) -> dict:
    """A dataclass's fields as a dict, without ``skip``; nested dataclasses as dicts."""
    return {f.name: (asdict(v) if is_dataclass(v) and not isinstance(v, type) else v) for f in fields(obj)
            if f.name not in skip
            for v in (getattr(obj, f.name),)}


def damping_json(d: DampingSearch) -> dict:
    """A damping search as JSON: the bracket, its resolution and every probe's verdict."""
    return {"method": d.method, "variant": d.variant, "largest_unstable_scale": d.largest_unstable,
            "smallest_stable_scale": d.smallest_stable, "resolution": d.resolution,
            "probes": {f"{p.scale:g}": {**p.verdict.to_json(), **p.info} for p in d.probes}}


def facts_json(f: MaterialFacts) -> dict:
    """The explanation's numbers of one material (plain values; verdict strings)."""
    out = _plain(f, skip=("lobes_verdict", "time_domain_verdict_basic"))
    out.update(lobes_verdict=f.lobes_verdict.status, time_domain_verdict_basic=f.time_domain_verdict_basic.status,
               tooth_passing_over_lowest_mode=f.tooth_passing_over_lowest_mode, krc_over_ktc=f.krc_over_ktc,
               local_over_lowest=f.local_over_lowest)
    return out


def _operating_point_json(o) -> dict:
    return {**o.verdict.to_json(), **_plain(o, skip=("point", "verdict", "material", "variant", "pose"))}


def _run_json(r) -> dict:
    return {**r.summary, **r.verdict.to_json(), "damping_scale": r.damping_scale, "t_end_s": r.t_end_s,
            "wall_s": r.wall_s, "steps": r.steps}


def to_json(res: StudyResult) -> dict:
    """``results.json``: every number of the study, JSON-ready (SI; NaN and inf become null)."""
    modes: dict = {}
    for m in res.modes:
        modes.setdefault(m.variant, {})[m.pose] = {**m.summary, "frf_peak_um_per_n": m.frf_peak_um_per_n,
                                                   "frf_file": m.frf_file}
    lobes: dict = {}
    for o in res.operating_points:
        point = {"operating_point": _operating_point_json(o)}
        lobes.setdefault(o.material, {}).setdefault(o.variant, {})[o.pose] = point
    for d in res.diagrams:
        lobes[d.material][d.variant][d.pose]["diagram"] = {
            "rpm": d.spindle_rpm, "depth_limit_m": d.depth_limit_m, "chatter_freq_hz": d.chatter_freq_hz,
            "bifurcation": list(d.bifurcation), "wall_s": d.wall_s, "figure": d.figure}
    for a in res.lowest_limits:
        lobes[a.material]["lowest_limit"] = {**_plain(a, skip=("material",)), "method": "RefinedSDM()",
                                             "search": "400 geometric speeds over 300-30000 rpm, then Brent's "
                                                       "bounded search at the 3 lowest sampled minima"}
    runs = {r.key: _run_json(r) for r in res.time_domain if r.damping_scale == 1.0}
    damped = [_run_json(r) for r in res.time_domain if r.damping_scale != 1.0]
    al, st = res.facts["aluminium"], res.facts["steel"]
    explanation: dict[str, object] = {mat: facts_json(f) for mat, f in res.facts.items()}
    explanation.update(
        ktc_ratio_steel_over_aluminium=res.ktc_ratio_steel_over_aluminium,
        lowest_limit_ratio_aluminium_over_steel=al.lowest_limit_m / st.lowest_limit_m,
        local_limit_ratio_aluminium_over_steel=al.local_limit_m / st.local_limit_m)
    return to_jsonable({
        "source": SOURCE, "provenance": res.provenance, "settings": _plain(res.settings), "cases": res.cases,
        "notes": list(res.notes),
        "modes": modes, "lobes": lobes,
        "time_domain": {"linearized": res.td_linearized, "runs": runs, "steel_damped": damped},
        "steel_damping": {"lobes": damping_json(res.damping_lobes),
                          "time_domain": damping_json(res.damping_time_domain),
                          **({"delay_based": damping_json(res.damping_delay)} if res.damping_delay else {}),
                          **({"lobes_at_ae_minus_dy": damping_json(res.damping_lobes_eroded),
                              "eroded_deflection_m": res.eroded_deflection_m} if res.damping_lobes_eroded else {}),
                          **({"lobes_about_forced_orbit": damping_json(res.damping_lobes_orbit),
                              "eroded_entry_deflection_m": res.eroded_entry_deflection_m}
                             if res.damping_lobes_orbit else {}),
                          "paper_scale": res.paper_damping_scale},
        "tab10": {r.name: r.values for r in res.tab10},
        "roughness": {r.name: {"Ra": r.Ra, "Rq": r.Rq, "Rt": r.Rt} for r in res.roughness},
        "explanation": explanation,
        "identify_facts": res.identify_facts,
        "wall_s": res.wall_s, "generated": res.generated, "linearize_calls": res.linearize_calls,
    })
