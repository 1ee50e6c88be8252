"""Lobe diagram figure (matplotlib, Agg): limit depth over speed, chatter frequency below."""

from __future__ import annotations

import os

import numpy as np

from robolobes.core.io import pyplot, save_figure

__all__ = ["plot_lobes"]


def plot_lobes(result, path: str | os.PathLike, operating_point=None, title: str | None = None,
               provenance: dict | None = None) -> None:
    """Write a PNG of a :class:`lobes.LobeResult`.

    Parameters
    ----------
    result : LobeResult
    path : str or PathLike
        Output file (PNG; written atomically, no partial file on error or interrupt).
    operating_point : StabilityPoint, optional
        Marked on the diagram (green circle if stable, red cross if unstable, orange cross if undetermined).
    title : str, optional
    provenance : dict, optional
        ``core.io.provenance(inputs)``, recorded in the PNG's metadata.
    """
    plt = pyplot()

    rpm = np.asarray(result.spindle_rpm)
    d_mm = np.asarray(result.depth_limit_m) * 1e3
    dmax_mm = result.stats.get("depth_max_m", np.nanmax(d_mm[np.isfinite(d_mm)], initial=1e-3) / 1e3) * 1e3
    shown = np.where(np.isfinite(d_mm), d_mm, np.nan)
    fig, (ax, axf) = plt.subplots(2, 1, sharex=True, figsize=(8, 6.5), gridspec_kw={"height_ratios": [2.2, 1]})
    ax.fill_between(rpm, np.where(np.isfinite(d_mm), d_mm, dmax_mm), dmax_mm, color="tab:red", alpha=0.15,
                    label="unstable")
    ax.plot(rpm, shown, color="k", lw=1.2, label=f"limit ({result.method.name})")
    _error_band(ax, result, rpm, d_mm, dmax_mm)
    bif = np.asarray(result.bifurcation)
    for kind, mk, col in (("flip", "v", "tab:purple"), ("fold", "s", "tab:green")):
        sel = bif == kind
        if sel.any():
            ax.plot(rpm[sel], d_mm[sel], mk, ms=3, color=col, label=f"{kind} limit", ls="none")
    if operating_point is not None:
        op = operating_point
        col = {"stable": "tab:green", "unstable": "tab:red"}.get(op.verdict.status, "tab:orange")
        mk = "o" if op.verdict.status == "stable" else "X"
        ax.plot([op.spindle_rpm], [op.depth_m * 1e3], mk, color=col, ms=9, mec="k",
                label=f"operating point: {op.verdict.status} (margin {op.margin:+.2f})")
    ax.set_ylim(0, dmax_mm)
    ax.set_ylabel("axial depth limit (mm)")
    ax.legend(loc="upper right", fontsize=8)
    ax.grid(alpha=0.3)
    if title:
        ax.set_title(title, fontsize=10)
    axf.plot(rpm, np.asarray(result.chatter_freq_hz), ".", ms=3, color="tab:blue")
    if operating_point is not None and np.isfinite(operating_point.chatter_freq_hz):
        axf.plot([operating_point.spindle_rpm], [operating_point.chatter_freq_hz], "o", color="tab:orange", mec="k")
    axf.set_ylabel("chatter freq. (Hz)")
    axf.set_xlabel("spindle speed (rpm)")
    axf.grid(alpha=0.3)
    fig.tight_layout()

    try:
        save_figure(fig, path, provenance=provenance, dpi=110)  # atomic: temp file + os.replace
    finally:
        plt.close(fig)


def _error_band(ax, result, rpm: np.ndarray, d_mm: np.ndarray, dmax_mm: float) -> None:
    """Shade ``limit +- depth_error_m`` (grey) and mark the unconverged speeds (orange ticks)."""
    err_mm = np.asarray(result.depth_error_m) * 1e3
    ok = np.isfinite(d_mm) & np.isfinite(err_mm)
    if ok.any():
        lo = np.where(ok, np.clip(d_mm - err_mm, 0, dmax_mm), np.nan)
        hi = np.where(ok, np.clip(d_mm + err_mm, 0, dmax_mm), np.nan)
        ax.fill_between(rpm, lo, hi, color="0.45", alpha=0.35, lw=0, label="error estimate")
    status = np.asarray(getattr(result, "status", np.full(len(rpm), "no-estimate")))
    bad = status == "unconverged"
    if bad.any():
        y = np.where(np.isfinite(d_mm[bad]), d_mm[bad], dmax_mm)
        ax.plot(rpm[bad], y, "|", ms=10, mew=1.5, color="tab:orange", ls="none",
                label=f"unconverged ({int(bad.sum())} speeds)")
