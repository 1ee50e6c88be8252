"""The largest kick the gated rule calls linear (timedomain/rate.py), against its closed form."""

from __future__ import annotations

import math

from robolobes.timedomain.rate import linear_kick_amplitude_m
from robolobes.timedomain.verdict import LOSS_LIMIT, ChipScale


def test_linear_kick_is_half_the_amplitude_that_loses_the_gate_s_share_of_the_chip():
    # arc [phi_st, pi] (down-milling): the chip h sin(phi) is below a over phi in [pi - asin(a/h), pi],
    # weight 1 - sqrt(1 - (a/h)^2) of the total 1 + cos(phi_st). Solved for a: the closed form below.
    phi_st, h_small = 1.7721542475852272, 3.8e-5
    chip = ChipScale(delays_s=(0.01, 0.01), max_chip_m=(5.2e-5, h_small), arc_rad=(phi_st, math.pi))
    a = h_small * math.sqrt(1 - (1 - LOSS_LIMIT * (1 + math.cos(phi_st))) ** 2)
    assert math.isclose(linear_kick_amplitude_m(chip), a / 2, rel_tol=2e-3)
