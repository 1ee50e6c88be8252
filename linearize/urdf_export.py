"""Write a robot (robolobes TOML or URDF) as a URDF plus the robot TOML of what the URDF lacks.

The URDF is in controller coordinates (each joint's position is the controller's angle: sign 1,
offset 0; :mod:`robolobes.linearize.urdf`), so the TOML written beside it loads back to the same
flexible model (``tests/test_urdf.py`` checks modes, FRFs and lobes to 1e-9).
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from robolobes.cases.spec import RobotSpec

from .model import chain_links

__all__ = ["write_urdf", "robot_toml"]


def _f(x: float) -> str:
    return repr(float(x))


def _v(xs) -> str:
    return " ".join(_f(x) for x in xs)


def _inertial(mass: float, com, inertia) -> str:
    i = np.asarray(inertia)
    return (f'    <inertial>\n      <origin xyz="{_v(com)}" rpy="0 0 0"/>\n      <mass value="{_f(mass)}"/>\n'
            f'      <inertia ixx="{_f(i[0, 0])}" iyy="{_f(i[1, 1])}" izz="{_f(i[2, 2])}" ixy="{_f(i[0, 1])}" '
            f'ixz="{_f(i[0, 2])}" iyz="{_f(i[1, 2])}"/>\n    </inertial>\n')


def _origin(m: pin.SE3) -> str:
    return f'    <origin xyz="{_v(m.translation)}" rpy="{_v(pin.rpy.matrixToRpy(m.rotation))}"/>\n'


def _link_names(spec: RobotSpec) -> list[str]:
    if spec.urdf is None:
        return [ln.name for ln in spec.links]
    return ["base"] + [f"{j.name}_link" for j in spec.joints]


def write_urdf(spec: RobotSpec, header: str = "") -> str:
    """The robot as URDF text, in controller coordinates (each joint's position is the controller's
    angle: sign 1, offset 0), with the link ``"flange_face"`` where the payload is fixed.

    ``header``: a line written as an XML comment (provenance). Joint limits are the robot's ranges;
    effort and velocity limits are not robot data here and are written as 0.
    """
    links, flange = chain_links(spec)
    names = _link_names(spec)
    out = ['<?xml version="1.0"?>\n']
    if header:
        out.append(f"<!-- {header} -->\n")
    out.append(f'<robot name="{_xml(spec.name)}">\n')
    if spec.urdf is None:
        b = spec.links[0]
        out.append(f'  <link name="{names[0]}">\n{_inertial(b.mass_kg, b.com_m, b.inertia_kg_m2)}  </link>\n')
    else:
        out.append(f'  <link name="{names[0]}"/>\n')
    for i, (js, (placement, axis, body)) in enumerate(zip(spec.joints, links)):
        a = np.eye(3)["xyz".index(axis)] if isinstance(axis, str) else np.asarray(axis)
        out.append(f'  <link name="{names[i + 1]}">\n{_inertial(body.mass, body.lever, body.inertia)}  </link>\n')
        lo, hi = js.range_rad
        out.append(f'  <joint name="{_xml(js.name)}" type="revolute">\n    <parent link="{names[i]}"/>\n'
                   f'    <child link="{names[i + 1]}"/>\n{_origin(placement)}    <axis xyz="{_v(a)}"/>\n'
                   f'    <limit lower="{_f(lo)}" upper="{_f(hi)}" effort="0" velocity="0"/>\n  </joint>\n')
    out.append('  <link name="flange_face"/>\n')
    out.append(f'  <joint name="flange_fixed" type="fixed">\n    <parent link="{names[-1]}"/>\n'
               f'    <child link="flange_face"/>\n{_origin(flange)}  </joint>\n')
    out.append("</robot>\n")
    return "".join(out)


def _xml(s: str) -> str:
    return s.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace('"', "&quot;")


def _toml_str(s: str) -> str:
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _inertia6(i) -> str:
    i = np.asarray(i)
    return _list([i[0, 0], i[1, 1], i[2, 2], i[0, 1], i[0, 2], i[1, 2]])


def _deg(x: float) -> str:
    """An angle (rad) in degrees with 12 significant digits (an error below 1e-12 relative, so that
    ``-11.71`` stays ``-11.71``)."""
    return repr(float(f"{math.degrees(x):.12g}"))


def _toml_value(v) -> str:
    """A number or list of numbers as TOML (integers stay integers)."""
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    return str(v) if isinstance(v, int) else _f(v)


def _list(xs) -> str:
    return "[" + ", ".join(_f(x) for x in xs) + "]"


def robot_toml(spec: RobotSpec, urdf_file: str, header: str = "") -> str:
    """The robot TOML of what the URDF written by :func:`write_urdf` lacks (``urdf = urdf_file``).

    The joint ranges are in the URDF (its ``limit`` elements); angles in degrees keep 12
    significant digits, every other number is written exactly (``repr``).

    Loading it (:func:`robolobes.cases.load_robot`) gives the same robot in the same controller
    angles. The orthogonal-compliance axes are written (``orthogonal_axes_xyz``) only where they
    differ from the default rule.
    """
    from robolobes.cases.urdf import completing_axes

    links, _ = chain_links(spec)
    lines = [f"# {header}"] if header else []
    lines += ['kind = "robot"', f"name = {_toml_str(spec.name)}", f"source = {_toml_str(spec.source)}",
              f"urdf = {_toml_str(urdf_file)}", 'flange_link = "flange_face"',
              f"gravity_m_per_s2 = {_f(spec.gravity_m_per_s2)}", ""]
    for i, (js, (_, axis, _)) in enumerate(zip(spec.joints, links)):
        lines += ["[[joints]]", f"name = {_toml_str(js.name)}",
                  f"stiffness_n_m_per_rad = {_f(js.stiffness_n_m_per_rad)}",
                  f"damping_n_m_s_per_rad = {_f(js.damping_n_m_s_per_rad)}",
                  f"gravity_compensation = {'true' if js.gravity_compensation else 'false'}"]
        if spec.urdf is not None:
            a = np.asarray(axis)
            given = np.asarray(spec.urdf.orthogonal_axes[i])
            if not np.array_equal(given, completing_axes(a)):
                lines.append(f"orthogonal_axes_xyz = {_list(given.ravel())}")
        lines.append("")
    p = spec.payload
    rpy = pin.rpy.matrixToRpy(np.array(p.tcp_rotation))
    rot = [f'["{ax}", {_deg(ang)}]' for ax, ang in zip("zyx", rpy[::-1]) if ang != 0.0]
    lines += ["[orthogonal]", f"stiffness_n_m_per_rad = {_f(spec.orthogonal_stiffness_n_m_per_rad)}",
              f"damping_n_m_s_per_rad = {_f(spec.orthogonal_damping_n_m_s_per_rad)}", "",
              "[backlash]", f"half_width_rad = {_f(spec.backlash_half_width_rad)}", "",
              "[payload]", f"name = {_toml_str(p.name)}", f"mass_kg = {_f(p.mass_kg)}", f"ag_m = {_list(p.com_m)}",
              f"gb_m = {_list(np.asarray(p.tcp_m) - np.asarray(p.com_m))}",
              f"inertia_kg_m2 = {_inertia6(p.inertia_kg_m2)}", f"tcp_rotation_deg = [{', '.join(rot)}]", ""]
    if spec.poses_rad:
        lines.append("[poses]")
        lines += [f"{k} = [{', '.join(_deg(x) for x in v)}]" for k, v in spec.poses_rad.items()]
        lines.append("")
    for e in spec.elements:
        lines += ["[[elements]]", f"type = {_toml_str(e.type)}"]
        lines += [f"{k} = {_toml_value(v)}" for k, v in e.params.items()]
        lines.append("")
    for a in spec.assumptions:
        reason = a.reason if a.key is None else f"{a.reason} ({a.key} = {a.value:g}, now in the URDF)"
        lines += ["[[assumption]]", f"reason = {_toml_str(reason)}", ""]
    return "\n".join(lines)
