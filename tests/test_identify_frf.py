"""Identification from tool-tip FRF sets: fast perturbations, the significance rule, the command line.

Synthetic data come from the project's model with one undeclared element (pinocchio model,
linearized at equilibrium, direct solve: identify/synthetic.py), written as UFF58 files; the
identifier uses its own fast perturbation of M, C, K, so the data do not come from its code path.
"""

import json
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from robolobes.cases import load_case
from robolobes.identify.effects import REGISTRY
from robolobes.identify.selection import significance, z_threshold
from robolobes.identify.synthetic import synthetic_frf_set, truth_errors
from robolobes.linearize import build_model, linearize
from robolobes.linearize.extra_elements import (JointCorrection, MountCompliance, OrthogonalCorrection, PayloadMass,
                                               ServoDrive)
from robolobes.linearize.tool import TcpOscillator
from robolobes.main import main

CASE = load_case("tx200-aluminium")
TAB7 = CASE.path.start_q_rad
THETA = TAB7 + np.radians([15, 5, -5, 0, 10, 0])


def _fast_vs_element(robot, variant, effect_name, params, element):
    """Receptance by the identifier's perturbation against the element's full model (base axes)."""
    from robolobes.identify.frf import PoseData, predict
    from robolobes.identify.structural import pose_matrices

    w = 2 * math.pi * np.linspace(2, 300, 150)
    pm = pose_matrices(robot, THETA)
    pairs = [(o, i) for o in range(3) for i in range(3)]
    n = len(w)
    pd = PoseData("p", pm, w, np.tile(np.arange(n), 9), np.zeros((9 * n, 3)), np.zeros((9 * n, 3)),
                  np.zeros(9 * n, complex), np.ones(9 * n), np.repeat(np.arange(9), n),
                  np.array([np.eye(3)[o] for o, _ in pairs]), np.array([np.eye(3)[i] for _, i in pairs]))
    fast = predict(pd, [(REGISTRY[effect_name], params)]).reshape(9, n)
    H = linearize(build_model(CASE.robot, variant, extra_elements=(element,)), THETA).frf(w).H
    full = np.array([H[o, i] for o, i in pairs])
    return fast, full


@pytest.mark.parametrize("variant,name,params,element", [
    ("basic", "tcp_mode", {"freq_hz": 180.0, "damping_ratio": 0.03, "stiffness_n_per_m": 8e6,
                           "polar_rad": 1.0, "azimuth_rad": 0.4},
     TcpOscillator.one_axis(180.0, 0.03, 8e6, (math.sin(1.0) * math.cos(0.4), math.sin(1.0) * math.sin(0.4), math.cos(1.0)))),
    ("basic", "joint_correction_a2", {"stiffness_scale": 0.7, "damping_scale": 2.0}, JointCorrection(2, 0.7, 2.0)),
    ("basic", "payload_mass", {"mass_scale": 1.2}, PayloadMass(0.2 * CASE.robot.payload.mass_kg)),
    ("orthogonal", "orthogonal_correction", {"stiffness_scale": 0.5, "damping_scale": 1.5},
     OrthogonalCorrection(0.5, 1.5)),
    ("gravity", "joint_correction_a3", {"stiffness_scale": 1.3, "damping_scale": 1.0}, JointCorrection(3, 1.3, 1.0)),
    # servo: J = 5 kg m^2, kp = 4e6 N m/rad, kd = 2e3 N m s/rad behind k2 = 6.02e6 N m/rad, as the
    # effect's kp / k, sqrt((k + kp) / J) / 2 pi and kd / (2 sqrt((k + kp) J))
    ("basic", "servo_a2", {"kp_scale": 4e6 / 6.02e6, "rotor_freq_hz": math.sqrt(10.02e6 / 5.0) / (2 * math.pi),
                           "rotor_damping_ratio": 2e3 / (2 * math.sqrt(10.02e6 * 5.0))},
     ServoDrive(2, 5.0, 4e6, 2e3)),
    # the mount: 1.5e8 N/m under the 1045 kg robot (NOTES.md Tab. 3-4), zeta 0.05: c = 2 zeta sqrt(k M)
    ("basic", "mount_z", {"stiffness_n_per_m": 1.5e8, "damping_ratio": 0.05},
     MountCompliance(kz_n_per_m=1.5e8, cz_n_s_per_m=0.1 * math.sqrt(1.5e8 * 1045.0))),
    ("gravity", "mount_z", {"stiffness_n_per_m": 1.5e8, "damping_ratio": 0.05},
     MountCompliance(kz_n_per_m=1.5e8, cz_n_s_per_m=0.1 * math.sqrt(1.5e8 * 1045.0))),
    # the mount's rocking: 6e7 N m/rad about base x and y (the robot, ~800 kg m^2 about them, at
    # ~44 Hz), damping time 3e-4 s: c = eta k on both axes
    ("basic", "mount_rock", {"stiffness_n_m_per_rad": 6e7, "damping_time_s": 3e-4},
     MountCompliance(krx_n_m_per_rad=6e7, kry_n_m_per_rad=6e7, crx_n_m_s_per_rad=1.8e4, cry_n_m_s_per_rad=1.8e4)),
    # with gravity the fast path omits M g z_G (~7e3 N m/rad) and its coupling to the joints, and the
    # tilt of the equilibrium under the centre of mass's offset: measured 7.9e-4 of the peak here
    # (THETA), but 7.6e-3 at Tab. 7 with A3 + 5 deg (docs/model.md), above this test's 5e-3
    ("gravity", "mount_rock", {"stiffness_n_m_per_rad": 6e7, "damping_time_s": 3e-4},
     MountCompliance(krx_n_m_per_rad=6e7, kry_n_m_per_rad=6e7, crx_n_m_s_per_rad=1.8e4, cry_n_m_s_per_rad=1.8e4)),
])
def test_fast_perturbation_equals_element_model(tx200_robot, variant, name, params, element):
    # two independent paths: M, C, K perturbed in place (identify) vs pinocchio rebuilt with the
    # element (linearize). Exact to round-off for the basic variant (no gravity). With gravity
    # (gravity, orthogonal variants) a softer spring sags further under the uncompensated load, so
    # q, J and dg/dq of the equilibrium move, which the fast path ignores: observed 2e-3 of the
    # peak for the virtual joints halved; tolerance 5e-3, below the 1-3 % measurement noise.
    fast, full = _fast_vs_element(tx200_robot(variant), variant, name, params, element)
    tol = 1e-9 if variant == "basic" else 5e-3
    assert_allclose(fast, full, rtol=0, atol=tol * np.abs(full).max())


def test_significance_rule_false_positive_rate_and_power():
    # Null: r0 = -n (model right), r1 = r0 + d with d independent of n. P(z > z_a) <= a; at
    # a = 0.05 over 4000 draws the rate must not exceed 0.05 + 3 binomial sd (0.0603).
    rng = np.random.default_rng(7)
    N, sigma = 400, np.full(400, 0.1)
    d = 0.002 * (rng.standard_normal(N) + 1j * rng.standard_normal(N))
    cn = lambda: sigma * (rng.standard_normal(N) + 1j * rng.standard_normal(N)) / math.sqrt(2)
    thr = z_threshold(0.05, 1)
    hits = sum(significance(-n, -n + d, sigma) > thr for n in (cn() for _ in range(4000)))
    assert hits / 4000 <= 0.05 + 3 * math.sqrt(0.05 * 0.95 / 4000)
    # Power: a real effect m of total size 5x the noise over the lines is found every time
    m = 5 * math.sqrt(2) * 0.1 / math.sqrt(N) * np.exp(1j * rng.uniform(0, 6.28, N)) * math.sqrt(N) / 2
    assert all(significance(m - n, -n, sigma) > z_threshold(0.01, 10) for n in (cn() for _ in range(50)))


def _run_cli(args, capsys):
    rc = main(args)
    cap = capsys.readouterr()
    return rc, cap.out, cap.err


def _draw(kind, rng):
    """An undeclared element, parameters uniform within bounds above the detection threshold."""
    if kind == "tcp_mode":
        # a tool-holder mode in the measured band: modal mass 0.05-0.5 kg (part of the 44 kg spindle),
        # k = m (2 pi f)^2; its peak 1 / (2 zeta k) >= 6.7e-6 m/N is >= 30x the robot's receptance there
        d = rng.standard_normal(3)
        f, m = rng.uniform(120, 280), 10 ** rng.uniform(math.log10(0.05), math.log10(0.5))
        return "tcp_mode", TcpOscillator.one_axis(f, rng.uniform(0.01, 0.05), m * (2 * math.pi * f) ** 2,
                                                  tuple(d / np.linalg.norm(d)))
    if kind == "joint_correction":
        j = int(rng.integers(1, 4))          # the main axes 1-3, which move the TCP at every pose
        s = rng.uniform(1.15, 1.6) if rng.random() < 0.5 else rng.uniform(0.6, 0.87)
        return f"joint_correction_a{j}", JointCorrection(j, s, rng.uniform(0.8, 1.25))
    if kind == "payload_mass":
        s = rng.uniform(1.1, 1.3) if rng.random() < 0.5 else rng.uniform(0.75, 0.9)
        return "payload_mass", PayloadMass((s - 1) * CASE.robot.payload.mass_kg)
    if kind == "orthogonal_correction":   # 18-DOF variant: virtual-joint stiffness x0.4-0.7 or x1.5-2.5
        s = rng.uniform(1.5, 2.5) if rng.random() < 0.5 else rng.uniform(0.4, 0.7)
        return "orthogonal_correction", OrthogonalCorrection(s, rng.uniform(0.8, 1.25))
    return None, None


def _identify_draw(tmp_path, capsys, kind, seed, n_poses=4, n_lines=400, poles=False, variant="basic"):
    rng = np.random.default_rng(seed)
    name, el = _draw(kind, rng)
    d = tmp_path / f"set_{kind}_{seed}"
    t = synthetic_frf_set(d, CASE, variant=variant, elements=(el,) if el else (), n_poses=n_poses,
                          f_hz=np.linspace(2, 300, n_lines), rel_noise=rng.uniform(0.01, 0.03),
                          add_noise=rng.uniform(0.01, 0.03), seed=seed)
    rc, out, err = _run_cli(["identify", "--measured", str(d), "--json", "--quiet", "--variant", variant]
                            + ([] if poles else ["--no-poles"]), capsys)
    assert rc == 0, err
    t["element"] = el
    return name, json.loads(out), t


def _correct(name, res, t):
    e_gen, e_own = truth_errors(t)
    if name is None:
        return res["effects"] == []
    ok = bool(res["effects"]) and res["effects"][0]["name"] == name and res["error_after"] <= 1.2 * e_gen
    if ok and e_own > 5 * e_gen:
        ok = res["error_before"] / res["error_after"] >= 5
    return ok


@pytest.mark.parametrize("kind,seed", [("tcp_mode", 1), ("joint_correction", 2), (None, 3)])
def test_cli_finds_the_undeclared_effect(tmp_path, capsys, kind, seed):
    name, res, t = _identify_draw(tmp_path, capsys, kind, seed)
    assert _correct(name, res, t), (name, res["effects"], res["error_before"], res["error_after"], truth_errors(t))
    if kind == "tcp_mode":
        # the Gauss-Newton standard deviations cover the truth: |fit - true| < 5 sigma (generous: the
        # noise estimate is conservative and sigma is inflated by the reduced chi-square)
        e, el = res["effects"][0], t["element"]
        for k, true in (("freq_hz", float(el.freq_hz[0])), ("damping_ratio", el.zeta1),
                        ("stiffness_n_per_m", el.k1_n_per_m)):
            assert abs(e["params"][k] - true) < 5 * e["uncertainty"][k], (k, e["params"][k], true, e["uncertainty"][k])
    assert res["metric"].startswith("held-out")
    assert "provenance" in res and len(res["provenance"]["inputs_sha256"]) == 64
    # the model output loads as a case and carries the effect
    p = tmp_path / "model.toml"
    p.write_text(res["model"])
    got = load_case(str(p))
    assert len(got.robot.elements) == len(res["effects"])


@pytest.mark.slow
@pytest.mark.long
@pytest.mark.parametrize("kind", ["tcp_mode", "joint_correction", "payload_mass"])
def test_each_effect_found_in_at_least_4_of_5_draws(tmp_path, capsys, kind, draw_plan):
    plan = draw_plan([11, 12, 13, 14, 15], 4)  # --draws N: the first N seeds, ceil(4 N / 5) of N
    good = [_correct(*_identify_draw(tmp_path, capsys, kind, s)) for s in plan.seeds]
    with capsys.disabled():
        print(f"\n{kind}: {sum(good)} of {len(good)} draws correct {good}")
    assert sum(good) >= plan.need, (plan.describe("4 of 5"), good)


@pytest.mark.slow
@pytest.mark.long
def test_orthogonal_correction_found_in_at_least_4_of_5_draws(tmp_path, capsys, draw_plan):
    plan = draw_plan([21, 22, 23, 24, 25], 4)  # --draws N: the first N seeds, ceil(4 N / 5) of N
    good = [_correct(*_identify_draw(tmp_path, capsys, "orthogonal_correction", s, variant="orthogonal"))
            for s in plan.seeds]
    with capsys.disabled():
        print(f"\northogonal_correction: {sum(good)} of {len(good)} draws correct {good}")
    assert sum(good) >= plan.need, (plan.describe("4 of 5"), good)


@pytest.mark.slow
@pytest.mark.long
def test_no_effect_in_at_least_19_of_20_seeds(tmp_path, capsys, draw_plan):
    plan = draw_plan(range(100, 120), 19)  # --draws N: the first N seeds, ceil(19 N / 20) of N
    good = [_correct(*_identify_draw(tmp_path, capsys, None, s)) for s in plan.seeds]
    with capsys.disabled():
        print(f"\nno effect: {sum(good)} of {len(good)} seeds give [] {good}")
    assert sum(good) >= plan.need, (plan.describe("19 of 20"), good)


def _mode_set(tmp_path):
    el = TcpOscillator.one_axis(200.0, 0.03, 0.2 * (2 * math.pi * 200.0) ** 2, (1.0, 0.0, 0.0))
    d = tmp_path / "set"
    synthetic_frf_set(d, CASE, elements=(el,), n_poses=2, f_hz=np.linspace(2, 300, 300), rel_noise=0.01,
                      add_noise=0.01, seed=5)
    return d


def test_cli_measured_poles(tmp_path, capsys):
    # a tool-holder mode at 200 Hz: the measured poles (LSCF) show an extra pole there, absent from
    # the model before (no model pole within 5 %) and matched after
    d = _mode_set(tmp_path)
    rc, out, err = _run_cli(["identify", "--measured", str(d), "--json", "--quiet"], capsys)
    assert rc == 0, err
    res = json.loads(out)
    assert res["effects"][0]["name"] == "tcp_mode"
    extra = [f for p in res["poles_before"]["per_pose"].values() for f in p.get("extra_poles_hz", [])]
    assert any(abs(f / 200.0 - 1) < 0.03 for f in extra), res["poles_before"]
    after = [f for p in res["poles_after"]["per_pose"].values() for f in p.get("extra_poles_hz", [])]
    assert not any(abs(f / 200.0 - 1) < 0.03 for f in after)


@pytest.mark.slow
def test_cli_report(tmp_path, capsys):
    # report.md, one figure per pose and the lobes before/after with the uncertainty band
    d = _mode_set(tmp_path)
    rep = tmp_path / "rep"
    rc, out, err = _run_cli(["identify", "--measured", str(d), "--quiet", "--no-poles", "--report", str(rep)], capsys)
    assert rc == 0, err
    assert (rep / "report.md").is_file() and len(list(rep.glob("pose_*.png"))) == 2
    assert (rep / "lobes.png").is_file() and "lobes.png" in (rep / "report.md").read_text()
    # a report from other inputs is not replaced: refused before any work, left as it was
    before = (rep / "report.md").read_text()
    rc, out, err = _run_cli(["identify", "--measured", str(d), "--quiet", "--alpha", "0.02", "--report", str(rep)],
                            capsys)
    assert rc == 2 and len(err.strip().splitlines()) == 1 and (rep / "report.md").read_text() == before


def test_servo_named_with_effects_is_found(tmp_path, capsys):
    # --effects restricts the candidates to those named. A soft position loop on axis 2 (kp = 4e6
    # N m/rad, 2/3 of the joint spring) with a 50 kg m^2 rotor: rotor mode sqrt((k + kp) / J) / 2 pi
    # = 71 Hz, so the axis's dynamic stiffness at its 27.7 Hz mode differs from the static one by
    # (k / kp) x / (1 - x) = 0.27 (x = (27.7 / 71)^2), above the 0.1 that tells a servo from a joint
    # correction (identify/structural.py, ServoEffect): it comes first and the error drops to the noise
    d = tmp_path / "set"
    t = synthetic_frf_set(d, CASE, elements=(ServoDrive(2, 50.0, 4e6, 2e3),), n_poses=3,
                          f_hz=np.linspace(2, 300, 400), rel_noise=0.02, add_noise=0.02, seed=9)
    rc, out, err = _run_cli(["identify", "--measured", str(d), "--json", "--quiet", "--no-poles",
                             "--effects", "servo_a2,joint_correction_a2,payload_mass"], capsys)
    assert rc == 0, err
    res = json.loads(out)
    e_gen, _ = truth_errors(t)
    assert res["effects"][0]["name"] == "servo_a2" and res["error_after"] <= 1.2 * e_gen, res["effects"]
    assert set(res["steps"][0]["candidates"]) == {"servo_a2", "joint_correction_a2", "payload_mass"}
    rc, out, err = _run_cli(["identify", "--measured", str(d), "--quiet", "--effects", "servo_a9"], capsys)
    assert rc == 2 and "servo_a9" in err


def test_two_effects_added_greedily_each_step_reported(tmp_path, capsys):
    # a tool mode and a softer, less damped axis 3 together: the larger residual (the mode) first,
    # then the axis; the third step keeps nothing; after both the error is the generating model's
    # (within 1.2x). The axis's damping is lowered too (x0.6): a softer axis with its damping
    # unchanged is also a stiff, light servo (J, kd -> 0 gives the series stiffness k kp / (k + kp)),
    # and either may then be reported (README, "Servo dynamics"); no servo lowers the damping.
    els = (TcpOscillator.one_axis(220.0, 0.03, 0.2 * (2 * math.pi * 220) ** 2, (0.6, 0.8, 0.0)), JointCorrection(3, 0.75, 0.6))
    d = tmp_path / "set"
    t = synthetic_frf_set(d, CASE, elements=els, n_poses=4, f_hz=np.linspace(2, 300, 400), seed=31)
    rc, out, err = _run_cli(["identify", "--measured", str(d), "--json", "--quiet", "--no-poles"], capsys)
    assert rc == 0, err
    res = json.loads(out)
    assert [e["name"] for e in res["effects"]] == ["tcp_mode", "joint_correction_a3"]
    steps = res["steps"]
    with capsys.disabled():
        print("\ntwo effects:", [(s["kept"], s["statistic"], round(s["threshold"], 2), round(s["error_before"], 4),
                                  round(s["error_after"], 4)) for s in steps], "generating", round(truth_errors(t)[0], 4))
    assert [s["kept"] for s in steps] == ["tcp_mode", "joint_correction_a3", None]
    assert all(s["statistic"] > s["threshold"] for s in steps[:2])
    # the third step keeps nothing: its best candidate fails the test, or (statistic null) every
    # candidate was screened out before the held-out test
    assert steps[2]["statistic"] is None or steps[2]["statistic"] <= steps[2]["threshold"]
    e_gen, _ = truth_errors(t)
    assert res["error_after"] <= 1.2 * e_gen
    assert_allclose(res["effects"][1]["params"]["stiffness_scale"], 0.75, atol=5 * res["effects"][1]["uncertainty"]
                    ["stiffness_scale"])


def test_cut_frame_accelerance_set_with_cross_pairs(tmp_path, capsys):
    # the same robot measured in the cut frame (feed, normal, axial), as accelerance in m/s^2/N,
    # pairs feed-normal and axial-feed only: read, converted and rotated right, nothing is missing
    # (held-out error at the noise) and a mode is still found
    # feed along base +y, so that the cut frame (x feed, y = z x x = -x_base, z up) is not the base frame
    from importlib import resources
    text = (resources.files("robolobes.cases") / "data" / "tx200-aluminium.toml").read_text()
    assert "feed_direction = [1, 0, 0]" in text
    case_file = tmp_path / "case_feed_y.toml"
    case_file.write_text(text.replace("feed_direction = [1, 0, 0]", "feed_direction = [0, 1, 0]"))
    case = load_case(str(case_file))
    d = tmp_path / "set"
    el = TcpOscillator.one_axis(180.0, 0.03, 0.2 * (2 * math.pi * 180) ** 2, (0.0, 1.0, 0.0))
    t = synthetic_frf_set(d, case, elements=(el,), n_poses=3, pairs=((0, 0), (1, 1), (0, 1), (2, 0)),
                          f_hz=np.linspace(2, 300, 400), frame="cut", ordinate=12, seed=41,
                          offsets_deg=[[0] * 6, [20, 0, 0, 0, 0, 0], [-25, 0, 0, 0, 0, 0]])  # tool stays vertical
    rc, out, err = _run_cli(["identify", "--measured", str(d), "--json", "--quiet", "--no-poles",
                             "--case", str(case_file)], capsys)
    assert rc == 0, err
    res = json.loads(out)
    e_gen, _ = truth_errors(t)
    assert [e["name"] for e in res["effects"]] == ["tcp_mode"] and res["error_after"] <= 1.2 * e_gen
