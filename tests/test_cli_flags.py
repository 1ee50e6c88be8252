"""Flags that would have no effect are refused; negative ranges are accepted as the docs write them.

Run through the command line with ``ROBOLOBES_VALIDATE_ONLY=1`` (stop after the checks made before
any work: these are all checks of the command line itself).
"""

import pytest

from robolobes.main import join_negative_values, main


def _run(monkeypatch, capsys, tmp_path, *argv):
    monkeypatch.setenv("ROBOLOBES_VALIDATE_ONLY", "1")
    monkeypatch.chdir(tmp_path)
    rc = main(list(argv))
    return rc, capsys.readouterr().err.strip().splitlines()


@pytest.mark.parametrize("argv,match", [
    (["map", "--over", "pass", "--x-range-mm=-200,200"], "--x-range-mm has no effect with --over pass"),
    (["map", "--over", "tool-rotation", "--tilt-range-deg=0,10"], "--tilt-range-deg has no effect"),
    (["map", "--over", "pass", "--case", "tx200-steel", "--model", "m.toml"], "--case has no effect with --model"),
    (["optimize", "--case", "tx200-steel", "--model", "m.toml"], "--case has no effect with --model"),
    (["optimize", "--td-end-s", "2"], "--td-end-s has no effect without --time-domain"),
    (["optimize", "--over", "tool-rotation", "--y-range-mm=-5,5"], "--y-range-mm has no effect"),
])
def test_flags_without_effect_are_refused(monkeypatch, capsys, tmp_path, argv, match):
    rc, err = _run(monkeypatch, capsys, tmp_path, *argv)
    assert rc == 2 and len(err) == 1 and match in err[0], err


def test_negative_ranges_as_separate_arguments(monkeypatch, capsys, tmp_path):
    # as the docs write it: a space, not "=", between the option and a value starting with "-"
    rc, err = _run(monkeypatch, capsys, tmp_path, "map", "--over", "placement", "--x-range-mm", "-200,200",
                   "--y-range-mm", "-50.5,1e2", "--out", "m")
    assert rc == 0, err
    assert join_negative_values(["--q-deg", "-10,20,30,0,45,-90"]) == ["--q-deg=-10,20,30,0,45,-90"]
    assert join_negative_values(["--x", "-5"]) == ["--x", "-5"]          # argparse reads a lone number itself
    assert join_negative_values(["--a", "-b"]) == ["--a", "-b"]


def test_a_refused_range_still_names_itself(monkeypatch, capsys, tmp_path):
    rc, err = _run(monkeypatch, capsys, tmp_path, "map", "--over", "placement", "--x-range-mm", "-200,-300")
    assert rc == 2 and "--x-range-mm" in err[0] and "A <= B" in err[0]


def test_flags_that_take_effect_still_pass(monkeypatch, capsys, tmp_path):
    rc, err = _run(monkeypatch, capsys, tmp_path, "optimize", "--time-domain", "--td-end-s", "2", "--out", "o")
    assert rc == 0, err
    rc, err = _run(monkeypatch, capsys, tmp_path, "map", "--over", "lead-tilt", "--tilt-range-deg=-10,10", "--out", "m")
    assert rc == 0, err
