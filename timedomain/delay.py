"""The delay-based regenerative simulator: ``simulate(problem, DelayNewmark())``.

The textbook regenerative model (Insperger & Stepan; Schmitz & Smith, "Machining Dynamics") that
the semi-discretization linearizes: a linear structure cuts at the nominal engagement for the whole
run, and the chip of tooth ``j`` on disc ``k`` is the static chip plus the projection of the
displacement now minus one tooth delay earlier (the equations and the integration are in
:mod:`timedomain.delay_kernel`). It has no workpiece: no surface, no roughness, no entry into the
part. It is the time domain's check of the lobes (rates against ``ln|mu| / Tp``) and the reference
the eroded-part simulator must converge to where both apply.

Problems
--------
* :class:`StructureProblem` ``(structure, tool, cut, law, t_end_s)``: a
  :class:`~robolobes.lobes.ModalStructure` or :class:`~robolobes.lobes.PhysicalStructure` (no robot;
  the Insperger-Stepan benchmarks);
* :class:`~timedomain.problem.SimulationProblem` ``(robot, case)``: the robot linearized at the
  pass start (:func:`robolobes.linearize.linearize` at ``case.path.start_q_rad``, the lobes' pose)
  cutting the case's tool, cut and law for the pass duration (or ``t_end_s``).

Start: on the forced periodic response of the static chips (Fourier series over the revolution;
for a uniform pitch the regenerative term vanishes on it, so it is the cut's periodic orbit; for a
variable pitch or runout it is the orbit without regeneration, and the rest is part of the
transient), with the history before t = 0 on the same response, and the structure deflected from
it by ``kick_m`` (the static deflection under a force in a seeded random direction of the cut
plane). Starting from rest instead, the first tooth passes would ring the structure with the whole
forced response, far above the kick (for the Insperger-Stepan benchmark at twice the limit the
teeth then leave the cut from the second pass on).
"""

from __future__ import annotations

import math
import time
from dataclasses import KW_ONLY, dataclass

import numpy as np
from robolobes.cases.milling import (
    Cut,
    CuttingLaw,
    Tool,
    check_cut,
    edge_forces,
    engagement_rad,
    principal_period,
    regeneration,
    tool_force_cut_frame,
)
from robolobes.core.validate import finite, readonly
from robolobes.lobes.structure import ModalStructure, PhysicalStructure

from .problem import DelayNewmark, SimulationError, SimulationProblem
from .rate import GatedRate, gated_growth_rate, loss_per_period
from .summary import has_runout
from .verdict import TimeDomainVerdict, beat_period_s, chip_scale, decide
from .workpiece import default_disc_count

__all__ = ["MAX_DELAY_STEPS", "DelayResult", "StructureProblem", "run_delay"]

#: Largest number of steps of one delay-based run (memory of the records: ~100 B per step).
MAX_DELAY_STEPS = 20_000_000
#: Principal periods skipped at the start of the verdict's window (the kick's fast modes die out).
TRANSIENT_PERIODS = 5
#: Principal periods skipped at the start of the rate's window (:mod:`timedomain.rate` gates the rest).
RATE_START_PERIODS = 1


@dataclass(frozen=True, eq=False)
class StructureProblem:
    """A linear structure cutting at the nominal engagement, for ``t_end_s`` seconds.

    Parameters
    ----------
    structure : lobes.ModalStructure or lobes.PhysicalStructure
        The tool tip's dynamics in the cut frame (as for the lobes).
    tool : cases.milling.Tool
    cut : cases.milling.Cut
        Radial and axial depth, mode, spindle speed and feed per tooth (> 0).
    law : cases.milling.CuttingLaw
    t_end_s : float
        Simulated time, s (> 0).
    """

    structure: ModalStructure | PhysicalStructure
    tool: Tool
    cut: Cut
    law: CuttingLaw
    _: KW_ONLY
    t_end_s: float = 1.0

    def __post_init__(self):
        if not isinstance(self.structure, (ModalStructure, PhysicalStructure)):
            raise SimulationError(f"structure must be a lobes.ModalStructure or lobes.PhysicalStructure, "
                                  f"got {type(self.structure).__name__}")
        for name, typ in (("tool", Tool), ("cut", Cut), ("law", CuttingLaw)):
            if not isinstance(getattr(self, name), typ):
                raise SimulationError(f"{name} must be a cases.milling.{typ.__name__}, "
                                      f"got {type(getattr(self, name)).__name__}")
        check_cut(self.tool, self.cut)
        if not self.cut.feed_per_tooth_m > 0:
            raise SimulationError(f"the delay-based model needs a feed per tooth > 0 m, "
                                  f"got {self.cut.feed_per_tooth_m}")
        object.__setattr__(self, "t_end_s", finite("t_end_s", self.t_end_s, positive=True, error=SimulationError))

    @property
    def physical(self) -> PhysicalStructure:
        s = self.structure
        return s.to_physical() if isinstance(s, ModalStructure) else s

    @classmethod
    def from_simulation(cls, problem: SimulationProblem) -> StructureProblem:
        """The robot of ``problem`` linearized at the pass start, with the case's tool, cut and law,
        over the problem's simulated time."""
        from robolobes.linearize.linear import linearize

        case = problem.case
        lin = linearize(problem.robot, case.path.start_q_rad)
        return cls(PhysicalStructure.from_linear(lin, case.cut.feed_direction), case.tool, case.cut, case.law,
                   t_end_s=problem.end_time_s)


@dataclass(frozen=True)
class DelayResult:
    """A delay-based run (SI; arrays read-only).

    problem : StructureProblem
    method : DelayNewmark
    t_s : array (N,)                    grid times, s.
    deviation_m : array (N, 2)          tool displacement in the cut plane (x_c, y_c), m.
    force_tool_n : array (N, 3)         force on the tool, cut frame, N.
    chip_loss : array (N,)              chip-weighted share of the engagement with chip <= 0 (with
                                        ``chip_loss=False`` the share whose chip is <= 0 but still cuts).
    chip_loss_angle : array (N,)        the same share by angle: elements in the arc with chip <= 0 over
                                        the elements in the arc (not weighted by the static chip); nan
                                        where no element is in the arc.
    principal_period_s : float         the sections' period, s: the principal period, or the revolution
                                        for a tool with runout (its forced response repeats once per revolution).
    verdict : TimeDomainVerdict         the verdict's rule over [5 principal periods, end].
    rate : GatedRate                    growth rate over the gated periods (:mod:`timedomain.rate`).
    stats : dict                        steps, newton_iterations, n_discs, h_s, cpu_s.
    """

    problem: StructureProblem
    method: DelayNewmark
    t_s: np.ndarray
    deviation_m: np.ndarray
    force_tool_n: np.ndarray
    chip_loss: np.ndarray
    chip_loss_angle: np.ndarray
    principal_period_s: float
    verdict: TimeDomainVerdict
    rate: GatedRate
    stats: dict


def _elements(tool: Tool, cut: Cut, n_discs: int):
    """Per element (tooth-major): angle offset (E,), tooth index (E,); per tooth: static chip h0 (T,)
    and delay (rad) (T,), teeth that do not cut get h0 = 0 and the shortest delay."""
    ap = cut.ap_m
    z = (np.arange(n_discs) + 0.5) * ap / n_discs
    off = (tool.tooth_angle_rad[:, None] - tool.lag_rad(z)[None, :]).ravel()
    tooth = np.repeat(np.arange(tool.teeth), n_discs)
    reg = regeneration(tool, cut)
    h0 = np.array([r.chip_m if (r.cuts and r.chip_m > 0) else 0.0 for r in reg])
    delay = np.array([r.delay_rad for r in reg])
    return np.ascontiguousarray(off), np.ascontiguousarray(tooth, dtype=np.int64), h0, delay


def _law_parts(law: CuttingLaw, db: float):
    """``K_c db`` (N/m) and ``K_e db`` (N) of one element, from the law of :mod:`cases.milling`."""
    f1, f2 = edge_forces(np.array([1.0, 2.0]), db, law)
    return np.ascontiguousarray(f2 - f1), np.ascontiguousarray(2 * f1 - f2)


def _kick(P: PhysicalStructure, amplitude_m: float, seed: int) -> np.ndarray:
    """Static deflection under a cut-plane force of seeded random direction, scaled to ``amplitude_m``."""
    u = np.random.default_rng(seed).normal(size=2)
    u /= np.linalg.norm(u)
    q = np.linalg.solve(np.asarray(P.K), np.asarray(P.tcp)[:2].T @ u)
    return q * (amplitude_m / np.linalg.norm(np.asarray(P.tcp)[:2] @ q))


def _engaged_fraction(phi0: np.ndarray, dphi: float, st: float, ex: float):
    """Arrays ``(a, b)``: the part of each step (fractions) where ``phi`` (from ``phi0`` over ``dphi``)
    lies in the arc; ``a == b`` where it does not (the numpy form of the kernel's)."""
    p = np.mod(phi0, 2 * math.pi)
    a = np.zeros_like(p)
    b = np.zeros_like(p)
    for shift in (2 * math.pi, 0.0):
        lo = np.maximum(p, st + shift)
        hi = np.minimum(p + dphi, ex + shift)
        on = hi > lo
        a = np.where(on, (lo - p) / dphi, a)
        b = np.where(on, (hi - p) / dphi, b)
    return a, b


def _static_step_force(tool: Tool, cut: Cut, off, tooth, h0, h: float, n_rev: int, kc, ke,
                       exact: bool = True) -> np.ndarray:
    """The kernel's weighted force sum ``sum_e w0 F_e(t_k) + w1 F_e(t_k+1)`` of the static chips for the
    ``n_rev`` steps of one revolution, (n_rev, 3) N (:mod:`timedomain.delay_kernel`; ``kc h + ke`` is
    the law of one element for ``h > 0``, continued linearly outside the arc)."""
    omega = cut.omega_rad_s
    dphi = omega * h
    st, ex = engagement_rad(tool, cut)
    phi0 = omega * h * np.arange(n_rev)[:, None] + off[None, :]
    a, b = _engaged_fraction(phi0, dphi, st, ex)
    if exact:
        w0 = (b - a) * (2 - a - b)
        w1 = (b - a) * (a + b)
    else:
        w0 = (a <= 1e-12) & (b > a)
        w1 = (b >= 1 - 1e-12) & (b > a)
    out = np.zeros((n_rev, 3))
    for phi, w, inside in ((phi0, w0, a <= 1e-12), (phi0 + dphi, w1, b >= 1 - 1e-12)):
        hs = h0[tooth][None, :] * np.sin(phi)
        keep = ~(inside & (hs <= 0))
        tra = (kc[None, None, :] * hs[..., None] + ke[None, None, :]) * (keep * w)[..., None]
        out += tool_force_cut_frame(phi, tra).sum(axis=1)
    return out


def _discrete_orbit(P: PhysicalStructure, fsum: np.ndarray, h: float, k: np.ndarray):
    """Periodic solution of the trapezoidal (average-acceleration) recurrence of
    ``M q'' + C q' + K q = tcp^T F`` with the step force sums ``fsum`` (n_rev, 3) repeating every
    revolution, at steps ``k``: ``(q (len k, n), v (len k, n))``. In the z-domain the recurrence is
    ``(M s^2 + C s + K) Q = tcp^T Fsum / (1 + z)``, ``s = (2/h)(z - 1)/(z + 1)`` (Tustin)."""
    n_rev = fsum.shape[0]
    Fn = np.fft.fft(fsum, axis=0) / n_rev
    z = np.exp(2j * math.pi * np.arange(n_rev) / n_rev)
    ok = np.abs(1 + z) > 1e-9  # the Nyquist harmonic of an even count has no trapezoidal response
    s = np.where(ok, (2 / h) * (z - 1) / np.where(ok, z + 1, 1.0), 0.0)
    M, C, K, B = (np.asarray(a, float) for a in (P.M, P.C, P.K, np.asarray(P.tcp).T))
    Z = K[None] + s[:, None, None] * C[None] + (s ** 2)[:, None, None] * M[None]
    rhs = np.where(ok[:, None], (B @ Fn.T).T / np.where(ok, 1 + z, 1.0)[:, None], 0.0)
    Qn = np.linalg.solve(Z, rhs[..., None])[..., 0]
    e = z[None, :] ** np.asarray(k)[:, None]
    return (e @ Qn).real, (e @ (s[:, None] * Qn)).real


def _share(part: np.ndarray, whole: np.ndarray, empty: float = 0.0) -> np.ndarray:
    """``part / whole`` where ``whole > 0``, else ``empty`` (arrays of the same shape)."""
    return np.where(whole > 0, part / np.where(whole > 0, whole, 1.0), empty)


def _section_period(tool: Tool, cut: Cut) -> float:
    """Period of the Poincare sections, s: the principal period, or the revolution for a tool with
    runout, whose forced response repeats only once per revolution (the second differences at the
    tooth period would keep it; a flip's multiplier per revolution is mu^2, the same rate per second)."""
    tp, _ = principal_period(tool, cut)
    return cut.spindle_period_s if has_runout(tool) else tp


def run_delay(problem, method: DelayNewmark) -> DelayResult:
    """Run the delay-based model (module docstring) on a :class:`StructureProblem` or a
    :class:`~timedomain.problem.SimulationProblem` (the robot linearized at the pass start)."""
    from .delay_kernel import run_delay_kernel  # numba: compiled or loaded on first use

    if isinstance(problem, SimulationProblem):
        problem = StructureProblem.from_simulation(problem)
    if not isinstance(problem, StructureProblem):
        raise SimulationError(f"problem must be a StructureProblem or SimulationProblem, got {type(problem).__name__}")
    if not isinstance(method, DelayNewmark):
        raise SimulationError(f"method must be DelayNewmark(...), got {method!r}")
    tool, cut, law = problem.tool, problem.cut, problem.law
    omega = cut.omega_rad_s
    h = math.radians(method.deg_per_step) / omega
    n_steps = int(math.ceil(problem.t_end_s / h - 1e-9))
    if n_steps > MAX_DELAY_STEPS:
        raise SimulationError(f"deg_per_step = {method.deg_per_step:g} over {problem.t_end_s:g} s needs {n_steps} "
                              f"steps; "
                              f"valid: at most {MAX_DELAY_STEPS} (a coarser step or a shorter t_end_s)")
    n_discs = method.n_discs or default_disc_count(tool, cut.ap_m)
    off, tooth, h0, delay = _elements(tool, cut, n_discs)
    dsteps = delay / (omega * h)
    dsteps = np.where(np.abs(dsteps - np.round(dsteps)) < 1e-9, np.round(dsteps), dsteps)
    if np.any(dsteps < 1):
        raise SimulationError(f"deg_per_step = {method.deg_per_step:g} is longer than the shortest tooth delay "
                              f"({math.degrees(float(delay.min())):.4g} deg); choose a finer step")
    P = problem.physical
    db = cut.ap_m / n_discs
    kc, ke = _law_parts(law, db)
    st, ex = engagement_rad(tool, cut)
    law_arr = np.array([law.ktc_pa, law.krc_pa, law.kac_pa, law.kte_n_per_m, law.kre_n_per_m, law.kae_n_per_m]) * db
    M, C, K = (np.ascontiguousarray(np.asarray(a, float)) for a in (P.M, P.C, P.K))
    Pr = np.ascontiguousarray(np.asarray(P.tcp, float)[:2])
    Pf = np.ascontiguousarray(np.asarray(P.tcp, float).T)
    # start on the periodic response of the static chips (exact for a uniform pitch, where the
    # regenerative term vanishes on it), deflected by the kick
    d0 = int(math.ceil(float(dsteps.max()))) + 2
    n_rev = 2 * math.pi / (omega * h)
    if abs(n_rev - round(n_rev)) > 1e-6:
        raise SimulationError(f"DelayNewmark needs a whole number of steps per revolution (360 / deg_per_step), "
                              f"got {n_rev:.6g} for deg_per_step = {method.deg_per_step:g}")
    fsum = _static_step_force(tool, cut, off, tooth, h0, h, int(round(n_rev)), kc, ke, method.entry_exit == "exact")
    qp, vp = _discrete_orbit(P, fsum, h, np.arange(d0 + 1) - d0)
    q0 = qp[-1] + _kick(P, method.kick_m, method.seed)
    v0 = vp[-1].copy()
    N = n_steps + 1
    r_hist, v_hist = np.zeros((d0 + N, 2)), np.zeros((d0 + N, 2))
    r_hist[:d0] = qp[:-1] @ Pr.T
    v_hist[:d0] = vp[:-1] @ Pr.T
    rec_f, rec_loss = np.zeros((N, 3)), np.zeros((N, 4))
    cpu0 = time.process_time()
    status, iters, k_fail = run_delay_kernel(n_steps, h, omega, M, C, K, Pr, Pf, off, tooth, h0, dsteps, st, ex, 1.0,
                                             law_arr, kc, ke, q0, v0, r_hist, v_hist, d0, rec_f, rec_loss, 50,
                                             method.entry_exit == "exact", method.chip_loss)
    cpu = time.process_time() - cpu0
    if status != 0:
        raise SimulationError(f"delay-based run: Newton {'did not converge' if status == 1 else 'went non-finite'} "
                              f"at the step to t = {(k_fail + 1) * h:.6g} s")
    r_hist = r_hist[d0:]
    t = np.arange(N) * h
    tp = _section_period(tool, cut)
    t0 = min(TRANSIENT_PERIODS * tp, t[-1])
    poles = P.state_space().poles
    verdict = decide(t, r_hist, tp, chip_scale(tool, cut), t_start_s=t0, t_end_s=float(t[-1]),
                     beat_period_s=beat_period_s(poles))
    loss, loss_angle = _share(rec_loss[:, 0], rec_loss[:, 1]), _share(rec_loss[:, 2], rec_loss[:, 3], math.nan)
    t1 = min(RATE_START_PERIODS * tp, t[-1])
    n_per = int((t[-1] - t1) / tp + 1e-9)
    lpp = loss_per_period(t, rec_loss[:, 0], rec_loss[:, 1], tp, t1, max(n_per, 1))
    # without chip loss the model is linear at any amplitude: no gate on the (would-be) loss
    rate = gated_growth_rate(t, r_hist, tp, t_start_s=t1, t_end_s=float(t[-1]), loss=lpp if method.chip_loss else None)
    stats = dict(steps=n_steps, newton_iterations=int(iters), n_discs=n_discs, h_s=h, cpu_s=cpu)
    return DelayResult(problem=problem, method=method, t_s=readonly(t), deviation_m=readonly(r_hist),
                       force_tool_n=readonly(rec_f), chip_loss=readonly(loss), chip_loss_angle=readonly(loss_angle),
                       principal_period_s=tp,
                       verdict=verdict, rate=rate, stats=stats)
