"""Linearize: the configuration-dependent flexible robot, kinematics, statics, modes and tool-tip FRFs.

The names below load on first use (PEP 562), so that a command-line parser can import
:mod:`robolobes.linearize.cli` without pinocchio; static tools read them from the
``TYPE_CHECKING`` block.
"""

if __name__ != "robolobes.linearize":  # this folder imported by itself (from the repository root): a second copy
    raise ImportError(f"{__name__!r} is the folder of the robolobes.linearize package: import robolobes.linearize instead")

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .chain import KinematicChain, chain_from_spec
    from .kinematics import (JointLimitError, JointLimitWarning, KinematicsError, SingularityError, UnreachableError,
                             check_limits, fk, ik, ik_all)
    from .linear import (FRF, Equilibrium, LinearBatch, LinearModel, Modes, SingularConfigurationError, equilibrium,
                         frf_direct, frf_modal, linearize, linearize_many, modal_analysis, state_space)
    from .maps import PoseMap, grid_map, pass_map
    from .model import (Element, FlexibleRobot, Gravity, GravityCompensation, MotionSprings, Payload, VirtualJoints,
                        build_model, element_forces, element_tangents, rigid_q, tcp_jacobian, tcp_pose)
    from .path import Pass
    from .summary import modes_summary
    from .variants import VARIANTS

_HOME = {name: module for module, names in {
    "variants": ("VARIANTS",),
    "model": ("Element", "FlexibleRobot", "Gravity", "GravityCompensation", "MotionSprings", "Payload",
              "VirtualJoints", "build_model", "element_forces", "element_tangents", "rigid_q", "tcp_jacobian",
              "tcp_pose"),
    "linear": ("FRF", "Equilibrium", "LinearModel", "Modes", "SingularConfigurationError", "equilibrium",
               "frf_direct", "frf_modal", "linearize", "modal_analysis", "state_space", "LinearBatch",
               "linearize_many"),
    "kinematics": ("JointLimitError", "JointLimitWarning", "KinematicsError", "SingularityError",
                   "UnreachableError", "check_limits", "fk", "ik", "ik_all"),
    "path": ("Pass",),
    "maps": ("PoseMap", "grid_map", "pass_map"),
    "summary": ("modes_summary",),
    "chain": ("KinematicChain", "chain_from_spec"),
}.items() for name in names}

__all__ = ["VARIANTS", "Element", "FlexibleRobot", "Gravity", "GravityCompensation", "MotionSprings", "Payload",
           "VirtualJoints", "build_model", "element_forces", "element_tangents", "rigid_q", "tcp_jacobian",
           "tcp_pose", "FRF", "Equilibrium", "LinearModel", "Modes", "SingularConfigurationError", "equilibrium",
           "frf_direct", "frf_modal", "linearize", "modal_analysis", "state_space", "LinearBatch", "linearize_many",
           "JointLimitError", "JointLimitWarning", "KinematicsError", "SingularityError", "UnreachableError",
           "check_limits", "fk", "ik", "ik_all", "Pass", "PoseMap", "grid_map", "pass_map", "modes_summary",
           "KinematicChain", "chain_from_spec"]


def __getattr__(name: str):
    module = _HOME.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_HOME))
