"""Mean cutting force over a spindle revolution, and the static TCP deflection it causes.

The force law is :mod:`robolobes.cases.milling` (``edge_forces``, ``tool_force_cut_frame``); this
module only averages it. Tooth ``j`` cuts the static chip ``h_j sin(phi)`` (``h_j`` from
:func:`cases.milling.regeneration`: pitch and runout) over the engagement ``[phi_st, phi_ex]``, so
the mean force on the tool over one revolution is::

    F = (a_p / 2 pi) sum_j integral_{phi_st}^{phi_ex} f(phi, h_j sin phi) d phi

A helix only shifts each axial slice's phase, which leaves the revolution mean unchanged. The
integrand is a trigonometric polynomial of degree 2 on the engagement (plus the constant edge
force), so Gauss-Legendre with 32 points is exact to rounding.
"""

from __future__ import annotations

import math

import numpy as np

from robolobes.cases.milling import Cut, CuttingLaw, Tool, edge_forces, engagement_rad, regeneration, \
    tool_force_cut_frame

__all__ = ["mean_force_cut_frame", "static_deflection"]


def mean_force_cut_frame(tool: Tool, cut: Cut, law: CuttingLaw, n_gauss: int = 32) -> np.ndarray:
    """Mean force on the tool over one revolution, cut frame ``(x_c, y_c, z_c)``, (3,), N.

    Uses the cut's axial depth ``ap_m``, radial depth, mode and feed per tooth.
    """
    st, ex = engagement_rad(tool, cut)
    x, w = np.polynomial.legendre.leggauss(n_gauss)
    phi = st + (x + 1.0) * 0.5 * (ex - st)
    wts = w * 0.5 * (ex - st)
    total = np.zeros(3)
    for tooth in regeneration(tool, cut):
        if not tooth.cuts:
            continue
        h = tooth.chip_m * np.sin(phi)
        f = tool_force_cut_frame(phi, edge_forces(h, cut.ap_m, law))  # (q, 3)
        total += wts @ f
    return total / (2 * math.pi)


def static_deflection(compliance_cut: np.ndarray, force_cut: np.ndarray) -> np.ndarray:
    """TCP deflection ``C F`` (3,), m, cut frame, under the force ``F`` on the tool (3,), N, with
    the static TCP compliance ``C`` (3, 3), m/N, in the same frame (``LinearModel.compliance``)."""
    return np.asarray(compliance_cut, dtype=float) @ np.asarray(force_cut, dtype=float)
