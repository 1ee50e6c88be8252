"""Output safety (issue 9 §3): ``core.outdir`` never overwrites or deletes a file robolobes did not write.

Each test builds the situation a user creates (their own file in the way, a file where a directory
is expected, a run interrupted while writing) and checks the bytes on disk afterwards.
"""

import json
import os
from pathlib import Path

import pytest

from robolobes.core.errors import BadInput
from robolobes.core.io import Progress, provenance, provenance_text, pyplot, save_figure, write_json
from robolobes.core.outdir import MARKER, OutputDir, OutputRefused, check_output_file, read_provenance, user_path_errors

INPUTS = {"command": "test", "case": "tx200-aluminium", "duration_s": 0.5}
OTHER = {"command": "test", "case": "tx200-steel", "duration_s": 0.5}


def _work(out: OutputDir) -> Path:
    """The staging directory of an entered OutputDir."""
    assert out.path is not None
    return out.path


def _write_result(out: OutputDir, text="result"):
    (_work(out) / "summary.json").write_text(json.dumps({"x": text, "provenance": out.provenance}))
    (_work(out) / "sub").mkdir()
    (_work(out) / "sub" / "series.csv").write_text("t_s\n0\n")


# ---- directories --------------------------------------------------------------------------------

def test_new_directory_is_created_with_a_marker_listing_its_files(tmp_path):
    target = tmp_path / "out"
    with OutputDir(target, "test", INPUTS) as out:
        assert out.path != target and not target.exists()  # work goes to a staging directory
        _write_result(out)
    marker = json.loads((target / MARKER).read_text())
    assert marker["files"] == ["sub/series.csv", "summary.json"]
    assert marker["provenance"] == provenance(INPUTS)
    assert marker["command"] == "test" and marker["complete"] is True
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # no staging left beside it


def test_directory_holding_a_users_file_is_refused_and_kept(tmp_path):
    target = tmp_path / "mydata"
    target.mkdir()
    (target / "thesis.tex").write_text("years of work")
    with pytest.raises(OutputRefused, match="robolobes did not write"):
        OutputDir(target, "test", INPUTS)
    assert (target / "thesis.tex").read_text() == "years of work"


def test_existing_file_is_not_turned_into_a_directory(tmp_path):
    f = tmp_path / "existing.txt"
    f.write_text("mine")
    with pytest.raises(OutputRefused, match="not a directory"):
        OutputDir(f, "test", INPUTS)
    assert f.read_text() == "mine"


def test_robolobes_output_with_a_file_the_user_added_is_refused(tmp_path):
    target = tmp_path / "out"
    with OutputDir(target, "test", INPUTS) as out:
        _write_result(out)
    (target / "sub" / "notes.txt").write_text("my notes")
    with pytest.raises(OutputRefused, match="notes.txt"):
        OutputDir(target, "test", INPUTS)
    assert (target / "sub" / "notes.txt").read_text() == "my notes"


def test_same_inputs_replace_other_inputs_are_refused(tmp_path):
    target = tmp_path / "out"
    with OutputDir(target, "test", INPUTS) as out:
        _write_result(out, "first")
    with OutputDir(target, "test", INPUTS) as out:
        _write_result(out, "second")
    assert json.loads((target / "summary.json").read_text())["x"] == "second"
    with pytest.raises(OutputRefused, match="other inputs"):
        OutputDir(target, "test", OTHER)
    assert json.loads((target / "summary.json").read_text())["x"] == "second"
    with OutputDir(target, "test", OTHER, replace=True) as out:  # explicit replace of a robolobes output
        (_work(out) / "only.txt").write_text("new")
    assert sorted(p.name for p in target.iterdir()) == [MARKER, "only.txt"]  # old files of the old run gone
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_error_or_ctrl_c_leaves_the_previous_output_as_it_was(tmp_path):
    target = tmp_path / "out"
    with OutputDir(target, "test", INPUTS) as out:
        _write_result(out, "good")
    before = {p: p.read_bytes() for p in target.rglob("*") if p.is_file()}
    for exc in (KeyboardInterrupt, RuntimeError):
        with pytest.raises(exc):
            with OutputDir(target, "test", INPUTS) as out:
                (_work(out) / "summary.json").write_text("half")
                raise exc()
        assert {p: p.read_bytes() for p in target.rglob("*") if p.is_file()} == before
        assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # no partial staging left


def test_empty_directory_is_accepted(tmp_path):
    target = tmp_path / "empty"
    target.mkdir()
    with OutputDir(target, "test", INPUTS) as out:
        (_work(out) / "a.txt").write_text("a")
    assert (target / "a.txt").read_text() == "a"


def test_missing_parent_is_refused_before_work(tmp_path):
    with pytest.raises(OutputRefused, match="does not exist"):
        OutputDir(tmp_path / "no" / "out", "test", INPUTS)
    assert not (tmp_path / "no").exists()


def test_resume_keeps_partial_work_for_the_same_inputs_only(tmp_path):
    target = tmp_path / "map"
    with pytest.raises(KeyboardInterrupt):
        with OutputDir(target, "test", INPUTS, resume=True) as out:
            assert not out.resumed
            (_work(out) / "chunk0.npy").write_text("0")
            raise KeyboardInterrupt
    assert not target.exists()
    with pytest.raises(OutputRefused, match="other inputs"):
        OutputDir(target, "test", OTHER, resume=True)
    with OutputDir(target, "test", INPUTS, resume=True) as out:
        assert out.resumed and (_work(out) / "chunk0.npy").read_text() == "0"
        (_work(out) / "chunk1.npy").write_text("1")
    assert sorted(p.name for p in target.iterdir()) == [MARKER, "chunk0.npy", "chunk1.npy"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["map"]


def test_oserror_while_writing_names_the_users_path(tmp_path):
    target = tmp_path / "out"
    with pytest.raises(BadInput, match=f"cannot write {target}"):
        with OutputDir(target, "test", INPUTS) as out:
            (_work(out) / "missing-dir" / "x.txt").write_text("x")  # FileNotFoundError inside the output
    assert not target.exists()


# ---- single files -------------------------------------------------------------------------------

def test_check_output_file_refuses_a_users_file_a_directory_and_a_bad_extension(tmp_path):
    mine = tmp_path / "lobes.png"
    mine.write_bytes(b"\x89PNG my holiday photo")
    with pytest.raises(OutputRefused, match="not written by robolobes"):
        check_output_file(mine, (".png",), INPUTS)
    assert mine.read_bytes() == b"\x89PNG my holiday photo"
    (tmp_path / "d.png").mkdir()
    with pytest.raises(OutputRefused, match="is a directory"):
        check_output_file(tmp_path / "d.png", (".png",), INPUTS)
    with pytest.raises(OutputRefused, match=r"\.csv, \.uff"):
        check_output_file(tmp_path / "f.txt", (".csv", ".uff"), INPUTS)
    with pytest.raises(OutputRefused, match="does not exist"):
        check_output_file(tmp_path / "nodir" / "f.csv", (".csv",), INPUTS)
    assert check_output_file(tmp_path / "new.CSV", (".csv",), INPUTS) == tmp_path / "new.CSV"


@pytest.mark.parametrize("suffix", [".png", ".pdf", ".svg"])
def test_figures_carry_provenance_and_are_replaced_only_for_the_same_inputs(tmp_path, suffix):
    plt = pyplot()
    fig, ax = plt.subplots()
    ax.plot([0, 1])
    f = tmp_path / ("fig" + suffix)
    save_figure(fig, f, provenance=provenance(INPUTS))
    plt.close(fig)
    assert read_provenance(f) == provenance(INPUTS)
    assert check_output_file(f, (suffix,), INPUTS) == f
    with pytest.raises(OutputRefused, match="other inputs"):
        check_output_file(f, (suffix,), OTHER)


def test_json_and_csv_provenance_is_recognized(tmp_path):
    j = tmp_path / "r.json"
    write_json(j, {"provenance": provenance(INPUTS), "data": list(range(50000))})  # > 64 KiB
    assert read_provenance(j) == provenance(INPUTS)
    c = tmp_path / "f.csv"
    c.write_text(f"# {provenance_text(provenance(INPUTS))}\nfreq_hz,h\n1,2\n")
    assert read_provenance(c) == provenance(INPUTS)
    assert read_provenance(tmp_path / "absent.csv") is None


def test_user_path_errors_gives_one_line_naming_the_path(tmp_path):
    with pytest.raises(BadInput, match=r"cannot write /some/where.csv: Permission denied"):
        with user_path_errors("/some/where.csv"):
            raise PermissionError(13, "Permission denied")


@pytest.mark.skipif(os.geteuid() != 0 and not os.path.isdir("/proc/self"), reason="needs an unwritable directory")
def test_unwritable_parent_is_refused_before_work():
    # /proc accepts no new files even for root (a chmod'ed directory would not stop root)
    with pytest.raises(OutputRefused, match="cannot write in /proc"):
        check_output_file("/proc/lobes.png", (".png",), INPUTS)
    with pytest.raises(OutputRefused, match="cannot write in /proc"):
        OutputDir("/proc/robolobes-out", "test", INPUTS)


# ---- progress -----------------------------------------------------------------------------------

class _Log:
    def __init__(self):
        self.text = ""

    def write(self, s):
        self.text += s

    def flush(self):
        pass

    def isatty(self):
        return False


def test_progress_in_a_log_file_is_a_few_lines_and_quiet_is_silent():
    log = _Log()
    bar = Progress("simulate", stream=log)
    for k in range(861):  # the 860 updates of a pass
        bar(k / 860, "steel")
    bar.done()
    lines = log.text.splitlines()
    assert 1 <= len(lines) <= 3, lines
    assert "\r" not in log.text and lines[-1].startswith("simulate 100%")
    quiet = _Log()
    bar = Progress("simulate", enabled=False, stream=quiet)
    for k in range(861):
        bar(k / 860)
    bar.done()
    assert quiet.text == ""
