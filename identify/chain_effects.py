"""The measurement chain of a hammer test as FRF effects: channel calibration, DAQ delay, accelerometer mass.

These effects change what is measured, not the machine (``stage = "chain"``): identification reports
them, and the model TOML it writes does not contain them (the machine cuts without the accelerometer,
and the calibration of the test rig is not a property of the robot). Each acts on the model's
receptance on the measured lines (:meth:`FrfChainEffect.measured`, applied by
:func:`robolobes.identify.frf.predict` after the structural effects), except the accelerometer's mass,
which is physically on the structure during the test and so perturbs the pose's matrices.

============================  =================================================  ==========================
effect                        measured FRF (model ``H``, ``w`` rad/s)             bounds, and why
============================  =================================================  ==========================
``channel_scale``             ``H_meas[o, i] = s_o H[o, i]``, ``o`` the response  ``s_o`` in [0.7, 1.3]
                              channel (the measurement frame's x, y, z)
``daq_delay``                 ``H_meas = exp(-i w tau) H``                         ``tau`` in [-200, 200] us
``accelerometer_mass``        ``M' = M + m_a J^T J`` (a point mass at the TCP)     ``m_a`` in [0, 0.1] kg
============================  =================================================  ==========================

Calibration scale, and its gauge
--------------------------------
An FRF is response over force: a response channel ``o`` whose sensitivity is off by ``a_o`` and a hammer
off by ``b`` give ``H_meas[o, i] = (a_o / b) H[o, i]``. Over a set of poses x pairs only the ratios
``a_o / b`` enter: a factor common to the hammer and every response channel cancels, so one scale per
response channel *and* one per hammer are not identifiable jointly. The gauge chosen here: the
hammer's factor is fixed to 1 and one scale ``s_o = a_o / b`` is fitted per response channel (three
parameters ``scale_x, scale_y, scale_z``, in the measurement frame: base x, y, z or cut feed, normal,
axial). A hammer error alone shows as the three equal (``s_o = 1 / b``); an error of one accelerometer
axis as one scale off. A set that lacks a channel leaves its scale undetermined (reported so).
Bounds 0.7-1.3: calibration errors of accelerometers and impact hammers (a wrong sensitivity from the
data sheet, a cable, the hammer tip's mass) are a few per cent to about 15 %; beyond 30 % the set is
not a calibration problem but a wrong unit or channel. Detection: 3 % (the lower end of the errors a
hammer test meets; a 1-3 % line noise over a few thousand lines resolves far less).

DAQ delay
---------
A pure delay between the response and the force channel (different anti-alias filters, multiplexed
ADCs, a sigma-delta converter's group delay on one channel type only): a phase linear in frequency.
``tau > 0``: the response lags. Bounds +-200 us: one sample at 5 kHz, and the group-delay mismatch of
two anti-alias filters of a few kHz cutoff is tens of us; a larger value is a wrongly paired channel,
not a delay. At 300 Hz, 50 us is a 5 degree phase error. Below a filter's cutoff its phase is close to
linear, so a filter mismatch shows as this delay.

Accelerometer mass
------------------
The accelerometer (with its base or magnet) is a point mass ``m_a`` at the TCP: ``M' = M + m_a J^T J``
on the pose's linearized model (``J`` the TCP's translational Jacobian, base axes), the exact element of
a point mass without rotary inertia (its rotary inertia, ``m_a r^2`` with ``r`` ~ 1 cm, is neglected).
On one driving point this is ``H' = H / (1 - w^2 m_a H)``; on a 1-DOF oscillator it moves the natural
frequency to ``sqrt(k / (m + m_a)) / 2 pi`` (tests/test_identify_chain.py). Assumption: one
accelerometer (a triaxial one, or one moved between directions with the same mass) stays at the TCP for
every pair. Bounds 0-0.1 kg: hammer-test accelerometers weigh 1-30 g, with a magnet base up to ~50 g.
It is *observable only where the TCP is light*: ``m_a`` changes the receptance by about ``m_a / m_eff``
with ``m_eff`` the modal mass at the TCP (tens of kg for a robot's own modes, so 20 g is ~0.1 % there:
at the edge of what a set resolves; on the bare TX200 it was named in one of five draws, the one with
1 % noise), and on a light tool mode it is indistinguishable from the mode's own mass (a mass-loaded mode is a
mode at a lower frequency). So it is not a default candidate (``candidate = False``): it is meant for a
model that already holds the tool mode (from an earlier measurement or the tool maker), where it is
the one effect that moves that mode by ``sqrt(m / (m + m_a))``; name it with ``--effects``.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .effects import Parameter, register
from .structural import PoseMatrices, StructuralEffect

__all__ = ["FrfChainEffect", "ChannelScaleEffect", "DaqDelayEffect", "AccelerometerMassEffect", "CHANNELS"]

CHANNELS = ("x", "y", "z")   # response channels: the measurement frame's axes (cut frame: feed, normal, axial)


class FrfChainEffect(StructuralEffect):
    """A stage of the measurement chain seen by an FRF set: it does not change the machine
    (``perturb`` is the identity) but what is measured on the pose's lines (:meth:`measured`)."""

    stage = "chain"

    def perturb(self, pm: PoseMatrices, params: dict) -> PoseMatrices:
        return pm

    def measured(self, pose, H: np.ndarray, params: dict) -> np.ndarray:
        """The measured receptance (N,) of ``pose`` (an :class:`identify.frf.PoseData`) from the
        model's ``H`` (N,) on its lines, m/N."""
        raise NotImplementedError


def _channels(pose) -> np.ndarray:
    """Response channel (0, 1, 2 = frame x, y, z) of each pair of ``pose`` (P,)."""
    ch = getattr(pose, "pair_channel", None)
    if ch is not None:
        return np.asarray(ch, dtype=int)
    return np.argmax(np.abs(pose.pair_out), axis=1)   # base frame: the direction is the axis


class ChannelScaleEffect(FrfChainEffect):
    name = "channel_scale"
    doc = ("Calibration of the response channels: H_meas = s_o H for response channel o (frame x, y, z); the "
           "hammer's factor is the gauge (fixed to 1: a hammer error shows as three equal scales).")
    parameters = tuple(
        Parameter(f"scale_{c}", 0.7, 1.3, neutral=1.0, detect=0.03,
                  doc=f"response channel {c} over the hammer: calibration errors are a few to ~15 %")
        for c in CHANNELS)
    observed_by = {"frf": "every pair of a response channel off by the same factor at every line and pose, "
                          ">~3 % (the receptance's shape unchanged)"}
    signatures = ("peak_height", "static_offset")

    def measured(self, pose, H, params):
        s = np.array([params[f"scale_{c}"] for c in CHANNELS])
        return H * s[_channels(pose)][pose.pair]

    def guesses(self, diagnosis):
        return [{f"scale_{c}": 1.0 for c in CHANNELS}]


class DaqDelayEffect(FrfChainEffect):
    name = "daq_delay"
    doc = "A pure delay of the response channel against the force channel: H_meas = exp(-i w tau) H."
    parameters = (Parameter("delay_s", -200e-6, 200e-6, neutral=0.0, detect=5e-6,
                            doc="tau > 0: the response lags; ADC / anti-alias group-delay mismatch is "
                                "tens of us, one sample at 5 kHz is 200 us"),)
    observed_by = {"frf": "a phase error growing linearly with frequency in every pair and pose, |tau| >~ 5 us "
                          "at 1-3 % line noise up to 300 Hz (w tau ~ 1 % of the phase)"}
    signatures = ("peak_height",)

    def measured(self, pose, H, params):
        return H * np.exp(-1j * pose.omega[pose.index] * params["delay_s"])

    def guesses(self, diagnosis):
        return [{"delay_s": 0.0}]


class AccelerometerMassEffect(FrfChainEffect):
    name = "accelerometer_mass"
    candidate = False   # observable only on a light TCP mode the model already holds (module doc)
    doc = ("The accelerometer's mass at the TCP during the hammer test: M' = M + m_a J^T J (a point mass; "
           "not written to the model, the machine cuts without it).")
    parameters = (Parameter("mass_kg", 0.0, 0.1, neutral=0.0, detect=0.005,
                            doc="hammer-test accelerometers weigh 1-30 g, with a magnet base up to ~50 g"),)
    observed_by = {"frf": "a light mode at the TCP (a tool mode in the model) shifted down by "
                          "sqrt(m / (m + m_a)) at every pose; on the robot's own modes (modal mass tens of kg) "
                          "20 g changes the receptance by ~0.1 %, at the edge of 1 % line noise"}
    signatures = ("uniform_shift",)

    def perturb(self, pm, params):
        return replace(pm, M=pm.M + params["mass_kg"] * pm.J.T @ pm.J)

    def measured(self, pose, H, params):
        return H

    def guesses(self, diagnosis):
        return [{"mass_kg": m} for m in (0.005, 0.02, 0.05)]


register(ChannelScaleEffect())
register(DaqDelayEffect())
register(AccelerometerMassEffect())
