"""Read robots and milling cases from TOML files (built-in, or a user's own by path).

A file with ``kind = "robot"`` describes a robot, ``kind = "cut"`` a milling case that names its
robot. Every key carries its unit (``_mm``, ``_deg``, ``_mpa``, ...); values are converted to SI
here. A missing, malformed or unknown key (a typo such as ``helx_deg``) raises :class:`CaseError` naming
the file, the key and what is expected.
"""

from __future__ import annotations

import math
import tomllib
from importlib import resources
from pathlib import Path
from typing import Any, cast

import numpy as np

from robolobes.core.errors import BadInput

from .milling import Cut, CuttingLaw, MillingError, Tool, check_cut
from .spec import (Assumption, Axis, ElementSpec, JointSpec, LinkSpec, MillingCase, PassSpec, PayloadSpec, RobotSpec,
                   UrdfSpec)

__all__ = ["CaseError", "load_robot", "load_case", "load_reference", "builtin_cases", "builtin_robots", "DEFAULT_CASE",
           "case_table"]

DEFAULT_CASE = "tx200-aluminium"
#: Largest joint stiffness accepted, N m/rad: five orders of magnitude above the TX200's stiffest
#: joint (6e6); beyond it the joint is rigid for every purpose and the stiffness matrix's ratio to
#: its softest terms approaches float64 resolution (the modal solve fails with no useful message).
MAX_STIFFNESS_N_M_PER_RAD = 1e12


class CaseError(BadInput):
    """A case or robot file that cannot be read: names the file, the key and what is expected."""


def _data_dir():
    return resources.files("robolobes.cases") / "data"


def _builtin(kind: str) -> list[str]:
    names = []
    for entry in _data_dir().iterdir():
        if entry.name.endswith(".toml"):
            with entry.open("rb") as fh:
                if tomllib.load(fh).get("kind") == kind:
                    names.append(entry.name[:-5])
    return sorted(names)


def builtin_cases() -> list[str]:
    """Names of the milling cases shipped with robolobes."""
    return _builtin("cut")


def builtin_robots() -> list[str]:
    """Names of the robots shipped with robolobes."""
    return _builtin("robot")


def _resolve(name_or_path: str | Path, kind: str, relative_to: Path | None = None) -> tuple[Path, dict]:
    p = Path(name_or_path)
    candidates = []
    if relative_to is not None and not p.is_absolute():
        candidates.append(relative_to / p)
    candidates.append(p)
    for c in candidates:
        if c.suffix == ".toml" and c.is_file():
            path = c
            break
    else:
        builtin = _data_dir() / f"{name_or_path}.toml"
        if not builtin.is_file():
            known = _builtin(kind)
            raise CaseError(
                f"no {kind} named {str(name_or_path)!r}: give a built-in name ({', '.join(known)}) "
                f"or the path of a .toml file"
            )
        path = Path(str(builtin))
    try:
        with open(path, "rb") as fh:
            data = tomllib.load(fh)
    except tomllib.TOMLDecodeError as e:
        raise CaseError(f"{path}: not valid TOML: {e}") from None
    got = data.get("kind")
    if got != kind:
        raise CaseError(f"{path}: key 'kind' must be {kind!r} for a {kind} file, got {got!r}")
    return path, data


def case_table(name_or_path: str | Path) -> tuple[Path, dict]:
    """The file of a case (built-in name or path of a case TOML) and its raw TOML table, unchecked
    beyond ``kind = "cut"``: for writing a modified copy of the case (:func:`load_case` checks it).

    >>> path, table = case_table("tx200-aluminium")
    >>> path.name, table["kind"]
    ('tx200-aluminium.toml', 'cut')
    """
    return _resolve(name_or_path, "cut")


class _Reader:
    """Typed access to one TOML table with error messages that name file and key."""

    def __init__(self, path: Path, table: dict, prefix: str = ""):
        self.path, self.t, self.prefix = path, table, prefix
        self.asked: set[str] = set()  # every key read (present or defaulted): the valid keys

    def _get(self, key: str, default=None):
        self.asked.add(key)
        return self.t.get(key, default)

    def allow(self, *keys: str) -> None:
        """Mark ``keys`` as valid without reading them (read elsewhere, or documentation only)."""
        self.asked.update(keys)

    def finish(self) -> None:
        """Raise :class:`CaseError` naming any key of this table that nothing read (a typo such as
        ``helx_deg`` would otherwise silently leave its default)."""
        unknown = sorted(set(self.t) - self.asked)
        if unknown:
            raise CaseError(f"{self.path}: unknown key '{self.prefix}{unknown[0]}'; valid keys here: "
                            f"{', '.join(sorted(self.asked))}")

    def _err(self, key: str, expected: str, got: Any = None, missing: bool = False) -> CaseError:
        where = f"{self.prefix}{key}"
        if missing:
            return CaseError(f"{self.path}: missing key '{where}' ({expected})")
        return CaseError(f"{self.path}: key '{where}' must be {expected}, got {got!r}")

    def has(self, key: str) -> bool:
        self.asked.add(key)
        return key in self.t

    def table(self, key: str) -> "_Reader":
        v = self._get(key)
        if not isinstance(v, dict):
            raise self._err(key, "a table", v, missing=v is None)
        return _Reader(self.path, v, f"{self.prefix}{key}.")

    def tables(self, key: str) -> list["_Reader"]:
        v = self._get(key)
        if not isinstance(v, list) or not all(isinstance(x, dict) for x in v):
            raise self._err(key, "an array of tables [[...]]", v, missing=v is None)
        return [_Reader(self.path, x, f"{self.prefix}{key}[{i}].") for i, x in enumerate(v)]

    def num(self, key: str, default=None, *, positive=False, nonneg=False, allow_nan=False,
            most: float | None = None) -> float:
        v = self._get(key, default)
        if v is None:
            raise self._err(key, "a number", missing=True)
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise self._err(key, "a number", v)
        v = float(v)
        if math.isnan(v) and allow_nan:
            return v
        if not math.isfinite(v):
            raise self._err(key, "a finite number", v)
        if positive and v <= 0:
            raise self._err(key, "a number > 0", v)
        if nonneg and v < 0:
            raise self._err(key, "a number >= 0", v)
        if most is not None and abs(v) > most:
            raise self._err(key, f"a number of magnitude <= {most:g}", v)
        return v

    def integer(self, key: str, default=None, *, minimum=None) -> int:
        v = self._get(key, default)
        if v is None:
            raise self._err(key, "an integer", missing=True)
        if isinstance(v, bool) or not isinstance(v, int) or (minimum is not None and v < minimum):
            raise self._err(key, f"an integer >= {minimum}" if minimum is not None else "an integer", v)
        return v

    def vec(self, key: str, n: int | None = None, default=None, allow_nan=False) -> np.ndarray:
        v = self._get(key, default)
        what = f"an array of {n} numbers" if n else "an array of numbers"
        if v is None:
            raise self._err(key, what, missing=True)
        if not isinstance(v, list) or (n is not None and len(v) != n) or not v:
            raise self._err(key, what, v)
        if any(isinstance(x, bool) or not isinstance(x, (int, float)) for x in v):
            raise self._err(key, what, v)
        a = np.array(v, dtype=float)
        bad = ~np.isfinite(a) & ~(np.isnan(a) if allow_nan else False)
        if np.any(bad):
            raise self._err(key, f"{what}, all finite", v)
        return a

    def text(self, key: str, default=None, choices=None) -> str:
        v = self._get(key, default)
        if v is None:
            raise self._err(key, "a string", missing=True)
        if not isinstance(v, str) or (choices and v not in choices):
            raise self._err(key, f"one of {list(choices)}" if choices else "a string", v)
        return v

    def boolean(self, key: str, default=None) -> bool:
        v = self._get(key, default)
        if not isinstance(v, bool):
            raise self._err(key, "true or false", v, missing=v is None)
        return v


def _inertia(r: _Reader, key: str) -> np.ndarray:
    xx, yy, zz, xy, xz, yz = r.vec(key, 6)
    inertia = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
    ev = np.linalg.eigvalsh(inertia)
    if ev[0] <= 0 or ev[2] > ev[0] + ev[1] + 1e-12:
        raise r._err(key, "a physical inertia [xx, yy, zz, xy, xz, yz] (positive definite, triangle inequality)",
                      [xx, yy, zz, xy, xz, yz])
    return inertia


_ROT = {"x": lambda a: np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]]),
        "y": lambda a: np.array([[math.cos(a), 0, math.sin(a)], [0, 1, 0], [-math.sin(a), 0, math.cos(a)]]),
        "z": lambda a: np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])}


def _apply_assumptions(path: Path, data: dict) -> list[Assumption]:
    out = []
    for i, a in enumerate(data.get("assumption", [])):
        r = _Reader(path, a, f"assumption[{i}].")
        reason = r.text("reason")
        r.allow("key", "value")
        r.finish()
        key = a.get("key")
        if key is None:
            out.append(Assumption(reason=reason))
            continue
        value = r.num("value")
        parts = str(key).split(".")
        if len(parts) != 4 or parts[0] not in ("links", "payload") or parts[3] not in ("x", "y", "z"):
            raise r._err("key", "'links.<link name>.<vector key>.<x|y|z>'", key)
        links = {ln.get("name"): ln for ln in data.get("links", [])}
        if parts[1] not in links:
            raise r._err("key", f"a link name among {list(links)}", key)
        vec = links[parts[1]].get(parts[2])
        if not isinstance(vec, list) or len(vec) != 3:
            raise r._err("key", f"a 3-vector key of link {parts[1]!r}", key)
        vec[{"x": 0, "y": 1, "z": 2}[parts[3]]] = value
        out.append(Assumption(reason=reason, key=key, value=value))
    return out


def _elements(path: Path, data: dict) -> tuple[ElementSpec, ...]:
    """``[[elements]]`` tables: a string ``type`` and number / array keys (the element checks its keys
    when the model is built: :func:`robolobes.linearize.extra_elements.element_from_spec`)."""
    if "elements" not in data:
        return ()
    out = []
    for er in _Reader(path, data).tables("elements"):
        kind = er.text("type")
        params = {}
        for k, v in er.t.items():
            if k == "type":
                continue
            ok = (isinstance(v, (int, float)) and not isinstance(v, bool)) or (
                isinstance(v, list) and v and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v))
            if not ok:
                raise er._err(k, "a number or an array of numbers", v)
            params[k] = v
        out.append(ElementSpec(type=kind, params=params))
    return tuple(out)


def _parse_robot(path: Path, data: dict) -> RobotSpec:
    assumptions = _apply_assumptions(path, data)
    r = _Reader(path, data)
    if r.has("urdf"):
        if "links" in data:
            raise CaseError(f"{path}: keys 'urdf' and 'links' exclude each other: a URDF robot takes its links "
                            "from the URDF")
        links: tuple[LinkSpec, ...] = ()
        jrs = r.tables("joints")
        urdf, axes, urdf_limits = _urdf_spec(path, r, jrs)
    else:
        links = tuple(_links(r))
        jrs = r.tables("joints")
        urdf, axes, urdf_limits = None, [None] * len(jrs), [None] * len(jrs)
    joints = tuple(_joint(jr, axis, lim) for jr, axis, lim in zip(jrs, axes, urdf_limits))
    if urdf is None and len(links) != len(joints) + 1:
        raise CaseError(f"{path}: {len(links)} [[links]] need {len(links) - 1} [[joints]], got {len(joints)}")
    payload = _payload(r.table("payload"))
    orth = r.table("orthogonal")
    back = r.table("backlash")
    poses = {}
    if r.has("poses"):
        pt = r.table("poses")
        for k in pt.t:
            poses[k] = np.radians(pt.vec(k, len(joints)))
    spec = RobotSpec(
        name=r.text("name"), links=links, joints=joints, payload=payload,
        gravity_m_per_s2=r.num("gravity_m_per_s2", nonneg=True),
        orthogonal_stiffness_n_m_per_rad=orth.num("stiffness_n_m_per_rad", positive=True,
                                                  most=MAX_STIFFNESS_N_M_PER_RAD),
        orthogonal_damping_n_m_s_per_rad=orth.num("damping_n_m_s_per_rad", nonneg=True),
        backlash_half_width_rad=back.num("half_width_rad", nonneg=True),
        poses_rad=poses, assumptions=tuple(assumptions), source=r.text("source", ""),
        elements=_elements(path, data), urdf=urdf)
    orth.finish()
    back.finish()
    r.allow("kind", "assumption", "elements")
    r.finish()
    return spec


def _links(r: _Reader) -> list[LinkSpec]:
    links = []
    for lr in r.tables("links"):
        name = lr.text("name")
        com = lr.vec("com_m", 3) if lr.has("com_m") else lr.vec("ag_m", 3)
        gb = lr.vec("gb_m", 3, allow_nan=True)
        if np.any(np.isnan(gb)):
            raise lr._err("gb_m", "fully known: a nan entry needs an [[assumption]] with key "
                          f"'links.{name}.gb_m.<x|y|z>' giving its value", gb.tolist())
        links.append(LinkSpec(name=name, mass_kg=lr.num("mass_kg", positive=True), com_m=com,
                              next_joint_m=gb, inertia_kg_m2=_inertia(lr, "inertia_kg_m2")))
        lr.allow("ag_m")
        lr.finish()
    return links


def _joint(jr: _Reader, urdf_axis: np.ndarray | None, urdf_limits: np.ndarray | None) -> JointSpec:
    """One ``[[joints]]`` table. For a URDF robot, ``urdf_axis`` is the joint's axis (joint frame) and
    ``urdf_limits`` its range in controller angles (nan: none in the URDF); ``range_deg`` overrides it."""
    if urdf_axis is None:
        axis = cast(Axis, jr.text("axis", choices=("x", "y", "z")))
    else:
        from .urdf import nearest_axis
        axis = cast(Axis, nearest_axis(urdf_axis))
    if jr.has("range_deg") or urdf_limits is None or np.any(np.isnan(urdf_limits)):
        if urdf_limits is not None and not jr.has("range_deg"):
            raise jr._err("range_deg", "[lower, upper] in degrees: the URDF gives no limits for this joint",
                          missing=True)
        rng = np.radians(jr.vec("range_deg", 2))
        if rng[0] >= rng[1]:
            raise jr._err("range_deg", "[lower, upper] with lower < upper", np.degrees(rng).tolist())
    else:
        rng = np.asarray(urdf_limits, dtype=float)
    spec = JointSpec(
        name=jr.text("name"), axis=axis,
        stiffness_n_m_per_rad=jr.num("stiffness_n_m_per_rad", positive=True, most=MAX_STIFFNESS_N_M_PER_RAD),
        damping_n_m_s_per_rad=jr.num("damping_n_m_s_per_rad", nonneg=True),
        range_rad=rng, gravity_compensation=jr.boolean("gravity_compensation", False))
    jr.finish()
    return spec


def _payload(pr: _Reader) -> PayloadSpec:
    rot = np.eye(3)
    for item in pr._get("tcp_rotation_deg", []) or []:
        if (not isinstance(item, list) or len(item) != 2 or item[0] not in _ROT
                or isinstance(item[1], bool) or not isinstance(item[1], (int, float))):
            raise pr._err("tcp_rotation_deg", 'a list of ["x"|"y"|"z", angle_deg] pairs', item)
        rot = rot @ _ROT[item[0]](math.radians(item[1]))
    payload = PayloadSpec(name=pr.text("name", "payload"), mass_kg=pr.num("mass_kg", positive=True),
                          com_m=pr.vec("ag_m", 3), tcp_m=pr.vec("ag_m", 3) + pr.vec("gb_m", 3),
                          inertia_kg_m2=_inertia(pr, "inertia_kg_m2"), tcp_rotation=rot)
    pr.finish()
    return payload


def _urdf_spec(path: Path, r: _Reader, jrs: list[_Reader]):
    """The :class:`UrdfSpec` of a robot TOML with ``urdf = "file"``, each joint's URDF axis, and each
    joint's URDF limits in controller angles ((2,), nan if the URDF has none)."""
    from .urdf import UrdfError, completing_axes, orthonormal_pair, read_urdf_tree

    rel = r.text("urdf")
    upath = Path(rel) if Path(rel).is_absolute() else path.parent / rel
    if not upath.is_file():
        raise r._err("urdf", "the path of a URDF file (relative to this TOML)", rel)
    names, signs, offsets, named_axes = [], [], [], []
    for jr in jrs:
        names.append(jr.text("urdf_joint", jr.t.get("name")))
        sign = jr.num("sign", 1.0)
        if sign not in (1.0, -1.0):
            raise jr._err("sign", "1 or -1", sign)
        signs.append(sign)
        offsets.append(math.radians(jr.num("offset_deg", 0.0)))
        named_axes.append(jr.vec("orthogonal_axes_xyz", 6) if jr.has("orthogonal_axes_xyz") else None)
    try:
        tree, flange = read_urdf_tree(upath, tuple(names), r.text("flange_link") if r.has("flange_link") else None)
    except UrdfError as e:
        raise CaseError(str(e)) from None
    sign, offset = np.array(signs), np.array(offsets)
    ortho = []
    for jr, a, given in zip(jrs, tree.axes, named_axes):
        if given is None:
            ortho.append(completing_axes(a))
            continue
        u, w = given[:3], given[3:]
        if min(np.linalg.norm(u), np.linalg.norm(w)) == 0 or max(
                abs(u @ a) / np.linalg.norm(u), abs(w @ a) / np.linalg.norm(w),
                abs(u @ w) / np.linalg.norm(u) / np.linalg.norm(w)) > 1e-6:
            raise jr._err("orthogonal_axes_xyz", "two non-zero axes [ux, uy, uz, wx, wy, wz] orthogonal to the "
                          "joint axis and to each other (joint frame)", given.tolist())
        ortho.append(orthonormal_pair(a, u / np.linalg.norm(u), w / np.linalg.norm(w)))
    # controller range from the URDF's: c = (p - offset) / sign
    lim = (tree.limits_rad - offset[:, None]) / sign[:, None]
    lim = np.sort(lim, axis=1)
    urdf = UrdfSpec(path=str(upath), joint_names=tuple(names), flange=flange, sign=sign, offset_rad=offset,
                    placements=tree.placements, axes=tree.axes, mass_kg=tree.mass_kg, com_m=tree.com_m,
                    inertia_kg_m2=tree.inertia_kg_m2, flange_placement=tree.flange_placement,
                    orthogonal_axes=np.array(ortho))
    return urdf, list(sign[:, None] * tree.axes), list(lim)


def load_robot(name_or_path: str | Path) -> RobotSpec:
    """Load a robot: a built-in name (``"tx200"``) or the path of a ``kind = "robot"`` TOML file."""
    path, data = _resolve(name_or_path, "robot")
    return _parse_robot(path, data)


def load_case(name_or_path: str | Path = DEFAULT_CASE) -> MillingCase:
    """Load a milling case: a built-in name (``"tx200-aluminium"``, ``"tx200-steel"``) or a path.

    The case's ``robot`` key is a built-in robot name or a path relative to the case file.

    >>> case = load_case("tx200-steel")
    >>> case.cut.spindle_rpm, case.cut.ap_m   # rpm, m
    (3100.0, 0.0016)
    """
    path, data = _resolve(name_or_path, "cut")
    r = _Reader(path, data)
    robot_ref = r.text("robot")
    try:
        rpath, rdata = _resolve(robot_ref, "robot", relative_to=path.parent)
    except CaseError as e:
        raise CaseError(f"{path}: key 'robot' = {robot_ref!r}: {e}") from None
    robot = _parse_robot(rpath, rdata)
    if "elements" in data:  # the case's [[elements]] add to the robot's
        from dataclasses import replace
        robot = replace(robot, elements=robot.elements + _elements(path, data))

    tr = r.table("tool")
    try:
        teeth = tr.integer("teeth", minimum=1)
        tool = Tool(
            diameter_m=tr.num("diameter_mm", positive=True) * 1e-3, teeth=teeth,
            helix_rad=math.radians(tr.num("helix_deg", 0.0)),
            pitch_rad=tuple(np.radians(tr.vec("pitch_deg"))) if tr.has("pitch_deg") else (),
            runout_m=tuple(tr.vec("runout_um") * 1e-6) if tr.has("runout_um") else ())
    except MillingError as e:
        raise CaseError(f"{path}: [tool]: {e}") from None
    tr.finish()
    mr = r.table("material")
    law = CuttingLaw(
        ktc_pa=mr.num("ktc_mpa", positive=True) * 1e6, krc_pa=mr.num("krc_mpa") * 1e6,
        kac_pa=mr.num("kac_mpa", 0.0) * 1e6, kte_n_per_m=mr.num("kte_n_per_mm", 0.0) * 1e3,
        kre_n_per_m=mr.num("kre_n_per_mm", 0.0) * 1e3, kae_n_per_m=mr.num("kae_n_per_mm", 0.0) * 1e3,
        name=mr.text("name", ""))
    mr.finish()
    cr = r.table("cut")
    try:
        cut = Cut.from_feed_rate(
            tool, ae_m=cr.num("ae_mm", positive=True) * 1e-3, ap_m=cr.num("ap_mm", positive=True) * 1e-3,
            spindle_rpm=cr.num("spindle_rpm", positive=True),
            feed_m_per_s=cr.num("feed_mm_per_min", nonneg=True) * 1e-3 / 60.0,
            mode=cr.text("mode", "down", choices=("up", "down")),
            feed_direction=tuple(cr.vec("feed_direction", 3, default=[1.0, 0.0, 0.0])))
        check_cut(tool, cut)
    except MillingError as e:
        raise CaseError(f"{path}: [cut]: {e}") from None
    cr.finish()
    pr = r.table("pass")
    sp = pr._get("start_pose")
    if isinstance(sp, str):
        if sp not in robot.poses_rad:
            raise pr._err("start_pose", f"a pose of robot {robot.name!r} ({sorted(robot.poses_rad)}) "
                          f"or {robot.n_joints} joint angles in degrees", sp)
        q0 = robot.poses_rad[sp]
    else:
        q0 = np.radians(pr.vec("start_pose", robot.n_joints))
    path_spec = PassSpec(start_q_rad=q0, part_length_m=pr.num("part_length_mm", positive=True) * 1e-3,
                         approach_m=pr.num("approach_mm", 0.0, nonneg=True) * 1e-3,
                         overrun_m=pr.num("overrun_mm", 0.0, nonneg=True) * 1e-3,
                         ramp_s=pr.num("ramp_s", positive=True))
    pr.finish()
    case = MillingCase(name=r.text("name", path.stem), robot=robot, tool=tool, law=law, cut=cut,
                       path=path_spec, source=r.text("source", ""))
    r.allow("kind", "elements")
    r.finish()
    return case


def load_reference(name_or_path: str | Path) -> dict:
    """Published results to compare with (``kind = "reference"``), as a plain dict (units in the keys).

    Built-in: ``"tx200-paper-results"`` (the paper's Tab. 10-12 and its steel observations).
    """
    _, data = _resolve(name_or_path, "reference")
    return data
