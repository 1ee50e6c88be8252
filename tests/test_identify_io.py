"""Reading measured FRF sets (linearize/frf_io.read_frf_set) and recognising measurement kinds."""

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from robolobes.core.errors import BadInput
from robolobes.identify.api import measurement_kind
from robolobes.identify.synthetic import write_uff_pairs
from robolobes.linearize.frf_io import read_frf_set
from robolobes.main import main

F = np.linspace(0.0, 50.0, 51)           # includes 0 Hz
W = 2 * math.pi * F


def _h(f0=20.0, zeta=0.05, k=1e6):
    """A single-DOF receptance (m/N), the closed form the files are made from."""
    w0 = 2 * math.pi * f0
    return 1 / (k * (1 - (W / w0) ** 2 + 2j * zeta * W / w0))


def _poses(d, names=("a", "b")):
    d.mkdir(parents=True, exist_ok=True)
    (d / "poses.csv").write_text("pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n" +
                                 "".join(f"{n},0,10,20,0,30,0\n" for n in names))


@pytest.mark.parametrize("ordinate,units,scale", [(8, "m", 1.0), (8, "mm", 1.0), (11, "m/s", 1.0), (11, "mm/s", 1.0),
                                                  (12, "m/s^2", 1.0), (12, "g", 1.0)])
def test_uff_ordinates_and_units_convert_to_receptance(tmp_path, ordinate, units, scale):
    # the writer (pyuff, identify/synthetic.py) multiplies by i w or -w^2 and the unit; the reader
    # must give back the receptance to round-off (UFF ascii keeps ~12 digits: rtol 1e-9)
    d = tmp_path / "set"
    _poses(d)
    h = _h()
    write_uff_pairs(d / "a.uff", "a", F, [(0, 0), (1, 0)], np.array([h, 0.5 * h]), ordinate=ordinate, units=units)
    s = read_frf_set(d)
    (pose,) = s.poses
    assert pose.pose == "a" and pose.frame == "base"
    p0, p1 = pose.pairs
    keep = F > 0 if ordinate != 8 else np.ones(len(F), bool)    # 0 Hz cannot be converted from 11/12
    assert_allclose(p0.omega, W[keep], rtol=1e-9)
    assert_allclose(p0.H, h[keep], rtol=1e-6)
    assert (p1.out_axis, p1.in_axis) == (1, 0)
    assert_allclose(p1.H, 0.5 * h[keep], rtol=1e-6)


def test_signed_directions_cut_frame_and_pose_from_id1(tmp_path):
    import pyuff
    d = tmp_path / "set"
    _poses(d)
    h = _h()
    sets = [pyuff.prepare_58(binary=0, id1="pose b (hammer)", id2="frame cut", func_type=4, rsp_node=1, rsp_dir=-2,
                             ref_node=1, ref_dir=3, ord_data_type=6, num_pts=len(F), abscissa_spacing=1,
                             abscissa_min=0.0, abscissa_inc=1.0, abscissa_spec_data_type=18,
                             ordinate_spec_data_type=8, orddenom_spec_data_type=13, data=h.astype(complex), x=F)]
    pyuff.UFF(str(d / "all.uff")).write_sets(sets, mode="add")
    s = read_frf_set(d)
    (pose,) = s.poses
    assert pose.pose == "b" and pose.frame == "cut"
    p = pose.pairs[0]
    assert (p.out_axis, p.out_sign, p.in_axis, p.in_sign) == (1, -1, 2, 1)
    assert_allclose(pose.theta, np.radians([0, 10, 20, 0, 30, 0]))


def test_csv_subset_and_per_pose_axes(tmp_path):
    d = tmp_path / "set"
    _poses(d)
    h = _h()
    rows = np.column_stack([F, h.real, h.imag])
    np.savetxt(d / "a.csv", rows, delimiter=",", comments="",
               header="# tool-tip receptance (m/N), frame base\nfreq_hz,H_z_-x_re_m_per_n,H_z_-x_im_m_per_n")
    write_uff_pairs(d / "b.uff", "b", F[:30] * 2, [(0, 0)], np.array([h[:30]]))
    s = read_frf_set(d)
    a, b = s.poses
    assert (a.pairs[0].out_axis, a.pairs[0].in_axis, a.pairs[0].in_sign) == (2, 0, -1)
    assert len(a.pairs[0].omega) == 51 and len(b.pairs[0].omega) == 30


def _bad(tmp_path, capsys, make, match):
    d = tmp_path / "bad"
    _poses(d)
    make(d)
    rc = main(["identify", "--measured", str(d), "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and match in err[0], err
    return err[0]


def test_bad_measurement_files_one_line_exit_2(tmp_path, capsys):
    h = _h()
    def nan(d):
        # pyuff writes NaN as 0: put a NaN into the file's text, as another program might
        write_uff_pairs(d / "a.uff", "a", F, [(0, 0)], np.array([h]))
        lines = (d / "a.uff").read_text().split("\n")
        i = next(k for k, line in enumerate(lines) if line.startswith("   ") and "e" in line and k > 10)
        lines[i] = "nan".rjust(20) + lines[i][20:]
        (d / "a.uff").write_text("\n".join(lines))
    _bad(tmp_path / "1", capsys, nan, "NaN")
    def unknown_pose(d):
        write_uff_pairs(d / "zz.uff", "zz", F, [(0, 0)], np.array([h]))
    _bad(tmp_path / "2", capsys, unknown_pose, "'zz' is not in")
    def decreasing(d):
        rows = np.column_stack([F[::-1], h.real, h.imag])
        np.savetxt(d / "a.csv", rows, delimiter=",", comments="",
                   header="# frame base\nfreq_hz,H_x_x_re_m_per_n,H_x_x_im_m_per_n")
    _bad(tmp_path / "3", capsys, decreasing, "increasing")
    for k, (over, match) in enumerate([({"ordinate_spec_data_type": 9}, "ordinate_spec_data_type = 9"),
                                       ({"rsp_dir": 4}, "rsp_dir = 4"),
                                       ({"ordinate_spec_data_type": 12, "ordinate_axis_units_lab": "furlong"},
                                        "unit 'furlong'")]):
        _bad(tmp_path / f"uff{k}", capsys, lambda d: _uff_with(d, h, **over), match)


def _uff_with(d, h, **over):
    """One UFF58 dataset for pose a, with some fields overridden (written by pyuff directly)."""
    import pyuff
    fields = dict(binary=0, id1="pose a", func_type=4, rsp_node=1, rsp_dir=1, ref_node=1, ref_dir=1, ord_data_type=6,
                  num_pts=len(F), abscissa_spacing=1, abscissa_min=0.0, abscissa_inc=1.0, abscissa_spec_data_type=18,
                  ordinate_spec_data_type=8, orddenom_spec_data_type=13, data=h.astype(complex), x=F)
    pyuff.UFF(str(d / "a.uff")).write_sets([pyuff.prepare_58(**{**fields, **over})], mode="add")


def test_measurement_kind_recognised_from_files(tmp_path):
    d = tmp_path / "frf"
    _poses(d)
    assert measurement_kind(d) == ("frf", d)
    assert measurement_kind(d / "poses.csv") == ("frf", d)
    (tmp_path / "st").mkdir()
    (tmp_path / "st" / "force_stats.toml").write_text("case = 'tx200-aluminium'\n")
    assert measurement_kind(tmp_path / "st")[0] == "force_stats"
    with pytest.raises(BadInput, match="no measurement set"):
        measurement_kind(tmp_path)
    with pytest.raises(BadInput, match="no such file"):
        measurement_kind(tmp_path / "nothing")


def test_case_in_the_files_and_the_override_note(tmp_path):
    from robolobes.identify.api import model_state
    d = tmp_path / "set"
    d.mkdir()
    (d / "poses.csv").write_text("pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,case\na,0,10,20,0,30,0,tx200-steel\n")
    write_uff_pairs(d / "a.uff", "a", F, [(0, 0)], np.array([_h()]))
    m = read_frf_set(d)
    assert m.case == "tx200-steel"
    state, notes = model_state(m)
    assert state.case.name == "tx200-steel" and notes == []
    state, notes = model_state(m, case="tx200-aluminium")
    assert state.case.name == "tx200-aluminium" and "overrides" in notes[0]
    with pytest.raises(BadInput, match="variant"):
        model_state(m, variant="stiff")
