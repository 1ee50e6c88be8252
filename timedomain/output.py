"""Write a simulation's results: series, wall, JSON summary and plots, atomically, into one directory.

Files (in ``out_dir``):

* ``series.npz`` or ``series.csv``: ``t_s``; ``fx_n, fy_n, fz_n`` force on the workpiece
  (dynamometer = cut frame: x along the feed, y normal, z up); ``dev_x_m, dev_y_m, dev_z_m`` TCP
  deviation from the commanded path (cut frame); ``spindle_angle_rad``;
* ``wall.csv``: ``x_m`` and the wall ``y_m`` of each slice (cut frame), at most 20000 points (the
  roughness in the summary is computed on the full 1 um grid);
* ``summary.json``: :meth:`SimulationSummary.to_json` (every field, ``None`` with a reason when
  not computable; ``provenance``) plus the case, the frames and the run statistics;
* ``forces.png`` (the whole pass), ``closeup.png`` (three spindle revolutions in the steady cut),
  ``wall.png`` (the machined lateral wall).

Everything is first written to a temporary directory beside ``out_dir`` and moved into place file
by file only when all of it exists: an interruption leaves no partial file in ``out_dir``. When
``out_dir`` holds the outputs of an earlier run (its ``summary.json`` was written by robolobes),
the earlier run's output files that this run does not write (e.g. ``series.csv`` when this run
writes ``series.npz``) are removed, so the directory never mixes two runs. Other files are never
touched.
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path
from typing import Any, Literal

import numpy as np

from robolobes.core.io import pyplot, save_figure, to_jsonable, write_json
from .result import SimulationResult

__all__ = ["save_result", "summary_dict", "plot_forces", "plot_closeup", "plot_wall", "OUTPUT_FILES"]

#: Every file name :func:`save_result` may write.
OUTPUT_FILES = ("series.npz", "series.csv", "wall.csv", "summary.json", "forces.png", "closeup.png", "wall.png")


def summary_dict(result: SimulationResult) -> dict:
    """JSON-ready summary: case, model, derived numbers, run statistics."""
    out: dict[str, Any] = {"case": result.problem.case.name,
           "force_frame": "workpiece (dynamometer) = cut frame: x feed, y normal, z up; force on the workpiece",
           "paper_axes_note": "force_stats_paper_axes: (Fx, Fy) as the paper's Tab. 10, Fx = -F_workpiece.x, "
                              "Fy = +F_workpiece.y (timedomain.workpiece_force)"}
    assert result.summary is not None  # simulate() always sets the summary
    out.update(result.summary.to_json())
    out["run"] = dict(result.stats)
    return to_jsonable(out)


def _is_earlier_run(out: Path) -> bool:
    """Whether ``out`` holds a summary.json written by robolobes simulate."""
    import json

    try:
        s = json.loads((out / "summary.json").read_text())
    except (OSError, ValueError):
        return False
    return isinstance(s, dict) and "force_frame" in s and ("provenance" in s or "run" in s)


def plot_forces(result: SimulationResult, path) -> None:
    """Fx, Fy (paper axes) over the whole run, with the steady window shaded."""
    plt = pyplot()
    t = np.asarray(result.t_s)
    f = np.asarray(result.force_paper_axes_n)
    fig, ax = plt.subplots(figsize=(8, 3.6))
    ax.plot(t, f[:, 0], lw=0.5, label="Fx (feed)")
    ax.plot(t, f[:, 1], lw=0.5, label="Fy (normal, paper sign)")
    ax.axvspan(*result.steady_window_s, color="0.9", zorder=0, label="steady cut")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("cutting force (N)")
    p, s = result.problem, result.summary
    assert s is not None  # simulate() always sets the summary
    st = s.stable
    damping = f", x{s.damping_scale:g} damping" if s.damping_scale not in (None, 1.0) else ""
    ax.set_title(f"{p.case.name} [{s.variant}{damping}]"
                 f" - {'stable' if st else 'unstable' if st is False else 'no verdict'}")
    ax.legend(fontsize=8, loc="lower right")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    save_figure(fig, path, dpi=120)
    plt.close(fig)


def plot_closeup(result: SimulationResult, path) -> None:
    """Three spindle revolutions in the middle of the steady cut."""
    plt = pyplot()
    t = np.asarray(result.t_s)
    T = result.problem.case.cut.spindle_period_s
    t0, t1 = result.steady_window_s
    tm = 0.5 * (t0 + min(t1, t[-1]))
    sel = (t >= tm) & (t <= tm + 3 * T)
    f = np.asarray(result.force_paper_axes_n)[sel]
    fig, ax = plt.subplots(figsize=(8, 3.4))
    ax.plot((t[sel] - tm) * 1e3, f[:, 0], label="Fx")
    ax.plot((t[sel] - tm) * 1e3, f[:, 1], label="Fy (paper sign)")
    ax.set_xlabel(f"time from {tm:.3f} s (ms)")
    ax.set_ylabel("cutting force (N)")
    ax.set_title("three spindle revolutions")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    save_figure(fig, path, dpi=120)
    plt.close(fig)


def plot_wall(result: SimulationResult, path) -> None:
    """The machined lateral wall (middle slice): deviation from the nominal wall y = -R (down) / +R (up)."""
    plt = pyplot()
    case = result.problem.case
    R = case.tool.radius_m
    nominal = -R if case.cut.mode == "down" else R
    y = np.asarray(result.wall_y_m)
    k = y.shape[0] // 2
    x = np.asarray(result.wall_x_m)
    done = y[k] != y[k][-1] if y.shape[1] else np.zeros(0, bool)
    fig, ax = plt.subplots(figsize=(8, 3.2))
    ax.plot(x[done] * 1e3, (y[k][done] - nominal) * 1e6, lw=0.6)
    ax.set_xlabel("x along the feed (mm)")
    ax.set_ylabel("wall - nominal (um)")
    assert result.summary is not None  # simulate() always sets the summary
    r = result.summary.roughness_um
    ax.set_title("machined lateral wall" + (f": Ra {r['Ra']:.2f} um, Rq {r['Rq']:.2f} um, Rt {r['Rt']:.2f} um"
                                            if r else ""))
    ax.grid(alpha=0.3)
    fig.tight_layout()
    save_figure(fig, path, dpi=120)
    plt.close(fig)


def save_result(result: SimulationResult, out_dir, series: Literal["npz", "csv"] = "npz") -> list[Path]:
    """Write all outputs into ``out_dir`` (created if missing); returns the written paths."""
    out = Path(out_dir)
    out.parent.mkdir(parents=True, exist_ok=True) if str(out.parent) else None
    out.mkdir(parents=True, exist_ok=True)
    earlier = _is_earlier_run(out)
    tmp = Path(tempfile.mkdtemp(prefix=".robolobes-", dir=out))
    try:
        t = np.asarray(result.t_s)
        f = np.asarray(result.force_workpiece_n)
        d = np.asarray(result.tcp_deviation_m)
        cols: dict[str, Any] = {"t_s": t, "fx_n": f[:, 0], "fy_n": f[:, 1], "fz_n": f[:, 2], "dev_x_m": d[:, 0],
                "dev_y_m": d[:, 1], "dev_z_m": d[:, 2], "spindle_angle_rad": np.asarray(result.spindle_angle_rad)}
        if series == "npz":
            np.savez_compressed(tmp / "series.npz", **cols)
        elif series == "csv":
            np.savetxt(tmp / "series.csv", np.column_stack(list(cols.values())), delimiter=",",
                       header=",".join(cols), comments="", fmt="%.10e")
        else:
            raise ValueError(f"series format must be 'npz' or 'csv', got {series!r}")
        wy = np.asarray(result.wall_y_m)
        stride = max(1, int(np.ceil(wy.shape[1] / 20000)))  # the wall at <= 20000 points (5 um for 90 mm)
        np.savetxt(tmp / "wall.csv", np.column_stack([result.wall_x_m[::stride], wy[:, ::stride].T]), delimiter=",",
                   fmt="%.10e", header="x_m," + ",".join(f"y_slice{k}_m" for k in range(wy.shape[0])), comments="")
        write_json(tmp / "summary.json", summary_dict(result))
        plot_forces(result, tmp / "forces.png")
        plot_closeup(result, tmp / "closeup.png")
        plot_wall(result, tmp / "wall.png")
        written = []
        for f in sorted(tmp.iterdir()):
            dest = out / f.name
            f.replace(dest)
            written.append(dest)
        if earlier:
            for name in set(OUTPUT_FILES) - {w.name for w in written}:
                (out / name).unlink(missing_ok=True)
        return written
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
