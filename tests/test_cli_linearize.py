"""``robolobes modes`` and ``robolobes frf`` end to end (through the dispatcher)."""

import json
import math
import shutil
import subprocess
import sys

import numpy as np
import pytest
from numpy.testing import assert_allclose

from robolobes import cases
import robolobes.linearize as L
from robolobes.main import main as robolobes_main
from robolobes.linearize.frf_io import read_frf


def run(capsys, *argv):
    rc = robolobes_main(list(argv))
    out = capsys.readouterr()
    return rc, out.out, out.err


def test_modes_json_defaults_match_python_api(capsys, tx200_spec, tx200_robot):
    rc, out, err = run(capsys, "modes", "--json")
    assert rc == 0
    d = json.loads(out)
    spec = tx200_spec
    lin = L.linearize(tx200_robot("basic"), spec.pose("tab7"))
    # same computation through two entry points: equal to round-off
    assert_allclose(d["freq_hz"], lin.modes().freq_hz, rtol=1e-12)
    assert_allclose(d["tcp_static_stiffness_n_per_m"], lin.stiffness(), rtol=1e-10)
    assert_allclose(d["q_deg"], [-11.71, 20.78, -212.14, 82.76, 60.80, -166.96], atol=1e-12)
    assert_allclose(d["tcp_position_m"], [0.794, 0.185, 0.316], atol=1e-3)
    assert_allclose(d["tool_axis"], [0, 0, -1], atol=5.2e-4)  # rounding of Tab. 7 (test_linearize)
    assert {"damping_ratio", "modal_stiffness_n_per_m", "variant"} <= set(d)
    assert d["variant"] == "basic" and d["n_dof"] == 6


def test_modes_table_and_variants(capsys):
    rc, out, _ = run(capsys, "modes", "--variant", "backlash", "--case", "tx200-steel")
    assert rc == 0
    assert "18 DOF" in out and "linearized with the gears engaged" in out
    rc, out, _ = run(capsys, "modes", "--path-s", "0.05", "--json")
    d = json.loads(out)
    case = cases.load_case("tx200-aluminium")
    assert_allclose(d["tcp_position_m"][0] - 0.05, L.fk(case.robot, case.path.start_q_rad)[0][0], atol=1e-9)


@pytest.mark.parametrize("argv, msg", [
    (["modes", "--q-deg", "1,2,3"], "--q-deg must be 6 finite comma-separated numbers"),
    (["modes", "--q-deg", "0,0,200,0,0,0"], "A3"),
    (["modes", "--pose", "home"], "has no pose 'home'"),
    (["modes", "--case", "nope"], "no cut named 'nope'"),
    (["modes", "--path-s", "5"], "s = 5 m is outside the pass [0, 0.102] m"),
    (["frf", "--out", "x.txt"], "the extension must be one of .csv, .uff, .unv"),
    (["frf", "--out", "x.csv", "--fmin-hz", "10", "--fmax-hz", "5"], "fmin"),
])
def test_cli_bad_input_is_one_clear_line(capsys, tmp_path, monkeypatch, argv, msg):
    monkeypatch.chdir(tmp_path)
    rc, out, err = run(capsys, *argv)
    assert rc == 2
    assert msg in err and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []  # nothing written


@pytest.mark.parametrize("ext", ["csv", "uff"])
def test_frf_file_and_plot(capsys, tmp_path, ext, tx200_spec, tx200_robot):
    out = tmp_path / f"tcp.{ext}"
    rc, txt, err = run(capsys, "frf", "--variant", "orthogonal", "--fmin-hz", "1", "--fmax-hz", "200",
                       "--n", "200", "--out", str(out))
    assert rc == 0, err
    assert out.exists() and out.with_suffix(".png").stat().st_size > 10000
    frf = read_frf(out)
    lin = L.linearize(tx200_robot("orthogonal"), tx200_spec.pose("tab7"))
    ref = lin.frf(frf.omega).H
    # CSV keeps 13 significant digits; UFF58 stores frequencies (min, increment) with 6 significant
    # digits (format E13.5), which moves the sampled frequencies by < 1e-5 relative
    assert_allclose(frf.freq_hz, np.linspace(1, 200, 200), rtol=1e-5 if ext == "uff" else 1e-12)
    assert_allclose(frf.H, lin.frf(2 * math.pi * np.linspace(1, 200, 200)).H, rtol=1e-9, atol=1e-12 * np.abs(ref).max())


def test_console_script_installed():
    exe = shutil.which("robolobes") or str(sys.prefix) + "/bin/robolobes"
    p = subprocess.run([exe, "modes", "--help"], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0 and "--variant" in p.stdout
