"""The stability problem: a structure, a tool, a cut and a cutting law."""

from __future__ import annotations

from dataclasses import dataclass

from robolobes.cases.milling import Cut, CuttingLaw, MillingError, Tool, check_cut

from ._errors import LobeError
from .measured import MeasuredStructure
from .structure import ModalStructure, PhysicalStructure, ReducedStructure, StateSpace, Structure

__all__ = ["LobeProblem"]


@dataclass(frozen=True, eq=False)
class LobeProblem:
    """Everything the stability of one cut depends on.

    Sweeps are made with :func:`dataclasses.replace`, e.g.
    ``replace(problem, cut=replace(problem.cut, spindle_rpm=12000.0))``.

    Parameters
    ----------
    structure : PhysicalStructure, ModalStructure, ReducedStructure, StateSpace, control.StateSpace or MeasuredStructure
        The tool tip's dynamics in the cut frame. A ``control.StateSpace`` (inputs: force x_c, y_c[, z_c],
        N; outputs: displacement, m; ``D = 0``) is converted by :meth:`StateSpace.from_control`. A
        :class:`MeasuredStructure` (an FRF with no model) serves the zero-order method only.
    tool : cases.milling.Tool
    cut : cases.milling.Cut
        Radial depth, mode (up/down), spindle speed and axial depth of the operating point; the
        feed per tooth matters only through runout (which teeth cut, :func:`cases.milling.regeneration`).
    law : cases.milling.CuttingLaw
        Only the cutting coefficients ``Ktc, Krc, Kac`` enter the linear stability.
    """

    structure: Structure | MeasuredStructure
    tool: Tool
    cut: Cut
    law: CuttingLaw

    def __post_init__(self) -> None:
        if type(self.structure).__name__ == "StateSpace" and type(self.structure).__module__.startswith("control"):
            object.__setattr__(self, "structure", StateSpace.from_control(self.structure))
        if not isinstance(self.structure, (PhysicalStructure, ModalStructure, ReducedStructure, StateSpace,
                                           MeasuredStructure)):
            raise LobeError(
                f"structure must be a PhysicalStructure, ModalStructure, ReducedStructure, StateSpace, "
                f"control.StateSpace or MeasuredStructure, got {type(self.structure).__name__}"
            )
        for name, typ in (("tool", Tool), ("cut", Cut), ("law", CuttingLaw)):
            if not isinstance(getattr(self, name), typ):
                raise LobeError(f"{name} must be a cases.milling.{typ.__name__}, got {type(getattr(self, name)).__name__}")
        try:
            check_cut(self.tool, self.cut)
        except MillingError as e:
            raise LobeError(str(e)) from None
