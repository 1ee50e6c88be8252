"""Every command's ``--out``, bounds, flags, error mapping, progress and provenance (issue 9 §3).

Each test is a user's action that, on the base commit, destroyed a file, ran into a 25-37 GiB
allocation, printed a traceback after the work, or printed 860 progress lines. Expected: one line
on stderr naming the value, exit 2 (130 for Ctrl-C), before any work, nothing of the user's changed.
"""

import json

import pytest

from robolobes.core.io import provenance
from robolobes.core.outdir import cli_inputs, read_provenance
from robolobes.main import build_parser, main as robolobes_main

from lobes_benchmark import MODAL, TOOLARGS as TOOL  # the symmetric 2-DOF benchmark modal file


def run(capsys, *argv):
    rc = robolobes_main([str(a) for a in argv])
    out = capsys.readouterr()
    return rc, out.out, out.err


def one_line(err: str) -> bool:
    return err.count("\n") == 1 and "Traceback" not in err


@pytest.fixture
def modal(tmp_path):
    f = tmp_path / "modes.toml"
    f.write_text(MODAL)
    return f


_WORKING = {"forbidden": False}


def _guarded(fn):
    """``fn``, failing while a ``no_work`` test runs (harmless where a module bound it at import)."""
    def wrapper(*a, **k):
        if _WORKING["forbidden"]:
            raise AssertionError("work started before the output was checked")
        return fn(*a, **k)
    return wrapper


@pytest.fixture
def no_work(monkeypatch):
    """Fail the test if a command starts computing (the checks must come first)."""
    import importlib

    for module, name in (("robolobes.linearize.linear", "linearize"), ("robolobes.lobes.cli", "solve"),
                         ("robolobes.timedomain.simulation", "simulate")):
        mod = importlib.import_module(module)
        monkeypatch.setattr(mod, name, _guarded(getattr(mod, name)))
    _WORKING["forbidden"] = True
    yield
    _WORKING["forbidden"] = False


# ---- --out never destroys a user's file; checked before the work -----------------------------------

def test_frf_refuses_a_users_csv_and_png_before_work(capsys, tmp_path, no_work):
    mine = tmp_path / "tcp.csv"
    mine.write_text("my measured FRF\n")
    rc, out, err = run(capsys, "frf", "--out", mine)
    assert rc == 2 and one_line(err) and "not written by robolobes" in err and str(mine) in err
    assert mine.read_text() == "my measured FRF\n"
    (tmp_path / "new.png").write_bytes(b"\x89PNG my picture")  # the Bode plot would land here
    rc, out, err = run(capsys, "frf", "--out", tmp_path / "new.csv")
    assert rc == 2 and one_line(err) and "new.png" in err
    assert (tmp_path / "new.png").read_bytes() == b"\x89PNG my picture"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["new.png", "tcp.csv"]


@pytest.mark.parametrize("argv", [
    ["frf", "--out", "/proc/tcp.csv"],
    ["lobes", "--modal", "MODAL", *TOOL, "--out", "/proc/lobes.png"],
    ["simulate", "--out", "/proc/robolobes-sim"],
])
def test_unwritable_output_is_one_line_before_work(capsys, modal, no_work, argv):
    # /proc takes no new files, even for root (on the base commit: a traceback after the work)
    argv = [str(modal) if a == "MODAL" else a for a in argv]
    rc, out, err = run(capsys, *argv)
    assert rc == 2 and one_line(err) and "cannot write in /proc" in err


def test_lobes_refuses_a_users_png_before_work(capsys, tmp_path, modal, no_work):
    mine = tmp_path / "lobes.png"
    mine.write_bytes(b"\x89PNG holiday")
    rc, out, err = run(capsys, "lobes", "--modal", modal, *TOOL, "--out", mine)
    assert rc == 2 and one_line(err) and "not written by robolobes" in err
    assert mine.read_bytes() == b"\x89PNG holiday"
    rc, out, err = run(capsys, "lobes", "--modal", modal, *TOOL, "--out", tmp_path / "lobes.txt")
    assert rc == 2 and ".png" in err


def test_simulate_refuses_a_users_directory_and_file_before_work(capsys, tmp_path, no_work):
    d = tmp_path / "mydata"
    d.mkdir()
    (d / "notes.txt").write_text("mine")
    rc, out, err = run(capsys, "simulate", "--linearized", "--duration", "0.05", "--quiet", "--out", d)
    assert rc == 2 and one_line(err) and "robolobes did not write" in err
    assert (d / "notes.txt").read_text() == "mine" and sorted(p.name for p in d.iterdir()) == ["notes.txt"]
    f = tmp_path / "existing.txt"
    f.write_text("mine")
    rc, out, err = run(capsys, "simulate", "--linearized", "--duration", "0.05", "--quiet", "--out", f)
    assert rc == 2 and "not a directory" in err and f.read_text() == "mine"


def test_study_refuses_a_users_directory_and_file_before_work(capsys, tmp_path):
    # on the base commit: the user's file in mydata/ was deleted, existing.txt became a directory
    # (after a full study; here the refusal comes first, in about a second)
    d = tmp_path / "mydata"
    d.mkdir()
    (d / "thesis.tex").write_text("years of work")
    rc, out, err = run(capsys, "study", "--quick", "--quiet", "--out", d)
    assert rc == 2 and one_line(err) and "robolobes did not write" in err
    assert (d / "thesis.tex").read_text() == "years of work" and len(list(d.iterdir())) == 1
    f = tmp_path / "existing.txt"
    f.write_text("mine")
    rc, out, err = run(capsys, "study", "--quick", "--quiet", "--out", f)
    assert rc == 2 and one_line(err) and "not a directory" in err and f.read_text() == "mine"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["existing.txt", "mydata"]


@pytest.mark.parametrize("argv", [
    ["study", "--quick", "--out"],
    ["simulate", "--linearized", "--duration", "0.05", "--out"],
    ["map", "--over", "pass", "--n", "3", "--out"],
    ["optimize", "--out"],
])
def test_every_directory_command_refuses_a_users_directory(capsys, tmp_path, argv):
    # one protocol for every command, including those added later (core.outdir.OutputDir)
    d = tmp_path / "mine"
    d.mkdir()
    (d / "notes.txt").write_text("mine")
    rc, out, err = run(capsys, *argv, d, "--quiet")
    assert rc == 2 and one_line(err) and "robolobes did not write" in err, err
    assert [p.name for p in d.iterdir()] == ["notes.txt"] and (d / "notes.txt").read_text() == "mine"
    assert [p.name for p in tmp_path.iterdir()] == ["mine"]


def test_frf_rerun_replaces_its_own_file_and_records_provenance(capsys, tmp_path):
    out = tmp_path / "tcp.csv"
    argv = ["frf", "--n", "20", "--fmax-hz", "50", "--out", out]
    assert run(capsys, *argv)[0] == 0
    ns = build_parser().parse_args([str(a) for a in argv])
    from robolobes.cases import load_case
    prov = provenance(cli_inputs(ns, case=load_case(ns.case)))
    assert read_provenance(out) == prov and read_provenance(out.with_suffix(".png")) == prov
    assert run(capsys, *argv)[0] == 0  # same inputs: replaced
    rc, _, err = run(capsys, "frf", "--n", "21", "--fmax-hz", "50", "--out", out)
    assert rc == 2 and "other inputs" in err  # a different result is not silently swapped in
    uff = tmp_path / "tcp.uff"
    assert run(capsys, "frf", "--n", "20", "--fmax-hz", "50", "--out", uff)[0] == 0
    got = read_provenance(uff)
    assert got is not None and got["robolobes_version"] == prov["robolobes_version"]


def test_ctrl_c_while_pyuff_writes_gives_130_and_no_file(capsys, tmp_path, monkeypatch):
    import pyuff

    real = pyuff.prepare_58

    class Interrupting(dict):  # Ctrl-C arrives inside pyuff's writer, which wraps it in Exception
        def __getitem__(self, k):
            if k == "func_type":
                raise KeyboardInterrupt
            return super().__getitem__(k)

    monkeypatch.setattr(pyuff, "prepare_58", lambda **kw: Interrupting(real(**kw)))
    rc, out, err = run(capsys, "frf", "--n", "20", "--out", tmp_path / "tcp.uff")
    assert rc == 130 and "Traceback" not in err and "Error writing data-set" not in err
    assert list(tmp_path.iterdir()) == []


# ---- bounds on what sets memory and time --------------------------------------------------------

@pytest.mark.parametrize("argv, msg", [
    (["simulate", "--duration", "100"], "past the end of the pass (1.75405 s"),
    (["simulate", "--case", "tx200-steel", "--duration", "22"], "past the end of the pass (21.9571 s"),
    (["simulate", "--deg-per-step", "1e-6"], "exceed the 2 GiB limit"),
    (["simulate", "--deg-per-step", "20"], "deg_per_step must be in (0, 10]"),
    (["simulate", "--damping-scale", "nan"], "--damping-scale must be a finite number >= 0"),
    (["lobes", "--m", "100000"], "--m must be an integer from 2 to 400"),
    (["lobes", "--n-rpm", "1000000000"], "--n-rpm must be from 1 to 5000"),
    (["frf", "--n", "1000000000", "--out", "x.csv"], "--n must be between 2 and 100000"),
])
def test_bounds_are_one_line_before_work(capsys, tmp_path, monkeypatch, no_work, argv, msg):
    monkeypatch.chdir(tmp_path)
    rc, out, err = run(capsys, *argv, "--quiet" if argv[0] != "frf" else "--frame=base")
    assert rc == 2 and one_line(err) and msg in err, err
    assert list(tmp_path.iterdir()) == []


def test_memory_error_is_one_line(capsys, tmp_path, modal, monkeypatch):
    def oom(*a, **k):
        raise MemoryError

    monkeypatch.setattr("robolobes.lobes.cli.solve", oom)
    rc, out, err = run(capsys, "lobes", "--modal", modal, *TOOL, "--quiet")
    assert rc == 1 and one_line(err) and "out of memory" in err


# ---- flags with no effect are errors ------------------------------------------------------------

@pytest.mark.parametrize("argv, msg", [
    (["lobes", "--teeth", "3"], "--teeth applies only with --modal"),
    (["lobes", "--ktc-mpa", "600"], "--ktc-mpa applies only with --modal"),
    (["lobes", "--modal", "MODAL", *TOOL, "--q-deg", "0,0,0,0,0,0"], "--q-deg selects the robot"),
    (["lobes", "--modal", "MODAL", *TOOL, "--variant", "orthogonal"], "--variant selects the robot"),
    (["lobes", "--modal", "MODAL", *TOOL, "--case", "tx200-steel"], "--case selects the robot"),
    (["lobes", "--method", "zoa", "--m", "80"], "--m applies only to --method sdm"),
])
def test_flags_without_effect_are_errors(capsys, modal, no_work, argv, msg):
    argv = [str(modal) if a == "MODAL" else a for a in argv]
    rc, out, err = run(capsys, *argv, "--quiet")
    assert rc == 2 and one_line(err) and msg in err, err


# ---- only bad input is "bad input"; internal errors keep their traceback ------------------------

@pytest.mark.parametrize("exc", [ValueError("internal bug"), KeyError("internal key")])
def test_internal_errors_are_not_reported_as_bad_input(modal, monkeypatch, exc):
    def bug(*a, **k):
        raise exc

    monkeypatch.setattr("robolobes.lobes.cli.solve", bug)
    with pytest.raises(type(exc)):
        robolobes_main(["lobes", "--modal", str(modal), *TOOL, "--quiet"])


def test_missing_modal_file_is_bad_input(capsys, tmp_path):
    rc, out, err = run(capsys, "lobes", "--modal", tmp_path / "nope.toml", *TOOL, "--quiet")
    assert rc == 2 and one_line(err) and "nope.toml" in err


# ---- progress: a few lines in a log, nothing with --quiet ----------------------------------------

def test_lobes_progress_in_a_log_is_a_few_lines(capsys, modal):
    # on the base commit: one line per chunk of speeds ("lobes: 8/200 speeds", ...)
    rc, out, err = run(capsys, "lobes", "--modal", modal, *TOOL, "--n-rpm", "200", "--m", "10")
    assert rc == 0
    assert 1 <= len(err.splitlines()) <= 3 and "\r" not in err, err
    rc, out, err = run(capsys, "lobes", "--modal", modal, *TOOL, "--n-rpm", "200", "--m", "10", "--quiet")
    assert rc == 0 and err == ""


# ---- provenance in every JSON -------------------------------------------------------------------

def test_lobes_and_modes_json_record_provenance(capsys, modal):
    rc, out, err = run(capsys, "lobes", "--modal", modal, *TOOL, "--n-rpm", "3", "--json", "--quiet")
    d = json.loads(out)
    ns = build_parser().parse_args(["lobes", "--modal", str(modal), *TOOL, "--n-rpm", "3", "--json", "--quiet"])
    assert d["provenance"]["inputs_sha256"] == provenance(cli_inputs(ns, files={"modal": modal}))["inputs_sha256"]
    modal.write_text(MODAL.replace("922", "923"))  # the file's content is an input
    rc, out2, _ = run(capsys, "lobes", "--modal", modal, *TOOL, "--n-rpm", "3", "--json", "--quiet")
    assert json.loads(out2)["provenance"]["inputs_sha256"] != d["provenance"]["inputs_sha256"]
    rc, out, err = run(capsys, "modes", "--json")
    assert set(json.loads(out)["provenance"]) == {"robolobes_version", "inputs_sha256"}
