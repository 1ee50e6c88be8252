"""Structural effects of the library (FRF-observable): each an :class:`Effect` plus a fast perturbation.

Every effect here is added to the model as an element of :mod:`robolobes.linearize.extra_elements`
(that is what the ``model`` TOML holds, and what the synthetic tests generate data with). For
fitting, each also perturbs the linearized matrices of a pose directly (:meth:`perturb`), which
costs a few microseconds instead of rebuilding and re-linearizing the pinocchio model:

* ``tcp_mode`` (the element :meth:`linearize.tool.TcpOscillator.one_axis`): one coordinate ``u``
  more, the mass ``m = k / w0^2`` at the TCP moving ``J dq + d u`` (``d`` the mode direction in
  base axes), taken from the payload at the TCP (moving ``J dq``): ``M' = [[M, m J^T d], [m d^T J, m]]``,
  ``K' = diag(K, k)``, ``C' = diag(C, c)``, TCP output ``[J, d]`` (exact to first order: the
  element's pinocchio model gives the same M, C, K up to the gravity load of the small mass);
* ``joint_correction_aN``: ``K[i, i] += (s_k - 1) k_N``, ``C[i, i] += (s_d - 1) d_N`` (exact);
* ``orthogonal_correction``: the same on every virtual joint (exact);
* ``servo_aN``: one rotor coordinate more, ``M[n, n] = J``, ``C[n, n] = kd``, ``K[n, n] = k + kp``,
  ``K[i, n] = K[n, i] = -k`` (exact);
* ``payload_mass``: ``M += dm J_G^T J_G`` with ``J_G`` the translational Jacobian of the payload's
  centre of mass (exact for the basic variant; with gravity the small change of the gravity
  stiffness is neglected);
* ``load_k_aN``: ``K[i, i] += k_N kappa |tau_N|``, ``tau_N`` the gear's static gravity torque at the
  pose (``PoseMatrices.gear_torque_n_m``; exact below the element's reference torque); a
  ``payload_mass`` correction adds its weight to the gear torques and moves that stiffness with
  them, in either order (exact);
* ``mount_z``: one coordinate more, the base's vertical translation, coupled to the others through
  the robot's momentum Jacobian (:class:`MountZEffect`);
* ``mount_rock``: two coordinates more, the base's rocking about base x and y, coupled to the others
  through the robot's angular momentum about the base origin (:class:`MountRockEffect`).

The consistency of each perturbation with its element is tested (tests/test_identify_frf.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from robolobes.cases.spec import ElementSpec

from .effects import Effect, ModelState, Parameter, check_params, register

__all__ = ["PoseMatrices", "StructuralEffect", "TcpModeEffect", "JointCorrectionEffect",
           "OrthogonalCorrectionEffect", "PayloadMassEffect", "ServoEffect", "MountZEffect", "MountRockEffect", "LoadKEffect",
           "pose_matrices"]


@dataclass(frozen=True)
class PoseMatrices:
    """The linearized model at one pose, with what the perturbations need.

    Attributes
    ----------
    M, C, K : array (n, n), SI
    J : array (3, n), m/rad, TCP translation in base axes
    R_tcp : array (3, 3), columns the TCP axes in base coordinates
    motion_dofs : array (n_joints,) of int
    virtual_dofs : array of int (empty without virtual joints)
    joint_k, joint_d : array (n_joints,), the joint table's stiffness and damping
    virtual_k, virtual_d : float, the virtual joints' stiffness and damping (0 without)
    J_payload : array (3, n), translational Jacobian of the payload centre of mass, base axes
    payload_mass_kg : float
    momentum_jacobian : array (3, n), kg m/rad, or None
        ``sum_i m_i J_G,i``: the robot's linear momentum per unit of each coordinate's velocity, base
        axes (total moving mass times the centre-of-mass Jacobian); what couples a base translation in
        (:class:`MountZEffect`)
    mount_mass_kg : float
        Mass the mount carries: every body of the model plus the base link, kg.
    angular_momentum_jacobian : array (3, n), kg m^2/rad, or None
        The robot's angular momentum about the base frame's origin per unit of each coordinate's
        velocity, base axes (what couples a rocking of the base in, :class:`MountRockEffect`).
    mount_first_moment_kg_m : array (3,) or None
        ``sum_i m_i c_i`` of the mass on the mount (base link included), base frame, kg m.
    mount_inertia_kg_m2 : array (3, 3) or None
        Inertia of the mass on the mount about the base frame's origin, base axes, kg m^2.
    payload_com_m : array (3,) or None
        The payload's centre of mass in the base frame, m (a payload correction's point mass).
    tcp_m : array (3,) or None
        The TCP's position in the base frame, m (a rocking moves it ``e x p``).
    gear_torque_n_m : array (n_joints,) or None
        The static gravity torque on each motion axis at the pose, N m (g = 9.81 m/s^2 even when the
        variant's dynamics omit gravity: what the gears carry, :class:`LoadKEffect`).
    load_slope_per_knm : array (n_joints,) or None
        The load laws already applied (:class:`LoadKEffect`, per kN m): a payload correction applied
        after them updates their stiffness with the torque it adds.
    """

    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    J: np.ndarray
    R_tcp: np.ndarray
    motion_dofs: np.ndarray
    virtual_dofs: np.ndarray
    joint_k: np.ndarray
    joint_d: np.ndarray
    virtual_k: float
    virtual_d: float
    J_payload: np.ndarray
    payload_mass_kg: float
    momentum_jacobian: np.ndarray | None = None
    mount_mass_kg: float = 0.0
    angular_momentum_jacobian: np.ndarray | None = None
    mount_first_moment_kg_m: np.ndarray | None = None
    mount_inertia_kg_m2: np.ndarray | None = None
    payload_com_m: np.ndarray | None = None
    tcp_m: np.ndarray | None = None
    gear_torque_n_m: np.ndarray | None = None
    load_slope_per_knm: np.ndarray | None = None


def pose_matrices(robot, theta: np.ndarray) -> PoseMatrices:
    """Linearize ``robot`` (a FlexibleRobot) at motor angles ``theta`` (rad) into :class:`PoseMatrices`."""
    import pinocchio as pin

    from robolobes.linearize import linearize
    from robolobes.linearize.base_elements import VirtualJoints, virtual_dofs

    lin = linearize(robot, theta)
    data = robot.create_data()
    spec = robot.spec
    vj = [e for e in robot.elements if isinstance(e, VirtualJoints)]
    # payload centre of mass: flange frame origin + R_flange com (point velocity v + w x r)
    pin.computeJointJacobians(robot.model, data, np.asarray(lin.q))
    pin.framesForwardKinematics(robot.model, data, np.asarray(lin.q))
    Jf = pin.getFrameJacobian(robot.model, data, robot.flange_frame, pin.LOCAL_WORLD_ALIGNED)
    Rf = data.oMf[robot.flange_frame].rotation
    r = Rf @ np.asarray(spec.payload.com_m)
    skew = np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])
    J_payload = Jf[:3] - skew @ Jf[3:]
    Jcom = pin.jacobianCenterOfMass(robot.model, data, np.asarray(lin.q))
    moving = float(data.mass[0])
    mounted = _mounted_mass_kg(robot, moving)
    L_origin, first, inertia = _mount_rotation_terms(robot, data, np.asarray(lin.q), moving * np.asarray(Jcom))
    return PoseMatrices(M=np.asarray(lin.M), C=np.asarray(lin.C), K=np.asarray(lin.K), J=np.asarray(lin.J),
                        R_tcp=np.asarray(lin.R_tcp), motion_dofs=np.asarray(robot.motion_dofs),
                        virtual_dofs=virtual_dofs(robot.model) if vj else np.zeros(0, dtype=int),
                        joint_k=spec.joint_stiffness, joint_d=spec.joint_damping,
                        virtual_k=vj[0].stiffness if vj else 0.0, virtual_d=vj[0].damping if vj else 0.0,
                        J_payload=J_payload, payload_mass_kg=spec.payload.mass_kg,
                        momentum_jacobian=moving * np.asarray(Jcom), mount_mass_kg=mounted,
                        angular_momentum_jacobian=L_origin, mount_first_moment_kg_m=first,
                        mount_inertia_kg_m2=inertia, payload_com_m=data.oMf[robot.flange_frame].translation + r,
                        tcp_m=np.asarray(lin.p_tcp),
                        gear_torque_n_m=_gear_torque(robot, np.asarray(lin.q)))


def _skew(r: np.ndarray) -> np.ndarray:
    """``[r]x`` (3, 3): ``_skew(r) @ v = r x v``."""
    return np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])


def _mount_rotation_terms(robot, data, q: np.ndarray, P: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """What a rocking of the base couples to, at link angles ``q`` (nq,) (``data``'s kinematics at
    ``q``; ``P`` (3, n) the momentum Jacobian): the angular momentum Jacobian about the base origin
    (3, n), kg m^2/rad; the first moment ``sum m c`` (3,), kg m, and the inertia about the origin
    (3, 3), kg m^2, of the mass on the mount (every body plus the base link unless it already rides on
    a mount), base axes. ``L_O = h_G + c x P``: pinocchio's centroidal map about the moving bodies'
    centre of mass ``c``, moved to the origin."""
    import pinocchio as pin

    from robolobes.linearize.extra_elements import MountCompliance
    from robolobes.linearize.model import base_inertia

    Ag = np.asarray(pin.computeCentroidalMap(robot.model, data, q))
    c = np.asarray(data.com[0])
    L_origin = Ag[3:] + _skew(c) @ P
    total = pin.Inertia.Zero()
    for i in range(1, robot.model.njoints):
        total = total + data.oMi[i].act(robot.model.inertias[i])
    if not any(isinstance(e, MountCompliance) and e.axes for e in robot.elements):
        total = total + base_inertia(robot.spec)
    m, g = float(total.mass), np.asarray(total.lever)
    inertia = np.asarray(total.inertia) + m * (float(g @ g) * np.eye(3) - np.outer(g, g))
    return L_origin, m * g, inertia


def _gear_torque(robot, q: np.ndarray) -> np.ndarray:
    """Static gravity torque (n_joints,), N m, on each motion axis at link angles ``q`` (nq,), with
    g = 9.81 m/s^2 along base -z (a copy of the model with gravity on)."""
    import pinocchio as pin

    m = pin.Model(robot.model)
    m.gravity = pin.Motion(np.array([0.0, 0.0, -GRAVITY_M_PER_S2]), np.zeros(3))
    return np.asarray(pin.computeGeneralizedGravity(m, m.createData(), q))[np.asarray(robot.motion_dofs)]


def _mounted_mass_kg(robot, moving_kg: float) -> float:
    """Mass on the mount, kg: the moving bodies plus the base link, unless the base already rides on a
    mount (then it is among the moving bodies)."""
    from robolobes.linearize.extra_elements import MountCompliance
    from robolobes.linearize.model import base_inertia

    on_mount = any(isinstance(e, MountCompliance) and e.axes for e in robot.elements)
    return moving_kg if on_mount else moving_kg + float(base_inertia(robot.spec).mass)


GRAVITY_M_PER_S2 = 9.81     # the field the gears carry (LoadKEffect, PayloadMassEffect)
#: Reference torque the load effect writes into its ``load_stiffness`` table, N m: the stiffening
#: ``kappa`` per kN m is the element's ``stiffening`` at this torque (no pose of a hammer test on the
#: TX200 loads axes 3-5 beyond 0.3 kN m, so the law is linear over the data).
LOAD_K_REFERENCE_N_M = 1000.0


def _load_fraction(tau_n_m: np.ndarray) -> np.ndarray:
    """``min(|tau| / T, 1)`` with ``T = LOAD_K_REFERENCE_N_M`` (the element's law), per axis."""
    return np.minimum(np.abs(tau_n_m) / LOAD_K_REFERENCE_N_M, 1.0)


def _reloaded(pm: PoseMatrices, tau_n_m: np.ndarray) -> PoseMatrices:
    """``pm`` with the gear torques ``tau_n_m`` (n_joints,), N m: the stiffness of every load law
    already applied moves with them (``k0 kappa`` times the change of the load fraction)."""
    out = replace(pm, gear_torque_n_m=tau_n_m)
    if pm.load_slope_per_knm is None or pm.gear_torque_n_m is None:
        return out
    K = pm.K.copy()
    dk = pm.joint_k * pm.load_slope_per_knm * (_load_fraction(tau_n_m) - _load_fraction(pm.gear_torque_n_m))
    K[pm.motion_dofs, pm.motion_dofs] += dk
    return replace(out, K=K)


def _bordered(A: np.ndarray, corner: float) -> np.ndarray:
    """``A`` (n, n) grown by one coordinate: (n + 1, n + 1), zeros in the new row and column except
    ``corner`` on the diagonal."""
    n = A.shape[0]
    out = np.zeros((n + 1, n + 1))
    out[:n, :n] = A
    out[n, n] = corner
    return out


class StructuralEffect(Effect):
    """An element effect with a fast perturbation of the linearized matrices."""

    stage = "element"


    def detect_limits(self, poses) -> dict:
        """The data's own limits of the parameters without a neutral value, ``{name: value}`` (their
        units), for the FRF poses ``poses`` (list of ``PoseData``); ``{}``: each parameter's ``detect``."""
        return {}
    def perturb(self, pm: PoseMatrices, params: dict) -> PoseMatrices:
        """The pose's matrices with the effect added (effects compose: apply one after the other)."""
        raise NotImplementedError

    def guesses(self, diagnosis: dict) -> list[dict]:
        """Start points for the fit (default: the neutral values, else the middle of the bounds)."""
        return [{p.name: (p.neutral if p.neutral is not None else
                          (math.sqrt(p.lower * p.upper) if p.log else 0.5 * (p.lower + p.upper)))
                 for p in self.parameters}]


def _padded(A: np.ndarray, n: int) -> np.ndarray:
    """``A`` (3, m <= n) with zero columns appended to (3, n)."""
    return np.hstack([A, np.zeros((A.shape[0], n - A.shape[1]))]) if A.shape[1] < n else A


def _direction(polar_rad: float, azimuth_rad: float) -> np.ndarray:
    return np.array([math.sin(polar_rad) * math.cos(azimuth_rad), math.sin(polar_rad) * math.sin(azimuth_rad),
                     math.cos(polar_rad)])


class TcpModeEffect(StructuralEffect):
    name = "tcp_mode"
    repeatable = True   # a holder has a mode in each radial direction, a spindle more than one
    doc = ("A spindle / tool-holder mode at the TCP: an oscillator (frequency, damping ratio, stiffness) "
           "along a direction fixed in the tool frame (polar angle from the tool axis, azimuth from TCP x).")
    parameters = (
        Parameter("freq_hz", 20.0, 3000.0, None, None, log=True, doc="natural frequency on a fixed base"),
        Parameter("damping_ratio", 0.003, 0.3, None, None, log=True, plausible=(0.003, 0.15),
                  doc="spindle / tool-holder modes: 1-10 % (Schmitz & Smith); above 15 % not a holder mode"),
        Parameter("stiffness_n_per_m", 1e4, 1e9, None, None, log=True,
                  doc="detectable when 1 / (2 zeta k) exceeds the robot's receptance at freq_hz by the noise"),
        # a direction's angles: the ends of their ranges are not physical bounds (d and -d are the same
        # mode, the azimuth wraps), so a value there is not "on a bound" (identify.evidence)
        Parameter("polar_rad", 0.0, math.pi, periodic=True, doc="direction: angle from the tool axis (TCP z)"),
        Parameter("azimuth_rad", -math.pi, math.pi, periodic=True,
                  doc="direction: angle about the tool axis from TCP x"),
    )
    observed_by = {"frf": "an extra peak, same frequency at every pose: 1 / (2 zeta k) above ~3x the noise of "
                          "the measured receptance at that frequency",
                   "stability": "shifts the lobes near its frequency"}
    # its stiffness k is in series with the robot: 1/k more compliance on the quasi-static lines
    signatures = ("extra_peak", "static_offset")

    def element_specs(self, model, params):
        """The ``tcp_mode`` element (built by :meth:`linearize.tool.TcpOscillator.one_axis`)."""
        return (ElementSpec("tcp_mode", {"freq_hz": float(params["freq_hz"]),
                                         "damping_ratio": float(params["damping_ratio"]),
                                         "stiffness_n_per_m": float(params["stiffness_n_per_m"]),
                                         "direction": self.direction_tcp(params)}),)

    @staticmethod
    def direction_tcp(params) -> list[float]:
        """The mode's unit direction (3,) in the TCP frame, from ``polar_rad`` and ``azimuth_rad``."""
        return [float(x) for x in _direction(params["polar_rad"], params["azimuth_rad"])]

    def perturb(self, pm, params):
        k = params["stiffness_n_per_m"]
        m = k / (2 * math.pi * params["freq_hz"]) ** 2
        c = 2 * params["damping_ratio"] * math.sqrt(k * m)
        d = pm.R_tcp @ _direction(params["polar_rad"], params["azimuth_rad"])
        n = pm.M.shape[0]
        Jd = pm.J.T @ d
        M = _bordered(pm.M, m)               # + m J^T J (mode body) - m J^T J (taken from the payload)
        M[:n, n] = M[n, :n] = m * Jd
        C, K = _bordered(pm.C, c), _bordered(pm.K, k)
        return replace(pm, M=M, C=C, K=K, J=np.hstack([pm.J, d[:, None]]),
                       J_payload=np.hstack([pm.J_payload, np.zeros((3, 1))]))

    def guesses(self, diagnosis):
        """Starts from the measured poles: every peak of the current residual (``residual_peaks``:
        frequency and amplitude, :func:`identify.frf.diagnose`) and the model-ratio peak, each along
        TCP x, y, z and the residual's rank-one direction; ``fit`` optimizes from the cheapest two."""
        peaks = list(diagnosis.get("residual_peaks") or [])
        f = diagnosis.get("extra_peak_hz")
        if f:
            peaks.append((f, diagnosis.get("extra_peak_m_per_n")))
        if not peaks:
            return []
        zeta = 0.03
        dirs = [(0.5 * math.pi, 0.0), (0.5 * math.pi, 0.5 * math.pi), (0.0, 0.0)]   # TCP x, y, z
        d = diagnosis.get("extra_peak_direction_tcp")
        if d is not None:     # from the residual's rank-one shape at the peak
            dirs.append((math.acos(max(-1.0, min(1.0, d[2]))), math.atan2(d[1], d[0])))
        out = []
        for fp, amp in peaks:
            fp = float(np.clip(fp, self.parameters[0].lower, self.parameters[0].upper))
            k = float(np.clip(1.0 / (2 * zeta * amp), 1e4, 1e9)) if amp else 1e6
            out += [{"freq_hz": fp, "damping_ratio": zeta, "stiffness_n_per_m": k, "polar_rad": p, "azimuth_rad": a}
                    for p, a in dirs]
        return out


class JointCorrectionEffect(StructuralEffect):
    stage = "element"
    observed_by = {"frf": "the robot's peaks shifted or reshaped in a pose-dependent way: stiffness off by "
                          ">~10 % or damping off by >~30 % on an axis that moves the TCP",
                   "stability": "moves the robot's lobes"}
    signatures = ("pose_shift", "peak_height", "static_offset")

    def __init__(self, joint: int):
        self.joint = joint
        self.name = f"joint_correction_a{joint}"
        self.doc = f"axis {joint}: motion-axis stiffness and damping scaled"
        self.parameters = (
            Parameter("stiffness_scale", 0.4, 2.5, neutral=1.0, detect=0.1, log=True),
            Parameter("damping_scale", 0.2, 5.0, neutral=1.0, detect=0.3, log=True),
        )

    def static_stiffness_scale(self, params) -> float:
        """The axis's static stiffness over the joint table's (what a joint correction and a servo share)."""
        return float(params["stiffness_scale"])

    def guesses(self, diagnosis):
        # a scan of the stiffness: a mode shifted by more than its bandwidth is a local minimum
        # of the least squares from the neutral start
        return [{"stiffness_scale": s, "damping_scale": 1.0} for s in (0.5, 0.7, 0.85, 1.0, 1.2, 1.5, 2.0)]

    def element_specs(self, model, params):
        return (ElementSpec("joint_correction", {"joint": self.joint, "stiffness_scale": float(params["stiffness_scale"]),
                                                 "damping_scale": float(params["damping_scale"])}),)

    def perturb(self, pm, params):
        i = pm.motion_dofs[self.joint - 1]
        K, C = pm.K.copy(), pm.C.copy()
        K[i, i] += (params["stiffness_scale"] - 1) * pm.joint_k[self.joint - 1]
        C[i, i] += (params["damping_scale"] - 1) * pm.joint_d[self.joint - 1]
        return replace(pm, C=C, K=K)

    def applicable(self, model: ModelState) -> bool:
        return self.joint <= model.case.robot.n_joints


class OrthogonalCorrectionEffect(StructuralEffect):
    name = "orthogonal_correction"
    doc = "virtual-joint (orthogonal) stiffness and damping scaled; needs the orthogonal or backlash variant"
    parameters = (Parameter("stiffness_scale", 0.2, 5.0, neutral=1.0, detect=0.3, log=True),
                  Parameter("damping_scale", 0.2, 5.0, neutral=1.0, detect=0.5, log=True))
    observed_by = {"frf": "the 18-DOF model's upper modes shifted at every pose (stiffness off by >~30 %)"}
    signatures = ("uniform_shift", "pose_shift")

    def applicable(self, model: ModelState) -> bool:
        return model.variant in ("orthogonal", "backlash")

    def guesses(self, diagnosis):
        return [{"stiffness_scale": s, "damping_scale": 1.0} for s in (0.3, 0.5, 0.7, 1.0, 1.5, 2.2, 3.5)]

    def perturb(self, pm, params):
        v = pm.virtual_dofs
        K, C = pm.K.copy(), pm.C.copy()
        K[v, v] += (params["stiffness_scale"] - 1) * pm.virtual_k
        C[v, v] += (params["damping_scale"] - 1) * pm.virtual_d
        return replace(pm, C=C, K=K)


class PayloadMassEffect(StructuralEffect):
    name = "payload_mass"
    doc = "the payload (spindle) mass off by a factor, the difference a point mass at its centre of mass"
    parameters = (Parameter("mass_scale", 0.6, 1.5, neutral=1.0, detect=0.08),)
    observed_by = {"frf": "every robot peak shifted down (heavier) or up (lighter) by about the same ratio, "
                          "mass off by >~8 %"}
    signatures = ("uniform_shift",)

    def element_specs(self, model, params):
        """A point mass ``(mass_scale - 1) m_payload`` at the payload's centre of mass (``payload_mass``)."""
        dm = (params["mass_scale"] - 1) * model.case.robot.payload.mass_kg
        return (ElementSpec("payload_mass", {"delta_mass_kg": float(dm)}),)

    def guesses(self, diagnosis):
        return [{"mass_scale": s} for s in (0.7, 0.85, 1.0, 1.2, 1.4)]

    def perturb(self, pm, params):
        dm = (params["mass_scale"] - 1) * pm.payload_mass_kg
        out = replace(pm, M=pm.M + dm * pm.J_payload.T @ pm.J_payload, mount_mass_kg=pm.mount_mass_kg + dm)
        if pm.gear_torque_n_m is not None:       # its weight on the gears: g += dm g0 J_G,z (motion axes)
            out = _reloaded(out, pm.gear_torque_n_m + dm * GRAVITY_M_PER_S2 * pm.J_payload[2, pm.motion_dofs])
        if pm.momentum_jacobian is not None:     # the point mass's momentum (a mount sees it)
            n = pm.M.shape[0]
            out = replace(out, momentum_jacobian=_padded(pm.momentum_jacobian, n) + dm * _padded(pm.J_payload, n))
        if pm.angular_momentum_jacobian is not None and pm.payload_com_m is not None \
                and pm.mount_first_moment_kg_m is not None and pm.mount_inertia_kg_m2 is not None:
            p, n = pm.payload_com_m, pm.M.shape[0]     # the point mass about the base origin (a rocking sees it)
            out = replace(out, angular_momentum_jacobian=_padded(pm.angular_momentum_jacobian, n)
                          + dm * _skew(p) @ _padded(pm.J_payload, n),
                          mount_first_moment_kg_m=pm.mount_first_moment_kg_m + dm * p,
                          mount_inertia_kg_m2=pm.mount_inertia_kg_m2 + dm * (float(p @ p) * np.eye(3) - np.outer(p, p)))
        return out


class ServoEffect(StructuralEffect):
    """Servo dynamics of axis ``joint``: the rotor (reflected inertia ``J``) held by a PD position loop
    (``kp``, ``kd``) behind the joint spring ``k`` (element :class:`~robolobes.linearize.extra_elements.ServoDrive`).

    Parameters are the loop's physics, relative to the axis (so one set of bounds fits every axis):
    ``kp_scale = kp / k``, the rotor's natural frequency against a locked link
    ``rotor_freq_hz = sqrt((k + kp) / J) / 2 pi`` and its damping ratio
    ``rotor_damping_ratio = kd / (2 sqrt((k + kp) J))``. The element's ``J, kp, kd`` follow from them
    and the joint table's ``k``.

    Detection threshold (derived from the axis's dynamic stiffness, not tuned): seen from the link,
    the servo puts the loop in series with the joint spring,
    ``k_eff(w) = k (kp - J w^2 + i w kd) / (k + kp - J w^2 + i w kd)``.

    * Against the model without it: the static stiffness ``k kp / (k + kp)`` differs from ``k`` by
      ``k / (k + kp)``; this must exceed the 10 % stiffness a joint correction needs
      (``joint_correction_aN`` ``detect``): ``kp_scale <= 9`` ("kp within ~10x the joint stiffness").
    * Against a joint correction (a constant stiffness scale, which mimics any static softening):
      only the frequency dependence of ``k_eff`` tells a servo apart. Undamped, between 0 and the
      axis's dominant robot mode ``f_r`` it changes by
      ``delta = (1 / kp_scale) x / (1 - x)``, ``x = (f_r / rotor_freq_hz)^2``; the same 10 %:
      ``|delta| >= 0.1``, i.e. the rotor mode within ``f_r / sqrt(x_t)`` with
      ``x_t = 0.1 kp_scale / (1 + 0.1 kp_scale)`` (for ``kp_scale = 1``: below 3.3 f_r). Above it the
      servo is a joint correction to within the noise, and either may be reported.
    """

    observed_by = {"frf": "static: kp <= 9 k (the axis 10 % softer, as a joint correction); told apart from a "
                          "joint correction when the axis's dynamic stiffness at its dominant robot mode f_r differs "
                          "from the static one by >= 10 %: |(k / kp) x / (1 - x)| >= 0.1, x = (f_r / rotor_freq_hz)^2"}
    # a softer axis statically (k kp / (k + kp)) and reshaped, pose-dependent robot modes; its rotor
    # mode's frequency and height move with the pose (the axis's participation), so it is not the
    # "extra_peak" signature (same frequency in every pose: a tool-holder mode)
    signatures = ("pose_shift", "peak_height", "static_offset")

    def __init__(self, joint: int):
        self.joint = joint
        self.name = f"servo_a{joint}"
        self.doc = (f"axis {joint}: rotor inertia and PD position loop behind the joint spring (kp = kp_scale k, "
                    "rotor frequency against a locked link, its damping ratio)")
        self.parameters = (
            Parameter("kp_scale", 0.05, 100.0, detect=9.0, log=True,
                      doc="position-loop stiffness / joint stiffness (link side); seen when <= 9"),
            Parameter("rotor_freq_hz", 5.0, 3000.0, log=True, doc="sqrt((k + kp) / J) / 2 pi"),
            Parameter("rotor_damping_ratio", 0.005, 2.0, log=True, doc="kd / (2 sqrt((k + kp) J))"))

    def static_stiffness_scale(self, params) -> float:
        """The axis's static stiffness over the joint table's: the loop in series with the spring,
        ``kp / (k + kp) = kp_scale / (1 + kp_scale)``."""
        return float(params["kp_scale"] / (1.0 + params["kp_scale"]))

    @staticmethod
    def physical(k: float, params) -> tuple[float, float, float]:
        """``(J kg m^2, kp N m/rad, kd N m s/rad)`` from the effect's parameters and the joint stiffness ``k``."""
        kp = params["kp_scale"] * k
        J = (k + kp) / (2 * math.pi * params["rotor_freq_hz"]) ** 2
        kd = 2 * params["rotor_damping_ratio"] * math.sqrt((k + kp) * J)
        return J, kp, kd

    def element_specs(self, model, params):
        """The ``servo_drive`` element in SI, from the parameters and the model's joint stiffness."""
        J, kp, kd = self.physical(model.case.robot.joints[self.joint - 1].stiffness_n_m_per_rad, params)
        return (ElementSpec("servo_drive", {"joint": self.joint, "rotor_inertia_kg_m2": J,
                                            "kp_n_m_per_rad": kp, "kd_n_m_s_per_rad": kd}),)

    def applicable(self, model: ModelState) -> bool:
        return self.joint <= model.case.robot.n_joints

    def guesses(self, diagnosis):
        # a scan: the rotor mode is a local minimum of the least squares away from its frequency;
        # fit() optimizes from the two starts with the lowest cost
        return [{"kp_scale": s, "rotor_freq_hz": f, "rotor_damping_ratio": 0.1}
                for s in (0.5, 2.0) for f in (20.0, 40.0, 80.0, 160.0, 320.0)]

    def perturb(self, pm, params):
        i, n = pm.motion_dofs[self.joint - 1], pm.M.shape[0]
        k = pm.joint_k[self.joint - 1]
        J, kp, kd = self.physical(k, params)
        M, C, K = _bordered(pm.M, J), _bordered(pm.C, kd), _bordered(pm.K, k + kp)
        K[i, n] = K[n, i] = -k
        z = np.zeros((3, 1))
        return replace(pm, M=M, C=C, K=K, J=np.hstack([pm.J, z]), J_payload=np.hstack([pm.J_payload, z]))


register(TcpModeEffect())
for _j in range(1, 7):
    register(JointCorrectionEffect(_j))
register(OrthogonalCorrectionEffect())
register(PayloadMassEffect())
for _j in range(1, 7):
    register(ServoEffect(_j))


def _with_mount(model: ModelState, spec: ElementSpec) -> ModelState:
    """``model`` with the ``mount_compliance`` keys of ``spec`` merged into the mount identification
    already added (a robot has one mount element: ``mount_z`` and ``mount_rock`` share it), else with
    ``spec`` added."""
    for i, e in enumerate(model.elements):
        if e.type == "mount_compliance":
            merged = ElementSpec("mount_compliance", {**e.params, **spec.params})
            return replace(model, elements=model.elements[:i] + (merged,) + model.elements[i + 1:])
    return model.with_element(spec)


MOUNT_Z_DETECT_N_PER_M = 3.7e9


class _MountEffect(StructuralEffect):
    """What the mount's effects share: one ``mount_compliance`` element per robot, offered only to a
    model without one, and extended by each mount effect found (``mount_z`` and ``mount_rock`` found
    together share it)."""

    def applicable(self, model: ModelState) -> bool:
        specs = tuple(model.elements) + tuple(model.case.robot.elements or ())
        return not any(e.type == "mount_compliance" for e in specs)

    def apply(self, model: ModelState, params) -> ModelState:
        """``model`` with the mount's keys added to its one ``mount_compliance`` element (``mount_z``
        and ``mount_rock`` found together share it)."""
        params = check_params(self, params)
        for spec in self.element_specs(model, params):
            model = _with_mount(model, spec)
        return model


class MountZEffect(_MountEffect):
    """The robot's base on a vertical spring and damper (element
    :class:`~robolobes.linearize.extra_elements.MountCompliance`, ``kz_n_per_m`` and ``cz_n_s_per_m``).

    Parameters: the stiffness ``k`` and the damping ratio of the whole robot on it,
    ``zeta = c / (2 sqrt(k M))``, ``M`` the mass the mount carries (every link and the payload:
    1045 kg on the TX200); the mode of the rigid robot on it is ``sqrt(k / M) / 2 pi``.

    Perturbation (exact for the model alone and with joint, servo, orthogonal and payload
    corrections): one coordinate ``u`` more, the base's vertical translation, which moves every body
    by ``u e_z``: ``M' = [[M, p_z^T], [p_z, M_mount]]`` with ``p_z`` the z row of the momentum
    Jacobian ``sum_i m_i J_G,i``; ``K' = diag(K, k)``, ``C' = diag(C, c)``; the TCP and the payload's
    centre of mass move ``e_z`` per unit ``u``. Gravity adds no stiffness to a translation. A tool
    mode's small mass (< 0.5 kg of 1045) is not coupled to ``u`` (a relative error below 5e-4).

    Detection threshold (derived as the tool mode's): the mount's mode, about ``f_m = sqrt(k / M) / 2 pi``,
    adds a peak ``~1 / (2 zeta k)`` to ``H_zz``; it is seen when that is above ~3x the noise of the
    measured receptance there (3 % noise: 9 % of ``|H_zz|``) and ``f_m`` lies in the measured band.
    On the TX200 sets (2-300 Hz, zeta 0.05) the ratio ``1 / (2 zeta k |H_zz(f_m)|)`` of the
    independent generator's robot is 0.06-0.63 over the six poses for ``f_m`` from 20 to 300 Hz (2-3.8
    at 10 Hz), the largest of the six at least 0.27, 3x the 9 %: the band decides,
    ``k <= M (2 pi 300 Hz)^2 = 3.7e9 N/m``
    (``detect``). Statically the mount adds ``1 / k``, 10 % of the TCP's vertical compliance only for
    ``f_m`` below ~20 Hz: the peak, not the static offset, is what shows a stiffer mount.
    """

    name = "mount_z"
    doc = ("the robot's base on a vertical spring and damper (its floor, anchoring or frame): stiffness and the "
           "damping ratio of the whole robot on it")
    parameters = (
        Parameter("stiffness_n_per_m", 1e6, 1e10, None, MOUNT_Z_DETECT_N_PER_M, log=True,
                  doc="a robot on isolators 1e6-1e7 (the 1045 kg TX200 at 5-15 Hz), anchored on concrete "
                      "1e8-1e9, a steel block 1e10; seen when <= 3.7e9 (its mode inside a 300 Hz band)"),
        Parameter("damping_ratio", 0.003, 0.5, None, None, log=True, plausible=(0.003, 0.3),
                  doc="anchoring and floors: 1-10 %; grout or elastomer pads up to 30 %"),
    )
    observed_by = {"frf": "a peak of the robot bouncing on its base, about sqrt(k / M_total) / 2 pi, mostly in "
                          "H_zz: 1 / (2 zeta k) above ~3x the noise of the measured receptance there, and that "
                          "frequency inside the measured band (TX200, 2-300 Hz: k <= 3.7e9 N/m)",
                   "stability": "shifts the lobes near its frequency"}
    signatures = ("extra_peak", "static_offset")


    @staticmethod
    def damping(params, mass_kg: float) -> float:
        """``c = 2 zeta sqrt(k M)``, N s/m, for the mass ``mass_kg`` on the mount."""
        return 2 * params["damping_ratio"] * math.sqrt(params["stiffness_n_per_m"] * mass_kg)

    def detect_limits(self, poses) -> dict:
        """``k <= M (2 pi f_max)^2``, N/m: the mount's mode inside the set's band (class doc), with ``M``
        the mass on the mount (``pm.mount_mass_kg``, kg) and ``f_max`` the highest measured line (Hz) of
        ``poses``; 3.7e9 for the TX200's 1045 kg and 300 Hz."""
        mass = float(poses[0].pm.mount_mass_kg)
        w_max = max(float(np.max(pd.omega)) for pd in poses)
        return {"stiffness_n_per_m": mass * w_max ** 2}

    def element_specs(self, model, params):
        """The ``mount_compliance`` element (z only): ``kz`` and ``cz = 2 zeta sqrt(kz M)``, ``M`` the
        mass of ``model``'s robot on the mount."""
        c = self.damping(params, _state_mass_kg(model))
        return (ElementSpec("mount_compliance", {"kz_n_per_m": float(params["stiffness_n_per_m"]),
                                                 "cz_n_s_per_m": float(c)}),)

    def guesses(self, diagnosis):
        """Starts at the residual's peaks (``k = M (2 pi f)^2``, ``M`` the mass on the mount,
        ``diagnosis["mount_mass_kg"]``: 1045 kg on the TX200) and a scan of 20-250 Hz; ``fit``
        optimizes from the cheapest two."""
        freqs = [float(f) for f, _ in (diagnosis.get("residual_peaks") or [])]
        if diagnosis.get("extra_peak_hz"):
            freqs.append(float(diagnosis["extra_peak_hz"]))
        freqs += [20.0, 35.0, 50.0, 70.0, 100.0, 150.0, 250.0]
        k = self.param("stiffness_n_per_m")
        mass = float(diagnosis["mount_mass_kg"])
        return [{"stiffness_n_per_m": float(np.clip(mass * (2 * math.pi * f) ** 2, k.lower, k.upper)),
                 "damping_ratio": 0.05} for f in freqs]

    def perturb(self, pm, params):
        if pm.momentum_jacobian is None:
            raise ValueError("mount_z needs the pose's momentum Jacobian (pose_matrices)")
        n = pm.M.shape[0]
        m = pm.mount_mass_kg
        k = params["stiffness_n_per_m"]
        P = _padded(pm.momentum_jacobian, n)
        M = _bordered(pm.M, m)
        M[:n, n] = M[n, :n] = P[2]
        ez = np.array([[0.0], [0.0], [1.0]])
        out = replace(pm, M=M, C=_bordered(pm.C, self.damping(params, m)), K=_bordered(pm.K, k),
                      J=np.hstack([pm.J, ez]), J_payload=np.hstack([_padded(pm.J_payload, n), ez]),
                      momentum_jacobian=np.hstack([P, m * ez]))
        if pm.angular_momentum_jacobian is not None and pm.mount_first_moment_kg_m is not None:
            # the angular momentum about the origin of the mass translating along z: S x e_z
            Lz = np.cross(pm.mount_first_moment_kg_m, ez[:, 0])[:, None]
            out = replace(out, angular_momentum_jacobian=np.hstack([_padded(pm.angular_momentum_jacobian, n), Lz]))
        return out


def _state_mass_kg(model: ModelState) -> float:
    """Mass of the robot of ``model`` (every body and the base link, counted once when a rocking
    mount already carries it), kg."""
    import pinocchio as pin

    robot = model.robot()
    return _mounted_mass_kg(robot, float(pin.computeTotalMass(robot.model)))


register(MountZEffect())


# derived, not tuned (docs/guide/identify-answers.md, "The mount's rocking"): on the independent
# generator's six TX200 poses (400 lines 2-300 Hz), the largest relative change |dH| / |H| a rocking
# mount makes on a driving-point line (xx, yy, zz) falls as 1 / k, 7.0e8 / k at the most sensitive
# pose; 3x the 3 % noise (0.09) is reached at k = 7.7e9 N m/rad
MOUNT_ROCK_DETECT_N_M_PER_RAD = 7.7e9


class MountRockEffect(_MountEffect):
    """The robot's base rocking on its mount about base x and y (element
    :class:`~robolobes.linearize.extra_elements.MountCompliance`, ``krx, kry`` and ``crx, cry``).

    Parameters: one rocking stiffness ``k`` for both axes and the damping time ``eta = c / k`` (s), so
    ``crx = cry = eta k``. Isotropic because a base anchored by a ring of bolts is nearly so, and a
    first parametrization: whether the six poses tell ``krx`` from ``kry`` was not measured. A damping
    time, not a damping ratio: the rocking inertia (730-930 kg m^2 about base x and y over the TX200
    set) changes with the pose, and the element holds one ``c``; at the rocking frequency ``f`` the
    ratio is ``zeta = pi f eta``.

    Perturbation (exact for the model alone and with joint, servo, payload and ``mount_z``
    corrections, basic variant): two coordinates ``a_x, a_y`` more, each rotating every body on the
    mount about its base axis ``e`` through the origin. The border of the mass matrix is ``e . L_O``,
    ``L_O`` (3, n) the robot's angular momentum about the origin per unit velocity; the corner is
    ``I_O`` (2 x 2 block of the inertia about the origin, base link included); a point ``p`` moves
    ``e x p`` per unit angle (the TCP, the payload's centre of mass), the linear momentum ``e x S``
    (``S = sum m c``). ``K' = diag(K, k, k)``, ``C' = diag(C, c, c)``. Gravity (gravity variant)
    would take ``M g z_G`` (about 7e3 N m/rad on the TX200) off the rocking stiffness and couple it
    to the joints; the perturbation omits it (below 1e-3 of the stiffness the data resolve).
    A tool mode's small mass is not coupled to the rocking (as for ``mount_z``).

    Detection threshold (derived, :data:`MOUNT_ROCK_DETECT_N_M_PER_RAD`): the rocking softens the
    whole robot at its TCP by ``|e x p_tcp|^2 / k`` (TX200 set: the TCP 0.37-0.62 m from base x, 0.75-1.13 m from
    base y), which shifts every
    robot peak; seen when some driving-point line changes by 3x the noise (9 % at 3 %): ``k <= 7.7e9``.
    """

    name = "mount_rock"
    doc = ("the robot's base rocking on its mount about base x and y (anchoring, floor): one rocking stiffness "
           "and the damping time c / k")
    parameters = (
        Parameter("stiffness_n_m_per_rad", 1e5, 1e10, None, MOUNT_ROCK_DETECT_N_M_PER_RAD, log=True,
                  doc="kz times the supports' squared radius (0.1-0.16 m^2 for a 0.6-0.8 m footprint): on "
                      "isolators 1e5-1.6e6 (the TX200 rocking at 2-7 Hz), anchored on concrete 1e7-1.6e8 "
                      "(18-70 Hz), a steel block 1.6e9; seen when <= 7.7e9"),
        Parameter("damping_time_s", 3e-6, 2e-2, None, None, log=True,
                  doc="c / k: a damping ratio of 0.3-50 % at a rocking mode of 10-300 Hz (zeta = pi f eta)"),
    )
    observed_by = {"frf": "every robot peak shifted, by an amount that depends on the pose (the TCP's distance "
                          "from the base axes): some driving-point line changed by 3x the noise, "
                          "TX200: k <= 7.7e9 N m/rad",
                   "stability": "moves the robot's lobes"}
    signatures = ("pose_shift", "static_offset")


    def element_specs(self, model, params):
        """The ``mount_compliance`` element (rocking only): ``krx = kry = k``, ``crx = cry = eta k``."""
        k = float(params["stiffness_n_m_per_rad"])
        c = float(params["damping_time_s"] * k)
        return (ElementSpec("mount_compliance", {"krx_n_m_per_rad": k, "kry_n_m_per_rad": k,
                                                 "crx_n_m_s_per_rad": c, "cry_n_m_s_per_rad": c}),)

    def guesses(self, diagnosis):
        """A scan of the rigid robot's rocking frequency, 5-250 Hz, ``k = I (2 pi f)^2`` with ``I`` the
        rocking inertia (``diagnosis["rock_inertia_kg_m2"]``), damping ratio 5 % there; ``fit``
        optimizes from the cheapest two."""
        inertia = float(diagnosis["rock_inertia_kg_m2"])
        kp, ep = self.param("stiffness_n_m_per_rad"), self.param("damping_time_s")
        out = []
        for f in (5.0, 12.0, 25.0, 40.0, 60.0, 90.0, 150.0, 250.0):
            w = 2 * math.pi * f
            out.append({"stiffness_n_m_per_rad": float(np.clip(inertia * w ** 2, kp.lower, kp.upper)),
                        "damping_time_s": float(np.clip(2 * 0.05 / w, ep.lower, ep.upper))})
        return out

    def perturb(self, pm, params):
        if pm.angular_momentum_jacobian is None or pm.mount_inertia_kg_m2 is None \
                or pm.mount_first_moment_kg_m is None or pm.payload_com_m is None or pm.momentum_jacobian is None:
            raise ValueError("mount_rock needs the pose's momentum terms (pose_matrices)")
        n = pm.M.shape[0]
        k = params["stiffness_n_m_per_rad"]
        c = params["damping_time_s"] * k
        E = np.eye(3)[:, :2]                                   # the axes e_x, e_y (3, 2)
        L = _padded(pm.angular_momentum_jacobian, n)
        M = np.zeros((n + 2, n + 2))
        M[:n, :n] = pm.M
        M[n:, :n] = E.T @ L
        M[:n, n:] = M[n:, :n].T
        M[n:, n:] = E.T @ pm.mount_inertia_kg_m2 @ E
        C, K = np.zeros_like(M), np.zeros_like(M)
        C[:n, :n], K[:n, :n] = pm.C, pm.K
        C[n:, n:], K[n:, n:] = c * np.eye(2), k * np.eye(2)
        turn = lambda p: np.cross(E.T, p).T                    # e x p per axis (3, 2)
        if pm.tcp_m is None:
            raise ValueError("mount_rock needs the TCP position (pose_matrices)")
        tcp = pm.tcp_m
        S = pm.mount_first_moment_kg_m
        return replace(pm, M=M, C=C, K=K, J=np.hstack([pm.J, turn(tcp)]),
                       J_payload=np.hstack([_padded(pm.J_payload, n), turn(pm.payload_com_m)]),
                       momentum_jacobian=np.hstack([_padded(pm.momentum_jacobian, n), turn(S)]),
                       angular_momentum_jacobian=np.hstack([L, pm.mount_inertia_kg_m2 @ E]))


register(MountRockEffect())


# detection thresholds (stiffening per kN m), derived, not tuned: the load law is told apart from a
# constant stiffness scale (joint_correction, which resolves 10 %) when the stiffness varies by 10 %
# over the poses, kappa (|tau|max - |tau|min) >= 0.1. On the TX200 sets (Tab. 7 and its five
# offsets) |tau| spans 18-265 N m on axis 3 (0.40 per kN m), 102-156 N m on axis 5 (1.85), 20-63 N m
# on axis 4 (2.3: above the bound 2, never told apart: not registered)
LOAD_K_DETECT_PER_KNM = {3: 0.40, 5: 1.85}


class LoadKEffect(StructuralEffect):
    """Axis ``joint``'s gear stiffening with the static torque it carries (element
    :class:`~robolobes.linearize.extra_elements.LoadStiffness`), linear over the data:
    ``k = k0 (1 + kappa |tau| / 1 kN m)``, ``tau`` the gravity torque at the pose.

    Bound: ``0 <= kappa <= 2`` per kN m: the catalogue ``K3 / K1 <= 3`` (``c <= 2``) reached at no
    less than 1 kN m (an assumption about the TX200's gears, whose catalogue curves are not published;
    a fit on the bound is reported as not credible). The data determine the slope ``kappa`` only,
    never ``c`` and ``T`` apart (every pose below ``T``). Detection: module constant
    :data:`LOAD_K_DETECT_PER_KNM`.
    """

    signatures = ("pose_shift", "static_offset")

    def __init__(self, joint: int, candidate: bool):
        self.joint = joint
        self.candidate = candidate
        self.name = f"load_k_a{joint}"
        self.doc = (f"axis {joint}: gear stiffness rising with the static gravity torque it carries, "
                    "k0 (1 + kappa |tau| / 1 kN m)")
        self.parameters = (Parameter("stiffening_per_knm", 0.0, 2.0, neutral=0.0,
                                     detect=LOAD_K_DETECT_PER_KNM[joint],
                                     doc="relative stiffening per kN m of static gear torque; catalogue K3 / K1 "
                                         "<= 3 at >= 1 kN m"),)
        self.observed_by = {"frf": "the robot's peaks shifted by a pose-dependent amount that follows the axis's "
                                   f"static gravity torque: kappa >= {LOAD_K_DETECT_PER_KNM[joint]} per kN m (10 % "
                                   "over the TX200 set's torque span)",
                            "stability": "moves the robot's lobes"}

    def applicable(self, model: ModelState) -> bool:
        return self.joint <= model.case.robot.n_joints

    def guesses(self, diagnosis):
        return [{"stiffening_per_knm": s} for s in (0.25, 0.5, 1.0, 1.6)]

    def element_specs(self, model, params):
        """The ``load_stiffness`` element: ``stiffening`` (c) at the reference torque of 1 kN m equals kappa."""
        return (ElementSpec("load_stiffness", {"joint": self.joint, "stiffening": float(params["stiffening_per_knm"]),
                                               "reference_torque_n_m": LOAD_K_REFERENCE_N_M}),)

    def perturb(self, pm, params):
        if pm.gear_torque_n_m is None:
            raise ValueError("load_k needs the pose's gear torques (pose_matrices)")
        i, j = pm.motion_dofs[self.joint - 1], self.joint - 1
        K = pm.K.copy()
        K[i, i] += pm.joint_k[j] * params["stiffening_per_knm"] * _load_fraction(pm.gear_torque_n_m[j])
        slopes = np.zeros(len(pm.joint_k)) if pm.load_slope_per_knm is None else pm.load_slope_per_knm.copy()
        slopes[j] += params["stiffening_per_knm"]
        return replace(pm, K=K, load_slope_per_knm=slopes)


register(LoadKEffect(3, candidate=True))
register(LoadKEffect(5, candidate=False))
