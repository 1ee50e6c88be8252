"""The one stability verdict of robolobes, used by the lobes and the time domain alike.

A :class:`Verdict` is ``"stable"``, ``"unstable"`` or ``"undetermined"``, always with a ``reason`` in
words (what decided it, or what is missing to decide, e.g. the discretization error bound of the
lobes straddling the cut depth, or a window too short for the time domain). JSON outputs write the
``status`` string as ``"verdict"`` and keep ``"stable"`` as ``true`` / ``false`` / ``null``
(:meth:`Verdict.to_json`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

__all__ = ["Verdict", "STATUSES"]

Status = Literal["stable", "unstable", "undetermined"]
STATUSES: tuple[str, ...] = ("stable", "unstable", "undetermined")


@dataclass(frozen=True)
class Verdict:
    """Stable, unstable or undetermined, and why.

    Attributes
    ----------
    status : {"stable", "unstable", "undetermined"}
    reason : str
        What decided the status, or what would be needed to decide (one sentence, numbers in SI or
        with their unit in words).
    """

    status: Status
    reason: str = ""

    def __post_init__(self):
        if self.status not in STATUSES:
            raise ValueError(f"verdict status must be one of {', '.join(STATUSES)}, got {self.status!r}")
        if not isinstance(self.reason, str):
            raise TypeError(f"verdict reason must be a string, got {type(self.reason).__name__}")

    @property
    def stable(self) -> bool | None:
        """True, False, or None when undetermined."""
        return {"stable": True, "unstable": False}.get(self.status)

    def __bool__(self) -> bool:  # a Verdict is not a boolean: `if verdict:` would read "undetermined" as True
        raise TypeError("use verdict.stable (True/False/None) or verdict.status, not bool(verdict)")

    def to_json(self) -> dict:
        """``{"verdict": status, "stable": true/false/null, "verdict_reason": reason}``."""
        return {"verdict": self.status, "stable": self.stable, "verdict_reason": self.reason}

    @classmethod
    def from_stable(cls, stable: bool | None, reason: str = "") -> "Verdict":
        """From True / False / None."""
        status: dict[bool | None, Status] = {True: "stable", False: "unstable", None: "undetermined"}
        return cls(status[stable], reason)
