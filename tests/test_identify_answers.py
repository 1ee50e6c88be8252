"""Identification that does not mislead: stepwise selection, credible / determined / unexplained answers,
checked on data from an independent generator (tests/generators, which never imports identification
or the model's elements).

Tolerances asserted (and stated in docs/guide/identify-answers.md):

* the generator with no added effect, and with each library effect (the mount included: the
  generator's floor compliance ``base_z``), equals robolobes' own model to 1e-9 of the largest |H|
  (a cross-check of both);
* the stepwise selection's family-wise false-positive rate on noise-only toy data stays below its
  alpha (binomial 99.9 % bound);
* the unexplained margin's false-alarm rate on noise-only lines stays below alpha (binomial bound);
* on a null FRF set from the generator: nothing identified, the residual not unexplained, the noise
  floor within 20 % of the generating model's error;
* the noise floor's estimator (identify.frf.pair_noise) within 20 % of the generating model's error
  on arm_bend, base_z, highpass and null seeds 1-5, with the residual of a model that identified
  nothing (the requirement's 20 %);
* slow, long: 5 draws of joint + servo, of the tool-mode pairs, of the mount (alone and with a
  joint), of the mount's rocking (alone and with a joint), of axis 3's load-dependent gear stiffness (alone and with the payload mass off) and of each effect outside the library (the DAQ's high-pass, the arm's lateral bending),
  at least 4 right; 20 nulls, at least 19 clean (tests/generators/draws.py states what
  "right" means); CI runs the first 2 of each, both right (``--draws 2``);
* the provisional and replace steps of the selection on a toy whose single fits are not credible.
"""

import math

import numpy as np
import pytest
from generators.draws import N_LINES, N_POSES, draw, run_case
from generators.tx200 import PAIRS, POSE_OFFSETS_DEG, POSE_TAB7_DEG, TX200, Effects, write_frf_set
from robolobes.identify.effects import Parameter
from robolobes.identify.evidence import (WHITENED_TOL, below_threshold, credibility, determined, margin, whitened_margin,
                                         whitened_ratio)
from robolobes.identify.frf import line_noise, pair_noise
from robolobes.identify.selection import Trial, stepwise_select, z_threshold
from scipy.stats import binom, norm

# ------------------------------------------------------------------------------------------------
# the generator against robolobes' model (both ways: neither is the reference of the other)


def test_generator_matches_robolobes_model():
    from robolobes.cases import load_case
    from robolobes.linearize import build_model, linearize
    from robolobes.linearize.extra_elements import (
        JointCorrection,
        MountCompliance,
        PayloadMass,
        ServoDrive,
    )
    from robolobes.linearize.tool import TcpOscillator

    case = load_case("tx200-aluminium")
    f = np.linspace(2.0, 300.0, 300)
    w = 2 * math.pi * f
    pairs = [(Effects(), ()),
             (Effects(tool_modes=((220.0, 0.03, 3.8e5, (0.6, 0.8, 0.0)),)), (TcpOscillator.one_axis(220.0, 0.03, 3.8e5, (0.6, 0.8, 0.0)),)),
             (Effects(joint_scale={3: (0.75, 0.6)}), (JointCorrection(3, 0.75, 0.6),)),
             (Effects(servo=(2, 50.0, 4e6, 2e3)), (ServoDrive(2, 50.0, 4e6, 2e3),)),
             (Effects(payload_factor=1.2), (PayloadMass(0.2 * 44.4),)),
             (Effects(base_z=(1.6e8, 4e4)), (MountCompliance(kz_n_per_m=1.6e8, cz_n_s_per_m=4e4),)),
             (Effects(base_rock=(6e7, 8e7, 3e3, 5e3)),
              (MountCompliance(krx_n_m_per_rad=6e7, kry_n_m_per_rad=8e7, crx_n_m_s_per_rad=3e3, cry_n_m_s_per_rad=5e3),))]
    for eff, els in pairs:
        gen, own = TX200(eff), build_model(case.robot, "basic", extra_elements=els)
        for k in range(len(POSE_OFFSETS_DEG)):
            q = POSE_TAB7_DEG + POSE_OFFSETS_DEG[k]
            Hg, Hr = gen.frf(q, f), linearize(own, np.radians(q)).frf(w).H
            assert np.abs(Hg - Hr).max() <= 1e-9 * np.abs(Hr).max(), (eff, k)


# ------------------------------------------------------------------------------------------------
# the stepwise selection on a toy linear problem (its trial is independent of any pipeline)


class _Toy:
    """y = sum of basis vectors + N(0, s^2); an effect adds one basis vector to a joint linear fit;
    two folds (even / odd samples), held-out residuals concatenated."""

    def __init__(self, basis: dict, y: np.ndarray, s: float):
        self.basis, self.y, self.s = basis, y, s
        n = len(y)
        self.folds = [np.arange(n) % 2 == 0, np.arange(n) % 2 == 1]

    def __call__(self, state, effect):
        names = list(state or []) + ([effect] if effect is not None else [])
        res = np.empty_like(self.y)
        for test in self.folds:
            train = ~test
            if names:
                X = np.column_stack([self.basis[k] for k in names])
                c, *_ = np.linalg.lstsq(X[train], self.y[train], rcond=None)
                res[test] = X[test] @ c - self.y[test]
            else:
                res[test] = -self.y[test]
        return Trial(residual=res, measured=self.y, sigma=np.full(len(self.y), self.s), state=names,
                     params={"n": float(len(names))})


class _Name(str):
    @property
    def name(self):
        return str(self)

    repeatable = False
    parameters = ()


def test_stepwise_drops_an_effect_the_later_ones_make_redundant():
    rng = np.random.default_rng(0)
    n, s = 4000, 0.05
    t = np.linspace(0, 1, n)
    a, b, d = np.sin(7 * t), np.cos(13 * t), np.sin(29 * t + 0.3)
    y = a + b + s * rng.standard_normal(n)
    # C = a + b + d: the best single effect, redundant (and wrong) once A and B are in
    toy = _Toy({"A": a, "B": b, "C": a + b + 0.5 * d}, y, s)
    cands = [_Name("A"), _Name("B"), _Name("C")]
    sel = stepwise_select([], cands, toy, alpha=0.01, max_effects=3, drop=lambda st, k: st[:k] + st[k + 1:])
    assert sel.steps[0].kept == "C"
    assert [st.action for st in sel.steps].count("drop") == 1 and any(st.removed == "C" for st in sel.steps)
    assert sorted(sel.state) == ["A", "B"]
    assert [e.name for e in sel.effects] == [x for x in sel.state]
    # the threshold is Bonferroni over 2 max_effects x L forward tests
    assert sel.threshold == pytest.approx(z_threshold(0.01, 2 * 3 * 3)) == pytest.approx(norm.isf(0.01 / 18))


def test_stepwise_provisional_and_replace_steps():
    # y = a + b; C has A's signature. Every single-effect fit is "not credible" (as a servo whose
    # rotor damping goes to its bound when it stands in for two axes); A is not credible at the final
    # joint fit (as a servo whose rotor frequency ends on its bound: a joint correction in disguise).
    rng = np.random.default_rng(2)
    n, s = 4000, 0.05
    t = np.linspace(0, 1, n)
    a, b = np.sin(7 * t), np.cos(13 * t)
    toy = _Toy({"A": a, "B": b, "C": a.copy()}, a + b + s * rng.standard_normal(n), s)

    def accept(effect, trial):
        ok = trial.params["n"] > 1 and not (effect == "A" and trial.params.get("final"))
        return ok, "" if ok else "not credible: on a bound"

    sel = stepwise_select([], [_Name("A"), _Name("B"), _Name("C")], toy, alpha=0.01, max_effects=3,
                          drop=lambda st, k: st[:k] + st[k + 1:], accept=accept,
                          params_of=lambda st, k: {"n": float(len(st)), "final": True})
    assert sel.steps[0].kept and sel.steps[0].provisional       # entered to be refitted with the next
    assert sel.steps[1].kept and not sel.steps[1].provisional
    assert sel.steps[-1].action == "replace" and sel.steps[-1].removed == "A" and sel.steps[-1].kept == "C"
    assert sorted(sel.state) == ["B", "C"] and [e.name for e in sel.effects] == list(sel.state)
    # without a backward step (forward only) nothing can enter provisionally: nothing is found
    fwd = stepwise_select([], [_Name("A"), _Name("B"), _Name("C")], toy, alpha=0.01, max_effects=3, accept=accept)
    assert fwd.effects == ()


def test_stepwise_family_wise_false_positive_rate():
    rng = np.random.default_rng(1)
    n, s, L, runs, alpha = 400, 1.0, 8, 300, 0.2
    t = np.linspace(0, 1, n)
    basis = {f"c{k}": np.sin((k + 1) * 3.1 * t + k) for k in range(L)}
    hits = 0
    for _ in range(runs):
        toy = _Toy(basis, s * rng.standard_normal(n), s)
        sel = stepwise_select([], [_Name(k) for k in basis], toy, alpha=alpha, max_effects=3,
                              drop=lambda st, k: st[:k] + st[k + 1:])
        hits += bool(sel.effects)
    assert hits <= binom.ppf(0.999, runs, alpha), hits


# ------------------------------------------------------------------------------------------------
# credible, below threshold, determined


def test_credibility_bounds_and_physical_range():
    class E:
        parameters = (Parameter("freq_hz", 20.0, 3000.0, log=True),
                      Parameter("damping_ratio", 0.003, 0.3, log=True, plausible=(0.003, 0.15)),
                      Parameter("kte_n_per_m", 0.0, 1e5, neutral=0.0, detect=5e3),
                      Parameter("phase_rad", -math.pi, math.pi, periodic=True))

    ok, why = credibility(E, {"freq_hz": 200.0, "damping_ratio": 0.03, "kte_n_per_m": 0.0, "phase_rad": math.pi})
    assert ok, why            # neutral bound and a periodic end are not failures
    ok, why = credibility(E, {"freq_hz": 3000.0, "damping_ratio": 0.03, "kte_n_per_m": 1e4, "phase_rad": 0.0})
    assert not ok and "upper bound 3000" in why[0]
    ok, why = credibility(E, {"freq_hz": 200.0, "damping_ratio": 0.25, "kte_n_per_m": 1e4, "phase_rad": 0.0})
    assert not ok and "physical range" in why[0]
    assert below_threshold(E, {"kte_n_per_m": 4.9e3}) and not below_threshold(E, {"kte_n_per_m": 5.1e3})


def test_a_parameter_without_neutral_is_below_threshold_beyond_its_resolved_limit():
    # detect of a parameter without a neutral value is the largest value the data resolve (a mount
    # stiffer than the band shows): a fit beyond it is not kept; the data's own limit, when a pipeline
    # gives one, replaces the declared one. Accept says why in words.
    from types import SimpleNamespace

    from robolobes.identify.evidence import accept

    class E:
        parameters = (Parameter("stiffness_n_per_m", 1e6, 1e10, None, 3.7e9, log=True),
                      Parameter("damping_ratio", 0.003, 0.5, log=True))

    assert below_threshold(E, {"stiffness_n_per_m": 4e9, "damping_ratio": 0.05})
    assert not below_threshold(E, {"stiffness_n_per_m": 3e9, "damping_ratio": 0.05})
    assert not below_threshold(E, {"stiffness_n_per_m": 4e9, "damping_ratio": 0.05}, {"stiffness_n_per_m": 5e9})
    beyond = SimpleNamespace(params={"stiffness_n_per_m": 4e9, "damping_ratio": 0.05}, evidence={})
    ok, why = accept(E, beyond)
    assert not ok and "below its own detection threshold" in why and "3.7e+09" in why
    assert accept(E, SimpleNamespace(params=beyond.params, evidence={"detect": {"stiffness_n_per_m": 5e9}}))[0]


def test_mount_z_detect_limit_is_the_mass_on_the_mount_times_the_band_squared():
    # M (2 pi f_max)^2 (MountZEffect doc): the mount's mode inside the measured band. 1045 kg and lines
    # up to 300 Hz: 3.713e9 N/m, the declared 3.7e9; a 500 kg robot measured to 150 Hz: 4.44e8. The
    # closed form typed here; rounding only: rtol 1e-12.
    from types import SimpleNamespace

    from robolobes.identify.effects import REGISTRY, effects_for

    from robolobes.identify.structural import MountZEffect

    effects_for("frf")
    mount = REGISTRY["mount_z"]
    assert isinstance(mount, MountZEffect)
    for mass, f_max, want in ((1045.0, 300.0, 1045.0 * (2 * math.pi * 300.0) ** 2),
                              (500.0, 150.0, 500.0 * (2 * math.pi * 150.0) ** 2)):
        poses = [SimpleNamespace(pm=SimpleNamespace(mount_mass_kg=mass), omega=2 * math.pi * np.linspace(2.0, f, 50))
                 for f in (f_max / 2, f_max)]
        got = mount.detect_limits(poses)["stiffness_n_per_m"]
        assert got == pytest.approx(want, rel=1e-12)
    assert 1045.0 * (2 * math.pi * 300.0) ** 2 == pytest.approx(3.7e9, rel=0.01)


def test_determined_reports_the_combination_only():
    pa = Parameter("a_m", -3e-5, 3e-5, neutral=0.0, detect=1.5e-6)
    pb = Parameter("b_m", -3e-5, 3e-5, neutral=0.0, detect=1.5e-6)
    # only a - b is seen: sd 0.1 detect along (1, -1), 100 detect along (1, 1)
    v = np.array([[1, -1], [1, 1]]) / math.sqrt(2)
    cov = (v.T @ np.diag([0.1, 100.0]) ** 2 @ v) * 1.5e-6 ** 2
    got = determined([("a_m", pa), ("b_m", pb)], [0.0, 0.0], cov)
    assert got["parameters"] == {"a_m": False, "b_m": False}
    best = got["combinations"][0]
    assert best["determined"] and abs(best["terms"]["a_m"] + best["terms"]["b_m"]) < 1e-6
    assert best["sd_units"] == pytest.approx(0.1) and not got["combinations"][1]["determined"]


def _false_alarms(sigma: np.ndarray, runs: int, alpha: float, rng: np.random.Generator) -> int:
    """Runs (of ``runs``) in which a model equal to the truth is called unexplained at ``alpha``, tolerance 0:
    the FRF verdict's statistic sqrt(sum |r|^2 / sum sigma^2), r = sigma * complex unit normal, against margin()."""
    m = margin(len(sigma), alpha, True, 0.0)
    alarms = 0
    for _ in range(runs):
        r = sigma * (rng.standard_normal(len(sigma)) + 1j * rng.standard_normal(len(sigma))) / math.sqrt(2)
        alarms += math.sqrt(np.sum(np.abs(r) ** 2) / np.sum(sigma ** 2)) > m
    return alarms


def test_unexplained_margin_false_alarm_rate():
    rng = np.random.default_rng(2)
    n, runs, alpha = 2000, 400, 0.05
    m = margin(n, alpha, True, 0.0)
    sigma = rng.uniform(0.5, 2.0, n)
    assert _false_alarms(sigma, runs, alpha, rng) <= binom.ppf(0.999, runs, alpha)
    assert margin(n, alpha, True, 0.2) == pytest.approx(m / 0.8)


def _resonant_sigma(n_lines: int = 400) -> np.ndarray:
    """Noise of 2 % of |H| on 6 FRFs of three modes (closed form typed here, not the code's model):
    H(f) = sum_k 1 / (k_k (1 - (f/f_k)^2 + 2 i zeta_k f / f_k)), modes 12, 31, 95 Hz, zeta 0.03, 0.02,
    0.05, stiffness 1e6, 3e6, 8e6 N/m; 2-300 Hz. As on a robot, a few lines near the poles carry most of
    sum sigma^2: the effective count (sum s^2)^2 / sum s^4 is 36 of the 2400 lines (43-45 of 9600 on
    the TX200 sets of tests/generators/draws.py)."""
    f = np.linspace(2.0, 300.0, n_lines)
    out = []
    for shift in (0.96, 0.98, 1.0, 1.02, 1.04, 1.06):   # six poses: the poles move a little
        H = sum(1.0 / (k * (1 - (f / (fk * shift)) ** 2 + 2j * z * f / (fk * shift)))
                for fk, z, k in ((12.0, 0.03, 1e6), (31.0, 0.02, 3e6), (95.0, 0.05, 8e6)))
        out.append(0.02 * np.abs(H))
    return np.concatenate(out)


def test_unexplained_margin_false_alarm_rate_on_a_resonant_noise_profile():
    """The error-over-floor ratio against margin() (chi-square with 2 N degrees of freedom) is wrong
    when a few lines carry most of the noise: on this profile a model equal to the truth is called
    unexplained in 153 of 400 runs at alpha 0.05 (tolerance 0). So the FRF verdict uses the whitened
    ratio (next test); the force verdict keeps margin(), its bins having equal noise."""
    runs, alpha = 400, 0.05
    alarms = _false_alarms(_resonant_sigma(), runs, alpha, np.random.default_rng(3))
    # an honest rule allows at most the binomial 99.9 % bound (35); the flawed one is far above it
    assert alarms > 3 * binom.ppf(0.999, runs, alpha), (alarms, runs)


def test_whitened_verdict_false_alarm_rate_on_a_resonant_noise_profile():
    # W = sqrt(mean |r / sigma|^2) of pure noise is sqrt(chi2(2 N) / 2 N) whatever the profile; the margin
    # from 200 null draws (normal approximation), tolerance 0, at alpha 0.05: at most the binomial 99.9 %
    # bound of 400 runs (35) may exceed it
    sigma = _resonant_sigma()
    rng = np.random.default_rng(4)
    cn = lambda: (rng.standard_normal(len(sigma)) + 1j * rng.standard_normal(len(sigma))) / math.sqrt(2)
    null = np.array([whitened_ratio(sigma * cn(), sigma) for _ in range(200)])
    m = whitened_margin(null, 0.05, tol=0.0)
    runs = 400
    alarms = sum(whitened_ratio(sigma * cn(), sigma) > m for _ in range(runs))
    assert alarms <= binom.ppf(0.999, runs, 0.05), (alarms, runs)
    # and it sees a 5 % misfit of every line that error / floor, dominated by the poles, would not weigh
    assert whitened_ratio(sigma * cn() + 0.05 * sigma / 0.02, sigma) > m


def test_whitened_estimator_accuracy_on_fresh_generator_sets(tmp_path):
    """WHITENED_TOL (3 %) was set from 42 noise-only sets of the independent generator (seeds 100-111,
    200-229). On 8 other seeds: W of a model equal to the truth, with the pipeline's noise estimator
    (line_noise of the residual), at most WHITENED_TOL above the mean of 40 draws of pure noise through
    the same estimator (written out here, not identify's own loop)."""
    f = np.linspace(2.0, 300.0, 400)
    for seed in range(300, 308):
        rel = np.random.default_rng(seed).uniform(0.01, 0.03)
        tr = write_frf_set(tmp_path / f"s{seed}", Effects(), n_poses=6, f_hz=f, rel_noise=rel, seed=seed)
        H = [h for hm in tr["H_meas"] for h in hm]
        r = [h - t for hm, ht in zip(tr["H_meas"], tr["H_true"]) for h, t in zip(hm, ht)]
        s = [line_noise(h, x) for h, x in zip(H, r)]
        w = whitened_ratio(np.concatenate(r), np.concatenate(s))
        g = np.random.default_rng(0)
        null = []
        for _ in range(40):
            rr = [x * (g.standard_normal(x.size) + 1j * g.standard_normal(x.size)) / math.sqrt(2) for x in s]
            null.append(whitened_ratio(np.concatenate(rr), np.concatenate([line_noise(h, x) for h, x in zip(H, rr)])))
        assert w <= np.mean(null) * (1 + WHITENED_TOL), (seed, w, np.mean(null))


# ------------------------------------------------------------------------------------------------
# through the command line, on sets from the independent generator


def test_null_set_from_the_generator_is_clean(tmp_path):
    r = run_case("null", 1, tmp_path)
    assert r["right"], r
    assert r["floor_ok"], (r["noise_floor"], r["noise_error"])


def _floor_over_true(case: str, seed: int, tmp, estimate) -> float:
    """The noise floor over the generating model's noise error on draw ``seed`` of ``case``, with the
    residual of a model that identified nothing: the generator with no effect (equal to robolobes' own
    model to 1e-9, the first test) minus the measured set; ``estimate(H, r)`` gives each pair's noise."""
    effects, _, noise = draw(case, seed)
    f = np.linspace(2.0, 300.0, N_LINES)
    t = write_frf_set(tmp / f"{case}_{seed}", effects, n_poses=N_POSES, f_hz=f, rel_noise=noise, seed=seed)
    base, sig, H = TX200(Effects()), [], []
    for k, hm in enumerate(t["H_meas"]):
        h0 = base.frf(POSE_TAB7_DEG + POSE_OFFSETS_DEG[k], f)
        for (o, i), h in zip(PAIRS, hm):
            sig.append(estimate(h, h0[o, i] - h))
            H.append(h)
    floor = math.sqrt(np.mean(np.concatenate(sig) ** 2) / np.mean(np.abs(np.concatenate(H)) ** 2))
    return floor / t["noise_error"]


def test_noise_floor_within_20_percent_with_an_unexplained_residual(tmp_path):
    """The floor's estimator (identify.frf.pair_noise, one relative-plus-additive noise model per pair)
    was chosen on noise-only sets (seeds 100-111) and on seeds 6-10 of arm_bend, base_z and highpass;
    here it is checked on seeds 1-5 of each and on nulls 1-5: within the required 20 % of the generating
    model's noise error in every set. The running median over 41 lines (the verdict's line_noise) gave
    1.39 and 1.52 on arm_bend seeds 2 and 3: the residual of the shifted robot poles (13-17 and 23-29 Hz)
    fills 13-21 of the 41 lines of the windows there."""
    got = {(c, s): _floor_over_true(c, s, tmp_path, pair_noise)
           for c in ("arm_bend", "base_z", "highpass", "null") for s in range(1, 6)}
    assert all(abs(v - 1) <= 0.2 for v in got.values()), {k: round(v, 3) for k, v in got.items()}
    # the sets are hard for the local estimator (it can fail here): arm_bend seeds 2 and 3 miss by > 20 %
    (tmp_path / "local").mkdir()
    assert all(_floor_over_true("arm_bend", s, tmp_path / "local", line_noise) > 1.2 for s in (2, 3))


@pytest.mark.slow
@pytest.mark.long
@pytest.mark.parametrize("case", ["joint+servo", "sensor_gain", "base_z", "base_z+joint", "base_rock", "base_rock+joint",
                                  "highpass", "arm_bend",
                                  "mode_xy+payload", "mode_xy+joint", "load_k", "load_k+payload"])
def test_draws_right_in_at_least_4_of_5(tmp_path, case, draw_plan):
    # the tool-mode cases take 30-100 s of CPU per draw (bench/bench_identify_answers.py runs the same
    # rule); --draws N: the first N seeds, ceil(4 N / 5) of N right (tests/draw_counts.py)
    plan = draw_plan(range(1, 6), 4)
    got = [run_case(case, seed, tmp_path) for seed in plan.seeds]
    right = sum(r["right"] for r in got)
    assert right >= plan.need, (plan.describe("4 of 5"), [(r["seed"], r["why"]) for r in got])
    floors = [round(r["floor_ratio"], 3) for r in got]
    floor_ok = sum(r["floor_ok"] for r in got) >= plan.need
    if not floor_ok and case in FLOOR_KNOWN_OFF:  # reported as an expected failure, never as a pass
        pytest.xfail(f"{case}: noise floor / true noise error {floors}: {FLOOR_KNOWN_OFF[case]}")
    assert floor_ok, floors


# draw sets whose noise floor is known to miss 20 % of the true noise error, with the reason
# (measured, in docs/guide/identify-answers.md): their answers are still asserted; a floor that misses
# is reported as xfail with its numbers, a floor that holds passes
FLOOR_KNOWN_OFF: dict[str, str] = {}
# (arm_bend was here with floor / true 1.04-1.50, 3 of 5 within 20 %, until the floor's estimator became
# identify.frf.pair_noise: 1.083, 1.058, 1.041, 0.909, 0.933 on seeds 1-5 through the pipeline)


@pytest.mark.slow
@pytest.mark.long
def test_nulls_clean_in_at_least_19_of_20(tmp_path, draw_plan):
    plan = draw_plan(range(1, 21), 19)
    got = [run_case("null", seed, tmp_path) for seed in plan.seeds]
    assert sum(r["right"] for r in got) >= plan.need, (plan.describe("19 of 20"),
                                                       [(r["seed"], r["why"]) for r in got if not r["right"]])
    assert all(r["floor_ok"] for r in got), [r["floor_ratio"] for r in got]


def test_joint_and_servo_share_the_static_stiffness_scale():
    # a servo (kp = 3 k) and a joint correction x0.75 of the same axis: the shared quantity is the
    # static stiffness scale kp / (k + kp) = 0.75, reported with the alternative's own value
    from robolobes.identify.effects import REGISTRY, effects_for
    from robolobes.identify.frf import _shared

    effects_for("frf")
    servo = REGISTRY["servo_a3"]
    params = {"kp_scale": 3.0, "rotor_freq_hz": 3000.0, "rotor_damping_ratio": 0.005}
    alt = [{"name": "joint_correction_a3", "params": {"stiffness_scale": 0.75, "damping_scale": 1.0}}]
    got = _shared(servo, params, np.diag([0.01 ** 2, 1.0, 1.0]), alt)
    assert got[0]["value"] == pytest.approx(0.75)
    assert got[0]["sd"] == pytest.approx(3.0 / 16.0 * 0.01)            # d(kp/(1+kp))/d ln kp = kp/(1+kp)^2
    assert got[0]["indistinguishable_from"] == [{"name": "joint_correction_a3", "value": 0.75}]
    assert _shared(servo, params, np.eye(3), [{"name": "joint_correction_a2", "params": {"stiffness_scale": 0.7}}]) == []
