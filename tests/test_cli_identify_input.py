"""``robolobes identify`` refuses what it cannot read in full or what is physically implausible.

Every case runs the command line (``robolobes.main.main``) and expects one line on stderr and exit
code 2, before any work. The measurement files are written here directly with pyuff / plain text
(not with the reader under test), from a closed-form single-DOF receptance.
"""

import math
import os
import re
from typing import Any

import numpy as np
import pytest

from robolobes.main import main

F = np.linspace(1.0, 50.0, 50)
W = 2 * math.pi * F
HEADER = "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg"
GOOD_Q = "0,10,20,0,30,0"


def _h(f0=20.0, zeta=0.05, k=1e6):
    w0 = 2 * math.pi * f0
    return 1 / (k * (1 - (W / w0) ** 2 + 2j * zeta * W / w0))


def _uff(path, pose_label, pairs=((1, 1), (2, 2)), h=None, **over):
    """UFF58 datasets written by pyuff itself: one per (rsp_dir, ref_dir)."""
    import pyuff
    h = _h() if h is None else h
    sets = []
    for o, i in pairs:
        # pyuff's keywords take values of several types (str, int, float, arrays)
        fields: dict[str, Any] = dict(
            binary=0, id1=f"pose {pose_label}", id2="frame base", func_type=4, rsp_node=1, rsp_dir=o,
            ref_node=1, ref_dir=i, ord_data_type=6, num_pts=len(F), abscissa_spacing=1,
            abscissa_min=float(F[0]), abscissa_inc=float(F[1] - F[0]), abscissa_spec_data_type=18,
            ordinate_spec_data_type=8, orddenom_spec_data_type=13, ordinate_axis_units_lab="m",
            orddenom_axis_units_lab="N", data=np.asarray(h, dtype=np.complex128), x=F)
        fields.update(over)
        sets.append(pyuff.prepare_58(**fields))
    pyuff.UFF(str(path)).write_sets(sets, mode="add")


def _set(d, names=("p1", "p2", "p3"), rows=None, header=HEADER, bom=False):
    d.mkdir(parents=True)
    rows = rows or {n: GOOD_Q for n in names}
    text = header + "\n" + "".join(f"{n},{q}\n" for n, q in rows.items())
    (d / "poses.csv").write_bytes((b"\xef\xbb\xbf" if bom else b"") + text.encode())
    for n in rows:
        _uff(d / f"{n}.uff", n)
    return d


def _refused(capsys, d, match, *extra):
    rc = main(["identify", "--measured", str(d), "--quiet", "--no-poles", *extra])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and match in err[0], (rc, err)
    assert "Traceback" not in err[0]
    return err[0]


def _damage(kind: str, path):
    text = path.read_text()
    if kind == "empty":
        path.write_text("")
    elif kind == "binary":
        path.write_bytes(bytes(range(256)) * 20)
    elif kind == "utf16":
        path.write_bytes(text.encode("utf-16"))
    elif kind == "truncated":
        lines = text.splitlines(keepends=True)
        path.write_text("".join(lines[: int(len(lines) * 0.8)]))
    elif kind == "dataset151":
        import pyuff
        path.unlink()
        pyuff.UFF(str(path)).write_sets([pyuff.prepare_151(
            model_name="m", description="d", db_app="a", date_db_created="", time_db_created="", version_db1=1,
            version_db2=1, file_type=0, date_db_saved="", time_db_saved="", program="p")], mode="add")


@pytest.mark.parametrize("kind", ["empty", "binary", "utf16", "truncated", "dataset151"])
def test_unreadable_uff_named_by_poses_csv_is_an_error_naming_it(tmp_path, capsys, kind):
    d = _set(tmp_path / "set")
    _damage(kind, d / "p2.uff")
    line = _refused(capsys, d, "p2.uff")
    assert "p1.uff" not in line and "p3.uff" not in line


def test_two_bad_files_the_first_is_named(tmp_path, capsys):
    d = _set(tmp_path / "set")
    _damage("empty", d / "p2.uff")
    _damage("truncated", d / "p3.uff")
    _refused(capsys, d, "p2.uff")


def test_truncated_csv_frf_is_refused(tmp_path, capsys):
    d = _set(tmp_path / "set", names=("p1", "p2"))
    (d / "p2.uff").unlink()
    h = _h()
    body = "# tool-tip receptance (m/N), frame base\nfreq_hz,H_x_x_re_m_per_n,H_x_x_im_m_per_n\n" + \
        "".join(f"{f:.12e},{v.real:.12e},{v.imag:.12e}\n" for f, v in zip(F, h))
    (d / "p2.csv").write_text(body[:-20])   # cut inside the last number, no final newline
    _refused(capsys, d, "p2.csv")
    (d / "p2.csv").write_bytes(body.encode("utf-16"))
    _refused(capsys, d, "p2.csv")


def test_all_zero_uff_is_refused(tmp_path, capsys):
    d = _set(tmp_path / "set")
    for n in ("p1", "p2", "p3"):
        (d / f"{n}.uff").unlink()
        _uff(d / f"{n}.uff", n, h=np.zeros(len(F)))
    _refused(capsys, d, "zero at every line")


def test_pair_given_twice_is_refused(tmp_path, capsys):
    d = _set(tmp_path / "set")
    _uff(d / "extra.uff", "p2", pairs=((1, 1),))
    _refused(capsys, d, "measured twice")


def test_dataset_labelled_with_another_pose_inside_a_pose_file(tmp_path, capsys):
    d = _set(tmp_path / "set")
    (d / "p2.uff").unlink()
    _uff(d / "p2.uff", "p1", pairs=((3, 3),))
    _refused(capsys, d, "labelled pose 'p1'")


@pytest.mark.parametrize("q,match", [("0,170,20,0,30,0", "A2"), ("0,1e300,20,0,30,0", "A2")])
def test_joint_angles_out_of_range_are_refused(tmp_path, capsys, q, match):
    d = _set(tmp_path / "set", rows={"p1": GOOD_Q, "p2": q, "p3": GOOD_Q})
    line = _refused(capsys, d, "pose p2")
    assert match in line


def test_missing_q6_column_refused_before_work(tmp_path, capsys):
    d = _set(tmp_path / "set", header=HEADER.rsplit(",", 1)[0], rows={n: "0,10,20,0,30" for n in ("p1", "p2")})
    _refused(capsys, d, "missing q6_deg")


def test_poses_csv_with_utf8_bom_is_read(tmp_path, capsys):
    # the reader must see the column "pose", not "\ufeffpose": a damaged p2 file is then the error
    d = _set(tmp_path / "set", bom=True)
    _damage("empty", d / "p2.uff")
    _refused(capsys, d, "p2.uff: empty file")


def test_report_option_is_named_in_its_messages(tmp_path, capsys):
    d = _set(tmp_path / "set", names=("p1", "p2"))
    (tmp_path / "rep").mkdir()
    (tmp_path / "rep" / "mine.txt").write_text("a user's file")
    _refused(capsys, d, "--report", "--report", str(tmp_path / "rep"))


# ---------------------------------------------------------------------------------- force side
def _force_set(d, forces, rate=1000.0, case='case = "tx200-aluminium"\n'):
    d.mkdir(parents=True)
    t = np.arange(len(forces)) / rate
    (d / "cut.toml").write_text(f"{case}sample_rate_hz = {rate}\nwindow_s = [0.0, {t[-1]}]\n")
    (d / "forces.csv").write_text("t_s,fx_n,fy_n,fz_n\n" + "".join(
        f"{ti:.17g},{a:.17g},{b:.17g},{c:.17g}\n" for ti, (a, b, c) in zip(t, forces)))
    return d


def test_all_zero_forces_refused(tmp_path, capsys):
    d = _force_set(tmp_path / "f", np.zeros((200, 3)))
    _refused(capsys, d, "every force sample in window_s is zero")


def test_a_force_of_1e308_newton_refused(tmp_path, capsys):
    rng = np.random.default_rng(0)
    f = 100 * rng.standard_normal((200, 3))
    f[57, 1] = 1e308
    d = _force_set(tmp_path / "f", f)
    _refused(capsys, d, "row 59, column fy_n")


def _stability(d, rpm="10000", depth="1.0", case="tx200-aluminium"):
    d.mkdir(parents=True)
    (d / "stability.csv").write_text("case,rpm,depth_mm,observed,path_s_m\n"
                                     f"{case},{rpm},{depth},stable,0.1\n{case},12000,0.5,chatter,0.2\n")
    return d


def test_stability_depth_of_1e6_mm_refused(tmp_path, capsys):
    _refused(capsys, _stability(tmp_path / "s", depth="1e6"), "depth_mm = '1e6'")


def test_stability_speed_of_1e9_rpm_refused(tmp_path, capsys):
    _refused(capsys, _stability(tmp_path / "s", rpm="1e9"), "rpm = '1e9'")


def test_force_stats_without_case_refused_unless_given(tmp_path, capsys):
    d = tmp_path / "st"
    d.mkdir()
    text = ('window_s = [0.0, 0.5]\naxes = "workpiece"\n[x]\nmin = -100.0\nmax = 100.0\nmean = 0.0\nrms = 50.0\n'
            '[y]\nmin = -80.0\nmax = 90.0\nmean = 5.0\nrms = 40.0\n')
    (d / "force_stats.toml").write_text(text)
    _refused(capsys, d, "names no case")


def test_model_stiffness_of_1e300_refused_naming_its_key(tmp_path, capsys):
    here = os.path.join(os.path.dirname(__file__), "..", "cases", "data")
    robot = open(os.path.join(here, "tx200.toml")).read()
    robot = robot.replace("stiffness_n_m_per_rad = 2.03e6", "stiffness_n_m_per_rad = 1e300", 1)
    (tmp_path / "robot.toml").write_text(robot)
    case = open(os.path.join(here, "tx200-aluminium.toml")).read()
    case = re.sub(r'(?m)^robot\s*=.*$', 'robot = "robot.toml"', case)
    (tmp_path / "case.toml").write_text(case)
    d = _set(tmp_path / "set", names=("p1", "p2"))
    _refused(capsys, d, "stiffness_n_m_per_rad", "--case", str(tmp_path / "case.toml"))
