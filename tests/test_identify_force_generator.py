"""The independent cutting-force generator (tests/generators/forces.py) against a closed form and
against robolobes' own force model.

Tolerances asserted:

* rigid tool, mean force over a revolution = Altintas' closed-form average force (Manufacturing
  Automation, eq. 2.60-2.61, with edge terms; chip ``fz sin(phi)``) plus its second-order part in
  ``fz / R`` (the exact trochoidal chip, the stock face at the entry, the edge force past 180 deg;
  closed form below), to ``(fz / R)^2`` of its magnitude (4e-4 here): the terms left out are of
  third order. The first-order closed form alone is 0.9 % off (the chip's second-order part), so
  the test fails for a generator that uses ``fz sin(phi)``;
* the generator on the independent TX200's receptance against robolobes' linearized pass (the model
  ``identify`` fits), one-revolution synchronous averages of 0.25-0.40 s after a sub-sample phase
  alignment: the RMS difference at most 0.35 of the noise of one bin of a 23-revolution held-out
  average at 2 N noise (2 / sqrt(23) = 0.42 N): a difference d raises the held-out error of a null
  set to sqrt(1 + (d / 0.42)^2) = 1.06 of its noise floor at most, under the verdict's margin
  (about 1.09). The RMS difference of the change that edge coefficients make (with minus without)
  at most half of that noise: the edge force steps on and off at each of robolobes' 22 discs, a
  discretization the generator's 40 slices resolve 2x finer. Both models are written
  independently; neither is the reference of the other. What remains is robolobes' own
  discretization (docs/guide/identify-answers.md);
* the generator's dynamometer against scipy's lsim on its force at 40 samples per data sample: a
  tenth of a bin's noise (reasons in the test);
* the generator's pass with its entry (``simulate_pass``: the independent TX200 in time from rest, the
  feed ramp, the part's entry face) against robolobes' linearized pass on the same cut (edge forces of
  about 90 N/mm and runout): the tool's motion off its periodic part over 0.25-0.40 s to a tenth of its
  RMS on each axis, and the synchronous averages to 0.35 of a bin's noise as above (reasons in the test);
* the pass's forces between samples (for the dynamometer) equal the samples' at the samples.
"""

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from generators.forces import (
    SAMPLES_PER_REV,
    WINDOW_S,
    CutSpec,
    ForceEffects,
    periodic_forces,
    rigid_forces,
)

#: The noise of one bin of a 23-revolution average at 2 N, N.
BIN_NOISE_N = 2.0 / math.sqrt(23)
#: Forces: a null set's held-out error stays within sqrt(1 + 0.35^2) = 1.06 of its floor (module doc), N.
TOL_N = 0.35 * BIN_NOISE_N
#: The change that edge coefficients make: half a bin's noise (module doc), N.
TOL_EDGE_N = 0.5 * BIN_NOISE_N


def _altintas_mean_on_tool(spec: CutSpec, kte: float, kre: float) -> np.ndarray:
    """Average (Fx, Fy) on the tool over a revolution, rigid, down milling (closed form, chip ``fz sin(phi)``)."""
    n = len(spec.pitch_rad)
    c = spec.feed_m_per_s * 2 * math.pi / (n * spec.omega_rad_s)       # feed per tooth
    a = spec.ap_m
    p_st, p_ex = math.pi - math.acos(1 - 2 * spec.ae_m / spec.diameter_m), math.pi

    def fx(p):
        return (n * a * c / (8 * math.pi) * (spec.ktc_pa * math.cos(2 * p) - spec.krc_pa * (2 * p - math.sin(2 * p)))
                + n * a / (2 * math.pi) * (-kte * math.sin(p) + kre * math.cos(p)))

    def fy(p):
        return (n * a * c / (8 * math.pi) * (spec.ktc_pa * (2 * p - math.sin(2 * p)) + spec.krc_pa * math.cos(2 * p))
                - n * a / (2 * math.pi) * (kte * math.cos(p) + kre * math.sin(p)))
    return np.array([fx(p_ex) - fx(p_st), fy(p_ex) - fy(p_st)])


def _trochoid_mean_on_tool(spec: CutSpec, kte: float, kre: float) -> np.ndarray:
    """The second-order part of the average (Fx, Fy) on the tool (closed form), rigid, no runout.

    Two circles of radius R whose centres are ``f = a L`` apart along the feed (``a = v_f / Omega``,
    ``L`` the angle to the tooth ahead), on a trochoid: the exact chip along the ray at ``phi`` is
    ``f sin(phi) + A cos(phi)^2 - B sin(phi) cos(phi) + O(f^3 / R^2)`` with ``A = f^2 / (2 R)`` (the
    circles' offset across the ray) and ``B = a f / R`` (the tooth path's lean); derivation in
    ``generators.forces._chip_behind``. Over the arc with ``dFt = Ktc dh``, ``dFr = Krc dh``:
    ``dFx = -(A c^2 - B s c) (Ktc c + Krc s)``, ``dFy = (A c^2 - B s c) (Ktc s - Krc c)``, integrated with
    ``int c^3 = s - s^3 / 3``, ``int c^2 s = -c^3 / 3``, ``int s^2 c = s^3 / 3``."""
    av = spec.feed_m_per_s / spec.omega_rad_s
    R = spec.diameter_m / 2
    lags = np.asarray(spec.pitch_rad)[::-1]          # the angle from each tooth to the one ahead
    A = float(np.sum((av * lags) ** 2)) / (2 * R)     # summed over the teeth
    B = float(np.sum(av * av * lags)) / R
    p_st, p_ex = math.pi - math.acos(1 - 2 * spec.ae_m / spec.diameter_m), math.pi

    def ints(p):
        s, c = math.sin(p), math.cos(p)
        return np.array([s - s ** 3 / 3, -c ** 3 / 3, s ** 3 / 3])   # c^3, c^2 s, s^2 c

    c3, c2s, s2c = ints(p_ex) - ints(p_st)
    kt, kr = spec.ktc_pa, spec.krc_pa
    fx = -kt * A * c3 - kr * A * c2s + kt * B * c2s + kr * B * s2c
    fy = kt * A * c2s - kr * A * c3 - kt * B * s2c + kr * B * c2s
    # The entry: the chip is bounded by the stock's face too, h <= R - (R - ae) / |cos(phi)|, which rises
    # from 0 at p_st with slope R^2 sin(p_st) / (R - ae) (0.0245 m/rad here) and meets f sin(p_st) after
    # ~0.2 deg: a triangle of chip-angle area (f sin p_st)^2 / (2 slope) = f^2 sin(p_st) (R - ae) / (2 R^2)
    # less than the textbook step, per tooth, with the force direction of p_st.
    s0, c0 = math.sin(p_st), math.cos(p_st)
    lost = float(np.sum((av * lags) ** 2)) * s0 * (R - spec.ae_m) / (2 * R * R)
    fx += lost * (kt * c0 + kr * s0)
    fy -= lost * (kt * s0 - kr * c0)
    # The exit: the two paths cross past 180 deg, where h = 0 at phi - pi = f / (2 R) (to this order): the
    # edge force of each tooth lasts that much longer, at phi = pi (Fx = Kte, Fy = Kre on the tool).
    ext = float(np.sum(av * lags)) / (2 * R)
    fx += ext * kte
    fy += ext * kre
    return spec.ap_m / (2 * math.pi) * np.array([fx, fy])


def test_rigid_mean_force_equals_the_closed_form():
    spec = CutSpec()
    t = np.arange(3600) / 3600 / (spec.spindle_rpm / 60.0)
    for kte, kre in ((0.0, 0.0), (2e4, 1e4)):
        got = -rigid_forces(t, spec, ForceEffects(kte_n_per_m=kte, kre_n_per_m=kre)).mean(0)[:2]   # on the tool
        want = _altintas_mean_on_tool(spec, kte, kre) + _trochoid_mean_on_tool(spec, kte, kre)
        fz = spec.feed_m_per_s * 2 * math.pi / (len(spec.pitch_rad) * spec.omega_rad_s)
        assert np.abs(got - want).max() <= (fz / (spec.diameter_m / 2)) ** 2 * np.linalg.norm(want), (got, want)


def _robolobes_revolutions(case) -> np.ndarray:
    from robolobes.identify.effects import ModelState
    from robolobes.identify.force_model import simulate_forces

    t, f = simulate_forces(ModelState(case=case), WINDOW_S[1])
    sel = t >= WINDOW_S[0]
    t, f = t[sel], f[sel]
    rate = case.cut.spindle_rpm / 60.0 * SAMPLES_PER_REV
    k = np.round(t * rate).astype(int)
    assert np.abs(k / rate - t).max() < 1e-9          # the pass is sampled on the generator's grid
    start = int(np.argmax(k % SAMPLES_PER_REV == 0))
    n = (len(k) - start) // SAMPLES_PER_REV
    return f[start:start + n * SAMPLES_PER_REV].reshape(n, SAMPLES_PER_REV, 3).mean(0)


def _aligned(gen: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """``gen`` (one revolution) circularly shifted by the sub-sample amount that best matches ``ref``."""
    G = np.fft.rfft(gen, axis=0)
    k = np.arange(G.shape[0])[:, None]

    def shifted(s):
        return np.fft.irfft(G * np.exp(2j * np.pi * k * s / len(gen)), n=len(gen), axis=0)
    s = minimize_scalar(lambda s: float(np.sum((shifted(s) - ref)[:, :2] ** 2)), bounds=(-3, 3), method="bounded").x  # pyright: ignore[reportAttributeAccessIssue]  # OptimizeResult carries x
    return shifted(s)


def test_generator_matches_robolobes_force_model():
    from robolobes.cases import load_case

    case = load_case("tx200-aluminium")
    ref0 = _robolobes_revolutions(case)
    gen0 = _aligned(periodic_forces(), ref0)
    assert np.sqrt(np.mean((gen0 - ref0)[:, :2] ** 2)) <= TOL_N
    kte, kre = 2e4, 1e4
    ref1 = _robolobes_revolutions(replace(case, law=replace(case.law, kte_n_per_m=kte, kre_n_per_m=kre)))
    gen1 = _aligned(periodic_forces(eff=ForceEffects(kte_n_per_m=kte, kre_n_per_m=kre)), ref1)
    d_ref, d_gen = (ref1 - ref0)[:, :2], (gen1 - gen0)[:, :2]
    assert np.sqrt(np.mean((d_gen - d_ref) ** 2)) <= TOL_EDGE_N


def test_rigid_generator_matches_robolobes_eroded_part_with_the_same_slices():
    # A rigid tool on a straight path: robolobes' eroded part and milling law (run_prescribed) against the
    # generator's rigid_forces at the same instants and with the same 22 slices, so that both compute the
    # same exact chip and differ only by robolobes' columns: boundary interpolation dx^2 / (8 R) = 2.5e-11 m
    # and removal chords of sagitta <= 1 nm. Tolerance: a chip error of 10 nm on every element,
    # Ktc * 10 nm * ap = 0.011 N (the 2 nm of the workpiece tests, with room for the corners at the
    # entry). The textbook chip fz sin(phi) is 0.49 N off, and robolobes' chip interpolated across the
    # tooth's own fresh cut was 0.13 N off. Second revolution (the first plunges into an uncut part).
    from robolobes.cases import load_case
    from robolobes.timedomain.workpiece import Workpiece
    from robolobes.timedomain.workpiece_force import MillingForce, run_prescribed, straight_path

    case = load_case("tx200-aluminium")
    spec = CutSpec()
    tol = spec.ktc_pa * 10e-9 * spec.ap_m
    for kte, kre, runout in ((0.0, 0.0, (0.0, 0.0)), (2e4, 1e4, (5e-6, 0.0)), (0.0, 0.0, (0.0, 120e-6))):
        tool = replace(case.tool, runout_m=runout)
        law = replace(case.law, kte_n_per_m=kte, kre_n_per_m=kre)
        wp = Workpiece(tool, case.cut, x_entry_m=0.0, part_length_m=0.02, discs=22)
        t = np.arange(3 * SAMPLES_PER_REV) / (case.cut.spindle_rpm / 60.0 * SAMPLES_PER_REV)
        c, a = straight_path(tool, case.cut, t, x0_m=tool.radius_m + 1e-3)
        ref = np.asarray(run_prescribed(MillingForce(tool, law, case.cut, wp), t, c, a).force_workpiece_n)
        last = slice(2 * SAMPLES_PER_REV, 3 * SAMPLES_PER_REV)
        gen = rigid_forces(t[last], spec, ForceEffects(kte_n_per_m=kte, kre_n_per_m=kre, tooth_radius_m=runout),
                           n_slices=22)
        assert np.sqrt(np.mean((gen - ref[last])[:, :2] ** 2)) <= tol, (kte, runout)


def test_dynamometer_acts_on_the_continuous_force():
    # The generator's dynamometer against a second method: scipy's lsim (the ODE, input linear between
    # samples) on the generator's own force at 40 samples per data sample, over three revolutions (the
    # start transient decays as exp(-zeta wn t), e^-30 after the first two), sampled at the data instants
    # of the last one. The force is edge-dominated (Kte 81, Kre 75 N/mm, the pair draw dynamometer+edge
    # seed 1) and the mode at 4.7 kHz, zeta 0.17, so the edge force's steps inside a sample interval
    # matter: filtering the 180-per-revolution samples with lsim was 0.87 N RMS off this reference.
    # Method errors: the reference's linear interpolation at 40x, second order, ~0.87 / 40^2 = 5e-4 N;
    # the generator's 20x oversampling 0.006 N (its value at 40x). Tolerance: a tenth of a bin's noise
    # (0.042 N), which raises a held-out error by sqrt(1 + 0.1^2) = 1.005 at most.
    from scipy import signal

    from generators.forces import measured_forces

    spec = CutSpec()
    fn, zeta = 4670.8, 0.1677
    eff = ForceEffects(kte_n_per_m=81.46e3, kre_n_per_m=74.77e3, dynamometer=(fn, zeta))
    t, got = measured_forces(spec, eff, entry=False)
    u = 40
    fine = periodic_forces(spec, ForceEffects(kte_n_per_m=81.46e3, kre_n_per_m=74.77e3), samples=SAMPLES_PER_REV * u)
    rate = spec.spindle_rpm / 60.0 * SAMPLES_PER_REV
    tt = np.arange(3 * len(fine)) / (rate * u)
    w = 2 * math.pi * fn
    stage = signal.lti([w * w], [1.0, 2 * zeta * w, w * w])
    out = np.column_stack([signal.lsim(stage, np.tile(fine[:, j], 3), tt)[1] for j in range(2)])
    want = out[2 * len(fine)::u]                       # last revolution, phase 2 pi k / 180
    k = np.round(t * rate).astype(int) % SAMPLES_PER_REV
    first = np.array([int(np.argmax(k == b)) for b in range(SAMPLES_PER_REV)])
    assert np.sqrt(np.mean((got[first, :2] - want) ** 2)) <= 0.1 * BIN_NOISE_N


def _off_periodic(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The part (n, k) of ``x`` (samples on the generator's grid over WINDOW_S) off its periodic part: minus a
    linear trend and minus each bin's mean over the whole revolutions of the window."""
    rate = CutSpec().spindle_rpm / 60.0 * SAMPLES_PER_REV
    k = np.round(t * rate).astype(int)
    sel = (t >= WINDOW_S[0] - 1e-9) & (t <= WINDOW_S[1] + 1e-9)
    k, x, t = k[sel], x[sel], t[sel]
    start = int(np.argmax(k % SAMPLES_PER_REV == 0))
    n = (len(k) - start) // SAMPLES_PER_REV
    x, t = x[start:start + n * SAMPLES_PER_REV], t[start:start + n * SAMPLES_PER_REV]
    A = np.column_stack([np.ones_like(t), t])
    res = x - A @ np.linalg.lstsq(A, x, rcond=None)[0]
    return res - np.tile(res.reshape(n, SAMPLES_PER_REV, -1).mean(0), (n, 1))


def _averages(t: np.ndarray, f: np.ndarray) -> np.ndarray:
    """One-revolution synchronous average (SAMPLES_PER_REV, 3) of ``f`` over the whole revolutions of WINDOW_S."""
    rate = CutSpec().spindle_rpm / 60.0 * SAMPLES_PER_REV
    sel = (t >= WINDOW_S[0] - 1e-9) & (t <= WINDOW_S[1] + 1e-9)
    k, f = np.round(t[sel] * rate).astype(int), f[sel]
    start = int(np.argmax(k % SAMPLES_PER_REV == 0))
    n = (len(k) - start) // SAMPLES_PER_REV
    return f[start:start + n * SAMPLES_PER_REV].reshape(n, SAMPLES_PER_REV, 3).mean(0)


@pytest.mark.slow  # 25-65 s: the default run stays under 10 minutes
def test_pass_entry_matches_robolobes_pass():
    # A second method for the generator's pass with its entry: robolobes' linearized pass (its own robot
    # model, Newmark, eroded part; the model identify fits) on the same cut with the truth of edge+runout
    # seed 1 (Kte 92.6, Kre 84.7 N/mm, tooth radii -11.2 and +11.2 um), where the robot's ringing after
    # the entry moved the synchronous averages by 0.48 N per bin off the generator's periodic steady state.
    # Tolerances: (1) the tool's motion off its periodic part (8.7 um RMS in x, 4.9 in y), difference at
    # most a tenth of robolobes' RMS on each axis: that motion made the 0.48 N per bin, so a tenth of it
    # is about 0.05 N, a tenth of a bin's noise; the generator's steady state (no such motion) fails it
    # by 100 %. (2) the synchronous averages, as in test_generator_matches_robolobes_force_model: 0.35 of a
    # bin's noise (the periodic generator was 0.48 N off here). Measured 2026-12-06: 0.047 and 0.069 um
    # (0.5 and 1.4 %), 0.086 N.
    from robolobes.cases import load_case
    from robolobes.identify.effects import ModelState
    from robolobes.identify.force_model import model_disc_count
    from robolobes.timedomain import LinearizedNewmark, SimulationProblem
    from robolobes.timedomain.drivers import run_linearized
    from robolobes.timedomain.equations import PassSetup

    from generators.forces import simulate_pass

    kte, kre, radii = 92.59e3, 84.69e3, (-11.2e-6, 11.2e-6)
    case = load_case("tx200-aluminium")
    case = replace(case, law=replace(case.law, kte_n_per_m=kte, kre_n_per_m=kre), tool=replace(case.tool, runout_m=radii))
    problem = SimulationProblem(ModelState(case=case).robot(), case, t_end_s=WINDOW_S[1])
    rec = run_linearized(PassSetup(problem, LinearizedNewmark(n_discs=model_disc_count(case))), None)
    run = simulate_pass(WINDOW_S[1], eff=ForceEffects(kte_n_per_m=kte, kre_n_per_m=kre, tooth_radius_m=radii))
    t_ref = np.asarray(rec.t_s)
    assert t_ref.shape == run.t_s.shape and np.abs(t_ref - run.t_s).max() < 1e-9
    ref = _off_periodic(t_ref, np.asarray(rec.center_m))
    gen = _off_periodic(run.t_s, run.centre)
    rms_ref = np.sqrt(np.mean(ref ** 2, axis=0))
    assert np.all(rms_ref > 3e-6)                      # the ringing is there (8.7 and 4.9 um)
    assert np.all(np.sqrt(np.mean((gen - ref) ** 2, axis=0)) <= 0.1 * rms_ref)
    d = _averages(run.t_s, run.force) - _averages(t_ref, -np.asarray(rec.force_tool_n))
    assert np.sqrt(np.mean(d[:, :2] ** 2)) <= TOL_N


@pytest.mark.slow  # 25-65 s: the default run stays under 10 minutes
def test_pass_forces_between_samples_are_the_samples_at_the_samples():
    # fine_pass_forces propagates the robot between samples from each sample's state; at a sample the
    # propagation is the identity, so its forces there are the pass's own, to rounding (1e-6 N). Up to
    # 0.12 s: through the first contact (0.065 s) and the full engagement (0.147 s is beyond; the entry
    # face bounds the chip throughout).
    from generators.forces import fine_pass_forces, simulate_pass

    eff = ForceEffects(kte_n_per_m=3e4, kre_n_per_m=2e4)
    run = simulate_pass(0.12, eff=eff)
    _, fine = fine_pass_forces(run, eff=eff, u=4)
    assert np.abs(run.force).max() > 10.0
    assert np.abs(fine[::4] - run.force).max() <= 1e-6
