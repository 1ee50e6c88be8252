"""Cutting-force identification on data from the independent force generator, through the command line.

The draws and the rule that says whether an answer is right are in tests/generators/force_draws.py
(stated before any draw ran): the null set 19 of 20 clean (nothing identified, not unexplained), the
pairs edge + runout and dynamometer + edge 4 of 5 right. Under ``--draws N`` the first N seeds run and
the share is never loosened (tests/draw_counts.py). Counts and CPU: docs/guide/identify-answers.md,
"Force draws" (the pairs on the generator's pass with its entry: seeds 1-5 of each right, 2026-12-06).
"""

import pytest

from generators.force_draws import CASES, run_force_case


def _run(case, plan, tmp_path):
    got = [run_force_case(case, seed, tmp_path) for seed in plan.seeds]
    with_numbers = [(r["seed"], r["right"], r["why"], r["identified"], round(r["ratio"], 3), round(r["cpu_s"], 1))
                    for r in got]
    print(case, with_numbers)
    return got, with_numbers


@pytest.mark.slow
@pytest.mark.long
def test_force_nulls_clean_in_at_least_19_of_20(tmp_path, draw_plan):
    plan = draw_plan(range(1, 21), 19)
    got, numbers = _run("null", plan, tmp_path)
    assert sum(r["right"] for r in got) >= plan.need, (plan.describe("19 of 20"), numbers)


@pytest.mark.slow
@pytest.mark.long
@pytest.mark.parametrize("case", [c for c in CASES if c != "null"])
def test_force_pairs_right_in_at_least_4_of_5(tmp_path, draw_plan, case):
    plan = draw_plan(range(1, 6), 4)
    got, numbers = _run(case, plan, tmp_path)
    assert sum(r["right"] for r in got) >= plan.need, (plan.describe("4 of 5"), numbers)


def _json(effects, unexplained=False):
    return {"effects": effects, "identified": [e["name"] for e in effects],
            "unexplained": {"unexplained": unexplained, "ratio_to_noise_floor": 1.5 if unexplained else 1.0}}


def _edge(kte, kre, sd=100.0):
    return {"name": "edge_coefficients", "params": {"kte_n_per_m": kte, "kre_n_per_m": kre},
            "uncertainty": {"kte_n_per_m": sd, "kre_n_per_m": sd}}


def test_force_judge_on_known_answers():
    # The rule of tests/generators/force_draws.py on hand-made answers: Kte, Kre within 3 sd or 5 %;
    # the tooth-radius difference within 3 sd or 1 um; nothing else; not unexplained.
    from generators.force_draws import draw, judge

    truth = {"edge_coefficients": {"kte_n_per_m": 3e4, "kre_n_per_m": 2e4},
             "runout": {"radius_difference_m": -1e-5}}
    runout = {"name": "runout", "params": {"amplitude_m": 5e-6, "phase_rad": 0.0},
              "uncertainty": {"amplitude_m": 1e-7, "phase_rad": 1.8},
              "determined": {"shared": [{"value": -1.02e-5, "sd": 1e-8}]}}
    assert judge(truth, _json([_edge(3.1e4, 2.05e4), runout]))[0]          # 3.3 % and 2.5 % off
    assert not judge(truth, _json([_edge(3.2e4, 2e4), runout]))[0]         # Kte 6.7 % off, 33 sd
    assert not judge(truth, _json([_edge(3e4, 2e4)]))[0]                   # runout missed
    far = dict(runout, determined={"shared": [{"value": -1.2e-5, "sd": 1e-8}]})
    assert not judge(truth, _json([_edge(3e4, 2e4), far]))[0]              # 2 um off
    low = {"name": "lowpass", "params": {"cutoff_hz": 3000.0}, "uncertainty": {"cutoff_hz": 10.0}}
    assert not judge(truth, _json([_edge(3e4, 2e4), runout, low]))[0]      # an extra effect
    assert not judge(truth, _json([_edge(3e4, 2e4), runout], unexplained=True))[0]
    assert judge({}, _json([]))[0] and not judge({}, _json([], unexplained=True))[0]
    # the draws are seeded and inside their stated ranges
    eff, t = draw("dynamometer+edge", 3)
    assert (eff, t) == draw("dynamometer+edge", 3)
    assert 1000 <= t["dynamometer"]["fn_hz"] <= 5000 and 1e4 <= t["edge_coefficients"]["kte_n_per_m"] <= 1e5
    eff, t = draw("edge+runout", 4)
    assert eff.tooth_radius_m[1] - eff.tooth_radius_m[0] == pytest.approx(t["runout"]["radius_difference_m"])
    assert 3e-6 <= abs(t["runout"]["radius_difference_m"]) <= 3e-5
