"""``robolobes.workspace.optimize``: the material removal rate objective and the optimum with
strict joint limits, on synthetic depth functions whose answers are known in closed form (the
lobes are monkeypatched, the IK of the paper's pass is real), plus the paper's pose."""

import itertools
import math

import numpy as np
import pytest

from robolobes.core.errors import BadInput
from robolobes.workspace import MapProblem
from robolobes.workspace import optimize as wo


def _problem(case, **kw):
    mp = MapProblem.make(case, "basic", "placement", n=1)
    return wo.OptimizeProblem(mp, ("tool_rotation_rad",), {"tool_rotation_rad": (-1.0, 1.0)}, n_s=2, **kw)


def test_mrr_per_depth_is_ae_fz_n_rpm(steel_case):
    # a_e v_f with v_f = f_z N n / 60 (n in rpm), from the case's own numbers: closed form, rtol 1e-12
    c = steel_case.cut
    want = c.ae_m * c.feed_per_tooth_m * steel_case.tool.teeth * np.array([1550.0, 3100.0]) / 60.0
    np.testing.assert_allclose(wo.mrr_per_depth_m2_per_s(steel_case, [1550.0, 3100.0]), want, rtol=1e-12)


def test_mrr_needs_speeds_and_depth_refuses_them(steel_case):
    with pytest.raises(BadInput, match="mrr objective needs"):
        _problem(steel_case, objective="mrr")
    with pytest.raises(BadInput, match="speeds_rpm is for the mrr objective"):
        _problem(steel_case, speeds_rpm=(3000.0,))
    with pytest.raises(BadInput, match="objective must be one of"):
        _problem(steel_case, objective="volume")


def test_mrr_objective_finds_the_closed_form_best_speed(steel_case, monkeypatch):
    # Two pass poses with known lobes: pose 0 a_0(n) = A / (1 + (n/n0)^2), pose 1 a_1 = 0.3 A.
    # MRR(n) = c n min(a_0, a_1), c = a_e f_z N / 60. For n/n0 <= x* = sqrt(1/0.3 - 1) the min is
    # 0.3 A (MRR rising with n); above, c A n / (1 + (n/n0)^2) falls (n > n0). So the best speed is
    # n* = x* n0 (not n0, the best speed of pose 0 alone), MRR* = 0.3 A c n*. Exact: rtol 1e-12.
    A, n0 = 4e-3, 2000.0
    n_star = math.sqrt(1 / 0.3 - 1) * n0
    speeds = np.sort(np.append(np.linspace(1000.0, 6000.0, 21), n_star))
    calls = itertools.count()

    def fake_depths(opt, method, theta, feed, full):
        n = opt.eval_speeds_rpm
        return A / (1 + (n / n0) ** 2) if next(calls) % 2 == 0 else np.full(len(n), 0.3 * A)

    monkeypatch.setattr(wo, "_depths_at", fake_depths)
    opt = _problem(steel_case, objective="mrr", speeds_rpm=tuple(speeds))
    ev = wo.evaluate_pass(opt, [0.0])
    c = steel_case.cut.ae_m * steel_case.cut.feed_per_tooth_m * steel_case.tool.teeth / 60.0
    assert ev.feasible and ev.rpm == n_star
    np.testing.assert_allclose(ev.mrr_m3_per_s, 0.3 * A * c * n_star, rtol=1e-12)
    np.testing.assert_allclose(ev.depth_m, [A / (1 + (n_star / n0) ** 2), 0.3 * A], rtol=1e-12)
    assert ev.depth_by_speed_m.shape == (2, len(speeds))
    # the depth objective at the chosen speed n0 (the case's op speed replaced): no speed freedom
    opt_d = wo.OptimizeProblem(MapProblem.make(steel_case, "basic", "placement", n=1, op_rpm=n0),
                               ("tool_rotation_rad",), {"tool_rotation_rad": (-1.0, 1.0)}, n_s=2)
    ev_d = wo.evaluate_pass(opt_d, [0.0])
    assert ev_d.rpm == n0 and ev_d.min_depth_m == pytest.approx(0.3 * A, rel=1e-12)


def test_depth_with_no_limit_counts_as_depth_max_in_the_mrr(steel_case, monkeypatch):
    # inf (stable up to depth_max_m at every speed): MRR = depth_max_m c n_max, a lower bound
    monkeypatch.setattr(wo, "_depths_at", lambda opt, *a: np.full(len(opt.eval_speeds_rpm), np.inf))
    opt = _problem(steel_case, objective="mrr", speeds_rpm=(1000.0, 2000.0))
    ev = wo.evaluate_pass(opt, [0.0])
    c = steel_case.cut.ae_m * steel_case.cut.feed_per_tooth_m * steel_case.tool.teeth / 60.0
    assert ev.rpm == 2000.0
    np.testing.assert_allclose(ev.mrr_m3_per_s, opt.depth_max_m * c * 2000.0, rtol=1e-12)


def test_strict_violation_of_the_papers_pose(steel_case):
    # Tab. 7 (NOTES.md): A3 = 147.86 deg, 2.86 deg past the datasheet's +145 deg
    text = wo.strict_violation(steel_case.robot, np.asarray(steel_case.path.start_q_rad)[None, :])
    assert text == "A3 2.86 deg past +145 deg at 1 of 1 pass poses"
    inside = np.asarray(steel_case.path.start_q_rad).copy()
    inside[2] = math.radians(140.0)
    assert wo.strict_violation(steel_case.robot, inside) == ""


# ------------------------------------------------------------------------- strict limits, two branches
def _fake_evaluate(x_strict: float, strict_calls: list):
    """Objective 1e-3 (1 - (x - 0.3)^2) m of the tool rotation x (max 1e-3 at x = 0.3); strictly
    feasible for x < x_strict (else A3 at 148 deg, 3 deg past +145); infeasible under strict limits
    there. Records whether each call had strict limits."""

    def fake(opt, x, method=None, *, full=False):
        x = np.asarray(x, dtype=float)
        strict_calls.append(opt.strict)
        ok = bool(x[0] < x_strict)
        theta = np.zeros((opt.n_s, 6))
        theta[:, 2] = math.radians(140.0 if ok else 148.0)
        s = np.linspace(0.0, 0.1, opt.n_s)
        if opt.strict and not ok:
            return wo.PassEvaluation(x, False, "strict", np.full(opt.n_s, np.nan), theta, np.array([1.0, 0, 0]), s)
        d = 1e-3 * (1 - (x[0] - 0.3) ** 2)
        return wo.PassEvaluation(x, True, "", np.full(opt.n_s, d), theta, np.array([1.0, 0, 0]), s, ok,
                                 speeds_rpm=np.array([3100.0]), depth_by_speed_m=np.full((opt.n_s, 1), d),
                                 rpm=3100.0, mrr_m3_per_s=d)

    return fake


def test_strict_optimum_is_the_tolerant_one_when_it_is_strict_feasible(steel_case, monkeypatch):
    calls = []
    monkeypatch.setattr(wo, "evaluate_pass", _fake_evaluate(0.5, calls))
    res, strict = wo.optimize_with_strict(_problem(steel_case), n_starts=6, n_local=1, max_local_evals=60)
    assert res.best.strict_ok and strict.how == "tolerant optimum" and strict.result is None
    assert strict.best is res.best
    assert not any(calls)   # no second run with strict limits
    # Nelder-Mead on a parabola from the best of 7 starts: the maximum x = 0.3 to its xatol scale
    np.testing.assert_allclose(res.best.x[0], 0.3, atol=0.02)


def test_strict_run_when_the_tolerant_optimum_is_past_a_strict_range(steel_case, monkeypatch):
    calls = []
    monkeypatch.setattr(wo, "evaluate_pass", _fake_evaluate(0.1, calls))
    res, strict = wo.optimize_with_strict(_problem(steel_case), n_starts=6, n_local=1, max_local_evals=60)
    assert not res.best.strict_ok and strict.how == "strict run" and any(calls)
    assert "A3 3.00 deg past +145 deg" in strict.note
    # the strict optimum is the feasible edge x -> 0.1: supremum 1e-3 (1 - 0.2^2) = 0.96e-3; the
    # search stops within its tolerances of the edge (0.5 % of the value)
    assert strict.best.feasible and strict.best.strict_ok and strict.best.x[0] < 0.1
    np.testing.assert_allclose(strict.best.min_depth_m, 0.96e-3, rtol=5e-3)
    assert strict.best.min_depth_m <= 0.96e-3
    np.testing.assert_allclose(res.best.min_depth_m, 1e-3, rtol=1e-3)


def test_time_domain_check_point_lies_between_the_limits_at_the_optimums_speed(steel_case):
    # Baseline limits 1 / 2 mm at 2000 / 3000 rpm, optimum best at 3000 rpm with 4 mm: the check
    # runs at 3000 rpm at sqrt(2 x 4) = 2.83 mm (geometric mean, below 1.5 x 2 = 3 mm), between the
    # baseline's 2 mm there and the optimum's 4 mm.
    from robolobes.workspace.verify import check_point as _td_point

    opt = _problem(steel_case, objective="mrr", speeds_rpm=(2000.0, 3000.0))
    s, theta, feed, sp = np.zeros(2), np.zeros((2, 6)), np.array([1.0, 0, 0]), np.array([2000.0, 3000.0])
    base = wo.PassEvaluation(np.zeros(1), True, "", np.full(2, 2e-3), theta, feed, s, speeds_rpm=sp,
                             depth_by_speed_m=np.array([[1e-3, 2e-3], [1.5e-3, 2e-3]]), rpm=3000.0, mrr_m3_per_s=1.0)
    best = wo.PassEvaluation(np.ones(1), True, "", np.full(2, 4e-3), theta, feed, s, speeds_rpm=sp,
                             depth_by_speed_m=np.array([[3e-3, 4e-3], [3e-3, 4e-3]]), rpm=3000.0, mrr_m3_per_s=2.0)
    rpm, d, b, o = _td_point(wo.Optimum(opt, base, best, ()))
    assert (rpm, b, o) == (3000.0, 2e-3, 4e-3)
    np.testing.assert_allclose(d, math.sqrt(8) * 1e-3, rtol=1e-12)
    # no gain there: the case's own depth, and the limits still reported
    rpm, d, b, o = _td_point(wo.Optimum(opt, base, base, ()))
    assert d == steel_case.cut.ap_m and b == o == 2e-3
