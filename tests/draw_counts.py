"""How many draws of an identification draw set run, and how many must be right.

Not a test module: the rule behind the ``--draws N`` option (tests/conftest.py), shared by the
draw-set tests (the ``long`` tests of tests/test_identify_*.py and tests/test_tool_oscillator.py).

A draw set's rule is "at least ``need`` of ``seeds`` right" (4 of 5, 19 of 20). ``--draws N`` runs
the first ``N`` seeds only, and the rule is never loosened: the reduced check requires
``ceil(need * N / len(seeds))`` of ``N`` right, a share at least the full rule's (for N = 2: both
right, for 4 of 5 and for 19 of 20 alike). Without the option, or with ``N >= len(seeds)``, the full
seed list and the full rule run.

A set may declare that it is judged by its full rule only (``full_rule_only``, with the reason): a set
whose known wrong draw is among the first ``N`` seeds meets "4 of 5" but fails the reduced "N of N",
so under ``--draws N`` its plan runs no seed and carries the reason to skip (``DrawPlan.skip``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass


@dataclass(frozen=True)
class DrawPlan:
    """The seeds to run and how many of them must be right (``need <= len(seeds)``)."""

    seeds: tuple[int, ...]
    need: int
    reduced: bool  # True: fewer seeds than the full set (``--draws N``)
    skip: str = ""  # non-empty: a full-rule-only set under ``--draws N``, why it does not run

    def describe(self, full: str) -> str:
        """The rule asserted, for assertion messages: ``full`` is the full rule's wording."""
        if not self.reduced:
            return full
        return f"{self.need} of {len(self.seeds)} right (reduced from {full} by --draws {len(self.seeds)})"


def plan_draws(seeds: Sequence[int], need: int, draws: int | None, *, full_rule_only: str = "") -> DrawPlan:
    """The plan for a rule "``need`` of ``seeds``" under ``--draws draws`` (None: the full set).

    ``full_rule_only``: non-empty for a set judged by its full rule only, the reason why; under a
    reducing ``--draws`` its plan has no seeds, ``need`` 0 and ``skip`` set to
    ``"full rule only (<need> of <n>): <reason>; run without --draws"``."""
    seeds = tuple(seeds)
    if not 1 <= need <= len(seeds):
        raise ValueError(f"need = {need} must be between 1 and the {len(seeds)} seeds")
    if draws is None or draws >= len(seeds):
        return DrawPlan(seeds, need, reduced=False)
    if draws < 1:
        raise ValueError(f"--draws {draws}: must be a whole number >= 1")
    if full_rule_only:
        why = f"full rule only ({need} of {len(seeds)}): {full_rule_only}; run without --draws"
        return DrawPlan((), 0, reduced=True, skip=why)
    return DrawPlan(seeds[:draws], -(-need * draws // len(seeds)), reduced=True)  # integer ceil
