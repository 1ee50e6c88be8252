"""The time-domain API in the lobes' shape: problem and method bounds (BadInput before any work),
summaries that keep every field on short runs without inverted ranges, and outputs that never mix
two runs (issue 9 section 3)."""

import dataclasses
import json
import warnings

import numpy as np
import pytest

from robolobes import cases
from robolobes.core.errors import BadInput
from robolobes.linearize import JointLimitWarning, MotionSprings, Payload, build_model
from robolobes.linearize.model import assemble
from robolobes.timedomain import (LinearizedNewmark, NonlinearNewmark, SimulationError, SimulationProblem,
                                  SimulationSummary, simulate)
from robolobes.timedomain.output import save_result
from robolobes.timedomain.result import SimulationResult
from robolobes.timedomain.problem import MAX_RECORD_BYTES, RECORD_BYTES_PER_STEP, step_count

warnings.filterwarnings("ignore", category=JointLimitWarning)  # Tab. 7's A3, accepted and tested elsewhere
ALU = cases.load_case("tx200-aluminium")
# The aluminium pass: 1.754 s; full engagement from 0.228 s; 18 700 rpm (3.2 ms per revolution).
PASS_S = 1.754054



def _simulated(problem, method) -> SimulationResult:
    """``simulate`` of a SimulationProblem: a SimulationResult (its declared return is a union)."""
    r = simulate(problem, method)
    assert isinstance(r, SimulationResult)
    return r


def _summary(r: SimulationResult) -> SimulationSummary:
    assert r.summary is not None
    return r.summary

def test_t_end_past_the_pass_is_refused_naming_the_pass_duration(tx200_robot):
    with pytest.raises(SimulationError, match=r"past the end of the pass \(1\.75405 s") as ei:
        SimulationProblem(tx200_robot("basic"), ALU, t_end_s=2.0)
    assert isinstance(ei.value, BadInput)
    assert SimulationProblem(tx200_robot("basic"), ALU, t_end_s=PASS_S - 1e-6).end_time_s == pytest.approx(PASS_S - 1e-6)
    with pytest.raises(SimulationError, match="t_end_s must be > 0"):
        SimulationProblem(tx200_robot("basic"), ALU, t_end_s=0.0)
    with pytest.raises(SimulationError, match="end > start"):
        SimulationProblem(tx200_robot("basic"), ALU, stats_window_s=(1.0, 0.5))
    with pytest.raises(SimulationError, match="linearize.FlexibleRobot"):
        SimulationProblem("basic", ALU)  # pyright: ignore[reportArgumentType]  # deliberately invalid input
    with pytest.raises(TypeError):  # t_end_s is keyword-only
        SimulationProblem(tx200_robot("basic"), ALU, 1.0)  # pyright: ignore[reportCallIssue]  # the positional call is the test


@pytest.mark.parametrize("kw, match", [
    (dict(deg_per_step=0.0), "deg_per_step must be > 0"), (dict(deg_per_step=11.0), r"\(0, 10\]"),
    (dict(n_discs=0), r"n_discs must be an integer in \[1, 1000\]"), (dict(n_discs=10 ** 6), r"\[1, 1000\]"),
    (dict(n_discs=2.5), "n_discs must be an integer"), (dict(dx_m=1e-9), r"dx_m .* \[1e-7, 1e-4\] m"),
])
def test_method_bounds(kw, match):
    for method in (LinearizedNewmark, NonlinearNewmark):
        with pytest.raises(SimulationError, match=match):
            method(**kw)
    with pytest.raises(SimulationError, match="max_iter"):
        NonlinearNewmark(max_iter=0)


def test_a_tiny_step_is_refused_before_any_work_with_the_memory_it_would_take(tx200_robot):
    # 1e-4 deg per step over the whole pass: 18 700 rpm x 360 deg / 60 s / 1e-4 deg x 1.754 s = 1.97e9
    # steps, 72 bytes of records each: 132 GiB > 2 GiB. The bound: steps <= 2 GiB / 72 B = 2.98e7.
    with pytest.raises(SimulationError, match=r"1968048649 steps.*132\.0 GiB.*2 GiB"):
        simulate(SimulationProblem(tx200_robot("basic"), ALU), LinearizedNewmark(deg_per_step=1e-4))
    h, n = step_count(SimulationProblem(tx200_robot("basic"), ALU), LinearizedNewmark(deg_per_step=0.01))
    assert (n + 1) * RECORD_BYTES_PER_STEP < MAX_RECORD_BYTES  # a fine but sane step still runs
    with pytest.raises(SimulationError, match="LinearizedNewmark"):
        simulate(SimulationProblem(tx200_robot("basic"), ALU, t_end_s=0.01), "linearized")  # pyright: ignore[reportArgumentType, reportCallIssue]  # deliberately invalid input


def _check_ranges(s: dict):
    for key in ("steady_window_s", "force_stats_window_s", "wall_x_range_m"):
        if s[key] is not None:
            assert s[key][1] > s[key][0], (key, s[key])


# every dataclass field; the verdict is written as "verdict", "stable" and "verdict_reason"
FIELDS = {f.name for f in dataclasses.fields(SimulationSummary)} | {"stable", "verdict_reason"}


@pytest.fixture(scope="module")
def short_runs(tx200_robot):
    # 0.05 s ends before the steady cut (0.228 s); 0.25 s ends 22 ms (7 revolutions) into it
    return {t: simulate(SimulationProblem(tx200_robot("basic"), ALU, t_end_s=t), LinearizedNewmark()) for t in (0.05, 0.25)}


def test_short_runs_keep_every_summary_field_with_reasons_and_no_inverted_range(short_runs):
    before = short_runs[0.05].summary.to_json()
    assert set(before) == FIELDS  # every field, always
    assert before["steady_window_s"] is None and before["stable"] is None and before["force_stats"] is None
    assert before["verdict"] == "undetermined" and before["verdict_reason"] == before["note"]
    assert "before the steady cut starts (0.228 s)" in before["note"]
    assert before["roughness_um"] is None and "too short" in before["roughness_note"]
    _check_ranges(before)
    inside = short_runs[0.25].summary.to_json()
    assert set(inside) == FIELDS
    t0, t1 = inside["steady_window_s"]
    assert t0 == pytest.approx(0.228, abs=1e-3) and t1 == pytest.approx(0.25)
    assert inside["stable"] is None and inside["force_stats"] is None and "fewer than 15 revolutions" in inside["note"]
    assert inside["verdict"] == "undetermined" and "fewer than 15 revolutions" in inside["verdict_reason"]
    _check_ranges(inside)
    for r in short_runs.values():
        assert r.summary.variant == "basic" and r.summary.elements == ("payload", "motion springs")
        assert r.summary.damping_scale == 1.0 and r.summary.linearized is True
        assert set(r.summary.provenance) == {"robolobes_version", "inputs_sha256"}
    # provenance: equal inputs hash equal, another t_end does not
    assert short_runs[0.05].summary.provenance != short_runs[0.25].summary.provenance


def test_summary_records_the_robot_it_simulated():
    # the problem takes any built robot: a damping scale and an extra element are simulated and
    # recorded (the free vibration of such a robot is checked against its modes in
    # test_timedomain_robot.py)
    extra = Payload(dataclasses.replace(ALU.robot.payload, mass_kg=5.0), name="extra mass")
    robot = build_model(ALU.robot, "basic", damping_scale=3.0, extra_elements=(extra,))
    s = _summary(_simulated(SimulationProblem(robot, ALU, t_end_s=0.01), LinearizedNewmark()))
    assert s.variant == "basic+"
    assert s.elements == ("payload", "motion springs", "extra mass")


# the paper's Tab. 6 joint damping, N m s/rad (typed from the paper, not read from the robot file)
TAB6_DAMPING = (383.3, 660.0, 371.7, 180.5, 126.2, 71.2)


@pytest.mark.parametrize("damping, expected", [(tuple(3 * d for d in TAB6_DAMPING), 3.0),
                                               (tuple(d * (2.0 if i == 1 else 1.0) for i, d in enumerate(TAB6_DAMPING)),
                                                None)], ids=["uniform x3", "axis 2 only"])
def test_summary_damping_scale_is_read_from_the_robots_springs(damping, expected):
    """A robot assembled by hand (no damping_scale argument anywhere): the summary's damping scale
    is the common factor of its springs' damping over Tab. 6, or None when there is none."""
    springs = MotionSprings(tuple(ALU.robot.joint_stiffness), damping)
    robot = assemble(ALU.robot, (Payload(ALU.robot.payload), springs))
    s = _summary(_simulated(SimulationProblem(robot, ALU, t_end_s=0.01), LinearizedNewmark()))
    assert s.damping_scale == (None if expected is None else pytest.approx(expected, rel=1e-12))


def test_save_result_into_an_earlier_run_removes_its_stale_outputs_only(short_runs, tmp_path):
    out = tmp_path / "sim"
    r = short_runs[0.05]
    save_result(r, out, series="csv")
    (out / "my-notes.txt").write_text("mine")
    assert (out / "series.csv").exists()
    written = save_result(r, out, series="npz")
    names = sorted(p.name for p in out.iterdir())
    assert names == ["closeup.png", "forces.png", "my-notes.txt", "series.npz", "summary.json", "wall.csv", "wall.png"]
    assert sorted(p.name for p in written) == sorted(set(names) - {"my-notes.txt"})
    s = json.loads((out / "summary.json").read_text())
    assert set(FIELDS) <= set(s) and s["steady_window_s"] is None
    # a directory that is not an earlier robolobes run: a file with an output's name is left alone
    other = tmp_path / "user"
    other.mkdir()
    (other / "series.csv").write_text("a user's own file")
    save_result(r, other, series="npz")
    assert (other / "series.csv").read_text() == "a user's own file"


def test_the_nonlinear_method_runs_through_simulate_with_its_options(tx200_robot):
    # 0.02 s of the approach (no cut yet): the full path records the axial TCP deviation, which the
    # linearized path does not have (NaN there), and uses the method's Newton options
    pb = SimulationProblem(tx200_robot("basic"), ALU, t_end_s=0.02)
    full = _simulated(pb, NonlinearNewmark(max_iter=30))
    lin = _simulated(pb, LinearizedNewmark())
    assert _summary(full).linearized is False and _summary(lin).linearized is True
    assert np.all(np.isfinite(full.tcp_deviation_m)) and np.all(np.isnan(lin.tcp_deviation_m[:, 2]))
    assert full.stats["steps"] == lin.stats["steps"] == len(full.t_s) - 1
    assert _summary(full).provenance != _summary(lin).provenance  # the method is an input
