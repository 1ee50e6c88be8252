"""The force pipeline's forward-backward search with joint refits (identify/forces.py, ``_select_forces``),
on a cheap fake model (no simulation): the model's synchronous average is a waveform plus a linear
combination of fixed templates, one per fake effect, so the real fitting, joint refit, selection and
backward step run in milliseconds.

Effect A's template is close to B + C (plus a component D that the data do not hold); the data hold
B + 0.6 C. A alone explains most of it and enters first; B, then C enter, refitted jointly with A;
with B and C in, A no longer explains anything (its joint value goes to 0) and the backward step
removes it. A forward-only search with frozen values keeps A and leaves B, C off their true values.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from robolobes.identify.cutting_effects import ForceEffect
from robolobes.identify.effects import ModelState, Parameter
from robolobes.identify.force_signals import SyncAverage, apply_transfer
from robolobes.identify.forces import _ForceSearch, _Joint, _select_forces

BINS = 64
NOISE = 0.02   # N, standard error of each bin of either average
TRUE = {"B": 1.0, "C": 0.6}


def _template(rng) -> np.ndarray:
    """A smooth periodic (BINS, 3) waveform: harmonics 2 to 8 with random coefficients."""
    th = 2 * np.pi * np.arange(BINS) / BINS
    out = np.zeros((BINS, 3))
    for ax in range(2):
        for k in range(2, 9):
            out[:, ax] += rng.normal() * np.cos(k * th) + rng.normal() * np.sin(k * th)
    return out / np.sqrt(np.mean(out[:, :2] ** 2))


RNG = np.random.default_rng(7)
G0 = _template(RNG) * 40.0 + np.array([30.0, -20.0, 0.0])   # the starting model's cutting forces
G = {k: _template(RNG) for k in "BCD"}
G["A"] = (G["B"] + G["C"] + 0.5 * G["D"]) / np.sqrt(2.25)


class _Fake(ForceEffect):
    """One template with one coefficient (added to the state as an override ``("fake", name, value)``)."""

    stage = "cutting_law"
    observed_by = {"forces": "fake"}
    signatures = ("mean_offset",)

    def __init__(self, name: str):
        self.name = name
        self.parameters = (Parameter(f"{name.lower()}_n", -3.0, 3.0, neutral=0.0, detect=0.05),)

    def apply_values(self, state, values):
        return state.with_override("fake", self.name, float(values[0]), state.case)


class _Ctx:
    """What the force fit reads of a :class:`ForceContext`, with a template model instead of simulation."""

    spindle_hz = 300.0
    bins = BINS

    def __init__(self, seed: int = 0):
        rng = np.random.default_rng(seed)
        truth = G0 + sum(v * G[k] for k, v in TRUE.items())
        sigma = np.full((BINS, 3), NOISE * np.sqrt(20))
        self.train, self.heldout = (SyncAverage(mean=truth + rng.normal(0, NOISE, (BINS, 3)), sigma=sigma, n=20,
                                                t_span_s=(0.0, 1.0)) for _ in range(2))
        self.runs = 0

    def raw_averages(self, state):
        self.runs += 1
        a = G0 + sum(v * G[key] for table, key, v in state.overrides if table == "fake")
        return [a.copy(), a.copy()]

    def filtered(self, avg, h):
        return apply_transfer(avg, self.spindle_hz, h)

    def averages(self, state):
        return self.raw_averages(state)


@pytest.fixture
def setup():
    ctx = _Ctx()
    state = ModelState(case=SimpleNamespace(tool=None))  # type: ignore[arg-type]  (the fakes read no case)
    return ctx, state, [_Fake(k) for k in "ABC"]


def test_a_later_effect_refits_the_earlier_ones(setup):
    """Adding B refits A jointly (A's value moves from its fit alone), and dropping A refits B."""
    ctx, state, (a, b, _) = setup
    tr, ho = ctx.averages(state)
    start = _Joint(state, train=tr, heldout=ho)
    search = _ForceSearch(ctx, state, ctx.heldout.mean[:, :2].ravel(), ctx.heldout.noise[:, :2].ravel(), start)
    with_a = search(start, a).state
    with_ab = search(with_a, b).state
    assert [e.name for e in with_ab.effects] == ["A", "B"]
    va, vab = float(with_a.values[0][0]), float(with_ab.values[0][0])
    # A alone: the projection of B + 0.6 C on A's template; with B in, A only carries the 0.6 C it can
    sd = float(np.sqrt(with_ab.cov[0, 0]))
    assert abs(va - vab) > 5 * sd, (va, vab, sd)
    only_b = search.drop(with_ab, 0)
    assert [e.name for e in only_b.effects] == ["B"]
    assert abs(float(only_b.values[0][0]) - float(with_ab.values[1][0])) > 0.05


def test_backward_step_removes_the_effect_a_later_one_explains(setup):
    ctx, state, library = setup
    sel = _select_forces(ctx, state, library, alpha=0.01, max_effects=3)
    names = [f.name for f in sel.effects]
    assert sorted(names) == ["B", "C"], [(s.action, s.kept, s.removed) for s in sel.steps]
    assert sel.steps[0].kept == "A"
    drops = [s for s in sel.steps if s.action == "drop"]
    assert [s.removed for s in drops] == ["A"]
    assert drops[0].statistic <= sel.threshold
    # the reported values and one sigma are those of the final joint fit of B and C: the truth within 5 sigma
    for f in sel.effects:
        key = f"{f.name.lower()}_n"
        v, sd = f.params[key], f.uncertainty[key]
        assert 0 < sd < 0.01 and abs(v - TRUE[f.name]) < 5 * sd, (f.name, v, sd)
        assert f.evidence["determined"]["parameters"][key]
    assert sel.final.error < 0.5 * sel.steps[0].error_after
