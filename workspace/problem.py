"""The map problem (what to sweep) and the map method (how precisely), in the lobes' shape.

    problem = MapProblem.placement(case, "orthogonal", x_range_m=(-0.2, 0.2), y_range_m=(-0.2, 0.2), n=1000)
    result = solve_map(problem, MapMethod())            # robolobes.workspace.solve_map

A map's poses are the Cartesian product of its ``axes`` (each a name and a 1-D array of values,
SI units), flattened in C order into the ``pose`` dimension. Axis names: ``x_offset_m``,
``y_offset_m``, ``z_offset_m`` (the pass start moved from the case's, base frame), ``yaw_rad``
(the part turned about base z), ``tool_rotation_rad`` (the tool turned about its own axis),
``tilt_rad`` (the tool axis tilted about the feed), ``s_m`` (travel along the pass).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from robolobes.cases.spec import MillingCase
from robolobes.core.errors import BadInput
from robolobes.lobes import ComplexMode, Mode
from robolobes.lobes.sdm import Search

__all__ = ["MapProblem", "MapMethod", "AXES", "OVER", "MAX_POSES", "MAX_SPEEDS", "LEAD_REASON"]

Over = Literal["pass", "placement", "tool-rotation", "lead-tilt"]
OVER = ("pass", "placement", "tool-rotation", "lead-tilt")
AXES = ("x_offset_m", "y_offset_m", "z_offset_m", "yaw_rad", "tool_rotation_rad", "tilt_rad", "s_m")
#: why a lead angle (the tool axis tilted towards the feed) is refused, in one sentence
LEAD_REASON = ("a lead angle tilts the tool axis towards the feed, but the 2.5-D cut model needs the feed "
               "perpendicular to the tool axis (chip and forces in the plane normal to the axis, axial motion "
               "ignored), so it cannot describe that cut; only lead 0 is modelled")
#: bounds on the inputs that set memory and run time (a 1000 x 100 map takes ~10 min here)
MAX_POSES = 100_000
MAX_SPEEDS = 2_000


def _grid_counts(n: int, k: int) -> list[int]:
    """Points per axis so that k varying axes hold about n poses in all (each >= 2)."""
    per = max(2, int(round(n ** (1.0 / k))))
    return [per] * k


_TILT_20_DEG = (-math.radians(20), math.radians(20))  # default tilt range, rad

@dataclass(frozen=True, eq=False)
class MapProblem:
    """What a lobe map sweeps.

    Attributes
    ----------
    case : MillingCase
        Robot, tool, material, cut and pass (the cut's speed and depth are the operating point).
    variant : str
        Robot model variant (``basic``, ``gravity``, ``orthogonal``, ``backlash``).
    over : {"pass", "placement", "tool-rotation", "lead-tilt"}
    axes : tuple of (name, array)
        The swept axes (see module docstring), SI units; fixed values are 1-point axes.
    speeds_rpm : array (S,), rpm
        Spindle speeds of the lobes at every pose.
    op_rpm : float
        Operating speed, rpm: the depth limit there is mapped too (``op_depth_limit_m``).
    tool_modes : tuple of linearize.tool.TcpOscillator, or of lobes.Mode / lobes.ComplexMode
        The tool: TCP oscillators (TCP frame), added to the robot's M, C, K (what the commands
        give); or modes (cut frame) put in series with the robot at every pose, ``H_robot + H_tool``,
        which leaves out the tool's inertia on the robot (valid only for a tool mass far below the
        robot's apparent mass at the TCP: docs/guide/hammer-test.md). Not both kinds at once.
    model_file : str or None
        An identified model TOML (the ``model`` output of ``robolobes identify``), added to the robot at every pose.
    """

    case: MillingCase
    variant: str
    over: Over
    axes: tuple
    speeds_rpm: np.ndarray
    op_rpm: float
    tool_modes: tuple = ()
    model_file: str | None = None

    def __post_init__(self) -> None:
        if self.over not in OVER:
            raise BadInput(f"over must be one of {', '.join(OVER)}, got {self.over!r}")
        axes = []
        for name, vals in self.axes:
            if name not in AXES:
                raise BadInput(f"unknown map axis {name!r}; valid: {', '.join(AXES)}")
            v = np.array(vals, dtype=float).reshape(-1)
            if v.size == 0 or not np.all(np.isfinite(v)):
                raise BadInput(f"map axis {name} must hold finite values, got {vals!r}")
            v.setflags(write=False)
            axes.append((name, v))
        object.__setattr__(self, "axes", tuple(axes))
        n = self.n_poses
        if not 1 <= n <= MAX_POSES:
            raise BadInput(f"a map has {n} poses; valid: 1 to {MAX_POSES}")
        s = np.array(self.speeds_rpm, dtype=float).reshape(-1)
        if not 1 <= s.size <= MAX_SPEEDS or not np.all(np.isfinite(s) & (s > 0)):
            raise BadInput(f"speeds_rpm must hold 1 to {MAX_SPEEDS} finite speeds > 0 rpm, got {s.size} values")
        s.setflags(write=False)
        object.__setattr__(self, "speeds_rpm", s)
        if not (math.isfinite(self.op_rpm) and self.op_rpm > 0):
            raise BadInput(f"op_rpm must be a speed > 0 rpm, got {self.op_rpm}")
        from robolobes.linearize.tool import TcpOscillator

        kinds = {TcpOscillator if isinstance(m, TcpOscillator) else Mode for m in self.tool_modes}
        for i, m in enumerate(self.tool_modes):
            if not isinstance(m, (Mode, ComplexMode, TcpOscillator)):
                raise BadInput(f"tool_modes[{i}] must be a linearize.tool.TcpOscillator, lobes.Mode or "
                               f"lobes.ComplexMode, got {type(m).__name__}")
        if len(kinds) > 1:
            raise BadInput("tool_modes: give TCP oscillators (in the robot) or modes (in series), not both")
        object.__setattr__(self, "tool_modes", tuple(self.tool_modes))

    # ------------------------------------------------------------------ constructors
    @classmethod
    def make(cls, case: MillingCase, variant: str, over: Over, *, n: int = 25,
             x_range_m=(-0.2, 0.2), y_range_m=(-0.2, 0.2), z_range_m=(0.0, 0.0), yaw_range_rad=(0.0, 0.0),
             rotation_range_rad=(-math.pi, math.pi), tilt_range_rad=_TILT_20_DEG,
             lead_range_rad=(0.0, 0.0), speeds_rpm=None, op_rpm: float | None = None, tool_modes=(),
             model_file=None) -> "MapProblem":
        """A map over ``over`` with about ``n`` poses.

        ``placement``: a grid of the pass start offset (x, y, z, m) and yaw (rad) over the ranges,
        about ``n`` points in all shared among the ranges of non-zero width. ``pass``: ``n``
        points from the start to the end of the case's pass. ``tool-rotation``: ``n`` angles about
        the tool axis over ``rotation_range_rad`` (end excluded when it spans 2 pi).
        ``lead-tilt``: ``n`` tilt angles about the feed over ``tilt_range_rad``; the lead stays 0
        (``lead_range_rad`` other than (0, 0) raises :class:`BadInput`, see :data:`LEAD_REASON`).
        Speeds: default 100 from 2000 to 25 000 rpm; ``op_rpm`` default the case's spindle speed.
        """
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 1 <= n <= MAX_POSES:
            raise BadInput(f"n (number of poses) must be an integer from 1 to {MAX_POSES}, got {n!r}")
        if tuple(lead_range_rad) != (0.0, 0.0):
            raise BadInput(f"lead range {tuple(lead_range_rad)!r} rad refused: {LEAD_REASON}")
        if over == "placement":
            ranges = [("x_offset_m", x_range_m), ("y_offset_m", y_range_m), ("z_offset_m", z_range_m),
                      ("yaw_rad", yaw_range_rad)]
            for name, (a, b) in ranges:
                if not (math.isfinite(a) and math.isfinite(b) and a <= b):
                    raise BadInput(f"{name} range must be finite with A <= B, got {a}, {b}")
            varying = [r for r in ranges if r[1][1] > r[1][0]]
            counts = _grid_counts(int(n), len(varying)) if varying else []
            cnt = dict(zip([r[0] for r in varying], counts))
            axes = tuple((name, np.linspace(a, b, cnt[name]) if name in cnt else np.array([a]))
                         for name, (a, b) in ranges)
        elif over == "pass":
            import warnings

            from robolobes.linearize.kinematics import JointLimitWarning
            from robolobes.linearize.path import Pass

            with warnings.catch_warnings():  # the poses' limits are reported per pose (reason)
                warnings.simplefilter("ignore", JointLimitWarning)
                travel = Pass.from_case(case).travel_m if n > 1 else 0.0
            axes = (("s_m", np.linspace(0.0, travel, int(n))),)
        elif over == "tool-rotation":
            a, b = rotation_range_rad
            full = abs((b - a) - 2 * math.pi) < 1e-9
            axes = (("tool_rotation_rad", np.linspace(a, b, int(n), endpoint=not full)),)
        elif over == "lead-tilt":
            a, b = tilt_range_rad
            axes = (("tilt_rad", np.linspace(a, b, int(n))),)
        else:
            raise BadInput(f"over must be one of {', '.join(OVER)}, got {over!r}")
        speeds = np.linspace(2000.0, 25000.0, 100) if speeds_rpm is None else speeds_rpm
        return cls(case=case, variant=variant, over=over, axes=axes, speeds_rpm=speeds,
                   op_rpm=float(case.cut.spindle_rpm if op_rpm is None else op_rpm),
                   tool_modes=tuple(tool_modes), model_file=model_file)

    # ------------------------------------------------------------------ geometry
    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(v) for _, v in self.axes)

    @property
    def n_poses(self) -> int:
        return int(np.prod(self.shape)) if self.axes else 1

    def pose_values(self) -> dict[str, np.ndarray]:
        """Each axis' value at every pose, ``{name: (P,)}`` (flattened Cartesian product, C order);
        axes not swept are 0."""
        out = {k: np.zeros(self.n_poses) for k in AXES}
        if self.axes:
            mesh = np.meshgrid(*[v for _, v in self.axes], indexing="ij")
            for (name, _), g in zip(self.axes, mesh):
                out[name] = g.reshape(-1)
        return out

    def describe(self) -> dict:
        """JSON-able description of the inputs (hashed into the store's provenance)."""
        c = self.case
        return {"case": c.name, "robot": c.robot.name, "tool": repr(c.tool), "cut": repr(c.cut), "law": repr(c.law),
                "start_q_rad": np.asarray(c.path.start_q_rad).tolist(), "variant": self.variant, "over": self.over,
                "axes": {k: v.tolist() for k, v in self.axes}, "speeds_rpm": self.speeds_rpm.tolist(),
                "op_rpm": self.op_rpm, "tool_modes": [repr(m) for m in self.tool_modes],
                "model_file": self.model_file}


@dataclass(frozen=True)
class MapMethod:
    """How each pose is solved: today's ``robolobes lobes`` fidelity (the full model) by default.

    Attributes
    ----------
    m : int
        SDM steps per principal period (40).
    depth_max_m : float
        Largest depth searched, m (0.01).
    rtol : float
        Relative bracket width of each critical depth (1e-3).
    reduce_max_freq_hz : float or None
        Default None: the full model at every pose (the limits are then those of
        ``lobes.solve`` of the full structure, and the error estimate of ``tol`` covers them).
        A frequency (Hz, opt-in): modal truncation of the robot at each pose, keeping the modes
        up to this natural frequency. Faster, but not covered by the error estimate: its error
        against the full model is measured at every pose only as static compliance and FRF error
        in the band (:class:`lobes.TruncationReport`, stored), and at 300 Hz it moved the limits
        by up to 3.9 % (20 random aluminium placement poses) and 10.2 % (steel placement poses)
        from ``lobes.solve`` of the full model (docs/guide/workspace.md).
    reduce_residual : bool
        Only with ``reduce_max_freq_hz``. True: the dropped modes are replaced by a residual mode
        carrying their static compliance (``lobes.basis.truncated_with_residual``: the cut-plane
        static compliance is kept exactly, the stored static error is at rounding level); the
        report's errors are then those of the cut-plane rows (x_c, y_c; the axial displacement
        enters no chip thickness). Default False: plain truncation (no static correction), errors
        of the full 3 x 3 receptance. With the residual the 300 Hz truncation is still up to
        1.09 % (aluminium) and 7.4 % (steel) off ``lobes.solve`` of the full model
        (docs/guide/workspace.md) and costs more CPU per pose than plain truncation.
    error_band_hz : (float, float)
        Band of the truncation's FRF error, Hz.
    prescan_m : int or None
        Steps per period of the cheap free-exact depth prescan that brackets each limit before the
        SDM at ``m`` verifies the bracket and refines it (``SemiDiscretization.prescan_m``; None:
        ``m``). The limits stay the SDM's: at three bench poses, 101 speeds, they equal those of
        the default prescan to 6e-14.
    chunk_poses : int
        Poses per chunk (unit of work, of storage and of resume).
    tol : float or None
        Default 0.01: the limits are refined per speed from ``m`` until their error estimate is
        below ``tol`` (``lobes.RefinedSDM``, the rule of ``robolobes lobes``), up to m = 320; the
        estimate and the status of every limit are stored (``depth_error_m``, ``unconverged``).
        None: one SDM level ``m`` per pose, no error estimate (NaN in the store).
    search : {"fast", "plain"}
        Depth search (``lobes.SemiDiscretization.search``); "plain" is the earlier one, for
        ``bench/bench_workspace.py``.
    """

    m: int = 40
    depth_max_m: float = 0.01
    rtol: float = 1e-3
    reduce_max_freq_hz: float | None = None
    reduce_residual: bool = False
    error_band_hz: tuple = (0.0, 1000.0)
    prescan_m: int | None = 12
    chunk_poses: int = 10
    tol: float | None = 0.01
    search: Search = "fast"

    def __post_init__(self) -> None:
        if isinstance(self.m, bool) or not isinstance(self.m, int) or self.m < 2:
            raise BadInput(f"m must be an integer >= 2, got {self.m!r}")
        if not (math.isfinite(self.depth_max_m) and 0 < self.depth_max_m <= 0.1):
            raise BadInput(f"depth_max_m must be in (0, 0.1] m, got {self.depth_max_m}")
        if not 0 < self.rtol < 0.5:
            raise BadInput(f"rtol must be in (0, 0.5), got {self.rtol}")
        if self.reduce_max_freq_hz is not None and not (math.isfinite(self.reduce_max_freq_hz)
                                                        and self.reduce_max_freq_hz > 0):
            raise BadInput(f"reduce_max_freq_hz must be a frequency > 0 Hz or None, got {self.reduce_max_freq_hz}")
        if not isinstance(self.reduce_residual, bool):
            raise BadInput(f"reduce_residual must be True or False, got {self.reduce_residual!r}")
        if self.reduce_residual and self.reduce_max_freq_hz is None:
            raise BadInput("reduce_residual=True needs a truncation (reduce_max_freq_hz in Hz): the full model "
                           "(reduce_max_freq_hz=None, the default) drops no mode")
        if self.prescan_m is not None and (isinstance(self.prescan_m, bool) or not isinstance(self.prescan_m, int)
                                           or self.prescan_m < 2):
            raise BadInput(f"prescan_m must be an integer >= 2 or None, got {self.prescan_m!r}")
        if isinstance(self.chunk_poses, bool) or not isinstance(self.chunk_poses, int) or not 1 <= self.chunk_poses <= 1000:
            raise BadInput(f"chunk_poses must be an integer from 1 to 1000, got {self.chunk_poses!r}")
        if self.tol is not None and (isinstance(self.tol, bool) or not isinstance(self.tol, (int, float))
                                     or not 0 < self.tol < 0.5):
            raise BadInput(f"tol must be None or a relative error target in (0, 0.5), got {self.tol!r}")
        if self.search not in ("fast", "plain"):
            raise BadInput(f"search must be 'fast' or 'plain', got {self.search!r}")

    def describe(self) -> dict:
        return {"m": self.m, "depth_max_m": self.depth_max_m, "rtol": self.rtol,
                "reduce_max_freq_hz": self.reduce_max_freq_hz,
                **({"reduce_residual": True} if self.reduce_residual else {}),  # stores made before it resume
                "error_band_hz": list(self.error_band_hz),
                "prescan_m": self.prescan_m,
                "chunk_poses": self.chunk_poses, **({} if self.tol is None else {"tol": self.tol}),
                "search": self.search}


def series_modes(problem: MapProblem) -> tuple:
    """The problem's tool modes put in series with the robot (lobes Mode / ComplexMode; the TCP
    oscillators are in the robot instead)."""
    return tuple(m for m in problem.tool_modes if isinstance(m, (Mode, ComplexMode)))


def tool_oscillators(problem: MapProblem) -> tuple:
    """The problem's TCP oscillators (added to the robot by :func:`workspace.compute.build_robot`)."""
    return tuple(m for m in problem.tool_modes if not isinstance(m, (Mode, ComplexMode)))
