"""The output rule at the library level: ``solve_map(problem, method, path=...)`` refuses, with
:class:`BadInput` and nothing changed or deleted, a path that is a file, a directory that is not a
robolobes map store (empty, with a user's files, or another zarr store), a map store of other
inputs, and a stale partial store that is not one of ours. A store of the same inputs resumes."""

import os

import numpy as np
import pytest

from robolobes.cases import load_case
from robolobes.core.errors import BadInput
from robolobes.workspace import MapMethod, MapProblem, solve_map

FAST = MapMethod(m=20, reduce_max_freq_hz=None, prescan_m=None, chunk_poses=1, tol=None)  # one level: cheap


@pytest.fixture(scope="module")
def problem():
    case = load_case("tx200-steel")
    return MapProblem.make(case, "basic", "placement", n=1, x_range_m=(0.0, 0.0), y_range_m=(0.0, 0.0),
                           speeds_rpm=np.array([3100.0]))


def _snapshot(path):
    """Every file under ``path`` (or the file itself) with its bytes."""
    if path.is_file():
        return {path.name: path.read_bytes()}
    return {os.path.relpath(os.path.join(r, f), path): open(os.path.join(r, f), "rb").read()
            for r, _, files in os.walk(path) for f in files} | {"dirs": sorted(r for r, _, _ in os.walk(path))}


def _refused(problem, path, words, method=FAST):
    before = _snapshot(path)
    with pytest.raises(BadInput, match=words):
        solve_map(problem, method, path=path, scheduler="serial")
    assert _snapshot(path) == before
    assert not (path.parent / f".{path.name}.partial").exists()


def test_an_existing_file_is_refused(problem, tmp_path):
    f = tmp_path / "map.zarr"
    f.write_text("a user's file")
    _refused(problem, f, "is an existing file")


def test_a_directory_that_is_not_a_map_store_is_refused(problem, tmp_path):
    d = tmp_path / "mine"
    d.mkdir()
    _refused(problem, d, "is an empty directory that is not a robolobes map store")
    (d / "notes.txt").write_text("keep me")
    _refused(problem, d, "is a directory that is not a robolobes map store")


def test_another_zarr_store_is_refused(problem, tmp_path):
    import xarray as xr

    z = tmp_path / "other.zarr"
    xr.Dataset({"a": ("x", np.arange(3.0))}).to_zarr(z, consolidated=False)
    _refused(problem, z, "not a robolobes map store")


def test_a_store_of_other_inputs_is_refused_and_the_same_inputs_resume(problem, tmp_path):
    path = tmp_path / "map.zarr"
    first = solve_map(problem, FAST, path=path, scheduler="serial")
    assert first.stats["computed_poses"] == 1
    other_problem = MapProblem.make(problem.case, "basic", "placement", n=1, x_range_m=(0.0, 0.0),
                                    y_range_m=(0.0, 0.0), speeds_rpm=np.array([3000.0]))
    _refused(other_problem, path, "holds a map of other inputs")
    _refused(problem, path, "holds a map of other inputs", method=MapMethod(m=21, reduce_max_freq_hz=None,
                                                                            prescan_m=None, chunk_poses=1))
    from dataclasses import replace

    truncated = replace(FAST, reduce_max_freq_hz=100.0)   # opt-in truncation (basic: modes 15.8-142 Hz): an input
    _refused(problem, path, "holds a map of other inputs", method=truncated)
    solve_map(problem, truncated, path=tmp_path / "t.zarr", scheduler="serial")
    _refused(problem, tmp_path / "t.zarr", "holds a map of other inputs",
             method=replace(truncated, reduce_residual=True))
    again = solve_map(problem, FAST, path=path, scheduler="serial")
    assert again.stats["computed_poses"] == 0
    np.testing.assert_array_equal(again.dataset["depth_limit_m"].values, first.dataset["depth_limit_m"].values)


def test_a_stale_partial_that_is_not_ours_is_kept(problem, tmp_path):
    stale = tmp_path / ".map.zarr.partial"
    stale.mkdir()
    (stale / "notes.txt").write_text("keep me")
    with pytest.raises(BadInput, match="not a partial robolobes map store"):
        solve_map(problem, FAST, path=tmp_path / "map.zarr", scheduler="serial")
    assert (stale / "notes.txt").read_text() == "keep me" and not (tmp_path / "map.zarr").exists()
