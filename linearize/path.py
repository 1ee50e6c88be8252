"""The milling pass: a straight TCP line at constant orientation with a jerk-limited feed profile.

A :class:`Pass` is built from a :class:`cases.MillingCase` (:meth:`Pass.from_case`). The TCP
starts at the pose of ``case.path.start_q_rad`` and moves along ``case.cut.feed_direction`` (base
frame) over ``case.path.travel_m(tool)`` = approach + D + part length + overrun, keeping the
start orientation. The motor angles ``theta`` along the pass come from the IK of
:mod:`linearize.kinematics` (closed form, or the numerical inverse for an arm that is not OPW), on
the branch of the start pose, continued in 2 pi from the start
pose *as given* (``theta(0) == start_q_rad``: the paper's A3 = -212.14 deg stays -212.14 deg).

Feed profile (S-curve, piecewise-constant jerk, no constant-acceleration phase)::

    0 <= t <= T/2      jerk +J        T = ramp_s, V = feed rate, J = 4 V / T^2
    T/2 <= t <= T      jerk -J        (v(T) = V, a(T) = 0, s(T) = V T / 2)
    T <= t <= t_e - T  jerk 0, v = V
    t_e - T .. t_e     mirror image back to rest,   t_e = duration = T + L / V

``s``, ``v``, ``a`` are continuous, ``|jerk| <= J``, ``a_max = 2 V / T``. Before 0 and after
``t_e`` the TCP is at rest (s clipped to [0, L]).

Part contact: the tool *envelope* (its full diameter) touches the entry face at
``part_entry_s = approach`` and clears the exit face at ``part_exit_s = approach + D + part
length``. With a radial depth ``ae < D/2`` the cutting edges touch the material only over the
chord ``w = sqrt(R^2 - (R - ae)^2)`` ahead of / behind the tool centre:
``contact_entry_s = approach + R - w`` and ``contact_exit_s = approach + R + part length + w``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from robolobes.cases.spec import MillingCase, RobotSpec
from robolobes.core.errors import BadInput

from .kinematics import (BRANCHES, branch_of, check_limits, check_structure, fk, ik_batch,
                         jacobian)

__all__ = ["PassError", "FeedProfile", "Pass", "FEED_PERPENDICULAR_TOL", "MAX_TABLE_STEP_RAD"]

#: |cos| between the feed direction and the tool axis above which the pass is refused (as
#: :func:`cases.milling.cut_frame`: 2.5-axis milling needs the feed in the plane of the tool).
FEED_PERPENDICULAR_TOL = 1e-3
#: Largest joint step between adjacent samples of the reference table (a branch jump guard), rad.
MAX_TABLE_STEP_RAD = 0.05


class PassError(BadInput):
    """A pass that cannot be built or queried (too short for its ramps, s out of range, ...)."""


# ------------------------------------------------------------------------------------ feed profile
@dataclass(frozen=True)
class FeedProfile:
    """Jerk-limited rest-to-rest motion over a distance at a constant cruise speed.

    Parameters
    ----------
    travel_m : float
        Distance L, m (> 0).
    feed_m_per_s : float
        Cruise speed V, m/s (> 0).
    ramp_s : float
        Duration T of each ramp (rest -> V and V -> rest), s (> 0). Needs ``V T <= L``.
    """

    travel_m: float
    feed_m_per_s: float
    ramp_s: float

    def __post_init__(self):
        for k in ("travel_m", "feed_m_per_s", "ramp_s"):
            v = getattr(self, k)
            if not (isinstance(v, (int, float, np.floating)) and math.isfinite(v) and v > 0):
                raise PassError(f"feed profile: {k} must be a finite number > 0, got {v!r}")
        need = self.feed_m_per_s * self.ramp_s
        if need > self.travel_m:
            raise PassError(
                f"feed profile: travel {self.travel_m * 1e3:.6g} mm is too short for two {self.ramp_s:g} s ramps to "
                f"{self.feed_m_per_s * 6e4:.6g} mm/min, which need V * T = {need * 1e3:.6g} mm; shorten ramp_s to at "
                f"most {self.travel_m / self.feed_m_per_s:.6g} s or lengthen the pass")

    @property
    def jerk_m_per_s3(self) -> float:
        """Jerk magnitude J = 4 V / T^2, m/s^3."""
        return 4 * self.feed_m_per_s / self.ramp_s ** 2

    @property
    def max_acceleration_m_per_s2(self) -> float:
        """Peak acceleration J T / 2 = 2 V / T, m/s^2."""
        return 2 * self.feed_m_per_s / self.ramp_s

    @property
    def ramp_distance_m(self) -> float:
        """Distance covered by one ramp, V T / 2, m."""
        return self.feed_m_per_s * self.ramp_s / 2

    @property
    def duration_s(self) -> float:
        """Total time T + L / V, s."""
        return self.ramp_s + self.travel_m / self.feed_m_per_s

    # ramp from rest, tau in [0, T]
    def _ramp(self, tau):
        T, V, J = self.ramp_s, self.feed_m_per_s, self.jerk_m_per_s3
        h = T / 2
        first = tau <= h
        u = tau - h
        s = np.where(first, J * tau ** 3 / 6, V * T / 12 + V / 2 * u + J * h * u ** 2 / 2 - J * u ** 3 / 6)
        v = np.where(first, J * tau ** 2 / 2, V / 2 + J * h * u - J * u ** 2 / 2)
        a = np.where(first, J * tau, J * h - J * u)
        j = np.where(first, J, -J)
        return s, v, a, j

    def state(self, t):
        """Path coordinate and its derivatives at times t.

        Parameters
        ----------
        t : float or array (...)
            Time from the start of the pass, s (clipped to [0, duration]).

        Returns
        -------
        s, v, a, jerk : arrays like t
            m, m/s, m/s^2, m/s^3 (jerk is the one-sided value on the right of a switching time).
        """
        t = np.clip(np.asarray(t, dtype=float), 0.0, self.duration_s)
        T, V, L, te = self.ramp_s, self.feed_m_per_s, self.travel_m, self.duration_s
        s1, v1, a1, j1 = self._ramp(np.clip(t, 0, T))
        s3, v3, a3, j3 = self._ramp(np.clip(te - t, 0, T))
        acc, dec = t < T, t > te - T
        s = np.where(acc, s1, np.where(dec, L - s3, V * T / 2 + V * (t - T)))
        v = np.where(acc, v1, np.where(dec, v3, V))
        a = np.where(acc, a1, np.where(dec, -a3, 0.0))
        j = np.where(acc, j1, np.where(dec, j3, 0.0))
        if np.ndim(t) == 0:
            return float(s), float(v), float(a), float(j)
        return s, v, a, j

    def s(self, t):
        """Path coordinate s(t), m."""
        return self.state(t)[0]

    def velocity(self, t):
        """Path speed ds/dt, m/s."""
        return self.state(t)[1]

    def acceleration(self, t):
        """Path acceleration, m/s^2."""
        return self.state(t)[2]

    def jerk(self, t):
        """Path jerk, m/s^3."""
        return self.state(t)[3]

    def time_at(self, s):
        """Inverse of s(t): time at path coordinate s, s; s clipped to [0, L]. Vectorized.

        Closed form on the constant-speed part, bisection (60 halvings, exact to double precision)
        on the ramps, where s(t) is strictly increasing.
        """
        s = np.clip(np.asarray(s, dtype=float), 0.0, self.travel_m)
        T, V, L, te = self.ramp_s, self.feed_m_per_s, self.travel_m, self.duration_s
        d = self.ramp_distance_m

        def ramp_inv(x):
            lo, hi = np.zeros_like(x), np.full_like(x, T)
            for _ in range(60):
                mid = 0.5 * (lo + hi)
                below = self._ramp(mid)[0] < x
                lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
            return np.where(x <= 0, 0.0, 0.5 * (lo + hi))

        t = np.where(s <= d, ramp_inv(np.minimum(s, d)),
                     np.where(s >= L - d, te - ramp_inv(np.minimum(L - s, d)), T + (s - d) / V))
        return float(t) if np.ndim(t) == 0 else t


# ---------------------------------------------------------------------------------------- the pass
@dataclass(frozen=True, eq=False)
class Pass:
    """A straight milling pass of a robot: TCP line, feed profile, motor angles.

    Build it with :meth:`Pass.from_case`. All methods are vectorized over
    arrays of t (s) or s (m).

    Attributes
    ----------
    robot : RobotSpec
    start_q : array (6,)
        Motor angles at the start, rad (as given by the case).
    start_position : array (3,)
        TCP at the start, base frame, m.
    rotation : array (3, 3)
        TCP orientation, constant along the pass (the start orientation).
    direction : array (3,)
        Unit feed direction, base frame.
    profile : FeedProfile
    part_entry_s, part_exit_s : float
        Travel at which the tool envelope touches the part / clears it, m.
    contact_entry_s, contact_exit_s : float
        Travel of the first / last contact of a cutting edge with the material (radial depth ae), m.
    branch : int
        IK branch of the start pose (index into :data:`linearize.kinematics.BRANCHES`).
    n_reference : int
        Size of the reference table used for the 2 pi continuation of theta.
    """

    robot: RobotSpec
    start_q: np.ndarray
    start_position: np.ndarray
    rotation: np.ndarray
    direction: np.ndarray
    profile: FeedProfile
    part_entry_s: float
    part_exit_s: float
    contact_entry_s: float
    contact_exit_s: float
    branch: int
    n_reference: int = 0
    _ref_s: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)  # set by _build_reference
    _ref_theta: np.ndarray = field(default_factory=lambda: np.zeros((0, 6)), repr=False)

    # --------------------------------------------------------------------------- construction
    @classmethod
    def from_case(cls, case: MillingCase, *, n_reference: int | None = None) -> "Pass":
        """Build the pass of a milling case.

        Parameters
        ----------
        case : MillingCase
        n_reference : int, optional
            Samples of the reference table (default: one per 0.5 mm of travel, at least 201).

        Raises
        ------
        PassError
            Feed rate zero, travel too short for the ramps, feed not perpendicular to the tool
            axis, a branch jump along the path.
        KinematicsError
            A singular or unreachable pose along the pass, a joint beyond its limit + tolerance
            (a joint within the tolerance gives a :class:`~linearize.kinematics.JointLimitWarning`).
        """
        spec, tool, cut, ps = case.robot, case.tool, case.cut, case.path
        check_structure(spec)
        q0 = np.array(ps.start_q_rad, dtype=float)
        if q0.shape != (spec.n_joints,):
            raise PassError(f"case {case.name!r}: start pose has shape {q0.shape}, expected ({spec.n_joints},)")
        feed = cut.feed_rate_m_per_s(tool)
        if not feed > 0:
            raise PassError(f"case {case.name!r}: the feed rate is {feed} m/s; a pass needs a feed rate > 0")
        travel = ps.travel_m(tool)
        profile = FeedProfile(travel_m=travel, feed_m_per_s=feed, ramp_s=ps.ramp_s)
        p0, R0 = fk(spec, q0)
        d = np.asarray(cut.feed_direction, dtype=float)
        d = d / np.linalg.norm(d)
        cosang = float(d @ R0[:, 2])
        if abs(cosang) > FEED_PERPENDICULAR_TOL:
            raise PassError(
                f"case {case.name!r}: feed direction {d.round(6).tolist()} is not perpendicular to the tool axis "
                f"{R0[:, 2].round(6).tolist()} of the start pose (cos = {cosang:.3g}, tolerance "
                f"{FEED_PERPENDICULAR_TOL:g})")
        R = tool.radius_m
        w = math.sqrt(max(R * R - (R - cut.ae_m) ** 2, 0.0)) if cut.ae_m < R else R
        n_ref = n_reference or max(201, int(math.ceil(travel / 5e-4)) + 1)
        obj = cls(robot=spec, start_q=q0, start_position=p0, rotation=R0, direction=d, profile=profile,
                  part_entry_s=ps.approach_m, part_exit_s=ps.approach_m + tool.diameter_m + ps.part_length_m,
                  contact_entry_s=ps.approach_m + R - w, contact_exit_s=ps.approach_m + R + ps.part_length_m + w,
                  branch=int(branch_of(spec, q0)), n_reference=n_ref)
        obj._build_reference()
        return obj

    def _build_reference(self):
        s = np.linspace(0.0, self.travel_m, self.n_reference)
        principal = self._ik(s)
        theta = np.unwrap(np.vstack([self.start_q, principal]), axis=0)[1:]
        err0 = np.abs(theta[0] - self.start_q).max()
        if err0 > 1e-9:
            raise PassError(f"internal: IK at s = 0 differs from the start pose by {err0:.3g} rad")
        theta[0] = self.start_q
        steps = np.abs(np.diff(theta, axis=0))
        if steps.size and steps.max() > MAX_TABLE_STEP_RAD:
            k, j = np.unravel_index(np.argmax(steps), steps.shape)
            raise PassError(
                f"joint {self.robot.joints[j].name} jumps by {math.degrees(steps[k, j]):.3g} deg between s = "
                f"{s[k] * 1e3:.4g} and {s[k + 1] * 1e3:.4g} mm (guard {math.degrees(MAX_TABLE_STEP_RAD):.3g} deg per "
                f"{(s[1] - s[0]) * 1e3:.3g} mm): the pass passes too close to a singularity")
        check_limits(self.robot, theta, stacklevel=4)
        object.__setattr__(self, "_ref_s", s)
        object.__setattr__(self, "_ref_theta", theta)

    def _ik(self, s: np.ndarray) -> np.ndarray:
        p = self.start_position + s[:, None] * self.direction
        return ik_batch(self.robot, p, self.rotation, self.branch, q_ref=self.start_q,
                        where=lambda k: f" at s = {s[k] * 1e3:.6g} mm of the pass")

    # ------------------------------------------------------------------------------- timing
    @property
    def travel_m(self) -> float:
        """Total TCP travel L, m."""
        return self.profile.travel_m

    @property
    def feed_m_per_s(self) -> float:
        """Cruise feed rate V, m/s."""
        return self.profile.feed_m_per_s

    @property
    def duration_s(self) -> float:
        """Duration of the pass (rest to rest), s."""
        return self.profile.duration_s

    @property
    def tool_axis(self) -> np.ndarray:
        """Tool axis (TCP z, out of the spindle), base frame, shape (3,)."""
        return self.rotation[:, 2].copy()

    @property
    def branch_name(self) -> str:
        return BRANCHES[self.branch]

    @property
    def part_entry_t(self) -> float:
        """Time at which the tool envelope reaches the part, s."""
        return float(self.profile.time_at(self.part_entry_s))

    @property
    def part_exit_t(self) -> float:
        """Time at which the tool envelope clears the part, s."""
        return float(self.profile.time_at(self.part_exit_s))

    @property
    def contact_entry_t(self) -> float:
        """Time of the first edge-material contact, s."""
        return float(self.profile.time_at(self.contact_entry_s))

    @property
    def contact_exit_t(self) -> float:
        """Time of the last edge-material contact, s."""
        return float(self.profile.time_at(self.contact_exit_s))

    def s(self, t):
        """Path coordinate at time t (s, clipped to [0, duration]), m."""
        return self.profile.s(t)

    def velocity(self, t):
        """Path speed at time t, m/s."""
        return self.profile.velocity(t)

    def acceleration(self, t):
        """Path acceleration at time t, m/s^2."""
        return self.profile.acceleration(t)

    def jerk(self, t):
        """Path jerk at time t, m/s^3."""
        return self.profile.jerk(t)

    def time_at_s(self, s):
        """Time at which the TCP has travelled s metres, s."""
        return self.profile.time_at(s)

    # ----------------------------------------------------------------------------- geometry
    def _check_s(self, s) -> np.ndarray:
        s = np.asarray(s, dtype=float)
        if not np.all(np.isfinite(s)):
            raise PassError(f"path coordinate s must be finite, got {s}")
        L = self.travel_m
        if np.any(s < -1e-12) or np.any(s > L + 1e-12):
            bad = s[(s < -1e-12) | (s > L + 1e-12)] if s.ndim else s
            raise PassError(f"path coordinate s = {np.atleast_1d(bad)[0]:.6g} m is outside the pass [0, {L:.6g}] m")
        return np.clip(s, 0.0, L)

    def tcp_position_at_s(self, s):
        """TCP position at path coordinate s (m), base frame, shape (..., 3)."""
        s = self._check_s(s)
        return self.start_position + s[..., None] * self.direction

    def tcp_position(self, t):
        """TCP position at time t, base frame, m, shape (..., 3)."""
        return self.start_position + np.asarray(self.s(t))[..., None] * self.direction

    def tcp_velocity(self, t):
        """TCP velocity at time t, base frame, m/s, shape (..., 3)."""
        return np.asarray(self.velocity(t))[..., None] * self.direction

    def pose_at(self, s) -> tuple[np.ndarray, np.ndarray]:
        """TCP pose at path coordinate s in [0, travel_m] (m): ``(p (3,), R (3, 3))``."""
        s = self._check_s(s)
        if s.ndim:
            raise PassError(f"pose_at takes one path coordinate, got shape {s.shape}")
        return self.start_position + float(s) * self.direction, self.rotation.copy()

    def theta_at_s(self, s):
        """Motor angles at path coordinate s (m): exact IK (to round-off, or 1e-11 numerical), continued from the start pose.

        Parameters
        ----------
        s : float or array (...)
            Path coordinate in [0, travel_m], m.

        Returns
        -------
        array (..., 6)
            rad; ``theta_at_s(0) == start_q``.
        """
        s = self._check_s(s)
        flat = np.atleast_1d(s).ravel()
        principal = self._ik(flat)
        ref = np.stack([np.interp(flat, self._ref_s, self._ref_theta[:, j]) for j in range(6)], axis=-1)
        theta = principal + 2 * np.pi * np.round((ref - principal) / (2 * np.pi))
        theta[flat == 0.0] = self.start_q
        return theta.reshape(np.shape(s) + (6,))

    def theta(self, t):
        """Motor angles at time t (s), rad, shape (..., 6)."""
        return self.theta_at_s(self.s(t))

    def theta_dot(self, t):
        """Motor speeds at time t, rad/s, shape (..., 6): ``J(theta)^-1 [v d; 0]``."""
        th = self.theta(t)
        J = jacobian(self.robot, th)
        twist = np.concatenate([self.tcp_velocity(t), np.zeros(np.shape(th)[:-1] + (3,))], axis=-1)
        return np.linalg.solve(J, twist[..., None])[..., 0]

    def theta_table(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        """Motor angles on a uniform time grid, for fast interpolation in a time-domain simulation.

        Parameters
        ----------
        n : int
            Number of samples (>= 2), from t = 0 to t = duration_s inclusive.

        Returns
        -------
        t : array (n,)
            s.
        theta : array (n, 6)
            rad, exact IK at each sample (``np.interp(t_query, t, theta[:, j])`` per joint).
        """
        if int(n) < 2:
            raise PassError(f"theta_table needs n >= 2 samples, got {n}")
        t = np.linspace(0.0, self.duration_s, int(n))
        return t, self.theta(t)
