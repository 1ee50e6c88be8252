"""``robolobes identify --report DIR``: Markdown + plots of what identification found.

Figures: per pose, measured receptance against the model before and after (magnitude of each
measured pair); the residual spectra |H_model - H_measured| before and after against the noise
estimated from the data.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from robolobes.core.io import pyplot, save_figure, write_text

__all__ = ["write_frf_report", "write_report"]


def _fig_pose(pd, before, after, path, provenance):
    plt = pyplot()
    pairs = np.unique(pd.pair)
    fig, axes = plt.subplots(2, 1, figsize=(8, 6.5), sharex=True)
    for k in pairs:
        s = pd.pair == k
        f = pd.omega[pd.index[s]] / (2 * math.pi)
        lab = f"pair {k}"
        axes[0].semilogy(f, np.abs(pd.H[s]) * 1e6, ".", ms=2, label=f"{lab} measured")
        axes[0].semilogy(f, np.abs(before[s]) * 1e6, ":", lw=1, label=f"{lab} model before")
        axes[0].semilogy(f, np.abs(after[s]) * 1e6, "-", lw=1, label=f"{lab} model after")
        axes[1].semilogy(f, np.abs(before[s] - pd.H[s]) * 1e6, ":", lw=1, label=f"{lab} before")
        axes[1].semilogy(f, np.abs(after[s] - pd.H[s]) * 1e6, "-", lw=1, label=f"{lab} after")
        axes[1].semilogy(f, pd.sigma[s] * 1e6, "k-", lw=0.5, alpha=0.5)
    axes[0].set_ylabel("|H| (um/N)")
    axes[0].legend(fontsize=6, ncol=3)
    axes[1].set_ylabel("|residual| (um/N); black: noise")
    axes[1].set_xlabel("frequency (Hz)")
    axes[0].set_title(f"pose {pd.name}: measured and model, before and after")
    for a in axes:
        a.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    save_figure(fig, path, provenance=provenance, dpi=110)
    plt.close(fig)


def _poles_lines(extra: dict) -> list[str]:
    """Measured poles beside the model's (before): per mode the mean shift and its spread over poses."""
    pb = extra.get("poles_before")
    if not pb:
        return []
    out = ["", "## Measured poles (LSCF/LSFD) beside the model's, before", "",
           "| model mode | mean frequency shift | spread over poses | poses |", "|---|---|---|---|"]
    for k, v in pb.get("shifts", {}).items():
        out.append(f"| {k} | {v['mean_shift']:+.2%} | {v['shift_spread']:.2%} | {v['n_poses']} |")
    extra_poles = {p: d.get("extra_poles_hz", []) for p, d in pb.get("per_pose", {}).items()}
    out += ["", "Measured poles with no model pole within 5 %: " +
            "; ".join(f"{p}: {', '.join(f'{f:.1f} Hz' for f in fs) or 'none'}" for p, fs in extra_poles.items())]
    return out


def _summary_lines(title: str, result, provenance: dict) -> list[str]:
    """Header, effects, diagnosis and selection steps of every report (Markdown lines)."""
    lines = [f"# robolobes identify: {title}", "",
             f"- metric: {result.metric}",
             f"- error before: {result.error_before:.4g}; after: {result.error_after:.4g}; "
             f"noise floor (from the data): {result.noise_floor:.4g}",
             f"- provenance: robolobes {provenance.get('robolobes_version')}, inputs sha256 "
             f"{provenance.get('inputs_sha256')}", ""]
    lines += answer_sentences(result)
    if result.effects:
        lines += ["## Effects found (best first)", "", "| effect | parameter | value | 1 sigma |", "|---|---|---|---|"]
        for e in result.effects:
            for k, v in e.params.items():
                lines.append(f"| {e.name} | {k} | {v:.6g} | {e.uncertainty.get(k, float('nan')):.3g} |")
        lines.append("")
    else:
        lines += ["No effect lowers the held-out error significantly: the model explains the data "
                  "within its noise (`effects: []`).", ""]
    from .ranking import diagnosis_markdown
    lines += diagnosis_markdown(result.extra)
    lines += ["## Selection steps", "", "| step | action | kept | removed | z | threshold | error before | error after |",
              "|---|---|---|---|---|---|---|---|"]
    for i, s in enumerate(result.steps, 1):
        action = s.action + (" (provisional)" if getattr(s, "provisional", False) else "")
        lines.append(f"| {i} | {action} | {s.kept or '-'} | {s.removed or '-'} | {_g(s.statistic, '.3g')} | "
                     f"{_g(s.threshold, '.3g')} | {_g(s.error_before, '.4g')} | {_g(s.error_after, '.4g')} |")
    return lines


def answer_sentences(result) -> list[str]:
    """The answer in sentences, each computed from the result's numbers (Markdown lines)."""
    out = ["## Answer", ""]
    u = result.unexplained or {}
    if u:
        ratio, m = u.get("ratio_to_noise_floor", float("nan")), u.get("margin", float("nan"))
        stat = u.get("statistic", ratio)
        versus = f"the {u.get('statistic_meaning', 'held-out error over the noise floor')} is {stat:.3g}"
        if u.get("unexplained"):
            where = u.get("where", {})
            parts = []
            for key, label in (("poses", "poses"), ("pairs", "FRF pairs"), ("axes", "force axes"),
                               ("bands_hz", "bands (Hz)")):
                items = where.get(key) or []
                if items:
                    names = [f"{x['name'][0]:g}-{x['name'][1]:g}" if key == "bands_hz" else str(x["name"])
                             for x in items[:4]]
                    parts.append(f"{label} {', '.join(names)}")
            if where.get("signatures"):
                parts.append("signatures " + ", ".join(where["signatures"]))
            out.append(f"The residual is **unexplained**: {versus}, above the margin {m:.3g}"
                       + (f" (the held-out error is {ratio:.3g}x the noise floor)" if stat != ratio else "")
                       + ". It stays above the noise in " + ("; ".join(parts) or "no single part")
                       + ". Every effect below lowers the error but is a **surrogate**: it is not shown to be the "
                         "physical cause.")
        else:
            out.append(f"The model explains the data within the noise: {versus} (margin {m:.3g})"
                       + (f"; the held-out error is {ratio:.3g}x the noise floor." if stat != ratio else "."))
    for e in result.effects:
        if not e.credible:
            out.append(f"- {e.name} is **not credible** ({'; '.join(e.not_credible_because)}): not an identified "
                       f"effect.")
            continue
        det = e.determined or {}
        undetermined = [k for k, v in (det.get("parameters") or {}).items() if not v]
        s = f"- {e.name}{' (surrogate)' if e.surrogate else ''}: lowers the held-out error from " \
            f"{e.evidence.get('heldout_error_without', float('nan')):.4g} to " \
            f"{e.evidence.get('heldout_error_with', float('nan')):.4g} (z = {e.evidence.get('z', float('nan')):.3g}, " \
            f"threshold {e.evidence.get('z_threshold', float('nan')):.3g})."
        if undetermined:
            s += f" Not determined by the data: {', '.join(undetermined)}."
        for sh in det.get("shared") or []:
            alt = ", ".join(a["name"] for a in sh.get("indistinguishable_from", []))
            s += f" Determined: {sh['quantity']} = {sh['value']:.4g} +- {sh['sd']:.2g}" + \
                 (f", which {alt} gives too: the data cannot tell them apart." if alt else ".")
        alts = [a["name"] for a in e.evidence.get("alternatives") or []]
        if alts and not det.get("shared"):
            s += f" The held-out data cannot tell it from {', '.join(alts)}."
        out.append(s)
    return out + [""]


def _g(x, fmt: str) -> str:
    """``x`` formatted, or '-' when it is None (binary data have no z statistic)."""
    return "-" if x is None else format(x, fmt)


def write_frf_report(directory: Path, result, poses, effects_state, provenance: dict, model=None,
                     theta=None) -> None:
    """Write ``report.md`` and one figure per pose into ``directory`` (an ``OutputDir``'s staging path)."""
    from .frf import predict

    lines = _summary_lines("tool-tip FRF set", result, provenance)
    lines += _poles_lines(result.extra)
    lines += ["", "## Poses", ""]
    for pd in poses:
        before, after = predict(pd, []), predict(pd, list(effects_state))
        name = f"pose_{pd.name}.png"
        _fig_pose(pd, before, after, directory / name, provenance)
        lines += [f"![pose {pd.name}]({name})", ""]
    if model is not None and theta is not None:
        name = lobe_figure(directory, model, result.effects, theta, provenance)
        lines += ["## Stability lobes at the first measured pose, before and after", "",
                  "SDM (m = 30) for the case's tool, cut and cutting law; the band moves every fitted "
                  "parameter by one standard deviation (both signs).", "", f"![lobes]({name})", ""]
    lines += ["## Model (case TOML)", "", "```toml", result.model_toml.rstrip(), "```", ""]
    lines += ["", f"<!-- robolobes_version {provenance.get('robolobes_version')} inputs_sha256 "
                  f"{provenance.get('inputs_sha256')} -->"]
    write_text(directory / "report.md", "\n".join(lines))


def _shifted(eff, params, unc, sign):
    """Parameters moved by ``sign`` x one standard deviation, inside the bounds."""
    out = {}
    for p in eff.parameters:
        v = params[p.name] + sign * unc.get(p.name, 0.0)
        out[p.name] = float(min(max(v, p.lower), p.upper))
    return out


def lobe_figure(directory: Path, model, fits, theta, provenance, n_speeds: int = 60) -> str:
    """Stability lobes at pose ``theta`` (rad) before and after, with the band of +-1 sigma of the
    fitted parameters (all moved together, both signs). Returns the figure's file name."""
    from robolobes.linearize import linearize
    from robolobes.lobes import LobeProblem, PhysicalStructure, SemiDiscretization, solve

    from .effects import REGISTRY

    case = model.case
    rpm = np.linspace(0.5, 1.5, n_speeds) * case.cut.spindle_rpm

    def limits(state):
        lin = linearize(state.robot(), theta)
        prob = LobeProblem(PhysicalStructure.from_linear(lin, case.cut.feed_direction), case.tool, case.cut, case.law)
        return np.asarray(solve(prob, SemiDiscretization(m=30), speeds_rpm=rpm).depth_limit_m, dtype=float)

    def state_with(sign):
        s = model
        for f in fits:
            eff = REGISTRY[f.name]
            s = eff.apply(s, f.params if sign == 0 else _shifted(eff, f.params, f.uncertainty, sign))
        return s

    before, after = limits(model), limits(state_with(0))
    band = [limits(state_with(s)) for s in (-1, 1)] if fits else []
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7.5, 4.5))
    ax.plot(rpm, before * 1e3, "k:", label="model before")
    ax.plot(rpm, after * 1e3, "b-", label="model after (identified)")
    if band:
        ax.fill_between(rpm, np.minimum(*band) * 1e3, np.maximum(*band) * 1e3, color="b", alpha=0.2,
                        label="after, parameters +-1 sigma")
    ax.axvline(case.cut.spindle_rpm, color="0.5", lw=0.8)
    ax.plot([case.cut.spindle_rpm], [case.cut.ap_m * 1e3], "r*", label="the case's cut")
    ax.set_xlabel("spindle speed (rpm)")
    ax.set_ylabel("depth limit (mm)")
    ax.set_title("stability lobes at the first measured pose")
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    save_figure(fig, directory / "lobes.png", provenance=provenance, dpi=110)
    plt.close(fig)
    return "lobes.png"


_TITLES = {"forces": "cutting-force series", "force_stats": "force statistics", "stability": "stability observations"}


def _fig_forces(arrays: dict, teeth: int, path, provenance) -> None:
    """Held-out synchronous average (x, y) measured against the model before and after, and the
    residual's revolution harmonics before and after against the noise of the average
    (:func:`force_signals.revolution_harmonics`; :func:`force_signals.harmonic_noise`, the RMS |c_k| of
    a residual that is noise only)."""
    from .force_signals import harmonic_noise, revolution_harmonics

    plt = pyplot()
    meas, before, after, noise = (np.asarray(arrays[k]) for k in
                                  ("heldout_measured_n", "model_before_n", "model_after_n", "heldout_noise_n"))
    M = meas.shape[0]
    angle_deg = np.arange(M) * 360.0 / M
    k = np.arange(1, M // 2)
    fig, axes = plt.subplots(2, 2, figsize=(10, 6.5))
    for a, name in enumerate(("x", "y")):
        ax = axes[0, a]
        ax.plot(angle_deg, meas[:, a], "k.", ms=2, label="measured (held out)")
        ax.plot(angle_deg, before[:, a], ":", lw=1, label="model before")
        ax.plot(angle_deg, after[:, a], "-", lw=1, label="model after")
        ax.set_title(f"F{name} (workpiece, cut frame), one revolution")
        ax.set_xlabel("spindle angle (deg)")
        ax.set_ylabel("force (N)")
        ax.legend(fontsize=7)
        ax = axes[1, a]
        for model, style, lab in ((before, ":", "residual before"), (after, "-", "residual after")):
            c = np.abs(revolution_harmonics(model[:, a] - meas[:, a]))[1:M // 2]
            ax.semilogy(k, c, style, marker=".", ms=3, lw=1, label=lab)
        ax.axhline(harmonic_noise(noise[:, a]), color="k", lw=0.8, label="noise of the average")
        for j in range(teeth, M // 2, teeth):
            ax.axvline(j, color="0.85", lw=0.5, zorder=0)
        ax.set_xlim(0.5, min(M // 2, 12 * teeth) + 0.5)
        ax.set_xlabel("revolution harmonic k (grey: tooth-passing harmonics)")
        ax.set_ylabel("|c_k| (N)")
        ax.legend(fontsize=7)
    fig.tight_layout()
    save_figure(fig, path, provenance=provenance, dpi=110)
    plt.close(fig)


def _stability_lines(extra: dict) -> list[str]:
    rows = extra.get("verdicts_before") or []
    if not rows:
        return []
    keys = [k for k in rows[0] if not isinstance(rows[0][k], (dict, list)) and k != "verdict_reason"]
    out = ["## Observations and the model's verdicts before", "", "| " + " | ".join(keys) + " |",
           "|" + "---|" * len(keys)]
    for r in rows:
        out.append("| " + " | ".join(f"{r[k]:.6g}" if isinstance(r[k], float) else str(r[k]) for k in keys) + " |")
    return out + [""]


def write_report(directory: Path, result, provenance: dict, teeth: int = 2) -> None:
    """``report.md`` (and, for a force series, ``forces.png``) for a force, force-statistics or
    stability identification, into ``directory`` (an ``OutputDir``'s staging path)."""
    lines = _summary_lines(_TITLES[result.kind], result, provenance)
    if result.kind == "forces" and result.arrays:
        _fig_forces(result.arrays, teeth, directory / "forces.png", provenance)
        lines += ["", "## Held-out synchronous average and residual spectra, before and after", "",
                  "![forces](forces.png)", ""]
    if result.kind == "stability":
        lines += [""] + _stability_lines(result.extra)
    lines += ["## Model (case TOML)", "", "```toml", result.model_toml.rstrip(), "```", ""]
    lines += ["", f"<!-- robolobes_version {provenance.get('robolobes_version')} inputs_sha256 "
                  f"{provenance.get('inputs_sha256')} -->"]
    write_text(directory / "report.md", "\n".join(lines))
