"""From a hammer test to lobes: FRF reading, the ZOA on the FRF, the modal fit, state-space input.

References are independent of the code under test: FRFs from the closed-form modal sum written
here (and the shipped file's generator, tests/data/make_hammer_uff.py, which uses numpy and pyuff
only); lobes of the generating modal model are the references for the lobes from the file.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from robolobes.main import main
from robolobes.cases.milling import Cut, CuttingLaw, Tool
from robolobes.core.errors import BadInput
from robolobes.linearize.frf_io import read_tool_frf
from robolobes.lobes import (ComplexMode, LobeError, LobeProblem, MeasuredStructure, ModalStructure, Mode,
                             SemiDiscretization, StateSpace, ZeroOrder, fit_modal, solve)

DATA = Path(__file__).parent / "data"
FILE = DATA / "hammer_tooltip.uff"
# the generator's model (tests/data/make_hammer_uff.py): x 922 Hz, y 1100 Hz
GEN_MODES = ((922.0, 0.011, 1.340049648e6, (1.0, 0.0)), (1100.0, 0.02, 2e6, (0.0, 1.0)))
TOOL = Tool(diameter_m=0.020, teeth=2)
LAW = CuttingLaw(ktc_pa=600e6, krc_pa=200e6)
CUT = Cut(ae_m=10e-3, ap_m=1e-3, spindle_rpm=15000.0, mode="up")


def receptance(modes, f_hz):
    """(2, 2, F) m/N: sum d d^T / (k (1 - r^2 + 2 i zeta r))."""
    H = np.zeros((2, 2, len(f_hz)), complex)
    for fn, z, k, d in modes:
        r = f_hz / fn
        H += np.outer(d, d)[:, :, None] / (k * (1 - r**2 + 2j * z * r))[None, None]
    return H


def model_structure():
    return ModalStructure(tuple(Mode(f, z, k, d) for f, z, k, d in GEN_MODES))


def _write_uff(path, sets):
    import pyuff

    out = []
    for (rsp, ref), f, data, ordinate, unit in sets:
        out.append(pyuff.prepare_58(
            binary=0, id1="test", func_type=4, rsp_node=1, rsp_dir=rsp, ref_node=1, ref_dir=ref, ord_data_type=6,
            num_pts=len(f), abscissa_spacing=1, abscissa_min=float(f[0]), abscissa_inc=float(f[1] - f[0]),
            abscissa_spec_data_type=18, ordinate_spec_data_type=ordinate, orddenom_spec_data_type=13,
            ordinate_axis_units_lab=unit, orddenom_axis_units_lab="N",
            data=np.ascontiguousarray(data, dtype=np.complex128), x=f))
    pyuff.UFF(str(path)).write_sets(out, mode="add")


# ----------------------------------------------------------------------------------------------- reading


def test_read_mobility_in_mm_with_signed_directions_and_axes(tmp_path):
    """Mobility in mm/s per N, x measured along -x; the feed along the measured y: H_cut = T H T^T."""
    modes = ((500.0, 0.03, 2e6, (0.6, 0.8)), (800.0, 0.02, 3e6, (0.8, -0.6)))
    f = np.arange(100.0, 1200.0, 2.0)
    H = receptance(modes, f)
    mob = 1j * 2 * math.pi * f * H * 1e3  # mm/s per N
    sets = [((-1, -1), f, mob[0, 0], 11, "mm/s"), ((-1, 2), f, -mob[0, 1], 11, "mm/s"),
            ((2, -1), f, -mob[1, 0], 11, "mm/s"), ((2, 2), f, mob[1, 1], 11, "mm/s")]
    _write_uff(tmp_path / "tip.uff", sets)
    t = read_tool_frf(tmp_path / "tip.uff", "y,-x")
    T = np.array([[0.0, 1.0], [-1.0, 0.0]])
    expect = np.einsum("ai,ijf,bj->abf", T, H, T)
    np.testing.assert_allclose(t.frf.H, expect, rtol=1e-9, atol=1e-12 * np.abs(H).max())
    assert t.cross_measured and t.notes == ()


def test_read_driving_points_only_says_xy_zero_and_directory(tmp_path):
    f = np.arange(100.0, 1200.0, 2.0)
    H = receptance(GEN_MODES, f)
    acc = -(2 * math.pi * f) ** 2 * H
    _write_uff(tmp_path / "xx.uff", [((1, 1), f, acc[0, 0] / 9.80665, 12, "g")])
    _write_uff(tmp_path / "yy.uff", [((2, 2), f, acc[1, 1], 12, "m/s^2")])
    t = read_tool_frf(tmp_path, "x,y")
    assert not t.cross_measured and any("xy = yx = 0" in n for n in t.notes)
    np.testing.assert_allclose(t.frf.H[0, 0], H[0, 0], rtol=1e-9)
    np.testing.assert_allclose(t.frf.H[1, 1], H[1, 1], rtol=1e-9)


@pytest.mark.parametrize("content,expect", [("not a uff\n", "not a UFF file"),
                                            (None, "driving point(s) yy are missing")])
def test_bad_frf_file_one_line_exit_2(tmp_path, capsys, content, expect):
    bad = tmp_path / "bad.uff"
    if content is None:
        f = np.arange(100.0, 1200.0, 2.0)
        _write_uff(bad, [((1, 1), f, receptance(GEN_MODES, f)[0, 0], 8, "m")])
    else:
        bad.write_text(content)
    rc = main(["lobes", "--frf", str(bad), "--frf-axes=x,y", "--teeth", "2", "--diameter-mm", "20", "--ae-mm", "10",
               "--up", "--ktc-mpa", "600", "--krc-mpa", "200", "--method", "zoa", "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and str(bad) in err[0] and expect in err[0]


def test_frf_needs_its_axes_flag():
    with pytest.raises(BadInput, match="FRF axes 'x,x'; valid: FEED,NORMAL"):
        read_tool_frf(FILE, "x,x")


# ----------------------------------------------------------------------------------------------- ZOA on the FRF


def _minima(depth):
    """Indices of the local minima of a lobe curve (finite, below both neighbours)."""
    d = np.asarray(depth)
    i = np.flatnonzero((d[1:-1] < d[:-2]) & (d[1:-1] <= d[2:]) & np.isfinite(d[1:-1])) + 1
    return i


def _problem(structure):
    return LobeProblem(structure, TOOL, CUT, LAW)


def _measured_from_file():
    t = read_tool_frf(FILE, "x,y")
    return MeasuredStructure(t.frf.omega, t.frf.H, cross_measured=t.cross_measured, source=str(FILE))


def test_zoa_from_the_file_matches_the_generating_model_at_the_lobe_minima():
    speeds = np.linspace(5000.0, 25000.0, 401)
    ref = solve(_problem(model_structure()), ZeroOrder(), speeds).depth_limit_m
    got = solve(_problem(_measured_from_file()), ZeroOrder(), speeds).depth_limit_m
    idx = _minima(ref)
    assert len(idx) >= 3
    np.testing.assert_allclose(got[idx], ref[idx], rtol=0.02)


def test_zoa_refuses_an_frf_with_fewer_than_5_lines_per_half_power_bandwidth():
    f = np.arange(200.0, 2500.0, 5.0)  # 922 Hz mode: bandwidth 20.3 Hz = 4 lines
    H = receptance(GEN_MODES, f)
    meas = MeasuredStructure(2 * math.pi * f, H, cross_measured=False, source="coarse.uff")
    with pytest.raises(LobeError, match=r"coarse.uff: the peak at 92\d Hz has 4.* lines per half-power bandwidth"):
        solve(_problem(meas), ZeroOrder(), [10000.0])


def test_sdm_needs_a_model_not_a_bare_frf():
    with pytest.raises(LobeError, match="fit it first"):
        solve(_problem(_measured_from_file()), SemiDiscretization(m=10), [10000.0])


# ----------------------------------------------------------------------------------------------- modal fit


def test_fit_recovers_the_generating_modes():
    fit = fit_modal(_measured_from_file())
    assert fit.credible, fit.problems
    got = sorted((m.freq_hz, m.damping_ratio, float(np.real(m.modal_constants[i, i])))
                 for i, m in zip((0, 1), sorted(fit.modes, key=lambda m: m.freq_hz)))
    for (f, z, c), (fn, zn, k, _) in zip(got, GEN_MODES):
        assert abs(f / fn - 1) < 1e-3 and abs(z / zn - 1) < 0.03 and abs(c / ((2 * math.pi * fn) ** 2 / k) - 1) < 0.03


def test_sdm_from_the_fit_matches_the_generating_model_at_the_lobe_minima():
    speeds = np.linspace(5000.0, 25000.0, 61)
    method = SemiDiscretization(m=20)
    ref = solve(_problem(model_structure()), method, speeds).depth_limit_m
    fit = fit_modal(_measured_from_file())
    got = solve(_problem(fit.structure), method, speeds).depth_limit_m
    idx = _minima(ref)
    assert len(idx) >= 3
    np.testing.assert_allclose(got[idx], ref[idx], rtol=0.02)


def test_fit_of_a_non_physical_frf_is_not_credible():
    """A resonance with a negative driving-point constant (an FRF no passive structure has)."""
    f = np.arange(200.0, 2500.0, 1.0)
    H = receptance(GEN_MODES, f) - receptance(((1600.0, 0.02, 3e6, (1.0, 0.0)),), f)
    fit = fit_modal(MeasuredStructure(2 * math.pi * f, H, cross_measured=False, source="odd"))
    assert not fit.credible
    text = "; ".join(fit.problems)
    assert "negative driving-point modal constant" in text and "1600" in text and "not passive" in text


def test_complex_mode_equals_its_real_mode_and_toml_reads_residues(tmp_path):
    from robolobes.lobes.cli import read_modal_toml

    m = Mode(922.0, 0.011, 1.340049648e6, (0.6, 0.8))
    c = ComplexMode.from_mode(m)
    # R = d d^T / (2 i m w_d): closed form
    wd = 2 * math.pi * 922.0 * math.sqrt(1 - 0.011**2)
    mass = 1.340049648e6 / (2 * math.pi * 922.0) ** 2
    np.testing.assert_allclose(c.residue, np.outer((0.6, 0.8), (0.6, 0.8)) / (2j * mass * wd), rtol=1e-12)
    R = c.residue
    (tmp_path / "c.toml").write_text(
        f"[[modes]]\nfreq_hz = 922.0\ndamping_ratio = 0.011\nresidue_re = {np.real(R).tolist()}\n"
        f"residue_im = {np.imag(R).tolist()}\n")
    st = read_modal_toml(tmp_path / "c.toml")
    f = np.linspace(500.0, 1500.0, 101)
    np.testing.assert_allclose(st.frf(2 * math.pi * f).H[:2, :2], receptance(((922.0, 0.011, 1.340049648e6, (0.6, 0.8)),), f),
                               rtol=1e-9)


# ----------------------------------------------------------------------------------------------- state space in


def test_control_state_space_in_and_feedthrough_refused():
    import control

    ss = model_structure().state_space()
    sys = control.ss(ss.A, ss.B[:, :2], ss.S[:2], np.zeros((2, 2)))
    speeds = [9000.0, 15000.0]
    a = solve(_problem(model_structure()), ZeroOrder(), speeds).depth_limit_m
    # a python-control system is accepted and converted (not in the declared type)
    b = solve(LobeProblem(sys, TOOL, CUT, LAW), ZeroOrder(), speeds).depth_limit_m  # pyright: ignore[reportArgumentType]
    np.testing.assert_allclose(b, a, rtol=1e-9)
    with pytest.raises(LobeError, match="algebraic loop through the chip"):
        StateSpace.from_control(control.ss(ss.A, ss.B[:, :2], ss.S[:2], 1e-9 * np.eye(2)))


# ----------------------------------------------------------------------------------------------- one command


def test_one_command_file_to_lobes_with_fit_figure(tmp_path, capsys):
    png, fitpng = tmp_path / "lobes.png", tmp_path / "fit.png"
    rc = main(["lobes", "--frf", str(FILE), "--frf-axes=x,y", "--teeth", "2", "--diameter-mm", "20", "--ae-mm", "10",
               "--up", "--ktc-mpa", "600", "--krc-mpa", "200", "--method", "zoa", "--rpm-min", "5000",
               "--rpm-max", "25000", "--n-rpm", "41", "--fit-plot", str(fitpng), "--out", str(png), "--json",
               "--quiet"])
    assert rc == 0
    out = json.loads(capsys.readouterr().out)
    assert any("xy = yx = 0" in n for n in out["frf"]["notes"]) and out["frf"]["fit"]["credible"]
    assert png.read_bytes()[:4] == b"\x89PNG" and fitpng.read_bytes()[:4] == b"\x89PNG"


# ----------------------------------------------------------------------------------------------- tool on the robot

TOOL_MODES = ((1500.0, 0.03, 3e7, (1.0, 0.0)), (1500.0, 0.03, 3e7, (0.0, 1.0)))


def test_in_series_adds_the_receptances():
    from robolobes.lobes import PhysicalStructure, in_series

    robot = PhysicalStructure(np.diag([2.0, 3.0]), np.diag([40.0, 30.0]), np.diag([2e6, 5e6]),
                              np.array([[1.0, 0.2], [0.1, 1.0]]))
    tool = ModalStructure(tuple(Mode(f, z, k, d) for f, z, k, d in TOOL_MODES))
    f = np.linspace(50.0, 2500.0, 200)
    w = 2 * math.pi * f
    # robot: tcp (K - w^2 M + i w C)^-1 tcp^T, by hand
    Hr = np.array([robot.tcp[:2] @ np.linalg.solve(robot.K - x**2 * robot.M + 1j * x * robot.C, robot.tcp[:2].T)
                   for x in w]).transpose(1, 2, 0)
    got = in_series(robot.state_space(), tool.state_space()).receptance(w)[:2, :2]
    np.testing.assert_allclose(got, Hr + receptance(TOOL_MODES, f), rtol=1e-8, atol=1e-12 * np.abs(Hr).max())


def test_tool_frf_on_the_robot_matches_the_tool_modes(tmp_path, capsys):
    f = np.arange(300.0, 3000.0, 2.0)  # bandwidth 90 Hz: 45 lines
    H = receptance(TOOL_MODES, f)
    rng = np.random.default_rng(3)
    noisy = H * (1 + 0.005 * (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape)))
    _write_uff(tmp_path / "holder.uff", [((1, 1), f, noisy[0, 0], 8, "m"), ((2, 2), f, noisy[1, 1], 8, "m")])
    (tmp_path / "holder.toml").write_text("".join(
        f"[[modes]]\nfreq_hz = {fn}\ndamping_ratio = {z}\nstiffness_n_per_m = {k}\ndirection = {list(d)}\n"
        for fn, z, k, d in TOOL_MODES))
    common = ["lobes", "--rpm-min", "8000", "--rpm-max", "25000", "--n-rpm", "18", "--json", "--quiet"]
    out = []
    for extra in (["--tool-modes", str(tmp_path / "holder.toml")],
                  ["--tool-frf", str(tmp_path / "holder.uff"), "--tool-frf-axes=x,y"]):
        assert main([*common, *extra]) == 0
        out.append(np.array(json.loads(capsys.readouterr().out)["depth_limit_m"], dtype=float))
    np.testing.assert_allclose(out[1], out[0], rtol=0.02)
