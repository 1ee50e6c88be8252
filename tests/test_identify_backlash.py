"""identify finds gear backlash (the eq. 12 dead zone) in cutting forces (issue 10, "Must show").

Synthetic data come from the FULL nonlinear time domain (``NonlinearNewmark``: pinocchio dynamics,
Newton on the full residual, the dead zone in the motion springs) of the aluminium pass with the
``basic`` variant plus a ``backlash`` element of half-width ``s`` drawn uniformly in
[3e-5, 3e-4] rad: from the detection threshold (``identify.cutting_effects.BACKLASH_DETECT_RAD``,
derived from the held-out noise, not from these draws) to the effect's upper bound. Noise: Gaussian,
standard deviation drawn in [1, 3] N per set. The sets are written as ``forces.csv`` + ``cut.toml``
and identified through the command line, without naming the effect (the whole force library is
searched, backlash included).

Criteria per draw (the issue's): backlash first; ``error_after`` at most 1.2 times the generating
model's error on the same held-out revolutions (the noise alone, since the data are the generating
model plus noise); ``before/after >= 5`` whenever the effect's own error (clean data with the dead
zone against clean data without it, after the best circular shift by whole 2-degree bins: the metric
aligns the unknown spindle phase, so a pure lag is not observable) is above 5 times the noise floor.
Those two reference errors are
computed here with plain numpy from the simulated samples (180 per revolution), not with the
identifier's resampling. Fast: one draw. Slow: 5 draws, at least 4 correct.
"""

import json
from pathlib import Path

import numpy as np
import pytest

from robolobes.cases import load_case
from robolobes.linearize import build_model
from robolobes.linearize.extra_elements import GearBacklash
from robolobes.main import main
from robolobes.identify.force_model import model_disc_count
from robolobes.timedomain import NonlinearNewmark, SimulationProblem, simulate

T_START, T_END = 0.25, 0.40   # steady cut from 0.228 s; 46 revolutions at 18 700 rpm
PER_REV = 180                 # simulation samples per revolution (2 deg steps)
S_LOW, S_HIGH = 3e-5, 3e-4    # draw bounds, rad: detection threshold .. the effect's upper bound


def _full_forces(case, half_width_rad):
    extra = (GearBacklash(half_width_rad),) if half_width_rad > 0 else ()
    robot = build_model(case.robot, "basic", extra_elements=extra)
    run = simulate(SimulationProblem(robot, case, t_end_s=T_END), NonlinearNewmark(n_discs=model_disc_count(case)),
                   verdict_companion=False)
    return np.asarray(run.t_s), np.asarray(run.force_workpiece_n)


@pytest.fixture(scope="module")
def base():
    case = load_case("tx200-aluminium")
    t, f = _full_forces(case, 0.0)
    return case, t, f


def _write_set(d: Path, t, f_clean, seed):
    """forces.csv + cut.toml of the window [T_START, T_END] with noise; returns (t_window, noise)."""
    rng = np.random.default_rng(seed)
    sd = rng.uniform(1.0, 3.0)
    sel = t >= T_START
    noise = rng.normal(0.0, sd, (int(sel.sum()), 3))
    d.mkdir(parents=True)
    np.savetxt(d / "forces.csv", np.column_stack([t[sel], f_clean[sel] + noise]), delimiter=",",
               header="t_s,fx_n,fy_n,fz_n", comments="", fmt="%.10g")
    (d / "cut.toml").write_text(f'case = "tx200-aluminium"\nsample_rate_hz = {1.0 / (t[1] - t[0]):.10g}\n'
                                f'window_s = [{t[sel][0]:.10g}, {t[sel][-1]:.10g}]\n')
    return t[sel], noise


def _identify(path: Path, capsys) -> dict:
    capsys.readouterr()
    code = main(["identify", "--measured", str(path), "--json", "--quiet"])
    out = capsys.readouterr().out
    assert code == 0, out
    return json.loads(out)


def _heldout(res: dict, t_win, x):
    """The held-out revolutions of samples ``x`` (at ``t_win``) as (n_rev, PER_REV, 3), from the span
    the identifier reports."""
    i0 = int(round((res["heldout_span_s"][0] - t_win[0]) / (t_win[1] - t_win[0])))
    n = res["revolutions"]["heldout"]
    return x[i0:i0 + n * PER_REV].reshape(n, PER_REV, 3)


def _rms_xy(a):
    return float(np.sqrt(np.mean(a[:, :2] ** 2)))


def _aligned_rms_xy(a, b):
    """min over circular shifts of ``b`` by whole bins (2 deg) of RMS_xy(a - b shifted), brute force."""
    return min(_rms_xy(a - np.roll(b, k, axis=0)) for k in range(len(b)))


def _judge(res, f_with, f_without, noise, t, t_win):
    """(correct, details) by the criteria of the module docstring."""
    sel = t >= T_START
    clean = _heldout(res, t_win, f_with[sel]).mean(0)
    n_avg = _heldout(res, t_win, noise).mean(0)
    ref = _rms_xy(clean + n_avg)                       # RMS of the measured held-out average
    gen = _rms_xy(n_avg) / ref                         # the generating model's error: the noise alone
    # the effect's own error as the metric can see it: the spindle angle at t = 0 is unknown, so the
    # model's phase is aligned, and the part of the effect a circular shift removes (the dead zone's
    # static lag along the feed) is not observable
    own = _aligned_rms_xy(clean, _heldout(res, t_win, f_without[sel]).mean(0)) / ref
    first = res["effects"][0]["name"] if res["effects"] else None
    ratio = res["error_before"] / res["error_after"]
    ok = first == "backlash" and res["error_after"] <= 1.2 * gen
    if own > 5 * res["noise_floor"]:
        ok = ok and ratio >= 5
    return ok, dict(first=first, after=res["error_after"], gen=gen, own=own, ratio=ratio, floor=res["noise_floor"],
                    params=res["effects"][0]["params"] if res["effects"] else None)


def _draws(seeds, base, tmp_path, capsys):
    case, t, f0 = base
    out = []
    for seed in seeds:
        s = float(np.random.default_rng(2000 + seed).uniform(S_LOW, S_HIGH))
        _, f = _full_forces(case, s)
        d = tmp_path / f"backlash-{seed}"
        t_win, noise = _write_set(d, t, f, seed)
        res = _identify(d, capsys)
        ok, info = _judge(res, f, f0, noise, t, t_win)
        out.append((ok, s, info))
        with capsys.disabled():
            print(f"\nbacklash draw {seed}: s = {s:.4g} rad, ok = {ok}, {info}")
    return out


def test_backlash_element_sets_the_dead_zone_of_any_variant(tx200_spec, tx200_robot):
    """The ``backlash`` element gives the motion springs of the basic variant eq. 12's dead zone:
    ``tau_i = -k_i (delta_i - s sign(delta_i))`` outside ``|delta_i| <= s``, 0 inside (closed form,
    k_i from the paper's Tab. 5), with the same DOF as the basic variant; on the backlash variant the
    element's width replaces the robot file's."""
    from robolobes.linearize.model import element_forces, rigid_q

    spec = tx200_spec
    s = 1e-4
    basic = tx200_robot("basic")
    robot = build_model(spec, "basic", extra_elements=(GearBacklash(s),))
    assert robot.nv == basic.nv == 6 and robot.backlash_rad == s and basic.backlash_rad == 0.0
    assert build_model(spec, "backlash", extra_elements=(GearBacklash(2e-4),)).backlash_rad == 2e-4
    # orthogonal + the element at the robot file's 7.3e-5 rad is the paper's backlash variant
    ortho = build_model(spec, "orthogonal", extra_elements=(GearBacklash(7.3e-5),))
    paper = tx200_robot("backlash")
    assert (ortho.nv, ortho.backlash_rad, [e.name for e in ortho.elements]) == \
        (paper.nv, paper.backlash_rad, [e.name for e in paper.elements]) == (18, 7.3e-5, [e.name for e in paper.elements])
    theta = np.radians([-11.71, 20.78, -212.14, 82.76, 60.80, -166.96])
    q = rigid_q(robot, theta)
    delta = np.array([3e-4, -3e-4, 0.5e-4, -0.5e-4, 1e-4, 2e-4])   # axes 3, 4 inside the zone
    q[robot.motion_dofs] += delta
    k = np.array([2.03e6, 6.02e6, 1.91e6, 0.45e6, 0.22e6, 0.07e6])  # Tab. 5, N m/rad
    expected = -k * np.where(np.abs(delta) > s, delta - s * np.sign(delta), 0.0)
    tau = element_forces(robot, q, np.zeros(robot.nv), theta)[robot.motion_dofs]
    np.testing.assert_allclose(tau, expected, rtol=1e-12, atol=1e-9)  # exact arithmetic, float rounding only


def test_backlash_element_in_a_case_toml(tmp_path):
    """``[[elements]] type = "backlash"`` in a case file loads under the strict key check and builds a
    basic robot with that dead zone; a bad width is one BadInput naming it."""
    from robolobes.core.errors import BadInput
    from robolobes.identify.effects import ModelState
    from robolobes.identify.model_toml import model_toml
    from robolobes.identify.cutting_effects import Backlash

    state = Backlash().apply_values(ModelState(load_case("tx200-aluminium"), case_ref="tx200-aluminium"), (1.2e-4,))
    path = tmp_path / "model.toml"
    path.write_text(model_toml(state))
    case = load_case(str(path))
    assert build_model(case.robot, "basic").backlash_rad == 1.2e-4
    with pytest.raises(BadInput, match="half_width_rad"):
        GearBacklash(-1e-5)


def test_spindle_estimate_takes_the_commanded_speed_within_half_a_step():
    """The spindle estimate returns the commanded speed when it is within half a search step
    ``0.1 / (k_max T)`` of it (k_max = 12, T = 0.15 s: 0.056 Hz), and the estimate otherwise. Signal:
    a two-tooth pulse train at f_true plus 2 N noise."""
    from robolobes.identify.force_signals import estimate_spindle_hz

    nominal = 18700 / 60
    t = np.arange(0, 0.15, 1 / 50e3)
    rng = np.random.default_rng(5)
    for f_true, expected, tol in ((nominal + 0.02, nominal, 0.0), (nominal * 1.002, nominal * 1.002, 1e-5 * nominal)):
        ph = 2 * np.pi * f_true * t
        x = np.column_stack([40 * np.maximum(np.sin(2 * ph), 0) + 10 * np.cos(ph),
                             -60 * np.maximum(np.sin(2 * ph + 0.4), 0)]) + rng.normal(0, 2.0, (len(t), 2))
        # tol: 1e-5 relative, the estimator's tested precision (tests/test_identify_forces_io.py)
        assert abs(estimate_spindle_hz(t, x, nominal) - expected) <= tol, f_true


@pytest.mark.slow   # 78-86 s: the longest test of the default run; CI's slow step runs it (its seed 0 also opens the long set)
def test_backlash_one_draw(base, tmp_path, capsys):
    (ok, s, info), = _draws([0], base, tmp_path, capsys)
    assert ok, (s, info)
    # the fitted half-width: within 1e-5 rad of the drawn one (the family's runs are 1e-6 apart; the
    # forces of widths 1e-5 apart differ by several times the noise of the average, see the README)
    assert abs(info["params"]["half_width_rad"] - s) < 1e-5, (s, info)


@pytest.mark.slow
@pytest.mark.long
def test_backlash_five_draws(base, tmp_path, capsys, draw_plan):
    plan = draw_plan(range(5), 4)  # --draws N: the first N seeds, ceil(4 N / 5) of N (tests/draw_counts.py)
    results = _draws(plan.seeds, base, tmp_path, capsys)
    assert sum(ok for ok, _, _ in results) >= plan.need, (plan.describe("4 of 5"), results)
