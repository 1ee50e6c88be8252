"""Errors of the lobes package."""

from __future__ import annotations

__all__ = ["LobeError"]


class LobeError(ValueError):
    """Bad input to a stability computation: names the bad value and what would be valid."""
