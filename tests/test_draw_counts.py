"""The ``--draws N`` rule (tests/draw_counts.py): fewer seeds, never a looser pass count.

Expected counts worked by hand: ceil(4 x 2 / 5) = ceil(1.6) = 2, ceil(19 x 2 / 20) = ceil(1.9) = 2,
ceil(4 x 3 / 5) = ceil(2.4) = 3, ceil(19 x 10 / 20) = ceil(9.5) = 10, ceil(19 x 1 / 20) = 1.
"""

import pytest
from draw_counts import plan_draws


@pytest.mark.parametrize("seeds, need, draws, want_seeds, want_need", [
    (range(1, 6), 4, 2, (1, 2), 2),             # 4 of 5 -> both of 2
    (range(100, 120), 19, 2, (100, 101), 2),    # 19 of 20 -> both of 2
    ([11, 12, 13, 14, 15], 4, 3, (11, 12, 13), 3),
    (range(20), 19, 10, tuple(range(10)), 10),  # 9.5 rounds up: a share of 1.0 >= 0.95
    (range(20), 19, 1, (0,), 1),
])
def test_reduced_plan_takes_the_first_seeds_and_rounds_the_count_up(seeds, need, draws, want_seeds, want_need):
    plan = plan_draws(seeds, need, draws)
    assert (plan.seeds, plan.need, plan.reduced) == (want_seeds, want_need, True)
    assert plan.need / len(plan.seeds) >= need / len(tuple(seeds))  # never looser than the full rule
    assert "reduced from" in plan.describe("4 of 5")


@pytest.mark.parametrize("draws", [None, 5, 7])
def test_full_plan_without_the_option_or_with_enough_draws(draws):
    plan = plan_draws(range(5), 4, draws)
    assert (plan.seeds, plan.need, plan.reduced) == ((0, 1, 2, 3, 4), 4, False)
    assert plan.describe("4 of 5") == "4 of 5"


def test_bad_counts_are_refused_naming_the_value():
    with pytest.raises(ValueError, match="--draws 0"):
        plan_draws(range(5), 4, 0)
    with pytest.raises(ValueError, match="need = 6"):
        plan_draws(range(5), 6, None)


def test_full_rule_only_sets_skip_when_reduced_and_run_in_full_otherwise():
    reduced = plan_draws(range(1, 6), 4, 2, full_rule_only="its wrong draw is seed 1")
    assert (reduced.seeds, reduced.need, reduced.reduced) == ((), 0, True)
    assert reduced.skip == "full rule only (4 of 5): its wrong draw is seed 1; run without --draws"
    for draws in (None, 5):
        full = plan_draws(range(1, 6), 4, draws, full_rule_only="its wrong draw is seed 1")
        assert (full.seeds, full.need, full.skip) == ((1, 2, 3, 4, 5), 4, "")
    assert plan_draws(range(1, 6), 4, 2).skip == ""  # a set without the declaration runs the reduced rule


def test_the_option_reaches_the_fixture(pytestconfig, draw_plan):
    n = pytestconfig.getoption("--draws")
    plan = draw_plan(range(5), 4)
    assert len(plan.seeds) == (5 if n is None else min(n, 5))
