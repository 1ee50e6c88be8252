"""The one FRF type of robolobes (python-control layout), used by linearize, lobes and identify.

Convention: ``H`` is complex ``(n_out, n_in, n_freq)`` in m/N (receptance: displacement per unit
force), ``omega`` in rad/s, and every FRF says the frame its axes refer to (``"base"``: the robot
base; ``"cut"``: x_c along the feed, y_c normal, z_c axial, :mod:`robolobes.cases.milling`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .errors import BadInput
from .validate import readonly

__all__ = ["FRF", "CUT_LABELS", "BASE_LABELS"]

BASE_LABELS = ("x", "y", "z")
CUT_LABELS = ("feed", "normal", "axial")


@dataclass(frozen=True)
class FRF:
    """Tool-tip receptance, python-control layout.

    Attributes
    ----------
    omega : array (F,), rad/s
    H : complex array (n_out, n_in, F), m/N
        ``H[i, j, f]``: displacement along axis i per unit force along axis j at ``omega[f]``.
    frame : str
        Name of the frame the axes refer to (``"base"`` or ``"cut"``).
    axes : array (n_out, 3) or None
        Rows: the frame's unit axes in base coordinates, when known (None for a structure given
        directly in the cut frame, e.g. hammer-test modes).
    labels : tuple of str
        Axis names.
    """

    omega: np.ndarray
    H: np.ndarray
    frame: str
    axes: np.ndarray | None = None
    labels: tuple[str, ...] = BASE_LABELS

    def __post_init__(self):
        omega = readonly(self.omega, float)
        H = readonly(self.H, complex)
        if omega.ndim != 1 or H.ndim != 3 or H.shape[2] != omega.shape[0]:
            raise BadInput(f"FRF needs omega (F,) and H (n_out, n_in, F); got omega {omega.shape}, H {H.shape}")
        if not isinstance(self.frame, str) or not self.frame:
            raise BadInput(f"FRF frame must be a non-empty name (e.g. 'base', 'cut'), got {self.frame!r}")
        object.__setattr__(self, "omega", omega)
        object.__setattr__(self, "H", H)
        if self.axes is not None:
            object.__setattr__(self, "axes", readonly(self.axes, float))

    @property
    def freq_hz(self) -> np.ndarray:
        """``omega / 2 pi``, Hz, (F,)."""
        return self.omega / (2 * math.pi)

    def to_control(self):
        """The FRF as a ``control.FrequencyResponseData`` (omega in rad/s)."""
        import control

        return control.frd(np.asarray(self.H), np.asarray(self.omega))
