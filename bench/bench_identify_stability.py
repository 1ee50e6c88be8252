"""Benchmark: one stability observation (the steel cut, 3100 rpm, 1.6 mm), old and new verdicts.

Old (before the fast pipeline): every bisection step on the damping scale was a robust lobes
verdict, :func:`lobes.stability` (a depth search at m = 40 and 80, Richardson, m doubled up to 640
while undetermined), with a new linearization. New (:mod:`identify.force_stability`): the pose is
linearized once, and a verdict is one SDM monodromy at m = 40; the critical scale is found by Brent
at m = 40 and at m = 20 (the bound). Prints, in the same process: the time of one old verdict near
the critical scale (x12.3, where it refines m), of one new verdict, their ratio, and the time of the
whole new identification (both candidates) of that observation.

    python bench/bench_identify_stability.py
"""

import os
import time
import warnings
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
warnings.filterwarnings("ignore", "joint A3")

from robolobes.cases import load_case  # noqa: E402
from robolobes.identify.effects import ModelState  # noqa: E402
from robolobes.identify.force_data import StabilityObservation, StabilityObservations  # noqa: E402
from robolobes.identify.force_stability import ObservationModel, identify_stability  # noqa: E402
from robolobes.linearize import linearize  # noqa: E402
from robolobes.lobes import LobeProblem, PhysicalStructure, stability  # noqa: E402


def main(scale: float = 12.3):
    case = load_case("tx200-steel")
    state = ModelState(case=case, case_ref="tx200-steel")
    row = StabilityObservation(case="tx200-steel", rpm=3100.0, depth_m=1.6e-3, chatter=False, path_s_m=0.0)
    om = ObservationModel.build(state, case, row)
    om.radius("joint_damping", 1.0)  # warm-up (imports, first expm)

    t = time.perf_counter()
    lin = linearize(state.robot(damping_scale=scale), state_pose(case))
    st = PhysicalStructure.from_linear(lin, case.cut.feed_direction)
    old = stability(LobeProblem(st, case.tool, case.cut, case.law))
    t_old = time.perf_counter() - t

    t = time.perf_counter()
    rho = om.radius("joint_damping", scale)
    t_new = time.perf_counter() - t
    print(f"one verdict at x{scale}: old {t_old:.2f} s ({old.verdict.status}, m up to {old.history[-1]['m']}), "
          f"new {t_new:.3f} s (|mu| = {rho:.4f}); ratio old/new {t_old / t_new:.0f}")

    t = time.perf_counter()
    res = identify_stability(StabilityObservations(path=Path("<bench: one synthetic row>"), rows=(row,)), state)
    t_all = time.perf_counter() - t
    print(f"whole identification of the observation (both candidates, m = 40 and 20): {t_all:.1f} s; "
          f"found {[(e.name, e.params) for e in res.effects]}")


def state_pose(case):
    from robolobes.linearize.path import Pass

    return Pass.from_case(case).theta_at_s(0.0)


if __name__ == "__main__":
    main()
