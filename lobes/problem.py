"""The stability problem: a structure, a tool, a cut and a cutting law."""

from __future__ import annotations

from dataclasses import dataclass

from robolobes.cases.milling import Cut, CuttingLaw, MillingError, Tool, check_cut

from ._errors import LobeError
from .structure import ModalStructure, PhysicalStructure, ReducedStructure, Structure

__all__ = ["LobeProblem"]


@dataclass(frozen=True, eq=False)
class LobeProblem:
    """Everything the stability of one cut depends on.

    Sweeps are made with :func:`dataclasses.replace`, e.g.
    ``replace(problem, cut=replace(problem.cut, spindle_rpm=12000.0))``.

    Parameters
    ----------
    structure : PhysicalStructure, ModalStructure or ReducedStructure
        The tool tip's dynamics in the cut frame.
    tool : cases.milling.Tool
    cut : cases.milling.Cut
        Radial depth, mode (up/down), spindle speed and axial depth of the operating point; the
        feed per tooth matters only through runout (which teeth cut, :func:`cases.milling.regeneration`).
    law : cases.milling.CuttingLaw
        Only the cutting coefficients ``Ktc, Krc, Kac`` enter the linear stability.
    """

    structure: Structure
    tool: Tool
    cut: Cut
    law: CuttingLaw

    def __post_init__(self) -> None:
        if not isinstance(self.structure, (PhysicalStructure, ModalStructure, ReducedStructure)):
            raise LobeError(
                f"structure must be a PhysicalStructure, ModalStructure or ReducedStructure, "
                f"got {type(self.structure).__name__}"
            )
        for name, typ in (("tool", Tool), ("cut", Cut), ("law", CuttingLaw)):
            if not isinstance(getattr(self, name), typ):
                raise LobeError(f"{name} must be a cases.milling.{typ.__name__}, got {type(getattr(self, name)).__name__}")
        try:
            check_cut(self.tool, self.cut)
        except MillingError as e:
            raise LobeError(str(e)) from None
