"""Stability lobe diagrams of milling: semi-discretization and zero-order approximation.

Problem / method / solve, in the spirit of SciML::

    problem = LobeProblem(structure, tool, cut, law)          # cases.milling objects, SI units
    result = solve(problem, speeds_rpm=np.linspace(5e3, 25e3, 200))   # RefinedSDM(): error < 1 %
    point = stability(problem)                                # at problem.cut, same rule, decided

``structure`` is a :class:`PhysicalStructure` (M, C, K, tcp rows in the cut frame; from a robot
with :meth:`PhysicalStructure.from_linear`), a :class:`ModalStructure` (hammer-test modes) or a
:class:`ReducedStructure` (modal truncation with its error report; :func:`reduced_basis` and
:func:`basis_for` make one by a loop-perturbation rule with a static residual mode). Methods:
:class:`RefinedSDM` (the default: SDM levels refined per speed until the error estimate is below
1 %, :mod:`lobes.refine`), :class:`SemiDiscretization` (one level of the first-order SDM, or the
exact-free-decay scheme), :class:`ZeroOrder` (Altintas-Budak) and :class:`Collocation` (force
collocation on the cutting intervals, :mod:`lobes.collocation`; a second method, not the default). Conventions: :mod:`cases.milling`.
"""

if __name__ != "robolobes.lobes":  # this folder imported by itself (from the repository root): a second copy
    raise ImportError(f"{__name__!r} is the folder of the robolobes.lobes package: import robolobes.lobes instead")

from ._errors import LobeError
from .directional import DirectionalPlan, average_directional_matrix
from .problem import LobeProblem
from .refine import RefinedSDM
from .sdm import Bifurcation, SemiDiscretization, classify_multiplier
from .solver import LobeResult, Method, StabilityPoint, Verdict, depth_verdict, solve, stability
from .measured import MeasuredStructure
from .modal_fit import ModalFit, fit_modal
from .structure import (ComplexMode, Mode, ModalStructure, PhysicalStructure, ReducedStructure, StateSpace, Structure,
                        TruncationReport, in_series)
from .zoa import ZeroOrder
from .collocation import Collocation
from .basis import BasisInfo, basis_for, reduced_basis

__all__ = [
    "LobeError", "LobeProblem", "Mode", "ModalStructure", "PhysicalStructure", "ReducedStructure",
    "StateSpace", "Structure", "TruncationReport", "SemiDiscretization", "RefinedSDM", "ZeroOrder", "Method",
    "solve", "stability", "LobeResult", "StabilityPoint", "Verdict", "Bifurcation", "classify_multiplier",
    "DirectionalPlan", "average_directional_matrix", "depth_verdict", "ComplexMode", "MeasuredStructure", "ModalFit",
    "fit_modal", "in_series", "BasisInfo", "basis_for", "reduced_basis", "Collocation",
]
