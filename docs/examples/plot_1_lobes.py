"""
Stability lobes of the robot at the pass start
===============================================

The TX200 (6-DOF basic model) linearized at the Tab. 7 pose, cutting steel St 52-3: the lobe
diagram by first-order semi-discretization, and the verdict at the case's operating point
(3100 rpm, 1.6 mm), decided on the Richardson-extrapolated critical depth with its error bound.
The command-line equivalent is ``robolobes lobes --case tx200-steel``.
"""

import matplotlib.pyplot as plt
import numpy as np

from robolobes import cases, linearize
from robolobes.lobes import LobeProblem, PhysicalStructure, SemiDiscretization, solve, stability

case = cases.load_case("tx200-steel")
robot = linearize.build_model(case.robot, "basic")
lin = linearize.linearize(robot, case.path.start_q_rad)
structure = PhysicalStructure.from_linear(lin, case.cut.feed_direction)
problem = LobeProblem(structure, case.tool, case.cut, case.law)

diagram = solve(problem, SemiDiscretization(m=40), speeds_rpm=np.linspace(2000.0, 6000.0, 41))
point = stability(problem)
print(f"operating point {point.spindle_rpm:.0f} rpm, {point.depth_m * 1e3:.2f} mm: {point.verdict.status}, margin {point.margin:+.2f}")
print(f"lowest limit over 2000-6000 rpm: {np.nanmin(diagram.depth_limit_m) * 1e3:.3f} mm")

# %%
# The lobes (depth limit against speed) with the operating point:

fig, ax = plt.subplots(figsize=(7, 4))
ax.plot(diagram.spindle_rpm, diagram.depth_limit_m * 1e3, "-k", lw=1.2)
ax.plot(point.spindle_rpm, point.depth_m * 1e3, "rx" if point.stable is False else "go", ms=9)
ax.set_xlabel("spindle speed (rpm)")
ax.set_ylabel("critical axial depth (mm)")
ax.set_title("TX200 basic, Tab. 7 pose, steel")
ax.grid(alpha=0.3)
plt.show()
