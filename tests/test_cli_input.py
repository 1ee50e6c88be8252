"""Strict input (issue 9 §3): unknown TOML keys, flags without effect, bounds, one bad-input error type.

Every case here is a user's mistake that used to be silently accepted, or to cost a 25-37 GiB
allocation or a traceback. The expected outcome is one line on stderr naming the bad value and
exit code 2, before any work (no output written).
"""

from pathlib import Path

import pytest

from robolobes import cases
from robolobes.cases import load_case, load_robot
from robolobes.core.errors import BadInput
from robolobes.main import main as robolobes_main

DATA = Path(cases.__file__).parent / "data"


def run(capsys, *argv):
    rc = robolobes_main([str(a) for a in argv])
    out = capsys.readouterr()
    return rc, out.out, out.err


# ---- unknown keys in case and robot files ---------------------------------------------------------

def test_case_typo_helx_deg_is_an_error_naming_the_key(tmp_path):
    text = (DATA / "tx200-aluminium.toml").read_text()
    assert "helix_deg = 30" in text
    f = tmp_path / "case.toml"
    f.write_text(text.replace("helix_deg = 30", "helx_deg = 30"))
    # before: the helix silently became 0
    with pytest.raises(BadInput, match=r"unknown key 'tool\.helx_deg'.*helix_deg"):
        load_case(f)


@pytest.mark.parametrize("old, new, key", [
    ("gravity_compensation = true", "gravity_compensaton = true", r"'joints\[1\]\.gravity_compensaton'"),
    ('tcp_rotation_deg = [["y", 60]]', 'tcp_rotaton_deg = [["y", 60]]', r"'payload\.tcp_rotaton_deg'"),
    ("half_width_rad = 7.3e-5", "half_width_rad = 7.3e-5\nhalfwidth_rad = 1e-3", r"'backlash\.halfwidth_rad'"),
    ("gravity_m_per_s2 = 9.81", "gravity_m_per_s2 = 9.81\ngravity = 0", r"'gravity'"),
])
def test_robot_unknown_keys_are_errors(tmp_path, old, new, key):
    text = (DATA / "tx200.toml").read_text()
    assert old in text
    f = tmp_path / "robot.toml"
    f.write_text(text.replace(old, new, 1))
    with pytest.raises(BadInput, match="unknown key " + key):
        load_robot(f)


def test_builtin_files_have_no_unknown_keys():
    for name in cases.builtin_cases():
        load_case(name)
    for name in cases.builtin_robots():
        load_robot(name)


def test_case_file_typo_through_the_cli(tmp_path, capsys):
    f = tmp_path / "case.toml"
    f.write_text((DATA / "tx200-aluminium.toml").read_text().replace("approach_mm =", "approch_mm ="))
    rc, out, err = run(capsys, "modes", "--case", f)
    assert rc == 2
    assert err.count("\n") == 1 and "unknown key 'pass.approch_mm'" in err
