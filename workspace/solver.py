"""``solve_map(problem, method)``: lobes at every pose of a map, chunked, stored, resumable, parallel.

Execution (``scheduler``):

* ``"local"`` (default): a pool of ``workers`` processes on this machine (default 2, both cores);
* ``"serial"``: in this process (tests, debugging);
* ``"tcp://HOST:PORT"``: a running Dask scheduler; or a ``distributed.Client`` / ``LocalCluster``
  object. The workers import robolobes and rebuild the robot once each.

The parent process is the only writer of the store: each finished chunk is region-written, then
marked ``done``. A killed or interrupted map resumes from its store; chunks already done are not
recomputed, and because a chunk's numbers depend only on its own poses (:mod:`.compute`), the
resumed map is bitwise equal to an uninterrupted one.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Callable

import numpy as np

from robolobes.core.errors import BadInput

from .compute import ChunkResult, compute_chunk
from .poses import solve_pose, start_pose, target
from .problem import MapMethod, MapProblem
from .store import create_store, open_for_resume, write_chunk

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["MapResult", "solve_map", "pose_table"]


def pose_table(problem: MapProblem) -> dict[str, np.ndarray]:
    """IK of every pose: ``theta`` (P, 6) rad, ``p`` (P, 3) m, ``feed`` (P, 3), ``reason`` (P,) int,
    ``sin_margin`` (P,), ``shoulder_m`` (P,) m, ``message`` (list of str)."""
    case = problem.case
    q0, p0, R0 = start_pose(case)
    vals = problem.pose_values()
    P = problem.n_poses
    out = {"theta": np.full((P, 6), np.nan), "p": np.zeros((P, 3)), "feed": np.zeros((P, 3)),
           "reason": np.zeros(P, int), "sin_margin": np.full(P, np.nan), "shoulder_m": np.full(P, np.nan),
           "message": [""] * P}
    q_prev = q0
    for i in range(P):
        tgt = target(case, p0, R0, offset_m=(vals["x_offset_m"][i], vals["y_offset_m"][i], vals["z_offset_m"][i]),
                     yaw_rad=vals["yaw_rad"][i], tool_rotation_rad=vals["tool_rotation_rad"][i],
                     tilt_rad=vals["tilt_rad"][i], s_m=vals["s_m"][i])
        # along a pass, continue from the previous pose (continuous branch and 2 pi representation)
        ref = q_prev if problem.over == "pass" else q0
        sol = solve_pose(case, tgt, ref)
        out["p"][i], out["feed"][i], out["reason"][i] = tgt.p_m, tgt.feed, sol.reason
        out["theta"][i], out["sin_margin"][i], out["shoulder_m"][i] = sol.theta, sol.sin_margin, sol.shoulder_m
        out["message"][i] = sol.message
        if sol.reachable:
            q_prev = sol.theta
    return out


@dataclass(frozen=True, eq=False)
class MapResult:
    """A lobe map: the problem, the method and the ``xarray.Dataset`` (see :mod:`.store`).

    ``stats``: ``computed_poses`` (poses computed by this call; 0 when the store was complete),
    ``computed_chunks``, ``wall_s``, ``path``.
    """

    problem: MapProblem
    method: MapMethod
    dataset: xr.Dataset
    stats: dict = field(default_factory=dict)

    def summary(self) -> dict:
        """The numbers a user asks first (JSON-able)."""
        ds = self.dataset
        depth = np.asarray(ds["depth_limit_m"].values)
        reach = np.asarray(ds["reachable"].values)
        theta = np.asarray(ds["theta_rad"].values)
        # per pose: lowest limit over the speeds (inf: stable at every speed up to depth_max_m)
        low = np.where(reach, np.min(np.where(np.isnan(depth), np.inf, depth), axis=1), np.nan)
        op = np.asarray(ds["op_depth_limit_m"].values)
        out = {"n_poses": int(depth.shape[0]), "n_speeds": int(depth.shape[1]),
               "n_unreachable": int((~reach).sum()), "n_strict_ok": int(np.asarray(ds["strict_ok"].values).sum()),
               "min_depth_limit_m": None, "worst_pose": None, "best_pose": None,
               "worst_pose_q_deg": None, "best_pose_q_deg": None, "op_rpm": self.problem.op_rpm}
        if reach.any():
            # worst / best pose: lowest / highest of the per-pose lowest limit, ties broken by the
            # limit at the operating speed
            idx = np.flatnonzero(reach)
            order = idx[np.lexsort((op[idx], low[idx]))]
            iw, ib = int(order[0]), int(order[-1])
            out.update(min_depth_limit_m=float(low[iw]), worst_pose=iw, best_pose=ib,
                       worst_pose_q_deg=np.degrees(theta[iw]).tolist(), best_pose_q_deg=np.degrees(theta[ib]).tolist(),
                       best_pose_min_depth_limit_m=float(low[ib]))
            op = np.asarray(ds["op_depth_limit_m"].values)
            out["op_min_depth_limit_m"] = float(np.nanmin(np.where(reach, op, np.nan)))
            out["op_max_depth_limit_m"] = float(np.nanmax(np.where(reach, op, np.nan)))
            err = np.asarray(ds["depth_error_m"].values)
            with np.errstate(invalid="ignore", divide="ignore"):
                rel = np.where(np.isfinite(depth) & np.isfinite(err) & reach[:, None], err / depth, np.nan)
            out["max_depth_error_rel"] = float(np.nanmax(rel)) if np.isfinite(rel).any() else None
            out["n_unconverged"] = int((np.asarray(ds["unconverged"].values) == 1).sum())
            for k in ("truncation_static_error", "truncation_frf_error"):
                v = np.asarray(ds[k].values)
                out[f"max_{k}"] = float(np.nanmax(v)) if np.isfinite(v).any() else None
        out.update(computed_poses=self.stats.get("computed_poses"), wall_s=self.stats.get("wall_s"))
        return out


def _chunks(P: int, size: int) -> list[tuple[int, int]]:
    return [(a, min(a + size, P)) for a in range(0, P, size)]


def _args(problem, method, poses, a, b):
    return (problem, method, a, poses["theta"][a:b], poses["feed"][a:b], poses["reason"][a:b] <= 1)


def _run_serial(tasks, on_result):
    for t in tasks:
        on_result(compute_chunk(*t))


def _run_pool(tasks, on_result, workers: int):
    """The local pool: workers ignore Ctrl-C and exit when this process dies (``core.interrupt``);
    on any exit from here (an interruption included) they are terminated, not awaited."""
    import multiprocessing as mp
    import os
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

    from robolobes.core import interrupt

    ex = ProcessPoolExecutor(max_workers=workers, mp_context=mp.get_context("spawn"),
                             initializer=interrupt.worker_init, initargs=(os.getpid(),))
    try:
        # the workers start with SIGINT/SIGTERM held back (then ignore SIGINT); this process finishes
        # starting them before it acts on a signal (a half-sent start would crash the worker)
        with interrupt.deferred(), interrupt.blocked():
            pending = {ex.submit(compute_chunk, *t) for t in tasks}
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for f in done:
                on_result(f.result())
    finally:
        _stop_pool(ex)


def _stop_pool(ex) -> None:
    """Cancel what is queued, terminate the workers (a chunk takes seconds to minutes: waiting for it
    would hang an interrupted map) and reap them."""
    procs = list(getattr(ex, "_processes", {}).values())   # private, but the only handle on the workers
    ex.shutdown(wait=False, cancel_futures=True)
    for proc in procs:
        if proc.is_alive():
            proc.terminate()
    for proc in procs:
        proc.join(5)


def _run_dask(tasks, on_result, scheduler):
    from distributed import Client, as_completed

    own = isinstance(scheduler, str)
    if own:
        client = Client(scheduler, timeout="20s")
    elif hasattr(scheduler, "scheduler_address") and not hasattr(scheduler, "submit"):
        client, own = Client(scheduler), True   # a cluster object
    else:
        client = scheduler
    futures = []
    try:
        futures = [client.submit(compute_chunk, *t, pure=False) for t in tasks]
        for f in as_completed(futures):
            on_result(f.result())
    finally:
        for f in futures:
            f.cancel()
        if own:
            client.close()


def solve_map(problem: MapProblem, method: MapMethod | None = None, *, path: str | Path | None = None,
              scheduler="local", workers: int = 2, progress: Callable[[int, int], None] | None = None,
              on_chunk: Callable[[int], None] | None = None) -> MapResult:
    """Lobes at every pose of ``problem``.

    Parameters
    ----------
    path : str or Path, optional
        The zarr store (``map.zarr``). Created whole first; an existing store made by the same
        inputs is resumed (only chunks not ``done`` are computed); another existing path raises
        :class:`BadInput`. Default: a temporary store, removed after loading.
    scheduler : "local", "serial", "tcp://HOST:PORT", or a distributed Client / cluster
    workers : int
        Processes of the local pool.
    progress : callable(done_poses, total_poses), optional
    on_chunk : callable(n_chunks_written), optional
        Called after each chunk is stored (a test hook: raising there interrupts the map).

    Examples
    --------
    One pose (the steel case's own placement) at the case's speed, in this process:

    >>> from robolobes.cases import load_case
    >>> from robolobes.workspace import MapProblem
    >>> pb = MapProblem.make(load_case("tx200-steel"), "basic", "placement", n=1, x_range_m=(0.0, 0.0),
    ...                      y_range_m=(0.0, 0.0), speeds_rpm=[3100.0])
    >>> s = solve_map(pb, scheduler="serial").summary()
    >>> s["n_poses"], 0.1e-3 < s["min_depth_limit_m"] < 1.6e-3   # the cut's 1.6 mm is above the limit
    (1, True)
    """
    import tempfile

    import xarray as xr

    method = MapMethod() if method is None else method
    if not isinstance(problem, MapProblem):
        raise BadInput(f"problem must be a MapProblem, got {type(problem).__name__}")
    if isinstance(workers, bool) or not isinstance(workers, int) or not 1 <= workers <= 256:
        raise BadInput(f"workers must be an integer from 1 to 256, got {workers!r}")
    t0 = time.perf_counter()
    tmpdir = None
    if path is None:
        tmpdir = tempfile.TemporaryDirectory(prefix="robolobes-map-")
        path = Path(tmpdir.name) / "map.zarr"
    path = Path(path)
    poses = pose_table(problem)
    if path.exists():
        done = open_for_resume(path, problem, method)
    else:
        create_store(path, problem, method, poses)
        done = np.zeros(problem.n_poses, bool)
    P = problem.n_poses
    chunks = _chunks(P, method.chunk_poses)
    todo = [(a, b) for a, b in chunks if not done[a:b].all()]
    tasks = [_args(problem, method, poses, a, b) for a, b in todo]
    counter = {"chunks": 0, "poses": 0, "done": int(done.sum())}
    if progress is not None:
        progress(counter["done"], P)

    def on_result(res: ChunkResult):
        n = len(res.op_depth_limit_m)
        write_chunk(path, res, n)
        counter["chunks"] += 1
        counter["poses"] += n
        counter["done"] += n
        if progress is not None:
            progress(counter["done"], P)
        if on_chunk is not None:
            on_chunk(counter["chunks"])

    try:
        if not tasks:
            pass
        elif scheduler == "serial" or (scheduler == "local" and workers == 1) or len(tasks) == 1:
            _run_serial(tasks, on_result)
        elif scheduler == "local":
            _run_pool(tasks, on_result, min(workers, len(tasks)))
        else:
            _run_dask(tasks, on_result, scheduler)
        ds = xr.open_zarr(path, consolidated=False).load()
    finally:
        if tmpdir is not None:
            tmpdir.cleanup()
    stats = {"computed_poses": counter["poses"], "computed_chunks": counter["chunks"],
             "wall_s": time.perf_counter() - t0, "path": None if tmpdir is not None else str(path),
             "messages": {i: m for i, m in enumerate(poses["message"]) if m}}
    return MapResult(problem=problem, method=method, dataset=ds, stats=stats)
