"""Diagnosis by named signatures (identify/signatures.py): synthetic residuals with one known
signature each must show that signature (and, where the physics separates them, no other); pure
noise must show none (family-wise rate 1 %: at least 19 of 20 seeds clean).

Synthetic forces: a two-tooth half-sine pulse train (100 N, half a tooth period), 256 bins per
revolution, bin noise 0.3 N (2 N per sample over 45 revolutions); the signatures are added from
their closed forms (a constant; a cos(theta) line; the sensor's resonance and a 4th-order
Butterworth applied line by line). Synthetic FRFs: two modes (100 Hz, 400 Hz, zeta 3 %) in four
poses, 2 % relative + small additive complex noise; the measurement chain's signatures from their
closed forms (the whole measurement x 1.05; x exp(-i w 20 us)).
"""

import numpy as np
import pytest

from robolobes.identify.cutting_effects import Dynamometer, Lowpass
from robolobes.identify.force_signals import apply_transfer
from robolobes.identify.frf_signatures import PoseResidual, frf_signatures
from robolobes.identify.ranking import rank_candidates
from robolobes.identify.signatures import FORCE_SIGNATURES, FRF_SIGNATURES, force_signatures

M, TEETH, REV_HZ, S = 256, 2, 311.7, 0.3


def _model():
    th = np.arange(M) / M * 2 * np.pi
    x = np.zeros((M, 3))
    phase = (th * TEETH) % (2 * np.pi)
    pulse = np.where(phase < np.pi, np.sin(phase), 0.0) * 100.0
    x[:, 0], x[:, 1] = pulse, 0.6 * np.roll(pulse, M // 16)
    return x


def _force_case(kind, seed):
    rng = np.random.default_rng(seed)
    model = _model()
    meas = model.copy()
    if kind == "mean_offset":
        meas[:, 0] += 1.0
    elif kind == "once_per_rev":
        meas[:, 0] += 1.0 * np.cos(np.arange(M) / M * 2 * np.pi)
    elif kind == "entry_ringing":
        meas = apply_transfer(model, REV_HZ, Dynamometer().transfer((4000.0, 0.1)))
    elif kind == "harmonic_rolloff":
        meas = apply_transfer(model, REV_HZ, Lowpass().transfer((2500.0,)))
    noise = np.full((M, 3), S)
    return meas + rng.normal(0, S, (M, 3)), model, noise


@pytest.mark.parametrize("kind", FORCE_SIGNATURES)
def test_each_force_signature_is_detected_alone(kind):
    got = force_signatures(*_force_case(kind, 7), TEETH)
    present = sorted(k for k, s in got.items() if s.present)
    assert present == [kind], {k: (s.statistic, s.threshold) for k, s in got.items()}


def test_force_noise_shows_no_signature_in_19_of_20_seeds():
    clean = 0
    for seed in range(20):
        got = force_signatures(*_force_case(None, 100 + seed), TEETH)
        clean += not any(s.present for s in got.values())
    assert clean >= 19


def _mode(f, f0, zeta, k=1e7):
    w, w0 = 2 * np.pi * f, 2 * np.pi * f0
    return w0 ** 2 / k / (w0 ** 2 - w ** 2 + 2j * zeta * w0 * w)


def _frf_case(kind, seed):
    rng = np.random.default_rng(seed)
    f = np.linspace(10, 1000, 400)
    out = []
    pose_shift = (0.05, -0.04, 0.08, 0.03)
    for p in range(4):
        model = _mode(f, 100.0, 0.03) + 0.5 * _mode(f, 400.0, 0.03)
        f1, z1, extra, stat = 100.0, 0.03, 0.0, 0.0
        if kind == "uniform_shift":
            f1 = 105.0
        elif kind == "pose_shift":
            f1 = 100.0 * (1 + pose_shift[p])
        elif kind == "peak_height":
            z1 = 0.06
        elif kind == "extra_peak":
            # a stiff tool mode: 1 % of the static compliance (an extra mode adds its 1/k to the
            # quasi-static lines too; at 1 % that stays below the noise of 24 lines at 2 %)
            extra = 0.01 * _mode(f, 700.0, 0.01)
        elif kind == "static_offset":
            stat = 0.3e-7
        meas = _mode(f, f1, z1) + 0.5 * _mode(f, 400.0 * f1 / 100.0 if kind == "uniform_shift" else 400.0, 0.03) \
            + extra + stat
        if kind == "channel_ratio":   # a response channel's calibration off by 5 %
            meas = 1.05 * meas
        elif kind == "phase_slope":   # the response 20 us late: 0.13 rad at 1 kHz
            meas = meas * np.exp(-2j * np.pi * f * 20e-6)
        sigma = 0.02 * np.abs(meas) + 1e-10
        n = sigma / np.sqrt(2) * (rng.normal(size=f.size) + 1j * rng.normal(size=f.size))
        out.append(PoseResidual(name=f"p{p}", f_hz=f, measured=(meas + n)[None], model=model[None],
                                sigma=sigma[None], modes=((100.0, 0.03), (400.0, 0.03))))
    return out


@pytest.mark.parametrize("kind", FRF_SIGNATURES)
def test_each_frf_signature_is_detected(kind):
    got = frf_signatures(_frf_case(kind, 3))
    present = sorted(k for k, s in got.items() if s.present)
    assert present == [kind], {k: (s.statistic, s.threshold, s.detail) for k, s in got.items()}


def _two_channel_case(seed, scale_y=1.0, delay_s=0.0):
    """Two pairs per pose (channels x and y, the y pair 0.6 of the x one), as _frf_case's noise."""
    rng = np.random.default_rng(seed)
    f = np.linspace(10, 1000, 400)
    out = []
    for p in range(4):
        model = np.array([_mode(f, 100.0, 0.03) + 0.5 * _mode(f, 400.0, 0.03)] * 2) * np.array([[1.0], [0.6]])
        meas = model * np.array([[1.0], [scale_y]]) * np.exp(-2j * np.pi * f * delay_s)[None, :]
        sigma = 0.02 * np.abs(meas) + 1e-10
        n = sigma / np.sqrt(2) * (rng.normal(size=meas.shape) + 1j * rng.normal(size=meas.shape))
        out.append(PoseResidual(name=f"p{p}", f_hz=f, measured=meas + n, model=model, sigma=sigma,
                                modes=((100.0, 0.03), (400.0, 0.03)), channels=np.array([0, 1])))
    return out


def test_channel_ratio_names_the_channel_and_its_scale():
    got = frf_signatures(_two_channel_case(4, scale_y=0.95))
    assert sorted(k for k, s in got.items() if s.present) == ["channel_ratio"]
    rows = {r["channel"]: r for r in got["channel_ratio"].detail["per_channel"]}
    # 2 % noise on 4 x 400 lines: the scale's standard error ~ 0.02 / sqrt(2 x 1600) ~ 4e-4 (x sqrt 1.5
    # NOISE_CAL); 0.003 is ~6 of them
    assert rows["y"]["scale"] == pytest.approx(0.95, abs=0.003) and rows["x"]["scale"] == pytest.approx(1.0, abs=0.003)
    assert abs(rows["x"]["z"]) < got["channel_ratio"].threshold


def test_phase_slope_reports_the_delay():
    got = frf_signatures(_two_channel_case(5, delay_s=30e-6))
    assert sorted(k for k, s in got.items() if s.present) == ["phase_slope"]
    # the delay's standard error ~ 0.02 / (w_rms sqrt(2 x 3200)) ~ 7e-8 s; 1 us is > 10 of them
    assert got["phase_slope"].detail["delay_s"] == pytest.approx(30e-6, abs=1e-6)


def test_chain_signatures_are_absent_when_the_residual_is_not_a_common_factor():
    # a stiffness change of the first mode (5 % up, the pose-independent case) is correlated with the
    # model's shape in its band but not a common factor: the homogeneity test refuses it
    got = frf_signatures(_frf_case("uniform_shift", 8))
    assert not got["channel_ratio"].present and not got["phase_slope"].present


def test_frf_noise_shows_no_signature_in_19_of_20_seeds():
    clean = sum(not any(s.present for s in frf_signatures(_frf_case(None, 200 + s)).values()) for s in range(20))
    assert clean >= 19


def test_ranking_puts_the_effect_that_explains_the_signature_first():
    class E:
        def __init__(self, name, sig, group=None):
            self.name, self.signatures, self.group = name, sig, group or name

    got = force_signatures(*_force_case("once_per_rev", 1), TEETH)
    effects = [E("edge_coefficients", ("mean_offset",)), E("runout", ("once_per_rev",)), E("lowpass", ())]
    # the held-out errors favour edge coefficients: the signature still ranks runout first
    rows = rank_candidates(got, effects, {"edge_coefficients": 0.05, "runout": 0.08, "lowpass": 0.09}, 0.1)
    assert [r["name"] for r in rows] == ["runout", "edge_coefficients", "lowpass"]
    assert rows[0]["explains"] == ["once_per_rev"] and rows[0]["score"] == 1.0 and "(1 of 1 detected)" in rows[0]["why"]
    # a tie (no signature) is broken by the explained residual
    assert rows[1]["explained_error"] == pytest.approx(0.05)


def test_ranking_order_is_not_changed_by_a_new_type_sharing_a_signature():
    class E:
        def __init__(self, name, sig):
            self.name, self.signatures = name, sig

    class S:
        def __init__(self, present):
            self.present = present

    got = {"uniform_shift": S(True), "peak_height": S(True), "pose_shift": S(True), "static_offset": S(False)}
    base = [E("payload_mass", ("uniform_shift",)), E("joint_2", ("pose_shift", "peak_height", "static_offset")),
            E("servo_2", ("pose_shift", "peak_height", "static_offset")), E("tcp_mode", ("extra_peak", "static_offset"))]
    errs = {"payload_mass": 0.06, "joint_2": 0.03, "servo_2": 0.05, "tcp_mode": 0.01}
    rows = rank_candidates(got, base, errs, 0.1)
    # eligible (a detected signature explained): joint_2 (removes 0.07), servo_2 (0.05), payload (0.04);
    # tcp_mode explains none of the detected ones: last, although its fit removes the most
    assert [r["name"] for r in rows] == ["joint_2", "servo_2", "payload_mass", "tcp_mode"]
    assert [r["score"] for r in rows] == [2.0, 2.0, 1.0, 0.0] and "(2 of 3 detected)" in rows[0]["why"]
    # a new type that shares pose_shift (the load law) enters by its own error, the others keep their order
    more = base + [E("load_k_3", ("pose_shift", "static_offset"))]
    rows = rank_candidates(got, more, {**errs, "load_k_3": 0.055}, 0.1)
    assert [r["name"] for r in rows] == ["joint_2", "servo_2", "load_k_3", "payload_mass", "tcp_mode"]  # 0.07, 0.05, 0.045, 0.04
    # untried eligible candidates come after the tried ones of their group
    rows = rank_candidates(got, base, {"payload_mass": 0.06}, 0.1)
    assert [r["name"] for r in rows][:1] == ["payload_mass"] and rows[1]["explained_error"] is None


# ---------------------------------------------------------------- on the project's FRF sets (CLI)
def _frf_set_ranking(tmp_path, capsys, element, seed):
    import json
    import math

    from robolobes.cases import load_case
    from robolobes.identify.synthetic import synthetic_frf_set
    from robolobes.main import main

    case = load_case("tx200-aluminium")
    d = tmp_path / f"set{seed}"
    synthetic_frf_set(d, case, elements=(element,) if element is not None else (), n_poses=4,
                      f_hz=np.linspace(2, 300, 400), rel_noise=0.02, add_noise=0.02, seed=seed)
    capsys.readouterr()
    assert main(["identify", "--measured", str(d), "--json", "--quiet", "--no-poles"]) == 0
    res = json.loads(capsys.readouterr().out)
    return res["signatures_detected"], [r["name"] for r in res["ranking"]], math


def _generating(name):
    import math

    from robolobes.cases import load_case
    from robolobes.linearize.extra_elements import JointCorrection, PayloadMass
    from robolobes.linearize.tool import TcpOscillator

    payload = load_case("tx200-aluminium").robot.payload.mass_kg
    return {"tcp_mode": (TcpOscillator.one_axis(200.0, 0.03, 0.2 * (2 * math.pi * 200.0) ** 2, (0.6, 0.0, 0.8)), 11),
            "payload_mass": (PayloadMass(0.25 * payload), 13),
            "joint_correction_a2": (JointCorrection(2, 1.4, 1.0), 12)}[name]


@pytest.mark.slow
@pytest.mark.parametrize("name", ["tcp_mode", "payload_mass", "joint_correction_a2"])
def test_frf_sets_rank_the_generating_effect_first(tmp_path, capsys, name):
    """Sets from the full model path with one undeclared element (fixed parameters above the
    detection thresholds): the ranking by signatures puts that effect first.

    Not an independent check of the ranking rule: the rule was revised after looking at sets like
    these (see the README)."""
    el, seed = _generating(name)
    sig, ranking, _ = _frf_set_ranking(tmp_path, capsys, el, seed)
    with capsys.disabled():
        print(name, sig, ranking[:4])
    assert ranking[0] == name, (name, sig, ranking[:4])


@pytest.mark.slow
def test_frf_noise_only_sets_show_no_signature(tmp_path, capsys):
    """Seed 21 showed channel_ratio (x: z -4.56 against 3.49) until the line noise estimate used
    mirrored median windows at the ends and the neighbours' |H| (tests/test_identify_line_noise.py)."""
    for seed in (21, 22):
        sig, _, _ = _frf_set_ranking(tmp_path, capsys, None, seed)
        assert sig == [], (seed, sig)
