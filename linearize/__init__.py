"""Linearize: the configuration-dependent flexible robot, kinematics, statics, modes and tool-tip FRFs."""

if __name__ != "robolobes.linearize":  # this folder imported by itself (from the repository root): a second copy
    raise ImportError(f"{__name__!r} is the folder of the robolobes.linearize package: import robolobes.linearize instead")

from .model import (VARIANTS, Element, FlexibleRobot, Gravity, GravityCompensation, MotionSprings, Payload,
                    VirtualJoints, build_model, element_forces, element_tangents, rigid_q, tcp_jacobian, tcp_pose)
from .linear import (FRF, Equilibrium, LinearModel, Modes, SingularConfigurationError, equilibrium, frf_direct,
                     frf_modal, linearize, modal_analysis, state_space, LinearBatch, linearize_many)
from .kinematics import (JointLimitError, JointLimitWarning, KinematicsError, SingularityError, UnreachableError,
                         check_limits, fk, ik, ik_all)
from .path import Pass
from .maps import PoseMap, grid_map, pass_map
from .summary import modes_summary
