"""The load-dependent gear stiffness (linearize.extra_elements.LoadStiffness) against closed forms.

* The gear torque at a pose computed by hand from NOTES.md's masses (Tab. 1, 3, 4, typed in
  tests/generators/tx200.py): at q = (0, 0, 90, 0, 0, 0) deg the links beyond axis 3 lie straight along
  base x, so the gravity torque on axis 3 is ``g sum m_i z_i`` with ``z_i`` each centre of mass's
  distance along the elbow frame's z axis: 754.79 N m. The element adds ``k3 c |tau| / T`` to K[3, 3].
* With the other joints 1e4 times stiffer the lowest mode is axis 3 against the links beyond it, so
  loading the gear scales its frequency by ``sqrt(1 + c |tau| / T)`` (the inertia cancels).
* The time domain (the element's own force and tangent in Newmark) rings at the linearized frequency.
"""

import math

import numpy as np
import pytest
from generators.tx200 import AG, GB, MASS, PAYLOAD_AG, PAYLOAD_MASS
from robolobes.cases import load_robot
from robolobes.cases.spec import ElementSpec
from robolobes.core.errors import BadInput
from robolobes.linearize import build_model, linearize
from robolobes.linearize.extra_elements import JointCorrection, LoadStiffness, element_from_spec, element_table
from ringing import crossing_frequency_hz

SPEC = load_robot("tx200")
Q_ARM_FLAT = np.radians([0.0, 0.0, 90.0, 0.0, 0.0, 0.0])
G = 9.81
K3 = 1.91e6          # NOTES.md, Tab. 5


def _axis3_torque_by_hand() -> float:
    """|gravity torque| on axis 3 at ``Q_ARM_FLAT``, N m: ``g sum m_i z_i`` over elbow..payload, ``z_i``
    the centre of mass along the elbow frame's z (the straight chain beyond axis 3, roty(90 deg) making
    it horizontal), from the AG and GB vectors of NOTES.md."""
    z, moment = 0.0, 0.0
    for link in ("elbow", "forearm", "wrist", "flange"):
        moment += MASS[link] * (z + AG[link][2])
        z += AG[link][2] + GB[link][2]
    moment += PAYLOAD_MASS * (z + PAYLOAD_AG[2])
    return G * abs(moment)


def test_hand_torque_is_the_notes_sum():
    # the hand sum itself, written out: 9.81 (99 (-0.043) + 41 0.423 + 14 0.868 + 0.6 0.923 + 44.4 1.152)
    assert _axis3_torque_by_hand() == pytest.approx(754.787286, rel=1e-9)


@pytest.mark.parametrize("variant", ["basic", "gravity"])
def test_added_stiffness_from_the_hand_torque(variant):
    # K[3, 3] of the loaded minus the plain model = k3 c |tau| / T; the hand sum uses the same decimals
    # as the robot file, so only rounding separates them: tolerance 1e-9 relative. Every other entry
    # unchanged to 1e-9 of k3 (the dk/dq term vanishes: axis 3 is compensated, its spring at rest in the
    # gravity variant, and without gravity q = theta)
    c, T = 1.3, 1200.0
    plain = linearize(build_model(SPEC, variant), Q_ARM_FLAT).K
    el = LoadStiffness(3, c, T)
    robot = build_model(SPEC, variant, extra_elements=(el,))
    dK = linearize(robot, Q_ARM_FLAT).K - plain
    i = int(robot.motion_dofs[2])
    assert dK[i, i] == pytest.approx(K3 * c * _axis3_torque_by_hand() / T, rel=1e-9)
    dK[i, i] = 0.0
    assert np.abs(dK).max() <= 1e-9 * K3


def test_saturates_at_the_reference_torque():
    # above T the top stiffness k0 (1 + c): T = 500 N m < 754.8 N m
    robot = build_model(SPEC, "basic", extra_elements=(LoadStiffness(3, 2.0, 500.0),))
    plain = linearize(build_model(SPEC, "basic"), Q_ARM_FLAT).K
    i = int(robot.motion_dofs[2])
    assert (linearize(robot, Q_ARM_FLAT).K - plain)[i, i] == pytest.approx(2.0 * K3, rel=1e-12)


def _lowest_hz(extra) -> float:
    stiff = tuple(JointCorrection(j, 1e4) for j in (1, 2, 4, 5, 6))
    lin = linearize(build_model(SPEC, "basic", extra_elements=stiff + extra), Q_ARM_FLAT)
    w2 = np.linalg.eigvals(np.linalg.solve(lin.M, lin.K)).real
    return float(np.sqrt(w2.min()) / (2 * math.pi))


def test_frequency_shift_against_sqrt_k_over_j():
    # other joints 1e4 x stiffer: the axis-3 mode is sqrt(k3 / J3) to O(1e-4) relative (their
    # compliance in series, k3 / (1e4 k_other) <= 2e-4 of k3's); the ratio loaded / plain is
    # sqrt(1 + c tau / T) with the inertia cancelling: tolerance 1e-3
    c, T = 1.5, 1000.0
    f0, f1 = _lowest_hz(()), _lowest_hz((LoadStiffness(3, c, T),))
    assert f1 / f0 == pytest.approx(math.sqrt(1 + c * _axis3_torque_by_hand() / T), rel=1e-3)


def test_toml_table_round_trip_and_bounds():
    e = element_from_spec(ElementSpec("load_stiffness", {"joint": 3, "stiffening": 1.0, "reference_torque_n_m": 800.0}))
    assert e == LoadStiffness(3, 1.0, 800.0)
    t = element_table(e)
    assert t == {"type": "load_stiffness", "joint": 3, "stiffening": 1.0, "reference_torque_n_m": 800.0,
                 "g_m_per_s2": 9.81}
    assert element_from_spec(ElementSpec(t.pop("type"), t)) == e
    for bad in ({"joint": 0, "stiffening": 1.0, "reference_torque_n_m": 800.0},
                {"joint": 3, "stiffening": -0.1, "reference_torque_n_m": 800.0},
                {"joint": 3, "stiffening": 2.5, "reference_torque_n_m": 800.0},
                {"joint": 3, "stiffening": 1.0, "reference_torque_n_m": 0.0},
                {"joint": 3, "stiffening": 1.0, "reference_torque_n_m": float("nan")},
                {"joint": 3, "stiffening": 1.0},
                {"joint": 3, "stiffening": 1.0, "reference_torque_n_m": 800.0, "tau_ref": 1.0}):
        with pytest.raises(BadInput):
            element_from_spec(ElementSpec("load_stiffness", bad))
    with pytest.raises(BadInput, match="axes 1..6"):
        build_model(SPEC, "basic", extra_elements=(LoadStiffness(7, 1.0, 800.0),))


def test_time_domain_rings_at_the_linearized_frequency():
    # the nonlinear equations (timedomain.equations.robot_equations: the element's own force and
    # tangent, gravity, its compensation) released along the mode with the largest axis-3 share, motors
    # fixed: axis 3 rings at the linearized mode's damped frequency. Zero crossings over 0.12 s (~26;
    # longer, the decayed ring meets the static offsets of the integrator's tolerance), 200 steps
    # per period (Newmark's period error (w h)^2 / 12 = 8e-5): tolerance 1 %. The loaded gear (c = 2,
    # T = 1000 N m: k3 x 2.51) moves that mode from 85.7 to 108.4 Hz, 8.6 % from the nearest mode of the
    # plain robot (117.8 Hz): the check below asks 5 % (5x the tolerance), so a simulation that ignored
    # the element would fail
    from robolobes.timedomain.equations import robot_equations
    from robolobes.timedomain.newmark import NewmarkOptions, integrate

    robot = build_model(SPEC, "gravity", extra_elements=(LoadStiffness(3, 2.0, 1000.0),))
    theta = Q_ARM_FLAT
    lin = linearize(robot, theta)
    modes = lin.modes()
    i3 = int(robot.motion_dofs[2])
    share = np.abs(modes.shapes[i3]) / np.linalg.norm(modes.shapes, axis=0)
    mode = int(np.argmax(share))
    f_ref = float(modes.damped_freq_hz[mode])
    bare = linearize(build_model(SPEC, "gravity"), theta).modes().damped_freq_hz
    assert np.min(np.abs(bare / f_ref - 1)) > 0.05, (bare, f_ref)
    lam = complex(2 * math.pi * (f_ref * 1j - modes.damping_ratio[mode] * modes.freq_hz[mode]))
    phi = modes.shapes[:, mode]
    eps = 1e-5 / float(np.abs(phi[i3]))
    res, tan, _kin, _ = robot_equations(robot, lambda t: theta)
    q_eq = np.asarray(lin.q)
    h = 1.0 / (200 * f_ref)
    t, x = [], []

    def rec(st):
        t.append(st.t_s)
        x.append(float(np.asarray(st.q)[i3] - q_eq[i3]))

    integrate(res, q_eq + eps * np.real(phi), eps * np.real(lam * phi), t0_s=0.0, h_s=h, n_steps=int(0.12 / h),
              tangent=tan, options=NewmarkOptions(atol=1e-14, rtol=1e-10), on_step=rec)
    f_sim = crossing_frequency_hz(t, x)
    assert f_sim == pytest.approx(f_ref, rel=0.01), (f_sim, f_ref)


def test_generator_load_k_equals_the_element():
    # the independent generator (its own pinocchio model and gravity torque) against robolobes' element
    # at the six poses of the identification sets: 1e-9 of the largest |H| (both compute the same
    # linear model; only rounding separates them)
    from generators.tx200 import POSE_OFFSETS_DEG, POSE_TAB7_DEG, TX200, Effects

    f = np.linspace(2.0, 300.0, 300)
    gen = TX200(Effects(load_k=(3, 1.5, 1000.0)))
    own = build_model(SPEC, "basic", extra_elements=(LoadStiffness(3, 1.5, 1000.0),))
    for k in range(len(POSE_OFFSETS_DEG)):
        q = POSE_TAB7_DEG + POSE_OFFSETS_DEG[k]
        Hg, Hr = gen.frf(q, f), linearize(own, np.radians(q)).frf(2 * math.pi * f).H
        assert np.abs(Hg - Hr).max() <= 1e-9 * np.abs(Hr).max(), k


@pytest.mark.parametrize("variant", ["basic", "gravity"])
def test_effect_perturbation_equals_the_element(variant):
    # identify's fast perturbation (K[3, 3] += k3 kappa |tau|) against the element's linearization
    # (same kappa as stiffening at T = 1 kN m), at a set's pose: M, C, K to 1e-9 of the largest entry
    from robolobes.identify.effects import REGISTRY
    from robolobes.identify.structural import LoadKEffect, pose_matrices

    theta = np.radians([-11.71 + 12, 20.78 + 6, -212.14 - 4 + 360, 82.76 + 5, 60.80 + 8, -166.96 - 10])
    pm = pose_matrices(build_model(SPEC, variant), theta)
    effect = REGISTRY["load_k_a3"]
    assert isinstance(effect, LoadKEffect)
    got = effect.perturb(pm, {"stiffening_per_knm": 1.2})
    ref = pose_matrices(build_model(SPEC, variant, extra_elements=(LoadStiffness(3, 1.2, 1000.0),)), theta)
    for a, b in ((got.K, ref.K), (got.M, ref.M), (got.C, ref.C)):
        assert np.abs(a - b).max() <= 1e-9 * np.abs(b).max()
    assert pm.gear_torque_n_m is not None
    assert abs(pm.gear_torque_n_m[2]) == pytest.approx(63.9, abs=0.1)   # generator's pose 1: 63.9 N m


@pytest.mark.parametrize("order", ["load_first", "payload_first"])
def test_effect_composes_with_a_payload_correction(order):
    # a heavier payload loads axis 3's gear more: the element (its torque from the model with the
    # PayloadMass element) against the perturbations applied in either order; K to 1e-9 of its largest
    # entry (the weight's torque dm g J_G,z is exact; the rest is rounding)
    from robolobes.identify.effects import REGISTRY
    from robolobes.identify.structural import LoadKEffect, PayloadMassEffect, pose_matrices
    from robolobes.linearize.extra_elements import PayloadMass

    theta = np.radians([-11.71 + 12, 20.78 + 6, -212.14 - 4, 82.76 + 5, 60.80 + 8, -166.96 - 10])
    load, pay = REGISTRY["load_k_a3"], REGISTRY["payload_mass"]
    assert isinstance(load, LoadKEffect) and isinstance(pay, PayloadMassEffect)
    pm = pose_matrices(build_model(SPEC, "basic"), theta)
    lp, pp = {"stiffening_per_knm": 1.5}, {"mass_scale": 1.25}
    got = pay.perturb(load.perturb(pm, lp), pp) if order == "load_first" else load.perturb(pay.perturb(pm, pp), lp)
    ref = pose_matrices(build_model(SPEC, "basic", extra_elements=(PayloadMass(0.25 * 44.4),
                                                                   LoadStiffness(3, 1.5, 1000.0))), theta)
    assert np.abs(got.K - ref.K).max() <= 1e-9 * np.abs(ref.K).max()
    assert np.abs(got.M - ref.M).max() <= 1e-9 * np.abs(ref.M).max()


def test_robot_with_the_element_pickles_and_keeps_its_gear_torque():
    # maps send built robots to worker processes; the element's per-thread pinocchio workspace is
    # scratch and stays behind. The unpickled robot's gear torque equals the original's (the same
    # pinocchio model and q: bit for bit) and the hand torque (1e-9 relative, as
    # test_added_stiffness_from_the_hand_torque), before and after a second call reuses the workspace.
    import pickle

    robot = build_model(SPEC, "gravity", extra_elements=(LoadStiffness(3, 1.0, 1000.0),))
    back = pickle.loads(pickle.dumps(robot))
    q = np.zeros(robot.model.nq)
    q[np.asarray(robot.motion_dofs)] = Q_ARM_FLAT       # the links at the motor angles (no sag)
    want = _axis3_torque_by_hand()

    def torque(r):
        k = next(i for i, e in enumerate(r.elements) if isinstance(e, LoadStiffness))
        el = r.elements[k]
        assert isinstance(el, LoadStiffness)
        return el.gear_torque(r.element_indices[k], None, q)

    for r in (robot, back):
        first, again = torque(r), torque(r)
        assert first == again
        assert abs(abs(first) / want - 1) < 1e-9, (first, want)
    assert torque(robot) == torque(back)
