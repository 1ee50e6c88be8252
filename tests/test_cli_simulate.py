"""``robolobes simulate`` end to end: files, JSON summary keys, bad input."""

import json

import numpy as np
import pytest

from robolobes.core.outdir import MARKER
from robolobes.main import main as robolobes_main


def test_simulate_writes_series_plots_and_summary(tmp_path, capsys):
    out = tmp_path / "sim"
    rc = robolobes_main(["simulate", "--duration", "0.3", "--linearized", "--quiet", "--json", "--series", "csv",
                         "--out", str(out)])
    assert rc == 0
    s = json.loads(capsys.readouterr().out)
    # the keys the issue asks for, and the stats per axis
    assert {"stable", "chatter_freq_hz", "force_stats", "roughness_um", "wall_s"} <= set(s)
    assert set(s["force_stats"]) == {"x", "y", "z"}
    assert set(s["force_stats"]["y"]) == {"min", "max", "mean", "rms"}
    assert s["wall_s"] > 0
    names = sorted(p.name for p in out.iterdir())
    assert names == [MARKER, "closeup.png", "forces.png", "series.csv", "summary.json", "wall.csv", "wall.png"]
    # summary.json and the printed JSON record the provenance; the marker lists every file
    on_disk = json.loads((out / "summary.json").read_text())
    assert on_disk["provenance"] == s["provenance"] == json.loads((out / MARKER).read_text())["provenance"]
    assert json.loads((out / MARKER).read_text())["files"] == names[1:]
    data = np.loadtxt(out / "series.csv", delimiter=",", skiprows=1)
    # 2 deg of spindle rotation per step at 18 700 rpm: 0.3 s -> 16 830 steps + the start
    assert data.shape == (16831, 8)
    # the summary's statistics are those of the written series (force on the workpiece, N)
    t, fy = data[:, 0], data[:, 2]
    lo, hi = s["force_stats_window_s"]
    sel = (t >= lo) & (t <= hi)
    assert abs(fy[sel].mean() - s["force_stats"]["y"]["mean"]) < 0.05 * abs(s["force_stats"]["y"]["mean"])


@pytest.mark.parametrize("argv, msg", [
    (["simulate", "--duration", "-1"], "t_end_s must be > 0, got -1"),
    (["simulate", "--damping-scale", "nan"], "--damping-scale must be a finite number >= 0"),
    (["simulate", "--deg-per-step", "20"], "deg_per_step must be in (0, 10]"),
    (["simulate", "--duration", "5"], "past the end of the pass (1.75405 s"),
    (["simulate", "--deg-per-step", "0.0001"], "exceed the 2 GiB limit"),
    (["simulate", "--case", "nope"], "no cut named 'nope'"),
])
def test_simulate_bad_input(tmp_path, capsys, argv, msg):
    rc = robolobes_main(argv + ["--quiet", "--out", str(tmp_path / "o")])
    assert rc == 2
    err = capsys.readouterr().err
    assert msg in err and err.count("\n") == 1
    assert not (tmp_path / "o").exists()
