"""Newmark average-acceleration integrator: accuracy, energy, kinks, fast path, control flow."""

from __future__ import annotations

import math
import os
import signal
from typing import Any

import numpy as np
import pytest
from numpy.testing import assert_allclose

from robolobes.timedomain.newmark import (LinearSystem, NewmarkConvergenceError, NewmarkError, NewmarkInterrupted,
                                NewmarkOptions, initial_acceleration, integrate)


def _recorder():
    rec = {"t": [], "q": [], "v": [], "a": [], "h": [], "dq": [], "it": [], "on_grid": []}

    def hook(step):
        rec["t"].append(step.t_s)
        rec["q"].append(np.array(step.q))
        rec["v"].append(np.array(step.v))
        rec["a"].append(np.array(step.a))
        rec["h"].append(step.h_s)
        rec["dq"].append(np.array(step.q) - step.q_prev)
        rec["it"].append(step.iterations)
        rec["on_grid"].append(step.on_grid)

    return rec, hook


# ---- 1-DOF damped oscillator under a harmonic force --------------------------------------------
M1, K1 = 2.0, 2.0 * (2 * math.pi * 5.0) ** 2  # 5 Hz
C1 = 2 * 0.05 * math.sqrt(K1 * M1)  # 5 % damping
F0, W_F = 3.0, 2 * math.pi * 3.0  # 3 N at 3 Hz
Q0, V0 = 0.01, -0.2


def _exact_oscillator(t):
    """Closed form: x = Re(X e^{i w t}) + e^{-zeta wn t}(A cos wd t + B sin wd t)."""
    wn = math.sqrt(K1 / M1)
    zeta = C1 / (2 * math.sqrt(K1 * M1))
    wd = wn * math.sqrt(1 - zeta**2)
    X = F0 / (K1 - M1 * W_F**2 + 1j * C1 * W_F)
    xp0, vp0 = X.real, (1j * W_F * X).real
    A = Q0 - xp0
    B = (V0 - vp0 + zeta * wn * A) / wd
    return (X * np.exp(1j * W_F * t)).real + np.exp(-zeta * wn * t) * (A * np.cos(wd * t) + B * np.sin(wd * t))


def _oscillator_system():
    return LinearSystem(M=np.array([[M1]]), C=np.array([[C1]]), K=np.array([[K1]]),
                        force=lambda t: np.array([F0 * math.cos(W_F * t)]))


def test_damped_oscillator_second_order_convergence():
    sys = _oscillator_system()
    errs, hs = [], []
    for n in (100, 200, 400, 800):
        h = 1.0 / n
        rec, hook = _recorder()
        integrate(sys.residual, [Q0], [V0], t0_s=0.0, h_s=h, n_steps=n, tangent=sys.tangent, on_step=hook,
                  options=NewmarkOptions(atol=1e-14))
        t = np.array(rec["t"])
        errs.append(np.max(np.abs(np.array(rec["q"])[:, 0] - _exact_oscillator(t))))
        hs.append(h)
    slope = np.polyfit(np.log(hs), np.log(errs), 1)[0]
    # Newmark average acceleration is second order: global error ~ C h^2. The fitted slope over a
    # factor 8 in h is 2 up to the next term, O(h^2) relative (wn h <= 0.31 here): +-0.1.
    assert_allclose(slope, 2.0, atol=0.1)
    # and the finest run is actually close: phase error of the trapezoidal rule is (wn h)^2 / 12 per
    # radian; over 5 periods at wn h = 0.039 that is ~4e-3 of the amplitude (~1e-2 m) -> 4e-5 m.
    assert errs[-1] < 1e-4


def test_initial_acceleration_is_consistent():
    sys = _oscillator_system()
    a0 = initial_acceleration(sys.residual, [Q0], [V0], 0.0, tangent=sys.tangent)
    # M a0 + C v0 + K q0 = F0 cos(0): closed form
    assert_allclose(a0, [(F0 - C1 * V0 - K1 * Q0) / M1], rtol=1e-14)


def test_linear_undamped_energy_is_conserved_exactly():
    """For a linear undamped system the trapezoidal rule conserves 1/2 v'Mv + 1/2 q'Kq exactly."""
    m = np.diag([1.0, 3.0])
    k = np.array([[400.0, -150.0], [-150.0, 900.0]])
    sys = LinearSystem(M=m, C=np.zeros((2, 2)), K=k, force=lambda t: np.zeros(2))
    rec, hook = _recorder()
    integrate(sys.residual, [0.01, -0.02], [0.3, 0.0], t0_s=0.0, h_s=0.01, n_steps=2000, tangent=sys.tangent,
              on_step=hook, options=NewmarkOptions(atol=1e-16))
    q, v = np.array(rec["q"]), np.array(rec["v"])
    e = 0.5 * np.einsum("ni,ij,nj->n", v, m, v) + 0.5 * np.einsum("ni,ij,nj->n", q, k, q)
    e0 = 0.5 * 0.3**2 + 0.5 * np.array([0.01, -0.02]) @ k @ np.array([0.01, -0.02])
    # exact in exact arithmetic; round-off over 2000 steps (each ~1e-16 relative)
    assert_allclose(e, e0, rtol=1e-11)


G_L = 9.81 / 0.5  # pendulum g / L, 1/s^2


def _pendulum(q, v, a, t):
    return a + G_L * np.sin(q)


def _pendulum_tangent(q, v, a, t):
    return np.diag(G_L * np.cos(q)), np.zeros((1, 1)), np.eye(1)


def _pendulum_energy(q, v):
    return 0.5 * v**2 + G_L * (1 - np.cos(q))


def test_pendulum_energy_bounded_second_order_no_drift():
    theta0 = 1.5  # rad, strongly nonlinear
    period = 2 * math.pi / math.sqrt(G_L) * 1.18  # large-amplitude period is ~18 % longer (approximate)
    errs = []
    for n_per in (50, 100):
        h = period / n_per
        rec, hook = _recorder()
        integrate(_pendulum, [theta0], [0.0], t0_s=0.0, h_s=h, n_steps=40 * n_per, tangent=_pendulum_tangent,
                  on_step=hook, options=NewmarkOptions(atol=1e-14))
        q, v = np.array(rec["q"])[:, 0], np.array(rec["v"])[:, 0]
        rel = np.abs(_pendulum_energy(q, v) / _pendulum_energy(theta0, 0.0) - 1)
        first, last = rel[: 10 * n_per].max(), rel[-10 * n_per:].max()
        # No secular drift: the error oscillates with the motion, the last 10 periods are no worse
        # than the first 10 (to 10 %, the sampling of the oscillating error by the steps).
        assert last <= 1.1 * first
        errs.append(rel.max())
    # bounded error of size O((w h)^2): halving h divides it by 4 (second order) within 20 %
    assert_allclose(errs[0] / errs[1], 4.0, rtol=0.2)
    # and it is small in absolute terms for w h = 2 pi / 100 (the leading term is ~ (w h)^2 / 8)
    assert errs[1] < (2 * math.pi / 100) ** 2


# ---- backlash dead zone ---------------------------------------------------------------------------
MB, KB, SB = 1.0, (2 * math.pi * 10.0) ** 2, 1e-3
CB = 2 * 0.02 * math.sqrt(KB * MB)
FB, WB = 5 * KB * SB, 2 * math.pi * 3.0  # force amplitude = 5 dead-zone half-widths of static deflection


def _spring(q):
    return np.where(q >= SB, KB * (q - SB), np.where(q <= -SB, KB * (q + SB), 0.0))


def _dspring(q):
    return np.where(np.abs(q) >= SB, KB, 0.0)


def _bl_residual(q, v, a, t):
    return MB * a + CB * v + _spring(q) - FB * math.sin(WB * t)


def _bl_tangent(q, v, a, t):
    return np.diag(_dspring(q)), np.array([[CB]]), np.array([[MB]])


@pytest.mark.parametrize("n_per_period", [400, 6])
def test_backlash_newton_converges_through_contact_loss(n_per_period):
    """Newton on the monotone piecewise-linear dead-zone residual needs at most 4 iterations, even at
    a huge step (6 steps per forcing period: w_n h = 7): the predictor's piece, at most two more
    pieces, and one iteration that confirms the increment is zero."""
    h = 2 * math.pi / WB / n_per_period
    rec, hook = _recorder()
    res = integrate(_bl_residual, [0.0], [0.0], t0_s=0.0, h_s=h, n_steps=3 * n_per_period, tangent=_bl_tangent,
                    on_step=hook, options=NewmarkOptions(atol=1e-15))
    q = np.array(rec["q"])[:, 0]
    pieces = np.sign(np.where(np.abs(q) < SB, 0.0, q))
    crossings = np.count_nonzero(np.diff(np.concatenate([[0.0], pieces])))
    assert crossings >= 10  # the motion does traverse the dead zone, in both directions, many times
    assert res.stats.rejected == 0
    assert res.stats.max_iterations <= 4
    # the total cost stays close to the 2 iterations of a smooth linear step (exact solve + zero
    # increment): only steps whose predictor or end lies on another piece pay an extra iteration
    assert res.stats.newton_iterations <= 2 * res.stats.accepted + 2 * crossings + 3 * n_per_period


def test_backlash_spring_curve_shows_the_dead_zone():
    # The spring force is NOT evaluated with the model's spring function (that would echo the input):
    # it is recovered from the integrated states through the dynamic balance of the oscillator,
    # f_spring = F(t) - m a - c v, with a and v Newmark's own outputs. If the integrator solved the
    # dead-zone equation (eq. 12), these pairs (q, f_spring) show zero force for |q| < s and, on each
    # loaded branch, lines of slope k crossing zero at +-s. Tolerance: the balance holds to the
    # Newton residual, |r| <= (m / (beta h^2)) atol = 1.4e8 x 1e-15 = 1.4e-7 N, i.e. < 1e-8 of the
    # 19.7 N force amplitude; the assertions allow 1e-6 of it (force) and 1e-6 relative (fits).
    h = 2 * math.pi / WB / 2000
    rec, hook = _recorder()
    integrate(_bl_residual, [0.0], [0.0], t0_s=0.0, h_s=h, n_steps=4000, tangent=_bl_tangent, on_step=hook,
              options=NewmarkOptions(atol=1e-15))
    t, q = np.array(rec["t"]), np.array(rec["q"])[:, 0]
    v, a = np.array(rec["v"])[:, 0], np.array(rec["a"])[:, 0]
    f = FB * np.sin(WB * t) - MB * a - CB * v
    # the simulated deflection covers the zone and both loaded branches
    assert q.min() < -2 * SB and q.max() > 2 * SB
    inside = np.abs(q) < SB
    assert inside.sum() > 100
    assert_allclose(f[inside], 0.0, atol=1e-6 * FB)  # no force transmitted in the dead zone
    for side in (1, -1):
        sel = side * q > 1.5 * SB
        slope, icpt = np.polyfit(q[sel], f[sel], 1)
        assert_allclose([slope, -icpt / slope], [KB, side * SB], rtol=1e-6)


def _bl_run(h, n, halvings=0, hook=None):
    return integrate(_bl_residual, [0.0], [0.0], t0_s=0.0, h_s=h, n_steps=n, tangent=_bl_tangent, on_step=hook,
                     events=(lambda q, v, t: np.abs(q) - SB) if halvings else None,
                     options=NewmarkOptions(atol=1e-15, event_halvings=halvings, max_halvings=max(halvings, 1)))


def test_backlash_stays_second_order():
    """The dead-zone force is continuous (only its slope jumps), so the step over a kink has a local
    error O(h^2 k |v| / m) instead of O(h^3): a bounded number of such steps adds O(h^2) globally,
    and the average-acceleration scheme stays second order through contact loss/re-engagement."""
    n_per = 100
    h = 2 * math.pi / WB / n_per
    ref = _bl_run(h / 64, 2 * n_per * 64)
    errs = [abs(_bl_run(h / f, 2 * n_per * f).q[0] - ref.q[0]) for f in (1, 2, 4)]
    slope = np.polyfit(np.log([1, 1 / 2, 1 / 4]), np.log(errs), 1)[0]
    # second order up to higher-order terms and the reference's own error (64x finer: 2.4e-4 of the
    # coarsest error, 4e-3 of the finest)
    assert_allclose(slope, 2.0, atol=0.1)


def test_event_refinement_shortens_the_steps_over_a_kink():
    n_per = 100
    h = 2 * math.pi / WB / n_per
    steps = []
    out = _bl_run(h, 2 * n_per, halvings=4, hook=lambda s: steps.append((s.h_s, s.q_prev[0], s.q[0])))
    hs, q0, q1 = np.array(steps).T
    over = np.sign(np.abs(q0) - SB) != np.sign(np.abs(q1) - SB)
    # starting at rest inside the zone, 2 forcing periods cross a kink 7 times (4 per period in steady state)
    # a kink met at the nominal step costs 4 rejected attempts; one met while still refined, fewer
    assert over.sum() >= 6 and 4 <= out.stats.event_refinements <= 4 * over.sum()
    assert_allclose(hs[over], h / 16, rtol=1e-12)  # every kink is crossed by a step of h / 2**4
    assert np.all(hs[~over] >= h / 16 * (1 - 1e-12))
    # the run is as accurate as the plain one (the kinks were not the dominant error: see above)
    ref = _bl_run(h / 64, 2 * n_per * 64)
    assert abs(out.q[0] - ref.q[0]) <= 1.05 * abs(_bl_run(h, 2 * n_per).q[0] - ref.q[0])


# ---- step rejection and re-growth -----------------------------------------------------------------
def test_step_halving_recovers_and_hits_the_grid():
    """A strongly nonlinear stiff spring with a tight iteration budget: large steps fail, halving
    and re-growth finish the run, and every nominal grid time is an accepted step."""

    def res(q, v, a, t):
        return a + 1e4 * q + 1e10 * q**3

    def tan(q, v, a, t):
        return np.diag(1e4 + 3e10 * q**2), np.zeros((1, 1)), np.eye(1)

    opts = NewmarkOptions(atol=1e-13, max_iter=3, max_halvings=8, regrow_after=2)
    rec, hook = _recorder()
    out = integrate(res, [0.01], [0.0], t0_s=0.0, h_s=1e-3, n_steps=40, tangent=tan, on_step=hook, options=opts)
    assert out.completed and out.stats.rejected > 0
    t = np.array(rec["t"])
    grid = np.array(rec["on_grid"])
    assert_allclose(t[grid], 1e-3 * np.arange(1, 41), rtol=0, atol=1e-15)
    assert out.stats.min_step_s < 1e-3 and out.stats.accepted > 40
    # every accepted state is converged: the last increment was <= atol + rtol |dq_step|, so the
    # residual there is at most the effective stiffness S = k(q) + 1 / (beta h^2) times that
    q, v, a = (np.array(rec[k])[:, 0] for k in ("q", "v", "a"))
    h, dq = np.array(rec["h"]), np.array(rec["dq"])[:, 0]
    s_eff = 1e4 + 3e10 * q**2 + 4 / h**2
    # (the bound uses the tangent at the final iterate; over the last increment S changes by
    # 6e10 q dq_last <= 1e-3 S, hence the factor 2)
    assert np.all(np.abs(res(q, v, a, 0.0)) <= 2 * s_eff * (1e-13 + opts.rtol * np.abs(dq)))


def test_convergence_failure_raises_with_state():
    sys = _oscillator_system()

    def res(q, v, a, t):  # the model breaks down after t = 0.05 s (NaN), at any step size
        return sys.residual(q, v, a, t) * (np.nan if t > 0.05 + 1e-12 else 1.0)

    with pytest.raises(NewmarkConvergenceError, match="smallest step") as ei:
        integrate(res, [Q0], [V0], t0_s=0.0, h_s=1e-2, n_steps=50, tangent=sys.tangent,
                  options=NewmarkOptions(max_halvings=3, regrow_after=1))
    r = ei.value.result
    assert r.completed is False
    assert_allclose(r.t_s, 0.05, rtol=1e-12)  # the last accepted state is the last good one
    assert r.stats.rejected == 4  # the nominal step, then 3 halvings


# ---- linear fast path -----------------------------------------------------------------------------
def test_linear_fast_path_matches_general_path():
    m = np.array([[2.0, 0.1], [0.1, 1.0]])
    c = np.array([[3.0, -1.0], [-1.0, 2.0]])
    k = np.array([[5e4, -2e4], [-2e4, 3e4]])
    sys = LinearSystem(M=m, C=c, K=k, force=lambda t: np.array([math.sin(40 * t), 2 * math.cos(25 * t)]))
    runs = []
    variants: tuple[dict[str, Any], ...] = (dict(tangent=sys.tangent), dict(constant_tangent=sys.matrices, linear=True))
    for kw in variants:
        rec, hook = _recorder()
        out = integrate(sys.residual, [1e-3, 0.0], [0.0, 0.05], t0_s=0.0, h_s=1e-3, n_steps=1000, on_step=hook,
                        options=NewmarkOptions(atol=1e-16, rtol=1e-14), **kw)
        runs.append((np.array(rec["q"]), out))
    (qg, og), (qf, of) = runs
    scale = np.abs(qg).max()
    # the same linear equations solved two ways: agreement to round-off (1e-16 relative per step,
    # amplified at most by the number of steps)
    assert_allclose(qf, qg, rtol=0, atol=1e-12 * scale)
    assert of.stats.newton_iterations == 1000  # one solve per step
    assert og.stats.newton_iterations == 2000  # exact solve + zero increment


# ---- control flow: progress, interruption, input errors -------------------------------------------
def test_progress_is_monotone_and_ends_at_one():
    sys = _oscillator_system()
    seen = []
    integrate(sys.residual, [Q0], [V0], t0_s=0.0, h_s=1e-3, n_steps=500, tangent=sys.tangent, progress=seen.append,
              options=NewmarkOptions(progress_every=0.1))
    assert seen[-1] == 1.0 and np.all(np.diff(seen) > 0) and 9 <= len(seen) <= 11


def test_keyboard_interrupt_in_residual_leaves_last_accepted_state():
    sys = _oscillator_system()
    calls = {"n": 0}
    hooks = []

    def res(q, v, a, t):
        calls["n"] += 1
        if calls["n"] == 41:  # inside the Newton iteration of step 21 (2 evaluations per step)
            raise KeyboardInterrupt
        return sys.residual(q, v, a, t)

    with pytest.raises(KeyboardInterrupt) as ei:
        integrate(res, [Q0], [V0], t0_s=0.0, h_s=1e-3, n_steps=100, tangent=sys.tangent,
                  on_step=lambda s: hooks.append(s.t_s), a0=[0.0])
    assert isinstance(ei.value, NewmarkInterrupted)
    r = ei.value.result
    assert r.stats.accepted == 20 and len(hooks) == 20
    assert_allclose(r.t_s, hooks[-1], rtol=0, atol=0)


def test_sigint_during_hook_is_deferred_until_the_hook_returns():
    sys = _oscillator_system()
    finished = []

    def hook(step):
        if step.index == 10:
            os.kill(os.getpid(), signal.SIGINT)
            # still running: the interrupt must wait until the hook has left a consistent state
            finished.append(step.index)
        else:
            finished.append(step.index)

    with pytest.raises(NewmarkInterrupted) as ei:
        integrate(sys.residual, [Q0], [V0], t0_s=0.0, h_s=1e-3, n_steps=100, tangent=sys.tangent, on_step=hook)
    assert finished == list(range(1, 11))
    assert ei.value.result.stats.accepted == 10


@pytest.mark.parametrize(
    "kw, match",
    [
        (dict(h_s=0.0), "step size h_s must be finite and > 0, got 0.0"),
        (dict(h_s=-1e-3), "step size h_s must be finite and > 0, got -0.001"),
        (dict(h_s=float("nan")), "step size h_s must be finite"),
        (dict(n_steps=0), "n_steps must be an integer >= 1, got 0"),
        (dict(q0=[float("nan")]), "q0 must be finite"),
        (dict(v0=[0.0, 1.0]), "v0 must have shape (1,), got (2,)"),
    ],
)
def test_bad_input_is_named(kw, match):
    sys = _oscillator_system()
    args: dict[str, Any] = dict(q0=[Q0], v0=[V0], t0_s=0.0, h_s=1e-3, n_steps=10, tangent=sys.tangent)
    args.update(kw)
    q0, v0 = args.pop("q0"), args.pop("v0")
    with pytest.raises(NewmarkError, match=match.replace("(", r"\(").replace(")", r"\)")):
        integrate(sys.residual, q0, v0, **args)


def test_bad_options_are_named():
    with pytest.raises(NewmarkError, match="beta must be a finite number > 0"):
        NewmarkOptions(beta=0.0)
    with pytest.raises(NewmarkError, match="event_halvings"):
        NewmarkOptions(event_halvings=5, max_halvings=2)
