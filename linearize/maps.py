"""Pose maps: how the robot's modes and TCP stiffness change along the pass and over the workspace.

The robot's dynamics depend on its configuration; these maps linearize it at many poses
(:func:`linearize.linear.linearize_many`) and tabulate, per pose, the natural frequencies, damping
ratios and static TCP stiffness (base frame). Poses come from the pass (:class:`linearize.path.Pass`)
or from a grid of TCP positions at a fixed tool orientation, solved by the closed-form IK on the
branch of a reference pose; targets that are unreachable, singular or out of the joint ranges are
kept as NaN rows with the reason, never silently dropped.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from robolobes.core.errors import BadInput

from robolobes.core.threads import blas_single_threaded

from .kinematics import KinematicsError, JointLimitWarning, ik
from .linear import linearize_many
from .model import FlexibleRobot

__all__ = ["PoseMap", "pass_map", "grid_map"]


@dataclass(frozen=True)
class PoseMap:
    """Modes and TCP stiffness at P poses.

    Attributes
    ----------
    tcp_position_m : array (P, 3)          target TCP positions, base frame
    theta : array (P, n_joints), rad       motor angles (NaN where the target failed)
    freq_hz : array (P, n_modes)           undamped natural frequencies
    damping_ratio : array (P, n_modes)
    tcp_stiffness_n_per_m : array (P, 3, 3)  static TCP stiffness, base frame
    path_s_m : array (P,) or None          path coordinate, for pass maps
    failures : tuple of (int, str)         index and reason of each target that has no pose
    """

    tcp_position_m: np.ndarray
    theta: np.ndarray
    freq_hz: np.ndarray
    damping_ratio: np.ndarray
    tcp_stiffness_n_per_m: np.ndarray
    path_s_m: np.ndarray | None
    failures: tuple[tuple[int, str], ...]
    variant: str

    def min_stiffness_n_per_m(self) -> np.ndarray:
        """Smallest eigenvalue of the TCP stiffness at each pose, (P,), N/m (the weakest direction)."""
        return np.linalg.eigvalsh(0.5 * (self.tcp_stiffness_n_per_m + np.swapaxes(self.tcp_stiffness_n_per_m, -1, -2)))[:, 0]


def _fill(robot, thetas, positions, s, failures, progress) -> PoseMap:
    P = len(thetas)
    ok = np.all(np.isfinite(thetas), axis=1)
    n_modes = None
    freq = damp = stiff = None
    if np.any(ok):
        batch = linearize_many(robot, thetas[ok], progress=progress)
        modes = batch.modes()
        n_modes = modes.freq_hz.shape[-1]
        freq = np.full((P, n_modes), np.nan)
        damp = np.full((P, n_modes), np.nan)
        stiff = np.full((P, 3, 3), np.nan)
        freq[ok], damp[ok] = modes.freq_hz, modes.damping_ratio
        stiff[ok] = np.linalg.inv(batch.compliance())
    else:
        freq = damp = np.full((P, 0), np.nan)
        stiff = np.full((P, 3, 3), np.nan)
    return PoseMap(tcp_position_m=positions, theta=thetas, freq_hz=freq, damping_ratio=damp,
                   tcp_stiffness_n_per_m=stiff, path_s_m=s, failures=tuple(failures), variant=robot.variant)


@blas_single_threaded
def pass_map(robot: FlexibleRobot, pas, n: int = 25, progress=None) -> PoseMap:
    """Modes and TCP stiffness at ``n`` evenly spaced points of the pass (start to end, inclusive).

    Parameters
    ----------
    robot : FlexibleRobot
    pas : linearize.path.Pass
    n : int, >= 2
    progress : callable(done, total), optional
    """
    if n < 2:
        raise BadInput(f"a pass map needs n >= 2 points, got {n}")
    s = np.linspace(0.0, pas.travel_m, n)
    thetas = np.array([pas.theta_at_s(si) for si in s])
    return _fill(robot, thetas, np.array([pas.tcp_position_at_s(si) for si in s]), s, [], progress)


@blas_single_threaded
def grid_map(robot: FlexibleRobot, positions_m: np.ndarray, orientation: np.ndarray, q_ref: np.ndarray,
             progress=None) -> PoseMap:
    """Modes and TCP stiffness over a user grid of TCP positions at one tool orientation.

    Parameters
    ----------
    positions_m : array (P, 3)
        TCP positions, base frame, m.
    orientation : array (3, 3)
        TCP orientation (columns: TCP axes in base), the same at every point.
    q_ref : array (n_joints,), rad
        Reference pose: its IK branch is used everywhere, and each joint's 2 pi representation is
        the one closest to it.

    Unreachable, singular or out-of-range targets give NaN rows, listed in ``failures``.
    """
    positions = np.asarray(positions_m, dtype=float)
    if positions.ndim != 2 or positions.shape[1] != 3 or not np.all(np.isfinite(positions)):
        raise BadInput(f"positions_m must be a finite (P, 3) array in m, got shape {positions.shape}")
    spec = robot.spec
    thetas = np.full((len(positions), spec.n_joints), np.nan)
    failures = []
    for k, p in enumerate(positions):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", JointLimitWarning)
                thetas[k] = ik(spec, p, orientation, q_ref=q_ref)
        except KinematicsError as e:
            failures.append((k, str(e)))
    return _fill(robot, thetas, positions, None, failures, progress)
