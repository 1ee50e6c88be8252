"""The measurement chain of a hammer test as FRF effects: channel calibration, DAQ delay, accelerometer mass.

These effects change what is measured, not the machine (``stage = "chain"``): identification reports
them, and the model TOML it writes does not hold them (the machine cuts without the accelerometer,
and the calibration of the rig is not a property of the robot). Each is a stage applied by
:func:`robolobes.identify.frf.predict` after the structural prediction (the "measured" stage,
:meth:`ChainEffect.measured`), per response channel of each pair (``PoseData.pair_channel``, from
:attr:`robolobes.linearize.frf_io.MeasuredPair.channel`: by default one channel per response direction).

============================  ==========================================================  ====================
effect                        measured FRF (model ``H``, ``w`` rad/s)                      bounds
============================  ==========================================================  ====================
``channel_scale``             ``H_meas[pair] = s_c H[pair]``, ``c`` the pair's channel       ``s_c`` in 0.7-1.3
``daq_delay``                 ``H_meas = exp(-i w tau) H``                                   ``tau`` +-200 us
``accelerometer_mass``        ``G' = G (I - w^2 m_a G)^-1`` at the TCP (point mass)          ``m_a`` in 0-0.1 kg
============================  ==========================================================  ====================

Calibration scale, and its gauge
--------------------------------
An FRF is response over force: a response channel ``c`` whose sensitivity is off by ``a_c`` and a
hammer whose force gauge is off by ``b`` give ``H_meas = (a_c / b) H`` on every pair of channel ``c``.
Only the ratios ``a_c / b`` enter an FRF, so a factor common to the hammer and every response
channel cancels: a scale per response channel *and* one for the hammer are not identifiable from
FRFs alone. The gauge chosen here: the hammer's force gauge is the reference (its factor fixed to 1)
and one scale ``s_c = a_c / b`` is fitted per response channel (``scale_x``, ``scale_y``, ``scale_z``,
the measurement frame's x, y, z). A hammer error alone shows as three equal scales ``1 / b``; one
accelerometer axis off as one scale off. A channel the set does not measure leaves its scale at 1,
undetermined (reported so). Bounds 0.7-1.3: calibration errors of accelerometers and hammers (a
data-sheet sensitivity, a cable, the hammer tip's mass) are a few per cent to ~15 %; beyond 30 % the
set has a wrong unit or channel, not a calibration error. Detection 1 %: a calibrated sensor's own
sensitivity is known to about that (a comparison calibration at its reference frequency), so a scale
within 1 % of 1 is not an error of the chain; the errors a hammer test meets start at a few per cent,
and a 1-3 % line noise over thousands of lines resolves far less than 1 % (a fitted scale's standard
deviation is a few 1e-4 on the six-pose sets of the tests).

DAQ delay
---------
A pure delay between response and force channels (different anti-alias filters, multiplexed ADCs, a
sigma-delta converter's group delay on one channel type): ``H_meas = H exp(-i w tau)``, ``tau > 0`` the
response late. It leaves ``|H|`` unchanged: its signature is a phase residual linear in ``w``, the same
in every pair and pose (``phase_slope``), not a peak height or a frequency shift. Bounds +-200 us:
one sample at 5 kHz; the group-delay mismatch of two anti-alias filters of a few kHz cutoff is tens of
us; more is a wrongly paired channel. Detection 5 us: at 300 Hz a phase of 0.009 rad, ~1 % of ``|H|``,
the line noise of a good set. Below a filter's cutoff its phase is nearly linear, so a filter mismatch
shows as this delay.

Accelerometer mass
------------------
The accelerometer (with its base or wax) is a point mass ``m_a`` glued at the response point, the TCP,
where the hammer also strikes. The structural-modification (mass-loading) closed form: with ``G`` (3, 3)
the TCP's driving-point receptance (base axes), the added inertial force ``w^2 m_a x`` gives
``x = G (f + w^2 m_a x)``, so ``G' = G (I - w^2 m_a G)^-1``; a driving point ``H' = H / (1 - w^2 m_a H)``
(one direction); a cross FRF needs the whole driving-point matrix at the response point. On a 1-DOF
oscillator it is ``1 / (k - w^2 (m + m_a) + i w c)``: the natural frequency falls to
``sqrt(k / (m + m_a)) / 2 pi`` (tests/test_identify_chain.py). Assumptions: one accelerometer (a
triaxial one) stays at the TCP for every pair; its rotary inertia (``m_a r^2``, ``r`` ~ 1 cm) is
neglected. Bounds 0-0.1 kg: hammer-test accelerometers weigh 1-30 g, with a magnet base up to ~50 g.

It is not a default candidate (``candidate = False``), for two reasons. (1) The closed form needs the
driving-point receptance at the response point in every direction; the model supplies ``G`` on every
line, but a set measures only some of its pairs, and a mass fitted through unmeasured driving points
rests on the model alone: identify refuses the effect (BadInput) for a set that does not measure the
driving point ``(c, c)`` of each response channel at each pose. (2) Observability: ``m_a`` changes the
receptance by about ``m_a / m_eff``, ``m_eff`` the modal mass at the TCP: tens of kg for a robot's own
modes, so 20 g is ~0.1 %, below a 1-3 % line noise; on a light tool mode it moves that mode by
``sqrt(m / (m + m_a))``, which a mode fitted at the same time absorbs (a mass-loaded mode is a mode at a
lower frequency). Name it with ``--effects`` for a model that already holds the tool mode.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from robolobes.core.errors import BadInput

from .effects import Parameter, register
from .structural import PoseMatrices, StructuralEffect

__all__ = ["ChainEffect", "ChannelScaleEffect", "DaqDelayEffect", "AccelerometerMassEffect", "CHANNELS",
           "mass_loaded", "check_driving_points"]

CHANNELS = ("x", "y", "z")   # response channels: the measurement frame's axes (cut frame: feed, normal, axial)

#: ``point()`` -> the model's TCP receptance (F, 3, 3), base axes, m/N, on the pose's lines ``omega``.
PointReceptance = Callable[[], np.ndarray]


class ChainEffect(StructuralEffect):
    """A stage of the measurement chain seen by an FRF set: it does not change the machine (``perturb``
    is the identity) but what is measured on the pose's lines (:meth:`measured`).

    ``order``: stages apply in increasing order (the accelerometer's mass acts on the structure, before
    the sensors' scale and delay, which commute)."""

    stage = "chain"
    order = 1

    def perturb(self, pm: PoseMatrices, params: dict) -> PoseMatrices:
        return pm

    def measured(self, pose, H: np.ndarray, params: dict, point: PointReceptance) -> np.ndarray:
        """The measured receptance (N,) of ``pose`` (an :class:`identify.frf.PoseData`) from the model's
        ``H`` (N,) on its lines, m/N; ``point`` gives the model's TCP receptance when a stage needs it."""
        raise NotImplementedError


def _line_channel(pose) -> np.ndarray:
    """Response channel (0, 1, 2) of each line of ``pose`` (N,)."""
    return np.asarray(pose.pair_channel, dtype=int)[pose.pair]


class ChannelScaleEffect(ChainEffect):
    name = "channel_scale"
    doc = ("Calibration of the response channels against the hammer: H_meas = s_c H on the pairs of response "
           "channel c (frame x, y, z); the hammer's force gauge is the reference (a common factor of all "
           "channels and the hammer is not identifiable from FRFs: a hammer error shows as three equal scales).")
    parameters = tuple(
        Parameter(f"scale_{c}", 0.7, 1.3, neutral=1.0, detect=0.01,
                  doc=f"response channel {c} over the hammer: calibration errors are a few to ~15 %; beyond "
                      "30 % a wrong unit or channel")
        for c in CHANNELS)
    observed_by = {"frf": "every pair of one response channel off by the same real factor at every line and "
                          "pose, >~1 % (the receptance's shape and phase unchanged)"}
    # a real, frequency-independent ratio confined to one channel's pairs, over all poses: not a
    # peak height (that changes one mode's band only) nor a static offset (an additive compliance)
    signatures = ("channel_ratio",)

    def measured(self, pose, H, params, point):
        s = np.array([params[f"scale_{c}"] for c in CHANNELS])
        return H * s[_line_channel(pose)]

    def guesses(self, diagnosis):
        return [{f"scale_{c}": 1.0 for c in CHANNELS}]


class DaqDelayEffect(ChainEffect):
    name = "daq_delay"
    doc = "A pure delay of the response channels against the force channel: H_meas = exp(-i w tau) H."
    parameters = (Parameter("delay_s", -200e-6, 200e-6, neutral=0.0, detect=5e-6,
                            doc="tau > 0: the response lags; anti-alias / ADC group-delay mismatch is tens of us, "
                                "one sample at 5 kHz is 200 us, more is a wrongly paired channel"),)
    observed_by = {"frf": "a phase error growing linearly with frequency, the same in every pair and pose, "
                          "|tau| >~ 5 us at 1-3 % line noise up to 300 Hz (w tau ~ 1 % of |H|)"}
    # |H| unchanged: a phase residual linear in w, common to all pairs and poses
    signatures = ("phase_slope",)

    def measured(self, pose, H, params, point):
        return H * np.exp(-1j * pose.omega[pose.index] * params["delay_s"])

    def guesses(self, diagnosis):
        return [{"delay_s": 0.0}]


def mass_loaded(G: np.ndarray, omega: np.ndarray, mass_kg: float) -> np.ndarray:
    """The point receptance (F, 3, 3) with a point mass ``mass_kg`` added at the point:
    ``G (I - w^2 m G)^-1`` (module doc); ``G`` (F, 3, 3) m/N, ``omega`` (F,) rad/s."""
    eye = np.eye(G.shape[-1])
    return np.linalg.solve((eye[None] - (omega ** 2 * mass_kg)[:, None, None] * G).transpose(0, 2, 1),
                           G.transpose(0, 2, 1)).transpose(0, 2, 1)


class AccelerometerMassEffect(ChainEffect):
    name = "accelerometer_mass"
    order = 0           # on the structure: before the sensors' scale and delay
    candidate = False   # needs measured driving points, and resolves only on a light TCP mode (module doc)
    doc = ("The accelerometer's mass at the TCP during the hammer test: G' = G (I - w^2 m_a G)^-1 with G the "
           "TCP's driving-point receptance (a point mass; not written to the model, the machine cuts without it).")
    parameters = (Parameter("mass_kg", 0.0, 0.1, neutral=0.0, detect=0.005,
                            doc="hammer-test accelerometers weigh 1-30 g, with a magnet base up to ~50 g"),)
    observed_by = {"frf": "a light mode at the TCP (a tool mode in the model) lowered by sqrt(m / (m + m_a)) at "
                          "every pose; on the robot's own modes (modal mass tens of kg) 20 g changes the receptance "
                          "by ~0.1 %, below 1-3 % line noise"}
    # the driving point's poles lowered, by the same ratio at every pose on a tool mode
    signatures = ("uniform_shift",)

    def measured(self, pose, H, params, point):
        Gp = mass_loaded(point(), pose.omega, params["mass_kg"])            # (F, 3, 3)
        return np.einsum("na,nab,nb->n", pose.out_vec, Gp[pose.index], pose.in_vec)

    def guesses(self, diagnosis):
        return [{"mass_kg": m} for m in (0.005, 0.02, 0.05)]


def check_driving_points(measurement, effects) -> None:
    """BadInput when ``accelerometer_mass`` is among ``effects`` and some pose of ``measurement`` (an
    :class:`~robolobes.linearize.frf_io.FRFSet`) lacks the driving point ``(c, c)`` of one of its
    response channels ``c``."""
    if not any(isinstance(e, AccelerometerMassEffect) for e in effects):
        return
    for pf in measurement.poses:
        driven = {p.out_axis for p in pf.pairs if p.out_axis == p.in_axis}
        missing = sorted({p.response_channel for p in pf.pairs} - driven)
        if missing:
            raise BadInput(f"--effects accelerometer_mass: pose {pf.pose} does not measure the driving point of "
                           f"response channel(s) {', '.join(CHANNELS[c] for c in missing)}; the mass-loading formula "
                           "needs each channel's driving-point FRF (measure it, or leave accelerometer_mass out)")


register(ChannelScaleEffect())
register(DaqDelayEffect())
register(AccelerometerMassEffect())
