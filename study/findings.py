"""What the study finds, in words computed from ``results.json``: the summary table and the findings.

Both the report and the README's marked block (:mod:`.readme`) are rendered from these functions,
so the README's numbers are those of a results file and every comparative word comes from
:mod:`.prose`.
"""

from __future__ import annotations

import math

from . import prose

__all__ = ["summary_table", "findings", "tab10_deviation", "variants_verdicts"]

VARIANTS = ("basic", "gravity", "orthogonal", "backlash")


def _mm(v) -> str:
    return "none below the search bound" if v is None or not math.isfinite(v) else f"{v * 1e3:.3g} mm"


def _op(data: dict, mat: str, variant: str = "basic") -> dict:
    return data["lobes"][mat][variant]["start"]["operating_point"]


def variants_verdicts(data: dict, mat: str) -> str:
    """The time-domain verdicts of the four variants: "stable" when all agree, else each named."""
    v = [data["time_domain"]["runs"][f"{mat}/{k}"]["verdict"] for k in VARIANTS]
    return v[0] if len(set(v)) == 1 else ", ".join(f"{k} {s}" for k, s in zip(VARIANTS, v))


def _op_cell(op: dict) -> str:
    lim = op["depth_limit_m"]
    s = (f"{_mm(lim)}, margin {op['margin']:+.2f}, {op['verdict']}" if lim is not None
         else f"{_mm(lim)}, {op['verdict']}")
    if op["verdict"] == "unstable" and op.get("limit_bifurcation") not in (None, "none"):
        s += f" ({op['limit_bifurcation']}, {op['limit_chatter_freq_hz']:.1f} Hz)"
    return s


def _lowest_cell(data: dict, mat: str) -> str:
    """E.g. "0.0246 mm at 962 rpm (flip, 16.0 Hz; estimated error 0.04 %)": the refined lowest limit."""
    low = data["lobes"][mat]["lowest_limit"]
    return (f"{_mm(low['depth_m'])} at {low['at_rpm']:.0f} rpm ({low['bifurcation']}, "
            f"{low['chatter_freq_hz']:.1f} Hz; estimated error {100 * low['depth_error_m'] / low['depth_m']:.1g} %)")


def summary_table(data: dict) -> str:
    """The aluminium / steel table of the README and the report (markdown)."""
    ex = data["explanation"]
    al, st = ex["aluminium"], ex["steel"]
    dl, dt = data["steel_damping"]["lobes"], data["steel_damping"]["time_domain"]
    td = data["time_domain"]
    rows = [
        ("spindle, tooth passing", f"{al['spindle_rpm']:.0f} rpm, {al['tooth_passing_hz']:.1f} Hz",
         f"{st['spindle_rpm']:.0f} rpm, {st['tooth_passing_hz']:.1f} Hz"),
        ("Ktc, Krc", f"{al['ktc_pa'] / 1e6:.1f}, {al['krc_pa'] / 1e6:.1f} MPa",
         f"{st['ktc_pa'] / 1e6:.0f}, {st['krc_pa'] / 1e6:.0f} MPa"),
        ("lobes, 6-DOF basic, at the cut speed", _op_cell(_op(data, "aluminium")), _op_cell(_op(data, "steel"))),
        ("lobes, 18-DOF orthogonal", _op_cell(_op(data, "aluminium", "orthogonal")),
         _op_cell(_op(data, "steel", "orthogonal"))),
        ("lowest limit, 6-DOF basic, 300-30000 rpm", _lowest_cell(data, "aluminium"),
         _lowest_cell(data, "steel")),
        (f"time domain ({'linearized' if td['linearized'] else 'full model'}), 4 variants",
         variants_verdicts(data, "aluminium"), variants_verdicts(data, "steel")),
        ("joint-damping scale that stabilizes steel (basic), [unstable, stable]", "",
         f"{prose.bracket_text(dl['largest_unstable_scale'], dl['smallest_stable_scale'])} lobes, "
         + (f"{prose.bracket_text(*_bracket(dt))} eroded-part time domain, "
            f"{prose.bracket_text(*_bracket(dd))} delay-based time domain"
            if (dd := data["steel_damping"].get("delay_based"))
            else f"{prose.bracket_text(*_bracket(dt))} time domain")),
    ]
    lines = ["| | aluminium 6060 | steel St 52-3 |", "|---|---|---|"]
    lines += [f"| {a} | {b} | {c} |" for a, b, c in rows]
    return "\n".join(lines)


def tab10_deviation(ours: dict, paper: dict) -> tuple[float, float]:
    """Largest relative deviation (%) of our Tab. 10 row from the paper's: (means and RMS, extremes).

    Zero paper values (Fy max = 0 in the model rows) are compared in N, not in %, and left out.
    """
    def worst(keys):
        d = [abs(ours[k] - paper[k]) / abs(paper[k]) * 100 for k in keys if paper[k] != 0]
        return max(d) if d else math.nan
    return (worst([f"f{a}_{s}" for a in "xy" for s in ("mean", "rms")]),
            worst([f"f{a}_{s}" for a in "xy" for s in ("min", "max")]))


def _why_aluminium(ex: dict) -> str:
    al = ex["aluminium"]
    return (f"**Tooth passing against the modes.** Aluminium's teeth pass at {al['tooth_passing_hz']:.0f} Hz, "
            f"{al['tooth_passing_over_lowest_mode']:.0f} times the lowest robot mode ({al['lowest_mode_hz']:.1f} Hz); "
            f"{prose.modes_below(al['modes_below_tooth_passing_basic'], al['n_modes_basic'], '6-DOF model')}. "
            f"Its limit at the cut speed is {prose.limit_against_cut(al['local_limit_m'], al['depth_m'])}, "
            + (f"{al['local_over_lowest']:.1f} times its lowest limit over 300-30000 rpm: "
               if al["local_over_lowest"] else "")
            + f"the lobes verdict is {al['lobes_verdict']}.")


def _why_steel(ex: dict) -> str:
    st = ex["steel"]
    scaling = prose.limit_scaling(ex["ktc_ratio_steel_over_aluminium"], ex["lowest_limit_ratio_aluminium_over_steel"],
                                  ex["local_limit_ratio_aluminium_over_steel"])
    below = prose.modes_below(st["modes_below_tooth_passing_basic"], st["n_modes_basic"], "6-DOF model")
    limit = prose.limit_against_cut(st["local_limit_m"], st["depth_m"])
    return (f"**Steel.** {scaling} Its teeth pass at {st['tooth_passing_hz']:.1f} Hz, "
            f"{st['tooth_passing_over_lowest_mode']:.1f} times the lowest mode; {below}. Its limit at "
            f"{st['spindle_rpm']:.0f} rpm is {limit}: the lobes verdict is {st['lobes_verdict']}.")


def _how_steel_chatters(ex: dict) -> str | None:
    st = ex["steel"]
    dm = st.get("dominant_mode")
    if not dm or st["chatter_freq_hz_lobes"] is None:
        return None
    s = (f"**How steel chatters.** The lobes' critical solution is a {st['bifurcation']} at "
         f"{st['chatter_freq_hz_lobes']:.1f} Hz; mode {dm['index']} ({dm['freq_hz']:.1f} Hz, "
         f"{100 * dm['damping_ratio']:.1f} % damping) carries {100 * dm['share']:.0f} % of the normal receptance "
         "there.")
    if st.get("chatter_freq_hz_time_domain") is not None:
        s += " " + prose.relative_agreement("The time domain (basic) finds", st["chatter_freq_hz_time_domain"],
                                            st["chatter_freq_hz_lobes"], "Hz", ref_label="the lobes'") + "."
    return s


def _bracket(d: dict) -> tuple:
    return d["largest_unstable_scale"], d["smallest_stable_scale"]


def _damping(data: dict) -> str:
    sd = data["steel_damping"]
    dl, dt = sd["lobes"], sd["time_domain"]
    label = "the eroded-part time domain" if sd.get("delay_based") else "the time domain"
    out = "**Damping.** " + prose.damping_comparison(_bracket(dl), _bracket(dt), sd["paper_scale"], label)
    if sd.get("delay_based"):
        at_dy, orbit = sd.get("lobes_at_ae_minus_dy"), sd.get("lobes_about_forced_orbit")
        out += " " + prose.damping_cross_check(_bracket(dl), _bracket(sd["delay_based"]), _bracket(dt),
                                               sd.get("eroded_deflection_m"), _bracket(at_dy) if at_dy else None,
                                               _bracket(orbit) if orbit else None, sd.get("eroded_entry_deflection_m"))
    return out


def _forces(data: dict) -> str | None:
    rows = data["tab10"]
    parts = []
    for v in VARIANTS:
        if f"robolobes {v}" in rows and f"paper {v}" in rows:
            m, e = tab10_deviation(rows[f"robolobes {v}"], rows[f"paper {v}"])
            parts.append(f"{v} {m:.1f} % ({e:.1f} %)")
    if not parts:
        return None
    b, p = rows.get("robolobes basic"), rows.get("paper basic")
    ex = (f" Basic: Fx mean / RMS {b['fx_mean']:.2f} / {b['fx_rms']:.2f} N against {p['fx_mean']:.2f} / "
          f"{p['fx_rms']:.2f}; Fy min / mean / RMS {b['fy_min']:.1f} / {b['fy_mean']:.2f} / {b['fy_rms']:.2f} N "
          f"against {p['fy_min']:.2f} / {p['fy_mean']:.2f} / {p['fy_rms']:.2f}.") if b and p else ""
    return ("**Forces against Tab. 10** (aluminium, the paper's window and axes). Largest deviation of our mean "
            "and RMS forces from the paper's model row of the same variant (and of the extremes): "
            + ", ".join(parts) + "." + ex)


def _roughness(data: dict) -> str | None:
    rough = data["roughness"]
    meas = rough.get("paper aluminium experimental")
    parts = []
    for v in ("backlash", "basic"):
        r = rough.get(f"robolobes aluminium {v}") or {}
        if r.get("Ra") is None or r.get("Rt") is None or not meas:
            continue
        (ra_lo, ra_hi), (rt_lo, rt_hi) = meas["Ra"], meas["Rt"]  # measured ranges, um
        parts.append(f"{v}: {prose.range_comparison('Ra', r['Ra'], ra_lo, ra_hi, 'um', 2)}, "
                     f"{prose.range_comparison('Rt', r['Rt'], rt_lo, rt_hi, 'um', 1)}")
    if not parts:
        return None
    return "**Roughness of the aluminium wall** (computed by robolobes, against Tab. 11): " + "; ".join(parts) + "."


def findings(data: dict) -> list[str]:
    """The study's findings as markdown paragraphs, every comparison computed from ``data``."""
    ex = data["explanation"]
    out = [_why_aluminium(ex), _why_steel(ex), _how_steel_chatters(ex), _damping(data), _forces(data),
           _roughness(data)]
    return [s for s in out if s]
