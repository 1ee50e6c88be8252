"""One model and one linearization per (robot, variant, damping scale, pose), shared by the study.

The modes, the FRFs, the operating points, the lobe diagrams, the lowest limits and the damping
search all need the robot linearized at the same few poses; before, each section built and
linearized its own copy (up to six linearizations of one (variant, pose)). :class:`Linearizations`
builds each robot once and linearizes it once per pose; ``share=False`` turns the sharing off (the
old behaviour, for ``bench/bench_study.py``).
"""

from __future__ import annotations

import numpy as np

from robolobes.linearize.linear import linearize
from robolobes.linearize.model import build_model

__all__ = ["Linearizations"]


class Linearizations:
    """Cache of built robots, their linearizations and cut-frame structures.

    Robots are keyed by their specification object (the study gives both cases the same one when
    their robots are equal), the variant and the damping scale; linearizations additionally by the
    pose's name, whose motor angles must not change between calls.

    Attributes
    ----------
    share : bool
        False: build and linearize anew at every call (the behaviour before sharing).
    linearize_calls : int
        How many linearizations were computed (cache misses).
    """

    def __init__(self, share: bool = True):
        self.share = share
        self.linearize_calls = 0
        self._robots: dict = {}
        self._lins: dict = {}
        self._structures: dict = {}
        self._specs: list = []  # keeps the keyed specification objects alive (their id is the key)

    def _spec_key(self, spec) -> int:
        if not any(s is spec for s in self._specs):
            self._specs.append(spec)
        return id(spec)

    def robot(self, spec, variant: str, damping_scale: float = 1.0):
        """The built :class:`FlexibleRobot` of ``spec`` (``build_model(spec, variant, damping_scale=...)``)."""
        key = (self._spec_key(spec), variant, float(damping_scale))
        if not self.share or key not in self._robots:
            self._robots[key] = build_model(spec, variant, damping_scale=damping_scale)
        return self._robots[key]

    def at(self, spec, variant: str, pose: str, theta_rad: np.ndarray, damping_scale: float = 1.0):
        """The :class:`LinearModel` of the robot at the motor angles ``theta_rad`` (6,), rad, named ``pose``."""
        key = (self._spec_key(spec), variant, float(damping_scale), pose)
        if self.share and key in self._lins:
            lin = self._lins[key]
            if not np.array_equal(np.asarray(lin.theta), np.asarray(theta_rad, dtype=float)):
                raise ValueError(f"pose {pose!r} was linearized at other motor angles")
            return lin
        self.linearize_calls += 1
        lin = linearize(self.robot(spec, variant, damping_scale), theta_rad)
        self._lins[key] = lin
        return lin

    def structure(self, case, variant: str, pose: str, theta_rad: np.ndarray, damping_scale: float = 1.0):
        """``(LinearModel, PhysicalStructure)`` of ``case``'s robot in the cut frame of its feed."""
        from robolobes.lobes.structure import PhysicalStructure

        lin = self.at(case.robot, variant, pose, theta_rad, damping_scale)
        key = (id(lin), tuple(np.asarray(case.cut.feed_direction, dtype=float)))
        if not self.share or key not in self._structures:
            self._structures[key] = PhysicalStructure.from_linear(lin, case.cut.feed_direction)
        return lin, self._structures[key]
