"""Case files: the TX200 numbers as the paper gives them, and clear errors for malformed files."""

import math
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from robolobes import cases
from robolobes.cases import CaseError, load_case, load_robot
from robolobes.core.io import atomic_path, write_json

DATA = Path(cases.__file__).parent / "data"


def test_tx200_numbers_from_the_paper():
    r = load_robot("tx200")
    # Tab. 5, 6
    assert_allclose(r.joint_stiffness, [2.03e6, 6.02e6, 1.91e6, 0.45e6, 0.22e6, 0.07e6])
    assert_allclose(r.joint_damping, [383.3, 660, 371.7, 180.5, 126.2, 71.2])
    # Tab. 4 masses; payload 44.4 kg
    assert_allclose([link.mass_kg for link in r.links], [226, 364, 256, 99, 41, 14, 0.6])
    assert r.payload.mass_kg == 44.4
    # eq. 10-12: orthogonal 5e6 / 1000, backlash 15 arcsec = 7.3e-5 rad
    assert r.orthogonal_stiffness_n_m_per_rad == 5e6 and r.orthogonal_damping_n_m_s_per_rad == 1000
    assert_allclose(r.backlash_half_width_rad, math.radians(15 / 3600), rtol=0.01)
    assert [j.gravity_compensation for j in r.joints] == [False, True, True, False, True, False]
    # datasheet ranges
    assert_allclose(np.degrees(r.joint_range_rad), [[-180, 180], [-120, 120], [-140, 145], [-270, 270],
                                                    [-120, 120], [-270, 270]])
    # TCP = AG + GB of the payload (Tab. 3) = (0.201, 0, 0.317) in flange axes
    assert_allclose(r.payload.tcp_m, [0.201, 0, 0.317], atol=1e-12)


def test_tx200_kinematic_sums_match_dh_table():
    # NOTES.md: the assumed GB z splits must keep d1 = 0.642, a2 = 0.95, d4 = 0.8 and the flange
    # face 0.194 beyond the wrist centre; x/y offsets close (0.25 shoulder offset, y sum 0).
    L = [link.com_m + link.next_joint_m for link in load_robot("tx200").links]
    assert_allclose(L[0][2] + L[1][2], 0.642, atol=1e-12)
    assert_allclose(L[2][2], 0.95, atol=1e-12)
    assert_allclose(L[3][2] + L[4][2], 0.8, atol=1e-12)
    assert_allclose(L[5][2] + L[6][2], 0.194, atol=1e-12)
    assert_allclose(L[1][0], 0.25, atol=1e-12)
    assert_allclose(L[1][1] + L[2][1] + L[3][1], 0.0, atol=1e-12)


def test_assumptions_are_listed_in_one_place():
    r = load_robot("tx200")
    keyed = {a.key: a.value for a in r.assumptions if a.key}
    assert keyed == {"links.base.gb_m.z": 0.2, "links.shoulder.gb_m.z": 0.114,
                     "links.elbow.gb_m.z": 0.2, "links.wrist.gb_m.z": 0.05}


def test_cutting_cases(alu_case, steel_case):
    al, st = alu_case, steel_case
    # Tab. 8
    assert al.tool.diameter_m == 0.01 and al.tool.teeth == 2
    assert_allclose(np.degrees(al.tool.pitch_rad), [170, 190])
    assert_allclose(al.law.ktc_pa, 661.553e6)
    assert_allclose(al.cut.feed_per_tooth_m, 3.7 / 60 / (18700 / 60 * 2))  # 3700 mm/min, 2 teeth
    assert al.cut.mode == "down" and al.cut.ae_m == 0.004 and al.cut.ap_m == 0.0016
    # Tab. 9
    assert_allclose(st.law.krc_pa, 2289e6)
    assert_allclose(st.tool.runout_m, [6.929e-6, 0])
    assert st.cut.spindle_rpm == 3100
    # pass: starts at Tab. 7
    assert_allclose(np.degrees(al.path.start_q_rad), [-11.71, 20.78, -212.14, 82.76, 60.80, -166.96])
    assert set(cases.builtin_cases()) >= {"tx200-aluminium", "tx200-steel"}


def _copy_case(tmp_path, edit_case=None, edit_robot=None):
    robot = (DATA / "tx200.toml").read_text()
    case = (DATA / "tx200-aluminium.toml").read_text().replace('robot = "tx200"', 'robot = "myrobot.toml"')
    if edit_robot:
        robot = edit_robot(robot)
    if edit_case:
        case = edit_case(case)
    (tmp_path / "myrobot.toml").write_text(robot)
    (tmp_path / "mycase.toml").write_text(case)
    return tmp_path / "mycase.toml"


def test_user_case_by_path_round_trips(tmp_path, alu_case):
    c = load_case(_copy_case(tmp_path))
    ref = alu_case
    assert_allclose(c.robot.joint_stiffness, ref.robot.joint_stiffness)
    assert c.cut == ref.cut and c.tool == ref.tool


@pytest.mark.parametrize("edit, match", [
    (lambda s: s.replace("ae_mm = 4", "ae_mm = 12"), r"ae = 12 mm exceeds the tool diameter D = 10 mm"),
    (lambda s: s.replace("pitch_deg = [170, 190]", "pitch_deg = [170, 180]"), r"sum to 350 deg; they must sum to 360"),
    (lambda s: s.replace("ap_mm = 1.6", "ap_mm = -1"), r"key 'cut.ap_mm' must be a number > 0, got -1.0"),
    (lambda s: s.replace("teeth = 2", "teeth = 0"), r"key 'tool.teeth' must be an integer >= 1, got 0"),
    (lambda s: s.replace('mode = "down"', 'mode = "climb"'), r"key 'cut.mode' must be one of \['up', 'down'\]"),
    (lambda s: s.replace("ktc_mpa = 661.553", 'ktc_mpa = "661"'), r"key 'material.ktc_mpa' must be a number"),
    (lambda s: s.replace("spindle_rpm = 18700\n", ""), r"missing key 'cut.spindle_rpm'"),
    (lambda s: s.replace('start_pose = "tab7"', 'start_pose = "home"'), r"key 'pass.start_pose' must be a pose"),
    (lambda s: s.replace('kind = "cut"', 'kind = "robot"'), r"key 'kind' must be 'cut'"),
    (lambda s: s.replace("[cut]", "[cut\n"), r"not valid TOML"),
])
def test_malformed_case_names_the_key(tmp_path, edit, match):
    with pytest.raises(CaseError, match=match):
        load_case(_copy_case(tmp_path, edit_case=edit))


@pytest.mark.parametrize("edit, match", [
    (lambda s: s.replace("value = 0.114\n", "value = 0.114\n", 1).replace('key = "links.shoulder.gb_m.z"', 'key = "links.shoulder.gb_m.w"'),
     r"'links.<link name>.<vector key>.<x\|y\|z>'"),
    (lambda s: s.replace('''[[assumption]]
key = "links.base.gb_m.z"
value = 0.200''', '''[[assumption]]
value = 0.200'''), r"links\[0\].gb_m' must be fully known"),
    (lambda s: s.replace("inertia_kg_m2 = [36.58, 39.92, 6.57, 0.05, 0.18, 0.74]", "inertia_kg_m2 = [1, 1, 5, 0, 0, 0]"),
     r"a physical inertia"),
    (lambda s: s.replace("range_deg = [-140, 145]", "range_deg = [145, -140]"), r"lower < upper"),
    (lambda s: s.replace('axis = "z"', 'axis = "w"', 1), r"key 'joints\[0\].axis' must be one of"),
])
def test_malformed_robot_names_the_key(tmp_path, edit, match):
    with pytest.raises(CaseError, match=match):
        load_case(_copy_case(tmp_path, edit_robot=edit))


def test_unknown_case_lists_the_builtins():
    with pytest.raises(CaseError, match=r"no cut named 'tx300'.*tx200-aluminium"):
        load_case("tx300")


def test_atomic_write_leaves_nothing_on_error(tmp_path):
    target = tmp_path / "out.json"
    target.write_text("old")
    with pytest.raises(RuntimeError):
        with atomic_path(target) as tmp:
            tmp.write_text("half")
            raise RuntimeError("interrupted")
    assert target.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.json"]
    write_json(target, {"a": np.float64(1.5), "b": np.array([1, 2]), "c": float("nan")})
    assert target.read_text().split() == ['{', '"a":', '1.5,', '"b":', '[', '1,', '2', '],', '"c":', 'null', '}']


def test_package_errors_are_bad_input():
    """Errors that signal bad user input are BadInput (the CLI maps only it to one line + exit 2)."""
    from robolobes.core.errors import BadInput
    from robolobes.cases import CaseError
    from robolobes.cases.milling import MillingError, Tool
    from robolobes.linearize import KinematicsError, SingularConfigurationError, UnreachableError
    from robolobes.linearize.path import PassError
    from robolobes.lobes import LobeError

    for cls in (CaseError, MillingError, KinematicsError, UnreachableError, PassError, SingularConfigurationError,
                LobeError):
        assert issubclass(cls, BadInput), cls
    with pytest.raises(BadInput, match="tool teeth must be an integer >= 1, got 0"):
        Tool(diameter_m=0.01, teeth=0)
