"""Benchmark: the robot-independent time-domain engine (timedomain.workpiece / cutting / newmark).

Per-call cost of the cutting-force evaluation (aluminium case: 2 teeth, helix 30 deg, 22 discs,
steady cut), of a workpiece commit (one step's tooth-tip paths), and of a Newmark step (18-DOF
linear system with a prefactored tangent; 2-DOF spring-mounted tool cutting, full Newton), each
also as a ratio to a reference numpy operation timed in the same run (these machines are noisy:
compare ratios, not microseconds). Target: force evaluation well under 100 us.

    python bench/bench_engine.py
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from robolobes.cases import load_case
from robolobes.timedomain.workpiece_force import MillingForce, run_prescribed, straight_path
from robolobes.timedomain.newmark import LinearSystem, NewmarkOptions, integrate
from robolobes.timedomain.workpiece import Workpiece


def _per_call(fn, n):
    fn(0)
    t0 = time.perf_counter()
    for i in range(n):
        fn(i)
    return (time.perf_counter() - t0) / n


def main(n: int = 20000) -> None:
    # reference: an 18 x 18 matrix-vector product plus a 44-element sine (the size of the problems)
    a = np.random.default_rng(0).standard_normal((18, 18))
    x = np.ones(18)
    ph = np.linspace(0, 6, 44)
    t_ref = _per_call(lambda i: (a @ x, np.sin(ph)), n)

    case = load_case("tx200-aluminium")
    tool, cut = case.tool, case.cut
    wp = Workpiece(tool, cut, x_entry_m=0.0, part_length_m=30e-3)
    model = MillingForce(tool, case.law, cut, wp)
    spr = 360
    t = np.arange(2 * spr + 1) * cut.spindle_period_s / spr
    c, ang = straight_path(tool, cut, t, 12e-3)
    run_prescribed(model, t, c, ang)  # steady cut
    t1 = t[-1] + np.arange(spr) * cut.spindle_period_s / spr
    c1, a1 = straight_path(tool, cut, t1, 12e-3)
    jitter = np.array([0.0, 1e-12])  # defeat the memo: a new state each call, as in Newton

    def force(i):
        model.force(float(a1[i % spr]), c1[i % spr] + jitter * (i + 1))

    t_force = _per_call(force, n)

    wp2 = wp.copy()
    m2 = MillingForce(tool, case.law, cut, wp2)
    nc = 5 * spr
    t2 = t[-1] + np.arange(nc + 1) * cut.spindle_period_s / spr
    c2, a2 = straight_path(tool, cut, t2, 12e-3)
    t_commit = _per_call(lambda i: m2.commit(float(a2[i]), c2[i], float(a2[i + 1]), c2[i + 1]), nc - 1)

    # Newmark: 18-DOF linear system, prefactored (the linear fast path and modified Newton)
    k = np.diag(np.linspace(1e6, 5e6, 18))
    sys = LinearSystem(M=np.eye(18), C=1e-3 * k, K=k, force=lambda tt: np.full(18, math.sin(100 * tt)))
    steps = 5000
    res = {}
    variants: tuple[tuple[str, dict[str, Any]], ...] = (
        ("linear fast path", dict(constant_tangent=sys.matrices, linear=True)),
        ("constant tangent", dict(constant_tangent=sys.matrices)),
        ("full Newton", dict(tangent=sys.tangent)))
    for name, kw in variants:
        t0 = time.perf_counter()
        integrate(sys.residual, np.zeros(18), np.zeros(18), t0_s=0.0, h_s=1e-5, n_steps=steps,
                  options=NewmarkOptions(atol=1e-14), on_step=lambda s: None, **kw)
        res[name] = (time.perf_counter() - t0) / steps

    # coupled: 2-DOF tool on springs cutting (the pattern of the robot coupling)
    from robolobes.cases.milling import Cut, Tool

    tool_s = Tool(diameter_m=0.01, teeth=2, helix_rad=math.radians(30))
    cut_s = Cut(ae_m=4e-3, ap_m=1.6e-3, spindle_rpm=cut.spindle_rpm, feed_per_tooth_m=cut.feed_per_tooth_m)
    wp3 = Workpiece(tool_s, cut_s, x_entry_m=0.0, part_length_m=30e-3)
    m3 = MillingForce(tool_s, case.law, cut_s, wp3)
    kk, mm = 1e7, 1e7 / (2 * math.pi * 5000) ** 2
    K, M, C = kk * np.eye(2), mm * np.eye(2), 0.1 * math.sqrt(kk * mm) * np.eye(2)
    om, vf = cut_s.omega_rad_s, cut_s.feed_rate_m_per_s(tool_s)

    def ctr(tt, q):
        return np.array([5e-3 + vf * tt, 0.0]) + q

    def r_fn(q, v, a, tt):
        return M @ a + C @ v + K @ q - m3.force(om * tt, ctr(tt, q))[0][:2]

    def j_fn(q, v, a, tt):
        return K - m3.force(om * tt, ctr(tt, q))[1][:2], C, M

    def hook(s):
        m3.commit(om * s.t_prev_s, ctr(s.t_prev_s, s.q_prev), om * s.t_s, ctr(s.t_s, s.q))

    csteps = 4000
    t0 = time.perf_counter()
    out = integrate(r_fn, np.zeros(2), np.zeros(2), t0_s=0.0, h_s=cut_s.spindle_period_s / 200, n_steps=csteps,
                    tangent=j_fn, on_step=hook, options=NewmarkOptions(atol=1e-13))
    t_coupled = (time.perf_counter() - t0) / csteps

    print(f"reference (18x18 mat-vec + 44 sines)            {t_ref * 1e6:8.2f} us")
    print(f"force + tangent, 2 teeth x {wp.discs.count} discs, steady cut   {t_force * 1e6:8.2f} us"
          f"  = {t_force / t_ref:5.1f} x ref  (target well under 100 us: {'met' if t_force < 100e-6 else 'NOT met'})")
    print(f"workpiece commit, one step of 1 deg              {t_commit * 1e6:8.2f} us  = {t_commit / t_ref:5.1f} x ref")
    for name, val in res.items():
        print(f"Newmark step, 18 DOF, {name:<18}         {val * 1e6:8.2f} us  = {val / t_ref:5.1f} x ref")
    print(f"coupled step (2-DOF tool, 22 discs, full Newton) {t_coupled * 1e6:8.2f} us  = {t_coupled / t_ref:5.1f} x ref"
          f"  ({out.stats.newton_iterations / out.stats.accepted:.2f} iterations per step)")


if __name__ == "__main__":
    main()
