"""The compiled linearized path (timedomain.fastpath) against the Python linearized path it compiles
(drivers.run_linearized_python) and against the full nonlinear path; chunking, progress,
interruption, failure reporting, the removal kernel's culling and the compile-cache guard."""

from __future__ import annotations

import math
import os
import signal
import threading
import warnings
from types import SimpleNamespace

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from robolobes import cases
from robolobes.cases.milling import Cut, Tool
from robolobes.timedomain import fastpath
from robolobes.timedomain.fastpath import FastPathConvergenceError, FastPathError, run_linear_milling
from robolobes.timedomain.newmark import NewmarkConvergenceError, NewmarkInterrupted
from robolobes.linearize.extra_elements import JointCorrection
from robolobes.linearize.tool import TcpOscillator
from robolobes.linearize.model import build_model
from robolobes.timedomain.drivers import run_full, run_linearized, run_linearized_python
from robolobes.timedomain.equations import PassSetup, linear_system_data
from robolobes.timedomain.problem import LinearizedNewmark, NonlinearNewmark, SimulationProblem
from robolobes.timedomain.workpiece import Workpiece, _remove_kernel

ALU = cases.load_case("tx200-aluminium")
STEEL = cases.load_case("tx200-steel")


def _setup(robot, case, t_end, linearized=True):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the Tab. 7 pose is 2.86 deg past A3's limit (accepted, warned)
        method = LinearizedNewmark() if linearized else NonlinearNewmark()
        return PassSetup(SimulationProblem(robot, case, t_end_s=t_end), method)


# The tool enters the aluminium part at 0.063 s and the steel part at 0.264 s (1 mm approach after
# the feed ramp): the runs below cover the approach, the entry and 2-8 revolutions of cutting.
# The last run adds identification's elements (a 900 Hz mode at the TCP: one more DOF; a softer,
# more damped axis 2): the compiled loop takes any built robot.
EXTRA = (TcpOscillator.one_axis(freq_hz=900.0, damping_ratio=0.03, stiffness_n_per_m=2e7, direction=(1.0, 0.0, 0.0)),
         JointCorrection(joint=2, stiffness_scale=0.8, damping_scale=1.5))
REFERENCE_RUNS = [(ALU, "basic", 0.1, ()), (ALU, "backlash", 0.1, ()), (STEEL, "backlash", 0.4, ()),
                  (ALU, "basic", 0.1, EXTRA)]


@pytest.mark.parametrize("case, variant, t_end, extra", REFERENCE_RUNS,
                         ids=[f"{c.name}-{v}{'-extra' if e else ''}" for c, v, _, e in REFERENCE_RUNS])
def test_compiled_loop_reproduces_the_python_linearized_path(tx200_robot, case, variant, t_end, extra):
    # Same equations, same Newmark update, same Newton iteration and tolerances: the two agree to
    # round-off as long as they take the same number of iterations at every step. Where round-off
    # flips a convergence test, one path takes one more increment, of at most atol = 1e-11 m (rad)
    # (modified Newton contracts by ~1e-6 per iteration, so the other's remaining error is ~1e-17):
    # the states then differ by <= 1e-11, the centre (|Jc| ~ 1 m/rad) by ~1e-11 m and the force by
    # (cutting stiffness <= 5e6 N/m) x 1e-11 m = 5e-5 N, i.e. < 1e-6 of the peak force (100-240 N).
    # Hence: forces to 1e-6 of the peak, centre to 1e-10 m, wall to 1e-9 m (the brief's bound; a
    # wall column is the minimum of chords through the tips, which move with the centre).
    robot = build_model(case.robot, variant, extra_elements=extra) if extra else tx200_robot(variant)
    S_c = _setup(robot, case, t_end)
    S_p = _setup(robot, case, t_end)
    rc = run_linearized(S_c, None)
    rp = run_linearized_python(S_p, None)
    n = S_c.n_steps + 1
    assert rc.t_s.shape == (n,) and rc.force_tool_n.shape == (n, 3) and rc.center_m.shape == (n, 2)
    assert rc.tcp_m.shape == (n, 3) and np.all(np.isnan(rc.tcp_m))
    assert_array_equal(rc.t_s, rp.t_s)
    peak = np.abs(rp.force_tool_n).max()
    assert peak > 50.0  # the run does cut
    assert_allclose(rc.force_tool_n, rp.force_tool_n, rtol=0, atol=1e-6 * peak)
    assert_allclose(rc.center_m, rp.center_m, rtol=0, atol=1e-10)
    wall_c, wall_p = S_c.workpiece.wall_profile().y_m, S_p.workpiece.wall_profile().y_m
    assert np.abs(wall_p - S_p.workpiece.edge_y_m).max() > 5e-4  # the tool has cut into the part
    assert_allclose(wall_c, wall_p, rtol=0, atol=1e-9)
    assert S_c.workpiece.revision == S_p.workpiece.revision == S_c.n_steps
    assert rc.stats["steps"] == rp.stats["steps"] == S_c.n_steps
    assert rc.stats["rejected"] == 0 and rp.stats["rejected"] == 0
    # same iteration (a flipped convergence test would change a count by one here and there)
    assert abs(rc.stats["newton_iterations"] - rp.stats["newton_iterations"]) <= 0.001 * rp.stats["newton_iterations"]
    assert rc.stats["max_iterations"] == rp.stats["max_iterations"]


def test_linearized_path_agrees_with_the_full_path_on_the_aluminium_cut(tx200_robot):
    # Basic model, 0.3 s: approach, entry and 0.07 s (22 revolutions) of full engagement. The only
    # difference is the linearization at the start pose: the tool moves ~12 mm of a ~0.8 m reach,
    # which changes the robot's compliance by ~1 %; the forces feel the compliance through the
    # static TCP deflection (~25 um against ae = 4 mm: 0.6 % of the force), so the force
    # statistics move by ~1e-4 of the RMS at most (measured 2e-5-3e-5). Tolerance: mean and RMS
    # of each axis within 5e-4 x that axis' RMS over the full engagement, and every sample within
    # 0.5 % of the peak force (measured 0.16 %; a time shift of one step would give ~10 %).
    S_l = _setup(tx200_robot("basic"), ALU, 0.3)
    S_f = _setup(tx200_robot("basic"), ALU, 0.3, linearized=False)
    rl = run_linearized(S_l, None)
    rf = run_full(S_f, None)
    sel = rl.t_s >= S_l.steady[0]
    assert sel.sum() > 3000
    fl, ff = rl.force_tool_n[sel, :2], rf.force_tool_n[sel, :2]
    rms_f = np.sqrt(np.mean(ff ** 2, axis=0))
    assert np.all(rms_f > 10.0)
    for ax in range(2):
        assert_allclose(fl[:, ax].mean(), ff[:, ax].mean(), rtol=0, atol=5e-4 * rms_f[ax])
        assert_allclose(np.sqrt(np.mean(fl[:, ax] ** 2)), rms_f[ax], rtol=0, atol=5e-4 * rms_f[ax])
    peak = np.abs(rf.force_tool_n).max()
    assert_allclose(rl.force_tool_n, rf.force_tool_n, rtol=0, atol=5e-3 * peak)


def _fresh(robot, case, t_end):
    S = _setup(robot, case, t_end)
    return S, linear_system_data(S)


def test_progress_is_reported_per_chunk_and_reaches_one(tx200_robot):
    S, d = _fresh(tx200_robot("backlash"), ALU, 0.1)
    seen = []
    run = run_linear_milling(d, S.milling, h_s=S.h, n_steps=S.n_steps, omega_rad_s=S.omega, progress=seen.append)
    assert 95 <= len(seen) <= 101  # about every 1 %
    assert np.all(np.diff(seen) > 0) and seen[-1] == 1.0
    assert run.stats["chunks"] == len(seen)
    # chunking is bookkeeping only: another chunk size gives the same numbers bit for bit
    S2, d2 = _fresh(tx200_robot("backlash"), ALU, 0.1)
    run2 = run_linear_milling(d2, S2.milling, h_s=S2.h, n_steps=S2.n_steps, omega_rad_s=S2.omega, chunk_steps=1000)
    assert_array_equal(run2.force_tool_n, run.force_tool_n)
    assert_array_equal(S2.workpiece.wall_profile().y_m, S.workpiece.wall_profile().y_m)


def test_ctrl_c_lands_between_chunks_with_a_consistent_part(tx200_robot):
    # A real SIGINT, sent from another thread while the compiled loop runs: it surfaces after the
    # running chunk as NewmarkInterrupted carrying the last accepted state, and the part is eroded
    # exactly up to that state: a fresh run stopped at that step count gives the same part.
    S, d = _fresh(tx200_robot("backlash"), ALU, 0.2)
    timer = []

    def progress(frac):
        if not timer:
            timer.append(threading.Timer(0.02, os.kill, (os.getpid(), signal.SIGINT)))
            timer[0].start()
        elif frac >= 0.5:
            # on a loaded machine the timer thread may not run before the (fast) loop ends: wait
            # here for it to have sent the signal, so that it lands before the run completes
            timer[0].join()

    with pytest.raises(NewmarkInterrupted) as ei:
        run_linear_milling(d, S.milling, h_s=S.h, n_steps=S.n_steps, omega_rad_s=S.omega, progress=progress,
                           chunk_steps=50)
    timer[0].join()
    res = ei.value.result
    k = res.stats.accepted
    assert 0 < k < S.n_steps and k % 50 == 0  # between two chunks
    assert res.t_s == k * S.h and not res.completed
    assert S.workpiece.revision == k
    S2, d2 = _fresh(tx200_robot("backlash"), ALU, 0.2)
    run2 = run_linear_milling(d2, S2.milling, h_s=S2.h, n_steps=k, omega_rad_s=S2.omega)
    assert_array_equal(run2.q, res.q)
    assert_array_equal(S2.workpiece.wall_profile().y_m, S.workpiece.wall_profile().y_m)


def test_failed_kernel_steps_are_redone_with_step_halving(tx200_robot):
    # With max_iter = 1 no cutting step can converge in the kernel (the first increment of a
    # cutting step exceeds atol): each is redone by the Python reference from the last accepted
    # state, which halves the step until one iteration suffices. The run must still be the same
    # motion up to the discretization: the fallback steps are integrated with halved steps, so the
    # two runs differ by Newmark's O(h^2) truncation error (measured 1e-4 of the peak force, at
    # 180 steps per revolution), not by round-off: forces within 1e-3 of the peak. The centre's
    # deviation from the commanded path integrates those force differences through the lightly
    # damped robot modes (quality factor ~50) while the tool enters the part's face: a fallback step
    # integrated with halved steps lies between the run at h and the run at h/2, so the fallback
    # run is within 1.5 x the difference of those two runs (the h run's truncation error, by
    # Richardson 4/3 of it) of the h run; that difference is 1.4 % of the excursion here. And the
    # erosion bookkeeping must stay consistent (one workpiece revision per accepted step, kernel
    # or fallback).
    S0, d0 = _fresh(tx200_robot("basic"), ALU, 0.08)
    ref = run_linear_milling(d0, S0.milling, h_s=S0.h, n_steps=S0.n_steps, omega_rad_s=S0.omega)
    Sh, dh = _fresh(tx200_robot("basic"), ALU, 0.08)
    half = run_linear_milling(dh, Sh.milling, h_s=Sh.h / 2, n_steps=2 * Sh.n_steps, omega_rad_s=Sh.omega)
    S, d = _fresh(tx200_robot("basic"), ALU, 0.08)
    run = run_linear_milling(d, S.milling, h_s=S.h, n_steps=S.n_steps, omega_rad_s=S.omega, max_iter=1)
    assert run.stats["python_fallback_steps"] > 50 and run.stats["rejected"] > 0
    assert ref.stats["python_fallback_steps"] == 0
    assert_allclose(run.force_tool_n, ref.force_tool_n, rtol=0, atol=1e-3 * np.abs(ref.force_tool_n).max())
    dev = ref.center_m[:, 1]
    truncation = np.abs(half.center_m[::2, 1] - dev).max()
    assert truncation < 0.05 * np.ptp(dev)  # the runs are converged in the step to a few % of the excursion
    assert_allclose(run.center_m[:, 1], dev, rtol=0, atol=1.5 * truncation)
    # one commit per accepted (sub)step: kernel steps plus the fallback's substeps
    fb = run.stats["python_fallback_steps"]
    assert S.workpiece.revision == S.n_steps - fb + run.stats["python_fallback_substeps"]


def test_unconvergeable_step_fails_loudly_with_the_time_and_the_last_state(tx200_robot):
    # One Newton iteration and no halving allowed in the fallback: the first cutting step cannot
    # converge anywhere; the error names the step's time and carries the last accepted state,
    # with the part eroded exactly up to it.
    S, d = _fresh(tx200_robot("basic"), ALU, 0.1)
    with pytest.raises(FastPathConvergenceError, match=r"at the step to t = [0-9.]+ s") as ei:
        run_linear_milling(d, S.milling, h_s=S.h, n_steps=S.n_steps, omega_rad_s=S.omega, max_iter=1,
                           fallback_halvings=0)
    assert isinstance(ei.value, NewmarkConvergenceError)
    res = ei.value.result
    k = res.stats.accepted
    assert 0 < k < S.n_steps and res.t_s == k * S.h
    assert S.workpiece.revision == k
    assert f"t = {(k + 1) * S.h:.9g} s" in str(ei.value)


@pytest.mark.parametrize("kw, match", [
    (dict(h_s=-1.0), "h_s"), (dict(h_s=float("nan")), "h_s"), (dict(n_steps=0), "n_steps"),
    (dict(n_steps=2.5), "n_steps"), (dict(omega_rad_s=float("inf")), "omega"), (dict(chunk_steps=0), "chunk_steps"),
    (dict(max_iter=0), "max_iter"), (dict(atol=0.0), "atol"), (dict(n_steps=10 ** 7), "tables"),
    (dict(fallback_halvings=-1), "fallback_halvings"),
])
def test_bad_input_is_named(tx200_robot, kw, match):
    S, d = _fresh(tx200_robot("basic"), ALU, 0.01)
    args = dict(h_s=S.h, n_steps=S.n_steps, omega_rad_s=S.omega) | kw
    with pytest.raises(FastPathError, match=match):
        run_linear_milling(d, S.milling, **args)
    with pytest.raises(FastPathError, match="MillingForce"):
        run_linear_milling(d, object(),  # pyright: ignore[reportArgumentType]  # deliberately invalid input
                           h_s=S.h, n_steps=1, omega_rad_s=S.omega)


@pytest.mark.parametrize("mode, runout_um", [("down", (0.0, 0.0)), ("down", (6.9, 0.0)), ("up", (0.0, 3.0))])
def test_culled_removal_is_identical_to_the_full_chord_walk(mode, runout_um):
    # _remove_kernel skips tip paths that provably miss the part (cull=True, the default used by
    # every caller); the result must be bit-identical to walking every chord. A wobbling tool
    # (+-30 um at 1.3 kHz) crosses the entry face, cuts and leaves the part at the exit face, in
    # steps of 1-7 deg (larger steps stress the sagitta bound r da^2 / 8).
    tool = Tool(diameter_m=10e-3, teeth=2, helix_rad=math.radians(30), pitch_rad=(math.radians(170), math.radians(190)),
                runout_m=tuple(r * 1e-6 for r in runout_um))
    cut = Cut(ae_m=4e-3, ap_m=1.6e-3, spindle_rpm=18700, feed_per_tooth_m=0.3e-3, mode=mode)
    wp = Workpiece(tool, cut, x_entry_m=0.0, part_length_m=4e-3, discs=6)
    wb, x0, dx, sgn, dth, wtop, pi_, pw, pa, pn = wp._kernel_state()
    rng = np.random.default_rng(1)
    om = cut.omega_rad_s
    off = np.asarray(tool.tooth_angle_rad)[:, None] - tool.lag_rad(wp.discs.z_m)[None, :]
    rad = tool.radius_m + np.asarray(tool.runout_m)
    t = np.cumsum(np.r_[0.0, rng.uniform(1, 7, 2400)]) * math.radians(1) / om
    cx = -6e-3 + 20e-3 * t / t[-1] + 30e-6 * np.sin(2 * math.pi * 1300 * t)
    cy = 30e-6 * np.cos(2 * math.pi * 1300 * t)
    assert cx[-1] > 4e-3 + 6e-3  # leaves the part
    a = [arr.copy() for arr in (wb, pi_, pw, pa, pn)]
    b = [arr.copy() for arr in (wb, pi_, pw, pa, pn)]
    touched = [0, 0]
    for i in range(len(t) - 1):
        p0 = np.ascontiguousarray(om * t[i] + off)
        p1 = np.ascontiguousarray(om * t[i + 1] + off)
        for s, (w_, i_, w2, a_, n_), cull in ((0, a, True), (1, b, False)):
            n, _ = _remove_kernel(w_, x0, dx, cx[i], sgn * cy[i], cx[i + 1], sgn * cy[i + 1], sgn, p0, p1, rad, dth,
                                  wtop, i_, w2, a_, n_, cull)
            touched[s] += n
    assert touched[0] == touched[1] > 10000
    for x, y in zip(a, b):
        assert_array_equal(x, y)


def test_cache_guard_flushes_when_the_dependencies_change(tmp_path, monkeypatch):
    flushes = []
    cache = SimpleNamespace(cache_path=str(tmp_path), flush=lambda: flushes.append(1))
    disp = SimpleNamespace(_cache=cache, py_func=SimpleNamespace(__name__="kernel"))
    fastpath._guard_cache(disp)
    assert flushes == [1]  # no stamp yet: flushed, stamp written
    fastpath._guard_cache(disp)
    assert flushes == [1]  # same sources: cache kept
    monkeypatch.setattr(fastpath, "_dependency_fingerprint", lambda: "changed")
    fastpath._guard_cache(disp)
    assert flushes == [1, 1]


def test_step_3x3_solve_is_gaussian_elimination_with_pivoting():
    """The step's Woodbury system ``G u = w`` (3 x 3) is solved on scalars (no allocation). Checked by
    its residual, the second method being the definition: a backward-stable elimination leaves
    ``|G u - w| <= c eps |G| |u|``; tolerance 64 eps |G| |u| (a few roundings per entry, with room).
    Matrices: near the identity (the cutting stiffness is small against the step's), general ones
    and permutations with zero diagonals (which need the row exchanges)."""
    rng = np.random.default_rng(3)
    mats = [np.eye(3) + 1e-4 * rng.normal(size=(3, 3)) for _ in range(50)]
    mats += [rng.normal(size=(3, 3)) for _ in range(200)]
    mats += [np.eye(3)[list(p)] * rng.uniform(0.5, 2.0, 3) for p in ((1, 0, 2), (2, 1, 0), (1, 2, 0), (2, 0, 1))]
    eps = np.finfo(float).eps
    for G in mats:
        w = rng.normal(size=3)
        u = np.array(fastpath._solve3(np.ascontiguousarray(G), w))
        assert np.all(np.abs(G @ u - w) <= 64 * eps * (np.abs(G) @ np.abs(u) + np.abs(w))), (G, w, u)
