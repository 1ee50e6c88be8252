"""The map's zarr store: created whole first, then filled chunk by chunk, with an explicit ``done``.

Layout (xarray ``Dataset``, dims ``pose``, ``rpm``, ``axis`` = x_c, y_c, z_c, ``joint``):

* inputs, written at creation: ``theta_rad`` (pose, joint), ``tcp_position_m`` (pose, 3 as
  ``axis`` in base x, y, z), ``feed_direction`` (pose, axis; base frame), ``reason`` (int8, see
  ``attrs['reasons']``), ``reachable``, ``strict_ok`` (inside the datasheet ranges without the 5 deg
  tolerance), ``sin_margin`` and ``shoulder_m`` (distance to singularities), the swept axes as
  coordinates along ``pose``;
* results, region-written per chunk: ``depth_limit_m`` and ``chatter_freq_hz`` (pose, rpm),
  ``bifurcation`` (int8 codes, ``attrs['flag_meanings']``), ``op_depth_limit_m``,
  ``op_chatter_freq_hz``, ``op_bifurcation`` at the operating speed, ``deflection_m`` (pose, axis;
  cut frame), ``truncation_static_error``, ``truncation_frf_error``, ``n_kept_modes``,
  ``depth_error_m`` and ``unconverged`` (pose, rpm: the limits' error estimate and status);
* ``done`` (pose, bool): True once the pose's chunk is written.

Integrity: every chunk of every array is written, also one that holds only fill values (zarr's
``write_empty_chunks``), and carries a CRC-32C checksum (zarr's ``crc32c`` codec, after Zstandard
compression). A resumed store is verified before it is trusted (:func:`verify_store`): a chunk
marked done whose file of any result array is missing, fails its checksum or cannot be decoded is
computed again, with a line on stderr saying which; a missing or damaged ``done`` array counts as
"nothing done". Damaged inputs (the pose table written at creation) cannot be recomputed in place:
the store is refused with one line. The checksum lives in each chunk file, written by the process
that writes the chunk, so no shared list of checksums can race between writers.

``depth_limit_m`` is ``inf`` where the cut is stable up to the depth searched, NaN where the pose is
unreachable. The store's attributes record the provenance (``inputs_sha256`` of the problem and
method): a store is only resumed by the same inputs.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np

from robolobes.core.errors import BadInput
from robolobes.core.io import provenance

from .compute import BIFURCATIONS, ChunkResult
from .poses import REASONS

__all__ = ["create_store", "open_for_resume", "write_chunk", "verify_store", "RESULT_VARS", "StoreDamageWarning"]


class StoreDamageWarning(UserWarning):
    """A chunk of a resumed map store is missing or damaged and is computed again."""

RESULT_VARS = {
    # name: (dims, dtype, fill, units, description)
    "depth_limit_m": (("pose", "rpm"), "f8", np.nan, "m", "critical axial depth (inf: stable up to depth_max_m)"),
    "chatter_freq_hz": (("pose", "rpm"), "f8", np.nan, "Hz", "chatter frequency at the limit"),
    "bifurcation": (("pose", "rpm"), "i1", -1, "1", "bifurcation code at the limit"),
    "op_depth_limit_m": (("pose",), "f8", np.nan, "m", "critical depth at the operating speed"),
    "op_chatter_freq_hz": (("pose",), "f8", np.nan, "Hz", "chatter frequency at the operating speed"),
    "op_bifurcation": (("pose",), "i1", -1, "1", "bifurcation code at the operating speed"),
    "deflection_m": (("pose", "axis"), "f8", np.nan, "m", "static TCP deflection under the mean cutting force, cut frame"),
    "truncation_static_error": (("pose",), "f8", np.nan, "1", "modal truncation: relative static compliance error"),
    "truncation_frf_error": (("pose",), "f8", np.nan, "1", "modal truncation: relative FRF error in the band"),
    "n_kept_modes": (("pose",), "i2", -1, "1", "modes kept by the truncation"),
    "depth_error_m": (("pose", "rpm"), "f8", np.nan, "m",
                      "error estimate of depth_limit_m (lobes.refine; NaN: one level, no estimate)"),
    "unconverged": (("pose", "rpm"), "i1", -1, "1",
                    "1: the limit did not reach the error target by m_max, 0: it did, -1: no estimate"),
}
_FIELD = {"truncation_static_error": "static_error", "truncation_frf_error": "frf_error"}


def _xr():
    import xarray as xr

    return xr


def _inputs_hash(problem, method) -> dict:
    # layout 2: every chunk written and checksummed (a layout-1 store cannot be verified);
    # layout 3: with the limits' error estimate and status (depth_error_m, unconverged)
    return provenance({"problem": problem.describe(), "method": method.describe(), "layout": 3})


def _codecs() -> dict:
    """Chunk encoding of every array: Zstandard, then a CRC-32C checksum of the compressed bytes."""
    from zarr.codecs import Crc32cCodec, ZstdCodec

    return {"compressors": [ZstdCodec(level=0), Crc32cCodec()]}


def create_store(path: Path, problem, method, poses: dict) -> None:
    """Write the whole store: inputs filled, results at their fill values, ``done`` False.

    Written into ``path.parent/.path.partial`` and renamed onto ``path`` only when complete, so a
    store either exists whole or not at all. ``poses``: arrays from :func:`solver.pose_table`.
    """
    xr = _xr()
    P, S = problem.n_poses, len(problem.speeds_rpm)
    # dims "axis" (x, y, z of the variable's frame) and "joint" (A1..A6) carry no coordinate: zarr v3
    # has no specified string type; their names are in the attributes
    coords = {"pose": np.arange(P), "rpm": ("rpm", problem.speeds_rpm, {"units": "rpm"})}
    for name, vals in problem.pose_values().items():
        if name in dict(problem.axes):
            unit = name.rsplit("_", 1)[-1]
            coords[name] = ("pose", vals, {"units": unit})
    data = {
        "theta_rad": (("pose", "joint"), poses["theta"], {"units": "rad"}),
        "tcp_position_m": (("pose", "axis"), poses["p"], {"units": "m", "frame": "base"}),
        "feed_direction": (("pose", "axis"), poses["feed"], {"units": "1", "frame": "base"}),
        "reason": ("pose", poses["reason"].astype("i1"), {"flag_values": list(REASONS), "flag_meanings": list(REASONS.values())}),
        "reachable": ("pose", poses["reason"] <= 1),
        "strict_ok": ("pose", poses["reason"] == 0),
        "sin_margin": ("pose", poses["sin_margin"], {"units": "1", "description": "min(|sin psi_elbow|, |sin q5|)"}),
        "shoulder_m": ("pose", poses["shoulder_m"], {"units": "m"}),
        "done": ("pose", np.zeros(P, bool)),
    }
    for name, (dims, dt, fill, unit, desc) in RESULT_VARS.items():
        shape = tuple({"pose": P, "rpm": S, "axis": 3}[d] for d in dims)
        attrs = {"units": unit, "description": desc}
        if name in ("bifurcation", "op_bifurcation"):
            attrs.update(flag_values=list(range(-1, len(BIFURCATIONS))), flag_meanings=["not computed"] + list(BIFURCATIONS))
        if name == "deflection_m":
            attrs["frame"] = "cut (x_c feed, y_c normal, z_c into the spindle)"
        data[name] = (dims, np.full(shape, fill, dtype=dt), attrs)
    prov = _inputs_hash(problem, method)
    attrs = {"robolobes_map": 1, "inputs": json.dumps({"problem": problem.describe(), "method": method.describe()}),
             "op_rpm": problem.op_rpm, "axis_names": ["x", "y", "z"],
             "joint_names": [j.name for j in problem.case.robot.joints], "over": problem.over, "variant": problem.variant, **prov}
    ds = xr.Dataset(data, coords=coords, attrs=attrs)
    cp = method.chunk_poses
    enc = {v: {"chunks": tuple(cp if d == "pose" else ds[v].sizes[d] for d in ds[v].dims), **_codecs()}
           for v in ds.data_vars}
    tmp = path.parent / f".{path.name}.partial"
    if tmp.exists():   # a create that was killed: removed only if it is one of ours
        if not _is_map_store(tmp):
            raise BadInput(f"{tmp} exists and is not a partial robolobes map store; move it away or choose "
                           f"another path")
        shutil.rmtree(tmp)
    from robolobes.core.interrupt import deferred

    with deferred():   # a Ctrl-C waits until the store exists whole (or its creation failed)
        try:
            ds.to_zarr(tmp, mode="w", encoding=enc, consolidated=False, write_empty_chunks=True)
            tmp.rename(path)
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            raise


def _is_map_store(path: Path) -> bool:
    """A directory whose zarr group attributes (``zarr.json`` of zarr v3, ``.zattrs`` of v2) carry
    the ``robolobes_map`` mark."""
    for name, get in (("zarr.json", lambda m: m.get("attributes", {})), (".zattrs", lambda m: m)):
        meta = path / name
        try:
            if path.is_dir() and meta.is_file() and get(json.loads(meta.read_text())).get("robolobes_map") == 1:
                return True
        except (OSError, ValueError, AttributeError):
            pass
    return False


def open_for_resume(path: Path, problem, method):
    """Open an existing store made by the same inputs. ``BadInput`` (nothing is changed or
    deleted) if ``path`` is a file, a directory that is not a robolobes map store (empty or not,
    or another zarr store), or a map store whose recorded inputs differ. Returns the ``done``
    array (P,) bool."""
    xr = _xr()
    valid = "give a path that does not exist (the store is created there) or a map store of the same inputs"
    if not path.is_dir():
        raise BadInput(f"{path} is an existing file, not a robolobes map store; {valid}")
    if not _is_map_store(path):
        kind = "an empty directory" if not any(path.iterdir()) else "a directory"
        raise BadInput(f"{path} is {kind} that is not a robolobes map store; {valid}")
    try:
        ds = xr.open_zarr(path, consolidated=False)
    except Exception as e:  # marked, but not readable
        raise BadInput(f"{path} is a damaged robolobes map store ({type(e).__name__}: {e}); {valid}") from None
    want = _inputs_hash(problem, method)["inputs_sha256"]
    if ds.attrs.get("inputs_sha256") != want:
        raise BadInput(f"{path} holds a map of other inputs (inputs_sha256 {ds.attrs.get('inputs_sha256', '?')[:12]}, "
                       f"these inputs {want[:12]}); use another --out or the same options to resume")
    return verify_store(path, _read_done(path, problem.n_poses, method.chunk_poses), method.chunk_poses)


def _read_done(path: Path, P: int, cp: int) -> np.ndarray:
    """The ``done`` array; a missing or damaged one is rewritten as "nothing done" (one warning)."""
    import warnings

    import zarr

    group = zarr.open_group(str(path), mode="r")
    why = next((w for k in range(-(-P // cp)) if (w := _chunk_problem(group, path, "done", k, cp))), None)
    arr = group["done"] if why is None else None
    if isinstance(arr, zarr.Array):
        done = np.asarray(arr[:], dtype=bool)
        if done.shape == (P,):
            return done
        why = f"done has shape {done.shape}, not ({P},)"
    warnings.warn(f"{path.name}: {why}; every chunk is computed again", StoreDamageWarning, stacklevel=2)
    xr = _xr()
    # mode "a" rewrites the group's attributes with the dataset's: keep the store's own
    attrs = dict(group.attrs)
    xr.Dataset({"done": ("pose", np.zeros(P, bool))}, attrs=attrs).to_zarr(
        path, mode="a", consolidated=False, write_empty_chunks=True,
        encoding={"done": {"chunks": (cp,), **_codecs()}} if "done" not in group else None)
    return np.zeros(P, bool)


def write_chunk(path: Path, res: ChunkResult, n: int) -> None:
    """Region-write one finished chunk of ``n`` poses (results and ``done``)."""
    xr = _xr()
    data = {}
    for name, (dims, dt, _, _, _) in RESULT_VARS.items():
        data[name] = (dims, np.asarray(getattr(res, _FIELD.get(name, name))).astype(dt))
    region = {"pose": slice(res.start, res.start + n)}
    from robolobes.core.interrupt import deferred

    with deferred():   # a Ctrl-C waits for the chunk's files: none is left half written
        _write_region(path, xr.Dataset(data), region, n)


def _write_region(path: Path, ds, region: dict, n: int) -> None:
    xr = _xr()
    ds.to_zarr(path, region=region, consolidated=False, write_empty_chunks=True)
    # ``done`` last, in its own write: a kill between the two leaves the chunk "not done"
    xr.Dataset({"done": ("pose", np.ones(n, bool))}).to_zarr(path, region=region, consolidated=False,
                                                             write_empty_chunks=True)


def _chunk_problem(group, path: Path, name: str, k: int, cp: int) -> str | None:
    """Why chunk ``k`` (poses ``k cp`` ..) of array ``name`` cannot be trusted, or None."""
    import zarr

    if name not in group:
        return f"array {name} is missing"
    arr = group[name]
    if not isinstance(arr, zarr.Array):
        return f"{name} is not an array"
    key = arr.metadata.encode_chunk_key((k,) + (0,) * (arr.ndim - 1))
    if not (path / name / key).is_file():
        return f"{name}/{key} is missing"
    try:
        arr[k * cp:(k + 1) * cp]
    except Exception as e:   # zarr/numcodecs raise ValueError, RuntimeError, ... for a damaged chunk
        why = "fails its checksum" if "checksum" in str(e).lower() else f"cannot be decoded ({type(e).__name__})"
        return f"{name}/{key} {why}"
    return None


def verify_store(path: Path, done: np.ndarray, chunk_poses: int) -> np.ndarray:
    """``done`` with every chunk whose result files are missing or damaged set back to False.

    Warns (:class:`StoreDamageWarning`, one line per chunk) naming the chunk, its poses and the
    first bad file. ``BadInput`` if an input array (written at creation) is damaged."""
    import warnings

    import zarr

    group = zarr.open_group(str(path), mode="r")
    P = len(done)
    done = done.copy()
    inputs = [n for n in ("theta_rad", "tcp_position_m", "feed_direction", "reason", "reachable", "strict_ok",
                          "sin_margin", "shoulder_m")]
    for k in range(-(-P // chunk_poses)):
        a, b = k * chunk_poses, min((k + 1) * chunk_poses, P)
        for name in inputs:
            why = _chunk_problem(group, path, name, k, chunk_poses)
            if why is not None:
                raise BadInput(f"{path} is a damaged robolobes map store: {why} (an input written at creation); "
                               "delete it to compute the map again")
        if not done[a:b].all():
            continue
        why = next((w for n in RESULT_VARS if (w := _chunk_problem(group, path, n, k, chunk_poses))), None)
        if why is not None:
            warnings.warn(f"{path.name}: chunk {k} (poses {a}..{b - 1}) was marked done but {why}; computing it "
                          "again", StoreDamageWarning, stacklevel=2)
            done[a:b] = False
    return done
