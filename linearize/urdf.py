"""Robots from URDF: their chain in controller coordinates, their rigid kinematic chain, and export.

A URDF robot (``RobotSpec.urdf``, read by :mod:`robolobes.cases.urdf`) gives, per motion joint,
its frame ``P_i`` (at URDF position 0, in the previous joint's frame), its axis ``a_i`` and the
body moving with it. The controller's angle ``c_i`` and the URDF position ``p_i`` are related by
``p_i = s_i c_i + o_i``. Since ``R(a, s c + o) = R(a, o) R(s a, c)``, the flexible model's motion
joint ``i`` sits at ``P_i R(a_i, o_i)`` and turns about ``s_i a_i``: its coordinate is the
controller's angle, and the frame it carries is exactly the URDF's joint frame at ``p_i``, so the
bodies, the next joints and the flange keep the URDF's placements. Every element (springs on
``c - theta``, virtual joints after each motion joint, gravity compensation, backlash) then works
unchanged on the URDF's tree.

:mod:`robolobes.linearize.urdf_export` writes any robot back as a URDF in these coordinates.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin

from robolobes.cases.spec import RobotSpec, UrdfSpec

from .element import revolute

__all__ = ["controller_chain", "rigid_chain"]


def _se3(h: np.ndarray) -> pin.SE3:
    h = np.asarray(h, dtype=float)
    return pin.SE3(h[:3, :3].copy(), h[:3, 3].copy())


def _body(u: UrdfSpec, i: int) -> pin.Inertia:
    return pin.Inertia(float(u.mass_kg[i]), np.array(u.com_m[i]), np.array(u.inertia_kg_m2[i]))


def controller_chain(u: UrdfSpec) -> tuple[list[tuple[pin.SE3, str | np.ndarray, pin.Inertia]], pin.SE3]:
    """The URDF chain with the controller's angles as joint coordinates (module docstring).

    Returns per motion joint ``(placement, axis (3,), body)`` and the flange placement in the last
    joint's frame, as :func:`robolobes.linearize.model.chain_links`.
    """
    out: list[tuple[pin.SE3, str | np.ndarray, pin.Inertia]] = []
    for i in range(len(u.joint_names)):
        a = np.array(u.axes[i])
        placement = _se3(u.placements[i]) * pin.SE3(pin.AngleAxis(float(u.offset_rad[i]), a).matrix(), np.zeros(3))
        out.append((placement, float(u.sign[i]) * a, _body(u, i)))
    return out, _se3(u.flange_placement)


def _tcp_placement(spec: RobotSpec) -> pin.SE3:
    """TCP frame in the flange frame: ``payload.tcp_m``, ``payload.tcp_rotation``."""
    return pin.SE3(np.array(spec.payload.tcp_rotation), np.array(spec.payload.tcp_m))


def rigid_chain(spec: RobotSpec) -> Any:
    """The rigid kinematic chain of a URDF robot (:class:`robolobes.linearize.chain.KinematicChain`).

    Its model has the URDF's joints (URDF positions ``p = sign * c + offset_rad``), the bodies,
    and the frames ``"flange"`` and ``"tcp"`` (TCP z axis: the tool axis). Gravity is off.
    """
    import importlib

    u = spec.urdf
    if u is None:
        raise ValueError(f"robot {spec.name!r} has no URDF: use linearize.chain.chain_from_spec")
    model = pin.Model()
    model.name = spec.name
    model.gravity = pin.Motion.Zero()
    parent = 0
    for i, name in enumerate(u.joint_names):
        parent = model.addJoint(parent, revolute(np.array(u.axes[i])), _se3(u.placements[i]), name)
        model.appendBodyToJoint(parent, _body(u, i), pin.SE3.Identity())
    flange = _se3(u.flange_placement)
    model.addFrame(pin.Frame("flange", parent, flange, pin.FrameType.OP_FRAME))
    tcp = model.addFrame(pin.Frame("tcp", parent, flange * _tcp_placement(spec), pin.FrameType.OP_FRAME))
    chain = importlib.import_module("robolobes.linearize.chain")  # written with the generic IK
    return chain.KinematicChain.from_pinocchio(model, tcp, np.array(u.sign), np.array(u.offset_rad),
                                               spec.joint_range_rad, name=spec.name)
