"""
A lobe map along the pass
=========================

The stability limit changes with the pose: ``robolobes.workspace.solve_map`` computes the lobes
at every pose of a map. Here five poses along the aluminium pass (basic model), 25 speeds around
the case's 18 700 rpm, computed in this process (``scheduler="serial"``); ``robolobes map --over
pass`` does the same on two worker processes with a resumable zarr store.
"""

import warnings

import matplotlib.pyplot as plt
import numpy as np

from robolobes import cases
from robolobes.linearize.kinematics import JointLimitWarning
from robolobes.workspace import MapMethod, MapProblem, solve_map

with warnings.catch_warnings():
    warnings.simplefilter("ignore", JointLimitWarning)  # Tab. 7's A3 is 2.86 deg past its range: known
    case = cases.load_case("tx200-aluminium")
problem = MapProblem.make(case, "basic", "pass", n=5, speeds_rpm=np.linspace(14000.0, 23000.0, 25))
result = solve_map(problem, MapMethod(), scheduler="serial")
ds = result.dataset
print(ds["depth_limit_m"].sizes)
print("limit at the operating speed per pose (mm):", np.round(ds["op_depth_limit_m"].values * 1e3, 3))

# %%
# Depth limit against speed, one line per pose along the pass (a gap: no limit below the
# searched 10 mm at those speeds, stored as ``inf``):

fig, ax = plt.subplots(figsize=(7, 4))
s_mm = ds["s_m"].values * 1e3
for k in range(ds.sizes["pose"]):
    depth = ds["depth_limit_m"].isel(pose=k).values * 1e3
    ax.plot(ds["rpm"].values, np.where(np.isfinite(depth), depth, np.nan), label=f"s = {s_mm[k]:.0f} mm")
ax.axvline(problem.op_rpm, color="grey", ls=":", label="operating speed")
ax.set_xlabel("spindle speed (rpm)")
ax.set_ylabel("critical axial depth (mm)")
ax.set_title("aluminium pass, basic model: lobes at five poses")
ax.legend(fontsize=8)
ax.grid(alpha=0.3)
plt.show()
