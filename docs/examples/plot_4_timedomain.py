"""
A time-domain pass: steel chatters
==================================

The first 3.2 s of the steel pass (basic model; the tool is fully engaged from 2.41 s on),
simulated on the linearized fast path:
the robot linearized at the pass start, the nonlinear milling force on the eroded part. The
verdict is read from the growth of the non-synchronous tool motion (a confidence interval on its
rate); the lobes predict this cut unstable, with a flip at 51.7 Hz. The command-line equivalent
is ``robolobes simulate --case tx200-steel --duration 3.2 --linearized``.
"""

import warnings

import matplotlib.pyplot as plt

from robolobes import cases, linearize
from robolobes.linearize.kinematics import JointLimitWarning
from robolobes.timedomain import LinearizedNewmark, SimulationProblem, simulate

with warnings.catch_warnings():
    warnings.simplefilter("ignore", JointLimitWarning)  # Tab. 7's A3 is 2.86 deg past its range: known
    case = cases.load_case("tx200-steel")
    robot = linearize.build_model(case.robot, "basic")
    run = simulate(SimulationProblem(robot, case, t_end_s=3.2), LinearizedNewmark(deg_per_step=2.0))

s = run.summary
print(f"verdict: {s.verdict.status} ({s.verdict.reason})")
if s.chatter_freq_hz is not None:
    print(f"chatter frequency {s.chatter_freq_hz:.1f} Hz")
for axis, st in (s.force_stats_paper_axes or {}).items():
    print(f"F{axis} (paper axes): " + ", ".join(f"{q} {float(v):.1f} N" for q, v in st.items()))

# %%
# The force on the workpiece normal to the feed, and the tool's deviation from its path:

fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(7, 5), sharex=True)
ax1.plot(run.t_s, run.force_workpiece_n[:, 1], lw=0.4)
ax1.set_ylabel("Fy on the part (N)")
ax2.plot(run.t_s, run.tcp_deviation_m[:, 1] * 1e6, lw=0.4, color="C1")
ax2.set_ylabel("TCP deviation y (um)")
ax2.set_xlabel("time (s)")
for ax in (ax1, ax2):
    ax.axvspan(*run.steady_window_s, color="grey", alpha=0.1)
    ax.grid(alpha=0.3)
plt.show()
