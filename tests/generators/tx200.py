"""An independent TX200 for test data: pinocchio assembled here from the numbers of NOTES.md.

Nothing here imports ``robolobes`` (not its robot files, not its elements, not identification): the
chain, the masses and the joint table are typed in from /work/shared/seed/NOTES.md (Huynh et al.,
Tab. 1-6, with the GB-z splits NOTES.md marks as assumed), and every effect is built here in its own
way (an extra pinocchio joint and body, a matrix block, a scale of the output), not through the
perturbations identification fits. Basic variant: motion-axis springs ``k (q - theta)`` and dampers
``d qdot``, no gravity, so the linearization at motor angles ``theta`` is ``q = theta``,
``M = crba(q)``, ``K = diag(k)``, ``C = diag(d)``, and the tool-tip receptance (base axes, m/N) is
``H(w) = J (K - w^2 M + i w C)^-1 J^T`` with ``J`` the TCP's translational Jacobian.

Effects (``Effects``, all optional):

* ``tool_modes``: a point mass ``m = k / w0^2`` at the TCP, taken from the payload there (so the total
  mass is unchanged), on a chain of prismatic joints, one per direction of the TCP frame (spring
  ``k``, damper ``2 zeta sqrt(k m)`` each; every entry must give the same ``m``): two joints along
  TCP x and y make the usual two-direction holder mode, frequency ``sqrt(k / m)`` along each.
* ``joint_scale``: {axis: (stiffness factor, damping factor)}.
* ``payload_factor``: the payload mass times this factor (the difference a point mass at its
  centre of mass).
* ``servo``: (axis, rotor inertia kg m^2, kp N m/rad, kd N m s/rad): a rotor coordinate behind the
  joint spring, held by a PD loop to the motor angle.
* ``base_z``: (stiffness N/m, damping N s/m): the robot's base on a vertical floor compliance (a
  prismatic joint under the base: a compliance outside the six joints, in no library element).
* ``base_rock``: (krx N m/rad, kry N m/rad, crx N m s/rad, cry N m s/rad): the robot's base rocking on
  its mount, two revolute joints under the base through the base frame's origin, about base x then
  base y (an axis with stiffness ``inf`` gets no joint). Every body, the base link included, rides on
  them. Gravity: this generator's dynamics omit it, so the rocking springs are ``k`` alone; a robot in
  gravity loses ``M g z_G`` of rocking stiffness about each horizontal axis (``z_G`` the height of
  the centre of mass above the base origin; the potential ``M g z_G'`` with ``z_G' = y_G sin a +
  z_G cos a`` about x has ``d^2 / da^2 = -M g z_G``), 1045 kg x 9.81 x 0.6-0.8 m, below 1e4 N m/rad,
  which is 2e-4 of the softest rocking stiffness drawn (tests/generators/draws.py): omitted here as
  in robolobes' basic variant.
* ``arm_bend``: (stiffness N m/rad, damping N m s/rad): lateral bending of the arm (link 2, between
  axes 2 and 3), a revolute joint about the arm's x axis halfway from axis 2 to axis 3 (the arm's
  mass stays on the proximal half, the rest of the chain bends): a compliance out of the plane of
  axes 2 and 3, which the basic model has no coordinate for (in no library element: an effect
  outside the library).
* ``load_k``: (axis, c, T N m): the axis's gear stiffens with the static torque it carries,
  ``k = k0 (1 + c min(|tau| / T, 1))``, ``tau`` the axis's gravity torque at the pose (this model's
  ``computeGeneralizedGravity`` with g = 9.81 m/s^2 along -z: the robot stands in gravity even though
  the dynamics here omit it); the damper is unchanged.
* ``sensor_gain``: the force sensor's calibration error: measured force = true force x gain, so the
  measured receptance is ``H / gain``.
* ``channel_gain``: (gx, gy, gz), the response channels' calibration errors (base axes): measured
  response = true response x gain, row ``o`` of the receptance times ``g_o``.
* ``delay_s``: the response sampled ``delay_s`` later than the force: ``H exp(-i w delay_s)``.
* ``accel_mass_kg``: an accelerometer, a point mass (no rotary inertia) on the body that carries the
  TCP, at the TCP: added to the payload's pinocchio inertia there, or to the tool mode's body when
  there is one (the mass rides on the tool).
* ``highpass_hz``: the DAQ's AC coupling on the response channels, a first-order high-pass
  ``i w / (i w + 2 pi f_c)`` (in no library element: an effect outside the library).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin

__all__ = ["Effects", "TX200", "POSE_TAB7_DEG", "POSE_OFFSETS_DEG", "PAIRS", "write_frf_set"]

# ---- NOTES.md, Tab. 1 (m), link frames at their entry joint ----------------------------------
AG = {"base": (0.007, 0.001, 0.119), "shoulder": (0.150, -0.008, 0.209), "arm": (0.007, 0.139, 0.401),
      "elbow": (0.039, -0.219, -0.043), "forearm": (0.0, 0.004, 0.266), "wrist": (0.0, 0.0, 0.068),
      "flange": (0.0, 0.0, 0.005)}
GB = {"base": (-0.007, -0.001, 0.200), "shoulder": (0.100, 0.243, 0.114), "arm": (-0.007, -0.095, 0.549),
      "elbow": (-0.039, -0.060, 0.200), "forearm": (0.0, -0.004, 0.377), "wrist": (0.0, 0.0, 0.050),
      "flange": (0.0, 0.0, 0.071)}
# ---- Tab. 4: mass kg; inertia at the COM, link axes: xx, yy, zz, xy, xz, yz --------------------
MASS = {"base": 226.0, "shoulder": 364.0, "arm": 256.0, "elbow": 99.0, "forearm": 41.0, "wrist": 14.0,
        "flange": 0.6}
INERTIA = {"base": (8.30, 7.98, 11.87, 0, -0.01, 0), "shoulder": (12.25, 17.83, 16.95, -0.20, 1.55, 0.25),
           "arm": (36.58, 39.92, 6.57, 0.05, 0.18, 0.74), "elbow": (0.57, 0.51, 0.46, -0.02, -0.07, 0.02),
           "forearm": (1.23, 1.17, 0.30, 0, 0, 0.06), "wrist": (0.03, 0.03, 0.02, 0, 0, 0),
           "flange": (6e-3, 6e-3, 1e-3, 0, 0, 0)}
LINKS = ("base", "shoulder", "arm", "elbow", "forearm", "wrist", "flange")
AXES = ("z", "y", "y", "z", "y", "z")                       # joint i: link i-1 -> link i
# ---- Tab. 5, 6 -----------------------------------------------------------------------------
K_JOINT = np.array([2.03e6, 6.02e6, 1.91e6, 0.45e6, 0.22e6, 0.07e6])
D_JOINT = np.array([383.3, 660.0, 371.7, 180.5, 126.2, 71.2])
# ---- Tab. 3: payload, flange axes, from the flange face -------------------------------------
PAYLOAD_MASS = 44.4
PAYLOAD_AG = np.array([-0.004, 0.0, 0.158])
PAYLOAD_TCP = np.array([0.201, 0.0, 0.317])
PAYLOAD_INERTIA = (0.095, 0.106, 0.098, 0, 0.035, 0)
TCP_ROT_Y_DEG = 60.0
# ---- Tab. 7 pose and the poses of a set --------------------------------------------------------
POSE_TAB7_DEG = np.array([-11.71, 20.78, -212.14, 82.76, 60.80, -166.96])
# A3 at Tab. 7 is 2.86 deg past +145 deg (wrapped), so A3 only moves back into its range: identify
# refuses a pose more than 5 deg past a limit, as every command does
POSE_OFFSETS_DEG = np.array([[0, 0, 0, 0, 0, 0], [12, 6, -4, 5, 8, -10], [-14, -4, -9, 12, -8, 25],
                             [25, 9, -8, -18, 6, -25], [-25, 10, -6, 15, 12, 12], [8, -7, -11, -12, -6, -20]],
                            dtype=float)
PAIRS = ((0, 0), (1, 1), (2, 2), (0, 1))   # (out, in) axes: xx, yy, zz, xy


def _inertia_matrix(v) -> np.ndarray:
    xx, yy, zz, xy, xz, yz = v
    return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]], dtype=float)


def _rot_y(deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


@dataclass(frozen=True)
class Effects:
    """What the generator adds to the nominal TX200 (module doc); the default is none."""

    tool_modes: tuple = ()          # ((freq_hz, zeta, k_n_per_m, direction_tcp (3,)), ...)
    joint_scale: dict = field(default_factory=dict)   # axis (1-6) -> (stiffness factor, damping factor)
    payload_factor: float = 1.0
    servo: tuple | None = None      # (axis, J kg m^2, kp N m/rad, kd N m s/rad)
    base_z: tuple | None = None     # (k N/m, c N s/m)
    base_rock: tuple | None = None  # (krx, kry N m/rad, crx, cry N m s/rad); inf: no joint
    arm_bend: tuple | None = None   # (k N m/rad, c N m s/rad)
    sensor_gain: float = 1.0
    channel_gain: tuple = (1.0, 1.0, 1.0)
    delay_s: float = 0.0
    accel_mass_kg: float = 0.0
    highpass_hz: float = 0.0
    load_k: tuple | None = None     # (axis 1-6, c, T N m)


class TX200:
    """The independent model with ``effects``; :meth:`frf` gives the tool-tip receptance at a pose."""

    def __init__(self, effects: Effects = Effects()):
        self.effects = effects
        self.model, self.tcp_frame, self.n_base, self.n_modes = self._build()
        self.data = self.model.createData()
        v = lambda name: self.model.joints[self.model.getJointId(name)].idx_v
        self.motion = np.array([v(f"A{i + 1}") for i in range(6)])              # the six axes' coordinates
        self.modes = [v(f"mode_{r}") for r in range(self.n_modes)]

    def _build(self):
        e = self.effects
        model = pin.Model()
        parent, n_base = 0, 0
        if e.base_z is not None:        # the base on a vertical floor spring
            parent = model.addJoint(0, pin.JointModelPZ(), pin.SE3.Identity(), "floor_z")
            n_base = 1
        for i, axis in enumerate(("x", "y")):      # the base rocking about base x, then y
            if e.base_rock is not None and math.isfinite(e.base_rock[i]):
                joint = pin.JointModelRX() if axis == "x" else pin.JointModelRY()
                parent = model.addJoint(parent, joint, pin.SE3.Identity(), f"rock_{axis}")
                n_base += 1
        base_inertia = pin.Inertia(MASS["base"], np.array(AG["base"]), _inertia_matrix(INERTIA["base"]))
        model.appendBodyToJoint(parent, base_inertia, pin.SE3.Identity())
        placement = pin.SE3(np.eye(3), np.array(AG["base"]) + np.array(GB["base"]))
        joint_models = {"z": pin.JointModelRZ, "y": pin.JointModelRY}
        for i, link in enumerate(LINKS[1:]):
            parent = model.addJoint(parent, joint_models[AXES[i]](), placement, f"A{i + 1}")
            model.appendBodyToJoint(parent, pin.Inertia(MASS[link], np.array(AG[link]),
                                                        _inertia_matrix(INERTIA[link])), pin.SE3.Identity())
            span = np.array(AG[link]) + np.array(GB[link])
            placement = pin.SE3(np.eye(3), span)
            if link == "arm" and e.arm_bend is not None:    # bend about the arm's x axis at mid-span
                parent = model.addJoint(parent, pin.JointModelRX(), pin.SE3(np.eye(3), 0.5 * span), "arm_bend")
                placement = pin.SE3(np.eye(3), 0.5 * span)
        # payload at the flange face (placement now: flange joint -> flange face)
        face = placement
        pm = PAYLOAD_MASS * e.payload_factor
        payload = pin.Inertia(PAYLOAD_MASS, PAYLOAD_AG, _inertia_matrix(PAYLOAD_INERTIA))
        if e.payload_factor != 1.0:      # the difference a point mass at the payload's centre of mass
            payload = payload + pin.Inertia(pm - PAYLOAD_MASS, PAYLOAD_AG, np.zeros((3, 3)))
        tcp_rot = _rot_y(TCP_ROT_Y_DEG)
        mode_mass = [k / (2 * math.pi * f) ** 2 for f, _, k, _ in e.tool_modes]
        if mode_mass:                   # one mass, taken from the payload at the TCP: total mass unchanged
            if max(mode_mass) > min(mode_mass) * (1 + 1e-9):
                raise ValueError(f"chained tool modes share one mass: k / w0^2 = {mode_mass} kg differ")
            payload = payload + pin.Inertia(-mode_mass[0], PAYLOAD_TCP, np.zeros((3, 3)))
        elif e.accel_mass_kg:           # the accelerometer on the payload, at the TCP
            payload = payload + pin.Inertia(e.accel_mass_kg, PAYLOAD_TCP, np.zeros((3, 3)))
        model.appendBodyToJoint(parent, payload, face)
        tcp = face * pin.SE3(tcp_rot, PAYLOAD_TCP)       # flange joint -> TCP
        for r, (_f, _z, _k, d) in enumerate(e.tool_modes):
            # a prismatic joint along d at the TCP (joint frame = TCP axes); the last carries the point
            # mass, the others are massless links of the chain (the mass moves along every direction)
            d = np.asarray(d, float) / np.linalg.norm(d)
            parent = model.addJoint(parent, pin.JointModelPrismaticUnaligned(d), tcp, f"mode_{r}")
            m = mode_mass[0] + e.accel_mass_kg if r == len(e.tool_modes) - 1 else 0.0   # accelerometer on the tool
            model.appendBodyToJoint(parent, pin.Inertia(m, np.zeros(3), np.zeros((3, 3))), pin.SE3.Identity())
            tcp = pin.SE3.Identity()          # the next mode joint sits on this body, same point and axes
        frame = model.addFrame(pin.Frame("tcp", parent, tcp, pin.FrameType.OP_FRAME))
        return model, frame, n_base, len(e.tool_modes)

    def matrices(self, theta_deg) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``M, C, K`` (n, n) and the TCP's translational Jacobian ``J`` (3, n), base axes, at motor
        angles ``theta_deg`` (the link angles equal them: no gravity)."""
        e = self.effects
        q = np.zeros(self.model.nq)
        q[self.motion] = np.radians(theta_deg)
        M = pin.crba(self.model, self.data, q)
        M = np.triu(M) + np.triu(M, 1).T
        pin.computeJointJacobians(self.model, self.data, q)
        pin.updateFramePlacements(self.model, self.data)
        J = pin.getFrameJacobian(self.model, self.data, self.tcp_frame, pin.LOCAL_WORLD_ALIGNED)[:3]
        n = self.model.nv
        k = K_JOINT.copy()
        d = D_JOINT.copy()
        for ax, (sk, sd) in e.joint_scale.items():
            k[ax - 1] *= sk
            d[ax - 1] *= sd
        if e.load_k is not None:
            ax, c, T = e.load_k
            k[ax - 1] *= 1.0 + c * min(abs(self.gravity_torque(q)[ax - 1]) / T, 1.0)
        K = np.zeros((n, n))
        C = np.zeros((n, n))
        j = self.motion
        K[j, j] = k
        C[j, j] = d
        if e.base_z is not None:
            K[0, 0], C[0, 0] = e.base_z
        if e.base_rock is not None:
            for r, axis in enumerate(("x", "y")):
                if math.isfinite(e.base_rock[r]):
                    i = self.model.joints[self.model.getJointId(f"rock_{axis}")].idx_v
                    K[i, i], C[i, i] = e.base_rock[r], e.base_rock[r + 2]
        if e.arm_bend is not None:
            i = self.model.joints[self.model.getJointId("arm_bend")].idx_v
            K[i, i], C[i, i] = e.arm_bend
        for r, (f, z, km, _) in enumerate(e.tool_modes):
            i = self.modes[r]
            m = km / (2 * math.pi * f) ** 2       # the mode's own mass (k / w0^2), without the accelerometer
            K[i, i] = km
            C[i, i] = 2 * z * math.sqrt(km * m)
        if e.servo is not None:     # rotor coordinate: spring k between link and rotor, PD to ground
            ax, Jr, kp, kd = e.servo
            i = self.motion[ax - 1]
            kk = K[i, i]
            M = np.pad(M, ((0, 1), (0, 1)))
            C = np.pad(C, ((0, 1), (0, 1)))
            K = np.pad(K, ((0, 1), (0, 1)))
            J = np.pad(J, ((0, 0), (0, 1)))
            M[-1, -1] = Jr
            C[-1, -1] = kd
            K[-1, -1] = kk + kp
            K[i, -1] = K[-1, i] = -kk
        return M, C, K, J

    def gravity_torque(self, q) -> np.ndarray:
        """Static gravity torque (6,), N m, on the six axes at the configuration ``q`` (nq,), rad:
        g = 9.81 m/s^2 along -z (a copy of the model with gravity on)."""
        m = pin.Model(self.model)
        m.gravity = pin.Motion(np.array([0.0, 0.0, -9.81]), np.zeros(3))
        return np.asarray(pin.computeGeneralizedGravity(m, m.createData(), q))[self.motion]

    def tcp_rotation(self, theta_deg) -> np.ndarray:
        """Rotation (3, 3) of the TCP frame in base axes at motor angles ``theta_deg`` (columns: TCP x, y, z)."""
        q = np.zeros(self.model.nq)
        q[self.motion] = np.radians(theta_deg)
        pin.framesForwardKinematics(self.model, self.data, q)
        return np.array(self.data.oMf[self.tcp_frame].rotation)

    def frf(self, theta_deg, f_hz) -> np.ndarray:
        """Tool-tip receptance (3, 3, F), m/N, base axes, at ``f_hz`` (F,), as measured: the sensors'
        gains, the delay and the high-pass applied."""
        e = self.effects
        M, C, K, J = self.matrices(theta_deg)
        w = 2 * math.pi * np.asarray(f_hz, float)
        Z = K[None] - w[:, None, None] ** 2 * M[None] + 1j * w[:, None, None] * C[None]
        X = np.linalg.solve(Z, np.broadcast_to(J.T, (len(w),) + J.T.shape))       # (F, n, 3)
        H = np.einsum("in,fnj->ijf", J, X)
        H = H * np.asarray(e.channel_gain, float)[:, None, None] / e.sensor_gain
        chain = np.exp(-1j * w * e.delay_s)
        if e.highpass_hz:
            chain = chain * (1j * w) / (1j * w + 2 * math.pi * e.highpass_hz)
        return H * chain[None, None, :]


def write_frf_set(directory, effects: Effects = Effects(), *, n_poses: int = 6, f_hz=None, rel_noise: float = 0.02,
                  seed: int = 0, case: str = "tx200-aluminium", pairs=PAIRS) -> dict:
    """Write ``poses.csv`` and ``p<k>.uff`` (UFF58, one dataset per pair, receptance m/N) into the new
    ``directory``. Noise: complex Gaussian, ``rel_noise`` x |H| per line (``E|n|^2 = rel_noise^2 |H|^2``).

    Returns the truth: ``H_true`` and ``H_meas`` per pose ((P, F) arrays), ``f_hz``, and
    ``noise_error``: RMS |H_meas - H_true| / RMS |H_meas| (the error the generating model has on the data).
    """
    import pyuff

    d = Path(directory)
    d.mkdir(parents=False, exist_ok=False)
    f_hz = np.linspace(2.0, 300.0, 600) if f_hz is None else np.asarray(f_hz, float)
    rng = np.random.default_rng(seed)
    robot = TX200(effects)
    lines = ["pose," + ",".join(f"q{i + 1}_deg" for i in range(6)) + ",case"]
    truth = {"H_true": [], "H_meas": [], "f_hz": f_hz}
    for k in range(n_poses):
        q = POSE_TAB7_DEG + POSE_OFFSETS_DEG[k]
        lines.append(f"p{k}," + ",".join(f"{v:.12g}" for v in q) + f",{case}")
        H = robot.frf(q, f_hz)
        ht = np.array([H[o, i] for o, i in pairs])
        noise = (rng.standard_normal(ht.shape) + 1j * rng.standard_normal(ht.shape)) / math.sqrt(2)
        hm = ht + rel_noise * np.abs(ht) * noise
        sets = [pyuff.prepare_58(binary=0, id1=f"pose p{k}", id2="frame base", func_type=4, rsp_node=1,
                                 rsp_dir=o + 1, ref_node=1, ref_dir=i + 1, ord_data_type=6, num_pts=len(f_hz),
                                 abscissa_spacing=1, abscissa_min=float(f_hz[0]),
                                 abscissa_inc=float(f_hz[1] - f_hz[0]), abscissa_spec_data_type=18,
                                 ordinate_spec_data_type=8, ordinate_axis_units_lab="m",
                                 orddenom_spec_data_type=13, orddenom_axis_units_lab="N",
                                 data=np.ascontiguousarray(h, dtype=np.complex128), x=f_hz)
                for (o, i), h in zip(pairs, hm)]
        pyuff.UFF(str(d / f"p{k}.uff")).write_sets(sets, mode="add")
        truth["H_true"].append(ht)
        truth["H_meas"].append(hm)
    (d / "poses.csv").write_text("\n".join(lines) + "\n")
    meas = np.concatenate([h.ravel() for h in truth["H_meas"]])
    true = np.concatenate([h.ravel() for h in truth["H_true"]])
    truth["noise_error"] = float(np.sqrt(np.mean(np.abs(meas - true) ** 2)) / np.sqrt(np.mean(np.abs(meas) ** 2)))
    return truth
