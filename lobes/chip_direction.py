"""The tilt of the regenerated surface: the feed's first-order correction to the dynamic chip.

The linear model of the lobes measures the dynamic chip along the ray of the edge,
``u = (sin phi, cos phi)`` in the cut frame ``(x_c, y_c)``: ``h = h_j sin(phi) + u . (r(t) - r(t - tau_j))``.
In the eroded part (:mod:`timedomain.workpiece`) the chip is the distance along that ray to the surface
the previous tooth left, and that surface is not normal to the ray: to first order in ``h_j / R``

* the ray meets the previous tooth's path (a circle about the centre ``h_j`` behind) where that tooth's
  own ray was turned by ``psi - phi = (h_j / R) cos(phi)``;
* the path is a trochoid: its tip velocity ``R Omega du/dphi + v x_c`` turns its normal by
  ``-(v / (R Omega)) sin(phi)`` from that tooth's ray, ``v / Omega = fz N / (2 pi)`` the feed per radian.

A displacement of the tool (or of the surface) moves the chip by its component along the surface normal
``n`` divided by ``u . n``, i.e. along::

    g = u + alpha du/dphi,      alpha = (h_j / R) cos(phi) - (fz N / (2 pi R)) sin(phi)

(a rotation of the chip's direction by ``alpha``, which is what :meth:`Workpiece.chip` returns as the
derivative of its chip in the tool centre; ``tests/test_lobes_chip_direction.py`` checks it there). It
multiplies the regenerative difference, like ``u``. It is of the relative order ``fz / R`` (0.006 in the
TX200 aluminium cut) but turns ``u`` towards the direction whose directional matrix does not cancel over
the engagement, so it moves the exponent near that cut's limit by 1.6-2.1 1/s per mm of feed
(``bench/bench_timedomain_chip_direction.py``).

The delayed instant (optional, :func:`delay_advance_rad`): the previous tooth reached the angle ``psi``
where it cut the point ``(psi - phi) / Omega = (h_j / (R Omega)) cos(phi)`` after ``t - tau_j``, so the
delayed displacement is taken at ``t - tau_j + (h_j / (R Omega)) cos(phi)`` (a shorter delay where
``cos(phi) > 0``). At a chatter frequency well below the tooth frequency this scales the regenerative
difference by ``1 - (fz N / (2 pi R)) cos(phi)`` (5-7 % of the tilt's effect on aluminium); at a flip it
is a phase. ``delay_time=True`` of :meth:`lobes.sdm.SDMEngine.monodromy_dense` and
:func:`lobes.entry_shift.entry_shift_exponent` carries it (default off).
"""

from __future__ import annotations

import math

import numpy as np

from robolobes.cases.milling import Cut, Tool

__all__ = ["surface_rotation_rad", "feed_per_radian_m", "delay_advance_rad"]


def feed_per_radian_m(tool: Tool, cut: Cut) -> float:
    """The feed per radian of spindle rotation ``v / Omega = fz N / (2 pi)``, m/rad."""
    return cut.feed_per_tooth_m * tool.teeth / (2 * math.pi)


def surface_rotation_rad(phi_rad, chip_m: float, radius_m: float, feed_per_rad_m: float) -> np.ndarray:
    """The angle ``alpha`` (rad, shape of ``phi_rad``) by which the chip's sensitivity to the
    displacement turns from the ray ``u`` towards ``du/dphi`` (module docstring).

    Parameters
    ----------
    phi_rad : array
        Edge angles, rad.
    chip_m : float
        Static chip ``h_j`` of the tooth (the feed between it and the tooth it regenerates on), m.
    radius_m : float
        Tool radius, m.
    feed_per_rad_m : float
        Feed per radian of spindle rotation, m/rad (:func:`feed_per_radian_m`).
    """
    phi = np.asarray(phi_rad, dtype=float)
    return (chip_m * np.cos(phi) - feed_per_rad_m * np.sin(phi)) / radius_m


def delay_advance_rad(phi_rad, chip_m: float, radius_m: float) -> np.ndarray:
    """The spindle angle ``(h_j / R) cos(phi)`` (rad, shape of ``phi_rad``) by which the previous tooth
    cut the point the edge at ``phi`` cuts later than ``t - tau_j`` (its time over ``Omega``): that tooth's
    angle there is ``psi = phi + (h_j / R) cos(phi)`` (module docstring, first order in ``h_j / R``).
    ``chip_m``: the tooth's static chip ``h_j``, m; ``radius_m``: the tool radius, m."""
    return chip_m * np.cos(np.asarray(phi_rad, dtype=float)) / radius_m
