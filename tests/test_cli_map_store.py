"""A damaged map store is detected on the rerun and the damaged chunks are computed again.

One map of 12 poses (two chunks: 10 + 2) is made once; each test damages a copy of it the way a
disk, a user or a crash would, reruns the same command and checks that (a) the damage is named on
stderr, (b) only the damaged chunks are recomputed, (c) the numbers equal the undamaged map's
bitwise and no best pose has a null limit.
"""

import json
import shutil
import warnings

import numpy as np
import pytest
import xarray as xr

from robolobes.main import main
from robolobes.workspace.store import StoreDamageWarning

ARGS = ["map", "--over", "pass", "--n", "12", "--n-rpm", "1", "--scheduler", "serial", "--quiet", "--json"]


def _run(out, capsys):
    """Run the map; returns its JSON and the warning lines it gave (stderr lines in a shell, where
    robolobes prints each warning as one line; pytest records them instead)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rc = main(ARGS + ["--out", str(out)])
    cap = capsys.readouterr()
    assert rc == 0, cap.err
    lines = [str(w.message) for w in caught if issubclass(w.category, StoreDamageWarning)]
    return json.loads(cap.out), "\n".join(lines + cap.err.splitlines())


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    out = tmp_path_factory.mktemp("map") / "m"
    assert main(ARGS + ["--out", str(out)]) == 0
    ds = xr.open_zarr(out / "map.zarr", consolidated=False).load()
    return out, ds


def _copy(made, tmp_path):
    dst = tmp_path / "m"
    shutil.copytree(made[0], dst, symlinks=True)
    return dst


def _same_results(out, ref):
    ds = xr.open_zarr(out / "map.zarr", consolidated=False).load()
    for v in ("depth_limit_m", "op_depth_limit_m", "chatter_freq_hz", "deflection_m", "done"):
        np.testing.assert_array_equal(ds[v].values, ref[v].values)


def test_deleted_chunk_file_is_recomputed_and_named(made, tmp_path, capsys):
    out = _copy(made, tmp_path)
    (out / "map.zarr" / "depth_limit_m" / "c" / "1" / "0").unlink()
    js, err = _run(out, capsys)
    assert "chunk 1 (poses 10..11)" in err and "depth_limit_m/c/1/0 is missing" in err
    assert js["computed_poses"] == 2
    assert js["best_pose"] is not None and js["best_pose_min_depth_limit_m"] is not None
    _same_results(out, made[1])


def test_garbage_in_a_chunk_fails_its_checksum_and_is_recomputed(made, tmp_path, capsys):
    out = _copy(made, tmp_path)
    f = out / "map.zarr" / "op_chatter_freq_hz" / "c" / "1"
    b = bytearray(f.read_bytes())
    b[len(b) // 2] ^= 0xFF          # one flipped byte: still the right length, wrong content
    f.write_bytes(bytes(b))
    js, err = _run(out, capsys)
    assert "op_chatter_freq_hz/c/1 fails its checksum" in err and "Traceback" not in err
    assert js["computed_poses"] == 2
    _same_results(out, made[1])


@pytest.mark.slow
def test_deleted_done_array_means_nothing_done(made, tmp_path, capsys):
    out = _copy(made, tmp_path)
    shutil.rmtree(out / "map.zarr" / "done")
    js, err = _run(out, capsys)
    assert "array done is missing" in err and len(err.strip().splitlines()) == 1
    assert js["computed_poses"] == 12
    _same_results(out, made[1])
    assert xr.open_zarr(out / "map.zarr", consolidated=False).attrs == made[1].attrs   # still our store


@pytest.mark.slow
def test_garbage_in_the_done_array_means_nothing_done(made, tmp_path, capsys):
    out = _copy(made, tmp_path)
    (out / "map.zarr" / "done" / "c" / "1").write_bytes(b"garbage")
    js, err = _run(out, capsys)
    assert "done/c/1 cannot be decoded" in err or "done/c/1 fails its checksum" in err, err
    assert js["computed_poses"] == 12
    _same_results(out, made[1])
    js, err = _run(out, capsys)      # and the repaired store resumes as complete
    assert js["computed_poses"] == 0 and not err.strip()


def test_an_edited_file_inside_the_output_is_not_overwritten(made, tmp_path, capsys):
    out = _copy(made, tmp_path)
    (out / "map.json").write_text('{"my": "notes"}\n')
    rc = main(ARGS + ["--out", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "'map.json', changed since robolobes wrote it" in err[0], err
    assert (out / "map.json").read_text() == '{"my": "notes"}\n'
