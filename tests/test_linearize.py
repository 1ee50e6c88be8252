"""Flexible model, statics, linearization, modes and FRFs (linearize).

References: closed forms for one-joint robots; pinocchio's analytic gravity derivatives against
central finite differences of pinocchio's gravity torque and of an independent numpy potential
energy; modal superposition against the direct solve; Maxwell-Betti reciprocity.
"""

import math
from dataclasses import replace

import numpy as np
import pinocchio as pin
import pytest
from numpy.testing import assert_allclose

from robolobes import cases
from robolobes.core.errors import BadInput
import robolobes.linearize as L
from robolobes.cases.spec import Axis, JointSpec, LinkSpec, PayloadSpec, RobotSpec

SPEC = cases.load_robot("tx200")
TAB7 = SPEC.pose("tab7")


def one_joint_robot(axis: Axis = "z", k=1e5, d=50.0, m=20.0, com=(0.3, 0.1, 0.2), payload_m=5.0):
    """A single revolute joint carrying one link and a payload: closed-form dynamics."""
    links = (LinkSpec("base", 10.0, np.zeros(3), np.array([0, 0, 0.5]), np.eye(3)),
             LinkSpec("link", m, np.array(com), np.array([0.2, 0.0, 0.3]) - np.array(com), np.diag([0.4, 0.5, 0.6])))
    joints = (JointSpec("A1", axis, k, d, np.radians([-180, 180])),)
    payload = PayloadSpec("tool", payload_m, np.array([0.0, 0.0, 0.1]), np.array([0.0, 0.0, 0.25]),
                          np.diag([0.01, 0.01, 0.02]), np.eye(3))
    return RobotSpec("one-joint", links, joints, payload, 9.81, 5e6, 1e3, 1e-4)


def test_one_joint_natural_frequency_and_damping_closed_form():
    # About z through the joint: I = Izz_link + m (x^2 + y^2) + Izz_payload + mp (xp^2 + yp^2),
    # with the link exit (flange) at (0.2, 0, 0.3) and the payload com 0.1 above it.
    # f_n = sqrt(k / I) / 2 pi, zeta = d / (2 sqrt(k I)), TCP stiffness along y = k / r^2 (r = 0.2).
    spec = one_joint_robot()
    robot = L.build_model(spec, "basic")
    lin = L.linearize(robot, np.zeros(1))
    inertia = 0.6 + 20 * (0.3 ** 2 + 0.1 ** 2) + 0.02 + 5 * 0.2 ** 2
    modes = lin.modes()
    assert_allclose(modes.freq_hz[0], math.sqrt(1e5 / inertia) / (2 * math.pi), rtol=1e-12)  # exact algebra
    assert_allclose(modes.damping_ratio[0], 50 / (2 * math.sqrt(1e5 * inertia)), rtol=1e-12)
    assert_allclose(lin.compliance()[1, 1], 0.2 ** 2 / 1e5, rtol=1e-12)
    # single-DOF modal stiffness along y equals the static stiffness k / r^2
    assert_allclose(modes.modal_stiffness_n_per_m[1, 0], 1e5 / 0.2 ** 2, rtol=1e-10)


def test_one_joint_gravity_stiffness_closed_form():
    # Joint about y, link com at horizontal distance x from the axis: gravity torque
    # g(q) = sum m g x_c(q); dg/dq at q = 0 equals -m g z_com (pendulum) for com above the joint.
    spec = one_joint_robot(axis="y", com=(0.0, 0.0, 0.2))
    robot = L.build_model(spec, "gravity")
    # no compensation on this joint (gravity_compensation False): K = k + dg/dq
    q = np.zeros(1)
    dg = pin.computeGeneralizedGravityDerivatives(robot.model, robot.create_data(), q)
    # inverted pendulum: link com 0.2 m above the joint (20 kg), payload com at flange z 0.3 + 0.1
    # and x 0.2: dg/dq = -g (sum m z) at q = 0
    expected = -9.81 * (20 * 0.2 + 5 * 0.4)
    assert_allclose(dg[0, 0], expected, rtol=1e-12)
    assert_allclose(L.linearize(robot, q, q=q).K[0, 0], 1e5 + expected, rtol=1e-12)


@pytest.mark.parametrize("variant", ["gravity", "orthogonal"])
def test_gravity_stiffness_matches_finite_differences(variant, tx200_robot):
    # pinocchio's analytic dg/dq against central differences of g(q), h = 1e-6 rad: truncation
    # error O(h^2 |g'''|) ~ 1e-9 of the entries, round-off ~ 1e-10 |g| / h: 1e-6 relative is safe.
    robot = tx200_robot(variant)
    q = L.equilibrium(robot, TAB7).q
    dg = pin.computeGeneralizedGravityDerivatives(robot.model, robot.create_data(), q)
    h = 1e-6
    fd = np.zeros_like(dg)
    for j in range(robot.nv):
        e = np.zeros(robot.nv)
        e[j] = h
        fd[:, j] = (pin.computeGeneralizedGravity(robot.model, robot.create_data(), q + e)
                    - pin.computeGeneralizedGravity(robot.model, robot.create_data(), q - e)) / (2 * h)
    assert_allclose(dg, fd, atol=1e-6 * np.max(np.abs(dg)))


def _potential_energy_numpy(spec, q):
    """Independent of pinocchio: chain of link frames by hand, V = sum m g z_com."""
    rot = {"x": lambda a: np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]]),
           "y": lambda a: np.array([[math.cos(a), 0, math.sin(a)], [0, 1, 0], [-math.sin(a), 0, math.cos(a)]]),
           "z": lambda a: np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])}
    R, p = np.eye(3), spec.links[0].com_m + spec.links[0].next_joint_m
    V = 0.0
    for i, js in enumerate(spec.joints):
        R = R @ rot[js.axis](q[i])
        link = spec.links[i + 1]
        V += link.mass_kg * spec.gravity_m_per_s2 * (p + R @ link.com_m)[2]
        p = p + R @ (link.com_m + link.next_joint_m)
    V += spec.payload.mass_kg * spec.gravity_m_per_s2 * (p + R @ spec.payload.com_m)[2]
    return V


def test_gravity_torque_matches_independent_potential_energy(tx200_robot):
    # g(q) = dV/dq with V from an independent numpy chain: checks the assembly of masses, centres
    # of mass, joint placements and the payload. Central differences, h = 1e-6: error < 1e-5 N m.
    robot = tx200_robot("gravity")
    rng = np.random.default_rng(1)
    for q in [TAB7] + [rng.uniform(-2, 2, 6) for _ in range(3)]:
        g = pin.computeGeneralizedGravity(robot.model, robot.create_data(), q)
        h = 1e-6
        grad = np.array([(_potential_energy_numpy(SPEC, q + h * e) - _potential_energy_numpy(SPEC, q - h * e)) / (2 * h)
                         for e in np.eye(6)])
        assert_allclose(g, grad, atol=1e-4, rtol=1e-7)


def test_total_moving_mass(tx200_robot):
    # Tab. 4: every link but the fixed base, plus the 44.4 kg payload = 819 kg
    robot = tx200_robot("orthogonal")
    assert_allclose(pin.computeTotalMass(robot.model), 364 + 256 + 99 + 41 + 14 + 0.6 + 44.4, rtol=1e-12)


def test_tab7_tcp_and_tool_axis(tx200_robot):
    # NOTES.md: TCP about (0.794, 0.185, 0.316) m, tool axis vertical. The printed Tab. 7 angles are
    # rounded to 0.01 deg (<= 8.7e-5 rad each); the tool-axis tilt from six rounded angles is at
    # most 6 x 8.7e-5 = 5.2e-4 rad, so (0, 0, -1) holds to that bound, not to 1e-6 (see the
    # kinematics tests for the IK-corrected start pose, vertical to 1e-12).
    p, R = L.tcp_pose(tx200_robot("basic"), L.rigid_q(tx200_robot("basic"), TAB7))
    assert_allclose(p, [0.794, 0.185, 0.316], atol=1e-3)  # "about": three printed decimals
    assert_allclose(R[:, 2], [0, 0, -1], atol=5.2e-4)


@pytest.mark.parametrize("variant", ["basic", "gravity", "orthogonal", "backlash"])
def test_frf_static_limit_and_modal_superposition(variant, tx200_robot):
    lin = L.linearize(tx200_robot(variant), TAB7)
    w = 2 * np.pi * np.concatenate([[0.0], np.geomspace(1, 2000, 200)])
    direct = lin.frf(w).H
    modal = lin.frf(w, method="modal").H
    scale = np.max(np.abs(direct))
    # H(0) = J K^-1 J^T: same linear algebra two ways, round-off only
    assert_allclose(direct[:, :, 0], lin.compliance(), rtol=0, atol=1e-12 * scale)
    # modal superposition over all 2n state-space poles equals the direct solve (exact identity;
    # round-off of the eigen-decomposition ~ cond(V) eps)
    assert_allclose(modal, direct, rtol=0, atol=1e-9 * scale)


@pytest.mark.parametrize("variant", ["basic", "orthogonal"])
def test_reciprocity(variant, tx200_robot):
    # Maxwell-Betti: symmetric M, C, K give H_xy = H_yx. The orthogonal variant includes gravity
    # compensation (non-symmetric K, see the next test), so build it without the compensation.
    robot = tx200_robot(variant)
    if variant == "orthogonal":
        robot = L.model.assemble(SPEC, tuple(e for e in robot.elements if not isinstance(e, L.GravityCompensation)))
    lin = L.linearize(robot, TAB7)
    assert_allclose(lin.K, lin.K.T, rtol=0, atol=1e-9 * np.max(np.abs(lin.K)))
    H = lin.frf(2 * np.pi * np.linspace(0, 300, 301)).H
    assert_allclose(H, np.swapaxes(H, 0, 1), rtol=0, atol=1e-10 * np.max(np.abs(H)))


def test_gravity_compensation_breaks_symmetry_only_slightly(tx200_robot):
    # Cancelling gravity on axes 2, 3, 5 only is not conservative: K is non-symmetric by the
    # off-diagonal gravity terms of those rows, tiny next to the joint stiffness (1e5-1e6 N m/rad).
    lin = L.linearize(tx200_robot("gravity"), TAB7)
    asym = np.max(np.abs(lin.K - lin.K.T)) / np.max(np.abs(lin.K))
    assert 1e-7 < asym < 1e-3


def test_gravity_compensation_cancels_load_on_compensated_axes(tx200_robot):
    # With compensation, axes 2, 3, 5 carry no spring torque at equilibrium (q = theta there),
    # while the uncompensated axes 1, 4, 6 do deflect (eq. 9 and section 2.1.1)
    robot = tx200_robot("gravity")
    eq = L.equilibrium(robot, TAB7)
    d = eq.deflection[robot.motion_dofs]
    assert_allclose(d[[1, 2, 4]], 0, atol=1e-13)
    # A4 carries the gravity moment of the forearm/wrist/spindle (deflection of order 1e-5 rad);
    # A1 is vertical (no gravity torque) and the spindle's centre of mass is only 4 mm off the A6 axis
    assert abs(d[3]) > 1e-5


def test_virtual_joint_stiffness_limit(tx200_robot):
    # As k_v -> inf the 18-DOF model's modes tend to the 6-DOF model's (same gravity and
    # compensation). The virtual springs act in series with the drive: the relative frequency
    # change is of order k_joint / k_v (6e6 / 1e11 = 6e-5) and shrinks like 1/k_v.
    base = L.linearize(tx200_robot("gravity"), TAB7).modes().freq_hz
    errs = []
    for kv in (1e9, 1e11):
        spec = replace(SPEC, orthogonal_stiffness_n_m_per_rad=kv)
        f = L.linearize(L.build_model(spec, "orthogonal"), TAB7).modes().freq_hz[:6]
        errs.append(np.max(np.abs(f - base) / base))
    assert errs[1] < 1e-4
    assert_allclose(errs[0] / errs[1], 100, rtol=0.05)  # first order in 1/k_v


def test_static_deflection_under_tcp_force_matches_compliance(tx200_robot):
    # Nonlinear static equilibrium under a small TCP force vs the linear compliance: equal to
    # O(F^2) (geometric nonlinearity ~ deflection / lever arm ~ 1e-5 relative for 100 N)
    robot = tx200_robot("basic")
    lin = L.linearize(robot, TAB7)
    F = np.array([30.0, -100.0, 50.0])
    eq = L.equilibrium(robot, TAB7, f_tcp=F)
    assert_allclose(eq.tcp_deflection, lin.compliance() @ F, rtol=1e-3, atol=1e-9)


def test_backlash_equilibrium_closed_form_one_joint():
    # One joint about y with a dead zone of half-width s under its gravity torque tau:
    # k dz(q - theta) = tau  =>  q - theta = tau / k + s sign(tau) (exactly, up to the geometric
    # change of tau over the deflection, which Newton resolves; compare with the engaged twin).
    spec = one_joint_robot(axis="y", com=(0.3, 0.0, 0.0))
    els = (L.Payload(spec.payload), L.MotionSprings((1e5,), (50.0,), 1e-4), L.Gravity(9.81))
    robot = L.model.assemble(spec, els)
    eq = L.equilibrium(robot, np.zeros(1))
    eng = L.equilibrium(robot.engaged_twin(), np.array([1e-4 * np.sign(eq.deflection[0])]))
    assert abs(eq.deflection[0]) > 1e-4  # beyond the dead zone
    assert_allclose(eq.q, eng.q, rtol=0, atol=1e-14)
    # static torque balance with the dead zone: k (|delta| - s) = |m g x| (link 20 kg at 0.3 m,
    # payload 5 kg at 0.2 m) to first order in the deflection
    tau = 9.81 * (20 * 0.3 + 5 * 0.2)
    assert_allclose(1e5 * (abs(eq.deflection[0]) - 1e-4), tau, rtol=1e-3)


def test_backlash_equilibrium_tx200_residual_and_side(tx200_robot):
    # The real dead-zone residual is met, and each loaded axis sits beyond the dead zone on the
    # side its load pushes (eq. 12); the compensated axes 2, 3, 5 stay centred.
    bl = tx200_robot("backlash")
    eq = L.equilibrium(bl, TAB7)
    assert eq.residual < 1e-8
    d = eq.deflection[bl.motion_dofs]
    s = SPEC.backlash_half_width_rad
    assert abs(d[3]) > s
    assert_allclose(d[[1, 2, 4]], 0, atol=1e-13)


def test_basic_variant_magnitudes_at_tab7(tx200_robot):
    # Numbers stated in the README (robot modes in the tens of hertz, TCP stiffness of order 1 N/um
    # is what robots of this class show). Values are this model's, rounded as printed there.
    lin = L.linearize(tx200_robot("basic"), TAB7)
    f = lin.modes().freq_hz
    assert_allclose(f[:6], [15.77, 25.15, 27.72, 33.52, 92.73, 142.3], rtol=2e-3)
    assert_allclose(np.diag(lin.stiffness()) / 1e6, [0.966, 2.993, 6.020], rtol=2e-3)


def test_bad_input_errors(tx200_robot):
    robot = tx200_robot("basic")
    with pytest.raises(ValueError, match="unknown model variant 'flexible'"):
        L.build_model(SPEC, "flexible")
    with pytest.raises(ValueError, match=r"theta .* shape \(6,\)"):
        L.linearize(robot, np.zeros(5))
    with pytest.raises(BadInput, match="must be finite"):
        L.linearize(robot, np.array([0, 0, np.nan, 0, 0, 0]))
    lin = L.linearize(robot, TAB7)
    with pytest.raises(ValueError, match="omega_rad_s"):
        lin.frf(np.array([1.0, np.nan]))
    with pytest.raises(ValueError, match="feed direction"):
        lin.frf(np.array([1.0]), frame="cut")
    with pytest.raises(cases.MillingError, match="not perpendicular to the tool axis"):
        lin.frf(np.array([1.0]), frame="cut", feed_direction=[0, 0, 1])


def test_singular_stiffness_reports_clearly():
    # A one-joint robot moves its TCP along one line only: the 3x3 compliance has rank 1
    lin = L.linearize(L.build_model(one_joint_robot(), "basic"), np.zeros(1))
    with pytest.raises(L.SingularConfigurationError, match="singular"):
        lin.stiffness()


def test_control_interop(tx200_robot):
    lin = L.linearize(tx200_robot("basic"), TAB7)
    w = 2 * np.pi * np.array([5.0, 25.0, 60.0])
    frd = lin.frf(w).to_control()
    assert_allclose(frd.frdata if hasattr(frd, "frdata") else frd.fresp, lin.frf(w).H, rtol=1e-14)
    sys = lin.to_control()
    # state-space model evaluated at s = i w equals the direct FRF
    resp = np.stack([sys(1j * wi) for wi in w], axis=-1)
    assert_allclose(resp, lin.frf(w).H, rtol=1e-8)


def test_pass_map_matches_single_pose_linearization(alu_case, tx200_robot):
    # The batched map at s = 0 is the single-pose linearization at the pass start (same code path,
    # stacked): equal to round-off.
    from robolobes.linearize.maps import pass_map
    case = alu_case
    robot = tx200_robot("basic")
    with pytest.warns(L.JointLimitWarning, match=r"A3 .*= -212.14 deg, wrapped to \+147.86 deg"):
        pas = L.Pass.from_case(case)
    m = pass_map(robot, pas, n=3)
    lin = L.linearize(robot, case.path.start_q_rad)
    assert_allclose(m.freq_hz[0], lin.modes().freq_hz, rtol=1e-10)
    assert_allclose(m.tcp_stiffness_n_per_m[0], lin.stiffness(), rtol=1e-8)
    assert m.path_s_m is not None  # a pass map has its path coordinate
    assert_allclose(m.path_s_m, [0, pas.travel_m / 2, pas.travel_m])


def test_grid_map_reports_unreachable_targets(alu_case, tx200_robot):
    from robolobes.linearize.maps import grid_map
    case = alu_case
    robot = tx200_robot("basic")
    p0, R0 = L.fk(case.robot, case.path.start_q_rad)
    pts = np.array([p0, p0 + [3.0, 0, 0]])
    g = grid_map(robot, pts, R0, case.path.start_q_rad)
    assert np.isfinite(g.freq_hz[0]).all() and np.isnan(g.freq_hz[1]).all()
    assert g.failures[0][0] == 1 and "unreachable" in g.failures[0][1]
