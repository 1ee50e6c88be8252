"""The tool on the robot: TCP oscillators in the robot's M, C, K against the series formula.

Run: .venv/bin/python bench/bench_tool_coupling.py

For three tools on the TX200 (aluminium case, basic variant, pass start), the lowest depth limit of
the lobes (SDM one level m = 40, 100 speeds 5000-25 000 rpm, depths to 10 mm) with the tool

* in the robot (``linearize.tool.TcpOscillator`` elements: what ``lobes``, ``map`` and ``optimize``
  use), and
* in series (``H_robot + H_tool``, ``lobes.in_series``: what they used before),

the relative difference, and the CPU-time ratio of the two diagrams (``time.process_time``, same
process). The robot's apparent mass at the TCP along the feed at the tool's first frequency,
``-1 / (w^2 Re H_xx)``, is printed beside the tool's mass. The tools: 1 g at 600 Hz along the feed
(tests/test_workspace_model.py), the two modes of tests/data/hammer_tooltip.uff (40 g at 922 Hz
along the feed, 42 g at 1100 Hz across), and an axisymmetric 1500 Hz holder of 0.34 kg in x and y
(tests/test_hammer.py).
"""

from __future__ import annotations

import math
import os
import sys
import time
from pathlib import Path

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_v] = "1"

import numpy as np  # noqa: E402  (after the BLAS thread count is set)

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from robolobes.cases import load_case  # noqa: E402
from robolobes.linearize import build_model, linearize  # noqa: E402
from robolobes.lobes import (LobeProblem, ModalStructure, Mode, PhysicalStructure, SemiDiscretization,  # noqa: E402
                             in_series, solve)
from robolobes.lobes.tooltip import tool_from_modes, with_tool  # noqa: E402

TOOLS = {
    "1 g, 600 Hz (feed)": (Mode(600.0, 0.03, 0.001 * (2 * math.pi * 600.0) ** 2, (1.0, 0.0)),),
    "hammer file modes (40 g / 42 g)": (Mode(922.0, 0.011, 1.340049648e6, (1.0, 0.0)),
                                        Mode(1100.0, 0.02, 2e6, (0.0, 1.0))),
    "0.34 kg, 1500 Hz (x and y)": (Mode(1500.0, 0.03, 3e7, (1.0, 0.0)), Mode(1500.0, 0.03, 3e7, (0.0, 1.0))),
}
SPEEDS = np.linspace(5000.0, 25000.0, 100)


def _lowest(structure, case) -> float:
    res = solve(LobeProblem(structure, case.tool, case.cut, case.law), SemiDiscretization(m=40), SPEEDS,
                depth_max_m=0.01)
    return float(np.nanmin(np.asarray(res.depth_limit_m, dtype=float)))


def main() -> int:
    case = load_case("tx200-aluminium")
    theta, feed = case.path.start_q_rad, case.cut.feed_direction
    robot = build_model(case.robot, "basic")
    lin = linearize(robot, theta)
    print(f"{'tool':34s} {'tool kg':>8s} {'M_app kg':>8s} {'element mm':>10s} {'series mm':>10s} {'diff':>7s} "
          f"{'cpu el/ser':>10s}")
    for name, modes in TOOLS.items():
        w1 = 2 * math.pi * modes[0].freq_hz
        Hxx = PhysicalStructure.from_linear(lin, feed).frf(np.array([w1])).H[0, 0, 0]
        m_app = -1.0 / (w1 ** 2 * Hxx.real)
        t0 = time.process_time()
        tool = tool_from_modes(modes, name, "modes")
        lin_t = linearize(with_tool(robot, tool.in_tcp_frame(lin.R_tcp, feed)), theta)
        b_el = _lowest(PhysicalStructure.from_linear(lin_t, feed), case)
        t1 = time.process_time()
        b_se = _lowest(in_series(PhysicalStructure.from_linear(lin, feed).state_space(),
                                 ModalStructure(modes).state_space()), case)
        t2 = time.process_time()
        print(f"{name:34s} {modes[0].mass_kg:8.3g} {m_app:8.3g} {1e3 * b_el:10.4g} {1e3 * b_se:10.4g} "
              f"{b_se / b_el - 1:+7.1%} {(t1 - t0) / (t2 - t1):10.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
