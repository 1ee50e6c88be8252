"""The equations a simulated pass integrates: everything a run needs, built once (:class:`PassSetup`),
the full nonlinear residual (:func:`robot_equations`, :func:`full_system`) and the linearized
system (:class:`LinearSystemData`, :func:`linear_system_data`, :func:`linear_system_python`).

Full path (:class:`~timedomain.problem.NonlinearNewmark`): Newmark average acceleration
(:mod:`timedomain.newmark`) on the nonlinear multibody equations of :mod:`linearize.model`, in
residual form::

    r(q, v, a, t) = rnea(q, v, a) - sum_e tau_e(q, v, theta(t)) - J(q)^T R_c^T F_tool(c(q), t) = 0

with the motor angles ``theta(t)`` from the closed-form IK of the pass (:class:`linearize.path.Pass`),
gravity and compensation where the robot has them, the backlash dead zone in full, and the
milling force of :mod:`timedomain.workpiece_force` on the eroded :class:`~timedomain.workpiece.Workpiece`.
``c(q)`` is the tool centre (the TCP) in the cut frame, measured from the commanded start point;
the part is fixed in that frame. Newton uses pinocchio's analytic derivatives
(``computeRNEADerivatives``), the elements' tangents and the cutting tangent
``-J^T R_c^T (dF/dc) R_c J``.

Linearized path (:class:`~timedomain.problem.LinearizedNewmark`): the linearization at the start
pose (``M, C, K, J`` of :func:`linearize.linearize`, gears engaged) for the deviation ``dq`` from
the nominal motion ``q_nom(t) = rigid_q(theta(t)) + (q_eq - rigid_q(theta_0))``, keeping the same
nonlinear milling force and, with backlash, the motion springs' dead zone::

    M dqdd + C dqd + K_rest dq + k o (dz(d0 + dq) - dz(d0)) = J^T R_c^T F_tool - f_nom(t)
    f_nom(t) = M P thetadd + C P thetad + G P (theta - theta_0)

``K_rest`` is K without the motion springs, ``d0`` the static deflection of the motion axes at the
start, ``P`` places motor angles into q, ``G`` the gravity (and compensation) part of K. The
nominal motion's inertia, the dampers acting on the absolute velocity (eq. 7) and the change of
the gravity load along the pass enter as ``f_nom``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
import pinocchio as pin

from robolobes.cases.milling import cut_frame
from robolobes.core.validate import readonly
from robolobes.linearize.linear import equilibrium, linearize
from robolobes.linearize.model import MotionSprings, dead_zone, element_forces, element_tangents
from robolobes.linearize.path import Pass

from .problem import SimulationError, SimulationProblem, step_count
from .workpiece import Workpiece, default_disc_count
from .workpiece_force import MillingForce

__all__ = ["PassSetup", "robot_equations", "full_system", "LinearSystemData", "linear_system_data",
           "linear_system_python"]


def _lerp_row(tab: np.ndarray, dt: float, t: float):
    """Row of a uniform table (spacing dt from t = 0) at time t, linearly interpolated, clamped."""
    x = t / dt
    i = min(max(int(x), 0), len(tab) - 2)
    f = x - i
    return tab[i] + f * (tab[i + 1] - tab[i])


class PassSetup:
    """Everything a run needs, built once: model, pass, cut frame, part, motor-angle tables.

    Attributes
    ----------
    case : MillingCase
    robot : linearize.FlexibleRobot
        The problem's built robot (n = ``robot.nv`` DOF).
    h, n_steps : float, int
        Nominal time step (s) and number of steps (bounded, :func:`timedomain.problem.step_count`).
    pas : linearize.path.Pass
    Rc : array (3, 3)
        Cut frame axes as rows, base frame components.
    p_ref : array (3,)
        Commanded start point of the TCP, base frame, m.
    omega : float
        Spindle speed, rad/s.
    t_end : float
        Simulated end time, s.
    workpiece : Workpiece
    milling : MillingForce
    t_tab, th_tab : array (T,), array (T, n_joints)
        Uniform table of the motor angles (0.2 ms spacing ``dt_tab``), s and rad.
    q_eq : array (n,)
        Static equilibrium at the start (rad).
    steady : (float, float)
        Full engagement of the tool in the part, s.
    """

    def __init__(self, problem: SimulationProblem, method):
        case = problem.case
        self.case = case
        self.robot = problem.robot
        self.h, self.n_steps = step_count(problem, method)
        self.pas = Pass.from_case(case)
        tool, cut = case.tool, case.cut
        self.Rc = cut_frame(cut.feed_direction, self.pas.tool_axis)
        self.p_ref = np.asarray(self.pas.start_position, dtype=float)
        self.omega = cut.omega_rad_s
        self.t_end = float(problem.t_end_s) if problem.t_end_s is not None else float(self.pas.duration_s)
        n_discs = method.n_discs or default_disc_count(tool, cut.ap_m)
        x_entry = self.pas.part_entry_s + tool.radius_m
        self.workpiece = Workpiece(tool, cut, x_entry_m=x_entry, part_length_m=case.path.part_length_m,
                                   discs=n_discs, dx_m=method.dx_m)
        self.milling = MillingForce(tool, case.law, cut, self.workpiece)
        #: whether entries and exits inside a step are integrated exactly (:mod:`timedomain.entry_exit`)
        self.exact_entry_exit = getattr(method, "entry_exit", "exact") == "exact"
        #: velocity kick of the linearized path, m/s (0: none); its time, s, is set with the steady window
        self.kick_m_s = float(getattr(method, "kick_m_s", 0.0))
        kick_at_s = getattr(method, "kick_at_s", None)
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
        #: time of the velocity kick, s (the method's ``kick_at_s``, else the start of full engagement)
        self.kick_time_s = self.steady[0] if kick_at_s is None else float(kick_at_s)
        self._check_kick()

    def _check_kick(self) -> None:
        """Refuse a velocity kick that would fall after the run's end (before any work is done)."""
        t_kick = self.kick_time_s
        if self.kick_m_s != 0.0 and t_kick > self.t_end:
            raise SimulationError(f"the velocity kick at t = {t_kick:.6g} s falls after the run's end "
                                  f"(t_end_s = {self.t_end:.6g} s); valid: kick_at_s <= t_end_s, or a longer run")

    def theta(self, t: float) -> np.ndarray:
        """Motor angles at time t (s), (n_joints,), rad, from the table."""
        return _lerp_row(self.th_tab, self.dt_tab, t)

    def center_of(self, p_tcp: np.ndarray) -> np.ndarray:
        """Tool centre (x_c, y_c) in the cut frame from the commanded start point, m, of a TCP position
        (3,) in the base frame, m."""
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
    model, data, tcp = robot.model, robot.create_data(), robot.tcp_frame
    cache = {}
    last = {}

    def kin(q):
        key = q.tobytes()
        if cache.get("key") != key:
            J = pin.computeFrameJacobian(model, data, q, tcp, pin.LOCAL_WORLD_ALIGNED)[:3]
            cache.update(key=key, J=J, p=data.oMf[tcp].translation.copy())
        return cache["J"], cache["p"]

    def residual(q, v, a, t):
        r = pin.rnea(model, data, q, v, a) - element_forces(robot, q, v, theta_of_t(t), data)
        if tcp_force is not None:
            J, p = kin(q)
            F, _ = tcp_force(t, p)
            last["F"] = F
            r = r - J.T @ F
        return r

    def tangent(q, v, a, t):
        dq, dv, M = pin.computeRNEADerivatives(model, data, q, v, a)
        kq, kv = element_tangents(robot, q, v, theta_of_t(t), data=data)
        dq = dq - kq
        if tcp_force is not None:
            J, p = kin(q)
            _, dF = tcp_force(t, p)
            dq = dq - J.T @ dF @ J
        return dq, dv - kv, M

    return residual, tangent, kin, last


def full_system(S: PassSetup):
    """The full path's residual, tangent, TCP position ``q -> p (3,)``, initial q (the static
    equilibrium at the start), a dict whose ``"f"`` is the cut-frame force on the tool (N) of the
    last residual evaluation, and the ``accepted_acceleration`` hook of
    :func:`timedomain.newmark.integrate`: entries and exits inside a step are integrated exactly, as
    on the linearized path (:mod:`timedomain.entry_exit`)."""
    from .entry_exit import StepForce

    Rc, RcT, milling, omega = S.Rc, S.Rc.T, S.milling, S.omega
    last_cut = {}
    holder = {}

    def tcp_force(t, p):
        f_cut, dfdc, corr = holder["step"].force(t, S.center_of(p))
        last_cut["f"] = f_cut
        return RcT @ (f_cut + corr), RcT @ dfdc @ Rc[:2]

    residual, tangent, kin, _ = robot_equations(S.robot, S.theta, tcp_force)
    q0 = S.q_eq.copy()
    c0 = S.center_of(kin(q0)[1])
    holder["step"] = StepForce(milling, omega, 0.0, c0, milling.evaluate(0.0, c0).chip_m, exact=S.exact_entry_exit)
    model, data = S.robot.model, S.robot.create_data()

    def accepted(t, q, v, a):
        corr = holder["step"].accept(t, S.center_of(kin(q)[1]))
        if not corr.any():
            return a
        J, _ = kin(q)
        return a - np.linalg.solve(pin.crba(model, data, q), J.T @ (RcT @ corr))

    return residual, tangent, (lambda q: kin(q)[1]), q0, last_cut, accepted


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


def linear_system_data(S: PassSetup) -> LinearSystemData:
    """Build the linearized path's arrays at the pass start (module docstring)."""
    robot = S.robot
    lin = linearize(robot, S.th_tab[0])
    M, C, K, J = (np.asarray(x) for x in (lin.M, lin.C, lin.K, lin.J))
    n = robot.nv
    idx = np.asarray(robot.motion_dofs)
    P = np.zeros((n, len(idx)))
    P[idx, np.arange(len(idx))] = 1.0
    springs = [e for e in robot.elements if isinstance(e, MotionSprings)]
    if len(springs) != 1:
        raise SimulationError(f"the linearized path needs exactly one MotionSprings element in the robot, "
                              f"got {len(springs)}; use NonlinearNewmark")
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
        M=readonly(M), C=readonly(C), K=readonly(K), K_rest=readonly(K - K_ms), motion_dofs=readonly(idx, dtype=None),
        k_motion=readonly(k),
        backlash_rad=float(robot.backlash_rad), d0=readonly(np.asarray(lin.q)[idx] - np.asarray(lin.theta)),
        Jc=readonly(S.Rc[:2] @ J), JtRt=readonly(J.T @ S.Rc.T), c_off=readonly(S.center_of(np.asarray(lin.p_tcp))),
        t_tab=readonly(S.t_tab), s_tab=readonly(S.pas.s(S.t_tab)), f_nom_tab=readonly(f_nom))


def linear_system_python(S: PassSetup):
    """Python evaluation of the linearized path (the reference of the compiled kernel): residual,
    constant tangent ``(K, C, M)``, centre ``(dq, t) -> c (2,)``, initial dq (zero), the dict of the
    last cut-frame force on the tool and the ``accepted_acceleration`` hook of
    :func:`timedomain.newmark.integrate` (entries and exits inside a step, :mod:`timedomain.entry_exit`)."""
    d = linear_system_data(S)
    q0 = np.zeros(d.M.shape[0])
    residual, accepted, last = corrected_residual(d, S.milling, S.omega, 0.0, q0, exact=S.exact_entry_exit)
    return residual, (d.K, d.C, d.M), d.center, q0, last, accepted


def corrected_residual(d: LinearSystemData, milling, omega: float, t0_s: float, q0: np.ndarray, *,
                       exact: bool = True):
    """Residual of the linearized path with the entries and exits inside a step integrated exactly
    (:mod:`timedomain.entry_exit`), from the accepted state ``q0`` at ``t0_s`` (its chips before its
    removal): ``(residual, accepted_acceleration, last)`` for :func:`timedomain.newmark.integrate`;
    ``last["f"]`` is the point force on the tool (cut frame, N) of the last evaluation. ``exact=False``:
    no correction (the force sampled at the step ends)."""
    from .entry_exit import StepForce, acceleration_shift

    c0 = d.center(q0, t0_s)
    chips0 = milling.evaluate(omega * t0_s, c0).chip_m
    return step_residual(d, StepForce(milling, omega, t0_s, c0, chips0, exact=exact), acceleration_shift(d.M, d.JtRt))


def step_residual(d: LinearSystemData, step, shift: np.ndarray):
    """``(residual, accepted_acceleration, last)`` on a :class:`timedomain.entry_exit.StepForce`
    ``step`` whose start is the last accepted state; ``shift = M^-1 J^T R_c^T`` (n, 3)."""
    last = {}

    def residual(dq, v, a, t):
        f_cut, _, corr = step.force(t, d.center(dq, t))
        last["f"] = f_cut
        return d.residual(dq, v, a, t, f_cut + corr)

    def accepted(t, dq, v, a):
        return a - shift @ step.accept(t, d.center(dq, t))

    return residual, accepted, last
