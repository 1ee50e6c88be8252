"""The study's figures, drawn from a :class:`StudyResult` (PNG files in the output directory)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from robolobes.core.io import pyplot, save_figure
from robolobes.linearize.model import VARIANTS

from .result import StudyResult

__all__ = ["write_figures", "plot_frfs", "plot_time_domain", "plot_main"]


def _finish(fig, path: Path) -> None:
    plt = pyplot()
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)


def plot_frfs(res: StudyResult, path: Path) -> None:
    """Direct feed and normal TCP receptances (cut frame), four variants, start and end of the pass."""
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), sharey=True)
    for ax, (i, name) in zip(axes, ((0, "feed"), (1, "normal"))):
        for variant in VARIANTS:
            for pose, ls in (("start", "-"), ("end", ":")):
                frf = res.mode_set(variant, pose).frf
                ax.semilogy(frf.freq_hz, np.abs(np.asarray(frf.H)[i, i]) * 1e6, ls, lw=1,
                            label=f"{variant}, {pose}" if i == 0 else None)
        ax.set_title(f"TCP receptance H_{name},{name} (cut frame)")
        ax.set_xlabel("frequency (Hz)")
        ax.grid(alpha=0.3, which="both")
    axes[0].set_ylabel("|H| (um/N)")
    axes[0].legend(fontsize=7, ncol=2)
    _finish(fig, path)


def _nominal_run(res: StudyResult, material: str):
    """The basic variant's pass at nominal damping (every study computes it)."""
    run = res.run(material)
    assert run is not None, f"the study has no nominal time-domain run of {material}"
    return run


def plot_time_domain(res: StudyResult, path: Path) -> None:
    """Forces (paper axes) of the basic passes; steel also at its smallest stabilizing damping."""
    plt = pyplot()
    fig, axes = plt.subplots(2, 1, figsize=(9, 6))
    for ax, mat in zip(axes, ("aluminium", "steel")):
        run = _nominal_run(res, mat)
        f = np.asarray(run.series.force_paper_axes_n)
        ax.plot(run.series.t_s, f[:, 1], lw=0.4, label="Fy, nominal damping")
        ax.plot(run.series.t_s, f[:, 0], lw=0.4, label="Fx, nominal damping")
        damped = [r for r in res.time_domain if r.material == mat and r.variant == "basic" and r.damping_scale != 1.0]
        if damped:
            r2 = max(damped, key=lambda r: r.damping_scale)
            ax.plot(r2.series.t_s, np.asarray(r2.series.force_paper_axes_n)[:, 1], lw=0.4, alpha=0.8,
                    label=f"Fy, damping x{r2.damping_scale:g} ({r2.verdict.status})")
        ax.set_title(f"{mat} [basic]: {run.verdict.status}", fontsize=10)
        ax.set_ylabel("force (N, paper axes)")
        ax.legend(fontsize=7, loc="lower left")
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time (s)")
    _finish(fig, path)


def _plot_modes_vs_tooth_passing(ax, res: StudyResult) -> None:
    for v, c in zip(VARIANTS, ("tab:blue", "tab:orange", "tab:green", "tab:red")):
        f = res.mode_set(v, "start").freq_hz
        ax.plot(f, np.full_like(f, VARIANTS.index(v)), "|", ms=14, mew=2, color=c, label=v)
    for mat, col in (("aluminium", "tab:gray"), ("steel", "k")):
        ftp = res.facts[mat].tooth_passing_hz
        for k in range(1, 4):
            ax.axvline(k * ftp, color=col, ls="--" if k > 1 else "-", lw=1,
                       label=f"{mat} tooth passing {ftp:.0f} Hz" if k == 1 else None)
    ax.set_xscale("log")
    ax.set_xlim(5, 3000)
    ax.set_yticks(range(len(VARIANTS)))
    ax.set_yticklabels(VARIANTS)
    ax.set_xlabel("frequency (Hz)")
    ax.set_title("robot modes (start pose) vs tooth-passing frequencies", fontsize=10)
    ax.legend(fontsize=7, loc="lower right")


def _plot_operating_point(ax, res: StudyResult, mat: str) -> None:
    d = res.diagram(mat)
    op = res.operating_point(mat)
    if d is not None:
        mm = d.depth_limit_m * 1e3
        ax.plot(d.spindle_rpm, np.where(np.isfinite(mm), mm, np.nan), "k", lw=1.2, label="SDM limit [basic]")
    stable = op.verdict.status == "stable"
    ax.plot([op.point.spindle_rpm], [op.depth_m * 1e3], "o" if stable else "X",
            color={"stable": "tab:green", "unstable": "tab:red"}.get(op.verdict.status, "tab:gray"), ms=10, mec="k",
            label=f"cut: {op.verdict.status}, limit {op.depth_limit_m * 1e3:.2f} mm")
    ax.set_ylim(0, 10)
    ax.set_xlabel("spindle speed (rpm)")
    ax.set_ylabel("axial depth (mm)")
    ax.set_title(f"{mat}: lobes at the start pose", fontsize=10)
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)


def _plot_engaged_forces(ax, res: StudyResult) -> None:
    for mat, col in (("aluminium", "tab:blue"), ("steel", "tab:red")):
        run = _nominal_run(res, mat)
        r = run.series
        t = np.asarray(r.t_s)
        t0 = r.steady_window_s[0]
        sel = (t >= t0) & (t <= t0 + 0.6)
        ax.plot(t[sel] - t0, np.asarray(r.force_paper_axes_n)[sel, 1], lw=0.5, color=col,
                label=f"{mat}: {run.verdict.status}")
    ax.set_xlabel("time from full engagement (s)")
    ax.set_ylabel("Fy (N, paper axes)")
    ax.set_title("time domain [basic]: normal force", fontsize=10)
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)


def plot_main(res: StudyResult, path: Path) -> None:
    """The main figure: modes vs tooth passing, the two operating points, the two cuts' forces."""
    plt = pyplot()
    fig, axes = plt.subplots(2, 2, figsize=(11, 7.5))
    _plot_modes_vs_tooth_passing(axes[0, 0], res)
    _plot_operating_point(axes[0, 1], res, "aluminium")
    _plot_operating_point(axes[1, 0], res, "steel")
    _plot_engaged_forces(axes[1, 1], res)
    _finish(fig, path)


def write_figures(res: StudyResult, out: Path) -> None:
    """Every figure of the report into the directory ``out``."""
    from robolobes.lobes.plot import plot_lobes
    from robolobes.timedomain.output import plot_wall

    plot_frfs(res, out / "frf.png")
    for d in res.diagrams:
        plot_lobes(d.result, out / d.figure, operating_point=res.operating_point(d.material, d.variant, d.pose).point,
                   title=f"{res.cases[d.material]} [{d.variant}], {d.pose} of the pass")
    plot_time_domain(res, out / "time_domain.png")
    plot_wall(_nominal_run(res, "aluminium").series, out / "wall_aluminium.png")
    plot_wall(_nominal_run(res, "steel").series, out / "wall_steel.png")
    plot_main(res, out / "study.png")
