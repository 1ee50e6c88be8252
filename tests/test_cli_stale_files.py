"""Files and staging directories left by a killed run are removed by a later run, only when
provably ours (robolobes' own naming) and dead (no process holds their ``flock`` any more)."""

import subprocess
import sys
import textwrap

from robolobes.core.io import atomic_path
from robolobes.core.outdir import OutputDir

INPUTS = {"command": "test", "x": 1}


def _die_inside(code: str, cwd):
    """Run ``code`` in a fresh interpreter that dies (os._exit, no clean-up) at its end."""
    src = "import os\n" + textwrap.dedent(code) + "\nos._exit(9)\n"
    res = subprocess.run([sys.executable, "-c", src], cwd=cwd, capture_output=True, text=True, timeout=120)
    assert res.returncode == 9, res.stderr


def test_stale_staging_directory_removed_live_one_kept(tmp_path):
    _die_inside("""
        from robolobes.core.outdir import OutputDir
        out = OutputDir("out", "test", {"command": "test", "x": 1})
        out.open()
        (out.path / "half.txt").write_text("half")
    """, tmp_path)
    stale = [p for p in tmp_path.iterdir() if ".robolobes-stage-" in p.name]
    assert len(stale) == 1
    live = OutputDir(tmp_path / "out", "test", INPUTS)
    live_path = live.open()          # this run's own staging directory, locked
    again = OutputDir(tmp_path / "out", "test", INPUTS)   # another run: removes only the dead one
    assert not stale[0].exists() and live_path.is_dir()
    with again:
        assert again.path is not None  # set on entering the OutputDir
        (again.path / "a.txt").write_text("a")
    live.discard()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_stale_part_file_removed_by_the_next_write(tmp_path):
    _die_inside("""
        from robolobes.core.io import atomic_path
        cm = atomic_path("fig.png")
        tmp = cm.__enter__()
        tmp.write_bytes(b"half a png")
    """, tmp_path)
    parts = [p for p in tmp_path.iterdir() if p.name.startswith(".fig.png.") and p.name.endswith(".part.png")]
    assert len(parts) == 1
    (tmp_path / ".fig.png.mine.part.png").write_text("a user's file with a similar name")
    with atomic_path(tmp_path / "fig.png") as tmp:
        tmp.write_bytes(b"png")
    assert not parts[0].exists()
    assert (tmp_path / ".fig.png.mine.part.png").exists() and (tmp_path / "fig.png").read_bytes() == b"png"


_FINISHED = """
    from robolobes.core.outdir import OutputDir
    out = OutputDir("out", "test", {"command": "test", "x": 1})
    with out:
        (out.path / "a.txt").write_text("old")
"""
#: a second run of the same inputs killed inside the final swap, after ``when`` renames of a directory
_KILLED_IN_SWAP = """
    import os
    from robolobes.core.outdir import OutputDir
    real, renames = os.rename, []
    def rename(a, b):
        real(a, b)
        renames.append(b)
        if len(renames) == {when}:
            os._exit(9)
    os.rename = rename
    out = OutputDir("out", "test", {{"command": "test", "x": 1}})
    with out:
        (out.path / "a.txt").write_text("new")
"""


def _killed_in_swap(tmp_path, when: int):
    subprocess.run([sys.executable, "-c", textwrap.dedent(_FINISHED)], cwd=tmp_path, check=True, timeout=120)
    _die_inside(_KILLED_IN_SWAP.format(when=when), tmp_path)
    return [p for p in tmp_path.iterdir() if ".robolobes-old-" in p.name]


def test_killed_between_the_two_renames_the_previous_output_is_put_back(tmp_path):
    old = _killed_in_swap(tmp_path, when=1)      # out -> .out.robolobes-old-X, then killed
    assert len(old) == 1 and not (tmp_path / "out").exists()
    OutputDir(tmp_path / "out", "test", INPUTS)  # the next run on the same --out
    assert (tmp_path / "out" / "a.txt").read_text() == "old" and not old[0].exists()


def test_killed_after_the_swap_the_replaced_output_is_removed(tmp_path):
    old = _killed_in_swap(tmp_path, when=2)      # both renames done, killed before the clean-up
    assert len(old) == 1 and (tmp_path / "out" / "a.txt").read_text() == "new"
    similar = tmp_path / ".out.robolobes-old-0badf00d"       # named like ours, no marker: a user's
    similar.mkdir()
    (similar / "keep.txt").write_text("a user's")
    OutputDir(tmp_path / "out", "test", INPUTS)
    assert not old[0].exists() and (similar / "keep.txt").exists()
    assert (tmp_path / "out" / "a.txt").read_text() == "new"


def test_replaced_output_of_a_live_swap_is_left_alone(tmp_path):
    import fcntl
    import os
    old = _killed_in_swap(tmp_path, when=2)
    fd = os.open(old[0], os.O_RDONLY)
    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)   # as a live run holds it during its swap
    try:
        OutputDir(tmp_path / "out", "test", INPUTS)
        assert old[0].is_dir()
    finally:
        os.close(fd)
