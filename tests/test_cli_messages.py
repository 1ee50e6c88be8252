"""What a user reads on a bad input: one line, plain numbers, no numpy repr, no numpy warning.

numpy >= 2 writes a scalar's ``repr`` as ``np.float64(0.0)``; a message that formats a tuple or a
value with ``!r`` shows it (``feed_direction ... got (np.float64(0.0), ...)``). Each line below is a
near-miss of a real input (a case TOML with one bad value, a modal file, a flag); each must be
refused with exit 2 and one line whose numbers read as the user wrote them.
"""

import re
import warnings
from pathlib import Path

import pytest

from robolobes.main import main

ROOT = Path(__file__).resolve().parents[1]
CASE = (ROOT / "cases" / "data" / "tx200-aluminium.toml").read_text()
ROBOT = (ROOT / "cases" / "data" / "tx200.toml").read_text()
TOOL = ["--teeth", "2", "--diameter-mm", "20", "--ae-mm", "10", "--ktc-mpa", "600", "--krc-mpa", "200"]
#: a numpy repr inside a message (np.float64(1.0), np.int64(3), array([...]), np.str_('x'))
NUMPY_REPR = re.compile(r"\bnp\.\w+\(|\barray\(|\bdtype=")

CASE_EDITS = {
    "feed": ("feed_direction = [1, 0, 0]", "feed_direction = [0, 0, 0]"),
    "runout": ("runout_um = [0, 0]", "runout_um = [-5, 1e300]"),
    "pitch": ("pitch_deg = [170, 190]", "pitch_deg = [170, 100]"),
    "ae": ("ae_mm = 4", "ae_mm = 40"),
    "helix": ("helix_deg = 30", "helix_deg = 95"),
    "pose": ('start_pose = "tab7"', "start_pose = [0, 1e300, 0, 0, 0, 0]"),
    "stiffness": ("stiffness_n_m_per_rad = 2.03e6", "stiffness_n_m_per_rad = -1"),
}
MODAL = {
    "direction": "stiffness_n_per_m = 1e7\ndirection = [2, 0]\n",
    "residue": "residue_re = [[1, 0], [0]]\nresidue_im = [[0, 0], [0, 0]]\n",
    "zeta": "stiffness_n_per_m = 1e7\ndirection = [1, 0]\ndamping_ratio = 2\n",
}


def _write_inputs(d: Path) -> None:
    for key, (a, b) in CASE_EDITS.items():
        robot = ROBOT.replace(a, b, 1) if key == "stiffness" else ROBOT
        (d / f"r_{key}.toml").write_text(robot)
        case = CASE if key == "stiffness" else CASE.replace(a, b, 1)
        (d / f"c_{key}.toml").write_text(case.replace('robot = "tx200"', f'robot = "r_{key}.toml"'))
    for key, body in MODAL.items():
        zeta = "" if "damping_ratio" in body else "damping_ratio = 0.02\n"
        (d / f"m_{key}.toml").write_text(f"[[modes]]\nfreq_hz = 500\n{zeta}{body}")


LINES = ([[cmd, "--case", f"c_{k}.toml", *extra] for k in CASE_EDITS
          for cmd, extra in (("modes", []), ("lobes", ["--n-rpm", "3"]))]
         + [["lobes", "--modal", f"m_{k}.toml", *TOOL] for k in MODAL]
         + [["modes", "--q-deg=0,0,0,0,0,1e300"], ["lobes", "--path-s", "1e9"],
            ["map", "--over", "placement", "--x-range-mm=nan,2"], ["simulate", "--duration=-1"]])


@pytest.mark.parametrize("argv", LINES, ids=[" ".join(a[:3]) for a in LINES])
def test_bad_input_message_has_plain_numbers(argv, tmp_path, monkeypatch, capsys):
    _write_inputs(tmp_path)
    monkeypatch.chdir(tmp_path)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rc = main(argv)
    err = capsys.readouterr().err
    assert rc == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"robolobes {argv[0]}: error: "), err
    assert not NUMPY_REPR.search(err), err
    assert len(lines[0]) < 400, err          # no 300-digit number (an angle of 1e300 deg)
    assert not [w for w in caught if issubclass(w.category, RuntimeWarning)], [str(w.message) for w in caught]
