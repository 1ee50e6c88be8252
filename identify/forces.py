"""Cutting-force sets, force statistics and stability observations (owned by the "forces" work).

Stub of the contract :mod:`identify.api` dispatches to; each function raises NotImplementedError
until the force pipeline lands. Readers take the path of the set (directory or file) and return a
measurement object with at least ``kind``, ``path``, ``case`` (name in the file, or None) and
``variant`` (or None); pipelines take ``(measurement, model: ModelState, *, alpha, max_effects,
progress)`` and return an :class:`identify.result.Identification`.
"""

from __future__ import annotations

__all__ = ["read_forces", "read_force_stats", "read_stability", "identify_forces", "identify_force_stats",
           "identify_stability"]


def _todo(what):
    raise NotImplementedError(f"{what} is not implemented yet")


def read_forces(path):
    _todo("reading a cutting-force set")


def read_force_stats(path):
    _todo("reading force statistics")


def read_stability(path):
    _todo("reading stability observations")


def identify_forces(measurement, model, **kw):
    _todo("identification from a cutting-force set")


def identify_force_stats(measurement, model, **kw):
    _todo("identification from force statistics")


def identify_stability(measurement, model, **kw):
    _todo("identification from stability observations")
