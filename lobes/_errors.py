"""Errors of the lobes package."""

from __future__ import annotations

from robolobes.core.errors import BadInput

__all__ = ["LobeError"]


class LobeError(BadInput):
    """Bad input to a stability computation: names the bad value and what would be valid."""
