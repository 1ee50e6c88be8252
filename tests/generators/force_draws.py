"""Seeded cutting-force draws from the independent force generator (:mod:`generators.forces`), through
``robolobes identify``, and the rule that says whether an answer is right (stated before any draw ran).

Cases (``CASES``): the aluminium cut's steady window (0.25-0.40 s, 46 revolutions, 180 samples per
revolution), white noise of 2 N on each axis and sample:

* ``null``: no effect;
* ``edge+runout``: edge coefficients Kte, Kre each drawn in 10-100 N/mm (at least twice the detection
  threshold of 5 N/mm) and tooth-radius offsets ``(d/2, -d/2)``, ``|d|`` drawn in 3-30 um, sign drawn
  (the two-tooth tool's forces see only the difference ``r_1 - r_0 = -d``);
* ``dynamometer+edge``: a dynamometer mode ``fn`` drawn in 1-5 kHz (below its 6 kHz detection
  threshold; at 5 kHz it still amplifies the fourth tooth-passing harmonic, 2.49 kHz, by 1 / (1 -
  0.4986^2) = 1.33), damping ratio drawn in 0.01-0.2, and edge coefficients as above.

What "right" means (:func:`judge`):

* every generated effect identified (credible, not a surrogate), each judged quantity within 3 of its
  reported standard deviations of the truth or within a stated tolerance when that is wider: Kte and
  Kre 5 % (the independent generator and robolobes' pass differ by about 0.1 N per bin, a few tenths
  of a per cent of the edge force's share); the tooth-radius difference 1 um (below the 1.5 um
  detection threshold of the runout amplitude); the dynamometer's fn 3 % and zeta 20 % (a damping
  ratio is the least determined parameter of a mode);
* nothing else identified;
* the residual not called unexplained.

A null is right when nothing is identified and the residual is not called unexplained.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from .draws import run_identify
from .forces import ForceEffects, write_force_set

__all__ = ["CASES", "NOISE_N", "draw", "judge", "run_force_case"]

CASES = ("null", "edge+runout", "dynamometer+edge")
NOISE_N = 2.0
TOL = {"kte_n_per_m": 0.05, "kre_n_per_m": 0.05, "fn_hz": 0.03, "zeta": 0.20}
RADIUS_DIFF_TOL_M = 1e-6


def draw(case: str, seed: int) -> tuple[ForceEffects, dict]:
    """``(effects, truth)`` of draw ``seed`` of ``case``."""
    if case not in CASES:
        raise ValueError(f"case {case!r}; valid: {', '.join(CASES)}")
    rng = np.random.default_rng(3000 + seed)
    truth: dict = {}
    kw: dict = {}
    if case == "dynamometer+edge":
        fn, zeta = float(rng.uniform(1000.0, 5000.0)), float(rng.uniform(0.01, 0.2))
        kw["dynamometer"] = (fn, zeta)
        truth["dynamometer"] = {"fn_hz": fn, "zeta": zeta}
    if case != "null":
        kte, kre = float(rng.uniform(1e4, 1e5)), float(rng.uniform(1e4, 1e5))
        kw.update(kte_n_per_m=kte, kre_n_per_m=kre)
        truth["edge_coefficients"] = {"kte_n_per_m": kte, "kre_n_per_m": kre}
    if case == "edge+runout":
        d = float(rng.choice([-1.0, 1.0]) * rng.uniform(3e-6, 3e-5))
        kw["tooth_radius_m"] = (d / 2, -d / 2)
        truth["runout"] = {"radius_difference_m": -d}
    return ForceEffects(**kw), truth


def _near(est: float, sd: float, true: float, rel: float) -> bool:
    return abs(est - true) <= max(3 * sd, rel * abs(true))


def _covered(name: str, true: dict, e: dict) -> str:
    """'' when effect ``e`` (identify JSON) covers ``true``, else why not."""
    if name == "runout":
        shared = e.get("determined", {}).get("shared", [])
        if not shared:
            return "runout without its tooth-radius difference"
        got, sd = float(shared[0]["value"]), float(shared[0]["sd"])
        want = true["radius_difference_m"]
        if abs(got - want) > max(3 * sd, RADIUS_DIFF_TOL_M):
            return f"runout r1 - r0 {got:.3g} +- {sd:.2g} m vs {want:.3g}"
        return ""
    bad = [f"{k} {e['params'][k]:.4g} +- {e['uncertainty'][k]:.2g} vs {v:.4g}" for k, v in true.items()
           if not _near(float(e["params"][k]), float(e["uncertainty"][k]), v, TOL[k])]
    return f"{name}: " + ", ".join(bad) if bad else ""


def judge(truth: dict, res: dict) -> tuple[bool, str]:
    """Whether ``res`` (the identify JSON of a force set) is right for a draw with ``truth`` (module doc)."""
    ident = [e for e in res["effects"] if e["name"] in res["identified"]]
    why = []
    for name, true in truth.items():
        hit = [e for e in ident if e["name"] == name]
        if not hit:
            why.append(f"{name} not identified")
            continue
        w = _covered(name, true, hit[0])
        if w:
            why.append(w)
    extra = [e["name"] for e in ident if e["name"] not in truth]
    if extra:
        why.append(f"also named {extra}")
    if res["unexplained"]["unexplained"]:
        why.append(f"residual unexplained ({res['unexplained']['ratio_to_noise_floor']:.3g}x the noise floor)")
    return (not why), "; ".join(why)


def run_force_case(case: str, seed: int, tmp: Path | None = None) -> dict:
    """Write draw ``seed`` of ``case`` (under ``tmp``, or a temporary directory), identify it through the
    command line, judge it."""
    eff, truth = draw(case, seed)
    with tempfile.TemporaryDirectory() as t:
        d = Path(tmp or t) / f"forces_{case}_{seed}"
        write_force_set(d, eff, noise_n=NOISE_N, seed=seed)
        res, cpu = run_identify(d)
    ok, why = judge(truth, res)
    return {"case": case, "seed": seed, "right": ok, "why": why, "cpu_s": cpu, "identified": res["identified"],
            "truth": truth, "fits": {e["name"]: (e["params"], e["uncertainty"]) for e in res["effects"]},
            "unexplained": res["unexplained"]["unexplained"], "ratio": res["unexplained"]["ratio_to_noise_floor"]}
