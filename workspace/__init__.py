"""Across the workspace: lobe maps over poses and placements, their storage, and optimization.

Problem / method / solve, as in :mod:`robolobes.lobes`::

    problem = MapProblem.make(case, "orthogonal", "placement", n=1000)
    result = solve_map(problem, MapMethod(), path="out/map.zarr")     # resumable, parallel
    result.dataset["depth_limit_m"]                                   # xarray, dims (pose, rpm)
"""

if __name__ != "robolobes.workspace":  # this folder imported by itself (from the repository root): a second copy
    raise ImportError(f"{__name__!r} is the folder of the robolobes.workspace package: import robolobes.workspace instead")

from .compute import BIFURCATIONS, build_robot, compute_chunk, pose_structure
from .forces import mean_force_cut_frame, static_deflection
from .poses import REASONS, PoseSolution, PoseTarget, solve_pose, start_pose, target
from .problem import AXES, OVER, MapMethod, MapProblem
from .solver import MapResult, pose_table, solve_map

__all__ = ["MapProblem", "MapMethod", "MapResult", "solve_map", "pose_table", "compute_chunk", "build_robot",
           "pose_structure", "mean_force_cut_frame", "static_deflection", "REASONS", "BIFURCATIONS", "AXES", "OVER",
           "PoseSolution", "PoseTarget", "solve_pose", "start_pose", "target"]
