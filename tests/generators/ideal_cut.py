"""The eroded part's chip and its derivative in the tool centre during a vibration-free straight cut
(:class:`timedomain.workpiece.Workpiece`, its exact ray walk), for the tilt of the regenerated surface
(lobes/chip_direction.py): used by tests/test_lobes_chip_direction.py and
bench/bench_timedomain_chip_direction.py."""

from __future__ import annotations

import math

import numpy as np

from robolobes.lobes.chip_direction import feed_per_radian_m
from robolobes.timedomain.workpiece import Workpiece


def chip_jacobians(tool, cut, angles_deg, revs=3, chord_tol_m=1e-10):
    """``(h, dh/dc)`` (m, shape (2,)) of each tooth at the integer edge angles ``angles_deg`` during the
    last of ``revs`` revolutions of a cut without vibration in 1 deg steps, as a run evaluates them:
    at a step's end, before that step's removal. Straight tool (one disc), tooth angles whole degrees;
    the tool centre starts 4 mm inside a 10 mm part (the first revolution cuts the block's edge).
    Returns a dict ``(tooth, deg) -> (h, dh/dc)``."""
    R, om = tool.radius_m, cut.omega_rad_s
    v = feed_per_radian_m(tool, cut) * om
    x0 = 4e-3
    wp = Workpiece(tool, cut, x_entry_m=0.0, part_length_m=10e-3, discs=1, dx_m=1e-6, chord_tol_m=chord_tol_m)
    th = np.radians(np.round(np.degrees(tool.tooth_angle_rad)))
    th_deg = np.round(np.degrees(th)).astype(int)
    rad = np.full(tool.teeth, R)
    out = {}
    for i in range(360 * revs):
        a0, a1 = math.radians(i), math.radians(i + 1)
        c0, c1 = np.array([x0 + v * a0 / om, 0.0]), np.array([x0 + v * a1 / om, 0.0])
        ph1 = (a1 + th)[:, None]
        if i >= 360 * (revs - 1):
            for j in range(tool.teeth):
                deg = int((i + 1 + th_deg[j]) % 360)
                if deg in angles_deg:
                    h, d = wp.chip(c1, ph1, rad)
                    out[(j, deg)] = (float(h[j, 0]), d[j, 0].copy())
        wp.remove(c0, c1, (a0 + th)[:, None], ph1, rad)
    return out
