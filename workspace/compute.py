"""The work of one chunk of poses: linearize, reduce, lobes, deflection. Pure and deterministic.

A chunk's numbers depend only on the problem, the method and the chunk's own poses (never on
which chunks ran before in the same process, nor on the worker), so a resumed map and a map run
on a cluster are bitwise equal to an uninterrupted local run. BLAS runs single-threaded inside
(:func:`threadpoolctl.threadpool_limits`): the matrices are small and two processes on two cores
each spinning BLAS threads run several times slower.
"""

from __future__ import annotations

import hashlib
import pickle
from dataclasses import dataclass, replace

import numpy as np

from robolobes.lobes import (LobeProblem, ModalStructure, PhysicalStructure, ReducedStructure, RefinedSDM,
                             SemiDiscretization, StateSpace, TruncationReport, in_series, solve)

from .forces import mean_force_cut_frame, static_deflection
from .problem import MapMethod, MapProblem, series_modes, tool_oscillators

__all__ = ["build_robot", "pose_structure", "compute_chunk", "BIFURCATIONS", "ChunkResult"]

#: bifurcation codes stored in a map (int8), by name
BIFURCATIONS = ("none", "hopf", "flip", "fold")

_ROBOTS: dict = {}


def build_robot(problem: MapProblem):
    """The flexible robot of the problem (cached per process): the variant plus the case's
    ``[[elements]]`` (an identified model TOML is a case TOML with its elements, loaded as the case).
    The one place a map builds a robot."""
    tool = tool_oscillators(problem)
    key = hashlib.sha256(pickle.dumps((problem.case.robot, problem.variant, problem.model_file, tool))).hexdigest()
    robot = _ROBOTS.get(key)
    if robot is None:
        from robolobes.linearize import build_model
        from robolobes.lobes.tooltip import with_tool

        robot = _ROBOTS[key] = with_tool(build_model(problem.case.robot, problem.variant), tool)
    return robot


def _series(robot_ss: StateSpace, tool_modes: tuple) -> StateSpace:
    """Tool-tip modes in series with the robot: the same force, displacements added
    (``H = H_robot + H_tool``): block-diagonal ``A``, stacked ``B``, side-by-side ``S``."""
    if not tool_modes:
        return robot_ss
    return in_series(robot_ss, ModalStructure(tuple(tool_modes)).state_space())


def _cutoff_hz(robot, max_freq_hz: float) -> float:
    """The truncation frequency: ``max_freq_hz``, raised to twice the highest rigid-base frequency
    of a tool element in ``robot`` (TCP oscillators, one-axis or planar: their modes must stay; on the robot
    they rise by ``sqrt(1 + m / M_apparent)``, far less than a factor 2 for a tool lighter than
    the robot's apparent mass at the TCP)."""
    from robolobes.linearize.tool import TcpOscillator

    cutoff = float(max_freq_hz)
    for e in robot.elements:
        if isinstance(e, TcpOscillator):
            cutoff = max(cutoff, 2.0 * float(np.max(e.freq_hz)))
    return cutoff


def pose_structure(problem: MapProblem, method: MapMethod, lin, feed: np.ndarray):
    """The tool-tip structure at one pose (cut frame of ``feed``): the robot (with the tool's TCP
    oscillators, if any), truncated to ``method.reduce_max_freq_hz`` (raised by :func:`_cutoff_hz`
    so the TCP oscillators keep their modes; with ``method.reduce_residual`` the dropped modes are
    replaced by their static compliance, :func:`_with_residual`) with its error report, plus any
    tool modes given as lobes modes in series (never truncated).

    Returns ``(structure, report)``; ``report`` is None without truncation.
    """
    phys = PhysicalStructure.from_linear(lin, feed)
    series = series_modes(problem)
    if method.reduce_max_freq_hz is None:
        if not series:
            return phys, None
        ss = phys.state_space()
        return ReducedStructure(_series(ss, series), TruncationReport((), (), 0.0, 0.0, (0.0, 0.0))), None
    cutoff = _cutoff_hz(lin.robot, method.reduce_max_freq_hz)
    if method.reduce_residual:
        red = _with_residual(phys, cutoff, tuple(method.error_band_hz))
    else:
        red = phys.truncated(max_freq_hz=cutoff, band_hz=tuple(method.error_band_hz))
    if series:
        red = ReducedStructure(_series(red.ss, series), red.report)
    return red, red.report


def _with_residual(phys: PhysicalStructure, cutoff_hz: float, band_hz: tuple) -> ReducedStructure:
    """The modes up to ``cutoff_hz`` plus a residual mode with the static compliance of the others
    (``lobes.basis.truncated_with_residual``, residual at the lowest dropped mode). Its report is
    of the cut-plane rows (x_c, y_c), the ones the residual restores and the chip thickness sees:
    static error ``||(G_red(0) - G(0))[:2]|| / ||G(0)[:2]||`` (rounding level) and FRF error
    ``max_band ||(G_red - G)[:2]|| / max_band ||G[:2]||`` over ``band_hz`` (4001 points, as
    ``PhysicalStructure.truncated``)."""
    from robolobes.lobes.basis import truncated_with_residual

    red = truncated_with_residual(phys, cutoff_hz)
    lo, hi = float(band_hz[0]), float(band_hz[1])
    full = phys.state_space()
    w = 2 * np.pi * np.linspace(lo, hi, 4001)
    Hf, Hr = full.receptance(w)[:2], red.ss.receptance(w)[:2]
    frf = float(np.max(np.linalg.norm(Hr - Hf, ord=2, axis=(0, 1))) / np.max(np.linalg.norm(Hf, ord=2, axis=(0, 1))))
    rep = replace(red.report, frf_rel_error=frf, band_hz=(lo, hi))
    return ReducedStructure(red.ss, rep, red.basis)


@dataclass(frozen=True)
class ChunkResult:
    """Arrays of one chunk of ``P`` poses (NaN where a pose is unreachable).

    ``depth_limit_m, chatter_freq_hz`` (P, S); ``bifurcation`` (P, S) int8 codes of
    :data:`BIFURCATIONS`; ``op_depth_limit_m, op_chatter_freq_hz`` (P,) at the operating speed;
    ``op_bifurcation`` (P,) int8; ``deflection_m`` (P, 3) cut frame; ``static_error, frf_error``
    (P,) of the truncation; ``n_kept_modes`` (P,) int16; ``depth_error_m`` (P, S) m and
    ``unconverged`` (P, S) int8 (1 unconverged, 0 converged, -1 no estimate) of the limits.
    """

    start: int
    depth_limit_m: np.ndarray
    chatter_freq_hz: np.ndarray
    bifurcation: np.ndarray
    op_depth_limit_m: np.ndarray
    op_chatter_freq_hz: np.ndarray
    op_bifurcation: np.ndarray
    deflection_m: np.ndarray
    static_error: np.ndarray
    frf_error: np.ndarray
    n_kept_modes: np.ndarray
    depth_error_m: np.ndarray
    unconverged: np.ndarray


def _bif_codes(b: np.ndarray) -> np.ndarray:
    return np.array([BIFURCATIONS.index(str(x)) for x in b], dtype=np.int8)


def compute_chunk(problem: MapProblem, method: MapMethod, start: int, theta: np.ndarray,
                  feed: np.ndarray, reachable: np.ndarray) -> ChunkResult:
    """Solve the poses ``start .. start + P - 1``: ``theta`` (P, 6) rad, ``feed`` (P, 3) unit (base
    frame), ``reachable`` (P,) bool."""
    from threadpoolctl import threadpool_limits

    from robolobes.linearize import linearize

    with threadpool_limits(1):
        P, S = len(theta), len(problem.speeds_rpm)
        out = dict(depth_limit_m=np.full((P, S), np.nan), chatter_freq_hz=np.full((P, S), np.nan),
                   bifurcation=np.full((P, S), -1, np.int8), op_depth_limit_m=np.full(P, np.nan),
                   op_chatter_freq_hz=np.full(P, np.nan), op_bifurcation=np.full(P, -1, np.int8),
                   deflection_m=np.full((P, 3), np.nan), static_error=np.full(P, np.nan),
                   frf_error=np.full(P, np.nan), n_kept_modes=np.full(P, -1, np.int16),
                   depth_error_m=np.full((P, S), np.nan), unconverged=np.full((P, S), -1, np.int8))
        case = problem.case
        robot = build_robot(problem)
        speeds = np.append(problem.speeds_rpm, problem.op_rpm)
        sdm = SemiDiscretization(m=method.m, prescan_m=method.prescan_m, search=method.search)
        if method.tol is not None:
            sdm = RefinedSDM(sdm, tol=method.tol, m_max=max(320, 2 * method.m))
        f_mean = mean_force_cut_frame(case.tool, case.cut, case.law)
        for i in range(P):
            if not reachable[i]:
                continue
            lin = linearize(robot, theta[i])
            structure, report = pose_structure(problem, method, lin, feed[i])
            cut = replace(case.cut, feed_direction=tuple(feed[i]), spindle_rpm=problem.op_rpm)
            res = solve(LobeProblem(structure, case.tool, cut, case.law), sdm, speeds,
                        depth_max_m=method.depth_max_m, rtol=method.rtol, chunk=len(speeds))
            out["depth_limit_m"][i] = res.depth_limit_m[:S]
            out["chatter_freq_hz"][i] = res.chatter_freq_hz[:S]
            out["bifurcation"][i] = _bif_codes(res.bifurcation[:S])
            out["op_depth_limit_m"][i] = res.depth_limit_m[S]
            out["op_chatter_freq_hz"][i] = res.chatter_freq_hz[S]
            out["op_bifurcation"][i] = _bif_codes(res.bifurcation[S:])[0]
            out["depth_error_m"][i] = res.depth_error_m[:S]
            assert res.status is not None
            st = res.status[:S]
            out["unconverged"][i] = np.where(st == "unconverged", 1, np.where(st == "converged", 0, -1))
            out["deflection_m"][i] = static_deflection(lin.compliance("cut", feed[i]), f_mean)
            if report is not None:
                out["static_error"][i] = report.static_compliance_rel_error
                out["frf_error"][i] = report.frf_rel_error
                out["n_kept_modes"][i] = len(report.kept_freq_hz)
        return ChunkResult(start=int(start), **out)
