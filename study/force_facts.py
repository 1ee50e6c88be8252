"""The seed paper's measured facts, confronted with the model by identification (for the study report).

(a) **Aluminium, Tab. 10** (:func:`tab10_fact`): the 8 measured force statistics against the basic
    model, before and after the effects that force-statistics identification selects (AICc, at most
    3 parameters; :func:`identify.forces.identify_force_stats`), beside the RMS of the paper's own
    model rows (:func:`paper_rows_rms`, from ``cases/data/tx200-paper-results.toml``).
(b) **Steel, measured stable, predicted unstable** (:func:`steel_fact`): the joint-damping scale and
    the process damping that make the lobes agree with the stable cut, with the surface wavelength
    ``V / f_chatter`` and whether each value is credible (:mod:`identify.force_stability`).

Both return plain dicts (JSON-ready); :func:`facts_markdown` renders them for a report.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["paper_rows_rms", "tab10_fact", "steel_fact", "facts_markdown", "TAB10_FILE"]

#: The shipped Tab. 10 experimental row, in the force_stats.toml format.
TAB10_FILE = Path(__file__).resolve().parents[1] / "cases" / "data" / "measured" / "tx200-aluminium-tab10" / \
    "force_stats.toml"


def _tab10_file() -> Path:
    from importlib import resources

    p = Path(str(resources.files("robolobes.cases") / "data" / "measured" / "tx200-aluminium-tab10" /
                 "force_stats.toml"))
    return p if p.is_file() else TAB10_FILE


def paper_rows_rms() -> dict:
    """RMS over the 8 statistics of each of the paper's model rows against its experimental row, N.

    Rows are ``[Fx min, Fy min, Fx max, Fy max, Fx mean, Fy mean, Fx rms, Fy rms]`` (paper axes)."""
    from robolobes.cases.loader import load_reference

    tab = load_reference("tx200-paper-results")["aluminium"]["tab10"]
    exp = np.asarray(tab["experimental"], float)
    return {k: float(np.sqrt(np.mean((np.asarray(v, float) - exp) ** 2)))
            for k, v in tab.items() if k not in ("experimental", "window_s")}


def tab10_fact(variant: str = "basic", progress=None) -> dict:
    """Fact (a): identification on the paper's Tab. 10 experimental row (module docstring)."""
    from robolobes.identify.api import model_state, read_measurement
    from robolobes.identify.force_data import ForceStatistics
    from robolobes.identify.forces import identify_force_stats

    m = read_measurement(_tab10_file())
    assert isinstance(m, ForceStatistics), m  # the shipped file is force_stats.toml
    state, _ = model_state(m, variant=variant)
    res = identify_force_stats(m, state, progress=progress)
    d = res.to_json()
    return {"variant": variant, "rms_before_n": res.error_before, "rms_after_n": res.error_after,
            "effects": d["effects"], "dof": d["dof"], "paper_rows_rms_n": paper_rows_rms(),
            "model_before_n": d["model_before_n"], "model_after_n": d["model_after_n"],
            "target_n": d["target_workpiece_axes_n"], "aicc_table": d["aicc_table"]}


def steel_fact(variant: str = "basic", progress=None) -> dict:
    """Fact (b): the steel cut observed stable at 3100 rpm, 1.6 mm, at the pass start (module docstring).

    The fast stability pipeline (:mod:`identify.force_stability`, about 15 s). ``verdict_before`` is
    the lobes' robust verdict (:func:`lobes.stability`, Richardson) with ``depth_limit_m`` and
    ``chatter_freq_hz``. When process damping within its physical bound (``Ksp L^2 <= 9e6 N/m``)
    cannot stabilize the cut, the value it would need (searched up to 1e12 N/m) is added to
    ``effects`` with ``"within_bounds": False`` and ``credible`` False."""
    import math

    from robolobes.cases import load_case
    from robolobes.lobes import stability

    from robolobes.identify.effects import ModelState
    from robolobes.identify.force_data import StabilityObservation, StabilityObservations
    from robolobes.identify.force_stability import (Candidate, ObservationModel, _pd_evidence, critical_value,
                                                    identify_stability)

    case = load_case("tx200-steel")
    row = StabilityObservation(case="tx200-steel", rpm=case.cut.spindle_rpm, depth_m=case.cut.ap_m, chatter=False,
                               path_s_m=0.0)
    obs = StabilityObservations(path=Path("tx200-steel (paper, section 4.2)"), rows=(row,))
    state = ModelState(case=case, variant=variant, case_ref="tx200-steel")
    res = identify_stability(obs, state, progress=progress)
    d = res.to_json()
    om = ObservationModel.build(state, case, row)
    sp = stability(om.problem)
    vb = {**d["verdicts_before"][0], "lobes_verdict": sp.verdict.status, "lobes_verdict_reason": sp.verdict.reason,
          "depth_limit_m": sp.depth_limit_m, "depth_limit_error_m": sp.depth_limit_error_m,
          "chatter_freq_hz": sp.limit_chatter_freq_hz, "bifurcation": sp.limit_bifurcation}
    effects = list(d["effects"])
    if not any(e["name"] == "process_damping" for e in effects):
        wide = Candidate("process_damping", "ksp_l2_n_per_m", 0.0, 1e12, 0.0)
        need = critical_value(om, wide)
        if math.isfinite(need):
            ev = _pd_evidence({"value": need}, [om], sp.limit_chatter_freq_hz)
            ev.update(credible=False, within_bounds=False,
                      why=ev["why"] + f"; beyond the physical bound Ksp L^2 <= {wide_bound():.3g} N/m")
            effects.append({"name": "process_damping", "params": {"ksp_l2_n_per_m": need},
                            "uncertainty": {"ksp_l2_n_per_m": math.nan}, "evidence": ev})
    return {"variant": variant, "error_before": res.error_before, "error_after": res.error_after,
            "verdict_before": vb, "effects": effects}


def wide_bound() -> float:
    """The physical upper bound of process damping's ``Ksp L^2``, N/m."""
    from robolobes.identify.cutting_effects import ProcessDamping

    return ProcessDamping.parameters[0].upper


def _fmt_stats(v) -> str:
    return ", ".join(f"{x:.1f}" for x in v)


def facts_markdown(a: dict | None, b: dict | None) -> str:
    """Markdown paragraphs for the report (either fact may be None)."""
    out = []
    if a is not None:
        rows = a["paper_rows_rms_n"]
        eff = "; ".join(f"{e['name']} " + ", ".join(f"{k} = {v:.4g}" for k, v in e["params"].items())
                        for e in a["effects"]) or "none"
        out.append(f"**(a) Aluminium, Tab. 10.** RMS over the 8 statistics: our {a['variant']} model "
                   f"{a['rms_before_n']:.1f} N (paper's basic row {rows['basic']:.1f} N, backlash row "
                   f"{rows['backlash']:.1f} N). Effects selected (AICc, at most 3 parameters, {a['dof']} degrees "
                   f"of freedom left): {eff}; after: {a['rms_after_n']:.1f} N. Measured (workpiece axes) "
                   f"{_fmt_stats(a['target_n'])}; model before {_fmt_stats(a['model_before_n'])}; after "
                   f"{_fmt_stats(a['model_after_n'])} N.")
    if b is not None:
        parts = []
        for e in b["effects"]:
            ev = e["evidence"]
            val = ", ".join(f"{k} = {v:.4g}" for k, v in e["params"].items())
            parts.append(f"{e['name']} ({val}): {'credible' if ev['credible'] else 'not credible'}: {ev['why']}.")
        vb = b["verdict_before"]
        out.append(f"**(b) Steel, observed stable.** The lobes say {vb['verdict']} (limit "
                   f"{vb['depth_limit_m'] * 1e3:.3f} mm at 3100 rpm, chatter {vb['chatter_freq_hz']:.1f} Hz). "
                   + " ".join(parts))
    return "\n\n".join(out)

