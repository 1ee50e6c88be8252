"""Ctrl-C, SIGTERM and SIGKILL of ``robolobes map`` at each moment, a busy ``--out``, a dead scheduler.

The map runs as a real process (``python -m robolobes``) in its own session; the signals are sent
by this test with ``os.killpg`` (the whole group, as a terminal's Ctrl-C does: the workers get them
too), exactly as many as each test states. Nothing wraps the command in GNU ``timeout`` (which
would forward a signal of its own). The moment is found by watching the staging directory:
``.map.zarr.partial`` while the store is created, ``map.zarr/done`` once chunks compute,
``map.json`` just before the final swap. The default run keeps the SIGKILL, lock and scheduler
tests; the Ctrl-C and SIGTERM moments (5-30 s each) are ``slow``.
"""

import fcntl
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

SMALL = ["--over", "pass", "--n", "12", "--n-rpm", "1", "--quiet"]


def _start(out: Path, args, env=None):
    cmd = [sys.executable, "-m", "robolobes", "map", "--out", str(out), *args]
    return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True,
                            env={**os.environ, **(env or {})})


def _stage(out: Path) -> Path:
    return out.parent / f".{out.name}.robolobes-partial"


def _seen(proc, path: Path, limit_s=300.0) -> bool:
    """Poll every 5 ms until ``path`` exists (True) or ``proc`` has ended (False); fail after ``limit_s``."""
    t0 = time.monotonic()
    while not path.exists():
        if proc.poll() is not None:
            return False
        assert time.monotonic() - t0 < limit_s, f"{path} did not appear"
        time.sleep(0.005)
    return True


def _wait_for(proc, path: Path, limit_s=300.0):
    assert _seen(proc, path, limit_s), proc.communicate()


def _children(pid: int) -> list[int]:
    out = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                stat = (d / "stat").read_text()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                out.append(int(d.name))
    return out


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def _signals(proc, sig, n: int, gap_s=0.3):
    for _ in range(n):
        if proc.poll() is not None:
            break
        os.killpg(proc.pid, sig)
        time.sleep(gap_s)


def _finish(proc, limit_s=120):
    out, err = proc.communicate(timeout=limit_s)
    return proc.returncode, out.decode(), err.decode()


def _one_line(err: str, text: str):
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert lines == [text], err
    assert "Traceback" not in err


def _resumable(out: Path):
    """The state an interruption must leave: no target yet, a staging directory with a valid,
    incomplete marker, a whole store or none, no partial store, no lock file."""
    stage = _stage(out)
    marker = json.loads((stage / ".robolobes.json").read_text())
    assert marker["complete"] is False and marker["command"] == "map"
    assert not (stage / ".map.zarr.partial").exists()
    if (stage / "map.zarr").exists():
        attrs = json.loads((stage / "map.zarr" / "zarr.json").read_text())["attributes"]
        assert attrs["robolobes_map"] == 1
    assert not (out.parent / f".{out.name}.robolobes-lock").exists()


@pytest.mark.slow
def test_three_sigints_while_the_store_is_created(tmp_path):
    out = tmp_path / "m"
    proc = _start(out, ["--over", "placement", "--n", "200", "--n-rpm", "1000", "--quiet"])
    _wait_for(proc, _stage(out) / ".map.zarr.partial")
    _signals(proc, signal.SIGINT, 3)
    rc, _, err = _finish(proc)
    assert rc == 130
    _one_line(err, "robolobes: interrupted")
    _resumable(out)
    assert (_stage(out) / "map.zarr" / "done").is_dir()   # the creation finished before the interruption


@pytest.mark.slow
def test_one_sigint_while_the_largest_allowed_map_creates_its_store(tmp_path):
    """The largest map the bounds allow (--n 20000 poses, --n-rpm 1000 speeds: 160 MB per array);
    one SIGINT to its process group (a terminal's Ctrl-C) while its store is created."""
    from robolobes.workspace.cli import MAX_N, MAX_N_RPM

    out = tmp_path / "m"
    proc = _start(out, ["--over", "placement", "--n", str(MAX_N), "--n-rpm", str(MAX_N_RPM), "--quiet"])
    _wait_for(proc, _stage(out) / ".map.zarr.partial", limit_s=900)
    os.killpg(proc.pid, signal.SIGINT)
    rc, _, err = _finish(proc, limit_s=600)
    assert rc == 130
    _one_line(err, "robolobes: interrupted")
    _resumable(out)


def _worker_pids(proc, n=2, limit_s=120):
    t0 = time.monotonic()
    while time.monotonic() - t0 < limit_s:
        kids = [p for p in _children(proc.pid) if "spawn_main" in Path(f"/proc/{p}/cmdline").read_text(errors="replace")]
        if len(kids) >= n:
            return kids
        time.sleep(0.05)
    raise AssertionError("the workers did not start")


@pytest.mark.slow
def test_sigints_while_chunks_compute_stop_the_workers_and_resume(tmp_path):
    out = tmp_path / "m"
    proc = _start(out, SMALL + ["--workers", "2"])
    _wait_for(proc, _stage(out) / "map.zarr" / "done")
    workers = _worker_pids(proc)
    _signals(proc, signal.SIGINT, 3, gap_s=0.25)
    rc, _, err = _finish(proc)
    assert rc == 130
    _one_line(err, "robolobes: interrupted")
    _resumable(out)
    time.sleep(1.0)
    assert not [p for p in workers if _alive(p)]
    # the same command resumes the store (serially: the scheduler is not an input)
    res = subprocess.run([sys.executable, "-m", "robolobes", "map", "--out", str(out), *SMALL, "--scheduler",
                          "serial", "--json"], capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr
    assert json.loads(res.stdout)["n_poses"] == 12 and (out / "map.json").is_file()


@pytest.mark.slow
def test_sigterm_is_handled_like_ctrl_c(tmp_path):
    out = tmp_path / "m"
    proc = _start(out, SMALL + ["--workers", "2"])
    _wait_for(proc, _stage(out) / "map.zarr" / "done")
    workers = _worker_pids(proc)
    os.kill(proc.pid, signal.SIGTERM)          # the main process only, as a service manager does
    rc, _, err = _finish(proc)
    assert rc == 143
    _one_line(err, "robolobes: interrupted")
    _resumable(out)
    time.sleep(1.0)
    assert not [p for p in workers if _alive(p)]


def test_sigkill_of_the_main_process_leaves_no_worker_alive(tmp_path):
    out = tmp_path / "m"
    proc = _start(out, SMALL + ["--workers", "2"])
    _wait_for(proc, _stage(out) / "map.zarr" / "done")
    kids = _worker_pids(proc) + [p for p in _children(proc.pid)]   # workers and the resource tracker
    lock = out.parent / f".{out.name}.robolobes-lock"
    os.kill(proc.pid, signal.SIGKILL)
    proc.communicate(timeout=60)
    t0 = time.monotonic()
    while time.monotonic() - t0 < 10 and [p for p in kids if _alive(p)]:
        time.sleep(0.1)
    assert not [p for p in kids if _alive(p)], "processes alive 10 s after the parent's SIGKILL"
    # the kernel released the lock with its holder
    fd = os.open(lock, os.O_RDWR)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    finally:
        os.close(fd)


def _start_caught_before_swap(tmp_path: Path, attempts: int = 5):
    """A small map started and caught with ``map.json`` in its staging directory (the moment just
    before the final swap): ``(out, proc)``. That moment lasts milliseconds, and a test process
    polling every 5 ms on a loaded machine can miss it; a run that finished first must then have
    swapped in whole (checked), and a new run is started, ``attempts`` at most (pytest fails after)."""
    for _ in range(attempts):
        out = tmp_path / "m"
        proc = _start(out, ["--over", "pass", "--n", "2", "--n-rpm", "1", "--quiet", "--scheduler", "serial"])
        if _seen(proc, _stage(out) / "map.json", limit_s=600):
            return out, proc
        rc, _, err = _finish(proc)
        assert rc == 0 and not err.strip(), (rc, err)
        assert json.loads((out / ".robolobes.json").read_text())["complete"] is True
        assert not _stage(out).exists()
        shutil.rmtree(out)  # the test's own output: start again
    pytest.fail(f"the moment before the final swap was missed in {attempts} runs")


@pytest.mark.slow
def test_sigints_at_the_final_swap_leave_one_consistent_output(tmp_path):
    out, proc = _start_caught_before_swap(tmp_path)
    _signals(proc, signal.SIGINT, 3, gap_s=0.1)
    rc, stdout, err = _finish(proc)
    assert "Traceback" not in err
    if rc == 130:
        _one_line(err, "robolobes: interrupted")
    else:
        assert rc == 0 and not err.strip()
    if out.exists():      # swapped in whole: complete marker, no staging left
        assert json.loads((out / ".robolobes.json").read_text())["complete"] is True
        assert (out / "map.json").is_file() and not _stage(out).exists()
    else:
        _resumable(out)
    leftovers = [p.name for p in tmp_path.iterdir() if p.name != "m" and p != _stage(out)]
    assert leftovers == []


def test_a_second_map_on_a_busy_out_is_refused_at_once(tmp_path):
    out = tmp_path / "m"
    first = _start(out, SMALL + ["--scheduler", "serial"])
    try:
        _wait_for(first, out.parent / f".{out.name}.robolobes-lock")
        res = subprocess.run([sys.executable, "-m", "robolobes", "map", "--out", str(out), *SMALL], capture_output=True,
                             text=True, timeout=300)
        assert res.returncode == 2
        lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
        assert len(lines) == 1 and "in use by another robolobes run" in lines[0] and str(first.pid) in lines[0]
    finally:
        first.kill()
        first.communicate()


@pytest.mark.parametrize("addr,n", [("tcp://127.0.0.1:1", "12"), ("tcp://127.0.0.1:1", "1"),
                                    ("tcp://127.0.0.1:99999", "1")])
def test_dead_or_invalid_scheduler_refused_before_any_work(tmp_path, addr, n):
    out = tmp_path / "m"
    res = subprocess.run([sys.executable, "-m", "robolobes", "map", "--out", str(out), "--over", "pass", "--n", n,
                          "--n-rpm", "1", "--quiet", "--scheduler", addr], capture_output=True, text=True, timeout=300)
    assert res.returncode == 2, res.stderr
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "--scheduler" in lines[0] and "Traceback" not in res.stderr
    assert list(tmp_path.iterdir()) == []    # no staging directory, no lock, nothing
