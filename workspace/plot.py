"""Figures of a lobe map: heatmap with the operating point, poses coloured by margin, the robot at
its best and worst poses. Every figure is saved atomically (:func:`robolobes.core.io.save_figure`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from robolobes.core.io import pyplot, save_figure
from robolobes.linearize.kinematics import fk_frames

__all__ = ["plot_map"]


def _margin(ds, ap_m: float) -> np.ndarray:
    """``op_depth_limit / ap - 1`` per pose (> 0 stable at the operating point); +inf: no limit."""
    return np.asarray(ds["op_depth_limit_m"].values) / ap_m - 1.0


def _heatmap(result, path: Path, ap_m: float) -> None:
    plt = pyplot()
    ds, pr = result.dataset, result.problem
    depth_mm = np.asarray(ds["depth_limit_m"].values) * 1e3
    dmax_mm = result.method.depth_max_m * 1e3
    shown = np.where(np.isinf(depth_mm), dmax_mm, depth_mm)
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8))
    ax = axes[0]
    names = [n for n, v in pr.axes if len(v) > 1]
    if pr.over == "placement" and {"x_offset_m", "y_offset_m"} <= set(names):
        # op-speed limit over the x, y grid (first z / yaw value), the paper's placement at (0, 0)
        vals = pr.pose_values()
        first = np.ones(pr.n_poses, bool)
        for n in ("z_offset_m", "yaw_rad"):
            first &= vals[n] == vals[n][0]
        op = np.asarray(ds["op_depth_limit_m"].values)[first] * 1e3
        op = np.where(np.isinf(op), dmax_mm, op)
        x, y = vals["x_offset_m"][first] * 1e3, vals["y_offset_m"][first] * 1e3
        sc = ax.scatter(x, y, c=op, cmap="viridis", marker="s", s=40, vmin=0, vmax=dmax_mm)
        bad = ~np.asarray(ds["reachable"].values)[first]
        ax.scatter(x[bad], y[bad], c="lightgrey", marker="s", s=40, label="unreachable / past limits")
        ax.plot([0], [0], "r*", ms=14, label="paper's placement")
        ax.set_xlabel("pass start offset x, mm")
        ax.set_ylabel("pass start offset y, mm")
        fig.colorbar(sc, ax=ax, label=f"critical depth at {pr.op_rpm:.0f} rpm, mm ({dmax_mm:g} = none below)")
        ax.legend(loc="best", fontsize=8)
    else:
        if len(names) == 1:  # the swept value on the x axis, in deg or mm
            name = names[0]
            x = pr.pose_values()[name]
            x, label = (np.degrees(x), name[:-4] + ", deg") if name.endswith("_rad") else (x * 1e3, name[:-2] + ", mm")
        else:
            x, label = np.arange(pr.n_poses, dtype=float), f"pose ({', '.join(names) or 'single pose'})"
        ax.set_facecolor("lightgrey")  # unreachable poses (NaN) show the background
        im = ax.pcolormesh(x, pr.speeds_rpm, np.ma.masked_invalid(shown.T), cmap="viridis", vmin=0, vmax=dmax_mm,
                           shading="nearest")
        ax.axhline(pr.op_rpm, color="r", lw=1, label=f"operating speed {pr.op_rpm:.0f} rpm")
        ax.set_xlabel(label)
        ax.set_ylabel("spindle speed, rpm")
        fig.colorbar(im, ax=ax, label=f"critical depth, mm ({dmax_mm:g} = none below; grey: unreachable)")
        ax.legend(loc="upper right", fontsize=8)
    ax.set_title(f"{pr.case.name}, {pr.variant}: over {pr.over}")
    ax = axes[1]
    reach = np.asarray(ds["reachable"].values)
    worst = np.where(reach[:, None], shown, np.nan)
    ax.plot(pr.speeds_rpm, np.nanmin(worst, axis=0), "b-", label="lowest over the poses")
    ax.plot(pr.speeds_rpm, np.nanmax(worst, axis=0), "g-", label="highest over the poses")
    ax.plot([pr.op_rpm], [ap_m * 1e3], "r*", ms=12, label="operating point")
    ax.set_xlabel("spindle speed, rpm")
    ax.set_ylabel("critical depth, mm")
    ax.set_ylim(0, dmax_mm * 1.05)
    ax.legend(fontsize=8)
    ax.set_title("envelope of the lobes over the map")
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)


def _margin_positions(result, path: Path, ap_m: float) -> None:
    plt = pyplot()
    ds = result.dataset
    p = np.asarray(ds["tcp_position_m"].values) * 1e3
    m = _margin(ds, ap_m)
    reach = np.asarray(ds["reachable"].values)
    fig, ax = plt.subplots(figsize=(6.5, 5))
    shown = np.clip(np.where(np.isinf(m), 5.0, m), -1, 5)
    sc = ax.scatter(p[reach, 0], p[reach, 1], c=shown[reach], cmap="RdYlGn", vmin=-1, vmax=1, s=25)
    ax.scatter(p[~reach, 0], p[~reach, 1], c="lightgrey", s=25, label="unreachable / past limits")
    fig.colorbar(sc, ax=ax, label=f"margin at the operating point (limit / {ap_m * 1e3:g} mm - 1)")
    ax.set_xlabel("TCP x (base), mm")
    ax.set_ylabel("TCP y (base), mm")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_title(f"poses coloured by margin at {result.problem.op_rpm:.0f} rpm")
    if (~reach).any():
        ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)


def _robots(result, path: Path, best: int, worst: int) -> None:
    plt = pyplot()
    spec = result.problem.case.robot
    theta = np.asarray(result.dataset["theta_rad"].values)
    depth = np.asarray(result.dataset["depth_limit_m"].values)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.8))
    for ax, (u, v, lab) in zip(axes, ((0, 2, "x-z"), (0, 1, "x-y"))):
        for i, colour, name in ((best, "g", "best"), (worst, "r", "worst")):
            pts, _ = fk_frames(spec, theta[i])
            pts = np.vstack([[0.0, 0.0, 0.0], pts]) * 1e3
            lim = np.nanmin(depth[i]) * 1e3
            ax.plot(pts[:, u], pts[:, v], "o-", color=colour, lw=3,
                    label=f"{name} pose {i}: lowest limit {lim:.3g} mm")
        ax.set_xlabel(f"{'xyz'[u]}, mm")
        ax.set_ylabel(f"{'xyz'[v]}, mm")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(f"robot at the best and worst poses ({lab})")
        ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)


def plot_map(result, out_dir: Path) -> list[str]:
    """Write ``map_heatmap.png``, ``map_margin.png`` and ``map_robot.png`` into ``out_dir``;
    returns the file names written."""
    out_dir = Path(out_dir)
    ap = result.problem.case.cut.ap_m
    _heatmap(result, out_dir / "map_heatmap.png", ap)
    _margin_positions(result, out_dir / "map_margin.png", ap)
    names = ["map_heatmap.png", "map_margin.png"]
    s = result.summary()
    if s["best_pose"] is not None:
        _robots(result, out_dir / "map_robot.png", s["best_pose"], s["worst_pose"])
        names.append("map_robot.png")
    return names
