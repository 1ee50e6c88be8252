"""Extra elements (linearize/extra_elements.py): closed forms and the [[elements]] TOML hook."""

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from robolobes.cases import load_case
from robolobes.cases.spec import ElementSpec
from robolobes.core.errors import BadInput
from robolobes.linearize import build_model, linearize
from robolobes.linearize.extra_elements import (JointCorrection, OrthogonalCorrection, PayloadMass, ServoDrive,
                                                element_from_spec, element_table)
from robolobes.linearize.tool import TcpOscillator

CASE = load_case("tx200-aluminium")
TAB7 = CASE.path.start_q_rad


def _sdof(f_hz, zeta, k, w):
    """Closed-form receptance of a single-DOF oscillator (m/N): 1 / (k - w^2 m + i w c)."""
    m = k / (2 * math.pi * f_hz) ** 2
    return 1.0 / (k - w ** 2 * m + 1j * w * 2 * zeta * math.sqrt(k * m))


def _substructured(H_r, d, f_hz, zeta, k, w):
    """Exact FRF coupling of a mass m on a spring-damper along unit d (base axes) to the robot's TCP.

    The robot first loses the mass m at its TCP (the mode's mass is part of the payload): a point
    mass -m changes its receptance to H_r' = H_r (I + w^2 m H_r)^-1. Body position y = x_r + d u;
    the robot carries the joint force back: x_r = H_r' (F + w^2 m y); along d the joint force is
    the spring's, u = d.(F + w^2 m y) / z with z = k + i w c. With G = H_r' + d d^T / z:
    y = (I - w^2 m G)^-1 G F. (Second method, independent of pinocchio.)
    """
    m = k / (2 * math.pi * f_hz) ** 2
    z = k + 1j * w * 2 * zeta * math.sqrt(k * m)
    Hr = np.moveaxis(H_r, -1, 0)
    Hr = np.linalg.solve(np.swapaxes(np.eye(3) + (w ** 2 * m)[:, None, None] * Hr, -1, -2),
                         np.swapaxes(Hr, -1, -2)).swapaxes(-1, -2)          # H_r (I + w^2 m H_r)^-1
    G = Hr + np.einsum("i,j,f->fij", d, d, 1 / z)
    out = np.linalg.solve(np.eye(3) - (w ** 2 * m)[:, None, None] * G, G)
    return np.moveaxis(out, 0, -1)


@pytest.mark.parametrize("direction", [(1.0, 0.0, 0.0), (0.0, 0.6, 0.8)])
def test_tcp_mode_frf_equals_substructured_robot_plus_oscillator(tx200_robot, direction):
    f0, zeta, k = 900.0, 0.03, 2.0e7
    base = linearize(tx200_robot("basic"), TAB7)
    mode = TcpOscillator.one_axis(f0, zeta, k, direction)
    lin = linearize(build_model(CASE.robot, "basic", extra_elements=(mode,)), TAB7)
    w = 2 * math.pi * np.concatenate([np.linspace(5, 60, 56), np.linspace(700, 1100, 41)])
    d = lin.R_tcp @ np.asarray(mode.direction)           # the mode direction in base axes
    expect = _substructured(base.frf(w).H, d, f0, zeta, k, w)
    # both are exact for the linearized model; 1e-6 of the peak leaves round-off only
    assert_allclose(lin.frf(w).H, expect, rtol=0, atol=1e-6 * abs(_sdof(f0, zeta, k, 2 * math.pi * f0)))


def test_light_tcp_mode_alone_where_robot_is_rigid():
    # m = k / w0^2 = 6.3 g against an apparent robot mass of ~28 kg at the TCP near 900 Hz
    # (a 0.63 kg mode shifts by 1.1 %, see the substructuring test): the robot is rigid by comparison
    # and the receptance along d is the single-DOF closed form.
    f0, zeta, k = 900.0, 0.02, 2.0e5
    mode = TcpOscillator.one_axis(f0, zeta, k, (0.0, 0.0, 1.0))
    lin = linearize(build_model(CASE.robot, "basic", extra_elements=(mode,)), TAB7)
    w = 2 * math.pi * np.linspace(800, 1000, 81)
    d = lin.R_tcp @ np.asarray(mode.direction)
    h_dd = np.einsum("i,ijf,j->f", d, lin.frf(w).H, d)
    peak = abs(_sdof(f0, zeta, k, 2 * math.pi * f0))
    # mass ratio 2e-4 moves the peak by 1e-4, i.e. 1e-4 / zeta = 0.5 % of the peak on its flanks;
    # the robot's own receptance is 1e-5 of the peak: 2 % of the peak
    assert_allclose(h_dd, _sdof(f0, zeta, k, w), rtol=0, atol=2e-2 * peak)
    m = lin.modes()
    i = int(np.argmin(np.abs(m.freq_hz - f0)))
    assert_allclose(m.freq_hz[i], f0, rtol=5e-4)   # sqrt(1 + m / M_eff) - 1 ~ 1e-4
    assert_allclose(m.damping_ratio[i], zeta, rtol=1e-2)
    assert lin.n == 7


def test_joint_correction_scales_axis_stiffness_and_damping():
    # the corrected robot equals a robot whose joint table holds s k, s d (closed form of the element)
    import dataclasses
    spec = CASE.robot
    corr = build_model(spec, "basic", extra_elements=(JointCorrection(2, 0.7, 3.0),))
    joints = list(spec.joints)
    joints[1] = dataclasses.replace(joints[1], stiffness_n_m_per_rad=0.7 * joints[1].stiffness_n_m_per_rad,
                                    damping_n_m_s_per_rad=3.0 * joints[1].damping_n_m_s_per_rad)
    ref = build_model(dataclasses.replace(spec, joints=tuple(joints)), "basic")
    a, b = linearize(corr, TAB7), linearize(ref, TAB7)
    assert_allclose(a.K, b.K, rtol=0, atol=1e-9 * np.abs(b.K).max())
    assert_allclose(a.C, b.C, rtol=0, atol=1e-12 * np.abs(b.C).max())


def test_orthogonal_correction_needs_virtual_joints_and_scales_them():
    import dataclasses
    spec = CASE.robot
    with pytest.raises(BadInput, match="orthogonal"):
        build_model(spec, "basic", extra_elements=(OrthogonalCorrection(0.5, 1.0),))
    a = linearize(build_model(spec, "orthogonal", extra_elements=(OrthogonalCorrection(0.5, 2.0),)), TAB7)
    ref_spec = dataclasses.replace(spec, orthogonal_stiffness_n_m_per_rad=0.5 * spec.orthogonal_stiffness_n_m_per_rad,
                                   orthogonal_damping_n_m_s_per_rad=2.0 * spec.orthogonal_damping_n_m_s_per_rad)
    b = linearize(build_model(ref_spec, "orthogonal"), TAB7)
    assert_allclose(a.K, b.K, rtol=0, atol=1e-9 * np.abs(b.K).max())
    assert_allclose(a.C, b.C, rtol=0, atol=1e-9 * np.abs(b.C).max())


def test_payload_mass_equals_heavier_payload():
    import dataclasses
    spec = CASE.robot
    a = linearize(build_model(spec, "basic", extra_elements=(PayloadMass(7.0),)), TAB7)
    p = spec.payload
    # a point mass at the centre of mass changes the mass and not the central inertia (parallel axes)
    ref_spec = dataclasses.replace(spec, payload=dataclasses.replace(p, mass_kg=p.mass_kg + 7.0))
    b = linearize(build_model(ref_spec, "basic"), TAB7)
    assert_allclose(a.M, b.M, rtol=0, atol=1e-10 * np.abs(b.M).max())


def test_element_tables_round_trip_and_strict_keys():
    for el in (TcpOscillator.one_axis(800.0, 0.02, 1e7, (0, 1, 0)), JointCorrection(3, 1.2, 0.5), OrthogonalCorrection(0.8, 1.0),
               PayloadMass(-3.0), ServoDrive(2, 5.0, 2e7, 1e3)):
        t = element_table(el)
        assert element_from_spec(ElementSpec(t.pop("type"), t)) == el
    with pytest.raises(BadInput, match="unknown key"):
        element_from_spec(ElementSpec("tcp_mode", {"freq_hz": 1.0, "damping_ratio": 0.1, "stiffness_n_per_m": 1.0,
                                                   "frequency": 3.0}))
    with pytest.raises(BadInput, match="missing"):
        element_from_spec(ElementSpec("tcp_mode", {"freq_hz": 1.0}))
    with pytest.raises(BadInput, match="valid: tcp_mode"):
        element_from_spec(ElementSpec("spindle", {}))
    with pytest.raises(BadInput, match="freq_hz"):
        element_from_spec(ElementSpec("tcp_mode", {"freq_hz": -1.0, "damping_ratio": 0.1, "stiffness_n_per_m": 1.0}))


def test_model_toml_loads_and_builds_the_identified_robot(tmp_path):
    # the written case loads (a case file, robot by built-in name) and its robot carries the elements
    from robolobes.identify.effects import ModelState
    from robolobes.identify.model_toml import model_toml
    state = ModelState(case=CASE, variant="basic", case_ref="tx200-aluminium",
                       elements=(ElementSpec("tcp_mode", {"freq_hz": 900.0, "damping_ratio": 0.03,
                                                          "stiffness_n_per_m": 2e7, "direction": [1.0, 0, 0]}),
                                 ElementSpec("joint_correction", {"joint": 2, "stiffness_scale": 0.8,
                                                                  "damping_scale": 1.0})))
    p = tmp_path / "model.toml"
    p.write_text(model_toml(state))
    case = load_case(str(p))
    assert case.name == "tx200-aluminium-identified"
    assert [e.type for e in case.robot.elements] == ["tcp_mode", "joint_correction"]
    ref = build_model(CASE.robot, "basic", extra_elements=(TcpOscillator.one_axis(900.0, 0.03, 2e7, (1, 0, 0)),
                                                            JointCorrection(2, 0.8, 1.0)))
    a, b = linearize(build_model(case.robot, "basic"), TAB7), linearize(ref, TAB7)
    assert_allclose(a.K, b.K, rtol=1e-12)
    assert_allclose(a.M, b.M, rtol=1e-12)
    assert case.law == CASE.law and case.cut == CASE.cut


def test_model_toml_runs_in_lobes_and_modes(tmp_path, capsys):
    # the written model is a case like any other for the commands upstream of identify
    import json
    from robolobes.identify.effects import ModelState
    from robolobes.identify.model_toml import model_toml
    from robolobes.main import main
    state = ModelState(case=CASE, variant="basic", case_ref="tx200-aluminium",
                       elements=(ElementSpec("tcp_mode", {"freq_hz": 900.0, "damping_ratio": 0.03,
                                                          "stiffness_n_per_m": 2e7, "direction": [1.0, 0, 0]}),))
    p = tmp_path / "model.toml"
    p.write_text(model_toml(state))
    assert main(["lobes", "--case", str(p), "--n-rpm", "5", "--json", "--quiet"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert len(out["rpm"]) == 5
    assert main(["modes", "--case", str(p), "--json"]) == 0
    modes = json.loads(capsys.readouterr().out)
    assert any(abs(f - 900) < 20 for f in modes["freq_hz"])


def test_servo_drive_stiff_loop_recovers_the_model_and_static_series_springs(tx200_robot):
    # kp -> inf: the rotor is locked and the robot is the one without servo (1e-4 of the peak at
    # kp = 1e12, k / kp = 6e-6). Statics: joint spring k and loop kp in series give the axis a
    # stiffness k kp / (k + kp), so the static TCP compliance equals that of a joint table with it.
    import dataclasses
    spec = CASE.robot
    w = 2 * math.pi * np.linspace(2, 200, 100)
    base = linearize(tx200_robot("basic"), TAB7).frf(w).H
    stiff = linearize(build_model(spec, "basic", extra_elements=(ServoDrive(2, 5.0, 1e12, 1e3),)), TAB7).frf(w).H
    assert_allclose(stiff, base, rtol=0, atol=1e-4 * np.abs(base).max())
    k, kp = spec.joints[1].stiffness_n_m_per_rad, 3e6
    servo = linearize(build_model(spec, "basic", extra_elements=(ServoDrive(2, 5.0, kp, 1e3),)), TAB7)
    joints = list(spec.joints)
    joints[1] = dataclasses.replace(joints[1], stiffness_n_m_per_rad=k * kp / (k + kp))
    series = linearize(build_model(dataclasses.replace(spec, joints=tuple(joints)), "basic"), TAB7)
    assert_allclose(servo.compliance(), series.compliance(), rtol=1e-9)
