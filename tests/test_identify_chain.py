"""The measurement chain as FRF effects (identify/chain_effects.py): closed forms and identification.

Closed forms: on a one-DOF oscillator ``H = 1 / (k - w^2 m + i w c)`` (typed here, not taken from the
code), the identifier's ``predict`` with each chain effect equals ``s H``, ``exp(-i w tau) H`` and
``1 / (k - w^2 (m + m_a) + i w c) = H / (1 - w^2 m_a H)``; the mass-loaded natural frequency is
``sqrt(k / (m + m_a)) / 2 pi``. The accelerometer's perturbation on the TX200 equals the independent
generator's pinocchio point mass (tests/generators/tx200.py). Identification: seeded sets from the
independent generator through the command line (rule: tests/generators/chain_draws.py).
"""

import math

import numpy as np
import pytest
from generators.chain_draws import run_chain_case
from generators.tx200 import POSE_OFFSETS_DEG, POSE_TAB7_DEG, TX200, Effects
from numpy.testing import assert_allclose
from robolobes.identify.chain_effects import AccelerometerMassEffect
from robolobes.identify.effects import REGISTRY, effects_for
from robolobes.identify.frf import PoseData, predict
from robolobes.identify.structural import PoseMatrices

effects_for("frf")   # loads the library into REGISTRY

M_KG, K_N_PER_M, C_N_S_PER_M = 0.5, 2.0e6, 40.0          # 318 Hz, zeta 0.02
W = 2 * math.pi * np.linspace(5.0, 800.0, 400)
# modal superposition through an eigendecomposition of a 2x2 state matrix: round-off ~1e-14
# relative; 1e-9 leaves only that
RTOL = 1e-9


def _sdof(mass_kg=M_KG):
    return 1.0 / (K_N_PER_M - W ** 2 * mass_kg + 1j * W * C_N_S_PER_M)


def _one_dof_pose(out_dirs=((1.0, 0.0, 0.0),), channels=(0,), J=(1.0, 0.0, 0.0)):
    """A one-DOF pose: the coordinate moves the TCP along ``J`` (base axes); one pair per output
    direction, force along x; ``channels`` their response channels."""
    pm = PoseMatrices(M=np.array([[M_KG]]), C=np.array([[C_N_S_PER_M]]), K=np.array([[K_N_PER_M]]),
                      J=np.array(J, float)[:, None], R_tcp=np.eye(3), motion_dofs=np.array([0]),
                      virtual_dofs=np.zeros(0, int), joint_k=np.array([K_N_PER_M]), joint_d=np.array([C_N_S_PER_M]),
                      virtual_k=0.0, virtual_d=0.0, J_payload=np.zeros((3, 1)), payload_mass_kg=0.0)
    n, P = len(W), len(out_dirs)
    return PoseData("p", pm, W, np.tile(np.arange(n), P), np.zeros((P * n, 3)), np.zeros((P * n, 3)),
                    np.zeros(P * n, complex), np.ones(P * n), np.repeat(np.arange(P), n),
                    np.array(out_dirs, float), np.tile([1.0, 0.0, 0.0], (P, 1)), np.array(channels))


def test_channel_scale_is_the_calibration_factor_of_its_response_channel():
    # J = (1, 0.5, 0): H_xx = 1 / Z, H_yx = 0.5 / Z; scale_y touches the y pair only
    pd = _one_dof_pose(out_dirs=((1.0, 0.0, 0.0), (0.0, 1.0, 0.0)), channels=(0, 1), J=(1.0, 0.5, 0.0))
    got = predict(pd, [(REGISTRY["channel_scale"], {"scale_x": 1.07, "scale_y": 0.88, "scale_z": 1.0})])
    n = len(W)
    assert_allclose(got[:n], 1.07 * _sdof(), rtol=RTOL)
    assert_allclose(got[n:], 0.88 * 0.5 * _sdof(), rtol=RTOL)


def test_daq_delay_is_a_linear_phase():
    pd = _one_dof_pose()
    tau = 50e-6
    got = predict(pd, [(REGISTRY["daq_delay"], {"delay_s": tau})])
    assert_allclose(got, np.exp(-1j * W * tau) * _sdof(), rtol=RTOL)
    # the phase lag at 800 Hz: 2 pi 800 50e-6 = 0.251 rad, against the undelayed model
    lag = np.angle(_sdof()[-1] / got[-1])
    assert lag == pytest.approx(2 * math.pi * 800.0 * tau, rel=1e-9)


def test_accelerometer_mass_loads_the_driving_point():
    pd = _one_dof_pose()
    ma = 0.02
    eff = REGISTRY["accelerometer_mass"]
    assert isinstance(eff, AccelerometerMassEffect)
    got = predict(pd, [(eff, {"mass_kg": ma})])
    H = _sdof()
    assert_allclose(got, _sdof(M_KG + ma), rtol=RTOL)
    assert_allclose(got, H / (1 - W ** 2 * ma * H), rtol=RTOL)
    pm = eff.perturb(pd.pm, {"mass_kg": ma})
    f_n = math.sqrt(np.linalg.eigvals(np.linalg.solve(pm.M, pm.K))[0].real) / (2 * math.pi)
    assert f_n == pytest.approx(math.sqrt(K_N_PER_M / (M_KG + ma)) / (2 * math.pi), rel=1e-12)   # 2x2 algebra


def test_accelerometer_mass_equals_the_generators_point_mass():
    # the perturbation M + m_a J^T J on the library's TX200 against the generator's pinocchio body
    # (an inertia added at the TCP, nothing shared); both linear models are exact: 1e-9 of max |H|
    from robolobes.cases import load_case
    from robolobes.identify.structural import pose_matrices
    from robolobes.linearize import build_model

    case = load_case("tx200-aluminium")
    robot = build_model(case.robot, "basic")
    f = np.linspace(2.0, 300.0, 200)
    w = 2 * math.pi * f
    pairs = [(o, i) for o in range(3) for i in range(3)]
    gen = TX200(Effects(accel_mass_kg=0.05))
    for k in (0, 3):
        q = POSE_TAB7_DEG + POSE_OFFSETS_DEG[k]
        pm = pose_matrices(robot, np.radians(q))
        n = len(w)
        pd = PoseData("p", pm, w, np.tile(np.arange(n), 9), np.zeros((9 * n, 3)), np.zeros((9 * n, 3)),
                      np.zeros(9 * n, complex), np.ones(9 * n), np.repeat(np.arange(9), n),
                      np.array([np.eye(3)[o] for o, _ in pairs]), np.array([np.eye(3)[i] for _, i in pairs]),
                      np.array([o for o, _ in pairs]))
        got = predict(pd, [(REGISTRY["accelerometer_mass"], {"mass_kg": 0.05})]).reshape(9, n)
        Hg = gen.frf(q, f)
        ref = np.array([Hg[o, i] for o, i in pairs])
        assert np.abs(got - ref).max() <= 1e-9 * np.abs(ref).max(), k


def test_chain_effects_are_declared_and_not_written_to_the_model():
    from robolobes.cases import load_case
    from robolobes.identify.effects import ModelState
    from robolobes.identify.model_toml import model_toml

    names = [e.name for e in effects_for("frf")]
    assert "channel_scale" in names and "daq_delay" in names and "accelerometer_mass" not in names
    state = ModelState(load_case("tx200-aluminium"), case_ref="tx200-aluminium")
    for name, params in (("channel_scale", {"scale_x": 1.05, "scale_y": 1.0, "scale_z": 1.0}),
                         ("daq_delay", {"delay_s": 5e-5}), ("accelerometer_mass", {"mass_kg": 0.02})):
        eff = REGISTRY[name]
        assert eff.stage == "chain" and "frf" in eff.observed_by and all(p.doc for p in eff.parameters)
        new = eff.apply(state, params)
        assert new.chain == ((name, params),) and new.elements == ()
        assert name not in model_toml(new)


# ------------------------------------------------------------------------------------------------
# identification through the command line, data from the independent generator


def test_channel_scale_12_one_draw(tmp_path):
    r = run_chain_case("channel_scale_12", 1, tmp_path)
    assert r["right"], r


@pytest.mark.slow
@pytest.mark.parametrize("case", ["channel_scale_5", "daq_delay", "accelerometer"])
def test_chain_effect_one_draw(tmp_path, case):
    r = run_chain_case(case, 1, tmp_path)
    assert r["right"], r


# channel_scale_5+joint and daq_delay+joint: 3 of 5 each on this code (docs/guide/identify.md,
# "Measurement-chain effects"): seeds 1 / 5 are missed because the selection's held-out z (unweighted
# |dH|^2, dominated by a few peak lines) is 2.3 even for the true model against 3.7 needed; seed 4 is
# found 6-8 sd off (the fit's weights come from identify's own noise estimate). strict: a pass shows
# as XPASS and fails the run.
_JOINT_5 = pytest.param("channel_scale_5+joint", marks=pytest.mark.xfail(
    strict=True, reason="3 of 5: held-out z too weak for a 5 % scale beside a joint (seed 1); seed 4 7.5 sd off"))
_DELAY_JOINT = pytest.param("daq_delay+joint", marks=pytest.mark.xfail(
    strict=True, reason="3 of 5: missed beside a joint (seed 5, held-out z); seed 4 6 sd off"))


@pytest.mark.slow
@pytest.mark.long
@pytest.mark.parametrize("case", ["channel_scale_5", "channel_scale_12", "daq_delay", _JOINT_5,
                                  _DELAY_JOINT, "accelerometer", "accelerometer_bare"])
def test_chain_draws_right_in_at_least_4_of_5(tmp_path, case):
    got = [run_chain_case(case, seed, tmp_path) for seed in range(1, 6)]
    assert sum(r["right"] for r in got) >= 4, [(r["seed"], r["why"]) for r in got]
