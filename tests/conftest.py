"""Test configuration and the fixtures shared by the test modules.

BLAS is single-threaded (see app/main.py, robolobes.main), set before numpy is imported.

Shared fixtures (session scope: each is built once per test run and shared by every test that
asks for it). Sharing is safe because each object is immutable: the specs and cases are frozen
dataclasses with read-only arrays, and a robot (``FlexibleRobot``) is a constant model whose
algorithms take a ``pin.Data`` workspace per call (docs/guide/development.md).

* ``tx200_spec``: the built-in TX200 robot spec (``cases.load_robot("tx200")``);
* ``alu_case``, ``steel_case``: the built-in milling cases ``tx200-aluminium`` / ``tx200-steel``;
* ``tx200_robot``: ``tx200_robot(variant)`` is the TX200 built as that variant
  (``"basic"``, ``"gravity"``, ``"orthogonal"``, ``"backlash"``), nominal damping, no extra
  elements, built once per variant. A robot with other arguments (damping scale, extra elements,
  another spec) is built by the test itself;
* ``draw_plan``: ``draw_plan(seeds, need)`` is the :class:`draw_counts.DrawPlan` of an
  identification draw set's rule "``need`` of ``seeds`` right" under the ``--draws N`` option
  (``pytest -m long --draws 2``: the first 2 seeds, both right; tests/draw_counts.py).
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING, Callable

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import pytest  # noqa: E402  (after the BLAS settings: pytest's plugins may import numpy)

if TYPE_CHECKING:
    from draw_counts import DrawPlan
    from robolobes.cases.spec import MillingCase, RobotSpec
    from robolobes.linearize import FlexibleRobot


@pytest.fixture(scope="session")
def tx200_spec() -> RobotSpec:
    """The built-in TX200 robot spec (SI units; frozen)."""
    from robolobes import cases

    return cases.load_robot("tx200")


@pytest.fixture(scope="session")
def alu_case() -> MillingCase:
    """The built-in aluminium case on the TX200 (frozen)."""
    from robolobes import cases

    return cases.load_case("tx200-aluminium")


@pytest.fixture(scope="session")
def steel_case() -> MillingCase:
    """The built-in steel case on the TX200 (frozen)."""
    from robolobes import cases

    return cases.load_case("tx200-steel")


@pytest.fixture(scope="session")
def tx200_robot(tx200_spec: RobotSpec) -> Callable[[str], FlexibleRobot]:
    """``tx200_robot(variant="basic")``: the TX200 built as ``variant``, once per variant (immutable)."""
    from robolobes.linearize import build_model

    built: dict[str, FlexibleRobot] = {}

    def robot(variant: str = "basic") -> FlexibleRobot:
        if variant not in built:
            built[variant] = build_model(tx200_spec, variant)
        return built[variant]

    return robot


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--draws", type=int, default=None, metavar="N",
                     help="identification draw sets (tests marked long): run the first N seeds of each; a rule "
                          "'k of n right' becomes ceil(k N / n) of N, never looser (tests/draw_counts.py)")


def pytest_configure(config: pytest.Config) -> None:
    n = config.getoption("--draws")
    if n is not None and n < 1:
        raise pytest.UsageError(f"--draws {n}: must be a whole number >= 1")


@pytest.fixture
def draw_plan(request: pytest.FixtureRequest) -> Callable[..., DrawPlan]:
    """``draw_plan(seeds, need, full_rule_only="")``: the :class:`draw_counts.DrawPlan` of a rule
    "``need`` of ``seeds`` right" under this run's ``--draws`` option (the full set without it)."""
    from draw_counts import plan_draws

    n = request.config.getoption("--draws")
    return lambda seeds, need, full_rule_only="": plan_draws(seeds, need, n, full_rule_only=full_rule_only)
