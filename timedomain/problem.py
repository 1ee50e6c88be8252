"""What a time-domain simulation is asked to do: the problem (a built robot cutting a case's part)
and the method (linearized or nonlinear Newmark, with its discretization), with their bounds.

``simulate(SimulationProblem(robot, case), LinearizedNewmark())`` (:mod:`timedomain.simulation`)
follows the lobes' shape ``solve(problem, method)``: the problem says what is simulated, the method
how. The robot is built by the caller (:func:`linearize.build_model`), so that damping scales,
``extra_elements`` and effects added by identification are simulated as they are linearized.

Bounds (everything that sets memory or run time is bounded; each violation raises
:class:`SimulationError`, a :class:`~robolobes.core.errors.BadInput`, before any work):

* ``t_end_s`` in (0, pass duration]: past the end of the pass there is no motion to simulate;
* the records of a run (time, force, centre, TCP: :data:`RECORD_BYTES_PER_STEP` bytes per step) stay
  below :data:`MAX_RECORD_BYTES` = 2 GiB, which bounds ``t_end_s / h`` for a small ``deg_per_step``;
* ``deg_per_step`` in (0, 10] deg of spindle rotation (coarser misses the tooth-tip arcs);
* ``n_discs`` in [1, :data:`MAX_DISCS`] (the workpiece grid itself is bounded by
  :data:`timedomain.workpiece._MAX_CELLS`);
* ``dx_m`` in [0.1 um, 100 um].
"""

from __future__ import annotations

import math
from dataclasses import KW_ONLY, dataclass

from robolobes.cases.spec import MillingCase
from robolobes.core.errors import BadInput
from robolobes.core.validate import finite, integer
from robolobes.linearize.model import FlexibleRobot

__all__ = ["SimulationError", "SimulationProblem", "LinearizedNewmark", "NonlinearNewmark", "DelayNewmark", "Method",
           "MAX_RECORD_BYTES", "RECORD_BYTES_PER_STEP", "MAX_DISCS", "max_steps", "step_count", "pass_duration_s"]

#: Memory of a run's records: t (8 B), force (3 x 8), centre (2 x 8), TCP (3 x 8) per step.
RECORD_BYTES_PER_STEP = 8 * (1 + 3 + 2 + 3)
#: The records of one run stay below 2 GiB (the part's grid is bounded separately).
MAX_RECORD_BYTES = 2 * 1024 ** 3
#: Axial discs of the tool: the default puts 0.5 deg of helix lag per disc (22 for the TX200 cuts).
MAX_DISCS = 1000


class SimulationError(BadInput):
    """A simulation problem or method out of its valid range (the message says which and what is valid)."""


def max_steps() -> int:
    """Largest number of time steps whose records fit in :data:`MAX_RECORD_BYTES`."""
    return MAX_RECORD_BYTES // RECORD_BYTES_PER_STEP


def _check_step_and_discs(deg_per_step: float, n_discs: int | None) -> None:
    """The step (deg of spindle rotation, in (0, 10]) and axial disc count (1..MAX_DISCS, or None) of a method."""
    d = finite("deg_per_step", deg_per_step, positive=True, error=SimulationError)
    if d > 10:
        raise SimulationError(f"deg_per_step must be in (0, 10] deg of spindle rotation per step, got {d}")
    if n_discs is not None:
        integer("n_discs", n_discs, minimum=1, maximum=MAX_DISCS, error=SimulationError)


@dataclass(frozen=True)
class _NewmarkMethod:
    deg_per_step: float = 2.0
    n_discs: int | None = None
    dx_m: float = 1e-6
    entry_exit: str = "exact"

    def __post_init__(self):
        _check_step_and_discs(self.deg_per_step, self.n_discs)
        if self.entry_exit not in ("exact", "sampled"):
            raise SimulationError(f"entry_exit must be 'exact' or 'sampled', got {self.entry_exit!r}")
        dx = finite("dx_m", self.dx_m, positive=True, error=SimulationError)
        if not 1e-7 <= dx <= 1e-4:
            raise SimulationError(f"dx_m (workpiece column spacing) must be in [1e-7, 1e-4] m, got {dx:g}")


@dataclass(frozen=True)
class LinearizedNewmark(_NewmarkMethod):
    """The robot linearized at the pass start (gears engaged, the dead zone kept), with the nonlinear
    milling force on the eroded part; compiled (:mod:`timedomain.fastpath`). The fast path for sweeps.

    Parameters
    ----------
    deg_per_step : float
        Spindle rotation per time step, deg, in (0, 10] (default 2: 180 steps per revolution).
    n_discs : int, optional
        Axial discs of the tool and slices of the part (default: 0.5 deg of helix lag each).
    dx_m : float
        Column spacing of the workpiece along the feed, m (default 1 um).
    entry_exit : {"exact", "sampled"}
        "exact" (default): an edge element that enters or leaves the part inside a step is
        integrated over its engaged part of the step (:mod:`timedomain.entry_exit`). "sampled": the
        force is sampled at the step ends only, a plain Newmark step (first order at each entry and
        exit; for comparison).
    kick_m_s : float
        Velocity kick, m/s, in [-1, 1] (default 0: none): at ``kick_at_s`` the joint velocities jump by the
        minimum-norm change that moves the tool centre at this speed along the cut frame's normal
        (y), the acceleration kept consistent. The eroded part otherwise starts from rest, and near
        a stability limit its regenerative mode can stay under the motion forced by the pass (the
        part's column grid): a kick lifts it above that floor (bench/bench_timedomain_steel_floor.py).
    kick_at_s : float, optional
        Time of the kick, s, >= 0 (default: the start of full engagement); rounded to the time grid;
        a kick after the run's end is refused (``SimulationError``) before the run starts.
    """

    kick_m_s: float = 0.0
    kick_at_s: float | None = None

    def __post_init__(self):
        super().__post_init__()
        v = finite("kick_m_s", self.kick_m_s, error=SimulationError)
        if abs(v) > 1.0:
            raise SimulationError(f"kick_m_s (velocity kick) must be in [-1, 1] m/s, got {v:g}")
        if self.kick_at_s is not None:
            finite("kick_at_s", self.kick_at_s, nonneg=True, error=SimulationError)


@dataclass(frozen=True)
class NonlinearNewmark(_NewmarkMethod):
    """Newmark (average acceleration) with Newton on the full nonlinear multibody equations.

    Parameters
    ----------
    deg_per_step, n_discs, dx_m, entry_exit : as :class:`LinearizedNewmark`
    atol : float
        Newton increment tolerance, absolute, in the units of each q (rad), > 0 (default 1e-11).
    rtol : float
        Newton increment tolerance relative to the step's change of q, > 0 (default 1e-8).
    max_iter : int
        Newton iterations before a step is halved, in [1, 100] (default 20).
    """

    atol: float = 1e-11
    rtol: float = 1e-8
    max_iter: int = 20

    def __post_init__(self):
        super().__post_init__()
        finite("atol", self.atol, positive=True, error=SimulationError)
        finite("rtol", self.rtol, positive=True, error=SimulationError)
        integer("max_iter", self.max_iter, minimum=1, maximum=100, error=SimulationError)


@dataclass(frozen=True)
class DelayNewmark:
    """The delay-based regenerative model (:mod:`timedomain.delay`): the chip of every tooth and disc
    is the static chip plus the projection of the displacement now minus one tooth delay earlier, at
    the nominal (fixed) engagement, on a linear structure (the robot linearized at the pass start, or
    a modal / physical structure); average-acceleration Newmark with exact entry and exit of every
    element inside a step.

    Parameters
    ----------
    deg_per_step : float
        Spindle rotation per time step, deg, in (0, 10] (default 2).
    n_discs : int, optional
        Axial discs of the tool (default: 0.5 deg of helix lag each; 1 for a straight tool).
    kick_m : float
        Initial displacement of the tool in the cut plane, m, in [1e-9, 1e-3] (default 5 um): the
        structure starts deflected by a force in a seeded random direction of the cut plane.
    seed : int
        Seed of that direction (default 0).
    entry_exit : {"exact", "sampled"}
        "exact" (default): each element's entry into and exit from the arc inside a step is
        integrated exactly (second order). "sampled": the screen function is sampled at the step
        ends, as a plain Newmark step does (first order; for comparison with the eroded part).
    chip_loss : bool
        True (default): the force is zero where the chip is not positive (the tooth leaves the cut).
        False: the force stays linear in the chip inside the nominal arc, negative chips included
        (the screen function of the arc still applies): the exact linear model the
        semi-discretization linearizes, whose growth rate does not depend on the kick (its rate is
        not gated by the chip loss, which it still reports).
    """

    deg_per_step: float = 2.0
    n_discs: int | None = None
    kick_m: float = 5e-6
    seed: int = 0
    entry_exit: str = "exact"
    chip_loss: bool = True

    def __post_init__(self):
        _check_step_and_discs(self.deg_per_step, self.n_discs)
        if not isinstance(self.chip_loss, bool):
            raise SimulationError(f"chip_loss must be True or False, got {self.chip_loss!r}")
        k = finite("kick_m", self.kick_m, positive=True, error=SimulationError)
        if not 1e-9 <= k <= 1e-3:
            raise SimulationError(f"kick_m (initial tool displacement) must be in [1e-9, 1e-3] m, got {k:g}")
        integer("seed", self.seed, minimum=0, error=SimulationError)
        if self.entry_exit not in ("exact", "sampled"):
            raise SimulationError(f"entry_exit must be 'exact' or 'sampled', got {self.entry_exit!r}")


Method = LinearizedNewmark | NonlinearNewmark | DelayNewmark


@dataclass(frozen=True, eq=False)
class SimulationProblem:
    """A time-domain simulation of a built robot cutting one case's pass.

    Parameters
    ----------
    robot : linearize.FlexibleRobot
        Built with :func:`linearize.build_model` (variant, ``damping_scale``, ``extra_elements``).
    case : MillingCase
        Tool, material, cut and pass (the robot's spec is taken from ``robot``).
    t_end_s : float, optional
        Simulate from 0 to this time, s, in (0, pass duration] (default: the whole pass).
    stats_window_s : (float, float), optional
        Window of the force statistics, s (default: the steady cut, full engagement).
    """

    robot: FlexibleRobot
    case: MillingCase
    _: KW_ONLY
    t_end_s: float | None = None
    stats_window_s: tuple[float, float] | None = None

    def __post_init__(self):
        if not isinstance(self.robot, FlexibleRobot):
            raise SimulationError(f"robot must be a linearize.FlexibleRobot (linearize.build_model(...)), "
                                  f"got {type(self.robot).__name__}")
        if not isinstance(self.case, MillingCase):
            raise SimulationError(f"case must be a cases.MillingCase (cases.load_case(...)), "
                                  f"got {type(self.case).__name__}")
        if self.t_end_s is not None:
            t = finite("t_end_s", self.t_end_s, positive=True, error=SimulationError)
            duration = self.pass_duration_s
            if t > duration * (1 + 1e-12):
                raise SimulationError(f"t_end_s = {t:g} s is past the end of the pass ({duration:.6g} s for case "
                                      f"{self.case.name!r}); valid: 0 < t_end_s <= {duration:.6g}")
        if self.stats_window_s is not None:
            w = self.stats_window_s
            if len(w) != 2:
                raise SimulationError(f"stats_window_s must be (start, end) in s, got {w!r}")
            lo = finite("stats_window_s[0]", w[0], nonneg=True, error=SimulationError)
            hi = finite("stats_window_s[1]", w[1], error=SimulationError)
            if not hi > lo:
                raise SimulationError(f"stats_window_s must have end > start, got ({lo:g}, {hi:g}) s")
            object.__setattr__(self, "stats_window_s", (lo, hi))

    @property
    def pass_duration_s(self) -> float:
        """Duration of the whole pass, s (:func:`pass_duration_s`)."""
        return pass_duration_s(self.case)

    @property
    def end_time_s(self) -> float:
        """The simulated end time, s: ``t_end_s`` or the pass duration."""
        return float(self.t_end_s) if self.t_end_s is not None else self.pass_duration_s


def pass_duration_s(case: MillingCase) -> float:
    """Duration of a case's whole pass (S-curve feed over the path), s: the feed profile of
    :class:`linearize.path.Pass`, without its inverse kinematics."""
    from robolobes.linearize.path import FeedProfile

    feed = case.cut.feed_rate_m_per_s(case.tool)
    if not feed > 0:
        raise SimulationError(f"case {case.name!r}: the feed rate is {feed} m/s; a pass needs a feed rate > 0")
    return float(FeedProfile(travel_m=case.path.travel_m(case.tool), feed_m_per_s=feed,
                             ramp_s=case.path.ramp_s).duration_s)


def step_count(problem: SimulationProblem, method: Method) -> tuple[float, int]:
    """Nominal time step (s) and number of steps of ``problem`` with ``method``, bounded.

    Raises :class:`SimulationError` when the records would exceed :data:`MAX_RECORD_BYTES`."""
    if not isinstance(method, (LinearizedNewmark, NonlinearNewmark)):
        raise SimulationError(f"method must be LinearizedNewmark(...) or NonlinearNewmark(...), got {method!r}")
    h = math.radians(method.deg_per_step) / problem.case.cut.omega_rad_s
    t_end = problem.end_time_s
    n = max(1, int(math.ceil(t_end / h - 1e-9)))
    if n + 1 > max_steps():
        raise SimulationError(
            f"deg_per_step = {method.deg_per_step:g} over {t_end:.4g} s needs {n} steps, whose records "
            f"({(n + 1) * RECORD_BYTES_PER_STEP / 2 ** 30:.1f} GiB) exceed the {MAX_RECORD_BYTES / 2 ** 30:.0f} GiB "
            f"limit; valid: deg_per_step >= {math.degrees(t_end / max_steps() * problem.case.cut.omega_rad_s):.3g} "
            f"or a shorter t_end_s")
    return h, n
