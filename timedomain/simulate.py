"""Time-domain simulation of a milling pass: the flexible robot, its motors, and the eroded part.

Full path (``linearized=False``): Newmark average acceleration (:mod:`timedomain.newmark`) on the
nonlinear multibody equations of :mod:`linearize.model`, in residual form::

    r(q, v, a, t) = rnea(q, v, a) - sum_e tau_e(q, v, theta(t)) - J(q)^T R_c^T F_tool(c(q), t) = 0

with the motor angles ``theta(t)`` from the closed-form IK of the pass (:class:`linearize.path.Pass`),
gravity and compensation where the variant has them, the backlash dead zone in full, and the
milling force of :mod:`timedomain.cutting` on the eroded :class:`~timedomain.workpiece.Workpiece`.
``c(q)`` is the tool centre (the TCP) in the cut frame, measured from the commanded start point;
the part is fixed in that frame. Newton uses pinocchio's analytic derivatives
(``computeRNEADerivatives``), the elements' tangents and the cutting tangent
``-J^T R_c^T (dF/dc) R_c J``.

Linearized path (``linearized=True``): the foundation's linearization at the start pose
(``M, C, K, J`` of :func:`linearize.linearize`, gears engaged) for the deviation ``dq`` from the
nominal motion ``q_nom(t) = rigid_q(theta(t)) + (q_eq - rigid_q(theta_0))``, keeping the same
nonlinear milling force and, for the backlash variant, the motion springs' dead zone::

    M dqdd + C dqd + K_rest dq + k o (dz(d0 + dq) - dz(d0)) = J^T R_c^T F_tool - f_nom(t)
    f_nom(t) = M P thetadd + C P thetad + G P (theta - theta_0)

``K_rest`` is K without the motion springs, ``d0`` the static deflection of the motion axes at the
start, ``P`` places motor angles into q, ``G`` the gravity (and compensation) part of K. The
nominal motion's inertia, the dampers acting on the absolute velocity (eq. 7) and the change of
the gravity load along the pass enter as ``f_nom``.

Outputs (:class:`SimulationResult`): forces on the workpiece in the dynamometer frame (the cut
frame: x along the feed, y normal, z along the spindle, up), the TCP deviation from the commanded
path (cut frame), the machined wall, its roughness, force statistics over a window, the
once-per-revolution stability verdict and the chatter frequency.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np
import pinocchio as pin

from robolobes.cases.milling import cut_frame
from robolobes.cases.spec import MillingCase
from robolobes.linearize.linear import equilibrium, linearize
from robolobes.linearize.model import (VARIANTS, MotionSprings, build_model, dead_zone, element_forces, element_tangents,
                             rigid_q)
from robolobes.linearize.path import Pass

from .cutting import MillingForce
from .newmark import NewmarkOptions, integrate
from .signals import chatter_frequency, force_stats
from .verdict import VERDICT_KEYS, principal_period, verdict_summary
from .workpiece import Workpiece, default_disc_count

__all__ = ["SimulationProblem", "SimulationResult", "simulate", "summarize", "robot_equations", "PAPER_AXES",
           "LinearSystemData", "linear_system_data", "Records"]

#: How the paper's Tab. 10 axes relate to ours (evidence in :mod:`timedomain.cutting`):
#: paper Fx = force on the tool along x_c = -F_workpiece.x ; paper Fy = -F_tool.y = F_workpiece.y.
PAPER_AXES = np.array([-1.0, 1.0])


@dataclass(frozen=True)
class SimulationProblem:
    """A time-domain simulation of one case's pass.

    Parameters
    ----------
    case : MillingCase
    variant : {"basic", "gravity", "orthogonal", "backlash"}
    damping_scale : float
        Factor on the motion-axis damping (the paper's x10 experiment), >= 0.
    t_end_s : float, optional
        Simulate from 0 to this time (default: the whole pass).
    deg_per_step : float
        Spindle rotation per nominal time step, deg (default 2: 180 steps per revolution).
    n_discs : int, optional
        Axial discs of the tool and slices of the part (default: 0.5 deg of helix lag each).
    linearized : bool
        Use the linearized fast path (module docstring).
    dx_m : float
        Column spacing of the workpiece along the feed, m.
    stats_window_s : (float, float), optional
        Window of the force statistics, s (default: the steady cut, full engagement).
    """

    case: MillingCase
    variant: str = "backlash"
    damping_scale: float = 1.0
    t_end_s: float | None = None
    deg_per_step: float = 2.0
    n_discs: int | None = None
    linearized: bool = False
    dx_m: float = 1e-6
    stats_window_s: tuple[float, float] | None = None

    def __post_init__(self):
        if self.variant not in VARIANTS:
            raise ValueError(f"unknown model variant {self.variant!r}; valid: {', '.join(VARIANTS)}")
        for name in ("damping_scale", "deg_per_step"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise ValueError(f"{name} must be a finite number >= 0, got {v!r}")
        if not 0 < self.deg_per_step <= 10:
            raise ValueError(f"deg_per_step must be in (0, 10] deg of spindle rotation, got {self.deg_per_step}")
        if self.t_end_s is not None and not (math.isfinite(self.t_end_s) and self.t_end_s > 0):
            raise ValueError(f"t_end_s must be a finite time > 0 s, got {self.t_end_s!r}")


@dataclass(frozen=True)
class SimulationResult:
    """Time series and derived numbers of a simulated pass (SI; arrays read-only).

    Attributes
    ----------
    problem : SimulationProblem
    t_s : array (N,)
    force_workpiece_n : array (N, 3)
        Force on the workpiece (what the dynamometer measures), cut frame axes, N.
    tcp_deviation_m : array (N, 3)
        TCP minus the commanded path, cut frame, m.
    spindle_angle_rad : array (N,)
    wall_x_m : array (n,), wall_y_m : array (K, n)
        Machined lateral wall per slice (y of the wall, cut frame; nominal ``-R`` for down-milling).
    steady_window_s : (float, float)
        Full engagement of the tool in the part.
    stats : dict
        Run statistics (wall time, steps, Newton iterations, rejections).
    summary : dict
        Derived numbers (see :func:`summarize`).
    """

    problem: SimulationProblem
    t_s: np.ndarray
    force_workpiece_n: np.ndarray
    tcp_deviation_m: np.ndarray
    spindle_angle_rad: np.ndarray
    wall_x_m: np.ndarray
    wall_y_m: np.ndarray
    steady_window_s: tuple[float, float]
    stats: dict
    summary: dict

    @property
    def force_tool_n(self) -> np.ndarray:
        """Force on the tool, cut frame, (N, 3), N."""
        return -self.force_workpiece_n

    @property
    def force_paper_axes_n(self) -> np.ndarray:
        """(Fx, Fy) as the paper's Tab. 10 reports them, (N, 2), N (see ``PAPER_AXES``)."""
        return self.force_workpiece_n[:, :2] * PAPER_AXES


def _ro(a):
    a = np.array(a)
    a.setflags(write=False)
    return a


def _lerp_row(tab: np.ndarray, dt: float, t: float):
    """Row of a uniform table (spacing dt from t = 0) at time t, linearly interpolated, clamped."""
    x = t / dt
    i = min(max(int(x), 0), len(tab) - 2)
    f = x - i
    return tab[i] + f * (tab[i + 1] - tab[i])


class _Setup:
    """Everything a run needs, built once: model, pass, cut frame, part, motor-angle tables."""

    def __init__(self, problem: SimulationProblem):
        case = problem.case
        self.case = case
        self.robot = build_model(case.robot, problem.variant, damping_scale=problem.damping_scale)
        self.pas = Pass.from_case(case)
        tool, cut = case.tool, case.cut
        self.Rc = cut_frame(cut.feed_direction, self.pas.tool_axis)
        self.p_ref = np.asarray(self.pas.start_position, dtype=float)
        self.omega = cut.omega_rad_s
        self.t_end = float(problem.t_end_s if problem.t_end_s is not None else self.pas.duration_s)
        self.h = math.radians(problem.deg_per_step) / self.omega
        self.n_steps = max(1, int(math.ceil(self.t_end / self.h - 1e-9)))
        n_discs = problem.n_discs or default_disc_count(tool, cut.ap_m)
        x_entry = self.pas.part_entry_s + tool.radius_m
        self.workpiece = Workpiece(tool, cut, x_entry_m=x_entry, part_length_m=case.path.part_length_m,
                                   discs=n_discs, dx_m=problem.dx_m)
        self.milling = MillingForce(tool, case.law, cut, self.workpiece)
        # motor angles on a fine table (0.2 ms; linear interpolation error ~ dt^2/8 |thetadd| ~ 1e-8 rad)
        n_tab = max(3, int(math.ceil(max(self.t_end, self.h) / 2e-4)) + 1)
        self.t_tab = np.linspace(0.0, max(self.t_end, self.h) + self.h, n_tab)
        self.dt_tab = self.t_tab[1] - self.t_tab[0]
        self.th_tab = self.pas.theta(self.t_tab)
        eq = equilibrium(self.robot, self.th_tab[0])
        self.q_eq = np.asarray(eq.q)
        # steady window: tool fully engaged (centre past the entry face + R, before exit face - R)
        pe = self.pas.part_entry_s + tool.diameter_m
        px = self.pas.part_exit_s - tool.diameter_m
        self.steady = (float(self.pas.time_at_s(pe)), float(self.pas.time_at_s(max(pe, px))))

    def theta(self, t: float) -> np.ndarray:
        return _lerp_row(self.th_tab, self.dt_tab, t)

    def center_of(self, p_tcp: np.ndarray) -> np.ndarray:
        return self.Rc[:2] @ (p_tcp - self.p_ref)


def robot_equations(robot, theta_of_t: Callable[[float], np.ndarray], tcp_force=None):
    """Residual and tangent of the flexible robot for :func:`timedomain.newmark.integrate`.

    ``r(q, v, a, t) = rnea(q, v, a) - sum_e tau_e(q, v, theta(t)) - J(q)^T F(t, p(q))``

    Parameters
    ----------
    robot : linearize.FlexibleRobot
    theta_of_t : callable ``t -> theta (n_joints,)``, rad
        Motor angles.
    tcp_force : callable ``(t, p_tcp) -> (F (3,), dF_dp (3, 3))``, optional
        Force on the TCP in the base frame (N) and its derivative with respect to the TCP
        position (N/m); enters the tangent as ``-J^T dF_dp J``.

    Returns
    -------
    residual, tangent : callables of ``(q, v, a, t)``
    kin : callable ``q -> (J (3, n), p (3,))``, translational TCP Jacobian (base axes) and position
    last : dict
        ``last["F"]``: the TCP force of the last residual evaluation.
    """
    model, data, tcp = robot.model, robot.data, robot.tcp_frame
    cache = {}
    last = {}

    def kin(q):
        key = q.tobytes()
        if cache.get("key") != key:
            J = pin.computeFrameJacobian(model, data, q, tcp, pin.LOCAL_WORLD_ALIGNED)[:3]
            cache.update(key=key, J=J, p=data.oMf[tcp].translation.copy())
        return cache["J"], cache["p"]

    def residual(q, v, a, t):
        r = pin.rnea(model, data, q, v, a) - element_forces(robot, q, v, theta_of_t(t))
        if tcp_force is not None:
            J, p = kin(q)
            F, _ = tcp_force(t, p)
            last["F"] = F
            r = r - J.T @ F
        return r

    def tangent(q, v, a, t):
        dq, dv, M = pin.computeRNEADerivatives(model, data, q, v, a)
        kq, kv = element_tangents(robot, q, v, theta_of_t(t))
        dq = dq - kq
        if tcp_force is not None:
            J, p = kin(q)
            _, dF = tcp_force(t, p)
            dq = dq - J.T @ dF @ J
        return dq, dv - kv, M

    return residual, tangent, kin, last


def _full_system(S: _Setup):
    Rc, RcT, milling, omega = S.Rc, S.Rc.T, S.milling, S.omega
    last_cut = {}

    def tcp_force(t, p):
        f_cut, dfdc = milling.force(omega * t, S.center_of(p))
        last_cut["f"] = f_cut
        return RcT @ f_cut, RcT @ dfdc @ Rc[:2]

    residual, tangent, kin, _ = robot_equations(S.robot, S.theta, tcp_force)
    return residual, tangent, (lambda q: kin(q)[1]), S.q_eq.copy(), last_cut


@dataclass(frozen=True)
class LinearSystemData:
    """The linearized path's equations (module docstring), as arrays; n = number of DOF.

    Attributes
    ----------
    M, C, K_rest : array (n, n)       SI; K_rest = K without the motion springs
    K : array (n, n)                  full linearized stiffness (the Newton matrix uses K, C, M)
    motion_dofs : int array (6,)      indices of the motion axes in q
    k_motion : array (6,)             motion spring stiffness, N m/rad
    backlash_rad : float              dead-zone half-width s (0: linear springs)
    d0 : array (6,)                   static deflection q - theta of the motion axes at the start
    Jc : array (2, n)                 TCP displacement in the cut plane (x_c, y_c) per dq, m
    JtRt : array (n, 3)               J^T R_c^T: generalized force per cut-frame TCP force
    c_off : array (2,)                static TCP offset from the commanded start point, cut frame, m
    t_tab : array (T,)                uniform time table, s (spacing dt_tab)
    s_tab : array (T,)                commanded path coordinate s(t), m
    f_nom_tab : array (T, n)          nominal-motion forcing f_nom(t) (enters the residual with +)
    """

    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    K_rest: np.ndarray
    motion_dofs: np.ndarray
    k_motion: np.ndarray
    backlash_rad: float
    d0: np.ndarray
    Jc: np.ndarray
    JtRt: np.ndarray
    c_off: np.ndarray
    t_tab: np.ndarray
    s_tab: np.ndarray
    f_nom_tab: np.ndarray

    @property
    def dt_tab(self) -> float:
        return float(self.t_tab[1] - self.t_tab[0])

    def interp(self, tab: np.ndarray, t: float):
        """Linear interpolation of a table row at time t (clamped to the table)."""
        return _lerp_row(tab, self.dt_tab, t)

    def center(self, dq: np.ndarray, t: float) -> np.ndarray:
        """Tool centre (x_c, y_c) in the cut frame, m."""
        return np.array([self.interp(self.s_tab, t), 0.0]) + self.c_off + self.Jc @ dq

    def residual(self, dq, v, a, t, f_cut_tool: np.ndarray) -> np.ndarray:
        """Residual for a given cut-frame force on the tool (N), shape (n,)."""
        idx, k, s = self.motion_dofs, self.k_motion, self.backlash_rad
        r = self.M @ a + self.C @ v + self.K_rest @ dq - self.JtRt @ f_cut_tool + self.interp(self.f_nom_tab, t)
        if s > 0:
            r[idx] += k * (dead_zone(self.d0 + dq[idx], s) - dead_zone(self.d0, s))
        else:
            r[idx] += k * dq[idx]
        return r


def linear_system_data(S: "_Setup") -> LinearSystemData:
    """Build the linearized path's arrays at the pass start (module docstring)."""
    robot = S.robot
    lin = linearize(robot, S.th_tab[0])
    M, C, K, J = (np.asarray(x) for x in (lin.M, lin.C, lin.K, lin.J))
    n = robot.nv
    idx = np.asarray(robot.motion_dofs)
    P = np.zeros((n, len(idx)))
    P[idx, np.arange(len(idx))] = 1.0
    springs = [e for e in robot.elements if isinstance(e, MotionSprings)]
    k = np.asarray(springs[0].stiffness, dtype=float)
    K_ms = np.zeros((n, n))
    K_ms[idx, idx] = k
    # gravity (+ compensation) part of K: K minus every element's spring tangent
    kq, _ = element_tangents(robot, np.asarray(lin.q), np.zeros(n), np.asarray(lin.theta), engaged=True)
    G = K + kq
    th = S.th_tab
    thd = np.gradient(th, S.dt_tab, axis=0)
    thdd = np.gradient(thd, S.dt_tab, axis=0)
    f_nom = (thdd @ (M @ P).T) + (thd @ (C @ P).T) + ((th - th[0]) @ (G @ P).T)
    return LinearSystemData(
        M=_ro(M), C=_ro(C), K=_ro(K), K_rest=_ro(K - K_ms), motion_dofs=_ro(idx), k_motion=_ro(k),
        backlash_rad=float(robot.backlash_rad), d0=_ro(np.asarray(lin.q)[idx] - np.asarray(lin.theta)),
        Jc=_ro(S.Rc[:2] @ J), JtRt=_ro(J.T @ S.Rc.T), c_off=_ro(S.center_of(np.asarray(lin.p_tcp))),
        t_tab=_ro(S.t_tab), s_tab=_ro(S.pas.s(S.t_tab)), f_nom_tab=_ro(f_nom))


def _linear_system(S: _Setup):
    """Python evaluation of the linearized path (reference for the compiled kernel)."""
    d = linear_system_data(S)
    milling, omega = S.milling, S.omega
    last = {}

    def residual(dq, v, a, t):
        f_cut, _ = milling.force(omega * t, d.center(dq, t))
        last["f"] = f_cut
        return d.residual(dq, v, a, t, f_cut)

    return residual, (d.K, d.C, d.M), d.center, np.zeros(d.M.shape[0]), last


@dataclass(frozen=True)
class Records:
    """Raw output of one run: every nominal grid time from 0 (inclusive).

    t_s (N,), force_tool_n (N, 3) cut frame, center_m (N, 2) cut frame, tcp_m (N, 3) base frame
    (NaN on the linearized path), stats (dict: steps, rejected, newton_iterations, ...).
    """

    t_s: np.ndarray
    force_tool_n: np.ndarray
    center_m: np.ndarray
    tcp_m: np.ndarray
    stats: dict


def _run_newmark(S: _Setup, residual, q0, center_at, tcp_of, last, progress, **kw) -> Records:
    N = S.n_steps + 1
    rec_t = np.empty(N)
    rec_f = np.empty((N, 3))
    rec_c = np.empty((N, 2))
    rec_p = np.full((N, 3), np.nan)
    count = [0]
    prev = {}

    def record(t, q, f=None):
        # f: the force of the last residual evaluation, at the converged Newton iterate (within the
        # increment tolerance, 1e-11, of the accepted q): no extra force evaluation per step
        c = center_at(q, t)
        if f is None:
            f, _ = S.milling.force(S.omega * t, c)
        i = count[0]
        rec_t[i], rec_f[i], rec_c[i] = t, f, c
        p = tcp_of(q, t)
        if p is not None:
            rec_p[i] = p
        count[0] += 1
        return c

    prev.update(t=0.0, c=record(0.0, q0))

    def on_step(st):
        if st.on_grid:
            c = record(st.t_s, st.q, last.get("f"))
        else:
            c = center_at(st.q, st.t_s)
        S.milling.commit(S.omega * prev["t"], prev["c"], S.omega * st.t_s, c)
        prev.update(t=st.t_s, c=c)

    n = len(q0)
    opts = NewmarkOptions(atol=np.full(n, 1e-11), rtol=1e-8, max_iter=20)
    res = integrate(residual, q0, np.zeros(n), t0_s=0.0, h_s=S.h, n_steps=S.n_steps, options=opts,
                    on_step=on_step, progress=progress, **kw)
    m = count[0]
    st = res.stats
    return Records(t_s=rec_t[:m], force_tool_n=rec_f[:m], center_m=rec_c[:m], tcp_m=rec_p[:m],
                   stats=dict(steps=st.accepted, rejected=st.rejected, newton_iterations=st.newton_iterations,
                              max_iterations=st.max_iterations))


def _run_full(S: _Setup, progress) -> Records:
    residual, tangent, tcp_position, q0, last = _full_system(S)
    return _run_newmark(S, residual, q0, lambda q, t: S.center_of(tcp_position(q)), lambda q, t: tcp_position(q),
                        last, progress, tangent=tangent)


def _run_linearized_python(S: _Setup, progress) -> Records:
    """The linearized path in Python (:func:`timedomain.newmark.integrate`): the reference of the
    compiled loop :mod:`timedomain.fastpath` (tests/test_fastpath.py), ~10x slower."""
    residual, const, center, q0, last = _linear_system(S)
    return _run_newmark(S, residual, q0, center, lambda q, t: None, last, progress, constant_tangent=const)


def _run_linearized(S: _Setup, progress) -> Records:
    """The linearized path, compiled (:func:`timedomain.fastpath.run_linear_milling`)."""
    from .fastpath import run_linear_milling

    run = run_linear_milling(linear_system_data(S), S.milling, h_s=S.h, n_steps=S.n_steps, omega_rad_s=S.omega,
                             progress=progress)
    return Records(t_s=run.t_s, force_tool_n=run.force_tool_n, center_m=run.center_m,
                   tcp_m=np.full((len(run.t_s), 3), np.nan), stats=run.stats)


def simulate(problem: SimulationProblem, progress: Callable[[float], None] | None = None, *,
             verdict_companion: bool = True) -> SimulationResult:
    """Simulate the pass of ``problem.case`` (module docstring for the equations).

    Parameters
    ----------
    problem : SimulationProblem
    progress : callable ``(fraction) -> None``, optional
        Called about every 1 % of the run.
    verdict_companion : bool
        For a tool with runout whose principal period is the tooth period, decide stability on a
        companion run without runout (see :func:`principal_period` and the summary's
        ``verdict_basis``).

    Returns
    -------
    SimulationResult

    Raises
    ------
    timedomain.newmark.NewmarkInterrupted
        On Ctrl-C (KeyboardInterrupt), carrying the last accepted state; nothing is written.
    """
    wall0 = time.perf_counter()
    S = _Setup(problem)
    rec = (_run_linearized if problem.linearized else _run_full)(S, progress)
    t = rec.t_s
    # deviation from the commanded path, cut frame: the commanded centre is (s(t), 0, 0)
    dev = np.zeros((len(t), 3))
    dev[:, 0] = rec.center_m[:, 0] - S.pas.s(t)
    dev[:, 1] = rec.center_m[:, 1]
    dev[:, 2] = (rec.tcp_m - S.p_ref) @ S.Rc[2]  # NaN on the linearized path (no axial output)
    wall = S.workpiece.wall_profile()
    stats = dict(wall_time_s=time.perf_counter() - wall0, h_s=S.h, n_dof=S.robot.nv,
                 n_discs=S.workpiece.discs.count, linearized=problem.linearized, **rec.stats)
    result = SimulationResult(problem=problem, t_s=_ro(t), force_workpiece_n=_ro(-rec.force_tool_n),
                              tcp_deviation_m=_ro(dev), spindle_angle_rad=_ro(S.omega * t), wall_x_m=_ro(wall.x_m),
                              wall_y_m=_ro(wall.y_m), steady_window_s=S.steady, stats=stats, summary={})
    summary = summarize(result, S.workpiece, last_centre_x_m=float(rec.center_m[-1, 0]),
                        poles_rad_s=linearize(S.robot, S.th_tab[0]).modes().poles)
    tool = problem.case.tool
    if verdict_companion and t[-1] > S.steady[0] and _has_runout(tool) \
            and principal_period(tool, problem.case.cut)[1] == "tooth":
        # With runout the forced response alternates from tooth to tooth: the same period as a flip
        # of the tooth period, so this run's section cannot separate them. While every tooth cuts,
        # runout changes neither the delays nor the linear stability (cases.milling.regeneration):
        # the verdict and chatter frequency come from the same run without runout, up to the end of
        # this run's steady window (at most 2 s of it).
        case0 = replace(problem.case, tool=replace(tool, runout_m=(0.0,) * tool.teeth))
        t_end0 = min(float(t[-1]), S.steady[0] + 2.0)
        comp = simulate(replace(problem, case=case0, t_end_s=t_end0), verdict_companion=False)
        cs = comp.summary
        keys = tuple(VERDICT_KEYS) + ("chatter_freq_hz", "nonsynchronous_peak_hz", "nonsynchronous_ratio")
        summary["runout_run_verdict"] = {k: summary.get(k) for k in keys}
        for k in keys:
            if k in cs:
                summary[k] = cs[k]
            else:
                summary.pop(k, None)
        summary["verdict_basis"] = (f"companion run without runout to t = {t_end0:.2f} s (runout forces a "
                                    f"tooth-to-tooth alternation indistinguishable from a flip)")
    else:
        summary["verdict_basis"] = "this run"
    stats["wall_time_s"] = time.perf_counter() - wall0
    summary["wall_s"] = stats["wall_time_s"]
    return replace(result, summary=summary)


def _has_runout(tool) -> bool:
    return max(tool.runout_m) - min(tool.runout_m) > 0


def _chatter(out: dict, t, dev_xy, case, window) -> None:
    """Chatter frequency (reported when unstable) and the largest non-synchronous line, in place."""
    Tp, pname = principal_period(case.tool, case.cut)
    forced = "tooth" if (pname == "tooth" and not _has_runout(case.tool)) else "spindle"
    T = case.cut.spindle_period_s
    cf = chatter_frequency(t, dev_xy, 1.0 / T, teeth=case.tool.teeth, harmonics=forced,
                           t_start_s=window[0], t_end_s=window[1])
    out["chatter_freq_hz"] = cf.freq_hz if out.get("stable") is False else None
    out["nonsynchronous_peak_hz"] = cf.freq_hz
    out["nonsynchronous_ratio"] = cf.ratio


def summarize(result: SimulationResult, workpiece: Workpiece | None = None, *,
              last_centre_x_m: float | None = None, poles_rad_s=()) -> dict:
    """Derived numbers: force statistics, stability verdict, chatter frequency, roughness, wall.

    * Force statistics over ``problem.stats_window_s`` (default: the steady window), per axis of the
      dynamometer (cut) frame, N; ``force_stats_paper_axes`` gives (Fx, Fy) as the paper's Tab. 10.
    * Verdict: :func:`timedomain.verdict.verdict_summary` on the TCP deviation (x, y) over the
      steady window (the rule is stated once, in :mod:`timedomain.verdict`): ``verdict``,
      ``stable`` (true/false/null), ``verdict_reason``, ``growth_rate_per_s`` with its standard
      error and 95 % interval, ``regenerative_ratio``; ``chatter_freq_hz`` when unstable.
    * Roughness: ISO 4287 on the wall of the middle slice, Gaussian mean line with the ISO 4288
      cutoff 0.8 mm (waviness from the robot modes, wavelengths v/f of millimetres, is form, not
      roughness), over the part the tool has fully passed.
    """
    p = result.problem
    case = p.case
    T = case.cut.spindle_period_s
    t = np.asarray(result.t_s)
    t0, t1 = result.steady_window_s
    t1 = min(t1, float(t[-1]))
    out: dict = {"variant": p.variant, "damping_scale": p.damping_scale, "linearized": p.linearized,
                 "spindle_rpm": case.cut.spindle_rpm, "steady_window_s": [t0, t1]}
    if t1 - t0 >= 15 * T:
        win = p.stats_window_s if p.stats_window_s and t[0] <= p.stats_window_s[0] < p.stats_window_s[1] <= t[-1] \
            else (t0, t1)
        fs = force_stats(t, result.force_workpiece_n, *win)
        fp = force_stats(t, result.force_paper_axes_n, *win)
        out["force_stats_window_s"] = [fs.t_start_s, fs.t_end_s]
        out["force_stats"] = {ax: {"min": fs.min_n[i], "max": fs.max_n[i], "mean": fs.mean_n[i], "rms": fs.rms_n[i]}
                              for i, ax in enumerate("xyz")}
        out["force_stats_paper_axes"] = {ax: {"min": fp.min_n[i], "max": fp.max_n[i], "mean": fp.mean_n[i],
                                              "rms": fp.rms_n[i]} for i, ax in enumerate("xy")}
        out.update(verdict_summary(t, result.tcp_deviation_m[:, :2], case.tool, case.cut, (t0, t1),
                                   poles_rad_s=poles_rad_s))
        _chatter(out, t, result.tcp_deviation_m[:, :2], case, (t0, t1))
        dy = result.tcp_deviation_m[(t >= t0) & (t <= t1), 1]
        out["tcp_deviation_y_um"] = {"min": float(dy.min() * 1e6), "max": float(dy.max() * 1e6)}
    else:
        out.update(verdict_summary(t, result.tcp_deviation_m[:, :2], case.tool, case.cut, (t0, t1),
                                   poles_rad_s=poles_rad_s))
        out["chatter_freq_hz"] = None
        out["note"] = (f"steady window {t0:.3f}-{t1:.3f} s holds fewer than 15 revolutions: no force "
                       f"statistics (simulate longer)")
    if workpiece is not None and last_centre_x_m is not None:
        # the wall is finished where the tool has fully passed: from the entry face + R to the last
        # tool-centre position - R
        x_lo = workpiece.x_entry_m + case.tool.radius_m
        x_hi = min(workpiece.x_exit_m, last_centre_x_m - case.tool.radius_m)
        out["wall_x_range_m"] = [x_lo, x_hi]
        out["roughness_um"] = None
        if x_hi - x_lo <= 2.5e-3:
            out["roughness_note"] = (f"finished wall {max(0.0, x_hi - x_lo) * 1e3:.2f} mm long: too short for the "
                                     f"0.8 mm cutoff and its run-in/run-out (needs > 2.5 mm); simulate longer")
        else:
            rough = workpiece.roughness(x_range_m=(x_lo, x_hi), form="gaussian", cutoff_m=0.8e-3)
            out["roughness_um"] = {"Ra": rough.ra_um, "Rq": rough.rq_um, "Rt": rough.rt_um}
            out["roughness_evaluation_length_m"] = rough.evaluation_length_m
            k = workpiece.discs.count // 2
            y = np.asarray(result.wall_y_m[k])
            sel = (np.asarray(result.wall_x_m) >= x_lo) & (np.asarray(result.wall_x_m) <= x_hi)
            out["wall_y_um"] = {"min": float(y[sel].min() * 1e6), "max": float(y[sel].max() * 1e6)}
    return out
