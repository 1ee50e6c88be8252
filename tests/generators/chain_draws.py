"""Seeded draws of the measurement chain (issue 20 section 1) from the independent generator, through
``robolobes identify``, and the rule that says whether an answer is right (stated before any draw ran).

Cases (``CASES``), 6 poses x 4 pairs (xx, yy, zz, xy), 400 lines 2-300 Hz, noise drawn in 1-3 %
(as :mod:`generators.draws`):

* ``channel_scale_3``, ``channel_scale_5``, ``channel_scale_12``: one response channel (x, y or z,
  drawn) off by 3 %, 5 % or 12 % (sign drawn): the generator's ``channel_gain``;
* ``daq_delay``: the response 50 us late (``delay_s``);
* ``accelerometer``: a 20 g accelerometer on a 0.2 kg, 200 Hz tool mode along TCP x that the model
  already holds (an ``[[elements]]`` tcp_mode in the case TOML: the mode known from an earlier
  measurement); candidates: the library's defaults and ``accelerometer_mass`` (not a default
  candidate, identify/chain_effects.py);
* each of them ``+joint``: with a joint's stiffness off (axis 1-3, x0.6-0.85 or x1.2-1.6, as
  :mod:`generators.draws`).

What "right" means (:func:`judge`): every generated chain effect is identified (credible, not a
surrogate) with each of its parameters within 3 of its reported standard deviations of the truth, or
within its detection threshold (``detect``: 1 % for a scale, 5 us, 5 g) when that is wider (the 99.7 %
interval per parameter: channel_scale has three, judged together); a generated joint as in
:func:`generators.draws.judge` (static scale within 2 sigma or 3 %); nothing else identified; the
residual not called unexplained.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .draws import N_LINES, N_POSES, _either, chain_covered, judge_axes, run_identify, verdict
from .tx200 import Effects, write_frf_set

__all__ = ["CASES", "draw", "judge", "run_chain_case", "TOOL_MODE"]

_BASE = ("channel_scale_3", "channel_scale_5", "channel_scale_12", "daq_delay", "accelerometer")
CASES = _BASE + tuple(f"{c}+joint" for c in _BASE)
DELAY_S = 50e-6
ACCEL_KG = 0.020
# the tool mode of the accelerometer case: 200 Hz, zeta 0.03, modal mass 0.2 kg, along TCP x
TOOL_MODE = (200.0, 0.03, 0.2 * (2 * np.pi * 200.0) ** 2, (1.0, 0.0, 0.0))


def draw(case: str, seed: int) -> tuple[Effects, dict, float]:
    """``(effects, truth, rel_noise)`` of draw ``seed`` of ``case``."""
    if case not in CASES:
        raise ValueError(f"case {case!r}; valid: {', '.join(CASES)}")
    rng = np.random.default_rng(1000 + seed)
    noise = float(rng.uniform(0.01, 0.03))
    truth: dict = {}
    kw: dict = {}
    base = case.split("+")[0]
    if base.startswith("channel_scale"):
        level = {"channel_scale_3": 0.03, "channel_scale_5": 0.05, "channel_scale_12": 0.12}[base]
        g = [1.0, 1.0, 1.0]
        g[int(rng.integers(0, 3))] = 1.0 + level * (1 if rng.random() < 0.5 else -1)
        kw["channel_gain"] = tuple(g)
        truth["channel_scale"] = {"scale_x": g[0], "scale_y": g[1], "scale_z": g[2]}
    elif base == "daq_delay":
        kw["delay_s"] = DELAY_S
        truth["daq_delay"] = {"delay_s": DELAY_S}
    else:
        kw["accel_mass_kg"], kw["tool_modes"] = ACCEL_KG, (TOOL_MODE,)
        truth["accelerometer_mass"] = {"mass_kg": ACCEL_KG}
    if case.endswith("+joint"):
        j = int(rng.integers(1, 4))
        s = _either(rng, (0.6, 0.85), (1.2, 1.6))
        kw["joint_scale"] = {j: (s, 1.0)}
        truth["axes"] = {j: s}
    return Effects(**kw), truth, noise


def judge(truth: dict, res: dict) -> tuple[bool, str]:
    """Whether ``res`` (the identify JSON) is right for a draw with ``truth`` (module doc), and why not."""
    ident = [e for e in res["effects"] if e["name"] in res["identified"]]
    used, why = set(), []
    for name in ("channel_scale", "daq_delay", "accelerometer_mass"):
        if name not in truth:
            continue
        hit = [e for e in ident if e["name"] == name]
        used |= {id(e) for e in hit}
        bad = chain_covered(name, truth[name], hit)
        if bad:
            why.append(bad)
    used |= judge_axes(truth, ident, why)
    return verdict(ident, used, res, why)


def _model_with_tool_mode(path: Path) -> Path:
    """A case TOML: tx200-aluminium with the accelerometer case's tool mode as an ``[[elements]]`` table."""
    f, zeta, k, d = TOOL_MODE
    from robolobes.cases import load_case
    from robolobes.cases.spec import ElementSpec
    from robolobes.identify.effects import ModelState
    from robolobes.identify.model_toml import model_toml

    state = ModelState(load_case("tx200-aluminium"), case_ref="tx200-aluminium").with_element(
        ElementSpec("tcp_mode", {"freq_hz": f, "damping_ratio": zeta, "stiffness_n_per_m": k, "direction": list(d)}))
    path.write_text(model_toml(state))
    return path


def run_chain_case(case: str, seed: int, tmp: Path) -> dict:
    """Write draw ``seed`` of ``case`` under ``tmp``, identify it through the command line, judge it."""
    effects, truth, noise = draw(case, seed)
    d = Path(tmp) / f"{case}_{seed}"
    write_frf_set(d, effects, n_poses=N_POSES, f_hz=np.linspace(2.0, 300.0, N_LINES), rel_noise=noise, seed=seed)
    args: list = []
    if case.startswith("accelerometer"):
        from robolobes.identify.effects import effects_for
        names = [e.name for e in effects_for("frf")] + ["accelerometer_mass"]
        args = ["--effects", ",".join(names),
                "--case", str(_model_with_tool_mode(Path(tmp) / f"model_{case}_{seed}.toml"))]
    res, cpu = run_identify(d, args)
    ok, why = judge(truth, res)
    return {"case": case, "seed": seed, "right": ok, "why": why, "cpu_s": cpu, "rel_noise": noise,
            "identified": res["identified"], "truth": truth,
            "fits": {e["name"]: (e["params"], e["uncertainty"]) for e in res["effects"]},
            "unexplained": res["unexplained"]["unexplained"], "ratio": res["unexplained"]["ratio_to_noise_floor"]}
