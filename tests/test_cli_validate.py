"""``ROBOLOBES_VALIDATE_ONLY=1`` makes every check a real run makes before its work, for every
subcommand: a command line that parses but would be refused by the run is refused here too (exit
2, one line), so the test of the documented command lines catches it. Each bad line below parses
(argparse accepts it) and is refused only by the run's own checks: a range, an input file that
does not parse, an output that may not be written, a bound on run time."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from robolobes.main import main

ROOT = Path(__file__).resolve().parents[1]
HAMMER = str(ROOT / "tests" / "data" / "hammer_tooltip.uff")
TOOL = ["--teeth", "2", "--diameter-mm", "20", "--ae-mm", "10", "--ktc-mpa", "600", "--krc-mpa", "200"]


def _validate(argv, tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("ROBOLOBES_VALIDATE_ONLY", "1")
    monkeypatch.chdir(tmp_path)
    (tmp_path / "user.png").write_bytes(b"a user's picture")
    (tmp_path / "bad.toml").write_text("[[modes]]\nfreq_hz = 'fast'\n")
    (tmp_path / "half.uff").write_text("    -1\n    58\n")
    case = (ROOT / "cases" / "data" / "tx200-aluminium.toml").read_text()     # a pass whose start pose
    (tmp_path / "tilted.toml").write_text(case.replace('robot = "tx200"', f'robot = "{ROOT}/cases/data/tx200.toml"')
                                          .replace('start_pose = "tab7"', "start_pose = [0, 60, 0, 0, 0, 0]"))
    rc = main(argv)
    return rc, capsys.readouterr().err


GOOD = [
    ["study", "--quick", "--out", "s"],
    ["modes", "--pose", "tab7"],
    ["frf", "--n", "50", "--out", "h.csv"],
    ["lobes", "--n-rpm", "20", "--out", "l.png"],
    ["lobes", "--frf", HAMMER, "--frf-axes=x,y", *TOOL, "--method", "zoa"],
    ["simulate", "--linearized", "--duration", "0.1", "--out", "sim"],
]
BAD = [
    (["study", "--out", "user.png"], "exists and is not a directory"),
    (["modes", "--pose", "nosuch"], "has no pose 'nosuch'"),
    (["modes", "--q-deg=0,0,0,0,0"], "--q-deg must be 6"),
    (["modes", "--q-deg=0,170,0,0,0,0"], "A2"),
    (["frf", "--n", "1", "--out", "h.csv"], "--n must be between 2 and 100000"),
    (["frf", "--out", "user.png"], "the extension must be one of"),
    (["lobes", "--rpm-min", "3000", "--rpm-max", "2000"], "--rpm-max (2000.0) must be >= --rpm-min"),
    (["lobes", "--out", "user.png"], "was not written by robolobes"),
    (["lobes", "--modal", "bad.toml", *TOOL], "bad.toml"),
    (["lobes", "--frf", "half.uff", "--frf-axes=x,y", *TOOL], "half.uff"),
    (["lobes", "--pose", "nosuch"], "has no pose 'nosuch'"),
    (["simulate", "--duration", "1e6", "--out", "sim"], "duration"),
    (["simulate", "--damping-scale=-1", "--out", "sim"], "--damping-scale must be"),
    (["simulate", "--deg-per-step", "50", "--out", "sim"], "deg"),
    (["simulate", "--case", "tilted.toml", "--out", "sim"], "is not perpendicular to the tool axis"),
]


@pytest.mark.parametrize("argv", GOOD, ids=[" ".join(a[:3]) for a in GOOD])
def test_valid_lines_are_checked_in_full(argv, tmp_path, monkeypatch, capsys):
    rc, err = _validate(argv, tmp_path, monkeypatch, capsys)
    assert rc == 0 and f"robolobes {argv[0]}: inputs valid" in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.toml", "half.uff", "tilted.toml", "user.png"]


@pytest.mark.parametrize("argv,why", BAD, ids=[" ".join(a) for a, _ in BAD])
def test_lines_the_run_would_refuse_are_refused(argv, why, tmp_path, monkeypatch, capsys):
    rc, err = _validate(argv, tmp_path, monkeypatch, capsys)
    lines = err.strip().splitlines()
    assert rc == 2 and why in err and "inputs valid" not in err, err
    assert len([ln for ln in lines if "warning" not in ln]) == 1, err


def test_a_documented_line_the_run_would_refuse_fails_the_docs_test(tmp_path):
    """The documented-commands test itself fails on such a line (run as pytest would run it)."""
    doc = tmp_path / "test_bad_doc.py"
    doc.write_text("from test_cli_documented_commands import test_documented_command_validates as t\n"
                   "def test_bad(tmp_path, monkeypatch, capsys):\n"
                   "    t('docs/x.md', 1, ['frf', '--n', '1', '--out', 'h.csv'], tmp_path, monkeypatch, capsys)\n")
    res = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(doc)],
                         cwd=tmp_path, capture_output=True, text=True, timeout=300,
                         env={**os.environ, "PYTHONPATH": os.pathsep.join(
                             [str(ROOT / "tests"), *filter(None, [os.environ.get("PYTHONPATH")])])})
    assert res.returncode == 1 and "docs/x.md:1" in res.stdout and "--n must be between" in res.stdout, res.stdout


@pytest.mark.parametrize("command,lo,hi", [("map", 1, 20_000), ("frf", 2, 100_000)])
def test_help_docs_and_checks_agree_on_the_range_of_n(command, lo, hi, tmp_path, monkeypatch, capsys):
    with pytest.raises(SystemExit):
        main([command, "--help"])
    helptext = " ".join(capsys.readouterr().out.split())
    assert f"{lo}..{hi}" in helptext, helptext
    docs = " ".join((ROOT / "docs" / "guide" / "inputs-and-interrupts.md").read_text().split())
    assert f"`--n` of `{command}` counts" in docs and f"from {lo} to {hi:,}".replace(",", " ") in docs
    extra = ["--over", "pass", "--scheduler", "serial"] if command == "map" else []
    for n, rc in ((lo - 1, 2), (hi + 1, 2), (lo, 0), (hi, 0)):
        if command == "map" and n == hi:
            continue        # 20 000 pass poses: valid, but the check builds their table (slow)
        got, err = _validate([command, *extra, "--n", str(n), "--out", "o.csv" if command == "frf" else "o"],
                             tmp_path, monkeypatch, capsys)
        assert got == rc, (n, err)
