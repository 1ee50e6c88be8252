"""Cases: robots, tools, materials, cuts and toolpaths as data.

The built-in data are the Staubli TX200 of Huynh, Riviere-Lorphevre and Verlinden ("Multibody
modelling of a flexible 6-axis robot dedicated to robotic machining"), with its aluminium and steel
shoulder-milling cases (``tx200-aluminium``, ``tx200-steel``). Users write their own robot or cut
in the same TOML format and load it by path.

>>> from robolobes.cases import load_case
>>> case = load_case("tx200-aluminium")
>>> round(case.cut.spindle_rpm)
18700
"""

if __name__ != "robolobes.cases":  # this folder imported by itself (from the repository root): a second copy
    raise ImportError(f"{__name__!r} is the folder of the robolobes.cases package: import robolobes.cases instead")

from .loader import DEFAULT_CASE, CaseError, builtin_cases, builtin_robots, load_case, load_reference, load_robot
from .milling import (Cut, CuttingLaw, MillingError, Tool, check_cut, cut_frame, directional_matrix,
                      edge_forces, engagement_rad, in_cut, regeneration, tool_force_cut_frame)
from .spec import Assumption, JointSpec, LinkSpec, MillingCase, PassSpec, PayloadSpec, RobotSpec

__all__ = [
    "DEFAULT_CASE", "CaseError", "builtin_cases", "builtin_robots", "load_case", "load_reference", "load_robot",
    "Cut", "CuttingLaw", "MillingError", "Tool", "check_cut", "cut_frame", "directional_matrix",
    "edge_forces", "engagement_rad", "in_cut", "regeneration", "tool_force_cut_frame",
    "Assumption", "JointSpec", "LinkSpec", "MillingCase", "PassSpec", "PayloadSpec", "RobotSpec",
]
