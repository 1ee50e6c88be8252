"""Plain-number summaries of the linearized robot (for JSON output and reports)."""

from __future__ import annotations

import numpy as np

from .linear import equilibrium, linearize
from .model import FlexibleRobot

__all__ = ["modes_summary"]


def modes_summary(robot: FlexibleRobot, theta: np.ndarray, case=None) -> dict:
    """Modes and static TCP stiffness at one pose, as plain numbers (what ``robolobes modes --json``
    prints and the study reuses): SI units, base frame.

    Parameters
    ----------
    robot : FlexibleRobot
    theta : array (n_joints,), rad
        Motor angles.
    case : cases.MillingCase, optional
        Only its name is recorded.

    Returns
    -------
    dict
        ``q_deg`` and ``q_equilibrium_deg`` (deg, edge unit in the name), ``tcp_position_m`` (3,),
        ``tool_axis`` (3,), ``tcp_gravity_deflection_m`` (3,), ``freq_hz``, ``damped_freq_hz``,
        ``damping_ratio``, ``modal_stiffness_n_per_m`` (per mode), ``tcp_static_stiffness_n_per_m`` and
        ``tcp_static_compliance_m_per_n`` (3, 3), ``frame`` ("base"), ``notes``.
    """
    lin = linearize(robot, theta)
    modes = lin.modes()
    eq = equilibrium(robot, theta) if robot.has_gravity else None
    out = {
        "case": getattr(case, "name", None),
        "variant": robot.variant,
        "n_dof": robot.nv,
        "q_deg": np.degrees(lin.theta),
        "q_equilibrium_deg": np.degrees(lin.q),
        "tcp_position_m": lin.p_tcp,
        "tool_axis": lin.tool_axis,
        "tcp_gravity_deflection_m": eq.tcp_deflection if eq is not None else np.zeros(3),
        "freq_hz": modes.freq_hz,
        "damped_freq_hz": modes.damped_freq_hz,
        "damping_ratio": modes.damping_ratio,
        "modal_stiffness_n_per_m": modes.modal_stiffness_n_per_m,
        "tcp_static_stiffness_n_per_m": lin.stiffness("base"),
        "tcp_static_compliance_m_per_n": lin.compliance("base"),
        "frame": "base",
        "notes": list(lin.notes),
    }
    return out
